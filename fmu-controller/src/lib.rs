//! HlcsController: the hybrid learning control scheme as an FMI 2.0 co-simulation FMU.
//!
//! Sampled semantics (docs/model.md §6): doStep(t_n, h) reads the inputs set at t_n, evaluates
//! the law of `ckcm::control` and holds the outputs over [t_n, t_n + h]. Before the first
//! step (after initialization) the outputs preview the law at the start time with the
//! integral of past samples only (none yet).
// Only the export macro of `fmi2-export` may bring unsafe code in (it allows it explicitly).
#![deny(unsafe_code)]

use std::sync::{Arc, Mutex, PoisonError};

use ckcm::nalgebra::Vector6;
use ckcm::{
    ControlInput, ControlSettings, Gains, Hlcs, LearningLaw, Mechanism, ParamError, Params, Pose,
    Reference, ReferenceTable, ReferenceTerms, Trajectory, TrajectoryKind,
};
use fmu_core::values::{ByteReader, ByteWriter, Values, all_finite};
use fmu_core::{Causality, Model, ModelError, ModelResult, VarSpec, VarType};

/// Generated from `modelDescription/HlcsController.xml` by the build script.
pub mod md {
    include!(concat!(env!("OUT_DIR"), "/model_description.rs"));
}
use md::enums::{
    TRAJECTORY_CIRCLE, TRAJECTORY_EXTERNAL, TRAJECTORY_HOLD, TRAJECTORY_ITEMS, TRAJECTORY_LINE,
};
use md::vr;

/// Prefix of the nominal-model parameters.
const MODEL_PREFIX: &str = "model.";

/// A nominal-model parameter error, naming the field by its variable (`model.rod_mass`).
fn model_param_error(e: ParamError) -> ModelError {
    ModelError::error(
        ParamError {
            field: format!("{MODEL_PREFIX}{}", e.field),
            ..e
        }
        .to_string(),
    )
}

/// The nominal model from the `model.*` Real parameters among `variables`; a `model.*`
/// name that is not a mechanism field is an error naming the variable.
fn nominal_params(variables: &[VarSpec], values: &Values) -> ModelResult<Params> {
    let mut p = Params::nominal();
    for v in variables {
        if let Some(field) = v.name.strip_prefix(MODEL_PREFIX) {
            if v.causality == Causality::Parameter && v.var_type == VarType::Real {
                p.set_field(field, values.real(v.value_reference))
                    .map_err(model_param_error)?;
            }
        }
    }
    Ok(p)
}

/// What this process's controller models share: the reference tables of the last few
/// parameter sets, and how many models are alive (instances, and the FMU states saved from
/// them). The tables cannot live in an instance alone: fmi2Reset, which a master calls before
/// every trial, replaces the model by a fresh one with all start values. They go with the last
/// model, though: what a static owns on the heap is freed neither by fmi2FreeInstance nor
/// when the library is unloaded, so a master that loads a fresh copy of this FMU for every
/// run (fmpy's `simulate_fmu` does) would otherwise keep every copy's tables until the
/// process ends, 2.4 MB each for a 15 s trajectory.
struct Shared {
    live: usize,
    tables: Vec<Arc<ReferenceTable>>,
}

static SHARED: Mutex<Shared> = Mutex::new(Shared {
    live: 0,
    tables: Vec::new(),
});

/// How many parameter sets [`SHARED`] remembers (a 15 s trial at 1 ms takes about 2.4 MB).
const TABLES_KEPT: usize = 4;

/// Most samples in one table (about 150 bytes each): a 15 s trajectory down to steps of
/// 75 µs. A smaller step computes its terms on the spot instead of allocating gigabytes,
/// which a step of 0.1 µs would ask.
const MAX_TABLE_SAMPLES: f64 = 200_000.0;

