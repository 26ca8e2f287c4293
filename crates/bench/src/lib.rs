//! The bench tool's library, on top of the model crate `tbm_thrust`: the recording CSV
//! (reader, checks, closed-loop replay), identification of the model's unknowns, diagnosis of
//! missing physics, bench-like synthetic recordings and the paper's experiments.
//!
//! Data flow: `recording` -> `identify` -> `diagnose`; `synth` writes recordings the others
//! read; `experiments` runs the paper's comparisons on the model.

pub mod diagnose;
pub mod experiments;
pub mod identify;
pub mod numerics;
pub mod progress;
pub mod quality;
pub mod recording;
pub mod synth;
