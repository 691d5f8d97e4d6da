//! The memory system's units as the windowed run clocks them apart (`window.rs`): the interfaces
//! it needs of them, declared here beside the run and implemented here from the units' own
//! registers and data accessors, so the units carry nothing for one runner.
//!
//! - [`DetachedL1d`]: an L1D running ahead of the L2 in its SM's window. It is never granted
//!   (`down_ready` false), so its miss queue only grows; the run keeps the real queue beside the
//!   L2's front end, reads each request the L1D sends down off its queue's tail
//!   ([`DetachedL1d::sent_at`]) and pops the L1D's copy when the front end granted the head
//!   ([`DetachedL1d::left_queue`]). The L1D's queue then holds the requests not yet known to have
//!   left: its length is an upper bound on the real one's, exact once the front end has run the
//!   cycles before.
//! - [`SplitL2`]: the L2 in two halves with clocks of their own: the front end (the banks'
//!   arbiters and the pipelines' entrances: [`SplitL2::front_eval`] of a [`FrontIn`] into a
//!   [`FrontStep`], applied by [`SplitL2::front_commit`]) and the back end (the tag checks on:
//!   [`Unit::eval`] with no request coming in, applied by [`SplitL2::back_commit`]), the back end
//!   up to the pipelines' delay ahead. A bank's length as the front end's arbiter must see it in
//!   its cycle is the requests it let in before that cycle less those the back end checked out
//!   before it; [`FrontEnd`] keeps both counts. The same results as the whole L2 (tested below).

use crate::clock::Unit;
use crate::mem::l1d::L1d;
use crate::mem::l2::{L2Step, L2};
use crate::mem::MemReq;
use std::collections::VecDeque;

/// An L1D whose miss queue the windowed run keeps beside the L2's front end (see the module
/// documentation). Evaluated with `down_ready` false.
pub(crate) trait DetachedL1d {
    /// After the clock edge of cycle `at`, with the queue `before` long before it: adds the
    /// requests sent down at that edge to `sent`, each with `at` (the real queue's from the next
    /// cycle on).
    fn sent_at(&self, at: u64, before: usize, sent: &mut Vec<(u64, MemReq)>);

    /// The head of the queue went to the L2 (the front end granted it in a cycle before this
    /// one).
    fn left_queue(&mut self);

    /// The queue's length bound: the requests sent down not yet known to have left.
    fn queue_bound(&self) -> usize;

    /// The first cycle in which the L1D acts with no input, its queue left out (the run counts
    /// the real queue's cycles itself).
    fn next_event_detached(&self) -> Option<u64>;
}

impl DetachedL1d for L1d {
    #[inline]
    fn sent_at(&self, at: u64, before: usize, sent: &mut Vec<(u64, MemReq)>) {
        // Never granted, the queue only grows at an edge: what it grew by was sent down at it
        // (most edges send nothing).
        let queue = self.miss_queue();
        if queue.len() > before {
            sent.extend(queue.range(before..).map(|&r| (at, r)));
        }
    }

    #[inline]
    fn left_queue(&mut self) {
        self.pop_miss_queue();
    }

    #[inline]
    fn queue_bound(&self) -> usize {
        self.miss_queue().len()
    }

    #[inline]
    fn next_event_detached(&self) -> Option<u64> {
        self.next_event_inside()
    }
}

/// What the split L2's front end keeps per bank to know the bank's length in its own cycle.
#[derive(Clone, Debug)]
pub(crate) struct FrontEnd {
    /// Requests the arbiter let in.
    let_in: Vec<u64>,
    /// Cycles in which the back end checked out a request, not yet seen by the front end.
    out_log: Vec<VecDeque<u64>>,
    /// Check-outs the front end has seen (in cycles before its own).
    out_seen: Vec<u64>,
}

impl FrontEnd {
    /// The front end of an L2 of `banks` banks, before any request.
    pub fn new(banks: usize) -> FrontEnd {
        FrontEnd { let_in: vec![0; banks], out_log: vec![VecDeque::new(); banks], out_seen: vec![0; banks] }
    }
}