/// [`SHARED`], also after a panic elsewhere poisoned its lock (the data stay consistent:
/// every change to it is a single push, remove, count change or clear, and a panic while
/// a table is built leaves it untouched).
fn shared() -> std::sync::MutexGuard<'static, Shared> {
    SHARED.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The table for these arguments: a remembered one, else with `build` a new one (then
/// remembered, the oldest forgotten). Its terms are computed exactly as the law computes
/// them itself, so nothing the FMU outputs depends on whether a table was found.
fn shared_table(
    model: &Mechanism,
    trajectory: &Trajectory,
    start_time: f64,
    h: f64,
    build: bool,
) -> Option<Arc<ReferenceTable>> {
    let mut shared = shared();
    if let Some(t) = shared
        .tables
        .iter()
        .find(|t| t.is_for(model, trajectory, start_time, h))
    {
        return Some(Arc::clone(t));
    }
    if !build {
        return None;
    }
    let table = Arc::new(ReferenceTable::new(model, trajectory, start_time, h));
    if shared.tables.len() == TABLES_KEPT {
        shared.tables.remove(0);
    }
    shared.tables.push(Arc::clone(&table));
    Some(table)
}

/// Counts one live controller model in [`SHARED`] (made, cloned for a saved FMU state,
/// dropped); the last one to go takes the shared tables with it.
#[derive(Debug)]
struct Live;

impl Live {
    fn new() -> Self {
        shared().live += 1;
        Live
    }
}

impl Clone for Live {
    fn clone(&self) -> Self {
        Live::new()
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        let mut shared = shared();
        shared.live = shared.live.saturating_sub(1);
        if shared.live == 0 {
            shared.tables = Vec::new();
        }
    }
}

/// The controller: variable values plus, once initialised, the control law state.
#[derive(Debug, Clone)]
pub struct HlcsController {
    values: Values,
    sim: Option<Sim>,
    /// Held for its count in [`SHARED`] only.
    _live: Live,
}

#[derive(Debug, Clone)]
struct Sim {
    law: Hlcs,
    /// `None` for the external reference inputs.
    trajectory: Option<Trajectory>,
    start_time: f64,
    /// The trajectory's reference terms for the step size of the last doStep (fetched at a
    /// doStep, since the step size is not known before; see [`Sim::fetch_table`]).
    table: Option<Arc<ReferenceTable>>,
    /// The step size of the last doStep that ran without a table: a table is built only for
    /// a step size used twice in a row, so a master that varies its steps does not pay for
    /// a whole trajectory's terms at every step.
    untabulated_h: f64,
}

impl HlcsController {
    fn params(&self) -> ModelResult<Params> {
        nominal_params(md::VARIABLES, &self.values)
    }

    fn settings(&self) -> ControlSettings {
        let r = |vr| self.values.real(vr);
        ControlSettings {
            gains: Gains {
                kp: r(vr::KP),
                ki: r(vr::KI),
                kd: r(vr::KD),
                phi: r(vr::PHI),
                gamma: r(vr::GAMMA),
                psi: r(vr::PSI),
            },
            learning: LearningLaw::from_switch(self.values.boolean(vr::LEARNING)),
            feedforward: self.values.boolean(vr::FEEDFORWARD),
        }
    }

    fn build(&self, start_time: f64) -> ModelResult<Sim> {
        // The nominal model's fields are the `model.*` variables.
        let model = Mechanism::new(self.params()?).map_err(model_param_error)?;
        let duration = self.values.real(vr::DURATION);
        if duration.is_nan() || duration <= 0.0 {
            return Err(ModelError::error(format!(
                "duration = {duration} s must be positive"
            )));
        }
        let home_height = model.params.geometry.home_height;
        let trajectory = match self.values.integer(vr::TRAJECTORY) {
            TRAJECTORY_HOLD => Some(TrajectoryKind::Hold),
            TRAJECTORY_LINE => Some(TrajectoryKind::Line),
            TRAJECTORY_CIRCLE => Some(TrajectoryKind::Circle),
            TRAJECTORY_EXTERNAL => None,
            other => {
                return Err(ModelError::error(format!(
                    "trajectory = {other} is not a Trajectory item ({TRAJECTORY_ITEMS})"
                )));
            }
        }
        .map(|kind| Trajectory {
            kind,
            duration,
            home_height,
        });
        Ok(Sim {
            law: Hlcs::new(model, self.settings()),
            trajectory,
            start_time,
            table: None,
            untabulated_h: f64::NAN,
        })
    }

    /// The reference at `t`: the trajectory's, or the external inputs'.
    fn reference(values: &Values, sim: &Sim, t: f64) -> Reference {
        match &sim.trajectory {
            Some(traj) => traj.sample(t - sim.start_time),
            None => Reference {
                pose: Pose::from_xyz_euler(&values.real6(vr::POSE_REF_1)),
                twist: Vector6::from_row_slice(&values.real6(vr::TWIST_REF_1)),
                accel: Vector6::from_row_slice(&values.real6(vr::ACCEL_REF_1)),
            },
        }
    }

    fn input(&self) -> ControlInput {
        let v = |first| Vector6::from_row_slice(&self.values.real6(first));
        ControlInput {
            length: v(vr::LENGTH_1),
            velocity: v(vr::VELOCITY_1),
            memory: v(vr::MEMORY_1),
        }
    }

    /// Evaluates the law at `t`; with `commit`, integrates this sample over `h`.
    ///
    /// The tabulated step runs here; every other path (the table to fetch, terms computed
    /// on the spot, an error to word) is a call out of line, so the step's own code stays
    /// in few cache lines: between two plant steps the dynamics' code and the FMUs' glue
    /// compete for the instruction cache (BENCHMARKS.md, round 33).
    fn sample(&mut self, t: f64, h: f64, commit: bool) -> ModelResult<()> {
        let settings = self.settings();
        let input = self.input();
        let Self { values, sim, .. } = self;
        let Some(sim) = sim.as_mut() else {
            return Err(not_initialized());
        };
        // Gains are tunable between steps.
        sim.law.settings = settings;
        sim.table_for(h);
        let computed;
        let terms = match sim.tabulated(t) {
            Some(terms) => terms,
            None => {
                computed = sim.terms_at(values, t);
                &computed
            }
        };
        let (out, integral) = match sim.law.evaluate_terms(terms, &input, h) {
            Ok(evaluated) => evaluated,
            Err(e) => return Err(law_failed(values, sim, t, &e)),
        };
        // Never hand non-finite commands on with fmi2OK: the plant would then blame its own
        // input. The first non-finite output is named with the time. One branch-free scan
        // per step; the culprit is looked up only on failure.
        let outputs = [
            ("force", &out.force),
            ("memory_next", &out.memory_next),
            ("length_ref", &out.length_ref),
            ("error", &out.error),
        ];
        let finite = outputs
            .iter()
            .map(|(_, v)| *v)
            .chain([&integral])
            .fold(true, |ok, v| ok & all_finite(v.as_slice()));
        if !finite {
            return Err(not_finite_output(t, &outputs, &integral, &input));
        }
        if commit {
            sim.law.integral = integral;
        }
        values.set_real6(vr::FORCE_1, &out.force.into());
        values.set_real6(vr::MEMORY_NEXT_1, &out.memory_next.into());
        values.set_real6(vr::LENGTH_REF_1, &out.length_ref.into());
        values.set_real6(vr::ERROR_1, &out.error.into());
        Ok(())
    }
}

impl Sim {
    /// Makes sure a tabulated trajectory's table is the one for step `h` (fetched at the
    /// first doStep, and again for another step size).
    #[inline]
    fn table_for(&mut self, h: f64) {
        if self.trajectory.is_some()
            && h > 0.0
            && self.table.as_ref().is_none_or(|tb| tb.step_size() != h)
        {
            self.fetch_table(h);
        }
    }

    /// The table's terms at `t`, when `t` is on its grid.
    #[inline]
    fn tabulated(&self, t: f64) -> Option<&ReferenceTerms> {
        match (&self.trajectory, &self.table) {
            (Some(_), Some(tb)) => tb.get(t - self.start_time),
            _ => None,
        }
    }

    /// A table for step `h`: one already made, else a new one for a step size used twice in
    /// a row whose table stays small. Otherwise none: the terms are computed on the spot,
    /// the same bits.
    #[cold]
    #[inline(never)]
    fn fetch_table(&mut self, h: f64) {
        let Some(traj) = &self.trajectory else { return };
        let repeated = h.to_bits() == self.untabulated_h.to_bits();
        let small = traj.duration / h <= MAX_TABLE_SAMPLES;
        self.table = shared_table(&self.law.model, traj, self.start_time, h, repeated && small);
        self.untabulated_h = if self.table.is_some() { f64::NAN } else { h };
    }

    /// The terms at `t` computed on the spot: for the external reference inputs, a time off
    /// the table's grid, and the preview at initialization. Out of line but not cold: it is
    /// every step's path under the external reference.
    #[inline(never)]
    fn terms_at(&self, values: &Values, t: f64) -> ReferenceTerms {
        let reference = HlcsController::reference(values, self, t);
        ReferenceTerms::new(&self.law.model, &reference, self.law.settings.feedforward)
    }
}

#[cold]
fn not_initialized() -> ModelError {
    ModelError::error("not initialized")
}

/// The error of a control law that could not be evaluated at `t`, with the reference pose.
#[cold]
#[inline(never)]
fn law_failed(values: &Values, sim: &Sim, t: f64, e: &dyn std::fmt::Display) -> ModelError {
    ModelError::error(format!(
        "control law failed at t = {t} s: {e} (reference pose {:?})",
        HlcsController::reference(values, sim, t)
            .pose
            .to_xyz_euler()
    ))
}

/// The error for the first non-finite value of `outputs`, else of `integral`, at `t`.
#[cold]
fn not_finite_output(
    t: f64,
    outputs: &[(&str, &Vector6<f64>)],
    integral: &Vector6<f64>,
    input: &ControlInput,
) -> ModelError {
    let culprit = outputs.iter().find_map(|(name, v)| {
        v.iter()
            .position(|x| !x.is_finite())
            .map(|i| (*name, i, v[i]))
    });
    ModelError::error(match culprit {
        Some((name, i, x)) => format!(
            "control law failed at t = {t} s: output {name}[{}] = {x} is not finite \
             (inputs length = {:?} m, memory = {:?} N)",
            i + 1,
            input.length.as_slice(),
            input.memory.as_slice()
        ),
        None => format!(
            "control law failed at t = {t} s: the error integral {:?} is not finite",
            integral.as_slice()
        ),
    })
}

impl Model for HlcsController {
    fmu_core::values_model!(md, values);

    fn new() -> Self {
        Self {
            values: Values::for_variables(md::START, md::VARIABLES),
            sim: None,
            _live: Live::new(),
        }
    }

    fn initialize(&mut self, start_time: f64) -> ModelResult<()> {
        self.sim = Some(self.build(start_time)?);
        self.sample(start_time, 0.0, false)
    }

    fn do_step(&mut self, t: f64, h: f64) -> ModelResult<()> {
        self.sample(t, h, true)
    }

    fn save(&self, out: &mut Vec<u8>) {
        let mut w = ByteWriter(out);
        self.values.save(&mut w);
        match &self.sim {
            None => w.u8(0),
            Some(sim) => {
                w.u8(1);
                w.f64(sim.start_time);
                w.f64s(sim.law.integral.as_slice());
            }
        }
    }

    fn restore(&mut self, bytes: &[u8]) -> ModelResult<()> {
        let mut r = ByteReader(bytes);
        let mut restored = Self {
            values: Values::default(),
            sim: None,
            _live: Live::new(),
        };
        restored.values.restore(&mut r)?;
        if r.u8()? == 1 {
            let start_time = r.f64()?;
            if !start_time.is_finite() {
                return Err(ModelError::error(format!(
                    "saved controller state is invalid: start time {start_time}"
                )));
            }
            let mut sim = restored.build(start_time)?;
            let mut integral = [0.0; 6];
            r.f64s(&mut integral)?;
            if !integral.iter().all(|x| x.is_finite()) {
                return Err(ModelError::error(format!(
                    "saved controller state is invalid: error integral {integral:?}"
                )));
            }
            sim.law.integral = Vector6::from_row_slice(&integral);
            restored.sim = Some(sim);
        }
        r.finish()?;
        *self = restored;
        Ok(())
    }
}

fmi2_export::export_fmu!(HlcsController);

#[cfg(test)]
mod tests {
    use super::*;

    /// Held by every test that makes models: `shared_tables_go_with_the_last_model` counts
    /// them, so no other test may make one meanwhile.
    static MODELS: Mutex<()> = Mutex::new(());

    fn models() -> std::sync::MutexGuard<'static, ()> {
        MODELS.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// A line controller of 0.2 s, initialised at `start_time`.
    fn line_controller(start_time: f64) -> HlcsController {
        let mut c = HlcsController::new();
        c.set_integer(vr::TRAJECTORY, TRAJECTORY_LINE).unwrap();
        c.set_real(vr::DURATION, 0.2).unwrap();
        c.initialize(start_time).unwrap();
        c
    }

    /// [`line_controller`] from 0, stepped twice by one step size, so it holds a table.
    fn stepped() -> HlcsController {
        let mut c = line_controller(0.0);
        c.do_step(0.0, 1e-3).unwrap();
        c.do_step(1e-3, 1e-3).unwrap();
        c
    }

    /// A failed control law names the first non-finite element of the first output that
    /// has one (1-based), or the integral when every output is finite.
    #[test]
    fn a_non_finite_output_is_named_by_its_element() {
        let finite = Vector6::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0);
        let bad = Vector6::new(1.0, 2.0, f64::INFINITY, f64::NAN, 5.0, 6.0);
        let input = ControlInput {
            length: Vector6::from_element(0.6),
            velocity: Vector6::zeros(),
            memory: Vector6::zeros(),
        };
        let integral = Vector6::zeros();
        let e = not_finite_output(
            0.5,
            &[("force", &finite), ("error", &bad)],
            &integral,
            &input,
        );
        assert!(
            e.message.starts_with(
                "control law failed at t = 0.5 s: output error[3] = inf is not finite"
            ),
            "{}",
            e.message
        );
        let e = not_finite_output(0.5, &[("force", &finite)], &bad, &input);
        assert!(e.message.contains("the error integral"), "{}", e.message);
    }

    fn table_of(c: &HlcsController) -> Arc<ReferenceTable> {
        Arc::clone(c.sim.as_ref().unwrap().table.as_ref().unwrap())
    }

    /// The shared tables stay while any model lives (across an fmi2Reset, which replaces the
    /// model by a fresh one, and in a saved FMU state) and go with the last one, as when a
    /// master frees the instance and unloads this copy of the library.
    #[test]
    fn shared_tables_go_with_the_last_model() {
        let _models = models();
        let count = || {
            let s = shared();
            (s.live, s.tables.len())
        };
        assert_eq!(count(), (0, 0));
        let mut a = stepped();
        assert_eq!(count(), (1, 1));
        let saved = a.clone();
        a = HlcsController::new();
        assert_eq!(
            count(),
            (2, 1),
            "fmi2Reset and a saved state keep the table"
        );
        drop(a);
        let b = stepped();
        assert!(
            Arc::ptr_eq(&table_of(&b), &table_of(&saved)),
            "a new instance reuses the table while another model lives"
        );
        assert_eq!(count(), (2, 1));
        drop(saved);
        assert_eq!(count(), (1, 1));
        drop(b);
        assert_eq!(count(), (0, 0), "the last model takes the tables with it");
    }

    /// The table is a cache: the outputs are the same bits without it
    /// (`ckcm::closed_loop`'s `the_table_changes_no_bit`), so only the model's state shows
    /// whether it serves the steps. It serves the grid times of the step size in use, from
    /// the start time; a new step size gets its own table on its second use in a row (one
    /// step of another size makes none), and the old one comes back from the shared tables.
    #[test]
    fn steps_on_the_grid_are_served_by_the_table_of_their_step_size() {
        let _models = models();
        let grid = |n: u32, h: f64| f64::from(n) * h;
        let mut c = line_controller(0.5);
        fn sim(c: &HlcsController) -> &Sim {
            c.sim.as_ref().unwrap()
        }
        let step = |c: &mut HlcsController, n: u32, h: f64| {
            c.do_step(0.5 + grid(n, h), h).unwrap();
            sim(c).table.as_ref().map(|tb| tb.step_size())
        };
        assert_eq!(
            step(&mut c, 0, 1e-3),
            None,
            "one step of a size makes no table"
        );
        assert_eq!(step(&mut c, 1, 1e-3), Some(1e-3));
        for n in [2, 3, 100, 200] {
            assert!(
                sim(&c).tabulated(0.5 + grid(n, 1e-3)).is_some(),
                "t = 0.5 + {n} ms"
            );
        }
        assert!(sim(&c).tabulated(0.5 + 1.5e-3).is_none(), "off the grid");
        assert!(
            sim(&c).tabulated(0.5 + grid(201, 1e-3)).is_none(),
            "past the trajectory"
        );
        assert_eq!(step(&mut c, 2, 1e-3), Some(1e-3));
        // Another step size: computed on the spot once, then tabulated.
        assert_eq!(step(&mut c, 1, 2e-3), None);
        assert_eq!(step(&mut c, 2, 2e-3), Some(2e-3));
        assert!(sim(&c).tabulated(0.5 + grid(3, 2e-3)).is_some());
        // Back to 1 ms: the shared table, at once.
        assert_eq!(step(&mut c, 6, 1e-3), Some(1e-3));
        // A zero step tabulates nothing.
        assert_eq!(step(&mut c, 7, 0.0), Some(1e-3));
        // Nor does a step whose table would outgrow MAX_TABLE_SAMPLES (0.2 s / 0.1 µs).
        assert_eq!(step(&mut c, 70_000, 1e-7), None);
        assert_eq!(step(&mut c, 70_001, 1e-7), None);
    }

    /// A `model.*` parameter that is no mechanism field (here `model.gravity` renamed) is
    /// an error naming the variable; an invalid value is named by its variable too.
    #[test]
    fn nominal_model_errors_name_the_variable() {
        let mut values = Values::for_variables(md::START, md::VARIABLES);
        let mut renamed: Vec<VarSpec> = md::VARIABLES.to_vec();
        let gravity = renamed
            .iter_mut()
            .find(|v| v.value_reference == vr::MODEL_GRAVITY)
            .unwrap();
        gravity.name = "model.gravitation";
        let e = nominal_params(&renamed, &values).unwrap_err();
        assert!(
            e.message
                .starts_with("parameter `model.gravitation` is not a mechanism parameter"),
            "{}",
            e.message
        );

        values.set_real(vr::MODEL_ROD_COM, -1.0);
        let p = nominal_params(md::VARIABLES, &values).unwrap();
        let e = Mechanism::new(p).map_err(model_param_error).unwrap_err();
        assert_eq!(
            e.message,
            "parameter `model.rod_com` = -1 must not be negative"
        );
    }
}
