//! The stack manager's decision logic: what one command of one thread does to the stack
//! registers, and which micro-op program (SPEC sections 3 and 5) it loads into the sequencer.
//!
//! Written once over the [`Logic`] abstraction: the simulator runs it on integers
//! ([`crate::logic::Int`]); `sms prove` runs it on symbolic bit-vectors and hands the result to
//! SMT solvers. Nothing here knows which.
//!
//! - A [`Plan`] reads and writes the registers through a [`Regfile`]: the simulator's sees the
//!   cycle's earlier plans over the committed registers; a proof's is an array of symbolic lanes.
//! - [`Steps`] names the pieces of the policy a different design (or a planted bug) replaces:
//!   pointer arithmetic, the idle search, borrowing, releasing, the global reload. [`Design`] is
//!   the design itself: every step as this file writes it.
//!
//! Branches on register values are [`Logic::decide`]; loops over a chain run to the warp size
//! and stop early only where [`Logic::maybe`] allows, so every instance computes one function.

use super::regs::{CmdOf, SrcOf, StackError, StackRegsOf, StackStats, ThreadRegsOf, UopOf};
use crate::config::{Config, Overflow};
use crate::logic::Logic;

/// An SH stack's registers under logic `L`.
pub type Regs<L> = StackRegsOf<<L as Logic>::Word, <L as Logic>::Bit>;
/// A thread's registers under logic `L`.
pub type Thread<L> = ThreadRegsOf<<L as Logic>::Word, <L as Logic>::Bit>;
/// A micro-op under logic `L`.
pub type UopL<L> = UopOf<<L as Logic>::Word, <L as Logic>::Val>;

/// A change to the commanding thread's RB.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RbOp<V> {
    /// The oldest entry leaves (it is being spilled).
    PopFront,
    PushBack(V),
    /// The top entry leaves (a pop).
    PopBack,
}

/// What a plan reads and writes besides the commanding thread's own registers.
pub trait Regfile<L: Logic> {
    /// Stack `s`'s registers as the cycle's plans so far leave them.
    fn stack(&mut self, l: &mut L, s: L::Word) -> Regs<L>;
    /// Stack `s`'s registers as the cycle began.
    fn stack_q(&mut self, l: &mut L, s: L::Word) -> Regs<L>;
    fn set_stack(&mut self, l: &mut L, s: L::Word, r: Regs<L>);
    /// Thread `s` has finished (as the cycle began).
    fn done(&mut self, l: &mut L, s: L::Word) -> L::Bit;
    /// Entries in the commanding thread's RB.
    fn rb_len(&mut self, l: &mut L) -> L::Word;
    /// Its oldest RB entry (read only when the RB holds one).
    fn rb_front(&mut self, l: &mut L) -> L::Val;
    /// Its newest RB entry (read only when the RB holds one).
    fn rb_back(&mut self, l: &mut L) -> L::Val;
    fn rb(&mut self, l: &mut L, op: RbOp<L::Val>);
    /// Appends `u` to the thread's micro-op program when `valid`.
    fn emit(&mut self, l: &mut L, valid: L::Bit, u: UopL<L>);
}

/// The members of one thread's chain in ring order from its dedicated stack: position `k` holds
/// stack `ids[k]` when `on[k]` (positions past the ring's end are off).
pub struct Chain<L: Logic> {
    pub ids: [L::Word; 32],
    pub on: [L::Bit; 32],
    /// Positions walked (the ring's length in simulation; the warp size in a proof).
    pub len: usize,
}

