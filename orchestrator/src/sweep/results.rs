//! What a sweep found: `sweep.csv` (one row per case), figures and `sweep-report.md`, all
//! computed from the case directories alone, so a merged sweep writes the same bytes.

use std::fmt::Write as _;
use std::path::Path;

use super::spec::{RESULT_COLUMNS, SweepSpec};
use super::{CaseOutcome, SweepError, case_dir, write_text};
use crate::campaign::read_summary;
use crate::output::{OutputError, sweep_plots, write_table_csv};
use crate::scenario::toml_message_at;

/// How a case ended, judged from its max-error history e_0 … e_{K−1}.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// The final trial is within 2× of the best one: learning settled.
    Converged,
    /// The final trial is more than 2× worse than the best: the error regrew.
    Diverged,
    /// An FMU failed during the case (e.g. the plant left its workspace).
    Failed,
}

impl Verdict {
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Converged => "converged",
            Verdict::Diverged => "diverged",
            Verdict::Failed => "failed",
        }
    }
}

/// One case's results.
#[derive(Debug, Clone, PartialEq)]
pub struct CaseResult {
    pub case: usize,
    /// Overall max |e| per completed trial, m.
    pub max: Vec<f64>,
    /// Overall RMS e per completed trial, m.
    pub rms: Vec<f64>,
    pub verdict: Verdict,
    /// Why the case failed, if it did.
    pub message: String,
}

