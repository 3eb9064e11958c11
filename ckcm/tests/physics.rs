//! Physics verification of the mechanism model (issue: mechanism core).
//!
//! Every check compares two independently derived quantities: energy vs work, closed-form
//! mass matrix vs Newton–Euler residual, Jacobian vs finite differences, FK vs IK, RK4 vs
//! Dormand–Prince, and the reference figures of docs/model.md.

use ckcm::nalgebra::{UnitQuaternion, Vector3, Vector6};
use ckcm::{
    DormandPrince, FkError, FkOptions, Friction, Mechanism, Params, Pose, Rk4, State, Trajectory,
};

/// SplitMix64: a deterministic, seedable generator in five lines, so the tests need no
/// random-number dev-dependency.
struct Rng(u64);
impl Rng {
    fn next_f64(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [−a, a].
    fn sym(&mut self, a: f64) -> f64 {
        (2.0 * self.next_f64() - 1.0) * a
    }
    fn vec6(&mut self, a: f64) -> Vector6<f64> {
        Vector6::from_fn(|_, _| self.sym(a))
    }
    /// A pose within ±0.1 m and ±10° of home.
    fn pose(&mut self, home: f64) -> Pose {
        let d = 10f64.to_radians();
        Pose::from_xyz_euler(&[
            self.sym(0.1),
            self.sym(0.1),
            home + self.sym(0.1),
            self.sym(d),
            self.sym(d),
            self.sym(d),
        ])
    }
}

fn plant() -> Mechanism {
    Mechanism::new(Params::default()).unwrap()
}

fn frictionless() -> Mechanism {
    Mechanism::new(Params {
        friction: Friction::NONE,
        ..Params::default()
    })
    .unwrap()
}

#[test]
fn home_geometry_matches_design_figures() {
    let m = plant();
    let legs = m.inverse_kinematics(&m.home());
    for i in 0..6 {
        assert!(
            (legs.length[i] - 0.566714).abs() < 1e-6,
            "leg {} = {}",
            i + 1,
            legs.length[i]
        );
    }
    let sv = legs.jacobian().singular_values();
    let cond = sv.max() / sv.min();
    assert!((6.0..8.0).contains(&cond), "cond(J) = {cond}");
}

#[test]
fn static_hold_forces_match_reference() {
    let m = plant();
    let tau = m.static_forces(&m.home()).unwrap();
    for i in 0..6 {
        assert!((tau[i] - 28.5315).abs() < 1e-4, "leg {}: {}", i + 1, tau[i]);
    }
    let no_rod = Mechanism::new(Params {
        legs: ckcm::Legs {
            rod_mass: 0.0,
            rod_inertia: 0.0,
            ..Default::default()
        },
        ..Params::default()
    })
    .unwrap();
    let tau = no_rod.static_forces(&no_rod.home()).unwrap();
    for i in 0..6 {
        assert!((tau[i] - 18.0647).abs() < 1e-4, "leg {}: {}", i + 1, tau[i]);
    }
}

#[test]
fn holding_static_forces_keeps_platform_at_home() {
    let m = plant();
    let tau = m.static_forces(&m.home()).unwrap();
    let mut s = State::at_rest(m.home());
    let rk = Rk4::default();
    let mut worst: f64 = 0.0;
    for _ in 0..1000 {
        rk.advance(&m, &mut s, &tau, 1e-3).unwrap();
        worst = worst.max((s.pose.p_world - m.home().p_world).norm());
    }
    assert!(worst < 1e-9, "drift {worst:e} m");
}

/// T + V − τ·l for constant forces τ (the potential of a constant load is −τ·l).
fn total_energy(m: &Mechanism, s: &State, tau: &Vector6<f64>) -> f64 {
    let l = m.inverse_kinematics(&s.pose).length;
    m.kinetic_energy(&s.pose, &s.twist) + m.potential_energy(&s.pose) - tau.dot(&l)
}

#[test]
fn energy_is_conserved_under_constant_forces() {
    let m = frictionless();
    let tau = m.static_forces(&m.home()).unwrap();
    let mut s = State {
        pose: m.home(),
        twist: Vector6::new(0.04, -0.03, 0.0335, 0.2, -0.15, 0.16),
    };
    let v = s.twist.fixed_rows::<3>(0).norm();
    let w = s.twist.fixed_rows::<3>(3).norm();
    assert!(
        (v - 0.06).abs() < 0.005 && (w - 0.3).abs() < 0.02,
        "|v| = {v}, |ω| = {w}"
    );
    let e0 = total_energy(&m, &s, &tau);
    let rk = Rk4::default();
    let mut worst: f64 = 0.0;
    for _ in 0..500 {
        rk.advance(&m, &mut s, &tau, 1e-3).unwrap();
        worst = worst.max((total_energy(&m, &s, &tau) - e0).abs());
    }
    // The motion is real: the platform moved and the energy split changed.
    assert!((s.pose.p_world - m.home().p_world).norm() > 5e-3);
    // Measured drift: 2.6e-13 J over 0.5 s (RK4's own truncation, fixed for a given
    // platform). The bound leaves 4x for a different libm's last-bit differences in sin, cos
    // and sqrt, and is still 1e-13 of the ~30 J energy: a wrong mass-matrix or bias term
    // breaks it by orders of magnitude.
    assert!(worst < 1e-12, "energy drift {worst:e} J");
}

#[test]
fn power_balance_under_time_varying_forces() {
    let m = frictionless();
    let hold = m.static_forces(&m.home()).unwrap();
    let mut s = State::at_rest(m.home());
    let energy = |s: &State| m.kinetic_energy(&s.pose, &s.twist) + m.potential_energy(&s.pose);
    let e0 = energy(&s);
    let h = 1e-3;
    let rk = Rk4::default();
    let mut work = 0.0;
    for n in 0..500 {
        let t = n as f64 * h;
        let tau = hold + Vector6::from_fn(|i, _| 2.0 * (6.0 * t + i as f64).sin());
        let l0 = m.inverse_kinematics(&s.pose).length;
        rk.advance(&m, &mut s, &tau, h).unwrap();
        let l1 = m.inverse_kinematics(&s.pose).length;
        // τ is held over the step, so ∫ τ·l̇ dt over it is exactly τ·Δl.
        work += tau.dot(&(l1 - l0));
    }
    let de = energy(&s) - e0;
    let moved = (s.pose.p_world - m.home().p_world).norm();
    assert!(moved > 1e-3 && moved < 0.1, "platform moved {moved} m");
    assert!(work.abs() > 1e-3, "test forces do too little work: {work}");
    assert!(((de - work) / work).abs() < 1e-6, "ΔE = {de}, W = {work}");
}

#[test]
fn closed_form_mass_matrix_equals_newton_euler() {
    let m = plant();
    let mut rng = Rng(1);
    for _ in 0..50 {
        let pose = rng.pose(0.5);
        let twist = rng.vec6(0.5);
        let tau = rng.vec6(50.0);
        let legs = m.inverse_kinematics(&pose);
        let closed = m.mass_matrix(&legs);
        let base = m.residual(&legs, &twist, &Vector6::zeros(), &tau);
        for j in 0..6 {
            let mut e = Vector6::zeros();
            e[j] = 1.0;
            let col = m.residual(&legs, &twist, &e, &tau) - base;
            let diff = (col - closed.column(j)).amax();
            assert!(diff < 1e-10, "column {j}: {diff:e}");
        }
        assert!((closed - closed.transpose()).amax() < 1e-12);
    }
}

#[test]
fn forward_of_inverse_dynamics_is_identity() {
    let m = plant();
    let mut rng = Rng(2);
    for _ in 0..200 {
        let pose = rng.pose(0.5);
        let twist = rng.vec6(0.3);
        let accel = rng.vec6(2.0);
        let legs = m.inverse_kinematics(&pose);
        let ldot = legs.jacobian() * twist;
        // Friction acts on the plant, so the actuators must supply it on top.
        let tau = m.inverse_dynamics(&pose, &twist, &accel).unwrap() - m.friction(&ldot);
        let back = m.forward_dynamics(&pose, &twist, &tau).unwrap();
        assert!((back - accel).amax() < 1e-9, "{:e}", (back - accel).amax());
    }
}

#[test]
fn joint_space_form_reproduces_task_space_forces() {
    let m = plant();
    let mut rng = Rng(3);
    for _ in 0..50 {
        let pose = rng.pose(0.5);
        let twist = rng.vec6(0.3);
        let accel = rng.vec6(2.0);
        let js = m.joint_space(&pose, &twist).unwrap();
        let lddot = m
            .inverse_kinematics(&pose)
            .leg_accelerations(&twist, &accel);
        let tau = m.inverse_dynamics(&pose, &twist, &accel).unwrap();
        let tau_js = js.mass * lddot + js.coriolis + js.gravity;
        assert!((tau - tau_js).amax() < 1e-8, "{:e}", (tau - tau_js).amax());
    }
}

/// Pose moved by a world-frame perturbation (δp, δθ).
fn perturb(pose: &Pose, d: &Vector6<f64>) -> Pose {
    Pose {
        p_world: pose.p_world + d.fixed_rows::<3>(0),
        q_world: UnitQuaternion::from_scaled_axis(d.fixed_rows::<3>(3).into_owned()) * pose.q_world,
    }
}

#[test]
fn jacobian_equals_finite_differences() {
    let m = plant();
    let mut rng = Rng(4);
    let h = 1e-6;
    for _ in 0..100 {
        let pose = rng.pose(0.5);
        let j = m.inverse_kinematics(&pose).jacobian();
        for k in 0..6 {
            let mut d = Vector6::zeros();
            d[k] = h;
            let lp = m.inverse_kinematics(&perturb(&pose, &d)).length;
            let lm = m.inverse_kinematics(&perturb(&pose, &-d)).length;
            let fd = (lp - lm) / (2.0 * h);
            assert!(
                (fd - j.column(k)).amax() < 1e-7,
                "column {k}: {:e}",
                (fd - j.column(k)).amax()
            );
        }
    }
}

#[test]
fn leg_accelerations_equal_finite_differences() {
    let m = plant();
    let mut rng = Rng(5);
    let dt = 1e-5;
    for _ in 0..100 {
        let pose = rng.pose(0.5);
        let twist = rng.vec6(0.4);
        let accel = rng.vec6(3.0);
        // Motion with constant twist derivative: p(t) = p + v t + ½ a t², R(t) = exp(ω t + ½ ω̇ t²) R.
        // The angular velocity of that R(t) differs from ω + ω̇t only at O(t²), even in t, so
        // it cancels in the central difference.
        let rate = |t: f64| {
            let d = twist * t + accel * (0.5 * t * t);
            let p = perturb(&pose, &d);
            m.inverse_kinematics(&p).leg_rates(&(twist + accel * t))
        };
        let fd = (rate(dt) - rate(-dt)) / (2.0 * dt);
        let exact = m
            .inverse_kinematics(&pose)
            .leg_accelerations(&twist, &accel);
        assert!((fd - exact).amax() < 1e-7, "{:e}", (fd - exact).amax());
    }
}

#[test]
fn forward_kinematics_round_trip() {
    let m = plant();
    let mut rng = Rng(6);
    let opts = FkOptions::default();
    let mut worst_iterations = 0;
    for _ in 0..1000 {
        let pose = rng.pose(0.5);
        let l = m.inverse_kinematics(&pose).length;
        let (found, iterations) = m.forward_kinematics(&l, &m.home(), &opts).unwrap();
        worst_iterations = worst_iterations.max(iterations);
        let residual = (m.inverse_kinematics(&found).length - l).amax();
        assert!(residual <= 1e-12, "residual {residual:e}");
        assert!((found.p_world - pose.p_world).norm() < 1e-11);
        assert!(found.q_world.angle_to(&pose.q_world) < 1e-11);
    }
    assert!(
        worst_iterations <= 8,
        "needed {worst_iterations} iterations"
    );
}

#[test]
fn forward_kinematics_reports_unreachable_lengths() {
    let m = plant();
    let opts = FkOptions::default();
    let too_short = Vector6::repeat(0.01);
    assert!(matches!(
        m.forward_kinematics(&too_short, &m.home(), &opts),
        Err(FkError::NotConverged { .. } | FkError::Singular { .. })
    ));
    let inconsistent = Vector6::new(0.3, 1.5, 0.3, 1.5, 0.3, 1.5);
    assert!(
        m.forward_kinematics(&inconsistent, &m.home(), &opts)
            .is_err()
    );
    let nan = Vector6::new(0.5, f64::NAN, 0.5, 0.5, 0.5, 0.5);
    assert!(matches!(
        m.forward_kinematics(&nan, &m.home(), &opts),
        Err(FkError::InvalidLength { index: 2, .. })
    ));
}

#[test]
fn invalid_parameters_are_rejected_by_name() {
    let mut p = Params::default();
    p.geometry.base_radius = -1.0;
    assert!(
        Mechanism::new(p)
            .unwrap_err()
            .to_string()
            .contains("base_radius")
    );
    let mut p = Params::default();
    p.platform.mass = f64::NAN;
    assert!(
        Mechanism::new(p)
            .unwrap_err()
            .to_string()
            .contains("platform_mass")
    );
    let mut p = Params::default();
    p.geometry.platform_joint_offset = 0.0;
    assert!(
        Mechanism::new(p)
            .unwrap_err()
            .to_string()
            .contains("platform_joint_offset")
    );
    let mut p = Params::default();
    p.geometry.base_joint_offset = 60f64.to_radians();
    assert!(
        Mechanism::new(p)
            .unwrap_err()
            .to_string()
            .contains("base_joint_offset")
    );
    let mut p = Params::default();
    p.legs.rod_mass = -0.1;
    assert!(
        Mechanism::new(p)
            .unwrap_err()
            .to_string()
            .contains("rod_mass")
    );
    assert!(Mechanism::new(Params::nominal()).is_ok());
    assert_eq!(Params::nominal().legs.rod_mass, 0.0);
    assert_eq!(Params::nominal().friction.coulomb, 0.0);
}

#[test]
fn trajectory_derivatives_equal_finite_differences() {
    let h = 1e-6;
    for traj in [
        Trajectory::line(0.5),
        Trajectory::circle(0.5),
        Trajectory::hold(0.5, 3.0),
    ] {
        let n = 97;
        for k in 1..n {
            let t = traj.duration * k as f64 / n as f64;
            let r = traj.sample(t);
            let (rp, rm) = (traj.sample(t + h), traj.sample(t - h));
            let v_fd = (rp.pose.p_world - rm.pose.p_world) / (2.0 * h);
            let a_fd = (rp.twist - rm.twist) / (2.0 * h);
            assert!(
                (v_fd - r.twist.fixed_rows::<3>(0)).amax() < 1e-8,
                "{:?} v at {t}",
                traj.kind
            );
            assert!((a_fd - r.accel).amax() < 1e-6, "{:?} a at {t}", traj.kind);
        }
    }
}

#[test]
fn trajectories_start_and_end_at_home_at_rest() {
    let home = Vector3::new(0.0, 0.0, 0.5);
    for traj in [Trajectory::line(0.5), Trajectory::circle(0.5)] {
        for t in [0.0, traj.duration] {
            let r = traj.sample(t);
            assert!(
                (r.pose.p_world - home).norm() < 1e-15,
                "{:?} at {t}",
                traj.kind
            );
            assert!(
                r.twist.norm() < 1e-15 && r.accel.norm() < 1e-12,
                "{:?} at {t}",
                traj.kind
            );
        }
    }
    // The line's far end lies on the paper's plane x + y − 2z + 1 = 0, at rest (C² turn-around).
    let line = Trajectory::line(0.5);
    let far = line.sample(7.5);
    let p = far.pose.p_world;
    assert!((p.x + p.y - 2.0 * p.z + 1.0).abs() < 1e-15);
    assert!((p - Vector3::new(0.1, 0.1, 0.6)).norm() < 1e-15);
    assert!(far.twist.norm() < 1e-15);
    // Every sample of the line stays on the plane; the circle stays at home height, radius 0.2.
    for k in 0..=150 {
        let t = 0.1 * k as f64;
        let p = line.sample(t).pose.p_world;
        assert!((p.x + p.y - 2.0 * p.z + 1.0).abs() < 1e-14);
        let c = Trajectory::circle(0.5).sample(t / 3.0).pose.p_world;
        assert!(((c - Vector3::new(0.0, 0.2, 0.5)).norm() - 0.2).abs() < 1e-14);
    }
}

#[test]
fn rk4_and_dormand_prince_agree_on_the_circle() {
    let m = plant();
    let traj = Trajectory::circle(0.5);
    let h = 1e-3;
    let mut a = State::at_rest(m.home());
    let mut b = a;
    let rk = Rk4::default();
    let mut dp = DormandPrince {
        rtol: 1e-10,
        atol: 1e-12,
        ..Default::default()
    };
    let mut worst: f64 = 0.0;
    for n in 0..2000 {
        let r = traj.sample(n as f64 * h);
        let ldot = m.inverse_kinematics(&r.pose).jacobian() * r.twist;
        let tau = m.inverse_dynamics(&r.pose, &r.twist, &r.accel).unwrap() - m.friction(&ldot);
        rk.advance(&m, &mut a, &tau, h).unwrap();
        dp.advance(&m, &mut b, &tau, h).unwrap();
        worst = worst.max((a.pose.p_world - b.pose.p_world).norm());
    }
    // The comparison covers real motion: open loop, the feedforward carries the platform
    // well away from home along the circle.
    let travelled = (a.pose.p_world - m.home().p_world).norm();
    assert!(travelled > 0.05, "the platform moved only {travelled} m");
    assert!(worst < 1e-8, "RK4 vs DP5: {worst:e} m");
}
