//! The co-simulation master for the CKCM FMUs (and any FMI 2.0 co-simulation FMU):
//! scenario files, the Gauss–Seidel master loop with iteration memory, campaigns with
//! atomic persistence and resume, outputs and plots, and the paper study.
#![deny(unsafe_code)]

/// `eprintln!` that never panics: a console that went away (a pipe whose reader exited, a
/// closed terminal) must not stop a campaign or turn a finished run's exit code into a
/// panic's. What could not be printed is lost; the result files are not.
#[macro_export]
macro_rules! console {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

pub mod campaign;
pub mod master;
pub mod output;
pub mod paper;
pub mod scenario;
pub mod simulate;
pub mod sweep;
pub mod variables;

/// The error and its causes, skipping causes whose text the message already contains
/// (library errors embed their source in their own message): for the CLI's errors, and for
/// warnings that have no error chain to carry the causes (an I/O error's own reason,
/// "Permission denied", is a cause).
pub fn describe(e: &(dyn std::error::Error + 'static)) -> String {
    let mut msg = e.to_string();
    for cause in std::iter::successors(e.source(), |c| c.source()) {
        let c = cause.to_string();
        if !msg.contains(&c) {
            msg.push_str(": ");
            msg.push_str(&c);
        }
    }
    msg
}
