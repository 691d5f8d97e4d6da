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

use crate::trace::{Kind, Probe, Sink};

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
    /// Thread whose load response was delivered last cycle (registered output).
    delivered: Option<u32>,
    /// Request sent to the port last cycle, for probes.
    issued: Option<GReq>,
    pub max_queue: usize,
}

impl MemSched {
    pub fn new() -> Self {
        MemSched::default()
    }

    /// Thread whose load data arrived in the previous cycle.
    pub fn delivered(&self) -> Option<u32> {
        self.delivered
    }

    pub fn is_idle(&self) -> bool {
        self.queue.is_empty() && self.fifo.is_empty() && self.delivered.is_none()
    }

    /// The request the port would take this cycle.
    pub fn head(&self) -> Option<GReq> {
        self.queue.front().copied()
    }

    /// One cycle: deliver one response, hand the head request to the port if `port_ready`,
    /// capture load completions from the port into the FIFO, enqueue `new`.
    /// Returns the request sent to the port.
    pub fn step(&mut self, new: &[GReq], port_ready: bool, completions: &[u32]) -> Option<GReq> {
        self.delivered = self.fifo.pop_front();
        self.issued = if port_ready { self.queue.pop_front() } else { None };
        self.fifo.extend(completions.iter().copied());
        self.queue.extend(new.iter().copied());
        self.max_queue = self.max_queue.max(self.queue.len());
        self.issued
    }
}

impl Probe for MemSched {
    fn probe<S: Sink>(&self, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("mem_sched");
        s.signal("req_valid", 1, u64::from(self.issued.is_some()));
        s.signal("req_write", 1, self.issued.map_or(0, |r| u64::from(r.write)));
        s.signal_kind("req_addr", 64, self.issued.map_or(0, |r| r.addr), Kind::Address);
        s.signal("req_thread", 16, self.issued.map_or(0, |r| r.thread as u64));
        s.signal("queue", 16, self.queue.len() as u64);
        s.pop_scope();
        s.push_scope("response_fifo");
        s.signal("occupancy", 16, self.fifo.len() as u64);
        s.signal("deq_valid", 1, u64::from(self.delivered.is_some()));
        s.signal("deq_thread", 16, self.delivered.unwrap_or(0) as u64);
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
    done: Vec<u32>,
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

    pub fn step(&mut self, req: Option<GReq>) {
        self.done.clear();
        while let Some(&(ready, t)) = self.inflight.front() {
            if ready > self.cycle {
                break;
            }
            self.done.push(t);
            self.inflight.pop_front();
        }
        if let Some(r) = req.filter(|r| !r.write || self.acks) {
            self.inflight.push_back((self.cycle + self.latency, r.thread));
        }
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

    #[test]
    fn load_round_trip_takes_latency_plus_fifo() {
        let mut s = MemSched::new();
        let mut m = FixedLatencyMem::new(10);
        let load = GReq { thread: 3, write: false, addr: 0 };
        let mut arrived = None;
        for cycle in 0..20 {
            let new = if cycle == 0 { vec![load] } else { vec![] };
            let port = s.step(&new, true, m.completions());
            m.step(port);
            if s.delivered() == Some(3) {
                arrived = Some(cycle);
                break;
            }
        }
        // cycle 0 enqueue, 1 issue, 11 complete (seen at 12), FIFO at 12, delivered at 13.
        assert_eq!(arrived, Some(13));
    }

    #[test]
    fn one_request_per_cycle_and_stores_need_no_response() {
        let mut s = MemSched::new();
        let reqs = [GReq { thread: 0, write: true, addr: 0 }, GReq { thread: 1, write: false, addr: 8 }];
        assert_eq!(s.step(&reqs, true, &[]), None);
        assert_eq!(s.step(&[], true, &[]), Some(reqs[0]));
        assert_eq!(s.step(&[], false, &[]), None, "port not ready");
        assert_eq!(s.step(&[], true, &[]), Some(reqs[1]));
    }
}
