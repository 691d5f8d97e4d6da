//! The stack manager's whole cycle, written once over [`Logic`]: the micro-op completions that
//! arrive, every sequencer's issue, every command's plan, how their register writes merge, and
//! the clock edge that applies them. The simulator runs it on integers
//! ([`crate::logic::Int`], through [`super::StackManager`]'s eval and commit); `sms prove` runs it
//! on symbolic terms over a symbolic warp and compares the next state with the specification's.
//!
//! One cycle, in dataflow order:
//!
//! 1. **Completions** (`done`: the bank arbiter's registered completions, `deq`: the response
//!    FIFO's): each named thread's micro-op in flight lands. A load fills the thread's data
//!    latch; a store writes its word; a release turns its stack Idle in the cycle's view of the
//!    stack registers, so the same cycle's plans see it.
//! 2. **Issue**: every thread with micro-ops queued and none in flight (after step 1) issues its
//!    head. SH operations and acknowledged global stores go out as requests and stay in flight;
//!    a posted global store, an RB-bottom fill and a release complete at issue. A store captures
//!    its data (an immediate or the latch) when it issues.
//! 3. **Plans**: the commands, in order. A thread's command is refused if its sequencer was busy
//!    as the cycle began (`ready` is a register). A plan reads the stack registers as steps 1–2
//!    and the earlier plans leave them; a refused plan writes nothing.
//!
//! **Merge**: the stack registers the cycle changes are one list (`stacks`), each stack once,
//! holding its value after the last change; every other write is a journal entry applied in
//! order at the edge ([`apply`]). A later write to a stack replaces an earlier one of the same
//! cycle because the later one was computed from it.
//!
//! The control shape (which threads complete, which micro-op kinds are queued or in flight,
//! which commands arrive) is concrete in both instances; addresses, register values and data
//! are the instance's words, bits and entries.

use super::policy::{Plan, RbOp, Regfile, Regs, Steps, Thread, UopL};
use super::regs::{CmdOf, SrcOf, StackError, StackRegsOf, StackStats, ThreadRegsOf, UopOf, POISON};
use crate::config::{Config, Widths};
use crate::logic::Logic;

/// A register or memory write the cycle decided, applied in order at the clock edge, or a
/// command the cycle took.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum WriteOf<W, B, V> {
    /// A thread's command as it came in: the edge writes nothing for it (its plan's writes
    /// follow); kept so that the probe shows the cycle's commands.
    Cmd(u32, CmdOf<V>),
    Thread(u32, ThreadRegsOf<W, B>),
    /// A plan's change to its thread's RB.
    Rb(u32, RbOp<V>),
    /// An entry back under the RB (the RB-bottom micro-op).
    RbPushFront(u32, V),
    Sh {
        stack: W,
        entry: W,
        value: V,
    },
    Global {
        thread: u32,
        slot: W,
        value: V,
    },
    /// A sequencer's next state; `issued`: its queue's head left.
    Seq {
        thread: u32,
        issued: bool,
        inflight: Option<UopOf<W, V>>,
        latch: Option<V>,
    },
    /// A micro-op appended to the thread's program when the bit is set.
    Emit(u32, B, UopOf<W, V>),
}

/// An SH request: the words are the stack's entry `entry` (the address map is the caller's).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShReqOf<W> {
    pub thread: u32,
    pub stack: W,
    pub entry: W,
    pub write: bool,
}

/// A global request to spill slot `slot` of the thread's region.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GReqOf<W> {
    pub thread: u32,
    pub write: bool,
    pub slot: W,
}

/// One cycle's decisions: the outputs and the writes the edge applies. A reusable buffer.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct JournalOf<W, B, V> {
    pub writes: Vec<WriteOf<W, B, V>>,
    /// Stack registers the cycle changed, as it leaves them (one entry per stack).
    pub stacks: Vec<(W, StackRegsOf<W, B>)>,
    /// Scratch of one plan: the stack registers it changed.
    pub plan_stacks: Vec<(W, StackRegsOf<W, B>)>,
    /// Sequencers the cycle's completions changed: (thread, in flight, latch).
    pub completed: Vec<(u32, Option<UopOf<W, V>>, Option<V>)>,
    /// What the cycle's plans counted (meaningful in simulation only).
    pub stats: StackStats,
    pub sh_req: Vec<ShReqOf<W>>,
    pub g_req: Vec<GReqOf<W>>,
    /// Pops answered: (thread, entry).
    pub pops: Vec<(u32, V)>,
    /// Pops answered Restart (a restart design's stack, empty after drops): the threads.
    pub restarts: Vec<u32>,
    /// Commands refused.
    pub errors: Vec<StackError>,
    /// The cycle's completions and its number, as they came in (for a scoreboard).
    pub done: Vec<u32>,
    pub deq: Option<u32>,
    pub now: u64,
}

