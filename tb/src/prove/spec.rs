//! The specification: SPEC sections 3 and 5's case table (with `docs/`'s settlement of SPEC
//! section 9), as what one accepted command does to the registers and which micro-op program it
//! loads. Written from the case table over the registers *before* the command, over [`Logic`]
//! so that the exhaustive checker runs it on integers and `sms prove` on symbolic terms. It
//! never calls the design's policy: the two are separate descriptions, compared.
//!
//! | command | case | sequence | registers |
//! |---|---|---|---|
//! | push | RB not full | — | — |
//! | push | RB full, M = 0 | global store (oldest RB entry) at the spill pointer | spill pointer + 1, Overflow |
//! | push | top stack not full | SH store at Top + 1 (at Top if empty) | Top |
//! | push | RA, an empty member | SH store at its Top | it becomes the top rank, the ranks above it move down |
//! | push | RA, chain shorter than 1 + borrow limit, an Idle stack | SH store at the lowest Idle stack's skewed base | it joins the ring after the owner, at the top rank |
//! | push | RA_G, chain shorter than 1 + borrow limit, an Idle stack among the G lanes of the thread's group | SH store at the lowest such stack's skewed base | as with RA |
//! | push | RA, several members or flush count below the limit: flush the oldest | (SH load → global store) × its count from Bottom, then SH store at its old Top | it becomes the top rank holding one entry, flush count + 1 (saturating), spill pointer + count |
//! | push | otherwise | SH load (Bottom) → global store → SH store at Top + 1 | Top and Bottom advance, spill pointer + 1 |
//! | pop | RB empty | refused | — |
//! | pop | M = 0, global holds entries | global load (newest slot) → RB bottom | spill pointer − 1 |
//! | pop | top stack not empty | SH load (Top) → RB bottom; release when that drained a borrowed top | Top retreats (or empties, flush count 0); a released stack leaves the ring with rank 0; a drained owner under borrowed stacks takes rank 0 |
//! | pop | then, global holds entries and the oldest stack has room | global load (newest slot) → SH store just below Bottom | Bottom retreats, spill pointer − 1 |
//! | finish | RB not empty | refused | — |
//! | finish | | — | done; with RA its stack turns Idle |
//!
//! A restart design (`+RT`) drops what the table above sends to global memory, and its
//! Overflow bit means "entries were dropped":
//!
//! | command | case | sequence | registers |
//! |---|---|---|---|
//! | push | RB full, M = 0 | — | the oldest RB entry leaves; Overflow |
//! | push | RA, several members: empty the oldest | SH store at its old Top | as the flush, with no global traffic; Overflow |
//! | push | RA, a lone full member | as "otherwise" | its flush count plays no part |
//! | push | otherwise | SH store at Top + 1 | Top and Bottom advance (the oldest entry is gone); Overflow |
//! | pop | RB empty, Overflow | — (answers Restart) | Overflow clears |
//! | pop | RB empty, no Overflow | refused | — |
//! | pop | global reload | never (nothing is in global memory) | — |
//! | finish | Overflow | refused (dropped entries are still owed) | — |

use rtl::config::{Config, Overflow, ShPolicy};
use rtl::logic::Logic;
use rtl::stack_manager::policy::{RbOp, Regfile, Regs, Thread};
use rtl::stack_manager::{CmdOf, SrcOf, StackError, StackRegsOf, UopOf};

/// SPEC 4's skew formula (`docs/stack.md`: `k = max(1, banks / (M · words per entry))`),
/// written from the formula, not from `Config::skew_base`.
pub fn formula_base<L: Logic>(l: &mut L, cfg: &Config, lane: L::Word) -> L::Word {
    let m = cfg.sh_entries;
    if !cfg.skew || m == 0 {
        return l.word(0);
    }
    let k = (cfg.banks * cfg.bank_bytes / (m * cfg.entry_bytes)).max(1);
    let (kw, mw) = (l.word(k), l.word(m));
    let q = l.div(lane, kw);
    l.rem(q, mw)
}

/// The specification's reading of one warp.
pub struct Spec<'a, L: Logic, R: Regfile<L>> {
    pub l: &'a mut L,
    pub rf: &'a mut R,
    pub cfg: &'a Config,
    /// The commanding thread and its warp's first thread.
    pub t: u32,
    pub base: u32,
    pub th: Thread<L>,
}

