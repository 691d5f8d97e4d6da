//! One warp of the stack manager as a synchronous circuit of [`Sym`] terms: every register a
//! variable, every input a variable, and each register's next value and each output one term,
//! built by running the design's own cycle ([`rtl::stack_manager::cycle`]) on symbolic values.
//!
//! The cycle's control shape (which micro-op is in flight or queued, which command arrives) is
//! concrete Rust control flow in the description, so it is enumerated here and the results are
//! merged under the condition that selects each shape, read from the registers' encodings. To
//! keep that a sum over lanes rather than a product, the cycle is built one lane at a time, in
//! the description's dataflow order:
//!
//! 1. **Sequencers**, lane by lane: a completion lands and the next micro-op issues
//!    ([`cycle::eval`] with only that lane's sequencer loaded and no command). A release
//!    changes another lane's stack: the stack registers of the warp are carried from lane to
//!    lane as the cycle's view of them.
//! 2. **Plans**, lane by lane: the lane's command ([`cycle::plan`]) over the cycle's view of the
//!    stack registers so far, each data-dependent branch ([`Logic::decide`]) explored by
//!    [`Sym::explore`] and merged under its path condition.
//! 3. **Edge**: a warp load replaces every lane's registers with their reset values.
//!
//! Lanes' sequencers are independent and their only shared effect (a release sets a stack's
//! Idle) commutes, so running completion and issue lane by lane computes what the
//! description's all-lanes-then-all-lanes order does; the plans run in the description's
//! command order (lane order).

use rtl::config::{Config, Overflow, Widths};
use rtl::logic::Logic;
use rtl::stack_manager::cycle::{self, CycleIn, Journal, Registers, WriteOf};
use rtl::stack_manager::policy::{Design, RbOp, Regs, Thread, UopL};
use rtl::stack_manager::{CmdOf, SrcOf, StackError, StackRegsOf, ThreadRegsOf, UopOf, POISON};

use crate::prove::query::{code, compact, encode, mux_enc, Enc};
use crate::prove::sym::{Sort, Sym, B, V, W};

/// Micro-op encodings a sequencer register can hold: (kind code, data from the latch).
const KINDS: [(u32, Option<bool>); 8] = [
    (code::SH_LOAD, None),
    (code::SH_STORE, Some(false)),
    (code::SH_STORE, Some(true)),
    (code::GLOBAL_LOAD, None),
    (code::GLOBAL_STORE, Some(false)),
    (code::GLOBAL_STORE, Some(true)),
    (code::RB_BOTTOM, None),
    (code::RELEASE, None),
];

/// Answer codes of the `answer` output: what the cycle did with the lane's command.
pub const ANSWERS: [&str; 11] = [
    "none",
    "accepted",
    "popped",
    "pop_empty",
    "finish_non_empty",
    "busy",
    "after_finish",
    "spill_region_full",
    "rb_count_overflow",
    "seq_step_overflow",
    "out_of_range",
];

/// The code of a command's answer ([`ANSWERS`]).
pub fn answer_code(a: &Result<Option<u64>, StackError>, commanded: bool) -> u32 {
    match a {
        Ok(None) => u32::from(commanded),
        Ok(Some(_)) => 2,
        Err(e) => error_code(e),
    }
}

fn error_code(e: &StackError) -> u32 {
    match e {
        StackError::PopEmpty { .. } => 3,
        StackError::FinishNonEmpty { .. } => 4,
        StackError::Busy { .. } => 5,
        StackError::AfterFinish { .. } => 6,
        StackError::SpillRegionFull { .. } => 7,
        StackError::Overflow { field: "rb_count", .. } => 8,
        StackError::Overflow { .. } => 9,
        StackError::OutOfRange { .. } => 10,
    }
}

/// Command kind codes on the `cmd_kind` input.
pub const CMD_NONE: u32 = 0;
pub const CMD_PUSH: u32 = 1;
pub const CMD_POP: u32 = 2;
pub const CMD_FINISH: u32 = 3;

/// A term of one of the three sorts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum T {
    B(B),
    W(W),
    V(V),
}

impl T {
    pub fn id(self) -> u32 {
        match self {
            T::B(b) => b.0,
            T::W(w) => w.0,
            T::V(v) => v.0,
        }
    }
    pub fn sort(self) -> Sort {
        match self {
            T::B(_) => Sort::Bool,
            T::W(_) => Sort::Word,
            T::V(_) => Sort::Val,
        }
    }
    fn mux(s: &mut Sym, c: B, a: T, b: T) -> T {
        match (a, b) {
            (T::B(x), T::B(y)) => T::B(s.mux_bit(c, x, y)),
            (T::W(x), T::W(y)) => T::W(s.mux(c, x, y)),
            (T::V(x), T::V(y)) => T::V(s.mux_val(c, x, y)),
            _ => unreachable!("merged results have one shape"),
        }
    }
}

/// A register: its Verilog name, the row of the cost report (`sms cost`) it is part of, its
/// width, the variable it is now and its next value.
#[derive(Clone, Debug)]
pub struct Reg {
    pub name: String,
    pub field: &'static str,
    pub bits: u32,
    pub q: T,
    pub d: T,
}

/// A port: its name, width and term (an input's variable, an output's value).
#[derive(Clone, Debug)]
pub struct Port {
    pub name: String,
    pub bits: u32,
    pub t: T,
}

