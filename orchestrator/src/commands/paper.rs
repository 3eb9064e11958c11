//! `paper` subcommand.

use anyhow::Result;

use crate::args::PaperArgs;

/// Runs `paper`.
pub fn run(args: PaperArgs) -> Result<()> {
    let _ = args;
    anyhow::bail!("`paper` is not implemented yet")
}
