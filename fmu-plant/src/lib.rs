//! CkcmPlant: the 6-DOF closed-kinematic-chain manipulator as an FMI 2.0 co-simulation FMU.
//!
//! Actuator forces come in and are held over each communication step; the rigid-body
//! model of `ckcm` is integrated over the step (RK4 with substeps, or adaptive
//! Dormand–Prince); leg lengths, leg rates and the platform pose go out. The reported
//! lengths and rates may carry seeded sensor noise (docs/model.md §10); the noise-free
//! values stay observable as `length_true` and `velocity_true`.
// Only the export macro of `fmi2-export` may bring unsafe code in (it allows it explicitly).
#![deny(unsafe_code)]

use ckcm::nalgebra::Vector6;
use ckcm::{
    DormandPrince, FrictionCurve, IntegrationError, Integrator, LegGeometry, Mechanism, Params,
    Pose, Rk4, State, Workspace,
};
use fmu_core::values::{ByteReader, ByteWriter, Values};
use fmu_core::{Causality, Model, ModelError, ModelResult, Shown, VarSpec, VarType, VrRun};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

/// Generated from `modelDescription/CkcmPlant.xml` by the build script.
pub mod md {
    // The table spells the XML's bounds as written there (±1.5707963267948966 rad).
    #![allow(clippy::approx_constant)]
    include!(concat!(env!("OUT_DIR"), "/model_description.rs"));
}
use md::enums::{
    FRICTION_CURVE_ALGEBRAIC, FRICTION_CURVE_ITEMS, FRICTION_CURVE_TANH, INTEGRATOR_DORMAND_PRINCE,
    INTEGRATOR_ITEMS, INTEGRATOR_RK4,
};
use md::vr;

/// The Real parameters the plant reads itself (initial pose, integrator tolerances,
/// workspace, sensor noise); every other Real parameter is a mechanism parameter.
const OWN_PARAMETERS: [u32; 13] = [
    vr::INITIAL_POSE_1,
    vr::INITIAL_POSE_2,
    vr::INITIAL_POSE_3,
    vr::INITIAL_POSE_4,
    vr::INITIAL_POSE_5,
    vr::INITIAL_POSE_6,
    vr::RELATIVE_TOLERANCE,
    vr::ABSOLUTE_TOLERANCE,
    vr::RK4_MAX_STEP,
    vr::LENGTH_MIN,
    vr::LENGTH_MAX,
    vr::LENGTH_NOISE_SIGMA,
    vr::VELOCITY_NOISE_SIGMA,
];

/// Mechanism parameters from the Real parameters among `variables` (names as in
/// `ckcm::Params::set_field`). One that is neither among [`OWN_PARAMETERS`] nor a mechanism
/// field is an error naming it: a parameter renamed in the XML alone must not keep its
/// default.
fn mechanism_params(variables: &[VarSpec], values: &Values) -> ModelResult<Params> {
    let mut p = Params::default();
    for v in variables {
        if v.causality == Causality::Parameter
            && v.var_type == VarType::Real
            && !OWN_PARAMETERS.contains(&v.value_reference)
        {
            p.set_field(v.name, values.real(v.value_reference))
                .map_err(|e| ModelError::error(e.to_string()))?;
        }
    }
    Ok(p)
}

/// The plant: variable values plus, once initialised, the simulated mechanism.
#[derive(Debug, Clone)]
pub struct CkcmPlant {
    values: Values,
    sim: Option<Sim>,
    /// A remark on the last step, for [`Model::take_warning`].
    warning: Option<String>,
}

#[derive(Debug, Clone)]
struct Sim {
    mechanism: Mechanism,
    integrator: Integrator,
    workspace: Workspace,
    state: State,
    noise: Noise,
    /// Index of the current communication point: 0 after initialization, +1 per doStep.
    /// The noise is drawn from it (not from the time), so it survives any step size.
    point: u64,
    /// Whether the adaptive integrator's slowness has been reported (once per
    /// initialization, so that a slow run is not also a flood of messages).
    slow_reported: bool,
}

/// Seeded white Gaussian sensor noise on the reported lengths and rates (docs/model.md §10).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Noise {
    /// σ of the noise on each `length[i]`, m (default 0: none).
    sigma_length_m: f64,
    /// σ of the noise on each `velocity[i]`, m/s (default 0: none).
    sigma_velocity_mps: f64,
    /// `noise_seed` (default 0).
    seed: i32,
}

