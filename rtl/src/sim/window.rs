//! The windowed run: each SM (its RT unit and its L1D) runs a window of cycles on its own,
//! ahead of the others, and the SMs meet the L2 only between windows. The same cycles, the same
//! registers and the same report as the reference loop (`tb/tests/eval_order.rs` compares them);
//! with a helper thread, the two threads meet once per window.
//!
//! Why an SM may run ahead. The SMs meet only in the memory system, and there only through:
//! - **responses**: a request the L2 lets into a bank pipeline in cycle `x` reaches its tag
//!   check at `x + l2_latency - 3` (157 cycles with the paper's 160), and whatever the check
//!   decides (hit, miss, DRAM, fill) is visible to an L1D only after that. So the L2's *back
//!   end* (tag checks, MSHRs, DRAM queue, DRAM, the response registers) can run up to that many
//!   cycles ahead of its *front end* (the banks' arbiters and the pipelines' entrances), and the
//!   responses an SM sees in a window are known before the window starts;
//! - **grants**: a bank's arbiter picks one of the SMs requesting it in a cycle, so when an L1D's
//!   request leaves its miss queue depends on the other SMs. The SM itself sees that only as the
//!   miss queue's length, when it is full (a request that needs a slot parks). So the miss queue
//!   is simulated beside the front end ([`DetachedL1d`]); the L1D keeps an upper bound
//!   of its length (the requests not yet known to have left), exact once the front end has run
//!   the cycles before. An SM whose bound reaches the queue's depth before that stops and waits;
//! - **jobs**: the dispatcher hands the next job to the first SM with a free warp slot, round
//!   robin, so which job an SM gets depends on the others' slots in that cycle. An SM with a
//!   free slot (while jobs remain) stops at that cycle, and the dispatch is made when every SM
//!   has reached it, from the same registers as the reference loop's.
//!
//! One round: the coordinator (the calling thread, alone) moves each SM's requests sent down
//! into the front end's miss queues and the back end's responses into each SM's inputs, runs
//! the front end up to the slowest SM, dispatches, and sets the window's end; then the SMs run
//! to it, and the back end runs on towards the next window's needs, in parallel when a helper
//! thread is there (the back end and the first SMs on the calling thread, the rest on the
//! helper: [`split_point`]).
//!
//! What the reference loop also reports is rebuilt exactly: a cycle it would evaluate is one
//! in which some unit has an event due (an RT unit's or L1D's next event, a non-empty miss queue,
//! the L2's or DRAM's next event, a dispatch); each part marks those cycles as it runs them and
//! the run counts their union. The run ends where that loop ends: at the first such cycle after
//! the last unit emptied with no job left, with the L2's and DRAM's counters as they were then
//! (the back end may have run further: [`Back::snapshots`]).

use super::helper::Helper;
use super::split::{DetachedL1d, FrontEnd, FrontIn, FrontStep, SplitL2};
use super::{Dispatcher, Outcome, Progress, Steps};
use crate::clock::Unit;
use crate::gpu::Gpu;
use crate::mem::dram::{Dram, DramIn, DramStep};
use crate::mem::hierarchy::MemSystem;
use crate::mem::l2::{L2In, L2Step, L2};
use crate::mem::{Counters, MemReq, MemResp, ReqKind};
use crate::ray_op::WarpJob;
use crate::rt_unit::{RtUnit, RunError};
use crate::sm::{Offer, Sm, SmIn, SmStep};
use crate::warp_buffer::Bits;
use std::collections::VecDeque;

/// Most cycles in a window. A window's SMs need the responses of all its cycles, which the
/// back end computes a window ahead, so two windows must fit in the L2's pipeline delay
/// ([`window_for`]). 64: the throughput bench's SMS run takes about 5 500 rounds (4 000 whole
/// windows, the rest ended early by an SM that stopped for a job); 48 and 78 measured no
/// different.
const WINDOW: u64 = 64;

