//! Export glue: fmi2DoStep time bookkeeping, discarded steps and status queries.
// The tests' logger is truly C-variadic under Miri (docs/testing.md).
#![cfg_attr(miri, feature(c_variadic))]

#[path = "support/mod.rs"]
mod export_support;

use export_support::{Fmu, Other, fail, instantiate_quiet, status, vr};
use fmi2_export::FmiState;
use fmi2_export::abi;
use fmi2_sys::Status;

#[test]
fn step_size_must_be_positive_and_finite() {
    for h in [0.0, -0.01, f64::NAN, f64::INFINITY] {
        let fmu = Fmu::initialized("h");
        assert_eq!(fmu.do_step(0.0, h), Status::Error, "h = {h}");
        assert!(fmu.log.contains(&format!(
            "fmi2DoStep: communicationStepSize {h} must be finite and > 0"
        )));
        assert_eq!(fmu.state(), Some(FmiState::Terminated));
    }
    // An absurd step is named in a few characters, not 300 digits.
    let fmu = Fmu::initialized("h");
    assert_eq!(fmu.do_step(0.0, -1e300), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2DoStep: communicationStepSize -1e300 must be finite and > 0"),
        "{:?}",
        fmu.log.records()
    );
}

/// Near t = 1e17 doubles are 16 apart, so t + 0.001 = t: such a step would integrate the
/// model while the time stood still, and is refused. A step that does move the time is
/// taken there.
#[test]
fn a_step_that_cannot_advance_time_is_refused() {
    let fmu = Fmu::initialized_at("stall", 1e17);
    let steps = fmu.get_integer(&[vr::STEP_COUNT]).1;
    assert_eq!(fmu.do_step(1e17, 0.001), Status::Error);
    assert!(
        fmu.log.contains(
            "fmi2DoStep: a step of 0.001 from 1e17 does not advance time: \
             neighbouring times there are 16 apart"
        ),
        "{:?}",
        fmu.log.messages()
    );
    assert_eq!(
        fmu.get_integer(&[vr::STEP_COUNT]).1,
        steps,
        "no step was taken"
    );

    // A step whose end lies beyond the largest double is refused too, before the model runs.
    let fmu = Fmu::initialized_at("overflow", 1e308);
    assert_eq!(fmu.do_step(1e308, 1e308), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2DoStep: a step of 1e308 from 1e308 ends beyond the largest double"),
        "{:?}",
        fmu.log.messages()
    );

    let fmu = Fmu::initialized_at("stall-ok", 1e17);
    assert_eq!(fmu.do_step(1e17, 32.0), Status::Ok);
    assert_eq!(fmu.last_successful_time(), (Status::Ok, 1e17 + 32.0));
}

#[test]
fn communication_point_must_match_the_fmu_time() {
    let fmu = Fmu::initialized("cp");
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Ok);
    assert_eq!(fmu.do_step(0.02, 0.01), Status::Error);
    assert!(
        fmu.log.contains(
            "fmi2DoStep: currentCommunicationPoint 0.02 does not match the FMU time 0.01"
        ),
        "{:?}",
        fmu.log.messages()
    );

    // Within the tolerance 1e-9·max(1, |t|): accepted, and the master's cp is used.
    let fmu = Fmu::initialized("cp-edge");
    assert_eq!(
        fmu.do_step(1e-9, 0.01),
        Status::Ok,
        "exactly at the tolerance"
    );
    let fmu = Fmu::initialized("cp-tol");
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Ok);
    assert_eq!(fmu.do_step(0.01 + 5e-10, 0.01), Status::Ok);
    assert_eq!(
        fmu.last_successful_time(),
        (Status::Ok, 0.01 + 5e-10 + 0.01)
    );
    assert_eq!(fmu.do_step(0.02 + 5e-10 + 2e-9, 0.01), Status::Error);

    // The tolerance grows with |t|: at t = 1000 s it is 1e-6 s, so a master's rounding of
    // a late communication point is not refused.
    let fmu = Fmu::initialized_at("cp-late", 1000.0);
    assert_eq!(fmu.do_step(1000.0, 0.01), Status::Ok);
    assert_eq!(fmu.do_step(1000.01 + 5e-7, 0.01), Status::Ok);
    assert_eq!(fmu.do_step(1000.02 + 5e-7 + 2e-6, 0.01), Status::Error);
}

