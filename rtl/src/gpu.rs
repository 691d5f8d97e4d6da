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
//! The normal run ([`EvalCheck::Dataflow`], a cycle no sink shows) evaluates the same cycle SM by
//! SM instead: the L2 and DRAM first (their inputs are registers), then for each SM its request,
//! its L1D ([`SmPorts::eval`]), its RT unit, and the clock edges of both, and last the L2's
//! and DRAM's edges. No SM reads another SM's registers or step, so only the order of work
//! changes, and one SM's state and code stay in the CPU's caches while it is worked on: 4 % fewer
//! instructions and 40 % fewer instruction-cache misses (callgrind). The other evaluation checks
//! run phase by phase, so the tests that compare their reports with the normal run's compare the
//! two forms.
//!
//! Two threads, the split form ([`Gpu::with_helper_thread`]): the RT units and the memory system
//! meet only in registers (an RT unit reads its L1D's `ready` and `resp` registers; an L1D reads
//! its RT unit's request register; an L1D's `req_fire` is its `ready` with a request offered), so
//! within a cycle the two sides are independent. The memory system (L2 and DRAM, then every L1D,
//! then the clock edges) runs on the calling thread, the RT units on a helper thread
//! ([`crate::lockstep`]), each side reading the other's registers as latched when the cycle began
//! ([`RtSide`], [`MemSide`]) and latching its own for the next cycle. The calling thread also
//! steps the first quarter of the RT units (the memory side is the lighter one), and of a cycle's
//! errors the lowest SM's comes first, as on one thread. Each RT unit leaves what the loop reads
//! between cycles (next event, free slot, emptiness) in one small array, and each L1D its next
//! event in another and its down request in the memory system's step for the next cycle's L2
//! ([`SmPorts::commit`]), so no thread reads state that another core has in its cache. The same
//! results as one thread, bit for bit (tested). Measured (stop 19, the throughput bench's SMS
//! run): 14 % less wall time at about 1.5 times the CPU time; splitting the SMs in two halves
//! instead gave 10 %. Either way each cycle ends with both threads meeting, and the work of a
//! cycle swings between the sides (responses come in bursts), so each side waits for the other
//! in many cycles.
//!
//! By windows (the default for the normal run, [`Gpu::with_windows`], module `window`): each SM
//! runs up to 64 cycles on its own between meetings at the L2, whose back end runs ahead of the
//! SMs (a request's tag check is `l2_latency - 3` cycles after the L2 lets it in, so every
//! response of a window is known before it starts) and whose front end (the banks' arbiters)
//! follows the slowest SM; an SM stops early where another SM's decision reaches it (a dispatch,
//! its miss queue's exact length). With a helper thread the SMs are split between the two
//! threads, which meet once a window instead of once a cycle. The same report as the loops
//! above, bit for bit (tested against them); they remain for waveforms, the evaluation checks,
//! `with_windows(false)` and an L2 too short for windows.
//!
//! Dispatch is a kernel launch's: job i goes to the next SM after the one that took job i-1 that
//! has a free warp slot, so at launch SM k gets jobs k, k + n, k + 2n, … and later jobs go wherever
//! a warp left. Every decision reads registers: a slot freed in cycle c takes a job in c + 1.
//!
//! Idle skipping: after each cycle every RT unit reports the next cycle in which it acts without
//! a memory response, and the memory system its next event; the run jumps to the earliest. The
//! skipped cycles would have changed nothing, so the report is identical to stepping every cycle
//! (tested). A sink sees every cycle it wants ([`Sink::next_wanted`]): skipping never jumps over one, so a
//! dump has every cycle of its window, and cycles outside the window are skipped as usual.

use crate::clock::EvalCheck;
use crate::config::{Config, ConfigError};
use crate::lockstep::{self, Helper};
use crate::mem::hierarchy::{MemSystem, SmPorts};
use crate::mem::l1d::L1d;
use crate::mem::{Counters, MemParams, MemReq, MemResp, ReqKind};
use crate::ray_op::WarpJob;
use crate::rt_unit::{RtIn, RtParams, RtStep, RtUnit, RunError};
use crate::stack_manager::StackStats;
use crate::trace::{Probe, Sink};

#[path = "window.rs"]
mod window;

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
    /// Cycle in which the last job was dispatched: after it the GPU only drains (sampling
    /// scales the part before it and keeps the drain).
    pub last_dispatch: u64,
}