/// One cycle's inputs of a split L2's front end ([`SplitL2::front_eval`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FrontIn<'a> {
    /// The front end's cycle.
    pub at: u64,
    /// Per bank: bit `sm` set when SM `sm`'s down request is for that bank ([`L2::bank_of`]).
    pub want: &'a [u64],
    /// Per SM: its down request (read only where `want` has the SM's bit).
    pub heads: &'a [MemReq],
}

/// One cycle of a split L2's front end ([`SplitL2::front_eval`]), applied by
/// [`SplitL2::front_commit`]: the cycle, the granted SMs (one bit each) and (bank, SM, request)
/// of each grant.
#[derive(Clone, Debug, Default)]
pub(crate) struct FrontStep {
    at: u64,
    pub granted: u64,
    accepted: Vec<(usize, u32, MemReq)>,
}

/// An L2 clocked in two halves (see the module documentation); the front end's state is `f`.
pub(crate) trait SplitL2 {
    /// The front end's cycle `i.at`, combinational: each requested bank with room grants one SM
    /// as [`Unit::eval`]'s arbiter does (the first from [`L2::arbiter_first`] on); writes the
    /// grants, with the requests they take, into `d`. The back end must have run every cycle
    /// before `i.at`.
    fn front_eval(&self, f: &FrontEnd, i: FrontIn, d: &mut FrontStep);

    /// The front end's clock edge for `d`: the granted requests enter their bank pipelines, due
    /// at their tag check `l2_latency - 3` cycles later, and each granting bank's arbiter moves
    /// on. The back end must not yet have reached the cycle a request let in now is due.
    fn front_commit(&mut self, f: &mut FrontEnd, d: &FrontStep);

    /// The back end's clock edge for `d`, a step evaluated with no request coming in: the L2's
    /// [`Unit::commit`], each check-out logged for the front end.
    fn back_commit(&mut self, f: &mut FrontEnd, d: &L2Step);
}