/// The window for an L2 whose bank pipelines hold a request `delay` cycles (`l2_latency - 3`):
/// `None` when that is too short for windows to pay (the reference loop runs instead).
pub(super) fn window_for(delay: u64) -> Option<u64> {
    let w = WINDOW.min(delay / 2);
    (w >= 4).then_some(w)
}

/// How many SMs the calling thread runs beside the back end; the helper runs the rest. The back
/// end costs about what one SM costs, so the calling thread takes a little under half the SMs.
fn split_point(sms: usize) -> usize {
    sms * 3 / 8
}

/// Cycles in which some unit had an event due (those the reference loop evaluates), one bit
/// each.
#[derive(Clone, Debug, Default)]
struct CycleSet {
    words: Vec<u64>,
}

impl CycleSet {
    fn set(&mut self, c: u64) {
        let w = (c >> 6) as usize;
        if w >= self.words.len() {
            self.words.resize(w + 1 + w / 4, 0);
        }
        self.words[w] |= 1 << (c & 63);
    }

    fn get(&self, c: u64) -> bool {
        self.words.get((c >> 6) as usize).is_some_and(|w| w >> (c & 63) & 1 != 0)
    }

    /// The first marked cycle in `from..to`.
    fn first_in(&self, from: u64, to: u64) -> Option<u64> {
        (from..to).find(|&c| self.get(c))
    }

    /// The last marked cycle, if any.
    fn last(&self) -> Option<u64> {
        let (w, word) = self.words.iter().enumerate().rev().find(|(_, &w)| w != 0)?;
        Some(w as u64 * 64 + 63 - u64::from(word.leading_zeros()))
    }
}

/// Marked cycles below `end` in the union of `all`.
fn count_union<'a>(all: impl Iterator<Item = &'a CycleSet> + Clone, end: u64) -> u64 {
    let words = end.div_ceil(64) as usize;
    (0..words)
        .map(|w| {
            let union = all.clone().fold(0u64, |u, b| u | b.words.get(w).copied().unwrap_or(0));
            let keep = if (w as u64 + 1) * 64 <= end { u64::MAX } else { (1u64 << (end % 64)) - 1 };
            u64::from((union & keep).count_ones())
        })
        .sum()
}

/// One SM's side of the run: what it has done, and its inputs and outputs between rounds.
#[derive(Default)]
struct Lane {
    /// The first cycle it has not run.
    frontier: u64,
    /// Responses of the L2 for its L1D, by the cycle they are visible in (the back end's).
    fills: VecDeque<(u64, MemResp)>,
    /// Cycles in which the front end granted its L1D's head request (it leaves the queue at that
    /// cycle's edge).
    pops: VecDeque<u64>,
    /// The job dispatched to it, landing in its next cycle.
    job: Option<WarpJob>,
    /// Requests its L1D sent down this round, with the cycle of the edge that queued each.
    sent: Vec<(u64, MemReq)>,
    /// This cycle's fills (scratch).
    now_fills: Vec<MemResp>,
    step: SmStep,
    /// The check that failed, in the cycle `frontier`.
    error: Option<RunError>,
    /// The cycle from which its RT unit has been empty (after the edge that emptied it).
    empty_since: u64,
    /// Cycles in which its RT unit or L1D had an event due.
    due: CycleSet,
}

/// What every SM's window reads alike.
#[derive(Clone, Copy)]
struct Limits {
    /// The window's end (exclusive): the back end has made every response visible before it.
    end: u64,
    /// The first cycle the front end has not run: a miss queue's length is exact in the cycles
    /// up to it.
    front: u64,
    /// A job remains: an SM with a free slot stops for the dispatch.
    jobs_left: bool,
    queue_depth: usize,
}

