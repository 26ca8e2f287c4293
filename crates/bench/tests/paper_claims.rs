//! The paper's qualitative claims (sections 3.3 and 4), checked on the default parameters.
//! Only orderings and ranges are asserted, never particular numbers. The runs take about a
//! second with `cargo test --release`.

use std::sync::OnceLock;
use tbm_bench::experiments::{
    load_spreads, Reproduction, Summary, FLOW_RATIO_RANGE, LOAD_SPREAD_LIMIT,
};
use tbm_thrust::simulation::DEFAULT_SUBSTEPS;
use tbm_thrust::Params;

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

#[test]
fn steady_main_to_auxiliary_flow_ratio_is_between_2_and_3() {
    let (lo, hi) = FLOW_RATIO_RANGE;
    let headline = summary().flow_ratio_main_aux;
    let startup = reproduction().startup_flow_ratios();
    let all_within = (lo..=hi).contains(&headline)
        && startup
            .iter()
            .all(|(_, r)| r.is_some_and(|r| (lo..=hi).contains(&r)));
    assert!(
        all_within,
        "Q1:Q2 at 10 kN, 0.05 m/s: {headline:.2}; Fig. 5 runs at 12 kN (v_ref [m/s], ratio): {startup:.2?}"
    );
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
