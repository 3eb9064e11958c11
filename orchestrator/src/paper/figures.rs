//! The study's figures (SVG): the paper's Fig. 6/7 (a–d) and 8, rebuilt so the quantity of
//! interest is visible, and extra ones, numbered E1–E8 so that none passes for a panel of the
//! paper's, for the path error, the error spectrum, the actuator effort and the learned input.

use std::path::Path;

use ckcm::{Trajectory, TrajectoryKind};

use super::cases::{CaseResult, Scheme, TRAJECTORIES, figure_number, traj_slug};
use super::metrics::{
    HIGH_HZ, RHOS, TRANSIENT_END, TrialMetrics, energy_below, error_spectrum, leg_errors,
    path_error,
};
use super::{PaperError, PaperOptions};
use crate::campaign::TrialSummary;
use crate::output::Recording;
use crate::output::plots::{
    Line, Panel, PathLine, RGBColor, Stroke, colour, ordered_colour, panels, path_projections,
};

/// Everything the figures of one case need: its summaries, the recorded trials, and their
/// derived metrics.
#[derive(Debug)]
pub struct CaseData {
    /// The campaign's result.
    pub result: CaseResult,
    /// Recorded trials, in trial order, reduced to what the figures draw.
    pub recordings: Vec<TrialData>,
    /// Metrics of the recorded trials, same order.
    pub metrics: Vec<TrialMetrics>,
    /// The desired trajectory.
    pub trajectory: Trajectory,
}

/// What the figures need of one recorded trial: the columns [`drawn`] names, so the study's
/// memory stays small (a whole 15 s recording is 3 MB).
#[derive(Debug)]
pub struct TrialData {
    /// Trial index.
    pub trial: usize,
    /// The recording, without the columns this trial's figures do not draw.
    pub rec: Recording,
    /// Max over legs of |e| per time bucket, mm: (bucket centres, maxima).
    pub envelope: (Vec<f64>, Vec<f64>),
    /// Single-sided error amplitude spectrum ([`error_spectrum`]): (Hz, mm).
    pub spectrum: (Vec<f64>, Vec<f64>),
    /// |p − p_d| at every sample, mm.
    pub path_error: Vec<f64>,
}

impl TrialData {
    /// Derives the figure data of trial `k` and drops the columns no figure needs.
    pub fn new(k: usize, mut rec: Recording, trajectory: &Trajectory, full: bool) -> Self {
        let envelope = envelope(&rec);
        let step = match rec.time.as_slice() {
            [a, b, ..] => b - a,
            _ => 1e-3,
        };
        let (f, a) = error_spectrum(&leg_errors(&rec), step);
        let spectrum = (f, scale(&a, 1e3));
        let path_error = scale(&path_error(&rec, trajectory), 1e3);
        let (names, columns): (Vec<String>, Vec<Vec<f64>>) = rec
            .names
            .drain(..)
            .zip(rec.columns.drain(..))
            .filter(|(n, _)| drawn(n, full))
            .unzip();
        rec.names = names;
        rec.columns = columns;
        TrialData {
            trial: k,
            rec,
            envelope,
            spectrum,
            path_error,
        }
    }
}

/// Width of a time bucket of the |e| envelope, s: fine enough for the 5–7 Hz growth.
const ENVELOPE_BUCKET: f64 = 0.02;
/// Share of every drawn trial's error energy that a spectrum figure's frequency range holds.
const SPECTRUM_ENERGY: f64 = 0.99;

/// Number of an extra figure, one the paper does not have: `what` is 0 for the path error, 1
/// the spectrum, 2 the actuator effort, 3 the learned input; E1–E4 on the line, E5–E8 on the
/// circle.
pub fn extra_figure(kind: TrajectoryKind, what: usize) -> String {
    let first = if kind == TrajectoryKind::Line { 1 } else { 5 };
    format!("E{}", first + what)
}

/// The trial the claims look at: 2 on the line ("after two trials"), 3 on the circle.
pub fn claim_trial(kind: TrajectoryKind) -> usize {
    if kind == TrajectoryKind::Line { 2 } else { 3 }
}

