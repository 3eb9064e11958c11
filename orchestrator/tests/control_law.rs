//! The packaged FMUs against quantities computed here, independently of their code paths:
//! the controller's law mid-trajectory (where the reference acceleration is not zero) term by
//! term against `ckcm`'s inverse dynamics and a hand-written reference, the learning update
//! `memory_next` term by term, the static hold forces of the independent reference model,
//! and the plant's initial pose.

mod common;

use ckcm::nalgebra::Vector6;
use ckcm::{Mechanism, Params, Pose};
use fmi2_import::{Fmu, Instance};

fn open(name: &str) -> Fmu {
    Fmu::open(common::built_fmu(name)).unwrap()
}

fn vr(f: &Fmu, name: &str) -> u32 {
    f.model_description()
        .variable_by_name(name)
        .unwrap_or_else(|| panic!("no variable {name}"))
        .value_reference
}

/// The value of the `Trajectory` item `name`, from the model description.
fn item(f: &Fmu, name: &str) -> i32 {
    f.model_description()
        .enumeration_item("trajectory", name)
        .unwrap_or_else(|| panic!("no Trajectory item {name}"))
}

fn vrs(f: &Fmu, base: &str) -> Vec<u32> {
    (1..=6).map(|i| vr(f, &format!("{base}[{i}]"))).collect()
}

fn initialise(inst: &mut Instance) {
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
}

fn get6(inst: &mut Instance, vrs: &[u32]) -> Vector6<f64> {
    let mut out = [0.0; 6];
    inst.get_real(vrs, &mut out).unwrap();
    Vector6::from_row_slice(&out)
}

/// The circle of docs/model.md §3 written out here from its definition (not through
/// `ckcm::trajectory`): p = (r sin θ, r − r cos θ, h), θ = 2π s(t/T),
/// s(τ) = 10τ³ − 15τ⁴ + 6τ⁵; returns (pose, twist, acceleration).
fn circle_by_hand(t: f64, duration: f64, h: f64) -> (Pose, Vector6<f64>, Vector6<f64>) {
    let r = 0.2;
    let tau = t / duration;
    let s = 10.0 * tau.powi(3) - 15.0 * tau.powi(4) + 6.0 * tau.powi(5);
    let ds = (30.0 * tau.powi(2) - 60.0 * tau.powi(3) + 30.0 * tau.powi(4)) / duration;
    let dds = (60.0 * tau - 180.0 * tau.powi(2) + 120.0 * tau.powi(3)) / (duration * duration);
    let tp = 2.0 * std::f64::consts::PI;
    let (th, thd, thdd) = (tp * s, tp * ds, tp * dds);
    let pose = Pose::from_xyz_euler(&[r * th.sin(), r - r * th.cos(), h, 0.0, 0.0, 0.0]);
    let twist = Vector6::new(r * th.cos() * thd, r * th.sin() * thd, 0.0, 0.0, 0.0, 0.0);
    let accel = Vector6::new(
        r * (th.cos() * thdd - th.sin() * thd * thd),
        r * (th.sin() * thdd + th.cos() * thd * thd),
        0.0,
        0.0,
        0.0,
        0.0,
    );
    (pose, twist, accel)
}

/// Gains chosen so that every term is large and each gain is distinct from every other:
/// a term dropped, a gain swapped or the integral replaced by the error moves an output by
/// far more than the tolerance. Ψ and Ki are thousands of times Table 1's, so Ψ·I and Ki·I
/// are tens of newtons.
const KP: f64 = 50000.0;
const KI: f64 = 20000.0;
const KD: f64 = 850.0;
const PHI: f64 = 47728.0;
const GAMMA: f64 = 847.0;
const PSI: f64 = 30000.0;
const H: f64 = 1e-3;
const DURATION: f64 = 5.0;

