//! The pose as users exchange it: [x, y, z, α, β, γ] with Z-Y-X Euler angles
//! (docs/model.md §3, paper eq. A.12), and the finiteness check that guards the FMUs'
//! inputs. Expected values come from rotations written out by hand, not from the code.

use ckcm::Pose;
use ckcm::nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

/// Elementary rotations written out, so the test does not reuse `ckcm::rotation`.
fn rz(a: f64) -> Matrix3<f64> {
    Matrix3::new(a.cos(), -a.sin(), 0.0, a.sin(), a.cos(), 0.0, 0.0, 0.0, 1.0)
}
fn ry(b: f64) -> Matrix3<f64> {
    Matrix3::new(b.cos(), 0.0, b.sin(), 0.0, 1.0, 0.0, -b.sin(), 0.0, b.cos())
}
fn rx(g: f64) -> Matrix3<f64> {
    Matrix3::new(1.0, 0.0, 0.0, 0.0, g.cos(), -g.sin(), 0.0, g.sin(), g.cos())
}

/// Non-trivial poses: every angle non-zero, of both signs, β away from ±π/2 (where γ is not
/// defined), α and γ beyond ±π/2 so that a wrong quadrant shows.
const POSES: [[f64; 6]; 4] = [
    [0.012, -0.034, 0.81, 0.3, -0.2, 0.1],
    [-0.05, 0.07, 0.95, -2.5, 1.1, 2.9],
    [0.1, 0.0, 0.7, 1.9, -1.3, -2.2],
    [0.0, -0.2, 1.2, -0.4, 0.6, -1.7],
];

#[test]
fn euler_angles_round_trip_through_the_pose() {
    for v in &POSES {
        let pose = Pose::from_xyz_euler(v);
        // The orientation is R = Rz(α) Ry(β) Rx(γ), eq. (A.12).
        let r_expected = rz(v[3]) * ry(v[4]) * rx(v[5]);
        let r = *pose.q_world.to_rotation_matrix().matrix();
        assert!(
            (r - r_expected).norm() < 1e-14,
            "pose {v:?}: R differs from Rz Ry Rx by {:e}",
            (r - r_expected).norm()
        );
        let back = pose.to_xyz_euler();
        for k in 0..6 {
            assert!(
                (back[k] - v[k]).abs() < 1e-12,
                "pose {v:?}: component {k} reads back as {} (error {:e})",
                back[k],
                back[k] - v[k]
            );
        }
    }
}

/// Euler angles read from a pose built without Euler angles: an axis-angle quaternion whose
/// Z-Y-X decomposition is known by hand.
#[test]
fn euler_angles_of_single_axis_rotations() {
    let cases = [
        (Vector3::z_axis(), 0.7, [0.7, 0.0, 0.0]),
        (Vector3::y_axis(), -0.4, [0.0, -0.4, 0.0]),
        (Vector3::x_axis(), 2.6, [0.0, 0.0, 2.6]),
    ];
    for (axis, angle, expected) in cases {
        let pose = Pose {
            p_world: Vector3::new(-0.3, 0.25, 1.05),
            q_world: UnitQuaternion::from_axis_angle(&axis, angle),
        };
        let v = pose.to_xyz_euler();
        assert_eq!(&v[..3], &[-0.3, 0.25, 1.05], "position read back");
        for k in 0..3 {
            assert!(
                (v[3 + k] - expected[k]).abs() < 1e-12,
                "rotation {angle} about {axis:?}: angle {k} = {}, expected {}",
                v[3 + k],
                expected[k]
            );
        }
    }
}

#[test]
fn finite_pose_is_finite() {
    for v in &POSES {
        assert!(Pose::from_xyz_euler(v).is_finite(), "{v:?}");
    }
    assert!(Pose::home(0.8).is_finite());
}

/// One bad component anywhere, position or orientation, makes the pose non-finite.
#[test]
fn one_non_finite_component_makes_the_pose_non_finite() {
    let good = Pose::from_xyz_euler(&POSES[0]);
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        for k in 0..3 {
            let mut pose = good;
            pose.p_world[k] = bad;
            assert!(!pose.is_finite(), "position component {k} = {bad}");
        }
        for k in 0..4 {
            let mut c = good.q_world.into_inner().coords;
            c[k] = bad;
            let pose = Pose {
                p_world: good.p_world,
                q_world: UnitQuaternion::new_unchecked(Quaternion::from(c)),
            };
            assert!(!pose.is_finite(), "quaternion component {k} = {bad}");
        }
    }
}

/// Forward kinematics takes leg lengths, which are positive distances: zero, negative and
/// infinite lengths are rejected up front, naming the leg (1-based), before any iteration
/// could turn them into a pose.
#[test]
fn forward_kinematics_rejects_non_positive_and_infinite_lengths() {
    let m = ckcm::Mechanism::new(ckcm::Params::default()).unwrap();
    let home_lengths = m.inverse_kinematics(&m.home()).length;
    for (leg, bad) in [
        (1, 0.0),
        (3, -0.5),
        (4, -0.0),
        (6, f64::INFINITY),
        (2, f64::NAN),
    ] {
        let mut lengths = home_lengths;
        lengths[leg - 1] = bad;
        match m.forward_kinematics(&lengths, &m.home(), &ckcm::FkOptions::default()) {
            Err(ckcm::FkError::InvalidLength { index, value }) => {
                assert_eq!(index, leg, "length {bad}");
                assert!(
                    value.to_bits() == bad.to_bits(),
                    "reported {value}, set {bad}"
                );
            }
            other => panic!("leg {leg} length {bad}: {other:?}"),
        }
    }
    // The valid home lengths give back the home pose.
    let (pose, _) = m
        .forward_kinematics(&home_lengths, &m.home(), &ckcm::FkOptions::default())
        .unwrap();
    assert!((pose.p_world - m.home().p_world).norm() < 1e-12);
}
