//! End-to-end: the `paper` study and campaigns through the real FMUs and the CLI.
//!
//! Needs the packaged FMUs (`cargo xtask fmu`; `cargo xtask test` builds them first).

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use common::tree;

fn fmu_dir() -> PathBuf {
    common::built_fmu("CkcmPlant");
    common::built_fmu("HlcsController")
        .parent()
        .expect("an FMU inside a directory")
        .to_path_buf()
}

fn orchestrator() -> Command {
    Command::cargo_bin("orchestrator").expect("the orchestrator binary is built")
}

/// The same file names with the same bytes.
fn assert_same_files(a: &BTreeMap<PathBuf, Vec<u8>>, b: &BTreeMap<PathBuf, Vec<u8>>, when: &str) {
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "file lists differ {when}"
    );
    for (k, v) in a {
        assert!(v == &b[k], "{} differs {when}", k.display());
    }
}

/// Parses `xml` (failing on malformed markup) and returns every element name, every
/// attribute (name, value), and the text of every `<text>` element.
fn parse_xml(xml: &str, what: &str) -> (Vec<String>, Vec<(String, String)>, Vec<String>) {
    use quick_xml::events::Event;
    let mut reader = quick_xml::Reader::from_str(xml);
    let (mut names, mut attrs, mut texts) = (Vec::new(), Vec::new(), Vec::new());
    let mut in_text: Option<String> = None;
    loop {
        let ev = reader.read_event().unwrap_or_else(|e| {
            panic!(
                "{what} is not well-formed at {}: {e}",
                reader.error_position()
            )
        });
        match ev {
            Event::Start(e) | Event::Empty(e) => {
                let name = e.name().as_ref().to_owned();
                for a in e.attributes() {
                    let a = a.unwrap_or_else(|err| panic!("{what}: bad attribute: {err}"));
                    attrs.push((a.key.as_ref().to_owned(), a.value.into_owned()));
                }
                if name == "text" {
                    in_text = Some(String::new());
                }
                names.push(name);
            }
            Event::End(e) if e.name().as_ref() == "text" => {
                texts.push(in_text.take().unwrap_or_default().trim().to_owned());
            }
            Event::Text(t) => {
                if let Some(c) = &mut in_text {
                    c.push_str(&t.xml10_content());
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    (names, attrs, texts)
}

/// Every figure parses, and each has its own title naming its figure and letter.
fn check_figures(dir: &Path) {
    let mut files: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    let mut expected = orchestrator::paper::figures::figure_files();
    expected.sort();
    assert_eq!(files, expected, "figure files");
    let mut titles = std::collections::BTreeSet::new();
    for f in &files {
        let svg = std::fs::read_to_string(dir.join(f)).unwrap();
        let (names, _, texts) = parse_xml(&svg, f);
        assert_eq!(names.first().map(String::as_str), Some("svg"), "{f}");
        let title = texts.first().cloned().unwrap_or_default();
        let (fig, t) = if f.starts_with("beyond_") {
            ("Beyond the paper", "")
        } else if let Some(t) = f.strip_prefix("line_") {
            ("Fig. 6", t)
        } else if let Some(t) = f.strip_prefix("circle_") {
            ("Fig. 7", t)
        } else {
            ("Fig. 8", f.as_str())
        };
        // The paper's panels a–d keep its figure number; the extra figures are E1–E4 on the
        // line and E5–E8 on the circle, so that none passes for a panel of the paper's.
        let extra = |i: usize| format!("Fig. E{}", if fig == "Fig. 6" { i } else { i + 4 });
        let expected = match t {
            "pid_leg_errors.svg" => format!("{fig}a"),
            "pd_ilc_leg_errors.svg" => format!("{fig}b"),
            "hlcs_leg_errors.svg" => format!("{fig}c"),
            "path.svg" => format!("{fig}d"),
            "path_error.svg" => extra(1),
            "spectrum.svg" => extra(2),
            "forces.svg" => extra(3),
            "learned_input.svg" => extra(4),
            _ => fig.to_owned(),
        };
        assert!(
            title.starts_with(&format!("{expected}:")),
            "{f}: title {title:?}"
        );
        if f.starts_with("convergence_lambda") {
            assert!(title.contains("ρ = "), "{f}: ρ not in the title {title:?}");
        }
        assert!(
            titles.insert(title.clone()),
            "{f}: title {title:?} used twice"
        );
        for t in &texts {
            assert!(
                !(t.starts_with("-0") && t.parse::<f64>() == Ok(0.0)),
                "{f}: tick label {t:?}"
            );
        }
    }
}

/// The HTML report is well-formed and self-contained: every figure inline, no reference to
/// another file or the network.
fn check_html(path: &Path) {
    let html = std::fs::read_to_string(path).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"), "doctype");
    let (names, attrs, texts) = parse_xml(&html, "report.html");
    assert_eq!(names.first().map(String::as_str), Some("html"));
    for bad in ["img", "link", "script", "iframe", "object", "embed"] {
        assert!(!names.iter().any(|n| n == bad), "report.html has <{bad}>");
    }
    for (k, v) in &attrs {
        let k = k.to_ascii_lowercase();
        assert!(
            !(k == "src" || k.ends_with("href")) || v.starts_with('#'),
            "report.html refers to {v:?} ({k})"
        );
        assert!(!v.contains("url("), "report.html refers to {v:?}");
    }
    assert!(!html.contains("@import"), "report.html imports a style");
    let svgs = names.iter().filter(|n| *n == "svg").count();
    assert_eq!(
        svgs,
        orchestrator::paper::figures::figure_files().len(),
        "inline figures"
    );
    assert!(
        texts.iter().any(|t| t.starts_with("Fig. 8")),
        "figure text inline"
    );
}

/// The verdicts printed in report.md are the ones graded from the CSVs.
fn check_verdicts(root: &Path) {
    use orchestrator::paper::claims::{Tables, grade};
    let grades = grade(&Tables::load(root).unwrap()).unwrap();
    let report = std::fs::read_to_string(root.join("report.md")).unwrap();
    for (i, v) in grades.verdicts.iter().enumerate() {
        let v = v.expect("graded");
        let heading = report
            .lines()
            .find(|l| l.starts_with(&format!("### {}.", i + 1)))
            .unwrap_or_else(|| panic!("no heading for claim {}", i + 1));
        assert!(
            heading.ends_with(&format!("— **{}**", v.as_str())),
            "claim {}: {heading:?} vs {v:?}",
            i + 1
        );
    }
}

/// (trial, overall max) of each row of a summary.csv.
fn max_errors(summary: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(summary).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header.iter().position(|h| *h == "max").unwrap();
    lines
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect()
}

/// `paper` with 4 s paths and 6 robust trials into `out`, then `options`.
fn short_study(out: &Path, options: &[&str]) -> Command {
    let mut c = orchestrator();
    c.args(["paper", "--line-duration", "4", "--circle-duration", "4"])
        .args(["--robust-trials", "6", "--fmu-dir"])
        .arg(fmu_dir())
        .arg("--out")
        .arg(out)
        .args(options);
    c
}

#[test]
fn paper_study_writes_every_file_and_learning_works() {
    let out = tempfile::tempdir().unwrap();
    let status = short_study(out.path(), &["--trials", "5"])
        .status()
        .unwrap();
    assert!(status.success());
    let root = out.path();
    for f in ["report.md", "convergence.csv", "robust.csv"] {
        assert!(root.join(f).is_file(), "{f}");
    }
    // Beyond the paper: every case ran its 6 trials (the plant did not stop any in 6), and
    // the robust cases learn on both paths.
    let robust = orchestrator::paper::robust::load(root).unwrap();
    for (c, s) in orchestrator::paper::robust::CASES.iter().zip(&robust) {
        assert_eq!(s.max.len(), 6, "{}", c.slug);
        assert!(s.stopped.is_none(), "{}", c.slug);
        assert!(
            !c.robust || s.max[5] < 0.1 * s.max[0],
            "{}: trial 5 {} vs trial 0 {}",
            c.slug,
            s.max[5],
            s.max[0]
        );
        let case = root
            .join("robust")
            .join(if c.trajectory == ckcm::TrajectoryKind::Line {
                "line"
            } else {
                "circle"
            })
            .join(c.slug);
        for f in ["scenario.toml", "summary.csv", "outcome.toml"] {
            assert!(case.join(f).is_file(), "{}/{f}", c.slug);
        }
    }
    check_figures(&root.join("figures"));
    check_html(&root.join("report.html"));
    check_verdicts(root);
    for t in ["line", "circle"] {
        for s in ["pid", "pd_ilc", "hlcs"] {
            let case = root.join(t).join(s);
            for f in [
                "scenario.toml",
                "summary.csv",
                "progress.toml",
                "memory/after_trial_004.f64",
            ] {
                assert!(case.join(f).is_file(), "{t}/{s}/{f}");
            }
            for k in 0..5 {
                assert!(
                    case.join(format!("trials/trial_{k:03}.csv")).is_file(),
                    "{t}/{s} trial {k}"
                );
            }
            if s != "pid" {
                let rec = std::fs::read_to_string(case.join("trials/trial_004.csv")).unwrap();
                assert!(
                    rec.lines()
                        .next()
                        .unwrap()
                        .contains("controller.memory_next[6]"),
                    "{t}/{s}: the learned input is recorded"
                );
            }
            let e = max_errors(&case.join("summary.csv"));
            assert_eq!(e.len(), 5);
            if s == "pid" {
                // Learning off: every trial is the same trial.
                assert!(e.iter().all(|&x| x == e[0]), "{t}/pid: {e:?}");
                let first = std::fs::read(case.join("trials/trial_000.csv")).unwrap();
                let last = std::fs::read(case.join("trials/trial_004.csv")).unwrap();
                assert!(first == last, "{t}/pid: trial 0 and trial 4 differ");
            } else {
                assert!(
                    e[2] < 0.2 * e[0],
                    "{t}/{s}: trial 2 {} vs trial 0 {}",
                    e[2],
                    e[0]
                );
            }
        }
    }
    let report = std::fs::read_to_string(root.join("report.md")).unwrap();
    for claim in [
        "### 1.",
        "### 2.",
        "### 3.",
        "### 4.",
        "Known effect",
        "Grading rule",
    ] {
        assert!(report.contains(claim), "report lacks {claim}");
    }
    assert!(!report.contains("{{"), "unfilled placeholder in report.md");
    // Campaigns run in parallel by default; one at a time gives the very same files.
    let serial = tempfile::tempdir().unwrap();
    let status = short_study(serial.path(), &["--trials", "5", "--jobs", "1"])
        .status()
        .unwrap();
    assert!(status.success());
    assert_same_files(
        &tree(root),
        &tree(serial.path()),
        "between --jobs 1 and parallel campaigns",
    );
    // `--resume` with other options names the first line where a case's scenario differs,
    // and that a study resumes with the options it began with; nothing changes.
    let before = tree(serial.path());
    let o = short_study(serial.path(), &["--resume", "--trials", "6"])
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains(
            "reads `trials = [0, 1, 2, 3, 4]`, where this scenario has `trials = [0, 1, 2, 3, 4, \
             5]`; `paper --resume` continues a study with the options and FMUs it began with"
        ),
        "{err}"
    );
    assert_same_files(&before, &tree(serial.path()), "after a refused resume");
}

fn line_scenario(dir: &Path, trials: usize) -> PathBuf {
    let fmus = fmu_dir();
    let p = dir.join("line.toml");
    std::fs::write(
        &p,
        format!(
            r#"step_size = 0.001
stop_time = 2.0
trials = {trials}
[[fmu]]
name = "controller"
path = "{c}"
[fmu.parameters]
trajectory = "line"
duration = 2.0
[[fmu]]
name = "plant"
path = "{p}"
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
variables = ["controller.error", "controller.memory_next", "plant.pose"]
[metrics]
error = "controller.error"
pose = "plant.pose"
trajectory = {{ kind = "line", duration = 2.0 }}
"#,
            c = fmus.join("HlcsController.fmu").display(),
            p = fmus.join("CkcmPlant.fmu").display()
        ),
    )
    .unwrap();
    p
}

#[test]
fn interrupted_and_resumed_campaign_equals_uninterrupted() {
    let tmp = tempfile::tempdir().unwrap();
    let scenario = line_scenario(tmp.path(), 5);
    let whole = tmp.path().join("whole");
    let parts = tmp.path().join("parts");
    assert!(
        orchestrator()
            .arg("run")
            .arg(&scenario)
            .arg("--out")
            .arg(&whole)
            .status()
            .unwrap()
            .success()
    );
    assert!(
        orchestrator()
            .arg("run")
            .arg(&scenario)
            .arg("--out")
            .arg(&parts)
            .args(["--stop-after", "2"])
            .status()
            .unwrap()
            .success()
    );
    let progress = std::fs::read_to_string(parts.join("progress.toml")).unwrap();
    assert!(progress.contains("completed = 2"), "{progress}");
    assert!(
        orchestrator()
            .arg("run")
            .arg(&scenario)
            .arg("--out")
            .arg(&parts)
            .arg("--resume")
            .status()
            .unwrap()
            .success()
    );
    assert_same_files(&tree(&whole), &tree(&parts), "after resume");
    // The memory really carried over: trial 1 learned from trial 0.
    let e = max_errors(&parts.join("summary.csv"));
    assert!(e[1] < 0.5 * e[0], "{e:?}");
}

#[test]
fn killed_and_resumed_campaign_equals_uninterrupted() {
    let tmp = tempfile::tempdir().unwrap();
    let trials = 60;
    let scenario = line_scenario(tmp.path(), trials);
    // With the paper's learning gains this fast 2 s line diverges after about 30 trials and
    // the plant stops at its workspace limits (the platform reaches the base plane in trial
    // 35); halved gains keep all 60 trials converging, so the campaign runs to the end.
    let text = std::fs::read_to_string(&scenario).unwrap();
    let text = text.replacen(
        "duration = 2.0\n[[fmu]]",
        "duration = 2.0\nphi = 20000.0\ngamma = 400.0\n[[fmu]]",
        1,
    );
    assert!(text.contains("phi = 20000.0"));
    std::fs::write(&scenario, text).unwrap();
    let whole = tmp.path().join("whole");
    let killed = tmp.path().join("killed");
    assert!(
        orchestrator()
            .arg("run")
            .arg(&scenario)
            .arg("--out")
            .arg(&whole)
            .status()
            .unwrap()
            .success()
    );
    let mut child = orchestrator()
        .arg("run")
        .arg(&scenario)
        .arg("--out")
        .arg(&killed)
        .spawn()
        .unwrap();
    // Kill it (SIGKILL: no clean-up) as soon as at least one trial is on disk.
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        let done = std::fs::read_to_string(killed.join("progress.toml")).unwrap_or_default();
        if done.contains("completed = ") || Instant::now() > deadline {
            break;
        }
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    let _ = child.kill();
    let _ = child.wait();
    let at_kill = std::fs::read_to_string(killed.join("progress.toml")).unwrap_or_default();
    let completed: usize = at_kill
        .lines()
        .find_map(|l| l.strip_prefix("completed = "))
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or(0);
    assert!(
        completed < trials,
        "the campaign finished before it could be killed: nothing was tested"
    );
    assert!(
        orchestrator()
            .arg("run")
            .arg(&scenario)
            .arg("--out")
            .arg(&killed)
            .arg("--resume")
            .status()
            .unwrap()
            .success()
    );
    // A kill can leave a temporary file of an atomic write behind; results are never torn.
    let killed: BTreeMap<_, _> = tree(&killed)
        .into_iter()
        .filter(|(k, _)| !k.to_string_lossy().contains(".tmp-"))
        .collect();
    assert_same_files(&tree(&whole), &killed, "after kill and resume");
}

#[test]
fn resume_refuses_a_different_scenario() {
    let tmp = tempfile::tempdir().unwrap();
    let scenario = line_scenario(tmp.path(), 3);
    let out = tmp.path().join("out");
    assert!(
        orchestrator()
            .arg("run")
            .arg(&scenario)
            .arg("--out")
            .arg(&out)
            .args(["--stop-after", "1"])
            .status()
            .unwrap()
            .success()
    );
    let text = std::fs::read_to_string(&scenario).unwrap().replace(
        "duration = 2.0\n[[fmu]]",
        "duration = 2.0\npsi = 0.0\n[[fmu]]",
    );
    std::fs::write(&scenario, text).unwrap();
    let o = orchestrator()
        .arg("run")
        .arg(&scenario)
        .arg("--out")
        .arg(&out)
        .arg("--resume")
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("different scenario"), "{err}");
    assert!(err.contains("where this scenario has `psi = 0.0`"), "{err}");
}

/// FMUs in a folder whose name holds a quote and a backslash: the generated scenarios quote
/// the paths as TOML, so they read back as the same files (they once made a TOML error, or
/// a path with `/` for `\`).
#[cfg(unix)]
#[test]
fn fmus_in_a_folder_with_quotes_and_backslashes() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("FMUs \"new\" \\ 2026");
    std::fs::create_dir(&dir).unwrap();
    for name in ["CkcmPlant.fmu", "HlcsController.fmu"] {
        std::fs::copy(fmu_dir().join(name), dir.join(name)).unwrap();
    }
    let out = tmp.path().join("study");
    let o = orchestrator()
        .args(["paper", "--trials", "5", "--robust-trials", "5"])
        .args([
            "--line-duration",
            "0.2",
            "--circle-duration",
            "0.2",
            "--fmu-dir",
        ])
        .arg(&dir)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(out.join("line/pid/scenario.toml")).unwrap();
    let parsed: toml::Table = toml::from_str(&text).unwrap();
    let fmus = parsed["fmu"].as_array().unwrap();
    assert_eq!(
        fmus[1]["path"].as_str(),
        Some(dir.join("CkcmPlant.fmu").to_str().unwrap())
    );
}