/// Runs SM `sm` from its frontier to the window's end, or to the first cycle in which it needs
/// what another SM decides (a job, or its miss queue's exact length), or to a failed check. Each
/// cycle is the reference loop's cycle of this SM, on the same inputs but the L2's grant (none:
/// its miss queue is the front end's, [`DetachedL1d`]).
fn run_sm<P: Steps>(sm: &mut Sm, lane: &mut Lane, lim: Limits, steps: P) {
    if lane.error.is_some() {
        return;
    }
    let mut c = lane.frontier;
    while c < lim.end {
        while lane.pops.front().is_some_and(|&p| p < c) {
            lane.pops.pop_front();
            sm.l1d.left_queue();
        }
        let (u, l1) = (&sm.rt, &sm.l1d);
        if steps.stops_for_job() && lane.job.is_none() && lim.jobs_left && u.free_slot().is_some() {
            break;
        }
        let offer = Offer::of(u, l1);
        // The L1D asks whether its miss queue has room only for a request it takes or holds
        // parked; the bound answers unless it has reached the queue's depth.
        if steps.stops_for_full_queue()
            && (offer.req.is_some() || !offer.ready)
            && l1.queue_bound() >= lim.queue_depth
            && lim.front < c
        {
            break;
        }
        let rt_due = u.next_event().is_some_and(|e| e <= c);
        let l1_due = l1.next_event_detached().is_some_and(|e| e <= c);
        lane.now_fills.clear();
        while let Some(&(at, r)) = lane.fills.front() {
            if at > c {
                break;
            }
            debug_assert_eq!(at, c, "a response passed by");
            lane.now_fills.push(r);
            lane.fills.pop_front();
        }
        steps.take_fills(&mut lane.now_fills);
        let rt_idle = idle(u, offer.req, &lane.job, c);
        if rt_idle && lane.now_fills.is_empty() && !l1_due {
            // Nothing happens in this SM before its next event or response: only the L1D's clock
            // moves (as the reference loop's quiet units), to there or to the window's end.
            let rt_next = u.next_event().map(|e| steps.rt_wakes_at(e));
            let next = [rt_next, l1.next_event_detached(), lane.fills.front().map(|f| f.0)]
                .into_iter()
                .flatten()
                .min()
                .map_or(lim.end, |e| e.min(lim.end));
            debug_assert!(next > c);
            sm.l1d.skip_to(next);
            c = next;
            continue;
        }
        if rt_due || l1_due {
            lane.due.set(c);
        }
        let i = SmIn { now: c, granted: false, fills: &lane.now_fills, job: lane.job.as_ref() };
        sm.eval_offered(offer, i, &mut lane.step, steps);
        if let Err(e) = lane.step.check() {
            lane.error = Some(e);
            break;
        }
        let before = sm.l1d.queue_bound();
        sm.commit(&lane.step);
        sm.l1d.sent_at(c, before, &mut lane.sent);
        // The job (if one came) landed: an idle unit gets none.
        lane.job = None;
        if lane.step.rt_stepped() && sm.rt.empty() {
            lane.empty_since = c + 1;
        }
        c += 1;
    }
    lane.frontier = c;
}

/// The RT unit offers no request (`req`), gets no job (`job`) and has no event due: it acts only
/// on a memory response.
#[inline]
fn idle(u: &RtUnit, req: Option<MemReq>, job: &Option<WarpJob>, now: u64) -> bool {
    req.is_none() && job.is_none() && u.next_event().is_none_or(|e| e > now)
}

/// A group of SMs' windows, in index order.
fn run_group<P: Steps>(sms: &mut [Sm], lanes: &mut [Lane], lim: Limits, steps: P) {
    for (sm, lane) in sms.iter_mut().zip(lanes.iter_mut()) {
        run_sm(sm, lane, lim, steps);
    }
}

