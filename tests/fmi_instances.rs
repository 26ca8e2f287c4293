//! Several instances of the packaged FMU in one process and on several threads, and FMU
//! states saved, serialized and restored: every replay is bit for bit.

mod common;

use common::fmi2::{packaged, Instance};
use std::ptr::null_mut;
use tbm_thrust::fmi::types::*;
use tbm_thrust::variables::{by_name, vr, Outputs};

type S = Fmi2Status;

const H: f64 = 0.01;

/// Every output, as bits.
fn outputs(inst: &Instance) -> Vec<u64> {
    let vrs: Vec<u32> = Outputs::NAMES
        .iter()
        .map(|n| by_name(n).unwrap().vr)
        .collect();
    inst.get_reals(&vrs)
        .unwrap()
        .iter()
        .map(|v| v.to_bits())
        .collect()
}

/// Steps from `t0` for `n` steps of `H` and records the outputs after each.
fn run(inst: &Instance, t0: f64, n: usize) -> Vec<Vec<u64>> {
    (0..n)
        .map(|k| {
            assert_eq!(
                inst.do_step(t0 + k as f64 * H, H),
                S::Ok,
                "{}",
                inst.errors()
            );
            outputs(inst)
        })
        .collect()
}

fn started(name: &str, v_ref: f64, gain_factor: f64) -> Instance<'static> {
    let inst = packaged().instance(name);
    let kp1 = by_name("Kp1").unwrap().vr;
    assert_eq!(inst.set_real(&[vr::V_REF], &[v_ref]), S::Ok);
    inst.initialize(0.0, None);
    let kp = inst.get_real(kp1);
    assert_eq!(inst.set_real(&[kp1], &[kp * gain_factor]), S::Ok);
    inst
}

#[test]
fn two_instances_side_by_side_do_not_disturb_each_other() {
    let solo_a = run(&started("solo_a", 0.05, 1.0), 0.0, 150);
    let solo_b = run(&started("solo_b", 0.02, 0.5), 0.0, 150);
    let (a, b) = (started("a", 0.05, 1.0), started("b", 0.02, 0.5));
    for k in 0..150 {
        let t = k as f64 * H;
        assert_eq!(a.do_step(t, H), S::Ok);
        assert_eq!(b.do_step(t, H), S::Ok);
        assert_eq!(outputs(&a), solo_a[k], "instance a at step {k}");
        assert_eq!(outputs(&b), solo_b[k], "instance b at step {k}");
    }
    assert_ne!(solo_a, solo_b);
}

