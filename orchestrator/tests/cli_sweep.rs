//! `orchestrator sweep`: sharded and merged runs equal the plain run byte for byte, an
//! interrupted sweep resumes without losing or repeating a case, and bad input fails before
//! anything is written.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use common::{built_fmu, orchestrator, tree};

/// Runs a command that must fail with an `error:` line containing every needle.
trait Fails {
    fn fails(&mut self, needles: &[&str]);
}

impl Fails for assert_cmd::Command {
    fn fails(&mut self, needles: &[&str]) {
        let output = self.output().unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "should fail; stderr: {stderr}");
        for n in needles {
            assert!(stderr.contains(n), "stderr lacks {n:?}: {stderr}");
        }
    }
}

/// A short circle campaign (0.4 s, 3 trials) as the base, and a sweep of 6 cases over it.
/// The CKCM loop on the 0.4 s circle, `trials` trials, then `tail` (its record and metrics).
fn closed_loop(trials: usize, tail: &str) -> String {
    format!(
        "step_size = 0.001\nstop_time = 0.4\ntrials = {trials}\n\
         [[fmu]]\nname = \"controller\"\npath = {c:?}\n\
         [fmu.parameters]\ntrajectory = \"circle\"\nduration = 0.4\n\
         [[fmu]]\nname = \"plant\"\npath = {p:?}\n\
         [[connection]]\nfrom = \"plant.length\"\nto = \"controller.length\"\n\
         [[connection]]\nfrom = \"plant.velocity\"\nto = \"controller.velocity\"\n\
         [[connection]]\nfrom = \"controller.force\"\nto = \"plant.force\"\n\
         [[memory]]\nfrom = \"controller.memory_next\"\nto = \"controller.memory\"\n{tail}",
        c = built_fmu("HlcsController"),
        p = built_fmu("CkcmPlant"),
    )
}

fn setup(dir: &Path, trials: usize) -> PathBuf {
    let base = closed_loop(
        3,
        "[record]\nvariables = [\"controller.error\"]\n[metrics]\nerror = \"controller.error\"\n",
    );
    fs::write(dir.join("base.toml"), base).unwrap();
    let sweep = format!(
        "base = \"base.toml\"\ntrials = {trials}\nseed = 3\n\
         [[axis]]\nname = \"mass\"\nparameters = [\"plant.platform_mass\"]\nscale = true\nvalues = [0.8, 1.0, 1.2]\n\
         [[axis]]\nname = \"friction\"\nparameters = [\"plant.viscous_friction\", \"plant.coulomb_friction\"]\n\
         scale = true\nuniform = [0.5, 2.0]\nsamples = 2\n"
    );
    let file = dir.join("sweep.toml");
    fs::write(&file, sweep).unwrap();
    file
}

