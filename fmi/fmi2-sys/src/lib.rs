//! The C level of FMI 2.0: the types of `fmi2TypesPlatform.h` and `fmi2FunctionTypes.h`, the
//! one table of the 34 Co-Simulation function signatures ([`__fmi2_functions!`]) that both the
//! export and the import crate expand, and the platform names of the archive's `binaries/`.
//!
//! Hand-written rather than bindgen-generated: the headers are tiny and stable, and
//! bindgen would add libclang to every build for 40 lines of declarations. No code here runs
//! anything unsafe; the crate only declares.

#![forbid(unsafe_code)]

mod functions;

use std::ffi::{c_char, c_int, c_uint, c_void};

/// `fmi2Component`: opaque instance pointer handed to the master.
pub type Fmi2Component = *mut c_void;
/// `fmi2ComponentEnvironment`: opaque master pointer passed back to the logger.
pub type Fmi2ComponentEnvironment = *mut c_void;
/// `fmi2FMUstate`: opaque snapshot pointer.
pub type Fmi2FmuState = *mut c_void;
/// `fmi2ValueReference`.
pub type Fmi2ValueReference = c_uint;
/// `fmi2Real`.
pub type Fmi2Real = f64;
/// `fmi2Integer`.
pub type Fmi2Integer = c_int;
/// `fmi2Boolean` (an int: 0 false, non-zero true).
pub type Fmi2Boolean = c_int;
/// `fmi2Char`.
pub type Fmi2Char = c_char;
/// `fmi2String`.
pub type Fmi2String = *const c_char;
/// `fmi2Byte`.
pub type Fmi2Byte = c_char;
/// `fmi2Status` as it crosses the ABI (a C enum, i.e. an int).
pub type Fmi2Status = c_int;
/// `fmi2Type` as it crosses the ABI.
pub type Fmi2Type = c_int;
/// `fmi2StatusKind` as it crosses the ABI.
pub type Fmi2StatusKind = c_int;

/// `fmi2True`.
pub const FMI2_TRUE: Fmi2Boolean = 1;
/// `fmi2False`.
pub const FMI2_FALSE: Fmi2Boolean = 0;
/// `fmi2ModelExchange`.
pub const FMI2_MODEL_EXCHANGE: Fmi2Type = 0;
/// `fmi2CoSimulation`.
pub const FMI2_CO_SIMULATION: Fmi2Type = 1;
/// Value of `fmi2GetTypesPlatform`.
pub const TYPES_PLATFORM: &std::ffi::CStr = c"default";
/// Value of `fmi2GetVersion`.
pub const FMI_VERSION: &std::ffi::CStr = c"2.0";

/// `fmi2Status` as a Rust enum; converted from the raw int with `TryFrom`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(i32)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

impl Status {
    /// The C name, as the standard spells it in log messages.
    pub fn name(self) -> &'static str {
        match self {
            Status::Ok => "fmi2OK",
            Status::Warning => "fmi2Warning",
            Status::Discard => "fmi2Discard",
            Status::Error => "fmi2Error",
            Status::Fatal => "fmi2Fatal",
            Status::Pending => "fmi2Pending",
        }
    }
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl From<Status> for Fmi2Status {
    fn from(s: Status) -> Self {
        s as Fmi2Status
    }
}

/// A raw status outside 0..=5.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("invalid fmi2Status value {0}")]
pub struct InvalidStatus(pub Fmi2Status);

impl TryFrom<Fmi2Status> for Status {
    type Error = InvalidStatus;
    fn try_from(raw: Fmi2Status) -> Result<Self, InvalidStatus> {
        Ok(match raw {
            0 => Status::Ok,
            1 => Status::Warning,
            2 => Status::Discard,
            3 => Status::Error,
            4 => Status::Fatal,
            5 => Status::Pending,
            other => return Err(InvalidStatus(other)),
        })
    }
}

/// `fmi2StatusKind` values.
pub mod status_kind {
    use super::Fmi2StatusKind;
    pub const DO_STEP_STATUS: Fmi2StatusKind = 0;
    pub const PENDING_STATUS: Fmi2StatusKind = 1;
    pub const LAST_SUCCESSFUL_TIME: Fmi2StatusKind = 2;
    pub const TERMINATED: Fmi2StatusKind = 3;
}

/// `fmi2CallbackLogger`: C-variadic; Rust can call it but not define it (the import
/// side defines it in a small C shim).
pub type Fmi2CallbackLogger = Option<
    unsafe extern "C" fn(
        Fmi2ComponentEnvironment,
        Fmi2String,
        Fmi2Status,
        Fmi2String,
        Fmi2String,
        ...
    ),
>;
/// `fmi2CallbackAllocateMemory`.
pub type Fmi2CallbackAllocateMemory = Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>;
/// `fmi2CallbackFreeMemory`.
pub type Fmi2CallbackFreeMemory = Option<unsafe extern "C" fn(*mut c_void)>;
/// `fmi2StepFinished`.
pub type Fmi2StepFinished = Option<unsafe extern "C" fn(Fmi2ComponentEnvironment, Fmi2Status)>;

/// `fmi2CallbackFunctions`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct Fmi2CallbackFunctions {
    pub logger: Fmi2CallbackLogger,
    pub allocate_memory: Fmi2CallbackAllocateMemory,
    pub free_memory: Fmi2CallbackFreeMemory,
    pub step_finished: Fmi2StepFinished,
    pub component_environment: Fmi2ComponentEnvironment,
}

/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "linux", target_pointer_width = "64"))]
pub const PLATFORM: &str = "linux64";
/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "linux", target_pointer_width = "32"))]
pub const PLATFORM: &str = "linux32";
/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "macos", target_pointer_width = "64"))]
pub const PLATFORM: &str = "darwin64";
/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "windows", target_pointer_width = "64"))]
pub const PLATFORM: &str = "win64";
/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "windows", target_pointer_width = "32"))]
pub const PLATFORM: &str = "win32";

/// File extension of shared libraries on this platform.
#[cfg(target_os = "linux")]
pub const SHARED_LIBRARY_EXTENSION: &str = "so";
/// File extension of shared libraries on this platform.
#[cfg(target_os = "macos")]
pub const SHARED_LIBRARY_EXTENSION: &str = "dylib";
/// File extension of shared libraries on this platform.
#[cfg(target_os = "windows")]
pub const SHARED_LIBRARY_EXTENSION: &str = "dll";
