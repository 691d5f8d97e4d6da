//! Clocked register-transfer model of the SMS hierarchical traversal stack.
//!
//! Conventions (see `../shared/STYLE.md`):
//! - one hardware unit per file, named after the unit;
//! - each unit keeps its registers as `q` (current) and computes `d` (next) in `eval`, reading
//!   only `q` and its inputs; `commit` is the clock edge (`q <= d`). No unit reads a value that
//!   another unit wrote in the same cycle;
//! - every width comes from [`config::Widths`], used alike by the logic, the waveform dump and
//!   the cost report;
//! - signals are exposed to a [`trace::Sink`] through [`trace::Probe`]; the [`trace::NullSink`]
//!   compiles away.
//!
//! No I/O lives in this crate.

pub mod config;
pub mod mem;
pub mod trace;
