//! `diagnose`: refit the nominal model, locate the mismatch, name and fit the missing physics.

pub mod effect;
pub mod lm;
pub mod model;
pub mod plausible;
pub mod replay;
pub mod search;
pub mod select;
pub mod series;
pub mod starts;
