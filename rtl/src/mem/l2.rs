//! L2 cache shared by all SMs: banked, write-back, write-allocate.
//!
//! ```text
//!   L1D 0..n down ports ─► per bank: round-robin grant (1 request/cycle/bank)
//!        ─► bank pipeline (l2_latency - 3 cycles) ─► tag check (1/cycle/bank, in order)
//!             read hit  ─► out (to the requesting SM)
//!             read miss ─► MSHR merge / allocate ─► DRAM queue ─► DRAM
//!             store     ─► allocate + dirty (write-back of a dirty victim ─► DRAM queue) ─► ack
//!   DRAM fill ─► tag fill (write-back of a dirty victim) ─► release MSHR waiters ─► out
//! ```
//!
//! Banks are memory sub-partitions (GPGPU-Sim's `addrdec_tlx`): `bank = addr / l2_interleave_bytes
//! mod l2_banks`, each with its own sets indexed by the address with the bank digit removed
//! (linear or IPOLY, see [`super::addr::L2Map`]); the `legacy` preset's mapping is `bank = line mod l2_banks`
//! over one array indexed `line mod sets`. Each bank grants at most one SM
//! per cycle, round-robin starting after the SM it granted last, while its pipeline has room. The
//! tag check sits at the end of the bank pipeline, so a miss pays the L2 latency and then DRAM's.
//! If the head of a bank cannot proceed (MSHR or DRAM queue full) it waits there and the bank
//! behind it waits too. Fills are applied after the tag checks of the same cycle, so a request
//! that merges into an entry whose fill arrives that cycle is released with it. Stores are
//! acknowledged at the tag check; a store that allocates over a dirty line queues a write-back
//! even if the DRAM queue is momentarily over its limit (a store is only checked in when there is
//! room for one), and so does a fill.
//!
//! Clocking: `resp` and `dram_req` are register outputs; [`L2::eval`] (pure) takes the L1Ds'
//! down requests and DRAM's `ready` and responses (all register outputs) and writes the per-SM
//! grants ([`L2Out::granted`], the L1Ds' `down_ready`) and the cycle's decisions into a step,
//! which [`L2::commit`] applies at the clock edge.
//!
//! Two ways to clock it, both part of the unit's interface:
//! - **whole** (the default): one [`Unit`], as above;
//! - **split** ([`L2::split_front_end`]), for a runner whose SMs run ahead of each other (the
//!   windowed run, `sim::window`): the front end (the banks' arbiters and the pipelines'
//!   entrances: [`L2::front_eval`] into a [`FrontStep`], applied by [`L2::front_commit`]) and the
//!   back end (the tag checks on: [`L2::eval`] and [`L2::commit`] with no request coming in)
//!   keep clocks of their own, the back end up to the pipelines' delay ahead. The same results as
//!   the whole L2 (tested below).

use super::cache::{Geometry, TagStore, Victim};
use super::mshr::{Mshr, Outcome, Waiter};
use super::{Counters, MemParams, MemReq, MemResp, MemWidths, ADDR_BITS};
use crate::clock::Unit;
use crate::trace::{Kind, Sink};
use std::collections::{HashMap, VecDeque};
use std::hash::BuildHasherDefault;

/// A request travelling through a bank pipeline.
#[derive(Clone, Copy, Debug)]
struct Lane {
    /// Cycle of its tag check.
    due: u64,
    sm: u32,
    req: MemReq,
}

/// Fate of a bank's head at its tag check.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Check {
    Hit,
    Merge,
    Allocate,
    Write,
    Stall,
}

/// This cycle's inputs.
#[derive(Clone, Copy, Debug, Default)]
pub struct L2In<'a> {
    /// Each SM's L1D down request ([`super::l1d::L1d::down_req`], a register output of the
    /// L1D), if valid.
    pub reqs: &'a [Option<MemReq>],
    /// DRAM takes [`L2::dram_req`] this cycle ([`super::dram::Dram::ready`], a register output).
    pub dram_ready: bool,
    /// DRAM's read responses ([`super::dram::Dram::resp`], a register output).
    pub fills: &'a [MemResp],
}

