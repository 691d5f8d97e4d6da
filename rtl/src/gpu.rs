//! The GPU: `sms` SMs (an RT unit and its L1D each), sharing the L2 and DRAM.
//!
//! ```text
//!  warp jobs ──► dispatcher (round-robin over SMs with a free warp slot, ≤ 1 job per SM per cycle)
//!                   │
//!        ┌──────────┼──────────────┐
//!        ▼          ▼              ▼
//!      SM 0       SM 1     …    SM n-1        each: RT unit ─ req ─► L1D (crate::sm)
//!        │          │              │
//!        └──────────┴── MemSystem ─┘          the L2 and DRAM (crate::mem::hierarchy)
//! ```
//!
//! One cycle ([`Gpu::eval_by`]): the L2 and DRAM on the L1Ds' down requests (register outputs);
//! then every SM (siblings: in index order, or as the evaluation says) on the L2's grant and
//! responses for it and the job landing in it. The clock edge: every RT unit's, then the
//! memory's (the L1Ds', the L2's and DRAM's; [`Gpu::commit_then`]).
//!
//! This module holds the netlist and what a run reports; the runners above it ([`crate::sim`])
//! clock it: the reference loop, cycle by cycle through [`Gpu::eval_by`] and
//! [`Gpu::commit_then`], or by windows of cycles (the default, on one thread or two), each SM on
//! its own, with the same report bit for bit. How a GPU is run (the runner, the evaluation check,
//! a helper thread) is the run's, not the hardware's: [`crate::sim::Runner`], which `Gpu::run` and
//! the `Gpu::with_*` run options make.

use crate::clock::Unit;
use crate::config::{Config, ConfigError};
use crate::mem::hierarchy::{MemStep, MemSystem};
use crate::mem::l1d::{L1d, L1dStep};
use crate::mem::{Counters, MemParams, MemReq, ReqKind};
use crate::ray_op::WarpJob;
use crate::rt_unit::{RtParams, RtUnit, RunError, StackParams};
use crate::sm::{Dataflow, Evaluation, Sm, SmIn, SmStep};
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

/// The GPU's registers: one [`Sm`] per SM and the memory they share, built from a stack
/// configuration and the hardware parameters. Running it is [`crate::sim`]'s (`Gpu::run`,
/// `Gpu::run_timed`, …).
#[derive(Clone, Debug)]
pub struct Gpu {
    cfg: Config,
    sms: Vec<Sm>,
    mem: MemSystem,
}

/// The GPU's inputs in a cycle: the job the dispatcher sends each SM (landing at the edge).
#[derive(Clone, Copy, Debug)]
pub struct GpuIn<'a> {
    pub jobs: &'a [Option<WarpJob>],
}

/// The GPU's cycle: every unit's step, the wires between them and the SMs' evaluation order. A
/// buffer reused from cycle to cycle.
#[derive(Clone, Debug, Default)]
pub struct GpuStep {
    /// Each L1D's down request (its register output): the memory's input.
    down: Vec<Option<MemReq>>,
    mem: MemStep,
    sms: Vec<SmStep>,
    /// The order in which the SMs were evaluated (and are committed).
    order: Vec<usize>,
}

impl GpuStep {
    /// SM `sm`'s step.
    #[inline]
    pub fn sm(&self, sm: usize) -> &SmStep {
        &self.sms[sm]
    }

