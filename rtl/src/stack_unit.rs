//! The stack subsystem of one RT unit, standing alone: stack manager, bank arbiter, memory
//! scheduler with its response FIFO, and a fixed-latency global memory.
//!
//! ```text
//!            cmds ──► stack_manager ──SH reqs──► bank_arbiter ──done (next cycle)──┐
//!                       ▲   │                                                       │
//!                       │   └──global reqs──► mem_sched ──► fixed-latency memory    │
//!                       │                        ▲   FIFO ◄──── completions ◄───────┘
//!                       └──── done / delivered ──┴──────────────────────────────────┘
//! ```
//!
//! Each unit reads only what the others registered in the previous cycle. The RT unit uses the
//! same three units but routes global requests through its cache hierarchy instead.

use crate::bank_arbiter::BankArbiter;
use crate::config::{Config, ConfigError};
use crate::mem_sched::{FixedLatencyMem, MemSched};
use crate::stack_manager::{Cmd, StackManager, StackStats, StackTiming};
use crate::trace::{Probe, Sink};

/// Default global-memory latency of the standalone stack unit, in cycles.
pub const DEFAULT_GLOBAL_LATENCY: u64 = 100;

#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct StackUnit {
    pub sm: StackManager,
    pub arb: BankArbiter,
    pub sched: MemSched,
    pub mem: FixedLatencyMem,
    pub cycle: u64,
}

/// What one run cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct UnitStats {
    pub stack: StackStats,
    pub conflict_cycles: u64,
    pub conflict_word_waits: u64,
    pub cycles: u64,
}

impl StackUnit {
    /// The stack subsystem as before issue 12: posted global stores and SH accesses done right
    /// after the banks (`sh_latency` 2).
    pub fn new(cfg: Config, global_latency: u64) -> Result<Self, ConfigError> {
        StackUnit::with_timing(
            cfg,
            global_latency,
            StackTiming::Overlapped,
            crate::bank_arbiter::MIN_SH_LATENCY,
        )
    }

    /// With `StackTiming::Blocking` the memory acknowledges stores and the sequencer waits for
    /// the acknowledgement; `sh_latency` as in [`BankArbiter::with_latency`]. (A standalone unit
    /// has no node fetches, so the rest of `Blocking` does not apply.)
    pub fn with_timing(
        cfg: Config,
        global_latency: u64,
        timing: StackTiming,
        sh_latency: u32,
    ) -> Result<Self, ConfigError> {
        let acked = timing == StackTiming::Blocking;
        Ok(StackUnit {
            sm: StackManager::new(cfg, 0)?.with_acked_stores(acked),
            arb: BankArbiter::with_latency(cfg.banks, sh_latency),
            sched: MemSched::new(),
            mem: FixedLatencyMem::with_acks(global_latency, acked),
            cycle: 0,
        })
    }

    /// One clock cycle. The answers to `cmds` are in `self.sm.answer(t)`.
    pub fn step(&mut self, cmds: &[(u32, Cmd)]) {
        self.sm.step(cmds, self.arb.done(), self.sched.delivered());
        self.arb.step(self.cycle, self.sm.sh_requests());
        let port = self.sched.step(self.sm.global_requests(), true, self.mem.completions());
        self.mem.step(port);
        self.cycle += 1;
    }

    /// Nothing in flight anywhere: stepping without commands changes nothing but time.
    pub fn idle(&self) -> bool {
        self.sm.quiescent() && self.arb.is_idle() && self.sched.is_idle() && self.mem.is_idle()
    }

    /// When only global loads are in flight, nothing happens until the first returns: skips
    /// those cycles, but not past cycle `limit`. Returns how many were skipped.
    pub fn skip_to_next_event(&mut self, limit: u64) -> u64 {
        let waiting = self.arb.is_idle() && self.sched.is_idle();
        match self.mem.next_event() {
            Some(at) if waiting && at.min(limit) > self.cycle + 1 => {
                let n = at.min(limit) - self.cycle - 1;
                self.mem.skip(n);
                self.cycle += n;
                n
            }
            _ => 0,
        }
    }

    pub fn stats(&self) -> UnitStats {
        UnitStats {
            stack: self.sm.stats,
            conflict_cycles: self.arb.conflict_cycles,
            conflict_word_waits: self.arb.conflict_word_waits,
            cycles: self.cycle,
        }
    }
}

impl Probe for StackUnit {
    fn probe<S: Sink>(&self, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("rt_unit");
        self.sm.probe(s);
        self.arb.probe(s);
        self.sched.probe(s);
        s.pop_scope();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// RB_2, no SH, global latency 10: pushes 1, 2, 3 (the third spills 1 to global memory),
    /// then pops 3, 2, 1. Returns the cycle the first pop is accepted. By hand: pushes in cycles
    /// 0, 1, 2; the sequencer issues the store in 3. Posted (Overlapped): it is idle after that,
    /// so the pop goes in 4. Acknowledged (Blocking): the scheduler sends the store in 4, the
    /// memory reports the ack in 4 + 10 = 14, the FIFO takes it in 15 and delivers it in 16, the
    /// sequencer completes the store in 17, the pop goes in 18.
    fn pop_cycle(timing: StackTiming) -> u64 {
        let cfg: Config = "RB_2".parse().unwrap();
        let mut u = StackUnit::with_timing(cfg, 10, timing, 2).unwrap();
        for v in [1, 2, 3] {
            u.step(&[(0, Cmd::Push(v))]);
        }
        while !u.sm.ready(0) {
            u.step(&[]);
        }
        let at = u.cycle;
        u.step(&[(0, Cmd::Pop)]);
        assert_eq!(u.sm.answer(0), Ok(Some(3)));
        for want in [2, 1] {
            while !u.sm.ready(0) {
                u.step(&[]);
            }
            u.step(&[(0, Cmd::Pop)]);
            assert_eq!(u.sm.answer(0), Ok(Some(want)), "the spilled entry comes back");
        }
        while !u.idle() {
            u.step(&[]);
        }
        at
    }

    #[test]
    fn acknowledged_stores_hold_the_sequencer_until_the_ack() {
        assert_eq!(pop_cycle(StackTiming::Overlapped), 4);
        assert_eq!(pop_cycle(StackTiming::Blocking), 18);
    }
}
