//! The generic C-ABI wrappers that [`export_fmu!`](crate::export_fmu) forwards every FMI
//! function to, one `pub unsafe fn` per FMI 2.0 Co-Simulation function.
//!
//! Each instance function goes through one shared guard, in this order:
//! 1. the component must be a live instance of `M` (NULL, freed, made up or foreign →
//!    fmi2Error, no log possible since there is no logger to log to);
//! 2. the FMI 2.0 CS allowed-states table ([`Function::allowed_in`]): a violation logs
//!    `"fmi2DoStep: illegal call sequence in state Instantiated"` and returns fmi2Error;
//! 3. the body runs inside `catch_unwind`: it checks every pointer argument for NULL and
//!    every length before building a slice (`nvr = 0` with NULL arrays is legal), then
//!    calls the model;
//! 4. a failure is logged and escalated, still inside `catch_unwind`: fmi2Error moves the
//!    instance to [`FmiState::Terminated`], fmi2Fatal or a panic to [`FmiState::Fatal`].
//!
//! # Status escalation
//! As Reference-FMUs does, every fmi2Error an instance function returns (an illegal call
//! and a bad argument included) moves the instance to `Terminated`: FMI 2.0 §2.1.3 says
//! that after fmi2Error "the simulation cannot be continued with this FMU instance" except
//! by fmi2SetFMUstate to an earlier state, fmi2Reset or fmi2FreeInstance, and in
//! `Terminated` exactly those, the get functions (for diagnostics) and fmi2SetDebugLogging
//! remain allowed. fmi2Fatal moves it to `Fatal`, where only fmi2FreeInstance is.
//! fmi2Discard from fmi2DoStep moves it to `StepFailed`.
//!
//! # Safety contract of every wrapper
//! The arguments are those of the FMI 2.0 C function: the component may hold any value,
//! since only a handle [`instantiate`] issued and fmi2FreeInstance has not retired is
//! followed (see `handles`), and a live instance is used by one thread at a time; each
//! array pointer is NULL or valid for the length passed with it; each pointer to a
//! single value is NULL or valid for it; strings are NULL or NUL-terminated. An FMU state
//! (`fmi2FMUstate`) may hold any value, since only one this library handed out and has not
//! freed is ever read (see `snapshot::LIVE`), and is used by one thread at a time.

use std::ffi::{CStr, c_char, c_void};
use std::panic::{self, AssertUnwindSafe};
use std::ptr;

use crate::handles;
use crate::instance::{Access, Failure, Instance, LogSink, Outcome};
use crate::snapshot::{DecodeError, NotOurs, Snapshot};
use crate::state::{FmiState, Function};
use fmi2_sys::{
    FMI_VERSION, FMI2_CO_SIMULATION, FMI2_FALSE, FMI2_TRUE, Fmi2Boolean, Fmi2Byte,
    Fmi2CallbackFunctions, Fmi2Component, Fmi2FmuState, Fmi2Integer, Fmi2Real, Fmi2Status,
    Fmi2StatusKind, Fmi2String, Fmi2Type, Fmi2ValueReference, Status, TYPES_PLATFORM, status_kind,
};
use fmu_core::{Model, VarType, VrRun};

/// The text of a panic payload (`&str` or `String`, as `panic!` produces).
fn panic_message(payload: &(dyn std::any::Any + Send)) -> &str {
    payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("(non-string panic payload)")
}

/// The shared guard of every instance function (see the module documentation).
///
/// # Safety
/// `c` satisfies the module's safety contract.
unsafe fn guard<M: Model>(
    c: Fmi2Component,
    function: Function,
    body: impl FnOnce(&mut Instance<M>) -> Outcome,
) -> Fmi2Status {
    // SAFETY: any value is checked against the live handles; a live instance is used by
    // this thread only (module contract).
    let Some(inst) = (unsafe { Instance::<M>::from_component(c) }) else {
        return Status::Error.into();
    };
    if !function.allowed_in(inst.glue.state) {
        return refuse_call(inst, function);
    }
    // The body's outcome becomes the C status inside `catch_unwind`: what crosses it is
    // one `c_int`, stored and read back whole. Crossing it as an `Outcome`, the success's
    // 4-byte status was stored and then read as 8 bytes, a load the processor cannot
    // forward from the store, and every fmi2DoStep waited for it (BENCHMARKS.md, round 37).
    // A panic while a failure is reported is caught too.
    let outcome = panic::catch_unwind(AssertUnwindSafe(|| match body(&mut *inst) {
        Ok(status) => status.into(),
        Err(failure) => report_failure(inst, function, failure),
    }));
    outcome.unwrap_or_else(|payload| report_panic(inst, function, payload))
}

// The guard's three ways out other than success, each out of line and cold: inlined into
// every FMI function, their formatting and logging split the per-step path over more cache
// lines than it runs (BENCHMARKS.md, round 33).

/// A call that the instance's state does not allow.
#[cold]
#[inline(never)]
fn refuse_call<M: Model>(inst: &mut Instance<M>, function: Function) -> Fmi2Status {
    let hint = function.illegal_call_hint();
    let name = inst.glue.state_name();
    let cause = inst.glue.error_from().map_or_else(String::new, |f| {
        format!(
            " (entered when {} returned fmi2Error; fmi2Reset or fmi2SetFMUstate continue)",
            f.name()
        )
    });
    inst.log(
        Status::Error,
        function,
        &format!("illegal call sequence in state {name}{cause}{hint}"),
    );
    inst.escalate(Status::Error, function);
    Status::Error.into()
}

