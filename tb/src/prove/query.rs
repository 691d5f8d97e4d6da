//! One-step equivalence queries: for every register state of a warp satisfying the
//! well-formedness invariant ([`well_formed`]), the design's policy ([`rtl::stack_manager::policy`])
//! and the specification ([`super::spec`]) give the same answer, micro-op program, thread
//! registers, RB length and stack registers of every lane, for one cycle's commands.
//!
//! Both sides run on the same symbolic state ([`SymWarp`]); each side's paths are merged under
//! their path conditions into one output, and the solver is asked for a state where the outputs
//! differ.

use rtl::config::{Config, Overflow};
use rtl::logic::Logic;
use rtl::stack_manager::policy::{Plan, RbOp, Regfile, Regs, Steps, Thread, UopL};
use rtl::stack_manager::{CmdOf, SrcOf, StackError, StackRegsOf, StackStats, ThreadRegsOf, UopOf};

use super::spec::Spec;
use super::sym::{Sym, B, V, W};

/// The kind of a command in a query (its push value is symbolic).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Kind {
    Push,
    Pop,
    Finish,
}

impl Kind {
    pub fn name(self) -> &'static str {
        match self {
            Kind::Push => "push",
            Kind::Pop => "pop",
            Kind::Finish => "finish",
        }
    }
}

/// One commanding lane of a query: its lane, command, and symbolic thread state.
#[derive(Clone, Copy, Debug)]
pub struct LaneIn {
    pub lane: u32,
    pub kind: Kind,
    pub th: Thread<Sym>,
    pub busy: B,
    pub rb_len: W,
    pub rb_front: V,
    pub rb_back: V,
    pub value: V,
}

/// The symbolic state of one warp: every lane's stack registers and done bit, and the
/// commanding lanes' thread registers.
pub struct State {
    pub base: u32,
    pub regs: Vec<Regs<Sym>>,
    pub done: Vec<B>,
    pub lanes: Vec<LaneIn>,
}

/// A stack's registers as fresh variables named `top_{tag}`, `bottom_{tag}`, ….
pub fn sym_stack(s: &mut Sym, tag: &str) -> Regs<Sym> {
    StackRegsOf {
        top: s.var_word(&format!("top_{tag}")),
        bottom: s.var_word(&format!("bottom_{tag}")),
        empty: s.var_bit(&format!("empty_{tag}")),
        idle: s.var_bit(&format!("idle_{tag}")),
        next_tid: s.var_word(&format!("next_tid_{tag}")),
        priority: s.var_word(&format!("priority_{tag}")),
        flush: s.var_word(&format!("flush_{tag}")),
    }
}

impl State {
    /// Fresh variables for a warp starting at thread `base` whose lanes `cmds` command.
    pub fn new(s: &mut Sym, cfg: &Config, base: u32, cmds: &[(u32, Kind)]) -> State {
        let ws = cfg.warp_size;
        let regs = (0..ws).map(|j| sym_stack(s, &j.to_string())).collect();
        let done = (0..ws).map(|j| s.var_bit(&format!("done_{j}"))).collect::<Vec<_>>();
        let lanes = cmds
            .iter()
            .map(|&(lane, kind)| LaneIn {
                lane,
                kind,
                th: ThreadRegsOf {
                    overflow: s.var_bit(&format!("overflow_{lane}")),
                    spill_ptr: s.var_word(&format!("spill_ptr_{lane}")),
                    done: done[lane as usize],
                },
                busy: s.var_bit(&format!("busy_{lane}")),
                rb_len: s.var_word(&format!("rb_len_{lane}")),
                rb_front: s.var_val(&format!("rb_front_{lane}")),
                rb_back: s.var_val(&format!("rb_back_{lane}")),
                value: s.var_val(&format!("push_value_{lane}")),
            })
            .collect();
        State { base, regs, done, lanes }
    }
}

/// The well-formedness invariant the equivalence assumes, over any [`Logic`] (the simulator's
/// reachable states satisfy it: a test checks that on random runs).
///
/// Every lane: Top and Bottom below M, an empty queue has Top = Bottom, Next TID names a lane;
/// with reallocation Priority ≤ borrow limit, Priority 0 when alone on its ring, Flush ≤ flush
/// limit, and an Idle stack is a
/// finished thread's empty stack alone on its ring with rank and count 0; without it, no stack is
/// Idle or linked. Every commanding lane: RB length ≤ N; Overflow exactly when the spill pointer
/// is above 0, which is at most the region's size; its ring returns to it within 1 + borrow limit
/// steps; the ring's ranks are distinct and below its length; its other members are finished and
/// not Idle; it is not Idle unless finished. Between an unfinished lane's commands (its
/// sequencer idle, `busy` false): with room in its RB its stack is empty and alone and nothing
/// is in global memory (entries fill the RB first, and every pop refills it from below before
/// the thread is ready again); a borrowed stack below the top of its ring holds entries; the
/// top is empty only on a ring of one; an empty member's Flush is 0.
pub fn well_formed<L: Logic>(
    l: &mut L,
    cfg: &Config,
    regs: &[Regs<L>],
    done: &[L::Bit],
    lanes: &[(u32, Thread<L>, L::Word, L::Bit)],
) -> L::Bit {
    let parts = well_formed_parts(l, cfg, regs, done, lanes);
    parts.into_iter().fold(l.bit(true), |ok, p| l.and(ok, p.1))
}

