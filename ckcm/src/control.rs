//! The hybrid learning control scheme (HLCS), sampled (docs/model.md §4, §6).
//!
//! At sample t_n with measured lengths l and rates l̇ and the stored learning input u_k(t_n):
//! e = l_d − l (paper eq. 10), ė = l̇_d − l̇, I_n = I_{n−1} + e h (our sampling of eq. 9's
//! integral), τ = Kp e + Kd ė + Ki I_n (eq. 9) + u_k (eq. 8) + τ_a (eq. 7, computed in task space with the
//! nominal model), and u_{k+1}(t_n) = u_k(t_n) + Φ e + Γ ė + Ψ I_n (eq. 14).

use nalgebra::Vector6;

use crate::dynamics::DynamicsError;
use crate::kinematics::Mechanism;
use crate::trajectory::{Reference, Trajectory};

/// Controller gains, all scalar (the same for every leg).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Gains {
    /// Proportional feedback gain Kp, N/m. Default 50000 (Table 1).
    pub kp: f64,
    /// Integral feedback gain Ki, N/(m·s). Default 10 (Table 1).
    pub ki: f64,
    /// Derivative feedback gain Kd, N·s/m. Default 850 (Table 1).
    pub kd: f64,
    /// Proportional learning gain Φ, N/m. Default 47728 (Table 1).
    pub phi: f64,
    /// Derivative learning gain Γ, N·s/m. Default 847 (Table 1).
    pub gamma: f64,
    /// Integral learning gain Ψ, N/(m·s); 0 gives PD-type ILC. Default 7.5 (Table 1).
    pub psi: f64,
}

impl Default for Gains {
    fn default() -> Self {
        Self {
            kp: 50000.0,
            ki: 10.0,
            kd: 850.0,
            phi: 47728.0,
            gamma: 847.0,
            psi: 7.5,
        }
    }
}

/// The iterative learning law: the memory u_{k+1}(t_n) a trial leaves for the next one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LearningLaw {
    /// No learning: the memory passes through unchanged (u_{k+1} = u_k; zero from trial 0,
    /// so PID feedback with feedforward only).
    None,
    /// PD-type ILC, the paper's comparison: u_{k+1} = u_k + Φe + Γė.
    PdType,
    /// PID-type ILC, the HLCS: u_{k+1} = u_k + Φe + Γė + ΨI (eq. 14). With Ψ = 0 it equals
    /// the PD-type law.
    PidType,
}

impl LearningLaw {
    /// The FMU's `learning` switch: on is the PID-type law (its Ψ may be 0), off is none.
    pub fn from_switch(learning: bool) -> Self {
        if learning {
            LearningLaw::PidType
        } else {
            LearningLaw::None
        }
    }

    /// u_{k+1} at one sample from u_k, the error e, its rate ė and its integral I.
    #[inline]
    pub fn next_memory(
        self,
        g: &Gains,
        memory: Vector6<f64>,
        e: Vector6<f64>,
        ed: Vector6<f64>,
        integral: Vector6<f64>,
    ) -> Vector6<f64> {
        match self {
            LearningLaw::None => memory,
            LearningLaw::PdType => memory + e * g.phi + ed * g.gamma,
            LearningLaw::PidType => memory + e * g.phi + ed * g.gamma + integral * g.psi,
        }
    }
}

/// Gains, the learning law and the feedforward switch.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlSettings {
    pub gains: Gains,
    /// The learning law. Default PID-type (the HLCS).
    pub learning: LearningLaw,
    /// Add the model-based feedforward τ_a. Default on.
    pub feedforward: bool,
}

impl Default for ControlSettings {
    fn default() -> Self {
        Self {
            gains: Gains::default(),
            learning: LearningLaw::PidType,
            feedforward: true,
        }
    }
}

/// Measurements and memory at one sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlInput {
    /// Measured leg lengths l, m.
    pub length: Vector6<f64>,
    /// Measured leg rates l̇, m/s.
    pub velocity: Vector6<f64>,
    /// Learning input u_k at this sample, N.
    pub memory: Vector6<f64>,
}

