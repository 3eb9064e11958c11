//! The packaged FMUs against hostile input (loaded with `fmi2-import`): declared ranges
//! enforced on set, at initialization and on deserialization; the plant's workspace
//! (strokes, base plane, finiteness) discarding a step with the leg, length and time; the
//! controller never answering fmi2OK with non-finite outputs; corrupted serialized states
//! refused by their checksum.

use std::path::{Path, PathBuf};

mod common;

use common::number_after;
use fmi2_import::Status;
use fmi2_import::{Fmu, ImportError, Instance};
use fmi2_md::{Causality, ModelDescription, VarType};

fn fmu(name: &str) -> Fmu {
    let dir = std::env::var_os("CKCM_FMU_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/fmu"));
    let path = dir.join(name);
    assert!(
        path.exists(),
        "{} not found: run `cargo xtask fmu` first",
        path.display()
    );
    Fmu::open(&path).unwrap()
}

fn vr(f: &Fmu, name: &str) -> u32 {
    f.model_description()
        .variable_by_name(name)
        .unwrap_or_else(|| panic!("no {name}"))
        .value_reference
}

fn vrs(f: &Fmu, base: &str) -> Vec<u32> {
    (1..=6).map(|i| vr(f, &format!("{base}[{i}]"))).collect()
}

fn initialize(inst: &mut Instance) -> Result<Status, ImportError> {
    inst.setup_experiment(None, 0.0, None)?;
    inst.enter_initialization_mode()?;
    inst.exit_initialization_mode()
}

/// The status and the text of a failed call.
fn failure(r: Result<Status, ImportError>) -> (Status, String) {
    match r {
        Err(e @ ImportError::Call { status, .. }) => (status, e.to_string()),
        other => panic!("expected a failed call, got {other:?}"),
    }
}

fn descriptions() -> Vec<(&'static str, ModelDescription)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../modelDescription");
    ["CkcmPlant", "HlcsController"]
        .into_iter()
        .map(|n| {
            let md = ModelDescription::from_file(dir.join(format!("{n}.xml"))).unwrap();
            (n, md)
        })
        .collect()
}

#[test]
fn every_parameter_declares_a_range_that_holds_its_start() {
    for (name, md) in descriptions() {
        for v in &md.model_variables {
            if v.causality != Causality::Parameter || v.var_type() == VarType::Boolean {
                continue;
            }
            let (min, max) = md.range_of(v);
            let (Some(min), Some(max)) = (min, max) else {
                panic!("{name}: parameter {} declares no min/max", v.name);
            };
            assert!(
                min.is_finite() && max.is_finite() && min < max,
                "{name}: {}",
                v.name
            );
            let start = v.start_as_f64().unwrap();
            assert!(
                (min..=max).contains(&start),
                "{name}: {} start {start} outside [{min}, {max}]",
                v.name
            );
        }
    }
}