/// The L2's front end beside the SMs' real miss queues.
struct Front {
    /// Per SM: (cycle of the edge that queued it, its L2 bank, request), oldest first; the head
    /// is offered from the cycle after that edge.
    queues: Vec<VecDeque<(u64, usize, MemReq)>>,
    /// SMs whose queue is not empty, one bit each.
    queued: u64,
    /// The first cycle not run.
    next: u64,
    /// Per bank: the SMs whose head requests it this cycle (scratch).
    want: Vec<u64>,
    /// Per SM: its head this cycle (scratch; stale where it has none).
    heads: Vec<MemReq>,
    step: FrontStep,
    /// The L2's front end's count of each bank's requests.
    end: FrontEnd,
    /// Cycles with a request in some miss queue, and cycles with a dispatch.
    due: CycleSet,
}

impl Front {
    /// Queues SM `k`'s request `r`, sent down at the edge of cycle `at`, for bank `bank`.
    fn push(&mut self, k: usize, at: u64, bank: usize, r: MemReq) {
        self.queues[k].push_back((at, bank, r));
        self.queued |= 1 << k;
    }

    /// Runs the front end's cycles up to `to` (inclusive); every SM must have run the cycles
    /// before it. Grants are passed to the SMs as cycles in which their head left.
    fn run_to(&mut self, to: u64, l2: &mut L2, lanes: &mut [Lane]) {
        let mut x = self.next;
        while x <= to {
            // The SMs whose head is offered in cycle `x`, and the first cycle any head is.
            let (mut offered, mut first) = (0u64, u64::MAX);
            for k in Bits::of(self.queued).map(|k| k as usize) {
                let &(at, bank, req) = self.queues[k].front().expect("queued");
                if at < x {
                    if offered == 0 {
                        self.want.iter_mut().for_each(|w| *w = 0);
                    }
                    offered |= 1 << k;
                    self.want[bank] |= 1 << k;
                    self.heads[k] = req;
                } else {
                    first = first.min(at + 1);
                }
            }
            if offered == 0 {
                x = first.min(to + 1);
                continue;
            }
            self.due.set(x);
            l2.front_eval(&self.end, FrontIn { at: x, want: &self.want, heads: &self.heads }, &mut self.step);
            l2.front_commit(&mut self.end, &self.step);
            for k in Bits::of(self.step.granted).map(|k| k as usize) {
                self.queues[k].pop_front();
                if self.queues[k].is_empty() {
                    self.queued &= !(1 << k);
                }
                lanes[k].pops.push_back(x);
            }
            x += 1;
        }
        self.next = self.next.max(x);
    }

    /// The first cycle from `from` (at or after the first cycle not run) in which some queue
    /// has a head, with no more requests coming.
    fn next_head(&self, from: u64) -> Option<u64> {
        self.queues.iter().filter_map(|q| q.front().map(|e| (e.0 + 1).max(from))).min()
    }
}

/// The L2's back end and DRAM.
struct Back {
    /// The L2's input of no new requests (the front end lets them in).
    none: Vec<Option<MemReq>>,
    step: L2Step,
    dram_step: DramStep,
    /// Cycles in which the L2 or DRAM had an event due.
    due: CycleSet,
    /// Per SM: responses made visible since the coordinator last took them, by cycle.
    staged: Vec<Vec<(u64, MemResp)>>,
    /// (cycle, L2's counters, DRAM's counters) before each cycle with an event, from the slowest
    /// SM's frontier of the round before on: the run may end before cycles the back end ran,
    /// and the report counts what the loop would have counted by then.
    snapshots: VecDeque<(u64, Counters, Counters)>,
}

