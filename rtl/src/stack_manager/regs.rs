//! The stack manager's register and signal types: commands, the ray-buffer fields of a thread
//! and of an SH stack, micro-ops, refusals and event counters. The register structs are generic
//! over their word and bit types so that the decision logic ([`super::policy`]) reads and writes
//! them alike in simulation (`u32`/`bool`) and in a proof (symbolic terms).

use crate::logic::{Int, Logic};
use crate::trace::Kind;

/// A stack entry: a node address.
pub type Entry = u64;

/// Base byte address of the global spill regions in the device address space.
pub const SPILL_BASE: u64 = 0x8000_0000_0000;

/// Value a load returns from a global slot that was never written (a bug in the design under
/// test shows up as this value at a pop, never as a panic).
pub const POISON: Entry = 0xDEAD_DEAD_DEAD_DEAD;

/// How a thread's stack traffic overlaps its traversal (`[stack] timing`).
///
/// The paper's RT unit handles a node's result in sequence: pop (and reload any spilled entry),
/// push the hit children (spilling as needed), and only then read the new stack top for the next
/// node fetch; SPEC section 3 makes a request that needs an earlier one's data wait until that
/// response is in the response FIFO. Vulkan-Sim retires an RT warp only when it has no write
/// pending (`shader.cc` ~3090: `!has_pending_writes()`), i.e. stores are acknowledged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum StackTiming {
    /// The paper's sequence (default): a thread's next node fetch waits until its sequencer is
    /// idle, and a global store completes when the L2's acknowledgement is delivered by the
    /// response FIFO (so a warp cannot leave with a store unacknowledged).
    #[default]
    Blocking,
    /// Global stores are posted (complete when issued), and a pop's
    /// refill and a push's spill proceed while the thread fetches its next node; only the
    /// thread's next stack command waits for them.
    Overlapped,
}

named_enum!(StackTiming, StackTiming::Blocking => "blocking", StackTiming::Overlapped => "overlapped");

impl std::str::FromStr for StackTiming {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        StackTiming::from_name(s).ok_or_else(|| format!("'{s}': expected \"blocking\" or \"overlapped\""))
    }
}

/// A command from the RT unit to the stack manager for one thread, over entry values `V`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum CmdOf<V> {
    #[default]
    None,
    Push(V),
    Pop,
    /// The traversal ended: the stack must be empty; with reallocation the SH stack turns idle.
    Finish,
}

/// A command in simulation.
pub type Cmd = CmdOf<Entry>;

impl Cmd {
    /// The command kinds by waveform code ([`Cmd::code`]): the names of the variants.
    pub const KIND_NAMES: &'static [&'static str] = &["none", "push", "pop", "finish"];
    /// How a waveform shows the command's kind (2 bits).
    pub const KIND: Kind = Kind::Enum { name: "cmd_kind", names: Cmd::KIND_NAMES };

    /// Waveform encoding of the kind (2 bits): an index into [`Cmd::KIND_NAMES`].
    pub fn code(self) -> u64 {
        match self {
            Cmd::None => 0,
            Cmd::Push(_) => 1,
            Cmd::Pop => 2,
            Cmd::Finish => 3,
        }
    }
}

/// Per-thread registers of the ray buffer (besides the RB entries themselves), over words `W` and
/// bits `B`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ThreadRegsOf<W, B> {
    /// Global memory holds entries of this thread.
    pub overflow: B,
    /// Entries this thread holds in its global spill region.
    pub spill_ptr: W,
    /// The thread has finished its traversal.
    pub done: B,
}

/// A thread's registers in simulation.
pub type ThreadRegs = ThreadRegsOf<u32, bool>;

/// Per-SH-stack registers, over words `W` and bits `B`. Stack `s` is thread `s`'s dedicated
/// stack.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct StackRegsOf<W, B> {
    /// Entry index of the newest entry (valid when `!empty`).
    pub top: W,
    /// Entry index of the oldest entry. When empty, `top == bottom`.
    pub bottom: W,
    /// Settles `top == bottom`: empty versus one entry (SPEC 9.1).
    pub empty: B,
    /// Finished and not lent.
    pub idle: B,
    /// Next stack (lane in the warp) on the ring of the chain this stack belongs to.
    pub next_tid: W,
    /// Rank in the chain: 0 oldest, highest = top stack.
    pub priority: W,
    /// Consecutive flushes since the stack last drained; saturates at the flush limit.
    pub flush: W,
}

/// An SH stack's registers in simulation.
pub type StackRegs = StackRegsOf<u32, bool>;