/// ChaCha words reserved for one channel's draw at one communication point: the ziggurat
/// of `StandardNormal` takes two words per attempt and rarely needs a second attempt, so
/// 256 words keep the channels' draws apart.
const WORDS_PER_CHANNEL: u128 = 256;

impl Noise {
    /// Standard normal value of `channel` (0–5 the lengths of legs 1–6, 6–11 their rates) at
    /// communication point `point`: a pure function of (seed, point, channel). Counter-based
    /// rather than a running generator, so repeated gets, FMU state restore and resumed
    /// campaigns see the same value without replaying any history. The ChaCha8 key is the
    /// seed as a little-endian u64 followed by zeros, the stream is the point index and the
    /// word position is the channel's block.
    fn standard_normal(&self, point: u64, channel: u32) -> f64 {
        let mut key = [0u8; 32];
        key[..8].copy_from_slice(&i64::from(self.seed).to_le_bytes());
        let mut rng = ChaCha8Rng::from_seed(key);
        rng.set_stream(point);
        rng.set_word_pos(u128::from(channel) * WORDS_PER_CHANNEL);
        StandardNormal.sample(&mut rng)
    }

    /// Adds σ·n to each value; σ = 0 leaves the values untouched (bit for bit). The test
    /// is inlined into every step; the draws are not.
    #[inline]
    fn add(&self, values: &mut [f64], sigma: f64, point: u64, first_channel: u32) {
        if sigma != 0.0 {
            self.add_draws(values, sigma, point, first_channel);
        }
    }

    #[inline(never)]
    fn add_draws(&self, values: &mut [f64], sigma: f64, point: u64, first_channel: u32) {
        for (i, x) in values.iter_mut().enumerate() {
            *x += sigma * self.standard_normal(point, first_channel + i as u32);
        }
    }
}

impl Sim {
    /// Checks `state` against the workspace (strokes, base plane, finiteness); its leg
    /// geometry, which the outputs need too.
    fn check(&self, state: &State) -> Result<LegGeometry, ckcm::WorkspaceError> {
        let legs = self.mechanism.inverse_kinematics(&state.pose);
        self.check_legs(state, &legs)?;
        Ok(legs)
    }

    /// [`Sim::check`] with the leg geometry `legs` of `state` already at hand.
    fn check_legs(&self, state: &State, legs: &LegGeometry) -> Result<(), ckcm::WorkspaceError> {
        let twist_finite = state.twist.iter().all(|x| x.is_finite());
        self.workspace.check(&state.pose, twist_finite, legs)
    }
}

impl CkcmPlant {
    /// The mechanism: the Real mechanism parameters and the `friction_curve` enumeration.
    fn params(&self) -> ModelResult<Params> {
        let mut p = mechanism_params(md::VARIABLES, &self.values)?;
        p.friction.curve = match self.values.integer(vr::FRICTION_CURVE) {
            FRICTION_CURVE_TANH => FrictionCurve::Tanh,
            FRICTION_CURVE_ALGEBRAIC => FrictionCurve::Algebraic,
            other => {
                return Err(ModelError::error(format!(
                    "friction_curve = {other} is not a FrictionCurve item ({FRICTION_CURVE_ITEMS})"
                )));
            }
        };
        Ok(p)
    }

    fn integrator(&self) -> ModelResult<Integrator> {
        match self.values.integer(vr::INTEGRATOR) {
            INTEGRATOR_RK4 => {
                let substeps = self.values.integer(vr::SUBSTEPS);
                if substeps < 1 {
                    return Err(ModelError::error(format!(
                        "substeps = {substeps} must be at least 1"
                    )));
                }
                let max_step = self.values.real(vr::RK4_MAX_STEP);
                if !(max_step.is_finite() && max_step > 0.0) {
                    return Err(ModelError::error(format!(
                        "rk4_max_step = {max_step} s must be positive"
                    )));
                }
                Ok(Integrator::Rk4(Rk4 {
                    substeps: substeps as u32,
                    max_step,
                }))
            }
            INTEGRATOR_DORMAND_PRINCE => {
                let rtol = self.values.real(vr::RELATIVE_TOLERANCE);
                let atol = self.values.real(vr::ABSOLUTE_TOLERANCE);
                for (n, x) in [("relative_tolerance", rtol), ("absolute_tolerance", atol)] {
                    if !(x.is_finite() && x > 0.0) {
                        return Err(ModelError::error(format!(
                            "{n} = {} must be positive",
                            Shown(x)
                        )));
                    }
                }
                Ok(Integrator::DormandPrince(DormandPrince {
                    rtol,
                    atol,
                    ..Default::default()
                }))
            }
            other => Err(ModelError::error(format!(
                "integrator = {other} is not an Integrator item ({INTEGRATOR_ITEMS})"
            ))),
        }
    }