/// Everything the controller outputs at one sample.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ControlOutput {
    /// Actuator forces τ, N.
    pub force: Vector6<f64>,
    /// Learning input for the next trial u_{k+1} at this sample, N.
    pub memory_next: Vector6<f64>,
    /// Desired leg lengths l_d, m.
    pub length_ref: Vector6<f64>,
    /// Leg errors e = l_d − l, m.
    pub error: Vector6<f64>,
    /// Feedforward τ_a alone, N (zero when feedforward is off).
    pub feedforward: Vector6<f64>,
}

/// What the law takes from the reference at one sample: the desired leg lengths and rates
/// and the feedforward τ_a. They depend on the reference and the nominal model only, not on
/// the measurements, so every trial can reuse them from a [`ReferenceTable`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceTerms {
    /// Desired leg lengths l_d, m.
    pub length_ref: Vector6<f64>,
    /// Desired leg rates l̇_d = J ẋ_d, m/s.
    pub velocity_ref: Vector6<f64>,
    /// τ_a = J⁻ᵀ (M ẍ_d + b) (eq. 7) with the nominal model, N; zero when not asked for, or
    /// why it could not be computed.
    pub feedforward: Result<Vector6<f64>, DynamicsError>,
}

impl ReferenceTerms {
    /// The terms at `reference` under `model`; τ_a only `with_feedforward` (else zero).
    pub fn new(model: &Mechanism, reference: &Reference, with_feedforward: bool) -> Self {
        let terms = model.terms(&reference.pose, &reference.twist);
        let feedforward = if with_feedforward {
            let wrench = terms.mass * reference.accel + terms.bias;
            terms
                .jacobian
                .transpose()
                .lu()
                .solve(&wrench)
                .ok_or(DynamicsError::SingularJacobian)
        } else {
            Ok(Vector6::zeros())
        };
        Self {
            length_ref: terms.legs.length,
            velocity_ref: terms.leg_rates,
            feedforward,
        }
    }
}

/// [`ReferenceTerms`] of a trajectory at every sample t_n − t_0 of a trial, computed once per
/// nominal model, trajectory, start time and step, and looked up by the exact time
/// (docs/model.md §4). Looking up a time that was not tabulated (another step size, a time
/// off the grid t_0 + n·h, past the trajectory's end) yields `None` and the caller computes
/// the terms itself, so the law's outputs are the same bits with or without the table.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceTable {
    model: Mechanism,
    trajectory: Trajectory,
    start_time: f64,
    h: f64,
    /// t_n − t_0 of each entry, as a master computes it: (t_0 + n·h) − t_0, s.
    times: Vec<f64>,
    terms: Vec<ReferenceTerms>,
}

impl ReferenceTable {
    /// Tabulates n = 0 ..= ⌈T/h⌉ (the whole trajectory of duration T) with τ_a.
    pub fn new(model: &Mechanism, trajectory: &Trajectory, start_time: f64, h: f64) -> Self {
        let samples = if h > 0.0 && h.is_finite() && trajectory.duration.is_finite() {
            (trajectory.duration / h).ceil() as usize + 1
        } else {
            0
        };
        let times: Vec<f64> = (0..samples)
            .map(|n| (start_time + n as f64 * h) - start_time)
            .collect();
        let terms = times
            .iter()
            .map(|&t| ReferenceTerms::new(model, &trajectory.sample(t), true))
            .collect();
        Self {
            model: *model,
            trajectory: *trajectory,
            start_time,
            h,
            times,
            terms,
        }
    }

    /// Whether this table was made for these arguments of [`ReferenceTable::new`].
    pub fn is_for(
        &self,
        model: &Mechanism,
        trajectory: &Trajectory,
        start_time: f64,
        h: f64,
    ) -> bool {
        self.h.to_bits() == h.to_bits()
            && self.start_time.to_bits() == start_time.to_bits()
            && self.trajectory == *trajectory
            && self.model == *model
    }

    /// Step size the table was made for, s.
    pub fn step_size(&self) -> f64 {
        self.h
    }

    /// The terms at `t` s after the start, if `t` is bit for bit a tabulated time.
    #[inline]
    pub fn get(&self, t: f64) -> Option<&ReferenceTerms> {
        let n = (t / self.h).round();
        if !(n >= 0.0 && n < self.times.len() as f64) {
            return None;
        }
        let n = n as usize;
        (self.times[n].to_bits() == t.to_bits()).then(|| &self.terms[n])
    }
}