/// Passed to the progress callback.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    pub cycle: u64,
    pub warps_dispatched: u64,
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
    /// Next SM the dispatcher tries.
    rr: usize,
    /// How sibling RT units are evaluated each cycle ([`Gpu::with_eval_check`]).
    eval_check: EvalCheck,
    #[cfg(feature = "mutants")]
    order_bug: Option<OrderBug>,
    /// Per SM: the request offered, whether the L1D was ready for it, the job dispatched, and
    /// the RT unit's cycle (reused every cycle).
    reqs: Vec<Option<MemReq>>,
    req_ready: Vec<bool>,
    jobs_in: Vec<Option<WarpJob>>,
    steps: Vec<RtStep>,
    /// Units skipped this cycle: nothing for them to do (see the run loop).
    quiet: Vec<bool>,
    /// Evaluation order of the RT units this cycle.
    order: Vec<usize>,
    /// Per SM: its RT unit's registers the run loop reads between cycles, and its L1D's next
    /// event.
    status: Vec<RtStatus>,
    l1d_next: Vec<Option<u64>>,
    /// The split form's latches ([`RtSide`], [`MemSide`]): each RT unit's request register and
    /// each L1D's outputs for this cycle and the next; `latched` says this cycle's hold the
    /// registers (the last cycle was of the split form).
    offers: Vec<Option<MemReq>>,
    offers_next: Vec<Option<MemReq>>,
    l1d_out: Vec<L1dOut>,
    l1d_out_next: Vec<L1dOut>,
    latched: bool,
    /// The normal run steps the RT units and the memory system on two threads
    /// ([`Gpu::with_helper_thread`]).
    helper_thread: bool,
    /// The normal run goes by windows ([`Gpu::with_windows`]).
    windows: bool,
}

/// Deliberately order-dependent runners, to show the [`EvalCheck`] runs catch such bugs. Test
/// builds only.
#[cfg(feature = "mutants")]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OrderBug {
    /// The dispatcher hands this cycle's jobs to the free RT units in the order they are
    /// evaluated, instead of round-robin by index: one unit's job depends on when its siblings
    /// were visited.
    DispatchInEvalOrder,
    /// An RT unit's step is not cleared between evaluations: a second evaluation in the same
    /// cycle counts the visits again.
    StaleStep,
    /// The wake-up skip lets a unit sleep through a memory response.
    SleepThroughResponses,
    /// The SM-by-SM loop of the normal run hands SM s the memory outputs of SM s + 1 (a wiring
    /// slip; the phase-by-phase loop is wired right).
    SmPortsCrossed,
    /// The SM-by-SM loop's whole-SM skip takes an RT unit's event as due one cycle after it is,
    /// so a unit otherwise quiet acts a cycle late.
    SkipLate,
    /// The SM-by-SM loop passes on an L1D's down request from before its clock edge instead of
    /// after it ([`SmPorts::commit`]), so the next cycle's L2 sees the old one.
    StaleDown,
    /// In the split form ([`Gpu::with_helper_thread`]) the run loop drops the helper thread's
    /// error.
    HelperErrorLost,
    /// In the split form the L1Ds' latched outputs are not renewed: the RT units see their
    /// L1Ds' outputs of the first cycle of the split form again and again.
    StaleLatch,
    /// The windowed run lets an SM whose miss queue may be full run on, its queue's length
    /// taken from a bound that still counts requests already granted.
    WindowIgnoresFullQueue,
    /// The windowed run lets an SM with a free warp slot run on instead of stopping for the
    /// dispatch, so its job lands when the dispatcher reaches its cycle, late.
    WindowSkipsJobStop,
    /// The windowed run's L2 back end runs further ahead of the front end than the bank pipelines'
    /// delay: it checks a bank's head before the request that the front end lets in later would
    /// have been there.
    WindowBackEndTooFar,
    /// The windowed run's SMs drop the L2's responses: their rays wait for ever, and the run
    /// must end as stalled rather than go on.
    WindowLosesResponses,
}

#[cfg(feature = "mutants")]
impl OrderBug {
    /// A slip of the windowed run (the others are of the cycle-by-cycle loops, which then run).
    fn in_windows(self) -> bool {
        matches!(
            self,
            OrderBug::WindowIgnoresFullQueue
                | OrderBug::WindowSkipsJobStop
                | OrderBug::WindowBackEndTooFar
                | OrderBug::WindowLosesResponses
        )
    }
}

/// An RT unit's registers the run loop reads between cycles, gathered after its clock edge by
/// whichever thread stepped it (so that the loop reads one small array, not every unit's state,
/// which may be in another core's cache).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct RtStatus {
    /// [`RtUnit::next_event`].
    next_event: Option<u64>,
    /// [`RtUnit::free_slot`] is some.
    free_slot: bool,
    /// [`RtUnit::empty`].
    empty: bool,
}

