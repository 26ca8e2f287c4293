//! The bench tool's numerics toolbox, one home for each routine identify, diagnose, the
//! recording reader and the generator share:
//!
//! | tool | module |
//! |---|---|
//! | least squares with box bounds (Levenberg-Marquardt) | [`lm`] |
//! | compass search for a cost that is flat at a finite-difference step | [`pattern`] |
//! | unit-box coordinates of a bounded parameter (linear or log) | [`bounds`] |
//! | peak, extremes, span, median, quantile, robust SD, noise level, a tone's least-squares coefficients, trapezoid, interpolation | [`stats`] |
//! | seeded random numbers (ChaCha8) | [`rng`] |
//! | CSV text | [`csv`] |
//!
//! The RK4 step (`tbm_thrust::ode`), the sample-and-hold run loop
//! (`tbm_thrust::simulation::sample_and_hold`) and the L/min factor (`tbm_thrust::units`)
//! live in the model crate, which needs them itself. Parallel maps are rayon's.

pub mod bounds;
pub mod csv;
pub mod lm;
pub mod pattern;
pub mod rng;
pub mod stats;
