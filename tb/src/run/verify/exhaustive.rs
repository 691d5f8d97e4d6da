//! Exhaustive model checking on stable Rust: bounded search, or exploration to a fixpoint.
//!
//! Breadth-first over every sequence of actions, for one warp of a small configuration. An
//! action is either a command from a ready thread (push of one of a few values, pop, finish —
//! invalid ones included: the design must refuse them) or the completion of one pending
//! micro-op of a busy thread. So every interleaving of commands *and* of micro-ops across
//! threads is covered, including a release racing a borrow. Equal states (design + reference)
//! are explored once. After every action the properties of [`super::invariants`] are checked;
//! the first violation comes back with the shortest action sequence that reaches it (depth
//! first, for the largest cases: a sequence that reaches it). Micro-ops private to one thread
//! are not interleaved with other threads' actions (partial-order reduction, below).
//!
//! **Fixpoint.** With [`Bounds::fixpoint`] there is no bound on the number of actions: the
//! search runs until a BFS level brings no new state, so every state reachable while the warp
//! holds at most `cap` entries has been visited and checked — a proof for that configuration
//! under that cap, for every interleaving and unbounded in time. The cap bounds the *logical*
//! stack depth (pushes are offered only while the warp holds fewer than `cap` entries); pops,
//! finishes and micro-op completions are always offered. [`default_cap`] picks a cap that
//! fills a whole chain and reaches global memory.
//!
//! **What a state is.** The state key ([`Model::key`]) covers what decides future behaviour
//! and nothing else: no event counter (`stats`, `pops_checked`: equal states reached by
//! different paths would otherwise count as different and the search would never close), and
//! no stale memory word (a popped SH entry or global slot keeps its old value, which the design
//! never reads again — [`Property::LiveReads`], checked on every accepted command, makes that
//! an obligation rather than an assumption). States are stored as 128-bit hashes (hash
//! compaction); the visited set plus the predecessor table (for counterexample traces) cost
//! about 25 bytes a state.
//!
//! **Why two push values suffice, and one marked push per run.** The stack manager is data
//! independent: it moves entries between RB, SH and global memory and compares none of them (no
//! branch, address or register depends on an entry's value — [`Model::key`] would otherwise
//! need the values anyway). So a run's control (every register, pointer and micro-op) does not
//! depend on the values pushed, and every value the hardware holds or answers is a copy of one
//! pushed value (or [`rtl::stack_manager::POISON`]). A Conservation or Equivalence failure is a
//! position where the hardware holds (or answers) a copy of push *a*, or poison, while the
//! reference has push *b* ≠ *a* there (or the lengths differ, seen with any values). Giving push
//! *b* the value [`MARKED`] and every other push [`UNMARKED`] keeps the run a run of the design
//! and the position wrong (UNMARKED or POISON against MARKED). So every such failure with
//! arbitrary values has one in which at most one push per run is marked (Wolper's
//! data-independence argument, POPL 1986). The fixpoint runs use exactly that
//! ([`Bounds::one_mark`]): a push offers MARKED only while no push of the run has taken it,
//! which keeps the states linear rather than exponential in the entries held; the bounded
//! search offers every value 1..=`values` at every push.
//!
//! **Partial-order reduction** ([`Bounds::por`], on for the fixpoint runs). An ample-set
//! reduction (Peled, CAV 1993; Godefroid, LNCS 1032, 1996; Clarke, Grumberg and Peled, *Model
//! Checking*, ch. 10): a state whose thread `t` has a *private* micro-op next — a global load,
//! a global store, or latch → RB bottom ([`Model::private_uop`], the lowest such thread) — is
//! expanded by that one action α; every other state by all its actions. Private means α reads
//! and writes only thread `t`'s RB (`rb[t]`), its own spill region (`global[t]`: a global
//! micro-op carries a slot of the *issuing* thread's region), its sequencer and data latch, and
//! the model's shadow of that latch. In the design's code the only writers of those are `t`'s
//! own micro-ops and `t`'s own commands (the planner's `Write::Rb*`, `Write::Global` and
//! `Write::Seq` all name the planning or completing thread), and no other thread's planner or
//! micro-op reads them: a command of `u` plans from `u`'s registers, the stack registers and the
//! threads' Done bits. That is a property of the code that writes, not of the values it writes,
//! so it holds for every mutant too (they change decisions, not which thread's RB or region a
//! write names). The conditions:
//! - C0: α is enabled, so the ample set is empty only when the state has no action.
//! - C1 (independence): no action of another thread reads or writes what α touches, so α and
//!   any such action commute (same state either order) and neither enables or disables the
//!   other; the actions of `t` itself cannot run before α (its sequencer is in order and a
//!   busy thread takes no command). So on every path from the state, only actions independent
//!   of α occur before α.
//! - C2 (invisibility): every check is monotone in α. The state checks after an action read the
//!   stack and thread registers and the SH words (not written by α), the logical stacks of
//!   *ready* threads (`t` is busy before α, so α can only add `t`'s check), and the quiescent
//!   and warp-exit checks, which α can only switch on (as `t`'s last micro-op). So a check that
//!   fails before α fails after it. The checks on another thread's action (Equivalence,
//!   RequestSequence, LiveReads, the bank map, placement, the cover goals) read that thread's
//!   state and the shared registers only, so they see the same before and after α.
//! - C3 (cycle proviso): every reduced step completes a micro-op, so it lowers the number of
//!   pending micro-ops by one; a cycle must contain a command, taken only from a fully expanded
//!   state. So no action is ignored around a cycle, whatever the search order (BFS or DFS).
//!
//! Then any run of the full graph that reaches a failing check has a permutation, with α moved
//! to the front, that the reduced graph contains and that fails a check too; by induction over
//! the run, the reduced search finds a violation whenever the full one does, and reaches the
//! same cover goals (observed on commands, which see the same state). SH micro-ops and releases
//! are *not* private: which stack a command's micro-ops name, and who may take a stack next, is
//! the planner's decision — the very thing under check — so treating them as independent would
//! assume the Chains property the search is proving. `tests/fixpoint.rs` runs every BFS case
//! with and without the reduction (same verdicts and covers, 6 % fewer states over the set) and
//! `tests/mutants.rs` catches every mutant both ways. `sms check --full --no-por` turns it off.
//!
//! **Several actions in one cycle.** Two threads' commands ([`Action::Both`], [`Bounds::pairs`])
//! and a micro-op completion with a command ([`Action::UopWithCmd`], [`Bounds::uop_cmds`]) are
//! checked against the same actions one after the other ([`Property::SameCycle`]) and then
//! taken through the checked path action by action, so they add transitions, not states. The
//! reduction above skips a combined action whose completion is a private micro-op α: such a
//! cycle is α and then the command, since a plan reads nothing α writes (a command of α's own
//! thread is refused in both, the thread being busy), so the check it would make holds
//! trivially; a combined action of another thread's completion commutes with α as its parts do.
//!
//! **Flush counts.** The model counts each stack's consecutive flushes itself
//! ([`Property::FlushCount`]): after every accepted command it runs the specification's case
//! table ([`super::sequence::expected_flush_counts`]) over the registers with its own counts in
//! place of the Flush registers, and compares the design's registers with the counts that
//! gives. The counts are not in the state key: while the property holds they equal the
//! registers the key hashes.
//!
//! **Depth first.** The 4-thread warps with M = 2 and reallocation ([`Case::dfs`]) are searched
//! depth first ([`Bounds::dfs`]): a BFS level of theirs holds millions of models (about 2.3 kB
//! each: the stack manager's vectors, the scoreboard, the shadows), the depth-first path only
//! one model per [`CHECKPOINT`] steps and the last [`CHECKPOINT`] steps' (a step otherwise costs
//! its action list and the action that led there, about 100 bytes; a model dropped from the path
//! is rebuilt by replaying the path's actions from the checkpoint below). Memory is then the
//! visited set (17 to 34 bytes a state, no predecessor table). Same checks on every transition;
//! the counterexamples are no longer shortest. (The key hashes a live SH word that a pending
//! store is about to overwrite, so a state reached with different stale words there counts
//! twice; which of them is met first depends on the order, so BFS and DFS counts differ by a
//! few per cent.)
//!
//! **No lane symmetry.** Lanes of a warp are not interchangeable here: a borrower takes the
//! *lowest-numbered* idle stack (`first_idle`), a chain's ring order follows Next TID, and with
//! skew each lane's stack starts at its own base entry. Permuting lanes changes which stack is
//! lent and where entries land, so merging lane-permuted states would be unsound; the search
//! does not do it.
//!
use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::time::{Duration, Instant};

