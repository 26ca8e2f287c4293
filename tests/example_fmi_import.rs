//! Runs examples/fmi_import.rs (so it cannot rot) and checks that the FMU's paper run
//! matches the native simulation at every communication point.

#[path = "../examples/fmi_import.rs"]
#[allow(dead_code)]
mod example;

use std::path::Path;
use tbm_thrust::{run, Params, Scenario};

#[test]
fn example_paper_run_matches_the_native_simulation() {
    let scenario = Scenario::startup(0.05, 12_000.0);
    let fmu = example::run_paper_case(Path::new(tbm_thrust_fmu::FMU_PATH), 0.05, 12_000.0, scenario.duration, scenario.sample_period)
        .expect("the example runs the FMU");
    let native = run(&Params::default(), &scenario);
    assert_eq!(fmu.len(), native.time.len());
    let signals: [(&str, fn(&example::Sample) -> f64); 6] =
        [("x", |s| s.x), ("v", |s| s.v), ("p", |s| s.p), ("Q1", |s| s.q1), ("Q2", |s| s.q2), ("e_x", |s| s.e_x)];
    for (name, get) in signals {
        let expected = native.signal(name).unwrap();
        let scale = expected.iter().fold(0.0_f64, |m, v| m.max(v.abs())).max(f64::MIN_POSITIVE);
        for (k, (s, e)) in fmu.iter().zip(&expected).enumerate() {
            assert!((s.time - native.time[k]).abs() < 1e-9);
            let tol = 1e-9 * e.abs().max(scale);
            assert!((get(s) - e).abs() <= tol, "{name} at t = {}: FMU {} vs native {e}", s.time, get(s));
        }
    }
    assert!(fmu.last().unwrap().x > 0.0, "the cylinder advanced");
}
