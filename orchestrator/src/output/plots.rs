//! SVG charts for the paper study: stacked panels with the legend beside the data, shared or
//! logarithmic scales, and path projections.
//!
//! Only the SVG backend of `plotters` is used, without its `ttf` feature: text is emitted as
//! SVG `<text>` and laid out by the viewer, so no font files, fontconfig or freetype are
//! needed. Each chart is rendered into a `String` and then written with [`write_atomic`].
//!
//! Legends are drawn in their own strip beside (or below) the plot area, never over data:
//! plotters' built-in series legend sits inside the plot area, so it is not used.
//!
//! Degenerate data never panics: non-finite points (and non-positive ones on a log axis)
//! break a line instead of being drawn, empty series still get their legend entry on empty
//! axes, and constant data gets a non-zero axis range.

use std::error::Error;
use std::ops::Range;
use std::path::Path;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{KeyPointHint, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::{OutputError, write_atomic};

pub use plotters::style::RGBColor;

/// How a line is drawn: solid or dashed, with its width in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stroke {
    /// A solid line of this width, px.
    Solid(u32),
    /// A dashed line of this width, px.
    Dashed(u32),
}

/// One line of a panel. Points are `(x[i], y[i])`; if the slices differ in length the extra
/// tail of the longer one is ignored.
#[derive(Debug, Clone)]
pub struct Line<'a> {
    /// Legend text; an empty label gets no legend entry.
    pub label: String,
    /// Abscissae.
    pub x: &'a [f64],
    /// Ordinates.
    pub y: &'a [f64],
    /// Line colour.
    pub colour: RGBColor,
    /// Line style.
    pub stroke: Stroke,
    /// Whether every point also gets a dot (for per-trial series).
    pub markers: bool,
}

/// One panel: axes, lines, and its legend in a strip to the right of the plot area.
#[derive(Debug, Clone, Default)]
pub struct Panel<'a> {
    /// Caption above the panel.
    pub title: String,
    /// Abscissa label with unit.
    pub x_label: String,
    /// Ordinate label with unit.
    pub y_label: String,
    /// Logarithmic y axis (values ≤ 0 are not drawn); its range is snapped to whole decades.
    pub log_y: bool,
    /// Fixed y range, to share one scale between panels; `None`: from the data.
    pub y_range: Option<Range<f64>>,
    /// Fixed x range; `None`: from the data.
    pub x_range: Option<Range<f64>>,
    /// The abscissa counts trials: integer ticks only.
    pub integer_x: bool,
    /// The lines, drawn in order (later ones on top).
    pub lines: Vec<Line<'a>>,
    /// Optional heading of the legend strip (e.g. what the colours mean).
    pub legend_title: String,
}

/// A path in 3-D for [`path_projections`], in the caller's unit.
#[derive(Debug, Clone)]
pub struct PathLine {
    /// Legend text.
    pub label: String,
    /// Points (x, y, z).
    pub points: Vec<[f64; 3]>,
    /// Line colour.
    pub colour: RGBColor,
    /// Line style.
    pub stroke: Stroke,
}

/// Upper bound on points drawn per line. A 15 s trial at 1 ms has 15 001 samples, far more
/// than a panel has pixels; without decimation a multi-panel figure is tens of megabytes.
const MAX_POINTS: usize = 1200;