impl<W, B, V> Default for JournalOf<W, B, V> {
    fn default() -> Self {
        JournalOf {
            writes: Vec::new(),
            stacks: Vec::new(),
            plan_stacks: Vec::new(),
            completed: Vec::new(),
            stats: StackStats::default(),
            sh_req: Vec::new(),
            g_req: Vec::new(),
            pops: Vec::new(),
            restarts: Vec::new(),
            errors: Vec::new(),
            done: Vec::new(),
            deq: None,
            now: 0,
        }
    }
}

impl<W, B, V: Copy> JournalOf<W, B, V> {
    /// What the cycle answered to thread `t`'s command: the popped entry, nothing (for a pop:
    /// Restart), or the refusal.
    pub fn answer(&self, t: u32) -> Result<Option<V>, StackError> {
        if let Some(e) = self.errors.iter().find(|e| e.thread() == t) {
            return Err(*e);
        }
        Ok(self.pops.iter().find(|p| p.0 == t).map(|p| p.1))
    }
}

impl<W, B, V> JournalOf<W, B, V> {
    pub fn clear(&mut self) {
        self.writes.clear();
        self.stacks.clear();
        self.plan_stacks.clear();
        self.completed.clear();
        self.stats = StackStats::default();
        self.sh_req.clear();
        self.g_req.clear();
        self.pops.clear();
        self.restarts.clear();
        self.errors.clear();
        self.done.clear();
        self.deq = None;
        self.now = 0;
    }
}

/// The journal under logic `L`.
pub type Journal<L> = JournalOf<<L as Logic>::Word, <L as Logic>::Bit, <L as Logic>::Val>;
/// A write under logic `L`.
pub type Write<L> = WriteOf<<L as Logic>::Word, <L as Logic>::Bit, <L as Logic>::Val>;

/// This cycle's inputs: the commands (at most one per thread) and the completions.
#[derive(Clone, Copy, Debug, Default)]
pub struct CycleIn<'a, V> {
    pub cmds: &'a [(u32, CmdOf<V>)],
    /// Threads whose SH request the bank arbiter completed.
    pub done: &'a [u32],
    /// Thread whose global response the response FIFO delivered.
    pub deq: Option<u32>,
    /// The cycle's number (reports only).
    pub now: u64,
}

/// The registers and memories as the cycle began (what the flip-flops and arrays hold).
pub trait Registers<L: Logic> {
    fn stack_q(&self, l: &mut L, s: L::Word) -> Regs<L>;
    fn thread_q(&self, l: &mut L, t: u32) -> Thread<L>;
    /// Thread (stack) `s` has finished.
    fn done_q(&self, l: &mut L, s: L::Word) -> L::Bit;
    /// Thread `t`'s sequencer is not idle (micro-ops queued or one in flight).
    fn busy_q(&self, l: &mut L, t: u32) -> L::Bit;
    fn inflight_q(&self, t: u32) -> Option<UopL<L>>;
    /// The head of thread `t`'s micro-op queue.
    fn head_q(&self, t: u32) -> Option<UopL<L>>;
    fn latch_q(&self, t: u32) -> Option<L::Val>;
    fn rb_len_q(&self, l: &mut L, t: u32) -> L::Word;
    fn rb_front_q(&self, l: &mut L, t: u32) -> L::Val;
    fn rb_back_q(&self, l: &mut L, t: u32) -> L::Val;
    fn sh_q(&self, l: &mut L, stack: L::Word, entry: L::Word) -> L::Val;
    fn global_q(&self, l: &mut L, t: u32, slot: L::Word) -> L::Val;
    /// The first thread at or after `from` with micro-ops queued.
    fn next_queued(&self, from: u32) -> Option<u32>;
    /// Global stores stay in flight until acknowledged (else they are posted).
    fn acked_stores(&self) -> bool;
}

