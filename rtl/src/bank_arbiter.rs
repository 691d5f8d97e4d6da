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
//! (broadcast). A request is done when all its words have been served, and is reported in `done`
//! the cycle after. A cycle in which some word waits because its bank serves another word is a
//! conflict delay cycle.

use crate::trace::{Probe, Sink};

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

/// Registers of the arbiter.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct BankArbiter {
    banks: u32,
    pending: Vec<Pending>,
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
    pub fn new(banks: u32) -> Self {
        BankArbiter { banks, ..Default::default() }
    }

    /// Threads whose request completed in the previous cycle.
    pub fn done(&self) -> &[u32] {
        &self.done
    }

    pub fn is_idle(&self) -> bool {
        self.pending.is_empty() && self.done.is_empty()
    }

    pub fn occupancy(&self) -> usize {
        self.pending.len()
    }

    /// One clock cycle: serve pending words (oldest first), then enqueue `new` for later cycles.
    pub fn step(&mut self, new: &[ShReq]) {
        self.done.clear();
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
        let done = &mut self.done;
        self.pending.retain(|p| {
            let complete = p.served.count_ones() == p.req.len as u32;
            if complete {
                done.push(p.req.thread);
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
        s.signal("grant", self.banks, self.grant_mask);
        s.signal("conflict", self.banks, self.conflict_mask);
        s.signal("pending", 16, self.pending.len() as u64);
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
        a.step(&[req(0, &[0, 1]), req(1, &[2, 3])]);
        a.step(&[]);
        assert_eq!(a.done(), &[0, 1]);
        assert_eq!(a.conflict_cycles, 0);
    }

    #[test]
    fn same_bank_different_words_serialise() {
        let mut a = BankArbiter::new(32);
        // Words 0, 32, 64 all sit in bank 0: three cycles, two of them with a conflict.
        a.step(&[req(0, &[0]), req(1, &[32]), req(2, &[64])]);
        let mut order = vec![];
        for _ in 0..3 {
            a.step(&[]);
            order.extend_from_slice(a.done());
        }
        assert_eq!(order, vec![0, 1, 2], "oldest first");
        assert_eq!(a.conflict_cycles, 2);
        assert_eq!(a.conflict_word_waits, 3);
        a.step(&[]);
        assert!(a.is_idle());
    }

    #[test]
    fn same_word_is_a_broadcast() {
        let mut a = BankArbiter::new(32);
        a.step(&[req(0, &[5]), req(1, &[5])]);
        a.step(&[]);
        assert_eq!(a.done(), &[0, 1]);
        assert_eq!(a.conflict_cycles, 0);
    }
}
