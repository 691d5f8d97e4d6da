//! The whole-cycle equivalence: for every well-formed state of a warp and a given control shape
//! of the cycle (which lanes command, which micro-ops are in flight or queued and which of them
//! complete), the design's cycle ([`rtl::stack_manager::cycle`]: completions, issue, plans,
//! the merge of their writes and the clock edge) leaves the same next state and puts out the
//! same requests and answers as the specification's cycle ([`spec_cycle`]).
//!
//! Both run on one register-file type, [`WarpState`], written over [`Logic`]: the design reads
//! it through [`Registers`] and writes it through [`Store`] (the same two traits the simulator's
//! stack manager implements on integers); the specification updates it in place, one effect
//! after another, as SPEC sections 3 and 5 describe them. Addresses, register values and data
//! are symbolic; the control shape is concrete and enumerated by the obligations
//! ([`obligations`]).
//!
//! Memory contents: every SH word of the warp is a free variable; each lane's global region
//! has [`GLOBAL_SLOTS`] free words and one more free value for every slot past them.

use rtl::config::Config;
use rtl::logic::Logic;
use rtl::stack_manager::cycle::{self, CycleIn, CycleSteps, Journal, Registers, Store};
use rtl::stack_manager::policy::{RbOp, Regfile, Regs, Thread, UopL};
use rtl::stack_manager::{CmdOf, SrcOf, StackError, StackRegsOf, ThreadRegsOf, UopOf, POISON};

use super::query::{compact, eq_bit, error_code, finish, mux_enc, sym_stack, well_formed, Enc, Kind, Query};
use super::spec::Spec;
use super::sym::{Sym, B, V, W};

/// Free words of each lane's global region in a query.
pub const GLOBAL_SLOTS: u32 = 4;

/// The kind of a micro-op in a lane's sequencer (its fields are symbolic).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum UopKind {
    ShLoad,
    /// An SH store of an immediate.
    ShStore,
    /// An SH store of the latch (queued only: a store captures its data when it issues).
    ShStoreLatch,
    GlobalLoad,
    GlobalStore,
    GlobalStoreLatch,
    RbBottom,
    Release,
}

impl UopKind {
    pub const QUEUED: [UopKind; 8] = [
        UopKind::ShLoad,
        UopKind::ShStore,
        UopKind::ShStoreLatch,
        UopKind::GlobalLoad,
        UopKind::GlobalStore,
        UopKind::GlobalStoreLatch,
        UopKind::RbBottom,
        UopKind::Release,
    ];

    fn name(self) -> &'static str {
        match self {
            UopKind::ShLoad => "sh-load",
            UopKind::ShStore => "sh-store",
            UopKind::ShStoreLatch => "sh-store(latch)",
            UopKind::GlobalLoad => "global-load",
            UopKind::GlobalStore => "global-store",
            UopKind::GlobalStoreLatch => "global-store(latch)",
            UopKind::RbBottom => "rb-bottom",
            UopKind::Release => "release",
        }
    }

    /// Goes out as a request and stays in flight (an SH access, a global load, and with
    /// acknowledged stores a global store).
    fn waits(self, acked: bool) -> bool {
        match self {
            UopKind::ShLoad | UopKind::ShStore | UopKind::ShStoreLatch | UopKind::GlobalLoad => true,
            UopKind::GlobalStore | UopKind::GlobalStoreLatch => acked,
            UopKind::RbBottom | UopKind::Release => false,
        }
    }

    fn is_sh(self) -> bool {
        matches!(self, UopKind::ShLoad | UopKind::ShStore | UopKind::ShStoreLatch)
    }
}

/// One lane's part of a cycle's control shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LaneShape {
    pub lane: u32,
    /// The micro-op in flight (an SH access, a global load or an acknowledged global store).
    pub inflight: Option<UopKind>,
    /// Its completion arrives this cycle (the bank arbiter's `done` for an SH access, the
    /// response FIFO's `deq` otherwise).
    pub completes: bool,
    /// The head of the lane's micro-op queue.
    pub head: Option<UopKind>,
    /// The data latch holds a value.
    pub latch: bool,
    /// The lane's command this cycle.
    pub cmd: Option<Kind>,
}

impl LaneShape {
    pub fn idle(lane: u32) -> LaneShape {
        LaneShape { lane, inflight: None, completes: false, head: None, latch: false, cmd: None }
    }

    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        if let Some(k) = self.inflight {
            parts.push(format!("{} in flight{}", k.name(), if self.completes { " completes" } else { "" }));
        }
        if let Some(k) = self.head {
            parts.push(format!("{} queued", k.name()));
        }
        if self.latch {
            parts.push("latch full".into());
        }
        if let Some(c) = self.cmd {
            parts.push(c.name().into());
        }
        if parts.is_empty() {
            parts.push("idle".into());
        }
        format!("lane {}: {}", self.lane, parts.join(", "))
    }
}

/// A lane's sequencer: the micro-op in flight, the queue (valid bit, micro-op) and the latch.
#[derive(Debug)]
pub struct SeqState<L: Logic> {
    pub inflight: Option<UopL<L>>,
    pub queue: Vec<(L::Bit, UopL<L>)>,
    pub latch: Option<L::Val>,
}

/// What happened to a lane's RB in the cycle (the RB's contents below its ends are not state
/// here: only its length and the entries that went in or out).
#[derive(Clone, Copy, Debug)]
pub enum RbEvent<V> {
    Op(RbOp<V>),
    PushFront(V),
}

/// A lane's RB: its length, its two ends, and the cycle's changes in order.
#[derive(Debug)]
pub struct RbState<L: Logic> {
    pub len: L::Word,
    pub front: L::Val,
    pub back: L::Val,
    pub log: Vec<RbEvent<L::Val>>,
}