fn find(data: &[CaseData], kind: TrajectoryKind, scheme: Scheme) -> Result<&CaseData, PaperError> {
    data.iter()
        .find(|d| d.result.trajectory == kind && d.result.scheme == scheme)
        .ok_or_else(|| {
            PaperError::Invalid(format!(
                "{} / {} did not run",
                traj_slug(kind),
                scheme.slug()
            ))
        })
}

fn recording(d: &CaseData, k: usize) -> Result<&Recording, PaperError> {
    d.recordings
        .iter()
        .find(|t| t.trial == k)
        .map(|t| &t.rec)
        .ok_or_else(|| {
            PaperError::Invalid(format!(
                "{}: trial {k} was not recorded",
                d.result.dir.display()
            ))
        })
}

/// Whether a figure draws column `name` of a trial kept `full` or not: every trial's leg-1
/// force and learned input; of the trials drawn in full, also the six leg errors, the
/// position (the pose's angles are not drawn) and every leg's learned input: 16 of the 24
/// columns `paper` records, which the study holds for every case until the figures are drawn.
fn drawn(name: &str, full: bool) -> bool {
    name == "controller.force[1]"
        || name == "controller.memory_next[1]"
        || (full
            && (name.starts_with("controller.error[")
                || name.starts_with("controller.memory_next[")
                || ["plant.pose[1]", "plant.pose[2]", "plant.pose[3]"].contains(&name)))
}

/// Max over legs of |e| per time bucket, mm: (bucket centres, maxima).
fn envelope(rec: &Recording) -> (Vec<f64>, Vec<f64>) {
    let errors = leg_errors(rec);
    let step = match rec.time.as_slice() {
        [a, b, ..] => b - a,
        _ => 1e-3,
    };
    let per = ((ENVELOPE_BUCKET / step).round() as usize).max(1);
    let n = rec.time.len();
    let mut x = Vec::with_capacity(n / per + 1);
    let mut y = Vec::with_capacity(n / per + 1);
    for start in (0..n).step_by(per) {
        let end = (start + per).min(n);
        let m = errors
            .iter()
            .flat_map(|e| e[start..end].iter())
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        x.push((rec.time[start] + rec.time[end - 1]) / 2.0);
        y.push(m * 1e3);
    }
    (x, y)
}

fn trial_line<'a>(label: String, x: &'a [f64], y: &'a [f64], k: usize, n: usize) -> Line<'a> {
    Line {
        label,
        x,
        y,
        colour: ordered_colour(k, n),
        stroke: Stroke::Solid(1),
        markers: false,
    }
}

fn scale(v: &[f64], f: f64) -> Vec<f64> {
    v.iter().map(|x| x * f).collect()
}

/// Writes every figure into `figures/`.
pub fn write_figures(opts: &PaperOptions, data: &[CaseData]) -> Result<(), PaperError> {
    let fig = opts.out_dir.join("figures");
    crate::output::create_folder(&fig)
        .map_err(|e| PaperError::Invalid(format!("cannot create {}: {e}", fig.display())))?;
    for kind in TRAJECTORIES {
        for scheme in Scheme::ALL {
            leg_error_figure(&fig, find(data, kind, scheme)?)?;
        }
        path_figure(&fig, data, kind)?;
        let hlcs = find(data, kind, Scheme::Hlcs)?;
        let pid = find(data, kind, Scheme::Pid)?;
        path_error_figure(&fig, hlcs, pid)?;
        spectrum_figure(&fig, hlcs)?;
        effort_figure(&fig, data, kind)?;
        learned_input_figure(&fig, hlcs)?;
    }
    convergence_figures(&fig, data)
}

fn file(fig: &Path, kind: TrajectoryKind, what: &str) -> std::path::PathBuf {
    fig.join(format!("{}_{what}.svg", traj_slug(kind)))
}

