//! Errors of the import side, each naming the file or the function and instance.

use std::fmt;
use std::path::PathBuf;

use crate::LogRecord;
use fmi2_md::{MdError, Problem};
use fmi2_sys::Status;

/// Something went wrong opening, loading or calling an FMU.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The .fmu file does not exist.
    #[error("{}: no such file", .path.display())]
    NotFound {
        /// The file asked for.
        path: PathBuf,
    },
    /// The file or the unpacked directory could not be read or written.
    #[error("{}: {source}", .path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A folder was given where the .fmu file goes.
    #[error(
        "{} is a folder, not an .fmu file: an FMU is one zip archive{}",
        .path.display(),
        if *.unpacked {
            " (this folder holds an unpacked FMU's modelDescription.xml: give the .fmu it came \
             from, or zip the folder's contents into one)"
        } else {
            ""
        }
    )]
    Folder {
        /// The folder.
        path: PathBuf,
        /// Whether it holds a modelDescription.xml.
        unpacked: bool,
    },
    /// The file is not a zip archive (or a damaged one).
    #[error("{} is not a zip archive: {detail}", .path.display())]
    NotZip {
        /// The .fmu file.
        path: PathBuf,
        /// What the file is instead, where its first bytes tell, else what the zip reader
        /// said.
        detail: String,
    },
    /// Unpacking failed.
    #[error("{}: cannot unpack: {detail}", .path.display())]
    Unpack {
        /// The .fmu file.
        path: PathBuf,
        /// What the zip reader said.
        detail: String,
    },
    /// The archive has no modelDescription.xml at its root.
    #[error("{} contains no modelDescription.xml at the archive root", .path.display())]
    NoModelDescription {
        /// The .fmu file.
        path: PathBuf,
    },
    /// modelDescription.xml could not be parsed (FMI 1.0, Model Exchange only, malformed...).
    #[error("{}: {source}", .path.display())]
    ModelDescription {
        /// The .fmu file.
        path: PathBuf,
        /// The parse error, with its line.
        source: MdError,
    },
    /// modelDescription.xml breaks FMI 2.0 rules.
    #[error("{}: modelDescription.xml has {} problem(s):{}", .path.display(), .problems.len(), list(.problems))]
    InvalidModelDescription {
        /// The .fmu file.
        path: PathBuf,
        /// Every problem found.
        problems: Vec<Problem>,
    },
    /// The binary for this platform is missing from the archive.
    #[error("{}: no binary for this platform ({platform}): expected {expected} inside the archive; {}", .path.display(), has_platforms(.available))]
    MissingBinary {
        /// The .fmu file.
        path: PathBuf,
        /// The platform folder looked in, e.g. `win64`.
        platform: &'static str,
        /// The path inside the archive, e.g. `binaries/linux64/CkcmPlant.so`.
        expected: String,
        /// The platform folders the archive does have under `binaries/`, sorted.
        available: Vec<String>,
    },
    /// The shared library could not be loaded, or its file is damaged (checked before
    /// loading, since a truncated file would crash the process once mapped).
    #[error("{}: cannot load its binary {binary}: {reason}", .path.display())]
    Load {
        /// The .fmu file.
        path: PathBuf,
        /// The binary's path inside the archive, e.g. `binaries/linux64/CkcmPlant.so`.
        binary: Box<str>,
        /// What the check or the loader found.
        reason: Box<str>,
    },
    /// A required FMI function is not exported by the binary.
    #[error("{}: its binary {binary} lacks the FMI 2.0 function {symbol}: {reason}", .path.display())]
    MissingSymbol {
        /// The .fmu file.
        path: PathBuf,
        /// The binary's path inside the archive.
        binary: Box<str>,
        /// The C name of the function.
        symbol: &'static str,
        /// What the loader said.
        reason: Box<str>,
    },
    /// The binary reports another FMI version or types platform than the description.
    #[error("{}: its binary {binary}: {function} returned \"{found}\", expected \"{expected}\"", .path.display())]
    Version {
        /// The .fmu file.
        path: PathBuf,
        /// The binary's path inside the archive.
        binary: Box<str>,
        /// `fmi2GetVersion` or `fmi2GetTypesPlatform`.
        function: &'static str,
        /// What it returned.
        found: String,
        /// What FMI 2.0 requires.
        expected: &'static str,
    },
    /// fmi2Instantiate returned NULL.
    #[error("fmi2Instantiate failed for instance '{instance}'{}", messages_suffix(.messages))]
    Instantiate {
        /// The instance name asked for.
        instance: String,
        /// What the FMU logged meanwhile (e.g. its GUID complaint).
        messages: Vec<LogRecord>,
    },
    /// An FMI call returned Discard, Error, Fatal or Pending.
    #[error("{function} on instance '{instance}' returned {status}{}", messages_suffix(.messages))]
    Call {
        /// The C name of the function.
        function: &'static str,
        /// The instance name.
        instance: String,
        /// The status it returned.
        status: Status,
        /// What the FMU logged during the call.
        messages: Vec<LogRecord>,
    },
    /// An FMI call returned an int that is no fmi2Status.
    #[error("{function} on instance '{instance}' returned {raw}, which is not a valid fmi2Status{}", messages_suffix(.messages))]
    InvalidStatus {
        /// The C name of the function.
        function: &'static str,
        /// The instance name.
        instance: String,
        /// The raw value.
        raw: i32,
        /// What the FMU logged during the call.
        messages: Vec<LogRecord>,
    },
    /// The master passed arguments that cannot be forwarded (length mismatch, NUL in a string...).
    #[error("{function} on instance '{instance}': {message}")]
    InvalidArgument {
        /// The C name of the function.
        function: &'static str,
        /// The instance name.
        instance: String,
        /// What is wrong.
        message: String,
    },
}

