//! The per-instance state behind an `fmi2Component`, and the safe logic of the FMI calls.
//!
//! Everything here is safe code: `abi` turns the raw C arguments into slices and
//! references first, then calls these methods inside the shared guard.

use std::ffi::{CStr, CString, c_void};

use crate::handles;
use crate::state::{FmiState, Function};
use fmi2_sys::{Fmi2ComponentEnvironment, Fmi2Status, Fmi2String, Status};
use fmu_core::{
    Causality, Model, ModelError, Severity, Shown, VarSpec, VarType, Variability, VrRun,
};

/// Log categories of every FMU built on this glue, as the logger callback receives them,
/// indexed by [`category_of`]. Each model description must declare exactly these names in
/// this order in `<LogCategories>` (with its own descriptions): `fmu-build` refuses to
/// build an FMU whose XML differs.
pub const LOG_CATEGORIES: [&CStr; 5] = [
    c"logEvents",
    c"logStatusWarning",
    c"logStatusDiscard",
    c"logStatusError",
    c"logStatusFatal",
];

/// Index into [`LOG_CATEGORIES`] of the category a message with `status` belongs to.
fn category_of(status: Status) -> usize {
    match status {
        Status::Ok | Status::Pending => 0,
        Status::Warning => 1,
        Status::Discard => 2,
        Status::Error => 3,
        Status::Fatal => 4,
    }
}

/// Relative time tolerance of the communication-point checks: 1e-9·max(1, |t|).
pub(crate) fn time_tolerance(t: f64) -> f64 {
    1e-9 * t.abs().max(1.0)
}

/// The C logger (`fmi2CallbackLogger` without its `Option`).
pub(crate) type Logger = unsafe extern "C" fn(
    Fmi2ComponentEnvironment,
    Fmi2String,
    Fmi2Status,
    Fmi2String,
    Fmi2String,
    ...
);

/// Where log messages go: the master's logger and its environment pointer.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LogSink {
    logger: Logger,
    env: Fmi2ComponentEnvironment,
}

impl LogSink {
    /// A sink over the master's logger.
    pub(crate) fn new(logger: Logger, env: Fmi2ComponentEnvironment) -> Self {
        Self { logger, env }
    }

    /// Calls the logger with format `"%s"` and `text` as the only vararg, so text from a
    /// model or the master is never interpreted as a printf format.
    pub(crate) fn emit(&self, instance_name: &CStr, status: Status, text: &str) {
        // Interior NULs would truncate the C string; show them instead of failing.
        let message = CString::new(text.replace('\0', "\\0")).unwrap_or_default();
        // SAFETY: `logger` is the non-NULL function pointer the master passed to
        // fmi2Instantiate, which FMI 2.0 requires to stay callable for the instance's
        // lifetime. Every string argument is NUL-terminated and outlives the call, and
        // the "%s" format consumes exactly the one `char*` vararg passed.
        unsafe {
            (self.logger)(
                self.env,
                instance_name.as_ptr(),
                Fmi2Status::from(status),
                LOG_CATEGORIES[category_of(status)].as_ptr(),
                c"%s".as_ptr(),
                message.as_ptr(),
            );
        }
    }
}

/// Which model a live instance or snapshot of this library belongs to. The tables of live
/// handles (`handles`) and states (`snapshot::LIVE`) prove that a pointer is one this glue
/// allocated and has not freed, and which kind it is; the tag, the first field of a
/// `#[repr(C)]` struct, tells the models built into one library apart.
#[repr(C)]
#[derive(Debug)]
pub(crate) struct Tag {
    guid: &'static str,
}

impl Tag {
    /// The tag of model `M`.
    pub(crate) fn new<M: Model>() -> Self {
        Self { guid: M::GUID }
    }

    /// Whether `ptr` starts with the tag of model `M`.
    ///
    /// # Safety
    /// `ptr` points to a live instance or snapshot this glue allocated (one of the two
    /// tables lists it), so it is never NULL and always aligned, and is not checked for
    /// either: this runs on every call of the step loop.
    #[inline]
    pub(crate) unsafe fn matches<M: Model>(ptr: *const c_void) -> bool {
        // SAFETY: a live, aligned `Tag` per this function's contract.
        let guid = unsafe { (*ptr.cast::<Tag>()).guid };
        // The same string in this library is the same pointer: every call on a live
        // instance takes that shortcut instead of comparing the GUID byte by byte.
        std::ptr::eq(guid, M::GUID) || guid == M::GUID
    }
}

