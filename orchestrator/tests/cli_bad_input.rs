//! Bad input through the CLI: each problem gets its own message (asserted on its text), a
//! non-zero exit, and no partial results (no output file or directory afterwards). FMU-level
//! problems go through `simulate`, `info` and `run`.

mod common;

use std::io::Write;
use std::path::{Path, PathBuf};

use common::{built_fmu, foreign_fmu, foreign_fmu_with, foreign_xml, orchestrator, repackage};

/// The outcome of one failing command.
struct Failure {
    stderr: String,
}

/// Runs `orchestrator args...`, which must fail without writing `must_not_exist`, and
/// within two minutes: a refusal is quick, and a command that hangs on bad input fails here
/// instead of stalling the suite.
fn fails(args: &[&std::ffi::OsStr], must_not_exist: &Path) -> Failure {
    let output = orchestrator()
        .args(args)
        .timeout(std::time::Duration::from_secs(120))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(
        !output.status.success(),
        "{args:?} should fail; stderr: {stderr}"
    );
    assert!(stderr.starts_with("error: "), "{args:?}: {stderr}");
    assert!(
        !must_not_exist.exists(),
        "{args:?} left {} behind",
        must_not_exist.display()
    );
    Failure { stderr }
}

impl Failure {
    fn says(&self, expected: &str) -> &Self {
        assert!(
            self.stderr.contains(expected),
            "expected {expected:?} in: {}",
            self.stderr
        );
        self
    }

    /// Like [`Failure::says`], and the text does not repeat (a cause printed twice).
    fn says_once(&self, expected: &str) -> &Self {
        assert_eq!(
            self.stderr.matches(expected).count(),
            1,
            "expected {expected:?} once in: {}",
            self.stderr
        );
        self
    }
}

/// `orchestrator run SCENARIO --out OUT`, which must fail without writing OUT.
fn run_fails(scenario: &Path, out: &Path) -> Failure {
    fails(
        &[
            "run".as_ref(),
            scenario.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        out,
    )
}

/// A scenario running `fmu` alone for 10 ms, written as `dir/<stem>.toml`.
fn scenario_for(dir: &Path, stem: &str, fmu: &Path) -> PathBuf {
    let path = dir.join(format!("{stem}.toml"));
    let text = format!(
        "step_size = 0.001\nstop_time = 0.01\n\n[[fmu]]\nname = \"unit\"\npath = {:?}\n",
        fmu.to_str().unwrap()
    );
    std::fs::write(&path, text).unwrap();
    path
}

/// Checks one broken FMU through `simulate`, `info` and `run`. `open_error` is what opening
/// it must report; `run` adds the scenario file and the line of the FMU's `path`.
fn check_fmu_problem(dir: &Path, fmu: &Path, open_error: &str) {
    let csv = dir.join("result.csv");
    fails(
        &[
            "simulate".as_ref(),
            fmu.as_os_str(),
            "-o".as_ref(),
            csv.as_os_str(),
        ],
        &csv,
    )
    .says_once(open_error);
    fails(&["info".as_ref(), fmu.as_os_str()], &csv).says_once(open_error);
    let scenario = scenario_for(dir, "single", fmu);
    let out = dir.join("run-out");
    run_fails(&scenario, &out)
        .says(&format!("{}:6: FMU \"unit\"", scenario.display()))
        .says_once(open_error);
}

#[test]
fn missing_fmu_file() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = dir.path().join("nowhere.fmu");
    check_fmu_problem(
        dir.path(),
        &fmu,
        &format!("{}: no such file", fmu.display()),
    );
    // A path a shell would have expanded says that the scenario's is not; a plain missing
    // path does not get the hint.
    let hint = "`~` and environment variables are not expanded";
    for written in ["~/fmus/X.fmu", "$HOME/X.fmu", "%USERPROFILE%\\X.fmu"] {
        let scenario = scenario_for(dir.path(), "shell", Path::new(written));
        run_fails(&scenario, &dir.path().join("out"))
            .says(&format!("{written}: no such file"))
            .says(hint);
    }
    let scenario = scenario_for(dir.path(), "plain", &fmu);
    let failure = run_fails(&scenario, &dir.path().join("out"));
    assert!(!failure.stderr.contains(hint), "{}", failure.stderr);
    assert!(!failure.stderr.contains("escape"), "{}", failure.stderr);

    // A Windows path between double quotes: `\U` is refused as an escape at the path's
    // line, and `\f`, `\n` are read as control characters, so the file is not found.
    let windows = |stem: &str, path: &str| {
        let file = dir.path().join(format!("{stem}.toml"));
        let text = format!(
            "step_size = 0.001\nstop_time = 0.01\n\n[[fmu]]\nname = \"unit\"\npath = \"{path}\"\n"
        );
        std::fs::write(&file, text).unwrap();
        run_fails(&file, &dir.path().join("out"))
    };
    windows("users", r"C:\Users\me\X.fmu")
        .says("users.toml:6:")
        .says(
            "a backslash starts an escape: write a Windows path with `/`, or between single quotes",
        );
    windows("formfeed", r"C:\fmus\new.fmu")
        .says("no such file")
        .says("the path holds a control character");
}

#[test]
fn a_file_that_is_not_a_zip() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = dir.path().join("text.fmu");
    std::fs::write(&fmu, "this is not an archive\n").unwrap();
    check_fmu_problem(
        dir.path(),
        &fmu,
        &format!("{} is not a zip archive", fmu.display()),
    );
}

