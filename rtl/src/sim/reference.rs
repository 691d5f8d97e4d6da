//! The reference loop: one cycle at a time, clocking the GPU as a unit.
//!
//! A cycle: dispatch (from the warp slots' registers); the GPU's evaluation
//! ([`crate::gpu::Gpu::eval_by`]: the L2 and DRAM on the L1Ds' down requests, then every SM, in
//! the order and as many times as the run's [`crate::clock::EvalCheck`] says, `check.rs`); its
//! clock edge ([`crate::gpu::Gpu::commit_then`]), between the RT units' edge and the memory's
//! the walks' next segments and the waveform's sample. Then the run jumps to the next cycle in
//! which anything happens.
//!
//! An RT unit with nothing to do is not evaluated ([`crate::sm`]), unless the check is
//! [`crate::clock::EvalCheck::EveryUnit`] or the cycle is one a waveform shows (which wants every
//! unit's combinational signals).

use super::check::Checked;
use super::{Dispatcher, Parts, Progress, Steps};
use crate::clock::Unit;
use crate::gpu::{GpuIn, GpuStep};
use crate::ray_op::WarpJob;
use crate::rt_unit::{RtUnit, RunError};
use crate::sm::Evaluation;
use crate::trace::Sink;

/// An RT unit's registers the loop reads between cycles.
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

/// The loop's per-SM inputs and status, reused from cycle to cycle.
struct Loop {
    /// The job landing in each SM at this cycle's edge.
    jobs_in: Vec<Option<WarpJob>>,
    step: GpuStep,
    /// The SMs' evaluation order this cycle (the dispatcher's slip reads it).
    order: Vec<usize>,
    status: Vec<RtStatus>,
    evaluated: u64,
}

/// Runs every job to completion; returns the cycles evaluated.
pub(super) fn run<S: Sink, P: Steps, I: Iterator<Item = WarpJob>>(
    parts: &mut Parts,
    steps: P,
    dispatcher: &mut Dispatcher<I>,
    sink: &mut S,
    every: u64,
    mut progress: impl FnMut(Progress),
) -> Result<u64, RunError> {
    let n = parts.gpu.sms().len();
    let mut l = Loop {
        jobs_in: vec![None; n],
        step: GpuStep::default(),
        order: Vec::with_capacity(n),
        status: Vec::with_capacity(n),
        evaluated: 0,
    };
    l.refresh_status(parts);
    let mut next_report = every;
    loop {
        let now = parts.gpu.cycle();
        #[cfg(not(feature = "untraced"))]
        let shown = sink.next_wanted(now) == Some(now);
        #[cfg(feature = "untraced")]
        let shown = false;
        let e = Checked { check: parts.eval_check, steps, every_unit: shown };
        e.order(now, n, &mut l.order);
        // Nothing to look at while every slot is full.
        if l.status.iter().any(|s| s.free_slot) {
            let (status, jobs_in) = (&l.status, &mut l.jobs_in);
            dispatcher.dispatch(
                now,
                steps,
                &l.order,
                |sm| status[sm].free_slot,
                |sm, job| jobs_in[sm] = Some(job),
            )?;
        }
        let more_jobs = dispatcher.jobs_left();
        if !more_jobs && l.jobs_in.iter().all(Option::is_none) && l.status.iter().all(|s| s.empty) {
            break;
        }
        parts.gpu.eval_by(GpuIn { jobs: &l.jobs_in }, &mut l.step, e);
        l.evaluated += 1;
        l.step.check()?;
        l.commit(parts, sink, now, shown);
        l.skip_idle(parts, sink, more_jobs, now)?;
        if parts.gpu.cycle() >= next_report {
            progress(Progress { cycle: parts.gpu.cycle(), warps_dispatched: dispatcher.dispatched });
            next_report = parts.gpu.cycle().saturating_add(every);
        }
    }
    sink.end_run(parts.gpu.cycle());
    Ok(l.evaluated)
}

impl Loop {
    /// Every SM's [`RtStatus`], from its RT unit's registers.
    fn refresh_status(&mut self, parts: &Parts) {
        self.status.clear();
        self.status.extend(parts.gpu.sms().iter().map(|sm| RtStatus::of(&sm.rt)));
    }

    /// The clock edge, and between the RT units' edge and the memory's the walks' next segments
    /// and the waveform's view of the cycle.
    fn commit<S: Sink>(&mut self, parts: &mut Parts, sink: &mut S, now: u64, shown: bool) {
        let (step, walks) = (&self.step, &mut parts.walks);
        parts.gpu.commit_then(step, |gpu| {
            gpu.follow_walks(step, walks, now);
            #[cfg(not(feature = "untraced"))]
            if shown {
                sink.begin_cycle(now);
                gpu.probe(step, sink);
            }
            #[cfg(feature = "untraced")]
            let _ = (sink, shown);
        });
        for (k, job) in self.jobs_in.iter_mut().enumerate() {
            if step.sm(k).rt_stepped() {
                *job = None;
            }
        }
        self.refresh_status(parts);
    }

    /// Jumps to the next cycle in which anything happens (never over one the sink wants to see);
    /// work left with nothing ever to happen again is a stall.
    fn skip_idle<S: Sink>(
        &self,
        parts: &mut Parts,
        sink: &mut S,
        more_jobs: bool,
        now: u64,
    ) -> Result<(), RunError> {
        let dispatch_next = more_jobs && self.status.iter().any(|s| s.free_slot);
        // The other units' events need not be looked at when the next cycle is the earliest
        // possible (they are never before the cycle it is in now).
        let soon = parts.gpu.cycle();
        let units_next = self.status.iter().filter_map(|s| s.next_event).min();
        let next = if dispatch_next || units_next == Some(soon) {
            Some(soon)
        } else {
            let l1d_next = parts.gpu.sms().iter().filter_map(|sm| sm.l1d.next_event());
            units_next.into_iter().chain(l1d_next).chain(parts.gpu.memory().next_event()).min()
        };
        match next {
            None if more_jobs || !self.status.iter().all(|s| s.empty) => {
                Err(RunError::Stalled { cycle: now })
            }
            Some(at) if parts.idle_skip && at > soon => {
                #[cfg(not(feature = "untraced"))]
                let at = sink.next_wanted(soon).map_or(at, |w| w.min(at));
                #[cfg(feature = "untraced")]
                let _ = sink;
                if at > soon {
                    parts.gpu.skip_to(at)
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }
}
