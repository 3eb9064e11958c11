//! `run SCENARIO.toml`: every trial of a scenario, persisted after each trial.

use std::path::Path;

use anyhow::Result;
use orchestrator::campaign::{
    CampaignError, CampaignOptions, completed_trials, failed_trial_file, run_campaign,
};
use orchestrator::scenario::{RecordFormat, Scenario};

use crate::args::RunArgs;

/// Runs `run`.
pub fn run(args: RunArgs) -> Result<()> {
    let (mut scenario, text, fmus) = Scenario::open(&args.scenario)?;
    if let Some(trials) = args.trials {
        anyhow::ensure!(trials >= 1, "--trials must be at least 1");
        scenario.trials = trials;
    }
    // Only when the file sets the count: `--trials 2` for a quick look at a scenario that
    // records trial 9 is a choice, not a slip.
    if args.trials.is_none()
        && let Some(k) = scenario.recorded_trial_beyond_count()
    {
        orchestrator::console!(
            "warning: {}: record.trials lists trial {k}, beyond this run's trials 0..{}: it is \
             recorded only if the campaign is extended (`--resume --trials`)",
            args.scenario.display(),
            scenario.trials - 1
        );
    }
    if let Some(format) = args.record_format {
        scenario.record.format = format;
    }
    let out_dir = args.out_dir();
    refuse_to_overwrite_the_scenario(&args.scenario, &out_dir)?;
    let opts = CampaignOptions {
        out_dir: out_dir.clone(),
        resume: args.resume,
        fmu_logging: args.fmu_logging,
        progress: true,
        stop_after: args.stop_after,
        force: args.force,
        memory_limit_mib: args.memory_limit_mib,
        crash_at: args.crash_at,
        lanes: args
            .jobs
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, usize::from)),
    };
    let summaries = run_campaign(&scenario, &text, fmus, &opts)
        .map_err(|e| kept_trials_told(e, &args.scenario, &out_dir, &scenario, &text))?;
    for s in &summaries {
        match s.legs {
            Some(legs) => orchestrator::console!(
                "trial {:3}: max |e| = {:.6} mm, RMS e = {:.6} mm",
                s.trial,
                legs.overall.max * 1e3,
                legs.overall.rms * 1e3
            ),
            None => orchestrator::console!(
                "trial {:3}: error not measured (the scenario has no [metrics])",
                s.trial
            ),
        }
    }
    orchestrator::console!("results in {}", out_dir.display());
    Ok(())
}

/// A campaign stopped part way by an FMU or a failed write, with the trials it keeps: a
/// user whose disk filled up learns that the trials run so far are safe, and how to go on
/// once there is room. An FMU's failure is not followed by that hint, since the resumed
/// trial would meet it again.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
struct StoppedPartWay {
    message: String,
    source: CampaignError,
}

fn kept_trials_told(
    e: CampaignError,
    file: &Path,
    out: &Path,
    scenario: &Scenario,
    text: &str,
) -> anyhow::Error {
    let write_failed = matches!(e, CampaignError::Output(_));
    let fmu_failed = matches!(e, CampaignError::Master(_));
    let completed = completed_trials(out, scenario, text);
    let format = scenario.record.format;
    let Some(kept) = kept_after(out, completed, write_failed, fmu_failed, format) else {
        return e.into();
    };
    // The whole chain in one message, so that the kept trials come after the reason
    // (`main` skips causes the message already holds).
    let mut message = orchestrator::describe(&e);
    let (trials, goes_on) = match kept {
        Kept::NoneYet => ("no trial is complete".to_owned(), "starts the campaign"),
        Kept::Trials(1) => ("trial 0 is kept".to_owned(), "continues the campaign"),
        Kept::Trials(n) => (
            format!("trials 0–{} are kept", n - 1),
            "continues the campaign",
        ),
    };
    message.push_str(&format!("\n{trials} in {}", out.display()));
    // The campaign keeps the failed trial's recording only where it could write it.
    let n = match kept {
        Kept::Trials(n) => n,
        Kept::NoneYet => 0,
    };
    if fmu_failed
        && let failed = failed_trial_file(out, n, format)
        && failed.is_file()
    {
        message.push_str(&format!(
            "\nthe recording of trial {n} up to its failure is in {}",
            failed.display()
        ));
    }
    if write_failed {
        message.push_str(&format!(
            "; once the write can succeed (free disk space, for one), `orchestrator run {} \
             --out {} --resume` {goes_on}",
            file.display(),
            out.display()
        ));
    }
    StoppedPartWay { message, source: e }.into()
}

