//! `identify` at the paper's GA budget: the GA of section 2.3 (population 25, at most 100
//! generations, so at most 2,500 closed-loop simulations) on a 20 s, 100 Hz recording of the
//! paper's identification run (single pump, PID, 0.05 m/s, 12 kN), and the full budget of
//! 2,500 replays of 20 s evaluated as the GA does, 25 at a time in parallel.
use criterion::{criterion_group, criterion_main, Criterion};
use rayon::prelude::*;
use std::time::Duration;
use tbm_bench::identify::{fit, FitOptions, Method};
use tbm_bench::recording::{replay, Recording};
use tbm_thrust::{run, Params, Scenario};

fn recording() -> (Params, Recording) {
    let mut p = Params::default();
    p.set_item("scheme", "single").unwrap();
    let rec = Recording::from_trace(&run(&p, &Scenario::startup(0.05, 12_000.0)))
        .with_meta("scheme", "single");
    (p, rec)
}

fn identify(c: &mut Criterion) {
    let (p, rec) = recording();
    let mut group = c.benchmark_group("identify");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(60));
    for method in [Method::PaperGa, Method::Default] {
        let opts = FitOptions::new(method, 1);
        let r = fit(&rec, &Params::default(), &opts).unwrap();
        eprintln!(
            "{}: {} closed-loop simulations, J = {:.3e}",
            method.name(),
            r.simulations,
            r.cost
        );
        group.bench_function(format!("fit_20s_{}", method.name()), |b| {
            b.iter(|| fit(&rec, &Params::default(), &opts).unwrap())
        });
    }
    group.bench_function("ga_budget_2500_replays_20s", |b| {
        b.iter(|| {
            for _ in 0..100 {
                let traces: Vec<usize> = (0..25)
                    .into_par_iter()
                    .map(|_| replay(&p, &rec).unwrap().time.len())
                    .collect();
                assert_eq!(traces.len(), 25);
            }
        })
    });
    group.finish();
}

criterion_group!(benches, identify);
criterion_main!(benches);
