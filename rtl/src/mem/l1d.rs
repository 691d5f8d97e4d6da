//! Per-SM L1 data cache.
//!
//! ```text
//!             ┌──────── parked (1 request that could not proceed) ────────┐
//!   req ─────►│ tag check ─ hit ──► hit pipe (hit_latency) ──────────────► │ out ─► resp
//!   (≤ 1/cyc) │           ─ read miss ─► MSHR ─ allocate ─► miss queue ───┼──► down (to L2)
//!             │           ─ write ── evict / keep sector ─► miss queue ───┤
//!   fill ────►│ tag fill, release MSHR waiters / forward write acks ─────► │ out
//!             └────────────────────────────────────────────────────────────┘
//! ```
//!
//! Clocking: `ready`, `down_req` and `resp` are register outputs; [`L1d::eval`] (pure) takes the
//! SM's request, the L2's grant of `down_req` (`down_ready`, combinational: the L2 is evaluated
//! first) and the L2's responses, and writes the cycle's outputs and decisions into a step,
//! which [`L1d::commit`] applies at the clock edge.
//!
//! Handshake: `ready` is high unless a request is parked. A request accepted in cycle `t` is
//! looked up in cycle `t`: a read hit answers at `t + hit_latency`; a read miss merges into the
//! MSHR entry of its sector or allocates one and queues a sector read for L2; a store goes on to
//! L2 and is acknowledged when L2 acknowledges it. A store hit invalidates its sector
//! (write-evict, [`L1dWrite::WriteEvict`], Vulkan-Sim's dl1 policy for the RT unit's global
//! stores) or refreshes LRU and keeps it (write-through, the `legacy` preset's); a store miss leaves
//! the tags alone (no write-allocate) in both. A request that needs an MSHR entry or a miss-queue slot
//! that is not there is parked and retried every cycle, and `ready` is low meanwhile (so a later
//! hit waits behind it, as in an in-order cache pipeline). Responses from L2 are registered: they
//! fill the tags at the clock edge and their waiters' responses are visible the next cycle. All
//! responses visible in a cycle are delivered together.
//!
//! The down port: the L2's grant comes in as `down_ready` in the same cycle, and the miss queue
//! pops at the edge; a queued request that is not granted changes nothing, so a cycle with no
//! request, fill or grant coming in and no work held is quiet whatever the queue holds.
//! [`L1d::miss_queue`], [`L1d::pop_miss_queue`] and [`L1d::next_event_inside`] are there for a
//! runner that keeps the queue's grants itself (the windowed run's detached L1D, `sim::split`).

use super::cache::{Geometry, TagStore};
use super::mshr::{Mshr, Outcome, Waiter};
use super::{Counters, L1dWrite, MemParams, MemReq, MemResp, MemWidths, ReqKind, ADDR_BITS, FLAG_BITS};
use crate::clock::Unit;
use crate::trace::{Kind, Sink};
use std::collections::VecDeque;

/// What the tag-check stage does with its request this cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Action {
    Hit,
    Merge,
    Allocate,
    WriteThrough,
    Park,
}

/// What an L2 response completes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Pending {
    /// The sector fill of an MSHR entry.
    Fill(u64),
    /// A store; forward this acknowledgement.
    Write(MemResp),
}

/// Down requests awaiting L2's response, by down id. Ids are handed out in order, so the table
/// is a window from the oldest id still in flight (`base`) to the newest, with a hole for each
/// id already answered: a lookup is an index, where a hash map would cost
/// a hash probe per insert and per removal.
#[derive(Clone, Debug, Default)]
struct InFlight {
    base: u64,
    slots: VecDeque<Option<Pending>>,
}

impl InFlight {
    /// Records down id `id`, the next in order.
    fn insert(&mut self, id: u64, p: Pending) {
        debug_assert_eq!(id, self.base + self.slots.len() as u64, "down ids are handed out in order");
        self.slots.push_back(Some(p));
    }

    /// Takes what id `id` completes (`None` if it is not in flight); drops answered ids from the
    /// front of the window.
    fn remove(&mut self, id: u64) -> Option<Pending> {
        let i = usize::try_from(id.checked_sub(self.base)?).ok()?;
        let p = self.slots.get_mut(i)?.take();
        while let Some(None) = self.slots.front() {
            self.slots.pop_front();
            self.base += 1;
        }
        p
    }
}

