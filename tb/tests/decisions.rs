//! The decision scoreboard of cycle-level runs (`sms --decisions`): the specification's cycle
//! beside every stack-manager cycle. A design that keeps every entry right but decides
//! differently (flushes where it may borrow, issues a cycle late) passes every data check of a
//! run (each pop against the trace, each warp at exit); the scoreboard names the cycle, lane
//! and property. A design that addresses past the register arrays stops the run with a checked
//! error, not a panic.

use rtl::config::Config;
use rtl::gpu::Gpu;
use rtl::rt_unit::RunError;
use rtl::stack_manager::Mutant;
use rtl::trace::NullSink;
use tb::prove::scoreboard::SpecBoard;
use tb::testing::{run_gpu_guarded, synthetic_jobs};

fn board() -> Box<dyn rtl::stack_manager::Scoreboard> {
    Box::new(SpecBoard::every(1))
}

#[test]
fn the_design_agrees_with_the_specification_every_cycle() {
    let work = synthetic_jobs(8, 8, 45);
    for cfg in ["RB_2", "RB_2+SH_4", "RB_2+SH_4+SK+RA", "RB_1+SH_2+SK+RA"] {
        let c: Config = cfg.parse().unwrap();
        let r = Gpu::paper(c).unwrap().with_scoreboard(&board).run(work.clone(), &mut NullSink);
        assert!(r.is_ok(), "{cfg}: {r:?}");
    }
}

#[test]
fn the_scoreboard_catches_decisions_the_data_checks_miss() {
    let work = synthetic_jobs(8, 8, 45);
    let cases = [
        (Mutant::FlushBeforeLastBorrow, "RB_1+SH_2+SK+RA", "stack registers"),
        (Mutant::IssueWaitsACycle, "RB_2+SH_4", "sequencer"),
    ];
    for (m, cfg, what) in cases {
        let c: Config = cfg.parse().unwrap();
        // Every entry lands right: the data checks pass.
        let r = Gpu::paper_with(c, m.policy()).unwrap().run(work.clone(), &mut NullSink);
        assert!(r.is_ok(), "{m:?} on {cfg} without the scoreboard: {r:?}");
        let r =
            Gpu::paper_with(c, m.policy()).unwrap().with_scoreboard(&board).run(work.clone(), &mut NullSink);
        match r {
            Err(RunError::Decision { what: msg, .. }) => {
                println!("{m:?} on {cfg}: {msg}");
                assert!(msg.contains(what), "{m:?}: {msg}");
                assert!(msg.starts_with("cycle ") && msg.contains(", lane "), "{msg}");
            }
            other => panic!("{m:?} on {cfg}: the scoreboard let it pass: {other:?}"),
        }
    }
}

#[test]
fn a_design_that_addresses_past_its_registers_is_a_checked_error() {
    // Borrowing links the owner to the lent stack's RT-unit thread id instead of its lane: in
    // warps 2 and 3 the chain then names stacks past the 128 the RT unit has.
    let work = synthetic_jobs(8, 16, 60);
    let c: Config = "RB_1+SH_1+SK+RA".parse().unwrap();
    let gpu = Gpu::paper_with(c, Mutant::LinkWithThreadId.policy()).unwrap();
    let r = run_gpu_guarded(gpu, work).expect("a checked error, not a panic");
    assert!(r.is_err(), "the planted bug went unnoticed");
    println!("{r:?}");
}

#[test]
fn a_run_report_says_how_many_decisions_it_checked() {
    let row = |mode: &str| {
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_sms"))
            .args(["-q", "--decisions", mode, "run", "--res", "8x8", "-c", "SMS"])
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8(o.stdout).unwrap();
        let line = out.lines().find(|l| l.starts_with("stack decisions checked against the spec")).unwrap();
        line.split_whitespace().skip(6).collect::<Vec<_>>().join(" ")
    };
    assert_eq!(row("all"), "every cycle");
    assert_eq!(row("sample"), "1 cycle in 64");
    assert_eq!(row("off"), "off");
}
