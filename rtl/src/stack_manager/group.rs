//! Reallocation among neighbours (`+RA_G`, [`ShPolicy::Group`]): the paper's policy in every
//! decision but one. A thread whose chain is full borrows the lowest-numbered idle stack of its
//! own group of G lanes, not of the whole warp: the idle search is a G-input priority encoder
//! instead of a warp-wide one, and a borrowed stack's skewed base stays in the owner's part of
//! the bank rows. What that saves in logic and what it costs in spills is what `sms run`,
//! `sms sweep -c` and `sms cost --synth` measure; `docs/stack.md` argues the design.

use super::policy::{Plan, Regfile, Steps};
use crate::config::ShPolicy;
use crate::logic::Logic;

/// The policy of [`ShPolicy::Group`].
#[derive(Clone, Copy, Debug, Default)]
pub struct Group;

impl Steps for Group {
    fn name(&self) -> &'static str {
        "group"
    }

    fn first_idle<L: Logic, R: Regfile<L>>(p: &mut Plan<L, Self, R>) -> (L::Bit, L::Word) {
        let lane = p.t - p.base;
        let (first, lanes) = p.cfg.policy.lend_window(lane, p.cfg.warp_size);
        debug_assert!(matches!(p.cfg.policy, ShPolicy::Group { .. }), "Group runs {:?}", p.cfg.policy);
        p.first_idle_among(first, lanes)
    }
}

impl super::cycle::CycleSteps for Group {}
