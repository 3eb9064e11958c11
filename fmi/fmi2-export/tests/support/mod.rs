//! Shared test fixtures of the export-glue tests: a small damped-oscillator model, a
//! capturing logger, and a harness that drives one instance through the generic ABI
//! wrappers (the same functions `export_fmu!` forwards to).

// Each test binary uses a different subset of these helpers.
#![allow(dead_code)]

use std::ffi::{CStr, CString, c_char, c_int, c_void};
use std::ptr;
use std::sync::{Arc, Mutex, PoisonError};

use fmi2_export::abi;
use fmi2_export::{FmiState, Function};
use fmi2_sys::Status;
use fmi2_sys::{
    FMI2_CO_SIMULATION, Fmi2Boolean, Fmi2CallbackFunctions, Fmi2CallbackLogger, Fmi2Component,
    Fmi2FmuState, Fmi2Status, status_kind,
};
use fmu_core::{Causality, Model, ModelError, ModelResult, VarSpec, VarType, Variability};

/// Value references of the test model.
pub mod vr {
    pub const TIME: u32 = 0;
    pub const X: u32 = 1;
    pub const V: u32 = 2;
    pub const FORCE: u32 = 3;
    pub const MASS: u32 = 4;
    pub const DAMPING: u32 = 5;
    pub const STIFFNESS: u32 = 6;
    pub const X0: u32 = 7;
    pub const OMEGA: u32 = 8;
    pub const ACCEL: u32 = 9;
    pub const UNIT: u32 = 10;
    pub const SUBSTEPS: u32 = 11;
    pub const STEP_COUNT: u32 = 12;
    pub const FAIL_MODE: u32 = 13;
    pub const BRAKE: u32 = 14;
    pub const AT_REST: u32 = 15;
}

/// Values of the `fail_mode` enumeration.
pub mod fail {
    pub const NONE: i32 = 0;
    pub const DISCARD: i32 = 1;
    pub const ERROR: i32 = 2;
    pub const PANIC: i32 = 3;
    /// The step is taken, with a warning ([`fmu_core::Model::take_warning`]).
    pub const WARN: i32 = 4;
}

pub const GUID: &str = "{5f1c2e7a-0d3b-4c8e-9a61-oscillator-test}";

const fn var(
    name: &'static str,
    value_reference: u32,
    var_type: VarType,
    causality: Causality,
    variability: Variability,
) -> VarSpec {
    VarSpec {
        name,
        value_reference,
        var_type,
        causality,
        variability,
        min: None,
        max: None,
    }
}

/// m ẍ = force − (damping + brake·10) ẋ − stiffness x, semi-implicit Euler with
/// `substeps` substeps per communication step. `fail_mode` makes the next step
/// discard, fail or panic on demand.
#[derive(Debug, Clone, PartialEq)]
pub struct Oscillator {
    time: f64,
    x: f64,
    v: f64,
    force: f64,
    mass: f64,
    damping: f64,
    stiffness: f64,
    x0: f64,
    omega: f64,
    accel: f64,
    substeps: i32,
    step_count: i32,
    fail_mode: i32,
    brake: bool,
}

impl Oscillator {
    fn damping_now(&self) -> f64 {
        self.damping + if self.brake { 10.0 } else { 0.0 }
    }

    fn acceleration(&self) -> f64 {
        (self.force - self.damping_now() * self.v - self.stiffness * self.x) / self.mass
    }
}

