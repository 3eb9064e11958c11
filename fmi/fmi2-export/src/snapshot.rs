//! FMU-state snapshots (fmi2GetFMUstate & co.) and their serialized byte format.
//!
//! # Serialized format, version 2
//!
//! Pointer-free and self-identifying, so a state saved by one process can be restored in
//! another (same FMU binary or a rebuild of the same model). All integers and floats are
//! little-endian; `n` and `g` are the byte lengths of the two UTF-8 strings.
//!
//! | offset        | size | field                                                        |
//! |---------------|------|--------------------------------------------------------------|
//! | 0             | 8    | magic `b"FMI2STAT"`                                          |
//! | 8             | 4    | format version, `u32` = 2                                    |
//! | 12            | 4    | `n`, `u32`                                                   |
//! | 16            | n    | model identifier                                             |
//! | 16+n          | 4    | `g`, `u32`                                                   |
//! | 20+n          | g    | GUID                                                         |
//! | 20+n+g        | 4    | FMI state, `u32`: 0 Instantiated, 1 InitializationMode, 2 StepComplete, 3 StepFailed, 4 StepCanceled, 5 Terminated (6, Fatal, is never saved and is refused) |
//! | 24+n+g        | 4    | flags, `u32`: bit 0 stop time defined, 1 tolerance defined, 2 first step size known, 3 terminate requested, 4 values dirty |
//! | 28+n+g        | 4    | status of the last fmi2DoStep, `u32` (0 OK, 1 Warning, 2 Discard) |
//! | 32+n+g        | 40   | `f64`s: start time, stop time, tolerance, FMU time, first step size (0 when undefined) |
//! | 72+n+g        | 8    | `p`, model payload length, `u64`                             |
//! | 80+n+g        | p    | model payload written by [`Model::save`]                     |
//! | 80+n+g+p      | 4    | CRC-32 (IEEE) of all preceding bytes, `u32`                  |
//!
//! The buffer must be exactly `84 + n + g + p` bytes long. Version 2 added the checksum:
//! without it, most single-byte corruptions decoded into a "valid" state (a flipped
//! exponent bit in a parameter or in the pose), which then stepped to NaN with fmi2OK.
//! After the checksum, every value is still checked: finite times, declared parameter
//! ranges (see [`check_ranges`]) and whatever the model's `restore` checks.

use std::collections::BTreeMap;
use std::ffi::c_void;
use std::sync::{Mutex, MutexGuard, PoisonError};

use crate::instance::{Glue, Tag, time_tolerance};
use crate::state::FmiState;
use fmi2_sys::Status;
use fmu_core::{Model, Shown, check_ranges};

/// Magic bytes at the start of every serialized FMU state.
pub const SERIALIZED_MAGIC: [u8; 8] = *b"FMI2STAT";
/// Version of the serialized format this glue writes and reads.
pub const SERIALIZED_VERSION: u32 = 2;
/// Bytes of the trailing checksum.
const CHECKSUM_LEN: usize = 4;

const FLAG_STOP: u32 = 1;
const FLAG_TOLERANCE: u32 = 1 << 1;
const FLAG_FIRST_STEP: u32 = 1 << 2;
const FLAG_TERMINATE: u32 = 1 << 3;
const FLAG_DIRTY: u32 = 1 << 4;
const ALL_FLAGS: u32 = FLAG_STOP | FLAG_TOLERANCE | FLAG_FIRST_STEP | FLAG_TERMINATE | FLAG_DIRTY;

/// Length of everything before the payload, for model `M`.
fn header_len<M: Model>() -> usize {
    80 + M::MODEL_IDENTIFIER.len() + M::GUID.len()
}

/// An FMU state: a model clone plus the glue bookkeeping. Boxed and handed to the master
/// as the `fmi2FMUstate`.
#[repr(C)]
pub(crate) struct Snapshot<M: Model> {
    /// First field, so an FMU-state pointer can be checked before it is trusted.
    tag: Tag,
    pub(crate) model: M,
    pub(crate) glue: Glue,
}

