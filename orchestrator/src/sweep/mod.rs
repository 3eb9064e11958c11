//! Parameter studies and Monte Carlo runs: a base scenario, axes over FMU parameters and
//! memory-update settings, and one ordinary campaign per case.
//!
//! Output directory layout:
//! - `.lock` while the sweep or a merge into it runs (the campaign's folder lock: one writer
//!   per folder);
//! - `sweep.toml`: the sweep file as run;
//! - `cases/case_NNNN/`: each case, a complete `run` campaign directory (its `scenario.toml`
//!   reruns it alone) plus `outcome.toml` once it has ended (completed or failed, and why;
//!   the fingerprints of its scenario and FMU files, which a resume compares);
//! - `sweep.csv`, `figures/*.svg`, `sweep-report.md`: the results of all cases;
//! - `shard.toml` instead of the results when only shard K of N was run (the sweep's
//!   fingerprint, K, N, and each FMU file's fingerprint); `merge` combines shard directories
//!   of one sweep and one set of FMUs into the results an unsharded run writes, byte for byte.
//!   A folder is resumed as the shard it began as.
//!
//! Cases are fixed by the sweep file alone (random draws come from its seed), so every shard
//! and every resume agrees on what case i is.

mod results;
pub mod spec;

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};

use fmi2_import::{FileStamp, Fmu, ImportError, KeptFmus, file_stamp};
use fmi2_md::{ModelDescription, ScalarVariable};

pub use self::results::{CaseResult, Verdict, write_results};
pub use self::spec::{Axis, Combine, Seeds, SweepSpec, SweepSpecError, Target};
use crate::campaign::{
    CampaignError, CampaignOptions, DirLock, FNV_BASIS, LOCK_FILE, begun_with, fnv1a, run_campaign,
    scenario_digest,
};
use crate::output::{OutputError, create_folder, write_atomic};
use crate::scenario::{Scenario, path_hint, toml_message_at};

/// A sweep failure; a failing case is not one (it is recorded as failed and the sweep goes on).
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    #[error(transparent)]
    Spec(#[from] SweepSpecError),
    /// A case's scenario (generated in memory, never written) was refused.
    #[error(
        "{}: case {case} ({labels}): its scenario, generated from {}, is refused: {}",
        file.display(),
        base.display(),
        problems.join("; ")
    )]
    Case {
        file: PathBuf,
        case: usize,
        labels: String,
        base: PathBuf,
        problems: Vec<String>,
    },
    #[error("{}: FMU {}: {message}", file.display(), fmu.display())]
    Fmu {
        file: PathBuf,
        fmu: PathBuf,
        message: String,
    },
    /// Opening an FMU failed; the import error names the file.
    #[error("{}: {source}", file.display())]
    Open {
        file: PathBuf,
        source: Box<ImportError>,
    },
    #[error("{}: {message}", dir.display())]
    Dir { dir: PathBuf, message: String },
    #[error("case {case}: {source}")]
    Campaign {
        case: usize,
        source: Box<CampaignError>,
    },
    #[error(transparent)]
    Output(#[from] OutputError),
    #[error("cannot merge: {0}")]
    Merge(String),
    /// The output folder is held by another sweep or merge, running now.
    #[error(transparent)]
    Locked(Box<CampaignError>),
}

/// How to run a sweep.
#[derive(Debug, Clone)]
pub struct SweepOptions {
    pub out_dir: PathBuf,
    /// Cases run at the same time (threads), each with its own FMUs; results do not depend on it.
    pub jobs: usize,
    /// Run only the cases i with i mod N = K, as `(K, N)`.
    pub shard: Option<(usize, usize)>,
    /// Continue a sweep found in `out_dir` (finished cases are kept, unfinished ones resumed).
    pub resume: bool,
    pub fmu_logging: bool,
    /// Print a line per finished case.
    pub progress: bool,
}

/// The sweep's fingerprint: its file and its base scenario. Shards of one sweep share it.
pub fn fingerprint(spec: &SweepSpec) -> String {
    let h = fnv1a(FNV_BASIS, spec.text.as_bytes());
    format!("{:016x}", fnv1a(h, spec.base_text.as_bytes()))
}

/// Directory of case `i` under a sweep directory.
pub fn case_dir(out: &Path, i: usize) -> PathBuf {
    out.join("cases").join(format!("case_{i:04}"))
}

/// The FMUs of the base scenario, opened once to read their model descriptions.
struct BaseFmus {
    /// (name, absolute path, model description) in scenario order.
    fmus: Vec<(String, PathBuf, ModelDescription)>,
}

