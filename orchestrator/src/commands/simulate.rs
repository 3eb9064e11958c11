//! `simulate X.fmu`: one FMU on its own (the engine is `orchestrator::simulate`), its
//! recording written as CSV. The result is written only after the last step succeeded, and
//! atomically, so a failed run leaves no output file behind.

use std::path::Path;

use anyhow::{Context, Result};
use fmi2_import::Fmu;
use orchestrator::output::{CsvWithText, Exporter, to_stdout, write_recording};
use orchestrator::simulate::{SimulateOptions, simulate};

use crate::args::SimulateArgs;

/// Runs `simulate`.
pub fn run(args: SimulateArgs) -> Result<()> {
    let fmu = open_fmu(&args.fmu)?;
    let opts = SimulateOptions {
        input: args.input,
        start_time: args.start_time,
        stop_time: args.stop_time,
        step_size: args.step_size,
        set: args.set,
        record: args.record,
        fmu_logging: args.fmu_logging,
    };
    let sim = simulate(&fmu, &opts)
        .with_context(|| format!("simulation of {} failed", args.fmu.display()))?;
    let (recording, text, ended) = (sim.recording, sim.text, sim.ended);
    if let Some(notice) = ended {
        orchestrator::console!(
            "notice: {notice}; the simulation ends at t = {} s with {} rows",
            recording.time.last().copied().unwrap_or(f64::NAN),
            recording.len()
        );
    }
    let exporter = CsvWithText { text };
    match &args.output {
        Some(path) => write_recording(path, &recording, &exporter)?,
        None => to_stdout(|w| exporter.write(&recording, w))
            .context("cannot write the result to standard output")?,
    }
    Ok(())
}

/// Opens an FMU. An [`ImportError`] is reported by its message alone: that message already
/// includes its cause, which `{:#}` in `main` would otherwise print a second time. A scenario
/// or sweep file given here is named as such, with the command that runs it.
pub(crate) fn open_fmu(path: &Path) -> Result<Fmu> {
    Fmu::open(path).map_err(|e| open_error(path, &e))
}

/// [`open_fmu`]'s report of why the FMU at `path` did not open.
pub(crate) fn open_error(path: &Path, e: &fmi2_import::ImportError) -> anyhow::Error {
    let hint = match e {
        fmi2_import::ImportError::NotZip { .. } => run_command_for(path),
        _ => None,
    };
    anyhow::Error::msg(match hint {
        Some(hint) => format!("{e}\n{hint}"),
        None => e.to_string(),
    })
}

/// `orchestrator run FILE` or `orchestrator sweep FILE` when `path` holds a scenario or a
/// sweep file (a TOML table with `[[fmu]]` or `[[axis]]`).
fn run_command_for(path: &Path) -> Option<String> {
    // Only a regular file: opening a pipe would block. `read_text` bounds the read as for
    // any scenario file (a device such as /dev/zero never ends).
    if !std::fs::metadata(path).ok()?.is_file() {
        return None;
    }
    let text = orchestrator::scenario::read_text(path).ok()?;
    let table: toml::Table = text.parse().ok()?;
    let (kind, command) = if table.contains_key("fmu") {
        ("scenario", "run")
    } else if table.contains_key("axis") {
        ("sweep", "sweep")
    } else {
        return None;
    };
    Some(format!(
        "it is a {kind} file: `orchestrator {command} {}` runs it",
        path.display()
    ))
}