/// A call whose body failed (a warning, discard, error or fatal) with `failure`'s message.
#[cold]
#[inline(never)]
fn report_failure<M: Model>(
    inst: &mut Instance<M>,
    function: Function,
    failure: Failure,
) -> Fmi2Status {
    inst.log(failure.status, function, &failure.message);
    inst.escalate(failure.status, function);
    failure.status.into()
}

/// A call whose body panicked.
#[cold]
#[inline(never)]
fn report_panic<M: Model>(
    inst: &mut Instance<M>,
    function: Function,
    payload: Box<dyn std::any::Any + Send>,
) -> Fmi2Status {
    // The model may be half-updated: nothing but fmi2FreeInstance may touch it.
    inst.escalate(Status::Fatal, function);
    inst.log(
        Status::Fatal,
        function,
        &format!("panic in the model: {}", panic_message(&*payload)),
    );
    Status::Fatal.into()
}

/// `ptr[..n]` as a slice, refusing NULL (unless `n == 0`), misalignment and sizes that
/// overflow `isize`.
///
/// # Safety
/// `ptr` is NULL or valid for reading `n` elements for `'a`.
#[inline]
unsafe fn input<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], Failure> {
    if n == 0 {
        return Ok(&[]);
    }
    check_array(ptr, n, what)?;
    // SAFETY: non-NULL, aligned, size fits isize (checked above); valid for `n`
    // elements per this function's contract.
    Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
}

