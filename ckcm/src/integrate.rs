//! Mechanism state and fixed-step / adaptive integration over one communication interval
//! with the actuator forces held constant.
//!
//! Hand-written rather than `ode_solvers`: that crate stores every accepted step in a `Vec`
//! (a heap allocation per step) and owns the time loop, while the FMU must advance exactly
//! one interval per doStep with no allocation, carrying the adaptive step size across calls.

use nalgebra::{Quaternion, SVector, UnitQuaternion, Vector6};

use crate::dynamics::DynamicsError;
use crate::kinematics::{Mechanism, Pose};
use crate::workspace::WorkspaceError;

/// Position, unit quaternion and world twist of the platform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    pub pose: Pose,
    /// World twist ν = (v, ω): linear velocity of the {A} origin and angular velocity, in {B}.
    pub twist: Vector6<f64>,
}

impl State {
    /// At rest at `pose`.
    pub fn at_rest(pose: Pose) -> Self {
        Self {
            pose,
            twist: Vector6::zeros(),
        }
    }

    fn to_vector(self) -> Y {
        let mut y = Y::zeros();
        y.fixed_rows_mut::<3>(0).copy_from(&self.pose.p_world);
        y.fixed_rows_mut::<4>(3)
            .copy_from(&self.pose.q_world.as_ref().coords);
        y.fixed_rows_mut::<6>(7).copy_from(&self.twist);
        y
    }

    fn from_vector(y: &Y) -> Self {
        let q = Quaternion::from(y.fixed_rows::<4>(3).into_owned());
        Self {
            pose: Pose {
                p_world: y.fixed_rows::<3>(0).into_owned(),
                q_world: UnitQuaternion::from_quaternion(q),
            },
            twist: y.fixed_rows::<6>(7).into_owned(),
        }
    }

    /// Whether every component is finite.
    pub fn is_finite(&self) -> bool {
        self.pose.is_finite() && self.twist.iter().all(|x| x.is_finite())
    }
}

/// Integration state vector: p (3), quaternion coordinates i, j, k, w (4), twist (6).
type Y = SVector<f64, 13>;

/// Integration failure.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum IntegrationError {
    #[error(transparent)]
    Dynamics(#[from] DynamicsError),
    #[error("the state became non-finite (diverged)")]
    NonFinite,
    #[error("adaptive step size fell below {h_min:e} s at t + {offset:e} s")]
    StepTooSmall { h_min: f64, offset: f64 },
    #[error("adaptive integration needed more than {max_steps} steps in one interval")]
    TooManySteps { max_steps: usize },
    /// The message leaves `h` to the caller, who names the step (an absurd `h` would
    /// otherwise be written out in hundreds of digits).
    #[error(
        "the interval needs more than {RK4_MAX_SUBSTEPS:e} RK4 substeps of at most {max_step} s"
    )]
    TooManySubsteps { h: f64, max_step: f64 },
    /// A state inside the interval, `offset` seconds from its start, failed the caller's
    /// check; the message leaves the time to the caller, who knows where the interval began.
    #[error("{cause}")]
    Outside { offset: f64, cause: WorkspaceError },
}

/// The check [`Integrator::advance_within`] makes of every state an interval reaches
/// before its end (substeps of RK4, accepted steps of Dormand–Prince): the caller checks
/// the end itself, where it needs the same work for its outputs. Taken as `dyn`, so the
/// integrators stay compiled once, in this crate, with their helpers inlined: made generic,
/// they were compiled in the plant's crate, which called those helpers out of line
/// (BENCHMARKS.md, round 51).
pub trait Inside {
    fn check(&mut self, state: &State) -> Result<(), WorkspaceError>;
}

impl<F: FnMut(&State) -> Result<(), WorkspaceError>> Inside for F {
    #[inline(always)]
    fn check(&mut self, state: &State) -> Result<(), WorkspaceError> {
        self(state)
    }
}