/// The policy, as the pieces a design (or a planted bug) replaces. Every method has the paper's
/// behaviour by default (the [`Plan`] method of the same name); an implementation overrides the
/// pieces it changes.
///
/// The first group are the decisions where designs differ: what a push does when the chain's
/// top stack is full, which idle stack it borrows, what the last level does when no stack takes
/// the entry, what a pop does when it drains the top stack, what a finish leaves behind. The
/// rest are the datapath's pieces (pointer arithmetic, comparators, register writes), the
/// places a slip in the hardware would sit.
pub trait Steps: Sized {
    /// The design's name in reports and errors.
    fn name(&self) -> &'static str {
        "paper"
    }

    // ---- decisions ----------------------------------------------------------------------------

    /// A push found the chain's top stack full: place `v` in another SH stack (`true`), or leave
    /// it to [`Steps::on_full_chain`] (`false`).
    fn on_full_top<L: Logic, R: Regfile<L>>(
        p: &mut Plan<L, Self, R>,
        chain: &Chain<L>,
        v: L::Val,
    ) -> Result<bool, StackError> {
        p.on_full_top(chain, v)
    }
    /// A push found the RB full and there is no SH level: the oldest RB entry `v` leaves it.
    fn on_full_rb<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, v: L::Val) -> Result<(), StackError> {
        p.on_full_rb(v)
    }
    /// No stack of the chain takes `v`: the last level's spill from the top stack `top`.
    fn on_full_chain<L: Logic, R: Regfile<L>>(
        p: &mut Plan<L, Self, R>,
        top: L::Word,
        v: L::Val,
    ) -> Result<(), StackError> {
        p.on_full_chain(top, v)
    }
    /// The idle stack a full chain borrows: (found, stack).
    fn first_idle<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>) -> (L::Bit, L::Word) {
        p.first_idle()
    }
    /// A pop drained the chain's top stack `top`.
    fn on_drained<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, chain: &Chain<L>, top: L::Word) {
        p.on_drained(chain, top)
    }
    /// A pop found the RB, and so the whole stack, empty: `Ok` answers Restart, `Err` refuses.
    fn on_empty_pop<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>) -> Result<(), StackError> {
        p.on_empty_pop()
    }
    /// An accepted Finish (the thread is done).
    fn on_finish<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>) {
        p.on_finish()
    }

    // ---- datapath pieces ----------------------------------------------------------------------

    /// Refuses a command the thread may not take now: busy sequencer, or after its finish.
    fn refuse<L: Logic, R: Regfile<L>>(
        p: &mut Plan<L, Self, R>,
        cmd: &CmdOf<L::Val>,
        busy: L::Bit,
    ) -> Option<StackError> {
        p.refuse(cmd, busy)
    }
    /// The entry after `i` in a circular queue.
    fn inc<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, i: L::Word) -> L::Word {
        p.inc(i)
    }
    /// Entries an SH stack holds.
    fn entries<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, r: &Regs<L>) -> L::Word {
        p.entries(r)
    }
    /// The entry at which `lane`'s SH queue starts.
    fn skew_base<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, lane: L::Word) -> L::Word {
        p.skew_base(lane)
    }
    /// The chain's top stack (highest Priority).
    fn top_of<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, c: &Chain<L>) -> L::Word {
        p.by_priority(c, true)
    }
    /// The stack a pop's global reload fills: the chain's oldest.
    fn reload_target<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, c: &Chain<L>) -> L::Word {
        p.by_priority(c, false)
    }
    /// A full chain of `len` stacks may borrow another (the borrow limit counts borrowed
    /// stacks, so a chain holds at most 1 + limit).
    fn may_borrow<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, len: L::Word, limit: L::Word) -> L::Bit {
        p.l.le(len, limit)
    }
    /// Links idle stack `s` into the thread's chain at rank `rank`.
    fn borrow<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, s: L::Word, rank: L::Word) {
        p.borrow(s, rank)
    }
    /// The member whose Next TID points at `s`.
    fn pred_of<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, c: &Chain<L>, s: L::Word) -> L::Word {
        p.pred_of(c, s)
    }
    /// Stack `s`'s registers once unlinked from its chain (`lane`: its own lane).
    fn unlinked<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, r: Regs<L>, lane: L::Word) -> Regs<L> {
        p.unlinked(r, lane)
    }
    fn reset_flush<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, s: L::Word) {
        p.reset_flush(s)
    }
    /// Stores spilled entry `v` on top of stack `s`.
    fn spill_into<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, s: L::Word, v: L::Val) {
        p.spill_into(s, v)
    }
    /// Takes the newest entry of stack `s` off the queue; returns its index.
    fn take_newest<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, s: L::Word) -> L::Word {
        p.pop_top(s)
    }
    /// Stack `s` is drained after a pop took its entry.
    fn drained<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, s: L::Word) -> L::Bit {
        p.stack(s).empty
    }
    /// Gives drained borrowed stack `s` back.
    fn release<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>, s: L::Word) {
        p.release(s)
    }
    /// A pop's reload of the newest global entry into the chain.
    fn global_reload<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>) {
        p.global_reload()
    }
    /// Frees the newest global slot: returns its index.
    fn release_spill_slot<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>) -> L::Word {
        p.release_spill_slot()
    }
}

/// The design: every step as [`Plan`] writes it.
#[derive(Clone, Copy, Debug, Default)]
pub struct Design;

impl Steps for Design {}
impl super::cycle::CycleSteps for Design {}

/// One command of one thread being planned.
pub struct Plan<'a, L: Logic, P: Steps, R: Regfile<L>> {
    pub l: &'a mut L,
    pub steps: &'a P,
    pub rf: &'a mut R,
    pub cfg: &'a Config,
    /// The commanding thread (its index in the RT unit) and its warp's first thread.
    pub t: u32,
    pub base: u32,
    /// The thread's registers, as the plan leaves them.
    pub th: Thread<L>,
    /// What the plan counted (meaningful in simulation only).
    pub stats: StackStats,
}

impl<'a, L: Logic, P: Steps, R: Regfile<L>> Plan<'a, L, P, R> {
    /// Plans `cmd` (`busy`: the thread's sequencer is not idle). Returns the popped entry for a
    /// pop (`None` for a pop answered Restart), or the refusal; on a refusal the caller drops
    /// what the plan wrote.
    pub fn run(&mut self, cmd: CmdOf<L::Val>, busy: L::Bit) -> Result<Option<L::Val>, StackError> {
        if let CmdOf::None = cmd {
            return Ok(None);
        }
        if let Some(e) = P::refuse(self, &cmd, busy) {
            return Err(e);
        }
        match cmd {
            CmdOf::None => Ok(None),
            CmdOf::Push(v) => {
                self.stats.pushes += 1;
                self.push(v).map(|_| None)
            }
            CmdOf::Pop => self.pop(),
            CmdOf::Finish => self.finish().map(|_| None),
        }
    }

    // ---- register access ----------------------------------------------------------------------

    pub fn stack(&mut self, s: L::Word) -> Regs<L> {
        self.rf.stack(self.l, s)
    }
    pub fn set(&mut self, s: L::Word, r: Regs<L>) {
        self.rf.set_stack(self.l, s, r)
    }
    fn emit(&mut self, u: UopL<L>) {
        let on = self.l.bit(true);
        self.rf.emit(self.l, on, u)
    }
    fn tw(&mut self) -> L::Word {
        self.l.word(self.t)
    }
    fn m(&self) -> u32 {
        self.cfg.sh_entries
    }

