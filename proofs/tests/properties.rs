//! Every stack property, run three ways from the same function ([`run_valued`], which checks all
//! of `tb::run::verify::invariants` and the request sequences after every action):
//! - as Kani proofs, where Kani is installed (it is not on the machines this project was built
//!   on, so these harnesses have never run under Kani):
//!   `cargo kani --tests -p proofs --enable-unstable --fail-uncoverable` — bolero swaps in its
//!   Kani engine, the input array (thread, command and *push value* per action) becomes
//!   symbolic, bounds shrink through `cfg!(kani)`, and every harness has `kani::cover!`s that
//!   `--fail-uncoverable` turns into obligations, so a proof cannot pass vacuously (with a Kani
//!   that lacks that unstable option, read the "N of M cover properties satisfied" line);
//! - randomly under `cargo test`: bolero's random engine on the small configurations (the same
//!   covers then asserted over all iterations), and proptest with long sequences on every
//!   full-size configuration of SPEC section 8;
//! - exhaustively: `tests/fixpoint.rs` and `tests/exhaustive.rs` drive the same `Model::act`.
//!
//! The harness bodies allocate nothing themselves (fixed-size input arrays, covers as static
//! flags, no `Vec`). What still allocates under them, all of it bounded by the configuration
//! (warp size W ≤ 4, M ≤ 2 here) and by `LEN`, so Kani's bounded-`Vec` model covers it within
//! `unwind(12)`:
//! - at construction (`Model::new`): the stack manager's per-thread vectors (registers, RB
//!   queues, sequencers, SH array, spill regions: W or W·M elements each, sized by
//!   `Config`), the scoreboard's W reference stacks and Done flags, and the W latch shadows;
//! - per action: the RB queue, spill region, reference stack and sequencer grow by at most
//!   the entries one command moves (≤ 4 micro-ops; each grows at most `LEN` deep over a run),
//!   `run_valued`'s counterexample trace (one `Action` per action, ≤ `LEN`), and the checks'
//!   scratch vectors — a snapshot of the W stack registers and of one spill region before a
//!   command, the chains walked (≤ 1 + borrow limit stacks), the logical stacks rebuilt for
//!   Conservation (≤ `LEN` entries), the holder table of Chains (W).
//!
//! The stack manager's vectors are sized from the configuration at run time (one type serves
//! every warp size and M), so making them fixed arrays would change the design's types, which
//! this layer does not own; the checks' scratch vectors are the next candidates.

use std::sync::atomic::{AtomicBool, Ordering::Relaxed};

use rtl::config::{Config, RbSize, Realloc, ShPolicy};
use tb::run::verify::exhaustive::{run_valued, Coverage};

/// Input length: symbolic under Kani, longer random sequences otherwise.
const LEN: usize = if cfg!(kani) { 10 } else { 200 };

/// One action per element: thread byte, command byte, push value.
type Input = [(u8, u8, u64); LEN];

fn small(n: u32, m: u32, ws: u32, borrow: u32) -> Config {
    Config {
        rb: RbSize::Entries(n),
        sh_entries: m,
        skew: m > 0,
        policy: ShPolicy::from((borrow > 0).then_some(Realloc { borrow_limit: borrow, flush_limit: 1 })),
        warp_size: ws,
        warps: 1,
        ..Config::default()
    }
}

fn holds(cfg: Config, input: &Input) -> Coverage {
    run_valued(cfg, input).unwrap_or_else(|cex| panic!("{}: {cex}", cfg.name()))
}

/// A cover goal: a `kani::cover!` under Kani; under `cargo test` a flag set when some random
/// input reaches it, asserted by [`assert_reached`] after the run.
macro_rules! cover {
    ($flag:expr, $cond:expr) => {{
        let c: bool = $cond;
        #[cfg(kani)]
        kani::cover!(c);
        if c {
            $flag.store(true, Relaxed);
        }
    }};
}

#[cfg(not(kani))]
fn assert_reached(flags: &[(&str, &AtomicBool)]) {
    for (name, f) in flags {
        assert!(f.load(Relaxed), "cover goal {name} never reached");
    }
}

#[test]
#[cfg_attr(kani, kani::proof, kani::unwind(12))]
fn verify_equivalence_baseline_short_stack() {
    static RELOAD: AtomicBool = AtomicBool::new(false);
    bolero::check!().with_type::<Input>().for_each(|input| {
        let cov = holds(small(1, 0, 2, 0), input);
        cover!(RELOAD, cov.global_reloads > 0);
    });
    #[cfg(not(kani))]
    assert_reached(&[("global reload", &RELOAD)]);
}

#[test]
#[cfg_attr(kani, kani::proof, kani::unwind(12))]
fn verify_equivalence_sh_queue() {
    static RELOAD: AtomicBool = AtomicBool::new(false);
    bolero::check!().with_type::<Input>().for_each(|input| {
        let cov = holds(small(1, 2, 2, 0), input);
        cover!(RELOAD, cov.global_reloads > 0);
    });
    #[cfg(not(kani))]
    assert_reached(&[("global reload", &RELOAD)]);
}

#[test]
#[cfg_attr(kani, kani::proof, kani::unwind(12))]
fn verify_reallocation_bookkeeping() {
    static BORROW: AtomicBool = AtomicBool::new(false);
    static FLUSH: AtomicBool = AtomicBool::new(false);
    static RELEASE: AtomicBool = AtomicBool::new(false);
    bolero::check!().with_type::<Input>().for_each(|input| {
        let cov = holds(small(1, 1, 2, 1), input);
        cover!(BORROW, cov.borrows > 0);
        cover!(FLUSH, cov.flushes > 0);
        cover!(RELEASE, cov.releases > 0);
    });
    #[cfg(not(kani))]
    assert_reached(&[("borrow", &BORROW), ("flush", &FLUSH), ("release", &RELEASE)]);
}

#[test]
#[cfg_attr(kani, kani::proof, kani::unwind(12))]
fn verify_reallocation_four_threads() {
    static BORROW: AtomicBool = AtomicBool::new(false);
    bolero::check!().with_type::<Input>().for_each(|input| {
        let cov = holds(small(2, 2, 4, 2), input);
        cover!(BORROW, cov.borrows > 0);
    });
    #[cfg(not(kani))]
    assert_reached(&[("borrow", &BORROW)]);
}

mod full_size {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

        /// Long sequences (thousands of actions) on one 32-thread warp of every configuration
        /// of SPEC section 8, so RB, SH, borrowing, flushing and global memory are all reached.
        #[test]
        fn paper_configurations_keep_every_property(
            input in proptest::collection::vec((0u8..8, any::<u8>()), 2000..6000)
        ) {
            let mut reached_global = false;
            for cfg in Config::paper_set() {
                let cov = tb::run::verify::exhaustive::run_bytes(cfg, &input)
                    .unwrap_or_else(|cex| panic!("{}: {cex}", cfg.name()));
                reached_global |= cov.global_reloads > 0;
            }
            prop_assert!(reached_global, "sequences must reach global memory");
        }
    }
}
