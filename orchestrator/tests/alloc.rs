//! After a warm-up trial, `Master::run_trial` allocates nothing: the master loop only copies
//! between buffers sized in `Master::new`, `new_recording` and `new_signals`. Nor does
//! `Master::run_trial_linked`, the loop of `run --jobs N`'s lanes, with a link that hands the
//! memory on through buffers of its own.
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
use orchestrator::master::{CHUNK_STEPS, Master, MemoryLink, Stopped};
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

/// Hands each trial's memory to the next chunk by chunk through two buffers of its own, as
/// a lane's link does through its channels (one channel of `width` values per step).
struct Loopback {
    width: usize,
    current: Vec<f64>,
    next: Vec<f64>,
}

impl MemoryLink for Loopback {
    const ACTIVE: bool = true;

    fn receive(&mut self, c: usize, chunk: usize, read: &mut [f64]) -> Result<(), Stopped> {
        assert_eq!(c, 0);
        let at = chunk * CHUNK_STEPS * self.width;
        read.copy_from_slice(&self.current[at..at + read.len()]);
        Ok(())
    }

    fn send(&mut self, c: usize, chunk: usize, written: &[f64]) {
        assert_eq!(c, 0);
        let at = chunk * CHUNK_STEPS * self.width;
        self.next[at..at + written.len()].copy_from_slice(written);
    }
}

/// The linked loop allocates nothing after a warm-up trial either, and computes what the
/// plain loop computes: the same memory and recording, bit for bit, trial after trial.
#[test]
fn linked_trials_do_not_allocate_and_match_the_plain_ones() {
    let text = scenario_toml("");
    let open = || Scenario::open_text(&text, Path::new("alloc-line.toml")).unwrap();
    let (scenario, fmus) = open();
    let (scenario_linked, fmus_linked) = open();
    let mut plain = Master::new(&scenario, fmus, false).unwrap();
    let mut linked = Master::new(&scenario_linked, fmus_linked, false).unwrap();
    let len = linked.memory()[0].len();
    let mut link = Loopback {
        width: len / 2000,
        current: vec![0.0; len],
        next: vec![0.0; len],
    };
    let (mut rec_plain, mut rec_linked) = (plain.new_recording(), linked.new_recording());
    let (mut sig_plain, mut sig_linked) = (plain.new_signals(), linked.new_signals());
    // The linked master's own read buffers are spoiled before each trial, so only what the
    // link delivers can make its trials equal the plain ones.
    let spoiled = vec![vec![f64::NAN; len]];
    for trial in 0..3 {
        plain
            .run_trial(trial, Some(&mut rec_plain), &mut sig_plain, |_| {})
            .unwrap();
        linked.set_memory(&spoiled);
        let (during, result) = counted(|| {
            linked.run_trial_linked(
                trial,
                Some(&mut rec_linked),
                &mut sig_linked,
                |_| {},
                &mut link,
            )
        });
        result.unwrap();
        if trial > 0 {
            assert_eq!(
                during, 0,
                "linked trial {trial} allocated {during} times (CKCM_ALLOC_BACKTRACE=1 shows where)"
            );
        }
        std::mem::swap(&mut link.current, &mut link.next);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(
            bits(&link.current),
            bits(plain.memory()[0]),
            "trial {trial}"
        );
        assert!(link.current.iter().any(|&u| u != 0.0));
        assert_eq!(rec_linked.len(), rec_plain.len());
        assert!(!rec_plain.is_empty());
        assert_eq!(bits(rec_linked.time()), bits(rec_plain.time()));
        for (n, (a, b)) in rec_linked.rows().zip(rec_plain.rows()).enumerate() {
            assert_eq!(bits(a), bits(b), "trial {trial}, row {n}");
        }
    }
}