    // ---- acceptance ----------------------------------------------------------------------------

    pub fn refuse(&mut self, _cmd: &CmdOf<L::Val>, busy: L::Bit) -> Option<StackError> {
        let t = self.t;
        if self.l.decide(busy) {
            return Some(StackError::Busy { thread: t });
        }
        if self.l.decide(self.th.done) {
            return Some(StackError::AfterFinish { thread: t });
        }
        None
    }

    // ---- circular queue pointer logic ----------------------------------------------------------

    pub fn inc(&mut self, i: L::Word) -> L::Word {
        let m = self.l.word(self.m());
        let n = self.l.add_k(i, 1);
        let inside = self.l.lt(n, m);
        let wrapped = self.l.sub(n, m);
        self.l.mux(inside, n, wrapped)
    }

    pub fn dec(&mut self, i: L::Word) -> L::Word {
        let zero = self.l.eq_k(i, 0);
        let last = self.l.word(self.m().wrapping_sub(1));
        let d = self.l.sub_k(i, 1);
        self.l.mux(zero, last, d)
    }

    pub fn entries(&mut self, r: &Regs<L>) -> L::Word {
        r.entries(self.l, self.m())
    }

    pub fn full(&mut self, s: L::Word) -> L::Bit {
        let r = self.stack(s);
        let n = P::entries(self, &r);
        self.l.eq_k(n, self.m())
    }

    fn push_top(&mut self, s: L::Word) -> L::Word {
        let r = self.stack(s);
        let up = P::inc(self, r.top);
        let top = self.l.mux(r.empty, r.top, up);
        let empty = self.l.bit(false);
        self.set(s, StackRegsOf { top, empty, ..r });
        top
    }

    pub fn pop_top(&mut self, s: L::Word) -> L::Word {
        let r = self.stack(s);
        let last = self.l.eq(r.top, r.bottom);
        let down = self.dec(r.top);
        let top = self.l.mux(last, r.top, down);
        let yes = self.l.bit(true);
        let empty = self.l.mux_bit(last, yes, r.empty);
        self.set(s, StackRegsOf { top, empty, ..r });
        r.top
    }

    pub fn push_bottom(&mut self, s: L::Word) -> L::Word {
        let r = self.stack(s);
        let down = self.dec(r.bottom);
        let bottom = self.l.mux(r.empty, r.bottom, down);
        let empty = self.l.bit(false);
        self.set(s, StackRegsOf { bottom, empty, ..r });
        bottom
    }

    pub fn pop_bottom(&mut self, s: L::Word) -> L::Word {
        let r = self.stack(s);
        let popped = self.pop_bottom_of(r);
        self.set(s, popped);
        r.bottom
    }

    /// Stack registers `r` with the oldest entry taken off.
    fn pop_bottom_of(&mut self, r: Regs<L>) -> Regs<L> {
        let next = P::inc(self, r.bottom);
        let last = self.l.eq(r.top, r.bottom);
        let bottom = self.l.mux(last, r.bottom, next);
        let yes = self.l.bit(true);
        let empty = self.l.mux_bit(last, yes, r.empty);
        StackRegsOf { bottom, empty, ..r }
    }

    pub fn skew_base(&mut self, lane: L::Word) -> L::Word {
        self.cfg.skew_base_of(self.l, lane)
    }

    // ---- chains (reallocation) -----------------------------------------------------------------

    /// The thread's chain, following Next TID around the ring from its dedicated stack. A chain
    /// holds at most 1 + borrow limit stacks (SPEC 5; one without reallocation), so the walker
    /// has that many stages.
    pub fn members(&mut self) -> Chain<L> {
        let t = self.tw();
        let base = self.l.word(self.base);
        let mut on = self.l.bit(true);
        let mut c = Chain { ids: [t; 32], on: [on; 32], len: 0 };
        let mut s = t;
        let bound = (self.cfg.policy.chain_bound() as usize).min(32);
        loop {
            c.ids[c.len] = s;
            c.on[c.len] = on;
            c.len += 1;
            let next = self.stack(s).next_tid;
            s = self.l.add(base, next);
            let back = self.l.eq(s, t);
            let go = self.l.not(back);
            on = self.l.and(on, go);
            if !self.l.maybe(on) || c.len == bound {
                return c;
            }
        }
    }

    /// Stacks in the chain.
    pub fn chain_len(&mut self, c: &Chain<L>) -> L::Word {
        let mut n = self.l.word(0);
        for k in 0..c.len {
            let one = self.l.count(c.on[k]);
            n = self.l.add(n, one);
        }
        n
    }

    /// The member of highest (`highest`) or lowest Priority: the last highest, or the first
    /// lowest, in ring order.
    pub fn by_priority(&mut self, c: &Chain<L>, highest: bool) -> L::Word {
        self.by_priority_among(c, c.len, highest)
    }

    /// [`Self::by_priority`] over the first `n` positions of the ring.
    pub fn by_priority_among(&mut self, c: &Chain<L>, n: usize, highest: bool) -> L::Word {
        let mut best = c.ids[0];
        let mut bp = self.stack(best).priority;
        for k in 1..n.min(c.len) {
            let p = self.stack(c.ids[k]).priority;
            let better = if highest { self.l.le(bp, p) } else { self.l.lt(p, bp) };
            let take = self.l.and(c.on[k], better);
            best = self.l.mux(take, c.ids[k], best);
            bp = self.l.mux(take, p, bp);
        }
        best
    }

