//! Hostile input and interruptions outside campaign folders: values outside a variable's
//! declared range or not finite, a variable recorded twice, control characters in a model
//! description, an FMU that discards a step, fmpy's default output interval, and signals
//! with the FMU extraction folders they must not leave behind.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use common::{foreign_fmu, foreign_fmu_with, foreign_xml, orchestrator, read_csv};

fn scenario(dir: &Path, parameters: &str, record: &str) -> PathBuf {
    let fmu = foreign_fmu(dir);
    let path = dir.join("s.toml");
    std::fs::write(
        &path,
        format!(
            "step_size = 0.01\nstop_time = 0.1\n[[fmu]]\nname = \"osc\"\npath = \"{}\"\n\
             [fmu.parameters]\n{parameters}\n[record]\nvariables = [{record}]\n",
            fmu.display()
        ),
    )
    .unwrap();
    path
}

/// Runs the scenario, which must fail before anything is written; returns stderr.
fn run_fails(dir: &Path, scenario: &Path) -> String {
    let out = dir.join("out");
    let o = orchestrator()
        .arg("run")
        .arg(scenario)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(!out.exists());
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn scenario_values_outside_the_declared_range_or_not_finite_name_file_and_line() {
    let tmp = tempfile::tempdir().unwrap();
    // Line 7 is the first parameter.
    let s = scenario(tmp.path(), "substeps = 0", "\"osc.x\"");
    let err = run_fails(tmp.path(), &s);
    assert!(err.contains("s.toml:7:"), "{err}");
    assert!(
        err.contains("\"substeps\" = 0 is below its declared min = 1"),
        "{err}"
    );
    let s = scenario(tmp.path(), "stiffness = 1.0\nmass = nan", "\"osc.x\"");
    let err = run_fails(tmp.path(), &s);
    assert!(err.contains("s.toml:8:"), "{err}");
    assert!(
        err.contains("'nan' is not a finite number ('mass' is a Real)"),
        "{err}"
    );
    let s = scenario(tmp.path(), "damping = -inf", "\"osc.x\"");
    let err = run_fails(tmp.path(), &s);
    assert!(err.contains("not a finite number"), "{err}");
    let s = scenario(tmp.path(), "mass = 1e-12", "\"osc.x\"");
    let err = run_fails(tmp.path(), &s);
    assert!(err.contains("below its declared min = 1e-9"), "{err}");
}

#[test]
fn a_variable_recorded_twice_is_an_error_with_its_line() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "", "\"osc.x\", \"osc.v\", \"osc.x\"");
    let err = run_fails(tmp.path(), &s);
    assert!(err.contains("s.toml:9:"), "{err}");
    assert!(
        err.contains("record: \"osc.x\" is listed twice (already recorded by \"osc.x\")"),
        "{err}"
    );
}

#[test]
fn simulate_set_checks_the_declared_range() {
    let tmp = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(tmp.path());
    let out = tmp.path().join("out.csv");
    for (set, says) in [
        (
            "substeps=0",
            "\"substeps\" = 0 is below its declared min = 1",
        ),
        ("mass=-1", "\"mass\" = -1 is below its declared min"),
    ] {
        let o = orchestrator()
            .arg("simulate")
            .arg(&fmu)
            .args(["--set", set, "--output"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(says), "{err}");
        assert!(err.contains(&format!("--set {set}")), "{err}");
        assert!(!out.exists());
    }
}

#[test]
fn info_escapes_control_characters() {
    let tmp = tempfile::tempdir().unwrap();
    let xml = foreign_xml()
        .replace(
            "name=\"drive\"",
            // A flat name may hold control characters but tab, line feed and return.
            "name=\"dri&#27;ve\" description=\"x&#27;[2J&#13;forged\"",
        )
        .replace("description=\"External force on the mass\"", "");
    let fmu = foreign_fmu_with(tmp.path(), "Ctl.fmu", &xml);
    let o = orchestrator().arg("info").arg(&fmu).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        !text.chars().any(|c| c.is_control() && c != '\n'),
        "raw control characters in: {text:?}"
    );
    assert!(text.contains("dri\\u{1b}ve"), "{text}");
    assert!(text.contains("x\\u{1b}[2J\\u{d}forged"), "{text}");
}

