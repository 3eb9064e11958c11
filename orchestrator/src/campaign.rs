//! A campaign: every trial of a scenario, with results and memory persisted atomically
//! after each trial so an interrupted campaign resumes with identical results.
//!
//! Output directory layout:
//! - `scenario.toml`: the scenario as run (absolute FMU paths, the trial count run);
//! - `trials/trial_NNN.csv`: recorded variables of each recorded trial;
//! - `memory/after_trial_NNN.f64`: the iteration memory the last completed trial NNN produced
//!   (read by trial NNN+1; exact binary with a format version and a checksum; older ones are
//!   removed once the next trial is done);
//! - `memory.csv`: that memory as a table, written when the run ends;
//! - `summary.csv`: metrics of every completed trial;
//! - `progress.toml`: completed trial count and a fingerprint of scenario and FMUs,
//!   written last, so it never claims a trial whose files are missing;
//! - `.lock`: present while a run holds the folder (see [`lock`]).
//!
//! Guarantees: one run at a time per folder; a new run refuses a folder that already holds
//! files unless forced, and even then removes the old campaign only once its own first trial
//! succeeded; `--resume` removes what a killed run left half-done (temporary files, memory
//! files of trials that `progress.toml` does not claim) and finishes every file.

mod lanes;
mod lock;
mod writers;

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::PoisonError;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use ckcm::metrics::{LegErrorMetrics, PathErrorStats, leg_error_metrics, path_error};
use clap::ValueEnum;
use fmi2_import::Fmu;
use fmi2_md::Shown;
use indicatif::{ProgressBar, ProgressStyle};

use self::lanes::Failed;
pub use self::lock::{DirLock, LOCK_FILE};
use self::writers::Writers;
use crate::master::{FmuConsole, Master, MasterError, TrialSignals};
use crate::output::{
    CsvExporter, Exporter, OutputError, Prepared, RecordedRows, Recording, prepare_atomic,
    push_csv_record, write_atomic, write_recorded_rows,
};
use crate::scenario::{RecordFormat, Scenario, ScenarioError, as_run_text};

/// A campaign failure.
#[derive(Debug, thiserror::Error)]
pub enum CampaignError {
    #[error(transparent)]
    Master(#[from] MasterError),
    #[error(transparent)]
    Output(#[from] OutputError),
    #[error(transparent)]
    TooLarge(#[from] ScenarioError),
    #[error("cannot resume in {dir}: {message}")]
    Resume { dir: PathBuf, message: String },
    #[error("cannot create {path}: {source}")]
    CreateDir {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot lock {path}: {source}")]
    Lock {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error(
        "{} is in use by another run ({holder}); wait for it to end or choose another --out",
        dir.display()
    )]
    Locked { dir: PathBuf, holder: String },
    #[error(
        "{} already holds {what}; a new run would replace it: use --resume to continue it, \
         --force to replace it, or choose another --out",
        dir.display()
    )]
    NotEmpty { dir: PathBuf, what: String },
    #[error(
        "cannot move {} aside to replace the campaign (--force): {source}; the old campaign \
         is unchanged",
        path.display()
    )]
    Replace {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot remove {path}: {source}")]
    Remove {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("cannot open another copy of FMU {fmu:?} ({}) for a second lane: {source}", path.display())]
    SecondCopy {
        fmu: String,
        path: PathBuf,
        source: Box<fmi2_import::ImportError>,
    },
}

/// Default of [`CampaignOptions::memory_limit_mib`] and of the scenario key
/// `memory_limit_mib`: 4 GiB.
pub const DEFAULT_MEMORY_LIMIT_MIB: u64 = 4096;

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
    /// Start a new campaign even if `out_dir` holds files (the old campaign's files are
    /// removed once the new first trial has succeeded).
    pub force: bool,
    /// Refuse to start when the campaign would need more memory than this, in MiB; `None`
    /// takes the scenario's `memory_limit_mib`, else [`DEFAULT_MEMORY_LIMIT_MIB`].
    pub memory_limit_mib: Option<u64>,
    /// Abort the process (no clean-up, like SIGKILL) at the n-th file operation, counting
    /// from 1: for tests that interrupt a campaign at every point.
    pub crash_at: Option<usize>,
    /// Trials run at the same time: N ≥ 2 runs trial k+1 on another lane a chunk of steps
    /// behind trial k (`lanes`) when every memory channel has the plain update, as many
    /// lanes as trials are left and as N times the memory estimate fits the limit;
    /// otherwise, or with 1, one trial runs after the other. Results do not depend on it.
    pub lanes: usize,
}

/// Metrics of one trial.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrialSummary {
    pub trial: usize,
    /// `None` when the scenario has no `[metrics]`: nothing was measured, which summary.csv
    /// writes as empty cells rather than zeros that read as a perfect trial.
    pub legs: Option<LegErrorMetrics>,
    pub path: Option<PathErrorStats>,
}

