//! The hybrid learning control scheme (HLCS), sampled (docs/model.md §4, §6).
//!
//! At sample t_n with measured lengths l and rates l̇ and the stored learning input u_k(t_n):
//! e = l_d − l, ė = l̇_d − l̇, I_n = I_{n−1} + e h (paper eq. 10),
//! τ = Kp e + Kd ė + Ki I_n (eq. 9) + u_k (eq. 8) + τ_a (eq. 7, computed in task space with the
//! nominal model), and u_{k+1}(t_n) = u_k(t_n) + Φ e + Γ ė + Ψ I_n (eq. 14).

use nalgebra::Vector6;

use crate::dynamics::DynamicsError;
use crate::kinematics::Mechanism;
use crate::trajectory::Reference;

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

/// Gains plus the two switches of the scheme.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlSettings {
    pub gains: Gains,
    /// Learning on: u_{k+1} = u_k + Φe + Γė + ΨI. Off: the memory is passed through unchanged
    /// (u_{k+1} = u_k; zero from trial 0, i.e. "PID only"). Default on.
    pub learning: bool,
    /// Add the model-based feedforward τ_a. Default on.
    pub feedforward: bool,
}

impl Default for ControlSettings {
    fn default() -> Self {
        Self {
            gains: Gains::default(),
            learning: true,
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
        let g = &self.settings.gains;
        let terms = self.model.terms(&reference.pose, &reference.twist);
        let length_ref = terms.legs.length;
        let velocity_ref = terms.leg_rates;
        let e = length_ref - input.length;
        let ed = velocity_ref - input.velocity;
        let integral = self.integral + e * h;
        let feedforward = if self.settings.feedforward {
            let wrench = terms.mass * reference.accel + terms.bias;
            terms
                .jacobian
                .transpose()
                .lu()
                .solve(&wrench)
                .ok_or(DynamicsError::SingularJacobian)?
        } else {
            Vector6::zeros()
        };
        let force = e * g.kp + ed * g.kd + integral * g.ki + input.memory + feedforward;
        let memory_next = if self.settings.learning {
            input.memory + e * g.phi + ed * g.gamma + integral * g.psi
        } else {
            input.memory
        };
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

    /// Back to the start of a trial.
    pub fn reset(&mut self) {
        self.integral = Vector6::zeros();
    }
}