/// A new campaign writes `OUT/scenario.toml`, and with `--force` (or `--resume` where no
/// campaign has begun) first moves that name aside and removes it: when that is the scenario
/// file itself, the user's file would be replaced by the campaign's copy. Resuming a
/// campaign begun there (it has a `progress.toml`) is what the campaign-folder hint
/// suggests, and writes only the same text again.
fn refuse_to_overwrite_the_scenario(scenario: &Path, out: &Path) -> Result<()> {
    let saved = out.join("scenario.toml");
    let same = match (scenario.canonicalize(), saved.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    };
    anyhow::ensure!(
        !same || out.join("progress.toml").exists(),
        "{} is the scenario file itself, and a campaign in {} writes its own scenario.toml \
         there: choose another --out (by default results/<scenario name>/)",
        saved.display(),
        out.display()
    );
    Ok(())
}

/// What a run stopped by a failed write or an FMU can say it left in `out`.
#[derive(Debug, PartialEq)]
enum Kept {
    /// Trials 0..n, committed (n > 0).
    Trials(usize),
    /// No trial, in a folder this run began: after a failed write its `scenario.toml` (no
    /// longer empty, so only `--resume` starts the campaign again there), after an FMU's
    /// failure the first trial's rows up to it.
    NoneYet,
}

/// `completed`: the trials the folder's progress records for this scenario (`None` when it
/// holds no progress, or another campaign's). After an FMU's failure the kept trials are
/// worth naming, or else the first trial's rows the campaign kept (recorded in `format`;
/// a run removes an earlier run's before it starts); after a failed write, a first trial
/// that failed is too.
fn kept_after(
    out: &Path,
    completed: Option<usize>,
    write_failed: bool,
    fmu_failed: bool,
    format: RecordFormat,
) -> Option<Kept> {
    match completed {
        Some(n) if n > 0 && (write_failed || fmu_failed) => Some(Kept::Trials(n)),
        None if write_failed
            && !out.join("progress.toml").exists()
            && out.join("scenario.toml").is_file() =>
        {
            Some(Kept::NoneYet)
        }
        None if fmu_failed && failed_trial_file(out, 0, format).is_file() => Some(Kept::NoneYet),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A failed first write is told only in a folder this run began (its scenario.toml and
    /// no progress): not where nothing was written, nor over another campaign's progress.
    #[test]
    fn a_failed_first_write_is_told_only_in_a_folder_this_run_began() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        let kept = |c, w, f| kept_after(out, c, w, f, RecordFormat::Csv);
        assert_eq!(kept(None, true, false), None, "an empty folder");
        std::fs::write(out.join("scenario.toml"), "").unwrap();
        assert_eq!(kept(None, true, false), Some(Kept::NoneYet));
        assert_eq!(kept(None, false, true), None, "an FMU's failure");
        assert_eq!(kept(Some(0), true, false), None);
        std::fs::write(out.join("progress.toml"), "").unwrap();
        assert_eq!(
            kept(None, true, false),
            None,
            "another campaign's progress (a --force run's first trial)"
        );
        assert_eq!(kept(Some(3), true, false), Some(Kept::Trials(3)));
        assert_eq!(kept(Some(3), false, true), Some(Kept::Trials(3)));
        assert_eq!(kept(Some(3), false, false), None);
    }

    /// A first trial's rows are told after an FMU's failure, in the scenario's format only.
    #[test]
    fn a_failed_first_trials_rows_are_told_after_an_fmus_failure() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path();
        let file = failed_trial_file(out, 0, RecordFormat::Csv);
        std::fs::create_dir(file.parent().unwrap()).unwrap();
        std::fs::write(&file, "").unwrap();
        assert_eq!(
            kept_after(out, None, false, true, RecordFormat::Csv),
            Some(Kept::NoneYet)
        );
        assert_eq!(
            kept_after(out, None, false, true, RecordFormat::Parquet),
            None
        );
        assert_eq!(kept_after(out, None, false, false, RecordFormat::Csv), None);
    }
}
