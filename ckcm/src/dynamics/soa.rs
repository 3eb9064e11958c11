//! Forward dynamics with the six legs laid out as structure of arrays, the form the
//! integrator calls four times per RK4 step.
//!
//! Every per-leg quantity is an `[f64; 6]` per component, and every per-leg formula is a
//! loop over the six legs with no calls in its body, so the compiler computes two legs per
//! SSE2 instruction (BENCHMARKS.md, round 4: AVX2 gained nothing, the evaluation is bound by
//! its chains of square roots and divisions). Each formula is written in exactly the operation order of the
//! reference path ([`Mechanism::inverse_kinematics`], [`Mechanism::terms`] and the
//! Cholesky solve, which follow nalgebra's order for dot, cross and matrix–vector
//! products), and sums over legs run in leg order: the result is bit-identical to the
//! reference, which `tests::same_bits_as_the_reference_path` checks on random states.

use nalgebra::{Matrix3, Matrix6, Vector6};

use super::{Cholesky6, DynamicsError};
use crate::kinematics::{LEGS, Mechanism, Pose};

/// One component per row: `v[k][i]` is component k of leg i.
type Soa3 = [[f64; LEGS]; 3];

/// a × b for six legs at once (nalgebra's component order).
#[inline(always)]
fn cross(a: &Soa3, b: &Soa3) -> Soa3 {
    let mut c = [[0.0; LEGS]; 3];
    for i in 0..LEGS {
        c[0][i] = a[1][i] * b[2][i] - a[2][i] * b[1][i];
        c[1][i] = a[2][i] * b[0][i] - a[0][i] * b[2][i];
        c[2][i] = a[0][i] * b[1][i] - a[1][i] * b[0][i];
    }
    c
}

/// a · b per leg, as nalgebra sums a 3-vector dot product: (x + y) + z.
#[inline(always)]
fn dot(a: &Soa3, b: &Soa3) -> [f64; LEGS] {
    std::array::from_fn(|i| a[0][i] * b[0][i] + a[1][i] * b[1][i] + a[2][i] * b[2][i])
}

/// A 3-vector broadcast to every leg.
#[inline(always)]
fn splat(x: [f64; 3]) -> Soa3 {
    [[x[0]; LEGS], [x[1]; LEGS], [x[2]; LEGS]]
}

/// Row `P` of the mass matrix's upper triangle from the legs' rank-one terms
/// w_i j_i j_iᵀ, summed in leg order.
///
/// Leg by leg, each adding to the whole row, so two columns take one instruction; the
/// row starts at the even column at or left of the diagonal (the extra entry is never
/// read). Summing one column over the legs at a time instead (the terms two legs per
/// instruction, the sum one leg at a time) took 1.2 % more CPU per FMI-free trial
/// (BENCHMARKS.md, round 18).
#[inline(always)]
fn mass_row<const P: usize>(
    u: &mut [f64; 6],
    w: &[f64; LEGS],
    jac_leg: &[[f64; 6]; LEGS],
    transverse: &[f64; LEGS],
    rr_leg: &[[[f64; 6]; 3]; LEGS],
    r_leg: &[[f64; 6]; LEGS],
) {
    let mut row = [0.0_f64; 6];
    for i in 0..LEGS {
        let wj = w[i] * jac_leg[i][P];
        let t: [f64; 6] = std::array::from_fn(|q| wj * jac_leg[i][q]);
        if P >= 3 {
            // The rotational block also gets c (|r|² I − r rᵀ) from each leg, added right
            // after that leg's rank-one term, as the reference does.
            let (a, ra) = (P - 3, r_leg[i][P]);
            let s: [f64; 6] =
                std::array::from_fn(|q| transverse[i] * (rr_leg[i][a][q] - ra * r_leg[i][q]));
            for q in P & !1..6 {
                row[q] += t[q];
                row[q] += s[q];
            }
        } else {
            for q in P & !1..6 {
                row[q] += t[q];
            }
        }
    }
    *u = row;
}

