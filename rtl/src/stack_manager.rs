//! Stack manager: the ray-buffer stack fields, the SH queues, the global spill regions, and the
//! per-thread sequencer that moves entries between them.
//!
//! ```text
//!  cmd (push/pop/finish) ──► plan ──► registers (Top, Bottom, Overflow, Idle, Next TID, …)
//!                              └────► micro-op program ──► sequencer ──► SH requests ──► bank arbiter
//!                                                             ▲    └───► global requests ─► mem sched
//!                                                             └── completions (registered, next cycle)
//! ```
//!
//! A command is accepted only from a thread whose sequencer is idle (`ready`, a register), one
//! per thread per cycle (the callers' contract). Accepting it
//! updates the thread's bookkeeping registers at once and loads the sequencer with the exact
//! request sequence of SPEC sections 3 and 5 (e.g. SH load → global store → SH store). The
//! sequencer issues one micro-op at a time, in order; a micro-op that needs an earlier load's data
//! waits for it in the thread's data latch. Data moves when a request completes, so the SH array
//! and the global spill regions hold real values and every pop is checked against a reference.
//!
//! Clocking: [`StackManager::eval`] is the cycle's combinational logic. It reads only the
//! registers and this cycle's inputs and writes a [`StackStep`]: the outputs (SH and global
//! requests, pops, refusals) and the ordered register writes (the next state as a journal, so a
//! cycle copies no register array); [`StackManager::commit`] applies them at the clock edge.
//! Planning a command (`Planner`) is pure in the same way: it reads the stack registers as the
//! cycle's earlier writes leave them (two threads of a warp may both touch idle stacks in one
//! cycle) and returns its decisions and micro-ops; a refused command changes nothing.
//!
//! The same plan drives two executors: eval/commit (cycle level, through the bank arbiter and
//! memory scheduler) and [`StackManager::apply`] (functional: micro-ops complete at once).
//! Decisions that depend only on a thread's own history are identical in both.
//!
//! Design choices for SPEC section 9 are argued in `rtl/DESIGN.md`.

use std::collections::VecDeque;

use crate::bank_arbiter::{ShReq, MAX_WORDS};
use crate::config::{warp_lane, Config, ConfigError, Widths};
use crate::mem::addr::{LocalLayout, LocalMap};
use crate::mem_sched::GReq;
use crate::trace::{Kind, Probe, Sink};

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
    /// The model before issue 12: global stores are posted (complete when issued), and a pop's
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

/// A command from the RT unit to the stack manager for one thread.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Cmd {
    #[default]
    None,
    Push(Entry),
    Pop,
    /// The traversal ended: the stack must be empty; with reallocation the SH stack turns idle.
    Finish,
}

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

/// Per-thread registers of the ray buffer (besides the RB entries themselves).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ThreadRegs {
    /// Global memory holds entries of this thread.
    pub overflow: bool,
    /// Entries this thread holds in its global spill region.
    pub spill_ptr: u32,
    /// The thread has finished its traversal.
    pub done: bool,
}

/// Per-SH-stack registers. Stack `s` is thread `s`'s dedicated stack.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct StackRegs {
    /// Entry index of the newest entry (valid when `!empty`).
    pub top: u32,
    /// Entry index of the oldest entry. When empty, `top == bottom`.
    pub bottom: u32,
    /// Settles `top == bottom`: empty versus one entry (SPEC 9.1).
    pub empty: bool,
    /// Finished and not lent.
    pub idle: bool,
    /// Next stack (lane in the warp) on the ring of the chain this stack belongs to.
    pub next_tid: u32,
    /// Rank in the chain: 0 oldest, highest = top stack.
    pub priority: u32,
    /// Consecutive flushes since the stack last drained; saturates at the flush limit.
    pub flush: u32,
}

impl StackRegs {
    pub fn count(&self, m: u32) -> u32 {
        if self.empty {
            0
        } else {
            // top and bottom are below m: one conditional subtraction, not a division.
            let d = self.top + m - self.bottom;
            if d < m {
                d + 1
            } else if d < 2 * m {
                d - m + 1
            } else {
                d % m + 1
            }
        }
    }
}

/// Where a store's data comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Src {
    Value(Entry),
    /// The thread's data latch, filled by the previous load.
    Latch,
}

/// One step of a request sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Uop {
    ShLoad {
        stack: u32,
        entry: u32,
    },
    ShStore {
        stack: u32,
        entry: u32,
        src: Src,
    },
    GlobalLoad {
        slot: u32,
    },
    GlobalStore {
        slot: u32,
        src: Src,
    },
    /// Latch → RB bottom.
    RbBottom,
    /// Give a drained borrowed stack back (Idle ← 1), after its last load completed.
    Release {
        stack: u32,
    },
}

impl Uop {
    /// The micro-ops by waveform code ([`Uop::code`]): `none` (no micro-op in flight), then
    /// the names of the variants.
    pub const NAMES: &'static [&'static str] =
        &["none", "sh_load", "sh_store", "global_load", "global_store", "rb_bottom", "release"];
    /// How a waveform shows the micro-op in flight (3 bits).
    pub const KIND: Kind = Kind::Enum { name: "uop", names: Uop::NAMES };
    /// Width of the waveform encoding.
    pub const CODE_BITS: u32 = 3;

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
            | StackError::Overflow { thread, .. } => thread,
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

/// Deliberately broken variants, for showing the checkers catch bugs. Only builds with the
/// `mutants` feature plant them ([`StackManager::mutant`]); the list is the one source of their
/// names (`sms check --mutant`, the proofs' mutant tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mutant {
    /// The circular queue wraps to entry 1 instead of 0.
    QueueWrapOffByOne,
    /// SH → RB reload takes the oldest SH entry instead of the newest.
    ReloadWrongEntry,
    /// An RB → SH spill advances Top but never stores the entry.
    SpillDropsEntry,
    /// A pop never reloads from global memory.
    MissingGlobalReload,
    /// A borrowed stack is released while it still holds one entry.
    EarlyRelease,
    /// Overflow is not cleared when global memory empties.
    SkipOverflowClear,
    /// A drained or released stack keeps its flush count.
    FlushKeepsCount,
    /// A drained borrowed stack turns Idle when the pop is planned, before its last entry is read.
    EagerRelease,
    /// Skew wrong for one M: with M = 2 every lane starts at entry `lane % 2` whatever the
    /// bank count (right only when 2M ≥ banks / words per entry).
    SkewWrongForOneM,
    /// A released stack keeps its Priority (rank in the chain it left).
    PriorityKeptOnRelease,
    /// Overflow is cleared when one global entry is still left (one pop early).
    OverflowClearedEarly,
    /// A release assumes the borrowed stack sits right after its owner on the ring: the owner's
    /// Next TID takes the released stack's, whatever stack really points at it (wrong once a
    /// flush has rotated the chain).
    ReleaseAssumesAdjacent,
    /// A pop's global reload goes into the top stack of the chain instead of the oldest.
    ReloadIntoTop,
    /// The idle-stack search also takes an active thread's empty, unchained dedicated stack: a
    /// stack lent while its owner is still active.
    LendActiveStack,
}

