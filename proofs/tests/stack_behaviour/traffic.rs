//! The stack traffic each configuration makes.

use rtl::config::{Config, RbSize};
use rtl::stack_manager::StackManager;
use rtl::stack_unit::StandaloneStack;
use tb::run::stack_tb::warp_work;
use tb::run::verify::harness::{run_functional_warps, CycleOpts, Op};
use tb::run::verify::streams::warps;
use tb::testing::{run_stack, small_workload, stack_opts};
use tb::workload::traverse::ChildOrder;

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
        let c = Config { rb: RbSize::Entries(n), ..Config::default() };
        let (mut spills, mut reloads) = (0, 0);
        for lane in work.iter().flat_map(|w| w.lanes.iter().flatten()) {
            let (s, r) = baseline_traffic(n as usize, lane);
            spills += s;
            reloads += r;
        }
        let mut unit = StandaloneStack::new(c, 50).unwrap();
        let st = run_stack(&mut unit, work.clone(), stack_opts(1)).stats.stack;
        assert!(spills > 0);
        assert_eq!((st.rb_to_global, st.global_to_rb), (spills, reloads), "RB_{n}");
        assert_eq!(st.sh_loads() + st.sh_stores(), 0);
    }
}

#[test]
fn full_rb_never_spills() {
    let mut unit = StandaloneStack::new("RB_FULL".parse().unwrap(), 50).unwrap();
    let s = run_stack(&mut unit, warps(4, 4, 32, 200), stack_opts(2));
    assert_eq!(s.stats.stack.global_accesses() + s.stats.stack.sh_loads() + s.stats.stack.sh_stores(), 0);
    assert!(s.pops_checked > 10_000);
}

#[test]
fn functional_level_counts_equal_the_cycle_level_without_reallocation() {
    let work = warps(5, 6, 32, 120);
    for c in Config::paper_set().into_iter().filter(|c| c.realloc().is_none()) {
        let mut unit = StandaloneStack::new(c, 50).unwrap();
        let cycle = run_stack(&mut unit, work.clone(), stack_opts(3)).stats.stack;
        let mut sm = StackManager::new(c, 0).unwrap();
        run_functional_warps(&mut sm, work.clone()).unwrap();
        assert_eq!(sm.stats, cycle, "{}", c.name());
    }
}

/// Real traversals of scene `name` drive the stack unit under every configuration of SPEC
/// section 8, scoreboard on: zero mismatches, and a scene deeper than 8 spills RB_8.
fn check_scene(name: &str, res: u32, order: ChildOrder) {
    let Some(scene) = tb::prereq::scene(name) else { return };
    let w = small_workload(&scene, res, order);
    let jobs: Vec<_> = w.warp_jobs().collect();
    let deepest = jobs.iter().flat_map(|j| j.lanes.iter().flatten()).map(|t| t.max_depth()).max().unwrap();
    let mut traffic = Vec::new();
    for cfg in Config::paper_set() {
        let mut unit = StandaloneStack::new(cfg, 100).unwrap();
        let o = CycleOpts { max_gap: 8, seed: 1, ..CycleOpts::default() };
        let s = run_stack(&mut unit, jobs.iter().map(warp_work), o);
        assert!(s.pops_checked > 500, "{name}: {} pops", s.pops_checked);
        traffic.push((cfg.name(), s.stats.stack.global_accesses()));
    }
    println!("{name} ({order:?}): deepest stack {deepest}; off-chip stack accesses {traffic:?}");
    if deepest > 8 {
        assert!(
            traffic.iter().find(|t| t.0 == "RB_8").unwrap().1 > 0,
            "{name}: depth {deepest} must spill RB_8"
        );
    }
}

#[test]
fn ship_under_every_configuration() {
    check_scene("ship", 24, ChildOrder::Nearest);
}

#[test]
fn builtin_scenes_under_every_configuration() {
    check_scene("wknd", 16, ChildOrder::VulkanSim);
    check_scene("clutter", 16, ChildOrder::Nearest);
}
