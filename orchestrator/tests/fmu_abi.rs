//! The packaged FMUs through the C ABI (loaded with `fmi2-import`): independence of
//! instances, FMU-state serialization, and the errors a user meets first.

mod common;

use fmi2_import::{Fmu, Instance};

fn fmu(name: &str) -> Fmu {
    let stem = name.strip_suffix(".fmu").unwrap_or(name);
    Fmu::open(common::built_fmu(stem)).unwrap()
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

fn start(inst: &mut Instance, reals: &[(u32, f64)]) {
    for &(v, x) in reals {
        inst.set_real(&[v], &[x]).unwrap();
    }
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    inst.exit_initialization_mode().unwrap();
}

const HOLD: f64 = 28.5315;

/// Steps a plant under `force` for `n` steps of 1 ms, returning z after each step.
fn heave(
    inst: &mut Instance,
    force: &[u32],
    pose: &[u32],
    f: f64,
    n: usize,
    t0: usize,
) -> Vec<f64> {
    let mut out = Vec::new();
    let mut p = [0.0; 6];
    for k in t0..t0 + n {
        inst.set_real(force, &[f; 6]).unwrap();
        inst.do_step(k as f64 * 1e-3, 1e-3, true).unwrap();
        inst.get_real(pose, &mut p).unwrap();
        out.push(p[2]);
    }
    out
}

#[test]
fn two_plant_instances_are_independent() {
    let plant = fmu("CkcmPlant.fmu");
    let (force, pose) = (vrs(&plant, "force"), vrs(&plant, "pose"));
    let rod = vr(&plant, "rod_mass");
    // Sequential reference runs.
    let mut a = plant.instantiate("a", false).unwrap();
    start(&mut a, &[]);
    let ref_a = heave(&mut a, &force, &pose, HOLD, 200, 0);
    let mut b = plant.instantiate("b", false).unwrap();
    start(&mut b, &[(rod, 3.0)]);
    let ref_b = heave(&mut b, &force, &pose, HOLD, 200, 0);
    drop((a, b));
    // The rod mass matters: with heavier rods the same forces let the platform sink.
    assert!((ref_a[199] - 0.5).abs() < 1e-6, "{}", ref_a[199]);
    assert!(ref_b[199] < 0.5 - 1e-4, "{}", ref_b[199]);
    // Interleaved stepping of two live instances reproduces both runs bit for bit.
    let mut a = plant.instantiate("a2", false).unwrap();
    let mut b = plant.instantiate("b2", false).unwrap();
    start(&mut a, &[]);
    start(&mut b, &[(rod, 3.0)]);
    let (mut za, mut zb) = (Vec::new(), Vec::new());
    for k in 0..200 {
        za.extend(heave(&mut a, &force, &pose, HOLD, 1, k));
        zb.extend(heave(&mut b, &force, &pose, HOLD, 1, k));
    }
    assert_eq!(za, ref_a);
    assert_eq!(zb, ref_b);
}

#[test]
fn serialized_state_continues_bit_identically_in_a_fresh_instance() {
    for integrator in ["rk4", "dormand_prince"] {
        let plant = fmu("CkcmPlant.fmu");
        let (force, pose) = (vrs(&plant, "force"), vrs(&plant, "pose"));
        let item = plant
            .model_description()
            .enumeration_item("integrator", integrator)
            .unwrap_or_else(|| panic!("no Integrator item {integrator}"));
        let mut a = plant.instantiate("a", false).unwrap();
        a.set_integer(&[vr(&plant, "integrator")], &[item]).unwrap();
        start(&mut a, &[]);
        heave(&mut a, &force, &pose, 30.0, 300, 0);
        let state = a.get_fmu_state().unwrap();
        let bytes = a.serialize_fmu_state(&state).unwrap();
        let cont = heave(&mut a, &force, &pose, 27.0, 300, 300);
        // Restore in the same instance.
        a.set_fmu_state(&state).unwrap();
        assert_eq!(heave(&mut a, &force, &pose, 27.0, 300, 300), cont);
        // Restore in a fresh, never-initialised instance.
        let mut b = plant.instantiate("b", false).unwrap();
        let restored = b.deserialize_fmu_state(&bytes).unwrap();
        b.set_fmu_state(&restored).unwrap();
        assert_eq!(
            heave(&mut b, &force, &pose, 27.0, 300, 300),
            cont,
            "integrator {integrator}"
        );
        // A truncated buffer is refused with a clear message.
        let err = b
            .deserialize_fmu_state(&bytes[..bytes.len() / 2])
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("fmi2DeSerializeFMUstate") && err.contains("truncated"),
            "{err}"
        );
    }
}