/// A ring in order from the owner: `(on, stack)` per position.
struct Ring<L: Logic> {
    at: Vec<(L::Bit, L::Word)>,
}

impl<L: Logic, R: Regfile<L>> Spec<'_, L, R> {
    /// Applies `cmd` (`busy`: the sequencer is not idle): the refusal, or the popped entry.
    pub fn apply(&mut self, cmd: CmdOf<L::Val>, busy: L::Bit) -> Result<Option<L::Val>, StackError> {
        let t = self.t;
        if let CmdOf::None = cmd {
            return Ok(None);
        }
        if self.l.decide(busy) {
            return Err(StackError::Busy { thread: t });
        }
        if self.l.decide(self.th.done) {
            return Err(StackError::AfterFinish { thread: t });
        }
        match cmd {
            CmdOf::None => Ok(None),
            CmdOf::Push(v) => self.push(v).map(|_| None),
            CmdOf::Pop => self.pop(),
            CmdOf::Finish => {
                let n = self.rf.rb_len(self.l);
                let zero = self.l.word(0);
                let empty = self.l.eq(n, zero);
                let clean = match self.cfg.overflow {
                    Overflow::Spill => self.l.bit(true),
                    Overflow::Drop => self.l.not(self.th.overflow),
                };
                let empty = self.l.and(empty, clean);
                if !self.l.decide(empty) {
                    return Err(StackError::FinishNonEmpty { thread: t });
                }
                self.th.done = self.l.bit(true);
                if self.cfg.realloc().is_some() {
                    let me = self.l.word(t);
                    let r = self.get(me);
                    let idle = self.l.bit(true);
                    self.put(me, StackRegsOf { idle, ..r });
                }
                Ok(None)
            }
        }
    }

    fn get(&mut self, s: L::Word) -> Regs<L> {
        self.rf.stack(self.l, s)
    }
    fn put(&mut self, s: L::Word, r: Regs<L>) {
        self.rf.set_stack(self.l, s, r)
    }
    fn out(&mut self, u: UopOf<L::Word, L::Val>) {
        let on = self.l.bit(true);
        self.rf.emit(self.l, on, u);
    }
    fn m(&self) -> u32 {
        self.cfg.sh_entries
    }

    /// `(i + k) mod M`, for `i < M`.
    fn step(&mut self, i: L::Word, k: u32) -> L::Word {
        let m = self.m();
        let s = self.l.add_k(i, k % m);
        let mw = self.l.word(m);
        self.l.rem(s, mw)
    }
    /// The entry count: 0 when empty, else `(Top − Bottom) mod M + 1`.
    fn count(&mut self, r: &Regs<L>) -> L::Word {
        let m = self.m();
        let d = self.l.sub(r.top, r.bottom);
        let up = self.l.add_k(d, m);
        let mw = self.l.word(m);
        let span = self.l.rem(up, mw);
        let n = self.l.add_k(span, 1);
        let zero = self.l.word(0);
        self.l.mux(r.empty, zero, n)
    }

    /// The ring of the commanding thread's chain, from its dedicated stack: at most 1 + borrow
    /// limit stacks (SPEC 5), one without reallocation.
    fn ring(&mut self) -> Ring<L> {
        let me = self.l.word(self.t);
        let mut at = vec![(self.l.bit(true), me)];
        let mut s = me;
        let mut on = self.l.bit(true);
        let most = self.cfg.policy.chain_bound().min(self.cfg.warp_size);
        for _ in 1..most {
            let next = self.get(s).next_tid;
            s = self.l.add_k(next, self.base);
            let home = self.l.eq(s, me);
            let away = self.l.not(home);
            on = self.l.and(on, away);
            if !self.l.maybe(on) {
                break;
            }
            at.push((on, s));
        }
        Ring { at }
    }

    fn len(&mut self, ring: &Ring<L>) -> L::Word {
        let mut n = self.l.word(0);
        for &(on, _) in &ring.at {
            let c = self.l.count(on);
            n = self.l.add(n, c);
        }
        n
    }

    /// The member of extreme Priority: highest (`top`) or lowest. Priorities in a chain are
    /// distinct, so which of equals wins is never asked.
    fn extreme(&mut self, ring: &Ring<L>, top: bool) -> L::Word {
        let (_, mut best) = ring.at[0];
        let mut bp = self.get(best).priority;
        for &(on, s) in &ring.at[1..] {
            let p = self.get(s).priority;
            let better = if top { self.l.lt(bp, p) } else { self.l.lt(p, bp) };
            let take = self.l.and(on, better);
            best = self.l.mux(take, s, best);
            bp = self.l.mux(take, p, bp);
        }
        best
    }

    /// Every member other than `s` whose rank lies above `s`'s moves down one; `s` takes
    /// `rank`.
    fn to_top_rank(&mut self, ring: &Ring<L>, s: L::Word, rank: L::Word) {
        let from = self.get(s).priority;
        for &(on, x) in &ring.at {
            let other = self.l.ne(x, s);
            let member = self.l.and(on, other);
            let r = self.get(x);
            let above = self.l.lt(from, r.priority);
            let shift = self.l.and(member, above);
            if !self.l.maybe(shift) {
                continue;
            }
            let down = self.l.sub_k(r.priority, 1);
            let priority = self.l.mux(shift, down, r.priority);
            self.put(x, StackRegsOf { priority, ..r });
        }
        let r = self.get(s);
        self.put(s, StackRegsOf { priority: rank, ..r });
    }

    /// Claims `n` global slots: the first one's index, or a refusal past the region.
    fn claim(&mut self, n: L::Word) -> Result<L::Word, StackError> {
        let limit = (1u32 << self.cfg.spill_ptr_bits.min(31)) - 1;
        let sp = self.th.spill_ptr;
        let room = self.l.word(limit);
        let room = self.l.sub(room, sp);
        let over = self.l.lt(room, n);
        if self.l.decide(over) {
            return Err(StackError::SpillRegionFull { thread: self.t, entries: limit });
        }
        self.th.spill_ptr = self.l.add(sp, n);
        self.th.overflow = self.l.bit(true);
        Ok(sp)
    }

    fn push(&mut self, v: L::Val) -> Result<(), StackError> {
        let full = match self.cfg.rb.capacity() {
            Some(n) => {
                let len = self.rf.rb_len(self.l);
                let nw = self.l.word(n);
                let below = self.l.lt(len, nw);
                let f = self.l.not(below);
                self.l.decide(f)
            }
            None => false,
        };
        if full {
            let oldest = self.rf.rb_front(self.l);
            self.rf.rb(self.l, RbOp::PopFront);
            self.spill(oldest)?;
        }
        self.rf.rb(self.l, RbOp::PushBack(v));
        Ok(())
    }

    fn drops(&self) -> bool {
        self.cfg.overflow == Overflow::Drop
    }

    fn spill(&mut self, v: L::Val) -> Result<(), StackError> {
        let m = self.m();
        if m == 0 && self.drops() {
            self.th.overflow = self.l.bit(true);
            return Ok(());
        }
        if m == 0 {
            let one = self.l.word(1);
            let slot = self.claim(one)?;
            self.out(UopOf::GlobalStore { slot, src: SrcOf::Value(v) });
            return Ok(());
        }
        let ring = self.ring();
        let top = self.extreme(&ring, true);
        let r = self.get(top);
        let n = self.count(&r);
        let room = self.l.lt_k(n, m);
        if self.l.decide(room) {
            let above = self.step(r.top, 1);
            let entry = self.l.mux(r.empty, r.top, above);
            self.out(UopOf::ShStore { stack: top, entry, src: SrcOf::Value(v) });
            let no = self.l.bit(false);
            self.put(top, StackRegsOf { top: entry, empty: no, ..r });
            return Ok(());
        }
        if let Some(ra) = self.cfg.realloc() {
            let len = self.len(&ring);
            let rank = self.l.sub_k(len, 1);
            // The first empty member in ring order.
            let mut found = self.l.bit(false);
            let mut e = top;
            for &(on, s) in &ring.at {
                let r = self.get(s);
                let here = self.l.and(on, r.empty);
                let fresh = self.l.not(found);
                let take = self.l.and(here, fresh);
                e = self.l.mux(take, s, e);
                found = self.l.or(found, take);
            }
            if self.l.decide(found) {
                let r = self.get(e);
                self.out(UopOf::ShStore { stack: e, entry: r.top, src: SrcOf::Value(v) });
                let no = self.l.bit(false);
                self.put(e, StackRegsOf { empty: no, ..r });
                self.to_top_rank(&ring, e, rank);
                return Ok(());
            }
            let short = self.l.lt_k(len, ra.borrow_limit + 1);
            if self.l.decide(short) {
                // The lanes a thread may borrow from: the whole warp with RA; with RA_G the
                // G lanes of its own group.
                let (first, lanes) = match self.cfg.policy {
                    ShPolicy::Group { lanes, .. } => ((self.t - self.base) / lanes * lanes, lanes),
                    _ => (0, self.cfg.warp_size),
                };
                let mut found = self.l.bit(false);
                let mut lane = self.l.word(first);
                for j in first..first + lanes {
                    let s = self.l.word(self.base + j);
                    let idle = self.get(s).idle;
                    let fresh = self.l.not(found);
                    let take = self.l.and(idle, fresh);
                    let jw = self.l.word(j);
                    lane = self.l.mux(take, jw, lane);
                    found = self.l.or(found, take);
                }
                if self.l.decide(found) {
                    let s = self.l.add_k(lane, self.base);
                    let b = formula_base(self.l, self.cfg, lane);
                    self.out(UopOf::ShStore { stack: s, entry: b, src: SrcOf::Value(v) });
                    let me = self.l.word(self.t);
                    let owner = self.get(me);
                    let (no, zero) = (self.l.bit(false), self.l.word(0));
                    self.put(
                        s,
                        StackRegsOf {
                            top: b,
                            bottom: b,
                            empty: no,
                            idle: no,
                            next_tid: owner.next_tid,
                            priority: len,
                            flush: zero,
                        },
                    );
                    self.put(me, StackRegsOf { next_tid: lane, ..owner });
                    return Ok(());
                }
            }
            let oldest = self.extreme(&ring, false);
            let r = self.get(oldest);
            let one = self.l.word(1);
            let several = self.l.lt(one, len);
            let fresh = self.l.lt_k(r.flush, ra.flush_limit);
            let lone_flush = if self.drops() { self.l.bit(false) } else { fresh };
            let flush = self.l.or(several, lone_flush);
            if self.l.decide(flush) {
                let n = self.count(&r);
                let first = if self.drops() {
                    self.th.overflow = self.l.bit(true);
                    self.l.word(0)
                } else {
                    self.claim(n)?
                };
                for i in 0..m {
                    if self.drops() {
                        break;
                    }
                    let iw = self.l.word(i);
                    let live = self.l.lt(iw, n);
                    if !self.l.maybe(live) {
                        break;
                    }
                    let entry = self.step(r.bottom, i);
                    let slot = self.l.add(first, iw);
                    self.rf.emit(self.l, live, UopOf::ShLoad { stack: oldest, entry });
                    self.rf.emit(self.l, live, UopOf::GlobalStore { slot, src: SrcOf::Latch });
                }
                self.out(UopOf::ShStore { stack: oldest, entry: r.top, src: SrcOf::Value(v) });
                let up = self.l.add_k(r.flush, 1);
                let count = self.l.mux(fresh, up, r.flush);
                let no = self.l.bit(false);
                self.put(oldest, StackRegsOf { bottom: r.top, empty: no, flush: count, ..r });
                self.to_top_rank(&ring, oldest, rank);
                return Ok(());
            }
        }
        // SPEC 3, push case 3.
        let r = self.get(top);
        if self.drops() {
            self.th.overflow = self.l.bit(true);
        } else {
            let one = self.l.word(1);
            let slot = self.claim(one)?;
            self.out(UopOf::ShLoad { stack: top, entry: r.bottom });
            self.out(UopOf::GlobalStore { slot, src: SrcOf::Latch });
        }
        let entry = self.step(r.top, 1);
        self.out(UopOf::ShStore { stack: top, entry, src: SrcOf::Value(v) });
        let bottom = self.step(r.bottom, 1);
        self.put(top, StackRegsOf { top: entry, bottom, ..r });
        Ok(())
    }

    /// Frees the newest global slot: its index.
    fn unclaim(&mut self) -> L::Word {
        let sp = self.l.sub_k(self.th.spill_ptr, 1);
        self.th.spill_ptr = sp;
        let zero = self.l.word(0);
        self.th.overflow = self.l.lt(zero, sp);
        sp
    }

    fn pop(&mut self) -> Result<Option<L::Val>, StackError> {
        let len = self.rf.rb_len(self.l);
        let none = self.l.eq_k(len, 0);
        if self.l.decide(none) {
            if self.drops() && self.l.decide(self.th.overflow) {
                self.th.overflow = self.l.bit(false);
                return Ok(None);
            }
            return Err(StackError::PopEmpty { thread: self.t });
        }
        let v = self.rf.rb_back(self.l);
        self.rf.rb(self.l, RbOp::PopBack);
        let zero = self.l.word(0);
        let global = self.l.lt(zero, self.th.spill_ptr);
        let m = self.m();
        if m == 0 {
            if self.l.decide(global) {
                let slot = self.unclaim();
                self.out(UopOf::GlobalLoad { slot });
                self.out(UopOf::RbBottom);
            }
            return Ok(Some(v));
        }
        let ring = self.ring();
        let top = self.extreme(&ring, true);
        let r = self.get(top);
        let n = self.count(&r);
        let holds = self.l.lt(zero, n);
        if self.l.decide(holds) {
            self.out(UopOf::ShLoad { stack: top, entry: r.top });
            self.out(UopOf::RbBottom);
            let last = self.l.eq_k(n, 1);
            if self.l.decide(last) {
                let yes = self.l.bit(true);
                let zero = self.l.word(0);
                self.put(top, StackRegsOf { empty: yes, flush: zero, ..r });
                let size = self.len(&ring);
                let one = self.l.word(1);
                let several = self.l.lt(one, size);
                if self.l.decide(several) {
                    let me = self.l.word(self.t);
                    let own = self.l.eq(top, me);
                    if !self.l.decide(own) {
                        self.out(UopOf::Release { stack: top });
                        // The member pointing at the released stack skips it.
                        let lane = self.l.sub_k(top, self.base);
                        for &(on, s) in &ring.at {
                            let x = self.get(s);
                            let points = self.l.eq(x.next_tid, lane);
                            let pred = self.l.and(on, points);
                            if !self.l.maybe(pred) {
                                continue;
                            }
                            let after = self.get(top).next_tid;
                            let next_tid = self.l.mux(pred, after, x.next_tid);
                            self.put(s, StackRegsOf { next_tid, ..x });
                        }
                        let x = self.get(top);
                        let zero = self.l.word(0);
                        self.put(top, StackRegsOf { next_tid: lane, priority: zero, ..x });
                    } else {
                        // Demotion: the drained owner takes rank 0, the ranks below it move up.
                        let from = self.get(me).priority;
                        for &(on, s) in &ring.at {
                            let other = self.l.ne(s, me);
                            let member = self.l.and(on, other);
                            let x = self.get(s);
                            let below = self.l.lt(x.priority, from);
                            let shift = self.l.and(member, below);
                            if !self.l.maybe(shift) {
                                continue;
                            }
                            let up = self.l.add_k(x.priority, 1);
                            let priority = self.l.mux(shift, up, x.priority);
                            self.put(s, StackRegsOf { priority, ..x });
                        }
                        let x = self.get(me);
                        let zero = self.l.word(0);
                        self.put(me, StackRegsOf { priority: zero, ..x });
                    }
                }
            } else {
                let down = self.step(r.top, m - 1);
                self.put(top, StackRegsOf { top: down, ..r });
            }
        }
        if self.l.decide(global) {
            let ring = self.ring();
            let oldest = self.extreme(&ring, false);
            let r = self.get(oldest);
            let n = self.count(&r);
            let room = self.l.lt_k(n, m);
            if self.l.decide(room) {
                let slot = self.unclaim();
                let below = self.step(r.bottom, m - 1);
                let entry = self.l.mux(r.empty, r.bottom, below);
                self.out(UopOf::GlobalLoad { slot });
                self.out(UopOf::ShStore { stack: oldest, entry, src: SrcOf::Latch });
                let no = self.l.bit(false);
                self.put(oldest, StackRegsOf { bottom: entry, empty: no, ..r });
            }
        }
        Ok(Some(v))
    }
}