/// Distinguishable colours (the "tab10" set), so that legs and schemes stay recognisable
/// when printed.
const COLOURS: [RGBColor; 10] = [
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

/// Anchors of the "viridis" map (dark purple → yellow), for ordered things such as trials:
/// a later trial is lighter, so a trend reads without the legend.
const VIRIDIS: [(f64, f64, f64); 5] = [
    (68.0, 1.0, 84.0),
    (59.0, 82.0, 139.0),
    (33.0, 145.0, 140.0),
    (94.0, 201.0, 98.0),
    (220.0, 200.0, 30.0),
];

pub(super) const FONT: &str = "sans-serif";
const TITLE_HEIGHT: u32 = 50;
/// Width of the legend strip right of each panel, px.
const LEGEND_WIDTH: u32 = 210;
/// Height of one stacked panel, px.
const PANEL_HEIGHT: u32 = 330;
/// Width of a stacked figure, px (readable at 1100 px).
const FIGURE_WIDTH: u32 = 1100;

pub(super) type DrawResult = Result<(), Box<dyn Error>>;
pub(super) type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// Colour `i` of the categorical set (legs, schemes).
pub fn colour(i: usize) -> RGBColor {
    COLOURS[i % COLOURS.len()]
}

/// Colour of item `k` of `n` ordered items (trials), dark to light.
pub fn ordered_colour(k: usize, n: usize) -> RGBColor {
    let s = if n <= 1 {
        0.0
    } else {
        k.min(n - 1) as f64 / (n - 1) as f64
    };
    let pos = s * (VIRIDIS.len() - 1) as f64;
    let i = (pos.floor() as usize).min(VIRIDIS.len() - 2);
    let f = pos - i as f64;
    let (a, b) = (VIRIDIS[i], VIRIDIS[i + 1]);
    let mix = |p: f64, q: f64| (p + (q - p) * f).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Panels stacked in one column, each with its legend strip on the right, under one title.
/// Fails with [`OutputError::Plot`] if `panels` is empty.
pub fn panels(path: &Path, title: &str, panels: &[Panel<'_>]) -> Result<(), OutputError> {
    if panels.is_empty() {
        return Err(plot_error(path, "no panels to draw"));
    }
    let size = (
        FIGURE_WIDTH,
        TITLE_HEIGHT + PANEL_HEIGHT * panels.len() as u32,
    );
    render(path, size, title, |body| {
        for (area, panel) in body.split_evenly((panels.len(), 1)).iter().zip(panels) {
            draw_panel(area, panel)?;
        }
        Ok(())
    })
}

fn draw_panel(area: &Area<'_>, p: &Panel<'_>) -> DrawResult {
    let (w, _) = area.dim_in_pixel();
    let (plot, legend) = area.split_horizontally(w.saturating_sub(LEGEND_WIDTH));
    let keep = |v: f64| v.is_finite() && (!p.log_y || v > 0.0);
    let runs: Vec<Vec<Vec<(f64, f64)>>> = p
        .lines
        .iter()
        .map(|l| {
            let pts =
                l.x.iter()
                    .zip(l.y)
                    .map(|(&x, &y)| (x, if keep(y) { y } else { f64::NAN }));
            finite_runs(pts).into_iter().map(decimate_m4).collect()
        })
        .collect();
    let points = || runs.iter().flatten().flatten();
    let x_range = match &p.x_range {
        Some(r) => r.clone(),
        None => linear_range(points().map(|q| q.0))?,
    };
    let y_given = p.y_range.clone();
    let builder = |x: Range<f64>| {
        let mut b = ChartBuilder::on(&plot);
        b.caption(&p.title, (FONT, 17))
            .margin(10)
            .x_label_area_size(42)
            .y_label_area_size(78);
        (b, x)
    };
    if p.log_y {
        let y = match y_given {
            Some(r) => r,
            None => log_range(points().map(|q| q.1))?,
        };
        let (mut b, x) = builder(x_range);
        let chart = b.build_cartesian_2d(x, LogAxis(y))?;
        draw_body(chart, p, runs, &|v| log_tick(*v))?;
    } else {
        let y = match y_given {
            Some(r) => r,
            None => linear_range(points().map(|q| q.1))?,
        };
        let decimals = tick_decimals(&y, Y_LABELS);
        let (mut b, x) = builder(x_range);
        let chart = b.build_cartesian_2d(x, y)?;
        draw_body(chart, p, runs, &|v| linear_tick(*v, decimals))?;
    }
    let entries: Vec<(&str, RGBColor, Stroke)> = p
        .lines
        .iter()
        .filter(|l| !l.label.is_empty())
        .map(|l| (l.label.as_str(), l.colour, l.stroke))
        .collect();
    draw_legend_column(&legend, &p.legend_title, &entries)
}

/// Mesh, labels and lines of a panel, shared by the linear and the logarithmic y axis.
fn draw_body<'a, 'b: 'a, Y>(
    mut chart: ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, Y>>,
    p: &Panel<'_>,
    runs: Vec<Vec<Vec<(f64, f64)>>>,
    y_format: &dyn Fn(&f64) -> String,
) -> DrawResult
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let x_range = chart.x_range();
    let x_span = x_range.end - x_range.start;
    let x_labels = if p.integer_x {
        (x_span.round() as usize + 1).min(21)
    } else {
        X_LABELS
    };
    let x_decimals = tick_decimals(&x_range, x_labels);
    let x_format = |v: &f64| {
        if p.integer_x {
            if (v - v.round()).abs() < 1e-9 {
                format!("{:.0}", v.round())
            } else {
                String::new()
            }
        } else {
            linear_tick(*v, x_decimals)
        }
    };
    chart
        .configure_mesh()
        .x_desc(p.x_label.as_str())
        .y_desc(p.y_label.as_str())
        .x_labels(x_labels)
        .y_labels(Y_LABELS)
        .x_label_formatter(&x_format)
        .y_label_formatter(y_format)
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 15))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    for (line, runs) in p.lines.iter().zip(runs) {
        let markers: Vec<(f64, f64)> = if line.markers {
            runs.iter().flatten().copied().collect()
        } else {
            Vec::new()
        };
        for run in runs {
            draw_run(&mut chart, run, line.colour, line.stroke)?;
        }
        let fill = line.colour.filled();
        chart.draw_series(markers.into_iter().map(|q| Circle::new(q, 3, fill)))?;
    }
    Ok(())
}