/// The registers and memories as the edge writes them ([`apply`]).
pub trait Store<L: Logic> {
    fn set_stack(&mut self, l: &mut L, s: L::Word, r: Regs<L>);
    fn set_thread(&mut self, t: u32, r: Thread<L>);
    fn rb(&mut self, l: &mut L, t: u32, op: RbOp<L::Val>);
    fn rb_push_front(&mut self, l: &mut L, t: u32, v: L::Val);
    fn sh(&mut self, l: &mut L, stack: L::Word, entry: L::Word, v: L::Val);
    fn global(&mut self, l: &mut L, t: u32, slot: L::Word, v: L::Val);
    fn seq(&mut self, t: u32, issued: bool, inflight: Option<UopL<L>>, latch: Option<L::Val>);
    fn emit(&mut self, l: &mut L, t: u32, valid: L::Bit, u: UopL<L>);
}

/// The pieces of the cycle a planted bug replaces; every method has the design's behaviour by
/// default. The policy's [`Steps`] is the other half of the seam.
pub trait CycleSteps: Steps {
    /// A release lands: stack `s` turns Idle in the cycle's view of the stack registers.
    fn land_release<L: Logic>(&self, l: &mut L, q: &impl Registers<L>, d: &mut Journal<L>, s: L::Word) {
        let r = stack_now(l, q, d, s);
        let idle = l.bit(true);
        merge_stack(l, &mut d.stacks, s, StackRegsOf { idle, ..r });
    }
    /// Whether a thread's command finds its sequencer busy (its register as the cycle began).
    fn busy_for_command<L: Logic>(
        &self,
        l: &mut L,
        q: &impl Registers<L>,
        _d: &Journal<L>,
        t: u32,
    ) -> L::Bit {
        q.busy_q(l, t)
    }
    /// A thread whose micro-op completed this cycle issues its next one in the same cycle.
    fn issue_after_completion(&self) -> bool {
        true
    }
    /// The latch an issuing micro-op reads: as this cycle's completion leaves it.
    fn latch_at_issue<L: Logic>(
        &self,
        _q: &impl Registers<L>,
        _t: u32,
        after: Option<L::Val>,
    ) -> Option<L::Val> {
        after
    }
    /// The entry a completing SH store writes.
    fn stored_entry<L: Logic>(&self, _l: &mut L, _cfg: &Config, entry: L::Word) -> L::Word {
        entry
    }
    /// Merges a plan's change of stack `s` into the cycle's list: the later value wins.
    fn merge_plan_stack<L: Logic>(
        &self,
        l: &mut L,
        list: &mut Vec<(L::Word, Regs<L>)>,
        s: L::Word,
        r: Regs<L>,
    ) {
        merge_stack(l, list, s, r)
    }
    /// The completions the cycle takes: every SH completion, then the response FIFO's.
    fn completions<'a>(&self, i: &CycleIn<'a, impl Copy>) -> (&'a [u32], Option<u32>) {
        (i.done, i.deq)
    }
}

/// Stack `s`'s registers in `list` over `r` (the last entry naming `s` wins).
pub fn lookup<L: Logic>(l: &mut L, list: &[(L::Word, Regs<L>)], s: L::Word, mut r: Regs<L>) -> Regs<L> {
    for &(i, v) in list {
        let hit = l.eq(i, s);
        if l.maybe(hit) {
            r = StackRegsOf::mux(l, hit, v, r);
        }
    }
    r
}

/// Records stack `s` as `r` in `list`: in place where the index is certainly the same word,
/// else appended (a read takes the last entry that names `s`).
pub fn merge_stack<L: Logic>(l: &mut L, list: &mut Vec<(L::Word, Regs<L>)>, s: L::Word, r: Regs<L>) {
    if let Some(last) = list.iter().rposition(|x| l.same(x.0, s)) {
        // In place only when no later entry could also name `s`.
        if last + 1 == list.len() || l.exact() {
            list[last].1 = r;
            return;
        }
    }
    list.push((s, r));
}

/// Stack `s` as the cycle so far leaves it.
pub fn stack_now<L: Logic>(l: &mut L, q: &impl Registers<L>, d: &Journal<L>, s: L::Word) -> Regs<L> {
    let r = q.stack_q(l, s);
    lookup(l, &d.stacks, s, r)
}

