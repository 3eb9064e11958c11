//! Beyond the paper (docs/model.md §9, §10): the paper's unfiltered learning update against
//! the robust one (a zero-phase Butterworth Q-filter and a phase lead) over many trials on
//! both paths, and the robust update with sensor noise, a heavier platform and lower learning
//! gains. All cases are HLCS with the Table 1 gains unless a case scales them; the metrics are
//! the true leg errors (reference − noise-free length).
//!
//! Results: `robust/<path>/<case>/` (ordinary campaign folders), `robust.csv` (per case and
//! trial: max and RMS leg error) and the figures `beyond_line.svg`, `beyond_circle.svg`. The
//! report's section and its acceptance checks are computed from `robust.csv`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use ckcm::TrajectoryKind;

use super::cases::{TRAJECTORIES, traj_from_slug, traj_slug};
use super::claims::{csv_error, number, read_rows};
use super::scenario::{Case, CaseSpec, render, run_scenario};
use super::{PaperError, PaperOptions};
use crate::campaign::{CampaignError, TrialSummary, read_summary};
use crate::output::plots::{Line, Panel, Stroke, colour, panels};
use crate::output::{write_atomic, write_table_csv};

/// The robust update: Butterworth order 4 at 8 Hz, forward and backward, with a lead of 25
/// samples (docs/model.md §9; the analysis of docs/convergence.md shows why these values).
pub const ROBUST_UPDATE: &str =
    "[memory.update]\nfilter = \"butterworth\"\norder = 4\ncutoff = 8.0\nlead = 25\n";

/// One case of this section.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RobustCase {
    /// Folder name and `robust.csv` key.
    pub slug: &'static str,
    /// Path tracked.
    pub trajectory: TrajectoryKind,
    /// Name in tables and legends.
    pub label: &'static str,
    /// The robust update; otherwise the paper's.
    pub robust: bool,
    /// σ of the white noise on the measured leg lengths, m (0: none).
    pub noise_sigma: f64,
    /// Platform mass over its nominal value (the controller keeps the nominal model).
    pub mass_scale: f64,
    /// Learning gains Φ, Γ, Ψ over Table 1's.
    pub gain_scale: f64,
}

const fn case(
    slug: &'static str,
    trajectory: TrajectoryKind,
    label: &'static str,
    robust: bool,
    noise_sigma: f64,
    mass_scale: f64,
    gain_scale: f64,
) -> RobustCase {
    RobustCase {
        slug,
        trajectory,
        label,
        robust,
        noise_sigma,
        mass_scale,
        gain_scale,
    }
}

use TrajectoryKind::{Circle, Line as LinePath};

/// Every case, per path: unfiltered and robust first, then the robust variations.
/// Columns: slug, path, label, robust update, noise σ (m), mass scale, learning-gain scale.
#[rustfmt::skip]
pub const CASES: [RobustCase; 10] = [
    case("unfiltered", LinePath, "unfiltered", false, 0.0, 1.0, 1.0),
    case("robust", LinePath, "robust", true, 0.0, 1.0, 1.0),
    case("robust_noise_1e-6", LinePath, "robust, σ = 1e-6 m", true, 1e-6, 1.0, 1.0),
    case("robust_noise_1e-5", LinePath, "robust, σ = 1e-5 m", true, 1e-5, 1.0, 1.0),
    case("unfiltered", Circle, "unfiltered", false, 0.0, 1.0, 1.0),
    case("robust", Circle, "robust", true, 0.0, 1.0, 1.0),
    case("robust_noise_1e-6", Circle, "robust, σ = 1e-6 m", true, 1e-6, 1.0, 1.0),
    case("robust_noise_1e-5", Circle, "robust, σ = 1e-5 m", true, 1e-5, 1.0, 1.0),
    case("robust_mass_1.3", Circle, "robust, platform mass × 1.3", true, 0.0, 1.3, 1.0),
    case("robust_gains_0.75", Circle, "robust, learning gains × 0.75", true, 0.0, 1.0, 0.75),
];

/// Base of the per-trial noise seed: trial k draws with seed 1000 + k.
const NOISE_SEED: u32 = 1000;

/// Where a case's campaign goes.
pub fn case_dir(out: &Path, c: &RobustCase) -> PathBuf {
    out.join("robust")
        .join(traj_slug(c.trajectory))
        .join(c.slug)
}