/// One warp of the stack manager as terms.
pub struct Circuit {
    pub sym: Sym,
    pub lanes: u32,
    pub regs: Vec<Reg>,
    pub inputs: Vec<Port>,
    pub outputs: Vec<Port>,
    /// Control shapes and paths run to build it.
    pub shapes: usize,
    pub paths: usize,
    /// Most paths of one lane's command.
    pub max_plan_paths: usize,
}

/// Micro-op program slots of a sequencer ([`Widths::seq_slots`]).
pub fn queue_slots(cfg: &Config) -> usize {
    cfg.widths().expect("a valid configuration").seq_slots as usize
}

/// A lane's RB: occupancy and entries, oldest first.
#[derive(Clone, Debug)]
struct Rb {
    count: W,
    e: Vec<V>,
}

/// A lane's sequencer: program occupancy and slots, the micro-op in flight (kind 0: none) and
/// the data latch.
#[derive(Clone, Debug)]
struct Seq {
    count: W,
    slots: Vec<Enc>,
    inflight: Enc,
    latch_valid: B,
    latch: V,
}

/// Inputs of one lane.
#[derive(Clone, Copy, Debug)]
struct LaneIn {
    cmd_kind: W,
    cmd_value: V,
    sh_done: B,
    sh_rdata: V,
    load_active: B,
}

/// The registers and memories as a stage reads them ([`Registers`]).
struct View<'a> {
    /// The stack registers `stack_q` reads; `None`: every read goes to the cycle's list.
    stacks: Option<&'a [Regs<Sym>]>,
    threads: &'a [Thread<Sym>],
    busy: &'a [B],
    rb: &'a [Rb],
    lane: u32,
    inflight: Option<UopL<Sym>>,
    head: Option<UopL<Sym>>,
    latch: Option<V>,
    sh_rdata: V,
    g_rdata: V,
    acked: bool,
}

/// What a stack outside the warp reads as (the simulator's default registers).
fn outside(s: &mut Sym) -> Regs<Sym> {
    let (z, no) = (s.word(0), s.bit(false));
    StackRegsOf { top: z, bottom: z, empty: no, idle: no, next_tid: z, priority: z, flush: z }
}

fn read_lanes(l: &mut Sym, stacks: &[Regs<Sym>], s: W) -> Regs<Sym> {
    let mut v = outside(l);
    for (k, r) in stacks.iter().enumerate().rev() {
        let hit = l.eq_k(s, k as u32);
        v = StackRegsOf::mux(l, hit, *r, v);
    }
    v
}

impl Registers<Sym> for View<'_> {
    fn stack_q(&self, l: &mut Sym, s: W) -> Regs<Sym> {
        match self.stacks {
            Some(st) => read_lanes(l, st, s),
            None => outside(l),
        }
    }
    fn thread_q(&self, _: &mut Sym, t: u32) -> Thread<Sym> {
        self.threads[t as usize]
    }
    fn done_q(&self, l: &mut Sym, s: W) -> B {
        let mut v = l.bit(true);
        for (k, th) in self.threads.iter().enumerate().rev() {
            let hit = l.eq_k(s, k as u32);
            v = l.mux_bit(hit, th.done, v);
        }
        v
    }
    fn busy_q(&self, _: &mut Sym, t: u32) -> B {
        self.busy[t as usize]
    }
    fn inflight_q(&self, t: u32) -> Option<UopL<Sym>> {
        self.inflight.filter(|_| t == self.lane)
    }
    fn head_q(&self, t: u32) -> Option<UopL<Sym>> {
        self.head.filter(|_| t == self.lane)
    }
    fn latch_q(&self, t: u32) -> Option<V> {
        self.latch.filter(|_| t == self.lane)
    }
    fn rb_len_q(&self, _: &mut Sym, t: u32) -> W {
        self.rb[t as usize].count
    }
    fn rb_front_q(&self, l: &mut Sym, t: u32) -> V {
        let rb = &self.rb[t as usize];
        let empty = l.eq_k(rb.count, 0);
        let poison = l.val(POISON);
        match rb.e.first() {
            Some(&v) => l.mux_val(empty, poison, v),
            None => poison,
        }
    }
    fn rb_back_q(&self, l: &mut Sym, t: u32) -> V {
        let rb = &self.rb[t as usize];
        let mut v = l.val(POISON);
        for (k, &e) in rb.e.iter().enumerate() {
            let hit = l.eq_k(rb.count, k as u32 + 1);
            v = l.mux_val(hit, e, v);
        }
        v
    }
    fn sh_q(&self, _: &mut Sym, _: W, _: W) -> V {
        self.sh_rdata
    }
    fn global_q(&self, _: &mut Sym, _: u32, _: W) -> V {
        self.g_rdata
    }
    fn next_queued(&self, from: u32) -> Option<u32> {
        (self.head.is_some() && from <= self.lane).then_some(self.lane)
    }
    fn acked_stores(&self) -> bool {
        self.acked
    }
}

