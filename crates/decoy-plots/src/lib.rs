//! Deterministic line plots written as PNG and SVG, with no system fonts.
//!
//! [`write_plot`] draws one [`Plot`] (a titled chart with one or more [`Series`]) into
//! `<stem>.png` (1200x800 pixels) and `<stem>.svg`; [`write_stacked`] draws several
//! plots stacked vertically into one figure.
//!
//! # Behaviour
//!
//! - **Fonts**: DejaVu Sans (regular and bold) is embedded through the `dejavu` crate and
//!   registered with plotters' `ab_glyph` backend, so rendering never reads system fonts.
//!   The SVG names the family `sans-serif`; viewers substitute their own sans font.
//! - **Non-finite values**: a point whose `x` or `y` is NaN or infinite is skipped and the
//!   line is broken there (the finite stretches either side are drawn as separate
//!   lines). A stretch of a single finite point is drawn as a dot. A plot with no finite
//!   point at all is [`PlotError::Empty`].
//! - **Axis ranges** come from the finite data with a 5% margin on each side. A constant
//!   coordinate (including a single point) gets a range of ±5% of its value, or ±1 when
//!   it is zero. With [`Aspect::Equal`] the range of one axis is then widened (about its
//!   centre) so that both axes have the same data units per pixel.
//! - **Inverted y** ([`Plot::invert_y`]): larger `y` values are drawn lower, e.g. depth
//!   "below" the surface growing downwards; tick labels show the true values.
//! - **Colours** come from a fixed 10-colour palette (Tableau 10), in series order; an
//!   eleventh series reuses the first colour. A legend with the series labels is drawn
//!   when a plot has more than one series, in the corner of the plot that covers the
//!   fewest data points.
//! - **Decimation**: a finite stretch with more than 4 points per pixel column of the
//!   plotting area is decimated before drawing. Consecutive points falling into the same
//!   pixel column are replaced by at most four of them, in their original order: the
//!   first, the one with the smallest `y`, the one with the largest `y` and the last. The
//!   drawn line therefore covers exactly the same vertical extent in every column, so
//!   peaks and spikes stay visible, while a 100k-point series costs a few thousand line
//!   segments. Data are never changed, only what is drawn.
//! - **Whole files**: each file is written under `<name>.partial` and renamed when
//!   complete ([`atomic`], which the other output files of the project use too), so
//!   a process killed while plotting never leaves a half-written image under its name.
//! - **Determinism**: the same input gives byte-identical SVG and PNG files (no
//!   timestamps, no randomness, no hash-order dependence).
//!
//! # Example
//!
//! ```no_run
//! use decoy_plots::{Aspect, Plot, Series, write_plot};
//!
//! let t: Vec<f64> = (0..100).map(|i| f64::from(i) * 0.1).collect();
//! let plot = Plot {
//!     title: "Cable tension".into(),
//!     x_label: "time [s]".into(),
//!     y_label: "tension [N]".into(),
//!     series: vec![Series {
//!         label: "tow point".into(),
//!         y: t.iter().map(|t| 100.0 + 5.0 * t.sin()).collect(),
//!         x: t,
//!     }],
//!     aspect: Aspect::Free,
//!     invert_y: false,
//! };
//! let [png, svg] = write_plot(&plot, std::path::Path::new("target/tension"))?;
//! # let _ = (png, svg);
//! # Ok::<(), decoy_plots::PlotError>(())
//! ```

pub mod atomic;
mod heatmap;

pub use heatmap::{HeatMap, write_heatmap};

use std::borrow::Cow;
use std::ffi::OsString;
use std::fmt::Display;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::coord::ranged1d::Ranged;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{FontStyle, register_font};

/// One line of a plot: `y[i]` against `x[i]`.
///
/// `x` and `y` must have the same length. Points are joined in the given order (they
/// need not be sorted by `x`: a cable shape or a trajectory is fine).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Name shown in the legend (the legend appears when a plot has more than one series).
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates, one for each abscissa.
    pub y: Vec<f64>,
}

/// How the two axes are scaled relative to each other.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Aspect {
    /// Each axis independently fills the plotting area.
    #[default]
    Free,
    /// The same data units (e.g. metres) per pixel on both axes, so shapes are not
    /// distorted (cable shapes, trajectories). One axis range is widened as needed.
    Equal,
}

/// A titled chart of one or more series.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Plot {
    /// Title drawn above the chart (also present as text in the SVG).
    pub title: String,
    /// Description of the x axis (with unit), drawn under it; empty for none.
    pub x_label: String,
    /// Description of the y axis (with unit), drawn left of it; empty for none.
    pub y_label: String,
    /// The lines to draw, coloured in order from a fixed palette.
    pub series: Vec<Series>,
    /// Relative scaling of the axes.
    pub aspect: Aspect,
    /// Draw larger `y` values lower (e.g. depth "below" growing downwards).
    pub invert_y: bool,
}

/// Why a plot could not be written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Creating the output directory or writing an output file failed.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The file or directory that could not be written or created.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// Rendering failed, or the input is malformed (e.g. `x` and `y` of different lengths).
    #[error("cannot draw plot: {0}")]
    Draw(String),
    /// The plot has no finite point to draw (no series, empty series, or only NaN/inf).
    #[error("plot {title:?} has no finite data point")]
    Empty {
        /// Title of the offending plot.
        title: String,
    },
}

