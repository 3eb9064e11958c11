//! Rigid-body dynamics in task space: M(x) ν̇ + b(x, ν) = Jᵀ(τ + friction) (docs/model.md §3).
//!
//! Generalised coordinates are the platform pose with the world twist ν = (v, ω). Each leg is
//! a cylinder hinged at the base and a rod ball-jointed to the platform, neither spinning
//! about the leg axis. The mass matrix is closed form; the bias b comes from per-body
//! Newton–Euler at zero acceleration, so the two are derived independently and the tests
//! can check one against the other.
//!
//! [`Mechanism::forward_dynamics`], which the integrators call four times per RK4 step,
//! lives in `soa`: the same formulas over the six legs as structure of arrays.

use nalgebra::{Matrix3, Matrix6, Vector3, Vector6};

use crate::kinematics::{LEGS, LegGeometry, Mechanism, Pose, skew};

mod soa;

/// Everything the dynamics needs at one state, computed once.
#[derive(Debug, Clone, Copy)]
pub struct DynamicsTerms {
    pub legs: LegGeometry,
    /// Task-space mass matrix M(x).
    pub mass: Matrix6<f64>,
    /// Bias b(x, ν): velocity-product and gravity terms.
    pub bias: Vector6<f64>,
    /// Leg Jacobian J(x).
    pub jacobian: Matrix6<f64>,
    /// Leg rates l̇ = J ν.
    pub leg_rates: Vector6<f64>,
}

/// The joint-space form of paper eq. (1): M(l) l̈ + C(l, l̇) l̇ + G(l) = τ.
#[derive(Debug, Clone, Copy)]
pub struct JointSpaceDynamics {
    /// M(l) = J⁻ᵀ M(x) J⁻¹.
    pub mass: Matrix6<f64>,
    /// C(l, l̇) l̇ = J⁻ᵀ (b(x, ν) − b(x, 0) − M(x) J⁻¹ J̇ν).
    pub coriolis: Vector6<f64>,
    /// G(l) = J⁻ᵀ b(x, 0).
    pub gravity: Vector6<f64>,
}

/// Why the dynamics could not be evaluated. Non-finite inputs and overflowing forces get
/// their own variants so a diverged integration is not reported as a singular matrix.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum DynamicsError {
    #[error("the leg Jacobian is singular at this pose")]
    SingularJacobian,
    #[error("the mass matrix is not positive definite at this pose")]
    SingularMass,
    #[error("the pose or twist is not finite (the integration diverged)")]
    NonFiniteState,
    #[error(
        "the platform acceleration is not finite: the actuator, gravity or friction forces overflow"
    )]
    NonFiniteAcceleration,
}

fn split(v: &Vector6<f64>) -> (Vector3<f64>, Vector3<f64>) {
    (
        v.fixed_rows::<3>(0).into_owned(),
        v.fixed_rows::<3>(3).into_owned(),
    )
}

impl Mechanism {
    /// Axial and transverse effective masses (a, c) of one leg at its platform joint, so that
    /// M_L = a n nᵀ + c (I − n nᵀ) with a = m_r and
    /// c = (m_c d_c² + I_c + m_r (l − d_r)² + I_r) / l².
    #[inline]
    fn leg_masses(&self, l: f64) -> (f64, f64) {
        let p = &self.params.legs;
        let transverse = (p.cylinder_mass * p.cylinder_com * p.cylinder_com
            + p.cylinder_inertia
            + p.rod_mass * (l - p.rod_com) * (l - p.rod_com)
            + p.rod_inertia)
            / (l * l);
        (p.rod_mass, transverse)
    }

    /// Closed-form task-space mass matrix M(x) = M_platform + Σ G_iᵀ M_L,i G_i with
    /// G_i = [I, −[r_i]×].
    ///
    /// Since M_L = c I + (a − c) n nᵀ and G_iᵀ n = j_i (the Jacobian row [n; r × n]),
    /// each leg adds c G_iᵀG_i + (a − c) j_i j_iᵀ, with
    /// G_iᵀG_i = [[I, −[r]×], [[r]×, |r|² I − r rᵀ]]: rank-one updates instead of 3×3 products.
    pub fn mass_matrix(&self, legs: &LegGeometry) -> Matrix6<f64> {
        self.mass_matrix_from(legs, &legs.jacobian(), &self.inertia_world(legs))
    }