/// `inside`'s check of the state `y` at `offset` into the interval, out of line: most
/// intervals are one substep and never call it.
#[cold]
#[inline(never)]
fn check_substep(inside: &mut dyn Inside, y: &Y, offset: f64) -> Result<(), IntegrationError> {
    inside
        .check(&State::from_vector(y))
        .map_err(|cause| IntegrationError::Outside { offset, cause })
}

/// No check: every state is accepted.
struct Anywhere;

impl Inside for Anywhere {
    #[inline(always)]
    fn check(&mut self, _: &State) -> Result<(), WorkspaceError> {
        Ok(())
    }
}

/// dy/dt with the actuator forces `tau` held constant.
fn derivative(mech: &Mechanism, y: &Y, tau: &Vector6<f64>) -> Result<Y, DynamicsError> {
    let state = State::from_vector(y);
    let accel = mech.forward_dynamics(&state.pose, &state.twist, tau)?;
    let w = state.twist.fixed_rows::<3>(3).into_owned();
    // q̇ = ½ (0, ω) ⊗ q for the world angular velocity ω, on the raw (unnormalised) coordinates.
    let q = Quaternion::from(y.fixed_rows::<4>(3).into_owned());
    let qd = Quaternion::from_parts(0.0, w) * q * 0.5;
    let mut dy = Y::zeros();
    dy.fixed_rows_mut::<3>(0)
        .copy_from(&state.twist.fixed_rows::<3>(0));
    dy.fixed_rows_mut::<4>(3).copy_from(&qd.coords);
    dy.fixed_rows_mut::<6>(7).copy_from(&accel);
    Ok(dy)
}

fn renormalise(y: &mut Y) {
    let norm = y.fixed_rows::<4>(3).norm();
    y.fixed_rows_mut::<4>(3).unscale_mut(norm);
}

/// Classic fourth-order Runge–Kutta with equal substeps over each interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rk4 {
    /// Fewest substeps per communication interval. Default 1.
    pub substeps: u32,
    /// Longest substep, s: a longer interval is split into ⌈h / max_step⌉ substeps (when
    /// that is more than `substeps`). Default ∞, no limit. RK4 is only conditionally
    /// stable, and the legs' viscous friction makes the model stiff enough that one RK4
    /// step of 10 ms already drifts, so the plant FMU caps it (its `rk4_max_step`).
    pub max_step: f64,
}

impl Default for Rk4 {
    fn default() -> Self {
        Self {
            substeps: 1,
            max_step: f64::INFINITY,
        }
    }
}

/// Most RK4 substeps in one interval, so that a huge interval fails instead of running
/// for hours.
const RK4_MAX_SUBSTEPS: f64 = 1e6;

impl Rk4 {
    /// Substeps for an interval of `h` seconds: `substeps`, or more where `h` exceeds
    /// `max_step`. An interval longer than `max_step` by rounding alone (1e-9 relative,
    /// as a master that adds up its steps makes) is not split.
    pub fn substeps_for(&self, h: f64) -> Result<u32, IntegrationError> {
        let needed = (h / self.max_step * (1.0 - 1e-9)).ceil();
        if needed > RK4_MAX_SUBSTEPS {
            return Err(IntegrationError::TooManySubsteps {
                h,
                max_step: self.max_step,
            });
        }
        // `needed` is in [0, 1e6] here, or NaN (h NaN), which `as` maps to 0.
        Ok(self.substeps.max(needed as u32).max(1))
    }

    /// Advances `state` by `h` seconds with `tau` held constant.
    pub fn advance(
        &self,
        mech: &Mechanism,
        state: &mut State,
        tau: &Vector6<f64>,
        h: f64,
    ) -> Result<(), IntegrationError> {
        self.advance_within(mech, state, tau, h, &mut Anywhere)
    }

