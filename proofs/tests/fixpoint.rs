//! Exhaustive exploration to the fixpoint: a representative subset of
//! [`full_configs`] proved under its depth cap with every cover goal reached, the state key
//! free of counters and stale words, and the skew placement property catching a planted bug.
//! `sms check --full` runs the whole set.

use rtl::config::{Config, RbSize, Realloc, ShPolicy};
use rtl::stack_manager::{Cmd, Mutant, StackRegs, POISON};
use tb::run::verify::exhaustive::{
    check, corner_cases, default_cap, describe, full_cases, full_configs, is_large, large_cap, Action,
    Bounds, Case, Coverage, Goal, Model,
};
use tb::run::verify::invariants::{formula_base, Property};

fn prove(c: &Config) -> Coverage {
    let cov = check(*c, Bounds::fixpoint(default_cap(c)), |sm| sm)
        .unwrap_or_else(|e| panic!("{}: {e}", describe(c)));
    println!(
        "{:48} cap {} states {:8} depth {:3} in {:>7.2?} peak frontier {} visited {} B",
        describe(c),
        default_cap(c),
        cov.states,
        cov.depth_reached,
        cov.elapsed,
        cov.peak_frontier,
        cov.visited_bytes
    );
    assert!(cov.fixpoint, "{}: no fixpoint", describe(c));
    assert_eq!(cov.covers.missing(c), vec![], "{}: cover goals never reached", describe(c));
    cov
}

fn find(pred: impl Fn(&Config) -> bool) -> Config {
    full_configs().into_iter().find(|c| pred(c)).expect("configuration in the full set")
}

/// One configuration per feature: plain SH, reallocation on 2-thread warps (flush saturation),
/// a chain of three stacks on 4-thread warps (rotated release), skew with nonzero bases.
#[test]
fn representative_configurations_reach_their_fixpoint_with_every_cover() {
    let picks = [
        find(|c| {
            c.rb == RbSize::Entries(2) && c.sh_entries == 1 && c.warp_size == 2 && c.realloc().is_none()
        }),
        find(|c| {
            c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 2 && c.realloc().is_some()
        }),
        find(|c| {
            c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 4 && c.realloc().is_some()
        }),
        find(|c| c.banks == 8 && c.realloc().is_none()),
    ];
    let three = picks[2].realloc().map(|r| r.borrow_limit);
    assert_eq!(three, Some(2), "the rotated-release pick has chains of three stacks");
    for c in &picks {
        prove(c);
    }
    // The skewed pick really has lanes with nonzero bases.
    assert!((0..4).any(|l| formula_base(&picks[3], l) != 0));
}

/// Event counters are not state: models that differ only in counters get the same key; a
/// different reference stack gets a different one.
#[test]
fn counters_are_not_part_of_the_state() {
    let c = find(|c| {
        c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 2 && c.realloc().is_none()
    });
    let mut cov = Coverage::default();
    let mut a = Model::new(c).unwrap();
    for act in [Action::Cmd(0, Cmd::Push(1)), Action::Cmd(0, Cmd::Pop)] {
        assert!(a.act(act, &mut cov).unwrap());
    }
    let mut b = a.clone();
    b.sb.pops_checked += 7;
    b.sm.stats.pushes += 3;
    assert_eq!(a.key(), b.key());
    assert!(b.act(Action::Cmd(1, Cmd::Push(1)), &mut cov).unwrap());
    assert_ne!(a.key(), b.key());
}

/// Stale memory words are not state: pushing 1, 1 or 2, 2 through the SH level and popping
/// both leaves the same model — every dead SH word overwritten with POISON — and equal keys.
#[test]
fn stale_words_are_not_part_of_the_state() {
    let c = find(|c| {
        c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 2 && c.realloc().is_none()
    });
    let run = |v| {
        let mut m = Model::new(c).unwrap();
        let mut cov = Coverage::default();
        for act in [Action::Cmd(0, Cmd::Push(v)), Action::Cmd(0, Cmd::Push(v))] {
            assert!(m.act(act, &mut cov).unwrap());
            while m.act(Action::Uop(0), &mut cov).unwrap() {}
        }
        assert_eq!(m.sm.sh_entry(0, 0), v, "the spilled entry is live");
        for _ in 0..2 {
            assert!(m.act(Action::Cmd(0, Cmd::Pop), &mut cov).unwrap());
            while m.act(Action::Uop(0), &mut cov).unwrap() {}
        }
        m
    };
    let (one, two) = (run(1), run(2));
    assert_eq!((one.sm.sh_entry(0, 0), two.sm.sh_entry(0, 0)), (POISON, POISON), "the dead word is scrubbed");
    assert_eq!(one.key(), two.key());
}

