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
//! Latency (`sh_latency`, [`BankArbiter::new`]): the cycles from the stack manager issuing
//! an unconflicted request to the cycle its sequencer sees it done (and issues its next micro-op);
//! each conflict cycle adds one. The request reaches the banks the cycle after issue, so with
//! `sh_latency = 2` it is reported in `done` right after its last word is served (the `legacy`
//! preset), and every cycle above 2 is a pipeline stage after the banks. Vulkan-Sim's ldst unit
//! is a pipeline `-gpgpu_smem_latency` deep (20 in `configs/tested-cfgs/MOBILE/gpgpusim.config`
//! line 108; `shader.cc` ~3646 builds the unit with that depth and asserts it is > 1) that a shared
//! access enters only after `shared_cycle` (~2261) has stalled it for its bank conflicts, so the
//! latency comes after the serialization, as here.

use crate::clock::Unit;
use crate::config::rem32;
use crate::trace::{Kind, Sink};

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

/// Total cycles of an unconflicted SH access with no pipeline after the banks (issue, bank
/// cycle, done; the `legacy` preset's): the least `sh_latency` can be.
pub const MIN_SH_LATENCY: u32 = 2;

/// Registers of the arbiter.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct BankArbiter {
    banks: u32,
    /// Pipeline stages after the banks: `sh_latency - 2`.
    stages: u32,
    pending: Vec<Pending>,
    /// Served requests in the pipeline after the banks: (cycle whose evaluation reports it,
    /// thread), in order.
    pipe: std::collections::VecDeque<(u64, u32)>,
    /// Threads whose request completed last cycle (the registered `done` output).
    done: Vec<u32>,
    /// Conflict delay cycles so far.
    pub conflict_cycles: u64,
    /// Word-cycles spent waiting on a busy bank (sum over waiting words).
    pub conflict_word_waits: u64,
    /// Width of the pending and pipeline counts in a waveform (`Widths::sh_requests`).
    count_bits: u32,
}

/// This cycle's inputs.
#[derive(Clone, Copy, Debug, Default)]
pub struct ArbIn<'a> {
    /// The cycle, as the stack unit numbers it (it may jump over cycles in which the arbiter is
    /// idle or only holds requests in the pipeline).
    pub now: u64,
    /// The stack manager's new requests (its `sh_req` output this cycle); they wait from the next
    /// cycle on.
    pub new: &'a [ShReq],
}

/// The arbiter's decisions in one cycle ([`BankArbiter::eval`]), applied at the clock edge by
/// [`BankArbiter::commit`]. A reusable buffer: evaluating allocates nothing once it has grown.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct ArbStep {
    /// The `done` register's next value.
    done: Vec<u32>,
    /// Requests leaving the pipeline after the banks.
    pipe_out: usize,
    /// Served-word mask of each pending request after this cycle's grants.
    served: Vec<u8>,
    /// Requests arriving (served from next cycle on).
    new: Vec<ShReq>,
    /// Banks that served a word, and banks that kept a word waiting.
    grant_mask: u64,
    conflict_mask: u64,
    waits: u64,
    now: u64,
}

impl ArbStep {
    /// The cycle this step was evaluated in: the only part of an idle arbiter's step that changes
    /// from cycle to cycle (the stack unit's quiet-step shortcut writes only this).
    pub(crate) fn set_now(&mut self, now: u64) {
        self.now = now;
    }
}

impl BankArbiter {
    /// The arbiter of `banks` banks. An unconflicted access takes `sh_latency` cycles from issue
    /// to completion (at least [`MIN_SH_LATENCY`]; smaller values are treated as the minimum —
    /// `RtParams::validate` rejects them first). `count_bits` is `Widths::sh_requests`.
    pub fn new(banks: u32, sh_latency: u32, count_bits: u32) -> Self {
        BankArbiter {
            banks,
            stages: sh_latency.saturating_sub(MIN_SH_LATENCY),
            count_bits,
            ..Default::default()
        }
    }

    /// Threads whose request completed in the previous cycle (a registered output: the stack
    /// manager reads it this cycle).
    #[inline]
    pub fn done(&self) -> &[u32] {
        &self.done
    }

    #[inline]
    pub fn is_idle(&self) -> bool {
        self.pending.is_empty() && self.done.is_empty() && self.pipe.is_empty()
    }

    /// Acts next cycle (a request at the banks, or a done signal for the stack manager to read).
    #[inline]
    pub fn busy(&self) -> bool {
        !self.pending.is_empty() || !self.done.is_empty()
    }

    /// Cycle whose evaluation reports the oldest request in the pipeline after the banks.
    #[inline]
    pub fn pipe_due(&self) -> Option<u64> {
        self.pipe.front().map(|&(at, _)| at)
    }

    pub fn occupancy(&self) -> usize {
        self.pending.len()
    }
}

impl Unit for BankArbiter {
    type In<'a> = ArbIn<'a>;
    type Step = ArbStep;

