//! The evaluation checks ([`EvalCheck`]) as the reference loop evaluates the GPU with them: an
//! [`Evaluation`] that orders the sibling SMs, evaluates each kernel as many times and skips
//! quiet units as the check says, around the runner's steps.

use super::Steps;
use crate::clock::EvalCheck;
use crate::mem::MemResp;
use crate::rt_unit::{RtIn, RtStep, RtUnit};
use crate::sm::Evaluation;

/// The reference loop's evaluation of a cycle: `check`'s order and passes, every unit evaluated
/// when `every_unit` (the check says so, or a waveform shows the cycle), and `steps`' RT units.
#[derive(Clone, Copy, Debug)]
pub(super) struct Checked<P> {
    pub check: EvalCheck,
    pub steps: P,
    pub every_unit: bool,
}

impl<P: Steps> Evaluation for Checked<P> {
    #[inline]
    fn order(self, cycle: u64, n: usize, order: &mut Vec<usize>) {
        match self.check {
            EvalCheck::Shuffled { seed } => shuffle(seed, cycle, n, order),
            _ => self.steps.order(cycle, n, order),
        }
    }

    #[inline]
    fn passes(self) -> u32 {
        self.check.passes()
    }

    #[inline]
    fn skips_quiet_units(self) -> bool {
        !self.every_unit && self.check.skips_quiet_units()
    }

    #[inline]
    fn wakes_for(self, resp: &[MemResp]) -> bool {
        self.steps.wakes_for(resp)
    }

    #[inline]
    fn eval_rt(self, u: &RtUnit, i: RtIn, step: &mut RtStep, pass: u32) {
        self.steps.eval_rt(u, i, step, pass);
    }
}

/// Fills `order` with a random order of `n` siblings, drawn afresh for each cycle from `seed` and
/// the cycle number.
fn shuffle(seed: u64, cycle: u64, n: usize, order: &mut Vec<usize>) {
    order.clear();
    order.extend(0..n);
    // Fisher–Yates driven by a splitmix64 stream keyed by (seed, cycle).
    let mut x = seed ^ cycle.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    for i in (1..n).rev() {
        x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = x;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        order.swap(i, (z % (i as u64 + 1)) as usize);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::Design;

    #[test]
    fn shuffled_orders_are_permutations_that_vary_by_cycle() {
        let mut a = Vec::new();
        let mut seen = std::collections::HashSet::new();
        let shuffled = Checked { check: EvalCheck::Shuffled { seed: 7 }, steps: Design, every_unit: false };
        for cycle in 0..50 {
            shuffled.order(cycle, 8, &mut a);
            let mut s = a.clone();
            s.sort();
            assert_eq!(s, (0..8).collect::<Vec<_>>());
            seen.insert(a.clone());
        }
        assert!(seen.len() > 40, "orders barely vary: {}", seen.len());
        a.clear();
        Checked { check: EvalCheck::Dataflow, steps: Design, every_unit: false }.order(3, 4, &mut a);
        assert_eq!(a, [0, 1, 2, 3]);
    }
}