/// Writes `<stem>.png` (1200x800) and `<stem>.svg`; returns both paths.
///
/// The extensions are appended to `stem` (`out/run.v2` gives `out/run.v2.png`), and the
/// parent directory is created if missing. Both images are rendered in memory before
/// either file is written, so a rendering error leaves no partial files, and each file
/// is written whole ([`atomic::write_atomically`]): under `<name>.partial`, then renamed.
///
/// # Errors
///
/// [`PlotError::Empty`] if the plot has no finite point, [`PlotError::Draw`] if a
/// series has `x` and `y` of different lengths or rendering fails, [`PlotError::Io`] if
/// a file cannot be written.
pub fn write_plot(plot: &Plot, stem: &Path) -> Result<[PathBuf; 2], PlotError> {
    write_figure(std::slice::from_ref(plot), stem, (WIDTH, HEIGHT))
}

/// Several plots stacked vertically in one figure (shared x label allowed), same outputs.
///
/// The figure is 1200 pixels wide and `max(800, 320 * plots.len())` pixels high, split
/// evenly between the plots, top to bottom in slice order. Every panel keeps its own
/// title, ranges and legend, and the plotting areas are aligned horizontally. When all
/// plots have the same `x_label` it is drawn only under the bottom panel.
///
/// # Errors
///
/// As [`write_plot`]; [`PlotError::Empty`] names the first plot without a finite point
/// (or has an empty title when `plots` is empty).
pub fn write_stacked(plots: &[Plot], stem: &Path) -> Result<[PathBuf; 2], PlotError> {
    write_stacked_shaded(plots, &[], stem)
}

/// [`write_stacked`] with x intervals shaded (light red, the full height of the
/// panel, under the lines) in each panel: `shaded[i]` for `plots[i]` (panels
/// beyond `shaded` have none). For example the times a limit is violated.
///
/// # Errors
///
/// As [`write_stacked`].
pub fn write_stacked_shaded(
    plots: &[Plot],
    shaded: &[Vec<(f64, f64)>],
    stem: &Path,
) -> Result<[PathBuf; 2], PlotError> {
    let rows = u32::try_from(plots.len()).unwrap_or(u32::MAX);
    let height = HEIGHT.max(STACKED_PANEL_HEIGHT.saturating_mul(rows));
    write_figure_shaded(plots, shaded, stem, (WIDTH, height))
}

// ---------------------------------------------------------------------------------------
// Layout constants (pixels). Font sizes are for a 1200-pixel-wide figure.

const WIDTH: u32 = 1200;
const HEIGHT: u32 = 800;
const STACKED_PANEL_HEIGHT: u32 = 320;
const FONT: &str = "sans-serif";
const TITLE_SIZE: u32 = 28;
const TITLE_HEIGHT: u32 = 44;
const DESC_SIZE: u32 = 22;
const TICK_SIZE: u32 = 18;
const LEGEND_SIZE: u32 = 18;
const LEGEND_MARGIN: u32 = 10;
const LEGEND_SAMPLE: u32 = 36;
const CHART_MARGIN_TOP: u32 = 6;
const CHART_MARGIN_RIGHT: u32 = 30;
const CHART_MARGIN_BOTTOM: u32 = 6;
const CHART_MARGIN_LEFT: u32 = 10;
/// Room for the tick marks and the gap between tick labels and the axis description.
const LABEL_GAP: u32 = 24;
/// Decimate a stretch when it has more than this many points per pixel column.
const DECIMATE_PER_COLUMN: usize = 4;
const LINE_WIDTH: u32 = 2;
const DOT_RADIUS: i32 = 4;

/// Tableau 10: distinct, colour-blind-aware, and fixed (deterministic).
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];
const GRID_BOLD: RGBColor = RGBColor(200, 200, 200);
/// Shaded intervals (light red).
const SHADE: RGBColor = RGBColor(250, 205, 205);
const GRID_LIGHT: RGBColor = RGBColor(236, 236, 236);
/// Minor grid lines between two major ones, at most.
const MINOR_GRID_LINES: usize = 4;

fn draw_err(e: impl Display) -> PlotError {
    PlotError::Draw(e.to_string())
}

/// Registers the embedded DejaVu Sans as plotters' `sans-serif` (once per process).
fn ensure_fonts() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_ok()
            && register_font(FONT, FontStyle::Bold, dejavu::sans::bold()).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(PlotError::Draw(
            "the embedded DejaVu font could not be parsed".into(),
        ))
    }
}

// ---------------------------------------------------------------------------------------
// Data preparation

/// A closed interval `lo..=hi` of data values.
type Span = (f64, f64);

/// A plot's finite data, split into drawable stretches.
struct Prepared<'a> {
    plot: &'a Plot,
    /// x intervals to shade.
    shaded: &'a [(f64, f64)],
    /// Per series, the maximal runs of consecutive finite points, in drawing
    /// coordinates (`y` negated when the plot is inverted).
    runs: Vec<Vec<Vec<(f64, f64)>>>,
    x: Span,
    y: Span,
}