use rtl::config::{Config, Overflow};
use rtl::stack_manager::{Cmd, Src, StackError, StackManager, StackRegs, StackStats, Uop, POISON};

use super::harness::Scoreboard;
use super::invariants::{
    check_bank_map, check_no_overlap, check_placement, check_thread, check_warp_exit, check_warp_fields,
    fail, Property, Violation,
};
use super::sequence::{check_sequence, expected_flush_counts, Before};

/// One step of an explored sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    Cmd(u32, Cmd),
    /// Two threads' commands in one cycle, planned in this order (the second sees the stack
    /// registers the first changed).
    Both(u32, Cmd, u32, Cmd),
    /// Thread's next micro-op completes.
    Uop(u32),
    /// In one cycle the first thread's next micro-op completes and the second thread's
    /// command is planned (the two threads may be one: its command is then refused, the thread
    /// being busy as the cycle begins).
    UopWithCmd(u32, u32, Cmd),
}

/// Bounds of one exhaustive run.
#[derive(Clone, Copy, Debug)]
pub struct Bounds {
    /// Longest action sequence (BFS level); `u32::MAX` explores to the fixpoint.
    pub depth: u32,
    /// Distinct push values (≥ 2 to see reordering).
    pub values: u32,
    /// Stop early when this many distinct states have been seen.
    pub max_states: usize,
    /// Cap on the warp's logical stack depth: the sum over its threads of the entries each
    /// holds. A push is offered only while the warp holds fewer entries; `None` = no cap.
    pub cap: Option<u32>,
    /// Check [`Property::RequestSequence`] (default); off to see which state property catches a
    /// bug without it.
    pub request_sequence: bool,
    /// Lanes active when the warp loads (bit per lane; the others start finished, their stacks
    /// Idle with reallocation); `None` = every lane.
    pub active: Option<u32>,
    /// At most one push per run carries a distinguished value, the others all one value
    /// ([`Model::one_mark`]); `values` is then unused. On for [`Bounds::fixpoint`].
    pub one_mark: bool,
    /// Partial-order reduction (module doc): a state whose thread has a private micro-op next
    /// (global load, global store, latch → RB bottom) is expanded by that action alone. On for
    /// [`Bounds::fixpoint`]; `sms check --no-por` turns it off.
    pub por: bool,
    /// Depth first instead of breadth first ([`check`]): the search then holds one model per
    /// step of the current path instead of a whole BFS level, so memory is the visited set plus
    /// the path; counterexamples are no longer shortest, and `depth` is ignored (to the
    /// fixpoint only). For the large cases of [`full_cases`] ([`Case::dfs`]).
    pub dfs: bool,
    /// Print a progress line to stderr every 2²² states of a depth-first search (`sms check
    /// --full`).
    pub progress: bool,
    /// Also offer every command to threads that are busy (a program still running), which the
    /// design must refuse without changing anything ([`Property::Busy`]).
    pub busy_cmds: bool,
    /// Also offer two ready threads' commands planned in one cycle ([`Action::Both`]), which
    /// must equal planning them one after the other ([`Property::SameCycle`]).
    pub pairs: bool,
    /// The warp explored: its threads start at `warp × warp size`, and the configuration
    /// holds `warp + 1` warps (so a nonzero warp's thread ids differ from its lanes).
    pub warp: u32,
    /// Overwrite dead SH words with [`POISON`] after every action ([`Model::scrub`]; on by
    /// default). Off only to show what the state key would miss without it.
    pub scrub: bool,
    /// Lanes (bit per lane) that load active but are never offered a command: threads still
    /// waiting on their first node, which keep their stacks out of the Idle pool so the idle
    /// search reaches higher lanes.
    pub silent: u32,
    /// Also offer a micro-op completion and a command in one cycle ([`Action::UopWithCmd`]):
    /// the completing thread's own command and every other ready thread's, which must equal
    /// completing and then planning ([`Property::SameCycle`]).
    pub uop_cmds: bool,
    /// Check [`Property::FlushCount`] (default); off to show which bugs only it catches.
    pub flush_count: bool,
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds {
            depth: u32::MAX,
            values: 2,
            max_states: usize::MAX,
            cap: None,
            request_sequence: true,
            active: None,
            one_mark: false,
            por: false,
            dfs: false,
            progress: false,
            busy_cmds: false,
            pairs: false,
            warp: 0,
            scrub: true,
            silent: 0,
            uop_cmds: false,
            flush_count: true,
        }
    }
}

impl Bounds {
    /// Every interleaving, unbounded in time, under the depth cap `cap`: a proof for the
    /// configuration when the run reaches its fixpoint ([`Coverage::fixpoint`]).
    pub fn fixpoint(cap: u32) -> Bounds {
        Bounds { cap: Some(cap), one_mark: true, por: true, ..Bounds::default() }
    }
}

/// The depth cap of a configuration's fixpoint run: enough entries for one thread to fill its RB
/// and a full chain of 1 + borrow-limit SH stacks and put one entry in global memory (RB_FULL:
/// three entries). Two-thread warps with reallocation and M = 1, and restart designs with
/// reallocation and M = 1, get 2 more, so the chain's two stacks are each flushed once and the
/// first a second time (flush saturation).
pub fn default_cap(c: &Config) -> u32 {
    let chain = 1 + c.realloc().map_or(0, |r| r.borrow_limit);
    // A thread that can borrow from one other lane only (a 2-thread warp, or groups of 2 lanes)
    // needs two entries more to flush a stack at its limit: the two stacks take turns.
    let pairs = c.policy.lend_window(0, c.warp_size).1 == 2;
    // So does a restart design: its full chain empties the oldest member, so each stack's turn
    // to be emptied again comes two entries later.
    let drops = c.overflow == Overflow::Drop;
    let extra = if c.realloc().is_some() && (pairs || drops) && c.sh_entries == 1 { 2 } else { 0 };
    match c.rb.capacity() {
        Some(n) => n + c.sh_entries * chain + 1 + extra,
        None => 3,
    }
}

/// The 4-thread warps with M = 2 and reallocation: the largest state spaces of the full set.
pub fn is_large(c: &Config) -> bool {
    c.warp_size == 4 && c.sh_entries == 2 && c.realloc().is_some()
}

