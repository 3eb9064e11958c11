//! `orchestrator`: run scenarios, simulate single FMUs, inspect FMUs, reproduce the paper,
//! analyse the convergence of learning.
#![deny(unsafe_code)]

mod args;
mod commands;

use std::process::ExitCode;

use clap::Parser;

/// Exit code after SIGINT, SIGTERM or SIGHUP (128 + SIGINT, as shells report Ctrl-C).
const EXIT_INTERRUPTED: i32 = 130;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    let resume = match cli.command {
        args::Command::Run(_) => "; `run --resume` continues the campaign",
        args::Command::Sweep(_) => "; `sweep --resume` continues the sweep",
        args::Command::Paper(_) => "; `paper --resume` continues the study",
        _ => "",
    };
    // On SIGINT, SIGTERM or SIGHUP, remove the FMUs' extraction folders (≈ 7 MB each) before
    // exiting. Result files need nothing: each is written to a temporary file and renamed,
    // and `--resume` removes temporaries an interrupted run left behind. Without a handler
    // (if installing it fails) the next start reaps the folders instead.
    let _ = ctrlc::set_handler(move || {
        let removed = fmi2_import::remove_extraction_dirs();
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
            orchestrator::console!("error: {}", describe(&e));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes, skipping causes whose text the message already contains
/// (library errors embed their source in their own message).
fn describe(e: &anyhow::Error) -> String {
    let mut msg = e.to_string();
    for cause in e.chain().skip(1) {
        let c = cause.to_string();
        if !msg.contains(&c) {
            msg.push_str(": ");
            msg.push_str(&c);
        }
    }
    msg
}