fn prepare(plot: &Plot) -> Result<Prepared<'_>, PlotError> {
    let sign = if plot.invert_y { -1.0 } else { 1.0 };
    let mut x: Option<Span> = None;
    let mut y: Option<Span> = None;
    let mut runs = Vec::with_capacity(plot.series.len());
    for s in &plot.series {
        if s.x.len() != s.y.len() {
            return Err(PlotError::Draw(format!(
                "series {:?} of plot {:?} has {} x values but {} y values",
                s.label,
                plot.title,
                s.x.len(),
                s.y.len()
            )));
        }
        let mut series_runs = Vec::new();
        let mut current = Vec::new();
        for (&px, &py) in s.x.iter().zip(&s.y) {
            if px.is_finite() && py.is_finite() {
                let py = sign * py;
                x = Some(x.map_or((px, px), |(lo, hi)| (lo.min(px), hi.max(px))));
                y = Some(y.map_or((py, py), |(lo, hi)| (lo.min(py), hi.max(py))));
                current.push((px, py));
            } else if !current.is_empty() {
                series_runs.push(std::mem::take(&mut current));
            }
        }
        if !current.is_empty() {
            series_runs.push(current);
        }
        runs.push(series_runs);
    }
    match (x, y) {
        (Some(x), Some(y)) => Ok(Prepared {
            plot,
            shaded: &[],
            runs,
            x,
            y,
        }),
        _ => Err(PlotError::Empty {
            title: plot.title.clone(),
        }),
    }
}

/// The data span widened by 5% on each side; a degenerate span gets ±5% of its value
/// (±1 at zero).
fn padded((lo, hi): Span) -> Span {
    // Halves first, so that the difference of two huge values cannot overflow.
    let centre = lo / 2.0 + hi / 2.0;
    let half = hi / 2.0 - lo / 2.0;
    let half = if half > centre.abs() * 1e-12 {
        half * 1.1
    } else if centre == 0.0 {
        1.0
    } else {
        centre.abs() * 0.05
    };
    sane(centre, half)
}

/// Largest magnitude of an axis limit. Plotters computes `hi - lo` and tick positions
/// without overflow checks; keeping the limits far from `f64::MAX` keeps those finite.
const AXIS_LIMIT: f64 = 1e300;

/// The range `centre ± half`, clamped to ±[`AXIS_LIMIT`] and never empty.
fn sane(centre: f64, half: f64) -> Span {
    let centre = centre.clamp(-AXIS_LIMIT / 2.0, AXIS_LIMIT / 2.0);
    let half = half
        .max(centre.abs() * 1e-9)
        .clamp(f64::MIN_POSITIVE, AXIS_LIMIT / 2.0);
    (centre - half, centre + half)
}

/// Widens one of the spans so that both have the same data units per pixel.
fn equalise(x: Span, y: Span, (w, h): (u32, u32)) -> (Span, Span) {
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    let per_px = ((x.1 - x.0) / w).max((y.1 - y.0) / h);
    let widen = |(lo, hi): Span, px: f64| sane(lo / 2.0 + hi / 2.0, per_px * px / 2.0);
    (widen(x, w), widen(y, h))
}

/// Min/max-per-pixel-column decimation of one stretch (see the crate docs).
fn decimate(points: &[(f64, f64)], x: Span, columns: u32) -> Cow<'_, [(f64, f64)]> {
    let columns = columns.max(1);
    if points.len() <= DECIMATE_PER_COLUMN * columns as usize {
        return Cow::Borrowed(points);
    }
    let scale = f64::from(columns) / (x.1 - x.0);
    // Saturating float-to-int conversion; only equality of columns matters.
    let column = |p: (f64, f64)| ((p.0 - x.0) * scale).floor() as i64;
    let mut out = Vec::with_capacity(4 * columns as usize);
    let mut start = 0;
    while start < points.len() {
        let c = column(points[start]);
        let (mut i_min, mut i_max) = (start, start);
        let mut end = start + 1;
        while end < points.len() && column(points[end]) == c {
            if points[end].1 < points[i_min].1 {
                i_min = end;
            }
            if points[end].1 > points[i_max].1 {
                i_max = end;
            }
            end += 1;
        }
        let mut keep = [start, i_min, i_max, end - 1];
        keep.sort_unstable();
        let mut last = None;
        for i in keep {
            if last != Some(i) {
                out.push(points[i]);
                last = Some(i);
            }
        }
        start = end;
    }
    Cow::Owned(out)
}

/// The cosine of the turn, in pixels, past which a line is split at a vertex
/// ([`line_pieces`]): 90 degrees.
const REVERSAL_COSINE: f64 = 0.0;
/// The least distance, pixels along either axis, between the points of a
/// drawn line ([`line_pieces`]).
const MIN_POINT_PX: f64 = 2.0;

