//! The sweep's own charts: a metric against a parameter, and a heatmap over a two-axis grid.
//! SVG text without fonts, as in [`super::plots`]; non-finite values are left out, never drawn.

use std::path::Path;

use plotters::prelude::*;

use super::OutputError;
use super::plots::{FONT, colour, render};

/// A log-axis range around the positive finite values, padded by a quarter of a decade.
fn log_bounds(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    (hi > 0.0).then(|| (lo / 1.8, hi * 1.8))
}

/// A tick label in the shortest readable form: 0.05, 2.5, 1.2e-5 (never "0.0500000001").
fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e4).contains(&a) {
        let digits = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{v:.digits$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    } else {
        format!("{v:.1e}")
    }
}

/// A metric (log scale) against a parameter, one colour per group, legend right of the data.
/// `Ok(false)`: not drawn, because the parameter's values span more than an axis can hold
/// (such as ±1.7e308: the axis' length overflows, and laying out its ticks never ends).
pub fn scatter(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    groups: &[(String, Vec<(f64, f64)>)],
) -> Result<bool, OutputError> {
    let pts = || groups.iter().flat_map(|(_, p)| p.iter().copied());
    let (y_lo, y_hi) = log_bounds(pts().map(|p| p.1)).unwrap_or((1e-3, 1.0));
    let xs: Vec<f64> = pts().map(|p| p.0).filter(|x| x.is_finite()).collect();
    let x_lo = xs.iter().copied().fold(f64::INFINITY, f64::min);
    let x_hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (x_lo, x_hi) = if x_lo.is_finite() && x_hi > x_lo {
        let pad = 0.05 * (x_hi - x_lo);
        (x_lo - pad, x_hi + pad)
    } else if x_lo.is_finite() {
        (x_lo - 0.5, x_lo + 0.5)
    } else {
        (0.0, 1.0)
    };
    if !(x_hi - x_lo).is_finite() {
        return Ok(false);
    }
    render(path, (1000, 560), title, |body| {
        let (plot, legend) = body.split_horizontally(790);
        let mut chart = ChartBuilder::on(&plot)
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(x_lo..x_hi, (y_lo..y_hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .y_label_formatter(&|v| tick(*v))
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 16))
            .draw()?;
        for (g, (_, points)) in groups.iter().enumerate() {
            let c = colour(g);
            chart.draw_series(
                points
                    .iter()
                    .filter(|p| p.0.is_finite() && p.1.is_finite() && p.1 > 0.0)
                    .map(|&p| Circle::new(p, 4, c.filled())),
            )?;
        }
        for (g, (label, _)) in groups.iter().enumerate() {
            let y = 30 + 26 * g as i32;
            let c = colour(g);
            legend.draw(&Circle::new((15, y), 5, c.filled()))?;
            legend.draw(&Text::new(label.clone(), (28, y - 8), (FONT, 15)))?;
        }
        Ok(())
    })
    .map(|()| true)
}

/// Colour of `t` in 0..1 on a blue (low) to red (high) ramp.
fn ramp(t: f64) -> RGBColor {
    let t = t.clamp(0.0, 1.0);
    let lerp = |a: u8, b: u8| (f64::from(a) + (f64::from(b) - f64::from(a)) * t).round() as u8;
    RGBColor(lerp(49, 215), lerp(54, 48), lerp(149, 39))
}

/// `z[i][j]` (log colour scale) over the grid of axis x (values `x.1`) and axis y, each cell
/// labelled with its value; a colour bar on the right.
pub fn heatmap(
    path: &Path,
    title: &str,
    x: (&str, &[String]),
    y: (&str, &[String]),
    z: &[Vec<f64>],
) -> Result<(), OutputError> {
    // The colour scale spans exactly the data, so small differences stay visible.
    let pos = || {
        z.iter()
            .flatten()
            .copied()
            .filter(|v| v.is_finite() && *v > 0.0)
    };
    let lo = pos().fold(f64::INFINITY, f64::min);
    let hi = pos().fold(0.0f64, f64::max);
    let (llo, lhi) = if hi > 0.0 {
        (lo.log10(), hi.log10().max(lo.log10() + 1e-3))
    } else {
        (-3.0, 0.0)
    };
    let shade = |v: f64| ramp((v.log10() - llo) / (lhi - llo));
    let (nx, ny) = (x.1.len(), y.1.len());
    render(path, (1000, 620), title, |body| {
        let (plot, bar) = body.split_horizontally(850);
        let mut chart = ChartBuilder::on(&plot)
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(90)
            .build_cartesian_2d(-0.5..nx as f64 - 0.5, -0.5..ny as f64 - 0.5)?;
        let label = |names: &[String], v: f64| {
            let i = v.round();
            if (v - i).abs() < 1e-9 && i >= 0.0 {
                names.get(i as usize).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        };
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(x.0)
            .y_desc(y.0)
            .x_labels(nx * 2 + 1)
            .y_labels(ny * 2 + 1)
            .x_label_formatter(&|v| label(x.1, *v))
            .y_label_formatter(&|v| label(y.1, *v))
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 16))
            .draw()?;
        for (i, col) in z.iter().enumerate() {
            for (j, &v) in col.iter().enumerate() {
                let (cx, cy) = (i as f64, j as f64);
                let fill = if v.is_finite() && v > 0.0 {
                    shade(v)
                } else {
                    RGBColor(220, 220, 220)
                };
                chart.draw_series(std::iter::once(Rectangle::new(
                    [(cx - 0.5, cy - 0.5), (cx + 0.5, cy + 0.5)],
                    fill.filled(),
                )))?;
                let text = if v.is_finite() {
                    format!("{v:.3}")
                } else {
                    "–".into()
                };
                chart.draw_series(std::iter::once(Text::new(
                    text,
                    (cx - 0.2, cy),
                    (FONT, 13).into_font().color(&WHITE),
                )))?;
            }
        }
        let steps = 8;
        for s in 0..steps {
            let t = s as f64 / (steps - 1) as f64;
            let y0 = 60 + (steps - 1 - s) * 50;
            bar.draw(&Rectangle::new([(10, y0), (40, y0 + 50)], ramp(t).filled()))?;
            let v = 10f64.powf(llo + t * (lhi - llo));
            bar.draw(&Text::new(tick(v), (45, y0 + 18), (FONT, 13)))?;
        }
        Ok(())
    })
}

