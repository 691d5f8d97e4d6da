//! The configurations and cases the exhaustive checks run: the small set of the test suite,
//! the full set `sms check --full` proves to its fixpoint, restart, group and skew
//! configurations, and each case's goals and bounds.

use rtl::config::{Config, Overflow};

use super::bounds::{default_cap, is_large, Bounds};
use super::coverage::Goal;

/// The small configurations the test suite checks exhaustively: N in {1, 2}, M in {0, 1, 2},
/// warps of 2 and 4 threads, with and without skew and reallocation (borrow limit 1–2, flush
/// limit 1).
pub fn small_configs() -> Vec<Config> {
    use rtl::config::{RbSize, Realloc};
    let mut out = Vec::new();
    for n in [1, 2] {
        for m in [0, 1, 2] {
            for (ws, borrow) in [(2, 0), (2, 1), (4, 0), (4, 2)] {
                if borrow > 0 && m == 0 {
                    continue;
                }
                let realloc = (borrow > 0).then_some(Realloc { borrow_limit: borrow, flush_limit: 1 });
                out.push(Config {
                    rb: RbSize::Entries(n),
                    sh_entries: m,
                    skew: m > 0 && ws == 4,
                    policy: realloc.into(),
                    warp_size: ws,
                    warps: 1,
                    ..Config::default()
                });
            }
        }
    }
    out
}

/// Every configuration `sms check --full` proves to its fixpoint: [`small_configs`] (the
/// 4-thread warps that combine M = 2 with reallocation depth first), plus skewed configurations
/// with 4 and 8 banks, where base entries differ between lanes (with the paper's 32 banks every
/// small configuration has k = 32 / (2M) ≥ warp size, so all bases are 0).
pub fn full_configs() -> Vec<Config> {
    let mut out: Vec<Config> = small_configs().into_iter().collect();
    out.extend(skew_configs().into_iter().filter(|c| c.realloc().is_none()));
    out.extend(group_configs());
    out.extend(restart_configs());
    out
}

/// Restart designs (`+RT`): an RB alone, an RB over one SH entry, and both with reallocation in
/// a 4-thread warp (a full chain of two empties its oldest member).
pub fn restart_configs() -> Vec<Config> {
    use rtl::config::{RbSize, Realloc, ShPolicy};
    let ra = ShPolicy::Realloc(Realloc { borrow_limit: 1, flush_limit: 1 });
    [(1, 0, 2, ShPolicy::Dedicated), (1, 1, 2, ShPolicy::Dedicated), (1, 1, 4, ra), (2, 1, 4, ra)]
        .into_iter()
        .map(|(n, m, ws, policy)| Config {
            rb: RbSize::Entries(n),
            sh_entries: m,
            skew: m > 0 && ws == 4,
            policy,
            overflow: Overflow::Drop,
            warp_size: ws,
            warps: 1,
            ..Config::default()
        })
        .collect()
}

/// Reallocation within groups of 2 lanes (`+RA_2`) in a 4-thread warp: a lane's group holds
/// one stack to lend, the other group's idle stacks are out of its reach.
pub fn group_configs() -> Vec<Config> {
    use rtl::config::{RbSize, Realloc, ShPolicy};
    [(1, 1, true), (2, 1, false)]
        .into_iter()
        .map(|(n, m, skew)| Config {
            rb: RbSize::Entries(n),
            sh_entries: m,
            skew,
            policy: ShPolicy::Group { ra: Realloc { borrow_limit: 1, flush_limit: 1 }, lanes: 2 },
            warp_size: 4,
            warps: 1,
            ..Config::default()
        })
        .collect()
}

