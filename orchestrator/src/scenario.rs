//! Scenario files: a TOML description of FMUs, connections, iteration-memory channels,
//! timing, recording and metrics, validated once into a typed [`Scenario`].
//!
//! Every semantic error names the file and the line of the offending entry, e.g.
//! `line.toml:23: connection from "plant.lenght": CkcmPlant has no variable "lenght"`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use ckcm::TrajectoryKind;
use ckcm::learning::{LowPass, UpdateSettings};
use fmi2_import::Fmu;
use fmi2_md::{Causality, VarType};

use crate::variables::{
    Literal, VariableKey, check_value, convert, resolve, settable, variable_key,
};
use fmi2_md::{ModelDescription, Shown, VariableKind};
use serde::Deserialize;
use toml::Spanned;

/// A scenario problem: file, line (when known) and message; validation goes on after a
/// problem where it can, and the further problems it finds are in `more`, so one run shows
/// them all (as `fmpy validate` does for a model description).
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioError {
    pub file: PathBuf,
    pub line: Option<usize>,
    pub message: String,
    /// Further problems of the same file, in the order found.
    pub more: Vec<ScenarioError>,
}

impl ScenarioError {
    /// One problem.
    pub fn new(file: impl Into<PathBuf>, line: Option<usize>, message: impl Into<String>) -> Self {
        ScenarioError {
            file: file.into(),
            line,
            message: message.into(),
            more: Vec::new(),
        }
    }

    /// Every problem's message without file and line: for a scenario generated in memory
    /// (a sweep's case, a paper case), whose file and lines the user never sees.
    pub fn messages(&self) -> Vec<String> {
        std::iter::once(self)
            .chain(&self.more)
            .map(|e| e.message.clone())
            .collect()
    }

    fn write_one(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some(l) = self.line {
            write!(f, ":{l}")?;
        }
        write!(f, ": {}", self.message)
    }
}

/// One problem per line.
impl std::fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.write_one(f)?;
        for e in &self.more {
            writeln!(f)?;
            e.write_one(f)?;
        }
        Ok(())
    }
}

impl std::error::Error for ScenarioError {}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScenario {
    step_size: Spanned<f64>,
    stop_time: Spanned<f64>,
    #[serde(default)]
    start_time: f64,
    #[serde(default = "one")]
    trials: Spanned<usize>,
    #[serde(rename = "fmu")]
    fmus: Vec<RawFmu>,
    #[serde(default, rename = "connection")]
    connections: Vec<RawLink>,
    #[serde(default)]
    memory: Vec<RawMemory>,
    #[serde(default = "no_record")]
    record: RawRecord,
    #[serde(default)]
    metrics: Option<Spanned<RawMetrics>>,
    /// Refuse to run beyond this estimated memory, MiB (see `campaign::check_memory`).
    #[serde(default)]
    memory_limit_mib: Option<Spanned<u64>>,
}

fn no_record() -> RawRecord {
    RawRecord {
        variables: Vec::new(),
        interval: one(),
        trials: None,
        format: None,
    }
}

fn one() -> Spanned<usize> {
    Spanned::new(0..0, 1)
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFmu {
    name: Spanned<String>,
    path: Spanned<String>,
    #[serde(default)]
    parameters: BTreeMap<Spanned<String>, Spanned<toml::Value>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLink {
    from: Spanned<String>,
    to: Spanned<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMemory {
    from: Spanned<String>,
    to: Spanned<String>,
    #[serde(default)]
    update: Option<Spanned<RawUpdate>>,
}

/// `[memory.update]`: the robust learning update (docs/model.md §9). Integers are read
/// signed so that a negative value gets its own message.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawUpdate {
    #[serde(default)]
    filter: Option<Spanned<String>>,
    #[serde(default)]
    order: Option<Spanned<i64>>,
    #[serde(default)]
    cutoff: Option<Spanned<f64>>,
    #[serde(default)]
    lead: Option<Spanned<i64>>,
    #[serde(default)]
    forgetting: Option<Spanned<f64>>,
    #[serde(default)]
    gain: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRecord {
    #[serde(default)]
    variables: Vec<Spanned<String>>,
    /// Record every n-th sample.
    #[serde(default = "one")]
    interval: Spanned<usize>,
    /// Trials to record (default: all).
    #[serde(default)]
    trials: Option<Spanned<Vec<usize>>>,
    /// File format of the recorded trials, `"csv"` (default) or `"parquet"`.
    #[serde(default)]
    format: Option<Spanned<String>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMetrics {
    /// Six leg errors computed by an FMU.
    #[serde(default)]
    error: Option<Spanned<String>>,
    /// Six desired leg lengths; with `length`, the error is reference − length.
    #[serde(default)]
    reference: Option<Spanned<String>>,
    /// Six true (noise-free) leg lengths.
    #[serde(default)]
    length: Option<Spanned<String>>,
    #[serde(default = "default_rho")]
    rho: Spanned<f64>,
    #[serde(default)]
    pose: Option<Spanned<String>>,
    #[serde(default)]
    trajectory: Option<Spanned<RawTrajectory>>,
}

fn default_rho() -> Spanned<f64> {
    Spanned::new(0..0, DEFAULT_RHO)
}

/// Most steps per trial: 2^53, where t_n = t_0 + n·h stops telling samples apart.
const MAX_STEPS: f64 = 9_007_199_254_740_992.0;

/// Why a step of `h` cannot advance time over [`start`, `stop`], if it cannot. Far from
/// t = 0 doubles are far apart (16 s at 1e17 s), and t_n = t_0 + n·h then repeats a time:
/// every FMU would be stepped at the same point, and the rows would share one time. Each t_n
/// is within two spacings of its exact value, so more than four spacings keep them apart.
pub fn unresolved_step(start: f64, stop: f64, h: f64) -> Option<String> {
    let far = start.abs().max(stop.abs());
    let spacing = fmi2_md::time_spacing(far);
    let resolves = h > 4.0 * spacing;
    (!resolves).then(|| {
        format!(
            "a step of {} s cannot advance time near t = {} s, where neighbouring times are {} s \
             apart; it must be more than four times that: start nearer t = 0 or take longer steps",
            Shown(h),
            Shown(far),
            Shown(spacing)
        )
    })
}

/// Default weight of the λ-norm, 1/s.
pub const DEFAULT_RHO: f64 = 1.0;

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTrajectory {
    kind: String,
    duration: f64,
    #[serde(default = "default_home")]
    home_height: f64,
}

fn default_home() -> f64 {
    0.5
}

pub use crate::variables::Value;

/// One parameter (or input start value) assignment, made before every trial.
#[derive(Debug, Clone, PartialEq)]
pub struct Setting {
    pub name: String,
    pub value_reference: u32,
    /// The value in trial 0.
    pub value: Value,
    /// Added once per trial, of the same type as `value`: trial k gets value + k·per_trial
    /// (`{ base = …, per_trial = … }` in the scenario; `None`: the same in every trial).
    pub per_trial: Option<Value>,
}

impl Setting {
    /// The value set before trial `k` (docs/model.md §10). Integer values were checked at
    /// validation to fit every trial of the scenario.
    pub fn value_in_trial(&self, k: usize) -> Value {
        match (&self.value, &self.per_trial) {
            (&Value::Integer(base), Some(Value::Integer(step))) => Value::Integer(
                (i64::from(base) + k as i64 * i64::from(*step))
                    .clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32,
            ),
            (&Value::Real(base), Some(Value::Real(step))) => Value::Real(base + k as f64 * step),
            (v, _) => v.clone(),
        }
    }
}

/// One FMU of the scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct FmuSpec {
    /// Instance name, used in `name.variable` references.
    pub name: String,
    /// Path of the `.fmu`, resolved against the scenario file's directory.
    pub path: PathBuf,
    pub settings: Vec<Setting>,
}

/// A contiguous group of scalar variables of one FMU: `plant.length` is `length[1..6]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Port {
    /// Index into [`Scenario::fmus`].
    pub fmu: usize,
    /// Reference as written, e.g. `plant.length`.
    pub reference: String,
    /// Scalar names, e.g. `plant.length[1]`.
    pub names: Vec<String>,
    pub value_references: Vec<u32>,
    pub var_type: VarType,
    /// Whether the values are held over a step (discrete outputs: recorded after the step)
    /// rather than values at the communication point (recorded before the step).
    pub sampled: bool,
}

/// An output → input coupling, or an iteration-memory channel.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    pub from: Port,
    pub to: Port,
}

/// An iteration-memory channel: `to` reads during trial k what `from` wrote during trial
/// k − 1, after the update.
#[derive(Debug, Clone, PartialEq)]
pub struct MemoryChannel {
    pub link: Link,
    /// The robust update between trials; `None` is the paper's update (the values written
    /// become the values read, bit for bit).
    pub update: Option<UpdateSettings>,
}

/// What to record.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    pub ports: Vec<Port>,
    /// Record every n-th sample.
    pub interval: usize,
    /// Trials to record; `None` means all.
    pub trials: Option<BTreeSet<usize>>,
    /// File format of each recorded trial (`[record] format`, default CSV).
    pub format: RecordFormat,
}

/// How a recorded trial is written (`trials/trial_NNN.csv` or `.parquet`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum RecordFormat {
    /// Comma-separated text, every number in its shortest exact form.
    #[default]
    Csv,
    /// Apache Parquet: binary doubles, read by pandas, polars and MATLAB as they are.
    Parquet,
}