fn draw_run<'a, 'b: 'a, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, Y>>,
    run: Vec<(f64, f64)>,
    colour: RGBColor,
    stroke: Stroke,
) -> DrawResult
where
    Y: Ranged<ValueType = f64>,
{
    match stroke {
        Stroke::Solid(w) => {
            chart.draw_series(LineSeries::new(run, colour.stroke_width(w)))?;
        }
        Stroke::Dashed(w) => {
            chart.draw_series(DashedLineSeries::new(run, 8, 5, colour.stroke_width(w)))?;
        }
    }
    Ok(())
}

/// A legend in its own area: one row per entry (a line sample and the label), top down.
fn draw_legend_column(
    area: &Area<'_>,
    heading: &str,
    entries: &[(&str, RGBColor, Stroke)],
) -> DrawResult {
    let mut y = 40;
    if !heading.is_empty() {
        area.draw(&Text::new(
            heading.to_owned(),
            (8, y),
            (FONT, 13).into_font(),
        ))?;
        y += 20;
    }
    for &(label, c, stroke) in entries {
        legend_sample(area, (8, y + 8), c, stroke)?;
        area.draw(&Text::new(
            label.to_owned(),
            (38, y),
            (FONT, 13).into_font(),
        ))?;
        y += 20;
    }
    Ok(())
}

/// A legend in one row (below a wide figure).
fn draw_legend_row(area: &Area<'_>, entries: &[(&str, RGBColor, Stroke)]) -> DrawResult {
    let mut x = 20;
    for &(label, c, stroke) in entries {
        legend_sample(area, (x, 18), c, stroke)?;
        area.draw(&Text::new(
            label.to_owned(),
            (x + 30, 10),
            (FONT, 14).into_font(),
        ))?;
        // About 7.5 px per character at 14 px, plus the sample and a gap.
        x += 60 + (label.chars().count() as i32) * 15 / 2;
    }
    Ok(())
}

fn legend_sample(area: &Area<'_>, (x, y): (i32, i32), c: RGBColor, stroke: Stroke) -> DrawResult {
    match stroke {
        Stroke::Solid(w) => area.draw(&PathElement::new(
            vec![(x, y), (x + 24, y)],
            c.stroke_width(w.clamp(1, 4)),
        ))?,
        Stroke::Dashed(w) => area.draw(&DashedPathElement::new(
            vec![(x, y), (x + 24, y)],
            6,
            3,
            c.stroke_width(w.clamp(1, 4)),
        ))?,
    }
    Ok(())
}

/// Labelled ticks asked of plotters on a panel's linear x and y axis.
const X_LABELS: usize = 10;
const Y_LABELS: usize = 8;

/// Decimals the labels of a linear axis over `range` with at most `labels` ticks need: as
/// many as plotters' own tick step (1, 2 or 5 × 10^k, chosen from the range and the count),
/// so that ticks 0.5 or 0.05 apart are not rounded to repeated labels.
fn tick_decimals(range: &Range<f64>, labels: usize) -> usize {
    let ticks = RangedCoordf64::from(range.clone()).key_points(labels);
    let step = ticks
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    // One tick or none: enough decimals for the range itself.
    let step = if step.is_finite() && step > 0.0 {
        step
    } else {
        (range.end - range.start).abs() / 10.0
    };
    (0..=12)
        .find(|&d| {
            let s = step * 10f64.powi(d);
            (s - s.round()).abs() <= 1e-6 * s
        })
        .map_or(12, |d| d as usize)
}

/// Tick label on a linear axis with `decimals` decimals (see [`tick_decimals`]), never "-0".
fn linear_tick(v: f64, decimals: usize) -> String {
    no_negative_zero(format!("{v:.decimals$}"))
}

/// Tick label on a logarithmic axis: plain decimals from 1e-4 to 1e4, else "2e-5".
fn log_tick(v: f64) -> String {
    if !(v > 0.0 && v.is_finite()) {
        return String::new();
    }
    let exp = v.log10().floor();
    let mantissa = (v / 10f64.powf(exp) * 1e6).round() / 1e6;
    if (-4.0..=4.0).contains(&exp) {
        let decimals = (-exp).max(0.0) as usize;
        format!("{v:.decimals$}")
    } else {
        format!("{mantissa}e{exp}")
    }
}

/// A logarithmic axis whose ticks we choose: plotters' own log axis labels the next decade
/// twice and drops the lowest one when the range starts exactly on a decade. Labelled ticks
/// are 1, 2, 5 per decade over up to four decades, else decades; grid lines at 1..9 per
/// decade over up to six decades.
#[derive(Debug, Clone)]
struct LogAxis(Range<f64>);

impl Ranged for LogAxis {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;

    fn map(&self, v: &f64, limit: (i32, i32)) -> i32 {
        let (lo, hi) = (self.0.start.ln(), self.0.end.ln());
        let f = (v.ln() - lo) / (hi - lo);
        let f = if f.is_finite() {
            f.clamp(-10.0, 10.0)
        } else {
            -10.0
        };
        limit.0 + (f * f64::from(limit.1 - limit.0)).round() as i32
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        log_ticks(&self.0, hint.weight().allow_light_points())
    }

    fn range(&self) -> Range<f64> {
        self.0.clone()
    }
}

