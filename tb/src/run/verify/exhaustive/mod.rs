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

mod actions;
mod bounds;
mod cases;
mod checks;
mod coverage;
mod key;
mod model;
mod search;

pub use bounds::{default_cap, is_large, large_cap, Bounds};
pub use cases::{
    corner_cases, describe, full_cases, full_configs, group_configs, restart_configs, skew_configs,
    small_configs, Case,
};
pub use coverage::{Coverage, Covers, Goal};
pub use model::{Action, Model, MARKED, UNMARKED};
pub use search::{check, run_bytes, run_bytes_on, run_valued, Counterexample, CHECKPOINT};