impl Model for Oscillator {
    const MODEL_IDENTIFIER: &'static str = "Oscillator";
    const GUID: &'static str = GUID;
    const VARIABLES: &'static [VarSpec] = &[
        var(
            "time",
            vr::TIME,
            VarType::Real,
            Causality::Independent,
            Variability::Continuous,
        ),
        var(
            "x",
            vr::X,
            VarType::Real,
            Causality::Output,
            Variability::Continuous,
        ),
        var(
            "v",
            vr::V,
            VarType::Real,
            Causality::Output,
            Variability::Continuous,
        ),
        var(
            "force",
            vr::FORCE,
            VarType::Real,
            Causality::Input,
            Variability::Continuous,
        ),
        var(
            "mass",
            vr::MASS,
            VarType::Real,
            Causality::Parameter,
            Variability::Fixed,
        ),
        // A lower bound alone: the glue must check a bound that comes without its partner.
        VarSpec {
            min: Some(0.0),
            ..var(
                "damping",
                vr::DAMPING,
                VarType::Real,
                Causality::Parameter,
                Variability::Tunable,
            )
        },
        var(
            "stiffness",
            vr::STIFFNESS,
            VarType::Real,
            Causality::Parameter,
            Variability::Tunable,
        ),
        var(
            "x0",
            vr::X0,
            VarType::Real,
            Causality::Parameter,
            Variability::Fixed,
        ),
        var(
            "omega",
            vr::OMEGA,
            VarType::Real,
            Causality::CalculatedParameter,
            Variability::Fixed,
        ),
        var(
            "accel",
            vr::ACCEL,
            VarType::Real,
            Causality::Local,
            Variability::Continuous,
        ),
        var(
            "unit",
            vr::UNIT,
            VarType::Real,
            Causality::Local,
            Variability::Constant,
        ),
        var(
            "substeps",
            vr::SUBSTEPS,
            VarType::Integer,
            Causality::Parameter,
            Variability::Fixed,
        ),
        var(
            "step_count",
            vr::STEP_COUNT,
            VarType::Integer,
            Causality::Output,
            Variability::Discrete,
        ),
        var(
            "fail_mode",
            vr::FAIL_MODE,
            VarType::Enumeration,
            Causality::Parameter,
            Variability::Tunable,
        ),
        var(
            "brake",
            vr::BRAKE,
            VarType::Boolean,
            Causality::Input,
            Variability::Discrete,
        ),
        var(
            "at_rest",
            vr::AT_REST,
            VarType::Boolean,
            Causality::Output,
            Variability::Discrete,
        ),
    ];
    const CAN_HANDLE_VARIABLE_STEP: bool = false;

    fn new() -> Self {
        Self {
            time: 0.0,
            x: 0.1,
            v: 0.0,
            force: 0.0,
            mass: 1.0,
            damping: 0.5,
            stiffness: 40.0,
            x0: 0.1,
            omega: 0.0,
            accel: 0.0,
            substeps: 4,
            step_count: 0,
            fail_mode: fail::NONE,
            brake: false,
        }
    }

    fn get_real(&self, vr: u32) -> f64 {
        match vr {
            vr::TIME => self.time,
            vr::X => self.x,
            vr::V => self.v,
            vr::FORCE => self.force,
            vr::MASS => self.mass,
            vr::DAMPING => self.damping,
            vr::STIFFNESS => self.stiffness,
            vr::X0 => self.x0,
            vr::OMEGA => self.omega,
            vr::ACCEL => self.accel,
            vr::UNIT => 1.0,
            _ => f64::NAN,
        }
    }

    fn set_real(&mut self, vr: u32, value: f64) -> ModelResult<()> {
        if !value.is_finite() {
            return Err(ModelError::error(format!(
                "value reference {vr} must be finite, got {value}"
            )));
        }
        match vr {
            vr::FORCE => self.force = value,
            vr::MASS => self.mass = value,
            vr::DAMPING => self.damping = value,
            vr::STIFFNESS => self.stiffness = value,
            vr::X0 => self.x0 = value,
            _ => {
                return Err(ModelError::error(format!(
                    "value reference {vr} is not settable"
                )));
            }
        }
        Ok(())
    }

    fn get_integer(&self, vr: u32) -> i32 {
        match vr {
            vr::SUBSTEPS => self.substeps,
            vr::STEP_COUNT => self.step_count,
            vr::FAIL_MODE => self.fail_mode,
            _ => -1,
        }
    }

    fn set_integer(&mut self, vr: u32, value: i32) -> ModelResult<()> {
        match vr {
            vr::SUBSTEPS if value >= 1 => self.substeps = value,
            vr::SUBSTEPS => {
                return Err(ModelError::error(format!(
                    "substeps must be >= 1, got {value}"
                )));
            }
            vr::FAIL_MODE => self.fail_mode = value,
            _ => {
                return Err(ModelError::error(format!(
                    "value reference {vr} is not settable"
                )));
            }
        }
        Ok(())
    }

    fn get_boolean(&self, vr: u32) -> bool {
        match vr {
            vr::BRAKE => self.brake,
            vr::AT_REST => self.v.abs() < 1e-6 && self.accel.abs() < 1e-6,
            _ => false,
        }
    }

    fn set_boolean(&mut self, vr: u32, value: bool) -> ModelResult<()> {
        match vr {
            vr::BRAKE => self.brake = value,
            _ => {
                return Err(ModelError::error(format!(
                    "value reference {vr} is not settable"
                )));
            }
        }
        Ok(())
    }

    fn initialize(&mut self, start_time: f64) -> ModelResult<()> {
        if self.mass <= 0.0 {
            return Err(ModelError::error(format!(
                "mass must be > 0, got {}",
                self.mass
            )));
        }
        self.time = start_time;
        self.x = self.x0;
        self.v = 0.0;
        self.step_count = 0;
        self.omega = (self.stiffness / self.mass).sqrt();
        self.accel = self.acceleration();
        Ok(())
    }

    fn do_step(&mut self, t: f64, h: f64) -> ModelResult<()> {
        match self.fail_mode {
            fail::DISCARD => return Err(ModelError::discard("fail_mode asks for a discard")),
            fail::ERROR => return Err(ModelError::error("fail_mode asks for an error")),
            fail::PANIC => panic!("fail_mode asks for a panic"),
            _ => {}
        }
        let dt = h / f64::from(self.substeps);
        for _ in 0..self.substeps {
            self.accel = self.acceleration();
            self.v += self.accel * dt;
            self.x += self.v * dt;
        }
        self.accel = self.acceleration();
        self.time = t + h;
        self.step_count += 1;
        Ok(())
    }

    fn take_warning(&mut self) -> Option<String> {
        (self.fail_mode == fail::WARN).then(|| "fail_mode asks for a warning".to_owned())
    }

    fn save(&self, out: &mut Vec<u8>) {
        for x in [
            self.time,
            self.x,
            self.v,
            self.force,
            self.mass,
            self.damping,
            self.stiffness,
            self.x0,
            self.omega,
            self.accel,
        ] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        for i in [
            self.substeps,
            self.step_count,
            self.fail_mode,
            i32::from(self.brake),
        ] {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }

    fn restore(&mut self, bytes: &[u8]) -> ModelResult<()> {
        if bytes.len() != 96 {
            return Err(ModelError::error(format!(
                "payload has {} bytes, expected 96",
                bytes.len()
            )));
        }
        let f =
            |i: usize| f64::from_le_bytes(bytes[8 * i..8 * i + 8].try_into().unwrap_or_default());
        let n = |i: usize| {
            i32::from_le_bytes(bytes[80 + 4 * i..84 + 4 * i].try_into().unwrap_or_default())
        };
        *self = Self {
            time: f(0),
            x: f(1),
            v: f(2),
            force: f(3),
            mass: f(4),
            damping: f(5),
            stiffness: f(6),
            x0: f(7),
            omega: f(8),
            accel: f(9),
            substeps: n(0),
            step_count: n(1),
            fail_mode: n(2),
            brake: n(3) != 0,
        };
        Ok(())
    }
}