/// The whole cycle's combinational logic: completions, issue, plans (module doc). `d` receives
/// the outputs and the writes; the registers do not change.
pub fn eval<L: Logic, P: CycleSteps>(
    l: &mut L,
    steps: &P,
    cfg: &Config,
    w: &Widths,
    q: &impl Registers<L>,
    i: &CycleIn<'_, L::Val>,
    d: &mut Journal<L>,
) {
    d.clear();
    d.done.extend_from_slice(i.done);
    d.deq = i.deq;
    d.now = i.now;
    let (done, deq) = steps.completions(i);
    for &t in done.iter().chain(deq.iter()) {
        let (inflight, latch) = match d.completed.iter().find(|c| c.0 == t) {
            Some(c) => (c.1, c.2),
            None => (q.inflight_q(t), q.latch_q(t)),
        };
        let (mut inflight, mut latch) = (inflight, latch);
        if let Some(u) = inflight.take() {
            complete(l, steps, cfg, q, t, u, &mut latch, d);
        }
        match d.completed.iter_mut().find(|c| c.0 == t) {
            Some(c) => (c.1, c.2) = (inflight, latch),
            None => d.completed.push((t, inflight, latch)),
        }
    }
    let mut from = 0;
    while let Some(t) = q.next_queued(from) {
        from = t + 1;
        let (inflight, latch) = match d.completed.iter().position(|c| c.0 == t) {
            Some(k) if steps.issue_after_completion() => {
                let c = d.completed.swap_remove(k);
                (c.1, steps.latch_at_issue(q, t, c.2))
            }
            // Completed but waits for the next cycle to issue (a planted bug only).
            Some(_) => continue,
            // Still waiting for its completion: nothing changes.
            None if q.inflight_q(t).is_some() => continue,
            None => (None, q.latch_q(t)),
        };
        issue(l, steps, cfg, q, t, inflight, latch, d);
    }
    // Completions of threads with nothing queued.
    for k in 0..d.completed.len() {
        let (thread, inflight, latch) = d.completed[k];
        d.writes.push(WriteOf::Seq { thread, issued: false, inflight, latch });
    }
    d.writes.extend(i.cmds.iter().filter(|c| !matches!(c.1, CmdOf::None)).map(|&(t, c)| WriteOf::Cmd(t, c)));
    plan(l, steps, cfg, w, q, i.cmds, d);
}

/// The data effect of completing micro-op `u` of thread `t`, whose data latch is `latch`.
#[allow(clippy::too_many_arguments)]
pub fn complete<L: Logic, P: CycleSteps>(
    l: &mut L,
    steps: &P,
    cfg: &Config,
    q: &impl Registers<L>,
    t: u32,
    u: UopL<L>,
    latch: &mut Option<L::Val>,
    d: &mut Journal<L>,
) {
    match u {
        UopOf::ShLoad { stack, entry } => *latch = Some(q.sh_q(l, stack, entry)),
        UopOf::ShStore { stack, entry, src } => {
            let value = take(l, latch, src);
            let entry = steps.stored_entry(l, cfg, entry);
            d.writes.push(WriteOf::Sh { stack, entry, value });
        }
        UopOf::GlobalLoad { slot } => *latch = Some(q.global_q(l, t, slot)),
        UopOf::GlobalStore { slot, src } => {
            let value = take(l, latch, src);
            d.writes.push(WriteOf::Global { thread: t, slot, value });
        }
        UopOf::RbBottom => {
            let v = take(l, latch, SrcOf::Latch);
            d.writes.push(WriteOf::RbPushFront(t, v));
        }
        UopOf::Release { stack } => steps.land_release(l, q, d, stack),
    }
}

/// A store's data: its immediate, or the latch (emptied; POISON if it held nothing).
fn take<L: Logic>(l: &mut L, latch: &mut Option<L::Val>, src: SrcOf<L::Val>) -> L::Val {
    match src {
        SrcOf::Value(v) => v,
        SrcOf::Latch => match latch.take() {
            Some(v) => v,
            None => l.val(POISON),
        },
    }
}

