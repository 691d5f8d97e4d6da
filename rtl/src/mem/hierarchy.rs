//! The memory the SMs share: the L2 and DRAM. Each SM's L1D is the SM's ([`crate::sm::Sm`]); the
//! GPU wires the L1Ds' down ports to this unit ([`crate::gpu`]).
//!
//! ```text
//!   down[sm] (each L1D's down_req) ─► L2 ─ dram_req ─► DRAM
//!   granted[sm] (combinational)    ◄─ L2
//!   resp[sm]    (registered)       ◄─ L2 ◄─── resp ──── DRAM
//! ```
//!
//! # One cycle
//!
//! Each unit has register outputs (functions of its registers alone: the L1D's `ready`,
//! `down_req` and `resp`, the L2's `resp` and `dram_req`, DRAM's `ready` and `resp`), a pure
//! `eval(&self, In, &mut Step)` ([`Unit`]) that computes the cycle's combinational outputs (`Step::out`)
//! and next-state decisions from the registers and the inputs, and `commit(&mut self, &Step)`,
//! the clock edge, which applies the step and nothing else. `eval` takes `&self`, so no unit's
//! registers change before the edge and no value of this cycle can be read out of a unit's
//! state: values of this cycle travel only as one unit's `Step::out` passed in another's `In`.
//!
//! Dataflow order across the GPU ([`crate::gpu::Gpu`]):
//! 1. This unit: the L2, whose inputs are register outputs only (each L1D's `down_req`, DRAM's
//!    `ready` and `resp`), and DRAM, whose input is the L2's `dram_req`, a register output (so
//!    the two are siblings).
//! 2. The SMs, siblings, in any order: an L1D's inputs are its SM's request, the L2's
//!    combinational grant for it ([`MemStep::granted`], which depends on every SM's down request
//!    through the banks' round-robin arbiters) and the L2's registered responses.
//!
//! The L1Ds cannot be evaluated before the L2: their `In` takes the grant from the step the L2's
//! evaluation writes, so moving them before it does not compile.
//!
//! When no L1D has anything to send, [`MemSystem::next_event`] tells the first cycle in which
//! anything happens, and [`MemSystem::skip_to`] jumps there: the skipped cycles would have
//! changed nothing (tested below against stepping every cycle).

use super::dram::{Dram, DramIn, DramStep};
use super::l2::{L2In, L2Step, L2};
use super::{MemParams, MemReq};
use crate::clock::Unit;
use crate::config::ConfigError;
use crate::trace::Sink;

/// One cycle's evaluation of the L2 and DRAM: their steps. A buffer reused from cycle to cycle,
/// so evaluating a cycle allocates nothing once warm.
#[derive(Clone, Debug, Default)]
pub struct MemStep {
    l2: L2Step,
    dram: DramStep,
}

impl MemStep {
    /// The L2 grants SM `sm`'s down request this cycle (its L1D's `down_ready`).
    #[inline]
    pub fn granted(&self, sm: usize) -> bool {
        self.l2.out.granted[sm]
    }
}

/// The L2 and DRAM.
#[derive(Clone, Debug)]
pub struct MemSystem {
    params: MemParams,
    l2: L2,
    dram: Dram,
}

impl MemSystem {
    pub fn new(params: MemParams) -> Result<MemSystem, ConfigError> {
        params.validate()?;
        Ok(MemSystem { params, l2: L2::new(&params), dram: Dram::new(&params) })
    }

    pub fn params(&self) -> &MemParams {
        &self.params
    }

    /// The current cycle.
    pub fn cycle(&self) -> u64 {
        self.l2.cycle()
    }

    pub fn l2(&self) -> &L2 {
        &self.l2
    }

    pub fn dram(&self) -> &Dram {
        &self.dram
    }

    /// The L2 and DRAM, to clock apart (each keeps its own clock).
    pub(crate) fn parts_mut(&mut self) -> (&mut L2, &mut Dram) {
        (&mut self.l2, &mut self.dram)
    }
}

