//! The handles a master holds for instances (`fmi2Component`), and the table that maps
//! them to live instances without a lock and without reading the master's pointer.
//!
//! A component used to be the instance's own heap address, recognised by a tag at that
//! address. A master that called with a freed component, or with a pointer it made up,
//! then had the glue read freed or foreign memory. Now a handle is an address inside
//! [`HANDLE_SPACE`], a reserved region of this library that nothing reads or writes, and
//! each call on it:
//! 1. checks that the address lies in that region (no other pointer can: the region is
//!    this library's own memory);
//! 2. loads the one slot the address names and compares the handle the slot last issued;
//! 3. only then follows the slot's instance pointer.
//!
//! A freed handle, a made-up pointer or another library's component is refused in step 1
//! or 2, and what it points to is never read. That adds a range check and two loads to
//! every call (BENCHMARKS.md, round 45, measured no cost the bench resolves) and needs no
//! lock: a mutex here would be taken by every call of the step loop.
//!
//! Limits: [`MAX_LIVE`] instances can be alive at once in one loaded copy of the library
//! (fmi2Instantiate refuses more, with a message); and a slot hands out
//! [`GENERATIONS`] different handles before one repeats, so a handle kept after
//! fmi2FreeInstance is refused until about `MAX_LIVE * GENERATIONS` (a million) more
//! instances have been made.

use std::ffi::c_void;
use std::ptr;
use std::sync::atomic::{AtomicPtr, AtomicU8, AtomicUsize, Ordering};

/// Instances alive at once per loaded copy of the library. A power of two.
pub(crate) const MAX_LIVE: usize = 4096;
/// Handles each slot cycles through before one repeats. A power of two. Under Miri, which
/// takes about a second per megabyte each time the region's address is taken, four: the
/// logic is the same for any power of two.
const GENERATIONS: usize = if cfg!(miri) { 4 } else { 256 };
/// Distinct handles, and bytes of [`HANDLE_SPACE`].
const HANDLES: usize = MAX_LIVE * GENERATIONS;

/// The addresses handed out as components: handle `k` is the address of byte `k`. Never
/// read or written; atomics only so that it is mutable to the compiler and lands in
/// `.bss` (no pages in the file, none touched in memory), where an immutable zeroed array
/// would take a megabyte of read-only data in the library.
static HANDLE_SPACE: [AtomicU8; HANDLES] = [const { AtomicU8::new(0) }; HANDLES];

/// One entry of [`SLOTS`].
struct Slot {
    /// The handle (address) this slot issued last, 0 while the slot is free.
    handle: AtomicUsize,
    /// The instance behind `handle`: a `Box<Instance<M>>` of some model `M` of this
    /// library, [`RESERVED`] between [`reserve`] and [`Reservation::issue`], NULL when free.
    instance: AtomicPtr<c_void>,
}

/// Handle `k` lives in slot `k % MAX_LIVE`.
static SLOTS: [Slot; MAX_LIVE] = [const {
    Slot {
        handle: AtomicUsize::new(0),
        instance: AtomicPtr::new(ptr::null_mut()),
    }
}; MAX_LIVE];

/// The next handle number to try; slots are taken round-robin, so a freed slot is reused
/// as late as possible.
static NEXT: AtomicUsize = AtomicUsize::new(0);

/// Marks a slot taken by [`reserve`] whose instance is not yet stored. Never followed: no
/// handle names the slot until [`Reservation::issue`].
const RESERVED: *mut c_void = ptr::dangling_mut();

/// The region's raw address (no reference to it is made: nothing may read it). Handles are
/// compared by `addr()`, which, unlike an `as` cast, does not expose their provenance.
fn space() -> *mut c_void {
    (&raw const HANDLE_SPACE).cast_mut().cast::<c_void>()
}

fn base() -> usize {
    space().addr()
}

/// The slot a handle names, or `None` for any address outside [`HANDLE_SPACE`].
fn slot_of(handle: *mut c_void) -> Option<&'static Slot> {
    let k = handle.addr().wrapping_sub(base());
    (k < HANDLES).then(|| &SLOTS[k % MAX_LIVE])
}

/// A slot taken for an instance that is being made.
#[derive(Debug)]
pub(crate) struct Reservation {
    k: usize,
}