/// The micro-op of encoding `KINDS[k]` with the fields of `e`.
fn decode(k: usize, e: &Enc) -> UopL<Sym> {
    let (kind, latch) = KINDS[k];
    let src = match latch {
        Some(true) => SrcOf::Latch,
        _ => SrcOf::Value(e.value),
    };
    match kind {
        code::SH_LOAD => UopOf::ShLoad { stack: e.a, entry: e.b },
        code::SH_STORE => UopOf::ShStore { stack: e.a, entry: e.b, src },
        code::GLOBAL_LOAD => UopOf::GlobalLoad { slot: e.a },
        code::GLOBAL_STORE => UopOf::GlobalStore { slot: e.a, src },
        code::RB_BOTTOM => UopOf::RbBottom,
        _ => UopOf::Release { stack: e.a },
    }
}

/// `e` holds encoding `KINDS[k]`.
fn holds(s: &mut Sym, k: usize, e: &Enc) -> B {
    let (kind, latch) = KINDS[k];
    let a = s.eq_k(e.kind, kind);
    match latch {
        Some(true) => s.and(a, e.latch),
        Some(false) => {
            let n = s.not(e.latch);
            s.and(a, n)
        }
        None => a,
    }
}

fn no_uop(s: &mut Sym) -> Enc {
    let (z, no, zv) = (s.word(0), s.bit(false), s.val(0));
    Enc { kind: z, a: z, b: z, latch: no, value: zv }
}

fn enc_parts(e: &Enc, out: &mut Vec<T>) {
    out.extend([T::W(e.kind), T::W(e.a), T::W(e.b), T::B(e.latch), T::V(e.value)]);
}

fn enc_from(p: &mut impl Iterator<Item = T>) -> Enc {
    Enc { kind: w(p), a: w(p), b: w(p), latch: b(p), value: v(p) }
}

fn b(p: &mut impl Iterator<Item = T>) -> B {
    match p.next() {
        Some(T::B(x)) => x,
        x => unreachable!("expected a bit, got {x:?}"),
    }
}
fn w(p: &mut impl Iterator<Item = T>) -> W {
    match p.next() {
        Some(T::W(x)) => x,
        x => unreachable!("expected a word, got {x:?}"),
    }
}
fn v(p: &mut impl Iterator<Item = T>) -> V {
    match p.next() {
        Some(T::V(x)) => x,
        x => unreachable!("expected a value, got {x:?}"),
    }
}

fn stack_parts(r: &Regs<Sym>, out: &mut Vec<T>) {
    out.extend([
        T::W(r.top),
        T::W(r.bottom),
        T::B(r.empty),
        T::B(r.idle),
        T::W(r.next_tid),
        T::W(r.priority),
        T::W(r.flush),
    ]);
}

fn stack_from(p: &mut impl Iterator<Item = T>) -> Regs<Sym> {
    StackRegsOf {
        top: w(p),
        bottom: w(p),
        empty: b(p),
        idle: b(p),
        next_tid: w(p),
        priority: w(p),
        flush: w(p),
    }
}

/// Every result of `paths` merged into one under the paths' conditions (the last is the
/// default), as flat term lists of one shape.
///
/// The conditions are disjoint (each is one branch of the control shapes' and the explored
/// decisions' tree), so each output is chosen among its *distinct* values rather than path by
/// path: the paths that give an output the same value share one multiplexer under the OR of
/// their conditions, and those that give it the default value need none. An output most paths
/// leave as it was costs a few multiplexers instead of one per path.
fn merge(s: &mut Sym, mut paths: Vec<(B, Vec<T>)>) -> Vec<T> {
    let (_, default) = paths.pop().expect("at least one path");
    let mut out = Vec::with_capacity(default.len());
    let mut groups: Vec<(T, B)> = Vec::new();
    for (i, &d) in default.iter().enumerate() {
        groups.clear();
        for (c, x) in &paths {
            debug_assert_eq!(x.len(), default.len());
            let y = x[i];
            if y == d {
                continue;
            }
            match groups.iter_mut().find(|g| g.0 == y) {
                Some(g) => g.1 = s.or(g.1, *c),
                None => groups.push((y, *c)),
            }
        }
        out.push(groups.iter().rev().fold(d, |acc, &(y, c)| T::mux(s, c, y, acc)));
    }
    out
}

/// Stack registers `list` (the cycle's changes, in order) leaves the warp's `stacks` at.
fn resolve(s: &mut Sym, stacks: &[Regs<Sym>], list: &[(W, Regs<Sym>)]) -> Vec<Regs<Sym>> {
    let mut out = stacks.to_vec();
    for &(i, r) in list {
        for (k, x) in out.iter_mut().enumerate() {
            let hit = s.eq_k(i, k as u32);
            if s.maybe(hit) {
                *x = StackRegsOf::mux(s, hit, r, *x);
            }
        }
    }
    out
}

/// The registers as they are declared, in order.
struct Decl {
    regs: Vec<Reg>,
}

impl Decl {
    /// A register's current value: a variable, or its constant reset value when it has no bits.
    fn add(
        &mut self,
        s: &mut Sym,
        name: String,
        field: &'static str,
        bits: u32,
        sort: Sort,
        reset: u64,
    ) -> T {
        let q = match (sort, bits) {
            (Sort::Bool, 0) => T::B(s.bit(reset != 0)),
            (Sort::Word, 0) => T::W(s.word(reset as u32)),
            (Sort::Val, 0) => T::V(s.val(reset)),
            (Sort::Bool, _) => T::B(s.var_bit(&name)),
            (Sort::Word, _) => T::W(s.var_word(&name)),
            (Sort::Val, _) => T::V(s.var_val(&name)),
        };
        self.regs.push(Reg { name, field, bits, q, d: q });
        q
    }