/// `orchestrator sweep SWEEP --out OUT --jobs JOBS`, which must succeed; its stderr.
fn sweep_succeeds(sweep: &Path, out: &Path, jobs: usize) -> String {
    let o = orchestrator()
        .arg("sweep")
        .arg(sweep)
        .arg("--out")
        .arg(out)
        .args(["--jobs", &jobs.to_string()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    err
}

/// Every result file of a sweep directory (not the case folders), by relative path.
fn results(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut files = vec![
        (
            "sweep.csv".to_string(),
            fs::read(dir.join("sweep.csv")).unwrap(),
        ),
        (
            "sweep-report.md".to_string(),
            fs::read(dir.join("sweep-report.md")).unwrap(),
        ),
    ];
    let mut figs: Vec<_> = fs::read_dir(dir.join("figures"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    figs.sort();
    for f in figs {
        files.push((
            format!("figures/{}", f.file_name().unwrap().to_string_lossy()),
            fs::read(&f).unwrap(),
        ));
    }
    for i in 0..6 {
        let p = format!("cases/case_{i:04}/summary.csv");
        files.push((p.clone(), fs::read(dir.join(&p)).unwrap()));
    }
    files
}

#[test]
fn shards_merge_to_the_plain_run_byte_for_byte() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 3);
    let plain = tmp.path().join("plain");
    let err = sweep_succeeds(&sweep, &plain, 2);
    // Progress counts the cases finished out of six, whatever order they finish in.
    for count in 1..=6 {
        assert!(err.contains(&format!(" done, {count} of 6 (")), "{err}");
    }
    let reference = results(&plain);
    let csv = String::from_utf8(reference[0].1.clone()).unwrap();
    assert_eq!(csv.lines().count(), 7, "a header and six cases:\n{csv}");
    assert!(
        csv.starts_with("case,mass,friction,verdict,trials,"),
        "{csv}"
    );
    // The friction draws lie in the range and the two friction parameters move together.
    let scenario = fs::read_to_string(plain.join("cases/case_0001/scenario.toml")).unwrap();
    let doc: toml::Table = toml::from_str(&scenario).unwrap();
    let plant = &doc["fmu"].as_array().unwrap()[1]["parameters"];
    let (v, c) = (
        plant["viscous_friction"].as_float().unwrap(),
        plant["coulomb_friction"].as_float().unwrap(),
    );
    assert!((v / 100.0 - c / 20.0).abs() < 1e-12, "{v} {c}");
    assert!((50.0..=200.0).contains(&v), "{v}");
    for n in [1usize, 3, 7] {
        let shards: Vec<PathBuf> = (0..n)
            .map(|k| {
                let out = tmp.path().join(format!("n{n}_shard{k}"));
                orchestrator()
                    .arg("sweep")
                    .arg(&sweep)
                    .arg("--out")
                    .arg(&out)
                    .arg("--shard")
                    .arg(format!("{k}/{n}"))
                    .args(["--jobs", "1"])
                    .assert()
                    .success();
                assert!(!out.join("sweep.csv").exists(), "a shard writes no results");
                out
            })
            .collect();
        let merged = tmp.path().join(format!("merged{n}"));
        orchestrator()
            .args(["sweep", "merge"])
            .arg(&sweep)
            .args(&shards)
            .arg("--out")
            .arg(&merged)
            .assert()
            .success();
        let got = results(&merged);
        for ((name, want), (_, have)) in reference.iter().zip(&got) {
            assert!(want == have, "N = {n}: {name} differs from the plain run");
        }
        // A folder holding anything (a merge, a shard, a campaign) is refused, untouched.
        for full in [&merged, &shards[0]] {
            let before = tree(full);
            orchestrator()
                .args(["sweep", "merge"])
                .arg(&sweep)
                .args(&shards)
                .arg("--out")
                .arg(full)
                .fails(&["the folder is not empty", "--out"]);
            assert!(
                tree(full) == before,
                "a refused merge changed {}",
                full.display()
            );
        }
    }
}

fn mtimes(dir: &Path) -> Vec<(usize, SystemTime)> {
    (0..6)
        .filter_map(|i| {
            let p = dir.join(format!("cases/case_{i:04}/outcome.toml"));
            Some((i, fs::metadata(p).ok()?.modified().ok()?))
        })
        .collect()
}

/// `sweep SWEEP --out OUT --resume`.
fn resume(sweep: &Path, out: &Path) -> assert_cmd::Command {
    let mut cmd = orchestrator();
    cmd.arg("sweep")
        .arg(sweep)
        .arg("--out")
        .arg(out)
        .arg("--resume");
    cmd
}

/// Starts `sweep SWEEP --out OUT --jobs 1` and returns once `cases` cases have ended (or
/// after two minutes), the sweep still running.
fn one_case_at_a_time(
    sweep: &Path,
    out: &Path,
    stderr: std::process::Stdio,
    cases: usize,
) -> std::process::Child {
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_orchestrator"))
        .arg("sweep")
        .arg(sweep)
        .arg("--out")
        .arg(out)
        .args(["--jobs", "1"])
        .stderr(stderr)
        .spawn()
        .unwrap();
    let start = Instant::now();
    while mtimes(out).len() < cases && start.elapsed() < Duration::from_secs(120) {
        std::thread::sleep(Duration::from_millis(2));
    }
    child
}

#[test]
fn a_killed_sweep_resumes_without_losing_or_repeating_a_case() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 6);
    let plain = tmp.path().join("plain");
    orchestrator()
        .arg("sweep")
        .arg(&sweep)
        .arg("--out")
        .arg(&plain)
        .assert()
        .success();
    let out = tmp.path().join("killed");
    let mut child = one_case_at_a_time(&sweep, &out, std::process::Stdio::null(), 2);
    // Killed once two cases have finished, while later ones run.
    child.kill().unwrap();
    child.wait().unwrap();
    let before = mtimes(&out);
    assert!(
        before.len() >= 2 && before.len() < 6,
        "killed after {} cases",
        before.len()
    );
    // Without --resume the folder is refused, and nothing in it changes.
    orchestrator()
        .arg("sweep")
        .arg(&sweep)
        .arg("--out")
        .arg(&out)
        .fails(&["--resume"]);
    resume(&sweep, &out).assert().success();
    let after = mtimes(&out);
    for (i, t) in &before {
        assert!(
            after.iter().any(|(j, u)| j == i && u == t),
            "case {i} finished before the kill but was run again"
        );
    }
    for ((name, want), (_, have)) in results(&plain).iter().zip(results(&out).iter()) {
        assert!(want == have, "{name} differs after resume");
    }
    // Killed while writing its first file, a sweep leaves only a temporary stamp: the
    // resume that a requeued cluster task runs (examples/slurm) starts it afresh.
    let early = tmp.path().join("early");
    fs::create_dir(&early).unwrap();
    fs::write(early.join(".sweep.toml.tmp-999999-0"), b"torn").unwrap();
    orchestrator()
        .arg("sweep")
        .arg(&sweep)
        .arg("--out")
        .arg(&early)
        .arg("--resume")
        .assert()
        .success();
    for ((name, want), (_, have)) in results(&plain).iter().zip(results(&early).iter()) {
        assert!(
            want == have,
            "{name} differs after a resume of a torn start"
        );
    }
}

/// Runs shard `k` of 2 of `sweep` into `dir`/`name`, which must succeed; that folder.
fn shard_of_two(sweep: &Path, k: usize, dir: &Path, name: &str) -> PathBuf {
    let out = dir.join(name);
    orchestrator()
        .arg("sweep")
        .arg(sweep)
        .arg("--out")
        .arg(&out)
        .arg("--shard")
        .arg(format!("{k}/2"))
        .assert()
        .success();
    out
}

