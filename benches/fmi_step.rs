//! Cost of one fmi2DoStep through the C ABI of the packaged FMU (target/fmu/TbmThrust.fmu),
//! for 1 ms and 10 ms communication steps, on the paper case (adaptive, 0.05 m/s, 12 kN).
//! Each iteration is one fmi2DoStep followed by an fmi2GetReal of the outputs, as an
//! importer does per step, with logging off; the instance is restarted from a saved FMU
//! state every 10 s of simulated time, before the piston reaches the end of its stroke.

#[path = "../tests/common/fmi2.rs"]
#[allow(dead_code)]
mod fmi2;

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;
use tbm_thrust::fmi::types::{Fmi2Status, FMI2_CO_SIMULATION};
use tbm_thrust::variables::{by_name, vr, Outputs};

fn do_step(c: &mut Criterion) {
    let fmu = fmi2::packaged();
    let outputs: Vec<u32> = Outputs::NAMES
        .iter()
        .map(|n| by_name(n).unwrap().vr)
        .collect();
    for (label, h) in [("fmi2DoStep_1ms", 1e-3), ("fmi2DoStep_10ms", 1e-2)] {
        let inst = fmu
            .instantiate(label, FMI2_CO_SIMULATION, fmu.guid(), false)
            .expect("fmi2Instantiate");
        assert_eq!(
            inst.set_real(&[vr::V_REF, vr::F_L], &[0.05, 12_000.0]),
            Fmi2Status::Ok
        );
        inst.initialize(0.0, None);
        let mut start = std::ptr::null_mut();
        assert_eq!(
            unsafe { (fmu.api.get_fmu_state)(inst.c, &mut start) },
            Fmi2Status::Ok
        );
        let steps_per_run = (10.0 / h) as usize;
        let mut k = 0;
        c.bench_function(label, |b| {
            b.iter(|| {
                if k == steps_per_run {
                    assert_eq!(
                        unsafe { (fmu.api.set_fmu_state)(inst.c, start) },
                        Fmi2Status::Ok
                    );
                    k = 0;
                }
                assert_eq!(inst.do_step(k as f64 * h, h), Fmi2Status::Ok);
                k += 1;
                black_box(inst.get_reals(&outputs).unwrap())
            })
        });
        let _ = inst.messages();
    }
}

criterion_group!(benches, do_step);
criterion_main!(benches);
