//! Command-line arguments (clap derive), validated once in each subcommand module.

use std::path::{Path, PathBuf};

use clap::{Args, Parser, Subcommand};
use orchestrator::scenario::RecordFormat;

/// FMI 2.0 co-simulation master for learning-control studies.
#[derive(Debug, Parser)]
#[command(name = "orchestrator", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run every trial of a scenario file (FMUs, connections, iteration memory, recording).
    Run(RunArgs),
    /// Simulate one FMI 2.0 co-simulation FMU alone, with optional inputs from a CSV file.
    Simulate(SimulateArgs),
    /// Show an FMU's model description: capabilities, default experiment and variables.
    Info(InfoArgs),
    /// Reproduce the paper's simulation study: line and circle, PID / PD-type ILC / HLCS.
    Paper(PaperArgs),
    /// Predict whether learning converges for a scenario, per leg-space mode and frequency,
    /// and the largest safe Q-filter cutoff for its lead (docs/convergence.md).
    Analyze(AnalyzeArgs),
    /// Run a parameter study or Monte Carlo sweep: one campaign per case of a sweep file.
    Sweep(SweepArgs),
}

/// `run`. A negative number after an option is its value, refused with the option's name.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct RunArgs {
    /// The scenario file (TOML).
    pub scenario: PathBuf,
    /// Output directory (default: results/<scenario file stem>).
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Continue an interrupted campaign from its last completed trial.
    #[arg(long)]
    pub resume: bool,
    /// Override the scenario's number of trials.
    #[arg(long)]
    pub trials: Option<usize>,
    /// File format of the recorded trials, overriding the scenario's `[record] format`:
    /// csv (trials/trial_NNN.csv) or parquet (trials/trial_NNN.parquet, binary doubles).
    #[arg(long, value_enum, value_name = "FORMAT")]
    pub record_format: Option<RecordFormat>,
    /// Ask the FMUs for debug logging (messages go to stderr).
    #[arg(long)]
    pub fmu_logging: bool,
    /// Start a new campaign in an --out folder that already holds one, replacing it (the
    /// old files are removed once the new first trial has succeeded; the names a campaign
    /// writes are replaced whoever wrote them, other files are kept).
    #[arg(long, conflicts_with = "resume")]
    pub force: bool,
    /// Refuse to start a campaign estimated to need more memory than this, in MiB
    /// (default: the scenario's `memory_limit_mib`, else 4096).
    #[arg(long, value_name = "MIB")]
    pub memory_limit_mib: Option<u64>,
    /// Trials run at the same time (default: the available cores): trial k+1 runs on
    /// another core 256 steps behind trial k, when every memory channel has the plain
    /// update; 1 runs one trial after the other. Results do not depend on it.
    #[arg(long, value_name = "N", value_parser = parse_jobs)]
    pub jobs: Option<usize>,
    /// Stop after this many trials in total, as if interrupted (for testing resume).
    #[arg(long, hide = true)]
    pub stop_after: Option<usize>,
    /// Abort at the n-th file operation, as if killed (for testing resume).
    #[arg(long, hide = true)]
    pub crash_at: Option<usize>,
}

impl RunArgs {
    /// `--out`, or its default `results/<scenario file stem>`.
    pub fn out_dir(&self) -> PathBuf {
        self.out.clone().unwrap_or_else(|| {
            PathBuf::from("results").join(self.scenario.file_stem().unwrap_or_default())
        })
    }
}

