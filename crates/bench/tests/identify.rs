//! Identification recovers the unknowns of a noisy synthetic recording made with the model.

mod common;

use common::{noisy_recording, scenario, truth, TRUTH};
use tbm_bench::identify::pump::{fit_pump, PumpSkipped};
use tbm_bench::identify::{fit, FitError, FitOptions, FitResult, Method};
use tbm_thrust::pump::Pump;
use tbm_thrust::Params;

fn report(label: &str, r: &FitResult) {
    let values: Vec<String> = TRUTH
        .iter()
        .map(|(n, t)| format!("{n} {:.4e} (truth {t:.4e})", r.params.get(n).unwrap()))
        .collect();
    eprintln!(
        "{label}: J {:.4e}, {} simulations: {}",
        r.cost,
        r.simulations,
        values.join(", ")
    );
}

fn relative_error(r: &FitResult, name: &str) -> f64 {
    let t = TRUTH.iter().find(|(n, _)| *n == name).unwrap().1;
    (r.params.get(name).unwrap() - t).abs() / t
}

#[test]
fn default_method_recovers_the_unknowns() {
    let rec = noisy_recording(&truth("single"), &scenario(4.0), 11);
    let r = fit(
        &rec,
        &Params::default(),
        &FitOptions::new(Method::Default, 1),
    )
    .unwrap();
    report("default", &r);
    assert!(relative_error(&r, "beta_e") < 0.05);
    assert!(relative_error(&r, "C_ip") < 0.15);
    assert!(relative_error(&r, "b") < 0.03);
}

#[test]
fn paper_ga_recovers_the_unknowns() {
    let rec = noisy_recording(&truth("single"), &scenario(4.0), 11);
    let r = fit(
        &rec,
        &Params::default(),
        &FitOptions::new(Method::PaperGa, 1),
    )
    .unwrap();
    report("paper-ga", &r);
    // The GA stops on its 1 % stall rule well before the optimum (docs/identify.md): b has
    // ended 0.3-9.9 % off on the recordings there and 15.2 % off here since the plant came to
    // locate the piston's reversals inside a step (the default method on the same recording:
    // within 3 %, above).
    assert!(relative_error(&r, "beta_e") < 0.1);
    assert!(relative_error(&r, "C_ip") < 0.35);
    assert!(relative_error(&r, "b") < 0.2);
}

/// Equal seeds give equal results, whatever the number of threads.
#[test]
fn results_do_not_depend_on_threads() {
    let rec = noisy_recording(&truth("adaptive"), &scenario(1.5), 3);
    for method in [Method::Default, Method::PaperGa] {
        let opts = FitOptions::new(method, 42);
        let on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| fit(&rec, &Params::default(), &opts).unwrap())
        };
        let (one, two) = (on(1), on(2));
        assert_eq!(one.params, two.params, "{method:?}");
        assert_eq!(
            (one.cost, one.simulations, &one.history),
            (two.cost, two.simulations, &two.history)
        );
        assert_eq!(one.pumps, two.pumps);
    }
}

#[test]
fn bad_options_are_refused() {
    let rec = noisy_recording(&truth("single"), &scenario(1.0), 1);
    let base = Params::default();
    let with = |names: &[&str], bounds: &[(f64, f64)]| {
        let opts = FitOptions {
            names: names.iter().map(|n| n.to_string()).collect(),
            bounds: bounds.to_vec(),
            ..FitOptions::new(Method::Default, 1)
        };
        fit(&rec, &base, &opts).unwrap_err()
    };
    assert_eq!(with(&[], &[]), FitError::NoParameters);
    assert_eq!(with(&[], &[]).to_string(), "no parameters to fit");
    let message = |names: &[&str], bounds: &[(f64, f64)]| with(names, bounds).to_string();
    assert!(message(&["beta_e"], &[]).contains("1 parameter names but 0 ranges"));
    assert!(message(&["x"], &[(0.0, 1.0)]).contains("not a real parameter"));
    assert!(message(&["b"], &[(5.0, 1.0)]).contains("is empty"));
    assert!(message(&["beta_e"], &[(1.0, 1e12)]).contains("leaves the allowed"));
    assert_eq!(
        with(&["b", "b"], &[(1.0, 2.0), (1.0, 2.0)]),
        FitError::ListedTwice("b".into())
    );
}

#[test]
fn a_pump_without_its_drive_command_is_skipped_by_name() {
    let rec = noisy_recording(&truth("single"), &scenario(1.0), 1).without_column("uc2");
    let skipped = fit_pump(&rec, &Params::default(), Pump::Aux).unwrap_err();
    assert_eq!(skipped, PumpSkipped::NoDriveCommand { pump: Pump::Aux });
    assert_eq!(
        skipped.to_string(),
        "no `uc2` column: pump 2 checks skipped (a2, b_u2, b_p2 kept as given)"
    );
}

/// The main pump of the bench runs twice as fast as the given one (a1 and b_u1 doubled, the
/// same steady flow per volt): the pump stage (least squares on the integral form, refined on
/// the replayed flow) finds it.
#[test]
fn a_pump_twice_as_fast_as_given_is_recovered_from_its_flow() {
    let mut bench = truth("single");
    bench.set("a1", 4.5).unwrap();
    bench.set("b_u1", 40.0).unwrap();
    let rec = noisy_recording(&bench, &scenario(4.0), 5);
    let fitted = fit_pump(&rec, &Params::default(), Pump::Main).unwrap();
    let value = |name: &str| fitted.values[fitted.names.iter().position(|n| n == name).unwrap()];
    assert!(fitted.accepted, "{}", fitted.summary());
    assert!((value("a1") / 4.5 - 1.0).abs() < 0.03, "a1 {}", value("a1"));
    assert!(
        (value("b_u1") / 40.0 - 1.0).abs() < 0.03,
        "b_u1 {}",
        value("b_u1")
    );
}