/// This cycle's combinational outputs.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct L2Out {
    /// Per SM: its down request is granted (`down_ready` of that SM's L1D). Depends on this
    /// cycle's requests through the banks' round-robin arbiters, so the L1Ds, which need it, are
    /// evaluated after the L2.
    pub granted: Vec<bool>,
    /// `dram_req_valid && dram_ready`: the head of the DRAM queue goes to DRAM.
    pub dram_fire: bool,
}

/// One cycle's evaluation: the outputs and the decisions [`L2::commit`] applies. Its buffers are
/// reused from cycle to cycle; [`L2::eval`] overwrites all of it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct L2Step {
    /// The cycle this step was evaluated in ([`L2::commit`] refuses a stale step).
    at: u64,
    pub out: L2Out,
    /// Per SM: the bank of its request (`u32::MAX`: none); wires of the grant logic.
    bank_of: Vec<u32>,
    /// The banks some SM requests, ascending (the arbiters of the others grant nothing).
    requested: Vec<u32>,
    /// (bank, sm, request) entering bank pipelines.
    accepted: Vec<(usize, u32, MemReq)>,
    /// (bank, fate) of each bank head checked this cycle.
    checks: Vec<(usize, Check)>,
    /// DRAM's responses, latched at the edge.
    fills: Vec<MemResp>,
}

#[derive(Clone, Debug)]
pub struct L2 {
    params: MemParams,
    widths: MemWidths,
    tags: TagStore,
    mshr: Mshr,
    banks: Vec<VecDeque<Lane>>,
    /// Per bank: the SM to consider first.
    rr: Vec<u32>,
    /// Requests for DRAM; the head is offered.
    dram_queue: VecDeque<MemReq>,
    /// DRAM reads in flight: id → sector.
    pending: HashMap<u64, u64, BuildHasherDefault<super::cache::LineHasher>>,
    next_dram_id: u64,
    /// Per SM: responses visible this cycle (the response registers).
    out: Vec<Vec<MemResp>>,
    now: u64,
    counters: Counters,
    /// The windowed run's front end, once split ([`L2::split_front_end`]).
    front: Option<FrontEnd>,
}

/// One cycle's inputs of a split L2's front end ([`L2::front_eval`]).
#[derive(Clone, Copy, Debug)]
pub struct FrontIn<'a> {
    /// The front end's cycle.
    pub at: u64,
    /// Per bank: bit `sm` set when SM `sm`'s down request is for that bank ([`L2::bank_of`]).
    pub want: &'a [u64],
    /// Per SM: its down request (read only where `want` has the SM's bit).
    pub heads: &'a [MemReq],
}

/// One cycle of a split L2's front end ([`L2::front_eval`]), applied by [`L2::front_commit`]:
/// the cycle, the granted SMs (one bit each) and (bank, SM, request) of each grant.
#[derive(Clone, Debug, Default)]
pub struct FrontStep {
    at: u64,
    pub granted: u64,
    accepted: Vec<(usize, u32, MemReq)>,
}

/// What the front end of a split L2 keeps per bank to know the bank's length in its own cycle.
#[derive(Clone, Debug)]
struct FrontEnd {
    /// Requests the arbiter let in.
    let_in: Vec<u64>,
    /// Cycles in which the back end checked out a request, not yet seen by the front end.
    out_log: Vec<VecDeque<u64>>,
    /// Check-outs the front end has seen (in cycles before its own).
    out_seen: Vec<u64>,
}

impl L2 {
    pub fn new(p: &MemParams) -> L2 {
        let sms = p.sms as usize;
        L2 {
            params: *p,
            widths: p.widths(),
            tags: TagStore::new(Geometry::l2(p)),
            mshr: Mshr::new(p.l2_mshrs, p.l2_mshr_merge),
            banks: vec![VecDeque::new(); p.l2_banks as usize],
            rr: vec![0; p.l2_banks as usize],
            dram_queue: VecDeque::new(),
            pending: HashMap::default(),
            next_dram_id: 0,
            out: vec![Vec::new(); sms],
            now: 0,
            counters: Counters::default(),
            front: None,
        }
    }

