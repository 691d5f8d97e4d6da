//! Testbenches, workloads and reports for the SMS model.

pub mod vcd;
