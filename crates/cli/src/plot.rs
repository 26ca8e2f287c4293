//! PNG line charts for the command-line tool, drawn with `plotters` on its bitmap backend.
//!
//! Generic on purpose (any subcommand may use it): a chart is one or more [`Panel`]s, each
//! with a title, axis labels (put the unit in them, e.g. "time [s]") and named
//! [`Series`] shown in a legend. Text is rendered with DejaVu Sans, loaded at run time from
//! [`FONT_PATH`] (Debian package `fonts-dejavu-core`); the library never links this module.

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::OnceLock;

/// The TrueType font every chart uses.
pub const FONT_PATH: &str = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
/// Family name the font is registered under with plotters.
const FAMILY: &str = "sans-serif";
/// Size of one panel [px].
const PANEL_PX: (u32, u32) = (900, 460);
/// Height of the figure title band above the panels [px].
const TITLE_PX: u32 = 40;
/// Distinguishable line colours (the "tab10" palette), used in series order.
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// One named curve: `ys[i]` plotted against `xs[i]`; a non-finite point breaks the line
/// (so one series can hold several pieces, e.g. the two edges of a band).
#[derive(Clone, Debug)]
pub struct Series {
    pub name: String,
    pub xs: Vec<f64>,
    pub ys: Vec<f64>,
    /// Index into the palette; the series' position in its panel when `None`.
    colour: Option<usize>,
}

impl Series {
    pub fn new(name: impl Into<String>, xs: Vec<f64>, ys: Vec<f64>) -> Self {
        Series {
            name: name.into(),
            xs,
            ys,
            colour: None,
        }
    }

    /// Draws the series in the palette's colour `slot` (to keep one meaning per colour
    /// across the panels of a figure).
    pub fn colour(mut self, slot: usize) -> Self {
        self.colour = Some(slot);
        self
    }

    fn points(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.runs().into_iter().flatten()
    }

    /// The pieces of the line between non-finite points.
    fn runs(&self) -> Vec<Vec<(f64, f64)>> {
        let mut runs = vec![Vec::new()];
        for (x, y) in self.xs.iter().zip(&self.ys) {
            if x.is_finite() && y.is_finite() {
                runs.last_mut().expect("never empty").push((*x, *y));
            } else if runs.last().is_some_and(|r| !r.is_empty()) {
                runs.push(Vec::new());
            }
        }
        runs.retain(|r| !r.is_empty());
        runs
    }
}

/// Where a panel's legend goes (pick the corner the curves leave empty).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Legend {
    UpperLeft,
    UpperRight,
}

/// One chart of a figure: title, axis labels with units, and its curves.
#[derive(Clone, Debug)]
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub legend: Legend,
}

impl Panel {
    pub fn new(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        series: Vec<Series>,
    ) -> Self {
        Panel {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            series,
            legend: Legend::UpperRight,
        }
    }

    pub fn legend_at(mut self, legend: Legend) -> Self {
        self.legend = legend;
        self
    }
}

/// A single-panel PNG at `path` (the title goes above the panel).
pub fn line_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: Vec<Series>,
) -> Result<(), String> {
    let panel = Panel::new("", x_label, y_label, series);
    panels(path, title, &[panel], 1)
}

/// A PNG at `path` with `title` above `panels` laid out row by row in `columns` columns.
pub fn panels(path: &Path, title: &str, panels: &[Panel], columns: usize) -> Result<(), String> {
    register_font()?;
    let columns = columns.clamp(1, panels.len().max(1));
    let rows = panels.len().div_ceil(columns).max(1);
    let size = (
        PANEL_PX.0 * columns as u32,
        PANEL_PX.1 * rows as u32 + TITLE_PX,
    );
    let fail = |e: &dyn std::fmt::Display| format!("cannot draw {}: {e}", path.display());
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let body = root.titled(title, (FAMILY, 26)).map_err(|e| fail(&e))?;
    for (area, panel) in body.split_evenly((rows, columns)).iter().zip(panels) {
        draw_panel(area, panel).map_err(|e| fail(&e))?;
    }
    root.present().map_err(|e| fail(&e))
}