    /// The bank (memory sub-partition) of `addr`.
    pub fn bank_of(&self, addr: u64) -> usize {
        self.tags.geometry().bank_of(addr, self.params.l2_banks) as usize
    }

    /// Register output: responses for SM `sm` visible this cycle.
    pub fn resp(&self, sm: usize) -> &[MemResp] {
        &self.out[sm]
    }

    /// Register output: the request offered to DRAM this cycle.
    pub fn dram_req(&self) -> Option<MemReq> {
        self.dram_queue.front().copied()
    }

    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    pub fn mshr_occupancy(&self) -> usize {
        self.mshr.len()
    }

    pub fn dram_queue_depth(&self) -> usize {
        self.dram_queue.len()
    }

    /// Splits the L2 in two halves with clocks of their own, for a runner that runs the SMs
    /// ahead of each other (the windowed run, `sim::window`): from now on the front end
    /// ([`L2::front_eval`] and [`L2::front_commit`]: the grants and the bank pipelines' entrances) and the back end (the
    /// tag checks onward: [`L2::eval`] and [`L2::commit`] with no request, which is all they then
    /// do) keep clocks of their own, the back end ahead. A bank's length as the front end's
    /// arbiter must see it in its cycle is then the requests it let in before that cycle less
    /// those the back end checked out before it, so the back end logs each check-out's cycle.
    pub fn split_front_end(&mut self) {
        let banks = self.banks.len();
        self.front = Some(FrontEnd {
            let_in: vec![0; banks],
            out_log: vec![VecDeque::new(); banks],
            out_seen: vec![0; banks],
        });
    }

    /// Split only ([`L2::split_front_end`]): the front end's cycle `i.at`, combinational. Each
    /// requested bank with room grants one SM as [`L2::eval`]'s arbiter does (the first from the
    /// SM after the one it granted last); writes the grants, with the requests they take, into
    /// `d`, which [`L2::front_commit`] applies. The back end must have run every cycle before
    /// `i.at`.
    pub fn front_eval(&self, i: FrontIn, d: &mut FrontStep) {
        let f = self.front.as_ref().expect("split_front_end first");
        let x = i.at;
        d.at = x;
        d.granted = 0;
        d.accepted.clear();
        for (b, &mask) in i.want.iter().enumerate() {
            if mask == 0 {
                continue;
            }
            // The bank's length in cycle `x`: let in less checked out before `x`.
            let out = f.out_seen[b] + f.out_log[b].iter().take_while(|&&c| c < x).count() as u64;
            if f.let_in[b] - out >= u64::from(self.params.l2_bank_queue) {
                continue;
            }
            // The first requesting SM from `rr[b]` on, round the ring.
            let from = mask & (u64::MAX << self.rr[b]);
            let sm = if from != 0 { from.trailing_zeros() } else { mask.trailing_zeros() };
            d.granted |= 1 << sm;
            d.accepted.push((b, sm, i.heads[sm as usize]));
        }
    }

    /// The front end's clock edge for the step of [`L2::front_eval`]: the granted requests
    /// enter their bank pipelines, due at their tag check `l2_latency - 3` cycles later, and each
    /// granting bank's arbiter moves on. The back end must not yet have reached the cycle a
    /// request let in now is due.
    pub fn front_commit(&mut self, d: &FrontStep) {
        let f = self.front.as_mut().expect("split_front_end first");
        let delay = u64::from(self.params.l2_latency - 3);
        debug_assert!(d.at + delay >= self.now, "the back end ran past a request's tag check");
        for (b, log) in f.out_log.iter_mut().enumerate() {
            while log.front().is_some_and(|&c| c < d.at) {
                log.pop_front();
                f.out_seen[b] += 1;
            }
        }
        for &(b, sm, req) in &d.accepted {
            self.enter_pipeline(b, sm, req, d.at + delay);
        }
    }

