//! Deliberately broken variants of the stack manager, for showing the checkers catch bugs.
//!
//! Each enters through the policy's interface: [`Mutated`] is an implementation of
//! [`Steps`] that replaces one step and keeps the design's others. It exists only in builds
//! with the `mutants` feature; the product's code has no trace of it.

/// Deliberately broken variants, for showing the checkers catch bugs. Only builds with the
/// `mutants` feature plant them (`StackManager::with_mutant`); the list is the one source of their
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
    /// The entry count comes out of a 3-bit adder: a full stack of 8 entries reads as empty
    /// (right for M ≤ 4).
    CountAdderTooNarrow,
    /// Priority is written by borrowing into a 2-bit field: the fifth stack of a chain gets
    /// rank 0 (right for chains of at most 4).
    PriorityTooNarrow,
    /// The idle-stack search reads Idle as the cycle began, missing a stack another lane's
    /// command borrowed earlier in the same cycle.
    IdleSearchIgnoresEarlierLends,
    /// Next TID is encoded in 4 bits when a stack is borrowed: lanes 16–31 link to lane − 16.
    NextTidTooNarrow,
    /// The top-of-chain comparator sees only the first 3 members of the ring.
    TopComparatorThreeMembers,
    /// Borrowing links the owner to the lent stack's RT-unit thread id instead of its lane
    /// (right in warp 0 only).
    LinkWithThreadId,
    /// Skew wrong for one M: with M = 4 a borrowed stack starts at `(lane / 2) mod 4` instead
    /// of `(lane / 4) mod 4`.
    SkewWrongForM4,
    /// A Finish is accepted while the thread's sequencer is busy.
    FinishWhileBusy,
    /// A pop's global reload moves the oldest stack's Bottom and frees the spill slot but loads
    /// and stores nothing, as if the entry were still in the SH word it was flushed from (it
    /// often is: a flush copies words without clearing them).
    ReloadAssumesWordKept,
    /// Write priority: when two changes of one stack's registers meet in a cycle (a release
    /// landing and a plan, or two lanes' plans), the first is kept and the later dropped.
    FirstStackWriteWins,
    /// A command is accepted from a thread whose last micro-op completes in the same cycle (the
    /// busy check reads the sequencer after the cycle's completions, not its register).
    BusyAfterCompletion,
    /// A sequencer whose micro-op completes issues its next one a cycle later.
    IssueWaitsACycle,
    /// A micro-op issued in the cycle its predecessor completes reads the data latch as the
    /// cycle began, not the value that completion brought.
    IssueReadsOldLatch,
    /// When an SH completion and a global response arrive in the same cycle, the response is
    /// dropped.
    ResponseDroppedWithShDone,
    /// A completing SH store addresses its entry with 3 bits (right for M ≤ 8).
    StoredEntryThreeBits,
    /// A full chain flushes where it may still borrow its last stack (every entry still lands
    /// right: only the decision differs).
    FlushBeforeLastBorrow,
    /// A flush is counted twice: the spill into the stack just flushed adds one more to its
    /// Flush register (saturating at the limit, so the count stays in range and is 0 on every
    /// empty stack; right for a flush limit of 1).
    FlushCountedTwice,
    /// A restart design's full chain drops the entry being pushed instead of the oldest one.
    DropsNewest,
    /// A restart design drops an entry without setting the Overflow bit.
    DropForgetsOverflow,
    /// A pop answered Restart leaves the Overflow bit set.
    RestartKeepsOverflow,
    /// An empty stack answers Restart even though nothing was dropped.
    RestartWithoutDrop,
}