/// The FMI bookkeeping of an instance, saved and restored with the model by the FMU-state
/// functions (everything except identity, callbacks and logging settings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Glue {
    /// FMI state.
    pub(crate) state: FmiState,
    /// startTime of fmi2SetupExperiment (0 until called).
    pub(crate) start_time: f64,
    /// stopTime, when stopTimeDefined.
    pub(crate) stop_time: Option<f64>,
    /// tolerance, when toleranceDefined (stored only).
    pub(crate) tolerance: Option<f64>,
    /// The FMU time: start time after init, cp + h after each successful step.
    pub(crate) time: f64,
    /// Step size of the first successful doStep (fixed-step models must keep it).
    pub(crate) first_step: Option<f64>,
    /// Status of the last fmi2DoStep (fmi2GetStatus(fmi2DoStepStatus)).
    pub(crate) last_step_status: Status,
    /// The model asked to end the simulation (a discarded step).
    pub(crate) terminate_requested: bool,
    /// A variable was set since `initialize` last ran (only matters in InitializationMode).
    pub(crate) dirty: bool,
    /// The function whose fmi2Error moved the instance to Terminated, so that later
    /// illegal calls name the state Error and say why the instance is there (a master that
    /// never called fmi2Terminate would otherwise read "in state Terminated" as a bug). Not
    /// serialized.
    pub(crate) failed_in: Option<Function>,
}

impl Glue {
    /// The call whose fmi2Error put the instance in Terminated, which is then FMI 2.0's
    /// error state (whose calls Terminated allows).
    pub(crate) fn error_from(&self) -> Option<Function> {
        self.failed_in
            .filter(|_| self.state == FmiState::Terminated)
    }

    /// The state as log messages name it: Error for Terminated entered through an fmi2Error.
    pub(crate) fn state_name(&self) -> &'static str {
        match self.error_from() {
            Some(_) => "Error",
            None => self.state.name(),
        }
    }

    /// The bookkeeping of a freshly instantiated (or reset) instance.
    pub(crate) fn new() -> Self {
        Self {
            state: FmiState::Instantiated,
            start_time: 0.0,
            stop_time: None,
            tolerance: None,
            time: 0.0,
            first_step: None,
            last_step_status: Status::Ok,
            terminate_requested: false,
            dirty: false,
            failed_in: None,
        }
    }
}

/// An error a call returns: its status and the message logged for it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Failure {
    pub(crate) status: Status,
    pub(crate) message: String,
}

impl Failure {
    /// An fmi2Warning: the call did its work, with a remark.
    pub(crate) fn warning(message: impl Into<String>) -> Self {
        Self {
            status: Status::Warning,
            message: message.into(),
        }
    }

    /// An fmi2Error.
    pub(crate) fn error(message: impl Into<String>) -> Self {
        Self {
            status: Status::Error,
            message: message.into(),
        }
    }
}

impl From<ModelError> for Failure {
    fn from(e: ModelError) -> Self {
        let status = match e.severity {
            Severity::Discard => Status::Discard,
            Severity::Error => Status::Error,
        };
        Self {
            status,
            message: e.message,
        }
    }
}

/// What a call body returns: its non-failing status, or a failure to log and escalate.
pub(crate) type Outcome = Result<Status, Failure>;

/// Which typed get/set function is asking for a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Access {
    Real,
    /// fmi2Get/SetInteger: Integer and Enumeration variables.
    Integer,
    Boolean,
}

impl Access {
    fn accepts(self, t: VarType) -> bool {
        matches!(
            (self, t),
            (Access::Real, VarType::Real)
                | (Access::Integer, VarType::Integer | VarType::Enumeration)
                | (Access::Boolean, VarType::Boolean)
        )
    }

    fn accepted_types(self) -> &'static str {
        match self {
            Access::Real => "Real",
            Access::Integer => "Integer and Enumeration",
            Access::Boolean => "Boolean",
        }
    }
}

