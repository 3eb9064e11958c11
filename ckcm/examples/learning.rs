//! Prints the max leg error per trial for the three schemes on both trajectories,
//! using the in-process loop (no FMI).
use ckcm::closed_loop::run_trial;
use ckcm::nalgebra::Vector6;
use ckcm::*;

fn main() {
    let plant = Mechanism::new(Params::default()).unwrap();
    let nominal = Mechanism::new(Params::nominal()).unwrap();
    let h = 1e-3;
    for traj in [Trajectory::line(0.5), Trajectory::circle(0.5)] {
        for (name, learning) in [
            ("PID", LearningLaw::None),
            ("PD-ILC", LearningLaw::PdType),
            ("HLCS", LearningLaw::PidType),
        ] {
            let settings = ControlSettings {
                gains: Gains::default(),
                learning,
                feedforward: true,
            };
            let steps = (traj.duration / h).round() as usize + 1;
            let mut mem = vec![Vector6::zeros(); steps];
            let mut next = vec![Vector6::zeros(); steps];
            let mut line = format!("{:?} {name:7}", traj.kind);
            for _k in 0..10 {
                let mut ctl = Hlcs::new(nominal, settings);
                let mut integ = Integrator::default();
                let mut maxe: f64 = 0.0;
                let r = run_trial(
                    &plant,
                    &mut integ,
                    &mut ctl,
                    &traj,
                    h,
                    &mem,
                    &mut next,
                    |_, _, _, o| {
                        maxe = maxe.max(o.error.amax());
                    },
                );
                if let Err(e) = r {
                    line += &format!(" ERR {e}");
                    break;
                }
                line += &format!(" {:.3}", maxe * 1e3);
                std::mem::swap(&mut mem, &mut next);
            }
            println!("{line}");
        }
    }
}
