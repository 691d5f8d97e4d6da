//! An SM: its RT unit and its L1D, one clocked unit.
//!
//! ```text
//!   RT unit ── req (its request register, offered with `ready`) ──► L1D ── down_req ──► L2
//!   RT unit ◄─ ready (the L1D's register), req_fire (its step) ───── L1D ◄── granted ─── L2
//!   RT unit ◄─ resp (the L1D's response register) ───────────────── L1D ◄── fills ───── L2
//!   dispatcher ── job ──► RT unit
//! ```
//!
//! A cycle of an SM ([`Sm::eval_by`]): [`Offer::of`] reads the request from registers alone (the
//! RT unit's request register, the L1D's `ready`); the L1D is evaluated on it with the L2's grant
//! and responses ([`Offer::l1d_in`]); the RT unit is evaluated on the L1D's outputs
//! ([`Offer::rt_in`]). The GPU evaluates every SM after the L2, whose grant the L1D takes
//! ([`crate::gpu::Gpu`]); the windowed run evaluates each SM in its own window, never granted
//! ([`crate::sim`]).
//!
//! An RT unit with no event due, no response from its L1D, no job landing and no request to
//! offer would evaluate to a step that changes nothing: it is neither evaluated nor committed
//! that cycle (a wake-up instead of a scan), unless the evaluation says every unit is evaluated
//! ([`Evaluation::skips_quiet_units`]). The L1D is always evaluated; a quiet L1D's step costs
//! next to nothing (`mem/l1d.rs`).

use crate::clock::Unit;
use crate::mem::l1d::{L1d, L1dIn, L1dStep};
use crate::mem::{MemReq, MemResp};
use crate::ray_op::WarpJob;
use crate::rt_unit::{RtIn, RtStep, RtUnit, RunError};
use crate::trace::Sink;

/// What an SM's RT unit offers its L1D in a cycle, from registers alone.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Offer {
    /// The L1D's `ready` register: it takes a request this cycle.
    pub ready: bool,
    /// The RT unit's request, offered with `ready` ([`RtUnit::req`]).
    pub req: Option<MemReq>,
}

impl Offer {
    /// The offer of RT unit `u` to its L1D `l1` this cycle.
    #[inline]
    pub fn of(u: &RtUnit, l1: &L1d) -> Offer {
        let ready = l1.ready();
        Offer { ready, req: u.req(ready) }
    }

    /// The L1D's input: the offered request, the L2's grant of the L1D's down request
    /// (`granted`) and the L2's responses visible this cycle (`fills`).
    #[inline]
    pub fn l1d_in(self, granted: bool, fills: &[MemResp]) -> L1dIn<'_> {
        L1dIn { req: self.req, down_ready: granted, fills }
    }

    /// The RT unit's input in cycle `now`, from its L1D `l1` evaluated into `l1_step`: the
    /// offer's `ready`, whether the L1D took the request, the L1D's responses (its response
    /// register, read in place) and the job landing at this cycle's edge.
    #[inline]
    pub fn rt_in<'a>(self, now: u64, l1: &'a L1d, l1_step: &L1dStep, job: Option<&'a WarpJob>) -> RtIn<'a> {
        let offered = self.req.is_some();
        RtIn {
            now,
            req_ready: self.ready,
            req_fire: offered && l1.sm_ready(l1_step, offered),
            resp: l1.resp(),
            job,
        }
    }
}

/// How the GPU's cycle is evaluated where the hardware leaves the choice free: the order in
/// which the sibling SMs are evaluated, how many times each kernel is, whether a unit with
/// nothing to do is, and (a planted slip, in test builds) how an RT unit's kernel is called. The
/// defaults are the design's ([`Dataflow`]); a runner checking that those choices change
/// nothing gives others (`sim`'s evaluation checks).
pub trait Evaluation: Copy {
    /// Fills `order` with the order in which the `n` SMs are evaluated in cycle `cycle`. The
    /// design's: index order (a vector that already holds `n` entries is left as it is).
    #[inline]
    fn order(self, _cycle: u64, n: usize, order: &mut Vec<usize>) {
        if order.len() != n {
            order.clear();
            order.extend(0..n);
        }
    }

    /// How many times each kernel is evaluated per cycle (the last evaluation is committed).
    #[inline]
    fn passes(self) -> u32 {
        1
    }

    /// Whether an RT unit with nothing to do is left unevaluated.
    #[inline]
    fn skips_quiet_units(self) -> bool {
        true
    }

    /// Whether responses `resp` wake an RT unit that has nothing else to do.
    #[inline]
    fn wakes_for(self, resp: &[MemResp]) -> bool {
        !resp.is_empty()
    }

    /// The `pass`-th evaluation of RT unit `u` in its cycle.
    #[inline]
    fn eval_rt(self, u: &RtUnit, i: RtIn, step: &mut RtStep, _pass: u32) {
        u.eval(i, step);
    }
}

/// The design's evaluation: SMs in index order, each kernel once, RT units with nothing to do
/// left unevaluated.
#[derive(Clone, Copy, Debug, Default)]
pub struct Dataflow;

impl Evaluation for Dataflow {}

/// An SM's registers: its RT unit and its L1D.
#[derive(Clone, Debug)]
pub struct Sm {
    pub rt: RtUnit,
    pub l1d: L1d,
}

/// An SM's inputs in a cycle.
#[derive(Clone, Copy, Debug, Default)]
pub struct SmIn<'a> {
    pub now: u64,
    /// The L2 grants the L1D's down request (combinational: the L2 is evaluated first).
    pub granted: bool,
    /// The L2's responses for this SM (its register).
    pub fills: &'a [MemResp],
    /// The job the dispatcher sends, landing at this cycle's edge.
    pub job: Option<&'a WarpJob>,
}

