//! `orchestrator info`: identity, capability flags, default experiment, log categories and
//! the variable table, for the foreign test FMU and both CKCM FMUs.

mod common;

use std::path::Path;

use common::{built_fmu, foreign_fmu, orchestrator};

/// Runs `info` and returns its standard output.
fn info(fmu: &Path) -> String {
    let output = orchestrator().arg("info").arg(fmu).output().unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).unwrap()
}

/// The table line of variable `name`, split into its whitespace-separated words.
fn variable_line<'a>(text: &'a str, name: &str) -> Vec<&'a str> {
    text.lines()
        .map(|l| l.split_whitespace().collect::<Vec<_>>())
        .find(|words| words.first() == Some(&name))
        .unwrap_or_else(|| panic!("no line for {name} in\n{text}"))
}

#[test]
fn foreign_fmu_info_lists_identity_flags_and_every_variable() {
    let dir = tempfile::tempdir().unwrap();
    let text = info(&foreign_fmu(dir.path()));
    for expected in [
        "Model            DampedOscillator",
        "GUID             {c0ffee00-5eed-4b1d-a11e-0123456789ab}",
        "Description      Damped spring-mass oscillator driven by an external force (test fixture)",
        "Generation tool  hand-written test fixture",
        "Generated        2026-11-23T12:00:00Z",
        "FMI version      2.0",
        "Variable naming  flat",
        "Co-Simulation (modelIdentifier ForeignOscillator)",
        "canHandleVariableCommunicationStepSize  yes",
        "canInterpolateInputs                    no",
        "canGetAndSetFMUstate                    yes",
        "Model Exchange: not offered",
        "Default experiment: start 0 s, stop 2 s, step 0.0078125 s, tolerance not given",
        "logStatusError    Calls that return fmi2Error",
        "Method: 1 = rk4, 2 = symplectic_euler",
        "Variables (15)",
    ] {
        assert!(text.contains(expected), "missing {expected:?} in\n{text}");
    }
    assert_eq!(
        variable_line(&text, "name"),
        [
            "name",
            "vr",
            "type",
            "causality",
            "variability",
            "initial",
            "start",
            "unit",
            "range",
            "description"
        ]
    );
    assert_eq!(
        variable_line(&text, "drive")[..6],
        ["drive", "0", "Real", "input", "continuous", "0"]
    );
    assert_eq!(
        variable_line(&text, "x")[..7],
        ["x", "1", "Real", "output", "continuous", "calculated", "m"]
    );
    assert_eq!(
        variable_line(&text, "steps")[..6],
        ["steps", "0", "Integer", "output", "discrete", "calculated"]
    );
    assert_eq!(
        variable_line(&text, "moving_up")[..6],
        [
            "moving_up",
            "0",
            "Boolean",
            "output",
            "discrete",
            "calculated"
        ]
    );
    assert_eq!(
        variable_line(&text, "gain")[..7],
        ["gain", "6", "Real", "parameter", "tunable", "exact", "1"]
    );
    assert_eq!(
        variable_line(&text, "damped")[..7],
        [
            "damped",
            "1",
            "Boolean",
            "parameter",
            "fixed",
            "exact",
            "true"
        ]
    );
    assert_eq!(
        variable_line(&text, "method")[..9],
        [
            "method",
            "2",
            "Enumeration",
            "Method",
            "parameter",
            "fixed",
            "exact",
            "1",
            "(rk4)"
        ]
    );
}

#[test]
fn ckcm_fmu_info_lists_their_interfaces() {
    let plant = info(&built_fmu("CkcmPlant"));
    for expected in [
        "Model            CkcmPlant",
        "Variable naming  structured",
        "Co-Simulation (modelIdentifier CkcmPlant)",
        "canSerializeFMUstate                    yes",
        "step 0.001 s",
        "Integrator: 1 = rk4, 2 = dormand_prince",
    ] {
        assert!(plant.contains(expected), "missing {expected:?} in\n{plant}");
    }
    for i in 1..=6 {
        assert_eq!(
            variable_line(&plant, &format!("force[{i}]"))[2..7],
            ["Real", "input", "continuous", "0", "N"]
        );
        assert_eq!(
            variable_line(&plant, &format!("length[{i}]"))[2..7],
            ["Real", "output", "continuous", "calculated", "m"]
        );
    }
    assert_eq!(variable_line(&plant, "pose[4]")[6], "rad");
    // The declared range follows the unit; outputs have none.
    assert_eq!(
        variable_line(&plant, "rod_mass")[6..10],
        ["1", "kg", "[0,", "10000]"]
    );
    assert_eq!(
        variable_line(&plant, "noise_seed")[6..9],
        ["0", "[0,", "2147483647]"]
    );

    let controller = info(&built_fmu("HlcsController"));
    assert!(controller.contains("Model            HlcsController"));
    assert!(controller.contains("Co-Simulation (modelIdentifier HlcsController)"));
    for name in [
        "kp",
        "phi",
        "learning",
        "memory[1]",
        "memory_next[6]",
        "force[3]",
    ] {
        variable_line(&controller, name);
    }
    assert_eq!(variable_line(&controller, "memory_next[6]")[3], "output");
    assert_eq!(variable_line(&controller, "memory[1]")[3], "input");
    assert_eq!(variable_line(&controller, "kp")[3], "parameter");
}

/// An FMU whose binary cannot run here (none for this platform, or one that does not load)
/// is still described, for a user reading an FMU built for another platform; the exit
/// status and the error on stderr say that it cannot run here.
#[test]
fn an_fmu_that_cannot_run_here_is_described_and_the_exit_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let here = format!("binaries/{}/", fmi2_import::PLATFORM);
    let elsewhere = dir.path().join("Elsewhere.fmu");
    common::repackage(&built_fmu("CkcmPlant"), &elsewhere, |name, bytes| {
        (!name.starts_with(&here)).then_some(bytes)
    });
    let cut = dir.path().join("Cut.fmu");
    common::repackage(&built_fmu("CkcmPlant"), &cut, |name, bytes| {
        Some(if name.starts_with(&here) {
            bytes[..bytes.len() / 2].to_vec()
        } else {
            bytes
        })
    });
    for (fmu, platforms, error) in [
        (
            &elsewhere,
            "win64",
            format!("no binary for this platform ({})", fmi2_import::PLATFORM),
        ),
        (&cut, "linux64, win64", "cannot load its binary".to_owned()),
    ] {
        let output = orchestrator().arg("info").arg(fmu).output().unwrap();
        let stdout = String::from_utf8_lossy(&output.stdout);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{stdout}");
        assert!(stderr.starts_with("error: "), "{stderr}");
        assert!(stderr.contains(&error), "{stderr}");
        let shown = format!(
            "Platforms        {platforms} (cannot run here, on {}: see the error below)",
            fmi2_import::PLATFORM
        );
        assert!(stdout.contains(&shown), "{shown:?} not in\n{stdout}");
        assert!(stdout.contains("Variables ("), "{stdout}");
        assert_eq!(variable_line(&stdout, "force[1]")[2], "Real", "{stdout}");
        // With nowhere to print the description, the binary's problem is still the error.
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let output = std::process::Command::new(env!("CARGO_BIN_EXE_orchestrator"))
            .arg("info")
            .arg(fmu)
            .stdout(full)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{stderr}");
        assert!(
            stderr.starts_with("warning: cannot write to standard output"),
            "{stderr}"
        );
        assert!(
            stderr.contains("\nerror: ") && stderr.contains(&error),
            "{stderr}"
        );
    }
}
