//! `paper`: the paper's simulation study, results in `results/paper/`.

use anyhow::Result;
use orchestrator::paper::{PaperOptions, run_paper};
use orchestrator::scenario::DEFAULT_RHO;

use crate::args::PaperArgs;

/// Runs `paper`.
pub fn run(args: PaperArgs) -> Result<()> {
    let opts = PaperOptions {
        fmu_dir: args.fmu_dir,
        out_dir: args.out.clone(),
        trials: args.trials,
        robust_trials: args.robust_trials,
        line_duration: args.line_duration,
        circle_duration: args.circle_duration,
        resume: args.resume,
        progress: true,
        rho: DEFAULT_RHO,
        jobs: args
            .jobs
            .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())),
    };
    let start = std::time::Instant::now();
    run_paper(&opts)?;
    orchestrator::console!(
        "paper study done in {:.1} s: {}",
        start.elapsed().as_secs_f64(),
        args.out.join("report.md").display()
    );
    Ok(())
}