    /// Bank `b`'s arbiter granted SM `sm`'s request `req`: it enters the bank pipeline, due at its
    /// tag check in cycle `due` (counted for the front end's bank length when split), and the
    /// arbiter starts after `sm` next time. The clock edge's part of a grant, in [`L2::commit`]
    /// and [`L2::front_commit`].
    fn enter_pipeline(&mut self, b: usize, sm: u32, req: MemReq, due: u64) {
        self.banks[b].push_back(Lane { due, sm, req });
        if let Some(f) = self.front.as_mut() {
            f.let_in[b] += 1;
        }
        self.rr[b] = if sm + 1 < self.params.sms { sm + 1 } else { 0 };
    }

    fn write_back(&mut self, victim: Option<Victim>) {
        if let Some(v) = victim.filter(|v| v.dirty != 0) {
            let bytes = v.dirty.count_ones() * self.params.sector_bytes;
            self.dram_queue.push_back(MemReq::write(0, v.addr, bytes, v.dirty_kind));
            self.counters.write_backs += 1;
        }
    }

    /// The cycle the L2 (the back end, when split) evaluates next.
    pub fn cycle(&self) -> u64 {
        self.now
    }
}

impl Unit for L2 {
    /// Moves the clock (the back end's, when split) to `cycle` over cycles with no event.
    fn skip_to(&mut self, cycle: u64) {
        self.now = cycle;
    }

    /// Next cycle whose commit changes something, ignoring new requests and DRAM responses;
    /// `None` when idle.
    fn next_event(&self) -> Option<u64> {
        if self.out.iter().any(|o| !o.is_empty()) || !self.dram_queue.is_empty() {
            return Some(self.now);
        }
        self.banks.iter().filter_map(|b| b.front().map(|l| l.due.max(self.now))).min()
    }

    type In<'a> = L2In<'a>;
    type Step = L2Step;

    /// Combinational logic of one cycle: a pure function of the registers and `i`, written into
    /// `d` (every field overwritten; its buffers are reused, so no allocation once warm).
    fn eval(&self, i: L2In<'_>, d: &mut L2Step) {
        let sms = self.out.len();
        assert_eq!(i.reqs.len(), sms, "one down port per SM");
        d.at = self.now;
        d.out.granted.clear();
        d.out.granted.resize(sms, false);
        d.out.dram_fire = i.dram_ready && !self.dram_queue.is_empty();
        d.fills.clear();
        d.fills.extend_from_slice(i.fills);
        d.accepted.clear();
        d.checks.clear();
        d.bank_of.clear();
        d.bank_of.extend(i.reqs.iter().map(|r| r.map_or(u32::MAX, |r| self.bank_of(r.addr) as u32)));
        // Each requested bank's round-robin arbiter, in bank order.
        d.requested.clear();
        d.requested.extend(d.bank_of.iter().copied().filter(|&b| b != u32::MAX));
        d.requested.sort_unstable();
        d.requested.dedup();
        for &b in &d.requested {
            let b = b as usize;
            if self.banks[b].len() >= self.params.l2_bank_queue as usize {
                continue;
            }
            let first = self.rr[b] as usize;
            // Round robin from `first` (below `sms`), without a division per candidate.
            let pick = (first..sms).chain(0..first).find(|&sm| d.bank_of[sm] == b as u32);
            if let Some(sm) = pick {
                d.out.granted[sm] = true;
                d.accepted.push((b, sm as u32, i.reqs[sm].expect("picked")));
            }
        }
        // Allocations this cycle share the MSHR and the DRAM queue, in bank order.
        let mut mshr_free = self.mshr.capacity() - self.mshr.len();
        let mut dram_room = (self.params.l2_dram_queue as usize).saturating_sub(self.dram_queue.len());
        for (b, bank) in self.banks.iter().enumerate() {
            let Some(head) = bank.front().filter(|l| l.due <= self.now) else {
                continue;
            };
            let r = head.req;
            let check = if r.write {
                if dram_room == 0 {
                    Check::Stall
                } else {
                    if self.tags.victim(r.addr).is_some_and(|v| v.dirty != 0) {
                        dram_room -= 1;
                    }
                    Check::Write
                }
            } else if self.tags.lookup(r.addr).is_hit() {
                Check::Hit
            } else {
                match self.mshr.check(self.params.sector_of(r.addr)) {
                    Outcome::Merge => Check::Merge,
                    Outcome::Allocate if mshr_free > 0 && dram_room > 0 => {
                        mshr_free -= 1;
                        dram_room -= 1;
                        Check::Allocate
                    }
                    _ => Check::Stall,
                }
            };
            d.checks.push((b, check));
        }
    }