/// A row of `summary.csv` that could not be formatted (in memory, so in practice never).
fn summary_error(dir: &Path, source: std::io::Error) -> CampaignError {
    CampaignError::from(OutputError::Io {
        path: dir.join("summary.csv"),
        source,
    })
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
        match &self.legs {
            Some(legs) => {
                let picks: [fn(&ckcm::metrics::ErrorStats) -> f64; 3] =
                    [|s| s.max, |s| s.rms, |s| s.lambda];
                for pick in picks {
                    r.extend(legs.per_leg.iter().map(|s| pick(s).to_string()));
                }
                r.extend(
                    [legs.overall.max, legs.overall.rms, legs.overall.lambda]
                        .map(|x| x.to_string()),
                );
            }
            None => r.extend(std::iter::repeat_n(String::new(), 21)),
        }
        match self.path {
            Some(p) => r.extend([p.max.to_string(), p.rms.to_string()]),
            None => r.extend([String::new(), String::new()]),
        }
        r
    }

    /// The overall cells for the study's tables: max, RMS and λ-norm over the legs, then the
    /// path's max and RMS; empty where the trial was not measured.
    pub fn overall_cells(&self) -> [String; 5] {
        let text = |x: Option<f64>| x.map(|x| x.to_string()).unwrap_or_default();
        let legs = self.legs.map(|l| l.overall);
        [
            text(legs.map(|o| o.max)),
            text(legs.map(|o| o.rms)),
            text(legs.map(|o| o.lambda)),
            text(self.path.map(|p| p.max)),
            text(self.path.map(|p| p.rms)),
        ]
    }

    /// Parses a row written by [`TrialSummary::to_row`] (by this version or an earlier one).
    pub fn from_row(row: &[String]) -> Option<Self> {
        let num = |i: usize| row.get(i)?.parse::<f64>().ok();
        let unmeasured = (1..=21).all(|i| row.get(i).is_some_and(String::is_empty));
        let legs = if unmeasured {
            None
        } else {
            let mut legs = LegErrorMetrics::default();
            for leg in 0..6 {
                legs.per_leg[leg].max = num(1 + leg)?;
                legs.per_leg[leg].rms = num(7 + leg)?;
                legs.per_leg[leg].lambda = num(13 + leg)?;
            }
            legs.overall.max = num(19)?;
            legs.overall.rms = num(20)?;
            legs.overall.lambda = num(21)?;
            Some(legs)
        };
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
        let Some(metrics) = &scenario.metrics else {
            return Self {
                trial,
                legs: None,
                path: None,
            };
        };
        // The λ-norm weights time since the start of the trial.
        let rel: Vec<f64> = s.time.iter().map(|t| t - scenario.start_time).collect();
        let legs = Some(leg_error_metrics(&rel, &s.error, metrics.rho));
        let path = metrics
            .trajectory
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
/// guaranteed stable). Over the scenario and its FMU files it costs about 8 M instructions
/// per run (BENCHMARKS.md, round 11); another hash would make `--resume` refuse campaigns
/// begun by earlier versions.
pub(crate) fn fnv1a(hash: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(hash, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// [`fnv1a`] from two states over the same bytes in one pass: each byte costs a multiply
/// whose latency a single chain waits for, so the two independent chains take about the
/// time of one (the FMU files' two passes were 6 % of a one-trial sweep case).
fn fnv1a_two([a, b]: [u64; 2], bytes: &[u8]) -> [u64; 2] {
    bytes.iter().fold([a, b], |[a, b], &byte| {
        let byte = u64::from(byte);
        [
            (a ^ byte).wrapping_mul(0x0100_0000_01b3),
            (b ^ byte).wrapping_mul(0x0100_0000_01b3),
        ]
    })
}

/// FNV-1a's offset basis, where every fingerprint starts.
pub(crate) const FNV_BASIS: u64 = 0xcbf2_9ce4_8422_2325;

/// The [`fnv1a`] of what a scenario sets, with its FMU paths and trial count left out: the
/// first part of a campaign's fingerprint, and what a sweep records of a finished case.
pub(crate) fn scenario_digest(scenario: &Scenario, text: &str) -> Result<u64, CampaignError> {
    let placeholders = vec![""; scenario.fmus.len()];
    let identity = as_run_text(text, &scenario.source, &placeholders, 0)?;
    Ok(fnv1a(FNV_BASIS, identity.as_bytes()))
}

/// A campaign's identity: its scenario text with the FMU paths and the trial count left out
/// ([`as_run_text`] with placeholders) and the bytes of its FMUs, so the original scenario
/// file, the saved `scenario.toml` and any `--trials` name the same campaign. Also the
/// fingerprint earlier versions wrote (the text as given, then the FMUs), so their campaigns
/// still resume.
struct Fingerprints {
    current: String,
    earlier: String,
}

fn fingerprint(scenario: &Scenario, text: &str) -> Result<Fingerprints, CampaignError> {
    let (mut current, mut earlier) = (
        scenario_digest(scenario, text)?,
        fnv1a(FNV_BASIS, text.as_bytes()),
    );
    for f in &scenario.fmus {
        let bytes = fs::read(&f.path).map_err(|e| CampaignError::Resume {
            dir: f.path.clone(),
            message: format!("cannot read FMU: {e}"),
        })?;
        [current, earlier] = fnv1a_two([current, earlier], &bytes);
    }
    Ok(Fingerprints {
        current: format!("{current:016x}"),
        earlier: format!("{earlier:016x}"),
    })
}

/// The scenario as run, for `scenario.toml`: absolute FMU paths (the text's were relative
/// to the original file) and the trial count actually run.
fn as_run(scenario: &Scenario, text: &str) -> Result<String, CampaignError> {
    let paths: Vec<String> = scenario
        .fmus
        .iter()
        .map(|f| {
            let absolute = std::path::absolute(&f.path).unwrap_or_else(|_| f.path.clone());
            if absolute.to_str().is_none() {
                crate::console!(
                    "warning: FMU {:?} lies at a path that is not valid UTF-8, which the saved \
                     scenario.toml (TOML, UTF-8) cannot hold: resume with the original scenario \
                     file, not with that copy",
                    f.name
                );
            }
            absolute.to_string_lossy().into_owned()
        })
        .collect();
    let paths: Vec<&str> = paths.iter().map(String::as_str).collect();
    Ok(as_run_text(
        text,
        &scenario.source,
        &paths,
        scenario.trials,
    )?)
}

/// Why a folder's campaign is not this one, for the refused resume: the first line where
/// its saved `scenario.toml` and this scenario differ (FMU paths and trial counts aside,
/// as the fingerprint leaves them out), or else its FMU files.
fn what_differs(dir: &Path, scenario: &Scenario, text: &str) -> String {
    const GENERIC: &str = "it holds a campaign of a different scenario or different FMUs";
    let saved_file = dir.join("scenario.toml");
    let Ok(saved) = fs::read_to_string(&saved_file) else {
        return GENERIC.into();
    };
    let placeholders = vec![""; scenario.fmus.len()];
    // A saved file that does not reduce (damaged, or another count of [[fmu]]) is named
    // no further than before.
    let (Ok(theirs), Ok(ours)) = (
        as_run_text(&saved, &saved_file, &placeholders, 0),
        as_run_text(text, &scenario.source, &placeholders, 0),
    ) else {
        return GENERIC.into();
    };
    if theirs == ours {
        return "it holds a campaign of this scenario run with other FMU files (rebuilt or \
                replaced since it began)"
            .into();
    }
    format!(
        "it holds a campaign of a different scenario: {}",
        first_difference(&theirs, &ours, "scenario.toml", "this scenario")
    )
}

/// Where a folder's saved copy `theirs` (its file `file`) first differs from `ours` (`this`
/// names it), by lines with text numbered as in the file: a blank line added or removed
/// above the edit does not hide it.
pub(crate) fn first_difference(theirs: &str, ours: &str, file: &str, this: &str) -> String {
    let text_lines = |t: &str| -> Vec<(usize, String)> {
        t.lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty())
            .map(|(i, l)| (i + 1, l.trim().to_owned()))
            .collect()
    };
    let (theirs, ours) = (text_lines(theirs), text_lines(ours));
    let n = theirs
        .iter()
        .zip(&ours)
        .take_while(|(a, b)| a.1 == b.1)
        .count();
    let line = match theirs.get(n) {
        Some((i, l)) => format!("line {i} of its {file} reads `{l}`"),
        None if n < ours.len() => format!("its {file} ends"),
        None => return format!("its {file} differs from this one in blank lines or spaces only"),
    };
    let ours = match ours.get(n) {
        Some((_, l)) => format!("`{l}`"),
        None => "nothing more".to_owned(),
    };
    format!("{line}, where {this} has {ours}")
}

#[derive(Debug, serde::Deserialize)]
struct Progress {
    completed: usize,
    fingerprint: String,
}

fn read_progress(file: &Path) -> Result<Progress, String> {
    let text = fs::read_to_string(file).map_err(|e| format!("cannot read progress.toml: {e}"))?;
    toml::from_str(&text).map_err(|e| format!("progress.toml: {e}"))
}

/// How many trials the campaign of `scenario` (with `text`) in `dir` has completed and
/// kept, by its `progress.toml`; `None` if it holds none readable, or one of another
/// scenario (a `--force` run that failed before its first trial leaves the old one).
pub fn completed_trials(dir: &Path, scenario: &Scenario, text: &str) -> Option<usize> {
    let p = read_progress(&dir.join("progress.toml")).ok()?;
    let ours = fingerprint(scenario, text).ok()?.matches(&p);
    ours.then_some(p.completed)
}

impl Fingerprints {
    fn matches(&self, p: &Progress) -> bool {
        p.fingerprint == self.current || p.fingerprint == self.earlier
    }
}

/// Whether the campaign in `dir` was begun from `scenario` and its FMUs as they are now,
/// which `--resume` requires; `None` if `dir` holds no campaign (no `progress.toml`).
/// A sweep keeps its finished cases on resume and asks this of them.
pub(crate) fn begun_with(
    dir: &Path,
    scenario: &Scenario,
    text: &str,
) -> Result<Option<bool>, CampaignError> {
    let file = dir.join("progress.toml");
    if !file.exists() {
        return Ok(None);
    }
    let p = read_progress(&file).map_err(|message| CampaignError::Resume {
        dir: dir.to_path_buf(),
        message,
    })?;
    Ok(Some(fingerprint(scenario, text)?.matches(&p)))
}

/// The CSV recording of trial `k` in campaign folder `dir`.
pub fn trial_csv(dir: &Path, k: usize) -> PathBuf {
    trial_file(dir, k, RecordFormat::Csv)
}

/// The recording of trial `k` in campaign folder `dir` in `format`: the one place that
/// names it.
pub fn trial_file(dir: &Path, k: usize, format: RecordFormat) -> PathBuf {
    let ext = format.exporter().extension();
    dir.join("trials").join(format!("trial_{k:03}.{ext}"))
}

/// Where the recording of trial `k`, which failed, is kept up to its failure: beside the
/// completed trials, under a name no completed trial's file has, so that reading the
/// campaign's trials never takes it for one.
pub fn failed_trial_file(dir: &Path, k: usize, format: RecordFormat) -> PathBuf {
    let ext = format.exporter().extension();
    dir.join("trials")
        .join(format!("trial_{k:03}.failed.{ext}"))
}

/// The trial of a failed trial's recording ([`failed_trial_file`]'s inverse, any format).
fn failed_trial_of_file(name: &str) -> Option<usize> {
    let (k, ext) = name.strip_prefix("trial_")?.split_once(".failed.")?;
    RecordFormat::value_variants()
        .iter()
        .any(|f| f.exporter().extension() == ext)
        .then(|| k.parse().ok())?
}

/// The trial and format of a recording's file name ([`trial_file`]'s inverse, any format).
fn trial_of_file(name: &str) -> Option<(usize, RecordFormat)> {
    let rest = name.strip_prefix("trial_")?;
    // Every format's files (clap's list of the variants).
    RecordFormat::value_variants().iter().find_map(|&f| {
        let k = rest
            .strip_suffix(f.exporter().extension())?
            .strip_suffix('.')?;
        Some((k.parse().ok()?, f))
    })
}

fn memory_file(dir: &Path, k: usize) -> PathBuf {
    dir.join("memory").join(format!("after_trial_{k:03}.f64"))
}

/// Magic bytes of a memory file; the last byte is the format version.
const MEMORY_MAGIC: &[u8; 8] = b"CKCMMEM2";
/// The first format, without a checksum; recognised only to say so.
const MEMORY_MAGIC_V1: &[u8; 8] = b"CKCMMEM1";

/// The bytes of a memory file, the iteration memory for resuming, exact and fast:
/// `CKCMMEM2` (format version 2), the channel count and each channel's length (u64), every
/// channel's values (f64), then the CRC-32 of everything before it (u32), all little-endian.
/// The checksum turns a corrupted or hand-edited file into an error instead of a silently
/// different campaign. Formatting 10⁵ floats as text after every trial would cost more than
/// the trial's co-simulation overhead; the readable `memory.csv` is written once at the end.
fn memory_bytes(buffers: &[&[f64]]) -> Vec<u8> {
    // Assembled in memory and checksummed in one pass: one checksum update per value cost
    // more than writing the file (BENCHMARKS.md, round 5).
    let values: usize = buffers.iter().map(|b| b.len()).sum();
    let mut bytes = Vec::with_capacity(MEMORY_MAGIC.len() + 8 * (1 + buffers.len() + values) + 4);
    bytes.extend_from_slice(MEMORY_MAGIC);
    bytes.extend_from_slice(&(buffers.len() as u64).to_le_bytes());
    for b in buffers {
        bytes.extend_from_slice(&(b.len() as u64).to_le_bytes());
    }
    for b in buffers {
        for x in *b {
            bytes.extend_from_slice(&x.to_le_bytes());
        }
    }
    let crc = crc32fast::hash(&bytes);
    bytes.extend_from_slice(&crc.to_le_bytes());
    bytes
}

/// Reads a memory file, checking its version and checksum, that it holds channels of
/// exactly `lens` values, and that every value is finite.
fn read_memory(path: &Path, lens: &[usize]) -> Result<Vec<Vec<f64>>, String> {
    let bytes = fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let bad = |what: &str| format!("{}: {what}", path.display());
    if bytes.starts_with(MEMORY_MAGIC_V1) {
        return Err(bad(
            "memory file format version 1 (without a checksum) is no longer read; \
             start the campaign again without --resume",
        ));
    }
    if !bytes.starts_with(MEMORY_MAGIC) {
        return Err(bad("not a memory file of this program (wrong magic bytes)"));
    }
    let Some(body_len) = bytes.len().checked_sub(4) else {
        return Err(bad("truncated memory file"));
    };
    let (body, stored) = bytes.split_at(body_len);
    let stored = u32::from_le_bytes(stored.try_into().expect("4 bytes"));
    let computed = crc32fast::hash(body);
    if stored != computed {
        return Err(bad(&format!(
            "checksum mismatch (stored {stored:08x}, computed {computed:08x}): the file is \
             corrupted or was edited; start the campaign again without --resume"
        )));
    }
    let mut at = MEMORY_MAGIC.len();
    let mut take = |n: usize| -> Result<&[u8], String> {
        let s = at
            .checked_add(n)
            .and_then(|end| body.get(at..end))
            .ok_or_else(|| bad("truncated memory file"))?;
        at += n;
        Ok(s)
    };
    let u64_at = |s: &[u8]| u64::from_le_bytes(s.try_into().expect("8 bytes"));
    if u64_at(take(8)?) != lens.len() as u64 {
        return Err(bad("memory channels do not match the scenario"));
    }
    for &len in lens {
        if u64_at(take(8)?) != len as u64 {
            return Err(bad("memory length does not match the scenario"));
        }
    }
    let mut out = Vec::with_capacity(lens.len());
    for (c, &len) in lens.iter().enumerate() {
        let raw = take(len * 8)?;
        let values: Vec<f64> = raw
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect();
        if let Some(i) = values.iter().position(|x| !x.is_finite()) {
            return Err(bad(&format!(
                "memory channel {} value {i} is {}, not a finite number",
                c + 1,
                values[i]
            )));
        }
        out.push(values);
    }
    if at != body.len() {
        return Err(bad("trailing bytes in memory file"));
    }
    Ok(out)
}

/// The final memory as a readable table (`time`, then one column per memory element),
/// durable but not yet in place.
fn prepare_memory_csv(
    path: &Path,
    scenario: &Scenario,
    names: &[String],
    buffers: &[&[f64]],
) -> Result<Prepared, OutputError> {
    let mut mem = Recording::with_capacity(names.to_vec(), scenario.steps);
    let mut row = vec![0.0; names.len()];
    for n in 0..scenario.steps {
        let mut col = 0;
        for (c, m) in scenario.memory.iter().enumerate() {
            let width = m.link.from.value_references.len();
            row[col..col + width].copy_from_slice(&buffers[c][n * width..(n + 1) * width]);
            col += width;
        }
        mem.push_row(scenario.time(n), &row);
    }
    prepare_atomic(path, |w| CsvExporter.write(&mem, w))
}

/// Bytes a campaign of `scenario` holds at its peak (8 bytes per value): the read and write
/// memory buffers, a resumed memory, the `memory.csv` table, the recording of one trial, the
/// full-rate signals and the metric work arrays. FMU-internal memory is not included.
pub fn memory_estimate(scenario: &Scenario) -> u64 {
    let steps = scenario.steps as f64;
    let memory_width: usize = scenario
        .memory
        .iter()
        .map(|l| l.link.from.value_references.len())
        .sum();
    // Memory: read + write + resumed copy + memory.csv (with its time column).
    let memory = steps * (4 * memory_width + 1) as f64;
    // Signals: time, six errors, x y z; metrics: relative time, desired x y z.
    let signals = steps * (1 + 6 + 3 + 1 + 3) as f64;
    saturating_u64(8.0 * (memory + signals) + recording_bytes(scenario))
}

/// Bytes one trial's recording holds (its time column included).
fn recording_bytes(scenario: &Scenario) -> f64 {
    let recorded: usize = scenario.record.ports.iter().map(|p| p.names.len()).sum();
    let rows = (scenario.steps as f64 / scenario.record.interval as f64).ceil();
    8.0 * rows * (recorded + 1) as f64
}

fn saturating_u64(bytes: f64) -> u64 {
    if bytes >= u64::MAX as f64 {
        u64::MAX
    } else {
        bytes as u64
    }
}

/// The memory limit in MiB that applies, and where it comes from.
fn memory_limit_mib(scenario: &Scenario, limit_mib: Option<u64>) -> (u64, &'static str) {
    match (limit_mib, scenario.memory_limit_mib) {
        (Some(l), _) => (l, "--memory-limit-mib"),
        (None, Some(l)) => (l, "the scenario's memory_limit_mib"),
        (None, None) => (DEFAULT_MEMORY_LIMIT_MIB, "the default limit"),
    }
}

/// Refuses a campaign whose [`memory_estimate`] exceeds the limit, or more than the process
/// can allocate, naming the scenario line that sets its length, before anything is
/// allocated.
///
/// The second check reserves the estimate once and frees it at once (address space only,
/// nothing is touched): with the limit raised past what the machine or `ulimit -v` allows,
/// the buffers' own allocation would otherwise fail later, and a failed allocation aborts
/// the process instead of returning an error.
pub fn check_memory(scenario: &Scenario, limit_mib: Option<u64>) -> Result<(), ScenarioError> {
    let (limit, from) = memory_limit_mib(scenario, limit_mib);
    let need = memory_estimate(scenario);
    let what = format!(
        "{} steps per trial (stop_time = {} s, step_size = {} s) need about {:.1} MiB of memory",
        scenario.steps,
        Shown(scenario.stop_time),
        Shown(scenario.step_size),
        need as f64 / f64::from(1 << 20),
    );
    let refuse = |why: String| {
        Err(ScenarioError::new(
            scenario.source.clone(),
            scenario.stop_time_line,
            format!("{what}, {why}"),
        ))
    };
    if need > limit.saturating_mul(1 << 20) {
        return refuse(format!(
            "more than {from} of {limit} MiB; shorten the trial, enlarge the step, or raise \
             the limit with --memory-limit-mib or memory_limit_mib in the scenario"
        ));
    }
    let reservable =
        usize::try_from(need).is_ok_and(|bytes| Vec::<u8>::new().try_reserve_exact(bytes).is_ok());
    if !reservable {
        return refuse(
            "more than this process can allocate now; shorten the trial or enlarge the step".into(),
        );
    }
    Ok(())
}

/// Counts file operations and aborts the process at the requested one (see
/// [`CampaignOptions::crash_at`]). The main thread and the writer threads share one count.
#[derive(Debug)]
struct CrashPoint {
    at: Option<usize>,
    count: AtomicUsize,
}

impl CrashPoint {
    fn tick(&self) {
        let count = self.count.fetch_add(1, Ordering::Relaxed) + 1;
        if self.at == Some(count) {
            std::process::abort();
        }
    }
}

/// Whether `name` is a temporary file of [`write_atomic`] (`.<name>.tmp-<pid>-<n>`).
pub(crate) fn is_temporary(name: &str) -> bool {
    name.starts_with('.') && name.contains(".tmp-")
}

/// The names in `dir` that keep a new campaign out (for the message refusing it): all but
/// the lock file, and but a `trials` folder holding only a failed first trial's recording,
/// all that a run which failed there left. `None` when `dir` cannot be listed.
fn existing_files(dir: &Path) -> Option<Vec<String>> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .ok()?
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n != LOCK_FILE)
        .collect();
    if names.len() == 1 && names[0] == "trials" && holds_only_failed_first_trial(dir) {
        names.clear();
    }
    names.sort();
    Some(names)
}

