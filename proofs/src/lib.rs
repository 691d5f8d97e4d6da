//! Reference unbounded stack, scoreboard, stack-consistency properties and their drivers.
//!
//! Every property is written once (in [`invariants`], checked by the drivers in [`harness`]) and
//! runs three ways: randomly under `cargo test`, exhaustively over small bounds
//! ([`exhaustive`]), and as Kani proofs where Kani is installed.

pub mod exhaustive;
pub mod harness;
pub mod invariants;
pub mod reference;
pub mod streams;