impl BaseFmus {
    fn open(spec: &SweepSpec) -> Result<BaseFmus, SweepError> {
        let doc: toml::Table = toml::from_str(&spec.base_text).map_err(|e| SweepSpecError {
            file: spec.base.clone(),
            line: None,
            message: e.message().to_string(),
        })?;
        let dir = spec.base.parent().unwrap_or(Path::new("."));
        let mut fmus = Vec::new();
        for f in doc
            .get("fmu")
            .and_then(toml::Value::as_array)
            .into_iter()
            .flatten()
        {
            let (Some(name), Some(path)) = (
                f.get("name").and_then(toml::Value::as_str),
                f.get("path").and_then(toml::Value::as_str),
            ) else {
                continue;
            };
            let joined = dir.join(path);
            let abs = fs::canonicalize(&joined).map_err(|e| SweepError::Fmu {
                file: spec.base.clone(),
                fmu: joined.clone(),
                message: match e.kind() {
                    std::io::ErrorKind::NotFound => {
                        format!("no such file{}", path_hint(path, &joined))
                    }
                    _ => e.to_string(),
                },
            })?;
            // Each case's scenario is TOML, which is UTF-8: it could not name this file.
            if abs.to_str().is_none() {
                return Err(SweepError::Fmu {
                    file: spec.base.clone(),
                    fmu: abs,
                    message: "the path is not valid UTF-8, so the cases' scenario files \
                              cannot name it; move the FMU to a folder whose name is"
                        .into(),
                });
            }
            let fmu = Fmu::open(&abs).map_err(|e| SweepError::Open {
                file: spec.base.clone(),
                source: Box::new(e),
            })?;
            fmus.push((name.to_string(), abs, fmu.model_description().clone()));
        }
        Ok(BaseFmus { fmus })
    }

    /// What the sweep runs: each FMU's name and the [`fnv1a`] of its file's bytes, as a
    /// shard and every case record them (shards run by cluster tasks may each have found other
    /// FMU files at the base's paths, and `merge` must not combine cases of two models), and
    /// each file's size and modification time, taken before its bytes were read.
    fn ran_with(&self, spec: &SweepSpec) -> Result<RanWith, SweepError> {
        let mut ran = RanWith::default();
        for (name, path, _) in &self.fmus {
            let stamp = file_stamp(path);
            let bytes = fs::read(path).map_err(|e| SweepError::Fmu {
                file: spec.base.clone(),
                fmu: path.clone(),
                message: e.to_string(),
            })?;
            let digest = fnv1a(FNV_BASIS, &bytes);
            ran.digests
                .insert(name.clone(), toml::Value::String(format!("{digest:016x}")));
            ran.stamps.push((path.clone(), stamp));
        }
        Ok(ran)
    }

    fn md(&self, path: &Path) -> Result<ModelDescription, String> {
        self.fmus
            .iter()
            .find(|(_, p, _)| p == path)
            .map(|(_, _, md)| md.clone())
            .ok_or_else(|| format!("{} is not an FMU of the base scenario", path.display()))
    }

    fn start(&self, fmu: &str, name: &str) -> Option<f64> {
        let (_, _, md) = self.fmus.iter().find(|(n, _, _)| n == fmu)?;
        md.variable_by_name(name)?.start_as_f64()
    }
}

/// The FMU files a sweep runs, as [`BaseFmus::ran_with`] found them at its start.
#[derive(Debug, Default)]
struct RanWith {
    /// FMU name → digest of the file's bytes.
    digests: toml::Table,
    /// Each file's path, size and modification time.
    stamps: Vec<(PathBuf, Option<FileStamp>)>,
}

impl RanWith {
    /// Refuses to run a case once an FMU file changed since the sweep began: its cases
    /// would be of two models, and every case records the digests taken at the start.
    /// Cheap (a `stat` per file), so it runs before every case.
    fn unchanged(&self, spec: &SweepSpec) -> Result<(), SweepError> {
        for (path, then) in &self.stamps {
            if file_stamp(path).is_none_or(|now| Some(now) != *then) {
                return Err(SweepError::Fmu {
                    file: spec.base.clone(),
                    fmu: path.clone(),
                    message: "the file changed while the sweep ran (its size or modification \
                              time), so the cases after it would be of another model; the \
                              finished cases are kept: restore the file and run again with \
                              --resume, or start the sweep in a new --out"
                        .into(),
                });
            }
        }
        Ok(())
    }
}