/// One case of `sms check --full`: a configuration, the lanes active when its warp loads, and
/// the depth cap.
#[derive(Clone, Copy, Debug)]
pub struct Case {
    pub cfg: Config,
    /// Bit per lane; the others start finished (their stacks Idle with reallocation).
    pub active: u32,
    pub cap: u32,
    /// Explore depth first ([`Bounds::dfs`]): the 4-thread warps with M = 2 and reallocation,
    /// whose BFS levels would hold millions of models.
    pub dfs: bool,
    /// Offer commands to busy threads ([`Bounds::busy_cmds`]).
    pub busy_cmds: bool,
    /// Offer two threads' commands in one cycle ([`Bounds::pairs`]).
    pub pairs: bool,
    /// The warp explored ([`Bounds::warp`]).
    pub warp: u32,
    /// Cover goals the case's cap cannot reach, which its siblings reach (see
    /// [`corner_cases`]).
    pub waived: &'static [Goal],
    /// Active lanes never offered a command ([`Bounds::silent`]).
    pub silent: u32,
    /// Offer a micro-op completion and a command in one cycle ([`Bounds::uop_cmds`]).
    pub uop_cmds: bool,
}

impl Case {
    fn all_lanes(c: &Config) -> u32 {
        u32::MAX >> (32 - c.warp_size)
    }
    /// Every lane active, under [`default_cap`]; the 4-thread warps with M = 2 and reallocation
    /// depth first.
    pub fn full(cfg: Config) -> Case {
        Case { active: Case::all_lanes(&cfg), cap: default_cap(&cfg), dfs: is_large(&cfg), ..Case::new(cfg) }
    }
    /// Every lane active under [`default_cap`], breadth first, warp 0, one command per action.
    pub fn new(cfg: Config) -> Case {
        Case {
            cfg,
            active: Case::all_lanes(&cfg),
            cap: default_cap(&cfg),
            dfs: false,
            busy_cmds: false,
            pairs: false,
            warp: 0,
            waived: &[],
            silent: 0,
            uop_cmds: false,
        }
    }
    pub fn partial(&self) -> bool {
        self.active != Case::all_lanes(&self.cfg)
    }
    /// The cover goals the case must reach: those its configuration has the feature for. A
    /// partial warp never falls back to per-entry spills (an Idle stack is always there to
    /// borrow). A one-lane warp is where a chain of three rotates twice within a small cap
    /// ([`Goal::NonAdjacentRelease`]); a two-lane warp under [`default_cap`] shares that cap
    /// between its lanes, so it is not asked for flush saturation or that rotation (its
    /// one-lane sibling reaches both).
    pub fn goals(&self) -> Vec<Goal> {
        let mut g: Vec<Goal> = Goal::ALL.into_iter().filter(|g| g.applies(&self.cfg)).collect();
        if self.partial() {
            g.retain(|&g| g != Goal::PerEntryFallback);
            let three = self.cfg.realloc().is_some_and(|r| r.borrow_limit >= 2);
            match self.active.count_ones() {
                1 if three => g.push(Goal::NonAdjacentRelease),
                1 => {}
                _ => g.retain(|&g| g != Goal::FlushSaturation),
            }
        }
        g.retain(|g| !self.waived.contains(g));
        if self.busy_cmds {
            g.push(Goal::BusyRefusal);
        }
        if self.pairs && self.cfg.realloc().is_some() {
            g.push(Goal::SameCycleBorrow);
        }
        if self.uop_cmds {
            g.push(Goal::BusyAsLastUopCompletes);
            if self.cfg.realloc().is_some() {
                g.push(Goal::ReleaseMeetsBorrow);
            }
        }
        g
    }
    pub fn bounds(&self) -> Bounds {
        Bounds {
            active: Some(self.active),
            dfs: self.dfs,
            busy_cmds: self.busy_cmds,
            pairs: self.pairs,
            warp: self.warp,
            silent: self.silent,
            uop_cmds: self.uop_cmds,
            ..Bounds::fixpoint(self.cap)
        }
    }
    pub fn describe(&self) -> String {
        let lanes = if self.partial() {
            format!(" lanes {:0w$b}", self.active, w = self.cfg.warp_size as usize)
        } else {
            String::new()
        };
        let warp =
            if self.warp > 0 { format!(" (warp {} of {})", self.warp, self.warp + 1) } else { String::new() };
        let busy = if self.busy_cmds { " +busy commands" } else { "" };
        let pairs = if self.pairs { " +two per cycle" } else { "" };
        let uop_cmds = if self.uop_cmds { " +completion with command" } else { "" };
        let silent = if self.silent != 0 { format!(" silent {:b}", self.silent) } else { String::new() };
        format!("{}{lanes}{silent}{warp}{busy}{pairs}{uop_cmds}", describe(&self.cfg))
    }
}

