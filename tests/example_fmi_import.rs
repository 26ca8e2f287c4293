//! Runs examples/fmi_import.rs (so it cannot rot) and checks that the FMU's paper run
//! equals the native `tbm_thrust::run` at every communication point, bit for bit: both
//! end their steps at the grid points k * 0.01 s, and the FMU runs the library's own code.

#[path = "../examples/fmi_import.rs"]
#[allow(dead_code)]
mod example;

use std::path::Path;
use tbm_thrust::{run, Params, Scenario};

type Getter = fn(&example::Sample) -> f64;
const SIGNALS: [(&str, Getter); 6] = [
    ("x", |s| s.x),
    ("v", |s| s.v),
    ("p", |s| s.p),
    ("Q1", |s| s.q1),
    ("Q2", |s| s.q2),
    ("e_x", |s| s.e_x),
];

#[test]
fn example_paper_run_equals_the_native_run() {
    let scenario = Scenario::startup(0.05, 12_000.0);
    let fmu = example::run_paper_case(
        Path::new(tbm_thrust_fmu::FMU_PATH),
        0.05,
        12_000.0,
        scenario.duration,
        scenario.sample_period,
    )
    .expect("the example runs the FMU");
    let native = run(&Params::default(), &scenario);
    assert_eq!(fmu.len(), native.time.len());
    for (name, get) in SIGNALS {
        let expected = native.signal(name).unwrap();
        for ((s, e), t) in fmu.iter().zip(&expected).zip(&native.time) {
            assert_eq!(s.time, *t);
            assert_eq!(
                get(s).to_bits(),
                e.to_bits(),
                "{name} at t = {t}: FMU {} vs native {e}",
                get(s)
            );
        }
    }
    assert!(fmu.last().unwrap().x > 0.0, "the cylinder advanced");
}
