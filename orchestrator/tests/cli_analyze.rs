//! `orchestrator analyze`: the summary, CSV and SVG it writes for a circle scenario, the
//! command-line overrides, and clear errors for bad settings (nothing written then).

mod common;

use std::path::{Path, PathBuf};

use common::{built_fmu, orchestrator, repackage};

/// The paper's circle under HLCS, with an optional `[memory.update]` table body.
fn circle(dir: &Path, update: Option<&str>) -> PathBuf {
    circle_with(
        dir,
        &built_fmu("HlcsController"),
        &built_fmu("CkcmPlant"),
        update,
    )
}

/// [`circle`] with the given controller and plant FMUs.
fn circle_with(dir: &Path, controller: &Path, plant: &Path, update: Option<&str>) -> PathBuf {
    let mut text = format!(
        r#"step_size = 0.001
stop_time = 5.0
trials = 50

[[fmu]]
name = "controller"
path = {:?}
[fmu.parameters]
trajectory = "circle"
duration = 5.0

[[fmu]]
name = "plant"
path = {:?}

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
"#,
        controller, plant,
    );
    if let Some(u) = update {
        text.push_str("[memory.update]\n");
        text.push_str(u);
    }
    let path = dir.join("circle.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn analyze(scenario: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    // A hang (as huge gains once caused) fails the test instead of holding CI.
    orchestrator()
        .arg("analyze")
        .arg(scenario)
        .arg("--out")
        .arg(out)
        .args(extra)
        .timeout(std::time::Duration::from_secs(120))
        .output()
        .unwrap()
}

#[test]
fn robust_setting_on_the_circle() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = circle(dir.path(), None);
    let out = dir.path().join("out");
    let o = analyze(
        &scenario,
        &out,
        &["--order", "4", "--cutoff", "8", "--lead", "25"],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        stdout.contains("Butterworth order 4 cutoff 8 Hz") && stdout.contains("lead δ = 25"),
        "{stdout}"
    );
    assert!(
        stdout.contains("Prediction (sustained masses): **converges**"),
        "{stdout}"
    );
    assert!(
        stdout.contains("Frozen worst case (every pose, conservative): **diverges**"),
        "{stdout}"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("summary.md")).unwrap(),
        stdout
    );
    // One row per frequency, 2 + 3 × 6 columns, factors finite and non-negative.
    let csv = std::fs::read_to_string(out.join("convergence.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap().split(',').count(), 20);
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert!(rows.len() > 1000);
    assert!(rows.iter().flatten().all(|x| x.is_finite() && *x >= 0.0));
    // The frequencies rise to just below Nyquist; the filter gain falls from 1 to ~0.
    assert!(rows.windows(2).all(|w| w[1][0] > w[0][0]));
    assert!(rows.last().unwrap()[0] < 500.0 && rows.last().unwrap()[0] > 499.0);
    assert!((rows[0][1] - 1.0).abs() < 1e-9 && rows.last().unwrap()[1] < 1e-9);
    let svg = std::fs::read_to_string(out.join("convergence.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("mode 6"), "svg");
}

#[test]
fn overrides_change_the_verdict() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = circle(dir.path(), None);
    let out = dir.path().join("out");
    // The paper's update diverges; gains × 1.5 diverge even with the robust setting.
    for extra in [
        &[][..],
        &[
            "--order",
            "4",
            "--cutoff",
            "8",
            "--lead",
            "25",
            "--gain-scale",
            "1.5",
        ][..],
    ] {
        let o = analyze(&scenario, &out, extra);
        let stdout = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(
            stdout.contains("Prediction (sustained masses): **diverges**"),
            "{extra:?}: {stdout}"
        );
    }
}

#[test]
fn bad_settings_are_named_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = circle(dir.path(), None);
    let out = dir.path().join("out");
    for (extra, expected) in [
        // A value from the command line is named as such, not blamed on the file.
        (
            &["--cutoff", "500"][..],
            "memory update with --cutoff 500: cutoff = 500",
        ),
        (
            &["--no-filter", "--order", "3"][..],
            "the argument '--no-filter' cannot be used with '--order <ORDER>'",
        ),
        (&["--cutoff", "NaN"][..], "cutoff = NaN"),
        (
            &["--cutoff", "8", "--order", "0"][..],
            "'0' for '--order <ORDER>': the Butterworth order must be an integer between 1 and 8",
        ),
        // The bound of a scenario's order (run refuses order = 20), not a looser one.
        (
            &["--cutoff", "8", "--order", "20"][..],
            "'20' for '--order <ORDER>': the Butterworth order must be an integer between 1 and 8",
        ),
        (
            &["--lead", "5000"][..],
            "lead = 5000 samples must be below the 5000",
        ),
        (&["--order", "4"][..], "--order needs a cutoff"),
        (&["--gain", "inf"][..], "gain = inf"),
        (&["--gain-scale=-1"][..], "--gain-scale = -1"),
        // A negative number after an option is its value, not an unknown option.
        (&["--gain-scale", "-1"][..], "--gain-scale = -1"),
        (
            &["--dwell", "-1"][..],
            "--dwell = -1 s must be zero or positive",
        ),
        (
            &["--dwell", "inf"][..],
            "--dwell = inf s must be zero or positive",
        ),
        (&["--stride", "0"][..], "--stride = 0 s must be positive"),
        (
            &["--lead", "-1"][..],
            "invalid value '-1' for '--lead <LEAD>': must be a whole number of samples, zero or more",
        ),
        (
            &["--lead", "2.5"][..],
            "invalid value '2.5' for '--lead <LEAD>': must be a whole number of samples, zero or more",
        ),
        // A negative exponent is a value too, which clap's own number test misses.
        (
            &["--dwell", "-1e-300"][..],
            "--dwell = -1e-300 s must be zero or positive",
        ),
        // Five billion poses on the 5 s circle: refused before any is sampled, the stride
        // shown short, not as 300 zeros.
        (
            &["--stride", "1e-9"][..],
            "--stride = 1e-9 s samples more than 1e5 poses along the 5 s reference; \
             use at least 5e-5 s",
        ),
        (
            &["--stride", "1e-300"][..],
            "--stride = 1e-300 s samples more than 1e5 poses",
        ),
    ] {
        let o = analyze(&scenario, &out, extra);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{extra:?} should fail");
        assert!(stderr.contains(expected), "{extra:?}: {stderr}");
        assert!(!out.exists(), "{extra:?} wrote {}", out.display());
    }
    // A file where the output folder goes, or above it, is named.
    let taken = dir.path().join("taken");
    std::fs::write(&taken, "a user's file").unwrap();
    for out in [taken.clone(), taken.join("out")] {
        let o = analyze(&scenario, &out, &[]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success());
        let expected = format!("{} is a file, not a folder", taken.display());
        assert!(stderr.contains(&expected), "{stderr}");
    }
    assert_eq!(std::fs::read_to_string(&taken).unwrap(), "a user's file");
}

#[test]
fn no_learning_at_all_converges_and_huge_gains_are_refused_or_shown_short() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = circle(dir.path(), None);
    let out = dir.path().join("out");
    // Every factor 0: the chart's log axis once had no finite lower bound and never
    // finished; this run must end (it takes well under a second when it works).
    let o = orchestrator()
        .arg("analyze")
        .arg(&scenario)
        .arg("--out")
        .arg(&out)
        .args(["--forgetting", "0", "--gain", "0"])
        .timeout(std::time::Duration::from_secs(120))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{stdout}");
    assert!(
        stdout.contains("Prediction (sustained masses): **converges**; peak factor 0.000"),
        "{stdout}"
    );
    assert!(
        std::fs::read_to_string(out.join("convergence.svg"))
            .unwrap()
            .starts_with("<svg")
    );

    // Gains that overflow are refused by name; huge finite ones print with an exponent.
    let o = analyze(
        &scenario,
        &dir.path().join("over"),
        &["--gain-scale", "1e304"],
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        stderr.contains("--gain-scale = 1e304 makes the learning gain Φ overflow to inf"),
        "{stderr}"
    );
    // So is an update gain whose convergence factor overflows: before, the chart's axis
    // ended at inf and `analyze` never finished.
    let over = dir.path().join("over_gain");
    let o = analyze(&scenario, &over, &["--gain", "1e308"]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        stderr.contains("gain g = 1e308, the convergence factor overflows to inf"),
        "{stderr}"
    );
    assert!(!over.exists());
    // A finite peak near the largest double (1.6e308): the chart's margin above it stays
    // finite, so the analysis finishes (it hung there too).
    let near = dir.path().join("near");
    let robust = [
        "--order", "4", "--cutoff", "8", "--lead", "25", "--gain", "8e307",
    ];
    let o = analyze(&scenario, &near, &robust);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("peak factor 1.617e308"), "{stdout}");
    assert!(near.join("convergence.svg").is_file());
    let o = analyze(
        &scenario,
        &dir.path().join("huge"),
        &["--gain-scale", "1e200"],
    );
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    let verdict = stdout
        .lines()
        .find(|l| l.starts_with("- Prediction (sustained masses)"))
        .unwrap();
    assert!(
        verdict.contains("**diverges**; peak factor ")
            && verdict.contains("e2")
            && verdict.len() < 120,
        "{verdict}"
    );
}