/// Tick values of a log axis over `range` (see [`LogAxis`]); `grid` asks for grid lines.
fn log_ticks(range: &Range<f64>, grid: bool) -> Vec<f64> {
    let (lo, hi) = (range.start, range.end);
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    let (first, last) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let decades = (hi / lo).log10();
    let mantissas: &[f64] = match (grid, decades) {
        (true, d) if d <= 6.5 => &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
        (false, d) if d <= 4.5 => &[1.0, 2.0, 5.0],
        _ => &[1.0],
    };
    let every = if decades > 12.0 { 2 } else { 1 };
    let mut out = Vec::new();
    for e in (first..=last).filter(|e| (e - first) % every == 0) {
        for m in mantissas {
            // Parse the decimal literal so a tick is exactly "0.002", not 2 × 0.001.
            let v: f64 = format!("{m}e{e}").parse().unwrap_or(f64::NAN);
            if v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9) {
                out.push(v);
            }
        }
    }
    out
}

fn no_negative_zero(s: String) -> String {
    match s.strip_prefix('-') {
        Some(rest) if rest.chars().all(|c| c == '0' || c == '.') => rest.to_owned(),
        _ => s,
    }
}

/// Desired vs actual path in three projections side by side (x–y, x–z, y–z), axes in
/// `unit` (the caller converts, and magnifies errors if it wants them visible). The x–y axes
/// span the same length, so a circle looks like a circle. `on_top` (the desired
/// path) is drawn after `paths`, so it stays visible; the legend is a row below the panels.
pub fn path_projections(
    path: &Path,
    title: &str,
    paths: &[PathLine],
    on_top: &PathLine,
    unit: &str,
) -> Result<(), OutputError> {
    const AXES: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];
    const NAMES: [&str; 3] = ["x", "y", "z"];
    render(path, (1500, TITLE_HEIGHT + 520), title, |body| {
        let (h_body, _) = (body.dim_in_pixel().1, ());
        let (main, legend) = body.split_vertically(h_body.saturating_sub(40));
        let all: Vec<&PathLine> = paths.iter().chain([on_top]).collect();
        for (area, &(a, b)) in main.split_evenly((1, 3)).iter().zip(&AXES) {
            let runs: Vec<Vec<Vec<(f64, f64)>>> = all
                .iter()
                .map(|l| {
                    finite_runs(l.points.iter().map(|p| (p[a], p[b])))
                        .into_iter()
                        .map(decimate_stride)
                        .collect()
                })
                .collect();
            let pts = || runs.iter().flatten().flatten();
            let (x_range, y_range) = (
                linear_range(pts().map(|p| p.0))?,
                linear_range(pts().map(|p| p.1))?,
            );
            // True shape in the x–y plane; the panels with z are stretched in z, where the
            // paths are flat, so that the height error shows.
            let (x_range, y_range) = if (a, b) == (0, 1) {
                equal_ranges(x_range, y_range)
            } else {
                (x_range, y_range)
            };
            const LABELS: usize = 6;
            let (x_decimals, y_decimals) = (
                tick_decimals(&x_range, LABELS),
                tick_decimals(&y_range, LABELS),
            );
            let mut chart = ChartBuilder::on(area)
                .caption(format!("{}–{} projection", NAMES[a], NAMES[b]), (FONT, 17))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(x_range, y_range)?;
            let x_fmt = |v: &f64| linear_tick(*v, x_decimals);
            let y_fmt = |v: &f64| linear_tick(*v, y_decimals);
            chart
                .configure_mesh()
                .x_desc(format!("{} [{unit}]", NAMES[a]))
                .y_desc(format!("{} [{unit}]", NAMES[b]))
                .x_labels(LABELS)
                .y_labels(LABELS)
                .x_label_formatter(&x_fmt)
                .y_label_formatter(&y_fmt)
                .label_style((FONT, 13))
                .axis_desc_style((FONT, 15))
                .light_line_style(RGBColor(235, 235, 235))
                .draw()?;
            for (l, runs) in all.iter().zip(runs) {
                for run in runs {
                    draw_run(&mut chart, run, l.colour, l.stroke)?;
                }
            }
        }
        let entries: Vec<(&str, RGBColor, Stroke)> = all
            .iter()
            .map(|l| (l.label.as_str(), l.colour, l.stroke))
            .collect();
        draw_legend_row(&legend, &entries)
    })
}

/// Renders a titled chart into memory, then writes it atomically. `draw` gets the area below
/// the title.
pub(super) fn render<F>(
    path: &Path,
    size: (u32, u32),
    title: &str,
    draw: F,
) -> Result<(), OutputError>
where
    F: FnOnce(&Area<'_>) -> DrawResult,
{
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        let drawn: DrawResult = (|| {
            root.fill(&WHITE)?;
            let body = root.titled(title, (FONT, 24))?;
            draw(&body)?;
            root.present()?;
            Ok(())
        })();
        drawn.map_err(|e| plot_error(path, &e.to_string()))?;
    }
    write_atomic(path, |w| w.write_all(svg.as_bytes()))
}

