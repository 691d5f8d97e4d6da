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
//! evaluate on its outputs (siblings: in index order, or as the run's evaluation check says);
//! then every RT unit and the memory system commit at the clock edge. What an SM's RT unit and
//! L1D see of each other is wired in [`crate::sm`].
//!
//! This module holds the parts (the netlist) and what a run reports; the runners above it
//! ([`crate::sim`]) clock them: the reference loop, cycle by cycle, or by windows of cycles (the
//! default, on one thread or two), with the same report bit for bit. How a GPU is run (the
//! runner, the evaluation check, a helper thread) is the run's, not the hardware's:
//! [`crate::sim::Runner`], which `Gpu::run` and the `Gpu::with_*` run options make.

use crate::clock::Unit;
use crate::config::{Config, ConfigError};
use crate::mem::hierarchy::{MemStep, MemSystem};
use crate::mem::{Counters, MemParams, ReqKind};
use crate::rt_unit::{RtParams, RtStep, RtUnit, StackParams};
use crate::stack_manager::{StackPolicy, StackStats};
use crate::thread_cycles::ThreadCycles;
use crate::trace::{Probe, Sink};

/// Passed to a run's progress callback.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    pub cycle: u64,
    pub warps_dispatched: u64,
}

/// Shared memory the SH stacks of one RT unit need: threads × M × entry bytes.
pub fn shared_bytes(cfg: &Config) -> u32 {
    cfg.threads() * cfg.sh_entries * cfg.entry_bytes
}

/// `base` with its unified L1D/shared array of `base.l1d_bytes` split: the SH stacks' shared
/// memory is carved out, the rest is L1D (SPEC 8: "shared memory is sized to exactly what the SH
/// stacks need"). E.g. the L1D sweep: `carve_out(&cfg, MemParams { l1d_bytes: 16 << 10, ..d })`.
pub fn carve_out(cfg: &Config, base: MemParams) -> MemParams {
    base.with_shared_carveout(shared_bytes(cfg))
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

/// The GPU's parts: one RT unit per SM and the memory system, built from a stack configuration
/// and the hardware parameters. Running it is [`crate::sim`]'s (`Gpu::run`, `Gpu::run_timed`, …).
pub struct Gpu {
    cfg: Config,
    units: Vec<RtUnit>,
    mem: MemSystem,
}

impl Gpu {
    /// `mem.sms` SMs with stack configuration `cfg`, RT units of latencies `rt` and stack timing
    /// `stack`, and the memory system `mem`.
    pub fn new(cfg: Config, rt: RtParams, stack: StackParams, mem: MemParams) -> Result<Gpu, ConfigError> {
        Gpu::build(cfg, rt, stack, mem, StackPolicy::of(&cfg))
    }

    /// As [`Gpu::new`], every stack manager running `policy` (an implementation of `cfg`'s
    /// policy other than the one it names: a design under study, a test build's planted bug).
    pub fn build(
        cfg: Config,
        rt: RtParams,
        stack: StackParams,
        mem: MemParams,
        policy: StackPolicy,
    ) -> Result<Gpu, ConfigError> {
        let sys = MemSystem::new(mem)?;
        let mut units = (0..mem.sms)
            .map(|sm| RtUnit::new(sm, cfg, rt, stack, mem.sector_bytes, policy.clone()))
            .collect::<Result<Vec<_>, _>>()?;
        for u in &mut units {
            u.stack_unit.manager.set_local_layout(mem.local_layout, mem.sms);
        }
        Ok(Gpu { cfg, units, mem: sys })
    }

    /// SPEC 7 defaults: 8 SMs, the L1D is 64 KB less the SH stacks' shared memory.
    pub fn paper(cfg: Config) -> Result<Gpu, ConfigError> {
        Gpu::paper_with(cfg, StackPolicy::of(&cfg))
    }

    /// [`Gpu::paper`] with every stack manager running `policy` (as [`Gpu::build`]).
    pub fn paper_with(cfg: Config, policy: StackPolicy) -> Result<Gpu, ConfigError> {
        Gpu::build(
            cfg,
            RtParams::default(),
            StackParams::default(),
            carve_out(&cfg, MemParams::default()),
            policy,
        )
    }

    /// Every stack manager gets a scoreboard from `make`, checking each cycle it commits.
    pub fn with_scoreboard(mut self, make: &dyn Fn() -> Box<dyn crate::stack_manager::Scoreboard>) -> Self {
        for u in &mut self.units {
            u.stack_unit.manager.set_scoreboard(make());
        }
        self
    }

    /// The stack configuration.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    pub fn units(&self) -> &[RtUnit] {
        &self.units
    }

    pub fn memory(&self) -> &MemSystem {
        &self.mem
    }

    /// The parts, lent to a runner for one run.
    pub(crate) fn parts_mut(&mut self) -> (&mut [RtUnit], &mut MemSystem) {
        (&mut self.units, &mut self.mem)
    }

    /// The report of a run that evaluated `evaluated` cycles and dispatched its last job in
    /// `last_dispatch`, from the units' and the memory system's counters; `l2_dram`: the L2's
    /// and DRAM's counters at the run's end where the runner ran them further (else theirs).
    pub(crate) fn report(
        &self,
        evaluated: u64,
        last_dispatch: u64,
        l2_dram: Option<(Counters, Counters)>,
    ) -> GpuReport {
        let (l2, dram) = l2_dram.unwrap_or((*self.mem.l2().counters(), *self.mem.dram().counters()));
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
            evaluated_cycles: evaluated,
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
            last_dispatch,
        }
    }
}

/// Every SM's RT unit (with its step of the cycle, `step(sm)`) and the memory system (with its
/// step, `mem_step`), to the sink: the GPU's waveform scopes `sm<k>` and `mem`.
pub(crate) fn probe<'a, S: Sink>(
    units: &[RtUnit],
    step: impl Fn(usize) -> &'a RtStep,
    mem: &MemSystem,
    mem_step: &MemStep,
    s: &mut S,
) {
    if !s.enabled() {
        return;
    }
    for (sm, u) in units.iter().enumerate() {
        s.push_scope(&format!("sm{sm}"));
        u.probe(step(sm), s);
        s.pop_scope();
    }
    s.push_scope("mem");
    mem.probe(mem_step, s);
    s.pop_scope();
}

/// The GPU's registers, between runs (every RT unit with an empty step).
impl Probe for Gpu {
    fn probe<S: Sink>(&self, s: &mut S) {
        let idle = RtStep::default();
        probe(&self.units, |_| &idle, &self.mem, &Default::default(), s);
    }
}