/// A smaller cap for the [`is_large`] configurations (`sms check --full --small-cap`): one
/// thread's RB, two full SH stacks and one entry more (the third stack of a chain), shared by the
/// four lanes — 6 entries for RB_1, 7 for RB_2. Every cover goal is reached under it too (the
/// lanes' entries together force flushes, saturation, demotion and reloads into the oldest
/// stack), in 10.6 · 10⁶ states (RB_1) and 4.8 · 10⁶ (RB_2); their default is [`default_cap`]
/// (8 and 9: a whole chain and one entry in global memory): 1.0 · 10⁸ and 3.9 · 10⁷ states,
/// 842 s and 369 s here (docs/verification.md).
pub fn large_cap(c: &Config) -> u32 {
    c.rb.capacity().unwrap_or(0) + 2 * c.sh_entries + 1
}

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

/// A property violation and the shortest action sequence that reaches it.
#[derive(Clone, Debug)]
pub struct Counterexample {
    pub violation: Violation,
    pub trace: Vec<Action>,
}

impl std::fmt::Display for Counterexample {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{}", self.violation)?;
        for (i, a) in self.trace.iter().enumerate() {
            writeln!(f, "  {i:3}: {a:?}")?;
        }
        Ok(())
    }
}

/// The design under test and its reference, checked after every action.
#[derive(Debug)]
pub struct Model {
    pub sm: StackManager,
    pub sb: Scoreboard,
    /// Per thread of the warp: what its sequencer's data latch holds, and the values its
    /// pending global loads will read (captured when the command is accepted). Tracked here
    /// from the micro-ops so the state key can leave stale memory out.
    shadow: Vec<Shadow>,
    /// Some thread of the warp borrowed on the way here: one bit of path history, part of the
    /// state so the warp-exit-after-a-borrow cover is not lost when paths merge.
    borrowed: bool,
    /// Check [`Property::RequestSequence`] on every accepted command (on by default; off to
    /// show the state properties catch a bug on their own).
    pub request_sequence: bool,
    /// Offer the marked value [`MARKED`] to at most one push per run; every other push carries
    /// [`UNMARKED`] (see the module doc: one mark suffices). Off: every value 1..=values.
    pub one_mark: bool,
    /// A push of [`MARKED`] was accepted on the way here (path history, part of the state).
    marked: bool,
    /// The warp explored ([`Bounds::warp`]).
    pub warp: u32,
    /// Offer commands to busy threads too ([`Bounds::busy_cmds`]).
    pub busy_cmds: bool,
    /// Offer two threads' commands in one cycle too ([`Bounds::pairs`]).
    pub pairs: bool,
    /// Overwrite dead SH words after every action ([`Bounds::scrub`]).
    pub scrub_dead: bool,
    /// Lanes never offered a command ([`Bounds::silent`]).
    pub silent: u32,
    /// Offer a micro-op completion and a command in one cycle too ([`Bounds::uop_cmds`]).
    pub uop_cmds: bool,
    /// Check [`Property::FlushCount`] ([`Bounds::flush_count`]).
    pub flush_count: bool,
    /// Per lane of the warp: the consecutive flushes of its stack as the checker counts them
    /// from the accepted commands and SPEC section 5 ([`expected_flush_counts`]), never from the
    /// design's Flush register. Not part of the state key: while [`Property::FlushCount`] holds
    /// it equals the registers the key hashes.
    flushes: Vec<u32>,
}

/// The one distinguished push value of a [`Bounds::one_mark`] run.
pub const MARKED: u64 = 1;
/// Every other push value of such a run.
pub const UNMARKED: u64 = 2;

#[derive(Debug, Default, PartialEq, Eq, Hash)]
struct Shadow {
    latch: Option<u64>,
    global_loads: std::collections::VecDeque<u64>,
}

impl Clone for Shadow {
    fn clone(&self) -> Self {
        Shadow { latch: self.latch, global_loads: self.global_loads.clone() }
    }
    fn clone_from(&mut self, src: &Self) {
        self.latch = src.latch;
        self.global_loads.clone_from(&src.global_loads);
    }
}

/// Field by field, so that `clone_from` reuses every allocation of the model it overwrites: the
/// searches clone a model for each transition they try, and most of those land on a state seen
/// before. Both functions name every field, so a new field not cloned here does not compile.
impl Clone for Model {
    fn clone(&self) -> Self {
        let Model {
            sm,
            sb,
            shadow,
            borrowed,
            request_sequence,
            one_mark,
            marked,
            warp,
            busy_cmds,
            pairs,
            scrub_dead,
            silent,
            uop_cmds,
            flush_count,
            flushes,
        } = self;
        Model {
            sm: sm.clone(),
            sb: sb.clone(),
            shadow: shadow.clone(),
            borrowed: *borrowed,
            request_sequence: *request_sequence,
            one_mark: *one_mark,
            marked: *marked,
            warp: *warp,
            busy_cmds: *busy_cmds,
            pairs: *pairs,
            scrub_dead: *scrub_dead,
            silent: *silent,
            uop_cmds: *uop_cmds,
            flush_count: *flush_count,
            flushes: flushes.clone(),
        }
    }
    fn clone_from(&mut self, src: &Self) {
        let Model {
            sm,
            sb,
            shadow,
            borrowed,
            request_sequence,
            one_mark,
            marked,
            warp,
            busy_cmds,
            pairs,
            scrub_dead,
            silent,
            uop_cmds,
            flush_count,
            flushes,
        } = src;
        self.sm.clone_from(sm);
        self.sb.clone_from(sb);
        self.shadow.clone_from(shadow);
        self.borrowed = *borrowed;
        self.request_sequence = *request_sequence;
        self.one_mark = *one_mark;
        self.marked = *marked;
        self.warp = *warp;
        self.busy_cmds = *busy_cmds;
        self.pairs = *pairs;
        self.scrub_dead = *scrub_dead;
        self.silent = *silent;
        self.uop_cmds = *uop_cmds;
        self.flush_count = *flush_count;
        self.flushes.clone_from(flushes);
    }
}

/// A 128-bit hash of the stack manager's whole architectural state
/// ([`StackManager::hash_state`]).
fn state_hash(sm: &StackManager) -> u128 {
    let mut h = KeyHasher::new();
    sm.hash_state(&mut h);
    h.key()
}

/// The state key's hasher. The bytes the state's `Hash` impls write form one stream (each
/// write's bytes in order, as SipHash takes its input; the impls write lengths before contents,
/// so the stream is unambiguous), packed into 64-bit words; each word goes through the SplitMix64
/// finaliser ([`super::harness::mix`]) in two lanes with different seeds, the two halves of the
/// 128-bit key. Packing mixes once per 8 bytes rather than once per field written.
struct KeyHasher {
    lanes: [u64; 2],
    /// Bits written and not yet mixed (fewer than 64 between writes).
    acc: u128,
    bits: u32,
    len: u64,
}

