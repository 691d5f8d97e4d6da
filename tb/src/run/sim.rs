//! One simulation of a workload under one stack configuration, at a chosen fidelity, optionally
//! on a sample of its warps: the engine behind `sms run`, `sms sweep` and `sms bench`.
//!
//! ```text
//!   Workload (scene, BVH, rays) ──► pixel warps, traced on demand, one at a time
//!        │                                   │
//!        │ Fidelity::Functional              │ Fidelity::Cycle
//!        ▼                                   ▼
//!   one stack manager, micro-ops       rtl_job(): trace ops → RayOps (node bytes by BVH layout)
//!   at once, pops checked              Gpu: 8 SMs × RT unit, L1D/L2/DRAM, pops checked
//!        └──────────────► Outcome { stack counts, GPU report? } ◄──────┘
//!                              │ with a SamplePlan: one Outcome per batch (functional), or one
//!                              ▼ launch of the whole sample shared out by residence (cycle)
//!                        Estimate of each additive metric, 95 % interval
//! ```
//!
//! The GPU is fed job by job in launch order; each traceRay call of a pixel warp (sample ×
//! bounce) is one warp job. Simplification: a warp's next bounce does not wait for its previous
//! one (the shader between traceRay calls is not modelled), so jobs of one pixel warp may run on
//! several SMs at once.

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use rtl::config::{Config, Overflow};
use rtl::gpu::{Gpu, GpuReport, Progress};
use rtl::ray_op::{self, RayOp, Walks};
use rtl::stack_manager::StackStats;
use rtl::thread_cycles::ThreadCycles;
use rtl::trace::{NullSink, Sink};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::run::sampling::{choose, estimate, Estimate, SamplePlan};
use crate::run::walked::TreeWalks;
use crate::workload::bvh::{node_bytes, BvhKind};
use crate::workload::geometry::Ray;
use crate::workload::restart::{default_levels, RestartTree};
use crate::workload::trace::{rtl_kind, TraceOp, WarpTraces, WARP_SIZE};
use crate::workload::Workload;

/// How much of the machine a run models.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Fidelity {
    /// Stack traffic counted per ray from the traces, no timing (fastest).
    Functional,
    /// The clocked RT units, stack managers and memory hierarchy.
    #[default]
    Cycle,
}

pub use crate::hw::Hardware;

/// A traceRay call of a warp as the RT unit's stimulus.
pub fn rtl_job(job: &WarpTraces, bvh: BvhKind) -> ray_op::WarpJob {
    let lane = |t: &crate::workload::trace::RayTrace| {
        t.ops()
            .map(|op| match op {
                TraceOp::Visit { addr, kind } => {
                    RayOp::Visit { addr, kind: rtl_kind(kind), bytes: node_bytes(bvh, kind) }
                }
                TraceOp::Push(a) => RayOp::Push(a),
                TraceOp::Pop(a) => RayOp::Pop(a),
            })
            .collect()
    };
    ray_op::WarpJob { lanes: job.lanes.iter().map(|l| l.as_ref().map(lane)).collect(), walk: None }
}

/// What one simulation (of all warps or of one batch) measured.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Outcome {
    pub fidelity: Fidelity,
    /// Pixel warps simulated.
    pub pixel_warps: u32,
    #[serde(serialize_with = "stack_counts")]
    pub stack: StackStats,
    /// Cycle level only.
    pub gpu: Option<GpuCounts>,
    pub pops_checked: u64,
    #[serde(serialize_with = "secs")]
    pub wall: Duration,
}

fn secs<S: serde::Serializer>(d: &Duration, s: S) -> std::result::Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}

/// Serialises a duration as seconds (a number), as every wall-clock field of the reports.
pub fn serialize_secs<S: serde::Serializer>(d: &Duration, s: S) -> std::result::Result<S::Ok, S::Error> {
    secs(d, s)
}

/// Serialises stack-manager counters as an object of every counter by name, in declaration order.
/// The restart designs' counters (`drops`, `restarts`) appear only when not zero: a design that
/// spills never drops, and its report reads as it did before those designs existed.
pub fn stack_counts<S: serde::Serializer>(c: &StackStats, s: S) -> std::result::Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut map = s.serialize_map(None)?;
    for (name, value) in c.fields() {
        if value == 0 && RESTART_COUNTS.contains(&name) {
            continue;
        }
        map.serialize_entry(name, &value)?;
    }
    map.end()
}

/// The counters only restart designs move.
pub const RESTART_COUNTS: [&str; 2] = ["drops", "restarts"];