#[test]
fn simulate_ends_cleanly_when_the_fmu_discards_a_step() {
    let tmp = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(tmp.path());
    let out = tmp.path().join("out.csv");
    let o = orchestrator()
        .arg("simulate")
        .arg(&fmu)
        .args([
            "--set",
            "drive=50",
            "--set",
            "x_limit=0.1",
            "--set",
            "discard_at_limit=true",
            "--output",
        ])
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("notice: fmi2DoStep from t = "), "{err}");
    assert!(err.contains("returned fmi2Discard"), "{err}");
    assert!(err.contains("beyond the end stop"), "{err}");
    let rec = read_csv(&out);
    let x = common::column(&rec, "x");
    // Every completed step is kept, and the refused one is not: x never passes the stop.
    let h = 0.0078125;
    assert!(
        rec.len() > 2 && *rec.time.last().unwrap() < 2.0,
        "{}",
        rec.len()
    );
    assert!(x.iter().all(|x| x.abs() <= 0.1), "{x:?}");
    assert!(
        x.last().unwrap().abs() > 0.05,
        "it stopped near the end stop"
    );
    for (n, t) in rec.time.iter().enumerate() {
        assert_eq!(*t, n as f64 * h);
    }
    assert!(
        err.contains(&format!(
            "ends at t = {} s with {} rows",
            rec.time.last().unwrap(),
            rec.len()
        )),
        "{err}"
    );
}

#[test]
fn without_a_model_step_the_output_interval_is_fmpys() {
    let tmp = tempfile::tempdir().unwrap();
    let xml = foreign_xml().replace(" stepSize=\"0.0078125\"", "");
    assert_ne!(xml, foreign_xml());
    let fmu = foreign_fmu_with(tmp.path(), "NoStep.fmu", &xml);
    // fmpy 0.3.32, util.auto_interval: a span of 2 s gives 10^(round(log10 2) − 3) = 1 ms,
    // i.e. 2000 steps, which it scales by 4 to 4 ms (500 steps); 0.5 s gives 1 ms (500 steps
    // of 10^(round(log10 0.5) − 3) = 1 ms, halved when ≤ 500: 0.5 ms).
    for (stop, interval) in [("2", 0.004), ("0.5", 0.0005)] {
        let out = tmp.path().join(format!("out-{stop}.csv"));
        let o = orchestrator()
            .arg("simulate")
            .arg(&fmu)
            .args(["--stop-time", stop, "--output"])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let rec = read_csv(&out);
        let span: f64 = stop.parse().unwrap();
        assert_eq!(
            rec.len(),
            (span / interval).round() as usize + 1,
            "stop {stop}"
        );
        assert!((rec.time[1] - interval).abs() < 1e-15, "{}", rec.time[1]);
    }
}

/// Extraction folders under `temp`.
fn extraction_dirs(temp: &Path) -> Vec<String> {
    std::fs::read_dir(temp)
        .unwrap()
        .filter_map(Result::ok)
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(fmi2_import::EXTRACTION_PREFIX))
        .collect()
}

/// Starts `command` with its temporary folder in `temp`, waits until `ready()` says so (at
/// most a minute), runs `check`, sends SIG`signal`, and returns the exit code and what went
/// to stderr.
fn interrupt(
    mut command: Command,
    temp: &Path,
    mut ready: impl FnMut() -> bool,
    signal: &str,
    check: impl FnOnce(),
) -> (Option<i32>, String) {
    let child = command
        .env("TMPDIR", temp)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !ready() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(5));
    }
    check();
    let status = Command::new("kill")
        .args([&format!("-{signal}"), &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let output = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&output.stderr).into_owned();
    (output.status.code(), err)
}