/// A folder is resumed as the shard it began as. Resumed as another, it ran that shard's cases
/// beside its own and then wrote a `shard.toml` naming only the second.
#[test]
fn a_folder_resumed_as_another_shard_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 1);
    let s0 = shard_of_two(&sweep, 0, tmp.path(), "s0");
    let resumed_as = |out: &Path, shard: Option<&str>| {
        let mut cmd = resume(&sweep, out);
        if let Some(s) = shard {
            cmd.args(["--shard", s]);
        }
        cmd
    };
    // A finished shard says which it is.
    let before = tree(&s0);
    resumed_as(&s0, Some("1/2")).fails(&[
        "s0",
        "the finished shard 0/2 (its shard.toml)",
        "this run is shard 1/2",
        "resume it with the --shard it began with",
    ]);
    resumed_as(&s0, None).fails(&["shard 0/2", "the whole sweep (no --shard)"]);
    assert!(tree(&s0) == before, "a refused resume changed the folder");
    resumed_as(&s0, Some("0/2")).assert().success();
    // An unfinished one by its cases.
    fs::remove_file(s0.join("shard.toml")).unwrap();
    resumed_as(&s0, Some("1/2")).fails(&["case_0000, which is not among this run's cases"]);
    assert!(!s0.join("cases/case_0001").exists());
    resumed_as(&s0, Some("0/2")).assert().success();
    assert!(s0.join("shard.toml").exists());
    // A whole sweep's folder is not resumed as a shard.
    let plain = tmp.path().join("plain");
    sweep_succeeds(&sweep, &plain, 2);
    let before = tree(&plain);
    resumed_as(&plain, Some("1/2")).fails(&["case_0000", "this run is shard 1/2"]);
    assert!(
        tree(&plain) == before,
        "a refused resume changed the folder"
    );
}

/// Gives the base scenario in `dir` (of [`setup`]) its own copy of the plant FMU, which a
/// test may then change; the copy's path and the base scenario's new text.
fn own_plant(dir: &Path) -> (PathBuf, String) {
    let plant = dir.join("CkcmPlant.fmu");
    fs::copy(built_fmu("CkcmPlant"), &plant).unwrap();
    let base_file = dir.join("base.toml");
    let text = fs::read_to_string(&base_file).unwrap().replace(
        &format!("{:?}", built_fmu("CkcmPlant")),
        &format!("{plant:?}"),
    );
    assert!(text.contains(&format!("{plant:?}")));
    fs::write(&base_file, &text).unwrap();
    (plant, text)
}

/// Gives the FMU at `fmu` other bytes, as a rebuild would: a file added to its archive.
fn rebuild(fmu: &Path) {
    let edited = fmu.with_extension("edited");
    common::repackage(fmu, &edited, |_, bytes| Some(bytes));
    let mut extra = zip::ZipWriter::new_append(
        fs::File::options()
            .read(true)
            .write(true)
            .open(&edited)
            .unwrap(),
    )
    .unwrap();
    extra
        .start_file(
            "documentation/note.txt",
            zip::write::SimpleFileOptions::default(),
        )
        .unwrap();
    std::io::Write::write_all(&mut extra, b"rebuilt").unwrap();
    extra.finish().unwrap();
    fs::rename(&edited, fmu).unwrap();
}

/// Shards run from one sweep file but with other FMU files at the base's paths (a rebuild
/// between two array tasks) hold cases of two models: `merge` refuses them, naming the FMU
/// and both folders, and writes nothing. Before the shards recorded their FMUs, it combined
/// them without a word.
#[test]
fn shards_of_other_fmus_do_not_merge() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 1);
    let (plant, _) = own_plant(tmp.path());
    let shard = |k: usize, name: &str| shard_of_two(&sweep, k, tmp.path(), name);
    let merge = |shards: &[&Path], out: &Path| {
        let mut cmd = orchestrator();
        cmd.args(["sweep", "merge"]).arg(&sweep);
        for s in shards {
            cmd.arg(s);
        }
        cmd.arg("--out").arg(out);
        cmd
    };
    let old0 = shard(0, "old0");
    let old1 = shard(1, "old1");
    rebuild(&plant);
    let new1 = shard(1, "new1");
    let merged = tmp.path().join("merged");
    merge(&[&old0, &new1], &merged).fails(&[
        "cannot merge",
        "new1 ran FMU \"plant\" from other bytes than",
        "old0",
    ]);
    assert!(
        !merged.exists(),
        "a refused merge wrote {}",
        merged.display()
    );
    // The shards of one set of FMUs merge.
    merge(&[&old0, &old1], &merged).assert().success();
    assert!(merged.join("sweep.csv").exists());
    // A shard of an earlier version names no FMUs: merged, with a warning that says so.
    let stamp = new1.join("shard.toml");
    let unnamed: String = fs::read_to_string(&stamp)
        .unwrap()
        .split("[fmus]")
        .next()
        .unwrap()
        .to_string();
    fs::write(&stamp, unnamed).unwrap();
    let o = merge(&[&old0, &new1], &tmp.path().join("merged_unchecked"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("new1") && err.contains("not checked"),
        "no warning: {err}"
    );
    // A damaged stamp is named with the line the TOML reader stopped at.
    let text = fs::read_to_string(&stamp).unwrap();
    let lines = text.lines().count();
    fs::write(&stamp, format!("{text}shard = \n")).unwrap();
    merge(&[&old0, &new1], &tmp.path().join("merged_damaged")).fails(&[
        "new1",
        "shard.toml: line ",
        &format!("line {}:", lines + 1),
    ]);
}

