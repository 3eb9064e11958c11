//! The paper's simulation study (docs/model.md §7): line (15 s) and circle (5 s), each under
//! PID feedback only, PID + PD-type ILC (Ψ = 0) and PID + PID-type ILC (HLCS), with the
//! Table 1 gains, run through the FMUs by the same campaign code as `orchestrator run`.
//!
//! - [`cases`]: the schemes and trajectories;
//! - [`scenario`]: each case as a scenario file, and running it;
//! - [`metrics`]: per-trial figures derived from the recordings (`trial_metrics.csv`);
//! - [`claims`]: the paper's claims graded from the CSVs;
//! - [`figures`]: the SVG figures;
//! - [`report`]: `report.md` from a template, and the self-contained `report.html`;
//! - [`robust`]: beyond the paper, the robust learning update against the paper's.

pub mod cases;
pub mod claims;
pub mod figures;
pub mod metrics;
pub mod report;
pub mod robust;
pub mod scenario;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

use ckcm::{Trajectory, TrajectoryKind};
use fmi2_import::{Fmu, ImportError};
use fmi2_md::Shown;

pub use self::cases::{CaseResult, Scheme, case_dir};
use self::cases::{TRAJECTORIES, traj_slug};
use self::figures::CaseData;
use self::scenario::Case;
pub use self::scenario::{recorded_trials, scenario_toml};
use crate::campaign::{CampaignError, DirLock, trial_csv};
use crate::output::{OutputError, read_recording_csv, write_table_csv};

/// Study settings.
#[derive(Debug, Clone)]
pub struct PaperOptions {
    /// Directory with CkcmPlant.fmu and HlcsController.fmu.
    pub fmu_dir: PathBuf,
    /// Where results go (default `results/paper`).
    pub out_dir: PathBuf,
    /// Trials per scheme (≥ 5 so the claims about trials 2, 3 and 4 can be checked).
    pub trials: usize,
    /// Line duration, s (paper: 15).
    pub line_duration: f64,
    /// Circle duration, s (paper: 5).
    pub circle_duration: f64,
    /// Continue interrupted campaigns.
    pub resume: bool,
    /// Print progress to stderr.
    pub progress: bool,
    /// Campaigns run at the same time (threads); results do not depend on it.
    pub jobs: usize,
    /// λ-norm weight ρ of the campaigns' summaries, 1/s (default 1).
    pub rho: f64,
    /// Trials of each case beyond the paper (the robust update; ≥ 5, default 50).
    pub robust_trials: usize,
}