/// `impl Model` for a unit-like type with one Real output, `y` (always 0), and nothing
/// settable: a model whose only use is its identity (`MODEL_IDENTIFIER`, `GUID`).
#[allow(unused_macros)]
macro_rules! minimal_model {
    ($model:ty, $identifier:literal, $guid:literal, $new:expr) => {
        impl fmu_core::Model for $model {
            const MODEL_IDENTIFIER: &'static str = $identifier;
            const GUID: &'static str = $guid;
            const VARIABLES: &'static [fmu_core::VarSpec] = &[fmu_core::VarSpec {
                name: "y",
                value_reference: 0,
                var_type: fmu_core::VarType::Real,
                causality: fmu_core::Causality::Output,
                variability: fmu_core::Variability::Continuous,
                min: None,
                max: None,
            }];
            const CAN_HANDLE_VARIABLE_STEP: bool = true;

            fn new() -> Self {
                $new
            }
            fn get_real(&self, _vr: u32) -> f64 {
                0.0
            }
            fn set_real(&mut self, vr: u32, _value: f64) -> fmu_core::ModelResult<()> {
                Err(fmu_core::ModelError::error(format!(
                    "value reference {vr} is not settable"
                )))
            }
            fn initialize(&mut self, _start_time: f64) -> fmu_core::ModelResult<()> {
                Ok(())
            }
            fn do_step(&mut self, _t: f64, _h: f64) -> fmu_core::ModelResult<()> {
                Ok(())
            }
            fn save(&self, _out: &mut Vec<u8>) {}
            fn restore(&mut self, _bytes: &[u8]) -> fmu_core::ModelResult<()> {
                Ok(())
            }
        }
    };
}

/// A second model with another identity, to feed foreign pointers and buffers.
#[derive(Debug, Clone, PartialEq)]
pub struct Other;

minimal_model!(Other, "Other", "{other-model}", Other);

/// A new instance of model `M` named `name`, with the capturing logger but no capture
/// (its messages are dropped); NULL only if the glue refuses it, which the caller asserts.
pub fn instantiate_quiet<M: Model>(name: &str) -> Fmi2Component {
    let name = CString::new(name).expect("name without NUL");
    let guid = CString::new(M::GUID).expect("GUID without NUL");
    let callbacks = Fmi2CallbackFunctions {
        logger: logger(),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: ptr::null_mut(),
    };
    // SAFETY: valid arguments; the glue copies the callbacks.
    unsafe {
        abi::instantiate::<M>(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            ptr::null(),
            &callbacks,
            0,
            0,
        )
    }
}

// ---------------------------------------------------------------------------------------
// Capturing logger
// ---------------------------------------------------------------------------------------

/// One call of the logger, as the FMU made it.
#[derive(Debug, Clone, PartialEq)]
pub struct LogRecord {
    pub instance: String,
    pub status: Fmi2Status,
    pub category: String,
    pub format: String,
    pub message: String,
}

/// The logger's component environment: every record, per instance.
#[derive(Debug, Default)]
pub struct Capture {
    records: Mutex<Vec<LogRecord>>,
}

