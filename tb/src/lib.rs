//! Testbenches, workloads and reports for the SMS model.

pub mod cost;
pub mod table;