#[test]
fn instances_run_on_separate_threads() {
    let cases: Vec<(f64, f64)> = vec![(0.05, 1.0), (0.03, 0.8), (0.05, 0.5), (0.01, 1.2)];
    let sequential: Vec<_> = cases
        .iter()
        .map(|&(v, g)| run(&started("seq", v, g), 0.0, 100))
        .collect();
    let threaded: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = cases
            .iter()
            .enumerate()
            .map(|(i, &(v, g))| {
                let inst = started(&format!("thread{i}"), v, g);
                scope.spawn(move || run(&inst, 0.0, 100))
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(threaded, sequential);
}

/// fmi2GetFMUstate, then the serialized bytes of that state.
fn save(inst: &Instance) -> (Fmi2FmuState, Vec<u8>) {
    let (a, c) = (inst.api(), inst.c);
    let mut state = null_mut();
    let mut size = 0;
    unsafe {
        assert_eq!((a.get_fmu_state)(c, &mut state), S::Ok);
        assert_eq!((a.serialized_fmu_state_size)(c, state, &mut size), S::Ok);
        let mut bytes = vec![0u8; size];
        assert_eq!(
            (a.serialize_fmu_state)(c, state, bytes.as_mut_ptr().cast(), size),
            S::Ok
        );
        (state, bytes)
    }
}

fn deserialize(inst: &Instance, bytes: &[u8], state: &mut Fmi2FmuState) -> S {
    unsafe { (inst.api().deserialize_fmu_state)(inst.c, bytes.as_ptr().cast(), bytes.len(), state) }
}

#[test]
fn saved_and_serialized_states_replay_bit_for_bit() {
    let inst = started("original", 0.05, 1.0);
    run(&inst, 0.0, 120);
    let (state, bytes) = save(&inst);
    let reference = run(&inst, 1.2, 80);
    let (a, c) = (inst.api(), inst.c);
    unsafe {
        assert_eq!((a.terminate)(c), S::Ok);
        assert_eq!(
            (a.set_fmu_state)(c, state),
            S::Ok,
            "restoring after fmi2Terminate"
        );
        assert_eq!(
            run(&inst, 1.2, 80),
            reference,
            "fmi2SetFMUstate replays bit for bit"
        );

        let fresh = packaged().instance("restored");
        let mut restored = null_mut();
        assert_eq!(deserialize(&fresh, &bytes, &mut restored), S::Ok);
        assert_eq!((a.set_fmu_state)(fresh.c, restored), S::Ok);
        assert_eq!(
            run(&fresh, 1.2, 80),
            reference,
            "a deserialized state replays bit for bit in a new instance"
        );

        assert_eq!(
            deserialize(&fresh, &bytes, &mut restored),
            S::Ok,
            "deserializing into an existing state"
        );
        assert_eq!((a.set_fmu_state)(fresh.c, restored), S::Ok);
        assert_eq!(run(&fresh, 1.2, 80), reference);
        assert_eq!((a.free_fmu_state)(fresh.c, &mut restored), S::Ok);
        assert!(restored.is_null());
        assert_eq!(
            (a.set_fmu_state)(fresh.c, state),
            S::Error,
            "a state belongs to its instance"
        );
        assert!(fresh.errors().contains("not created by this instance"));
        let mut state = state;
        assert_eq!((a.free_fmu_state)(c, &mut state), S::Ok);
        assert_eq!((a.set_fmu_state)(c, state), S::Error);
    }
}

#[test]
fn bad_serialized_states_are_refused() {
    let inst = started("bytes", 0.05, 1.0);
    run(&inst, 0.0, 10);
    let (state, bytes) = save(&inst);
    let (a, c) = (inst.api(), inst.c);
    let mut target = null_mut();
    let refused = |status: S, needle: &str| {
        assert_eq!(status, S::Error);
        let errors = inst.errors();
        assert!(errors.contains(needle), "{needle:?} in {errors}");
    };
    refused(
        deserialize(&inst, &bytes[..bytes.len() / 2], &mut target),
        "truncated",
    );
    let mut foreign = bytes.clone();
    let guid_at = 16;
    foreign[guid_at + 1] ^= 0x01;
    refused(
        deserialize(&inst, &foreign, &mut target),
        "written by FMU build",
    );
    refused(
        deserialize(&inst, b"garbage!garbage!", &mut target),
        "magic",
    );
    let mut short = vec![0u8; bytes.len() - 1];
    refused(
        unsafe { (a.serialize_fmu_state)(c, state, short.as_mut_ptr().cast(), short.len()) },
        "fmi2SerializedFMUstateSize gives",
    );
    assert!(target.is_null(), "no state was made from bad bytes");
    assert_eq!(inst.do_step(0.1, H), S::Ok, "the instance is still usable");
}

#[test]
fn reset_gives_the_same_run_as_a_new_instance() {
    let inst = started("reset", 0.05, 1.0);
    let first = run(&inst, 0.0, 60);
    unsafe { assert_eq!((inst.api().reset)(inst.c), S::Ok) };
    assert_eq!(inst.set_real(&[vr::V_REF], &[0.05]), S::Ok);
    inst.initialize(0.0, None);
    assert_eq!(run(&inst, 0.0, 60), first);
}

#[test]
fn a_run_can_start_at_any_time() {
    let zero = started("zero", 0.05, 1.0);
    let reference = run(&zero, 0.0, 100);
    let late = packaged().instance("late");
    assert_eq!(late.set_real(&[vr::V_REF], &[0.05]), S::Ok);
    late.initialize(100.0, Some(101.0));
    assert_eq!(
        late.do_step(0.0, H),
        S::Error,
        "the first step starts at the start time"
    );
    assert!(late.errors().contains("ended at 100 s"));
    let shifted = run(&late, 100.0, 100);
    let x = Outputs::NAMES.iter().position(|n| *n == "x").unwrap();
    for (a, b) in shifted.iter().zip(&reference) {
        let (a, b) = (f64::from_bits(a[x]), f64::from_bits(b[x]));
        assert!((a - b).abs() <= 1e-9 * b.abs().max(1e-3), "x {a} vs {b}");
    }
    assert_eq!(late.do_step(101.0, H), S::Error, "past the stop time");
}
