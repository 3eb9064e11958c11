//! The import side of FMI 2.0 Co-Simulation: open a .fmu, load its binary, call it through
//! one choke point.
//!
//! [`Fmu::open`] unpacks, validates and loads; [`Fmu::instantiate`] creates an
//! [`Instance`] whose methods each return `Result<Status, ImportError>`: `Ok` and
//! `Warning` are `Ok` (the warning's text stays in [`Instance::take_log`]), every
//! other status is an [`ImportError::Call`] naming the function, the instance and what
//! the FMU logged. Real and Integer get/set never allocate on success.

#![deny(clippy::undocumented_unsafe_blocks)]

mod binary;
mod error;
mod extract;
mod fmu;
mod functions;
mod instance;
mod kept;
mod logger;

pub use error::ImportError;
pub use extract::{EXTRACTION_PREFIX, reap_stale_extraction_dirs, remove_extraction_dirs};
pub use fmi2_sys::{PLATFORM, SHARED_LIBRARY_EXTENSION, Status};
pub use fmu::{DEFAULT_MAX_UNPACKED_MIB, Fmu, MAX_UNPACKED_VAR, file_uri, read_description};
pub use functions::SYMBOLS;
pub use instance::{FmuState, Instance};
pub use kept::{FileStamp, KeptFmus, file_stamp};
pub use logger::{LogRecord, MAX_LOG_RECORDS};