/// Fig. 6/7 a–c: per scheme, the |e| envelope of every recorded trial on one log scale,
/// and the signed leg errors of the claims' trial after the transient.
fn leg_error_figure(fig: &Path, d: &CaseData) -> Result<(), PaperError> {
    let (kind, scheme) = (d.result.trajectory, d.result.scheme);
    let n = d.recordings.len();
    // PID does not learn: every trial is trial 0 (checked on the summaries), so one line.
    let identical = !scheme.learning()
        && d.result
            .summaries
            .windows(2)
            .all(|w| summaries_equal(&w[0], &w[1]));
    let shown = if identical { 1 } else { n };
    let top_lines: Vec<Line<'_>> = d
        .recordings
        .iter()
        .take(shown)
        .map(|td| {
            let (k, (x, y)) = (&td.trial, &td.envelope);
            let label = if identical {
                format!("trials 0–{} (identical)", d.result.summaries.len() - 1)
            } else {
                format!("trial {k}")
            };
            trial_line(label, x, y, *k, n.max(2))
        })
        .collect();
    let kc = claim_trial(kind);
    let rec = recording(d, kc)?;
    let from = rec.time.partition_point(|&t| t < TRANSIENT_END);
    let signed: Vec<Vec<f64>> = leg_errors(rec)
        .iter()
        .map(|e| scale(&e[from..], 1e3))
        .collect();
    let bottom_lines: Vec<Line<'_>> = signed
        .iter()
        .enumerate()
        .map(|(i, y)| Line {
            label: format!("leg {}", i + 1),
            x: &rec.time[from..],
            y,
            colour: colour(i),
            stroke: Stroke::Solid(1),
            markers: false,
        })
        .collect();
    let title = format!(
        "Fig. {}{}: {}, leg errors under {}",
        figure_number(kind),
        scheme.letter(),
        traj_slug(kind),
        scheme.label()
    );
    panels(
        &file(fig, kind, &format!("{}_leg_errors", scheme.slug())),
        &title,
        &[
            Panel {
                title: format!(
                    "max over legs of |e|, {:.0} ms envelope, every recorded trial (one log scale)",
                    ENVELOPE_BUCKET * 1e3
                ),
                x_label: "time [s]".into(),
                y_label: "|e| [mm]".into(),
                log_y: true,
                lines: top_lines,
                legend_title: if identical {
                    String::new()
                } else {
                    "trial (dark → light)".into()
                },
                ..Panel::default()
            },
            Panel {
                title: format!(
                    "trial {kc}, t ≥ {TRANSIENT_END} s (after the transient): leg errors"
                ),
                x_label: "time [s]".into(),
                y_label: "e = l_d − l [mm]".into(),
                lines: bottom_lines,
                ..Panel::default()
            },
        ],
    )?;
    Ok(())
}

fn summaries_equal(a: &TrialSummary, b: &TrialSummary) -> bool {
    a.legs.map(|l| l.overall) == b.legs.map(|l| l.overall)
}

fn xyz(rec: &Recording) -> Vec<[f64; 3]> {
    let c = |i: usize| rec.column(&format!("plant.pose[{i}]")).unwrap_or(&[]);
    let (x, y, z) = (c(1), c(2), c(3));
    x.iter()
        .zip(y)
        .zip(z)
        .map(|((x, y), z)| [*x, *y, *z])
        .collect()
}

/// The 1-2-5 number (1, 2, 5, 10, 20, …) next to `v` (≥ 1): at or above it with `up`, else
/// at or below it.
fn round_125(v: f64, up: bool) -> f64 {
    if !(v.is_finite() && v > 1.0) {
        return 1.0;
    }
    let e = 10f64.powf(v.log10().floor());
    let [one, two, five, ten] = [1.0, 2.0, 5.0, 10.0].map(|m| m * e);
    if up {
        [one, two, five]
            .into_iter()
            .find(|&c| c >= v)
            .unwrap_or(ten)
    } else {
        [five, two].into_iter().find(|&c| c <= v).unwrap_or(one)
    }
}

