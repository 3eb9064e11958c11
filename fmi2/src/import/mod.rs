//! Import side: open a .fmu, load its binary, call it through one choke point.
//!
//! [`Fmu::open`] unpacks, validates and loads; [`Fmu::instantiate`] creates an
//! [`Instance`] whose methods each return `Result<Status, ImportError>`: `Ok` and
//! `Warning` are `Ok` (the warning's text stays in [`Instance::take_log`]), every
//! other status is an [`ImportError::Call`] naming the function, the instance and what
//! the FMU logged. Real and Integer get/set never allocate on success.

mod error;
mod extract;
mod fmu;
mod functions;
mod instance;
mod logger;
mod package;

pub use error::ImportError;
pub use extract::{EXTRACTION_PREFIX, reap_stale_extraction_dirs, remove_extraction_dirs};
pub use fmu::{Fmu, file_uri};
pub use functions::SYMBOLS;
pub use instance::{FmuState, Instance};
pub use logger::{LogRecord, MAX_LOG_RECORDS};
pub use package::write_fmu;

/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "linux", target_pointer_width = "64"))]
pub const PLATFORM: &str = "linux64";
/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "linux", target_pointer_width = "32"))]
pub const PLATFORM: &str = "linux32";
/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "macos", target_pointer_width = "64"))]
pub const PLATFORM: &str = "darwin64";
/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "windows", target_pointer_width = "64"))]
pub const PLATFORM: &str = "win64";
/// The `binaries/` subdirectory for this platform.
#[cfg(all(target_os = "windows", target_pointer_width = "32"))]
pub const PLATFORM: &str = "win32";

/// File extension of shared libraries on this platform.
#[cfg(target_os = "linux")]
pub const SHARED_LIBRARY_EXTENSION: &str = "so";
/// File extension of shared libraries on this platform.
#[cfg(target_os = "macos")]
pub const SHARED_LIBRARY_EXTENSION: &str = "dylib";
/// File extension of shared libraries on this platform.
#[cfg(target_os = "windows")]
pub const SHARED_LIBRARY_EXTENSION: &str = "dll";
