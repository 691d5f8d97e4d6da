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
//! A command is accepted only from a thread whose sequencer is idle (`ready`). Accepting it
//! updates the thread's bookkeeping registers at once and loads the sequencer with the exact
//! request sequence of SPEC sections 3 and 5 (e.g. SH load → global store → SH store). The
//! sequencer issues one micro-op at a time, in order; a micro-op that needs an earlier load's data
//! waits for it in the thread's data latch. Data moves when a request completes, so the SH array
//! and the global spill regions hold real values and every pop is checked against a reference.
//!
//! The same plan drives two executors: [`StackManager::step`] (cycle level, through the bank
//! arbiter and memory scheduler) and [`StackManager::apply`] (functional: micro-ops complete at
//! once). Decisions that depend only on a thread's own history are identical in both.
//!
//! Design choices for SPEC section 9 are argued in `rtl/DESIGN.md`.

use std::collections::VecDeque;

use crate::bank_arbiter::{ShReq, MAX_WORDS};
use crate::config::{Config, ConfigError, Widths};
use crate::mem::addr::{LocalLayout, LocalMap};
use crate::mem_sched::GReq;
use crate::trace::{Probe, Sink};

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
            (self.top + m - self.bottom) % m + 1
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

/// Commands the stack manager refuses. Each is a bug in whoever sent the command, or (spill
/// region) a traversal deeper than the configured region.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StackError {
    PopEmpty { thread: u32 },
    FinishNonEmpty { thread: u32 },
    Busy { thread: u32 },
    AfterFinish { thread: u32 },
    SpillRegionFull { thread: u32, entries: u32 },
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
            | StackError::SpillRegionFull { thread, .. } => thread,
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
}

impl Mutant {
    /// Every mutant, in declaration order (the order of [`Self::NAMES`]).
    pub const ALL: [Mutant; 8] = [
        Mutant::QueueWrapOffByOne,
        Mutant::ReloadWrongEntry,
        Mutant::SpillDropsEntry,
        Mutant::MissingGlobalReload,
        Mutant::EarlyRelease,
        Mutant::SkipOverflowClear,
        Mutant::FlushKeepsCount,
        Mutant::EagerRelease,
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
    Mutant::EagerRelease => "eager-release"
);

#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct Sequencer {
    uops: VecDeque<Uop>,
    inflight: Option<Uop>,
    latch: Option<Entry>,
}

/// The members of one thread's chain, in ring order from its dedicated stack.
#[derive(Clone, Copy)]
struct Chain {
    ids: [u32; 32],
    len: usize,
}

impl Chain {
    fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        self.ids[..self.len].iter().copied()
    }
}

