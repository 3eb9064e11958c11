//! A run that the adaptive integrator slows to a crawl says so: an interval of 1,000 or more
//! Dormand–Prince steps gives the step a warning ([`Model::take_warning`], which the glue
//! returns as fmi2Warning), once per initialization. Driven through the safe
//! `fmu_core::Model` trait.

use ckcm::{Mechanism, Params};
use ckcm_plant::CkcmPlant;
use ckcm_plant::md::enums::{INTEGRATOR_DORMAND_PRINCE, INTEGRATOR_RK4};
use fmu_core::Model;

mod common;
use common::{array, vr};

/// A plant with `integrator` and `friction_velocity` (m/s), initialized and driven by the
/// static forces plus 1.5 N on leg 1: less than the 20 N of Coulomb friction, so the leg
/// creeps and its rate hovers about zero, where a small `friction_velocity` is stiff.
fn creeping_plant(integrator: i32, friction_velocity: f64) -> CkcmPlant {
    let mech = Mechanism::new(Params::default()).unwrap();
    let mut force = mech.static_forces(&mech.home()).unwrap();
    force[0] += 1.5;
    let mut plant = CkcmPlant::new();
    plant.set_integer(vr("integrator"), integrator).unwrap();
    plant
        .set_real(vr("friction_velocity"), friction_velocity)
        .unwrap();
    plant.initialize(0.0).unwrap();
    for (vr, f) in array("force").into_iter().zip(force.iter()) {
        plant.set_real(vr, *f).unwrap();
    }
    plant
}

/// The warnings of `steps` steps of 1 ms from `t0`, by step index.
fn warnings(plant: &mut CkcmPlant, t0: f64, steps: u32) -> Vec<(u32, String)> {
    let mut found = Vec::new();
    for n in 0..steps {
        plant.do_step(t0 + f64::from(n) * 1e-3, 1e-3).unwrap();
        if let Some(w) = plant.take_warning() {
            found.push((n, w));
        }
        assert_eq!(plant.take_warning(), None, "a warning is handed over once");
    }
    found
}

/// The number in "took N steps" of a warning.
fn steps_taken(warning: &str) -> usize {
    let rest = warning
        .split_once("took ")
        .unwrap_or_else(|| panic!("{warning}"))
        .1;
    rest.split(' ').next().unwrap().parse().unwrap()
}

#[test]
fn a_stiff_interval_is_reported_once_per_initialization() {
    let mut plant = creeping_plant(INTEGRATOR_DORMAND_PRINCE, 1e-6);
    let found = warnings(&mut plant, 0.0, 5);
    assert_eq!(found.len(), 1, "{found:?}");
    let (n, w) = &found[0];
    assert_eq!(*n, 0, "the first interval is already slow: {w}");
    assert!(steps_taken(w) >= 1_000, "{w}");
    for part in [
        "the adaptive integrator took",
        "friction_velocity",
        "relative_tolerance = 1e-8",
        "absolute_tolerance = 1e-10",
        "at 100000 it refuses a step",
    ] {
        assert!(w.contains(part), "{part:?} missing from {w:?}");
    }
    // A new initialization may say it again.
    plant.initialize(0.0).unwrap();
    assert_eq!(warnings(&mut plant, 0.0, 2).len(), 1);
}

#[test]
fn ordinary_runs_say_nothing() {
    // The default friction: a few adaptive steps per interval.
    let mut plant = creeping_plant(INTEGRATOR_DORMAND_PRINCE, 0.02);
    assert_eq!(warnings(&mut plant, 0.0, 50), []);
    // RK4's substeps are the user's choice; it never warns.
    let mut plant = creeping_plant(INTEGRATOR_RK4, 0.02);
    assert_eq!(warnings(&mut plant, 0.0, 50), []);
}
