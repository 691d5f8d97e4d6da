//! Deliberately wrong runners, for showing the tests catch such slips (`tb/tests/eval_order.rs`).
//!
//! Each enters through the runners' interface: [`Slipped`] is an implementation of [`Steps`] that
//! gets one decision wrong and keeps the design's others. It exists only in builds with the
//! `mutants` feature; the product's runners have no trace of it.

use super::{Design, Steps};
use crate::clock::Unit;
use crate::mem::MemResp;
use crate::rt_unit::{RtIn, RtStep, RtUnit};
use crate::sm::Evaluation;
use std::sync::atomic::{AtomicU64, Ordering};

/// A slip planted in a runner (`Gpu::with_order_bug`). Test builds only.
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
    /// The windowed run lets an SM whose miss queue may be full run on, its queue's length
    /// taken from a bound that still counts requests already granted.
    WindowIgnoresFullQueue,
    /// The windowed run lets an SM with a free warp slot run on instead of stopping for the
    /// dispatch, so its job lands when the dispatcher reaches its cycle, late.
    WindowSkipsJobStop,
    /// The windowed run's L2 back end runs further ahead of the front end than the bank
    /// pipelines' delay: it checks a bank's head before the request that the front end lets in
    /// later would have been there.
    WindowBackEndTooFar,
    /// The windowed run's skip over an SM's quiet cycles wakes its RT unit a cycle after its
    /// event is due, so a unit otherwise quiet acts a cycle late.
    WindowWakesLate,
    /// The windowed run's SMs drop the L2's responses: their rays wait for ever, and the run
    /// must end as stalled rather than go on.
    WindowLosesResponses,
    /// A mechanism that couples the SMs outside the L2's grants and responses and the dispatch:
    /// the RT units share one visit counter, each evaluation reading it and adding its visits to
    /// it, and an evaluation that finds it odd counts its own visits twice. What an SM reads
    /// depends on how far the others have run: in the reference loop their cycles before this
    /// one (and this one's, for a lower SM), in the windowed run whatever part of a window they
    /// have run, ahead or behind. Both runners run it; the windowed run's visits differ.
    SmsShareACounter,
}

impl OrderBug {
    /// A slip of the windowed run (the others are of the reference loop, which then runs).
    fn in_windows(self) -> bool {
        matches!(
            self,
            OrderBug::WindowIgnoresFullQueue
                | OrderBug::WindowSkipsJobStop
                | OrderBug::WindowBackEndTooFar
                | OrderBug::WindowWakesLate
                | OrderBug::WindowLosesResponses
                | OrderBug::SmsShareACounter
        )
    }
}

/// The design's runner steps with one slip; `.1` is the counter the SMs share under
/// [`OrderBug::SmsShareACounter`] (one per run).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Slipped<'a>(pub OrderBug, pub &'a AtomicU64);

impl Evaluation for Slipped<'_> {
    fn eval_rt(self, u: &RtUnit, i: RtIn, step: &mut RtStep, pass: u32) {
        let earlier = (self.0 == OrderBug::StaleStep && pass > 0).then(|| step.visits());
        u.eval(i, step);
        if let Some(v) = earlier {
            step.count_visits_again(v);
        }
        if self.0 == OrderBug::SmsShareACounter {
            let shared = self.1.fetch_add(step.visits(), Ordering::Relaxed);
            if shared % 2 == 1 {
                step.count_visits_again(step.visits());
            }
        }
    }

    fn wakes_for(self, resp: &[MemResp]) -> bool {
        self.0 != OrderBug::SleepThroughResponses && Design.wakes_for(resp)
    }
}

impl Steps for Slipped<'_> {
    fn windows_allowed(self) -> bool {
        self.0.in_windows()
    }

    fn dispatch_to(self, k: usize, start: usize, n: usize, order: &[usize]) -> usize {
        match self.0 {
            OrderBug::DispatchInEvalOrder => order[k],
            _ => Design.dispatch_to(k, start, n, order),
        }
    }

    fn stops_for_job(self) -> bool {
        self.0 != OrderBug::WindowSkipsJobStop
    }

    fn stops_for_full_queue(self) -> bool {
        self.0 != OrderBug::WindowIgnoresFullQueue
    }

    fn rt_wakes_at(self, event: u64) -> u64 {
        match self.0 {
            OrderBug::WindowWakesLate => event + 1,
            _ => Design.rt_wakes_at(event),
        }
    }

    fn take_fills(self, fills: &mut Vec<MemResp>) {
        if self.0 == OrderBug::WindowLosesResponses {
            fills.clear();
        }
    }

    fn back_end_to(self, front_next: u64, delay: u64, window_end: u64, w: u64) -> u64 {
        match self.0 {
            OrderBug::WindowBackEndTooFar => front_next + delay + w,
            _ => Design.back_end_to(front_next, delay, window_end, w),
        }
    }
}