impl Mutant {
    /// Every mutant, in declaration order (the order of [`Self::NAMES`]).
    pub const ALL: [Mutant; 14] = [
        Mutant::QueueWrapOffByOne,
        Mutant::ReloadWrongEntry,
        Mutant::SpillDropsEntry,
        Mutant::MissingGlobalReload,
        Mutant::EarlyRelease,
        Mutant::SkipOverflowClear,
        Mutant::FlushKeepsCount,
        Mutant::EagerRelease,
        Mutant::SkewWrongForOneM,
        Mutant::PriorityKeptOnRelease,
        Mutant::OverflowClearedEarly,
        Mutant::ReleaseAssumesAdjacent,
        Mutant::ReloadIntoTop,
        Mutant::LendActiveStack,
    ];
}

named_enum!(
    Mutant,
    Mutant::QueueWrapOffByOne => "queue-wrap-off-by-one",
    Mutant::ReloadWrongEntry => "reload-wrong-entry",
    Mutant::SpillDropsEntry => "spill-drops-entry",
    Mutant::MissingGlobalReload => "missing-global-reload",
    Mutant::EarlyRelease => "early-release",
    Mutant::SkipOverflowClear => "skip-overflow-clear",
    Mutant::FlushKeepsCount => "flush-keeps-count",
    Mutant::EagerRelease => "eager-release",
    Mutant::SkewWrongForOneM => "skew-wrong-for-one-m",
    Mutant::PriorityKeptOnRelease => "priority-kept-on-release",
    Mutant::OverflowClearedEarly => "overflow-cleared-early",
    Mutant::ReleaseAssumesAdjacent => "release-assumes-adjacent",
    Mutant::ReloadIntoTop => "reload-into-top",
    Mutant::LendActiveStack => "lend-active-stack"
);

#[derive(Debug, Default, PartialEq, Eq, Hash)]
struct Sequencer {
    uops: VecDeque<Uop>,
    inflight: Option<Uop>,
    latch: Option<Entry>,
}

/// Field by field, so that `clone_from` keeps the queue's allocation (see [`StackManager`]'s).
impl Clone for Sequencer {
    fn clone(&self) -> Self {
        let Sequencer { uops, inflight, latch } = self;
        Sequencer { uops: uops.clone(), inflight: *inflight, latch: *latch }
    }
    fn clone_from(&mut self, src: &Self) {
        let Sequencer { uops, inflight, latch } = src;
        self.uops.clone_from(uops);
        self.inflight = *inflight;
        self.latch = *latch;
    }
}

/// The members of one thread's chain, in ring order from its dedicated stack.
#[derive(Clone, Copy)]
struct Chain {
    ids: [u32; 32],
    len: usize,
}

impl Chain {
    /// The chain of thread `t`, following `next_tid` of each stack around the ring.
    fn of(t: u32, warp_size: u32, next_tid: impl Fn(u32) -> u32) -> Chain {
        let mut c = Chain { ids: [0; 32], len: 0 };
        let base = t - warp_lane(t, warp_size).1;
        let mut s = t;
        loop {
            c.ids[c.len] = s;
            c.len += 1;
            s = base + next_tid(s);
            if s == t || c.len == c.ids.len() {
                return c;
            }
        }
    }

    fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        self.ids[..self.len].iter().copied()
    }
}

/// One register or memory write the cycle decided, applied in order at the clock edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Write {
    Thread(u32, ThreadRegs),
    RbPushBack(u32, Entry),
    RbPopBack(u32),
    RbPopFront(u32),
    RbPushFront(u32, Entry),
    Sh(usize, Entry),
    Global {
        thread: u32,
        slot: u32,
        value: Entry,
    },
    /// A sequencer's next state; `issued`: its queue's head left.
    Seq {
        thread: u32,
        issued: bool,
        inflight: Option<Uop>,
        latch: Option<Entry>,
    },
    Emit(u32, Uop),
}

/// This cycle's inputs of the stack manager.
#[derive(Clone, Copy, Debug, Default)]
pub struct StackIn<'a> {
    /// Commands, at most one per thread, each from a thread that is [`StackManager::ready`].
    pub cmds: &'a [(u32, Cmd)],
    /// Threads whose SH request the bank arbiter completed (its registered `done`).
    pub done: &'a [u32],
    /// Thread whose load data (or, with acknowledged stores, store acknowledgement) the response
    /// FIFO delivered (its registered `deq`).
    pub deq: Option<u32>,
}

/// The stack manager's cycle: its outputs and the writes its registers take at the clock edge
/// ([`StackManager::eval`], [`StackManager::commit`]). A reusable buffer: a cycle allocates
/// nothing once it has grown.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct StackStep {
    writes: Vec<Write>,
    /// Stack registers the cycle changed, as it leaves them (one entry per stack).
    stacks: Vec<(u32, StackRegs)>,
    /// Sequencers the cycle's completions changed: (thread, inflight, latch).
    completed: Vec<(u32, Option<Uop>, Option<Entry>)>,
    stats: StackStats,
    /// Scratch of one plan: the stack registers it changed, and where its writes start.
    plan_stacks: Vec<(u32, StackRegs)>,
    /// SH requests to the bank arbiter.
    pub sh_req: Vec<ShReq>,
    /// Global requests to the memory scheduler.
    pub g_req: Vec<GReq>,
    /// Pops answered: (thread, entry).
    pub pops: Vec<(u32, Entry)>,
    /// Commands refused (the per-thread error signals).
    pub errors: Vec<StackError>,
}

impl StackStep {
    fn clear(&mut self) {
        self.writes.clear();
        self.stacks.clear();
        self.completed.clear();
        self.stats = StackStats::default();
        self.plan_stacks.clear();
        self.sh_req.clear();
        self.g_req.clear();
        self.pops.clear();
        self.errors.clear();
    }

    /// What the cycle answered to thread `t`'s command: the popped entry, nothing, or the
    /// refusal.
    pub fn answer(&self, t: u32) -> Result<Option<Entry>, StackError> {
        if let Some(e) = self.errors.iter().find(|e| e.thread() == t) {
            return Err(*e);
        }
        Ok(self.pops.iter().find(|p| p.0 == t).map(|p| p.1))
    }

    fn stack_now(&self, q: &[StackRegs], s: u32) -> StackRegs {
        self.stacks.iter().find(|x| x.0 == s).map_or(q[s as usize], |x| x.1)
    }

    fn set_stack(&mut self, s: u32, r: StackRegs) {
        match self.stacks.iter_mut().find(|x| x.0 == s) {
            Some(x) => x.1 = r,
            None => self.stacks.push((s, r)),
        }
    }
}

