//! The searches: breadth first with a predecessor table (shortest counterexamples), depth first
//! with checkpoints (the largest cases), and the replay of byte-encoded action sequences that the
//! random and Kani harnesses run. A violation comes back as a [`Counterexample`].

use std::collections::{HashMap, HashSet};
use std::time::Instant;

use rtl::config::Config;
use rtl::stack_manager::StackManager;

use crate::run::verify::invariants::{check_no_overlap, check_placement, Violation};

use super::bounds::Bounds;
use super::coverage::Coverage;
use super::model::{Action, Model};

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