impl Unit for MemSystem {
    /// Jumps to `cycle`, skipping cycles in which nothing would happen. Panics if that would skip
    /// an event (a caller bug).
    fn skip_to(&mut self, cycle: u64) {
        assert!(cycle >= self.cycle(), "cannot go back to cycle {cycle}");
        if let Some(event) = self.next_event() {
            assert!(cycle <= event, "skipping to {cycle} would miss the event at {event}");
        }
        self.l2.skip_to(cycle);
        self.dram.skip_to(cycle);
    }

    /// The first cycle, from now on, whose `eval`/`commit` does anything if no L1D sends a
    /// request before it; `None` when both are idle.
    fn next_event(&self) -> Option<u64> {
        self.l2.next_event().into_iter().chain(self.dram.next_event()).min()
    }

    /// Each SM's down request (its L1D's `down_req`, a register output), if valid.
    type In<'a> = &'a [Option<MemReq>];
    type Step = MemStep;

    /// One cycle of combinational logic, a pure function of the registers and `down`, written
    /// into `d`: the L2's grants ([`MemStep::granted`]) and both units' decisions.
    fn eval(&self, down: &[Option<MemReq>], d: &mut MemStep) {
        let l2_in = L2In { reqs: down, dram_ready: self.dram.ready(), fills: self.dram.resp() };
        self.l2.eval(l2_in, &mut d.l2);
        self.dram.eval(DramIn { req: self.l2.dram_req() }, &mut d.dram);
    }

    /// Clock edge: both units apply their part of `d`, the step [`MemSystem::eval`] produced
    /// this cycle (each writes only its own registers).
    fn commit(&mut self, d: &MemStep) {
        self.dram.commit(&d.dram);
        self.l2.commit(&d.l2);
    }

