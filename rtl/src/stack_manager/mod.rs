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
//! Clocking: the manager is a [`Unit`]. Its eval is the cycle's combinational logic: it reads
//! only the registers and this cycle's inputs ([`StackIn`]) and writes a [`StackStep`]: the
//! outputs (SH and global requests, pops, refusals) and the ordered register writes (the next
//! state as a journal, so a cycle copies no register array); its commit applies them at the
//! clock edge.
//! Planning a command ([`policy::Plan`], written once over [`crate::logic::Logic`] so that the
//! same code simulates and is proved) is pure in the same way: it reads the stack registers as
//! the cycle's earlier writes leave them (two threads of a warp may both touch idle stacks in
//! one cycle) and returns its decisions and micro-ops; a refused command changes nothing.
//!
//! Files: `regs.rs` (register and signal types), `policy.rs` (the decision logic and its
//! replaceable [`policy::Steps`]), `group.rs` (reallocation within groups of lanes),
//! `select.rs` (which policy implementation a manager runs), `cycle.rs` (the whole cycle over
//! [`crate::logic::Logic`]), this file (register arrays, sequencers, eval and commit),
//! `regfile.rs` (the arrays as the cycle reads and writes them), `functional.rs` (the functional
//! executor), `backdoor.rs` (state loaded from outside, the state hash), `probe.rs` (waveform
//! signals), `mutants.rs` (planted bugs: their names in every build, the bugs themselves only
//! with the `mutants` feature).
//!
//! The same plan drives two executors: eval/commit (cycle level, through the bank arbiter and
//! memory scheduler) and [`StackManager::apply`] (functional: micro-ops complete at once).
//! Decisions that depend only on a thread's own history are identical in both.
//!
//! Design choices for SPEC section 9 are argued in `docs/stack.md`.

use std::collections::VecDeque;

use crate::bank_arbiter::{ShReq, MAX_WORDS};
use crate::clock::Unit;
use crate::config::{warp_lane, Config, ConfigError, Widths};
use crate::logic::Int;
use crate::mem::addr::{LocalLayout, LocalMap};
use crate::mem_sched::GReq;
use crate::trace::Sink;

mod backdoor;
pub mod cycle;
mod functional;
pub mod group;
pub mod mutants;
pub mod policy;
mod probe;
mod regfile;
pub mod regs;
pub mod select;

use cycle::{CycleIn, CycleSteps, Journal, Overlay, Registers, Store, WriteOf};
pub use mutants::Mutant;
use policy::{Design, Plan, RbOp, Regs, Thread};
pub use regs::*;
pub use select::StackPolicy;

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

/// This cycle's inputs of the stack manager: commands, at most one per thread, each from a
/// thread that is [`StackManager::ready`]; the threads whose SH request the bank arbiter
/// completed (its registered `done`); the thread whose load data (or, with acknowledged stores,
/// store acknowledgement) the response FIFO delivered (its registered `deq`).
pub type StackIn<'a> = CycleIn<'a, Entry>;

/// The stack manager's cycle: its outputs and the writes its registers take at the clock edge
/// ([`Unit::eval`], [`Unit::commit`]): the journal of [`cycle::eval`] and its requests in the
/// address maps of the bank arbiter and the memory scheduler. A reusable buffer: a cycle
/// allocates nothing once it has grown.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct StackStep {
    j: Journal<Int>,
    /// SH requests to the bank arbiter.
    pub sh_req: Vec<ShReq>,
    /// Global requests to the memory scheduler.
    pub g_req: Vec<GReq>,
}

impl StackStep {
    fn clear(&mut self) {
        self.j.clear();
        self.sh_req.clear();
        self.g_req.clear();
    }

    /// Pops answered: (thread, entry).
    pub fn pops(&self) -> &[(u32, Entry)] {
        &self.j.pops
    }

    /// The threads whose pop this cycle answered Restart (restart designs).
    pub fn restarts(&self) -> &[u32] {
        &self.j.restarts
    }

    /// Commands refused (the per-thread error signals).
    pub fn errors(&self) -> &[StackError] {
        &self.j.errors
    }

    /// Sets the cycle number the step carries (a quiet cycle's step reused unchanged).
    pub fn set_now(&mut self, now: u64) {
        self.j.now = now;
    }

    /// The cycle's decisions and writes ([`cycle::eval`]'s journal).
    pub fn journal(&self) -> &Journal<Int> {
        &self.j
    }

    /// What the cycle answered to thread `t`'s command: the popped entry, nothing, or the
    /// refusal.
    pub fn answer(&self, t: u32) -> Result<Option<Entry>, StackError> {
        self.j.answer(t)
    }