/// Which registers a clause of [`well_formed_parts`] is about.
#[derive(Clone, Copy)]
enum Who {
    Stack(u32),
    Lane(u32),
}

fn need<B>(parts: &mut Vec<(String, B)>, who: Who, what: &str, b: B) {
    let name = match who {
        Who::Stack(j) => format!("stack of lane {j}: {what}"),
        Who::Lane(n) => format!("lane {n}: {what}"),
    };
    parts.push((name, b));
}

/// [`well_formed`] clause by clause, each named (for a counterexample's report): every stack's
/// registers, then each lane's RB, thread registers and ring.
pub fn well_formed_parts<L: Logic>(
    l: &mut L,
    cfg: &Config,
    regs: &[Regs<L>],
    done: &[L::Bit],
    lanes: &[(u32, Thread<L>, L::Word, L::Bit)],
) -> Vec<(String, L::Bit)> {
    let mut parts: Vec<(String, L::Bit)> = Vec::new();
    for (j, r) in regs.iter().enumerate() {
        stack_parts(l, cfg, j, r, done, &mut parts);
    }
    for &(lane, th, rb_len, busy) in lanes {
        rb_parts(l, cfg, regs, (lane, th, rb_len, busy), &mut parts);
        thread_parts(l, cfg, done, lane, th, &mut parts);
        ring_parts(l, cfg, regs, done, (lane, th, busy), &mut parts);
    }
    parts
}

/// The clauses on stack `j`'s own registers: Top and Bottom in range, Next TID a lane, and
/// Priority, Flush and Idle as reallocation (or its absence) allows.
fn stack_parts<L: Logic>(
    l: &mut L,
    cfg: &Config,
    j: usize,
    r: &Regs<L>,
    done: &[L::Bit],
    parts: &mut Vec<(String, L::Bit)>,
) {
    let m = cfg.sh_entries;
    let ws = cfg.warp_size;
    let who = Who::Stack(j as u32);
    let jw = l.word(j as u32);
    if m > 0 {
        let a = l.lt_k(r.top, m);
        need(parts, who, "Top below M", a);
        let b = l.lt_k(r.bottom, m);
        need(parts, who, "Bottom below M", b);
        let same = l.eq(r.top, r.bottom);
        let full_or_same = implies(l, r.empty, same);
        need(parts, who, "an empty queue has Top = Bottom", full_or_same);
    }
    let n = l.lt_k(r.next_tid, ws);
    need(parts, who, "Next TID names a lane", n);
    let alone = l.eq(r.next_tid, jw);
    let rank0 = l.eq_k(r.priority, 0);
    let count0 = l.eq_k(r.flush, 0);
    match cfg.realloc() {
        Some(ra) => {
            let p = l.lt_k(r.priority, cfg.policy.chain_bound());
            need(parts, who, "Priority within the borrow limit", p);
            let f = l.lt_k(r.flush, ra.flush_limit + 1);
            need(parts, who, "Flush within its limit", f);
            let ranked = implies(l, alone, rank0);
            need(parts, who, "a stack alone on its ring has Priority 0", ranked);
            let a = l.and(done[j], alone);
            let b = l.and(r.empty, rank0);
            let c = l.and(a, b);
            let idle_ok = l.and(c, count0);
            let not_idle = l_not(l, r.idle);
            let imp = l.or(not_idle, idle_ok);
            need(
                parts,
                who,
                "an Idle stack is a finished thread's empty stack, alone, rank and Flush 0",
                imp,
            );
        }
        None => {
            let not_idle = l_not(l, r.idle);
            need(parts, who, "no stack Idle without reallocation", not_idle);
            need(parts, who, "no chains without reallocation", alone);
            need(parts, who, "Priority 0 without reallocation", rank0);
            need(parts, who, "Flush 0 without reallocation", count0);
        }
    }
}

