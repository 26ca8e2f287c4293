//! Runs examples/fmi_import.rs (so it cannot rot) and checks the FMU's paper run against
//! the library: bit for bit against a Simulator stepped as the importer steps, and closely
//! against the native `tbm_thrust::run`.

#[path = "../examples/fmi_import.rs"]
#[allow(dead_code)]
mod example;

use std::path::Path;
use tbm_thrust::variables::Inputs;
use tbm_thrust::{run, Params, Scenario, Simulator};

type Getter = fn(&example::Sample) -> f64;
const SIGNALS: [(&str, Getter); 6] =
    [("x", |s| s.x), ("v", |s| s.v), ("p", |s| s.p), ("Q1", |s| s.q1), ("Q2", |s| s.q2), ("e_x", |s| s.e_x)];

#[test]
fn example_paper_run_matches_the_library() {
    let scenario = Scenario::startup(0.05, 12_000.0);
    let h = scenario.sample_period;
    let fmu = example::run_paper_case(Path::new(tbm_thrust_fmu::FMU_PATH), 0.05, 12_000.0, scenario.duration, h)
        .expect("the example runs the FMU");

    // The FMU steps from t_k = k h to t_k + h, as the example asks it to.
    let mut sim = Simulator::new(Params::default(), Inputs { v_ref: 0.05, F_L: 12_000.0 }, 0.0);
    for (k, sample) in fmu.iter().enumerate().skip(1) {
        let t = (k - 1) as f64 * h;
        sim.advance((t + h) - sim.time());
        let o = sim.outputs();
        let same = [o.x, o.v, o.p, o.Q1, o.Q2, o.e_x];
        for ((name, get), expected) in SIGNALS.iter().zip(same) {
            assert_eq!(get(sample).to_bits(), expected.to_bits(), "{name} at t = {}", sample.time);
        }
    }

    // The native run ends its steps at (k + 1) h rather than k h + h: the last-bit
    // differences of the step ends grow through the stick-slip start-up to ~1e-8 relative.
    let native = run(&Params::default(), &scenario);
    assert_eq!(fmu.len(), native.time.len());
    for (name, get) in SIGNALS {
        let expected = native.signal(name).unwrap();
        let scale = expected.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        for (s, e) in fmu.iter().zip(&expected) {
            assert!((get(s) - e).abs() <= 1e-6 * scale, "{name} at t = {}: FMU {} vs native {e}", s.time, get(s));
        }
    }
    assert!(fmu.last().unwrap().x > 0.0, "the cylinder advanced");
}
