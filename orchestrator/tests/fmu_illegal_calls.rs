//! Every FMI 2.0 function in every reachable state, on both packaged FMUs (loaded with
//! `fmi2-import`, so each call crosses the real C ABI): no crash, a call the standard's
//! state table forbids is fmi2Error naming the state, an allowed call never is refused as
//! an illegal sequence, and the statuses the standard fixes hold (unavailable status kinds
//! are fmi2Discard, unsupported capabilities fmi2Error).
//!
//! The glue's table is checked against an independent transcription of FMI 2.0 §4.2.4 in
//! `fmi/fmi2-export/tests/lifecycle.rs`; here it is the reference. Left out: fmi2FreeInstance
//! and fmi2FreeFMUstate (run on drop, their status is not observable), and the Fatal state,
//! which these FMUs reach only through a panic (covered with a panicking test model there).

use std::path::{Path, PathBuf};

use fmi2_export::{FmiState, Function};
use fmi2_import::Status;
use fmi2_import::{Fmu, FmuState, ImportError, Instance};

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

/// Value references for the typed get/set calls: a Real output, a Real input, an Integer
/// (or Enumeration) and a Boolean; a value reference no variable has where the FMU has no
/// variable of that type (the call then fails on it, after the state check).
fn some_vrs(f: &Fmu) -> [u32; 4] {
    use fmi2_md::{Causality, VarType};
    let md = f.model_description();
    let find = |ok: &dyn Fn(Causality, VarType) -> bool| {
        md.model_variables
            .iter()
            .find(|v| ok(v.causality, v.var_type()))
            .map_or(999_999, |v| v.value_reference)
    };
    [
        find(&|c, t| c == Causality::Output && t == VarType::Real),
        find(&|c, t| c == Causality::Input && t == VarType::Real),
        find(&|_, t| matches!(t, VarType::Integer | VarType::Enumeration)),
        find(&|_, t| t == VarType::Boolean),
    ]
}

/// An instance brought into `state`; `snap` is an FMU state taken right after instantiation.
fn instance_in(f: &Fmu, state: FmiState) -> (Instance, FmuState, Vec<u8>) {
    let mut inst = f.instantiate("sweep", true).unwrap();
    let snap = inst.get_fmu_state().unwrap();
    let bytes = inst.serialize_fmu_state(&snap).unwrap();
    if state != FmiState::Instantiated {
        inst.setup_experiment(None, 0.0, None).unwrap();
        inst.enter_initialization_mode().unwrap();
    }
    match state {
        FmiState::Instantiated | FmiState::InitializationMode => {}
        FmiState::StepComplete => {
            inst.exit_initialization_mode().unwrap();
        }
        FmiState::Terminated => {
            inst.exit_initialization_mode().unwrap();
            inst.terminate().unwrap();
        }
        FmiState::StepFailed | FmiState::StepCanceled => {
            // A StepComplete state with its FMI state code rewritten (and resealed): the
            // controller never discards a step, and no synchronous FMU cancels one.
            inst.exit_initialization_mode().unwrap();
            let s = inst.get_fmu_state().unwrap();
            let mut edited = inst.serialize_fmu_state(&s).unwrap();
            let md = f.model_description();
            let at = 20 + md.model_identifier().unwrap().len() + md.guid.len();
            let code: u32 = if state == FmiState::StepFailed { 3 } else { 4 };
            edited[at..at + 4].copy_from_slice(&code.to_le_bytes());
            let body = edited.len() - 4;
            let crc = crc32fast::hash(&edited[..body]);
            edited[body..].copy_from_slice(&crc.to_le_bytes());
            let restored = inst.deserialize_fmu_state(&edited).unwrap();
            inst.set_fmu_state(&restored).unwrap();
        }
        FmiState::Fatal => unreachable!("not swept"),
    }
    inst.take_log();
    (inst, snap, bytes)
}

fn status(r: Result<impl Sized, ImportError>) -> Status {
    match r {
        Ok(_) => Status::Ok,
        Err(ImportError::Call { status, .. }) => status,
        Err(e) => panic!("not an FMU status: {e}"),
    }
}