/// The scenario of a case.
pub fn spec(opts: &PaperOptions, c: &RobustCase) -> CaseSpec {
    let g = ckcm::Gains::default();
    let mut controller = format!("psi = {:?}\n", g.psi * c.gain_scale);
    if c.gain_scale != 1.0 {
        controller = format!(
            "phi = {:?}\ngamma = {:?}\n{controller}",
            g.phi * c.gain_scale,
            g.gamma * c.gain_scale
        );
    }
    let mut plant = String::new();
    if c.mass_scale != 1.0 {
        let mass = ckcm::Params::default().platform.mass * c.mass_scale;
        plant.push_str(&format!("platform_mass = {mass:?}\n"));
    }
    if c.noise_sigma != 0.0 {
        plant.push_str(&format!(
            "length_noise_sigma = {:?}\nnoise_seed = {{ base = {NOISE_SEED}, per_trial = 1 }}\n",
            c.noise_sigma
        ));
    }
    CaseSpec {
        title: format!(
            "Paper study, beyond the paper: {} under HLCS, {}",
            traj_slug(c.trajectory),
            c.label
        ),
        kind: c.trajectory,
        trials: opts.robust_trials,
        learning: true,
        controller_parameters: controller,
        plant_parameters: plant,
        update: if c.robust {
            ROBUST_UPDATE.to_owned()
        } else {
            String::new()
        },
        record: None,
    }
}

/// Case `i` of [`CASES`] as it runs.
pub(super) fn case_of(opts: &PaperOptions, i: usize) -> Case {
    let c = &CASES[i];
    Case {
        dir: case_dir(&opts.out_dir, c),
        text: render(opts, &spec(opts, c)),
        what: format!(
            "beyond the paper: {} / {}",
            traj_slug(c.trajectory),
            c.label
        ),
    }
}

/// Runs case `i` of [`CASES`]. The paper's update can drive the platform into the base
/// plane or a stroke end; the plant then refuses the step and the case ends there, as
/// `outcome.toml` (status and the plant's message) in its folder records, with the summaries
/// of the trials it finished. Any other failure fails the study.
pub(super) fn run_case(
    opts: &PaperOptions,
    i: usize,
    show_progress: bool,
) -> Result<Vec<TrialSummary>, PaperError> {
    let case = case_of(opts, i);
    let dir = &case.dir;
    let (summaries, outcome) = match run_scenario(opts, &case, show_progress) {
        Ok(s) => (s, "status = \"completed\"\n".to_owned()),
        Err(PaperError::Campaign(CampaignError::Master(e))) => {
            let summary = dir.join("summary.csv");
            let s = read_summary(&summary).map_err(PaperError::Invalid)?;
            (
                s,
                format!("status = \"stopped\"\nmessage = {:?}\n", e.to_string()),
            )
        }
        Err(e) => return Err(e),
    };
    write_atomic(&dir.join("outcome.toml"), |w| {
        w.write_all(outcome.as_bytes())
    })?;
    Ok(summaries)
}

/// How a case ended, from its `outcome.toml`.
#[derive(Debug, serde::Deserialize)]
struct Outcome {
    status: String,
    #[serde(default)]
    message: String,
}

const HEADER: [&str; 5] = ["trajectory", "case", "trial", "max", "rms"];

/// Writes `robust.csv`: one row per case and trial, errors in m.
pub(super) fn write_table(out: &Path, results: &[Vec<TrialSummary>]) -> Result<(), PaperError> {
    let rows: Vec<Vec<String>> = CASES
        .iter()
        .zip(results)
        .flat_map(|(c, summaries)| {
            summaries.iter().map(move |s| {
                let [max, rms, ..] = s.overall_cells();
                vec![
                    traj_slug(c.trajectory).to_owned(),
                    c.slug.to_owned(),
                    s.trial.to_string(),
                    max,
                    rms,
                ]
            })
        })
        .collect();
    write_table_csv(&out.join("robust.csv"), &HEADER, &rows)?;
    Ok(())
}

/// Per-trial max and RMS leg error of one case, m.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Series {
    /// Max leg error per trial.
    pub max: Vec<f64>,
    /// RMS leg error per trial.
    pub rms: Vec<f64>,
    /// Why the case ended early (the plant's message), if it did.
    pub stopped: Option<String>,
}

