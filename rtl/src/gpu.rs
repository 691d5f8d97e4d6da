//! The GPU: `sms` SMs, one RT unit each, sharing one memory system (per-SM L1D, one L2, DRAM).
//!
//! ```text
//!  warp jobs ──► dispatcher (round-robin over SMs with a free warp slot, ≤ 1 job per SM per cycle)
//!                   │
//!        ┌──────────┼──────────────┐
//!        ▼          ▼              ▼
//!     RT unit 0  RT unit 1  …  RT unit n-1      each: req ≤ 1 (from registers), eval on responses
//!        │          │              │
//!        └──────────┴── MemSystem ─┘  (eval: ready + responses per SM; commit: clock edge)
//! ```
//!
//! One cycle: the RT units' requests (from registers) go to [`MemSystem::eval`]; the RT units
//! evaluate on its outputs (siblings: in index order, or as [`Gpu::with_eval_check`] says); then
//! every RT unit and the memory system commit at the clock edge.
//!
//! This module holds the parts and what a run reports; [`crate::sim`] runs them: the reference
//! loop, cycle by cycle, or by windows of cycles (the default, on one thread or two), with the
//! same report bit for bit.

use crate::clock::EvalCheck;
use crate::config::{Config, ConfigError};
use crate::mem::hierarchy::MemSystem;
use crate::mem::{Counters, MemParams, ReqKind};
use crate::ray_op::{Walks, WarpJob};
use crate::rt_unit::{RtParams, RtStep, RtUnit, RunError};
use crate::sim::{self, Parts};
use crate::stack_manager::{StackPolicy, StackStats};
use crate::thread_cycles::ThreadCycles;
use crate::trace::{Probe, Sink};

pub use crate::sim::Progress;

/// Shared memory the SH stacks of one RT unit need: threads × M × entry bytes.
pub fn shared_bytes(cfg: &Config) -> u32 {
    cfg.threads() * cfg.sh_entries * cfg.entry_bytes
}

/// `base` with its unified L1D/shared array of `base.l1d_bytes` split: the SH stacks' shared
/// memory is carved out, the rest is L1D (SPEC 8: "shared memory is sized to exactly what the SH
/// stacks need"). E.g. the L1D sweep: `carve_out(&cfg, MemParams { l1d_bytes: 16 << 10, ..d })`.
pub fn carve_out(cfg: &Config, base: MemParams) -> MemParams {
    MemParams { l1d_bytes: base.l1d_bytes.saturating_sub(shared_bytes(cfg)), ..base }
}

/// What a run cost. Plain data: identical inputs give an identical report.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GpuReport {
    pub cycles: u64,
    /// Cycles actually evaluated (the rest were skipped as idle); equals `cycles` without
    /// skipping.
    pub evaluated_cycles: u64,
    pub warps: u64,
    pub rays: u64,
    /// Visit operations of all rays, before merging.
    pub visits: u64,
    /// Node sector requests sent to the L1Ds (after merging within warps).
    pub node_fetches: u64,
    /// Off-chip (DRAM) accesses caused by node fetches.
    pub dram_node: u64,
    /// Off-chip accesses caused by stack spills and reloads (including write-backs of spilled
    /// lines).
    pub dram_stack: u64,
    /// Requests leaving the SMs for L2 caused by node fetches (L1D fill requests): the paper's
    /// "off-chip memory accesses", which count L2 as off-chip.
    pub l2_node: u64,
    /// Requests leaving the SMs for L2 caused by stack spills (write-through stores) and reloads
    /// (L1D fill requests).
    pub l2_stack: u64,
    pub l1d_hit_rate: f64,
    pub l2_hit_rate: f64,
    /// Stack manager counters summed over SMs.
    pub stack: StackStats,
    /// Bank-conflict delay cycles summed over SMs.
    pub bank_conflict_cycles: u64,
    pub pops_checked: u64,
    /// The RT units' thread-cycles by category, summed over SMs: `cycles` × SMs × thread slots
    /// in all ([`crate::thread_cycles`]).
    pub thread_cycles: ThreadCycles,
    /// Cycle in which the last job was dispatched: after it the GPU only drains (sampling
    /// scales the part before it and keeps the drain).
    pub last_dispatch: u64,
}

fn hit_rate(c: &Counters) -> f64 {
    if c.accesses == 0 {
        0.0
    } else {
        c.hits as f64 / c.accesses as f64
    }
}