    /// Shows the registers and `d`, this cycle's step, to `sink` (sampled between eval and
    /// commit, a probe shows the cycle's inputs and decisions).
    fn probe<S: Sink>(&self, d: &MemStep, sink: &mut S) {
        if !sink.enabled() {
            return;
        }
        sink.push_scope("l2");
        self.l2.probe(&d.l2, sink);
        sink.pop_scope();
        sink.push_scope("dram");
        self.dram.probe(&d.dram, sink);
        sink.pop_scope();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::cache::reference::RefLru;
    use crate::mem::cache::Geometry;
    use crate::mem::l1d::{L1d, L1dIn, L1dStep};
    use crate::mem::testutil::XorShift;
    use crate::mem::{Assoc, ReqKind};
    use crate::mem::{Counters, MemResp};
    use crate::trace::Snapshot;
    use std::collections::VecDeque;

    type Log = Vec<(u64, usize, MemResp)>;

    /// The memory hierarchy under test: one L1D per SM in front of the L2 and DRAM, wired as the
    /// GPU wires them (`crate::gpu`, `crate::sm`), each SM's request offered straight to its L1D.
    #[derive(Clone, Debug)]
    struct Hierarchy {
        l1d: Vec<L1d>,
        mem: MemSystem,
    }

    /// What one SM sees in a cycle: its L1D took the request offered, and the L1D's responses.
    #[derive(Clone, Debug, Default, PartialEq, Eq)]
    struct SmOut {
        ready: bool,
        resp: Vec<MemResp>,
    }

    /// One cycle of the hierarchy: every unit's step and what each SM sees.
    #[derive(Clone, Debug, Default)]
    struct Step {
        down: Vec<Option<MemReq>>,
        mem: MemStep,
        l1d: Vec<L1dStep>,
        out: Vec<SmOut>,
    }

    impl Hierarchy {
        fn new(p: MemParams) -> Hierarchy {
            let mem = MemSystem::new(p).unwrap();
            Hierarchy { l1d: (0..p.sms).map(|_| L1d::new(&p)).collect(), mem }
        }

        fn cycle(&self) -> u64 {
            self.mem.cycle()
        }

        /// The cycle on SM `sm`'s request `reqs[sm]`: the L2 and DRAM, then every L1D.
        fn eval(&self, reqs: &[Option<MemReq>], d: &mut Step) {
            let sms = self.l1d.len();
            d.down.clear();
            d.down.extend(self.l1d.iter().map(L1d::down_req));
            self.mem.eval(&d.down, &mut d.mem);
            d.l1d.resize_with(sms, L1dStep::default);
            d.out.resize_with(sms, SmOut::default);
            for (k, l1) in self.l1d.iter().enumerate() {
                let i = L1dIn { req: reqs[k], down_ready: d.mem.granted(k), fills: self.mem.l2().resp(k) };
                l1.eval(i, &mut d.l1d[k]);
                let o = &mut d.out[k];
                o.ready = l1.sm_ready(&d.l1d[k], reqs[k].is_some());
                o.resp.clear();
                o.resp.extend_from_slice(l1.resp());
            }
        }

        fn step(&self, reqs: &[Option<MemReq>]) -> Step {
            let mut d = Step::default();
            self.eval(reqs, &mut d);
            d
        }

        fn commit(&mut self, d: &Step) {
            for (l1, s) in self.l1d.iter_mut().zip(&d.l1d) {
                l1.commit(s);
            }
            self.mem.commit(&d.mem);
        }

        fn next_event(&self) -> Option<u64> {
            self.l1d.iter().filter_map(L1d::next_event).chain(self.mem.next_event()).min()
        }

        /// Every clock moved to `cycle`, events or not.
        fn set_now(&mut self, cycle: u64) {
            for l1 in &mut self.l1d {
                l1.skip_to(cycle);
            }
            let (l2, dram) = self.mem.parts_mut();
            l2.skip_to(cycle);
            dram.skip_to(cycle);
        }

        fn skip_to(&mut self, cycle: u64) {
            assert!(self.next_event().is_none_or(|e| cycle <= e), "skipping to {cycle} misses an event");
            self.set_now(cycle);
        }

        fn probe<S: Sink>(&self, d: &Step, sink: &mut S) {
            for (sm, l1) in self.l1d.iter().enumerate() {
                sink.push_scope(&format!("l1d{sm}"));
                l1.probe(&d.l1d[sm], sink);
                sink.pop_scope();
            }
            self.mem.probe(&d.mem, sink);
        }

        fn l1d(&self, sm: usize) -> &L1d {
            &self.l1d[sm]
        }

        fn l2(&self) -> &L2 {
            self.mem.l2()
        }

        fn dram(&self) -> &Dram {
            self.mem.dram()
        }

        /// L1D counters summed over SMs.
        fn l1d_counters(&self) -> Counters {
            let mut total = Counters::default();
            for l1 in &self.l1d {
                total.add(l1.counters());
            }
            total
        }
    }

    #[derive(Clone, Copy, PartialEq, Eq)]
    enum Skip {
        Never,
        ToNextEvent,
        /// Planted bug: jump one cycle past the next event.
        PastNextEvent,
    }

    /// Offers each SM's requests in order, each no earlier than its cycle, until all are answered.
    /// Returns the responses and the number of cycles evaluated.
    fn drive(sys: &mut Hierarchy, mut traffic: Vec<VecDeque<(u64, MemReq)>>, skip: Skip) -> (Log, u64) {
        let mut log = Log::new();
        let mut evals = 0;
        let mut d = Step::default();
        loop {
            evals += 1;
            let c = sys.cycle();
            let offers: Vec<Option<MemReq>> =
                traffic.iter().map(|q| q.front().filter(|(t, _)| *t <= c).map(|x| x.1)).collect();
            sys.eval(&offers, &mut d);
            for (sm, o) in d.out.iter().enumerate() {
                log.extend(o.resp.iter().map(|r| (c, sm, *r)));
                if o.ready && offers[sm].is_some() {
                    traffic[sm].pop_front();
                }
            }
            sys.commit(&d);
            let arrival = traffic.iter().filter_map(|q| q.front().map(|x| x.0)).min();
            let event = sys.next_event();
            if arrival.is_none() && event.is_none() {
                return (log, evals);
            }
            let now = sys.cycle();
            let target = arrival.into_iter().chain(event).min().unwrap().max(now);
            match skip {
                Skip::Never => {}
                Skip::ToNextEvent => sys.skip_to(target),
                Skip::PastNextEvent => {
                    if event == Some(target) && target > now {
                        sys.set_now(target + 1);
                    } else {
                        sys.skip_to(target);
                    }
                }
            }
            assert!(sys.cycle() < 10_000_000, "runaway");
        }
    }

    fn small() -> MemParams {
        MemParams {
            sms: 4,
            l1d_bytes: 1024,
            l1d_mshrs: 4,
            l1d_mshr_merge: 2,
            l1d_miss_queue: 2,
            // 2 banks of 16 sets of 2 ways (IPOLY needs 16 sets or more).
            l2_bytes: 8 * 1024,
            l2_assoc: Assoc::Ways(2),
            l2_banks: 2,
            l2_bank_queue: 16,
            l2_mshrs: 6,
            l2_mshr_merge: 3,
            l2_dram_queue: 4,
            dram_bytes_per_cycle: 8,
            dram_queue: 4,
            ..MemParams::default()
        }
    }

    /// Per SM, `n` requests in bursts: reads and writes of all kinds over a span a few times the
    /// L2, with a shared region every SM reads.
    fn traffic(seed: u64, sms: usize, n: usize) -> Vec<VecDeque<(u64, MemReq)>> {
        let mut rng = XorShift(seed);
        (0..sms)
            .map(|sm| {
                let mut t = 0;
                (0..n as u64)
                    .map(|i| {
                        t += if rng.below(40) == 0 { 300 } else { rng.below(3) };
                        let kind = ReqKind::ALL[rng.below(3) as usize];
                        let addr = if rng.below(2) == 0 {
                            rng.below(64) * 8
                        } else {
                            (sm as u64 + 1) * 0x10_0000 + rng.below(4096) * 8
                        };
                        let id = ((sm as u64) << 32) | i;
                        let req = if kind == ReqKind::StackSpill {
                            MemReq::write(id, addr, 8, kind)
                        } else {
                            MemReq::read(id, addr, 8, kind)
                        };
                        (t, req)
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn latency_of_each_level() {
        let mut sys = Hierarchy::new(MemParams::default());
        let one = |sm: usize, req: MemReq| {
            let mut t: Vec<VecDeque<(u64, MemReq)>> = vec![VecDeque::new(); 8];
            t[sm].push_back((0, req));
            t
        };
        let mut latency = |sm, req| {
            let start = sys.cycle();
            let (log, _) = drive(&mut sys, one(sm, req), Skip::ToNextEvent);
            assert_eq!(log.len(), 1);
            assert_eq!(log[0].2, req.response());
            log[0].0 - start
        };
        let node = |addr| MemReq::read(1, addr, 32, ReqKind::NodeFetch);
        assert_eq!(latency(0, node(0x4000)), 260, "L1D miss, L2 miss");
        assert_eq!(latency(0, node(0x4000)), 1, "L1D hit, used by the RT unit the next cycle");
        assert_eq!(latency(1, node(0x4000)), 160, "L1D miss, L2 hit");
        let spill = MemReq::write(2, 0x8000, 8, ReqKind::StackSpill);
        assert_eq!(latency(0, spill), 160, "store acknowledged by L2");
        let reload = MemReq::read(3, 0x8000, 8, ReqKind::StackReload);
        assert_eq!(latency(0, reload), 160, "reload: L1D did not allocate, L2 did");
        assert_eq!(sys.dram().counters().accesses, 1);
    }

    #[test]
    fn dram_bandwidth_adds_transfer_cycles() {
        let p = MemParams { dram_bytes_per_cycle: 8, ..MemParams::default() };
        let mut sys = Hierarchy::new(p);
        let mut t: Vec<VecDeque<(u64, MemReq)>> = vec![VecDeque::new(); 8];
        t[0].push_back((0, MemReq::read(1, 0, 8, ReqKind::NodeFetch)));
        let (log, _) = drive(&mut sys, t, Skip::Never);
        // A 32-byte sector at 8 B/cycle holds the bus 4 cycles: 3 more than one.
        assert_eq!(log[0].0, 263);
    }

    /// Every request answered exactly once, and the counters agree with each other.
    fn check_run(p: MemParams, seed: u64, n: usize) -> (Log, Hierarchy) {
        let mut sys = Hierarchy::new(p);
        let sms = p.sms as usize;
        let t = traffic(seed, sms, n);
        let all: Vec<(usize, MemReq)> =
            t.iter().enumerate().flat_map(|(sm, q)| q.iter().map(move |x| (sm, x.1))).collect();
        let (log, _) = drive(&mut sys, t, Skip::Never);
        let mut got: Vec<(usize, MemResp)> = log.iter().map(|x| (x.1, x.2)).collect();
        let mut want: Vec<(usize, MemResp)> = all.iter().map(|(sm, r)| (*sm, r.response())).collect();
        got.sort_by_key(|x| (x.0, x.1.id));
        want.sort_by_key(|x| (x.0, x.1.id));
        assert_eq!(got, want, "every request answered exactly once");

        let l1 = sys.l1d_counters();
        let (l2, dram) = (*sys.l2().counters(), *sys.dram().counters());
        assert_eq!(l1.accesses, (sms * n) as u64);
        assert_eq!(l1.hits + l1.misses, l1.accesses);
        let l1_read_misses = l1.misses - l1.by_kind[ReqKind::StackSpill.index()].misses;
        assert_eq!(l2.reads, l1_read_misses - l1.merged, "one L2 read per L1D fill");
        assert_eq!(l2.writes, l1.writes, "write-through");
        assert_eq!(l2.hits + l2.misses, l2.accesses);
        let l2_write_misses = l2.kind(ReqKind::StackSpill).misses;
        assert_eq!(dram.reads, l2.misses - l2_write_misses - l2.merged, "one read per L2 fill");
        assert_eq!(dram.writes, l2.write_backs);
        let by_kind: u64 = dram.by_kind.iter().map(|k| k.accesses).sum();
        assert_eq!(by_kind, dram.accesses);
        (log, sys)
    }

    /// Everything a run's report is made of.
    fn results(sys: &Hierarchy) -> (u64, Counters, Counters, Counters) {
        (sys.cycle(), sys.l1d_counters(), *sys.l2().counters(), *sys.dram().counters())
    }

    #[test]
    fn random_traffic_is_answered_and_counted_consistently() {
        let (_, sys) = check_run(small(), 1, 400);
        let l1 = sys.l1d_counters();
        // The run must exercise what it claims to check.
        assert!(l1.hits > 0 && l1.merged > 0 && l1.stall_cycles > 0);
        let l2 = sys.l2().counters();
        assert!(l2.hits > 0 && l2.merged > 0 && l2.write_backs > 0 && l2.stall_cycles > 0);
        for kind in ReqKind::ALL {
            assert!(sys.dram().counters().kind(kind).accesses > 0, "{kind:?}");
        }
    }

    #[test]
    fn runs_are_deterministic() {
        let (a, sa) = check_run(small(), 7, 200);
        let (b, sb) = check_run(small(), 7, 200);
        assert_eq!(a, b);
        assert_eq!(results(&sa), results(&sb));
        let (c, _) = check_run(small(), 8, 200);
        assert_ne!(a, c, "a different seed differs");
    }

    #[test]
    fn skipping_idle_cycles_matches_stepping() {
        for seed in [3, 4] {
            // Sparse enough to leave the SMs waiting on memory, dense enough to queue at times.
            let t: Vec<VecDeque<(u64, MemReq)>> = traffic(seed, 4, 200)
                .into_iter()
                .map(|q| q.into_iter().map(|(t, r)| (t * 20, r)).collect())
                .collect();
            let stepped = drive(&mut Hierarchy::new(small()), t.clone(), Skip::Never);
            let skipped = drive(&mut Hierarchy::new(small()), t.clone(), Skip::ToNextEvent);
            assert_eq!(stepped.0, skipped.0, "seed {seed}");
            assert!(skipped.1 * 2 < stepped.1, "idle cycles were skipped: {} of {}", skipped.1, stepped.1);
            let planted = drive(&mut Hierarchy::new(small()), t, Skip::PastNextEvent);
            assert_ne!(stepped.0, planted.0, "skipping past an event must show");
        }
    }

    #[test]
    #[should_panic(expected = "would miss the event")]
    fn skip_to_refuses_to_skip_an_event() {
        let mut sys = MemSystem::new(MemParams::default()).unwrap();
        let mut down = vec![None; 8];
        down[0] = Some(MemReq::read(1, 0, 32, ReqKind::NodeFetch));
        let d = sys.step(&down);
        sys.commit(&d);
        // The request's tag check, at the end of its bank pipeline.
        let e = sys.next_event().unwrap();
        assert!(e > sys.cycle());
        sys.skip_to(e);
        sys.skip_to(e + 1);
    }

    /// One SM, one request at a time: every L1D and L2 hit or miss must be what reference LRU
    /// caches predict (L1D write-evict or write-through, without allocate; L2 write-allocate,
    /// indexed by the L2 mapping of `p`), and every latency must be the level's figure:
    /// `l1d_hit_latency`, 160 or 260 for reads, 160 for stores. `evict_ref`: what the reference
    /// does on an L1D store hit (a planted mismatch when it differs from `p.l1d_write`).
    fn caches_against_reference(
        p: MemParams,
        fifo_l1d: bool,
        fifo_l2: bool,
        evict_ref: bool,
    ) -> Result<(), String> {
        caches_against(p, fifo_l1d, fifo_l2, evict_ref, Geometry::l2(&p))
    }

    /// As [`caches_against_reference`], the reference L2 shaped as `l2_ref`.
    fn caches_against(
        p: MemParams,
        fifo_l1d: bool,
        fifo_l2: bool,
        evict_ref: bool,
        l2_ref: Geometry,
    ) -> Result<(), String> {
        let mut sys = Hierarchy::new(p);
        let mut r1 = RefLru::new(sys.l1d(0).tags().geometry());
        let mut r2 = RefLru::new(l2_ref);
        r1.fifo = fifo_l1d;
        r2.fifo = fifo_l2;
        let mut rng = XorShift(11);
        for i in 0..3000 {
            // Half the accesses within three L1Ds' worth, half within three L2s' worth.
            let span = 3 * u64::from(if rng.below(2) == 0 { p.l1d_bytes } else { p.l2_bytes });
            let addr = rng.below(span / 8) * 8;
            let req = if rng.below(4) == 0 {
                MemReq::write(i, addr, 8, ReqKind::StackSpill)
            } else {
                MemReq::read(i, addr, 8, ReqKind::NodeFetch)
            };
            let want1 = r1.lookup(addr).is_hit();
            let want2 = (req.write || !want1).then(|| r2.lookup(addr).is_hit());
            let (h1, a2, h2) =
                (sys.l1d(0).counters().hits, sys.l2().counters().accesses, sys.l2().counters().hits);
            let start = sys.cycle();
            let (log, _) = drive(&mut sys, vec![VecDeque::from([(start, req)])], Skip::ToNextEvent);
            let got1 = sys.l1d(0).counters().hits > h1;
            let got2 = (sys.l2().counters().accesses > a2).then(|| sys.l2().counters().hits > h2);
            if (got1, got2) != (want1, want2) {
                return Err(format!(
                    "request {i} {req:?}: L1D/L2 hit {got1}/{got2:?}, reference {want1}/{want2:?}"
                ));
            }
            let latency = log[0].0 - start;
            let expected = match (req.write, want1, want2) {
                (true, _, _) => 160,
                (false, true, _) => u64::from(p.l1d_hit_latency),
                (false, false, Some(true)) => 160,
                (false, false, _) => 260,
            };
            if latency != expected {
                return Err(format!("request {i} {req:?}: latency {latency}, expected {expected}"));
            }
            // Update the references as the caches do.
            match (want1, req.write) {
                (true, true) if evict_ref => r1.invalidate(addr),
                (true, _) => r1.touch(addr),
                (false, false) => {
                    r1.fill(addr);
                }
                (false, true) => {}
            }
            match want2 {
                Some(true) => r2.touch(addr),
                Some(false) => {
                    r2.fill(addr);
                }
                None => {}
            }
        }
        Ok(())
    }

    /// The reference test's system: one SM, small caches, 2 L2 banks of 16 sets.
    fn ref_params() -> MemParams {
        MemParams {
            sms: 1,
            l1d_bytes: 2048,
            l2_bytes: 16384,
            l2_assoc: Assoc::Ways(4),
            l2_banks: 2,
            ..MemParams::default()
        }
    }

    /// The old mapping and L1D policy.
    fn old(p: MemParams) -> MemParams {
        MemParams {
            l1d_write: crate::mem::L1dWrite::WriteThrough,
            l1d_hit_latency: 20,
            l2_set_index: crate::mem::SetIndex::Linear,
            l2_interleave_bytes: 128,
            ..p
        }
    }

    #[test]
    fn cache_hits_and_latencies_match_reference_lru() {
        let p = ref_params();
        caches_against(p, false, false, true, Geometry::l2(&p)).unwrap();
        caches_against_reference(old(ref_params()), false, false, false).unwrap();
        // Linear index within 256-byte sub-partitions.
        let linear = MemParams { l2_set_index: crate::mem::SetIndex::Linear, ..ref_params() };
        caches_against_reference(linear, false, false, true).unwrap();
    }

    #[test]
    fn cache_checker_catches_a_fifo_reference_and_a_wrong_write_policy() {
        assert!(caches_against_reference(ref_params(), true, false, true).is_err());
        assert!(caches_against_reference(ref_params(), false, true, true).is_err());
        assert!(caches_against_reference(ref_params(), false, false, false).is_err());
        assert!(caches_against_reference(old(ref_params()), false, false, true).is_err());
    }

    #[test]
    fn cache_checker_catches_a_reference_with_another_set_index() {
        // The reference indexes each bank linearly while the L2 hashes (IPOLY): hits differ.
        let p = ref_params();
        let mut linear = Geometry::l2(&p);
        linear.banked.as_mut().expect("banked L2").index = crate::mem::SetIndex::Linear;
        assert!(caches_against(p, false, false, true, linear).is_err());
        // And the old single array against the new mapping.
        let old_ref = Geometry::l2(&old(p));
        assert!(caches_against(p, false, false, true, old_ref).is_err());
    }

    #[test]
    fn probe_names_every_unit() {
        let sys = MemSystem::new(MemParams { sms: 2, ..MemParams::default() }).unwrap();
        let d = sys.step(&[Some(MemReq::read(1, 0x40, 32, ReqKind::NodeFetch)), None]);
        let mut s = Snapshot::default();
        sys.probe(&d, &mut s);
        assert_eq!(s.get("l2.accept_count"), Some(1));
        assert_eq!(s.get("l2.accept_addr"), Some(0x40));
        assert!(s.get("l2.mshr_occupancy").is_some());
        assert!(s.get("dram.queue_depth").is_some());
    }

    #[test]
    fn eight_busy_sms_are_answered_and_counted_consistently() {
        let p = MemParams { sms: 8, ..small() };
        let (_, sys) = check_run(p, 21, 300);
        assert!(sys.l1d_counters().stall_cycles > 0 && sys.l2().counters().stall_cycles > 0, "busy");
    }

    #[test]
    fn a_reused_step_buffer_matches_a_fresh_step_every_cycle() {
        let mut a = Hierarchy::new(small());
        let mut b = Hierarchy::new(small());
        let mut d = Step::default();
        let mut t = traffic(9, 4, 100);
        for _ in 0..3000 {
            let c = a.cycle();
            let offers: Vec<Option<MemReq>> =
                t.iter().map(|q| q.front().filter(|(at, _)| *at <= c).map(|x| x.1)).collect();
            b.eval(&offers, &mut d);
            // Evaluating again changes nothing: the kernel is a function of registers and inputs.
            let fresh = a.step(&offers);
            assert_eq!(fresh.out, d.out);
            assert_eq!(fresh.l1d, d.l1d);
            for (sm, o) in fresh.out.iter().enumerate() {
                if o.ready && offers[sm].is_some() {
                    t[sm].pop_front();
                }
            }
            a.commit(&fresh);
            b.commit(&d);
        }
        assert_eq!(results(&a), results(&b));
        assert!(a.l2().counters().accesses > 0);
    }

    #[test]
    #[should_panic(expected = "committed a step evaluated in another cycle")]
    fn committing_a_step_twice_is_refused() {
        let mut sys = MemSystem::new(small()).unwrap();
        let mut d = MemStep::default();
        sys.eval(&[Some(MemReq::read(1, 0, 32, ReqKind::NodeFetch)), None, None, None], &mut d);
        sys.commit(&d);
        sys.commit(&d);
    }

    /// Runs random traffic, probing every cycle between eval and commit, until `visit` returns
    /// false or everything is answered.
    fn probe_each_cycle(mut visit: impl FnMut(&Snapshot) -> bool) {
        let mut sys = Hierarchy::new(small());
        let mut t = traffic(2, 4, 300);
        let mut d = Step::default();
        while t.iter().any(|q| !q.is_empty()) || sys.next_event().is_some() {
            assert!(sys.cycle() < 100_000, "runaway");
            let c = sys.cycle();
            let offers: Vec<Option<MemReq>> =
                t.iter().map(|q| q.front().filter(|(at, _)| *at <= c).map(|x| x.1)).collect();
            sys.eval(&offers, &mut d);
            for (sm, o) in d.out.iter().enumerate() {
                if o.ready && offers[sm].is_some() {
                    t[sm].pop_front();
                }
            }
            let mut s = Snapshot::default();
            sys.probe(&d, &mut s);
            if !visit(&s) {
                return;
            }
            sys.commit(&d);
        }
    }

    /// The first probed value that does not fit its width with `spare` bits fewer.
    fn probed_overflow(spare: u32) -> Option<(String, u32, u64)> {
        let mut bad = None;
        probe_each_cycle(|s| {
            bad = s
                .signals
                .iter()
                .find(|(_, w, v)| w.saturating_sub(spare) < 64 && *v >> w.saturating_sub(spare) != 0)
                .cloned();
            bad.is_none()
        });
        bad
    }

    #[test]
    fn probed_values_fit_their_declared_widths() {
        assert_eq!(probed_overflow(0), None);
        // The check can fail: one bit fewer does not hold what the run shows.
        assert!(probed_overflow(1).is_some());
    }

    /// Counts this thread's heap allocations (the test binary's allocator).
    mod allocations {
        use std::alloc::{GlobalAlloc, Layout, System};
        use std::cell::Cell;

        thread_local! {
            static COUNT: Cell<u64> = const { Cell::new(0) };
        }

        struct Counting;

        fn count() {
            let _ = COUNT.try_with(|c| c.set(c.get() + 1));
        }

        // SAFETY: every call is forwarded to the system allocator unchanged.
        unsafe impl GlobalAlloc for Counting {
            unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
                count();
                unsafe { System.alloc(layout) }
            }
            unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
                count();
                unsafe { System.alloc_zeroed(layout) }
            }
            unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
                count();
                unsafe { System.realloc(ptr, layout, new_size) }
            }
            unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
                unsafe { System.dealloc(ptr, layout) }
            }
        }

        #[global_allocator]
        static ALLOCATOR: Counting = Counting;

        /// Allocations made by this thread so far.
        pub fn so_far() -> u64 {
            COUNT.with(Cell::get)
        }
    }

    /// Allocations in 200 cycles in which every SM's request hits in its L1D, after warming up.
    fn allocations_per_hit_cycles() -> u64 {
        let mut sys = Hierarchy::new(small());
        let mut offers: Vec<Option<MemReq>> =
            (0..4).map(|sm| Some(MemReq::read(0, sm * 0x1000, 8, ReqKind::NodeFetch))).collect();
        let mut d = Step::default();
        let mut run = |sys: &mut Hierarchy, cycles: u64| {
            for _ in 0..cycles {
                sys.eval(&offers, &mut d);
                for (o, r) in d.out.iter().zip(&mut offers) {
                    if let (true, Some(r)) = (o.ready, r) {
                        r.id += 1;
                    }
                }
                sys.commit(&d);
            }
        };
        // Misses, fills, then hits that fill the buffers to their steady size. The misses
        // allocate (MSHR entries, pending-request maps): the counter counts.
        let start = allocations::so_far();
        run(&mut sys, 1000);
        assert!(allocations::so_far() > start);
        assert!(sys.l1d_counters().hits > 100);
        let before = allocations::so_far();
        run(&mut sys, 200);
        allocations::so_far() - before
    }

    #[test]
    fn cycles_of_hits_allocate_nothing() {
        assert_eq!(allocations_per_hit_cycles(), 0);
    }

    #[test]
    fn bad_parameters_are_rejected() {
        let e = MemSystem::new(MemParams { l1d_bytes: 0, ..MemParams::default() }).unwrap_err();
        assert_eq!(e.parameter, "l1d_bytes");
    }
}