    /// The platform inertia in {B}, R I_A Rᵀ: once per evaluation, shared by M and b.
    #[inline]
    fn inertia_world(&self, legs: &LegGeometry) -> Matrix3<f64> {
        self.inertia_world_from(&legs.rot_world)
    }

    /// R I_A Rᵀ for the orientation matrix R.
    #[inline]
    fn inertia_world_from(&self, rot: &Matrix3<f64>) -> Matrix3<f64> {
        rot * self.inertia_platform * rot.transpose()
    }

    /// [`Mechanism::mass_matrix`] from the leg Jacobian J (its rows j_i) and R I_A Rᵀ,
    /// which the caller has computed anyway.
    fn mass_matrix_from(
        &self,
        legs: &LegGeometry,
        jacobian: &Matrix6<f64>,
        inertia_world: &Matrix3<f64>,
    ) -> Matrix6<f64> {
        // Upper triangle on plain arrays (M is symmetric), mirrored at the end: half the
        // products of full 6×6 rank-one updates and no 3×3 temporaries.
        let mut u = [[0.0_f64; 6]; 6];
        let mut c_sum = self.params.platform.mass;
        let mut c_r = Vector3::zeros();
        for i in 0..LEGS {
            let (a, c) = self.leg_masses(legs.length[i]);
            let r = legs.r_world[i];
            let j: [f64; 6] = std::array::from_fn(|k| jacobian[(i, k)]);
            let w = a - c;
            for p in 0..6 {
                let wj = w * j[p];
                for q in p..6 {
                    u[p][q] += wj * j[q];
                }
            }
            c_sum += c;
            c_r += r * c;
            // c (|r|² I − r rᵀ), upper triangle of the rotational block.
            let rr = r.norm_squared();
            for p in 0..3 {
                for q in p..3 {
                    u[3 + p][3 + q] += c * (if p == q { rr } else { 0.0 } - r[p] * r[q]);
                }
            }
        }
        let mut m = Matrix6::from_fn(|p, q| if p <= q { u[p][q] } else { u[q][p] });
        for k in 0..3 {
            m[(k, k)] += c_sum;
        }
        let tr = -skew(&c_r);
        let mut top_right = m.fixed_view_mut::<3, 3>(0, 3);
        top_right += tr;
        let mut bottom_left = m.fixed_view_mut::<3, 3>(3, 0);
        bottom_left += tr.transpose();
        let mut bottom_right = m.fixed_view_mut::<3, 3>(3, 3);
        bottom_right += inertia_world;
        m
    }

    /// Force exerted by leg `i` on the platform at its joint, from per-body Newton–Euler of
    /// the cylinder and rod, given the joint's motion and the axial force `tau` (actuator plus
    /// friction, positive extends).
    fn leg_force_on_platform(
        &self,
        legs: &LegGeometry,
        i: usize,
        sd: &Vector3<f64>,
        sdd: &Vector3<f64>,
        tau: f64,
    ) -> Vector3<f64> {
        let p = &self.params.legs;
        let g = self.params.gravity;
        let n = legs.n_world[i];
        let l = legs.length[i];
        let ld = n.dot(sd);
        // Leg angular velocity ω_L = n × ṡ / l and acceleration α_L (no spin about n).
        let n_cross_sdd = n.cross(sdd);
        let w_leg = n.cross(sd) / l;
        let a_leg = (n_cross_sdd - w_leg * (2.0 * ld)) / l;
        let nd_sq = (sd.norm_squared() - ld * ld) / (l * l);
        // Both bodies' centre-of-mass accelerations involve n̈ = α_L × n + ω_L × ṅ, and since
        // α_L, ṅ and ω_L are all ⟂ n: n × n̈ = α_L and n·n̈ = −|ṅ|².
        // Cylinder: a_c = d_c n̈. Rod: a_r = s̈ − d_r n̈.
        let lever_rod = l - p.rod_com;
        // Moment balance of the whole leg about the base joint gives n × F (F: platform on
        // rod): l n × F = m_c d_c n × a_c + m_r (l − d_r) n × a_r + (I_c + I_r) α_L + gravity.
        let n_cross_f = (a_leg
            * (p.cylinder_mass * p.cylinder_com * p.cylinder_com
                + p.cylinder_inertia
                + p.rod_inertia
                - p.rod_mass * lever_rod * p.rod_com)
            + n_cross_sdd * (p.rod_mass * lever_rod)
            + Vector3::new(n.y, -n.x, 0.0)
                * (g * (p.cylinder_mass * p.cylinder_com + p.rod_mass * lever_rod)))
            / l;
        let f_perp = n_cross_f.cross(&n);
        // Axial balance of the rod: m_r a_r·n = F·n + τ − m_r g n_z.
        let f_axial = p.rod_mass * (n.dot(sdd) + p.rod_com * nd_sq + g * n.z) - tau;
        -(f_perp + n * f_axial)
    }