/// The state key may leave stale words out only because the search scrubs them. Planted
/// through the back door: after 1 was spilled to an SH word and popped again, the stack's
/// registers claim that dead word once more while the reference holds a 1 (a push that moved
/// Top over the word without storing). Without the scrub the word still holds 1 and every
/// property holds — two states that differ only in that stale word would behave differently;
/// with it the word reads POISON and Conservation fails.
#[test]
fn a_revived_dead_word_is_caught_only_with_the_scrub() {
    let c = find(|c| {
        c.rb == RbSize::Entries(1) && c.sh_entries == 2 && c.warp_size == 2 && c.realloc().is_none()
    });
    let run = |scrub: bool| {
        let mut m = Model::new(c).unwrap();
        m.scrub_dead = scrub;
        let mut cov = Coverage::default();
        for v in [1, 2] {
            assert!(m.act(Action::Cmd(0, Cmd::Push(v)), &mut cov).unwrap());
            while m.act(Action::Uop(0), &mut cov).unwrap() {}
        }
        let word = m.sm.stack(0).top;
        assert_eq!(m.sm.sh_entry(0, word), 1, "1 was spilled to the SH word");
        for _ in 0..2 {
            assert!(m.act(Action::Cmd(0, Cmd::Pop), &mut cov).unwrap());
            while m.act(Action::Uop(0), &mut cov).unwrap() {}
        }
        let st = *m.sm.stack(0);
        m.sm.load_stack(0, StackRegs { empty: false, top: word, bottom: word, ..st });
        m.sb.check(0, Cmd::Push(1), Ok(None)).unwrap();
        m.act(Action::Cmd(1, Cmd::Pop), &mut cov)
    };
    assert_eq!(run(false), Ok(true), "without the scrub the revived stale word passes");
    let caught = run(true).expect_err("with the scrub the revived word reads POISON");
    assert_eq!(caught.property, Property::Conservation);
    assert!(caught.detail.contains(&format!("{POISON:x}")), "{caught}");
}

/// A skew base wrong for one geometry (M = 2 with 8 banks) passes every other property but is
/// caught by Placement; with 4 banks the wrong formula happens to be right, and the proof holds.
#[test]
fn skew_wrong_for_one_m_is_caught_by_placement() {
    let c = Config {
        rb: RbSize::Entries(1),
        sh_entries: 2,
        skew: true,
        banks: 8,
        policy: ShPolicy::Realloc(Realloc { borrow_limit: 1, flush_limit: 1 }),
        warp_size: 4,
        warps: 1,
        ..Config::default()
    };
    let bounds = Bounds { depth: 6, ..Bounds::fixpoint(3) };
    let cex = check(c, bounds, |sm| sm.with_mutant(Some(Mutant::SkewWrongForOneM)))
        .expect_err("SkewWrongForOneM survived");
    println!("SkewWrongForOneM caught by {:?}: {cex}", cex.violation.property);
    assert_eq!(cex.violation.property, Property::Placement);
    let right = Config { banks: 4, ..c };
    check(right, bounds, |sm| sm.with_mutant(Some(Mutant::SkewWrongForOneM))).expect("right for 4 banks");
}

/// The goals a configuration needs follow its features.
#[test]
fn cover_goals_follow_the_features() {
    let plain = find(|c| c.sh_entries == 1 && c.realloc().is_none() && c.warp_size == 2);
    assert!(Goal::ALL.iter().all(|g| !g.applies(&plain)));
    let three = find(|c| c.sh_entries == 1 && c.warp_size == 4 && c.realloc().is_some());
    assert!(Goal::RotatedRelease.applies(&three) && Goal::Borrow.applies(&three));
    assert!(!Goal::SkewBase.applies(&three), "32 banks: every base is 0");
}

