//! Shared-memory bank arbiter.
//!
//! ```text
//!   new requests ──► pending (arrival order) ──► per bank: grant the oldest word ──► done
//!                         ▲                                  │ losers wait
//!                         └──────────────────────────────────┘
//! ```
//!
//! A request is one stack entry: `entry_bytes / bank_bytes` words in adjacent banks. Each cycle
//! every bank serves at most one word; two requests for the *same* word are served together
//! (broadcast). A request is done when all its words have been served; it then passes the
//! shared-memory pipeline and is reported in `done`. A cycle in which some word waits because its
//! bank serves another word is a conflict delay cycle.
//!
//! Latency (`sh_latency`, [`BankArbiter::with_latency`]): the cycles from the stack manager issuing
//! an unconflicted request to the cycle its sequencer sees it done (and issues its next micro-op);
//! each conflict cycle adds one. The request reaches the banks the cycle after issue, so with
//! `sh_latency = 2` it is reported in `done` right after its last word is served (the model before
//! issue 12), and every cycle above 2 is a pipeline stage after the banks. Vulkan-Sim's ldst unit
//! is a pipeline `-gpgpu_smem_latency` deep (20 in `configs/tested-cfgs/MOBILE/gpgpusim.config`
//! line 108; `shader.cc` ~3646 builds the unit with that depth and asserts it is > 1) that a shared
//! access enters only after `shared_cycle` (~2261) has stalled it for its bank conflicts, so the
//! latency comes after the serialization, as here.

use crate::trace::{Kind, Probe, Sink};

/// Most words one entry can span (8-byte entries over 1-byte banks).
pub const MAX_WORDS: usize = 8;

/// One shared-memory access: the words of one stack entry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ShReq {
    /// Requesting thread (RT-unit index); at most one request per thread is outstanding.
    pub thread: u32,
    pub write: bool,
    /// Word addresses (byte address / bank_bytes); `len` of them are used.
    pub words: [u32; MAX_WORDS],
    pub len: u8,
}

impl ShReq {
    pub fn words(&self) -> &[u32] {
        &self.words[..self.len as usize]
    }
}

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct Pending {
    req: ShReq,
    /// Bit i set: word i already served.
    served: u8,
}

/// Total cycles of an unconflicted SH access in the model before issue 12 (issue, bank cycle,
/// done): the least `sh_latency` can be.
pub const MIN_SH_LATENCY: u32 = 2;

/// Registers of the arbiter.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct BankArbiter {
    banks: u32,
    /// Pipeline stages after the banks: `sh_latency - 2`.
    stages: u32,
    pending: Vec<Pending>,
    /// Served requests in the pipeline after the banks: (cycle whose step reports it, thread), in
    /// order.
    pipe: std::collections::VecDeque<(u64, u32)>,
    /// Threads whose request completed last cycle (registered output).
    done: Vec<u32>,
    /// Per-cycle signals of the last evaluated cycle, for probes.
    grant_mask: u64,
    conflict_mask: u64,
    /// Conflict delay cycles so far.
    pub conflict_cycles: u64,
    /// Word-cycles spent waiting on a busy bank (sum over waiting words).
    pub conflict_word_waits: u64,
}

impl BankArbiter {
    /// `sh_latency` = [`MIN_SH_LATENCY`]: done right after the banks.
    pub fn new(banks: u32) -> Self {
        BankArbiter { banks, ..Default::default() }
    }

    /// An unconflicted access takes `sh_latency` cycles from issue to completion (at least
    /// [`MIN_SH_LATENCY`]; smaller values are treated as the minimum — `RtParams::validate`
    /// rejects them first).
    pub fn with_latency(banks: u32, sh_latency: u32) -> Self {
        BankArbiter { banks, stages: sh_latency.saturating_sub(MIN_SH_LATENCY), ..Default::default() }
    }

    /// Threads whose request completed in the previous cycle.
    pub fn done(&self) -> &[u32] {
        &self.done
    }

    pub fn is_idle(&self) -> bool {
        self.pending.is_empty() && self.done.is_empty() && self.pipe.is_empty()
    }

    /// Acts next cycle (a request at the banks, or a done signal for the stack manager to read).
    pub fn busy(&self) -> bool {
        !self.pending.is_empty() || !self.done.is_empty()
    }

    /// Cycle whose step reports the oldest request in the pipeline after the banks.
    pub fn pipe_due(&self) -> Option<u64> {
        self.pipe.front().map(|&(at, _)| at)
    }

    pub fn occupancy(&self) -> usize {
        self.pending.len()
    }