/// `robust.csv` read back: the series of every case, in [`CASES`] order.
pub fn load(dir: &Path) -> Result<Vec<Series>, PaperError> {
    let path = dir.join("robust.csv");
    let mut series = vec![Series::default(); CASES.len()];
    for (line, row) in read_rows(&path)? {
        let get = |c: &str| {
            row.get(c)
                .map(String::as_str)
                .ok_or_else(|| csv_error(&path, line, format!("no column {c:?}")))
        };
        let kind = traj_from_slug(get("trajectory")?)
            .ok_or_else(|| csv_error(&path, line, "trajectory is neither line nor circle"))?;
        let slug = get("case")?;
        let i = CASES
            .iter()
            .position(|c| c.trajectory == kind && c.slug == slug)
            .ok_or_else(|| csv_error(&path, line, format!("unknown case {slug:?}")))?;
        let trial: usize = get("trial")?
            .parse()
            .map_err(|_| csv_error(&path, line, "trial is not a whole number"))?;
        let s = &mut series[i];
        if trial != s.max.len() {
            return Err(csv_error(
                &path,
                line,
                format!("trial {trial} of {slug} out of order"),
            ));
        }
        s.max.push(number(&path, line, &row, "max")?);
        s.rms.push(number(&path, line, &row, "rms")?);
    }
    for (c, s) in CASES.iter().zip(series.iter_mut()) {
        if s.max.is_empty() {
            return Err(csv_error(
                &path,
                0,
                format!("no rows for {} / {}", traj_slug(c.trajectory), c.slug),
            ));
        }
        let file = case_dir(dir, c).join("outcome.toml");
        let text = std::fs::read_to_string(&file)
            .map_err(|e| PaperError::Invalid(format!("{}: {e}", file.display())))?;
        let outcome: Outcome = toml::from_str(&text)
            .map_err(|e| PaperError::Invalid(format!("{}: {e}", file.display())))?;
        if outcome.status != "completed" {
            s.stopped = Some(outcome.message);
        }
    }
    Ok(series)
}

/// Figure files of this section.
pub fn figure_files() -> Vec<String> {
    TRAJECTORIES
        .iter()
        .map(|&k| format!("beyond_{}.svg", traj_slug(k)))
        .collect()
}

/// Per path: the max and RMS leg error of every case against the trial, on log scales, with
/// the acceptance bounds as dashed lines.
pub(super) fn write_figures(fig: &Path, series: &[Series]) -> Result<(), PaperError> {
    for kind in TRAJECTORIES {
        let picked: Vec<(&RobustCase, &Series)> = CASES
            .iter()
            .zip(series)
            .filter(|(c, _)| c.trajectory == kind)
            .collect();
        let trials = picked.iter().map(|p| p.1.max.len()).max().unwrap_or(1);
        let ks: Vec<f64> = (0..trials).map(|k| k as f64).collect();
        let in_mm = |v: &[f64]| v.iter().map(|x| x * 1e3).collect::<Vec<f64>>();
        let max_mm: Vec<Vec<f64>> = picked.iter().map(|p| in_mm(&p.1.max)).collect();
        let rms_mm: Vec<Vec<f64>> = picked.iter().map(|p| in_mm(&p.1.rms)).collect();
        let cases: Vec<&RobustCase> = picked.iter().map(|p| p.0).collect();
        let bounds: Vec<(String, [f64; 2])> = bounds(kind)
            .iter()
            .map(|(label, b)| (label.to_string(), [b * 1e3; 2]))
            .collect();
        let ends = [-0.5, trials as f64 - 0.5];
        let mut top = case_lines(&cases, &ks, &max_mm);
        for (label, y) in &bounds {
            top.push(Line {
                label: label.clone(),
                x: &ends,
                y,
                colour: colour(7),
                stroke: Stroke::Dashed(1),
                markers: false,
            });
        }
        let x_range = Some(-0.5..trials as f64 - 0.5);
        let path = traj_slug(kind);
        panels(
            &fig.join(format!("beyond_{path}.svg")),
            &format!(
                "Beyond the paper: {path}, HLCS with the paper's and the robust update over {trials} trials"
            ),
            &[
                Panel {
                    title: "max-norm of the true leg error (dashed grey: acceptance bounds)".into(),
                    x_label: "trial".into(),
                    y_label: "max |e| [mm]".into(),
                    log_y: true,
                    integer_x: true,
                    x_range: x_range.clone(),
                    lines: top,
                    ..Panel::default()
                },
                Panel {
                    title: "RMS of the true leg error".into(),
                    x_label: "trial".into(),
                    y_label: "RMS e [mm]".into(),
                    log_y: true,
                    integer_x: true,
                    x_range,
                    lines: case_lines(&cases, &ks, &rms_mm),
                    ..Panel::default()
                },
            ],
        )?;
    }
    Ok(())
}