/// The stack manager of one RT unit: `warps × warp_size` threads.
#[derive(Debug, PartialEq, Eq, Hash)]
pub struct StackManager {
    cfg: Config,
    w: Widths,
    /// Which SM this is: places the spill regions in the device address space.
    sm: u32,
    /// Where spill slots live ([`StackManager::set_local_layout`]; per-thread regions until set).
    local: LocalMap,
    threads: Vec<ThreadRegs>,
    stacks: Vec<StackRegs>,
    rb: Vec<VecDeque<Entry>>,
    seq: Vec<Sequencer>,
    /// Bit t: thread t has micro-ops queued (derived from `seq`, so a cycle visits only those).
    queued: Vec<u64>,
    /// Bit t: thread t's sequencer is not `ready` (micro-ops queued or one in flight; derived from
    /// `seq`, so `ready` reads one bit instead of the sequencer).
    busy: Vec<u64>,
    sh_data: Vec<Entry>,
    global: Vec<Vec<Entry>>,
    /// A global store stays in flight until its acknowledgement arrives on the global
    /// completion input ([`StackTiming::Blocking`]); otherwise it is posted.
    acked_stores: bool,
    pub stats: StackStats,
    #[cfg(feature = "mutants")]
    pub mutant: Option<Mutant>,
    /// Reused by the one-command entry points ([`StackManager::accept`], `apply`); always empty
    /// between calls.
    scratch: StackStep,
}

/// Field by field, so that `clone_from` reuses every vector's allocation: the exhaustive search
/// (`sms check`) clones a model for each transition it tries. `clone` builds the struct and
/// `clone_from` destructures it, each naming every field, so a field added to the struct and
/// not cloned here does not compile.
impl Clone for StackManager {
    fn clone(&self) -> Self {
        StackManager {
            cfg: self.cfg,
            w: self.w,
            sm: self.sm,
            local: self.local,
            threads: self.threads.clone(),
            stacks: self.stacks.clone(),
            rb: self.rb.clone(),
            seq: self.seq.clone(),
            queued: self.queued.clone(),
            busy: self.busy.clone(),
            sh_data: self.sh_data.clone(),
            global: self.global.clone(),
            acked_stores: self.acked_stores,
            stats: self.stats,
            #[cfg(feature = "mutants")]
            mutant: self.mutant,
            scratch: self.scratch.clone(),
        }
    }

    fn clone_from(&mut self, src: &Self) {
        let StackManager {
            cfg,
            w,
            sm,
            local,
            threads,
            stacks,
            rb,
            seq,
            queued,
            busy,
            sh_data,
            global,
            acked_stores,
            stats,
            #[cfg(feature = "mutants")]
            mutant,
            scratch,
        } = src;
        self.cfg = *cfg;
        self.w = *w;
        self.sm = *sm;
        self.local = *local;
        self.threads.clone_from(threads);
        self.stacks.clone_from(stacks);
        self.rb.clone_from(rb);
        self.seq.clone_from(seq);
        self.queued.clone_from(queued);
        self.busy.clone_from(busy);
        self.sh_data.clone_from(sh_data);
        self.global.clone_from(global);
        self.acked_stores = *acked_stores;
        self.stats = *stats;
        #[cfg(feature = "mutants")]
        {
            self.mutant = *mutant;
        }
        // Empty between calls on both sides; keeping ours keeps its capacity.
        debug_assert_eq!(*scratch, StackStep::default());
        self.scratch.clear();
    }
}

impl StackManager {
    pub fn new(cfg: Config, sm: u32) -> Result<Self, ConfigError> {
        let w = cfg.widths()?;
        let n = cfg.threads() as usize;
        let mut s = StackManager {
            cfg,
            w,
            sm,
            local: LocalMap {
                layout: LocalLayout::Linear,
                base: SPILL_BASE,
                sms: sm + 1,
                threads: cfg.threads(),
                warp_size: cfg.warp_size,
                entry_bytes: cfg.entry_bytes,
                slots: 1u64 << cfg.spill_ptr_bits,
            },
            threads: vec![ThreadRegs::default(); n],
            stacks: vec![StackRegs::default(); n],
            rb: vec![VecDeque::new(); n],
            seq: vec![Sequencer::default(); n],
            queued: vec![0; n.div_ceil(64)],
            busy: vec![0; n.div_ceil(64)],
            sh_data: vec![0; n * cfg.sh_entries as usize],
            global: vec![Vec::new(); n],
            acked_stores: false,
            stats: StackStats::default(),
            #[cfg(feature = "mutants")]
            mutant: None,
            scratch: StackStep::default(),
        };
        for wp in 0..cfg.warps {
            s.load_warp(wp, u32::MAX >> (32 - cfg.warp_size));
        }
        Ok(s)
    }