/// `ptr[..n]` as a mutable slice (same checks as [`input`]).
///
/// # Safety
/// `ptr` is NULL or valid for writing `n` elements for `'a`, aliased by nothing else.
#[inline]
unsafe fn output<'a, T>(ptr: *mut T, n: usize, what: &str) -> Result<&'a mut [T], Failure> {
    if n == 0 {
        return Ok(&mut []);
    }
    check_array(ptr, n, what)?;
    // SAFETY: as in `input`; exclusivity per this function's contract.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

/// Inlined, the accepted case is three comparisons; the messages are built out of line.
#[inline]
fn check_array<T>(ptr: *const T, n: usize, what: &str) -> Result<(), Failure> {
    if ptr.is_null() || !ptr.is_aligned() || n > isize::MAX as usize / size_of::<T>().max(1) {
        return Err(bad_array(ptr, n, what));
    }
    Ok(())
}

#[cold]
#[inline(never)]
fn bad_array<T>(ptr: *const T, n: usize, what: &str) -> Failure {
    Failure::error(if ptr.is_null() {
        format!("argument {what} is NULL but its length is {n}")
    } else if !ptr.is_aligned() {
        format!("argument {what} is misaligned")
    } else {
        format!("argument {what} has an impossible length {n}")
    })
}

/// A single-value out-pointer as a reference (NULL and misalignment refused).
///
/// # Safety
/// `ptr` is NULL or valid for writing a `T` for `'a`, aliased by nothing else.
unsafe fn out_ref<'a, T>(ptr: *mut T, what: &str) -> Result<&'a mut T, Failure> {
    if ptr.is_null() {
        return Err(Failure::error(format!("argument {what} is NULL")));
    }
    if !ptr.is_aligned() {
        return Err(Failure::error(format!("argument {what} is misaligned")));
    }
    // SAFETY: non-NULL, aligned, writable and exclusive per this function's contract.
    Ok(unsafe { &mut *ptr })
}

/// A C string argument, NULL refused, invalid UTF-8 replaced.
///
/// # Safety
/// `s` is NULL or NUL-terminated and readable.
unsafe fn c_str(s: Fmi2String, what: &str) -> Result<String, Failure> {
    if s.is_null() {
        return Err(Failure::error(format!("argument {what} is NULL")));
    }
    // SAFETY: non-NULL and NUL-terminated per this function's contract.
    Ok(unsafe { CStr::from_ptr(s) }.to_string_lossy().into_owned())
}

fn fmi_bool(b: Fmi2Boolean) -> bool {
    b != FMI2_FALSE
}

fn to_fmi_bool(b: bool) -> Fmi2Boolean {
    if b { FMI2_TRUE } else { FMI2_FALSE }
}

// ---------------------------------------------------------------------------------------
// Functions without an instance
// ---------------------------------------------------------------------------------------

/// fmi2GetTypesPlatform: `"default"` (generic only so that every entry of the function table
/// has the same shape).
pub fn get_types_platform<M>() -> *const c_char {
    TYPES_PLATFORM.as_ptr()
}

/// fmi2GetVersion: `"2.0"` (generic like [`get_types_platform`]).
pub fn get_version<M>() -> *const c_char {
    FMI_VERSION.as_ptr()
}

/// fmi2Instantiate: a new instance of `M`, or NULL.
///
/// Returns NULL for: `functions` NULL or without a logger (FMI 2.0 gives the FMU no other
/// way to report errors, so this glue requires it; `allocateMemory`/`freeMemory` are not
/// used, the model descriptions declare `canNotUseMemoryManagementFunctions="true"`, and
/// `stepFinished` is unused as steps are synchronous); `instanceName` NULL, empty or only
/// white space;
/// `fmuType` other than fmi2CoSimulation; `fmuGUID` NULL or different from `M::GUID`; a
/// panic in `M::new()`; `handles::MAX_LIVE` instances of this library alive already. Each
/// case is logged with status fmi2Error when the logger is usable. `fmuResourceLocation`
/// and `visible` are ignored. The component returned is a handle (see `handles`), not
/// the instance's address.
///
/// # Safety
/// `functions` is NULL or points to a valid `fmi2CallbackFunctions` whose logger stays
/// callable while the instance lives; the strings are NULL or NUL-terminated.
pub unsafe fn instantiate<M: Model>(
    instance_name: Fmi2String,
    fmu_type: Fmi2Type,
    fmu_guid: Fmi2String,
    _fmu_resource_location: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    _visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    if functions.is_null() || !functions.cast::<Fmi2CallbackFunctions>().is_aligned() {
        return ptr::null_mut();
    }
    // SAFETY: non-NULL and aligned; valid per this function's contract. Copied, as FMI
    // 2.0 does not require the struct itself to outlive this call.
    let callbacks = unsafe { *functions };
    let Some(logger) = callbacks.logger else {
        return ptr::null_mut();
    };
    let sink = LogSink::new(logger, callbacks.component_environment);
    let fail = |name: &CStr, text: String| {
        sink.emit(name, Status::Error, &format!("fmi2Instantiate: {text}"));
        ptr::null_mut()
    };
    if instance_name.is_null() {
        return fail(c"", "instanceName is NULL".to_owned());
    }
    // SAFETY: non-NULL and NUL-terminated per this function's contract.
    let name = unsafe { CStr::from_ptr(instance_name) }.to_owned();
    if name.is_empty() {
        return fail(&name, "instanceName is empty".to_owned());
    }
    if String::from_utf8_lossy(name.to_bytes()).trim().is_empty() {
        return fail(
            &name,
            format!(
                "instanceName {:?} is only white space; FMI 2.0 asks for at least one other \
                 character",
                String::from_utf8_lossy(name.to_bytes())
            ),
        );
    }
    if fmu_type != FMI2_CO_SIMULATION {
        return fail(
            &name,
            format!(
                "fmuType {fmu_type} is not fmi2CoSimulation ({FMI2_CO_SIMULATION}); \
                 {} supports Co-Simulation only",
                M::MODEL_IDENTIFIER
            ),
        );
    }
    // SAFETY: NULL or NUL-terminated per this function's contract.
    let guid = match unsafe { c_str(fmu_guid, "fmuGUID") } {
        Ok(g) => g,
        Err(f) => return fail(&name, format!("{}; expected GUID '{}'", f.message, M::GUID)),
    };
    if guid != M::GUID {
        return fail(
            &name,
            format!("GUID mismatch: expected '{}', received '{guid}'", M::GUID),
        );
    }
    let created = panic::catch_unwind(|| M::new());
    let model = match created {
        Ok(m) => m,
        Err(payload) => {
            sink.emit(
                &name,
                Status::Fatal,
                &format!(
                    "fmi2Instantiate: panic in the model: {}",
                    panic_message(&*payload)
                ),
            );
            return ptr::null_mut();
        }
    };
    let Some(reservation) = handles::reserve() else {
        return fail(
            &name,
            format!(
                "{} instances of this FMU library are alive, the most it allows; \
                 free one (fmi2FreeInstance) before instantiating another",
                handles::MAX_LIVE
            ),
        );
    };
    let inst = Box::new(Instance::new(model, name, sink, fmi_bool(logging_on)));
    inst.log_as(
        Status::Ok,
        "fmi2Instantiate",
        &format!("instance of {} created", M::MODEL_IDENTIFIER),
    );
    reservation.issue(Box::into_raw(inst).cast::<c_void>())
}

/// fmi2FreeInstance: releases the instance and everything it owns. NULL, or a component
/// that is not a live instance of `M` (freed already, say), is a no-op.
///
/// # Safety
/// See the module's safety contract; the master gives up `c` with this call.
pub unsafe fn free_instance<M: Model>(c: Fmi2Component) {
    // SAFETY: `c` satisfies the module contract.
    let Some(inst) = (unsafe { Instance::<M>::from_component(c) }) else {
        return;
    };
    // Allowed in every state, Fatal included (see `state`), so no table check here.
    inst.event(Function::FreeInstance, "instance freed");
    // The handle is retired before the memory goes, so no call reaches the instance.
    let Some(p) = handles::release(c) else {
        return;
    };
    // SAFETY: `p` is the instance `from_component` found, a `Box::into_raw` of an
    // `Instance<M>` in `instantiate::<M>`; its handle is retired, so no function reaches
    // it again, and the reference `inst` is no longer used.
    let boxed = unsafe { Box::from_raw(p.cast::<Instance<M>>()) };
    // A panicking Drop in the model must not unwind into the master; the memory is then
    // leaked, the only safe option once a destructor has failed.
    let _ = panic::catch_unwind(AssertUnwindSafe(move || drop(boxed)));
    // SAFETY: `c` was an instance of `M`, now freed; the master holds no reference into
    // its FMU states during this call (module contract).
    let _ = panic::catch_unwind(|| unsafe { Snapshot::<M>::free_owned_by(c.addr()) });
}

/// fmi2SetDebugLogging: `nCategories = 0` switches every category of
/// [`LOG_CATEGORIES`](super::LOG_CATEGORIES) to `loggingOn`, otherwise only the named
/// ones; an unknown name is skipped with an fmi2Warning that names it.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn set_debug_logging<M: Model>(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n_categories: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    let body = |inst: &mut Instance<M>| {
        // SAFETY: NULL or valid for `n_categories` elements (module contract).
        let raw = unsafe { input(categories, n_categories, "categories[]") }?;
        let mut names = Vec::with_capacity(raw.len());
        for (i, &p) in raw.iter().enumerate() {
            // SAFETY: each entry is NULL or NUL-terminated (module contract).
            names.push(unsafe { c_str(p, &format!("categories[{i}]")) }?);
        }
        inst.set_debug_logging(fmi_bool(logging_on), &names)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::SetDebugLogging, body) }
}

