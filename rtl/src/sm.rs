//! One SM's wiring: what its RT unit and its L1D see of each other in a cycle, written once for
//! both runners ([`crate::sim`]).
//!
//! ```text
//!   RT unit ── req (its request register, offered with `ready`) ──► L1D ── down_req ──► L2
//!   RT unit ◄─ ready (the L1D's register), req_fire (its step) ───── L1D ◄── granted ─── L2
//!   RT unit ◄─ resp (the L1D's response register) ───────────────── L1D ◄── fills ───── L2
//!   dispatcher ── job ──► RT unit
//! ```
//!
//! A cycle of an SM: [`Offer::of`] reads the request from registers alone (the RT unit's request
//! register, the L1D's `ready`); the L1D is evaluated on it ([`Offer::l1d_in`]); the RT unit is
//! evaluated on the L1D's outputs ([`Offer::rt_in`]). The reference loop evaluates every L1D inside
//! the memory system, which wires each L1D's grant and fills from the L2 it clocks with it
//! ([`crate::mem::hierarchy::MemSystem`]); the windowed run evaluates each SM's L1D in the SM's
//! window on [`Offer::l1d_in`], its down port detached. Both evaluate the RT unit on
//! [`Offer::rt_in`].

use crate::mem::l1d::{L1d, L1dIn, L1dStep};
use crate::mem::{MemReq, MemResp};
use crate::ray_op::WarpJob;
use crate::rt_unit::{RtIn, RtUnit};

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
    /// (`granted`; false while a runner clocks the miss queue apart,
    /// [`L1d::detach_miss_queue`]) and the L2's responses visible this cycle (`fills`).
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