/// Fig. 6/7 d: desired vs actual path of the three schemes in the claims' trial, with the
/// error magnified so that millimetres show on a path of decimetres.
fn path_figure(fig: &Path, data: &[CaseData], kind: TrajectoryKind) -> Result<(), PaperError> {
    let k = claim_trial(kind);
    let pid = find(data, kind, Scheme::Pid)?;
    let desired: Vec<[f64; 3]> = recording(pid, k)?
        .time
        .iter()
        .map(|&t| trajectory_point(&pid.trajectory, t))
        .collect();
    let span = {
        let mut s = 0.0_f64;
        for a in 0..3 {
            let (lo, hi) = desired
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                    (l.min(p[a]), h.max(p[a]))
                });
            s = s.max(hi - lo);
        }
        s
    };
    let mut actual = Vec::new();
    let mut worst = 0.0_f64;
    for scheme in Scheme::ALL {
        let rec = recording(find(data, kind, scheme)?, k)?;
        let p = xyz(rec);
        if scheme == Scheme::Hlcs {
            for (a, d) in p.iter().zip(&desired) {
                let e =
                    ((a[0] - d[0]).powi(2) + (a[1] - d[1]).powi(2) + (a[2] - d[2]).powi(2)).sqrt();
                worst = worst.max(e);
            }
        }
        actual.push((scheme, p));
    }
    // HLCS's largest error drawn at about 5 % of the path's extent (PID's, larger, shows
    // magnified by the same factor).
    let m = round_125(0.05 * span / worst, false);
    let lines: Vec<PathLine> = actual
        .into_iter()
        .map(|(scheme, p)| PathLine {
            label: format!("{} (trial {k})", scheme.label()),
            points: p
                .iter()
                .zip(&desired)
                .map(|(a, d)| std::array::from_fn(|i| 1e3 * (d[i] + m * (a[i] - d[i]))))
                .collect(),
            colour: colour(scheme.colour_index()),
            // PD-type ILC lies under HLCS: drawn wider so that both stay visible.
            stroke: Stroke::Solid(if scheme == Scheme::PdIlc { 6 } else { 2 }),
        })
        .collect();
    let desired_line = PathLine {
        label: "desired (drawn on top)".into(),
        points: desired.iter().map(|d| d.map(|v| v * 1e3)).collect(),
        colour: RGBColor(0, 0, 0),
        stroke: Stroke::Dashed(2),
    };
    let title = format!(
        "Fig. {}d: {}, desired vs actual path in trial {k}, errors magnified ×{m}",
        figure_number(kind),
        traj_slug(kind)
    );
    path_projections(
        &file(fig, kind, "path"),
        &title,
        &lines,
        &desired_line,
        "mm",
    )?;
    Ok(())
}

fn trajectory_point(t: &Trajectory, time: f64) -> [f64; 3] {
    let p = t.sample(time).pose.p_world;
    [p.x, p.y, p.z]
}

/// Fig. E1/E5: Cartesian path error against time, HLCS per trial and PID.
fn path_error_figure(fig: &Path, hlcs: &CaseData, pid: &CaseData) -> Result<(), PaperError> {
    let kind = hlcs.result.trajectory;
    let n = hlcs.recordings.len();
    let pid0 = pid
        .recordings
        .first()
        .ok_or_else(|| PaperError::Invalid("PID: no recorded trial".into()))?;
    let mut lines: Vec<Line<'_>> = vec![Line {
        label: "PID (every trial)".into(),
        x: &pid0.rec.time,
        y: &pid0.path_error,
        colour: RGBColor(0, 0, 0),
        stroke: Stroke::Dashed(2),
        markers: false,
    }];
    for td in &hlcs.recordings {
        let k = td.trial;
        lines.push(trial_line(
            format!("HLCS trial {k}"),
            &td.rec.time,
            &td.path_error,
            k,
            n,
        ));
    }
    let title = format!(
        "Fig. {}: {}, Cartesian path error |p − p_d| against time",
        extra_figure(kind, 0),
        traj_slug(kind)
    );
    panels(
        &file(fig, kind, "path_error"),
        &title,
        &[Panel {
            title: "HLCS per trial (PD-type ILC is indistinguishable) and PID alone".into(),
            x_label: "time [s]".into(),
            y_label: "|p − p_d| [mm]".into(),
            log_y: true,
            lines,
            ..Panel::default()
        }],
    )?;
    Ok(())
}