impl<M: Model> std::fmt::Debug for Snapshot<M> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Snapshot")
            .field("model", &M::MODEL_IDENTIFIER)
            .field("glue", &self.glue)
            .finish_non_exhaustive()
    }
}

impl<M: Model> Snapshot<M> {
    /// A snapshot of `model` and `glue`.
    pub(crate) fn new(model: M, glue: Glue) -> Self {
        Self {
            tag: Tag::new::<M>(),
            model,
            glue,
        }
    }

    /// Moves the snapshot to the heap and hands out its pointer, recorded as allocated by
    /// the instance at address `owner` (see [`LIVE`]).
    pub(crate) fn into_raw(self, owner: usize) -> *mut c_void {
        let p = Box::into_raw(Box::new(self)).cast::<c_void>();
        register(p, owner);
        p
    }

    /// The snapshot behind an FMU-state pointer, if it is a live snapshot of `M`.
    ///
    /// Any pointer value is accepted: only one that [`LIVE`] lists is read, so a freed,
    /// made-up or foreign pointer is refused without touching its memory.
    ///
    /// # Safety
    /// No other reference to the snapshot is live during `'a`, and no other thread frees
    /// it meanwhile (FMI 2.0 lets a master use an FMU state from one thread at a time).
    pub(crate) unsafe fn from_ptr<'a>(p: *mut c_void) -> Result<&'a mut Self, NotOurs> {
        if !is_live(p) {
            return Err(NotOurs::NotLive);
        }
        // SAFETY: listed in `LIVE`, so `p` came from `into_raw` of a snapshot of some model
        // of this library and has not been freed: it points to a readable `Tag`.
        if !unsafe { Tag::matches::<M>(p) } {
            return Err(NotOurs::OtherModel);
        }
        // SAFETY: the tag proves it is a live `Snapshot<M>`; exclusive per the contract.
        Ok(unsafe { &mut *p.cast::<Self>() })
    }

    /// Frees the snapshot behind `p` (checked as [`Self::from_ptr`] does).
    ///
    /// # Safety
    /// As [`Self::from_ptr`], and no reference to the snapshot outlives this call.
    #[cold]
    #[inline(never)]
    pub(crate) unsafe fn free(p: *mut c_void) -> Result<(), NotOurs> {
        // SAFETY: forwarded contract; the reference is not kept.
        unsafe { Self::from_ptr(p) }?;
        unregister(p);
        // SAFETY: a live `Snapshot<M>` from `Box::into_raw` (checked above), now unlisted,
        // so this is the one place that frees it and no function reads it again.
        drop(unsafe { Box::from_raw(p.cast::<Self>()) });
        Ok(())
    }

    /// Frees every snapshot that the instance at address `owner` allocated and the master
    /// has not freed (fmi2FreeInstance frees all memory its instance allocated).
    ///
    /// # Safety
    /// `owner` is an instance of `M` being freed (so it allocated only `Snapshot<M>`s), and
    /// no reference to its snapshots is live.
    #[cold]
    #[inline(never)]
    pub(crate) unsafe fn free_owned_by(owner: usize) {
        for p in take_owned_by(owner) {
            // SAFETY: was listed in `LIVE`, so allocated and not yet freed: a readable tag.
            if unsafe { Tag::matches::<M>(p) } {
                // SAFETY: a `Snapshot<M>` from `Box::into_raw`, unlisted above, so freed
                // only here; its pointer is no longer accepted by any function.
                drop(unsafe { Box::from_raw(p.cast::<Self>()) });
            }
        }
    }