/// An FMU file replaced while a sweep runs (a rebuild during a long study) stops the sweep
/// before its next case, naming the file: the cases after it would be of another model.
/// The finished cases are kept, and once the file's bytes are restored the sweep resumes
/// and ends as an uninterrupted run. Before, the later cases ran with the new FMU.
#[test]
fn an_fmu_replaced_during_a_sweep_stops_it() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 6);
    let (plant, _) = own_plant(tmp.path());
    let pristine = fs::read(&plant).unwrap();
    let plain = tmp.path().join("plain");
    sweep_succeeds(&sweep, &plain, 2);
    let rebuilt = tmp.path().join("rebuilt.fmu");
    fs::copy(&plant, &rebuilt).unwrap();
    rebuild(&rebuilt);
    let out = tmp.path().join("out");
    let child = one_case_at_a_time(&sweep, &out, std::process::Stdio::piped(), 1);
    fs::rename(&rebuilt, &plant).unwrap();
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success(), "the sweep went on: {stderr}");
    assert!(
        stderr.contains("CkcmPlant.fmu") && stderr.contains("changed while the sweep ran"),
        "{stderr}"
    );
    let kept = mtimes(&out);
    assert!(
        !kept.is_empty() && kept.len() < 6,
        "{} cases ended",
        kept.len()
    );
    fs::write(&plant, &pristine).unwrap();
    resume(&sweep, &out).assert().success();
    assert_eq!(
        mtimes(&out)[..kept.len()],
        kept[..],
        "kept cases were run again"
    );
    for ((name, want), (_, have)) in results(&plain).iter().zip(results(&out).iter()) {
        assert!(want == have, "{name} differs after the resume");
    }
}

/// One sweep per output folder at a time: a second sweep, or a resume, into a folder whose
/// sweep is running is refused at once, naming the holder, and writes nothing. Before, it took
/// up the cases the first had not reached and stopped part way, on the first case the first
/// sweep held, while the first went on to find cases the second had started. A merge into
/// it is refused too: before, it merged beside the running sweep.
#[test]
fn a_sweep_or_merge_into_a_folder_in_use_is_refused_at_once() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 1);
    let out = tmp.path().join("out");
    // The running sweep's lock, held here as a sweep process holds it.
    fs::create_dir(&out).unwrap();
    let held = orchestrator::campaign::DirLock::acquire(&out).unwrap();
    let names = || -> Vec<_> {
        fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect()
    };
    for resume in [false, true] {
        let mut cmd = orchestrator();
        cmd.arg("sweep").arg(&sweep).arg("--out").arg(&out);
        if resume {
            cmd.arg("--resume");
        }
        cmd.fails(&[
            &format!("{} is in use by another run", out.display()),
            &format!("pid {}", std::process::id()),
        ]);
        assert_eq!(names(), [".lock"], "a refused sweep wrote into the folder");
    }
    // A merge into it too: two writers would interleave their files.
    let shards = [0, 1].map(|k| shard_of_two(&sweep, k, tmp.path(), &format!("s{k}")));
    orchestrator()
        .args(["sweep", "merge"])
        .arg(&sweep)
        .args(&shards)
        .arg("--out")
        .arg(&out)
        .fails(&[&format!("{} is in use by another run", out.display())]);
    assert_eq!(names(), [".lock"], "a refused merge wrote into the folder");
    drop(held);
    // A lock file left by a killed sweep is no file of the sweep's: a new one starts.
    fs::write(out.join(".lock"), "pid = 1\nhost = \"gone\"\nsince = 0\n").unwrap();
    sweep_succeeds(&sweep, &out, 2);
    assert!(out.join("sweep.csv").exists());
    assert!(
        !out.join(".lock").exists(),
        "the sweep left its lock behind"
    );
}

