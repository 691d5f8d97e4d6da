//! The whole clocked cycle (`sms prove`'s "whole cycle" obligations): the stack manager's cycle
//! as the simulator runs it (completions, issue, plans, the merge of their writes, the clock
//! edge: `rtl::stack_manager::cycle`) proved equal to the specification's cycle by two
//! solvers, for every control shape of a cycle CI affords; and each planted bug in the cycle
//! code caught, naming the obligation and the part of the next state that differs.
//!
//! The solvers are Debian's `z3` and `boolector` (`.ci/run` installs them); a test fails saying
//! which to install when one is missing.

use std::time::Duration;

use rtl::config::{Config, Realloc};
use rtl::stack_manager::mutants::Mutated;
use rtl::stack_manager::policy::Design;
use rtl::stack_manager::Mutant;
use tb::prove::cycle::{LaneShape, UopKind};
use tb::prove::solver::{Solver, Verdict};
use tb::prove::{cycle_obligations, prove, Obligation};

const LIMIT: Duration = Duration::from_secs(300);

/// Configuration `name` (reallocation with borrow limit 2, flush limit 1) on warps of
/// `warp_size` lanes, `warps` to an RT unit.
fn cfg(name: &str, warp_size: u32, warps: u32) -> Config {
    let base: Config = name.parse().expect("a configuration name");
    let realloc = Some(Realloc { borrow_limit: 2, flush_limit: 1 });
    let c = Config { policy: realloc.into(), warp_size, warps, ..base };
    c.validate().expect("a valid test configuration");
    c
}

fn solvers() -> Vec<Solver> {
    Solver::defaults_installed().unwrap_or_else(|e| panic!("{e}"))
}

/// Two lanes' commands beside a release take minutes (the paths of the two plans multiply):
/// `sms prove` runs them, CI does not.
const SLOW: &str = "push+push";

#[test]
fn the_whole_cycle_equals_the_specifications_cycle_with_two_solvers() {
    let sv = solvers();
    // Chains of 3 with a flush limit on a second warp; M = 16, where an entry needs 4 bits.
    for c in [cfg("RB_2+SH_2+SK+RA", 4, 2), cfg("RB_2+SH_16+SK+RA", 4, 1)] {
        let obs: Vec<Obligation> =
            cycle_obligations(&c).into_iter().filter(|o| !o.name.contains(SLOW)).collect();
        assert!(obs.len() > 30, "every sequencer combination and the command shapes");
        // Every (in flight, completes, queued, latch) combination appears on some lane.
        for acked in [false, true] {
            let lanes: Vec<LaneShape> =
                obs.iter().filter(|o| o.acked == acked).flat_map(|o| o.shape.clone()).collect();
            for head in UopKind::QUEUED {
                for latch in [false, true] {
                    assert!(
                        lanes.iter().any(|x| x.head == Some(head) && x.latch == latch && x.completes),
                        "{head:?} queued behind a completion, latch {latch}"
                    );
                }
            }
        }
        for ob in &obs {
            // Acknowledged stores change only the sequencer; M = 16 only the words addressed.
            if (ob.acked || c.sh_entries == 16) && !ob.name.contains("sequencers") {
                continue;
            }
            for o in prove(&c, &Design, ob, &sv, LIMIT).unwrap() {
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

/// The first obligation (posted stores) whose shape has a lane matching `f`.
fn with_lane(obs: &[Obligation], acked: bool, f: impl Fn(&LaneShape) -> bool) -> Obligation {
    obs.iter().find(|o| o.acked == acked && o.shape.iter().any(&f)).expect("a shape with that lane").clone()
}

#[test]
fn every_planted_bug_in_the_cycle_code_is_caught() {
    let sv = solvers();
    let small = cfg("RB_2+SH_2+SK+RA", 4, 2);
    let wide = cfg("RB_2+SH_16+SK+RA", 4, 1);
    let named = |c: &Config, name: &str| {
        cycle_obligations(c).into_iter().find(|o| !o.acked && o.name.ends_with(name)).expect("the obligation")
    };
    let small_obs = cycle_obligations(&small);
    let wide_obs = cycle_obligations(&wide);
    let completes_then = |k: UopKind| {
        move |x: &LaneShape| x.inflight == Some(UopKind::ShLoad) && x.completes && x.head == Some(k)
    };
    let cases: [(Mutant, &Config, Obligation, &str); 6] = [
        // Write priority: a finish turns a stack Idle and a later lane borrows it in the cycle.
        (Mutant::FirstStackWriteWins, &small, named(&small, "finish+push"), "registers"),
        // Completion against command: the lane whose store completes is still busy.
        (
            Mutant::BusyAfterCompletion,
            &small,
            named(&small, "push beside completions and a release"),
            "answer",
        ),
        // The sequencer.
        (
            Mutant::IssueWaitsACycle,
            &small,
            with_lane(&small_obs, false, completes_then(UopKind::ShLoad)),
            "sequencer",
        ),
        (
            Mutant::IssueReadsOldLatch,
            &small,
            with_lane(&small_obs, false, completes_then(UopKind::ShStoreLatch)),
            "sequencer",
        ),
        // Two completion ports in one cycle.
        (
            Mutant::ResponseDroppedWithShDone,
            &small,
            named(&small, "pop beside completions and a release"),
            "sequencer",
        ),
        // Wide M: an SH store's entry in 3 bits, caught at M = 16.
        (
            Mutant::StoredEntryThreeBits,
            &wide,
            with_lane(&wide_obs, false, |x| x.inflight == Some(UopKind::ShStore) && x.completes),
            "SH word",
        ),
    ];
    // One solver per mutant keeps CI short; both prove the design's obligations above.
    for (m, c, ob, part) in cases {
        for o in prove(c, &Mutated(m), &ob, &sv[1..], LIMIT).unwrap() {
            println!(
                "{:32} {:44} {:10} {:6.1} s: {:?}",
                m.name(),
                o.property,
                o.solver.name(),
                o.seconds,
                o.differ
            );
            assert!(
                matches!(o.verdict, Verdict::Counterexample(_)),
                "{} survived {} ({}): {:?}",
                m.name(),
                o.property,
                o.solver.name(),
                o.verdict
            );
            assert!(
                o.differ.iter().any(|d| d.contains(part)),
                "{}: {} differ, expected {part}",
                m.name(),
                o.differ.join("; ")
            );
        }
        // The design proves the same obligation: the counterexample is the bug's.
        for o in prove(c, &Design, &ob, &sv[..1], LIMIT).unwrap() {
            assert_eq!(o.verdict, Verdict::Proved, "the design: {}", o.property);
        }
    }
    // The wide-M bug is invisible at M = 2 (entries fit 3 bits): only the M = 16 case shows it.
    let ob = with_lane(&small_obs, false, |x| x.inflight == Some(UopKind::ShStore) && x.completes);
    for o in prove(&small, &Mutated(Mutant::StoredEntryThreeBits), &ob, &sv[..1], LIMIT).unwrap() {
        assert_eq!(o.verdict, Verdict::Proved, "M = 2 cannot show a 3-bit entry");
    }
}
