//! Runs one trial of a scenario through `Master` and then repeats trial 1 REPS times, with
//! the memory trial 0 learned, recording every trial (with `--unrecorded`, trial 0 only):
//! CPU time per trial without criterion's wall clock, which a shared machine makes noisy
//! (`scripts/bench_cpu.sh master` takes the difference of two repeat counts, so loading the
//! FMUs and trial 0 cancel).
//!
//! Usage: master_trials SCENARIO [REPS] [--unrecorded]

use std::path::Path;

use orchestrator::master::Master;
use orchestrator::scenario::Scenario;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let path = args
        .first()
        .ok_or("usage: master_trials SCENARIO [REPS] [--unrecorded]")?;
    let reps: usize = args.get(1).map_or(Ok(10), |s| s.parse())?;
    let recorded = !args.iter().any(|a| a == "--unrecorded");
    let (scenario, _text, fmus) = Scenario::open(Path::new(path))?;
    let mut master = Master::new(&scenario, fmus, false)?;
    let mut recording = master.new_recording();
    let mut signals = master.new_signals();
    master.run_trial(0, Some(&mut recording), &mut signals, |_| {})?;
    let learned: Vec<Vec<f64>> = master.memory().iter().map(|m| m.to_vec()).collect();
    let start = std::time::Instant::now();
    for _ in 0..reps {
        master.set_memory(&learned);
        let rec = recorded.then_some(&mut recording);
        master.run_trial(1, rec, &mut signals, |_| {})?;
    }
    let per = start.elapsed().as_secs_f64() / reps.max(1) as f64;
    println!(
        "{:.2} ms per trial of {} s ({:.0}x real time), {}",
        per * 1e3,
        scenario.stop_time,
        scenario.stop_time / per,
        if recorded { "recorded" } else { "unrecorded" }
    );
    Ok(())
}