/// The register file of one warp: every lane's stack, thread, sequencer and RB registers, the
/// warp's SH words and each lane's global region.
#[derive(Debug)]
pub struct WarpState<L: Logic> {
    /// The warp's first thread.
    pub base: u32,
    pub m: u32,
    pub acked: bool,
    pub stacks: Vec<Regs<L>>,
    pub threads: Vec<Thread<L>>,
    pub seq: Vec<SeqState<L>>,
    pub rb: Vec<RbState<L>>,
    /// SH words, `lane × M + entry`.
    pub sh: Vec<L::Val>,
    /// Global regions: the first slots of each lane, and the value of any slot past them.
    pub global: Vec<Vec<L::Val>>,
    pub global_far: Vec<L::Val>,
    /// Global writes of the cycle per lane: (slot, value).
    pub global_writes: Vec<Vec<(L::Word, L::Val)>>,
    /// Stack registers read at an index outside the warp.
    pub outside: Regs<L>,
}

impl<L: Logic> Clone for SeqState<L> {
    fn clone(&self) -> Self {
        SeqState { inflight: self.inflight, queue: self.queue.clone(), latch: self.latch }
    }
}

impl<L: Logic> Clone for RbState<L> {
    fn clone(&self) -> Self {
        RbState { len: self.len, front: self.front, back: self.back, log: self.log.clone() }
    }
}

impl<L: Logic> Clone for WarpState<L> {
    fn clone(&self) -> Self {
        WarpState {
            base: self.base,
            m: self.m,
            acked: self.acked,
            stacks: self.stacks.clone(),
            threads: self.threads.clone(),
            seq: self.seq.clone(),
            rb: self.rb.clone(),
            sh: self.sh.clone(),
            global: self.global.clone(),
            global_far: self.global_far.clone(),
            global_writes: self.global_writes.clone(),
            outside: self.outside,
        }
    }
}

impl<L: Logic> WarpState<L> {
    fn lanes(&self) -> u32 {
        self.stacks.len() as u32
    }
    fn lane(&self, t: u32) -> usize {
        (t - self.base) as usize
    }
    fn hit(&self, l: &mut L, s: L::Word, j: usize) -> L::Bit {
        l.eq_k(s, self.base + j as u32)
    }
    /// Lane `j` that word `s` names, when the instance knows values (integers): indexing then
    /// replaces the multiplexer over the warp. `Err` when the word names no lane.
    fn known_lane(&self, l: &L, s: L::Word) -> Option<Result<usize, ()>> {
        if !l.exact() {
            return None;
        }
        let v = l.concrete(s);
        Some(match v.checked_sub(self.base) {
            Some(j) if j < self.lanes() => Ok(j as usize),
            _ => Err(()),
        })
    }
    fn read_stack(&self, l: &mut L, s: L::Word) -> Regs<L> {
        if let Some(j) = self.known_lane(l, s) {
            return j.map_or(self.outside, |j| self.stacks[j]);
        }
        let mut v = self.outside;
        for j in (0..self.stacks.len()).rev() {
            let hit = self.hit(l, s, j);
            v = StackRegsOf::mux(l, hit, self.stacks[j], v);
        }
        v
    }
    fn write_stack(&mut self, l: &mut L, s: L::Word, r: Regs<L>) {
        if let Some(j) = self.known_lane(l, s) {
            if let Ok(j) = j {
                self.stacks[j] = r;
            }
            return;
        }
        for j in 0..self.stacks.len() {
            let hit = self.hit(l, s, j);
            if l.maybe(hit) {
                self.stacks[j] = StackRegsOf::mux(l, hit, r, self.stacks[j]);
            }
        }
    }
    fn read_sh(&self, l: &mut L, stack: L::Word, entry: L::Word) -> L::Val {
        if let Some(j) = self.known_lane(l, stack) {
            let e = l.concrete(entry);
            return match j {
                Ok(j) if e < self.m => self.sh[j * self.m as usize + e as usize],
                _ => l.val(POISON),
            };
        }
        let mut v = l.val(POISON);
        for j in (0..self.stacks.len()).rev() {
            for e in (0..self.m).rev() {
                let a = self.hit(l, stack, j);
                let b = l.eq_k(entry, e);
                let hit = l.and(a, b);
                v = l.mux_val(hit, self.sh[j * self.m as usize + e as usize], v);
            }
        }
        v
    }
    fn write_sh(&mut self, l: &mut L, stack: L::Word, entry: L::Word, x: L::Val) {
        if let Some(j) = self.known_lane(l, stack) {
            let e = l.concrete(entry);
            if let (Ok(j), true) = (j, e < self.m) {
                self.sh[j * self.m as usize + e as usize] = x;
            }
            return;
        }
        for j in 0..self.stacks.len() {
            for e in 0..self.m {
                let a = self.hit(l, stack, j);
                let b = l.eq_k(entry, e);
                let hit = l.and(a, b);
                if l.maybe(hit) {
                    let k = j * self.m as usize + e as usize;
                    self.sh[k] = l.mux_val(hit, x, self.sh[k]);
                }
            }
        }
    }
    fn read_global(&self, l: &mut L, t: u32, slot: L::Word) -> L::Val {
        let j = self.lane(t);
        if l.exact() {
            let k = l.concrete(slot) as usize;
            return self.global[j].get(k).copied().unwrap_or(self.global_far[j]);
        }
        let mut v = self.global_far[j];
        for k in (0..self.global[j].len()).rev() {
            let hit = l.eq_k(slot, k as u32);
            v = l.mux_val(hit, self.global[j][k], v);
        }
        v
    }
    fn busy(&self, j: usize) -> bool {
        self.seq[j].inflight.is_some() || !self.seq[j].queue.is_empty()
    }
    fn rb_op(&mut self, l: &mut L, t: u32, ev: RbEvent<L::Val>) {
        let j = self.lane(t);
        let rb = &mut self.rb[j];
        match ev {
            RbEvent::Op(RbOp::PushBack(v)) => {
                let empty = l.eq_k(rb.len, 0);
                rb.front = l.mux_val(empty, v, rb.front);
                rb.back = v;
                rb.len = l.add_k(rb.len, 1);
            }
            RbEvent::PushFront(v) => {
                let empty = l.eq_k(rb.len, 0);
                rb.back = l.mux_val(empty, v, rb.back);
                rb.front = v;
                rb.len = l.add_k(rb.len, 1);
            }
            RbEvent::Op(RbOp::PopBack | RbOp::PopFront) => rb.len = l.sub_k(rb.len, 1),
        }
        rb.log.push(ev);
    }
}