/// Every bound of every parameter is enforced by the glue: a value just outside is refused
/// at the set call with the variable, the value and the range; the bound itself passes;
/// NaN and infinities are refused. Each bad value follows a good one through the same
/// value-reference array, so the glue's shortcut for an array it accepted before is
/// covered too: it may skip the lookup, never the range check.
#[test]
fn every_parameter_range_is_enforced_on_set() {
    for (name, md) in descriptions() {
        let f = fmu(&format!("{name}.fmu"));
        let mut inst = f.instantiate("ranges", true).unwrap();
        for v in &md.model_variables {
            let (Some(min), Some(max)) = md.range_of(v) else {
                continue;
            };
            if v.causality != Causality::Parameter {
                continue;
            }
            let r = v.value_reference;
            match v.var_type() {
                VarType::Real => {
                    let below = if min == 0.0 {
                        -1e-9
                    } else {
                        min - min.abs() * 1e-6
                    };
                    let above = max + max.abs() * 1e-6;
                    for bad in [below, above, f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                        inst.set_real(&[r], &[min])
                            .unwrap_or_else(|e| panic!("{name}: {} = {min}: {e}", v.name));
                        let (status, err) = failure(inst.set_real(&[r], &[bad]));
                        assert_eq!(status, Status::Error, "{name}: {} = {bad}", v.name);
                        if bad.is_finite() {
                            // The numbers' spelling is the FMU's (exponents for extreme
                            // values); their values must be exact.
                            let said = range_message(&err, v.name.as_str());
                            let bits = |(x, lo, hi): (f64, f64, f64)| {
                                [x.to_bits(), lo.to_bits(), hi.to_bits()]
                            };
                            assert_eq!(
                                said.map(bits),
                                Some(bits((bad, min, max))),
                                "{name}: {err}"
                            );
                        } else {
                            let expected = format!("{} = {bad} ", v.name);
                            assert!(err.contains(&expected), "{name}: {err}");
                        }
                        // An error terminates the instance; start over.
                        inst = f.instantiate("ranges", true).unwrap();
                    }
                    for good in [min, max] {
                        inst.set_real(&[r], &[good])
                            .unwrap_or_else(|e| panic!("{name}: {} = {good}: {e}", v.name));
                    }
                }
                VarType::Integer | VarType::Enumeration => {
                    // Every Integer outside [min, max] that an Integer can hold.
                    let outside = [
                        i64::from(min as i32) - 1,
                        i64::from(max as i32) + 1,
                        i64::from(i32::MAX),
                        i64::from(i32::MIN),
                    ]
                    .into_iter()
                    .filter(|&x| x < min as i64 || x > max as i64)
                    .filter_map(|x| i32::try_from(x).ok());
                    for bad in outside {
                        inst.set_integer(&[r], &[min as i32])
                            .unwrap_or_else(|e| panic!("{name}: {} = {min}: {e}", v.name));
                        let (status, err) = failure(inst.set_integer(&[r], &[bad]));
                        assert_eq!(status, Status::Error, "{name}: {} = {bad}", v.name);
                        assert!(
                            err.contains(&format!(
                                "{} = {bad} is outside its range [{min}, {max}]",
                                v.name
                            )),
                            "{name}: {err}"
                        );
                        inst = f.instantiate("ranges", true).unwrap();
                    }
                }
                _ => {}
            }
        }
    }
}

/// Issue 11, defect 1: one doStep could be made to run for hours.
#[test]
fn substeps_is_bounded() {
    let plant = fmu("CkcmPlant.fmu");
    let mut a = plant.instantiate("a", true).unwrap();
    let (status, err) = failure(a.set_integer(&[vr(&plant, "substeps")], &[2_147_483_647]));
    assert_eq!(status, Status::Error);
    assert!(
        err.contains("substeps = 2147483647 is outside its range [1, 1000]"),
        "{err}"
    );
    let mut b = plant.instantiate("b", true).unwrap();
    b.set_integer(&[vr(&plant, "substeps")], &[1000]).unwrap();
    initialize(&mut b).unwrap();
    b.do_step(0.0, 1e-3, true).unwrap();
}

/// A serialized state edited to hold an out-of-range parameter (with a valid checksum, as
/// a deliberate edit would have) is refused on deserialization, naming the variable.
#[test]
fn deserialized_state_with_an_out_of_range_parameter_is_refused() {
    let plant = fmu("CkcmPlant.fmu");
    let mut a = plant.instantiate("a", true).unwrap();
    a.set_integer(&[vr(&plant, "substeps")], &[7]).unwrap();
    initialize(&mut a).unwrap();
    let s = a.get_fmu_state().unwrap();
    let mut bytes = a.serialize_fmu_state(&s).unwrap();
    // Integers follow the Reals in the model payload; substeps = 7 is the only 7 there.
    let seven = 7i32.to_le_bytes();
    let body = bytes.len() - 4;
    let at = (0..body - 4)
        .rev()
        .find(|&i| bytes[i..i + 4] == seven)
        .expect("substeps = 7 is in the state");
    bytes[at..at + 4].copy_from_slice(&i32::MAX.to_le_bytes());
    // Without a new checksum: corrupted.
    let err = a.deserialize_fmu_state(&bytes).unwrap_err().to_string();
    assert!(err.contains("checksum mismatch"), "{err}");
    let crc = crc32fast::hash(&bytes[..body]);
    bytes[body..].copy_from_slice(&crc.to_le_bytes());
    let mut b = plant.instantiate("b", true).unwrap();
    let err = b.deserialize_fmu_state(&bytes).unwrap_err().to_string();
    assert!(
        err.contains("the state holds substeps = 2147483647 is outside its range [1, 1000]"),
        "{err}"
    );
}