/// The clauses on `lane`'s RB: its length within N and, quiescent with room, nothing below it.
fn rb_parts<L: Logic>(
    l: &mut L,
    cfg: &Config,
    regs: &[Regs<L>],
    (lane, th, rb_len, busy): (u32, Thread<L>, L::Word, L::Bit),
    parts: &mut Vec<(String, L::Bit)>,
) {
    let m = cfg.sh_entries;
    let who = Who::Lane(lane);
    if let Some(n) = cfg.rb.capacity() {
        let a = l.lt_k(rb_len, n + 1);
        need(parts, who, "RB length at most N", a);
        // Quiescent with room in the RB: nothing below it.
        let room = l.lt_k(rb_len, n);
        let idle = l.not(busy);
        let quiet = l.and(room, idle);
        let live = l.not(th.done);
        let quiet = l.and(quiet, live);
        let own = regs[lane as usize];
        // A restart design's Overflow bit stays set, entries owed, while pops drain it.
        let mut below = match cfg.overflow {
            Overflow::Spill => l.not(th.overflow),
            Overflow::Drop => l.bit(true),
        };
        if m > 0 {
            let me = l.word(lane);
            let alone = l.eq(own.next_tid, me);
            let e = l.and(own.empty, alone);
            below = l.and(below, e);
        }
        let imp = implies(l, quiet, below);
        let what = match cfg.overflow {
            Overflow::Spill => "quiescent with room in the RB: stack empty and alone, no overflow",
            Overflow::Drop => "quiescent with room in the RB: stack empty and alone",
        };
        need(parts, who, what, imp);
    }
}

/// The clauses on `lane`'s thread registers: Overflow and the spill pointer agree and stay in
/// range, and the done bit agrees with the warp's.
fn thread_parts<L: Logic>(
    l: &mut L,
    cfg: &Config,
    done: &[L::Bit],
    lane: u32,
    th: Thread<L>,
    parts: &mut Vec<(String, L::Bit)>,
) {
    let who = Who::Lane(lane);
    let limit = (1u32 << cfg.spill_ptr_bits.min(31)) - 1;
    let zero = l.word(0);
    match cfg.overflow {
        Overflow::Spill => {
            let some = l.lt(zero, th.spill_ptr);
            let same = eq_bit(l, some, th.overflow);
            need(parts, who, "Overflow exactly when the spill pointer is above 0", same);
        }
        Overflow::Drop => {
            let none = l.eq(th.spill_ptr, zero);
            need(parts, who, "no global region in a restart design: spill pointer 0", none);
        }
    }
    let sp = l.lt_k(th.spill_ptr, limit + 1);
    need(parts, who, "spill pointer within its region", sp);
    let d = eq_bit(l, th.done, done[lane as usize]);
    need(parts, who, "done bit agrees", d);
}

/// The clauses on `lane`'s ring: its own stack not Idle unless finished, the ring home within
/// 1 + borrow limit steps, its members' ranks, and (between commands) which members may be
/// empty.
fn ring_parts<L: Logic>(
    l: &mut L,
    cfg: &Config,
    regs: &[Regs<L>],
    done: &[L::Bit],
    (lane, th, busy): (u32, Thread<L>, L::Bit),
    parts: &mut Vec<(String, L::Bit)>,
) {
    let m = cfg.sh_entries;
    let ws = cfg.warp_size;
    let max_ring = cfg.policy.chain_bound() as usize;
    let who = Who::Lane(lane);
    let me = l.word(lane);
    let own = regs[lane as usize];
    let not_idle = l_not(l, own.idle);
    let a = l.or(th.done, not_idle);
    need(parts, who, "not Idle unless finished", a);
    // Walk the ring: `ids[k]` is the lane k steps along; it must come home within max_ring.
    let mut ids = vec![me];
    let mut home = l.bit(false);
    let mut len = l.word(0);
    let mut cur = me;
    for k in 1..=max_ring.min(ws as usize) {
        let next = select(l, regs, cur, |r| r.next_tid);
        let back = l.eq(next, me);
        let fresh = l_not(l, home);
        let now = l.and(back, fresh);
        let kw = l.word(k as u32);
        len = l.mux(now, kw, len);
        home = l.or(home, now);
        ids.push(next);
        cur = next;
    }
    let r = l.or(home, th.done);
    need(parts, who, "ring returns home within 1 + borrow limit", r);
    // Members (positions below len): ranks distinct and below len; others finished, not Idle.
    for (k, &x) in ids.iter().enumerate().take(max_ring) {
        let kw = l.word(k as u32);
        let member = l.lt(kw, len);
        let p = select(l, regs, x, |r| r.priority);
        let below = l.lt(p, len);
        let imp = implies(l, member, below);
        let held = l.or(imp, th.done);
        need(parts, who, "ring ranks below its length", held);
        if k > 0 {
            let fin = select_bit(l, done, x);
            let idle = select_idle(l, regs, x);
            let awake = l.not(idle);
            let good = l.and(fin, awake);
            let imp = implies(l, member, good);
            let held = l.or(imp, th.done);
            need(parts, who, "ring members finished and not Idle", held);
        }
        for &y in ids.iter().take(k) {
            let q = select(l, regs, y, |r| r.priority);
            let distinct = l.ne(p, q);
            let imp = implies(l, member, distinct);
            let held = l.or(imp, th.done);
            need(parts, who, "ring ranks distinct", held);
        }
        if m > 0 {
            // Between the owner's commands (its sequencer idle): a borrowed stack below the
            // top holds entries (a drained one is released at once), the top is empty only
            // on a ring of one (a drained dedicated stack moves to the bottom), and an
            // empty member's Flush is 0.
            let quiet = l.not(busy);
            let live = l.not(th.done);
            let quiet = l.and(quiet, live);
            let here = l.and(quiet, member);
            let e = select_flag(l, regs, x, |r| r.empty);
            let top_rank = l.sub_k(len, 1);
            let top = l.eq(p, top_rank);
            let full = l.not(e);
            if k > 0 {
                let not_top = l.not(top);
                let c = l.and(here, not_top);
                let imp = implies(l, c, full);
                need(parts, who, "quiescent: a borrowed stack below the top holds entries", imp);
            }
            let c = l.and(here, top);
            let c = l.and(c, e);
            let one = l.eq_k(len, 1);
            let imp = implies(l, c, one);
            need(parts, who, "quiescent: the top is empty only on a ring of one", imp);
            if cfg.realloc().is_some() {
                let c = l.and(here, e);
                let f = select(l, regs, x, |r| r.flush);
                let zero = l.eq_k(f, 0);
                let imp = implies(l, c, zero);
                need(parts, who, "quiescent: an empty member's Flush is 0", imp);
            }
        }
    }
}