/// `simulate`. A negative number after an option is its value: `--start-time -1` is a start
/// time (FMI allows one before 0), not an unknown option.
// Options that take a Real also accept values starting with a hyphen: clap's negative-number
// test does not know an exponent's sign (`-1e-3`), here or in `paper` and `analyze`.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct SimulateArgs {
    /// The FMU (.fmu).
    pub fmu: PathBuf,
    /// Input CSV: a `time` column, then columns named after input variables; values are held
    /// from each row's time until the next (zero-order hold); before the first row the
    /// inputs keep their start values.
    #[arg(short, long)]
    pub input: Option<PathBuf>,
    /// Output CSV (default: standard output).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Start time in s (default: the model's DefaultExperiment, else 0).
    #[arg(long, allow_hyphen_values = true)]
    pub start_time: Option<f64>,
    /// Stop time in s (default: the model's DefaultExperiment, else 1).
    #[arg(long, allow_hyphen_values = true)]
    pub stop_time: Option<f64>,
    /// Communication step size in s (default: the model's DefaultExperiment, else fmpy's
    /// default output interval: 500 to 1000 steps over the span, e.g. 2 ms for 1 s).
    #[arg(long, allow_hyphen_values = true)]
    pub step_size: Option<f64>,
    /// Start values, NAME=VALUE (repeatable): numbers for Real and Integer, true/false for
    /// Boolean, a number or an item name for Enumeration; an array name (`force`) sets
    /// every element.
    #[arg(long = "set", value_name = "NAME=VALUE")]
    pub set: Vec<String>,
    /// Variables to record (repeatable; default: all outputs); an array name (`pose`)
    /// records every element.
    #[arg(long = "record", value_name = "NAME")]
    pub record: Vec<String>,
    /// Ask the FMU for debug logging (messages go to stderr).
    #[arg(long)]
    pub fmu_logging: bool,
}

/// `info`.
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The FMU (.fmu).
    pub fmu: PathBuf,
}

/// `paper`. A negative number after an option is its value, refused with the option's name.
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct PaperArgs {
    /// Directory holding CkcmPlant.fmu and HlcsController.fmu.
    #[arg(long, default_value = "target/fmu")]
    pub fmu_dir: PathBuf,
    /// Output directory.
    #[arg(short, long, default_value = "results/paper")]
    pub out: PathBuf,
    /// Trials per scheme (5 to 1000: the claims compare trials 0, 2, 3 and 4, and every
    /// learning trial is recorded).
    #[arg(long, default_value_t = 10)]
    pub trials: usize,
    /// Line duration in s (the paper: 15; shorter for quick checks).
    #[arg(long, default_value_t = 15.0, allow_hyphen_values = true)]
    pub line_duration: f64,
    /// Circle duration in s (the paper: 5).
    #[arg(long, default_value_t = 5.0, allow_hyphen_values = true)]
    pub circle_duration: f64,
    /// Trials of each case beyond the paper: the paper's update against the robust one, and
    /// the robust update with noise, a heavier platform and lower gains (at least 5).
    #[arg(long, default_value_t = 50)]
    pub robust_trials: usize,
    /// Continue an interrupted study.
    #[arg(long)]
    pub resume: bool,
    /// Campaigns to run at the same time (default: the available cores); results do not
    /// depend on it.
    #[arg(long, value_parser = parse_jobs)]
    pub jobs: Option<usize>,
}

/// `analyze`. The update settings come from the scenario's first `[[memory]]` channel
/// (`[memory.update]`); the options below override them. A negative number after an
/// option is its value (`--lead -1` is refused as a lead, not read as an unknown option).
#[derive(Debug, Args)]
#[command(allow_negative_numbers = true)]
pub struct AnalyzeArgs {
    /// The scenario file (TOML).
    pub scenario: PathBuf,
    /// Output directory for convergence.csv, convergence.svg and summary.md
    /// (default: results/<scenario file stem>-convergence). The summary also goes to stdout.
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    #[arg(long, value_parser = parse_order, help = order_help(), conflicts_with = "no_filter")]
    pub order: Option<usize>,
    /// Filter cutoff f_c, Hz (0 < f_c < Nyquist).
    #[arg(long, conflicts_with = "no_filter", allow_hyphen_values = true)]
    pub cutoff: Option<f64>,
    /// Analyse without the filter, whatever the scenario says.
    #[arg(long)]
    pub no_filter: bool,
    /// Lead δ, samples.
    #[arg(long, value_parser = parse_lead, allow_hyphen_values = true)]
    pub lead: Option<usize>,
    /// Forgetting factor α.
    #[arg(long, allow_hyphen_values = true)]
    pub forgetting: Option<f64>,
    /// Gain g on the learning increment.
    #[arg(long, allow_hyphen_values = true)]
    pub gain: Option<f64>,
    /// Scale the controller's learning gains Φ, Γ, Ψ (default 1).
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub gain_scale: f64,
    /// How long, s, a pose must last to count in the sustained-mass prediction.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub dwell: f64,
    /// Spacing, s, of the poses sampled along the reference.
    #[arg(long, default_value_t = 0.005, allow_hyphen_values = true)]
    pub stride: f64,
}

