//! The stack manager as synthesizable Verilog, printed from the same description the simulator
//! runs and `sms prove` proves (docs/verilog.md).

pub mod build;