/// One FMU instance: the model plus everything FMI needs around it. Boxed and handed to
/// the master as the `fmi2Component`.
#[repr(C)]
pub(crate) struct Instance<M: Model> {
    /// First field, so a component pointer can be checked before it is trusted.
    tag: Tag,
    pub(crate) model: M,
    pub(crate) glue: Glue,
    name: CString,
    sink: LogSink,
    /// Enabled flag per entry of [`LOG_CATEGORIES`].
    enabled: [bool; 5],
    /// `(value reference, index into M::VARIABLES)`, sorted by value reference.
    index: Vec<(u32, usize)>,
    /// Per [`Access`], `value reference → 1 + index into M::VARIABLES` (0: none). Value
    /// references are usually small dense integers, and get/set run every step for every
    /// scalar, so a direct table replaces the search; empty when they are too sparse.
    direct: [Vec<u32>; 3],
    /// Per [`Access`], the last array of value references a getter (`[k][0]`) and a
    /// setter (`[k][1]`) accepted. Masters pass the same array every step, so comparing
    /// it with the last accepted one replaces a lookup and a settability check per scalar.
    accepted: [[Accepted; 2]; 3],
}

/// An array of value references that one typed get or set function accepted, with the
/// variables they name and, for setters, the state it was accepted in (settability
/// depends on the state; that the references exist and have the right type does not).
#[derive(Debug, Default)]
struct Accepted {
    valid: bool,
    /// Whether any of the variables declares a `min` or `max` (the setters' range check
    /// is skipped otherwise).
    ranged: bool,
    vrs: Vec<u32>,
    specs: Vec<&'static VarSpec>,
    /// `vrs` cut into runs of consecutive value references.
    runs: Vec<VrRun>,
    state: Option<FmiState>,
}

/// Largest value reference for which [`Instance`] builds direct lookup tables.
const DIRECT_TABLE_LIMIT: u32 = 1 << 16;

impl<M: Model> std::fmt::Debug for Instance<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Instance")
            .field("model", &M::MODEL_IDENTIFIER)
            .field("name", &self.name)
            .field("glue", &self.glue)
            .field("enabled", &self.enabled)
            .finish_non_exhaustive()
    }
}

impl<M: Model> Instance<M> {
    /// A new instance in state Instantiated with `M::new()`.
    pub(crate) fn new(model: M, name: CString, sink: LogSink, logging_on: bool) -> Self {
        let mut index: Vec<(u32, usize)> = M::VARIABLES
            .iter()
            .enumerate()
            .map(|(i, v)| (v.value_reference, i))
            .collect();
        index.sort_by_key(|&(vr, _)| vr);
        let mut direct: [Vec<u32>; 3] = Default::default();
        let max = index.last().map_or(0, |&(vr, _)| vr);
        if max < DIRECT_TABLE_LIMIT {
            for (k, access) in [Access::Real, Access::Integer, Access::Boolean]
                .into_iter()
                .enumerate()
            {
                direct[k] = vec![0; max as usize + 1];
                // The first declared variable of a type wins, as in the search below.
                for &(vr, i) in index.iter().rev() {
                    if access.accepts(M::VARIABLES[i].var_type) {
                        direct[k][vr as usize] = i as u32 + 1;
                    }
                }
            }
        }
        Self {
            tag: Tag::new::<M>(),
            model,
            glue: Glue::new(),
            name,
            sink,
            // loggingOn switches debug logging; the status categories start on, so a
            // master that never asks still hears why a step warned or was discarded (FMI 2.0
            // §2.1.3: with fmi2Warning the logger "was called"). fmi2SetDebugLogging turns
            // them off.
            enabled: [logging_on, true, true, true, true],
            index,
            direct,
            accepted: Default::default(),
        }
    }

    /// The instance behind a component handle, if it is a live instance of `M`.
    ///
    /// Any pointer value is accepted: only a handle the table issued and has not retired
    /// is followed (see [`handles`]), so a freed, made-up or foreign component is refused
    /// without reading its memory.
    ///
    /// # Safety
    /// No other reference to the instance is live during `'a`, and no other thread frees
    /// it meanwhile (FMI forbids concurrent calls on one instance).
    #[inline]
    pub(crate) unsafe fn from_component<'a>(c: *mut c_void) -> Option<&'a mut Self> {
        let p = handles::instance(c)?;
        // SAFETY: a live handle's instance is a `Box<Instance<_>>` of some model of this
        // library, alive until its handle is released: it starts with a readable `Tag`.
        if !unsafe { Tag::matches::<M>(p) } {
            return None;
        }
        // SAFETY: the tag proves it is an `Instance<M>`; exclusivity is part of this
        // function's contract.
        Some(unsafe { &mut *p.cast::<Self>() })
    }

