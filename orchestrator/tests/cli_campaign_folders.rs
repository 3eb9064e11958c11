//! Campaign folders that cannot be lost: one run per folder (a lock naming its holder), no
//! new run over an existing campaign without `--force` (and then only once its first trial
//! succeeded), a memory estimate refused before anything is allocated, memory files with a
//! checksum, and a kill at every file operation of a campaign resumed to the very bytes of an
//! uninterrupted run. The foreign test FMU keeps these campaigns to milliseconds.

mod common;

use std::path::{Path, PathBuf};

use common::{foreign_fmu, orchestrator, run_scenario as run, tree};
use orchestrator::campaign::{DirLock, LOCK_FILE};

/// A 3-trial campaign whose memory (the last trial's x, fed back as drive) changes every
/// trial, so a resume that lost or garbled the memory shows in the results.
fn scenario(dir: &Path, extra: &str) -> PathBuf {
    let fmu = foreign_fmu(dir);
    let path = dir.join("osc.toml");
    std::fs::write(
        &path,
        format!(
            r#"step_size = 0.01
stop_time = 0.5
trials = 3
{extra}
[[fmu]]
name = "osc"
path = "{}"
[fmu.parameters]
x0 = 0.1
[[memory]]
from = "osc.x"
to = "osc.drive"
[record]
variables = ["osc.x", "osc.v"]
"#,
            fmu.display()
        ),
    )
    .unwrap();
    path
}

/// In `dir`: the scenario, its campaign run whole (`whole`) and stopped after its first
/// trial (`out`).
fn whole_and_stopped(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let s = scenario(dir, "");
    let (whole, out) = (dir.join("whole"), dir.join("out"));
    assert!(run(&s, &whole, &[]).status.success());
    assert!(run(&s, &out, &["--stop-after", "1"]).status.success());
    (s, whole, out)
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn assert_same_tree(expected: &Path, actual: &Path, when: &str) {
    let (a, b) = (tree(expected), tree(actual));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "file lists differ {when}"
    );
    for (k, v) in &a {
        assert!(v == &b[k], "{} differs {when}", k.display());
    }
}

#[test]
fn a_locked_folder_is_refused_naming_the_holder() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let out = tmp.path().join("out");
    let lock = DirLock::acquire(&out).unwrap();
    for args in [&[][..], &["--resume"][..], &["--force"][..]] {
        let o = run(&s, &out, args);
        assert!(!o.status.success(), "{args:?}");
        let err = stderr(&o);
        assert!(err.contains("is in use by another run"), "{err}");
        assert!(
            err.contains(&format!("pid {}", std::process::id())),
            "{err}"
        );
        assert!(err.contains("on host"), "{err}");
    }
    // The refused runs wrote nothing.
    assert_eq!(
        tree(&out).into_keys().collect::<Vec<_>>(),
        [PathBuf::from(LOCK_FILE)]
    );
    drop(lock);
    let o = run(&s, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        !out.join(LOCK_FILE).exists(),
        "a finished run removes its lock"
    );
}

#[test]
fn a_new_run_never_destroys_an_existing_campaign() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let out = tmp.path().join("out");
    assert!(run(&s, &out, &[]).status.success());
    let before = tree(&out);

    let o = run(&s, &out, &[]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("already holds a campaign (3 completed trials)"),
        "{err}"
    );
    assert!(err.contains("--resume") && err.contains("--force"), "{err}");
    assert_eq!(
        tree(&out),
        before,
        "a refused run must not touch the folder"
    );

    // Forced, but the new first trial fails (x beyond the end stop): the old campaign stays.
    let failing = std::fs::read_to_string(&s)
        .unwrap()
        .replace("x0 = 0.1", "x0 = 0.1\nx_limit = 0.01");
    let bad = tmp.path().join("bad.toml");
    std::fs::write(&bad, failing).unwrap();
    let o = run(&bad, &out, &["--force"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("end stop"), "{}", stderr(&o));
    // The old campaign's trials are not this run's to name as kept.
    assert!(!stderr(&o).contains("kept in"), "{}", stderr(&o));
    assert_eq!(
        tree(&out),
        before,
        "a failed forced run must keep the old campaign"
    );

    // Forced and succeeding: the folder holds exactly the new campaign.
    let other = tmp.path().join("other.toml");
    std::fs::write(
        &other,
        std::fs::read_to_string(&s)
            .unwrap()
            .replace("trials = 3", "trials = 2"),
    )
    .unwrap();
    let fresh = tmp.path().join("fresh");
    assert!(run(&other, &fresh, &[]).status.success());
    let o = run(&other, &out, &["--force"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_tree(&fresh, &out, "after --force");

    // Other files in the folder also stop a new run.
    let mine = tmp.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), b"keep me").unwrap();
    let o = run(&s, &mine, &[]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("already holds files (notes.txt)"));
}

