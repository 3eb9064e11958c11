//! Dynamics checks that energy conservation cannot make: the gyroscopic moment does no work,
//! a constant offset of the potential does not change its gradient, and the actuator forces
//! enter the Newton–Euler residual but not the mass matrix or the bias. Each test compares the
//! model (docs/model.md §3) with an independent statement of the physics: Euler's equations of
//! a free rigid body, the principle of virtual work, forward dynamics.

use ckcm::nalgebra::{Matrix3, UnitQuaternion, Vector3, Vector6};
use ckcm::{Friction, Legs, Mechanism, Params, Platform, Pose};

/// Legs without inertia: the cylinder's mass sits at its base joint (d_c = 0, I_c = 0) and the
/// rod is massless, so the legs only transmit the actuator forces. No gravity, no friction;
/// platform principal inertias all different, so every term of Euler's equations is non-zero.
fn free_platform() -> Mechanism {
    Mechanism::new(Params {
        platform: Platform {
            mass: 7.5,
            inertia: Vector3::new(0.07, 0.11, 0.18),
        },
        legs: Legs {
            cylinder_com: 0.0,
            cylinder_inertia: 0.0,
            rod_mass: 0.0,
            rod_com: 0.0,
            rod_inertia: 0.0,
            ..Legs::default()
        },
        friction: Friction::NONE,
        gravity: 0.0,
        ..Params::default()
    })
    .unwrap()
}

/// A tilted, shifted pose, so that body and world axes differ.
fn tilted(m: &Mechanism) -> Pose {
    Pose::from_xyz_euler(&[
        0.03,
        -0.02,
        m.params.geometry.home_height + 0.04,
        0.5,
        -0.2,
        0.3,
    ])
}

/// With massless legs and no forces the platform is a free rigid body: its centre of mass
/// does not accelerate and its angular velocity obeys Euler's equations in body axes,
/// I₁ ω̇₁ = (I₂ − I₃) ω₂ ω₃ and cyclic. The gyroscopic moment ω × Iω does no work, so the
/// energy tests cannot see its sign; this one does.
#[test]
fn free_platform_obeys_eulers_equations() {
    let m = free_platform();
    let pose = tilted(&m);
    let i = m.params.platform.inertia;
    let rot: Matrix3<f64> = *pose.q_world.to_rotation_matrix().matrix();
    for twist in [
        Vector6::new(0.1, -0.2, 0.05, 1.5, -2.0, 0.7),
        Vector6::new(0.0, 0.0, 0.0, -0.3, 0.8, 2.5),
    ] {
        let w_body = rot.transpose() * twist.fixed_rows::<3>(3);
        let dw_body = Vector3::new(
            (i.y - i.z) / i.x * w_body.y * w_body.z,
            (i.z - i.x) / i.y * w_body.z * w_body.x,
            (i.x - i.y) / i.z * w_body.x * w_body.y,
        );
        // ν̇ holds the world angular acceleration; ω̇_world = R ω̇_body since
        // d/dt (R ω_body) = R (ω_body × ω_body) + R ω̇_body.
        let dw_expected = rot * dw_body;
        let accel = m
            .forward_dynamics(&pose, &twist, &Vector6::zeros())
            .unwrap();
        let lin = accel.fixed_rows::<3>(0).norm();
        let ang = (accel.fixed_rows::<3>(3) - dw_expected).amax();
        assert!(
            lin < 1e-12,
            "twist {twist:?}: centre of mass accelerates, {lin:e} m/s²"
        );
        assert!(
            ang < 1e-12 * dw_expected.amax().max(1.0),
            "twist {twist:?}: ω̇ = {:?}, Euler's equations give {dw_expected:?}",
            accel.fixed_rows::<3>(3)
        );
        assert!(
            dw_expected.amax() > 0.5,
            "test must exercise the gyroscopic term"
        );
    }
}

