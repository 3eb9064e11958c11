//! A counting global allocator for the zero-allocation tests of every crate.
//!
//! FMI calls sit in 1 ms loops, so "no heap allocation per step" is a tested property. The
//! allocator is its own crate, used only as a dev-dependency, so that no shipped library
//! carries it; a test installs it with
//! `#[global_allocator] static A: alloc_count::CountingAllocator = alloc_count::CountingAllocator;`
//! and measures with [`counted`].
//!
//! Counts are per thread, because the test harness runs tests on parallel threads and a
//! global counter would charge one test with another's allocations. With the environment
//! variable `CKCM_ALLOC_BACKTRACE` set, every counted allocation prints a backtrace.

#![deny(clippy::undocumented_unsafe_blocks)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::backtrace::Backtrace;
use std::cell::Cell;

/// Forwards to the system allocator and counts the calling thread's allocations.
#[derive(Debug, Clone, Copy, Default)]
pub struct CountingAllocator;

thread_local! {
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
    /// Blocks allocated minus blocks freed on this thread (a reallocation keeps the count).
    static LIVE_BLOCKS: Cell<isize> = const { Cell::new(0) };
    /// Print a backtrace for every counted allocation.
    static TRACE: Cell<bool> = const { Cell::new(false) };
    /// Set while a backtrace is printed: its own allocations are neither counted nor
    /// traced, so the allocator never recurses into itself.
    static IN_HOOK: Cell<bool> = const { Cell::new(false) };
}

/// Adds `delta` to this thread's [`live_blocks`].
fn count_live(delta: isize) {
    let _ = LIVE_BLOCKS.try_with(|b| b.set(b.get() + delta));
}

fn count() {
    let _ = IN_HOOK.try_with(|hook| {
        if hook.get() {
            return;
        }
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
        if TRACE.with(Cell::get) {
            hook.set(true);
            eprintln!("allocation:\n{}", Backtrace::force_capture());
            hook.set(false);
        }
    });
}

// SAFETY: every method forwards its arguments unchanged to `System`, which upholds the
// `GlobalAlloc` contract. The extra work touches const-initialised thread-local `Cell`s,
// which never allocate; the optional backtrace does allocate, but `IN_HOOK` sends those
// nested calls straight to `System`, so there is no recursion. `try_with` skips the count
// once the thread's locals are destroyed, and nothing here can unwind.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        count_live(1);
        // SAFETY: the caller's contract for `layout` is passed on unchanged.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        count_live(1);
        // SAFETY: the caller's contract for `layout` is passed on unchanged.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        count_live(-1);
        // SAFETY: `ptr` was returned by `System` for this `layout` (every allocation goes there).
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: `ptr` came from `System` with `layout`; the caller's contract is passed on.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

/// Allocations counted on this thread so far (0 unless [`CountingAllocator`] is installed).
pub fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

/// Blocks allocated minus blocks freed on this thread so far: unchanged across code that
/// frees all it allocates (on the same thread). 0 unless [`CountingAllocator`] is installed.
pub fn live_blocks() -> isize {
    LIVE_BLOCKS.with(Cell::get)
}

/// Runs `f` and returns how many allocations it made on this thread, with its result.
pub fn counted<T>(f: impl FnOnce() -> T) -> (usize, T) {
    let trace = std::env::var_os("CKCM_ALLOC_BACKTRACE").is_some();
    let before = allocations();
    TRACE.with(|t| t.set(trace));
    let out = f();
    TRACE.with(|t| t.set(false));
    (allocations() - before, out)
}

/// Allocations of the calling thread seen by the preloaded malloc counter of
/// `tests/fixtures/malloc-count` (`LD_PRELOAD`), or `None` when it is not loaded.
///
/// [`CountingAllocator`] sees only the allocations of the binary that installs it; a loaded
/// FMU's shared library has its own global allocator. Both end in the process's `malloc`,
/// which the preloaded counter interposes, so this counts the library's allocations too.
/// The first call looks the counter up (and may allocate); later calls only read it.
#[cfg(target_os = "linux")]
pub fn preloaded_allocations() -> Option<u64> {
    type Counter = unsafe extern "C" fn() -> std::ffi::c_ulong;
    static COUNTER: std::sync::OnceLock<Option<Counter>> = std::sync::OnceLock::new();
    let counter = COUNTER.get_or_init(|| {
        let this = libloading::os::unix::Library::this();
        // SAFETY: malloc_count.c defines `unsigned long ckcm_malloc_count(void)`, which is
        // this type. The main program's handle never unloads, so the pointer stays valid
        // after `this` is dropped.
        unsafe { this.get::<Counter>(b"ckcm_malloc_count\0").ok().map(|f| *f) }
    });
    // SAFETY: as above; the function takes no arguments and only reads a thread-local.
    counter.map(|f| unsafe { f() })
}
