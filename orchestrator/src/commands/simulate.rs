//! `simulate` subcommand.

use anyhow::Result;

use crate::args::SimulateArgs;

/// Runs `simulate`.
pub fn run(args: SimulateArgs) -> Result<()> {
    let _ = args;
    anyhow::bail!("`simulate` is not implemented yet")
}