impl Back {
    /// Runs the cycles before `to`: each cycle in which the L2 or DRAM has an event due is their
    /// evaluation and clock edge with no request coming in; the others only move their clocks
    /// (they would change nothing else).
    fn run_to(&mut self, to: u64, l2: &mut L2, dram: &mut Dram, front: &mut FrontEnd) {
        while l2.cycle() < to {
            let y = l2.cycle();
            let next = l2.next_event().into_iter().chain(dram.next_event()).min();
            if next.is_none_or(|e| e > y) {
                let t = next.map_or(to, |e| e.min(to));
                l2.skip_to(t);
                dram.skip_to(t);
                continue;
            }
            self.due.set(y);
            self.snapshots.push_back((y, *l2.counters(), *dram.counters()));
            l2.eval(L2In { reqs: &self.none, dram_ready: dram.ready(), fills: dram.resp() }, &mut self.step);
            dram.eval(DramIn { req: l2.dram_req() }, &mut self.dram_step);
            dram.commit(&self.dram_step);
            l2.back_commit(front, &self.step);
            for (k, staged) in self.staged.iter_mut().enumerate() {
                staged.extend(l2.resp(k).iter().map(|&r| (y + 1, r)));
            }
        }
    }
}

/// The windowed run's state between rounds: the SMs' lanes, the L2's two ends and the bookkeeping
/// of the run's end.
struct Windows {
    lanes: Vec<Lane>,
    front: Front,
    back: Back,
    /// The window's length ([`window_for`]) and the L2's pipeline delay.
    w: u64,
    delay: u64,
    queue_depth: usize,
    /// The slowest SM's frontier in the last round before every unit emptied.
    last_min: u64,
    rounds: u64,
}

/// Runs every job to completion by windows (see the module documentation), the SMs split between
/// this thread and `helper`'s if there is one; returns what the reference loop would have: the
/// cycle at which it ends, the cycles it evaluates and the L2's and DRAM's counters as it leaves
/// them (the back end may have run further).
pub(super) fn run<P: Steps, I: Iterator<Item = WarpJob>>(
    gpu: &mut Gpu,
    steps: P,
    helper: Option<&Helper>,
    dispatcher: &mut Dispatcher<I>,
    w: u64,
    every: u64,
    mut progress: impl FnMut(Progress),
) -> Result<Outcome, RunError> {
    let (sms, mem) = gpu.parts_mut();
    let mut r = Windows::new(sms.len(), mem, w);
    let mut next_report = every;
    loop {
        let m = r.exchange(mem);
        r.front.run_to(m, mem.parts_mut().0, &mut r.lanes);
        if dispatcher.jobs_left() {
            r.dispatch(m, sms, steps, dispatcher)?;
        }
        r.first_error()?;
        let jobs_left = dispatcher.jobs_left();
        let drained =
            !jobs_left && r.lanes.iter().all(|l| l.job.is_none()) && sms.iter().all(|sm| sm.rt.empty());
        if drained {
            if let Some(mut end) = r.finish(m, sms, mem) {
                end.last_dispatch = dispatcher.last_dispatch;
                return Ok(end);
            }
        }
        r.rounds += 1;
        if !drained && r.rounds.is_multiple_of(64) && r.stalled(sms, mem, jobs_left) {
            let last = r.due_sets().filter_map(CycleSet::last).max();
            return Err(RunError::Stalled { cycle: last.unwrap_or(0) });
        }
        r.round(m, sms, mem, steps, helper, jobs_left, drained);
        if m >= next_report {
            progress(Progress { cycle: m, warps_dispatched: dispatcher.dispatched });
            next_report = m.saturating_add(every);
        }
    }
}

impl Windows {
    /// The run's state before its first round: the L1Ds' miss queues and the L2's front end are
    /// to be clocked apart ([`DetachedL1d`], [`SplitL2`]), from a memory system with no request
    /// in flight.
    fn new(n: usize, mem: &MemSystem, w: u64) -> Windows {
        let params = *mem.params();
        Windows {
            lanes: (0..n).map(|_| Lane::default()).collect(),
            front: Front {
                queues: vec![VecDeque::new(); n],
                queued: 0,
                next: 0,
                want: vec![0; params.l2_banks as usize],
                heads: vec![MemReq::read(0, 0, 0, ReqKind::NodeFetch); n],
                step: FrontStep::default(),
                end: FrontEnd::new(params.l2_banks as usize),
                due: CycleSet::default(),
            },
            back: Back {
                none: vec![None; n],
                step: L2Step::default(),
                dram_step: DramStep::default(),
                due: CycleSet::default(),
                staged: vec![Vec::new(); n],
                snapshots: VecDeque::new(),
            },
            w,
            delay: u64::from(params.l2_latency - 3),
            queue_depth: params.l1d_miss_queue as usize,
            last_min: 0,
            rounds: 0,
        }
    }