/// This cycle's inputs.
#[derive(Clone, Copy, Debug, Default)]
pub struct L1dIn<'a> {
    /// The SM's request, if valid.
    pub req: Option<MemReq>,
    /// The L2 grants [`L1d::down_req`] this cycle: the L2's combinational output
    /// ([`super::l2::L2Out::granted`]), so the L2 is evaluated before the L1Ds.
    pub down_ready: bool,
    /// The L2's responses for this L1D ([`super::l2::L2::resp`], a register output of the L2).
    pub fills: &'a [MemResp],
}

/// This cycle's combinational outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct L1dOut {
    /// `req_valid && req_ready`: the SM's request is taken at this clock edge.
    pub req_fire: bool,
    /// `down_valid && down_ready`: the head of the miss queue goes to the L2.
    pub down_fire: bool,
}

/// One cycle's evaluation: the outputs and the decisions [`L1d::commit`] applies. Its buffer is
/// reused from cycle to cycle; [`L1d::eval`] overwrites all of it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct L1dStep {
    /// The cycle this step was evaluated in ([`L1d::commit`] refuses a stale step).
    at: u64,
    pub out: L1dOut,
    /// The offered request: an input kept for the probe (a copy, no logic).
    req: Option<MemReq>,
    /// The request in the tag-check stage (parked or newly accepted) and its fate.
    work: Option<(MemReq, Action)>,
    /// The L2's responses, latched at the edge.
    fills: Vec<MemResp>,
    /// Evaluated on a quiet cycle ([`L1d::eval`]): the step is the same in every quiet cycle but
    /// for `at`, and its commit only advances the cycle.
    quiet: bool,
}

#[derive(Clone, Debug)]
pub struct L1d {
    params: MemParams,
    widths: MemWidths,
    tags: TagStore,
    mshr: Mshr,
    /// Hits in flight: (cycle visible, response), in order.
    hit_pipe: VecDeque<(u64, MemResp)>,
    /// Requests for L2; the head is offered on the down port.
    miss_queue: VecDeque<MemReq>,
    /// Down requests awaiting L2's response, by down id.
    pending: InFlight,
    next_down_id: u64,
    parked: Option<MemReq>,
    /// Responses visible this cycle (the response register).
    out: Vec<MemResp>,
    now: u64,
    counters: Counters,
}

impl L1d {
    pub fn new(p: &MemParams) -> L1d {
        L1d {
            params: *p,
            widths: p.widths(),
            tags: TagStore::new(Geometry::new(p.l1d_bytes, p.l1d_assoc, p.line_bytes, p.sector_bytes)),
            mshr: Mshr::new(p.l1d_mshrs, p.l1d_mshr_merge),
            hit_pipe: VecDeque::new(),
            miss_queue: VecDeque::new(),
            pending: InFlight::default(),
            next_down_id: 0,
            parked: None,
            out: Vec::new(),
            now: 0,
            counters: Counters::default(),
        }
    }

    /// The miss queue: requests for the L2, the head offered on the down port ([`L1d::down_req`]).
    pub(crate) fn miss_queue(&self) -> &VecDeque<MemReq> {
        &self.miss_queue
    }

    /// The head of the miss queue leaves for the L2: what a granted down request does at the
    /// clock edge.
    pub(crate) fn pop_miss_queue(&mut self) {
        self.miss_queue.pop_front();
    }

    /// Register output: the L1D takes a request this cycle.
    pub fn ready(&self) -> bool {
        self.parked.is_none()
    }

    /// What the SM sees as `ready` in the cycle `d` was evaluated: the `ready` register, and with
    /// a request offered (`offered`) whether the L1D took it (the same, unless a test withholds
    /// the offered request from the L1D).
    #[inline]
    pub fn sm_ready(&self, d: &L1dStep, offered: bool) -> bool {
        self.ready() && (!offered || d.out.req_fire)
    }

    /// Register output: the request offered to L2 this cycle.
    pub fn down_req(&self) -> Option<MemReq> {
        self.miss_queue.front().copied()
    }

    /// Register output: responses visible this cycle.
    pub fn resp(&self) -> &[MemResp] {
        &self.out
    }

    pub fn counters(&self) -> &Counters {
        &self.counters
    }

    pub fn mshr_occupancy(&self) -> usize {
        self.mshr.len()
    }

    pub fn tags(&self) -> &TagStore {
        &self.tags
    }