/// The HLCS with its integral state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hlcs {
    /// The controller's own (nominal) model.
    pub model: Mechanism,
    pub settings: ControlSettings,
    /// Σ_{j≤n} e_j h of the samples committed so far, m·s.
    pub integral: Vector6<f64>,
}

impl Hlcs {
    /// A controller with zero integral.
    pub fn new(model: Mechanism, settings: ControlSettings) -> Self {
        Self {
            model,
            settings,
            integral: Vector6::zeros(),
        }
    }

    /// Evaluates the law at one sample without committing it. `h` is the sample period that
    /// this sample's error is integrated over: the doStep size, or 0 for a preview of the
    /// output before the first step (integral of past samples only).
    pub fn evaluate(
        &self,
        reference: &Reference,
        input: &ControlInput,
        h: f64,
    ) -> Result<(ControlOutput, Vector6<f64>), DynamicsError> {
        let terms = ReferenceTerms::new(&self.model, reference, self.settings.feedforward);
        self.evaluate_terms(&terms, input, h)
    }

    /// [`Hlcs::evaluate`] from the reference's terms (computed with this controller's model,
    /// e.g. looked up in a [`ReferenceTable`]).
    #[inline]
    pub fn evaluate_terms(
        &self,
        terms: &ReferenceTerms,
        input: &ControlInput,
        h: f64,
    ) -> Result<(ControlOutput, Vector6<f64>), DynamicsError> {
        let g = &self.settings.gains;
        let length_ref = terms.length_ref;
        let e = length_ref - input.length;
        let ed = terms.velocity_ref - input.velocity;
        let integral = self.integral + e * h;
        let feedforward = if self.settings.feedforward {
            terms.feedforward?
        } else {
            Vector6::zeros()
        };
        let force = e * g.kp + ed * g.kd + integral * g.ki + input.memory + feedforward;
        let memory_next = self
            .settings
            .learning
            .next_memory(g, input.memory, e, ed, integral);
        Ok((
            ControlOutput {
                force,
                memory_next,
                length_ref,
                error: e,
                feedforward,
            },
            integral,
        ))
    }

    /// Evaluates the law at sample t_n with period `h` and commits the integral.
    pub fn step(
        &mut self,
        reference: &Reference,
        input: &ControlInput,
        h: f64,
    ) -> Result<ControlOutput, DynamicsError> {
        let (out, integral) = self.evaluate(reference, input, h)?;
        self.integral = integral;
        Ok(out)
    }

    /// [`Hlcs::step`] from the reference's terms.
    #[inline]
    pub fn step_terms(
        &mut self,
        terms: &ReferenceTerms,
        input: &ControlInput,
        h: f64,
    ) -> Result<ControlOutput, DynamicsError> {
        let (out, integral) = self.evaluate_terms(terms, input, h)?;
        self.integral = integral;
        Ok(out)
    }

    /// Back to the start of a trial.
    pub fn reset(&mut self) {
        self.integral = Vector6::zeros();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_learning_law_adds_its_own_terms() {
        let g = Gains {
            phi: 2.0,
            gamma: 3.0,
            psi: 5.0,
            ..Gains::default()
        };
        let v = |x: f64| Vector6::repeat(x);
        let (u, e, ed, i) = (v(1.0), v(10.0), v(100.0), v(1000.0));
        assert_eq!(LearningLaw::None.next_memory(&g, u, e, ed, i), v(1.0));
        assert_eq!(LearningLaw::PdType.next_memory(&g, u, e, ed, i), v(321.0));
        assert_eq!(LearningLaw::PidType.next_memory(&g, u, e, ed, i), v(5321.0));
        let pd = Gains { psi: 0.0, ..g };
        assert_eq!(
            LearningLaw::PidType.next_memory(&pd, u, e, ed, i),
            LearningLaw::PdType.next_memory(&pd, u, e, ed, i)
        );
        assert_eq!(LearningLaw::from_switch(true), LearningLaw::PidType);
        assert_eq!(LearningLaw::from_switch(false), LearningLaw::None);
    }
}