/// Whether `dir/trials` holds nothing but failed first trials' recordings (or nothing).
fn holds_only_failed_first_trial(dir: &Path) -> bool {
    fs::read_dir(dir.join("trials")).is_ok_and(|entries| {
        entries.filter_map(Result::ok).all(|e| {
            failed_trial_of_file(&e.file_name().to_string_lossy()) == Some(0)
                && e.file_type().is_ok_and(|t| t.is_file())
        })
    })
}

fn remove_file_if_present(path: &Path) -> Result<(), CampaignError> {
    match fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(CampaignError::Remove {
            path: path.to_path_buf(),
            source: e,
        }),
        _ => Ok(()),
    }
}

fn remove_dir_if_present(path: &Path) -> Result<(), CampaignError> {
    match fs::remove_dir_all(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(CampaignError::Remove {
            path: path.to_path_buf(),
            source: e,
        }),
        _ => Ok(()),
    }
}

/// Folder inside a campaign folder that a replaced campaign's files are moved into before
/// they are removed.
const REPLACED_DIR: &str = ".replaced";

/// The names a campaign writes in its folder, `progress.toml` first so that a folder never
/// claims trials whose files are gone.
const CAMPAIGN_NAMES: [&str; 6] = [
    "progress.toml",
    "summary.csv",
    "memory.csv",
    "scenario.toml",
    "trials",
    "memory",
];