/// Planted bugs of chains and lending, each caught by the fixpoint search of a configuration of
/// the full set, by the state property named (RequestSequence off: `tests/mutants.rs` runs them
/// with every property on).
#[test]
fn new_mutants_are_caught_by_the_fixpoint_search() {
    let ra2 = find(|c| {
        c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 2 && c.realloc().is_some()
    });
    let plain = find(|c| {
        c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 2 && c.realloc().is_none()
    });
    let three = find(|c| {
        c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 4 && c.realloc().is_some()
    });
    let cases = [
        (ra2, default_cap(&ra2), Mutant::PriorityKeptOnRelease, Property::Chains),
        // Two global entries are needed to clear Overflow one pop early.
        (plain, default_cap(&plain) + 1, Mutant::OverflowClearedEarly, Property::Overflow),
        // Escaped the bounded search (depth 9 on 4-thread warps); the fixpoint finds the
        // 14-action race of three threads.
        (three, default_cap(&three), Mutant::EagerRelease, Property::Conservation),
    ];
    for (c, cap, m, expected) in cases {
        let bounds = Bounds { request_sequence: false, ..Bounds::fixpoint(cap) };
        let cex = check(c, bounds, |sm| sm.with_mutant(Some(m)))
            .unwrap_err_or_else(|| panic!("{m:?} survived on {}", describe(&c)));
        println!(
            "{m:?} on {}: caught by {:?} after {} actions",
            describe(&c),
            cex.violation.property,
            cex.trace.len()
        );
        assert_eq!(cex.violation.property, expected, "{m:?}");
    }
}

trait UnwrapErr<E> {
    fn unwrap_err_or_else(self, f: impl FnOnce()) -> E;
}

impl<T, E> UnwrapErr<E> for Result<T, E> {
    fn unwrap_err_or_else(self, f: impl FnOnce()) -> E {
        match self {
            Ok(_) => {
                f();
                unreachable!()
            }
            Err(e) => e,
        }
    }
}

/// The one-lane case of `sms check --full` with 1-entry stacks (4-thread warps, chains of
/// three, lanes 1 to 3 finished from the start; the other partial cases run in
/// `sms check --full`): every interleaving to the fixpoint, its goals reached — among them
/// a release of a stack that is not the one after its owner, which the full warps reach only
/// past their default cap — and the planted ReleaseAssumesAdjacent caught there.
#[test]
fn one_lane_case_rotates_its_chains_and_catches_release_assumes_adjacent() {
    let cases: Vec<_> = full_cases().into_iter().filter(|c| c.active == 1 && c.cfg.sh_entries == 1).collect();
    assert_eq!(cases.len(), 1);
    for case in &cases {
        let cov =
            check(case.cfg, case.bounds(), |sm| sm).unwrap_or_else(|e| panic!("{}: {e}", case.describe()));
        println!(
            "{:52} cap {} states {:8} depth {:3} in {:>7.2?}",
            case.describe(),
            case.cap,
            cov.states,
            cov.depth_reached,
            cov.elapsed
        );
        assert!(cov.fixpoint, "{}", case.describe());
        assert!(case.goals().contains(&Goal::NonAdjacentRelease));
        assert_eq!(cov.covers.missing_of(&case.goals()), vec![], "{}", case.describe());
        let cex = check(case.cfg, case.bounds(), |sm| sm.with_mutant(Some(Mutant::ReleaseAssumesAdjacent)))
            .expect_err("ReleaseAssumesAdjacent survived");
        println!("  ReleaseAssumesAdjacent: {} after {} actions", cex.violation, cex.trace.len());
        assert_eq!(cex.violation.property, Property::Chains);
    }
}

