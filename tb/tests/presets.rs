//! Hardware presets. The `legacy` preset, with `--accel flat --order nearest --path-end always`,
//! reproduces the reports of the model without the Vulkan-Sim mechanisms, bit for bit (numbers from
//! `sms run` at commit e21cd48); the default (`paper`) differs from it in the way the mechanisms
//! say.

use tb::hw::{preset, Hardware};
use tb::run::sim::{Fidelity, Outcome};
use tb::workload::traverse::ChildOrder;
use tb::workload::{Accel, PathEnd, Workload, WorkloadOpts};

fn old_workload(scene: &tb::Scene) -> Workload<'_> {
    let opts = WorkloadOpts {
        width: 64,
        height: 64,
        spp: 1,
        max_bounces: 2,
        accel: Accel::Flat,
        order: ChildOrder::Nearest,
        path_end: PathEnd::Always,
        ..WorkloadOpts::for_scene(scene)
    };
    Workload::new(scene, opts).unwrap()
}

mod common;

fn run(name: &str, hw: Hardware, w: &Workload) -> Outcome {
    common::simulate(name.parse().unwrap(), hw, Fidelity::Cycle, w)
}

#[test]
fn legacy_preset_reproduces_the_old_model() {
    let scene = tb::load_scene("clutter").unwrap();
    let w = old_workload(&scene);
    assert_eq!(w.num_rays(), 8981);
    let legacy = preset("legacy").unwrap();
    // (configuration, cycles, DRAM accesses of stack traffic, bank-conflict cycles) at e21cd48.
    for (name, cycles, dram_stack, conflicts) in [("RB_2", 178_122, 45_961, 0), ("RB_8+SH_8", 164_307, 0, 94)]
    {
        let g = run(name, legacy, &w).gpu.unwrap();
        assert_eq!(
            (g.cycles, g.dram_stack, g.bank_conflict_cycles),
            (cycles, dram_stack, conflicts),
            "{name}"
        );
    }
    // The paper preset times the same traces differently: blocking stack traffic and the
    // Vulkan-Sim memory path keep RB_2's spills out of DRAM.
    let paper = run("RB_2", Hardware::default(), &w).gpu.unwrap();
    assert_ne!(paper.cycles, 178_122);
    assert!(paper.dram_stack < 45_961 / 10, "interleaved local memory and IPOLY: {}", paper.dram_stack);
}
