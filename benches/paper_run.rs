//! The 20 s paper run (adaptive, PID, 0.05 m/s, 12 kN) and its single-pump twin, and the
//! plant's share of it: the 40,000 solver steps of 0.5 ms alone (sliding, constant drive).
use criterion::{criterion_group, criterion_main, Criterion};
use tbm_thrust::plant::{Drive, PlantState};
use tbm_thrust::pump::PumpParams;
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

fn plant_steps(c: &mut Criterion) {
    let (p, f_load, h) = (Params::default(), 12_000.0, 5e-4);
    let pumps = PumpParams::both(&p);
    let drive = Drive {
        uc: [3.0, 1.0],
        f_load,
    };
    c.bench_function("plant_steps_40000", |b| {
        b.iter(|| {
            let mut s = PlantState::at_rest(&p, f_load);
            for k in 0..40_000 {
                s.step(&p, &pumps, &drive, k as f64 * h, h);
            }
            s
        })
    });
}

criterion_group!(benches, paper_run, plant_steps);
criterion_main!(benches);