impl RtStatus {
    fn of(u: &RtUnit) -> RtStatus {
        RtStatus { next_event: u.next_event(), free_slot: u.free_slot().is_some(), empty: u.empty() }
    }
}

/// What an RT unit sees of its L1D in a cycle of the split form: the L1D's register outputs
/// `ready` and `resp` as they were when the cycle began (the memory side's thread writes the
/// next cycle's while the RT side reads these).
#[derive(Clone, Debug, Default)]
struct L1dOut {
    ready: bool,
    resp: Vec<MemResp>,
}

impl L1dOut {
    /// Copies `l1`'s outputs (the responses only if either side has any: most cycles none).
    fn latch(&mut self, l1: &L1d) {
        self.ready = l1.ready();
        if !self.resp.is_empty() || !l1.resp().is_empty() {
            self.resp.clear();
            self.resp.extend_from_slice(l1.resp());
        }
    }
}

/// The RT units' side of a cycle in the split form ([`Gpu::with_helper_thread`]): every RT unit,
/// on the helper thread, while the calling thread runs the memory system ([`MemSide`]). The two
/// meet only in registers: an RT unit reads its L1D's `ready` and `resp`, the L1D reads the RT
/// unit's request. Each side reads the other's as latched when the cycle began and latches its
/// own for the next cycle.
struct RtSide<'a> {
    /// The first unit's SM (the units are SMs `first..first + units.len()`).
    first: usize,
    units: &'a mut [RtUnit],
    steps: &'a mut [RtStep],
    jobs_in: &'a mut [Option<WarpJob>],
    status: &'a mut [RtStatus],
    /// Each L1D's outputs when the cycle began.
    l1d_out: &'a [L1dOut],
    /// Each RT unit's request register when the cycle began (offered if its L1D is ready).
    offers: &'a [Option<MemReq>],
    /// Each RT unit's request register after its clock edge: the next cycle's `offers`.
    offers_next: &'a mut [Option<MemReq>],
}

impl<'a> RtSide<'a> {
    /// The units below SM `first + k` and the rest.
    fn split_at(self, k: usize) -> (RtSide<'a>, RtSide<'a>) {
        let (ua, ub) = self.units.split_at_mut(k);
        let (sa, sb) = self.steps.split_at_mut(k);
        let (ja, jb) = self.jobs_in.split_at_mut(k);
        let (ta, tb) = self.status.split_at_mut(k);
        let (oa, ob) = self.offers_next.split_at_mut(k);
        let (l1d_out, offers) = (self.l1d_out, self.offers);
        let a = RtSide {
            first: self.first,
            units: ua,
            steps: sa,
            jobs_in: ja,
            status: ta,
            l1d_out,
            offers,
            offers_next: oa,
        };
        let b = RtSide {
            first: self.first + k,
            units: ub,
            steps: sb,
            jobs_in: jb,
            status: tb,
            l1d_out,
            offers,
            offers_next: ob,
        };
        (a, b)
    }

    /// Every RT unit's cycle, as the SM-by-SM loop's: the same inputs, so the same steps. Stops
    /// at the first unit whose checks fail (the lowest SM's error, as on one thread).
    fn step(self, ctx: &GroupCtx) -> Result<(), RunError> {
        let now = ctx.now;
        // The L1Ds' outputs were written on the other core: read them all before the first unit's
        // work, so that their cache misses overlap rather than each waiting for a unit's work.
        let mine = &self.l1d_out[self.first..self.first + self.units.len()];
        std::hint::black_box(mine.iter().fold(0, |a, o| a + usize::from(o.ready) + o.resp.len()));
        for (k, u) in self.units.iter_mut().enumerate() {
            let sm = self.first + k;
            let out = &self.l1d_out[sm];
            let req_ready = out.ready;
            // `RtUnit::req`: the request register, offered when the L1D is ready (which takes
            // it: an L1D's `req_fire` is its `ready` with a request offered).
            let req = if req_ready { self.offers[sm] } else { None };
            let rt_idle = idle(u, req, &self.jobs_in[k], now);
            let i = RtIn { now, req_ready, req_fire: req_ready && req.is_some(), resp: &out.resp };
            if rt_cycle(u, &mut self.steps[k], &mut self.jobs_in[k], rt_idle, &i, ctx.deaf)? {
                self.offers_next[k] = u.req(true);
                self.status[k] = RtStatus::of(u);
            } else {
                // Not stepped: its registers, so its request and status, are as they were.
                self.offers_next[k] = self.offers[sm];
            }
        }
        Ok(())
    }
}