/// The scenario text of case `i`: the base scenario with absolute FMU paths, the sweep's
/// trial count, no recording unless asked, and the case's axis values and seed.
fn case_text(spec: &SweepSpec, base: &BaseFmus, i: usize) -> Result<String, String> {
    let mut doc: toml::Table = toml::from_str(&spec.base_text).map_err(|e| e.to_string())?;
    if let Some(t) = spec.trials {
        doc.insert("trials".into(), toml::Value::Integer(t as i64));
    }
    if !spec.record {
        doc.remove("record");
    }
    for f in fmu_tables(&mut doc) {
        let name = f.get("name").and_then(toml::Value::as_str).unwrap_or("");
        if let Some((_, abs, _)) = base.fmus.iter().find(|(n, _, _)| n == name) {
            f.insert(
                "path".into(),
                toml::Value::String(abs.to_string_lossy().into_owned()),
            );
        }
    }
    for (axis, &v) in spec.axes.iter().zip(&spec.cases[i]) {
        let value = &axis.values[v];
        match &axis.target {
            Target::Parameters(ps) => {
                for (fmu, name) in ps {
                    let params = parameters_of(&mut doc, fmu)?;
                    let set = if axis.scale {
                        let factor = value.as_float().or(value.as_integer().map(|x| x as f64));
                        let current = params
                            .get(name)
                            .and_then(|x| x.as_float().or(x.as_integer().map(|x| x as f64)))
                            .or_else(|| base.start(fmu, name))
                            .ok_or_else(|| format!("{fmu}.{name} has no numeric value to scale"))?;
                        toml::Value::Float(current * factor.unwrap_or(f64::NAN))
                    } else {
                        value.clone()
                    };
                    params.insert(name.clone(), set);
                }
            }
            Target::Memory { channel, setting } => {
                let ch = memory_table(&mut doc, channel)?;
                if setting == "update" {
                    match value.as_table() {
                        Some(t) if t.is_empty() => {
                            ch.remove("update");
                        }
                        Some(t) => {
                            ch.insert("update".into(), toml::Value::Table(t.clone()));
                        }
                        None => return Err("setting = \"update\" takes tables".into()),
                    }
                } else {
                    let update = ch
                        .entry("update")
                        .or_insert_with(|| toml::Value::Table(toml::Table::new()));
                    if let Some(t) = update.as_table_mut() {
                        t.insert(setting.clone(), value.clone());
                    }
                }
            }
        }
    }
    if let Some(s) = &spec.seeds {
        let seed = s.base.wrapping_add(s.stride.wrapping_mul(i as i64));
        let params = parameters_of(&mut doc, &s.fmu)?;
        match params
            .get_mut(&s.parameter)
            .and_then(toml::Value::as_table_mut)
        {
            // A per-trial value: the case moves its base, the trials keep their steps.
            Some(t) if t.contains_key("base") => {
                t.insert("base".into(), toml::Value::Integer(seed));
            }
            _ => {
                let value = match s.per_trial {
                    Some(step) => {
                        let mut t = toml::Table::new();
                        t.insert("base".into(), toml::Value::Integer(seed));
                        t.insert("per_trial".into(), toml::Value::Integer(step));
                        toml::Value::Table(t)
                    }
                    None => toml::Value::Integer(seed),
                };
                params.insert(s.parameter.clone(), value);
            }
        }
    }
    toml::to_string(&doc).map_err(|e| e.to_string())
}

fn fmu_tables(doc: &mut toml::Table) -> impl Iterator<Item = &mut toml::Table> {
    doc.get_mut("fmu")
        .and_then(toml::Value::as_array_mut)
        .into_iter()
        .flatten()
        .filter_map(toml::Value::as_table_mut)
}

fn parameters_of<'d>(doc: &'d mut toml::Table, fmu: &str) -> Result<&'d mut toml::Table, String> {
    let f = fmu_tables(doc)
        .find(|f| f.get("name").and_then(toml::Value::as_str) == Some(fmu))
        .ok_or_else(|| format!("the base scenario has no FMU {fmu:?}"))?;
    f.entry("parameters")
        .or_insert_with(|| toml::Value::Table(toml::Table::new()))
        .as_table_mut()
        .ok_or_else(|| format!("parameters of {fmu:?} is not a table"))
}

fn memory_table<'d>(doc: &'d mut toml::Table, to: &str) -> Result<&'d mut toml::Table, String> {
    doc.get_mut("memory")
        .and_then(toml::Value::as_array_mut)
        .into_iter()
        .flatten()
        .filter_map(toml::Value::as_table_mut)
        .find(|m| m.get("to").and_then(toml::Value::as_str) == Some(to))
        .ok_or_else(|| format!("the base scenario has no memory channel to {to:?}"))
}