/// fmi2SetupExperiment: stores start time, optional stop time and tolerance (the
/// tolerance is only stored). The FMU time becomes `startTime`.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn setup_experiment<M: Model>(
    c: Fmi2Component,
    tolerance_defined: Fmi2Boolean,
    tolerance: Fmi2Real,
    start_time: Fmi2Real,
    stop_time_defined: Fmi2Boolean,
    stop_time: Fmi2Real,
) -> Fmi2Status {
    let tolerance = fmi_bool(tolerance_defined).then_some(tolerance);
    let stop_time = fmi_bool(stop_time_defined).then_some(stop_time);
    let body = |inst: &mut Instance<M>| inst.setup_experiment(tolerance, start_time, stop_time);
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::SetupExperiment, body) }
}

/// fmi2EnterInitializationMode.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn enter_initialization_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    // SAFETY: `c` satisfies the module contract.
    unsafe {
        guard(
            c,
            Function::EnterInitializationMode,
            |inst: &mut Instance<M>| inst.enter_initialization_mode(),
        )
    }
}

/// fmi2ExitInitializationMode: runs [`Model::initialize`] at the start time.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn exit_initialization_mode<M: Model>(c: Fmi2Component) -> Fmi2Status {
    // SAFETY: `c` satisfies the module contract.
    unsafe {
        guard(
            c,
            Function::ExitInitializationMode,
            |inst: &mut Instance<M>| inst.exit_initialization_mode(),
        )
    }
}

/// fmi2Terminate.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn terminate<M: Model>(c: Fmi2Component) -> Fmi2Status {
    // SAFETY: `c` satisfies the module contract.
    unsafe {
        guard(c, Function::Terminate, |inst: &mut Instance<M>| {
            inst.terminate()
        })
    }
}

/// fmi2Reset: back to Instantiated with `M::new()`; name, callbacks and logging stay.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn reset<M: Model>(c: Fmi2Component) -> Fmi2Status {
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::Reset, |inst: &mut Instance<M>| inst.reset()) }
}

// ---------------------------------------------------------------------------------------
// Get and set
// ---------------------------------------------------------------------------------------

/// Shared body of the typed getters: all value references are checked before any value
/// is read; in InitializationMode `initialize` is re-run first if something was set.
/// `read` fills the whole batch, given the batch's runs of consecutive value references.
///
/// # Safety
/// See the module's safety contract.
unsafe fn get_values<M: Model, T>(
    c: Fmi2Component,
    function: Function,
    access: Access,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut T,
    read: impl Fn(&M, &[u32], &[VrRun], &mut [T]),
) -> Fmi2Status {
    let body = |inst: &mut Instance<M>| {
        // SAFETY: NULL or valid for `nvr` elements (module contract).
        let vrs = unsafe { input(vr, nvr, "vr[]") }?;
        // SAFETY: NULL or valid for writing `nvr` elements, not aliased (module contract).
        let out = unsafe { output(value, nvr, "value[]") }?;
        inst.accept(function, access, false, vrs)?;
        if nvr > 0 {
            inst.refresh_if_dirty()?;
        }
        let (model, runs) = inst.model_and_runs(access, false);
        read(model, vrs, runs, out);
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, function, body) }
}

/// Shared body of the typed setters: every value reference is checked (declared, right
/// type, settable in this state) and every value against the variable's declared
/// `min`/`max` (`numeric` gives the value as a number; `None` for Booleans) before the
/// first value is written, so a refused call changes nothing. `write` gets the whole batch:
/// Reals go to [`Model::set_reals`], which for a `values_model!` FMU also refuses NaN and
/// infinities before writing any value.
///
/// # Safety
/// See the module's safety contract.
#[allow(clippy::too_many_arguments)] // the C signature's four plus what selects the type
unsafe fn set_values<M: Model, T: Copy>(
    c: Fmi2Component,
    function: Function,
    access: Access,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const T,
    numeric: fn(T) -> Option<f64>,
    write: impl Fn(&mut M, &[u32], &[VrRun], &[T]) -> fmu_core::ModelResult<()>,
) -> Fmi2Status {
    let body = |inst: &mut Instance<M>| {
        // SAFETY: NULL or valid for `nvr` elements (module contract).
        let vrs = unsafe { input(vr, nvr, "vr[]") }?;
        // SAFETY: NULL or valid for `nvr` elements (module contract).
        let values = unsafe { input(value, nvr, "value[]") }?;
        let (specs, ranged) = inst.accept(function, access, true, vrs)?;
        if ranged {
            for (spec, &v) in specs.iter().zip(values) {
                if let Some(x) = numeric(v) {
                    spec.check_range(x).map_err(Failure::error)?;
                }
            }
        }
        if nvr > 0 {
            inst.glue.dirty = true;
        }
        let (model, runs) = inst.model_and_runs(access, true);
        write(model, vrs, runs, values)?;
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, function, body) }
}