    /// Newton–Euler residual M(x) ν̇ + b(x, ν) − Jᵀ τ for the platform with all six legs.
    ///
    /// `tau` is the total axial force of each leg (actuator plus friction).
    pub fn residual(
        &self,
        legs: &LegGeometry,
        twist: &Vector6<f64>,
        accel: &Vector6<f64>,
        tau: &Vector6<f64>,
    ) -> Vector6<f64> {
        self.residual_from(legs, &self.inertia_world(legs), twist, accel, tau)
    }

    /// [`Mechanism::residual`] with R I_A Rᵀ computed by the caller.
    fn residual_from(
        &self,
        legs: &LegGeometry,
        inertia_world: &Matrix3<f64>,
        twist: &Vector6<f64>,
        accel: &Vector6<f64>,
        tau: &Vector6<f64>,
    ) -> Vector6<f64> {
        let (v, w) = split(twist);
        let (a, dw) = split(accel);
        let m = self.params.platform.mass;
        let mut force = (a + Vector3::z() * self.params.gravity) * m;
        let mut moment = inertia_world * dw + w.cross(&(inertia_world * w));
        for i in 0..LEGS {
            let r = legs.r_world[i];
            let sd = v + w.cross(&r);
            let sdd = a + dw.cross(&r) + w.cross(&w.cross(&r));
            let f = self.leg_force_on_platform(legs, i, &sd, &sdd, tau[i]);
            force -= f;
            moment -= r.cross(&f);
        }
        Vector6::new(force.x, force.y, force.z, moment.x, moment.y, moment.z)
    }

    /// Bias b(x, ν) = residual at zero acceleration and zero force.
    pub fn bias(&self, legs: &LegGeometry, twist: &Vector6<f64>) -> Vector6<f64> {
        self.residual(legs, twist, &Vector6::zeros(), &Vector6::zeros())
    }

    /// M, b, J and l̇ at one state.
    pub fn terms(&self, pose: &Pose, twist: &Vector6<f64>) -> DynamicsTerms {
        let legs = self.inverse_kinematics(pose);
        let jacobian = legs.jacobian();
        let inertia_world = self.inertia_world(&legs);
        DynamicsTerms {
            mass: self.mass_matrix_from(&legs, &jacobian, &inertia_world),
            bias: self.residual_from(
                &legs,
                &inertia_world,
                twist,
                &Vector6::zeros(),
                &Vector6::zeros(),
            ),
            leg_rates: jacobian * twist,
            jacobian,
            legs,
        }
    }

    /// Friction of every leg at leg rates `ldot`.
    pub fn friction(&self, ldot: &Vector6<f64>) -> Vector6<f64> {
        ldot.map(|x| self.params.friction.force(x))
    }

    /// Inverse dynamics τ = J⁻ᵀ (M ν̇ + b): the actuator forces that produce `accel`,
    /// ignoring friction (the feedforward of docs/model.md §4 uses a frictionless nominal model).
    pub fn inverse_dynamics(
        &self,
        pose: &Pose,
        twist: &Vector6<f64>,
        accel: &Vector6<f64>,
    ) -> Result<Vector6<f64>, DynamicsError> {
        let t = self.terms(pose, twist);
        let wrench = t.mass * accel + t.bias;
        t.jacobian
            .transpose()
            .lu()
            .solve(&wrench)
            .ok_or(DynamicsError::SingularJacobian)
    }