#[test]
fn controller_state_serialization_keeps_the_integral() {
    let ctl = fmu("HlcsController.fmu");
    let (len, force) = (vrs(&ctl, "length"), vrs(&ctl, "force"));
    let mut a = ctl.instantiate("a", false).unwrap();
    start(&mut a, &[]);
    let mut out = [0.0; 6];
    let step = |inst: &mut Instance, k: usize, out: &mut [f64; 6]| {
        inst.set_real(&len, &[0.56; 6]).unwrap();
        inst.do_step(k as f64 * 1e-3, 1e-3, true).unwrap();
        inst.get_real(&force, out).unwrap();
        *out
    };
    for k in 0..500 {
        step(&mut a, k, &mut out);
    }
    let bytes = {
        let s = a.get_fmu_state().unwrap();
        a.serialize_fmu_state(&s).unwrap()
    };
    let cont: Vec<_> = (500..600).map(|k| step(&mut a, k, &mut out)).collect();
    let mut b = ctl.instantiate("b", false).unwrap();
    let s = b.deserialize_fmu_state(&bytes).unwrap();
    b.set_fmu_state(&s).unwrap();
    let again: Vec<_> = (500..600).map(|k| step(&mut b, k, &mut out)).collect();
    assert_eq!(cont, again);
}

#[test]
fn non_finite_input_is_an_error_naming_the_variable() {
    let plant = fmu("CkcmPlant.fmu");
    let force = vrs(&plant, "force");
    let mut a = plant.instantiate("a", false).unwrap();
    start(&mut a, &[]);
    let err = a
        .set_real(&force[2..3], &[f64::NAN])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("force[3]") && err.contains("not finite"),
        "{err}"
    );
}

/// A batch with one non-finite value in the middle is refused whole: the message names that
/// element, and the elements before it keep their old values.
#[test]
fn a_refused_batch_writes_nothing() {
    let plant = fmu("CkcmPlant.fmu");
    let force = vrs(&plant, "force");
    let mut a = plant.instantiate("a", false).unwrap();
    start(&mut a, &[]);
    a.set_real(&force, &[1.0; 6]).unwrap();
    let bad = [2.0, 2.0, 2.0, f64::INFINITY, 2.0, 2.0];
    let err = a.set_real(&force, &bad).unwrap_err().to_string();
    assert!(
        err.contains("force[4]") && err.contains("not finite"),
        "{err}"
    );
    let mut now = [0.0; 6];
    a.get_real(&force, &mut now).unwrap();
    assert_eq!(now, [1.0; 6]);
}

