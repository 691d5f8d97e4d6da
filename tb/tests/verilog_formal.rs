//! The formal check of the generated Verilog (`sms verilog --prove`): yosys's SAT solver on the
//! warp module with the well-formedness invariant as assertions, its verdict at small
//! configurations, a planted bug it catches naming the clause, and its refusals.

use rtl::config::Config;
use tb::verilog::formal::{self, Verdict};
use tb::verilog::generate;

fn config(name: &str, lanes: u32) -> Config {
    Config { warp_size: lanes, warps: 1, ..name.parse().unwrap() }
}

/// `f` with `insert` written right after the first `line` (a register update), checked for `steps`.
fn planted(f: &formal::Formal, line: &str, insert: &str, d: &std::path::Path, steps: u32) -> formal::Outcome {
    let at = f.text.find(line).expect("the register update to plant in") + line.len();
    let mut bad = formal::Formal { text: f.text.clone(), ..f.clone() };
    bad.text.insert_str(at, insert);
    formal::prove(&bad, &d.join("planted"), steps).unwrap()
}

fn dir(tag: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("sms-formal-{}-{tag}", std::process::id()))
}

/// The check at RB_1+SH_2 on two lanes: no counterexample within the steps, and a verdict that
/// says which kind of result it is (a proof by induction, or bounded at the steps examined).
#[test]
fn the_invariant_holds_on_the_generated_verilog_and_a_planted_bug_is_caught_naming_the_clause() {
    if !tb::prereq::tools(&["yosys"], "yosys (apt-get install yosys)") {
        return;
    }
    let mut g = generate(&config("RB_1+SH_2", 2), true).unwrap();
    let f = formal::build(&mut g).unwrap();
    let d = dir("good");
    let o = formal::prove(&f, &d, 3).unwrap();
    match o.verdict {
        Verdict::Proved { k } => assert!(k <= 3, "{k}"),
        Verdict::Bounded { depth, .. } => assert_eq!(depth, 2, "every step but the load's examined"),
        v => panic!("{v}"),
    }
    assert_eq!(o.asserts, f.asserts.len());

    // Planted: lane 0's SH-empty flag inverted on every edge.
    let o = planted(&f, "        lane0_sh_empty <= ", "~", &d, 3);
    let Verdict::Counterexample { step, failed } = &o.verdict else { panic!("{}", o.verdict) };
    assert!(*step >= 1, "{step}");
    assert!(!failed.is_empty() && failed.iter().all(|c| f.asserts.contains(c)), "{failed:?}");
    assert!(o.verdict.to_string().starts_with("counterexample"), "{}", o.verdict);
    let _ = std::fs::remove_dir_all(&d);
}

/// A restart design without an SH level (RB_2+RT on two lanes) loads no micro-op program, so its
/// invariant (the RB length, the spill pointer 0, the done bit) closes by induction; planted, a
/// push into the full RB that drops nothing (the RB count past N) is a counterexample naming the
/// clause.
#[test]
fn a_restart_designs_invariant_is_proved_by_induction_and_a_drop_that_keeps_everything_is_caught() {
    if !tb::prereq::tools(&["yosys"], "yosys (apt-get install yosys)") {
        return;
    }
    let mut g = generate(&config("RB_2+RT", 2), true).unwrap();
    let f = formal::build(&mut g).unwrap();
    let d = dir("restart");
    let o = formal::prove(&f, &d, 3).unwrap();
    assert_eq!(o.verdict, Verdict::Proved { k: 1 });

    // The load, two pushes that fill the RB and a third: the registers break the clause after
    // the third push's edge, 4 cycles after the load's.
    let plant = "(lane0_cmd_kind == 2'd1 && lane0_rb_count == 2'd2) ? 2'd3 : ";
    let o = planted(&f, "        lane0_rb_count <= ", plant, &d, 5);
    let Verdict::Counterexample { step, failed } = &o.verdict else { panic!("{}", o.verdict) };
    assert_eq!(*step, 4, "{}", o.verdict);
    assert!(failed.iter().any(|c| c == "lane 0: RB length at most N"), "{failed:?}");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_configuration_too_large_is_refused_in_one_line_with_the_limit() {
    let e = formal::too_large(&config("RB_1+SH_2", 8)).unwrap();
    assert!(e.contains("at most 4 lanes") && !e.contains('\n'), "{e}");
    let e = formal::too_large(&config("RB_1+SH_8", 2)).unwrap();
    assert!(e.contains("4 SH entries") && !e.contains('\n'), "{e}");
    assert!(formal::too_large(&config("RB_1+SH_2+SK+RA", 4)).is_none());
}

/// The verdicts from yosys's log: a bounded result is never read as a proof.
#[test]
fn the_log_reader_tells_a_proof_from_a_bounded_check_and_names_failing_clauses() {
    let names = vec!["a".to_string(), "b".to_string()];
    let bounded = "[base case 1] ...\n[induction step 1] ...\n[base case 2] ...\n[induction step 2] ...\n\
                   Induction step failed. Incrementing induction length.\n  1 \\wf_0 1 1 1\n  1 \\wf_1 1 1 1\n\
                   \x20 3 \\wf_0 0 0 0\n  3 \\wf_1 1 1 1\nReached maximum number of time steps -> proof failed.\n";
    let v = formal::parse(bounded, &names).unwrap();
    assert_eq!(v, Verdict::Bounded { depth: 1, step_fails: vec!["a".into()] });
    assert!(v.to_string().starts_with("bounded: ") && !v.to_string().contains("proved"), "{v}");
    let proved = "[base case 1] ...\n[induction step 1] ...\nInduction step proven: SUCCESS!\n";
    assert_eq!(formal::parse(proved, &names).unwrap(), Verdict::Proved { k: 1 });
    let cex = "[base case 3] ...\nSAT temporal induction proof finished - model found for base case: FAIL!\n\
               Time Signal Dec Hex Bin\n  1 \\wf_0 1 1 1\n  1 \\wf_1 1 1 1\n  3 \\wf_0 1 1 1\n  3 \\wf_1 0 0 0\n";
    assert_eq!(
        formal::parse(cex, &names).unwrap(),
        Verdict::Counterexample { step: 2, failed: vec!["b".into()] }
    );
    assert!(formal::parse("nothing", &names).is_err());
}
