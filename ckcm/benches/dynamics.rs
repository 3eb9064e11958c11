//! Costs of the mechanism maths the FMUs are built on: one forward-dynamics evaluation
//! (M, b, Cholesky solve), one inverse-dynamics evaluation (the controller's feedforward),
//! one 1 ms integration step, and the FMI-free coupled line trial (the floor the
//! co-simulation is compared against in BENCHMARKS.md). `forward_dynamics_chains` compares
//! one chain of dependent evaluations with two chains run alternately, per evaluation: if
//! two cost less, a second evaluation fills idle units and reordering the RK4 stages could
//! pay (the pose of stage s + 1 does not need stage s's acceleration; BENCHMARKS.md, rounds
//! 18 and 40).
//!
//! Run: `cargo bench -p ckcm --bench dynamics`.

use std::hint::black_box;
use std::time::Duration;

use ckcm::closed_loop::run_trial_with_table;
use ckcm::nalgebra::Vector6;
use ckcm::{
    ControlSettings, DormandPrince, FrictionCurve, Hlcs, Integrator, Mechanism, Params, Pose,
    ReferenceTable, Rk4, State, Trajectory,
};
use criterion::{Criterion, Throughput, criterion_group, criterion_main};

/// Communication step, s.
const H: f64 = 1e-3;

/// A state away from every symmetry of the home pose: displaced, tilted about all three axes
/// and moving, so no term of M or b vanishes and the timings are not flattered.
fn busy_state() -> State {
    State {
        pose: Pose::from_xyz_euler(&[0.03, -0.02, 0.55, 0.05, -0.04, 0.03]),
        twist: Vector6::new(0.05, -0.03, 0.04, 0.2, -0.1, 0.15),
    }
}

fn plant() -> Mechanism {
    Mechanism::new(Params::default()).expect("default parameters are valid")
}

/// Static forces at home, so an integration step starts near equilibrium yet moves.
fn holding_force(mech: &Mechanism) -> Vector6<f64> {
    mech.static_forces(&mech.home())
        .expect("home is not singular")
}

fn evaluations(c: &mut Criterion) {
    let mech = plant();
    let nominal = Mechanism::new(Params::nominal()).expect("nominal parameters are valid");
    let state = busy_state();
    let tau = holding_force(&mech);
    let accel = Vector6::new(0.1, 0.2, -0.1, 0.3, -0.2, 0.1);
    // The default model, and the same evaluation with the cheaper Coulomb smoothing (a model
    // change, docs/model.md §3).
    let mut algebraic = Params::default();
    algebraic.friction.curve = FrictionCurve::Algebraic;
    let algebraic = Mechanism::new(algebraic).expect("default parameters are valid");
    for (name, m) in [
        ("forward_dynamics", &mech),
        ("forward_dynamics_algebraic_friction", &algebraic),
    ] {
        c.bench_function(name, |b| {
            b.iter(|| {
                m.forward_dynamics(
                    black_box(&state.pose),
                    black_box(&state.twist),
                    black_box(&tau),
                )
                .expect("regular state")
            })
        });
    }
    c.bench_function("inverse_dynamics", |b| {
        b.iter(|| {
            nominal
                .inverse_dynamics(
                    black_box(&state.pose),
                    black_box(&state.twist),
                    black_box(&accel),
                )
                .expect("regular state")
        })
    });
}

