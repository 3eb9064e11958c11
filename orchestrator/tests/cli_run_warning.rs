//! `run` when an FMU returns fmi2Warning from fmi2DoStep: the step stands and the campaign
//! goes on, and the user hears the FMU's first warning once per campaign, with trial and
//! time, whatever the number of lanes; `--fmu-logging` shows every one.

mod common;

use common::{CLOSED_LOOP, fmu_path_text, orchestrator};

/// The line scenario with the plant on the adaptive integrator and the smallest
/// `friction_velocity`, where every 1 ms interval takes it thousands of steps: the plant
/// warns once per initialization, so once in each of the three trials.
fn scenario(dir: &std::path::Path) -> std::path::PathBuf {
    let path = dir.join("stiff.toml");
    std::fs::write(
        &path,
        format!(
            r#"step_size = 0.001
stop_time = 0.003
trials = 3
[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "line"
duration = 15.0
learning = true
[[fmu]]
name = "plant"
path = "{plant}"
[fmu.parameters]
integrator = "dormand_prince"
friction_velocity = 1e-6
{CLOSED_LOOP}
[record]
variables = ["plant.length"]
"#,
            controller = fmu_path_text("HlcsController"),
            plant = fmu_path_text("CkcmPlant"),
        ),
    )
    .unwrap();
    path
}

/// `run` of the scenario with `args`: success, and stderr.
fn run(dir: &std::path::Path, out: &str, args: &[&str]) -> (bool, String) {
    let o = orchestrator()
        .arg("run")
        .arg(scenario(dir))
        .arg("--out")
        .arg(dir.join(out))
        .args(args)
        .output()
        .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn the_first_step_warning_is_shown_once_with_trial_and_time() {
    let tmp = tempfile::tempdir().unwrap();
    for (out, jobs) in [("one", "--jobs=1"), ("two", "--jobs=2")] {
        let (ok, err) = run(tmp.path(), out, &[jobs]);
        assert!(ok, "{jobs}: {err}");
        assert_eq!(
            err.matches("returned fmi2Warning from fmi2DoStep").count(),
            1,
            "{jobs}: {err}"
        );
        // The campaign's folder first: a sweep or the paper study runs many.
        let folder = tmp.path().join(out);
        assert!(
            err.contains(&format!(
                "warning: {}: trial 0, t = 0 s: FMU \"plant\" returned fmi2Warning",
                folder.display()
            )),
            "{jobs}: {err}"
        );
        assert!(
            err.contains("the adaptive integrator took"),
            "{jobs}: {err}"
        );
        assert!(
            err.contains("--fmu-logging shows every message"),
            "{jobs}: {err}"
        );
        // Every trial ran to its end and was written.
        for trial in 0..3 {
            let csv = tmp
                .path()
                .join(out)
                .join(format!("trials/trial_{trial:03}.csv"));
            let text = std::fs::read_to_string(&csv)
                .unwrap_or_else(|e| panic!("{jobs}: {}: {e}", csv.display()));
            assert_eq!(text.lines().count(), 1 + 3, "{jobs}: {text}");
        }
    }
}

#[test]
fn fmu_logging_shows_every_warning() {
    let tmp = tempfile::tempdir().unwrap();
    let (ok, err) = run(tmp.path(), "logged", &["--jobs=1", "--fmu-logging"]);
    assert!(ok, "{err}");
    assert_eq!(
        err.matches("the adaptive integrator took").count(),
        3,
        "{err}"
    );
    assert_eq!(
        err.matches("returned fmi2Warning from fmi2DoStep").count(),
        0,
        "{err}"
    );
}