    fn uop(&mut self, s: &mut Sym, name: &str, field: &'static str, bits: [u32; 5]) -> Enc {
        let f = ["kind", "a", "b", "latch", "value"];
        let sorts = [Sort::Word, Sort::Word, Sort::Word, Sort::Bool, Sort::Val];
        let parts: Vec<T> =
            (0..5).map(|i| self.add(s, format!("{name}_{}", f[i]), field, bits[i], sorts[i], 0)).collect();
        enc_from(&mut parts.into_iter())
    }
}

/// One lane's registers, in declaration order.
#[derive(Clone, Debug)]
struct Lane {
    stack: Regs<Sym>,
    thread: Thread<Sym>,
    rb: Rb,
    seq: Seq,
}

impl Lane {
    fn parts(&self) -> Vec<T> {
        let mut out = Vec::new();
        stack_parts(&self.stack, &mut out);
        let th = &self.thread;
        out.extend([T::B(th.overflow), T::W(th.spill_ptr), T::B(th.done), T::W(self.rb.count)]);
        out.extend(self.rb.e.iter().map(|&x| T::V(x)));
        out.push(T::W(self.seq.count));
        for e in self.seq.slots.iter().chain([&self.seq.inflight]) {
            enc_parts(e, &mut out);
        }
        out.extend([T::B(self.seq.latch_valid), T::V(self.seq.latch)]);
        out
    }

    /// Declares lane `j`'s registers (names `lane{j}_…`), reset as a loaded lane.
    fn declare(s: &mut Sym, d: &mut Decl, cfg: &Config, wd: &Widths, j: u32) -> Lane {
        let n_rb = cfg.rb.capacity().unwrap_or(0);
        let base = u64::from(cfg.skew_base(j));
        let f = |x: &str| format!("lane{j}_{x}");
        let stack = [
            ("top", wd.top, Sort::Word, base),
            ("bottom", wd.bottom, Sort::Word, base),
            ("sh_empty", wd.sh_empty, Sort::Bool, 1),
            ("idle", wd.idle, Sort::Bool, 0),
            ("next_tid", wd.next_tid, Sort::Word, u64::from(j)),
            ("priority", wd.priority, Sort::Word, 0),
            ("flush", wd.flush, Sort::Word, 0),
            ("overflow", wd.overflow, Sort::Bool, 0),
            ("spill_ptr", wd.spill_ptr, Sort::Word, 0),
        ];
        let mut p: Vec<T> =
            stack.iter().map(|&(n, bits, sort, r)| d.add(s, f(n), n, bits, sort, r)).collect();
        p.push(d.add(s, f("done"), "done", 1, Sort::Bool, 0));
        p.push(d.add(s, f("rb_count"), "rb_count", wd.rb_count, Sort::Word, 0));
        let mut it = p.into_iter();
        let stack = stack_from(&mut it);
        let thread = ThreadRegsOf { overflow: b(&mut it), spill_ptr: w(&mut it), done: b(&mut it) };
        let count = w(&mut it);
        let e = (0..n_rb).map(|k| d.add(s, f(&format!("rb{k}")), "rb_entries", wd.entry, Sort::Val, 0));
        let e: Vec<V> = e.collect::<Vec<_>>().into_iter().map(|t| v(&mut [t].into_iter())).collect();
        let rb = Rb { count, e };
        let sc = d.add(s, f("seq_step"), "seq_step", wd.seq_step, Sort::Word, 0);
        let ub = wd.uop_bits();
        let slots =
            (0..queue_slots(cfg)).map(|k| d.uop(s, &f(&format!("seq{k}")), "seq_program", ub)).collect();
        let inflight = d.uop(s, &f("inflight"), "seq_inflight", ub);
        let lv = d.add(s, f("latch_valid"), "seq_latch_valid", 1, Sort::Bool, 0);
        let lx = d.add(s, f("latch"), "seq_latch", wd.entry, Sort::Val, 0);
        let seq = Seq {
            count: w(&mut [sc].into_iter()),
            slots,
            inflight,
            latch_valid: b(&mut [lv].into_iter()),
            latch: v(&mut [lx].into_iter()),
        };
        Lane { stack, thread, rb, seq }
    }

    /// Lane `j`'s registers when a warp load starts it (`active`) or leaves it finished.
    fn reset(&self, s: &mut Sym, cfg: &Config, j: u32, active: B) -> Lane {
        let base = s.word(cfg.skew_base(j));
        let (z, no, yes, zv) = (s.word(0), s.bit(false), s.bit(true), s.val(0));
        let finished = s.not(active);
        let idle = if cfg.realloc().is_some() { finished } else { no };
        let lane = s.word(j);
        let stack =
            StackRegsOf { top: base, bottom: base, empty: yes, idle, next_tid: lane, priority: z, flush: z };
        let thread = ThreadRegsOf { overflow: no, spill_ptr: z, done: finished };
        let rb = Rb { count: z, e: self.rb.e.clone() };
        let none = no_uop(s);
        let seq = Seq {
            count: z,
            slots: self.seq.slots.clone(),
            inflight: none,
            latch_valid: no,
            latch: self.seq.latch,
        };
        let _ = zv;
        Lane { stack, thread, rb, seq }
    }
}

