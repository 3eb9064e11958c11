//! Simulation of one FMI 2.0 co-simulation FMU on its own, like fmpy's `simulate` or
//! fmi-sim: start values, an optional input table, a fixed communication grid, and the
//! recorded variables. The `simulate` subcommand is a thin front end over [`simulate`].
//!
//! Everything the user supplies (start values, input table, recorded names, time grid) is
//! checked against the model description before the FMU is instantiated, so a typo fails at
//! once with its file, line and column.

use std::io;
use std::path::{Path, PathBuf};

use fmi2_import::Status;
use fmi2_import::{Fmu, ImportError, Instance};
use fmi2_md::Causality;
use fmi2_md::{ModelDescription, ScalarVariable, Shown, VariableKind};

use crate::master::STATUS_CATEGORIES;
use crate::output::{Recording, seconds};
use crate::variables::{
    Literal, Value, VariableKey, causality_phrase, check_value, convert, no_such_variable, resolve,
    set_value, settable, variable_key,
};

/// Stop time when neither the options nor the DefaultExperiment give one.
const DEFAULT_STOP_TIME: f64 = 1.0;
/// Refuse grids longer than this: the recording is kept in memory, and such a count is
/// almost always a mistyped step size.
const MAX_STEPS: usize = 100_000_000;
/// Relative slack (in step sizes) for deciding that a time lies on the grid: `t0 + n·h`
/// is rounded, so a stop time or input row meant to be on the grid may sit a few ulps off.
const GRID_SLACK: f64 = 1e-9;

/// A failed simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// A start value, input file, recorded name or time grid is wrong; the message names
    /// the option, file, line, column or variable.
    #[error("{0}")]
    Invalid(String),
    /// An FMI call failed (`context`: what the call was for, and the time).
    #[error("{context}: {error}")]
    Fmu {
        /// What was being done.
        context: String,
        /// The failed call, with the FMU's messages.
        error: ImportError,
    },
    /// An output was NaN or infinite although the call returned fmi2OK.
    #[error(
        "FMU {instance:?} returned {variable} = {value} at t = {} s from fmi2GetReal with \
         status fmi2OK; a value that is not finite stops the simulation",
        seconds(*time)
    )]
    NotFinite {
        instance: String,
        variable: String,
        time: f64,
        value: f64,
    },
}

impl From<ImportError> for SimulateError {
    fn from(error: ImportError) -> Self {
        SimulateError::Fmu {
            context: "the FMU".into(),
            error,
        }
    }
}

/// Adds what was being done to an FMI call's error.
trait FmuContext<T> {
    fn during(self, context: impl FnOnce() -> String) -> Result<T, SimulateError>;
}

impl<T> FmuContext<T> for Result<T, ImportError> {
    fn during(self, context: impl FnOnce() -> String) -> Result<T, SimulateError> {
        self.map_err(|error| SimulateError::Fmu {
            context: context(),
            error,
        })
    }
}

macro_rules! bail {
    ($($arg:tt)*) => {
        return Err(SimulateError::Invalid(format!($($arg)*)))
    };
}

macro_rules! ensure {
    ($cond:expr, $($arg:tt)*) => {
        let holds: bool = $cond;
        if !holds {
            bail!($($arg)*);
        }
    };
}

type Result<T, E = SimulateError> = std::result::Result<T, E>;

/// What to simulate; every field is optional.
#[derive(Debug, Clone, Default)]
pub struct SimulateOptions {
    /// Input CSV: a `time` column, then input variables (zero-order hold).
    pub input: Option<PathBuf>,
    /// Start time, s (default: the DefaultExperiment's, else 0).
    pub start_time: Option<f64>,
    /// Stop time, s (default: the DefaultExperiment's, else start + 1).
    pub stop_time: Option<f64>,
    /// Communication step, s (default: the DefaultExperiment's, else fmpy's output interval).
    pub step_size: Option<f64>,
    /// Start values, `NAME=VALUE`.
    pub set: Vec<String>,
    /// Recorded variables (default: every non-String output).
    pub record: Vec<String>,
    /// Ask the FMU for debug logging (messages go to stderr).
    pub fmu_logging: bool,
}

/// What a simulation produced.
#[derive(Debug)]
pub struct Simulation {
    /// The numeric columns (String columns hold NaN there).
    pub recording: Recording,
    /// The String columns: (column, one value per row).
    pub text: TextColumns,
    /// Why it ended before the stop time (fmi2Discard), if it did.
    pub ended: Option<String>,
}

/// Simulates `fmu` as `opts` says. An fmi2Discard ends the run normally with every
/// completed row, as fmpy and fmusim do; [`Simulation::ended`] says why.
pub fn simulate(fmu: &Fmu, opts: &SimulateOptions) -> Result<Simulation> {
    let mut plan = Plan::new(opts, fmu.model_description())?;
    let (recording, text, ended) = run_plan(fmu, &mut plan, opts.fmu_logging)?;
    Ok(Simulation {
        recording,
        text,
        ended,
    })
}

/// The arguments of one `simulate` run, validated against the model description.
#[derive(Debug)]
struct Plan {
    /// `--set` values, applied before initialization.
    starts: Vec<Assignment>,
    /// The communication points.
    grid: Grid,
    /// `tolerance` of the DefaultExperiment, passed on to fmi2SetupExperiment.
    tolerance: Option<f64>,
    /// The `--input` table.
    inputs: Option<InputTable>,
    /// What to read after initialization and after each step.
    recorder: Recorder,
}