/// `huge.toml` beside `s`: `s` with 10^8 steps, about 11 GiB for one recorded trial.
fn huge_scenario(s: &Path) -> PathBuf {
    let huge = s.with_file_name("huge.toml");
    std::fs::write(
        &huge,
        std::fs::read_to_string(s)
            .unwrap()
            .replace("stop_time = 0.5", "stop_time = 1000000"),
    )
    .unwrap();
    huge
}

#[test]
fn a_campaign_beyond_the_memory_limit_is_refused_with_the_scenario_line() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let out = tmp.path().join("out");
    let huge = huge_scenario(&s);
    let o = run(&huge, &out, &[]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("huge.toml:2:"), "{err}");
    assert!(err.contains("100000000 steps per trial"), "{err}");
    assert!(
        err.contains("more than the default limit of 4096 MiB"),
        "{err}"
    );
    assert!(err.contains("--memory-limit-mib"), "{err}");
    assert!(!out.exists());

    // The limit is the user's: a scenario key (with its line) and a flag that overrides it.
    let tight = scenario(tmp.path(), "memory_limit_mib = 0");
    let o = run(&tight, &out, &[]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("the scenario's memory_limit_mib of 0 MiB"),
        "{err}"
    );
    let o = run(&tight, &out, &["--memory-limit-mib", "16"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A limit raised past what the process may allocate (here `ulimit -v`, 3 GB of address
/// space against the 11 GiB the trial needs) is refused up front; a failed allocation
/// later would abort the process with a backtrace and leave the folder's lock behind.
#[cfg(target_os = "linux")]
#[test]
fn a_limit_beyond_what_the_process_can_allocate_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let huge = huge_scenario(&scenario(tmp.path(), ""));
    let out = tmp.path().join("out");
    let o = std::process::Command::new("sh")
        .arg("-c")
        .arg(
            "ulimit -v 3000000 && exec \"$0\" run \"$1\" --out \"$2\" --memory-limit-mib 100000000",
        )
        .arg(env!("CARGO_BIN_EXE_orchestrator"))
        .arg(&huge)
        .arg(&out)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("huge.toml:2:"), "{err}");
    assert!(
        err.contains("more than this process can allocate now"),
        "{err}"
    );
    assert!(!err.contains("backtrace"), "{err}");
    assert!(!out.exists());
}

/// Byte offset of the first memory value in a format-2 memory file with one channel.
const FIRST_VALUE: usize = 8 + 8 + 8;

#[test]
fn a_corrupted_memory_file_is_refused_on_resume() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let out = tmp.path().join("out");
    assert!(run(&s, &out, &["--stop-after", "1"]).status.success());
    let file = out.join("memory/after_trial_000.f64");
    let good = std::fs::read(&file).unwrap();
    assert!(good.starts_with(b"CKCMMEM2"), "format version in the magic");

    // A NaN patched in: the checksum no longer matches.
    let mut bytes = good.clone();
    bytes[FIRST_VALUE + 8..FIRST_VALUE + 16].copy_from_slice(&f64::NAN.to_le_bytes());
    std::fs::write(&file, &bytes).unwrap();
    let o = run(&s, &out, &["--resume"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains("after_trial_000.f64"), "{err}");
    assert!(err.contains("checksum mismatch"), "{err}");

    // The same NaN with a matching checksum: still refused, naming the value.
    let n = bytes.len() - 4;
    let crc = crc32fast::hash(&bytes[..n]);
    bytes[n..].copy_from_slice(&crc.to_le_bytes());
    std::fs::write(&file, &bytes).unwrap();
    let err = stderr(&run(&s, &out, &["--resume"]));
    assert!(
        err.contains("memory channel 1 value 1 is NaN, not a finite number"),
        "{err}"
    );

    // Truncated.
    std::fs::write(&file, &good[..good.len() / 2]).unwrap();
    let err = stderr(&run(&s, &out, &["--resume"]));
    assert!(err.contains("checksum mismatch"), "{err}");

    // Restored, the campaign resumes.
    std::fs::write(&file, &good).unwrap();
    let o = run(&s, &out, &["--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A write that fails part way (here `memory.csv`, blocked by a folder of that name, as a
/// full disk would fail it) stops the run naming the file, the trials kept and the command
/// that continues; once the write can succeed, that command ends the campaign with the
/// very files of an uninterrupted run.
#[test]
fn a_failed_write_names_the_trials_kept_and_the_resume_that_finishes_them() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, whole, out) = whole_and_stopped(tmp.path());
    let blocker = out.join("memory.csv");
    std::fs::remove_file(&blocker).unwrap();
    std::fs::create_dir_all(blocker.join("in-the-way")).unwrap();
    let o = run(&s, &out, &["--resume"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(err.contains(&blocker.display().to_string()), "{err}");
    assert!(
        err.contains(&format!(
            "trials 0–2 are kept in {shown}; once the write can succeed (free disk space, for \
             one), `orchestrator run {} --out {shown} --resume` continues the campaign",
            s.display(),
            shown = out.display()
        )),
        "{err}"
    );
    std::fs::remove_dir_all(&blocker).unwrap();
    let o = run(&s, &out, &["--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_tree(&whole, &out, "after the resumed write");
}

/// `--resume` continues only the campaign of the same scenario (and FMUs): a folder started
/// from another scenario text is refused, naming the folder, and left as it was.
#[test]
fn resume_refuses_a_folder_of_a_different_scenario() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let out = tmp.path().join("out");
    assert!(run(&s, &out, &["--stop-after", "1"]).status.success());
    let before = tree(&out);

    let changed = scenario(tmp.path(), "start_time = 0.0");
    let o = run(&changed, &out, &["--resume"]);
    assert!(!o.status.success());
    let err = stderr(&o);
    // The first line that differs is named, blank lines aside.
    assert!(
        err.contains(&format!(
            "cannot resume in {}: it holds a campaign of a different scenario: line 5 of its \
             scenario.toml reads `[[fmu]]`, where this scenario has `start_time = 0.0`",
            out.display()
        )),
        "{err}"
    );
    assert_eq!(tree(&out), before, "a refused resume changed the folder");

    // The same scenario with another FMU file (rebuilt): the FMU is named as the difference.
    let same = scenario(tmp.path(), "");
    let fmu = tmp.path().join("DampedOscillator.fmu");
    let bytes = std::fs::read(&fmu).unwrap();
    std::fs::write(&fmu, [&bytes[..], b" "].concat()).unwrap();
    let err = stderr(&run(&same, &out, &["--resume"]));
    assert!(
        err.contains("it holds a campaign of this scenario run with other FMU files"),
        "{err}"
    );
    assert_eq!(tree(&out), before, "a refused resume changed the folder");
    std::fs::write(&fmu, bytes).unwrap();

    let o = run(&same, &out, &["--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Kills the campaign (abort: no destructor, no clean-up, like SIGKILL) at every file
/// operation in turn, then resumes it (itself killed once more on the way when that is
/// possible): each folder ends byte-identical to an uninterrupted run, without temporary or
/// stale memory files. On one lane and on two, where two trials' writers run at once and the
/// order of file operations varies from run to run.
#[test]
fn kill_at_every_file_operation_then_resume_is_byte_identical() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let whole = tmp.path().join("whole");
    let o = run(&s, &whole, &["--jobs", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    for jobs in ["1", "2"] {
        let mut points = 0;
        for at in 1.. {
            let out = tmp.path().join(format!("killed-{jobs}-{at}"));
            let o = run(&s, &out, &["--jobs", jobs, "--crash-at", &at.to_string()]);
            if o.status.success() {
                break;
            }
            assert!(
                o.status.code().is_none(),
                "crash point {at} must abort: {}",
                stderr(&o)
            );
            points += 1;
            if out.exists() {
                // Leftovers a kill inside a write can leave: a temporary file and a memory
                // file of a trial that progress.toml does not claim.
                std::fs::write(out.join(".summary.csv.tmp-999999-0"), b"torn").unwrap();
                if out.join("memory").is_dir() {
                    std::fs::write(out.join("memory/after_trial_007.f64"), b"stale").unwrap();
                }
            }
            // A second interruption during the resume, then the resume that finishes.
            let _ = run(&s, &out, &["--jobs", jobs, "--resume", "--crash-at", "2"]);
            let o = run(&s, &out, &["--jobs", jobs, "--resume"]);
            assert!(
                o.status.success(),
                "resume after point {at}: {}",
                stderr(&o)
            );
            let when = format!("after a kill at point {at} with --jobs {jobs}");
            assert_same_tree(&whole, &out, &when);
        }
        // 3 trials: removal of an old campaign, scenario, and per trial CSV, memory, summary,
        // progress (and removal of the previous memory), then memory.csv.
        assert!(points >= 15, "only {points} kill points with --jobs {jobs}");
    }
}

/// A progress.toml that claims no completed trial (written by hand or by another tool: a
/// campaign writes it only after its first trial) resumes from trial 0, replacing the files
/// of the trials it does not claim, to the bytes of an uninterrupted run.
#[test]
fn a_progress_file_claiming_no_trial_resumes_from_the_first() {
    let tmp = tempfile::tempdir().unwrap();
    let (s, whole, out) = whole_and_stopped(tmp.path());
    let progress = out.join("progress.toml");
    let text = std::fs::read_to_string(&progress).unwrap();
    assert!(text.starts_with("completed = 1\n"), "{text}");
    std::fs::write(
        &progress,
        text.replacen("completed = 1", "completed = 0", 1),
    )
    .unwrap();
    let o = run(&s, &out, &["--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_tree(&whole, &out, "after resuming from a progress of 0 trials");
}

/// Without `[metrics]` nothing is measured: the console says so and summary.csv leaves the
/// cells empty, not zeros that read as a perfect trial. A campaign of an earlier version
/// (zeros in those cells) resumes into the same files as a new one.
#[test]
fn unmeasured_trials_are_reported_as_such() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let out = tmp.path().join("out");
    let o = run(&s, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("trial   0: error not measured"), "{err}");
    assert!(!err.contains("max |e|"), "{err}");
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let rows: Vec<&str> = summary.lines().skip(1).collect();
    assert_eq!(rows.len(), 3, "{summary}");
    for (k, row) in rows.iter().enumerate() {
        assert_eq!(*row, format!("{k}{}", ",".repeat(23)), "{summary}");
    }
    // An earlier version's interrupted campaign: one trial, zeros in the leg metrics' cells
    // (and, so that both halves of the rewrite are seen, in the path's).
    let header = summary.lines().next().unwrap();
    for (name, path_cells) in [("old", ",,"), ("old-path", ",0,0")] {
        let old = tmp.path().join(name);
        let o = run(&s, &old, &["--stop-after", "1"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let zeros = format!("{header}\n0{}{path_cells}\n", ",0".repeat(21));
        std::fs::write(old.join("summary.csv"), zeros).unwrap();
        let o = run(&s, &old, &["--resume"]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(
            std::fs::read_to_string(old.join("summary.csv")).unwrap(),
            summary,
            "{name}"
        );
    }
}

/// FNV-1a 64 as earlier versions fingerprinted a campaign: the scenario text as given, then
/// the FMU files.
fn earlier_fingerprint(text: &str, fmu: &Path) -> String {
    let fnv = |h: u64, bytes: &[u8]| {
        bytes
            .iter()
            .fold(h, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
    };
    let h = fnv(0xcbf2_9ce4_8422_2325, text.as_bytes());
    format!("{:016x}", fnv(h, &std::fs::read(fmu).unwrap()))
}

/// The saved `scenario.toml` is the scenario as run: its FMU paths resolve from the output
/// folder (the original's were relative to the original file) and it holds the `--trials`
/// count. `--resume` from it finishes the campaign byte-identical to an uninterrupted run,
/// and a campaign begun by an earlier version (its fingerprint over the text as given, its
/// scenario.toml a verbatim copy) still resumes from the original file.
#[test]
fn the_saved_scenario_reruns_and_resumes_from_the_output_folder() {
    let tmp = tempfile::tempdir().unwrap();
    let src = tmp.path().join("src");
    std::fs::create_dir(&src).unwrap();
    let s = scenario(&src, "");
    let fmu = src.join("DampedOscillator.fmu");
    let relative = std::fs::read_to_string(&s)
        .unwrap()
        .replace(&fmu.display().to_string(), "DampedOscillator.fmu");
    std::fs::write(&s, &relative).unwrap();

    let whole = tmp.path().join("whole");
    let o = run(&s, &whole, &["--trials", "5"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = tmp.path().join("out");
    let o = run(&s, &out, &["--trials", "5", "--stop-after", "2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let saved_path = out.join("scenario.toml");
    let saved: toml::Table =
        toml::from_str(&std::fs::read_to_string(&saved_path).unwrap()).unwrap();
    assert_eq!(saved["trials"].as_integer(), Some(5));
    let path = Path::new(saved["fmu"][0]["path"].as_str().unwrap());
    assert!(path.is_absolute() && path.is_file(), "{}", path.display());

    // Resumed from the saved file, run from another working directory.
    let o = orchestrator()
        .current_dir(tmp.path())
        .arg("run")
        .arg(&saved_path)
        .arg("--out")
        .arg(&out)
        .arg("--resume")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_tree(&whole, &out, "after a resume from the saved scenario");
    // Fewer trials than are done is refused, not silently ignored.
    let o = run(&saved_path, &out, &["--resume", "--trials", "2"]);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("it holds 5 completed trials, more than the 2 asked for"),
        "{}",
        stderr(&o)
    );
    assert_same_tree(&whole, &out, "after a refused resume with fewer trials");

    // A campaign of an earlier version: resumed from the original file, it ends as a new one.
    let old = tmp.path().join("old");
    assert!(
        run(&s, &old, &["--trials", "5", "--stop-after", "2"])
            .status
            .success()
    );
    std::fs::write(old.join("scenario.toml"), &relative).unwrap();
    let progress = format!(
        "completed = 2\nfingerprint = \"{}\"\n",
        earlier_fingerprint(&relative, &fmu)
    );
    std::fs::write(old.join("progress.toml"), progress).unwrap();
    let o = run(&s, &old, &["--trials", "5", "--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_tree(
        &whole,
        &old,
        "after resuming a campaign of an earlier version",
    );
}

/// A campaign run with `--trials` below a trial its `[record] trials` names saves a
/// scenario.toml with the lower count and the selection as written, so the run from that
/// file warns instead of refusing it (before: "record.trials lists trial 2, but trials are
/// numbered 0..0"), and an extended resume from it records the trial.
#[test]
fn a_run_with_fewer_trials_than_it_records_resumes_from_its_saved_scenario() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let text = std::fs::read_to_string(&s).unwrap();
    std::fs::write(
        &s,
        text.replace("[record]\n", "[record]\ntrials = [0, 2]\n"),
    )
    .unwrap();
    let whole = tmp.path().join("whole");
    let o = run(&s, &whole, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));

    // `--trials 1` is the user's choice and gets no warning; the saved file, which sets one
    // trial and records trial 2, does.
    let out = tmp.path().join("out");
    let o = run(&s, &out, &["--trials", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    let saved = out.join("scenario.toml");
    let o = run(&saved, &out, &["--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains(
            "record.trials lists trial 2, beyond this run's trials 0..0: it is recorded only \
             if the campaign is extended"
        ),
        "{}",
        stderr(&o)
    );
    let o = run(&saved, &out, &["--resume", "--trials", "3"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_tree(&whole, &out, "after extending from the saved scenario");
}

/// A console that goes away (stdout and stderr into pipes whose reader has exited, as
/// `run … 2>&1 | head -1` leaves them) neither stops the campaign nor turns its exit code
/// into a panic's: the run finishes every trial and exits 0.
#[test]
fn a_closed_console_does_not_stop_a_run() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let whole = tmp.path().join("whole");
    assert!(run(&s, &whole, &[]).status.success());
    let out = tmp.path().join("out");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .arg("run")
        .arg(&s)
        .arg("--out")
        .arg(&out)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    drop(child.stderr.take());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(0));
    assert_same_tree(&whole, &out, "with a closed console");
}

/// A scenario file that is itself `OUT/scenario.toml` is refused as --out, with or without
/// --force or --resume, and left as it was: the campaign would replace it with its copy.
/// Once a campaign began there, resuming it from that file works.
#[test]
fn the_scenario_file_is_never_the_campaigns_own_copy() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), "");
    let own = tmp.path().join("own");
    std::fs::create_dir(&own).unwrap();
    let inside = own.join("scenario.toml");
    std::fs::copy(&s, &inside).unwrap();
    let before = tree(&own);
    for args in [&[][..], &["--force"], &["--resume"]] {
        let o = run(&inside, &own, args);
        assert!(!o.status.success(), "{args:?}");
        let err = stderr(&o);
        assert!(
            err.contains(&format!(
                "{} is the scenario file itself, and a campaign in {} writes its own \
                 scenario.toml there: choose another --out",
                inside.display(),
                own.display()
            )),
            "{args:?}: {err}"
        );
        assert_eq!(tree(&own), before, "{args:?} changed the folder");
    }
    let out = tmp.path().join("out");
    assert!(run(&s, &out, &["--stop-after", "1"]).status.success());
    let o = run(&out.join("scenario.toml"), &out, &["--resume"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// `memory.csv` lays the channels side by side: the learning memory carried as six
/// one-element channels gives the very file the one six-element channel gives.
#[test]
fn memory_channels_side_by_side_make_the_same_memory_csv_as_one() {
    let tmp = tempfile::tempdir().unwrap();
    // The closed loop's one channel, and the same memory as six.
    let one_channel = "[[memory]]\nfrom = \"controller.memory_next\"\nto = \"controller.memory\"\n";
    assert!(common::CLOSED_LOOP.contains(one_channel));
    let six_channels: String = (1..=6)
        .map(|i| {
            format!(
                "[[memory]]\nfrom = \"controller.memory_next[{i}]\"\nto = \"controller.memory[{i}]\"\n"
            )
        })
        .collect();
    let campaign = |name: &str, coupling: &str| {
        let path = tmp.path().join(format!("{name}.toml"));
        std::fs::write(
            &path,
            format!(
                r#"step_size = 0.001
stop_time = 0.2
trials = 2

[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "line"
duration = 0.2

[[fmu]]
name = "plant"
path = "{plant}"
{coupling}
[record]
variables = ["controller.error"]
trials = []
"#,
                controller = common::fmu_path_text("HlcsController"),
                plant = common::fmu_path_text("CkcmPlant"),
            ),
        )
        .unwrap();
        let out = tmp.path().join(name);
        let o = run(&path, &out, &[]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        std::fs::read_to_string(out.join("memory.csv")).unwrap()
    };
    let one = campaign("one", common::CLOSED_LOOP);
    let six = campaign(
        "six",
        &common::CLOSED_LOOP.replace(one_channel, &six_channels),
    );
    let learned = one
        .lines()
        .skip(1)
        .flat_map(|l| l.split(',').skip(1))
        .any(|v| v.parse::<f64>().unwrap() != 0.0);
    assert!(learned, "the memory learned nothing:\n{one}");
    assert_eq!(six, one);
}