/// Thread `t`'s sequencer this cycle: after any completion (`inflight`, `latch`), it issues its
/// queue's head if nothing is in flight.
#[allow(clippy::too_many_arguments)]
fn issue<L: Logic, P: CycleSteps>(
    l: &mut L,
    steps: &P,
    cfg: &Config,
    q: &impl Registers<L>,
    t: u32,
    mut inflight: Option<UopL<L>>,
    mut latch: Option<L::Val>,
    d: &mut Journal<L>,
) {
    let head = if inflight.is_none() { q.head_q(t) } else { None };
    if let Some(u) = head {
        match u {
            UopOf::ShLoad { stack, entry } => {
                d.sh_req.push(ShReqOf { thread: t, stack, entry, write: false });
                inflight = Some(u);
            }
            UopOf::ShStore { stack, entry, src } => {
                // The store carries its data to the bank.
                let v = take(l, &mut latch, src);
                d.sh_req.push(ShReqOf { thread: t, stack, entry, write: true });
                inflight = Some(UopOf::ShStore { stack, entry, src: SrcOf::Value(v) });
            }
            UopOf::GlobalLoad { slot } => {
                d.g_req.push(GReqOf { thread: t, write: false, slot });
                inflight = Some(u);
            }
            UopOf::GlobalStore { slot, src } if q.acked_stores() => {
                // The data lands, and the sequencer moves on, when the acknowledgement comes.
                let v = take(l, &mut latch, src);
                d.g_req.push(GReqOf { thread: t, write: true, slot });
                inflight = Some(UopOf::GlobalStore { slot, src: SrcOf::Value(v) });
            }
            UopOf::GlobalStore { slot, .. } => {
                d.g_req.push(GReqOf { thread: t, write: true, slot });
                complete(l, steps, cfg, q, t, u, &mut latch, d);
            }
            UopOf::RbBottom | UopOf::Release { .. } => complete(l, steps, cfg, q, t, u, &mut latch, d),
        }
    }
    d.writes.push(WriteOf::Seq { thread: t, issued: head.is_some(), inflight, latch });
}

/// Plans `cmds` in order into `d`: a plan sees the stack registers earlier ones changed.
pub fn plan<L: Logic, P: CycleSteps>(
    l: &mut L,
    steps: &P,
    cfg: &Config,
    w: &Widths,
    q: &impl Registers<L>,
    cmds: &[(u32, CmdOf<L::Val>)],
    d: &mut Journal<L>,
) {
    for &(t, cmd) in cmds {
        if matches!(cmd, CmdOf::None) {
            continue;
        }
        match plan_one(l, steps, cfg, w, q, d, t, cmd) {
            Ok(Some(v)) => d.pops.push((t, v)),
            Ok(None) if matches!(cmd, CmdOf::Pop) => d.restarts.push(t),
            Ok(None) => {}
            Err(e) => d.errors.push(e),
        }
    }
}

/// Plans thread `t`'s command: its stack-register changes stay in `plan_stacks` until the plan
/// succeeds, so a refused command changes nothing.
#[allow(clippy::too_many_arguments)]
fn plan_one<L: Logic, P: CycleSteps>(
    l: &mut L,
    steps: &P,
    cfg: &Config,
    w: &Widths,
    q: &impl Registers<L>,
    d: &mut Journal<L>,
    t: u32,
    cmd: CmdOf<L::Val>,
) -> Result<Option<L::Val>, StackError> {
    d.plan_stacks.clear();
    let first_write = d.writes.len();
    let th = q.thread_q(l, t);
    let base = t - t % cfg.warp_size;
    let busy = steps.busy_for_command(l, q, d, t);
    let mut rf = Overlay { q, d, t };
    let mut p = Plan { l: &mut *l, steps, rf: &mut rf, cfg, t, base, th, stats: StackStats::default() };
    let r = p.run(cmd, busy);
    let (th, stats) = (p.th, p.stats);
    let r = r.and_then(|v| check_widths(l, w, q, d, t, first_write).map(|_| v));
    match r {
        Ok(_) => {
            d.writes.push(WriteOf::Thread(t, th));
            for k in 0..d.plan_stacks.len() {
                let (s, regs) = d.plan_stacks[k];
                steps.merge_plan_stack(l, &mut d.stacks, s, regs);
            }
            d.stats.add(&stats);
        }
        Err(_) => {
            // A refused push still counts as a push (the counters count commands seen).
            d.writes.truncate(first_write);
            d.stats.pushes += stats.pushes;
        }
    }
    r
}

