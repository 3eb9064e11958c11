//! Export glue: how many instances one loaded library holds, and that a handle is not
//! handed out again soon after it is freed. Its own test binary, since it fills the
//! process-wide table of live instances that every other test's instances share; the
//! tests here take turns ([`TABLE`]).
// The tests' logger is truly C-variadic under Miri (docs/testing.md).
#![cfg_attr(miri, feature(c_variadic))]

#[path = "support/mod.rs"]
mod export_support;

use std::collections::HashSet;
use std::ffi::CString;
use std::sync::Mutex;

use export_support::{GUID, Oscillator, instantiate_raw};
use fmi2_export::abi;
use fmi2_sys::{FMI2_CO_SIMULATION, Fmi2Component};

/// The limit the glue documents (`handles::MAX_LIVE`).
const MAX_LIVE: usize = 4096;

/// Held by each test: one fills the table the other needs.
static TABLE: Mutex<()> = Mutex::new(());

fn instantiate(name: &CString) -> (Fmi2Component, Vec<String>) {
    let guid = CString::new(GUID).unwrap();
    let (c, log) = instantiate_raw(Some(name), FMI2_CO_SIMULATION, Some(&guid), false);
    (c, log.messages())
}

fn free(c: Fmi2Component) {
    // SAFETY: a live instance of this test, or NULL.
    unsafe { abi::free_instance::<Oscillator>(c) };
}

#[test]
#[cfg_attr(
    miri,
    ignore = "4096 instances are too slow under Miri; the unit tests cover the table"
)]
fn the_table_holds_max_live_instances_refuses_one_more_with_a_message_and_recovers() {
    let _turn = TABLE.lock().unwrap_or_else(|e| e.into_inner());
    let name = CString::new("many").unwrap();
    let mut live = Vec::new();
    for _ in 0..MAX_LIVE {
        let (c, log) = instantiate(&name);
        assert!(!c.is_null(), "instance {} refused: {log:?}", live.len());
        live.push(c);
    }
    let distinct: HashSet<usize> = live.iter().map(|&c| c.addr()).collect();
    assert_eq!(distinct.len(), MAX_LIVE);

    let (c, log) = instantiate(&name);
    assert!(c.is_null(), "one more than the table holds");
    assert_eq!(
        log,
        [format!(
            "fmi2Instantiate: {MAX_LIVE} instances of this FMU library are alive, the most \
             it allows; free one (fmi2FreeInstance) before instantiating another"
        )]
    );

    // One freed makes room for one more.
    free(live.swap_remove(1234));
    let (c, log) = instantiate(&name);
    assert!(!c.is_null(), "{log:?}");
    live.push(c);
    let (extra, _) = instantiate(&name);
    assert!(extra.is_null());

    for c in live {
        free(c);
    }
    let (c, log) = instantiate(&name);
    assert!(!c.is_null(), "{log:?}");
    free(c);
}

#[test]
fn a_freed_handle_is_not_handed_out_again_for_many_instantiations() {
    let _turn = TABLE.lock().unwrap_or_else(|e| e.into_inner());
    let name = CString::new("cycle").unwrap();
    let (first, _) = instantiate(&name);
    free(first);
    // Freed at once, so every instance could take the first one's memory: the handle
    // still differs, through every slot and again in each slot's later generations.
    let mut seen = HashSet::from([first.addr()]);
    let rounds = if cfg!(miri) { 50 } else { 3 * MAX_LIVE };
    for _ in 0..rounds {
        let (c, log) = instantiate(&name);
        assert!(!c.is_null(), "{log:?}");
        assert!(seen.insert(c.addr()), "handle {c:?} handed out twice");
        free(c);
    }
}