impl<L: Logic> Registers<L> for WarpState<L> {
    fn stack_q(&self, l: &mut L, s: L::Word) -> Regs<L> {
        self.read_stack(l, s)
    }
    fn thread_q(&self, _: &mut L, t: u32) -> Thread<L> {
        self.threads[self.lane(t)]
    }
    fn done_q(&self, l: &mut L, s: L::Word) -> L::Bit {
        if let Some(j) = self.known_lane(l, s) {
            return j.map_or_else(|_| l.bit(true), |j| self.threads[j].done);
        }
        let mut v = l.bit(true);
        for j in (0..self.threads.len()).rev() {
            let hit = self.hit(l, s, j);
            v = l.mux_bit(hit, self.threads[j].done, v);
        }
        v
    }
    fn busy_q(&self, l: &mut L, t: u32) -> L::Bit {
        let b = self.busy(self.lane(t));
        l.bit(b)
    }
    fn inflight_q(&self, t: u32) -> Option<UopL<L>> {
        self.seq[self.lane(t)].inflight
    }
    fn head_q(&self, t: u32) -> Option<UopL<L>> {
        self.seq[self.lane(t)].queue.first().map(|x| x.1)
    }
    fn latch_q(&self, t: u32) -> Option<L::Val> {
        self.seq[self.lane(t)].latch
    }
    fn rb_len_q(&self, _: &mut L, t: u32) -> L::Word {
        self.rb[self.lane(t)].len
    }
    fn rb_front_q(&self, _: &mut L, t: u32) -> L::Val {
        self.rb[self.lane(t)].front
    }
    fn rb_back_q(&self, _: &mut L, t: u32) -> L::Val {
        self.rb[self.lane(t)].back
    }
    fn sh_q(&self, l: &mut L, stack: L::Word, entry: L::Word) -> L::Val {
        self.read_sh(l, stack, entry)
    }
    fn global_q(&self, l: &mut L, t: u32, slot: L::Word) -> L::Val {
        self.read_global(l, t, slot)
    }
    fn next_queued(&self, from: u32) -> Option<u32> {
        (from.max(self.base)..self.base + self.lanes()).find(|&t| !self.seq[self.lane(t)].queue.is_empty())
    }
    fn acked_stores(&self) -> bool {
        self.acked
    }
}

impl<L: Logic> Store<L> for WarpState<L> {
    fn set_stack(&mut self, l: &mut L, s: L::Word, r: Regs<L>) {
        self.write_stack(l, s, r)
    }
    fn set_thread(&mut self, t: u32, r: Thread<L>) {
        let j = self.lane(t);
        self.threads[j] = r;
    }
    fn rb(&mut self, l: &mut L, t: u32, op: RbOp<L::Val>) {
        self.rb_op(l, t, RbEvent::Op(op))
    }
    fn rb_push_front(&mut self, l: &mut L, t: u32, v: L::Val) {
        self.rb_op(l, t, RbEvent::PushFront(v))
    }
    fn sh(&mut self, l: &mut L, stack: L::Word, entry: L::Word, v: L::Val) {
        self.write_sh(l, stack, entry, v)
    }
    fn global(&mut self, _: &mut L, t: u32, slot: L::Word, v: L::Val) {
        let j = self.lane(t);
        self.global_writes[j].push((slot, v));
    }
    fn seq(&mut self, t: u32, issued: bool, inflight: Option<UopL<L>>, latch: Option<L::Val>) {
        let j = self.lane(t);
        let q = &mut self.seq[j];
        if issued {
            q.queue.remove(0);
        }
        (q.inflight, q.latch) = (inflight, latch);
    }
    fn emit(&mut self, _: &mut L, t: u32, valid: L::Bit, u: UopL<L>) {
        let j = self.lane(t);
        self.seq[j].queue.push((valid, u));
    }
}

/// What one cycle put out besides the next state: per lane its SH and global request and its
/// command's answer.
#[derive(Clone, Debug, Default)]
pub struct Outputs<W, V> {
    /// (lane, stack, entry, write).
    pub sh_req: Vec<(u32, W, W, bool)>,
    /// (lane, slot, write).
    pub g_req: Vec<(u32, W, bool)>,
    /// (lane, answer).
    pub answers: Vec<(u32, Result<Option<V>, StackError>)>,
}

/// The design's cycle on `q`: [`cycle::eval`], then [`cycle::apply`] onto a copy of `q`.
pub fn design_cycle<L: Logic, P: CycleSteps>(
    l: &mut L,
    steps: &P,
    cfg: &Config,
    q: &WarpState<L>,
    cmds: &[(u32, CmdOf<L::Val>)],
    done: &[u32],
    deq: Option<u32>,
) -> (WarpState<L>, Outputs<L::Word, L::Val>, Journal<L>) {
    let w = cfg.widths().expect("a valid configuration");
    let mut d = Journal::<L>::default();
    cycle::eval(l, steps, cfg, &w, q, &CycleIn { cmds, done, deq, now: 0 }, &mut d);
    let mut next = q.clone();
    next.rb.iter_mut().for_each(|r| r.log.clear());
    next.global_writes.iter_mut().for_each(|g| g.clear());
    cycle::apply(l, &d, &mut next);
    let out = Outputs {
        sh_req: d.sh_req.iter().map(|r| (r.thread - q.base, r.stack, r.entry, r.write)).collect(),
        g_req: d.g_req.iter().map(|r| (r.thread - q.base, r.slot, r.write)).collect(),
        answers: cmds
            .iter()
            .filter(|c| !matches!(c.1, CmdOf::None))
            .map(|&(t, _)| (t - q.base, d.answer(t)))
            .collect(),
    };
    (next, out, d)
}