impl Mechanism {
    /// Forward dynamics ν̇ = M⁻¹ (Jᵀ(τ + friction(l̇)) − b), with `tau` the actuator forces.
    ///
    /// Always inlined (its one caller in a trial is the integrators' derivative): returned
    /// through memory, the result's six values were written one by one and read back two at
    /// a time, a load the processor cannot forward from the stores, stalling every RK4
    /// stage; 2.5–3.3 % of the FMI-free trial (BENCHMARKS.md, round 11).
    #[inline(always)]
    pub fn forward_dynamics(
        &self,
        pose: &Pose,
        twist: &Vector6<f64>,
        tau: &Vector6<f64>,
    ) -> Result<Vector6<f64>, DynamicsError> {
        let rot = *pose.q_world.to_rotation_matrix().matrix();
        let p = pose.p_world;

        // Inverse kinematics, paper eqs. (A.14)–(A.16): r = R a (gemv order: columns
        // accumulated left to right), l = (p + r) − b, |l| = √((x² + y²) + z²), n = l / |l|.
        let mut r: Soa3 = [[0.0; LEGS]; 3];
        let mut n: Soa3 = [[0.0; LEGS]; 3];
        let mut length = [0.0; LEGS];
        {
            let a: Soa3 = std::array::from_fn(|k| std::array::from_fn(|i| self.a_platform[i][k]));
            let b: Soa3 = std::array::from_fn(|k| std::array::from_fn(|i| self.b_world[i][k]));
            let mut leg: Soa3 = [[0.0; LEGS]; 3];
            for k in 0..3 {
                for i in 0..LEGS {
                    r[k][i] = rot[(k, 0)] * a[0][i] + rot[(k, 1)] * a[1][i] + rot[(k, 2)] * a[2][i];
                    leg[k][i] = p[k] + r[k][i] - b[k][i];
                }
            }
            for i in 0..LEGS {
                length[i] =
                    (leg[0][i] * leg[0][i] + leg[1][i] * leg[1][i] + leg[2][i] * leg[2][i]).sqrt();
            }
            for k in 0..3 {
                for i in 0..LEGS {
                    n[k][i] = leg[k][i] / length[i];
                }
            }
        }
        // Jacobian rows j_i = [n_i; r_i × n_i].
        let m = cross(&r, &n);
        let jac = [n[0], n[1], n[2], m[0], m[1], m[2]];
        // l̇ = J ν in gemv order (columns of J accumulated left to right).
        let mut leg_rates = [0.0; LEGS];
        for i in 0..LEGS {
            leg_rates[i] = jac[0][i] * twist[0]
                + jac[1][i] * twist[1]
                + jac[2][i] * twist[2]
                + jac[3][i] * twist[3]
                + jac[4][i] * twist[4]
                + jac[5][i] * twist[5];
        }
        // The friction's six libm calls come before the mass matrix, not after its
        // factorisation, where more values are live across them: 3–4.5 % less CPU per
        // trial of the FMI-free floor, same bits (BENCHMARKS.md, round 6).
        let friction = self.params.friction.force6(&leg_rates);

        let inertia_world = self.inertia_world_from(&rot);
        let mass = self.mass_matrix_soa(&r, &length, &jac, &inertia_world);
        // Factor M before the bias: the factorisation is one long chain of dependent
        // square roots and divisions that the processor overlaps with the bias below.
        let factor = Cholesky6::new(&mass);
        let bias = self.bias_soa(&r, &n, &length, twist, &inertia_world);

        let total: [f64; LEGS] = std::array::from_fn(|i| tau[i] + friction[i]);
        // Jᵀ (τ + friction) − b, legs accumulated in order.
        let rhs = Vector6::from_fn(|c, _| {
            let mut s = jac[c][0] * total[0];
            for i in 1..LEGS {
                s += jac[c][i] * total[i];
            }
            s - bias[c]
        });
        match factor.map(|f| f.solve(&rhs)) {
            Some(accel) if accel.iter().all(|x| x.is_finite()) => Ok(accel),
            // The cause, checked only on the failure path: a non-finite state also makes the
            // mass matrix NaN, which alone would read as "not positive definite".
            _ if !(pose.is_finite() && twist.iter().all(|x| x.is_finite())) => {
                Err(DynamicsError::NonFiniteState)
            }
            Some(_) => Err(DynamicsError::NonFiniteAcceleration),
            None => Err(DynamicsError::SingularMass),
        }
    }

