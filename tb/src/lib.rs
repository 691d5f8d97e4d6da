//! Testbenches, workloads and reports for the SMS model, in layers that follow the data:
//!
//! ```text
//!   workload  scenes ─► BVHs ─► rays ─► recorded traversals ─► warps in launch order
//!      │
//!   run       cycle-level and functional simulation, sampling, the stack testbench, sweeps
//!      │
//!   report    bench, cost, tables, figures and plots
//!      │
//!   cli       the `sms` commands (argument parsing and output only)
//! ```
//!
//! [`hw`] (hardware descriptions and presets) and [`vcd`] (waveforms) sit beside them. Each layer
//! uses only the layers above it in the picture.

pub mod cli;
pub mod digest;
pub mod error;
pub mod hw;
pub mod prereq;
pub mod prove;
pub mod report;
pub mod run;
#[doc(hidden)]
pub mod testing;
pub mod vcd;
pub mod verilog;
pub mod workload;

pub use error::{Error, Result};
pub use workload::scene::{load_scene, Scene, SceneLibrary};
