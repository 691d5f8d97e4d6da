//! Stack policies other than the paper's, on real traversals: reallocation within groups of G
//! lanes (`+RA_G`). A group as wide as the warp is the paper's policy, bit for bit; narrower
//! groups borrow less and flush more, and every decision agrees with the specification's
//! group rows; a manager that searches the whole warp under a group configuration is caught.

use rtl::config::Config;
use rtl::gpu::Gpu;
use rtl::rt_unit::RunError;
use rtl::stack_manager::policy::Design;
use rtl::stack_manager::StackPolicy;
use rtl::trace::NullSink;
use tb::prove::scoreboard::SpecBoard;
use tb::testing::{bits, report, scene_jobs, synthetic_jobs};

fn board() -> Box<dyn rtl::stack_manager::Scoreboard> {
    Box::new(SpecBoard::every(1))
}

fn cfg(name: &str) -> Config {
    name.parse().unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn a_group_as_wide_as_the_warp_runs_exactly_as_the_paper() {
    let jobs = scene_jobs("clutter", 32);
    let paper = report(Gpu::paper(cfg("RB_2+SH_8+SK+RA")).unwrap(), jobs.clone(), "RA");
    let whole = report(Gpu::paper(cfg("RB_2+SH_8+SK+RA_32")).unwrap(), jobs.clone(), "RA_32");
    assert!(paper.stack.borrows > 0, "the workload never borrows: {:?}", paper.stack);
    assert_eq!(bits(&paper), bits(&whole));
    // Groups of 4 lanes: three stacks to lend at most, found among fewer lanes.
    let quads = report(Gpu::paper(cfg("RB_2+SH_8+SK+RA_4")).unwrap(), jobs, "RA_4");
    assert_ne!(bits(&paper), bits(&quads));
    assert!(quads.stack.borrows > 0, "{:?}", quads.stack);
}

#[test]
fn every_group_decision_agrees_with_the_specification() {
    let work = synthetic_jobs(8, 8, 45);
    for name in ["RB_1+SH_2+SK+RA_2", "RB_2+SH_4+SK+RA_4", "RB_1+SH_2+SK+RA_8"] {
        let r = Gpu::paper(cfg(name)).unwrap().with_scoreboard(&board).run(work.clone(), &mut NullSink);
        let r = r.unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(r.stack.borrows > 0, "{name}: no borrow to check: {:?}", r.stack);
    }
}

/// The paper's implementation under a group configuration borrows the lowest idle stack of the
/// whole warp: every entry still lands right (the data checks pass), but the decision is not the
/// group policy's, and the scoreboard names it.
#[test]
fn a_group_whose_search_spans_the_warp_is_caught() {
    let work = synthetic_jobs(8, 8, 45);
    let c = cfg("RB_1+SH_2+SK+RA_2");
    let wrong = || Gpu::paper_with(c, StackPolicy::new(Design)).unwrap();
    let r = wrong().run(work.clone(), &mut NullSink);
    assert!(r.is_ok(), "the data checks alone already fail: {r:?}");
    match wrong().with_scoreboard(&board).run(work, &mut NullSink) {
        Err(RunError::Decision { what, .. }) => println!("caught: {what}"),
        other => panic!("a warp-wide search under RA_2 went unnoticed: {other:?}"),
    }
}

#[test]
fn the_verilog_printer_refuses_a_group_policy_in_one_line() {
    let e = tb::verilog::generate(&cfg("RB_2+SH_2+SK+RA_2"), false)
        .err()
        .expect("printed a policy it does not print");
    assert!(e.contains("RA_2") && e.contains("not printed") && !e.contains('\n'), "{e}");
}