/// One group's quantiles of a metric per trial (entry k is trial k).
#[derive(Debug, Clone)]
pub struct Band {
    pub label: String,
    pub median: Vec<f64>,
    pub p5: Vec<f64>,
    pub p95: Vec<f64>,
}

/// Median (line) and 5–95 % band (shaded) of a metric per trial, one colour per group; log y.
pub fn envelope(
    path: &Path,
    title: &str,
    y_label: &str,
    groups: &[Band],
) -> Result<(), OutputError> {
    let all = || {
        groups
            .iter()
            .flat_map(|b| b.median.iter().chain(&b.p5).chain(&b.p95).copied())
    };
    let (y_lo, y_hi) = log_bounds(all()).unwrap_or((1e-3, 1.0));
    let trials = groups
        .iter()
        .map(|g| g.median.len())
        .max()
        .unwrap_or(1)
        .max(1);
    let ok = |v: f64| v.is_finite() && v > 0.0;
    render(path, (1000, 560), title, |body| {
        let (plot, legend) = body.split_horizontally(790);
        let mut chart = ChartBuilder::on(&plot)
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d(-0.5..trials as f64 - 0.5, (y_lo..y_hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("trial")
            .y_desc(y_label)
            .x_labels(trials.min(25) + 1)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| tick(*v))
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 16))
            .draw()?;
        for (
            g,
            Band {
                median, p5, p95, ..
            },
        ) in groups.iter().enumerate()
        {
            let c = colour(g);
            let band: Vec<(f64, f64)> = (0..trials)
                .filter(|&k| {
                    p5.get(k).is_some_and(|&v| ok(v)) && p95.get(k).is_some_and(|&v| ok(v))
                })
                .map(|k| (k as f64, p95[k]))
                .chain(
                    (0..trials)
                        .rev()
                        .filter(|&k| {
                            p5.get(k).is_some_and(|&v| ok(v)) && p95.get(k).is_some_and(|&v| ok(v))
                        })
                        .map(|k| (k as f64, p5[k])),
                )
                .collect();
            if band.len() >= 3 {
                chart.draw_series(std::iter::once(Polygon::new(band, c.mix(0.2).filled())))?;
            }
            let line: Vec<(f64, f64)> = median
                .iter()
                .enumerate()
                .filter(|(_, v)| ok(**v))
                .map(|(k, &v)| (k as f64, v))
                .collect();
            chart.draw_series(LineSeries::new(line.clone(), c.stroke_width(2)))?;
            chart.draw_series(line.into_iter().map(|p| Circle::new(p, 3, c.filled())))?;
        }
        for (g, Band { label, .. }) in groups.iter().enumerate() {
            let y = 30 + 44 * g as i32;
            let c = colour(g);
            legend.draw(&PathElement::new(vec![(5, y), (30, y)], c.stroke_width(2)))?;
            legend.draw(&Text::new(
                format!("{label}: median"),
                (36, y - 8),
                (FONT, 15),
            ))?;
            legend.draw(&Rectangle::new(
                [(5, y + 12), (30, y + 24)],
                c.mix(0.2).filled(),
            ))?;
            legend.draw(&Text::new(
                "5–95 % of cases".to_string(),
                (36, y + 10),
                (FONT, 13),
            ))?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::tick;

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(0.05), "0.05");
        assert_eq!(tick(0.050000000001), "0.05");
        assert_eq!(tick(2.5), "2.5");
        assert_eq!(tick(100.0), "100");
        assert_eq!(tick(1.2e-5), "1.2e-5");
        assert_eq!(tick(0.0), "0");
    }
}
