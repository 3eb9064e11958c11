//! Everything FMI 2.0 for this project: the C types, the export glue the FMUs are
//! built on, the import side the orchestrator uses, and modelDescription parsing.

#![deny(clippy::undocumented_unsafe_blocks)]

pub mod export;
pub mod md;
mod sys;
pub mod types;

#[cfg(feature = "import")]
pub mod import;

pub use types::Status;
