//! The version-neutral core of an FMU (the role of Reference-FMUs' `model.h`): the safe
//! [`Model`] trait an FMU crate implements, its variable table ([`VarSpec`]), the flat value
//! storage and the byte format of a model's saved state ([`values`]).
//!
//! Nothing here knows a C ABI, a calling sequence or an FMI version's status codes: the export
//! crate (`fmi2-export` today; an FMI 3.0 one could sit beside it) owns those, and a model only
//! sees validated calls: value references it declared, of the right type, set only in states
//! where their causality/variability allows it. The variable vocabulary (causality,
//! variability, base type) is the model description's, which owns it.

#![forbid(unsafe_code)]

pub mod values;

pub use fmi2_md::{Causality, Shown, VarType, Variability, time_spacing};

/// One scalar variable of the model, generated from `modelDescription/<Model>.xml`
/// by the FMU crate's build script so the two never drift apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VarSpec {
    /// Full scalar name, e.g. `force[3]`.
    pub name: &'static str,
    pub value_reference: u32,
    pub var_type: VarType,
    pub causality: Causality,
    pub variability: Variability,
    /// Smallest allowed value (`min` of the model description, for Real, Integer and
    /// Enumeration); the glue refuses anything below it on set and at initialization.
    pub min: Option<f64>,
    /// Largest allowed value (`max`), enforced like `min`.
    pub max: Option<f64>,
}

/// The first variable of `M` whose current value lies outside its declared range, as the
/// message of [`VarSpec::check_range`], or a Real input or parameter that is not finite
/// (which fmi2SetReal refuses). The glue calls it where values arrive without a set call:
/// at fmi2ExitInitializationMode and on fmi2DeSerializeFMUstate.
pub fn check_ranges<M: Model>(model: &M) -> Result<(), String> {
    for spec in M::VARIABLES {
        let value = match spec.var_type {
            VarType::Real => {
                let x = model.get_real(spec.value_reference);
                let settable = matches!(spec.causality, Causality::Input | Causality::Parameter);
                if settable && !x.is_finite() {
                    return Err(format!("{} = {} is not finite", spec.name, Shown(x)));
                }
                x
            }
            VarType::Integer | VarType::Enumeration => {
                f64::from(model.get_integer(spec.value_reference))
            }
            VarType::Boolean | VarType::String => continue,
        };
        spec.check_range(value)?;
    }
    Ok(())
}

impl VarSpec {
    /// Checks `value` against this variable's declared range; NaN is never inside a
    /// declared range. The message names the variable, the value and the range.
    #[inline]
    pub fn check_range(&self, value: f64) -> Result<(), String> {
        if self.min.is_none() && self.max.is_none() {
            return Ok(());
        }
        let below = self.min.is_some_and(|lo| value < lo);
        let above = self.max.is_some_and(|hi| value > hi);
        if value.is_nan() || below || above {
            return Err(self.out_of_range(value));
        }
        Ok(())
    }

    /// The message of a failed [`VarSpec::check_range`], out of line (see there).
    #[cold]
    fn out_of_range(&self, value: f64) -> String {
        let bound =
            |b: Option<f64>, inf: &str| b.map_or_else(|| inf.to_owned(), |x| Shown(x).to_string());
        format!(
            "{} = {} is outside its range [{}, {}]",
            self.name,
            Shown(value),
            bound(self.min, "-inf"),
            bound(self.max, "inf")
        )
    }
}

/// How a model operation failed; the export glue maps it onto its FMI version's status.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Severity {
    /// The step was not taken and the state is unchanged; the master may retry smaller or
    /// stop (fmi2Discard).
    Discard,
    /// The operation failed; the instance cannot continue without a reset or an earlier
    /// state (fmi2Error).
    Error,
}

/// A model-level failure. The glue logs `message` (prefixed with the function name
/// and the instance) and returns the status of `severity` to the master.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelError {
    pub severity: Severity,
    pub message: String,
}

impl ModelError {
    /// An error with the given message.
    pub fn error(message: impl Into<String>) -> Self {
        Self {
            severity: Severity::Error,
            message: message.into(),
        }
    }

    /// A discard with the given message (the step was not taken; the master may retry smaller).
    pub fn discard(message: impl Into<String>) -> Self {
        Self {
            severity: Severity::Discard,
            message: message.into(),
        }
    }
}

/// Result of a model operation.
pub type ModelResult<T> = Result<T, ModelError>;

/// `vrs[at..at + len] == first..first + len` in a batch of value references: the elements
/// of an array variable, which masters pass in order. The glue cuts each batch it accepts
/// into runs once and reuses them while the master passes the same batch, so a model that
/// stores its values by value reference copies a run as one slice rather than looking up
/// each scalar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct VrRun {
    /// Index of the run's first element in the batch.
    pub at: usize,
    /// Its value reference.
    pub first: u32,
    /// Number of elements.
    pub len: usize,
}