    /// The first cycle, from now on, in which the L1D acts with no input, its down port left out:
    /// a request parked (retried), responses shown (cleared at the edge) or a hit becoming
    /// visible at the edge. [`L1d::next_event`] adds the down port.
    pub(crate) fn next_event_inside(&self) -> Option<u64> {
        if self.parked.is_some() || !self.out.is_empty() {
            return Some(self.now);
        }
        self.hit_pipe.front().map(|&(visible, _)| visible - 1)
    }

    /// No request, fill or grant comes in and the registers have no event of their own this cycle
    /// ([`L1d::next_event_inside`]: nothing parked or shown, no hit visible at the edge). A queued
    /// request that is not granted changes nothing.
    #[inline]
    fn quiet(&self, i: &L1dIn) -> bool {
        i.req.is_none()
            && i.fills.is_empty()
            && (!i.down_ready || self.miss_queue.is_empty())
            && self.next_event_inside().is_none_or(|e| e > self.now)
    }

    fn eval_full(&self, i: &L1dIn, d: &mut L1dStep) {
        let ready = self.ready();
        if let (true, Some(r)) = (ready, &i.req) {
            self.params.check_request(r);
        }
        let work = match self.parked {
            Some(parked) => Some(parked),
            None => i.req,
        }
        .map(|r| (r, self.classify(&r)));
        d.at = self.now;
        d.out = L1dOut {
            req_fire: ready && i.req.is_some(),
            down_fire: i.down_ready && !self.miss_queue.is_empty(),
        };
        d.req = i.req;
        d.work = work;
        d.fills.clear();
        d.fills.extend_from_slice(i.fills);
    }

    fn classify(&self, r: &MemReq) -> Action {
        let room = self.miss_queue.len() < self.params.l1d_miss_queue as usize;
        if r.write {
            return if room { Action::WriteThrough } else { Action::Park };
        }
        if self.tags.lookup(r.addr).is_hit() {
            return Action::Hit;
        }
        match self.mshr.check(self.params.sector_of(r.addr)) {
            Outcome::Merge => Action::Merge,
            Outcome::Allocate if room => Action::Allocate,
            _ => Action::Park,
        }
    }

    fn send_down(&mut self, req: MemReq, pending: Pending) {
        let id = self.next_down_id;
        self.next_down_id += 1;
        self.miss_queue.push_back(MemReq { id, ..req });
        self.pending.insert(id, pending);
    }

    fn commit_full(&mut self, d: &L1dStep) {
        let next = self.now + 1;
        if d.out.down_fire {
            self.pop_miss_queue();
        }
        if let Some((r, action)) = d.work {
            self.parked = None;
            let key = self.params.sector_of(r.addr);
            let waiter = Waiter { port: 0, id: r.id, addr: r.addr };
            match action {
                Action::Park => {
                    self.parked = Some(r);
                    self.counters.stall_cycles += 1;
                }
                Action::Hit => {
                    self.tags.touch(r.addr);
                    let visible = self.now + u64::from(self.params.l1d_hit_latency);
                    self.hit_pipe.push_back((visible, r.response()));
                    self.counters.lookup(&r, true);
                }
                Action::Merge => {
                    self.mshr.insert(key, waiter);
                    self.counters.lookup(&r, false);
                    self.counters.merged += 1;
                }
                Action::Allocate => {
                    self.mshr.insert(key, waiter);
                    let fill = MemReq::read(0, key, self.params.sector_bytes, r.kind);
                    self.send_down(fill, Pending::Fill(key));
                    self.counters.lookup(&r, false);
                }
                Action::WriteThrough => {
                    let hit = self.tags.lookup(r.addr).is_hit();
                    if hit {
                        match self.params.l1d_write {
                            L1dWrite::WriteEvict => self.tags.invalidate(r.addr),
                            L1dWrite::WriteThrough => self.tags.touch(r.addr),
                        }
                    }
                    self.send_down(r, Pending::Write(r.response()));
                    self.counters.lookup(&r, hit);
                }
            }
        }
        self.out.clear();
        while let Some(&(visible, resp)) = self.hit_pipe.front() {
            if visible > next {
                break;
            }
            self.out.push(resp);
            self.hit_pipe.pop_front();
        }
        for f in &d.fills {
            match self.pending.remove(f.id) {
                Some(Pending::Fill(key)) => {
                    // Write-through: L1D lines are never dirty, so a victim needs no write-back.
                    self.tags.fill(key, None);
                    let out = &mut self.out;
                    self.mshr.release_each(key, |w| out.push(MemResp { id: w.id, addr: w.addr }));
                }
                Some(Pending::Write(ack)) => self.out.push(ack),
                None => panic!("L1D got a response for unknown down id {}", f.id),
            }
        }
        self.now = next;
    }
}