impl Capture {
    pub fn records(&self) -> Vec<LogRecord> {
        self.records
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    pub fn messages(&self) -> Vec<String> {
        self.records().into_iter().map(|r| r.message).collect()
    }

    pub fn clear(&self) {
        self.records
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clear();
    }

    /// Whether some message contains `needle`.
    pub fn contains(&self, needle: &str) -> bool {
        self.messages().iter().any(|m| m.contains(needle))
    }
}

fn lossy(p: *const c_char) -> String {
    if p.is_null() {
        return "<NULL>".to_owned();
    }
    // SAFETY: the FMU passes NUL-terminated strings that live across the call.
    unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
}

/// The test logger, declared with the one vararg the FMU passes as a fixed 6th argument.
unsafe extern "C" fn capture_logger(
    env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    format: *const c_char,
    message: *const c_char,
) {
    if env.is_null() {
        return;
    }
    // SAFETY: every instance in these tests gets a `Capture` that outlives it as env.
    let capture = unsafe { &*env.cast::<Capture>() };
    let record = LogRecord {
        instance: lossy(instance),
        status,
        category: lossy(category),
        format: lossy(format),
        message: lossy(message),
    };
    capture
        .records
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .push(record);
}

/// [`capture_logger`] as a true C-variadic function, for Miri (docs/testing.md): it stops
/// on the call through a transmuted function type that [`logger`] makes on stable Rust.
#[cfg(miri)]
unsafe extern "C" fn capture_logger_variadic(
    env: *mut c_void,
    instance: *const c_char,
    status: c_int,
    category: *const c_char,
    format: *const c_char,
    mut args: ...
) {
    // SAFETY: the glue always passes exactly one `char*` vararg ("%s", text).
    let message: *const c_char = unsafe { args.next_arg() };
    // SAFETY: the logger's own arguments, forwarded.
    unsafe { capture_logger(env, instance, status, category, format, message) }
}

/// The capturing logger under Miri.
#[cfg(miri)]
pub fn logger() -> Fmi2CallbackLogger {
    Some(capture_logger_variadic)
}

/// [`capture_logger`] as the variadic `fmi2CallbackLogger` type.
#[cfg(not(miri))]
pub fn logger() -> Fmi2CallbackLogger {
    type Fixed = unsafe extern "C" fn(
        *mut c_void,
        *const c_char,
        c_int,
        *const c_char,
        *const c_char,
        *const c_char,
    );
    type Variadic =
        unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char, ...);
    let fixed: Fixed = capture_logger;
    // SAFETY: Rust cannot define a C-variadic function on stable. On x86_64 System V
    // (and AArch64 Linux) a variadic call passes its first pointer vararg exactly like a
    // sixth fixed pointer argument, in the next integer register (the caller also sets
    // %al to the number of vector registers used, which the callee ignores), and the
    // glue always calls the logger with exactly one `char*` vararg ("%s", text). So a
    // non-variadic function with that sixth parameter receives the call correctly.
    Some(unsafe { std::mem::transmute::<Fixed, Variadic>(fixed) })
}

// ---------------------------------------------------------------------------------------
// Harness
// ---------------------------------------------------------------------------------------

pub fn status(raw: Fmi2Status) -> Status {
    Status::try_from(raw).expect("valid fmi2Status")
}

/// Calls `abi::instantiate::<Oscillator>` with the given (possibly broken) arguments and
/// a capturing logger; returns the component (maybe NULL) and the capture.
pub fn instantiate_raw(
    name: Option<&CStr>,
    fmu_type: c_int,
    guid: Option<&CStr>,
    logging_on: bool,
) -> (Fmi2Component, Arc<Capture>) {
    let capture = Arc::<Capture>::default();
    let callbacks = Fmi2CallbackFunctions {
        logger: logger(),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: Arc::as_ptr(&capture).cast_mut().cast(),
    };
    // SAFETY: valid callbacks, NUL-terminated or NULL strings.
    let c = unsafe {
        abi::instantiate::<Oscillator>(
            name.map_or(ptr::null(), CStr::as_ptr),
            fmu_type,
            guid.map_or(ptr::null(), CStr::as_ptr),
            ptr::null(),
            &callbacks,
            0,
            Fmi2Boolean::from(logging_on),
        )
    };
    (c, capture)
}

/// One Oscillator instance driven through the generic ABI wrappers; freed on drop.
#[derive(Debug)]
pub struct Fmu {
    pub c: Fmi2Component,
    pub log: Arc<Capture>,
}

impl Drop for Fmu {
    fn drop(&mut self) {
        // SAFETY: `c` is our live instance (or NULL after `free`).
        unsafe { abi::free_instance::<Oscillator>(self.c) };
    }
}

impl Fmu {
    pub fn new(name: &str) -> Self {
        Self::with_logging(name, false)
    }

    pub fn with_logging(name: &str, logging_on: bool) -> Self {
        let name = CString::new(name).expect("name without NUL");
        let guid = CString::new(GUID).expect("GUID without NUL");
        let (c, log) = instantiate_raw(Some(&name), FMI2_CO_SIMULATION, Some(&guid), logging_on);
        assert!(!c.is_null(), "instantiate failed: {:?}", log.messages());
        Self { c, log }
    }

    /// Frees the instance now (the drop then sees NULL).
    pub fn free(&mut self) {
        // SAFETY: our live instance; NULLed right after.
        unsafe { abi::free_instance::<Oscillator>(self.c) };
        self.c = ptr::null_mut();
    }