/// A study failure.
#[derive(Debug, thiserror::Error)]
pub enum PaperError {
    /// An FMU could not be opened (the import error names the file).
    #[error(transparent)]
    Fmu(Box<ImportError>),
    /// A case's scenario, generated in memory from the options, was refused; its problems
    /// without the file and lines of a text the user never sees.
    #[error(
        "{case}: its scenario, generated from the paper options and the FMUs in --fmu-dir, \
         is refused: {}",
        problems.join("; ")
    )]
    Scenario {
        /// The case, e.g. `line / PID`.
        case: String,
        problems: Vec<String>,
    },
    /// A campaign failed.
    #[error(transparent)]
    Campaign(#[from] CampaignError),
    /// A result file could not be written or read.
    #[error(transparent)]
    Output(#[from] OutputError),
    /// A study table is malformed.
    #[error("{}:{line}: {message}", path.display())]
    Table {
        /// The CSV file.
        path: PathBuf,
        /// 1-based line (the header is line 1; 0 if the file could not be opened).
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// Anything else, with its reason.
    #[error("{0}")]
    Invalid(String),
}

/// Most `--trials`: every trial of the learning schemes is recorded, so the study's disk use
/// grows with them (20 GB here), and the trial lists are built before anything runs.
pub const MAX_TRIALS: usize = 1000;

/// Runs all six cases, then writes the tables, figures and the report.
pub fn run_paper(opts: &PaperOptions) -> Result<Vec<CaseResult>, PaperError> {
    if opts.robust_trials < 5 {
        return Err(PaperError::Invalid(format!(
            "--robust-trials {} is too few: the robust section compares trials 0 to 4 at least",
            opts.robust_trials
        )));
    }
    if opts.trials < 5 {
        return Err(PaperError::Invalid(format!(
            "--trials {} is too few: the claims need at least 5 trials",
            opts.trials
        )));
    }
    if opts.trials > MAX_TRIALS {
        return Err(PaperError::Invalid(format!(
            "--trials {} is too many: the study records every trial of its two learning schemes \
             on both paths (about 20 MB per trial at the paper's durations), so at most \
             {MAX_TRIALS}; `run` studies longer campaigns of one scenario",
            opts.trials
        )));
    }
    for (option, d) in [
        ("--line-duration", opts.line_duration),
        ("--circle-duration", opts.circle_duration),
    ] {
        if !(d.is_finite() && d >= 0.01) {
            return Err(PaperError::Invalid(format!(
                "{option} {} s is not usable: a trajectory lasts at least 0.01 s",
                Shown(d)
            )));
        }
    }
    // The cases' scenarios are TOML, which is UTF-8: they could not name the FMUs.
    if opts.fmu_dir.to_str().is_none() {
        return Err(PaperError::Invalid(format!(
            "--fmu-dir {}: the path is not valid UTF-8, so the study's scenario files cannot \
             name the FMUs in it; move them to a folder whose name is",
            opts.fmu_dir.display()
        )));
    }
    // Open both FMUs once up front: a missing or broken FMU fails before anything is written.
    let mut described = Vec::new();
    for model in ["CkcmPlant", "HlcsController"] {
        let p = opts.fmu_dir.join(format!("{model}.fmu"));
        let fmu = Fmu::open(&p).map_err(|e| PaperError::Fmu(Box::new(e)))?;
        // Another model under the name would fail later, as a list of missing variables.
        let held = &fmu.model_description().model_name;
        if held != model {
            return Err(PaperError::Invalid(format!(
                "{} holds the model {held:?}, not {model:?}: --fmu-dir must hold this \
                 project's CkcmPlant.fmu and HlcsController.fmu (`cargo xtask fmu` builds them)",
                p.display()
            )));
        }
        described.push((
            std::path::absolute(&p).unwrap_or(p),
            fmu.model_description().clone(),
        ));
    }
    let cases: Vec<(TrajectoryKind, Scheme)> = TRAJECTORIES
        .into_iter()
        .flat_map(|k| Scheme::ALL.map(|s| (k, s)))
        .collect();
    // Every campaign's scenario checked before the first runs: an option the FMUs refuse
    // (a duration above the controller's declared max) fails at once, not after the cases
    // before it have run.
    let describe = |path: &Path| {
        described
            .iter()
            .find(|(p, _)| p == path)
            .map(|(_, md)| md.clone())
            .ok_or_else(|| format!("{} is not one of --fmu-dir's FMUs", path.display()))
    };
    for &(kind, scheme) in &cases {
        Case::paper(opts, kind, scheme).check(describe)?;
    }
    for i in 0..robust::CASES.len() {
        robust::case_of(opts, i).check(describe)?;
    }
    // One study per folder at a time: a second one started while this one runs would take
    // up the same cases and stop part way on the first it finds locked.
    let _lock = DirLock::acquire(&opts.out_dir)?;
    let data = run_parallel(opts, cases.len(), |i, show_progress| {
        let (kind, scheme) = cases[i];
        let r = scenario::run_case(opts, kind, scheme, show_progress)
            .and_then(|r| case_data(opts, r))?;
        Ok((r, format!("{} / {}", traj_slug(kind), scheme.label())))
    })?;
    let robust = run_parallel(opts, robust::CASES.len(), |i, show_progress| {
        let c = &robust::CASES[i];
        let r = robust::run_case(opts, i, show_progress)?;
        Ok((
            r,
            format!(
                "beyond the paper: {} / {}",
                traj_slug(c.trajectory),
                c.label
            ),
        ))
    })?;
    robust::write_table(&opts.out_dir, &robust)?;
    drop(robust);
    let results: Vec<CaseResult> = data.iter().map(|d| d.result.clone()).collect();
    write_convergence_table(opts, &results)?;
    let metric_rows: Vec<(TrajectoryKind, Scheme, &[metrics::TrialMetrics])> = data
        .iter()
        .map(|d| (d.result.trajectory, d.result.scheme, d.metrics.as_slice()))
        .collect();
    metrics::write_trial_metrics(&opts.out_dir.join("trial_metrics.csv"), &metric_rows)?;
    figures::write_figures(opts, &data)?;
    drop(data);
    robust::write_figures(&opts.out_dir.join("figures"), &robust::load(&opts.out_dir)?)?;
    report::write_report(opts)?;
    Ok(results)
}

/// Runs `n` independent campaigns on `opts.jobs` threads and returns their results in order.
/// Each campaign opens its own FMUs, so no FMI instance ever crosses a thread, and results
/// do not depend on `jobs`. `run(i, show_progress)` runs campaign i and names it for the
/// progress line; after a failure no further campaign starts and the first error is returned.
fn run_parallel<T: Send>(
    opts: &PaperOptions,
    n: usize,
    run: impl Fn(usize, bool) -> Result<(T, String), PaperError> + Sync,
) -> Result<Vec<T>, PaperError> {
    let jobs = opts.jobs.clamp(1, n.max(1));
    let next = AtomicUsize::new(0);
    let slots: Vec<Mutex<Option<Result<T, PaperError>>>> =
        (0..n).map(|_| Mutex::new(None)).collect();
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= n {
                        break;
                    }
                    let result = run(i, jobs == 1).map(|(r, what)| {
                        if opts.progress && jobs > 1 {
                            crate::console!("done: {what}");
                        }
                        r
                    });
                    let failed = result.is_err();
                    *slots[i].lock().unwrap_or_else(PoisonError::into_inner) = Some(result);
                    if failed {
                        // Take no further cases; the ones running finish their trial loop.
                        next.store(n, Ordering::Relaxed);
                        break;
                    }
                }
            });
        }
    });
    let mut out = Vec::with_capacity(n);
    for slot in slots {
        match slot.into_inner().unwrap_or_else(PoisonError::into_inner) {
            Some(Ok(r)) => out.push(r),
            Some(Err(e)) => return Err(e),
            None => {}
        }
    }
    if out.len() != n {
        return Err(PaperError::Invalid("a campaign did not run".into()));
    }
    Ok(out)
}

