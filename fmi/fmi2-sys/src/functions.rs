//! The C signatures of the 34 FMI 2.0 Co-Simulation functions, written once (the role of
//! `fmi2Functions.h`): the export side generates its shims from this table and the import
//! side its typed function pointers, so the two cannot disagree.

/// Expands `$callback! { [args…] cname => wrapper(arg: Type, …) -> Return; … }` with every
/// function, in the order of `fmi2Functions.h`; `wrapper` is the snake-case name the export
/// side implements it under. Invoked as `__fmi2_functions!({path::to::callback} [args…])`:
/// the export crate's callback writes the `extern "C"` shims, the import crate's the struct of
/// function pointers it resolves.
#[doc(hidden)]
#[macro_export]
macro_rules! __fmi2_functions {
    ({$($callback:tt)+} [$($args:tt)*]) => {
        $($callback)+! { [$($args)*]
            fmi2GetTypesPlatform => get_types_platform() -> *const ::std::ffi::c_char;
            fmi2GetVersion => get_version() -> *const ::std::ffi::c_char;
            fmi2SetDebugLogging => set_debug_logging(
                c: $crate::Fmi2Component,
                logging_on: $crate::Fmi2Boolean,
                n_categories: usize,
                categories: *const $crate::Fmi2String
            ) -> $crate::Fmi2Status;
            fmi2Instantiate => instantiate(
                instance_name: $crate::Fmi2String,
                fmu_type: $crate::Fmi2Type,
                fmu_guid: $crate::Fmi2String,
                fmu_resource_location: $crate::Fmi2String,
                functions: *const $crate::Fmi2CallbackFunctions,
                visible: $crate::Fmi2Boolean,
                logging_on: $crate::Fmi2Boolean
            ) -> $crate::Fmi2Component;
            fmi2FreeInstance => free_instance(
                c: $crate::Fmi2Component
            ) -> ();
            fmi2SetupExperiment => setup_experiment(
                c: $crate::Fmi2Component,
                tolerance_defined: $crate::Fmi2Boolean,
                tolerance: $crate::Fmi2Real,
                start_time: $crate::Fmi2Real,
                stop_time_defined: $crate::Fmi2Boolean,
                stop_time: $crate::Fmi2Real
            ) -> $crate::Fmi2Status;
            fmi2EnterInitializationMode => enter_initialization_mode(
                c: $crate::Fmi2Component
            ) -> $crate::Fmi2Status;
            fmi2ExitInitializationMode => exit_initialization_mode(
                c: $crate::Fmi2Component
            ) -> $crate::Fmi2Status;
            fmi2Terminate => terminate(
                c: $crate::Fmi2Component
            ) -> $crate::Fmi2Status;
            fmi2Reset => reset(
                c: $crate::Fmi2Component
            ) -> $crate::Fmi2Status;
            fmi2GetReal => get_real(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                value: *mut $crate::Fmi2Real
            ) -> $crate::Fmi2Status;
            fmi2GetInteger => get_integer(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                value: *mut $crate::Fmi2Integer
            ) -> $crate::Fmi2Status;
            fmi2GetBoolean => get_boolean(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                value: *mut $crate::Fmi2Boolean
            ) -> $crate::Fmi2Status;
            fmi2GetString => get_string(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                value: *mut $crate::Fmi2String
            ) -> $crate::Fmi2Status;
            fmi2SetReal => set_real(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                value: *const $crate::Fmi2Real
            ) -> $crate::Fmi2Status;
            fmi2SetInteger => set_integer(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                value: *const $crate::Fmi2Integer
            ) -> $crate::Fmi2Status;
            fmi2SetBoolean => set_boolean(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                value: *const $crate::Fmi2Boolean
            ) -> $crate::Fmi2Status;
            fmi2SetString => set_string(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                value: *const $crate::Fmi2String
            ) -> $crate::Fmi2Status;
            fmi2GetFMUstate => get_fmu_state(
                c: $crate::Fmi2Component,
                state: *mut $crate::Fmi2FmuState
            ) -> $crate::Fmi2Status;
            fmi2SetFMUstate => set_fmu_state(
                c: $crate::Fmi2Component,
                state: $crate::Fmi2FmuState
            ) -> $crate::Fmi2Status;
            fmi2FreeFMUstate => free_fmu_state(
                c: $crate::Fmi2Component,
                state: *mut $crate::Fmi2FmuState
            ) -> $crate::Fmi2Status;
            fmi2SerializedFMUstateSize => serialized_fmu_state_size(
                c: $crate::Fmi2Component,
                state: $crate::Fmi2FmuState,
                size: *mut usize
            ) -> $crate::Fmi2Status;
            fmi2SerializeFMUstate => serialize_fmu_state(
                c: $crate::Fmi2Component,
                state: $crate::Fmi2FmuState,
                serialized_state: *mut $crate::Fmi2Byte,
                size: usize
            ) -> $crate::Fmi2Status;
            fmi2DeSerializeFMUstate => de_serialize_fmu_state(
                c: $crate::Fmi2Component,
                serialized_state: *const $crate::Fmi2Byte,
                size: usize,
                state: *mut $crate::Fmi2FmuState
            ) -> $crate::Fmi2Status;
            fmi2GetDirectionalDerivative => get_directional_derivative(
                c: $crate::Fmi2Component,
                v_unknown_ref: *const $crate::Fmi2ValueReference,
                n_unknown: usize,
                v_known_ref: *const $crate::Fmi2ValueReference,
                n_known: usize,
                dv_known: *const $crate::Fmi2Real,
                dv_unknown: *mut $crate::Fmi2Real
            ) -> $crate::Fmi2Status;
            fmi2SetRealInputDerivatives => set_real_input_derivatives(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                order: *const $crate::Fmi2Integer,
                value: *const $crate::Fmi2Real
            ) -> $crate::Fmi2Status;
            fmi2GetRealOutputDerivatives => get_real_output_derivatives(
                c: $crate::Fmi2Component,
                vr: *const $crate::Fmi2ValueReference,
                nvr: usize,
                order: *const $crate::Fmi2Integer,
                value: *mut $crate::Fmi2Real
            ) -> $crate::Fmi2Status;
            fmi2DoStep => do_step(
                c: $crate::Fmi2Component,
                current_communication_point: $crate::Fmi2Real,
                communication_step_size: $crate::Fmi2Real,
                no_set_fmu_state_prior_to_current_point: $crate::Fmi2Boolean
            ) -> $crate::Fmi2Status;
            fmi2CancelStep => cancel_step(
                c: $crate::Fmi2Component
            ) -> $crate::Fmi2Status;
            fmi2GetStatus => get_status(
                c: $crate::Fmi2Component,
                kind: $crate::Fmi2StatusKind,
                value: *mut $crate::Fmi2Status
            ) -> $crate::Fmi2Status;
            fmi2GetRealStatus => get_real_status(
                c: $crate::Fmi2Component,
                kind: $crate::Fmi2StatusKind,
                value: *mut $crate::Fmi2Real
            ) -> $crate::Fmi2Status;
            fmi2GetIntegerStatus => get_integer_status(
                c: $crate::Fmi2Component,
                kind: $crate::Fmi2StatusKind,
                value: *mut $crate::Fmi2Integer
            ) -> $crate::Fmi2Status;
            fmi2GetBooleanStatus => get_boolean_status(
                c: $crate::Fmi2Component,
                kind: $crate::Fmi2StatusKind,
                value: *mut $crate::Fmi2Boolean
            ) -> $crate::Fmi2Status;
            fmi2GetStringStatus => get_string_status(
                c: $crate::Fmi2Component,
                kind: $crate::Fmi2StatusKind,
                value: *mut $crate::Fmi2String
            ) -> $crate::Fmi2Status;
        }
    };
}