impl Mutant {
    /// Every mutant, in declaration order (the order of [`Self::NAMES`]).
    pub const ALL: [Mutant; 35] = [
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
        Mutant::CountAdderTooNarrow,
        Mutant::PriorityTooNarrow,
        Mutant::IdleSearchIgnoresEarlierLends,
        Mutant::NextTidTooNarrow,
        Mutant::TopComparatorThreeMembers,
        Mutant::LinkWithThreadId,
        Mutant::SkewWrongForM4,
        Mutant::FinishWhileBusy,
        Mutant::ReloadAssumesWordKept,
        Mutant::FirstStackWriteWins,
        Mutant::BusyAfterCompletion,
        Mutant::IssueWaitsACycle,
        Mutant::IssueReadsOldLatch,
        Mutant::ResponseDroppedWithShDone,
        Mutant::StoredEntryThreeBits,
        Mutant::FlushBeforeLastBorrow,
        Mutant::FlushCountedTwice,
        Mutant::DropsNewest,
        Mutant::DropForgetsOverflow,
        Mutant::RestartKeepsOverflow,
        Mutant::RestartWithoutDrop,
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
    Mutant::LendActiveStack => "lend-active-stack",
    Mutant::CountAdderTooNarrow => "count-adder-too-narrow",
    Mutant::PriorityTooNarrow => "priority-too-narrow",
    Mutant::IdleSearchIgnoresEarlierLends => "idle-search-ignores-earlier-lends",
    Mutant::NextTidTooNarrow => "next-tid-too-narrow",
    Mutant::TopComparatorThreeMembers => "top-comparator-three-members",
    Mutant::LinkWithThreadId => "link-with-thread-id",
    Mutant::SkewWrongForM4 => "skew-wrong-for-m4",
    Mutant::FinishWhileBusy => "finish-while-busy",
    Mutant::ReloadAssumesWordKept => "reload-assumes-word-kept",
    Mutant::FirstStackWriteWins => "first-stack-write-wins",
    Mutant::BusyAfterCompletion => "busy-after-completion",
    Mutant::IssueWaitsACycle => "issue-waits-a-cycle",
    Mutant::IssueReadsOldLatch => "issue-reads-old-latch",
    Mutant::ResponseDroppedWithShDone => "response-dropped-with-sh-done",
    Mutant::StoredEntryThreeBits => "stored-entry-three-bits",
    Mutant::FlushBeforeLastBorrow => "flush-before-last-borrow",
    Mutant::FlushCountedTwice => "flush-counted-twice",
    Mutant::DropsNewest => "drops-newest",
    Mutant::DropForgetsOverflow => "drop-forgets-overflow",
    Mutant::RestartKeepsOverflow => "restart-keeps-overflow",
    Mutant::RestartWithoutDrop => "restart-without-drop"
);

#[cfg(feature = "mutants")]
pub use planted::Mutated;

#[cfg(feature = "mutants")]
impl Mutant {
    /// The paper's design with this bug planted, as a stack manager's policy.
    pub fn policy(self) -> super::StackPolicy {
        super::StackPolicy::new(Mutated(self))
    }
}

#[cfg(feature = "mutants")]
impl super::StackManager {
    /// The manager running the paper's design with bug `m` planted (none: its configuration's
    /// policy).
    pub fn with_mutant(self, m: Option<Mutant>) -> Self {
        let policy = match m {
            Some(m) => m.policy(),
            None => super::StackPolicy::of(self.config()),
        };
        self.with_policy(policy)
    }
}

#[cfg(feature = "mutants")]
mod planted {
    use super::super::cycle::{merge_stack, CycleIn, CycleSteps, Journal, Registers};
    use super::super::policy::{Chain, Plan, Regfile, Regs, Steps};
    use super::super::regs::{CmdOf, StackError, StackRegsOf};
    use super::Mutant;
    use crate::config::{Config, Overflow};
    use crate::logic::Logic;