    /// The cycle's failed check: of the SMs' failed checks, the lowest SM's (whatever the
    /// evaluation order).
    pub fn check(&self) -> Result<(), RunError> {
        self.sms.iter().try_for_each(SmStep::check)
    }
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
        let sms = (0..mem.sms)
            .map(|sm| {
                let mut rt = RtUnit::new(sm, cfg, rt, stack, mem.sector_bytes, policy.clone())?;
                rt.stack_unit.manager.set_local_layout(mem.local_layout, mem.sms);
                Ok(Sm { rt, l1d: L1d::new(&mem) })
            })
            .collect::<Result<Vec<_>, ConfigError>>()?;
        Ok(Gpu { cfg, sms, mem: sys })
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
        for sm in &mut self.sms {
            sm.rt.stack_unit.manager.set_scoreboard(make());
        }
        self
    }

    /// The stack configuration.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    pub fn sms(&self) -> &[Sm] {
        &self.sms
    }

    /// The memory the SMs share (the L2 and DRAM) and its parameters.
    pub fn memory(&self) -> &MemSystem {
        &self.mem
    }

    /// The current cycle.
    pub fn cycle(&self) -> u64 {
        self.mem.cycle()
    }

    /// The SMs and the shared memory, to clock apart (the windowed run).
    pub(crate) fn parts_mut(&mut self) -> (&mut [Sm], &mut MemSystem) {
        (&mut self.sms, &mut self.mem)
    }

    /// L1D counters summed over SMs.
    pub fn l1d_counters(&self) -> Counters {
        let mut total = Counters::default();
        for sm in &self.sms {
            total.add(sm.l1d.counters());
        }
        total
    }

    /// [`Unit::eval`] with the choices of `e` ([`Evaluation`]): the L2 and DRAM, then the SMs in
    /// the order `e` gives, each kernel as many times as it says.
    pub fn eval_by<E: Evaluation>(&self, i: GpuIn<'_>, d: &mut GpuStep, e: E) {
        let n = self.sms.len();
        assert_eq!(i.jobs.len(), n, "one job slot per SM");
        let now = self.cycle();
        d.down.clear();
        d.down.extend(self.sms.iter().map(|sm| sm.l1d.down_req()));
        for _ in 0..e.passes() {
            self.mem.eval(&d.down, &mut d.mem);
        }
        d.sms.resize_with(n, SmStep::default);
        e.order(now, n, &mut d.order);
        for &k in &d.order {
            let i = SmIn {
                now,
                granted: d.mem.granted(k),
                fills: self.mem.l2().resp(k),
                job: i.jobs[k].as_ref(),
            };
            self.sms[k].eval_by(i, &mut d.sms[k], e);
        }
    }

    /// [`Unit::commit`], calling `between` after the SMs' RT units took their edge and before the
    /// memory (the L1Ds, the L2 and DRAM) takes its: where walk-driven warps take their next
    /// segments ([`Gpu::follow_walks`]) and a waveform samples the cycle ([`Unit::probe`]: the RT
    /// units' registers after the edge, the memory's before it, with the cycle's signals). Each
    /// unit's edge writes only its own registers, so their order does not matter (the SMs take
    /// theirs in the order they were evaluated in).
    pub fn commit_then(&mut self, d: &GpuStep, between: impl FnOnce(&mut Gpu)) {
        for &k in &d.order {
            let s = &d.sms[k];
            if s.rt_stepped() {
                self.sms[k].rt.commit(&s.rt);
            }
        }
        between(self);
        for &k in &d.order {
            self.sms[k].l1d.commit(&d.sms[k].l1d);
        }
        self.mem.commit(&d.mem);
    }

    /// The rest of the clock edge for walk-driven warps ([`RtUnit::follow_walks`]): every RT
    /// unit that took an edge in `d`, in the order it was evaluated in.
    pub fn follow_walks(&mut self, d: &GpuStep, walks: &mut Option<&mut dyn crate::ray_op::Walks>, now: u64) {
        for &k in &d.order {
            if d.sms[k].rt_stepped() {
                self.sms[k].rt.follow_walks(walks, now);
            }
        }
    }

    /// The report of a run that evaluated `evaluated` cycles of `cycles` and dispatched its last
    /// job in `last_dispatch`, from the units' counters; `l2_dram`: the L2's and DRAM's counters
    /// at the run's end where the runner ran them further (else theirs).
    pub(crate) fn report(
        &self,
        cycles: u64,
        evaluated: u64,
        last_dispatch: u64,
        l2_dram: Option<(Counters, Counters)>,
    ) -> GpuReport {
        let (l2, dram) = l2_dram.unwrap_or((*self.mem.l2().counters(), *self.mem.dram().counters()));
        // Every L2 access is a request an SM's L1D sent down (the L2 serves nothing else).
        let mut stack = StackStats::default();
        let units = || self.sms.iter().map(|sm| &sm.rt);
        for u in units() {
            stack.add(u.counters().0);
        }
        let sum = |f: fn(&RtUnit) -> u64| units().map(f).sum::<u64>();
        let mut thread_cycles = ThreadCycles::default();
        for u in units() {
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
            l1d_hit_rate: hit_rate(&self.l1d_counters()),
            l2_hit_rate: hit_rate(&l2),
            stack,
            bank_conflict_cycles: sum(|u| u.counters().2),
            pops_checked: sum(|u| u.stats.pops_checked),
            thread_cycles,
            last_dispatch,
        }
    }
}