/// The glue copies runs of consecutive value references as slices, cut once per accepted
/// array: batches in any order, with repeats, and one after another on the same instance
/// read and write exactly what one value per call does.
#[test]
fn batches_agree_with_one_value_per_call() {
    let plant = fmu("CkcmPlant.fmu");
    let (force, pose, length) = (
        vrs(&plant, "force"),
        vrs(&plant, "pose"),
        vrs(&plant, "length"),
    );
    let mut a = plant.instantiate("a", false).unwrap();
    start(&mut a, &[]);
    let order = [3, 4, 5, 0, 1, 2];
    let shuffled: Vec<u32> = order.iter().map(|&i| force[i]).collect();
    let f = [
        HOLD + 1.0,
        HOLD + 2.0,
        HOLD + 3.0,
        HOLD - 1.0,
        HOLD - 2.0,
        HOLD - 3.0,
    ];
    a.set_real(&shuffled, &f).unwrap();
    for (&i, &x) in order.iter().zip(&f) {
        let mut one = [0.0];
        a.get_real(&force[i..=i], &mut one).unwrap();
        assert_eq!(one[0], x, "force[{}]", i + 1);
    }
    a.do_step(0.0, 1e-3, true).unwrap();
    let reversed: Vec<u32> = length.iter().rev().copied().collect();
    let repeated = [length[2], length[2], length[3], pose[0], pose[1], length[3]];
    let joined: Vec<u32> = pose.iter().chain(&length).copied().collect();
    for batch in [&joined[..], &reversed, &repeated, &pose, &joined] {
        let mut got = vec![f64::NAN; batch.len()];
        a.get_real(batch, &mut got).unwrap();
        let one_by_one: Vec<f64> = batch
            .iter()
            .map(|&v| {
                let mut one = [f64::NAN];
                a.get_real(&[v], &mut one).unwrap();
                one[0]
            })
            .collect();
        assert_eq!(got, one_by_one, "{batch:?}");
    }
}

#[test]
fn diverging_plant_is_an_error_never_nan_outputs() {
    let plant = fmu("CkcmPlant.fmu");
    let (force, pose) = (vrs(&plant, "force"), vrs(&plant, "pose"));
    let mut a = plant.instantiate("a", true).unwrap();
    start(&mut a, &[]);
    // Pull legs 1-3 hard in and push 4-6 hard out: the platform is torn apart.
    let f = [-1e7, -1e7, -1e7, 1e7, 1e7, 1e7];
    let mut failed = None;
    let mut p = [0.0; 6];
    for k in 0..5000 {
        a.set_real(&force, &f).unwrap();
        match a.do_step(k as f64 * 1e-3, 1e-3, true) {
            Ok(_) => {
                a.get_real(&pose, &mut p).unwrap();
                assert!(p.iter().all(|x| x.is_finite()), "NaN output at step {k}");
            }
            Err(e) => {
                failed = Some((k, e.to_string()));
                break;
            }
        }
    }
    let (k, err) = failed.expect("a 10 MN tear never failed");
    assert!(
        err.contains("fmi2DoStep") && err.contains("t = "),
        "step {k}: {err}"
    );
}

#[test]
fn invalid_parameter_is_rejected_at_initialization_by_name() {
    // In range one by one, but together an empty stroke: refused at initialization.
    let plant = fmu("CkcmPlant.fmu");
    let mut a = plant.instantiate("a", false).unwrap();
    a.set_real(&[vr(&plant, "length_min")], &[0.9]).unwrap();
    a.set_real(&[vr(&plant, "length_max")], &[0.8]).unwrap();
    a.setup_experiment(None, 0.0, None).unwrap();
    a.enter_initialization_mode().unwrap();
    let err = a.exit_initialization_mode().unwrap_err().to_string();
    assert!(err.contains("length_min must be below length_max"), "{err}");
    // Out of range: refused at the set call, by name.
    let ctl = fmu("HlcsController.fmu");
    let mut c = ctl.instantiate("c", false).unwrap();
    let err = c
        .set_real(&[vr(&ctl, "model.cylinder_mass")], &[0.0])
        .unwrap_err()
        .to_string();
    assert!(err.contains("model.cylinder_mass = 0 is outside"), "{err}");
}

#[test]
fn log_categories_match_the_model_descriptions() {
    for name in ["CkcmPlant.fmu", "HlcsController.fmu"] {
        let f = fmu(name);
        let declared: Vec<&str> = f
            .model_description()
            .log_categories
            .iter()
            .map(|c| c.name.as_str())
            .collect();
        // The names the export glue passes to the logger.
        let glue: Vec<&str> = fmi2_export::LOG_CATEGORIES
            .iter()
            .map(|n| n.to_str().unwrap())
            .collect();
        assert_eq!(declared, glue, "{name}");
    }
}
