//! The 20 s paper run (adaptive, PID, 0.05 m/s, 12 kN) and its single-pump twin.
use criterion::{criterion_group, criterion_main, Criterion};
use tbm_thrust::{run, Params, Scenario, Scheme};

fn paper_run(c: &mut Criterion) {
    let scenario = Scenario::startup(0.05, 12_000.0);
    for scheme in [Scheme::Adaptive, Scheme::Single] {
        let p = Params {
            scheme,
            ..Params::default()
        };
        c.bench_function(&format!("paper_run_20s_{}", scheme.name()), |b| {
            b.iter(|| run(&p, &scenario))
        });
    }
}

criterion_group!(benches, paper_run);
criterion_main!(benches);
