//! Export glue: instantiation, the legal call sequence, the allowed-states table, NULL
//! handling, logging and status escalation.
// The tests' logger is truly C-variadic under Miri (docs/testing.md).
#![cfg_attr(miri, feature(c_variadic))]

#[path = "support/mod.rs"]
mod export_support;

use std::ffi::CString;
use std::ptr;

use export_support::{
    Donor, Fmu, GUID, Oscillator, call, expected_allowed, fail, glue_run, instantiate_raw,
    reference_run, status, vr,
};
use fmi2_export::{FmiState, Function, abi};
use fmi2_sys::Status;
use fmi2_sys::{FMI2_CO_SIMULATION, FMI2_MODEL_EXCHANGE, Fmi2CallbackFunctions, Fmi2Component};

#[test]
fn legal_sequence_matches_the_model_run_directly() {
    let h = 0.01;
    let force = |k: usize| if k < 50 { 2.0 } else { -1.0 };
    let fmu = Fmu::with_logging("legal", true);
    assert_eq!(fmu.state(), Some(FmiState::Instantiated));
    assert_eq!(fmu.setup(0.0, Some(1.0)), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    assert_eq!(fmu.set_real(&[vr::DAMPING], &[0.5]), Status::Ok);
    assert_eq!(fmu.exit_init(), Status::Ok);
    assert_eq!(fmu.state(), Some(FmiState::StepComplete));
    let reference = reference_run(100, h, force);
    for (k, &(x_ref, v_ref)) in reference.iter().enumerate() {
        assert_eq!(fmu.set_real(&[vr::FORCE], &[force(k)]), Status::Ok);
        assert_eq!(fmu.do_step(k as f64 * h, h), Status::Ok);
        let (s, xv) = fmu.get_real(&[vr::X, vr::V]);
        assert_eq!(s, Status::Ok);
        assert_eq!(xv[0].to_bits(), x_ref.to_bits(), "x at step {k}");
        assert_eq!(xv[1].to_bits(), v_ref.to_bits(), "v at step {k}");
    }
    let (s, counts) = fmu.get_integer(&[vr::STEP_COUNT]);
    assert_eq!((s, counts[0]), (Status::Ok, 100));
    let (s, t) = fmu.last_successful_time();
    assert_eq!(s, Status::Ok);
    assert!((t - 1.0).abs() < 1e-12, "time after 100 steps of 0.01: {t}");
    assert_eq!(fmu.terminate(), Status::Ok);
    assert_eq!(fmu.state(), Some(FmiState::Terminated));
    // Values stay readable after terminate.
    assert_eq!(fmu.real(vr::X).to_bits(), reference[99].0.to_bits());
    let events = fmu.log.records();
    assert!(
        events
            .iter()
            .all(|r| r.category == "logEvents" && r.status == 0),
        "{events:?}"
    );
    for f in [
        "fmi2Instantiate: ",
        "fmi2SetupExperiment: ",
        "fmi2ExitInitializationMode: ",
        "fmi2Terminate: ",
    ] {
        assert!(
            fmu.log.messages().iter().any(|m| m.starts_with(f)),
            "no event from {f}"
        );
    }
}

#[test]
fn library_table_matches_the_standard_table() {
    for f in Function::ALL {
        for s in FmiState::ALL {
            assert_eq!(
                f.allowed_in(s),
                expected_allowed(f, s),
                "{} in {s}",
                f.name()
            );
        }
    }
}

#[test]
fn every_forbidden_call_is_an_error_and_every_allowed_one_passes_the_state_check() {
    let donor = Donor::new();
    for state in FmiState::ALL {
        for f in Function::ALL {
            if f == Function::FreeInstance {
                continue;
            }
            let fmu = Fmu::in_state(state);
            let got = call(fmu.c, f, &donor);
            let illegal = format!("{}: illegal call sequence in state {state}", f.name());
            if expected_allowed(f, state) {
                assert!(
                    !fmu.log.contains(&illegal),
                    "{} rejected in {state}",
                    f.name()
                );
            } else {
                assert_eq!(got, Status::Error, "{} in {state}", f.name());
                let records = fmu.log.records();
                assert!(
                    records.iter().any(|r| r.message.starts_with(&illegal)
                        && r.status == 3
                        && r.category == "logStatusError"),
                    "{} in {state}: {records:?}",
                    f.name()
                );
                let after = if state == FmiState::Fatal {
                    FmiState::Fatal
                } else {
                    FmiState::Terminated
                };
                assert_eq!(fmu.state(), Some(after), "{} in {state}", f.name());
            }
        }
    }
}

#[test]
fn null_component_is_an_error_for_every_function() {
    let donor = Donor::new();
    for f in Function::ALL {
        if f != Function::FreeInstance {
            assert_eq!(
                call(ptr::null_mut(), f, &donor),
                Status::Error,
                "{}",
                f.name()
            );
        }
    }
    // SAFETY: NULL is explicitly allowed.
    unsafe { abi::free_instance::<Oscillator>(ptr::null_mut()) };
}

#[test]
fn foreign_component_is_rejected_without_touching_it() {
    let donor = Donor::new();
    // A snapshot is not a component; neither is an instance of another model.
    assert_eq!(
        call(donor.snapshot, Function::GetReal, &donor),
        Status::Error
    );
    let name = CString::new("other").unwrap();
    let guid = CString::new(<export_support::Other as fmu_core::Model>::GUID).unwrap();
    let callbacks = Fmi2CallbackFunctions {
        logger: export_support::logger(),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: ptr::null_mut(),
    };
    // SAFETY: valid arguments.
    let other = unsafe {
        abi::instantiate::<export_support::Other>(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            ptr::null(),
            &callbacks,
            0,
            0,
        )
    };
    assert!(!other.is_null());
    assert_eq!(call(other, Function::Reset, &donor), Status::Error);
    // SAFETY: a live Other instance: FreeInstance of the wrong model is a no-op ...
    unsafe { abi::free_instance::<Oscillator>(other) };
    // SAFETY: ... so it is still alive and in its own state.
    assert_eq!(
        unsafe { abi::instance_state::<export_support::Other>(other) },
        Some(FmiState::Instantiated)
    );
    // SAFETY: the live Other instance.
    unsafe { abi::free_instance::<export_support::Other>(other) };
}

#[test]
fn a_freed_component_is_refused_for_every_function_and_never_read() {
    let donor = Donor::new();
    let mut fmu = Fmu::initialized("freed");
    let stale = fmu.c;
    fmu.free();
    // A new instance may take the memory the freed one had; the stale handle must not
    // reach it.
    let fresh = Fmu::initialized("fresh");
    assert_ne!(fresh.c, stale, "a handle is not reissued at once");
    for f in Function::ALL {
        if f != Function::FreeInstance {
            assert_eq!(call(stale, f, &donor), Status::Error, "{}", f.name());
        }
    }
    // SAFETY: any value may be passed; a freed handle is a no-op ...
    unsafe { abi::free_instance::<Oscillator>(stale) };
    // SAFETY: ... and is not an instance.
    assert_eq!(unsafe { abi::instance_state::<Oscillator>(stale) }, None);
    assert_eq!(fresh.state(), Some(FmiState::StepComplete));
    // With logging off only an error would be logged; a call that reached the new
    // instance and succeeded would have failed the status check above.
    assert!(
        fresh.log.records().is_empty(),
        "the calls on the stale handle reached the new instance: {:?}",
        fresh.log.messages()
    );
    assert_eq!(fresh.do_step(0.0, 0.01), Status::Ok);
}

/// Laid out as the tag that starts a live Oscillator instance (the model's GUID), with
/// room behind it.
#[repr(C)]
struct Forged {
    guid: &'static str,
    rest: [u8; 4096],
}

/// The same in the tag's layout before components were handles (a magic, then the GUID).
#[repr(C)]
struct ForgedBefore {
    magic: u64,
    guid: &'static str,
    rest: [u8; 4096],
}

/// Every function on `c`, which is not an instance, is an fmi2Error; FreeInstance does
/// nothing.
fn refused(c: Fmi2Component, donor: &Donor) {
    for f in Function::ALL {
        if f != Function::FreeInstance {
            assert_eq!(call(c, f, donor), Status::Error, "{}", f.name());
        }
    }
    // SAFETY: any value may be passed; this one is not an instance.
    unsafe { abi::free_instance::<Oscillator>(c) };
    // SAFETY: as above.
    assert_eq!(unsafe { abi::instance_state::<Oscillator>(c) }, None);
}

#[test]
fn a_forged_instance_tag_is_not_an_instance() {
    // Before components were handles, memory that began with an instance's tag was taken
    // for an instance and written to.
    let donor = Donor::new();
    let now = Forged {
        guid: GUID,
        rest: [0xA5; 4096],
    };
    refused(ptr::from_ref(&now).cast_mut().cast(), &donor);
    assert!(ptr::eq(now.guid, GUID));
    assert!(now.rest.iter().all(|&b| b == 0xA5), "nothing was written");

    let before = ForgedBefore {
        magic: u64::from_le_bytes(*b"FMI2INST"),
        guid: GUID,
        rest: [0xA5; 4096],
    };
    refused(ptr::from_ref(&before).cast_mut().cast(), &donor);
    assert_eq!(before.magic, u64::from_le_bytes(*b"FMI2INST"));
    assert!(
        before.rest.iter().all(|&b| b == 0xA5),
        "nothing was written"
    );
}

/// A misaligned array, or a length no array can have, is refused before a slice is made of
/// it: either would be undefined behaviour in the glue, not a wrong answer.
#[test]
fn misaligned_arrays_and_impossible_lengths_are_errors() {
    let refs = [vr::X; 2];
    let mut values = [0.0_f64; 2];
    let fmu = Fmu::initialized("misaligned");
    let odd = refs.as_ptr().cast::<u8>().wrapping_add(1).cast::<u32>();
    // SAFETY: a misaligned vr[] must be refused before any read.
    let s = unsafe { abi::get_real::<Oscillator>(fmu.c, odd, 1, values.as_mut_ptr()) };
    assert_eq!(status(s), Status::Error);
    assert!(
        fmu.log.contains("fmi2GetReal: argument vr[] is misaligned"),
        "{:?}",
        fmu.log.messages()
    );

    let fmu = Fmu::initialized("impossible");
    let n = isize::MAX as usize / size_of::<u32>() + 1;
    // SAFETY: a length beyond any array must be refused before any read.
    let s = unsafe { abi::get_real::<Oscillator>(fmu.c, refs.as_ptr(), n, values.as_mut_ptr()) };
    assert_eq!(status(s), Status::Error);
    assert!(
        fmu.log.contains(&format!(
            "fmi2GetReal: argument vr[] has an impossible length {n}"
        )),
        "{:?}",
        fmu.log.messages()
    );
}

#[test]
fn null_arrays_with_nvr_are_errors_and_nvr_zero_is_ok() {
    let fmu = Fmu::initialized("nulls");
    let mut value = [0.0];
    // SAFETY: NULL arrays with nvr = 0 are legal.
    let s = unsafe { abi::get_real::<Oscillator>(fmu.c, ptr::null(), 0, ptr::null_mut()) };
    assert_eq!(status(s), Status::Ok);
    // SAFETY: as above.
    let s = unsafe { abi::set_real::<Oscillator>(fmu.c, ptr::null(), 0, ptr::null()) };
    assert_eq!(status(s), Status::Ok);
    assert_eq!(fmu.state(), Some(FmiState::StepComplete));
    // SAFETY: NULL vr with nvr = 1 must be refused before any read.
    let s = unsafe { abi::get_real::<Oscillator>(fmu.c, ptr::null(), 1, value.as_mut_ptr()) };
    assert_eq!(status(s), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2GetReal: argument vr[] is NULL but its length is 1"),
        "{:?}",
        fmu.log.messages()
    );
    assert_eq!(fmu.state(), Some(FmiState::Terminated));

    let fmu = Fmu::initialized("nulls2");
    // SAFETY: NULL value with nvr = 1 must be refused before any write.
    let s = unsafe { abi::set_real::<Oscillator>(fmu.c, [vr::FORCE].as_ptr(), 1, ptr::null()) };
    assert_eq!(status(s), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2SetReal: argument value[] is NULL but its length is 1")
    );

    let fmu = Fmu::initialized("nulls3");
    // SAFETY: NULL out pointer of a status function.
    let s = unsafe {
        abi::get_real_status::<Oscillator>(
            fmu.c,
            fmi2_sys::status_kind::LAST_SUCCESSFUL_TIME,
            ptr::null_mut(),
        )
    };
    assert_eq!(status(s), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2GetRealStatus: argument value is NULL")
    );
}

#[test]
fn instantiate_rejects_bad_arguments_with_a_message() {
    let name = CString::new("bad").unwrap();
    let guid = CString::new(GUID).unwrap();
    let wrong = CString::new("{not-the-guid}").unwrap();
    let empty = CString::new("").unwrap();

    let (c, log) = instantiate_raw(Some(&name), FMI2_CO_SIMULATION, Some(&wrong), false);
    assert!(c.is_null());
    let msgs = log.messages();
    assert!(
        msgs.iter()
            .any(|m| m.contains("fmi2Instantiate: GUID mismatch")
                && m.contains(GUID)
                && m.contains("{not-the-guid}")),
        "{msgs:?}"
    );
    let (c, log) = instantiate_raw(Some(&name), FMI2_CO_SIMULATION, None, false);
    assert!(c.is_null() && log.contains("fmuGUID is NULL"));
    let (c, log) = instantiate_raw(Some(&name), FMI2_MODEL_EXCHANGE, Some(&guid), false);
    assert!(c.is_null() && log.contains("is not fmi2CoSimulation"));
    let (c, log) = instantiate_raw(None, FMI2_CO_SIMULATION, Some(&guid), false);
    assert!(c.is_null() && log.contains("instanceName is NULL"));
    let (c, log) = instantiate_raw(Some(&empty), FMI2_CO_SIMULATION, Some(&guid), false);
    assert!(c.is_null() && log.contains("instanceName is empty"));
    // FMI 2.0 §2.1.5: at least one character that is not white space.
    for blank in [" ", "   ", "\t\n", "\u{a0}"] {
        let blank = CString::new(blank).unwrap();
        let (c, log) = instantiate_raw(Some(&blank), FMI2_CO_SIMULATION, Some(&guid), false);
        assert!(
            c.is_null() && log.contains("is only white space"),
            "{blank:?}"
        );
    }
    let padded = CString::new(" a ").unwrap();
    let (c, _) = instantiate_raw(Some(&padded), FMI2_CO_SIMULATION, Some(&guid), false);
    assert!(!c.is_null());
    // SAFETY: a live instance of this model, freed once.
    unsafe { abi::free_instance::<Oscillator>(c) };
    for r in log.records() {
        assert_eq!(
            (r.status, r.category.as_str(), r.format.as_str()),
            (3, "logStatusError", "%s")
        );
    }

    // NULL callbacks and a NULL logger: NULL, nothing to log to.
    // SAFETY: NULL callbacks are checked.
    let c = unsafe {
        abi::instantiate::<Oscillator>(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            ptr::null(),
            ptr::null(),
            0,
            0,
        )
    };
    assert!(c.is_null());
    let no_logger = Fmi2CallbackFunctions {
        logger: None,
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: ptr::null_mut(),
    };
    // SAFETY: valid callbacks struct.
    let c = unsafe {
        abi::instantiate::<Oscillator>(
            name.as_ptr(),
            FMI2_CO_SIMULATION,
            guid.as_ptr(),
            ptr::null(),
            &no_logger,
            0,
            0,
        )
    };
    assert!(c.is_null());
}

#[test]
fn logger_always_gets_percent_s_and_the_text_verbatim() {
    let fmu = Fmu::with_logging("fmt", true);
    // Text from the master goes into messages verbatim, printf directives included.
    let hostile = CString::new("log%s%n%x").unwrap();
    // SAFETY: one valid category string.
    let s =
        unsafe { abi::set_debug_logging::<Oscillator>(fmu.c, 1, 1, [hostile.as_ptr()].as_ptr()) };
    assert_eq!(status(s), Status::Warning);
    let records = fmu.log.records();
    assert!(!records.is_empty());
    for r in &records {
        assert_eq!(r.format, "%s", "{r:?}");
        assert_eq!(r.instance, "fmt");
    }
    assert!(
        records.iter().any(|r| r
            .message
            .starts_with("fmi2SetDebugLogging: unknown log category 'log%s%n%x' ignored")),
        "{records:?}"
    );

    // Instance names with % are passed as data too.
    let name = CString::new("50%s%n").unwrap();
    let guid = CString::new(GUID).unwrap();
    let (c, log) = instantiate_raw(Some(&name), FMI2_CO_SIMULATION, Some(&guid), true);
    assert!(!c.is_null());
    // SAFETY: live instance; DoStep in Instantiated is illegal.
    assert_eq!(
        status(unsafe { abi::do_step::<Oscillator>(c, 0.0, 0.1, 1) }),
        Status::Error
    );
    // SAFETY: live instance.
    unsafe { abi::free_instance::<Oscillator>(c) };
    let records = log.records();
    assert!(
        records
            .iter()
            .all(|r| r.format == "%s" && r.instance == "50%s%n"),
        "{records:?}"
    );
    assert!(
        records
            .iter()
            .any(|r| r.message == "fmi2DoStep: illegal call sequence in state Instantiated")
    );
}

#[test]
fn debug_logging_filters_categories_but_never_errors() {
    // Logging off: events are not passed; the status categories are, from instantiation.
    let on = Fmu::with_logging("on", false);
    assert_eq!(on.setup(0.0, None), Status::Ok);
    assert_eq!(on.enter_init(), Status::Ok);
    assert_eq!(on.exit_init(), Status::Ok);
    assert!(on.log.records().is_empty(), "{:?}", on.log.messages());
    assert_eq!(
        on.set_integer(&[vr::FAIL_MODE], &[fail::DISCARD]),
        Status::Ok
    );
    assert_eq!(on.do_step(0.0, 0.01), Status::Discard);
    let records = on.log.records();
    assert_eq!(records.len(), 1, "{records:?}");
    assert_eq!(records[0].category, "logStatusDiscard");
    assert!(records[0].message.starts_with("fmi2DoStep: "));

    // A category switched off is filtered.
    let fmu = Fmu::with_logging("cats", false);
    assert_eq!(fmu.debug_logging(false, &["logStatusDiscard"]), Status::Ok);
    assert_eq!(fmu.setup(0.0, None), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    assert_eq!(fmu.exit_init(), Status::Ok);
    assert_eq!(
        fmu.set_integer(&[vr::FAIL_MODE], &[fail::DISCARD]),
        Status::Ok
    );
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Discard);
    assert!(
        fmu.log.records().is_empty(),
        "logStatusDiscard and logEvents off: {:?}",
        fmu.log.messages()
    );

    // n = 0 switches all categories.
    // SAFETY: n = 0 with NULL categories is legal.
    let s = unsafe { abi::set_debug_logging::<Oscillator>(fmu.c, 1, 0, ptr::null()) };
    assert_eq!(status(s), Status::Ok);
    assert_eq!(fmu.terminate(), Status::Ok);
    assert!(fmu.log.contains("fmi2Terminate: "));

    // An unknown category is a warning naming it; the known ones beside it are switched,
    // and the instance goes on.
    let off = Fmu::with_logging("off", true);
    assert_eq!(off.debug_logging(false, &[]), Status::Ok);
    assert_eq!(
        off.debug_logging(true, &["logEverything", "logStatusWarning", "logEvents"]),
        Status::Warning
    );
    assert!(off.log.contains(
        "fmi2SetDebugLogging: unknown log category 'logEverything' ignored; this FMU declares"
    ));
    off.log.clear();
    assert_eq!(off.reset(), Status::Ok);
    assert!(off.log.contains("fmi2Reset: "), "logEvents is on");

    // logAll, which many tools send, switches every category.
    let all = Fmu::with_logging("all", true);
    assert_eq!(all.debug_logging(false, &[]), Status::Ok);
    assert_eq!(all.debug_logging(true, &["logAll"]), Status::Ok);
    assert_eq!(all.reset(), Status::Ok);
    assert!(all.log.contains("fmi2Reset: "), "logEvents is on");

    // Errors reach the logger even with every category off.
    let quiet = Fmu::new("quiet");
    assert_eq!(quiet.debug_logging(false, &[]), Status::Ok);
    assert_eq!(quiet.do_step(0.0, 0.1), Status::Error);
    assert_eq!(quiet.log.records().len(), 1);
}

#[test]
fn panicking_model_is_fatal_and_then_only_free_works() {
    let mut fmu = Fmu::initialized("panic");
    assert_eq!(
        fmu.set_integer(&[vr::FAIL_MODE], &[fail::PANIC]),
        Status::Ok
    );
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Fatal);
    assert_eq!(fmu.state(), Some(FmiState::Fatal));
    let records = fmu.log.records();
    assert!(
        records.iter().any(|r| r.status == 4
            && r.category == "logStatusFatal"
            && r.message == "fmi2DoStep: panic in the model: fail_mode asks for a panic"),
        "{records:?}"
    );
    let donor = Donor::new();
    for f in Function::ALL {
        if f != Function::FreeInstance {
            assert_eq!(call(fmu.c, f, &donor), Status::Error, "{}", f.name());
            assert_eq!(fmu.state(), Some(FmiState::Fatal));
        }
    }
    fmu.free();
}