/// The memory system's side of a cycle in the split form, on the calling thread: the L2 and
/// DRAM, then every L1D on its RT unit's request as latched when the cycle began, and the clock
/// edges.
struct MemSide<'a> {
    mem: &'a mut MemSystem,
    offers: &'a [Option<MemReq>],
    l1d_next: &'a mut [Option<u64>],
    /// Each L1D's outputs after its clock edge: the next cycle's [`RtSide::l1d_out`].
    l1d_out_next: &'a mut [L1dOut],
}

impl MemSide<'_> {
    fn step(self) {
        // The RT units' requests were written on the other core: read them all first (as the RT
        // side does with the L1Ds' outputs).
        std::hint::black_box(self.offers.iter().filter(|o| o.is_some()).count());
        self.mem.eval_shared();
        let mut ports = self.mem.sm_ports();
        for sm in ports.range() {
            let req = if ports.ready(sm) { self.offers[sm] } else { None };
            // No request, no fill and no event: only the clock moves (the quiet step would change
            // nothing else).
            if req.is_some() || !ports.skip_quiet(sm) {
                ports.eval(sm, req);
                ports.commit(sm);
            }
            let l1 = ports.l1d(sm);
            self.l1d_next[sm] = l1.next_event();
            self.l1d_out_next[sm].latch(l1);
        }
        self.mem.commit_shared();
    }
}

/// The RT unit offers no request (`req`), gets no job (`job`) and has no event due: it acts only
/// on a memory response.
#[inline]
fn idle(u: &RtUnit, req: Option<MemReq>, job: &Option<WarpJob>, now: u64) -> bool {
    req.is_none() && job.is_none() && u.next_event().is_none_or(|e| e > now)
}

/// One RT unit's cycle, in the SM-by-SM loop or the split form: evaluated on `i` and committed
/// with the job landing (`job`), unless it is idle and shows no response (`deaf`: a planted bug
/// that ignores them), when its step would change nothing. Returns whether it was stepped.
#[inline]
fn rt_cycle(
    u: &mut RtUnit,
    step: &mut RtStep,
    job: &mut Option<WarpJob>,
    rt_idle: bool,
    i: &RtIn,
    deaf: bool,
) -> Result<bool, RunError> {
    if rt_idle && (i.resp.is_empty() || deaf) {
        return Ok(false);
    }
    u.eval(i, step)?;
    u.commit(step, job.take());
    Ok(true)
}

/// What every SM's cycle reads alike.
#[derive(Clone, Copy)]
struct GroupCtx {
    now: u64,
    /// [`OrderBug::SleepThroughResponses`].
    deaf: bool,
    #[cfg(feature = "mutants")]
    order_bug: Option<OrderBug>,
}

/// The SMs, lent out for one cycle of the SM-by-SM loop: their RT units with their steps and
/// incoming jobs, and their L1Ds.
struct SmLoop<'a> {
    units: &'a mut [RtUnit],
    status: &'a mut [RtStatus],
    l1d_next: &'a mut [Option<u64>],
    steps: &'a mut [RtStep],
    jobs_in: &'a mut [Option<WarpJob>],
    ports: SmPorts<'a>,
}

impl SmLoop<'_> {
    /// One cycle of each SM in turn: its request, its L1D, its RT unit, and the clock edges of
    /// both. Stops at the first SM whose checks fail.
    fn step(mut self, ctx: &GroupCtx) -> Result<(), RunError> {
        let now = ctx.now;
        for (sm, u) in self.units.iter_mut().enumerate() {
            let req_ready = self.ports.ready(sm);
            let req = u.req(req_ready);
            let rt_idle = idle(u, req, &self.jobs_in[sm], now);
            // An SM with nothing to do (that, and an L1D with no fill and no event) only lets
            // its L1D's clock move: its evaluation would show no response and change nothing.
            #[cfg(feature = "mutants")]
            let skippable = if ctx.order_bug == Some(OrderBug::SkipLate) {
                req.is_none() && self.jobs_in[sm].is_none() && u.next_event().is_none_or(|e| e + 1 > now)
            } else {
                rt_idle
            };
            #[cfg(not(feature = "mutants"))]
            let skippable = rt_idle;
            if skippable && self.ports.skip_quiet(sm) {
                self.l1d_next[sm] = self.ports.l1d(sm).next_event();
                continue;
            }
            self.ports.eval(sm, req);
            #[cfg(feature = "mutants")]
            let port = if ctx.order_bug == Some(OrderBug::SmPortsCrossed) {
                (sm + 1) % self.ports.range().len()
            } else {
                sm
            };
            #[cfg(not(feature = "mutants"))]
            let port = sm;
            let (ready, resp) = self.ports.sm_in(port, req.is_some());
            let i = RtIn { now, req_ready, req_fire: ready && req.is_some(), resp };
            // Not stepped: its registers, so its status, are as they were.
            if rt_cycle(u, &mut self.steps[sm], &mut self.jobs_in[sm], rt_idle, &i, ctx.deaf)? {
                self.status[sm] = RtStatus::of(u);
            }
            #[cfg(feature = "mutants")]
            if ctx.order_bug == Some(OrderBug::StaleDown) {
                self.ports.commit_stale_down(sm);
            } else {
                self.ports.commit(sm);
            }
            #[cfg(not(feature = "mutants"))]
            self.ports.commit(sm);
            self.l1d_next[sm] = self.ports.l1d(sm).next_event();
        }
        Ok(())
    }
}

