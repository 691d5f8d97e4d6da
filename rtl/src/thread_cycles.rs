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
//! edge, so an RT unit counts once per evaluated cycle: the census of its registers times the
//! cycles they have held since its last count (skipped idle cycles and cycles the runner left it
//! quiet included). The census is taken in `eval` (it reads registers) and added in `commit`; a
//! report adds the cycles after the last edge ([`crate::rt_unit::RtUnit::thread_cycles`]), so the
//! five sum to cycles × slots exactly.

/// Thread-cycles by category (or, as a census, thread slots by category in one cycle).
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

    /// Adds `census` (thread slots by category) held for `cycles` cycles.
    #[inline]
    pub fn add_held(&mut self, census: &ThreadCycles, cycles: u64) {
        self.node_data += census.node_data * cycles;
        self.fetch_queue += census.fetch_queue * cycles;
        self.stack += census.stack * cycles;
        self.latency += census.latency * cycles;
        self.idle += census.idle * cycles;
    }

    /// Adds another count (another RT unit's).
    pub fn add(&mut self, other: &ThreadCycles) {
        self.add_held(other, 1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_census_held_for_cycles_scales_every_category() {
        let census = ThreadCycles { node_data: 1, fetch_queue: 2, stack: 3, latency: 4, idle: 6 };
        let mut t = ThreadCycles::default();
        t.add_held(&census, 10);
        t.add(&census);
        assert_eq!(t.values(), [11, 22, 33, 44, 66]);
        assert_eq!(t.total(), 11 * 16);
    }
}
