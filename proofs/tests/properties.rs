//! Every stack property, run three ways from the same function ([`run_bytes`], which checks all
//! of `tb::run::verify::invariants` after every action):
//! - as Kani proofs (`cargo kani --tests -p proofs`, where Kani is installed): bolero swaps in
//!   its Kani engine, inputs become symbolic, bounds shrink through `cfg!(kani)`, and
//!   `kani::cover!` marks the paths a proof must reach so it cannot pass vacuously;
//! - randomly under `cargo test`: bolero's random engine on the small configurations, and
//!   proptest with long sequences on every full-size configuration of SPEC section 8;
//! - exhaustively over small bounds: `tests/exhaustive.rs` drives the same `Model::act`.

use rtl::config::{Config, RbSize, Realloc};
use tb::run::verify::exhaustive::{run_bytes, Coverage};

/// Input length: symbolic under Kani, longer random sequences otherwise.
const LEN: usize = if cfg!(kani) { 10 } else { 200 };

fn small(n: u32, m: u32, ws: u32, borrow: u32) -> Config {
    Config {
        rb: RbSize::Entries(n),
        sh_entries: m,
        skew: m > 0,
        realloc: (borrow > 0).then_some(Realloc { borrow_limit: borrow, flush_limit: 1 }),
        warp_size: ws,
        warps: 1,
        ..Config::default()
    }
}

fn holds(cfg: Config, input: &[(u8, u8)]) -> Coverage {
    run_bytes(cfg, input).unwrap_or_else(|cex| panic!("{}: {cex}", cfg.name()))
}

#[test]
#[cfg_attr(kani, kani::proof, kani::unwind(12))]
fn verify_equivalence_baseline_short_stack() {
    bolero::check!().with_type::<[(u8, u8); LEN]>().for_each(|input| {
        holds(small(1, 0, 2, 0), input);
    });
}

#[test]
#[cfg_attr(kani, kani::proof, kani::unwind(12))]
fn verify_equivalence_sh_queue() {
    bolero::check!().with_type::<[(u8, u8); LEN]>().for_each(|input| {
        let cov = holds(small(1, 2, 2, 0), input);
        #[cfg(kani)]
        kani::cover!(cov.global_reloads > 0);
        let _ = cov;
    });
}

#[test]
#[cfg_attr(kani, kani::proof, kani::unwind(12))]
fn verify_reallocation_bookkeeping() {
    bolero::check!().with_type::<[(u8, u8); LEN]>().for_each(|input| {
        let cov = holds(small(1, 1, 2, 1), input);
        #[cfg(kani)]
        {
            kani::cover!(cov.borrows > 0);
            kani::cover!(cov.flushes > 0);
            kani::cover!(cov.releases > 0);
        }
        let _ = cov;
    });
}

#[test]
#[cfg_attr(kani, kani::proof, kani::unwind(12))]
fn verify_reallocation_four_threads() {
    bolero::check!().with_type::<[(u8, u8); LEN]>().for_each(|input| {
        holds(small(2, 2, 4, 2), input);
    });
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
                let cov = holds(cfg, &input);
                reached_global |= cov.global_reloads > 0;
            }
            prop_assert!(reached_global, "sequences must reach global memory");
        }
    }
}
