//! The friction law with either Coulomb smoothing curve (docs/model.md §3) enters the
//! dynamics as a force that only removes energy: along a free motion under constant
//! actuator forces, the total energy T + V − τ·l falls by exactly the work of the friction
//! forces, ∫ f(l̇)·l̇ dt ≤ 0, integrated here independently of the integrator.

use ckcm::nalgebra::Vector6;
use ckcm::{Friction, FrictionCurve, Mechanism, Params, Rk4, State};

fn plant(curve: FrictionCurve) -> Mechanism {
    Mechanism::new(Params {
        friction: Friction {
            curve,
            ..Friction::default()
        },
        ..Params::default()
    })
    .unwrap()
}

/// T + V − τ·l for constant forces τ (the potential of a constant load is −τ·l).
fn total_energy(m: &Mechanism, s: &State, tau: &Vector6<f64>) -> f64 {
    let l = m.inverse_kinematics(&s.pose).length;
    m.kinetic_energy(&s.pose, &s.twist) + m.potential_energy(&s.pose) - tau.dot(&l)
}

/// Power of the friction forces, W (never positive).
fn friction_power(m: &Mechanism, s: &State) -> f64 {
    let ldot = m.inverse_kinematics(&s.pose).leg_rates(&s.twist);
    m.friction(&ldot).dot(&ldot)
}

/// Runs 0.3 s from home with a twist whose leg rates sweep through the friction curve's
/// knee (|l̇| from 0 to several v_s); returns the energy lost, the friction work by
/// Simpson's rule over the step ends, and the final state.
fn coast(m: &Mechanism) -> (f64, f64, State) {
    let tau = m.static_forces(&m.home()).unwrap();
    let mut s = State {
        pose: m.home(),
        twist: Vector6::new(0.04, -0.03, 0.0335, 0.2, -0.15, 0.16),
    };
    let h = 2.5e-4;
    let n = 1200;
    let e0 = total_energy(m, &s, &tau);
    let mut last = e0;
    let mut power = vec![friction_power(m, &s)];
    let rk = Rk4::default();
    for k in 0..n {
        rk.advance(m, &mut s, &tau, h).unwrap();
        let e = total_energy(m, &s, &tau);
        // RK4's truncation over one step is ~1e-16 J here; friction removes far more
        // while the legs move.
        assert!(
            e <= last + 1e-12,
            "{:?}: energy rose by {:e} J in step {k}",
            m.params.friction.curve,
            e - last
        );
        last = e;
        power.push(friction_power(m, &s));
    }
    assert!(
        power.iter().all(|&p| p <= 0.0),
        "friction did positive work"
    );
    let work = h / 3.0
        * power
            .iter()
            .enumerate()
            .map(|(i, p)| match i {
                0 => *p,
                i if i == n => *p,
                i if i % 2 == 1 => 4.0 * p,
                _ => 2.0 * p,
            })
            .sum::<f64>();
    (last - e0, work, s)
}

#[test]
fn energy_lost_equals_friction_work_for_either_curve() {
    let mut finals = Vec::new();
    for curve in [FrictionCurve::Tanh, FrictionCurve::Algebraic] {
        let m = plant(curve);
        let (de, work, s) = coast(&m);
        // Measured: ΔE = −0.05511 J (tanh), −0.05517 J (algebraic), nearly all the kinetic
        // energy; the balance holds to 2.7e-8 and 2.0e-8 relative (Simpson's rule at
        // h = 0.25 ms), so 1e-6 leaves ~40x while a friction force the dynamics use but
        // the power does not (or the reverse) breaks it by far more.
        assert!(de < -0.02, "{curve:?}: only {de} J dissipated");
        assert!(
            ((de - work) / work).abs() < 1e-6,
            "{curve:?}: ΔE = {de} J, friction work {work} J"
        );
        finals.push((de, s));
    }
    // The curves are different models: the same start ends elsewhere, having lost
    // another amount of energy (measured: 5.8e-5 J and 6.3e-5 m apart, against a balance
    // residual of ~1.5e-9 J).
    let (tanh, algebraic) = (&finals[0], &finals[1]);
    assert!(
        (tanh.0 - algebraic.0).abs() > 1e-5,
        "ΔE {} vs {} J",
        tanh.0,
        algebraic.0
    );
    assert!((tanh.1.pose.p_world - algebraic.1.pose.p_world).norm() > 1e-5);
}