/// The specification's cycle, from SPEC sections 3 and 5, one effect after another on the
/// state itself:
///
/// 1. every completion arriving this cycle lands: a load's data comes into the thread's latch,
///    a store's word is written; memory is read as the cycle began (a load and a store of one
///    word in one cycle read the old word);
/// 2. every thread with nothing in flight sends its next micro-op (a thread's requests are
///    sequential): an SH access or global load goes out and waits for its completion, as does
///    a global store whose acknowledgement is awaited; a posted global store, the RB-bottom
///    fill and a release take effect at once (the release turns its stack Idle); a store takes
///    its data (its immediate, or the latch, POISON if empty) as it goes out;
/// 3. the commands, in order, each as [`Spec::apply`] describes it against the state steps 1–2
///    and the earlier commands left; a thread whose sequencer was busy as the cycle began is
///    refused; a refused command changes nothing.
pub fn spec_cycle<L: Logic>(
    l: &mut L,
    cfg: &Config,
    st: &mut WarpState<L>,
    cmds: &[(u32, CmdOf<L::Val>)],
    done: &[u32],
    deq: Option<u32>,
) -> Outputs<L::Word, L::Val> {
    st.rb.iter_mut().for_each(|r| r.log.clear());
    st.global_writes.iter_mut().for_each(|g| g.clear());
    let busy: Vec<bool> = (0..st.stacks.len()).map(|j| st.busy(j)).collect();
    let mut out = Outputs { sh_req: Vec::new(), g_req: Vec::new(), answers: Vec::new() };
    let data = |l: &mut L, latch: &mut Option<L::Val>, src: SrcOf<L::Val>| match src {
        SrcOf::Value(v) => v,
        SrcOf::Latch => latch.take().unwrap_or_else(|| l.val(POISON)),
    };
    // 1. Completions: the loads read memory as the cycle began, so they land before the
    //    stores.
    let mut arrived: Vec<u32> = done.to_vec();
    arrived.extend(deq);
    for loads in [true, false] {
        for &t in &arrived {
            let j = st.lane(t);
            let is_load = matches!(st.seq[j].inflight, Some(UopOf::ShLoad { .. } | UopOf::GlobalLoad { .. }));
            if is_load != loads {
                continue;
            }
            let Some(u) = st.seq[j].inflight.take() else { continue };
            let mut latch = st.seq[j].latch;
            match u {
                UopOf::ShLoad { stack, entry } => latch = Some(st.read_sh(l, stack, entry)),
                UopOf::GlobalLoad { slot } => latch = Some(st.read_global(l, t, slot)),
                UopOf::ShStore { stack, entry, src } => {
                    let v = data(l, &mut latch, src);
                    st.write_sh(l, stack, entry, v);
                }
                UopOf::GlobalStore { slot, src } => {
                    let v = data(l, &mut latch, src);
                    st.global_writes[j].push((slot, v));
                }
                // Complete at issue; never in flight.
                UopOf::RbBottom | UopOf::Release { .. } => {}
            }
            st.seq[j].latch = latch;
        }
    }
    // 2. Issue.
    for j in 0..st.stacks.len() {
        let t = st.base + j as u32;
        if st.seq[j].inflight.is_some() || st.seq[j].queue.is_empty() {
            continue;
        }
        let (_, u) = st.seq[j].queue.remove(0);
        let mut latch = st.seq[j].latch;
        let mut inflight = None;
        match u {
            UopOf::ShLoad { stack, entry } => {
                out.sh_req.push((j as u32, stack, entry, false));
                inflight = Some(u);
            }
            UopOf::ShStore { stack, entry, src } => {
                let v = data(l, &mut latch, src);
                out.sh_req.push((j as u32, stack, entry, true));
                inflight = Some(UopOf::ShStore { stack, entry, src: SrcOf::Value(v) });
            }
            UopOf::GlobalLoad { slot } => {
                out.g_req.push((j as u32, slot, false));
                inflight = Some(u);
            }
            UopOf::GlobalStore { slot, src } => {
                let v = data(l, &mut latch, src);
                out.g_req.push((j as u32, slot, true));
                if st.acked {
                    inflight = Some(UopOf::GlobalStore { slot, src: SrcOf::Value(v) });
                } else {
                    st.global_writes[j].push((slot, v));
                }
            }
            UopOf::RbBottom => {
                let v = data(l, &mut latch, SrcOf::Latch);
                st.rb_op(l, t, RbEvent::PushFront(v));
            }
            UopOf::Release { stack } => {
                let r = st.read_stack(l, stack);
                let idle = l.bit(true);
                st.write_stack(l, stack, StackRegsOf { idle, ..r });
            }
        }
        st.seq[j].inflight = inflight;
        st.seq[j].latch = latch;
    }
    // 3. Commands.
    for &(t, cmd) in cmds {
        if matches!(cmd, CmdOf::None) {
            continue;
        }
        let j = st.lane(t);
        // A refused command changes nothing: what a command may change is kept to put back.
        let (stacks, rb, queued) = (st.stacks.clone(), st.rb[j].clone(), st.seq[j].queue.len());
        let th = st.threads[j];
        let b = l.bit(busy[j]);
        let base = st.base;
        let (r, th) = {
            let mut rf = SpecFile { st: &mut *st, t };
            let mut p = Spec { l: &mut *l, rf: &mut rf, cfg, t, base, th };
            let r = p.apply(cmd, b);
            (r, p.th)
        };
        if r.is_ok() {
            st.threads[j] = th;
        } else {
            st.stacks = stacks;
            st.rb[j] = rb;
            st.seq[j].queue.truncate(queued);
        }
        out.answers.push((j as u32, r));
    }
    out
}