/// One marked push per run (`Bounds::one_mark`, the fixpoint default; the data-independence
/// argument in the module doc of `exhaustive`) reaches the same fixpoint and covers as every
/// value at every push, with far fewer states, and still catches a reordering bug by
/// Conservation alone.
#[test]
fn one_marked_push_per_run_proves_the_same_with_fewer_states() {
    let c = find(|c| {
        c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 2 && c.realloc().is_some()
    });
    let cap = default_cap(&c);
    let one = check(c, Bounds::fixpoint(cap), |sm| sm).unwrap();
    let all = check(c, Bounds { one_mark: false, ..Bounds::fixpoint(cap) }, |sm| sm).unwrap();
    println!("{}: {} states with one mark, {} with every value", describe(&c), one.states, all.states);
    assert!(one.fixpoint && all.fixpoint);
    assert_eq!(one.covers.missing(&c), vec![]);
    assert!(one.states * 2 < all.states, "{} vs {}", one.states, all.states);
    let sh2 = find(|c| {
        c.rb == RbSize::Entries(1) && c.sh_entries == 2 && c.warp_size == 2 && c.realloc().is_none()
    });
    let bounds = Bounds { request_sequence: false, ..Bounds::fixpoint(default_cap(&sh2)) };
    let cex = check(sh2, bounds, |sm| sm.with_mutant(Some(Mutant::ReloadWrongEntry)))
        .expect_err("ReloadWrongEntry survived one mark");
    assert_eq!(cex.violation.property, Property::Conservation);
}

/// The goals a run reached (count > 0), of every goal.
fn reached(cov: &Coverage) -> Vec<Goal> {
    Goal::ALL.into_iter().filter(|&g| cov.covers.count(g) > 0).collect()
}

/// The partial-order reduction (`Bounds::por`, the fixpoint default; soundness argument in the
/// module doc of `exhaustive`) in practice: on every breadth-first case of `sms check --full`,
/// the reduced and the unreduced search both reach their fixpoint and reach the same cover
/// goals, and the reduction expands some states by one action and visits fewer states in all.
#[test]
fn partial_order_reduction_keeps_every_verdict_and_cover() {
    let (mut with, mut without) = (0, 0);
    let corners: Vec<String> = corner_cases().iter().map(Case::describe).collect();
    let small = |c: &Case| !c.dfs && (!corners.contains(&c.describe()) || c.cap <= 10);
    for case in full_cases().into_iter().filter(small) {
        let on =
            check(case.cfg, case.bounds(), |sm| sm).unwrap_or_else(|e| panic!("{}: {e}", case.describe()));
        let off = check(case.cfg, Bounds { por: false, ..case.bounds() }, |sm| sm)
            .unwrap_or_else(|e| panic!("{} without POR: {e}", case.describe()));
        println!(
            "{:60} states {:7} with POR ({} reduced), {:7} without",
            case.describe(),
            on.states,
            on.reduced,
            off.states
        );
        assert!(on.fixpoint && off.fixpoint, "{}", case.describe());
        assert_eq!(off.reduced, 0);
        assert_eq!(reached(&on), reached(&off), "{}: covers differ with POR", case.describe());
        assert_eq!(on.covers.missing_of(&case.goals()), vec![], "{}", case.describe());
        with += on.states;
        without += off.states;
    }
    println!("all cases: {with} states with POR, {without} without");
    assert!(with < without, "{with} vs {without}");
}

/// The cases at the design's own sizes (M = 4 and 8, the paper's SMS on a 32-lane warp, chains
/// of 5, flush limit 3, lanes above 15, a second warp, two lanes per cycle, commands to busy
/// threads) reach their fixpoint with every cover goal they are asked for.
#[test]
fn the_design_sizes_reach_their_fixpoint_with_every_cover() {
    for case in corner_cases() {
        let cov =
            check(case.cfg, case.bounds(), |sm| sm).unwrap_or_else(|e| panic!("{}: {e}", case.describe()));
        println!("{:100} {:8} states {:.2?}", case.describe(), cov.states, cov.elapsed);
        assert!(cov.fixpoint, "{}", case.describe());
        assert_eq!(cov.covers.missing_of(&case.goals()), vec![], "{}", case.describe());
    }
}

