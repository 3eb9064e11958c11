//! FMI 2.0 Co-Simulation instance states and the allowed-states table.
//!
//! One bitmask per function, checked by one shared guard (as Reference-FMUs'
//! `fmi2Functions.c` does), transcribed from the state table of FMI 2.0 §4.2.4 with
//! two deliberate choices:
//! - `StepInProgress` is left out: this glue runs every step synchronously
//!   (`canRunAsynchronuously = false`), so an instance never reaches it. `fmi2CancelStep`
//!   is allowed only there and is therefore always an illegal call.
//! - In `Fatal` only `fmi2FreeInstance` is allowed (the standard allows no call at all,
//!   but a master must still be able to release the memory).

use std::fmt;

/// The FMI 2.0 Co-Simulation state of one instance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FmiState {
    /// After fmi2Instantiate or fmi2Reset: start values, experiment setup.
    Instantiated,
    /// Between fmi2EnterInitializationMode and fmi2ExitInitializationMode.
    InitializationMode,
    /// Ready for the next fmi2DoStep.
    StepComplete,
    /// fmi2DoStep returned fmi2Discard: the step was not taken.
    StepFailed,
    /// An asynchronous step was cancelled (never reached: steps are synchronous).
    StepCanceled,
    /// After fmi2Terminate.
    Terminated,
    /// A call returned fmi2Fatal (e.g. a panic in the model): only fmi2FreeInstance remains.
    Fatal,
}

impl FmiState {
    /// Every state, in declaration order (for exhaustive tests).
    pub const ALL: [FmiState; 7] = [
        FmiState::Instantiated,
        FmiState::InitializationMode,
        FmiState::StepComplete,
        FmiState::StepFailed,
        FmiState::StepCanceled,
        FmiState::Terminated,
        FmiState::Fatal,
    ];

    /// The name used in log messages, e.g. `StepComplete`.
    pub fn name(self) -> &'static str {
        match self {
            FmiState::Instantiated => "Instantiated",
            FmiState::InitializationMode => "InitializationMode",
            FmiState::StepComplete => "StepComplete",
            FmiState::StepFailed => "StepFailed",
            FmiState::StepCanceled => "StepCanceled",
            FmiState::Terminated => "Terminated",
            FmiState::Fatal => "Fatal",
        }
    }

    /// Code in the serialized FMU state (declaration index).
    pub(crate) fn code(self) -> u32 {
        self as u32
    }

    /// Inverse of [`FmiState::code`].
    pub(crate) fn from_code(code: u32) -> Option<Self> {
        Self::ALL.get(usize::try_from(code).ok()?).copied()
    }

    const fn bit(self) -> u16 {
        1 << self as u16
    }
}

impl fmt::Display for FmiState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

const INSTANTIATED: u16 = FmiState::Instantiated.bit();
const INIT: u16 = FmiState::InitializationMode.bit();
const STEP_COMPLETE: u16 = FmiState::StepComplete.bit();
const STEP_FAILED: u16 = FmiState::StepFailed.bit();
const STEP_CANCELED: u16 = FmiState::StepCanceled.bit();
const TERMINATED: u16 = FmiState::Terminated.bit();
const FATAL: u16 = FmiState::Fatal.bit();

/// Every state in which the instance still exists and is not fatally broken.
const ALIVE: u16 = INSTANTIATED | INIT | STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED;
/// Where values can be read (after an error too, for diagnostics: FMI 2.0 footnote 7).
const READABLE: u16 = INIT | STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED;
/// Where some variables can be set (which ones is checked per variable).
const SETTABLE: u16 = INSTANTIATED | INIT | STEP_COMPLETE;
/// Where the fmi2Get*Status functions answer.
const STATUS: u16 = STEP_COMPLETE | STEP_FAILED | TERMINATED;

/// Every FMI 2.0 Co-Simulation function that takes an instance (all except
/// fmi2GetTypesPlatform, fmi2GetVersion and fmi2Instantiate).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Function {
    /// `fmi2SetDebugLogging`.
    SetDebugLogging,
    /// `fmi2FreeInstance`.
    FreeInstance,
    /// `fmi2SetupExperiment`.
    SetupExperiment,
    /// `fmi2EnterInitializationMode`.
    EnterInitializationMode,
    /// `fmi2ExitInitializationMode`.
    ExitInitializationMode,
    /// `fmi2Terminate`.
    Terminate,
    /// `fmi2Reset`.
    Reset,
    /// `fmi2GetReal`.
    GetReal,
    /// `fmi2GetInteger`.
    GetInteger,
    /// `fmi2GetBoolean`.
    GetBoolean,
    /// `fmi2GetString`.
    GetString,
    /// `fmi2SetReal`.
    SetReal,
    /// `fmi2SetInteger`.
    SetInteger,
    /// `fmi2SetBoolean`.
    SetBoolean,
    /// `fmi2SetString`.
    SetString,
    /// `fmi2GetFMUstate`.
    GetFmuState,
    /// `fmi2SetFMUstate`.
    SetFmuState,
    /// `fmi2FreeFMUstate`.
    FreeFmuState,
    /// `fmi2SerializedFMUstateSize`.
    SerializedFmuStateSize,
    /// `fmi2SerializeFMUstate`.
    SerializeFmuState,
    /// `fmi2DeSerializeFMUstate`.
    DeSerializeFmuState,
    /// `fmi2GetDirectionalDerivative`.
    GetDirectionalDerivative,
    /// `fmi2SetRealInputDerivatives`.
    SetRealInputDerivatives,
    /// `fmi2GetRealOutputDerivatives`.
    GetRealOutputDerivatives,
    /// `fmi2DoStep`.
    DoStep,
    /// `fmi2CancelStep`.
    CancelStep,
    /// `fmi2GetStatus`.
    GetStatus,
    /// `fmi2GetRealStatus`.
    GetRealStatus,
    /// `fmi2GetIntegerStatus`.
    GetIntegerStatus,
    /// `fmi2GetBooleanStatus`.
    GetBooleanStatus,
    /// `fmi2GetStringStatus`.
    GetStringStatus,
}