/// Reads a finished case's recordings and derives their metrics.
fn case_data(opts: &PaperOptions, result: CaseResult) -> Result<CaseData, PaperError> {
    let kind = result.trajectory;
    let trajectory = Trajectory {
        kind,
        duration: scenario::duration(opts, kind),
        home_height: 0.5,
    };
    let mut recordings = Vec::new();
    let mut metrics = Vec::new();
    let recorded = recorded_trials(opts.trials, result.scheme);
    let last = recorded.last().copied();
    for k in recorded {
        let rec = read_recording_csv(&trial_csv(&result.dir, k))?;
        metrics.push(metrics::trial_metrics(k, &rec, &trajectory));
        // Drawn in full: the trial the claims look at (leg errors, path) and the last one
        // (learned input of every leg).
        let full = k == figures::claim_trial(kind) || Some(k) == last;
        recordings.push(figures::TrialData::new(k, rec, &trajectory, full));
    }
    Ok(CaseData {
        result,
        recordings,
        metrics,
        trajectory,
    })
}

fn write_convergence_table(opts: &PaperOptions, results: &[CaseResult]) -> Result<(), PaperError> {
    let header = [
        "trajectory",
        "scheme",
        "trial",
        "max",
        "rms",
        "lambda",
        "path_max",
        "path_rms",
    ];
    let rows: Vec<Vec<String>> = results
        .iter()
        .flat_map(|r| {
            r.summaries.iter().map(move |s| {
                let mut row = vec![
                    traj_slug(r.trajectory).to_string(),
                    r.scheme.slug().to_string(),
                    s.trial.to_string(),
                ];
                row.extend(s.overall_cells());
                row
            })
        })
        .collect();
    write_table_csv(&opts.out_dir.join("convergence.csv"), &header, &rows)?;
    Ok(())
}