/// Depth first (`Bounds::dfs`) proves what breadth first proves: on one case per feature both
/// reach their fixpoint with the same covers, the depth-first search holding far fewer models.
#[test]
fn depth_first_search_proves_what_breadth_first_proves() {
    let picks = [
        find(|c| {
            c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 2 && c.realloc().is_some()
        }),
        find(|c| {
            c.rb == RbSize::Entries(2) && c.sh_entries == 1 && c.warp_size == 4 && c.realloc().is_some()
        }),
        find(|c| c.banks == 8 && c.realloc().is_none()),
    ];
    for c in picks {
        let bfs = check(c, Bounds::fixpoint(default_cap(&c)), |sm| sm).unwrap();
        let dfs = check(c, Bounds { dfs: true, ..Bounds::fixpoint(default_cap(&c)) }, |sm| sm).unwrap();
        println!(
            "{:48} BFS {} states, peak {} models ({} B); DFS {} states, peak {} models ({} B)",
            describe(&c),
            bfs.states,
            bfs.peak_frontier,
            bfs.peak_frontier_bytes,
            dfs.states,
            dfs.peak_frontier,
            dfs.peak_frontier_bytes
        );
        assert!(bfs.fixpoint && dfs.fixpoint, "{}", describe(&c));
        assert_eq!(reached(&bfs), reached(&dfs), "{}", describe(&c));
        assert_eq!(dfs.covers.missing(&c), vec![], "{}", describe(&c));
    }
}

/// The 4-thread warps with M = 2 and reallocation are in `sms check --full`, depth first under
/// `default_cap` (tens of minutes there; `--small-cap`: `large_cap`, minutes). Here the cheap
/// part: RB_1's under cap 4, depth first with the
/// reduction, reaches its fixpoint with a borrow, a flush and a warp exit after a borrow
/// reached, and catches a planted bug.
#[test]
fn four_thread_m2_reallocation_depth_first_under_a_small_cap() {
    let large: Vec<Case> = full_cases().into_iter().filter(|c| is_large(&c.cfg) && !c.partial()).collect();
    assert_eq!(large.len(), 2, "RB_1 and RB_2");
    assert!(large.iter().all(|c| c.dfs && c.cap == default_cap(&c.cfg)));
    assert_eq!(large.iter().map(|c| (c.cap, large_cap(&c.cfg))).collect::<Vec<_>>(), [(8, 6), (9, 7)]);
    assert!(full_cases().iter().all(|c| c.dfs == large.iter().any(|l| l.describe() == c.describe())));
    let c = large[0].cfg;
    assert_eq!((c.rb, large_cap(&c)), (RbSize::Entries(1), 6));
    let bounds = Bounds { cap: Some(4), ..large[0].bounds() };
    let cov = check(c, bounds, |sm| sm).unwrap_or_else(|e| panic!("{}: {e}", describe(&c)));
    println!(
        "{} cap 4: {} states, longest path {}, {} models held at the peak ({} B), visited {} B, {:.2?}",
        describe(&c),
        cov.states,
        cov.depth_reached,
        cov.peak_frontier,
        cov.peak_frontier_bytes,
        cov.visited_bytes,
        cov.elapsed
    );
    assert!(cov.fixpoint);
    // A release out of allocation order needs a chain of three rotated by flushes, past cap 4;
    // the one-lane cases of the quick set reach it (every cover asserted there).
    let goals = [Goal::Borrow, Goal::Flush, Goal::ExitAfterBorrow];
    assert_eq!(cov.covers.missing_of(&goals), vec![]);
    let cex = check(c, bounds, |sm| sm.with_mutant(Some(Mutant::LendActiveStack)))
        .expect_err("LendActiveStack survived");
    println!("  LendActiveStack: {} after {} actions", cex.violation, cex.trace.len());
}

/// The corner case whose description contains `text`.
fn corner(text: &str) -> Case {
    corner_cases().into_iter().find(|c| c.describe().contains(text)).unwrap_or_else(|| panic!("{text:?}"))
}

