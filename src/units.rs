//! Unit factors used across the workspace (the model works in SI throughout).

/// L/min per m^3/s: the bench's flow unit, in which the paper's flow-loop gains are read
/// (ARCHITECTURE.md, "Units of the paper's gains") and flows are plotted.
pub const LPM: f64 = 6e4;
