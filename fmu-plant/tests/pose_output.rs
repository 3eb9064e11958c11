//! The pose output's Euler angles are computed when a master reads them, not at every step
//! (BENCHMARKS.md, round 30). Whatever the batch they are read in, they must be the angles
//! of the current state: checked against the leg lengths through inverse kinematics, and
//! batch against batch. Driven through the safe `fmu_core::Model` trait.

use ckcm::{Mechanism, Params, Pose};
use ckcm_plant::CkcmPlant;
use fmu_core::{Model, VrRun};

mod common;
use common::array;

/// `vrs` read in one batch, as the glue passes it to the model.
fn read(plant: &CkcmPlant, vrs: &[u32]) -> Vec<f64> {
    let mut runs = Vec::new();
    VrRun::split(vrs, &mut runs);
    let mut out = vec![f64::NAN; vrs.len()];
    plant.get_reals(vrs, &runs, &mut out);
    out
}

/// A plant started tilted and turned, under the forces that hold the level platform at
/// home, so that it moves and its orientation changes from step to step.
fn moving_plant() -> CkcmPlant {
    let mech = Mechanism::new(Params::default()).unwrap();
    let hold = mech.static_forces(&mech.home()).unwrap();
    let mut plant = CkcmPlant::new();
    let initial = array("initial_pose");
    for (&r, x) in initial.iter().zip([0.01, -0.02, 0.03, 0.04, -0.05, 0.06]) {
        plant.set_real(r, x).unwrap();
    }
    plant.initialize(0.0).unwrap();
    for (&r, &f) in array("force").iter().zip(hold.iter()) {
        plant.set_real(r, f).unwrap();
    }
    plant
}

#[test]
fn euler_angles_read_in_any_batch_are_those_of_the_current_state() {
    let mech = Mechanism::new(Params::default()).unwrap();
    let pose = array("pose");
    let length = array("length_true");
    let mut plant = moving_plant();
    let mut previous = None;
    for n in 0..40 {
        if n > 0 {
            plant.do_step(f64::from(n - 1) * 1e-3, 1e-3).unwrap();
        }
        // The whole pose, then every value on its own.
        let whole = read(&plant, &pose);
        for (&r, &x) in pose.iter().zip(&whole) {
            assert_eq!(plant.get_real(r).to_bits(), x.to_bits(), "pose vr {r}");
        }
        // Batches that cut the angles into several runs, out of order, mixed with other
        // outputs, cover only part of them, or ask for one again after a run of all three.
        let batches: [&[u32]; 8] = [
            &[pose[5], pose[3]],
            &[pose[4]],
            &[pose[2], pose[3], length[0]],
            &[length[5], pose[5], pose[4], pose[3], pose[0]],
            &[pose[3], pose[3], pose[5]],
            &[pose[3], pose[4], pose[5], pose[4]],
            &[length[0], pose[2], pose[3], pose[4], pose[5], length[1]],
            &[
                pose[0], pose[1], pose[2], pose[3], pose[4], pose[5], length[0],
            ],
        ];
        for batch in batches {
            let got = read(&plant, batch);
            for (&r, &x) in batch.iter().zip(&got) {
                let at = pose.iter().position(|&p| p == r);
                let expected = at.map_or_else(|| plant.get_real(r), |i| whole[i]);
                assert_eq!(x.to_bits(), expected.to_bits(), "vr {r} in batch {batch:?}");
            }
        }
        // The angles and the position are the state's: inverse kinematics of the pose
        // read gives the leg lengths the plant reports.
        let reported = read(&plant, &length);
        let xyz_euler: [f64; 6] = whole.clone().try_into().unwrap();
        let legs = mech.inverse_kinematics(&Pose::from_xyz_euler(&xyz_euler));
        for (i, (&l, &expected)) in legs.length.iter().zip(&reported).enumerate() {
            assert!(
                (l - expected).abs() < 1e-12,
                "step {n}, leg {}: {l} from the pose read, {expected} reported",
                i + 1
            );
        }
        if let Some(p) = previous.replace(whole.clone()) {
            assert_ne!(p[3..], whole[3..], "the orientation moved at step {n}");
        }
    }
}

#[test]
fn euler_angles_survive_a_saved_state() {
    let pose = array("pose");
    let mut plant = moving_plant();
    for n in 0..25 {
        plant.do_step(f64::from(n) * 1e-3, 1e-3).unwrap();
    }
    let before = read(&plant, &pose);
    let mut bytes = Vec::new();
    plant.save(&mut bytes);
    let mut restored = CkcmPlant::new();
    restored.restore(&bytes).unwrap();
    let after = read(&restored, &pose);
    assert_eq!(
        before.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
        after.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
    );
    assert!(before[3..].iter().all(|&a| a != 0.0), "{before:?}");
}
