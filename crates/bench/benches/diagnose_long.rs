//! `diagnose` on a 600 s, 100 Hz recording: one timed run (criterion's ten samples would
//! take a quarter of an hour). The recording is a `simulate` run of the adaptive scheme:
//! moves of 4 and 5 mm/s and stops, 10 s each, load steps at 100 s and 300 s (the stroke
//! of 1.5 m is not reached). Target: under 2 minutes on 2 cores.
//! Run: `cargo bench -p tbm-bench --bench diagnose_long`.
use std::time::Instant;
use tbm_bench::diagnose::{diagnose, series::Series};
use tbm_bench::recording::Recording;
use tbm_thrust::{run, Params, Profile, Scenario};

fn main() {
    let v_ref = Profile(
        (0..60)
            .map(|i| {
                let v = match i % 4 {
                    0 => 0.004,
                    2 => 0.005,
                    _ => 0.0,
                };
                (10.0 * i as f64, v)
            })
            .collect(),
    );
    let load = Profile(vec![(0.0, 10_000.0), (100.0, 12_000.0), (300.0, 9_000.0)]);
    let scenario = Scenario {
        v_ref,
        load,
        duration: 600.0,
        sample_period: 0.01,
    };
    let params = Params::default();
    let csv = Recording::from_trace(&run(&params, &scenario))
        .with_meta("scheme", "adaptive")
        .to_csv();
    let rec = Recording::parse(&csv, "bench").expect("recording parses");
    let series = Series::from_recording(&rec).expect("uniform grid");
    let started = Instant::now();
    let d = diagnose(&series, &params).expect("runs");
    println!(
        "diagnose_600s_100Hz: {:.1} s ({} samples, verdict {})",
        started.elapsed().as_secs_f64(),
        series.len(),
        d.verdict()
    );
}