#[test]
fn controller_law_mid_circle_term_by_term() {
    let ctl = open("HlcsController");
    let mut c = ctl.instantiate("law", false).unwrap();
    for (name, value) in [
        ("kp", KP),
        ("ki", KI),
        ("kd", KD),
        ("phi", PHI),
        ("gamma", GAMMA),
        ("psi", PSI),
        ("duration", DURATION),
    ] {
        c.set_real(&[vr(&ctl, name)], &[value]).unwrap();
    }
    c.set_integer(&[vr(&ctl, "trajectory")], &[item(&ctl, "circle")])
        .unwrap();
    c.set_boolean(&[vr(&ctl, "learning")], &[true]).unwrap();
    c.set_boolean(&[vr(&ctl, "feedforward")], &[true]).unwrap();
    initialise(&mut c);
    let (length, velocity, memory) = (
        vrs(&ctl, "length"),
        vrs(&ctl, "velocity"),
        vrs(&ctl, "memory"),
    );
    let (force, memory_next, error) = (
        vrs(&ctl, "force"),
        vrs(&ctl, "memory_next"),
        vrs(&ctl, "error"),
    );

    // The controller's nominal model: the plant's defaults without rod and friction.
    let model = Mechanism::new(Params::nominal()).unwrap();
    let home_height = model.params.geometry.home_height;
    let mut integral = Vector6::<f64>::zeros();
    let mut checked_mid = false;
    for n in 0..=1500 {
        let t = n as f64 * H;
        let (pose_d, twist_d, accel_d) = circle_by_hand(t, DURATION, home_height);
        let legs_d = model.inverse_kinematics(&pose_d);
        let l_d = legs_d.length;
        let ldot_d = legs_d.leg_rates(&twist_d);
        // Measurements off the reference by known amounts, a learning input of tens of N.
        let delta = Vector6::from_fn(|i, _| 1e-3 * (3.0 * t + i as f64).sin());
        let delta_dot = Vector6::from_fn(|i, _| 2e-3 * (5.0 * t + 2.0 * i as f64).cos());
        let u = Vector6::from_fn(|i, _| 40.0 * (2.0 * t + i as f64).sin());
        let l = l_d + delta;
        let ldot = ldot_d + delta_dot;
        c.set_real(&length, l.as_slice()).unwrap();
        c.set_real(&velocity, ldot.as_slice()).unwrap();
        c.set_real(&memory, u.as_slice()).unwrap();
        c.do_step(t, H, true).unwrap();

        // Expected, term by term (paper eqs. 7-10, 14).
        let e = -delta;
        let edot = -delta_dot;
        integral += e * H; // I_n = I_{n-1} + e_n h, eq. (10)
        let tau_a = model.inverse_dynamics(&pose_d, &twist_d, &accel_d).unwrap();
        let feedback = e * KP + edot * KD + integral * KI;
        let learning = e * PHI + edot * GAMMA + integral * PSI;
        let got_force = get6(&mut c, &force);
        let got_next = get6(&mut c, &memory_next);
        let got_error = get6(&mut c, &error);

        // Tolerance: rounding of sums of terms of ≤ 1e3 N, and of e = l_d − l near 0.57 m
        // (1e-16 m, times Kp).
        let tol = 1e-9;
        assert!(
            (got_error - e).amax() < 1e-12,
            "t = {t}: error {got_error:?}, expected {e:?}"
        );
        let force_gap = (got_force - (feedback + u + tau_a)).amax();
        assert!(force_gap < tol, "t = {t}: force off by {force_gap:e} N");
        let next_gap = (got_next - (u + learning)).amax();
        assert!(next_gap < tol, "t = {t}: memory_next off by {next_gap:e} N");

        if n == 1000 {
            // Mid-trajectory: every term is resolvable. The reference acceleration is far
            // from zero, so dropping M·a_d from the feedforward would show; the integral
            // differs from the error, so Ψ·e in place of Ψ·I would show.
            assert!(accel_d.norm() > 0.3, "a_d = {accel_d:?}");
            let tau_static = model
                .inverse_dynamics(&pose_d, &twist_d, &Vector6::zeros())
                .unwrap();
            let terms = [
                ("M a_d in τ_a", (tau_a - tau_static).amin()),
                ("Kp e", (e * KP).amin()),
                ("Kd ė", (edot * KD).amin()),
                ("Ki I", (integral * KI).amin()),
                ("Φ e", (e * PHI).amin()),
                ("Γ ė", (edot * GAMMA).amin()),
                ("Ψ I", (integral * PSI).amin()),
                ("Ψ (I − e)", ((integral - e) * PSI).amin()),
                ("u", u.amin()),
            ];
            for (name, size) in terms {
                assert!(size > 1e6 * tol, "{name} is too small to test: {size:e} N");
            }
            checked_mid = true;
        }
    }
    assert!(checked_mid);
}