    /// Thread `t`'s command this cycle ([`Cmd::None`] if it sent none).
    fn cmd(&self, t: u32) -> Cmd {
        let taken = self.j.writes.iter().find_map(|w| match *w {
            WriteOf::Cmd(u, c) if u == t => Some(c),
            _ => None,
        });
        taken.unwrap_or(Cmd::None)
    }
}

/// A checker of every committed cycle (a scoreboard): it sees the registers as the cycle began
/// and the cycle's decisions ([`Scoreboard::before`]), then the registers after the clock edge
/// ([`Scoreboard::after`]), and names the first disagreement with its own model of the cycle.
pub trait Scoreboard: Send + std::panic::UnwindSafe + std::panic::RefUnwindSafe {
    fn before(&mut self, q: &StackManager, d: &StackStep);
    /// The disagreement, if any: "cycle N, SM s, warp w, lane l: what (design …, expected …)".
    fn after(&mut self, next: &StackManager, d: &StackStep) -> Option<String>;
    fn clone_box(&self) -> Box<dyn Scoreboard>;
}

/// The scoreboard a run attached, and the first disagreement it found. Not architectural state:
/// equality and hashing ignore it.
#[derive(Default)]
struct Board {
    check: Option<Box<dyn Scoreboard>>,
    failed: Option<String>,
}

