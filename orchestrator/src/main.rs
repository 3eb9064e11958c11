//! `orchestrator`: run scenarios, simulate single FMUs, inspect FMUs, reproduce the paper.

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
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
