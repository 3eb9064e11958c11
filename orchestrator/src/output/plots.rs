//! SVG charts in the style of the paper's Figures 6, 7 and 8.
//!
//! Only the SVG backend of `plotters` is used, without its `ttf` feature: text is emitted as
//! SVG `<text>` and laid out by the viewer, so no font files, fontconfig or freetype are
//! needed. Each chart is rendered into a `String` and then written with
//! [`write_atomic`].
//!
//! Degenerate data never panics: non-finite points break a line instead of being drawn,
//! empty series still get their legend entry on empty axes, and constant data gets a
//! non-zero axis range.

use std::error::Error;
use std::ops::Range;
use std::path::Path;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::{OutputError, write_atomic};

/// A series for a line chart. Points are `(x[i], y[i])`; if the slices differ in length the
/// extra tail of the longer one is ignored.
#[derive(Debug, Clone)]
pub struct Series<'a> {
    /// Legend text.
    pub label: String,
    /// Abscissae.
    pub x: &'a [f64],
    /// Ordinates.
    pub y: &'a [f64],
}

/// Upper bound on points drawn per line. A 15 s trial at 1 ms has 15 001 samples, far more
/// than a panel has pixels; without decimation a five-panel figure is tens of megabytes.
const MAX_POINTS: usize = 2000;

/// Distinguishable colours (the "tab10" set), so that leg 1..6 and the schemes stay
/// recognisable when printed.
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

pub(super) const FONT: &str = "sans-serif";
const TITLE_HEIGHT: u32 = 50;

pub(super) type DrawResult = Result<(), Box<dyn Error>>;
pub(super) type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type Chart2d<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

pub(super) fn colour(i: usize) -> RGBColor {
    COLOURS[i % COLOURS.len()]
}

/// Figure 6a–c / 7a–c style: leg errors vs time. One panel per entry of `panels`, each with
/// its own title, its series (typically leg 1..6, already in mm) in their own colours with a
/// legend, and the axis labels `time [s]` and `leg error [mm]`. Each panel has its own y
/// range, because errors of different schemes or trials differ by orders of magnitude.
///
/// Up to three panels are stacked in one column, more go into two columns.
/// Fails with [`OutputError::Plot`] if `panels` is empty.
pub fn leg_errors(
    path: &Path,
    title: &str,
    panels: &[(String, Vec<Series<'_>>)],
) -> Result<(), OutputError> {
    if panels.is_empty() {
        return Err(plot_error(path, "no panels to draw"));
    }
    let cols = if panels.len() <= 3 { 1 } else { 2 };
    let rows = panels.len().div_ceil(cols);
    let size = (1000, TITLE_HEIGHT + 320 * rows as u32);
    render(path, size, title, |body| {
        for (area, (panel_title, series)) in body.split_evenly((rows, cols)).iter().zip(panels) {
            draw_time_panel(area, panel_title, series)?;
        }
        Ok(())
    })
}

fn draw_time_panel(area: &Area<'_>, panel_title: &str, series: &[Series<'_>]) -> DrawResult {
    let runs: Vec<Vec<Vec<(f64, f64)>>> = series
        .iter()
        .map(|s| {
            finite_runs(s.x.iter().copied().zip(s.y.iter().copied()))
                .into_iter()
                .map(decimate_m4)
                .collect()
        })
        .collect();
    let points = || runs.iter().flatten().flatten();
    let x_range = linear_range(points().map(|p| p.0))?;
    let y_range = linear_range(points().map(|p| p.1))?;
    let mut chart = cartesian(
        area,
        panel_title,
        x_range,
        y_range,
        "time [s]",
        "leg error [mm]",
    )?;
    for (i, (s, runs)) in series.iter().zip(runs).enumerate() {
        draw_line(&mut chart, runs, &s.label, colour(i).stroke_width(1))?;
    }
    draw_legend(&mut chart, SeriesLabelPosition::UpperRight)
}

/// Figure 6d / 7d style: desired vs actual path in three projections side by side (x–y, x–z,
/// y–z), axes labelled in `unit` (the caller converts the points). `desired` is drawn dashed
/// black, each actual path in its own colour; all appear in the legend. Both axes of a panel
/// span the same length and the plot areas are nearly square, so a circle looks like a
/// circle (and a path flat in z looks flat: true shape, not magnified errors).
pub fn path_projections(
    path: &Path,
    title: &str,
    desired: &[[f64; 3]],
    actual: &[(String, Vec<[f64; 3]>)],
    unit: &str,
) -> Result<(), OutputError> {
    const AXES: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];
    const NAMES: [&str; 3] = ["x", "y", "z"];
    render(path, (1500, TITLE_HEIGHT + 480), title, |body| {
        for (area, &(a, b)) in body.split_evenly((1, 3)).iter().zip(&AXES) {
            let project = |pts: &[[f64; 3]]| -> Vec<Vec<(f64, f64)>> {
                finite_runs(pts.iter().map(|p| (p[a], p[b])))
                    .into_iter()
                    .map(decimate_stride)
                    .collect()
            };
            let desired_runs = project(desired);
            let actual_runs: Vec<_> = actual.iter().map(|(_, pts)| project(pts)).collect();
            let all = || {
                desired_runs
                    .iter()
                    .chain(actual_runs.iter().flatten())
                    .flatten()
            };
            let (x_range, y_range) = equal_ranges(
                linear_range(all().map(|p| p.0))?,
                linear_range(all().map(|p| p.1))?,
            );
            let panel_title = format!("{}–{} projection", NAMES[a], NAMES[b]);
            let x_label = format!("{} [{unit}]", NAMES[a]);
            let y_label = format!("{} [{unit}]", NAMES[b]);
            let mut chart = cartesian(area, &panel_title, x_range, y_range, &x_label, &y_label)?;
            draw_dashed(&mut chart, desired_runs, "desired")?;
            for (i, ((label, _), runs)) in actual.iter().zip(actual_runs).enumerate() {
                draw_line(&mut chart, runs, label, colour(i).stroke_width(2))?;
            }
            draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        }
        Ok(())
    })
}