/// A forged state (edited, then sealed with a fresh checksum) that holds a non-finite input
/// is refused on deserialization, naming the input: fmi2SetReal would have refused it.
#[test]
fn deserialized_state_with_a_non_finite_input_is_refused() {
    let plant = fmu("CkcmPlant.fmu");
    let mut a = plant.instantiate("a", true).unwrap();
    initialize(&mut a).unwrap();
    let marker = 1_234.567_890_123_f64;
    a.set_real(&[vr(&plant, "force[2]")], &[marker]).unwrap();
    let s = a.get_fmu_state().unwrap();
    let bytes = a.serialize_fmu_state(&s).unwrap();
    let body = bytes.len() - 4;
    let at = (0..body - 8)
        .find(|&i| bytes[i..i + 8] == marker.to_le_bytes())
        .expect("the force is in the state");
    for bad in [f64::NAN, f64::INFINITY] {
        let mut forged = bytes.clone();
        forged[at..at + 8].copy_from_slice(&bad.to_le_bytes());
        let crc = crc32fast::hash(&forged[..body]);
        forged[body..].copy_from_slice(&crc.to_le_bytes());
        let mut b = plant.instantiate("b", true).unwrap();
        let err = b.deserialize_fmu_state(&forged).unwrap_err().to_string();
        assert!(
            err.contains(&format!("the state holds force[2] = {bad} is not finite")),
            "{err}"
        );
    }
    // The state as saved is accepted.
    let mut b = plant.instantiate("b", true).unwrap();
    b.deserialize_fmu_state(&bytes).unwrap();
}

/// Issue 11, defect 13: every single-byte corruption of a serialized plant and controller
/// state is refused; none decodes into a state that steps to NaN with fmi2OK.
#[test]
fn corrupted_serialized_states_are_refused() {
    for name in ["CkcmPlant.fmu", "HlcsController.fmu"] {
        let f = fmu(name);
        let mut a = f.instantiate("a", true).unwrap();
        initialize(&mut a).unwrap();
        a.do_step(0.0, 1e-3, true).unwrap();
        let s = a.get_fmu_state().unwrap();
        let bytes = a.serialize_fmu_state(&s).unwrap();
        let mut b = f.instantiate("b", true).unwrap();
        for i in 0..bytes.len() {
            for x in [0x01u8, 0x80, 0xff] {
                let mut bad = bytes.clone();
                bad[i] ^= x;
                let err = b
                    .deserialize_fmu_state(&bad)
                    .map(|_| ())
                    .expect_err(&format!("{name}: byte {i} ^ {x:#x} accepted"));
                let text = err.to_string();
                assert!(
                    text.contains("fmi2DeSerializeFMUstate")
                        && (text.contains("checksum")
                            || text.contains("magic")
                            || text.contains("version")),
                    "{name}: byte {i}: {text}"
                );
                // A refused deserialization is an fmi2Error: start a fresh instance.
                b = f.instantiate("b", true).unwrap();
            }
        }
    }
}

/// Steps the plant under constant forces until a step fails; returns the failed status,
/// its message and the number of successful steps. Outputs stay finite throughout.
fn drive_plant(forces: [f64; 6], max_steps: usize) -> (Status, String, usize, [f64; 6]) {
    let plant = fmu("CkcmPlant.fmu");
    let (force, length) = (vrs(&plant, "force"), vrs(&plant, "length"));
    let mut a = plant.instantiate("a", true).unwrap();
    initialize(&mut a).unwrap();
    let mut l = [0.0; 6];
    for k in 0..max_steps {
        a.set_real(&force, &forces).unwrap();
        match a.do_step(k as f64 * 1e-3, 1e-3, true) {
            Ok(_) => {
                a.get_real(&length, &mut l).unwrap();
                assert!(l.iter().all(|x| x.is_finite()), "step {k}: {l:?}");
            }
            Err(e) => {
                let (status, text) = failure(Err(e));
                // After a discard the outputs are those of the last accepted step.
                let mut after = [0.0; 6];
                a.get_real(&length, &mut after).unwrap();
                assert_eq!(after, l, "outputs changed by the refused step");
                assert_eq!(a.last_successful_time().unwrap(), k as f64 * 1e-3);
                return (status, text, k, l);
            }
        }
    }
    panic!("the plant never left its workspace under {forces:?} N");
}

