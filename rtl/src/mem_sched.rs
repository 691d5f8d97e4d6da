//! Memory scheduler and response FIFO for the stack manager's global (local-memory) traffic.
//!
//! ```text
//!  stack manager ──► request queue ──(≤1 per cycle, when the port is ready)──► memory port
//!                                                                                  │
//!  stack manager ◄── response FIFO (≤1 delivered per cycle) ◄── completions ◄──────┘
//! ```
//!
//! Each thread has at most one request outstanding that waits for a response (its sequencer waits
//! for a load's data before the next request), so the scheduler keeps one thread's requests in
//! order by construction. Stores are posted with `StackTiming::Overlapped` (they leave the queue
//! and need no response); with `StackTiming::Blocking` the L2's acknowledgement of a store is a
//! completion like a load's data and goes through the FIFO too: the sequencer has one completion
//! input that takes one response per cycle, and SPEC section 3 has a dependent request wait until
//! the earlier response "is in the response FIFO".

use std::collections::VecDeque;

use crate::clock::Unit;
use crate::config::Widths;
use crate::trace::{Kind, Sink};

/// A global-memory request of the stack manager.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct GReq {
    pub thread: u32,
    pub write: bool,
    /// Byte address in the thread's spill region.
    pub addr: u64,
}

/// Registers of the scheduler.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct MemSched {
    queue: VecDeque<GReq>,
    fifo: VecDeque<u32>,
    /// Thread whose response the FIFO delivered last cycle (the registered `deq` output).
    deq: Option<u32>,
    pub max_queue: usize,
    /// Global stores in the request queue (what `[stack] store_queue` bounds).
    stores: u32,
    /// Width of the request queue's occupancy: [`Widths::gm_queue`], or
    /// [`crate::config::GM_POSTED_QUEUE_BITS`] with posted stores.
    queue_bits: u32,
    /// Widths of a thread number and of the FIFO's occupancy ([`Widths::thread`],
    /// [`Widths::gm_responses`]), for the probe.
    thread_bits: u32,
    fifo_bits: u32,
}

/// This cycle's inputs of the scheduler.
#[derive(Clone, Copy, Debug, Default)]
pub struct SchedIn<'a> {
    /// The stack manager's new global requests (its `g_req` output this cycle); they join the
    /// queue at the edge.
    pub new: &'a [GReq],
    /// The memory port takes the head request (`req_ready`).
    pub req_ready: bool,
    /// Threads whose load (or acknowledged store) the memory completed; they enter the FIFO at
    /// the edge.
    pub completions: &'a [u32],
}

/// The scheduler's decisions in one cycle ([`Unit::eval`]), applied by [`Unit::commit`]. A
/// reusable buffer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct SchedStep {
    /// The request the port took this cycle (the `req` handshake fired).
    pub req: Option<GReq>,
    /// The FIFO's head leaves (the `deq` register's next value).
    deq: Option<u32>,
    completions: Vec<u32>,
    new: Vec<GReq>,
}

impl MemSched {
    /// A scheduler whose request queue holds at most `2^queue_bits - 1` requests (the width its
    /// probe declares); `w` gives the widths of its other signals.
    pub fn new(queue_bits: u32, w: &Widths) -> Self {
        MemSched { queue_bits, thread_bits: w.thread, fifo_bits: w.gm_responses, ..MemSched::default() }
    }

    /// Thread whose response the FIFO delivered in the previous cycle (registered output).
    #[inline]
    pub fn deq(&self) -> Option<u32> {
        self.deq
    }

    #[inline]
    pub fn is_idle(&self) -> bool {
        self.queue.is_empty() && self.fifo.is_empty() && self.deq.is_none()
    }

    /// Global stores waiting in the request queue (a register: counted at the edge).
    #[inline]
    pub fn queued_stores(&self) -> u32 {
        self.stores
    }

    /// The request offered to the port this cycle (`req_valid` and its data; from registers).
    #[inline]
    pub fn head(&self) -> Option<GReq> {
        self.queue.front().copied()
    }
}

impl Unit for MemSched {
    type In<'a> = SchedIn<'a>;
    type Step = SchedStep;

    /// One cycle, combinational: the FIFO delivers one response, the port takes the head request
    /// if `req_ready`; the completions enter the FIFO and the new requests the queue at the edge.
    fn eval(&self, i: SchedIn<'_>, d: &mut SchedStep) {
        d.deq = self.fifo.front().copied();
        d.req = if i.req_ready { self.head() } else { None };
        d.completions.clear();
        d.completions.extend_from_slice(i.completions);
        d.new.clear();
        d.new.extend_from_slice(i.new);
    }

    /// The clock edge.
    fn commit(&mut self, d: &SchedStep) {
        self.deq = d.deq;
        if d.deq.is_some() {
            self.fifo.pop_front();
        }
        if let Some(r) = d.req {
            self.queue.pop_front();
            self.stores -= u32::from(r.write);
        }
        self.fifo.extend(d.completions.iter().copied());
        self.queue.extend(d.new.iter().copied());
        self.stores += d.new.iter().filter(|r| r.write).count() as u32;
        self.max_queue = self.max_queue.max(self.queue.len());
    }