    /// Clock cycle `now`: report requests leaving the pipeline, serve pending words (oldest
    /// first), then enqueue `new` for later cycles. `now` numbers the caller's cycles (it may jump
    /// over cycles in which the arbiter is idle or only holds requests in the pipeline).
    pub fn step(&mut self, now: u64, new: &[ShReq]) {
        self.done.clear();
        while let Some(&(at, t)) = self.pipe.front() {
            if at > now {
                break;
            }
            self.done.push(t);
            self.pipe.pop_front();
        }
        let mut bank_word = [u32::MAX; 64];
        let mut grant_mask = 0u64;
        let mut conflict_mask = 0u64;
        let mut waits = 0u64;
        for p in &mut self.pending {
            for (i, &w) in p.req.words().iter().enumerate() {
                if p.served & (1 << i) != 0 {
                    continue;
                }
                let bank = (w % self.banks) as usize;
                if grant_mask & (1 << bank) == 0 {
                    grant_mask |= 1 << bank;
                    bank_word[bank] = w;
                    p.served |= 1 << i;
                } else if bank_word[bank] == w {
                    p.served |= 1 << i;
                } else {
                    conflict_mask |= 1 << bank;
                    waits += 1;
                }
            }
        }
        let (done, pipe, due) = (&mut self.done, &mut self.pipe, now + u64::from(self.stages));
        self.pending.retain(|p| {
            let complete = p.served.count_ones() == p.req.len as u32;
            if complete {
                if due == now {
                    done.push(p.req.thread);
                } else {
                    pipe.push_back((due, p.req.thread));
                }
            }
            !complete
        });
        self.conflict_cycles += u64::from(conflict_mask != 0);
        self.conflict_word_waits += waits;
        self.grant_mask = grant_mask;
        self.conflict_mask = conflict_mask;
        self.pending.extend(new.iter().map(|&req| Pending { req, served: 0 }));
    }
}

impl Probe for BankArbiter {
    fn probe<S: Sink>(&self, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("bank_arbiter");
        s.signal_kind("grant", self.banks, self.grant_mask, Kind::Mask);
        s.signal_kind("conflict", self.banks, self.conflict_mask, Kind::Mask);
        s.signal("pending", 16, self.pending.len() as u64);
        s.signal("pipe", 16, self.pipe.len() as u64);
        s.signal("delay_cycles", 64, self.conflict_cycles);
        s.pop_scope();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn req(thread: u32, words: &[u32]) -> ShReq {
        let mut w = [0; MAX_WORDS];
        w[..words.len()].copy_from_slice(words);
        ShReq { thread, write: false, words: w, len: words.len() as u8 }
    }

    #[test]
    fn disjoint_banks_finish_in_one_cycle() {
        let mut a = BankArbiter::new(32);
        a.step(0, &[req(0, &[0, 1]), req(1, &[2, 3])]);
        a.step(0, &[]);
        assert_eq!(a.done(), &[0, 1]);
        assert_eq!(a.conflict_cycles, 0);
    }

    #[test]
    fn same_bank_different_words_serialise() {
        let mut a = BankArbiter::new(32);
        // Words 0, 32, 64 all sit in bank 0: three cycles, two of them with a conflict.
        a.step(0, &[req(0, &[0]), req(1, &[32]), req(2, &[64])]);
        let mut order = vec![];
        for _ in 0..3 {
            a.step(0, &[]);
            order.extend_from_slice(a.done());
        }
        assert_eq!(order, vec![0, 1, 2], "oldest first");
        assert_eq!(a.conflict_cycles, 2);
        assert_eq!(a.conflict_word_waits, 3);
        a.step(0, &[]);
        assert!(a.is_idle());
    }

    #[test]
    fn same_word_is_a_broadcast() {
        let mut a = BankArbiter::new(32);
        a.step(0, &[req(0, &[5]), req(1, &[5])]);
        a.step(0, &[]);
        assert_eq!(a.done(), &[0, 1]);
        assert_eq!(a.conflict_cycles, 0);
    }

    /// Vulkan-Sim's 20-cycle shared-memory latency comes after the bank serialization: three
    /// requests issued in cycle 0 to bank 0 are served in 1, 2, 3 and reported done (read by the
    /// sequencer the cycle after) in 19, 20, 21, i.e. completed 20, 21, 22 cycles after issue.
    #[test]
    fn latency_follows_bank_serialisation() {
        let mut a = BankArbiter::with_latency(32, 20);
        a.step(0, &[req(0, &[0]), req(1, &[32]), req(2, &[64])]);
        let mut done = vec![];
        for now in 1..=30 {
            a.step(now, &[]);
            done.extend(a.done().iter().map(|&t| (now, t)));
            if now == 3 {
                assert!(!a.busy() && !a.is_idle(), "only the pipeline holds requests");
                assert_eq!(a.pipe_due(), Some(19));
            }
        }
        assert_eq!(done, [(19, 0), (20, 1), (21, 2)]);
        assert_eq!(a.conflict_cycles, 2, "the pipeline adds no conflicts");
        assert!(a.is_idle());
        // The minimum latency is the arbiter without a pipeline.
        let mut b = BankArbiter::with_latency(32, MIN_SH_LATENCY);
        b.step(0, &[req(0, &[0])]);
        b.step(1, &[]);
        assert_eq!(b.done(), &[0]);
    }
}