    fn noise(&self) -> ModelResult<Noise> {
        let noise = Noise {
            sigma_length_m: self.values.real(vr::LENGTH_NOISE_SIGMA),
            sigma_velocity_mps: self.values.real(vr::VELOCITY_NOISE_SIGMA),
            seed: self.values.integer(vr::NOISE_SEED),
        };
        for (n, x) in [
            ("length_noise_sigma", noise.sigma_length_m),
            ("velocity_noise_sigma", noise.sigma_velocity_mps),
        ] {
            if x < 0.0 {
                return Err(ModelError::error(format!(
                    "{n} = {} must not be negative",
                    Shown(x)
                )));
            }
        }
        if noise.seed < 0 {
            return Err(ModelError::error(format!(
                "noise_seed = {} must not be negative",
                noise.seed
            )));
        }
        Ok(noise)
    }

    fn build(&self) -> ModelResult<Sim> {
        let mechanism =
            Mechanism::new(self.params()?).map_err(|e| ModelError::error(e.to_string()))?;
        let workspace = Workspace {
            length_min: self.values.real(vr::LENGTH_MIN),
            length_max: self.values.real(vr::LENGTH_MAX),
        };
        workspace
            .validate()
            .map_err(|e| ModelError::error(e.to_string()))?;
        let offset = self.values.real6(vr::INITIAL_POSE_1);
        let mut initial = offset;
        initial[2] += mechanism.params.geometry.home_height;
        Ok(Sim {
            mechanism,
            integrator: self.integrator()?,
            workspace,
            state: State::at_rest(Pose::from_xyz_euler(&initial)),
            noise: self.noise()?,
            point: 0,
            slow_reported: false,
        })
    }

    fn write_outputs(&mut self) {
        let Some(sim) = &self.sim else { return };
        let legs = sim.mechanism.inverse_kinematics(&sim.state.pose);
        self.write_outputs_from(&legs);
    }

    /// The outputs from the current state's leg geometry.
    fn write_outputs_from(&mut self, legs: &LegGeometry) {
        let Some(sim) = &self.sim else { return };
        let rates = legs.leg_rates(&sim.state.twist);
        let position = sim.state.pose.p_world;
        let mut length: [f64; 6] = legs.length.into();
        let mut velocity: [f64; 6] = rates.into();
        self.values.set_real6(vr::LENGTH_TRUE_1, &length);
        self.values.set_real6(vr::VELOCITY_TRUE_1, &velocity);
        let noise = sim.noise;
        noise.add(&mut length, noise.sigma_length_m, sim.point, 0);
        noise.add(&mut velocity, noise.sigma_velocity_mps, sim.point, 6);
        self.values.set_real6(vr::LENGTH_1, &length);
        self.values.set_real6(vr::VELOCITY_1, &velocity);
        self.values
            .set_reals_at(vr::POSE_1, &[position.x, position.y, position.z]);
    }

    /// The pose's Euler angles `pose[4..6]`, from the current state when a master reads
    /// them: a master that taps only the position (as the metrics do) saves their libm
    /// calls of every step (BENCHMARKS.md, round 30). Before initialization they read as
    /// stored.
    fn derived_reals(&self, runs: &[VrRun], out: &mut [f64]) {
        let Some(sim) = &self.sim else { return };
        // Most reads (the coupling's) ask for none of them: one comparison per run.
        let angles = |r: &VrRun| {
            r.first <= vr::POSE_6 && u64::from(r.first) + r.len as u64 > u64::from(vr::POSE_4)
        };
        if runs.iter().any(angles) {
            let [.., alpha, beta, gamma] = sim.state.pose.to_xyz_euler();
            for r in runs.iter().filter(|r| angles(r)) {
                for (vr, value) in (vr::POSE_4..).zip([alpha, beta, gamma]) {
                    if let Some(i) = vr.checked_sub(r.first).filter(|&i| (i as usize) < r.len) {
                        out[r.at + i as usize] = value;
                    }
                }
            }
        }
    }
}