impl Gpu {
    /// `mem.sms` SMs with stack configuration `cfg`.
    pub fn new(cfg: Config, rt: RtParams, mem: MemParams) -> Result<Gpu, ConfigError> {
        let sys = MemSystem::new(mem)?;
        let mut units = (0..mem.sms)
            .map(|sm| RtUnit::new(sm, cfg, rt, mem.sector_bytes))
            .collect::<Result<Vec<_>, _>>()?;
        for u in &mut units {
            u.stack_unit.manager.set_local_layout(mem.local_layout, mem.sms);
        }
        let n = units.len();
        Ok(Gpu {
            cfg,
            rt,
            units,
            mem: sys,
            rr: 0,
            eval_check: EvalCheck::Dataflow,
            #[cfg(feature = "mutants")]
            order_bug: None,
            reqs: vec![None; n],
            req_ready: vec![false; n],
            jobs_in: vec![None; n],
            steps: vec![RtStep::default(); n],
            quiet: vec![false; n],
            order: Vec::with_capacity(n),
            helper_thread: false,
            status: Vec::new(),
            l1d_next: vec![None; n],
            offers: vec![None; n],
            offers_next: vec![None; n],
            l1d_out: vec![L1dOut::default(); n],
            l1d_out_next: vec![L1dOut::default(); n],
            latched: false,
            windows: true,
        })
    }

    /// SPEC 7 defaults: 8 SMs, the L1D is 64 KB less the SH stacks' shared memory.
    pub fn paper(cfg: Config) -> Result<Gpu, ConfigError> {
        Gpu::new(cfg, RtParams::default(), carve_out(&cfg, MemParams::default()))
    }

    /// Every stack manager gets a deliberately broken variant (test builds).
    #[cfg(feature = "mutants")]
    pub fn with_mutant(mut self, m: crate::stack_manager::Mutant) -> Self {
        for u in &mut self.units {
            u.stack_unit.manager.mutant = Some(m);
        }
        self
    }

    /// Evaluate the RT units, and within the memory system the L1Ds and DRAM, in the order, and
    /// as many times per cycle, that `check` says (the report must not change: tests compare it
    /// with the [`EvalCheck::Dataflow`] run's).
    pub fn with_eval_check(mut self, check: EvalCheck) -> Self {
        self.eval_check = check;
        self.order.clear();
        self.mem.set_eval_check(check);
        self
    }

    /// Runs the normal run on two threads (by windows, each thread running its share of the SMs;
    /// without windows, the split form of the module documentation): the same results as one
    /// thread, in less wall time when a second core is free.
    pub fn with_helper_thread(mut self, on: bool) -> Self {
        self.helper_thread = on && self.units.len() >= 2;
        self
    }

    /// In the split form with `units` RT units, how many the calling thread steps beside the
    /// memory system (SMs `0..n`); the helper steps the rest. The memory side costs less than the RT units (stop 19,
    /// bench: 460 M against 615 M cycles of the host's clock over a run), so with one of eight
    /// units here the two sides about balanced; with the build optimised across crates (stop
    /// 21), two of eight ran 2–3 % faster (paired medians, 14 of 20 alternations faster; three:
    /// no gain; stop 22, with lighter tracing: one, two and three alike).
    pub fn units_on_calling_thread(units: usize) -> usize {
        units / 4
    }

