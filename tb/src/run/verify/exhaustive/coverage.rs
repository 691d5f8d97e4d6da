//! What an exhaustive run reached: the cover goals (situations a run must reach for its
//! verdict to mean anything), their counts, the search's statistics, and how a command's
//! effect is mapped to the goals it hits.

use std::hash::Hash;
use std::time::Duration;

use rtl::config::{Config, Overflow};
use rtl::stack_manager::{Src, StackManager, StackStats, Uop};

/// The cover goals, each a situation a run must reach (when the configuration has
/// the feature) for its "all properties hold" to mean anything.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Goal {
    /// A thread borrows an idle stack.
    Borrow,
    /// A borrowed stack is released out of allocation order: it does not sit right after its
    /// owner on the ring, or the ring's order was not the priority order before the pop.
    RotatedRelease,
    /// A chain of 1 + borrow-limit stacks.
    FullChain,
    /// A whole SH stack is flushed to global memory.
    Flush,
    /// A flush of a stack whose flush count is at its limit.
    FlushSaturation,
    /// With reallocation on, a spill falls back to moving one entry SH → global.
    PerEntryFallback,
    /// A drained dedicated stack moves to the bottom of its chain.
    Demotion,
    /// A pop reloads from global memory into the oldest stack (lowest Priority) of a chain of
    /// two or more: the reload's SH store names that stack.
    OldestReload,
    /// A warp exits after one of its threads borrowed.
    ExitAfterBorrow,
    /// An SH access to a stack whose skewed base entry is not 0.
    SkewBase,
    /// A released stack is not the one right after its owner on the ring (two flushes rotated
    /// a chain of three). Asked of the partial-warp cases ([`Case::goals`]) only: a full warp
    /// reaches it only past the default cap.
    NonAdjacentRelease,
    /// A stack's flush counter stands at its limit, when the limit is above 1.
    FlushAtLimit,
    /// A command offered to a busy thread is refused. Asked of the cases that offer such
    /// commands ([`Case::busy_cmds`]).
    BusyRefusal,
    /// Two threads borrow in one cycle, the second seeing the first's lend. Asked of the cases
    /// that plan two threads' commands in one cycle ([`Case::pairs`]) with reallocation.
    SameCycleBorrow,
    /// A stack whose release completes in a cycle is borrowed by another thread's command in
    /// that same cycle. Asked of the cases that offer a completion and a command in one cycle
    /// ([`Case::uop_cmds`]) with reallocation.
    ReleaseMeetsBorrow,
    /// A command of a thread whose last micro-op completes in the same cycle is refused (Busy).
    /// Asked of the cases that offer a completion and a command in one cycle.
    BusyAsLastUopCompletes,
    /// A restart design drops an entry on overflow.
    Drop,
    /// A restart design answers a pop with Restart.
    Restart,
}

impl Goal {
    pub const ALL: [Goal; 18] = [
        Goal::Borrow,
        Goal::RotatedRelease,
        Goal::FullChain,
        Goal::Flush,
        Goal::FlushSaturation,
        Goal::PerEntryFallback,
        Goal::Demotion,
        Goal::OldestReload,
        Goal::ExitAfterBorrow,
        Goal::SkewBase,
        Goal::NonAdjacentRelease,
        Goal::FlushAtLimit,
        Goal::BusyRefusal,
        Goal::SameCycleBorrow,
        Goal::ReleaseMeetsBorrow,
        Goal::BusyAsLastUopCompletes,
        Goal::Drop,
        Goal::Restart,
    ];

    /// Whether `c` has the feature the goal needs (so it must be reached).
    pub fn applies(self, c: &Config) -> bool {
        let ra = c.realloc().is_some();
        let finite = c.rb.capacity().is_some();
        let drops = c.overflow == Overflow::Drop;
        match self {
            Goal::Borrow | Goal::FullChain | Goal::Demotion | Goal::ExitAfterBorrow => ra && finite,
            Goal::Flush | Goal::FlushSaturation => ra && finite,
            // A restart design neither spills single entries to global memory nor reloads.
            Goal::PerEntryFallback | Goal::OldestReload => ra && finite && !drops,
            Goal::Drop | Goal::Restart => drops,
            // With one borrowed stack it always sits right after its owner, and the priorities
            // then follow the ring at every release.
            Goal::RotatedRelease => finite && c.realloc().is_some_and(|r| r.borrow_limit >= 2),
            Goal::SkewBase => finite && (0..c.warp_size).any(|l| c.skew_base(l) != 0),
            Goal::FlushAtLimit => finite && c.realloc().is_some_and(|r| r.flush_limit >= 2),
            Goal::NonAdjacentRelease
            | Goal::BusyRefusal
            | Goal::SameCycleBorrow
            | Goal::ReleaseMeetsBorrow
            | Goal::BusyAsLastUopCompletes => false,
        }
    }
}

/// How often each [`Goal`] was reached.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Covers([u64; Goal::ALL.len()]);

