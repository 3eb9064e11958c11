//! A co-simulation instance and its FMU states, every call through one choke point.

use std::ffi::{CStr, CString, c_void};
use std::ptr::{self, NonNull};
use std::rc::Rc;
use std::sync::Arc;

use crate::fmu::Loaded;
use crate::functions::Functions;
use crate::logger::{LogEnv, fmi2_import_logger};
use crate::{ImportError, LogRecord};
use fmi2_sys::{
    FMI2_CO_SIMULATION, FMI2_FALSE, FMI2_TRUE, Fmi2Boolean, Fmi2CallbackFunctions, Fmi2Component,
    Fmi2FmuState, Fmi2Status, Fmi2String, InvalidStatus, Status, status_kind,
};

unsafe extern "C" {
    /// C `calloc`, handed to the FMU as `allocateMemory` (same contract).
    fn calloc(count: usize, size: usize) -> *mut c_void;
    /// C `free`, handed to the FMU as `freeMemory`.
    fn free(ptr: *mut c_void);
}

/// Booleans are converted through a stack buffer of this many values per FMI call,
/// so get/set_boolean never allocate.
const BOOL_CHUNK: usize = 64;

fn fmi_bool(b: bool) -> Fmi2Boolean {
    if b { FMI2_TRUE } else { FMI2_FALSE }
}

/// The live component and everything its callbacks point to. Shared (via `Rc`) by the
/// [`Instance`] and its [`FmuState`]s, so a state can always be freed against a live
/// component; fmi2FreeInstance runs when the last of them is dropped.
#[derive(Debug)]
struct Component {
    loaded: Arc<Loaded>,
    raw: NonNull<c_void>,
    name: String,
    /// `componentEnvironment`: must stay at this heap address until after FreeInstance.
    env: Box<LogEnv>,
    /// The FMU may keep a pointer to the callback struct, so it lives as long as the component.
    _callbacks: Box<Fmi2CallbackFunctions>,
}

impl Component {
    #[inline]
    fn f(&self) -> &Functions {
        &self.loaded.functions
    }

    #[inline]
    fn c(&self) -> Fmi2Component {
        self.raw.as_ptr()
    }

    /// The choke point: every status-returning FMI call goes through here. Ok and
    /// Warning pass (a warning's text stays in the log); everything else becomes an
    /// error naming the function and instance with what the FMU logged during the call.
    /// Allocates only on the error path, which is kept out of line: inlined, the success
    /// path is a comparison (six calls per co-simulation step).
    #[inline]
    fn check(
        &self,
        function: &'static str,
        mark: u64,
        raw: Fmi2Status,
    ) -> Result<Status, ImportError> {
        match Status::try_from(raw) {
            Ok(status @ (Status::Ok | Status::Warning)) => Ok(status),
            other => Err(self.failure(function, mark, other)),
        }
    }

    /// The error of a call that returned `status` (Discard, Error, Fatal, Pending or a
    /// value outside the enumeration).
    #[cold]
    #[inline(never)]
    fn failure(
        &self,
        function: &'static str,
        mark: u64,
        status: Result<Status, InvalidStatus>,
    ) -> ImportError {
        match status {
            Ok(status) => ImportError::Call {
                function,
                instance: self.name.clone(),
                status,
                messages: self.env.since(mark),
            },
            Err(invalid) => ImportError::InvalidStatus {
                function,
                instance: self.name.clone(),
                raw: invalid.0,
                messages: self.env.since(mark),
            },
        }
    }

    /// Runs one FMI call and checks its status.
    #[inline]
    fn call(
        &self,
        function: &'static str,
        f: impl FnOnce() -> Fmi2Status,
    ) -> Result<Status, ImportError> {
        let mark = self.env.mark();
        let raw = f();
        self.check(function, mark, raw)
    }

    fn invalid(&self, function: &'static str, message: impl Into<String>) -> ImportError {
        ImportError::InvalidArgument {
            function,
            instance: self.name.clone(),
            message: message.into(),
        }
    }
}

impl Drop for Component {
    fn drop(&mut self) {
        // SAFETY: `raw` came from fmi2Instantiate of this library (kept loaded by
        // `loaded`), is freed exactly once (this is the only owner's drop), and no FMU
        // state refers to it any more (they hold this `Rc`). `env` and the callbacks
        // are dropped only after this body, i.e. after FreeInstance.
        unsafe { (self.f().fmi2FreeInstance)(self.c()) };
    }
}