    /// [`Rk4::advance`], with `inside` checking the state after each substep but the last.
    pub fn advance_within(
        &self,
        mech: &Mechanism,
        state: &mut State,
        tau: &Vector6<f64>,
        h: f64,
        inside: &mut dyn Inside,
    ) -> Result<(), IntegrationError> {
        let n = self.substeps_for(h)?;
        let dt = h / f64::from(n);
        let mut y = state.to_vector();
        for i in 0..n {
            let k1 = derivative(mech, &y, tau)?;
            let k2 = derivative(mech, &(y + k1 * (dt / 2.0)), tau)?;
            let k3 = derivative(mech, &(y + k2 * (dt / 2.0)), tau)?;
            let k4 = derivative(mech, &(y + k3 * dt), tau)?;
            y += (k1 + (k2 + k3) * 2.0 + k4) * (dt / 6.0);
            renormalise(&mut y);
            if i + 1 != n {
                check_substep(inside, &y, dt * f64::from(i + 1))?;
            }
        }
        let next = State::from_vector(&y);
        if !next.is_finite() {
            return Err(IntegrationError::NonFinite);
        }
        *state = next;
        Ok(())
    }
}

/// Adaptive embedded Dormand–Prince 5(4) with local extrapolation and FSAL.
///
/// The accepted step size is kept between calls (`h_next`), so a long run of 1 ms
/// communication intervals does not restart the step-size search each time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DormandPrince {
    /// Relative tolerance. Default 1e-8.
    pub rtol: f64,
    /// Absolute tolerance (m, quaternion units, m/s, rad/s alike). Default 1e-10.
    pub atol: f64,
    /// Smallest step before giving up, s. Default 1e-12.
    pub h_min: f64,
    /// Most steps in one interval. Default 100 000.
    pub max_steps: usize,
    /// Step size to try first on the next call, s; 0 means "start with the interval".
    pub h_next: f64,
    /// Steps (accepted and rejected) the last successful [`DormandPrince::advance`] took,
    /// so that a caller can tell a user why a run has slowed down. Default 0.
    pub last_steps: usize,
}

impl Default for DormandPrince {
    fn default() -> Self {
        Self {
            rtol: 1e-8,
            atol: 1e-10,
            h_min: 1e-12,
            max_steps: 100_000,
            h_next: 0.0,
            last_steps: 0,
        }
    }
}

// Dormand & Prince (1980) tableau. The system is autonomous, so the nodes c_i are not needed.
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const B1: f64 = 35.0 / 384.0;
const B3: f64 = 500.0 / 1113.0;
const B4: f64 = 125.0 / 192.0;
const B5: f64 = -2187.0 / 6784.0;
const B6: f64 = 11.0 / 84.0;
// Error coefficients: fifth-order minus fourth-order weights.
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;

impl DormandPrince {
    /// Advances `state` by exactly `h` seconds with `tau` held constant.
    pub fn advance(
        &mut self,
        mech: &Mechanism,
        state: &mut State,
        tau: &Vector6<f64>,
        h: f64,
    ) -> Result<(), IntegrationError> {
        self.advance_within(mech, state, tau, h, &mut Anywhere)
    }