/// A batch reader from a reader of one value.
fn each<M, T>(read: impl Fn(&M, u32) -> T) -> impl Fn(&M, &[u32], &[VrRun], &mut [T]) {
    move |m, vrs, _, out| {
        for (o, &r) in out.iter_mut().zip(vrs) {
            *o = read(m, r);
        }
    }
}

/// fmi2GetReal.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_real<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    // SAFETY: forwarded module contract.
    unsafe {
        get_values(
            c,
            Function::GetReal,
            Access::Real,
            vr,
            nvr,
            value,
            M::get_reals,
        )
    }
}

/// fmi2GetInteger (Integer and Enumeration variables).
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_integer<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    // SAFETY: forwarded module contract.
    unsafe {
        get_values(
            c,
            Function::GetInteger,
            Access::Integer,
            vr,
            nvr,
            value,
            each(M::get_integer),
        )
    }
}

/// fmi2GetBoolean.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_boolean<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    let read = each(|m: &M, r: u32| to_fmi_bool(m.get_boolean(r)));
    // SAFETY: forwarded module contract.
    unsafe {
        get_values(
            c,
            Function::GetBoolean,
            Access::Boolean,
            vr,
            nvr,
            value,
            read,
        )
    }
}

/// The error for a String value reference: these models declare no String variables.
fn no_string_variable<M: Model>(vr: u32) -> Failure {
    let declared = M::VARIABLES
        .iter()
        .any(|v| v.value_reference == vr && v.var_type == VarType::String);
    Failure::error(if declared {
        format!("String variable with value reference {vr} is not supported by this FMU glue")
    } else {
        format!("unknown value reference {vr} (this FMU has no String variables)")
    })
}

/// fmi2GetString: every value reference is an error (no String variables).
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_string<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2String,
) -> Fmi2Status {
    let body = |_: &mut Instance<M>| {
        // SAFETY: NULL or valid for `nvr` elements (module contract).
        let vrs = unsafe { input(vr, nvr, "vr[]") }?;
        // SAFETY: NULL or valid for writing `nvr` elements (module contract).
        unsafe { output(value, nvr, "value[]") }?;
        match vrs.first() {
            Some(&r) => Err(no_string_variable::<M>(r)),
            None => Ok(Status::Ok),
        }
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::GetString, body) }
}

/// fmi2SetReal. Model rejections (e.g. a NaN input) are returned with their status.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn set_real<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Real,
) -> Fmi2Status {
    // SAFETY: forwarded module contract.
    unsafe {
        set_values(
            c,
            Function::SetReal,
            Access::Real,
            vr,
            nvr,
            value,
            Some,
            M::set_reals,
        )
    }
}

/// fmi2SetInteger (Integer and Enumeration variables).
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn set_integer<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Integer,
) -> Fmi2Status {
    // SAFETY: forwarded module contract.
    unsafe {
        set_values(
            c,
            Function::SetInteger,
            Access::Integer,
            vr,
            nvr,
            value,
            |x| Some(f64::from(x)),
            |m: &mut M, vrs: &[u32], _: &[VrRun], values: &[Fmi2Integer]| {
                vrs.iter()
                    .zip(values)
                    .try_for_each(|(&r, &v)| m.set_integer(r, v))
            },
        )
    }
}

/// fmi2SetBoolean (any non-zero value is true).
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn set_boolean<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    let write = |m: &mut M, vrs: &[u32], _: &[VrRun], values: &[Fmi2Boolean]| {
        vrs.iter()
            .zip(values)
            .try_for_each(|(&r, &v)| m.set_boolean(r, fmi_bool(v)))
    };
    // SAFETY: forwarded module contract.
    unsafe {
        set_values(
            c,
            Function::SetBoolean,
            Access::Boolean,
            vr,
            nvr,
            value,
            |_| None,
            write,
        )
    }
}

/// fmi2SetString: every value reference is an error (no String variables).
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn set_string<M: Model>(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2String,
) -> Fmi2Status {
    let body = |_: &mut Instance<M>| {
        // SAFETY: NULL or valid for `nvr` elements (module contract).
        let vrs = unsafe { input(vr, nvr, "vr[]") }?;
        // SAFETY: NULL or valid for `nvr` elements (module contract).
        unsafe { input(value, nvr, "value[]") }?;
        match vrs.first() {
            Some(&r) => Err(no_string_variable::<M>(r)),
            None => Ok(Status::Ok),
        }
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::SetString, body) }
}

// ---------------------------------------------------------------------------------------
// FMU state
// ---------------------------------------------------------------------------------------