/// An SM's cycle: its L1D's step and, when it was evaluated, its RT unit's.
#[derive(Clone, Debug, Default)]
pub struct SmStep {
    pub l1d: L1dStep,
    pub rt: RtStep,
    /// The RT unit was evaluated this cycle (else it had nothing to do, and is not committed).
    rt_stepped: bool,
}

impl SmStep {
    /// The RT unit was evaluated (and is committed at the edge).
    #[inline]
    pub fn rt_stepped(&self) -> bool {
        self.rt_stepped
    }

    /// The cycle's failed check ([`RtStep::check`]): a step that holds one is not committed.
    #[inline]
    pub fn check(&self) -> Result<(), RunError> {
        if self.rt_stepped {
            self.rt.check()
        } else {
            Ok(())
        }
    }
}

impl Sm {
    /// [`Unit::eval`] with the choices of `e`.
    #[inline]
    pub fn eval_by<E: Evaluation>(&self, i: SmIn<'_>, d: &mut SmStep, e: E) {
        self.eval_offered(Offer::of(&self.rt, &self.l1d), i, d, e);
    }

    /// [`Sm::eval_by`] with the cycle's `offer` already read ([`Offer::of`] this SM).
    #[inline]
    pub fn eval_offered<E: Evaluation>(&self, offer: Offer, i: SmIn<'_>, d: &mut SmStep, e: E) {
        debug_assert_eq!(offer, Offer::of(&self.rt, &self.l1d), "another cycle's offer");
        let l1_in = offer.l1d_in(i.granted, i.fills);
        for _ in 0..e.passes() {
            self.l1d.eval(l1_in, &mut d.l1d);
        }
        d.rt_stepped = !(e.skips_quiet_units()
            && offer.req.is_none()
            && i.job.is_none()
            && self.rt.next_event().is_none_or(|t| t > i.now)
            && !e.wakes_for(self.l1d.resp()));
        if d.rt_stepped {
            let rt_in = offer.rt_in(i.now, &self.l1d, &d.l1d, i.job);
            for pass in 0..e.passes() {
                e.eval_rt(&self.rt, rt_in, &mut d.rt, pass);
            }
        }
    }
}

impl Unit for Sm {
    type In<'a> = SmIn<'a>;
    type Step = SmStep;

    /// The SM's cycle as the design evaluates it ([`Sm::eval_by`] with [`Dataflow`]).
    fn eval(&self, i: SmIn<'_>, d: &mut SmStep) {
        self.eval_by(i, d, Dataflow);
    }

    /// The clock edge: the L1D's, and the RT unit's if it was evaluated. A step with a failed
    /// check ([`SmStep::check`]) is not committed.
    #[inline]
    fn commit(&mut self, d: &SmStep) {
        if d.rt_stepped {
            self.rt.commit(&d.rt);
        }
        self.l1d.commit(&d.l1d);
    }

    /// The RT unit's registers and signals (its scope `rt_unit`), then the L1D's (scope `l1d`).
    fn probe<S: Sink>(&self, d: &SmStep, s: &mut S) {
        if !s.enabled() {
            return;
        }
        self.rt.probe(&d.rt, s);
        s.push_scope("l1d");
        self.l1d.probe(&d.l1d, s);
        s.pop_scope();
    }

    /// The first cycle in which the RT unit or the L1D acts with no input.
    fn next_event(&self) -> Option<u64> {
        self.rt.next_event().into_iter().chain(self.l1d.next_event()).min()
    }

    /// Moves the L1D's clock (the RT unit keeps none between edges).
    fn skip_to(&mut self, cycle: u64) {
        self.l1d.skip_to(cycle);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::gpu::Gpu;
    use crate::trace::Snapshot;

    /// An SM's probe shows its RT unit (scope `rt_unit`) and its L1D (scope `l1d`), each with
    /// its own signals.
    #[test]
    fn probe_shows_the_rt_unit_and_the_l1d() {
        let gpu = Gpu::paper(Config::sms()).unwrap();
        let sm = &gpu.sms()[0];
        let mut s = Snapshot::default();
        sm.probe(&SmStep::default(), &mut s);
        assert_eq!(s.get("rt_unit.port.req_fire"), Some(0));
        assert_eq!(s.get("l1d.req_ready"), Some(1));
        assert_eq!(s.get("l1d.miss_queue_depth"), Some(0));
        assert!(s.signals.iter().all(|(p, _, _)| p.starts_with("rt_unit.") || p.starts_with("l1d.")));
    }

    /// An SM with nothing to do: its RT unit is not evaluated under the design's evaluation, and
    /// is under one that evaluates every unit; the committed registers are the same either way.
    #[test]
    fn a_quiet_rt_unit_is_left_unevaluated_unless_every_unit_is() {
        #[derive(Clone, Copy)]
        struct EveryUnit;
        impl Evaluation for EveryUnit {
            fn skips_quiet_units(self) -> bool {
                false
            }
        }
        let gpu = Gpu::paper(Config::sms()).unwrap();
        let (mut a, mut b) = (gpu.sms()[0].clone(), gpu.sms()[0].clone());
        let (mut da, mut db) = (SmStep::default(), SmStep::default());
        for now in 0..3 {
            let i = SmIn { now, granted: false, fills: &[], job: None };
            a.eval_by(i, &mut da, Dataflow);
            b.eval_by(i, &mut db, EveryUnit);
            assert!(!da.rt_stepped() && db.rt_stepped());
            a.commit(&da);
            b.commit(&db);
        }
        assert_eq!(format!("{:?}", a.l1d), format!("{:?}", b.l1d));
        assert_eq!(a.rt.next_event(), b.rt.next_event());
        assert_eq!(a.rt.stats, b.rt.stats);
    }
}