impl<W: Copy, B: Copy> StackRegsOf<W, B> {
    /// Field by field `c ? a : b`.
    pub fn mux<L: Logic<Word = W, Bit = B>>(l: &mut L, c: B, a: Self, b: Self) -> Self {
        StackRegsOf {
            top: l.mux(c, a.top, b.top),
            bottom: l.mux(c, a.bottom, b.bottom),
            empty: l.mux_bit(c, a.empty, b.empty),
            idle: l.mux_bit(c, a.idle, b.idle),
            next_tid: l.mux(c, a.next_tid, b.next_tid),
            priority: l.mux(c, a.priority, b.priority),
            flush: l.mux(c, a.flush, b.flush),
        }
    }

    /// Entries the queue holds, for `m` entries per stack (`top` and `bottom` below `m`): one
    /// conditional subtraction, not a division.
    pub fn entries<L: Logic<Word = W, Bit = B>>(&self, l: &mut L, m: u32) -> W {
        let mw = l.word(m);
        let up = l.add(self.top, mw);
        let d = l.sub(up, self.bottom);
        let d1 = l.add_k(d, 1);
        let wrapped = l.sub(d1, mw);
        let in_row = l.lt(d, mw);
        let n = l.mux(in_row, d1, wrapped);
        let zero = l.word(0);
        l.mux(self.empty, zero, n)
    }
}

impl StackRegs {
    pub fn count(&self, m: u32) -> u32 {
        self.entries(&mut Int, m)
    }
}

impl<W: Copy, B: Copy> ThreadRegsOf<W, B> {
    /// Field by field `c ? a : b`.
    pub fn mux<L: Logic<Word = W, Bit = B>>(l: &mut L, c: B, a: Self, b: Self) -> Self {
        ThreadRegsOf {
            overflow: l.mux_bit(c, a.overflow, b.overflow),
            spill_ptr: l.mux(c, a.spill_ptr, b.spill_ptr),
            done: l.mux_bit(c, a.done, b.done),
        }
    }
}

/// Where a store's data comes from, over entry values `V`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SrcOf<V> {
    Value(V),
    /// The thread's data latch, filled by the previous load.
    Latch,
}

/// A store's data source in simulation.
pub type Src = SrcOf<u64>;

/// One step of a request sequence, over words `W` and entry values `V`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UopOf<W, V> {
    ShLoad {
        stack: W,
        entry: W,
    },
    ShStore {
        stack: W,
        entry: W,
        src: SrcOf<V>,
    },
    GlobalLoad {
        slot: W,
    },
    GlobalStore {
        slot: W,
        src: SrcOf<V>,
    },
    /// Latch → RB bottom.
    RbBottom,
    /// Give a drained borrowed stack back (Idle ← 1), after its last load completed.
    Release {
        stack: W,
    },
}

/// A micro-op in simulation.
pub type Uop = UopOf<u32, u64>;

impl Uop {
    /// The micro-ops by waveform code ([`Uop::code`]): `none` (no micro-op in flight), then
    /// the names of the variants.
    pub const NAMES: &'static [&'static str] =
        &["none", "sh_load", "sh_store", "global_load", "global_store", "rb_bottom", "release"];
    /// How a waveform shows the micro-op in flight (3 bits).
    pub const KIND: Kind = Kind::Enum { name: "uop", names: Uop::NAMES };
    /// Width of the waveform encoding.
    pub const CODE_BITS: u32 = crate::config::UOP_CODE_BITS;

    /// Waveform encoding of `uop` (0: none): an index into [`Uop::NAMES`].
    pub fn code(uop: Option<Uop>) -> u64 {
        match uop {
            None => 0,
            Some(Uop::ShLoad { .. }) => 1,
            Some(Uop::ShStore { .. }) => 2,
            Some(Uop::GlobalLoad { .. }) => 3,
            Some(Uop::GlobalStore { .. }) => 4,
            Some(Uop::RbBottom) => 5,
            Some(Uop::Release { .. }) => 6,
        }
    }
}

/// Commands the stack manager refuses. Each is a bug in whoever sent the command, or (spill
/// region) a traversal deeper than the configured region.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StackError {
    PopEmpty {
        thread: u32,
    },
    FinishNonEmpty {
        thread: u32,
    },
    Busy {
        thread: u32,
    },
    AfterFinish {
        thread: u32,
    },
    SpillRegionFull {
        thread: u32,
        entries: u32,
    },
    /// A register would take a value its width (from [`Widths`]) cannot hold.
    Overflow {
        thread: u32,
        field: &'static str,
        value: u64,
        bits: u32,
    },
    /// The design addressed a stack or SH entry that does not exist (a design bug, reported
    /// instead of indexing past an array).
    OutOfRange {
        thread: u32,
        what: &'static str,
        value: u64,
    },
}