/// The specification's register file for one command: the state itself.
struct SpecFile<'a, L: Logic> {
    st: &'a mut WarpState<L>,
    t: u32,
}

impl<L: Logic> Regfile<L> for SpecFile<'_, L> {
    fn stack(&mut self, l: &mut L, s: L::Word) -> Regs<L> {
        self.st.read_stack(l, s)
    }
    fn stack_q(&mut self, l: &mut L, s: L::Word) -> Regs<L> {
        self.st.read_stack(l, s)
    }
    fn set_stack(&mut self, l: &mut L, s: L::Word, r: Regs<L>) {
        self.st.write_stack(l, s, r)
    }
    fn done(&mut self, l: &mut L, s: L::Word) -> L::Bit {
        self.st.done_q(l, s)
    }
    fn rb_len(&mut self, _: &mut L) -> L::Word {
        self.st.rb[self.st.lane(self.t)].len
    }
    fn rb_front(&mut self, _: &mut L) -> L::Val {
        self.st.rb[self.st.lane(self.t)].front
    }
    fn rb_back(&mut self, _: &mut L) -> L::Val {
        self.st.rb[self.st.lane(self.t)].back
    }
    fn rb(&mut self, l: &mut L, op: RbOp<L::Val>) {
        self.st.rb_op(l, self.t, RbEvent::Op(op))
    }
    fn emit(&mut self, _: &mut L, valid: L::Bit, u: UopL<L>) {
        let j = self.st.lane(self.t);
        self.st.seq[j].queue.push((valid, u));
    }
}

// ---- the query ----------------------------------------------------------------------------------

/// A fresh symbolic micro-op of kind `k` for lane `j` (`tag` tells its variables apart).
fn sym_uop(s: &mut Sym, k: UopKind, j: u32, tag: &str) -> UopL<Sym> {
    let w = |s: &mut Sym, f: &str| s.var_word(&format!("{tag}_{f}_{j}"));
    let v = |s: &mut Sym, f: &str| s.var_val(&format!("{tag}_{f}_{j}"));
    match k {
        UopKind::ShLoad => UopOf::ShLoad { stack: w(s, "stack"), entry: w(s, "entry") },
        UopKind::ShStore => {
            UopOf::ShStore { stack: w(s, "stack"), entry: w(s, "entry"), src: SrcOf::Value(v(s, "data")) }
        }
        UopKind::ShStoreLatch => {
            UopOf::ShStore { stack: w(s, "stack"), entry: w(s, "entry"), src: SrcOf::Latch }
        }
        UopKind::GlobalLoad => UopOf::GlobalLoad { slot: w(s, "slot") },
        UopKind::GlobalStore => UopOf::GlobalStore { slot: w(s, "slot"), src: SrcOf::Value(v(s, "data")) },
        UopKind::GlobalStoreLatch => UopOf::GlobalStore { slot: w(s, "slot"), src: SrcOf::Latch },
        UopKind::RbBottom => UopOf::RbBottom,
        UopKind::Release => UopOf::Release { stack: w(s, "stack") },
    }
}

/// The free state of the warp at `base` for control shape `shape` (lanes not named are idle).
pub fn sym_state(s: &mut Sym, cfg: &Config, base: u32, shape: &[LaneShape], acked: bool) -> WarpState<Sym> {
    let ws = cfg.warp_size;
    let m = cfg.sh_entries;
    let stacks = (0..ws).map(|j| sym_stack(s, &j.to_string())).collect();
    let outside = sym_stack(s, "outside");
    let threads = (0..ws)
        .map(|j| ThreadRegsOf {
            overflow: s.var_bit(&format!("overflow_{j}")),
            spill_ptr: s.var_word(&format!("spill_ptr_{j}")),
            done: s.var_bit(&format!("done_{j}")),
        })
        .collect();
    let seq = (0..ws)
        .map(|j| {
            let sh = shape.iter().find(|x| x.lane == j).copied().unwrap_or(LaneShape::idle(j));
            let inflight = sh.inflight.map(|k| sym_uop(s, k, j, "inflight"));
            let queue = sh.head.map(|k| (s.bit(true), sym_uop(s, k, j, "head"))).into_iter().collect();
            let latch = sh.latch.then(|| s.var_val(&format!("latch_{j}")));
            SeqState { inflight, queue, latch }
        })
        .collect();
    let rb = (0..ws)
        .map(|j| RbState {
            len: s.var_word(&format!("rb_len_{j}")),
            front: s.var_val(&format!("rb_front_{j}")),
            back: s.var_val(&format!("rb_back_{j}")),
            log: Vec::new(),
        })
        .collect();
    let sh = (0..ws * m).map(|k| s.var_val(&format!("sh_{}_{}", k / m.max(1), k % m.max(1)))).collect();
    let global =
        (0..ws).map(|j| (0..GLOBAL_SLOTS).map(|k| s.var_val(&format!("global_{j}_{k}"))).collect()).collect();
    let global_far = (0..ws).map(|j| s.var_val(&format!("global_{j}_far"))).collect();
    WarpState {
        base,
        m,
        acked,
        stacks,
        threads,
        seq,
        rb,
        sh,
        global,
        global_far,
        global_writes: vec![Vec::new(); ws as usize],
        outside,
    }
}

