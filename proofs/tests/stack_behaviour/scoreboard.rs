//! The scoreboard catches planted stack-manager bugs on random streams, and the design passes
//! the same runs.

use rtl::config::Config;
use rtl::stack_manager::Mutant;
use rtl::stack_unit::StandaloneStack;
use tb::run::verify::invariants::Property;
use tb::run::verify::streams::warps;
use tb::testing::{run_stack, stack_opts, violated};

fn cfg(name: &str) -> Config {
    name.parse().unwrap()
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
        let mut unit = StandaloneStack::new(cfg(c), 30).unwrap();
        unit.unit.manager = unit.unit.manager.clone().with_mutant(Some(m));
        let p = violated(&mut unit, warps(8, 4, 32, 90), stack_opts(6));
        assert!(matches!(p, Property::Equivalence | Property::WarpExit), "{m:?} caught by {p:?}");
    }
}

#[test]
fn the_unmutated_design_passes_the_same_runs() {
    for c in ["RB_4+SH_8", "RB_4+SH_4+SK+RA", "RB_4+SH_4"] {
        let mut unit = StandaloneStack::new(cfg(c), 30).unwrap();
        run_stack(&mut unit, warps(8, 4, 32, 90), stack_opts(6));
    }
}