/// `points` as the pieces a line is drawn in. A thick line's joins are mitred
/// by the bitmap backend (plotters-backend's `polygonize`) on whole pixels,
/// and the inner side of a join is not limited: where the line turns back on
/// itself (after the rounding: a margin jumping from one side's value to the
/// other's and back between samples half a pixel apart did) it drew a spike
/// far past the vertex, out of its panel. So points less than
/// [`MIN_POINT_PX`] from the last one kept along both axes are dropped (which
/// bounds the rounding's turn of a segment to 20 degrees; the last point of the
/// line is always kept, in place of the one before it if that is that near),
/// and the line is split, the vertex in both pieces, wherever it turns by more
/// than 90 degrees: pieces have no join there, and a join turns by at most
/// 130 degrees after the rounding, its inner vertex within 2.5 half widths.
fn line_pieces(points: &[(f64, f64)], lay: &Layout) -> Vec<Vec<(f64, f64)>> {
    let sx = f64::from(lay.plot_px.0.max(1)) / (lay.x.1 - lay.x.0);
    let sy = f64::from(lay.plot_px.1.max(1)) / (lay.y.1 - lay.y.0);
    let px = |p: (f64, f64)| (p.0 * sx, p.1 * sy);
    let near = |a: (f64, f64), b: (f64, f64)| {
        let (a, b) = (px(a), px(b));
        (a.0 - b.0).abs() < MIN_POINT_PX && (a.1 - b.1).abs() < MIN_POINT_PX
    };
    let mut kept: Vec<(f64, f64)> = Vec::with_capacity(points.len());
    for (i, &p) in points.iter().enumerate() {
        match kept.last() {
            Some(&last) if near(last, p) => {
                if i + 1 == points.len() && kept.len() > 1 {
                    kept.pop();
                    kept.push(p);
                }
            }
            _ => kept.push(p),
        }
    }
    let mut pieces = Vec::new();
    let mut start = 0;
    for i in 1..kept.len().saturating_sub(1) {
        let (a, b, c) = (px(kept[i - 1]), px(kept[i]), px(kept[i + 1]));
        let u = (b.0 - a.0, b.1 - a.1);
        let v = (c.0 - b.0, c.1 - b.1);
        let norms = (u.0 * u.0 + u.1 * u.1).sqrt() * (v.0 * v.0 + v.1 * v.1).sqrt();
        if norms > 0.0 && (u.0 * v.0 + u.1 * v.1) / norms < REVERSAL_COSINE {
            pieces.push(kept[start..=i].to_vec());
            start = i;
        }
    }
    pieces.push(kept[start..].to_vec());
    pieces
}

// ---------------------------------------------------------------------------------------
// Tick labels

/// How to print the tick values of one axis: fixed decimals chosen from the tick step,
/// scientific notation for very large or very small magnitudes.
#[derive(Debug, Clone, Copy)]
struct TickFormat {
    decimals: usize,
    scientific: bool,
    negate: bool,
    zero_below: f64,
}

impl TickFormat {
    fn new(ticks: &[f64], span: Span, negate: bool) -> Self {
        let step = match ticks {
            [a, b, ..] => (b - a).abs(),
            _ => (span.1 - span.0).abs() / 10.0,
        };
        let step = if step > 0.0 && step.is_finite() {
            step
        } else {
            1.0
        };
        let magnitude = span.0.abs().max(span.1.abs());
        let step_exp = step.log10().floor();
        let scientific = magnitude >= 1e6 || step < 1e-4;
        let decimals = if scientific {
            // Mantissa digits needed to tell neighbouring ticks apart.
            (magnitude.log10().floor() - step_exp).clamp(0.0, 6.0)
        } else {
            (-step_exp).clamp(0.0, 10.0)
        } as usize;
        // One more digit when the step is not a power of ten (e.g. 0.25 or 2.5).
        let mantissa = step / 10f64.powf(step_exp);
        let decimals = if (mantissa - mantissa.round()).abs() > 1e-6 {
            decimals + 1
        } else {
            decimals
        };
        Self {
            decimals,
            scientific,
            negate,
            zero_below: step * 1e-6,
        }
    }

    fn format(&self, v: f64) -> String {
        let v = if self.negate { -v } else { v };
        // Avoid "-0.0" and round-off noise such as 1e-17 at zero.
        let v = if v.abs() < self.zero_below { 0.0 } else { v };
        if self.scientific && v != 0.0 {
            format!("{:.*e}", self.decimals, v)
        } else {
            format!("{:.*}", self.decimals, v)
        }
    }
}

fn tick_values(span: Span, max_ticks: usize) -> Vec<f64> {
    RangedCoordf64::from(span.0..span.1).key_points(max_ticks)
}

fn text_width(text: &str, size: u32) -> u32 {
    (FONT, size)
        .into_font()
        .box_size(text)
        .map_or(size * text.chars().count() as u32, |(w, _)| w)
}

// ---------------------------------------------------------------------------------------
// Layout

/// Everything needed to draw one panel, decided before anything is drawn.
struct Layout {
    x: Span,
    y: Span,
    x_ticks: usize,
    y_ticks: usize,
    x_format: TickFormat,
    y_format: TickFormat,
    /// Plotting-area size in pixels.
    plot_px: (u32, u32),
    /// Width of the left label area this layout's tick labels need.
    y_area_needed: u32,
}

fn x_area_height(show_x_desc: bool) -> u32 {
    if show_x_desc {
        TICK_SIZE + DESC_SIZE + 20
    } else {
        TICK_SIZE + 14
    }
}