    /// Logs `"<function>: <text>"`. Errors and fatal errors always reach the logger so
    /// the master can report why a call failed; other messages only if their category
    /// is enabled (warnings and discards are, until the master turns them off).
    pub(crate) fn log(&self, status: Status, function: Function, text: &str) {
        self.log_as(status, function.name(), text);
    }

    /// [`Instance::log`] with the function given by name (for fmi2Instantiate, which
    /// has no [`Function`] as it takes no instance).
    pub(crate) fn log_as(&self, status: Status, function: &str, text: &str) {
        let always = matches!(status, Status::Error | Status::Fatal);
        if always || self.enabled[category_of(status)] {
            self.sink
                .emit(&self.name, status, &format!("{function}: {text}"));
        }
    }

    /// Logs a lifecycle event (category logEvents).
    pub(crate) fn event(&self, function: Function, text: &str) {
        self.log(Status::Ok, function, text);
    }

    /// Applies the status escalation of a failed call, as Reference-FMUs does: fmi2Error
    /// moves the instance to Terminated (FMI 2.0 §2.1.3: the simulation cannot continue
    /// except by restoring an FMU state, resetting or freeing); fmi2Fatal to Fatal, which is
    /// never left.
    pub(crate) fn escalate(&mut self, status: Status, function: Function) {
        match status {
            Status::Error if self.glue.state != FmiState::Fatal => {
                if self.glue.state != FmiState::Terminated {
                    self.glue.failed_in = Some(function);
                }
                self.glue.state = FmiState::Terminated;
            }
            Status::Fatal => self.glue.state = FmiState::Fatal,
            _ => {}
        }
    }

    /// fmi2SetDebugLogging: `categories` empty, or the name `logAll` that many tools send,
    /// means all; otherwise each named category is switched to `on`. Names this FMU does
    /// not declare are skipped with fmi2Warning: an error would end the instance (every
    /// fmi2Error does) over a master's logging preference.
    pub(crate) fn set_debug_logging(&mut self, on: bool, categories: &[String]) -> Outcome {
        if categories.is_empty() || categories.iter().any(|c| c == "logAll") {
            self.enabled = [on; 5];
        }
        let mut unknown = Vec::new();
        for name in categories.iter().filter(|c| *c != "logAll") {
            match LOG_CATEGORIES
                .iter()
                .position(|c| c.to_bytes() == name.as_bytes())
            {
                Some(k) => self.enabled[k] = on,
                None => unknown.push(format!("'{name}'")),
            }
        }
        if unknown.is_empty() {
            return Ok(Status::Ok);
        }
        let known: Vec<_> = LOG_CATEGORIES.iter().map(|c| c.to_string_lossy()).collect();
        Err(Failure::warning(format!(
            "unknown log category {} ignored; this FMU declares {} (or logAll for all)",
            unknown.join(", "),
            known.join(", ")
        )))
    }

