//! Shared by the bench tool's integration tests and `examples/identify_recordings.rs`:
//! synthetic bench recordings made with the model itself (known truth).
#![allow(dead_code)]

use tbm_bench::numerics::rng::{seeded, Draw};
use tbm_bench::recording::Recording;
use tbm_thrust::{run, Params, Profile, Scenario};

/// The truth of the identification tests: inside Table 2 and away from the defaults.
pub const TRUTH: [(&str, f64); 3] = [("beta_e", 1.3e9), ("C_ip", 1.5e-12), ("b", 5000.0)];

/// The model's parameters with the truth and the scheme.
pub fn truth(scheme: &str) -> Params {
    let mut p = Params::default();
    p.set_item("scheme", scheme).unwrap();
    for (name, value) in TRUTH {
        p.set(name, value).unwrap();
    }
    p
}

/// A bench-like run of `duration` [s] at 100 Hz: start-up from rest, a speed step up, a
/// load step down and a speed step down (all relative to the duration).
pub fn scenario(duration: f64) -> Scenario {
    Scenario {
        v_ref: Profile(vec![
            (0.0, 0.03),
            (0.4 * duration, 0.05),
            (0.75 * duration, 0.02),
        ]),
        load: Profile(vec![(0.0, 12_000.0), (0.55 * duration, 9_000.0)]),
        duration,
        sample_period: 0.01,
    }
}

/// The recording of `params` on `scenario`, with sensor noise as a bench's: displacement
/// 0.02 mm, velocity 0.1 mm/s, pressure 0.02 MPa, flows 1 % of reading (standard
/// deviations), drawn from a fixed seed.
pub fn noisy_recording(params: &Params, scenario: &Scenario, seed: u64) -> Recording {
    let mut rng = seeded(seed);
    let mut rec =
        Recording::from_trace(&run(params, scenario)).with_meta("scheme", params.scheme.name());
    for (name, absolute, relative) in [
        ("x", 2e-5, 0.0),
        ("v", 1e-4, 0.0),
        ("p", 2e4, 0.0),
        ("Q1", 0.0, 0.01),
        ("Q2", 0.0, 0.01),
    ] {
        let noisy: Vec<f64> = rec
            .column(name)
            .unwrap()
            .iter()
            .map(|&y| y + absolute * rng.normal() + relative * y * rng.normal())
            .collect();
        rec = rec.with_column(name, noisy);
    }
    rec
}
