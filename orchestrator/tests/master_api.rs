//! The master's library interface (docs/model.md §6) as a caller of `orchestrator::master`
//! sees it, with the packaged FMUs: the memory channels' names, the memory it hands to the
//! next trial, replacing that memory (resume), and the recording's columns.

mod common;

use std::path::Path;

use orchestrator::master::Master;
use orchestrator::scenario::Scenario;

/// A 0.3 s line under HLCS recording the controller's error and the plant's lengths.
fn scenario_toml() -> String {
    format!(
        r#"
step_size = 0.001
stop_time = 0.3
trials = 2

[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "line"
duration = 0.3
learning = true

[[fmu]]
name = "plant"
path = "{plant}"
{closed_loop}
[record]
variables = ["controller.error", "plant.length"]
interval = 1
"#,
        controller = common::fmu_path_text("HlcsController"),
        plant = common::fmu_path_text("CkcmPlant"),
        closed_loop = common::CLOSED_LOOP,
    )
}

fn names(prefix: &str) -> Vec<String> {
    (1..=6).map(|i| format!("{prefix}[{i}]")).collect()
}

#[test]
fn master_reports_its_memory_and_columns() {
    let text = scenario_toml();
    let (scenario, fmus) = Scenario::open_text(&text, Path::new("master-api.toml")).unwrap();
    let mut master = Master::new(&scenario, fmus, false).unwrap();

    let mut expected = names("controller.error");
    expected.extend(names("plant.length"));
    assert_eq!(master.memory_names(), names("controller.memory_next"));

    // Before the first trial the memory is zero; after it, the read buffer holds the
    // memory_next the controller produced, one row of six per sample.
    assert_eq!(master.memory().len(), 1);
    assert_eq!(master.memory()[0].len(), 300 * 6);
    assert!(master.memory()[0].iter().all(|&u| u == 0.0));
    let mut recording = master.new_recording();
    let mut signals = master.new_signals();
    master
        .run_trial(0, Some(&mut recording), &mut signals, |_| {})
        .unwrap();
    assert_eq!(recording.names(), expected);
    assert_eq!(recording.len(), 300);
    let learned = master.memory()[0].to_vec();
    assert!(learned.iter().any(|&u| u != 0.0));

    // set_memory replaces the read buffer that the next trial uses.
    let replaced: Vec<f64> = (0..300 * 6).map(|k| k as f64 * 1e-3).collect();
    master.set_memory(std::slice::from_ref(&replaced));
    assert_eq!(master.memory()[0], replaced.as_slice());
}

/// An unrecorded trial reads only the outputs the coupling and the metrics need (the
/// plant's Euler angles are then never computed); its metrics' signals and the memory it
/// hands on must be those of the same trial recorded, bit for bit, trial after trial.
#[test]
fn unrecorded_trials_match_recorded_ones_bit_for_bit() {
    let text = format!(
        r#"
step_size = 0.001
stop_time = 0.4
trials = 3

[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "circle"
duration = 0.4
learning = true

[[fmu]]
name = "plant"
path = "{plant}"
{closed_loop}
[record]
variables = ["plant.pose", "controller.force", "plant.velocity_true"]
interval = 2

[metrics]
reference = "controller.length_ref"
length = "plant.length_true"
rho = 1.0
pose = "plant.pose"
trajectory = {{ kind = "circle", duration = 0.4, home_height = 0.5 }}
"#,
        controller = common::fmu_path_text("HlcsController"),
        plant = common::fmu_path_text("CkcmPlant"),
        closed_loop = common::CLOSED_LOOP,
    );
    let (scenario, fmus) = Scenario::open_text(&text, Path::new("unrecorded.toml")).unwrap();
    let (scenario_b, fmus_b) = Scenario::open_text(&text, Path::new("unrecorded.toml")).unwrap();
    let mut recorded = Master::new(&scenario, fmus, false).unwrap();
    let mut unrecorded = Master::new(&scenario_b, fmus_b, false).unwrap();
    let mut recording = recorded.new_recording();
    let mut signals = recorded.new_signals();
    let mut signals_b = unrecorded.new_signals();
    // Bit for bit, naming the first sample that differs.
    let same = |a: &[f64], b: &[f64], what: &str| {
        assert_eq!(a.len(), b.len(), "{what}: lengths");
        if let Some(i) = (0..a.len()).find(|&i| a[i].to_bits() != b[i].to_bits()) {
            panic!(
                "{what}: sample {i} is {} recorded, {} unrecorded",
                a[i], b[i]
            );
        }
    };
    for trial in 0..3 {
        recorded
            .run_trial(trial, Some(&mut recording), &mut signals, |_| {})
            .unwrap();
        unrecorded
            .run_trial(trial, None, &mut signals_b, |_| {})
            .unwrap();
        assert_eq!(recording.len(), 200, "trial {trial}");
        same(
            &signals.time,
            &signals_b.time,
            &format!("trial {trial}, time"),
        );
        same(
            signals.error.as_flattened(),
            signals_b.error.as_flattened(),
            &format!("trial {trial}, leg errors"),
        );
        same(
            signals.position.as_flattened(),
            signals_b.position.as_flattened(),
            &format!("trial {trial}, position"),
        );
        assert!(
            signals.position.iter().any(|p| p[0] != 0.0),
            "trial {trial}"
        );
        same(
            recorded.memory()[0],
            unrecorded.memory()[0],
            &format!("trial {trial}, memory"),
        );
    }
    // The recorded pose's angles moved with the circle (they are computed on read).
    let recording = recording.to_recording();
    let yaw = recording.column("plant.pose[6]").unwrap();
    assert!(yaw.iter().any(|&a| a != 0.0));
}

/// A memory channel fed by the only FMU in the scenario: the master copies the producer's
/// output into the memory right after the producer's own step, whatever the other FMUs are.
/// (With a plant after the controller, copying after the plant's step instead would copy the
/// same values; alone, the controller is the only FMU that steps.)
#[test]
fn memory_of_a_lone_controller_is_written_after_its_step() {
    let controller = std::fs::canonicalize(common::built_fmu("HlcsController")).unwrap();
    let text = format!(
        r#"
step_size = 0.001
stop_time = 0.1
trials = 1

[[fmu]]
name = "controller"
path = "{}"
[fmu.parameters]
trajectory = "line"
duration = 0.1
learning = true

[[memory]]
from = "controller.memory_next"
to = "controller.memory"
"#,
        controller.display()
    );
    let (scenario, fmus) = Scenario::open_text(&text, Path::new("lone-controller.toml")).unwrap();
    let mut master = Master::new(&scenario, fmus, false).unwrap();
    let mut signals = master.new_signals();
    master.run_trial(0, None, &mut signals, |_| {}).unwrap();
    // The lengths stay at their start values while the reference moves, so the error and
    // with it memory_next are non-zero from the first samples on.
    let memory = master.memory()[0];
    assert_eq!(memory.len(), 100 * 6);
    assert!(
        memory.iter().filter(|&&u| u != 0.0).count() > 300,
        "the memory of the next trial is mostly zero: {:?}",
        &memory[..12]
    );
}

/// Compiles the importer's C test FMU (MiniPlatform) so that its fmi2GetReal fails once its
/// time reaches 2.5 ms, and packages it into `dir`.
fn mini_platform_failing_get(dir: &Path) -> std::path::PathBuf {
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fmi");
    let lib = dir.join("libMiniPlatform.so");
    let cc = std::env::var_os("CC").unwrap_or_else(|| "cc".into());
    let status = std::process::Command::new(&cc)
        .args([
            "-shared",
            "-fPIC",
            "-fvisibility=hidden",
            "-DFAIL_GET_REAL_FROM=0.0025",
            "-o",
        ])
        .arg(&lib)
        .arg(fixtures.join("fmi2-import/tests/fixtures/dummy_fmu.c"))
        .arg("-lm")
        .status()
        .unwrap_or_else(|e| panic!("cannot run the C compiler {cc:?}: {e}"));
    assert!(status.success(), "compiling the test FMU failed");
    let xml = std::fs::read_to_string(fixtures.join("fmi2-md/tests/fixtures/valid.xml")).unwrap();
    let fmu = dir.join("MiniPlatform.fmu");
    fmu_build::write_fmu(&fmu, &xml, Some(&lib), &[]).unwrap();
    fmu
}

/// An FMU whose fmi2GetReal fails right after a successful step: the error names the call and
/// the time the step reached, t₃ = 3 ms (computed from the step index, as every time is). The
/// recording keeps the rows of the steps before, although the master stages rows in blocks.
#[test]
fn a_failing_get_after_a_step_names_the_time_the_step_reached() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = mini_platform_failing_get(dir.path());
    let text = format!(
        r#"
step_size = 0.001
stop_time = 0.01
trials = 1

[[fmu]]
name = "mini"
path = "{}"

[record]
variables = ["mini.x"]
"#,
        fmu.display()
    );
    let (scenario, fmus) = Scenario::open_text(&text, Path::new("mini.toml")).unwrap();
    let mut master = Master::new(&scenario, fmus, false).unwrap();
    let mut signals = master.new_signals();
    let mut recording = master.new_recording();
    let err = master
        .run_trial(0, Some(&mut recording), &mut signals, |_| {})
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("trial 0, t = 0.003 s: fmi2GetReal of FMU \"mini\" failed"),
        "{err}"
    );
    assert!(err.contains("GetReal refused at t=0.003"), "{err}");
    assert_eq!(recording.time(), [0.0, 0.001]);
    let recording = recording.to_recording();
    assert!(!recording.columns.is_empty());
    assert!(recording.columns.iter().all(|c| c.len() == 2));
}