impl Unit for Gpu {
    type In<'a> = GpuIn<'a>;
    type Step = GpuStep;

    /// The GPU's cycle as the design evaluates it ([`Gpu::eval_by`] with [`Dataflow`]).
    fn eval(&self, i: GpuIn<'_>, d: &mut GpuStep) {
        self.eval_by(i, d, Dataflow);
    }

    /// The clock edge of every unit ([`Gpu::commit_then`]). A step with a failed check
    /// ([`GpuStep::check`]) is not committed.
    fn commit(&mut self, d: &GpuStep) {
        self.commit_then(d, |_| {});
    }

    /// The waveform's scopes: `sm<k>`, each SM's RT unit, and `mem`, the memory: every SM's L1D
    /// (`l1d<k>`), the L2 and DRAM, grouped as the memory hierarchy is (so this probe shows the
    /// SMs' L1Ds itself rather than through [`Sm`]'s probe). Sampled where
    /// [`Gpu::commit_then`] calls `between`.
    fn probe<S: Sink>(&self, d: &GpuStep, s: &mut S) {
        if !s.enabled() {
            return;
        }
        let idle = SmStep::default();
        let step = |k: usize| d.sms.get(k).unwrap_or(&idle);
        for (k, sm) in self.sms.iter().enumerate() {
            s.push_scope(&format!("sm{k}"));
            sm.rt.probe(&step(k).rt, s);
            s.pop_scope();
        }
        s.push_scope("mem");
        let idle_l1d = L1dStep::default();
        for (k, sm) in self.sms.iter().enumerate() {
            s.push_scope(&format!("l1d{k}"));
            sm.l1d.probe(d.sms.get(k).map_or(&idle_l1d, |x| &x.l1d), s);
            s.pop_scope();
        }
        self.mem.probe(&d.mem, s);
        s.pop_scope();
    }

    /// The first cycle in which some unit acts with no new input.
    fn next_event(&self) -> Option<u64> {
        self.sms.iter().filter_map(Sm::next_event).chain(self.mem.next_event()).min()
    }

    /// Jumps to `cycle` over cycles in which nothing happens. Panics if that would skip an event
    /// ([`Gpu::next_event`]: a caller bug).
    fn skip_to(&mut self, cycle: u64) {
        assert!(cycle >= self.cycle(), "cannot go back to cycle {cycle}");
        if let Some(event) = self.next_event() {
            assert!(cycle <= event, "skipping to {cycle} would miss the event at {event}");
        }
        for sm in &mut self.sms {
            sm.skip_to(cycle);
        }
        self.mem.skip_to(cycle);
    }
}

/// The GPU's registers, between runs.
impl Probe for Gpu {
    fn probe<S: Sink>(&self, s: &mut S) {
        Unit::probe(self, &GpuStep::default(), s);
    }
}
