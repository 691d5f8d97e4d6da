//! `sms check --vcd`: a counterexample of the exhaustive checker, replayed and dumped as a VCD,
//! shows exactly the registers the planted bug produced, step by step.

mod common;
use common::TmpDir;
use rtl::config::{Config, RbSize};
use rtl::stack_manager::{Mutant, StackManager};
use rtl::trace::{Probe, Sink};
use tb::cli::check::dump_counterexample;
use tb::run::verify::exhaustive::{check, Bounds, Coverage, Model};
use tb::vcd::check::{compare, read, Mode, Recorder};

fn cfg() -> Config {
    Config { rb: RbSize::Entries(1), sh_entries: 2, warp_size: 2, warps: 1, ..Config::default() }
}

fn reload_wrong_entry(sm: StackManager) -> StackManager {
    sm.with_mutant(Some(Mutant::ReloadWrongEntry))
}

/// The registers after each action of `trace`, walked like the dump does.
fn replay(
    design: fn(StackManager) -> StackManager,
    trace: &[tb::run::verify::exhaustive::Action],
) -> Recorder {
    let mut m = Model::new(cfg()).unwrap();
    m.sm = design(m.sm);
    let mut rec = Recorder::default();
    rec.begin_cycle(0);
    m.sm.probe(&mut rec);
    for (i, &a) in trace.iter().enumerate() {
        let _ = m.act(a, &mut Coverage::default());
        rec.begin_cycle(i as u64 + 1);
        m.sm.probe(&mut rec);
    }
    rec
}

#[test]
fn counterexample_dump_replays_the_buggy_registers() {
    let bounds = Bounds { depth: 16, values: 2, max_states: 1_000_000, ..Bounds::default() };
    let cex = check(cfg(), bounds, reload_wrong_entry).expect_err("the planted bug is caught");
    let dir = TmpDir::new("check-vcd", "cex");
    let path = dir.join("cex.vcd");
    dump_counterexample(cfg(), reload_wrong_entry, u32::MAX >> (32 - cfg().warp_size), &cex.trace, &path)
        .unwrap();
    assert!(path.with_extension("gtkw").is_file(), "a save file next to the dump");

    let text = std::fs::read(&path).unwrap();
    let waves = read(&text[..], Mode::Strict).unwrap_or_else(|e| panic!("{e}"));
    assert!(waves.signals.iter().any(|s| s.0.ends_with("thread[0].rb_top")));
    let steps = cex.trace.len() as u64;
    assert!(waves.times().all(|t| t <= steps + 1), "one time step per action");

    let buggy = replay(reload_wrong_entry, &cex.trace);
    let compared = compare(&waves, &buggy, 0..=steps).unwrap();
    assert_eq!(compared, buggy.cycles().len() * waves.signals.len(), "every value of every step");
    // The dump shows the bug: the correct design's registers differ somewhere on the same trace.
    let correct = replay(|sm| sm, &cex.trace);
    assert!(compare(&waves, &correct, 0..=steps).is_err(), "the dump would look the same without the bug");
}