/// A scenario or sweep file given to `info` or `simulate` in place of an FMU is named as one,
/// with the command that runs it; another text file only as text.
#[test]
fn a_scenario_or_sweep_file_given_as_an_fmu_names_its_command() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = scenario_for(dir.path(), "study", &dir.path().join("unit.fmu"));
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        "base = \"study.toml\"\n[[axis]]\nname = \"m\"\nparameters = [\"unit.m\"]\nvalues = [1.0]\n",
    )
    .unwrap();
    let other = dir.path().join("notes.toml");
    std::fs::write(&other, "title = \"not a scenario\"\n").unwrap();
    let csv = dir.path().join("result.csv");
    for (file, command) in [
        (&scenario, Some("run")),
        (&sweep, Some("sweep")),
        (&other, None),
    ] {
        for verb in ["info", "simulate"] {
            let failure = fails(&[verb.as_ref(), file.as_os_str()], &csv);
            failure.says_once(&format!(
                "{} is not a zip archive: it is a text file; an FMU is a zip archive",
                file.display()
            ));
            match command {
                Some(command) => {
                    failure.says(&format!(
                        "`orchestrator {command} {}` runs it",
                        file.display()
                    ));
                }
                None => assert!(!failure.stderr.contains("runs it"), "{}", failure.stderr),
            }
        }
    }
}

/// `info` and `simulate` given a named pipe or an endless device fail at once, naming it:
/// neither is opened or read in search of a scenario file.
#[cfg(unix)]
#[test]
fn a_pipe_or_device_given_as_an_fmu_fails_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.fmu");
    assert!(
        std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let csv = dir.path().join("result.csv");
    for (file, kind) in [
        (fifo.as_path(), "a named pipe"),
        (Path::new("/dev/zero"), "a device"),
    ] {
        for verb in ["info", "simulate"] {
            fails(&[verb.as_ref(), file.as_os_str()], &csv).says_once(&format!(
                "{} is not a zip archive: it is {kind}",
                file.display()
            ));
        }
    }
}

#[test]
fn a_zip_without_model_description() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = dir.path().join("empty.fmu");
    let mut zip = zip::ZipWriter::new(std::fs::File::create(&fmu).unwrap());
    zip.start_file(
        "documentation/readme.txt",
        zip::write::SimpleFileOptions::default(),
    )
    .unwrap();
    zip.write_all(b"no model description here").unwrap();
    zip.finish().unwrap();
    check_fmu_problem(
        dir.path(),
        &fmu,
        "contains no modelDescription.xml at the archive root",
    );
}

#[test]
fn an_fmu_whose_binary_is_cut_short() {
    // Loaded as it is, the library would be mapped and the first read past its end would
    // kill the process with SIGBUS, no message at all.
    let dir = tempfile::tempdir().unwrap();
    let fmu = dir.path().join("cut.fmu");
    repackage(&foreign_fmu(dir.path()), &fmu, |name, bytes| {
        Some(if name.starts_with("binaries/") {
            bytes[..bytes.len() / 3].to_vec()
        } else {
            bytes
        })
    });
    check_fmu_problem(
        dir.path(),
        &fmu,
        &format!(
            "{}: cannot load its binary binaries/{}/ForeignOscillator.{}: the file is",
            fmu.display(),
            fmi2_import::PLATFORM,
            fmi2_import::SHARED_LIBRARY_EXTENSION
        ),
    );
}

