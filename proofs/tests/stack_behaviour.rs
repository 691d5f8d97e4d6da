//! Behaviour the stack design must show on random and lockstep streams: the M = 0 baseline, no
//! spills with FULL, skew against bank conflicts, functional = cycle level without RA, and
//! planted bugs caught by the scoreboard.

use rtl::config::Config;
use rtl::stack_manager::{Mutant, StackManager};
use rtl::stack_unit::StandaloneStack;
use rtl::trace::NullSink;
use tb::run::verify::harness::{run_cycle, run_functional_warps, CycleOpts, HarnessError, Op, WarpWork};
use tb::run::verify::invariants::Property;
use tb::run::verify::streams::{stream, warps};
use tb::testing::run_stack;

fn cfg(name: &str) -> Config {
    name.parse().unwrap()
}

fn opts(seed: u64) -> CycleOpts {
    CycleOpts { max_gap: 6, seed, check_every_cycle: false, max_cycles: 20_000_000, lockstep: false }
}

/// The textbook short stack: N entries on chip, the oldest spilled to global when full, reloaded
/// on a pop when global holds entries. Returns (spills, reloads).
fn baseline_traffic(n: usize, ops: &[Op]) -> (u64, u64) {
    let (mut on_chip, mut global, mut spills, mut reloads) = (0usize, 0usize, 0, 0);
    for op in ops {
        match op {
            Op::Push(_) if on_chip == n => {
                global += 1;
                spills += 1;
            }
            Op::Push(_) => on_chip += 1,
            Op::Pop => {
                on_chip -= 1;
                if global > 0 {
                    global -= 1;
                    on_chip += 1;
                    reloads += 1;
                }
            }
        }
    }
    (spills, reloads)
}

#[test]
fn without_sh_the_traffic_is_the_baseline_short_stack() {
    let work = warps(3, 6, 32, 100);
    for n in [1, 2, 8, 16] {
        let c = Config { rb: rtl::config::RbSize::Entries(n), ..Config::default() };
        let (mut spills, mut reloads) = (0, 0);
        for lane in work.iter().flat_map(|w| w.lanes.iter().flatten()) {
            let (s, r) = baseline_traffic(n as usize, lane);
            spills += s;
            reloads += r;
        }
        let mut unit = StandaloneStack::new(c, 50).unwrap();
        let st = run_stack(&mut unit, work.clone(), opts(1)).stats.stack;
        assert!(spills > 0);
        assert_eq!((st.rb_to_global, st.global_to_rb), (spills, reloads), "RB_{n}");
        assert_eq!(st.sh_loads() + st.sh_stores(), 0);
    }
}

#[test]
fn full_rb_never_spills() {
    let mut unit = StandaloneStack::new(cfg("RB_FULL"), 50).unwrap();
    let s = run_stack(&mut unit, warps(4, 4, 32, 200), opts(2));
    assert_eq!(s.stats.stack.global_accesses() + s.stats.stack.sh_loads() + s.stats.stack.sh_stores(), 0);
    assert!(s.pops_checked > 10_000);
}

#[test]
fn functional_level_counts_equal_the_cycle_level_without_reallocation() {
    let work = warps(5, 6, 32, 120);
    for c in Config::paper_set().into_iter().filter(|c| c.realloc.is_none()) {
        let mut unit = StandaloneStack::new(c, 50).unwrap();
        let cycle = run_stack(&mut unit, work.clone(), opts(3)).stats.stack;
        let mut sm = StackManager::new(c, 0).unwrap();
        run_functional_warps(&mut sm, work.clone()).unwrap();
        assert_eq!(sm.stats, cycle, "{}", c.name());
    }
}

/// All 32 lanes run the same stream in lockstep: every SH access of a round hits the same entry
/// index in every thread's queue.
fn lockstep_conflicts(c: Config) -> u64 {
    let s = stream(9, 40);
    let work = vec![WarpWork { lanes: vec![Some(s); 32] }];
    let mut unit = StandaloneStack::new(Config { warps: 1, ..c }, 50).unwrap();
    let o = CycleOpts { max_gap: 0, lockstep: true, ..opts(4) };
    run_stack(&mut unit, work, o).stats.conflict_cycles
}