impl Unit for L1d {
    /// Moves the clock to `cycle` over cycles in which nothing happens (a runner's idle skip):
    /// all that committing a quiet step in each would do.
    fn skip_to(&mut self, cycle: u64) {
        self.now = cycle;
    }

    /// Next cycle whose commit changes something, ignoring L2 responses; `None` when idle. A
    /// request in the miss queue is offered down every cycle until the L2 grants it.
    fn next_event(&self) -> Option<u64> {
        if !self.miss_queue.is_empty() {
            return Some(self.now);
        }
        self.next_event_inside()
    }

    type In<'a> = L1dIn<'a>;
    type Step = L1dStep;

    /// Combinational logic of one cycle: a pure function of the registers and `i`, written into
    /// `d` (every field overwritten; the fills buffer is reused, so no allocation once warm).
    ///
    /// A quiet cycle ([`L1d::quiet`]: no request, fill or grant comes in, nothing is parked or
    /// shown, and no hit becomes visible at the edge) evaluates to the same step every time
    /// but for the cycle it carries; when `d` already holds one, only that is updated, and
    /// [`L1d::commit`] only advances the cycle. Test:
    /// `quiet_cycles_skip_work_with_identical_steps_and_state`.
    fn eval(&self, i: L1dIn<'_>, d: &mut L1dStep) {
        let quiet = self.quiet(&i);
        if quiet && d.quiet {
            d.at = self.now;
            return;
        }
        self.eval_full(&i, d);
        d.quiet = quiet;
    }

    /// Clock edge: applies `d`, the step [`L1d::eval`] produced this cycle. The tag array, the
    /// MSHR table and the queues are RAM-like: `d` holds the cycle's decisions and this writes
    /// them, as a register file's write port does, without deciding anything new.
    fn commit(&mut self, d: &L1dStep) {
        assert_eq!(d.at, self.now, "L1D committed a step evaluated in another cycle");
        if d.quiet {
            self.now += 1;
        } else {
            self.commit_full(d);
        }
    }