/// Fig. E2/E6: error amplitude spectrum per trial (HLCS), with the median frequency of the
/// error energy and the share above 5 Hz in the legend, up to the frequency below which
/// [`SPECTRUM_ENERGY`] of every trial's energy lies (the line's late trials oscillate near
/// 150 Hz, the circle's at 5–7 Hz).
fn spectrum_figure(fig: &Path, d: &CaseData) -> Result<(), PaperError> {
    let kind = d.result.trajectory;
    let n = d.recordings.len();
    let top = round_125(
        d.recordings
            .iter()
            .map(|td| energy_below(&td.spectrum.0, &td.spectrum.1, SPECTRUM_ENERGY))
            .fold(10.0, f64::max),
        true,
    );
    let lines: Vec<Line<'_>> = d
        .recordings
        .iter()
        .zip(&d.metrics)
        .map(|(td, m)| {
            let (k, (f, a)) = (&td.trial, &td.spectrum);
            // The 0 Hz bin is empty after removing the mean, so it is left out.
            let shown = f.partition_point(|&x| x <= top);
            let from = 1.min(shown);
            trial_line(
                format!(
                    "{k}: {:.1} Hz, {:.0} % > {HIGH_HZ:.0} Hz",
                    m.median_hz,
                    100.0 * m.above_high
                ),
                &f[from..shown],
                &a[from..shown],
                *k,
                n,
            )
        })
        .collect();
    let title = format!(
        "Fig. {}: {}, spectrum of the leg error per trial under HLCS",
        extra_figure(kind, 1),
        traj_slug(kind)
    );
    panels(
        &file(fig, kind, "spectrum"),
        &title,
        &[Panel {
            title: format!(
                "single-sided amplitude, RMS over the legs, mean removed; 0–{top} Hz holds ≥ {:.0} % of each trial's energy",
                100.0 * SPECTRUM_ENERGY
            ),
            x_label: "frequency [Hz]".into(),
            y_label: "amplitude [mm]".into(),
            log_y: true,
            x_range: Some(0.0..top),
            lines,
            legend_title: format!("trial: median, share > {HIGH_HZ:.0} Hz"),
            ..Panel::default()
        }],
    )?;
    Ok(())
}

