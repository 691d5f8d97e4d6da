//! Testbenches, workloads and reports for the SMS model, in layers that follow the data:
//!
//! ```text
//!   cli, prereq, testing   the `sms` commands (argument parsing and output only); the scenes
//!      │                   a test needs; test helpers
//!   verilog                the Verilog printer, its co-simulation and synthesis (a cost report)
//!      │
//!   report                 bench, cost, tables, figures and plots
//!      │
//!   run                    cycle-level and functional simulation, sampling, the stack testbench
//!      │                   and its verification, sweeps, the bench's and the ablation's runs,
//!      │                   example waves, the provenance of what ran
//!   prove                  the specification, the scoreboard the simulator checks every decision
//!      │                   with, and the SMT proofs
//!   workload               scenes ─► BVHs ─► rays ─► recorded traversals ─► warps in launch order
//!      │
//!   hw, vcd                hardware descriptions and presets; waveforms
//!      │
//!   error, digest          errors; digests of bytes (file hashes, model and hardware identities)
//! ```
//!
//! A module names only modules of the layers below it, never one beside it, and no two source
//! files name each other, directly or through others. `tests/layers.rs` checks both against
//! this picture.

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