/// The first of an axis' values that its variables cannot take (of the wrong type, or
/// outside a declared range), named by its place: caught here, it is reported at the axis'
/// line rather than as the scenario of some case. Scale factors and per-trial or array
/// values are left to each case's scenario, where they meet the base values.
fn axis_value_problem(
    axis: &Axis,
    md: &ModelDescription,
    vars: &[&ScalarVariable],
) -> Option<String> {
    use crate::variables::{Literal, check_value, convert};
    if axis.scale {
        return None;
    }
    axis.values
        .iter()
        .enumerate()
        .filter(|(_, v)| !(v.is_array() || v.is_table()))
        .find_map(|(j, value)| {
            vars.iter()
                .find_map(|var| {
                    convert(md, var, Literal::Toml(value))
                        .and_then(|parsed| check_value(md, var, &parsed))
                        .err()
                })
                .map(|why| format!("value {} of {}: {why}", j + 1, axis.values.len()))
        })
}

/// Every case's scenario, validated against the FMUs before anything runs.
fn plan(
    spec: &SweepSpec,
    base: &BaseFmus,
    out: &Path,
) -> Result<Vec<(Scenario, String)>, SweepError> {
    // Parameters named by an axis must exist, so a typo fails at its own line.
    for axis in &spec.axes {
        if let Target::Parameters(ps) = &axis.target {
            for (fmu, name) in ps {
                let md = base
                    .fmus
                    .iter()
                    .find(|(n, _, _)| n == fmu)
                    .map(|(_, _, md)| md);
                let vars = md
                    .map(|md| crate::variables::resolve(md, name))
                    .unwrap_or_default();
                // Unknown, or known but not a value a master may give (an output).
                let problem = match (vars.first(), md) {
                    (Some(_), Some(md)) => vars
                        .iter()
                        .find_map(|v| crate::variables::settable(v).err())
                        .map(|why| format!("FMU {fmu:?}: {why}"))
                        .or_else(|| axis_value_problem(axis, md, &vars)),
                    _ => Some(format!("FMU {fmu:?} has no variable {name:?}")),
                };
                if let Some(problem) = problem {
                    return Err(SweepSpecError {
                        file: spec.source.clone(),
                        line: axis.line,
                        message: format!("axis {:?}: {problem}", axis.name),
                    }
                    .into());
                }
            }
        }
    }
    (0..spec.cases.len())
        .map(|i| {
            let case_err = |problems: Vec<String>| SweepError::Case {
                file: spec.source.clone(),
                case: i,
                labels: spec.case_labels(i).join(", "),
                base: spec.base.clone(),
                problems,
            };
            let text = case_text(spec, base, i).map_err(|message| case_err(vec![message]))?;
            // Where the case's campaign saves it (FMU paths are absolute, so it only labels).
            let file = case_dir(out, i).join("scenario.toml");
            let scenario = Scenario::parse(&text, &file, |p| base.md(p))
                .map_err(|e| case_err(e.messages()))?;
            // The case's trial count is the sweep's: a recorded trial beyond it is a mistake.
            if let Some(k) = scenario.recorded_trial_beyond_count() {
                return Err(case_err(vec![format!(
                    "record.trials lists trial {k}, but trials are numbered 0..{}",
                    scenario.trials - 1
                )]));
            }
            Ok((scenario, text))
        })
        .collect()
}

/// Writes `text` into `path` atomically.
fn write_text(path: &Path, text: &str) -> Result<(), OutputError> {
    write_atomic(path, |w| w.write_all(text.as_bytes()))
}

/// Whether `dir` exists and holds anything but temporary files of an interrupted write and
/// the lock: a sweep's output folder must not, unless resumed. A run killed while writing
/// its first file (the stamp) leaves only such a temporary and its lock file, and must start
/// again rather than be refused.
fn holds_files(dir: &Path) -> bool {
    fs::read_dir(dir).is_ok_and(|d| {
        d.filter_map(Result::ok).any(|e| {
            let name = e.file_name();
            let name = name.to_string_lossy();
            name != LOCK_FILE && !crate::campaign::is_temporary(&name)
        })
    })
}

/// How a sweep run is split: "shard K/N" or "the whole sweep".
fn shard_label(shard: Option<(usize, usize)>) -> String {
    match shard {
        Some((k, n)) => format!("shard {k}/{n}"),
        None => "the whole sweep (no --shard)".into(),
    }
}

