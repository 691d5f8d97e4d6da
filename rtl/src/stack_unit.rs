//! The stack subsystem of one RT unit: stack manager, bank arbiter, and memory scheduler with
//! its response FIFO, wired once; the RT unit and the standalone [`StandaloneStack`] both use it.
//!
//! ```text
//!            cmds ──► stack_manager ──sh_req──► bank_arbiter ──done (registered)──┐
//!                       ▲   │                                                      │
//!                       │   └──g_req──► mem_sched ──req (head; fires on req_ready)──► memory
//!                       │                  ▲ FIFO ◄──── completions ◄───── memory ┘
//!                       └──── done / deq (registered outputs, read next cycle) ────┘
//! ```
//!
//! Dataflow within a cycle: the arbiter's `done` and the FIFO's `deq` are registers, so the
//! stack manager evaluates first on them and this cycle's commands; its SH and global requests
//! are then inputs of the arbiter and the scheduler. Nothing changes until the commit. The
//! stack unit and its three children are [`Unit`]s.

use crate::bank_arbiter::{ArbIn, ArbStep, BankArbiter, MIN_SH_LATENCY};
use crate::clock::Unit;
use crate::config::{Config, ConfigError, GM_POSTED_QUEUE_BITS};
use crate::mem_sched::{FixedLatencyMem, FixedStep, GReq, MemSched, SchedIn, SchedStep};
use crate::stack_manager::{
    Cmd, Entry, StackError, StackIn, StackManager, StackPolicy, StackStats, StackStep, StackTiming,
};
use crate::trace::{Probe, Sink};

/// Default global-memory latency of the standalone stack unit, in cycles.
pub const DEFAULT_GLOBAL_LATENCY: u64 = 100;

/// Stack manager, bank arbiter and memory scheduler of one RT unit (registers).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct StackUnit {
    pub manager: StackManager,
    pub arb: BankArbiter,
    pub sched: MemSched,
}

/// This cycle's inputs of the stack subsystem.
#[derive(Clone, Copy, Debug, Default)]
pub struct StackUnitIn<'a> {
    /// The cycle (the arbiter's pipeline counts in it).
    pub now: u64,
    /// Commands, at most one per thread, from threads the manager shows `ready`.
    pub cmds: &'a [(u32, Cmd)],
    /// The memory port takes the request [`StackUnit::req`] offers.
    pub req_ready: bool,
    /// Threads whose global load (or acknowledged store) the memory completed.
    pub completions: &'a [u32],
}

/// The cycle of the stack subsystem: every child's outputs and decisions.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct StackUnitStep {
    pub manager: StackStep,
    pub arb: ArbStep,
    pub sched: SchedStep,
    /// Evaluated on a quiet cycle (see the eval): every child's step is its value for no
    /// input on idle registers, and committing it changes nothing.
    quiet: bool,
}

impl StackUnitStep {
    /// What the cycle answered to thread `t`'s command.
    pub fn answer(&self, t: u32) -> Result<Option<Entry>, StackError> {
        self.manager.answer(t)
    }
}

impl StackUnit {
    /// The stack subsystem of SM `sm`. With [`StackTiming::Blocking`] the sequencer waits for the
    /// acknowledgement of each global store; `sh_latency` as in [`BankArbiter::new`].
    pub fn new(cfg: Config, sm: u32, timing: StackTiming, sh_latency: u32) -> Result<Self, ConfigError> {
        StackUnit::with_stores(cfg, sm, timing == StackTiming::Blocking, sh_latency, StackPolicy::of(&cfg))
    }

    /// As [`StackUnit::new`], saying only whether global stores wait for their acknowledgement
    /// (`acked_stores`) or are posted, the manager running `policy`.
    pub fn with_stores(
        cfg: Config,
        sm: u32,
        acked_stores: bool,
        sh_latency: u32,
        policy: StackPolicy,
    ) -> Result<Self, ConfigError> {
        let queue_bits = if acked_stores { cfg.widths()?.gm_queue } else { GM_POSTED_QUEUE_BITS };
        Ok(StackUnit {
            manager: StackManager::new(cfg, sm)?.with_acked_stores(acked_stores).with_policy(policy),
            arb: BankArbiter::new(cfg.banks, sh_latency, cfg.widths()?.sh_requests),
            sched: MemSched::new(queue_bits, &cfg.widths()?),
        })
    }

    /// The stack manager's counters so far.
    pub fn stats(&self) -> &StackStats {
        &self.manager.stats
    }

    /// Cycles an SH access waited on a bank conflict so far.
    pub fn conflict_cycles(&self) -> u64 {
        self.arb.conflict_cycles
    }

    /// The request offered to the memory port this cycle (from registers).
    #[inline]
    pub fn req(&self) -> Option<GReq> {
        self.sched.head()
    }