/// `--jobs` of run, paper and sweep alike: at least 1 (0 would run nothing, or one).
fn parse_jobs(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err("must be a whole number of at least 1".into()),
    }
}

/// `analyze --lead`: a count of samples, so a negative or fractional lead gets its own words,
/// not the integer parser's "invalid digit".
fn parse_lead(text: &str) -> Result<usize, String> {
    text.parse::<usize>()
        .map_err(|_| "must be a whole number of samples, zero or more".into())
}

/// `analyze --order`: the bounds a scenario's `order` has (`ckcm::learning::MAX_ORDER`), so
/// analyze never predicts for a filter `run` refuses.
fn parse_order(text: &str) -> Result<usize, String> {
    let max = ckcm::learning::MAX_ORDER;
    match text.parse::<usize>() {
        Ok(o) if (1..=max).contains(&o) => Ok(o),
        _ => Err(format!(
            "the Butterworth order must be an integer between 1 and {max}, as in a scenario"
        )),
    }
}

fn order_help() -> String {
    format!(
        "Butterworth order N_Q of the filter, 1 to {} (default: the scenario's, else 4)",
        ckcm::learning::MAX_ORDER
    )
}

/// `sweep`. A negative number after an option is its value, refused with the option's name.
#[derive(Debug, Args)]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    allow_negative_numbers = true
)]
pub struct SweepArgs {
    #[command(subcommand)]
    pub action: Option<SweepAction>,
    /// The sweep file (TOML): a base scenario plus axes.
    #[arg(required = true)]
    pub sweep: Option<PathBuf>,
    /// Output directory (default: results/<sweep file stem>).
    #[arg(short, long)]
    pub out: Option<PathBuf>,
    /// Cases run at the same time (default: the available cores); results do not depend on it.
    #[arg(long, value_parser = parse_jobs)]
    pub jobs: Option<usize>,
    /// Run only shard K of N (cases i with i mod N = K), e.g. `--shard 3/8` or
    /// `--shard $SLURM_ARRAY_TASK_ID/8`; combine the shard folders with `sweep merge`. A shard's
    /// folder is resumed with the same --shard.
    #[arg(long, value_name = "K/N", allow_hyphen_values = true)]
    pub shard: Option<String>,
    /// Continue a sweep in --out: finished cases are kept, unfinished ones resumed.
    #[arg(long)]
    pub resume: bool,
    /// Ask the FMUs for debug logging (messages go to stderr).
    #[arg(long)]
    pub fmu_logging: bool,
}

impl SweepArgs {
    /// `--out`, or its default `results/<sweep file stem>`.
    pub fn out_dir(&self, file: &Path) -> PathBuf {
        self.out
            .clone()
            .unwrap_or_else(|| PathBuf::from("results").join(file.file_stem().unwrap_or_default()))
    }
}

/// Subcommands of `sweep`.
#[derive(Debug, Subcommand)]
pub enum SweepAction {
    /// Combine the folders of every shard of a sweep into the results of an unsharded run.
    Merge(SweepMergeArgs),
}

/// `sweep merge`.
#[derive(Debug, Args)]
pub struct SweepMergeArgs {
    /// The sweep file the shards ran.
    pub sweep: PathBuf,
    /// The shard folders (each written by `sweep --shard K/N`), all N of them.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Output directory for the merged sweep (new or empty).
    #[arg(short, long)]
    pub out: PathBuf,
}