impl KeyHasher {
    fn new() -> Self {
        KeyHasher { lanes: [0x5EED_0001, 0xC0FF_EE02], acc: 0, bits: 0, len: 0 }
    }
    /// Appends the low `n` bits of `x` (`n` ≤ 64; the higher bits of `x` are zero).
    #[inline]
    fn push(&mut self, x: u64, n: u32) {
        self.acc |= u128::from(x) << self.bits;
        self.bits += n;
        self.len += u64::from(n);
        if self.bits >= 64 {
            let w = self.acc as u64;
            self.lanes = self.lanes.map(|h| super::harness::mix(h ^ w));
            self.acc >>= 64;
            self.bits -= 64;
        }
    }
    fn key(mut self) -> u128 {
        let (rest, len) = (self.acc as u64, self.len);
        self.lanes = self.lanes.map(|h| super::harness::mix(super::harness::mix(h ^ rest) ^ len));
        u128::from(self.lanes[0]) << 64 | u128::from(self.lanes[1])
    }
}

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        unreachable!("the state key is taken with KeyHasher::key")
    }
    fn write(&mut self, bytes: &[u8]) {
        for c in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..c.len()].copy_from_slice(c);
            self.push(u64::from_le_bytes(w), 8 * c.len() as u32);
        }
    }
    fn write_u8(&mut self, x: u8) {
        self.push(x.into(), 8);
    }
    fn write_u16(&mut self, x: u16) {
        self.push(x.into(), 16);
    }
    fn write_u32(&mut self, x: u32) {
        self.push(x.into(), 32);
    }
    fn write_u64(&mut self, x: u64) {
        self.push(x, 64);
    }
    fn write_usize(&mut self, x: usize) {
        self.push(x as u64, 64);
    }
}

impl Model {
    /// One warp of `cfg` (its `warps` is forced to 1).
    pub fn new(cfg: Config) -> Result<Model, rtl::config::ConfigError> {
        Model::on_warp(cfg, 0)
    }

    /// Warp `warp` of `cfg`, whose `warps` is forced to `warp + 1` (the warps below stay as
    /// reset and take no commands).
    pub fn on_warp(cfg: Config, warp: u32) -> Result<Model, rtl::config::ConfigError> {
        let cfg = Config { warps: warp + 1, ..cfg };
        Ok(Model {
            sm: StackManager::new(cfg, 0)?,
            sb: Scoreboard::new(&cfg),
            shadow: vec![Shadow::default(); cfg.threads() as usize],
            borrowed: false,
            request_sequence: true,
            one_mark: false,
            marked: false,
            warp,
            busy_cmds: false,
            pairs: false,
            scrub_dead: true,
            silent: 0,
            uop_cmds: false,
            flush_count: true,
            flushes: vec![0; cfg.warp_size as usize],
        })
    }

    /// Thread `t` is never offered a command ([`Bounds::silent`]).
    fn is_silent(&self, t: u32) -> bool {
        self.silent >> (t % self.sm.config().warp_size) & 1 == 1
    }

    /// The explored warp's threads.
    pub fn threads(&self) -> std::ops::Range<u32> {
        self.sm.warp_threads(self.warp)
    }

    /// The state key: a 128-bit hash of everything that decides the warp's future behaviour —
    /// thread and stack registers, RB entries, pending micro-ops, data latches, the values
    /// pending global loads will read, every SH word of the warp's stacks, the global slots
    /// and the reference stacks — and no event counter. Stale SH words are not state because
    /// every action ends by overwriting them with [`POISON`] ([`Model::scrub`]): the model
    /// itself holds no history in dead memory, so two states with equal keys behave alike
    /// forever. A design that reads a dead word ([`Property::LiveReads`]) or moves a pointer
    /// over one it never stored reads POISON, which no push carries.
    pub fn key(&self) -> u128 {
        let mut h = KeyHasher::new();
        self.hash_live(&mut h);
        h.key()
    }

    fn hash_live<H: Hasher>(&self, h: &mut H) {
        let sm = &self.sm;
        let m = sm.config().sh_entries;
        for t in sm.warp_threads(self.warp) {
            sm.thread(t).hash(h);
            let st = sm.stack(t);
            st.hash(h);
            sm.rb(t).hash(h);
            sm.global(t).hash(h);
            for e in 0..m {
                sm.sh_entry(t, e).hash(h);
            }
            h.write_u8(0xEE);
            for u in sm.pending_uops(t) {
                u.hash(h);
            }
            h.write_u8(0xEF);
        }
        self.shadow.hash(h);
        self.borrowed.hash(h);
        self.marked.hash(h);
        self.sb.hash(h);
    }