#[test]
fn model_error_moves_to_terminated_where_reset_recovers() {
    let fmu = Fmu::initialized("err");
    assert_eq!(
        fmu.set_integer(&[vr::FAIL_MODE], &[fail::ERROR]),
        Status::Ok
    );
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Error);
    assert!(fmu.log.contains("fmi2DoStep: fail_mode asks for an error"));
    assert_eq!(fmu.state(), Some(FmiState::Terminated));
    // Diagnostics still readable, stepping not.
    assert_eq!(fmu.get_real(&[vr::X]).0, Status::Ok);
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Error);
    assert_eq!(fmu.terminate(), Status::Error);
    // Reset: start values again, name and logger kept.
    assert_eq!(fmu.set_real(&[vr::MASS], &[3.0]), Status::Error);
    assert_eq!(fmu.reset(), Status::Ok);
    assert_eq!(fmu.state(), Some(FmiState::Instantiated));
    assert_eq!(fmu.setup(0.0, None), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    let (s, fm) = fmu.get_integer(&[vr::FAIL_MODE]);
    assert_eq!((s, fm[0]), (Status::Ok, fail::NONE));
    assert_eq!(fmu.exit_init(), Status::Ok);
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Ok);
}

#[test]
fn reset_restores_start_values_and_keeps_identity() {
    let fmu = Fmu::initialized("reset");
    assert_eq!(
        fmu.set_real(&[vr::FORCE, vr::DAMPING], &[5.0, 2.0]),
        Status::Ok
    );
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Ok);
    assert_eq!(fmu.reset(), Status::Ok);
    assert_eq!(fmu.setup(0.0, None), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    let (s, v) = fmu.get_real(&[vr::FORCE, vr::DAMPING, vr::X]);
    assert_eq!(s, Status::Ok);
    assert_eq!(v, [0.0, 0.5, 0.1]);
    // Time restarts: the first step is from the start time again.
    assert_eq!(fmu.exit_init(), Status::Ok);
    assert_eq!(fmu.do_step(0.0, 0.02), Status::Ok);
    assert!(fmu.log.records().iter().all(|r| r.instance == "reset"));
}

