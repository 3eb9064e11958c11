//! One module per subcommand.

pub mod analyze;
pub mod info;
pub mod paper;
pub mod run;
pub mod simulate;
pub mod sweep;
