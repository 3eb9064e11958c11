//! Whether independent forward-dynamics evaluations overlap on this processor: the time
//! per evaluation of one chain, each evaluation's pose and twist taken from the one before,
//! against two such chains evaluated alternately. If two chains cost less per evaluation,
//! the processor has idle units that a second evaluation fills, and reordering the RK4
//! stages (the pose of stage s + 1 does not need stage s's acceleration) could pay; if not,
//! an evaluation is bound by its instruction stream (BENCHMARKS.md, rounds 18 and 40).
//!
//! Usage: chains [EVALUATIONS] (default 2,000,000), three rounds.
use std::hint::black_box;

use ckcm::nalgebra::Vector6;
use ckcm::{Mechanism, Params, Pose};

fn main() {
    let mech = Mechanism::new(Params::default()).expect("default parameters are valid");
    let tau = mech
        .static_forces(&mech.home())
        .expect("home is not singular");
    let evaluations: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(2_000_000);
    // Two busy states away from the home pose's symmetries.
    let start = [
        (
            Pose::from_xyz_euler(&[0.03, -0.02, 0.55, 0.05, -0.04, 0.03]),
            Vector6::new(0.05, -0.03, 0.04, 0.2, -0.1, 0.15),
        ),
        (
            Pose::from_xyz_euler(&[0.02, -0.01, 0.56, 0.04, -0.03, 0.02]),
            Vector6::new(0.04, -0.02, 0.03, 0.1, -0.2, 0.1),
        ),
    ];
    // One evaluation, and the next state made to depend on its acceleration (the changes
    // are far too small to move the state away from where it started).
    let step = |pose: &mut Pose, twist: &mut Vector6<f64>| {
        let accel = mech
            .forward_dynamics(pose, twist, &tau)
            .expect("a regular state");
        *twist += accel * 1e-9;
        pose.p_world.x += accel[0] * 1e-15;
    };
    for round in 1..=3 {
        let (mut pose, mut twist) = black_box(start[0]);
        let t0 = std::time::Instant::now();
        for _ in 0..evaluations {
            step(&mut pose, &mut twist);
        }
        let one = t0.elapsed().as_secs_f64() / evaluations as f64;
        black_box((pose, twist));
        let [(mut pose_a, mut twist_a), (mut pose_b, mut twist_b)] = black_box(start);
        let t0 = std::time::Instant::now();
        for _ in 0..evaluations / 2 {
            step(&mut pose_a, &mut twist_a);
            step(&mut pose_b, &mut twist_b);
        }
        let two = t0.elapsed().as_secs_f64() / (evaluations / 2 * 2) as f64;
        black_box((pose_a, twist_a, pose_b, twist_b));
        println!(
            "round {round}: one chain {:.1} ns per evaluation, two chains {:.1} ns",
            one * 1e9,
            two * 1e9
        );
    }
}