    /// The first member, in ring order, whose SH stack is empty: (found, stack).
    fn first_empty(&mut self, c: &Chain<L>) -> (L::Bit, L::Word) {
        let mut found = self.l.bit(false);
        let mut id = c.ids[0];
        for k in 0..c.len {
            let e = self.stack(c.ids[k]).empty;
            let fresh = self.l.not(found);
            let here = self.l.and(c.on[k], e);
            let take = self.l.and(here, fresh);
            id = self.l.mux(take, c.ids[k], id);
            found = self.l.or(found, take);
        }
        (found, id)
    }

    /// Moves member `s` to rank `to`, shifting the ranks between.
    pub fn move_to_rank(&mut self, c: &Chain<L>, s: L::Word, to: L::Word) {
        let from = self.stack(s).priority;
        let up = self.l.lt(from, to);
        let down = self.l.lt(to, from);
        for k in 0..c.len {
            let id = c.ids[k];
            let other = self.l.ne(id, s);
            let member = self.l.and(c.on[k], other);
            if !self.l.maybe(member) {
                continue;
            }
            let r = self.stack(id);
            let p = r.priority;
            // from < to: the ranks in (from, to] move down one; to < from: [to, from) up one.
            let above_from = self.l.lt(from, p);
            let to_or_below = self.l.le(p, to);
            let a = self.l.and(up, above_from);
            let lower = self.l.and(a, to_or_below);
            let from_above = self.l.lt(p, from);
            let to_or_above = self.l.le(to, p);
            let b = self.l.and(down, from_above);
            let raise = self.l.and(b, to_or_above);
            let moved = self.l.or(lower, raise);
            let change = self.l.and(member, moved);
            if !self.l.maybe(change) {
                continue;
            }
            let pm = self.l.sub_k(p, 1);
            let pp = self.l.add_k(p, 1);
            let np = self.l.mux(lower, pm, pp);
            let priority = self.l.mux(change, np, p);
            self.set(id, StackRegsOf { priority, ..r });
        }
        let r = self.stack(s);
        self.set(s, StackRegsOf { priority: to, ..r });
    }

    pub fn reset_flush(&mut self, s: L::Word) {
        let r = self.stack(s);
        let flush = self.l.word(0);
        self.set(s, StackRegsOf { flush, ..r });
    }

    /// The lowest-numbered Idle stack of the warp: (found, stack).
    pub fn first_idle(&mut self) -> (L::Bit, L::Word) {
        self.first_idle_among(0, self.cfg.warp_size)
    }

    /// The lowest-numbered Idle stack among the `count` lanes from `first`: (found, stack).
    pub fn first_idle_among(&mut self, first: u32, count: u32) -> (L::Bit, L::Word) {
        let mut found = self.l.bit(false);
        let from = self.base + first;
        let mut id = self.l.word(from);
        for s in from..from + count {
            let sw = self.l.word(s);
            let idle = self.stack(sw).idle;
            let fresh = self.l.not(found);
            let take = self.l.and(idle, fresh);
            id = self.l.mux(take, sw, id);
            found = self.l.or(found, take);
            let searching = self.l.not(found);
            if !self.l.maybe(searching) {
                break;
            }
        }
        (found, id)
    }

    pub fn borrow(&mut self, s: L::Word, rank: L::Word) {
        let t = self.tw();
        let base = self.l.word(self.base);
        let lane = self.l.sub(s, base);
        let anchor = self.stack(t);
        let b = P::skew_base(self, lane);
        let (no, zero) = (self.l.bit(false), self.l.word(0));
        let yes = self.l.bit(true);
        self.set(
            s,
            StackRegsOf {
                top: b,
                bottom: b,
                empty: yes,
                idle: no,
                next_tid: anchor.next_tid,
                priority: rank,
                flush: zero,
            },
        );
        self.set(t, StackRegsOf { next_tid: lane, ..anchor });
        self.stats.borrows += 1;
    }

    pub fn pred_of(&mut self, c: &Chain<L>, s: L::Word) -> L::Word {
        let base = self.l.word(self.base);
        let mut found = self.l.bit(false);
        let mut pred = self.tw();
        for k in 0..c.len {
            let next = self.stack(c.ids[k]).next_tid;
            let points = self.l.add(base, next);
            let hit = self.l.eq(points, s);
            let fresh = self.l.not(found);
            let here = self.l.and(c.on[k], hit);
            let take = self.l.and(here, fresh);
            pred = self.l.mux(take, c.ids[k], pred);
            found = self.l.or(found, take);
        }
        pred
    }

    pub fn unlinked(&mut self, r: Regs<L>, lane: L::Word) -> Regs<L> {
        let priority = self.l.word(0);
        StackRegsOf { next_tid: lane, priority, ..r }
    }

    /// Takes drained borrowed stack `s` out of the thread's chain.
    fn unlink(&mut self, s: L::Word) {
        let c = self.members();
        let pred = P::pred_of(self, &c, s);
        let next = self.stack(s).next_tid;
        let r = self.stack(pred);
        self.set(pred, StackRegsOf { next_tid: next, ..r });
        let r = self.stack(s);
        let base = self.l.word(self.base);
        let lane = self.l.sub(s, base);
        let r = P::unlinked(self, r, lane);
        self.set(s, r);
        P::reset_flush(self, s);
    }

