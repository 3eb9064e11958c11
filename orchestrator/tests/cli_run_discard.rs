//! `run` when an FMU refuses a step with fmi2Discard: the campaign stops with a message
//! naming the trial, the time, the FMU and its last successful time, exits non-zero, and
//! keeps the trials that completed before, and the failed trial's rows.

mod common;

use std::path::Path;

use common::{foreign_fmu, number_after, orchestrator, read_csv, tree};

fn scenario(dir: &Path, discard: bool) -> std::path::PathBuf {
    let fmu = foreign_fmu(dir);
    let path = dir.join(format!("limit-{discard}.toml"));
    // A constant drive pushes x past the 0.1 m end stop within the first second.
    std::fs::write(
        &path,
        format!(
            r#"step_size = 0.01
stop_time = 2.0
trials = 1
[[fmu]]
name = "osc"
path = "{}"
[fmu.parameters]
drive = 50.0
x_limit = 0.1
discard_at_limit = {discard}
[record]
variables = ["osc.x"]
"#,
            fmu.display()
        ),
    )
    .unwrap();
    path
}

#[test]
fn discard_stops_the_run_naming_time_and_last_successful_time() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o = orchestrator()
        .arg("run")
        .arg(scenario(tmp.path(), true))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("trial 0, t = "), "{err}");
    assert!(
        err.contains("fmi2DoStep of FMU \"osc\" was discarded"),
        "{err}"
    );
    assert!(err.contains("last successful time"), "{err}");
    assert!(err.contains("beyond the end stop"), "{err}");
    // The time reported is the step that was refused, and the FMU says it got no further.
    let t = number_after(&err, "t = ");
    let last = number_after(&err, "last successful time ");
    assert!(t > 0.0 && t < 2.0, "{t}");
    // The FMU's time is cp + h of its last step, the master's t_0 + n·h: equal up to rounding.
    assert!(
        (last - t).abs() < 1e-9,
        "the refused step must leave the FMU at its start: {last} vs {t}"
    );
    // In a new folder a failed first trial keeps its rows up to the failure, and only them.
    let failed = out.join("trials/trial_000.failed.csv");
    assert!(
        err.contains(&format!(
            "\nno trial is complete in {}\nthe recording of trial 0 up to its failure is in {}",
            out.display(),
            failed.display()
        )),
        "{err}"
    );
    let files: Vec<_> = tree(&out).into_keys().collect();
    assert_eq!(files, [Path::new("trials/trial_000.failed.csv")]);
    let rows = read_csv(&failed);
    assert_eq!(rows.names, ["osc.x"]);
    assert_eq!(rows.time[0], 0.0);
    let end = *rows.time.last().unwrap();
    assert!(
        end < t && end >= t - 0.02 - 1e-12,
        "last row at {end} s, refused step at {t} s"
    );
}

/// The folder a failed first trial left holds no campaign: the next run starts there without
/// `--force` (failing again, it keeps its own rows), a run that succeeds there leaves no
/// failed recording, and a forced run whose first trial fails never writes into the
/// campaign it would have replaced.
#[test]
fn a_failed_first_trial_keeps_its_rows_only_where_no_campaign_is() {
    let tmp = tempfile::tempdir().unwrap();
    let failing = scenario(tmp.path(), true);
    let out = tmp.path().join("out");
    failing_run(&failing, &out, &[]);
    let first = tree(&out);
    let err = failing_run(&failing, &out, &[]);
    assert!(err.contains("was discarded"), "{err}");
    assert!(!err.contains("already holds"), "{err}");
    assert_eq!(tree(&out), first, "the second failure keeps the same rows");

    let passing = tmp.path().join("passing.toml");
    std::fs::write(
        &passing,
        std::fs::read_to_string(&failing)
            .unwrap()
            .replace("x_limit = 0.1", "x_limit = 1000.0"),
    )
    .unwrap();
    let o = common::run_scenario(&passing, &out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("trials/trial_000.csv").is_file());
    assert!(!out.join("trials/trial_000.failed.csv").exists());

    let campaign = tree(&out);
    let err = failing_run(&failing, &out, &["--force"]);
    assert!(err.contains("was discarded"), "{err}");
    assert!(!err.contains("up to its failure"), "{err}");
    assert_eq!(
        tree(&out),
        campaign,
        "a failed forced run keeps the old campaign"
    );
}