    pub fn config(&self) -> &Config {
        &self.cfg
    }
    /// Global stores wait for their acknowledgement (`true`, [`StackTiming::Blocking`]) or are
    /// posted (`false`, the default of [`StackManager::new`], and [`StackTiming::Overlapped`]).
    /// The functional level ([`StackManager::apply`], [`StackManager::complete_next`]) completes
    /// a store at once either way.
    pub fn with_acked_stores(mut self, acked: bool) -> Self {
        self.acked_stores = acked;
        self
    }
    pub fn acked_stores(&self) -> bool {
        self.acked_stores
    }
    pub fn widths(&self) -> &Widths {
        &self.w
    }
    pub fn thread(&self, t: u32) -> &ThreadRegs {
        &self.threads[t as usize]
    }
    pub fn stack(&self, s: u32) -> &StackRegs {
        &self.stacks[s as usize]
    }
    /// RB entries of thread `t`, oldest (bottom) first.
    pub fn rb(&self, t: u32) -> &VecDeque<Entry> {
        &self.rb[t as usize]
    }
    /// SH entry `e` of stack `s`.
    pub fn sh_entry(&self, s: u32, e: u32) -> Entry {
        self.sh_data[(s * self.cfg.sh_entries + e) as usize]
    }
    /// Global spill region of thread `t`: written slots, oldest first.
    pub fn global(&self, t: u32) -> &[Entry] {
        let len = self.threads[t as usize].spill_ptr as usize;
        let g = &self.global[t as usize];
        &g[..len.min(g.len())]
    }
    /// Micro-ops the thread still has to issue (after `accept`, the whole program).
    pub fn pending_uops(&self, t: u32) -> impl Iterator<Item = &Uop> + '_ {
        self.seq[t as usize].uops.iter()
    }
    /// Stacks of thread `t`'s chain, in ring order starting at its dedicated stack.
    pub fn chain(&self, t: u32) -> Vec<u32> {
        Chain::of(t, self.cfg.warp_size, |s| self.stacks[s as usize].next_tid).iter().collect()
    }
    /// Ready for a command: the thread's sequencer is idle.
    #[inline]
    pub fn ready(&self, t: u32) -> bool {
        self.busy[(t / 64) as usize] & 1 << (t % 64) == 0
    }
    /// The lanes of warp `w` that are [`StackManager::ready`] (bit l: thread `w · warp_size + l`).
    /// A warp's threads never straddle two words of `busy`: the warp size is a power of two of
    /// at most 32 ([`Config::validate`]).
    #[inline]
    pub fn ready_lanes(&self, w: u32) -> u32 {
        let ws = self.cfg.warp_size;
        let first = w * ws;
        let bits = self.busy[(first / 64) as usize] >> (first % 64);
        !(bits as u32) & (u32::MAX >> (32 - ws))
    }
    /// Some thread will issue a micro-op in the next `step` without waiting for a completion
    /// (it has micro-ops queued and none in flight). When false, every busy thread waits on the
    /// bank arbiter or on global memory.
    pub fn can_issue(&self) -> bool {
        self.queued.iter().enumerate().any(|(word, &bits)| {
            let mut rest = bits;
            while rest != 0 {
                let t = word * 64 + rest.trailing_zeros() as usize;
                rest &= rest - 1;
                if self.seq[t].inflight.is_none() {
                    return true;
                }
            }
            false
        })
    }
    /// No thread has a micro-op queued (some may still wait for one in flight).
    #[inline]
    pub fn nothing_queued(&self) -> bool {
        self.queued.iter().all(|&w| w == 0)
    }
    /// No thread has work in flight.
    pub fn quiescent(&self) -> bool {
        self.busy.iter().all(|&w| w == 0)
    }
    pub fn warp_of(&self, t: u32) -> u32 {
        warp_lane(t, self.cfg.warp_size).0
    }
    /// Every thread of warp `w` finished and quiet: the warp may leave.
    pub fn warp_done(&self, w: u32) -> bool {
        self.warp_threads(w).all(|t| self.threads[t as usize].done && self.ready(t))
    }
    pub fn warp_threads(&self, w: u32) -> std::ops::Range<u32> {
        w * self.cfg.warp_size..(w + 1) * self.cfg.warp_size
    }

    /// Lays the spill slots out as `layout` among the threads of `sms` SMs (the memory system's
    /// `local_layout`; see [`LocalMap`]).
    pub fn set_local_layout(&mut self, layout: LocalLayout, sms: u32) {
        self.local.layout = layout;
        self.local.sms = sms.max(self.sm + 1);
    }

    /// Byte address of a global spill slot.
    pub fn spill_addr(&self, t: u32, slot: u32) -> u64 {
        self.local.addr(self.sm, t, slot)
    }

    /// Loads a new warp into slot `w`; lanes not in `active` start finished.
    /// The previous occupant must have left (`warp_done`).
    pub fn load_warp(&mut self, w: u32, active: u32) {
        let ws = self.cfg.warp_size;
        for lane in 0..ws {
            let t = (w * ws + lane) as usize;
            let base = self.skew_base(lane);
            let on = active & (1 << lane) != 0;
            self.threads[t] = ThreadRegs { overflow: false, spill_ptr: 0, done: !on };
            self.stacks[t] = StackRegs {
                top: base,
                bottom: base,
                empty: true,
                idle: !on && self.cfg.realloc.is_some(),
                next_tid: lane,
                priority: 0,
                flush: 0,
            };
            self.rb[t].clear();
            self.seq[t] = Sequencer::default();
            self.sync_queued(t as u32);
            self.global[t].clear();
        }
    }

    /// The base entry of `lane`'s stack ([`Config::skew_base`]).
    fn skew_base(&self, lane: u32) -> u32 {
        if self.mutant(Mutant::SkewWrongForOneM) && self.cfg.skew && self.cfg.sh_entries == 2 {
            return lane % 2;
        }
        self.cfg.skew_base(lane)
    }

    #[inline(always)]
    fn mutant(&self, _m: Mutant) -> bool {
        #[cfg(feature = "mutants")]
        {
            self.mutant == Some(_m)
        }
        #[cfg(not(feature = "mutants"))]
        {
            false
        }
    }

    // ---- executing micro-ops ---------------------------------------------------------------

    fn sh_index(&self, stack: u32, entry: u32) -> usize {
        (stack * self.cfg.sh_entries + entry) as usize
    }

    /// The data effect of completing micro-op `u` of thread `t`, whose data latch is `latch`.
    fn complete_into(&self, t: u32, u: Uop, latch: &mut Option<Entry>, d: &mut StackStep) {
        let mut take = |src: Src| match src {
            Src::Value(v) => v,
            Src::Latch => latch.take().unwrap_or(POISON),
        };
        match u {
            Uop::ShLoad { stack, entry } => *latch = Some(self.sh_data[self.sh_index(stack, entry)]),
            Uop::ShStore { stack, entry, src } => {
                let v = take(src);
                d.writes.push(Write::Sh(self.sh_index(stack, entry), v));
            }
            Uop::GlobalLoad { slot } => {
                *latch = Some(self.global[t as usize].get(slot as usize).copied().unwrap_or(POISON));
            }
            Uop::GlobalStore { slot, src } => {
                let value = take(src);
                d.writes.push(Write::Global { thread: t, slot, value });
            }
            Uop::RbBottom => {
                let v = take(Src::Latch);
                d.writes.push(Write::RbPushFront(t, v));
            }
            Uop::Release { stack } => {
                let r = StackRegs { idle: true, ..d.stack_now(&self.stacks, stack) };
                d.set_stack(stack, r);
            }
        }
    }

    /// Completes `u` of thread `t` at once (the functional level).
    fn complete(&mut self, t: u32, u: Uop) {
        let mut d = std::mem::take(&mut self.scratch);
        let mut latch = self.seq[t as usize].latch;
        self.complete_into(t, u, &mut latch, &mut d);
        self.seq[t as usize].latch = latch;
        self.commit(&d);
        d.clear();
        self.scratch = d;
    }

    /// Completes thread `t`'s next micro-op at once (for exploring every interleaving of
    /// micro-ops across threads). Returns false if it had none.
    pub fn complete_next(&mut self, t: u32) -> bool {
        match self.seq[t as usize].uops.pop_front() {
            Some(u) => {
                self.sync_queued(t);
                self.complete(t, u);
                true
            }
            None => false,
        }
    }

    /// Hashes the architectural state: every register, queue, sequencer and memory word, but not
    /// the event counters, so equal states hash equal.
    pub fn hash_state<H: std::hash::Hasher>(&self, h: &mut H) {
        use std::hash::Hash;
        self.threads.hash(h);
        self.stacks.hash(h);
        self.rb.hash(h);
        self.seq.hash(h);
        self.sh_data.hash(h);
        self.global.hash(h);
    }

    /// Accepts a command from a ready thread: updates registers and loads the sequencer (plan,
    /// then commit). Returns the popped entry for a pop.
    pub fn accept(&mut self, t: u32, cmd: Cmd) -> Result<Option<Entry>, StackError> {
        let mut d = std::mem::take(&mut self.scratch);
        d.clear();
        self.plan(&[(t, cmd)], &mut d);
        let r = d.answer(t);
        self.commit(&d);
        d.clear();
        self.scratch = d;
        r
    }

    /// Functional level: accept the command and complete its whole program at once.
    pub fn apply(&mut self, t: u32, cmd: Cmd) -> Result<Option<Entry>, StackError> {
        let r = self.accept(t, cmd)?;
        while let Some(u) = self.seq[t as usize].uops.pop_front() {
            self.complete(t, u);
        }
        self.sync_queued(t);
        Ok(r)
    }

    /// The SH request that reads entry `entry` of stack `s`: the words (and so the banks) the
    /// design addresses for it.
    pub fn sh_read_request(&self, s: u32, entry: u32) -> ShReq {
        self.sh_request(s, s, entry, false)
    }

    fn sh_request(&self, t: u32, stack: u32, entry: u32, write: bool) -> ShReq {
        let wpe = self.cfg.entry_bytes / self.cfg.bank_bytes;
        let first = (stack * self.cfg.sh_entries + entry) * wpe;
        let mut words = [0; MAX_WORDS];
        for (i, w) in words.iter_mut().take(wpe as usize).enumerate() {
            *w = first + i as u32;
        }
        ShReq { thread: t, write, words, len: wpe as u8 }
    }

    /// Thread `t`'s sequencer this cycle: it may have completed its micro-op in flight
    /// (`inflight`, `latch` after the completion), then issues its next one if none is in flight.
    fn issue(&self, t: u32, mut inflight: Option<Uop>, mut latch: Option<Entry>, d: &mut StackStep) {
        let head = if inflight.is_none() { self.seq[t as usize].uops.front().copied() } else { None };
        if let Some(u) = head {
            let mut take = |src: Src| match src {
                Src::Value(v) => v,
                Src::Latch => latch.take().unwrap_or(POISON),
            };
            match u {
                Uop::ShLoad { stack, entry } => {
                    d.sh_req.push(self.sh_request(t, stack, entry, false));
                    inflight = Some(u);
                }
                Uop::ShStore { stack, entry, src } => {
                    // Capture the latch now: the store carries its data to the bank.
                    let v = take(src);
                    d.sh_req.push(self.sh_request(t, stack, entry, true));
                    inflight = Some(Uop::ShStore { stack, entry, src: Src::Value(v) });
                }
                Uop::GlobalLoad { slot } => {
                    d.g_req.push(GReq { thread: t, write: false, addr: self.spill_addr(t, slot) });
                    inflight = Some(u);
                }
                Uop::GlobalStore { slot, src } if self.acked_stores => {
                    // Capture the latch now (the store carries its data); the data lands, and
                    // the sequencer moves on, when the acknowledgement comes back.
                    let v = take(src);
                    d.g_req.push(GReq { thread: t, write: true, addr: self.spill_addr(t, slot) });
                    inflight = Some(Uop::GlobalStore { slot, src: Src::Value(v) });
                }
                Uop::GlobalStore { slot, .. } => {
                    d.g_req.push(GReq { thread: t, write: true, addr: self.spill_addr(t, slot) });
                    self.complete_into(t, u, &mut latch, d);
                }
                Uop::RbBottom | Uop::Release { .. } => self.complete_into(t, u, &mut latch, d),
            }
        }
        d.writes.push(Write::Seq { thread: t, issued: head.is_some(), inflight, latch });
    }

    /// One clock cycle at the cycle level, combinational: completions (`done`, `deq`) land
    /// in their sequencers, every sequencer with nothing in flight issues its next micro-op, and
    /// each command is planned (in order: a plan sees the stack registers earlier ones changed).
    /// `d` receives the outputs and the register writes; nothing in `self` changes.
    pub fn eval(&self, i: &StackIn, d: &mut StackStep) {
        d.clear();
        for &t in i.done.iter().chain(i.deq.iter()) {
            let (inflight, latch) = match d.completed.iter().find(|c| c.0 == t) {
                Some(c) => (c.1, c.2),
                None => (self.seq[t as usize].inflight, self.seq[t as usize].latch),
            };
            let (mut inflight, mut latch) = (inflight, latch);
            if let Some(u) = inflight.take() {
                self.complete_into(t, u, &mut latch, d);
            }
            match d.completed.iter_mut().find(|c| c.0 == t) {
                Some(c) => (c.1, c.2) = (inflight, latch),
                None => d.completed.push((t, inflight, latch)),
            }
        }
        for word in 0..self.queued.len() {
            let mut bits = self.queued[word];
            while bits != 0 {
                let t = word as u32 * 64 + bits.trailing_zeros();
                bits &= bits - 1;
                let (inflight, latch) = match d.completed.iter().position(|c| c.0 == t) {
                    Some(k) => {
                        let c = d.completed.swap_remove(k);
                        (c.1, c.2)
                    }
                    // Still waiting for its completion: nothing changes.
                    None if self.seq[t as usize].inflight.is_some() => continue,
                    None => (None, self.seq[t as usize].latch),
                };
                self.issue(t, inflight, latch, d);
            }
        }
        // Completions of threads with nothing queued.
        for k in 0..d.completed.len() {
            let (thread, inflight, latch) = d.completed[k];
            d.writes.push(Write::Seq { thread, issued: false, inflight, latch });
        }
        self.plan(i.cmds, d);
    }

    /// Plans `cmds` in order into `d`: a plan sees the stack registers earlier ones changed.
    fn plan(&self, cmds: &[(u32, Cmd)], d: &mut StackStep) {
        for (k, &(t, cmd)) in cmds.iter().enumerate() {
            if cmd == Cmd::None {
                continue;
            }
            // A thread's command port takes one command per cycle (the callers send at most one).
            debug_assert!(
                !cmds[..k].iter().any(|c| c.0 == t && c.1 != Cmd::None),
                "two commands of thread {t}"
            );
            let r = if !self.ready(t) {
                // From an idle sequencer only.
                Err(StackError::Busy { thread: t })
            } else if self.threads[t as usize].done {
                Err(StackError::AfterFinish { thread: t })
            } else {
                Planner::run(self, d, t, cmd)
            };
            match r {
                Ok(Some(v)) => d.pops.push((t, v)),
                Ok(None) => {}
                Err(e) => d.errors.push(e),
            }
        }
    }

    /// The clock edge: applies the writes [`StackManager::eval`] decided, in order.
    pub fn commit(&mut self, d: &StackStep) {
        for &(s, r) in &d.stacks {
            self.stacks[s as usize] = r;
        }
        for &w in &d.writes {
            match w {
                Write::Thread(t, r) => self.threads[t as usize] = r,
                Write::RbPushBack(t, v) => self.rb[t as usize].push_back(v),
                Write::RbPopBack(t) => {
                    self.rb[t as usize].pop_back();
                }
                Write::RbPopFront(t) => {
                    self.rb[t as usize].pop_front();
                }
                Write::RbPushFront(t, v) => self.rb[t as usize].push_front(v),
                Write::Sh(i, v) => self.sh_data[i] = v,
                Write::Global { thread, slot, value } => {
                    let g = &mut self.global[thread as usize];
                    if g.len() <= slot as usize {
                        g.resize(slot as usize + 1, POISON);
                    }
                    g[slot as usize] = value;
                }
                Write::Seq { thread, issued, inflight, latch } => {
                    let q = &mut self.seq[thread as usize];
                    if issued {
                        q.uops.pop_front();
                    }
                    (q.inflight, q.latch) = (inflight, latch);
                    self.sync_queued(thread);
                }
                Write::Emit(t, u) => {
                    self.seq[t as usize].uops.push_back(u);
                    self.sync_queued(t);
                }
            }
        }
        self.stats.add(&d.stats);
    }

    /// Threads with work in flight or queued.
    pub fn busy_threads(&self) -> usize {
        self.busy.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Sets a mutant (test builds).
    #[cfg(feature = "mutants")]
    pub fn with_mutant(mut self, m: Option<Mutant>) -> Self {
        self.mutant = m;
        self
    }

    /// Brings thread `t`'s bits of `queued` and `busy` in line with its sequencer (after any
    /// change to it).
    fn sync_queued(&mut self, t: u32) {
        let (word, bit) = ((t / 64) as usize, 1u64 << (t % 64));
        let q = &self.seq[t as usize];
        let (queued, busy) = (!q.uops.is_empty(), !q.uops.is_empty() || q.inflight.is_some());
        self.queued[word] = self.queued[word] & !bit | if queued { bit } else { 0 };
        self.busy[word] = self.busy[word] & !bit | if busy { bit } else { 0 };
    }
}