    /// Applies `a` and checks every property. Returns false if `a` does not apply (a micro-op of
    /// a thread with none pending). Then overwrites every dead SH word with [`POISON`]
    /// ([`Model::scrub`]).
    pub fn act(&mut self, a: Action, cov: &mut Coverage) -> Result<bool, Violation> {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.act_checked(a, cov)));
        r.unwrap_or_else(|p| {
            let why = p
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("no message");
            fail(Property::InRange, format!("the design panicked on {a:?}: {why}"))
        })
    }

    fn act_checked(&mut self, a: Action, cov: &mut Coverage) -> Result<bool, Violation> {
        let r = match a {
            Action::Cmd(t, cmd) if !self.sm.ready(t) => self.refuse_busy(t, cmd, cov),
            Action::Both(t, c, u, d) => self.same_cycle((t, c), (u, d), cov),
            Action::UopWithCmd(u, t, c) => self.uop_with_cmd(u, (t, c), cov),
            Action::Cmd(..) | Action::Uop(_) => self.act_one(a, cov),
        };
        if r == Ok(true) && self.scrub_dead {
            self.scrub();
        }
        r
    }

    /// A command to a busy thread: the design must refuse it (Busy) and change nothing.
    fn refuse_busy(&mut self, t: u32, cmd: Cmd, cov: &mut Coverage) -> Result<bool, Violation> {
        let before = state_hash(&self.sm);
        let got = self.sm.accept(t, cmd);
        if got != Err(StackError::Busy { thread: t }) {
            return fail(Property::Busy, format!("thread {t} is busy: {cmd:?} answered {got:?}"));
        }
        if state_hash(&self.sm) != before {
            return fail(
                Property::Busy,
                format!("thread {t} is busy: the refused {cmd:?} changed the state"),
            );
        }
        cov.covers.hit(Goal::BusyRefusal);
        Ok(true)
    }

    /// Two threads' commands planned in one cycle: the design must answer and leave the state
    /// exactly as planning them one after the other does ([`Property::SameCycle`]); every other
    /// property is checked on the way, command by command.
    fn same_cycle(&mut self, a: (u32, Cmd), b: (u32, Cmd), cov: &mut Coverage) -> Result<bool, Violation> {
        let start = self.sm.clone();
        let mut one_by_one = start.clone();
        let want = [one_by_one.accept(a.0, a.1), one_by_one.accept(b.0, b.1)];
        let got = self.sm.accept_all(&[a, b]);
        if got != want || state_hash(&self.sm) != state_hash(&one_by_one) {
            return fail(
                Property::SameCycle,
                format!(
                    "threads {} and {} in one cycle ({:?}, {:?}) answered {got:?} and left another state \
                     than one after the other ({want:?})",
                    a.0, b.0, a.1, b.1
                ),
            );
        }
        // The same commands once more, one by one through the checked path, from the state
        // before the cycle (they end in the state the cycle left).
        self.sm = start;
        let b0 = self.sm.stats.borrows;
        self.act_one(Action::Cmd(a.0, a.1), cov)?;
        let b1 = self.sm.stats.borrows;
        self.act_one(Action::Cmd(b.0, b.1), cov)?;
        if b1 > b0 && self.sm.stats.borrows > b1 {
            cov.covers.hit(Goal::SameCycleBorrow);
        }
        Ok(true)
    }

    /// Thread `u`'s next micro-op completes and thread `t`'s command is planned in one cycle
    /// ([`StackManager::complete_and_accept`]). The design must answer and leave the state
    /// exactly as completing the micro-op and then planning the command one after the other
    /// does, except that a command of `u` itself is refused (Busy: `ready` is a register, so a
    /// thread is busy for the whole cycle its last micro-op completes in) and changes nothing
    /// ([`Property::SameCycle`]). Every other property is checked on the way, action by action.
    fn uop_with_cmd(&mut self, u: u32, (t, cmd): (u32, Cmd), cov: &mut Coverage) -> Result<bool, Violation> {
        let Some(&uop) = self.sm.pending_uops(u).next() else { return Ok(false) };
        let last = self.sm.pending_uops(u).count() == 1;
        let start = self.sm.clone();
        let mut one_by_one = start.clone();
        one_by_one.complete_next(u);
        let want = if t == u { Err(StackError::Busy { thread: t }) } else { one_by_one.accept(t, cmd) };
        let got = self.sm.complete_and_accept(&[u], &[(t, cmd)]);
        let then = if t == u { "refusing the command" } else { "then planning the command" };
        let cycle = format!("thread {u}'s {uop:?} completing in the cycle of thread {t}'s {cmd:?}");
        if got != [want] {
            return fail(
                Property::SameCycle,
                format!("{cycle} answered {got:?}; completing it and {then}: {want:?}"),
            );
        }
        if state_hash(&self.sm) != state_hash(&one_by_one) {
            return fail(
                Property::SameCycle,
                format!("{cycle} left another state than completing it and {then} (both answered {want:?})"),
            );
        }
        // The same cycle once more through the checked path, from the state before it.
        self.sm = start;
        self.act_one(Action::Uop(u), cov)?;
        if t == u {
            if last {
                cov.covers.hit(Goal::BusyAsLastUopCompletes);
            }
            return Ok(true);
        }
        self.act_one(Action::Cmd(t, cmd), cov)?;
        if let Uop::Release { stack } = uop {
            if self.sm.chain(t).contains(&stack) {
                cov.covers.hit(Goal::ReleaseMeetsBorrow);
            }
        }
        Ok(true)
    }

    /// Overwrites every SH word of the warp that is dead — outside its stack's Bottom..Top and
    /// named by no pending micro-op — with [`POISON`], which no push carries. Stale memory is
    /// then never state (the key hashes every word), and a design that revives a dead word
    /// without storing it shows POISON in the logical stack ([`Property::Conservation`]), what
    /// ever the word held before.
    fn scrub(&mut self) {
        let sm = &self.sm;
        let m = sm.config().sh_entries;
        if m == 0 {
            return;
        }
        let base = self.warp * sm.config().warp_size;
        let mut live = vec![false; (sm.config().warp_size * m) as usize];
        for s in sm.warp_threads(self.warp) {
            let st = sm.stack(s);
            if !st.empty {
                let mut e = st.bottom;
                for _ in 0..st.count(m) {
                    live[((s - base) * m + e) as usize] = true;
                    e = (e + 1) % m;
                }
            }
            for u in sm.pending_uops(s) {
                if let Uop::ShLoad { stack, entry } | Uop::ShStore { stack, entry, .. } = *u {
                    live[((stack - base) * m + entry) as usize] = true;
                }
            }
        }
        for (i, _) in live.iter().enumerate().filter(|x| !x.1) {
            let (s, e) = (base + i as u32 / m, i as u32 % m);
            if self.sm.sh_entry(s, e) != POISON {
                self.sm.load_sh_entry(s, e, POISON);
            }
        }
    }

    fn act_one(&mut self, a: Action, cov: &mut Coverage) -> Result<bool, Violation> {
        let base = self.warp * self.sm.config().warp_size;
        let sm = &mut self.sm;
        let before = sm.stats;
        let ra = sm.config().realloc();
        // The chain before a pop, in ring order with each member's Priority then, for the
        // rotated-release cover.
        let ring_before: Option<Vec<(u32, u32)>> = match a {
            Action::Cmd(t, _) if ra.is_some() => {
                Some(sm.chain(t).into_iter().map(|s| (s, sm.stack(s).priority)).collect())
            }
            _ => None,
        };
        match a {
            Action::Cmd(t, cmd) => {
                let stacks: Vec<_> = sm.warp_threads(self.warp).map(|s| *sm.stack(s)).collect();
                let global = sm.global(t).to_vec();
                let (thread, rb) = (*sm.thread(t), sm.rb(t).clone());
                let got = sm.accept(t, cmd);
                let accepted = got.is_ok();
                self.marked |= self.one_mark && accepted && cmd == Cmd::Push(MARKED);
                self.sb.check(t, cmd, got)?;
                if self.request_sequence {
                    let before = Before { cfg: sm.config(), stacks: &stacks, thread, rb: &rb };
                    check_sequence(&before, base, t, cmd, accepted, sm.pending_uops(t))?;
                }
                if accepted && ra.is_some() {
                    // The checker's counts in place of the design's Flush registers.
                    let counted: Vec<StackRegs> = stacks
                        .iter()
                        .zip(&self.flushes)
                        .map(|(r, &flush)| StackRegs { flush, ..*r })
                        .collect();
                    let before = Before { cfg: sm.config(), stacks: &counted, thread, rb: &rb };
                    if let Some(f) = expected_flush_counts(&before, base, t, cmd) {
                        self.flushes = f;
                    }
                }
                let loads = live_reads(sm, t, &stacks, &global)?;
                self.shadow[t as usize].global_loads = loads;
            }
            Action::Uop(t) => {
                let Some(&u) = sm.pending_uops(t).next() else { return Ok(false) };
                if let Uop::ShLoad { stack, entry } | Uop::ShStore { stack, entry, .. } = u {
                    check_bank_map(sm.config(), stack, entry, sm.sh_read_request(stack, entry).words())?;
                }
                let sh = &mut self.shadow[t as usize];
                match u {
                    Uop::ShLoad { stack, entry } => sh.latch = Some(sm.sh_entry(stack, entry)),
                    Uop::GlobalLoad { .. } => sh.latch = sh.global_loads.pop_front(),
                    Uop::ShStore { src: Src::Latch, .. }
                    | Uop::GlobalStore { src: Src::Latch, .. }
                    | Uop::RbBottom => sh.latch = None,
                    _ => {}
                }
                sm.complete_next(t);
            }
            Action::Both(..) | Action::UopWithCmd(..) => {
                unreachable!(
                    "a cycle of several actions goes through Model::same_cycle or Model::uop_with_cmd"
                )
            }
        }
        let d = sm.stats.since(&before);
        cov.borrows += d.borrows;
        self.borrowed |= d.borrows > 0;
        cov.flushes += d.flushes;
        cov.global_reloads += d.global_loads();
        cov.releases += d.releases;
        if let Action::Cmd(t, _) = a {
            if let (true, Some(ring)) = (d.borrows > 0, &ring_before) {
                for s in sm.chain(t).into_iter().filter(|s| !ring.iter().any(|r| r.0 == *s)) {
                    check_placement(sm, s)?;
                }
            }
            let ring = ring_before.as_deref().filter(|_| matches!(a, Action::Cmd(_, Cmd::Pop)));
            observe_covers(sm, t, &d, ring, &mut cov.covers);
        }
        let quiescent = sm.quiescent();
        check_warp_fields(sm, self.warp, quiescent)?;
        if self.flush_count && ra.is_some() {
            check_flush_counts(sm, self.warp, &self.flushes)?;
        }
        for t in sm.warp_threads(self.warp).filter(|&t| sm.ready(t)) {
            check_thread(sm, t, self.sb.reference(t))?;
        }
        if quiescent && sm.warp_done(self.warp) {
            check_warp_exit(sm, self.warp)?;
            cov.warp_exits += 1;
            if self.borrowed {
                cov.covers.hit(Goal::ExitAfterBorrow);
            }
        }
        Ok(true)
    }

    /// The lowest-numbered thread whose next micro-op is *private* — a global load, a global
    /// store or latch → RB bottom: it reads and writes only that thread's RB, spill region,
    /// sequencer and data latch, which no other thread's action reads or writes — or `None`.
    /// The ample set of the partial-order reduction (module doc).
    pub fn private_uop(&self) -> Option<u32> {
        self.sm.warp_threads(self.warp).find(|&t| {
            matches!(
                self.sm.pending_uops(t).next(),
                Some(Uop::GlobalLoad { .. } | Uop::GlobalStore { .. } | Uop::RbBottom)
            )
        })
    }

    /// Bytes the model occupies: its inline size plus the heap blocks it owns (an estimate from
    /// lengths through the public accessors, each block rounded up to 16 bytes with 16 bytes of
    /// allocator overhead; the stack manager's own vectors are counted from the configuration).
    pub fn bytes(&self) -> usize {
        let block = |n: usize| if n == 0 { 0 } else { n.div_ceil(16) * 16 + 16 };
        let sm = &self.sm;
        let n = sm.config().warp_size as usize;
        let m = sm.config().sh_entries as usize;
        let mut b = std::mem::size_of::<Model>();
        // threads, stacks, rb, seq, queued, sh_data, global: one block each.
        b += block(n * std::mem::size_of::<rtl::stack_manager::ThreadRegs>());
        b += block(n * std::mem::size_of::<StackRegs>());
        b += block(n * std::mem::size_of::<std::collections::VecDeque<u64>>());
        b += block(n * (std::mem::size_of::<std::collections::VecDeque<Uop>>() + 48));
        b += block(8) + block(n * m * 8);
        b += block(n * std::mem::size_of::<Vec<u64>>());
        for t in sm.warp_threads(self.warp) {
            b += block(sm.rb(t).len() * 8);
            b += block(sm.pending_uops(t).count() * std::mem::size_of::<Uop>());
            b += block(sm.global(t).len() * 8);
            b += block(self.sb.reference(t).len() * 8);
        }
        b += block(n * std::mem::size_of::<super::reference::RefStack>()) + block(n);
        b += block(n * std::mem::size_of::<Shadow>()) + block(n * 4);
        b += self.shadow.iter().map(|s| block(s.global_loads.len() * 8)).sum::<usize>();
        b
    }

    /// Entries the warp holds (the reference's view).
    pub fn held(&self) -> u32 {
        self.sm.warp_threads(self.warp).map(|t| self.sb.reference(t).len() as u32).sum()
    }

    /// Every action possible now: commands (valid or not) of ready unfinished threads with push
    /// values 1..=values, and the next micro-op of each busy thread.
    pub fn actions(&self, values: u32) -> Vec<Action> {
        self.actions_capped(values, None)
    }

    /// [`Model::actions`], with pushes offered only while the warp holds fewer than `cap`
    /// entries.
    pub fn actions_capped(&self, values: u32, cap: Option<u32>) -> Vec<Action> {
        let sm = &self.sm;
        let push = cap.is_none_or(|c| self.held() < c);
        let mut out = Vec::new();
        for t in sm.warp_threads(self.warp) {
            if !sm.ready(t) {
                out.push(Action::Uop(t));
                if self.busy_cmds && !sm.thread(t).done {
                    out.extend([Cmd::Push(UNMARKED), Cmd::Pop, Cmd::Finish].map(|c| Action::Cmd(t, c)));
                }
                if self.uop_cmds {
                    self.uop_cmd_actions(t, push, &mut out);
                }
                continue;
            }
            if sm.thread(t).done || self.is_silent(t) {
                continue;
            }
            if push && self.one_mark {
                out.push(Action::Cmd(t, Cmd::Push(UNMARKED)));
                if !self.marked {
                    out.push(Action::Cmd(t, Cmd::Push(MARKED)));
                }
            } else if push {
                out.extend((1..=values as u64).map(|v| Action::Cmd(t, Cmd::Push(v))));
            }
            out.push(Action::Cmd(t, Cmd::Pop));
            out.push(Action::Cmd(t, Cmd::Finish));
        }
        if self.pairs {
            self.pair_actions(cap, &mut out);
        }
        out
    }

    /// Busy thread `u`'s next micro-op completing in the cycle of a command of `u` itself or of
    /// any ready, unfinished thread: every kind, pushes carrying [`UNMARKED`] while `push` (the
    /// cap leaves room).
    fn uop_cmd_actions(&self, u: u32, push: bool, out: &mut Vec<Action>) {
        let sm = &self.sm;
        let kinds: &[Cmd] =
            if push { &[Cmd::Push(UNMARKED), Cmd::Pop, Cmd::Finish] } else { &[Cmd::Pop, Cmd::Finish] };
        let open = |t: u32| t == u || (sm.ready(t) && !sm.thread(t).done && !self.is_silent(t));
        for t in sm.warp_threads(self.warp).filter(|&t| open(t)) {
            out.extend(kinds.iter().map(|&c| Action::UopWithCmd(u, t, c)));
        }
    }

    /// Two ready, unfinished threads' commands in one cycle, in lane order: every pair of
    /// kinds, pushes carrying [`UNMARKED`] (or value 2) while the cap leaves room for them.
    fn pair_actions(&self, cap: Option<u32>, out: &mut Vec<Action>) {
        let sm = &self.sm;
        let room = cap.map_or(u32::MAX, |c| c.saturating_sub(self.held()));
        let open: Vec<u32> = sm
            .warp_threads(self.warp)
            .filter(|&t| sm.ready(t) && !sm.thread(t).done && !self.is_silent(t))
            .collect();
        let kinds = [Cmd::Push(UNMARKED), Cmd::Pop, Cmd::Finish];
        for (i, &t) in open.iter().enumerate() {
            for &u in &open[i + 1..] {
                for a in kinds {
                    for b in kinds {
                        let pushes =
                            u32::from(matches!(a, Cmd::Push(_))) + u32::from(matches!(b, Cmd::Push(_)));
                        if pushes <= room {
                            out.push(Action::Both(t, a, u, b));
                        }
                    }
                }
            }
        }
    }

    /// Decodes one input byte pair into an action for the current state: the first byte picks
    /// the thread (a busy thread completes a micro-op), the second the command, biased to
    /// pushes so stacks get deep. `value` is the push value to use.
    pub fn decode(&self, (a, b): (u8, u8), value: u64) -> Action {
        let ws = self.sm.config().warp_size;
        let t = self.warp * ws + a as u32 % ws;
        if !self.sm.ready(t) {
            return Action::Uop(t);
        }
        match b {
            0..=139 => Action::Cmd(t, Cmd::Push(value)),
            140..=249 => Action::Cmd(t, Cmd::Pop),
            _ => Action::Cmd(t, Cmd::Finish),
        }
    }
}