impl Clone for Board {
    fn clone(&self) -> Self {
        Board { check: self.check.as_ref().map(|c| c.clone_box()), failed: self.failed.clone() }
    }
}
impl PartialEq for Board {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}
impl Eq for Board {}
impl std::hash::Hash for Board {
    fn hash<H: std::hash::Hasher>(&self, _: &mut H) {}
}
impl std::fmt::Debug for Board {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Board {{ attached: {}, failed: {:?} }}", self.check.is_some(), self.failed)
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
    board: Board,
    /// The policy's implementation this manager runs ([`StackPolicy::of`] its configuration's,
    /// unless built with another).
    policy: StackPolicy,
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
            board: self.board.clone(),
            policy: self.policy.clone(),
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
            board,
            policy,
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
        self.board = board.clone();
        if !self.policy.same(policy) {
            self.policy = policy.clone();
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
            board: Board::default(),
            policy: StackPolicy::of(&cfg),
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
    /// Which SM this stack manager belongs to.
    pub fn sm(&self) -> u32 {
        self.sm
    }
    /// Attaches a scoreboard that checks every committed cycle.
    pub fn set_scoreboard(&mut self, b: Box<dyn Scoreboard>) {
        self.board.check = Some(b);
    }
    /// The first disagreement the scoreboard found.
    pub fn scoreboard_failure(&self) -> Option<&str> {
        self.board.failed.as_deref()
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
    /// Thread `t`'s data latch.
    pub fn latch(&self, t: u32) -> Option<Entry> {
        self.seq[t as usize].latch
    }
    /// Thread `t`'s global region as the memory holds it: every slot ever written, including
    /// those past the spill pointer.
    pub fn global_region(&self, t: u32) -> &[Entry] {
        &self.global[t as usize]
    }
    /// The micro-op thread `t` has issued and not yet completed.
    pub fn inflight_uop(&self, t: u32) -> Option<Uop> {
        self.seq[t as usize].inflight
    }
    /// Stacks of thread `t`'s chain, in ring order starting at its dedicated stack.
    pub fn chain(&self, t: u32) -> Vec<u32> {
        let mut d = Journal::<Int>::default();
        let mut rf = Overlay { q: self, d: &mut d, t };
        let th = self.threads[t as usize];
        let base = t - warp_lane(t, self.cfg.warp_size).1;
        let mut p = Plan {
            l: &mut Int,
            steps: &Design,
            rf: &mut rf,
            cfg: &self.cfg,
            t,
            base,
            th,
            stats: StackStats::default(),
        };
        let c = p.members();
        c.ids[..c.len].to_vec()
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
                idle: !on && self.cfg.realloc().is_some(),
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

    /// The base entry of `lane`'s stack (the policy's skew step; [`Config::skew_base`] in the
    /// design).
    fn skew_base(&self, lane: u32) -> u32 {
        self.policy.0.skew_base(self, lane)
    }

    pub(crate) fn base_with<P: CycleSteps>(&self, steps: &P, lane: u32) -> u32 {
        let mut d = Journal::<Int>::default();
        let mut rf = Overlay { q: self, d: &mut d, t: 0 };
        let th = self.threads[0];
        let mut p = Plan {
            l: &mut Int,
            steps,
            rf: &mut rf,
            cfg: &self.cfg,
            t: 0,
            base: 0,
            th,
            stats: StackStats::default(),
        };
        P::skew_base(&mut p, lane)
    }

    // ---- executing micro-ops ---------------------------------------------------------------

    fn sh_index(&self, stack: u32, entry: u32) -> usize {
        (stack * self.cfg.sh_entries + entry) as usize
    }

    /// One cycle of the whole description ([`cycle::eval`]) with the manager's policy, into `d`.
    fn cycle(&self, i: &CycleIn<'_, Entry>, d: &mut StackStep) {
        self.policy.0.eval(&self.cfg, &self.w, self, i, &mut d.j);
        d.sh_req.clear();
        d.g_req.clear();
        if let Err(e) = self.addressed(&d.j) {
            d.j.errors.push(e);
            return;
        }
        for r in &d.j.sh_req {
            d.sh_req.push(self.sh_request(r.thread, r.stack, r.entry, r.write));
        }
        for r in &d.j.g_req {
            d.g_req.push(GReq { thread: r.thread, write: r.write, addr: self.spill_addr(r.thread, r.slot) });
        }
    }

    /// Every stack and SH entry the cycle writes or addresses exists: a design that names one
    /// past the arrays is a refused cycle, never an index out of bounds.
    fn addressed(&self, d: &Journal<Int>) -> Result<(), StackError> {
        let (n, m) = (self.cfg.threads(), self.cfg.sh_entries);
        let stack = |thread: u32, s: u32| match s < n {
            true => Ok(()),
            false => Err(StackError::OutOfRange { thread, what: "stack", value: u64::from(s) }),
        };
        let entry = |thread: u32, e: u32| match e < m {
            true => Ok(()),
            false => Err(StackError::OutOfRange { thread, what: "SH entry", value: u64::from(e) }),
        };
        let uop = |t: u32, u: &Uop| match *u {
            Uop::ShLoad { stack: s, entry: e } | Uop::ShStore { stack: s, entry: e, .. } => {
                stack(t, s).and_then(|_| entry(t, e))
            }
            Uop::Release { stack: s } => stack(t, s),
            _ => Ok(()),
        };
        for &(s, _) in &d.stacks {
            stack(s, s)?;
        }
        for w in &d.writes {
            match w {
                WriteOf::Sh { stack: s, entry: e, .. } => stack(*s, *s).and_then(|_| entry(*s, *e))?,
                WriteOf::Emit(t, _, u) => uop(*t, u)?,
                _ => {}
            }
        }
        for r in &d.sh_req {
            stack(r.thread, r.stack).and_then(|_| entry(r.thread, r.entry))?;
        }
        Ok(())
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

    /// Plans `cmds` in order into `d` ([`cycle::plan`]): a plan sees the stack registers earlier
    /// ones changed.
    fn plan(&self, cmds: &[(u32, Cmd)], d: &mut StackStep) {
        for (k, &(t, cmd)) in cmds.iter().enumerate() {
            // A thread's command port takes one command per cycle (the callers send at most one).
            debug_assert!(
                cmd == Cmd::None || !cmds[..k].iter().any(|c| c.0 == t && c.1 != Cmd::None),
                "two commands of thread {t}"
            );
        }
        self.policy.0.plan(&self.cfg, &self.w, self, cmds, &mut d.j)
    }

    /// Threads with work in flight or queued.
    pub fn busy_threads(&self) -> usize {
        self.busy.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// The manager with policy implementation `policy` in place of its configuration's.
    pub fn with_policy(mut self, policy: StackPolicy) -> Self {
        self.policy = policy;
        self
    }

    /// The policy's implementation this manager runs.
    pub fn policy(&self) -> &StackPolicy {
        &self.policy
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

impl Unit for StackManager {
    type In<'a> = StackIn<'a>;
    type Step = StackStep;

    /// One clock cycle at the cycle level, combinational: completions (`done`, `deq`) land
    /// in their sequencers, every sequencer with nothing in flight issues its next micro-op, and
    /// each command is planned (in order: a plan sees the stack registers earlier ones changed).
    /// `d` receives the outputs and the register writes; nothing in `self` changes.
    fn eval(&self, i: StackIn<'_>, d: &mut StackStep) {
        // `cycle::eval` starts from a cleared journal and the requests are rebuilt from it.
        self.cycle(&i, d);
    }

    /// The clock edge: applies the writes the eval decided ([`cycle::apply`]).
    fn commit(&mut self, d: &StackStep) {
        let mut check = self.board.check.take();
        if let Some(b) = &mut check {
            b.before(self, d);
        }
        cycle::apply(&mut Int, &d.j, self);
        self.stats.add(&d.j.stats);
        if let Some(b) = &mut check {
            if let Some(e) = b.after(self, d) {
                self.board.failed.get_or_insert(e);
            }
        }
        self.board.check = check;
    }

    /// The registers, and the cycle's commands with the pops that answered them, under
    /// `stack_manager`.
    fn probe<S: Sink>(&self, d: &StackStep, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("stack_manager");
        self.probe_signals(|t| d.cmd(t), d.pops(), s);
        s.pop_scope();
    }
}