/// One FMI 2.0 co-simulation instance.
///
/// Not `Send`: FMI 2.0 forbids concurrent calls on one instance, and its FMU states
/// share the component. The library and unpacked files stay alive while it exists.
#[derive(Debug)]
pub struct Instance {
    component: Rc<Component>,
}

/// A snapshot from fmi2GetFMUstate/fmi2DeSerializeFMUstate, freed with fmi2FreeFMUstate
/// on drop. It keeps its component alive, so dropping it after the [`Instance`] is safe.
#[derive(Debug)]
pub struct FmuState {
    component: Rc<Component>,
    raw: Fmi2FmuState,
}

impl Drop for FmuState {
    fn drop(&mut self) {
        let f = self.component.f().fmi2FreeFMUstate;
        // SAFETY: `raw` was produced for this component, which is still alive (we hold
        // an `Rc` to it), and is freed exactly once here. The status is ignored: drop
        // cannot report it, and the FMU has logged any complaint.
        let _ = unsafe { f(self.component.c(), &mut self.raw) };
    }
}

impl Instance {
    pub(crate) fn instantiate(
        loaded: Arc<Loaded>,
        name: CString,
        guid: &CStr,
        resource_uri: &CStr,
        logging_on: bool,
    ) -> Result<Instance, ImportError> {
        let env = Box::new(LogEnv::new());
        let callbacks = Box::new(Fmi2CallbackFunctions {
            logger: Some(fmi2_import_logger),
            allocate_memory: Some(calloc),
            free_memory: Some(free),
            step_finished: None,
            component_environment: (&*env as *const LogEnv).cast_mut().cast(),
        });
        let instantiate = loaded.functions.fmi2Instantiate;
        // SAFETY: all strings are NUL-terminated and outlive the call; `callbacks` and
        // the environment it points to are boxed and kept beside the component until
        // after FreeInstance; the logger has the fmi2CallbackLogger signature (C shim).
        let raw = unsafe {
            instantiate(
                name.as_ptr(),
                FMI2_CO_SIMULATION,
                guid.as_ptr(),
                resource_uri.as_ptr(),
                &*callbacks,
                FMI2_FALSE,
                fmi_bool(logging_on),
            )
        };
        let name = name.to_string_lossy().into_owned();
        match NonNull::new(raw) {
            Some(raw) => Ok(Instance {
                component: Rc::new(Component {
                    loaded,
                    raw,
                    name,
                    env,
                    _callbacks: callbacks,
                }),
            }),
            None => Err(ImportError::Instantiate {
                instance: name,
                messages: env.take(),
            }),
        }
    }

    /// The instance name given to fmi2Instantiate.
    pub fn name(&self) -> &str {
        &self.component.name
    }

    /// Removes and returns everything the FMU logged so far.
    pub fn take_log(&self) -> Vec<LogRecord> {
        self.component.env.take()
    }