    pub fn release(&mut self, s: L::Word) {
        self.emit(UopOf::Release { stack: s });
    }

    // ---- the plan: registers now, micro-ops for the sequencer ----------------------------------

    fn claim_spill_slots(&mut self, n: L::Word) -> Result<L::Word, StackError> {
        let limit = (1u32 << self.cfg.spill_ptr_bits.min(31)) - 1;
        let sp = self.th.spill_ptr;
        let sum = self.l.add(sp, n);
        let lw = self.l.word(limit);
        let past = self.l.lt(lw, sum);
        let wrapped = self.l.lt(sum, sp);
        let over = self.l.or(past, wrapped);
        if self.l.decide(over) {
            return Err(StackError::SpillRegionFull { thread: self.t, entries: limit });
        }
        self.th.spill_ptr = sum;
        self.th.overflow = self.l.bit(true);
        Ok(sp)
    }

    /// Spills `v` (the oldest RB entry) out of the full RB.
    fn spill(&mut self, v: L::Val) -> Result<(), StackError> {
        if self.m() == 0 {
            return P::on_full_rb(self, v);
        }
        let chain = self.members();
        let top = P::top_of(self, &chain);
        let full = self.full(top);
        let room = self.l.not(full);
        if self.l.decide(room) {
            P::spill_into(self, top, v);
            return Ok(());
        }
        if P::on_full_top(self, &chain, v)? {
            return Ok(());
        }
        P::on_full_chain(self, top, v)
    }

    /// The paper's answer to a full top stack (SPEC 5): an empty member of the chain takes the
    /// entry; else a chain shorter than the limit borrows an idle stack; else the oldest member
    /// is flushed to global memory (when the chain has several members or its flush count is
    /// below the limit). Without reallocation, none of these: `false`.
    pub fn on_full_top(&mut self, chain: &Chain<L>, v: L::Val) -> Result<bool, StackError> {
        let Some(ra) = self.cfg.realloc() else { return Ok(false) };
        let len = self.chain_len(chain);
        let rank = self.l.sub_k(len, 1);
        let (some_empty, e) = self.first_empty(chain);
        if self.l.decide(some_empty) {
            self.move_to_rank(chain, e, rank);
            P::spill_into(self, e, v);
            return Ok(true);
        }
        let limit = self.l.word(ra.borrow_limit);
        let may_borrow = P::may_borrow(self, len, limit);
        if self.l.decide(may_borrow) {
            let (some_idle, s) = P::first_idle(self);
            if self.l.decide(some_idle) {
                P::borrow(self, s, len);
                P::spill_into(self, s, v);
                return Ok(true);
            }
        }
        let oldest = self.by_priority(chain, false);
        let one = self.l.word(1);
        let several = self.l.lt(one, len);
        let f = self.stack(oldest).flush;
        let below_limit = self.l.lt_k(f, ra.flush_limit);
        // A restart design empties the oldest member only when it is not the top: a lone full
        // stack drops one entry at a time ([`Plan::on_full_chain`]) rather than all of them.
        let below_limit = match self.cfg.overflow {
            Overflow::Spill => below_limit,
            Overflow::Drop => self.l.bit(false),
        };
        let may_flush = self.l.or(several, below_limit);
        if self.l.decide(may_flush) {
            self.flush(oldest, ra.flush_limit)?;
            self.move_to_rank(chain, oldest, rank);
            P::spill_into(self, oldest, v);
            return Ok(true);
        }
        Ok(false)
    }

    /// The RB's spill without an SH level (SPEC 3, M = 0): `v` goes to global memory at the
    /// spill pointer. A restart design drops it instead.
    pub fn on_full_rb(&mut self, v: L::Val) -> Result<(), StackError> {
        if self.cfg.overflow == Overflow::Drop {
            self.dropped();
            return Ok(());
        }
        let one = self.l.word(1);
        let slot = self.claim_spill_slots(one)?;
        self.emit(UopOf::GlobalStore { slot, src: SrcOf::Value(v) });
        self.stats.rb_to_global += 1;
        Ok(())
    }

    /// An entry left the stack for good (a restart design's overflow): the Overflow bit records
    /// that the stack no longer holds everything pushed.
    fn dropped(&mut self) {
        self.th.overflow = self.l.bit(true);
        self.stats.drops += 1;
    }

    /// The last level's spill (SPEC 3, push case 3): the top stack's oldest entry goes to global
    /// memory and `v` takes its place: SH load (Bottom) → global store → SH store (Top + 1). A
    /// restart design drops the oldest entry instead: Bottom advances with no micro-op, then the
    /// SH store.
    pub fn on_full_chain(&mut self, top: L::Word, v: L::Val) -> Result<(), StackError> {
        if self.cfg.overflow == Overflow::Drop {
            self.pop_bottom(top);
            self.dropped();
            P::spill_into(self, top, v);
            return Ok(());
        }
        let one = self.l.word(1);
        let slot = self.claim_spill_slots(one)?;
        let b = self.pop_bottom(top);
        self.emit(UopOf::ShLoad { stack: top, entry: b });
        self.emit(UopOf::GlobalStore { slot, src: SrcOf::Latch });
        self.stats.sh_to_global += 1;
        P::spill_into(self, top, v);
        Ok(())
    }

