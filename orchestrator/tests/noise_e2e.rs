//! End-to-end: sensor noise of the plant in campaigns (docs/model.md §10). A per-trial seed
//! draws fresh noise in every trial and resumes identically, and the metrics report the true
//! error (reference − noise-free length), not the error the controller sees.
//!
//! Needs the packaged FMUs (`cargo xtask fmu`; `cargo xtask test` builds them first).

mod common;

use std::path::Path;

use common::{built_fmu, column, read_csv, tree};
use fmi2_import::Fmu;
use orchestrator::campaign::{CampaignOptions, TrialSummary, run_campaign};
use orchestrator::scenario::Scenario;

/// A 0.5 s line campaign of `trials` trials; `plant` holds extra plant parameter lines and
/// `metrics` the error lines of `[metrics]`.
fn scenario_text(trials: usize, plant: &str, metrics: &str) -> String {
    format!(
        r#"step_size = 0.001
stop_time = 0.5
trials = {trials}
[[fmu]]
name = "controller"
path = "{c}"
[fmu.parameters]
trajectory = "line"
duration = 0.5
[[fmu]]
name = "plant"
path = "{p}"
[fmu.parameters]
{plant}
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
[record]
variables = ["controller.error", "controller.length_ref", "plant.length", "plant.length_true", "plant.velocity", "plant.velocity_true"]
[metrics]
{metrics}
"#,
        c = built_fmu("HlcsController").display(),
        p = built_fmu("CkcmPlant").display()
    )
}

const TRUE_ERROR: &str = "reference = \"controller.length_ref\"\nlength = \"plant.length_true\"";
const MEASURED_ERROR: &str = "error = \"controller.error\"";

/// Runs (or resumes) the campaign of `text` in `dir`, stopping after `stop_after` trials.
fn run(text: &str, dir: &Path, resume: bool, stop_after: Option<usize>) -> Vec<TrialSummary> {
    run_on(text, dir, resume, stop_after, 1)
}

/// [`run`] with `lanes` trials at a time.
fn run_on(
    text: &str,
    dir: &Path,
    resume: bool,
    stop_after: Option<usize>,
    lanes: usize,
) -> Vec<TrialSummary> {
    std::fs::create_dir_all(dir).unwrap();
    let source = dir.join("in.toml");
    let (scenario, fmus) = Scenario::open_text(text, &source).unwrap_or_else(|e| panic!("{e}"));
    run_campaign(
        &scenario,
        text,
        fmus,
        &CampaignOptions {
            out_dir: dir.to_path_buf(),
            resume,
            fmu_logging: false,
            progress: false,
            stop_after,
            force: true,
            memory_limit_mib: None,
            crash_at: None,
            lanes,
        },
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Noise on length[leg] of a recorded trial: reported − true, per sample.
fn length_noise(dir: &Path, trial: usize, leg: usize) -> Vec<f64> {
    let rec = read_csv(&dir.join(format!("trials/trial_{trial:03}.csv")));
    let l = column(&rec, &format!("plant.length[{leg}]"));
    let t = column(&rec, &format!("plant.length_true[{leg}]"));
    l.iter().zip(t).map(|(a, b)| a - b).collect()
}

const NOISY: &str = "length_noise_sigma = 1e-5\nvelocity_noise_sigma = 1e-4\n";

#[test]
fn a_per_trial_seed_draws_fresh_noise_each_trial_and_resumes_identically() {
    let tmp = tempfile::tempdir().unwrap();
    let text = scenario_text(
        4,
        &format!("{NOISY}noise_seed = {{ base = 1000, per_trial = 1 }}"),
        TRUE_ERROR,
    );
    let whole = tmp.path().join("whole");
    run(&text, &whole, false, None);
    // Trial k's noise is the noise of seed 1000 + k: compare with single-trial runs.
    for k in [0, 3] {
        let single = tmp.path().join(format!("seed{k}"));
        let seed = 1000 + k;
        run(
            &scenario_text(1, &format!("{NOISY}noise_seed = {seed}"), TRUE_ERROR),
            &single,
            false,
            None,
        );
        for leg in 1..=6 {
            let a = length_noise(&whole, k, leg);
            let b = length_noise(&single, 0, leg);
            assert_eq!(a.len(), b.len());
            // Equal up to the rounding of (true + noise) − true at ~0.6 m.
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() < 1e-15, "trial {k} leg {leg}: {x} vs {y}");
            }
        }
    }
    // Consecutive trials draw different noise.
    for k in 0..3 {
        let a = length_noise(&whole, k, 1);
        let b = length_noise(&whole, k + 1, 1);
        let same = a
            .iter()
            .zip(&b)
            .filter(|(x, y)| (*x - *y).abs() < 1e-9)
            .count();
        assert!(same < 5, "trials {k} and {}: {same} equal samples", k + 1);
    }
    // Interrupted after 2 trials and resumed: the very same files. Two trials at a time
    // (each lane draws its trials' seeds; the resumed lane starts from the memory file):
    // the very same files again.
    let parts = tmp.path().join("parts");
    run(&text, &parts, false, Some(2));
    run(&text, &parts, true, None);
    let two_lanes = tmp.path().join("two-lanes");
    run_on(&text, &two_lanes, false, None, 2);
    let three_lanes = tmp.path().join("three-lanes");
    run_on(&text, &three_lanes, false, None, 3);
    let resumed_on_two = tmp.path().join("resumed-on-two");
    run(&text, &resumed_on_two, false, Some(1));
    run_on(&text, &resumed_on_two, true, None, 2);
    let a = tree(&whole);
    for (other, what) in [
        (&parts, "after resume"),
        (&two_lanes, "on two lanes"),
        (&three_lanes, "on three lanes"),
        (&resumed_on_two, "resumed on two lanes"),
    ] {
        let b = tree(other);
        assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
        for (k, v) in &a {
            assert!(v == &b[k], "{} differs {what}", k.display());
        }
    }
}