    /// [`Mechanism::mass_matrix`] over structure-of-arrays legs (same operations, same order).
    #[inline(always)]
    fn mass_matrix_soa(
        &self,
        r: &Soa3,
        length: &[f64; LEGS],
        jac: &[[f64; LEGS]; 6],
        inertia_world: &Matrix3<f64>,
    ) -> Matrix6<f64> {
        let lp = &self.params.legs;
        let mut transverse = [0.0; LEGS];
        let mut w = [0.0; LEGS];
        let mut rr = [0.0; LEGS];
        for i in 0..LEGS {
            let l = length[i];
            transverse[i] = (lp.cylinder_mass * lp.cylinder_com * lp.cylinder_com
                + lp.cylinder_inertia
                + lp.rod_mass * (l - lp.rod_com) * (l - lp.rod_com)
                + lp.rod_inertia)
                / (l * l);
            w[i] = lp.rod_mass - transverse[i];
            rr[i] = r[0][i] * r[0][i] + r[1][i] * r[1][i] + r[2][i] * r[2][i];
        }
        // Per leg: j_i; r_i behind three zeros, so that column q of the rotational block
        // reads element q; and |r_i|² on the diagonal of that block's row a, else 0 (a table
        // rather than a choice per column in `mass_row`: 0.6 % less CPU per FMI-free trial,
        // round 18).
        let jac_leg: [[f64; 6]; LEGS] = std::array::from_fn(|i| std::array::from_fn(|q| jac[q][i]));
        let r_leg: [[f64; 6]; LEGS] =
            std::array::from_fn(|i| [0.0, 0.0, 0.0, r[0][i], r[1][i], r[2][i]]);
        let rr_leg: [[[f64; 6]; 3]; LEGS] = std::array::from_fn(|i| {
            std::array::from_fn(|a| std::array::from_fn(|q| if q == a + 3 { rr[i] } else { 0.0 }))
        });
        let mut u = [[0.0_f64; 6]; 6];
        // One call per row with the row index a constant, so each row's loops unroll
        // completely and its block test is decided at compile time.
        mass_row::<0>(&mut u[0], &w, &jac_leg, &transverse, &rr_leg, &r_leg);
        mass_row::<1>(&mut u[1], &w, &jac_leg, &transverse, &rr_leg, &r_leg);
        mass_row::<2>(&mut u[2], &w, &jac_leg, &transverse, &rr_leg, &r_leg);
        mass_row::<3>(&mut u[3], &w, &jac_leg, &transverse, &rr_leg, &r_leg);
        mass_row::<4>(&mut u[4], &w, &jac_leg, &transverse, &rr_leg, &r_leg);
        mass_row::<5>(&mut u[5], &w, &jac_leg, &transverse, &rr_leg, &r_leg);
        let mut c_sum = self.params.platform.mass;
        let mut c_r = [0.0; 3];
        for i in 0..LEGS {
            c_sum += transverse[i];
            for k in 0..3 {
                c_r[k] += r[k][i] * transverse[i];
            }
        }
        let mut m = Matrix6::from_fn(|p, q| if p <= q { u[p][q] } else { u[q][p] });
        for k in 0..3 {
            m[(k, k)] += c_sum;
        }
        // −[c_r]× in the top right block, its transpose in the bottom left one.
        let tr = [
            [-0.0, -(-c_r[2]), -c_r[1]],
            [-c_r[2], -0.0, -(-c_r[0])],
            [-(-c_r[1]), -c_r[0], -0.0],
        ];
        for a in 0..3 {
            for b in 0..3 {
                m[(a, 3 + b)] += tr[a][b];
                m[(3 + a, b)] += tr[b][a];
                m[(3 + a, 3 + b)] += inertia_world[(a, b)];
            }
        }
        m
    }