impl RecordFormat {
    /// The exporter writing this format.
    pub fn exporter(self) -> &'static dyn crate::output::Exporter {
        match self {
            RecordFormat::Csv => &crate::output::CsvExporter,
            RecordFormat::Parquet => &crate::output::ParquetExporter,
        }
    }
}

impl Record {
    /// Whether trial `k` is recorded.
    pub fn records_trial(&self, k: usize) -> bool {
        !self.ports.is_empty() && self.trials.as_ref().is_none_or(|t| t.contains(&k))
    }
}

/// Where the six leg errors of the metrics come from.
#[derive(Debug, Clone, PartialEq)]
pub enum LegError {
    /// An FMU's error outputs (e.g. the controller's, which see the measured lengths).
    Output(Port),
    /// reference − length, sample by sample: with the plant's noise-free `length_true`, the
    /// true error even when the measurements are noisy (docs/model.md §10).
    Difference { reference: Port, length: Port },
}

impl LegError {
    /// The ports the master taps: the error, or the reference then the length.
    pub fn ports(&self) -> Vec<&Port> {
        match self {
            LegError::Output(p) => vec![p],
            LegError::Difference { reference, length } => vec![reference, length],
        }
    }
}

/// What the per-trial summary measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Metrics {
    /// Six leg errors.
    pub error: LegError,
    /// λ-norm weight ρ, 1/s.
    pub rho: f64,
    /// Platform pose (x, y, z, ...) for the Cartesian path error.
    pub pose: Option<Port>,
    /// Desired path for the Cartesian path error.
    pub trajectory: Option<ckcm::Trajectory>,
}

/// A validated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    pub source: PathBuf,
    pub step_size: f64,
    pub start_time: f64,
    pub stop_time: f64,
    /// Macro steps per trial: round((stop − start) / h).
    pub steps: usize,
    pub trials: usize,
    /// FMUs in stepping (Gauss–Seidel) order.
    pub fmus: Vec<FmuSpec>,
    pub connections: Vec<Link>,
    pub memory: Vec<MemoryChannel>,
    pub record: Record,
    pub metrics: Option<Metrics>,
    /// `memory_limit_mib`: the most memory a campaign may take, MiB (default: the
    /// campaign's default, 4096).
    pub memory_limit_mib: Option<u64>,
    /// Line of `stop_time`, which with `step_size` sets the campaign's size (for messages).
    pub stop_time_line: Option<usize>,
}

/// Most bytes a scenario or sweep file may hold. Such files are a few kilobytes; the bound
/// turns a path to an endless source (`/dev/zero`, a device) into an error instead of a
/// read that never ends, while pipes (`run <(generate)`) still work.
pub const MAX_TEXT_BYTES: u64 = 64 << 20;

/// Reads a scenario or sweep file as UTF-8 text of at most [`MAX_TEXT_BYTES`]; text in
/// another encoding is named as such (UTF-16), or by the line of its first bad byte.
pub fn read_text(path: &Path) -> std::io::Result<String> {
    use std::io::Read;
    if path.is_dir() {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            folder_given_for_file(path),
        ));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(MAX_TEXT_BYTES + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_TEXT_BYTES {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "it holds more than {} MiB, which no scenario or sweep file does (is it a \
                 device or a data file?)",
                MAX_TEXT_BYTES >> 20
            ),
        ));
    }
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let message = if bytes.starts_with(&[0xff, 0xfe]) || bytes.starts_with(&[0xfe, 0xff]) {
            "it is UTF-16 text (an editor's \"Unicode\"); save it as UTF-8".to_string()
        } else if bytes.starts_with(b"PK\x03\x04") {
            "it is a zip archive (an FMU?), not a scenario or sweep file: `orchestrator info` \
             describes an FMU, `orchestrator simulate` runs one alone, and a scenario names its \
             FMUs under [[fmu]]"
                .to_string()
        } else {
            let at = e.utf8_error().valid_up_to();
            let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
            format!(
                "line {line} is not UTF-8 text (byte 0x{:02x}); save the file as UTF-8",
                bytes[at]
            )
        };
        std::io::Error::new(std::io::ErrorKind::InvalidData, message)
    })
}

/// Why a folder cannot be read as a scenario or sweep file, with the command that continues
/// the campaign or sweep it holds. Checked before opening: Linux opens a folder and fails
/// on the read ("Is a directory"), Windows refuses it as "Access is denied".
fn folder_given_for_file(dir: &Path) -> String {
    let shown = dir.display();
    let scenario = dir.join("scenario.toml");
    if scenario.is_file() && dir.join("progress.toml").is_file() {
        format!(
            "it is a campaign's folder, not a scenario file: its scenario is {0} \
             (`orchestrator run {0} --out {shown} --resume` continues the campaign)",
            scenario.display()
        )
    } else if dir.join("sweep.toml").is_file() {
        format!(
            "it is a sweep's folder, not a sweep file; `orchestrator sweep SWEEP.toml --out \
             {shown} --resume`, with the sweep file it began with, continues its sweep"
        )
    } else {
        "it is a folder, not a file".to_owned()
    }
}

/// Line (1-based) of a byte offset.
pub(crate) fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// The TOML reader's message for `e`, with a date or time where a number or string belongs
/// called what it is: the reader represents it as a table internally and says
/// "invalid type: map".
pub(crate) fn toml_message(e: &toml::de::Error, text: &str) -> String {
    let message = e.message();
    let is_datetime = e
        .span()
        .and_then(|span| text.get(span))
        .is_some_and(|value| value.trim().parse::<toml::value::Datetime>().is_ok());
    let mut message = if is_datetime {
        message.replacen("invalid type: map", "invalid type: a date or time", 1)
    } else {
        message.to_string()
    };
    message = in_plain_words(message);
    // `path = "C:\Users\me\X.fmu"`: TOML reads `\U` as the start of an escape.
    let line_has_backslash = e.span().is_some_and(|span| {
        text.lines()
            .nth(line_of(text, span.start) - 1)
            .is_some_and(|l| l.contains('\\'))
    });
    if line_has_backslash && (message.contains("escape") || message.contains("unicode")) {
        message.push_str(BACKSLASH_HINT);
    }
    message
}

/// serde names the Rust type it wanted ("expected usize"), which says nothing to a user
/// writing a TOML file: name the kind of number instead, and say how to write it when a
/// decimal or a quoted number stands where it is not read.
fn in_plain_words(message: String) -> String {
    const WHOLE: [&str; 4] = ["usize", "u64", "u32", "u8"];
    let Some(wanted) = message
        .rfind(", expected ")
        .map(|i| i + ", expected ".len())
    else {
        return message;
    };
    let (head, ty) = message.split_at(wanted);
    // Not "0 or more": which keys take 0 (a sweep's `seed`) and which refuse it (`trials`) is
    // checked, and said, after parsing.
    let (plain, whole) = if WHOLE.contains(&ty) || ["i64", "i32"].contains(&ty) {
        ("a whole number", true)
    } else if ty == "f64" {
        ("a number", false)
    } else {
        return message;
    };
    let quoted_number = head
        .strip_prefix("invalid type: string \"")
        .and_then(|rest| rest.rsplit_once('"'))
        .is_some_and(|(inner, _)| inner.trim().parse::<f64>().is_ok());
    let how = if WHOLE.contains(&ty) && head.starts_with("invalid value: integer `-") {
        " (not negative)"
    } else if whole && head.starts_with("invalid type: floating point") {
        " (written without a decimal point or exponent: 2, not 2.0 or 2e0)"
    } else if quoted_number {
        " (written without quotes)"
    } else {
        ""
    };
    format!("{head}{plain}{how}")
}

/// Why a backslash in a scenario's or sweep file's path goes wrong, and what to write instead.
const BACKSLASH_HINT: &str = " (in a \"…\" string a backslash starts an escape: write a \
     Windows path with `/`, or between single quotes: 'C:\\fmus\\X.fmu')";

/// What may explain that a path `written` in a scenario or sweep file, `path` once joined to
/// the file's folder, cannot be opened: written as for a shell, or with backslashes that TOML
/// read as escapes. Empty when neither applies, or when the path exists.
pub(crate) fn path_hint(written: &str, path: &Path) -> &'static str {
    if path.exists() {
        ""
    } else if written.contains(['\u{8}', '\t', '\n', '\u{c}', '\r']) {
        " (the path holds a control character: `\\b`, `\\t`, `\\n`, `\\f` or `\\r` in a \"…\" \
         string is an escape, not a backslash and a letter; write a Windows path with `/`, or \
         between single quotes)"
    } else if written.starts_with('~') || written.contains(['$', '%']) {
        " (the file's paths are taken as written, relative to its folder: `~` and \
         environment variables are not expanded)"
    } else {
        ""
    }
}

/// [`toml_message`] led by the line it points at, for the files the tools write themselves
/// (`shard.toml`, `outcome.toml`), whose errors name the file but carry no line of their own.
pub(crate) fn toml_message_at(e: &toml::de::Error, text: &str) -> String {
    match e.span() {
        Some(span) => format!(
            "line {}: {}",
            line_of(text, span.start),
            toml_message(e, text)
        ),
        None => toml_message(e, text),
    }
}

/// Whether `text` is a TOML document with one of `keys` at its top level: a sweep file given
/// where a scenario goes, or the other way round, is told apart from a scenario with a typo.
pub(crate) fn has_top_level_key(text: &str, keys: &[&str]) -> bool {
    text.parse::<toml::Table>()
        .is_ok_and(|doc| keys.iter().any(|k| doc.contains_key(*k)))
}