/// A copy of the built FMU `name` whose model description has `from` renamed to `to`.
fn renamed(dir: &Path, name: &str, from: &str, to: &str) -> PathBuf {
    let out = dir.join(format!("{name}.fmu"));
    repackage(&built_fmu(name), &out, |entry, bytes| {
        if entry != "modelDescription.xml" {
            return Some(bytes);
        }
        let xml = String::from_utf8(bytes).unwrap();
        let edited = xml.replace(&format!("name=\"{from}\""), &format!("name=\"{to}\""));
        assert_ne!(edited, xml, "{from} is not in {name}'s model description");
        Some(edited.into_bytes())
    });
    out
}

#[test]
fn a_parameter_renamed_in_the_xml_is_an_error_not_a_default() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let plant = renamed(dir.path(), "CkcmPlant", "rod_mass", "rod_mass_kg");
    let scenario = circle_with(dir.path(), &built_fmu("HlcsController"), &plant, None);
    let o = analyze(&scenario, &out, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "a plant without rod_mass was analysed");
    assert!(
        stderr.contains("FMU \"plant\"") && stderr.contains("has no parameter rod_mass"),
        "{stderr}"
    );
    assert!(!out.exists());

    let controller = renamed(
        dir.path(),
        "HlcsController",
        "model.gravity",
        "model.gravitation",
    );
    let scenario = circle_with(dir.path(), &controller, &built_fmu("CkcmPlant"), None);
    let o = analyze(&scenario, &out, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "model.gravitation was ignored");
    assert!(
        stderr.contains("FMU \"controller\"")
            && stderr.contains("parameter `model.gravitation` is not a mechanism parameter"),
        "{stderr}"
    );
    assert!(!out.exists());
}

/// The analysis models one loop: with a second controller and plant in the scenario it
/// analyses the first pair and says so, naming the ones it leaves out.
#[test]
fn a_second_loop_is_named_as_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = circle(dir.path(), None);
    let mut text = std::fs::read_to_string(&scenario).unwrap();
    text += &format!(
        "\n[[fmu]]\nname = \"c2\"\npath = {:?}\n\n[[fmu]]\nname = \"p2\"\npath = {:?}\n",
        built_fmu("HlcsController"),
        built_fmu("CkcmPlant")
    );
    std::fs::write(&scenario, text).unwrap();
    let o = analyze(&scenario, &dir.path().join("out"), &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    for (model, first, other) in [
        ("CkcmPlant", "plant", "p2"),
        ("HlcsController", "controller", "c2"),
    ] {
        let says = format!(
            "the analysis models one loop: of the {model} FMUs it takes the first, \
             \"{first}\", not \"{other}\""
        );
        assert!(stderr.contains(&says), "{stderr}");
    }
}