/// A resumed folder goes on as the shard it began as: resumed as another shard, it would run
/// that shard's cases beside the ones it holds, and its `shard.toml` would then name one shard
/// while the folder held cases of two. A finished shard says which it is in `shard.toml`; an
/// unfinished one by its cases' numbers.
fn check_begun_as(
    out: &Path,
    shard: Option<(usize, usize)>,
    mine: &[usize],
) -> Result<(), SweepError> {
    let refuse = |held: String| SweepError::Dir {
        dir: out.to_path_buf(),
        message: format!(
            "it holds {held}, and this run is {}; resume it with the --shard it began with",
            shard_label(shard)
        ),
    };
    let stamp_path = out.join("shard.toml");
    if let Ok(text) = fs::read_to_string(&stamp_path) {
        let s: ShardStamp = toml::from_str(&text).map_err(|e| SweepError::Dir {
            dir: out.to_path_buf(),
            message: format!("shard.toml: {}", toml_message_at(&e, &text)),
        })?;
        if shard != Some((s.shard, s.shards)) {
            return Err(refuse(format!(
                "the finished {} (its shard.toml)",
                shard_label(Some((s.shard, s.shards)))
            )));
        }
    }
    let Ok(entries) = fs::read_dir(out.join("cases")) else {
        return Ok(());
    };
    let other = entries
        .filter_map(Result::ok)
        .filter_map(|e| e.file_name().to_str()?.strip_prefix("case_")?.parse().ok())
        .filter(|i| mine.binary_search(i).is_err())
        .min();
    match other {
        Some(i) => Err(refuse(format!(
            "case_{i:04}, which is not among this run's cases (begun as another shard, or \
             unsharded)"
        ))),
        None => Ok(()),
    }
}

/// Whether a case ended (completed or failed) in an earlier run.
fn finished(out: &Path, i: usize) -> bool {
    case_dir(out, i).join("outcome.toml").exists()
}

/// Runs (or resumes) the cases of `spec` that `opts.shard` selects, then writes the results
/// (unsharded) or `shard.toml` (sharded). Returns the indices of the cases run now.
pub fn run_sweep(spec: &SweepSpec, opts: &SweepOptions) -> Result<Vec<usize>, SweepError> {
    let out = &opts.out_dir;
    if let Some((k, n)) = opts.shard
        && (n == 0 || k >= n)
    {
        return Err(SweepError::Dir {
            dir: out.clone(),
            message: format!("shard {k}/{n}: K must be below N"),
        });
    }
    // One sweep per folder at a time: a second one, or a resume, started while this one runs
    // would take up the same cases and stop on the first it finds locked, part way through.
    let _lock = DirLock::acquire(out).map_err(|e| SweepError::Locked(Box::new(e)))?;
    let fp = fingerprint(spec);
    let stamp = out.join("sweep.toml");
    if holds_files(out) {
        if !opts.resume {
            return Err(SweepError::Dir {
                dir: out.clone(),
                message: "the folder is not empty; pass --resume to continue the sweep in it, \
                          or choose another --out"
                    .into(),
            });
        }
        match fs::read_to_string(&stamp) {
            Ok(t) if t == spec.text => {}
            saved => {
                // Any edit counts, comments and spaces too: the folder's sweep.toml is the
                // sweep file as it began.
                let what = match saved {
                    Ok(t) => format!(
                        "it holds a different sweep: {}",
                        crate::campaign::first_difference(
                            &t,
                            &spec.text,
                            "sweep.toml",
                            &spec.source.display().to_string()
                        )
                    ),
                    Err(_) => "it holds no sweep (no sweep.toml)".to_owned(),
                };
                return Err(SweepError::Dir {
                    dir: out.clone(),
                    message: format!("{what}; cannot resume"),
                });
            }
        }
    }
    let base = BaseFmus::open(spec)?;
    // Taken before any case runs, so the stamp names the FMUs the cases ran with.
    let ran_with = base.ran_with(spec)?;
    let plans = plan(spec, &base, out)?;
    let mine: Vec<usize> = (0..plans.len())
        .filter(|i| opts.shard.is_none_or(|(k, n)| i % n == k))
        .collect();
    check_begun_as(out, opts.shard, &mine)?;
    // Cases of this run (this shard) that ended in an earlier run, and those left to run.
    let (ended, todo): (Vec<usize>, Vec<usize>) = mine.iter().partition(|&&i| finished(out, i));
    check_kept_cases(spec, &plans, out, &ended, &ran_with.digests)?;
    // The stamp first (the lock made the folder): a folder that holds anything else then
    // always says which sweep it is.
    write_text(&stamp, &spec.text)?;
    create_folder(&out.join("cases")).map_err(|e| SweepError::Dir {
        dir: out.clone(),
        message: e.to_string(),
    })?;
    // Cases of this run (this shard) finished so far, resumed ones included, for progress.
    let done = AtomicUsize::new(ended.len());
    let jobs = opts.jobs.clamp(1, todo.len().max(1));
    let next = AtomicUsize::new(0);
    let first_error: Mutex<Option<SweepError>> = Mutex::new(None);
    let failed = AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            scope.spawn(|| {
                // Kept from case to case: opening the FMUs and the controller's reference
                // table cost a one-trial case a quarter of its time (BENCHMARKS.md, round 15).
                let mut kept = KeptFmus::default();
                loop {
                    let slot = next.fetch_add(1, Ordering::Relaxed);
                    let Some(&i) = todo.get(slot) else { break };
                    let failure =
                        match run_case(spec, &plans[i], out, i, opts, &ran_with, &mut kept) {
                            Ok(failure) => failure,
                            Err(e) => {
                                first_error
                                    .lock()
                                    .unwrap_or_else(PoisonError::into_inner)
                                    .get_or_insert(e);
                                next.store(todo.len(), Ordering::Relaxed);
                                break;
                            }
                        };
                    if failure.is_some() {
                        failed.fetch_add(1, Ordering::Relaxed);
                    }
                    if opts.progress {
                        let count = done.fetch_add(1, Ordering::Relaxed) + 1;
                        let ended = match &failure {
                            None => "done,".to_string(),
                            Some(why) => format!("failed: {why};"),
                        };
                        crate::console!(
                            "case {i} {ended} {count} of {} ({})",
                            mine.len(),
                            spec.case_labels(i).join(", ")
                        );
                    }
                }
            });
        }
    });
    if let Some(e) = first_error
        .into_inner()
        .unwrap_or_else(PoisonError::into_inner)
    {
        return Err(e);
    }
    let failed = failed.into_inner();
    if failed > 0 {
        crate::console!(
            "{failed} of the {} cases run here failed; each one's outcome.toml says why, and \
             sweep.csv marks it",
            todo.len()
        );
    }
    match opts.shard {
        Some((k, n)) => {
            let stamp = ShardStamp {
                fingerprint: fp,
                shard: k,
                shards: n,
                fmus: Some(ran_with.digests),
            };
            let text = toml::to_string(&stamp).map_err(|e| SweepError::Dir {
                dir: out.clone(),
                message: format!("shard.toml: {e}"),
            })?;
            write_text(&out.join("shard.toml"), &text)?
        }
        None => write_results(spec, out)?,
    }
    Ok(todo)
}

