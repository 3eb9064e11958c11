//! `run --jobs N`: trial k+1 follows trial k on the next lane, reading its memory chunk by
//! chunk. Whatever happens, the folder must hold byte for byte what one lane writes, and a
//! failing trial must fail with the same message, on any lane.

mod common;

use std::path::{Path, PathBuf};

use common::{column, foreign_fmu, orchestrator, read_csv, tree};

/// The foreign oscillator driven by its own position of the trial before
/// (drive_{k+1}(t) = x_k(t), amplified by `gain`): the memory grows from trial to trial until
/// x passes `x_limit`, an fmi2Error mid-trial.
fn scenario(dir: &Path, gain: f64, x_limit: f64) -> PathBuf {
    let fmu = foreign_fmu(dir);
    let path = dir.join(format!("g{gain}-x{x_limit}.toml"));
    std::fs::write(
        &path,
        format!(
            "step_size = 0.001\nstop_time = 2.0\ntrials = 8\n[[fmu]]\nname = \"osc\"\n\
             path = \"{}\"\n[fmu.parameters]\nx0 = 0.1\ngain = {gain}\nx_limit = {x_limit}\n\
             [[memory]]\nfrom = \"osc.x\"\nto = \"osc.drive\"\n\
             [record]\nvariables = [\"osc.x\", \"osc.drive\"]\ntrials = [0, 1, 2, 5]\n",
            fmu.display()
        ),
    )
    .unwrap();
    path
}

/// Runs `scenario` with `--jobs jobs` into `out`: success, and the error line of stderr (its
/// last line when there is none).
fn run(scenario: &Path, out: &Path, jobs: usize) -> (bool, String) {
    let o = orchestrator()
        .arg("run")
        .arg(scenario)
        .arg("--out")
        .arg(out)
        .arg(format!("--jobs={jobs}"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    (
        o.status.success(),
        // The error's own line: the trials kept follow it, in the lane count's folder.
        err.lines()
            .find(|l| l.starts_with("error: "))
            .or_else(|| err.lines().last())
            .unwrap_or_default()
            .to_owned(),
    )
}

#[test]
fn lanes_write_what_one_writes_and_fail_where_it_fails() {
    let tmp = tempfile::tempdir().unwrap();
    // Which trial fails was found by running one lane: none; trial 3 (the second of two
    // lanes, the first of three); trial 2 (the first of two, the third of three).
    for (gain, x_limit, failing) in [
        (10.0, 1e3, None),
        (10.0, 1.0, Some(3)),
        (14.0, 1.0, Some(2)),
    ] {
        let s = scenario(tmp.path(), gain, x_limit);
        let one = tmp.path().join(format!("one-{gain}-{x_limit}"));
        let (ok1, last1) = run(&s, &one, 1);
        for jobs in [2, 3] {
            let two = tmp.path().join(format!("jobs{jobs}-{gain}-{x_limit}"));
            let (ok2, last2) = run(&s, &two, jobs);
            assert_eq!(ok1, failing.is_none(), "{last1}");
            assert_eq!(
                ok1, ok2,
                "--jobs {jobs}, gain {gain}, x_limit {x_limit}: {last2}"
            );
            if let Some(k) = failing {
                assert_eq!(last1, last2);
                assert!(
                    last2.starts_with(&format!("error: trial {k}, t = "))
                        && last2.contains("x_limit"),
                    "{last2}"
                );
            }
            let (a, b) = (tree(&one), tree(&two));
            assert_eq!(
                a.keys().collect::<Vec<_>>(),
                b.keys().collect::<Vec<_>>(),
                "gain {gain}, x_limit {x_limit}"
            );
            for (path, bytes) in &a {
                assert!(
                    bytes == &b[path],
                    "--jobs {jobs}: {} differs",
                    path.display()
                );
            }
            let completed = failing.unwrap_or(8);
            let progress = String::from_utf8_lossy(&a[Path::new("progress.toml")]).into_owned();
            assert!(
                progress.starts_with(&format!("completed = {completed}\n")),
                "{progress}"
            );
        }
    }
}

/// The oscillator's one input is one memory channel, which the master sets straight from the
/// channel. Over the step from t_n trial k+1's drive is trial k's x after that step, x(t_{n+1});
/// the row at t_m records the value before the step from t_m, so the drive set for the step
/// before: drive_{k+1}(t_m) = x_k(t_m) for m ≥ 1, bit for bit, on every lane count, and the
/// start value 0 at t_0.
#[test]
fn a_memory_input_reads_the_trial_before() {
    let tmp = tempfile::tempdir().unwrap();
    let s = scenario(tmp.path(), 10.0, 1e3);
    for jobs in [1, 2] {
        let out = tmp.path().join(format!("memory-{jobs}"));
        let (ok, last) = run(&s, &out, jobs);
        assert!(ok, "{last}");
        let trial = |k: usize| read_csv(&out.join(format!("trials/trial_{k:03}.csv")));
        for k in [0, 1] {
            let (before, after) = (trial(k), trial(k + 1));
            let x = column(&before, "osc.x");
            let drive = column(&after, "osc.drive");
            assert_eq!(x.len(), 2000);
            assert_eq!(drive.len(), x.len());
            assert!(x.iter().any(|&v| v != 0.0));
            assert_eq!(drive[0], 0.0);
            for m in 1..x.len() {
                assert_eq!(
                    drive[m].to_bits(),
                    x[m].to_bits(),
                    "--jobs {jobs}, trial {}, row {m}",
                    k + 1
                );
            }
        }
    }
}
