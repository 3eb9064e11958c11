//! Costs of co-simulation through the FMI 2.0 C ABI: one plant doStep (RK4 and adaptive
//! Dormand–Prince), one controller doStep, and the coupled 15 s line trial under the
//! orchestrator's `Master`, next to the same trial without FMI (`ckcm::closed_loop`) so the
//! FMI overhead ratio comes from one run on one machine state.
//!
//! Needs the packaged FMUs: `cargo xtask fmu`, then `cargo bench -p orchestrator --bench cosim`.
//! `CKCM_FMU_DIR` overrides where they are looked for (default `<workspace>/target/fmu`).
//! `CKCM_ALTERNATE=N` (N ≥ 1) also times N rounds of the two floors (one recording the
//! row a recorded trial stores, one keeping only the metrics' signals), the recorded and
//! the unrecorded trial back to back and prints the median ratios, each trial against the
//! floor doing the same work (filter `alternated_only` to run only those; BENCHMARKS.md,
//! rounds 22 and 58). With it, `CKCM_FMU_DIR_B` times a second
//! build's FMUs in the same rounds and prints their ratio to the first's (round 30).

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use ckcm::closed_loop::run_trial_with_table;
use ckcm::nalgebra::Vector6;
use ckcm::{ControlSettings, Hlcs, Integrator, Mechanism, Params, ReferenceTable, Trajectory};
use criterion::{Criterion, criterion_group, criterion_main};
use fmi2_import::{Fmu, Instance};
use orchestrator::master::{Master, TrialSignals};
use orchestrator::output::RecordedRows;
use orchestrator::scenario::Scenario;

/// Communication step, s.
const H: f64 = 1e-3;
/// Steps of a 15 s trial (the controller's default duration).
const TRIAL_STEPS: u64 = 15_000;
/// Legs, and so the width of every array variable of both FMUs.
const LEGS: usize = 6;

/// `$CKCM_FMU_DIR/<name>.fmu`, else `<workspace>/target/fmu/<name>.fmu`.
fn fmu_path(name: &str) -> PathBuf {
    let dir = std::env::var_os("CKCM_FMU_DIR").map_or_else(
        || Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/fmu"),
        PathBuf::from,
    );
    fmu_path_in(&dir, name)
}

/// `<dir>/<name>.fmu`, canonical.
fn fmu_path_in(dir: &Path, name: &str) -> PathBuf {
    let path = dir.join(format!("{name}.fmu"));
    assert!(
        path.is_file(),
        "{} is missing: run cargo xtask fmu (or set CKCM_FMU_DIR)",
        path.display()
    );
    std::fs::canonicalize(&path).expect("an existing file has a canonical path")
}

fn open(name: &str) -> Fmu {
    Fmu::open(fmu_path(name)).unwrap_or_else(|e| panic!("cannot open {name}.fmu: {e}"))
}

/// Value references of `base[1]` .. `base[6]`.
fn array_vrs(fmu: &Fmu, base: &str) -> [u32; LEGS] {
    std::array::from_fn(|i| {
        let name = format!("{base}[{}]", i + 1);
        fmu.model_description()
            .variable_by_name(&name)
            .unwrap_or_else(|| panic!("no variable {name}"))
            .value_reference
    })
}