/// A resumed sweep keeps its finished cases, so it refuses to go on once the FMUs or the
/// base scenario changed under them (as `run --resume` refuses a campaign), and goes on once
/// they are restored. Before this check, the resumed cases ran with the new FMUs beside
/// cases of the old ones.
#[test]
fn a_resumed_sweep_refuses_cases_of_other_fmus_or_another_base() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 3);
    let (plant, original) = own_plant(tmp.path());
    let base_file = tmp.path().join("base.toml");
    let out = tmp.path().join("out");
    sweep_succeeds(&sweep, &out, 2);
    let reference = results(&out);
    let last = out.join("cases/case_0005");
    fs::remove_dir_all(&last).unwrap();
    let before = mtimes(&out);

    // Other FMU bytes: a file added to the plant's archive.
    let pristine = fs::read(&plant).unwrap();
    rebuild(&plant);
    resume(&sweep, &out).fails(&["cannot resume", "case 0", "different FMUs", "--out"]);
    assert!(!last.exists(), "a refused resume ran a case");
    assert_eq!(
        mtimes(&out),
        before,
        "a refused resume touched a finished case"
    );

    // Another base scenario: one more metric setting.
    fs::write(&plant, &pristine).unwrap();
    fs::write(
        &base_file,
        original.replace("[metrics]\n", "[metrics]\nrho = 2.0\n"),
    )
    .unwrap();
    resume(&sweep, &out).fails(&["cannot resume", "case 0", "base.toml"]);
    assert!(!last.exists(), "a refused resume ran a case");

    // Both restored: the sweep goes on and ends as the uninterrupted run did.
    fs::write(&base_file, &original).unwrap();
    resume(&sweep, &out).assert().success();
    assert_eq!(
        mtimes(&out)[..5],
        before[..],
        "finished cases were run again"
    );
    for ((name, want), (_, have)) in reference.iter().zip(results(&out).iter()) {
        assert!(want == have, "{name} differs after the resume");
    }

    // Every kept case is checked, not only the first and the last: a case folder of the
    // same sweep over another base, put in the middle, is named.
    let other = tmp.path().join("other");
    fs::write(
        &base_file,
        original.replace("[metrics]\n", "[metrics]\nrho = 2.0\n"),
    )
    .unwrap();
    sweep_succeeds(&sweep, &other, 2);
    fs::write(&base_file, &original).unwrap();
    let middle = out.join("cases/case_0002");
    fs::remove_dir_all(&middle).unwrap();
    fs::rename(other.join("cases/case_0002"), &middle).unwrap();
    fs::remove_dir_all(&last).unwrap();
    resume(&sweep, &out).fails(&["cannot resume", "case 2", "base.toml"]);
    assert!(!last.exists(), "a refused resume ran a case");

    // Cases of earlier versions record only how they ended: their first and last are
    // checked by their campaign fingerprints.
    fs::remove_dir_all(&middle).unwrap();
    for i in [0, 1, 3, 4] {
        let outcome = out.join(format!("cases/case_{i:04}/outcome.toml"));
        assert!(fs::read_to_string(&outcome).unwrap().contains("[fmus]"));
        fs::write(&outcome, "status = \"completed\"\n").unwrap();
    }
    rebuild(&plant);
    resume(&sweep, &out).fails(&["cannot resume", "case 0", "different FMUs"]);
    fs::write(&plant, &pristine).unwrap();
    // A damaged outcome is named with its line, and nothing runs.
    let damaged = out.join("cases/case_0003/outcome.toml");
    fs::write(&damaged, "status = \"completed\"\nscenario = \n").unwrap();
    resume(&sweep, &out).fails(&["case_0003", "outcome.toml", "line 2:"]);
    assert!(!last.exists(), "a refused resume ran a case");
    fs::write(&damaged, "status = \"completed\"\n").unwrap();
    resume(&sweep, &out).assert().success();
    for ((name, want), (_, have)) in reference.iter().zip(results(&out).iter()) {
        assert!(want == have, "{name} differs after the last resume");
    }

    // The sweep file edited (a comment counts): the first line that differs is named.
    let text = fs::read_to_string(&sweep).unwrap();
    let first = text.lines().find(|l| !l.trim().is_empty()).unwrap().trim();
    fs::write(
        &sweep,
        text.replacen(first, &format!("{first}  # edited"), 1),
    )
    .unwrap();
    resume(&sweep, &out).fails(&[
        "it holds a different sweep: line",
        &format!("of its sweep.toml reads `{first}`, where"),
        &format!("has `{first}  # edited`; cannot resume"),
    ]);
    fs::remove_file(out.join("sweep.toml")).unwrap();
    resume(&sweep, &out).fails(&["it holds no sweep (no sweep.toml); cannot resume"]);
}