fn l_not<L: Logic>(l: &mut L, b: L::Bit) -> L::Bit {
    l.not(b)
}

pub(super) fn implies<L: Logic>(l: &mut L, a: L::Bit, b: L::Bit) -> L::Bit {
    let na = l.not(a);
    l.or(na, b)
}

pub(super) fn eq_bit<L: Logic>(l: &mut L, a: L::Bit, b: L::Bit) -> L::Bit {
    let nb = l.not(b);
    l.mux_bit(a, b, nb)
}

/// Field `f` of the lane `lane` names (a multiplexer over the warp).
pub(super) fn select<L: Logic>(
    l: &mut L,
    regs: &[Regs<L>],
    lane: L::Word,
    f: impl Fn(&Regs<L>) -> L::Word,
) -> L::Word {
    let mut v = f(&regs[regs.len() - 1]);
    for j in (0..regs.len() - 1).rev() {
        let hit = l.eq_k(lane, j as u32);
        v = l.mux(hit, f(&regs[j]), v);
    }
    v
}

fn select_idle<L: Logic>(l: &mut L, regs: &[Regs<L>], lane: L::Word) -> L::Bit {
    select_flag(l, regs, lane, |r| r.idle)
}

/// Bit `f` of the lane `lane` names (a multiplexer over the warp).
pub(super) fn select_flag<L: Logic>(
    l: &mut L,
    regs: &[Regs<L>],
    lane: L::Word,
    f: impl Fn(&Regs<L>) -> L::Bit,
) -> L::Bit {
    let mut v = f(&regs[regs.len() - 1]);
    for j in (0..regs.len() - 1).rev() {
        let hit = l.eq_k(lane, j as u32);
        v = l.mux_bit(hit, f(&regs[j]), v);
    }
    v
}

fn select_bit<L: Logic>(l: &mut L, bits: &[L::Bit], lane: L::Word) -> L::Bit {
    let mut v = bits[bits.len() - 1];
    for j in (0..bits.len() - 1).rev() {
        let hit = l.eq_k(lane, j as u32);
        v = l.mux_bit(hit, bits[j], v);
    }
    v
}

/// The symbolic register file both sides plan against: one plan's working copy of the
/// registers (`work`, from the cycle's registers so far), the registers as the cycle began
/// (`q`), and what the plan emitted.
pub struct SymWarp<'a> {
    pub base: u32,
    pub q: &'a [Regs<Sym>],
    pub work: Vec<Regs<Sym>>,
    pub done: &'a [B],
    pub lane: LaneIn,
    pub prog: Vec<(B, UopL<Sym>)>,
    pub rb_len: W,
    /// The plan's changes to the RB, in order (conservation follows an entry through them).
    pub rb_log: Vec<RbOp<V>>,
}

