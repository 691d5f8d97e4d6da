//! A second stack policy, reallocation within groups of G lanes (`+RA_G`), through the same
//! layers as the paper's: explored to its fixpoint with every cover goal, proved equal to the
//! specification's group rows by two solvers, and the paper's warp-wide search planted in its
//! place caught by each layer.

use std::time::Duration;

use rtl::config::{Config, RbSize, Realloc, ShPolicy};
use rtl::stack_manager::group::Group;
use rtl::stack_manager::policy::Design;
use rtl::stack_manager::StackPolicy;
use tb::prove::solver::{Solver, Verdict};
use tb::prove::{obligations, prove};
use tb::run::verify::exhaustive::{check, default_cap, describe, group_configs, Bounds};
use tb::run::verify::invariants::Property;

const LIMIT: Duration = Duration::from_secs(300);

#[test]
fn group_configurations_reach_their_fixpoint_with_every_cover() {
    let configs = group_configs();
    assert!(!configs.is_empty());
    for c in &configs {
        assert!(matches!(c.policy, ShPolicy::Group { lanes: 2, .. }), "{}", c.name());
        let cov = check(*c, Bounds::fixpoint(default_cap(c)), |sm| sm)
            .unwrap_or_else(|e| panic!("{}: {e}", describe(c)));
        println!(
            "{:48} states {:8} depth {:3} in {:>7.2?}",
            describe(c),
            cov.states,
            cov.depth_reached,
            cov.elapsed
        );
        assert!(cov.fixpoint, "{}: no fixpoint", describe(c));
        assert_eq!(cov.covers.missing(c), vec![], "{}: cover goals never reached", describe(c));
        assert!(cov.borrows > 0 && cov.flushes > 0, "{}: {cov:?}", describe(c));
    }
}

/// The paper's implementation under a group configuration lends a stack from the other group:
/// the request-sequence property (SPEC's case table, group rows included) names the decision;
/// without it, the chain property names the stack that left its group.
#[test]
fn a_warp_wide_search_under_a_group_policy_is_caught_by_the_search() {
    let c = group_configs()[0];
    let wide = |sm: rtl::stack_manager::StackManager| sm.with_policy(StackPolicy::new(Design));
    let b = Bounds::fixpoint(default_cap(&c));
    let cex = check(c, b, wide).expect_err("the warp-wide search survived");
    println!("{cex}");
    assert_eq!(cex.violation.property, Property::RequestSequence, "{cex}");
    let cex =
        check(c, Bounds { request_sequence: false, ..b }, wide).expect_err("survived the state properties");
    println!("{cex}");
    assert_eq!(cex.violation.property, Property::Chains, "{cex}");
    assert!(cex.violation.detail.contains("outside its group"), "{cex}");
}

fn group(rb: u32, m: u32, lanes: u32, borrow: u32, warp_size: u32, warps: u32) -> Config {
    let c = Config {
        rb: RbSize::Entries(rb),
        sh_entries: m,
        skew: true,
        policy: ShPolicy::Group { ra: Realloc { borrow_limit: borrow, flush_limit: 1 }, lanes },
        warp_size,
        warps,
        ..Config::default()
    };
    c.validate().expect("a valid test configuration");
    c
}

#[test]
fn the_group_policy_equals_its_specification_with_two_solvers() {
    let sv = Solver::defaults_installed().unwrap_or_else(|e| panic!("{e}"));
    // Groups of 2 in a 4-lane warp (the second warp, so thread ids differ from lanes): every
    // one-step equivalence and the invariant's induction step; groups of 4 in an 8-lane warp
    // with chains of three: one command. The whole-cycle and conservation obligations take the
    // solvers minutes each here: `sms prove -c RB_2+SH_2+SK+RA_2 --warp-size 4 --warps 2` runs
    // them, CI does not.
    let cases: [(Config, &[&str]); 2] = [
        (group(2, 2, 2, 1, 4, 2), &["one-step", "invariant kept by"]),
        (group(1, 2, 4, 2, 8, 1), &["one-step push", "one-step pop", "one-step finish"]),
    ];
    for (c, wanted) in cases {
        let obs: Vec<_> =
            obligations(&c).into_iter().filter(|o| wanted.iter().any(|w| o.name.starts_with(w))).collect();
        assert!(obs.len() >= wanted.len(), "{}: {} obligations", c.name(), obs.len());
        for ob in obs {
            for o in prove(&c, &Group, &ob, &sv, LIMIT).unwrap() {
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

#[test]
fn a_warp_wide_search_under_a_group_policy_is_refuted_by_the_solver() {
    let sv = Solver::defaults_installed().unwrap_or_else(|e| panic!("{e}"));
    let c = group(2, 2, 2, 1, 4, 2);
    let ob = obligations(&c).into_iter().find(|o| o.name == "one-step push").expect("a push obligation");
    let outs = prove(&c, &Design, &ob, &sv[..1], LIMIT).unwrap();
    assert!(
        outs.iter().any(|o| matches!(o.verdict, Verdict::Counterexample(_))),
        "the paper's search proved equal to the group rows: {:?}",
        outs.iter().map(|o| &o.verdict).collect::<Vec<_>>()
    );
}