    /// [`Mechanism::bias`] over structure-of-arrays legs: the Newton–Euler residual at
    /// zero acceleration and zero leg force, in the reference's operation order.
    #[inline(always)]
    fn bias_soa(
        &self,
        r: &Soa3,
        n: &Soa3,
        length: &[f64; LEGS],
        twist: &Vector6<f64>,
        inertia_world: &Matrix3<f64>,
    ) -> [f64; 6] {
        let lp = &self.params.legs;
        let g = self.params.gravity;
        let v = [twist[0], twist[1], twist[2]];
        let w = [twist[3], twist[4], twist[5]];
        // The reference evaluates the residual at zero acceleration a = ω̇ = 0. For a finite r
        // its s̈ = (a + ω̇ × r) + ω × (ω × r) adds (0 + ±0) = +0 to ω × (ω × r), which is
        // x + 0.0: −0 becomes +0 and every other x stays. So the products with zero are
        // folded but that one sum is kept, which makes s̈ equal to the reference's by
        // construction rather than by an argument that its zeros' signs never reach the
        // result: one operation per component instead of five, 2.5 % less CPU per
        // FMI-free trial (BENCHMARKS.md, round 18). A non-finite r comes only from a
        // non-finite pose, which fails either way. ṡ = v + ω × r.
        let w_s = splat(w);
        let w_cross_r = cross(&w_s, r);
        let w_cross_w_cross_r = cross(&w_s, &w_cross_r);
        let mut sd: Soa3 = [[0.0; LEGS]; 3];
        let mut sdd: Soa3 = [[0.0; LEGS]; 3];
        for k in 0..3 {
            for i in 0..LEGS {
                sd[k][i] = v[k] + w_cross_r[k][i];
                sdd[k][i] = w_cross_w_cross_r[k][i] + 0.0;
            }
        }
        let ld = dot(n, &sd);
        let n_cross_sdd = cross(n, &sdd);
        let n_cross_sd = cross(n, &sd);
        let sd_sq = dot(&sd, &sd);
        let n_dot_sdd = dot(n, &sdd);
        let inertia_sum = lp.cylinder_mass * lp.cylinder_com * lp.cylinder_com
            + lp.cylinder_inertia
            + lp.rod_inertia;
        let mut f: Soa3 = [[0.0; LEGS]; 3];
        for i in 0..LEGS {
            let l = length[i];
            let w_leg = [0, 1, 2].map(|k| n_cross_sd[k][i] / l);
            let a_leg = [0, 1, 2].map(|k| (n_cross_sdd[k][i] - w_leg[k] * (2.0 * ld[i])) / l);
            let nd_sq = (sd_sq[i] - ld[i] * ld[i]) / (l * l);
            let lever_rod = l - lp.rod_com;
            let k_alpha = inertia_sum - lp.rod_mass * lever_rod * lp.rod_com;
            let k_sdd = lp.rod_mass * lever_rod;
            let k_g = g * (lp.cylinder_mass * lp.cylinder_com + lp.rod_mass * lever_rod);
            let tilt = [n[1][i], -n[0][i], 0.0];
            let n_cross_f = [0, 1, 2]
                .map(|k| (a_leg[k] * k_alpha + n_cross_sdd[k][i] * k_sdd + tilt[k] * k_g) / l);
            let nk = [n[0][i], n[1][i], n[2][i]];
            let f_perp = [
                n_cross_f[1] * nk[2] - n_cross_f[2] * nk[1],
                n_cross_f[2] * nk[0] - n_cross_f[0] * nk[2],
                n_cross_f[0] * nk[1] - n_cross_f[1] * nk[0],
            ];
            // The reference subtracts the leg force τ = 0 here: x − 0 is x to the bit.
            let f_axial = lp.rod_mass * (n_dot_sdd[i] + lp.rod_com * nd_sq + g * nk[2]);
            for k in 0..3 {
                f[k][i] = -(f_perp[k] + nk[k] * f_axial);
            }
        }
        let r_cross_f = cross(r, &f);
        let mass = self.params.platform.mass;
        let mut force = [0.0 * mass, 0.0 * mass, (0.0 + g) * mass];
        // I ω̇ + ω × (I ω) with ω̇ = 0, in gemv order.
        let iw: [f64; 3] = std::array::from_fn(|k| {
            inertia_world[(k, 0)] * w[0]
                + inertia_world[(k, 1)] * w[1]
                + inertia_world[(k, 2)] * w[2]
        });
        let idw: [f64; 3] = std::array::from_fn(|k| {
            inertia_world[(k, 0)] * 0.0 + inertia_world[(k, 1)] * 0.0 + inertia_world[(k, 2)] * 0.0
        });
        let w_cross_iw = [
            w[1] * iw[2] - w[2] * iw[1],
            w[2] * iw[0] - w[0] * iw[2],
            w[0] * iw[1] - w[1] * iw[0],
        ];
        let mut moment: [f64; 3] = std::array::from_fn(|k| idw[k] + w_cross_iw[k]);
        for i in 0..LEGS {
            for k in 0..3 {
                force[k] -= f[k][i];
                moment[k] -= r_cross_f[k][i];
            }
        }
        [
            force[0], force[1], force[2], moment[0], moment[1], moment[2],
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Params;
    use nalgebra::{UnitQuaternion, Vector3};

    /// A small deterministic generator (SplitMix64), so the test needs no RNG crate and
    /// every run sees the same states.
    struct SplitMix(u64);
    impl SplitMix {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^= z >> 31;
            (z >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        }
    }

    /// The fold in `bias_soa`: the reference's (a + ω̇ × r) + x with a = ω̇ = 0 and r finite
    /// is x + 0.0 bit for bit, signed zeros, subnormals and infinities included.
    #[test]
    fn zero_acceleration_term_is_adding_zero() {
        let values = [
            0.0,
            -0.0,
            f64::from_bits(1),
            -f64::from_bits(1),
            1e-300,
            -1.0,
            0.75,
            1e300,
            -1e300,
            f64::MAX,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for &x in &values {
            for &b in values.iter().filter(|v| v.is_finite()) {
                for &c in values.iter().filter(|v| v.is_finite()) {
                    let zero = 0.0_f64;
                    let reference = (zero + (zero * b - zero * c)) + x;
                    assert_eq!(
                        reference.to_bits(),
                        (x + 0.0).to_bits(),
                        "x {x:e}, r {b:e}, {c:e}"
                    );
                }
            }
        }
    }

    #[test]
    fn same_bits_as_the_reference_path() {
        let mech = Mechanism::new(Params::default()).unwrap();
        same_bits_for(&mech, 20_000);
        // Platform joints off the platform's plane (`Mechanism::new` puts them in it), so
        // that every term of r = R a counts.
        let mut below = mech;
        for (i, a) in below.a_platform.iter_mut().enumerate() {
            a.z = -0.02 - 0.005 * i as f64;
        }
        same_bits_for(&below, 2_000);
    }

    fn same_bits_for(mech: &Mechanism, cases: usize) {
        let home = mech.home();
        let mut rng = SplitMix(7);
        for case in 0..cases {
            // Every other case unnormalised: the two paths must agree for any quaternion,
            // though the integrator hands the dynamics normalised ones
            // (`UnitQuaternion::from_quaternion` in `State::from_vector`).
            let q = nalgebra::Quaternion::new(
                1.0 + 0.05 * rng.next(),
                0.1 * rng.next(),
                0.1 * rng.next(),
                0.1 * rng.next(),
            );
            let pose = Pose {
                p_world: home.p_world
                    + Vector3::new(0.05 * rng.next(), 0.05 * rng.next(), 0.05 * rng.next()),
                q_world: if case % 2 == 0 {
                    UnitQuaternion::new_normalize(q)
                } else {
                    UnitQuaternion::new_unchecked(q)
                },
            };
            let scale = if case % 7 == 0 { 0.0 } else { 0.5 };
            let twist = Vector6::from_fn(|_, _| scale * rng.next());
            let tau = Vector6::from_fn(|_, _| 2000.0 * rng.next());
            let t = mech.terms(&pose, &twist);
            let total = tau + mech.friction(&t.leg_rates);
            let rhs = t.jacobian.transpose() * total - t.bias;
            let reference = Cholesky6::new(&t.mass).unwrap().solve(&rhs);
            let ours = mech.forward_dynamics(&pose, &twist, &tau).unwrap();
            for k in 0..6 {
                assert_eq!(
                    ours[k].to_bits(),
                    reference[k].to_bits(),
                    "case {case}, component {k}: {} against {}",
                    ours[k],
                    reference[k]
                );
            }
        }
    }
}
