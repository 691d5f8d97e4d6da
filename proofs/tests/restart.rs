//! The restart designs' stack (`+RT`: drop the oldest entry on overflow, answer Restart when
//! popped empty after a drop) through the same layers as the paper's designs: every restart
//! configuration explored to its fixpoint with every cover goal, the drop decisions checked
//! against the specification's restart rows, and the planted drop bugs caught.

use rtl::config::Overflow;
use rtl::stack_manager::Mutant;
use tb::run::verify::exhaustive::{check, default_cap, describe, restart_configs, Bounds, Goal};
use tb::run::verify::invariants::Property;

#[test]
fn restart_configurations_reach_their_fixpoint_with_every_cover() {
    let configs = restart_configs();
    assert_eq!(configs.len(), 4);
    for c in &configs {
        assert_eq!(c.overflow, Overflow::Drop, "{}", c.name());
        let cov = check(*c, Bounds::fixpoint(default_cap(c)), |sm| sm)
            .unwrap_or_else(|e| panic!("{}: {e}", describe(c)));
        println!(
            "{:48} states {:8} depth {:3} in {:>7.2?} drops {} restarts {}",
            describe(c),
            cov.states,
            cov.depth_reached,
            cov.elapsed,
            cov.covers.count(Goal::Drop),
            cov.covers.count(Goal::Restart)
        );
        assert!(cov.fixpoint, "{}: no fixpoint", describe(c));
        assert_eq!(cov.covers.missing(c), vec![], "{}: cover goals never reached", describe(c));
        assert_eq!(cov.global_reloads, 0, "{}: a restart design never reloads", describe(c));
    }
}

/// Each planted drop bug on every restart configuration where it can act: caught, and by the
/// property a reader would name for it.
#[test]
fn the_drop_bugs_are_caught_on_every_restart_configuration() {
    let bugs = [
        (Mutant::DropsNewest, &[Property::RequestSequence][..], true),
        (Mutant::DropForgetsOverflow, &[Property::Overflow, Property::Equivalence][..], false),
        (Mutant::RestartKeepsOverflow, &[Property::Overflow][..], false),
        (Mutant::RestartWithoutDrop, &[Property::Equivalence][..], false),
    ];
    for c in restart_configs() {
        for &(m, props, needs_sh) in &bugs {
            if needs_sh && c.sh_entries == 0 {
                continue;
            }
            let cex = check(c, Bounds::fixpoint(default_cap(&c)), |sm| sm.with_mutant(Some(m)))
                .err()
                .unwrap_or_else(|| panic!("{m:?} survived {}", describe(&c)));
            println!("{:24} {:44} caught by {:?}", m.name(), describe(&c), cex.violation.property);
            assert!(props.contains(&cex.violation.property), "{m:?} on {}: {cex}", describe(&c));
        }
    }
}

fn restart(name: &str, warp_size: u32, warps: u32) -> rtl::config::Config {
    let c = rtl::config::Config { warp_size, warps, ..name.parse::<rtl::config::Config>().unwrap() };
    let mut c = c;
    if let Some(ra) = c.policy.realloc_mut() {
        *ra = rtl::config::Realloc { borrow_limit: 1, flush_limit: 1 };
    }
    c.validate().expect("a valid test configuration");
    c
}

/// The restart designs' decision logic equals the specification's restart rows (written from
/// the description of dropping and restarting, not from the policy's code), keeps the
/// invariant, and keeps the newest entries in order through pushes and pops: every one-step,
/// induction and conservation obligation, with two solvers, on an RB alone and on SMS with
/// reallocation (4 lanes, the second warp).
#[test]
fn the_restart_decisions_equal_their_specification_with_two_solvers() {
    use tb::prove::solver::{Solver, Verdict};
    use tb::prove::{obligations, prove};
    let sv = Solver::defaults_installed().unwrap_or_else(|e| panic!("{e}"));
    let limit = std::time::Duration::from_secs(300);
    for c in [restart("RB_2+RT", 4, 2), restart("RB_2+SH_2+SK+RA+RT", 4, 2)] {
        let obs: Vec<_> = obligations(&c)
            .into_iter()
            .filter(|o| {
                ["one-step", "invariant kept by", "conservation"].iter().any(|w| o.name.starts_with(w))
            })
            .collect();
        assert_eq!(obs.len(), 10, "{}", c.name());
        for ob in obs {
            for o in prove(&c, &rtl::stack_manager::policy::Design, &ob, &sv, limit).unwrap() {
                println!("{:44} {:24} {:10} {:6.1} s", o.property, c.name(), o.solver.name(), o.seconds);
                assert_eq!(
                    o.verdict,
                    Verdict::Proved,
                    "{} at {} by {}",
                    o.property,
                    c.name(),
                    o.solver.name()
                );
            }
        }
    }
}

/// The planted drop bugs, refuted by the solver from any well-formed state: each with the
/// obligation and the compared part that names it.
#[test]
fn the_drop_bugs_are_refuted_by_the_solver() {
    use rtl::stack_manager::mutants::Mutated;
    use tb::prove::solver::{Solver, Verdict};
    use tb::prove::{obligations, prove};
    let sv = Solver::defaults_installed().unwrap_or_else(|e| panic!("{e}"));
    let limit = std::time::Duration::from_secs(300);
    let sh = restart("RB_2+SH_2+RT", 4, 1);
    let rb = restart("RB_2+RT", 4, 1);
    let table = [
        (Mutant::DropsNewest, sh, "conservation through push", "tracked entry"),
        (Mutant::DropsNewest, sh, "one-step push", "program"),
        (Mutant::DropForgetsOverflow, rb, "one-step push", "Overflow"),
        (Mutant::DropForgetsOverflow, sh, "one-step push", "Overflow"),
        (Mutant::RestartKeepsOverflow, rb, "one-step pop", "Overflow"),
        (Mutant::RestartWithoutDrop, sh, "one-step pop", "answer"),
    ];
    for (m, c, property, part) in table {
        let ob = obligations(&c).into_iter().find(|o| o.name == property).expect("the obligation exists");
        for o in prove(&c, &Mutated(m), &ob, &sv[..1], limit).unwrap() {
            println!("{:24} {:14} {:28} {:?}", m.name(), c.name(), property, o.differ);
            assert!(
                matches!(o.verdict, Verdict::Counterexample(_)),
                "{m:?} survived {property}: {:?}",
                o.verdict
            );
            assert!(
                o.differ.iter().any(|d| d.contains(part)),
                "{m:?}: {} differ, expected {part}",
                o.differ.join("; ")
            );
        }
    }
}
