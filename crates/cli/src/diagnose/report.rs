//! The `--report DIR` of `diagnose`: a Markdown page for a hydraulic engineer with PNG
//! figures (signals and model before/after, replay errors against time, and each
//! subsystem's equation error against time, velocity and pressure).

use crate::plot::{panels, Legend, Panel, Series as Curve};
use std::path::Path;
use tbm_bench::diagnose::effect::Effect;
use tbm_bench::diagnose::explain::fmt_si;
use tbm_bench::diagnose::locate::EquationError;
use tbm_bench::diagnose::model::Split;
use tbm_bench::diagnose::search::{explained, Trial};
use tbm_bench::diagnose::{judged, Diagnosis};
use tbm_thrust::units::LPM;

/// Bins of the residual-against-velocity and -pressure curves.
const BINS: usize = 25;

pub fn write(
    dir: &Path,
    d: &Diagnosis,
    recording: &Path,
    params: &Path,
    elapsed: f64,
) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    signals_figure(&dir.join("signals.png"), d)?;
    errors_figure(&dir.join("replay_errors.png"), d)?;
    let mut figures = Vec::new();
    for (before, after) in d.equations_before.iter().zip(&d.equations_after) {
        let name = format!("equation_{}.png", before.subsystem.name());
        equation_figure(&dir.join(&name), d, before, after)?;
        figures.push((before.subsystem.name(), name));
    }
    let mut finding_figures = Vec::new();
    for (i, f) in d.findings.iter().enumerate() {
        let name = format!("finding_{}_{}.png", i + 1, f.effect.id());
        if finding_figure(&dir.join(&name), d, f)? {
            finding_figures.push((i, name));
        }
    }
    let text = markdown(d, recording, params, elapsed, &figures, &finding_figures);
    crate::output::write_atomic(&dir.join("report.md"), &text)
}

/// Display unit of a signal: (factor from SI, label).
fn unit(name: &str) -> (f64, &'static str) {
    match name {
        "x" => (1e3, "x [mm]"),
        "v" => (1e3, "v [mm/s]"),
        "p" => (1e-6, "p [MPa]"),
        "Q1" => (LPM, "Q1 [L/min]"),
        _ => (LPM, "Q2 [L/min]"),
    }
}

fn scaled(v: &[f64], f: f64) -> Vec<f64> {
    v.iter().map(|x| x * f).collect()
}