impl SymWarp<'_> {
    fn pick(&self, l: &mut Sym, arr: &[Regs<Sym>], s: W) -> Regs<Sym> {
        let base = self.base;
        let mut v = arr[arr.len() - 1];
        for j in (0..arr.len() - 1).rev() {
            let hit = l.eq_k(s, base + j as u32);
            v = StackRegsOf::mux(l, hit, arr[j], v);
        }
        v
    }
}

impl Regfile<Sym> for SymWarp<'_> {
    fn stack(&mut self, l: &mut Sym, s: W) -> Regs<Sym> {
        let arr = std::mem::take(&mut self.work);
        let v = self.pick(l, &arr, s);
        self.work = arr;
        v
    }
    fn stack_q(&mut self, l: &mut Sym, s: W) -> Regs<Sym> {
        self.pick(l, self.q, s)
    }
    fn set_stack(&mut self, l: &mut Sym, s: W, r: Regs<Sym>) {
        for j in 0..self.work.len() {
            let hit = l.eq_k(s, self.base + j as u32);
            if l.maybe(hit) {
                self.work[j] = StackRegsOf::mux(l, hit, r, self.work[j]);
            }
        }
    }
    fn done(&mut self, l: &mut Sym, s: W) -> B {
        let mut v = self.done[self.done.len() - 1];
        for j in (0..self.done.len() - 1).rev() {
            let hit = l.eq_k(s, self.base + j as u32);
            v = l.mux_bit(hit, self.done[j], v);
        }
        v
    }
    fn rb_len(&mut self, _: &mut Sym) -> W {
        self.lane.rb_len
    }
    fn rb_front(&mut self, _: &mut Sym) -> V {
        self.lane.rb_front
    }
    fn rb_back(&mut self, _: &mut Sym) -> V {
        self.lane.rb_back
    }
    fn rb(&mut self, l: &mut Sym, op: RbOp<V>) {
        self.rb_log.push(op);
        self.rb_len = match op {
            RbOp::PushBack(_) => l.add_k(self.rb_len, 1),
            RbOp::PopFront | RbOp::PopBack => l.sub_k(self.rb_len, 1),
        };
    }
    fn emit(&mut self, _: &mut Sym, valid: B, u: UopL<Sym>) {
        self.prog.push((valid, u));
    }
}

/// A micro-op as words: kind (its waveform code), first field (stack or slot), entry, whether
/// its data comes from the latch, and its immediate value.
#[derive(Clone, Copy, Debug)]
pub struct Enc {
    pub kind: W,
    pub a: W,
    pub b: W,
    pub latch: B,
    pub value: V,
}

/// [`Enc::kind`] codes.
pub mod code {
    pub const SH_LOAD: u32 = 1;
    pub const SH_STORE: u32 = 2;
    pub const GLOBAL_LOAD: u32 = 3;
    pub const GLOBAL_STORE: u32 = 4;
    pub const RB_BOTTOM: u32 = 5;
    pub const RELEASE: u32 = 6;
}

pub fn encode(l: &mut Sym, u: &UopL<Sym>) -> Enc {
    let z = l.word(0);
    let no = l.bit(false);
    let zv = l.val(0);
    let src = |l: &mut Sym, s: &SrcOf<V>| match *s {
        SrcOf::Value(v) => (l.bit(false), v),
        SrcOf::Latch => (l.bit(true), l.val(0)),
    };
    let (kind, a, b, (latch, value)) = match u {
        UopOf::ShLoad { stack, entry } => (code::SH_LOAD, *stack, *entry, (no, zv)),
        UopOf::ShStore { stack, entry, src: s } => (code::SH_STORE, *stack, *entry, src(l, s)),
        UopOf::GlobalLoad { slot } => (code::GLOBAL_LOAD, *slot, z, (no, zv)),
        UopOf::GlobalStore { slot, src: s } => (code::GLOBAL_STORE, *slot, z, src(l, s)),
        UopOf::RbBottom => (code::RB_BOTTOM, z, z, (no, zv)),
        UopOf::Release { stack } => (code::RELEASE, *stack, z, (no, zv)),
    };
    let kind = l.word(kind);
    Enc { kind, a, b, latch, value }
}

pub fn mux_enc(l: &mut Sym, c: B, x: Enc, y: Enc) -> Enc {
    Enc {
        kind: l.mux(c, x.kind, y.kind),
        a: l.mux(c, x.a, y.a),
        b: l.mux(c, x.b, y.b),
        latch: l.mux_bit(c, x.latch, y.latch),
        value: l.mux_val(c, x.value, y.value),
    }
}

