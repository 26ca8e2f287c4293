//! The figures of `reproduce`, numbered as in the paper (Figs. 3-6, 11-13), as PNG files.

use crate::plot::{self, Legend, Panel, Series};
use rayon::prelude::*;
use std::path::Path;
use tbm_bench::experiments::{
    Reproduction, Run, COMPARISON_LOAD, COMPARISON_SPEED, STARTUP_LOAD, STARTUP_SPEEDS,
    TABLE7_LOADS,
};
use tbm_thrust::units::LPM;
use tbm_thrust::{Controller, Scheme};

/// m^3/s to L/min.
/// m to mm.
const MM: f64 = 1e3;
/// Display magnification of the displacement deviation in Fig. 3 (as in the paper).
const MAGNIFY: f64 = 10.0;
const TIME: &str = "time [s]";
const ERROR: &str = "displacement error e_x [mm]";

/// One figure: its file name, what it shows, and how it is drawn.
pub struct Figure {
    pub file: &'static str,
    pub caption: &'static str,
    draw: fn(&Reproduction, &Path) -> Result<(), String>,
}

pub const FIGURES: [Figure; 7] = [
    Figure {
        file: "fig03_displacement.png",
        caption: "Fig. 3: displacement x against the reference x_ref at 0.01, 0.03 and 0.05 m/s \
                  (12 kN), single pump vs adaptive dual pump; the deviation x - x_ref is drawn \
                  magnified 10 times, as in the paper (display only)",
        draw: fig03,
    },
    Figure {
        file: "fig04_error.png",
        caption: "Fig. 4: displacement error e_x at the three start-up speeds (12 kN)",
        draw: fig04,
    },
    Figure {
        file: "fig05_flows.png",
        caption:
            "Fig. 5: pump flows Q1 (main) and Q2 (auxiliary) at the three start-up speeds (12 kN)",
        draw: fig05,
    },
    Figure {
        file: "fig06_gains.png",
        caption:
            "Fig. 6: adaptive gains k_x, k_v, k_a of the auxiliary pump at the three start-up \
                  speeds (12 kN)",
        draw: fig06,
    },
    Figure {
        file: "fig11_schemes.png",
        caption: "Fig. 11: e_x of single pump, fixed 60/40 split and adaptive dual pump \
                  (0.05 m/s, 10 kN)",
        draw: fig11,
    },
    Figure {
        file: "fig12_loads.png",
        caption: "Fig. 12: e_x of single pump and adaptive dual pump at loads 10, 9, 8 and 7 kN \
                  (0.05 m/s)",
        draw: fig12,
    },
    Figure {
        file: "fig13_controllers.png",
        caption: "Fig. 13: e_x with PID and ADRC inner flow loops, single pump and adaptive dual \
                  pump (0.05 m/s, 10 kN)",
        draw: fig13,
    },
];

/// Draws every figure into `dir` (in parallel); returns the figures written.
pub fn render_all(r: &Reproduction, dir: &Path) -> Result<&'static [Figure], String> {
    FIGURES
        .par_iter()
        .try_for_each(|f| (f.draw)(r, &dir.join(f.file)))?;
    Ok(&FIGURES)
}

/// `signal` of a run against time, multiplied by `scale`.
fn series(name: &str, run: &Run, signal: &str, scale: f64) -> Series {
    let ys = run
        .trace
        .signal(signal)
        .expect("the trace records every output");
    Series::new(
        name,
        run.trace.time.clone(),
        ys.iter().map(|y| y * scale).collect(),
    )
}

fn startup_title(i: usize, v: f64) -> String {
    format!("({}) v_ref = {v} m/s, {} kN", letter(i), STARTUP_LOAD / 1e3)
}

fn letter(i: usize) -> char {
    (b'a' + i as u8) as char
}

/// One panel per start-up speed, its curves made by `curves` from the single and adaptive runs.
fn startup_panels(
    r: &Reproduction,
    y_label: &str,
    curves: impl Fn(&Run, &Run) -> Vec<Series>,
) -> Vec<Panel> {
    STARTUP_SPEEDS
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            let (single, adaptive) = (r.startup(Scheme::Single, v), r.startup(Scheme::Adaptive, v));
            Panel::new(startup_title(i, v), TIME, y_label, curves(single, adaptive))
        })
        .collect()
}