    /// Shows the registers and `d`, this cycle's step, to `sink`; the decision flags (`hit`,
    /// `merge`, `park`) are derived here from the step, not computed by [`L1d::eval`].
    fn probe<S: Sink>(&self, d: &L1dStep, sink: &mut S) {
        if !sink.enabled() {
            return;
        }
        let req = d.req;
        let action = d.work.map(|(_, a)| a);
        let down = self.down_req();
        let w = &self.widths;
        sink.signal("req_valid", FLAG_BITS, u64::from(req.is_some()));
        sink.signal("req_ready", FLAG_BITS, u64::from(self.ready()));
        sink.signal_kind("req_addr", ADDR_BITS, req.map_or(0, |r| r.addr), Kind::Address);
        sink.signal("req_write", FLAG_BITS, u64::from(req.is_some_and(|r| r.write)));
        sink.signal_kind("req_kind", ReqKind::BITS, req.map_or(0, |r| r.kind.code()), ReqKind::KIND);
        sink.signal("hit", FLAG_BITS, u64::from(action == Some(Action::Hit)));
        sink.signal("merge", FLAG_BITS, u64::from(action == Some(Action::Merge)));
        sink.signal("park", FLAG_BITS, u64::from(action == Some(Action::Park)));
        sink.signal("mshr_occupancy", w.l1d_mshr_occupancy, self.mshr.len() as u64);
        sink.signal("miss_queue_depth", w.l1d_miss_queue_depth, self.miss_queue.len() as u64);
        sink.signal("down_valid", FLAG_BITS, u64::from(down.is_some()));
        sink.signal_kind("down_addr", ADDR_BITS, down.map_or(0, |r| r.addr), Kind::Address);
        sink.signal("resp_valid", FLAG_BITS, u64::from(!self.out.is_empty()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::cache::Lookup;
    use crate::trace::Snapshot;

    /// An L1D in front of a stand-in L2 that accepts one request per cycle and answers every
    /// request `delay` cycles later.
    struct Bench {
        l1: L1d,
        delay: u64,
        l2: VecDeque<(u64, MemResp)>,
        l2_out: Vec<MemResp>,
        down_log: Vec<MemReq>,
        resp_log: Vec<(u64, MemResp)>,
        cycle: u64,
    }

    impl Bench {
        fn new(p: MemParams, delay: u64) -> Bench {
            Bench {
                l1: L1d::new(&p),
                delay,
                l2: VecDeque::new(),
                l2_out: Vec::new(),
                down_log: Vec::new(),
                resp_log: Vec::new(),
                cycle: 0,
            }
        }

        /// One cycle; returns whether `req` was accepted.
        fn step(&mut self, req: Option<MemReq>) -> bool {
            for r in self.l1.resp() {
                self.resp_log.push((self.cycle, *r));
            }
            let down = self.l1.down_req();
            let fills = std::mem::take(&mut self.l2_out);
            let mut d = L1dStep::default();
            self.l1.eval(L1dIn { req, down_ready: true, fills: &fills }, &mut d);
            let fire = d.out.req_fire;
            self.l1.commit(&d);
            if let Some(d) = down {
                self.down_log.push(d);
                self.l2.push_back((self.cycle + self.delay, d.response()));
            }
            while self.l2.front().is_some_and(|&(c, _)| c <= self.cycle + 1) {
                self.l2_out.push(self.l2.pop_front().unwrap().1);
            }
            self.cycle += 1;
            fire
        }

        fn run_until_quiet(&mut self) {
            for _ in 0..10_000 {
                if self.l1.next_event().is_none() && self.l2.is_empty() && self.l2_out.is_empty() {
                    return;
                }
                self.step(None);
            }
            panic!("did not settle");
        }
    }

    fn read(id: u64, addr: u64) -> Option<MemReq> {
        Some(MemReq::read(id, addr, 8, ReqKind::NodeFetch))
    }

    /// Two copies of one L1D on the same random requests and fills: one through [`L1d::eval`]
    /// and [`L1d::commit`] (quiet cycles skipped), one evaluated and committed in full every
    /// cycle. Every step and state must agree. Returns the quiet cycles.
    fn quiet_run(p: MemParams, seed: u64) -> u64 {
        use crate::mem::testutil::XorShift;
        let (mut fast, mut full) = (L1d::new(&p), L1d::new(&p));
        let (mut df, mut dg) = (L1dStep::default(), L1dStep::default());
        let mut rng = XorShift(seed);
        let mut l2: VecDeque<(u64, MemResp)> = VecDeque::new();
        let (mut fills, mut quiet) = (Vec::new(), 0);
        for now in 0..8000u64 {
            // Bursts of requests (reads, some stores) over a few lines, then pauses.
            let req = rng.burst_request(now);
            let down = fast.down_req();
            let i = L1dIn { req, down_ready: rng.below(3) != 0, fills: &fills };
            quiet += u64::from(fast.quiet(&i));
            fast.eval(i, &mut df);
            full.eval_full(&i, &mut dg);
            dg.quiet = df.quiet;
            assert_eq!(df, dg, "cycle {now}");
            fast.commit(&df);
            full.commit_full(&dg);
            assert_eq!(format!("{fast:?}"), format!("{full:?}"), "cycle {now}");
            if let Some(d) = down.filter(|_| df.out.down_fire) {
                l2.push_back((now + 5 + rng.below(40), d.response()));
            }
            fills.clear();
            while let Some(k) = l2.iter().position(|&(c, _)| c <= now + 1) {
                fills.push(l2.remove(k).unwrap().1);
            }
        }
        quiet
    }

    #[test]
    fn quiet_cycles_skip_work_with_identical_steps_and_state() {
        let d = MemParams::default();
        // A short miss queue and few MSHR entries park requests, on either.
        let params =
            [d, MemParams { l1d_hit_latency: 20, l1d_miss_queue: 2, ..d }, MemParams { l1d_mshrs: 2, ..d }];
        for (seed, p) in params.into_iter().enumerate() {
            let quiet = quiet_run(p, seed as u64 + 3);
            assert!(quiet > 2000, "the run has quiet cycles to skip ({quiet})");
        }
    }

    /// Cycle, after acceptance, in which a hit's response is visible to the requester.
    fn hit_latency(p: MemParams) -> u64 {
        let mut b = Bench::new(p, 50);
        assert!(b.step(read(1, 0x1000)));
        b.run_until_quiet();
        let t = b.cycle;
        assert!(b.step(read(2, 0x1008)));
        b.run_until_quiet();
        assert_eq!(b.l1.counters().hits, 1);
        assert_eq!(b.l1.counters().misses, 1);
        let (c, r) = *b.resp_log.last().unwrap();
        assert_eq!(r, MemResp { id: 2, addr: 0x1008 });
        c - t
    }

    #[test]
    fn hit_takes_exactly_the_hit_latency() {
        // Default: the RT unit's direct L1D access, a hit visible the cycle after the lookup
        // (the response register); the old load/store-unit figure stays reachable.
        assert_eq!(hit_latency(MemParams::default()), 1);
        assert_eq!(hit_latency(MemParams { l1d_hit_latency: 20, ..MemParams::default() }), 20);
    }

    #[test]
    fn two_misses_to_one_sector_make_one_l2_request() {
        let mut b = Bench::new(MemParams::default(), 50);
        assert!(b.step(read(1, 0x2000)));
        assert!(b.step(read(2, 0x2010)));
        // Another sector of the same line is another fill.
        assert!(b.step(read(3, 0x2020)));
        b.run_until_quiet();
        assert_eq!(b.down_log.iter().map(|r| r.addr).collect::<Vec<_>>(), vec![0x2000, 0x2020]);
        let mut ids: Vec<u64> = b.resp_log.iter().map(|(_, r)| r.id).collect();
        ids.sort();
        assert_eq!(ids, vec![1, 2, 3]);
        assert_eq!(b.l1.counters().merged, 1);
        // Both merged requests answer in the same cycle: the fill's.
        assert_eq!(b.resp_log[0].0, b.resp_log[1].0);
    }

    #[test]
    fn line_granular_configuration_merges_same_line_misses() {
        let p = MemParams { sector_bytes: 128, ..MemParams::default() };
        let mut b = Bench::new(p, 50);
        assert!(b.step(read(1, 0x2000)));
        assert!(b.step(read(2, 0x2060)));
        b.run_until_quiet();
        assert_eq!(b.down_log.len(), 1);
        assert_eq!(b.resp_log.len(), 2);
    }

    #[test]
    fn streaming_defaults_are_the_mobile_config() {
        // -gpgpu_cache:dl1 S:1:128:256,…,A:256:8,16:0,32 with alloc 's': 1 set × 256 ways × 4 × 4
        // MSHRs (gpu-cache.h:562-563), merge MAX_WARP_PER_SM (564), miss queue 16.
        let p = MemParams::default();
        assert_eq!((p.l1d_mshrs, p.l1d_mshr_merge, p.l1d_miss_queue), (256 * 4 * 4, 64, 16));
        // 4096 distinct sectors in flight at once are all taken without a stall.
        let mut b = Bench::new(MemParams { l1d_miss_queue: 4096, ..p }, 5000);
        for i in 0..4096 {
            assert!(b.step(read(i, i * 32)), "miss {i}");
        }
        assert_eq!(b.l1.mshr_occupancy(), 4096);
        assert_eq!(b.l1.counters().stall_cycles, 0);
    }

    #[test]
    fn full_mshr_stalls_until_a_fill() {
        let p = MemParams { l1d_miss_queue: 64, l1d_mshrs: 32, ..MemParams::default() };
        let mut b = Bench::new(p, 100);
        for i in 0..32 {
            assert!(b.step(read(i, i * 32)), "miss {i}");
        }
        assert_eq!(b.l1.mshr_occupancy(), 32);
        // The 33rd distinct sector is taken but parks; nothing more is accepted.
        assert!(b.step(read(32, 32 * 32)));
        let mut refused = 0;
        while !b.step(read(33, 0)) {
            refused += 1;
        }
        assert!(refused > 50, "stalled {refused} cycles");
        assert!(b.l1.counters().stall_cycles > 50);
        b.run_until_quiet();
        assert_eq!(b.resp_log.len(), 34);
        assert_eq!(b.down_log.len(), 33);
    }

    #[test]
    fn a_full_mshr_entry_parks_the_next_merge() {
        let p = MemParams { l1d_mshr_merge: 2, ..MemParams::default() };
        let mut b = Bench::new(p, 40);
        assert!(b.step(read(1, 0x100)));
        assert!(b.step(read(2, 0x104)));
        // Third request for the sector: taken, parked until the fill frees the entry.
        assert!(b.step(read(3, 0x108)));
        assert!(!b.step(read(4, 0x900)));
        b.run_until_quiet();
        assert_eq!(b.down_log.len(), 1, "the parked read hits after the fill");
        let ids: Vec<u64> = b.resp_log.iter().map(|(_, r)| r.id).collect();
        assert_eq!(ids, vec![1, 2, 3]);
        assert_eq!(b.l1.counters().merged, 1);
        assert_eq!(b.l1.counters().hits, 1);
    }

    /// Store miss, load (fills the sector), store hit, reload: returns the bench.
    fn store_sequence(write: L1dWrite) -> Bench {
        let mut b = Bench::new(MemParams { l1d_write: write, ..MemParams::default() }, 30);
        assert!(b.step(Some(MemReq::write(1, 0x40, 8, ReqKind::StackSpill))));
        b.run_until_quiet();
        assert_eq!(b.resp_log.len(), 1, "store acknowledged");
        assert_eq!(b.l1.tags().lines_held(), 0, "a store miss allocates nothing");
        assert!(b.down_log[0].write);
        assert!(b.step(Some(MemReq::read(2, 0x40, 8, ReqKind::StackReload))));
        b.run_until_quiet();
        assert_eq!(b.l1.counters().kind(ReqKind::StackReload).misses, 1);
        assert_eq!(b.l1.tags().lookup(0x40), Lookup::Hit);
        // Now present: a store hits and goes on to L2; then a reload.
        assert!(b.step(Some(MemReq::write(3, 0x40, 8, ReqKind::StackSpill))));
        assert!(b.step(Some(MemReq::read(4, 0x40, 8, ReqKind::StackReload))));
        b.run_until_quiet();
        assert_eq!(b.l1.counters().kind(ReqKind::StackSpill).misses, 1, "the second store hit");
        assert_eq!(b.resp_log.len(), 4);
        b
    }

    #[test]
    fn write_through_keeps_the_sector() {
        let b = store_sequence(L1dWrite::WriteThrough);
        // Store miss, fill, store hit: three L2 requests; the reload hits.
        assert_eq!(b.down_log.len(), 3);
        assert_eq!(b.l1.counters().kind(ReqKind::StackReload).misses, 1);
        assert_eq!(b.l1.counters().hits, 2);
    }

    #[test]
    fn write_evict_invalidates_the_sector_so_the_reload_misses() {
        let b = store_sequence(L1dWrite::WriteEvict);
        // The store hit invalidated the only valid sector: the line left the cache, and the
        // reload went to L2 again.
        assert_eq!(b.down_log.len(), 4);
        assert!(!b.down_log[3].write);
        assert_eq!(b.l1.counters().kind(ReqKind::StackReload).misses, 2);
        assert_eq!(b.l1.counters().hits, 1);
        // After the reload's fill the sector is back.
        assert_eq!(b.l1.tags().lookup(0x40), Lookup::Hit);
    }

    #[test]
    fn write_evict_keeps_the_lines_other_sectors() {
        let mut b = Bench::new(MemParams::default(), 30);
        assert!(b.step(read(1, 0x100)));
        assert!(b.step(read(2, 0x120)));
        b.run_until_quiet();
        assert!(b.step(Some(MemReq::write(3, 0x100, 8, ReqKind::StackSpill))));
        b.run_until_quiet();
        assert_eq!(b.l1.tags().lookup(0x100), Lookup::SectorMiss);
        assert_eq!(b.l1.tags().lookup(0x120), Lookup::Hit);
        assert_eq!(b.l1.tags().lines_held(), 1);
    }

    #[test]
    fn probe_shows_the_cycle() {
        let mut l1 = L1d::new(&MemParams::default());
        let mut d = L1dStep::default();
        l1.eval(L1dIn { req: read(1, 0x80), down_ready: false, fills: &[] }, &mut d);
        let mut s = Snapshot::default();
        l1.probe(&d, &mut s);
        assert_eq!(s.get("req_valid"), Some(1));
        assert_eq!(s.get("req_addr"), Some(0x80));
        assert_eq!(s.get("hit"), Some(0));
        l1.commit(&d);
        let mut s = Snapshot::default();
        l1.probe(&d, &mut s);
        assert_eq!(s.get("mshr_occupancy"), Some(1));
        assert_eq!(s.get("down_valid"), Some(1));
        let widths: Vec<u32> = s.signals.iter().map(|x| x.1).collect();
        assert!(widths.iter().all(|&w| (1..=64).contains(&w)));
    }
}