/// Loads and registers the font once per process.
fn register_font() -> Result<(), String> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            let bytes = std::fs::read(FONT_PATH).map_err(|e| {
                format!("cannot read the plot font {FONT_PATH} ({e}); install it with `apt-get install fonts-dejavu-core`")
            })?;
            let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
            plotters::style::register_font(FAMILY, FontStyle::Normal, bytes)
                .map_err(|_| format!("{FONT_PATH} is not a usable TrueType font"))
        })
        .clone()
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (x_range, y_range) = bounds(&panel.series);
    let mut builder = ChartBuilder::on(area);
    if !panel.title.is_empty() {
        builder.caption(&panel.title, (FAMILY, 20));
    }
    let mut chart = builder
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(72)
        .build_cartesian_2d(x_range, y_range)?;
    chart
        .configure_mesh()
        .x_desc(&panel.x_label)
        .y_desc(&panel.y_label)
        .label_style((FAMILY, 14))
        .axis_desc_style((FAMILY, 16))
        .draw()?;
    for (i, s) in panel.series.iter().enumerate() {
        let colour = COLOURS[s.colour.unwrap_or(i) % COLOURS.len()];
        let mut runs = s.runs().into_iter();
        let first = runs.next().unwrap_or_default();
        chart
            .draw_series(LineSeries::new(first, colour.stroke_width(2)))?
            .label(&s.name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(2))
            });
        for run in runs {
            chart.draw_series(LineSeries::new(run, colour.stroke_width(2)))?;
        }
    }
    let position = match panel.legend {
        Legend::UpperLeft => SeriesLabelPosition::UpperLeft,
        Legend::UpperRight => SeriesLabelPosition::UpperRight,
    };
    chart
        .configure_series_labels()
        .position(position)
        .label_font((FAMILY, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
}

/// Axis ranges covering every finite point, the y range padded by 5 % (never empty).
fn bounds(series: &[Series]) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let range = |values: &mut dyn Iterator<Item = f64>| {
        values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
    };
    let (x0, x1) = range(&mut series.iter().flat_map(|s| s.points().map(|p| p.0)));
    let (y0, y1) = range(&mut series.iter().flat_map(|s| s.points().map(|p| p.1)));
    (widen(x0, x1, 0.0), widen(y0, y1, 0.05))
}

fn widen(lo: f64, hi: f64, pad: f64) -> std::ops::Range<f64> {
    if !(lo.is_finite() && hi.is_finite()) {
        return 0.0..1.0;
    }
    let span = hi - lo;
    if span <= f64::EPSILON * hi.abs().max(1.0) {
        return (lo - 0.5 * lo.abs().max(1.0))..(hi + 0.5 * hi.abs().max(1.0));
    }
    (lo - pad * span)..(hi + pad * span)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_pad_y_and_skip_non_finite_points() {
        let s = Series::new("a", vec![0.0, 1.0, 2.0], vec![1.0, f64::NAN, 3.0]);
        let (x, y) = bounds(&[s]);
        assert_eq!(x, 0.0..2.0);
        assert!((y.start - 0.9).abs() < 1e-12 && (y.end - 3.1).abs() < 1e-12);
    }

    #[test]
    fn a_non_finite_point_breaks_the_line() {
        let nan = f64::NAN;
        let s = Series::new(
            "band",
            vec![0.0, 1.0, nan, 0.0, 1.0, nan],
            vec![1.0, 1.0, nan, -1.0, -1.0, nan],
        );
        assert_eq!(
            s.runs(),
            vec![vec![(0.0, 1.0), (1.0, 1.0)], vec![(0.0, -1.0), (1.0, -1.0)]]
        );
    }

    #[test]
    fn a_flat_or_empty_series_still_gets_a_range() {
        let (_, y) = bounds(&[Series::new("flat", vec![0.0, 1.0], vec![2.0, 2.0])]);
        assert!(y.start < 2.0 && y.end > 2.0);
        assert_eq!(bounds(&[]).0, 0.0..1.0);
    }

    #[test]
    fn writes_a_png() {
        let dir = std::env::temp_dir().join(format!("tbm-thrust-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("chart.png");
        let xs: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
        let ys = xs.iter().map(|x| x.sin()).collect();
        line_chart(
            &path,
            "sine",
            "time [s]",
            "value [-]",
            vec![Series::new("sin", xs, ys)],
        )
        .unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        std::fs::remove_dir_all(dir).unwrap();
    }
}
