//! Orientation conversions used only at the interfaces.
//!
//! Inside the model orientation is a unit quaternion; Z-Y-X Euler angles
//! (alpha about z, beta about y, gamma about x), R = Rz(α)Ry(β)Rx(γ), paper eq. (A.12),
//! appear only in poses exchanged with users.

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// R = Rz(alpha) Ry(beta) Rx(gamma), paper eq. (A.12).
pub fn rotation_from_euler_zyx(alpha: f64, beta: f64, gamma: f64) -> Matrix3<f64> {
    let (sa, ca) = alpha.sin_cos();
    let (sb, cb) = beta.sin_cos();
    let (sg, cg) = gamma.sin_cos();
    Matrix3::new(
        ca * cb,
        ca * sb * sg - sa * cg,
        ca * sb * cg + sa * sg,
        sa * cb,
        sa * sb * sg + ca * cg,
        sa * sb * cg - ca * sg,
        -sb,
        cb * sg,
        cb * cg,
    )
}

/// Unit quaternion of the Z-Y-X Euler angles.
pub fn quaternion_from_euler_zyx(alpha: f64, beta: f64, gamma: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), alpha)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), beta)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), gamma)
}

/// Z-Y-X Euler angles (alpha, beta, gamma) of a rotation matrix; beta in [−π/2, π/2].
///
/// beta comes from atan2(sin β, cos β) beyond ±π/6, exact to rounding up to ±π/2 (where
/// asin loses about half the digits), and from asin within. Where cos β <
/// [`GIMBAL_LOCK_COS`] alpha and gamma are no longer told apart by the matrix (gimbal
/// lock): gamma is set to zero and alpha takes the whole rotation about z. The threshold
/// balances the two errors, the rounding of the regular formulas (about 1e-16 / cos β) and
/// gamma's share dropped here (about cos β).
#[inline]
pub fn euler_zyx_from_rotation(r: &Matrix3<f64>) -> (f64, f64, f64) {
    let cos_beta = (r[(0, 0)] * r[(0, 0)] + r[(1, 0)] * r[(1, 0)]).sqrt();
    let sin_beta = -r[(2, 0)];
    // asin is as exact where |sin β| ≤ 1/2 and cheaper: the poses a trial reads every step
    // keep their bits and their cost (BENCHMARKS.md, round 54).
    let beta = if sin_beta.abs() <= 0.5 {
        sin_beta.asin()
    } else {
        sin_beta.atan2(cos_beta)
    };
    if cos_beta >= GIMBAL_LOCK_COS {
        let alpha = r[(1, 0)].atan2(r[(0, 0)]);
        let gamma = r[(2, 1)].atan2(r[(2, 2)]);
        (alpha, beta, gamma)
    } else {
        let alpha = (-r[(0, 1)]).atan2(r[(1, 1)]);
        (alpha, beta, 0.0)
    }
}

/// cos β below which [`euler_zyx_from_rotation`] reports gamma = 0 (β within 1e-8 rad of
/// ±π/2).
pub const GIMBAL_LOCK_COS: f64 = 1e-8;

/// Z-Y-X Euler angles of a unit quaternion.
#[inline]
pub fn euler_zyx_from_quaternion(q: &UnitQuaternion<f64>) -> (f64, f64, f64) {
    let r: Rotation3<f64> = q.to_rotation_matrix();
    euler_zyx_from_rotation(r.matrix())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn euler_round_trip_and_quaternion_agree() {
        for &(a, b, g) in &[
            (0.1, -0.2, 0.3),
            (-2.0, 1.2, 3.0),
            (0.0, 0.0, 0.0),
            (3.0, -1.5, -0.7),
        ] {
            let r = rotation_from_euler_zyx(a, b, g);
            let q = quaternion_from_euler_zyx(a, b, g);
            assert!((q.to_rotation_matrix().matrix() - r).norm() < 1e-14);
            let (a2, b2, g2) = euler_zyx_from_rotation(&r);
            assert!((rotation_from_euler_zyx(a2, b2, g2) - r).norm() < 1e-13);
            assert!((a2 - a).abs() < 1e-12 && (b2 - b).abs() < 1e-12 && (g2 - g).abs() < 1e-12);
        }
    }

    /// Near gimbal lock the angles still rebuild the rotation and beta stays exact: before,
    /// within 1e-12 of |sin β| = 1 (β within 1.4e-6 rad of ±π/2) gamma was dropped, off by
    /// up to cos β · |sin γ| in the rebuilt matrix, and asin put beta off by as much as 6e-9.
    #[test]
    fn angles_near_gimbal_lock_rebuild_the_rotation() {
        for sign in [1.0, -1.0] {
            for offset in [1e-5, 1e-6, 1e-7, 2e-8, 5e-9, 1e-12, 0.0] {
                let (a, b, g) = (0.3, sign * (std::f64::consts::FRAC_PI_2 - offset), 0.7);
                let r = rotation_from_euler_zyx(a, b, g);
                let (a2, b2, g2) = euler_zyx_from_rotation(&r);
                let rebuilt = rotation_from_euler_zyx(a2, b2, g2);
                assert!(
                    (rebuilt - r).amax() < 2e-8,
                    "β = ±π/2 ∓ {offset}: rebuilt off by {:e}",
                    (rebuilt - r).amax()
                );
                assert!((b2 - b).abs() < 1e-15, "β = ±π/2 ∓ {offset}: {b2} for {b}");
            }
        }
    }

    #[test]
    fn rotation_is_orthonormal() {
        let r = rotation_from_euler_zyx(0.4, -0.3, 1.1);
        assert!((r * r.transpose() - Matrix3::identity()).norm() < 1e-14);
        assert!((r.determinant() - 1.0).abs() < 1e-14);
    }
}