/// The first FMU whose digest differs between two records of FMU digests (or that only one
/// of them names).
fn first_difference<'t>(a: &'t toml::Table, b: &'t toml::Table) -> Option<&'t String> {
    a.keys()
        .chain(b.keys())
        .find(|name| a.get(*name) != b.get(*name))
}

/// `outcome.toml`: how a case ended, and what it ran: the [`scenario_digest`] of its
/// scenario and each FMU file's digest ([`BaseFmus::ran_with`]). Cases of earlier versions
/// recorded only how they ended. Written by [`run_case`], read by the resume check and by
/// the results.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
struct CaseOutcome {
    status: String,
    message: Option<String>,
    scenario: Option<String>,
    fmus: Option<toml::Table>,
}

/// A resumed sweep keeps its finished cases, so they must come from the base scenario and
/// FMUs as they are now, as `run --resume` requires of a campaign: otherwise the sweep
/// would mix cases of two models without a word. Every `ended` case is compared by what its
/// `outcome.toml` records, which costs no FMU file read per case. Of cases of earlier
/// versions, which record nothing, the first and the last are checked by their campaign
/// fingerprints, each check reading the FMU files once.
fn check_kept_cases(
    spec: &SweepSpec,
    plans: &[(Scenario, String)],
    out: &Path,
    ended: &[usize],
    digests: &toml::Table,
) -> Result<(), SweepError> {
    let refuse = |i: usize, what: String| SweepError::Dir {
        dir: out.to_path_buf(),
        message: format!(
            "cannot resume: case {i} ({}) was run {what} than the sweep has now, and resuming \
             would mix its results with cases of another model; restore them, or run the sweep \
             into a new --out",
            case_dir(out, i).display(),
        ),
    };
    let mut unrecorded = Vec::new();
    for &i in ended {
        let file = case_dir(out, i).join("outcome.toml");
        let bad = |message: String| SweepError::Dir {
            dir: file.clone(),
            message,
        };
        let text = fs::read_to_string(&file).map_err(|e| bad(e.to_string()))?;
        let outcome: CaseOutcome =
            toml::from_str(&text).map_err(|e| bad(toml_message_at(&e, &text)))?;
        let (Some(ran), Some(fmus)) = (outcome.scenario, outcome.fmus) else {
            unrecorded.push(i);
            continue;
        };
        let (scenario, text) = &plans[i];
        let digest = scenario_digest(scenario, text).map_err(|source| SweepError::Campaign {
            case: i,
            source: Box::new(source),
        })?;
        if ran != format!("{digest:016x}") {
            return Err(refuse(
                i,
                format!("from a different {} (what it sets)", spec.base.display()),
            ));
        }
        if let Some(name) = first_difference(digests, &fmus) {
            return Err(refuse(
                i,
                format!("with different FMUs (FMU {name:?}, other file bytes)"),
            ));
        }
    }
    let (Some(&first), Some(&last)) = (unrecorded.first(), unrecorded.last()) else {
        return Ok(());
    };
    for i in std::iter::once(first).chain((last != first).then_some(last)) {
        let (scenario, text) = &plans[i];
        let same = begun_with(&case_dir(out, i), scenario, text).map_err(|source| {
            SweepError::Campaign {
                case: i,
                source: Box::new(source),
            }
        })?;
        if same == Some(false) {
            return Err(refuse(
                i,
                format!("from a different {} or different FMUs", spec.base.display()),
            ));
        }
    }
    Ok(())
}

