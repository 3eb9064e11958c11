//! Every parameter declared in each FMU's model description reaches its model.
//!
//! For each variable of causality `parameter` in the XML (tunable ones included), the
//! packaged FMU is run through the C ABI twice from the same inputs: once as is, once with
//! that parameter set to another legal value (inside its declared min/max). The outputs
//! after initialization and after every step, and how the run ended, must differ; a value
//! the FMU dropped (an unknown name, a parameter read from nowhere) would give bit-identical
//! runs. A tunable parameter is also changed between steps, where it must change the steps
//! after, and only those.
//!
//! Some parameters only show under conditions: the Dormand–Prince tolerances need that
//! integrator, the noise seed a non-zero noise, the controller's trajectory duration an
//! internal trajectory. Those conditions are listed per case (`context`), as are the few
//! test values the generic rule (start × 1.2, 0.01 for a zero start, integer + 1, the
//! other Boolean, another enumeration item) would not make visible (`values`).

mod common;

use std::collections::BTreeMap;

use fmi2_import::Status;
use fmi2_import::{Fmu, Instance};
use fmi2_md::{Causality, ModelDescription, ScalarVariable, SimpleTypeKind, VariableKind};

/// A value of a variable; `Item` is an enumeration item by name, looked up in the XML.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Val {
    Real(f64),
    Int(i32),
    Bool(bool),
    Item(&'static str),
}

/// One FMU and how to run it.
struct Case {
    name: &'static str,
    fmu: Fmu,
    /// Inputs and settings of every run.
    inputs: Vec<(&'static str, Val)>,
    /// Settings a parameter needs before its effect can show: (parameter, settings).
    context: Vec<(&'static str, Vec<(&'static str, Val)>)>,
    /// Test values where the generic rule would show nothing: (parameter, value).
    values: Vec<(&'static str, Val)>,
    step_size: f64,
    steps: usize,
}

/// What a run produced: the outputs (as bits) after initialization and after each step,
/// or the status or error that ended it.
#[derive(Debug, Clone, PartialEq)]
enum Event {
    Outputs(Vec<u64>),
    Stopped(String),
}

fn variable<'a>(md: &'a ModelDescription, name: &str) -> &'a ScalarVariable {
    md.variable_by_name(name)
        .unwrap_or_else(|| panic!("{}: no variable {name}", md.model_name))
}

fn set(inst: &mut Instance, md: &ModelDescription, name: &str, value: Val) {
    let vr = variable(md, name).value_reference;
    let status = match value {
        Val::Real(x) => inst.set_real(&[vr], &[x]),
        Val::Int(i) => inst.set_integer(&[vr], &[i]),
        Val::Bool(b) => inst.set_boolean(&[vr], &[b]),
        Val::Item(item) => {
            let i = md
                .enumeration_item(name, item)
                .unwrap_or_else(|| panic!("{}: {name} has no item {item}", md.model_name));
            inst.set_integer(&[vr], &[i])
        }
    };
    let status = status.unwrap_or_else(|e| panic!("{}: {name} = {value:?}: {e}", md.model_name));
    assert_eq!(status, Status::Ok, "{}: {name} = {value:?}", md.model_name);
}

/// Every output, as bits (integers and Booleans widened).
fn outputs(inst: &mut Instance, md: &ModelDescription) -> Vec<u64> {
    let mut out = Vec::new();
    for v in md
        .model_variables
        .iter()
        .filter(|v| v.causality == Causality::Output)
    {
        let vr = [v.value_reference];
        match v.kind {
            VariableKind::Real { .. } => {
                let mut x = [0.0];
                inst.get_real(&vr, &mut x).unwrap();
                out.push(x[0].to_bits());
            }
            VariableKind::Integer { .. } | VariableKind::Enumeration { .. } => {
                let mut i = [0];
                inst.get_integer(&vr, &mut i).unwrap();
                out.push(i[0] as u64);
            }
            VariableKind::Boolean { .. } => {
                let mut b = [false];
                inst.get_boolean(&vr, &mut b).unwrap();
                out.push(u64::from(b[0]));
            }
            VariableKind::String { .. } => {}
        }
    }
    out
}

/// Runs `case` with `settings` (applied in order before initialization); with `tune`,
/// sets (variable, value) before step `k`.
fn run(case: &Case, settings: &[(&str, Val)], tune: Option<(usize, &str, Val)>) -> Vec<Event> {
    let md = case.fmu.model_description();
    let mut inst = case.fmu.instantiate(case.name, false).unwrap();
    for &(name, value) in settings {
        set(&mut inst, md, name, value);
    }
    let mut events = Vec::new();
    inst.setup_experiment(None, 0.0, None).unwrap();
    inst.enter_initialization_mode().unwrap();
    if let Err(e) = inst.exit_initialization_mode() {
        events.push(Event::Stopped(format!("initialization: {e}")));
        return events;
    }
    events.push(Event::Outputs(outputs(&mut inst, md)));
    for k in 0..case.steps {
        if let Some((at, name, value)) = tune {
            if at == k {
                set(&mut inst, md, name, value);
            }
        }
        match inst.do_step(k as f64 * case.step_size, case.step_size, true) {
            Ok(Status::Ok) => events.push(Event::Outputs(outputs(&mut inst, md))),
            Ok(status) => {
                events.push(Event::Stopped(format!("step {k}: {status:?}")));
                break;
            }
            Err(e) => {
                events.push(Event::Stopped(format!("step {k}: {e}")));
                break;
            }
        }
    }
    events
}