/// Issue 11, defect 7: zero forces let the platform fall; it stops at the stroke end.
#[test]
fn falling_platform_is_discarded_at_the_stroke_end() {
    let (status, err, steps, last) = drive_plant([0.0; 6], 5000);
    assert_eq!(status, Status::Discard, "{err}");
    assert!(err.contains("outside its stroke [0.4, 0.95] m"), "{err}");
    assert!(err.contains("has length 0.39"), "{err}");
    // The time of the end of the refused step, as the plant computes it.
    let t = format!("at t = {} s leg ", steps as f64 * 1e-3 + 1e-3);
    assert!(err.contains(&t), "{t} in {err}");
    assert!(last.iter().all(|l| *l >= 0.4), "{last:?}");
}

/// Issue 11, defect 7: 1 MN per leg no longer lifts the platform to 19.8 km.
#[test]
fn launched_platform_is_discarded_at_the_stroke_end() {
    let (status, err, _, last) = drive_plant([1e6; 6], 5000);
    assert_eq!(status, Status::Discard, "{err}");
    assert!(err.contains("outside its stroke [0.4, 0.95] m"), "{err}");
    assert!(last.iter().all(|l| *l <= 0.95), "{last:?}");
}

/// A leg that leaves its stroke and comes back within one long communication step is
/// refused as it is within 1 ms steps, at the substep where it left: whether a path is
/// refused does not depend on the master's step size, for either integrator.
#[test]
fn a_stroke_left_and_regained_within_one_step_is_refused() {
    let plant = fmu("CkcmPlant.fmu");
    let force = vrs(&plant, "force");
    // Without friction these forces swing leg 1 below 0.4 m at t = 0.1 s and back above it
    // by t = 0.2 s.
    let forces = [-191.0, 187.5, -243.1, 345.3, -41.3, 152.8];
    let start = |integrator: i32| {
        let mut a = plant.instantiate("a", true).unwrap();
        let names = ["viscous_friction", "coulomb_friction"];
        a.set_real(&names.map(|n| vr(&plant, n)), &[0.0, 0.0])
            .unwrap();
        a.set_integer(&[vr(&plant, "integrator")], &[integrator])
            .unwrap();
        initialize(&mut a).unwrap();
        a.set_real(&force, &forces).unwrap();
        a
    };
    // In 1 ms steps the leg leaves at the end of the hundredth step.
    let mut fine = start(1);
    let mut k = 0;
    while fine.do_step(k as f64 * 1e-3, 1e-3, true).is_ok() {
        k += 1;
        assert!(k < 200, "1 ms steps never left the stroke");
    }
    assert_eq!(k, 99);
    for integrator in [1, 2] {
        let mut long = start(integrator);
        let (status, err) = failure(long.do_step(0.0, 0.2, true));
        assert_eq!(status, Status::Discard, "integrator {integrator}: {err}");
        assert!(err.contains("leg 1 has length 0.39"), "{err}");
        assert!(err.contains("outside its stroke [0.4, 0.95] m"), "{err}");
        assert_eq!(long.last_successful_time().unwrap(), 0.0);
        if integrator == 1 {
            // RK4's substeps are those of the 1 ms steps (rk4_max_step = 1 ms).
            assert!(err.contains("at t = 0.1 s leg 1"), "{err}");
        } else {
            // An accepted step of Dormand–Prince ends where it ends: after 0.1 s and by
            // the end of the step.
            let at = number_after(&err, "at t = ");
            assert!(at > 0.1 && at < 0.2, "{err}");
        }
    }
}

