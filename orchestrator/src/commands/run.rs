//! `run SCENARIO.toml`: every trial of a scenario, persisted after each trial.

use std::path::PathBuf;

use anyhow::{Context, Result};
use fmi2::import::Fmu;
use orchestrator::campaign::{CampaignOptions, run_campaign};
use orchestrator::scenario::Scenario;

use crate::args::RunArgs;

/// Opens every FMU a scenario names, validating the scenario against their model
/// descriptions; the FMUs come back in scenario order.
pub fn load(path: &std::path::Path) -> Result<(Scenario, String, Vec<Fmu>)> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut opened: Vec<(PathBuf, Fmu)> = Vec::new();
    let scenario = Scenario::parse(&text, path, |fmu_path| {
        let fmu = Fmu::open(fmu_path).map_err(|e| e.to_string())?;
        let md = fmu.model_description().clone();
        opened.push((fmu_path.to_path_buf(), fmu));
        Ok(md)
    })?;
    let fmus = opened.into_iter().map(|(_, f)| f).collect();
    Ok((scenario, text, fmus))
}

/// Runs `run`.
pub fn run(args: RunArgs) -> Result<()> {
    let (mut scenario, text, fmus) = load(&args.scenario)?;
    if let Some(trials) = args.trials {
        anyhow::ensure!(trials >= 1, "--trials must be at least 1");
        scenario.trials = trials;
    }
    let out_dir = args.out.unwrap_or_else(|| {
        PathBuf::from("results").join(args.scenario.file_stem().unwrap_or_default())
    });
    let opts = CampaignOptions {
        out_dir: out_dir.clone(),
        resume: args.resume,
        fmu_logging: args.fmu_logging,
        progress: true,
        stop_after: args.stop_after,
        force: args.force,
        memory_limit_mib: args.memory_limit_mib,
        crash_at: args.crash_at,
    };
    let summaries = run_campaign(&scenario, &text, fmus, &opts)?;
    for s in &summaries {
        eprintln!(
            "trial {:3}: max |e| = {:.6} mm, RMS e = {:.6} mm",
            s.trial,
            s.legs.overall.max * 1e3,
            s.legs.overall.rms * 1e3
        );
    }
    eprintln!("results in {}", out_dir.display());
    Ok(())
}
