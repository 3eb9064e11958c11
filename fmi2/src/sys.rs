//! The C signatures of the 34 FMI 2.0 Co-Simulation functions, written once (the role of
//! `fmi2Functions.h`): the export side generates its shims from this table and the import
//! side its typed function pointers, so the two cannot disagree.

/// Calls [`__fmi2_each!`](crate::__fmi2_each) with `[$mode]` and every function, in the
/// order of `fmi2Functions.h`, as `cname => wrapper(arg: Type, …) -> Return;` where
/// `wrapper` is the function of `fmi2::export::abi` that implements it.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi2_functions {
    ($($mode:tt)*) => {
        $crate::__fmi2_each! { [$($mode)*]
            fmi2GetTypesPlatform => get_types_platform() -> *const ::std::ffi::c_char;
            fmi2GetVersion => get_version() -> *const ::std::ffi::c_char;
            fmi2SetDebugLogging => set_debug_logging(
                c: $crate::types::Fmi2Component,
                logging_on: $crate::types::Fmi2Boolean,
                n_categories: usize,
                categories: *const $crate::types::Fmi2String
            ) -> $crate::types::Fmi2Status;
            fmi2Instantiate => instantiate(
                instance_name: $crate::types::Fmi2String,
                fmu_type: $crate::types::Fmi2Type,
                fmu_guid: $crate::types::Fmi2String,
                fmu_resource_location: $crate::types::Fmi2String,
                functions: *const $crate::types::Fmi2CallbackFunctions,
                visible: $crate::types::Fmi2Boolean,
                logging_on: $crate::types::Fmi2Boolean
            ) -> $crate::types::Fmi2Component;
            fmi2FreeInstance => free_instance(
                c: $crate::types::Fmi2Component
            ) -> ();
            fmi2SetupExperiment => setup_experiment(
                c: $crate::types::Fmi2Component,
                tolerance_defined: $crate::types::Fmi2Boolean,
                tolerance: $crate::types::Fmi2Real,
                start_time: $crate::types::Fmi2Real,
                stop_time_defined: $crate::types::Fmi2Boolean,
                stop_time: $crate::types::Fmi2Real
            ) -> $crate::types::Fmi2Status;
            fmi2EnterInitializationMode => enter_initialization_mode(
                c: $crate::types::Fmi2Component
            ) -> $crate::types::Fmi2Status;
            fmi2ExitInitializationMode => exit_initialization_mode(
                c: $crate::types::Fmi2Component
            ) -> $crate::types::Fmi2Status;
            fmi2Terminate => terminate(
                c: $crate::types::Fmi2Component
            ) -> $crate::types::Fmi2Status;
            fmi2Reset => reset(
                c: $crate::types::Fmi2Component
            ) -> $crate::types::Fmi2Status;
            fmi2GetReal => get_real(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                value: *mut $crate::types::Fmi2Real
            ) -> $crate::types::Fmi2Status;
            fmi2GetInteger => get_integer(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                value: *mut $crate::types::Fmi2Integer
            ) -> $crate::types::Fmi2Status;
            fmi2GetBoolean => get_boolean(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                value: *mut $crate::types::Fmi2Boolean
            ) -> $crate::types::Fmi2Status;
            fmi2GetString => get_string(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                value: *mut $crate::types::Fmi2String
            ) -> $crate::types::Fmi2Status;
            fmi2SetReal => set_real(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                value: *const $crate::types::Fmi2Real
            ) -> $crate::types::Fmi2Status;
            fmi2SetInteger => set_integer(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                value: *const $crate::types::Fmi2Integer
            ) -> $crate::types::Fmi2Status;
            fmi2SetBoolean => set_boolean(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                value: *const $crate::types::Fmi2Boolean
            ) -> $crate::types::Fmi2Status;
            fmi2SetString => set_string(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                value: *const $crate::types::Fmi2String
            ) -> $crate::types::Fmi2Status;
            fmi2GetFMUstate => get_fmu_state(
                c: $crate::types::Fmi2Component,
                state: *mut $crate::types::Fmi2FmuState
            ) -> $crate::types::Fmi2Status;
            fmi2SetFMUstate => set_fmu_state(
                c: $crate::types::Fmi2Component,
                state: $crate::types::Fmi2FmuState
            ) -> $crate::types::Fmi2Status;
            fmi2FreeFMUstate => free_fmu_state(
                c: $crate::types::Fmi2Component,
                state: *mut $crate::types::Fmi2FmuState
            ) -> $crate::types::Fmi2Status;
            fmi2SerializedFMUstateSize => serialized_fmu_state_size(
                c: $crate::types::Fmi2Component,
                state: $crate::types::Fmi2FmuState,
                size: *mut usize
            ) -> $crate::types::Fmi2Status;
            fmi2SerializeFMUstate => serialize_fmu_state(
                c: $crate::types::Fmi2Component,
                state: $crate::types::Fmi2FmuState,
                serialized_state: *mut $crate::types::Fmi2Byte,
                size: usize
            ) -> $crate::types::Fmi2Status;
            fmi2DeSerializeFMUstate => de_serialize_fmu_state(
                c: $crate::types::Fmi2Component,
                serialized_state: *const $crate::types::Fmi2Byte,
                size: usize,
                state: *mut $crate::types::Fmi2FmuState
            ) -> $crate::types::Fmi2Status;
            fmi2GetDirectionalDerivative => get_directional_derivative(
                c: $crate::types::Fmi2Component,
                v_unknown_ref: *const $crate::types::Fmi2ValueReference,
                n_unknown: usize,
                v_known_ref: *const $crate::types::Fmi2ValueReference,
                n_known: usize,
                dv_known: *const $crate::types::Fmi2Real,
                dv_unknown: *mut $crate::types::Fmi2Real
            ) -> $crate::types::Fmi2Status;
            fmi2SetRealInputDerivatives => set_real_input_derivatives(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                order: *const $crate::types::Fmi2Integer,
                value: *const $crate::types::Fmi2Real
            ) -> $crate::types::Fmi2Status;
            fmi2GetRealOutputDerivatives => get_real_output_derivatives(
                c: $crate::types::Fmi2Component,
                vr: *const $crate::types::Fmi2ValueReference,
                nvr: usize,
                order: *const $crate::types::Fmi2Integer,
                value: *mut $crate::types::Fmi2Real
            ) -> $crate::types::Fmi2Status;
            fmi2DoStep => do_step(
                c: $crate::types::Fmi2Component,
                current_communication_point: $crate::types::Fmi2Real,
                communication_step_size: $crate::types::Fmi2Real,
                no_set_fmu_state_prior_to_current_point: $crate::types::Fmi2Boolean
            ) -> $crate::types::Fmi2Status;
            fmi2CancelStep => cancel_step(
                c: $crate::types::Fmi2Component
            ) -> $crate::types::Fmi2Status;
            fmi2GetStatus => get_status(
                c: $crate::types::Fmi2Component,
                kind: $crate::types::Fmi2StatusKind,
                value: *mut $crate::types::Fmi2Status
            ) -> $crate::types::Fmi2Status;
            fmi2GetRealStatus => get_real_status(
                c: $crate::types::Fmi2Component,
                kind: $crate::types::Fmi2StatusKind,
                value: *mut $crate::types::Fmi2Real
            ) -> $crate::types::Fmi2Status;
            fmi2GetIntegerStatus => get_integer_status(
                c: $crate::types::Fmi2Component,
                kind: $crate::types::Fmi2StatusKind,
                value: *mut $crate::types::Fmi2Integer
            ) -> $crate::types::Fmi2Status;
            fmi2GetBooleanStatus => get_boolean_status(
                c: $crate::types::Fmi2Component,
                kind: $crate::types::Fmi2StatusKind,
                value: *mut $crate::types::Fmi2Boolean
            ) -> $crate::types::Fmi2Status;
            fmi2GetStringStatus => get_string_status(
                c: $crate::types::Fmi2Component,
                kind: $crate::types::Fmi2StatusKind,
                value: *mut $crate::types::Fmi2String
            ) -> $crate::types::Fmi2Status;
        }
    };
}