    pub fn spill_into(&mut self, s: L::Word, v: L::Val) {
        let e = self.push_top(s);
        self.emit(UopOf::ShStore { stack: s, entry: e, src: SrcOf::Value(v) });
        self.stats.rb_to_sh += 1;
    }

    /// Writes the whole of stack `s` to global memory, oldest entry first (lowest address). A
    /// restart design drops its entries instead: no micro-ops, the Overflow bit set.
    fn flush(&mut self, s: L::Word, limit: u32) -> Result<(), StackError> {
        let r = self.stack(s);
        let n = P::entries(self, &r);
        let drop = self.cfg.overflow == Overflow::Drop;
        let first = if drop { self.l.word(0) } else { self.claim_spill_slots(n)? };
        for i in 0..self.m() {
            let iw = self.l.word(i);
            let live = self.l.lt(iw, n);
            if !self.l.maybe(live) {
                break;
            }
            let r = self.stack(s);
            let popped = self.pop_bottom_of(r);
            let next = StackRegsOf::mux(self.l, live, popped, r);
            self.set(s, next);
            if drop {
                self.th.overflow = self.l.bit(true);
                self.stats.drops += 1;
                continue;
            }
            let slot = self.l.add(first, iw);
            self.rf.emit(self.l, live, UopOf::ShLoad { stack: s, entry: r.bottom });
            self.rf.emit(self.l, live, UopOf::GlobalStore { slot, src: SrcOf::Latch });
            self.stats.sh_to_global += 1;
        }
        self.stats.flushes += 1;
        let r = self.stack(s);
        let below = self.l.lt_k(r.flush, limit);
        let saturated = self.l.not(below);
        if self.l.maybe(saturated) {
            self.stats.flushes_saturated += 1;
        }
        if self.l.maybe(below) {
            let up = self.l.add_k(r.flush, 1);
            let flush = self.l.mux(saturated, r.flush, up);
            self.set(s, StackRegsOf { flush, ..r });
        }
        Ok(())
    }

    fn push(&mut self, v: L::Val) -> Result<(), StackError> {
        if let Some(n) = self.cfg.rb.capacity() {
            let len = self.rf.rb_len(self.l);
            let nw = self.l.word(n);
            let full = self.l.le(nw, len);
            if self.l.decide(full) {
                let oldest = self.rf.rb_front(self.l);
                self.rf.rb(self.l, RbOp::PopFront);
                self.spill(oldest)?;
            }
        }
        self.rf.rb(self.l, RbOp::PushBack(v));
        Ok(())
    }

    fn pop(&mut self) -> Result<Option<L::Val>, StackError> {
        let len = self.rf.rb_len(self.l);
        let empty = self.l.eq_k(len, 0);
        if self.l.decide(empty) {
            P::on_empty_pop(self)?;
            self.stats.restarts += 1;
            return Ok(None);
        }
        let v = self.rf.rb_back(self.l);
        self.rf.rb(self.l, RbOp::PopBack);
        self.stats.pops += 1;
        if self.m() == 0 {
            if self.cfg.overflow == Overflow::Spill && self.l.decide(self.th.overflow) {
                let slot = P::release_spill_slot(self);
                self.emit(UopOf::GlobalLoad { slot });
                self.emit(UopOf::RbBottom);
                self.stats.global_to_rb += 1;
            }
            return Ok(Some(v));
        }
        let chain = self.members();
        let top = P::top_of(self, &chain);
        let holds = self.stack(top).empty;
        let holds = self.l.not(holds);
        if self.l.decide(holds) {
            let e = P::take_newest(self, top);
            self.emit(UopOf::ShLoad { stack: top, entry: e });
            self.emit(UopOf::RbBottom);
            self.stats.sh_to_rb += 1;
            let drained = P::drained(self, top);
            if self.l.decide(drained) {
                P::on_drained(self, &chain, top);
            }
        }
        P::global_reload(self);
        Ok(Some(v))
    }

    /// The paper's answer to a pop of an empty stack: refused. A restart design whose Overflow
    /// bit is set answers Restart and clears the bit (every entry still owed was dropped, and the
    /// walk re-pushes what it needs from the root); with the bit clear it refuses too.
    pub fn on_empty_pop(&mut self) -> Result<(), StackError> {
        let refuse = Err(StackError::PopEmpty { thread: self.t });
        if self.cfg.overflow == Overflow::Spill || !self.l.decide(self.th.overflow) {
            return refuse;
        }
        self.th.overflow = self.l.bit(false);
        Ok(())
    }

    /// The paper's answer to a pop that drained the chain's top stack: its flush count
    /// restarts; in a chain of several, a borrowed top leaves the ring and is given back, the
    /// thread's own stack takes the lowest rank.
    pub fn on_drained(&mut self, chain: &Chain<L>, top: L::Word) {
        P::reset_flush(self, top);
        let len = self.chain_len(chain);
        let one = self.l.word(1);
        let several = self.l.lt(one, len);
        if self.l.decide(several) {
            let t = self.tw();
            let own = self.l.eq(top, t);
            let borrowed = self.l.not(own);
            if self.l.decide(borrowed) {
                self.unlink(top);
                P::release(self, top);
                self.stats.releases += 1;
            } else {
                let zero = self.l.word(0);
                self.move_to_rank(chain, t, zero);
                self.stats.demotions += 1;
            }
        }
    }