#[test]
fn a_parameter_set_twice_in_one_fmu_table() {
    // The whole array and one of its elements: both would apply, the later winning.
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("twice.toml");
    std::fs::write(
        &scenario,
        format!(
            "step_size = 0.001\nstop_time = 0.01\n\n[[fmu]]\nname = \"plant\"\npath = {:?}\n\
             [fmu.parameters]\ninitial_pose = [0.01, 0, 0, 0, 0, 0]\n\"initial_pose[1]\" = 0.02\n",
            built_fmu("CkcmPlant").to_str().unwrap()
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    run_fails(&scenario, &out)
        .says(&format!("{}:9:", scenario.display()))
        .says(
            "parameter \"initial_pose[1]\" sets initial_pose[1] again: \"initial_pose\" on line 8 \
         already sets it; give each value once",
        );
}

#[test]
fn malformed_model_description() {
    let dir = tempfile::tempdir().unwrap();
    let xml = foreign_xml().replace("</ModelVariables>", "</ModelVariablez>");
    let line = 1 + xml[..xml.find("</ModelVariablez>").unwrap()]
        .matches('\n')
        .count();
    let fmu = dir.path().join("malformed.fmu");
    // No binary: the description is read first, so its error must win.
    fmu_build::write_fmu(&fmu, &xml, None, &[]).unwrap();
    check_fmu_problem(
        dir.path(),
        &fmu,
        &format!("modelDescription.xml:{line}: malformed XML"),
    );
}

#[test]
fn fmi_1_model_description() {
    let dir = tempfile::tempdir().unwrap();
    let xml = r#"<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="1.0" modelName="Legacy" modelIdentifier="Legacy"
  guid="{11111111-2222-3333-4444-555555555555}" numberOfContinuousStates="0"
  numberOfEventIndicators="0">
  <ModelVariables/>
</fmiModelDescription>
"#;
    let fmu = dir.path().join("legacy.fmu");
    fmu_build::write_fmu(&fmu, xml, None, &[]).unwrap();
    check_fmu_problem(
        dir.path(),
        &fmu,
        "FMI 1.0 model descriptions are not supported (fmiVersion=\"1.0\")",
    );
}

#[test]
fn model_exchange_only_description() {
    let dir = tempfile::tempdir().unwrap();
    let xml = foreign_xml();
    let start = xml.find("<CoSimulation").unwrap();
    let end = start + xml[start..].find("/>").unwrap() + 2;
    let me_only = format!(
        "{}<ModelExchange modelIdentifier=\"ForeignOscillator\"/>{}",
        &xml[..start],
        &xml[end..]
    );
    // `write_fmu` needs a co-simulation description to place the binary, so package the
    // working FMU first and swap the description afterwards.
    let working = foreign_fmu(dir.path());
    let fmu = dir.path().join("me.fmu");
    repackage(&working, &fmu, |name, bytes| {
        Some(if name == "modelDescription.xml" {
            me_only.clone().into_bytes()
        } else {
            bytes
        })
    });
    check_fmu_problem(
        dir.path(),
        &fmu,
        "no <CoSimulation> element: this FMU is Model Exchange only",
    );
}

#[test]
fn missing_binary() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = dir.path().join("nobinary.fmu");
    fmu_build::write_fmu(&fmu, &foreign_xml(), None, &[]).unwrap();
    check_fmu_problem(
        dir.path(),
        &fmu,
        &format!(
            "no binary for this platform ({0}): expected binaries/{0}/ForeignOscillator.{1} \
             inside the archive; the archive has no binaries for any platform",
            fmi2_import::PLATFORM,
            fmi2_import::SHARED_LIBRARY_EXTENSION
        ),
    );
}

#[test]
fn guid_mismatch_fails_instantiation_with_the_fmus_own_message() {
    let dir = tempfile::tempdir().unwrap();
    let original = "{8f5b7a3e-2c41-4d0a-9b6e-5a1c0e7d9b21}";
    let forged = "{00000000-1111-2222-3333-444444444444}";
    let fmu = dir.path().join("forged.fmu");
    repackage(&built_fmu("CkcmPlant"), &fmu, |name, bytes| {
        if name != "modelDescription.xml" {
            return Some(bytes);
        }
        let xml = String::from_utf8(bytes).unwrap();
        assert!(xml.contains(original), "CkcmPlant.xml changed its GUID");
        Some(xml.replace(original, forged).into_bytes())
    });
    // The FMU's own log line, passed on verbatim.
    let fmu_says = format!("GUID mismatch: expected '{original}', received '{forged}'");

    let csv = dir.path().join("result.csv");
    fails(
        &[
            "simulate".as_ref(),
            fmu.as_os_str(),
            "-o".as_ref(),
            csv.as_os_str(),
        ],
        &csv,
    )
    .says_once("fmi2Instantiate failed for instance 'CkcmPlant'")
    .says_once(&fmu_says);

    let scenario = scenario_for(dir.path(), "forged", &fmu);
    let out = dir.path().join("run-out");
    run_fails(&scenario, &out)
        .says("fmi2Instantiate failed")
        .says(&fmu_says);

    // `info` only reads the archive, so it still describes it, showing the forged GUID.
    let output = orchestrator().arg("info").arg(&fmu).output().unwrap();
    assert!(output.status.success());
    assert!(String::from_utf8_lossy(&output.stdout).contains(forged));
}

#[test]
fn scenario_naming_an_unknown_variable() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(dir.path());
    let scenario = dir.path().join("bad.toml");
    std::fs::write(
        &scenario,
        format!(
            "step_size = 0.0078125\nstop_time = 0.5\n\n[[fmu]]\nname = \"osc\"\npath = {:?}\n\n\
             [record]\nvariables = [\"osc.x\", \"osc.position\"]\n",
            fmu.to_str().unwrap()
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    run_fails(&scenario, &out)
        .says(&format!("{}:9:", scenario.display()))
        .says("DampedOscillator has no variable \"position\"");
}

#[test]
fn scenario_with_a_toml_syntax_error() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("broken.toml");
    std::fs::write(
        &scenario,
        "step_size = 0.001\nstop_time = 1.0\n\n[[fmu]\nname = \"plant\"\n",
    )
    .unwrap();
    let out = dir.path().join("out");
    run_fails(&scenario, &out).says(&format!("{}:4:", scenario.display()));
}

#[test]
fn a_date_where_a_number_belongs_is_called_a_date() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("dated.toml");
    let out = dir.path().join("out");
    for value in ["1979-05-27", "07:32:00", "1979-05-27T07:32:00Z"] {
        std::fs::write(
            &scenario,
            format!("step_size = 0.001\nstop_time = 1.0\ntrials = {value}\n"),
        )
        .unwrap();
        run_fails(&scenario, &out)
            .says(&format!("{}:3:", scenario.display()))
            .says("invalid type: a date or time, expected a whole number");
    }
}

/// serde's messages name the Rust type wanted ("expected usize", "expected f64"); a user
/// writing a scenario reads the kind of number instead, and how to write it when a decimal
/// or a quoted number stands in its place.
#[test]
fn a_number_of_the_wrong_kind_is_named_in_words() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = dir.path().join("kinds.toml");
    let out = dir.path().join("out");
    for (line, says) in [
        (
            "trials = -1",
            "invalid value: integer `-1`, expected a whole number (not negative)",
        ),
        (
            "trials = 1e3",
            "invalid type: floating point `1000.0`, expected a whole number \
             (written without a decimal point or exponent: 2, not 2.0 or 2e0)",
        ),
        (
            "trials = \"3\"",
            "invalid type: string \"3\", expected a whole number (written without quotes)",
        ),
        (
            "step_size = \"1e-3\"",
            "invalid type: string \"1e-3\", expected a number (written without quotes)",
        ),
        (
            "step_size = \"fast\"",
            "invalid type: string \"fast\", expected a number\n",
        ),
        (
            "step_size = true",
            "invalid type: boolean `true`, expected a number\n",
        ),
    ] {
        let text = "step_size = 0.001\nstop_time = 1.0\ntrials = 2\n"
            .replace(&format!("{} = ", &line[..line.find(' ').unwrap()]), "#")
            + line
            + "\n";
        std::fs::write(&scenario, text).unwrap();
        run_fails(&scenario, &out).says(&format!("{}:4: {says}", scenario.display()));
    }
    // An FMU's parameter given a number in quotes is told it is text, not that "2.5" is no
    // number.
    let quoted = scenario_for(dir.path(), "quoted", &foreign_fmu(dir.path()));
    let mut text = std::fs::read_to_string(&quoted).unwrap();
    text.push_str("[fmu.parameters]\nmass = \"2.5\"\nsubsteps = \" 4\"\n");
    std::fs::write(&quoted, text).unwrap();
    run_fails(&quoted, &out)
        .says(
            ":8: \"2.5\" is quoted, so it is text, not a number: write it without quotes \
             ('mass' is a Real)",
        )
        .says(
            ":9: \" 4\" is quoted, so it is text, not a number: write it without quotes \
             ('substeps' is an Integer)",
        );
}