/// The value `v` has under `settings`, else its start value.
fn current(v: &ScalarVariable, settings: &[(&str, Val)]) -> Val {
    if let Some(&(_, value)) = settings.iter().rev().find(|(n, _)| *n == v.name) {
        return value;
    }
    match &v.kind {
        VariableKind::Real { start, .. } => Val::Real(start.unwrap_or(0.0)),
        VariableKind::Integer { start, .. } | VariableKind::Enumeration { start, .. } => {
            Val::Int(start.unwrap_or(0))
        }
        VariableKind::Boolean { start } => Val::Bool(start.unwrap_or(false)),
        VariableKind::String { .. } => panic!("{}: String parameters are not covered", v.name),
    }
}

/// Another legal value for `v`, which has `now`: start × 1.2 (× 0.8 above the maximum),
/// 0.01 for zero, integer + 1 (− 1 above the maximum), the other Boolean, the first other
/// enumeration item.
fn other_value(md: &ModelDescription, v: &ScalarVariable, now: Val) -> Val {
    let (_, max) = md.range_of(v);
    let max = max.unwrap_or(f64::INFINITY);
    match (&v.kind, now) {
        (VariableKind::Real { .. }, Val::Real(0.0)) => Val::Real(0.01),
        (VariableKind::Real { .. }, Val::Real(x)) => {
            Val::Real(if x * 1.2 <= max { x * 1.2 } else { x * 0.8 })
        }
        (VariableKind::Integer { .. }, Val::Int(i)) => Val::Int(if f64::from(i + 1) <= max {
            i + 1
        } else {
            i - 1
        }),
        (VariableKind::Boolean { .. }, Val::Bool(b)) => Val::Bool(!b),
        (VariableKind::Enumeration { declared_type, .. }, now) => {
            let now = match now {
                Val::Int(i) => i,
                Val::Item(item) => md.enumeration_item(&v.name, item).unwrap(),
                other => panic!("{}: {other:?} for an enumeration", v.name),
            };
            let Some(SimpleTypeKind::Enumeration { items, .. }) =
                md.simple_type(declared_type).map(|t| &t.kind)
            else {
                panic!("{}: type {declared_type} is no enumeration", v.name);
            };
            let item = items
                .iter()
                .find(|i| i.value != now)
                .unwrap_or_else(|| panic!("{}: a single item", v.name));
            Val::Int(item.value)
        }
        (kind, now) => panic!("{}: {now:?} does not fit {kind:?}", v.name),
    }
}

/// Fails unless `value` lies inside the declared min/max of `v`.
fn assert_legal(md: &ModelDescription, v: &ScalarVariable, value: Val) {
    let x = match value {
        Val::Real(x) => x,
        Val::Int(i) => f64::from(i),
        Val::Bool(_) | Val::Item(_) => return,
    };
    let (min, max) = md.range_of(v);
    assert!(
        min.is_none_or(|m| x >= m) && max.is_none_or(|m| x <= m),
        "{}: test value {x} is outside [{min:?}, {max:?}]",
        v.name
    );
}

/// Checks every parameter of `case`; returns how many there were.
fn every_parameter_reaches_the_model(case: &Case) -> usize {
    let md = case.fmu.model_description();
    let context: BTreeMap<&str, &Vec<(&str, Val)>> =
        case.context.iter().map(|(n, c)| (*n, c)).collect();
    let values: BTreeMap<&str, Val> = case.values.iter().copied().collect();
    for name in context.keys().chain(values.keys()) {
        let v = variable(md, name);
        assert_eq!(v.causality, Causality::Parameter, "{name} is no parameter");
    }
    let mut checked = 0;
    for v in md
        .model_variables
        .iter()
        .filter(|v| v.causality == Causality::Parameter)
    {
        let name = v.name.as_str();
        let mut settings = case.inputs.clone();
        if let Some(extra) = context.get(name) {
            settings.extend(extra.iter().copied());
        }
        let now = current(v, &settings);
        let value = values
            .get(name)
            .copied()
            .unwrap_or_else(|| other_value(md, v, now));
        assert_ne!(value, now, "{name}: the test value is the current one");
        assert_legal(md, v, value);

        let base = run(case, &settings, None);
        assert!(
            base == run(case, &settings, None),
            "{}: two identical runs differ; the comparison below would prove nothing",
            case.name
        );
        let mut changed_settings = settings.clone();
        changed_settings.push((name, value));
        let changed = run(case, &changed_settings, None);
        // `assert!`, not `assert_ne!`: the runs are long, the message says what matters.
        assert!(
            changed != base,
            "{}: {name} = {value:?} (instead of {now:?}) changed nothing: the value does not \
             reach the model",
            case.name
        );
        if v.variability == fmi2_md::Variability::Tunable {
            let k = case.steps / 2;
            let tuned = run(case, &settings, Some((k, name, value)));
            assert!(
                tuned[..=k] == base[..=k],
                "{}: {name} changed the steps before it was tuned",
                case.name
            );
            assert!(
                tuned != base,
                "{}: tuning {name} = {value:?} between steps changed nothing",
                case.name
            );
        }
        checked += 1;
    }
    checked
}