/// The registers a plan fills must hold their values: the RB count and the sequencer step (the
/// program's length).
fn check_widths<L: Logic>(
    l: &mut L,
    w: &Widths,
    q: &impl Registers<L>,
    d: &Journal<L>,
    t: u32,
    first_write: usize,
) -> Result<(), StackError> {
    let mut rb = q.rb_len_q(l, t);
    let mut steps = l.word(0);
    for x in &d.writes[first_write..] {
        match x {
            WriteOf::Rb(_, RbOp::PushBack(_)) => rb = l.add_k(rb, 1),
            WriteOf::Rb(..) => rb = l.sub_k(rb, 1),
            WriteOf::Emit(_, valid, _) => {
                let one = l.count(*valid);
                steps = l.add(steps, one);
            }
            _ => {}
        }
    }
    let limit = |bits: u32| if bits >= 32 { u32::MAX } else { (1u32 << bits) - 1 };
    let over = l.lt_k(rb, limit(w.rb_count).wrapping_add(1));
    let fits = if w.rb_count >= 32 { l.bit(true) } else { over };
    let wide = l.not(fits);
    if l.decide(wide) {
        let value = u64::from(l.concrete(rb));
        return Err(StackError::Overflow { thread: t, field: "rb_count", value, bits: w.rb_count });
    }
    let fits = if w.seq_step >= 32 { l.bit(true) } else { l.lt_k(steps, limit(w.seq_step).wrapping_add(1)) };
    let long = l.not(fits);
    if l.decide(long) {
        let value = u64::from(l.concrete(steps));
        return Err(StackError::Overflow { thread: t, field: "seq_step", value, bits: w.seq_step });
    }
    Ok(())
}

/// The clock edge: the cycle's stack registers, then its writes in order.
pub fn apply<L: Logic>(l: &mut L, d: &Journal<L>, st: &mut impl Store<L>) {
    for &(s, r) in &d.stacks {
        st.set_stack(l, s, r);
    }
    for &x in &d.writes {
        match x {
            WriteOf::Cmd(..) => {}
            WriteOf::Thread(t, r) => st.set_thread(t, r),
            WriteOf::Rb(t, op) => st.rb(l, t, op),
            WriteOf::RbPushFront(t, v) => st.rb_push_front(l, t, v),
            WriteOf::Sh { stack, entry, value } => st.sh(l, stack, entry, value),
            WriteOf::Global { thread, slot, value } => st.global(l, thread, slot, value),
            WriteOf::Seq { thread, issued, inflight, latch } => st.seq(thread, issued, inflight, latch),
            WriteOf::Emit(t, valid, u) => st.emit(l, t, valid, u),
        }
    }
}

/// The register file of one plan: the registers as the cycle began under the cycle's earlier
/// changes (`d.stacks`) and this plan's own (`d.plan_stacks`).
pub struct Overlay<'a, L: Logic, Q: Registers<L>> {
    pub q: &'a Q,
    pub d: &'a mut Journal<L>,
    /// The commanding thread.
    pub t: u32,
}

impl<L: Logic, Q: Registers<L>> Regfile<L> for Overlay<'_, L, Q> {
    #[inline]
    fn stack(&mut self, l: &mut L, s: L::Word) -> Regs<L> {
        let r = stack_now(l, self.q, self.d, s);
        lookup(l, &self.d.plan_stacks, s, r)
    }
    fn stack_q(&mut self, l: &mut L, s: L::Word) -> Regs<L> {
        self.q.stack_q(l, s)
    }
    #[inline]
    fn set_stack(&mut self, l: &mut L, s: L::Word, r: Regs<L>) {
        merge_stack(l, &mut self.d.plan_stacks, s, r)
    }
    fn done(&mut self, l: &mut L, s: L::Word) -> L::Bit {
        self.q.done_q(l, s)
    }
    fn rb_len(&mut self, l: &mut L) -> L::Word {
        self.q.rb_len_q(l, self.t)
    }
    fn rb_front(&mut self, l: &mut L) -> L::Val {
        self.q.rb_front_q(l, self.t)
    }
    fn rb_back(&mut self, l: &mut L) -> L::Val {
        self.q.rb_back_q(l, self.t)
    }
    fn rb(&mut self, _: &mut L, op: RbOp<L::Val>) {
        self.d.writes.push(WriteOf::Rb(self.t, op));
    }
    #[inline]
    fn emit(&mut self, l: &mut L, valid: L::Bit, u: UopL<L>) {
        if l.maybe(valid) {
            self.d.writes.push(WriteOf::Emit(self.t, valid, u));
        }
    }
}