/// The first item of `items` that an earlier one equals: (the earlier index, its own).
pub(crate) fn first_repeat<T: PartialEq>(items: &[T]) -> Option<(usize, usize)> {
    (1..items.len()).find_map(|j| {
        items[..j]
            .iter()
            .position(|x| *x == items[j])
            .map(|i| (i, j))
    })
}

struct Ctx<'a> {
    file: &'a Path,
    text: &'a str,
    /// Problems found so far; validation goes on past each where it can.
    problems: std::cell::RefCell<Vec<ScenarioError>>,
}

impl Ctx<'_> {
    fn err<T>(
        &self,
        span: std::ops::Range<usize>,
        message: impl Into<String>,
    ) -> Result<T, ScenarioError> {
        Err(self.error(span, message))
    }

    /// The problem at `span`, with its line.
    fn error(&self, span: std::ops::Range<usize>, message: impl Into<String>) -> ScenarioError {
        ScenarioError::new(
            self.file,
            (span.end > 0).then(|| line_of(self.text, span.start)),
            message,
        )
    }

    /// The value, or `None` with the problem kept for the final report.
    fn keep<T>(&self, r: Result<T, ScenarioError>) -> Option<T> {
        match r {
            Ok(v) => Some(v),
            Err(e) => {
                self.problems.borrow_mut().push(e);
                None
            }
        }
    }

    /// Every problem kept so far as one error (sorted by line), or `Ok` if there is none.
    fn check(&self) -> Result<(), ScenarioError> {
        let mut all = std::mem::take(&mut *self.problems.borrow_mut());
        if all.is_empty() {
            return Ok(());
        }
        all.sort_by_key(|e| e.line.unwrap_or(0));
        let mut first = all.remove(0);
        first.more = all;
        Err(first)
    }
}

impl Scenario {
    /// The last `record.trials` entry when it is at or beyond the trial count. Not an error
    /// of the file: a campaign run with `--trials N` saves its scenario.toml with
    /// `trials = N` and the original selection, which an extended run (`--resume --trials
    /// M`) still records. `run` warns of it, and a sweep refuses a case with one (its count
    /// is the sweep's).
    pub fn recorded_trial_beyond_count(&self) -> Option<usize> {
        let last = self.record.trials.as_ref()?.last().copied()?;
        (last >= self.trials).then_some(last)
    }

    /// Reads the scenario file, opens every FMU it names and validates the scenario against
    /// their model descriptions: the scenario, its text (kept with the results) and the FMUs
    /// in scenario order.
    pub fn open(file: &Path) -> Result<(Scenario, String, Vec<Fmu>), ScenarioError> {
        let text = read_text(file).map_err(|e| {
            ScenarioError::new(file, None, format!("cannot read the scenario: {e}"))
        })?;
        let (scenario, fmus) = Self::open_text(&text, file)?;
        Ok((scenario, text, fmus))
    }

    /// [`Scenario::open`] for scenario `text` said to come from `file` (for messages and
    /// relative FMU paths). Each FMU is unzipped once, for validation and for running.
    pub fn open_text(text: &str, file: &Path) -> Result<(Scenario, Vec<Fmu>), ScenarioError> {
        let mut fmus = Vec::new();
        let scenario = Self::parse(text, file, |path| {
            let fmu = Fmu::open(path).map_err(|e| e.to_string())?;
            let md = fmu.model_description().clone();
            fmus.push(fmu);
            Ok(md)
        })?;
        Ok((scenario, fmus))
    }

