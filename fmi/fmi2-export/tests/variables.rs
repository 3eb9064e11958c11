//! Export glue: value references, types, the FMI 2.0 CS set rules and initialization.
// The tests' logger is truly C-variadic under Miri (docs/testing.md).
#![cfg_attr(miri, feature(c_variadic))]

#[path = "support/mod.rs"]
mod export_support;

use std::ffi::CString;
use std::ptr;

use export_support::{Fmu, Oscillator, fail, status, vr};
use fmi2_export::{FmiState, abi};
use fmi2_sys::Status;

#[test]
fn unknown_value_reference_is_an_error() {
    let fmu = Fmu::initialized("unknown");
    let (s, _) = fmu.get_real(&[vr::X, 99]);
    assert_eq!(s, Status::Error);
    assert!(
        fmu.log.contains("fmi2GetReal: unknown value reference 99"),
        "{:?}",
        fmu.log.messages()
    );
    assert_eq!(fmu.state(), Some(FmiState::Terminated));

    let fmu = Fmu::initialized("unknown-set");
    assert_eq!(fmu.set_integer(&[1234], &[1]), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2SetInteger: unknown value reference 1234")
    );
}

#[test]
fn wrong_type_names_the_variable() {
    let fmu = Fmu::initialized("type");
    let (s, _) = fmu.get_integer(&[vr::MASS]);
    assert_eq!(s, Status::Error);
    assert!(
        fmu.log.contains(
            "fmi2GetInteger: variable 'mass' (value reference 4) is of type Real; \
             fmi2GetInteger accepts only Integer and Enumeration variables"
        ),
        "{:?}",
        fmu.log.messages()
    );

    let fmu = Fmu::initialized("type2");
    assert_eq!(fmu.set_boolean(&[vr::FAIL_MODE], &[1]), Status::Error);
    assert!(
        fmu.log
            .contains("variable 'fail_mode' (value reference 13) is of type Enumeration")
    );

    let fmu = Fmu::initialized("type3");
    let (s, _) = fmu.get_real(&[vr::BRAKE]);
    assert_eq!(s, Status::Error);
    assert!(fmu.log.contains("fmi2GetReal: variable 'brake'"));
}

#[test]
fn enumerations_and_booleans_go_through_integer_and_boolean() {
    let fmu = Fmu::initialized("enum");
    let (s, v) = fmu.get_integer(&[vr::FAIL_MODE, vr::SUBSTEPS, vr::STEP_COUNT]);
    assert_eq!((s, v), (Status::Ok, vec![fail::NONE, 4, 0]));
    assert_eq!(
        fmu.set_boolean(&[vr::BRAKE], &[7]),
        Status::Ok,
        "any non-zero is true"
    );
    let (s, b) = fmu.get_boolean(&[vr::BRAKE, vr::AT_REST]);
    assert_eq!(s, Status::Ok);
    assert_eq!(b[0], 1);
    assert_eq!(b[1], 0, "released from x0 = 0.1, not at rest");
}

#[test]
fn strings_are_unknown_but_state_checked() {
    let fmu = Fmu::initialized("strings");
    let mut out = [ptr::null(); 1];
    // SAFETY: nvr = 0 with NULL arrays.
    let s = unsafe { abi::get_string::<Oscillator>(fmu.c, ptr::null(), 0, ptr::null_mut()) };
    assert_eq!(status(s), Status::Ok);
    // SAFETY: arrays of length 1.
    let s = unsafe { abi::get_string::<Oscillator>(fmu.c, [vr::X].as_ptr(), 1, out.as_mut_ptr()) };
    assert_eq!(status(s), Status::Error);
    assert!(fmu.log.contains("fmi2GetString: unknown value reference 1"));

    let fmu = Fmu::initialized("strings2");
    let text = CString::new("hello").unwrap();
    // SAFETY: arrays of length 1.
    let s =
        unsafe { abi::set_string::<Oscillator>(fmu.c, [7].as_ptr(), 1, [text.as_ptr()].as_ptr()) };
    assert_eq!(status(s), Status::Error);
    assert!(fmu.log.contains("fmi2SetString: unknown value reference 7"));

    let fmu = Fmu::new("strings3");
    // SAFETY: nvr = 0; but GetString is illegal in Instantiated.
    let s = unsafe { abi::get_string::<Oscillator>(fmu.c, ptr::null(), 0, ptr::null_mut()) };
    assert_eq!(status(s), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2GetString: illegal call sequence in state Instantiated")
    );
}