/// The stack manager of one RT unit: `warps × warp_size` threads.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
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
    sh_data: Vec<Entry>,
    global: Vec<Vec<Entry>>,
    /// Per-cycle outputs of the last `step`.
    sh_out: Vec<ShReq>,
    g_out: Vec<GReq>,
    pops_out: Vec<(u32, Entry)>,
    errors_out: Vec<StackError>,
    cmds_seen: Vec<(u32, Cmd)>,
    /// A global store stays in flight until its acknowledgement arrives on the global
    /// completion input ([`StackTiming::Blocking`]); otherwise it is posted.
    acked_stores: bool,
    pub stats: StackStats,
    #[cfg(feature = "mutants")]
    pub mutant: Option<Mutant>,
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
            sh_data: vec![0; n * cfg.sh_entries as usize],
            global: vec![Vec::new(); n],
            sh_out: Vec::new(),
            g_out: Vec::new(),
            pops_out: Vec::new(),
            errors_out: Vec::new(),
            cmds_seen: Vec::new(),
            acked_stores: false,
            stats: StackStats::default(),
            #[cfg(feature = "mutants")]
            mutant: None,
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
        self.members(t).iter().collect()
    }
    /// Ready for a command: the thread's sequencer is idle.
    pub fn ready(&self, t: u32) -> bool {
        let q = &self.seq[t as usize];
        q.uops.is_empty() && q.inflight.is_none()
    }
    /// Some thread will issue a micro-op in the next `step` without waiting for a completion
    /// (it has micro-ops queued and none in flight). When false, every busy thread waits on the
    /// bank arbiter or on global memory.
    pub fn can_issue(&self) -> bool {
        self.queued.iter().enumerate().any(|(word, &bits)| {
            (0..64).any(|b| bits & (1 << b) != 0 && self.seq[word * 64 + b].inflight.is_none())
        })
    }
    /// No thread has work in flight.
    pub fn quiescent(&self) -> bool {
        (0..self.cfg.threads()).all(|t| self.ready(t))
    }
    pub fn warp_of(&self, t: u32) -> u32 {
        t / self.cfg.warp_size
    }
    /// Every thread of warp `w` finished and quiet: the warp may leave.
    pub fn warp_done(&self, w: u32) -> bool {
        self.warp_threads(w).all(|t| self.threads[t as usize].done && self.ready(t))
    }
    pub fn warp_threads(&self, w: u32) -> std::ops::Range<u32> {
        w * self.cfg.warp_size..(w + 1) * self.cfg.warp_size
    }

    /// SH requests issued in the last `step`.
    pub fn sh_requests(&self) -> &[ShReq] {
        &self.sh_out
    }
    /// Global requests issued in the last `step`.
    pub fn global_requests(&self) -> &[GReq] {
        &self.g_out
    }
    /// Pops answered in the last `step`: (thread, entry).
    pub fn pops(&self) -> &[(u32, Entry)] {
        &self.pops_out
    }

    /// Commands refused in the last `step` (the per-thread error signals).
    pub fn errors(&self) -> &[StackError] {
        &self.errors_out
    }

    /// What the last `step` answered to thread `t`'s command: the popped entry, nothing, or the
    /// refusal.
    pub fn answer(&self, t: u32) -> Result<Option<Entry>, StackError> {
        if let Some(e) = self.errors_out.iter().find(|e| e.thread() == t) {
            return Err(*e);
        }
        Ok(self.pops_out.iter().find(|p| p.0 == t).map(|p| p.1))
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
            let base = self.cfg.skew_base(lane);
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

    // ---- circular queue pointer logic -------------------------------------------------------

    fn inc(&self, i: u32) -> u32 {
        let m = self.cfg.sh_entries;
        if self.mutant(Mutant::QueueWrapOffByOne) && i + 1 >= m {
            return 1 % m;
        }
        (i + 1) % m
    }

    fn dec(&self, i: u32) -> u32 {
        let m = self.cfg.sh_entries;
        (i + m - 1) % m
    }

    fn full(&self, s: u32) -> bool {
        self.stacks[s as usize].count(self.cfg.sh_entries) == self.cfg.sh_entries
    }

    fn push_top(&mut self, s: u32) -> u32 {
        let r = self.stacks[s as usize];
        let top = if r.empty { r.top } else { self.inc(r.top) };
        let st = &mut self.stacks[s as usize];
        st.top = top;
        st.empty = false;
        top
    }

    fn pop_top(&mut self, s: u32) -> u32 {
        let r = self.stacks[s as usize];
        let st = &mut self.stacks[s as usize];
        if r.top == r.bottom {
            st.empty = true;
        } else {
            st.top = (r.top + self.cfg.sh_entries - 1) % self.cfg.sh_entries;
        }
        r.top
    }

    fn push_bottom(&mut self, s: u32) -> u32 {
        let r = self.stacks[s as usize];
        let bottom = if r.empty { r.bottom } else { self.dec(r.bottom) };
        let st = &mut self.stacks[s as usize];
        st.bottom = bottom;
        st.empty = false;
        bottom
    }

    fn pop_bottom(&mut self, s: u32) -> u32 {
        let r = self.stacks[s as usize];
        let next = self.inc(r.bottom);
        let st = &mut self.stacks[s as usize];
        if r.top == r.bottom {
            st.empty = true;
        } else {
            st.bottom = next;
        }
        r.bottom
    }

    // ---- chains (reallocation) ----------------------------------------------------------------

    fn warp_base(&self, s: u32) -> u32 {
        s - s % self.cfg.warp_size
    }

    fn members(&self, t: u32) -> Chain {
        let mut c = Chain { ids: [0; 32], len: 0 };
        let base = self.warp_base(t);
        let mut s = t;
        loop {
            c.ids[c.len] = s;
            c.len += 1;
            s = base + self.stacks[s as usize].next_tid;
            if s == t || c.len == c.ids.len() {
                return c;
            }
        }
    }

    fn by_priority(&self, c: &Chain, highest: bool) -> u32 {
        let key = |s: &u32| self.stacks[*s as usize].priority;
        if highest {
            c.iter().max_by_key(key).unwrap_or(c.ids[0])
        } else {
            c.iter().min_by_key(key).unwrap_or(c.ids[0])
        }
    }

    /// Moves stack `s` to rank `to` in its chain, shifting the ranks between.
    fn move_to_rank(&mut self, c: &Chain, s: u32, to: u32) {
        let from = self.stacks[s as usize].priority;
        for m in c.iter().filter(|&m| m != s) {
            let p = &mut self.stacks[m as usize].priority;
            if from < to && *p > from && *p <= to {
                *p -= 1;
            } else if to < from && *p >= to && *p < from {
                *p += 1;
            }
        }
        self.stacks[s as usize].priority = to;
    }

    fn reset_flush(&mut self, s: u32) {
        if !self.mutant(Mutant::FlushKeepsCount) {
            self.stacks[s as usize].flush = 0;
        }
    }

    fn first_idle(&self, t: u32) -> Option<u32> {
        let base = self.warp_base(t);
        (base..base + self.cfg.warp_size).find(|&s| self.stacks[s as usize].idle)
    }

    fn borrow(&mut self, t: u32, s: u32, rank: u32) {
        let base = self.warp_base(t);
        let lane = s - base;
        let anchor_next = self.stacks[t as usize].next_tid;
        let b = self.cfg.skew_base(lane);
        let st = &mut self.stacks[s as usize];
        *st = StackRegs {
            top: b,
            bottom: b,
            empty: true,
            idle: false,
            next_tid: anchor_next,
            priority: rank,
            flush: 0,
        };
        self.stacks[t as usize].next_tid = lane;
        self.stats.borrows += 1;
    }

    fn unlink(&mut self, t: u32, s: u32) {
        let base = self.warp_base(t);
        let c = self.members(t);
        let pred = c.iter().find(|&p| base + self.stacks[p as usize].next_tid == s).unwrap_or(t);
        self.stacks[pred as usize].next_tid = self.stacks[s as usize].next_tid;
        let st = &mut self.stacks[s as usize];
        st.next_tid = s - base;
        st.priority = 0;
        self.reset_flush(s);
    }

    // ---- the plan: registers now, micro-ops for the sequencer ----------------------------------

    fn emit(&mut self, t: u32, u: Uop) {
        self.seq[t as usize].uops.push_back(u);
        self.sync_queued(t);
    }

    fn sync_queued(&mut self, t: u32) {
        let (word, bit) = ((t / 64) as usize, 1u64 << (t % 64));
        if self.seq[t as usize].uops.is_empty() {
            self.queued[word] &= !bit;
        } else {
            self.queued[word] |= bit;
        }
    }

    fn claim_spill_slots(&mut self, t: u32, n: u32) -> Result<u32, StackError> {
        let limit = (1u32 << self.cfg.spill_ptr_bits.min(31)) - 1;
        let th = &mut self.threads[t as usize];
        if th.spill_ptr.saturating_add(n) > limit {
            return Err(StackError::SpillRegionFull { thread: t, entries: limit });
        }
        let slot = th.spill_ptr;
        th.spill_ptr += n;
        th.overflow = true;
        Ok(slot)
    }

    /// Spills `v` (the oldest RB entry) out of the full RB.
    fn spill(&mut self, t: u32, v: Entry) -> Result<(), StackError> {
        if self.cfg.sh_entries == 0 {
            let slot = self.claim_spill_slots(t, 1)?;
            self.emit(t, Uop::GlobalStore { slot, src: Src::Value(v) });
            self.stats.rb_to_global += 1;
            return Ok(());
        }
        let chain = self.members(t);
        let top = self.by_priority(&chain, true);
        if !self.full(top) {
            self.spill_into(t, top, v);
            return Ok(());
        }
        if let Some(ra) = self.cfg.realloc {
            let len = chain.len as u32;
            if let Some(e) = chain.iter().find(|&s| self.stacks[s as usize].empty) {
                self.move_to_rank(&chain, e, len - 1);
                self.spill_into(t, e, v);
                return Ok(());
            }
            if len <= ra.borrow_limit {
                if let Some(s) = self.first_idle(t) {
                    self.borrow(t, s, len);
                    self.spill_into(t, s, v);
                    return Ok(());
                }
            }
            let oldest = self.by_priority(&chain, false);
            if len > 1 || self.stacks[oldest as usize].flush < ra.flush_limit {
                self.flush(t, oldest, ra.flush_limit)?;
                self.move_to_rank(&chain, oldest, len - 1);
                self.spill_into(t, oldest, v);
                return Ok(());
            }
        }
        // SPEC 3, push case 3: SH load (Bottom) → global store → SH store (Top + 1).
        let slot = self.claim_spill_slots(t, 1)?;
        let b = self.pop_bottom(top);
        self.emit(t, Uop::ShLoad { stack: top, entry: b });
        self.emit(t, Uop::GlobalStore { slot, src: Src::Latch });
        self.stats.sh_to_global += 1;
        self.spill_into(t, top, v);
        Ok(())
    }

    fn spill_into(&mut self, t: u32, s: u32, v: Entry) {
        let e = self.push_top(s);
        if !self.mutant(Mutant::SpillDropsEntry) {
            self.emit(t, Uop::ShStore { stack: s, entry: e, src: Src::Value(v) });
        }
        self.stats.rb_to_sh += 1;
    }

    /// Writes the whole of stack `s` to global memory, oldest entry first (lowest address).
    fn flush(&mut self, t: u32, s: u32, limit: u32) -> Result<(), StackError> {
        let m = self.cfg.sh_entries;
        let n = self.stacks[s as usize].count(m);
        let first = self.claim_spill_slots(t, n)?;
        for i in 0..n {
            let e = self.pop_bottom(s);
            self.emit(t, Uop::ShLoad { stack: s, entry: e });
            self.emit(t, Uop::GlobalStore { slot: first + i, src: Src::Latch });
        }
        self.stats.sh_to_global += n as u64;
        self.stats.flushes += 1;
        let st = &mut self.stacks[s as usize];
        if st.flush >= limit {
            self.stats.flushes_saturated += 1;
        } else {
            st.flush += 1;
        }
        Ok(())
    }

    fn plan_push(&mut self, t: u32, v: Entry) -> Result<(), StackError> {
        self.stats.pushes += 1;
        let full = self.cfg.rb.capacity().is_some_and(|n| self.rb[t as usize].len() as u32 >= n);
        if full {
            let oldest = self.rb[t as usize].pop_front().unwrap_or(POISON);
            if let Err(e) = self.spill(t, oldest) {
                self.rb[t as usize].push_front(oldest);
                return Err(e);
            }
        }
        self.rb[t as usize].push_back(v);
        Ok(())
    }

    fn plan_pop(&mut self, t: u32) -> Result<Entry, StackError> {
        let Some(v) = self.rb[t as usize].pop_back() else {
            return Err(StackError::PopEmpty { thread: t });
        };
        self.stats.pops += 1;
        if self.cfg.sh_entries == 0 {
            if self.threads[t as usize].overflow {
                let slot = self.release_spill_slot(t);
                self.emit(t, Uop::GlobalLoad { slot });
                self.emit(t, Uop::RbBottom);
                self.stats.global_to_rb += 1;
            }
            return Ok(v);
        }
        let chain = self.members(t);
        let top = self.by_priority(&chain, true);
        if !self.stacks[top as usize].empty {
            let e =
                if self.mutant(Mutant::ReloadWrongEntry) { self.pop_bottom(top) } else { self.pop_top(top) };
            self.emit(t, Uop::ShLoad { stack: top, entry: e });
            self.emit(t, Uop::RbBottom);
            self.stats.sh_to_rb += 1;
            let drained = self.stacks[top as usize].empty
                || (self.mutant(Mutant::EarlyRelease)
                    && top != t
                    && self.stacks[top as usize].count(self.cfg.sh_entries) == 1);
            if drained {
                self.reset_flush(top);
                if chain.len > 1 {
                    if top != t {
                        self.unlink(t, top);
                        if self.mutant(Mutant::EagerRelease) {
                            self.stacks[top as usize].idle = true;
                        } else {
                            self.emit(t, Uop::Release { stack: top });
                        }
                        self.stats.releases += 1;
                    } else {
                        self.move_to_rank(&chain, t, 0);
                        self.stats.demotions += 1;
                    }
                }
            }
        }
        if self.threads[t as usize].overflow && !self.mutant(Mutant::MissingGlobalReload) {
            let chain = self.members(t);
            let oldest = self.by_priority(&chain, false);
            if !self.full(oldest) {
                let slot = self.release_spill_slot(t);
                let e = self.push_bottom(oldest);
                self.emit(t, Uop::GlobalLoad { slot });
                self.emit(t, Uop::ShStore { stack: oldest, entry: e, src: Src::Latch });
                self.stats.global_to_sh += 1;
            }
        }
        Ok(v)
    }

    fn release_spill_slot(&mut self, t: u32) -> u32 {
        let skip_clear = self.mutant(Mutant::SkipOverflowClear);
        let th = &mut self.threads[t as usize];
        th.spill_ptr = th.spill_ptr.wrapping_sub(1);
        if th.spill_ptr == 0 && !skip_clear {
            th.overflow = false;
        }
        th.spill_ptr
    }

    fn plan_finish(&mut self, t: u32) -> Result<(), StackError> {
        if !self.rb[t as usize].is_empty() {
            return Err(StackError::FinishNonEmpty { thread: t });
        }
        self.threads[t as usize].done = true;
        if self.cfg.realloc.is_some() {
            self.stacks[t as usize].idle = true;
        }
        Ok(())
    }

    /// Accepts a command from a ready thread: updates registers and loads the sequencer.
    /// Returns the popped entry for a pop.
    pub fn accept(&mut self, t: u32, cmd: Cmd) -> Result<Option<Entry>, StackError> {
        if cmd == Cmd::None {
            return Ok(None);
        }
        if !self.ready(t) {
            return Err(StackError::Busy { thread: t });
        }
        if self.threads[t as usize].done {
            return Err(StackError::AfterFinish { thread: t });
        }
        match cmd {
            Cmd::None => Ok(None),
            Cmd::Push(v) => self.plan_push(t, v).map(|_| None),
            Cmd::Pop => self.plan_pop(t).map(Some),
            Cmd::Finish => self.plan_finish(t).map(|_| None),
        }
    }

    // ---- executing micro-ops ---------------------------------------------------------------

    fn sh_index(&self, stack: u32, entry: u32) -> usize {
        (stack * self.cfg.sh_entries + entry) as usize
    }

    fn take_src(&mut self, t: u32, src: Src) -> Entry {
        match src {
            Src::Value(v) => v,
            Src::Latch => self.seq[t as usize].latch.take().unwrap_or(POISON),
        }
    }

    fn global_write(&mut self, t: u32, slot: u32, v: Entry) {
        let g = &mut self.global[t as usize];
        if g.len() <= slot as usize {
            g.resize(slot as usize + 1, POISON);
        }
        g[slot as usize] = v;
    }

    /// The data effect of a completed micro-op.
    fn complete(&mut self, t: u32, u: Uop) {
        match u {
            Uop::ShLoad { stack, entry } => {
                self.seq[t as usize].latch = Some(self.sh_data[self.sh_index(stack, entry)]);
            }
            Uop::ShStore { stack, entry, src } => {
                let v = self.take_src(t, src);
                let i = self.sh_index(stack, entry);
                self.sh_data[i] = v;
            }
            Uop::GlobalLoad { slot } => {
                let v = self.global[t as usize].get(slot as usize).copied().unwrap_or(POISON);
                self.seq[t as usize].latch = Some(v);
            }
            Uop::GlobalStore { slot, src } => {
                let v = self.take_src(t, src);
                self.global_write(t, slot, v);
            }
            Uop::RbBottom => {
                let v = self.take_src(t, Src::Latch);
                self.rb[t as usize].push_front(v);
            }
            Uop::Release { stack } => self.stacks[stack as usize].idle = true,
        }
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
    /// the event counters or last cycle's outputs, so equal states hash equal.
    pub fn hash_state<H: std::hash::Hasher>(&self, h: &mut H) {
        use std::hash::Hash;
        self.threads.hash(h);
        self.stacks.hash(h);
        self.rb.hash(h);
        self.seq.hash(h);
        self.sh_data.hash(h);
        self.global.hash(h);
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

    fn sh_request(&self, t: u32, stack: u32, entry: u32, write: bool) -> ShReq {
        let wpe = self.cfg.entry_bytes / self.cfg.bank_bytes;
        let first = (stack * self.cfg.sh_entries + entry) * wpe;
        let mut words = [0; MAX_WORDS];
        for (i, w) in words.iter_mut().take(wpe as usize).enumerate() {
            *w = first + i as u32;
        }
        ShReq { thread: t, write, words, len: wpe as u8 }
    }

    /// Issues thread `t`'s next micro-op, if it has one and nothing is in flight.
    fn issue(&mut self, t: u32) {
        if self.seq[t as usize].inflight.is_some() {
            return;
        }
        let Some(u) = self.seq[t as usize].uops.pop_front() else {
            return;
        };
        self.sync_queued(t);
        match u {
            Uop::ShLoad { stack, entry } => {
                let r = self.sh_request(t, stack, entry, false);
                self.sh_out.push(r);
                self.seq[t as usize].inflight = Some(u);
            }
            Uop::ShStore { stack, entry, src } => {
                // Capture the latch now: the store carries its data to the bank.
                let v = self.take_src(t, src);
                let r = self.sh_request(t, stack, entry, true);
                self.sh_out.push(r);
                self.seq[t as usize].inflight = Some(Uop::ShStore { stack, entry, src: Src::Value(v) });
            }
            Uop::GlobalLoad { slot } => {
                self.g_out.push(GReq { thread: t, write: false, addr: self.spill_addr(t, slot) });
                self.seq[t as usize].inflight = Some(u);
            }
            Uop::GlobalStore { slot, src } if self.acked_stores => {
                // Capture the latch now (the store carries its data); the data lands, and the
                // sequencer moves on, when the acknowledgement comes back.
                let v = self.take_src(t, src);
                self.g_out.push(GReq { thread: t, write: true, addr: self.spill_addr(t, slot) });
                self.seq[t as usize].inflight = Some(Uop::GlobalStore { slot, src: Src::Value(v) });
            }
            Uop::GlobalStore { slot, .. } => {
                self.g_out.push(GReq { thread: t, write: true, addr: self.spill_addr(t, slot) });
                self.complete(t, u);
            }
            Uop::RbBottom | Uop::Release { .. } => self.complete(t, u),
        }
    }

    /// One clock cycle at the cycle level.
    ///
    /// `sh_done` are the threads whose SH request the arbiter completed last cycle, `g_done` the
    /// thread whose load data (or, with acknowledged stores, store acknowledgement) the response
    /// FIFO delivered last cycle; `cmds` go to ready threads.
    /// Afterwards `sh_requests`, `global_requests`, `pops` and `errors` hold this cycle's outputs.
    pub fn step(&mut self, cmds: &[(u32, Cmd)], sh_done: &[u32], g_done: Option<u32>) {
        self.sh_out.clear();
        self.g_out.clear();
        self.pops_out.clear();
        self.errors_out.clear();
        self.cmds_seen.clear();
        for &t in sh_done.iter().chain(g_done.iter()) {
            if let Some(u) = self.seq[t as usize].inflight.take() {
                self.complete(t, u);
            }
        }
        for word in 0..self.queued.len() {
            let mut bits = self.queued[word];
            while bits != 0 {
                let t = word as u32 * 64 + bits.trailing_zeros();
                bits &= bits - 1;
                self.issue(t);
            }
        }
        for &(t, cmd) in cmds {
            self.cmds_seen.push((t, cmd));
            match self.accept(t, cmd) {
                Ok(Some(v)) => self.pops_out.push((t, v)),
                Ok(None) => {}
                Err(e) => self.errors_out.push(e),
            }
        }
    }

    /// Threads with work in flight or queued.
    pub fn busy_threads(&self) -> usize {
        (0..self.cfg.threads()).filter(|&t| !self.ready(t)).count()
    }

    /// Sets a mutant (test builds).
    #[cfg(feature = "mutants")]
    pub fn with_mutant(mut self, m: Option<Mutant>) -> Self {
        self.mutant = m;
        self
    }
}

impl Probe for StackManager {
    fn probe<S: Sink>(&self, s: &mut S) {
        if !s.enabled() {
            return;
        }
        let w = &self.w;
        for wp in 0..self.cfg.warps {
            s.push_scope(&format!("warp[{wp}]"));
            for t in self.warp_threads(wp) {
                let lane = t % self.cfg.warp_size;
                s.push_scope(&format!("thread[{lane}]"));
                let cmd = self.cmds_seen.iter().find(|c| c.0 == t).map_or(Cmd::None, |c| c.1);
                let (kind, data) = match cmd {
                    Cmd::None => (0, 0),
                    Cmd::Push(v) => (1, v),
                    Cmd::Pop => (2, self.pops_out.iter().find(|p| p.0 == t).map_or(0, |p| p.1)),
                    Cmd::Finish => (3, 0),
                };
                s.signal("cmd_valid", 1, u64::from(kind != 0));
                s.signal("cmd_kind", 2, kind);
                s.signal("cmd_data", w.entry, data);
                let th = &self.threads[t as usize];
                let st = &self.stacks[t as usize];
                s.signal("rb_count", w.rb_count, self.rb[t as usize].len() as u64);
                s.signal("rb_top", w.entry, self.rb[t as usize].back().copied().unwrap_or(0));
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
