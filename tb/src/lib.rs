//! Testbenches, workloads and reports for the SMS model.
//!
//! The workload side turns scenes into the per-ray stack histories an RT unit would produce:
//! [`scene`] loads geometry, [`bvh`] builds the hierarchies with device addresses, [`raygen`] makes
//! the path tracer's rays, [`traverse`] records every node visit, push and pop, [`workload`]
//! groups the traces into warps in GPU launch order, and [`depth`] summarises stack depths.

pub mod bench;
pub mod bvh;
pub mod cli;
pub mod cost;
pub mod depth;
pub mod error;
pub mod functional;
pub mod geometry;
pub mod hw;
pub mod presets;
pub mod raygen;
mod rng;
pub mod sampling;
pub mod scene;
pub mod sim;
pub mod stack_tb;
pub mod sweep;
pub mod table;
pub mod traverse;
pub mod vcd;
pub mod workload;

pub use error::{Error, Result};
pub use scene::{load_scene, Scene, SceneLibrary};
