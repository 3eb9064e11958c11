//! Random sequences of FMI calls through `fmi2-import` on a packaged FMU (built by
//! `cargo xtask fmu`), each input a fresh instance: calls in any order, value references
//! declared or not, NaN and infinite values, odd step sizes, FMU states saved, restored,
//! serialized with flipped bytes, strings, input and output derivatives, status queries.
//! Every call returns a status; fmi2Fatal (the glue's answer
//! to a panic) is a finding, as is a NaN or infinity read with fmi2OK, a crash or a hang.
//!
//! The FMU's own code is not instrumented (it is a separate library), so this target steers
//! by the importer's coverage only; it is a random walk more than a guided search.
use std::path::{Path, PathBuf};

use fmi2_import::{Fmu, ImportError, Instance, Status};
use fmi2_md::VarType;
use libfuzzer_sys::arbitrary::{Result, Unstructured};

pub fn open(file: &str) -> Fmu {
    let dir = std::env::var_os("CKCM_FMU_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/fmu"));
    Fmu::open(dir.join(file)).expect("the packaged FMU: run `cargo xtask fmu` first")
}

/// Panics on fmi2Fatal; any other outcome is allowed.
fn checked(r: std::result::Result<Status, ImportError>, what: &str) -> bool {
    match r {
        Ok(_) => true,
        Err(ImportError::Call { status, .. }) => {
            assert!(status != Status::Fatal, "{what} returned fmi2Fatal");
            false
        }
        Err(_) => false,
    }
}

fn real(u: &mut Unstructured) -> Result<f64> {
    Ok(match u.int_in_range(0..=5)? {
        0 => f64::NAN,
        1 => f64::INFINITY,
        2 => f64::from(u.arbitrary::<i16>()?) / 64.0,
        3 => 10f64.powi(u.int_in_range(-320..=308)?),
        4 => 0.0,
        _ => f64::from_bits(u.arbitrary()?),
    })
}

/// Up to eight value references, mostly declared ones of one type (any number where the
/// model declares none of it).
fn vrs(u: &mut Unstructured, declared: &[u32]) -> Result<Vec<u32>> {
    let n = u.int_in_range(0..=8)?;
    (0..n)
        .map(|_| {
            Ok(if declared.is_empty() || u.ratio(1, 8)? {
                u.arbitrary()?
            } else {
                *u.choose(declared)?
            })
        })
        .collect()
}

