//! After a warm-up step, the plant's doStep with its input/output calls performs no heap
//! allocation, with either integrator: checked with a counting global allocator while the
//! model is driven through the safe `fmu_core::Model` trait.

use alloc_count::{CountingAllocator, allocations};
use ckcm::{Mechanism, Params};
use ckcm_plant::CkcmPlant;
use fmu_core::Model;

mod common;
use common::{array, vr};

#[global_allocator]
static GLOBAL: CountingAllocator = CountingAllocator;

const H: f64 = 1e-3;
const STEPS: u32 = 1000;

/// Initialises a plant (`adaptive` selects Dormand–Prince at relative tolerance 1e-8, `noise`
/// turns the sensor noise on), takes
/// one warm-up step, then counts the allocations of 1000 doSteps, each with the six forces
/// set and all 18 outputs read. The forces hold the platform against gravity plus a PD pull
/// towards leg lengths swinging ±5 mm about home, so the state keeps changing. Returns the
/// count and the last leg lengths.
fn count_steps(adaptive: bool, noise: bool) -> (usize, [f64; 6]) {
    let force = array("force");
    let outputs: Vec<u32> = ["length", "velocity", "pose"]
        .iter()
        .flat_map(|b| array(b))
        .collect();
    let mech = Mechanism::new(Params::default()).unwrap();
    let hold = mech.static_forces(&mech.home()).unwrap();
    let l_home = mech.inverse_kinematics(&mech.home()).length;

    let mut plant = CkcmPlant::new();
    if adaptive {
        plant.set_integer(vr("integrator"), 2).unwrap();
        plant.set_real(vr("relative_tolerance"), 1e-8).unwrap();
    }
    if noise {
        plant.set_real(vr("length_noise_sigma"), 1e-6).unwrap();
        plant.set_real(vr("velocity_noise_sigma"), 1e-5).unwrap();
        plant.set_integer(vr("noise_seed"), 42).unwrap();
    }
    plant.initialize(0.0).unwrap();
    let mut y = [0.0; 18];
    let step = |plant: &mut CkcmPlant, n: u32, y: &mut [f64; 18]| {
        let t = f64::from(n) * H;
        let wobble = 0.005 * (std::f64::consts::TAU * t).sin();
        for i in 0..6 {
            let f = hold[i] + 5e4 * (l_home[i] + wobble - y[i]) - 850.0 * y[6 + i];
            plant.set_real(force[i], f).unwrap();
        }
        plant.do_step(t, H).unwrap();
        for (out, &r) in y.iter_mut().zip(&outputs) {
            *out = plant.get_real(r);
        }
    };
    for (out, &r) in y.iter_mut().zip(&outputs) {
        *out = plant.get_real(r);
    }
    step(&mut plant, 0, &mut y);
    let before = allocations();
    for n in 1..=STEPS {
        step(&mut plant, n, &mut y);
    }
    let during = allocations() - before;
    (during, std::array::from_fn(|i| y[i]))
}

#[test]
fn rk4_step_loop_does_not_allocate() {
    let (during, length) = count_steps(false, false);
    assert_eq!(during, 0, "1000 RK4 doSteps allocated {during} times");
    assert!(length.iter().all(|l| (0.5..0.65).contains(l)), "{length:?}");
}

#[test]
fn step_loop_with_sensor_noise_does_not_allocate() {
    let (during, length) = count_steps(false, true);
    assert_eq!(during, 0, "1000 noisy RK4 doSteps allocated {during} times");
    assert!(length.iter().all(|l| (0.5..0.65).contains(l)), "{length:?}");
}

#[test]
fn dormand_prince_step_loop_does_not_allocate() {
    let (during, length) = count_steps(true, false);
    assert_eq!(
        during, 0,
        "1000 Dormand–Prince doSteps allocated {during} times"
    );
    assert!(length.iter().all(|l| (0.5..0.65).contains(l)), "{length:?}");
}

/// The counter sees allocations at all: a rejected input builds its error message.
#[test]
fn counter_counts() {
    let mut plant = CkcmPlant::new();
    plant.initialize(0.0).unwrap();
    let before = allocations();
    assert!(plant.set_real(vr("force[1]"), f64::NAN).is_err());
    assert!(allocations() > before);
}
