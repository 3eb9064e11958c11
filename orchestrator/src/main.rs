//! `orchestrator`: run scenarios, simulate single FMUs, inspect FMUs, reproduce the paper.
#![deny(unsafe_code)]

mod args;
mod commands;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    let result = match cli.command {
        args::Command::Run(a) => commands::run::run(a),
        args::Command::Simulate(a) => commands::simulate::run(a),
        args::Command::Info(a) => commands::info::run(a),
        args::Command::Paper(a) => commands::paper::run(a),
        args::Command::Sweep(a) => commands::sweep::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", describe(&e));
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
