//! Export glue: FMU-state snapshots and their serialized form.
// The tests' logger is truly C-variadic under Miri (docs/testing.md).
#![cfg_attr(miri, feature(c_variadic))]

#[path = "support/mod.rs"]
#[macro_use]
mod export_support;

use std::ptr;
use std::sync::atomic::{AtomicUsize, Ordering};

use export_support::{
    Fmu, GUID, Oscillator, Other, fail, instantiate_quiet, state_code_offset, status, vr,
};
use fmi2_export::{FmiState, SERIALIZED_MAGIC, abi};
use fmi2_sys::Status;
use fmi2_sys::{Fmi2Component, Fmi2FmuState};
use fmu_core::Model;

/// Steps `n` times from the instance's current time with a force ramp; returns (x, v).
fn run(fmu: &Fmu, from_step: u32, n: u32) -> Vec<(u64, u64)> {
    (from_step..from_step + n)
        .map(|k| {
            assert_eq!(
                fmu.set_real(&[vr::FORCE], &[f64::from(k) * 0.1]),
                Status::Ok
            );
            assert_eq!(
                fmu.do_step(f64::from(k) * 0.01, 0.01),
                Status::Ok,
                "{:?}",
                fmu.log.messages()
            );
            (fmu.real(vr::X).to_bits(), fmu.real(vr::V).to_bits())
        })
        .collect()
}

#[test]
fn get_and_set_state_round_trip() {
    let fmu = Fmu::initialized("roundtrip");
    run(&fmu, 0, 20);
    let mut snap: Fmi2FmuState = ptr::null_mut();
    assert_eq!(fmu.get_state(&mut snap), Status::Ok);
    assert!(!snap.is_null());
    let first = run(&fmu, 20, 30);
    assert_eq!(fmu.set_state(snap), Status::Ok);
    assert_eq!(fmu.last_successful_time(), (Status::Ok, a_time_after(20)));
    let again = run(&fmu, 20, 30);
    assert_eq!(first, again);

    // Overwriting the same snapshot in place keeps the pointer.
    let before = snap;
    assert_eq!(fmu.get_state(&mut snap), Status::Ok);
    assert_eq!(snap, before);
    assert_eq!(fmu.set_state(snap), Status::Ok);
    assert_eq!(fmu.last_successful_time().1, a_time_after(50));

    // The FMI state is part of the snapshot: a terminated instance comes back to StepComplete.
    assert_eq!(fmu.terminate(), Status::Ok);
    assert_eq!(fmu.set_state(snap), Status::Ok);
    assert_eq!(fmu.state(), Some(FmiState::StepComplete));
    assert_eq!(fmu.free_state(&mut snap), Status::Ok);
    assert!(snap.is_null());
}

#[test]
fn set_state_recovers_from_an_error_and_a_discard() {
    let fmu = Fmu::initialized("recover");
    run(&fmu, 0, 5);
    let mut snap = ptr::null_mut();
    assert_eq!(fmu.get_state(&mut snap), Status::Ok);
    let expected = run(&fmu, 5, 5);
    for mode in [fail::ERROR, fail::DISCARD] {
        assert_eq!(fmu.set_state(snap), Status::Ok);
        assert_eq!(fmu.set_integer(&[vr::FAIL_MODE], &[mode]), Status::Ok);
        assert_ne!(fmu.do_step(0.05, 0.01), Status::Ok);
        assert_ne!(fmu.state(), Some(FmiState::StepComplete));
        assert_eq!(fmu.set_state(snap), Status::Ok);
        assert_eq!(fmu.state(), Some(FmiState::StepComplete));
        assert_eq!(fmu.terminated_flag(), (Status::Ok, 0));
        assert_eq!(run(&fmu, 5, 5), expected);
    }
    assert_eq!(fmu.free_state(&mut snap), Status::Ok);
}