/// Figure 8 style: a norm of the error vs trial number, one line with markers per scheme.
/// Entry `k` of each vector is trial `k` (the first trial is 0). With `log_y` the y axis is
/// logarithmic and values `<= 0` (which it cannot show) are skipped like non-finite ones.
pub fn convergence(
    path: &Path,
    title: &str,
    y_label: &str,
    series: &[(String, Vec<f64>)],
    log_y: bool,
) -> Result<(), OutputError> {
    let keep = |v: f64| v.is_finite() && (!log_y || v > 0.0);
    let runs: Vec<Vec<Vec<(f64, f64)>>> = series
        .iter()
        .map(|(_, ys)| {
            finite_runs(
                ys.iter()
                    .enumerate()
                    .map(|(k, &y)| (k as f64, if keep(y) { y } else { f64::NAN })),
            )
        })
        .collect();
    let trials = series
        .iter()
        .map(|(_, ys)| ys.len())
        .max()
        .unwrap_or(0)
        .max(1);
    let x_range = -0.5..trials as f64 - 0.5;
    let ys = || runs.iter().flatten().flatten().map(|p| p.1);
    let y_range = if log_y {
        log_range(ys())
    } else {
        linear_range(ys())
    }
    .map_err(|e| plot_error(path, &e.to_string()))?;
    render(path, (900, TITLE_HEIGHT + 550), title, |body| {
        let labels: Vec<&str> = series.iter().map(|(l, _)| l.as_str()).collect();
        if log_y {
            let chart = ChartBuilder::on(body)
                .margin(15)
                .x_label_area_size(45)
                .y_label_area_size(80)
                .build_cartesian_2d(x_range, y_range.log_scale())?;
            draw_convergence(chart, &labels, runs, trials, y_label)
        } else {
            let chart = ChartBuilder::on(body)
                .margin(15)
                .x_label_area_size(45)
                .y_label_area_size(80)
                .build_cartesian_2d(x_range, y_range)?;
            draw_convergence(chart, &labels, runs, trials, y_label)
        }
    })
}

/// The part of [`convergence`] shared by the linear and the logarithmic y axis.
fn draw_convergence<'a, 'b: 'a, Y>(
    mut chart: ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, Y>>,
    labels: &[&str],
    runs: Vec<Vec<Vec<(f64, f64)>>>,
    trials: usize,
    y_label: &str,
) -> DrawResult
where
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_desc("trial")
        .y_desc(y_label)
        .x_labels(trials.min(20) + 1)
        .x_label_formatter(&|v| format!("{v:.0}"))
        .label_style((FONT, 14))
        .axis_desc_style((FONT, 16))
        .draw()?;
    for (i, (label, runs)) in labels.iter().zip(runs).enumerate() {
        let style = colour(i).stroke_width(2);
        let markers: Vec<(f64, f64)> = runs.iter().flatten().copied().collect();
        draw_line(&mut chart, runs, label, style)?;
        chart.draw_series(
            markers
                .into_iter()
                .map(|p| Circle::new(p, 4, style.filled())),
        )?;
    }
    // Errors fall from the upper left, so the lower left is usually free.
    draw_legend(&mut chart, SeriesLabelPosition::LowerLeft)
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
            let body = root.titled(title, (FONT, 26))?;
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