/// [`Property::LiveReads`] for the program thread `t`'s command just queued; `stacks` are the
/// warp's stack registers and `global` the thread's live global slots before the command.
/// Returns the values its global loads will read, in order.
fn live_reads(
    sm: &StackManager,
    t: u32,
    stacks: &[StackRegs],
    global: &[u64],
) -> Result<std::collections::VecDeque<u64>, Violation> {
    let m = sm.config().sh_entries;
    let base = t - t % sm.config().warp_size;
    let live = |s: u32, e: u32| {
        let st = &stacks[(s - base) as usize];
        !st.empty && (e + m - st.bottom) % m < st.count(m)
    };
    let mut stored: Vec<(u32, u32)> = Vec::new();
    let mut loads = std::collections::VecDeque::new();
    for (i, u) in sm.pending_uops(t).enumerate() {
        match *u {
            Uop::ShStore { stack, entry, .. } => stored.push((stack, entry)),
            Uop::ShLoad { stack, entry } if !live(stack, entry) && !stored.contains(&(stack, entry)) => {
                return fail(
                    Property::LiveReads,
                    format!("thread {t}: micro-op {i} loads SH entry {entry} of stack {stack}, not live"),
                );
            }
            Uop::GlobalLoad { slot } => match global.get(slot as usize) {
                Some(&v) => loads.push_back(v),
                None => {
                    return fail(
                        Property::LiveReads,
                        format!(
                            "thread {t}: micro-op {i} loads global slot {slot} with {} live",
                            global.len()
                        ),
                    )
                }
            },
            _ => {}
        }
    }
    Ok(loads)
}