#[test]
fn error_at_the_end_stop_is_reported_as_a_failed_call() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o = orchestrator()
        .arg("run")
        .arg(scenario(tmp.path(), false))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("fmi2DoStep of FMU \"osc\" failed"), "{err}");
    assert!(!err.contains("discarded"), "{err}");
}

/// Runs `scenario` into `out` with `args` after it, asserts that the run fails, and gives
/// its stderr.
fn failing_run(scenario: &Path, out: &Path, args: &[&str]) -> String {
    let o = common::run_scenario(scenario, out, args);
    assert!(!o.status.success());
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// An output that is NaN or infinite with fmi2OK (here: a stiff spring that one explicit
/// substep blows up in trial 1) stops the campaign like a failed call: the message names the
/// trial, the time, the FMU and the variable, the exit is non-zero, and trial 0 is kept,
/// with trial 1's recording up to the failure beside it, on one lane and on two; so after a
/// resume, and in a forced new campaign over the folder.
#[test]
fn a_non_finite_output_stops_the_run_and_keeps_the_completed_trials() {
    let one = non_finite_output_run("1");
    let two = non_finite_output_run("2");
    assert_eq!(one, two, "trial 1's recording on one lane and on two");
}

/// Runs the campaign with `--jobs jobs`, checks it, and gives the failed trial's recording.
fn non_finite_output_run(jobs: &str) -> String {
    let tmp = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(tmp.path());
    let scenario = tmp.path().join("stiff.toml");
    std::fs::write(
        &scenario,
        format!(
            r#"step_size = 0.0078125
stop_time = 0.5
trials = 3
[[fmu]]
name = "osc"
path = "{}"
[fmu.parameters]
mass = 1e-9
stiffness = {{ base = 0.0, per_trial = 1e12 }}
x_limit = 1e308
x0 = 1.0
substeps = 1
[record]
variables = ["osc.x", "osc.v"]
"#,
            fmu.display()
        ),
    )
    .unwrap();
    let out = tmp.path().join("out");
    let err = failing_run(&scenario, &out, &["--jobs", jobs]);
    assert!(err.contains("trial 1, t = "), "{err}");
    assert!(err.contains("FMU \"osc\" returned osc.x = "), "{err}");
    assert!(err.contains("not finite"), "{err}");
    // The trials kept are named; no resume is suggested, since it would meet the same step.
    assert!(
        err.contains(&format!("\ntrial 0 is kept in {}\n", out.display())),
        "{err}"
    );
    assert!(!err.contains("--resume"), "{err}");
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(summary.lines().count(), 2, "trial 0 only: {summary}");
    assert!(out.join("trials/trial_000.csv").exists());
    assert!(!out.join("trials/trial_001.csv").exists());
    // Trial 1's rows up to the failure: one per completed step. The error gives the time of
    // the non-finite output, the end of the failed step, so the last row is two steps before.
    let failed = out.join("trials/trial_001.failed.csv");
    assert!(
        err.contains(&format!(
            "\nthe recording of trial 1 up to its failure is in {}",
            failed.display()
        )),
        "{err}"
    );
    let t = number_after(&err, "trial 1, t = ");
    let text = std::fs::read_to_string(&failed).unwrap();
    let rows = read_csv(&failed);
    assert_eq!(rows.names, ["osc.x", "osc.v"], "{text}");
    let times = &rows.time;
    assert!(!times.is_empty(), "{text}");
    assert_eq!(times[0], 0.0);
    let last = *times.last().unwrap();
    assert!(
        (last - (t - 2.0 * 0.0078125)).abs() < 1e-12,
        "last row at {last} s, failure at {t} s"
    );
    // A resume runs trial 1 again: it fails the same way and keeps its recording again.
    failing_run(&scenario, &out, &["--jobs", jobs, "--resume"]);
    assert_eq!(std::fs::read_to_string(&failed).unwrap(), text);
    // A forced new campaign over this one (its own failed file gone): its trial 0 replaces
    // the folder's campaign, so its failed trial 1 keeps its recording there too.
    std::fs::remove_file(&failed).unwrap();
    failing_run(&scenario, &out, &["--jobs", jobs, "--force"]);
    assert_eq!(
        std::fs::read_to_string(&failed).unwrap(),
        text,
        "after --force"
    );
    text
}

/// A failed first trial's file that an earlier run left is removed before a new run starts,
/// so that no message names it as the new run's: not when the new run fails before its first
/// step, nor when it fails in a folder that holds more (where it keeps nothing).
#[test]
fn an_earlier_failed_first_trial_is_never_named_as_this_runs() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let stale = out.join("trials/trial_000.failed.csv");
    let leave_stale = || {
        std::fs::create_dir_all(stale.parent().unwrap()).unwrap();
        std::fs::write(&stale, "time,osc.x\n0,1\n").unwrap();
    };
    let at_start = tmp.path().join("start.toml");
    std::fs::write(
        &at_start,
        std::fs::read_to_string(scenario(tmp.path(), true))
            .unwrap()
            .replace("drive = 50.0", "drive = 50.0\nx0 = 6.0"),
    )
    .unwrap();
    leave_stale();
    let err = failing_run(&at_start, &out, &[]);
    assert!(err.contains("trial 0"), "{err}");
    assert!(!err.contains("up to its failure"), "{err}");
    assert!(!stale.exists(), "the earlier run's rows are gone");

    leave_stale();
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    let err = failing_run(&scenario(tmp.path(), true), &out, &["--force"]);
    assert!(err.contains("was discarded"), "{err}");
    assert!(!err.contains("up to its failure"), "{err}");
    let files: Vec<_> = tree(&out).into_keys().collect();
    assert_eq!(
        files,
        [Path::new("notes.txt")],
        "only the user's file is left"
    );
}