/// One line per case: robust ones solid, the paper's update dashed.
fn case_lines<'a>(cases: &[&RobustCase], ks: &'a [f64], values: &'a [Vec<f64>]) -> Vec<Line<'a>> {
    cases
        .iter()
        .zip(values)
        .enumerate()
        .map(|(j, (c, v))| Line {
            label: c.label.to_owned(),
            x: ks,
            y: v,
            colour: colour(j),
            stroke: if c.robust {
                Stroke::Solid(2)
            } else {
                Stroke::Dashed(2)
            },
            markers: true,
        })
        .collect()
}

/// The acceptance bounds drawn in a path's figure, m.
fn bounds(kind: TrajectoryKind) -> &'static [(&'static str, f64)] {
    if kind == LinePath {
        &[("0.001 mm", 1e-6), ("0.01 mm", 1e-5)]
    } else {
        &[("0.035 mm", 35e-6), ("0.025 mm", 25e-6)]
    }
}

/// Millimetres to three significant digits (the robust errors span 1e-4 to 1e2 mm).
fn mm3(metres: f64) -> String {
    let v = metres * 1e3;
    if !v.is_finite() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).max(0) as usize;
    format!("{v:.digits$}")
}

/// Index of a case of [`CASES`]; the slugs passed are constants of this module, so a miss
/// is a programming error, not input to report.
fn find(kind: TrajectoryKind, slug: &str) -> usize {
    CASES
        .iter()
        .position(|c| c.trajectory == kind && c.slug == slug)
        .expect("a case of CASES")
}

/// Lowest max leg error of a case and its trial (∞ and 0 for no trials).
fn best(s: &Series) -> (f64, usize) {
    s.max.iter().enumerate().fold(
        (f64::INFINITY, 0),
        |b, (k, &e)| if e < b.0 { (e, k) } else { b },
    )
}

/// How the noise-free robust case ends on each path, against its best trial: it settles
/// at a level, which may lie above its best.
fn settle(series: &[Series]) -> String {
    let parts: Vec<String> = TRAJECTORIES
        .iter()
        .map(|&kind| {
            let s = &series[find(kind, "robust")];
            let (low, at) = best(s);
            let last = s.max.last().copied().unwrap_or(f64::NAN);
            format!(
                "on the {}, its max leg error is lowest in trial {at} ({} mm) and {} mm in trial {} ({:.2}× its lowest)",
                traj_slug(kind),
                mm3(low),
                mm3(last),
                s.max.len().saturating_sub(1),
                last / low
            )
        })
        .collect();
    format!(
        "The robust update stops the divergence; it does not make the error fall in every trial: noise-free, {}.",
        parts.join("; ")
    )
}

/// The template values of the section: `robust.trials`, `robust.update`,
/// `robust.gain_scale`, `robust.settle`, `robust.line.table`, `robust.circle.table` and
/// `robust.checks`.
pub fn values(series: &[Series]) -> BTreeMap<String, String> {
    let trials = series.iter().map(|s| s.max.len()).max().unwrap_or(0);
    let mut v = BTreeMap::new();
    v.insert("robust.trials".to_owned(), trials.to_string());
    v.insert(
        "robust.update".to_owned(),
        "Butterworth order 4 at 8 Hz, lead 25 samples".into(),
    );
    let scales: Vec<String> = CASES
        .iter()
        .filter(|c| c.gain_scale != 1.0)
        .map(|c| c.gain_scale.to_string())
        .collect();
    v.insert("robust.gain_scale".to_owned(), scales.join(", "));
    v.insert("robust.settle".to_owned(), settle(series));
    for kind in TRAJECTORIES {
        let mut cols: Vec<usize> = [0, 1, 2, 3, 5, 10, 20, 29, trials.saturating_sub(1)]
            .into_iter()
            .filter(|&k| k < trials)
            .collect();
        cols.dedup();
        let mut s = String::from("| case |");
        for k in &cols {
            let _ = write!(s, " {k} |");
        }
        s.push_str(" best (trial) |\n|---|");
        s.push_str(&"---:|".repeat(cols.len() + 1));
        s.push('\n');
        for (c, x) in CASES.iter().zip(series) {
            if c.trajectory != kind {
                continue;
            }
            let _ = write!(s, "| {} |", c.label);
            for &k in &cols {
                let cell = x
                    .max
                    .get(k)
                    .map_or_else(|| "stopped".to_owned(), |&e| mm3(e));
                let _ = write!(s, " {cell} |");
            }
            let (low, at) = best(x);
            let _ = writeln!(s, " {} ({at}) |", mm3(low));
        }
        v.insert(format!("robust.{}.table", traj_slug(kind)), s);
    }
    v.insert("robust.checks".to_owned(), checks(series).join("\n"));
    v
}

