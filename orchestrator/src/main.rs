//! `orchestrator`: run scenarios, simulate single FMUs, inspect FMUs, reproduce the paper,
//! analyse the convergence of learning.
#![deny(unsafe_code)]

mod args;
mod commands;

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Parser;

/// Exit code after SIGINT, SIGTERM or SIGHUP (128 + SIGINT, as shells report Ctrl-C).
const EXIT_INTERRUPTED: i32 = 130;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    // What continues the work after a signal, and after a full disk (`run` names its kept
    // trials and its resume command itself, for any failed write: commands/run.rs).
    let resume = Resume::of(&cli.command);
    let after_full_disk = resume
        .as_ref()
        .filter(|_| !matches!(cli.command, args::Command::Run(_)))
        .map(Resume::continues);
    // On SIGINT, SIGTERM or SIGHUP, remove the FMUs' extraction folders (≈ 7 MB each) before
    // exiting. Result files need nothing: each is written to a temporary file and renamed,
    // and `--resume` removes temporaries an interrupted run left behind. Without a handler
    // (if installing it fails) the next start reaps the folders instead.
    let _ = ctrlc::set_handler(move || {
        let removed = fmi2_import::remove_extraction_dirs();
        let resume = resume.as_ref().map_or_else(String::new, Resume::hint);
        orchestrator::console!("interrupted: removed {removed} FMU extraction folder(s){resume}");
        std::process::exit(EXIT_INTERRUPTED);
    });
    let result = match cli.command {
        args::Command::Run(a) => commands::run::run(a),
        args::Command::Simulate(a) => commands::simulate::run(a),
        args::Command::Info(a) => commands::info::run(a),
        args::Command::Paper(a) => commands::paper::run(a),
        args::Command::Analyze(a) => commands::analyze::run(a),
        args::Command::Sweep(a) => commands::sweep::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            let hint = after_full_disk
                .filter(|_| disk_full(&e))
                .map(|resume| {
                    format!(
                        "\nthe disk is full: what finished is kept, and once there is room {resume}"
                    )
                })
                .unwrap_or_default();
            orchestrator::console!("error: {}{hint}", orchestrator::describe(&*e));
            ExitCode::FAILURE
        }
    }
}

/// The command that continues a `run`, `sweep` or `paper` after an interruption, and the
/// file whose presence says there is something to continue.
struct Resume {
    command: String,
    what: &'static str,
    begun: PathBuf,
}

impl Resume {
    fn of(command: &args::Command) -> Option<Self> {
        match command {
            args::Command::Run(a) => {
                let out = a.out_dir();
                // The saved scenario carries the trial count run (`--trials` included).
                Some(Self {
                    command: format!(
                        "orchestrator run {} --out {} --resume",
                        out.join("scenario.toml").display(),
                        out.display()
                    ),
                    what: "the campaign",
                    begun: out.join("progress.toml"),
                })
            }
            args::Command::Sweep(a) => {
                let file = a.sweep.as_ref()?;
                let out = a.out_dir(file);
                let shard = a
                    .shard
                    .as_ref()
                    .map_or_else(String::new, |k| format!(" --shard {k}"));
                Some(Self {
                    command: format!(
                        "orchestrator sweep {} --out {}{shard} --resume",
                        file.display(),
                        out.display()
                    ),
                    what: "the sweep",
                    begun: out.join("sweep.toml"),
                })
            }
            args::Command::Paper(a) => Some(Self {
                command: "paper --resume".into(),
                what: "the study, with the same options",
                begun: a.out.clone(),
            }),
            _ => None,
        }
    }

    /// "`COMMAND` continues WHAT".
    fn continues(&self) -> String {
        format!("`{}` continues {}", self.command, self.what)
    }

    /// What the interruption message adds: the command, or that nothing is kept to resume.
    fn hint(&self) -> String {
        if self.begun.exists() {
            format!("; {}", self.continues())
        } else {
            "; nothing was kept yet, so there is nothing to resume".into()
        }
    }
}

/// Whether `e` comes from a full disk (or a full quota, which Linux reports the same way):
/// a long study stopped by it keeps what it finished, and a resume goes on once there is room.
fn disk_full(e: &anyhow::Error) -> bool {
    e.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::StorageFull)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ENOSPC is found however deep the write's error lies (a sweep wraps the campaign's);
    /// other I/O errors, such as a refused permission, are not taken for it.
    #[test]
    fn a_full_disk_is_found_anywhere_in_the_chain() {
        // ENOSPC, as a write to a full disk returns it on Linux.
        #[cfg(target_os = "linux")]
        let full = std::io::Error::from_raw_os_error(28);
        #[cfg(not(target_os = "linux"))]
        let full = std::io::Error::from(std::io::ErrorKind::StorageFull);
        let e = anyhow::Error::new(full)
            .context("I/O error on x.csv")
            .context("case 3");
        assert!(disk_full(&e));
        let denied = std::io::Error::from(std::io::ErrorKind::PermissionDenied);
        assert!(!disk_full(
            &anyhow::Error::new(denied).context("I/O error on x.csv")
        ));
        assert!(!disk_full(&anyhow::anyhow!("No space left on device")));
    }
}