impl Plan {
    fn new(args: &SimulateOptions, md: &ModelDescription) -> Result<Plan> {
        let mut starts: Vec<Assignment> = Vec::new();
        // Which --set gave each variable: a second one would silently win.
        let mut set_by: Vec<(VariableKey, &str)> = Vec::new();
        // Every bad --set, one per line, as a scenario file lists all its problems.
        let mut problems: Vec<String> = Vec::new();
        for text in &args.set {
            let new = match parse_assignment(md, text) {
                Ok(new) => new,
                Err(e) => {
                    problems.push(format!("--set {text}: {e}"));
                    continue;
                }
            };
            for a in &new {
                let key = variable_key(a.vr, &a.value);
                match set_by.iter().find(|(k, _)| *k == key) {
                    Some((_, first)) => problems.push(format!(
                        "--set {text}: {} is already set by --set {first}; give each value once",
                        a.name
                    )),
                    None => set_by.push((key, text)),
                }
            }
            starts.extend(new);
        }
        if !problems.is_empty() {
            return Err(SimulateError::Invalid(problems.join("\n")));
        }
        let experiment = md.default_experiment.clone().unwrap_or_default();
        let start = args.start_time.or(experiment.start_time).unwrap_or(0.0);
        let stop = args
            .stop_time
            .or(experiment.stop_time)
            .unwrap_or(start + DEFAULT_STOP_TIME);
        let step = args
            .step_size
            .or(experiment.step_size)
            .unwrap_or_else(|| auto_interval(stop - start));
        let can_vary = md
            .co_simulation
            .as_ref()
            .is_some_and(|cs| cs.can_handle_variable_communication_step_size);
        let grid = Grid::new(start, stop, step, can_vary)?;
        let inputs = args
            .input
            .as_deref()
            .map(|path| InputTable::read(path, md))
            .transpose()?;
        let recorder = Recorder::new(md, &args.record)?;
        Ok(Plan {
            starts,
            grid,
            tolerance: experiment.tolerance,
            inputs,
            recorder,
        })
    }
}

/// One start value from `--set`.
#[derive(Debug, Clone, PartialEq)]
struct Assignment {
    name: String,
    vr: u32,
    value: Value,
}

/// `NAME=VALUE` → one assignment per variable `NAME` denotes (all elements of an array).
fn parse_assignment(md: &ModelDescription, text: &str) -> Result<Vec<Assignment>> {
    let Some((name, value)) = text.split_once('=') else {
        bail!("expected NAME=VALUE");
    };
    let name = name.trim();
    let vars = resolve(md, name);
    if vars.is_empty() {
        bail!("{}", no_such_variable(md, name));
    }
    vars.into_iter()
        .map(|var| {
            settable(var).map_err(SimulateError::Invalid)?;
            let value = convert(md, var, Literal::Text(value)).map_err(SimulateError::Invalid)?;
            check_value(md, var, &value).map_err(SimulateError::Invalid)?;
            Ok(Assignment {
                name: var.name.clone(),
                vr: var.value_reference,
                value,
            })
        })
        .collect()
}

/// fmpy's default output interval (`fmpy.util.auto_interval`, fmpy 0.3.32), used when
/// neither `--step-size` nor the model gives a step: 10^(round(log10 span) − 3), scaled
/// so that the span holds between 500 and 1000 steps (a 1 s span gives 2 ms).
fn auto_interval(span: f64) -> f64 {
    // numpy rounds halves to even.
    let h = 10f64.powf(span.log10().round_ties_even() - 3.0);
    // The rounding keeps span / 10^round(log10 span) within [10^−0.5, 10^0.5], so n lies in
    // [316, 3163]: fmpy's two arms for n ≤ 200 and n ≤ 250 (÷5, ÷4) cannot be reached and
    // are left out.
    let n = span / h;
    if n >= 2500.0 {
        h * 5.0
    } else if n >= 2000.0 {
        h * 4.0
    } else if n >= 1000.0 {
        h * 2.0
    } else if n <= 500.0 {
        h / 2.0
    } else {
        h
    }
}

/// The communication points t_n = t0 + n·h (computed, never accumulated), plus a shorter
/// last step to the stop time when the span is not a whole number of steps.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Grid {
    start: f64,
    stop: f64,
    step: f64,
    /// Number of full steps of `step`.
    full_steps: usize,
    /// Whether a shorter step from `t_full_steps` to `stop` follows.
    partial: bool,
}