fn session(fmu: &Fmu, u: &mut Unstructured) -> Result<()> {
    let md = fmu.model_description();
    let of = |t: VarType| -> Vec<u32> {
        md.model_variables
            .iter()
            .filter(|v| v.var_type() == t)
            .map(|v| v.value_reference)
            .collect()
    };
    let (reals, integers, booleans) = (
        of(VarType::Real),
        of(VarType::Integer),
        of(VarType::Boolean),
    );
    let strings = of(VarType::String);
    let integers: Vec<u32> = integers
        .into_iter()
        .chain(of(VarType::Enumeration))
        .collect();
    let Ok(mut inst): std::result::Result<Instance, _> = fmu.instantiate("fuzz", u.arbitrary()?)
    else {
        return Ok(());
    };
    let mut states = Vec::new();
    let mut t = 0.0;
    for _ in 0..u.int_in_range(0..=64)? {
        match u.int_in_range(0..=18)? {
            0 => {
                let tol = if u.arbitrary()? { Some(real(u)?) } else { None };
                let start = if u.arbitrary()? { 0.0 } else { real(u)? };
                let stop = if u.arbitrary()? { Some(real(u)?) } else { None };
                if checked(
                    inst.setup_experiment(tol, start, stop),
                    "fmi2SetupExperiment",
                ) {
                    t = start;
                }
            }
            1 => {
                checked(
                    inst.enter_initialization_mode(),
                    "fmi2EnterInitializationMode",
                );
            }
            2 => {
                checked(
                    inst.exit_initialization_mode(),
                    "fmi2ExitInitializationMode",
                );
            }
            3 => {
                let v = vrs(u, &reals)?;
                let x: Vec<f64> = v.iter().map(|_| real(u)).collect::<Result<_>>()?;
                checked(inst.set_real(&v, &x), "fmi2SetReal");
            }
            4 => {
                let v = vrs(u, &reals)?;
                let mut x = vec![0.0; v.len()];
                if checked(inst.get_real(&v, &mut x), "fmi2GetReal") {
                    assert!(
                        x.iter().all(|x| x.is_finite()),
                        "fmi2GetReal {v:?} gave {x:?}"
                    );
                }
            }
            5 => {
                let v = vrs(u, &integers)?;
                let x: Vec<i32> = v.iter().map(|_| u.arbitrary()).collect::<Result<_>>()?;
                checked(inst.set_integer(&v, &x), "fmi2SetInteger");
            }
            6 => {
                let v = vrs(u, &integers)?;
                let mut x = vec![0; v.len()];
                checked(inst.get_integer(&v, &mut x), "fmi2GetInteger");
            }
            7 => {
                let v = vrs(u, &booleans)?;
                let x: Vec<bool> = v.iter().map(|_| u.arbitrary()).collect::<Result<_>>()?;
                checked(inst.set_boolean(&v, &x), "fmi2SetBoolean");
            }
            8..=10 => {
                let h = match u.int_in_range(0..=3)? {
                    0 => real(u)?,
                    1 => 1e-2,
                    _ => 1e-3,
                };
                let at = if u.ratio(1, 8)? { real(u)? } else { t };
                if checked(inst.do_step(at, h, u.arbitrary()?), "fmi2DoStep") {
                    t = at + h;
                }
            }
            11 => {
                checked(inst.reset(), "fmi2Reset");
            }
            12 => {
                checked(inst.terminate(), "fmi2Terminate");
            }
            13 => match u.int_in_range(0..=2)? {
                0 => {
                    if let Ok(s) = inst.get_fmu_state() {
                        states.push(s);
                    }
                }
                1 if !states.is_empty() => {
                    let s = u.choose(&states)?;
                    checked(inst.set_fmu_state(s), "fmi2SetFMUstate");
                }
                _ if !states.is_empty() => {
                    let i = u.choose_index(states.len())?;
                    if let Ok(mut bytes) = inst.serialize_fmu_state(&states[i]) {
                        if u.arbitrary()? && !bytes.is_empty() {
                            let at = u.choose_index(bytes.len())?;
                            bytes[at] ^= u.arbitrary::<u8>()?;
                        }
                        if let Ok(s) = inst.deserialize_fmu_state(&bytes) {
                            states.push(s);
                        }
                    }
                }
                _ => {}
            },
            14 => {
                let unknowns = vrs(u, &reals)?;
                let knowns = vrs(u, &reals)?;
                let dv: Vec<f64> = knowns.iter().map(|_| real(u)).collect::<Result<_>>()?;
                let mut out = vec![0.0; unknowns.len()];
                checked(
                    inst.get_directional_derivative(&unknowns, &knowns, &dv, &mut out),
                    "fmi2GetDirectionalDerivative",
                );
            }
            15 => {
                let v = vrs(u, &reals)?;
                let orders: Vec<i32> = v
                    .iter()
                    .map(|_| u.int_in_range(-1..=3))
                    .collect::<Result<_>>()?;
                if u.arbitrary()? {
                    let x: Vec<f64> = v.iter().map(|_| real(u)).collect::<Result<_>>()?;
                    checked(
                        inst.set_real_input_derivatives(&v, &orders, &x),
                        "fmi2SetRealInputDerivatives",
                    );
                } else {
                    let mut x = vec![0.0; v.len()];
                    checked(
                        inst.get_real_output_derivatives(&v, &orders, &mut x),
                        "fmi2GetRealOutputDerivatives",
                    );
                }
            }
            16 => {
                let v = vrs(u, &strings)?;
                if u.arbitrary()? {
                    let texts = ["", "line", "x\u{1b}[31m", "\u{fffd}"];
                    let x: Vec<&str> = v
                        .iter()
                        .map(|_| u.choose(&texts).copied())
                        .collect::<Result<_>>()?;
                    checked(inst.set_string(&v, &x), "fmi2SetString");
                } else {
                    let _ = inst.get_string(&v);
                }
            }
            17 => {
                checked(inst.cancel_step(), "fmi2CancelStep");
                let _ = inst.integer_status(u.arbitrary()?);
                let _ = inst.pending_status();
                let _ = inst.is_terminated();
            }
            _ => {
                let all = ["logAll", "logError", "logStatusError", "nonsense", ""];
                let n = u.int_in_range(0..=3)?;
                let cats: Vec<&str> = (0..n)
                    .map(|_| u.choose(&all).copied())
                    .collect::<Result<_>>()?;
                checked(
                    inst.set_debug_logging(u.arbitrary()?, &cats),
                    "fmi2SetDebugLogging",
                );
                let _ = inst.do_step_status();
                let _ = inst.last_successful_time();
            }
        }
    }
    drop(states);
    drop(inst);
    Ok(())
}

pub fn run(fmu: &Fmu, bytes: &[u8]) {
    let _ = session(fmu, &mut Unstructured::new(bytes));
}