#[test]
fn set_rules_before_initialization() {
    let fmu = Fmu::new("rules");
    // Instantiated: parameters (fixed and tunable) and inputs.
    assert_eq!(
        fmu.set_real(
            &[vr::MASS, vr::DAMPING, vr::FORCE, vr::X0],
            &[2.0, 1.0, 0.5, 0.2]
        ),
        Status::Ok
    );
    assert_eq!(
        fmu.set_integer(&[vr::SUBSTEPS, vr::FAIL_MODE], &[8, fail::NONE]),
        Status::Ok
    );
    assert_eq!(fmu.set_boolean(&[vr::BRAKE], &[1]), Status::Ok);
    assert_eq!(fmu.setup(0.0, None), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    assert_eq!(
        fmu.set_real(&[vr::MASS], &[2.5]),
        Status::Ok,
        "fixed parameter in init mode"
    );
    assert_eq!(fmu.exit_init(), Status::Ok);
    let (s, v) = fmu.get_real(&[vr::MASS, vr::DAMPING, vr::FORCE, vr::X, vr::OMEGA]);
    assert_eq!(s, Status::Ok);
    assert_eq!(v, [2.5, 1.0, 0.5, 0.2, (40.0f64 / 2.5).sqrt()]);
    let (_, n) = fmu.get_integer(&[vr::SUBSTEPS]);
    assert_eq!(n, [8]);
}

#[test]
fn set_rules_after_initialization() {
    let fmu = Fmu::initialized("after");
    // Inputs and tunable parameters: fine.
    assert_eq!(
        fmu.set_real(&[vr::FORCE, vr::DAMPING], &[1.0, 0.7]),
        Status::Ok
    );
    assert_eq!(fmu.set_integer(&[vr::FAIL_MODE], &[fail::NONE]), Status::Ok);
    // A fixed parameter: refused with the rule.
    assert_eq!(fmu.set_real(&[vr::MASS], &[2.0]), Status::Error);
    assert!(
        fmu.log.contains(
            "fmi2SetReal: cannot set fixed parameter 'mass' in state StepComplete; \
             fixed parameters may be set only before fmi2ExitInitializationMode"
        ),
        "{:?}",
        fmu.log.messages()
    );
    assert_eq!(fmu.state(), Some(FmiState::Terminated));
    let fmu = Fmu::initialized("after-int");
    assert_eq!(fmu.set_integer(&[vr::SUBSTEPS], &[2]), Status::Error);
    assert!(
        fmu.log
            .contains("cannot set fixed parameter 'substeps' in state StepComplete")
    );
}

/// The glue accepts a value-reference array it accepted before by comparing it with the
/// last one; settability depends on the state, so the same array is refused once the
/// state forbids it, and an array with one unknown reference is never remembered.
#[test]
fn an_accepted_array_is_checked_again_in_a_new_state() {
    let fmu = Fmu::new("again");
    let both = [vr::FORCE, vr::MASS];
    assert_eq!(fmu.set_real(&both, &[0.5, 2.0]), Status::Ok);
    assert_eq!(fmu.set_real(&both, &[0.6, 2.1]), Status::Ok);
    assert_eq!(fmu.setup(0.0, None), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    assert_eq!(fmu.set_real(&both, &[0.7, 2.2]), Status::Ok);
    assert_eq!(fmu.exit_init(), Status::Ok);
    assert_eq!(fmu.set_real(&both, &[0.8, 2.3]), Status::Error);
    assert!(
        fmu.log
            .contains("cannot set fixed parameter 'mass' in state StepComplete"),
        "{:?}",
        fmu.log.messages()
    );

    let fmu = Fmu::initialized("again-unknown");
    assert_eq!(fmu.get_real(&[vr::X, vr::V]).0, Status::Ok);
    assert_eq!(fmu.get_real(&[vr::X, 99]).0, Status::Error);
    // Terminated still allows gets; the refused array was not remembered.
    assert_eq!(fmu.get_real(&[vr::X, 99]).0, Status::Error);
    let refused = fmu.log.messages();
    let refused = refused
        .iter()
        .filter(|m| m.contains("unknown value reference 99"))
        .count();
    assert_eq!(refused, 2, "{:?}", fmu.log.messages());
}

#[test]
fn never_settable_variables() {
    let cases: [(u32, &str); 6] = [
        (vr::X, "fmi2SetReal: cannot set output 'x'"),
        (
            vr::OMEGA,
            "fmi2SetReal: cannot set calculated parameter 'omega'",
        ),
        (vr::ACCEL, "fmi2SetReal: cannot set local variable 'accel'"),
        (vr::UNIT, "fmi2SetReal: cannot set constant 'unit'"),
        (
            vr::TIME,
            "fmi2SetReal: cannot set independent variable 'time'",
        ),
        (vr::V, "fmi2SetReal: cannot set output 'v'"),
    ];
    for (r, msg) in cases {
        for before in [true, false] {
            let fmu = if before {
                Fmu::new("never")
            } else {
                Fmu::initialized("never")
            };
            let x_before = if before { None } else { Some(fmu.real(vr::X)) };
            assert_eq!(fmu.set_real(&[vr::FORCE, r], &[3.0, 1.0]), Status::Error);
            assert!(fmu.log.contains(msg), "{:?}", fmu.log.messages());
            if let Some(x) = x_before {
                // Nothing of the call was applied: validation precedes every write.
                assert_eq!(fmu.real(vr::X), x);
                assert_eq!(fmu.real(vr::FORCE), 0.0);
            }
        }
    }
    let fmu = Fmu::initialized("never-int");
    assert_eq!(fmu.set_integer(&[vr::STEP_COUNT], &[5]), Status::Error);
    assert!(fmu.log.contains("cannot set output 'step_count'"));
    let fmu = Fmu::initialized("never-bool");
    assert_eq!(fmu.set_boolean(&[vr::AT_REST], &[1]), Status::Error);
    assert!(fmu.log.contains("cannot set output 'at_rest'"));
}

#[test]
fn model_rejection_is_returned_and_logged() {
    let fmu = Fmu::initialized("reject");
    assert_eq!(fmu.set_real(&[vr::FORCE], &[f64::INFINITY]), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2SetReal: value reference 3 must be finite, got inf")
    );
    let fmu = Fmu::new("reject-int");
    assert_eq!(fmu.set_integer(&[vr::SUBSTEPS], &[0]), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2SetInteger: substeps must be >= 1, got 0")
    );
}

#[test]
fn outputs_in_initialization_mode_follow_what_was_set() {
    let fmu = Fmu::new("dirty");
    assert_eq!(fmu.setup(0.0, None), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    // Nothing set yet: still initialized before the first read.
    let (s, v) = fmu.get_real(&[vr::X, vr::OMEGA]);
    assert_eq!(s, Status::Ok);
    assert_eq!(v, [0.1, 40f64.sqrt()]);
    // Setting a parameter makes the next read re-run initialize.
    assert_eq!(
        fmu.set_real(&[vr::X0, vr::STIFFNESS], &[0.3, 9.0]),
        Status::Ok
    );
    let (s, v) = fmu.get_real(&[vr::X, vr::OMEGA, vr::ACCEL]);
    assert_eq!(s, Status::Ok);
    assert_eq!(v, [0.3, 3.0, -9.0 * 0.3]);
    // An input too.
    assert_eq!(fmu.set_real(&[vr::FORCE], &[1.0]), Status::Ok);
    assert_eq!(fmu.real(vr::ACCEL), 1.0 - 9.0 * 0.3);
    assert_eq!(fmu.exit_init(), Status::Ok);
    assert_eq!(fmu.real(vr::X), 0.3);
}

#[test]
fn initialization_errors_are_returned() {
    let fmu = Fmu::new("bad-mass");
    assert_eq!(fmu.set_real(&[vr::MASS], &[-1.0]), Status::Ok);
    assert_eq!(fmu.setup(0.0, None), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    assert_eq!(fmu.exit_init(), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2ExitInitializationMode: mass must be > 0, got -1")
    );
    assert_eq!(fmu.state(), Some(FmiState::Terminated));

    let fmu = Fmu::new("bad-mass-get");
    assert_eq!(fmu.setup(0.0, None), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    assert_eq!(fmu.set_real(&[vr::MASS], &[0.0]), Status::Ok);
    assert_eq!(fmu.get_real(&[vr::X]).0, Status::Error);
    assert!(fmu.log.contains("fmi2GetReal: mass must be > 0, got 0"));
}

/// A declared `min` without a `max` still bounds what a setter accepts; a refused call
/// changes nothing.
#[test]
fn a_lower_bound_alone_is_enforced() {
    let fmu = Fmu::initialized("lower-bound");
    assert_eq!(
        fmu.set_real(&[vr::DAMPING], &[0.0]),
        Status::Ok,
        "the bound itself"
    );
    assert_eq!(
        fmu.set_real(&[vr::FORCE, vr::DAMPING], &[3.0, -1.0]),
        Status::Error
    );
    assert!(
        fmu.log
            .contains("fmi2SetReal: damping = -1 is outside its range [0, inf]"),
        "{:?}",
        fmu.log.messages()
    );
    assert_eq!(fmu.real(vr::DAMPING), 0.0);
    assert_eq!(
        fmu.real(vr::FORCE),
        0.0,
        "nothing of the refused call was written"
    );
}

#[test]
fn setup_experiment_validates_times() {
    let fmu = Fmu::new("setup");
    assert_eq!(fmu.setup(1.0, Some(0.5)), Status::Error);
    assert!(
        fmu.log.contains(
            "fmi2SetupExperiment: stopTime 0.5 must be finite and not before startTime 1"
        )
    );
    let fmu = Fmu::new("setup-nan");
    assert_eq!(fmu.setup(f64::NAN, None), Status::Error);
    // An experiment that ends where it starts is allowed (nothing to step).
    let fmu = Fmu::new("setup-empty");
    assert_eq!(fmu.setup(1.0, Some(1.0)), Status::Ok);
    let fmu = Fmu::new("setup-ok");
    assert_eq!(fmu.setup(2.5, Some(3.0)), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    assert_eq!(fmu.real(vr::TIME), 2.5, "initialize gets the start time");
    assert_eq!(fmu.exit_init(), Status::Ok);
    assert_eq!(fmu.last_successful_time(), (Status::Ok, 2.5));
}