impl Function {
    /// Every instance function (for exhaustive tests).
    pub const ALL: [Function; 31] = [
        Function::SetDebugLogging,
        Function::FreeInstance,
        Function::SetupExperiment,
        Function::EnterInitializationMode,
        Function::ExitInitializationMode,
        Function::Terminate,
        Function::Reset,
        Function::GetReal,
        Function::GetInteger,
        Function::GetBoolean,
        Function::GetString,
        Function::SetReal,
        Function::SetInteger,
        Function::SetBoolean,
        Function::SetString,
        Function::GetFmuState,
        Function::SetFmuState,
        Function::FreeFmuState,
        Function::SerializedFmuStateSize,
        Function::SerializeFmuState,
        Function::DeSerializeFmuState,
        Function::GetDirectionalDerivative,
        Function::SetRealInputDerivatives,
        Function::GetRealOutputDerivatives,
        Function::DoStep,
        Function::CancelStep,
        Function::GetStatus,
        Function::GetRealStatus,
        Function::GetIntegerStatus,
        Function::GetBooleanStatus,
        Function::GetStringStatus,
    ];

    /// The C name, used as the prefix of every log message, e.g. `fmi2DoStep`.
    pub fn name(self) -> &'static str {
        match self {
            Function::SetDebugLogging => "fmi2SetDebugLogging",
            Function::FreeInstance => "fmi2FreeInstance",
            Function::SetupExperiment => "fmi2SetupExperiment",
            Function::EnterInitializationMode => "fmi2EnterInitializationMode",
            Function::ExitInitializationMode => "fmi2ExitInitializationMode",
            Function::Terminate => "fmi2Terminate",
            Function::Reset => "fmi2Reset",
            Function::GetReal => "fmi2GetReal",
            Function::GetInteger => "fmi2GetInteger",
            Function::GetBoolean => "fmi2GetBoolean",
            Function::GetString => "fmi2GetString",
            Function::SetReal => "fmi2SetReal",
            Function::SetInteger => "fmi2SetInteger",
            Function::SetBoolean => "fmi2SetBoolean",
            Function::SetString => "fmi2SetString",
            Function::GetFmuState => "fmi2GetFMUstate",
            Function::SetFmuState => "fmi2SetFMUstate",
            Function::FreeFmuState => "fmi2FreeFMUstate",
            Function::SerializedFmuStateSize => "fmi2SerializedFMUstateSize",
            Function::SerializeFmuState => "fmi2SerializeFMUstate",
            Function::DeSerializeFmuState => "fmi2DeSerializeFMUstate",
            Function::GetDirectionalDerivative => "fmi2GetDirectionalDerivative",
            Function::SetRealInputDerivatives => "fmi2SetRealInputDerivatives",
            Function::GetRealOutputDerivatives => "fmi2GetRealOutputDerivatives",
            Function::DoStep => "fmi2DoStep",
            Function::CancelStep => "fmi2CancelStep",
            Function::GetStatus => "fmi2GetStatus",
            Function::GetRealStatus => "fmi2GetRealStatus",
            Function::GetIntegerStatus => "fmi2GetIntegerStatus",
            Function::GetBooleanStatus => "fmi2GetBooleanStatus",
            Function::GetStringStatus => "fmi2GetStringStatus",
        }
    }

    /// The allowed-states bitmask of this function.
    const fn mask(self) -> u16 {
        match self {
            Function::SetDebugLogging => ALIVE,
            Function::FreeInstance => ALIVE | FATAL,
            Function::SetupExperiment | Function::EnterInitializationMode => INSTANTIATED,
            Function::ExitInitializationMode => INIT,
            Function::Terminate => STEP_COMPLETE | STEP_FAILED,
            Function::Reset => ALIVE,
            Function::GetReal
            | Function::GetInteger
            | Function::GetBoolean
            | Function::GetString
            | Function::GetDirectionalDerivative => READABLE,
            Function::SetReal
            | Function::SetInteger
            | Function::SetBoolean
            | Function::SetString
            | Function::SetRealInputDerivatives => SETTABLE,
            Function::GetFmuState
            | Function::SetFmuState
            | Function::FreeFmuState
            | Function::SerializedFmuStateSize
            | Function::SerializeFmuState
            | Function::DeSerializeFmuState => ALIVE,
            Function::GetRealOutputDerivatives => {
                STEP_COMPLETE | STEP_FAILED | STEP_CANCELED | TERMINATED
            }
            Function::DoStep => STEP_COMPLETE,
            // Only in StepInProgress, which a synchronous FMU never enters.
            Function::CancelStep => 0,
            Function::GetStatus
            | Function::GetRealStatus
            | Function::GetIntegerStatus
            | Function::GetBooleanStatus
            | Function::GetStringStatus => STATUS,
        }
    }

    /// Whether the FMI 2.0 CS state table allows this function in `state`.
    pub fn allowed_in(self, state: FmiState) -> bool {
        self.mask() & state.bit() != 0
    }

    /// Extra context appended to the illegal-call message where the bare state is puzzling.
    pub(crate) fn illegal_call_hint(self) -> &'static str {
        match self {
            Function::CancelStep => {
                "; fmi2CancelStep is allowed only while an asynchronous step is in progress, \
                 and this FMU steps synchronously (canRunAsynchronuously=false), \
                 so cancelling is not supported"
            }
            _ => "",
        }
    }
}
