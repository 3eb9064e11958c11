//! Sensor noise of the plant (docs/model.md §10), driven through the safe
//! `fmu_core::Model` trait: σ = 0 changes nothing, a value depends only on the seed,
//! the communication point and the channel (repeated gets, state save/restore), seeds
//! differ, and the noise has the stated σ.

use ckcm::{Mechanism, Params};
use ckcm_plant::CkcmPlant;
use fmu_core::Model;

mod common;
use common::{array, vr};

const H: f64 = 1e-3;

/// One communication point: noisy lengths, noisy rates, true lengths, true rates.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Point {
    length: [f64; 6],
    velocity: [f64; 6],
    length_true: [f64; 6],
    velocity_true: [f64; 6],
}

fn read(plant: &CkcmPlant) -> Point {
    let get = |base: &str| array(base).map(|r| plant.get_real(r));
    Point {
        length: get("length"),
        velocity: get("velocity"),
        length_true: get("length_true"),
        velocity_true: get("velocity_true"),
    }
}

/// A plant with the given noise settings (`None` leaves the parameter at its default),
/// initialised at home.
fn plant(sigma_length: Option<f64>, sigma_velocity: Option<f64>, seed: Option<i32>) -> CkcmPlant {
    let mut p = CkcmPlant::new();
    if let Some(s) = sigma_length {
        p.set_real(vr("length_noise_sigma"), s).unwrap();
    }
    if let Some(s) = sigma_velocity {
        p.set_real(vr("velocity_noise_sigma"), s).unwrap();
    }
    if let Some(s) = seed {
        p.set_integer(vr("noise_seed"), s).unwrap();
    }
    p.initialize(0.0).unwrap();
    p
}

/// Forces that hold the platform against gravity and swing it ±5 mm with a PD pull computed
/// from the true lengths and rates, so the motion is the same with and without noise.
struct Driver {
    hold: [f64; 6],
    l_home: [f64; 6],
    force: [u32; 6],
}

impl Driver {
    fn new() -> Self {
        let mech = Mechanism::new(Params::default()).unwrap();
        let hold = mech.static_forces(&mech.home()).unwrap();
        let l_home = mech.inverse_kinematics(&mech.home()).length;
        Self {
            hold: std::array::from_fn(|i| hold[i]),
            l_home: std::array::from_fn(|i| l_home[i]),
            force: array("force"),
        }
    }

    /// doStep n (from t = n·h), returning the values at the new point.
    fn step(&self, plant: &mut CkcmPlant, n: u32) -> Point {
        let y = read(plant);
        let t = f64::from(n) * H;
        let wobble = 0.005 * (std::f64::consts::TAU * t).sin();
        for i in 0..6 {
            let f = self.hold[i] + 5e4 * (self.l_home[i] + wobble - y.length_true[i])
                - 850.0 * y.velocity_true[i];
            plant.set_real(self.force[i], f).unwrap();
        }
        plant.do_step(t, H).unwrap();
        read(plant)
    }

    fn run(&self, plant: &mut CkcmPlant, steps: u32) -> Vec<Point> {
        let mut out = vec![read(plant)];
        out.extend((0..steps).map(|n| self.step(plant, n)));
        out
    }
}

fn bits(x: &[f64; 6]) -> [u64; 6] {
    x.map(f64::to_bits)
}

#[test]
fn zero_sigma_reports_the_true_values_bit_for_bit() {
    let d = Driver::new();
    let default = d.run(&mut plant(None, None, None), 200);
    let explicit = d.run(&mut plant(Some(0.0), Some(0.0), Some(12345)), 200);
    for (a, b) in default.iter().zip(&explicit) {
        assert_eq!(bits(&a.length), bits(&a.length_true));
        assert_eq!(bits(&a.velocity), bits(&a.velocity_true));
        assert_eq!(bits(&a.length), bits(&b.length));
        assert_eq!(bits(&a.velocity), bits(&b.velocity));
    }
    // The platform really moved (the comparison is not between constants).
    let travel = (default[100].length_true[0] - default[0].length_true[0]).abs();
    assert!(travel > 1e-4, "leg 1 moved only {travel} m");
}

#[test]
fn noise_leaves_the_motion_alone_and_is_added_to_the_reported_values_only() {
    let d = Driver::new();
    let clean = d.run(&mut plant(None, None, None), 100);
    let noisy = d.run(&mut plant(Some(1e-5), Some(1e-3), Some(7)), 100);
    for (c, n) in clean.iter().zip(&noisy) {
        // The driver uses the true values, so the motion must be identical.
        assert_eq!(bits(&c.length_true), bits(&n.length_true));
        assert_eq!(bits(&c.velocity_true), bits(&n.velocity_true));
        for i in 0..6 {
            assert_ne!(n.length[i], n.length_true[i]);
            assert_ne!(n.velocity[i], n.velocity_true[i]);
            // 7 σ: a bound a correct generator exceeds with probability ~1e-11 per value.
            assert!((n.length[i] - n.length_true[i]).abs() < 7e-5);
            assert!((n.velocity[i] - n.velocity_true[i]).abs() < 7e-3);
        }
    }
}

#[test]
fn each_signal_has_its_own_sigma() {
    let d = Driver::new();
    let only_length = d.run(&mut plant(Some(1e-5), None, Some(3)), 10);
    for p in &only_length {
        assert_eq!(bits(&p.velocity), bits(&p.velocity_true));
        assert!(p.length.iter().zip(&p.length_true).all(|(a, b)| a != b));
    }
    let only_velocity = d.run(&mut plant(None, Some(1e-3), Some(3)), 10);
    for p in &only_velocity {
        assert_eq!(bits(&p.length), bits(&p.length_true));
        assert!(p.velocity.iter().zip(&p.velocity_true).all(|(a, b)| a != b));
    }
}