#[test]
fn bad_sweeps_fail_naming_the_file_and_write_nothing() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 2);
    let text = fs::read_to_string(&sweep).unwrap();
    let cases = [
        (
            text.replace("plant.platform_mass", "plant.platform_mas"),
            "sweep.toml:4",
            "has no variable \"platform_mas\"",
        ),
        (
            text.replace("values = [0.8, 1.0, 1.2]", "values = []"),
            "sweep.toml:4",
            "values is empty",
        ),
        (
            text.replace("samples = 2", "samples = 0"),
            "sweep.toml:9",
            "samples must be at least 1",
        ),
        // serde's "expected usize" said in words a TOML writer knows, with how to write it.
        (
            text.replacen("samples = 2", "samples = 2.0", 1),
            "sweep.toml:14",
            "invalid type: floating point `2.0`, expected a whole number (written \
             without a decimal point or exponent: 2, not 2.0 or 2e0)",
        ),
        // An axis named like one of sweep.csv's own columns would make two of that name.
        (
            text.replace("name = \"mass\"", "name = \"case\""),
            "sweep.toml:4",
            "axis name \"case\" is a column sweep.csv already has",
        ),
        (
            text.replace("name = \"mass\"", "name = \"rms_2\""),
            "sweep.toml:4",
            "axis name \"rms_2\" is a column sweep.csv already has",
        ),
        // Two values shown alike could not be told apart in the tables and figures.
        (
            text.replace(
                "values = [0.8, 1.0, 1.2]",
                "values = [0.8, 1.0, 1.2]\nlabels = [\"a\", \"b\", \"a\"]",
            ),
            "sweep.toml:4",
            "labels lists \"a\" twice (values 1 and 3)",
        ),
        // An output is no parameter to sweep.
        (
            text.replace("plant.platform_mass", "plant.length"),
            "sweep.toml:4",
            "axis \"mass\": FMU \"plant\": 'length[1]' is an output",
        ),
        (
            format!("{text}[report]\nthreshold = nan\n"),
            "sweep.toml:16",
            "report.threshold = NaN must be positive",
        ),
        // A value its variable cannot take is named at its axis, not as some case's scenario.
        (
            text.replace(
                "scale = true\nvalues = [0.8, 1.0, 1.2]",
                "values = [0.8, \"1.0\", 1.2]",
            ),
            "sweep.toml:4",
            "axis \"mass\": value 2 of 3: \"1.0\" is quoted, so it is text, not a number: write it \
             without quotes ('platform_mass' is a Real)",
        ),
        (
            text.replace(
                "parameters = [\"plant.platform_mass\"]\nscale = true\nvalues = [0.8, 1.0, 1.2]",
                "parameters = [\"plant.substeps\"]\nvalues = [1, 0, 2.5]",
            ),
            "sweep.toml:4",
            "axis \"mass\": value 2 of 3: \"substeps\" = 0 is below its declared min = 1",
        ),
        // Each axis within the limit, their product beyond it: the axis that passes it.
        (
            text.replace("samples = 2", "samples = 400000"),
            "sweep.toml:9",
            "axis 2: its 400000 values times the 3 cases of the axes before it make more \
             than 1000000 cases",
        ),
    ];
    for (i, (bad, at, what)) in cases.iter().enumerate() {
        let file = tmp.path().join(format!("bad{i}.toml"));
        fs::write(&file, bad.replace("sweep.toml", "x")).unwrap();
        let out = tmp.path().join(format!("out{i}"));
        let at = at.replace("sweep.toml", &format!("bad{i}.toml"));
        orchestrator()
            .arg("sweep")
            .arg(&file)
            .arg("--out")
            .arg(&out)
            .fails(&[at.as_str(), what]);
        assert!(!out.exists(), "case {i} wrote {}", out.display());
    }
    orchestrator()
        .arg("sweep")
        .arg(&sweep)
        .args(["--shard", "3/3"])
        .fails(&["K must be below N"]);
    // A scenario given to `sweep`, and a sweep file given to `run`, say what they are.
    let base = tmp.path().join("base.toml");
    let out = tmp.path().join("mixed");
    orchestrator()
        .arg("sweep")
        .arg(&base)
        .arg("--out")
        .arg(&out)
        .fails(&[
            // The reader names the unknown keys in sorted order: `connection` first.
            "base.toml:13: unknown field `connection`",
            "this is a scenario",
        ]);
    orchestrator()
        .arg("run")
        .arg(&sweep)
        .arg("--out")
        .arg(&out)
        .fails(&["sweep.toml:4: unknown field `axis`", "this is a sweep file"]);
    assert!(!out.exists(), "a refused file wrote {}", out.display());
    // A base whose FMU path was written as for a shell says that it is taken as written.
    let shell = tmp.path().join("shell");
    fs::create_dir(&shell).unwrap();
    let base_text = fs::read_to_string(&base).unwrap();
    let plant = format!("{:?}", built_fmu("CkcmPlant").to_str().unwrap());
    assert!(base_text.contains(&plant));
    fs::write(
        shell.join("base.toml"),
        base_text.replace(&plant, "\"~/fmus/CkcmPlant.fmu\""),
    )
    .unwrap();
    fs::write(shell.join("sweep.toml"), &text).unwrap();
    orchestrator()
        .arg("sweep")
        .arg(shell.join("sweep.toml"))
        .arg("--out")
        .arg(&out)
        .fails(&[
            "base.toml: FMU",
            "CkcmPlant.fmu: no such file",
            "`~` and environment variables are not expanded",
        ]);
    assert!(!out.exists(), "a refused sweep wrote {}", out.display());
    // Shards of two different sweeps, and a missing shard, do not merge.
    let other = tmp.path().join("other.toml");
    fs::write(&other, text.replace("seed = 3", "seed = 4")).unwrap();
    let a0 = shard_of_two(&sweep, 0, tmp.path(), "a0");
    let b1 = shard_of_two(&other, 1, tmp.path(), "b1");
    let merged = tmp.path().join("merged");
    orchestrator()
        .args(["sweep", "merge"])
        .arg(&sweep)
        .arg(&a0)
        .arg(&b1)
        .arg("--out")
        .arg(&merged)
        .fails(&["b1 is a shard of a different sweep"]);
    orchestrator()
        .args(["sweep", "merge"])
        .arg(&sweep)
        .arg(&a0)
        .arg("--out")
        .arg(&merged)
        .fails(&["shards 1/2 are missing"]);
    assert!(
        !merged.exists(),
        "a failed merge wrote {}",
        merged.display()
    );
    // A file where the output folder goes is named.
    let taken = tmp.path().join("taken");
    fs::write(&taken, "a user's file").unwrap();
    let named = format!("{} is a file, not a folder", taken.display());
    orchestrator()
        .arg("sweep")
        .arg(&sweep)
        .arg("--out")
        .arg(taken.join("out"))
        .fails(&[&named]);
    let a1 = shard_of_two(&sweep, 1, tmp.path(), "a1");
    orchestrator()
        .args(["sweep", "merge"])
        .arg(&sweep)
        .arg(&a0)
        .arg(&a1)
        .arg("--out")
        .arg(&taken)
        .fails(&[&named]);
    assert_eq!(fs::read_to_string(&taken).unwrap(), "a user's file");
}