fn cartesian<'a, 'b>(
    area: &'a Area<'b>,
    caption: &str,
    x_range: Range<f64>,
    y_range: Range<f64>,
    x_label: &str,
    y_label: &str,
) -> Result<Chart2d<'a, 'b>, Box<dyn Error>> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x_range, y_range)?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 15))
        .draw()?;
    Ok(chart)
}

/// Draws the runs of one series as separate polylines (so gaps stay gaps) with one legend
/// entry, which is added even when there is nothing to draw.
fn draw_line<'a, 'b: 'a, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, Y>>,
    runs: Vec<Vec<(f64, f64)>>,
    label: &str,
    style: ShapeStyle,
) -> DrawResult
where
    Y: Ranged<ValueType = f64>,
{
    let mut runs = runs.into_iter();
    chart
        .draw_series(LineSeries::new(runs.next().unwrap_or_default(), style))?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], style));
    for run in runs {
        chart.draw_series(LineSeries::new(run, style))?;
    }
    Ok(())
}

fn draw_dashed(chart: &mut Chart2d<'_, '_>, runs: Vec<Vec<(f64, f64)>>, label: &str) -> DrawResult {
    let style = BLACK.stroke_width(2);
    let mut runs = runs.into_iter();
    chart
        .draw_series(DashedLineSeries::new(
            runs.next().unwrap_or_default(),
            8,
            5,
            style,
        ))?
        .label(label)
        .legend(move |(x, y)| DashedPathElement::new(vec![(x, y), (x + 20, y)], 6, 3, style));
    for run in runs {
        chart.draw_series(DashedLineSeries::new(run, 8, 5, style))?;
    }
    Ok(())
}

fn draw_legend<'a, 'b: 'a, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, Y>>,
    position: SeriesLabelPosition,
) -> DrawResult
where
    Y: Ranged<ValueType = f64>,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT, 13))
        .draw()?;
    Ok(())
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