    /// The serialized form (see the module documentation).
    pub(crate) fn encode(&self) -> Vec<u8> {
        let mut payload = Vec::new();
        self.model.save(&mut payload);
        let g = &self.glue;
        let mut out = Vec::with_capacity(header_len::<M>() + payload.len() + CHECKSUM_LEN);
        out.extend_from_slice(&SERIALIZED_MAGIC);
        out.extend_from_slice(&SERIALIZED_VERSION.to_le_bytes());
        for s in [M::MODEL_IDENTIFIER, M::GUID] {
            out.extend_from_slice(&len_u32(s.len()).to_le_bytes());
            out.extend_from_slice(s.as_bytes());
        }
        let flags = [
            (g.stop_time.is_some(), FLAG_STOP),
            (g.tolerance.is_some(), FLAG_TOLERANCE),
            (g.first_step.is_some(), FLAG_FIRST_STEP),
            (g.terminate_requested, FLAG_TERMINATE),
            (g.dirty, FLAG_DIRTY),
        ]
        .iter()
        .filter(|(set, _)| *set)
        .fold(0, |acc, (_, bit)| acc | bit);
        out.extend_from_slice(&g.state.code().to_le_bytes());
        out.extend_from_slice(&flags.to_le_bytes());
        out.extend_from_slice(&(g.last_step_status as u32).to_le_bytes());
        for x in [
            g.start_time,
            g.stop_time.unwrap_or(0.0),
            g.tolerance.unwrap_or(0.0),
            g.time,
            g.first_step.unwrap_or(0.0),
        ] {
            out.extend_from_slice(&x.to_le_bytes());
        }
        out.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        out.extend_from_slice(&payload);
        let crc = crc32fast::hash(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    /// Parses and validates a serialized state of model `M`, restoring the payload into
    /// a fresh `M::new()`. The error text says exactly what is wrong.
    pub(crate) fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let total = bytes.len();
        let header = header_len::<M>();
        let truncated = |needed: usize| {
            DecodeError::Invalid(format!(
                "buffer truncated: {total} bytes, header needs {}",
                needed.max(header + CHECKSUM_LEN)
            ))
        };
        if total >= 8 && bytes[..8] != SERIALIZED_MAGIC {
            return Err(DecodeError::Invalid(format!(
                "wrong magic bytes {:02x?}, expected {:02x?} (\"FMI2STAT\"): not a serialized FMU state of this glue",
                &bytes[..8],
                SERIALIZED_MAGIC
            )));
        }
        let mut r = Reader { bytes, pos: 0 };
        r.take(8).ok_or_else(|| truncated(8))?;
        let version = r.u32().ok_or_else(|| truncated(12))?;
        if version != SERIALIZED_VERSION {
            return Err(DecodeError::Invalid(format!(
                "unsupported format version {version}, this FMU reads version {SERIALIZED_VERSION}"
            )));
        }
        // The checksum before anything else is trusted: a corrupted length or state code
        // gets this message rather than a misleading one about the field it hit.
        let sealed = split_checksum(bytes).filter(|&(_, stored, computed)| stored == computed);
        if sealed.is_some() {
            // Intact, so possibly another model's state (perhaps shorter than our header):
            // named as such rather than called truncated.
            let mut peek = Reader { bytes, pos: r.pos };
            if let (Ok(identifier), Ok(guid)) = (peek.string(), peek.string()) {
                if identifier != M::MODEL_IDENTIFIER.as_bytes() || guid != M::GUID.as_bytes() {
                    return Err(DecodeError::Invalid(format!(
                        "state belongs to model '{}' with GUID '{}', but this FMU is '{}' with GUID '{}'",
                        String::from_utf8_lossy(identifier),
                        String::from_utf8_lossy(guid),
                        M::MODEL_IDENTIFIER,
                        M::GUID
                    )));
                }
            }
        }
        if total < header + CHECKSUM_LEN {
            return Err(truncated(header + CHECKSUM_LEN));
        }
        let Some((body, _, _)) = sealed else {
            let (stored, computed) = split_checksum(bytes).map_or((0, 0), |(_, s, c)| (s, c));
            return Err(DecodeError::Invalid(format!(
                "checksum mismatch: the state's CRC-32 is {stored:#010x}, its bytes give \
                 {computed:#010x}; the serialized state is corrupted or truncated"
            )));
        };
        let mut r = Reader {
            bytes: body,
            pos: r.pos,
        };
        // Identifier and GUID were compared above; here they are only skipped.
        r.string().map_err(truncated)?;
        r.string().map_err(truncated)?;
        let (Some(state), Some(flags), Some(step_status)) = (r.u32(), r.u32(), r.u32()) else {
            return Err(truncated(header));
        };
        let mut reals = [0.0; 5];
        for x in &mut reals {
            *x = r.f64().ok_or_else(|| truncated(header))?;
        }
        let payload_len = r.u64().ok_or_else(|| truncated(header))?;
        let expected = usize::try_from(payload_len)
            .ok()
            .and_then(|p| p.checked_add(header + CHECKSUM_LEN))
            .ok_or_else(|| {
                DecodeError::Invalid(format!("payload length {payload_len} is impossibly large"))
            })?;
        if total < expected {
            return Err(DecodeError::Invalid(format!(
                "buffer truncated: {total} bytes, header announces {expected}"
            )));
        }
        if total > expected {
            return Err(DecodeError::Invalid(format!(
                "buffer too long: {total} bytes, header announces {expected}"
            )));
        }
        let glue = decode_glue(state, flags, step_status, reals).map_err(DecodeError::Invalid)?;
        let mut model = M::new();
        model.restore(&body[header..]).map_err(DecodeError::Model)?;
        check_ranges(&model).map_err(|e| DecodeError::Invalid(format!("the state holds {e}")))?;
        Ok(Self::new(model, glue))
    }
}

/// Every FMU-state snapshot this library has handed out and not yet freed, by address,
/// with the instance that allocated it.
///
/// The glue's one global. A snapshot is not part of its instance's memory: FMI 2.0 lets a
/// master restore, serialize or free a state through any instance of the model. Yet
/// fmi2FreeInstance frees "all the allocated memory" of its instance, states the master
/// never freed included; and a pointer looked up here before it is read makes a freed,
/// twice-freed or made-up FMU state an fmi2Error instead of a read of memory the glue
/// does not own. Locked only by the FMU-state functions and fmi2FreeInstance, never in a
/// step.
static LIVE: Mutex<BTreeMap<Handed, usize>> = Mutex::new(BTreeMap::new());

/// A snapshot pointer as handed out: kept as a pointer, not as its address, so that the
/// one freeing it keeps its provenance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
struct Handed(*mut c_void);

// SAFETY: the table only compares and returns these pointers, never dereferences them,
// and a snapshot is read or freed by one thread at a time (the FMI functions' contract),
// whichever thread allocated it.
unsafe impl Send for Handed {}

/// The live-snapshot table; a panic while it was held cannot have left it inconsistent
/// (every update is a single insert, remove, retain or swap for an empty map), so
/// poisoning is ignored.
fn live() -> MutexGuard<'static, BTreeMap<Handed, usize>> {
    LIVE.lock().unwrap_or_else(PoisonError::into_inner)
}

