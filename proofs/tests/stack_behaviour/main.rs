//! What the stack design does, one file per behaviour area, all run through the shared test
//! support (`tb::testing`):
//!
//! - `traffic`: the stack traffic each configuration makes (the M = 0 baseline, no spills with
//!   FULL, functional = cycle level without RA, real traversals under every configuration);
//! - `banks`: skew against lockstep bank conflicts, and the conflict bound;
//! - `stores`: global stores and the sequencer (acknowledged stores hold it, and bound the
//!   memory scheduler's queue);
//! - `registers`: a value that does not fit its register;
//! - `scoreboard`: planted bugs caught by the scoreboard, the design passing the same runs.

mod banks;
mod registers;
mod scoreboard;
mod stores;
mod traffic;