    /// The paper's joint-space form, eq. (1), derived from the task-space one.
    pub fn joint_space(
        &self,
        pose: &Pose,
        twist: &Vector6<f64>,
    ) -> Result<JointSpaceDynamics, DynamicsError> {
        let t = self.terms(pose, twist);
        let j_inv = t
            .jacobian
            .try_inverse()
            .ok_or(DynamicsError::SingularJacobian)?;
        let j_inv_t = j_inv.transpose();
        let gravity_task = self.bias(&t.legs, &Vector6::zeros());
        let jdot_nu = t.legs.leg_accelerations(twist, &Vector6::zeros());
        Ok(JointSpaceDynamics {
            mass: j_inv_t * t.mass * j_inv,
            coriolis: j_inv_t * (t.bias - gravity_task - t.mass * (j_inv * jdot_nu)),
            gravity: j_inv_t * gravity_task,
        })
    }

    /// Kinetic energy ½ νᵀ M ν, J.
    pub fn kinetic_energy(&self, pose: &Pose, twist: &Vector6<f64>) -> f64 {
        let legs = self.inverse_kinematics(pose);
        0.5 * twist.dot(&(self.mass_matrix(&legs) * twist))
    }

    /// Gravitational potential energy of platform, cylinders and rods (zero at z = 0), J.
    pub fn potential_energy(&self, pose: &Pose) -> f64 {
        let legs = self.inverse_kinematics(pose);
        let p = &self.params.legs;
        let g = self.params.gravity;
        let mut v = self.params.platform.mass * g * pose.p_world.z;
        for i in 0..LEGS {
            let n = legs.n_world[i];
            let s_z = self.b_world[i].z + legs.leg_world[i].z;
            v += g
                * (p.cylinder_mass * (self.b_world[i].z + p.cylinder_com * n.z)
                    + p.rod_mass * (s_z - p.rod_com * n.z));
        }
        v
    }

    /// Actuator forces that hold `pose` at rest (inverse dynamics at zero twist and acceleration).
    pub fn static_forces(&self, pose: &Pose) -> Result<Vector6<f64>, DynamicsError> {
        self.inverse_dynamics(pose, &Vector6::zeros(), &Vector6::zeros())
    }
}

/// The Cholesky factor M = L Lᵀ of a symmetric positive-definite 6×6 M, with the
/// reciprocals of its diagonal.
///
/// Hand-written on fixed-size arrays rather than nalgebra's `cholesky().solve()`: in
/// profiles the generic factorisation plus its two triangular solves was the largest single
/// cost of a forward-dynamics evaluation after the Newton–Euler bias. Each column is its own
/// const-generic call so every loop unrolls completely: as plain nested loops the outer one
/// stayed a loop and the FMI-free trial took 7–8 % more CPU (BENCHMARKS.md, round 7). Split
/// into factor and solve so the caller can put independent work between them.
struct Cholesky6 {
    /// L column by column: `lt[k][i]` = L_ik, so one column's rows are contiguous and the
    /// updates of a column's six rows vectorise.
    lt: [[f64; 6]; 6],
    /// 1 / L_jj: six divisions instead of one per element.
    inv: [f64; 6],
}

// Index loops state the textbook algorithm directly; iterator forms obscure it.
#[allow(clippy::needless_range_loop)]
impl Cholesky6 {
    /// The factor, or `None` when M is not positive definite (NaN included).
    #[inline]
    fn new(m: &Matrix6<f64>) -> Option<Self> {
        let mut lt = [[0.0_f64; 6]; 6];
        let mut inv = [0.0_f64; 6];
        // One call per column with the column index a constant, so every inner loop has a
        // constant trip count and unrolls completely.
        (Self::column::<0>(m, &mut lt, &mut inv)
            && Self::column::<1>(m, &mut lt, &mut inv)
            && Self::column::<2>(m, &mut lt, &mut inv)
            && Self::column::<3>(m, &mut lt, &mut inv)
            && Self::column::<4>(m, &mut lt, &mut inv)
            && Self::column::<5>(m, &mut lt, &mut inv))
        .then_some(Self { lt, inv })
    }

