//! The paper's qualitative claims (sections 3.3 and 4), checked on the default parameters,
//! and the calibrated single-pump row pinned. Apart from that pin only orderings and ranges
//! are asserted. The claims the model does not reproduce (the full adaptive law better than
//! the same law with frozen gains under the PID loops, the flow ratio at 0.01 m/s) are
//! listed in docs/reproduce.md with the measured numbers. The runs take about a second with
//! `cargo test --release`.

use std::sync::OnceLock;
use tbm_bench::experiments::{
    load_spreads, Reproduction, Summary, FLOW_RATIO_RANGE, LIVE_LAW_RECOVERY, LOAD_SPREAD_LIMIT,
};
use tbm_thrust::simulation::DEFAULT_SUBSTEPS;
use tbm_thrust::{Controller, Params, Scheme};

/// Every run of the comparisons, computed once for all tests of this file.
fn reproduction() -> &'static Reproduction {
    static RUNS: OnceLock<Reproduction> = OnceLock::new();
    RUNS.get_or_init(|| Reproduction::compute(&Params::default(), DEFAULT_SUBSTEPS))
}

fn summary() -> &'static Summary {
    static SUMMARY: OnceLock<Summary> = OnceLock::new();
    SUMMARY.get_or_init(|| reproduction().summary())
}

#[test]
fn adaptive_beats_fixed_split_which_beats_single_in_max_error() {
    let s = summary();
    let (single, split, adaptive) = (
        s.table7.single["10"].max_mm,
        s.fixed_split.max_mm,
        s.table7.adaptive["10"].max_mm,
    );
    assert!(
        adaptive < split && split < single,
        "max error [mm]: adaptive {adaptive:.3}, fixed_split {split:.3}, single {single:.3}"
    );
}

/// The Fig. 5 start-up speeds [m/s] at which the steady flow ratio is asserted; at
/// 0.01 m/s the model gives 1.72, 14 % below the paper's range: the main pump's flow lost to
/// the pressure coupling b_p p (Eq. 10) is the same at every speed, so at the smallest speed
/// it is the largest share, which the auxiliary pump makes up (docs/reproduce.md).
const RATIO_SPEEDS: [f64; 2] = [0.03, 0.05];

#[test]
fn steady_main_to_auxiliary_flow_ratio_is_between_2_and_3() {
    let (lo, hi) = FLOW_RATIO_RANGE;
    let headline = summary().flow_ratio_main_aux;
    let startup = reproduction().startup_flow_ratios();
    let all_within = (lo..=hi).contains(&headline)
        && startup
            .iter()
            .filter(|(v, _)| RATIO_SPEEDS.contains(v))
            .all(|(_, r)| r.is_some_and(|r| (lo..=hi).contains(&r)));
    assert!(
        all_within,
        "Q1:Q2 at 10 kN, 0.05 m/s: {headline:.2}; Fig. 5 runs at 12 kN (v_ref [m/s], ratio): {startup:.2?}"
    );
}

/// The single-pump 10 kN row the calibration (crates/bench/examples/calibrate.rs) gave, with
/// the recovery time [s]: max, min, mean, S.D. [mm] (Eq. 34-37). Table 7 prints 3.352,
/// -0.863, 1.284, 0.663 mm and section 4.1 about 5 s.
const CALIBRATED_SINGLE: [f64; 5] = [3.487, -0.660, 0.664, 0.266, 0.77];

#[test]
fn the_calibrated_single_pump_row_is_kept() {
    let s = summary();
    let row = &s.table7.single["10"];
    let got = [
        row.max_mm,
        row.min_mm,
        row.mean_mm,
        row.sd_mm,
        s.recovery_time_s.single,
    ];
    // 1 % or 5 um (0.02 s for the recovery time, two samples), whichever is larger.
    let floors = [0.005, 0.005, 0.005, 0.005, 0.02];
    for ((g, want), floor) in got.iter().zip(CALIBRATED_SINGLE).zip(floors) {
        assert!(
            (g - want).abs() <= (0.01 * want.abs()).max(floor),
            "single pump at 10 kN: got {got:.3?}, calibrated {CALIBRATED_SINGLE:?}"
        );
    }
}

#[test]
fn the_four_load_rows_are_nearly_alike() {
    let s = summary();
    for (scheme, rows) in [
        ("single", &s.table7.single),
        ("adaptive", &s.table7.adaptive),
    ] {
        let [max, mean, sd] = load_spreads(rows);
        assert!(
            [max, mean, sd].iter().all(|v| *v <= LOAD_SPREAD_LIMIT),
            "{scheme}: spread over 7-10 kN relative to the mean: max {:.1} %, mean {:.1} %, S.D. {:.1} % \
             (limit {:.0} %)",
            100.0 * max,
            100.0 * mean,
            100.0 * sd,
            100.0 * LOAD_SPREAD_LIMIT
        );
    }
}

/// Fig. 13: ADRC better than PID under each scheme, ADRC + adaptive the best of the four.
#[test]
fn adrc_beats_pid_and_adrc_with_adaptive_compensation_is_best() {
    let s = summary();
    let (pid_single, pid_adaptive) = (s.table7.single["10"].max_mm, s.table7.adaptive["10"].max_mm);
    let (adrc_single, adrc_adaptive) = (s.adrc.single.max_mm, s.adrc.adaptive.max_mm);
    let msg = format!(
        "max error [mm]: PID single {pid_single:.3}, PID adaptive {pid_adaptive:.3}, \
         ADRC single {adrc_single:.3}, ADRC adaptive {adrc_adaptive:.3}"
    );
    assert!(
        adrc_single < pid_single,
        "ADRC single pump should beat PID: {msg}"
    );
    assert!(
        adrc_adaptive < pid_adaptive,
        "ADRC dual pump should beat PID: {msg}"
    );
    assert!(
        adrc_adaptive < adrc_single,
        "ADRC + adaptive should be the best: {msg}"
    );
}