/// Plans one command of one thread (SPEC sections 3 and 5): reads the manager's registers as the
/// cycle has left them so far, and writes only to the cycle's [`StackStep`]: its stack-register
/// changes stay in `plan_stacks` until the plan succeeds, so a refused command changes nothing.
struct Planner<'a> {
    m: &'a StackManager,
    d: &'a mut StackStep,
    t: u32,
    th: ThreadRegs,
    /// Where this plan's writes start in `d.writes` (dropped on refusal).
    first_write: usize,
    stats: StackStats,
}

impl<'a> Planner<'a> {
    fn run(m: &'a StackManager, d: &'a mut StackStep, t: u32, cmd: Cmd) -> Result<Option<Entry>, StackError> {
        d.plan_stacks.clear();
        let first_write = d.writes.len();
        let mut p = Planner { m, d, t, th: m.threads[t as usize], first_write, stats: StackStats::default() };
        let r = match cmd {
            Cmd::None => Ok(None),
            Cmd::Push(v) => {
                p.stats.pushes += 1;
                p.push(v).map(|_| None)
            }
            Cmd::Pop => p.pop().map(Some),
            Cmd::Finish => p.finish().map(|_| None),
        };
        let r = r.and_then(|v| p.check_widths().map(|_| v));
        match r {
            Ok(_) => {
                let Planner { d, th, stats, .. } = p;
                d.writes.push(Write::Thread(t, th));
                for k in 0..d.plan_stacks.len() {
                    let (s, regs) = d.plan_stacks[k];
                    d.set_stack(s, regs);
                }
                d.stats.add(&stats);
            }
            Err(_) => {
                // A refused push still counts as a push (the counters count commands seen).
                p.d.writes.truncate(p.first_write);
                p.d.stats.pushes += p.stats.pushes;
            }
        }
        r
    }