#[test]
fn memory_update_axes_and_case_seeds_reach_each_case_scenario() {
    let tmp = tempfile::tempdir().unwrap();
    setup(tmp.path(), 2);
    let sweep = tmp.path().join("memory.toml");
    fs::write(
        &sweep,
        "base = \"base.toml\"\ntrials = 2\n\
         [[axis]]\nname = \"scheme\"\nmemory = \"controller.memory\"\nsetting = \"update\"\n\
         values = [{}, { filter = \"butterworth\", order = 2, cutoff = 8.0 }]\nlabels = [\"paper\", \"filtered\"]\n\
         [[axis]]\nmemory = \"controller.memory\"\nsetting = \"lead\"\nvalues = [0, 5]\n\
         [seeds]\nparameter = \"plant.noise_seed\"\nbase = 7\nstride = 100\nper_trial = 1\n",
    )
    .unwrap();
    let out = tmp.path().join("out");
    orchestrator()
        .arg("sweep")
        .arg(&sweep)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let case = |i: usize| -> toml::Table {
        let text =
            fs::read_to_string(out.join(format!("cases/case_{i:04}/scenario.toml"))).unwrap();
        toml::from_str(&text).unwrap()
    };
    // Case 1: the paper's update table with only the lead set; case 3: the filter and lead 5.
    let update = |t: &toml::Table| t["memory"].as_array().unwrap()[0].get("update").cloned();
    let u1 = update(&case(1)).expect("the lead axis adds an update table");
    assert_eq!(u1.get("lead").and_then(toml::Value::as_integer), Some(5));
    assert!(u1.get("filter").is_none(), "{u1:?}");
    let u3 = update(&case(3)).unwrap();
    assert_eq!(
        u3.get("filter").and_then(toml::Value::as_str),
        Some("butterworth")
    );
    assert_eq!(u3.get("cutoff").and_then(toml::Value::as_float), Some(8.0));
    assert_eq!(u3.get("lead").and_then(toml::Value::as_integer), Some(5));
    // The seed is per case and per trial: { base = 7 + 100·case, per_trial = 1 }.
    let case3 = case(3);
    let seed = &case3["fmu"].as_array().unwrap()[1]["parameters"]["noise_seed"];
    assert_eq!(
        seed.get("base").and_then(toml::Value::as_integer),
        Some(307)
    );
    assert_eq!(
        seed.get("per_trial").and_then(toml::Value::as_integer),
        Some(1)
    );
    let csv = fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert!(
        csv.lines().nth(4).unwrap().starts_with("3,filtered,5,"),
        "{csv}"
    );
}

/// An axis that moves the controller's reference, with `metrics.trajectory` left out of the
/// base: each case's path error is measured against its own reference (the figures of the
/// case's path written out). A learning update that overflows fails its case, naming the
/// update, and the sweep goes on; the report counts one trial as one.
#[test]
fn each_case_is_measured_against_its_own_reference_and_an_overflow_fails_its_case() {
    let tmp = tempfile::tempdir().unwrap();
    let base = |metrics_trajectory: &str| {
        closed_loop(
            2,
            &format!(
                "[metrics]\nreference = \"controller.length_ref\"\nlength = \"plant.length_true\"\n\
                 pose = \"plant.pose\"\n{metrics_trajectory}"
            ),
        )
    };
    fs::write(tmp.path().join("base.toml"), base("")).unwrap();
    let sweep = tmp.path().join("duration.toml");
    fs::write(
        &sweep,
        "base = \"base.toml\"\ntrials = 1\n\
         [[axis]]\nname = \"duration\"\nparameters = [\"controller.duration\"]\nvalues = [0.4, 0.8]\n",
    )
    .unwrap();
    let out = tmp.path().join("out");
    sweep_succeeds(&sweep, &out, 1);
    // Case 1 alone, its path written out: the same summary, byte for byte.
    let alone = tmp.path().join("alone.toml");
    let text = base("trajectory = { kind = \"circle\", duration = 0.8 }\n")
        .replace("duration = 0.4\n", "duration = 0.8\n");
    fs::write(&alone, text).unwrap();
    let alone_out = tmp.path().join("alone");
    orchestrator()
        .arg("run")
        .arg(&alone)
        .args(["--trials", "1", "--out"])
        .arg(&alone_out)
        .assert()
        .success();
    let summary = |dir: &Path| fs::read_to_string(dir.join("summary.csv")).unwrap();
    assert_eq!(summary(&out.join("cases/case_0001")), summary(&alone_out));
    assert_ne!(
        summary(&out.join("cases/case_0000")),
        summary(&alone_out),
        "the two cases' paths differ"
    );
    let report = fs::read_to_string(out.join("sweep-report.md")).unwrap();
    assert!(report.contains(": 2 cases (every combination of the axes), 1 trial each."));

    // A gain that overflows the memory: that case fails, the other runs.
    let sweep = tmp.path().join("gain.toml");
    fs::write(
        &sweep,
        "base = \"base.toml\"\n\
         [[axis]]\nmemory = \"controller.memory\"\nsetting = \"gain\"\nvalues = [1.0, 1e308]\n",
    )
    .unwrap();
    let out = tmp.path().join("gain");
    let stderr = sweep_succeeds(&sweep, &out, 1);
    assert!(
        stderr.contains("1 of the 2 cases run here failed"),
        "{stderr}"
    );
    let outcome = fs::read_to_string(out.join("cases/case_0001/outcome.toml")).unwrap();
    assert!(outcome.contains("status = \"failed\""), "{outcome}");
    assert!(
        outcome.contains(
            "trial 0: the update of memory channel \"controller.memory\" ([memory.update]: \
             no filter, lead δ = 0 samples, forgetting α = 1, gain g = 1e308) made the next \
             trial's memory not finite"
        ),
        "{outcome}"
    );
    let csv = fs::read_to_string(out.join("sweep.csv")).unwrap();
    assert!(
        csv.lines().nth(1).unwrap().contains(",converged,2,"),
        "{csv}"
    );
    assert!(csv.lines().nth(2).unwrap().contains(",failed,0,"), "{csv}");
}