/// Whether a check holds, in the report's words.
fn verdict(ok: bool) -> &'static str {
    if ok { "holds" } else { "does not hold" }
}

/// Largest max leg error over trials `from..` and its trial; a NaN wins, so that a broken
/// trial fails every bound (NaN if there are no such trials).
fn max_from(s: &Series, from: usize) -> (f64, usize) {
    s.max
        .iter()
        .enumerate()
        .skip(from)
        .fold(None, |b: Option<(f64, usize)>, (k, &e)| match b {
            Some((x, _)) if x.is_nan() || x >= e => b,
            _ => Some((e, k)),
        })
        .unwrap_or((f64::NAN, 0))
}

/// Largest trial-to-trial rise of the max leg error after trial 3, m, and where.
fn largest_rise(s: &Series) -> (f64, usize) {
    s.max
        .windows(2)
        .enumerate()
        .skip(3)
        .map(|(k, w)| (w[1] - w[0], k + 1))
        .fold((f64::NEG_INFINITY, 0), |b, r| if r.0 > b.0 { r } else { b })
}

/// The plant's reason for stopping a case, shortened to the time and what it refused.
fn stop_reason(message: &str) -> &str {
    message
        .rsplit_once("is refused: ")
        .map_or(message, |(_, why)| why)
}