/// What lane `j`'s sequencer stage leaves: its sequencer, the entry it puts under its RB, its
/// memory writes and requests, and the warp's stack registers.
struct SeqOut {
    issued: B,
    inflight: Enc,
    latch_valid: B,
    latch: V,
    push_front: (B, V),
    sh_wr: (B, W, W, V),
    g_wr: (B, W, V),
    sh_req: (B, W, W, B),
    g_req: (B, B, W),
    stacks: Vec<Regs<Sym>>,
}

impl SeqOut {
    fn parts(&self) -> Vec<T> {
        let mut out = vec![T::B(self.issued)];
        enc_parts(&self.inflight, &mut out);
        out.extend([
            T::B(self.latch_valid),
            T::V(self.latch),
            T::B(self.push_front.0),
            T::V(self.push_front.1),
        ]);
        let (a, b_, c, d) = self.sh_wr;
        out.extend([T::B(a), T::W(b_), T::W(c), T::V(d)]);
        let (a, b_, c) = self.g_wr;
        out.extend([T::B(a), T::W(b_), T::V(c)]);
        let (a, b_, c, d) = self.sh_req;
        out.extend([T::B(a), T::W(b_), T::W(c), T::B(d)]);
        let (a, b_, c) = self.g_req;
        out.extend([T::B(a), T::B(b_), T::W(c)]);
        for r in &self.stacks {
            stack_parts(r, &mut out);
        }
        out
    }

    fn from(p: Vec<T>) -> SeqOut {
        let p = &mut p.into_iter();
        let issued = b(p);
        let inflight = enc_from(p);
        let (latch_valid, latch) = (b(p), v(p));
        let push_front = (b(p), v(p));
        let sh_wr = (b(p), w(p), w(p), v(p));
        let g_wr = (b(p), w(p), v(p));
        let sh_req = (b(p), w(p), w(p), b(p));
        let g_req = (b(p), b(p), w(p));
        let mut stacks = Vec::new();
        while p.len() > 0 {
            stacks.push(stack_from(p));
        }
        SeqOut { issued, inflight, latch_valid, latch, push_front, sh_wr, g_wr, sh_req, g_req, stacks }
    }
}

/// Lane `j`'s sequencer stage from journal `d` of a cycle that ran only it.
fn seq_out(
    s: &mut Sym,
    lane: &Lane,
    j: u32,
    stacks: &[Regs<Sym>],
    d: &Journal<Sym>,
) -> Result<SeqOut, String> {
    let (no, z, zv) = (s.bit(false), s.word(0), s.val(0));
    let yes = s.bit(true);
    let mut o = SeqOut {
        issued: no,
        inflight: lane.seq.inflight,
        latch_valid: lane.seq.latch_valid,
        latch: lane.seq.latch,
        push_front: (no, zv),
        sh_wr: (no, z, z, zv),
        g_wr: (no, z, zv),
        sh_req: (no, z, z, no),
        g_req: (no, no, z),
        stacks: resolve(s, stacks, &d.stacks),
    };
    let twice = |what: &str| Err(format!("lane {j}: two {what} in one cycle"));
    for x in &d.writes {
        match *x {
            WriteOf::Seq { issued, inflight, latch, .. } => {
                o.issued = s.bit(issued);
                o.inflight = match inflight {
                    Some(u) => encode(s, &u),
                    None => no_uop(s),
                };
                o.latch_valid = s.bit(latch.is_some());
                o.latch = latch.unwrap_or(lane.seq.latch);
            }
            WriteOf::Sh { stack, entry, value } => {
                if o.sh_wr.0 == yes {
                    return twice("SH writes");
                }
                o.sh_wr = (yes, stack, entry, value);
            }
            WriteOf::Global { slot, value, .. } => {
                if o.g_wr.0 == yes {
                    return twice("global writes");
                }
                o.g_wr = (yes, slot, value);
            }
            WriteOf::RbPushFront(_, v) => o.push_front = (yes, v),
            _ => return Err(format!("lane {j}: the sequencer stage wrote {x:?}")),
        }
    }
    if let [r] = d.sh_req[..] {
        let wr = s.bit(r.write);
        o.sh_req = (yes, r.stack, r.entry, wr);
    }
    if let [r] = d.g_req[..] {
        let wr = s.bit(r.write);
        o.g_req = (yes, wr, r.slot);
    }
    if d.sh_req.len() > 1 || d.g_req.len() > 1 {
        return twice("requests");
    }
    Ok(o)
}

/// A change to a lane's RB.
#[derive(Clone, Copy, Debug)]
enum RbEv {
    Op(RbOp<V>),
    PushFront(V),
}