    pub fn global_reload(&mut self) {
        // A restart design's Overflow bit says entries were dropped: there is nothing to reload.
        if self.cfg.overflow == Overflow::Drop || !self.l.decide(self.th.overflow) {
            return;
        }
        let chain = self.members();
        let oldest = P::reload_target(self, &chain);
        let full = self.full(oldest);
        let room = self.l.not(full);
        if self.l.decide(room) {
            let slot = P::release_spill_slot(self);
            let e = self.push_bottom(oldest);
            self.emit(UopOf::GlobalLoad { slot });
            self.emit(UopOf::ShStore { stack: oldest, entry: e, src: SrcOf::Latch });
            self.stats.global_to_sh += 1;
        }
    }

    pub fn release_spill_slot(&mut self) -> L::Word {
        let sp = self.l.sub_k(self.th.spill_ptr, 1);
        let emptied = self.l.eq_k(sp, 0);
        let kept = self.l.not(emptied);
        self.th.spill_ptr = sp;
        self.th.overflow = self.l.and(self.th.overflow, kept);
        sp
    }

    fn finish(&mut self) -> Result<(), StackError> {
        let len = self.rf.rb_len(self.l);
        let zero = self.l.word(0);
        let holds = self.l.ne(len, zero);
        // A restart design that dropped entries still owes them: the walk must restart first.
        let owes = self.l.bit(self.cfg.overflow == Overflow::Drop);
        let owes = self.l.and(owes, self.th.overflow);
        let holds = self.l.or(holds, owes);
        if self.l.decide(holds) {
            return Err(StackError::FinishNonEmpty { thread: self.t });
        }
        self.th.done = self.l.bit(true);
        P::on_finish(self);
        Ok(())
    }

    /// The paper's answer to an accepted Finish: with reallocation, the thread's own stack turns
    /// Idle, free to lend.
    pub fn on_finish(&mut self) {
        if self.cfg.realloc().is_some() {
            let t = self.tw();
            let r = self.stack(t);
            let idle = self.l.bit(true);
            self.set(t, StackRegsOf { idle, ..r });
        }
    }
}

/// The paper's decisions, one by one, on a warp of 4 lanes with one RB and one SH entry per lane
/// (every third push decides something), completing each command's micro-ops at once.
#[cfg(test)]
mod tests {
    use crate::config::Config;
    use crate::stack_manager::{Cmd, StackManager};

    /// `name` on one 4-lane warp; with reallocation, a borrow limit of 2 (chains of three).
    fn manager(name: &str) -> StackManager {
        let mut cfg = Config { warp_size: 4, warps: 1, ..name.parse::<Config>().unwrap() };
        if let Some(ra) = cfg.policy.realloc_mut() {
            ra.borrow_limit = 2;
        }
        StackManager::new(cfg, 0).unwrap()
    }

    fn pushes(sm: &mut StackManager, t: u32, values: std::ops::RangeInclusive<u64>) {
        for v in values {
            sm.apply(t, Cmd::Push(v)).unwrap();
        }
    }

    /// Pops thread `t` empty, newest first.
    fn pop_all(sm: &mut StackManager, t: u32) -> Vec<u64> {
        std::iter::from_fn(|| sm.apply(t, Cmd::Pop).ok().flatten()).collect()
    }

    #[test]
    fn without_reallocation_a_full_chain_spills_its_oldest_entry_to_global() {
        let mut sm = manager("RB_1+SH_1");
        pushes(&mut sm, 0, 1..=3);
        assert_eq!((sm.stats.rb_to_sh, sm.stats.sh_to_global), (2, 1));
        assert_eq!(sm.global(0), [1], "the oldest entry left for global memory");
        assert_eq!(pop_all(&mut sm, 0), [3, 2, 1]);
        assert_eq!(sm.stats.global_to_sh, 1);
    }

    #[test]
    fn a_full_top_borrows_the_lowest_idle_stack_then_flushes_the_oldest() {
        let mut sm = manager("RB_1+SH_1+RA");
        for t in [2, 3] {
            sm.apply(t, Cmd::Finish).unwrap();
            assert!(sm.stack(t).idle, "a finished thread's stack is free to lend");
        }
        pushes(&mut sm, 0, 1..=3);
        assert_eq!(sm.chain(0), [0, 2], "the lowest Idle stack, linked after the owner");
        assert!(!sm.stack(2).idle);
        assert_eq!((sm.stack(0).priority, sm.stack(2).priority), (0, 1));
        // The next full top borrows lane 3 (a chain of three is the limit); the one after
        // flushes the oldest.
        pushes(&mut sm, 0, 4..=4);
        assert_eq!(sm.chain(0), [0, 3, 2]);
        pushes(&mut sm, 0, 5..=5);
        assert_eq!((sm.stats.borrows, sm.stats.flushes), (2, 1));
        assert_eq!(sm.global(0), [1], "the flush wrote the oldest stack to global memory");
        assert_eq!(pop_all(&mut sm, 0), [5, 4, 3, 2, 1]);
    }

    #[test]
    fn a_drained_borrowed_top_is_given_back() {
        let mut sm = manager("RB_1+SH_1+RA");
        sm.apply(1, Cmd::Finish).unwrap();
        pushes(&mut sm, 0, 1..=3);
        assert_eq!(sm.chain(0), [0, 1]);
        assert_eq!(sm.apply(0, Cmd::Pop).unwrap(), Some(3));
        // The pop reloaded the RB from the borrowed top (entry 2), which drained it.
        assert_eq!(sm.apply(0, Cmd::Pop).unwrap(), Some(2));
        assert_eq!(sm.chain(0), [0], "released");
        let s = sm.stack(1);
        assert!(s.idle && s.priority == 0 && s.next_tid == 1, "back with its owner: {s:?}");
        assert_eq!(sm.stats.releases, 1);
    }