/// An interval that takes the adaptive integrator this many steps or more is reported. A
/// 1 ms interval of the paper's trials takes 2–15; at the smallest `friction_velocity`
/// (10⁻⁶ m/s) the smoothed Coulomb friction makes the motion so stiff that one takes
/// about 2,900 and a 15 s trial minutes. The user then hears why, long before
/// `max_steps` refuses a step.
const SLOW_STEPS: usize = 1_000;

/// The warning for an interval that took `dp` [`DormandPrince::last_steps`] steps.
#[cold]
#[inline(never)]
fn slow_integration(dp: &DormandPrince) -> String {
    format!(
        "the adaptive integrator took {} steps in this interval ({SLOW_STEPS} or more make \
         a run slow; at {} it refuses a step). The motion is stiff (a small \
         friction_velocity or a large viscous_friction makes it so) or relative_tolerance = \
         {} and absolute_tolerance = {} are tight (reported once per initialization)",
        dp.last_steps,
        dp.max_steps,
        Shown(dp.rtol),
        Shown(dp.atol)
    )
}

/// The Discard of a step from `t` by `h` under `force` that is refused for `cause`. Out of
/// line and cold: formatted in place, the message's code sat between the step's own
/// (BENCHMARKS.md, round 33).
#[cold]
#[inline(never)]
fn refused(t: f64, h: f64, force: &Vector6<f64>, cause: std::fmt::Arguments<'_>) -> ModelError {
    ModelError::discard(format!(
        "the step from t = {} s by {} s under force = {:?} N is refused: {cause}",
        Shown(t),
        Shown(h),
        force.as_slice()
    ))
}

impl Model for CkcmPlant {
    fmu_core::values_model!(md, values, derived = derived_reals);

    fn new() -> Self {
        Self {
            values: Values::for_variables(md::START, md::VARIABLES),
            sim: None,
            warning: None,
        }
    }

    fn initialize(&mut self, start_time: f64) -> ModelResult<()> {
        let sim = self.build()?;
        // A geometry whose home or initial pose lies outside the workspace (or whose leg
        // lengths overflow) cannot be simulated: an error here, not outputs of inf.
        sim.check(&sim.state).map_err(|e| {
            ModelError::error(format!(
                "the initial pose (home_height + initial_pose) is outside the workspace: \
                 at t = {} s {e}",
                Shown(start_time)
            ))
        })?;
        self.sim = Some(sim);
        self.write_outputs();
        Ok(())
    }

    /// Integrates a copy of the state and commits it only if it stays in the workspace:
    /// a step that leaves it (or whose integration fails) is discarded, the outputs keep
    /// the last accepted state, and the message names the cause and the time.
    fn do_step(&mut self, t: f64, h: f64) -> ModelResult<()> {
        let force = Vector6::from_row_slice(&self.values.real6(vr::FORCE_1));
        let sim = self
            .sim
            .as_mut()
            .ok_or_else(|| ModelError::error("doStep before initialization"))?;
        let mut next = sim.state;
        let mut integrator = sim.integrator;
        // Every substep's state is checked, not only the step's end: a leg that leaves its
        // stroke and comes back within one long step is refused as within 1 ms steps.
        let mut inside = |s: &State| sim.check(s).map(drop);
        let advanced = integrator.advance_within(&sim.mechanism, &mut next, &force, h, &mut inside);
        let end = t + h;
        // The leg geometry stays where it is computed and is checked by reference. Moved
        // out through the check's Result it was copied (552 bytes) right before the outputs
        // read it, and those reads waited on the copy's stores.
        let legs = sim.mechanism.inverse_kinematics(&next.pose);
        // An integration failure other than leaving the workspace happens somewhere inside
        // the step, so it gets no time of its own beyond the step's.
        match advanced {
            Ok(()) => {}
            Err(IntegrationError::Outside { offset, cause }) => {
                let at = Shown(t + offset);
                return Err(refused(t, h, &force, format_args!("at t = {at} s {cause}")));
            }
            Err(e) => return Err(refused(t, h, &force, format_args!("{e}"))),
        }
        if let Err(e) = sim.check_legs(&next, &legs) {
            return Err(refused(
                t,
                h,
                &force,
                format_args!("at t = {} s {e}", Shown(end)),
            ));
        }
        sim.state = next;
        sim.integrator = integrator;
        sim.point += 1;
        if let Integrator::DormandPrince(dp) = &integrator {
            if dp.last_steps >= SLOW_STEPS && !sim.slow_reported {
                sim.slow_reported = true;
                self.warning = Some(slow_integration(dp));
            }
        }
        self.write_outputs_from(&legs);
        Ok(())
    }

