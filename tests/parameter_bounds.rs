//! Every real parameter at its declared min and at its max (the others at their defaults),
//! under every scheme and controller, gives finite outputs over a start-up with a speed and
//! a load step: the plant's solver
//! step adapts to the stiffest mode (`plant::stable_substeps`), and no declared bound
//! admits a value the model cannot run.

use tbm_thrust::variables::{Causality, Kind, VARIABLES};
use tbm_thrust::{run, Controller, Params, Profile, Scenario, Scheme};

#[test]
fn every_parameter_at_its_bounds_gives_finite_outputs() {
    let scenario = Scenario {
        v_ref: Profile(vec![(0.0, 0.05), (0.6, 0.02)]),
        load: Profile(vec![(0.0, 12_000.0), (0.8, 8_000.0)]),
        duration: 1.0,
        sample_period: 0.01,
    };
    let mut failures = Vec::new();
    for var in VARIABLES
        .iter()
        .filter(|v| v.causality == Causality::Parameter)
    {
        let Kind::Real { min, max, .. } = var.kind else {
            continue;
        };
        let modes = [Scheme::Single, Scheme::FixedSplit, Scheme::Adaptive]
            .into_iter()
            .flat_map(|s| [Controller::Pid, Controller::Adrc].map(|c| (s, c)));
        let values = [min, max].into_iter().filter(|v| v.is_finite());
        for ((scheme, controller), value) in modes.flat_map(|m| values.clone().map(move |v| (m, v)))
        {
            let mut p = Params {
                scheme,
                controller,
                ..Params::default()
            };
            p.set(var.name, value).expect("a bound is a legal value");
            let trace = run(&p, &scenario);
            let bad = trace
                .outputs
                .iter()
                .zip(&trace.time)
                .find(|(o, _)| o.values().iter().any(|v| !v.is_finite()));
            if let Some((_, t)) = bad {
                failures.push(format!(
                    "{} = {value:e} ({}, {}): non-finite output at {t} s",
                    var.name,
                    scheme.name(),
                    controller.name()
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}