/// The message for an `fmi2FMUstate` argument `what` that is not a live snapshot of `M`.
fn not_ours<M: Model>(why: NotOurs, what: &str) -> Failure {
    Failure::error(match why {
        NotOurs::NotLive => format!(
            "{what} is not a live FMU state of this FMU: fmi2GetFMUstate or \
             fmi2DeSerializeFMUstate never returned it, or it has been freed (by \
             fmi2FreeFMUstate, or by fmi2FreeInstance of the instance that allocated it)"
        ),
        NotOurs::OtherModel => format!(
            "{what} is not an FMU state of this model ({}, GUID {})",
            M::MODEL_IDENTIFIER,
            M::GUID
        ),
    })
}

/// The snapshot behind an `fmi2FMUstate` argument; NULL, freed and foreign pointers
/// refused.
///
/// # Safety
/// As [`Snapshot::from_ptr`]: the snapshot is not otherwise referenced during the call.
unsafe fn snapshot_arg<'a, M: Model>(
    p: Fmi2FmuState,
    what: &str,
) -> Result<&'a mut Snapshot<M>, Failure> {
    if p.is_null() {
        return Err(Failure::error(format!("argument {what} is NULL")));
    }
    // SAFETY: forwarded contract of this function.
    unsafe { Snapshot::<M>::from_ptr(p) }.map_err(|why| not_ours::<M>(why, what))
}

/// Stores `snap` into `*slot`: a new allocation, owned by the instance at `owner`, if
/// `*slot` is NULL, else overwriting the snapshot it points to (which must be a live one
/// of this model's).
///
/// # Safety
/// As [`snapshot_arg`] for `*slot`.
unsafe fn store_snapshot<M: Model>(
    slot: &mut Fmi2FmuState,
    snap: Snapshot<M>,
    owner: Fmi2Component,
) -> Result<(), Failure> {
    if slot.is_null() {
        *slot = snap.into_raw(owner.addr());
    } else {
        // SAFETY: forwarded contract of this function.
        *unsafe { snapshot_arg::<M>(*slot, "*FMUstate") }? = snap;
    }
    Ok(())
}

/// fmi2GetFMUstate: a snapshot of the model and the glue bookkeeping (FMI state, times,
/// first step size, status flags) into `*state`, allocated if `*state` is NULL (and freed
/// with this instance unless the master frees it first), else overwriting that snapshot.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_fmu_state<M: Model>(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    let body = |inst: &mut Instance<M>| {
        // SAFETY: NULL or valid for writing one pointer (module contract).
        let slot = unsafe { out_ref(state, "FMUstate") }?;
        let snap = Snapshot::new(inst.model.clone(), inst.glue);
        // SAFETY: the module contract (FMU states are used by one thread at a time).
        unsafe { store_snapshot(slot, snap, c) }?;
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::GetFmuState, body) }
}

/// fmi2SetFMUstate: restores a snapshot of this model (NULL, freed or foreign refused),
/// including the FMI state it was taken in.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn set_fmu_state<M: Model>(c: Fmi2Component, state: Fmi2FmuState) -> Fmi2Status {
    let body = |inst: &mut Instance<M>| {
        // SAFETY: any pointer value is checked before it is read; the module contract
        // (FMU states are used by one thread at a time) keeps the reference exclusive.
        let snap = unsafe { snapshot_arg::<M>(state, "FMUstate") }?;
        inst.model = snap.model.clone();
        inst.glue = snap.glue;
        inst.event(
            Function::SetFmuState,
            &format!(
                "restored state {} at t = {}",
                inst.glue.state_name(),
                fmu_core::Shown(inst.glue.time)
            ),
        );
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::SetFmuState, body) }
}

/// fmi2FreeFMUstate: frees `*state` and sets it to NULL (`*state` NULL: no-op). Any
/// instance of the model may free it; one already freed is an fmi2Error, not a double free.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn free_fmu_state<M: Model>(c: Fmi2Component, state: *mut Fmi2FmuState) -> Fmi2Status {
    let body = |_: &mut Instance<M>| {
        // SAFETY: NULL or valid for one pointer (module contract).
        let slot = unsafe { out_ref(state, "FMUstate") }?;
        if slot.is_null() {
            return Ok(Status::Ok);
        }
        // SAFETY: the module contract (FMU states are used by one thread at a time), and
        // no reference to the snapshot is held here.
        unsafe { Snapshot::<M>::free(*slot) }.map_err(|why| not_ours::<M>(why, "*FMUstate"))?;
        *slot = ptr::null_mut();
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::FreeFmuState, body) }
}

/// fmi2SerializedFMUstateSize: the exact byte size [`serialize_fmu_state`] needs.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn serialized_fmu_state_size<M: Model>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    size: *mut usize,
) -> Fmi2Status {
    let body = |_: &mut Instance<M>| {
        // SAFETY: any pointer value is checked before it is read; the module contract
        // (FMU states are used by one thread at a time) keeps the reference exclusive.
        let snap = unsafe { snapshot_arg::<M>(state, "FMUstate") }?;
        // SAFETY: NULL or valid for writing one size_t (module contract).
        *unsafe { out_ref(size, "size") }? = snap.encode().len();
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::SerializedFmuStateSize, body) }
}

