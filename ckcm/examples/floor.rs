//! Times the FMI-free floor: one 15 s line trial of HLCS, repeated.
//!
//! Every timed trial starts from the memory one untimed first trial learned, as the cosim
//! bench and `master_trials` do, so each repetition times the same trial. Learning on from
//! trial to trial instead would let the unfiltered law diverge after some hundred trials
//! (docs/convergence.md) and stop the example with a singular mass matrix.
//!
//! Usage: floor [REPS] (default 10).
use ckcm::closed_loop::run_trial_with_table;
use ckcm::nalgebra::Vector6;
use ckcm::*;

fn main() {
    let plant = Mechanism::new(Params::default()).unwrap();
    let nominal = Mechanism::new(Params::nominal()).unwrap();
    let traj = Trajectory::line(0.5);
    let h = 1e-3;
    let steps = 15000;
    let reps: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    // The reference terms once for every trial, as the controller FMU does.
    let table = ReferenceTable::new(&nominal, &traj, 0.0, h);
    let trial = |memory: &[Vector6<f64>], next: &mut [Vector6<f64>]| {
        let mut ctl = Hlcs::new(nominal, ControlSettings::default());
        let mut integ = Integrator::default();
        run_trial_with_table(
            &plant,
            &mut integ,
            &mut ctl,
            &traj,
            h,
            Some(&table),
            memory,
            next,
            |_, _, _, _| {},
        )
        .unwrap();
    };
    let mut learned = vec![Vector6::zeros(); steps];
    let mut next = vec![Vector6::zeros(); steps];
    trial(&vec![Vector6::zeros(); steps], &mut learned);
    let start = std::time::Instant::now();
    for _ in 0..reps {
        trial(&learned, &mut next);
    }
    let per = start.elapsed().as_secs_f64() / reps.max(1) as f64;
    println!(
        "{:.2} ms per 15 s trial ({:.0}x real time)",
        per * 1e3,
        15.0 / per
    );
}
