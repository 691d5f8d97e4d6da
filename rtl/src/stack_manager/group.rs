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

#[cfg(test)]
mod tests {
    use crate::config::Config;
    use crate::stack_manager::policy::Design;
    use crate::stack_manager::{Cmd, StackManager, StackPolicy};

    /// One warp of 8 lanes, RB 1 and SH 1 per lane: the second push of a lane spills to SH, the
    /// third finds its stack full and borrows. Lanes 1–3 and 5–7 finish first, so every group of
    /// 4 holds idle stacks; lane 4 then borrows.
    fn borrowed_by_lane_4(policy: Option<StackPolicy>) -> Vec<u32> {
        let cfg = Config { warp_size: 8, warps: 1, ..("RB_1+SH_1+RA_4".parse::<Config>().unwrap()) };
        let mut sm = StackManager::new(cfg, 0).unwrap();
        if let Some(p) = policy {
            sm = sm.with_policy(p);
        }
        for t in [1, 2, 3, 5, 6, 7] {
            sm.apply(t, Cmd::Finish).unwrap();
        }
        for v in 1..=3 {
            sm.apply(4, Cmd::Push(v)).unwrap();
        }
        sm.chain(4)
    }

    #[test]
    fn a_full_chain_borrows_within_its_group() {
        // Lane 4's group is lanes 4–7: the lowest idle stack there is 5, not the warp's 1.
        assert_eq!(borrowed_by_lane_4(None), [4, 5]);
    }

    #[test]
    fn the_paper_policy_borrows_across_the_warp() {
        // The planted contrast: the warp-wide search takes lane 1's stack.
        assert_eq!(borrowed_by_lane_4(Some(StackPolicy::new(Design))), [4, 1]);
    }

    #[test]
    fn a_group_with_nothing_idle_spills_to_global() {
        let cfg = Config { warp_size: 8, warps: 1, ..("RB_1+SH_1+RA_4".parse::<Config>().unwrap()) };
        let mut sm = StackManager::new(cfg, 0).unwrap();
        for t in [0, 1, 2, 3] {
            sm.apply(t, Cmd::Finish).unwrap();
        }
        for v in 1..=3 {
            sm.apply(4, Cmd::Push(v)).unwrap();
        }
        assert_eq!(sm.chain(4), [4], "lanes 0–3 are idle but outside lane 4's group");
        assert_eq!(sm.global(4).len(), 1, "the third push spilled to global memory");
    }
}