#[test]
fn time_is_cp_plus_h_without_accumulation() {
    let fmu = Fmu::initialized("time");
    let h = 0.001;
    for n in 0..1000 {
        // The master computes t_n = n·h, never by summing.
        let t = f64::from(n) * h;
        assert_eq!(
            fmu.do_step(t, h),
            Status::Ok,
            "step {n}: {:?}",
            fmu.log.messages()
        );
        assert_eq!(fmu.last_successful_time().1.to_bits(), (t + h).to_bits());
    }
}

#[test]
fn fixed_step_models_keep_the_first_step_size() {
    let fmu = Fmu::initialized("fixed");
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Ok);
    assert_eq!(
        fmu.do_step(0.01, 0.01 * (1.0 + 5e-10)),
        Status::Ok,
        "within 1e-9 relative"
    );
    let t = fmu.last_successful_time().1;
    // 1e-7 relative: beyond the tolerance, refused like any other step size.
    assert_eq!(fmu.do_step(t, 0.01 + 1e-9), Status::Error);
    let fmu = Fmu::initialized("fixed-2");
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Ok);
    let t = fmu.last_successful_time().1;
    assert_eq!(fmu.do_step(t, 0.02), Status::Error);
    assert!(
        fmu.log.contains(
            "fmi2DoStep: communicationStepSize 0.02 differs from the first step size 0.01"
        )
    );
}