impl ImportError {
    /// Whether opening failed only at this platform's binary (missing, not loading, or not
    /// an FMI 2.0 binary), after the archive and its model description were read and found
    /// valid: the FMU is sound, it just cannot run here.
    pub fn is_binary_problem(&self) -> bool {
        matches!(
            self,
            ImportError::MissingBinary { .. }
                | ImportError::Load { .. }
                | ImportError::MissingSymbol { .. }
                | ImportError::Version { .. }
        )
    }
}

/// `the archive has binaries for linux64, win64` or says it has none.
fn has_platforms(available: &[String]) -> String {
    if available.is_empty() {
        "the archive has no binaries for any platform".into()
    } else {
        // Folder names come from the archive: escaped, so that they cannot drive a terminal.
        format!(
            "the archive has binaries for {}",
            fmi2_md::printable(&available.join(", "))
        )
    }
}

/// Problems as an indented list, one per line.
fn list(problems: &[Problem]) -> String {
    problems.iter().map(|p| format!("\n  - {p}")).collect()
}

/// `: msg1; msg2` or ` (the FMU logged nothing)`.
fn messages_suffix(messages: &[LogRecord]) -> String {
    if messages.is_empty() {
        return " (the FMU logged nothing)".into();
    }
    let mut out = String::from(": ");
    for (i, m) in messages.iter().enumerate() {
        if i > 0 {
            out.push_str("; ");
        }
        // Writing into a String cannot fail.
        let _ = fmt::write(&mut out, format_args!("{m}"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Status;

    fn record(message: &str) -> LogRecord {
        LogRecord {
            status: Status::Error,
            category: "logStatusError".into(),
            message: message.into(),
        }
    }

    /// A failed call quotes what the FMU logged, each message apart.
    #[test]
    fn a_failed_call_lists_the_fmus_messages_apart() {
        let call = |messages| ImportError::Call {
            function: "fmi2DoStep",
            instance: "plant".into(),
            status: Status::Error,
            messages,
        };
        assert_eq!(
            call(vec![record("first"), record("second")]).to_string(),
            "fmi2DoStep on instance 'plant' returned fmi2Error: [fmi2Error] logStatusError: \
             first; [fmi2Error] logStatusError: second"
        );
        assert_eq!(
            call(Vec::new()).to_string(),
            "fmi2DoStep on instance 'plant' returned fmi2Error (the FMU logged nothing)"
        );
    }
}
