//! The coupled plant + controller loop without any FMI layer, in the Gauss–Seidel order of
//! docs/model.md §6. It is the floor the co-simulation is benchmarked against, and lets tests
//! study learning without building FMUs.

use nalgebra::Vector6;

use crate::control::{ControlInput, ControlOutput, Hlcs, ReferenceTable, ReferenceTerms};
use crate::dynamics::DynamicsError;
use crate::integrate::{IntegrationError, Integrator, State};
use crate::kinematics::Mechanism;
use crate::trajectory::Trajectory;

/// Failure of one closed-loop trial, with the sample where it happened.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TrialError {
    #[error("controller failed at t = {t} s: {source}")]
    Controller { t: f64, source: DynamicsError },
    #[error("plant failed at t = {t} s: {source}")]
    Plant { t: f64, source: IntegrationError },
}

/// One trial of `steps` samples of period `h` from rest at the trajectory's start.
///
/// `memory` holds u_k for every sample (read), `memory_next` receives u_{k+1} (written);
/// `observe(n, state_before_step, measurements, output)` sees each sample.
#[allow(clippy::too_many_arguments)]
pub fn run_trial(
    plant: &Mechanism,
    integrator: &mut Integrator,
    controller: &mut Hlcs,
    trajectory: &Trajectory,
    h: f64,
    memory: &[Vector6<f64>],
    memory_next: &mut [Vector6<f64>],
    observe: impl FnMut(usize, &State, &ControlInput, &ControlOutput),
) -> Result<State, TrialError> {
    run_trial_with_table(
        plant,
        integrator,
        controller,
        trajectory,
        h,
        None,
        memory,
        memory_next,
        observe,
    )
}

/// [`run_trial`] taking the reference terms from `table` where it has them (made with the
/// controller's model, `trajectory`, start time 0 and step `h`; any other table is ignored).
/// The outputs are the same bits as without the table.
#[allow(clippy::too_many_arguments)]
pub fn run_trial_with_table(
    plant: &Mechanism,
    integrator: &mut Integrator,
    controller: &mut Hlcs,
    trajectory: &Trajectory,
    h: f64,
    table: Option<&ReferenceTable>,
    memory: &[Vector6<f64>],
    memory_next: &mut [Vector6<f64>],
    mut observe: impl FnMut(usize, &State, &ControlInput, &ControlOutput),
) -> Result<State, TrialError> {
    let table = table.filter(|tb| tb.is_for(&controller.model, trajectory, 0.0, h));
    let mut state = State::at_rest(trajectory.sample(0.0).pose);
    controller.reset();
    let steps = memory.len().min(memory_next.len());
    for n in 0..steps {
        let t = n as f64 * h;
        let legs = plant.inverse_kinematics(&state.pose);
        let input = ControlInput {
            length: legs.length,
            velocity: legs.leg_rates(&state.twist),
            memory: memory[n],
        };
        let out = match table.and_then(|tb| tb.get(t)) {
            Some(terms) => controller.step_terms(terms, &input, h),
            None => {
                let reference = trajectory.sample(t);
                let terms = ReferenceTerms::new(
                    &controller.model,
                    &reference,
                    controller.settings.feedforward,
                );
                controller.step_terms(&terms, &input, h)
            }
        }
        .map_err(|source| TrialError::Controller { t, source })?;
        memory_next[n] = out.memory_next;
        observe(n, &state, &input, &out);
        integrator
            .advance(plant, &mut state, &out.force, h)
            .map_err(|source| TrialError::Plant { t, source })?;
    }
    Ok(state)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Params;

    /// A learning line trial gives the same bits with the reference table as without it,
    /// and a table made for another step is ignored rather than misused.
    #[test]
    fn the_table_changes_no_bit() {
        let plant = Mechanism::new(Params::default()).unwrap();
        let nominal = Mechanism::new(Params::nominal()).unwrap();
        let trajectory = Trajectory {
            duration: 0.5,
            ..Trajectory::line(plant.params.geometry.home_height)
        };
        let h = 1e-3;
        let memory: Vec<Vector6<f64>> =
            (0..600).map(|n| Vector6::repeat(1e-2 * n as f64)).collect();
        let run = |table: Option<&ReferenceTable>| {
            let mut controller = Hlcs::new(nominal, Default::default());
            let mut next = vec![Vector6::zeros(); memory.len()];
            let mut seen = Vec::new();
            run_trial_with_table(
                &plant,
                &mut Integrator::default(),
                &mut controller,
                &trajectory,
                h,
                table,
                &memory,
                &mut next,
                |_, state, _, out| {
                    let bits = |v: &Vector6<f64>| v.map(f64::to_bits);
                    seen.push((
                        state.twist.map(f64::to_bits),
                        bits(&out.force),
                        bits(&out.error),
                    ));
                },
            )
            .unwrap();
            (seen, next)
        };
        let without = run(None);
        assert_eq!(
            run(Some(&ReferenceTable::new(&nominal, &trajectory, 0.0, h))),
            without
        );
        assert_eq!(
            run(Some(&ReferenceTable::new(&nominal, &trajectory, 0.0, 2e-3))),
            without
        );
    }
}
