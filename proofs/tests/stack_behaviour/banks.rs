//! SH bank conflicts: skew spreads a lockstep warp's accesses over the banks.

use rtl::config::{Config, RbSize};
use rtl::stack_manager::Mutant;
use rtl::stack_unit::UnitStats;
use tb::run::verify::invariants::lockstep_bank_load;
use tb::testing::run_lockstep;

fn cfg(name: &str) -> Config {
    name.parse().unwrap()
}

#[test]
fn skew_cuts_lockstep_bank_conflicts() {
    let plain = run_lockstep(cfg("RB_8+SH_8"), |_| {}).conflict_cycles;
    let skewed = run_lockstep(cfg("RB_8+SH_8+SK"), |_| {}).conflict_cycles;
    // Without skew 16 threads share each bank pair (15 extra cycles per access round); with skew
    // 2 do (1 extra cycle): at least a 15-fold cut (measured: 5064 against 248 cycles, 20×,
    // because requests that follow a conflicted one arrive staggered).
    assert!(skewed > 0, "two threads still share each bank pair under skew");
    assert!(plain >= 15 * skewed, "skewed {skewed} vs plain {plain}");
}

/// The lockstep bank-conflict bound, for full 32-thread warps and every M from 1 to 32 (M = 2 is
/// where the planted skew bug is): in lockstep every lane makes the same SH accesses, one access
/// round per micro-op, and a round costs at most `lockstep_bank_load − 1` conflict cycles, the load
/// computed from the skew formula (docs/stack.md, "Skew") and SPEC section 4's bank map in the spec
/// layer. With skew the load is 2 for every M (lanes t and t + 16 share a bank pair); the arbiter
/// and manager never exceed rounds × (load − 1). A skew formula wrong for M = 2 (every lane at
/// `lane % 2`) does.
#[test]
fn lockstep_bank_conflicts_stay_within_the_skew_bound() {
    let bound = |c: &Config, st: &UnitStats| {
        let accesses = st.stack.sh_loads() + st.stack.sh_stores();
        assert!(accesses > 0 && accesses.is_multiple_of(32), "{}: {accesses} SH accesses", c.name());
        (accesses / 32) * (lockstep_bank_load(c, 0) as u64 - 1)
    };
    for m in [1, 2, 4, 8, 16, 32] {
        let c = Config { rb: RbSize::Entries(8), sh_entries: m, skew: true, ..Config::default() };
        assert_eq!(lockstep_bank_load(&c, 0), 2, "{}", c.name());
        let st = run_lockstep(c, |_| {});
        let b = bound(&c, &st);
        println!("{}: {} conflict cycles, bound {b}", c.name(), st.conflict_cycles);
        assert!(
            st.conflict_cycles <= b,
            "{}: {} conflict cycles over the bound {b}",
            c.name(),
            st.conflict_cycles
        );
        let plain = Config { skew: false, ..c };
        let st = run_lockstep(plain, |_| {});
        let b = bound(&plain, &st);
        println!("{}: {} conflict cycles, bound {b}", plain.name(), st.conflict_cycles);
        assert!(st.conflict_cycles <= b, "{}: {} over {b}", plain.name(), st.conflict_cycles);
    }
    let c = cfg("RB_8+SH_2+SK");
    let good = run_lockstep(c, |_| {});
    let bad = run_lockstep(c, |u| {
        u.unit.manager = u.unit.manager.clone().with_mutant(Some(Mutant::SkewWrongForOneM))
    });
    let b = bound(&c, &bad);
    println!(
        "SkewWrongForOneM on {}: {} conflict cycles (correct {}), bound {b}",
        c.name(),
        bad.conflict_cycles,
        good.conflict_cycles
    );
    assert!(
        bad.conflict_cycles > b,
        "SkewWrongForOneM kept within the bound: {} <= {b}",
        bad.conflict_cycles
    );
}
