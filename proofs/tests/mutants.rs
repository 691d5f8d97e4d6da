//! Every planted bug of the one [`Mutant`] list but those of the cycle's issue and completion
//! ports ([`CYCLE_ONLY`]), caught by the exhaustive layer itself: the
//! fixpoint search of one case of [`full_cases`] — per mutant the smallest that catches it: a
//! small configuration of [`full_configs`], or for the bugs only the design's own sizes show
//! (M = 4 or 8, chains of 5, lanes ≥ 16, a second warp, two lanes in one cycle, a busy thread)
//! a case of [`corner_cases`] — every property on, the property that caught it named.
//! `sms check --full --mutant NAME` (a `--features mutants` build) runs the whole set; the SMT
//! layer catches the same bugs from any well-formed state (`proofs/tests/smt.rs`).

use rtl::config::{Config, Overflow, RbSize};
use rtl::stack_manager::Mutant;
use tb::run::verify::exhaustive::{
    check, corner_cases, default_cap, describe, full_cases, full_configs, Bounds, Case,
};
use tb::run::verify::invariants::Property;

/// The configurations of the table, by short name.
#[derive(Clone, Copy, Debug)]
enum Pick {
    /// RB_1+SH_1 warp 2.
    Sh1,
    /// RB_1+SH_2 warp 2: two-entry queues (wrap, which end reloads).
    Sh2,
    /// RB_1+SH_1+RA warp 2 borrow 1.
    Ra,
    /// RB_1+SH_2+RA warp 2 borrow 1: a borrowed queue holding two entries.
    Ra2,
    /// RB_1+SH_1+SK+RA warp 4 borrow 2 with lane 0 alone active (the partial case of
    /// `full_cases`): chains of three stacks, rotated by flushes.
    Chain3,
    /// RB_1+SH_2+SK warp 4 with 8 banks: skew bases 0 0 1 1.
    Skew8,
    /// The case of [`corner_cases`] whose description contains the text.
    Corner(&'static str),
    /// RB_1+RT warp 2: a restart design with an RB alone.
    RtRb,
    /// RB_1+SH_1+RT warp 2: a restart design over one SH entry.
    RtSh,
}

fn case(p: Pick) -> Case {
    match p {
        Pick::Chain3 => {
            let one_lane = |c: &Case| c.partial() && c.cfg.sh_entries == 1;
            full_cases().into_iter().find(one_lane).expect("the one-lane chain-of-three case")
        }
        Pick::Corner(text) => corner_cases()
            .into_iter()
            .find(|c| c.describe().contains(text))
            .unwrap_or_else(|| panic!("a corner case named {text:?}")),
        _ => Case::full(config(p)),
    }
}

fn config(p: Pick) -> Config {
    let ra = |c: &Config| c.realloc().map(|r| r.borrow_limit);
    let spills = |c: &Config| c.overflow == Overflow::Spill;
    let is = |c: &Config, n, m, ws, borrow: Option<u32>, banks| {
        spills(c)
            && c.rb == RbSize::Entries(n)
            && c.sh_entries == m
            && c.warp_size == ws
            && ra(c) == borrow
            && c.banks == banks
    };
    let want: &dyn Fn(&Config) -> bool = match p {
        Pick::Sh1 => &|c| is(c, 1, 1, 2, None, 32),
        Pick::Sh2 => &|c| is(c, 1, 2, 2, None, 32),
        Pick::Ra => &|c| is(c, 1, 1, 2, Some(1), 32),
        Pick::Ra2 => &|c| is(c, 1, 2, 2, Some(1), 32),
        Pick::Chain3 | Pick::Corner(_) => unreachable!("a partial case: see case()"),
        Pick::Skew8 => &|c| is(c, 1, 2, 4, None, 8),
        Pick::RtRb => &|c| !spills(c) && c.sh_entries == 0 && c.warp_size == 2,
        Pick::RtSh => &|c| !spills(c) && c.sh_entries == 1 && c.warp_size == 2,
    };
    full_configs().into_iter().find(|c| want(c)).unwrap_or_else(|| panic!("{p:?} in the full set"))
}

/// Per mutant: the smallest case whose fixpoint search catches it, extra depth-cap entries
/// beyond the case's cap ([`default_cap`] for full warps), and the property that catches it
/// first.
const TABLE: [(Mutant, Pick, u32, Property); 31] = [
    (Mutant::QueueWrapOffByOne, Pick::Sh2, 0, Property::RequestSequence),
    (Mutant::ReloadWrongEntry, Pick::Sh2, 0, Property::RequestSequence),
    (Mutant::SpillDropsEntry, Pick::Sh1, 0, Property::RequestSequence),
    (Mutant::MissingGlobalReload, Pick::Sh1, 0, Property::RequestSequence),
    (Mutant::EarlyRelease, Pick::Ra2, 0, Property::RequestSequence),
    (Mutant::SkipOverflowClear, Pick::Sh1, 0, Property::Overflow),
    (Mutant::FlushKeepsCount, Pick::Ra, 0, Property::FlushCount),
    (Mutant::EagerRelease, Pick::Ra, 0, Property::RequestSequence),
    (Mutant::SkewWrongForOneM, Pick::Skew8, 0, Property::Placement),
    (Mutant::PriorityKeptOnRelease, Pick::Ra, 0, Property::Chains),
    // Two global entries are needed to clear Overflow one pop early.
    (Mutant::OverflowClearedEarly, Pick::Sh1, 1, Property::Overflow),
    // Two flushes must rotate the chain of three before the released stack is not the one
    // after its owner: past the full warp's default cap (its search to the bug takes 46 s);
    // the one-lane case (lanes 1 to 3 start finished) gets there in milliseconds.
    (Mutant::ReleaseAssumesAdjacent, Pick::Chain3, 0, Property::Chains),
    (Mutant::ReloadIntoTop, Pick::Ra, 0, Property::RequestSequence),
    (Mutant::LendActiveStack, Pick::Ra, 0, Property::RequestSequence),
    // A full stack of 8 entries, on the paper's RB_8+SH_8 (one lane of a 32-lane warp).
    (Mutant::CountAdderTooNarrow, Pick::Corner("RB_8+SH_8"), 0, Property::RequestSequence),
    // The fifth stack of a chain, ranked 0.
    (Mutant::PriorityTooNarrow, Pick::Corner("RB_8+SH_8"), 0, Property::Chains),
    // Two lanes borrowing in one cycle get the same Idle stack.
    (Mutant::IdleSearchIgnoresEarlierLends, Pick::Corner("two per cycle"), 0, Property::SameCycle),
    // Lane 16 borrows lane 17's stack and links to lane 1.
    (Mutant::NextTidTooNarrow, Pick::Corner("silent"), 0, Property::Chains),
    // A chain of 5 whose top is its fourth member.
    (Mutant::TopComparatorThreeMembers, Pick::Corner("warp 8 borrow 4"), 0, Property::RequestSequence),
    // In warp 1 the link names thread 4 + lane: past the register file.
    (Mutant::LinkWithThreadId, Pick::Corner("(warp 1"), 0, Property::InRange),
    // Lane 5's borrowed stacks, M = 4 with bases 0 0 0 0 1 1 1 1.
    (Mutant::SkewWrongForM4, Pick::Corner("SH_4"), 0, Property::Placement),
    (Mutant::FinishWhileBusy, Pick::Corner("busy commands"), 0, Property::Busy),
    (Mutant::ReloadAssumesWordKept, Pick::Sh1, 0, Property::RequestSequence),
    // Lane 0's finish and lane 1's borrow of the stack it frees, in one cycle: the borrow's
    // write to that stack is dropped.
    (Mutant::FirstStackWriteWins, Pick::Corner("two per cycle"), 0, Property::SameCycle),
    // An SH store to entry 8 or above of a 16- or 32-entry queue lands 8 entries lower.
    (Mutant::StoredEntryThreeBits, Pick::Corner("SH_32+"), 0, Property::Conservation),
    // A chain of two flushes where it could borrow a third stack.
    (Mutant::FlushBeforeLastBorrow, Pick::Chain3, 0, Property::RequestSequence),
    // The first flush of a stack, with flush limit 3, counts 2.
    (Mutant::FlushCountedTwice, Pick::Corner("flush 3 lanes 0100"), 0, Property::FlushCount),
    (Mutant::DropsNewest, Pick::RtSh, 0, Property::RequestSequence),
    (Mutant::DropForgetsOverflow, Pick::RtRb, 0, Property::Overflow),
    (Mutant::RestartKeepsOverflow, Pick::RtRb, 0, Property::Overflow),
    (Mutant::RestartWithoutDrop, Pick::RtRb, 0, Property::Equivalence),
];

/// The planted bugs of the cycle's issue and completion ports. The exhaustive layer's
/// micro-ops complete at once (nothing waits in flight for a port), so no thread there issues
/// in the cycle its predecessor completes and no SH and global completions meet; `sms prove`'s
/// whole-cycle obligations catch these.
const CYCLE_ONLY: [Mutant; 4] = [
    Mutant::BusyAfterCompletion,
    Mutant::IssueWaitsACycle,
    Mutant::IssueReadsOldLatch,
    Mutant::ResponseDroppedWithShDone,
];

/// The port bugs survive the exhaustive layer, even the case that completes micro-ops in a
/// command's cycle: the claim that it cannot see them, checked.
#[test]
fn the_cycle_port_bugs_are_outside_the_exhaustive_layer() {
    let case = case(Pick::Corner("+completion with command"));
    for m in CYCLE_ONLY {
        let cov = check(case.cfg, case.bounds(), |sm| sm.with_mutant(Some(m)))
            .unwrap_or_else(|e| panic!("{m:?} is caught after all: {e}"));
        assert!(cov.fixpoint, "{m:?}");
    }
}

#[test]
fn every_mutant_is_caught_by_the_fixpoint_search() {
    let listed: Vec<Mutant> = Mutant::ALL.into_iter().filter(|m| !CYCLE_ONLY.contains(m)).collect();
    assert_eq!(
        TABLE.map(|r| r.0)[..],
        listed[..],
        "the table lists every mutant of the one list but the cycle's ports', in its order"
    );
    let mut wrong = Vec::new();
    for (m, pick, extra, expected) in TABLE {
        let case = case(pick);
        let cap = case.cap + extra;
        let started = std::time::Instant::now();
        let caught =
            check(case.cfg, Bounds { cap: Some(cap), ..case.bounds() }, |sm| sm.with_mutant(Some(m)));
        let Err(cex) = caught else {
            panic!("{m:?} survived the fixpoint search of {} under cap {cap}", case.describe());
        };
        println!(
            "{:26} {:48} cap {cap}: caught by {:?} after {} actions ({:.2?})",
            m.name(),
            case.describe(),
            cex.violation.property,
            cex.trace.len(),
            started.elapsed()
        );
        if cex.violation.property != expected {
            wrong.push(format!(
                "{m:?}: caught by {:?}, table says {expected:?}\n{cex}",
                cex.violation.property
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

/// With [`Property::RequestSequence`] off, the state properties catch the bugs it catches
/// first, so they do not rest on one property: per mutant the configuration (ReloadIntoTop needs
/// two-entry queues then; EagerRelease needs a third thread, `tests/fixpoint.rs`).
#[test]
fn without_request_sequence_the_state_properties_catch_them() {
    let table = [
        (Mutant::QueueWrapOffByOne, Pick::Sh2),
        (Mutant::ReloadWrongEntry, Pick::Sh2),
        (Mutant::SpillDropsEntry, Pick::Sh1),
        (Mutant::MissingGlobalReload, Pick::Sh1),
        (Mutant::EarlyRelease, Pick::Ra2),
        (Mutant::ReloadIntoTop, Pick::Ra2),
        (Mutant::LendActiveStack, Pick::Ra),
        (Mutant::CountAdderTooNarrow, Pick::Corner("RB_8+SH_8")),
        (Mutant::TopComparatorThreeMembers, Pick::Corner("warp 8 borrow 4")),
        (Mutant::ReloadAssumesWordKept, Pick::Sh1),
        (Mutant::DropsNewest, Pick::RtSh),
    ];
    let rs: Vec<Mutant> = TABLE
        .iter()
        // FlushBeforeLastBorrow keeps every entry right: only its program differs, so no state
        // property can see it (RequestSequence and the decision scoreboard do).
        .filter(|r| r.3 == Property::RequestSequence)
        .filter(|r| !matches!(r.0, Mutant::EagerRelease | Mutant::FlushBeforeLastBorrow))
        .map(|r| r.0)
        .collect();
    assert_eq!(
        table.map(|r| r.0).to_vec(),
        rs,
        "every mutant RequestSequence catches first, but EagerRelease and FlushBeforeLastBorrow"
    );
    for (m, pick) in table {
        let (c, bounds) = match pick {
            Pick::Corner(_) => (case(pick).cfg, case(pick).bounds()),
            _ => (config(pick), Bounds::fixpoint(default_cap(&config(pick)))),
        };
        let bounds = Bounds { request_sequence: false, ..bounds };
        let cex = check(c, bounds, |sm| sm.with_mutant(Some(m)))
            .err()
            .unwrap_or_else(|| panic!("{m:?} survived {} without RequestSequence", describe(&c)));
        println!(
            "{:26} {:40}: without RequestSequence caught by {:?} after {} actions",
            m.name(),
            describe(&c),
            cex.violation.property,
            cex.trace.len()
        );
        assert_ne!(cex.violation.property, Property::RequestSequence);
    }
}

/// The search variants catch every mutant too: without the partial-order reduction, and depth
/// first (whose counterexamples are not shortest, so the property may differ from the table's).
#[test]
fn every_mutant_is_caught_without_por_and_depth_first() {
    for (m, pick, extra, _) in TABLE {
        let case = case(pick);
        let cap = Some(case.cap + extra);
        for (name, bounds) in [
            ("without POR", Bounds { cap, por: false, ..case.bounds() }),
            ("depth first", Bounds { cap, dfs: true, ..case.bounds() }),
        ] {
            let cex = check(case.cfg, bounds, |sm| sm.with_mutant(Some(m)))
                .err()
                .unwrap_or_else(|| panic!("{m:?} survived {} {name}", case.describe()));
            println!(
                "{:26} {name}: caught by {:?} after {} actions",
                m.name(),
                cex.violation.property,
                cex.trace.len()
            );
        }
    }
}