/// A scenario saved in another encoding than UTF-8 (Windows editors offer UTF-16 as
/// "Unicode", and Latin-1) is named with what it is and the line of the first bad byte,
/// not only "stream did not contain valid UTF-8"; an FMU given instead is named as one. A
/// UTF-8 byte-order mark and CRLF line ends, which the same editors write, are read.
#[test]
fn a_scenario_not_in_utf8_is_named_with_its_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let good = scenario_for(dir.path(), "unit", &foreign_fmu(dir.path()));
    let text = std::fs::read_to_string(&good).unwrap();
    let out = dir.path().join("out");
    let utf16 = dir.path().join("utf16.toml");
    let mut bytes = vec![0xff, 0xfe];
    bytes.extend(text.encode_utf16().flat_map(u16::to_le_bytes));
    std::fs::write(&utf16, bytes).unwrap();
    run_fails(&utf16, &out).says("utf16.toml: cannot read the scenario: it is UTF-16 text");
    let latin1 = dir.path().join("latin1.toml");
    let mut bytes = text.replacen("\n", "\n# M\u{fc}nster\n", 2).into_bytes();
    // ü in Latin-1 is one byte, 0xfc: replace its two UTF-8 bytes (0xc3 0xbc) on line 2.
    let at = bytes.windows(2).position(|w| w == [0xc3, 0xbc]).unwrap();
    bytes.splice(at..at + 2, [0xfc]);
    std::fs::write(&latin1, bytes).unwrap();
    run_fails(&latin1, &out).says("line 2 is not UTF-8 text (byte 0xfc)");
    // An FMU where the scenario belongs is called an archive, not text in a bad encoding.
    run_fails(&foreign_fmu(dir.path()), &out)
        .says("cannot read the scenario: it is a zip archive (an FMU?), not a scenario");
    let windows = dir.path().join("windows.toml");
    std::fs::write(&windows, format!("\u{feff}{}", text.replace('\n', "\r\n"))).unwrap();
    orchestrator()
        .arg("run")
        .arg(&windows)
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
}

/// A folder given where a scenario, sweep or input file belongs (a campaign's `--out`, as a
/// user resuming it might) is called a folder, with the command that continues what it
/// holds; that command works. Before, it said "Is a directory (os error 21)".
#[test]
fn a_folder_given_as_the_scenario_names_the_command_that_resumes_it() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = scenario_for(dir.path(), "unit", &foreign_fmu(dir.path()));
    let campaign = dir.path().join("campaign");
    orchestrator()
        .args([
            "run".as_ref(),
            scenario.as_os_str(),
            "--trials".as_ref(),
            "2".as_ref(),
        ])
        .arg("--out")
        .arg(&campaign)
        .assert()
        .success();
    let out = dir.path().join("out");
    let shown = campaign.display();
    run_fails(&campaign, &out).says(&format!(
        "{shown}: cannot read the scenario: it is a campaign's folder, not a scenario file: \
         its scenario is {shown}/scenario.toml (`orchestrator run {shown}/scenario.toml --out \
         {shown} --resume` continues the campaign)"
    ));
    orchestrator()
        .arg("run")
        .arg(campaign.join("scenario.toml"))
        .args(["--out".as_ref(), campaign.as_os_str(), "--resume".as_ref()])
        .args(["--trials", "3"])
        .assert()
        .success();
    assert!(campaign.join("memory/after_trial_002.f64").exists());

    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    run_fails(&empty, &out).says(&format!(
        "{}: cannot read the scenario: it is a folder, not a file",
        empty.display()
    ));
    let csv = dir.path().join("result.csv");
    fails(
        &[
            "simulate".as_ref(),
            foreign_fmu(dir.path()).as_os_str(),
            "--input".as_ref(),
            empty.as_os_str(),
            "-o".as_ref(),
            csv.as_os_str(),
        ],
        &csv,
    )
    .says(&format!(
        "cannot read the input file {}: it is a folder, not a CSV file",
        empty.display()
    ));
    let swept = dir.path().join("swept");
    std::fs::create_dir(&swept).unwrap();
    std::fs::write(swept.join("sweep.toml"), "").unwrap();
    fails(&["sweep".as_ref(), swept.as_os_str()], &out).says(&format!(
        "it is a sweep's folder, not a sweep file; `orchestrator sweep SWEEP.toml --out {} \
         --resume`, with the sweep file it began with, continues its sweep",
        swept.display()
    ));
}

#[test]
fn simulate_setting_an_unknown_variable() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("result.csv");
    let plant = built_fmu("CkcmPlant");
    fails(
        &[
            "simulate".as_ref(),
            plant.as_os_str(),
            "--set".as_ref(),
            "nosuchvar=1".as_ref(),
            "-o".as_ref(),
            csv.as_os_str(),
        ],
        &csv,
    )
    .says("--set nosuchvar=1: model 'CkcmPlant' has no variable named 'nosuchvar'");
    // A near miss gets suggestions.
    fails(
        &[
            "simulate".as_ref(),
            plant.as_os_str(),
            "--set".as_ref(),
            "radius=1".as_ref(),
            "-o".as_ref(),
            csv.as_os_str(),
        ],
        &csv,
    )
    .says("similar names: base_radius, platform_radius");
}