/// Takes a free slot, or `None` when [`MAX_LIVE`] instances are alive.
pub(crate) fn reserve() -> Option<Reservation> {
    for _ in 0..MAX_LIVE {
        let k = NEXT.fetch_add(1, Ordering::Relaxed) % HANDLES;
        let taken = SLOTS[k % MAX_LIVE].instance.compare_exchange(
            ptr::null_mut(),
            RESERVED,
            Ordering::Acquire,
            Ordering::Relaxed,
        );
        if taken.is_ok() {
            return Some(Reservation { k });
        }
    }
    None
}

impl Reservation {
    /// Stores `instance` in the slot and returns its new handle. `instance` is a
    /// `Box::into_raw` of an `Instance<M>`, owned by the table until [`release`].
    pub(crate) fn issue(self, instance: *mut c_void) -> *mut c_void {
        let slot = &SLOTS[self.k % MAX_LIVE];
        slot.instance.store(instance, Ordering::Relaxed);
        let issued = space().wrapping_byte_add(self.k);
        // Release: a thread that loads this handle sees the instance pointer and the
        // instance's contents.
        slot.handle.store(issued.addr(), Ordering::Release);
        std::mem::forget(self);
        issued
    }
}

impl Drop for Reservation {
    /// A slot reserved and never issued is given back.
    fn drop(&mut self) {
        let _ = SLOTS[self.k % MAX_LIVE].instance.compare_exchange(
            RESERVED,
            ptr::null_mut(),
            Ordering::Relaxed,
            Ordering::Relaxed,
        );
    }
}

/// The instance behind a live handle; `None` for NULL, freed, made-up or foreign ones,
/// none of which is read.
#[inline]
pub(crate) fn instance(handle: *mut c_void) -> Option<*mut c_void> {
    let slot = slot_of(handle)?;
    if slot.handle.load(Ordering::Acquire) != handle.addr() {
        return None;
    }
    Some(slot.instance.load(Ordering::Relaxed))
}

/// Retires a live handle and returns its instance, which the caller now owns and frees.
/// `None` if the handle is not live (freed already, or never issued).
pub(crate) fn release(handle: *mut c_void) -> Option<*mut c_void> {
    let slot = slot_of(handle)?;
    // The handle first, so no call finds the instance any more; then the slot, so it can
    // be taken again.
    slot.handle
        .compare_exchange(handle.addr(), 0, Ordering::Acquire, Ordering::Relaxed)
        .ok()?;
    Some(slot.instance.swap(ptr::null_mut(), Ordering::Release))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_handle_is_live_from_issue_to_release_and_then_refused() {
        let mut value = 7_u64;
        let p = ptr::from_mut(&mut value).cast::<c_void>();
        let h = reserve().expect("a free slot").issue(p);
        assert_eq!(instance(h), Some(p));
        assert_eq!(release(h), Some(p));
        assert_eq!(instance(h), None, "a released handle is refused");
        assert_eq!(release(h), None, "and cannot be released twice");
    }

    /// A slot reserved for an instance that is never made (its construction unwound) is
    /// given back: more such failures than the table has slots still leave room.
    #[test]
    fn a_dropped_reservation_gives_its_slot_back() {
        for _ in 0..=MAX_LIVE {
            drop(reserve().expect("a free slot"));
        }
    }

    #[test]
    fn addresses_outside_the_handle_space_are_refused() {
        let mut value = 7_u64;
        let outside = [
            ptr::null_mut(),
            ptr::from_mut(&mut value).cast::<c_void>(),
            ptr::without_provenance_mut(base() - 1),
            ptr::without_provenance_mut(base() + HANDLES),
            ptr::without_provenance_mut(usize::MAX),
        ];
        for h in outside {
            assert_eq!(instance(h), None, "{h:?}");
            assert_eq!(release(h), None, "{h:?}");
        }
    }

    #[test]
    fn a_handle_in_the_space_that_was_never_issued_is_refused() {
        let mut value = 7_u64;
        let p = ptr::from_mut(&mut value).cast::<c_void>();
        let h = reserve().expect("a free slot").issue(p);
        // The same slot's other generations (its neighbours may be live in other tests).
        for other in [h.addr() + MAX_LIVE, h.addr().wrapping_sub(MAX_LIVE)] {
            if other.wrapping_sub(base()) < HANDLES {
                assert_eq!(instance(ptr::without_provenance_mut(other)), None);
            }
        }
        assert_eq!(release(h), Some(p));
    }
}
