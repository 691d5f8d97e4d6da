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
//!
//! The warp's stack registers are where the terms grow (each lane reads and writes stacks at
//! indices only known at run time), so they are built to be shared:
//!
//! - **Reads** ([`Stacks`]): a read at an index is made once per stage and reused by every
//!   path; an index that multiplexers choose among indices already read or constant (an idle
//!   search's result, a chain walk's next member) reads as a multiplexer of those reads; any
//!   other index through a tree on its bits, as deep as the index is wide.
//! - **Writes** ([`merge_plans`]): a path's writes keep only the fields they change
//!   ([`writes_of`]), and the paths' write sequences are laid on common slots (a shortest common
//!   sequence of their targets, [`write_slots`]), merged slot by slot like the other results,
//!   and applied to the warp's stacks once per lane rather than once per path.

use std::cell::RefCell;
use std::collections::HashMap;

use rtl::config::{Config, Overflow, Widths};
use rtl::logic::Logic;
use rtl::stack_manager::cycle::{self, CycleIn, Journal, Registers, WriteOf};
use rtl::stack_manager::policy::{Design, RbOp, Regs, Thread, UopL};
use rtl::stack_manager::{CmdOf, SrcOf, StackError, StackRegsOf, ThreadRegsOf, UopOf, POISON};

use crate::prove::query::{self, code, encode, mux_enc, Enc};
use crate::prove::sym::{Node, Sort, Sym, B, V, W};

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
    /// The stack registers `stack_q` reads.
    stacks: &'a Stacks,
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

/// The warp's stack registers as a stage reads them, and the reads made so far by index term.
struct Stacks {
    regs: Vec<Regs<Sym>>,
    reads: RefCell<HashMap<u32, Regs<Sym>>>,
}

/// How many multiplexers deep an index is read through ([`Stacks::read`]).
const READ_DEPTH: u32 = 8;

impl Stacks {
    fn new(regs: Vec<Regs<Sym>>) -> Stacks {
        Stacks { regs, reads: RefCell::default() }
    }

    /// Stack `s`. An index multiplexers choose among indices already read or constant
    /// (`c ? a : b`, as a search over a chain's members gives) reads as
    /// `c ? stack a : stack b` from those reads; any other through a multiplexer tree on its
    /// bits ([`read_tree`]). An index reads as the same term every time.
    fn read(&self, l: &mut Sym, s: W) -> Regs<Sym> {
        if let Some(&r) = self.reads.borrow().get(&s.0) {
            return r;
        }
        let r = match *l.node(s.0) {
            Node::Ite(Sort::Word, c, a, b)
                if self.known(l, a, READ_DEPTH) && self.known(l, b, READ_DEPTH) =>
            {
                let (ra, rb) = (self.read(l, W(a)), self.read(l, W(b)));
                StackRegsOf::mux(l, B(c), ra, rb)
            }
            _ => read_tree(l, &self.regs, s),
        };
        self.reads.borrow_mut().insert(s.0, r);
        r
    }

    /// Index `i` reads from reads already made: it was read, is a constant, or multiplexers
    /// at most `depth` deep choose among such indices.
    fn known(&self, l: &Sym, i: u32, depth: u32) -> bool {
        match *l.node(i) {
            Node::Word(_) => true,
            _ if self.reads.borrow().contains_key(&i) => true,
            Node::Ite(Sort::Word, _, a, b) => {
                depth > 0 && self.known(l, a, depth - 1) && self.known(l, b, depth - 1)
            }
            _ => false,
        }
    }
}