    /// The meeting at the L2: each SM's requests sent down go into the front end's miss queues,
    /// the back end's responses into the SMs' inputs. Returns the slowest SM's frontier.
    fn exchange(&mut self, mem: &MemSystem) -> u64 {
        let l2 = mem.l2();
        for (k, lane) in self.lanes.iter_mut().enumerate() {
            for (at, r) in lane.sent.drain(..) {
                self.front.push(k, at, l2.bank_of(r.addr), r);
            }
            lane.fills.extend(self.back.staged[k].drain(..));
        }
        self.lanes.iter().map(|l| l.frontier).min().unwrap_or(0)
    }

    /// The dispatch in cycle `m`: every SM has run the cycles before it, and those ahead of it
    /// had no free slot in it (they would have stopped there). It comes before any failed check
    /// of cycle `m` or later, as in the reference loop.
    fn dispatch<P: Steps, I: Iterator<Item = WarpJob>>(
        &mut self,
        m: u64,
        sms: &[Sm],
        steps: P,
        dispatcher: &mut Dispatcher<I>,
    ) -> Result<(), RunError> {
        // At most 64 SMs go by windows: one bit each.
        let takes = self
            .lanes
            .iter()
            .zip(sms)
            .enumerate()
            .filter(|(_, (l, sm))| l.frontier == m && l.job.is_none() && sm.rt.free_slot().is_some())
            .fold(0u64, |b, (sm, _)| b | 1 << sm);
        let (lanes, due) = (&mut self.lanes, &mut self.front.due);
        dispatcher.dispatch(
            m,
            steps,
            &[],
            |sm| takes >> sm & 1 != 0,
            |sm, job| {
                lanes[sm].job = Some(job);
                due.set(m);
            },
        )
    }

    /// A failed check: the earliest, and in its cycle the lowest SM's, once every other SM is past
    /// that cycle (as the reference loop, which stops at the first SM that fails).
    fn first_error(&mut self) -> Result<(), RunError> {
        let lanes = &mut self.lanes;
        let failed =
            lanes.iter().enumerate().filter(|(_, l)| l.error.is_some()).map(|(k, l)| (l.frontier, k)).min();
        match failed {
            Some((c, k)) if lanes.iter().all(|l| l.error.is_some() || l.frontier > c) => {
                Err(lanes[k].error.take().expect("failed"))
            }
            _ => Ok(()),
        }
    }

    /// Every part's cycles in which some unit had an event due.
    fn due_sets(&self) -> impl Iterator<Item = &CycleSet> + Clone {
        self.lanes.iter().map(|l| &l.due).chain([&self.front.due, &self.back.due])
    }