    /// Validates scenario `text` read from `file` (used for messages and relative paths).
    pub fn parse(
        text: &str,
        file: &Path,
        mut describe: impl FnMut(&Path) -> Result<ModelDescription, String>,
    ) -> Result<Scenario, ScenarioError> {
        let cx = Ctx {
            file,
            text,
            problems: Default::default(),
        };
        let raw: RawScenario = toml::from_str(text).map_err(|e| {
            let mut message = toml_message(&e, text);
            if has_top_level_key(text, &["base", "axis"]) {
                message += " (this is a sweep file: `orchestrator sweep` runs it)";
            }
            ScenarioError::new(file, e.span().map(|s| line_of(text, s.start)), message)
        })?;
        let h = *raw.step_size.get_ref();
        if !(h.is_finite() && h > 0.0) {
            return cx.err(
                raw.step_size.span(),
                format!("step_size = {} must be positive", Shown(h)),
            );
        }
        let span_stop = raw.stop_time.span();
        let stop = raw.stop_time.into_inner();
        if !(stop.is_finite() && stop > raw.start_time) {
            return cx.err(
                span_stop,
                format!(
                    "stop_time = {} must exceed start_time = {}",
                    Shown(stop),
                    Shown(raw.start_time)
                ),
            );
        }
        let steps_f = (stop - raw.start_time) / h;
        // Beyond 2^53 steps t_n = t_0 + n·h no longer tells samples apart.
        if !(steps_f.is_finite() && steps_f <= MAX_STEPS) {
            return cx.err(
                span_stop.clone(),
                format!(
                    "(stop_time − start_time) / step_size = {steps_f:e} steps is more than \
                     {MAX_STEPS:e}; enlarge step_size or shorten the trial"
                ),
            );
        }
        if let Some(why) = unresolved_step(raw.start_time, stop, h) {
            return cx.err(raw.step_size.span(), format!("step_size: {why}"));
        }
        // A trial of zero steps would run nothing and report an all-zero summary.
        if steps_f < 1.0 - 1e-6 {
            return cx.err(
                raw.step_size.span(),
                format!(
                    "step_size = {} s is longer than the trial (stop_time − start_time = {} s); \
                     a trial must hold at least one step",
                    Shown(h),
                    Shown(stop - raw.start_time)
                ),
            );
        }
        let steps = steps_f.round() as usize;
        if (steps_f - steps as f64).abs() > 1e-6 * steps_f.max(1.0) {
            return cx.err(
                span_stop.clone(),
                format!(
                    "stop_time − start_time = {} is not a whole number of steps of {} s",
                    Shown(stop - raw.start_time),
                    Shown(h)
                ),
            );
        }
        let trials = *raw.trials.get_ref();
        if trials == 0 {
            return cx.err(raw.trials.span(), "trials must be at least 1");
        }
        if raw.fmus.is_empty() {
            return cx.err(0..0, "no [[fmu]] entries");
        }
        let base = file.parent().unwrap_or(Path::new("."));
        // From here on a problem is kept and validation goes on, so that one run reports
        // every bad entry; only an FMU that cannot be opened stops it (every reference to
        // it would fail too).
        let mut fmus = Vec::new();
        let mut mds = Vec::new();
        // Per FMU, whether one of its parameters was refused: its settings then lack that
        // value, and what they say it tracks is not what the file says.
        let mut refused = Vec::new();
        for f in &raw.fmus {
            let name = f.name.get_ref();
            let opened = (|| {
                if name.is_empty() || name.contains('.') || name.contains(char::is_whitespace) {
                    return cx.err(
                        f.name.span(),
                        format!("FMU name {name:?} must be non-empty, without dots or spaces"),
                    );
                }
                if fmus.iter().any(|x: &FmuSpec| &x.name == name) {
                    return cx.err(f.name.span(), format!("FMU name {name:?} is used twice"));
                }
                let path = base.join(f.path.get_ref());
                match describe(&path) {
                    Ok(md) => Ok((path, md)),
                    Err(e) => {
                        let hint = path_hint(f.path.get_ref(), &path);
                        cx.err(f.path.span(), format!("FMU {name:?}: {e}{hint}"))
                    }
                }
            })();
            let Some((path, md)) = cx.keep(opened) else {
                continue;
            };
            let mut settings: Vec<Setting> = Vec::new();
            // Which key set each variable: a whole array and one of its elements (or two
            // names of one variable) would both apply, the later silently winning.
            let mut set_by: Vec<(VariableKey, &Spanned<String>)> = Vec::new();
            let mut any_refused = false;
            for (key, value) in &f.parameters {
                let Some(s) = cx.keep(parameter_settings(&cx, &md, key, value, trials)) else {
                    any_refused = true;
                    continue;
                };
                for new in &s {
                    let id = variable_key(new.value_reference, &new.value);
                    if let Some((_, first)) = set_by.iter().find(|(k, _)| *k == id) {
                        cx.keep::<()>(cx.err(
                            key.span(),
                            format!(
                                "parameter {:?} sets {} again: {:?} on line {} already sets it; \
                                 give each value once",
                                key.get_ref(),
                                new.name,
                                first.get_ref(),
                                line_of(cx.text, first.span().start)
                            ),
                        ));
                    }
                    set_by.push((id, key));
                }
                settings.extend(s);
            }
            fmus.push(FmuSpec {
                name: name.clone(),
                path,
                settings,
            });
            mds.push(md);
            refused.push(any_refused);
        }
        if fmus.len() != raw.fmus.len() {
            cx.check()?;
        }
        let resolve = |r: &Spanned<String>, what: &str| resolve_port(&cx, &fmus, &mds, r, what);
        let mut connections = Vec::new();
        let mut fed_by: Vec<&RawLink> = Vec::new();
        for c in &raw.connections {
            let link = (|| {
                let from = resolve(&c.from, "connection from")?;
                let to = resolve(&c.to, "connection to")?;
                check_link(&cx, &mds, c, &from, &to, "connection")?;
                Ok(Link { from, to })
            })();
            if let Some(link) = cx.keep(link) {
                connections.push(link);
                fed_by.push(c);
            }
        }
        let raw_memory: Vec<RawLink> = raw
            .memory
            .iter()
            .map(|m| RawLink {
                from: m.from.clone(),
                to: m.to.clone(),
            })
            .collect();
        let mut memory = Vec::new();
        for (c, m) in raw_memory.iter().zip(&raw.memory) {
            let channel = (|| {
                let from = resolve(&c.from, "memory from")?;
                let to = resolve(&c.to, "memory to")?;
                check_link(&cx, &mds, c, &from, &to, "memory channel")?;
                let update = match &m.update {
                    None => None,
                    Some(u) => Some(parse_update(&cx, u, steps, h)?),
                };
                Ok(MemoryChannel {
                    link: Link { from, to },
                    update,
                })
            })();
            if let Some(channel) = cx.keep(channel) {
                memory.push(channel);
                fed_by.push(c);
            }
        }
        // An input fed twice would silently depend on the order of the entries.
        let mut fed = BTreeSet::new();
        for (link, raw_link) in connections
            .iter()
            .chain(memory.iter().map(|m| &m.link))
            .zip(fed_by)
        {
            if link
                .to
                .value_references
                .iter()
                .any(|vr| !fed.insert((link.to.fmu, *vr)))
            {
                cx.keep::<()>(cx.err(
                    raw_link.to.span(),
                    format!(
                        "input {:?} is fed by more than one connection",
                        raw_link.to.get_ref()
                    ),
                ));
            }
        }
        let mut ports: Vec<Port> = Vec::new();
        let mut recorded: BTreeMap<String, String> = BTreeMap::new();
        for r in &raw.record.variables {
            let port = (|| {
                let p = resolve(r, "record")?;
                // A variable listed twice would give two CSV columns of one name: refused,
                // so the scenario says exactly what each column is.
                for name in &p.names {
                    if let Some(by) = recorded.insert(name.clone(), r.get_ref().clone()) {
                        return cx.err(
                            r.span(),
                            format!(
                                "record: {name:?} is listed twice (already recorded by {by:?})"
                            ),
                        );
                    }
                }
                if p.var_type != VarType::Real {
                    return cx.err(
                        r.span(),
                        format!(
                            "record: {:?} is not Real; only Real variables are recorded",
                            r.get_ref()
                        ),
                    );
                }
                Ok(p)
            })();
            if let Some(p) = cx.keep(port) {
                ports.push(p);
            }
        }
        let interval = *raw.record.interval.get_ref();
        if interval == 0 {
            cx.keep::<()>(cx.err(
                raw.record.interval.span(),
                "record.interval must be at least 1",
            ));
        }
        let format = match raw
            .record
            .format
            .as_ref()
            .map(|f| (f, f.get_ref().as_str()))
        {
            None | Some((_, "csv")) => RecordFormat::Csv,
            Some((_, "parquet")) => RecordFormat::Parquet,
            Some((f, other)) => {
                cx.keep::<()>(cx.err(
                    f.span(),
                    format!("record.format {other:?} is not \"csv\" or \"parquet\""),
                ));
                RecordFormat::Csv
            }
        };
        let rec_trials = match &raw.record.trials {
            None => None,
            // A trial beyond the count is allowed here: `run --trials N` saves a scenario.toml
            // whose count may be below it (`Scenario::recorded_trial_beyond_count`).
            Some(t) => {
                if let Some((_, j)) = first_repeat(t.get_ref()) {
                    let twice = t.get_ref()[j];
                    cx.keep::<()>(
                        cx.err(t.span(), format!("record.trials lists trial {twice} twice")),
                    );
                }
                Some(t.get_ref().iter().copied().collect())
            }
        };
        let metrics = (|| {
            let Some(spanned) = &raw.metrics else {
                return Ok(None);
            };
            {
                let m = spanned.get_ref();
                // The metrics compute in metres: a variable whose declared unit is another
                // (a force, an angle) would give figures that look right and mean nothing.
                let in_metres = |r: &Spanned<String>, what: &str, port: &Port, first: usize| {
                    let md = &mds[port.fmu];
                    let other = port.value_references[..first].iter().find_map(|&vr| {
                        let v = md.variable_by_vr(VarType::Real, vr)?;
                        md.unit_of(v).filter(|&u| u != "m").map(|u| (&v.name, u))
                    });
                    match other {
                        Some((name, unit)) => cx.err(
                            r.span(),
                            format!(
                                "{what} {:?}: {name} is in {unit}; the metrics need lengths in m",
                                r.get_ref()
                            ),
                        ),
                        None => Ok(()),
                    }
                };
                let six = |r: &Spanned<String>, what: &str| {
                    let port = resolve(r, what)?;
                    if port.names.len() != 6 || port.var_type != VarType::Real {
                        return cx.err(
                            r.span(),
                            format!(
                                "{what} {:?} must be six Real variables (one per leg)",
                                r.get_ref()
                            ),
                        );
                    }
                    in_metres(r, what, &port, 6)?;
                    Ok(port)
                };
                let error = match (&m.error, &m.reference, &m.length) {
                    (Some(e), None, None) => LegError::Output(six(e, "metrics.error")?),
                    (None, Some(r), Some(l)) => LegError::Difference {
                        reference: six(r, "metrics.reference")?,
                        length: six(l, "metrics.length")?,
                    },
                    _ => {
                        return cx.err(
                            spanned.span(),
                            "[metrics] needs either error = \"fmu.error\" or both reference = \"fmu.length_ref\" \
                             and length = \"fmu.length_true\" (the true error reference − length), not a mix",
                        );
                    }
                };
                let rho = *m.rho.get_ref();
                if !(rho.is_finite() && rho >= 0.0) {
                    return cx.err(
                        m.rho.span(),
                        format!("metrics.rho = {} must be a non-negative number", Shown(rho)),
                    );
                }
                let pose = match &m.pose {
                    None => None,
                    Some(p) => {
                        let port = resolve(p, "metrics.pose")?;
                        if port.names.len() < 3 || port.var_type != VarType::Real {
                            return cx.err(p.span(), format!("metrics.pose {:?} must be at least three Real variables (x, y, z)", p.get_ref()));
                        }
                        in_metres(p, "metrics.pose", &port, 3)?;
                        // Past x, y, z a pose holds its orientation: a length there (the
                        // plant's six leg lengths, say) means the variable is not a pose.
                        let md = &mds[port.fmu];
                        let length = port.value_references[3..].iter().find_map(|&vr| {
                            let v = md.variable_by_vr(VarType::Real, vr)?;
                            (md.unit_of(v) == Some("m")).then_some(&v.name)
                        });
                        if let Some(name) = length {
                            let message = format!(
                                "metrics.pose {:?}: {name} is in m, so this is not a pose (x, y, \
                                 z, then angles); name the FMU's pose output",
                                p.get_ref()
                            );
                            return cx.err(p.span(), message);
                        }
                        Some(port)
                    }
                };
                // The path is the one tracked by the controller whose leg errors are
                // measured (a scenario may hold two loops); when those come from another
                // model, by every HlcsController in the scenario.
                let measured = match &error {
                    LegError::Output(p) => p.fmu,
                    LegError::Difference { reference, .. } => reference.fmu,
                };
                let only_measured = mds[measured].model_name == "HlcsController";
                let trackers: Vec<usize> = (0..fmus.len())
                    .filter(|&i| !refused[i] && (!only_measured || i == measured))
                    .collect();
                let trajectory = match &m.trajectory {
                    Some(t) => {
                        let parsed = parse_trajectory(&cx, t)?;
                        check_tracked(&cx, t, &parsed, &fmus, &mds, &trackers)?;
                        Some(parsed)
                    }
                    // Without one, the path is the reference the CKCM controller tracks.
                    None if pose.is_some() => {
                        let mut tracked = trackers
                            .iter()
                            .filter_map(|&i| tracked_trajectory(&fmus[i], &mds[i]));
                        match tracked.next() {
                            Some(one) if tracked.all(|t| t == one) => Some(one),
                            _ => return cx.err(
                                spanned.span(),
                                "metrics.pose needs metrics.trajectory, the path it is measured \
                                 against (without it, the reference of the scenario's \
                                 HlcsController FMU is taken, when there is one that tracks its \
                                 own the same in every trial)",
                            ),
                        }
                    }
                    None => None,
                };
                if pose.is_none() && trajectory.is_some() {
                    return cx.err(
                        spanned.span(),
                        "metrics.trajectory needs metrics.pose (the path error needs both)",
                    );
                }
                Ok(Some(Metrics {
                    error,
                    rho,
                    pose,
                    trajectory,
                }))
            }
        })();
        let metrics = cx.keep(metrics).flatten();
        cx.check()?;
        Ok(Scenario {
            source: file.to_path_buf(),
            step_size: h,
            start_time: raw.start_time,
            stop_time: stop,
            steps,
            trials,
            fmus,
            connections,
            memory,
            record: Record {
                ports,
                interval,
                trials: rec_trials,
                format,
            },
            metrics,
            memory_limit_mib: raw.memory_limit_mib.as_ref().map(|m| *m.get_ref()),
            stop_time_line: (span_stop.end > 0).then(|| line_of(text, span_stop.start)),
        })
    }

    /// Time of sample n: t_n = t_0 + n·h, never accumulated.
    #[inline]
    pub fn time(&self, n: usize) -> f64 {
        self.start_time + n as f64 * self.step_size
    }
}

/// The path an HlcsController's `trajectory` item `item` names, looked up by name in its
/// XML (a renumbered item needs no edit); `None` for `external` or an unknown item.
pub fn trajectory_item(md: &ModelDescription, item: i32) -> Option<TrajectoryKind> {
    TrajectoryKind::ALL
        .into_iter()
        .find(|k| md.enumeration_item("trajectory", k.name()) == Some(item))
}