impl Grid {
    fn new(start: f64, stop: f64, step: f64, can_vary_step: bool) -> Result<Grid> {
        let (start_s, stop_s, step_s) = (Shown(start), Shown(stop), Shown(step));
        ensure!(start.is_finite(), "start time {start_s} must be finite");
        ensure!(stop.is_finite(), "stop time {stop_s} must be finite");
        ensure!(
            stop > start,
            "stop time {stop_s} s must be after the start time {start_s} s"
        );
        ensure!(step.is_finite(), "step size {step_s} must be finite");
        ensure!(step > 0.0, "step size {step_s} s must be positive");
        let ratio = (stop - start) / step;
        ensure!(
            ratio <= MAX_STEPS as f64,
            "{ratio:.3e} steps of {step_s} s from {start_s} s to {stop_s} s are more than {MAX_STEPS}; use a larger --step-size"
        );
        if let Some(why) = crate::scenario::unresolved_step(start, stop, step) {
            bail!("{why}");
        }
        let rounded = ratio.round();
        let (full_steps, partial) = if (ratio - rounded).abs() <= GRID_SLACK * rounded.max(1.0) {
            (rounded as usize, false)
        } else {
            (ratio.floor() as usize, true)
        };
        // A step beyond the span would leave only the initial row, or one shortened step.
        ensure!(
            full_steps >= 1,
            "step size {step} s is longer than the span from {start} s to {stop} s; \
             it must hold at least one step: use a smaller --step-size"
        );
        ensure!(
            !partial || can_vary_step,
            "stop − start = {} s is not a whole number of steps of {step} s, and the FMU cannot \
             vary its communication step size; choose --stop-time or --step-size to fit",
            stop - start
        );
        Ok(Grid {
            start,
            stop,
            step,
            full_steps,
            partial,
        })
    }

    /// Number of doStep calls.
    fn steps(&self) -> usize {
        self.full_steps + usize::from(self.partial)
    }

    /// t_n for n in 0..=steps().
    fn time(&self, n: usize) -> f64 {
        if n > self.full_steps {
            self.stop
        } else {
            self.start + n as f64 * self.step
        }
    }

    /// The step size of the step from t_n. Full steps all pass the same `h`, so FMUs that
    /// need a fixed step size see exactly one value.
    fn step_from(&self, n: usize) -> f64 {
        if n < self.full_steps {
            self.step
        } else {
            self.stop - self.time(n)
        }
    }
}

/// One column of the input table: the input variable it drives.
#[derive(Debug, Clone)]
struct InputColumn {
    name: String,
    vr: u32,
}

/// Longest line an `--input` CSV may have: a time and far more inputs than any FMU has.
const MAX_INPUT_LINE: usize = 1 << 20;

/// A reader that fails once a line passes [`MAX_INPUT_LINE`] bytes. The `csv` crate holds a
/// record in memory until its line ends, and has no limit of its own, so a path to an endless
/// source without newlines (`/dev/zero`) would be read until memory ran out; any length of
/// file with lines of a sane length still reads.
struct ShortLines<R> {
    inner: R,
    /// Bytes since the last newline.
    line: usize,
}

impl<R> ShortLines<R> {
    fn new(inner: R) -> Self {
        ShortLines { inner, line: 0 }
    }
}

impl<R: io::Read> io::Read for ShortLines<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.line = match buf[..n].iter().rposition(|&b| b == b'\n') {
            Some(last) => n - last - 1,
            None => self.line + n,
        };
        if self.line > MAX_INPUT_LINE {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "a line longer than {} MiB, which no input table has (is it a device or a \
                     binary file?)",
                    MAX_INPUT_LINE >> 20
                ),
            ));
        }
        Ok(n)
    }
}

/// The `--input` CSV: rows of (time, one value per column), times non-decreasing.
#[derive(Debug)]
struct InputTable {
    columns: Vec<InputColumn>,
    times: Vec<f64>,
    rows: Vec<Vec<Value>>,
    /// Row last applied, so unchanged inputs are not set again.
    applied: Option<usize>,
}

