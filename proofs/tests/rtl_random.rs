//! Long random runs: 4 warps × 32 threads of random streams with depths past 100,
//! through the cycle-level RTL, for every configuration of SPEC section 8, scoreboard on.

use rtl::config::Config;
use rtl::stack_manager::StackTiming;
use rtl::stack_unit::StandaloneStack;
use tb::run::verify::harness::{CycleOpts, RunSummary};
use tb::run::verify::streams::warps;
use tb::testing::run_stack;

fn run(cfg: Config, seed: u64, warp_count: u32, check_every_cycle: bool) -> RunSummary {
    run_timed(StandaloneStack::new(cfg, 40).unwrap(), seed, warp_count, check_every_cycle)
}

fn run_timed(mut unit: StandaloneStack, seed: u64, warp_count: u32, check_every_cycle: bool) -> RunSummary {
    let cfg = *unit.manager().config();
    let work = warps(seed, warp_count, cfg.warp_size, 130);
    let opts = CycleOpts { max_gap: 6, seed, check_every_cycle, max_cycles: 50_000_000, lockstep: false };
    run_stack(&mut unit, work, opts)
}

#[test]
fn every_paper_configuration_matches_the_reference() {
    for cfg in Config::paper_set() {
        let s = run(cfg, 7, 8, false);
        assert!(s.pops_checked > 50_000, "{}: {} pops", cfg.name(), s.pops_checked);
        let st = s.stats.stack;
        match cfg.rb.capacity() {
            None => assert_eq!(st.global_accesses() + st.sh_loads() + st.sh_stores(), 0, "FULL never spills"),
            Some(_) => {
                assert!(st.global_accesses() > 0, "{}: depth 130 must reach global memory", cfg.name())
            }
        }
        if cfg.realloc().is_some() {
            assert!(st.borrows > 0 && st.releases > 0, "{}: {st:?}", cfg.name());
            assert!(st.flushes > 0 && st.global_to_sh > 0, "{}: {st:?}", cfg.name());
            assert!(st.demotions > 0, "{}: {st:?}", cfg.name());
        }
    }
}

#[test]
fn every_cycle_checks_hold_on_the_full_sms() {
    for cfg in [Config::sms(), "RB_2+SH_8+SK+RA".parse().unwrap(), "RB_8+SH_4".parse().unwrap()] {
        let s = run(cfg, 11, 4, true);
        assert!(s.stats.stack.flushes_saturated > 0 || cfg.realloc().is_none() || s.stats.stack.flushes > 0);
    }
}

/// Acknowledged global stores (Blocking) and the 20-cycle SH latency keep every pop
/// right and every per-cycle invariant, and only cost time.
#[test]
fn acknowledged_stores_and_sh_latency_keep_the_checks() {
    for cfg in [Config::sms(), "RB_2+SH_4".parse().unwrap(), "RB_2".parse().unwrap()] {
        let old = run(cfg, 13, 4, false);
        let unit = StandaloneStack::with_timing(cfg, 40, StackTiming::Blocking, 20).unwrap();
        let new = run_timed(unit, 13, 4, true);
        assert_eq!(new.pops_checked, old.pops_checked, "{}", cfg.name());
        assert!(
            new.stats.cycles > old.stats.cycles,
            "{}: {} vs {}",
            cfg.name(),
            new.stats.cycles,
            old.stats.cycles
        );
    }
}
