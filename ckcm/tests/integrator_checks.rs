//! The fixed-step integrator is the classic fourth-order Runge–Kutta method: halving the step
//! divides the global error by 2⁴ = 16. A mistaken stage still converges (at a lower order),
//! so agreement with another integrator at one step size does not show it; the error ratio
//! does. Also: a state with one non-finite component is not finite.

use ckcm::nalgebra::{Quaternion, UnitQuaternion, Vector6};
use ckcm::{Friction, Mechanism, Params, Pose, Rk4, State};

fn frictionless() -> Mechanism {
    Mechanism::new(Params {
        friction: Friction::NONE,
        ..Params::default()
    })
    .unwrap()
}

/// State after `t` seconds from a tumbling start under constant forces, with `n` RK4 steps,
/// as [p, q coordinates, twist].
fn run(m: &Mechanism, t: f64, n: u32) -> [f64; 13] {
    let tau =
        m.static_forces(&m.home()).unwrap() + Vector6::new(30.0, -20.0, 10.0, -25.0, 15.0, 5.0);
    let mut s = State {
        pose: m.home(),
        twist: Vector6::new(0.05, -0.04, 0.03, 1.2, -0.9, 1.5),
    };
    Rk4 {
        substeps: n,
        ..Rk4::default()
    }
    .advance(m, &mut s, &tau, t)
    .unwrap();
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
    use ckcm::{DormandPrince, IntegrationError, Integrator, WorkspaceError};
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
                if let Integrator::Rk4(_) = integrator {
                    assert_eq!(offset, 0.08 / 8.0 * 3.0);
                }
            }
            other => panic!("{other:?}"),
        }
    }
}