    #[test]
    fn a_restart_design_drops_the_oldest_entry_and_answers_restart_when_empty() {
        for name in ["RB_1+RT", "RB_1+SH_1+RT"] {
            let mut sm = manager(name);
            let kept = if name.contains("SH") { 2 } else { 1 };
            pushes(&mut sm, 0, 1..=3);
            assert_eq!(sm.stats.drops, 3 - kept, "{name}");
            assert!(sm.thread(0).overflow, "{name}: the Overflow bit records the drop");
            assert!(sm.global(0).is_empty(), "{name}: nothing goes to global memory");
            assert!(sm.apply(0, Cmd::Finish).is_err(), "{name}: a thread that dropped entries owes them");
            let popped: Vec<u64> = (0..kept).map(|_| sm.apply(0, Cmd::Pop).unwrap().unwrap()).collect();
            assert_eq!(popped, (4 - kept..=3).rev().collect::<Vec<u64>>(), "{name}: newest first");
            assert_eq!(sm.apply(0, Cmd::Pop).unwrap(), None, "{name}: empty after drops: Restart");
            assert_eq!(sm.stats.restarts, 1);
            assert!(!sm.thread(0).overflow, "{name}: the restart clears the bit");
            assert!(sm.apply(0, Cmd::Pop).is_err(), "{name}: empty with nothing dropped is refused");
            sm.apply(0, Cmd::Finish).unwrap();
        }
    }

    #[test]
    fn a_restart_design_with_reallocation_drops_the_oldest_member_when_the_chain_is_full() {
        // RB 1, own stack 1, one borrowed (lane 2), then the chain of two is full (lane 3 busy).
        let mut sm3 = manager("RB_1+SH_1+RA+RT");
        sm3.apply(2, Cmd::Finish).unwrap();
        pushes(&mut sm3, 0, 1..=3);
        assert_eq!(sm3.chain(0), [0, 2]);
        pushes(&mut sm3, 0, 4..=4);
        assert_eq!((sm3.stats.drops, sm3.stats.flushes), (1, 1), "the oldest member emptied, no store");
        assert!(sm3.global(0).is_empty());
        assert_eq!(pop_all(&mut sm3, 0), [4, 3, 2], "then Restart");
        assert_eq!(sm3.stats.restarts, 1);
        // A lone full stack with nothing to borrow drops one entry at a time: its flush count
        // plays no part.
        let mut sm = manager("RB_1+SH_1+RA+RT");
        pushes(&mut sm, 1, 1..=4);
        assert_eq!((sm.stats.drops, sm.stats.flushes), (2, 0));
        assert_eq!(pop_all(&mut sm, 1), [4, 3]);
    }

    #[test]
    fn without_an_sh_level_the_rb_spills_its_oldest_entry_to_global() {
        let mut sm = manager("RB_1");
        pushes(&mut sm, 0, 1..=3);
        assert_eq!(sm.stats.rb_to_global, 2);
        assert_eq!(sm.global(0), [1, 2], "oldest first, at rising slots");
        assert_eq!(pop_all(&mut sm, 0), [3, 2, 1]);
    }

    #[test]
    fn a_lone_stack_flushes_until_its_limit_then_spills_one_entry_at_a_time() {
        // Every lane live: nothing to borrow, so a full chain of one flushes its stack while its
        // Flush count is below the limit (1 here), and at it sends only the oldest entry down.
        let mut cfg = Config { warp_size: 4, warps: 1, .."RB_1+SH_1+RA".parse::<Config>().unwrap() };
        let ra = cfg.policy.realloc_mut().unwrap();
        (ra.borrow_limit, ra.flush_limit) = (2, 1);
        let mut sm = StackManager::new(cfg, 0).unwrap();
        pushes(&mut sm, 0, 1..=3);
        // A flush's entries count as SH → global moves too.
        assert_eq!((sm.stats.flushes, sm.stats.sh_to_global, sm.stack(0).flush), (1, 1, 1));
        pushes(&mut sm, 0, 4..=4);
        assert_eq!((sm.stats.flushes, sm.stats.sh_to_global), (1, 2), "saturated: no second flush");
        assert_eq!(sm.global(0), [1, 2]);
        assert_eq!(pop_all(&mut sm, 0), [4, 3, 2, 1]);
    }

    #[test]
    fn a_pop_of_an_empty_stack_is_refused_and_changes_nothing() {
        let mut sm = manager("RB_1+SH_1+RA");
        let before = (*sm.thread(0), *sm.stack(0));
        assert!(matches!(sm.apply(0, Cmd::Pop), Err(crate::stack_manager::StackError::PopEmpty { .. })));
        assert_eq!((*sm.thread(0), *sm.stack(0)), before);
    }

    #[test]
    fn finish_is_refused_with_entries_and_lends_only_with_reallocation() {
        let mut sm = manager("RB_1+SH_1+RA");
        sm.apply(0, Cmd::Push(7)).unwrap();
        assert!(sm.apply(0, Cmd::Finish).is_err(), "a thread with entries cannot finish");
        let mut plain = manager("RB_1+SH_1");
        plain.apply(0, Cmd::Finish).unwrap();
        assert!(plain.thread(0).done && !plain.stack(0).idle, "without RA nothing is lent");
    }
}