/// Evaluations whose pose and twist depend on the acceleration of the one before, one chain
/// or two run alternately; the throughput is per evaluation.
fn evaluation_chains(c: &mut Criterion) {
    let mech = plant();
    let tau = holding_force(&mech);
    let start = [
        busy_state(),
        State {
            pose: Pose::from_xyz_euler(&[0.02, -0.01, 0.56, 0.04, -0.03, 0.02]),
            twist: Vector6::new(0.04, -0.02, 0.03, 0.1, -0.2, 0.1),
        },
    ];
    // The next state is the start plus the acceleration times zero: the processor must wait
    // for the evaluation before it, but the state stays where it started (the products are
    // zero for a finite acceleration), so every evaluation does the same work.
    let next = |s: &mut State, from: &State| {
        let accel = mech
            .forward_dynamics(&s.pose, &s.twist, &tau)
            .expect("regular state");
        s.twist = from.twist + accel * 0.0;
        s.pose.p_world.x = from.pose.p_world.x + accel[0] * 0.0;
    };
    let mut g = c.benchmark_group("forward_dynamics_chains");
    g.throughput(Throughput::Elements(1));
    g.bench_function("one", |b| {
        let mut s = black_box(start[0]);
        b.iter(|| next(&mut s, &start[0]))
    });
    g.throughput(Throughput::Elements(2));
    g.bench_function("two", |b| {
        let [mut a, mut z] = black_box(start);
        b.iter(|| {
            next(&mut a, &start[0]);
            next(&mut z, &start[1]);
        })
    });
    g.finish();
}

fn integration(c: &mut Criterion) {
    let mech = plant();
    let tau = holding_force(&mech);
    let start = busy_state();
    let mut g = c.benchmark_group("advance_1ms");
    // Each iteration restarts from the same state, so every sample times the same step.
    g.bench_function("rk4", |b| {
        let mut integ = Integrator::Rk4(Rk4::default());
        b.iter(|| {
            let mut s = start;
            integ
                .advance(&mech, &mut s, black_box(&tau), H)
                .expect("regular state");
            s
        })
    });
    g.bench_function("dormand_prince_1e-8", |b| {
        // Start every iteration with the step size a first call settled on, as in the
        // middle of a long run (only a run's first interval searches for it).
        let mut warm = DormandPrince::default();
        let mut s = start;
        warm.advance(&mech, &mut s, &tau, H).expect("regular state");
        b.iter(|| {
            let mut integ = Integrator::DormandPrince(warm);
            let mut s = start;
            integ
                .advance(&mech, &mut s, black_box(&tau), H)
                .expect("regular state");
            s
        })
    });
    g.finish();
}

/// The paper's 15 s line under HLCS, trial ≥ 1: the memory is the one trial 0 learned,
/// restored before every iteration so each sample times identical work.
fn floor_trial(c: &mut Criterion) {
    let mech = plant();
    let nominal = Mechanism::new(Params::nominal()).expect("nominal parameters are valid");
    let trajectory = Trajectory::line(mech.params.geometry.home_height);
    let steps = (trajectory.duration / H).round() as usize;
    let zero = vec![Vector6::zeros(); steps];
    let mut memory = vec![Vector6::zeros(); steps];
    let mut next = vec![Vector6::zeros(); steps];
    // The reference terms once for every trial, as the controller FMU does.
    let table = ReferenceTable::new(&nominal, &trajectory, 0.0, H);
    let run = |read: &[Vector6<f64>], write: &mut [Vector6<f64>]| {
        let mut controller = Hlcs::new(nominal, ControlSettings::default());
        let mut integrator = Integrator::default();
        run_trial_with_table(
            &mech,
            &mut integrator,
            &mut controller,
            &trajectory,
            H,
            Some(&table),
            read,
            write,
            |_, _, _, _| {},
        )
        .expect("the line trial runs")
    };
    run(&zero, &mut memory);
    assert!(
        memory.iter().any(|u| u.norm() > 0.0),
        "trial 0 learned nothing"
    );
    // Not named like the orchestrator's `line_trial_15s/floor`: criterion keeps its baselines
    // under target/criterion by name, and the two would overwrite each other's.
    let mut g = c.benchmark_group("closed_loop");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    g.bench_function("line_trial_15s", |b| {
        b.iter(|| run(black_box(&memory), &mut next))
    });
    g.finish();
}

criterion_group!(
    benches,
    evaluations,
    evaluation_chains,
    integration,
    floor_trial
);
criterion_main!(benches);