#[test]
fn set_state_rejects_null_and_foreign_snapshots() {
    let fmu = Fmu::initialized("reject");
    assert_eq!(fmu.set_state(ptr::null_mut()), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2SetFMUstate: argument FMUstate is NULL")
    );

    // A snapshot of another model.
    let other = instantiate_quiet::<Other>("other");
    assert!(!other.is_null());
    let mut foreign = ptr::null_mut();
    // SAFETY: live Other instance, valid slot.
    assert_eq!(
        status(unsafe { abi::get_fmu_state::<Other>(other, &mut foreign) }),
        Status::Ok
    );
    let fmu = Fmu::initialized("reject2");
    assert_eq!(fmu.set_state(foreign), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2SetFMUstate: FMUstate is not an FMU state of this model (Oscillator")
    );
    // Nor can it be freed or overwritten through this model.
    let fmu = Fmu::initialized("reject3");
    let mut slot = foreign;
    assert_eq!(fmu.free_state(&mut slot), Status::Error);
    assert_eq!(slot, foreign);
    let fmu = Fmu::initialized("reject4");
    assert_eq!(fmu.get_state(&mut slot), Status::Error);
    assert!(
        fmu.log
            .contains("fmi2GetFMUstate: *FMUstate is not an FMU state of this model")
    );
    // A component is not a snapshot either.
    let fmu = Fmu::initialized("reject5");
    assert_eq!(fmu.set_state(fmu.c), Status::Error);
    // SAFETY: live Other instance and its own snapshot.
    unsafe {
        assert_eq!(
            status(abi::free_fmu_state::<Other>(other, &mut foreign)),
            Status::Ok
        );
        abi::free_instance::<Other>(other);
    }
}

#[test]
fn serialized_state_continues_bit_identically_in_a_fresh_instance() {
    let a = Fmu::initialized("a");
    run(&a, 0, 37);
    let mut snap = ptr::null_mut();
    assert_eq!(a.get_state(&mut snap), Status::Ok);
    let bytes = a.serialize(snap);
    assert_eq!(a.free_state(&mut snap), Status::Ok);
    assert_eq!(&bytes[..8], &SERIALIZED_MAGIC);
    let expected = run(&a, 37, 40);

    // A fresh instance, never initialized: restoring brings it to StepComplete at t = 0.37.
    let b = Fmu::new("b");
    let mut restored = ptr::null_mut();
    assert_eq!(
        b.deserialize(&bytes, &mut restored),
        Status::Ok,
        "{:?}",
        b.log.messages()
    );
    assert_eq!(b.set_state(restored), Status::Ok);
    assert_eq!(b.free_state(&mut restored), Status::Ok);
    assert_eq!(b.state(), Some(FmiState::StepComplete));
    assert_eq!(
        b.last_successful_time().1.to_bits(),
        a_time_after(37).to_bits()
    );
    assert_eq!(run(&b, 37, 40), expected);

    // Serializing the restored state gives the same bytes (the format is canonical).
    let c = Fmu::new("c");
    let mut s = ptr::null_mut();
    assert_eq!(c.deserialize(&bytes, &mut s), Status::Ok);
    assert_eq!(c.serialize(s), bytes);
    // A live snapshot in FMUstate is reused, as fmi2GetFMUstate reuses one (and as fmpy's
    // `deSerializeFMUstate(bytes, state)` expects): the same handle, now holding the
    // deserialized state, and no second allocation left behind.
    let mut other = ptr::null_mut();
    assert_eq!(a.get_state(&mut other), Status::Ok);
    let later = a.serialize(other);
    assert_eq!(a.free_state(&mut other), Status::Ok);
    assert_ne!(later, bytes);
    let previous = s;
    assert_eq!(c.deserialize(&later, &mut s), Status::Ok);
    assert_eq!(s, previous);
    assert_eq!(c.serialize(s), later);
    assert_eq!(c.free_state(&mut s), Status::Ok);
    // A stale or uninitialised value is not read (this one would crash if it were): a new
    // snapshot is made.
    let mut junk = 0x1000 as Fmi2FmuState;
    assert_eq!(c.deserialize(&bytes, &mut junk), Status::Ok);
    assert_ne!(junk, 0x1000 as Fmi2FmuState);
    assert_eq!(c.serialize(junk), bytes);
    assert_eq!(c.free_state(&mut junk), Status::Ok);
}

/// The experiment's tolerance, which only the serialized form shows, travels with a state.
#[test]
fn a_serialized_state_keeps_the_experiments_tolerance() {
    let a = Fmu::new("tol");
    // SAFETY: our live instance.
    let s = unsafe { abi::setup_experiment::<Oscillator>(a.c, 1, 1e-6, 0.0, 0, 0.0) };
    assert_eq!(status(s), Status::Ok);
    assert_eq!(a.enter_init(), Status::Ok);
    assert_eq!(a.exit_init(), Status::Ok);
    let bytes = state_bytes(&a);
    let tolerance = 1e-6_f64.to_le_bytes();
    assert!(bytes.windows(8).any(|w| w == tolerance));
    restore_in_new(&bytes, "tol-b");
}

/// The current state of `fmu`, serialized (the snapshot taken for it is freed).
fn state_bytes(fmu: &Fmu) -> Vec<u8> {
    let mut snap = ptr::null_mut();
    assert_eq!(fmu.get_state(&mut snap), Status::Ok);
    let bytes = fmu.serialize(snap);
    assert_eq!(fmu.free_state(&mut snap), Status::Ok);
    bytes
}

/// A new instance `name` set to the serialized state `bytes`, after checking that the
/// deserialized state serializes to the same bytes (nothing was lost on the way).
fn restore_in_new(bytes: &[u8], name: &str) -> Fmu {
    let fmu = Fmu::new(name);
    let mut snap = ptr::null_mut();
    assert_eq!(fmu.deserialize(bytes, &mut snap), Status::Ok);
    assert_eq!(
        fmu.serialize(snap),
        bytes,
        "{name}: the same state came back"
    );
    assert_eq!(fmu.set_state(snap), Status::Ok);
    assert_eq!(fmu.free_state(&mut snap), Status::Ok);
    fmu
}

/// What the glue keeps beside the model travels with a serialized state: a discarded
/// step's request to terminate, and values set in Initialization Mode that the model has
/// not yet been initialized with.
#[test]
fn a_serialized_state_keeps_the_termination_request_and_unapplied_values() {
    let discarded = Fmu::initialized("discarded");
    run(&discarded, 0, 3);
    assert_eq!(
        discarded.set_integer(&[vr::FAIL_MODE], &[fail::DISCARD]),
        Status::Ok
    );
    assert_eq!(discarded.do_step(0.03, 0.01), Status::Discard);
    assert_eq!(discarded.terminated_flag(), (Status::Ok, 1));
    let restored = restore_in_new(&state_bytes(&discarded), "discarded-b");
    assert_eq!(restored.state(), Some(FmiState::StepFailed));
    assert_eq!(restored.terminated_flag(), (Status::Ok, 1));

    let set = Fmu::new("set-in-init");
    assert_eq!(set.setup(0.0, None), Status::Ok);
    assert_eq!(set.enter_init(), Status::Ok);
    assert_eq!(set.set_real(&[vr::MASS], &[4.0]), Status::Ok);
    let restored = restore_in_new(&state_bytes(&set), "set-in-init-b");
    assert_eq!(restored.state(), Some(FmiState::InitializationMode));
    assert_eq!(restored.real(vr::OMEGA), set.real(vr::OMEGA));
}

/// States at the edges of what fmi2SetupExperiment and fmi2DoStep allow deserialize: an
/// experiment that ends where it starts, and a time one tolerance past the stop time.
#[test]
fn states_at_the_edges_of_the_experiment_deserialize() {
    let round_trips = |fmu: &Fmu| {
        let (s, msgs) = try_deserialize(&state_bytes(fmu));
        assert_eq!(s, Status::Ok, "{msgs:?}");
    };
    let empty = Fmu::new("empty");
    assert_eq!(empty.setup(1.0, Some(1.0)), Status::Ok);
    assert_eq!(empty.enter_init(), Status::Ok);
    assert_eq!(empty.exit_init(), Status::Ok);
    round_trips(&empty);

    let edge = Fmu::new("edge");
    assert_eq!(edge.setup(0.0, Some(1.0)), Status::Ok);
    assert_eq!(edge.enter_init(), Status::Ok);
    assert_eq!(edge.exit_init(), Status::Ok);
    // 1 + 1e-9: the stop time plus its tolerance, 1e-9·max(1, |t|).
    assert_eq!(edge.do_step(0.0, 1.0 + 1e-9), Status::Ok);
    round_trips(&edge);
}

/// The FMU time after `n` steps of 0.01 from 0 with cp = k·0.01.
fn a_time_after(n: u32) -> f64 {
    f64::from(n - 1) * 0.01 + 0.01
}

#[test]
fn serialize_needs_the_exact_size() {
    let fmu = Fmu::initialized("size");
    let mut snap = ptr::null_mut();
    assert_eq!(fmu.get_state(&mut snap), Status::Ok);
    let bytes = fmu.serialize(snap);
    // Header, 96 payload bytes, 4 checksum bytes.
    let expected_len = state_code_offset() + 60 + 96 + 4;
    assert_eq!(bytes.len(), expected_len);
    let mut buf = vec![0u8; bytes.len() + 1];
    // SAFETY: live instance, snapshot, buffer of buf.len() bytes.
    let s = unsafe {
        abi::serialize_fmu_state::<Oscillator>(fmu.c, snap, buf.as_mut_ptr().cast(), buf.len())
    };
    assert_eq!(status(s), Status::Error);
    assert!(fmu.log.contains(&format!(
        "fmi2SerializeFMUstate: size {} does not match the serialized size {}",
        bytes.len() + 1,
        bytes.len()
    )));
    // The snapshot is still ours to free, and FreeFMUstate is allowed in Error.
    let mut s2 = snap;
    assert_eq!(fmu.free_state(&mut s2), Status::Ok);
}

/// Deserializes `bytes` into a fresh instance; returns the status and the messages.
fn try_deserialize(bytes: &[u8]) -> (Status, Vec<String>) {
    let fmu = Fmu::new("deser");
    let mut slot = ptr::null_mut();
    let s = fmu.deserialize(bytes, &mut slot);
    assert!(slot.is_null() || s == Status::Ok);
    if !slot.is_null() {
        assert_eq!(fmu.free_state(&mut slot), Status::Ok);
    }
    (s, fmu.log.messages())
}

fn good_bytes() -> Vec<u8> {
    let fmu = Fmu::initialized("good");
    run(&fmu, 0, 3);
    state_bytes(&fmu)
}

/// `body` (a serialized state without its checksum) with a fresh CRC-32 appended, so a
/// deliberate edit reaches the field checks behind the checksum.
fn sealed(mut body: Vec<u8>) -> Vec<u8> {
    let crc = crc32fast::hash(&body);
    body.extend_from_slice(&crc.to_le_bytes());
    body
}

/// A state whose checksum is right but whose values break a declared range (written by
/// hand, or by another build) is refused naming the value: no set call checked it.
#[test]
fn a_sealed_state_holding_a_value_out_of_its_range_is_refused() {
    let fmu = Fmu::initialized("ranged");
    let marker = 0.123_456_789_f64;
    assert_eq!(fmu.set_real(&[vr::DAMPING], &[marker]), Status::Ok);
    let good = state_bytes(&fmu);
    let mut body = good[..good.len() - 4].to_vec();
    let at = body
        .windows(8)
        .position(|w| w == marker.to_le_bytes())
        .expect("the damping's bytes are in the state");
    body[at..at + 8].copy_from_slice(&(-1.0_f64).to_le_bytes());
    let (s, msgs) = try_deserialize(&sealed(body));
    assert_eq!(s, Status::Error);
    assert!(
        msgs.iter()
            .any(|m| m.contains("the state holds damping = -1 is outside its range [0, inf]")),
        "{msgs:?}"
    );
}

#[test]
fn corrupt_buffers_are_rejected_with_a_reason() {
    let good = good_bytes();
    assert_eq!(try_deserialize(&good).0, Status::Ok);
    // Everything but the 96 payload bytes: header and checksum.
    let header = good.len() - 96;
    let body = good[..good.len() - 4].to_vec();
    assert_eq!(
        sealed(body.clone()),
        good,
        "the checksum is a CRC-32 of the rest"
    );
    let expect = |bytes: &[u8], needle: &str| {
        let (s, msgs) = try_deserialize(bytes);
        assert_eq!(s, Status::Error, "{needle}");
        assert!(
            msgs.iter()
                .any(|m| m.starts_with("fmi2DeSerializeFMUstate: ") && m.contains(needle)),
            "expected '{needle}' in {msgs:?}"
        );
    };

    expect(
        &[],
        &format!("buffer truncated: 0 bytes, header needs {header}"),
    );
    expect(
        &good[..40],
        &format!("buffer truncated: 40 bytes, header needs {header}"),
    );
    expect(
        &good[..header - 1],
        &format!(
            "buffer truncated: {} bytes, header needs {header}",
            header - 1
        ),
    );
    // Cut or extended without a new checksum: the checksum catches it.
    expect(&good[..good.len() - 1], "checksum mismatch");
    let mut long = good.clone();
    long.push(0);
    expect(&long, "checksum mismatch");
    // Every single-bit flip after the version is caught by the checksum.
    for i in 12..good.len() {
        for bit in 0..8 {
            let mut flipped = good.clone();
            flipped[i] ^= 1 << bit;
            let (s, msgs) = try_deserialize(&flipped);
            assert_eq!(s, Status::Error, "bit {bit} of byte {i}");
            assert!(
                msgs.iter().any(|m| m.contains("checksum mismatch")),
                "bit {bit} of byte {i}: {msgs:?}"
            );
        }
    }
    // With a valid checksum, the length fields are still checked.
    let mut short = body.clone();
    short.pop();
    expect(
        &sealed(short),
        &format!(
            "buffer truncated: {} bytes, header announces {}",
            good.len() - 1,
            good.len()
        ),
    );
    let mut long = body.clone();
    long.push(0);
    expect(
        &sealed(long),
        &format!(
            "buffer too long: {} bytes, header announces {}",
            good.len() + 1,
            good.len()
        ),
    );

    let mut magic = good.clone();
    magic[0] = b'X';
    expect(&magic, "wrong magic bytes");
    let mut version = good.clone();
    version[8..12].copy_from_slice(&1u32.to_le_bytes());
    expect(
        &version,
        "unsupported format version 1, this FMU reads version 2",
    );
    let mut guid = body.clone();
    let g = 20 + Oscillator::MODEL_IDENTIFIER.len();
    guid[g] = b'#';
    expect(
        &sealed(guid),
        &format!("but this FMU is 'Oscillator' with GUID '{GUID}'"),
    );
    let at = state_code_offset();
    // 6 is Fatal: no snapshot is taken there, so none may bring an instance into it.
    for code in [6u32, 7] {
        let mut state = body.clone();
        state[at..at + 4].copy_from_slice(&code.to_le_bytes());
        expect(&sealed(state), &format!("invalid FMI state code {code}"));
    }
    let mut flags = body.clone();
    flags[at + 4..at + 8].copy_from_slice(&0x100u32.to_le_bytes());
    expect(&sealed(flags), "unknown flag bits 0x100");
    let mut time = body.clone();
    time[at + 12 + 24..at + 12 + 32].copy_from_slice(&f64::NAN.to_le_bytes());
    expect(&sealed(time), "a time field is not finite");
    // Times no call sequence reaches: a stop time before the start, a time past the stop.
    let real = |i: usize| at + 12 + 8 * i;
    let mut stop = body.clone();
    stop[real(1)..real(1) + 8].copy_from_slice(&(-1.0f64).to_le_bytes());
    expect(&sealed(stop), "stop time -1 is before the start time 0");
    let mut late = body.clone();
    late[real(3)..real(3) + 8].copy_from_slice(&11.0f64.to_le_bytes());
    expect(&sealed(late), "time 11 is beyond the stop time 10");
    let mut payload = body.clone();
    payload.truncate(payload.len() - 8);
    let p = at + 12 + 40;
    payload[p..p + 8].copy_from_slice(&88u64.to_le_bytes());
    expect(&sealed(payload), "payload has 88 bytes, expected 96");

    // A state of another model, serialized by that model's glue.
    let other = instantiate_quiet::<Other>("other");
    // SAFETY: a live instance; its snapshot and buffer are released below.
    unsafe {
        let mut snap = ptr::null_mut();
        assert_eq!(
            status(abi::get_fmu_state::<Other>(other, &mut snap)),
            Status::Ok
        );
        let mut size = 0;
        assert_eq!(
            status(abi::serialized_fmu_state_size::<Other>(
                other, snap, &mut size
            )),
            Status::Ok
        );
        let mut foreign = vec![0u8; size];
        assert_eq!(
            status(abi::serialize_fmu_state::<Other>(
                other,
                snap,
                foreign.as_mut_ptr().cast(),
                size
            )),
            Status::Ok
        );
        assert_eq!(
            status(abi::free_fmu_state::<Other>(other, &mut snap)),
            Status::Ok
        );
        abi::free_instance::<Other>(other);
        expect(
            &foreign,
            "state belongs to model 'Other' with GUID '{other-model}'",
        );
    }

    // NULL buffer with a size, and NULL slot pointer.
    let fmu = Fmu::new("nulls");
    // SAFETY: NULL buffer with size > 0 must be refused.
    let s = unsafe {
        abi::de_serialize_fmu_state::<Oscillator>(fmu.c, ptr::null(), 10, &mut ptr::null_mut())
    };
    assert_eq!(status(s), Status::Error);
    assert!(
        fmu.log
            .contains("argument serializedState[] is NULL but its length is 10")
    );
    let fmu = Fmu::new("nulls2");
    // SAFETY: NULL FMUstate* must be refused.
    let s = unsafe {
        abi::de_serialize_fmu_state::<Oscillator>(
            fmu.c,
            good.as_ptr().cast(),
            good.len(),
            ptr::null_mut(),
        )
    };
    assert_eq!(status(s), Status::Error);
}

/// Directory through which the parent and child halves of the cross-process test talk.
const CHILD_DIR: &str = "FMI2_EXPORT_TEST_CHILD_DIR";

#[test]
fn serialized_state_restores_in_another_process() {
    let a = Fmu::initialized("parent");
    run(&a, 0, 25);
    let mut snap = ptr::null_mut();
    assert_eq!(a.get_state(&mut snap), Status::Ok);
    let bytes = a.serialize(snap);
    assert_eq!(a.free_state(&mut snap), Status::Ok);
    let expected: Vec<u8> = run(&a, 25, 40)
        .into_iter()
        .flat_map(|(x, v)| [x.to_le_bytes(), v.to_le_bytes()].concat())
        .collect();

    let dir = std::env::temp_dir().join(format!("fmi2-export-state-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("state.bin"), &bytes).unwrap();
    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "child_continues_serialized_state",
            "--ignored",
            "--test-threads=1",
        ])
        .env(CHILD_DIR, &dir)
        .output()
        .unwrap();
    let result = std::fs::read(dir.join("result.bin"));
    std::fs::remove_dir_all(&dir).unwrap();
    assert!(
        out.status.success(),
        "child failed: {}",
        String::from_utf8_lossy(&out.stdout)
    );
    assert_eq!(
        result.unwrap(),
        expected,
        "the other process continued differently"
    );
}

#[test]
#[ignore = "child half of serialized_state_restores_in_another_process, run by it"]
fn child_continues_serialized_state() {
    let Some(dir) = std::env::var_os(CHILD_DIR) else {
        eprintln!("{CHILD_DIR} not set: nothing to do outside the parent test");
        return;
    };
    let dir = std::path::PathBuf::from(dir);
    let bytes = std::fs::read(dir.join("state.bin")).unwrap();
    let fmu = Fmu::new("child");
    let mut snap = ptr::null_mut();
    assert_eq!(
        fmu.deserialize(&bytes, &mut snap),
        Status::Ok,
        "{:?}",
        fmu.log.messages()
    );
    assert_eq!(fmu.set_state(snap), Status::Ok);
    assert_eq!(fmu.free_state(&mut snap), Status::Ok);
    let result: Vec<u8> = run(&fmu, 25, 40)
        .into_iter()
        .flat_map(|(x, v)| [x.to_le_bytes(), v.to_le_bytes()].concat())
        .collect();
    std::fs::write(dir.join("result.bin"), result).unwrap();
}

#[test]
fn a_freed_or_made_up_state_is_refused_without_being_read() {
    let fmu = Fmu::initialized("stale");
    let mut snap = ptr::null_mut();
    assert_eq!(fmu.get_state(&mut snap), Status::Ok);
    let stale = snap;
    assert_eq!(fmu.free_state(&mut snap), Status::Ok);
    let not_live = "is not a live FMU state of this FMU";
    assert_eq!(fmu.set_state(stale), Status::Error);
    assert!(
        fmu.log
            .contains(&format!("fmi2SetFMUstate: FMUstate {not_live}")),
        "{:?}",
        fmu.log.messages()
    );
    // Freeing it again is an error, not a double free, and the slot keeps its value.
    let fmu = Fmu::initialized("stale2");
    let mut again = stale;
    assert_eq!(fmu.free_state(&mut again), Status::Error);
    assert_eq!(again, stale);
    assert!(
        fmu.log
            .contains(&format!("fmi2FreeFMUstate: *FMUstate {not_live}"))
    );
    // Nor is a made-up address dereferenced (page 1 of the address space is never
    // mapped, so a read would crash the test).
    let fmu = Fmu::initialized("made-up");
    let mut made_up = 0x1000 as Fmi2FmuState;
    assert_eq!(fmu.set_state(made_up), Status::Error);
    let fmu = Fmu::initialized("made-up2");
    assert_eq!(fmu.get_state(&mut made_up), Status::Error);
    assert_eq!(made_up, 0x1000 as Fmi2FmuState);
    let fmu = Fmu::initialized("made-up3");
    assert_eq!(fmu.free_state(&mut made_up), Status::Error);
}

/// Drops of [`Counted`] models: instances and snapshots, since a snapshot holds a clone.
static DROPS: AtomicUsize = AtomicUsize::new(0);

/// A model that counts its drops, to see which snapshots fmi2FreeInstance frees.
#[derive(Debug, Clone, PartialEq)]
struct Counted;

impl Drop for Counted {
    fn drop(&mut self) {
        DROPS.fetch_add(1, Ordering::SeqCst);
    }
}

minimal_model!(Counted, "Counted", "{counted-model}", Counted);

#[test]
fn free_instance_frees_the_states_its_instance_allocated() {
    let (a, b) = (
        instantiate_quiet::<Counted>("a"),
        instantiate_quiet::<Counted>("b"),
    );
    assert!(!a.is_null() && !b.is_null());
    // SAFETY: `a` and `b` are live instances of `Counted` until freed below; every slot
    // and buffer is valid for what is passed with it.
    unsafe {
        let get = |c: Fmi2Component| {
            let mut s = ptr::null_mut();
            assert_eq!(status(abi::get_fmu_state::<Counted>(c, &mut s)), Status::Ok);
            s
        };
        let (s1, mut s2, s3) = (get(a), get(a), get(a));
        // A state deserialized through `a` is `a`'s too.
        let mut size = 0;
        let st = abi::serialized_fmu_state_size::<Counted>(a, s1, &mut size);
        assert_eq!(status(st), Status::Ok);
        let mut bytes = vec![0u8; size];
        let st = abi::serialize_fmu_state::<Counted>(a, s1, bytes.as_mut_ptr().cast(), size);
        assert_eq!(status(st), Status::Ok);
        let mut s4 = ptr::null_mut();
        let st = abi::de_serialize_fmu_state::<Counted>(a, bytes.as_ptr().cast(), size, &mut s4);
        assert_eq!(status(st), Status::Ok);
        let mut t1 = get(b);
        // Any instance may free a state: `b` frees one of `a`'s, and `a` must not free it
        // a second time below.
        assert_eq!(
            status(abi::free_fmu_state::<Counted>(b, &mut s2)),
            Status::Ok
        );

        let before = DROPS.load(Ordering::SeqCst);
        abi::free_instance::<Counted>(a);
        // `a`'s model and its three states the master never freed (s1, s3, s4).
        assert_eq!(DROPS.load(Ordering::SeqCst) - before, 4);
        for gone in [s1, s3, s4] {
            assert_eq!(
                status(abi::set_fmu_state::<Counted>(b, gone)),
                Status::Error
            );
        }
        // `b`'s own state is untouched.
        assert_eq!(status(abi::set_fmu_state::<Counted>(b, t1)), Status::Ok);
        assert_eq!(
            status(abi::free_fmu_state::<Counted>(b, &mut t1)),
            Status::Ok
        );
        let before = DROPS.load(Ordering::SeqCst);
        abi::free_instance::<Counted>(b);
        assert_eq!(DROPS.load(Ordering::SeqCst) - before, 1);
    }
}

/// Instances on several threads save, serialize, restore and free FMU states at once, and
/// each frees its instance with states still live: the live-state table is shared by all,
/// so every state must stay its own (each thread checks the time its states restore to).
#[test]
fn instances_on_several_threads_keep_their_own_states() {
    let rounds = if cfg!(miri) { 3 } else { 200 };
    let threads: Vec<_> = (0..4u32)
        .map(|k| {
            std::thread::spawn(move || {
                let fmu = Fmu::initialized(&format!("thread{k}"));
                run(&fmu, 0, k + 1);
                let mut kept = ptr::null_mut();
                assert_eq!(fmu.get_state(&mut kept), Status::Ok);
                let expected = fmu.last_successful_time();
                for _ in 0..rounds {
                    let mut s = ptr::null_mut();
                    assert_eq!(fmu.get_state(&mut s), Status::Ok);
                    let bytes = fmu.serialize(s);
                    let mut d = ptr::null_mut();
                    assert_eq!(fmu.deserialize(&bytes, &mut d), Status::Ok);
                    assert_eq!(fmu.set_state(d), Status::Ok);
                    assert_eq!(fmu.last_successful_time(), expected);
                    assert_eq!(fmu.free_state(&mut s), Status::Ok);
                    assert_eq!(fmu.free_state(&mut d), Status::Ok);
                }
                assert_eq!(fmu.set_state(kept), Status::Ok);
                assert_eq!(fmu.last_successful_time(), expected);
                // `kept` is left for fmi2FreeInstance (the drop of `fmu`).
            })
        })
        .collect();
    for t in threads {
        t.join().unwrap();
    }
}