// The table's four operations, not generic and out of line, so that each is compiled once
// and away from the FMI functions a step calls: inlined into the generic ones, the map's
// code sat between fmi2DoStep and fmi2GetReal in an FMU's library and moved them apart
// (about 1 % slower steps with the same step code; BENCHMARKS.md, round 41).

/// Records `p` as live, allocated by the instance at address `owner`.
#[cold]
#[inline(never)]
fn register(p: *mut c_void, owner: usize) {
    live().insert(Handed(p), owner);
}

/// Whether `p` is a live snapshot.
#[inline(never)]
fn is_live(p: *mut c_void) -> bool {
    live().contains_key(&Handed(p))
}

/// Unlists `p`.
#[cold]
#[inline(never)]
fn unregister(p: *mut c_void) {
    let mut live = live();
    live.remove(&Handed(p));
    release_if_empty(&mut live);
}

/// Unlists and returns the snapshots the instance at address `owner` allocated.
#[cold]
#[inline(never)]
fn take_owned_by(owner: usize) -> Vec<*mut c_void> {
    let mut live = live();
    let mut owned = Vec::new();
    live.retain(|&Handed(p), &mut o| {
        if o == owner {
            owned.push(p);
        }
        o != owner
    });
    release_if_empty(&mut live);
    owned
}

/// Frees the map's last node once it holds nothing. A map emptied by removals keeps its
/// root node allocated; in a static that is never dropped it outlives the library, and
/// every load of the FMU that saved a state would leave one behind (LeakSanitizer found it
/// at the end of a fuzz run; `tests/alloc.rs` checks it).
fn release_if_empty(live: &mut BTreeMap<Handed, usize>) {
    if live.is_empty() {
        *live = BTreeMap::new();
    }
}