#[test]
fn metrics_report_the_true_error_not_the_measured_one() {
    let tmp = tempfile::tempdir().unwrap();
    // Large length noise (0.1 mm): the measured error is dominated by it.
    let plant = "length_noise_sigma = 1e-4\nnoise_seed = 5";
    let true_dir = tmp.path().join("true");
    let measured_dir = tmp.path().join("measured");
    let true_summary = run(&scenario_text(2, plant, TRUE_ERROR), &true_dir, false, None);
    let measured_summary = run(
        &scenario_text(2, plant, MEASURED_ERROR),
        &measured_dir,
        false,
        None,
    );
    for k in 0..2 {
        let rec = read_csv(&true_dir.join(format!("trials/trial_{k:03}.csv")));
        let mut true_max: f64 = 0.0;
        let mut measured_max: f64 = 0.0;
        for leg in 1..=6 {
            let r = column(&rec, &format!("controller.length_ref[{leg}]"));
            let l = column(&rec, &format!("plant.length_true[{leg}]"));
            let e = column(&rec, &format!("controller.error[{leg}]"));
            for i in 0..r.len() {
                true_max = true_max.max((r[i] - l[i]).abs());
                measured_max = measured_max.max(e[i].abs());
            }
        }
        let got = true_summary[k].legs.unwrap().overall.max;
        assert_eq!(got, true_max, "trial {k}: summary max vs recorded truth");
        assert_eq!(measured_summary[k].legs.unwrap().overall.max, measured_max);
        // The two really differ: the noise raises the measured error's peak.
        assert!(
            measured_max > true_max,
            "trial {k}: measured {measured_max} vs true {true_max}"
        );
    }
}

#[test]
fn without_noise_the_true_error_metrics_equal_the_controller_error_metrics() {
    let tmp = tempfile::tempdir().unwrap();
    let a = tmp.path().join("a");
    let b = tmp.path().join("b");
    run(&scenario_text(2, "", TRUE_ERROR), &a, false, None);
    run(&scenario_text(2, "", MEASURED_ERROR), &b, false, None);
    let sa = std::fs::read(a.join("summary.csv")).unwrap();
    let sb = std::fs::read(b.join("summary.csv")).unwrap();
    assert!(
        sa == sb,
        "summary.csv differs between the two error sources"
    );
    // The recorded trials (everything but the metrics source) are identical too.
    for k in 0..2 {
        let f = format!("trials/trial_{k:03}.csv");
        assert!(std::fs::read(a.join(&f)).unwrap() == std::fs::read(b.join(&f)).unwrap());
    }
}

#[test]
fn metrics_error_sources_are_exclusive_and_named_with_the_line() {
    let tmp = tempfile::tempdir().unwrap();
    for (metrics, expected) in [
        (format!("{MEASURED_ERROR}\n{TRUE_ERROR}"), "either error"),
        (
            "reference = \"controller.length_ref\"".to_string(),
            "either error",
        ),
        (
            "reference = \"controller.length_ref\"\nlength = \"plant.platform_mass\"".to_string(),
            "metrics.length \"plant.platform_mass\" must be six Real variables",
        ),
    ] {
        let text = scenario_text(1, "", &metrics);
        let err = Scenario::parse(&text, &tmp.path().join("s.toml"), |p| {
            Ok(Fmu::open(p)
                .map_err(|e| e.to_string())?
                .model_description()
                .clone())
        })
        .unwrap_err();
        assert!(err.message.contains(expected), "{err}");
        assert!(err.line.is_some(), "{err}");
    }
}