    /// Runs the normal run (no waveform, [`EvalCheck::Dataflow`], idle cycles skipped) by
    /// windows of cycles, each SM on its own between meetings at the L2 (the module `window`:
    /// the same report as cycle by cycle); on by default, off for the cycle-by-cycle loop.
    pub fn with_windows(mut self, on: bool) -> Self {
        self.windows = on;
        self
    }

    /// A deliberately order-dependent runner (test builds).
    #[cfg(feature = "mutants")]
    pub fn with_order_bug(mut self, bug: OrderBug) -> Self {
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
        if self.helper_thread {
            lockstep::with_helper(|h| self.run_loop(Some(h), jobs, sink, every, progress, residence))
        } else {
            self.run_loop(None, jobs, sink, every, progress, residence)
        }
    }

    /// [`Gpu::run_timed`], with the helper thread that steps the RT units, if any.
    fn run_loop<S: Sink>(
        mut self,
        helper: Option<&Helper>,
        jobs: impl IntoIterator<Item = WarpJob>,
        sink: &mut S,
        every: u64,
        mut progress: impl FnMut(Progress),
        residence: &mut Vec<u64>,
    ) -> Result<GpuReport, RunError> {
        #[cfg(feature = "mutants")]
        let plain = self.order_bug.is_none_or(OrderBug::in_windows);
        #[cfg(not(feature = "mutants"))]
        let plain = true;
        let delay = u64::from(self.mem.params().l2_latency - 3);
        if let Some(w) = window::window_for(delay).filter(|_| {
            self.windows
                && plain
                && self.eval_check == EvalCheck::Dataflow
                && self.rt.idle_skip
                && self.units.len() <= 64
                && sink.next_wanted(0).is_none()
        }) {
            let report = window::run(&mut self, helper, jobs, w, every, progress, residence)?;
            sink.end_run(report.cycles);
            return Ok(report);
        }
        self.refresh_status();
        // Job index of each SM's loads, in load order.
        let mut loaded: Vec<Vec<u64>> = vec![Vec::new(); self.units.len()];
        let mut last_dispatch = 0;
        let mut jobs = jobs.into_iter().peekable();
        let n = self.units.len();
        let mut dispatched = 0u64;
        let mut next_report = every;
        let mut evaluated = 0;
        // Some warp slot is free (the registers after the last edge; all are before the first).
        let mut slot_free = true;
        loop {
            let now = self.mem.cycle();
            self.eval_check.order(now, n, &mut self.order);
            // Dispatch (reads the slots' registers); nothing to look at while every slot is full.
            let start = self.rr;
            for k in 0..if slot_free { n } else { 0 } {
                #[cfg(feature = "mutants")]
                let sm = if self.order_bug == Some(OrderBug::DispatchInEvalOrder) {
                    self.order[k]
                } else {
                    (start + k) % n
                };
                #[cfg(not(feature = "mutants"))]
                let sm = (start + k) % n;
                if !self.status[sm].free_slot {
                    continue;
                }
                let Some(job) = jobs.next() else { break };
                job.validate(self.cfg.warp_size)
                    .map_err(|reason| RunError::BadJob { job: dispatched, reason })?;
                self.jobs_in[sm] = Some(job);
                loaded[sm].push(dispatched);
                dispatched += 1;
                last_dispatch = now;
                self.rr = (sm + 1) % n;
            }
            let more_jobs = jobs.peek().is_some();
            if !more_jobs && self.jobs_in.iter().all(Option::is_none) && self.status.iter().all(|s| s.empty) {
                break;
            }
            #[cfg(not(feature = "untraced"))]
            let shown = sink.next_wanted(now) == Some(now);
            #[cfg(feature = "untraced")]
            let shown = false;
            #[cfg(feature = "mutants")]
            let deaf = self.order_bug == Some(OrderBug::SleepThroughResponses);
            #[cfg(not(feature = "mutants"))]
            let deaf = false;
            // A unit with no event due, no response, no job landing and no request offered would
            // evaluate to a step that changes nothing: it is not evaluated (wake-up instead of a
            // scan). A cycle the sink shows evaluates every unit, for its combinational signals.
            if self.eval_check == EvalCheck::Dataflow && !shown {
                // The same cycle, SM by SM: each SM's request, L1D, RT unit and their clock edges
                // before the next SM's, so one SM's state is read and written while it is in the
                // cache (the L2 and DRAM evaluate first: their inputs are registers; they commit
                // last). No SM reads another's registers or step, so the results are those of
                // the phase-by-phase form below (which the other evaluation orders use; tests
                // compare their reports).
                evaluated += 1;
                let ctx = GroupCtx {
                    now,
                    deaf,
                    #[cfg(feature = "mutants")]
                    order_bug: self.order_bug,
                };
                if let Some(h) = helper {
                    // The split form: the RT units on the helper thread, the memory system here.
                    if !self.latched {
                        for (sm, u) in self.units.iter().enumerate() {
                            self.offers[sm] = u.req(true);
                            self.l1d_out[sm].latch(self.mem.l1d(sm));
                        }
                    }
                    let rt = RtSide {
                        first: 0,
                        units: &mut self.units,
                        steps: &mut self.steps,
                        jobs_in: &mut self.jobs_in,
                        status: &mut self.status,
                        l1d_out: &self.l1d_out,
                        offers: &self.offers,
                        offers_next: &mut self.offers_next,
                    };
                    let mem = MemSide {
                        mem: &mut self.mem,
                        offers: &self.offers,
                        l1d_next: &mut self.l1d_next,
                        l1d_out_next: &mut self.l1d_out_next,
                    };
                    // This thread also steps the first RT units.
                    let (rt_here, rt_there) = rt.split_at(Gpu::units_on_calling_thread(n));
                    // The helper gets its own copy of the context: one line fewer to fetch from
                    // this core before it can start.
                    let ctx_there = ctx;
                    let (ra, rb) = h.join(
                        || {
                            mem.step();
                            rt_here.step(&ctx)
                        },
                        move || rt_there.step(&ctx_there),
                    );
                    #[cfg(feature = "mutants")]
                    let rb = if self.order_bug == Some(OrderBug::HelperErrorLost) { Ok(()) } else { rb };
                    ra?;
                    rb?;
                    std::mem::swap(&mut self.offers, &mut self.offers_next);
                    #[cfg(feature = "mutants")]
                    let stale = self.order_bug == Some(OrderBug::StaleLatch);
                    #[cfg(not(feature = "mutants"))]
                    let stale = false;
                    if !stale {
                        std::mem::swap(&mut self.l1d_out, &mut self.l1d_out_next);
                    }
                    self.latched = true;
                } else {
                    self.mem.eval_shared();
                    let group = SmLoop {
                        units: &mut self.units,
                        status: &mut self.status,
                        l1d_next: &mut self.l1d_next,
                        steps: &mut self.steps,
                        jobs_in: &mut self.jobs_in,
                        ports: self.mem.sm_ports(),
                    };
                    group.step(&ctx)?;
                    self.mem.commit_shared();
                    self.latched = false;
                }
            } else {
                // Phase by phase: the RT units' requests come from their registers and the L1Ds'
                // ready registers; the memory system evaluates on them; the RT units (siblings:
                // none reads another) evaluate on its outputs, in the order `eval_check` says;
                // then every unit commits at the clock edge.
                for (sm, u) in self.units.iter().enumerate() {
                    self.req_ready[sm] = self.mem.ready(sm);
                    self.reqs[sm] = u.req(self.req_ready[sm]);
                }
                let out = self.mem.eval(&self.reqs);
                evaluated += 1;
                let mut first_error: Option<(usize, RunError)> = None;
                for (sm, u) in self.units.iter().enumerate() {
                    self.quiet[sm] = !shown
                        && self.eval_check.skips_quiet_units()
                        && u.next_event().is_none_or(|e| e > now)
                        && (out[sm].resp.is_empty() || deaf)
                        && self.jobs_in[sm].is_none()
                        && self.reqs[sm].is_none();
                }
                for &sm in &self.order {
                    if self.quiet[sm] {
                        continue;
                    }
                    let i = RtIn {
                        now,
                        req_ready: self.req_ready[sm],
                        req_fire: out[sm].ready && self.reqs[sm].is_some(),
                        resp: &out[sm].resp,
                    };
                    for _pass in 0..self.eval_check.passes() {
                        #[cfg(feature = "mutants")]
                        let earlier = (self.order_bug == Some(OrderBug::StaleStep) && _pass > 0)
                            .then(|| self.steps[sm].visits());
                        if let Err(e) = self.units[sm].eval(&i, &mut self.steps[sm]) {
                            // The lowest SM's error, whatever the evaluation order.
                            if first_error.as_ref().is_none_or(|f| sm < f.0) {
                                first_error = Some((sm, e));
                            }
                        }
                        #[cfg(feature = "mutants")]
                        if let Some(v) = earlier {
                            self.steps[sm].count_visits_again(v);
                        }
                    }
                }
                if let Some((_, e)) = first_error {
                    return Err(e);
                }
                for &sm in &self.order {
                    if !self.quiet[sm] {
                        self.units[sm].commit(&self.steps[sm], self.jobs_in[sm].take());
                    }
                }
                #[cfg(not(feature = "untraced"))]
                if shown {
                    sink.begin_cycle(now);
                    self.probe(sink);
                }
                self.mem.commit();
                self.refresh_status();
                self.latched = false;
            }
            slot_free = self.status.iter().any(|s| s.free_slot);
            let dispatch_next = more_jobs && slot_free;
            // The next cycle is the earliest possible: the memory system's events need not be
            // looked at (they are never before the cycle it is in now).
            let soon = self.mem.cycle();
            let units_next = self.status.iter().filter_map(|s| s.next_event).min();
            let next = if dispatch_next || units_next == Some(soon) {
                Some(soon)
            } else {
                let l1d_next = self.l1d_next.iter().filter_map(|&e| e);
                units_next.into_iter().chain(l1d_next).chain(self.mem.shared_next_event()).min()
            };
            match next {
                None if more_jobs || !self.status.iter().all(|s| s.empty) => {
                    return Err(RunError::Stalled { cycle: now });
                }
                Some(at) if self.rt.idle_skip && at > self.mem.cycle() => {
                    // Never skip a cycle the sink wants to see.
                    #[cfg(not(feature = "untraced"))]
                    let at = sink.next_wanted(self.mem.cycle()).map_or(at, |w| w.min(at));
                    if at > self.mem.cycle() {
                        self.mem.skip_to(at)
                    }
                }
                _ => {}
            }
            if self.mem.cycle() >= next_report {
                progress(Progress { cycle: self.mem.cycle(), warps_dispatched: dispatched });
                next_report = self.mem.cycle().saturating_add(every);
            }
        }
        sink.end_run(self.mem.cycle());
        residence.clear();
        residence.resize(dispatched as usize, 0);
        for (u, jobs) in self.units.iter().zip(&loaded) {
            for (&job, &cycles) in jobs.iter().zip(&u.residence) {
                residence[job as usize] = cycles;
            }
        }
        Ok(GpuReport { evaluated_cycles: evaluated, last_dispatch, ..self.report() })
    }