    /// Every unit is empty with no job left (`m`: the slowest SM's frontier): the reference loop
    /// ends at the first cycle after the edge that emptied the last unit in which some unit has an
    /// event due. Once every part has run up to there, returns that cycle, the cycles that loop
    /// evaluated and the L2's and DRAM's counters as it leaves them (when the back end ran
    /// further); `None` until then.
    fn finish(&mut self, m: u64, sms: &[Sm], mem: &MemSystem) -> Option<Outcome> {
        let (l2, dram) = (mem.l2(), mem.dram());
        let after = self.lanes.iter().map(|l| l.empty_since).max().unwrap_or(0);
        if m < after || self.front.next < after || l2.cycle() < after {
            return None;
        }
        let front = &self.front;
        let end = self
            .lanes
            .iter()
            .zip(sms)
            .map(|(lane, sm)| {
                lane.due.first_in(after, lane.frontier).or_else(|| {
                    [sm.rt.next_event(), sm.l1d.next_event_detached()].into_iter().flatten().min()
                })
            })
            .chain([front.due.first_in(after, front.next).or_else(|| front.next_head(front.next))])
            .chain([self
                .back
                .due
                .first_in(after, l2.cycle())
                .or_else(|| l2.next_event().into_iter().chain(dram.next_event()).min())])
            .flatten()
            .min()
            .map_or(after, |e| e.max(after));
        // The L2's and DRAM's counts as they were after the cycle before `end`.
        let counters = self.back.snapshots.iter().find(|s| s.0 >= end).map(|&(_, l2c, dramc)| (l2c, dramc));
        let evaluated = count_union(self.due_sets(), end);
        Some(Outcome { cycles: end, evaluated, last_dispatch: 0, l2_dram_counters: counters })
    }

    /// Nothing will ever happen again, yet work remains: the reference loop's `Stalled`. (Looked
    /// at every 64th round: it reads every unit, some in the other core's cache, and a run that
    /// has stalled stays so.)
    fn stalled(&self, sms: &[Sm], mem: &MemSystem, jobs_left: bool) -> bool {
        let (l2, dram) = (mem.l2(), mem.dram());
        self.lanes.iter().zip(sms).all(|(lane, sm)| {
            let (u, l1) = (&sm.rt, &sm.l1d);
            lane.job.is_none()
                && lane.fills.is_empty()
                && lane.error.is_none()
                && u.next_event().is_none()
                && l1.next_event_detached().is_none()
                && !(jobs_left && u.free_slot().is_some())
        }) && self.front.queued == 0
            && self.back.staged.iter().all(Vec::is_empty)
            && l2.next_event().is_none()
            && dram.next_event().is_none()
    }

    /// One round from the slowest SM's frontier `m`: the SMs run their window, every response in
    /// which is visible (the back end ran the cycles before its last), and the back end runs on
    /// to the next window's needs, as far as the requests the front end let in allow (a request
    /// let in at the front end's last cycle is due at its tag check `delay` cycles later). With a
    /// helper, the back end and the first SMs run on this thread, the other SMs on the helper.
    #[allow(clippy::too_many_arguments)]
    fn round<P: Steps>(
        &mut self,
        m: u64,
        sms: &mut [Sm],
        mem: &mut MemSystem,
        steps: P,
        helper: Option<&Helper>,
        jobs_left: bool,
        drained: bool,
    ) {
        let (l2, dram) = mem.parts_mut();
        let lim = Limits {
            end: (m + self.w).min(l2.cycle() + 1),
            front: self.front.next,
            jobs_left,
            queue_depth: self.queue_depth,
        };
        let back_to = steps.back_end_to(self.front.next, self.delay, lim.end, self.w);
        // Once every unit is empty with no job left the run ends in a cycle not yet known, perhaps
        // before the slowest SM's frontier: the counts of every cycle since then are kept.
        if !drained {
            while self.back.snapshots.front().is_some_and(|s| s.0 < self.last_min) {
                self.back.snapshots.pop_front();
            }
            self.last_min = m;
        }
        let back = &mut self.back;
        let lanes = &mut self.lanes;
        let front_end = &mut self.front.end;
        match helper {
            Some(h) => {
                let a = split_point(sms.len());
                let (sa, sb) = sms.split_at_mut(a);
                let (na, nb) = lanes.split_at_mut(a);
                h.join(
                    || {
                        back.run_to(back_to, l2, dram, front_end);
                        run_group(sa, na, lim, steps);
                    },
                    move || run_group(sb, nb, lim, steps),
                );
            }
            None => {
                back.run_to(back_to, l2, dram, front_end);
                run_group(sms, lanes, lim, steps);
            }
        }
    }
}
