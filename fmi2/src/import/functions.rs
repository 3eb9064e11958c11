//! The 34 FMI 2.0 functions of a co-simulation FMU (common + CS), resolved up front.

use std::ffi::c_char;

use libloading::Library;

use crate::types::{
    Fmi2Boolean, Fmi2Byte, Fmi2CallbackFunctions, Fmi2Component, Fmi2FmuState, Fmi2Integer,
    Fmi2Real, Fmi2Status, Fmi2StatusKind, Fmi2String, Fmi2Type, Fmi2ValueReference,
};

type C = Fmi2Component;
type Vr = *const Fmi2ValueReference;

macro_rules! fmi2_functions {
    ($($field:ident = $symbol:literal: fn($($arg:ty),*) $(-> $ret:ty)?;)*) => {
        /// Typed pointers to every function; valid while the `Library` they came from is loaded.
        #[allow(non_snake_case)] // Field names are the C symbol names, for grep-ability.
        #[derive(Debug, Clone, Copy)]
        pub(crate) struct Functions {
            $(pub(crate) $field: unsafe extern "C" fn($($arg),*) $(-> $ret)?,)*
        }

        /// Every symbol `Functions::load` resolves, in the order of the standard's header.
        pub const SYMBOLS: &[&str] = &[$($symbol),*];

        impl Functions {
            /// Resolves every symbol; the first missing one is returned by name.
            ///
            /// # Safety
            /// `library` must be an FMI 2.0 binary: each symbol, if present, must have the
            /// signature of the standard's header, which is what the pointer is typed as.
            pub(crate) unsafe fn load(library: &Library) -> Result<Self, (&'static str, libloading::Error)> {
                Ok(Self {
                    $($field: {
                        // SAFETY: per this function's contract, the symbol has this signature.
                        let symbol = unsafe {
                            library.get::<unsafe extern "C" fn($($arg),*) $(-> $ret)?>($symbol)
                        };
                        *symbol.map_err(|e| ($symbol, e))?
                    },)*
                })
            }
        }
    };
}

fmi2_functions! {
    fmi2GetTypesPlatform = "fmi2GetTypesPlatform": fn() -> *const c_char;
    fmi2GetVersion = "fmi2GetVersion": fn() -> *const c_char;
    fmi2SetDebugLogging = "fmi2SetDebugLogging": fn(C, Fmi2Boolean, usize, *const Fmi2String) -> Fmi2Status;
    fmi2Instantiate = "fmi2Instantiate": fn(Fmi2String, Fmi2Type, Fmi2String, Fmi2String, *const Fmi2CallbackFunctions, Fmi2Boolean, Fmi2Boolean) -> C;
    fmi2FreeInstance = "fmi2FreeInstance": fn(C);
    fmi2SetupExperiment = "fmi2SetupExperiment": fn(C, Fmi2Boolean, Fmi2Real, Fmi2Real, Fmi2Boolean, Fmi2Real) -> Fmi2Status;
    fmi2EnterInitializationMode = "fmi2EnterInitializationMode": fn(C) -> Fmi2Status;
    fmi2ExitInitializationMode = "fmi2ExitInitializationMode": fn(C) -> Fmi2Status;
    fmi2Terminate = "fmi2Terminate": fn(C) -> Fmi2Status;
    fmi2Reset = "fmi2Reset": fn(C) -> Fmi2Status;
    fmi2GetReal = "fmi2GetReal": fn(C, Vr, usize, *mut Fmi2Real) -> Fmi2Status;
    fmi2GetInteger = "fmi2GetInteger": fn(C, Vr, usize, *mut Fmi2Integer) -> Fmi2Status;
    fmi2GetBoolean = "fmi2GetBoolean": fn(C, Vr, usize, *mut Fmi2Boolean) -> Fmi2Status;
    fmi2GetString = "fmi2GetString": fn(C, Vr, usize, *mut Fmi2String) -> Fmi2Status;
    fmi2SetReal = "fmi2SetReal": fn(C, Vr, usize, *const Fmi2Real) -> Fmi2Status;
    fmi2SetInteger = "fmi2SetInteger": fn(C, Vr, usize, *const Fmi2Integer) -> Fmi2Status;
    fmi2SetBoolean = "fmi2SetBoolean": fn(C, Vr, usize, *const Fmi2Boolean) -> Fmi2Status;
    fmi2SetString = "fmi2SetString": fn(C, Vr, usize, *const Fmi2String) -> Fmi2Status;
    fmi2GetFMUstate = "fmi2GetFMUstate": fn(C, *mut Fmi2FmuState) -> Fmi2Status;
    fmi2SetFMUstate = "fmi2SetFMUstate": fn(C, Fmi2FmuState) -> Fmi2Status;
    fmi2FreeFMUstate = "fmi2FreeFMUstate": fn(C, *mut Fmi2FmuState) -> Fmi2Status;
    fmi2SerializedFMUstateSize = "fmi2SerializedFMUstateSize": fn(C, Fmi2FmuState, *mut usize) -> Fmi2Status;
    fmi2SerializeFMUstate = "fmi2SerializeFMUstate": fn(C, Fmi2FmuState, *mut Fmi2Byte, usize) -> Fmi2Status;
    fmi2DeSerializeFMUstate = "fmi2DeSerializeFMUstate": fn(C, *const Fmi2Byte, usize, *mut Fmi2FmuState) -> Fmi2Status;
    fmi2GetDirectionalDerivative = "fmi2GetDirectionalDerivative": fn(C, Vr, usize, Vr, usize, *const Fmi2Real, *mut Fmi2Real) -> Fmi2Status;
    fmi2SetRealInputDerivatives = "fmi2SetRealInputDerivatives": fn(C, Vr, usize, *const Fmi2Integer, *const Fmi2Real) -> Fmi2Status;
    fmi2GetRealOutputDerivatives = "fmi2GetRealOutputDerivatives": fn(C, Vr, usize, *const Fmi2Integer, *mut Fmi2Real) -> Fmi2Status;
    fmi2DoStep = "fmi2DoStep": fn(C, Fmi2Real, Fmi2Real, Fmi2Boolean) -> Fmi2Status;
    fmi2CancelStep = "fmi2CancelStep": fn(C) -> Fmi2Status;
    fmi2GetStatus = "fmi2GetStatus": fn(C, Fmi2StatusKind, *mut Fmi2Status) -> Fmi2Status;
    fmi2GetRealStatus = "fmi2GetRealStatus": fn(C, Fmi2StatusKind, *mut Fmi2Real) -> Fmi2Status;
    fmi2GetIntegerStatus = "fmi2GetIntegerStatus": fn(C, Fmi2StatusKind, *mut Fmi2Integer) -> Fmi2Status;
    fmi2GetBooleanStatus = "fmi2GetBooleanStatus": fn(C, Fmi2StatusKind, *mut Fmi2Boolean) -> Fmi2Status;
    fmi2GetStringStatus = "fmi2GetStringStatus": fn(C, Fmi2StatusKind, *mut Fmi2String) -> Fmi2Status;
}