#[test]
fn signals_remove_the_extraction_folders_and_stale_ones_are_reaped() {
    let tmp = tempfile::tempdir().unwrap();
    let temp = tmp.path().join("temp");
    std::fs::create_dir(&temp).unwrap();
    // A long campaign: 10^5 steps per trial, many trials.
    let fmu = foreign_fmu(tmp.path());
    let s = tmp.path().join("long.toml");
    std::fs::write(
        &s,
        format!(
            "step_size = 0.001\nstop_time = 100\ntrials = 1000\n[[fmu]]\nname = \"osc\"\npath = \"{}\"\n",
            fmu.display()
        ),
    )
    .unwrap();
    // Two lanes unpack a second copy of the FMU; it goes too.
    for (signal, copies) in [("INT", 2), ("TERM", 1), ("HUP", 1)] {
        let out = tmp.path().join(format!("out-{signal}"));
        let mut run = std::process::Command::new(env!("CARGO_BIN_EXE_orchestrator"));
        run.arg("run")
            .arg(&s)
            .arg("--out")
            .arg(&out)
            .arg(format!("--jobs={copies}"));
        let (code, err) = interrupt(
            run,
            &temp,
            || out.join("progress.toml").exists(),
            signal,
            || {
                assert_eq!(extraction_dirs(&temp).len(), copies, "the FMU is unpacked");
            },
        );
        assert_eq!(code, Some(130), "SIG{signal}");
        // The command to continue names the saved scenario, which holds the trial count run.
        assert!(
            err.contains(&format!(
                "interrupted: removed {copies} FMU extraction folder(s); \
                 `orchestrator run {} --out {} --resume` continues the campaign\n",
                out.join("scenario.toml").display(),
                out.display()
            )),
            "{err}"
        );
        assert!(
            extraction_dirs(&temp).is_empty(),
            "SIG{signal} left {:?}",
            extraction_dirs(&temp)
        );
    }

    // A study's interruption points to `paper --resume`, not to the other commands'.
    let study = tmp.path().join("study");
    let mut paper = std::process::Command::new(env!("CARGO_BIN_EXE_orchestrator"));
    paper
        .args(["paper", "--jobs", "1", "--trials", "1000", "--fmu-dir"])
        .arg(common::built_fmu("CkcmPlant").parent().unwrap())
        .arg("--out")
        .arg(&study);
    let ready = study.join("line/pid/progress.toml");
    let (code, err) = interrupt(paper, &temp, || ready.exists(), "TERM", || {});
    assert_eq!(code, Some(130));
    assert!(
        err.contains(
            "FMU extraction folder(s); `paper --resume` continues the study, with the same \
             options\n"
        ),
        "{err}"
    );
    assert!(extraction_dirs(&temp).is_empty());

    // Interrupted before anything was kept (here while still reading its scenario from a
    // FIFO), `run` says there is nothing to resume instead of offering `--resume`.
    let fifo = tmp.path().join("scenario.fifo");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let out = tmp.path().join("out-fifo");
    let mut run = std::process::Command::new(env!("CARGO_BIN_EXE_orchestrator"));
    run.arg("run").arg(&fifo).arg("--out").arg(&out);
    // Opening the write end without blocking succeeds only once the run opened the read
    // end, which it does after installing its signal handler; held open and unwritten, it
    // keeps the run waiting for the rest of its scenario.
    let mut writer = None;
    let opened = || {
        use std::os::unix::fs::OpenOptionsExt;
        // Linux's O_NONBLOCK (the tests do not depend on libc for one constant).
        const O_NONBLOCK: i32 = 0o4000;
        match std::fs::OpenOptions::new()
            .write(true)
            .custom_flags(O_NONBLOCK)
            .open(&fifo)
        {
            Ok(w) => writer = Some(w),
            Err(e) => assert_eq!(e.raw_os_error(), Some(6), "ENXIO until a reader opens: {e}"),
        }
        writer.is_some()
    };
    let (code, err) = interrupt(run, &temp, opened, "INT", || {});
    assert!(writer.is_some(), "the run never opened its scenario");
    assert_eq!(code, Some(130), "{err}");
    assert!(
        err.contains(
            "FMU extraction folder(s); nothing was kept yet, so there is nothing to resume\n"
        ),
        "{err}"
    );
    assert!(
        !out.exists(),
        "an interrupted run that kept nothing leaves no folder"
    );

    // SIGKILL leaves the folder; the next start reaps it (its pid is dead), and leaves
    // folders of running processes alone.
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .arg("run")
        .arg(&s)
        .arg("--out")
        .arg(tmp.path().join("out-KILL"))
        .arg("--jobs=1")
        .env("TMPDIR", &temp)
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while extraction_dirs(&temp).is_empty() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(5));
    }
    std::thread::sleep(Duration::from_millis(200));
    child.kill().unwrap();
    child.wait().unwrap();
    let stale = extraction_dirs(&temp);
    assert_eq!(stale.len(), 1);
    let alive = temp.join(format!(
        "{}{}-keep",
        fmi2_import::EXTRACTION_PREFIX,
        std::process::id()
    ));
    std::fs::create_dir(&alive).unwrap();
    let o = orchestrator()
        .arg("info")
        .arg(&fmu)
        .env("TMPDIR", &temp)
        .output()
        .unwrap();
    assert!(o.status.success());
    let left = extraction_dirs(&temp);
    assert_eq!(left.len(), 1, "{left:?}");
    assert!(!left.contains(&stale[0]), "the stale folder was reaped");
    assert!(alive.exists(), "a live process's folder is kept");
}
