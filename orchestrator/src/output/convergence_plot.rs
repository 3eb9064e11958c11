//! The convergence-factor chart of `orchestrator analyze` (docs/convergence.md): factor vs
//! frequency on log–log axes, one colour per leg-space mode, with the line where learning
//! stops contracting.

use std::path::Path;

use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::OutputError;
use super::plots::{DrawResult, FONT, colour, finite_runs, render};

/// One mode's curves: factor with the filter (solid) and without it (dashed, same colour).
#[derive(Debug, Clone)]
pub struct ModeCurves<'a> {
    /// Legend text, e.g. `mode 6 (27–59 kg)`.
    pub label: String,
    /// Factor with the update's filter, per frequency.
    pub filtered: &'a [f64],
    /// Factor without the filter, per frequency.
    pub unfiltered: &'a [f64],
}

/// Draws the chart into `path`. Non-positive and non-finite values are skipped (log axis).
pub fn convergence_factor(
    path: &Path,
    title: &str,
    frequencies: &[f64],
    modes: &[ModeCurves<'_>],
) -> Result<(), OutputError> {
    let runs = |ys: &[f64]| {
        finite_runs(
            frequencies
                .iter()
                .zip(ys)
                .map(|(&f, &y)| (f, if y > 0.0 { y } else { f64::NAN })),
        )
    };
    let positive = |v: &&f64| v.is_finite() && **v > 0.0;
    let all = || {
        modes
            .iter()
            .flat_map(|m| m.filtered.iter().chain(m.unfiltered))
            .filter(positive)
    };
    // Without a positive factor (every one 0: no learning), the axis keeps its floor; an
    // infinite bound would never finish laying out the log axis' ticks, so the margin above
    // the largest factor stops at the largest double (a factor of 1.7e308 hung `analyze`).
    let lo = all().copied().reduce(f64::min).unwrap_or(1e-6).max(1e-6);
    let hi = all().copied().fold(0.0, f64::max).max(2.0);
    let top = (hi * 1.2).min(f64::MAX);
    let f_lo = frequencies.first().copied().unwrap_or(0.1);
    let f_hi = frequencies.last().copied().unwrap_or(500.0);
    render(path, (1000, 50 + 600), title, |body| -> DrawResult {
        let mut chart = ChartBuilder::on(body)
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(80)
            .build_cartesian_2d((f_lo..f_hi).log_scale(), (lo * 0.8..top).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("frequency [Hz]")
            .y_desc("|Q|²·|α − g z^δ L P|")
            .label_style((FONT, 14))
            .axis_desc_style((FONT, 16))
            .draw()?;
        let one = BLACK.stroke_width(1);
        chart
            .draw_series(LineSeries::new([(f_lo, 1.0), (f_hi, 1.0)], one))?
            .label("1: learning diverges above")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], one));
        for (i, m) in modes.iter().enumerate() {
            let solid = colour(i).stroke_width(2);
            let thin = colour(i).stroke_width(1);
            let mut first = true;
            for run in runs(m.filtered) {
                let drawn = chart.draw_series(LineSeries::new(run, solid))?;
                if first {
                    drawn
                        .label(m.label.clone())
                        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], solid));
                    first = false;
                }
            }
            let mut first = true;
            for run in runs(m.unfiltered) {
                let drawn = chart.draw_series(DashedLineSeries::new(run, 6, 4, thin))?;
                if first && i == 0 {
                    drawn
                        .label("dashed: without the filter")
                        .legend(move |(x, y)| {
                            DashedPathElement::new(vec![(x, y), (x + 20, y)], 6, 3, thin)
                        });
                }
                first = false;
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font((FONT, 13))
            .draw()?;
        Ok(())
    })
}