fn vr(fmu: &Fmu, name: &str) -> u32 {
    fmu.model_description()
        .variable_by_name(name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .value_reference
}

/// An instance in step mode at t = 0, after `configure` set its parameters.
fn started(fmu: &Fmu, name: &str, configure: impl FnOnce(&mut Instance)) -> Instance {
    let mut inst = fmu.instantiate(name, false).expect("instantiate");
    configure(&mut inst);
    inst.setup_experiment(None, 0.0, None).expect("setup");
    inst.enter_initialization_mode().expect("enter init");
    inst.exit_initialization_mode().expect("exit init");
    inst
}

/// One plant doStep with its I/O, as a master calls it: set the six forces, step 1 ms, read
/// all 18 outputs. The forces come from a stiff PD law towards leg lengths oscillating ±5 mm
/// about home, so the platform keeps moving (a plant at rest would flatter the adaptive
/// integrator) and stays bounded however many iterations criterion runs.
fn plant_step(c: &mut Criterion) {
    let fmu = open("CkcmPlant");
    let force = array_vrs(&fmu, "force");
    let outputs: Vec<u32> = ["length", "velocity", "pose"]
        .iter()
        .flat_map(|b| array_vrs(&fmu, b))
        .collect();
    let mech = Mechanism::new(Params::default()).expect("default parameters are valid");
    let hold = mech
        .static_forces(&mech.home())
        .expect("home is not singular");
    let l_home = mech.inverse_kinematics(&mech.home()).length;
    let integrator = vr(&fmu, "integrator");
    let rtol = vr(&fmu, "relative_tolerance");
    let mut g = c.benchmark_group("plant_do_step");
    for (label, adaptive) in [("rk4", false), ("dormand_prince_1e-8", true)] {
        let mut inst = started(&fmu, "plant", |inst| {
            if adaptive {
                inst.set_integer(&[integrator], &[2])
                    .expect("set integrator");
                inst.set_real(&[rtol], &[1e-8])
                    .expect("set relative_tolerance");
            }
        });
        let mut y = [0.0; 3 * LEGS];
        inst.get_real(&outputs, &mut y).expect("get outputs");
        let mut n = 0u64;
        g.bench_function(label, |b| {
            b.iter(|| {
                let t = n as f64 * H;
                let wobble = 0.005 * (std::f64::consts::TAU * t).sin();
                let f: [f64; LEGS] = std::array::from_fn(|i| {
                    hold[i] + 5e4 * (l_home[i] + wobble - y[i]) - 850.0 * y[LEGS + i]
                });
                inst.set_real(&force, &f).expect("set force");
                inst.do_step(t, H, true).expect("plant step");
                inst.get_real(&outputs, &mut y).expect("get outputs");
                n += 1;
                black_box(&y);
            })
        });
    }
    g.finish();
}

/// One controller doStep with its I/O: set length, velocity and memory, step, read force and
/// memory_next. Line trajectory with learning on (the defaults). Time wraps into a 15 s trial
/// (fmi2Reset and initialisation, as a master starts the next one, every 15 000 steps): past
/// the trajectory's end the law computes its reference terms afresh instead of looking them
/// up, which no trial does.
fn controller_step(c: &mut Criterion) {
    let fmu = open("HlcsController");
    let inputs: Vec<u32> = ["length", "velocity", "memory"]
        .iter()
        .flat_map(|b| array_vrs(&fmu, b))
        .collect();
    let outputs: Vec<u32> = ["force", "memory_next"]
        .iter()
        .flat_map(|b| array_vrs(&fmu, b))
        .collect();
    let mech = Mechanism::new(Params::default()).expect("default parameters are valid");
    let l_home = mech.inverse_kinematics(&mech.home()).length;
    let mut u = [0.0; 3 * LEGS];
    u[..LEGS].copy_from_slice(l_home.as_slice());
    u[2 * LEGS..].fill(1.0);
    let mut y = [0.0; 2 * LEGS];
    let mut inst = started(&fmu, "controller", |_| {});
    let mut n = 0u64;
    c.bench_function("controller_do_step", |b| {
        b.iter(|| {
            if n == TRIAL_STEPS {
                inst.reset().expect("reset");
                inst.setup_experiment(None, 0.0, None).expect("setup");
                inst.enter_initialization_mode().expect("enter init");
                inst.exit_initialization_mode().expect("exit init");
                n = 0;
            }
            let t = n as f64 * H;
            inst.set_real(&inputs, black_box(&u)).expect("set inputs");
            inst.do_step(t, H, true).expect("controller step");
            inst.get_real(&outputs, &mut y).expect("get outputs");
            n += 1;
            black_box(&y);
        })
    });
}

/// The coupled scenario of `scenarios/line-hlcs.toml` (15 s line, HLCS, everything recorded
/// at every sample, metrics on), with the absolute paths of `controller` and `plant`.
fn line_scenario_toml(controller: &Path, plant: &Path) -> String {
    format!(
        r#"
step_size = 0.001
stop_time = 15.0
trials = 2

[[fmu]]
name = "controller"
path = "{controller}"
[fmu.parameters]
trajectory = "line"
duration = 15.0
learning = true
psi = 7.5

[[fmu]]
name = "plant"
path = "{plant}"

[[connection]]
from = "plant.length"
to = "controller.length"

[[connection]]
from = "plant.velocity"
to = "controller.velocity"

[[connection]]
from = "controller.force"
to = "plant.force"

[[memory]]
from = "controller.memory_next"
to = "controller.memory"

[record]
variables = ["controller.error", "controller.force", "controller.memory_next", "plant.length", "plant.pose"]
interval = 1

[metrics]
error = "controller.error"
rho = 1.0
pose = "plant.pose"
trajectory = {{ kind = "line", duration = 15.0, home_height = 0.5 }}
"#,
        controller = controller.display(),
        plant = plant.display(),
    )
}

/// The line scenario with the FMUs of `controller` and `plant`.
fn line_scenario(controller: &Path, plant: &Path) -> (Scenario, Vec<Fmu>) {
    let text = line_scenario_toml(controller, plant);
    Scenario::open_text(&text, Path::new("bench-line.toml")).expect("valid scenario")
}

/// Runs trial 0 and returns what trial 1 needs: a recording, signals and the iteration
/// memory trial 0 learned.
fn prime(master: &mut Master) -> (RecordedRows, TrialSignals, Vec<Vec<f64>>) {
    let mut recording = master.new_recording();
    let mut signals = master.new_signals();
    master
        .run_trial(0, Some(&mut recording), &mut signals, |_| {})
        .expect("trial 0");
    let learned: Vec<Vec<f64>> = master.memory().iter().map(|m| m.to_vec()).collect();
    assert!(
        learned.iter().flatten().any(|&u| u != 0.0),
        "trial 0 learned nothing"
    );
    (recording, signals, learned)
}

/// Trial 1 from `learned`, timed without the memory's restore: restoring copies 720 kB that
/// `run_trial` itself never copies (it swaps its read and write buffers between trials).
fn timed_trial(
    master: &mut Master,
    learned: &[Vec<f64>],
    recording: Option<&mut RecordedRows>,
    signals: &mut TrialSignals,
) -> Duration {
    master.set_memory(learned);
    let start = Instant::now();
    master
        .run_trial(1, recording, signals, |_| {})
        .expect("trial 1");
    start.elapsed()
}

/// Trial ≥ 1 of the 15 s line through the orchestrator's `Master` and through the FMI-free
/// loop. Both restore the memory trial 0 learned before every iteration, so every sample
/// times the same (non-zero-memory) trial.
fn line_trial(c: &mut Criterion) {
    let (scenario, fmus) = line_scenario(&fmu_path("HlcsController"), &fmu_path("CkcmPlant"));
    let mut master = Master::new(&scenario, fmus, false).expect("master");
    let (mut recording, mut signals, learned) = prime(&mut master);

    let plant = Mechanism::new(Params::default()).expect("default parameters are valid");
    let nominal = Mechanism::new(Params::nominal()).expect("nominal parameters are valid");
    let trajectory = Trajectory::line(plant.params.geometry.home_height);
    let steps = scenario.steps;
    // The controller FMU tabulates its reference terms once per parameter set and reuses
    // them in every trial; the floor does the same, so the ratio still measures FMI alone.
    let table = ReferenceTable::new(&nominal, &trajectory, 0.0, H);
    // The floor produces what the orchestrator trial records at every sample: leg errors,
    // forces, next memory, measured lengths and the pose (Euler angles), into storage
    // allocated once, so the ratio measures the FMI layer and nothing else. It also keeps
    // what `Master` keeps in every trial for the metrics, in the same `TrialSignals`: the
    // time, reference − true length of each leg (true lengths: the floor has no sensor
    // noise) and the position (BENCHMARKS.md, round 35).
    let mut floor_record: Vec<[f64; 30]> = Vec::with_capacity(steps);
    let mut floor_signals = master.new_signals();
    let mut floor =
        |read: &[Vector6<f64>], write: &mut [Vector6<f64>], floor_signals: &mut TrialSignals| {
            let mut controller = Hlcs::new(nominal, ControlSettings::default());
            let mut integrator = Integrator::default();
            floor_record.clear();
            floor_signals.clear();
            run_trial_with_table(
                &plant,
                &mut integrator,
                &mut controller,
                &trajectory,
                H,
                Some(&table),
                read,
                write,
                |n, state, input, out| {
                    let error = out.length_ref - input.length;
                    floor_signals.error.push(error.into());
                    let p = state.pose.p_world;
                    floor_signals.position.push([p.x, p.y, p.z]);
                    floor_signals.time.push(n as f64 * H);
                    let mut row = [0.0; 30];
                    row[0..6].copy_from_slice(out.error.as_slice());
                    row[6..12].copy_from_slice(out.force.as_slice());
                    row[12..18].copy_from_slice(out.memory_next.as_slice());
                    row[18..24].copy_from_slice(input.length.as_slice());
                    row[24..30].copy_from_slice(&state.pose.to_xyz_euler());
                    floor_record.push(row);
                },
            )
            .expect("the line trial runs")
        };
    // The floor an unrecorded `Master` trial is judged against: the same trial keeping only
    // the metrics' signals, so neither side computes the pose's angles or stores a row.
    // Written out beside the recording floor rather than through a shared helper: round 58
    // measured these two closures, and a helper tried later could not be shown not to slow
    // the recording floor, which would flatter the ratio.
    let floor_unrecorded =
        |read: &[Vector6<f64>], write: &mut [Vector6<f64>], floor_signals: &mut TrialSignals| {
            let mut controller = Hlcs::new(nominal, ControlSettings::default());
            let mut integrator = Integrator::default();
            floor_signals.clear();
            run_trial_with_table(
                &plant,
                &mut integrator,
                &mut controller,
                &trajectory,
                H,
                Some(&table),
                read,
                write,
                |n, state, input, out| {
                    let error = out.length_ref - input.length;
                    floor_signals.error.push(error.into());
                    let p = state.pose.p_world;
                    floor_signals.position.push([p.x, p.y, p.z]);
                    floor_signals.time.push(n as f64 * H);
                },
            )
            .expect("the line trial runs")
        };
    let mut floor_memory = vec![Vector6::zeros(); steps];
    let mut floor_next = vec![Vector6::zeros(); steps];
    floor(
        &vec![Vector6::zeros(); steps],
        &mut floor_memory,
        &mut floor_signals,
    );
    // The same trial 0 as `Master`'s, sample by sample: the floor keeps the same signals.
    assert!(
        floor_signals == signals,
        "the floor's trial 0 differs from Master's"
    );
    let mut learned_unrecorded = vec![Vector6::zeros(); steps];
    floor_unrecorded(
        &vec![Vector6::zeros(); steps],
        &mut learned_unrecorded,
        &mut floor_signals,
    );
    assert!(
        floor_signals == signals && learned_unrecorded == floor_memory,
        "the unrecorded floor's trial 0 differs from the recording floor's"
    );

    let mut g = c.benchmark_group("line_trial_15s");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    let mut timed = |recorded: bool| {
        timed_trial(
            &mut master,
            &learned,
            recorded.then_some(&mut recording),
            &mut signals,
        )
    };
    g.bench_function("orchestrator", |b| {
        b.iter_custom(|iters| (0..iters).map(|_| timed(true)).sum())
    });
    // The same trial recording nothing (the metrics' signals are still kept): what
    // recording every signal at every sample costs `Master`, next to the FMI layer itself.
    g.bench_function("orchestrator_unrecorded", |b| {
        b.iter_custom(|iters| (0..iters).map(|_| timed(false)).sum())
    });
    g.bench_function("floor", |b| {
        b.iter(|| {
            floor(
                black_box(&floor_memory),
                &mut floor_next,
                &mut floor_signals,
            )
        })
    });
    g.bench_function("floor_unrecorded", |b| {
        b.iter(|| {
            floor_unrecorded(
                black_box(&floor_memory),
                &mut floor_next,
                &mut floor_signals,
            )
        })
    });
    g.finish();

    // The ratios trial by trial, for `CKCM_ALTERNATE=N`: criterion times each benchmark for
    // 10 s after the other, and a shared machine drifts by more than the 10 % the FMI
    // overhead target leaves between them. Here each round times all the trials back to
    // back, in an order that rotates, and the ratios are taken within a round.
    let Ok(text) = std::env::var("CKCM_ALTERNATE") else {
        return;
    };
    // A mistyped count must not look like a run that measured nothing.
    let rounds = text
        .parse::<usize>()
        .ok()
        .filter(|&n| n > 0)
        .unwrap_or_else(|| panic!("CKCM_ALTERNATE={text:?}: expected a positive number of rounds"));
    // `CKCM_FMU_DIR_B`: a second build's FMUs, timed in the same rounds, so that a change is
    // judged against its base within one run of a shared machine, not across runs.
    let dir_b = std::env::var_os("CKCM_FMU_DIR_B").map(PathBuf::from);
    let (scenario_b, fmus_b) = dir_b
        .as_ref()
        .map(|dir| {
            line_scenario(
                &fmu_path_in(dir, "HlcsController"),
                &fmu_path_in(dir, "CkcmPlant"),
            )
        })
        .unzip();
    let mut master_b = scenario_b
        .as_ref()
        .zip(fmus_b)
        .map(|(sc, fmus)| Master::new(sc, fmus, false).expect("master of build B"));
    let mut primed_b = master_b.as_mut().map(prime);
    // Trials of a round: each floor, then each `Master` trial. A trial is judged against the
    // floor that does the same work besides FMI: recorded against the floor that records the
    // same row, unrecorded against the floor that keeps only the metrics' signals.
    #[derive(Clone, Copy, PartialEq)]
    enum Kind {
        Floor { recorded: bool },
        Master { recorded: bool, build_b: bool },
    }
    let mut kinds = vec![
        Kind::Floor { recorded: true },
        Kind::Floor { recorded: false },
    ];
    let builds: &[bool] = if master_b.is_some() {
        &[false, true]
    } else {
        &[false]
    };
    for &build_b in builds {
        for recorded in [true, false] {
            kinds.push(Kind::Master { recorded, build_b });
        }
    }
    let index = |kind: Kind| kinds.iter().position(|&k| k == kind).expect("a timed kind");
    let mut times = vec![Vec::with_capacity(rounds); kinds.len()];
    for round in 0..rounds {
        for k in 0..kinds.len() {
            let which = (round + k) % kinds.len();
            let start = Instant::now();
            let elapsed = match kinds[which] {
                Kind::Floor { recorded: true } => {
                    floor(
                        black_box(&floor_memory),
                        &mut floor_next,
                        &mut floor_signals,
                    );
                    start.elapsed()
                }
                Kind::Floor { recorded: false } => {
                    floor_unrecorded(
                        black_box(&floor_memory),
                        &mut floor_next,
                        &mut floor_signals,
                    );
                    start.elapsed()
                }
                Kind::Master {
                    recorded,
                    build_b: false,
                } => timed(recorded),
                Kind::Master {
                    recorded,
                    build_b: true,
                } => {
                    let (rec, sig, learned_b) = primed_b.as_mut().expect("build B is primed");
                    let m = master_b.as_mut().expect("build B is loaded");
                    timed_trial(m, learned_b, recorded.then_some(rec), sig)
                }
            };
            times[which].push(elapsed.as_secs_f64() * 1e3);
        }
    }
    let median = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // Per round, trial `a` over trial `b`: the host's drift between rounds cancels.
    let ratio = |a: Kind, b: Kind| {
        let per_round: Vec<f64> = times[index(a)]
            .iter()
            .zip(&times[index(b)])
            .map(|(a, b)| a / b)
            .collect();
        median(&per_round)
    };
    let floor_of = |recorded| Kind::Floor { recorded };
    let master = |recorded, build_b| Kind::Master { recorded, build_b };
    println!(
        "line_trial_15s alternated, {rounds} rounds: floor median {:.2} ms recording, {:.2} ms \
         unrecorded; Master / floor median {:.3} recorded, {:.3} unrecorded (against the \
         recording floor: {:.3})",
        median(&times[index(floor_of(true))]),
        median(&times[index(floor_of(false))]),
        ratio(master(true, false), floor_of(true)),
        ratio(master(false, false), floor_of(false)),
        ratio(master(false, false), floor_of(true)),
    );
    if let Some(dir) = dir_b {
        println!(
            "  build B ({}): Master / floor median {:.3} recorded, {:.3} unrecorded; \
             B / A median {:.4} recorded, {:.4} unrecorded",
            dir.display(),
            ratio(master(true, true), floor_of(true)),
            ratio(master(false, true), floor_of(false)),
            ratio(master(true, true), master(true, false)),
            ratio(master(false, true), master(false, false)),
        );
    }
}

criterion_group!(benches, plant_step, controller_step, line_trial);
criterion_main!(benches);