/// Fig. E3/E7: actuator effort: leg-1 force per trial, its change from trial 0, and the
/// RMS force per trial of every scheme.
fn effort_figure(fig: &Path, data: &[CaseData], kind: TrajectoryKind) -> Result<(), PaperError> {
    let hlcs = find(data, kind, Scheme::Hlcs)?;
    let n = hlcs.recordings.len();
    let force = |r: &Recording| r.column("controller.force[1]").unwrap_or(&[]).to_vec();
    let f0 = force(recording(hlcs, 0)?);
    let forces: Vec<(usize, Vec<f64>, Vec<f64>)> = hlcs
        .recordings
        .iter()
        .map(|td| {
            let f = force(&td.rec);
            let df = f.iter().zip(&f0).map(|(a, b)| a - b).collect();
            (td.trial, f, df)
        })
        .collect();
    let top: Vec<Line<'_>> = forces
        .iter()
        .zip(&hlcs.recordings)
        .map(|((k, f, _), td)| trial_line(format!("trial {k}"), &td.rec.time, f, *k, n))
        .collect();
    let mid: Vec<Line<'_>> = forces
        .iter()
        .zip(&hlcs.recordings)
        .skip(1)
        .map(|((k, _, df), td)| trial_line(format!("trial {k}"), &td.rec.time, df, *k, n))
        .collect();
    let rms: Vec<(Scheme, Vec<f64>, Vec<f64>)> = Scheme::ALL
        .into_iter()
        .map(|s| {
            let d = find(data, kind, s)?;
            Ok((
                s,
                d.metrics.iter().map(|m| m.trial as f64).collect(),
                d.metrics.iter().map(|m| m.force_rms).collect(),
            ))
        })
        .collect::<Result<_, PaperError>>()?;
    let bottom: Vec<Line<'_>> = rms
        .iter()
        .map(|(s, k, v)| Line {
            label: s.label().into(),
            x: k,
            y: v,
            colour: colour(s.colour_index()),
            stroke: Stroke::Solid(if *s == Scheme::PdIlc { 5 } else { 2 }),
            markers: true,
        })
        .collect();
    let trials = hlcs.result.summaries.len() as f64;
    let title = format!(
        "Fig. {}: {}, actuator effort per trial",
        extra_figure(kind, 2),
        traj_slug(kind)
    );
    panels(
        &file(fig, kind, "forces"),
        &title,
        &[
            Panel {
                title: "HLCS: force of leg 1 in every trial".into(),
                x_label: "time [s]".into(),
                y_label: "τ₁ [N]".into(),
                lines: top,
                legend_title: "trial (dark → light)".into(),
                ..Panel::default()
            },
            Panel {
                title: "HLCS: change of the leg-1 force from trial 0 (what learning adds)".into(),
                x_label: "time [s]".into(),
                y_label: "τ₁ − τ₁(trial 0) [N]".into(),
                lines: mid,
                ..Panel::default()
            },
            Panel {
                title: "RMS force over the six legs and the trial, per scheme".into(),
                x_label: "trial".into(),
                y_label: "RMS τ [N]".into(),
                integer_x: true,
                x_range: Some(-0.5..trials - 0.5),
                lines: bottom,
                ..Panel::default()
            },
        ],
    )?;
    Ok(())
}

/// Fig. E4/E8: the learned input u_{k+1} built during trial k (HLCS).
fn learned_input_figure(fig: &Path, d: &CaseData) -> Result<(), PaperError> {
    let kind = d.result.trajectory;
    let n = d.recordings.len();
    let top: Vec<Line<'_>> = d
        .recordings
        .iter()
        .filter_map(|td| {
            let k = td.trial;
            Some(trial_line(
                format!("u{} (after trial {k})", subscript(k + 1)),
                &td.rec.time,
                td.rec.column("controller.memory_next[1]")?,
                k,
                n,
            ))
        })
        .collect();
    let last_data = d
        .recordings
        .last()
        .ok_or_else(|| PaperError::Invalid("no recorded trial".into()))?;
    let (k_last, last) = (&last_data.trial, &last_data.rec);
    let bottom: Vec<Line<'_>> = (1..=6)
        .filter_map(|leg| {
            Some(Line {
                label: format!("leg {leg}"),
                x: &last.time,
                y: last.column(&format!("controller.memory_next[{leg}]"))?,
                colour: colour(leg - 1),
                stroke: Stroke::Solid(1),
                markers: false,
            })
        })
        .collect();
    let title = format!(
        "Fig. {}: {}, learned input u_k under HLCS",
        extra_figure(kind, 3),
        traj_slug(kind)
    );
    panels(
        &file(fig, kind, "learned_input"),
        &title,
        &[
            Panel {
                title: "leg 1: u_{k+1}(t) = u_k + Φe + Γė + Ψ∫e (eq. 14), built in trial k".into(),
                x_label: "time [s]".into(),
                y_label: "u₁ [N]".into(),
                lines: top,
                legend_title: "input (dark → light)".into(),
                ..Panel::default()
            },
            Panel {
                title: format!(
                    "all legs: u{} (after trial {k_last})",
                    subscript(k_last + 1)
                ),
                x_label: "time [s]".into(),
                y_label: "u [N]".into(),
                lines: bottom,
                ..Panel::default()
            },
        ],
    )?;
    Ok(())
}

fn subscript(k: usize) -> String {
    const DIGITS: [char; 10] = ['₀', '₁', '₂', '₃', '₄', '₅', '₆', '₇', '₈', '₉'];
    k.to_string()
        .chars()
        .map(|c| DIGITS[c.to_digit(10).unwrap_or(0) as usize])
        .collect()
}