/// Takes the files of a previous campaign out of `dir` (only the campaign's own names) for
/// `--force`. They are first moved aside into [`REPLACED_DIR`] with `rename`; when a move
/// fails, the ones already moved go back and the old campaign stays as it was. Only then are
/// they removed: a removal that fails leaves them aside, named in the returned warning, and
/// the new campaign goes on. `rename` and `remove_all` are `fs::rename` and
/// `fs::remove_dir_all` outside the tests, which make them fail.
fn replace_campaign(
    dir: &Path,
    mut rename: impl FnMut(&Path, &Path) -> std::io::Result<()>,
    remove_all: impl FnOnce(&Path) -> std::io::Result<()>,
) -> Result<Option<String>, CampaignError> {
    let aside = dir.join(REPLACED_DIR);
    // A run killed while replacing an earlier campaign leaves this folder; it was meant to go.
    remove_dir_if_present(&aside)?;
    let present: Vec<&str> = CAMPAIGN_NAMES
        .into_iter()
        .filter(|name| fs::symlink_metadata(dir.join(name)).is_ok())
        .collect();
    if !present.is_empty() {
        fs::create_dir(&aside).map_err(|source| CampaignError::CreateDir {
            path: aside.clone(),
            source,
        })?;
        for (moved, name) in present.iter().enumerate() {
            if let Err(source) = rename(&dir.join(name), &aside.join(name)) {
                for back in present[..moved].iter().rev() {
                    // Best effort: a move that worked one way works back.
                    let _ = rename(&aside.join(back), &dir.join(back));
                }
                let _ = fs::remove_dir(&aside);
                return Err(CampaignError::Replace {
                    path: dir.join(name),
                    source,
                });
            }
        }
    }
    remove_leftovers(dir, 0)?;
    Ok(remove_all(&aside)
        .err()
        .filter(|e| e.kind() != std::io::ErrorKind::NotFound)
        .map(|e| {
            format!(
                "the replaced campaign's files remain in {} (cannot remove them: {e}); \
                 remove that folder by hand",
                aside.display()
            )
        }))
}

/// On resume after `completed` trials: removes temporary files of interrupted writes,
/// memory files other than the one trial `completed` reads, and trial files (also those of
/// failed trials) of trials that will run again.
fn remove_leftovers(dir: &Path, completed: usize) -> Result<(), CampaignError> {
    let keep_memory = completed
        .checked_sub(1)
        .map(|k| memory_file(dir, k).file_name().map(ToOwned::to_owned));
    for sub in [dir.to_path_buf(), dir.join("trials"), dir.join("memory")] {
        let Ok(entries) = fs::read_dir(&sub) else {
            continue;
        };
        for entry in entries.filter_map(Result::ok) {
            let name = entry.file_name();
            let text = name.to_string_lossy();
            let stale = is_temporary(&text)
                || (sub.ends_with("memory")
                    && text.starts_with("after_trial_")
                    && keep_memory
                        .as_ref()
                        .is_none_or(|k| k.as_deref() != Some(&*name)))
                || (sub.ends_with("trials")
                    && (trial_of_file(&text).is_some_and(|(k, _)| k >= completed)
                        || failed_trial_of_file(&text).is_some_and(|k| k >= completed)));
            if stale {
                remove_file_if_present(&entry.path())?;
            }
        }
    }
    Ok(())
}

/// The name of a recorded trial below `completed` (one a resume keeps) written in another
/// format than `format`.
fn kept_trial_of_other_format(
    dir: &Path,
    completed: usize,
    format: RecordFormat,
) -> Option<String> {
    let entries = fs::read_dir(dir.join("trials")).ok()?;
    entries.filter_map(Result::ok).find_map(|entry| {
        let name = entry.file_name().to_string_lossy().into_owned();
        let (k, f) = trial_of_file(&name)?;
        (k < completed && f != format).then_some(name)
    })
}

/// Writes `rows`, the recording of trial `k` up to its failure, to [`failed_trial_file`].
fn keep_failed_recording(
    dir: &Path,
    k: usize,
    rows: &RecordedRows,
    format: RecordFormat,
) -> Result<(), CampaignError> {
    let trials = dir.join("trials");
    crate::output::create_folder(&trials).map_err(|source| CampaignError::CreateDir {
        path: trials,
        source,
    })?;
    write_recorded_rows(&failed_trial_file(dir, k, format), rows, format.exporter())?;
    Ok(())
}

/// Sets the flag that stops the lanes when dropped.
struct StopLanes<'a>(&'a AtomicBool);

impl Drop for StopLanes<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// Lanes for `trials` trials of `scenario` when `lanes` are asked for: at most one per trial,
/// one when a memory update needs whole trials, and no more than the memory limit (`limit_mib`
/// as [`CampaignOptions::memory_limit_mib`]) has room for, each lane holding a master's
/// buffers and a recording waiting for its writer.
fn lane_count(scenario: &Scenario, limit_mib: Option<u64>, lanes: usize, trials: usize) -> usize {
    if !Master::memory_is_plain(scenario) {
        return 1;
    }
    let per_lane =
        memory_estimate(scenario).saturating_add(saturating_u64(recording_bytes(scenario)));
    let room = memory_limit_mib(scenario, limit_mib)
        .0
        .saturating_mul(1 << 20)
        / per_lane.max(1);
    lanes
        .min(trials)
        .min(usize::try_from(room).unwrap_or(usize::MAX))
}

