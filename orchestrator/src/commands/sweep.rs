//! `sweep SWEEP.toml`: one campaign per case, locally in parallel or as one shard of many;
//! `sweep merge`: the shards' folders combined into the results of an unsharded run.

use anyhow::{Context, Result, bail};
use orchestrator::sweep::{SweepOptions, SweepSpec, merge, run_sweep};

use crate::args::{SweepAction, SweepArgs};

/// `K/N` with K < N.
fn parse_shard(text: &str) -> Result<(usize, usize)> {
    let parse = || -> Option<(usize, usize)> {
        let (k, n) = text.split_once('/')?;
        Some((k.trim().parse().ok()?, n.trim().parse().ok()?))
    };
    let Some((k, n)) = parse() else {
        bail!("--shard {text:?}: expected K/N, e.g. 0/4");
    };
    if n == 0 || k >= n {
        bail!("--shard {text}: K must be below N (shards are numbered 0..N-1)");
    }
    Ok((k, n))
}

/// Runs `sweep`.
pub fn run(args: SweepArgs) -> Result<()> {
    if let Some(SweepAction::Merge(m)) = args.action {
        let spec = SweepSpec::load(&m.sweep)?;
        merge(&spec, &m.out, &m.shards)?;
        orchestrator::console!("merged {} shards into {}", m.shards.len(), m.out.display());
        return Ok(());
    }
    let file = args.sweep.clone().context("a sweep file is required")?;
    let shard = args.shard.as_deref().map(parse_shard).transpose()?;
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, std::num::NonZero::get));
    let spec = SweepSpec::load(&file)?;
    let out = args.out_dir(&file);
    let opts = SweepOptions {
        out_dir: out.clone(),
        jobs,
        shard,
        resume: args.resume,
        fmu_logging: args.fmu_logging,
        progress: true,
    };
    let ran = run_sweep(&spec, &opts)?;
    orchestrator::console!(
        "{} of {} cases run now; results in {}",
        ran.len(),
        spec.cases.len(),
        out.display()
    );
    Ok(())
}