    pub fn state(&self) -> Option<FmiState> {
        // SAFETY: our live instance.
        unsafe { abi::instance_state::<Oscillator>(self.c) }
    }

    pub fn setup(&self, start: f64, stop: Option<f64>) -> Status {
        // SAFETY: our live instance.
        status(unsafe {
            abi::setup_experiment::<Oscillator>(
                self.c,
                0,
                0.0,
                start,
                Fmi2Boolean::from(stop.is_some()),
                stop.unwrap_or(0.0),
            )
        })
    }

    /// fmi2SetDebugLogging(`on`, `categories`).
    pub fn debug_logging(&self, on: bool, categories: &[&str]) -> Status {
        let names: Vec<CString> = categories
            .iter()
            .map(|c| CString::new(*c).expect("category without NUL"))
            .collect();
        let ptrs: Vec<*const c_char> = names.iter().map(|c| c.as_ptr()).collect();
        // SAFETY: our live instance; `ptrs` holds `ptrs.len()` NUL-terminated strings that
        // outlive the call.
        status(unsafe {
            abi::set_debug_logging::<Oscillator>(
                self.c,
                Fmi2Boolean::from(on),
                ptrs.len(),
                ptrs.as_ptr(),
            )
        })
    }

    pub fn enter_init(&self) -> Status {
        // SAFETY: our live instance.
        status(unsafe { abi::enter_initialization_mode::<Oscillator>(self.c) })
    }

    pub fn exit_init(&self) -> Status {
        // SAFETY: our live instance.
        status(unsafe { abi::exit_initialization_mode::<Oscillator>(self.c) })
    }

    pub fn do_step(&self, t: f64, h: f64) -> Status {
        // SAFETY: our live instance.
        status(unsafe { abi::do_step::<Oscillator>(self.c, t, h, 1) })
    }

    pub fn terminate(&self) -> Status {
        // SAFETY: our live instance.
        status(unsafe { abi::terminate::<Oscillator>(self.c) })
    }

    pub fn reset(&self) -> Status {
        // SAFETY: our live instance.
        status(unsafe { abi::reset::<Oscillator>(self.c) })
    }

    pub fn get_real(&self, vrs: &[u32]) -> (Status, Vec<f64>) {
        let mut out = vec![f64::NAN; vrs.len()];
        // SAFETY: arrays of length vrs.len().
        let s = unsafe {
            abi::get_real::<Oscillator>(self.c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr())
        };
        (status(s), out)
    }

    /// One Real that must read fine.
    pub fn real(&self, vr: u32) -> f64 {
        let (s, v) = self.get_real(&[vr]);
        assert_eq!(s, Status::Ok, "{:?}", self.log.messages());
        v[0]
    }

    pub fn set_real(&self, vrs: &[u32], values: &[f64]) -> Status {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: arrays of length vrs.len().
        status(unsafe {
            abi::set_real::<Oscillator>(self.c, vrs.as_ptr(), vrs.len(), values.as_ptr())
        })
    }

    pub fn get_integer(&self, vrs: &[u32]) -> (Status, Vec<i32>) {
        let mut out = vec![i32::MIN; vrs.len()];
        // SAFETY: arrays of length vrs.len().
        let s = unsafe {
            abi::get_integer::<Oscillator>(self.c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr())
        };
        (status(s), out)
    }

    pub fn set_integer(&self, vrs: &[u32], values: &[i32]) -> Status {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: arrays of length vrs.len().
        status(unsafe {
            abi::set_integer::<Oscillator>(self.c, vrs.as_ptr(), vrs.len(), values.as_ptr())
        })
    }

    pub fn get_boolean(&self, vrs: &[u32]) -> (Status, Vec<Fmi2Boolean>) {
        let mut out = vec![-1; vrs.len()];
        // SAFETY: arrays of length vrs.len().
        let s = unsafe {
            abi::get_boolean::<Oscillator>(self.c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr())
        };
        (status(s), out)
    }

    pub fn set_boolean(&self, vrs: &[u32], values: &[Fmi2Boolean]) -> Status {
        assert_eq!(vrs.len(), values.len());
        // SAFETY: arrays of length vrs.len().
        status(unsafe {
            abi::set_boolean::<Oscillator>(self.c, vrs.as_ptr(), vrs.len(), values.as_ptr())
        })
    }

    /// fmi2GetStatus(fmi2DoStepStatus): the status of the last fmi2DoStep.
    pub fn do_step_status(&self) -> Status {
        let mut st = -1;
        // SAFETY: our live instance, valid out pointer.
        let s =
            unsafe { abi::get_status::<Oscillator>(self.c, status_kind::DO_STEP_STATUS, &mut st) };
        assert_eq!(status(s), Status::Ok, "{:?}", self.log.messages());
        status(st)
    }

    /// fmi2GetRealStatus(fmi2LastSuccessfulTime).
    pub fn last_successful_time(&self) -> (Status, f64) {
        let mut t = f64::NAN;
        // SAFETY: our live instance, valid out pointer.
        let s = unsafe {
            abi::get_real_status::<Oscillator>(self.c, status_kind::LAST_SUCCESSFUL_TIME, &mut t)
        };
        (status(s), t)
    }