/// The cycle's inputs for `shape`: commands (push values fresh), SH completions, the response
/// FIFO's completion.
#[allow(clippy::type_complexity)]
fn inputs(s: &mut Sym, base: u32, shape: &[LaneShape]) -> (Vec<(u32, CmdOf<V>)>, Vec<u32>, Option<u32>) {
    let mut cmds = Vec::new();
    let mut done = Vec::new();
    let mut deq = None;
    for x in shape {
        let t = base + x.lane;
        if let Some(k) = x.cmd {
            let c = match k {
                Kind::Push => CmdOf::Push(s.var_val(&format!("push_value_{}", x.lane))),
                Kind::Pop => CmdOf::Pop,
                Kind::Finish => CmdOf::Finish,
            };
            cmds.push((t, c));
        }
        if let (Some(k), true) = (x.inflight, x.completes) {
            if k.is_sh() {
                done.push(t);
            } else {
                deq = Some(t);
            }
        }
    }
    (cmds, done, deq)
}

/// The well-formedness the cycle query assumes: the invariant of the one-step queries over
/// every lane (busy as the shape says), and every micro-op in flight or queued naming a stack
/// of the warp and an entry below M.
fn assumption(s: &mut Sym, cfg: &Config, st: &WarpState<Sym>) -> B {
    let lanes: Vec<(u32, Thread<Sym>, W, B)> = (0..st.lanes())
        .map(|j| {
            let busy = s.bit(st.busy(j as usize));
            (j, st.threads[j as usize], st.rb[j as usize].len, busy)
        })
        .collect();
    let done: Vec<B> = st.threads.iter().map(|t| t.done).collect();
    let mut ok = well_formed(s, cfg, &st.stacks, &done, &lanes);
    for (j, q) in st.seq.iter().enumerate() {
        for u in q.inflight.iter().chain(q.queue.iter().map(|x| &x.1)) {
            let a = addressed(s, cfg, st.base, u);
            ok = s.and(ok, a);
            if let UopOf::Release { stack } = *u {
                let a = releasable(s, st, j as u32, stack);
                ok = s.and(ok, a);
            }
        }
    }
    ok
}

/// A release lane `j` has queued names what a pop's plan hands back: another lane's stack,
/// whose thread has finished, unlinked (alone on its ring, Priority 0), empty and not yet Idle.
fn releasable(s: &mut Sym, st: &WarpState<Sym>, j: u32, stack: W) -> B {
    let mut ok = s.bit(false);
    for (k, r) in st.stacks.iter().enumerate() {
        if k as u32 == j {
            continue;
        }
        let here = s.eq_k(stack, st.base + k as u32);
        let alone = s.eq_k(r.next_tid, k as u32);
        let rank0 = s.eq_k(r.priority, 0);
        let not_idle = s.not(r.idle);
        let a = s.and(here, st.threads[k].done);
        let a = s.and(a, alone);
        let a = s.and(a, rank0);
        let a = s.and(a, r.empty);
        let a = s.and(a, not_idle);
        ok = s.or(ok, a);
    }
    ok
}

/// Micro-op `u` names a stack of the warp at `base` and an entry below M.
fn addressed(s: &mut Sym, cfg: &Config, base: u32, u: &UopL<Sym>) -> B {
    let (stack, entry) = match *u {
        UopOf::ShLoad { stack, entry } | UopOf::ShStore { stack, entry, .. } => (Some(stack), Some(entry)),
        UopOf::Release { stack } => (Some(stack), None),
        _ => (None, None),
    };
    let mut ok = s.bit(true);
    if let Some(x) = stack {
        let lo = s.word(base);
        let below = s.lt(x, lo);
        let in_lo = s.not(below);
        let hi = s.lt_k(x, base + cfg.warp_size);
        let a = s.and(in_lo, hi);
        ok = s.and(ok, a);
    }
    if let Some(e) = entry {
        let a = s.lt_k(e, cfg.sh_entries.max(1));
        ok = s.and(ok, a);
    }
    ok
}

/// One side's cycle as comparable parts: `(name, value)` in a fixed order.
#[derive(Clone, Debug)]
enum Part {
    W(W),
    B(B),
    V(V),
    E(Enc),
}

fn part_mux(s: &mut Sym, c: B, x: &Part, y: &Part) -> Part {
    match (x, y) {
        (Part::W(a), Part::W(b)) => Part::W(s.mux(c, *a, *b)),
        (Part::B(a), Part::B(b)) => Part::B(s.mux_bit(c, *a, *b)),
        (Part::V(a), Part::V(b)) => Part::V(s.mux_val(c, *a, *b)),
        (Part::E(a), Part::E(b)) => Part::E(mux_enc(s, c, *a, *b)),
        _ => unreachable!("the two paths flatten to one shape"),
    }
}

fn part_eq(s: &mut Sym, x: &Part, y: &Part) -> B {
    match (x, y) {
        (Part::W(a), Part::W(b)) => s.eq(*a, *b),
        (Part::B(a), Part::B(b)) => eq_bit(s, *a, *b),
        (Part::V(a), Part::V(b)) => s.eq_val(*a, *b),
        (Part::E(a), Part::E(b)) => {
            let k = s.eq(a.kind, b.kind);
            let f1 = s.eq(a.a, b.a);
            let f2 = s.eq(a.b, b.b);
            let f3 = eq_bit(s, a.latch, b.latch);
            let f4 = s.eq_val(a.value, b.value);
            let x = s.and(k, f1);
            let x = s.and(x, f2);
            let x = s.and(x, f3);
            s.and(x, f4)
        }
        _ => unreachable!("both sides flatten to one shape"),
    }
}

/// Slots of a flattened list: a cycle adds at most this many micro-ops to a queue.
fn queue_slots(cfg: &Config) -> usize {
    2 * cfg.sh_entries as usize + 5
}

