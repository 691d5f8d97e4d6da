//! DRAM: a fixed latency behind one data bus of limited bandwidth, with a FIFO queue.
//!
//! ```text
//!   req ─► [queue ≤ dram_queue] ─► bus: ceil(bytes / bytes_per_cycle) cycles each ─► latency ─► resp
//! ```
//!
//! Accepts at most one request per cycle (valid/ready; ready while fewer than `dram_queue`
//! requests wait for the bus). A request accepted in cycle `a` starts on the bus at
//! `start = max(a, bus_free)`, holds it for `xfer = ceil(bytes / bytes_per_cycle)` cycles, and its
//! response is visible at `start + xfer - 1 + latency - 1` (unloaded, one-cycle transfer:
//! `a + latency - 1`; the L2's port and response registers add the last cycle, so an L2 miss costs
//! exactly `dram_latency` more than an L2 hit). Reads are answered; writes are posted: they use
//! the bus but produce no response. One channel carries the whole bandwidth: there are no bank or
//! row-buffer effects.
//!
//! Clocking: `ready` and `resp` are register outputs; [`Dram::eval`] (pure) decides whether the
//! offered request fires, and [`Dram::commit`] applies that at the clock edge.

use super::{Counters, MemParams, MemReq, MemResp, MemWidths, ADDR_BITS, FLAG_BITS, ID_BITS};
use crate::clock::Unit;
use crate::trace::{Kind, Sink};
use std::collections::VecDeque;

/// This cycle's inputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DramIn {
    /// The L2's request ([`super::l2::L2::dram_req`], a register output of the L2), if valid.
    pub req: Option<MemReq>,
}

/// This cycle's combinational outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DramOut {
    /// `req_valid && req_ready`: the request is accepted at this clock edge.
    pub req_fire: bool,
}

/// One cycle's evaluation: the outputs and the decisions [`Dram::commit`] applies.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DramStep {
    /// The cycle this step was evaluated in ([`Dram::commit`] refuses a stale step).
    at: u64,
    pub out: DramOut,
    /// The offered request (accepted iff `out.req_fire`).
    req: Option<MemReq>,
}

#[derive(Clone, Debug)]
pub struct Dram {
    latency: u64,
    bytes_per_cycle: u64,
    queue_cap: usize,
    widths: MemWidths,
    /// Start cycles of accepted requests not yet on the bus.
    waiting: VecDeque<u64>,
    /// First cycle the bus is free.
    bus_free: u64,
    /// Reads in flight: (cycle the response is visible, response), in order.
    in_flight: VecDeque<(u64, MemResp)>,
    /// Responses visible this cycle (the response register).
    out: Vec<MemResp>,
    now: u64,
    counters: Counters,
}

impl Dram {
    pub fn new(p: &MemParams) -> Dram {
        Dram {
            latency: u64::from(p.dram_latency),
            bytes_per_cycle: u64::from(p.dram_bytes_per_cycle),
            queue_cap: p.dram_queue as usize,
            widths: p.widths(),
            waiting: VecDeque::new(),
            bus_free: 0,
            in_flight: VecDeque::new(),
            out: Vec::new(),
            now: 0,
            counters: Counters::default(),
        }
    }

    /// Register output: the DRAM accepts a request this cycle.
    pub fn ready(&self) -> bool {
        self.waiting.len() < self.queue_cap
    }

    /// Register output: read responses visible this cycle.
    pub fn resp(&self) -> &[MemResp] {
        &self.out
    }

    /// Requests waiting for the bus.
    pub fn queue_depth(&self) -> usize {
        self.waiting.len()
    }

    pub fn counters(&self) -> &Counters {
        &self.counters
    }
}

impl Unit for Dram {
    /// Moves the clock to `cycle` over cycles with no event.
    fn skip_to(&mut self, cycle: u64) {
        self.now = cycle;
    }

