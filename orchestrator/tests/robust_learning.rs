//! The robust memory update (docs/model.md §9) through the packaged FMUs: without an update
//! table the memory is the paper's, bit for bit; with the robust setting (Butterworth order
//! 4, 8 Hz, lead 25) learning meets the acceptance bounds on the circle and the line,
//! also with a 30 % heavier platform and with the learning gains scaled by 0.75.

mod common;

use std::path::Path;

use orchestrator::master::Master;
use orchestrator::scenario::Scenario;

const ROBUST: &str =
    "[memory.update]\nfilter = \"butterworth\"\norder = 4\ncutoff = 8.0\nlead = 25\n";

/// A scenario of `trajectory` over `duration` s with `update` as the memory channel's
/// update table (empty: none), extra controller and plant parameters, and the memory
/// written recorded.
fn scenario_toml(
    trajectory: &str,
    duration: f64,
    update: &str,
    controller_params: &str,
    plant_params: &str,
) -> String {
    format!(
        r#"
step_size = 0.001
stop_time = {duration:?}

[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "{trajectory}"
duration = {duration:?}
learning = true
{controller_params}

[[fmu]]
name = "plant"
path = "{plant}"
[fmu.parameters]
{plant_params}
{closed_loop}{update}

[record]
variables = ["controller.memory_next"]

# The true error (reference − noise-free length), also under sensor noise.
[metrics]
reference = "controller.length_ref"
length = "plant.length_true"
"#,
        controller = common::fmu_path_text("HlcsController"),
        plant = common::fmu_path_text("CkcmPlant"),
        closed_loop = common::CLOSED_LOOP,
    )
}

/// Runs `trials` trials of `text`; per trial the max leg error (m), the memory_next written
/// (sample-major, as the memory buffer) and the memory left for the next trial.
fn run(text: &str, trials: usize) -> Vec<(f64, Vec<f64>, Vec<f64>)> {
    let (scenario, fmus) = Scenario::open_text(text, Path::new("robust.toml")).unwrap();
    let mut master = Master::new(&scenario, fmus, false).unwrap();
    let mut recording = master.new_recording();
    let mut signals = master.new_signals();
    (0..trials)
        .map(|k| {
            master
                .run_trial(k, Some(&mut recording), &mut signals, |_| {})
                .unwrap();
            let max = signals
                .error
                .iter()
                .flatten()
                .fold(0.0f64, |m, e| m.max(e.abs()));
            let written: Vec<f64> = recording.rows().flatten().copied().collect();
            (max, written, master.memory()[0].to_vec())
        })
        .collect()
}

fn max_errors_mm(runs: &[(f64, Vec<f64>, Vec<f64>)]) -> Vec<f64> {
    runs.iter().map(|r| r.0 * 1e3).collect()
}

/// After trial 3 the max error never rises by more than 1 µm from one trial to the next.
fn assert_no_rise_after_trial_3(max_mm: &[f64], what: &str) {
    for k in 3..max_mm.len() - 1 {
        assert!(
            max_mm[k + 1] - max_mm[k] <= 1e-3,
            "{what}: max error rises from {} to {} mm at trial {}: {max_mm:?}",
            max_mm[k],
            max_mm[k + 1],
            k + 1
        );
    }
}

#[test]
fn without_an_update_table_the_memory_is_the_paper_bit_for_bit() {
    let plain = run(&scenario_toml("line", 2.0, "", "", ""), 3);
    for (k, (_, written, memory)) in plain.iter().enumerate() {
        // The next trial reads exactly what this one wrote.
        assert_eq!(written, memory, "trial {k}");
        assert!(memory.iter().any(|&u| u != 0.0));
    }
    // A table that spells out the defaults is the paper's update too.
    let identity = "[memory.update]\nlead = 0\nforgetting = 1.0\ngain = 1.0\n";
    let spelled = run(&scenario_toml("line", 2.0, identity, "", ""), 3);
    for (k, (a, b)) in plain.iter().zip(&spelled).enumerate() {
        assert_eq!(a.0.to_bits(), b.0.to_bits(), "trial {k}: max error");
        assert_eq!(a.2, b.2, "trial {k}: memory");
    }
    // The robust update does change the memory.
    let robust = run(&scenario_toml("line", 2.0, ROBUST, "", ""), 1);
    assert_ne!(robust[0].1, robust[0].2);
}

/// Trials of the circle runs: the bounds hold from trial 10 to trial 200.
const CIRCLE_TRIALS: usize = 201;

/// Bounds on the circle over 201 trials: ≤ 0.025 mm from trial 10 to 200, with `early`
/// ≤ 0.035 mm in trial 3, and with `steady` no rise above 1 µm after trial 3. (Measured with
/// the heavier platform and with the lower gains, trial 3 is at 0.041 and 0.038 mm: learning
/// is slower there, so only the nominal and the noise cases are held to the trial-3 bound.
/// Under σ = 1e-5 m single trials move by a few µm with the noise.)
fn assert_circle_bounds(
    controller_params: &str,
    plant_params: &str,
    what: &str,
    early: bool,
    steady: bool,
) {
    let text = scenario_toml("circle", 5.0, ROBUST, controller_params, plant_params);
    let max_mm = max_errors_mm(&run(&text, CIRCLE_TRIALS));
    assert!(
        max_mm[0] > 1.0,
        "{what}: trial 0 shows the mismatch: {max_mm:?}"
    );
    assert!(
        !early || max_mm[3] <= 0.035,
        "{what}: above 0.035 mm in trial 3: {max_mm:?}"
    );
    assert!(
        max_mm[10..].iter().all(|&e| e <= 0.025),
        "{what}: above 0.025 mm from trial 10: {max_mm:?}"
    );
    if steady {
        assert_no_rise_after_trial_3(&max_mm, what);
    }
}

#[test]
fn circle_robust_meets_the_bounds() {
    assert_circle_bounds("", "", "circle", true, true);
}

#[test]
fn circle_robust_meets_the_bounds_with_a_heavier_platform() {
    let mass = ckcm::Params::default().platform.mass * 1.3;
    assert_circle_bounds(
        "",
        &format!("platform_mass = {mass:?}"),
        "platform mass × 1.3",
        false,
        true,
    );
}

#[test]
fn circle_robust_meets_the_bounds_with_learning_gains_scaled_by_0_75() {
    let g = ckcm::Gains::default();
    let params = format!(
        "phi = {:?}\ngamma = {:?}\npsi = {:?}",
        g.phi * 0.75,
        g.gamma * 0.75,
        g.psi * 0.75
    );
    assert_circle_bounds(&params, "", "learning gains × 0.75", false, true);
}

/// White noise of σ on the measured lengths, fresh in every trial.
fn noise(sigma: f64) -> String {
    format!("length_noise_sigma = {sigma:?}\nnoise_seed = {{ base = 1000, per_trial = 1 }}")
}

#[test]
fn circle_robust_meets_the_bounds_with_sensor_noise() {
    assert_circle_bounds("", &noise(1e-5), "σ = 1e-5 m", true, false);
    assert_circle_bounds("", &noise(1e-6), "σ = 1e-6 m", true, true);
}

#[test]
fn line_robust_with_sensor_noise_meets_the_bounds_by_trial_29() {
    for (sigma, bound, steady) in [(1e-6, 0.001, true), (1e-5, 0.01, false)] {
        let text = scenario_toml("line", 15.0, ROBUST, "", &noise(sigma));
        let max_mm = max_errors_mm(&run(&text, 30));
        assert!(
            max_mm[29] <= bound,
            "σ = {sigma} m: trial 29 above {bound} mm: {max_mm:?}"
        );
        if steady {
            assert_no_rise_after_trial_3(&max_mm, &format!("line, σ = {sigma} m"));
        }
    }
}

#[test]
fn line_robust_reaches_a_micrometre_by_trial_5_and_stays() {
    let text = scenario_toml("line", 15.0, ROBUST, "", "");
    let max_mm = max_errors_mm(&run(&text, 20));
    assert!(
        max_mm[5..].iter().all(|&e| e <= 0.001),
        "above 0.001 mm from trial 5: {max_mm:?}"
    );
    assert_no_rise_after_trial_3(&max_mm, "line");
}

/// An update whose gain overflows makes the next trial's memory NaN: the master stops at the
/// end of that trial naming the channel, the settings and the first bad element. Before, the
/// NaN memory was kept as the trial's, and the next trial failed in the controller's
/// fmi2SetReal, naming neither the update nor the trial that made it.
#[test]
fn an_update_that_makes_the_memory_not_finite_stops_at_that_trial() {
    let update = format!("{ROBUST}gain = 1e308\n");
    let text = scenario_toml("circle", 0.2, &update, "", "");
    let (scenario, fmus) = Scenario::open_text(&text, Path::new("robust.toml")).unwrap();
    let mut master = Master::new(&scenario, fmus, false).unwrap();
    let mut signals = master.new_signals();
    let err = master.run_trial(0, None, &mut signals, |_| {}).unwrap_err();
    let message = err.to_string();
    assert!(
        matches!(
            &err,
            orchestrator::master::MasterError::UpdateNotFinite { trial: 0, variable, time, value, .. }
                if variable == "controller.memory[1]" && *time == 0.0 && value.is_nan()
        ),
        "{message}"
    );
    assert!(
        message.starts_with(
            "trial 0: the update of memory channel \"controller.memory\" ([memory.update]: \
             Butterworth order 4 cutoff 8 Hz (zero phase), lead δ = 25 samples, forgetting \
             α = 1, gain g = 1e308) made the next trial's memory not finite: \
             controller.memory[1] at t = 0 s is NaN"
        ),
        "{message}"
    );
    // The trial's own memory stays the one it read.
    assert!(master.memory()[0].iter().all(|&u| u == 0.0));
}
