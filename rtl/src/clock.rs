//! How a cycle is evaluated, and the checks that show evaluation order does not matter.
//!
//! Every unit computes its outputs and its next register values from its current registers and
//! this cycle's inputs; registers change only when the runner commits at the clock edge. Units
//! with no combinational path between them (the SMs' RT units, the L1Ds) are *siblings*: the
//! order in which they are evaluated cannot matter, and evaluating a unit twice in a cycle must
//! give the same outputs and next state. [`EvalCheck`] makes a run evaluate siblings in a seeded
//! random order each cycle, or every kernel twice, so tests can compare its report with the
//! normal run's bit for bit.

/// How a runner evaluates sibling units within a cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EvalCheck {
    /// Siblings in index order, each once (the normal build).
    #[default]
    Dataflow,
    /// Siblings in a random order drawn afresh each cycle from `seed` and the cycle number.
    Shuffled { seed: u64 },
    /// Every kernel evaluated twice per cycle; the second evaluation's results are the ones
    /// committed (they must equal the first's).
    Twice,
    /// Every unit evaluated every cycle, including those the runner would let sleep (no event
    /// due, no input): shows the wake-up skip changes nothing.
    EveryUnit,
}

impl EvalCheck {
    /// How many times each kernel is evaluated per cycle.
    pub fn passes(self) -> u32 {
        if self == EvalCheck::Twice {
            2
        } else {
            1
        }
    }

    /// Whether a runner may skip a unit that has nothing to do this cycle.
    pub fn skips_quiet_units(self) -> bool {
        self != EvalCheck::EveryUnit
    }

    /// Fill `order` with the evaluation order of `n` siblings in cycle `cycle`. Only a shuffle
    /// changes from cycle to cycle: otherwise a vector that already holds `n` entries is left
    /// as it is, so a runner must fill its vector with one mode only (clear it when the mode
    /// changes).
    pub fn order(self, cycle: u64, n: usize, order: &mut Vec<usize>) {
        let shuffled = matches!(self, EvalCheck::Shuffled { .. });
        if !shuffled && order.len() == n {
            debug_assert!(order.iter().enumerate().all(|(i, &k)| i == k), "order filled by a shuffle");
            return;
        }
        order.clear();
        order.extend(0..n);
        if let EvalCheck::Shuffled { seed } = self {
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
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shuffled_orders_are_permutations_that_vary_by_cycle() {
        let mut a = Vec::new();
        let mut seen = std::collections::HashSet::new();
        for cycle in 0..50 {
            EvalCheck::Shuffled { seed: 7 }.order(cycle, 8, &mut a);
            let mut s = a.clone();
            s.sort();
            assert_eq!(s, (0..8).collect::<Vec<_>>());
            seen.insert(a.clone());
        }
        assert!(seen.len() > 40, "orders barely vary: {}", seen.len());
        EvalCheck::Dataflow.order(3, 4, &mut a);
        assert_eq!(a, [0, 1, 2, 3]);
    }
}
