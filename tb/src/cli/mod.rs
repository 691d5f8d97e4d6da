//! The `sms` subcommands, one module each: clap `Args` and a `run`.

pub mod check;
pub mod cost;
pub mod stack_config;