pub struct Gpu {
    cfg: Config,
    rt: RtParams,
    units: Vec<RtUnit>,
    mem: MemSystem,
    /// How sibling RT units are evaluated each cycle ([`Gpu::with_eval_check`]).
    eval_check: EvalCheck,
    /// The windowed run's SMs are split between two threads ([`Gpu::with_helper_thread`]).
    helper_thread: bool,
    /// The run goes by windows where it can ([`Gpu::with_windows`]).
    windows: bool,
    /// A slip planted in the runner ([`Gpu::with_order_bug`]).
    #[cfg(feature = "mutants")]
    order_bug: Option<sim::OrderBug>,
}

impl Gpu {
    /// `mem.sms` SMs with stack configuration `cfg`.
    pub fn new(cfg: Config, rt: RtParams, mem: MemParams) -> Result<Gpu, ConfigError> {
        Gpu::build(cfg, rt, mem, StackPolicy::of(&cfg))
    }

    /// As [`Gpu::new`], every stack manager running `policy` (an implementation of `cfg`'s
    /// policy other than the one it names: a design under study, a test build's planted bug).
    pub fn build(cfg: Config, rt: RtParams, mem: MemParams, policy: StackPolicy) -> Result<Gpu, ConfigError> {
        let sys = MemSystem::new(mem)?;
        let mut units = (0..mem.sms)
            .map(|sm| RtUnit::new(sm, cfg, rt, mem.sector_bytes, policy.clone()))
            .collect::<Result<Vec<_>, _>>()?;
        for u in &mut units {
            u.stack_unit.manager.set_local_layout(mem.local_layout, mem.sms);
        }
        Ok(Gpu {
            cfg,
            rt,
            units,
            mem: sys,
            eval_check: EvalCheck::Dataflow,
            helper_thread: false,
            windows: true,
            #[cfg(feature = "mutants")]
            order_bug: None,
        })
    }

    /// SPEC 7 defaults: 8 SMs, the L1D is 64 KB less the SH stacks' shared memory.
    pub fn paper(cfg: Config) -> Result<Gpu, ConfigError> {
        Gpu::paper_with(cfg, StackPolicy::of(&cfg))
    }

    /// [`Gpu::paper`] with every stack manager running `policy` (as [`Gpu::build`]).
    pub fn paper_with(cfg: Config, policy: StackPolicy) -> Result<Gpu, ConfigError> {
        Gpu::build(cfg, RtParams::default(), carve_out(&cfg, MemParams::default()), policy)
    }

    /// Every stack manager gets a scoreboard from `make`, checking each cycle it commits.
    pub fn with_scoreboard(mut self, make: &dyn Fn() -> Box<dyn crate::stack_manager::Scoreboard>) -> Self {
        for u in &mut self.units {
            u.stack_unit.manager.set_scoreboard(make());
        }
        self
    }

    /// Evaluate the RT units, and within the memory system the L1Ds and DRAM, in the order, and
    /// as many times per cycle, that `check` says (the report must not change: tests compare it
    /// with the [`EvalCheck::Dataflow`] run's).
    pub fn with_eval_check(mut self, check: EvalCheck) -> Self {
        self.eval_check = check;
        self.mem.set_eval_check(check);
        self
    }

    /// Runs the windowed run's SMs on two threads (the calling thread and a helper): the same
    /// results as one thread, in less wall time when a second core is free. The reference loop
    /// runs on one thread either way.
    pub fn with_helper_thread(mut self, on: bool) -> Self {
        self.helper_thread = on && self.units.len() >= 2;
        self
    }

    /// Runs by windows of cycles, each SM on its own between meetings at the L2 ([`crate::sim`]:
    /// the same report as the reference loop), where the run allows it: no waveform,
    /// [`EvalCheck::Dataflow`], idle cycles skipped, at most 64 SMs and an L2 long enough. On by
    /// default; off for the reference loop.
    pub fn with_windows(mut self, on: bool) -> Self {
        self.windows = on;
        self
    }

    /// A runner with a planted slip (test builds).
    #[cfg(feature = "mutants")]
    pub fn with_order_bug(mut self, bug: sim::OrderBug) -> Self {
        self.order_bug = Some(bug);
        self
    }

    pub fn units(&self) -> &[RtUnit] {
        &self.units
    }

    pub fn memory(&self) -> &MemSystem {
        &self.mem
    }

