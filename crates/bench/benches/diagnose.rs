//! `diagnose` on a 30 s bench recording (the mixed programme, adaptive scheme, one concealed
//! effect so that the second selection round runs too), at 100 Hz on the default bench and at
//! 1 kHz on a bench drawn from the generator's ranges. Targets on 2 cores: 10 s at 100 Hz,
//! 60 s at 1 kHz.
use criterion::{criterion_group, criterion_main, Criterion};
use std::time::Duration;
use tbm_bench::diagnose::effect::Effect;
use tbm_bench::diagnose::{diagnose, series::Series};
use tbm_bench::numerics::rng::seeded;
use tbm_bench::recording::Recording;
use tbm_bench::synth::{generate, BenchScenario, Case, Variation, SAMPLE_PERIOD};
use tbm_thrust::{Params, Scheme};

/// The 30 s recording of the benchmarks, logged every `sample_period` seconds, on
/// `variation`'s bench or the default one.
fn recording(sample_period: f64, variation: Option<Variation>) -> Series {
    let case = Case {
        sample_period,
        variation,
        ..Case::new(
            BenchScenario::Mixed,
            Scheme::Adaptive,
            vec![Effect::StribeckFriction],
            102,
        )
    };
    let csv = generate(&case).expect("case generates").csv;
    let rec = Recording::parse(&csv, "bench").expect("recording parses");
    Series::from_recording(&rec).expect("uniform grid")
}

fn diagnose_30s(c: &mut Criterion) {
    let (_, drawn) = Variation::draw(&mut seeded(102));
    let base = Params::default();
    let mut group = c.benchmark_group("diagnose");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(60))
        .warm_up_time(Duration::from_secs(1));
    for (name, series) in [
        (
            "diagnose_30s_100Hz_mixed_adaptive",
            recording(SAMPLE_PERIOD, None),
        ),
        (
            "diagnose_30s_1kHz_mixed_adaptive",
            recording(1e-3, Some(drawn)),
        ),
    ] {
        group.bench_function(name, |b| b.iter(|| diagnose(&series, &base).expect("runs")));
    }
    group.finish();
}

criterion_group!(benches, diagnose_30s);
criterion_main!(benches);
