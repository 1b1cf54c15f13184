//! The `ballisto` binary's command line: one module per group of subcommands.

pub mod args;
pub mod estimate;
pub mod manual;
pub mod sim;
pub mod tc;
pub mod telemetry;
