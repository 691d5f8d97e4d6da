//! Real traversals of real scenes drive the RTL under every configuration of SPEC section 8,
//! scoreboard on: zero mismatches.

use rtl::config::Config;
use rtl::stack_unit::StandaloneStack;
use tb::run::stack_tb::warp_work;
use tb::run::verify::harness::CycleOpts;
use tb::workload::traverse::ChildOrder;

mod common;

fn check_scene(name: &str, res: u32, order: ChildOrder) {
    let Some(scene) = tb::prereq::scene(name) else { return };
    let w = common::small_workload(&scene, res, order);
    let jobs: Vec<_> = w.warp_jobs().collect();
    let deepest = jobs.iter().flat_map(|j| j.lanes.iter().flatten()).map(|t| t.max_depth()).max().unwrap();
    let mut traffic = Vec::new();
    for cfg in Config::paper_set() {
        let mut unit = StandaloneStack::new(cfg, 100).unwrap();
        let o = CycleOpts { max_gap: 8, seed: 1, ..CycleOpts::default() };
        let s = common::run_stack(&mut unit, jobs.iter().map(warp_work), o);
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
