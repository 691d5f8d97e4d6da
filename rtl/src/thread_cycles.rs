//! Where an RT unit's thread-cycles go: every thread slot (warp-buffer slots × warp size) in
//! every cycle of a run is in exactly one category, as GPGPU-Sim sorts an SM's stall reasons.
//!
//! ```text
//!  thread slot in cycle c ─┬─ empty slot, inactive or finished lane (Done) ─────► idle
//!                          ├─ WaitMem: its node's sectors not all back ──────────► node_data
//!                          ├─ Fetch, fetchable: waits for the scheduler / port ──► fetch_queue
//!                          ├─ Fetch held by its busy sequencer (Blocking), Stack ► stack
//!                          └─ Busy: operation latency, BVH header ───────────────► latency
//! ```
//!
//! The categories are a function of the registers alone, and the registers change only at an
//! edge, so nothing is counted per cycle or per thread, and skipped idle cycles and cycles a
//! runner leaves a unit quiet cost nothing:
//! - the lane-cycles of each thread state are an integral the warp buffer keeps at its edges
//!   (a lane entering a state in cycle `c` subtracts `c`, leaving it adds `c`; the lanes in the
//!   state at the end count up to the end: [`crate::warp_buffer::WarpBuffer::lane_cycles`]);
//! - the lanes waiting to fetch that their sequencer holds back (Blocking timing) depend on the
//!   stack manager's registers too: an evaluated RT unit's `eval` counts them with the cycles
//!   its registers have held since its last edge, and its `commit` adds the product;
//! - a report ([`crate::rt_unit::RtUnit::thread_cycles`]) adds the cycles after the last edge and
//!   takes idle as the rest, so the five sum to cycles × slots exactly.

/// Thread-cycles by category.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ThreadCycles {
    /// Waiting for node data: state WaitMem.
    pub node_data: u64,
    /// Waiting to fetch and allowed to: state Fetch, lane fetchable (the scheduler or the memory
    /// port has not taken it yet).
    pub fetch_queue: u64,
    /// Waiting on the stack sequencer: state Stack, or Fetch held back because the lane's
    /// sequencer is still busy (Blocking stack timing only).
    pub stack: u64,
    /// In an operation unit: state Busy (operation latency, BVH header).
    pub latency: u64,
    /// Nothing to do: empty warp slot, inactive lane, finished lane (Done).
    pub idle: u64,
}

impl ThreadCycles {
    /// Every category's name, in declaration order (the reports' order).
    pub const NAMES: [&'static str; 5] = ["node_data", "fetch_queue", "stack", "latency", "idle"];

    /// The counts in declaration order.
    pub fn values(&self) -> [u64; 5] {
        [self.node_data, self.fetch_queue, self.stack, self.latency, self.idle]
    }

    /// All categories together.
    pub fn total(&self) -> u64 {
        self.values().iter().sum()
    }

    /// Adds another count (another RT unit's).
    pub fn add(&mut self, other: &ThreadCycles) {
        self.node_data += other.node_data;
        self.fetch_queue += other.fetch_queue;
        self.stack += other.stack;
        self.latency += other.latency;
        self.idle += other.idle;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_add_by_category() {
        let a = ThreadCycles { node_data: 1, fetch_queue: 2, stack: 3, latency: 4, idle: 6 };
        let mut t = a;
        t.add(&a);
        assert_eq!(t.values(), [2, 4, 6, 8, 12]);
        assert_eq!(t.total(), 32);
    }
}