/// `paper` generates its scenarios in memory: a refused one is named by its case and the
/// options it comes from, not by a scenario.toml that was never written.
#[test]
fn paper_names_the_case_of_a_refused_generated_scenario() {
    let dir = tempfile::tempdir().unwrap();
    let fmus = dir.path().join("fmus");
    std::fs::create_dir(&fmus).unwrap();
    std::fs::copy(built_fmu("CkcmPlant"), fmus.join("CkcmPlant.fmu")).unwrap();
    // Named as the controller (the study checks the model name first), but without its
    // variables, so the generated scenario is what refuses it.
    let xml = foreign_xml().replace(
        "modelName=\"DampedOscillator\"",
        "modelName=\"HlcsController\"",
    );
    foreign_fmu_with(&fmus, "HlcsController.fmu", &xml);
    let out = dir.path().join("paper");
    let f = fails(
        &[
            "paper".as_ref(),
            "--fmu-dir".as_ref(),
            fmus.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
            "--line-duration".as_ref(),
            "1".as_ref(),
            "--circle-duration".as_ref(),
            "1".as_ref(),
        ],
        &out,
    );
    assert!(
        f.stderr.contains("line / PID: its scenario, generated from the paper options and the FMUs in --fmu-dir, is refused: parameter \"trajectory\": HlcsController has no variable"),
        "{}",
        f.stderr
    );
    assert!(!f.stderr.contains("scenario.toml"), "{}", f.stderr);
}

/// `--jobs 0` means the same to every subcommand: refused, before anything runs. So does a
/// negative count, which is refused as the option's value, not read as an unknown option
/// with clap's tip to write `-- -1` (which would make it the scenario's path).
#[test]
fn jobs_zero_is_refused_by_run_sweep_and_paper() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    for args in [
        &["run", "s.toml"][..],
        &["sweep", "sweep.toml"][..],
        &["paper"][..],
    ] {
        for jobs in ["0", "-1"] {
            let mut all: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_ref()).collect();
            all.extend([
                "--jobs".as_ref(),
                jobs.as_ref(),
                "--out".as_ref(),
                out.as_os_str(),
            ]);
            fails(&all, &out)
                .says(&format!("invalid value '{jobs}' for '--jobs"))
                .says("must be a whole number of at least 1");
        }
    }
    for (args, says) in [
        (
            &["run", "s.toml", "--trials", "-1"][..],
            "invalid value '-1' for '--trials <TRIALS>'",
        ),
        (
            &["run", "s.toml", "--memory-limit-mib", "-5"][..],
            "invalid value '-5' for '--memory-limit-mib <MIB>'",
        ),
        (
            &["sweep", "sweep.toml", "--shard", "-1/2"][..],
            "--shard \"-1/2\": expected K/N",
        ),
    ] {
        let mut all: Vec<&std::ffi::OsStr> = args.iter().map(|a| a.as_ref()).collect();
        all.extend(["--out".as_ref(), out.as_os_str()]);
        fails(&all, &out).says(says);
    }
}

/// An output folder given where a file is (or below one) names the file: the system's own
/// "File exists" and "Not a directory" did not say which path was in the way. (`analyze`:
/// `cli_analyze.rs`; `sweep`: `cli_sweep.rs`.)
#[test]
fn a_file_where_an_output_folder_goes_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = scenario_for(dir.path(), "unit", &foreign_fmu(dir.path()));
    let taken = dir.path().join("taken");
    std::fs::write(&taken, "a user's file").unwrap();
    let below = taken.join("out");
    for out in [&taken, &below] {
        fails(
            &[
                "run".as_ref(),
                scenario.as_os_str(),
                "--out".as_ref(),
                out.as_os_str(),
            ],
            &below,
        )
        .says(&format!("cannot create {}", out.display()))
        .says(&format!("{} is a file, not a folder", taken.display()));
    }
    assert_eq!(std::fs::read_to_string(&taken).unwrap(), "a user's file");
}

#[test]
fn simulate_given_one_variable_twice() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(dir.path());
    let csv = dir.path().join("result.csv");
    // Two values for one parameter: the second would silently win.
    fails(
        &[
            "simulate".as_ref(),
            fmu.as_os_str(),
            "--set".as_ref(),
            "mass=1".as_ref(),
            "--set".as_ref(),
            "mass=2".as_ref(),
            "-o".as_ref(),
            csv.as_os_str(),
        ],
        &csv,
    )
    .says("--set mass=2: mass is already set by --set mass=1; give each value once");
    // Several bad values: every one is named, not only the first.
    fails(
        &[
            "simulate".as_ref(),
            fmu.as_os_str(),
            "--set".as_ref(),
            "nosuchvar=1".as_ref(),
            "--set".as_ref(),
            "mass=1".as_ref(),
            "--set".as_ref(),
            "mass=nan".as_ref(),
            "--set".as_ref(),
            "mass=2".as_ref(),
            "-o".as_ref(),
            csv.as_os_str(),
        ],
        &csv,
    )
    .says("--set nosuchvar=1: model")
    .says("--set mass=nan: ")
    .says("--set mass=2: mass is already set by --set mass=1; give each value once");
    // One variable recorded twice: two columns of one name.
    fails(
        &[
            "simulate".as_ref(),
            fmu.as_os_str(),
            "--record".as_ref(),
            "x".as_ref(),
            "--record".as_ref(),
            "x".as_ref(),
            "-o".as_ref(),
            csv.as_os_str(),
        ],
        &csv,
    )
    .says("--record x: x is recorded twice");
}