/// `rb` after `ev` when `valid`.
fn rb_apply(s: &mut Sym, rb: &Rb, ev: RbEv, valid: B) -> Rb {
    let n = rb.e.len();
    let mut e = rb.e.clone();
    let (count, grow) = match ev {
        RbEv::Op(RbOp::PushBack(x)) => {
            for (k, slot) in e.iter_mut().enumerate() {
                let at = s.eq_k(rb.count, k as u32);
                *slot = s.mux_val(at, x, *slot);
            }
            (s.add_k(rb.count, 1), true)
        }
        RbEv::Op(RbOp::PopBack) => (s.sub_k(rb.count, 1), false),
        RbEv::Op(RbOp::PopFront) => {
            if n > 1 {
                e[..n - 1].copy_from_slice(&rb.e[1..]);
            }
            (s.sub_k(rb.count, 1), false)
        }
        RbEv::PushFront(x) => {
            for k in (1..n).rev() {
                e[k] = rb.e[k - 1];
            }
            if let Some(first) = e.first_mut() {
                *first = x;
            }
            (s.add_k(rb.count, 1), true)
        }
    };
    let _ = grow;
    let count = s.mux(valid, count, rb.count);
    let e = e.iter().zip(&rb.e).map(|(&a, &b_)| s.mux_val(valid, a, b_)).collect();
    Rb { count, e }
}

/// A lane's sequencer program: occupancy and slots.
fn queue_parts(count: W, slots: &[Enc], out: &mut Vec<T>) {
    out.push(T::W(count));
    for e in slots {
        enc_parts(e, out);
    }
}

/// Lane `j`'s plan stage from journal `d`: the warp's stack registers, the lane's thread
/// registers, RB and program, and its answer (code, popped entry; with `restarts`, whether a pop
/// answered Restart), as flat terms.
#[allow(clippy::too_many_arguments)]
fn plan_parts(
    s: &mut Sym,
    j: u32,
    q_slots: usize,
    restarts: bool,
    stacks: &[Regs<Sym>],
    thread: Thread<Sym>,
    rb: &Rb,
    queue: (W, &[Enc]),
    d: &Journal<Sym>,
) -> Result<Vec<T>, String> {
    let stacks = resolve(s, stacks, &d.stacks);
    let mut thread = thread;
    let mut rb = rb.clone();
    let mut emits = Vec::new();
    let yes = s.bit(true);
    for x in &d.writes {
        match *x {
            WriteOf::Thread(_, th) => thread = th,
            WriteOf::Rb(_, op) => rb = rb_apply(s, &rb, RbEv::Op(op), yes),
            WriteOf::Emit(_, valid, u) => emits.push((valid, u)),
            WriteOf::Cmd(..) => {}
            _ => return Err(format!("lane {j}: a plan wrote {x:?}")),
        }
    }
    let mut out = Vec::new();
    for r in &stacks {
        stack_parts(r, &mut out);
    }
    out.extend([T::B(thread.overflow), T::W(thread.spill_ptr), T::B(thread.done), T::W(rb.count)]);
    out.extend(rb.e.iter().map(|&x| T::V(x)));
    if emits.is_empty() {
        queue_parts(queue.0, queue.1, &mut out);
    } else {
        if emits.len() > q_slots {
            return Err(format!(
                "lane {j}: a program of {} micro-ops exceeds the {q_slots} slots",
                emits.len()
            ));
        }
        let slots = compact(s, &emits, q_slots);
        let mut count = s.word(0);
        for (valid, _) in &slots {
            let one = s.count(*valid);
            count = s.add(count, one);
        }
        let encs: Vec<Enc> = slots.iter().map(|x| x.1).collect();
        queue_parts(count, &encs, &mut out);
    }
    let (code, value) = match d.answer(j) {
        Ok(None) => (1, s.val(0)),
        Ok(Some(v)) => (2, v),
        Err(e) => (error_code(&e), s.val(0)),
    };
    let code = s.word(code);
    out.extend([T::W(code), T::V(value)]);
    if restarts {
        let r = s.bit(d.restarts.contains(&j));
        out.push(T::B(r));
    }
    Ok(out)
}

