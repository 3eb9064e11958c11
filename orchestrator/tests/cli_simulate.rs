//! `orchestrator simulate` end to end: a foreign FMU against closed-form and hand-computed
//! responses (the importer is generic), the CKCM plant holding its home pose under the
//! static leg force, and the error paths of start values, input files and failing steps.

mod common;

use std::path::Path;

use common::{built_fmu, column, foreign_fmu, orchestrator, read_csv};

/// Parameters of the foreign FMU (its start values in modelDescription.xml).
const MASS: f64 = 1.0;
const STIFFNESS: f64 = 4.0;
const DAMPING: f64 = 0.4;
/// DefaultExperiment of the foreign FMU: 2 s in steps of 1/128 s (exact in binary).
const STEP: f64 = 0.0078125;
const STOP: f64 = 2.0;

/// Position and velocity at time `s` after a force step of `force` applied to the damped
/// oscillator at rest at 0 (underdamped second-order step response, e.g. Ogata, *Modern
/// Control Engineering*, §5-3); zero for s < 0.
fn step_response(force: f64, s: f64) -> (f64, f64) {
    if s < 0.0 {
        return (0.0, 0.0);
    }
    let w0 = (STIFFNESS / MASS).sqrt();
    let sigma = DAMPING / (2.0 * MASS);
    let wd = (w0 * w0 - sigma * sigma).sqrt();
    let decay = (-sigma * s).exp();
    let x = force / STIFFNESS * (1.0 - decay * ((wd * s).cos() + sigma / wd * (wd * s).sin()));
    let v = force / STIFFNESS * decay * (w0 * w0 / wd) * (wd * s).sin();
    (x, v)
}

#[test]
fn foreign_fmu_follows_the_analytic_response_to_a_held_input() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(dir.path());
    // 0.25 s is a grid point; 0.3 s is not, so the zero-order hold must apply that row from
    // the first grid point after it, 39/128 s.
    let input = dir.path().join("drive.csv");
    std::fs::write(&input, "time,drive\n0,0\n0.25,2\n0.3,-1\n").unwrap();
    let out = dir.path().join("out.csv");
    orchestrator()
        .arg("simulate")
        .arg(&fmu)
        .arg("--input")
        .arg(&input)
        .arg("--output")
        .arg(&out)
        .assert()
        .success();

    let rec = read_csv(&out);
    assert_eq!(rec.names, ["x", "v", "steps", "moving_up"]);
    let n_steps = (STOP / STEP) as usize;
    assert_eq!(rec.len(), n_steps + 1);
    let (x, v) = (column(&rec, "x"), column(&rec, "v"));
    let (steps, moving_up) = (column(&rec, "steps"), column(&rec, "moving_up"));
    let t_switch = 39.0 * STEP;
    let expected = |t: f64, switch: f64| {
        let (x1, v1) = step_response(2.0, t - 0.25);
        let (x2, v2) = step_response(-3.0, t - switch);
        (x1 + x2, v1 + v2)
    };
    let mut worst_if_interpolated: f64 = 0.0;
    for (n, &t) in rec.time.iter().enumerate() {
        assert_eq!(
            t,
            n as f64 * STEP,
            "time of row {n} is on the computed grid"
        );
        let (xe, ve) = expected(t, t_switch);
        // RK4 with 16 substeps of 1/2048 s: its error is below 1e-11 here.
        assert!((x[n] - xe).abs() < 1e-9, "x({t}) = {} vs {xe}", x[n]);
        assert!((v[n] - ve).abs() < 1e-8, "v({t}) = {} vs {ve}", v[n]);
        assert_eq!(steps[n], n as f64, "Integer output counts the steps");
        if ve.abs() > 1e-6 {
            assert_eq!(moving_up[n], f64::from(u8::from(ve > 0.0)), "at t = {t}");
        }
        worst_if_interpolated = worst_if_interpolated.max((x[n] - expected(t, 0.3).0).abs());
    }
    // The tolerance above can tell the hold rule apart from applying the row at 0.3 s.
    assert!(worst_if_interpolated > 1e-4, "{worst_if_interpolated}");
    assert_eq!(*rec.time.last().unwrap(), STOP);
}