#[test]
fn steps_may_not_pass_the_stop_time() {
    let fmu = Fmu::new("stop");
    assert_eq!(fmu.setup(0.0, Some(0.05)), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    assert_eq!(fmu.exit_init(), Status::Ok);
    for n in 0..5 {
        assert_eq!(
            fmu.do_step(f64::from(n) * 0.01, 0.01),
            Status::Ok,
            "step {n}"
        );
    }
    assert_eq!(fmu.do_step(0.05, 0.01), Status::Error);
    assert!(
        fmu.log.contains("fmi2DoStep: a step of 0.01 from 0.05 ends at 0.060000000000000005, beyond the stop time 0.05"),
        "{:?}",
        fmu.log.messages()
    );

    // A step may end up to the time tolerance, 1e-9·max(1, |t|), beyond the stop time, and
    // not one double more.
    let edge: f64 = 1.0 + 1e-9;
    for (name, h, expected) in [
        ("stop-edge", edge, Status::Ok),
        ("stop-beyond", edge.next_up(), Status::Error),
    ] {
        let fmu = Fmu::new(name);
        assert_eq!(fmu.setup(0.0, Some(1.0)), Status::Ok);
        assert_eq!(fmu.enter_init(), Status::Ok);
        assert_eq!(fmu.exit_init(), Status::Ok);
        assert_eq!(
            fmu.do_step(0.0, h),
            expected,
            "{name}: {:?}",
            fmu.log.messages()
        );
    }
}

/// A model's remark on a step it took ([`fmu_core::Model::take_warning`]) makes that
/// fmi2DoStep return fmi2Warning: the step stands, the message goes to logStatusWarning
/// (on from instantiation, whatever loggingOn, until the master turns it off),
/// fmi2GetStatus(fmi2DoStepStatus) says Warning, and the instance steps on.
#[test]
fn a_step_taken_with_a_warning_stands() {
    for (logging_on, turned_off) in [(true, false), (false, false), (false, true)] {
        let fmu = Fmu::with_logging("warn", logging_on);
        if turned_off {
            assert_eq!(fmu.debug_logging(false, &["logStatusWarning"]), Status::Ok);
        }
        let logging = !turned_off;
        assert_eq!(fmu.setup(0.0, None), Status::Ok);
        assert_eq!(fmu.enter_init(), Status::Ok);
        assert_eq!(fmu.exit_init(), Status::Ok);
        assert_eq!(fmu.do_step(0.0, 0.01), Status::Ok);
        assert_eq!(fmu.do_step_status(), Status::Ok);
        let x = fmu.real(vr::X);
        assert_eq!(fmu.set_integer(&[vr::FAIL_MODE], &[fail::WARN]), Status::Ok);
        assert_eq!(fmu.do_step(0.01, 0.01), Status::Warning);
        assert_eq!(fmu.state(), Some(FmiState::StepComplete));
        assert_eq!(fmu.last_successful_time(), (Status::Ok, 0.02));
        assert_eq!(fmu.get_integer(&[vr::STEP_COUNT]).1, [2]);
        assert_ne!(fmu.real(vr::X), x, "the step was taken");
        assert_eq!(fmu.do_step_status(), Status::Warning);
        let warned = fmu.log.records().iter().any(|r| {
            r.status == 1
                && r.category == "logStatusWarning"
                && r.message
                    == "fmi2DoStep: step from 0.01 by 0.01 taken: fail_mode asks for a warning"
        });
        assert_eq!(warned, logging, "{:?}", fmu.log.records());
        assert_eq!(fmu.set_integer(&[vr::FAIL_MODE], &[fail::NONE]), Status::Ok);
        assert_eq!(fmu.do_step(0.02, 0.01), Status::Ok);
        assert_eq!(fmu.do_step_status(), Status::Ok);
        assert_eq!(fmu.last_successful_time(), (Status::Ok, 0.03));
    }
}

#[test]
fn discarded_step_reports_terminated_and_last_successful_time() {
    let fmu = Fmu::with_logging("discard", true);
    assert_eq!(fmu.setup(0.0, None), Status::Ok);
    assert_eq!(fmu.enter_init(), Status::Ok);
    assert_eq!(fmu.exit_init(), Status::Ok);
    assert_eq!(fmu.do_step(0.0, 0.01), Status::Ok);
    assert_eq!(fmu.do_step(0.01, 0.01), Status::Ok);
    let x = fmu.real(vr::X);
    assert_eq!(fmu.terminated_flag(), (Status::Ok, 0));
    assert_eq!(
        fmu.set_integer(&[vr::FAIL_MODE], &[fail::DISCARD]),
        Status::Ok
    );
    assert_eq!(fmu.do_step(0.02, 0.01), Status::Discard);
    assert_eq!(fmu.state(), Some(FmiState::StepFailed));
    assert_eq!(fmu.terminated_flag(), (Status::Ok, 1));
    assert_eq!(fmu.last_successful_time(), (Status::Ok, 0.02));
    assert_eq!(fmu.real(vr::X), x, "a discarded step changes nothing");
    assert!(fmu.log.records().iter().any(|r| {
        r.status == 2
            && r.category == "logStatusDiscard"
            && r.message
                .starts_with("fmi2DoStep: step from 0.02 by 0.01 discarded")
    }));
    // No further steps; terminate is allowed.
    assert_eq!(fmu.do_step(0.02, 0.01), Status::Error);
    let fmu2 = Fmu::initialized("discard2");
    assert_eq!(
        fmu2.set_integer(&[vr::FAIL_MODE], &[fail::DISCARD]),
        Status::Ok
    );
    assert_eq!(fmu2.do_step(0.0, 0.01), Status::Discard);
    assert_eq!(fmu2.terminate(), Status::Ok);
    assert_eq!(fmu2.state(), Some(FmiState::Terminated));
}

/// A model with nothing to say about its steps (the trait's default remark) steps with
/// fmi2OK: a warning on every step would bury the real ones.
#[test]
fn a_model_without_remarks_steps_with_ok() {
    let c = instantiate_quiet::<Other>("quiet-steps");
    assert!(!c.is_null());
    // SAFETY: `c` is a live `Other` instance until it is freed at the end.
    unsafe {
        assert_eq!(
            status(abi::setup_experiment::<Other>(c, 0, 0.0, 0.0, 0, 0.0)),
            Status::Ok
        );
        assert_eq!(
            status(abi::enter_initialization_mode::<Other>(c)),
            Status::Ok
        );
        assert_eq!(
            status(abi::exit_initialization_mode::<Other>(c)),
            Status::Ok
        );
        for n in 0..3 {
            let t = f64::from(n) * 0.1;
            assert_eq!(status(abi::do_step::<Other>(c, t, 0.1, 1)), Status::Ok);
        }
        abi::free_instance::<Other>(c);
    }
}