    /// Clock edge: applies `d`, the step [`L2::eval`] produced this cycle. The tag array, the
    /// MSHR table and the queues are RAM-like: `d` holds the cycle's decisions and this writes
    /// them, as a register file's write port does, without deciding anything new.
    fn commit(&mut self, d: &L2Step) {
        assert_eq!(d.at, self.now, "L2 committed a step evaluated in another cycle");
        let delay = u64::from(self.params.l2_latency - 3);
        if d.out.dram_fire {
            self.dram_queue.pop_front();
        }
        for out in &mut self.out {
            out.clear();
        }
        for &(b, sm, req) in &d.accepted {
            self.enter_pipeline(b, sm, req, self.now + delay);
        }
        for &(b, check) in &d.checks {
            if check == Check::Stall {
                self.counters.stall_cycles += 1;
                continue;
            }
            let Lane { sm, req: r, .. } = self.banks[b].pop_front().expect("checked head");
            if let Some(f) = self.front.as_mut() {
                f.out_log[b].push_back(self.now);
            }
            let key = self.params.sector_of(r.addr);
            match check {
                Check::Hit => {
                    self.tags.touch(r.addr);
                    self.out[sm as usize].push(r.response());
                    self.counters.lookup(&r, true);
                }
                Check::Merge | Check::Allocate => {
                    let waiter = Waiter { port: sm, id: r.id, addr: r.addr };
                    self.mshr.insert(key, waiter);
                    self.counters.lookup(&r, false);
                    if check == Check::Merge {
                        self.counters.merged += 1;
                    } else {
                        let id = self.next_dram_id;
                        self.next_dram_id += 1;
                        self.dram_queue.push_back(MemReq::read(id, key, self.params.sector_bytes, r.kind));
                        self.pending.insert(id, key);
                    }
                }
                Check::Write => {
                    self.counters.lookup(&r, self.tags.lookup(r.addr).is_hit());
                    let victim = self.tags.fill(r.addr, Some(r.kind));
                    self.write_back(victim);
                    self.out[sm as usize].push(r.response());
                }
                Check::Stall => unreachable!("stalls skipped above"),
            }
        }
        for f in &d.fills {
            let key = self
                .pending
                .remove(&f.id)
                .unwrap_or_else(|| panic!("L2 got a DRAM response for unknown id {}", f.id));
            let victim = self.tags.fill(key, None);
            self.write_back(victim);
            let out = &mut self.out;
            self.mshr.release_each(key, |w| out[w.port as usize].push(MemResp { id: w.id, addr: w.addr }));
        }
        self.now += 1;
    }