#[test]
fn two_instances_with_different_parameters_stay_independent() {
    let a = Fmu::new("a");
    let b = Fmu::new("b");
    for (fmu, k) in [(&a, 40.0), (&b, 90.0)] {
        assert_eq!(fmu.setup(0.0, None), Status::Ok);
        assert_eq!(fmu.enter_init(), Status::Ok);
        assert_eq!(fmu.set_real(&[vr::STIFFNESS], &[k]), Status::Ok);
        assert_eq!(fmu.exit_init(), Status::Ok);
    }
    for k in 0..50 {
        assert_eq!(a.do_step(k as f64 * 0.01, 0.01), Status::Ok);
        assert_eq!(b.do_step(k as f64 * 0.01, 0.01), Status::Ok);
    }
    let expected_a = glue_run("a-alone", 50, 0.01, |_| 0.0);
    assert_eq!(a.real(vr::X).to_bits(), expected_a[49].0.to_bits());
    assert_ne!(a.real(vr::X), b.real(vr::X));
    assert_eq!(a.real(vr::OMEGA), 40f64.sqrt());
    assert_eq!(b.real(vr::OMEGA), 90f64.sqrt());
    // An error in one leaves the other untouched.
    assert_eq!(b.terminate(), Status::Ok);
    assert_eq!(b.do_step(0.5, 0.01), Status::Error);
    assert_eq!(a.state(), Some(FmiState::StepComplete));
    assert_eq!(a.do_step(0.5, 0.01), Status::Ok);
    assert!(a.log.records().is_empty() && !b.log.records().is_empty());
}