#[test]
fn repeated_gets_at_one_point_see_the_same_value() {
    let d = Driver::new();
    let mut p = plant(Some(1e-5), Some(1e-3), Some(11));
    for n in 0..20 {
        d.step(&mut p, n);
        let a = read(&p);
        let b = read(&p);
        assert_eq!(bits(&a.length), bits(&b.length));
        assert_eq!(bits(&a.velocity), bits(&b.velocity));
    }
}

#[test]
fn saved_and_restored_state_replays_the_same_noise() {
    let d = Driver::new();
    let mut p = plant(Some(1e-5), Some(1e-3), Some(99));
    d.run(&mut p, 50);
    let mut saved = Vec::new();
    p.save(&mut saved);
    let first: Vec<Point> = (50..80).map(|n| d.step(&mut p, n)).collect();
    // Restore into the same instance, and into a fresh one (a deserialized state).
    p.restore(&saved).unwrap();
    let again: Vec<Point> = (50..80).map(|n| d.step(&mut p, n)).collect();
    let mut fresh = CkcmPlant::new();
    fresh.restore(&saved).unwrap();
    assert_eq!(read(&fresh), {
        let mut q = plant(Some(1e-5), Some(1e-3), Some(99));
        d.run(&mut q, 50).pop().unwrap()
    });
    let other: Vec<Point> = (50..80).map(|n| d.step(&mut fresh, n)).collect();
    assert_eq!(first, again);
    assert_eq!(first, other);
}

#[test]
fn different_seeds_give_different_noise_and_the_same_seed_the_same() {
    let d = Driver::new();
    let a = d.run(&mut plant(Some(1e-5), Some(1e-3), Some(1000)), 30);
    let b = d.run(&mut plant(Some(1e-5), Some(1e-3), Some(1001)), 30);
    let a2 = d.run(&mut plant(Some(1e-5), Some(1e-3), Some(1000)), 30);
    assert_eq!(a, a2);
    for (x, y) in a.iter().zip(&b) {
        for i in 0..6 {
            assert_ne!(x.length[i], y.length[i]);
            assert_ne!(x.velocity[i], y.velocity[i]);
        }
    }
}

/// Sample statistics of (reported − true)/σ over 2001 points × 12 channels = 24 012 values
/// of a standard normal: the mean within 5 standard errors (5/√N ≈ 0.032) of 0, the standard
/// deviation within 5 of its standard errors (5/√(2N) ≈ 0.023) of 1, and neighbouring
/// points and channels uncorrelated within 5/√N of 0.
#[test]
fn noise_is_white_with_the_stated_sigma() {
    let (sl, sv) = (2e-5, 3e-3);
    let d = Driver::new();
    let run = d.run(&mut plant(Some(sl), Some(sv), Some(2024)), 2000);
    // channel-major: 0–5 lengths, 6–11 rates.
    let mut z: Vec<Vec<f64>> = vec![Vec::new(); 12];
    for p in &run {
        for i in 0..6 {
            z[i].push((p.length[i] - p.length_true[i]) / sl);
            z[6 + i].push((p.velocity[i] - p.velocity_true[i]) / sv);
        }
    }
    let all: Vec<f64> = z.iter().flatten().copied().collect();
    let n = all.len() as f64;
    let mean = all.iter().sum::<f64>() / n;
    let std = (all.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    assert!(mean.abs() < 5.0 / n.sqrt(), "mean {mean}");
    assert!((std - 1.0).abs() < 5.0 / (2.0 * n).sqrt(), "std {std}");
    // Lag-1 correlation along the points, pooled over channels.
    let pairs: Vec<(f64, f64)> = z
        .iter()
        .flat_map(|c| c.windows(2).map(|w| (w[0], w[1])))
        .collect();
    let lag1 = pairs.iter().map(|(a, b)| a * b).sum::<f64>() / pairs.len() as f64;
    assert!(
        lag1.abs() < 5.0 / (pairs.len() as f64).sqrt(),
        "lag-1 {lag1}"
    );
    // Correlation between neighbouring channels at the same point.
    let cross: Vec<f64> = (0..11)
        .flat_map(|c| z[c].iter().zip(&z[c + 1]).map(|(a, b)| a * b))
        .collect();
    let cc = cross.iter().sum::<f64>() / cross.len() as f64;
    assert!(cc.abs() < 5.0 / (cross.len() as f64).sqrt(), "cross {cc}");
    eprintln!("N = {n}: mean {mean:.5}, std {std:.5}, lag-1 {lag1:.5}, cross {cc:.5}");
}

/// Refused either when set (below the declared min) or at initialization, naming the variable.
#[test]
fn negative_sigma_or_seed_is_refused() {
    for (name, real) in [
        ("length_noise_sigma", true),
        ("velocity_noise_sigma", true),
        ("noise_seed", false),
    ] {
        let mut p = CkcmPlant::new();
        let set = if real {
            p.set_real(vr(name), -1e-3)
        } else {
            p.set_integer(vr(name), -1)
        };
        let err = match set {
            Err(e) => e,
            Ok(()) => p.initialize(0.0).unwrap_err(),
        };
        assert!(err.message.contains(name), "{}", err.message);
    }
}