/// Like [`linear_range`] for a logarithmic axis: only positive finite values count, the
/// margin is a factor. No data gets 0.1..10.
fn log_range(values: impl Iterator<Item = f64>) -> Result<Range<f64>, Box<dyn Error>> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if lo > hi {
        return Ok(0.1..10.0);
    }
    let factor = (hi / lo).powf(0.05).max(1.5);
    let range = (lo / factor)..(hi * factor);
    if range.start > 0.0 && range.end.is_finite() {
        Ok(range)
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

    fn legs<'a>(t: &'a [f64], ys: &'a [Vec<f64>]) -> Vec<Series<'a>> {
        ys.iter()
            .enumerate()
            .map(|(i, y)| Series {
                label: format!("leg {}", i + 1),
                x: t,
                y,
            })
            .collect()
    }

    #[test]
    fn leg_errors_renders_titles_labels_and_legend() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fig6.svg");
        let t: Vec<f64> = (0..=15_000).map(|i| f64::from(i) * 1e-3).collect();
        let ys: Vec<Vec<f64>> = (0..6)
            .map(|k| t.iter().map(|&s| (s + f64::from(k)).sin()).collect())
            .collect();
        let panels: Vec<(String, Vec<Series<'_>>)> = [0, 1, 2, 5, 9]
            .iter()
            .map(|k| (format!("trial {k}"), legs(&t, &ys)))
            .collect();
        leg_errors(&path, "PID-HLCS <line> & co", &panels).unwrap();
        let texts = read_texts(&path);
        assert_has(
            &texts,
            &[
                "PID-HLCS <line> & co",
                "trial 0",
                "trial 9",
                "leg 1",
                "leg 6",
                "time [s]",
                "leg error [mm]",
            ],
        );
        // 5 panels x 6 legs x 15 001 samples must be decimated to a reasonable file.
        let size = std::fs::metadata(&path).unwrap().len();
        assert!(size < 3_000_000, "SVG is {size} bytes");
    }

    #[test]
    fn leg_errors_survives_degenerate_data() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("deg.svg");
        let t = [0.0, 0.001, 0.002, 0.003];
        let empty: [f64; 0] = [];
        let constant = [2.5; 4];
        let nan = [f64::NAN, 1.0, f64::NAN, 2.0];
        let inf = [f64::INFINITY, f64::NEG_INFINITY, f64::NAN, f64::NAN];
        let tiny = [1e-300; 4];
        let series = |label: &str, x: &'static [f64], y: &'static [f64]| Series {
            label: label.into(),
            x,
            y,
        };
        let leak = |v: &[f64]| -> &'static [f64] { Box::leak(v.to_vec().into_boxed_slice()) };
        let panels = vec![
            (
                "empty".to_owned(),
                vec![series("e", leak(&empty), leak(&empty))],
            ),
            (
                "constant".to_owned(),
                vec![series("c", leak(&t), leak(&constant))],
            ),
            ("nan".to_owned(), vec![series("n", leak(&t), leak(&nan))]),
            ("inf".to_owned(), vec![series("i", leak(&t), leak(&inf))]),
            ("tiny".to_owned(), vec![series("t", leak(&t), leak(&tiny))]),
            (
                "short x".to_owned(),
                vec![series("s", leak(&t[..1]), leak(&nan))],
            ),
            ("no series".to_owned(), vec![]),
        ];
        leg_errors(&path, "degenerate", &panels).unwrap();
        assert_has(
            &read_texts(&path),
            &["empty", "e", "constant", "nan", "n", "i", "no series"],
        );

        let err = leg_errors(&path, "none", &[]).unwrap_err();
        assert!(matches!(err, OutputError::Plot { .. }), "{err}");
        assert!(err.to_string().contains("deg.svg"));

        let huge = [f64::MAX, -f64::MAX];
        let huge_panel = vec![(
            "huge".to_owned(),
            vec![series("h", leak(&t[..2]), leak(&huge))],
        )];
        let err = leg_errors(&path, "huge", &huge_panel).unwrap_err();
        assert!(err.to_string().contains("too large"), "{err}");
        // The failed plot left the earlier good file in place.
        assert_has(&read_texts(&path), &["degenerate"]);
    }

    #[test]
    fn path_projections_renders_three_views_and_legend() {
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
        let actual = vec![
            ("PID".to_owned(), shifted),
            ("HLCS".to_owned(), circle.clone()),
        ];
        path_projections(&path, "Circle", &circle, &actual, "mm").unwrap();
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
    }

    #[test]
    fn path_projections_survives_degenerate_data() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.svg");
        path_projections(&path, "empty", &[], &[], "m").unwrap();
        let nan_path = vec![("bad".to_owned(), vec![[f64::NAN; 3], [0.0, 0.0, 0.5]])];
        path_projections(&path, "point", &[[0.0, 0.0, 0.5]], &nan_path, "m").unwrap();
        assert_has(&read_texts(&path), &["point", "desired", "bad"]);
    }

    #[test]
    fn convergence_renders_linear_and_log() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fig8.svg");
        let series = vec![
            ("PID".to_owned(), vec![2.2; 10]),
            (
                "PD-ILC".to_owned(),
                (0..10).map(|k| 2.2 / f64::from(k + 1)).collect(),
            ),
            (
                "HLCS".to_owned(),
                (0..10).map(|k| 2.2 * 0.3f64.powi(k)).collect(),
            ),
        ];
        for log_y in [false, true] {
            convergence(&path, "Convergence", "ρ-norm [mm]", &series, log_y).unwrap();
            assert_has(
                &read_texts(&path),
                &[
                    "Convergence",
                    "ρ-norm [mm]",
                    "trial",
                    "PID",
                    "PD-ILC",
                    "HLCS",
                    "0",
                    "9",
                ],
            );
        }
    }

    #[test]
    fn convergence_survives_degenerate_data() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.svg");
        for log_y in [false, true] {
            convergence(&path, "none", "e", &[], log_y).unwrap();
            let series = vec![
                ("empty".to_owned(), vec![]),
                ("zeros".to_owned(), vec![0.0, -1.0, f64::NAN]),
                ("one".to_owned(), vec![1e-3]),
            ];
            convergence(&path, "deg", "e", &series, log_y).unwrap();
            assert_has(&read_texts(&path), &["deg", "empty", "zeros", "one"]);
        }
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
        let l = log_range([0.0, -1.0, 1e-3, 1.0].into_iter()).unwrap();
        assert!(l.start > 0.0 && l.start < 1e-3 && l.end > 1.0);
        assert_eq!(log_range([-1.0].into_iter()).unwrap(), 0.1..10.0);
        assert!(log_range([5e-324, f64::MAX].into_iter()).is_err());
        let (x, y) = equal_ranges(0.0..2.0, 10.0..11.0);
        assert_eq!((x, y), (0.0..2.0, 9.5..11.5));
    }
}