impl InputTable {
    /// Reads and checks the whole table; errors name the file, the line and the column.
    fn read(path: &Path, md: &ModelDescription) -> Result<InputTable> {
        // Linux opens a folder and fails only on the read, as if the header were at fault.
        if path.is_dir() {
            return Err(SimulateError::Invalid(format!(
                "cannot read the input file {}: it is a folder, not a CSV file",
                path.display()
            )));
        }
        let file = std::fs::File::open(path).map_err(|e| {
            SimulateError::Invalid(format!(
                "cannot read the input file {}: {e}",
                path.display()
            ))
        })?;
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(io::BufReader::new(ShortLines::new(file)));
        let at = |line: u64, column: usize| format!("{}:{line}: column {column}", path.display());
        let header = reader
            .headers()
            .map_err(|e| {
                SimulateError::Invalid(format!("{}:1: cannot read the header: {e}", path.display()))
            })?
            .clone();
        match header.get(0) {
            Some("time") => {}
            // Spreadsheets set to a decimal comma export `;` or tab between fields.
            Some(other) => match [';', '\t']
                .into_iter()
                .find(|&c| other.starts_with(&format!("time{c}")))
            {
                Some(c) => bail!(
                    "{}: must be `time`, found '{}': the fields are separated by {:?}, and the \
                     input file needs commas (and `.` as the decimal point)",
                    at(1, 1),
                    other.escape_debug(),
                    c
                ),
                None => bail!("{}: must be `time`, found '{other}'", at(1, 1)),
            },
            None => bail!(
                "{}:1: empty file, expected a header `time,<inputs>`",
                path.display()
            ),
        }
        let mut columns = Vec::new();
        let mut vars = Vec::new();
        for (i, name) in header.iter().enumerate().skip(1) {
            let Some(var) = md.variable_by_name(name) else {
                bail!(
                    "{} '{name}': model '{}' has no variable of that name",
                    at(1, i + 1),
                    md.model_name
                );
            };
            if var.causality != Causality::Input {
                bail!(
                    "{} '{name}' is {}, not an input; only inputs can be driven from a file",
                    at(1, i + 1),
                    causality_phrase(var.causality)
                );
            }
            if columns.iter().any(|c: &InputColumn| c.name == name) {
                bail!("{} '{name}' appears twice", at(1, i + 1));
            }
            columns.push(InputColumn {
                name: name.to_owned(),
                vr: var.value_reference,
            });
            vars.push(var);
        }
        let mut times = Vec::new();
        let mut rows = Vec::new();
        let mut record = csv::StringRecord::new();
        loop {
            match reader.read_record(&mut record) {
                Ok(true) => {}
                Ok(false) => break,
                Err(e) => {
                    let line = e.position().map_or(0, csv::Position::line);
                    if let csv::ErrorKind::UnequalLengths {
                        expected_len, len, ..
                    } = e.kind()
                    {
                        bail!(
                            "{}:{line}: {len} field(s), expected {expected_len} as in the header",
                            path.display()
                        );
                    }
                    bail!("{}:{line}: {e}", path.display());
                }
            }
            let line = record.position().map_or(0, csv::Position::line);
            let cell = record.get(0).unwrap_or_default();
            let t = cell
                .parse::<f64>()
                .ok()
                .filter(|t| t.is_finite())
                .ok_or_else(|| {
                    SimulateError::Invalid(format!(
                        "{} (time): '{cell}' is not a finite number",
                        at(line, 1)
                    ))
                })?;
            if let Some(&last) = times.last() {
                ensure!(
                    t >= last,
                    "{} (time): {t} is before the previous row's {last}; times must not decrease",
                    at(line, 1)
                );
            }
            let values = vars
                .iter()
                .enumerate()
                .map(|(i, var)| {
                    let cell = record.get(i + 1).unwrap_or_default();
                    match convert(md, var, Literal::Text(cell))
                        .and_then(|v| check_value(md, var, &v).map(|()| v))
                    {
                        Ok(v) => Ok(v),
                        Err(message) => bail!("{} ('{}'): {message}", at(line, i + 2), var.name),
                    }
                })
                .collect::<Result<Vec<_>>>()?;
            times.push(t);
            rows.push(values);
        }
        ensure!(
            !times.is_empty(),
            "{}: no data rows after the header",
            path.display()
        );
        Ok(InputTable {
            columns,
            times,
            rows,
            applied: None,
        })
    }

    /// The last row with time ≤ t (a row a few ulps after a grid point counts as on it).
    fn row_at(&self, t: f64, slack: f64) -> Option<usize> {
        self.times
            .partition_point(|&row_time| row_time <= t + slack)
            .checked_sub(1)
    }

    /// Sets the inputs held at `t` (zero-order hold), unless they are already set. Before
    /// the first row the FMU keeps its start values.
    fn apply(&mut self, inst: &mut Instance, t: f64, slack: f64) -> Result<Status, ImportError> {
        let Some(row) = self.row_at(t, slack) else {
            return Ok(Status::Ok);
        };
        if self.applied == Some(row) {
            return Ok(Status::Ok);
        }
        let mut worst = Status::Ok;
        for (column, value) in self.columns.iter().zip(&self.rows[row]) {
            worst = worst.max(set_value(inst, column.vr, value)?);
        }
        self.applied = Some(row);
        Ok(worst)
    }
}

/// Reads the recorded variables, grouped by base type so each sample is three FMI calls.
#[derive(Debug)]
struct Recorder {
    names: Vec<String>,
    reals: Group<f64>,
    integers: Group<i32>,
    booleans: Group<bool>,
    /// String variables: value references, their columns, and every sample's values.
    strings: Vec<(u32, usize, Vec<String>)>,
}

/// Value references of one base type, the recording columns they fill, and a buffer.
#[derive(Debug, Default)]
struct Group<T> {
    vrs: Vec<u32>,
    columns: Vec<usize>,
    buffer: Vec<T>,
}

impl<T: Default + Clone> Group<T> {
    fn push(&mut self, vr: u32, column: usize) {
        self.vrs.push(vr);
        self.columns.push(column);
        self.buffer.push(T::default());
    }
}

impl Recorder {
    /// `--record` names (arrays expanded), or every output when none are given (String
    /// outputs only when named, as fmpy does).
    fn new(md: &ModelDescription, names: &[String]) -> Result<Recorder> {
        let vars: Vec<&ScalarVariable> = if names.is_empty() {
            md.model_variables
                .iter()
                .filter(|v| {
                    v.causality == Causality::Output
                        && !matches!(v.kind, VariableKind::String { .. })
                })
                .collect()
        } else {
            let mut vars: Vec<&ScalarVariable> = Vec::new();
            for name in names {
                let found = resolve(md, name);
                if found.is_empty() {
                    bail!("--record {name}: {}", no_such_variable(md, name));
                }
                // Two columns of one name would leave the CSV ambiguous, as in a scenario.
                if let Some(twice) = found.iter().find(|v| vars.iter().any(|w| w.name == v.name)) {
                    bail!("--record {name}: {} is recorded twice", twice.name);
                }
                vars.extend(found);
            }
            vars
        };
        let mut recorder = Recorder {
            names: Vec::with_capacity(vars.len()),
            reals: Group::default(),
            integers: Group::default(),
            booleans: Group::default(),
            strings: Vec::new(),
        };
        for (column, var) in vars.into_iter().enumerate() {
            let vr = var.value_reference;
            match var.kind {
                VariableKind::Real { .. } => recorder.reals.push(vr, column),
                VariableKind::Integer { .. } | VariableKind::Enumeration { .. } => {
                    recorder.integers.push(vr, column);
                }
                VariableKind::Boolean { .. } => recorder.booleans.push(vr, column),
                VariableKind::String { .. } => recorder.strings.push((vr, column, Vec::new())),
            }
            recorder.names.push(var.name.clone());
        }
        Ok(recorder)
    }

