//! Exhaustive checks of the small configurations, and every mutant caught by them.

use rtl::config::{Config, RbSize, Realloc};
use rtl::stack_manager::Mutant;
use tb::run::verify::exhaustive::{check, describe, run_bytes_on, small_configs, Bounds, Coverage, Model};
use tb::run::verify::harness::mix;
use tb::run::verify::invariants::Property;

/// Depth per configuration: 2-thread warps go deeper (reloads from global need long
/// sequences), 4-thread warps cover more interleavings at a smaller depth.
fn bounds(c: &Config) -> Bounds {
    let depth = if c.warp_size == 2 { 16 } else { 9 };
    Bounds { depth, values: 2, max_states: 5_000_000, ..Bounds::default() }
}

fn run(c: Config) -> Coverage {
    let cov = check(c, bounds(&c), |sm| sm).unwrap_or_else(|e| panic!("{}: {e}", describe(&c)));
    println!(
        "{:42} depth {:2} states {:8} sequences {:>16} in {:>6.2?}  borrows {} flushes {} reloads {} releases {}",
        describe(&c),
        cov.depth_reached,
        cov.states,
        cov.sequences,
        cov.elapsed,
        cov.borrows,
        cov.flushes,
        cov.global_reloads,
        cov.releases
    );
    assert!(cov.complete, "{}: state cap hit", describe(&c));
    cov
}

#[test]
fn small_configurations_keep_every_property() {
    for c in small_configs() {
        let cov = run(c);
        assert!(cov.warp_exits > 0, "{}: no warp exit reached", describe(&c));
        if c.rb != RbSize::Full {
            assert!(
                cov.global_reloads > 0 || c.warp_size == 4,
                "{}: no reload from global reached",
                describe(&c)
            );
        }
        if c.realloc.is_some() {
            // The cover points: a borrow and a flush everywhere; a release (which needs the
            // borrowed stack filled and drained again) within the 2-thread warps' deeper bound.
            assert!(cov.borrows > 0 && cov.flushes > 0, "{}: {cov:?}", describe(&c));
            assert!(cov.releases > 0 || c.warp_size == 4, "{}: {cov:?}", describe(&c));
        }
    }
}

/// The property that catches `m` with RequestSequence off: the state properties (Conservation,
/// Overflow, Flush, …) catch these bugs on their own; `tests/mutants.rs` runs every mutant with
/// every property on.
fn mutant_caught(c: Config, m: Mutant) -> Property {
    let b = Bounds { request_sequence: false, ..bounds(&c) };
    match check(c, b, |sm| sm.with_mutant(Some(m))) {
        Err(cex) => {
            println!(
                "{m:?} on {}: caught by {:?} after {} actions\n{cex}",
                describe(&c),
                cex.violation.property,
                cex.trace.len()
            );
            cex.violation.property
        }
        Ok(cov) => panic!("{m:?} on {} survived {} states", describe(&c), cov.states),
    }
}

#[test]
fn every_mutant_is_caught() {
    let ra = |n, m| Config {
        rb: RbSize::Entries(n),
        sh_entries: m,
        realloc: Some(Realloc { borrow_limit: 1, flush_limit: 1 }),
        warp_size: 2,
        warps: 1,
        ..Config::default()
    };
    let plain = |n, m| Config { realloc: None, ..ra(n, m) };
    let cases = [
        (plain(1, 2), Mutant::QueueWrapOffByOne, Property::Conservation),
        (plain(1, 2), Mutant::ReloadWrongEntry, Property::Conservation),
        (plain(1, 1), Mutant::SpillDropsEntry, Property::Conservation),
        (plain(1, 1), Mutant::MissingGlobalReload, Property::Equivalence),
        (ra(1, 2), Mutant::EarlyRelease, Property::Conservation),
        (plain(1, 1), Mutant::SkipOverflowClear, Property::Overflow),
        (ra(1, 1), Mutant::FlushKeepsCount, Property::Flush),
    ];
    for (c, m, expected) in cases {
        assert_eq!(mutant_caught(c, m), expected, "{m:?}");
    }
}

/// Setting Idle when the pop is planned (before the drained stack's last entry is read) is safe
/// under the cycle model's oldest-first arbiter, but not for arbitrary latencies: another thread
/// may borrow the stack and overwrite the entry first. The race needs three threads and about 14
/// actions, past the exhaustive bound of 4-thread warps, so random interleavings find it.
#[test]
fn eager_release_loses_an_entry_under_some_interleaving() {
    let c = Config {
        rb: RbSize::Entries(1),
        sh_entries: 1,
        realloc: Some(Realloc { borrow_limit: 1, flush_limit: 1 }),
        warp_size: 4,
        warps: 1,
        ..Config::default()
    };
    let input = |seed: u64| -> Vec<(u8, u8)> {
        (0..400u64).map(|i| mix(seed << 20 | i)).map(|h| ((h % 4) as u8, (h >> 8) as u8)).collect()
    };
    let model = |m| {
        let mut x = Model::new(c).unwrap();
        x.sm = x.sm.with_mutant(m);
        // The state properties alone (RequestSequence catches the missing release micro-op at
        // once: tests/sequence.rs).
        x.request_sequence = false;
        x
    };
    for seed in 0..2000 {
        run_bytes_on(model(None), &input(seed)).unwrap_or_else(|e| panic!("correct design failed: {e}"));
    }
    let caught =
        (0..2000).find_map(|seed| run_bytes_on(model(Some(Mutant::EagerRelease)), &input(seed)).err());
    let cex = caught.expect("EagerRelease survived 2000 random interleavings");
    println!("EagerRelease caught by {:?} after {} actions", cex.violation.property, cex.trace.len());
    assert!(matches!(cex.violation.property, Property::Conservation | Property::Equivalence));
}
