//! After a warm-up step, the controller's doStep with its input/output calls performs no heap
//! allocation (line trajectory, learning on): checked with a counting global allocator while
//! the model is driven through the safe `fmu_core::Model` trait.

use alloc_count::{CountingAllocator, allocations};
use ckcm::{Mechanism, Params, Trajectory};
use fmu_core::Model;
use hlcs_controller::HlcsController;
use hlcs_controller::md::VARIABLES;

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

/// Value reference of a variable by name.
fn vr(name: &str) -> u32 {
    VARIABLES
        .iter()
        .find(|v| v.name == name)
        .unwrap_or_else(|| panic!("HlcsController has no variable {name}"))
        .value_reference
}

fn array(base: &str) -> [u32; 6] {
    std::array::from_fn(|i| vr(&format!("{base}[{}]", i + 1)))
}

const H: f64 = 1e-3;
const STEPS: u32 = 1000;

#[test]
fn learning_line_step_loop_does_not_allocate() {
    let inputs: Vec<u32> = ["length", "velocity", "memory"]
        .iter()
        .flat_map(|b| array(b))
        .collect();
    let outputs: Vec<u32> = ["force", "memory_next"]
        .iter()
        .flat_map(|b| array(b))
        .collect();
    let mech = Mechanism::new(Params::default()).unwrap();
    let line = Trajectory::line(mech.params.geometry.home_height);

    let mut controller = HlcsController::new();
    controller.set_integer(vr("trajectory"), 2).unwrap();
    controller.set_boolean(vr("learning"), true).unwrap();
    controller.initialize(0.0).unwrap();
    let mut y = [0.0; 12];
    // Measurements lag the reference by 1 mm per leg and the memory is non-zero, so every
    // term of the law and of the learning update is exercised.
    let step = |controller: &mut HlcsController, n: u32, y: &mut [f64; 12]| {
        let t = f64::from(n) * H;
        let legs = mech.inverse_kinematics(&line.sample(t).pose);
        let mut u = [0.0; 18];
        for i in 0..6 {
            u[i] = legs.length[i] - 1e-3;
            u[6 + i] = 0.0;
            u[12 + i] = 10.0;
        }
        for (&r, &v) in inputs.iter().zip(&u) {
            controller.set_real(r, v).unwrap();
        }
        controller.do_step(t, H).unwrap();
        for (out, &r) in y.iter_mut().zip(&outputs) {
            *out = controller.get_real(r);
        }
    };
    // The reference table is built at the second step of one step size.
    step(&mut controller, 0, &mut y);
    step(&mut controller, 1, &mut y);
    let before = allocations();
    for n in 2..=STEPS + 1 {
        step(&mut controller, n, &mut y);
    }
    let during = allocations() - before;
    assert_eq!(
        during, 0,
        "1000 controller doSteps allocated {during} times"
    );
    // Learning is on: u_{k+1} = u_k + Φe + Γė + ΨI differs from u_k = 10 N.
    assert!(y[6..].iter().all(|&m| (m - 10.0).abs() > 1.0), "{y:?}");
}

/// The counter sees allocations at all: a rejected input builds its error message.
#[test]
fn counter_counts() {
    let mut controller = HlcsController::new();
    controller.initialize(0.0).unwrap();
    let before = allocations();
    assert!(controller.set_real(vr("length[1]"), f64::NAN).is_err());
    assert!(allocations() > before);
}
