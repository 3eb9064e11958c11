//! Fuzzing of FMU-state deserialization on both packaged FMUs, as an ordinary test:
//! serialized states (fresh ones from this build and the kept seeds in
//! `fuzz/corpus/fmu_state/`) are mutated, half of them resealed with a valid checksum so the
//! edits reach the header checks, the declared ranges and the models' own `restore`.
//! Every input must be refused with fmi2Error and a message, or accepted into a state from
//! which doSteps either succeed with finite outputs or fail with a status; never a crash,
//! never NaN with fmi2OK.
//!
//! Kept seeds are named `<model>-N.bin`. Bounded: `FUZZ_CASES` mutated states per FMU (default 1500, a few seconds in release).
//! A failing case is shrunk by proptest and kept in `fuzz_fmu_state.regressions`.

use std::path::{Path, PathBuf};

use fmi2_import::Status;
use fmi2_import::{Fmu, ImportError, Instance};
use proptest::prelude::*;
use proptest::test_runner::{Config, FileFailurePersistence, TestRunner};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn fmu(name: &str) -> Fmu {
    let dir = std::env::var_os("CKCM_FMU_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target/fmu"));
    let path = dir.join(name);
    assert!(
        path.exists(),
        "{} not found: run `cargo xtask fmu` first",
        path.display()
    );
    Fmu::open(&path).unwrap()
}

fn cases() -> u32 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1500)
}

fn real_outputs(f: &Fmu) -> Vec<u32> {
    f.model_description()
        .model_variables
        .iter()
        .filter(|v| {
            v.causality == fmi2_md::Causality::Output && v.var_type() == fmi2_md::VarType::Real
        })
        .map(|v| v.value_reference)
        .collect()
}

/// Serialized states of `f` from this build: before and after initialization, after some
/// steps, with each integrator for the plant; plus the kept seeds for this model.
fn seeds(f: &Fmu, model: &str) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    let md = f.model_description();
    let integrator = md.variable_by_name("integrator").map(|v| {
        let dormand_prince = md
            .enumeration_item("integrator", "dormand_prince")
            .expect("Integrator item dormand_prince");
        (v.value_reference, dormand_prince)
    });
    for variant in 0..3 {
        let mut inst = f.instantiate("seed", true).unwrap();
        let s = inst.get_fmu_state().unwrap();
        out.push(inst.serialize_fmu_state(&s).unwrap());
        if let (Some((vr, dormand_prince)), 2) = (integrator, variant) {
            inst.set_integer(&[vr], &[dormand_prince]).unwrap();
        }
        inst.setup_experiment(None, 0.0, None).unwrap();
        inst.enter_initialization_mode().unwrap();
        inst.exit_initialization_mode().unwrap();
        for k in 0..(variant * 50) {
            inst.do_step(k as f64 * 1e-3, 1e-3, true).unwrap();
        }
        let s = inst.get_fmu_state().unwrap();
        out.push(inst.serialize_fmu_state(&s).unwrap());
    }
    let dir = root().join("fuzz/corpus/fmu_state");
    // `FUZZ_SAVE_SEEDS=1` keeps this build's states as seeds (they stay useful as inputs
    // after a format or GUID change: then they exercise the refusals).
    if std::env::var_os("FUZZ_SAVE_SEEDS").is_some() {
        for (i, bytes) in out.iter().enumerate() {
            std::fs::write(dir.join(format!("{model}-{i}.bin")), bytes).unwrap();
        }
    }
    let mut kept: Vec<PathBuf> = std::fs::read_dir(&dir)
        .expect("the kept corpus exists")
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(model))
        })
        .collect();
    kept.sort();
    out.extend(kept.iter().map(|p| std::fs::read(p).unwrap()));
    out
}

#[derive(Debug, Clone)]
enum Edit {
    Flip(usize, u8),
    Byte(usize, u8),
    /// Overwrite 8 bytes (at an offset taken modulo the length) with a striking f64.
    Real(usize, f64),
    /// Overwrite 4 bytes with a striking i32/u32.
    Word(usize, u32),
    Truncate(usize),
    Extend(Vec<u8>),
}

fn edit() -> impl Strategy<Value = Edit> {
    let real = prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(f64::NEG_INFINITY),
        Just(1e300),
        Just(-1e300),
        Just(0.0),
        Just(-0.0),
        Just(f64::MIN_POSITIVE),
        any::<f64>(),
    ];
    let word = prop_oneof![
        Just(0u32),
        Just(1),
        Just(u32::MAX),
        Just(i32::MAX as u32),
        Just(i32::MIN as u32),
        any::<u32>(),
    ];
    prop_oneof![
        3 => (any::<usize>(), 0u8..8).prop_map(|(i, b)| Edit::Flip(i, b)),
        2 => (any::<usize>(), any::<u8>()).prop_map(|(i, b)| Edit::Byte(i, b)),
        3 => (any::<usize>(), real).prop_map(|(i, x)| Edit::Real(i, x)),
        2 => (any::<usize>(), word).prop_map(|(i, x)| Edit::Word(i, x)),
        1 => any::<usize>().prop_map(Edit::Truncate),
        1 => prop::collection::vec(any::<u8>(), 1..16).prop_map(Edit::Extend),
    ]
}

