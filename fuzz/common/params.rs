//! The two models driven as the FMI glue drives them, with parameters and inputs from the
//! fuzzer: settings within the declared ranges (the glue refuses the rest before the model
//! sees them), initialization, steps of varied sizes, tunable parameters and inputs changed
//! between steps. Every call either succeeds or returns an error; after a success every
//! Real output is finite, and a step's warning, if any, is handed over once. A panic, a
//! hang or a huge allocation is a finding.
#[path = "outputs.rs"]
mod outputs;

use fmi2_md::{Causality, VarType, Variability};
use fmu_core::{Model, VarSpec};
use libfuzzer_sys::arbitrary::{Result, Unstructured};
use outputs::outputs_finite;

/// A value for `spec`: its bounds, its current value scaled, small and large magnitudes,
/// or any bits at all (NaN and infinities included; `set_real` must refuse those).
fn real(u: &mut Unstructured, spec: &VarSpec, current: f64) -> Result<f64> {
    Ok(match u.int_in_range(0..=7)? {
        0 => spec.min.unwrap_or(-1.0),
        1 => spec.max.unwrap_or(1.0),
        2 => current * f64::from(u.int_in_range(-40..=40i8)?) / 8.0,
        3 => current + f64::from(u.arbitrary::<i16>()?) * 1e-6,
        4 => 10f64.powi(u.int_in_range(-320..=308)?),
        5 => -(10f64.powi(u.int_in_range(-320..=308)?)),
        6 => 0.0,
        _ => f64::from_bits(u.arbitrary()?),
    })
}

/// Sets `spec` as the glue would: a value outside the declared range never reaches the
/// model.
fn set<M: Model>(m: &mut M, spec: &VarSpec, u: &mut Unstructured) -> Result<()> {
    let vr = spec.value_reference;
    match spec.var_type {
        VarType::Real => {
            let x = real(u, spec, m.get_real(vr))?;
            if spec.check_range(x).is_ok() {
                let accepted = m.set_real(vr, x).is_ok();
                trace(format_args!("set {} = {x:e}: {accepted}", spec.name));
                assert!(x.is_finite() || !accepted, "{} = {x} accepted", spec.name);
            }
        }
        VarType::Integer | VarType::Enumeration => {
            let lo = spec.min.map_or(i32::MIN, |x| x as i32);
            let hi = spec.max.map_or(i32::MAX, |x| x as i32);
            let v = if u.arbitrary()? {
                u.int_in_range(lo.min(hi)..=hi.max(lo))?
            } else {
                u.arbitrary()?
            };
            if spec.check_range(f64::from(v)).is_ok() {
                let accepted = m.set_integer(vr, v).is_ok();
                trace(format_args!("set {} = {v}: {accepted}", spec.name));
            }
        }
        VarType::Boolean => {
            let b = u.arbitrary()?;
            let accepted = m.set_boolean(vr, b).is_ok();
            trace(format_args!("set {} = {b}: {accepted}", spec.name));
        }
        VarType::String => {}
    }
    Ok(())
}

/// With `FUZZ_TRACE` set, what the input does, to read a finding.
fn trace(what: std::fmt::Arguments) {
    if std::env::var_os("FUZZ_TRACE").is_some() {
        eprintln!("{what}");
    }
}

fn drive<M: Model>(u: &mut Unstructured) -> Result<()> {
    let mut m = M::new();
    let parameters: Vec<&VarSpec> = M::VARIABLES
        .iter()
        .filter(|v| v.causality == Causality::Parameter && v.variability != Variability::Constant)
        .collect();
    let inputs: Vec<&VarSpec> = M::VARIABLES
        .iter()
        .filter(|v| v.causality == Causality::Input)
        .collect();
    let tunable: Vec<&VarSpec> = parameters
        .iter()
        .copied()
        .filter(|v| v.variability == Variability::Tunable)
        .collect();
    for _ in 0..u.int_in_range(0..=12)? {
        let spec = *u.choose(&parameters)?;
        set(&mut m, spec, u)?;
    }
    for _ in 0..u.int_in_range(0..=4)? {
        let spec = *u.choose(&inputs)?;
        set(&mut m, spec, u)?;
    }
    let start = *u.choose(&[0.0, 0.5, -3.0, 1e9])?;
    let init = m.initialize(start);
    trace(format_args!(
        "initialize({start}): {:?}",
        init.as_ref().err()
    ));
    if init.is_err() || fmu_core::check_ranges(&m).is_err() {
        return Ok(());
    }
    outputs_finite(&m, "after initialization");
    let mut t = start;
    let mut h = 1e-3;
    for _ in 0..u.int_in_range(0..=40)? {
        match u.int_in_range(0..=9)? {
            0 => h = *u.choose(&[1e-3, 2e-3, 5e-4, 1e-2, 0.1, 1e-6])?,
            1 if !tunable.is_empty() => {
                let spec = *u.choose(&tunable)?;
                set(&mut m, spec, u)?;
            }
            2 | 3 => {
                let spec = *u.choose(&inputs)?;
                set(&mut m, spec, u)?;
            }
            _ => {}
        }
        let step = m.do_step(t, h);
        trace(format_args!(
            "doStep t = {t} h = {h}: {:?}",
            step.as_ref().err()
        ));
        if step.is_err() {
            break;
        }
        // A remark on the step, as the glue asks for it after every successful step:
        // handed over once, and never empty.
        if let Some(warning) = m.take_warning() {
            trace(format_args!("warning: {warning}"));
            assert!(!warning.is_empty(), "an empty step warning");
            assert_eq!(m.take_warning(), None, "a step warning handed over twice");
        }
        t += h;
        outputs_finite(&m, &format!("after the step to t = {t}"));
    }
    Ok(())
}

/// One fuzz input: the model driven until the input runs out.
pub fn run<M: Model>(bytes: &[u8]) {
    let _ = drive::<M>(&mut Unstructured::new(bytes));
}