    /// Runs every job to completion. Every pop is checked against its trace; the first problem
    /// stops the run.
    pub fn run<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        sink: &mut S,
    ) -> Result<GpuReport, RunError> {
        self.run_with_progress(jobs, sink, u64::MAX, |_| {})
    }

    /// As [`Gpu::run`], calling `progress` about every `every` cycles.
    pub fn run_with_progress<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
    ) -> Result<GpuReport, RunError> {
        self.run_timed(jobs, sink, every, progress, &mut Vec::new())
    }

    /// As [`Gpu::run_with_progress`], also filling `residence` with the cycles each job spent
    /// in its RT unit's warp buffer, indexed by job (launch order).
    // Kept out of line: `scripts/instructions.sh` counts the instructions inside it.
    #[inline(never)]
    pub fn run_timed<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
        residence: &mut Vec<u64>,
    ) -> Result<GpuReport, RunError> {
        #[cfg(feature = "mutants")]
        if let Some(bug) = self.order_bug {
            let shared = std::sync::atomic::AtomicU64::new(0);
            return self.run_with(sim::Slipped(bug, &shared), jobs, None, sink, every, progress, residence);
        }
        self.run_with(sim::Design, jobs, None, sink, every, progress, residence)
    }

    /// As [`Gpu::run_timed`], for walk-driven jobs (`WarpJob::walk`, the restart designs): each
    /// ray's operations come from `walks` as its stack answers. Every pop is checked against the
    /// walk's unbounded reference stack (or answered Restart by the stack's own decision).
    pub fn run_walks<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        walks: &mut dyn Walks,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
        residence: &mut Vec<u64>,
    ) -> Result<GpuReport, RunError> {
        self.run_with(sim::Design, jobs, Some(walks), sink, every, progress, residence)
    }

    /// [`Gpu::run_timed`] with the runner's steps `steps`.
    fn run_with<S: Sink>(
        mut self,
        steps: impl sim::Steps,
        jobs: impl IntoIterator<Item = WarpJob>,
        walks: Option<&mut dyn Walks>,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
        residence: &mut Vec<u64>,
    ) -> Result<GpuReport, RunError> {
        let mut walks = walks;
        let parts = Parts {
            units: &mut self.units,
            mem: &mut self.mem,
            warp_size: self.cfg.warp_size,
            idle_skip: self.rt.idle_skip,
            eval_check: self.eval_check,
            helper_thread: self.helper_thread,
            windows: self.windows,
            walks: walks.as_mut().map(|w| &mut **w as &mut dyn Walks),
        };
        let o = sim::run(parts, steps, jobs, sink, every, progress, residence)?;
        Ok(self.report(&o))
    }

    /// The report of a run that ended as `o` says.
    fn report(&self, o: &sim::Outcome) -> GpuReport {
        let (l2, dram) =
            o.l2_dram_counters.unwrap_or((*self.mem.l2().counters(), *self.mem.dram().counters()));
        // Every L2 access is a request an SM's L1D sent down (the L2 serves nothing else).
        let mut stack = StackStats::default();
        for u in &self.units {
            stack.add(u.counters().0);
        }
        let sum = |f: fn(&RtUnit) -> u64| self.units.iter().map(f).sum::<u64>();
        let cycles = self.mem.cycle();
        let mut thread_cycles = ThreadCycles::default();
        for u in &self.units {
            thread_cycles.add(&u.thread_cycles(cycles));
        }
        GpuReport {
            cycles,
            evaluated_cycles: o.evaluated,
            warps: sum(|u| u.stats.warps),
            rays: sum(|u| u.stats.rays),
            visits: sum(|u| u.stats.visits),
            node_fetches: sum(|u| u.counters().1),
            dram_node: dram.kind(ReqKind::NodeFetch).accesses,
            dram_stack: dram.kind(ReqKind::StackSpill).accesses + dram.kind(ReqKind::StackReload).accesses,
            l2_node: l2.kind(ReqKind::NodeFetch).accesses,
            l2_stack: l2.kind(ReqKind::StackSpill).accesses + l2.kind(ReqKind::StackReload).accesses,
            l1d_hit_rate: hit_rate(&self.mem.l1d_counters()),
            l2_hit_rate: hit_rate(&l2),
            stack,
            bank_conflict_cycles: sum(|u| u.counters().2),
            pops_checked: sum(|u| u.stats.pops_checked),
            thread_cycles,
            last_dispatch: o.last_dispatch,
        }
    }
}

/// The GPU's registers, between runs (every RT unit with an empty step).
impl Probe for Gpu {
    fn probe<S: Sink>(&self, s: &mut S) {
        let idle = RtStep::default();
        sim::probe(&self.units, |_| &idle, &self.mem, &Default::default(), s);
    }
}