/// Declares [`GpuCounts`] from one list of fields, each with its kind and the [`GpuReport`] field
/// it comes from, so the struct, its construction and its scaling are written once. A `count`
/// scales with the share of the frame simulated, a `rate` does not, and `last_dispatch` (a cycle
/// number, kept for the drain) neither.
macro_rules! gpu_counts {
    ($($(#[$doc:meta])* $kind:ident $f:ident = $($from:ident).+),+ $(,)?) => {
        /// The cycle level's GPU-wide measurements.
        #[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
        pub struct GpuCounts {
            $($(#[$doc])* pub $f: gpu_counts!(@ty $kind),)+
        }

        impl GpuCounts {
            /// Every field's name, in declaration order (the JSON's order).
            pub const NAMES: [&'static str; [$(stringify!($f)),+].len()] = [$(stringify!($f)),+];

            /// Every `count` field mapped by `f`; rates and the last dispatch cycle unchanged.
            pub fn map_counts(&self, f: impl Fn(u64) -> u64) -> GpuCounts {
                GpuCounts { $($f: gpu_counts!(@map $kind, self.$f, f)),+ }
            }

            /// Every field as a 64-bit word in declaration order, rates as their bit patterns
            /// (exact: for the result cache).
            pub fn to_words(&self) -> Vec<u64> {
                vec![$(gpu_counts!(@word $kind, self.$f)),+]
            }

            /// The inverse of [`GpuCounts::to_words`]; `None` for the wrong number of words.
            pub fn from_words(words: &[u64]) -> Option<GpuCounts> {
                let mut w = words.iter().copied();
                let g = GpuCounts { $($f: gpu_counts!(@unword $kind, w.next()?)),+ };
                w.next().is_none().then_some(g)
            }
        }

        impl From<&GpuReport> for GpuCounts {
            fn from(r: &GpuReport) -> Self {
                GpuCounts { $($f: r.$($from).+),+ }
            }
        }
    };
    (@ty count) => { u64 };
    (@ty cycle) => { u64 };
    (@ty rate) => { f64 };
    (@map count, $v:expr, $f:ident) => { $f($v) };
    (@map cycle, $v:expr, $f:ident) => { $v };
    (@map rate, $v:expr, $f:ident) => { $v };
    (@word rate, $v:expr) => { $v.to_bits() };
    (@word $kind:ident, $v:expr) => { $v };
    (@unword rate, $v:expr) => { f64::from_bits($v) };
    (@unword $kind:ident, $v:expr) => { $v };
}

gpu_counts! {
    count cycles = cycles,
    count evaluated_cycles = evaluated_cycles,
    count warp_jobs = warps,
    count rays = rays,
    count visits = visits,
    count node_fetches = node_fetches,
    count dram_node = dram_node,
    count dram_stack = dram_stack,
    /// Off-chip accesses as the paper counts them (it counts L2 as off-chip): requests leaving
    /// the SMs for L2, caused by node fetches.
    count offchip_node = l2_node,
    /// Requests leaving the SMs for L2 caused by stack spills and reloads.
    count offchip_stack = l2_stack,
    rate l1d_hit_rate = l1d_hit_rate,
    rate l2_hit_rate = l2_hit_rate,
    count bank_conflict_cycles = bank_conflict_cycles,
    /// Cycle of the last job's dispatch; the rest of the run is the drain.
    cycle last_dispatch = last_dispatch,
    /// The RT units' thread-cycles by category (`rtl::thread_cycles::ThreadCycles`): together
    /// `cycles` × SMs × warp-buffer slots × warp size. Waiting for node data (WaitMem).
    count thread_cycles_node_data = thread_cycles.node_data,
    /// Waiting to fetch and allowed to (for the scheduler or the memory port).
    count thread_cycles_fetch_queue = thread_cycles.fetch_queue,
    /// Waiting on the stack sequencer (a stack command, or a fetch it holds back).
    count thread_cycles_stack = thread_cycles.stack,
    /// In an operation unit (operation latency, BVH header).
    count thread_cycles_latency = thread_cycles.latency,
    /// Empty slot, inactive or finished lane.
    count thread_cycles_idle = thread_cycles.idle,
}

impl GpuCounts {
    /// The thread-cycle breakdown as `rtl`'s [`ThreadCycles`].
    pub fn thread_cycles(&self) -> ThreadCycles {
        ThreadCycles {
            node_data: self.thread_cycles_node_data,
            fetch_queue: self.thread_cycles_fetch_queue,
            stack: self.thread_cycles_stack,
            latency: self.thread_cycles_latency,
            idle: self.thread_cycles_idle,
        }
    }
}

/// The headline metrics every fidelity and sample reports, by name.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    /// Total GPU cycles (cycle level).
    Cycles,
    /// Stack entries moved to or from global memory.
    StackGlobal,
    /// DRAM accesses of stack traffic (cycle level).
    DramStack,
    /// DRAM accesses of node fetches (cycle level).
    DramNode,
    /// Off-chip accesses as the paper counts them: requests leaving the SMs for L2 (cycle level).
    Offchip,
    /// Of which node fetches.
    OffchipNode,
    /// Of which stack spills and reloads.
    OffchipStack,
    /// RB → SH spills.
    ShSpills,
    /// SH → global spills (SMS's SH stacks overflowing to local memory).
    ShToGlobal,
    /// Global → SH reloads.
    GlobalToSh,
    Borrows,
    Flushes,
    /// Shared-memory bank-conflict delay cycles (cycle level).
    ConflictCycles,
}

impl Metric {
    pub const ALL: [Metric; 13] = [
        Metric::Cycles,
        Metric::StackGlobal,
        Metric::DramStack,
        Metric::DramNode,
        Metric::Offchip,
        Metric::OffchipNode,
        Metric::OffchipStack,
        Metric::ShSpills,
        Metric::ShToGlobal,
        Metric::GlobalToSh,
        Metric::Borrows,
        Metric::Flushes,
        Metric::ConflictCycles,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Metric::Cycles => "cycles",
            Metric::StackGlobal => "stack_global",
            Metric::DramStack => "dram_stack",
            Metric::DramNode => "dram_node",
            Metric::Offchip => "offchip",
            Metric::OffchipNode => "offchip_node",
            Metric::OffchipStack => "offchip_stack",
            Metric::ShSpills => "sh_spills",
            Metric::ShToGlobal => "sh_to_global",
            Metric::GlobalToSh => "global_to_sh",
            Metric::Borrows => "borrows",
            Metric::Flushes => "flushes",
            Metric::ConflictCycles => "conflict_cycles",
        }
    }

    /// The metric's value in `o`, if `o`'s fidelity measures it.
    pub fn of(self, o: &Outcome) -> Option<f64> {
        let g = o.gpu.as_ref();
        Some(match self {
            Metric::Cycles => g?.cycles as f64,
            Metric::StackGlobal => o.stack.global_accesses() as f64,
            Metric::DramStack => g?.dram_stack as f64,
            Metric::DramNode => g?.dram_node as f64,
            Metric::Offchip => (g?.offchip_node + g?.offchip_stack) as f64,
            Metric::OffchipNode => g?.offchip_node as f64,
            Metric::OffchipStack => g?.offchip_stack as f64,
            Metric::ShSpills => o.stack.rb_to_sh as f64,
            Metric::ShToGlobal => o.stack.sh_to_global as f64,
            Metric::GlobalToSh => o.stack.global_to_sh as f64,
            Metric::Borrows => o.stack.borrows as f64,
            Metric::Flushes => o.stack.flushes as f64,
            Metric::ConflictCycles => g?.bank_conflict_cycles as f64,
        })
    }
}

/// Everything a run needs besides the workload.
#[derive(Clone, Copy, Debug)]
pub struct RunSpec {
    pub config: Config,
    pub hw: Hardware,
    pub fidelity: Fidelity,
}

impl RunSpec {
    /// Checks what the workload side cannot vary: traces come 32 lanes to a warp.
    pub fn validate(&self) -> Result<()> {
        if self.config.warp_size as usize != WARP_SIZE {
            return Err(Error::Invalid(format!(
                "warp size {}: traces are packed {WARP_SIZE} rays to a warp",
                self.config.warp_size
            )));
        }
        let shared = rtl::gpu::shared_bytes(&self.config);
        if shared >= self.hw.mem.l1d_bytes {
            return Err(Error::Invalid(format!(
                "{}: the SH stacks need {} KB of shared memory, the unified L1D/shared array has only {} KB",
                self.config.name(),
                f64::from(shared) / 1024.0,
                f64::from(self.hw.mem.l1d_bytes) / 1024.0
            )));
        }
        if self.config.overflow == Overflow::Drop && self.fidelity == Fidelity::Functional {
            return Err(Error::Invalid(format!(
                "{}: a restart design's walk follows what its stack drops, which the functional level \
                 does not model; use --fidelity cycle (or `sms steps` for traversal steps alone)",
                self.config.name()
            )));
        }
        Ok(())
    }
}

/// Progress of a long run, as the callback sees it.
#[derive(Clone, Copy, Debug)]
pub struct Tick {
    pub pixel_warps_done: u32,
    pub pixel_warps: u32,
    /// GPU cycle reached (cycle level).
    pub cycle: u64,
}

/// Simulates the pixel warps `warps` (all when `None`) of `w`. The sink sees every cycle of a
/// cycle-level run; `progress` is called now and then.
pub fn simulate<S: Sink>(
    spec: &RunSpec,
    w: &Workload,
    warps: Option<&[u32]>,
    sink: &mut S,
    progress: impl FnMut(Tick),
) -> Result<Outcome> {
    simulate_inner(spec, w, warps, sink, progress, &mut Vec::new())
}

/// As [`simulate`]; at the cycle level also fills `residence` with the cycles each pixel warp's
/// jobs spent in warp buffers (summed over its jobs, in the order of `warps`).
fn simulate_inner<S: Sink>(
    spec: &RunSpec,
    w: &Workload,
    warps: Option<&[u32]>,
    sink: &mut S,
    progress: impl FnMut(Tick),
    residence: &mut Vec<u64>,
) -> Result<Outcome> {
    spec.validate()?;
    let all: Vec<u32>;
    let warps = match warps {
        Some(ws) => ws,
        None => {
            all = (0..w.num_warps()).collect();
            &all
        }
    };
    let start = Instant::now();
    let bvh = w.opts().bvh;
    let (stack, gpu, pops_checked) = std::thread::scope(|scope| match spec.fidelity {
        Fidelity::Functional => run_functional(spec, warps.len(), traced(scope, w, warps, |t| t), progress),
        // The RT units' jobs are made where the traces are: on the tracing thread when there is
        // one, so that the conversion is not on the simulation's thread (whose helper waits
        // for it when a job is dispatched).
        Fidelity::Cycle if spec.config.overflow == Overflow::Drop => {
            run_walked(spec, w, warps, sink, progress, residence)
        }
        Fidelity::Cycle => {
            let jobs = traced(scope, w, warps, move |t| t.iter().map(|j| rtl_job(j, bvh)).collect());
            run_cycle(spec, warps.len(), jobs, None, sink, progress, residence)
        }
    })?;
    Ok(Outcome {
        fidelity: spec.fidelity,
        pixel_warps: warps.len() as u32,
        stack,
        gpu,
        pops_checked,
        wall: start.elapsed(),
    })
}

/// How many pixel warps the tracing thread may run ahead of the simulation.
const TRACE_AHEAD: usize = 16;

/// What `prepare` makes of the traces of `warps` (each pixel warp's), in order. Tracing is
/// independent of the simulation, so when a core is free for it (not inside a parallel sweep,
/// whose runs already fill the cores) a second thread traces and prepares up to [`TRACE_AHEAD`]
/// pixel warps ahead; otherwise each is traced when the simulation asks for it. The order, so
/// every result, is the same either way; only the wall time differs.
fn traced<'a, 'scope, T: Send + 'a>(
    scope: &'scope std::thread::Scope<'scope, '_>,
    w: &'a Workload<'a>,
    warps: &'a [u32],
    prepare: impl Fn(Vec<WarpTraces>) -> T + Send + 'a,
) -> Box<dyn Iterator<Item = T> + 'a>
where
    'a: 'scope,
{
    if !spare_core() || warps.len() < 2 {
        return Box::new(warps.iter().map(move |&i| prepare(w.warp(i))));
    }
    let (tx, rx) = std::sync::mpsc::sync_channel(TRACE_AHEAD);
    scope.spawn(move || {
        for &i in warps {
            // The simulation stopped early (an error): nothing more to trace.
            if tx.send(prepare(w.warp(i))).is_err() {
                break;
            }
        }
    });
    Box::new(rx.into_iter())
}

/// Whether cycle-level runs with a core to spare run part of the model on a helper thread (the
/// default; [`allow_helper_thread`]).
static HELPER_THREAD: AtomicBool = AtomicBool::new(true);

/// Lets cycle-level runs with a core to spare run part of the model on a helper thread (`true`, the
/// default) or not. The results are the same either way; this only trades a second core's time
/// for wall time (e.g. `scripts/instructions.sh` counts the one-thread loop, which valgrind
/// would otherwise run with a spinning helper).
pub fn allow_helper_thread(on: bool) {
    HELPER_THREAD.store(on, Ordering::Relaxed);
}

/// Whether a cycle-level run started here runs part of the model on a helper thread: it has a core to
/// spare and [`allow_helper_thread`] allows it.
pub fn helper_thread() -> bool {
    spare_core() && HELPER_THREAD.load(Ordering::Relaxed)
}

/// Every how many cycles cycle-level runs check the stack manager's cycle against the
/// specification's ([`crate::prove::scoreboard::SpecBoard`], [`check_decisions`]).
static DECISIONS: AtomicU64 = AtomicU64::new(crate::prove::scoreboard::SAMPLE_EVERY);

/// Has cycle-level runs check every `every`-th cycle's stack-manager decisions (the default:
/// [`crate::prove::scoreboard::SAMPLE_EVERY`]; 1: every cycle); 0 turns the scoreboard off, and a run checks data only (every pop against the
/// trace, every warp at exit).
pub fn check_decisions(every: u64) {
    DECISIONS.store(every, Ordering::Relaxed);
}

/// Every how many cycles cycle-level runs started here check decisions (0: never).
pub fn decisions_checked() -> u64 {
    DECISIONS.load(Ordering::Relaxed)
}

/// Whether a run started here has a core to spare, so that it traces on a second thread and
/// runs part of the model on another ([`Gpu::with_helper_thread`]): a second core exists and this is
/// not one of a parallel sweep's runs (a rayon worker).
pub fn spare_core() -> bool {
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    cores >= 2 && rayon::current_thread_index().is_none()
}

/// What a run measured: stack counters, the GPU's counts (cycle level), pops checked.
type Measured = (StackStats, Option<GpuCounts>, u64);

/// The functional level on the traces of `total` pixel warps, in order.
fn run_functional(
    spec: &RunSpec,
    total: usize,
    pixel_warps: impl Iterator<Item = Vec<WarpTraces>>,
    mut progress: impl FnMut(Tick),
) -> Result<Measured> {
    let (total, mut done) = (total as u32, 0u32);
    let mut last = Instant::now();
    let run = crate::run::functional::run(
        spec.config,
        pixel_warps.inspect(|_| {
            done += 1;
            if last.elapsed() > Duration::from_millis(500) {
                last = Instant::now();
                progress(Tick { pixel_warps_done: done, pixel_warps: total, cycle: 0 });
            }
        }),
    )
    .map_err(|e| functional_failure(&spec.config, e))?;
    Ok((run.total, None, run.pops_checked))
}

/// A functional run's failure as the CLI reports it: a configuration the stack manager refuses
/// is bad input; a stack property violated is the design's failure.
pub(crate) fn functional_failure(config: &Config, e: crate::run::functional::FunctionalError) -> Error {
    use crate::run::functional::FunctionalError;
    match e {
        FunctionalError::Config(_) => Error::Invalid(format!("{}: {e}", config.name())),
        FunctionalError::Violation(_) => Error::DesignCheck(format!("{}: {e}", config.name())),
    }
}

/// A cycle-level run's failure as the CLI reports it: a job the RT unit cannot take is bad
/// input; a refused stack command, a pop that disagrees with the trace, a warp leaving stack
/// state behind or a stall is the design's failure.
pub(crate) fn cycle_failure(config: &Config, e: rtl::rt_unit::RunError) -> Error {
    match e {
        rtl::rt_unit::RunError::BadJob { .. } => Error::Invalid(format!("{}: {e}", config.name())),
        _ => Error::DesignCheck(format!("{}: {e}", config.name())),
    }
}

/// The cycle level on the RT units' jobs of `total` pixel warps, in order; fills `residence`
/// with each pixel warp's cycles in warp buffers (summed over its jobs).
fn run_cycle<S: Sink>(
    spec: &RunSpec,
    total: usize,
    pixel_warps: impl Iterator<Item = Vec<ray_op::WarpJob>>,
    walks: Option<&mut dyn Walks>,
    sink: &mut S,
    mut progress: impl FnMut(Tick),
    residence: &mut Vec<u64>,
) -> Result<Measured> {
    let done = Cell::new(0u32);
    // Jobs of each pixel warp, in order: maps the GPU's per-job residence back to pixel warps.
    let jobs_per_warp = std::cell::RefCell::new(Vec::with_capacity(total));
    let jobs = pixel_warps.flat_map(|jobs| {
        done.set(done.get() + 1);
        jobs_per_warp.borrow_mut().push(jobs.len());
        jobs
    });
    let gpu = Gpu::new(spec.config, spec.hw.rt, spec.hw.stack, spec.hw.mem_for(&spec.config))
        .map_err(|e| Error::Invalid(e.to_string()))?
        .with_idle_skip(spec.hw.idle_skip)
        .with_helper_thread(helper_thread());
    let gpu = match decisions_checked() {
        0 => gpu,
        every => gpu.with_scoreboard(&|| Box::new(crate::prove::scoreboard::SpecBoard::every(every))),
    };
    let mut per_job = Vec::new();
    let total = total as u32;
    let tick =
        |p: Progress| progress(Tick { pixel_warps_done: done.get(), pixel_warps: total, cycle: p.cycle });
    let report = match walks {
        Some(walks) => gpu.run_walks(jobs, walks, sink, 100_000, tick, &mut per_job),
        None => gpu.run_timed(jobs, sink, 100_000, tick, &mut per_job),
    }
    .map_err(|e| cycle_failure(&spec.config, e))?;
    let mut next = per_job.iter();
    residence.clear();
    residence.extend(jobs_per_warp.borrow().iter().map(|&n| next.by_ref().take(n).sum::<u64>()));
    Ok((report.stack, Some(GpuCounts::from(&report)), report.pops_checked))
}

/// The cycle level for a restart design (`+RT`): every ray walks the workload's BVH as its stack
/// answers ([`crate::run::walked`]), each checked against the full-stack walk when it ends.
fn run_walked<S: Sink>(
    spec: &RunSpec,
    w: &Workload,
    warps: &[u32],
    sink: &mut S,
    progress: impl FnMut(Tick),
    residence: &mut Vec<u64>,
) -> Result<Measured> {
    let o = w.opts();
    let tree = RestartTree::new(w.bvh(), &w.scene().primitives, o.order, default_levels(o.bvh)).map_err(
        |e| match e {
            Error::Invalid(m) => Error::Invalid(format!("{}: {m}", spec.config.name())),
            e => e,
        },
    )?;
    let per_warp: Vec<Vec<Vec<Option<Ray>>>> = warps.iter().map(|&i| w.warp_rays(i)).collect();
    let counts: Vec<usize> = per_warp.iter().map(Vec::len).collect();
    let mut walks = TreeWalks::new(&tree, &w.scene().primitives, per_warp.into_iter().flatten().collect());
    let mut jobs = walks.jobs().into_iter();
    let pixel_warps: Vec<Vec<ray_op::WarpJob>> =
        counts.iter().map(|&n| jobs.by_ref().take(n).collect()).collect();
    let measured =
        run_cycle(spec, warps.len(), pixel_warps.into_iter(), Some(&mut walks), sink, progress, residence)?;
    if walks.live() != 0 || walks.counts.rays_checked != walks.rays() {
        return Err(Error::DesignCheck(format!(
            "{}: {} rays still walking at the end, {} of {} checked",
            spec.config.name(),
            walks.live(),
            walks.counts.rays_checked,
            walks.rays()
        )));
    }
    Ok(measured)
}

/// Simulates every pixel warp, without waveforms.
pub fn simulate_all(spec: &RunSpec, w: &Workload) -> Result<Outcome> {
    simulate(spec, w, None, &mut NullSink, |_| {})
}

/// A sampled run: one outcome per batch and the estimate of each metric the fidelity measures.
#[derive(Clone, Debug, Serialize)]
pub struct Sampled {
    pub fraction: f64,
    /// Functional level: one run per batch. Cycle level: each batch's share of `launch`.
    pub batches: Vec<Outcome>,
    /// Cycle level: the one launch of every sampled warp.
    pub launch: Option<Outcome>,
    pub estimates: Vec<(Metric, Estimate)>,
    #[serde(serialize_with = "secs")]
    pub wall: Duration,
}

impl Sampled {
    pub fn get(&self, m: Metric) -> Option<Estimate> {
        self.estimates.iter().find(|(k, _)| *k == m).map(|(_, e)| *e)
    }
}

/// Screen tile of pixel warp `warp`: 8 × 8-pixel-row tiles of whole warps. A warp is 32
/// consecutive pixels of a row-major image, so tiles are bands of rows split into column groups.
pub fn tile_of(width: u32, warp: u32) -> u32 {
    let first = warp * WARP_SIZE as u32;
    let (row, col) = (first / width.max(1), first % width.max(1));
    let cols = width.div_ceil(64).max(1);
    (row / 8) * cols + col / 64
}

/// Simulates the batches of `plan` and estimates each metric's workload total.
pub fn simulate_sampled(
    spec: &RunSpec,
    w: &Workload,
    plan: &SamplePlan,
    mut progress: impl FnMut(Tick),
) -> Result<Sampled> {
    plan.validate().map_err(Error::Invalid)?;
    let start = Instant::now();
    let width = w.opts().width;
    let batches = choose(w.num_warps(), plan, |warp| tile_of(width, warp));
    let total: u32 = batches.iter().map(|b| b.len() as u32).sum();
    let mut done = 0;
    let mut outcomes = Vec::with_capacity(batches.len());
    let mut launch = None;
    match spec.fidelity {
        Fidelity::Functional => {
            for b in &batches {
                let o = simulate(spec, w, Some(b), &mut NullSink, |t| {
                    let pixel_warps_done = done + t.pixel_warps_done;
                    progress(Tick { pixel_warps_done, pixel_warps: total, cycle: t.cycle })
                })?;
                done += b.len() as u32;
                outcomes.push(o);
            }
        }
        Fidelity::Cycle => {
            // One launch of the whole sample in launch order (separate launches per batch would
            // each pay a fill and a drain of the GPU), then each batch's share by residence.
            let mut order: Vec<(u32, usize)> =
                batches.iter().enumerate().flat_map(|(b, ws)| ws.iter().map(move |&w| (w, b))).collect();
            order.sort_unstable();
            let warps: Vec<u32> = order.iter().map(|o| o.0).collect();
            let mut residence = Vec::new();
            let o = simulate_inner(spec, w, Some(&warps), &mut NullSink, &mut progress, &mut residence)?;
            let all: u64 = residence.iter().sum();
            // Cycles: the dispatch phase scales with the work, the drain after the last dispatch
            // does not; each batch gets its residence share of the first and its warp share of
            // the second, so the estimate is dispatch × total/sampled + drain.
            let (cycles, dispatch) = o.gpu.map_or((0, 0), |g| (g.cycles, g.last_dispatch));
            let drain = cycles - dispatch.min(cycles);
            let n_total = f64::from(w.num_warps());
            for (b, ws) in batches.iter().enumerate() {
                let mine: u64 = order.iter().zip(&residence).filter(|(o, _)| o.1 == b).map(|(_, r)| r).sum();
                let share = if all == 0 { 1.0 / batches.len() as f64 } else { mine as f64 / all as f64 };
                let mut part = share_of(&o, share, ws.len() as u32);
                if let Some(g) = part.gpu.as_mut() {
                    let c = dispatch.min(cycles) as f64 * share + drain as f64 * ws.len() as f64 / n_total;
                    g.cycles = c.round() as u64;
                }
                outcomes.push(part);
            }
            launch = Some(o);
        }
    }
    let estimates = Metric::ALL
        .into_iter()
        .filter_map(|m| {
            let obs: Option<Vec<(f64, u32)>> =
                outcomes.iter().map(|o| Some((m.of(o)?, o.pixel_warps))).collect();
            Some((m, estimate(&obs?, w.num_warps())))
        })
        .collect();
    Ok(Sampled { fraction: plan.fraction, batches: outcomes, launch, estimates, wall: start.elapsed() })
}

/// `share` of a launch's counts, for a batch of `pixel_warps` warps (rates unchanged).
pub(crate) fn share_of(o: &Outcome, share: f64, pixel_warps: u32) -> Outcome {
    let x = |v: u64| (v as f64 * share).round() as u64;
    Outcome {
        fidelity: o.fidelity,
        pixel_warps,
        stack: o.stack.map(x),
        gpu: o.gpu.map(|g| g.map_counts(x)),
        pops_checked: x(o.pops_checked),
        wall: o.wall.mul_f64(share),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workload::trace::FetchKind;
    use crate::workload::WorkloadOpts;
    use rtl::ray_op::NodeKind as RtlKind;

    #[test]
    fn stack_counts_serialise_every_counter_by_name_in_order() {
        let s = StackStats::from_values(std::array::from_fn(|i| i as u64 + 1));
        assert_eq!((s.pushes, s.pops, s.demotions), (1, 2, 13));
        assert_eq!(StackStats::from_values(s.values()), s);
        let json = stack_counts(&s, serde_json::value::Serializer).unwrap();
        let map = json.as_object().unwrap();
        let mut names = StackStats::NAMES;
        names.sort_unstable();
        assert_eq!(map.keys().map(String::as_str).collect::<Vec<_>>(), names);
        assert_eq!(map["sh_to_global"], 5);
        assert_eq!(s.map(|v| v * 2).zip(&s, |a, b| a - b), s);
        let spilling = StackStats { drops: 0, restarts: 0, ..s };
        let json = stack_counts(&spilling, serde_json::value::Serializer).unwrap();
        let keys = json.as_object().unwrap().keys().cloned().collect::<Vec<_>>();
        assert_eq!(keys.len(), StackStats::COUNT - 2, "a design that never drops shows no drop counters");
        assert!(!keys.iter().any(|k| RESTART_COUNTS.contains(&k.as_str())));
    }

    /// A run's failed check is the design's failure, reported as such; only what the input got
    /// wrong (a configuration refused, a job the RT unit cannot take) is an invalid option.
    #[test]
    fn a_failed_design_check_is_not_worded_as_bad_input() {
        use crate::run::functional::FunctionalError;
        use crate::run::verify::invariants::{Property, Violation};
        use rtl::rt_unit::RunError;
        let cfg = Config::sms();
        let v = Violation {
            property: Property::Equivalence,
            detail: "thread 3 popped 7, the reference 9".into(),
        };
        let e = functional_failure(&cfg, FunctionalError::Violation(v)).to_string();
        assert_eq!(
            e,
            "design check failed: RB_8+SH_8+SK+RA: stack mismatch at the functional level: Equivalence violated: \
             thread 3 popped 7, the reference 9"
        );
        let refused = Config { sh_entries: 3, ..cfg }.validate().unwrap_err();
        let e = functional_failure(&cfg, FunctionalError::Config(refused)).to_string();
        assert!(e.starts_with("invalid option: RB_8+SH_8+SK+RA: "), "{e}");
        let pop = RunError::PopMismatch { cycle: 10, sm: 0, thread: 3, expected: 9, got: 7 };
        let e = cycle_failure(&cfg, pop).to_string();
        assert!(e.starts_with("design check failed: RB_8+SH_8+SK+RA: "), "{e}");
        let e = cycle_failure(&cfg, RunError::Stalled { cycle: 10 }).to_string();
        assert!(e.starts_with("design check failed: "), "{e}");
        let job = RunError::BadJob { job: 1, reason: "31 lanes".into() };
        assert!(cycle_failure(&cfg, job).to_string().starts_with("invalid option: "));
    }

    fn workload(scene: &crate::workload::scene::Scene, res: u32) -> Workload<'_> {
        Workload::new(scene, WorkloadOpts::quick(scene, res)).unwrap()
    }

    fn spec(name: &str, fidelity: Fidelity) -> RunSpec {
        RunSpec { config: name.parse().unwrap(), hw: Hardware::default(), fidelity }
    }

    #[test]
    fn node_bytes_follow_the_layouts() {
        assert_eq!(node_bytes(BvhKind::Bvh6, FetchKind::Internal), 64);
        assert_eq!(node_bytes(BvhKind::Bvh6, FetchKind::Leaf), 8);
        assert_eq!(node_bytes(BvhKind::Bvh2, FetchKind::Leaf), 48);
        assert_eq!(node_bytes(BvhKind::Cwbvh, FetchKind::Internal), 80);
        assert_eq!(node_bytes(BvhKind::Cwbvh, FetchKind::Triangle), 64);
    }

    #[test]
    fn instance_leaves_and_headers_cost_their_bytes_and_latencies() {
        let mut t = crate::workload::trace::RayTrace::default();
        use crate::workload::traverse::Recorder;
        t.visit(0x100, FetchKind::BvhHeader);
        t.visit(0x200, FetchKind::Instance);
        let mut lanes = vec![None; WARP_SIZE];
        lanes[0] = Some(t);
        let job = rtl_job(&WarpTraces { lanes }, BvhKind::Bvh6);
        let ops = job.lanes[0].as_ref().unwrap();
        assert_eq!(ops[0], RayOp::Visit { addr: 0x100, kind: RtlKind::BvhHeader, bytes: 64 });
        assert_eq!(ops[1], RayOp::Visit { addr: 0x200, kind: RtlKind::InstanceLeaf, bytes: 128 });
        let rt = rtl::rt_unit::RtParams::default();
        assert_eq!((rt.latency(RtlKind::InstanceLeaf), rt.latency(RtlKind::BvhHeader)), (8, 4));
    }

    #[test]
    fn two_level_runs_at_both_levels_with_every_pop_checked() {
        let scene = crate::load_scene("clutter").unwrap();
        for order in
            [crate::workload::traverse::ChildOrder::Nearest, crate::workload::traverse::ChildOrder::VulkanSim]
        {
            let opts = WorkloadOpts {
                accel: crate::workload::Accel::TwoLevel,
                order,
                ..WorkloadOpts::quick(&scene, 16)
            };
            let w = Workload::new(&scene, opts).unwrap();
            let f = simulate_all(&spec("RB_4+SH_4", Fidelity::Functional), &w).unwrap();
            let c = simulate_all(&spec("RB_4+SH_4", Fidelity::Cycle), &w).unwrap();
            assert_eq!(f.stack, c.stack, "{order:?}");
            assert_eq!(c.pops_checked, c.stack.pops, "{order:?}");
            assert!(c.pops_checked > 0);
        }
    }

    #[test]
    fn functional_equals_cycle_without_reallocation() {
        let scene = crate::load_scene("clutter").unwrap();
        let w = workload(&scene, 24);
        for name in ["RB_8", "RB_4+SH_4", "RB_8+SH_8+SK"] {
            let f = simulate_all(&spec(name, Fidelity::Functional), &w).unwrap();
            let c = simulate_all(&spec(name, Fidelity::Cycle), &w).unwrap();
            assert_eq!(f.stack, c.stack, "{name}");
            assert!(
                f.stack.rb_to_sh + f.stack.global_accesses() > 0,
                "{name}: clutter goes deeper than 4 + 4 entries"
            );
            assert_eq!(f.pops_checked, c.pops_checked);
            assert!(c.gpu.unwrap().cycles > 0);
        }
    }

    /// This test's thread has cores to spare (on a machine with two or more): its runs trace on a
    /// second thread and step their RT units on a helper thread. A rayon worker does neither. The
    /// outcomes are equal.
    #[test]
    fn tracing_and_stepping_on_spare_cores_change_no_result() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(spare_core(), cores >= 2);
        let scene = crate::load_scene("clutter").unwrap();
        let w = workload(&scene, 32);
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        for fidelity in [Fidelity::Cycle, Fidelity::Functional] {
            let s = spec("SMS", fidelity);
            let here = simulate_all(&s, &w).unwrap();
            let (inline, ahead_there) = one.install(|| (simulate_all(&s, &w).unwrap(), spare_core()));
            assert!(!ahead_there, "a rayon worker traces inline");
            let strip = |o: Outcome| Outcome { wall: Duration::ZERO, ..o };
            assert_eq!(strip(here), strip(inline), "{fidelity:?}");
            assert!(here.pops_checked > 0);
        }
    }

    #[test]
    fn a_share_scales_every_gpu_count_and_keeps_rates_and_the_dispatch_cycle() {
        let g = GpuCounts {
            cycles: 10,
            evaluated_cycles: 20,
            warp_jobs: 30,
            rays: 40,
            visits: 50,
            node_fetches: 60,
            dram_node: 70,
            dram_stack: 80,
            offchip_node: 90,
            offchip_stack: 100,
            l1d_hit_rate: 0.5,
            l2_hit_rate: 0.25,
            bank_conflict_cycles: 110,
            last_dispatch: 120,
            thread_cycles_node_data: 130,
            thread_cycles_fetch_queue: 140,
            thread_cycles_stack: 150,
            thread_cycles_latency: 160,
            thread_cycles_idle: 170,
        };
        let o = Outcome {
            fidelity: Fidelity::Cycle,
            pixel_warps: 8,
            stack: StackStats::default(),
            gpu: Some(g),
            pops_checked: 0,
            wall: Duration::ZERO,
        };
        let words = g.to_words();
        assert_eq!(words.len(), GpuCounts::NAMES.len());
        assert_eq!(words[10], 0.5f64.to_bits(), "rates as bit patterns");
        assert_eq!(GpuCounts::from_words(&words), Some(g), "exact round trip");
        assert_eq!(GpuCounts::from_words(&words[1..]), None, "too few words");
        assert_eq!(GpuCounts::from_words(&[&words[..], &[0]].concat()), None, "too many words");
        let half = share_of(&o, 0.5, 4).gpu.unwrap();
        let json = |g: &GpuCounts| serde_json::to_value(g).unwrap();
        let (full, half) = (json(&g), json(&half));
        let mut names = GpuCounts::NAMES.to_vec();
        names.sort_unstable();
        assert_eq!(full.as_object().unwrap().keys().collect::<Vec<_>>(), names, "NAMES names every field");
        for name in GpuCounts::NAMES {
            let kept = matches!(name, "l1d_hit_rate" | "l2_hit_rate" | "last_dispatch");
            let want = if kept { full[name].as_f64().unwrap() } else { full[name].as_f64().unwrap() / 2.0 };
            assert_eq!(half[name].as_f64().unwrap(), want, "{name}");
        }
    }

    #[test]
    fn offchip_accesses_are_the_requests_between_l1d_and_dram() {
        let scene = crate::load_scene("clutter").unwrap();
        let w = workload(&scene, 24);
        for name in ["RB_1", "RB_8", "RB_4+SH_4+SK+RA"] {
            let o = simulate_all(&spec(name, Fidelity::Cycle), &w).unwrap();
            let g = o.gpu.unwrap();
            let m = |k: Metric| k.of(&o).unwrap();
            assert_eq!(m(Metric::Offchip), m(Metric::OffchipNode) + m(Metric::OffchipStack), "{name}");
            // The L1D filters node fetches before L2, the L2 filters requests before DRAM.
            assert!(g.offchip_node > 0 && g.offchip_node <= g.node_fetches, "{name}: {g:?}");
            assert!(g.offchip_node >= g.dram_node, "{name}: {g:?}");
            assert!(
                g.offchip_stack >= o.stack.rb_to_global + o.stack.sh_to_global,
                "{name}: every spill leaves"
            );
        }
    }

    #[test]
    fn sampling_a_fraction_of_one_is_the_full_run_split() {
        let scene = crate::load_scene("clutter").unwrap();
        let w = workload(&scene, 24);
        let s = spec("RB_4+SH_4", Fidelity::Functional);
        let full = simulate_all(&s, &w).unwrap();
        let plan =
            SamplePlan { fraction: 1.0, mode: crate::run::sampling::SampleMode::Random, batches: 4, seed: 1 };
        let sampled = simulate_sampled(&s, &w, &plan, |_| {}).unwrap();
        let sum: u64 = sampled.batches.iter().map(|b| b.stack.global_accesses()).sum();
        assert_eq!(sum, full.stack.global_accesses(), "the batches partition the warps");
        assert!(sampled.get(Metric::StackGlobal).unwrap().contains(full.stack.global_accesses() as f64));
        assert!(sampled.get(Metric::Cycles).is_none(), "functional level has no cycles");
    }
}

#[cfg(test)]
mod cycle_sampling_tests {
    use super::*;
    use crate::workload::WorkloadOpts;

    #[test]
    fn sampling_every_warp_at_the_cycle_level_is_the_full_run() {
        let scene = crate::load_scene("clutter").unwrap();
        let w = Workload::new(&scene, WorkloadOpts::quick(&scene, 32)).unwrap();
        let s = RunSpec {
            config: "RB_4+SH_4".parse().unwrap(),
            hw: Hardware::default(),
            fidelity: Fidelity::Cycle,
        };
        let full = simulate_all(&s, &w).unwrap();
        let plan =
            SamplePlan { fraction: 1.0, mode: crate::run::sampling::SampleMode::Random, batches: 4, seed: 3 };
        let sampled = simulate_sampled(&s, &w, &plan, |_| {}).unwrap();
        let launch = sampled.launch.unwrap();
        assert_eq!(launch.gpu.unwrap().cycles, full.gpu.unwrap().cycles, "one launch of every warp");
        assert_eq!(launch.stack, full.stack);
        // Shares add up to the launch (up to rounding), so the estimate is the full run's value.
        let cycles: u64 = sampled.batches.iter().map(|b| b.gpu.unwrap().cycles).sum();
        assert!(cycles.abs_diff(full.gpu.unwrap().cycles) <= 4, "{cycles}");
        let e = sampled.get(Metric::Cycles).unwrap();
        let rel = (e.value - full.gpu.unwrap().cycles as f64).abs() / full.gpu.unwrap().cycles as f64;
        assert!(rel < 0.25, "batch shares differ in warps per residence, but not wildly: {rel}");
        assert!(e.half_width > 0.0 && e.half_width.is_finite());
    }
}