    /// fmi2GetBooleanStatus(fmi2Terminated).
    pub fn terminated_flag(&self) -> (Status, Fmi2Boolean) {
        let mut b = -1;
        // SAFETY: our live instance, valid out pointer.
        let s = unsafe {
            abi::get_boolean_status::<Oscillator>(self.c, status_kind::TERMINATED, &mut b)
        };
        (status(s), b)
    }

    /// fmi2GetFMUstate into `*slot`.
    pub fn get_state(&self, slot: &mut Fmi2FmuState) -> Status {
        // SAFETY: our live instance, valid slot.
        status(unsafe { abi::get_fmu_state::<Oscillator>(self.c, slot) })
    }

    pub fn set_state(&self, state: Fmi2FmuState) -> Status {
        // SAFETY: our live instance; `state` is NULL or a snapshot.
        status(unsafe { abi::set_fmu_state::<Oscillator>(self.c, state) })
    }

    pub fn free_state(&self, slot: &mut Fmi2FmuState) -> Status {
        // SAFETY: our live instance, valid slot.
        status(unsafe { abi::free_fmu_state::<Oscillator>(self.c, slot) })
    }

    /// fmi2SerializedFMUstateSize + fmi2SerializeFMUstate.
    pub fn serialize(&self, state: Fmi2FmuState) -> Vec<u8> {
        let mut size = 0usize;
        // SAFETY: our live instance; `state` is a snapshot; valid out pointer.
        let s = unsafe { abi::serialized_fmu_state_size::<Oscillator>(self.c, state, &mut size) };
        assert_eq!(status(s), Status::Ok, "{:?}", self.log.messages());
        let mut bytes = vec![0u8; size];
        // SAFETY: buffer of `size` bytes.
        let s = unsafe {
            abi::serialize_fmu_state::<Oscillator>(self.c, state, bytes.as_mut_ptr().cast(), size)
        };
        assert_eq!(status(s), Status::Ok, "{:?}", self.log.messages());
        bytes
    }

    /// fmi2DeSerializeFMUstate into `*slot`.
    pub fn deserialize(&self, bytes: &[u8], slot: &mut Fmi2FmuState) -> Status {
        // SAFETY: our live instance; buffer of bytes.len() bytes; valid slot.
        status(unsafe {
            abi::de_serialize_fmu_state::<Oscillator>(
                self.c,
                bytes.as_ptr().cast(),
                bytes.len(),
                slot,
            )
        })
    }

    /// Instantiated → (setup at 0, stop 10) → InitializationMode → StepComplete.
    pub fn initialized(name: &str) -> Self {
        let fmu = Self::new(name);
        assert_eq!(fmu.setup(0.0, Some(10.0)), Status::Ok);
        assert_eq!(fmu.enter_init(), Status::Ok);
        assert_eq!(fmu.exit_init(), Status::Ok);
        fmu
    }

    /// A fresh instance initialized at `start`, with no stop time.
    pub fn initialized_at(name: &str, start: f64) -> Self {
        let fmu = Self::new(name);
        assert_eq!(fmu.setup(start, None), Status::Ok);
        assert_eq!(fmu.enter_init(), Status::Ok);
        assert_eq!(fmu.exit_init(), Status::Ok);
        fmu
    }

    /// A fresh instance brought into `state` through legal calls only (StepCanceled,
    /// unreachable for a synchronous FMU, through a serialized state carrying it).
    pub fn in_state(state: FmiState) -> Self {
        let fmu = Self::new("sweep");
        match state {
            FmiState::Instantiated => {}
            FmiState::InitializationMode => {
                assert_eq!(fmu.setup(0.0, None), Status::Ok);
                assert_eq!(fmu.enter_init(), Status::Ok);
            }
            _ => {
                assert_eq!(fmu.setup(0.0, None), Status::Ok);
                assert_eq!(fmu.enter_init(), Status::Ok);
                assert_eq!(fmu.exit_init(), Status::Ok);
            }
        }
        let fail_then_step = |mode: i32, expected: Status| {
            assert_eq!(fmu.set_integer(&[vr::FAIL_MODE], &[mode]), Status::Ok);
            assert_eq!(fmu.do_step(0.0, 0.01), expected);
        };
        match state {
            FmiState::StepFailed => fail_then_step(fail::DISCARD, Status::Discard),
            FmiState::Fatal => fail_then_step(fail::PANIC, Status::Fatal),
            FmiState::Terminated => assert_eq!(fmu.terminate(), Status::Ok),
            FmiState::StepCanceled => {
                let mut snap = ptr::null_mut();
                assert_eq!(fmu.get_state(&mut snap), Status::Ok);
                let mut bytes = fmu.serialize(snap);
                assert_eq!(fmu.free_state(&mut snap), Status::Ok);
                let at = state_code_offset();
                bytes[at..at + 4].copy_from_slice(&4u32.to_le_bytes());
                reseal(&mut bytes);
                assert_eq!(fmu.deserialize(&bytes, &mut snap), Status::Ok);
                assert_eq!(fmu.set_state(snap), Status::Ok);
                assert_eq!(fmu.free_state(&mut snap), Status::Ok);
            }
            _ => {}
        }
        assert_eq!(fmu.state(), Some(state), "{:?}", fmu.log.messages());
        fmu.log.clear();
        fmu
    }
}