/// Fig. 8: a norm of the leg error per trial for every case (log scale), and the HLCS /
/// PD-type ILC ratio − 1 so that their near-identity is visible.
fn convergence_figures(fig: &Path, data: &[CaseData]) -> Result<(), PaperError> {
    type Pick = fn(&CaseData) -> Vec<f64>;
    let rho = |i: usize| RHOS[i];
    let figures: [(&str, String, &str, Pick); 4] = [
        ("max", "max-norm".into(), "max |e| [mm]", |d| {
            d.result
                .summaries
                .iter()
                .map(|s| s.legs.map_or(f64::NAN, |l| l.overall.max))
                .collect()
        }),
        (
            "lambda",
            format!("λ-norm, ρ = {} 1/s", rho(0)),
            "sup e^(−ρt)|e| [mm]",
            |d| lambda_series(d, 0),
        ),
        (
            "lambda_rho5",
            format!("λ-norm, ρ = {} 1/s", rho(1)),
            "sup e^(−ρt)|e| [mm]",
            |d| lambda_series(d, 1),
        ),
        ("rms", "RMS".into(), "RMS e [mm]", |d| {
            d.result
                .summaries
                .iter()
                .map(|s| s.legs.map_or(f64::NAN, |l| l.overall.rms))
                .collect()
        }),
    ];
    let trials = data
        .iter()
        .map(|d| d.result.summaries.len())
        .max()
        .unwrap_or(1);
    let ks: Vec<f64> = (0..trials).map(|k| k as f64).collect();
    for (slug, name, y_label, pick) in figures {
        let series: Vec<(TrajectoryKind, Scheme, Vec<f64>)> = data
            .iter()
            .map(|d| (d.result.trajectory, d.result.scheme, scale(&pick(d), 1e3)))
            .collect();
        let top: Vec<Line<'_>> = series
            .iter()
            .map(|(kind, s, v)| Line {
                label: format!("{} {}", traj_slug(*kind), s.label()),
                x: &ks,
                y: v,
                colour: colour(s.colour_index()),
                stroke: if *kind == TrajectoryKind::Line {
                    Stroke::Solid(if *s == Scheme::PdIlc { 5 } else { 2 })
                } else {
                    Stroke::Dashed(if *s == Scheme::PdIlc { 5 } else { 2 })
                },
                markers: true,
            })
            .collect();
        let ratio: Vec<(TrajectoryKind, Vec<f64>)> = TRAJECTORIES
            .into_iter()
            .map(|kind| {
                let get = |s| {
                    series
                        .iter()
                        .find(|(k, sc, _)| *k == kind && *sc == s)
                        .map(|x| x.2.clone())
                        .unwrap_or_default()
                };
                let (h, p) = (get(Scheme::Hlcs), get(Scheme::PdIlc));
                (
                    kind,
                    h.iter().zip(&p).map(|(h, p)| (h / p - 1.0) * 1e6).collect(),
                )
            })
            .collect();
        let bottom: Vec<Line<'_>> = ratio
            .iter()
            .enumerate()
            .map(|(i, (kind, v))| Line {
                label: traj_slug(*kind).into(),
                x: &ks,
                y: v,
                colour: colour(2 + i),
                stroke: Stroke::Solid(2),
                markers: true,
            })
            .collect();
        let x_range = Some(-0.5..trials as f64 - 0.5);
        panels(
            &fig.join(format!("convergence_{slug}.svg")),
            &format!("Fig. 8: {name} of the leg error per trial"),
            &[
                Panel {
                    title: format!("{name}, every case (solid: line, dashed: circle)"),
                    x_label: "trial".into(),
                    y_label: y_label.into(),
                    log_y: true,
                    integer_x: true,
                    x_range: x_range.clone(),
                    lines: top,
                    ..Panel::default()
                },
                Panel {
                    title: "HLCS / PD-type ILC − 1: how far the two schemes differ".into(),
                    x_label: "trial".into(),
                    y_label: "ratio − 1 [ppm]".into(),
                    integer_x: true,
                    x_range,
                    lines: bottom,
                    ..Panel::default()
                },
            ],
        )?;
    }
    Ok(())
}