fn open(name: &str) -> Fmu {
    Fmu::open(common::built_fmu(name)).unwrap()
}

/// `base[1]` … `base[6]` set to `values`. The names are leaked: a few dozen short strings
/// for the life of the test keep every setting a plain `(&str, Val)`.
fn six(base: &str, values: [f64; 6]) -> Vec<(&'static str, Val)> {
    (1..=6)
        .zip(values)
        .map(|(i, x)| {
            let name: &'static str = Box::leak(format!("{base}[{i}]").into_boxed_str());
            (name, Val::Real(x))
        })
        .collect()
}

/// Leg length at the home pose, m.
const HOME_LENGTH: f64 = 0.5667144462950593;

#[test]
fn every_plant_parameter_reaches_the_model() {
    // Unequal forces about the holding force turn and shift the platform, so masses,
    // inertias (about all three axes), leg properties and friction all show in the motion.
    let hold = 28.5315;
    let case = Case {
        name: "CkcmPlant",
        fmu: open("CkcmPlant"),
        inputs: six(
            "force",
            [0.0, -5.0, 3.0, -8.0, 6.0, -2.0].map(|d| hold + 10.0 * d),
        ),
        context: vec![
            (
                "relative_tolerance",
                vec![("integrator", Val::Item("dormand_prince"))],
            ),
            (
                "absolute_tolerance",
                vec![("integrator", Val::Item("dormand_prince"))],
            ),
            ("noise_seed", vec![("length_noise_sigma", Val::Real(1e-4))]),
        ],
        // The workspace bounds show when the home pose falls outside them.
        values: vec![
            ("length_min", Val::Real(HOME_LENGTH + 0.01)),
            ("length_max", Val::Real(HOME_LENGTH - 0.01)),
            // A longer cap than the 1 ms step changes nothing; a shorter one splits it.
            ("rk4_max_step", Val::Real(0.4e-3)),
        ],
        step_size: 1e-3,
        steps: 100,
    };
    let n = every_parameter_reaches_the_model(&case);
    assert_eq!(n, 36, "CkcmPlant parameters checked");
}

#[test]
fn every_controller_parameter_reaches_the_model() {
    // An external reference that moves and turns (so the nominal model's inertias enter
    // the feedforward), measured lengths and rates off it (so every gain acts) and a
    // non-zero memory.
    let mut inputs = vec![("trajectory", Val::Item("external"))];
    inputs.extend(six("pose_ref", [0.01, -0.02, 0.51, 0.02, -0.01, 0.03]));
    inputs.extend(six("twist_ref", [0.01, 0.02, -0.01, 0.05, -0.04, 0.03]));
    inputs.extend(six("accel_ref", [0.1, -0.2, 0.3, 0.5, -0.4, 0.6]));
    inputs.extend(six(
        "length",
        [1.0, -2.0, 3.0, -1.0, 2.0, -3.0].map(|d| HOME_LENGTH + 1e-3 * d),
    ));
    inputs.extend(six("velocity", [5e-3, -3e-3, 2e-3, -4e-3, 1e-3, 6e-3]));
    inputs.extend(six("memory", [1.0, -2.0, 3.0, -1.0, 0.5, 2.0]));
    let internal = vec![("trajectory", Val::Item("line"))];
    let case = Case {
        name: "HlcsController",
        fmu: open("HlcsController"),
        inputs,
        context: vec![
            // The duration and the home height shape the internal trajectories only.
            ("duration", internal.clone()),
            ("model.home_height", internal),
            // The rod's centre of mass matters once the rod has mass.
            ("model.rod_com", vec![("model.rod_mass", Val::Real(0.5))]),
        ],
        values: vec![],
        step_size: 1e-3,
        steps: 20,
    };
    let n = every_parameter_reaches_the_model(&case);
    assert_eq!(n, 26, "HlcsController parameters checked");
}

#[test]
fn every_parameter_of_the_foreign_fmu_reaches_its_model() {
    let dir = tempfile::tempdir().unwrap();
    let small_limit = ("x_limit", Val::Real(0.05));
    let case = Case {
        name: "ForeignOscillator",
        fmu: Fmu::open(common::foreign_fmu(dir.path())).unwrap(),
        inputs: vec![("drive", Val::Real(1.0))],
        // The end stop and what happens there show once the mass reaches it.
        context: vec![("discard_at_limit", vec![small_limit])],
        values: vec![small_limit],
        step_size: 0.0078125,
        steps: 64,
    };
    let n = every_parameter_reaches_the_model(&case);
    assert_eq!(n, 10, "ForeignOscillator parameters checked");
}