/// `StackManager::complete_and_accept` is the cycle's order: a release completing in a cycle is
/// seen by that cycle's plans (another lane borrows the released stack, the lowest Idle one,
/// where planning before the release lands takes the next), and the completing thread is busy
/// for its own command that cycle even when the micro-op is its last.
#[test]
fn a_release_completing_in_a_cycle_is_seen_by_that_cycles_plans() {
    let c = Config {
        rb: RbSize::Entries(1),
        sh_entries: 1,
        policy: ShPolicy::Realloc(Realloc { borrow_limit: 2, flush_limit: 1 }),
        warp_size: 4,
        warps: 1,
        ..Config::default()
    };
    let mut sm = rtl::stack_manager::StackManager::new(c, 0).unwrap();
    sm.load_warp(0, 0b0011);
    let drain = |sm: &mut rtl::stack_manager::StackManager, t| while sm.complete_next(t) {};
    // Lane 0 fills its RB, its stack and borrows stack 2; lane 1 fills its RB and its stack.
    for (t, n) in [(0, 3), (1, 2)] {
        for v in 0..n {
            sm.accept(t, Cmd::Push(10 * t as u64 + v)).unwrap();
            drain(&mut sm, t);
        }
    }
    assert_eq!(sm.chain(0), [0, 2]);
    // Lane 0's pop drains the borrowed stack: SH load, RB bottom, then the release.
    sm.accept(0, Cmd::Pop).unwrap();
    sm.complete_next(0);
    sm.complete_next(0);
    assert_eq!(
        sm.pending_uops(0).copied().collect::<Vec<_>>(),
        [rtl::stack_manager::Uop::Release { stack: 2 }]
    );
    let early = {
        let mut x = sm.clone();
        assert_eq!(x.accept(1, Cmd::Push(12)), Ok(None));
        x.chain(1)
    };
    assert_eq!(early, [1, 3], "planned before the release lands, lane 1 borrows stack 3");
    let mut same = sm.clone();
    assert_eq!(same.complete_and_accept(&[0], &[(1, Cmd::Push(12))]), [Ok(None)]);
    assert_eq!(same.chain(1), [1, 2], "in the release's cycle, lane 1 borrows the released stack");
    assert!(same.ready(0), "the release was lane 0's last micro-op");
    assert_eq!(
        sm.complete_and_accept(&[0], &[(0, Cmd::Pop)]),
        [Err(rtl::stack_manager::StackError::Busy { thread: 0 })],
        "lane 0 is busy for the whole cycle its last micro-op completes in"
    );
    assert!(sm.ready(0) && sm.stack(2).idle, "the completion landed, the refused pop changed nothing");
}

/// A completion and a command in one cycle (`Action::UopWithCmd`) reach the cases they are for
/// (a stack released and borrowed in one cycle; a command refused as the thread's last
/// micro-op completes), and catch a merge that keeps a release's write to a stack over a
/// same-cycle plan's (FirstStackWriteWins) by SameCycle, which the search without them misses.
#[test]
fn completions_with_commands_in_one_cycle_reach_their_cases_and_catch_a_lost_write() {
    let case = corner("+completion with command");
    let goals = case.goals();
    assert!(goals.contains(&Goal::ReleaseMeetsBorrow) && goals.contains(&Goal::BusyAsLastUopCompletes));
    let cov = check(case.cfg, case.bounds(), |sm| sm).unwrap_or_else(|e| panic!("{e}"));
    assert!(cov.fixpoint);
    assert_eq!(cov.covers.missing_of(&goals), vec![]);
    println!("{}: {} states, {:.2?}", case.describe(), cov.states, cov.elapsed);
    // The completions alone (no two commands per cycle, no commands to busy threads).
    let alone = Case { busy_cmds: false, pairs: false, ..case };
    let planted = |sm: rtl::stack_manager::StackManager| sm.with_mutant(Some(Mutant::FirstStackWriteWins));
    let cex = check(alone.cfg, alone.bounds(), planted).expect_err("FirstStackWriteWins survived");
    println!("  FirstStackWriteWins: {cex}");
    assert_eq!(cex.violation.property, Property::SameCycle);
    assert!(matches!(cex.trace.last(), Some(Action::UopWithCmd(u, t, _)) if u != t), "{cex}");
    let without = check(alone.cfg, Bounds { uop_cmds: false, ..alone.bounds() }, planted)
        .unwrap_or_else(|e| panic!("without completions in a command's cycle nothing merges: {e}"));
    assert!(without.fixpoint);
}

