//! `export_fmu!`: the C entry points of an FMU crate.
//!
//! This macro body is where the FMU crates' only `unsafe` text comes from: each FMU
//! crate can `#![deny(unsafe_code)]` (not `forbid`, which an `allow` cannot lift) and
//! still export the FMI functions, because every shim carries `#[allow(unsafe_code)]`
//! and merely forwards its raw arguments to a wrapper in [`crate::export::abi`], which
//! does all checking.

/// Exports the 34 FMI 2.0 Co-Simulation functions for a [`Model`](crate::export::Model).
///
/// Invoke once, at the root of the FMU's `cdylib` crate:
///
/// ```ignore
/// fmi2::export_fmu!(MyModel);
/// ```
///
/// It expands to `#[unsafe(no_mangle)] pub unsafe extern "C" fn fmi2DoStep(...)` and the
/// rest: the 25 common functions and the 9 Co-Simulation ones, with the exact names and
/// signatures of `fmi2Functions.h`. Each body is one call of the generic wrapper in
/// [`fmi2::export::abi`](crate::export::abi), which validates the component, the
/// allowed-states table and every pointer, and converts panics into fmi2Fatal.
#[macro_export]
macro_rules! export_fmu {
    ($model:ty) => {
        // SAFETY (whole expansion): the FMI 2.0 master guarantees the C calling contract of
        // fmi2Functions.h; each shim forwards its arguments unchanged to the wrapper in
        // `fmi2::export::abi`, which checks the component, every pointer and every length
        // before use and catches every panic, so no unchecked dereference happens here.
        #[allow(unsafe_code, non_snake_case)]
        #[unsafe(no_mangle)]
        /// FMI 2.0 `fmi2GetTypesPlatform`.
        pub extern "C" fn fmi2GetTypesPlatform() -> *const ::std::ffi::c_char {
            $crate::export::abi::get_types_platform()
        }

        #[allow(unsafe_code, non_snake_case)]
        #[unsafe(no_mangle)]
        /// FMI 2.0 `fmi2GetVersion`.
        pub extern "C" fn fmi2GetVersion() -> *const ::std::ffi::c_char {
            $crate::export::abi::get_version()
        }

        $crate::__fmi2_shim!($model; fmi2Instantiate => instantiate(
            instance_name: $crate::types::Fmi2String,
            fmu_type: $crate::types::Fmi2Type,
            fmu_guid: $crate::types::Fmi2String,
            fmu_resource_location: $crate::types::Fmi2String,
            functions: *const $crate::types::Fmi2CallbackFunctions,
            visible: $crate::types::Fmi2Boolean,
            logging_on: $crate::types::Fmi2Boolean
        ) -> $crate::types::Fmi2Component);
        $crate::__fmi2_shim!($model; fmi2FreeInstance => free_instance(
            c: $crate::types::Fmi2Component
        ) -> ());
        $crate::__fmi2_shim!($model; fmi2SetDebugLogging => set_debug_logging(
            c: $crate::types::Fmi2Component,
            logging_on: $crate::types::Fmi2Boolean,
            n_categories: usize,
            categories: *const $crate::types::Fmi2String
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2SetupExperiment => setup_experiment(
            c: $crate::types::Fmi2Component,
            tolerance_defined: $crate::types::Fmi2Boolean,
            tolerance: $crate::types::Fmi2Real,
            start_time: $crate::types::Fmi2Real,
            stop_time_defined: $crate::types::Fmi2Boolean,
            stop_time: $crate::types::Fmi2Real
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2EnterInitializationMode => enter_initialization_mode(
            c: $crate::types::Fmi2Component
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2ExitInitializationMode => exit_initialization_mode(
            c: $crate::types::Fmi2Component
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2Terminate => terminate(
            c: $crate::types::Fmi2Component
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2Reset => reset(
            c: $crate::types::Fmi2Component
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetReal => get_real(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::types::Fmi2Real
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetInteger => get_integer(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::types::Fmi2Integer
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetBoolean => get_boolean(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::types::Fmi2Boolean
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetString => get_string(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            value: *mut $crate::types::Fmi2String
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2SetReal => set_real(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::types::Fmi2Real
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2SetInteger => set_integer(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::types::Fmi2Integer
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2SetBoolean => set_boolean(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::types::Fmi2Boolean
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2SetString => set_string(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            value: *const $crate::types::Fmi2String
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetFMUstate => get_fmu_state(
            c: $crate::types::Fmi2Component,
            state: *mut $crate::types::Fmi2FmuState
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2SetFMUstate => set_fmu_state(
            c: $crate::types::Fmi2Component,
            state: $crate::types::Fmi2FmuState
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2FreeFMUstate => free_fmu_state(
            c: $crate::types::Fmi2Component,
            state: *mut $crate::types::Fmi2FmuState
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2SerializedFMUstateSize => serialized_fmu_state_size(
            c: $crate::types::Fmi2Component,
            state: $crate::types::Fmi2FmuState,
            size: *mut usize
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2SerializeFMUstate => serialize_fmu_state(
            c: $crate::types::Fmi2Component,
            state: $crate::types::Fmi2FmuState,
            serialized_state: *mut $crate::types::Fmi2Byte,
            size: usize
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2DeSerializeFMUstate => de_serialize_fmu_state(
            c: $crate::types::Fmi2Component,
            serialized_state: *const $crate::types::Fmi2Byte,
            size: usize,
            state: *mut $crate::types::Fmi2FmuState
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetDirectionalDerivative => get_directional_derivative(
            c: $crate::types::Fmi2Component,
            v_unknown_ref: *const $crate::types::Fmi2ValueReference,
            n_unknown: usize,
            v_known_ref: *const $crate::types::Fmi2ValueReference,
            n_known: usize,
            dv_known: *const $crate::types::Fmi2Real,
            dv_unknown: *mut $crate::types::Fmi2Real
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2SetRealInputDerivatives => set_real_input_derivatives(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            order: *const $crate::types::Fmi2Integer,
            value: *const $crate::types::Fmi2Real
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetRealOutputDerivatives => get_real_output_derivatives(
            c: $crate::types::Fmi2Component,
            vr: *const $crate::types::Fmi2ValueReference,
            nvr: usize,
            order: *const $crate::types::Fmi2Integer,
            value: *mut $crate::types::Fmi2Real
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2DoStep => do_step(
            c: $crate::types::Fmi2Component,
            current_communication_point: $crate::types::Fmi2Real,
            communication_step_size: $crate::types::Fmi2Real,
            no_set_fmu_state_prior_to_current_point: $crate::types::Fmi2Boolean
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2CancelStep => cancel_step(
            c: $crate::types::Fmi2Component
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetStatus => get_status(
            c: $crate::types::Fmi2Component,
            kind: $crate::types::Fmi2StatusKind,
            value: *mut $crate::types::Fmi2Status
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetRealStatus => get_real_status(
            c: $crate::types::Fmi2Component,
            kind: $crate::types::Fmi2StatusKind,
            value: *mut $crate::types::Fmi2Real
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetIntegerStatus => get_integer_status(
            c: $crate::types::Fmi2Component,
            kind: $crate::types::Fmi2StatusKind,
            value: *mut $crate::types::Fmi2Integer
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetBooleanStatus => get_boolean_status(
            c: $crate::types::Fmi2Component,
            kind: $crate::types::Fmi2StatusKind,
            value: *mut $crate::types::Fmi2Boolean
        ) -> $crate::types::Fmi2Status);
        $crate::__fmi2_shim!($model; fmi2GetStringStatus => get_string_status(
            c: $crate::types::Fmi2Component,
            kind: $crate::types::Fmi2StatusKind,
            value: *mut $crate::types::Fmi2String
        ) -> $crate::types::Fmi2Status);
    };
}

/// One exported shim of [`export_fmu!`]; not for direct use.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi2_shim {
    ($model:ty; $cname:ident => $wrapper:ident ( $($arg:ident : $ty:ty),* $(,)? ) -> $ret:ty) => {
        #[doc = concat!("FMI 2.0 `", stringify!($cname), "` (forwards to `fmi2::export::abi::", stringify!($wrapper), "`).")]
        #[doc = ""]
        #[doc = "# Safety"]
        #[doc = "The FMI 2.0 calling contract: the component comes from fmi2Instantiate and is used by one thread at a time; pointers are NULL or valid for the lengths passed."]
        #[allow(unsafe_code, non_snake_case)]
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn $cname($($arg: $ty),*) -> $ret {
            // SAFETY: the arguments are forwarded unchanged under the same contract; the
            // wrapper checks the component, every pointer and every length before use.
            unsafe { $crate::export::abi::$wrapper::<$model>($($arg),*) }
        }
    };
}