/// Runs one case as an ordinary campaign; an FMU failure ends the case as failed (its
/// message returned), not the sweep.
fn run_case(
    spec: &SweepSpec,
    (scenario, text): &(Scenario, String),
    out: &Path,
    i: usize,
    opts: &SweepOptions,
    ran_with: &RanWith,
    kept: &mut KeptFmus,
) -> Result<Option<String>, SweepError> {
    let dir = case_dir(out, i);
    let mut fmus = Vec::with_capacity(scenario.fmus.len());
    for (slot, f) in scenario.fmus.iter().enumerate() {
        fmus.push(kept.open(slot, &f.path).map_err(|e| SweepError::Open {
            file: spec.source.clone(),
            source: Box::new(e),
        })?);
    }
    // After the opening: the FMUs this case runs were opened from the files as they began.
    ran_with.unchanged(spec)?;
    let copts = CampaignOptions {
        out_dir: dir.clone(),
        resume: true,
        fmu_logging: opts.fmu_logging,
        progress: false,
        stop_after: None,
        // Cases resume in their own folders; the sweep itself refuses a foreign folder.
        force: false,
        memory_limit_mib: None,
        crash_at: None,
        lanes: 1,
    };
    let ran = run_campaign(scenario, text, fmus, &copts);
    if ran.is_err() {
        kept.clear();
    }
    let failure = match ran {
        Ok(_) => None,
        Err(CampaignError::Master(e)) => Some(e.to_string()),
        Err(e) => {
            return Err(SweepError::Campaign {
                case: i,
                source: Box::new(e),
            });
        }
    };
    create_folder(&dir).map_err(|e| SweepError::Dir {
        dir: dir.clone(),
        message: e.to_string(),
    })?;
    let digest = scenario_digest(scenario, text).map_err(|source| SweepError::Campaign {
        case: i,
        source: Box::new(source),
    })?;
    let outcome = CaseOutcome {
        status: if failure.is_some() {
            "failed"
        } else {
            "completed"
        }
        .into(),
        message: failure.clone(),
        scenario: Some(format!("{digest:016x}")),
        fmus: Some(ran_with.digests.clone()),
    };
    let outcome = toml::to_string(&outcome).map_err(|e| SweepError::Dir {
        dir: dir.clone(),
        message: format!("outcome.toml: {e}"),
    })?;
    write_text(&dir.join("outcome.toml"), &outcome)?;
    Ok(failure)
}

/// `shard.toml`: which sweep and shard a folder holds, and the FMUs its cases ran with
/// (absent in shards of earlier versions).
#[derive(Debug, serde::Serialize, serde::Deserialize)]
struct ShardStamp {
    fingerprint: String,
    shard: usize,
    shards: usize,
    fmus: Option<toml::Table>,
}