/// The next state and outputs as named parts (the group name first: what a counterexample
/// reports).
fn flatten(s: &mut Sym, cfg: &Config, st: &WarpState<Sym>, out: &Outputs<W, V>) -> Vec<(String, Part)> {
    let mut p: Vec<(String, Part)> = Vec::new();
    let none = |s: &mut Sym| {
        let z = s.word(0);
        let no = s.bit(false);
        let zv = s.val(0);
        Enc { kind: z, a: z, b: z, latch: no, value: zv }
    };
    for j in 0..st.lanes() as usize {
        let r = st.stacks[j];
        let g = format!("stack of lane {j}: registers");
        for x in [r.top, r.bottom, r.next_tid, r.priority, r.flush] {
            p.push((g.clone(), Part::W(x)));
        }
        p.push((g.clone(), Part::B(r.empty)));
        p.push((g, Part::B(r.idle)));
        let th = st.threads[j];
        let g = format!("lane {j}: Overflow, spill pointer, done");
        p.push((g.clone(), Part::B(th.overflow)));
        p.push((g.clone(), Part::W(th.spill_ptr)));
        p.push((g, Part::B(th.done)));
        let rb = &st.rb[j];
        let g = format!("lane {j}: RB");
        p.push((g.clone(), Part::W(rb.len)));
        for k in 0..3 {
            let (code, v) = match rb.log.get(k) {
                Some(RbEvent::Op(RbOp::PushBack(v))) => (1, *v),
                Some(RbEvent::Op(RbOp::PopBack)) => (2, s.val(0)),
                Some(RbEvent::Op(RbOp::PopFront)) => (3, s.val(0)),
                Some(RbEvent::PushFront(v)) => (4, *v),
                None => (0, s.val(0)),
            };
            let c = s.word(code);
            p.push((g.clone(), Part::W(c)));
            p.push((g.clone(), Part::V(v)));
        }
        let q = &st.seq[j];
        let g = format!("lane {j}: sequencer (in flight, latch, queue)");
        let fl = s.bit(q.inflight.is_some());
        p.push((g.clone(), Part::B(fl)));
        let e = match &q.inflight {
            Some(u) => compact(s, &[(fl, *u)], 1)[0].1,
            None => none(s),
        };
        p.push((g.clone(), Part::E(e)));
        let lv = s.bit(q.latch.is_some());
        p.push((g.clone(), Part::B(lv)));
        let lx = q.latch.unwrap_or_else(|| s.val(0));
        p.push((g.clone(), Part::V(lx)));
        for (valid, e) in compact(s, &q.queue, queue_slots(cfg)) {
            p.push((g.clone(), Part::B(valid)));
            p.push((g.clone(), Part::E(e)));
        }
        let g = format!("lane {j}: global writes");
        for k in 0..2 {
            let (v, slot, x) = match st.global_writes[j].get(k) {
                Some(&(slot, x)) => (s.bit(true), slot, x),
                None => (s.bit(false), s.word(0), s.val(0)),
            };
            p.push((g.clone(), Part::B(v)));
            p.push((g.clone(), Part::W(slot)));
            p.push((g.clone(), Part::V(x)));
        }
        let g = format!("lane {j}: requests");
        let sh = out.sh_req.iter().find(|r| r.0 == j as u32);
        let (v, a, b, wr) = match sh {
            Some(&(_, a, b, wr)) => (s.bit(true), a, b, s.bit(wr)),
            None => (s.bit(false), s.word(0), s.word(0), s.bit(false)),
        };
        for x in [Part::B(v), Part::W(a), Part::W(b), Part::B(wr)] {
            p.push((g.clone(), x));
        }
        let gr = out.g_req.iter().find(|r| r.0 == j as u32);
        let (v, a, wr) = match gr {
            Some(&(_, a, wr)) => (s.bit(true), a, s.bit(wr)),
            None => (s.bit(false), s.word(0), s.bit(false)),
        };
        for x in [Part::B(v), Part::W(a), Part::B(wr)] {
            p.push((g.clone(), x));
        }
        if let Some((_, a)) = out.answers.iter().find(|x| x.0 == j as u32) {
            let g = format!("lane {j}: answer");
            let (code, value) = match a {
                Ok(None) => (0, s.val(0)),
                Ok(Some(v)) => (1, *v),
                Err(e) => (error_code(e), s.val(0)),
            };
            let c = s.word(code);
            p.push((g.clone(), Part::W(c)));
            p.push((g, Part::V(value)));
        }
    }
    for (k, &v) in st.sh.iter().enumerate() {
        let m = st.m.max(1) as usize;
        p.push((format!("SH word {} of lane {}", k % m, k / m), Part::V(v)));
    }
    p
}

/// Every path of `run`, flattened and merged under its path condition.
fn merged(s: &mut Sym, mut run: impl FnMut(&mut Sym) -> Vec<(String, Part)>) -> Vec<(String, Part)> {
    let paths = s.explore(|l| run(l));
    let mut it = paths.into_iter().rev();
    let (_, mut acc) = it.next().expect("at least one path");
    for (c, x) in it {
        assert_eq!(x.len(), acc.len(), "the paths flatten to one shape");
        for (a, b) in acc.iter_mut().zip(&x) {
            a.1 = part_mux(s, c, &b.1, &a.1);
        }
    }
    acc
}

/// Stacks, SH words and requests the design's cycle names lie in the warp (an index outside it
/// would write another warp's registers in the simulator).
fn in_range(s: &mut Sym, cfg: &Config, base: u32, d: &Journal<Sym>) -> B {
    let mut ok = s.bit(true);
    let stack_ok = |s: &mut Sym, x: W| {
        let lo = s.word(base);
        let below = s.lt(x, lo);
        let a = s.not(below);
        let b = s.lt_k(x, base + cfg.warp_size);
        s.and(a, b)
    };
    for &(x, _) in &d.stacks {
        let a = stack_ok(s, x);
        ok = s.and(ok, a);
    }
    for w in &d.writes {
        let u = match *w {
            rtl::stack_manager::cycle::WriteOf::Emit(_, _, u) => u,
            rtl::stack_manager::cycle::WriteOf::Sh { stack, entry, value: _ } => {
                UopOf::ShLoad { stack, entry }
            }
            _ => continue,
        };
        let a = addressed(s, cfg, base, &u);
        ok = s.and(ok, a);
    }
    ok
}