    /// The String columns recorded so far, as (column, values).
    fn take_text(&mut self) -> TextColumns {
        self.strings
            .iter_mut()
            .map(|(_, column, values)| (*column, std::mem::take(values)))
            .collect()
    }

    /// Refuses a Real output in `row` that is NaN or infinite: it would go silently into
    /// the result.
    fn check_finite(&self, row: &[f64], instance: &str, time: f64) -> Result<()> {
        match self.reals.columns.iter().find(|&&c| !row[c].is_finite()) {
            None => Ok(()),
            Some(&c) => Err(SimulateError::NotFinite {
                instance: instance.to_owned(),
                variable: self.names[c].clone(),
                time,
                value: row[c],
            }),
        }
    }

    /// Reads every recorded variable into `row` (Booleans as 0/1; Strings into their own
    /// columns, leaving NaN in `row`).
    fn sample(&mut self, inst: &mut Instance, row: &mut [f64]) -> Result<(), ImportError> {
        for (vr, column, values) in &mut self.strings {
            let mut text = inst.get_string(&[*vr])?;
            values.push(text.pop().unwrap_or_default());
            row[*column] = f64::NAN;
        }
        if !self.reals.vrs.is_empty() {
            inst.get_real(&self.reals.vrs, &mut self.reals.buffer)?;
            for (&c, &x) in self.reals.columns.iter().zip(&self.reals.buffer) {
                row[c] = x;
            }
        }
        if !self.integers.vrs.is_empty() {
            inst.get_integer(&self.integers.vrs, &mut self.integers.buffer)?;
            for (&c, &n) in self.integers.columns.iter().zip(&self.integers.buffer) {
                row[c] = f64::from(n);
            }
        }
        if !self.booleans.vrs.is_empty() {
            inst.get_boolean(&self.booleans.vrs, &mut self.booleans.buffer)?;
            for (&c, &b) in self.booleans.columns.iter().zip(&self.booleans.buffer) {
                row[c] = if b { 1.0 } else { 0.0 };
            }
        }
        Ok(())
    }
}

/// Prints what the FMU logged: everything with `--fmu-logging`, otherwise only when a call
/// returned a warning, whose explanation would else be lost.
fn report_log(inst: &Instance, status: Status, verbose: bool) {
    if verbose || status >= Status::Warning {
        for record in inst.take_log() {
            crate::console!("{}: {record}", inst.name());
        }
    }
}

/// String columns of a recording: (column, one value per row).
pub type TextColumns = Vec<(usize, Vec<String>)>;