/// Combines shard directories of `spec` into `out`: copies every case and writes the results
/// exactly as an unsharded run would.
pub fn merge(spec: &SweepSpec, out: &Path, shard_dirs: &[PathBuf]) -> Result<(), SweepError> {
    // Two merges (or a merge and a sweep) into one folder would interleave their files.
    let _lock = DirLock::acquire(out).map_err(|e| SweepError::Locked(Box::new(e)))?;
    // Merged into a folder holding other files, the results would mix with them (or, in a
    // shard's folder, with its shard.toml).
    if holds_files(out) {
        return Err(SweepError::Dir {
            dir: out.to_path_buf(),
            message: "the folder is not empty; merge into a new or empty --out".into(),
        });
    }
    let fp = fingerprint(spec);
    let mut seen: Vec<Option<&Path>> = Vec::new();
    let mut total = None;
    // The first shard that named its FMUs, and the FMUs it named.
    let mut first_fmus: Option<(&Path, toml::Table)> = None;
    let mut unnamed = Vec::new();
    for dir in shard_dirs {
        let stamp_path = dir.join("shard.toml");
        let text = fs::read_to_string(&stamp_path).map_err(|e| {
            SweepError::Merge(format!(
                "{}: {e} (is it a finished shard?)",
                stamp_path.display()
            ))
        })?;
        let s: ShardStamp = toml::from_str(&text).map_err(|e| {
            SweepError::Merge(format!(
                "{}: {}",
                stamp_path.display(),
                toml_message_at(&e, &text)
            ))
        })?;
        if s.fingerprint != fp {
            return Err(SweepError::Merge(format!(
                "{} is a shard of a different sweep (or of an edited {})",
                dir.display(),
                spec.source.display()
            )));
        }
        if *total.get_or_insert(s.shards) != s.shards || s.shard >= s.shards {
            return Err(SweepError::Merge(format!(
                "{} is shard {}/{}, the others are of {} shards",
                dir.display(),
                s.shard,
                s.shards,
                total.unwrap_or(0)
            )));
        }
        seen.resize(s.shards, None);
        if let Some(prev) = seen[s.shard] {
            return Err(SweepError::Merge(format!(
                "shard {}/{} is given twice: {} and {}",
                s.shard,
                s.shards,
                prev.display(),
                dir.display()
            )));
        }
        seen[s.shard] = Some(dir);
        match (s.fmus, &first_fmus) {
            (None, _) => unnamed.push(dir.display().to_string()),
            (Some(fmus), None) => first_fmus = Some((dir, fmus)),
            (Some(fmus), Some((first, want))) => {
                if let Some(name) = first_difference(&fmus, want) {
                    return Err(SweepError::Merge(format!(
                        "{} ran FMU {name:?} from other bytes than {} did (the FMU file was \
                         rebuilt or replaced between the shards), so their cases are of two \
                         models; rerun the shards with one set of FMUs",
                        dir.display(),
                        first.display()
                    )));
                }
            }
        }
    }
    if !unnamed.is_empty() {
        crate::console!(
            "warning: {} written by an earlier version, which did not record the FMUs: that \
             all shards ran the same FMUs is not checked",
            unnamed.join(", ")
        );
    }
    let missing: Vec<String> = seen
        .iter()
        .enumerate()
        .filter(|(_, d)| d.is_none())
        .map(|(k, _)| format!("{k}/{}", seen.len()))
        .collect();
    if seen.is_empty() || !missing.is_empty() {
        return Err(SweepError::Merge(format!(
            "shards {} are missing",
            if seen.is_empty() {
                "(all)".into()
            } else {
                missing.join(", ")
            }
        )));
    }
    let n = seen.len();
    for i in 0..spec.cases.len() {
        let from = case_dir(seen[i % n].unwrap_or(Path::new(".")), i);
        if !from.join("outcome.toml").exists() {
            return Err(SweepError::Merge(format!(
                "case {i} has not finished in {}",
                from.display()
            )));
        }
    }
    create_folder(&out.join("cases")).map_err(|e| SweepError::Dir {
        dir: out.to_path_buf(),
        message: e.to_string(),
    })?;
    write_text(&out.join("sweep.toml"), &spec.text)?;
    for i in 0..spec.cases.len() {
        let from = case_dir(seen[i % n].unwrap_or(Path::new(".")), i);
        copy_tree(&from, &case_dir(out, i))?;
    }
    write_results(spec, out)
}

/// Copies a case directory (files atomically, so an interrupted merge leaves no torn file).
fn copy_tree(from: &Path, to: &Path) -> Result<(), SweepError> {
    let io = |p: &Path, e: std::io::Error| SweepError::Dir {
        dir: p.to_path_buf(),
        message: e.to_string(),
    };
    create_folder(to).map_err(|e| io(to, e))?;
    for entry in fs::read_dir(from).map_err(|e| io(from, e))? {
        let entry = entry.map_err(|e| io(from, e))?;
        let src = entry.path();
        let dst = to.join(entry.file_name());
        if src.is_dir() {
            copy_tree(&src, &dst)?;
        } else {
            let bytes = fs::read(&src).map_err(|e| io(&src, e))?;
            write_atomic(&dst, |w| w.write_all(&bytes))?;
        }
    }
    Ok(())
}