/// With the stroke limits out of the way, the platform reaches the base plane.
#[test]
fn base_plane_is_a_workspace_limit() {
    let plant = fmu("CkcmPlant.fmu");
    let (force, pose) = (vrs(&plant, "force"), vrs(&plant, "pose"));
    let mut a = plant.instantiate("a", true).unwrap();
    a.set_real(&[vr(&plant, "length_min")], &[0.0]).unwrap();
    initialize(&mut a).unwrap();
    let mut p = [0.0; 6];
    for k in 0..5000 {
        a.set_real(&force, &[0.0; 6]).unwrap();
        if let Err(e) = a.do_step(k as f64 * 1e-3, 1e-3, true) {
            let (status, err) = failure(Err(e));
            assert_eq!(status, Status::Discard, "{err}");
            assert!(err.contains("reached the base plane (z = -"), "{err}");
            assert!(p[2] > 0.0, "{p:?}");
            return;
        }
        a.get_real(&pose, &mut p).unwrap();
    }
    panic!("the platform never reached the base plane");
}

/// Issue 11, defect 8: a geometry whose initial pose is outside the workspace fails at
/// fmi2ExitInitializationMode with the cause, never OK with infinite lengths.
#[test]
fn initial_pose_outside_the_workspace_fails_initialization() {
    let plant = fmu("CkcmPlant.fmu");
    for (var, value, needle) in [
        ("initial_pose[3]", -0.5, "reached the base plane"),
        ("home_height", 10.0, "outside its stroke"),
        ("base_radius", 10.0, "outside its stroke"),
    ] {
        let mut a = plant.instantiate("a", true).unwrap();
        a.set_real(&[vr(&plant, var)], &[value]).unwrap();
        let (status, err) = failure(initialize(&mut a));
        assert_eq!(status, Status::Error, "{var}");
        assert!(
            err.contains("fmi2ExitInitializationMode")
                && err.contains("the initial pose")
                && err.contains(needle),
            "{var} = {value}: {err}"
        );
    }
}

/// Issue 11, defect 6: absurd measurements make the law non-finite; the controller says
/// so itself, naming the output and the time, instead of passing NaN on with fmi2OK.
#[test]
fn controller_refuses_non_finite_outputs() {
    let ctl = fmu("HlcsController.fmu");
    let (length, velocity) = (vrs(&ctl, "length"), vrs(&ctl, "velocity"));
    for inputs in [&length, &velocity] {
        let mut c = ctl.instantiate("c", true).unwrap();
        initialize(&mut c).unwrap();
        c.do_step(0.0, 1e-3, true).unwrap();
        // Finite, but Kp e (or Kd de) overflows.
        c.set_real(inputs, &[1e306; 6]).unwrap();
        let (status, err) = failure(c.do_step(1e-3, 1e-3, true));
        assert_eq!(status, Status::Error, "{err}");
        assert!(
            err.contains("control law failed at t = 0.001 s: output ")
                && err.contains("is not finite"),
            "{err}"
        );
    }
}

/// Issue 11, defect 11: the pending status is not available (fmi2Discard), and asking for
/// it leaves the instance usable.
#[test]
fn pending_string_status_is_discard() {
    for name in ["CkcmPlant.fmu", "HlcsController.fmu"] {
        let f = fmu(name);
        let mut a = f.instantiate("a", true).unwrap();
        initialize(&mut a).unwrap();
        a.do_step(0.0, 1e-3, true).unwrap();
        let err = a.pending_status().unwrap_err();
        assert!(
            matches!(
                err,
                ImportError::Call {
                    status: Status::Discard,
                    ..
                }
            ),
            "{name}: {err}"
        );
        a.do_step(1e-3, 1e-3, true).unwrap();
    }
}

/// The value and range of a message "`name` = x is outside its range [lo, hi]", parsed.
fn range_message(message: &str, name: &str) -> Option<(f64, f64, f64)> {
    let rest = &message[message.find(&format!("{name} = "))? + name.len() + 3..];
    let (value, rest) = rest.split_once(" is outside its range [")?;
    let (lo, rest) = rest.split_once(", ")?;
    let (hi, _) = rest.split_once(']')?;
    Some((value.parse().ok()?, lo.parse().ok()?, hi.parse().ok()?))
}