/// `simulate` with the given extra arguments, recording x, v and moving_up to stdout.
fn symplectic_run(fmu: &Path, extra: &[&str]) -> String {
    let output = orchestrator()
        .arg("simulate")
        .arg(fmu)
        .args(["--stop-time", "0.5", "--step-size", "0.01"])
        .args(["--record", "x", "--record", "v", "--record", "moving_up"])
        .args(extra)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout).unwrap()
}

#[test]
fn start_values_of_every_type_reach_the_fmu() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(dir.path());
    let by_name = symplectic_run(
        &fmu,
        &[
            "--set",
            "method=symplectic_euler",
            "--set",
            "substeps=1",
            "--set",
            "damped=false",
            "--set",
            "gain=0.5",
            "--set",
            "drive=2",
            "--set",
            "x0=0.1",
        ],
    );
    // Semi-implicit Euler, one substep per 0.01 s step, no damping, force 0.5 · 2 = 1 N.
    let (mut x, mut v) = (0.1_f64, 0.0_f64);
    let mut lines = by_name.lines();
    assert_eq!(lines.next(), Some("time,x,v,moving_up"));
    for n in 0..=50 {
        let line = lines.next().unwrap_or_else(|| panic!("row {n} missing"));
        let fields: Vec<f64> = line.split(',').map(|f| f.parse().unwrap()).collect();
        assert_eq!(fields[0], n as f64 * 0.01);
        assert!((fields[1] - x).abs() < 1e-12, "x at row {n}: {line} vs {x}");
        assert!((fields[2] - v).abs() < 1e-12, "v at row {n}: {line} vs {v}");
        assert_eq!(fields[3], f64::from(u8::from(v > 0.0)), "row {n}");
        v += 0.01 * (1.0 - STIFFNESS * x) / MASS;
        x += 0.01 * v;
    }
    assert_eq!(lines.next(), None);

    // The enumeration item by number and the Boolean as 0 give the same run.
    let by_number = symplectic_run(
        &fmu,
        &[
            "--set",
            "method=2",
            "--set",
            "substeps=1",
            "--set",
            "damped=0",
            "--set",
            "gain=0.5",
            "--set",
            "drive=2",
            "--set",
            "x0=0.1",
        ],
    );
    assert_eq!(by_name, by_number);
    // And the defaults (RK4, damped) give a different one.
    assert_ne!(by_name, symplectic_run(&fmu, &["--set", "x0=0.1"]));
}

/// `simulate` of the foreign FMU from `start` to `stop` in steps of 0.01 s: (time, steps).
fn step_count(fmu: &Path, start: &str, stop: &str) -> (Vec<f64>, Vec<f64>) {
    let out = fmu.with_file_name("steps.csv");
    orchestrator()
        .arg("simulate")
        .arg(fmu)
        .args(["--start-time", start, "--stop-time", stop])
        .args(["--step-size", "0.01", "--record", "steps", "-o"])
        .arg(&out)
        .assert()
        .success();
    let rec = read_csv(&out);
    let steps = column(&rec, "steps").to_vec();
    (rec.time, steps)
}

#[test]
fn a_span_that_is_no_whole_number_of_steps_ends_with_a_shorter_step() {
    let dir = tempfile::tempdir().unwrap();
    let (time, steps) = step_count(&foreign_fmu(dir.path()), "0.5", "0.525");
    assert_eq!(time, [0.5, 0.5 + 0.01, 0.5 + 2.0 * 0.01, 0.525]);
    assert_eq!(steps, [0.0, 1.0, 2.0, 3.0]);
}