impl SplitL2 for L2 {
    fn front_eval(&self, f: &FrontEnd, i: FrontIn, d: &mut FrontStep) {
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
            if f.let_in[b] - out >= u64::from(self.params().l2_bank_queue) {
                continue;
            }
            // The first requesting SM from the arbiter's first on, round the ring.
            let from = mask & (u64::MAX << self.arbiter_first(b));
            let sm = if from != 0 { from.trailing_zeros() } else { mask.trailing_zeros() };
            d.granted |= 1 << sm;
            d.accepted.push((b, sm, i.heads[sm as usize]));
        }
    }

    fn front_commit(&mut self, f: &mut FrontEnd, d: &FrontStep) {
        let delay = u64::from(self.params().l2_latency - 3);
        debug_assert!(d.at + delay >= self.cycle(), "the back end ran past a request's tag check");
        for (b, log) in f.out_log.iter_mut().enumerate() {
            while log.front().is_some_and(|&c| c < d.at) {
                log.pop_front();
                f.out_seen[b] += 1;
            }
        }
        for &(b, sm, req) in &d.accepted {
            self.enter_pipeline(b, sm, req, d.at + delay);
            f.let_in[b] += 1;
        }
    }

    fn back_commit(&mut self, f: &mut FrontEnd, d: &L2Step) {
        let at = self.cycle();
        for b in d.checked_out() {
            f.out_log[b].push_back(at);
        }
        self.commit(d);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mem::l1d::{L1dIn, L1dStep};
    use crate::mem::testutil::{L2Bench, XorShift};
    use crate::mem::{Counters, MemParams, MemResp, ReqKind};

    /// Two copies of one L1D on the same random requests and fills: one attached (granted at
    /// random), one detached and told of each grant right after the edge. The detached one keeps
    /// the attached one's registers cycle by cycle, and lists every request that went down, in
    /// order, each from an edge before its grant.
    #[test]
    fn a_detached_l1d_told_of_each_grant_keeps_the_attached_ones_registers() {
        let p = MemParams { l1d_miss_queue: 3, l1d_mshrs: 4, ..MemParams::default() };
        let (mut attached, mut detached) = (L1d::new(&p), L1d::new(&p));
        let (mut da, mut dd) = (L1dStep::default(), L1dStep::default());
        let mut rng = XorShift(9);
        let mut l2: VecDeque<(u64, MemResp)> = VecDeque::new();
        let (mut fills, mut went_down, mut sent) = (Vec::new(), Vec::new(), Vec::new());
        for now in 0..6_000u64 {
            let req = rng.burst_request(now);
            let granted = rng.below(3) != 0;
            let down = attached.down_req().filter(|_| granted);
            attached.eval(L1dIn { req, down_ready: granted, fills: &fills }, &mut da);
            detached.eval(L1dIn { req, down_ready: false, fills: &fills }, &mut dd);
            assert_eq!(da.out.req_fire, dd.out.req_fire, "cycle {now}");
            attached.commit(&da);
            let before = detached.queue_bound();
            detached.commit(&dd);
            detached.sent_at(now, before, &mut sent);
            if let Some(d) = down {
                went_down.push((now, d));
                detached.left_queue();
                l2.push_back((now + 5 + rng.below(30), d.response()));
            }
            assert_eq!(format!("{attached:?}"), format!("{detached:?}"), "cycle {now}");
            assert_eq!(detached.queue_bound(), attached.miss_queue().len());
            assert_eq!(detached.next_event_detached(), attached.next_event_inside());
            fills.clear();
            while let Some(k) = l2.iter().position(|&(c, _)| c <= now + 1) {
                fills.push(l2.remove(k).unwrap().1);
            }
        }
        assert!(went_down.len() > 300, "traffic: {}", went_down.len());
        let sent_reqs: Vec<MemReq> = sent.iter().map(|s| s.1).collect();
        let down_reqs: Vec<MemReq> = went_down.iter().map(|s| s.1).collect();
        assert_eq!(sent_reqs[..down_reqs.len()], down_reqs[..], "the requests sent down, in order");
        for (s, g) in sent.iter().zip(&went_down) {
            assert!(s.0 < g.0, "{:?} listed at the edge of cycle {}, granted in {}", s.1, s.0, g.0);
        }
    }

    /// Random traffic from four SMs through the L2, each SM offering the head of its own queue of
    /// requests (reads and writes to a few hot lines, so hits, misses, merges and write-backs
    /// happen; pipelines of six, so banks fill): `ahead` < 0 runs the L2 whole (`eval` and
    /// `commit` every cycle); otherwise split as the windowed run splits it, the front end cycle
    /// by cycle and the back end run `ahead` cycles in front of it. Returns every response with
    /// its cycle, and the counters.
    fn queued_traffic(p: MemParams, ahead: i64, seed: u64) -> (Vec<(u64, usize, MemResp)>, Counters) {
        let sms = p.sms as usize;
        let mut rng = XorShift(seed);
        let mut b = L2Bench::new(p, 30);
        let mut front = FrontEnd::new(p.l2_banks as usize);
        let mut queues = vec![VecDeque::new(); sms];
        let mut id = 0;
        let none = vec![None; sms];
        let (mut want, mut heads, mut fs) = (
            vec![0u64; p.l2_banks as usize],
            vec![MemReq::read(0, 0, 0, ReqKind::NodeFetch); sms],
            FrontStep::default(),
        );
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
                b.l2.front_eval(&front, FrontIn { at: x, want: &want, heads: &heads }, &mut fs);
                b.l2.front_commit(&mut front, &fs);
                // The back end runs on to `ahead` cycles in front of the front end.
                while b.cycle < x + 1 + ahead as u64 {
                    b.step_committing(&none, |l2, d| l2.back_commit(&mut front, d));
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

    /// The windowed run's split L2: the front end at its cycle and the back end up to the bank
    /// pipelines' delay in front of it give the whole L2's responses, at the same cycles, and its
    /// counters; a back end further ahead than that (the windowed run's planted
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
}
