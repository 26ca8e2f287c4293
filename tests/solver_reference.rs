//! The optimised plant solver against a stored reference: every output of four 20 s runs
//! (adaptive and single PID from rest, ADRC and every effect term on speed and load steps),
//! sampled every 0.5 s, as the solver computed them before its speed-up, regenerated once
//! when zero crossings of the velocity came to be located inside a step
//! (`tests/data/solver_reference.csv`, its header says by how much they moved). They must agree to 1e-12 relative (in practice to
//! the last bit).

use tbm_thrust::variables::{MainCommand, Outputs};
use tbm_thrust::{run, Controller, Params, Profile, Scenario, Scheme};

const REFERENCE: &str = include_str!("data/solver_reference.csv");
const RELATIVE: f64 = 1e-12;

fn steps() -> Scenario {
    Scenario {
        v_ref: Profile(vec![(0.0, 0.03), (4.0, 0.05), (9.0, 0.0), (12.0, 0.04)]),
        load: Profile(vec![(0.0, 12_000.0), (6.0, 9_000.0), (14.0, 15_000.0)]),
        duration: 20.0,
        sample_period: 0.01,
    }
}

/// The parameters the reference was computed with: the defaults of that time. Pinned here so
/// that recalibrating the defaults (main pump, drive dead time, auxiliary pump, main-pump
/// command of the adaptive scheme) does not masquerade as a solver change.
fn reference_params() -> Params {
    Params {
        a1: 3.9622,
        b_u1: 22.431,
        t_d1: 0.0,
        K_pos: 21.074,
        b0_1: 9.9056,
        a2: 12.5,
        main_command: MainCommand::Target,
        ..Params::default()
    }
}

fn case(name: &str) -> (Params, Scenario) {
    let base = reference_params();
    let startup = Scenario::startup(0.05, 12_000.0);
    match name {
        "adaptive_pid" => (base, startup),
        "single_pid" => (
            Params {
                scheme: Scheme::Single,
                ..base
            },
            startup,
        ),
        "adaptive_adrc" => (
            Params {
                controller: Controller::Adrc,
                ..base
            },
            steps(),
        ),
        "effects" => (
            Params {
                F_s: 800.0,
                mu: 0.02,
                k_load: 1e4,
                air_fraction: 0.01,
                delay1: 0.02,
                rate_limit2: 0.05,
                ripple_amp1: 0.02,
                ripple_freq1: 7.0,
                p_crack: 5e6,
                ..base
            },
            steps(),
        ),
        other => panic!("unknown case {other}"),
    }
}

#[test]
fn every_output_matches_the_stored_reference() {
    let mut rows = REFERENCE.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = rows.next().expect("header").split(',').collect();
    // Each reference column's position among the outputs (outputs added later are not in it).
    let columns: Vec<usize> = header[2..]
        .iter()
        .map(|n| {
            Outputs::NAMES
                .iter()
                .position(|o| o == n)
                .expect("an output")
        })
        .collect();
    let mut traces = std::collections::BTreeMap::new();
    let (mut compared, mut worst) = (0, 0.0f64);
    for row in rows {
        let cells: Vec<&str> = row.split(',').collect();
        let trace = traces.entry(cells[0]).or_insert_with(|| {
            let (p, scenario) = case(cells[0]);
            run(&p, &scenario)
        });
        let t: f64 = cells[1].parse().unwrap();
        let k = trace
            .time
            .iter()
            .position(|&s| s == t)
            .expect("sample time");
        let values = trace.outputs[k].values();
        for ((name, cell), &j) in header[2..].iter().zip(&cells[2..]).zip(&columns) {
            let (want, got): (f64, f64) = (cell.parse().unwrap(), values[j]);
            let error = (got - want).abs();
            assert!(
                error <= RELATIVE * want.abs(),
                "{} at {t} s: {name} = {got:e}, reference {want:e}",
                cells[0]
            );
            worst = worst.max(error / want.abs().max(f64::MIN_POSITIVE));
            compared += 1;
        }
    }
    assert_eq!(compared, 4 * 41 * columns.len());
    eprintln!("{compared} values, largest relative difference {worst:e}");
}