    fn cfg(&self) -> &Config {
        &self.m.cfg
    }

    /// The registers this plan fills must hold their values: the RB count (unbounded for
    /// RB_FULL in the model, [`crate::config::RB_FULL_COUNT_BITS`] wide) and the sequencer step
    /// (the program's length).
    fn check_widths(&self) -> Result<(), StackError> {
        let w = &self.m.w;
        let t = self.t;
        let (mut rb, mut steps) = (self.rb_len() as u64, 0u64);
        for x in &self.d.writes[self.first_write..] {
            match x {
                Write::RbPushBack(..) => rb += 1,
                Write::RbPopBack(_) | Write::RbPopFront(_) => rb -= 1,
                Write::Emit(..) => steps += 1,
                _ => {}
            }
        }
        if rb >= 1 << w.rb_count {
            return Err(StackError::Overflow { thread: t, field: "rb_count", value: rb, bits: w.rb_count });
        }
        if steps >= 1 << w.seq_step {
            return Err(StackError::Overflow {
                thread: t,
                field: "seq_step",
                value: steps,
                bits: w.seq_step,
            });
        }
        Ok(())
    }

    fn mutant(&self, tag: Mutant) -> bool {
        self.m.mutant(tag)
    }

    fn get(&self, s: u32) -> StackRegs {
        match self.d.plan_stacks.iter().find(|x| x.0 == s) {
            Some(x) => x.1,
            None => self.d.stack_now(&self.m.stacks, s),
        }
    }

    fn set(&mut self, s: u32, r: StackRegs) {
        match self.d.plan_stacks.iter_mut().find(|x| x.0 == s) {
            Some(x) => x.1 = r,
            None => self.d.plan_stacks.push((s, r)),
        }
    }

    fn emit(&mut self, u: Uop) {
        self.d.writes.push(Write::Emit(self.t, u));
    }

    fn rb_len(&self) -> usize {
        self.m.rb[self.t as usize].len()
    }

    // ---- circular queue pointer logic -------------------------------------------------------

    fn inc(&self, i: u32) -> u32 {
        let m = self.cfg().sh_entries;
        if self.mutant(Mutant::QueueWrapOffByOne) && i + 1 >= m {
            return 1 % m;
        }
        // i < m: a compare, not a division.
        if i + 1 < m {
            i + 1
        } else {
            (i + 1) % m
        }
    }

    fn dec(&self, i: u32) -> u32 {
        let m = self.cfg().sh_entries;
        if (1..=m).contains(&i) {
            i - 1
        } else {
            (i + m - 1) % m
        }
    }

    fn full(&self, s: u32) -> bool {
        self.get(s).count(self.cfg().sh_entries) == self.cfg().sh_entries
    }

    fn push_top(&mut self, s: u32) -> u32 {
        let r = self.get(s);
        let top = if r.empty { r.top } else { self.inc(r.top) };
        self.set(s, StackRegs { top, empty: false, ..r });
        top
    }

    fn pop_top(&mut self, s: u32) -> u32 {
        let r = self.get(s);
        if r.top == r.bottom {
            self.set(s, StackRegs { empty: true, ..r });
        } else {
            self.set(s, StackRegs { top: self.dec(r.top), ..r });
        }
        r.top
    }

    fn push_bottom(&mut self, s: u32) -> u32 {
        let r = self.get(s);
        let bottom = if r.empty { r.bottom } else { self.dec(r.bottom) };
        self.set(s, StackRegs { bottom, empty: false, ..r });
        bottom
    }

    fn pop_bottom(&mut self, s: u32) -> u32 {
        let r = self.get(s);
        let next = self.inc(r.bottom);
        if r.top == r.bottom {
            self.set(s, StackRegs { empty: true, ..r });
        } else {
            self.set(s, StackRegs { bottom: next, ..r });
        }
        r.bottom
    }

