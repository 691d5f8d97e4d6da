//! A GPU and how to run it: the run options (the evaluation check, the runner, a helper thread,
//! idle-cycle skipping, a planted slip in test builds) beside the hardware, which holds none of them.
//!
//! `Gpu::run` and the other `Gpu::run_*` run with the default options; `Gpu::with_*` gives a
//! [`Runner`] with one option set, whose own `with_*` set the others.

use super::{Design, Parts, Steps};
use crate::clock::EvalCheck;
use crate::gpu::{Gpu, GpuReport, Progress};
use crate::ray_op::{Walks, WarpJob};
use crate::rt_unit::RunError;
use crate::trace::Sink;

/// A GPU with the options of its run.
pub struct Runner {
    gpu: Gpu,
    /// How sibling RT units are evaluated each cycle ([`Runner::with_eval_check`]).
    eval_check: EvalCheck,
    /// The windowed run's SMs are split between two threads ([`Runner::with_helper_thread`]).
    helper_thread: bool,
    /// The run goes by windows where it can ([`Runner::with_windows`]).
    windows: bool,
    /// Cycles in which every thread waits on memory are jumped over ([`Runner::with_idle_skip`]).
    idle_skip: bool,
    /// A slip planted in the runner ([`Runner::with_order_bug`]).
    #[cfg(feature = "mutants")]
    order_bug: Option<super::OrderBug>,
}

impl From<Gpu> for Runner {
    /// The default run: by windows where the run allows it, on one thread, in dataflow order.
    fn from(gpu: Gpu) -> Runner {
        Runner {
            gpu,
            eval_check: EvalCheck::Dataflow,
            helper_thread: false,
            windows: true,
            idle_skip: true,
            #[cfg(feature = "mutants")]
            order_bug: None,
        }
    }
}

impl Runner {
    /// Evaluate the SMs in the order, and every kernel as many times per cycle, that `check` says
    /// (the report must not change: tests compare it with the [`EvalCheck::Dataflow`] run's).
    pub fn with_eval_check(mut self, check: EvalCheck) -> Self {
        self.eval_check = check;
        self
    }

    /// Runs the windowed run's SMs on two threads (the calling thread and a helper): the same
    /// results as one thread, in less wall time when a second core is free. The reference loop
    /// runs on one thread either way.
    pub fn with_helper_thread(mut self, on: bool) -> Self {
        self.helper_thread = on && self.gpu.sms().len() >= 2;
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

    /// Jumps over cycles in which every thread waits on memory: the same report, in less wall
    /// time. On by default; off clocks every cycle.
    pub fn with_idle_skip(mut self, on: bool) -> Self {
        self.idle_skip = on;
        self
    }

    /// A runner with a planted slip (test builds).
    #[cfg(feature = "mutants")]
    pub fn with_order_bug(mut self, bug: super::OrderBug) -> Self {
        self.order_bug = Some(bug);
        self
    }

    /// [`Gpu::with_scoreboard`] on the GPU being run.
    pub fn with_scoreboard(mut self, make: &dyn Fn() -> Box<dyn crate::stack_manager::Scoreboard>) -> Self {
        self.gpu = self.gpu.with_scoreboard(make);
        self
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

    /// As [`Runner::run`], calling `progress` about every `every` cycles.
    pub fn run_with_progress<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
    ) -> Result<GpuReport, RunError> {
        self.run_timed(jobs, sink, every, progress, &mut Vec::new())
    }

    /// As [`Runner::run_with_progress`], also filling `residence` with the cycles each job spent
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
            return self.run_with(super::Slipped(bug, &shared), jobs, None, sink, every, progress, residence);
        }
        self.run_with(Design, jobs, None, sink, every, progress, residence)
    }

    /// As [`Runner::run_timed`], for walk-driven jobs (`WarpJob::walk`, the restart designs):
    /// each ray's operations come from `walks` as its stack answers. Every pop is checked against
    /// the walk's unbounded reference stack (or answered Restart by the stack's own decision).
    pub fn run_walks<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        walks: &mut dyn Walks,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
        residence: &mut Vec<u64>,
    ) -> Result<GpuReport, RunError> {
        self.run_with(Design, jobs, Some(walks), sink, every, progress, residence)
    }

    /// [`Runner::run_timed`] with the runner's steps `steps`.
    #[allow(clippy::too_many_arguments)]
    fn run_with<S: Sink>(
        mut self,
        steps: impl Steps,
        jobs: impl IntoIterator<Item = WarpJob>,
        walks: Option<&mut dyn Walks>,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
        residence: &mut Vec<u64>,
    ) -> Result<GpuReport, RunError> {
        let mut walks = walks;
        let (warp_size, idle_skip) = (self.gpu.config().warp_size, self.idle_skip);
        let parts = Parts {
            gpu: &mut self.gpu,
            warp_size,
            idle_skip,
            eval_check: self.eval_check,
            helper_thread: self.helper_thread,
            windows: self.windows,
            walks: walks.as_mut().map(|w| &mut **w as &mut dyn Walks),
        };
        let o = super::run(parts, steps, jobs, sink, every, progress, residence)?;
        Ok(self.gpu.report(o.cycles, o.evaluated, o.last_dispatch, o.l2_dram_counters))
    }
}

/// The run options on a GPU, and its runs with the default ones ([`Runner`]).
impl Gpu {
    /// [`Runner::with_eval_check`] on this GPU's run.
    pub fn with_eval_check(self, check: EvalCheck) -> Runner {
        Runner::from(self).with_eval_check(check)
    }

    /// [`Runner::with_helper_thread`] on this GPU's run.
    pub fn with_helper_thread(self, on: bool) -> Runner {
        Runner::from(self).with_helper_thread(on)
    }

    /// [`Runner::with_idle_skip`] on this GPU's run.
    pub fn with_idle_skip(self, on: bool) -> Runner {
        Runner::from(self).with_idle_skip(on)
    }

    /// [`Runner::with_windows`] on this GPU's run.
    pub fn with_windows(self, on: bool) -> Runner {
        Runner::from(self).with_windows(on)
    }

    /// [`Runner::with_order_bug`] on this GPU's run (test builds).
    #[cfg(feature = "mutants")]
    pub fn with_order_bug(self, bug: super::OrderBug) -> Runner {
        Runner::from(self).with_order_bug(bug)
    }

    /// [`Runner::run`] with the default options.
    pub fn run<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        sink: &mut S,
    ) -> Result<GpuReport, RunError> {
        Runner::from(self).run(jobs, sink)
    }

    /// [`Runner::run_with_progress`] with the default options.
    pub fn run_with_progress<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
    ) -> Result<GpuReport, RunError> {
        Runner::from(self).run_with_progress(jobs, sink, every, progress)
    }

    /// [`Runner::run_timed`] with the default options.
    pub fn run_timed<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
        residence: &mut Vec<u64>,
    ) -> Result<GpuReport, RunError> {
        Runner::from(self).run_timed(jobs, sink, every, progress, residence)
    }

    /// [`Runner::run_walks`] with the default options.
    pub fn run_walks<S: Sink>(
        self,
        jobs: impl IntoIterator<Item = WarpJob>,
        walks: &mut dyn Walks,
        sink: &mut S,
        every: u64,
        progress: impl FnMut(Progress),
        residence: &mut Vec<u64>,
    ) -> Result<GpuReport, RunError> {
        Runner::from(self).run_walks(jobs, walks, sink, every, progress, residence)
    }
}
