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
//! A runner whose SMs run ahead of each other (the windowed run) clocks the banks' arbiters and
//! the pipelines' entrances apart from the rest (`sim::split`): [`L2::arbiter_first`] and
//! [`L2::enter_pipeline`] are the arbiters' state and the grant's edge, and
//! [`L2Step::checked_out`] the banks whose head left its pipeline in a cycle.

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

impl L2Step {
    /// The banks whose head left its pipeline at this step's edge (checked, not stalled), in bank
    /// order.
    pub(crate) fn checked_out(&self) -> impl Iterator<Item = usize> + '_ {
        self.checks.iter().filter(|c| c.1 != Check::Stall).map(|c| c.0)
    }
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

    pub(crate) fn params(&self) -> &MemParams {
        &self.params
    }

    /// Bank `b`'s arbiter: the SM it considers first (the one after the SM it granted last).
    pub(crate) fn arbiter_first(&self, b: usize) -> u32 {
        self.rr[b]
    }

    /// Bank `b`'s arbiter granted SM `sm`'s request `req`: it enters the bank pipeline, due at its
    /// tag check in cycle `due`, and the arbiter starts after `sm` next time. The clock edge's
    /// part of a grant ([`L2::commit`]).
    pub(crate) fn enter_pipeline(&mut self, b: usize, sm: u32, req: MemReq, due: u64) {
        self.banks[b].push_back(Lane { due, sm, req });
        self.rr[b] = if sm + 1 < self.params.sms { sm + 1 } else { 0 };
    }

    fn write_back(&mut self, victim: Option<Victim>) {
        if let Some(v) = victim.filter(|v| v.dirty != 0) {
            let bytes = v.dirty.count_ones() * self.params.sector_bytes;
            self.dram_queue.push_back(MemReq::write(0, v.addr, bytes, v.dirty_kind));
            self.counters.write_backs += 1;
        }
    }

    /// The cycle the L2 evaluates next.
    pub fn cycle(&self) -> u64 {
        self.now
    }
}

impl Unit for L2 {
    /// Moves the clock to `cycle` over cycles with no event.
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
    use crate::mem::testutil::L2Bench as Bench;
    use crate::mem::{Assoc, ReqKind};
    use crate::trace::Snapshot;

    fn p(sms: u32) -> MemParams {
        MemParams { sms, ..MemParams::default() }
    }

    fn read(id: u64, addr: u64) -> Option<MemReq> {
        Some(MemReq::read(id, addr, 32, ReqKind::NodeFetch))
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
