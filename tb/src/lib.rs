//! Testbenches, workloads and reports for the SMS model.

pub mod cli;
pub mod cost;
pub mod table;