/// Applies the edits to the bytes before the checksum; then reseals or keeps the old one.
fn mutate(bytes: &[u8], edits: &[Edit], reseal: bool) -> Vec<u8> {
    let body_len = bytes.len().saturating_sub(4);
    let mut body = bytes[..body_len].to_vec();
    let old_crc = bytes[body_len..].to_vec();
    for e in edits {
        let n = body.len();
        if n < 8 {
            break;
        }
        match e {
            Edit::Flip(i, b) => body[i % n] ^= 1 << b,
            Edit::Byte(i, b) => body[i % n] = *b,
            Edit::Real(i, x) => {
                let at = i % (n - 7);
                body[at..at + 8].copy_from_slice(&x.to_le_bytes());
            }
            Edit::Word(i, x) => {
                let at = i % (n - 3);
                body[at..at + 4].copy_from_slice(&x.to_le_bytes());
            }
            Edit::Truncate(i) => body.truncate(i % n),
            Edit::Extend(more) => body.extend_from_slice(more),
        }
    }
    if reseal {
        let crc = crc32fast::hash(&body);
        body.extend_from_slice(&crc.to_le_bytes());
    } else {
        body.extend_from_slice(&old_crc);
    }
    body
}

/// The property for one input; `accepted` counts the inputs that decoded.
fn check(
    f: &Fmu,
    outputs: &[u32],
    bytes: &[u8],
    accepted: &std::cell::Cell<u32>,
) -> Result<(), TestCaseError> {
    let mut inst: Instance = f.instantiate("fuzz", true).unwrap();
    let state = match inst.deserialize_fmu_state(bytes) {
        Ok(s) => s,
        Err(ImportError::Call {
            status, messages, ..
        }) => {
            prop_assert_eq!(status, Status::Error);
            prop_assert!(!messages.is_empty(), "refused without a message");
            return Ok(());
        }
        Err(e) => return Err(TestCaseError::fail(format!("unexpected {e}"))),
    };
    accepted.set(accepted.get() + 1);
    if inst.set_fmu_state(&state).is_err() {
        return Ok(());
    }
    let time = inst.last_successful_time().unwrap_or(0.0);
    let mut y = vec![0.0; outputs.len()];
    for k in 0..5 {
        match inst.do_step(time + f64::from(k) * 1e-3, 1e-3, true) {
            Ok(_) => {
                inst.get_real(outputs, &mut y).unwrap();
                prop_assert!(
                    y.iter().all(|x| x.is_finite()),
                    "fmi2OK with non-finite outputs {:?}",
                    y
                );
            }
            // Not in a state that steps, or the step was refused: a status, not a crash.
            Err(ImportError::Call { .. }) => return Ok(()),
            Err(e) => return Err(TestCaseError::fail(format!("unexpected {e}"))),
        }
    }
    Ok(())
}

fn fuzz(name: &str, model: &str) {
    let f = fmu(name);
    let outputs = real_outputs(&f);
    let seeds = seeds(&f, model);
    let accepted = std::cell::Cell::new(0);
    for s in &seeds {
        check(&f, &outputs, s, &accepted).unwrap();
    }
    // This build's six states decode (kept seeds of an older format need not).
    assert!(accepted.get() >= 6, "only {} seeds decode", accepted.get());
    accepted.set(0);
    let mut runner = TestRunner::new(Config {
        cases: cases(),
        failure_persistence: Some(Box::new(FileFailurePersistence::WithSource("regressions"))),
        source_file: Some(file!()),
        ..Config::default()
    });
    let strategy = (
        0..seeds.len(),
        prop::collection::vec(edit(), 1..6),
        any::<bool>(),
    );
    runner
        .run(&strategy, |(seed, edits, reseal)| {
            check(
                &f,
                &outputs,
                &mutate(&seeds[seed], &edits, reseal),
                &accepted,
            )
        })
        .unwrap();
    // The resealed edits must get past the header some of the time (e.g. a changed input
    // value is a valid state), or the fuzzing never reaches the models' restore.
    assert!(accepted.get() > 0, "{name}: no mutated state was accepted");
    eprintln!(
        "{name}: {} of {} mutated states accepted",
        accepted.get(),
        cases()
    );
}

#[test]
fn mutated_plant_states_are_refused_or_safe() {
    fuzz("CkcmPlant.fmu", "CkcmPlant");
}

#[test]
fn mutated_controller_states_are_refused_or_safe() {
    fuzz("HlcsController.fmu", "HlcsController");
}