/// fmi2SerializeFMUstate: writes the format documented in `snapshot` into a buffer of
/// exactly the size fmi2SerializedFMUstateSize reported.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn serialize_fmu_state<M: Model>(
    c: Fmi2Component,
    state: Fmi2FmuState,
    serialized_state: *mut Fmi2Byte,
    size: usize,
) -> Fmi2Status {
    let body = |_: &mut Instance<M>| {
        // SAFETY: any pointer value is checked before it is read; the module contract
        // (FMU states are used by one thread at a time) keeps the reference exclusive.
        let bytes = unsafe { snapshot_arg::<M>(state, "FMUstate") }?.encode();
        if size != bytes.len() {
            return Err(Failure::error(format!(
                "size {size} does not match the serialized size {} (see fmi2SerializedFMUstateSize)",
                bytes.len()
            )));
        }
        // SAFETY: NULL or valid for writing `size` bytes (module contract); fmi2Byte
        // (char) and u8 have the same size and alignment.
        let out = unsafe { output(serialized_state.cast::<u8>(), size, "serializedState[]") }?;
        out.copy_from_slice(&bytes);
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::SerializeFmuState, body) }
}

/// fmi2DeSerializeFMUstate: validates a serialized state (magic, version, model
/// identifier and GUID, glue fields, exact length) and restores its payload into a new
/// snapshot, whose pointer goes to `*state`. Every rejection names what is wrong.
///
/// A live snapshot of this model in `*state` is overwritten and kept, as fmi2GetFMUstate
/// does and as Reference-FMUs and fmpy expect; any other value (NULL, freed, made up, an
/// uninitialised variable) is only compared against the live snapshots, never followed,
/// and replaced by a new one.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn de_serialize_fmu_state<M: Model>(
    c: Fmi2Component,
    serialized_state: *const Fmi2Byte,
    size: usize,
    state: *mut Fmi2FmuState,
) -> Fmi2Status {
    let body = |_: &mut Instance<M>| {
        // SAFETY: NULL or valid for writing one pointer (module contract).
        let slot = unsafe { out_ref(state, "FMUstate") }?;
        // SAFETY: NULL or valid for `size` bytes (module contract); see serialize.
        let bytes = unsafe { input(serialized_state.cast::<u8>(), size, "serializedState[]") }?;
        let snap = Snapshot::<M>::decode(bytes).map_err(|e| match e {
            DecodeError::Invalid(message) => Failure::error(message),
            DecodeError::Model(e) => Failure::from(e),
        })?;
        // A live snapshot of this model in `*slot` is reused, as fmi2GetFMUstate reuses
        // one (fmpy passes the previous state for that): allocating beside it would leave
        // it unreachable to a master that overwrites its handle, until fmi2FreeInstance.
        // Any other value is overwritten: the standard does not ask callers to set
        // `*FMUstate` before this call, so it may hold anything.
        // SAFETY: the pointer in `*slot` is followed only if the registry lists it as a
        // live snapshot (`from_ptr` checks before reading); the module contract keeps the
        // reference exclusive.
        match unsafe { Snapshot::<M>::from_ptr(*slot) } {
            Ok(old) => *old = snap,
            Err(_) => *slot = snap.into_raw(c.addr()),
        }
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::DeSerializeFmuState, body) }
}

/// fmi2GetDirectionalDerivative: not supported (`providesDirectionalDerivative=false`);
/// fmi2Error after the state check.
///
/// # Safety
/// See the module's safety contract (no pointer is dereferenced).
pub unsafe fn get_directional_derivative<M: Model>(
    c: Fmi2Component,
    _v_unknown_ref: *const Fmi2ValueReference,
    _n_unknown: usize,
    _v_known_ref: *const Fmi2ValueReference,
    _n_known: usize,
    _dv_known: *const Fmi2Real,
    _dv_unknown: *mut Fmi2Real,
) -> Fmi2Status {
    // SAFETY: `c` satisfies the module contract.
    unsafe {
        unsupported::<M>(
            c,
            Function::GetDirectionalDerivative,
            "providesDirectionalDerivative=false",
        )
    }
}

/// Body of the functions whose capability is off: fmi2Error naming the capability.
///
/// # Safety
/// See the module's safety contract.
unsafe fn unsupported<M: Model>(
    c: Fmi2Component,
    function: Function,
    capability: &str,
) -> Fmi2Status {
    let body = |_: &mut Instance<M>| {
        Err(Failure::error(format!(
            "not supported by this FMU ({capability})"
        )))
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, function, body) }
}

// ---------------------------------------------------------------------------------------
// Co-Simulation
// ---------------------------------------------------------------------------------------

/// fmi2SetRealInputDerivatives: not supported (`canInterpolateInputs=false`).
///
/// # Safety
/// See the module's safety contract (no pointer is dereferenced).
pub unsafe fn set_real_input_derivatives<M: Model>(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *const Fmi2Real,
) -> Fmi2Status {
    // SAFETY: `c` satisfies the module contract.
    unsafe {
        unsupported::<M>(
            c,
            Function::SetRealInputDerivatives,
            "canInterpolateInputs=false",
        )
    }
}

/// fmi2GetRealOutputDerivatives: not supported (`maxOutputDerivativeOrder=0`).
///
/// # Safety
/// See the module's safety contract (no pointer is dereferenced).
pub unsafe fn get_real_output_derivatives<M: Model>(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *mut Fmi2Real,
) -> Fmi2Status {
    // SAFETY: `c` satisfies the module contract.
    unsafe {
        unsupported::<M>(
            c,
            Function::GetRealOutputDerivatives,
            "maxOutputDerivativeOrder=0",
        )
    }
}