    // ---- chains (reallocation) ----------------------------------------------------------------

    fn warp_base(&self, s: u32) -> u32 {
        s - warp_lane(s, self.cfg().warp_size).1
    }

    fn members(&self, t: u32) -> Chain {
        Chain::of(t, self.cfg().warp_size, |s| self.get(s).next_tid)
    }

    fn by_priority(&self, c: &Chain, highest: bool) -> u32 {
        let key = |s: &u32| self.get(*s).priority;
        if highest {
            c.iter().max_by_key(key).unwrap_or(c.ids[0])
        } else {
            c.iter().min_by_key(key).unwrap_or(c.ids[0])
        }
    }

    /// Moves stack `s` to rank `to` in its chain, shifting the ranks between.
    fn move_to_rank(&mut self, c: &Chain, s: u32, to: u32) {
        let from = self.get(s).priority;
        for m in c.iter().filter(|&m| m != s) {
            let mut r = self.get(m);
            if from < to && r.priority > from && r.priority <= to {
                r.priority -= 1;
            } else if to < from && r.priority >= to && r.priority < from {
                r.priority += 1;
            } else {
                continue;
            }
            self.set(m, r);
        }
        let r = self.get(s);
        self.set(s, StackRegs { priority: to, ..r });
    }

    fn reset_flush(&mut self, s: u32) {
        if !self.mutant(Mutant::FlushKeepsCount) {
            let r = self.get(s);
            self.set(s, StackRegs { flush: 0, ..r });
        }
    }

    fn first_idle(&self, t: u32) -> Option<u32> {
        let base = self.warp_base(t);
        let active_unchained = |s: u32| {
            let r = self.get(s);
            s != t && r.empty && r.next_tid == s - base && !self.m.threads[s as usize].done
        };
        (base..base + self.cfg().warp_size)
            .find(|&s| self.get(s).idle || (self.mutant(Mutant::LendActiveStack) && active_unchained(s)))
    }

    fn borrow(&mut self, t: u32, s: u32, rank: u32) {
        let base = self.warp_base(t);
        let lane = s - base;
        let anchor = self.get(t);
        let b = self.m.skew_base(lane);
        self.set(
            s,
            StackRegs {
                top: b,
                bottom: b,
                empty: true,
                idle: false,
                next_tid: anchor.next_tid,
                priority: rank,
                flush: 0,
            },
        );
        self.set(t, StackRegs { next_tid: lane, ..anchor });
        self.stats.borrows += 1;
    }

    fn unlink(&mut self, t: u32, s: u32) {
        let base = self.warp_base(t);
        let c = self.members(t);
        let pred = if self.mutant(Mutant::ReleaseAssumesAdjacent) {
            t
        } else {
            c.iter().find(|&p| base + self.get(p).next_tid == s).unwrap_or(t)
        };
        let next = self.get(s).next_tid;
        let r = self.get(pred);
        self.set(pred, StackRegs { next_tid: next, ..r });
        let r = self.get(s);
        let priority = if self.mutant(Mutant::PriorityKeptOnRelease) { r.priority } else { 0 };
        self.set(s, StackRegs { next_tid: s - base, priority, ..r });
        self.reset_flush(s);
    }

    // ---- the plan: registers now, micro-ops for the sequencer ----------------------------------

    fn claim_spill_slots(&mut self, n: u32) -> Result<u32, StackError> {
        let limit = (1u32 << self.cfg().spill_ptr_bits.min(31)) - 1;
        if self.th.spill_ptr.saturating_add(n) > limit {
            return Err(StackError::SpillRegionFull { thread: self.t, entries: limit });
        }
        let slot = self.th.spill_ptr;
        self.th.spill_ptr += n;
        self.th.overflow = true;
        Ok(slot)
    }

    /// Spills `v` (the oldest RB entry) out of the full RB.
    fn spill(&mut self, v: Entry) -> Result<(), StackError> {
        let t = self.t;
        if self.cfg().sh_entries == 0 {
            let slot = self.claim_spill_slots(1)?;
            self.emit(Uop::GlobalStore { slot, src: Src::Value(v) });
            self.stats.rb_to_global += 1;
            return Ok(());
        }
        let chain = self.members(t);
        let top = self.by_priority(&chain, true);
        if !self.full(top) {
            self.spill_into(top, v);
            return Ok(());
        }
        if let Some(ra) = self.cfg().realloc {
            let len = chain.len as u32;
            if let Some(e) = chain.iter().find(|&s| self.get(s).empty) {
                self.move_to_rank(&chain, e, len - 1);
                self.spill_into(e, v);
                return Ok(());
            }
            if len <= ra.borrow_limit {
                if let Some(s) = self.first_idle(t) {
                    self.borrow(t, s, len);
                    self.spill_into(s, v);
                    return Ok(());
                }
            }
            let oldest = self.by_priority(&chain, false);
            if len > 1 || self.get(oldest).flush < ra.flush_limit {
                self.flush(oldest, ra.flush_limit)?;
                self.move_to_rank(&chain, oldest, len - 1);
                self.spill_into(oldest, v);
                return Ok(());
            }
        }
        // SPEC 3, push case 3: SH load (Bottom) → global store → SH store (Top + 1).
        let slot = self.claim_spill_slots(1)?;
        let b = self.pop_bottom(top);
        self.emit(Uop::ShLoad { stack: top, entry: b });
        self.emit(Uop::GlobalStore { slot, src: Src::Latch });
        self.stats.sh_to_global += 1;
        self.spill_into(top, v);
        Ok(())
    }

    fn spill_into(&mut self, s: u32, v: Entry) {
        let e = self.push_top(s);
        if !self.mutant(Mutant::SpillDropsEntry) {
            self.emit(Uop::ShStore { stack: s, entry: e, src: Src::Value(v) });
        }
        self.stats.rb_to_sh += 1;
    }

    /// Writes the whole of stack `s` to global memory, oldest entry first (lowest address).
    fn flush(&mut self, s: u32, limit: u32) -> Result<(), StackError> {
        let m = self.cfg().sh_entries;
        let n = self.get(s).count(m);
        let first = self.claim_spill_slots(n)?;
        for i in 0..n {
            let e = self.pop_bottom(s);
            self.emit(Uop::ShLoad { stack: s, entry: e });
            self.emit(Uop::GlobalStore { slot: first + i, src: Src::Latch });
        }
        self.stats.sh_to_global += n as u64;
        self.stats.flushes += 1;
        let mut r = self.get(s);
        if r.flush >= limit {
            self.stats.flushes_saturated += 1;
        } else {
            r.flush += 1;
            self.set(s, r);
        }
        Ok(())
    }

    fn push(&mut self, v: Entry) -> Result<(), StackError> {
        let t = self.t;
        let full = self.cfg().rb.capacity().is_some_and(|n| self.rb_len() as u32 >= n);
        if full {
            let oldest = self.m.rb[t as usize].front().copied().unwrap_or(POISON);
            self.d.writes.push(Write::RbPopFront(t));
            self.spill(oldest)?;
        }
        self.d.writes.push(Write::RbPushBack(t, v));
        Ok(())
    }

