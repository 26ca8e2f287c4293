//! `diagnose` on a 30 s, 100 Hz bench recording (the mixed programme, adaptive scheme, one
//! concealed effect so that the second selection round runs too). Target: well under a
//! minute on 2 cores.
use criterion::{criterion_group, criterion_main, Criterion};
use std::time::Duration;
use tbm_bench::diagnose::effect::Effect;
use tbm_bench::diagnose::{diagnose, series::Series};
use tbm_bench::recording::Recording;
use tbm_bench::synth::{generate, BenchScenario, Case};
use tbm_thrust::{Params, Scheme};

fn diagnose_30s(c: &mut Criterion) {
    let case = Case::new(
        BenchScenario::Mixed,
        Scheme::Adaptive,
        vec![Effect::StribeckFriction],
        102,
    );
    let csv = generate(&case).expect("case generates").csv;
    let rec = Recording::parse(&csv, "bench").expect("recording parses");
    let series = Series::from_recording(&rec).expect("uniform grid");
    let base = Params::default();
    let mut group = c.benchmark_group("diagnose");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(60))
        .warm_up_time(Duration::from_secs(1));
    group.bench_function("diagnose_30s_100Hz_mixed_adaptive", |b| {
        b.iter(|| diagnose(&series, &base).expect("runs"))
    });
    group.finish();
}

criterion_group!(benches, diagnose_30s);
criterion_main!(benches);
