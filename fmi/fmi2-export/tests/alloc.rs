//! The export glue's step-loop entry points (fmi2SetReal, fmi2DoStep, fmi2GetReal,
//! fmi2GetInteger) allocate nothing on success after a warm-up step, so an FMU whose model
//! does not allocate stays allocation-free behind the C ABI. Checked on the test oscillator
//! with a counting global allocator.
// The tests' logger is truly C-variadic under Miri (docs/testing.md).
#![cfg_attr(miri, feature(c_variadic))]

#[path = "support/mod.rs"]
mod export_support;

use alloc_count::{CountingAllocator, allocations, live_blocks};
use export_support::{Fmu, Oscillator, status, vr};
use fmi2_export::abi;
use fmi2_sys::Status;

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

const H: f64 = 1e-3;

/// One master step on the raw ABI with stack buffers only: set the force, step, read x and v
/// and the step counter.
fn step(fmu: &Fmu, n: u32, xv: &mut [f64; 2], steps: &mut [i32; 1]) -> [Status; 4] {
    let t = f64::from(n) * H;
    let force = [(t * 10.0).sin()];
    let outs = [vr::X, vr::V];
    // SAFETY: `fmu.c` is a live instance; every array is as long as the count passed with it.
    unsafe {
        [
            status(abi::set_real::<Oscillator>(
                fmu.c,
                &vr::FORCE,
                1,
                force.as_ptr(),
            )),
            status(abi::do_step::<Oscillator>(fmu.c, t, H, 1)),
            status(abi::get_real::<Oscillator>(
                fmu.c,
                outs.as_ptr(),
                2,
                xv.as_mut_ptr(),
            )),
            status(abi::get_integer::<Oscillator>(
                fmu.c,
                &vr::STEP_COUNT,
                1,
                steps.as_mut_ptr(),
            )),
        ]
    }
}

/// An initialized instance after one warm-up step, with the step's output buffers.
fn warmed(name: &str) -> (Fmu, [f64; 2], [i32; 1]) {
    let fmu = Fmu::initialized(name);
    let (mut xv, mut steps) = ([0.0; 2], [0]);
    assert_eq!(step(&fmu, 0, &mut xv, &mut steps), [Status::Ok; 4]);
    (fmu, xv, steps)
}

#[test]
fn step_loop_through_the_abi_does_not_allocate() {
    let (fmu, mut xv, mut steps) = warmed("alloc");
    let before = allocations();
    for n in 1..=1000 {
        let statuses = step(&fmu, n, &mut xv, &mut steps);
        assert!(statuses == [Status::Ok; 4]);
    }
    let during = allocations() - before;
    assert_eq!(during, 0, "1000 ABI steps allocated {during} times");
    assert_eq!(steps[0], 1001);
    assert!(xv[0] != 0.0 && xv[1].is_finite());
}

/// The counter sees the glue's allocations at all: a rejected call logs a formatted message.
#[test]
fn counter_counts() {
    let fmu = Fmu::initialized("alloc-error");
    let before = allocations();
    // SAFETY: live instance, arrays of length 1.
    let s = unsafe { abi::set_real::<Oscillator>(fmu.c, &vr::FORCE, 1, [f64::NAN].as_ptr()) };
    assert_ne!(status(s), Status::Ok);
    assert!(allocations() > before);
}

/// FMU states leave nothing allocated once freed, by the master or with their instance:
/// the glue's table of live states is a static, never dropped, so a node it kept would
/// outlive the FMU's library (LeakSanitizer saw one at the end of a fuzz run). The only
/// test in this binary that saves states, so the table is empty before and after.
#[test]
fn freed_fmu_states_leave_no_allocation_behind() {
    let (fmu, ..) = warmed("alloc-states");
    let before = live_blocks();
    let mut s = std::ptr::null_mut();
    assert_eq!(fmu.get_state(&mut s), Status::Ok);
    assert_eq!(fmu.free_state(&mut s), Status::Ok);
    assert_eq!(
        live_blocks(),
        before,
        "a saved and freed state left blocks allocated"
    );

    drop(fmu);

    // A whole instance with a state it leaves to fmi2FreeInstance: everything goes.
    let before = live_blocks();
    {
        let (mut fmu, ..) = warmed("alloc-states-kept");
        let mut kept = std::ptr::null_mut();
        assert_eq!(fmu.get_state(&mut kept), Status::Ok);
        fmu.free();
    }
    assert_eq!(
        live_blocks(),
        before,
        "an instance and its unfreed state left blocks"
    );
}