impl std::fmt::Display for StackError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StackError::PopEmpty { thread } => write!(f, "thread {thread}: pop on an empty stack"),
            StackError::FinishNonEmpty { thread } => {
                write!(f, "thread {thread}: finish with a non-empty stack")
            }
            StackError::Busy { thread } => {
                write!(f, "thread {thread}: command while the sequencer is busy")
            }
            StackError::AfterFinish { thread } => {
                write!(f, "thread {thread}: command after finish")
            }
            StackError::OutOfRange { thread, what, value } => {
                write!(f, "thread {thread}: {what} {value} lies outside the stack manager's registers")
            }
            StackError::Overflow { thread, field, value, bits } => {
                write!(f, "thread {thread}: {field} = {value} does not fit its {bits}-bit register")
            }
            StackError::SpillRegionFull { thread, entries } => {
                write!(
                    f,
                    "thread {thread}: global spill region full ({entries} entries); raise spill_ptr_bits"
                )
            }
        }
    }
}

impl std::error::Error for StackError {}

impl StackError {
    pub fn thread(&self) -> u32 {
        match *self {
            StackError::PopEmpty { thread }
            | StackError::FinishNonEmpty { thread }
            | StackError::Busy { thread }
            | StackError::AfterFinish { thread }
            | StackError::SpillRegionFull { thread, .. }
            | StackError::Overflow { thread, .. }
            | StackError::OutOfRange { thread, .. } => thread,
        }
    }
}

/// Declares [`StackStats`] from one list of counters, with their names in the same order.
macro_rules! stack_stats {
    ($($(#[$doc:meta])* $f:ident),+ $(,)?) => {
        /// Event counters. Transfers are counted when planned, so both executors count alike.
        #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
        pub struct StackStats {
            $($(#[$doc])* pub $f: u64,)+
        }

        impl StackStats {
            /// Number of counters.
            pub const COUNT: usize = [$(stringify!($f)),+].len();

            /// Every counter's field name, in declaration order (the order of [`Self::values`]).
            pub const NAMES: [&'static str; StackStats::COUNT] = [$(stringify!($f)),+];

            /// Every counter's value, in the order of [`Self::NAMES`].
            pub fn values(&self) -> [u64; StackStats::COUNT] {
                [$(self.$f),+]
            }

            /// The counters from their values in the order of [`Self::NAMES`].
            pub fn from_values(v: [u64; StackStats::COUNT]) -> StackStats {
                let [$($f),+] = v;
                StackStats { $($f),+ }
            }
        }
    };
}

stack_stats! {
    pushes,
    pops,
    rb_to_sh,
    sh_to_rb,
    sh_to_global,
    global_to_sh,
    /// M = 0: RB spills straight to global and reloads from it.
    rb_to_global,
    global_to_rb,
    borrows,
    releases,
    flushes,
    /// Flushes at the flush limit (the counter stayed saturated).
    flushes_saturated,
    /// Dedicated stacks that drained under borrowed ones and moved to the chain's bottom.
    demotions,
    /// Entries a restart design (`+RT`) dropped on overflow.
    drops,
    /// Pops a restart design answered with Restart (the stack empty after drops).
    restarts,
}

impl StackStats {
    /// `(name, value)` of every counter, in declaration order.
    pub fn fields(&self) -> impl Iterator<Item = (&'static str, u64)> {
        Self::NAMES.into_iter().zip(self.values())
    }

    /// Every counter of `self` combined with the same counter of `o` by `f`.
    pub fn zip(&self, o: &StackStats, f: impl Fn(u64, u64) -> u64) -> StackStats {
        let (a, b) = (self.values(), o.values());
        StackStats::from_values(std::array::from_fn(|i| f(a[i], b[i])))
    }

    /// Every counter mapped by `f`.
    pub fn map(&self, f: impl Fn(u64) -> u64) -> StackStats {
        StackStats::from_values(self.values().map(f))
    }

    /// Adds `o`'s counts to these (totals over RT units).
    pub fn add(&mut self, o: &StackStats) {
        *self = self.zip(o, |a, b| a + b);
    }

    /// The counts since `before` (a snapshot of the same counters).
    pub fn since(&self, before: &StackStats) -> StackStats {
        self.zip(before, |a, b| a - b)
    }

    pub fn sh_loads(&self) -> u64 {
        self.sh_to_rb + self.sh_to_global
    }
    pub fn sh_stores(&self) -> u64 {
        self.rb_to_sh + self.global_to_sh
    }
    pub fn global_loads(&self) -> u64 {
        self.global_to_sh + self.global_to_rb
    }
    pub fn global_stores(&self) -> u64 {
        self.sh_to_global + self.rb_to_global
    }
    /// Off-chip stack accesses (loads + stores).
    pub fn global_accesses(&self) -> u64 {
        self.global_loads() + self.global_stores()
    }
}