    fn eval_children(&self, i: &StackUnitIn, d: &mut StackUnitStep) {
        self.manager.eval(
            StackIn { cmds: i.cmds, done: self.arb.done(), deq: self.sched.deq(), now: i.now },
            &mut d.manager,
        );
        self.arb.eval(ArbIn { now: i.now, new: &d.manager.sh_req }, &mut d.arb);
        let sched_in = SchedIn { new: &d.manager.g_req, req_ready: i.req_ready, completions: i.completions };
        self.sched.eval(sched_in, &mut d.sched);
    }

    /// Nothing comes in (no command, completion or port handshake) and nothing is held: no
    /// micro-op queued, nothing at the banks, in their pipeline or `done` register, nothing in
    /// the scheduler's queue, FIFO or `deq` register.
    #[inline]
    fn quiet(&self, i: &StackUnitIn) -> bool {
        i.cmds.is_empty()
            && i.completions.is_empty()
            && !i.req_ready
            && self.manager.nothing_queued()
            && self.arb.is_idle()
            && self.sched.is_idle()
    }

    fn commit_children(&mut self, d: &StackUnitStep) {
        self.manager.commit(&d.manager);
        self.arb.commit(&d.arb);
        self.sched.commit(&d.sched);
    }

    /// Nothing in flight: no command waits and no request or response is anywhere.
    pub fn idle(&self) -> bool {
        self.manager.quiescent() && self.arb.is_idle() && self.sched.is_idle()
    }
}

impl Unit for StackUnit {
    type In<'a> = StackUnitIn<'a>;
    type Step = StackUnitStep;

    /// Cycle `i.now`, combinational, in dataflow order; `d` receives every output and decision.
    ///
    /// A quiet cycle (no command, completion or port handshake comes in, and no register holds
    /// work: [`StackUnit::quiet`]) evaluates every child to its value for no input, which is the
    /// same in every quiet cycle but for the cycle number the arbiter's and the manager's steps
    /// carry. So when `d`
    /// already holds a quiet cycle's step, only that number is updated; the children are not
    /// evaluated again, and the commit skips the step (committing it changes nothing).
    /// Test: `quiet_cycles_skip_work_with_identical_steps_and_state` compares every step and
    /// state with the children evaluated and committed every cycle.
    #[inline]
    fn eval(&self, i: StackUnitIn<'_>, d: &mut StackUnitStep) {
        let quiet = self.quiet(&i);
        if quiet && d.quiet {
            d.arb.set_now(i.now);
            d.manager.set_now(i.now);
            return;
        }
        self.eval_children(&i, d);
        d.quiet = quiet;
    }

    /// The clock edge.
    #[inline]
    fn commit(&mut self, d: &StackUnitStep) {
        if !d.quiet {
            self.commit_children(d);
        }
    }

    /// Registers, and the cycle `d`: each child's probe.
    fn probe<S: Sink>(&self, d: &StackUnitStep, s: &mut S) {
        if !s.enabled() {
            return;
        }
        Unit::probe(&self.manager, &d.manager, s);
        self.arb.probe(&d.arb, s);
        self.sched.probe(&d.sched, s);
    }
}

/// The stack subsystem standing alone: a [`StackUnit`] whose global requests go to a
/// fixed-latency memory. Drives proofs and testbenches that exercise the stack without node
/// fetches.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct StandaloneStack {
    pub unit: StackUnit,
    pub mem: FixedLatencyMem,
    pub cycle: u64,
    /// The last cycle's step (what [`StandaloneStack::answer`] and the probe show).
    d: StackUnitStep,
    mem_d: FixedStep,
}

/// What one run cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct UnitStats {
    pub stack: StackStats,
    pub conflict_cycles: u64,
    pub conflict_word_waits: u64,
    pub cycles: u64,
}

impl StandaloneStack {
    /// The stack subsystem with the `legacy` preset's timing: posted global stores and SH
    /// accesses done right after the banks (`sh_latency` 2).
    pub fn new(cfg: Config, global_latency: u64) -> Result<Self, ConfigError> {
        StandaloneStack::with_timing(cfg, global_latency, StackTiming::Overlapped, MIN_SH_LATENCY)
    }

    /// With `StackTiming::Blocking` the memory acknowledges stores and the sequencer waits for
    /// the acknowledgement; `sh_latency` as in [`BankArbiter::new`]. (A standalone unit
    /// has no node fetches, so the rest of `Blocking` does not apply.)
    pub fn with_timing(
        cfg: Config,
        global_latency: u64,
        timing: StackTiming,
        sh_latency: u32,
    ) -> Result<Self, ConfigError> {
        Ok(StandaloneStack {
            unit: StackUnit::new(cfg, 0, timing, sh_latency)?,
            mem: FixedLatencyMem::with_acks(global_latency, timing == StackTiming::Blocking),
            cycle: 0,
            d: StackUnitStep::default(),
            mem_d: FixedStep::default(),
        })
    }