    /// Shows the registers and `d`, this cycle's step, to `sink`; the counts are derived here
    /// from the step, not computed by [`L2::eval`].
    fn probe<S: Sink>(&self, d: &L2Step, sink: &mut S) {
        if !sink.enabled() {
            return;
        }
        let w = &self.widths;
        let count = |c: Check| d.checks.iter().filter(|x| x.1 == c).count() as u64;
        sink.signal("accept_count", w.l2_bank_count, d.accepted.len() as u64);
        sink.signal_kind("accept_addr", ADDR_BITS, d.accepted.first().map_or(0, |a| a.2.addr), Kind::Address);
        sink.signal("hit_count", w.l2_bank_count, count(Check::Hit));
        sink.signal("miss_count", w.l2_bank_count, count(Check::Merge) + count(Check::Allocate));
        sink.signal("stall_count", w.l2_bank_count, count(Check::Stall));
        sink.signal("mshr_occupancy", w.l2_mshr_occupancy, self.mshr.len() as u64);
        sink.signal(
            "pipeline_depth_max",
            w.l2_pipeline_depth,
            self.banks.iter().map(VecDeque::len).max().unwrap_or(0) as u64,
        );
        sink.signal("dram_queue_depth", w.l2_dram_queue_depth, self.dram_queue.len() as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::{Assoc, ReqKind};
    use crate::trace::Snapshot;

    /// An L2 with a stand-in DRAM answering every read `dram` cycles after it is offered.
    struct Bench {
        l2: L2,
        dram: u64,
        in_dram: VecDeque<(u64, MemResp)>,
        dram_out: Vec<MemResp>,
        dram_log: Vec<MemReq>,
        resp_log: Vec<(u64, usize, MemResp)>,
        cycle: u64,
    }

    impl Bench {
        fn new(p: MemParams, dram: u64) -> Bench {
            Bench {
                l2: L2::new(&p),
                dram,
                in_dram: VecDeque::new(),
                dram_out: Vec::new(),
                dram_log: Vec::new(),
                resp_log: Vec::new(),
                cycle: 0,
            }
        }

        fn step(&mut self, reqs: &[Option<MemReq>]) -> Vec<bool> {
            for sm in 0..self.l2.out.len() {
                for r in self.l2.resp(sm) {
                    self.resp_log.push((self.cycle, sm, *r));
                }
            }
            let to_dram = self.l2.dram_req();
            let fills = std::mem::take(&mut self.dram_out);
            let mut d = L2Step::default();
            self.l2.eval(L2In { reqs, dram_ready: true, fills: &fills }, &mut d);
            let granted = d.out.granted.clone();
            self.l2.commit(&d);
            if let Some(r) = to_dram {
                self.dram_log.push(r);
                if !r.write {
                    self.in_dram.push_back((self.cycle + self.dram, r.response()));
                }
            }
            while self.in_dram.front().is_some_and(|&(c, _)| c <= self.cycle + 1) {
                self.dram_out.push(self.in_dram.pop_front().unwrap().1);
            }
            self.cycle += 1;
            granted
        }

        fn settle(&mut self, sms: usize) {
            for _ in 0..10_000 {
                if self.l2.next_event().is_none() && self.in_dram.is_empty() && self.dram_out.is_empty() {
                    return;
                }
                self.step(&vec![None; sms]);
            }
            panic!("did not settle");
        }
    }

    fn p(sms: u32) -> MemParams {
        MemParams { sms, ..MemParams::default() }
    }

    fn read(id: u64, addr: u64) -> Option<MemReq> {
        Some(MemReq::read(id, addr, 32, ReqKind::NodeFetch))
    }

    /// Random traffic from four SMs through the L2, each SM offering the head of its own queue of
    /// requests (reads and writes to a few hot lines, so hits, misses, merges and write-backs
    /// happen; pipelines of six, so banks fill): `ahead` < 0 runs the L2 whole (`eval` and
    /// `commit` every cycle); otherwise split as the windowed run splits it, the front end cycle
    /// by cycle and the back end run `ahead` cycles in front of it. Returns every response with
    /// its cycle, and the counters.
    fn queued_traffic(p: MemParams, ahead: i64, seed: u64) -> (Vec<(u64, usize, MemResp)>, Counters) {
        use crate::mem::testutil::XorShift;
        let sms = p.sms as usize;
        let mut rng = XorShift(seed);
        let mut b = Bench::new(p, 30);
        let mut queues = vec![VecDeque::new(); sms];
        let mut id = 0;
        let none = vec![None; sms];
        let (mut want, mut heads, mut fs) = (
            vec![0u64; p.l2_banks as usize],
            vec![MemReq::read(0, 0, 0, ReqKind::NodeFetch); sms],
            FrontStep::default(),
        );
        if ahead >= 0 {
            b.l2.split_front_end();
        }
        for x in 0..3_000u64 {
            for q in queues.iter_mut() {
                if rng.below(2) == 0 {
                    id += 1;
                    let addr = rng.below(48) * 32;
                    q.push_back(if rng.below(5) == 0 {
                        MemReq::write(id, addr, 8, ReqKind::StackSpill)
                    } else {
                        MemReq::read(id, addr, 32, ReqKind::NodeFetch)
                    });
                }
            }
            let reqs: Vec<Option<MemReq>> = queues.iter().map(|q| q.front().copied()).collect();
            let granted: Vec<bool> = if ahead < 0 {
                b.step(&reqs)
            } else {
                want.iter_mut().for_each(|w| *w = 0);
                for (k, r) in reqs.iter().enumerate() {
                    if let Some(r) = r {
                        want[b.l2.bank_of(r.addr)] |= 1 << k;
                        heads[k] = *r;
                    }
                }
                b.l2.front_eval(FrontIn { at: x, want: &want, heads: &heads }, &mut fs);
                b.l2.front_commit(&fs);
                // The back end runs on to `ahead` cycles in front of the front end.
                while b.cycle < x + 1 + ahead as u64 {
                    b.step(&none);
                }
                (0..sms).map(|k| fs.granted & 1 << k != 0).collect()
            };
            for (q, g) in queues.iter_mut().zip(granted) {
                if g {
                    q.pop_front();
                }
            }
        }
        b.settle(sms);
        (b.resp_log, *b.l2.counters())
    }

    /// The windowed run's split L2: the front end at its cycle and the back end up to
    /// the bank pipelines' delay in front of it give the whole L2's responses, at the same
    /// cycles, and its counters; a back end further ahead than that (the windowed run's planted
    /// `WindowBackEndTooFar`) checks a bank's head before a request let in later would have been
    /// in front of it, and the comparison catches it.
    #[test]
    fn split_front_and_back_end_equal_the_whole_l2() {
        let p = MemParams { sms: 4, l2_bank_queue: 6, l2_latency: 30, l2_mshrs: 8, ..MemParams::default() };
        let delay = i64::from(p.l2_latency - 3);
        for seed in 1..4 {
            let whole = queued_traffic(p, -1, seed);
            assert!(whole.0.len() > 1_000 && whole.1.hits > 0 && whole.1.misses > 0, "traffic of every kind");
            for ahead in [0, 1, delay / 2, delay] {
                assert_eq!(queued_traffic(p, ahead, seed), whole, "seed {seed}, back end {ahead} ahead");
            }
            assert_ne!(queued_traffic(p, delay + 8, seed), whole, "a back end too far ahead must show");
        }
    }

    #[test]
    fn hit_and_miss_timing() {
        let mut b = Bench::new(p(1), 40);
        assert_eq!(b.step(&[read(1, 0x100)]), vec![true]);
        b.settle(1);
        // Miss: tag check at 157, DRAM offered at 158, fill visible at 198, response at 199.
        assert_eq!(b.resp_log, vec![(199, 0, MemResp { id: 1, addr: 0x100 })]);
        let t = b.cycle;
        b.step(&[read(2, 0x110)]);
        b.settle(1);
        // Hit: visible l2_latency - 2 after acceptance (the L1D's two port registers make 160).
        assert_eq!(b.resp_log[1], (t + 158, 0, MemResp { id: 2, addr: 0x110 }));
        assert_eq!((b.l2.counters().hits, b.l2.counters().misses), (1, 1));
    }

    #[test]
    fn one_bank_grants_one_sm_per_cycle_round_robin() {
        let mut b = Bench::new(p(3), 10);
        // 256-byte interleaving over 8 banks: 0 and 8 × 256 share bank 0; 256 is in bank 1.
        let reqs = [read(1, 0), read(2, 8 * 256), read(3, 256)];
        assert_eq!(b.step(&reqs), vec![true, false, true]);
        assert_eq!(b.step(&[read(4, 0), read(2, 8 * 256), None]), vec![false, true, false]);
        assert_eq!(b.step(&[read(4, 0), None, None]), vec![true, false, false]);
        b.settle(3);
        // SM 0's two reads of one sector: one DRAM read.
        assert_eq!(b.dram_log.len(), 3);
        assert_eq!(b.l2.counters().merged, 1);
        assert_eq!(b.resp_log.len(), 4);
    }

    #[test]
    fn a_full_mshr_stalls_the_bank_until_a_fill() {
        let mp = MemParams { l2_mshrs: 2, l2_banks: 1, ..p(1) };
        let mut b = Bench::new(mp, 40);
        for (i, addr) in [0x000, 0x020, 0x040, 0x040].into_iter().enumerate() {
            b.step(&[read(i as u64, addr)]);
        }
        b.settle(1);
        // The third read, due at 159, waits until the first fill (input at 198) frees an entry,
        // allocates at 199, and its DRAM read is answered at 240; the fourth merges into it.
        assert_eq!(b.dram_log.len(), 3);
        let times: Vec<(u64, u64)> = b.resp_log.iter().map(|x| (x.2.id, x.0)).collect();
        assert_eq!(times, vec![(0, 199), (1, 200), (2, 241), (3, 241)]);
        assert_eq!(b.l2.counters().merged, 1);
        assert!(b.l2.counters().stall_cycles >= 40);
    }

    #[test]
    fn banks_follow_the_mapping() {
        // Old: line interleaving; new: 256-byte chunks. Two requests from two SMs in one cycle
        // are both granted iff they are in different banks.
        let old = MemParams { l2_set_index: crate::mem::SetIndex::Linear, l2_interleave_bytes: 128, ..p(2) };
        assert_eq!(Bench::new(old, 10).step(&[read(1, 0), read(2, 128)]), vec![true, true]);
        assert_eq!(Bench::new(p(2), 10).step(&[read(1, 0), read(2, 128)]), vec![true, false]);
        assert_eq!(Bench::new(p(2), 10).step(&[read(1, 0), read(2, 256)]), vec![true, true]);
    }

    #[test]
    fn dirty_lines_are_written_back_on_eviction() {
        // 2 sets of 2 ways, old linear mapping: lines 0, 2, 4 share set 0.
        let mp = MemParams {
            l2_bytes: 4 * 128,
            l2_assoc: Assoc::Ways(2),
            l2_banks: 1,
            l2_set_index: crate::mem::SetIndex::Linear,
            l2_interleave_bytes: 128,
            ..p(1)
        };
        let mut b = Bench::new(mp, 10);
        b.step(&[Some(MemReq::write(1, 0x20, 8, ReqKind::StackSpill))]);
        b.step(&[Some(MemReq::write(2, 0x40, 8, ReqKind::StackSpill))]);
        b.step(&[read(3, 2 * 128)]);
        b.settle(1);
        assert!(b.dram_log.iter().all(|r| !r.write));
        b.step(&[read(4, 4 * 128)]);
        b.settle(1);
        let wb: Vec<&MemReq> = b.dram_log.iter().filter(|r| r.write).collect();
        assert_eq!(wb.len(), 1);
        assert_eq!((wb[0].addr, wb[0].bytes, wb[0].kind), (0, 64, ReqKind::StackSpill));
        assert_eq!(b.l2.counters().write_backs, 1);
        // The stores allocated without a DRAM read and were acknowledged.
        assert_eq!(b.resp_log.len(), 4);
        // Misses: the first store, the second (same line, other sector) and both reads.
        assert_eq!(b.l2.counters().misses, 4);
        let mut s = Snapshot::default();
        b.l2.probe(&L2Step::default(), &mut s);
        assert_eq!(s.get("mshr_occupancy"), Some(0));
    }
}