/// A `[memory.update]` in words, for the analysis' summary and the master's errors.
pub fn describe_update(u: &UpdateSettings) -> String {
    let filter = match u.filter {
        Some(q) => format!(
            "Butterworth order {} cutoff {} Hz (zero phase)",
            q.order,
            Shown(q.cutoff_hz)
        ),
        None => "no filter".to_string(),
    };
    format!(
        "{filter}, lead δ = {} samples, forgetting α = {}, gain g = {}",
        u.lead,
        Shown(u.forgetting),
        Shown(u.gain)
    )
}

/// Validates `[memory.update]` for trials of `steps` samples of `h` s. Every bad entry is
/// reported: all but the last are kept in `cx`, the last is returned.
fn parse_update(
    cx: &Ctx<'_>,
    u: &Spanned<RawUpdate>,
    steps: usize,
    h: f64,
) -> Result<UpdateSettings, ScenarioError> {
    let r = u.get_ref();
    let mut errors = Vec::new();
    let mut keep = |e: ScenarioError| errors.push(e);
    let mut settings = UpdateSettings::default();
    let mut finite = |v: &Option<Spanned<f64>>, name: &str, default: f64| match v {
        None => default,
        Some(x) if x.get_ref().is_finite() => *x.get_ref(),
        Some(x) => {
            keep(cx.error(
                x.span(),
                format!(
                    "memory.update.{name} = {} must be a finite number",
                    Shown(*x.get_ref())
                ),
            ));
            default
        }
    };
    settings.forgetting = finite(&r.forgetting, "forgetting", 1.0);
    settings.gain = finite(&r.gain, "gain", 1.0);
    if let Some(lead) = &r.lead {
        let l = *lead.get_ref();
        if l < 0 {
            keep(cx.error(
                lead.span(),
                format!("memory.update.lead = {l} must not be negative (samples of phase lead)"),
            ));
        } else if l as u64 >= steps as u64 {
            keep(cx.error(
                lead.span(),
                format!(
                    "memory.update.lead = {l} must be less than the {steps} samples of a trial"
                ),
            ));
        } else {
            settings.lead = l as usize;
        }
    }
    match &r.filter {
        None => {
            if let Some(span) = r
                .order
                .as_ref()
                .map(|o| o.span())
                .or(r.cutoff.as_ref().map(|c| c.span()))
            {
                keep(cx.error(
                    span,
                    "memory.update: order and cutoff need filter = \"butterworth\"",
                ));
            }
        }
        Some(f) if f.get_ref() == "butterworth" => {
            if r.order.is_none() {
                keep(cx.error(
                    f.span(),
                    "memory.update: filter = \"butterworth\" needs order (>= 1)",
                ));
            }
            if r.cutoff.is_none() {
                keep(cx.error(
                    f.span(),
                    "memory.update: filter = \"butterworth\" needs cutoff (Hz)",
                ));
            }
            let order = r.order.as_ref().and_then(|order| {
                let o = *order.get_ref();
                if !(1..=ckcm::learning::MAX_ORDER as i64).contains(&o) {
                    keep(cx.error(
                        order.span(),
                        format!(
                            "memory.update.order = {o} must be between 1 and {}",
                            ckcm::learning::MAX_ORDER
                        ),
                    ));
                    None
                } else if steps <= 2 * o as usize {
                    keep(cx.error(
                        order.span(),
                        format!("memory.update: a zero-phase filter of order {o} needs more than {} samples per trial, there are {steps}", 2 * o),
                    ));
                    None
                } else {
                    Some(o as usize)
                }
            });
            let cutoff = r.cutoff.as_ref().and_then(|cutoff| {
                let fc = *cutoff.get_ref();
                let nyquist = 0.5 / h;
                if fc.is_finite() && fc > 0.0 && fc < nyquist {
                    Some(fc)
                } else {
                    keep(cx.error(
                        cutoff.span(),
                        format!("memory.update.cutoff = {fc} Hz must lie strictly between 0 and the Nyquist frequency 1/(2·step_size) = {nyquist} Hz"),
                    ));
                    None
                }
            });
            if let (Some(order), Some(cutoff_hz)) = (order, cutoff) {
                settings.filter = Some(LowPass { order, cutoff_hz });
            }
        }
        Some(f) => {
            keep(cx.error(
                f.span(),
                format!(
                    "memory.update.filter {:?} is unknown: the only filter is \"butterworth\"",
                    f.get_ref()
                ),
            ));
        }
    }
    match errors.pop() {
        None => Ok(settings),
        Some(last) => {
            cx.problems.borrow_mut().extend(errors);
            Err(last)
        }
    }
}

fn parse_trajectory(
    cx: &Ctx<'_>,
    t: &Spanned<RawTrajectory>,
) -> Result<ckcm::Trajectory, ScenarioError> {
    let r = t.get_ref();
    let Some(kind) = TrajectoryKind::from_name(&r.kind) else {
        return cx.err(
            t.span(),
            format!(
                "metrics.trajectory.kind {:?} is not one of {}",
                r.kind,
                TrajectoryKind::names()
            ),
        );
    };
    if !(r.duration > 0.0 && r.home_height > 0.0) {
        return cx.err(
            t.span(),
            "metrics.trajectory needs duration > 0 and home_height > 0",
        );
    }
    Ok(ckcm::Trajectory {
        kind,
        duration: r.duration,
        home_height: r.home_height,
    })
}

/// `metrics.trajectory` must be the path each of `trackers` (CKCM controllers among them)
/// tracks: the two are written apart, and a path error measured against another path looks
/// plausible.
fn check_tracked(
    cx: &Ctx<'_>,
    t: &Spanned<RawTrajectory>,
    measured: &ckcm::Trajectory,
    fmus: &[FmuSpec],
    mds: &[ModelDescription],
    trackers: &[usize],
) -> Result<(), ScenarioError> {
    let shown = |t: &ckcm::Trajectory| {
        format!(
            "{} of {} s at home height {} m",
            t.kind.name(),
            Shown(t.duration),
            Shown(t.home_height)
        )
    };
    for &i in trackers {
        let spec = &fmus[i];
        let Some(tracked) = tracked_trajectory(spec, &mds[i]) else {
            continue;
        };
        let same = tracked.kind == measured.kind
            && tracked.home_height == measured.home_height
            && (tracked.duration == measured.duration || tracked.kind == TrajectoryKind::Hold);
        if !same {
            return cx.err(
                t.span(),
                format!(
                    "metrics.trajectory is a {}, but FMU {:?} tracks a {}: the path error \
                     would measure the platform against another path; make them equal, or \
                     leave out metrics.trajectory to measure against the controller's",
                    shown(measured),
                    spec.name,
                    shown(&tracked)
                ),
            );
        }
    }
    Ok(())
}

/// The reference an HlcsController FMU tracks in every trial, from its `trajectory`,
/// `duration` and `model.home_height` as set (or declared); `None` for another model, an
/// external reference, or one that changes from trial to trial.
fn tracked_trajectory(spec: &FmuSpec, md: &ModelDescription) -> Option<ckcm::Trajectory> {
    if md.model_name != "HlcsController" {
        return None;
    }
    let value = |name: &str| -> Option<Value> {
        match spec.settings.iter().rfind(|s| s.name == name) {
            Some(s) if s.per_trial.is_some() => None,
            Some(s) => Some(s.value.clone()),
            None => match &md.variable_by_name(name)?.kind {
                VariableKind::Real { start, .. } => start.map(Value::Real),
                VariableKind::Enumeration { start, .. } => start.map(Value::Integer),
                _ => None,
            },
        }
    };
    let real = |name: &str| match value(name)? {
        Value::Real(x) => Some(x),
        _ => None,
    };
    let Value::Integer(item) = value("trajectory")? else {
        return None;
    };
    let kind = trajectory_item(md, item)?;
    Some(ckcm::Trajectory {
        kind,
        duration: real("duration")?,
        home_height: real("model.home_height")?,
    })
}

fn check_link(
    cx: &Ctx<'_>,
    mds: &[ModelDescription],
    raw: &RawLink,
    from: &Port,
    to: &Port,
    what: &str,
) -> Result<(), ScenarioError> {
    let causality = |p: &Port, i: usize| {
        mds[p.fmu]
            .model_variables
            .iter()
            .find(|v| v.value_reference == p.value_references[i] && v.var_type() == p.var_type)
            .map(|v| v.causality)
    };
    for i in 0..from.names.len() {
        if causality(from, i) != Some(Causality::Output) {
            return cx.err(
                raw.from.span(),
                format!(
                    "{what} from {:?}: {} is not an output",
                    raw.from.get_ref(),
                    from.names[i]
                ),
            );
        }
    }
    for i in 0..to.names.len() {
        if causality(to, i) != Some(Causality::Input) {
            return cx.err(
                raw.to.span(),
                format!(
                    "{what} to {:?}: {} is not an input",
                    raw.to.get_ref(),
                    to.names[i]
                ),
            );
        }
    }
    if from.names.len() != to.names.len() {
        return cx.err(
            raw.to.span(),
            format!(
                "{what} {:?} → {:?}: sizes differ ({} vs {})",
                raw.from.get_ref(),
                raw.to.get_ref(),
                from.names.len(),
                to.names.len()
            ),
        );
    }
    if from.var_type != to.var_type {
        return cx.err(
            raw.to.span(),
            format!(
                "{what} {:?} → {:?}: types differ ({:?} vs {:?})",
                raw.from.get_ref(),
                raw.to.get_ref(),
                from.var_type,
                to.var_type
            ),
        );
    }
    // The master moves values through one bus of Reals (fmi2GetReal/fmi2SetReal).
    if from.var_type != VarType::Real {
        return cx.err(
            raw.from.span(),
            format!(
                "{what} {:?} → {:?}: only Real variables can be coupled, these are {:?}",
                raw.from.get_ref(),
                raw.to.get_ref(),
                from.var_type
            ),
        );
    }
    Ok(())
}

