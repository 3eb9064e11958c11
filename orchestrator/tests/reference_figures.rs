//! The figures of the independent reference model (a separate numpy task-space model of the
//! same mechanism and controller, RK4 at 1 ms; docs/model.md §7), reproduced through the
//! packaged FMUs and the `orchestrator run` command.
//!
//! These catch a wrong model that every self-consistency check accepts (a wrong friction curve,
//! a dropped feedforward term, a master that reads the memory one sample late): the energy,
//! power and inverse∘forward tests compare the model with itself.
//!
//! Tolerance: each figure is printed with a few decimals, so it says only that the true value
//! lies within half a unit of its last printed digit; the independent model and this
//! implementation agree to about 2e-5 relative on top of that. A figure passes when
//! |measured − printed| ≤ ½·10^(−decimals) + 2e-5·|printed|.

mod common;

/// The half-unit-of-last-digit tolerance of a printed figure, plus the stated 2e-5 relative
/// agreement of the two models.
fn tolerance(printed: &str) -> f64 {
    let decimals = printed.split_once('.').map_or(0, |(_, d)| d.len());
    let value: f64 = printed.parse().unwrap();
    0.5 * 10f64.powi(-(decimals as i32)) + 2e-5 * value.abs()
}

fn assert_figure(what: &str, measured: f64, printed: &str) {
    let expected: f64 = printed.parse().unwrap();
    let tol = tolerance(printed);
    assert!(
        (measured - expected).abs() <= tol,
        "{what}: measured {measured}, independent model {printed} (tolerance ±{tol:e})"
    );
}

/// A closed loop of the packaged FMUs on the paper's `trajectory` with its default duration,
/// learning on or off, run for `trials` trials; returns the overall max leg error of each
/// trial in mm, read from `summary.csv`.
fn max_errors_mm(trajectory: &str, learning: bool, trials: usize) -> Vec<f64> {
    let duration = match trajectory {
        "line" => 15.0,
        "circle" => 5.0,
        _ => unreachable!(),
    };
    let fmu = |name| {
        std::fs::canonicalize(common::built_fmu(name))
            .unwrap()
            .display()
            .to_string()
    };
    let toml = format!(
        r#"
step_size = 0.001
stop_time = {duration}
trials = {trials}

[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "{trajectory}"
duration = {duration}
learning = {learning}
psi = 7.5

[[fmu]]
name = "plant"
path = "{plant}"

[[connection]]
from = "plant.length"
to = "controller.length"

[[connection]]
from = "plant.velocity"
to = "controller.velocity"

[[connection]]
from = "controller.force"
to = "plant.force"

[[memory]]
from = "controller.memory_next"
to = "controller.memory"

[metrics]
error = "controller.error"
"#,
        controller = fmu("HlcsController"),
        plant = fmu("CkcmPlant"),
    );
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("scenario.toml");
    std::fs::write(&scenario, toml).unwrap();
    let out = dir.path().join("out");
    common::orchestrator()
        .arg("run")
        .arg(&scenario)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let mut rows = summary.lines().map(|l| l.split(',').collect::<Vec<_>>());
    let header = rows.next().expect("summary.csv has a header");
    let max = header
        .iter()
        .position(|h| *h == "max")
        .expect("summary.csv has a `max` column");
    let max_mm: Vec<f64> = rows.map(|r| r[max].parse::<f64>().unwrap() * 1e3).collect();
    assert_eq!(max_mm.len(), trials, "one summary row per trial");
    max_mm
}

#[test]
fn circle_pid_only_matches_the_independent_model() {
    let max = max_errors_mm("circle", false, 2);
    // Without learning every trial repeats the first.
    assert_eq!(max[0], max[1], "PID-only trials differ: {max:?}");
    assert_figure("circle PID max leg error (mm)", max[0], "1.409");
}

#[test]
fn line_pid_only_matches_the_independent_model() {
    let max = max_errors_mm("line", false, 2);
    assert_eq!(max[0], max[1], "PID-only trials differ: {max:?}");
    assert_figure("line PID max leg error (mm)", max[0], "0.6205");
}

#[test]
fn circle_hlcs_trials_match_the_independent_model() {
    let max = max_errors_mm("circle", true, 5);
    for (k, printed) in ["1.409", "0.177", "0.136", "0.184", "0.286"]
        .iter()
        .enumerate()
    {
        assert_figure(
            &format!("circle HLCS trial {k} max leg error (mm)"),
            max[k],
            printed,
        );
    }
}

#[test]
fn line_hlcs_trials_match_the_independent_model() {
    let max = max_errors_mm("line", true, 5);
    for (k, printed) in ["0.6205", "0.0477", "0.0178", "0.0078", "0.0043"]
        .iter()
        .enumerate()
    {
        assert_figure(
            &format!("line HLCS trial {k} max leg error (mm)"),
            max[k],
            printed,
        );
    }
}
