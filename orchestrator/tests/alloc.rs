//! After a warm-up trial, `Master::run_trial` allocates nothing: the master loop only copies
//! between buffers sized in `Master::new`, `new_recording` and `new_signals`.
//!
//! The counting allocator is this test binary's global allocator, so it counts the master's
//! own allocations (and fmi2-import's); the FMUs are shared libraries with their own
//! allocator, covered by the tests in fmu-plant/ and fmu-controller/.
//!
//! To find an allocation, run with `CKCM_ALLOC_BACKTRACE=1` (and `--nocapture`): every counted
//! allocation then prints its backtrace to stderr.

mod common;

use std::path::Path;

use alloc_count::{CountingAllocator, counted};
use orchestrator::master::Master;
use orchestrator::scenario::Scenario;

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// A 2 s line under HLCS with sensor noise seeded per trial, recording at every sample and
/// the true-error metrics ports (reference and noise-free length), with the packaged FMUs;
/// `update` is the memory channel's update table (empty: the paper's).
fn scenario_toml(update: &str) -> String {
    format!(
        r#"
step_size = 0.001
stop_time = 2.0
trials = 3

[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "line"
duration = 2.0
learning = true

[[fmu]]
name = "plant"
path = "{plant}"
[fmu.parameters]
length_noise_sigma = 1e-6
velocity_noise_sigma = 1e-5
noise_seed = {{ base = 7, per_trial = 1 }}
{closed_loop}{update}

[record]
variables = ["controller.error", "controller.force", "controller.memory_next", "plant.length", "plant.pose"]
interval = 1

[metrics]
reference = "controller.length_ref"
length = "plant.length_true"
pose = "plant.pose"
trajectory = {{ kind = "line", duration = 2.0, home_height = 0.5 }}
"#,
        controller = common::fmu_path_text("HlcsController"),
        plant = common::fmu_path_text("CkcmPlant"),
        closed_loop = common::CLOSED_LOOP,
    )
}

#[test]
fn trials_after_the_first_do_not_allocate() {
    trials_after_the_first_do_not_allocate_with("");
}

/// The robust update (zero-phase Butterworth filter, lead, forgetting, gain) runs on
/// buffers prepared in `Master::new`.
#[test]
fn trials_after_the_first_do_not_allocate_with_the_robust_update() {
    trials_after_the_first_do_not_allocate_with(
        "[memory.update]\nfilter = \"butterworth\"\norder = 4\ncutoff = 8.0\nlead = 25\nforgetting = 0.99\ngain = 0.9\n",
    );
}

fn trials_after_the_first_do_not_allocate_with(update: &str) {
    let text = scenario_toml(update);
    let (scenario, fmus) = Scenario::open_text(&text, Path::new("alloc-line.toml")).unwrap();
    let mut master = Master::new(&scenario, fmus, false).unwrap();
    let mut recording = master.new_recording();
    let mut signals = master.new_signals();
    let mut steps = 0;
    master
        .run_trial(0, Some(&mut recording), &mut signals, |_| steps += 1)
        .unwrap();
    assert_eq!(steps, 2000);

    for trial in 1..3 {
        let (during, result) =
            counted(|| master.run_trial(trial, Some(&mut recording), &mut signals, |_| {}));
        result.unwrap();
        assert_eq!(
            during, 0,
            "trial {trial} allocated {during} times (CKCM_ALLOC_BACKTRACE=1 shows where)"
        );
        // The trial did run and record: every sample, with non-zero learned memory.
        assert_eq!(recording.len(), 2000);
        assert_eq!(signals.time.len(), 2000);
        let memory = master.memory();
        assert!(memory[0].iter().any(|&u| u != 0.0));
    }
}

/// The counter sees the master's allocations at all: building a recording allocates.
#[test]
fn counter_counts() {
    let (during, recording) =
        counted(|| orchestrator::output::Recording::with_capacity(vec![], 10));
    assert!(during > 0);
    assert!(recording.is_empty());
}