    /// Next cycle whose commit changes something visible; `None` when idle.
    fn next_event(&self) -> Option<u64> {
        if !self.out.is_empty() {
            return Some(self.now);
        }
        let response = self.in_flight.front().map(|&(v, _)| v - 1);
        let start = self.waiting.front().map(|&s| s.max(self.now + 1) - 1);
        response.into_iter().chain(start).min()
    }

    type In<'a> = DramIn;
    type Step = DramStep;

    /// Combinational logic of one cycle: a pure function of the registers and `i`, written into
    /// `d` (every field overwritten).
    fn eval(&self, i: DramIn, d: &mut DramStep) {
        let req_fire = i.req.is_some() && self.ready();
        *d = DramStep { at: self.now, out: DramOut { req_fire }, req: i.req };
    }

    /// Clock edge: applies `d`, the step [`Dram::eval`] produced this cycle.
    fn commit(&mut self, d: &DramStep) {
        assert_eq!(d.at, self.now, "DRAM committed a step evaluated in another cycle");
        let next = self.now + 1;
        if let (true, Some(req)) = (d.out.req_fire, d.req) {
            let start = self.now.max(self.bus_free);
            let xfer = u64::from(req.bytes).div_ceil(self.bytes_per_cycle);
            self.bus_free = start + xfer;
            self.waiting.push_back(start);
            if !req.write {
                let visible = start + xfer - 1 + self.latency - 1;
                self.in_flight.push_back((visible, req.response()));
            }
            self.counters.access(&req);
        }
        while self.waiting.front().is_some_and(|&s| s <= next) {
            self.waiting.pop_front();
        }
        self.out.clear();
        while let Some(&(visible, resp)) = self.in_flight.front() {
            if visible > next {
                break;
            }
            self.out.push(resp);
            self.in_flight.pop_front();
        }
        self.now = next;
    }

