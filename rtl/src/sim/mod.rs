//! The runners: what clocks the GPU's units, cycle after cycle, until every job is done.
//!
//! Two runners, each written once:
//! - the **reference loop** (`reference.rs`): one cycle at a time, the GPU's evaluation
//!   ([`crate::gpu::Gpu::eval_by`]: the L2 and DRAM, then every SM) and its clock edge
//!   ([`crate::gpu::Gpu::commit_then`]). It is the model as the hardware describes it; waveforms,
//!   the evaluation checks ([`EvalCheck`], `check.rs`), runs without idle skipping and an L2 too
//!   short for windows use it;
//! - the **windowed run** (`window.rs`): each SM ([`crate::sm::Sm`]) runs a window of up to 64
//!   cycles on its own between meetings at the L2, on one thread or split between two
//!   ([`helper`]), its L1D's miss queue and the L2 clocked apart through the interfaces of
//!   `split.rs`. Every other run uses it. Its report is the reference loop's, bit for bit
//!   (`tb/tests/eval_order.rs`).
//!
//! Both dispatch jobs the same way (`Dispatcher`, below): a kernel launch's round robin, job i to the
//! next SM after the one that took job i-1 that has a free warp slot, so at launch SM k gets jobs
//! k, k + n, k + 2n, … and later jobs go wherever a warp left. Every decision reads registers: a
//! slot freed in cycle c takes a job in c + 1.
//!
//! Both skip idle cycles: a cycle in which no unit has an event due, no response arrives and no
//! job lands would change nothing, so the runners jump over it; the report counts the cycles that
//! were evaluated (`GpuReport::evaluated_cycles`), the same for both.
//!
//! The decisions a runner makes (which SM the dispatcher tries next, when an SM in a window must
//! stop, how far the L2's back end may run ahead, …, and how an RT unit is evaluated: the
//! [`crate::sm::Evaluation`] it extends) go through the `Steps` trait; the product runs `Design`.
//! Test builds (the `mutants` feature) also have `slips::Slipped`, which replaces one of those
//! decisions with a planted bug (`OrderBug`, `slips.rs`) so the tests can show they catch it.

mod check;
pub mod helper;
mod reference;
mod runner;
#[cfg(feature = "mutants")]
mod slips;
mod split;
mod window;

#[cfg(feature = "mutants")]
pub use slips::OrderBug;
#[cfg(feature = "mutants")]
pub(crate) use slips::Slipped;

use crate::clock::EvalCheck;
use crate::gpu::Gpu;
use crate::mem::{Counters, MemResp};
use crate::ray_op::WarpJob;
use crate::rt_unit::RunError;
use crate::sm::{Evaluation, Sm};
use crate::trace::Sink;
use std::iter::Peekable;

pub use crate::gpu::Progress;
pub use runner::Runner;

/// The GPU's parts and how to run them, lent to a runner for one run.
pub(crate) struct Parts<'a> {
    pub gpu: &'a mut Gpu,
    pub warp_size: u32,
    pub idle_skip: bool,
    pub eval_check: EvalCheck,
    /// Run the windowed run's SMs on two threads.
    pub helper_thread: bool,
    /// Go by windows where the run allows it.
    pub windows: bool,
    /// The walks of walk-driven warps (the restart designs); such a run takes the reference
    /// loop (its units' walks go on at each clock edge, one unit after the other).
    pub walks: Option<&'a mut dyn crate::ray_op::Walks>,
}

/// What a run reports beside the units' and the memory system's counters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Outcome {
    /// The run's cycles: the cycle after the last.
    pub cycles: u64,
    /// Cycles evaluated (the others were skipped as idle).
    pub evaluated: u64,
    /// Cycle of the last dispatch.
    pub last_dispatch: u64,
    /// The L2's and DRAM's counters at the run's end, where the runner ran them further (the
    /// windowed run's back end runs ahead); `None`: theirs as they are.
    pub l2_dram_counters: Option<(Counters, Counters)>,
}

/// The decisions a runner makes that a planted bug may get wrong, and the evaluation of the SMs'
/// cycles it extends; the default methods are the design's ([`Design`]).
pub(crate) trait Steps: Evaluation + Send + Sync {
    /// Whether the run may go by windows (a slip of the reference loop needs that loop to run).
    fn windows_allowed(self) -> bool {
        true
    }

    /// The `k`-th SM the dispatcher tries in a cycle of `n` SMs: round robin from `start`
    /// (`order` is the cycle's evaluation order of the siblings).
    #[inline]
    fn dispatch_to(self, k: usize, start: usize, n: usize, _order: &[usize]) -> usize {
        (start + k) % n
    }

    /// Whether an SM in a window stops where a job may be dispatched to it (a free warp slot
    /// while jobs remain).
    #[inline]
    fn stops_for_job(self) -> bool {
        true
    }

    /// Whether an SM in a window stops where its miss queue may be full.
    #[inline]
    fn stops_for_full_queue(self) -> bool {
        true
    }