    impl CycleSteps for Mutated {
        fn busy_for_command<L: Logic>(
            &self,
            l: &mut L,
            q: &impl Registers<L>,
            d: &Journal<L>,
            t: u32,
        ) -> L::Bit {
            let busy = q.busy_q(l, t);
            if self.0 != Mutant::BusyAfterCompletion {
                return busy;
            }
            // Ready again if the cycle's completion emptied a sequencer with nothing queued.
            let drained = d.completed.iter().any(|c| c.0 == t && c.1.is_none()) && q.head_q(t).is_none();
            if drained {
                l.bit(false)
            } else {
                busy
            }
        }
        fn issue_after_completion(&self) -> bool {
            self.0 != Mutant::IssueWaitsACycle
        }
        fn latch_at_issue<L: Logic>(
            &self,
            q: &impl Registers<L>,
            t: u32,
            after: Option<L::Val>,
        ) -> Option<L::Val> {
            if self.0 == Mutant::IssueReadsOldLatch {
                q.latch_q(t)
            } else {
                after
            }
        }
        fn stored_entry<L: Logic>(&self, l: &mut L, _cfg: &Config, entry: L::Word) -> L::Word {
            if self.0 == Mutant::StoredEntryThreeBits {
                let low = l.word(7);
                l.mask(entry, low)
            } else {
                entry
            }
        }
        fn merge_plan_stack<L: Logic>(
            &self,
            l: &mut L,
            list: &mut Vec<(L::Word, Regs<L>)>,
            s: L::Word,
            r: Regs<L>,
        ) {
            if self.0 != Mutant::FirstStackWriteWins {
                return merge_stack(l, list, s, r);
            }
            // Keep an earlier entry for the same stack: the later change is dropped.
            let mut keep = l.bit(false);
            for &(i, _) in list.iter() {
                let hit = l.eq(i, s);
                keep = l.or(keep, hit);
            }
            let before = super::super::cycle::lookup(l, list, s, r);
            let v = StackRegsOf::mux(l, keep, before, r);
            merge_stack(l, list, s, v);
        }
        fn completions<'a>(&self, i: &CycleIn<'a, impl Copy>) -> (&'a [u32], Option<u32>) {
            if self.0 == Mutant::ResponseDroppedWithShDone && !i.done.is_empty() {
                (i.done, None)
            } else {
                (i.done, i.deq)
            }
        }
    }

    /// The design with planted bug `.0`.
    #[derive(Clone, Copy, Debug)]
    pub struct Mutated(pub Mutant);

    type P<'a, L, R> = Plan<'a, L, Mutated, R>;

    fn is<L: Logic, R: Regfile<L>>(p: &P<L, R>, m: Mutant) -> bool {
        p.steps.0 == m
    }

    impl Steps for Mutated {
        fn name(&self) -> &'static str {
            self.0.name()
        }

        fn refuse<L: Logic, R: Regfile<L>>(
            p: &mut P<L, R>,
            cmd: &CmdOf<L::Val>,
            busy: L::Bit,
        ) -> Option<StackError> {
            if is(p, Mutant::FinishWhileBusy) && matches!(cmd, CmdOf::Finish) {
                let idle = p.l.bit(false);
                return p.refuse(cmd, idle);
            }
            p.refuse(cmd, busy)
        }