#[test]
fn scenario_recording_a_trial_twice_or_measuring_the_wrong_quantity() {
    let dir = tempfile::tempdir().unwrap();
    let (controller, plant) = (built_fmu("HlcsController"), built_fmu("CkcmPlant"));
    let write = |stem: &str, tail: &str| {
        let path = dir.path().join(format!("{stem}.toml"));
        std::fs::write(
            &path,
            format!(
                "step_size = 0.001\ntrials = 3\nstop_time = 0.01\n\n\
                 [[fmu]]\nname = \"controller\"\npath = {:?}\n\n\
                 [[fmu]]\nname = \"plant\"\npath = {:?}\n\n{tail}",
                controller.to_str().unwrap(),
                plant.to_str().unwrap()
            ),
        )
        .unwrap();
        path
    };
    let out = dir.path().join("out");
    let twice = write(
        "twice",
        "[record]\nvariables = [\"plant.length\"]\ntrials = [1, 2, 1]\n",
    );
    run_fails(&twice, &out)
        .says(&format!("{}:15:", twice.display()))
        .says("record.trials lists trial 1 twice");
    let force = write(
        "force",
        "[metrics]\nreference = \"controller.length_ref\"\nlength = \"plant.force\"\n",
    );
    run_fails(&force, &out)
        .says(&format!("{}:15:", force.display()))
        .says("metrics.length \"plant.force\": force[1] is in N; the metrics need lengths in m");
    // The leg lengths are in metres as a pose's x, y, z are, but a pose goes on in angles.
    let with_pose = |variable: &str| {
        write(
            variable,
            &format!(
                "[metrics]\nreference = \"controller.length_ref\"\nlength = \"plant.length_true\"\n\
                 pose = \"plant.{variable}\"\ntrajectory = {{ kind = \"line\", duration = 15.0 }}\n"
            ),
        )
    };
    // A weight beyond reason is named short, not with 300 digits.
    let rho = write(
        "rho",
        "[metrics]\nreference = \"controller.length_ref\"\nlength = \"plant.length_true\"\n\
         rho = -1e300\n",
    );
    run_fails(&rho, &out)
        .says(&format!("{}:16:", rho.display()))
        .says("metrics.rho = -1e300 must be a non-negative number");
    let lengths = with_pose("length");
    run_fails(&lengths, &out)
        .says(&format!("{}:16:", lengths.display()))
        .says("metrics.pose \"plant.length\": length[4] is in m, so this is not a pose");
    orchestrator()
        .arg("run")
        .arg(with_pose("pose"))
        .arg("--out")
        .arg(dir.path().join("pose_out"))
        .assert()
        .success();
}

/// `metrics.trajectory` is written apart from the controller's reference, and a path error
/// against another path looks plausible (355 mm for a line measured as a circle, where the
/// true one is 0.65 mm): a CKCM controller's fixed reference must be the one measured, and
/// is taken when the file names none.
#[test]
fn the_path_error_is_measured_against_the_controllers_reference() {
    let dir = tempfile::tempdir().unwrap();
    let (controller, plant) = (built_fmu("HlcsController"), built_fmu("CkcmPlant"));
    let write = |stem: &str, parameters: &str, measured: &str| {
        let path = dir.path().join(format!("{stem}.toml"));
        std::fs::write(
            &path,
            format!(
                "step_size = 0.001\ntrials = 2\nstop_time = 0.01\n\n\
                 [[fmu]]\nname = \"controller\"\npath = {:?}\n[fmu.parameters]\n{parameters}\n\n\
                 [[fmu]]\nname = \"plant\"\npath = {:?}\n\n\
                 [metrics]\nreference = \"controller.length_ref\"\nlength = \"plant.length_true\"\n\
                 pose = \"plant.pose\"\n{measured}",
                controller.to_str().unwrap(),
                plant.to_str().unwrap(),
                measured = if measured.is_empty() {
                    String::new()
                } else {
                    format!("trajectory = {{ {measured} }}\n")
                }
            ),
        )
        .unwrap();
        path
    };
    let out = dir.path().join("out");
    for (stem, parameters, measured, says) in [
        (
            "circle",
            "",
            "kind = \"circle\", duration = 15.0",
            "metrics.trajectory is a circle of 15 s at home height 0.5 m, but FMU \"controller\" \
             tracks a line of 15 s at home height 0.5 m: the path error would measure the \
             platform against another path; make them equal, or leave out metrics.trajectory \
             to measure against the controller's",
        ),
        (
            "duration",
            "trajectory = \"circle\"\nduration = 5.0",
            "kind = \"circle\", duration = 6.0",
            "is a circle of 6 s at home height 0.5 m, but FMU \"controller\" tracks a circle of 5 s",
        ),
        (
            "home",
            "\"model.home_height\" = 0.45",
            "kind = \"line\", duration = 15.0",
            "tracks a line of 15 s at home height 0.45 m",
        ),
    ] {
        let scenario = write(stem, parameters, measured);
        let text = std::fs::read_to_string(&scenario).unwrap();
        let line = 1 + text
            .lines()
            .position(|l| l.starts_with("trajectory = {"))
            .unwrap();
        run_fails(&scenario, &out)
            .says(&format!("{}:{line}: ", scenario.display()))
            .says(says);
    }
    // The same path, a held pose of any duration, an external reference, or one that
    // changes from trial to trial (which the check cannot follow) run.
    for (stem, parameters, measured) in [
        (
            "same",
            "trajectory = \"circle\"\nduration = 5.0\n\"model.home_height\" = 0.45",
            "kind = \"circle\", duration = 5.0, home_height = 0.45",
        ),
        (
            "hold",
            "trajectory = \"hold\"",
            "kind = \"hold\", duration = 1.0",
        ),
        (
            "external",
            "trajectory = \"external\"",
            "kind = \"circle\", duration = 5.0",
        ),
        (
            "per_trial",
            "duration = { base = 15.0, per_trial = 1.0 }",
            "kind = \"line\", duration = 15.0",
        ),
    ] {
        orchestrator()
            .arg("run")
            .arg(write(stem, parameters, measured))
            .arg("--out")
            .arg(dir.path().join(format!("{stem}_out")))
            .assert()
            .success();
    }
    // Without metrics.trajectory the path is the controller's own: the same figures as the
    // matching one written out; an external or changing reference leaves nothing to take.
    orchestrator()
        .arg("run")
        .arg(write(
            "derived",
            "trajectory = \"circle\"\nduration = 5.0\n\"model.home_height\" = 0.45",
            "",
        ))
        .arg("--out")
        .arg(dir.path().join("derived_out"))
        .assert()
        .success();
    let summary = |stem: &str| {
        std::fs::read_to_string(dir.path().join(format!("{stem}_out/summary.csv"))).unwrap()
    };
    assert_eq!(summary("derived"), summary("same"));
    assert!(
        !summary("derived").lines().nth(1).unwrap().ends_with(','),
        "a path error"
    );
    for (stem, parameters) in [
        ("external_only", "trajectory = \"external\""),
        (
            "per_trial_only",
            "duration = { base = 15.0, per_trial = 1.0 }",
        ),
    ] {
        let scenario = write(stem, parameters, "");
        run_fails(&scenario, &out).says(
            "metrics.pose needs metrics.trajectory, the path it is measured against (without \
             it, the reference of the scenario's HlcsController FMU is taken",
        );
    }
    // A refused duration is the only error: the controller's declared default, which its
    // settings then hold instead, is not a path it was asked to track.
    let scenario = write(
        "refused",
        "trajectory = \"circle\"\nduration = 86400.5",
        "kind = \"circle\", duration = 86400.5",
    );
    let failure = run_fails(&scenario, &out);
    failure.says("\"duration\" = 86400.5 is above its declared max = 86400");
    assert!(!failure.stderr.contains("tracks a"), "{}", failure.stderr);
}