    /// fmi2SetDebugLogging with the given categories (empty: all). Allocates.
    pub fn set_debug_logging(
        &mut self,
        logging_on: bool,
        categories: &[&str],
    ) -> Result<Status, ImportError> {
        const F: &str = "fmi2SetDebugLogging";
        let c = &*self.component;
        let owned = categories
            .iter()
            .map(|s| {
                CString::new(*s)
                    .map_err(|_| c.invalid(F, format!("category {s:?} contains a NUL byte")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let ptrs: Vec<Fmi2String> = owned.iter().map(|s| s.as_ptr()).collect();
        // SAFETY: live component; `ptrs` holds `len` valid C strings for the call.
        c.call(F, || unsafe {
            (c.f().fmi2SetDebugLogging)(c.c(), fmi_bool(logging_on), ptrs.len(), ptrs.as_ptr())
        })
    }

    /// fmi2SetupExperiment.
    pub fn setup_experiment(
        &mut self,
        tolerance: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Result<Status, ImportError> {
        let c = &*self.component;
        // SAFETY: live component, plain value arguments.
        c.call("fmi2SetupExperiment", || unsafe {
            (c.f().fmi2SetupExperiment)(
                c.c(),
                fmi_bool(tolerance.is_some()),
                tolerance.unwrap_or(0.0),
                start,
                fmi_bool(stop.is_some()),
                stop.unwrap_or(0.0),
            )
        })
    }

    /// fmi2EnterInitializationMode.
    pub fn enter_initialization_mode(&mut self) -> Result<Status, ImportError> {
        let c = &*self.component;
        // SAFETY: live component.
        c.call("fmi2EnterInitializationMode", || unsafe {
            (c.f().fmi2EnterInitializationMode)(c.c())
        })
    }

    /// fmi2ExitInitializationMode.
    pub fn exit_initialization_mode(&mut self) -> Result<Status, ImportError> {
        let c = &*self.component;
        // SAFETY: live component.
        c.call("fmi2ExitInitializationMode", || unsafe {
            (c.f().fmi2ExitInitializationMode)(c.c())
        })
    }

    /// fmi2Terminate.
    pub fn terminate(&mut self) -> Result<Status, ImportError> {
        let c = &*self.component;
        // SAFETY: live component.
        c.call("fmi2Terminate", || unsafe { (c.f().fmi2Terminate)(c.c()) })
    }

    /// fmi2Reset.
    pub fn reset(&mut self) -> Result<Status, ImportError> {
        let c = &*self.component;
        // SAFETY: live component.
        c.call("fmi2Reset", || unsafe { (c.f().fmi2Reset)(c.c()) })
    }

    /// fmi2DoStep from `t` by `h`.
    ///
    /// This and `set_real`/`get_real` are `#[inline]`: a master's stepping loop is often
    /// generic and compiled in another crate, where each call here was a call across the
    /// crate boundary, six per step (BENCHMARKS.md, round 34).
    #[inline]
    pub fn do_step(&mut self, t: f64, h: f64, no_set_prior: bool) -> Result<Status, ImportError> {
        let c = &*self.component;
        // SAFETY: live component, plain value arguments.
        c.call("fmi2DoStep", || unsafe {
            (c.f().fmi2DoStep)(c.c(), t, h, fmi_bool(no_set_prior))
        })
    }

    /// fmi2CancelStep (only meaningful after a Pending doStep).
    pub fn cancel_step(&mut self) -> Result<Status, ImportError> {
        let c = &*self.component;
        // SAFETY: live component.
        c.call("fmi2CancelStep", || unsafe {
            (c.f().fmi2CancelStep)(c.c())
        })
    }

    /// fmi2SetReal. Does not allocate unless the FMU reports an error.
    #[inline]
    pub fn set_real(&mut self, vrs: &[u32], values: &[f64]) -> Result<Status, ImportError> {
        const F: &str = "fmi2SetReal";
        let c = &*self.component;
        same_len(c, F, vrs.len(), values.len())?;
        // SAFETY: live component; both arrays hold `vrs.len()` elements for the call.
        c.call(F, || unsafe {
            (c.f().fmi2SetReal)(c.c(), vrs.as_ptr(), vrs.len(), values.as_ptr())
        })
    }

    /// fmi2GetReal into `values`. Does not allocate unless the FMU reports an error.
    #[inline]
    pub fn get_real(&mut self, vrs: &[u32], values: &mut [f64]) -> Result<Status, ImportError> {
        const F: &str = "fmi2GetReal";
        let c = &*self.component;
        same_len(c, F, vrs.len(), values.len())?;
        // SAFETY: live component; `values` is writable for `vrs.len()` elements.
        c.call(F, || unsafe {
            (c.f().fmi2GetReal)(c.c(), vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        })
    }

    /// fmi2SetInteger (also for Enumeration variables). Does not allocate unless the FMU reports an error.
    pub fn set_integer(&mut self, vrs: &[u32], values: &[i32]) -> Result<Status, ImportError> {
        const F: &str = "fmi2SetInteger";
        let c = &*self.component;
        same_len(c, F, vrs.len(), values.len())?;
        // SAFETY: live component; both arrays hold `vrs.len()` elements for the call.
        c.call(F, || unsafe {
            (c.f().fmi2SetInteger)(c.c(), vrs.as_ptr(), vrs.len(), values.as_ptr())
        })
    }

    /// fmi2GetInteger into `values`. Does not allocate unless the FMU reports an error.
    pub fn get_integer(&mut self, vrs: &[u32], values: &mut [i32]) -> Result<Status, ImportError> {
        const F: &str = "fmi2GetInteger";
        let c = &*self.component;
        same_len(c, F, vrs.len(), values.len())?;
        // SAFETY: live component; `values` is writable for `vrs.len()` elements.
        c.call(F, || unsafe {
            (c.f().fmi2GetInteger)(c.c(), vrs.as_ptr(), vrs.len(), values.as_mut_ptr())
        })
    }

    /// fmi2SetBoolean, converting through a stack buffer in chunks of 64 (no allocation).
    /// Returns the worst status of the chunks.
    pub fn set_boolean(&mut self, vrs: &[u32], values: &[bool]) -> Result<Status, ImportError> {
        const F: &str = "fmi2SetBoolean";
        let c = &*self.component;
        same_len(c, F, vrs.len(), values.len())?;
        let mut worst = Status::Ok;
        for (vr_chunk, value_chunk) in vrs.chunks(BOOL_CHUNK).zip(values.chunks(BOOL_CHUNK)) {
            let mut buf = [FMI2_FALSE; BOOL_CHUNK];
            for (slot, &v) in buf.iter_mut().zip(value_chunk) {
                *slot = fmi_bool(v);
            }
            // SAFETY: live component; `buf` holds at least `vr_chunk.len()` elements.
            let status = c.call(F, || unsafe {
                (c.f().fmi2SetBoolean)(c.c(), vr_chunk.as_ptr(), vr_chunk.len(), buf.as_ptr())
            })?;
            worst = worst.max(status);
        }
        Ok(worst)
    }

    /// fmi2GetBoolean into `values`, through a stack buffer in chunks of 64 (no allocation).
    pub fn get_boolean(&mut self, vrs: &[u32], values: &mut [bool]) -> Result<Status, ImportError> {
        const F: &str = "fmi2GetBoolean";
        let c = &*self.component;
        same_len(c, F, vrs.len(), values.len())?;
        let mut worst = Status::Ok;
        for (vr_chunk, value_chunk) in vrs.chunks(BOOL_CHUNK).zip(values.chunks_mut(BOOL_CHUNK)) {
            let mut buf = [FMI2_FALSE; BOOL_CHUNK];
            // SAFETY: live component; `buf` is writable for at least `vr_chunk.len()` elements.
            let status = c.call(F, || unsafe {
                (c.f().fmi2GetBoolean)(c.c(), vr_chunk.as_ptr(), vr_chunk.len(), buf.as_mut_ptr())
            })?;
            for (v, &raw) in value_chunk.iter_mut().zip(&buf) {
                *v = raw != FMI2_FALSE;
            }
            worst = worst.max(status);
        }
        Ok(worst)
    }

    /// fmi2SetString. Allocates (one C string per value); not for the step loop.
    pub fn set_string(&mut self, vrs: &[u32], values: &[&str]) -> Result<Status, ImportError> {
        const F: &str = "fmi2SetString";
        let c = &*self.component;
        same_len(c, F, vrs.len(), values.len())?;
        let owned = values
            .iter()
            .map(|s| {
                CString::new(*s)
                    .map_err(|_| c.invalid(F, format!("value {s:?} contains a NUL byte")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let ptrs: Vec<Fmi2String> = owned.iter().map(|s| s.as_ptr()).collect();
        // SAFETY: live component; `ptrs` holds `vrs.len()` C strings valid for the call.
        c.call(F, || unsafe {
            (c.f().fmi2SetString)(c.c(), vrs.as_ptr(), vrs.len(), ptrs.as_ptr())
        })
    }

    /// fmi2GetString, copied out immediately (the FMU's pointers are only valid until
    /// its next call). Allocates.
    pub fn get_string(&mut self, vrs: &[u32]) -> Result<Vec<String>, ImportError> {
        const F: &str = "fmi2GetString";
        let c = &*self.component;
        let mut ptrs: Vec<Fmi2String> = vec![ptr::null(); vrs.len()];
        // SAFETY: live component; `ptrs` is writable for `vrs.len()` elements.
        c.call(F, || unsafe {
            (c.f().fmi2GetString)(c.c(), vrs.as_ptr(), vrs.len(), ptrs.as_mut_ptr())
        })?;
        ptrs.into_iter()
            .map(|p| {
                if p.is_null() {
                    Err(c.invalid(F, "the FMU returned a NULL string"))
                } else {
                    // SAFETY: non-null string the FMU just returned, valid until its next call.
                    Ok(unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned())
                }
            })
            .collect()
    }

    /// fmi2GetFMUstate: a new snapshot of the instance.
    pub fn get_fmu_state(&mut self) -> Result<FmuState, ImportError> {
        const F: &str = "fmi2GetFMUstate";
        let c = &*self.component;
        let mut raw: Fmi2FmuState = ptr::null_mut();
        // SAFETY: live component; `raw` is NULL, which asks the FMU for a new state.
        c.call(F, || unsafe { (c.f().fmi2GetFMUstate)(c.c(), &mut raw) })?;
        self.wrap_state(F, raw)
    }

    /// fmi2SetFMUstate from a snapshot of this same instance.
    pub fn set_fmu_state(&mut self, state: &FmuState) -> Result<Status, ImportError> {
        const F: &str = "fmi2SetFMUstate";
        let c = &*self.component;
        if !Rc::ptr_eq(&state.component, &self.component) {
            return Err(c.invalid(
                F,
                format!(
                    "the FMU state belongs to instance '{}'",
                    state.component.name
                ),
            ));
        }
        // SAFETY: live component; `state.raw` was created for it and is still allocated.
        c.call(F, || unsafe { (c.f().fmi2SetFMUstate)(c.c(), state.raw) })
    }

    /// fmi2SerializedFMUstateSize + fmi2SerializeFMUstate.
    pub fn serialize_fmu_state(&mut self, state: &FmuState) -> Result<Vec<u8>, ImportError> {
        const F: &str = "fmi2SerializeFMUstate";
        let c = &*self.component;
        if !Rc::ptr_eq(&state.component, &self.component) {
            return Err(c.invalid(
                F,
                format!(
                    "the FMU state belongs to instance '{}'",
                    state.component.name
                ),
            ));
        }
        let mut size = 0usize;
        // SAFETY: live component, its own state, `size` writable.
        c.call("fmi2SerializedFMUstateSize", || unsafe {
            (c.f().fmi2SerializedFMUstateSize)(c.c(), state.raw, &mut size)
        })?;
        let mut bytes = vec![0u8; size];
        // SAFETY: live component, its own state; `bytes` is writable for `size` bytes.
        c.call(F, || unsafe {
            (c.f().fmi2SerializeFMUstate)(c.c(), state.raw, bytes.as_mut_ptr().cast(), size)
        })?;
        Ok(bytes)
    }

    /// fmi2DeSerializeFMUstate: a snapshot rebuilt from `bytes`.
    pub fn deserialize_fmu_state(&mut self, bytes: &[u8]) -> Result<FmuState, ImportError> {
        const F: &str = "fmi2DeSerializeFMUstate";
        let c = &*self.component;
        let mut raw: Fmi2FmuState = ptr::null_mut();
        // SAFETY: live component; `bytes` readable for its length; `raw` NULL asks for a new state.
        c.call(F, || unsafe {
            (c.f().fmi2DeSerializeFMUstate)(c.c(), bytes.as_ptr().cast(), bytes.len(), &mut raw)
        })?;
        self.wrap_state(F, raw)
    }

    fn wrap_state(
        &self,
        function: &'static str,
        raw: Fmi2FmuState,
    ) -> Result<FmuState, ImportError> {
        if raw.is_null() {
            return Err(self.component.invalid(
                function,
                "the FMU reported success but returned a NULL state",
            ));
        }
        Ok(FmuState {
            component: Rc::clone(&self.component),
            raw,
        })
    }

    /// fmi2GetRealStatus(fmi2LastSuccessfulTime).
    pub fn last_successful_time(&mut self) -> Result<f64, ImportError> {
        let c = &*self.component;
        let mut t = f64::NAN;
        // SAFETY: live component; `t` writable.
        c.call("fmi2GetRealStatus", || unsafe {
            (c.f().fmi2GetRealStatus)(c.c(), status_kind::LAST_SUCCESSFUL_TIME, &mut t)
        })?;
        Ok(t)
    }

    /// fmi2GetBooleanStatus(fmi2Terminated): whether the FMU wants to end the simulation.
    pub fn is_terminated(&mut self) -> Result<bool, ImportError> {
        let c = &*self.component;
        let mut terminated = FMI2_FALSE;
        // SAFETY: live component; `terminated` writable.
        c.call("fmi2GetBooleanStatus", || unsafe {
            (c.f().fmi2GetBooleanStatus)(c.c(), status_kind::TERMINATED, &mut terminated)
        })?;
        Ok(terminated != FMI2_FALSE)
    }
}

impl Instance {
    /// fmi2GetDirectionalDerivative: `dv_unknown = J · dv_known` for the given value references.
    pub fn get_directional_derivative(
        &mut self,
        unknowns: &[u32],
        knowns: &[u32],
        dv_known: &[f64],
        dv_unknown: &mut [f64],
    ) -> Result<Status, ImportError> {
        const F: &str = "fmi2GetDirectionalDerivative";
        let c = &*self.component;
        same_len(c, F, knowns.len(), dv_known.len())?;
        same_len(c, F, unknowns.len(), dv_unknown.len())?;
        // SAFETY: live component; every array holds the length passed beside it.
        c.call(F, || unsafe {
            (c.f().fmi2GetDirectionalDerivative)(
                c.c(),
                unknowns.as_ptr(),
                unknowns.len(),
                knowns.as_ptr(),
                knowns.len(),
                dv_known.as_ptr(),
                dv_unknown.as_mut_ptr(),
            )
        })
    }

    /// fmi2SetRealInputDerivatives: the `orders[i]`-th time derivative of each input.
    pub fn set_real_input_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &[f64],
    ) -> Result<Status, ImportError> {
        const F: &str = "fmi2SetRealInputDerivatives";
        let c = &*self.component;
        same_len(c, F, vrs.len(), orders.len())?;
        same_len(c, F, vrs.len(), values.len())?;
        // SAFETY: live component; all three arrays hold `vrs.len()` elements.
        c.call(F, || unsafe {
            (c.f().fmi2SetRealInputDerivatives)(
                c.c(),
                vrs.as_ptr(),
                vrs.len(),
                orders.as_ptr(),
                values.as_ptr(),
            )
        })
    }

    /// fmi2GetRealOutputDerivatives: the `orders[i]`-th time derivative of each output.
    pub fn get_real_output_derivatives(
        &mut self,
        vrs: &[u32],
        orders: &[i32],
        values: &mut [f64],
    ) -> Result<Status, ImportError> {
        const F: &str = "fmi2GetRealOutputDerivatives";
        let c = &*self.component;
        same_len(c, F, vrs.len(), orders.len())?;
        same_len(c, F, vrs.len(), values.len())?;
        // SAFETY: live component; all three arrays hold `vrs.len()` elements.
        c.call(F, || unsafe {
            (c.f().fmi2GetRealOutputDerivatives)(
                c.c(),
                vrs.as_ptr(),
                vrs.len(),
                orders.as_ptr(),
                values.as_mut_ptr(),
            )
        })
    }

    /// fmi2GetStatus(fmi2DoStepStatus): the final status of an asynchronous doStep.
    pub fn do_step_status(&mut self) -> Result<Status, ImportError> {
        const F: &str = "fmi2GetStatus";
        let c = &*self.component;
        let mut raw: Fmi2Status = Status::Ok.into();
        // SAFETY: live component; `raw` writable.
        c.call(F, || unsafe {
            (c.f().fmi2GetStatus)(c.c(), status_kind::DO_STEP_STATUS, &mut raw)
        })?;
        Status::try_from(raw)
            .map_err(|e| c.invalid(F, format!("the FMU reported {e} as the doStep status")))
    }

    /// fmi2GetStringStatus(fmi2PendingStatus): the FMU's description of a pending doStep.
    pub fn pending_status(&mut self) -> Result<String, ImportError> {
        const F: &str = "fmi2GetStringStatus";
        let c = &*self.component;
        let mut text: Fmi2String = ptr::null();
        // SAFETY: live component; `text` writable.
        c.call(F, || unsafe {
            (c.f().fmi2GetStringStatus)(c.c(), status_kind::PENDING_STATUS, &mut text)
        })?;
        if text.is_null() {
            return Ok(String::new());
        }
        // SAFETY: non-null string the FMU just returned, valid until its next call.
        Ok(unsafe { CStr::from_ptr(text) }
            .to_string_lossy()
            .into_owned())
    }

    /// fmi2GetIntegerStatus for a raw status kind (FMI 2.0 defines none for it; tools may).
    pub fn integer_status(&mut self, kind: i32) -> Result<i32, ImportError> {
        const F: &str = "fmi2GetIntegerStatus";
        let c = &*self.component;
        let mut value = 0;
        // SAFETY: live component; `value` writable.
        c.call(F, || unsafe {
            (c.f().fmi2GetIntegerStatus)(c.c(), kind, &mut value)
        })?;
        Ok(value)
    }
}

/// Rejects slices of different lengths before anything reaches the FMU.
#[inline]
fn same_len(
    c: &Component,
    function: &'static str,
    vrs: usize,
    values: usize,
) -> Result<(), ImportError> {
    if vrs == values {
        Ok(())
    } else {
        Err(not_same_len(c, function, vrs, values))
    }
}

#[cold]
#[inline(never)]
fn not_same_len(c: &Component, function: &'static str, vrs: usize, values: usize) -> ImportError {
    c.invalid(
        function,
        format!("{vrs} value references but {values} values"),
    )
}
