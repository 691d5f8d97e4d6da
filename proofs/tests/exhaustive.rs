//! Exhaustive checks of the small configurations, and every mutant caught by them.

use rtl::config::{Config, RbSize, Realloc, ShPolicy};
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
        if c.realloc().is_some() {
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
        policy: ShPolicy::Realloc(Realloc { borrow_limit: 1, flush_limit: 1 }),
        warp_size: 2,
        warps: 1,
        ..Config::default()
    };
    let plain = |n, m| Config { policy: ShPolicy::Dedicated, ..ra(n, m) };
    let cases = [
        (plain(1, 2), Mutant::QueueWrapOffByOne, Property::Conservation),
        (plain(1, 2), Mutant::ReloadWrongEntry, Property::Conservation),
        (plain(1, 1), Mutant::SpillDropsEntry, Property::Conservation),
        (plain(1, 1), Mutant::MissingGlobalReload, Property::Equivalence),
        (ra(1, 2), Mutant::EarlyRelease, Property::Conservation),
        (plain(1, 1), Mutant::SkipOverflowClear, Property::Overflow),
        // The checker's own flush count sees the count kept right after the pop's plan; the
        // bounds (0 on every empty stack) only once the pop's micro-ops are done.
        (ra(1, 1), Mutant::FlushKeepsCount, Property::FlushCount),
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
        policy: ShPolicy::Realloc(Realloc { borrow_limit: 1, flush_limit: 1 }),
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

/// Runs `n` actions picked by `seed` from those `m` offers (invalid commands included).
fn walk(m: &mut Model, seed: u64, n: usize) {
    let mut cov = Coverage::default();
    for i in 0..n {
        let acts = m.actions_capped(2, Some(10));
        if acts.is_empty() {
            return; // every thread finished
        }
        let a = acts[(mix(seed ^ i as u64) % acts.len() as u64) as usize];
        m.act(a, &mut cov).unwrap_or_else(|v| panic!("a correct design failed {v:?}"));
    }
}

/// The searches overwrite one model with another (`clone_from`, which keeps allocations; each
/// type's is written field by field). Overwritten, a model must equal the source in every field
/// and behave alike after: checked on models whose queues, RBs, global regions and reference
/// stacks had different lengths and capacities before.
#[test]
fn a_model_overwritten_by_clone_from_equals_its_source() {
    let c = Config {
        rb: RbSize::Entries(1),
        sh_entries: 2,
        warp_size: 4,
        policy: ShPolicy::Realloc(Realloc { borrow_limit: 2, flush_limit: 1 }),
        ..Config::sms()
    };
    for seed in 0..40u64 {
        let (mut a, mut b) = (Model::new(c).unwrap(), Model::new(c).unwrap());
        walk(&mut a, seed, 30 + seed as usize % 17);
        walk(&mut b, !seed, 5 + seed as usize % 29);
        a.clone_from(&b);
        assert_eq!(a.sm, b.sm, "seed {seed}: stack manager");
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "seed {seed}: model");
        assert_eq!(a.key(), b.key());
        walk(&mut a, seed * 7, 20);
        walk(&mut b, seed * 7, 20);
        assert_eq!(format!("{a:?}"), format!("{b:?}"), "seed {seed}: after 20 more actions");
    }
}
