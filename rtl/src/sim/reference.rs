//! The reference loop: one cycle at a time, phase by phase.
//!
//! A cycle: dispatch (from the warp slots' registers); every RT unit's request, from its request
//! register and its L1D's `ready` register; the memory system's evaluation on them; every RT
//! unit's evaluation on the memory system's outputs (siblings: none reads another, so in the order
//! the [`crate::clock::EvalCheck`] says, as many times as it says); every clock edge. Then the run jumps to the
//! next cycle in which anything happens.
//!
//! A unit with no event due, no response, no job landing and no request offered would evaluate
//! to a step that changes nothing: it is not evaluated (a wake-up instead of a scan), unless the
//! check is [`crate::clock::EvalCheck::EveryUnit`] or the cycle is one a waveform shows (which wants every
//! unit's combinational signals).

use super::{Dispatcher, Parts, Progress, Steps};
use crate::clock::Unit;
use crate::mem::hierarchy::MemStep;
use crate::mem::MemReq;
use crate::ray_op::WarpJob;
use crate::rt_unit::{RtStep, RtUnit, RunError};
use crate::sm::Offer;
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

/// The loop's per-SM wires and status, reused from cycle to cycle.
struct Loop {
    /// What each RT unit offers its L1D, and the requests alone (the memory system's input).
    offers: Vec<Offer>,
    reqs: Vec<Option<MemReq>>,
    /// The job landing in each RT unit at this cycle's edge.
    jobs_in: Vec<Option<WarpJob>>,
    steps: Vec<RtStep>,
    /// The memory system's step.
    mem_step: MemStep,
    /// Units not evaluated this cycle: nothing for them to do.
    quiet: Vec<bool>,
    /// Evaluation order of the RT units this cycle.
    order: Vec<usize>,
    status: Vec<RtStatus>,
    /// Each L1D's next event.
    l1d_next: Vec<Option<u64>>,
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
    let n = parts.units.len();
    let mut l = Loop {
        offers: vec![Offer::default(); n],
        reqs: vec![None; n],
        jobs_in: vec![None; n],
        steps: vec![RtStep::default(); n],
        mem_step: MemStep::default(),
        quiet: vec![false; n],
        order: Vec::with_capacity(n),
        status: Vec::with_capacity(n),
        l1d_next: vec![None; n],
        evaluated: 0,
    };
    l.refresh_status(parts);
    let mut next_report = every;
    loop {
        let now = parts.mem.cycle();
        parts.eval_check.order(now, n, &mut l.order);
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
        #[cfg(not(feature = "untraced"))]
        let shown = sink.next_wanted(now) == Some(now);
        #[cfg(feature = "untraced")]
        let shown = false;
        l.eval(parts, steps, now, shown)?;
        l.commit(parts, sink, now, shown);
        l.skip_idle(parts, sink, more_jobs, now)?;
        if parts.mem.cycle() >= next_report {
            progress(Progress { cycle: parts.mem.cycle(), warps_dispatched: dispatcher.dispatched });
            next_report = parts.mem.cycle().saturating_add(every);
        }
    }
    sink.end_run(parts.mem.cycle());
    Ok(l.evaluated)
}

impl Loop {
    /// Every SM's [`RtStatus`] and its L1D's next event, from their registers.
    fn refresh_status(&mut self, parts: &Parts) {
        self.status.clear();
        self.status.extend(parts.units.iter().map(RtStatus::of));
        for (sm, e) in self.l1d_next.iter_mut().enumerate() {
            *e = parts.mem.l1d(sm).next_event();
        }
    }

    /// The cycle's combinational logic: the RT units' requests, the memory system on them, the
    /// RT units on its outputs. Of the cycle's failed checks, the lowest SM's is the error,
    /// whatever the evaluation order.
    fn eval<P: Steps>(&mut self, parts: &mut Parts, steps: P, now: u64, shown: bool) -> Result<(), RunError> {
        for (sm, u) in parts.units.iter().enumerate() {
            self.offers[sm] = Offer::of(u, parts.mem.l1d(sm));
            self.reqs[sm] = self.offers[sm].req;
        }
        parts.mem.eval(&self.reqs, &mut self.mem_step);
        self.evaluated += 1;
        let skip_quiet = !shown && parts.eval_check.skips_quiet_units();
        for (sm, u) in parts.units.iter().enumerate() {
            self.quiet[sm] = skip_quiet
                && u.next_event().is_none_or(|e| e > now)
                && !steps.wakes_for(parts.mem.l1d(sm).resp())
                && self.jobs_in[sm].is_none()
                && self.reqs[sm].is_none();
        }
        let mut first_error: Option<(usize, RunError)> = None;
        for &sm in &self.order {
            if self.quiet[sm] {
                continue;
            }
            let l1 = parts.mem.l1d(sm);
            let i = self.offers[sm].rt_in(now, l1, self.mem_step.l1d(sm), self.jobs_in[sm].as_ref());
            for pass in 0..parts.eval_check.passes() {
                if let Err(e) = steps.eval_rt(&parts.units[sm], i, &mut self.steps[sm], pass) {
                    if first_error.as_ref().is_none_or(|f| sm < f.0) {
                        first_error = Some((sm, e));
                    }
                }
            }
        }
        first_error.map_or(Ok(()), |(_, e)| Err(e))
    }

    /// The clock edge of every unit evaluated (and the waveform's view of the cycle).
    fn commit<S: Sink>(&mut self, parts: &mut Parts, sink: &mut S, now: u64, shown: bool) {
        for &sm in &self.order {
            if !self.quiet[sm] {
                parts.units[sm].commit(&self.steps[sm]);
                parts.units[sm].follow_walks(&mut parts.walks, now);
                self.jobs_in[sm] = None;
            }
        }
        #[cfg(not(feature = "untraced"))]
        if shown {
            sink.begin_cycle(now);
            crate::gpu::probe(parts.units, |sm| &self.steps[sm], parts.mem, &self.mem_step, sink);
        }
        #[cfg(feature = "untraced")]
        let _ = (sink, now, shown);
        parts.mem.commit(&self.mem_step);
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
        // The memory system's events need not be looked at when the next cycle is the earliest
        // possible (they are never before the cycle it is in now).
        let soon = parts.mem.cycle();
        let units_next = self.status.iter().filter_map(|s| s.next_event).min();
        let next = if dispatch_next || units_next == Some(soon) {
            Some(soon)
        } else {
            let l1d_next = self.l1d_next.iter().filter_map(|&e| e);
            units_next.into_iter().chain(l1d_next).chain(parts.mem.shared_next_event()).min()
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
                    parts.mem.skip_to(at)
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }
}