    fn take_warning(&mut self) -> Option<String> {
        self.warning.take()
    }

    fn save(&self, out: &mut Vec<u8>) {
        let mut w = ByteWriter(out);
        self.values.save(&mut w);
        match &self.sim {
            None => w.u8(0),
            Some(sim) => {
                w.u8(1);
                w.f64s(sim.state.pose.p_world.as_slice());
                w.f64s(sim.state.pose.q_world.coords.as_slice());
                w.f64s(sim.state.twist.as_slice());
                w.f64(match sim.integrator {
                    Integrator::DormandPrince(dp) => dp.h_next,
                    Integrator::Rk4(_) => 0.0,
                });
                w.u64(sim.point);
            }
        }
    }

    fn restore(&mut self, bytes: &[u8]) -> ModelResult<()> {
        let mut r = ByteReader(bytes);
        let mut restored = Self {
            values: Values::default(),
            sim: None,
            warning: None,
        };
        restored.values.restore(&mut r)?;
        if r.u8()? == 1 {
            let mut sim = restored.build()?;
            let mut buf = [0.0; 14];
            r.f64s(&mut buf)?;
            sim.state.pose.p_world = ckcm::nalgebra::Vector3::new(buf[0], buf[1], buf[2]);
            sim.state.pose.q_world = ckcm::nalgebra::UnitQuaternion::new_unchecked(
                ckcm::nalgebra::Quaternion::new(buf[6], buf[3], buf[4], buf[5]),
            );
            sim.state.twist = Vector6::from_row_slice(&buf[7..13]);
            if let Integrator::DormandPrince(dp) = &mut sim.integrator {
                dp.h_next = buf[13];
            }
            sim.point = r.u64()?;
            // A state this plant could have reached: finite, a unit quaternion, inside the
            // workspace, a usable step-size proposal.
            let norm = sim.state.pose.q_world.coords.norm();
            if !((norm - 1.0).abs() < 1e-9 && buf[13].is_finite() && buf[13] >= 0.0) {
                return Err(ModelError::error(format!(
                    "saved plant state is invalid: orientation quaternion norm {norm}, \
                     step-size proposal {} s",
                    buf[13]
                )));
            }
            sim.check(&sim.state)
                .map_err(|e| ModelError::error(format!("saved plant state is invalid: {e}")))?;
            restored.sim = Some(sim);
        }
        r.finish()?;
        *self = restored;
        Ok(())
    }
}

fmi2_export::export_fmu!(CkcmPlant);

#[cfg(test)]
mod tests {
    use super::*;

    /// A parameter of the XML that is no mechanism field and not read by the plant itself
    /// (here `rod_mass` renamed) stops initialization with a message naming it.
    #[test]
    fn an_unknown_real_parameter_is_an_error_naming_it() {
        let values = Values::for_variables(md::START, md::VARIABLES);
        let mut renamed: Vec<VarSpec> = md::VARIABLES.to_vec();
        let rod = renamed
            .iter_mut()
            .find(|v| v.value_reference == vr::ROD_MASS)
            .unwrap();
        rod.name = "rod_mass_kg";
        let e = mechanism_params(&renamed, &values).unwrap_err();
        assert_eq!(e.severity, fmu_core::Severity::Error);
        assert!(
            e.message
                .starts_with("parameter `rod_mass_kg` is not a mechanism parameter"),
            "{}",
            e.message
        );
        let p = mechanism_params(md::VARIABLES, &values).unwrap();
        assert_eq!(
            p,
            Params::default(),
            "the XML's start values are the defaults"
        );
    }
}