    /// [`DormandPrince::advance`], with `inside` checking the state after each accepted
    /// step but the last.
    pub fn advance_within(
        &mut self,
        mech: &Mechanism,
        state: &mut State,
        tau: &Vector6<f64>,
        h: f64,
        inside: &mut dyn Inside,
    ) -> Result<(), IntegrationError> {
        let mut y = state.to_vector();
        let mut offset = 0.0;
        let mut step = if self.h_next > 0.0 {
            self.h_next.min(h)
        } else {
            h
        };
        let mut k1 = derivative(mech, &y, tau)?;
        let mut steps = 0;
        while offset < h {
            steps += 1;
            if steps > self.max_steps {
                return Err(IntegrationError::TooManySteps {
                    max_steps: self.max_steps,
                });
            }
            let remaining = h - offset;
            let last = step >= remaining * (1.0 - 1e-12);
            let dt = if last { remaining } else { step };
            let k2 = derivative(mech, &(y + k1 * (A21 * dt)), tau)?;
            let k3 = derivative(mech, &(y + (k1 * A31 + k2 * A32) * dt), tau)?;
            let k4 = derivative(mech, &(y + (k1 * A41 + k2 * A42 + k3 * A43) * dt), tau)?;
            let k5 = derivative(
                mech,
                &(y + (k1 * A51 + k2 * A52 + k3 * A53 + k4 * A54) * dt),
                tau,
            )?;
            let k6 = derivative(
                mech,
                &(y + (k1 * A61 + k2 * A62 + k3 * A63 + k4 * A64 + k5 * A65) * dt),
                tau,
            )?;
            let y_new = y + (k1 * B1 + k3 * B3 + k4 * B4 + k5 * B5 + k6 * B6) * dt;
            let k7 = derivative(mech, &y_new, tau)?;
            let err_vec = (k1 * E1 + k3 * E3 + k4 * E4 + k5 * E5 + k6 * E6 + k7 * E7) * dt;
            let mut sum = 0.0;
            for i in 0..13 {
                let scale = self.atol + self.rtol * y[i].abs().max(y_new[i].abs());
                sum += (err_vec[i] / scale).powi(2);
            }
            let err = (sum / 13.0).sqrt();
            if !err.is_finite() {
                return Err(IntegrationError::NonFinite);
            }
            let factor = if err == 0.0 {
                5.0
            } else {
                (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
            };
            if err <= 1.0 {
                y = y_new;
                renormalise(&mut y);
                if !last {
                    check_substep(inside, &y, offset + dt)?;
                }
                k1 = if last { k7 } else { derivative(mech, &y, tau)? };
                offset = if last { h } else { offset + dt };
                // Remember the controller's proposal, not the truncated last step.
                if !last || dt >= step {
                    step = dt * factor;
                }
            } else {
                step = dt * factor.min(1.0);
                if step < self.h_min {
                    return Err(IntegrationError::StepTooSmall {
                        h_min: self.h_min,
                        offset,
                    });
                }
            }
        }
        self.h_next = step;
        self.last_steps = steps;
        let next = State::from_vector(&y);
        if !next.is_finite() {
            return Err(IntegrationError::NonFinite);
        }
        *state = next;
        Ok(())
    }
}

/// Either integrator, as an FMU parameter selects it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Integrator {
    Rk4(Rk4),
    DormandPrince(DormandPrince),
}

impl Default for Integrator {
    fn default() -> Self {
        Integrator::Rk4(Rk4::default())
    }
}

impl Integrator {
    /// Advances `state` by `h` with `tau` held constant. `#[inline]`, as `Hlcs::step_terms`
    /// and `Pose::to_xyz_euler`: small, and called every step from other crates (the plant
    /// FMU, the benchmarks' floor), where a call would cross the crate boundary
    /// (BENCHMARKS.md, round 34).
    #[inline]
    pub fn advance(
        &mut self,
        mech: &Mechanism,
        state: &mut State,
        tau: &Vector6<f64>,
        h: f64,
    ) -> Result<(), IntegrationError> {
        self.advance_within(mech, state, tau, h, &mut Anywhere)
    }

    /// [`Integrator::advance`], with `inside` checking every state the interval reaches
    /// before its end, so that whether a path leaves the workspace does not depend on how
    /// long the caller's intervals are.
    #[inline]
    pub fn advance_within(
        &mut self,
        mech: &Mechanism,
        state: &mut State,
        tau: &Vector6<f64>,
        h: f64,
        inside: &mut dyn Inside,
    ) -> Result<(), IntegrationError> {
        match self {
            Integrator::Rk4(rk) => rk.advance_within(mech, state, tau, h, inside),
            Integrator::DormandPrince(dp) => dp.advance_within(mech, state, tau, h, inside),
        }
    }
}
