//! The fixed-step integrator is the classic fourth-order Runge–Kutta method: halving the step
//! divides the global error by 2⁴ = 16. A mistaken stage still converges (at a lower order),
//! so agreement with another integrator at one step size does not show it; the error ratio
//! does. The adaptive integrator's Dormand–Prince pair is checked the same way: its
//! fifth-order solution at fixed steps, and its embedded error estimate through the steps a
//! tolerance takes. Also: a state with one non-finite component is not finite.

use ckcm::nalgebra::{Quaternion, UnitQuaternion, Vector6};
use ckcm::{DormandPrince, Friction, Mechanism, Params, Pose, Rk4, State};

fn frictionless() -> Mechanism {
    Mechanism::new(Params {
        friction: Friction::NONE,
        ..Params::default()
    })
    .unwrap()
}

/// A tumbling start at the home pose, and constant forces off the static ones.
fn tumbling_start(m: &Mechanism) -> (State, Vector6<f64>) {
    let tau =
        m.static_forces(&m.home()).unwrap() + Vector6::new(30.0, -20.0, 10.0, -25.0, 15.0, 5.0);
    let s = State {
        pose: m.home(),
        twist: Vector6::new(0.05, -0.04, 0.03, 1.2, -0.9, 1.5),
    };
    (s, tau)
}

/// State after `t` seconds from the tumbling start under its constant forces, with `n` RK4
/// steps, as [p, q coordinates, twist].
fn run(m: &Mechanism, t: f64, n: u32) -> [f64; 13] {
    let (mut s, tau) = tumbling_start(m);
    Rk4 {
        substeps: n,
        ..Rk4::default()
    }
    .advance(m, &mut s, &tau, t)
    .unwrap();
    flat(&s)
}

/// [p, q coordinates, twist].
fn flat(s: &State) -> [f64; 13] {
    let q = s.pose.q_world.as_ref().coords;
    let p = s.pose.p_world;
    let w = s.twist;
    [
        p.x, p.y, p.z, q[0], q[1], q[2], q[3], w[0], w[1], w[2], w[3], w[4], w[5],
    ]
}