    /// Shows the registers and `d`, this cycle's step, to `sink`.
    fn probe<S: Sink>(&self, d: &DramStep, sink: &mut S) {
        if !sink.enabled() {
            return;
        }
        let req = d.req;
        sink.signal("req_valid", FLAG_BITS, u64::from(req.is_some()));
        sink.signal("req_ready", FLAG_BITS, u64::from(self.ready()));
        sink.signal_kind("req_addr", ADDR_BITS, req.map_or(0, |r| r.addr), Kind::Address);
        sink.signal("req_write", FLAG_BITS, u64::from(req.is_some_and(|r| r.write)));
        sink.signal("queue_depth", self.widths.dram_queue_depth, self.waiting.len() as u64);
        sink.signal("resp_valid", FLAG_BITS, u64::from(!self.out.is_empty()));
        sink.signal_kind("resp_id", ID_BITS, self.out.first().map_or(0, |r| r.id), Kind::Data);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::testutil::XorShift;
    use crate::mem::ReqKind;
    use crate::trace::Snapshot;

    fn params(latency: u32, bpc: u32, queue: u32) -> MemParams {
        MemParams {
            dram_latency: latency,
            dram_bytes_per_cycle: bpc,
            dram_queue: queue,
            ..MemParams::default()
        }
    }

    /// (request id, cycle) pairs.
    type Times = Vec<(u64, u64)>;

    /// Offers requests per `offers[cycle]`; returns (id, cycle visible) of every response and the
    /// accept cycle of every request.
    fn run(p: &MemParams, offers: &[Option<MemReq>]) -> (Times, Times) {
        let mut dram = Dram::new(p);
        let (mut resps, mut accepts) = (Vec::new(), Vec::new());
        let mut pending: VecDeque<MemReq> = VecDeque::new();
        let mut cycle = 0;
        while cycle < offers.len() as u64 || !pending.is_empty() || dram.next_event().is_some() {
            if let Some(Some(r)) = offers.get(cycle as usize) {
                pending.push_back(*r);
            }
            for r in dram.resp() {
                resps.push((r.id, cycle));
            }
            let mut d = DramStep::default();
            dram.eval(DramIn { req: pending.front().copied() }, &mut d);
            if d.out.req_fire {
                accepts.push((pending.pop_front().unwrap().id, cycle));
            }
            dram.commit(&d);
            cycle += 1;
        }
        (resps, accepts)
    }

    /// The documented timing, written directly from the accept cycles.
    fn reference(p: &MemParams, reqs: &[MemReq], accepts: &[(u64, u64)], ignore_bandwidth: bool) -> Times {
        let mut bus_free = 0;
        let mut out = Vec::new();
        for &(id, a) in accepts {
            let r = reqs.iter().find(|r| r.id == id).unwrap();
            let xfer = u64::from(r.bytes).div_ceil(u64::from(p.dram_bytes_per_cycle));
            let start = if ignore_bandwidth { a } else { a.max(bus_free) };
            bus_free = start + xfer;
            if !r.write {
                out.push((id, start + xfer - 1 + u64::from(p.dram_latency) - 1));
            }
        }
        out
    }

    fn stream(seed: u64, n: usize) -> Vec<Option<MemReq>> {
        let mut rng = XorShift(seed);
        (0..n as u64)
            .map(|i| {
                (rng.below(3) != 0).then(|| {
                    let bytes = [8, 32, 64, 128][rng.below(4) as usize];
                    let addr = rng.below(1 << 20) * 128;
                    if rng.below(4) == 0 {
                        MemReq::write(i, addr, bytes, ReqKind::StackSpill)
                    } else {
                        MemReq::read(i, addr, bytes, ReqKind::NodeFetch)
                    }
                })
            })
            .collect()
    }

    #[test]
    fn unloaded_latency() {
        let p = params(100, 32, 8);
        let r = MemReq::read(7, 0x1000, 32, ReqKind::NodeFetch);
        let (resps, accepts) = run(&p, &[Some(r)]);
        assert_eq!(accepts, vec![(7, 0)]);
        assert_eq!(resps, vec![(7, 99)]);
    }

    #[test]
    fn bandwidth_queueing_matches_reference() {
        for (seed, bpc, queue) in [(1, 32, 4), (2, 16, 2), (3, 24, 64), (4, 8, 1)] {
            let p = params(30, bpc, queue);
            let offers = stream(seed, 400);
            let reqs: Vec<MemReq> = offers.iter().flatten().copied().collect();
            let (resps, accepts) = run(&p, &offers);
            assert_eq!(accepts.len(), reqs.len());
            assert_eq!(resps, reference(&p, &reqs, &accepts, false), "seed {seed}");
            // The planted reference without a bandwidth limit must disagree: the stream is
            // dense enough to queue.
            assert_ne!(resps, reference(&p, &reqs, &accepts, true), "seed {seed}");
        }
    }

    #[test]
    fn full_queue_refuses() {
        let p = params(10, 1, 2);
        let mut dram = Dram::new(&p);
        let r = |id| Some(MemReq::read(id, 0, 32, ReqKind::NodeFetch));
        let mut d = DramStep::default();
        // Each request holds the bus for 32 cycles: the first starts at once, two more wait.
        for id in 0..3 {
            dram.eval(DramIn { req: r(id) }, &mut d);
            assert!(d.out.req_fire);
            dram.commit(&d);
        }
        assert_eq!(dram.queue_depth(), 2);
        assert!(!dram.ready());
        dram.eval(DramIn { req: r(3) }, &mut d);
        assert!(!d.out.req_fire);
        let mut snap = Snapshot::default();
        dram.probe(&d, &mut snap);
        assert_eq!(snap.get("req_valid"), Some(1));
        assert_eq!(snap.get("req_ready"), Some(0));
        assert_eq!(snap.get("queue_depth"), Some(2));
        dram.commit(&d);
        assert_eq!(dram.counters().accesses, 3);
    }
}