/// [`Property::FlushCount`]: every stack's Flush register of warp `w` equals `counted`, the
/// consecutive flushes the checker counted for it (lane order).
fn check_flush_counts(sm: &StackManager, w: u32, counted: &[u32]) -> Result<(), Violation> {
    for (s, &want) in sm.warp_threads(w).zip(counted) {
        let got = sm.stack(s).flush;
        if got != want {
            return fail(
                Property::FlushCount,
                format!("stack {s}: Flush {got}, SPEC section 5 counts {want} consecutive flushes"),
            );
        }
    }
    Ok(())
}

/// Records the cover goals a command of thread `t` reached; `d` is what it counted, `ring` its
/// chain before a pop (ring order from its dedicated stack, each member's Priority then).
fn observe_covers(sm: &StackManager, t: u32, d: &StackStats, ring: Option<&[(u32, u32)]>, c: &mut Covers) {
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

/// Runs byte-encoded actions (see [`Model::decode`]) on one warp of `cfg`, checking every
/// property after each; pushes take unique values. The random and Kani harnesses call this.
pub fn run_bytes(cfg: Config, input: &[(u8, u8)]) -> Result<Coverage, Box<Counterexample>> {
    run_bytes_on(Model::new(cfg).expect("harness configurations are valid"), input)
}

/// [`run_bytes`] on a given model (e.g. one whose stack manager is a mutant).
pub fn run_bytes_on(m: Model, input: &[(u8, u8)]) -> Result<Coverage, Box<Counterexample>> {
    run_decoded(m, input.iter().enumerate().map(|(i, &pair)| (pair, i as u64 + 1)))
}

/// [`run_bytes`] with the push values given too: `(thread byte, command byte, value)` per
/// action. The Kani harnesses use it so push values are symbolic (any value, equal ones
/// included), not fixed by position.
pub fn run_valued(cfg: Config, input: &[(u8, u8, u64)]) -> Result<Coverage, Box<Counterexample>> {
    let m = Model::new(cfg).expect("harness configurations are valid");
    run_decoded(m, input.iter().map(|&(a, b, v)| ((a, b), v)))
}

fn run_decoded(
    mut m: Model,
    input: impl Iterator<Item = ((u8, u8), u64)>,
) -> Result<Coverage, Box<Counterexample>> {
    let mut cov = Coverage::default();
    let mut trace = Vec::new();
    if let Err(violation) = check_no_overlap(&m.sm) {
        return Err(Box::new(Counterexample { violation, trace }));
    }
    for (pair, value) in input {
        let a = m.decode(pair, value);
        trace.push(a);
        if let Err(violation) = m.act(a, &mut cov) {
            return Err(Box::new(Counterexample { violation, trace }));
        }
    }
    cov.complete = true;
    Ok(cov)
}

struct Node {
    model: Model,
    id: u32,
    paths: u128,
}

/// The action sequence that first reached state `id`, from the predecessor table.
fn trace_of(parents: &[(u32, Option<Action>)], mut id: u32) -> Vec<Action> {
    let mut out = Vec::new();
    while let (p, Some(a)) = parents[id as usize] {
        out.push(a);
        id = p;
    }
    out.reverse();
    out
}

/// Explores every action sequence up to `bounds.depth` on one warp of `cfg` (breadth first, so
/// counterexamples are shortest), or to the fixpoint: until no new state appears. `design` may
/// replace the stack manager (a mutant). Returns what was covered, or the first violation with
/// its shortest trace (shortest in the reduced graph with [`Bounds::por`]; with [`Bounds::dfs`]
/// the search is depth first and the trace is the path that reached it).
///
/// States are stored as 128-bit hashes of everything that decides future behaviour — the
/// design's registers, queues, sequencers and memory words ([`StackManager::hash_state`]) and the
/// reference stacks — but no event counter (hash compaction: two distinct states collide with
/// probability about n² / 2¹²⁹ for n states, below 10⁻²⁴ for 10⁸ states).
pub fn check(
    cfg: Config,
    bounds: Bounds,
    design: impl Fn(StackManager) -> StackManager,
) -> Result<Coverage, Box<Counterexample>> {
    let start = Instant::now();
    let mut model =
        Model::on_warp(cfg, bounds.warp).expect("exhaustive configurations are validated by the caller");
    model.sm = design(model.sm);
    // Load the warp again with the design under check, so its placement is the one checked.
    let active = bounds.active.unwrap_or(u32::MAX) & u32::MAX >> (32 - cfg.warp_size);
    model.sm.load_warp(bounds.warp, active);
    model.sb.load_warp(model.sm.warp_threads(bounds.warp), active);
    model.request_sequence = bounds.request_sequence;
    model.one_mark = bounds.one_mark;
    model.busy_cmds = bounds.busy_cmds;
    model.pairs = bounds.pairs;
    model.scrub_dead = bounds.scrub;
    model.silent = bounds.silent;
    model.uop_cmds = bounds.uop_cmds;
    model.flush_count = bounds.flush_count;
    if bounds.scrub {
        model.scrub();
    }
    let mut cov = Coverage { complete: true, ..Default::default() };
    let placed = model.threads().try_for_each(|s| check_placement(&model.sm, s));
    if let Err(violation) = placed.and_then(|_| check_no_overlap(&model.sm)) {
        return Err(Box::new(Counterexample { violation, trace: vec![] }));
    }
    if bounds.dfs {
        return check_dfs(model, bounds, cov, start);
    }
    let mut seen: HashSet<u128> = HashSet::new();
    seen.insert(model.key());
    let mut parents: Vec<(u32, Option<Action>)> = vec![(0, None)];
    // Each transition is tried on `scratch`, overwritten in place (`clone_from` keeps its
    // allocations); a new state takes it into the next level and a spare (a model of an
    // earlier level, any content) takes its place.
    let mut scratch = model.clone();
    let mut spare: Vec<Model> = Vec::new();
    let mut frontier = vec![Node { model, id: 0, paths: 1 }];
    let mut depth = 0;
    while depth < bounds.depth {
        depth += 1;
        let mut next: Vec<Node> = Vec::new();
        let mut index: HashMap<u128, usize> = HashMap::new();
        for node in &frontier {
            for a in expand(&node.model, &bounds, &mut cov) {
                cov.transitions += 1;
                scratch.clone_from(&node.model);
                match scratch.act(a, &mut cov) {
                    Ok(true) => {}
                    Ok(false) => continue,
                    Err(violation) => {
                        let mut trace = trace_of(&parents, node.id);
                        trace.push(a);
                        return Err(Box::new(Counterexample { violation, trace }));
                    }
                }
                cov.sequences = cov.sequences.saturating_add(node.paths);
                let k = scratch.key();
                if let Some(&i) = index.get(&k) {
                    next[i].paths = next[i].paths.saturating_add(node.paths);
                    continue;
                }
                if !seen.insert(k) {
                    continue;
                }
                let id = parents.len() as u32;
                parents.push((node.id, Some(a)));
                index.insert(k, next.len());
                let model =
                    std::mem::replace(&mut scratch, spare.pop().unwrap_or_else(|| node.model.clone()));
                next.push(Node { model, id, paths: node.paths });
            }
        }
        cov.states = seen.len();
        if next.len() > cov.peak_frontier {
            cov.peak_frontier = next.len();
            cov.peak_frontier_bytes = next.iter().map(|n| n.model.bytes()).sum();
        }
        if next.is_empty() {
            // Nothing new at this level: the previous one was the last.
            depth -= 1;
            cov.fixpoint = true;
            break;
        }
        cov.depth_reached = depth;
        if seen.len() >= bounds.max_states {
            cov.complete = false;
            break;
        }
        spare.extend(std::mem::replace(&mut frontier, next).into_iter().map(|n| n.model));
    }
    cov.depth_reached = depth;
    cov.states = seen.len();
    cov.visited_bytes = seen.capacity() * (std::mem::size_of::<u128>() + 1)
        + parents.capacity() * std::mem::size_of::<(u32, Option<Action>)>();
    cov.elapsed = start.elapsed();
    Ok(cov)
}

/// [`check`] depth first (`bounds.dfs`), to the fixpoint: every state reachable from `model`
/// (under the cap, with the reduction if `bounds.por`) is visited once and every property
/// checked on every transition out of it. The search holds the visited set (128-bit keys) and
/// the current path: per step the action that led there and the actions still to try, and the
/// model itself only at every [`CHECKPOINT`]-th step and in the last [`CHECKPOINT`] steps —
/// backtracking below that window rebuilds a step's model by replaying the path's actions from
/// the checkpoint under it (the actions are deterministic, so it is the same model).
fn check_dfs(
    model: Model,
    bounds: Bounds,
    mut cov: Coverage,
    start: Instant,
) -> Result<Coverage, Box<Counterexample>> {
    struct Frame {
        /// Held at checkpoints and in the window of the last steps (see above).
        model: Option<Box<Model>>,
        actions: Vec<Action>,
        next: usize,
        /// The action that led here (none at the root).
        via: Option<Action>,
    }
    let mut seen: HashSet<u128> = HashSet::new();
    seen.insert(model.key());
    let actions = expand(&model, &bounds, &mut cov);
    let mut path_bytes = model.bytes();
    // Transitions are tried on `scratch`, overwritten in place (`clone_from` keeps its
    // allocations); a new state moves it onto the path, and models leaving the path are kept
    // as spares for that (never more than the path held at its peak, so at most doubling the
    // frontier's memory).
    let mut scratch = Box::new(model.clone());
    let mut spare: Vec<Box<Model>> = Vec::new();
    let copy = |spare: &mut Vec<Box<Model>>, m: &Model| match spare.pop() {
        Some(mut b) => {
            Model::clone_from(&mut b, m);
            b
        }
        None => Box::new(m.clone()),
    };
    let mut path = vec![Frame { model: Some(Box::new(model)), actions, next: 0, via: None }];
    let mut held = 1;
    cov.fixpoint = true;
    while let Some(i) = path.len().checked_sub(1) {
        if path[i].next >= path[i].actions.len() {
            if let Some(m) = path.pop().and_then(|f| f.model) {
                path_bytes -= m.bytes();
                held -= 1;
                spare.push(m);
            }
            continue;
        }
        if path[i].model.is_none() {
            // Rebuild from the checkpoint below (which holds its model).
            let mut replayed = Coverage::default();
            for j in i - i % CHECKPOINT + 1..=i {
                if path[j].model.is_some() {
                    continue;
                }
                let mut m =
                    copy(&mut spare, path[j - 1].model.as_ref().expect("the step below holds its model"));
                let via = path[j].via.expect("a step above the root");
                assert!(matches!(m.act(via, &mut replayed), Ok(true)), "replaying a checked action");
                path_bytes += m.bytes();
                held += 1;
                path[j].model = Some(m);
            }
        }
        let a = path[i].actions[path[i].next];
        path[i].next += 1;
        cov.transitions += 1;
        scratch.clone_from(path[i].model.as_ref().expect("the top step holds its model"));
        match scratch.act(a, &mut cov) {
            Ok(true) => {}
            Ok(false) => continue,
            Err(violation) => {
                let mut trace: Vec<Action> = path.iter().filter_map(|f| f.via).collect();
                trace.push(a);
                return Err(Box::new(Counterexample { violation, trace }));
            }
        }
        if !seen.insert(scratch.key()) {
            continue;
        }
        if seen.len() >= bounds.max_states {
            cov.complete = false;
            cov.fixpoint = false;
            break;
        }
        // The new state keeps the scratch model; a spare (any content) becomes the scratch.
        let fresh = spare.pop().unwrap_or_else(|| scratch.clone());
        let model = std::mem::replace(&mut scratch, fresh);
        if bounds.progress && seen.len().is_multiple_of(1 << 22) {
            eprintln!(
                "  ... {} states, path {}, {held} models held, {:.0} s",
                seen.len(),
                path.len(),
                start.elapsed().as_secs_f64()
            );
        }
        let actions = expand(&model, &bounds, &mut cov);
        path_bytes += model.bytes();
        held += 1;
        path.push(Frame { model: Some(model), actions, next: 0, via: Some(a) });
        // The step leaving the window drops its model unless it is a checkpoint.
        let d = path.len() - 1;
        if let Some(old) = d.checked_sub(CHECKPOINT).filter(|&j| j % CHECKPOINT != 0) {
            if let Some(m) = path[old].model.take() {
                path_bytes -= m.bytes();
                held -= 1;
                spare.push(m);
            }
        }
        if path_bytes > cov.peak_frontier_bytes {
            cov.peak_frontier = held;
            cov.peak_frontier_bytes = path_bytes;
        }
        cov.depth_reached = cov.depth_reached.max(d as u32);
    }
    cov.states = seen.len();
    cov.visited_bytes =
        seen.capacity() * (std::mem::size_of::<u128>() + 1) + path.capacity() * std::mem::size_of::<Frame>();
    cov.elapsed = start.elapsed();
    Ok(cov)
}

/// The actions explored out of `m`: with the reduction (`bounds.por`) a private micro-op alone,
/// when `m` has one (counted in `cov.reduced`); else every action under the cap.
fn expand(m: &Model, bounds: &Bounds, cov: &mut Coverage) -> Vec<Action> {
    match bounds.por.then(|| m.private_uop()).flatten() {
        Some(t) => {
            cov.reduced += 1;
            vec![Action::Uop(t)]
        }
        None => m.actions_capped(bounds.values, bounds.cap),
    }
}

/// Every how many steps of its path the depth-first search ([`Bounds::dfs`]) keeps a model.
pub const CHECKPOINT: usize = 32;

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