/// The program as `slots` fixed positions: `(valid, micro-op)`, valid ones first.
pub fn compact(l: &mut Sym, prog: &[(B, UopL<Sym>)], slots: usize) -> Vec<(B, Enc)> {
    let none = no_uop(l);
    let mut out = vec![(l.bit(false), none); slots];
    let mut pos = l.word(0);
    let enc: Vec<(B, Enc)> = prog.iter().map(|(g, u)| (*g, encode(l, u))).collect();
    for (g, e) in enc {
        for (k, slot) in out.iter_mut().enumerate() {
            place(l, slot, g, pos, k as u32, e);
        }
        let one = l.count(g);
        pos = l.add(pos, one);
    }
    out
}

/// The encoding of an empty program slot (every field zero).
pub fn no_uop(l: &mut Sym) -> Enc {
    let (z, no, zv) = (l.word(0), l.bit(false), l.val(0));
    Enc { kind: z, a: z, b: z, latch: no, value: zv }
}

/// Puts micro-op `e`, valid under `g`, in `slot` (number `k`) where its position `pos` is `k`;
/// nothing where that cannot hold.
pub fn place(l: &mut Sym, slot: &mut (B, Enc), g: B, pos: W, k: u32, e: Enc) {
    let at = l.eq_k(pos, k);
    let here = l.and(g, at);
    if l.maybe(here) {
        slot.0 = l.or(slot.0, here);
        slot.1 = mux_enc(l, here, e, slot.1);
    }
}

/// What a plan did to the RB: which of its changes happened (each at most once per plan), and
/// the entry pushed.
#[derive(Clone, Copy, Debug)]
pub(super) struct RbChange {
    pub pop_back: B,
    pub pop_front: B,
    pub push_back: B,
    pub pushed: V,
}

impl RbChange {
    fn of(l: &mut Sym, log: &[RbOp<V>]) -> RbChange {
        let has = |l: &mut Sym, f: &dyn Fn(&RbOp<V>) -> bool| l.bit(log.iter().any(f));
        let pushed = log
            .iter()
            .find_map(|o| match o {
                RbOp::PushBack(v) => Some(*v),
                _ => None,
            })
            .unwrap_or_else(|| l.val(0));
        RbChange {
            pop_back: has(l, &|o| matches!(o, RbOp::PopBack)),
            pop_front: has(l, &|o| matches!(o, RbOp::PopFront)),
            push_back: has(l, &|o| matches!(o, RbOp::PushBack(_))),
            pushed,
        }
    }

    fn mux(l: &mut Sym, c: B, x: RbChange, y: RbChange) -> RbChange {
        RbChange {
            pop_back: l.mux_bit(c, x.pop_back, y.pop_back),
            pop_front: l.mux_bit(c, x.pop_front, y.pop_front),
            push_back: l.mux_bit(c, x.push_back, y.push_back),
            pushed: l.mux_val(c, x.pushed, y.pushed),
        }
    }
}

/// One lane's answer in one cycle.
#[derive(Clone, Debug)]
pub(super) struct Answer {
    /// 0: accepted, nothing returned; 1: accepted, popped `value`; 2 + k: refused with the
    /// k-th kind of [`StackError`].
    pub code: W,
    pub value: V,
    pub prog: Vec<(B, Enc)>,
    pub th: Thread<Sym>,
    pub rb_len: W,
    pub rb: RbChange,
}

/// A side's whole cycle: every lane's answer and every stack's registers after it.
#[derive(Clone, Debug)]
pub(super) struct Cycle {
    pub lanes: Vec<Answer>,
    pub regs: Vec<Regs<Sym>>,
}

pub(super) fn error_code(e: &StackError) -> u32 {
    2 + match e {
        StackError::PopEmpty { .. } => 0,
        StackError::FinishNonEmpty { .. } => 1,
        StackError::Busy { .. } => 2,
        StackError::AfterFinish { .. } => 3,
        StackError::SpillRegionFull { .. } => 4,
        StackError::Overflow { .. } => 5,
        StackError::OutOfRange { .. } => 6,
    }
}

/// Which description plans the commands.
pub enum Side<'a, P: Steps> {
    Design(&'a P),
    Spec,
}

