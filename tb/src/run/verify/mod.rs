//! Reference unbounded stack, scoreboard, stack-consistency properties and their drivers: the
//! functional level and the stack testbench run on them, and the `proofs` crate tests them.
//!
//! Every property is written once (in [`invariants`], checked by the drivers in [`harness`]) and
//! runs three ways: randomly under `cargo test` (the `proofs` crate), exhaustively over small
//! bounds ([`exhaustive`], `sms check`), and as Kani proofs where Kani is installed.

pub mod exhaustive;
pub mod harness;
pub mod invariants;
pub mod reference;
pub mod sequence;
pub mod streams;