/// Replaces the trailing CRC-32 of an edited serialized state, so the edit reaches the
/// checks behind the checksum.
pub fn reseal(bytes: &mut [u8]) {
    let body = bytes.len() - 4;
    let crc = crc32fast::hash(&bytes[..body]);
    bytes[body..].copy_from_slice(&crc.to_le_bytes());
}

/// Offset of the FMI-state code in a serialized Oscillator state.
pub fn state_code_offset() -> usize {
    20 + Oscillator::MODEL_IDENTIFIER.len() + GUID.len()
}

/// The FMI 2.0 CS allowed-states table, transcribed independently of the library's
/// (FMI 2.0 §4.2.4; StepInProgress never occurs; in Fatal only fmi2FreeInstance).
pub fn expected_allowed(f: Function, s: FmiState) -> bool {
    use FmiState as S;
    let alive = s != S::Fatal;
    match f {
        Function::FreeInstance => true,
        Function::SetDebugLogging
        | Function::Reset
        | Function::GetFmuState
        | Function::SetFmuState
        | Function::FreeFmuState
        | Function::SerializedFmuStateSize
        | Function::SerializeFmuState
        | Function::DeSerializeFmuState => alive,
        Function::SetupExperiment | Function::EnterInitializationMode => s == S::Instantiated,
        Function::ExitInitializationMode => s == S::InitializationMode,
        Function::Terminate => matches!(s, S::StepComplete | S::StepFailed),
        Function::GetReal
        | Function::GetInteger
        | Function::GetBoolean
        | Function::GetString
        | Function::GetDirectionalDerivative => matches!(
            s,
            S::InitializationMode
                | S::StepComplete
                | S::StepFailed
                | S::StepCanceled
                | S::Terminated
        ),
        Function::SetReal
        | Function::SetInteger
        | Function::SetBoolean
        | Function::SetString
        | Function::SetRealInputDerivatives => {
            matches!(s, S::Instantiated | S::InitializationMode | S::StepComplete)
        }
        Function::GetRealOutputDerivatives => {
            matches!(
                s,
                S::StepComplete | S::StepFailed | S::StepCanceled | S::Terminated
            )
        }
        Function::DoStep => s == S::StepComplete,
        Function::CancelStep => false,
        Function::GetStatus
        | Function::GetRealStatus
        | Function::GetIntegerStatus
        | Function::GetBooleanStatus
        | Function::GetStringStatus => matches!(s, S::StepComplete | S::StepFailed | S::Terminated),
    }
}

/// A donor of valid FMU-state arguments for [`call`].
#[derive(Debug)]
pub struct Donor {
    pub fmu: Fmu,
    pub snapshot: Fmi2FmuState,
    pub bytes: Vec<u8>,
}

impl Donor {
    pub fn new() -> Self {
        let fmu = Fmu::initialized("donor");
        let mut snapshot = ptr::null_mut();
        assert_eq!(fmu.get_state(&mut snapshot), Status::Ok);
        let bytes = fmu.serialize(snapshot);
        Self {
            fmu,
            snapshot,
            bytes,
        }
    }
}

impl Drop for Donor {
    fn drop(&mut self) {
        let mut s = self.snapshot;
        assert_eq!(self.fmu.free_state(&mut s), Status::Ok);
    }
}