/// SH queues of 16 and 32 entries (4- and 5-bit Top and Bottom; skew base lane mod M, k = 1)
/// on one lane of a 32-lane warp: valid configurations, every interleaving to the fixpoint
/// through a full chain, a flush and the global reload, and a store addressed with 3 bits
/// (right for M ≤ 8) caught at both sizes.
#[test]
fn queues_of_16_and_32_entries_reach_their_fixpoint_and_catch_a_narrow_store_address() {
    for m in [16, 32] {
        let case = corner(&format!("SH_{m}+"));
        let c = case.cfg;
        c.validate().unwrap();
        assert!((0..32).all(|l| c.skew_base(l) == l % m && formula_base(&c, l) == l % m));
        let goals = case.goals();
        for g in
            [Goal::Borrow, Goal::FullChain, Goal::Flush, Goal::OldestReload, Goal::Demotion, Goal::SkewBase]
        {
            assert!(goals.contains(&g), "SH_{m}: {g:?}");
        }
        let cov = check(c, case.bounds(), |sm| sm).unwrap_or_else(|e| panic!("{}: {e}", case.describe()));
        println!(
            "{}: {} states, depth {}, {:.2?}",
            case.describe(),
            cov.states,
            cov.depth_reached,
            cov.elapsed
        );
        assert!(cov.fixpoint);
        assert_eq!(cov.covers.missing_of(&goals), vec![], "{}", case.describe());
        let cex = check(c, case.bounds(), |sm| sm.with_mutant(Some(Mutant::StoredEntryThreeBits)))
            .expect_err("StoredEntryThreeBits survived");
        println!("  StoredEntryThreeBits: {} after {} actions", cex.violation, cex.trace.len());
        assert_eq!(cex.violation.property, Property::Conservation);
    }
    let eight = corner("RB_8+SH_8");
    check(eight.cfg, eight.bounds(), |sm| sm.with_mutant(Some(Mutant::StoredEntryThreeBits)))
        .expect("3 bits address every entry of M = 8");
}

/// FlushCount compares every Flush register with the count the checker keeps from SPEC 5. A
/// flush counted twice (saturating, so in range and 0 on every empty stack) passes every other
/// property, the bounds-only Flush property and RequestSequence (which reads the design's
/// counts) included, to the fixpoint; FlushCount catches it at the first flush. With a flush
/// limit of 1 counting twice is right, and the search passes.
#[test]
fn flush_count_catches_a_flush_counted_twice_that_the_bounds_pass() {
    let case = corner("flush 3 lanes 0100");
    assert_eq!(case.cfg.realloc().map(|r| r.flush_limit), Some(3));
    let twice = |sm: rtl::stack_manager::StackManager| sm.with_mutant(Some(Mutant::FlushCountedTwice));
    let cov = check(case.cfg, Bounds { flush_count: false, ..case.bounds() }, twice)
        .unwrap_or_else(|e| panic!("without FlushCount: {e}"));
    assert!(cov.fixpoint && cov.flushes > 0, "the search flushed");
    assert_eq!(cov.covers.missing_of(&case.goals()), vec![]);
    let cex = check(case.cfg, case.bounds(), twice).expect_err("FlushCountedTwice survived FlushCount");
    println!("FlushCountedTwice: {cex}");
    assert_eq!(cex.violation.property, Property::FlushCount);
    let ra = find(|c| {
        c.rb == RbSize::Entries(1) && c.sh_entries == 1 && c.warp_size == 2 && c.realloc().is_some()
    });
    check(ra, Bounds::fixpoint(default_cap(&ra)), twice).expect("with flush limit 1 twice is once");
    // The bounds still catch a count never reset, on their own, once the pop is done.
    let kept = check(ra, Bounds { flush_count: false, ..Bounds::fixpoint(default_cap(&ra)) }, |sm| {
        sm.with_mutant(Some(Mutant::FlushKeepsCount))
    })
    .expect_err("FlushKeepsCount survived the bounds");
    assert_eq!(kept.violation.property, Property::Flush);
}
