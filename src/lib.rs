//! TBM thrust cylinder driven by a main and an auxiliary pump (Yang et al., Actuators 2026,
//! 15, 63): the plant of Eq. (12), the dual-pump controllers of section 3, the FMI 2.0
//! co-simulation interface. This crate is what the FMU carries: nothing for fitting, plotting,
//! progress bars or threads (those live in `crates/bench` and `crates/cli`).
//!
//! Data flow: `variables` (generated from modelDescription/variables.toml) -> `params` ->
//! physics (`cylinder`, `chamber`, `pump`, `plant`) + `control` -> `simulation` -> `metrics`.

pub mod chamber;
pub mod control;
pub mod cylinder;
pub mod fmi;
pub mod fmu_model;
pub mod metrics;
pub mod ode;
pub mod params;
pub mod plant;
pub mod pump;
pub mod simulation;
pub mod units;
pub mod variables;

pub use simulation::{run, Profile, Scenario, Simulator, Trace};
pub use variables::{Controller, Params, Scheme};