/// Calls `f` on component `c` with valid arguments (snapshots and buffers from `donor`),
/// releasing anything it allocated. Not for FreeInstance.
pub fn call(c: Fmi2Component, f: Function, donor: &Donor) -> Status {
    type O = Oscillator;
    let vr_x = [vr::X];
    let vr_step = [vr::STEP_COUNT];
    let vr_force = [vr::FORCE];
    let mut real = [0.0];
    let mut int = [0];
    let mut string: [*const c_char; 1] = [ptr::null()];
    let mut st: Fmi2Status = 0;
    let mut size = 0usize;
    // SAFETY: every pointer is valid for the length passed; `c` is NULL or live.
    let raw = unsafe {
        match f {
            Function::FreeInstance => panic!("call() does not free instances"),
            Function::SetDebugLogging => abi::set_debug_logging::<O>(c, 1, 0, ptr::null()),
            Function::SetupExperiment => abi::setup_experiment::<O>(c, 0, 0.0, 0.0, 0, 0.0),
            Function::EnterInitializationMode => abi::enter_initialization_mode::<O>(c),
            Function::ExitInitializationMode => abi::exit_initialization_mode::<O>(c),
            Function::Terminate => abi::terminate::<O>(c),
            Function::Reset => abi::reset::<O>(c),
            Function::GetReal => abi::get_real::<O>(c, vr_x.as_ptr(), 1, real.as_mut_ptr()),
            Function::GetInteger => abi::get_integer::<O>(c, vr_step.as_ptr(), 1, int.as_mut_ptr()),
            Function::GetBoolean => {
                abi::get_boolean::<O>(c, [vr::AT_REST].as_ptr(), 1, int.as_mut_ptr())
            }
            Function::GetString => abi::get_string::<O>(c, ptr::null(), 0, string.as_mut_ptr()),
            Function::SetReal => abi::set_real::<O>(c, vr_force.as_ptr(), 1, [1.0].as_ptr()),
            Function::SetInteger => {
                abi::set_integer::<O>(c, [vr::FAIL_MODE].as_ptr(), 1, [0].as_ptr())
            }
            Function::SetBoolean => abi::set_boolean::<O>(c, [vr::BRAKE].as_ptr(), 1, [0].as_ptr()),
            Function::SetString => abi::set_string::<O>(c, ptr::null(), 0, ptr::null()),
            Function::GetFmuState => {
                let mut slot = ptr::null_mut();
                let s = abi::get_fmu_state::<O>(c, &mut slot);
                if !slot.is_null() {
                    assert_eq!(donor.fmu.free_state(&mut slot), Status::Ok);
                }
                s
            }
            Function::SetFmuState => abi::set_fmu_state::<O>(c, donor.snapshot),
            Function::FreeFmuState => abi::free_fmu_state::<O>(c, &mut ptr::null_mut()),
            Function::SerializedFmuStateSize => {
                abi::serialized_fmu_state_size::<O>(c, donor.snapshot, &mut size)
            }
            Function::SerializeFmuState => {
                let mut buf = vec![0u8; donor.bytes.len()];
                abi::serialize_fmu_state::<O>(c, donor.snapshot, buf.as_mut_ptr().cast(), buf.len())
            }
            Function::DeSerializeFmuState => {
                let mut slot = ptr::null_mut();
                let bytes = &donor.bytes;
                let s = abi::de_serialize_fmu_state::<O>(
                    c,
                    bytes.as_ptr().cast(),
                    bytes.len(),
                    &mut slot,
                );
                if !slot.is_null() {
                    assert_eq!(donor.fmu.free_state(&mut slot), Status::Ok);
                }
                s
            }
            Function::GetDirectionalDerivative => abi::get_directional_derivative::<O>(
                c,
                ptr::null(),
                0,
                ptr::null(),
                0,
                ptr::null(),
                ptr::null_mut(),
            ),
            Function::SetRealInputDerivatives => {
                abi::set_real_input_derivatives::<O>(c, ptr::null(), 0, ptr::null(), ptr::null())
            }
            Function::GetRealOutputDerivatives => abi::get_real_output_derivatives::<O>(
                c,
                ptr::null(),
                0,
                ptr::null(),
                ptr::null_mut(),
            ),
            Function::DoStep => abi::do_step::<O>(c, 0.0, 0.01, 1),
            Function::CancelStep => abi::cancel_step::<O>(c),
            Function::GetStatus => abi::get_status::<O>(c, status_kind::DO_STEP_STATUS, &mut st),
            Function::GetRealStatus => {
                abi::get_real_status::<O>(c, status_kind::LAST_SUCCESSFUL_TIME, real.as_mut_ptr())
            }
            Function::GetIntegerStatus => {
                abi::get_integer_status::<O>(c, status_kind::DO_STEP_STATUS, int.as_mut_ptr())
            }
            Function::GetBooleanStatus => {
                abi::get_boolean_status::<O>(c, status_kind::TERMINATED, int.as_mut_ptr())
            }
            Function::GetStringStatus => {
                abi::get_string_status::<O>(c, status_kind::PENDING_STATUS, string.as_mut_ptr())
            }
        }
    };
    status(raw)
}

/// Runs the reference trajectory with the model itself (no FMI glue): `n` steps of `h`
/// from 0 with `force(k)` applied before step k; returns (x, v) after each step.
pub fn reference_run(n: usize, h: f64, force: impl Fn(usize) -> f64) -> Vec<(f64, f64)> {
    let mut m = Oscillator::new();
    m.initialize(0.0).expect("initialize");
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        m.set_real(vr::FORCE, force(k)).expect("set force");
        m.do_step(k as f64 * h, h).expect("step");
        out.push((m.get_real(vr::X), m.get_real(vr::V)));
    }
    out
}

/// The same run through the FMI glue on a fresh instance named `name`.
pub fn glue_run(name: &str, n: usize, h: f64, force: impl Fn(usize) -> f64) -> Vec<(f64, f64)> {
    let fmu = Fmu::initialized(name);
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        assert_eq!(fmu.set_real(&[vr::FORCE], &[force(k)]), Status::Ok);
        assert_eq!(
            fmu.do_step(k as f64 * h, h),
            Status::Ok,
            "{:?}",
            fmu.log.messages()
        );
        let (s, xv) = fmu.get_real(&[vr::X, vr::V]);
        assert_eq!(s, Status::Ok);
        out.push((xv[0], xv[1]));
    }
    out
}