#[test]
fn concurrent_instances_match_sequential_runs() {
    let forces: Vec<f64> = (0..4).map(|i| f64::from(i) * 0.75 - 1.0).collect();
    let sequential: Vec<_> = forces
        .iter()
        .map(|&f| glue_run("seq", 300, 0.01, move |_| f))
        .collect();
    let threads: Vec<_> = forces
        .iter()
        .enumerate()
        .map(|(i, &f)| {
            std::thread::spawn(move || glue_run(&format!("thread{i}"), 300, 0.01, move |_| f))
        })
        .collect();
    for (t, seq) in threads.into_iter().zip(&sequential) {
        let par = t.join().expect("thread");
        let bits = |v: &[(f64, f64)]| {
            v.iter()
                .map(|(x, y)| (x.to_bits(), y.to_bits()))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&par), bits(seq));
    }
    assert_ne!(sequential[0], sequential[1]);
}

#[test]
fn unsupported_capabilities_are_errors_after_the_state_check() {
    let donor = Donor::new();
    for f in [
        Function::GetDirectionalDerivative,
        Function::SetRealInputDerivatives,
        Function::GetRealOutputDerivatives,
    ] {
        let fmu = Fmu::initialized("caps");
        assert_eq!(call(fmu.c, f, &donor), Status::Error, "{}", f.name());
        let prefix = format!("{}: not supported by this FMU (", f.name());
        assert!(
            fmu.log.messages().iter().any(|m| m.starts_with(&prefix)),
            "{:?}",
            fmu.log.messages()
        );
    }
    let fmu = Fmu::initialized("cancel");
    assert_eq!(call(fmu.c, Function::CancelStep, &donor), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2CancelStep: illegal call sequence in state StepComplete")
    );
    assert!(fmu.log.contains("so cancelling is not supported"));
}