/// fmi2DoStep: checks the step (h finite and > 0; `currentCommunicationPoint` equal to
/// the FMU time within 1e-9·max(1, |t|); the first step size again for fixed-step models;
/// not beyond the stop time) and calls [`Model::do_step`]. On success the FMU time
/// becomes exactly `cp + h`; a model Discard leaves the time and moves to StepFailed.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn do_step<M: Model>(
    c: Fmi2Component,
    current_communication_point: Fmi2Real,
    communication_step_size: Fmi2Real,
    _no_set_fmu_state_prior_to_current_point: Fmi2Boolean,
) -> Fmi2Status {
    let body =
        |inst: &mut Instance<M>| inst.do_step(current_communication_point, communication_step_size);
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::DoStep, body) }
}

/// fmi2CancelStep: only legal while an asynchronous step is in progress, which never
/// happens here, so the state check always rejects it with a message saying so.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn cancel_step<M: Model>(c: Fmi2Component) -> Fmi2Status {
    // SAFETY: `c` satisfies the module contract.
    unsafe { unsupported::<M>(c, Function::CancelStep, "canRunAsynchronuously=false") }
}

/// Status kinds this FMU does not answer: fmi2Discard for a defined kind (as
/// Reference-FMUs does), fmi2Error for a value outside the enumeration.
fn unavailable_status(function: Function, kind: Fmi2StatusKind) -> Outcome {
    let name = match kind {
        status_kind::DO_STEP_STATUS => "fmi2DoStepStatus",
        status_kind::PENDING_STATUS => "fmi2PendingStatus",
        status_kind::LAST_SUCCESSFUL_TIME => "fmi2LastSuccessfulTime",
        status_kind::TERMINATED => "fmi2Terminated",
        other => return Err(Failure::error(format!("invalid fmi2StatusKind {other}"))),
    };
    Err(Failure {
        status: Status::Discard,
        message: format!(
            "status kind {name} is not available from {}",
            function.name()
        ),
    })
}

/// fmi2GetStatus: `fmi2DoStepStatus` gives the status of the last fmi2DoStep (steps are
/// synchronous, so never fmi2Pending); other kinds → fmi2Discard.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Status,
) -> Fmi2Status {
    let body = |inst: &mut Instance<M>| {
        // SAFETY: NULL or valid for writing one value (module contract).
        let out = unsafe { out_ref(value, "value") }?;
        if kind != status_kind::DO_STEP_STATUS {
            return unavailable_status(Function::GetStatus, kind);
        }
        *out = inst.glue.last_step_status.into();
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::GetStatus, body) }
}

/// fmi2GetRealStatus: `fmi2LastSuccessfulTime` is the FMU time (after a discarded step,
/// the time before it); other kinds → fmi2Discard.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_real_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    let body = |inst: &mut Instance<M>| {
        // SAFETY: NULL or valid for writing one value (module contract).
        let out = unsafe { out_ref(value, "value") }?;
        if kind != status_kind::LAST_SUCCESSFUL_TIME {
            return unavailable_status(Function::GetRealStatus, kind);
        }
        *out = inst.glue.time;
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::GetRealStatus, body) }
}

/// fmi2GetIntegerStatus: FMI 2.0 defines no Integer status kinds → fmi2Discard.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_integer_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    let body = |_: &mut Instance<M>| {
        // SAFETY: NULL or valid for writing one value (module contract).
        unsafe { out_ref(value, "value") }?;
        unavailable_status(Function::GetIntegerStatus, kind)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::GetIntegerStatus, body) }
}

/// fmi2GetBooleanStatus: `fmi2Terminated` is true after the model discarded a step
/// (it asks the master to end the simulation); other kinds → fmi2Discard.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_boolean_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    let body = |inst: &mut Instance<M>| {
        // SAFETY: NULL or valid for writing one value (module contract).
        let out = unsafe { out_ref(value, "value") }?;
        if kind != status_kind::TERMINATED {
            return unavailable_status(Function::GetBooleanStatus, kind);
        }
        *out = to_fmi_bool(inst.glue.terminate_requested);
        Ok(Status::Ok)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::GetBooleanStatus, body) }
}

/// fmi2GetStringStatus: FMI 2.0's only String kind, fmi2PendingStatus, needs asynchronous
/// steps, which this glue never runs, so every defined kind → fmi2Discard (as
/// fmi2GetIntegerStatus does): the status is not available, the instance stays usable.
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn get_string_status<M: Model>(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2String,
) -> Fmi2Status {
    let body = |_: &mut Instance<M>| {
        // SAFETY: NULL or valid for writing one value (module contract).
        unsafe { out_ref(value, "value") }?;
        unavailable_status(Function::GetStringStatus, kind)
    };
    // SAFETY: `c` satisfies the module contract.
    unsafe { guard(c, Function::GetStringStatus, body) }
}

/// The FMI state of an instance, for diagnostics and tests (`None` for NULL or a
/// pointer that is not a live instance of `M`).
///
/// # Safety
/// See the module's safety contract.
pub unsafe fn instance_state<M: Model>(c: Fmi2Component) -> Option<FmiState> {
    // SAFETY: `c` satisfies the module contract.
    unsafe { Instance::<M>::from_component(c) }.map(|inst| inst.glue.state)
}