/// Stack `s` of the warp's `stacks`: a multiplexer tree on the bits of `s`, as deep as the
/// index is wide rather than as the warp is long; past the warp, [`outside`].
fn read_tree(l: &mut Sym, stacks: &[Regs<Sym>], s: W) -> Regs<Sym> {
    if let Node::Word(k) = *l.node(s.0) {
        return stacks.get(k as usize).copied().unwrap_or_else(|| outside(l));
    }
    let past = outside(l);
    let n = stacks.len().next_power_of_two();
    let mut level: Vec<Regs<Sym>> = (0..n).map(|k| stacks.get(k).copied().unwrap_or(past)).collect();
    let mut bit = 1;
    while level.len() > 1 {
        let m = l.word(bit);
        let masked = l.mask(s, m);
        let clear = l.eq_k(masked, 0);
        level = level.chunks(2).map(|p| StackRegsOf::mux(l, clear, p[0], p[1])).collect();
        bit <<= 1;
    }
    let inside = l.lt_k(s, n as u32);
    StackRegsOf::mux(l, inside, level[0], past)
}

impl Registers<Sym> for View<'_> {
    fn stack_q(&self, l: &mut Sym, s: W) -> Regs<Sym> {
        self.stacks.read(l, s)
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

/// Stack registers `stacks` after `writes`, in order ([`write_stack`]).
fn resolve(s: &mut Sym, stacks: &[Regs<Sym>], writes: &[Write]) -> Vec<Regs<Sym>> {
    let mut out = stacks.to_vec();
    for x in writes {
        let mut parts = Vec::new();
        stack_parts(&x.regs, &mut parts);
        let fields: Vec<(B, T)> = x.sets.iter().zip(parts).map(|(&set, t)| (s.bit(set), t)).collect();
        write_stack(s, &mut out, x.at, &fields);
    }
    out
}

/// Writes to stack `at` of `stacks` each field whose bit is set (`fields`, in
/// [`stack_parts`]'s order): a multiplexer per stack the index may name and field written.
fn write_stack(s: &mut Sym, stacks: &mut [Regs<Sym>], at: W, fields: &[(B, T)]) {
    for (k, x) in stacks.iter_mut().enumerate() {
        let here = s.eq_k(at, k as u32);
        let mut parts = Vec::new();
        stack_parts(x, &mut parts);
        for (part, &(set, value)) in parts.iter_mut().zip(fields) {
            let hit = s.and(set, here);
            if s.maybe(hit) {
                *part = T::mux(s, hit, value, *part);
            }
        }
        *x = stack_from(&mut parts.into_iter());
    }
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
        let none = query::no_uop(s);
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
    wd: &Widths,
    lane: &Lane,
    j: u32,
    stacks: &Stacks,
    d: &Journal<Sym>,
) -> Result<SeqOut, String> {
    let writes: Vec<Write> = writes_of(s, stacks, &d.stacks).iter().map(|x| fit(s, wd, x)).collect();
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
        stacks: resolve(s, &stacks.regs, &writes),
    };
    let twice = |what: &str| Err(format!("lane {j}: two {what} in one cycle"));
    for x in &d.writes {
        match *x {
            WriteOf::Seq { issued, inflight, latch, .. } => {
                o.issued = s.bit(issued);
                o.inflight = match inflight {
                    Some(u) => encode(s, &u),
                    None => query::no_uop(s),
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

/// The program `prog` (micro-ops appended when their bit is set) as `slots` fixed positions:
/// `(valid, micro-op)`, valid ones first. A micro-op goes to the slot its position names, the
/// number of valid micro-ops before it; only the positions that number can take are built:
/// the earlier micro-ops that are valid whenever this one is (a set bit, or a bit this one's
/// implies: a flush's `i < n` implies every `i' < n` for `i' < i`) count as one each, and the
/// others add what their bits can sum to.
fn compact(s: &mut Sym, prog: &[(B, UopL<Sym>)], slots: usize) -> Vec<(B, Enc)> {
    if prog.iter().all(|(g, _)| s.bool_of(g.0).is_some()) {
        // Every position is a constant: the proofs' compaction builds nothing to prune.
        return query::compact(s, prog, slots);
    }
    let none = query::no_uop(s);
    let no = s.bit(false);
    let mut out = vec![(no, none); slots];
    for (i, &(g, u)) in prog.iter().enumerate() {
        if !s.maybe(g) {
            continue;
        }
        let e = encode(s, &u);
        let mut base = 0usize;
        let mut open: Vec<B> = Vec::new();
        for &(h, _) in &prog[..i] {
            if s.bool_of(h.0) == Some(true) || implies(s, g, h) {
                base += 1;
            } else if s.maybe(h) {
                open.push(h);
            }
        }
        // What the open bits can sum to: each distinct bit adds its multiplicity or nothing.
        let mut sums = vec![true];
        let mut seen: Vec<B> = Vec::new();
        for &h in &open {
            if seen.contains(&h) {
                continue;
            }
            seen.push(h);
            let m = open.iter().filter(|&&x| x == h).count();
            let mut next = sums.clone();
            next.resize(sums.len() + m, false);
            for (k, &on) in sums.iter().enumerate() {
                next[k + m] |= on;
            }
            sums = next;
        }
        let mut pos = s.word(base as u32);
        for &h in &open {
            let one = s.count(h);
            pos = s.add(pos, one);
        }
        for (k, slot) in out.iter_mut().enumerate().skip(base) {
            if !sums.get(k - base).copied().unwrap_or(false) {
                continue;
            }
            query::place(s, slot, g, pos, k as u32, e);
        }
    }
    out
}

/// `g` implies `h`, as far as the terms show: the same bit, or `a < x` and `b < x` with
/// constants `b <= a`.
fn implies(s: &Sym, g: B, h: B) -> bool {
    if g == h {
        return true;
    }
    match (s.node(g.0), s.node(h.0)) {
        (&Node::Lt(a, x), &Node::Lt(b, y)) if x == y => match (s.node(a), s.node(b)) {
            (&Node::Word(a), &Node::Word(b)) => b <= a,
            _ => false,
        },
        _ => false,
    }
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

/// Lane `j`'s plan stage from journal `d`, over the warp's stack registers `stacks`: the
/// path's stack writes ([`writes_of`]) and, as flat terms, the lane's thread registers, RB and
/// program, and its answer (code, popped entry; with `restarts`, whether a pop answered
/// Restart).
#[allow(clippy::too_many_arguments)]
fn plan_parts(
    s: &mut Sym,
    j: u32,
    q_slots: usize,
    restarts: bool,
    stacks: &Stacks,
    thread: Thread<Sym>,
    rb: &Rb,
    queue: (W, &[Enc]),
    d: &Journal<Sym>,
) -> Result<PlanOut, String> {
    let writes = writes_of(s, stacks, &d.stacks);
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
    Ok((writes, out))
}

/// What one path of a lane's plan leaves: its stack writes in order, and its other results as
/// flat terms.
type PlanOut = (Vec<Write>, Vec<T>);

/// Stack registers as a list of fields, in [`stack_parts`]'s order.
const STACK_FIELDS: usize = 7;

/// One write of a plan to the stack registers: the stack's index, its registers after the
/// write, and which fields the write sets (the others hold what the stack held just before).
#[derive(Clone, Copy, Debug)]
struct Write {
    at: W,
    regs: Regs<Sym>,
    sets: [bool; STACK_FIELDS],
}

/// The writes of one path's list `list` (its stack changes in order, over the warp's `stacks`),
/// each value cut to its registers' widths ([`fit`]). A field a write sets is one whose term
/// differs from the field as the list so far leaves that stack, the read the plan made before
/// writing: a write that moves one stack's Priority leaves its other six fields alone, and
/// later lanes see them through no multiplexer of this one.
fn writes_of(s: &mut Sym, stacks: &Stacks, list: &[(W, Regs<Sym>)]) -> Vec<Write> {
    (0..list.len())
        .map(|m| {
            let (at, regs) = list[m];
            let held = stacks.read(s, at);
            let before = cycle::lookup(s, &list[..m], at, held);
            let (mut now, mut was) = (Vec::new(), Vec::new());
            stack_parts(&regs, &mut now);
            stack_parts(&before, &mut was);
            let sets = std::array::from_fn(|f| now[f] != was[f]);
            Write { at, regs, sets }
        })
        .collect()
}

/// `x` cut to its low `bits` (its register's width); a variable or a constant as it is.
fn cut(s: &mut Sym, x: W, bits: u32) -> W {
    if bits == 0 || bits >= 32 || matches!(s.node(x.0), Node::Var(..) | Node::Word(_)) {
        return x;
    }
    let m = s.word((1u32 << bits) - 1);
    s.mask(x, m)
}

/// Write `x` with the fields it sets cut to their registers' widths.
fn fit(s: &mut Sym, wd: &Widths, x: &Write) -> Write {
    let mut parts = Vec::new();
    stack_parts(&x.regs, &mut parts);
    let bits = [wd.top, wd.bottom, 0, 0, wd.next_tid, wd.priority, wd.flush];
    for ((part, &set), &bits) in parts.iter_mut().zip(&x.sets).zip(&bits) {
        if let (true, T::W(w)) = (set, *part) {
            *part = T::W(cut(s, w, bits));
        }
    }
    Write { regs: stack_from(&mut parts.into_iter()), ..*x }
}

/// Where a stack write may land: a constant index names its stack, any other index may name
/// any stack.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Stack(u32),
    Any,
}

fn target(s: &Sym, i: W) -> Target {
    match *s.node(i.0) {
        Node::Word(k) => Target::Stack(k),
        _ => Target::Any,
    }
}

/// A short sequence of write slots that holds every path's write sequence in order, built path
/// by path: each step keeps a longest common subsequence of the slots so far and the next
/// path's targets, and interleaves the rest.
fn write_slots(paths: &[Vec<Target>]) -> Vec<Target> {
    let mut all: Vec<Target> = Vec::new();
    for p in paths {
        let (n, m) = (all.len(), p.len());
        // lcs[a][b]: longest common subsequence of all[a..] and p[b..].
        let mut lcs = vec![vec![0usize; m + 1]; n + 1];
        for a in (0..n).rev() {
            for b in (0..m).rev() {
                lcs[a][b] =
                    if all[a] == p[b] { lcs[a + 1][b + 1] + 1 } else { lcs[a + 1][b].max(lcs[a][b + 1]) };
            }
        }
        let (mut a, mut b) = (0, 0);
        let mut next = Vec::with_capacity(n + m);
        while a < n || b < m {
            if a < n && b < m && all[a] == p[b] {
                next.push(all[a]);
                a += 1;
                b += 1;
            } else if b == m || (a < n && lcs[a + 1][b] >= lcs[a][b + 1]) {
                next.push(all[a]);
                a += 1;
            } else {
                next.push(p[b]);
                b += 1;
            }
        }
        all = next;
    }
    all
}

/// The write each slot of `slots` takes from `writes` (targets `targets`): the leftmost
/// embedding, in order.
fn slot_of(slots: &[Target], targets: &[Target], writes: &[Write]) -> Vec<Option<Write>> {
    let mut at = vec![None; slots.len()];
    let mut k = 0;
    for (t, &x) in targets.iter().zip(writes) {
        while slots[k] != *t {
            k += 1;
        }
        at[k] = Some(x);
        k += 1;
    }
    at
}

/// `writes` without those the same path repeats later to the same index term: the later write
/// sets what the earlier one set as well (its fields hold the earlier one's values).
fn last_writes(writes: &[Write]) -> Vec<Write> {
    let mut out: Vec<Write> = Vec::new();
    for (k, x) in writes.iter().enumerate() {
        let mut x = *x;
        for y in &writes[..k] {
            if y.at == x.at {
                for f in 0..STACK_FIELDS {
                    x.sets[f] |= y.sets[f];
                }
            }
        }
        if writes[k + 1..].iter().all(|y| y.at != x.at) {
            out.push(x);
        }
    }
    out
}

/// Every path's results and stack writes merged into one ([`merge`]), the writes resolved
/// once against `stacks`. The paths' write sequences ([`last_writes`]) are laid out on common
/// slots ([`write_slots`]): a slot holds the index, the value and, per field, whether it is
/// set; its index is a constant when every path writing there names that stack. A lane's plan
/// then resolves each slot's set fields once against the warp's stacks rather than each
/// path's writes. Each path's valid slots are its own writes in its own order, so the stacks
/// come out as each path's writes leave them.
fn merge_plans(
    s: &mut Sym,
    wd: &Widths,
    stacks: &[Regs<Sym>],
    paths: Vec<(B, PlanOut)>,
) -> (Vec<Regs<Sym>>, Vec<T>) {
    let writes: Vec<Vec<Write>> =
        paths.iter().map(|(_, (w, _))| last_writes(w).iter().map(|x| fit(s, wd, x)).collect()).collect();
    let targets: Vec<Vec<Target>> =
        writes.iter().map(|w| w.iter().map(|x| target(s, x.at)).collect()).collect();
    let slots = write_slots(&targets);
    let laid: Vec<Vec<Option<Write>>> =
        targets.iter().zip(&writes).map(|(t, w)| slot_of(&slots, t, w)).collect();
    // Where a path leaves a slot or a field unset it carries the value of one that sets it: the
    // slot's multiplexers then have only the written values to choose among.
    let filler: Vec<(W, Vec<T>)> = (0..slots.len())
        .map(|k| {
            let any = laid.iter().rev().find_map(|l| l[k]).expect("a path writes each slot");
            let mut parts = Vec::new();
            stack_parts(&any.regs, &mut parts);
            for (f, part) in parts.iter_mut().enumerate() {
                if let Some(x) = laid.iter().rev().find_map(|l| l[k].filter(|x| x.sets[f])) {
                    let mut p = Vec::new();
                    stack_parts(&x.regs, &mut p);
                    *part = p[f];
                }
            }
            (any.at, parts)
        })
        .collect();
    let (yes, no) = (s.bit(true), s.bit(false));
    let flat = paths
        .into_iter()
        .zip(laid)
        .map(|((c, (_, rest)), l)| {
            let mut out = Vec::new();
            for (k, x) in l.iter().enumerate() {
                let (at, fill) = &filler[k];
                out.push(T::W(x.map_or(*at, |x| x.at)));
                let mut parts = Vec::new();
                if let Some(x) = x {
                    stack_parts(&x.regs, &mut parts);
                }
                for f in 0..STACK_FIELDS {
                    let set = x.is_some_and(|x| x.sets[f]);
                    out.push(T::B(if set { yes } else { no }));
                    out.push(if set { parts[f] } else { fill[f] });
                }
            }
            out.extend(rest);
            (c, out)
        })
        .collect();
    let merged = merge(s, flat);
    let p = &mut merged.into_iter();
    let mut out = stacks.to_vec();
    for _ in &slots {
        let at = w(p);
        let fields: Vec<(B, T)> = (0..STACK_FIELDS).map(|_| (b(p), p.next().expect("a field"))).collect();
        write_stack(s, &mut out, at, &fields);
    }
    let stacks = out;
    (stacks, p.collect())
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
        let seq_view = Stacks::new(view_stacks.clone());
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
                            stacks: &seq_view,
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
                            seq_out(l, &wd, lane, j, &seq_view, &d).map(|o| o.parts())
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
        let plan_view = Stacks::new(view_stacks.clone());
        {
            let cond = s.eq_k(li.cmd_kind, CMD_NONE);
            let mut out = Vec::new();
            let th = lane.thread;
            out.extend([T::B(th.overflow), T::W(th.spill_ptr), T::B(th.done), T::W(rb_after.count)]);
            out.extend(rb_after.e.iter().map(|&x| T::V(x)));
            queue_parts(count, &slots, &mut out);
            let (z, zv) = (s.word(0), s.val(0));
            out.extend([T::W(z), T::V(zv)]);
            if restarts {
                out.push(T::B(s.bit(false)));
            }
            results.push((cond, (Vec::new(), out)));
        }
        for (k, cmd) in
            [(CMD_PUSH, CmdOf::Push(li.cmd_value)), (CMD_POP, CmdOf::Pop), (CMD_FINISH, CmdOf::Finish)]
        {
            let cond = s.eq_k(li.cmd_kind, k);
            let view = View {
                stacks: &plan_view,
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
                let mut d = Journal::<Sym>::default();
                cycle::plan(l, &Design, cfg, &wd, &view, &[(j, cmd)], &mut d);
                plan_parts(l, j, q_slots, restarts, &plan_view, lane.thread, &rb_after, (count, &slots), &d)
            });
            shapes += 1;
            paths += found.len();
            max_plan_paths = max_plan_paths.max(found.len());
            for (pc, r) in found {
                let c = s.and(cond, pc);
                results.push((c, r?));
            }
        }
        let (stacks, merged) = merge_plans(&mut s, &wd, &view_stacks, results);
        view_stacks = stacks;
        let p = &mut merged.into_iter();
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

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn target() -> impl Strategy<Value = Target> {
        prop_oneof![(0u32..3).prop_map(Target::Stack), Just(Target::Any)]
    }

    /// `p` is `slots` with some entries left out, in order.
    fn embeds(p: &[Target], slots: &[Target]) -> bool {
        let mut it = slots.iter();
        p.iter().all(|t| it.any(|s| s == t))
    }

    proptest! {
        /// Every path's write targets embed in the common slots in order, so each path's writes
        /// apply in its own order; the slots are at least as long as the longest path and no
        /// longer than all paths together, and a path the slots already hold adds none.
        #[test]
        fn every_paths_writes_embed_in_the_slots_in_order(
            paths in prop::collection::vec(prop::collection::vec(target(), 0..6), 1..6),
        ) {
            let slots = write_slots(&paths);
            for p in &paths {
                prop_assert!(embeds(p, &slots), "{p:?} in {slots:?}");
            }
            prop_assert!(slots.len() >= paths.iter().map(Vec::len).max().unwrap_or(0));
            prop_assert!(slots.len() <= paths.iter().map(Vec::len).sum::<usize>());
            let mut again = paths.clone();
            again.push(paths[0].clone());
            prop_assert_eq!(write_slots(&again), slots);
        }

        /// A path's writes reduced to the last write to each index: one per index, in the order
        /// of their last writes, each setting every field any write to that index set.
        #[test]
        fn last_writes_keep_one_write_per_index_with_every_field_set(
            list in prop::collection::vec((0u32..3, prop::array::uniform7(any::<bool>())), 0..8),
        ) {
            let mut s = Sym::default();
            let regs = outside(&mut s);
            let at: Vec<W> = (0..3).map(|k| s.var_word(&format!("i{k}"))).collect();
            let writes: Vec<Write> =
                list.iter().map(|&(i, sets)| Write { at: at[i as usize], regs, sets }).collect();
            let out = last_writes(&writes);
            let mut order: Vec<u32> = Vec::new();
            for &(i, _) in list.iter().rev() {
                if !order.contains(&i) {
                    order.insert(0, i);
                }
            }
            prop_assert_eq!(out.iter().map(|x| x.at).collect::<Vec<_>>(), order.iter().map(|&i| at[i as usize]).collect::<Vec<_>>());
            for (x, &i) in out.iter().zip(&order) {
                let want: [bool; STACK_FIELDS] = std::array::from_fn(|f| list.iter().any(|&(j, sets)| j == i && sets[f]));
                prop_assert_eq!(x.sets, want);
            }
        }
    }
}