    /// Registers and this cycle's port handshake (from `d`).
    fn probe<S: Sink>(&self, d: &SchedStep, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("mem_sched");
        s.signal("req_valid", 1, u64::from(d.req.is_some()));
        s.signal("req_write", 1, d.req.map_or(0, |r| u64::from(r.write)));
        s.signal_kind("req_addr", 64, d.req.map_or(0, |r| r.addr), Kind::Address);
        s.signal("req_thread", self.thread_bits, d.req.map_or(0, |r| r.thread as u64));
        s.signal("queue", self.queue_bits, self.queue.len() as u64);
        s.pop_scope();
        s.push_scope("response_fifo");
        s.signal("occupancy", self.fifo_bits, self.fifo.len() as u64);
        s.signal("deq_valid", 1, u64::from(self.deq.is_some()));
        s.signal("deq_thread", self.thread_bits, self.deq.unwrap_or(0) as u64);
        s.pop_scope();
    }
}

/// Global memory that answers every load (and, if asked, acknowledges every store) a fixed
/// number of cycles after it was issued; accepts one request per cycle. The RT unit replaces it
/// with the cache hierarchy.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct FixedLatencyMem {
    latency: u64,
    /// Stores are acknowledged (for acknowledged-store sequencers) rather than posted.
    acks: bool,
    cycle: u64,
    /// (ready cycle, thread), in issue order, so also in ready order.
    inflight: VecDeque<(u64, u32)>,
    /// Threads whose load (or acknowledged store) completed last cycle (registered output).
    done: Vec<u32>,
}

/// The memory's decisions in one cycle ([`FixedLatencyMem::eval`]).
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct FixedStep {
    done: Vec<u32>,
    accepted: Option<(u64, u32)>,
}

impl FixedLatencyMem {
    pub fn new(latency: u64) -> Self {
        FixedLatencyMem { latency: latency.max(1), ..Default::default() }
    }

    /// As [`FixedLatencyMem::new`], acknowledging stores after the same latency if `acks`.
    pub fn with_acks(latency: u64, acks: bool) -> Self {
        FixedLatencyMem { acks, ..FixedLatencyMem::new(latency) }
    }

    /// Loads (and acknowledged stores) that completed in the previous cycle.
    pub fn completions(&self) -> &[u32] {
        &self.done
    }

    pub fn is_idle(&self) -> bool {
        self.inflight.is_empty() && self.done.is_empty()
    }

    /// Cycle at which the next load completes, if any.
    pub fn next_event(&self) -> Option<u64> {
        self.inflight.front().map(|&(c, _)| c)
    }

    /// One cycle with request `req` (the port always takes it).
    pub fn eval(&self, req: Option<GReq>, d: &mut FixedStep) {
        d.done.clear();
        d.done.extend(self.inflight.iter().take_while(|&&(ready, _)| ready <= self.cycle).map(|&(_, t)| t));
        d.accepted = req.filter(|r| !r.write || self.acks).map(|r| (self.cycle + self.latency, r.thread));
    }

    /// The clock edge.
    pub fn commit(&mut self, d: &FixedStep) {
        self.inflight.drain(..d.done.len());
        self.done.clone_from(&d.done);
        self.inflight.extend(d.accepted);
        self.cycle += 1;
    }

    /// Skips `n` idle cycles (nothing can complete in them).
    pub fn skip(&mut self, n: u64) {
        self.cycle += n;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scheduler with a queue of 4 bits, RB_8's widths otherwise.
    fn sched() -> MemSched {
        let cfg: crate::config::Config = "RB_8".parse().unwrap();
        MemSched::new(4, &cfg.widths().unwrap())
    }

    /// One cycle of the scheduler and the memory behind it; returns the request the port took.
    fn step(s: &mut MemSched, m: &mut FixedLatencyMem, new: &[GReq], ready: bool) -> Option<GReq> {
        let (mut ds, mut dm) = (SchedStep::default(), FixedStep::default());
        s.eval(SchedIn { new, req_ready: ready, completions: m.completions() }, &mut ds);
        m.eval(ds.req, &mut dm);
        s.commit(&ds);
        m.commit(&dm);
        ds.req
    }

    #[test]
    fn load_round_trip_takes_latency_plus_fifo() {
        let mut s = sched();
        let mut m = FixedLatencyMem::new(10);
        let load = GReq { thread: 3, write: false, addr: 0 };
        let mut arrived = None;
        for cycle in 0..20 {
            let new = if cycle == 0 { vec![load] } else { vec![] };
            step(&mut s, &mut m, &new, true);
            if s.deq() == Some(3) {
                arrived = Some(cycle);
                break;
            }
        }
        // cycle 0 enqueue, 1 issue, 11 complete (seen at 12), FIFO at 12, delivered at 13.
        assert_eq!(arrived, Some(13));
    }

    #[test]
    fn one_request_per_cycle_and_stores_need_no_response() {
        let mut s = sched();
        let mut m = FixedLatencyMem::new(10);
        let reqs = [GReq { thread: 0, write: true, addr: 0 }, GReq { thread: 1, write: false, addr: 8 }];
        assert_eq!(step(&mut s, &mut m, &reqs, true), None);
        assert_eq!(step(&mut s, &mut m, &[], true), Some(reqs[0]));
        assert_eq!(step(&mut s, &mut m, &[], false), None, "port not ready");
        assert_eq!(step(&mut s, &mut m, &[], true), Some(reqs[1]));
    }
}