/// An axis whose values span more than a double (forgetting ±1.7e308, which one trial
/// survives): its figure is left out with a warning, and the sweep finishes. Before, laying
/// out that figure's axis never ended.
#[test]
fn an_axis_spanning_more_than_a_double_leaves_its_figure_out() {
    let tmp = tempfile::tempdir().unwrap();
    setup(tmp.path(), 1);
    let sweep = tmp.path().join("alpha.toml");
    fs::write(
        &sweep,
        "base = \"base.toml\"\ntrials = 1\n[[axis]]\nname = \"alpha\"\n\
         memory = \"controller.memory\"\nsetting = \"forgetting\"\n",
    )
    .unwrap();
    for (values, drawn) in [("[-1.7e308, 1.7e308]", false), ("[-8e307, 8e307]", true)] {
        let mut text = fs::read_to_string(&sweep).unwrap();
        text.truncate(text.find("values").unwrap_or(text.len()));
        fs::write(&sweep, format!("{text}values = {values}\n")).unwrap();
        let out = tmp.path().join(format!("out-{drawn}"));
        let o = orchestrator()
            .arg("sweep")
            .arg(&sweep)
            .arg("--out")
            .arg(&out)
            .timeout(Duration::from_secs(120))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{values}: {stderr}");
        let figure = out.join("figures/final_vs_alpha.svg");
        assert_eq!(figure.is_file(), drawn, "{values}");
        let report = fs::read_to_string(out.join("sweep-report.md")).unwrap();
        assert_eq!(report.contains("final_vs_alpha.svg"), drawn, "{values}");
        assert_eq!(
            stderr.contains(
                "warning: figures/final_vs_alpha.svg is not drawn: the values of axis \"alpha\" \
                 span more than a linear axis can hold"
            ),
            !drawn,
            "{stderr}"
        );
    }
}

/// `--fmu-logging` forwards the FMUs' messages, named by instance, as `simulate` does.
#[test]
fn fmu_logging_forwards_the_fmus_messages() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 1);
    let o = orchestrator()
        .arg("sweep")
        .arg(&sweep)
        .arg("--out")
        .arg(tmp.path().join("out"))
        .args(["--jobs", "1", "--fmu-logging"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    for fmu in ["controller", "plant"] {
        assert!(err.contains(&format!("{fmu}: [fmi2OK] ")), "{err}");
    }
    let o = orchestrator()
        .arg("run")
        .arg(tmp.path().join("base.toml"))
        .arg("--out")
        .arg(tmp.path().join("run"))
        .args(["--trials", "1", "--fmu-logging"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("plant: [fmi2OK] "), "{err}");
}

/// A case's scenario is generated in memory: a problem in it names the sweep file, the case
/// and the base scenario, never a generated file and line that do not exist.
#[test]
fn a_refused_case_names_the_sweep_case_and_base_not_a_generated_file() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 2);
    let base = tmp.path().join("base.toml");
    let text = fs::read_to_string(&base).unwrap();
    fs::write(
        &base,
        text.replace("[record]\n", "[record]\ntrials = [2]\n"),
    )
    .unwrap();
    let with_record = fs::read_to_string(&sweep)
        .unwrap()
        .replace("seed = 3\n", "seed = 3\nrecord = true\n");
    fs::write(&sweep, with_record).unwrap();
    let out = tmp.path().join("out");
    let o = orchestrator()
        .arg("sweep")
        .arg(&sweep)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(&format!("{}: case 0 (0.8, ", sweep.display()))
            && err.contains(&format!("generated from {}", base.display()))
            && err.contains("record.trials lists trial 2, but trials are numbered 0..1"),
        "{err}"
    );
    assert!(!err.contains("case_0000"), "{err}");
    assert!(!out.exists(), "a refused sweep wrote {}", out.display());
}

#[test]
fn a_failing_case_is_reported_and_counted_and_the_sweep_goes_on() {
    let tmp = tempfile::tempdir().unwrap();
    setup(tmp.path(), 1);
    // A feedback gain 200 times the default drives the plant out of its workspace at once.
    let sweep = tmp.path().join("kp.toml");
    fs::write(
        &sweep,
        "base = \"base.toml\"\ntrials = 1\n\
         [[axis]]\nname = \"kp\"\nparameters = [\"controller.kp\"]\nvalues = [50000.0, 1e7]\n",
    )
    .unwrap();
    let out = tmp.path().join("out");
    let err = sweep_succeeds(&sweep, &out, 1);
    assert!(err.contains("case 0 done, 1 of 2 (50000)"), "{err}");
    assert!(err.contains("case 1 failed: trial 0, t = "), "{err}");
    assert!(
        err.contains("1 of the 2 cases run here failed; each one's outcome.toml says why"),
        "{err}"
    );
    let outcome = fs::read_to_string(out.join("cases/case_0001/outcome.toml")).unwrap();
    assert!(outcome.contains("status = \"failed\""), "{outcome}");
}

#[test]
fn a_broken_fmu_of_the_base_is_named_once() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = setup(tmp.path(), 1);
    // The plant replaced by a file that is no archive: the import error names the file
    // itself, so the sweep's message must not name it a second time.
    let broken = tmp.path().join("broken.fmu");
    fs::write(&broken, b"not a zip").unwrap();
    let base = fs::read_to_string(tmp.path().join("base.toml")).unwrap();
    let plant = format!("{:?}", built_fmu("CkcmPlant"));
    fs::write(
        tmp.path().join("base.toml"),
        base.replace(&plant, &format!("{broken:?}")),
    )
    .unwrap();
    let o = orchestrator()
        .arg("sweep")
        .arg(&sweep)
        .arg("--out")
        .arg(tmp.path().join("out"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(err.contains("is not a zip archive"), "{err}");
    assert_eq!(
        err.matches(broken.to_str().unwrap()).count(),
        1,
        "the path once: {err}"
    );
}
