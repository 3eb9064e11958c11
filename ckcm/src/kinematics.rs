//! Joint layout, closed-form inverse kinematics (paper A.14–A.16), the leg Jacobian,
//! leg accelerations, and Newton–Raphson forward kinematics on SE(3).

use nalgebra::{Matrix3, Matrix6, UnitQuaternion, Vector3, Vector6};

use crate::params::{ParamError, Params};
use crate::rotation::{euler_zyx_from_quaternion, quaternion_from_euler_zyx};

/// Number of legs.
pub const LEGS: usize = 6;

/// Platform pose in {B}: position of the {A} origin and orientation of {A}.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub p_world: Vector3<f64>,
    pub q_world: UnitQuaternion<f64>,
}

impl Pose {
    /// Whether position and orientation are finite.
    pub fn is_finite(&self) -> bool {
        self.p_world.iter().all(|x| x.is_finite())
            && self.q_world.coords.iter().all(|x| x.is_finite())
    }

    /// Pose from [x, y, z, alpha, beta, gamma] (Z-Y-X Euler angles, rad).
    pub fn from_xyz_euler(v: &[f64; 6]) -> Self {
        Self {
            p_world: Vector3::new(v[0], v[1], v[2]),
            q_world: quaternion_from_euler_zyx(v[3], v[4], v[5]),
        }
    }

    /// [x, y, z, alpha, beta, gamma].
    #[inline]
    pub fn to_xyz_euler(&self) -> [f64; 6] {
        let (a, b, g) = euler_zyx_from_quaternion(&self.q_world);
        [self.p_world.x, self.p_world.y, self.p_world.z, a, b, g]
    }

    /// The home pose (0, 0, h), R = I.
    pub fn home(home_height: f64) -> Self {
        Self {
            p_world: Vector3::new(0.0, 0.0, home_height),
            q_world: UnitQuaternion::identity(),
        }
    }
}

/// Leg geometry at one pose, from inverse kinematics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LegGeometry {
    /// Platform orientation R as a matrix, computed once for everything downstream.
    pub rot_world: Matrix3<f64>,
    /// Platform joint offsets rotated into {B}: r_i = R a_i, m.
    pub r_world: [Vector3<f64>; LEGS],
    /// Leg vectors l_i = p + R a_i − b_i, eq. (A.14), m.
    pub leg_world: [Vector3<f64>; LEGS],
    /// Unit leg vectors n_i.
    pub n_world: [Vector3<f64>; LEGS],
    /// Leg lengths |l_i|, eq. (A.16), m.
    pub length: Vector6<f64>,
}

impl LegGeometry {
    /// J with rows [n_iᵀ, (r_i × n_i)ᵀ], so that l̇ = J ν for the world twist ν = (v, ω).
    pub fn jacobian(&self) -> Matrix6<f64> {
        let mut j = Matrix6::zeros();
        for i in 0..LEGS {
            let n = self.n_world[i];
            let m = self.r_world[i].cross(&n);
            j.fixed_view_mut::<1, 3>(i, 0).copy_from(&n.transpose());
            j.fixed_view_mut::<1, 3>(i, 3).copy_from(&m.transpose());
        }
        j
    }

    /// Leg rates l̇ = J ν.
    pub fn leg_rates(&self, twist: &Vector6<f64>) -> Vector6<f64> {
        let v = twist.fixed_rows::<3>(0).into_owned();
        let w = twist.fixed_rows::<3>(3).into_owned();
        Vector6::from_fn(|i, _| self.n_world[i].dot(&(v + w.cross(&self.r_world[i]))))
    }

    /// Leg accelerations l̈ = n·s̈ + |ṡ⊥|²/l, with s the platform joint:
    /// ṡ = v + ω×r, s̈ = v̇ + ω̇×r + ω×(ω×r).
    pub fn leg_accelerations(&self, twist: &Vector6<f64>, accel: &Vector6<f64>) -> Vector6<f64> {
        let v = twist.fixed_rows::<3>(0).into_owned();
        let w = twist.fixed_rows::<3>(3).into_owned();
        let a = accel.fixed_rows::<3>(0).into_owned();
        let dw = accel.fixed_rows::<3>(3).into_owned();
        Vector6::from_fn(|i, _| {
            let r = self.r_world[i];
            let n = self.n_world[i];
            let sd = v + w.cross(&r);
            let sdd = a + dw.cross(&r) + w.cross(&w.cross(&r));
            let ld = n.dot(&sd);
            n.dot(&sdd) + (sd.norm_squared() - ld * ld) / self.length[i]
        })
    }
}

/// Forward kinematics failure.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum FkError {
    #[error(
        "forward kinematics did not converge in {iterations} iterations (residual {residual:e} m)"
    )]
    NotConverged { iterations: usize, residual: f64 },
    #[error(
        "forward kinematics met a singular Jacobian after {iterations} iterations (residual {residual:e} m)"
    )]
    Singular { iterations: usize, residual: f64 },
    #[error("leg length {index} = {value} is not a finite positive length")]
    InvalidLength { index: usize, value: f64 },
}