#[test]
fn recovery_is_faster_with_the_auxiliary_pump() {
    let r = &summary().recovery_time_s;
    assert!(
        r.adaptive < r.single,
        "recovery time: adaptive {:.2} s, single {:.2} s",
        r.adaptive,
        r.single
    );
}

/// Peak auxiliary-pump flow [L/min] in the second after a target-speed step from 0.03 to
/// 0.05 m/s at 5 s (10 kN, adaptive scheme), with micro-gating down to `g_min`.
fn aux_peak_after_speed_step(controller: Controller, g_min: f64) -> f64 {
    use tbm_thrust::simulation::{run, Profile, Scenario};
    let p = Params {
        g_min,
        controller,
        ..Params::default()
    };
    let scenario = Scenario {
        v_ref: Profile(vec![(0.0, 0.03), (5.0, 0.05), (10.0, 0.03)]),
        load: Profile::constant(10_000.0),
        duration: 12.0,
        sample_period: 0.01,
    };
    let trace = run(&p, &scenario);
    let q2 = trace.signal("Q2").expect("Q2 is recorded");
    trace
        .time
        .iter()
        .zip(&q2)
        .filter(|(t, _)| **t > 5.0 && **t <= 6.0)
        .map(|(_, q)| q * 6e4)
        .fold(0.0, f64::max)
}

/// Section 3.1: micro-gating (Eq. 24, g_sw drops to 0.75 on a speed change of more than
/// 20 %) limits the auxiliary pump's reaction to a speed step. Measured: 4.052 L/min with
/// gating against 4.134 L/min without (g_min = 1) under PID, 2.821 against 2.974 L/min
/// under ADRC; the runs are deterministic, so with gating switched off the two peaks are
/// equal and this test fails.
#[test]
fn micro_gating_reduces_the_auxiliary_reaction_to_a_speed_step() {
    for controller in [Controller::Pid, Controller::Adrc] {
        let (gated, ungated) = (
            aux_peak_after_speed_step(controller, Params::default().g_min),
            aux_peak_after_speed_step(controller, 1.0),
        );
        assert!(
            gated < ungated - 0.01,
            "{controller:?}: peak Q2 after the 5 s speed step: gated {gated:.3} L/min, \
             ungated {ungated:.3} L/min"
        );
    }
}

/// Fig. 6: "the adaptive parameters fluctuate throughout the entire process but are
/// controlled within a certain range". In the 10 kN, 0.05 m/s adaptive run k_v and k_a
/// (Eq. 21-22) move by more than 10 % of their reference values, are still more than 5 %
/// away at 10 s, and stay within 0.5-5 times them. With frozen gains (Gamma = 0) they never
/// move and this test fails.
#[test]
fn the_adaptive_gains_move_through_the_run_within_bounds() {
    let p = Params::default();
    let run = reproduction().headline(Scheme::Adaptive, Controller::Pid);
    for (name, k0) in [("k_v", p.k_v0), ("k_a", p.k_a0)] {
        let k = run.trace.signal(name).expect("the gains are recorded");
        let at_10_s = k[run
            .trace
            .time
            .iter()
            .position(|t| *t >= 10.0)
            .expect("20 s run")];
        let largest = k.iter().map(|v| (v - k0).abs()).fold(0.0, f64::max);
        let bounded = k.iter().all(|v| (0.5 * k0..=5.0 * k0).contains(v));
        assert!(
            largest > 0.1 * k0 && (at_10_s - k0).abs() > 0.05 * k0 && bounded,
            "{name}: reference {k0}, largest departure {largest:.4}, at 10 s {at_10_s:.4}, \
             within 0.5-5 x reference: {bounded}"
        );
    }
}

/// Section 3.3: the gain updates (Eq. 20-23) turn the velocity and acceleration channels
/// negative as the piston catches up and so prevent overshoot. With ADRC flow loops, whose
/// auxiliary pump delivers what the law commands, the full law at 10 kN, 0.05 m/s
/// overshoots less than the same law with frozen gains (min -1.036 against -1.176 mm
/// measured), so the error creeps back sooner: recovery 2.89 against 3.24 s (-11 %), S.D.
/// 0.273 against 0.313 mm. With the learning rates at zero the two runs are the same and
/// this test fails. (Under the PID loops the auxiliary command sits at the Eq. 26 limit
/// through the peak and the law is not live: docs/reproduce.md, "The adaptive law".)
#[test]
fn the_adaptive_gains_shorten_the_recovery_and_the_overshoot_under_adrc() {
    let law = &summary().adaptive_law["adrc"];
    let (full, frozen) = (&law.full, &law.frozen_gains);
    assert!(
        law.recovery_gain() >= LIVE_LAW_RECOVERY
            && full.error.min_mm > frozen.error.min_mm
            && full.error.sd_mm < frozen.error.sd_mm,
        "ADRC adaptive, full law against Gamma = 0: recovery {:.2} against {:.2} s, \
         min {:.3} against {:.3} mm, S.D. {:.3} against {:.3} mm",
        full.recovery_time_s,
        frozen.recovery_time_s,
        full.error.min_mm,
        frozen.error.min_mm,
        full.error.sd_mm,
        frozen.error.sd_mm
    );
}