/// Pixel size of the plotting area plotters will produce for these label areas.
fn plotting_px<DB: DrawingBackend>(
    body: &DrawingArea<DB, Shift>,
    y_area: u32,
    x_area: u32,
) -> Result<(u32, u32), PlotError> {
    // Building a chart without a caption draws nothing; it only splits the area.
    let chart = chart_builder(body, y_area, x_area)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)
        .map_err(draw_err)?;
    Ok(chart.plotting_area().dim_in_pixel())
}

fn chart_builder<'a, 'b, DB: DrawingBackend>(
    body: &'a DrawingArea<DB, Shift>,
    y_area: u32,
    x_area: u32,
) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(body);
    builder
        .margin_top(CHART_MARGIN_TOP)
        .margin_right(CHART_MARGIN_RIGHT)
        .margin_bottom(CHART_MARGIN_BOTTOM)
        .margin_left(CHART_MARGIN_LEFT)
        .x_label_area_size(x_area)
        .y_label_area_size(y_area);
    builder
}

fn layout<DB: DrawingBackend>(
    body: &DrawingArea<DB, Shift>,
    data: &Prepared<'_>,
    y_area: u32,
    show_x_desc: bool,
) -> Result<Layout, PlotError> {
    let plot_px = plotting_px(body, y_area, x_area_height(show_x_desc))?;
    let (mut x, mut y) = (padded(data.x), padded(data.y));
    if data.plot.aspect == Aspect::Equal {
        (x, y) = equalise(x, y, plot_px);
    }
    let x_ticks = (plot_px.0 / 110).clamp(3, 12) as usize;
    let y_ticks = (plot_px.1 / 35).clamp(4, 12) as usize;
    let x_format = TickFormat::new(&tick_values(x, x_ticks), x, false);
    let y_values = tick_values(y, y_ticks);
    let y_format = TickFormat::new(&y_values, y, data.plot.invert_y);
    let widest = y_values
        .iter()
        .map(|&v| text_width(&y_format.format(v), TICK_SIZE))
        .max()
        .unwrap_or(0);
    let desc = if data.plot.y_label.is_empty() {
        0
    } else {
        DESC_SIZE
    };
    Ok(Layout {
        x,
        y,
        x_ticks,
        y_ticks,
        x_format,
        y_format,
        plot_px,
        y_area_needed: widest + desc + LABEL_GAP,
    })
}

/// Splits an area into the title strip and the chart body.
fn split_title<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
) -> (DrawingArea<DB, Shift>, DrawingArea<DB, Shift>) {
    area.split_vertically(TITLE_HEIGHT)
}

// ---------------------------------------------------------------------------------------
// Drawing

fn write_figure(plots: &[Plot], stem: &Path, size: (u32, u32)) -> Result<[PathBuf; 2], PlotError> {
    write_figure_shaded(plots, &[], stem, size)
}

fn write_figure_shaded(
    plots: &[Plot],
    shaded: &[Vec<(f64, f64)>],
    stem: &Path,
    size: (u32, u32),
) -> Result<[PathBuf; 2], PlotError> {
    ensure_fonts()?;
    if plots.is_empty() {
        return Err(PlotError::Empty {
            title: String::new(),
        });
    }
    let mut data = plots.iter().map(prepare).collect::<Result<Vec<_>, _>>()?;
    for (d, s) in data.iter_mut().zip(shaded) {
        d.shaded = s.as_slice();
    }

    let mut pixels = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, size).into_drawing_area();
        draw_figure(&root, &data)?;
        root.present().map_err(draw_err)?;
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        draw_figure(&root, &data)?;
        root.present().map_err(draw_err)?;
    }
    save_figure(stem, &pixels, size, &svg)
}

/// Writes a drawn figure: `pixels` (RGB, `size`) as `stem.png`, `svg` as
/// `stem.svg`, each whole or not at all.
fn save_figure(
    stem: &Path,
    pixels: &[u8],
    size: (u32, u32),
    svg: &str,
) -> Result<[PathBuf; 2], PlotError> {
    let png = encode_png(pixels, size)?;

    let png_path = with_suffix(stem, ".png");
    let svg_path = with_suffix(stem, ".svg");
    if let Some(dir) = stem.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|source| PlotError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    // Each file whole or not at all: a run stopped while plotting leaves no
    // half-written image under its name.
    for (path, bytes) in [(&png_path, png.as_slice()), (&svg_path, svg.as_bytes())] {
        atomic::write_atomically(path, bytes).map_err(|source| PlotError::Io {
            path: path.clone(),
            source,
        })?;
    }
    Ok([png_path, svg_path])
}

fn with_suffix(stem: &Path, suffix: &str) -> PathBuf {
    let mut name = OsString::from(stem.as_os_str());
    name.push(suffix);
    PathBuf::from(name)
}

fn encode_png(rgb: &[u8], (w, h): (u32, u32)) -> Result<Vec<u8>, PlotError> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, w, h);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(draw_err)?;
    writer.write_image_data(rgb).map_err(draw_err)?;
    writer.finish().map_err(draw_err)?;
    Ok(out)
}