/// Newton–Raphson settings for forward kinematics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FkOptions {
    /// Stop when max |l(x) − l| falls below this, m. Default 1e-12.
    pub tolerance: f64,
    /// Give up after this many iterations. Default 20.
    pub max_iterations: usize,
}

impl Default for FkOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-12,
            max_iterations: 20,
        }
    }
}

/// A validated mechanism: parameters plus the joint positions they imply.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mechanism {
    pub params: Params,
    /// Platform joints a_i in {A}, m.
    pub a_platform: [Vector3<f64>; LEGS],
    /// Base joints b_i in {B}, m.
    pub b_world: [Vector3<f64>; LEGS],
    /// Platform inertia in {A}, kg·m².
    pub inertia_platform: Matrix3<f64>,
}

impl Mechanism {
    /// Validates `params` and places the joints (docs/model.md §3, the Simscape Stewart layout):
    /// base joint angles 120°k ∓ θB, platform joint angles 120°k − 60° + θA and 120°k + 60° − θA.
    pub fn new(params: Params) -> Result<Self, ParamError> {
        params.validate()?;
        let g = &params.geometry;
        let mut a_platform = [Vector3::zeros(); LEGS];
        let mut b_world = [Vector3::zeros(); LEGS];
        for k in 0..3 {
            let base = (120.0 * k as f64).to_radians();
            let sixty = 60f64.to_radians();
            let angles_b = [base - g.base_joint_offset, base + g.base_joint_offset];
            let angles_a = [
                base - sixty + g.platform_joint_offset,
                base + sixty - g.platform_joint_offset,
            ];
            for j in 0..2 {
                let i = 2 * k + j;
                b_world[i] =
                    Vector3::new(angles_b[j].cos(), angles_b[j].sin(), 0.0) * g.base_radius;
                a_platform[i] =
                    Vector3::new(angles_a[j].cos(), angles_a[j].sin(), 0.0) * g.platform_radius;
            }
        }
        Ok(Self {
            params,
            a_platform,
            b_world,
            inertia_platform: Matrix3::from_diagonal(&params.platform.inertia),
        })
    }

    /// The home pose of this mechanism.
    pub fn home(&self) -> Pose {
        Pose::home(self.params.geometry.home_height)
    }

    /// Closed-form inverse kinematics, paper eqs. (A.14)–(A.16).
    pub fn inverse_kinematics(&self, pose: &Pose) -> LegGeometry {
        let rot = *pose.q_world.to_rotation_matrix().matrix();
        let mut out = LegGeometry {
            rot_world: rot,
            r_world: [Vector3::zeros(); LEGS],
            leg_world: [Vector3::zeros(); LEGS],
            n_world: [Vector3::zeros(); LEGS],
            length: Vector6::zeros(),
        };
        for i in 0..LEGS {
            let r = rot * self.a_platform[i];
            let leg = pose.p_world + r - self.b_world[i];
            let l = leg.norm();
            out.r_world[i] = r;
            out.leg_world[i] = leg;
            out.n_world[i] = leg / l;
            out.length[i] = l;
        }
        out
    }

    /// Forward kinematics by Newton–Raphson on SE(3), starting from `guess`.
    ///
    /// The update solves J δ = l − l(x) for δ = (δp, δθ) and applies p += δp,
    /// R ← exp(δθ) R, so J is the exact derivative of l with respect to a world-frame
    /// perturbation and convergence is quadratic near the solution. Returns the pose and
    /// the number of iterations used.
    pub fn forward_kinematics(
        &self,
        lengths: &Vector6<f64>,
        guess: &Pose,
        options: &FkOptions,
    ) -> Result<(Pose, usize), FkError> {
        for (index, &value) in lengths.iter().enumerate() {
            if !(value.is_finite() && value > 0.0) {
                return Err(FkError::InvalidLength {
                    index: index + 1,
                    value,
                });
            }
        }
        let mut pose = *guess;
        let mut residual = f64::INFINITY;
        for iteration in 0..=options.max_iterations {
            let legs = self.inverse_kinematics(&pose);
            let err = lengths - legs.length;
            residual = err.amax();
            if !residual.is_finite() {
                break;
            }
            if residual <= options.tolerance {
                return Ok((pose, iteration));
            }
            if iteration == options.max_iterations {
                break;
            }
            let delta = legs
                .jacobian()
                .lu()
                .solve(&err)
                .filter(|d| d.iter().all(|x| x.is_finite()))
                .ok_or(FkError::Singular {
                    iterations: iteration,
                    residual,
                })?;
            pose.p_world += delta.fixed_rows::<3>(0);
            pose.q_world = UnitQuaternion::from_scaled_axis(delta.fixed_rows::<3>(3).into_owned())
                * pose.q_world;
        }
        Err(FkError::NotConverged {
            iterations: options.max_iterations,
            residual,
        })
    }
}

/// Skew-symmetric cross-product matrix [v]× with [v]× w = v × w.
#[inline]
pub fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}