    /// Every SM's [`RtStatus`] and its L1D's next event from their registers.
    fn refresh_status(&mut self) {
        self.status.clear();
        self.status.extend(self.units.iter().map(RtStatus::of));
        for (sm, e) in self.l1d_next.iter_mut().enumerate() {
            *e = self.mem.l1d(sm).next_event();
        }
    }

    fn report(&self) -> GpuReport {
        let dram = self.mem.dram().counters();
        // Every L2 access is a request an SM's L1D sent down (the L2 serves nothing else).
        let l2 = self.mem.l2().counters();
        let mut stack = StackStats::default();
        for u in &self.units {
            stack.add(&u.stack_unit.manager.stats);
        }
        let sum = |f: fn(&RtUnit) -> u64| self.units.iter().map(f).sum::<u64>();
        GpuReport {
            cycles: self.mem.cycle(),
            evaluated_cycles: 0,
            warps: sum(|u| u.stats.warps),
            rays: sum(|u| u.stats.rays),
            visits: sum(|u| u.stats.visits),
            node_fetches: sum(|u| u.fetch.requests),
            dram_node: dram.kind(ReqKind::NodeFetch).accesses,
            dram_stack: dram.kind(ReqKind::StackSpill).accesses + dram.kind(ReqKind::StackReload).accesses,
            l2_node: l2.kind(ReqKind::NodeFetch).accesses,
            l2_stack: l2.kind(ReqKind::StackSpill).accesses + l2.kind(ReqKind::StackReload).accesses,
            l1d_hit_rate: hit_rate(&self.mem.l1d_counters()),
            l2_hit_rate: hit_rate(self.mem.l2().counters()),
            stack,
            bank_conflict_cycles: sum(|u| u.stack_unit.arb.conflict_cycles),
            pops_checked: sum(|u| u.stats.pops_checked),
            last_dispatch: 0,
        }
    }
}

impl Probe for Gpu {
    fn probe<S: Sink>(&self, s: &mut S) {
        if !s.enabled() {
            return;
        }
        for (sm, (u, d)) in self.units.iter().zip(&self.steps).enumerate() {
            s.push_scope(&format!("sm{sm}"));
            u.probe(d, s);
            s.pop_scope();
        }
        s.push_scope("mem");
        self.mem.probe(s);
        s.pop_scope();
    }
}