/// Runs one side, lane by lane in the cycle's order: each lane's plan over every path, its
/// paths' outputs and registers merged under their conditions before the next lane plans (so
/// the paths of two lanes add, not multiply).
pub(super) fn side<P: Steps>(s: &mut Sym, cfg: &Config, st: &State, which: &Side<P>, slots: usize) -> Cycle {
    let mut now = st.regs.clone();
    let mut lanes = Vec::new();
    for lane in &st.lanes {
        let paths = s.explore(|l| {
            let t = st.base + lane.lane;
            let cmd = match lane.kind {
                Kind::Push => CmdOf::Push(lane.value),
                Kind::Pop => CmdOf::Pop,
                Kind::Finish => CmdOf::Finish,
            };
            let mut rf = SymWarp {
                base: st.base,
                q: &st.regs,
                work: now.clone(),
                done: &st.done,
                lane: *lane,
                prog: Vec::new(),
                rb_len: lane.rb_len,
                rb_log: Vec::new(),
            };
            let (r, th) = match which {
                Side::Design(steps) => {
                    let mut p = Plan {
                        l: &mut *l,
                        steps: *steps,
                        rf: &mut rf,
                        cfg,
                        t,
                        base: st.base,
                        th: lane.th,
                        stats: StackStats::default(),
                    };
                    let r = p.run(cmd, lane.busy);
                    (r, p.th)
                }
                Side::Spec => {
                    let mut p = Spec { l: &mut *l, rf: &mut rf, cfg, t, base: st.base, th: lane.th };
                    let r = p.apply(cmd, lane.busy);
                    (r, p.th)
                }
            };
            let zv = l.val(0);
            let (code, value, accepted) = match r {
                Ok(None) => (0, zv, true),
                Ok(Some(v)) => (1, v, true),
                Err(e) => (error_code(&e), zv, false),
            };
            let code = l.word(code);
            // A refused command changes nothing.
            if accepted {
                let prog = compact(l, &rf.prog, slots);
                let rb = RbChange::of(l, &rf.rb_log);
                (Answer { code, value, prog, th, rb_len: rf.rb_len, rb }, rf.work)
            } else {
                let prog = compact(l, &[], slots);
                let rb = RbChange::of(l, &[]);
                (Answer { code, value, prog, th: lane.th, rb_len: lane.rb_len, rb }, now.clone())
            }
        });
        let mut it = paths.into_iter().rev();
        let (_, (mut a, mut regs)) = it.next().expect("at least one path");
        for (c, (x, xr)) in it {
            a.code = s.mux(c, x.code, a.code);
            a.value = s.mux_val(c, x.value, a.value);
            for (sa, sx) in a.prog.iter_mut().zip(&x.prog) {
                sa.0 = s.mux_bit(c, sx.0, sa.0);
                sa.1 = mux_enc(s, c, sx.1, sa.1);
            }
            a.th = ThreadRegsOf::mux(s, c, x.th, a.th);
            a.rb_len = s.mux(c, x.rb_len, a.rb_len);
            a.rb = RbChange::mux(s, c, x.rb, a.rb);
            for (ra, rx) in regs.iter_mut().zip(&xr) {
                *ra = StackRegsOf::mux(s, c, *rx, *ra);
            }
        }
        lanes.push(a);
        now = regs;
    }
    Cycle { lanes, regs: now }
}

/// What the two sides must agree on, and the names of the parts (for a counterexample's
/// report): a list of `(what, equal)`.
fn agreement(s: &mut Sym, d: &Cycle, sp: &Cycle, lanes: &[LaneIn]) -> Vec<(String, B)> {
    let mut parts = Vec::new();
    for ((a, b), lane) in d.lanes.iter().zip(&sp.lanes).zip(lanes) {
        let n = lane.lane;
        let code = s.eq(a.code, b.code);
        parts.push((format!("lane {n}: answer"), code));
        let value = s.eq_val(a.value, b.value);
        parts.push((format!("lane {n}: popped entry"), value));
        let mut prog = s.bit(true);
        for (x, y) in a.prog.iter().zip(&b.prog) {
            let v = eq_bit(s, x.0, y.0);
            let fields = {
                let k = s.eq(x.1.kind, y.1.kind);
                let f1 = s.eq(x.1.a, y.1.a);
                let f2 = s.eq(x.1.b, y.1.b);
                let f3 = eq_bit(s, x.1.latch, y.1.latch);
                let f4 = s.eq_val(x.1.value, y.1.value);
                let all = s.and(k, f1);
                let all = s.and(all, f2);
                let all = s.and(all, f3);
                s.and(all, f4)
            };
            let nv = s.not(x.0);
            let ok = s.or(nv, fields);
            let ok = s.and(v, ok);
            prog = s.and(prog, ok);
        }
        parts.push((format!("lane {n}: micro-op program"), prog));
        let th = {
            let o = eq_bit(s, a.th.overflow, b.th.overflow);
            let p = s.eq(a.th.spill_ptr, b.th.spill_ptr);
            let dn = eq_bit(s, a.th.done, b.th.done);
            let x = s.and(o, p);
            s.and(x, dn)
        };
        parts.push((format!("lane {n}: Overflow, spill pointer, done"), th));
        let rb = s.eq(a.rb_len, b.rb_len);
        parts.push((format!("lane {n}: RB length"), rb));
    }
    for (j, (x, y)) in d.regs.iter().zip(&sp.regs).enumerate() {
        let fields = [
            s.eq(x.top, y.top),
            s.eq(x.bottom, y.bottom),
            eq_bit(s, x.empty, y.empty),
            eq_bit(s, x.idle, y.idle),
            s.eq(x.next_tid, y.next_tid),
            s.eq(x.priority, y.priority),
            s.eq(x.flush, y.flush),
        ];
        let all = fields.into_iter().fold(s.bit(true), |acc, f| s.and(acc, f));
        parts.push((format!("stack of lane {j}: registers"), all));
    }
    parts
}