fn plot_error(path: &Path, message: &str) -> OutputError {
    OutputError::Plot {
        path: path.to_owned(),
        message: message.to_owned(),
    }
}

/// Splits a sequence of points into maximal runs of finite points: a NaN or infinity in
/// either coordinate ends the current line instead of being drawn at a bogus pixel.
pub(super) fn finite_runs(points: impl Iterator<Item = (f64, f64)>) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut current = Vec::new();
    for p in points {
        if p.0.is_finite() && p.1.is_finite() {
            current.push(p);
        } else if !current.is_empty() {
            runs.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        runs.push(current);
    }
    runs
}

/// Reduces a time series to at most about [`MAX_POINTS`] points, keeping in every bucket its
/// first, lowest, highest and last point (the "M4" scheme): the drawn line is visually the
/// same, and short spikes survive, unlike plain subsampling.
fn decimate_m4(run: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if run.len() <= MAX_POINTS {
        return run;
    }
    let bucket = run.len().div_ceil(MAX_POINTS / 4);
    let mut out = Vec::with_capacity(MAX_POINTS + 4);
    for chunk in run.chunks(bucket) {
        let by_y = |a: &(usize, &(f64, f64)), b: &(usize, &(f64, f64))| a.1.1.total_cmp(&b.1.1);
        let lowest = chunk.iter().enumerate().min_by(by_y).map_or(0, |(i, _)| i);
        let highest = chunk.iter().enumerate().max_by(by_y).map_or(0, |(i, _)| i);
        let mut keep = [0, lowest, highest, chunk.len() - 1];
        keep.sort_unstable();
        let mut last = None;
        for i in keep {
            if last != Some(i) {
                out.push(chunk[i]);
                last = Some(i);
            }
        }
    }
    out
}

/// Reduces a path (not a function of x) by keeping every n-th point plus the last one; the
/// paths are smooth at the 1 ms sampling, so this is visually lossless.
fn decimate_stride(run: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    if run.len() <= MAX_POINTS {
        return run;
    }
    let step = run.len().div_ceil(MAX_POINTS - 1);
    let mut out: Vec<(f64, f64)> = run.iter().step_by(step).copied().collect();
    if (run.len() - 1) % step != 0 {
        out.extend(run.last());
    }
    out
}

/// Axis range covering all finite `values` with a 5 % margin. Constant data gets ±10 % of
/// its magnitude (±1 around zero); no data gets 0..1. Fails only if the range overflows.
fn linear_range(values: impl Iterator<Item = f64>) -> Result<Range<f64>, Box<dyn Error>> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return Ok(0.0..1.0);
    }
    let scale = lo.abs().max(hi.abs());
    let span = hi - lo;
    let pad = if span > scale * 1e-9 {
        span * 0.05
    } else {
        scale * 0.1
    };
    // Zero data, or a subnormal constant whose tenth underflows to zero.
    let pad = if pad > 0.0 { pad } else { 1.0 };
    let range = (lo - pad)..(hi + pad);
    if range.start.is_finite() && range.end.is_finite() {
        Ok(range)
    } else {
        Err(format!("data range {lo:e}..{hi:e} is too large to draw").into())
    }
}

/// Like [`linear_range`] for a logarithmic axis: only positive finite values count, and the
/// range is widened to whole decades so the lowest and highest data have a labelled decade
/// below and above them. No data gets 0.1..10.
fn log_range(values: impl Iterator<Item = f64>) -> Result<Range<f64>, Box<dyn Error>> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return Ok(0.1..10.0);
    }
    let start = 10f64.powf(lo.log10().floor());
    let mut end = 10f64.powf(hi.log10().ceil());
    if end <= start {
        end = start * 10.0;
    }
    if start > 0.0 && end.is_finite() {
        Ok(start..end)
    } else {
        Err(format!("data range {lo:e}..{hi:e} is too large to draw").into())
    }
}

/// Widens the shorter of two ranges about its centre so both have the same length.
fn equal_ranges(x: Range<f64>, y: Range<f64>) -> (Range<f64>, Range<f64>) {
    let half = (x.end - x.start).max(y.end - y.start) / 2.0;
    let centre = |r: &Range<f64>| r.start / 2.0 + r.end / 2.0;
    let (cx, cy) = (centre(&x), centre(&y));
    ((cx - half)..(cx + half), (cy - half)..(cy + half))
}

#[cfg(test)]
mod tests {
    use super::*;
    use quick_xml::Reader;
    use quick_xml::events::Event;