/// The two readers of the table: `[export Model]` writes the exported shims, `[import]` the
/// struct of function pointers the importer resolves; not for direct use.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi2_each {
    ([export $model:ty] $($cname:ident => $wrapper:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty;)*) => {
        $( $crate::__fmi2_shim!($model; $cname => $wrapper($($arg: $ty),*) -> $ret); )*
    };
    ([import] $($cname:ident => $wrapper:ident ( $($arg:ident : $ty:ty),* ) -> $ret:ty;)*) => {
        /// Typed pointers to every function; valid while the `Library` they came from is loaded.
        #[allow(non_snake_case)] // Field names are the C symbol names, for grep-ability.
        #[derive(Debug, Clone, Copy)]
        pub(crate) struct Functions {
            $(pub(crate) $cname: unsafe extern "C" fn($($ty),*) -> $ret,)*
        }

        /// Every symbol `Functions::load` resolves, in the order of the standard's header.
        pub const SYMBOLS: &[&str] = &[$(stringify!($cname)),*];

        impl Functions {
            /// Resolves every symbol; the first missing one is returned by name.
            ///
            /// # Safety
            /// `library` must be an FMI 2.0 binary: each symbol, if present, must have the
            /// signature of the standard's header, which is what the pointer is typed as.
            pub(crate) unsafe fn load(
                library: &libloading::Library,
            ) -> Result<Self, (&'static str, libloading::Error)> {
                Ok(Self {
                    $($cname: {
                        // SAFETY: per this function's contract, the symbol has this signature.
                        let symbol = unsafe {
                            library.get::<unsafe extern "C" fn($($ty),*) -> $ret>(stringify!($cname))
                        };
                        *symbol.map_err(|e| (stringify!($cname), e))?
                    },)*
                })
            }
        }
    };
}