#[test]
fn status_queries() {
    let fmu = Fmu::initialized("status");
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Ok);
    let mut st = -1;
    // SAFETY: live instance, valid out pointer.
    let s = unsafe {
        abi::get_status::<Oscillator>(fmu.c, fmi2_sys::status_kind::DO_STEP_STATUS, &mut st)
    };
    assert_eq!((status(s), st), (Status::Ok, 0));
    assert_eq!(fmu.terminated_flag(), (Status::Ok, 0));
    let mut int = 0;
    // SAFETY: live instance, valid out pointer.
    let s = unsafe {
        abi::get_integer_status::<Oscillator>(
            fmu.c,
            fmi2_sys::status_kind::PENDING_STATUS,
            &mut int,
        )
    };
    assert_eq!(status(s), Status::Discard);
    assert_eq!(fmu.state(), Some(FmiState::StepComplete));
    // fmi2PendingStatus needs asynchronous steps: not available, like the Integer status,
    // and the instance stays usable.
    let mut text: fmi2_sys::Fmi2String = ptr::null();
    // SAFETY: live instance, valid out pointer.
    let s = unsafe {
        abi::get_string_status::<Oscillator>(
            fmu.c,
            fmi2_sys::status_kind::PENDING_STATUS,
            &mut text,
        )
    };
    assert_eq!(status(s), Status::Discard);
    assert_eq!(fmu.state(), Some(FmiState::StepComplete));
    assert_eq!(fmu.do_step(0.01, 0.01), Status::Ok);
    // SAFETY: live instance; an out-of-range kind.
    let s = unsafe { abi::get_status::<Oscillator>(fmu.c, 42, &mut st) };
    assert_eq!(status(s), Status::Error);
    assert!(fmu.log.contains("fmi2GetStatus: invalid fmi2StatusKind 42"));
}

