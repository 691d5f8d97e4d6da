//! The bounds of one exhaustive run (depth, values, state and depth caps, which actions are
//! offered, the reduction and search order) and the depth caps chosen per configuration.

use rtl::config::{Config, Overflow};

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