/// The static force per leg at home of the independent reference model (docs/model.md §3):
/// 28.5315 N with the plant's defaults, 18.0647 N without rods. The controller's nominal model
/// has no rods, so its feedforward at rest at home is the second figure.
#[test]
fn controller_feedforward_at_home_is_the_rodless_static_force() {
    let ctl = open("HlcsController");
    let mut c = ctl.instantiate("hold", false).unwrap();
    c.set_integer(&[vr(&ctl, "trajectory")], &[item(&ctl, "hold")])
        .unwrap();
    initialise(&mut c);
    let model = Mechanism::new(Params::nominal()).unwrap();
    let l_home = model.inverse_kinematics(&model.home()).length;
    c.set_real(&vrs(&ctl, "length"), l_home.as_slice()).unwrap();
    c.do_step(0.0, H, true).unwrap();
    let f = get6(&mut c, &vrs(&ctl, "force"));
    // Printed to 4 decimals: ±5e-5 N, plus the models' 2e-5 relative agreement.
    for (i, fi) in f.iter().enumerate() {
        assert!(
            (fi - 18.0647).abs() <= 5e-5 + 2e-5 * 18.0647,
            "leg {}: {fi} N",
            i + 1
        );
    }
}

/// The hold force the plant itself needs, measured: the platform's sink after 20 ms under
/// two uniform leg forces, interpolated to zero. Near rest every effect (including the
/// friction's tanh) is linear in the force, and the two forces sit symmetrically about the
/// answer, so the interpolation error is far below the tolerance.
fn plant_hold_force(rods: bool) -> f64 {
    let plant = open("CkcmPlant");
    let sink = |f: f64| {
        let mut p = plant.instantiate("hold", false).unwrap();
        if !rods {
            p.set_real(
                &[vr(&plant, "rod_mass"), vr(&plant, "rod_inertia")],
                &[0.0, 0.0],
            )
            .unwrap();
        }
        initialise(&mut p);
        let force = vrs(&plant, "force");
        for n in 0..20 {
            p.set_real(&force, &[f; 6]).unwrap();
            p.do_step(n as f64 * H, H, true).unwrap();
        }
        let pose = get6(&mut p, &vrs(&plant, "pose"));
        pose[2] - 0.5
    };
    let guess = if rods { 28.5 } else { 18.1 };
    let (f1, f2) = (guess - 0.1, guess + 0.1);
    let (z1, z2) = (sink(f1), sink(f2));
    assert!(z1 < 0.0 && z2 > 0.0, "{f1} N: dz = {z1}, {f2} N: dz = {z2}");
    f1 - z1 * (f2 - f1) / (z2 - z1)
}

#[test]
fn plant_hold_force_matches_the_independent_model() {
    for (rods, printed) in [(true, 28.5315), (false, 18.0647)] {
        let f = plant_hold_force(rods);
        assert!(
            (f - printed).abs() <= 5e-5 + 2e-5 * printed,
            "rods {rods}: measured hold force {f} N, independent model {printed} N"
        );
    }
}

/// `initial_pose` is an offset from home (0, 0, home_height): the plant starts there, at rest.
#[test]
fn plant_starts_at_its_initial_pose() {
    let plant = open("CkcmPlant");
    let mut p = plant.instantiate("offset", false).unwrap();
    let offset = [0.01, -0.02, 0.03, 0.05, -0.04, 0.1];
    p.set_real(&vrs(&plant, "initial_pose"), &offset).unwrap();
    initialise(&mut p);
    let pose = get6(&mut p, &vrs(&plant, "pose"));
    let mut expected = offset;
    expected[2] += 0.5;
    for i in 0..6 {
        assert!(
            (pose[i] - expected[i]).abs() < 1e-12,
            "pose {pose:?}, expected {expected:?}"
        );
    }
    let legs = Mechanism::new(Params::default())
        .unwrap()
        .inverse_kinematics(&Pose::from_xyz_euler(&expected))
        .length;
    let length = get6(&mut p, &vrs(&plant, "length"));
    assert!(
        (length - legs).amax() < 1e-12,
        "lengths {length:?}, expected {legs:?}"
    );
    assert_eq!(get6(&mut p, &vrs(&plant, "velocity")), Vector6::zeros());
}
