//! The closed loop of docs/model.md §6 run in-process on `ckcm` alone (plant: default
//! parameters, RK4 at 1 ms; controller: nominal model, Table 1 gains), against the figures of
//! the independent reference model (a separate numpy task-space model, docs/model.md §7).
//!
//! The FMU-level tests check the same figures through the packaged FMUs; this one checks the
//! maths crate on its own, so that a wrong friction curve, mass term, feedforward or learning
//! update fails `cargo test -p ckcm` (and so its mutants are caught).
//!
//! Tolerance: a figure printed with d decimals says only that the true value lies within half
//! a unit of its last digit; the two models agree to about 2e-5 relative on top of that.

use ckcm::closed_loop::run_trial;
use ckcm::nalgebra::Vector6;
use ckcm::{ControlSettings, Hlcs, Integrator, LearningLaw, Mechanism, Params, Rk4, Trajectory};

const H: f64 = 1e-3;

fn assert_figure(what: &str, measured_mm: f64, printed: &str) {
    let decimals = printed.split_once('.').map_or(0, |(_, d)| d.len());
    let expected: f64 = printed.parse().unwrap();
    let tol = 0.5 * 10f64.powi(-(decimals as i32)) + 2e-5 * expected;
    assert!(
        (measured_mm - expected).abs() <= tol,
        "{what}: measured {measured_mm} mm, independent model {printed} mm (±{tol:e})"
    );
}

/// Runs `trials` trials of the crate's closed loop (`closed_loop::run_trial`, Gauss–Seidel:
/// the controller samples the plant's outputs at t_n, the plant integrates over
/// [t_n, t_n + h] under the force just computed), each from rest at the trajectory's start
/// with the memory the one before it wrote, and returns each trial's max |e| over all legs
/// and samples, mm.
fn max_errors_mm(trajectory: Trajectory, learning: bool, trials: usize) -> Vec<f64> {
    let plant = Mechanism::new(Params::default()).unwrap();
    let model = Mechanism::new(Params::nominal()).unwrap();
    let settings = ControlSettings {
        learning: LearningLaw::from_switch(learning),
        ..ControlSettings::default()
    };
    let steps = (trajectory.duration / H).round() as usize;
    let mut memory = vec![Vector6::zeros(); steps];
    let mut law = Hlcs::new(model, settings);
    let mut integrator = Integrator::Rk4(Rk4::default());
    let mut out = Vec::new();
    for _ in 0..trials {
        let mut next = vec![Vector6::zeros(); steps];
        let mut max: f64 = 0.0;
        run_trial(
            &plant,
            &mut integrator,
            &mut law,
            &trajectory,
            H,
            &memory,
            &mut next,
            |_, _, _, o| max = max.max(o.error.amax()),
        )
        .unwrap();
        memory = next;
        out.push(max * 1e3);
    }
    out
}

#[test]
fn circle_pid_and_hlcs_trial_1_match_the_independent_model() {
    let circle = Trajectory::circle(0.5);
    let pid = max_errors_mm(circle, false, 1);
    assert_figure("circle PID", pid[0], "1.409");
    let hlcs = max_errors_mm(circle, true, 3);
    assert_figure("circle HLCS trial 0", hlcs[0], "1.409");
    assert_figure("circle HLCS trial 1", hlcs[1], "0.177");
    assert_figure("circle HLCS trial 2", hlcs[2], "0.136");
}

#[test]
fn line_pid_matches_the_independent_model() {
    let pid = max_errors_mm(Trajectory::line(0.5), false, 1);
    assert_figure("line PID", pid[0], "0.6205");
}

#[test]
fn line_hlcs_trial_1_matches_the_independent_model() {
    let hlcs = max_errors_mm(Trajectory::line(0.5), true, 2);
    assert_figure("line HLCS trial 1", hlcs[1], "0.0477");
}
