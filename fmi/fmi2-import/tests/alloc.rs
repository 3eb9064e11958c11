//! The step-loop calls (get/set Real, Integer, Boolean and doStep) allocate nothing on
//! success, checked with a counting global allocator.

#[path = "support/mod.rs"]
mod import_support;

use alloc_count::{CountingAllocator, allocations};
use fmi2_import::Fmu;

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

#[test]
fn step_loop_does_not_allocate() {
    let dir = tempfile::tempdir().unwrap();
    let fmu = Fmu::open(import_support::dummy_fmu(dir.path())).unwrap();
    let mut inst = fmu.instantiate("plant", false).unwrap();
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();

    let forces = [1u32, 2, 3, 4, 5, 6];
    let xs = [11u32, 12, 13, 14, 15, 16];
    let mut x = [0.0; 6];
    let mut ints = [0; 2];
    let mut bools = [false; 2];
    let before = allocations();
    for n in 0..1000 {
        let t = f64::from(n) * 0.001;
        inst.set_real(&forces, &[t; 6]).unwrap();
        inst.do_step(t, 0.001, true).unwrap();
        inst.get_real(&xs, &mut x).unwrap();
        inst.set_integer(&[24, 25], &[n, n]).unwrap();
        inst.get_integer(&[24, 25], &mut ints).unwrap();
        inst.set_boolean(&[23, 24], &[true, false]).unwrap();
        inst.get_boolean(&[23, 24], &mut bools).unwrap();
    }
    let during = allocations() - before;
    assert_eq!(during, 0, "the step loop allocated {during} times");
    assert!(x[0] > 0.0 && ints == [999, 999] && bools == [true, false]);

    // The counter works: an error path does allocate (its message).
    let before = allocations();
    assert!(inst.do_step(1.0, -1.0, true).is_err());
    assert!(allocations() > before);
}