fn distance(a: &[f64; 13], b: &[f64; 13]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn rk4_global_error_falls_sixteenfold_per_halving() {
    let m = frictionless();
    let t = 0.2;
    let y: Vec<[f64; 13]> = [5, 10, 20, 40].iter().map(|&n| run(&m, t, n)).collect();
    // Differences of successive solutions estimate the error of the coarser one.
    let d: Vec<f64> = y.windows(2).map(|w| distance(&w[0], &w[1])).collect();
    // The errors must stay far above rounding (1e-16 of O(1) values) for the ratio to mean
    // anything.
    assert!(d[2] > 1e-11, "errors too small to measure the order: {d:?}");
    for k in 0..2 {
        let ratio = d[k] / d[k + 1];
        // Fourth order: 16 in the limit; a second-order stage mistake gives about 4.
        assert!(
            (12.0..20.0).contains(&ratio),
            "error ratio {ratio} between {} and {} steps (differences {d:?})",
            5 << k,
            10 << k
        );
    }
}

#[test]
fn state_with_one_non_finite_component_is_not_finite() {
    let good = State {
        pose: Pose::from_xyz_euler(&[0.01, 0.02, 0.9, 0.1, -0.1, 0.2]),
        twist: Vector6::new(0.1, 0.2, 0.3, 0.4, 0.5, 0.6),
    };
    assert!(good.is_finite());
    for bad in [f64::NAN, f64::INFINITY] {
        for k in 0..6 {
            let mut s = good;
            s.twist[k] = bad;
            assert!(!s.is_finite(), "twist component {k} = {bad}");
        }
        let mut s = good;
        s.pose.p_world.y = bad;
        assert!(!s.is_finite(), "position y = {bad}");
        let mut c = good.pose.q_world.into_inner().coords;
        c[2] = bad;
        s = good;
        s.pose.q_world = UnitQuaternion::new_unchecked(Quaternion::from(c));
        assert!(!s.is_finite(), "quaternion = {bad}");
    }
}

/// `advance_within` checks every state an interval reaches before its end, in order, and
/// stops at the first refused one with its offset; checks that pass change nothing.
#[test]
fn states_inside_an_interval_are_checked_in_order() {
    use ckcm::{IntegrationError, Integrator, WorkspaceError};
    let m = frictionless();
    let tau = m.static_forces(&m.home()).unwrap() + Vector6::from_element(40.0);
    let start = State::at_rest(m.home());
    for mut integrator in [
        Integrator::Rk4(Rk4 {
            substeps: 8,
            ..Rk4::default()
        }),
        Integrator::DormandPrince(DormandPrince {
            h_next: 0.01,
            ..DormandPrince::default()
        }),
    ] {
        let mut plain = start;
        integrator
            .clone()
            .advance(&m, &mut plain, &tau, 0.08)
            .unwrap();
        // Every state before the end, seen in order; the interval's result is the same.
        let mut seen = Vec::new();
        let mut checked = start;
        integrator
            .clone()
            .advance_within(&m, &mut checked, &tau, 0.08, &mut |s: &State| {
                seen.push(s.pose.p_world.z);
                Ok(())
            })
            .unwrap();
        assert_eq!(checked, plain, "{integrator:?}");
        assert!(seen.len() >= 5, "{integrator:?}: {} states", seen.len());
        assert!(seen.windows(2).all(|w| w[1] > w[0]), "{seen:?}");
        assert!(*seen.last().unwrap() < plain.pose.p_world.z);
        // The third state refused: the error gives its offset, and the state is unchanged.
        let mut count = 0;
        let mut refused = start;
        let e = integrator
            .advance_within(&m, &mut refused, &tau, 0.08, &mut |s: &State| {
                count += 1;
                if count == 3 {
                    Err(WorkspaceError::BasePlane {
                        joint: 1,
                        z: s.pose.p_world.z,
                    })
                } else {
                    Ok(())
                }
            })
            .unwrap_err();
        assert_eq!(refused, start);
        match e {
            IntegrationError::Outside {
                offset,
                cause: WorkspaceError::BasePlane { z, .. },
            } => {
                assert!(offset > 0.0 && offset < 0.08, "{offset}");
                assert_eq!(z, seen[2]);
                match integrator {
                    Integrator::Rk4(_) => assert_eq!(offset, 0.08 / 8.0 * 3.0),
                    // The same steps over `offset` alone end on the refused state.
                    Integrator::DormandPrince(_) => {
                        let mut s = start;
                        DormandPrince {
                            h_next: 0.01,
                            ..DormandPrince::default()
                        }
                        .advance(&m, &mut s, &tau, offset)
                        .unwrap();
                        assert!((s.pose.p_world.z - z).abs() < 1e-12, "{offset}");
                    }
                }
            }
            other => panic!("{other:?}"),
        }
    }
}

/// The fixed-step Dormand–Prince solution of `run`'s problem with `n` steps: a tolerance no
/// error estimate reaches accepts every step, and a step proposal of at least the interval
/// makes each `advance` one step.
fn run_dormand_prince(m: &Mechanism, t: f64, n: u32) -> [f64; 13] {
    let (mut s, tau) = tumbling_start(m);
    let h = t / f64::from(n);
    let mut dp = DormandPrince {
        rtol: 1e6,
        atol: 1e6,
        h_next: h,
        ..DormandPrince::default()
    };
    for _ in 0..n {
        dp.advance(m, &mut s, &tau, h).unwrap();
        assert_eq!(dp.last_steps, 1, "the step of {h} s was split");
    }
    flat(&s)
}

/// Dormand–Prince's fifth-order weights: at fixed steps the global error falls by about
/// 2⁵ = 32 or more per halving of the step (the test asks for more than 28). A wrong
/// tableau entry breaks an order condition (a fourth-order method gives 16, most mistakes
/// far less), and the step control alone would hide it by shrinking the steps. On this
/// problem the errors at these steps still carry sixth-order terms: the ratios are 55, 62
/// and 68, approaching 32 only near rounding.
#[test]
fn dormand_prince_is_of_fifth_order_at_fixed_steps() {
    let m = frictionless();
    let t = 0.2;
    let reference = run_dormand_prince(&m, t, 2048);
    let e: Vec<f64> = [4, 8, 16, 32]
        .iter()
        .map(|&n| distance(&run_dormand_prince(&m, t, n), &reference))
        .collect();
    assert!(e[0] < 1e-4, "error {} with 4 steps of 50 ms", e[0]);
    assert!(e[3] > 1e-12, "errors too small to measure the order: {e:?}");
    for k in 0..3 {
        let ratio = e[k] / e[k + 1];
        assert!(
            ratio > 28.0,
            "error ratio {ratio} between {} and {} steps (errors {e:?})",
            4 << k,
            8 << k
        );
    }
}

/// The embedded error estimate is of fifth order in the step (a fourth-order pair), so a
/// tolerance 10⁵ times tighter takes about 10⁵ᐟ⁵ = 10 times the steps (8.2 here); and the
/// solution it accepts is as accurate as asked. A wrong error weight makes the estimate of lower
/// order (far more steps) or too small (a solution off by more than the tolerance).
#[test]
fn dormand_prince_error_estimate_is_fourth_order_and_honest() {
    let m = frictionless();
    let t = 0.2;
    let (start, tau) = tumbling_start(&m);
    let reference = run_dormand_prince(&m, t, 256);
    let solve = |tol: f64| {
        let mut s = start;
        let mut dp = DormandPrince {
            rtol: tol,
            atol: tol,
            h_next: t,
            ..DormandPrince::default()
        };
        dp.advance(&m, &mut s, &tau, t).unwrap();
        (dp.last_steps, distance(&flat(&s), &reference))
    };
    let (coarse_steps, coarse_error) = solve(1e-7);
    let (fine_steps, fine_error) = solve(1e-12);
    // The counts themselves (10 and 82 here): an error norm off by a constant factor moves
    // them by its fifth root.
    assert!(
        (8..=12).contains(&coarse_steps),
        "{coarse_steps} steps at 1e-7"
    );
    assert!(
        (66..=100).contains(&fine_steps),
        "{fine_steps} steps at 1e-12"
    );
    let ratio = fine_steps as f64 / coarse_steps as f64;
    assert!(
        (6.0..16.0).contains(&ratio),
        "{coarse_steps} steps at 1e-7, {fine_steps} at 1e-12: ratio {ratio}"
    );
    // The tolerance bounds each step's error; over the interval they add up to a few times
    // it (1.4 and 0.15 times here).
    assert!(
        coarse_error < 1e-6,
        "error {coarse_error} at tolerance 1e-7"
    );
    assert!(fine_error < 1e-11, "error {fine_error} at tolerance 1e-12");
}

/// RK4's substeps: at least `substeps`, and ⌈h / max_step⌉ where that is more; an interval
/// longer than `max_step` by a master's rounding alone is not split; a million substeps is
/// the most an interval may take.
#[test]
fn rk4_splits_an_interval_by_its_longest_substep() {
    let rk4 = |substeps, max_step| Rk4 { substeps, max_step };
    let n = |r: Rk4, h: f64| r.substeps_for(h).unwrap();
    assert_eq!(n(Rk4::default(), 0.001), 1);
    assert_eq!(n(Rk4::default(), 1e3), 1);
    assert_eq!(n(rk4(1, 0.002), 0.001), 1);
    assert_eq!(n(rk4(1, 0.002), 0.002), 1);
    assert_eq!(n(rk4(1, 0.002), 0.01), 5);
    assert_eq!(n(rk4(1, 0.002), 0.0101), 6);
    // Ten steps of 1 ms added up by a master: 0.010000000000000002.
    let summed: f64 = (0..10).map(|_| 0.001).sum();
    assert!(summed > 0.01);
    assert_eq!(n(rk4(1, 0.001), summed), 10);
    assert_eq!(n(rk4(1, 0.001), 0.01 * (1.0 + 1e-7)), 11);
    assert_eq!(n(rk4(8, 0.002), 0.01), 8);
    assert_eq!(n(rk4(3, 0.002), 0.01), 5);
    assert_eq!(n(rk4(0, f64::INFINITY), 0.001), 1);
    assert_eq!(n(rk4(2, 0.002), f64::NAN), 2);
    // Exactly a million substeps is allowed, one more is refused.
    assert_eq!(n(rk4(1, 1e-3), 1e3), 1_000_000);
    assert!(matches!(
        rk4(1, 1e-3).substeps_for(1e3 * (1.0 + 1e-6)),
        Err(ckcm::IntegrationError::TooManySubsteps { .. })
    ));
}

/// Dormand–Prince starts from the step it proposed last (`h_next`), takes a proposal short
/// of the interval by rounding alone as the interval, and allows `max_steps` steps but not
/// one more. With a tolerance no estimate reaches, every step is accepted and the next one
/// grows fivefold, so the counts are exact.
#[test]
fn dormand_prince_starts_from_its_proposal_and_counts_its_steps() {
    let m = frictionless();
    let (start, tau) = tumbling_start(&m);
    let h = 0.01;
    let advance = |h_next: f64, max_steps: usize| {
        let mut dp = DormandPrince {
            rtol: 1e6,
            atol: 1e6,
            h_next,
            max_steps,
            ..DormandPrince::default()
        };
        let mut s = start;
        dp.advance(&m, &mut s, &tau, h)
            .map(|()| (dp.last_steps, dp.h_next))
    };
    let steps = |h_next, max_steps| advance(h_next, max_steps).map(|(n, _)| n);
    // The next proposal: five times the last step that was not cut short, and never the
    // cut-short last step's.
    let proposal = |h_next: f64| advance(h_next, 10).unwrap().1;
    assert!((proposal(0.0) / (5.0 * h) - 1.0).abs() < 1e-12);
    assert!((proposal(h / 4.0) / (1.25 * h) - 1.0).abs() < 1e-12);
    // No proposal yet: the whole interval at once.
    assert_eq!(steps(0.0, 10), Ok(1));
    // A quarter of the interval, then five quarters, cut to the three left.
    assert_eq!(steps(h / 4.0, 10), Ok(2));
    assert_eq!(steps(h / 4.0, 2), Ok(2));
    assert_eq!(
        steps(h / 4.0, 1),
        Err(ckcm::IntegrationError::TooManySteps { max_steps: 1 })
    );
    // Short of the interval by 1e-13 of it: one step, not a second of 1e-15 s.
    assert_eq!(steps(h * (1.0 - 1e-13), 10), Ok(1));
}

/// A step the error control shrinks below `h_min` ends the interval with an error that
/// names where it stopped, rather than crawling on.
#[test]
fn dormand_prince_refuses_a_step_below_its_smallest() {
    let m = frictionless();
    let (mut s, tau) = tumbling_start(&m);
    let before = s;
    let mut dp = DormandPrince {
        rtol: 1e-12,
        atol: 1e-12,
        h_min: 0.01,
        h_next: 0.02,
        ..DormandPrince::default()
    };
    assert_eq!(
        dp.advance(&m, &mut s, &tau, 0.02),
        Err(ckcm::IntegrationError::StepTooSmall {
            h_min: 0.01,
            offset: 0.0
        })
    );
    assert_eq!(s, before);
}

/// A relative tolerance holds each component to its own size. Most of this state's
/// components are well under 1 (the position's x and y, the quaternion's vector part), so
/// a purely relative tolerance of 1e-9 asks more of them than an absolute one of 1e-9 and
/// takes more steps (36 against 26 here; a tolerance that grew as a component shrank would
/// take about as many).
#[test]
fn dormand_prince_relative_tolerance_scales_with_each_component() {
    let m = frictionless();
    let t = 0.2;
    let (start, tau) = tumbling_start(&m);
    let steps = |rtol, atol| {
        let mut s = start;
        let mut dp = DormandPrince {
            rtol,
            atol,
            h_next: t,
            ..DormandPrince::default()
        };
        dp.advance(&m, &mut s, &tau, t).unwrap();
        dp.last_steps as f64
    };
    let ratio = steps(1e-9, 0.0) / steps(0.0, 1e-9);
    assert!((1.25..2.0).contains(&ratio), "ratio {ratio}");
}