    /// The cycle in which an SM in a window that has nothing to do wakes for its RT unit's next
    /// event, due in cycle `event` (that cycle).
    #[inline]
    fn rt_wakes_at(self, event: u64) -> u64 {
        event
    }

    /// The responses an SM takes in a cycle of a window (all of them).
    #[inline]
    fn take_fills(self, _fills: &mut Vec<MemResp>) {}

    /// Where the windowed run's L2 back end stops: `delay` cycles (the bank pipelines') after the
    /// front end's first cycle not run, and no further than the next window needs.
    #[inline]
    fn back_end_to(self, front_next: u64, delay: u64, window_end: u64, w: u64) -> u64 {
        (front_next + delay).min(window_end + w + 1)
    }
}

/// The design's decisions.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Design;

impl Evaluation for Design {}

impl Steps for Design {}

/// Runs `jobs` on `parts` to completion, by windows where they apply, else on the reference loop;
/// fills `residence` with each job's cycles in its RT unit's warp buffer (by launch order).
pub(crate) fn run<S: Sink, P: Steps>(
    mut parts: Parts,
    steps: P,
    jobs: impl IntoIterator<Item = WarpJob>,
    sink: &mut S,
    every: u64,
    progress: impl FnMut(Progress),
    residence: &mut Vec<u64>,
) -> Result<Outcome, RunError> {
    let n = parts.gpu.sms().len();
    let mut dispatcher = Dispatcher::new(jobs, n, parts.warp_size);
    let delay = u64::from(parts.gpu.memory().params().l2_latency - 3);
    let windowed = window::window_for(delay).filter(|_| {
        parts.windows
            && parts.walks.is_none()
            && steps.windows_allowed()
            && parts.eval_check == EvalCheck::Dataflow
            && parts.idle_skip
            && n <= 64
            && sink.next_wanted(0).is_none()
    });
    let o = match windowed {
        Some(w) if parts.helper_thread && n >= 2 => helper::with_helper(|h| {
            window::run(&mut *parts.gpu, steps, Some(h), &mut dispatcher, w, every, progress)
        })?,
        Some(w) => window::run(&mut *parts.gpu, steps, None, &mut dispatcher, w, every, progress)?,
        None => {
            let evaluated = reference::run(&mut parts, steps, &mut dispatcher, sink, every, progress)?;
            let last_dispatch = dispatcher.last_dispatch;
            Outcome { cycles: parts.gpu.cycle(), evaluated, last_dispatch, l2_dram_counters: None }
        }
    };
    if windowed.is_some() {
        sink.end_run(o.cycles);
    }
    dispatcher.residence(parts.gpu.sms(), residence);
    Ok(o)
}

/// The dispatcher: hands the next jobs to SMs with a free warp slot, round robin.
pub(crate) struct Dispatcher<I: Iterator<Item = WarpJob>> {
    jobs: Peekable<I>,
    /// Next SM tried.
    rr: usize,
    warp_size: u32,
    /// Job index of each SM's loads, in load order.
    loaded: Vec<Vec<u64>>,
    /// Jobs dispatched so far.
    pub dispatched: u64,
    pub last_dispatch: u64,
}

impl<I: Iterator<Item = WarpJob>> Dispatcher<I> {
    fn new(jobs: impl IntoIterator<IntoIter = I>, sms: usize, warp_size: u32) -> Self {
        Dispatcher {
            jobs: jobs.into_iter().peekable(),
            rr: 0,
            warp_size,
            loaded: vec![Vec::new(); sms],
            dispatched: 0,
            last_dispatch: 0,
        }
    }

    /// Some job is left.
    pub fn jobs_left(&mut self) -> bool {
        self.jobs.peek().is_some()
    }

    /// Cycle `now`'s dispatch: each SM in turn (the `k`-th tried is `steps.dispatch_to`) that
    /// `takes` a job gets the next, handed to `land`. A job that is not well formed is an error.
    pub fn dispatch<P: Steps>(
        &mut self,
        now: u64,
        steps: P,
        order: &[usize],
        takes: impl Fn(usize) -> bool,
        mut land: impl FnMut(usize, WarpJob),
    ) -> Result<(), RunError> {
        let n = self.loaded.len();
        let start = self.rr;
        for k in 0..n {
            let sm = steps.dispatch_to(k, start, n, order);
            if !takes(sm) {
                continue;
            }
            let Some(job) = self.jobs.next() else { break };
            job.validate(self.warp_size)
                .map_err(|reason| RunError::BadJob { job: self.dispatched, reason })?;
            land(sm, job);
            self.loaded[sm].push(self.dispatched);
            self.dispatched += 1;
            self.last_dispatch = now;
            self.rr = (sm + 1) % n;
        }
        Ok(())
    }

    /// Each job's cycles in its RT unit's warp buffer, by job.
    fn residence(&self, sms: &[Sm], residence: &mut Vec<u64>) {
        residence.clear();
        residence.resize(self.dispatched as usize, 0);
        for (sm, jobs) in sms.iter().zip(&self.loaded) {
            for (&job, &cycles) in jobs.iter().zip(&sm.rt.residence) {
                residence[job as usize] = cycles;
            }
        }
    }
}
