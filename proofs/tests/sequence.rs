//! Property::RequestSequence: the micro-ops the stack manager plans for an
//! accepted command equal SPEC sections 3 and 5's sequence for that case, written independently
//! in `tb::run::verify::sequence::expected_program`. Checked on every accepted command of the
//! exhaustive search and of the random runs (both drive `Model::act`).

use rtl::config::{Config, RbSize, Realloc, ShPolicy};
use rtl::stack_manager::{Cmd, Mutant, Src, Uop};
use tb::run::verify::exhaustive::{
    check, default_cap, describe, run_bytes_on, Action, Bounds, Coverage, Model,
};
use tb::run::verify::harness::mix;
use tb::run::verify::invariants::Property;

fn config(m: u32, borrow: u32) -> Config {
    Config {
        rb: RbSize::Entries(1),
        sh_entries: m,
        policy: ShPolicy::from((borrow > 0).then_some(Realloc { borrow_limit: borrow, flush_limit: 1 })),
        warp_size: 2,
        warps: 1,
        ..Config::default()
    }
}

/// Accepts `cmd` from thread `t` (every property on) and returns the program it loaded, then
/// completes it.
fn program(m: &mut Model, t: u32, cmd: Cmd) -> Vec<Uop> {
    let mut cov = Coverage::default();
    m.act(Action::Cmd(t, cmd), &mut cov).unwrap_or_else(|v| panic!("{cmd:?}: {v}"));
    let p = m.sm.pending_uops(t).copied().collect();
    while m.act(Action::Uop(t), &mut cov).unwrap() {}
    p
}

/// SPEC section 3's cases, written out by hand for RB_1+SH_1: spill into SH (case 2), the
/// SH load → global store → SH store of case 3, and a pop that reloads SH → RB and global → SH.
#[test]
fn spec_section_3_sequences_by_hand() {
    use rtl::stack_manager::UopOf::*;
    let mut m = Model::new(config(1, 0)).unwrap();
    assert_eq!(program(&mut m, 0, Cmd::Push(1)), vec![], "push, RB not full");
    let case2 = vec![ShStore { stack: 0, entry: 0, src: Src::Value(1) }];
    assert_eq!(program(&mut m, 0, Cmd::Push(2)), case2, "push, RB full, SH not full");
    let case3 = vec![
        ShLoad { stack: 0, entry: 0 },
        GlobalStore { slot: 0, src: Src::Latch },
        ShStore { stack: 0, entry: 0, src: Src::Value(2) },
    ];
    assert_eq!(program(&mut m, 0, Cmd::Push(3)), case3, "push, RB and SH full");
    let pop = vec![
        ShLoad { stack: 0, entry: 0 },
        RbBottom,
        GlobalLoad { slot: 0 },
        ShStore { stack: 0, entry: 0, src: Src::Latch },
    ];
    assert_eq!(program(&mut m, 0, Cmd::Pop), pop, "pop with SH entries and Overflow");
    assert_eq!(program(&mut m, 0, Cmd::Pop), vec![ShLoad { stack: 0, entry: 0 }, RbBottom]);
    assert_eq!(program(&mut m, 0, Cmd::Pop), vec![], "pop from the RB only");
    assert_eq!(program(&mut m, 0, Cmd::Finish), vec![]);
}

/// SPEC section 5's borrow and release, by hand for RB_1+SH_1+RA on a 2-thread warp: thread 1
/// finishes, thread 0 borrows its stack on the spill past its own, and the pop that drains the
/// borrowed stack releases it after the load that read its entry.
#[test]
fn spec_section_5_borrow_and_release_by_hand() {
    use rtl::stack_manager::UopOf::*;
    let mut m = Model::new(config(1, 1)).unwrap();
    program(&mut m, 1, Cmd::Finish);
    program(&mut m, 0, Cmd::Push(1));
    program(&mut m, 0, Cmd::Push(2));
    let borrow = vec![ShStore { stack: 1, entry: 0, src: Src::Value(2) }];
    assert_eq!(program(&mut m, 0, Cmd::Push(3)), borrow, "spill into the borrowed stack");
    let release = vec![ShLoad { stack: 1, entry: 0 }, RbBottom, Release { stack: 1 }];
    assert_eq!(program(&mut m, 0, Cmd::Pop), release, "drain and release the borrowed stack");
    assert!(m.sm.stack(1).idle, "released");
}

/// The planted bug EagerRelease (Idle set when the pop is planned, no release micro-op) survives
/// the whole fixpoint search of a 2-thread warp without RequestSequence (the lost entry needs a
/// third thread to borrow the stack in between) and is caught by RequestSequence at the first
/// release with it.
#[test]
fn request_sequence_catches_eager_release_where_the_state_properties_cannot() {
    let c = config(1, 1);
    let cap = default_cap(&c);
    let design = |sm: rtl::stack_manager::StackManager| sm.with_mutant(Some(Mutant::EagerRelease));
    let without = Bounds { request_sequence: false, ..Bounds::fixpoint(cap) };
    let cov = check(c, without, design).unwrap_or_else(|e| panic!("caught without RequestSequence: {e}"));
    assert!(cov.fixpoint && cov.releases > 0, "{}: {cov:?}", describe(&c));
    let cex = check(c, Bounds::fixpoint(cap), design).expect_err("EagerRelease survived RequestSequence");
    println!("EagerRelease on {}: {} after {} actions", describe(&c), cex.violation, cex.trace.len());
    assert_eq!(cex.violation.property, Property::RequestSequence);
    check(c, Bounds::fixpoint(cap), |sm| sm).expect("the correct design keeps it");
}

/// Random runs check it too: ReloadIntoTop on a 2-thread warp with reallocation is caught by
/// RequestSequence in random byte sequences; the correct design passes the same sequences.
#[test]
fn random_runs_check_the_request_sequence() {
    let c = config(1, 1);
    let input = |seed: u64| -> Vec<(u8, u8)> {
        (0..300u64).map(|i| mix(seed << 20 | i)).map(|h| ((h % 2) as u8, (h >> 8) as u8)).collect()
    };
    let model = |m| {
        let mut x = Model::new(c).unwrap();
        x.sm = x.sm.with_mutant(m);
        x
    };
    for seed in 0..300 {
        run_bytes_on(model(None), &input(seed)).unwrap_or_else(|e| panic!("correct design failed: {e}"));
    }
    let cex = (0..300)
        .find_map(|seed| run_bytes_on(model(Some(Mutant::ReloadIntoTop)), &input(seed)).err())
        .expect("ReloadIntoTop survived 300 random sequences");
    println!("ReloadIntoTop: {} after {} actions", cex.violation, cex.trace.len());
    assert_eq!(cex.violation.property, Property::RequestSequence);
}
