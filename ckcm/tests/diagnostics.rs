//! Failures of the dynamics name their actual cause (issue 11, defect 8): a diverged state
//! or overflowing forces are not reported as a mass matrix that is not positive definite.

use ckcm::nalgebra::Vector6;
use ckcm::{DynamicsError, IntegrationError, Integrator, Mechanism, Params, Rk4, State};

fn mechanism() -> Mechanism {
    Mechanism::new(Params::default()).unwrap()
}

#[test]
fn non_finite_state_is_named_as_such() {
    let m = mechanism();
    let mut pose = m.home();
    pose.p_world.z = f64::NAN;
    let e = m
        .forward_dynamics(&pose, &Vector6::zeros(), &Vector6::zeros())
        .unwrap_err();
    assert_eq!(e, DynamicsError::NonFiniteState);
    let twist = Vector6::from_element(f64::INFINITY);
    let e = m
        .forward_dynamics(&m.home(), &twist, &Vector6::zeros())
        .unwrap_err();
    assert_eq!(e, DynamicsError::NonFiniteState);
    assert!(e.to_string().contains("not finite"), "{e}");
}

#[test]
fn overflowing_forces_are_named_as_such() {
    let m = mechanism();
    let tau = Vector6::from_element(1e308);
    let e = m
        .forward_dynamics(&m.home(), &Vector6::zeros(), &tau)
        .unwrap_err();
    assert_eq!(e, DynamicsError::NonFiniteAcceleration);
    assert!(e.to_string().contains("forces overflow"), "{e}");
    // Gravity that overflows the same way (the FMUs bound it, the library does not).
    let mut p = Params::default();
    p.set_field("gravity", 1e308).unwrap();
    let heavy = Mechanism::new(p).unwrap();
    let e = heavy
        .forward_dynamics(&heavy.home(), &Vector6::zeros(), &Vector6::zeros())
        .unwrap_err();
    assert_eq!(e, DynamicsError::NonFiniteAcceleration, "{e}");
}

#[test]
fn a_blown_up_integration_is_not_a_singular_mass_matrix() {
    let m = mechanism();
    let mut state = State::at_rest(m.home());
    let mut rk4 = Integrator::Rk4(Rk4::default());
    let tau = Vector6::from_element(1e300);
    let e = rk4.advance(&m, &mut state, &tau, 1e-3).unwrap_err();
    assert!(
        !matches!(e, IntegrationError::Dynamics(DynamicsError::SingularMass)),
        "{e}"
    );
    assert!(!e.to_string().contains("positive definite"), "{e}");
    // The state is left as it was.
    assert_eq!(state.pose, m.home());
}