fn lambda_series(d: &CaseData, i: usize) -> Vec<f64> {
    let mut v = vec![f64::NAN; d.result.summaries.len()];
    for m in &d.metrics {
        if let Some(x) = v.get_mut(m.trial) {
            *x = m.lambda[i];
        }
    }
    // PID does not learn: its unrecorded trials equal trial 0 (its summaries say so).
    if !d.result.scheme.learning() {
        let first = v.first().copied().unwrap_or(f64::NAN);
        for x in v.iter_mut().filter(|x| x.is_nan()) {
            *x = first;
        }
    }
    v
}

/// Path of a figure, for the report.
pub fn figure_files() -> Vec<String> {
    let mut v = Vec::new();
    for kind in TRAJECTORIES {
        let t = traj_slug(kind);
        for s in Scheme::ALL {
            v.push(format!("{t}_{}_leg_errors.svg", s.slug()));
        }
        for what in ["path", "path_error", "spectrum", "forces", "learned_input"] {
            v.push(format!("{t}_{what}.svg"));
        }
    }
    for s in ["max", "lambda", "lambda_rho5", "rms"] {
        v.push(format!("convergence_{s}.svg"));
    }
    v.extend(super::robust::figure_files());
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_125_goes_to_the_next_1_2_5_number_either_way() {
        for (v, down, up) in [
            (0.5, 1.0, 1.0),
            (1.0, 1.0, 1.0),
            (3.0, 2.0, 5.0),
            (7.0, 5.0, 10.0),
            (10.0, 10.0, 10.0),
            (120.0, 100.0, 200.0),
            (499.0, 200.0, 500.0),
            (f64::NAN, 1.0, 1.0),
        ] {
            assert_eq!(round_125(v, false), down, "{v} down");
            assert_eq!(round_125(v, true), up, "{v} up");
        }
    }

    /// A trial's recording as `paper` records it (error, force and learned input of every
    /// leg, the pose), 50 samples of small values.
    fn recorded() -> Recording {
        let names: Vec<String> = [
            "controller.error",
            "controller.force",
            "controller.memory_next",
        ]
        .iter()
        .chain(&["plant.pose"])
        .flat_map(|base| (1..=6).map(move |i| format!("{base}[{i}]")))
        .collect();
        let mut rec = Recording::new(names);
        for n in 0..50 {
            let row: Vec<f64> = (0..rec.names.len())
                .map(|c| 1e-4 * ((n * 7 + c) % 11) as f64)
                .collect();
            rec.push_row(n as f64 * 1e-3, &row);
        }
        rec
    }

    /// Every column a figure reads stays, with its values; the pose's angles and the force
    /// of legs 2–6, which no figure draws, go.
    #[test]
    fn kept_columns_are_those_the_figures_read() {
        let line = Trajectory {
            kind: TrajectoryKind::Line,
            duration: 0.05,
            home_height: 0.5,
        };
        let whole = recorded();
        let legs =
            |base: &str| -> Vec<String> { (1..=6).map(|i| format!("{base}[{i}]")).collect() };
        let mut full = legs("controller.error");
        full.push("controller.force[1]".into());
        full.extend(legs("controller.memory_next"));
        full.extend((1..=3).map(|i| format!("plant.pose[{i}]")));
        let partial = vec![
            "controller.force[1]".to_string(),
            "controller.memory_next[1]".to_string(),
        ];
        for (is_full, expected) in [(true, full), (false, partial)] {
            let td = TrialData::new(4, whole.clone(), &line, is_full);
            assert_eq!(td.rec.names, expected, "full: {is_full}");
            for name in &expected {
                assert_eq!(td.rec.column(name), whole.column(name), "{name}");
            }
            assert_eq!(td.rec.time, whole.time);
        }
    }
}