/// Two loops in one scenario, each controller tracking its own path: the path error is
/// checked against the controller whose leg errors are measured, not against the other.
#[test]
fn with_two_loops_the_measured_controllers_path_is_the_one_checked() {
    let dir = tempfile::tempdir().unwrap();
    let (controller, plant) = (built_fmu("HlcsController"), built_fmu("CkcmPlant"));
    let (controller, plant) = (controller.to_str().unwrap(), plant.to_str().unwrap());
    let mut loops = String::new();
    for (c, p, path) in [("c1", "p1", "line"), ("c2", "p2", "circle")] {
        loops += &format!(
            "[[fmu]]\nname = \"{c}\"\npath = {controller:?}\n[fmu.parameters]\n\
             trajectory = \"{path}\"\nduration = 5.0\n\n\
             [[fmu]]\nname = \"{p}\"\npath = {plant:?}\n\n"
        );
        for (from, to) in [
            (format!("{p}.length"), format!("{c}.length")),
            (format!("{p}.velocity"), format!("{c}.velocity")),
            (format!("{c}.force"), format!("{p}.force")),
        ] {
            loops += &format!("[[connection]]\nfrom = \"{from}\"\nto = \"{to}\"\n\n");
        }
    }
    let write = |stem: &str, measured: &str| {
        let path = dir.path().join(format!("{stem}.toml"));
        let (c, p) = (measured, measured.replace('c', "p"));
        std::fs::write(
            &path,
            format!(
                "step_size = 0.001\ntrials = 1\nstop_time = 0.01\n\n{loops}\
                 [metrics]\nreference = \"{c}.length_ref\"\nlength = \"{p}.length_true\"\n\
                 pose = \"{p}.pose\"\ntrajectory = {{ kind = \"line\", duration = 5.0 }}\n"
            ),
        )
        .unwrap();
        path
    };
    orchestrator()
        .arg("run")
        .arg(write("first", "c1"))
        .arg("--out")
        .arg(dir.path().join("first_out"))
        .assert()
        .success();
    let second = write("second", "c2");
    run_fails(&second, &dir.path().join("second_out")).says(
        "metrics.trajectory is a line of 5 s at home height 0.5 m, but FMU \"c2\" tracks a \
         circle of 5 s",
    );
}