#[test]
fn skew_cuts_lockstep_bank_conflicts() {
    let plain = lockstep_conflicts(cfg("RB_8+SH_8"));
    let skewed = lockstep_conflicts(cfg("RB_8+SH_8+SK"));
    // Without skew 16 threads share each bank pair (15 extra cycles per access round); with skew
    // 2 do (1 extra cycle): at least a 15-fold cut (measured: 5064 against 248 cycles, 20×,
    // because requests that follow a conflicted one arrive staggered).
    assert!(skewed > 0, "two threads still share each bank pair under skew");
    assert!(plain >= 15 * skewed, "skewed {skewed} vs plain {plain}");
}

fn caught(c: Config, m: Mutant) -> Property {
    let mut unit = StandaloneStack::new(c, 30).unwrap();
    unit.unit.manager = unit.unit.manager.clone().with_mutant(Some(m));
    let o = CycleOpts { check_every_cycle: false, ..opts(6) };
    match run_cycle(&mut unit, warps(8, 4, 32, 90), o, &mut NullSink) {
        Err(HarnessError::Violation { violation, .. }) => violation.property,
        other => panic!("{m:?} on {} escaped the scoreboard: {other:?}", c.name()),
    }
}

#[test]
fn the_scoreboard_catches_planted_bugs() {
    for (c, m) in [
        ("RB_4+SH_8", Mutant::ReloadWrongEntry),
        ("RB_4+SH_8", Mutant::SpillDropsEntry),
        ("RB_4+SH_4+SK+RA", Mutant::EarlyRelease),
        ("RB_4+SH_4", Mutant::QueueWrapOffByOne),
        ("RB_4+SH_4", Mutant::MissingGlobalReload),
    ] {
        let p = caught(cfg(c), m);
        assert!(matches!(p, Property::Equivalence | Property::WarpExit), "{m:?} caught by {p:?}");
    }
}

#[test]
fn the_unmutated_design_passes_the_same_runs() {
    for c in ["RB_4+SH_8", "RB_4+SH_4+SK+RA", "RB_4+SH_4"] {
        let mut unit = StandaloneStack::new(cfg(c), 30).unwrap();
        run_stack(&mut unit, warps(8, 4, 32, 90), opts(6));
    }
}

/// All 32 lanes of one warp run the same stream in lockstep through the cycle-level unit
/// (optionally with a planted bug): the run's stats.
fn lockstep_run(c: Config, m: Option<Mutant>) -> rtl::stack_unit::UnitStats {
    let s = stream(9, 40);
    let work = vec![WarpWork { lanes: vec![Some(s); 32] }];
    let mut unit = StandaloneStack::new(Config { warps: 1, ..c }, 50).unwrap();
    unit.unit.manager = unit.unit.manager.clone().with_mutant(m);
    let o = CycleOpts { max_gap: 0, lockstep: true, ..opts(4) };
    run_stack(&mut unit, work, o).stats
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
    use tb::run::verify::invariants::lockstep_bank_load;
    let bound = |c: &Config, st: &rtl::stack_unit::UnitStats| {
        let accesses = st.stack.sh_loads() + st.stack.sh_stores();
        assert!(accesses > 0 && accesses.is_multiple_of(32), "{}: {accesses} SH accesses", c.name());
        (accesses / 32) * (lockstep_bank_load(c, 0) as u64 - 1)
    };
    for m in [1, 2, 4, 8, 16, 32] {
        let c =
            Config { rb: rtl::config::RbSize::Entries(8), sh_entries: m, skew: true, ..Config::default() };
        assert_eq!(lockstep_bank_load(&c, 0), 2, "{}", c.name());
        let st = lockstep_run(c, None);
        let b = bound(&c, &st);
        println!("{}: {} conflict cycles, bound {b}", c.name(), st.conflict_cycles);
        assert!(
            st.conflict_cycles <= b,
            "{}: {} conflict cycles over the bound {b}",
            c.name(),
            st.conflict_cycles
        );
        let plain = Config { skew: false, ..c };
        let st = lockstep_run(plain, None);
        let b = bound(&plain, &st);
        println!("{}: {} conflict cycles, bound {b}", plain.name(), st.conflict_cycles);
        assert!(st.conflict_cycles <= b, "{}: {} over {b}", plain.name(), st.conflict_cycles);
    }
    let c: Config = "RB_8+SH_2+SK".parse().unwrap();
    let good = lockstep_run(c, None);
    let bad = lockstep_run(c, Some(Mutant::SkewWrongForOneM));
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