    /// The declared variable `vr` as seen by a typed get/set function.
    pub(crate) fn lookup(
        &self,
        function: Function,
        access: Access,
        vr: u32,
    ) -> Result<&'static VarSpec, Failure> {
        let slot = self.direct[access as usize]
            .get(vr as usize)
            .copied()
            .unwrap_or(0);
        if slot != 0 {
            return Ok(&M::VARIABLES[slot as usize - 1]);
        }
        let start = self.index.partition_point(|&(r, _)| r < vr);
        let candidates = self.index[start..].iter().take_while(|&&(r, _)| r == vr);
        let mut wrong_type = None;
        for &(_, i) in candidates {
            let spec = &M::VARIABLES[i];
            if access.accepts(spec.var_type) {
                return Ok(spec);
            }
            wrong_type.get_or_insert(spec);
        }
        Err(Failure::error(match wrong_type {
            Some(spec) => format!(
                "variable '{}' (value reference {vr}) is of type {:?}; {} accepts only {} variables",
                spec.name,
                spec.var_type,
                function.name(),
                access.accepted_types()
            ),
            None => format!("unknown value reference {vr}"),
        }))
    }

    /// The variables `vrs` name, each checked for `access` and, for a setter, for being
    /// settable in the current state, and whether any of them has a declared range. The
    /// first failure is returned; nothing is changed.
    ///
    /// The accepted array is remembered per function, and the same array in a later call
    /// (in the same state, for a setter) is accepted by one comparison. The buffers are
    /// reused, so once they have grown a call allocates nothing.
    #[inline]
    pub(crate) fn accept(
        &mut self,
        function: Function,
        access: Access,
        setter: bool,
        vrs: &[u32],
    ) -> Result<(&[&'static VarSpec], bool), Failure> {
        let state = setter.then_some(self.glue.state);
        let (k, j) = (access as usize, usize::from(setter));
        let last = &self.accepted[k][j];
        if !(last.valid && last.state == state && last.vrs == vrs) {
            self.accept_new(function, access, setter, vrs)?;
        }
        let entry = &self.accepted[k][j];
        Ok((&entry.specs, entry.ranged))
    }

    /// [`Instance::accept`] for an array that differs from the last accepted one: checks
    /// each value reference and remembers the array. Out of line, so the per-step path
    /// (the same array again) stays a comparison inlined into each getter and setter.
    #[inline(never)]
    fn accept_new(
        &mut self,
        function: Function,
        access: Access,
        setter: bool,
        vrs: &[u32],
    ) -> Result<(), Failure> {
        let state = setter.then_some(self.glue.state);
        let (k, j) = (access as usize, usize::from(setter));
        let mut entry = std::mem::take(&mut self.accepted[k][j]);
        entry.valid = false;
        entry.specs.clear();
        let checked: Result<(), Failure> = vrs.iter().try_for_each(|&r| {
            let spec = self.lookup(function, access, r)?;
            if setter {
                self.check_settable(spec)?;
            }
            entry.specs.push(spec);
            Ok(())
        });
        if checked.is_ok() {
            entry.ranged = entry
                .specs
                .iter()
                .any(|v| v.min.is_some() || v.max.is_some());
            entry.vrs.clear();
            entry.vrs.extend_from_slice(vrs);
            VrRun::split(vrs, &mut entry.runs);
            entry.state = state;
            entry.valid = true;
        }
        self.accepted[k][j] = entry;
        checked
    }

    /// The model, and the runs of the array a getter (`setter == false`) or setter of
    /// `access` accepted last; only meaningful right after [`Instance::accept`] succeeded
    /// for that array.
    pub(crate) fn model_and_runs(&mut self, access: Access, setter: bool) -> (&mut M, &[VrRun]) {
        (
            &mut self.model,
            &self.accepted[access as usize][usize::from(setter)].runs,
        )
    }

    /// Checks that `spec` may be set in the current state (FMI 2.0 CS rules). The state
    /// table already limits set calls to Instantiated, InitializationMode and StepComplete.
    pub(crate) fn check_settable(&self, spec: &VarSpec) -> Result<(), Failure> {
        let state = self.glue.state;
        let name = spec.name;
        let reason = match (spec.causality, spec.variability) {
            (_, Variability::Constant) => {
                format!("cannot set constant '{name}'; constants can never be set")
            }
            (Causality::Input, _) | (Causality::Parameter, Variability::Tunable) => return Ok(()),
            (Causality::Parameter, _) => {
                if matches!(state, FmiState::Instantiated | FmiState::InitializationMode) {
                    return Ok(());
                }
                format!(
                    "cannot set fixed parameter '{name}' in state {state}; fixed parameters \
                     may be set only before fmi2ExitInitializationMode"
                )
            }
            (Causality::Output, _) => {
                format!(
                    "cannot set output '{name}'; outputs are computed by the FMU and can never be set"
                )
            }
            (Causality::CalculatedParameter, _) => format!(
                "cannot set calculated parameter '{name}'; it is computed from other parameters \
                 and can never be set"
            ),
            (Causality::Local, _) => {
                format!("cannot set local variable '{name}'; local variables can never be set")
            }
            (Causality::Independent, _) => format!(
                "cannot set independent variable '{name}'; time advances only through \
                 fmi2SetupExperiment and fmi2DoStep"
            ),
        };
        Err(Failure::error(reason))
    }

    /// Before a get in InitializationMode: re-runs `initialize` if anything was set since
    /// it last ran, so the values read are consistent with the inputs and parameters.
    pub(crate) fn refresh_if_dirty(&mut self) -> Result<(), Failure> {
        if self.glue.state == FmiState::InitializationMode && self.glue.dirty {
            self.model.initialize(self.glue.start_time)?;
            self.glue.dirty = false;
        }
        Ok(())
    }

    /// fmi2SetupExperiment.
    pub(crate) fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start_time: f64,
        stop_time: Option<f64>,
    ) -> Outcome {
        if !start_time.is_finite() {
            return Err(Failure::error(format!(
                "startTime {} is not finite",
                Shown(start_time)
            )));
        }
        if let Some(stop) = stop_time {
            if !stop.is_finite() || stop < start_time {
                return Err(Failure::error(format!(
                    "stopTime {} must be finite and not before startTime {}",
                    Shown(stop),
                    Shown(start_time)
                )));
            }
        }
        self.glue.tolerance = tolerance;
        self.glue.start_time = start_time;
        self.glue.stop_time = stop_time;
        self.glue.time = start_time;
        let stop = stop_time.map_or_else(|| "undefined".to_owned(), |s| Shown(s).to_string());
        self.event(
            Function::SetupExperiment,
            &format!("startTime = {}, stopTime = {stop}", Shown(start_time)),
        );
        Ok(Status::Ok)
    }

    /// fmi2EnterInitializationMode. Marks the values dirty so the first get runs
    /// `initialize` even if nothing is set.
    pub(crate) fn enter_initialization_mode(&mut self) -> Outcome {
        self.glue.state = FmiState::InitializationMode;
        self.glue.dirty = true;
        self.glue.time = self.glue.start_time;
        self.event(
            Function::EnterInitializationMode,
            "entered initialization mode",
        );
        Ok(Status::Ok)
    }

    /// fmi2ExitInitializationMode: checks every declared range (values restored from an
    /// FMU state never went through a set call), then always runs `initialize(start_time)`.
    pub(crate) fn exit_initialization_mode(&mut self) -> Outcome {
        fmu_core::check_ranges(&self.model).map_err(Failure::error)?;
        self.model.initialize(self.glue.start_time)?;
        self.glue.dirty = false;
        self.glue.time = self.glue.start_time;
        self.glue.state = FmiState::StepComplete;
        self.event(
            Function::ExitInitializationMode,
            &format!("initialized at t = {}", Shown(self.glue.start_time)),
        );
        Ok(Status::Ok)
    }

    /// fmi2Terminate.
    pub(crate) fn terminate(&mut self) -> Outcome {
        self.glue.state = FmiState::Terminated;
        self.event(
            Function::Terminate,
            &format!("terminated at t = {}", Shown(self.glue.time)),
        );
        Ok(Status::Ok)
    }

    /// fmi2Reset: a fresh model with all start values; name, callbacks and logging stay.
    pub(crate) fn reset(&mut self) -> Outcome {
        self.model = M::new();
        self.glue = Glue::new();
        self.event(Function::Reset, "reset to start values");
        Ok(Status::Ok)
    }

    /// fmi2DoStep from `cp` by `h`.
    pub(crate) fn do_step(&mut self, cp: f64, h: f64) -> Outcome {
        // One test for a step that cannot be taken: h not finite or not > 0, cp not finite,
        // h below the spacing of doubles at cp (t + h = t), or an end beyond the largest
        // double. Each is told apart out of line.
        let end = cp + h;
        if !(end.is_finite() && end > cp) {
            return Err(self.step_cannot_advance(cp, h));
        }
        let t = self.glue.time;
        if (cp - t).abs() > time_tolerance(t) {
            return Err(self.cp_mismatch(cp));
        }
        if !M::CAN_HANDLE_VARIABLE_STEP {
            if let Some(h0) = self.glue.first_step {
                if (h - h0).abs() > 1e-9 * h0.abs() {
                    return Err(step_refused(format_args!(
                        "communicationStepSize {} differs from the first step size {}; this FMU \
                         needs a fixed step (canHandleVariableCommunicationStepSize=false)",
                        Shown(h),
                        Shown(h0)
                    )));
                }
            }
        }
        if let Some(stop) = self.glue.stop_time {
            if end > stop + time_tolerance(stop) {
                return Err(step_refused(format_args!(
                    "a step of {} from {} ends at {}, beyond the stop time {}",
                    Shown(h),
                    Shown(cp),
                    Shown(end),
                    Shown(stop)
                )));
            }
        }
        if let Err(e) = self.model.do_step(cp, h) {
            return Err(self.step_failed(cp, h, e));
        }
        self.glue.time = end;
        self.glue.first_step.get_or_insert(h);
        self.glue.last_step_status = Status::Ok;
        if let Some(remark) = self.model.take_warning() {
            return Err(self.step_warning(cp, h, remark));
        }
        Ok(Status::Ok)
    }

    /// Why [`Instance::do_step`] refused a step that would not move the time forward, in
    /// the order a user fixes them: the step size, the communication point, then a step
    /// too small to move the time off `cp` (the model would integrate by `h` while the
    /// FMU's time, and so every later communication point, stood still).
    #[cold]
    #[inline(never)]
    fn step_cannot_advance(&self, cp: f64, h: f64) -> Failure {
        if !(h.is_finite() && h > 0.0) {
            return step_refused(format_args!(
                "communicationStepSize {} must be finite and > 0",
                Shown(h)
            ));
        }
        if !cp.is_finite() {
            return self.cp_mismatch(cp);
        }
        if !(cp + h).is_finite() {
            return step_refused(format_args!(
                "a step of {} from {} ends beyond the largest double",
                Shown(h),
                Shown(cp)
            ));
        }
        step_refused(format_args!(
            "a step of {} from {} does not advance time: neighbouring times there are {} apart",
            Shown(h),
            Shown(cp),
            Shown(fmu_core::time_spacing(cp))
        ))
    }

    /// The error of a communication point other than the FMU's time. Out of line, as
    /// [`step_refused`].
    #[cold]
    #[inline(never)]
    fn cp_mismatch(&self, cp: f64) -> Failure {
        step_refused(format_args!(
            "currentCommunicationPoint {} does not match the FMU time {}",
            Shown(cp),
            Shown(self.glue.time)
        ))
    }

    /// The outcome of a model step that was taken with a remark: fmi2Warning, the step
    /// stands. Out of line, as [`step_refused`].
    #[cold]
    #[inline(never)]
    fn step_warning(&mut self, cp: f64, h: f64, remark: String) -> Failure {
        self.glue.last_step_status = Status::Warning;
        Failure::warning(format!(
            "step from {} by {} taken: {remark}",
            Shown(cp),
            Shown(h)
        ))
    }

    /// The outcome of a model step that failed: a Discard leaves the time where it was and
    /// moves to StepFailed. Out of line, as [`step_refused`].
    #[cold]
    #[inline(never)]
    fn step_failed(&mut self, cp: f64, h: f64, e: ModelError) -> Failure {
        if e.severity != Severity::Discard {
            return e.into();
        }
        self.glue.state = FmiState::StepFailed;
        self.glue.terminate_requested = true;
        self.glue.last_step_status = Status::Discard;
        Failure {
            status: Status::Discard,
            message: format!(
                "step from {} by {} discarded: {}",
                Shown(cp),
                Shown(h),
                e.message
            ),
        }
    }
}

/// The error of a doStep refused by its arguments. Out of line and cold: formatted in
/// place, the messages' code sat between the checks of every step (BENCHMARKS.md, round 33).
#[cold]
#[inline(never)]
fn step_refused(message: std::fmt::Arguments<'_>) -> Failure {
    Failure::error(message.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each status's messages go to the category named after it (fmi2Error →
    /// logStatusError), lifecycle messages (OK, Pending) to logEvents: a reordered table
    /// would file messages under the wrong name.
    #[test]
    fn each_status_is_logged_under_its_own_category() {
        for status in [
            Status::Ok,
            Status::Warning,
            Status::Discard,
            Status::Error,
            Status::Fatal,
            Status::Pending,
        ] {
            let expected = match status {
                Status::Ok | Status::Pending => "logEvents".to_owned(),
                other => format!("logStatus{}", other.name().trim_start_matches("fmi2")),
            };
            assert_eq!(
                LOG_CATEGORIES[category_of(status)].to_str(),
                Ok(expected.as_str()),
                "{status}"
            );
        }
    }
}