    pub fn manager(&self) -> &StackManager {
        &self.unit.manager
    }

    pub fn manager_mut(&mut self) -> &mut StackManager {
        &mut self.unit.manager
    }

    /// One clock cycle: evaluate the stack unit and the memory (the port is always ready), then
    /// commit both. The answers to `cmds` are in [`StandaloneStack::answer`].
    pub fn step(&mut self, cmds: &[(u32, Cmd)]) {
        let i = StackUnitIn { now: self.cycle, cmds, req_ready: true, completions: self.mem.completions() };
        self.unit.eval(i, &mut self.d);
        self.mem.eval(self.d.sched.req, &mut self.mem_d);
        self.unit.commit(&self.d);
        self.mem.commit(&self.mem_d);
        self.cycle += 1;
    }

    /// What the last cycle answered to thread `t`'s command.
    pub fn answer(&self, t: u32) -> Result<Option<Entry>, StackError> {
        self.d.answer(t)
    }

    /// Nothing in flight anywhere: stepping without commands changes nothing but time.
    pub fn idle(&self) -> bool {
        self.unit.idle() && self.mem.is_idle()
    }

    /// When only global loads are in flight, nothing happens until the first returns: skips
    /// those cycles, but not past cycle `limit`. Returns how many were skipped.
    pub fn skip_to_next_event(&mut self, limit: u64) -> u64 {
        let waiting = self.unit.arb.is_idle() && self.unit.sched.is_idle();
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
            stack: self.unit.manager.stats,
            conflict_cycles: self.unit.arb.conflict_cycles,
            conflict_word_waits: self.unit.arb.conflict_word_waits,
            cycles: self.cycle,
        }
    }
}

impl Probe for StandaloneStack {
    fn probe<S: Sink>(&self, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("rt_unit");
        self.unit.probe(&self.d, s);
        s.pop_scope();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs random pushes and pops on two copies of one stack unit: one through its eval and
    /// commit (quiet cycles skipped), one with every child
    /// evaluated and committed every cycle. Every step and every state must agree; returns how
    /// many quiet cycles the run had.
    fn quiet_run(config: &str, timing: StackTiming, sh_latency: u32, seed: u64) -> u64 {
        use crate::mem::testutil::XorShift;
        let cfg: Config = config.parse().unwrap();
        let new = || StackUnit::new(cfg, 0, timing, sh_latency).unwrap();
        let (mut fast, mut full) = (new(), new());
        let mut mem = FixedLatencyMem::with_acks(30, timing == StackTiming::Blocking);
        let (mut df, mut dg, mut dm) =
            (StackUnitStep::default(), StackUnitStep::default(), FixedStep::default());
        let mut rng = XorShift(seed);
        let mut depth = vec![0u32; cfg.threads() as usize];
        let (mut cmds, mut quiet) = (Vec::new(), 0);
        for now in 0..6000u64 {
            // Bursts of commands from a few threads, then long pauses.
            cmds.clear();
            if now % 400 < 150 {
                for t in 0..cfg.threads().min(8) {
                    if fast.manager.ready(t) && rng.below(3) == 0 {
                        let pop = depth[t as usize] > 0 && rng.below(2) == 0;
                        cmds.push((t, if pop { Cmd::Pop } else { Cmd::Push(now) }));
                        depth[t as usize] = if pop { depth[t as usize] - 1 } else { depth[t as usize] + 1 };
                    }
                }
            }
            let i = StackUnitIn {
                now,
                cmds: &cmds,
                req_ready: fast.req().is_some(),
                completions: mem.completions(),
            };
            quiet += u64::from(fast.quiet(&i));
            fast.eval(i, &mut df);
            full.eval_children(&i, &mut dg);
            let steps = (&df.manager, &df.arb, &df.sched) == (&dg.manager, &dg.arb, &dg.sched);
            assert!(steps, "cycle {now}: steps differ\n{df:?}\n{dg:?}");
            mem.eval(df.sched.req, &mut dm);
            fast.commit(&df);
            full.commit_children(&dg);
            mem.commit(&dm);
            assert!(fast == full, "cycle {now}: states differ");
        }
        quiet
    }

    #[test]
    fn quiet_cycles_skip_work_with_identical_steps_and_state() {
        let runs = [
            ("RB_2", StackTiming::Blocking, 20),
            ("RB_2+SH_2+SK", StackTiming::Blocking, 20),
            ("RB_1+SH_2", StackTiming::Overlapped, 2),
            ("RB_2+SH_2+SK+RA", StackTiming::Blocking, 20),
        ];
        for (seed, (config, timing, latency)) in runs.into_iter().enumerate() {
            let quiet = quiet_run(config, timing, latency, seed as u64 + 1);
            assert!(quiet > 1000, "{config}: the run has quiet cycles to skip ({quiet})");
        }
    }
}