impl CaseResult {
    /// Smallest max error and its trial.
    pub fn best(&self) -> Option<(usize, f64)> {
        self.max
            .iter()
            .copied()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    /// First trial whose max error is at most `fraction` of trial 0's.
    pub fn trials_to(&self, fraction: f64) -> Option<usize> {
        let e0 = *self.max.first()?;
        self.max.iter().position(|&e| e <= fraction * e0)
    }

    fn judge(max: &[f64], failed: bool) -> Verdict {
        let best = max.iter().copied().fold(f64::INFINITY, f64::min);
        match max.last() {
            _ if failed => Verdict::Failed,
            Some(&last) if last.is_finite() && last <= 2.0 * best => Verdict::Converged,
            _ => Verdict::Diverged,
        }
    }
}

/// Reads every case's summary and outcome.
pub fn read_cases(spec: &SweepSpec, out: &Path) -> Result<Vec<CaseResult>, SweepError> {
    (0..spec.cases.len())
        .map(|i| {
            let dir = case_dir(out, i);
            let bad = |m: String| SweepError::Dir {
                dir: dir.clone(),
                message: m,
            };
            let outcome: CaseOutcome = std::fs::read_to_string(dir.join("outcome.toml"))
                .map_err(|e| bad(format!("outcome.toml: {e}")))
                .and_then(|t| {
                    toml::from_str(&t)
                        .map_err(|e| bad(format!("outcome.toml: {}", toml_message_at(&e, &t))))
                })?;
            let summary = dir.join("summary.csv");
            let rows = if summary.exists() {
                read_summary(&summary).map_err(bad)?
            } else {
                Vec::new()
            };
            let legs = rows
                .iter()
                .map(|r| {
                    r.legs.map(|l| l.overall).ok_or_else(|| {
                        bad(format!(
                            "summary.csv: trial {} has no leg errors (no [metrics])",
                            r.trial
                        ))
                    })
                })
                .collect::<Result<Vec<_>, _>>()?;
            let max: Vec<f64> = legs.iter().map(|l| l.max).collect();
            let rms: Vec<f64> = legs.iter().map(|l| l.rms).collect();
            let failed = outcome.status != "completed";
            Ok(CaseResult {
                case: i,
                verdict: CaseResult::judge(&max, failed),
                max,
                rms,
                message: outcome.message.unwrap_or_default(),
            })
        })
        .collect()
}

/// Trials per case: the longest completed history.
fn trials(results: &[CaseResult]) -> usize {
    results.iter().map(|r| r.max.len()).max().unwrap_or(0)
}

fn opt<T: ToString>(x: Option<T>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

/// Writes `sweep.csv`, the figures and `sweep-report.md` into `out`.
pub fn write_results(spec: &SweepSpec, out: &Path) -> Result<(), SweepError> {
    let results = read_cases(spec, out)?;
    let k = trials(&results);
    let mut header: Vec<String> = vec!["case".into()];
    header.extend(spec.axes.iter().map(|a| a.name.clone()));
    header.extend(RESULT_COLUMNS.map(String::from));
    header.extend((0..k).map(|t| format!("max_{t}")));
    header.extend((0..k).map(|t| format!("rms_{t}")));
    let rows: Vec<Vec<String>> = results
        .iter()
        .map(|r| {
            let mut row = vec![r.case.to_string()];
            row.extend(spec.case_labels(r.case).into_iter().map(String::from));
            let best = r.best();
            row.extend([
                r.verdict.as_str().to_string(),
                r.max.len().to_string(),
                opt(best.map(|b| b.1)),
                opt(best.map(|b| b.0)),
                opt(r.max.last()),
                opt(r.trials_to(0.1)),
                opt(r.trials_to(0.01)),
            ]);
            let pad = |v: &[f64]| (0..k).map(|t| opt(v.get(t))).collect::<Vec<_>>();
            row.extend(pad(&r.max));
            row.extend(pad(&r.rms));
            row
        })
        .collect();
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    write_table_csv(&out.join("sweep.csv"), &header_refs, &rows)?;
    let figures = write_figures(spec, out, &results)?;
    let report = report(spec, &results, &figures);
    write_text(&out.join("sweep-report.md"), &report)?;
    Ok(())
}

/// The first axis whose values are categories (schemes, variants), used to group cases.
fn group_axis(spec: &SweepSpec) -> Option<usize> {
    spec.axes
        .iter()
        .position(|a| !a.numeric && a.values.len() > 1)
}

/// Case groups: (label, case indices), one group per value of the grouping axis.
fn groups(spec: &SweepSpec) -> Vec<(String, Vec<usize>)> {
    match group_axis(spec) {
        None => vec![("all cases".into(), (0..spec.cases.len()).collect())],
        Some(g) => spec.axes[g]
            .labels
            .iter()
            .enumerate()
            .map(|(v, label)| {
                let members = (0..spec.cases.len())
                    .filter(|&i| spec.cases[i][g] == v)
                    .collect();
                (label.clone(), members)
            })
            .collect(),
    }
}

/// The q-quantile (0..1) of `xs` by linear interpolation between order statistics, as
/// numpy's default; `None` when empty.
fn quantile(xs: &mut [f64], q: f64) -> Option<f64> {
    if xs.is_empty() {
        return None;
    }
    xs.sort_by(f64::total_cmp);
    let pos = q * (xs.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    Some(xs[lo] + (xs[hi] - xs[lo]) * (pos - lo as f64))
}

fn write_figures(
    spec: &SweepSpec,
    out: &Path,
    results: &[CaseResult],
) -> Result<Vec<(String, String)>, OutputError> {
    let fig = out.join("figures");
    crate::output::create_folder(&fig).map_err(|source| OutputError::Io {
        path: fig.clone(),
        source,
    })?;
    let mut written = Vec::new();
    let groups = groups(spec);
    let final_mm = |r: &CaseResult| r.max.last().map_or(f64::NAN, |e| e * 1e3);
    // The final error against each numeric axis, one colour per group.
    for (a, axis) in spec.axes.iter().enumerate() {
        if !axis.numeric || axis.values.len() < 2 {
            continue;
        }
        let series: Vec<(String, Vec<(f64, f64)>)> = groups
            .iter()
            .map(|(label, members)| {
                let pts = members
                    .iter()
                    .map(|&i| {
                        let v = &axis.values[spec.cases[i][a]];
                        let x = v.as_float().or(v.as_integer().map(|x| x as f64));
                        (x.unwrap_or(f64::NAN), final_mm(&results[i]))
                    })
                    .collect();
                (label.clone(), pts)
            })
            .collect();
        let file = format!("final_vs_{}.svg", slug(&axis.name));
        let drawn = sweep_plots::scatter(
            &fig.join(&file),
            &format!("Final max leg error vs {}", axis.name),
            &axis.name,
            "max |e| in the last trial [mm]",
            &series,
        )?;
        if drawn {
            written.push((file, format!("final max leg error against {}", axis.name)));
        } else {
            crate::console!(
                "warning: figures/{file} is not drawn: the values of axis {:?} span more than \
                 a linear axis can hold",
                axis.name
            );
        }
    }
    // A heatmap when the sweep is a two-axis numeric grid.
    if spec.axes.len() == 2 && spec.axes.iter().all(|a| a.numeric && a.grid) {
        let (ax, ay) = (&spec.axes[0], &spec.axes[1]);
        let mut z = vec![vec![f64::NAN; ay.values.len()]; ax.values.len()];
        for (i, idx) in spec.cases.iter().enumerate() {
            z[idx[0]][idx[1]] = final_mm(&results[i]);
        }
        let file = "heatmap.svg".to_string();
        sweep_plots::heatmap(
            &fig.join(&file),
            "Final max leg error [mm] (log colour scale)",
            (&ax.name, &ax.labels),
            (&ay.name, &ay.labels),
            &z,
        )?;
        written.push((
            file,
            format!("final max leg error over {} × {}", ax.name, ay.name),
        ));
    }
    // The envelope of the error over trials: median and 5–95 % band per group.
    let k = trials(results);
    if k > 0 {
        let mut series = Vec::new();
        for (label, members) in &groups {
            let per_trial = |q: f64| -> Vec<f64> {
                (0..k)
                    .map(|t| {
                        let mut xs: Vec<f64> = members
                            .iter()
                            .filter_map(|&i| results[i].max.get(t).map(|e| e * 1e3))
                            .filter(|e| e.is_finite())
                            .collect();
                        quantile(&mut xs, q).unwrap_or(f64::NAN)
                    })
                    .collect()
            };
            series.push(sweep_plots::Band {
                label: label.clone(),
                median: per_trial(0.5),
                p5: per_trial(0.05),
                p95: per_trial(0.95),
            });
        }
        let file = "envelope.svg".to_string();
        sweep_plots::envelope(
            &fig.join(&file),
            "Max leg error per trial across cases",
            "max |e| [mm]",
            &series,
        )?;
        written.push((
            file,
            "median and 5–95 % band of the max leg error per trial".into(),
        ));
    }
    Ok(written)
}

/// A file-name-safe form of an axis name.
fn slug(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect()
}

fn report(spec: &SweepSpec, results: &[CaseResult], figures: &[(String, String)]) -> String {
    let mut s = String::new();
    let n = results.len();
    let k = trials(results);
    let _ = writeln!(s, "# Sweep report\n");
    let _ = writeln!(
        s,
        "Sweep `{}` over the base scenario `{}`: {n} case{} ({}), {k} trial{} each.\n",
        spec.source
            .file_name()
            .unwrap_or_default()
            .to_string_lossy(),
        spec.base.file_name().unwrap_or_default().to_string_lossy(),
        if n == 1 { "" } else { "s" },
        match spec.combine {
            super::Combine::Product => "every combination of the axes",
            super::Combine::Zip => "the axes zipped",
        },
        if k == 1 { "" } else { "s" },
    );
    let _ = writeln!(s, "| axis | target | values |\n|---|---|---|");
    for a in &spec.axes {
        let target = match &a.target {
            super::Target::Parameters(ps) => ps
                .iter()
                .map(|(f, p)| format!("`{f}.{p}`"))
                .collect::<Vec<_>>()
                .join(", "),
            super::Target::Memory { channel, setting } => {
                format!("memory update of `{channel}`: `{setting}`")
            }
        };
        let shown: Vec<&str> = a.labels.iter().take(6).map(String::as_str).collect();
        let values = if !a.source.is_empty() {
            a.source.clone()
        } else if a.labels.len() > 6 {
            format!("{} … ({} values)", shown.join(", "), a.labels.len())
        } else {
            shown.join(", ")
        };
        let _ = writeln!(
            s,
            "| {} | {target}{} | {values} |",
            a.name,
            if a.scale { " (× base value)" } else { "" },
        );
    }
    let _ = writeln!(
        s,
        "\nA case **converged** when the max leg error of its last trial is within 2× of its \
         best trial, **diverged** when it is more, **failed** when an FMU or its learning update \
         stopped it (the reason is in the case folder's `outcome.toml`).\n"
    );
    let th_mm = spec.threshold * 1e3;
    let _ = writeln!(
        s,
        "| group | cases | converged | diverged | failed | last trial ≤ {th_mm} mm | median last-trial error (mm) |\n|---|---:|---:|---:|---:|---:|---:|"
    );
    for (label, members) in groups(spec) {
        let count =
            |v: super::Verdict| members.iter().filter(|&&i| results[i].verdict == v).count();
        let below = members
            .iter()
            .filter(|&&i| {
                results[i].verdict != super::Verdict::Failed
                    && results[i].max.len() == k
                    && results[i].max.last().is_some_and(|&e| e <= spec.threshold)
            })
            .count();
        let mut finals: Vec<f64> = members
            .iter()
            .filter_map(|&i| results[i].max.last().map(|e| e * 1e3))
            .collect();
        let median = quantile(&mut finals, 0.5).map_or("–".into(), |m| format!("{m:.4}"));
        let m = members.len().max(1) as f64;
        let _ = writeln!(
            s,
            "| {label} | {} | {} | {} | {} | {} ({:.0} %) | {median} |",
            members.len(),
            count(super::Verdict::Converged),
            count(super::Verdict::Diverged),
            count(super::Verdict::Failed),
            below,
            100.0 * below as f64 / m
        );
    }
    if !figures.is_empty() {
        let _ = writeln!(s, "\n## Figures\n");
        for (file, what) in figures {
            let _ = writeln!(s, "- `figures/{file}`: {what}");
        }
    }
    let _ = writeln!(
        s,
        "\nEvery case is an ordinary campaign in `cases/case_NNNN/`; `orchestrator run \
         cases/case_NNNN/scenario.toml` reruns it alone. Per-trial errors are in `sweep.csv` \
         (m)."
    );
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdicts_follow_the_last_trial_against_the_best() {
        assert_eq!(
            CaseResult::judge(&[1.0, 0.1, 0.15], false),
            Verdict::Converged
        );
        assert_eq!(
            CaseResult::judge(&[1.0, 0.1, 0.25], false),
            Verdict::Diverged
        );
        assert_eq!(
            CaseResult::judge(&[1.0, f64::NAN], false),
            Verdict::Diverged
        );
        assert_eq!(CaseResult::judge(&[1.0, 0.1], true), Verdict::Failed);
    }

    #[test]
    fn quantiles_interpolate_like_numpy() {
        let mut xs = vec![4.0, 1.0, 3.0, 2.0];
        assert_eq!(quantile(&mut xs, 0.5), Some(2.5));
        assert_eq!(quantile(&mut xs, 0.0), Some(1.0));
        assert!((quantile(&mut xs, 0.95).unwrap() - 3.85).abs() < 1e-12);
        assert_eq!(quantile(&mut [], 0.5), None);
    }

    #[test]
    fn trials_to_a_fraction_counts_from_trial_zero() {
        let r = CaseResult {
            case: 0,
            max: vec![1.0, 0.5, 0.09, 0.009],
            rms: vec![],
            verdict: Verdict::Converged,
            message: String::new(),
        };
        assert_eq!(r.trials_to(0.1), Some(2));
        assert_eq!(r.trials_to(0.01), Some(3));
        assert_eq!(r.trials_to(0.001), None);
        assert_eq!(r.best(), Some((3, 0.009)));
    }
}
