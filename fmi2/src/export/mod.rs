//! Export side: the C ABI of an FMI 2.0 Co-Simulation FMU over a safe [`Model`].
//!
//! Three layers, as in rust-fmi's export but stricter:
//! 1. [`export_fmu!`](crate::export_fmu) expands, in the FMU crate, to the 34 FMI 2.0
//!    CS functions with their exact C names, each a one-line shim into [`abi`];
//! 2. [`abi`]: generic `unsafe fn` wrappers over raw pointers that all pass through one
//!    guard (component check, allowed-states table, NULL/length checks, `catch_unwind`,
//!    status escalation);
//! 3. the per-instance state (model, name, callbacks, logging, FMI state, times) and the
//!    safe [`Model`] trait the FMU crates implement.
//!
//! There are no globals: every piece of state lives in its instance or snapshot, so any
//! number of instances can run in one process and in different threads.

pub mod abi;
mod instance;
mod macros;
mod model;
mod snapshot;
mod state;
pub mod values;

pub use instance::LOG_CATEGORIES;
pub use model::{
    Causality, Model, ModelError, ModelResult, VarSpec, VarType, Variability, check_ranges,
};
pub use snapshot::{SERIALIZED_MAGIC, SERIALIZED_VERSION};
pub use state::{FmiState, Function};