impl Covers {
    pub fn hit(&mut self, g: Goal) {
        self.0[g as usize] += 1;
    }
    pub fn count(&self, g: Goal) -> u64 {
        self.0[g as usize]
    }
    /// Goals `c` needs that were never reached.
    pub fn missing(&self, c: &Config) -> Vec<Goal> {
        Goal::ALL.into_iter().filter(|&g| g.applies(c) && self.count(g) == 0).collect()
    }
    /// Of `goals`, those never reached.
    pub fn missing_of(&self, goals: &[Goal]) -> Vec<Goal> {
        goals.iter().copied().filter(|&g| self.count(g) == 0).collect()
    }
}

/// What an exhaustive run covered.
#[derive(Clone, Debug, Default)]
pub struct Coverage {
    pub states: usize,
    pub transitions: u64,
    /// Action sequences of every length up to the bound (counted through merged states).
    pub sequences: u128,
    /// The last BFS level (depth first: the longest path).
    pub depth_reached: u32,
    /// The state cap was not hit.
    pub complete: bool,
    /// No new state appeared: every reachable state (under the depth cap) was explored.
    pub fixpoint: bool,
    pub elapsed: Duration,
    /// Most states in one BFS level (depth first: the models held on the path at its peak).
    pub peak_frontier: usize,
    /// Bytes of the models the search held at its peak (one BFS level, or the depth-first
    /// path), from [`Model::bytes`].
    pub peak_frontier_bytes: usize,
    /// States expanded by one private micro-op alone ([`Bounds::por`]).
    pub reduced: usize,
    /// Bytes of the visited set and the predecessor table at the end (the search's memory
    /// besides the frontier).
    pub visited_bytes: usize,
    /// How often the interesting paths were reached (none may be zero for a non-vacuous run
    /// when the configuration has the feature).
    pub borrows: u64,
    pub flushes: u64,
    pub global_reloads: u64,
    pub releases: u64,
    pub warp_exits: u64,
    pub covers: Covers,
}

/// Records the cover goals a command of thread `t` reached; `d` is what it counted, `ring` its
/// chain before a pop (ring order from its dedicated stack, each member's Priority then).
pub(super) fn observe_covers(
    sm: &StackManager,
    t: u32,
    d: &StackStats,
    ring: Option<&[(u32, u32)]>,
    c: &mut Covers,
) {
    let cfg = sm.config();
    if d.borrows > 0 {
        c.hit(Goal::Borrow);
    }
    if d.flushes > 0 {
        c.hit(Goal::Flush);
    }
    if d.flushes_saturated > 0 {
        c.hit(Goal::FlushSaturation);
    }
    if let Some(ra) = cfg.realloc().filter(|r| r.flush_limit >= 2) {
        if sm.warp_threads(sm.warp_of(t)).any(|s| sm.stack(s).flush == ra.flush_limit) {
            c.hit(Goal::FlushAtLimit);
        }
    }
    if d.demotions > 0 {
        c.hit(Goal::Demotion);
    }
    if d.drops > 0 {
        c.hit(Goal::Drop);
    }
    if d.restarts > 0 {
        c.hit(Goal::Restart);
    }
    if cfg.realloc().is_some() && d.sh_to_global > 0 && d.flushes == 0 {
        c.hit(Goal::PerEntryFallback);
    }
    let chain = sm.chain(t);
    if let Some(ra) = cfg.realloc() {
        if chain.len() as u32 == 1 + ra.borrow_limit {
            c.hit(Goal::FullChain);
        }
    }
    // The reload's SH store (data from the latch after a global load) must land in the chain's
    // oldest stack, not merely happen in a chain.
    let oldest = chain.iter().copied().min_by_key(|&s| sm.stack(s).priority);
    let reload_into = sm.pending_uops(t).find_map(|u| match *u {
        Uop::ShStore { stack, src: Src::Latch, .. } => Some(stack),
        _ => None,
    });
    if d.global_to_sh > 0 && chain.len() > 1 && reload_into.is_some() && reload_into == oldest {
        c.hit(Goal::OldestReload);
    }
    if let (true, Some(ring)) = (d.releases > 0, ring) {
        // Out of allocation order: the released stack is not the one after the owner, or the
        // ring's order was not the priority order before the pop.
        let released = ring.iter().map(|r| r.0).find(|s| !chain.contains(s));
        let in_order = ring.iter().enumerate().all(|(i, r)| r.1 == i as u32);
        let apart = released.is_some_and(|s| ring.get(1).map(|r| r.0) != Some(s));
        if apart || !in_order {
            c.hit(Goal::RotatedRelease);
        }
        if apart {
            c.hit(Goal::NonAdjacentRelease);
        }
    }
    let ws = cfg.warp_size;
    let skewed = sm.pending_uops(t).any(|u| match *u {
        Uop::ShLoad { stack, .. } | Uop::ShStore { stack, .. } => cfg.skew_base(stack % ws) != 0,
        _ => false,
    });
    if skewed {
        c.hit(Goal::SkewBase);
    }
}