#[test]
fn paper_names_its_bad_options_bad_fmus_and_a_folder_in_use() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    fails(
        &[
            "paper".as_ref(),
            "--line-duration".as_ref(),
            "0".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        &out,
    )
    .says("--line-duration 0 s is not usable: a trajectory lasts at least 0.01 s");
    // Every learning trial is recorded: a count beyond reason is refused, not allocated (a
    // list of 1e11 recorded trials aborted the process).
    fails(
        &[
            "paper".as_ref(),
            "--trials".as_ref(),
            "100000000000".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        &out,
    )
    .says("--trials 100000000000 is too many")
    .says("at most 1000");
    let missing = dir.path().join("nowhere");
    fails(
        &[
            "paper".as_ref(),
            "--fmu-dir".as_ref(),
            missing.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        &out,
    )
    .says_once(&missing.join("CkcmPlant.fmu").display().to_string());
    // Another model under the plant's name is named as such, not as its missing variables.
    let swapped = dir.path().join("swapped");
    std::fs::create_dir(&swapped).unwrap();
    let controller = built_fmu("HlcsController");
    std::fs::copy(&controller, swapped.join("CkcmPlant.fmu")).unwrap();
    std::fs::copy(&controller, swapped.join("HlcsController.fmu")).unwrap();
    fails(
        &[
            "paper".as_ref(),
            "--fmu-dir".as_ref(),
            swapped.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        &out,
    )
    .says("CkcmPlant.fmu holds the model \"HlcsController\", not \"CkcmPlant\"");
    // A duration the controller's declared range refuses fails before any case runs: before,
    // the three line cases ran first and the study stopped at the first circle case.
    let fmu_dir = built_fmu("CkcmPlant").parent().unwrap().to_path_buf();
    fails(
        &[
            "paper".as_ref(),
            "--fmu-dir".as_ref(),
            fmu_dir.as_os_str(),
            "--circle-duration".as_ref(),
            "100000".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        &out,
    )
    .says("circle / PID: its scenario, generated from the paper options and the FMUs in --fmu-dir, is refused")
    .says("\"duration\" = 100000 is above its declared max = 86400");
    // A study whose folder another study holds is refused at once, naming the holder, and
    // writes nothing: before, it ran the cases the first had not reached and stopped part
    // way, on the first one the first study held.
    std::fs::create_dir(&out).unwrap();
    let held = orchestrator::campaign::DirLock::acquire(&out).unwrap();
    for resume in [&[][..], &["--resume".as_ref()][..]] {
        let mut args: Vec<&std::ffi::OsStr> = vec![
            "paper".as_ref(),
            "--fmu-dir".as_ref(),
            fmu_dir.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ];
        args.extend(resume);
        fails(&args, &out.join("line"))
            .says(&format!("{} is in use by another run", out.display()))
            .says(&format!("pid {}", std::process::id()));
        assert_eq!(std::fs::read_dir(&out).unwrap().count(), 1, "only the lock");
    }
    drop(held);
}

/// FMUs in a folder whose name is not valid UTF-8 (Latin-1 bytes, as on old mounts): TOML
/// cannot name them, so `paper`, whose scenarios are generated, refuses them by name, and
/// `run` says that its saved copy of the scenario cannot be resumed from.
#[cfg(target_os = "linux")]
#[test]
fn fmus_in_a_folder_whose_name_is_not_utf8() {
    use std::os::unix::ffi::OsStrExt;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join(std::ffi::OsStr::from_bytes(b"caf\xe9"));
    std::fs::create_dir(&dir).unwrap();
    for name in ["CkcmPlant", "HlcsController"] {
        std::fs::copy(built_fmu(name), dir.join(format!("{name}.fmu"))).unwrap();
    }
    let out = tmp.path().join("study");
    fails(
        &[
            "paper".as_ref(),
            "--fmu-dir".as_ref(),
            dir.as_os_str(),
            "--out".as_ref(),
            out.as_os_str(),
        ],
        &out,
    )
    .says("the path is not valid UTF-8, so the study's scenario files cannot name the FMUs");

    let scenario = dir.join("one.toml");
    std::fs::write(
        &scenario,
        "step_size = 0.001\nstop_time = 0.01\n[[fmu]]\nname = \"plant\"\npath = \"CkcmPlant.fmu\"\n",
    )
    .unwrap();
    let o = orchestrator()
        .arg("run")
        .arg(&scenario)
        .arg("--out")
        .arg(tmp.path().join("run"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("warning: FMU \"plant\" lies at a path that is not valid UTF-8"),
        "{err}"
    );
}

/// A path to an endless source (`/dev/zero`) as a scenario, a sweep file, a sweep's base or
/// an input table is refused once it passes any such file's size, with the reason; before,
/// each was read until memory ran out. A pipe still reads (`run <(generate)`), which is
/// why the bound is on size and not on the kind of file.
#[cfg(unix)]
#[test]
fn endless_sources_are_refused_not_read_forever() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let zero = Path::new("/dev/zero");
    let sweep = dir.path().join("sweep.toml");
    std::fs::write(
        &sweep,
        "base = \"/dev/zero\"\n[[axis]]\nname = \"m\"\nparameters = [\"plant.platform_mass\"]\n\
         values = [1.0]\n",
    )
    .unwrap();
    let plant = built_fmu("CkcmPlant");
    let cases: [(Vec<&std::ffi::OsStr>, &str); 4] = [
        (
            vec![
                "run".as_ref(),
                zero.as_ref(),
                "--out".as_ref(),
                out.as_ref(),
            ],
            "/dev/zero: cannot read the scenario: it holds more than 64 MiB",
        ),
        (
            vec![
                "sweep".as_ref(),
                zero.as_ref(),
                "--out".as_ref(),
                out.as_ref(),
            ],
            "/dev/zero: cannot read the sweep file: it holds more than 64 MiB",
        ),
        (
            vec![
                "sweep".as_ref(),
                sweep.as_ref(),
                "--out".as_ref(),
                out.as_ref(),
            ],
            "sweep.toml:1: cannot read the base scenario /dev/zero: it holds more than 64 MiB",
        ),
        (
            vec![
                "simulate".as_ref(),
                plant.as_ref(),
                "--input".as_ref(),
                zero.as_ref(),
                "--output".as_ref(),
                out.as_ref(),
            ],
            "/dev/zero:1: cannot read the header: a line longer than 1 MiB",
        ),
    ];
    for (args, says) in &cases {
        fails(args, &out).says(says);
    }
}

/// A result that cannot be written to standard output (a full disk behind a redirect) is
/// an error naming it, with a non-zero exit; before, `info` and `analyze` exited 0 with
/// their text lost.
#[cfg(target_os = "linux")]
#[test]
fn a_full_standard_output_is_an_error() {
    let full = || {
        std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    let plant = built_fmu("CkcmPlant");
    for (args, says) in [
        (vec!["info"], "cannot write to standard output"),
        (
            vec!["simulate", "--stop-time", "0.01"],
            "cannot write the result to standard output",
        ),
    ] {
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_orchestrator"))
            .args(&args)
            .arg(&plant)
            .stdout(full())
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{args:?} exited 0: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
}