/// Builds one warp of `cfg`'s stack manager (global stores acknowledged when `acked`), lanes
/// numbered from 0.
pub fn warp(cfg: &Config, acked: bool) -> Result<Circuit, String> {
    let wd = cfg.widths().map_err(|e| e.to_string())?;
    if cfg.rb.capacity().is_none() {
        return Err("RB_FULL has no hardware bound: choose RB_N".into());
    }
    let ws = cfg.warp_size;
    let q_slots = queue_slots(cfg);
    // A restart design answers a pop of a stack emptied by drops with Restart: an output of its own.
    let restarts = cfg.overflow == Overflow::Drop;
    let mut s = Sym::default();
    let mut decl = Decl { regs: Vec::new() };
    let lanes: Vec<Lane> = (0..ws).map(|j| Lane::declare(&mut s, &mut decl, cfg, &wd, j)).collect();
    let mut inputs = Vec::new();
    let mut input = |s: &mut Sym, name: String, bits: u32, sort: Sort| {
        let t = match (sort, bits) {
            (Sort::Word, 0) => T::W(s.word(0)),
            (Sort::Bool, _) => T::B(s.var_bit(&name)),
            (Sort::Word, _) => T::W(s.var_word(&name)),
            (Sort::Val, _) => T::V(s.var_val(&name)),
        };
        inputs.push(Port { name, bits, t });
        t
    };
    let mut ins = Vec::new();
    for j in 0..ws {
        let p = [
            input(&mut s, format!("lane{j}_cmd_kind"), 2, Sort::Word),
            input(&mut s, format!("lane{j}_cmd_value"), wd.entry, Sort::Val),
            input(&mut s, format!("lane{j}_sh_done"), 1, Sort::Bool),
            input(&mut s, format!("lane{j}_sh_rdata"), wd.entry, Sort::Val),
            input(&mut s, format!("lane{j}_load_active"), 1, Sort::Bool),
        ];
        let p = &mut p.into_iter();
        ins.push(LaneIn {
            cmd_kind: w(p),
            cmd_value: v(p),
            sh_done: b(p),
            sh_rdata: v(p),
            load_active: b(p),
        });
    }
    let p = [
        input(&mut s, "deq_valid".into(), 1, Sort::Bool),
        input(&mut s, "deq_lane".into(), wd.tid, Sort::Word),
        input(&mut s, "g_rdata".into(), wd.entry, Sort::Val),
        input(&mut s, "load".into(), 1, Sort::Bool),
    ];
    let p = &mut p.into_iter();
    let (deq_valid, deq_lane, g_rdata, load) = (b(p), w(p), v(p), b(p));

    let threads: Vec<Thread<Sym>> = lanes.iter().map(|l| l.thread).collect();
    let rbs: Vec<Rb> = lanes.iter().map(|l| l.rb.clone()).collect();
    let busy: Vec<B> = lanes
        .iter()
        .map(|l| {
            let a = nonzero(&mut s, l.seq.inflight.kind);
            let q = nonzero(&mut s, l.seq.count);
            s.or(a, q)
        })
        .collect();
    let mut view_stacks: Vec<Regs<Sym>> = lanes.iter().map(|l| l.stack).collect();
    let (mut shapes, mut paths, mut max_plan_paths) = (0, 0, 0);

    // 1. Sequencers.
    let waiting: Vec<usize> = [0usize, 1, 3].into_iter().chain(acked.then_some(4)).collect();
    let mut seq_outs = Vec::new();
    for j in 0..ws {
        let lane = &lanes[j as usize];
        let at = s.eq_k(deq_lane, j);
        let deq_here = s.and(deq_valid, at);
        let completes = s.or(ins[j as usize].sh_done, deq_here);
        let mut results = Vec::new();
        for inf in [None].into_iter().chain(waiting.iter().map(|&k| Some(k))) {
            let c_inf = match inf {
                None => s.eq_k(lane.seq.inflight.kind, 0),
                Some(k) => holds(&mut s, k, &lane.seq.inflight),
            };
            for c in [false, true] {
                if c && inf.is_none() {
                    continue;
                }
                let c_c = match (inf, c) {
                    (None, _) => s.bit(true),
                    (_, true) => completes,
                    (_, false) => s.not(completes),
                };
                for head in [None].into_iter().chain((0..KINDS.len()).map(Some)) {
                    let c_h = match head {
                        None => s.eq_k(lane.seq.count, 0),
                        Some(k) => {
                            let some = nonzero(&mut s, lane.seq.count);
                            let h = holds(&mut s, k, &lane.seq.slots[0]);
                            s.and(some, h)
                        }
                    };
                    for lv in [false, true] {
                        let c_l = if lv { lane.seq.latch_valid } else { s.not(lane.seq.latch_valid) };
                        let cond = s.and(c_inf, c_c);
                        let cond = s.and(cond, c_h);
                        let cond = s.and(cond, c_l);
                        let view = View {
                            stacks: Some(&view_stacks),
                            threads: &threads,
                            busy: &busy,
                            rb: &rbs,
                            lane: j,
                            inflight: inf.map(|k| decode(k, &lane.seq.inflight)),
                            head: head.map(|k| decode(k, &lane.seq.slots[0])),
                            latch: lv.then_some(lane.seq.latch),
                            sh_rdata: ins[j as usize].sh_rdata,
                            g_rdata,
                            acked,
                        };
                        let done = [j];
                        let cin =
                            CycleIn { cmds: &[], done: if c { &done[..] } else { &[] }, deq: None, now: 0 };
                        let found = s.explore(|l| {
                            let mut d = Journal::<Sym>::default();
                            cycle::eval(l, &Design, cfg, &wd, &view, &cin, &mut d);
                            seq_out(l, lane, j, &view_stacks, &d).map(|o| o.parts())
                        });
                        shapes += 1;
                        paths += found.len();
                        for (pc, r) in found {
                            let c = s.and(cond, pc);
                            results.push((c, r?));
                        }
                    }
                }
            }
        }
        let o = SeqOut::from(merge(&mut s, results));
        view_stacks = o.stacks.clone();
        seq_outs.push(o);
    }

    // 2. Plans.
    let mut next_lanes = Vec::new();
    let mut answers = Vec::new();
    for j in 0..ws {
        let (lane, so, li) = (&lanes[j as usize], &seq_outs[j as usize], ins[j as usize]);
        let rb_after = rb_apply(&mut s, &lane.rb, RbEv::PushFront(so.push_front.1), so.push_front.0);
        let (count, slots) = {
            let one = s.count(so.issued);
            let count = s.sub(lane.seq.count, one);
            let n = lane.seq.slots.len();
            let slots: Vec<Enc> = (0..n)
                .map(|k| {
                    let shifted = lane.seq.slots[(k + 1).min(n - 1)];
                    mux_enc(&mut s, so.issued, shifted, lane.seq.slots[k])
                })
                .collect();
            (count, slots)
        };
        let mut results = Vec::new();
        {
            let cond = s.eq_k(li.cmd_kind, CMD_NONE);
            let mut out = Vec::new();
            for r in &view_stacks {
                stack_parts(r, &mut out);
            }
            let th = lane.thread;
            out.extend([T::B(th.overflow), T::W(th.spill_ptr), T::B(th.done), T::W(rb_after.count)]);
            out.extend(rb_after.e.iter().map(|&x| T::V(x)));
            queue_parts(count, &slots, &mut out);
            let (z, zv) = (s.word(0), s.val(0));
            out.extend([T::W(z), T::V(zv)]);
            if restarts {
                out.push(T::B(s.bit(false)));
            }
            results.push((cond, out));
        }
        for (k, cmd) in
            [(CMD_PUSH, CmdOf::Push(li.cmd_value)), (CMD_POP, CmdOf::Pop), (CMD_FINISH, CmdOf::Finish)]
        {
            let cond = s.eq_k(li.cmd_kind, k);
            let view = View {
                stacks: None,
                threads: &threads,
                busy: &busy,
                rb: &rbs,
                lane: j,
                inflight: None,
                head: None,
                latch: None,
                sh_rdata: li.sh_rdata,
                g_rdata,
                acked,
            };
            let found = s.explore(|l| {
                let stacks = view_stacks.iter().enumerate().map(|(k, r)| (l.word(k as u32), *r)).collect();
                let mut d = Journal::<Sym> { stacks, ..Journal::<Sym>::default() };
                cycle::plan(l, &Design, cfg, &wd, &view, &[(j, cmd)], &mut d);
                plan_parts(l, j, q_slots, restarts, &view_stacks, lane.thread, &rb_after, (count, &slots), &d)
            });
            shapes += 1;
            paths += found.len();
            max_plan_paths = max_plan_paths.max(found.len());
            for (pc, r) in found {
                let c = s.and(cond, pc);
                results.push((c, r?));
            }
        }
        let merged = merge(&mut s, results);
        let p = &mut merged.into_iter();
        view_stacks = (0..ws).map(|_| stack_from(p)).collect();
        let thread = ThreadRegsOf { overflow: b(p), spill_ptr: w(p), done: b(p) };
        let rb = Rb { count: w(p), e: (0..lane.rb.e.len()).map(|_| v(p)).collect() };
        let count = w(p);
        let slots: Vec<Enc> = (0..q_slots).map(|_| enc_from(p)).collect();
        answers.push((w(p), v(p), restarts.then(|| b(p))));
        let seq = Seq { count, slots, inflight: so.inflight, latch_valid: so.latch_valid, latch: so.latch };
        next_lanes.push(Lane { stack: lane.stack, thread, rb, seq });
    }

    // 3. Edge.
    let mut k = 0;
    for j in 0..ws as usize {
        let mut next = next_lanes[j].clone();
        next.stack = view_stacks[j];
        let reset = lanes[j].reset(&mut s, cfg, j as u32, ins[j].load_active);
        let d: Vec<T> =
            next.parts().into_iter().zip(reset.parts()).map(|(n, r)| T::mux(&mut s, load, r, n)).collect();
        for t in d {
            decl.regs[k].d = t;
            k += 1;
        }
    }
    debug_assert_eq!(k, decl.regs.len());

    let mut outputs = Vec::new();
    for j in 0..ws as usize {
        let so = &seq_outs[j];
        let f = |x: &str| format!("lane{j}_{x}");
        let ready = s.not(busy[j]);
        let (a, st, e, wr) = so.sh_req;
        let (ga, gwr, gslot) = so.g_req;
        let (wa, wst, we, wv) = so.sh_wr;
        let (xa, xslot, xv) = so.g_wr;
        let (code, value, restart) = answers[j];
        let restart = restart.map(|r| ("restart", 1, T::B(r)));
        for (name, bits, t) in [
            ("ready", 1, T::B(ready)),
            ("sh_req_valid", 1, T::B(a)),
            ("sh_req_stack", wd.tid, T::W(st)),
            ("sh_req_entry", wd.top, T::W(e)),
            ("sh_req_write", 1, T::B(wr)),
            ("g_req_valid", 1, T::B(ga)),
            ("g_req_write", 1, T::B(gwr)),
            ("g_req_slot", wd.spill_ptr, T::W(gslot)),
            ("sh_wr_valid", 1, T::B(wa)),
            ("sh_wr_stack", wd.tid, T::W(wst)),
            ("sh_wr_entry", wd.top, T::W(we)),
            ("sh_wr_data", wd.entry, T::V(wv)),
            ("g_wr_valid", 1, T::B(xa)),
            ("g_wr_slot", wd.spill_ptr, T::W(xslot)),
            ("g_wr_data", wd.entry, T::V(xv)),
            ("answer", ANSWER_BITS, T::W(code)),
            ("answer_value", wd.entry, T::V(value)),
        ]
        .into_iter()
        .chain(restart)
        {
            outputs.push(Port { name: f(name), bits, t });
        }
    }
    Ok(Circuit { sym: s, lanes: ws, regs: decl.regs, inputs, outputs, shapes, paths, max_plan_paths })
}

/// Width of the `answer` output.
pub const ANSWER_BITS: u32 = 4;

fn nonzero(s: &mut Sym, x: W) -> B {
    let z = s.word(0);
    s.ne(x, z)
}
