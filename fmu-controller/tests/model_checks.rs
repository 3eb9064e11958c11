//! The controller model through the safe `fmu_core::Model` trait, for what the FMU-level tests
//! do not reach: a start time other than zero, and the model's own refusal of a bad duration
//! (the glue's declared range stops it first; the model must not rely on that).

use ckcm::{Mechanism, Params, Trajectory, TrajectoryKind};
use fmu_core::Model;
use hlcs_controller::HlcsController;
use hlcs_controller::md::enums::{TRAJECTORY_CIRCLE, TRAJECTORY_ITEMS};
use hlcs_controller::md::vr;

const H: f64 = 1e-3;

/// Force and length reference over `steps` samples of the circle, started at `t0`, with the
/// measured lengths 1 mm short of the reference (the same inputs whatever `t0`).
fn run(t0: f64, steps: u32) -> Vec<[f64; 12]> {
    let mech = Mechanism::new(Params::default()).unwrap();
    let circle = Trajectory::circle(mech.params.geometry.home_height);
    let length = [
        vr::LENGTH_1,
        vr::LENGTH_2,
        vr::LENGTH_3,
        vr::LENGTH_4,
        vr::LENGTH_5,
        vr::LENGTH_6,
    ];
    let velocity = [
        vr::VELOCITY_1,
        vr::VELOCITY_2,
        vr::VELOCITY_3,
        vr::VELOCITY_4,
        vr::VELOCITY_5,
        vr::VELOCITY_6,
    ];
    let memory = [
        vr::MEMORY_1,
        vr::MEMORY_2,
        vr::MEMORY_3,
        vr::MEMORY_4,
        vr::MEMORY_5,
        vr::MEMORY_6,
    ];
    let force = [
        vr::FORCE_1,
        vr::FORCE_2,
        vr::FORCE_3,
        vr::FORCE_4,
        vr::FORCE_5,
        vr::FORCE_6,
    ];
    let length_ref = [
        vr::LENGTH_REF_1,
        vr::LENGTH_REF_2,
        vr::LENGTH_REF_3,
        vr::LENGTH_REF_4,
        vr::LENGTH_REF_5,
        vr::LENGTH_REF_6,
    ];
    let mut c = HlcsController::new();
    c.set_integer(vr::TRAJECTORY, TRAJECTORY_CIRCLE).unwrap();
    c.set_boolean(vr::LEARNING, true).unwrap();
    c.initialize(t0).unwrap();
    let mut out = Vec::new();
    for n in 0..steps {
        let tau = f64::from(n) * H;
        let legs = mech.inverse_kinematics(&circle.sample(tau).pose);
        for i in 0..6 {
            c.set_real(length[i], legs.length[i] - 1e-3).unwrap();
            c.set_real(velocity[i], 0.0).unwrap();
            c.set_real(memory[i], 5.0).unwrap();
        }
        c.do_step(t0 + f64::from(n) * H, H).unwrap();
        let mut y = [0.0; 12];
        for i in 0..6 {
            y[i] = c.get_real(force[i]);
            y[6 + i] = c.get_real(length_ref[i]);
        }
        out.push(y);
    }
    out
}

/// The trajectory is timed from the start time: a run started at t = 2.5 s sees, at
/// 2.5 s + τ, what a run started at 0 sees at τ (to rounding of the time sums: t₀ + n·h − t₀
/// is n·h only to a few ulps).
#[test]
fn the_trajectory_is_timed_from_the_start_time() {
    let steps = 800;
    let (a, b) = (run(0.0, steps), run(2.5, steps));
    for (n, (ya, yb)) in a.iter().zip(&b).enumerate() {
        for k in 0..12 {
            let scale = ya[k].abs().max(1e-3);
            assert!(
                (ya[k] - yb[k]).abs() <= 1e-9 * scale,
                "sample {n}, output {k}: {} from t0 = 0 against {} from t0 = 2.5",
                ya[k],
                yb[k]
            );
        }
    }
    // The circle moves: the comparison is not between constants.
    assert!((a[0][6] - a[steps as usize - 1][6]).abs() > 1e-4);
}

/// A duration that is not positive is refused by the model at initialization, with its name,
/// even when set past the glue (whose declared minimum would refuse it first).
#[test]
fn a_duration_that_is_not_positive_is_refused_by_the_model() {
    for duration in [0.0, -1.0] {
        let mut c = HlcsController::new();
        c.set_real(vr::DURATION, duration).unwrap();
        let e = c.initialize(0.0).unwrap_err();
        assert!(e.message.contains("duration"), "{}", e.message);
    }
}

/// Scenario files, result folders and the orchestrator's lookups spell a path by
/// `TrajectoryKind::name`; the controller's XML must number the same names in the same order.
#[test]
fn the_kinds_names_are_the_controllers_items() {
    let items: Vec<&str> = TRAJECTORY_ITEMS.split(", ").collect();
    for (i, kind) in TrajectoryKind::ALL.into_iter().enumerate() {
        let item = format!("{} {}", i + 1, kind.name());
        assert!(
            items.contains(&item.as_str()),
            "{kind:?}: {item:?} is not among the controller's items {TRAJECTORY_ITEMS:?}"
        );
        assert_eq!(TrajectoryKind::from_name(kind.name()), Some(kind));
    }
    assert_eq!(TrajectoryKind::from_name("external"), None);
    assert_eq!(TrajectoryKind::names(), "hold, line, circle");
}