/// The acceptance bounds of the robust update, each measured against `robust.csv`.
fn checks(series: &[Series]) -> Vec<String> {
    let mut out = Vec::new();
    let at = |s: &Series, k: usize| s.max.get(k).copied();
    let mut bound = |what: String, value: Option<f64>, limit: f64, detail: String| {
        out.push(match value {
            Some(x) => format!(
                "- {what}: {} mm{detail}, bound {} mm: **{}**.",
                mm3(x),
                mm3(limit),
                verdict(x <= limit)
            ),
            None => format!("- {what}: not measured (too few trials)."),
        });
    };
    for slug in [
        "robust",
        "robust_mass_1.3",
        "robust_noise_1e-5",
        "robust_gains_0.75",
    ] {
        let i = find(Circle, slug);
        let (s, label) = (&series[i], CASES[i].label);
        bound(
            format!("Circle, {label}, trial 3"),
            at(s, 3),
            35e-6,
            String::new(),
        );
        let (worst, k) = max_from(s, 10);
        let trials = s.max.len();
        bound(
            format!("Circle, {label}, every trial from 10 to {}", trials - 1),
            (trials > 10 && s.stopped.is_none()).then_some(worst),
            25e-6,
            format!(" at most (trial {k})"),
        );
    }
    let line = &series[find(LinePath, "robust")];
    let (worst, k) = max_from(line, 5);
    let trials = line.max.len();
    bound(
        format!("Line, robust, every trial from 5 to {}", trials - 1),
        (trials > 5 && line.stopped.is_none()).then_some(worst),
        1e-6,
        format!(" at most (trial {k})"),
    );
    // Under noise the line's bound is to be reached by trial 29; whether it then holds in
    // every later trial, as the circle's does from trial 10, is a second check, so that a
    // later trial above the bound is not hidden behind the first.
    for (slug, limit) in [("robust_noise_1e-6", 1e-6), ("robust_noise_1e-5", 1e-5)] {
        let i = find(LinePath, slug);
        let s = &series[i];
        bound(
            format!("Line, {}, trial 29", CASES[i].label),
            at(s, 29),
            limit,
            String::new(),
        );
        let (worst, k) = max_from(s, 29);
        let trials = s.max.len();
        bound(
            format!(
                "Line, {}, every trial from 29 to {}",
                CASES[i].label,
                trials.saturating_sub(1)
            ),
            (trials > 29 && s.stopped.is_none()).then_some(worst),
            limit,
            format!(" at most (trial {k})"),
        );
    }
    for (kind, slug) in [
        (LinePath, "robust"),
        (LinePath, "robust_noise_1e-6"),
        (Circle, "robust"),
        (Circle, "robust_noise_1e-6"),
    ] {
        let i = find(kind, slug);
        let (rise, k) = largest_rise(&series[i]);
        let trials = series[i].max.len();
        bound(
            format!(
                "{}, {}, largest rise of the max error from one trial to the next after trial 3",
                if kind == LinePath { "Line" } else { "Circle" },
                CASES[i].label
            ),
            (trials > 4).then_some(rise.max(0.0)),
            1e-6,
            format!(" (into trial {k})"),
        );
    }
    for kind in TRAJECTORIES {
        let s = &series[find(kind, "unfiltered")];
        let (low, at) = best(s);
        let last = s.max.last().copied().unwrap_or(f64::NAN);
        let stopped = s.stopped.as_deref().map_or(String::new(), |m| {
            format!(
                " Trial {} did not finish: the plant refused a step because {}.",
                s.max.len(),
                stop_reason(m)
            )
        });
        out.push(format!(
            "- {}, the paper's unfiltered update, for comparison: best {} mm in trial {at}, {} mm in trial {} ({:.0}× its best).{stopped}",
            if kind == LinePath { "Line" } else { "Circle" },
            mm3(low),
            mm3(last),
            s.max.len() - 1,
            last / low
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn millimetres_keep_three_significant_digits() {
        assert_eq!(mm3(1.4094e-3), "1.41");
        assert_eq!(mm3(0.0183e-3), "0.0183");
        assert_eq!(mm3(1.13e-7), "0.000113");
        assert_eq!(mm3(0.341), "341");
        assert_eq!(mm3(0.0), "0");
    }

    /// The robust line settles above its best trial, and the report says so with the
    /// numbers; the learning-gain scale of the gains case is named.
    #[test]
    fn values_say_where_the_robust_update_settles() {
        let mut series = vec![Series::default(); CASES.len()];
        for s in series.iter_mut() {
            s.max = (0..50).map(|k| if k < 3 { 1e-3 } else { 2e-5 }).collect();
        }
        let line = &mut series[find(LinePath, "robust")].max;
        *line = (0..50)
            .map(|k| match k {
                0..6 => 1e-3,
                6 => 6.46e-8,
                _ => 1.06e-7,
            })
            .collect();
        let v = values(&series);
        let settle = &v["robust.settle"];
        assert!(
            settle.contains(
                "on the line, its max leg error is lowest in trial 6 (0.0000646 mm) and 0.000106 mm in trial 49 (1.64× its lowest)"
            ),
            "{settle}"
        );
        assert_eq!(v["robust.gain_scale"], "0.75");
    }

    #[test]
    fn checks_measure_against_the_bounds() {
        let mut series = vec![Series::default(); CASES.len()];
        for (c, s) in CASES.iter().zip(series.iter_mut()) {
            let level = if c.trajectory == LinePath { 1e-7 } else { 2e-5 };
            s.max = (0..50).map(|k| if k < 3 { 1e-3 } else { level }).collect();
            s.rms = s.max.clone();
        }
        let text = checks(&series).join("\n");
        assert!(!text.contains("does not hold"), "{text}");
        let failing_lines = |text: &str| -> Vec<String> {
            text.lines()
                .filter(|l| l.contains("does not hold"))
                .map(str::to_owned)
                .collect()
        };
        // A rise of 2 µm into trial 40 of the noise-free circle is found and fails.
        series[find(Circle, "robust")].max[40] = 2.2e-5 + 2e-6;
        let text = checks(&series).join("\n");
        let failing = failing_lines(&text);
        assert_eq!(failing.len(), 1, "{text}");
        assert!(
            failing[0].contains("Circle, robust, largest rise"),
            "{text}"
        );
        assert!(failing[0].contains("(into trial 40)"), "{text}");
        // One noisy line trial above its bound after trial 29 fails the later-trials check,
        // not the bound at trial 29.
        series[find(Circle, "robust")].max[40] = 2e-5;
        series[find(LinePath, "robust_noise_1e-5")].max[31] = 1.12e-5;
        let text = checks(&series).join("\n");
        let failing = failing_lines(&text);
        assert_eq!(failing.len(), 1, "{text}");
        assert!(
            failing[0].contains("Line, robust, σ = 1e-5 m, every trial from 29 to 49")
                && failing[0].contains("(trial 31)"),
            "{text}"
        );
        assert!(
            text.contains(
                "Line, robust, σ = 1e-5 m, trial 29: 0.000100 mm, bound 0.0100 mm: **holds**"
            ),
            "{text}"
        );
        // Above the bound at trial 29 itself, both checks fail.
        series[find(LinePath, "robust_noise_1e-5")].max[29] = 1.2e-5;
        let text = checks(&series).join("\n");
        assert_eq!(failing_lines(&text).len(), 2, "{text}");
    }
}
