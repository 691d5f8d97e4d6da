//! Clocked register-transfer model of the SMS hierarchical traversal stack.
//!
//! Conventions (see `../shared/STYLE.md`):
//! - each hardware unit in a file of its own named after it, or a directory when it has parts
//!   (`stack_manager/`, `mem/`);
//! - a unit is a kernel, [`clock::Unit`]: `eval(&self, inputs, &mut step)` reads only its
//!   registers and this cycle's inputs (other units' outputs, in dataflow order) and writes its
//!   outputs and decisions into `step`; `commit(&mut self, &step)` applies them at the clock edge
//!   and takes nothing else (`docs/clocking.md`, "Units" and "One cycle");
//! - every width comes from [`config::Widths`], used alike by the logic, the waveform dump and
//!   the cost report;
//! - signals are exposed to a [`trace::Sink`] through [`trace::Probe`]; the [`trace::NullSink`]
//!   compiles away.
//!
//! No I/O lives in this crate.

/// `NAMES`, `name` and `from_name` (and `Display`, and [`params::Param`]) for a fieldless enum
/// spelled by name in hardware descriptions.
macro_rules! named_enum {
    ($t:ty, $($v:path => $n:literal),+) => {
        impl $t {
            /// Names accepted by [`Self::from_name`], in declaration order.
            pub const NAMES: &'static [&'static str] = &[$($n),+];

            pub fn name(self) -> &'static str {
                match self { $($v => $n),+ }
            }

            pub fn from_name(s: &str) -> Option<Self> {
                match s { $($n => Some($v),)+ _ => None }
            }
        }

        impl $crate::params::Param for $t {
            const KIND: $crate::params::Kind = $crate::params::Kind::Choice(<$t>::NAMES);
            fn value(self) -> $crate::params::Value {
                $crate::params::Value::Name(self.name())
            }
            fn from_value(v: $crate::params::Value) -> Option<$t> {
                match v {
                    $crate::params::Value::Name(n) => <$t>::from_name(n),
                    _ => None,
                }
            }
        }

        impl std::fmt::Display for $t {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

#[macro_use]
pub mod params;
pub mod bank_arbiter;
pub mod clock;
pub mod config;
pub mod gpu;
pub mod logic;
pub mod mem;
pub mod mem_sched;
pub mod node_fetch;
pub mod ray_op;
pub mod rt_unit;
pub mod scheduler;
pub mod sim;
pub mod sm;
pub mod stack_manager;
pub mod stack_unit;
pub mod thread_cycles;
pub mod thread_fsm;
pub mod trace;
pub mod warp_buffer;