impl VrRun {
    /// `vrs` cut into maximal runs, into `runs` (cleared first; its buffer is reused).
    pub fn split(vrs: &[u32], runs: &mut Vec<VrRun>) {
        runs.clear();
        for (at, &vr) in vrs.iter().enumerate() {
            match runs.last_mut() {
                Some(r) if r.first.checked_add(r.len as u32) == Some(vr) => r.len += 1,
                _ => runs.push(VrRun {
                    at,
                    first: vr,
                    len: 1,
                }),
            }
        }
    }
}

/// A co-simulation model behind the FMI 2.0 C ABI.
///
/// `Clone` backs fmi2GetFMUstate/fmi2SetFMUstate; `save`/`restore` back the
/// serialized form (the glue adds a versioned, self-identifying header around it).
pub trait Model: Clone + Send + 'static {
    /// `modelIdentifier` of the CoSimulation element.
    const MODEL_IDENTIFIER: &'static str;
    /// `guid` attribute of the model description; Instantiate rejects any other.
    const GUID: &'static str;
    /// Every scalar variable, from the model description.
    const VARIABLES: &'static [VarSpec];
    /// Whether the model accepts a different communication step size on each doStep.
    const CAN_HANDLE_VARIABLE_STEP: bool;

    /// A model with every variable at its start value.
    fn new() -> Self;

    /// Reads a Real (only called with a declared Real value reference).
    fn get_real(&self, vr: u32) -> f64;
    /// Reads one fmi2GetReal call's values into `out`; `runs` is `vrs` cut by
    /// [`VrRun::split`]. The default reads them one by one; [`values_model!`] copies each
    /// run as one slice.
    fn get_reals(&self, vrs: &[u32], runs: &[VrRun], out: &mut [f64]) {
        let _ = runs;
        for (o, &vr) in out.iter_mut().zip(vrs) {
            *o = self.get_real(vr);
        }
    }
    /// Writes a Real (only called where its causality/variability allows it in the current
    /// state). Rejects invalid values, e.g. non-finite inputs, with a message naming the variable.
    fn set_real(&mut self, vr: u32, value: f64) -> ModelResult<()>;
    /// Writes one fmi2SetReal call's values, each checked as by `set_real`; `runs` is `vrs`
    /// cut by [`VrRun::split`]. The default writes them one by one; [`values_model!`]
    /// checks the whole batch first, so a refused call writes nothing, and then copies each
    /// run as one slice.
    fn set_reals(&mut self, vrs: &[u32], runs: &[VrRun], values: &[f64]) -> ModelResult<()> {
        let _ = runs;
        vrs.iter()
            .zip(values)
            .try_for_each(|(&vr, &value)| self.set_real(vr, value))
    }

    /// Reads an Integer or Enumeration.
    fn get_integer(&self, vr: u32) -> i32 {
        let _ = vr;
        0
    }
    /// Writes an Integer or Enumeration.
    fn set_integer(&mut self, vr: u32, value: i32) -> ModelResult<()> {
        let _ = value;
        Err(ModelError::error(format!(
            "value reference {vr} is not a settable Integer"
        )))
    }
    /// Reads a Boolean.
    fn get_boolean(&self, vr: u32) -> bool {
        let _ = vr;
        false
    }
    /// Writes a Boolean.
    fn set_boolean(&mut self, vr: u32, value: bool) -> ModelResult<()> {
        let _ = value;
        Err(ModelError::error(format!(
            "value reference {vr} is not a settable Boolean"
        )))
    }

    /// Called by fmi2ExitInitializationMode at `start_time`: validate parameters, build
    /// the internal state, and make every output consistent with the inputs at that time.
    ///
    /// Must be idempotent and re-callable: in InitializationMode the glue calls it again
    /// before a get whenever a variable was set since the last call (so outputs read
    /// during initialization are consistent), and always once more at
    /// fmi2ExitInitializationMode. Each call rebuilds the state from the current
    /// parameters and inputs, never from the previous call's result.
    fn initialize(&mut self, start_time: f64) -> ModelResult<()>;

    /// Advances from `t` (the communication point, exactly as the master passed it) by `h > 0`.
    fn do_step(&mut self, t: f64, h: f64) -> ModelResult<()>;

    /// A remark on the step [`Model::do_step`] just took successfully, handed over once:
    /// the glue logs it and returns fmi2Warning from that fmi2DoStep, whose step stands.
    /// For what a user should hear about while the run goes on (e.g. the integrator slowing
    /// to a crawl); called after every successful step, so it must be cheap when there is
    /// nothing to say. The default has nothing to say.
    #[inline]
    fn take_warning(&mut self) -> Option<String> {
        None
    }

    /// Appends the complete dynamic state (parameters included) as plain bytes, pointer-free.
    fn save(&self, out: &mut Vec<u8>);
    /// Rebuilds the state written by `save` (the glue has checked header, model and version).
    fn restore(&mut self, bytes: &[u8]) -> ModelResult<()>;
}