fn draw_figure<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    data: &[Prepared<'_>],
) -> Result<(), PlotError> {
    root.fill(&WHITE).map_err(draw_err)?;
    let panels = root.split_evenly((data.len(), 1));
    let shared_x = data.len() > 1
        && data
            .windows(2)
            .all(|w| w[0].plot.x_label == w[1].plot.x_label);
    let show_x_desc = |i: usize| {
        let last = i + 1 == data.len();
        (!shared_x || last) && !data[i].plot.x_label.is_empty()
    };
    let bodies: Vec<_> = panels.iter().map(split_title).collect();

    // The left label area is shared by all panels so their plotting areas line up; its
    // width depends on the tick labels, which (with an equal aspect) depend on it.
    let mut y_area = 0;
    let mut layouts = Vec::new();
    for _ in 0..4 {
        layouts = data
            .iter()
            .zip(&bodies)
            .enumerate()
            .map(|(i, (d, (_, body)))| layout(body, d, y_area, show_x_desc(i)))
            .collect::<Result<Vec<_>, _>>()?;
        let needed = layouts.iter().map(|l| l.y_area_needed).max().unwrap_or(0);
        if needed <= y_area {
            break;
        }
        y_area = needed;
    }

    for (i, ((d, (title, body)), lay)) in data.iter().zip(&bodies).zip(&layouts).enumerate() {
        draw_title(title, &d.plot.title)?;
        draw_panel(body, d, lay, y_area, show_x_desc(i))?;
    }
    Ok(())
}

fn draw_title<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    title: &str,
) -> Result<(), PlotError> {
    if title.is_empty() {
        return Ok(());
    }
    let (w, h) = area.dim_in_pixel();
    // Not `.style(Bold)` on a font: in plotters 0.3.7 that keeps the regular glyphs.
    let style = TextStyle::from((FONT, TITLE_SIZE, FontStyle::Bold).into_font())
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Center));
    let centre = (
        i32::try_from(w / 2).unwrap_or(0),
        i32::try_from(h / 2).unwrap_or(0) + 4,
    );
    area.draw_text(title, &style, centre).map_err(draw_err)
}

fn draw_panel<DB: DrawingBackend>(
    body: &DrawingArea<DB, Shift>,
    data: &Prepared<'_>,
    lay: &Layout,
    y_area: u32,
    show_x_desc: bool,
) -> Result<(), PlotError> {
    let plot = data.plot;
    let mut chart = chart_builder(body, y_area, x_area_height(show_x_desc))
        .build_cartesian_2d(lay.x.0..lay.x.1, lay.y.0..lay.y.1)
        .map_err(draw_err)?;

    let x_fmt = |v: &f64| lay.x_format.format(*v);
    let y_fmt = |v: &f64| lay.y_format.format(*v);
    let mut mesh = chart.configure_mesh();
    mesh.x_labels(lay.x_ticks)
        .y_labels(lay.y_ticks)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style((FONT, TICK_SIZE))
        .axis_desc_style((FONT, DESC_SIZE))
        .bold_line_style(GRID_BOLD)
        .light_line_style(GRID_LIGHT)
        .max_light_lines(MINOR_GRID_LINES)
        .axis_style(BLACK);
    if show_x_desc {
        mesh.x_desc(plot.x_label.as_str());
    }
    if !plot.y_label.is_empty() {
        mesh.y_desc(plot.y_label.as_str());
    }
    mesh.draw().map_err(draw_err)?;

    // Shaded x intervals, clipped to the axes, under the lines.
    for &(a, b) in data.shaded {
        let (lo, hi) = (a.max(lay.x.0), b.min(lay.x.1));
        if lo.is_finite() && hi.is_finite() && lo <= hi {
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(lo, lay.y.0), (hi, lay.y.1)],
                    SHADE.filled(),
                )))
                .map_err(draw_err)?;
        }
    }

    let legend = plot.series.len() > 1;
    // Every drawn stretch (after decimation), for placing the legend.
    let mut drawn: Vec<Cow<'_, [(f64, f64)]>> = Vec::new();
    for (i, (series, runs)) in plot.series.iter().zip(&data.runs).enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let line = colour.stroke_width(LINE_WIDTH);
        if legend {
            // An empty series carries the legend entry, whatever the data look like.
            chart
                .draw_series(LineSeries::new(std::iter::empty(), line))
                .map_err(draw_err)?
                .label(series.label.as_str())
                .legend(move |(x, y)| {
                    let sample = i32::try_from(LEGEND_SAMPLE).unwrap_or(30) - 8;
                    PathElement::new(vec![(x, y), (x + sample, y)], colour.stroke_width(3))
                });
        }
        for run in runs {
            if let [p] = run.as_slice() {
                chart
                    .draw_series(std::iter::once(Circle::new(
                        *p,
                        DOT_RADIUS,
                        colour.filled(),
                    )))
                    .map_err(draw_err)?;
                drawn.push(Cow::Borrowed(run.as_slice()));
            } else {
                let points = decimate(run, lay.x, lay.plot_px.0);
                for piece in line_pieces(&points, lay) {
                    chart
                        .draw_series(LineSeries::new(piece, line))
                        .map_err(draw_err)?;
                }
                drawn.push(points);
            }
        }
    }

    if legend {
        let position = legend_corner(plot, lay, &drawn);
        chart
            .configure_series_labels()
            .position(position)
            .margin(LEGEND_MARGIN)
            .legend_area_size(LEGEND_SAMPLE)
            .label_font((FONT, LEGEND_SIZE))
            .background_style(WHITE.mix(0.9))
            .border_style(RGBColor(120, 120, 120))
            .draw()
            .map_err(draw_err)?;
    }
    Ok(())
}

