//! The controller's reference table (the desired leg lengths, rates and feedforward of each
//! sample, computed once per parameter set and shared across fmi2Reset) changes nothing
//! observable: every output of every doStep equals, bit for bit, the law evaluated from
//! scratch by `ckcm::Hlcs`, in the trial that builds the table, in later trials that reuse it,
//! after a nominal-model parameter changes, for another step size or start time, and across
//! an FMU state save and restore.

use ckcm::nalgebra::Vector6;
use ckcm::{ControlInput, ControlSettings, Hlcs, Mechanism, Params, Trajectory};
use fmu_core::Model;
use hlcs_controller::HlcsController;
use hlcs_controller::md::VARIABLES;

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

/// A short line, so a test trial is a few hundred samples.
const DURATION: f64 = 0.4;

/// A line controller with learning on; `platform_mass` for the nominal model's platform.
fn controller(platform_mass: f64) -> HlcsController {
    let mut c = HlcsController::new();
    c.set_integer(vr("trajectory"), 2).unwrap();
    c.set_boolean(vr("learning"), true).unwrap();
    c.set_real(vr("duration"), DURATION).unwrap();
    c.set_real(vr("model.platform_mass"), platform_mass)
        .unwrap();
    c
}

/// The same law from scratch, without any table.
fn law(platform_mass: f64) -> Hlcs {
    let mut p = Params::nominal();
    p.set_field("platform_mass", platform_mass).unwrap();
    Hlcs::new(Mechanism::new(p).unwrap(), ControlSettings::default())
}

/// Measurements that lag the reference and wobble, and a non-zero memory, at sample `n`.
fn input(n: usize) -> ControlInput {
    let x = n as f64;
    ControlInput {
        length: Vector6::from_fn(|i, _| 0.62 + 1e-4 * (0.3 * x + i as f64).sin()),
        velocity: Vector6::from_fn(|i, _| 1e-3 * (0.2 * x - i as f64).cos()),
        memory: Vector6::from_fn(|i, _| 5.0 + i as f64 + 1e-2 * x),
    }
}

/// Outputs force, memory_next, length_ref and error, as bits.
fn outputs(c: &HlcsController) -> Vec<u64> {
    ["force", "memory_next", "length_ref", "error"]
        .iter()
        .flat_map(|b| array(b))
        .map(|r| c.get_real(r).to_bits())
        .collect()
}

fn expected(out: &ckcm::ControlOutput) -> Vec<u64> {
    [out.force, out.memory_next, out.length_ref, out.error]
        .iter()
        .flat_map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
        .collect()
}

/// Steps `c` (initialised at `start`) over samples `range` at t = t0 + n·h and checks each
/// against `reference`.
fn run_and_compare(
    c: &mut HlcsController,
    reference: &mut Hlcs,
    start: f64,
    t0: f64,
    h: f64,
    range: std::ops::Range<usize>,
) -> Vec<Vec<u64>> {
    let trajectory = Trajectory {
        kind: ckcm::TrajectoryKind::Line,
        duration: DURATION,
        home_height: reference.model.params.geometry.home_height,
    };
    let mut seen = Vec::new();
    for n in range {
        let t = t0 + n as f64 * h;
        let u = input(n);
        for (bases, v) in [
            ("length", u.length),
            ("velocity", u.velocity),
            ("memory", u.memory),
        ] {
            for (r, x) in array(bases).into_iter().zip(v.iter()) {
                c.set_real(r, *x).unwrap();
            }
        }
        c.do_step(t, h).unwrap();
        let want = reference
            .step(&trajectory.sample(t - start), &u, h)
            .expect("the law evaluates");
        let got = outputs(c);
        assert_eq!(got, expected(&want), "sample {n}, t = {t} s, h = {h} s");
        seen.push(got);
    }
    seen
}

/// One trial from initialization at `t0`, beyond the trajectory's end.
fn trial(platform_mass: f64, t0: f64, h: f64) {
    let mut c = controller(platform_mass);
    c.initialize(t0).unwrap();
    let mut reference = law(platform_mass);
    let samples = (DURATION / h) as usize + 20;
    run_and_compare(&mut c, &mut reference, t0, t0, h, 0..samples);
}

#[test]
fn outputs_equal_the_law_from_scratch_in_every_trial_and_parameter_set() {
    let nominal = Params::nominal().platform.mass;
    // Trial 0 makes the table, trials 1 and 2 (fresh models, as after fmi2Reset) reuse it.
    for _ in 0..3 {
        trial(nominal, 0.0, 1e-3);
    }
    // Another nominal model must not see the first one's feedforward.
    trial(nominal * 1.5, 0.0, 1e-3);
    trial(nominal, 0.0, 1e-3);
    // Another step size and another start time (off the first table's times).
    trial(nominal, 0.0, 2e-3);
    trial(nominal, 0.25, 1e-3);
}

#[test]
fn a_step_off_the_grid_and_a_changed_step_size_are_evaluated_from_scratch() {
    let nominal = Params::nominal().platform.mass;
    let mut c = controller(nominal);
    c.initialize(0.0).unwrap();
    let mut reference = law(nominal);
    run_and_compare(&mut c, &mut reference, 0.0, 0.0, 1e-3, 0..50);
    // Half a step: from t = 0.05 s by 0.5 ms, then on at 1 ms from t = 0.0505 s.
    run_and_compare(&mut c, &mut reference, 0.0, 0.05, 5e-4, 0..1);
    run_and_compare(&mut c, &mut reference, 0.0, 0.0505, 1e-3, 0..30);
}

#[test]
fn save_and_restore_reproduce_the_same_outputs() {
    let nominal = Params::nominal().platform.mass;
    let mut c = controller(nominal);
    c.initialize(0.0).unwrap();
    let mut reference = law(nominal);
    run_and_compare(&mut c, &mut reference, 0.0, 0.0, 1e-3, 0..150);
    let mut saved = Vec::new();
    c.save(&mut saved);
    let integral = reference.integral;
    let first = run_and_compare(&mut c, &mut reference, 0.0, 0.0, 1e-3, 150..300);

    let mut restored = HlcsController::new();
    restored.restore(&saved).unwrap();
    reference.integral = integral;
    let again = run_and_compare(&mut restored, &mut reference, 0.0, 0.0, 1e-3, 150..300);
    assert_eq!(first, again);
}

#[test]
fn a_tiny_step_is_evaluated_on_the_spot_not_tabulated() {
    // A table for 1 ns steps over the 0.4 s line would hold 4e8 samples, about 60 GB: its
    // allocation would abort the whole process. Without a table the outputs are the law's.
    let nominal = Params::nominal().platform.mass;
    let mut c = controller(nominal);
    c.initialize(0.0).unwrap();
    let mut reference = law(nominal);
    run_and_compare(&mut c, &mut reference, 0.0, 0.0, 1e-9, 0..5);
}

#[test]
fn step_sizes_that_change_every_step_give_the_law_from_scratch() {
    // A master cycling through more step sizes than the tables kept: each step is evaluated
    // from scratch (or from a table), always the law's bits.
    let nominal = Params::nominal().platform.mass;
    let mut c = controller(nominal);
    c.initialize(0.0).unwrap();
    let mut reference = law(nominal);
    let mut t = 0.0;
    for n in 0..60 {
        let h = 1e-3 * (1.0 + 0.01 * (n % 7) as f64);
        run_and_compare(&mut c, &mut reference, 0.0, t, h, 0..1);
        t += h;
    }
    // Then a fixed step again, tabulated from its second sample on.
    run_and_compare(&mut c, &mut reference, 0.0, t, 1e-3, 0..40);
}