    /// Column `J` of L (left-looking): false when M is not positive definite there.
    #[inline(always)]
    fn column<const J: usize>(
        m: &Matrix6<f64>,
        lt: &mut [[f64; 6]; 6],
        inv: &mut [f64; 6],
    ) -> bool {
        let mut d = m[(J, J)];
        for k in 0..J {
            d -= lt[k][J] * lt[k][J];
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let d = d.sqrt();
        lt[J][J] = d;
        inv[J] = 1.0 / d;
        let mut s = [0.0_f64; 6];
        for i in J + 1..6 {
            s[i] = m[(i, J)];
        }
        for k in 0..J {
            for i in J + 1..6 {
                s[i] -= lt[k][i] * lt[k][J];
            }
        }
        for i in J + 1..6 {
            lt[J][i] = s[i] * inv[J];
        }
        true
    }

    /// x with M x = b.
    #[inline]
    fn solve(&self, b: &Vector6<f64>) -> Vector6<f64> {
        let (lt, inv) = (&self.lt, &self.inv);
        let mut y = [0.0_f64; 6];
        for i in 0..6 {
            let mut s = b[i];
            for k in 0..i {
                s -= lt[k][i] * y[k];
            }
            y[i] = s * inv[i];
        }
        let mut x = [0.0_f64; 6];
        for i in (0..6).rev() {
            let mut s = y[i];
            for k in i + 1..6 {
                s -= lt[i][k] * x[k];
            }
            x[i] = s * inv[i];
        }
        Vector6::from(x)
    }
}

/// Solves M x = b for a symmetric positive-definite 6×6 M, or `None` when M is not
/// positive definite.
#[cfg(test)]
fn solve_spd6(m: &Matrix6<f64>, b: &Vector6<f64>) -> Option<Vector6<f64>> {
    Cholesky6::new(m).map(|f| f.solve(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spd_solve_matches_nalgebra_and_rejects_indefinite() {
        let a = Matrix6::from_fn(|i, j| ((i * 7 + j * 3) % 5) as f64 - 1.5);
        let m = a * a.transpose() + Matrix6::identity() * 0.5;
        let b = Vector6::new(1.0, -2.0, 0.5, 3.0, -1.0, 2.0);
        let ours = solve_spd6(&m, &b).unwrap();
        let theirs = m.cholesky().unwrap().solve(&b);
        assert!((ours - theirs).amax() < 1e-12 * theirs.amax().max(1.0));
        assert!((m * ours - b).amax() < 1e-10);
        let mut indefinite = m;
        indefinite[(3, 3)] = -1.0;
        assert!(solve_spd6(&indefinite, &b).is_none());
        assert!(solve_spd6(&(m * f64::NAN), &b).is_none());
    }

    /// The unrolled, column-major factorisation performs each element's operations in the
    /// textbook order (row-major loops below), so it gives the same bits, and fails on the
    /// same matrices.
    #[test]
    #[allow(clippy::needless_range_loop)]
    fn same_bits_as_the_textbook_loops() {
        fn textbook(m: &Matrix6<f64>, b: &Vector6<f64>) -> Option<[f64; 6]> {
            let mut l = [[0.0_f64; 6]; 6];
            let mut inv = [0.0_f64; 6];
            for j in 0..6 {
                let mut d = m[(j, j)];
                for k in 0..j {
                    d -= l[j][k] * l[j][k];
                }
                if d.is_nan() || d <= 0.0 {
                    return None;
                }
                l[j][j] = d.sqrt();
                inv[j] = 1.0 / l[j][j];
                for i in j + 1..6 {
                    let mut s = m[(i, j)];
                    for k in 0..j {
                        s -= l[i][k] * l[j][k];
                    }
                    l[i][j] = s * inv[j];
                }
            }
            let mut y = [0.0; 6];
            for i in 0..6 {
                let mut s = b[i];
                for k in 0..i {
                    s -= l[i][k] * y[k];
                }
                y[i] = s * inv[i];
            }
            let mut x = [0.0; 6];
            for i in (0..6).rev() {
                let mut s = y[i];
                for k in i + 1..6 {
                    s -= l[k][i] * x[k];
                }
                x[i] = s * inv[i];
            }
            Some(x)
        }
        let mut seed = 0x2545_F491_4F6C_DD1D_u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for case in 0..5_000 {
            let a = Matrix6::from_fn(|_, _| next());
            let mut m = a * a.transpose() + Matrix6::identity() * (0.01 + next().abs());
            // Every sixth case loses definiteness at a different column.
            if case % 6 == 5 {
                let j = (case / 6) % 6;
                m[(j, j)] = -next().abs();
            }
            let b = Vector6::from_fn(|_, _| 10.0 * next());
            let ours = solve_spd6(&m, &b).map(|x| x.map(f64::to_bits));
            let theirs = textbook(&m, &b).map(|x| Vector6::from(x).map(f64::to_bits));
            assert_eq!(ours, theirs, "case {case}");
        }
    }
}