/// Calls `function` once with plausible arguments; returns its status.
fn call(inst: &mut Instance, f: &Fmu, function: Function, snap: &FmuState, bytes: &[u8]) -> Status {
    let [out, input, integer, flag] = some_vrs(f);
    // The Integer's start value, a value it may always hold.
    let start = f
        .model_description()
        .model_variables
        .iter()
        .find(|v| v.value_reference == integer)
        .and_then(|v| v.start_as_f64())
        .map_or(0, |x| x as i32);
    let mut real = [0.0];
    let mut int = [0];
    let mut boolean = [false];
    match function {
        Function::SetDebugLogging => status(inst.set_debug_logging(true, &[])),
        Function::SetupExperiment => status(inst.setup_experiment(None, 0.0, None)),
        Function::EnterInitializationMode => status(inst.enter_initialization_mode()),
        Function::ExitInitializationMode => status(inst.exit_initialization_mode()),
        Function::Terminate => status(inst.terminate()),
        Function::Reset => status(inst.reset()),
        Function::GetReal => status(inst.get_real(&[out], &mut real)),
        Function::GetInteger => status(inst.get_integer(&[integer], &mut int)),
        Function::GetBoolean => status(inst.get_boolean(&[flag], &mut boolean)),
        Function::GetString => status(inst.get_string(&[999_999])),
        Function::SetReal => status(inst.set_real(&[input], &[0.5])),
        Function::SetInteger => status(inst.set_integer(&[integer], &[start])),
        Function::SetBoolean => status(inst.set_boolean(&[flag], &[true])),
        Function::SetString => status(inst.set_string(&[999_999], &["x"])),
        Function::GetFmuState => status(inst.get_fmu_state()),
        Function::SetFmuState => status(inst.set_fmu_state(snap)),
        Function::SerializedFmuStateSize | Function::SerializeFmuState => {
            status(inst.serialize_fmu_state(snap))
        }
        Function::DeSerializeFmuState => status(inst.deserialize_fmu_state(bytes)),
        Function::GetDirectionalDerivative => {
            status(inst.get_directional_derivative(&[out], &[input], &[1.0], &mut real))
        }
        Function::SetRealInputDerivatives => {
            status(inst.set_real_input_derivatives(&[input], &[1], &[0.0]))
        }
        Function::GetRealOutputDerivatives => {
            status(inst.get_real_output_derivatives(&[out], &[1], &mut real))
        }
        Function::DoStep => status(inst.do_step(0.0, 1e-3, true)),
        Function::CancelStep => status(inst.cancel_step()),
        Function::GetStatus => status(inst.do_step_status()),
        Function::GetRealStatus => status(inst.last_successful_time()),
        Function::GetIntegerStatus => status(inst.integer_status(2)),
        Function::GetBooleanStatus => status(inst.is_terminated()),
        Function::GetStringStatus => status(inst.pending_status()),
        Function::FreeInstance | Function::FreeFmuState => unreachable!("not swept"),
    }
}

#[test]
fn every_function_in_every_state_of_both_fmus() {
    let mut calls = 0;
    for name in ["CkcmPlant.fmu", "HlcsController.fmu"] {
        let f = fmu(name);
        for state in FmiState::ALL {
            if state == FmiState::Fatal {
                continue;
            }
            for function in Function::ALL {
                if matches!(function, Function::FreeInstance | Function::FreeFmuState) {
                    continue;
                }
                let (mut inst, snap, bytes) = instance_in(&f, state);
                let got = call(&mut inst, &f, function, &snap, &bytes);
                calls += 1;
                let log: Vec<String> = inst.take_log().iter().map(|r| r.message.clone()).collect();
                let what = format!("{name}: {} in {state}: {got:?} {log:?}", function.name());
                let illegal = format!(
                    "{}: illegal call sequence in state {state}",
                    function.name()
                );
                if !function.allowed_in(state) {
                    assert_eq!(got, Status::Error, "{what}");
                    assert!(log.iter().any(|m| m.starts_with(&illegal)), "{what}");
                    // fmi2Error leaves the instance in Terminated, where reset recovers it.
                    inst.reset()
                        .unwrap_or_else(|e| panic!("{what}: reset: {e}"));
                    continue;
                }
                assert!(
                    !log.iter().any(|m| m.contains("illegal call sequence")),
                    "{what}"
                );
                let expected = match function {
                    Function::GetIntegerStatus | Function::GetStringStatus => Some(Status::Discard),
                    Function::GetDirectionalDerivative
                    | Function::SetRealInputDerivatives
                    | Function::GetRealOutputDerivatives => Some(Status::Error),
                    Function::GetRealStatus | Function::GetBooleanStatus => Some(Status::Ok),
                    _ => None,
                };
                if let Some(expected) = expected {
                    assert_eq!(got, expected, "{what}");
                }
                assert!(
                    matches!(
                        got,
                        Status::Ok | Status::Warning | Status::Discard | Status::Error
                    ),
                    "{what}"
                );
            }
        }
    }
    assert_eq!(calls, 2 * 6 * 29);
}
