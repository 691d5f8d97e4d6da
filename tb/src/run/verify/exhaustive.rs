//! Exhaustive bounded model checking on stable Rust.
//!
//! Breadth-first over every sequence of actions up to a bound, for one warp of a small
//! configuration. An action is either a command from a ready thread (push of one of a few values,
//! pop, finish — invalid ones included: the design must refuse them) or the completion of one
//! pending micro-op of a busy thread. So every interleaving of commands *and* of micro-ops across
//! threads is covered, including a release racing a borrow. Equal states (design + reference) are
//! explored once (state hashing). After every action the properties of [`super::invariants`] are
//! checked; the first violation comes back with the shortest action sequence that reaches it.
//!
//! Push values come from a small alphabet: the stack manager never branches on an entry's value
//! (data independence), so two distinct values suffice to expose a lost, duplicated or reordered
//! entry, while keeping equal states equal.

use std::collections::{HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::time::{Duration, Instant};

use rtl::config::Config;
use rtl::stack_manager::{Cmd, StackManager};

use super::harness::Scoreboard;
use super::invariants::{check_thread, check_warp_exit, check_warp_fields, Violation};

/// One step of an explored sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    Cmd(u32, Cmd),
    /// Thread's next micro-op completes.
    Uop(u32),
}

/// Bounds of one exhaustive run.
#[derive(Clone, Copy, Debug)]
pub struct Bounds {
    /// Longest action sequence.
    pub depth: u32,
    /// Distinct push values (≥ 2 to see reordering).
    pub values: u32,
    /// Stop early when this many distinct states have been seen.
    pub max_states: usize,
}

/// What an exhaustive run covered.
#[derive(Clone, Debug, Default)]
pub struct Coverage {
    pub states: usize,
    pub transitions: u64,
    /// Action sequences of every length up to the bound (counted through merged states).
    pub sequences: u128,
    pub depth_reached: u32,
    pub complete: bool,
    pub elapsed: Duration,
    /// How often the interesting paths were reached (none may be zero for a non-vacuous run
    /// when the configuration has the feature).
    pub borrows: u64,
    pub flushes: u64,
    pub global_reloads: u64,
    pub releases: u64,
    pub warp_exits: u64,
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
#[derive(Clone, Debug)]
pub struct Model {
    pub sm: StackManager,
    pub sb: Scoreboard,
}

impl Model {
    /// One warp of `cfg` (its `warps` is forced to 1).
    pub fn new(cfg: Config) -> Result<Model, rtl::config::ConfigError> {
        let cfg = Config { warps: 1, ..cfg };
        Ok(Model { sm: StackManager::new(cfg, 0)?, sb: Scoreboard::new(cfg.threads()) })
    }

    fn key(&self) -> u128 {
        let mut h1 = std::collections::hash_map::DefaultHasher::new();
        let mut h2 = std::collections::hash_map::DefaultHasher::new();
        0xA5u8.hash(&mut h2);
        for h in [&mut h1, &mut h2] {
            self.sm.hash_state(h);
            self.sb.hash(h);
        }
        (h1.finish() as u128) << 64 | h2.finish() as u128
    }

    /// Applies `a` and checks every property. Returns false if `a` does not apply (a micro-op of
    /// a thread with none pending).
    pub fn act(&mut self, a: Action, cov: &mut Coverage) -> Result<bool, Violation> {
        let sm = &mut self.sm;
        let before = sm.stats;
        match a {
            Action::Cmd(t, cmd) => {
                let got = sm.accept(t, cmd);
                self.sb.check(t, cmd, got)?;
            }
            Action::Uop(t) => {
                if !sm.complete_next(t) {
                    return Ok(false);
                }
            }
        }
        cov.borrows += sm.stats.borrows - before.borrows;
        cov.flushes += sm.stats.flushes - before.flushes;
        cov.global_reloads += sm.stats.global_loads() - before.global_loads();
        cov.releases += sm.stats.releases - before.releases;
        let quiescent = sm.quiescent();
        check_warp_fields(sm, 0, quiescent)?;
        for t in sm.warp_threads(0).filter(|&t| sm.ready(t)) {
            check_thread(sm, t, self.sb.reference(t))?;
        }
        if quiescent && sm.warp_done(0) {
            check_warp_exit(sm, 0)?;
            cov.warp_exits += 1;
        }
        Ok(true)
    }