/// A built query: the SMT-LIB text, the variables whose values a counterexample reports, and
/// the parts compared (for naming what differed).
pub struct Query {
    pub text: String,
    pub vars: Vec<String>,
    pub parts: Vec<String>,
    /// Terms in the DAG, paths explored per side.
    pub terms: usize,
}

/// Builds the one-step equivalence query of `cmds` (lanes of the warp at `base`, planned in
/// that order in one cycle) for the design with `steps`.
pub fn one_step<P: Steps>(cfg: &Config, steps: &P, base: u32, cmds: &[(u32, Kind)]) -> Query {
    one_step_in(Sym::default(), cfg, steps, base, cmds)
}

/// [`one_step`] built in `s` (a builder with other simplifications).
pub fn one_step_in<P: Steps>(s: Sym, cfg: &Config, steps: &P, base: u32, cmds: &[(u32, Kind)]) -> Query {
    let (mut s, st, inv, d, slots) = design_cycle(s, cfg, steps, base, cmds);
    let sp = side::<P>(&mut s, cfg, &st, &Side::Spec, slots);
    let parts = agreement(&mut s, &d, &sp, &st.lanes);
    finish(s, inv, parts)
}

/// Builds the invariant-preservation query of `cmds` (one induction step of [`well_formed`]):
/// from every state satisfying it, the design's cycle leaves a state satisfying it — every
/// lane's stack registers, and the commanding lanes' thread registers, RB lengths and
/// sequencers (busy when the cycle loaded a program) as the cycle leaves them.
pub fn preserves<P: Steps>(cfg: &Config, steps: &P, base: u32, cmds: &[(u32, Kind)]) -> Query {
    let (mut s, st, inv, d, _) = design_cycle(Sym::default(), cfg, steps, base, cmds);
    let mut done = st.done.clone();
    let mut after = Vec::new();
    for (x, a) in st.lanes.iter().zip(&d.lanes) {
        done[x.lane as usize] = a.th.done;
        // The program is compacted, so it is not empty exactly when its first slot is valid.
        let runs = a.prog.first().map_or_else(|| s.bit(false), |p| p.0);
        let busy = s.or(x.busy, runs);
        after.push((x.lane, a.th, a.rb_len, busy));
    }
    let kept = well_formed_parts(&mut s, cfg, &d.regs, &done, &after);
    finish(s, inv, kept.into_iter().map(|(n, b)| (format!("after the cycle, {n}"), b)).collect())
}

/// The start both queries share, in `s`: fresh state variables for `cmds`, the invariant over
/// them, and the design's cycle (with the program's slot count, for the specification's side).
fn design_cycle<P: Steps>(
    mut s: Sym,
    cfg: &Config,
    steps: &P,
    base: u32,
    cmds: &[(u32, Kind)],
) -> (Sym, State, B, Cycle, usize) {
    let st = State::new(&mut s, cfg, base, cmds);
    let lanes: Vec<(u32, Thread<Sym>, W, B)> =
        st.lanes.iter().map(|x| (x.lane, x.th, x.rb_len, x.busy)).collect();
    let inv = well_formed(&mut s, cfg, &st.regs, &st.done, &lanes);
    let slots = 2 * cfg.sh_entries as usize + 4;
    let d = side(&mut s, cfg, &st, &Side::Design(steps), slots);
    (s, st, inv, d, slots)
}

/// The query asserting `assume` and that some part fails, with one `agree_k` variable per part
/// (so a counterexample names the parts that failed).
pub(super) fn finish(mut s: Sym, assume: B, parts: Vec<(String, B)>) -> Query {
    let all = parts.iter().fold(s.bit(true), |acc, p| s.and(acc, p.1));
    let differ = s.not(all);
    let names: Vec<String> = parts.iter().map(|p| p.0.clone()).collect();
    let keep: Vec<B> = parts.iter().map(|p| p.1).collect();
    let mut text = s.smtlib(&[assume, differ], &keep);
    for (k, b) in keep.iter().enumerate() {
        text += &format!("(declare-fun agree_{k} () Bool)\n(assert (= agree_{k} {}))\n", s.name_of(*b));
    }
    let mut vars: Vec<String> = s.vars().map(|v| v.0.to_string()).collect();
    vars.extend((0..parts.len()).map(|k| format!("agree_{k}")));
    Query { text, vars, parts: names, terms: s.size() }
}