    fn pop(&mut self) -> Result<Entry, StackError> {
        let t = self.t;
        let Some(&v) = self.m.rb[t as usize].back() else {
            return Err(StackError::PopEmpty { thread: t });
        };
        self.d.writes.push(Write::RbPopBack(t));
        self.stats.pops += 1;
        if self.cfg().sh_entries == 0 {
            if self.th.overflow {
                let slot = self.release_spill_slot();
                self.emit(Uop::GlobalLoad { slot });
                self.emit(Uop::RbBottom);
                self.stats.global_to_rb += 1;
            }
            return Ok(v);
        }
        let chain = self.members(t);
        let top = self.by_priority(&chain, true);
        if !self.get(top).empty {
            let e =
                if self.mutant(Mutant::ReloadWrongEntry) { self.pop_bottom(top) } else { self.pop_top(top) };
            self.emit(Uop::ShLoad { stack: top, entry: e });
            self.emit(Uop::RbBottom);
            self.stats.sh_to_rb += 1;
            let drained = self.get(top).empty
                || (self.mutant(Mutant::EarlyRelease)
                    && top != t
                    && self.get(top).count(self.cfg().sh_entries) == 1);
            if drained {
                self.reset_flush(top);
                if chain.len > 1 {
                    if top != t {
                        self.unlink(t, top);
                        if self.mutant(Mutant::EagerRelease) {
                            let r = self.get(top);
                            self.set(top, StackRegs { idle: true, ..r });
                        } else {
                            self.emit(Uop::Release { stack: top });
                        }
                        self.stats.releases += 1;
                    } else {
                        self.move_to_rank(&chain, t, 0);
                        self.stats.demotions += 1;
                    }
                }
            }
        }
        if self.th.overflow && !self.mutant(Mutant::MissingGlobalReload) {
            let chain = self.members(t);
            let oldest = self.by_priority(&chain, self.mutant(Mutant::ReloadIntoTop));
            if !self.full(oldest) {
                let slot = self.release_spill_slot();
                let e = self.push_bottom(oldest);
                self.emit(Uop::GlobalLoad { slot });
                self.emit(Uop::ShStore { stack: oldest, entry: e, src: Src::Latch });
                self.stats.global_to_sh += 1;
            }
        }
        Ok(v)
    }

    fn release_spill_slot(&mut self) -> u32 {
        let skip_clear = self.mutant(Mutant::SkipOverflowClear);
        let early = u32::from(self.mutant(Mutant::OverflowClearedEarly));
        let th = &mut self.th;
        th.spill_ptr = th.spill_ptr.wrapping_sub(1);
        if th.spill_ptr <= early && !skip_clear {
            th.overflow = false;
        }
        th.spill_ptr
    }

    fn finish(&mut self) -> Result<(), StackError> {
        let t = self.t;
        if self.rb_len() != 0 {
            return Err(StackError::FinishNonEmpty { thread: t });
        }
        self.th.done = true;
        if self.cfg().realloc.is_some() {
            let r = self.get(t);
            self.set(t, StackRegs { idle: true, ..r });
        }
        Ok(())
    }
}

/// The registers alone (no command this cycle).
impl Probe for StackManager {
    fn probe<S: Sink>(&self, s: &mut S) {
        self.probe_cycle(&[], &[], s);
    }
}

impl StackManager {
    /// The registers, and the cycle's commands `cmds` (the input) with the pops that answered
    /// them (`pops`, from [`StackStep::pops`]).
    pub fn probe_cycle<S: Sink>(&self, cmds: &[(u32, Cmd)], pops: &[(u32, Entry)], s: &mut S) {
        if !s.enabled() {
            return;
        }
        let w = &self.w;
        for wp in 0..self.cfg.warps {
            s.push_scope(&format!("warp[{wp}]"));
            for t in self.warp_threads(wp) {
                let lane = t % self.cfg.warp_size;
                s.push_scope(&format!("thread[{lane}]"));
                let cmd = cmds.iter().find(|c| c.0 == t).map_or(Cmd::None, |c| c.1);
                let data = match cmd {
                    Cmd::Push(v) => v,
                    Cmd::Pop => pops.iter().find(|p| p.0 == t).map_or(0, |p| p.1),
                    Cmd::None | Cmd::Finish => 0,
                };
                s.signal("cmd_valid", 1, u64::from(cmd != Cmd::None));
                s.signal_kind("cmd_kind", 2, cmd.code(), Cmd::KIND);
                s.signal_kind("cmd_data", w.entry, data, Kind::Data);
                s.signal_kind("uop", Uop::CODE_BITS, Uop::code(self.seq[t as usize].inflight), Uop::KIND);
                let th = &self.threads[t as usize];
                let st = &self.stacks[t as usize];
                s.signal("rb_count", w.rb_count, self.rb[t as usize].len() as u64);
                s.signal_kind(
                    "rb_top",
                    w.entry,
                    self.rb[t as usize].back().copied().unwrap_or(0),
                    Kind::Data,
                );
                if w.top > 0 {
                    s.signal("top", w.top, st.top as u64);
                    s.signal("bottom", w.bottom, st.bottom as u64);
                }
                if w.sh_empty > 0 {
                    s.signal("sh_empty", w.sh_empty, u64::from(st.empty));
                }
                s.signal("overflow", w.overflow, u64::from(th.overflow));
                if self.cfg.realloc.is_some() {
                    s.signal("idle", w.idle, u64::from(st.idle));
                    s.signal("next_tid", w.next_tid, st.next_tid as u64);
                    s.signal("priority", w.priority, st.priority as u64);
                    s.signal("flush", w.flush, st.flush as u64);
                }
                s.signal("spill_ptr", w.spill_ptr, th.spill_ptr as u64);
                s.signal("done", 1, u64::from(th.done));
                s.signal("busy", 1, u64::from(!self.ready(t)));
                s.pop_scope();
            }
            s.pop_scope();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RB_FULL has no hardware bound; its count register is [`crate::config::RB_FULL_COUNT_BITS`]
    /// wide, and a push past what it holds is refused, not silently counted in a wider integer.
    #[test]
    fn a_value_that_does_not_fit_its_register_is_an_error() {
        let mut m = StackManager::new("RB_FULL".parse().unwrap(), 0).unwrap();
        let bits = m.widths().rb_count;
        for v in 0..(1u64 << bits) - 1 {
            m.apply(0, Cmd::Push(v)).unwrap();
        }
        let value = 1 << bits;
        assert_eq!(
            m.apply(0, Cmd::Push(7)),
            Err(StackError::Overflow { thread: 0, field: "rb_count", value, bits })
        );
        assert_eq!(m.rb(0).len() as u64, value - 1, "the refused push changed nothing");
        assert_eq!(m.apply(0, Cmd::Pop), Ok(Some(value - 2)));
    }
}