fn resolve_port(
    cx: &Ctx<'_>,
    fmus: &[FmuSpec],
    mds: &[ModelDescription],
    r: &Spanned<String>,
    what: &str,
) -> Result<Port, ScenarioError> {
    let reference = r.get_ref();
    let Some((fmu_name, var)) = reference.split_once('.') else {
        return cx.err(
            r.span(),
            format!("{what} {reference:?}: expected \"fmu.variable\""),
        );
    };
    let Some(fmu) = fmus.iter().position(|f| f.name == fmu_name) else {
        let known: Vec<_> = fmus.iter().map(|f| f.name.as_str()).collect();
        return cx.err(
            r.span(),
            format!(
                "{what} {reference:?}: no FMU named {fmu_name:?} (known: {})",
                known.join(", ")
            ),
        );
    };
    let md = &mds[fmu];
    let vars = resolve(md, var);
    if vars.is_empty() {
        return cx.err(
            r.span(),
            format!(
                "{what} {reference:?}: {} has no variable {var:?}",
                md.model_name
            ),
        );
    }
    let var_type = vars[0].var_type();
    if vars.iter().any(|v| v.var_type() != var_type) {
        return cx.err(
            r.span(),
            format!("{what} {reference:?}: the elements have different types"),
        );
    }
    Ok(Port {
        fmu,
        reference: reference.clone(),
        names: vars
            .iter()
            .map(|v| format!("{fmu_name}.{}", v.name))
            .collect(),
        value_references: vars.iter().map(|v| v.value_reference).collect(),
        var_type,
        sampled: vars
            .iter()
            .all(|v| v.variability == fmi2_md::Variability::Discrete),
    })
}

fn parameter_settings(
    cx: &Ctx<'_>,
    md: &ModelDescription,
    key: &Spanned<String>,
    value: &Spanned<toml::Value>,
    trials: usize,
) -> Result<Vec<Setting>, ScenarioError> {
    let name = key.get_ref();
    let vars = resolve(md, name);
    if vars.is_empty() {
        // `model.mass = 1` is TOML for a table `model` holding `mass`: the variable
        // "model.mass" needs its name quoted.
        let prefix = format!("{name}.");
        let hint = match value.get_ref() {
            toml::Value::Table(t)
                if md
                    .model_variables
                    .iter()
                    .any(|v| v.name.starts_with(&prefix)) =>
            {
                let first = t.keys().next().map_or("…", String::as_str);
                format!(
                    "; TOML reads an unquoted dot as a table: quote the dotted name, \
                     \"{prefix}{first}\" = …"
                )
            }
            _ => String::new(),
        };
        return cx.err(
            key.span(),
            format!(
                "parameter {name:?}: {} has no variable {name:?}{hint}",
                md.model_name
            ),
        );
    }
    // Whether it can be set at all comes first: an output given one value is not a size
    // mismatch.
    for v in &vars {
        if let Err(message) = settable(v) {
            return cx.err(key.span(), message);
        }
    }
    let values: Vec<&toml::Value> = match value.get_ref() {
        // A list is for an array variable's elements; for a scalar it is a slip (or a
        // guess at another tool's syntax) that a user should see, not have read as its item.
        toml::Value::Array(_) if vars.len() == 1 && vars[0].name == *name => {
            return cx.err(
                value.span(),
                format!(
                    "parameter {name:?} is a single value, not an array: write it without \
                     brackets"
                ),
            );
        }
        toml::Value::Array(items) => items.iter().collect(),
        single => vec![single],
    };
    if values.len() != vars.len() {
        return cx.err(
            value.span(),
            format!(
                "parameter {name:?} has {} elements, the value gives {}",
                vars.len(),
                values.len()
            ),
        );
    }
    let mut out = Vec::new();
    for (v, x) in vars.iter().zip(values) {
        if let toml::Value::Table(table) = x {
            let (base, step) = per_trial_values(cx, v, value.span(), table, trials)?;
            out.push(Setting {
                name: v.name.clone(),
                value_reference: v.value_reference,
                value: base,
                per_trial: Some(step),
            });
            continue;
        }
        let parsed = match convert(md, v, Literal::Toml(x)) {
            Ok(parsed) => parsed,
            Err(message) => return cx.err(value.span(), message),
        };
        if let Err(message) = check_value(md, v, &parsed) {
            return cx.err(value.span(), message);
        }
        out.push(Setting {
            name: v.name.clone(),
            value_reference: v.value_reference,
            value: parsed,
            per_trial: None,
        });
    }
    Ok(out)
}

/// A per-trial value `{ base = B, per_trial = S }` of a Real or Integer variable: B in
/// trial 0, B + k·S in trial k. Every trial's value must fit the variable's type and its
/// declared min/max, checked here so that a campaign never fails at trial 37.
fn per_trial_values(
    cx: &Ctx<'_>,
    v: &fmi2_md::ScalarVariable,
    span: std::ops::Range<usize>,
    table: &toml::Table,
    trials: usize,
) -> Result<(Value, Value), ScenarioError> {
    let name = &v.name;
    if let Some(k) = table
        .keys()
        .find(|k| !matches!(k.as_str(), "base" | "per_trial"))
    {
        return cx.err(
            span,
            format!(
                "{name:?}: unknown key {k:?} in a per-trial value (expected base and per_trial)"
            ),
        );
    }
    let (Some(base), Some(step)) = (table.get("base"), table.get("per_trial")) else {
        return cx.err(
            span,
            format!("{name:?}: a per-trial value needs both base and per_trial, e.g. {{ base = 1000, per_trial = 1 }}"),
        );
    };
    let last = (trials - 1) as i64;
    match &v.kind {
        VariableKind::Integer { min, max, .. } => {
            let (toml::Value::Integer(b), toml::Value::Integer(s)) = (base, step) else {
                return cx.err(
                    span,
                    format!("{name:?} is an Integer: base and per_trial must be integers"),
                );
            };
            let lo = i64::from(min.unwrap_or(i32::MIN));
            let hi = i64::from(max.unwrap_or(i32::MAX));
            for (k, x) in [
                (0, Some(*b)),
                (last, s.checked_mul(last).and_then(|d| b.checked_add(d))),
            ] {
                match x {
                    Some(x) if (lo..=hi).contains(&x) => {}
                    _ => {
                        return cx.err(
                            span,
                            format!(
                                "{name:?} = {b} + trial·{s} leaves [{lo}, {hi}] in trial {k} of 0..{last}"
                            ),
                        );
                    }
                }
            }
            Ok((Value::Integer(*b as i32), Value::Integer(*s as i32)))
        }
        VariableKind::Real { min, max, .. } => {
            let number = |x: &toml::Value| match x {
                toml::Value::Float(f) => Some(*f),
                toml::Value::Integer(i) => Some(*i as f64),
                _ => None,
            };
            let (Some(b), Some(s)) = (number(base), number(step)) else {
                return cx.err(
                    span,
                    format!("{name:?} is Real: base and per_trial must be numbers"),
                );
            };
            let lo = min.unwrap_or(f64::NEG_INFINITY);
            let hi = max.unwrap_or(f64::INFINITY);
            for (k, x) in [(0, b), (last, b + last as f64 * s)] {
                if !(x.is_finite() && (lo..=hi).contains(&x)) {
                    return cx.err(
                        span,
                        format!(
                            "{name:?} = {} + trial·{} is {} in trial {k}, outside [{}, {}]",
                            Shown(b),
                            Shown(s),
                            Shown(x),
                            Shown(lo),
                            Shown(hi)
                        ),
                    );
                }
            }
            Ok((Value::Real(b), Value::Real(s)))
        }
        _ => cx.err(
            span,
            format!("{name:?}: per-trial values are for Real and Integer variables only"),
        ),
    }
}

/// Where a scenario text says how many trials and where each FMU is, for [`as_run_text`].
#[derive(Debug, Deserialize)]
struct RawPlaces {
    #[serde(default)]
    trials: Option<Spanned<toml::Value>>,
    #[serde(default, rename = "fmu")]
    fmus: Vec<RawPlace>,
}

#[derive(Debug, Deserialize)]
struct RawPlace {
    path: Spanned<toml::Value>,
}

