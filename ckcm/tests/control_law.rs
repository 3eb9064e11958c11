//! The HLCS law (paper eqs. 7–10, 14) term by term, mid-circle where the reference
//! acceleration is not zero, against `Mechanism::inverse_dynamics` and a reference written out
//! here from its definition. Gains are distinct and large (Ki and Ψ thousands of times
//! Table 1's), so a dropped term, a swapped gain or the error in place of the integral moves
//! the outputs by newtons while the tolerance is 1e-9 N. The same law is checked through the
//! packaged controller FMU in `orchestrator/tests/control_law.rs`.

use ckcm::nalgebra::Vector6;
use ckcm::{
    ControlInput, ControlSettings, Gains, Hlcs, LearningLaw, Mechanism, Params, Pose, Trajectory,
};

const H: f64 = 1e-3;
const T: f64 = 5.0;
const TOL: f64 = 1e-9;

const GAINS: Gains = Gains {
    kp: 50000.0,
    ki: 20000.0,
    kd: 850.0,
    phi: 47728.0,
    gamma: 847.0,
    psi: 30000.0,
};

/// The circle of docs/model.md §3 from its definition: (pose, twist, acceleration).
fn circle_by_hand(t: f64) -> (Pose, Vector6<f64>, Vector6<f64>) {
    let (r, tp) = (0.2, 2.0 * std::f64::consts::PI);
    let tau = t / T;
    let s = 10.0 * tau.powi(3) - 15.0 * tau.powi(4) + 6.0 * tau.powi(5);
    let ds = (30.0 * tau.powi(2) - 60.0 * tau.powi(3) + 30.0 * tau.powi(4)) / T;
    let dds = (60.0 * tau - 180.0 * tau.powi(2) + 120.0 * tau.powi(3)) / (T * T);
    let (th, w, dw) = (tp * s, tp * ds, tp * dds);
    let pose = Pose::from_xyz_euler(&[r * th.sin(), r - r * th.cos(), 0.5, 0.0, 0.0, 0.0]);
    let twist = Vector6::new(r * th.cos() * w, r * th.sin() * w, 0.0, 0.0, 0.0, 0.0);
    let accel = Vector6::new(
        r * (th.cos() * dw - th.sin() * w * w),
        r * (th.sin() * dw + th.cos() * w * w),
        0.0,
        0.0,
        0.0,
        0.0,
    );
    (pose, twist, accel)
}

/// Measurements off the reference by known amounts, and a learning input of tens of N.
fn offsets(t: f64) -> (Vector6<f64>, Vector6<f64>, Vector6<f64>) {
    (
        Vector6::from_fn(|i, _| 1e-3 * (3.0 * t + i as f64).sin()),
        Vector6::from_fn(|i, _| 2e-3 * (5.0 * t + 2.0 * i as f64).cos()),
        Vector6::from_fn(|i, _| 40.0 * (2.0 * t + i as f64).sin()),
    )
}

/// Steps the law over the first 1.2 s of the circle with every combination of the switches,
/// checking force, memory_next, error and l_d at every sample and the size of every term at
/// t = 1 s.
#[test]
fn law_term_by_term_mid_circle() {
    let model = Mechanism::new(Params::nominal()).unwrap();
    let trajectory = Trajectory::circle(0.5);
    for (learning, feedforward) in [(true, true), (false, true), (true, false)] {
        let settings = ControlSettings {
            gains: GAINS,
            learning: LearningLaw::from_switch(learning),
            feedforward,
        };
        let mut law = Hlcs::new(model, settings);
        let mut integral = Vector6::<f64>::zeros();
        for n in 0..=1200 {
            let t = n as f64 * H;
            let (pose_d, twist_d, accel_d) = circle_by_hand(t);
            let legs_d = model.inverse_kinematics(&pose_d);
            let (delta, delta_dot, u) = offsets(t);
            let input = ControlInput {
                length: legs_d.length + delta,
                velocity: legs_d.leg_rates(&twist_d) + delta_dot,
                memory: u,
            };
            // evaluate previews without committing; step commits.
            let (preview, _) = law.evaluate(&trajectory.sample(t), &input, H).unwrap();
            let out = law.step(&trajectory.sample(t), &input, H).unwrap();
            assert_eq!(preview, out);

            let (e, edot) = (-delta, -delta_dot);
            integral += e * H;
            let tau_a = if feedforward {
                model.inverse_dynamics(&pose_d, &twist_d, &accel_d).unwrap()
            } else {
                Vector6::zeros()
            };
            let force = e * GAINS.kp + edot * GAINS.kd + integral * GAINS.ki + u + tau_a;
            let next = if learning {
                u + e * GAINS.phi + edot * GAINS.gamma + integral * GAINS.psi
            } else {
                u
            };
            assert!((out.error - e).amax() < 1e-12, "t = {t}: error");
            assert!(
                (out.length_ref - legs_d.length).amax() < 1e-12,
                "t = {t}: l_d"
            );
            assert!((out.feedforward - tau_a).amax() < TOL, "t = {t}: τ_a");
            assert!((out.force - force).amax() < TOL, "t = {t}: force");
            assert!(
                (out.memory_next - next).amax() < TOL,
                "t = {t}: memory_next"
            );
            assert!(
                (law.integral - integral).amax() < 1e-15,
                "t = {t}: integral"
            );

            if n == 1000 {
                let tau_static = model
                    .inverse_dynamics(&pose_d, &twist_d, &Vector6::zeros())
                    .unwrap();
                for (name, size) in [
                    ("M a_d", (tau_a - tau_static).amin()),
                    ("Ki I", (integral * GAINS.ki).amin()),
                    ("Ψ I", (integral * GAINS.psi).amin()),
                    ("Ψ (I − e)", ((integral - e) * GAINS.psi).amin()),
                    ("Kd ė", (edot * GAINS.kd).amin()),
                    ("Γ ė", (edot * GAINS.gamma).amin()),
                ] {
                    if feedforward || name != "M a_d" {
                        assert!(size > 1e-3, "{name} too small to test: {size:e} N");
                    }
                }
            }
        }
        // A new trial starts from a zero integral.
        law.reset();
        assert_eq!(law.integral, Vector6::zeros());
    }
}
