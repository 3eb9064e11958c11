//! The export side of FMI 2.0 Co-Simulation: the C ABI of an FMU over a safe
//! [`fmu_core::Model`].
//!
//! Three layers, as in rust-fmi's export but stricter:
//! 1. [`export_fmu!`](crate::export_fmu) expands, in the FMU crate, to the 34 FMI 2.0
//!    CS functions with their exact C names, one line each of the signature table in
//!    `fmi2-sys`, each a shim into [`abi`];
//! 2. [`abi`]: generic `unsafe fn` wrappers over raw pointers that all pass through one
//!    guard (component check, allowed-states table, NULL/length checks, `catch_unwind`,
//!    status escalation);
//! 3. the per-instance state (model, name, callbacks, logging, FMI state, times) and the
//!    FMU-state snapshots around the model's own saved bytes.
//!
//! Every piece of simulation state lives in its instance or snapshot, so any number of
//! instances can run in one process and in different threads. There are two globals, both
//! tables of what the glue handed out and has not freed, so that a freed, made-up or
//! foreign pointer is refused without being read:
//! - `handles`: the live instances. A component is a handle into it, not the instance's
//!   address; every call looks it up without a lock (two loads).
//! - `snapshot::LIVE`: the live FMU-state snapshots, which also lets fmi2FreeInstance
//!   free the states its instance allocated. No step touches it.

#![deny(clippy::undocumented_unsafe_blocks)]

pub mod abi;
mod handles;
mod instance;
mod macros;
mod snapshot;
mod state;

pub use instance::LOG_CATEGORIES;
pub use snapshot::{SERIALIZED_MAGIC, SERIALIZED_VERSION};
pub use state::{FmiState, Function};

/// The crates the expansion of [`export_fmu!`] names; not for direct use.
#[doc(hidden)]
pub mod __private {
    pub use fmi2_sys;
}
