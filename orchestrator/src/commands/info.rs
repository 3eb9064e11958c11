//! `info` subcommand.

use anyhow::Result;

use crate::args::InfoArgs;

/// Runs `info`.
pub fn run(args: InfoArgs) -> Result<()> {
    let _ = args;
    anyhow::bail!("`info` is not implemented yet")
}