/// Why an FMU-state pointer was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NotOurs {
    /// Never handed out by this library, or already freed.
    NotLive,
    /// A live snapshot of another model in the same library.
    OtherModel,
}

/// Why a serialized state was rejected.
#[derive(Debug)]
pub(crate) enum DecodeError {
    /// The bytes are not a valid state of this model (message says why).
    Invalid(String),
    /// The header was valid but the model rejected its payload.
    Model(fmu_core::ModelError),
}

/// The bytes before the trailing checksum, the stored checksum and the one computed.
fn split_checksum(bytes: &[u8]) -> Option<(&[u8], u32, u32)> {
    let body_len = bytes.len().checked_sub(CHECKSUM_LEN)?;
    let (body, tail) = bytes.split_at(body_len);
    let stored = u32::from_le_bytes(tail.try_into().ok()?);
    Some((body, stored, crc32fast::hash(body)))
}

/// Validates the glue fields of a serialized state.
fn decode_glue(state: u32, flags: u32, step_status: u32, reals: [f64; 5]) -> Result<Glue, String> {
    let state = match FmiState::from_code(state) {
        Some(FmiState::Fatal) | None => return Err(format!("invalid FMI state code {state}")),
        Some(s) => s,
    };
    if flags & !ALL_FLAGS != 0 {
        return Err(format!("unknown flag bits {:#x}", flags & !ALL_FLAGS));
    }
    let last_step_status = match step_status {
        0 => Status::Ok,
        1 => Status::Warning,
        2 => Status::Discard,
        other => return Err(format!("invalid last doStep status {other}")),
    };
    let [start_time, stop, tolerance, time, first] = reals;
    let has = |bit: u32| flags & bit != 0;
    let glue = Glue {
        state,
        start_time,
        stop_time: has(FLAG_STOP).then_some(stop),
        tolerance: has(FLAG_TOLERANCE).then_some(tolerance),
        time,
        first_step: has(FLAG_FIRST_STEP).then_some(first),
        last_step_status,
        terminate_requested: has(FLAG_TERMINATE),
        dirty: has(FLAG_DIRTY),
        failed_in: None,
    };
    let finite = [
        Some(start_time),
        glue.stop_time,
        glue.tolerance,
        Some(time),
        glue.first_step,
    ];
    if finite.iter().flatten().any(|x| !x.is_finite()) {
        return Err("a time field is not finite".to_owned());
    }
    if glue.first_step.is_some_and(|h| h <= 0.0) {
        return Err(format!("first step size {first} is not positive"));
    }
    // What fmi2SetupExperiment and fmi2DoStep let no state reach.
    if let Some(stop) = glue.stop_time {
        if stop < start_time {
            return Err(format!(
                "stop time {} is before the start time {}",
                Shown(stop),
                Shown(start_time)
            ));
        }
        if time > stop + time_tolerance(stop) {
            return Err(format!(
                "time {} is beyond the stop time {}",
                Shown(time),
                Shown(stop)
            ));
        }
    }
    Ok(glue)
}

/// A string length as the format's `u32`. Identifiers and GUIDs are short; a longer
/// one would be a broken model description, so it saturates (and then fails to decode).
fn len_u32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// Sequential little-endian reads over the serialized bytes.
struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let end = self.pos.checked_add(n)?;
        let s = self.bytes.get(self.pos..end)?;
        self.pos = end;
        Some(s)
    }

    fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        self.take(N)?.try_into().ok()
    }

    fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_le_bytes)
    }

    fn u64(&mut self) -> Option<u64> {
        self.array().map(u64::from_le_bytes)
    }

    fn f64(&mut self) -> Option<f64> {
        self.array().map(f64::from_le_bytes)
    }

    /// A length-prefixed string; on truncation, the offset the string would need.
    fn string(&mut self) -> Result<&'a [u8], usize> {
        let at = self.pos;
        let n = self.u32().ok_or(at + 4)? as usize;
        self.take(n).ok_or(at + 4 + n)
    }
}