/// A trial that fails before its first step (here trial 2 starts past the end stop, so
/// fmi2ExitInitializationMode fails) has no rows: no failed trial's file is written, on one
/// lane and on two. On one lane the recording buffer it would have filled is one an earlier
/// trial's writer handed back, still holding that trial's rows, so a file written from it
/// would have shown another trial.
#[test]
fn a_trial_that_fails_at_its_start_leaves_no_recording() {
    let tmp = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(tmp.path());
    let scenario = tmp.path().join("start.toml");
    std::fs::write(
        &scenario,
        format!(
            r#"step_size = 0.0078125
stop_time = 20.0
trials = 4
[[fmu]]
name = "osc"
path = "{}"
[fmu.parameters]
x0 = {{ base = 0.0, per_trial = 6.0 }}
substeps = 5000
[record]
variables = ["osc.x", "osc.v"]
"#,
            fmu.display()
        ),
    )
    .unwrap();
    for jobs in ["1", "2"] {
        let out = tmp.path().join(format!("out-{jobs}"));
        let err = failing_run(&scenario, &out, &["--jobs", jobs]);
        assert!(err.contains("trial 2"), "{err}");
        assert!(err.contains("trials 0–1 are kept"), "{err}");
        assert!(!err.contains("up to its failure"), "{err}");
        let mut files: Vec<String> = std::fs::read_dir(out.join("trials"))
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        files.sort();
        assert_eq!(files, ["trial_000.csv", "trial_001.csv"], "--jobs {jobs}");
    }
}