/// Actuator forces on the free platform: m v̇ = Σ τ_i n_i and I ω̇ + ω × Iω = Σ τ_i r_i × n_i,
/// with n_i and r_i from the joint positions directly (eq. A.14), not from the leg Jacobian.
#[test]
fn free_platform_under_leg_forces() {
    let m = free_platform();
    let pose = tilted(&m);
    let rot: Matrix3<f64> = *pose.q_world.to_rotation_matrix().matrix();
    let inertia_world = rot * Matrix3::from_diagonal(&m.params.platform.inertia) * rot.transpose();
    let twist = Vector6::new(0.05, 0.02, -0.03, 0.4, -0.6, 0.9);
    let w = twist.fixed_rows::<3>(3).into_owned();
    let tau = Vector6::new(12.0, -7.0, 3.5, 20.0, -15.0, 9.0);
    let mut force = Vector3::zeros();
    let mut moment = Vector3::zeros();
    for k in 0..6 {
        let r = rot * m.a_platform[k];
        let leg = pose.p_world + r - m.b_world[k];
        let n = leg / leg.norm();
        force += n * tau[k];
        moment += r.cross(&n) * tau[k];
    }
    let a_expected = force / m.params.platform.mass;
    let dw_expected =
        inertia_world.try_inverse().unwrap() * (moment - w.cross(&(inertia_world * w)));
    let accel = m.forward_dynamics(&pose, &twist, &tau).unwrap();
    assert!(
        (accel.fixed_rows::<3>(0) - a_expected).amax() < 1e-12 * a_expected.amax(),
        "v̇ = {:?}, expected {a_expected:?}",
        accel.fixed_rows::<3>(0)
    );
    assert!(
        (accel.fixed_rows::<3>(3) - dw_expected).amax() < 1e-12 * dw_expected.amax(),
        "ω̇ = {:?}, expected {dw_expected:?}",
        accel.fixed_rows::<3>(3)
    );
}

/// The Newton–Euler residual M ν̇ + b − Jᵀ(τ + friction) vanishes at the acceleration forward
/// dynamics returns for the same τ: the actuator force enters the residual with the right sign.
#[test]
fn residual_vanishes_at_the_forward_dynamics_acceleration() {
    let m = Mechanism::new(Params::default()).unwrap();
    let poses = [
        tilted(&m),
        Pose::from_xyz_euler(&[
            -0.05,
            0.04,
            m.params.geometry.home_height - 0.03,
            -0.3,
            0.1,
            -0.2,
        ]),
    ];
    for (k, pose) in poses.iter().enumerate() {
        let twist = Vector6::new(0.1, -0.05, 0.02, 0.3, 0.2, -0.4) * (k as f64 + 1.0);
        let hold = m.static_forces(pose).unwrap();
        let tau = hold + Vector6::new(15.0, -10.0, 5.0, -20.0, 8.0, 12.0);
        let accel = m.forward_dynamics(pose, &twist, &tau).unwrap();
        assert!(
            accel.amax() > 1.0,
            "the forces must accelerate the platform"
        );
        let legs = m.inverse_kinematics(pose);
        let total = tau + m.friction(&(legs.jacobian() * twist));
        let r = m.residual(&legs, &twist, &accel, &total);
        assert!(r.amax() < 1e-9, "pose {k}: residual {r:?}");
    }
}

/// Pose moved by a world-frame perturbation (δp, δθ): p + δp, exp(δθ) R.
fn perturb(pose: &Pose, d: &Vector6<f64>) -> Pose {
    Pose {
        p_world: pose.p_world + d.fixed_rows::<3>(0),
        q_world: UnitQuaternion::from_scaled_axis(d.fixed_rows::<3>(3).into_owned()) * pose.q_world,
    }
}

/// Virtual work: at rest the gravity wrench b(x, 0) (Newton–Euler, per body) is the gradient
/// of the potential energy with respect to the world perturbation (δp, δθ). Checked by central
/// differences for the default legs and for heavier rods and cylinders, so that a term of the
/// potential that happens to be constant for one rod mass (1 kg by default) is still seen.
#[test]
fn gravity_wrench_is_the_gradient_of_the_potential() {
    let variants = [
        Legs::default(),
        Legs {
            rod_mass: 2.5,
            cylinder_mass: 4.0,
            rod_com: 0.22,
            ..Legs::default()
        },
    ];
    for legs_params in variants {
        let m = Mechanism::new(Params {
            legs: legs_params,
            ..Params::default()
        })
        .unwrap();
        let pose = tilted(&m);
        let wrench = m.bias(&m.inverse_kinematics(&pose), &Vector6::zeros());
        let h = 1e-5;
        for j in 0..6 {
            let mut d = Vector6::zeros();
            d[j] = h;
            let grad = (m.potential_energy(&perturb(&pose, &d))
                - m.potential_energy(&perturb(&pose, &-d)))
                / (2.0 * h);
            // Central differences: O(h²) truncation (~1e-9 N here) plus rounding of ~100 J
            // energies, 1e-14·100/1e-5 = 1e-7 N.
            assert!(
                (grad - wrench[j]).abs() < 1e-6,
                "{legs_params:?}, component {j}: ∂V = {grad}, b(x, 0) = {}",
                wrench[j]
            );
        }
    }
}
