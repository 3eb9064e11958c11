//! Export glue: `export_fmu!` expands to the 34 FMI functions and they reach the model.
// The tests' logger is truly C-variadic under Miri (docs/testing.md).
#![cfg_attr(miri, feature(c_variadic))]

#[path = "support/mod.rs"]
mod export_support;

use std::ffi::{CStr, CString};
use std::ptr;

use export_support::{Capture, GUID, Oscillator, logger, vr};
use fmi2_sys::{FMI2_CO_SIMULATION, Fmi2CallbackFunctions, Fmi2FmuState, status_kind};

fmi2_export::export_fmu!(Oscillator);

#[test]
fn exported_functions_drive_the_model() {
    // SAFETY: the exported functions are called as a master would, with valid arguments.
    unsafe {
        assert_eq!(CStr::from_ptr(fmi2GetVersion()), c"2.0");
        assert_eq!(CStr::from_ptr(fmi2GetTypesPlatform()), c"default");
        let capture = std::sync::Arc::<Capture>::default();
        let callbacks = Fmi2CallbackFunctions {
            logger: logger(),
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: std::sync::Arc::as_ptr(&capture).cast_mut().cast(),
        };
        let name = CString::new("macro").unwrap();
        let guid = CString::new(GUID).unwrap();
        let c = fmi2Instantiate(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            ptr::null(),
            &callbacks,
            0,
            1,
        );
        assert!(!c.is_null());
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 1, 1.0), 0);
        assert_eq!(fmi2EnterInitializationMode(c), 0);
        assert_eq!(fmi2SetReal(c, [vr::FORCE].as_ptr(), 1, [1.5].as_ptr()), 0);
        assert_eq!(fmi2ExitInitializationMode(c), 0);
        for k in 0..10 {
            assert_eq!(fmi2DoStep(c, f64::from(k) * 0.1, 0.1, 1), 0);
        }
        let mut x = [0.0; 2];
        assert_eq!(
            fmi2GetReal(c, [vr::X, vr::FORCE].as_ptr(), 2, x.as_mut_ptr()),
            0
        );
        assert_eq!(x[1], 1.5);
        let mut n = [0];
        assert_eq!(
            fmi2GetInteger(c, [vr::STEP_COUNT].as_ptr(), 1, n.as_mut_ptr()),
            0
        );
        assert_eq!(n[0], 10);
        let mut t = 0.0;
        assert_eq!(
            fmi2GetRealStatus(c, status_kind::LAST_SUCCESSFUL_TIME, &mut t),
            0
        );
        assert!((t - 1.0).abs() < 1e-12);

        let mut state: Fmi2FmuState = ptr::null_mut();
        assert_eq!(fmi2GetFMUstate(c, &mut state), 0);
        let mut size = 0;
        assert_eq!(fmi2SerializedFMUstateSize(c, state, &mut size), 0);
        let mut bytes = vec![0; size];
        assert_eq!(fmi2SerializeFMUstate(c, state, bytes.as_mut_ptr(), size), 0);
        assert_eq!(fmi2FreeFMUstate(c, &mut state), 0);
        assert_eq!(
            fmi2DeSerializeFMUstate(c, bytes.as_ptr(), size, &mut state),
            0
        );
        assert_eq!(fmi2SetFMUstate(c, state), 0);
        assert_eq!(fmi2FreeFMUstate(c, &mut state), 0);

        // The not-supported functions exist and answer fmi2Error (3).
        assert_eq!(fmi2CancelStep(c), 3);
        assert_eq!(fmi2Reset(c), 0);
        assert_eq!(fmi2SetDebugLogging(c, 0, 0, ptr::null()), 0);
        assert_eq!(fmi2Terminate(c), 3, "illegal in Instantiated");
        fmi2FreeInstance(c);
        assert!(capture.contains("fmi2Instantiate: instance of Oscillator created"));
        assert!(capture.contains("fmi2CancelStep: illegal call sequence in state StepComplete"));
        assert!(capture.contains("fmi2Terminate: illegal call sequence in state Instantiated"));

        // Every other symbol exists with the FMI signature (a function-pointer coercion
        // fails to compile otherwise).
        let _: [unsafe extern "C" fn(fmi2_sys::Fmi2Component) -> fmi2_sys::Fmi2Status; 4] = [
            fmi2Terminate,
            fmi2Reset,
            fmi2CancelStep,
            fmi2EnterInitializationMode,
        ];
        let _: unsafe extern "C" fn(
            fmi2_sys::Fmi2Component,
            *const u32,
            usize,
            *const u32,
            usize,
            *const f64,
            *mut f64,
        ) -> i32 = fmi2GetDirectionalDerivative;
        let symbols: [*const (); 11] = [
            fmi2GetBoolean as *const (),
            fmi2GetString as *const (),
            fmi2SetInteger as *const (),
            fmi2SetBoolean as *const (),
            fmi2SetString as *const (),
            fmi2SetRealInputDerivatives as *const (),
            fmi2GetRealOutputDerivatives as *const (),
            fmi2GetStatus as *const (),
            fmi2GetIntegerStatus as *const (),
            fmi2GetBooleanStatus as *const (),
            fmi2GetStringStatus as *const (),
        ];
        assert!(symbols.iter().all(|p| !p.is_null()));
    }
}