/// Builds the whole-cycle equivalence query for `shape` at the warp starting at `base`.
pub fn whole_cycle<P: CycleSteps>(
    cfg: &Config,
    steps: &P,
    base: u32,
    shape: &[LaneShape],
    acked: bool,
) -> Query {
    let mut s = Sym::default();
    let st = sym_state(&mut s, cfg, base, shape, acked);
    let (cmds, done, deq) = inputs(&mut s, base, shape);
    let assume = assumption(&mut s, cfg, &st);
    let design = merged(&mut s, |l| {
        let (next, out, d) = design_cycle(l, steps, cfg, &st, &cmds, &done, deq);
        let ok = in_range(l, cfg, base, &d);
        let mut f = flatten(l, cfg, &next, &out);
        f.push(("the design addresses only its warp's stacks and entries".into(), Part::B(ok)));
        f
    });
    let spec = merged(&mut s, |l| {
        let mut next = st.clone();
        let out = spec_cycle(l, cfg, &mut next, &cmds, &done, deq);
        let mut f = flatten(l, cfg, &next, &out);
        let yes = l.bit(true);
        f.push(("the design addresses only its warp's stacks and entries".into(), Part::B(yes)));
        f
    });
    // Group the element-wise equalities by name, in first-seen order.
    let mut parts: Vec<(String, B)> = Vec::new();
    for (a, b) in design.iter().zip(&spec) {
        debug_assert_eq!(a.0, b.0);
        let e = part_eq(&mut s, &a.1, &b.1);
        match parts.iter_mut().find(|p| p.0 == a.0) {
            Some(p) => p.1 = s.and(p.1, e),
            None => parts.push((a.0.clone(), e)),
        }
    }
    finish(s, assume, parts)
}

/// The cycle shapes proved at `cfg`: every combination of in-flight, completing and queued
/// micro-op on a lane without a command (packed several to a warp), and a command of each kind
/// beside a release landing, an SH store and a global load completing, an RB-bottom fill and a
/// command to a lane whose last micro-op completes in the same cycle; then two lanes'
/// commands beside a release.
pub fn shapes(cfg: &Config, acked: bool) -> Vec<(String, Vec<LaneShape>)> {
    let ws = cfg.warp_size;
    let mut out = Vec::new();
    // The sequencer alone: every (in flight, completes, head, latch) combination.
    let mut singles = Vec::new();
    let inflights: Vec<Option<UopKind>> = [None]
        .into_iter()
        .chain(
            [UopKind::ShLoad, UopKind::ShStore, UopKind::GlobalLoad, UopKind::GlobalStore]
                .into_iter()
                .filter(|k| k.waits(acked))
                .map(Some),
        )
        .collect();
    for &inflight in &inflights {
        for completes in [false, true] {
            if completes && inflight.is_none() {
                continue;
            }
            for head in [None].into_iter().chain(UopKind::QUEUED.into_iter().map(Some)) {
                for latch in [false, true] {
                    if inflight.is_none() && head.is_none() {
                        continue;
                    }
                    singles.push((inflight, completes, head, latch));
                }
            }
        }
    }
    // SH completions share the `done` port; global ones the single `deq`: one global
    // completion per warp-shape.
    let mut k = 0;
    while k < singles.len() {
        let mut lanes = Vec::new();
        let mut deq_used = false;
        while k < singles.len() && (lanes.len() as u32) < ws {
            let (inflight, completes, head, latch) = singles[k];
            let global_done = completes && inflight.is_some_and(|u| !u.is_sh());
            if global_done && deq_used {
                break;
            }
            deq_used |= global_done;
            let lane = lanes.len() as u32;
            lanes.push(LaneShape { lane, inflight, completes, head, latch, cmd: None });
            k += 1;
        }
        out.push((format!("sequencers {}", out.len() + 1), lanes));
    }
    if ws >= 4 {
        for cmd in [Kind::Push, Kind::Pop, Kind::Finish] {
            let lanes = vec![
                LaneShape { cmd: Some(cmd), ..LaneShape::idle(0) },
                LaneShape { head: Some(UopKind::Release), ..LaneShape::idle(1) },
                LaneShape {
                    inflight: Some(UopKind::ShStore),
                    completes: true,
                    cmd: Some(Kind::Push),
                    ..LaneShape::idle(2)
                },
                LaneShape {
                    inflight: Some(UopKind::GlobalLoad),
                    completes: true,
                    head: Some(UopKind::RbBottom),
                    ..LaneShape::idle(3)
                },
            ];
            out.push((format!("{} beside completions and a release", cmd.name()), lanes));
        }
        let lanes = vec![
            LaneShape { cmd: Some(Kind::Push), ..LaneShape::idle(0) },
            LaneShape { head: Some(UopKind::Release), ..LaneShape::idle(1) },
            LaneShape { cmd: Some(Kind::Push), ..LaneShape::idle(2) },
            LaneShape { inflight: Some(UopKind::ShLoad), completes: true, ..LaneShape::idle(3) },
        ];
        out.push(("push+push beside a release".into(), lanes));
        let lanes = vec![
            LaneShape { cmd: Some(Kind::Finish), ..LaneShape::idle(0) },
            LaneShape { cmd: Some(Kind::Push), ..LaneShape::idle(1) },
        ];
        out.push(("finish+push".into(), lanes));
    }
    out
}