/// Runs (or resumes) every trial of `scenario` with `fmus` opened from its FMU paths,
/// returning the summaries of all trials.
pub fn run_campaign(
    scenario: &Scenario,
    scenario_text: &str,
    fmus: Vec<Fmu>,
    opts: &CampaignOptions,
) -> Result<Vec<TrialSummary>, CampaignError> {
    check_memory(scenario, opts.memory_limit_mib)?;
    let dir = &opts.out_dir;
    let fps = fingerprint(scenario, scenario_text)?;
    let fp = &fps.current;
    let saved_text = as_run(scenario, scenario_text)?;
    let _lock = DirLock::acquire(dir)?;
    let crash = CrashPoint {
        at: opts.crash_at,
        count: AtomicUsize::new(0),
    };
    let mut summaries: Vec<TrialSummary> = Vec::new();
    let mut first = 0;
    // The memory trial `first` reads, when resuming after a completed trial.
    let mut initial: Option<Vec<Vec<f64>>> = None;
    let progress_file = dir.join("progress.toml");
    let resuming = opts.resume && progress_file.exists();
    let files = existing_files(dir);
    // A folder that holds nothing (a failed first trial's recording aside) may keep this run's
    // failed first trial; one holding a campaign that `--force` would replace may not. One
    // that cannot be listed counts as holding something.
    let fresh = !resuming && files.as_ref().is_some_and(Vec::is_empty);
    if resuming {
        let resume_err = |message: String| CampaignError::Resume {
            dir: dir.clone(),
            message,
        };
        let p = read_progress(&progress_file).map_err(resume_err)?;
        if !fps.matches(&p) {
            return Err(resume_err(what_differs(dir, scenario, scenario_text)));
        }
        let rows = read_summary(&dir.join("summary.csv")).map_err(resume_err)?;
        if rows.len() < p.completed {
            return Err(resume_err(format!(
                "summary.csv has {} trials, progress.toml says {}",
                rows.len(),
                p.completed
            )));
        }
        // A campaign begun before unmeasured trials were written as empty cells has zeros
        // there; rewritten as empty, its summary.csv reads as one of this version.
        summaries = rows
            .into_iter()
            .take(p.completed)
            .map(|row| match scenario.metrics {
                Some(_) => row,
                None => TrialSummary {
                    legs: None,
                    path: None,
                    ..row
                },
            })
            .collect();
        // Resuming with fewer trials than are done would run nothing and say nothing.
        if p.completed > scenario.trials {
            return Err(resume_err(format!(
                "it holds {} completed trials, more than the {} asked for (trials in the \
                 scenario or --trials); resume with at least {} trials",
                p.completed, scenario.trials, p.completed
            )));
        }
        // One campaign, one recording format: trials kept in one format and continued in the
        // other would leave a folder that a glob of either misses.
        if let Some(kept) = kept_trial_of_other_format(dir, p.completed, scenario.record.format) {
            return Err(resume_err(format!(
                "its recorded trials are in another format ({kept}) than this run would write \
                 ({}); resume with the campaign's format (`--record-format`, or the \
                 scenario's `[record] format`), or start a new --out",
                scenario.record.format.exporter().extension()
            )));
        }
        first = p.completed;
        if first > 0 {
            let lens: Vec<usize> = scenario
                .memory
                .iter()
                .map(|m| scenario.steps * m.link.from.value_references.len())
                .collect();
            initial = Some(read_memory(&memory_file(dir, first - 1), &lens).map_err(resume_err)?);
        }
        remove_leftovers(dir, first)?;
    } else if !opts.resume && !opts.force {
        let files = files.unwrap_or_default();
        if !files.is_empty() {
            let what = match fs::read_to_string(&progress_file)
                .ok()
                .and_then(|t| toml::from_str::<Progress>(&t).ok())
            {
                Some(p) => format!("a campaign ({} completed trials)", p.completed),
                None => format!("files ({})", files.join(", ")),
            };
            return Err(CampaignError::NotEmpty {
                dir: dir.clone(),
                what,
            });
        }
    }
    if !resuming && !progress_file.exists() {
        // An earlier run's failed first trial, in either format: whatever this run does, the
        // file is not its own, and a message must not name it as such. No campaign holds one.
        for format in [RecordFormat::Csv, RecordFormat::Parquet] {
            remove_file_if_present(&failed_trial_file(dir, 0, format))?;
        }
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
    let console = FmuConsole::new(bar.clone(), scenario.fmus.len()).for_campaign(dir);
    let n_lanes = lane_count(
        scenario,
        opts.memory_limit_mib,
        opts.lanes,
        last.saturating_sub(first),
    );
    let use_lanes = n_lanes >= 2;
    // One lane: this thread's master runs every trial, into one recording and one set of
    // signals. More: the lanes open their own masters below and this thread only persists
    // their outcomes.
    let (mut one_lane, first_copy) = if use_lanes {
        (None, Some(fmus))
    } else {
        let mut master = Master::new(scenario, fmus, opts.fmu_logging)?;
        master.set_console(console.clone());
        if let Some(data) = &initial {
            master.set_memory(data);
        }
        let (recording, signals) = (master.new_recording(), master.new_signals());
        (Some((master, recording, signals)), None)
    };
    let memory_names: Vec<String> = scenario
        .memory
        .iter()
        .flat_map(|m| m.link.from.names.iter().cloned())
        .collect();
    // The memory the last trial run wrote (lanes), for memory.csv.
    let mut last_memory: Option<Vec<Vec<f64>>> = None;
    let abort = AtomicBool::new(false);
    // summary.csv as text, each row formatted once as its trial ends: committing trial j
    // writes the text up to j's row, a copy rather than every row formatted again (which made
    // a campaign of 20,000 short trials quadratic: 510 s, most of it formatting).
    let mut text = Vec::new();
    push_csv_record(&mut text, summary_header()).map_err(|source| summary_error(dir, source))?;
    for s in &summaries {
        push_csv_record(&mut text, s.to_row()).map_err(|source| summary_error(dir, source))?;
    }
    let summary_text = std::sync::Mutex::new(text);
    // Trial j is committed (summary.csv, progress.toml, the previous memory file removed),
    // in trial order, only once all its files are durable. A writer thread writes a trial's
    // files while the next trials run and commits it after the trial before (see
    // `writers`); a kill therefore never leaves progress.toml claiming a trial whose
    // recording or memory is missing.
    let commit = |j: usize, end: usize| {
        let text = summary_text.lock().unwrap_or_else(PoisonError::into_inner)[..end].to_vec();
        write_atomic(&dir.join("summary.csv"), |w| w.write_all(&text))?;
        crash.tick();
        let progress = format!("completed = {}\nfingerprint = \"{fp}\"\n", j + 1);
        write_atomic(&progress_file, |w| w.write_all(progress.as_bytes()))?;
        crash.tick();
        // Resume needs only the newest memory; the older one is stale once progress moved on.
        if j > 0 {
            let _ = fs::remove_file(memory_file(dir, j - 1));
            crash.tick();
        }
        Ok::<(), CampaignError>(())
    };
    let format = scenario.record.format;
    std::thread::scope(|scope| {
        // However this closure returns, lanes still running (after a failure) stop at their
        // next chunk before the scope waits for them.
        let _stop = StopLanes(&abort);
        let mut lanes = match first_copy {
            Some(fmus) => Some(lanes::Lanes::start(
                scope,
                scenario,
                fmus,
                n_lanes,
                opts.fmu_logging,
                (first, last),
                initial.as_deref(),
                &console,
                &abort,
            )?),
            None => None,
        };
        // As many writers in flight as lanes: each lane's recording may wait for its writer
        // while the lane runs on (counted in the lanes' memory room above).
        let mut writers = Writers::new(n_lanes);
        for k in first..last {
            bar.set_message(format!("trial {k}/{}", scenario.trials - 1));
            let record_this = scenario.record.records_trial(k);
            let ran = match (&mut one_lane, &mut lanes) {
                (Some((master, recording, signals)), _) => master
                    .run_trial(k, record_this.then_some(recording), signals, |n| {
                        if n % 1000 == 999 {
                            bar.inc(1000);
                        }
                    })
                    .map(|()| None)
                    .map_err(Box::<Failed>::from),
                (None, Some(lanes)) => lanes.next(k).map(Some),
                (None, None) => unreachable!("one lane has a master, more have lanes"),
            };
            writers.reap()?;
            let from_lane = match ran {
                Ok(done) => done,
                Err(failed) => {
                    // The trials before succeeded: they are kept either way.
                    writers.finish()?;
                    let rows = match (&failed.recording, &one_lane) {
                        (Some(rows), _) => Some(rows),
                        (None, Some((_, rows, _))) if record_this => Some(rows),
                        _ => None,
                    };
                    // Into a folder that holds this campaign, or none: a run whose first
                    // trial fails never touches the campaign `--force` would have replaced.
                    let cancelled = matches!(failed.error, MasterError::Cancelled { .. });
                    let keep = (k > first || resuming || fresh) && !cancelled;
                    // A trial that failed before its first step has no rows to show.
                    if let Some(rows) = rows.filter(|r| keep && !r.is_empty())
                        && let Err(e) = keep_failed_recording(dir, k, rows, format)
                    {
                        let e = crate::describe(&e);
                        bar.suspend(|| {
                            crate::console!(
                                "warning: cannot keep the recording of failed trial {k}: {e}"
                            );
                        });
                    }
                    return Err(CampaignError::from(failed.error));
                }
            };
            if k == first && !resuming {
                // A new campaign replaces an old one only now that its first trial succeeded.
                if let Some(warning) = replace_campaign(
                    dir,
                    |from, to| fs::rename(from, to),
                    |aside| fs::remove_dir_all(aside),
                )? {
                    bar.suspend(|| crate::console!("warning: {warning}"));
                }
                crash.tick();
            }
            // Folders appear once a trial has succeeded (or, holding only its rows, once a
            // first trial failed in a folder without a campaign).
            for sub in ["trials", "memory"] {
                let p = dir.join(sub);
                crate::output::create_folder(&p)
                    .map_err(|source| CampaignError::CreateDir { path: p, source })?;
            }
            if k == first {
                write_atomic(&dir.join("scenario.toml"), |w| {
                    w.write_all(saved_text.as_bytes())
                })?;
                crash.tick();
            }
            let (memory, full) = match (from_lane, &mut one_lane) {
                (Some(done), _) => {
                    summaries.push(done.summary);
                    let slices: Vec<&[f64]> = done.memory.iter().map(Vec::as_slice).collect();
                    let memory = memory_bytes(&slices);
                    last_memory = Some(done.memory);
                    (memory, done.recording)
                }
                (None, Some((master, recording, signals))) => {
                    summaries.push(TrialSummary::compute(k, scenario, signals));
                    let full = record_this.then(|| {
                        let next = writers
                            .spare
                            .take()
                            .unwrap_or_else(|| master.new_recording());
                        std::mem::replace(recording, next)
                    });
                    (memory_bytes(&master.memory()), full)
                }
                (None, None) => unreachable!("a trial ran on a lane or on the master"),
            };
            let end = {
                let mut text = summary_text.lock().unwrap_or_else(PoisonError::into_inner);
                let row = summaries
                    .last()
                    .map(TrialSummary::to_row)
                    .unwrap_or_default();
                push_csv_record(&mut text, row).map_err(|source| summary_error(dir, source))?;
                text.len()
            };
            let crash = &crash;
            writers.spawn(
                scope,
                move || {
                    if let Some(full) = &full {
                        write_recorded_rows(&trial_file(dir, k, format), full, format.exporter())?;
                        crash.tick();
                    }
                    write_atomic(&memory_file(dir, k), |w| w.write_all(&memory))?;
                    crash.tick();
                    Ok(full)
                },
                move || commit(k, end),
            )?;
        }
        // memory.csv is formatted and synced while the last writers finish, and put in place
        // only after their commits. Also when a resumed campaign had nothing left to run: a
        // run killed right after its last progress.toml still gets its memory.csv.
        let table = (last > first || (resuming && first == scenario.trials && first > 0))
            .then(|| {
                prepare_memory_csv(
                    &dir.join("memory.csv"),
                    scenario,
                    &memory_names,
                    &match (&one_lane, &last_memory) {
                        (Some((master, ..)), _) => master.memory(),
                        (None, Some(m)) => m.iter().map(Vec::as_slice).collect(),
                        (None, None) => unreachable!("lanes run at least two trials"),
                    },
                )
            })
            .transpose();
        // A writer's error concerns an earlier file than memory.csv: it wins.
        writers.finish()?;
        if let Some(table) = table? {
            table.commit()?;
            crash.tick();
        }
        Ok::<(), CampaignError>(())
    })?;
    bar.finish_and_clear();
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

#[cfg(test)]
mod tests {
    use super::*;
    use fmi2_md::ModelDescription;

    /// The shipped controller and plant, as a scenario's `[[fmu]]` tables.
    const TWO_FMUS: &str = "[[fmu]]\nname = \"controller\"\npath = \"HlcsController.fmu\"\n\
                            [[fmu]]\nname = \"plant\"\npath = \"CkcmPlant.fmu\"\n";

    /// A two-FMU scenario over the shipped model descriptions (no FMU is opened), with the
    /// metrics of `scenarios/line-hlcs.toml` and the given start time.
    fn scenario(start_time: f64) -> Scenario {
        parse_scenario(&format!(
            r#"
start_time = {start_time}
step_size = 0.001
stop_time = {stop}
{TWO_FMUS}[metrics]
reference = "controller.length_ref"
length = "plant.length_true"
rho = 5.0
pose = "plant.pose"
trajectory = {{ kind = "line", duration = 15.0, home_height = 0.5 }}
"#,
            stop = start_time + 1.0
        ))
    }

    /// `text` parsed as `s.toml`, its FMUs' model descriptions taken from the shipped ones.
    fn parse_scenario(text: &str) -> Scenario {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        Scenario::parse(text, Path::new("s.toml"), |path| {
            let xml = root
                .join("modelDescription")
                .join(path.with_extension("xml"));
            ModelDescription::from_file(&xml).map_err(|e| e.to_string())
        })
        .unwrap()
    }

    /// Errors that grow along the trial and positions 1 mm off the line, sampled from
    /// `start_time`.
    fn signals(start_time: f64) -> TrialSignals {
        let n = 200;
        let time: Vec<f64> = (0..n).map(|k| start_time + k as f64 * 1e-3).collect();
        let error = (0..n)
            .map(|k| std::array::from_fn(|leg| 1e-4 * (1.0 + leg as f64) * (k as f64 / n as f64)))
            .collect();
        let line = ckcm::Trajectory::line(0.5);
        let position = (0..n)
            .map(|k| {
                let p = line.sample(k as f64 * 1e-3).pose.p_world;
                [p.x + 1e-3, p.y, p.z]
            })
            .collect();
        TrialSignals {
            time,
            error,
            position,
        }
    }

    /// The estimate is the sum of the buffers its doc lists, counted here by hand: 1,000
    /// steps, memory links of 6 values, 12 recorded columns every third step.
    #[test]
    fn memory_estimate_adds_up_the_buffers_it_names() {
        let with = |memories: &str, record: &str| {
            parse_scenario(&format!(
                r#"
step_size = 0.001
stop_time = 1.0
{TWO_FMUS}{memories}
{record}
"#
            ))
        };
        let memory = "[[memory]]\nfrom = \"controller.memory_next\"\nto = \"controller.memory\"\n";
        let record =
            "[record]\nvariables = [\"controller.force\", \"plant.length\"]\ninterval = 3\n";
        // Signals and metric work arrays: 14 values per step.
        let signals = 8 * 1000 * 14;
        // Read, write, resumed copy and memory.csv's column per memory value, plus its time.
        let memory_bytes = |width: u64| 8 * 1000 * (4 * width + 1);
        // ceil(1000 / 3) = 334 rows of 12 columns and the time.
        let recording = 8 * 334 * 13;
        let bare = with("", "");
        assert_eq!(bare.steps, 1000);
        // Without a [record] table the recording is its time column, every step.
        assert_eq!(recording_bytes(&bare), 8000.0);
        assert_eq!(memory_estimate(&bare), memory_bytes(0) + signals + 8000);
        assert_eq!(recording_bytes(&with("", record)), recording as f64);
        assert_eq!(
            memory_estimate(&with(memory, record)),
            memory_bytes(6) + signals + recording
        );
        // Each memory link adds its own four copies; the time column is counted once.
        let second = "[[memory]]\nfrom = \"controller.force\"\nto = \"plant.force\"\n";
        assert_eq!(
            memory_estimate(&with(&format!("{memory}{second}"), "")),
            memory_bytes(12) + signals + 8000
        );
    }

    /// A campaign is refused only beyond the limit: 131,072 steps with nothing stored but
    /// the signals and two time columns (`memory.csv`'s and the recording's) need 128 bytes
    /// a step, 16 MiB exactly.
    #[test]
    fn a_campaign_exactly_at_the_memory_limit_runs() {
        let at_limit = parse_scenario(&format!(
            "step_size = 0.001\nstop_time = 131.072\n{TWO_FMUS}"
        ));
        assert_eq!(at_limit.steps, 131_072);
        assert_eq!(memory_estimate(&at_limit), 16 << 20);
        assert!(check_memory(&at_limit, Some(16)).is_ok());
        let err = check_memory(&at_limit, Some(15)).unwrap_err().to_string();
        assert!(
            err.contains("more than --memory-limit-mib of 15 MiB"),
            "{err}"
        );
    }

    /// Lanes as asked, but no more than trials are left and the memory limit has room for,
    /// and one when a memory update needs the whole trial.
    /// A file that is already gone is no error of a clean-up, but one that cannot be removed
    /// is, naming it: the clean-up must not go on as if it were gone.
    #[test]
    fn removing_what_is_gone_is_fine_and_what_cannot_be_removed_an_error() {
        let tmp = tempfile::tempdir().unwrap();
        let gone = tmp.path().join("gone.csv");
        assert!(remove_file_if_present(&gone).is_ok());
        assert!(remove_dir_if_present(&gone).is_ok());
        // A folder where a file is expected: `remove_file` refuses it.
        let folder = tmp.path().join("trial_000.csv");
        fs::create_dir(&folder).unwrap();
        let err = remove_file_if_present(&folder).unwrap_err().to_string();
        assert!(
            err.starts_with(&format!("cannot remove {}", folder.display())),
            "{err}"
        );
        assert!(folder.exists());
        // A file where a folder is expected: `remove_dir_all` refuses it.
        let file = tmp.path().join("memory");
        fs::write(&file, b"x").unwrap();
        let err = remove_dir_if_present(&file).unwrap_err().to_string();
        assert!(
            err.starts_with(&format!("cannot remove {}", file.display())),
            "{err}"
        );
        assert!(file.exists());
    }

    #[test]
    fn lanes_are_as_many_as_trials_and_the_memory_limit_allow() {
        // 16 MiB of buffers and a 1 MiB time column per lane (as in the test above).
        let plain = parse_scenario(&format!(
            "step_size = 0.001\nstop_time = 131.072\n{TWO_FMUS}"
        ));
        assert_eq!(
            memory_estimate(&plain) + recording_bytes(&plain) as u64,
            17 << 20
        );
        assert_eq!(lane_count(&plain, Some(68), 4, 10), 4);
        assert_eq!(lane_count(&plain, Some(68), 3, 10), 3);
        assert_eq!(lane_count(&plain, Some(68), 4, 2), 2);
        assert_eq!(lane_count(&plain, Some(67), 4, 10), 3);
        assert_eq!(lane_count(&plain, Some(34), 4, 10), 2);
        assert_eq!(lane_count(&plain, Some(33), 4, 10), 1);
        // The scenario's own limit when no option gives one.
        let limited = parse_scenario(&format!(
            "step_size = 0.001\nstop_time = 131.072\nmemory_limit_mib = 51\n{TWO_FMUS}"
        ));
        assert_eq!(lane_count(&limited, None, 4, 10), 3);
        assert_eq!(lane_count(&limited, Some(34), 4, 10), 2);
        let filtered = parse_scenario(&format!(
            "step_size = 0.001\nstop_time = 1.0\n{TWO_FMUS}[[memory]]\n\
             from = \"controller.memory_next\"\nto = \"controller.memory\"\n\
             [memory.update]\nfilter = \"butterworth\"\norder = 2\ncutoff = 8.0\n"
        ));
        assert_eq!(lane_count(&filtered, Some(1 << 20), 4, 10), 1);
    }

    /// Each way two saved texts can differ is worded as such, with the line numbered as in
    /// the saved file (blank lines count) and spaces around a line ignored.
    #[test]
    fn first_difference_words_each_kind_of_difference() {
        let diff = |theirs, ours| first_difference(theirs, ours, "scenario.toml", "this one");
        assert_eq!(
            diff("a = 1\n\nb = 2\n", "a = 1\nb = 3\n"),
            "line 3 of its scenario.toml reads `b = 2`, where this one has `b = 3`"
        );
        assert_eq!(
            diff("a = 1\nb = 2\n", "a = 1\n"),
            "line 2 of its scenario.toml reads `b = 2`, where this one has nothing more"
        );
        assert_eq!(
            diff("a = 1\n", "a = 1\n\nb = 2\n"),
            "its scenario.toml ends, where this one has `b = 2`"
        );
        assert_eq!(
            diff("  a = 1\n\n\nb = 2   \n", "a = 1\nb = 2"),
            "its scenario.toml differs from this one in blank lines or spaces only"
        );
    }

    /// What keeps a new campaign out of a folder: anything but the lock file, except a
    /// `trials` folder holding only failed first trials' recordings (what a run that failed
    /// there leaves). A user's file or folder in `trials` keeps it out, also one named like
    /// such a recording.
    #[test]
    fn only_a_failed_first_trials_recording_lets_a_new_campaign_in() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        assert_eq!(existing_files(&dir.join("missing")), None);
        fs::write(dir.join(LOCK_FILE), "").unwrap();
        assert_eq!(existing_files(dir), Some(vec![]));
        fs::create_dir(dir.join("trials")).unwrap();
        for format in [RecordFormat::Csv, RecordFormat::Parquet] {
            fs::write(failed_trial_file(dir, 0, format), "").unwrap();
        }
        assert_eq!(existing_files(dir), Some(vec![]));
        let trials = Some(vec!["trials".to_owned()]);
        for name in [
            "notes.txt",
            "trial_001.failed.csv",
            "trial_000.csv",
            "trial_000.failed.json",
        ] {
            let path = dir.join("trials").join(name);
            fs::write(&path, "").unwrap();
            assert_eq!(existing_files(dir), trials, "{name}");
            fs::remove_file(&path).unwrap();
        }
        let parquet = failed_trial_file(dir, 0, RecordFormat::Parquet);
        fs::remove_file(&parquet).unwrap();
        fs::create_dir(&parquet).unwrap();
        assert_eq!(existing_files(dir), trials, "a folder");
        fs::write(dir.join("summary.csv"), "").unwrap();
        assert_eq!(
            existing_files(dir),
            Some(vec!["summary.csv".to_owned(), "trials".to_owned()])
        );
    }

    /// A recording's file name gives back its trial and format; other names give nothing.
    #[test]
    fn trial_of_file_inverts_trial_file() {
        for format in [RecordFormat::Csv, RecordFormat::Parquet] {
            for k in [0, 7, 1234] {
                let path = trial_file(Path::new("c"), k, format);
                let name = path.file_name().unwrap().to_str().unwrap();
                assert_eq!(trial_of_file(name), Some((k, format)), "{name}");
            }
        }
        for name in [
            "trial_x.csv",
            "trial_001.f64",
            "trial_001csv",
            "after_trial_001.csv",
        ] {
            assert_eq!(trial_of_file(name), None, "{name}");
        }
    }

    /// A warning without an error chain still gives the operating system's reason.
    #[test]
    fn describe_keeps_the_reason() {
        let e = OutputError::Io {
            path: PathBuf::from("c/trials/trial_001.failed.csv"),
            source: std::io::Error::from(std::io::ErrorKind::PermissionDenied),
        };
        let text = crate::describe(&e);
        assert!(
            text.starts_with("I/O error on c/trials/trial_001.failed.csv: "),
            "{text}"
        );
        assert!(text.contains("permission denied"), "{text}");
    }

    /// A failed trial's recording has a name of its own: never taken for a completed trial's
    /// file, and removed on resume with the trial files of the trials that run again.
    #[test]
    fn failed_trial_files_are_named_apart_and_removed_when_their_trial_runs_again() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        fs::create_dir_all(dir.join("trials")).unwrap();
        for format in [RecordFormat::Csv, RecordFormat::Parquet] {
            let path = failed_trial_file(dir, 7, format);
            let name = path.file_name().unwrap().to_str().unwrap();
            assert_eq!(trial_of_file(name), None, "{name}");
            assert_eq!(failed_trial_of_file(name), Some(7), "{name}");
        }
        for name in [
            "trial_007.failed.f64",
            "trial_x.failed.csv",
            "trial_007.csv",
            "trial_007failed.csv",
        ] {
            assert_eq!(failed_trial_of_file(name), None, "{name}");
        }
        let kept = failed_trial_file(dir, 2, RecordFormat::Csv);
        let stale = failed_trial_file(dir, 3, RecordFormat::Parquet);
        let own = dir.join("trials").join("notes.txt");
        for p in [&kept, &stale, &own] {
            fs::write(p, "x").unwrap();
        }
        remove_leftovers(dir, 3).unwrap();
        assert!(kept.exists(), "trial 2 does not run again");
        assert!(!stale.exists(), "trial 3 runs again");
        assert!(own.exists(), "a file of the user's");
    }

    /// The λ-norm weights time since the start of the trial, so the same errors give the same
    /// metrics whatever the scenario's start time; the path error is computed when positions
    /// were recorded (1 mm off the line here).
    #[test]
    fn metrics_are_timed_from_the_trial_start_and_include_the_path() {
        let at_zero = TrialSummary::compute(3, &scenario(0.0), &signals(0.0));
        let later = TrialSummary::compute(3, &scenario(100.0), &signals(100.0));
        let (legs0, legs1) = (at_zero.legs.unwrap(), later.legs.unwrap());
        for (a, b) in legs0.per_leg.iter().zip(&legs1.per_leg) {
            assert!(
                (a.lambda - b.lambda).abs() <= 1e-12 * a.lambda,
                "{a:?} {b:?}"
            );
            assert_eq!(a.max, b.max);
        }
        // With ρ = 5 /s the weight matters: the λ-norm is below the maximum.
        assert!(legs0.overall.lambda < 0.9 * legs0.overall.max);
        let path = at_zero.path.expect("positions were recorded");
        assert!((path.max - 1e-3).abs() < 1e-12 && (path.rms - 1e-3).abs() < 1e-12);
        assert_eq!(at_zero.trial, 3);
    }

    /// `summary.csv` rows read back into the same summary, path statistics included.
    #[test]
    fn summary_rows_round_trip() {
        let s = TrialSummary::compute(7, &scenario(0.0), &signals(0.0));
        let row = s.to_row();
        assert_eq!(row.len(), summary_header().len());
        assert_eq!(TrialSummary::from_row(&row), Some(s));
        let no_path = TrialSummary { path: None, ..s };
        assert_eq!(TrialSummary::from_row(&no_path.to_row()), Some(no_path));
    }

    /// Without `[metrics]` nothing is measured: the cells are empty, not zeros, and read back
    /// as unmeasured; a row of an earlier version (zeros) still reads.
    #[test]
    fn unmeasured_trials_have_empty_cells() {
        let mut no_metrics = scenario(0.0);
        no_metrics.metrics = None;
        let s = TrialSummary::compute(2, &no_metrics, &signals(0.0));
        assert_eq!(s.legs, None);
        let row = s.to_row();
        assert_eq!(row.len(), summary_header().len());
        assert_eq!(row[0], "2");
        assert!(row[1..].iter().all(String::is_empty), "{row:?}");
        assert!(s.overall_cells().iter().all(String::is_empty));
        // The study's overall cells are the summary row's last five.
        let measured = TrialSummary::compute(2, &scenario(0.0), &signals(0.0));
        assert_eq!(measured.to_row()[19..], measured.overall_cells());
        assert!(measured.overall_cells().iter().all(|c| !c.is_empty()));
        assert_eq!(TrialSummary::from_row(&row), Some(s));
        let mut old = vec!["2".to_string()];
        old.extend(std::iter::repeat_n("0".to_string(), 21));
        old.extend([String::new(), String::new()]);
        let legs = TrialSummary::from_row(&old).unwrap().legs.unwrap();
        assert_eq!(legs.overall.max, 0.0);
        // Some cells empty and others not is no row of any version.
        old[3].clear();
        assert_eq!(TrialSummary::from_row(&old), None);
    }

    /// The published FNV-1a 64-bit test vectors (offset basis 0xcbf29ce484222325).
    #[test]
    fn fnv1a_matches_the_reference_vectors() {
        let basis = 0xcbf2_9ce4_8422_2325;
        assert_eq!(fnv1a(basis, b""), basis);
        assert_eq!(fnv1a(basis, b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(basis, b"foobar"), 0x8594_4171_f739_67e8);
    }

    #[test]
    fn the_two_chain_fnv1a_equals_two_single_ones() {
        let bytes: Vec<u8> = (0..10_007u32).map(|i| (i * 7919 % 251) as u8).collect();
        for (a, b) in [(0xcbf2_9ce4_8422_2325, 1), (0, u64::MAX), (42, 42)] {
            for n in [0, 1, 3, 4, 5, 10_007] {
                assert_eq!(
                    fnv1a_two([a, b], &bytes[..n]),
                    [fnv1a(a, &bytes[..n]), fnv1a(b, &bytes[..n])]
                );
            }
        }
    }

    /// A folder holding an old campaign, a temporary file and a file of the user's.
    fn old_campaign(dir: &Path) {
        for (file, text) in [
            ("progress.toml", "completed = 2\n"),
            ("summary.csv", "trial\n0\n1\n"),
            ("scenario.toml", "trials = 2\n"),
            ("trials/trial_000.csv", "t\n0\n"),
            ("memory/after_trial_001.f64", "m"),
            (".summary.csv.tmp-1-0", "torn"),
            ("notes.txt", "mine"),
        ] {
            let path = dir.join(file);
            fs::create_dir_all(path.parent().unwrap()).unwrap();
            fs::write(path, text).unwrap();
        }
    }

    fn listing(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = walk(dir, dir);
        names.sort();
        names
    }

    fn walk(root: &Path, dir: &Path) -> Vec<String> {
        fs::read_dir(dir)
            .unwrap()
            .flat_map(|e| {
                let path = e.unwrap().path();
                if path.is_dir() {
                    walk(root, &path)
                } else {
                    let text = fs::read_to_string(&path).unwrap();
                    let name = path.strip_prefix(root).unwrap().display();
                    vec![format!("{name}={text}")]
                }
            })
            .collect()
    }

    #[test]
    fn a_replaced_campaign_goes_and_the_users_files_stay() {
        let tmp = tempfile::tempdir().unwrap();
        old_campaign(tmp.path());
        // A half-replaced campaign of a killed run is removed too.
        fs::create_dir_all(tmp.path().join(".replaced/trials")).unwrap();
        let warning = replace_campaign(
            tmp.path(),
            |a, b| fs::rename(a, b),
            |p| fs::remove_dir_all(p),
        )
        .unwrap();
        assert_eq!(warning, None);
        assert_eq!(listing(tmp.path()), ["notes.txt=mine"]);
    }

    /// A move that fails part-way (the k-th of five) leaves the old campaign byte for byte,
    /// with nothing aside, and the error names what could not be moved.
    #[test]
    fn a_failed_move_leaves_the_old_campaign_as_it_was() {
        for fail_at in 0..5 {
            let tmp = tempfile::tempdir().unwrap();
            old_campaign(tmp.path());
            let before = listing(tmp.path());
            let mut calls = 0;
            let err = replace_campaign(
                tmp.path(),
                |a, b| {
                    calls += 1;
                    if calls == fail_at + 1 {
                        Err(std::io::Error::other("refused by the test"))
                    } else {
                        fs::rename(a, b)
                    }
                },
                |p| fs::remove_dir_all(p),
            )
            .unwrap_err();
            let text = err.to_string();
            assert!(text.contains("refused by the test"), "{text}");
            assert!(text.contains("the old campaign is unchanged"), "{text}");
            let names = [
                "progress.toml",
                "summary.csv",
                "scenario.toml",
                "trials",
                "memory",
            ];
            assert!(text.contains(names[fail_at]), "{text}");
            assert_eq!(listing(tmp.path()), before, "failing move {fail_at}");
        }
    }

    /// A removal that fails after every move worked loses nothing: the old campaign waits
    /// whole in `.replaced/` (the torn temporary of an interrupted write aside, which goes
    /// as on every start), the warning names that folder and the cause, and the campaign's
    /// names are free for the new run.
    #[test]
    fn a_failed_removal_warns_and_keeps_the_old_campaign_aside() {
        let tmp = tempfile::tempdir().unwrap();
        old_campaign(tmp.path());
        let before = listing(tmp.path());
        let warning = replace_campaign(
            tmp.path(),
            |a, b| fs::rename(a, b),
            |_| Err(std::io::Error::other("refused by the test")),
        )
        .unwrap()
        .expect("a warning");
        assert!(warning.contains(".replaced"), "{warning}");
        assert!(warning.contains("refused by the test"), "{warning}");
        assert!(warning.contains("remove that folder by hand"), "{warning}");
        let aside: Vec<String> = before
            .iter()
            .filter(|entry| !entry.starts_with(".summary.csv.tmp-"))
            .map(|entry| {
                if entry.starts_with("notes.txt") {
                    entry.clone()
                } else {
                    format!(".replaced/{entry}")
                }
            })
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        assert_eq!(listing(tmp.path()), aside);
    }
}