    /// Combinational: requests leaving the pipeline, then each bank grants its oldest pending
    /// word; the new requests wait from the next cycle on.
    fn eval(&self, i: ArbIn<'_>, d: &mut ArbStep) {
        let (now, new) = (i.now, i.new);
        d.now = now;
        d.done.clear();
        d.pipe_out = 0;
        for &(at, t) in &self.pipe {
            if at > now {
                break;
            }
            d.done.push(t);
            d.pipe_out += 1;
        }
        let (mut grant_mask, mut conflict_mask, mut waits) = (0u64, 0u64, 0u64);
        d.served.clear();
        // Nothing pending (most cycles): no grant logic to evaluate.
        if !self.pending.is_empty() {
            // The word each granted bank reads (meaningful where `grant_mask` is set).
            let mut bank_word = [u32::MAX; 64];
            for p in &self.pending {
                let mut served = p.served;
                for (i, &w) in p.req.words().iter().enumerate() {
                    if served & (1 << i) != 0 {
                        continue;
                    }
                    let bank = rem32(w, self.banks) as usize;
                    if grant_mask & (1 << bank) == 0 {
                        grant_mask |= 1 << bank;
                        bank_word[bank] = w;
                        served |= 1 << i;
                    } else if bank_word[bank] == w {
                        served |= 1 << i;
                    } else {
                        conflict_mask |= 1 << bank;
                        waits += 1;
                    }
                }
                if self.stages == 0 && served.count_ones() == p.req.len as u32 {
                    d.done.push(p.req.thread);
                }
                d.served.push(served);
            }
        }
        (d.grant_mask, d.conflict_mask, d.waits) = (grant_mask, conflict_mask, waits);
        d.new.clear();
        d.new.extend_from_slice(new);
    }

    /// The clock edge: takes the state [`BankArbiter::eval`] decided.
    fn commit(&mut self, d: &ArbStep) {
        self.done.clone_from(&d.done);
        self.pipe.drain(..d.pipe_out);
        let due = d.now + u64::from(self.stages);
        let mut i = 0;
        let (pipe, stages) = (&mut self.pipe, self.stages);
        self.pending.retain_mut(|p| {
            p.served = d.served[i];
            i += 1;
            let complete = p.served.count_ones() == p.req.len as u32;
            if complete && stages > 0 {
                pipe.push_back((due, p.req.thread));
            }
            !complete
        });
        self.conflict_cycles += u64::from(d.conflict_mask != 0);
        self.conflict_word_waits += d.waits;
        self.pending.extend(d.new.iter().map(|&req| Pending { req, served: 0 }));
    }

    /// Registers and this cycle's grants (`d`, from [`BankArbiter::eval`]).
    fn probe<S: Sink>(&self, d: &ArbStep, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("bank_arbiter");
        s.signal_kind("grant", self.banks, d.grant_mask, Kind::Mask);
        s.signal_kind("conflict", self.banks, d.conflict_mask, Kind::Mask);
        s.signal("pending", self.count_bits, self.pending.len() as u64);
        s.signal("pipe", self.count_bits, self.pipe.len() as u64);
        s.signal("delay_cycles", 64, self.conflict_cycles);
        s.pop_scope();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One cycle: evaluate, then the clock edge.
    fn step(a: &mut BankArbiter, now: u64, new: &[ShReq]) {
        let mut d = ArbStep::default();
        a.eval(ArbIn { now, new }, &mut d);
        a.commit(&d);
    }

    fn req(thread: u32, words: &[u32]) -> ShReq {
        let mut w = [0; MAX_WORDS];
        w[..words.len()].copy_from_slice(words);
        ShReq { thread, write: false, words: w, len: words.len() as u8 }
    }

    #[test]
    fn disjoint_banks_finish_in_one_cycle() {
        let mut a = BankArbiter::new(32, MIN_SH_LATENCY, 8);
        step(&mut a, 0, &[req(0, &[0, 1]), req(1, &[2, 3])]);
        step(&mut a, 0, &[]);
        assert_eq!(a.done(), &[0, 1]);
        assert_eq!(a.conflict_cycles, 0);
    }

    #[test]
    fn same_bank_different_words_serialise() {
        let mut a = BankArbiter::new(32, MIN_SH_LATENCY, 8);
        // Words 0, 32, 64 all sit in bank 0: three cycles, two of them with a conflict.
        step(&mut a, 0, &[req(0, &[0]), req(1, &[32]), req(2, &[64])]);
        let mut order = vec![];
        for _ in 0..3 {
            step(&mut a, 0, &[]);
            order.extend_from_slice(a.done());
        }
        assert_eq!(order, vec![0, 1, 2], "oldest first");
        assert_eq!(a.conflict_cycles, 2);
        assert_eq!(a.conflict_word_waits, 3);
        step(&mut a, 0, &[]);
        assert!(a.is_idle());
    }

    #[test]
    fn same_word_is_a_broadcast() {
        let mut a = BankArbiter::new(32, MIN_SH_LATENCY, 8);
        step(&mut a, 0, &[req(0, &[5]), req(1, &[5])]);
        step(&mut a, 0, &[]);
        assert_eq!(a.done(), &[0, 1]);
        assert_eq!(a.conflict_cycles, 0);
    }

    /// Vulkan-Sim's 20-cycle shared-memory latency comes after the bank serialization: three
    /// requests issued in cycle 0 to bank 0 are served in 1, 2, 3 and reported done (read by the
    /// sequencer the cycle after) in 19, 20, 21, i.e. completed 20, 21, 22 cycles after issue.
    #[test]
    fn latency_follows_bank_serialisation() {
        let mut a = BankArbiter::new(32, 20, 8);
        step(&mut a, 0, &[req(0, &[0]), req(1, &[32]), req(2, &[64])]);
        let mut done = vec![];
        for now in 1..=30 {
            step(&mut a, now, &[]);
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
        let mut b = BankArbiter::new(32, MIN_SH_LATENCY, 8);
        step(&mut b, 0, &[req(0, &[0])]);
        step(&mut b, 1, &[]);
        assert_eq!(b.done(), &[0]);
    }
}