/// The corner whose legend box would cover the fewest drawn points (ties: upper right,
/// upper left, lower right, lower left).
fn legend_corner(
    plot: &Plot,
    lay: &Layout,
    drawn: &[Cow<'_, [(f64, f64)]>],
) -> SeriesLabelPosition {
    let (w, h) = (f64::from(lay.plot_px.0), f64::from(lay.plot_px.1));
    let text_w = plot
        .series
        .iter()
        .map(|s| text_width(&s.label, LEGEND_SIZE))
        .max()
        .unwrap_or(0);
    // Generous estimate of plotters' legend box, plus its offset from the corner.
    let box_w = f64::from(text_w + LEGEND_SAMPLE + 3 * LEGEND_MARGIN + 10);
    let line_h = f64::from(LEGEND_SIZE) * 1.3;
    let box_h = line_h * plot.series.len() as f64 + f64::from(3 * LEGEND_MARGIN + 10);
    let corners = [
        (SeriesLabelPosition::UpperRight, true, true),
        (SeriesLabelPosition::UpperLeft, false, true),
        (SeriesLabelPosition::LowerRight, true, false),
        (SeriesLabelPosition::LowerLeft, false, false),
    ];
    let mut counts = [0usize; 4];
    for &(px, py) in drawn.iter().flat_map(|run| run.iter()) {
        // Pixel offsets from the plotting area's left and top edges.
        let dx = (px - lay.x.0) / (lay.x.1 - lay.x.0) * w;
        let dy = (lay.y.1 - py) / (lay.y.1 - lay.y.0) * h;
        for (count, &(_, right, top)) in counts.iter_mut().zip(&corners) {
            let in_x = if right { dx >= w - box_w } else { dx <= box_w };
            let in_y = if top { dy <= box_h } else { dy >= h - box_h };
            if in_x && in_y {
                *count += 1;
            }
        }
    }
    let best = (0..corners.len())
        .min_by_key(|&i| (counts[i], i))
        .unwrap_or(0);
    corners[best].0.clone()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn padded_adds_five_percent_each_side() {
        let (lo, hi) = padded((0.0, 10.0));
        assert!(
            (lo + 0.5).abs() < 1e-12 && (hi - 10.5).abs() < 1e-12,
            "{lo} {hi}"
        );
    }

    #[test]
    fn padded_handles_degenerate_spans() {
        assert_eq!(padded((0.0, 0.0)), (-1.0, 1.0));
        let (lo, hi) = padded((-20.0, -20.0));
        assert!((lo + 21.0).abs() < 1e-12 && (hi + 19.0).abs() < 1e-12);
        for span in [
            (f64::MAX, f64::MAX),
            (-f64::MAX, f64::MAX),
            (f64::MIN_POSITIVE, f64::MIN_POSITIVE),
            (5e-324, 5e-324),
            (1e6, 1e6 + 1e-9),
        ] {
            let (lo, hi) = padded(span);
            assert!(lo.is_finite() && hi.is_finite() && lo < hi, "{span:?}");
            assert!((hi - lo).is_finite(), "{span:?}");
            let (x, y) = equalise((lo, hi), (0.0, 1.0), (1000, 500));
            assert!((x.1 - x.0).is_finite() && (y.1 - y.0).is_finite() && y.0 < y.1);
        }
    }

    #[test]
    fn equalise_gives_same_units_per_pixel() {
        let (x, y) = equalise((0.0, 100.0), (0.0, 10.0), (1000, 500));
        assert!(((x.1 - x.0) / 1000.0 - (y.1 - y.0) / 500.0).abs() < 1e-12);
        assert_eq!(x, (0.0, 100.0));
        assert!((y.0 + 20.0).abs() < 1e-12 && (y.1 - 30.0).abs() < 1e-12);
        let (x, y) = equalise((0.0, 1.0), (0.0, 100.0), (1000, 500));
        assert_eq!(y, (0.0, 100.0));
        assert!(((x.1 - x.0) - 200.0).abs() < 1e-9);
    }

    #[test]
    fn lines_split_where_they_turn_back_and_drop_subpixel_steps() {
        let lay = Layout {
            x: (0.0, 10.0),
            y: (0.0, 1000.0),
            x_ticks: 5,
            y_ticks: 5,
            x_format: TickFormat::new(&[0.0, 2.0], (0.0, 10.0), false),
            y_format: TickFormat::new(&[0.0, 200.0], (0.0, 1000.0), false),
            plot_px: (1000, 200),
            y_area_needed: 0,
        };
        // Down from 1000 to 12 and straight back up between samples 0.01 s
        // (a pixel) apart: split at the bottom vertex, which both pieces keep
        // (the turn at the top is less than a right angle).
        let spike = [(1.0, 1000.0), (1.01, 12.0), (1.02, 1000.0), (2.0, 1000.0)];
        assert_eq!(
            line_pieces(&spike, &lay),
            vec![spike[..2].to_vec(), spike[1..].to_vec()]
        );
        // Points within a pixel of the last one kept go; the line's last
        // point stays.
        let steps = [
            (1.0, 500.0),
            (1.004, 501.0),
            (1.008, 502.0),
            (3.0, 500.0),
            (3.001, 500.0),
        ];
        assert_eq!(
            line_pieces(&steps, &lay),
            vec![vec![(1.0, 500.0), (3.001, 500.0)]]
        );
        // A smooth curve and a right angle are one piece, every point kept.
        let smooth: Vec<(f64, f64)> = (0..100)
            .map(|i| {
                (
                    f64::from(i) * 0.1,
                    500.0 + 400.0 * (f64::from(i) * 0.1).sin(),
                )
            })
            .collect();
        assert_eq!(line_pieces(&smooth, &lay), vec![smooth.clone()]);
        let corner = [(0.0, 0.0), (5.0, 0.0), (5.0, 500.0)];
        assert_eq!(line_pieces(&corner, &lay), vec![corner.to_vec()]);
        assert_eq!(line_pieces(&spike[..1], &lay), vec![spike[..1].to_vec()]);
    }

    #[test]
    fn decimation_keeps_extremes_and_order() {
        let n = 100_000;
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let t = f64::from(i) / f64::from(n);
                (t, (t * 50.0).sin())
            })
            .collect();
        pts[31_337].1 = 40.0; // a one-sample spike
        pts[77_777].1 = -40.0;
        let out = decimate(&pts, (0.0, 1.0), 1000);
        assert!(out.len() <= 4 * 1001, "{}", out.len());
        assert!(out.contains(&pts[31_337]) && out.contains(&pts[77_777]));
        assert_eq!(out.first(), pts.first());
        assert_eq!(out.last(), pts.last());
        assert!(out.windows(2).all(|w| w[0].0 <= w[1].0), "order kept");
        // Short stretches are drawn as they are.
        assert!(matches!(
            decimate(&pts[..100], (0.0, 1.0), 1000),
            Cow::Borrowed(_)
        ));
    }

    #[test]
    fn tick_format_uses_step_decimals() {
        let f = TickFormat::new(&[0.0, 0.5, 1.0], (0.0, 1.0), false);
        assert_eq!(f.format(0.5), "0.5");
        assert_eq!(f.format(-1e-17), "0.0");
        let f = TickFormat::new(&[0.0, 0.25], (0.0, 1.0), false);
        assert_eq!(f.format(0.75), "0.75");
        let f = TickFormat::new(&[0.0, 20.0], (0.0, 100.0), true);
        assert_eq!(f.format(-40.0), "40");
        assert_eq!(f.format(0.0), "0");
        let f = TickFormat::new(&[1e6, 2e6], (0.0, 9e6), false);
        assert_eq!(f.format(3e6), "3e6");
    }

    #[test]
    fn prepare_splits_runs_at_non_finite_points() {
        let plot = Plot {
            series: vec![Series {
                label: "s".into(),
                x: vec![0.0, 1.0, f64::NAN, 3.0, 4.0, 5.0],
                y: vec![1.0, 2.0, 3.0, f64::INFINITY, 5.0, 6.0],
            }],
            invert_y: true,
            ..Plot::default()
        };
        let p = prepare(&plot).unwrap();
        assert_eq!(
            p.runs,
            vec![vec![
                vec![(0.0, -1.0), (1.0, -2.0)],
                vec![(4.0, -5.0), (5.0, -6.0)]
            ]]
        );
        assert_eq!((p.x, p.y), ((0.0, 5.0), (-6.0, -1.0)));
    }

    /// With `Aspect::Equal` the drawn chart maps one data unit to the same number of
    /// pixels on both axes (checked through plotters' own coordinate mapping).
    #[test]
    fn equal_aspect_is_equal_in_pixels() {
        ensure_fonts().unwrap();
        let plot = Plot {
            title: "cable".into(),
            x_label: "x [m]".into(),
            y_label: "depth [m]".into(),
            series: vec![Series {
                label: "cable".into(),
                x: vec![0.0, 300.0],
                y: vec![0.0, 20.0],
            }],
            aspect: Aspect::Equal,
            invert_y: true,
        };
        let data = prepare(&plot).unwrap();
        let mut buf = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
        let root = BitMapBackend::with_buffer(&mut buf, (WIDTH, HEIGHT)).into_drawing_area();
        let (_, body) = split_title(&root);
        let lay = layout(&body, &data, 120, true).unwrap();
        let chart = chart_builder(&body, 120, x_area_height(true))
            .build_cartesian_2d(lay.x.0..lay.x.1, lay.y.0..lay.y.1)
            .unwrap();
        let o = chart.backend_coord(&(100.0, -10.0));
        let dx = chart.backend_coord(&(150.0, -10.0));
        let dy = chart.backend_coord(&(100.0, -60.0));
        let (px_x, px_y) = ((dx.0 - o.0).abs(), (dy.1 - o.1).abs());
        assert!(px_x > 50, "{px_x}");
        assert!(
            (px_x - px_y).abs() <= 1,
            "x: {px_x} px/50 m, y: {px_y} px/50 m"
        );
    }
}