/// Scenario `text` (from `file`) with every `[[fmu]]` `path` replaced by `paths` (in order)
/// and `trials` set to `trials` (added at the top when absent); comments and layout are
/// kept. A campaign saves its scenario this way, so the saved file reruns from anywhere and
/// says what ran, and fingerprints it this way with placeholders, so the original file and
/// the saved one identify the same campaign.
pub fn as_run_text(
    text: &str,
    file: &Path,
    paths: &[&str],
    trials: usize,
) -> Result<String, ScenarioError> {
    let places: RawPlaces = toml::from_str(text).map_err(|e| {
        ScenarioError::new(file, e.span().map(|s| line_of(text, s.start)), e.message())
    })?;
    if places.fmus.len() != paths.len() {
        return Err(ScenarioError::new(
            file,
            None,
            format!(
                "{} [[fmu]] entries, but {} FMU paths to write",
                places.fmus.len(),
                paths.len()
            ),
        ));
    }
    let mut edits: Vec<(std::ops::Range<usize>, String)> = places
        .fmus
        .iter()
        .zip(paths)
        .map(|(f, p)| {
            (
                f.path.span(),
                toml::Value::String((*p).to_owned()).to_string(),
            )
        })
        .collect();
    let count = trials.to_string();
    match &places.trials {
        Some(t) => edits.push((t.span(), count)),
        // A top-level key is valid before any table, i.e. first (after a byte-order mark).
        None => {
            let at = if text.starts_with('\u{feff}') { 3 } else { 0 };
            edits.push((at..at, format!("trials = {count}\n")));
        }
    }
    edits.sort_by_key(|(r, _)| r.start);
    let mut out = String::with_capacity(text.len() + 256);
    let mut at = 0;
    for (range, new) in edits {
        out.push_str(&text[at..range.start]);
        out.push_str(&new);
        at = range.end;
    }
    out.push_str(&text[at..]);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal model with Real and Integer outputs and inputs.
    const MD: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="M" guid="{1}">
  <CoSimulation modelIdentifier="M"/>
  <ModelVariables>
    <ScalarVariable name="yr" valueReference="1" causality="output"><Real/></ScalarVariable>
    <ScalarVariable name="ur" valueReference="2" causality="input"><Real start="0"/></ScalarVariable>
    <ScalarVariable name="yi" valueReference="1" causality="output" variability="discrete"><Integer/></ScalarVariable>
    <ScalarVariable name="ui" valueReference="2" causality="input" variability="discrete"><Integer start="0"/></ScalarVariable>
    <ScalarVariable name="seed" valueReference="3" causality="parameter" variability="fixed" initial="exact"><Integer start="0" min="0" max="2000"/></ScalarVariable>
    <ScalarVariable name="sigma" valueReference="3" causality="parameter" variability="fixed" initial="exact"><Real start="0" min="0"/></ScalarVariable>
    <ScalarVariable name="on" valueReference="3" causality="parameter" variability="fixed" initial="exact"><Boolean start="false"/></ScalarVariable>
    <ScalarVariable name="model.mass" valueReference="4" causality="parameter" variability="fixed" initial="exact"><Real start="1"/></ScalarVariable>
  </ModelVariables>
  <ModelStructure>
    <Outputs><Unknown index="1"/><Unknown index="3"/></Outputs>
  </ModelStructure>
</fmiModelDescription>"#;

    fn parse(link: &str) -> Result<Scenario, ScenarioError> {
        let text = format!(
            "step_size = 0.1\nstop_time = 1.0\n[[fmu]]\nname = \"a\"\npath = \"a.fmu\"\n[[fmu]]\nname = \"b\"\npath = \"b.fmu\"\n{link}"
        );
        Scenario::parse(&text, Path::new("s.toml"), |_| {
            ModelDescription::parse(MD).map_err(|e| e.to_string())
        })
    }

    #[test]
    fn a_step_longer_than_the_trial_is_refused_at_its_line() {
        for h in ["1e6", "1e300", "1.5"] {
            let text = format!(
                "stop_time = 1.0\nstep_size = {h}\n[[fmu]]\nname = \"a\"\npath = \"a.fmu\"\n"
            );
            let err = Scenario::parse(&text, Path::new("s.toml"), |_| {
                ModelDescription::parse(MD).map_err(|e| e.to_string())
            })
            .unwrap_err();
            assert_eq!(err.line, Some(2), "{err}");
            assert!(err.to_string().contains("at least one step"), "{err}");
        }
    }

    /// A huge number in a refusal is shown with an exponent, not as 300 digits.
    #[test]
    fn huge_times_are_shown_short_in_their_errors() {
        let fmu = "[[fmu]]\nname = \"a\"\npath = \"a.fmu\"\n";
        for (head, says) in [
            (
                "step_size = -1e300\nstop_time = 1.0",
                "step_size = -1e300 must be positive",
            ),
            (
                "step_size = 0.1\nstop_time = -1e300",
                "stop_time = -1e300 must exceed start_time = 0",
            ),
            (
                "step_size = 1e300\nstop_time = 1.0",
                "step_size = 1e300 s is longer than the trial",
            ),
            (
                "step_size = 0.1\nstop_time = 1e300",
                "(stop_time − start_time) / step_size = 1e301 steps is more than",
            ),
        ] {
            let text = format!("{head}\n{fmu}");
            let err = Scenario::parse(&text, Path::new("s.toml"), |_| {
                ModelDescription::parse(MD).map_err(|e| e.to_string())
            })
            .unwrap_err()
            .to_string();
            assert!(err.contains(says), "{err}");
            assert!(err.len() < 200, "{err}");
        }
    }

    /// Far from t = 0 a millisecond step would repeat one time in every row.
    #[test]
    fn a_step_below_the_time_resolution_is_refused_at_its_line() {
        let parse = |times: &str| {
            let text =
                format!("{times}\nstep_size = 0.001\n[[fmu]]\nname = \"a\"\npath = \"a.fmu\"\n");
            Scenario::parse(&text, Path::new("s.toml"), |_| {
                ModelDescription::parse(MD).map_err(|e| e.to_string())
            })
        };
        // Doubles near 1e17 are 16 s apart; near 1e12, 1.2e-4 s (more than 4 × that is
        // 4.9e-4 s, so a millisecond still resolves).
        let err = parse("start_time = 1e17\nstop_time = 100000000000000016.0").unwrap_err();
        assert_eq!(err.line, Some(3), "{err}");
        assert!(
            err.to_string().contains(
                "step_size: a step of 0.001 s cannot advance time near t = 1.0000000000000002e17 \
                 s, where neighbouring times are 16 s apart"
            ),
            "{err}"
        );
        let err = parse("start_time = 1e13\nstop_time = 10000000000001.0").unwrap_err();
        assert!(err.to_string().contains("cannot advance time"), "{err}");
        let sc = parse("start_time = 1e12\nstop_time = 1000000000001.0").unwrap();
        assert!((1..sc.steps).all(|n| sc.time(n) > sc.time(n - 1)));
    }

    #[test]
    fn every_problem_is_reported_at_once_with_its_line() {
        // Line 8: unknown variable; 10: Integer coupling; 16: bad parameter value (of FMU b,
        // given after the connections); 18: a record of a missing variable.
        let text = "step_size = 0.1\nstop_time = 1.0\n[[fmu]]\nname = \"a\"\npath = \"a.fmu\"\n\
                    [[connection]]\nfrom = \"a.yr\"\n\
                    to = \"b.nope\"\n\
                    [[connection]]\nfrom = \"a.yi\"\nto = \"b.ui\"\n\
                    [[fmu]]\nname = \"b\"\npath = \"b.fmu\"\n[fmu.parameters]\nsigma = -1.0\n\
                    [record]\nvariables = [\"a.zz\"]\n";
        let err = Scenario::parse(text, Path::new("s.toml"), |_| {
            ModelDescription::parse(MD).map_err(|e| e.to_string())
        })
        .unwrap_err();
        let lines: Vec<Option<usize>> = std::iter::once(err.line)
            .chain(err.more.iter().map(|e| e.line))
            .collect();
        assert_eq!(lines, [Some(8), Some(10), Some(16), Some(18)], "{err}");
        let shown = err.to_string();
        assert_eq!(shown.lines().count(), 4, "{shown}");
        assert!(shown.lines().all(|l| l.starts_with("s.toml:")), "{shown}");
        assert!(shown.contains("has no variable \"nope\""), "{shown}");
        assert!(shown.contains("below its declared min"), "{shown}");
        assert!(shown.contains("\"a.zz\""), "{shown}");
    }

    #[test]
    fn couples_reals_and_refuses_other_types_with_the_line() {
        assert!(parse("[[connection]]\nfrom = \"a.yr\"\nto = \"b.ur\"\n").is_ok());
        let err = parse("[[connection]]\nfrom = \"a.yi\"\nto = \"b.ui\"\n").unwrap_err();
        assert_eq!(err.line, Some(10), "{err}");
        assert!(
            err.message.contains("only Real variables can be coupled"),
            "{err}"
        );
        let err = parse("[[memory]]\nfrom = \"a.yi\"\nto = \"a.ui\"\n").unwrap_err();
        assert!(
            err.message.contains("only Real variables can be coupled"),
            "{err}"
        );
        let err = parse("[[connection]]\nfrom = \"a.yr\"\nto = \"b.ui\"\n").unwrap_err();
        assert!(err.message.contains("types differ"), "{err}");
    }

    /// A memory channel a.yr → a.ur (10 samples of 0.1 s: Nyquist 5 Hz) with `update` as
    /// the body of its `[memory.update]` table, which starts on line 13.
    fn parse_update(update: &str) -> Result<Scenario, ScenarioError> {
        parse(&format!(
            "[[memory]]\nfrom = \"a.yr\"\nto = \"a.ur\"\n[memory.update]\n{update}"
        ))
    }

    #[test]
    fn memory_update_is_read_with_defaults() {
        let s =
            parse_update("filter = \"butterworth\"\norder = 2\ncutoff = 1.5\nlead = 3\n").unwrap();
        assert_eq!(
            s.memory[0].update,
            Some(UpdateSettings {
                filter: Some(LowPass {
                    order: 2,
                    cutoff_hz: 1.5
                }),
                lead: 3,
                forgetting: 1.0,
                gain: 1.0,
            })
        );
        let s = parse("[[memory]]\nfrom = \"a.yr\"\nto = \"a.ur\"\n").unwrap();
        assert_eq!(s.memory[0].update, None);
    }

    #[test]
    fn bad_memory_updates_name_the_line() {
        let f = "filter = \"butterworth\"\n";
        for (body, line, needle) in [
            (format!("{f}order = 4\ncutoff = 5.0\n"), 15, "Nyquist"),
            (format!("{f}order = 4\ncutoff = 7.5\n"), 15, "Nyquist"),
            (format!("{f}order = 4\ncutoff = nan\n"), 15, "Nyquist"),
            (format!("{f}order = 4\ncutoff = -1.0\n"), 15, "Nyquist"),
            (format!("{f}order = 0\ncutoff = 1.0\n"), 14, "between 1 and"),
            (format!("{f}order = 4\n"), 13, "needs cutoff"),
            (
                format!("{f}order = 2\ncutoff = 1.0\nlead = -1\n"),
                16,
                "negative",
            ),
            (
                format!("{f}order = 2\ncutoff = 1.0\nlead = 10\n"),
                16,
                "less than the 10 samples",
            ),
            ("lead = 2\ngain = nan\n".to_string(), 14, "finite"),
            ("forgetting = inf\n".to_string(), 13, "finite"),
            ("order = 2\n".to_string(), 13, "need filter"),
            ("filter = \"chebyshev\"\n".to_string(), 13, "unknown"),
            ("lag = 3\n".to_string(), 13, "unknown field `lag`"),
        ] {
            let err = parse_update(&body).expect_err(&body);
            assert_eq!(err.line, Some(line), "{body}: {err}");
            assert!(err.message.contains(needle), "{body}: {err}");
            assert!(err.to_string().starts_with("s.toml:"), "{err}");
        }
    }

    /// Every bad entry of one `[memory.update]` is named, in line order, as in the rest of
    /// a scenario file.
    #[test]
    fn every_bad_memory_update_entry_is_named() {
        let body = "filter = \"butterworth\"\norder = 0\ncutoff = 600.0\nlead = -1\nforgetting = nan\ngain = inf\n";
        let err = parse_update(body).expect_err(body);
        let lines: Vec<_> = std::iter::once(&err)
            .chain(&err.more)
            .map(|e| (e.line, e.message.clone()))
            .collect();
        let expected = [
            (14, "memory.update.order = 0 must be between 1 and"),
            (
                15,
                "memory.update.cutoff = 600 Hz must lie strictly between 0 and",
            ),
            (16, "memory.update.lead = -1 must not be negative"),
            (17, "memory.update.forgetting = NaN must be a finite number"),
            (18, "memory.update.gain = inf must be a finite number"),
        ];
        assert_eq!(lines.len(), expected.len(), "{lines:?}");
        for ((line, message), (l, needle)) in lines.iter().zip(expected) {
            assert_eq!(*line, Some(l), "{lines:?}");
            assert!(message.starts_with(needle), "{message}");
        }
    }

    /// A scenario of `trials` trials whose FMU "a" gets `parameters` (TOML lines).
    fn with_parameters(trials: usize, parameters: &str) -> Result<Scenario, ScenarioError> {
        let text = format!(
            "step_size = 0.1\nstop_time = 1.0\ntrials = {trials}\n[[fmu]]\nname = \"a\"\npath = \"a.fmu\"\n[fmu.parameters]\n{parameters}"
        );
        Scenario::parse(&text, Path::new("s.toml"), |_| {
            ModelDescription::parse(MD).map_err(|e| e.to_string())
        })
    }

    /// An unquoted dotted name is a TOML table; the error says to quote it, and quoted it
    /// sets the variable.
    #[test]
    fn an_unquoted_dotted_parameter_name_is_told_to_be_quoted() {
        let err = with_parameters(1, "sigma = 1.0\nmodel.mass = 2.0\n").unwrap_err();
        assert_eq!(err.line, Some(9), "{err}");
        assert!(
            err.to_string().contains(
                "parameter \"model\": M has no variable \"model\"; TOML reads an unquoted dot \
                 as a table: quote the dotted name, \"model.mass\" = …"
            ),
            "{err}"
        );
        // A table under a name no variable starts with gets no such hint.
        let err = with_parameters(1, "other.mass = 2.0\n").unwrap_err();
        assert!(!err.to_string().contains("quote"), "{err}");
        let sc = with_parameters(1, "\"model.mass\" = 2.0\n").unwrap();
        let s = &sc.fmus[0].settings[0];
        assert_eq!((s.name.as_str(), s.value_reference), ("model.mass", 4));
    }

    /// A scalar given a list of one is refused, not read as the list's item.
    #[test]
    fn a_scalar_given_a_list_is_refused() {
        for value in ["[1.0]", "[1.0, 2.0]", "[]"] {
            let err = with_parameters(1, &format!("sigma = {value}\n")).unwrap_err();
            assert_eq!(err.line, Some(8), "{err}");
            assert!(
                err.message.contains(
                    "parameter \"sigma\" is a single value, not an array: write it without brackets"
                ),
                "{value}: {err}"
            );
        }
        assert!(with_parameters(1, "sigma = 1.0\n").is_ok());
    }

    /// A value for an output is refused as such, whatever its size.
    #[test]
    fn an_output_given_a_value_is_named_as_an_output() {
        for value in ["1.0", "[1.0, 2.0]"] {
            let err = with_parameters(1, &format!("yr = {value}\n")).unwrap_err();
            assert!(
                err.message
                    .starts_with("'yr' is an output and computed by the FMU"),
                "{value}: {err}"
            );
        }
    }

    #[test]
    fn per_trial_values_step_once_per_trial() {
        let sc = with_parameters(
            5,
            "seed = { base = 1000, per_trial = 1 }\nsigma = { base = 1e-6, per_trial = 0.5e-6 }\non = true\n",
        )
        .unwrap();
        let get = |name: &str| {
            sc.fmus[0]
                .settings
                .iter()
                .find(|s| s.name == name)
                .unwrap()
                .clone()
        };
        let seeds: Vec<Value> = (0..5).map(|k| get("seed").value_in_trial(k)).collect();
        assert_eq!(seeds, (1000..1005).map(Value::Integer).collect::<Vec<_>>());
        assert_eq!(get("sigma").value_in_trial(0), Value::Real(1e-6));
        assert_eq!(
            get("sigma").value_in_trial(4),
            Value::Real(1e-6 + 4.0 * 0.5e-6)
        );
        // A plain value is the same in every trial.
        assert_eq!(get("on").per_trial, None);
        assert_eq!(get("on").value_in_trial(3), Value::Boolean(true));
    }

    #[test]
    fn bad_per_trial_values_name_the_line_and_the_problem() {
        let cases = [
            ("seed = { base = 1000 }\n", "needs both base and per_trial"),
            (
                "seed = { base = 1, per_trial = 1, step = 2 }\n",
                "unknown key \"step\"",
            ),
            ("seed = { base = 1.5, per_trial = 1 }\n", "must be integers"),
            // 1000 + 9·200 = 2800 exceeds the declared max 2000 in the last trial.
            ("seed = { base = 1000, per_trial = 200 }\n", "in trial 9"),
            (
                "seed = { base = 5, per_trial = -1 }\n",
                "leaves [0, 2000] in trial 9",
            ),
            (
                "sigma = { base = 0.0, per_trial = -1.0 }\n",
                "outside [0, inf]",
            ),
            (
                "sigma = { base = \"x\", per_trial = 1 }\n",
                "must be numbers",
            ),
            (
                "on = { base = 1, per_trial = 1 }\n",
                "Real and Integer variables only",
            ),
        ];
        for (line, expected) in cases {
            let err = with_parameters(10, line).unwrap_err();
            assert_eq!(err.line, Some(8), "{line}: {err}");
            assert!(err.message.contains(expected), "{line}: {err}");
        }
        // The i32 range is checked without overflow, also for huge steps.
        let err = with_parameters(3, "seed = { base = 0, per_trial = 9223372036854775807 }\n")
            .unwrap_err();
        assert!(err.message.contains("in trial 2"), "{err}");
    }

    /// The saved scenario keeps comments and layout, holds the given FMU paths and trial
    /// count (added when absent), and rendering it again changes nothing.
    #[test]
    fn as_run_text_replaces_paths_and_trials_only() {
        let text = "# my study\nstep_size = 0.001 # h\nstop_time = 1.0\n[[fmu]]\nname = \"a\"\n\
                    path = \"../a.fmu\" # relative\n[[fmu]]\nname = \"b\"\npath = 'b.fmu'\n";
        let file = Path::new("s.toml");
        let run = as_run_text(text, file, &["/abs/a.fmu", "C:\\x\\b.fmu"], 5).unwrap();
        assert!(run.starts_with("trials = 5\n# my study\n"), "{run}");
        assert!(run.contains("path = \"/abs/a.fmu\" # relative\n"), "{run}");
        let doc: toml::Table = toml::from_str(&run).unwrap();
        assert_eq!(doc["fmu"][1]["path"].as_str(), Some("C:\\x\\b.fmu"));
        assert_eq!(doc["trials"].as_integer(), Some(5));
        assert!(run.contains("step_size = 0.001 # h\n"), "{run}");
        let again = as_run_text(&run, file, &["/abs/a.fmu", "C:\\x\\b.fmu"], 5).unwrap();
        assert_eq!(again, run);
        // An existing trials key is replaced in place, whatever its value.
        let other = as_run_text(&run, file, &["", ""], 0).unwrap();
        assert_eq!(other, as_run_text(text, file, &["", ""], 0).unwrap());
        assert!(as_run_text(text, file, &["x"], 1).is_err());
    }
}