/// Every case `sms check --full` proves: [`full_configs`] with every lane active under
/// [`default_cap`], plus one-lane warps with chains of three stacks (lanes 1–3 start finished,
/// so lane 0 borrows at once) under a cap that lets every stack of a full chain be flushed once
/// and the first again, so flushes rotate the chain far enough that a release is not of the
/// stack after its owner — with 1-entry stacks (cap 8), and with 2-entry skewed stacks over 8
/// banks (bases 0 0 1 1: skew with reallocation; cap 14); and the skewed 2-entry
/// configurations with reallocation of [`skew_configs`] (4 and 8 banks) with two lanes active,
/// racing to borrow the two Idle stacks, under [`default_cap`]. (Two lanes with the one-lane
/// cap 14 pass 8 · 10⁶ states.)
pub fn full_cases() -> Vec<Case> {
    use rtl::config::{RbSize, Realloc, ShPolicy};
    let mut out: Vec<Case> = full_configs().into_iter().map(Case::full).collect();
    for (m, banks) in [(1, 32), (2, 8)] {
        let cfg = Config {
            rb: RbSize::Entries(1),
            sh_entries: m,
            skew: true,
            banks,
            policy: ShPolicy::Realloc(Realloc { borrow_limit: 2, flush_limit: 1 }),
            warp_size: 4,
            warps: 1,
            ..Config::default()
        };
        // RB, then every stack of the chain filled, flushed once, and the first flushed again
        // (flush saturation), then one more entry.
        let cap = 1 + 2 * m * 3 + 1;
        out.push(Case { active: 1, cap, ..Case::new(cfg) });
    }
    for c in skew_configs().into_iter().filter(|c| c.realloc().is_some()) {
        out.push(Case { active: 0b0011, ..Case::new(c) });
    }
    out.extend(corner_cases());
    out
}