fn fig03(r: &Reproduction, path: &Path) -> Result<(), String> {
    let magnified = |name: &str, run: &Run| {
        let x_ref = run.trace.signal("x_ref").expect("x_ref is recorded");
        let e_x = run.trace.signal("e_x").expect("e_x is recorded");
        let ys = x_ref
            .iter()
            .zip(&e_x)
            .map(|(x, e)| x - MAGNIFY * e)
            .collect();
        Series::new(name, run.trace.time.clone(), ys)
    };
    let panels: Vec<Panel> = startup_panels(r, "displacement x [m]", |s, a| {
        vec![
            series("x_ref", s, "x_ref", 1.0),
            magnified("x, single pump (deviation x10)", s),
            magnified("x, adaptive dual pump (deviation x10)", a),
        ]
    })
    .into_iter()
    .map(|p| p.legend_at(Legend::UpperLeft))
    .collect();
    plot::panels(
        path,
        "Fig. 3: displacement tracking, single vs adaptive",
        &panels,
        1,
    )
}

fn fig04(r: &Reproduction, path: &Path) -> Result<(), String> {
    let panels = startup_panels(r, ERROR, |s, a| {
        vec![
            series("single pump", s, "e_x", MM),
            series("adaptive dual pump", a, "e_x", MM),
        ]
    });
    plot::panels(
        path,
        "Fig. 4: displacement tracking error, single vs adaptive",
        &panels,
        1,
    )
}

fn fig05(r: &Reproduction, path: &Path) -> Result<(), String> {
    let panels = startup_panels(r, "pump flow [L/min]", |s, a| {
        vec![
            series("Q1, single pump", s, "Q1", LPM),
            series("Q1 main, adaptive dual pump", a, "Q1", LPM),
            series("Q2 auxiliary, adaptive dual pump", a, "Q2", LPM),
        ]
    });
    plot::panels(path, "Fig. 5: pump flows, single vs adaptive", &panels, 1)
}

fn fig06(r: &Reproduction, path: &Path) -> Result<(), String> {
    let panels = startup_panels(r, "gain [law units, see ARCHITECTURE.md]", |_, a| {
        vec![
            series("k_x", a, "k_x", 1.0),
            series("k_v", a, "k_v", 1.0),
            series("k_a", a, "k_a", 1.0),
        ]
    });
    plot::panels(
        path,
        "Fig. 6: adaptive gains of the auxiliary pump",
        &panels,
        1,
    )
}

fn fig11(r: &Reproduction, path: &Path) -> Result<(), String> {
    let run = |scheme| r.headline(scheme, Controller::Pid);
    let curves = vec![
        series("single pump", run(Scheme::Single), "e_x", MM),
        series("fixed split 60/40", run(Scheme::FixedSplit), "e_x", MM),
        series("adaptive dual pump", run(Scheme::Adaptive), "e_x", MM),
    ];
    let title = format!(
        "Fig. 11: dual-pump schemes ({COMPARISON_SPEED} m/s, {} kN)",
        COMPARISON_LOAD / 1e3
    );
    plot::line_chart(path, &title, TIME, ERROR, curves)
}

fn fig12(r: &Reproduction, path: &Path) -> Result<(), String> {
    let panels: Vec<Panel> = TABLE7_LOADS
        .iter()
        .enumerate()
        .map(|(i, &load)| {
            let curves = vec![
                series("single pump", r.at_load(Scheme::Single, load), "e_x", MM),
                series(
                    "adaptive dual pump",
                    r.at_load(Scheme::Adaptive, load),
                    "e_x",
                    MM,
                ),
            ];
            Panel::new(
                format!("({}) external load {} kN", letter(i), load / 1e3),
                TIME,
                ERROR,
                curves,
            )
        })
        .collect();
    let title = format!("Fig. 12: error under different loads ({COMPARISON_SPEED} m/s)");
    plot::panels(path, &title, &panels, 2)
}

fn fig13(r: &Reproduction, path: &Path) -> Result<(), String> {
    let curves = [Controller::Pid, Controller::Adrc]
        .iter()
        .flat_map(|&c| {
            [
                (Scheme::Single, "single pump"),
                (Scheme::Adaptive, "adaptive dual pump"),
            ]
            .map(|(s, name)| {
                series(
                    &format!("{}, {name}", c.name().to_uppercase()),
                    r.headline(s, c),
                    "e_x",
                    MM,
                )
            })
        })
        .collect();
    let title = format!(
        "Fig. 13: PID vs ADRC inner loops ({COMPARISON_SPEED} m/s, {} kN)",
        COMPARISON_LOAD / 1e3
    );
    plot::line_chart(path, &title, TIME, ERROR, curves)
}