/// Instantiates, initializes and steps the FMU over the grid, returning the recording, its
/// String columns, and why it ended early (fmi2Discard, with or without a request to
/// terminate), if it did.
fn run_plan(
    fmu: &Fmu,
    plan: &mut Plan,
    verbose: bool,
) -> Result<(Recording, TextColumns, Option<String>)> {
    let md = fmu.model_description();
    let mut inst = fmu
        .instantiate(&md.model_name, verbose)
        .during(|| "fmi2Instantiate".to_owned())?;
    if verbose {
        let status = inst.set_debug_logging(true, &[])?;
        report_log(&inst, status, verbose);
    } else {
        // Still hear why a call fails or is discarded: the status categories the FMU
        // declares log only when something goes wrong.
        let categories: Vec<&str> = md
            .log_categories
            .iter()
            .map(|c| c.name.as_str())
            .filter(|n| STATUS_CATEGORIES.contains(n))
            .collect();
        if !categories.is_empty() {
            inst.set_debug_logging(true, &categories)?;
        }
    }
    for a in &plan.starts {
        let status = set_value(&mut inst, a.vr, &a.value)
            .during(|| format!("setting the start value of '{}'", a.name))?;
        report_log(&inst, status, verbose);
    }

    let grid = plan.grid;
    let slack = GRID_SLACK * grid.step;
    let status = inst.setup_experiment(plan.tolerance, grid.start, Some(grid.stop))?;
    report_log(&inst, status, verbose);
    let status = inst.enter_initialization_mode()?;
    report_log(&inst, status, verbose);
    if let Some(inputs) = &mut plan.inputs {
        let status = inputs
            .apply(&mut inst, grid.start, slack)
            .during(|| format!("setting the inputs at t = {} s", grid.start))?;
        report_log(&inst, status, verbose);
    }
    let status = inst.exit_initialization_mode()?;
    report_log(&inst, status, verbose);

    let mut recording = Recording::with_capacity(plan.recorder.names.clone(), grid.steps() + 1);
    let mut row = vec![0.0; recording.names.len()];
    plan.recorder
        .sample(&mut inst, &mut row)
        .during(|| format!("reading the outputs at t = {} s", grid.start))?;
    plan.recorder
        .check_finite(&row, &md.model_name, grid.start)?;
    recording.push_row(grid.start, &row);

    for n in 0..grid.steps() {
        let t = grid.time(n);
        let h = grid.step_from(n);
        if let Some(inputs) = &mut plan.inputs {
            let status = inputs
                .apply(&mut inst, t, slack)
                .during(|| format!("setting the inputs at t = {} s", seconds(t)))?;
            report_log(&inst, status, verbose);
        }
        let status = match inst.do_step(t, h, true) {
            Ok(status) => status,
            // The FMU cannot (or will not) go on: like fmpy and fmusim, keep every completed
            // row and end normally rather than lose the result.
            Err(ImportError::Call {
                status: Status::Discard,
                messages,
                ..
            }) => {
                let terminated = inst.is_terminated().unwrap_or(false);
                let last = inst.last_successful_time().ok().filter(|x| x.is_finite());
                // A partly completed step: its outputs hold at the last successful time.
                if let Some(last) = last.filter(|&x| x > t + slack && x < t + h) {
                    if plan.recorder.sample(&mut inst, &mut row).is_ok() {
                        recording.push_row(last, &row);
                    }
                }
                let _ = inst.terminate();
                let why: Vec<String> = messages.iter().map(ToString::to_string).collect();
                let notice = format!(
                    "fmi2DoStep from t = {} s by {h} s returned fmi2Discard{}{}",
                    seconds(t),
                    if terminated {
                        " and the FMU asks to terminate"
                    } else {
                        ""
                    },
                    if why.is_empty() {
                        String::new()
                    } else {
                        format!(" ({})", why.join("; "))
                    }
                );
                let text = plan.recorder.take_text();
                return Ok((recording, text, Some(notice)));
            }
            Err(e) => return Err(e).during(|| format!("step from t = {} s by {h} s", seconds(t))),
        };
        report_log(&inst, status, verbose);
        let t_next = grid.time(n + 1);
        plan.recorder
            .sample(&mut inst, &mut row)
            .during(|| format!("reading the outputs at t = {t_next} s"))?;
        plan.recorder.check_finite(&row, &md.model_name, t_next)?;
        recording.push_row(t_next, &row);
    }
    let status = inst.terminate()?;
    report_log(&inst, status, verbose);
    let text = plan.recorder.take_text();
    Ok((recording, text, None))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Any length of file with short lines reads whole, however the reads split it; a line
    /// just over the limit fails, one at the limit does not.
    #[test]
    fn short_lines_bounds_lines_not_files() {
        use std::io::Read;
        let read = |bytes: Vec<u8>| {
            let mut out = Vec::new();
            ShortLines::new(io::Cursor::new(bytes))
                .read_to_end(&mut out)
                .map(|_| out.len())
        };
        let rows = "0.001,1.5,2.5\n".repeat(300_000).into_bytes();
        assert_eq!(read(rows.clone()).unwrap(), rows.len());
        let mut at_limit = vec![b'1'; MAX_INPUT_LINE];
        at_limit.push(b'\n');
        at_limit.extend_from_slice(&rows);
        assert!(read(at_limit).is_ok());
        let mut over = rows;
        over.extend(std::iter::repeat_n(b'1', MAX_INPUT_LINE + 1));
        let err = read(over).unwrap_err();
        assert!(
            err.to_string().contains("a line longer than 1 MiB"),
            "{err}"
        );
    }

    /// A line's length counts from its newline, wherever a read ends: reads of 4096 bytes,
    /// the first holding a newline at byte 3000, then a last line (no newline ends it) of
    /// exactly the limit (read whole) or one byte more (refused).
    #[test]
    fn short_lines_count_from_a_newline_inside_a_read() {
        use std::io::Read;
        struct Chunks(io::Cursor<Vec<u8>>);
        impl io::Read for Chunks {
            fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
                let n = buf.len().min(4096);
                self.0.read(&mut buf[..n])
            }
        }
        let read = |line: usize| {
            let mut bytes = vec![b'1'; 3000];
            bytes.push(b'\n');
            bytes.extend(std::iter::repeat_n(b'2', line));
            let mut out = Vec::new();
            ShortLines::new(Chunks(io::Cursor::new(bytes)))
                .read_to_end(&mut out)
                .map(|_| out.len())
        };
        assert_eq!(read(MAX_INPUT_LINE).unwrap(), 3001 + MAX_INPUT_LINE);
        assert!(read(MAX_INPUT_LINE + 1).is_err());
    }

    #[test]
    fn grid_is_computed_not_accumulated() {
        let g = Grid::new(0.0, 1.0, 0.1, false).unwrap();
        assert_eq!(g.steps(), 10);
        assert_eq!(g.time(3), 3.0 * 0.1);
        assert_eq!(g.step_from(9), 0.1);
        // Accumulating 0.1 ten times gives 0.9999999999999999; the grid gives 1.0.
        assert_eq!(g.time(10), 1.0);
    }

    #[test]
    fn grid_with_remainder_needs_variable_steps() {
        let g = Grid::new(0.0, 1.05, 0.1, true).unwrap();
        assert_eq!(g.steps(), 11);
        assert_eq!(g.time(11), 1.05);
        assert!((g.step_from(10) - 0.05).abs() < 1e-12);
        let err = Grid::new(0.0, 1.05, 0.1, false).unwrap_err().to_string();
        assert!(err.contains("not a whole number of steps"), "{err}");
    }

    #[test]
    fn auto_interval_follows_fmpy() {
        // fmpy 0.3.32 util.auto_interval: h = 10^(round(log10 span) − 3), then scaled so the
        // span holds 500 to 1000 steps. The same eight values come out of fmpy itself.
        assert_eq!(auto_interval(1.0), 0.002); // 1000 steps of 1 ms → ×2
        assert_eq!(auto_interval(2.0), 0.004); // 2000 → ×4
        assert_eq!(auto_interval(10.0), 0.02); // 1000 of 10 ms → ×2
        assert_eq!(auto_interval(0.3), 0.0005); // h = 1e-4 (log10 0.3 → −1), 3000 → ×5
        assert_eq!(auto_interval(5.0), 0.005); // h = 0.01 (log10 5 → 1), 500 → ÷2
        assert_eq!(auto_interval(2.5), 0.005); // 2500 → ×5
        assert_eq!(auto_interval(0.7), 0.001); // h = 1e-3 (log10 0.7 → 0), 700 kept
        assert_eq!(auto_interval(0.4), 0.0005); // h = 1e-3, 400 → ÷2
        // Every span from 1 µs to 1e6 s, eight per decade (so the half-way points, where the
        // rounding turns, among them), holds 500 to 1000 steps of a power of ten times 5, 4,
        // 2, 1 or 1/2.
        for k in -48..=48 {
            let span = 10f64.powf(f64::from(k) / 8.0);
            let step = auto_interval(span);
            let n = span / step;
            assert!(
                (500.0 - 1e-9..=1000.0 + 1e-9).contains(&n),
                "{span}: {n} steps"
            );
            let mantissa = step / 10f64.powf(step.log10().floor());
            assert!(
                [1.0, 2.0, 4.0, 5.0]
                    .iter()
                    .any(|m| (mantissa - m).abs() < 1e-9),
                "{span}: step {step}"
            );
        }
    }

    #[test]
    fn grid_rejects_bad_times() {
        for (start, stop, step) in [(0.0, 0.0, 0.1), (1.0, 0.5, 0.1), (0.0, 1.0, 0.0)] {
            assert!(Grid::new(start, stop, step, true).is_err());
        }
        for (start, stop, step, says) in [
            (0.0, f64::INFINITY, 0.1, "stop time inf must be finite"),
            (0.0, 1.0, f64::NAN, "step size NaN must be finite"),
            (0.0, 1.0, f64::INFINITY, "step size inf must be finite"),
        ] {
            let err = Grid::new(start, stop, step, true).unwrap_err().to_string();
            assert_eq!(err, says);
        }
        let err = Grid::new(0.0, 1e3, 1e-9, true).unwrap_err().to_string();
        assert!(err.contains("--step-size"), "{err}");
        // Doubles near 1e17 are 16 s apart: steps of 1 s would repeat one time.
        let err = Grid::new(1e17, 1e17 + 32.0, 1.0, true)
            .unwrap_err()
            .to_string();
        assert!(err.contains("cannot advance time"), "{err}");
        for step in [1e6, 1.5] {
            let err = Grid::new(0.0, 1.0, step, true).unwrap_err().to_string();
            assert!(err.contains("at least one step"), "{err}");
        }
    }

    #[test]
    fn input_rows_hold_from_their_time_and_the_last_equal_time_wins() {
        let table = InputTable {
            columns: Vec::new(),
            times: vec![0.5, 1.0, 1.0, 2.0],
            rows: vec![Vec::new(); 4],
            applied: None,
        };
        let slack = 1e-12;
        assert_eq!(table.row_at(0.4, slack), None);
        assert_eq!(table.row_at(0.5, slack), Some(0));
        assert_eq!(table.row_at(0.999, slack), Some(0));
        assert_eq!(table.row_at(1.0, slack), Some(2));
        // A grid time rounded a few ulps below a row's time still reaches that row.
        assert_eq!(table.row_at(1.0 - 1e-15, slack), Some(2));
        assert_eq!(table.row_at(5.0, slack), Some(3));
    }

    fn foreign_md() -> ModelDescription {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/fixtures/foreign-fmu/modelDescription.xml");
        ModelDescription::parse(&std::fs::read_to_string(path).unwrap()).unwrap()
    }

    /// A model with a String input, which no FMU of the workspace has.
    fn string_md() -> ModelDescription {
        let xml = foreign_md_xml().replace(
            "<!-- 1 -->",
            r#"<ScalarVariable name="label" valueReference="9" causality="input" variability="discrete"><String start=""/></ScalarVariable>
    <!-- 1 -->"#,
        );
        ModelDescription::parse(&xml).unwrap()
    }

    fn foreign_md_xml() -> String {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../tests/fixtures/foreign-fmu/modelDescription.xml");
        std::fs::read_to_string(path).unwrap()
    }

    /// Recorded variables fall into one group per base type, each with its columns; the
    /// String column's values are handed over once, with their column.
    #[test]
    fn the_recorder_groups_by_type_and_hands_over_text_once() {
        let md = string_md();
        let names = ["x", "label", "steps", "moving_up", "v"].map(String::from);
        let mut recorder = Recorder::new(&md, &names).unwrap();
        assert_eq!(recorder.names, names);
        assert_eq!(recorder.reals.columns, [0, 4]);
        assert_eq!(recorder.reals.vrs, [1, 2]);
        assert_eq!(recorder.integers.columns, [2]);
        assert_eq!(recorder.booleans.columns, [3]);
        recorder.strings[0].2 = vec!["a".into(), "b".into()];
        assert_eq!(recorder.strings[0].1, 1);
        assert_eq!(
            recorder.take_text(),
            vec![(1, vec!["a".to_owned(), "b".to_owned()])]
        );
        assert_eq!(recorder.take_text(), vec![(1, Vec::<String>::new())]);
        // Without --record: every output (the String input is none), in the file's order.
        let all = Recorder::new(&md, &[]).unwrap();
        assert_eq!(all.names, ["x", "v", "steps", "moving_up"]);
    }

    #[test]
    fn string_inputs_are_read_from_the_file() {
        let md = string_md();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("in.csv");
        std::fs::write(&path, "time,label,drive\n0,\"a, b\",1\n1,c,2\n").unwrap();
        let table = InputTable::read(&path, &md).unwrap();
        assert_eq!(table.rows[0][0], Value::String("a, b".into()));
        assert_eq!(table.rows[1][0], Value::String("c".into()));
        assert_eq!(table.rows[1][1], Value::Real(2.0));
    }

    #[test]
    fn input_values_outside_the_declared_range_name_line_and_column() {
        let md = foreign_md();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("in.csv");
        // `drive` has no range, but it must be finite.
        std::fs::write(&path, "time,drive\n0,1\n1,nan\n").unwrap();
        let err = InputTable::read(&path, &md).unwrap_err().to_string();
        assert!(err.contains("in.csv:3: column 2 ('drive')"), "{err}");
        assert!(err.contains("not a finite number"), "{err}");
    }

    /// Fuzzing the input-CSV reader: the files of `tests/corpus/input_csv/` (the kept
    /// corpus), mutated at random, are read into a consistent table or refused with the
    /// file and a line, never a panic. 1000 cases; a failure is stored by proptest under
    /// `proptest-regressions/` and replayed first.
    mod fuzz_input_csv {
        use super::*;
        use proptest::prelude::*;

        const TOKENS: &[&str] = &[
            "nan", "inf", "-inf", "1e309", "-0", ",", "\"", "\n", "\r\n", "time", "drive", "x",
            "label", " ", "\u{0}", "0.5", "-1", "1e-320",
        ];

        fn corpus() -> Vec<Vec<u8>> {
            let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/input_csv");
            let mut files: Vec<_> = std::fs::read_dir(dir)
                .unwrap()
                .map(|e| e.unwrap().path())
                .collect();
            files.sort();
            files.iter().map(|p| std::fs::read(p).unwrap()).collect()
        }

        #[test]
        fn the_corpus_is_valid() {
            let md = string_md();
            let dir = tempfile::tempdir().unwrap();
            for (i, bytes) in corpus().iter().enumerate() {
                let path = dir.path().join(format!("{i}.csv"));
                std::fs::write(&path, bytes).unwrap();
                InputTable::read(&path, &md).unwrap();
            }
        }

        proptest! {
            #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

            #[test]
            fn mutated_inputs_are_consistent_or_refused_with_the_line(
                pick in any::<usize>(),
                edits in prop::collection::vec(
                    (any::<usize>(), 0..TOKENS.len(), any::<bool>()), 1..6),
            ) {
                let md = string_md();
                let corpus = corpus();
                let mut bytes = corpus[pick % corpus.len()].clone();
                for &(at, token, delete) in &edits {
                    let at = at % (bytes.len() + 1);
                    if delete && at < bytes.len() {
                        bytes.remove(at);
                    } else {
                        bytes.splice(at..at, TOKENS[token].bytes());
                    }
                }
                let dir = tempfile::tempdir().unwrap();
                let path = dir.path().join("in.csv");
                std::fs::write(&path, &bytes).unwrap();
                match InputTable::read(&path, &md) {
                    Ok(t) => {
                        prop_assert!(!t.times.is_empty());
                        prop_assert_eq!(t.times.len(), t.rows.len());
                        prop_assert!(t.times.iter().all(|t| t.is_finite()));
                        prop_assert!(t.times.windows(2).all(|w| w[0] <= w[1]));
                        for row in &t.rows {
                            prop_assert_eq!(row.len(), t.columns.len());
                            for v in row {
                                if let Value::Real(x) = v {
                                    prop_assert!(x.is_finite());
                                }
                            }
                        }
                    }
                    Err(e) => {
                        let text = format!("{e:#}");
                        let prefix = format!("{}:", path.display());
                        prop_assert!(
                            text.starts_with(&prefix) || text.starts_with("cannot read"),
                            "{}", text
                        );
                    }
                }
            }
        }
    }
}
