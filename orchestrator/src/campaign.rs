//! A campaign: every trial of a scenario, with results and memory persisted atomically
//! after each trial so an interrupted campaign resumes with identical results.
//!
//! Output directory layout:
//! - `scenario.toml`: the scenario as run;
//! - `trials/trial_NNN.csv`: recorded variables of each recorded trial;
//! - `memory/after_trial_NNN.f64`: the iteration memory the last completed trial NNN produced
//!   (read by trial NNN+1; exact binary; older ones are removed once the next trial is done);
//! - `memory.csv`: that memory as a table, written when the run ends;
//! - `summary.csv`: metrics of every completed trial;
//! - `progress.toml`: completed trial count and a fingerprint of scenario and FMUs,
//!   written last, so it never claims a trial whose files are missing.

use std::fs;
use std::path::{Path, PathBuf};

use ckcm::metrics::{LegErrorMetrics, PathErrorStats, leg_error_metrics, path_error};
use fmi2::import::Fmu;
use indicatif::{ProgressBar, ProgressStyle};

use crate::master::{Master, MasterError, TrialSignals};
use crate::output::{
    CsvExporter, OutputError, Recording, write_atomic, write_recording, write_table_csv,
};
use crate::scenario::Scenario;

/// A campaign failure.
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    #[error(transparent)]
    Master(#[from] MasterError),
    #[error(transparent)]
    Output(#[from] OutputError),
    #[error("cannot resume in {dir}: {message}")]
    Resume { dir: PathBuf, message: String },
    #[error("cannot create {path}: {source}")]
    CreateDir {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// How to run a campaign.
#[derive(Debug, Clone)]
pub struct CampaignOptions {
    pub out_dir: PathBuf,
    /// Continue after the last completed trial found in `out_dir`.
    pub resume: bool,
    /// Pass loggingOn = true to the FMUs.
    pub fmu_logging: bool,
    /// Show a progress bar (it hides itself when stderr is not a terminal).
    pub progress: bool,
    /// Stop after this many trials in total (for tests of interruption); `None` runs all.
    pub stop_after: Option<usize>,
}

/// Metrics of one trial.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrialSummary {
    pub trial: usize,
    pub legs: LegErrorMetrics,
    pub path: Option<PathErrorStats>,
}

/// Header of `summary.csv`.
pub fn summary_header() -> Vec<String> {
    let mut h = vec!["trial".to_string()];
    for stat in ["max", "rms", "lambda"] {
        for leg in 1..=6 {
            h.push(format!("{stat}_leg{leg}"));
        }
    }
    h.extend(["max", "rms", "lambda", "path_max", "path_rms"].map(String::from));
    h
}

impl TrialSummary {
    /// One `summary.csv` row (values in m; shortest round-trip formatting).
    pub fn to_row(&self) -> Vec<String> {
        let mut r = vec![self.trial.to_string()];
        let picks: [fn(&ckcm::metrics::ErrorStats) -> f64; 3] =
            [|s| s.max, |s| s.rms, |s| s.lambda];
        for pick in picks {
            r.extend(self.legs.per_leg.iter().map(|s| pick(s).to_string()));
        }
        r.extend(
            [
                self.legs.overall.max,
                self.legs.overall.rms,
                self.legs.overall.lambda,
            ]
            .map(|x| x.to_string()),
        );
        match self.path {
            Some(p) => r.extend([p.max.to_string(), p.rms.to_string()]),
            None => r.extend([String::new(), String::new()]),
        }
        r
    }

    /// Parses a row written by [`TrialSummary::to_row`].
    pub fn from_row(row: &[String]) -> Option<Self> {
        let num = |i: usize| row.get(i)?.parse::<f64>().ok();
        let mut legs = LegErrorMetrics::default();
        for leg in 0..6 {
            legs.per_leg[leg].max = num(1 + leg)?;
            legs.per_leg[leg].rms = num(7 + leg)?;
            legs.per_leg[leg].lambda = num(13 + leg)?;
        }
        legs.overall.max = num(19)?;
        legs.overall.rms = num(20)?;
        legs.overall.lambda = num(21)?;
        let path = match (num(22), num(23)) {
            (Some(max), Some(rms)) => Some(PathErrorStats { max, rms }),
            _ => None,
        };
        Some(Self {
            trial: row.first()?.parse().ok()?,
            legs,
            path,
        })
    }

    fn compute(trial: usize, scenario: &Scenario, s: &TrialSignals) -> Self {
        let rho = scenario
            .metrics
            .as_ref()
            .map_or(crate::scenario::DEFAULT_RHO, |m| m.rho);
        // The λ-norm weights time since the start of the trial.
        let rel: Vec<f64> = s.time.iter().map(|t| t - scenario.start_time).collect();
        let e: [&[f64]; 6] = std::array::from_fn(|i| s.error[i].as_slice());
        let legs = leg_error_metrics(&rel, &e, rho);
        let path = scenario
            .metrics
            .as_ref()
            .and_then(|m| m.trajectory)
            .filter(|_| !s.position.is_empty())
            .map(|traj| {
                let desired: Vec<[f64; 3]> = rel
                    .iter()
                    .map(|&t| traj.sample(t).pose.p_world.into())
                    .collect();
                path_error(&s.position, &desired)
            });
        Self { trial, legs, path }
    }
}

/// FNV-1a, 64 bit: a stable fingerprint across builds and platforms (std's hasher is not
/// guaranteed stable), over a handful of bytes where speed does not matter.
pub(crate) fn fnv1a(hash: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(hash, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

fn fingerprint(scenario: &Scenario, text: &str) -> Result<String, CampaignError> {
    let mut h = fnv1a(0xcbf2_9ce4_8422_2325, text.as_bytes());
    for f in &scenario.fmus {
        let bytes = fs::read(&f.path).map_err(|e| CampaignError::Resume {
            dir: f.path.clone(),
            message: format!("cannot read FMU: {e}"),
        })?;
        h = fnv1a(h, &bytes);
    }
    Ok(format!("{h:016x}"))
}

#[derive(Debug, serde::Deserialize)]
struct Progress {
    completed: usize,
    fingerprint: String,
}

fn trial_csv(dir: &Path, k: usize) -> PathBuf {
    dir.join("trials").join(format!("trial_{k:03}.csv"))
}

fn memory_file(dir: &Path, k: usize) -> PathBuf {
    dir.join("memory").join(format!("after_trial_{k:03}.f64"))
}

/// Magic bytes of a memory file (format version 1).
const MEMORY_MAGIC: &[u8; 8] = b"CKCMMEM1";

/// The iteration memory for resuming, exact and fast: `CKCMMEM1`, the channel count and
/// each channel's length (u64), then every channel's values (f64), all little-endian.
/// Formatting 10⁵ floats as text after every trial would cost more than the trial's
/// co-simulation overhead; the readable `memory.csv` is written once at the end.
fn write_memory(path: &Path, buffers: &[&[f64]]) -> Result<(), OutputError> {
    write_atomic(path, |w| {
        w.write_all(MEMORY_MAGIC)?;
        w.write_all(&(buffers.len() as u64).to_le_bytes())?;
        for b in buffers {
            w.write_all(&(b.len() as u64).to_le_bytes())?;
        }
        for b in buffers {
            for x in *b {
                w.write_all(&x.to_le_bytes())?;
            }
        }
        Ok(())
    })
}

/// Reads a memory file, checking it holds channels of exactly `lens` values.
fn read_memory(path: &Path, lens: &[usize]) -> Result<Vec<Vec<f64>>, String> {
    let bytes = fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let bad = |what: &str| format!("{}: {what}", path.display());
    let mut at = 0;
    let mut take = |n: usize| -> Result<&[u8], String> {
        let s = bytes
            .get(at..at + n)
            .ok_or_else(|| bad("truncated memory file"))?;
        at += n;
        Ok(s)
    };
    if take(8)? != MEMORY_MAGIC {
        return Err(bad("not a memory file of this program"));
    }
    let u64_at = |s: &[u8]| u64::from_le_bytes(s.try_into().expect("8 bytes")) as usize;
    if u64_at(take(8)?) != lens.len() {
        return Err(bad("memory channels do not match the scenario"));
    }
    for &len in lens {
        if u64_at(take(8)?) != len {
            return Err(bad("memory length does not match the scenario"));
        }
    }
    let mut out = Vec::with_capacity(lens.len());
    for &len in lens {
        let raw = take(len * 8)?;
        out.push(
            raw.chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect(),
        );
    }
    if at != bytes.len() {
        return Err(bad("trailing bytes in memory file"));
    }
    Ok(out)
}

/// The final memory as a readable table: `time`, then one column per memory element.
fn write_memory_csv(
    path: &Path,
    scenario: &Scenario,
    names: &[String],
    buffers: &[&[f64]],
) -> Result<(), OutputError> {
    let mut mem = Recording::with_capacity(names.to_vec(), scenario.steps);
    let mut row = vec![0.0; names.len()];
    for n in 0..scenario.steps {
        let mut col = 0;
        for (c, l) in scenario.memory.iter().enumerate() {
            let width = l.from.value_references.len();
            row[col..col + width].copy_from_slice(&buffers[c][n * width..(n + 1) * width]);
            col += width;
        }
        mem.push_row(scenario.time(n), &row);
    }
    write_recording(path, &mem, &CsvExporter)
}

/// Runs (or resumes) every trial of `scenario` with `fmus` opened from its FMU paths,
/// returning the summaries of all trials.
pub fn run_campaign(
    scenario: &Scenario,
    scenario_text: &str,
    fmus: Vec<Fmu>,
    opts: &CampaignOptions,
) -> Result<Vec<TrialSummary>, CampaignError> {
    let dir = &opts.out_dir;
    let fp = fingerprint(scenario, scenario_text)?;
    let mut master = Master::new(scenario, fmus, opts.fmu_logging)?;
    let mut summaries: Vec<TrialSummary> = Vec::new();
    let mut first = 0;
    let progress_file = dir.join("progress.toml");
    if opts.resume && progress_file.exists() {
        let resume_err = |message: String| CampaignError::Resume {
            dir: dir.clone(),
            message,
        };
        let text = fs::read_to_string(&progress_file)
            .map_err(|e| resume_err(format!("cannot read progress.toml: {e}")))?;
        let p: Progress =
            toml::from_str(&text).map_err(|e| resume_err(format!("progress.toml: {e}")))?;
        if p.fingerprint != fp {
            return Err(resume_err(
                "it holds a campaign of a different scenario or different FMUs".into(),
            ));
        }
        let rows = read_summary(&dir.join("summary.csv")).map_err(resume_err)?;
        if rows.len() < p.completed {
            return Err(resume_err(format!(
                "summary.csv has {} trials, progress.toml says {}",
                rows.len(),
                p.completed
            )));
        }
        summaries = rows.into_iter().take(p.completed).collect();
        first = p.completed;
        if first > 0 {
            let lens: Vec<usize> = scenario
                .memory
                .iter()
                .map(|l| scenario.steps * l.from.value_references.len())
                .collect();
            let data = read_memory(&memory_file(dir, first - 1), &lens).map_err(resume_err)?;
            master.set_memory(&data);
        }
    } else {
        // A fresh campaign: forget a previous one in the same directory (only our own files).
        let _ = fs::remove_file(&progress_file);
        let _ = fs::remove_dir_all(dir.join("trials"));
        let _ = fs::remove_dir_all(dir.join("memory"));
        let _ = fs::remove_file(dir.join("summary.csv"));
    }
    let last = opts
        .stop_after
        .unwrap_or(scenario.trials)
        .min(scenario.trials);
    let bar = if opts.progress {
        let bar = ProgressBar::new(((last.saturating_sub(first)) * scenario.steps) as u64);
        bar.set_style(
            ProgressStyle::with_template("{msg} [{bar:30}] {percent:>3}% {elapsed}<{eta}")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let mut recording: Recording = master.new_recording();
    let mut signals = master.new_signals();
    let memory_names = master.memory_names();
    let header = summary_header();
    let header_refs: Vec<&str> = header.iter().map(String::as_str).collect();
    for k in first..last {
        bar.set_message(format!("trial {k}/{}", scenario.trials - 1));
        let rec = scenario.record.records_trial(k).then_some(&mut recording);
        let record_this = rec.is_some();
        master.run_trial(k, rec, &mut signals, |n| {
            if n % 1000 == 999 {
                bar.inc(1000);
            }
        })?;
        // Folders appear only once a trial has succeeded: a run that fails at once leaves nothing.
        for sub in ["trials", "memory"] {
            let p = dir.join(sub);
            fs::create_dir_all(&p)
                .map_err(|source| CampaignError::CreateDir { path: p, source })?;
        }
        if k == first {
            write_atomic(&dir.join("scenario.toml"), |w| {
                w.write_all(scenario_text.as_bytes())
            })?;
        }
        if record_this {
            write_recording(&trial_csv(dir, k), &recording, &CsvExporter)?;
        }
        write_memory(&memory_file(dir, k), &master.memory())?;
        summaries.push(TrialSummary::compute(k, scenario, &signals));
        let rows: Vec<Vec<String>> = summaries.iter().map(TrialSummary::to_row).collect();
        write_table_csv(&dir.join("summary.csv"), &header_refs, &rows)?;
        let progress = format!("completed = {}\nfingerprint = \"{fp}\"\n", k + 1);
        write_atomic(&progress_file, |w| w.write_all(progress.as_bytes()))?;
        // Resume needs only the newest memory; the older one is stale once progress moved on.
        if k > 0 {
            let _ = fs::remove_file(memory_file(dir, k - 1));
        }
    }
    bar.finish_and_clear();
    if last > first {
        write_memory_csv(
            &dir.join("memory.csv"),
            scenario,
            &memory_names,
            &master.memory(),
        )?;
    }
    Ok(summaries)
}

pub fn read_summary(path: &Path) -> Result<Vec<TrialSummary>, String> {
    let mut reader =
        csv::Reader::from_path(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    for (i, rec) in reader.records().enumerate() {
        let rec = rec.map_err(|e| format!("{}: {e}", path.display()))?;
        let row: Vec<String> = rec.iter().map(String::from).collect();
        out.push(
            TrialSummary::from_row(&row)
                .ok_or_else(|| format!("{}:{}: malformed summary row", path.display(), i + 2))?,
        );
    }
    Ok(out)
}