/// One panel per replayed signal, drawn by `panel(name, recorded, before, after, unit)`.
fn per_signal(
    d: &Diagnosis,
    panel: impl Fn(&str, &[f64], &[f64], &[f64], (f64, &'static str)) -> Panel,
) -> Vec<Panel> {
    d.before
        .iter()
        .zip(&d.after)
        .map(|((name, b), (_, a))| panel(name, d.series.col(name), b, a, unit(name)))
        .collect()
}

/// The signal a finding acts on (its subsystem's mismatch signal), recorded and replayed
/// before and after, around the window where the effect cuts the error most; false when the
/// finding has no located window.
fn finding_figure(
    path: &Path,
    d: &Diagnosis,
    f: &tbm_bench::diagnose::Finding,
) -> Result<bool, String> {
    let Some(m) = d
        .mismatch
        .iter()
        .find(|m| m.subsystem == f.effect.subsystem())
    else {
        return Ok(false);
    };
    let Some(w) = m.windows.first() else {
        return Ok(false);
    };
    let (Some((_, b)), Some((_, a))) = (
        d.before.iter().find(|(n, _)| *n == m.signal),
        d.after.iter().find(|(n, _)| *n == m.signal),
    ) else {
        return Ok(false);
    };
    let (t0, t1) = (w[0] - 0.5, w[1] + 0.5);
    let keep: Vec<usize> = (0..d.series.len())
        .filter(|&k| (t0..=t1).contains(&d.series.time(k)))
        .collect();
    if keep.len() < 2 {
        return Ok(false);
    }
    let (factor, label) = unit(m.signal);
    let t: Vec<f64> = keep.iter().map(|&k| d.series.time(k)).collect();
    let pick = |v: &[f64]| -> Vec<f64> { keep.iter().map(|&k| v[k] * factor).collect() };
    let y = d.series.col(m.signal);
    let signal = Panel::new(
        format!(
            "{}: {} where it acts ({:.2}-{:.2} s), on data not used to fit",
            f.effect.id(),
            m.signal,
            w[0],
            w[1]
        ),
        "time [s]",
        label,
        vec![
            Curve::new("recorded", t.clone(), pick(y)),
            Curve::new("nominal, refitted", t.clone(), pick(b)),
            Curve::new("with the effects found", t.clone(), pick(a)),
        ],
    )
    .legend_at(Legend::UpperLeft);
    let error = judged_error_panel(d, m.signal, (b, a), &t, &pick);
    panels(
        path,
        &format!("Finding: {}", f.effect.id()),
        &[signal, error],
        1,
    )?;
    Ok(true)
}

/// The error of `signal` as the method judges it (recorded minus replayed; for `x` and `p`
/// the level low-passed segment by segment, `x` about its segment mean), before and after
/// the effects, beside the floor the replay can reach (RMS over the recording): where the
/// error the effects leave lies inside that band, the rest is noise.
fn judged_error_panel(
    d: &Diagnosis,
    signal: &str,
    (before, after): (&[f64], &[f64]),
    t: &[f64],
    pick: &dyn Fn(&[f64]) -> Vec<f64>,
) -> Panel {
    let segs = if signal.starts_with('Q') {
        &d.layout.pump
    } else {
        &d.layout.hydro
    };
    let error = |pred: &[f64]| {
        let (level, model) = judged(&d.series, segs, signal, pred);
        let e: Vec<f64> = level.iter().zip(&model).map(|(y, m)| y - m).collect();
        pick(&e)
    };
    let (factor, label) = unit(signal);
    let mut curves = vec![
        Curve::new("nominal, refitted", t.to_vec(), error(before)).colour(1),
        Curve::new("with the effects found", t.to_vec(), error(after)).colour(2),
    ];
    if let Some(floor) = d.floors.iter().find(|f| f.signal == signal) {
        let level = floor.total() * factor;
        let (t0, t1) = (t[0], t[t.len() - 1]);
        curves.push(
            Curve::new(
                "± the reachable floor (RMS)",
                vec![t0, t1, f64::NAN, t0, t1],
                vec![level, level, f64::NAN, -level, -level],
            )
            .colour(7),
        );
    }
    Panel::new(
        format!("{signal}: recorded minus replayed, as judged"),
        "time [s]",
        format!("error of {label}"),
        curves,
    )
    .legend_at(Legend::UpperLeft)
}

fn signals_figure(path: &Path, d: &Diagnosis) -> Result<(), String> {
    let t = d.series.times();
    let list = per_signal(d, |name, y, b, a, (f, label)| {
        Panel::new(
            format!("{name}: recorded and replayed (each segment from the recorded state)"),
            "time [s]",
            label,
            vec![
                Curve::new("recorded", t.clone(), scaled(y, f)),
                Curve::new("nominal, refitted", t.clone(), scaled(b, f)),
                Curve::new("with the effects found", t.clone(), scaled(a, f)),
            ],
        )
        .legend_at(Legend::UpperLeft)
    });
    panels(path, "Signals and model, on data not used to fit", &list, 1)
}

fn errors_figure(path: &Path, d: &Diagnosis) -> Result<(), String> {
    let t = d.series.times();
    let list = per_signal(d, |name, y, b, a, (f, label)| {
        let err = |m: &[f64]| {
            y.iter()
                .zip(m)
                .map(|(y, m)| (y - m) * f)
                .collect::<Vec<f64>>()
        };
        Panel::new(
            format!("{name}: recorded minus replayed"),
            "time [s]",
            format!("error of {label}"),
            vec![
                Curve::new("nominal, refitted", t.clone(), err(b)),
                Curve::new("with the effects found", t.clone(), err(a)),
            ],
        )
    });
    panels(path, "Replay errors on data not used to fit", &list, 1)
}

/// The window means of a signal over an equation error's windows.
fn window_means(e: &EquationError, y: &[f64], width: usize) -> Vec<f64> {
    e.start
        .iter()
        .map(|&k| y[k..(k + width).min(y.len())].iter().sum::<f64>() / width as f64)
        .collect()
}

/// Mean of `r` in bins of `x` (bins with fewer than 3 windows skipped): (centres, means).
fn binned(x: &[f64], r: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (lo, hi) = tbm_bench::numerics::stats::extremes(x);
    let width = ((hi - lo) / BINS as f64).max(f64::MIN_POSITIVE);
    let mut sums = vec![(0.0, 0.0, 0usize); BINS];
    for (xv, rv) in x.iter().zip(r) {
        let b = (((xv - lo) / width) as usize).min(BINS - 1);
        sums[b] = (sums[b].0 + xv, sums[b].1 + rv, sums[b].2 + 1);
    }
    sums.iter()
        .filter(|s| s.2 >= 3)
        .map(|s| (s.0 / s.2 as f64, s.1 / s.2 as f64))
        .unzip()
}

/// Display factor and unit of an equation error's SI unit.
fn residual_unit(si: &str) -> (f64, &'static str) {
    match si {
        "m^3/s" => (LPM, "L/min"),
        "m^3/s^2" => (LPM, "L/min per s"),
        _ => (1.0, "N"),
    }
}

fn equation_figure(
    path: &Path,
    d: &Diagnosis,
    before: &EquationError,
    after: &EquationError,
) -> Result<(), String> {
    let width = (0.2 / d.series.dt).round() as usize;
    let v = scaled(&window_means(before, &d.velocity, width), 1e3);
    let p = scaled(&window_means(before, d.series.col("p"), width), 1e-6);
    let (f, u) = residual_unit(before.unit);
    let (rb, ra) = (scaled(&before.residual, f), scaled(&after.residual, f));
    let label = format!("mean residual over 0.2 s [{u}]");
    let against = |x: &[f64], name: &str, xl: &str| {
        let (xb, rb) = binned(x, &rb);
        let (xa, ra) = binned(x, &ra);
        Panel::new(
            format!("against {name} (bin means)"),
            xl,
            label.clone(),
            vec![
                Curve::new("nominal, refitted", xb, rb),
                Curve::new("with the effects found", xa, ra),
            ],
        )
    };
    let list = vec![
        Panel::new(
            "against time",
            "time [s]",
            label.clone(),
            vec![
                Curve::new("nominal, refitted", before.time.clone(), rb.clone()),
                Curve::new("with the effects found", after.time.clone(), ra.clone()),
            ],
        ),
        against(&v, "velocity", "velocity [mm/s]"),
        against(&p, "pressure", "pressure [MPa]"),
    ];
    let title = format!(
        "{}: equation error in weak form (integrated over 0.2 s windows)",
        before.subsystem.name()
    );
    panels(path, &title, &list, 1)
}

fn markdown(
    d: &Diagnosis,
    recording: &Path,
    params: &Path,
    elapsed: f64,
    figures: &[(&str, String)],
    finding_figures: &[(usize, String)],
) -> String {
    [
        header(d, recording, params, elapsed),
        findings_section(d, finding_figures),
        floor_section(d),
        mismatch_section(d),
        fits_section(d),
        equations_section(figures),
        candidates_section(d),
        notes_section(d),
    ]
    .concat()
}

fn header(d: &Diagnosis, recording: &Path, params: &Path, elapsed: f64) -> String {
    let mut s = format!("# Diagnosis of `{}`\n\n", recording.display());
    s.push_str(&format!(
        "**Verdict: {}.** {} samples at {:.0} Hz; ran in {elapsed:.1} s. Fitted parameters: `{}`.\n\n",
        d.verdict(),
        d.series.len(),
        1.0 / d.series.dt,
        params.display()
    ));
    s.push_str("Method: the nominal unknowns are refitted first; each subsystem is replayed from the recorded signals at its boundary, in 1 s segments started from the recorded state; the segments alternate between two halves, and every figure and fit index below shows the half *not* used to fit. See docs/diagnose.md.\n\n");
    s
}

/// Each named effect: its equation, parameters with units, evidence and figure.
fn findings_section(d: &Diagnosis, finding_figures: &[(usize, String)]) -> String {
    let mut s = String::from("## Missing physics\n\n");
    if d.findings.is_empty() {
        s.push_str("None: noise and a refit of the nominal unknowns explain the recording.\n\n");
    }
    if d.findings.is_empty() && !d.above_floor.is_empty() {
        s.push_str("None of the contract's effects passed the selection rule, but the held-out error stands above the floor a replay can reach (see the notes and the table of candidates below): physics is missing that the contract's list does not name, or an input is not recorded.\n\n");
    }
    for (i, f) in d.findings.iter().enumerate() {
        let params: Vec<String> = f
            .parameters
            .iter()
            .map(|(k, v)| match k.as_str() {
                "pump" => format!("pump {v:.0}"),
                _ => format!("{k} = {}{}", fmt_si(*v), unit_suffix(f.effect, k)),
            })
            .collect();
        s.push_str(&format!(
            "### `{}` — {}\n\n{}\n\n{}\n\n",
            f.effect.id(),
            f.effect.equation(),
            params.join(", "),
            f.evidence
        ));
        if let Some((_, file)) = finding_figures.iter().find(|(j, _)| *j == i) {
            s.push_str(&format!(
                "![{}]({file})\n\nAbove, the signal; below, its error as the method judges it (the level low-passed for `x` and `p`, `x` about each segment's mean) against the floor a replay can reach: an error the effects leave inside that band is noise.\n\n",
                f.effect.id()
            ));
        }
    }
    s
}

/// The reachable floor of each judged signal, its parts, and the held-out error against it.
fn floor_section(d: &Diagnosis) -> String {
    let mut s = String::from("## Reachable floor\n\n| signal | sensor noise | propagated input noise | input sampling, solver step | floor | held-out RMSE after | ratio |\n|---|---|---|---|---|---|---|\n");
    for fl in &d.floors {
        let rmse = d
            .fit_after
            .iter()
            .find(|(n, _)| *n == fl.signal)
            .map_or(f64::NAN, |(_, f)| f.rmse);
        let (f, label) = unit(fl.signal);
        s.push_str(&format!(
            "| {label} | {} | {} | {} | {} | {} | {:.2} |\n",
            fmt_si(f * fl.sensor),
            fmt_si(f * fl.propagated),
            fmt_si(f * fl.sampling),
            fmt_si(f * fl.total()),
            fmt_si(f * rmse),
            rmse / fl.total()
        ));
    }
    s.push_str(&format!(
        "\nThe verdict is `adequate` only when no effect is named and every ratio is at most {}.",
        tbm_bench::diagnose::FLOOR_MULTIPLE
    ));
    let unfloored: Vec<String> = d
        .fit_after
        .iter()
        .filter(|(n, _)| !d.floors.iter().any(|f| f.signal == *n))
        .map(|(n, _)| format!("`{n}`"))
        .collect();
    match unfloored.len() {
        0 => {}
        1 => s.push_str(&format!(
            " {} has no floor: its pump cannot be replayed from a command and is predicted by its own flow's running median, against which only a ripple is tested (see the notes).",
            unfloored[0]
        )),
        _ => s.push_str(&format!(
            " {} have no floor: their pumps cannot be replayed from a command and are predicted by their own flows' running medians, against which only a ripple is tested (see the notes).",
            unfloored.join(" and ")
        )),
    }
    s.push_str("\n\n");
    s
}

fn mismatch_section(d: &Diagnosis) -> String {
    let mut s = String::from("## Where the model misses\n\n| subsystem | signal | share | regime | windows [s] |\n|---|---|---|---|---|\n");
    for m in &d.mismatch {
        let w: Vec<String> = m
            .windows
            .iter()
            .map(|w| format!("{:.2}-{:.2}", w[0], w[1]))
            .collect();
        s.push_str(&format!(
            "| {} | {} | {:.2} | {} | {} |\n",
            m.subsystem.name(),
            m.signal,
            m.share,
            m.regime,
            w.join(", ")
        ));
    }
    s
}

fn fits_section(d: &Diagnosis) -> String {
    let mut s = String::from("\n## Fit on data not used to fit\n\n| signal | R² before | R² after | RMSE before | RMSE after | MAPE before [%] | MAPE after [%] |\n|---|---|---|---|---|---|---|\n");
    for ((n, b), (_, a)) in d.fit_before.iter().zip(&d.fit_after) {
        let (f, label) = unit(n);
        s.push_str(&format!(
            "| {label} | {:.4} | {:.4} | {} | {} | {:.2} | {:.2} |\n",
            b.r2,
            a.r2,
            fmt_si(f * b.rmse),
            fmt_si(f * a.rmse),
            b.mape,
            a.mape
        ));
    }
    s.push_str("\n![signals](signals.png)\n\n![errors](replay_errors.png)\n\n");
    s
}

fn equations_section(figures: &[(&str, String)]) -> String {
    let mut s = String::from("## Equation errors per subsystem\n\n");
    s.push_str("Each subsystem's equation integrated over 0.2 s windows with the recorded signals (nothing differentiated but the smoothed displacement): a structure here that the effects remove is physics the nominal equation lacks.\n\n");
    for (name, file) in figures {
        s.push_str(&format!("![{name}]({file})\n\n"));
    }
    s
}

/// One row per candidate tested, in order: what each half's fit found and how it was judged.
fn candidates_section(d: &Diagnosis) -> String {
    let mut s = String::from("## Every candidate tested\n\n| effect | on top of | fitted (half 1 / half 2) | z | share removed where it acts | error where it acts [x floor] | halves | plausible | verdict |\n|---|---|---|---|---|---|---|---|---|\n");
    for t in &d.trials {
        s.push_str(&candidate_row(t));
    }
    s
}

fn candidate_row(t: &Trial) -> String {
    let on: Vec<&str> = t.on_top_of.iter().map(|e| e.id()).collect();
    format!(
        "| {}{} | {} | {} | {:.1} | {:.2} | {:.1} | {:.3e} / {:.3e}{} | {} | {} |\n",
        t.effect.id(),
        t.effect
            .pump()
            .map(|p| format!(" (pump {p})"))
            .unwrap_or_default(),
        if on.is_empty() {
            "-".to_string()
        } else {
            on.join(", ")
        },
        fold_fits(t),
        t.comparison.z,
        explained(&t.comparison, t.excess),
        t.excess.multiple,
        t.comparison.halves[0],
        t.comparison.halves[1],
        match t.fit.split {
            Split::Blocked => "",
            Split::Interleaved => " (samples interleaved: the evidence in one half)",
        },
        if t.plausibility.ok {
            "yes".to_string()
        } else {
            t.plausibility.reasons.join("; ")
        },
        if t.chosen {
            "**named**"
        } else if t.passed {
            "passed, not the best"
        } else {
            "no"
        }
    )
}

fn notes_section(d: &Diagnosis) -> String {
    if d.notes.is_empty() {
        return String::new();
    }
    let mut s = String::from("\n## Notes\n\n");
    for n in &d.notes {
        s.push_str(&format!("- {n}\n"));
    }
    s
}

/// A candidate's reported parameters as each half's fit left them, with their units:
/// "delay 0.031 / 0.029 s" (the halves' agreement is what the plausibility column judges).
fn fold_fits(t: &Trial) -> String {
    let [a, b] = t.fit.folds.each_ref().map(|m| t.effect.reported(&m.params));
    a.iter()
        .filter(|(k, _)| *k != "pump")
        .map(|(k, v)| {
            let unit = unit_suffix(t.effect, k);
            format!("{k} {} / {}{unit}", fmt_si(*v), fmt_si(b[k]))
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// " unit" after a reported parameter's value, nothing for a dimensionless one.
fn unit_suffix(effect: Effect, key: &str) -> String {
    match effect.reported_unit(key) {
        "" | "1" => String::new(),
        unit => format!(" {unit}"),
    }
}