/// The cases at the design's own sizes, each with few active lanes so the search stays small
/// (each waives only the cover goals a sibling case reaches):
/// - M = 4 on an 8-lane warp (skew bases 0 0 0 0 1 1 1 1), one lane at base 1 whose chains of
///   three rotate under flushes;
/// - the paper's RB_8+SH_8, borrow limit 4, flush limit 3, on one lane of a 32-lane warp (lane
///   21: skew base 2): its RB, a chain of five 8-entry stacks and an entry in global memory;
/// - chains of 5 one-entry stacks with flush limit 3, deep enough that flushes rotate the chain
///   until a flush counter stands at its limit; and chains of 2 with flush limit 3, deep enough
///   that a flush saturates;
/// - two lanes above 15 of a 32-lane warp (16 and 30) racing for Idle stacks in chains of up
///   to 5, while lanes 0–15 are active but silent (still waiting on their first node), so the
///   stacks lent are lanes 17 and up (Next TID needs 5 bits);
/// - the second warp of an RT unit (thread ids differ from lanes);
/// - two threads' commands planned in one cycle, commands offered to busy threads, and a
///   micro-op completion with a command in one cycle;
/// - M = 16 and M = 32 (4- and 5-bit Top and Bottom, skew base lane mod M) on one lane of a
///   32-lane warp, through a full chain of two stacks, a flush and the global reload.
pub fn corner_cases() -> Vec<Case> {
    use rtl::config::{RbSize, Realloc, ShPolicy};
    let ra = |borrow_limit, flush_limit| Some(Realloc { borrow_limit, flush_limit });
    let cfg = |n, m, ws, realloc| Config {
        rb: RbSize::Entries(n),
        sh_entries: m,
        skew: m > 0,
        policy: ShPolicy::from(realloc),
        warp_size: ws,
        warps: 1,
        ..Config::default()
    };
    let deep = &[Goal::FlushSaturation, Goal::FlushAtLimit, Goal::NonAdjacentRelease];
    vec![
        Case { active: 1 << 5, cap: 22, ..Case::new(cfg(1, 4, 8, ra(2, 1))) },
        Case { active: 1 << 21, cap: 8 + 8 * 5 + 1, waived: deep, ..Case::new(cfg(8, 8, 32, ra(4, 3))) },
        Case {
            active: 1 << 3,
            cap: 18,
            waived: &[Goal::FlushSaturation],
            ..Case::new(cfg(1, 1, 8, ra(4, 3)))
        },
        Case { active: 1 << 2, cap: 10, ..Case::new(cfg(1, 1, 4, ra(1, 3))) },
        Case {
            active: 0x1_FFFF | 1 << 30,
            silent: 0xFFFF,
            cap: 12,
            waived: &[Goal::FlushAtLimit, Goal::ExitAfterBorrow],
            ..Case::new(cfg(1, 2, 32, ra(4, 3)))
        },
        Case { active: 0b0110, warp: 1, ..Case::new(cfg(1, 1, 4, ra(2, 1))) },
        Case {
            active: 0b0011,
            busy_cmds: true,
            pairs: true,
            uop_cmds: true,
            cap: 6,
            ..Case::new(cfg(1, 1, 4, ra(2, 1)))
        },
        // M = 16: lane 17 (base 1) on a 32-lane warp, the others finished: its RB, a chain of
        // two 16-entry stacks, then a flush of the oldest and the global reload.
        Case {
            active: 1 << 17,
            cap: 1 + 2 * 16 + 1,
            waived: &[Goal::FlushSaturation],
            ..Case::new(cfg(1, 16, 32, ra(1, 1)))
        },
        // M = 32: lane 21 (base 21; the stack it borrows, lane 0's, links back to it with Next
        // TID 21), the same path through 32-entry stacks.
        Case {
            active: 1 << 21,
            cap: 1 + 2 * 32 + 1,
            waived: &[Goal::FlushSaturation],
            ..Case::new(cfg(1, 32, 32, ra(1, 1)))
        },
    ]
}

/// Small skewed configurations with few banks: RB_1+SH_2 on 4-thread warps with 4 banks (bases
/// 0 1 0 1) and 8 banks (bases 0 0 1 1), without and with reallocation (borrow limit 2).
pub fn skew_configs() -> Vec<Config> {
    use rtl::config::{RbSize, Realloc, ShPolicy};
    let mut out = Vec::new();
    for banks in [4, 8] {
        for borrow in [0, 2] {
            out.push(Config {
                rb: RbSize::Entries(1),
                sh_entries: 2,
                skew: true,
                banks,
                policy: ShPolicy::from(
                    (borrow > 0).then_some(Realloc { borrow_limit: borrow, flush_limit: 1 }),
                ),
                warp_size: 4,
                warps: 1,
                ..Config::default()
            });
        }
    }
    out
}

/// A configuration's short description for reports.
pub fn describe(c: &Config) -> String {
    let ra =
        c.realloc().map_or(String::new(), |r| format!(" borrow {} flush {}", r.borrow_limit, r.flush_limit));
    let banks = if c.banks == 32 { String::new() } else { format!(" banks {}", c.banks) };
    format!("{} warp {}{}{}", c.name(), c.warp_size, ra, banks)
}