    /// Every action possible now: commands (valid or not) of ready unfinished threads with push
    /// values 1..=values, and the next micro-op of each busy thread.
    pub fn actions(&self, values: u32) -> Vec<Action> {
        let sm = &self.sm;
        let mut out = Vec::new();
        for t in sm.warp_threads(0) {
            if !sm.ready(t) {
                out.push(Action::Uop(t));
                continue;
            }
            if sm.thread(t).done {
                continue;
            }
            out.extend((1..=values as u64).map(|v| Action::Cmd(t, Cmd::Push(v))));
            out.push(Action::Cmd(t, Cmd::Pop));
            out.push(Action::Cmd(t, Cmd::Finish));
        }
        out
    }

    /// Decodes one input byte pair into an action for the current state: the first byte picks
    /// the thread (a busy thread completes a micro-op), the second the command, biased to
    /// pushes so stacks get deep. `value` is the push value to use.
    pub fn decode(&self, (a, b): (u8, u8), value: u64) -> Action {
        let t = a as u32 % self.sm.config().warp_size;
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

/// Runs byte-encoded actions (see [`Model::decode`]) on one warp of `cfg`, checking every
/// property after each; pushes take unique values. The random and Kani harnesses call this.
pub fn run_bytes(cfg: Config, input: &[(u8, u8)]) -> Result<Coverage, Box<Counterexample>> {
    run_bytes_on(Model::new(cfg).expect("harness configurations are valid"), input)
}

/// [`run_bytes`] on a given model (e.g. one whose stack manager is a mutant).
pub fn run_bytes_on(mut m: Model, input: &[(u8, u8)]) -> Result<Coverage, Box<Counterexample>> {
    let mut cov = Coverage::default();
    let mut trace = Vec::new();
    for (i, &pair) in input.iter().enumerate() {
        let a = m.decode(pair, i as u64 + 1);
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
    trace: Vec<Action>,
    paths: u128,
}

/// Explores every action sequence up to `bounds.depth` on one warp of `cfg`. `design` may
/// replace the stack manager (a mutant). Returns what was covered, or the first violation with
/// its shortest trace.
pub fn check(
    cfg: Config,
    bounds: Bounds,
    design: impl Fn(StackManager) -> StackManager,
) -> Result<Coverage, Box<Counterexample>> {
    let start = Instant::now();
    let mut model = Model::new(cfg).expect("exhaustive configurations are validated by the caller");
    model.sm = design(model.sm);
    let mut cov = Coverage { complete: true, ..Default::default() };
    let mut seen: HashSet<u128> = HashSet::new();
    seen.insert(model.key());
    let mut frontier = vec![Node { model, trace: vec![], paths: 1 }];
    for depth in 1..=bounds.depth {
        let mut next: Vec<Node> = Vec::new();
        let mut index: HashMap<u128, usize> = HashMap::new();
        for node in &frontier {
            for a in node.model.actions(bounds.values) {
                cov.transitions += 1;
                let mut model = node.model.clone();
                match model.act(a, &mut cov) {
                    Ok(true) => {}
                    Ok(false) => continue,
                    Err(violation) => {
                        let mut trace = node.trace.clone();
                        trace.push(a);
                        return Err(Box::new(Counterexample { violation, trace }));
                    }
                }
                cov.sequences += node.paths;
                let k = model.key();
                if let Some(&i) = index.get(&k) {
                    next[i].paths = next[i].paths.saturating_add(node.paths);
                    continue;
                }
                if !seen.insert(k) {
                    continue;
                }
                let mut trace = node.trace.clone();
                trace.push(a);
                index.insert(k, next.len());
                next.push(Node { model, trace, paths: node.paths });
            }
        }
        cov.depth_reached = depth;
        cov.states = seen.len();
        if next.is_empty() {
            break;
        }
        if seen.len() >= bounds.max_states {
            cov.complete = false;
            break;
        }
        frontier = next;
    }
    cov.elapsed = start.elapsed();
    Ok(cov)
}

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
                    realloc,
                    warp_size: ws,
                    warps: 1,
                    ..Config::default()
                });
            }
        }
    }
    out
}

/// A configuration's short description for reports.
pub fn describe(c: &Config) -> String {
    let ra =
        c.realloc.map_or(String::new(), |r| format!(" borrow {} flush {}", r.borrow_limit, r.flush_limit));
    format!("{} warp {}{}", c.name(), c.warp_size, ra)
}