    /// Parses `svg` as XML (failing on malformed markup) and returns the content of every
    /// `<text>` element with entities resolved.
    fn svg_texts(svg: &str) -> Vec<String> {
        assert!(svg.starts_with("<svg"), "{}", &svg[..svg.len().min(80)]);
        let mut reader = Reader::from_str(svg);
        let mut texts = Vec::new();
        let mut current: Option<String> = None;
        loop {
            match reader.read_event().expect("well-formed SVG") {
                Event::Start(e) if e.name().as_ref() == "text" => current = Some(String::new()),
                Event::End(e) if e.name().as_ref() == "text" => {
                    texts.push(current.take().unwrap().trim().to_owned());
                }
                Event::Text(t) => {
                    if let Some(c) = &mut current {
                        c.push_str(&t.xml10_content());
                    }
                }
                Event::GeneralRef(r) => {
                    if let Some(c) = &mut current {
                        c.push(match r.xml10_content().as_ref() {
                            "lt" => '<',
                            "gt" => '>',
                            "amp" => '&',
                            "quot" => '"',
                            "apos" => '\'',
                            other => panic!("unexpected entity {other}"),
                        });
                    }
                }
                Event::Eof => break,
                _ => {}
            }
        }
        texts
    }

    fn read_texts(path: &Path) -> Vec<String> {
        svg_texts(&std::fs::read_to_string(path).unwrap())
    }

    fn assert_has(texts: &[String], wanted: &[&str]) {
        for w in wanted {
            assert!(
                texts.iter().any(|t| t == w),
                "missing text {w:?} in {texts:?}"
            );
        }
    }

    fn line<'a>(label: &str, x: &'a [f64], y: &'a [f64], i: usize) -> Line<'a> {
        Line {
            label: label.to_owned(),
            x,
            y,
            colour: colour(i),
            stroke: Stroke::Solid(1),
            markers: false,
        }
    }