/// The part of an `impl Model` that every FMU here writes the same way, for a model that keeps
/// all its variables in a [`values::Values`] field: the four constants from the generated table
/// module and the typed getters and setters.
///
/// ```ignore
/// impl Model for MyModel {
///     fmu_core::values_model!(md, values); // the generated `md` module, the `Values` field
///     fn new() -> Self { … }
///     // initialize, do_step, save, restore
/// }
/// ```
///
/// A Real that is not finite is refused with an error naming the variable (no model here has a
/// use for NaN or infinities, and they would poison every later step); Integers and Booleans
/// are stored as given, the glue having checked type, settability and declared range.
///
/// `values_model!(md, values, derived = method)` is for outputs that are computed when they
/// are read rather than stored at every step: after the stored values are copied,
/// `fn method(&self, runs: &[VrRun], out: &mut [f64])` overwrites the entries of `out` whose
/// value references it derives (`runs` cut as for [`Model::get_reals`]).
#[macro_export]
macro_rules! values_model {
    ($md:ident, $values:ident) => {
        $crate::values_model!(@common $md, $values);

        fn get_real(&self, vr: u32) -> f64 {
            self.$values.real(vr)
        }

        fn get_reals(&self, vrs: &[u32], runs: &[$crate::VrRun], out: &mut [f64]) {
            self.$values.reals_into(vrs, runs, out)
        }
    };
    ($md:ident, $values:ident, derived = $derived:ident) => {
        $crate::values_model!(@common $md, $values);

        fn get_real(&self, vr: u32) -> f64 {
            let mut out = [self.$values.real(vr)];
            let run = $crate::VrRun {
                at: 0,
                first: vr,
                len: 1,
            };
            self.$derived(&[run], &mut out);
            out[0]
        }

        fn get_reals(&self, vrs: &[u32], runs: &[$crate::VrRun], out: &mut [f64]) {
            self.$values.reals_into(vrs, runs, out);
            self.$derived(runs, out);
        }
    };
    (@common $md:ident, $values:ident) => {
        const MODEL_IDENTIFIER: &'static str = $md::MODEL_IDENTIFIER;
        const GUID: &'static str = $md::GUID;
        const VARIABLES: &'static [$crate::VarSpec] = $md::VARIABLES;
        const CAN_HANDLE_VARIABLE_STEP: bool = $md::CAN_HANDLE_VARIABLE_STEP;

        fn set_real(&mut self, vr: u32, value: f64) -> $crate::ModelResult<()> {
            self.$values.set_finite_real($md::VARIABLES, vr, value)
        }

        fn set_reals(
            &mut self,
            vrs: &[u32],
            runs: &[$crate::VrRun],
            values: &[f64],
        ) -> $crate::ModelResult<()> {
            self.$values
                .set_finite_reals($md::VARIABLES, vrs, runs, values)
        }

        fn get_integer(&self, vr: u32) -> i32 {
            self.$values.integer(vr)
        }

        fn set_integer(&mut self, vr: u32, value: i32) -> $crate::ModelResult<()> {
            self.$values.set_integer(vr, value);
            Ok(())
        }

        fn get_boolean(&self, vr: u32) -> bool {
            self.$values.boolean(vr)
        }

        fn set_boolean(&mut self, vr: u32, value: bool) -> $crate::ModelResult<()> {
            self.$values.set_boolean(vr, value);
            Ok(())
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bounds themselves are inside the range; one double beyond either is not.
    #[test]
    fn a_range_includes_its_bounds() {
        let spec = VarSpec {
            name: "kd",
            value_reference: 0,
            var_type: VarType::Real,
            causality: Causality::Parameter,
            variability: Variability::Tunable,
            min: Some(-2.0),
            max: Some(3.0),
        };
        assert_eq!(spec.check_range(-2.0), Ok(()));
        assert_eq!(spec.check_range(3.0), Ok(()));
        assert!(spec.check_range(f64::next_down(-2.0)).is_err());
        assert!(spec.check_range(f64::next_up(3.0)).is_err());
        assert!(spec.check_range(f64::NAN).is_err());
    }

    /// A range message names an absurd value in a few characters.
    #[test]
    fn out_of_range_message_stays_short() {
        let spec = VarSpec {
            name: "kp",
            value_reference: 0,
            var_type: VarType::Real,
            causality: Causality::Parameter,
            variability: Variability::Tunable,
            min: Some(0.0),
            max: Some(1e7),
        };
        assert_eq!(
            spec.check_range(1e300),
            Err("kp = 1e300 is outside its range [0, 10000000]".to_owned())
        );
    }
}