        fn inc<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, i: L::Word) -> L::Word {
            if is(p, Mutant::QueueWrapOffByOne) {
                let m = p.cfg.sh_entries;
                let n = p.l.add_k(i, 1);
                let inside = p.l.lt_k(n, m);
                let one = p.l.word(1 % m);
                return p.l.mux(inside, n, one);
            }
            p.inc(i)
        }

        fn entries<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, r: &Regs<L>) -> L::Word {
            let n = p.entries(r);
            if is(p, Mutant::CountAdderTooNarrow) {
                let three_bits = p.l.word(7);
                return p.l.mask(n, three_bits);
            }
            n
        }

        fn skew_base<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, lane: L::Word) -> L::Word {
            let (skew, m) = (p.cfg.skew, p.cfg.sh_entries);
            if is(p, Mutant::SkewWrongForOneM) && skew && m == 2 {
                let two = p.l.word(2);
                return p.l.rem(lane, two);
            }
            if is(p, Mutant::SkewWrongForM4) && skew && m == 4 {
                let (two, four) = (p.l.word(2), p.l.word(4));
                let row = p.l.div(lane, two);
                return p.l.rem(row, four);
            }
            p.skew_base(lane)
        }

        fn top_of<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, c: &Chain<L>) -> L::Word {
            if is(p, Mutant::TopComparatorThreeMembers) {
                return p.by_priority_among(c, 3, true);
            }
            p.by_priority(c, true)
        }

        fn reload_target<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, c: &Chain<L>) -> L::Word {
            p.by_priority(c, is(p, Mutant::ReloadIntoTop))
        }

        fn may_borrow<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, len: L::Word, limit: L::Word) -> L::Bit {
            if is(p, Mutant::FlushBeforeLastBorrow) {
                p.l.lt(len, limit)
            } else {
                p.l.le(len, limit)
            }
        }

        fn on_full_rb<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, v: L::Val) -> Result<(), StackError> {
            if is(p, Mutant::DropForgetsOverflow) && p.cfg.overflow == Overflow::Drop {
                p.stats.drops += 1;
                return Ok(());
            }
            p.on_full_rb(v)
        }

        fn on_full_chain<L: Logic, R: Regfile<L>>(
            p: &mut P<L, R>,
            top: L::Word,
            v: L::Val,
        ) -> Result<(), StackError> {
            if p.cfg.overflow == Overflow::Drop {
                if is(p, Mutant::DropsNewest) {
                    p.th.overflow = p.l.bit(true);
                    p.stats.drops += 1;
                    return Ok(());
                }
                if is(p, Mutant::DropForgetsOverflow) {
                    p.pop_bottom(top);
                    p.stats.drops += 1;
                    Self::spill_into(p, top, v);
                    return Ok(());
                }
            }
            p.on_full_chain(top, v)
        }

        fn on_empty_pop<L: Logic, R: Regfile<L>>(p: &mut P<L, R>) -> Result<(), StackError> {
            if p.cfg.overflow == Overflow::Drop {
                if is(p, Mutant::RestartKeepsOverflow) && p.l.decide(p.th.overflow) {
                    return Ok(());
                }
                if is(p, Mutant::RestartWithoutDrop) {
                    p.th.overflow = p.l.bit(false);
                    return Ok(());
                }
            }
            p.on_empty_pop()
        }

        fn first_idle<L: Logic, R: Regfile<L>>(p: &mut P<L, R>) -> (L::Bit, L::Word) {
            if !is(p, Mutant::LendActiveStack) && !is(p, Mutant::IdleSearchIgnoresEarlierLends) {
                return p.first_idle();
            }
            let lend_active = is(p, Mutant::LendActiveStack);
            let t = p.t;
            let mut found = p.l.bit(false);
            let mut id = p.l.word(p.base);
            for s in p.base..p.base + p.cfg.warp_size {
                let sw = p.l.word(s);
                let r = if lend_active { p.stack(sw) } else { p.rf.stack_q(p.l, sw) };
                let mut idle = r.idle;
                if lend_active && s != t {
                    // An active thread's empty, unchained dedicated stack taken as if idle.
                    let lane = p.l.word(s - p.base);
                    let unchained = p.l.eq(r.next_tid, lane);
                    let done = p.rf.done(p.l, sw);
                    let active = p.l.not(done);
                    let a = p.l.and(r.empty, unchained);
                    let a = p.l.and(a, active);
                    idle = p.l.or(idle, a);
                }
                let fresh = p.l.not(found);
                let take = p.l.and(idle, fresh);
                id = p.l.mux(take, sw, id);
                found = p.l.or(found, take);
            }
            (found, id)
        }

        fn borrow<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, s: L::Word, rank: L::Word) {
            let t = p.l.word(p.t);
            let before = p.stack(t);
            p.borrow(s, rank);
            if is(p, Mutant::PriorityTooNarrow) {
                let r = p.stack(s);
                let two_bits = p.l.word(3);
                let priority = p.l.mask(rank, two_bits);
                p.set(s, StackRegsOf { priority, ..r });
            }
            if is(p, Mutant::NextTidTooNarrow) || is(p, Mutant::LinkWithThreadId) {
                let base = p.l.word(p.base);
                let lane = p.l.sub(s, base);
                let next_tid = if is(p, Mutant::LinkWithThreadId) {
                    s
                } else {
                    let four_bits = p.l.word(15);
                    p.l.mask(lane, four_bits)
                };
                p.set(t, StackRegsOf { next_tid, ..before });
            }
        }

        fn pred_of<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, c: &Chain<L>, s: L::Word) -> L::Word {
            if is(p, Mutant::ReleaseAssumesAdjacent) {
                return p.l.word(p.t);
            }
            p.pred_of(c, s)
        }

        fn unlinked<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, r: Regs<L>, lane: L::Word) -> Regs<L> {
            let u = p.unlinked(r, lane);
            if is(p, Mutant::PriorityKeptOnRelease) {
                return StackRegsOf { priority: r.priority, ..u };
            }
            u
        }

        fn reset_flush<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, s: L::Word) {
            if !is(p, Mutant::FlushKeepsCount) {
                p.reset_flush(s)
            }
        }

        fn spill_into<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, s: L::Word, v: L::Val) {
            if let (true, Some(ra)) = (is(p, Mutant::FlushCountedTwice), p.cfg.realloc()) {
                // The plan flushed `s` when its count moved since the cycle began (nothing else
                // in a push's plan writes Flush but a borrow, which writes 0 over 0).
                let now = p.stack(s);
                let was = p.rf.stack_q(p.l, s);
                let flushed = p.l.ne(now.flush, was.flush);
                let room = p.l.lt_k(now.flush, ra.flush_limit);
                let again = p.l.and(flushed, room);
                let up = p.l.add_k(now.flush, 1);
                let flush = p.l.mux(again, up, now.flush);
                p.set(s, StackRegsOf { flush, ..now });
            }
            if is(p, Mutant::SpillDropsEntry) {
                // Top advances; the store never issues.
                let r = p.stack(s);
                let up = Self::inc(p, r.top);
                let top = p.l.mux(r.empty, r.top, up);
                let empty = p.l.bit(false);
                p.set(s, StackRegsOf { top, empty, ..r });
                p.stats.rb_to_sh += 1;
                return;
            }
            p.spill_into(s, v)
        }

        fn take_newest<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, s: L::Word) -> L::Word {
            if is(p, Mutant::ReloadWrongEntry) {
                return p.pop_bottom(s);
            }
            p.pop_top(s)
        }

        fn drained<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, s: L::Word) -> L::Bit {
            let r = p.stack(s);
            if is(p, Mutant::EarlyRelease) {
                let t = p.l.word(p.t);
                let borrowed = p.l.ne(s, t);
                let n = Self::entries(p, &r);
                let one_left = p.l.eq_k(n, 1);
                let early = p.l.and(borrowed, one_left);
                return p.l.or(r.empty, early);
            }
            r.empty
        }

        fn release<L: Logic, R: Regfile<L>>(p: &mut P<L, R>, s: L::Word) {
            if is(p, Mutant::EagerRelease) {
                let r = p.stack(s);
                let idle = p.l.bit(true);
                p.set(s, StackRegsOf { idle, ..r });
                return;
            }
            p.release(s)
        }

        fn global_reload<L: Logic, R: Regfile<L>>(p: &mut P<L, R>) {
            if is(p, Mutant::ReloadAssumesWordKept) {
                if p.l.decide(p.th.overflow) {
                    let chain = p.members();
                    let oldest = p.by_priority(&chain, false);
                    let full = p.full(oldest);
                    let room = p.l.not(full);
                    if p.l.decide(room) {
                        p.release_spill_slot();
                        p.push_bottom(oldest);
                    }
                }
                return;
            }
            if !is(p, Mutant::MissingGlobalReload) {
                p.global_reload()
            }
        }

        fn release_spill_slot<L: Logic, R: Regfile<L>>(p: &mut P<L, R>) -> L::Word {
            let skip_clear = is(p, Mutant::SkipOverflowClear);
            let early = is(p, Mutant::OverflowClearedEarly);
            if !skip_clear && !early {
                return p.release_spill_slot();
            }
            let sp = p.l.sub_k(p.th.spill_ptr, 1);
            p.th.spill_ptr = sp;
            if early {
                let at_most_one = p.l.lt_k(sp, 2);
                let kept = p.l.not(at_most_one);
                p.th.overflow = p.l.and(p.th.overflow, kept);
            }
            sp
        }
    }
}