    #[test]
    fn panels_render_titles_labels_and_legend_beside_the_data() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fig.svg");
        let t: Vec<f64> = (0..=15_000).map(|i| f64::from(i) * 1e-3).collect();
        let ys: Vec<Vec<f64>> = (0..6)
            .map(|k| t.iter().map(|&s| (s + f64::from(k)).sin()).collect())
            .collect();
        let abs: Vec<f64> = ys[0].iter().map(|v| v.abs() + 1e-4).collect();
        let lines: Vec<Line<'_>> = ys
            .iter()
            .enumerate()
            .map(|(i, y)| line(&format!("leg {}", i + 1), &t, y, i))
            .collect();
        let figure = [
            Panel {
                title: "signed".into(),
                x_label: "time [s]".into(),
                y_label: "leg error [mm]".into(),
                lines,
                ..Panel::default()
            },
            Panel {
                title: "log".into(),
                x_label: "time [s]".into(),
                y_label: "|e| [mm]".into(),
                log_y: true,
                lines: vec![line("envelope", &t, &abs, 0)],
                legend_title: "trial".into(),
                ..Panel::default()
            },
        ];
        panels(&path, "PID-HLCS <line> & co", &figure).unwrap();
        let texts = read_texts(&path);
        assert_has(
            &texts,
            &[
                "PID-HLCS <line> & co",
                "signed",
                "log",
                "leg 1",
                "leg 6",
                "envelope",
                "trial",
                "time [s]",
                "leg error [mm]",
                "0.0001",
                "0.001",
                "1",
            ],
        );
        assert!(
            texts
                .iter()
                .all(|t| !t.starts_with("-0") || t.parse::<f64>().is_ok_and(|v| v != 0.0)),
            "{texts:?}"
        );
        // Six lines of 15 001 samples in two panels must be decimated to a reasonable file.
        let size = std::fs::metadata(&path).unwrap().len();
        assert!(size < 1_000_000, "SVG is {size} bytes");
        assert!(matches!(
            panels(&path, "none", &[]).unwrap_err(),
            OutputError::Plot { .. }
        ));
    }

    #[test]
    fn panels_survive_degenerate_data() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("deg.svg");
        let t = [0.0, 0.001, 0.002, 0.003];
        let empty: [f64; 0] = [];
        let constant = [2.5; 4];
        let nan = [f64::NAN, 1.0, f64::NAN, 2.0];
        let inf = [f64::INFINITY, f64::NEG_INFINITY, f64::NAN, f64::NAN];
        let tiny = [1e-300; 4];
        let zeros = [0.0, -1.0, 0.0, -2.0];
        let panel = |title: &str, log_y: bool, lines: Vec<Line<'static>>| Panel {
            title: title.into(),
            log_y,
            lines,
            ..Panel::default()
        };
        let leak = |v: &[f64]| -> &'static [f64] { Box::leak(v.to_vec().into_boxed_slice()) };
        let figure = vec![
            panel(
                "empty",
                false,
                vec![line("e", leak(&empty), leak(&empty), 0)],
            ),
            panel(
                "constant",
                false,
                vec![line("c", leak(&t), leak(&constant), 0)],
            ),
            panel("nan", true, vec![line("n", leak(&t), leak(&nan), 0)]),
            panel("inf", false, vec![line("i", leak(&t), leak(&inf), 0)]),
            panel("tiny", true, vec![line("t", leak(&t), leak(&tiny), 0)]),
            panel(
                "not positive",
                true,
                vec![line("z", leak(&t), leak(&zeros), 0)],
            ),
            panel(
                "short x",
                false,
                vec![line("s", leak(&t[..1]), leak(&nan), 0)],
            ),
            panel("no series", false, vec![]),
        ];
        panels(&path, "degenerate", &figure).unwrap();
        assert_has(
            &read_texts(&path),
            &["empty", "e", "constant", "nan", "n", "i", "z", "no series"],
        );
        let huge = [f64::MAX, -f64::MAX];
        let huge_panel = vec![panel(
            "huge",
            false,
            vec![line("h", leak(&t[..2]), leak(&huge), 0)],
        )];
        let err = panels(&path, "huge", &huge_panel).unwrap_err();
        assert!(err.to_string().contains("too large"), "{err}");
        assert!(err.to_string().contains("deg.svg"), "{err}");
        // The failed plot left the earlier good file in place.
        assert_has(&read_texts(&path), &["degenerate"]);
    }

    #[test]
    fn per_trial_panels_have_integer_ticks() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fig8.svg");
        let k: Vec<f64> = (0..10).map(f64::from).collect();
        let y: Vec<f64> = (0..10).map(|i| 2.2 * 0.3f64.powi(i)).collect();
        let mut l = line("HLCS", &k, &y, 0);
        l.markers = true;
        let figure = [Panel {
            title: "convergence".into(),
            x_label: "trial".into(),
            y_label: "ρ-norm [mm]".into(),
            log_y: true,
            integer_x: true,
            x_range: Some(-0.5..9.5),
            lines: vec![l],
            ..Panel::default()
        }];
        panels(&path, "Convergence", &figure).unwrap();
        let texts = read_texts(&path);
        assert_has(
            &texts,
            &[
                "Convergence",
                "ρ-norm [mm]",
                "trial",
                "HLCS",
                "0",
                "9",
                "1e-5",
            ],
        );
        assert!(!texts.iter().any(|t| t == "0.5" || t == "8.5"), "{texts:?}");
    }

    /// Ticks 0.5 s and 0.05 mm apart, as on the circle's leg-error panels, are labelled
    /// with the decimals of their step: every label distinct and equal to its tick's value.
    #[test]
    fn linear_tick_labels_show_their_step() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("legs.svg");
        let t: Vec<f64> = (600..=5000).map(|i| f64::from(i) * 1e-3).collect();
        let e: Vec<f64> = t
            .iter()
            .map(|t| 0.17 * (std::f64::consts::TAU * 6.0 * t).sin())
            .collect();
        let figure = [Panel {
            title: "leg errors".into(),
            lines: vec![line("leg 1", &t, &e, 0)],
            ..Panel::default()
        }];
        panels(&path, "Ticks", &figure).unwrap();
        let labels: Vec<String> = read_texts(&path)
            .into_iter()
            .filter(|s| s.parse::<f64>().is_ok())
            .collect();
        let mut distinct = labels.clone();
        distinct.sort();
        distinct.dedup();
        assert_eq!(distinct.len(), labels.len(), "repeated labels: {labels:?}");
        for (values, n) in [(&t, X_LABELS), (&e, Y_LABELS)] {
            let range = linear_range(values.iter().copied()).unwrap();
            let ticks = RangedCoordf64::from(range).key_points(n);
            assert!(ticks.len() >= 5, "{ticks:?}");
            for v in ticks {
                assert!(
                    labels
                        .iter()
                        .any(|l| (l.parse::<f64>().unwrap() - v).abs() < 1e-9),
                    "tick {v} has no label equal to it: {labels:?}"
                );
            }
        }
    }

    #[test]
    fn tick_labels_are_clean() {
        assert_eq!(linear_tick(-0.0001, 1), "0.0");
        assert_eq!(linear_tick(-0.5, 1), "-0.5");
        assert_eq!(tick_decimals(&(0.0..400.0), X_LABELS), 0);
        assert_eq!(tick_decimals(&(78.0..84.0), Y_LABELS), 0);
        assert_eq!(tick_decimals(&(0.38..5.02), X_LABELS), 1);
        assert_eq!(tick_decimals(&(-0.19..0.19), Y_LABELS), 2);
        assert_eq!(log_tick(0.001), "0.001");
        assert_eq!(log_tick(0.002), "0.002");
        assert_eq!(log_tick(2e-5), "2e-5");
        assert_eq!(log_tick(100.0), "100");
        assert_eq!(
            log_ticks(&(1e-3..1.0), false),
            vec![0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0]
        );
        assert_eq!(
            log_ticks(&(1e-6..1.0), false),
            vec![1e-6, 1e-5, 1e-4, 1e-3, 1e-2, 0.1, 1.0]
        );
        assert_eq!(log_ticks(&(0.1..1.0), true).len(), 10);
        assert!(log_ticks(&(0.0..1.0), false).is_empty());
    }

    #[test]
    fn path_projections_render_three_views_and_the_desired_path_last() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fig7d.svg");
        let circle: Vec<[f64; 3]> = (0..5001)
            .map(|i| {
                let th = std::f64::consts::TAU * f64::from(i) / 5000.0;
                [200.0 * th.sin(), 200.0 - 200.0 * th.cos(), 500.0]
            })
            .collect();
        let shifted: Vec<[f64; 3]> = circle
            .iter()
            .map(|p| [p[0] + 1.0, p[1], p[2] - 0.5])
            .collect();
        let pl = |label: &str, points: Vec<[f64; 3]>, i: usize| PathLine {
            label: label.into(),
            points,
            colour: colour(i),
            stroke: Stroke::Solid(2),
        };
        let actual = vec![pl("PID", shifted, 0), pl("HLCS", circle.clone(), 1)];
        let desired = PathLine {
            stroke: Stroke::Dashed(1),
            ..pl("desired", circle, 2)
        };
        path_projections(&path, "Circle", &actual, &desired, "mm").unwrap();
        assert_has(
            &read_texts(&path),
            &[
                "Circle",
                "desired",
                "PID",
                "HLCS",
                "x–y projection",
                "x–z projection",
                "y–z projection",
                "x [mm]",
                "z [mm]",
            ],
        );
        let empty = PathLine {
            label: "none".into(),
            points: vec![[f64::NAN; 3], [0.0, 0.0, 0.5]],
            colour: colour(0),
            stroke: Stroke::Solid(1),
        };
        path_projections(&path, "point", &[], &empty, "m").unwrap();
        assert_has(&read_texts(&path), &["point", "none"]);
    }

    #[test]
    fn ordered_colours_run_dark_to_light() {
        let lum = |c: RGBColor| u32::from(c.0) + u32::from(c.1) + u32::from(c.2);
        let cs: Vec<RGBColor> = (0..10).map(|k| ordered_colour(k, 10)).collect();
        assert!(cs.windows(2).all(|w| lum(w[0]) <= lum(w[1])), "{cs:?}");
        assert_eq!(ordered_colour(0, 1), ordered_colour(0, 10));
    }

    #[test]
    fn finite_runs_split_at_gaps() {
        let pts = [
            (0.0, 1.0),
            (1.0, f64::NAN),
            (2.0, 2.0),
            (3.0, 3.0),
            (f64::INFINITY, 0.0),
        ];
        assert_eq!(
            finite_runs(pts.into_iter()),
            vec![vec![(0.0, 1.0)], vec![(2.0, 2.0), (3.0, 3.0)]]
        );
    }

    #[test]
    fn m4_decimation_bounds_points_and_keeps_spikes_and_ends() {
        let mut run: Vec<(f64, f64)> = (0..100_000).map(|i| (f64::from(i), 0.0)).collect();
        run[54_321].1 = 10.0;
        run[77_777].1 = -3.0;
        let out = decimate_m4(run.clone());
        assert!(out.len() <= MAX_POINTS + 4, "{}", out.len());
        assert!(out.contains(&(54_321.0, 10.0)));
        assert!(out.contains(&(77_777.0, -3.0)));
        assert_eq!(out.first(), run.first());
        assert_eq!(out.last(), run.last());
        assert!(out.windows(2).all(|w| w[0].0 < w[1].0), "order kept");
    }

    #[test]
    fn stride_decimation_keeps_ends() {
        let run: Vec<(f64, f64)> = (0..10_001).map(|i| (f64::from(i), 1.0)).collect();
        let out = decimate_stride(run.clone());
        assert!(out.len() <= MAX_POINTS + 1, "{}", out.len());
        assert_eq!(out.first(), run.first());
        assert_eq!(out.last(), run.last());
        let short: Vec<(f64, f64)> = run[..10].to_vec();
        assert_eq!(decimate_stride(short.clone()), short);
    }

    #[test]
    fn ranges_have_margins_and_handle_degenerate_input() {
        let r = linear_range([0.0, 10.0].into_iter()).unwrap();
        assert_eq!(r, -0.5..10.5);
        assert_eq!(linear_range(std::iter::empty()).unwrap(), 0.0..1.0);
        assert_eq!(linear_range([0.0, 0.0].into_iter()).unwrap(), -1.0..1.0);
        let sub = linear_range([5e-324].into_iter()).unwrap();
        assert!(sub.start < 5e-324 && sub.end > 5e-324);
        let c = linear_range([5.0, f64::NAN].into_iter()).unwrap();
        assert!(c.start < 5.0 && c.end > 5.0);
        assert!(linear_range([f64::MAX, -f64::MAX].into_iter()).is_err());
        let l = log_range([0.0, -1.0, 1.7e-3, 3.2].into_iter()).unwrap();
        assert_eq!(l, 1e-3..10.0);
        assert_eq!(log_range([1.0].into_iter()).unwrap(), 1.0..10.0);
        assert_eq!(log_range([-1.0].into_iter()).unwrap(), 0.1..10.0);
        assert!(log_range([5e-324, f64::MAX].into_iter()).is_err());
        let (x, y) = equal_ranges(0.0..2.0, 10.0..11.0);
        assert_eq!((x, y), (0.0..2.0, 9.5..11.5));
    }
}