/// A negative number after an option is its value: FMI allows a start time before 0, and a
/// negative step size is refused with its own message rather than read as an unknown option
/// (the parser's tip for that, `-- -1`, would have made it the FMU's path).
#[test]
fn negative_times_are_values_not_options() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(dir.path());
    let (time, steps) = step_count(&fmu, "-0.02", "0");
    assert_eq!(time, [-0.02, -0.02 + 0.01, 0.0]);
    assert_eq!(steps, [0.0, 1.0, 2.0]);
    // With a negative exponent too, which clap's own number test does not take for a number.
    let (time, _) = step_count(&fmu, "-2e-2", "0");
    assert_eq!(time, [-0.02, -0.02 + 0.01, 0.0]);
    let o = orchestrator()
        .arg("simulate")
        .arg(&fmu)
        .args(["--step-size", "-0.01"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(err.contains("step size -0.01 s must be positive"), "{err}");
}

#[test]
fn an_fmu_error_mid_run_names_the_time_and_the_call_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(dir.path());
    let out = dir.path().join("out.csv");
    let output = orchestrator()
        .arg("simulate")
        .arg(&fmu)
        .args(["--set", "x_limit=0.1", "--set", "drive=1", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    // A constant 1 N settles at 0.25 m, so the end stop at 0.1 m is hit on the way.
    let n_fail = (1..)
        .find(|&n| step_response(1.0, f64::from(n) * STEP).0 > 0.1)
        .unwrap();
    let t_from = f64::from(n_fail - 1) * STEP;
    assert!(
        stderr.contains(&format!("step from t = {t_from} s by {STEP} s")),
        "{stderr}"
    );
    assert!(stderr.contains("fmi2DoStep"), "{stderr}");
    assert!(stderr.contains("returned fmi2Error"), "{stderr}");
    assert!(stderr.contains("end stop x_limit = 0.1 m"), "{stderr}");
    assert!(!out.exists(), "a failed run must leave no output file");
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "no temporary files"
    );
}

/// The plant under `args`, recording the pose for 0.5 s.
fn plant_pose(dir: &Path, args: &[&str]) -> orchestrator::output::Recording {
    let out = dir.join("pose.csv");
    orchestrator()
        .arg("simulate")
        .arg(built_fmu("CkcmPlant"))
        .args(["--stop-time", "0.5", "--record", "pose", "-o"])
        .arg(&out)
        .args(args)
        .assert()
        .success();
    read_csv(&out)
}

#[test]
fn plant_holds_its_home_pose_under_the_static_leg_force() {
    let dir = tempfile::tempdir().unwrap();
    // `force` names the whole array force[1..6].
    let rec = plant_pose(dir.path(), &["--set", "force=28.5315"]);
    assert_eq!(rec.len(), 501, "0.5 s at the default 1 ms step");
    assert_eq!(
        rec.names,
        [
            "pose[1]", "pose[2]", "pose[3]", "pose[4]", "pose[5]", "pose[6]"
        ]
    );
    let home = [0.0, 0.0, 0.5];
    for (i, &target) in home.iter().enumerate() {
        let c = &rec.columns[i];
        let worst = c.iter().map(|p| (p - target).abs()).fold(0.0, f64::max);
        assert!(
            worst < 1e-4,
            "pose[{}] strays {worst} m from {target}",
            i + 1
        );
    }
    for c in &rec.columns[3..] {
        assert!(c.iter().all(|a| a.abs() < 1e-3), "orientation stays level");
    }

    // The same forces from an input file (structured names as CSV columns) give the same run.
    let input = dir.path().join("forces.csv");
    let header: Vec<String> = (1..=6).map(|i| format!("force[{i}]")).collect();
    std::fs::write(
        &input,
        format!(
            "time,{}\n0,{}\n",
            header.join(","),
            ["28.5315"; 6].join(",")
        ),
    )
    .unwrap();
    let from_file = plant_pose(dir.path(), &["--input", input.to_str().unwrap()]);
    assert_eq!(from_file, rec);
}

/// Runs `simulate` on the foreign FMU with an input file holding `csv` and returns stderr.
fn input_error(csv: &str) -> (String, String) {
    let dir = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(dir.path());
    let input = dir.path().join("in.csv");
    std::fs::write(&input, csv).unwrap();
    let out = dir.path().join("out.csv");
    let output = orchestrator()
        .arg("simulate")
        .arg(&fmu)
        .arg("-i")
        .arg(&input)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(!output.status.success());
    assert!(!out.exists());
    (
        String::from_utf8_lossy(&output.stderr).into_owned(),
        input.display().to_string(),
    )
}

#[test]
fn input_file_errors_name_file_line_and_column() {
    let (err, file) = input_error("time,drive,force\n0,1,2\n");
    assert!(
        err.contains(&format!("{file}:1: column 3 'force'")) && err.contains("no variable"),
        "{err}"
    );
    let (err, file) = input_error("time,x\n0,1\n");
    assert!(
        err.contains(&format!(
            "{file}:1: column 2 'x' is an output, not an input"
        )),
        "{err}"
    );
    let (err, file) = input_error("time,drive\n0,1\n0.5,1.5\n1,abc\n");
    assert!(
        err.contains(&format!(
            "{file}:4: column 2 ('drive'): 'abc' is not a finite number"
        )),
        "{err}"
    );
    let (err, file) = input_error("time,drive\n0.5,1\n0.25,1\n");
    assert!(
        err.contains(&format!("{file}:3: column 1 (time)")) && err.contains("must not decrease"),
        "{err}"
    );
    let (err, file) = input_error("t,drive\n0,1\n");
    assert!(
        err.contains(&format!("{file}:1: column 1: must be `time`")),
        "{err}"
    );
    // A spreadsheet's export with a decimal comma puts `;` between the fields.
    let (err, file) = input_error("time;drive\n0;1,5\n");
    assert!(
        err.contains(&format!(
            "{file}:1: column 1: must be `time`, found 'time;drive'"
        )) && err.contains("separated by ';'")
            && err.contains("needs commas"),
        "{err}"
    );
    let (err, file) = input_error("time,drive\n0,1\n1\n");
    assert!(
        err.contains(&format!("{file}:3: 1 field(s), expected 2")),
        "{err}"
    );
}

#[test]
fn start_value_and_record_errors_are_specific() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(dir.path());
    let cases: [(&[&str], &str); 6] = [
        (
            &["--set", "x=1"],
            "--set x=1: 'x' is an output and computed by the FMU",
        ),
        (
            &["--set", "mass=heavy"],
            "'heavy' is not a finite number ('mass' is a Real)",
        ),
        (
            &["--set", "substeps=2.5"],
            "'2.5' is not an integer ('substeps' is an Integer)",
        ),
        (
            &["--set", "damped=yes"],
            "'yes' is not a Boolean ('damped' is a Boolean: use true or false)",
        ),
        (
            &["--set", "method=euler"],
            "takes one of: rk4 (1), symplectic_euler (2)",
        ),
        (
            &["--record", "position"],
            "--record position: model 'DampedOscillator' has no variable named 'position'",
        ),
    ];
    for (args, expected) in cases {
        let output = orchestrator()
            .arg("simulate")
            .arg(&fmu)
            .args(args)
            .output()
            .unwrap();
        assert!(!output.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(expected), "{args:?}: {stderr}");
        assert!(output.stdout.is_empty(), "{args:?}: nothing on stdout");
    }
}

/// An output that is NaN or infinite with fmi2OK is an error naming the instance, the
/// variable and the time, and nothing is written.
#[test]
fn a_non_finite_output_is_an_error_naming_variable_and_time() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = foreign_fmu(dir.path());
    let out = dir.path().join("out.csv");
    let o = orchestrator()
        .arg("simulate")
        .arg(&fmu)
        .args([
            "--set",
            "mass=1e-9",
            "--set",
            "stiffness=1e12",
            "--set",
            "x0=1",
        ])
        .args(["--set", "x_limit=1e308", "--set", "substeps=1", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("returned x = "), "{err}");
    assert!(err.contains(" at t = "), "{err}");
    assert!(err.contains("not finite"), "{err}");
    assert!(!out.exists());
}