#[test]
fn free_instance_releases_everything() {
    let mut fmu = Fmu::initialized("free");
    let mut snap = ptr::null_mut();
    assert_eq!(fmu.get_state(&mut snap), Status::Ok);
    assert_eq!(fmu.free_state(&mut snap), Status::Ok);
    assert!(snap.is_null());
    assert_eq!(
        fmu.free_state(&mut snap),
        Status::Ok,
        "freeing NULL is a no-op"
    );
    fmu.free();
    assert!(fmu.c.is_null());
}

#[test]
fn calls_after_an_error_name_the_function_that_failed() {
    // An illegal call in Instantiated escalates to Terminated, which FMI 2.0 calls the
    // error state when an error put the instance there; the next illegal call names that
    // state and the call.
    let fmu = Fmu::with_logging("after-error", true);
    assert_eq!(fmu.do_step(0.0, 0.1), Status::Error);
    assert_eq!(fmu.state(), Some(FmiState::Terminated));
    fmu.log.clear();
    assert_eq!(fmu.setup(0.0, None), Status::Error);
    assert!(
        fmu.log.contains(
            "fmi2SetupExperiment: illegal call sequence in state Error (entered when \
             fmi2DoStep returned fmi2Error; fmi2Reset or fmi2SetFMUstate continue)"
        ),
        "{:?}",
        fmu.log.messages()
    );
    // A state saved there and restored later is named the same way.
    let mut snap = std::ptr::null_mut();
    assert_eq!(fmu.get_state(&mut snap), Status::Ok);
    assert_eq!(fmu.reset(), Status::Ok);
    fmu.log.clear();
    assert_eq!(fmu.set_state(snap), Status::Ok);
    assert!(
        fmu.log.contains("restored state Error at t = 0"),
        "{:?}",
        fmu.log.messages()
    );
    assert_eq!(fmu.free_state(&mut snap), Status::Ok);
    // fmi2Reset forgets the cause with the state.
    assert_eq!(fmu.reset(), Status::Ok);
    assert_eq!(fmu.setup(0.0, None), Status::Ok);

    // A master that terminated on purpose is not told about an error.
    let fmu = Fmu::initialized("terminated");
    assert_eq!(fmu.terminate(), Status::Ok);
    fmu.log.clear();
    assert_eq!(fmu.do_step(0.0, 0.1), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2DoStep: illegal call sequence in state Terminated"),
        "{:?}",
        fmu.log.messages()
    );
    assert!(
        !fmu.log
            .messages()
            .iter()
            .any(|m| m.contains("entered when")),
        "{:?}",
        fmu.log.messages()
    );
}
