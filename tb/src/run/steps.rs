//! Traversal steps of the restart-trail walk ([`crate::workload::restart`]) with a short stack
//! of N entries, against the full-stack walk, at the functional level: the engine behind
//! `sms steps`.
//!
//! ```text
//!   every ray of the workload ──► traverse::trace (full stack): hit, counts
//!          │
//!          └─► for each N: RestartWalk ◄──segments / answers──► DropOldest(N): hit, counts
//!                          the hits must be equal, every pop checked, every restart after a drop
//! ```
//!
//! The short stack ([`DropOldest`]) holds N entries; a push onto a full stack drops the oldest.
//! A pop of an empty stack that dropped entries since the walk last restarted answers
//! [`Popped::Restart`]; a pop of an empty stack that dropped nothing is an error (the walk
//! popped what it never pushed). The stack is a [`ShortStack`] so that a test can swap in a
//! faulty one.
//!
//! Every ray is checked, none sampled: the walk's closest hit (primitive and distance) equals the
//! full-stack walk's, every popped entry is the one an unbounded stack would return, no visit
//! enters a finished subtree, and a restart happens only after a drop.

use std::collections::VecDeque;

use rtl::ray_op::{NodeKind, Popped, RayOp, Walk};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::workload::bvh::BvhKind;
use crate::workload::geometry::{Primitives, Ray};
use crate::workload::restart::{RankedTrail, RestartTree, RestartWalk, TrailRules};
use crate::workload::trace::FetchKind;
use crate::workload::traverse::{trace, ChildOrder, Hit, Recorder};

/// A per-ray stack of bounded size.
pub trait ShortStack {
    /// Pushes `entry`; returns the entry dropped to make room, if any.
    fn push(&mut self, entry: u64) -> Option<u64>;
    /// The newest entry, removed; `None` when empty.
    fn pop(&mut self) -> Option<u64>;
}

/// N entries; a push onto a full stack drops the oldest.
#[derive(Clone, Debug)]
pub struct DropOldest {
    entries: VecDeque<u64>,
    capacity: usize,
}

impl DropOldest {
    /// A stack of `capacity` entries (at least 1).
    pub fn new(capacity: usize) -> Result<Self> {
        if capacity == 0 {
            return Err(Error::Invalid("a short stack of 0 entries holds nothing; give 1 or more".into()));
        }
        Ok(DropOldest { entries: VecDeque::with_capacity(capacity), capacity })
    }
}

impl ShortStack for DropOldest {
    fn push(&mut self, entry: u64) -> Option<u64> {
        let dropped = (self.entries.len() == self.capacity).then(|| self.entries.pop_front()).flatten();
        self.entries.push_back(entry);
        dropped
    }

    fn pop(&mut self) -> Option<u64> {
        self.entries.pop_back()
    }
}

/// What a set of rays did. Traversal steps are internal-node plus leaf visits; `visits` counts
/// every node fetch, primitives included.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    pub rays: u64,
    pub internal: u64,
    pub leaves: u64,
    pub visits: u64,
    pub pushes: u64,
    pub pops: u64,
    pub drops: u64,
    pub restarts: u64,
    /// Node visits made while descending the trail after a restart (in `internal` too).
    pub refetched: u64,
}

impl Counts {
    pub fn steps(&self) -> u64 {
        self.internal + self.leaves
    }

    pub fn add(&mut self, o: &Counts) {
        self.rays += o.rays;
        self.internal += o.internal;
        self.leaves += o.leaves;
        self.visits += o.visits;
        self.pushes += o.pushes;
        self.pops += o.pops;
        self.drops += o.drops;
        self.restarts += o.restarts;
        self.refetched += o.refetched;
    }

    /// `value` per ray.
    pub fn per_ray(&self, value: u64) -> f64 {
        if self.rays == 0 {
            0.0
        } else {
            value as f64 / self.rays as f64
        }
    }
}

impl Recorder for Counts {
    fn visit(&mut self, _: u64, kind: FetchKind) {
        self.visits += 1;
        match kind {
            FetchKind::Internal => self.internal += 1,
            FetchKind::Leaf => self.leaves += 1,
            _ => {}
        }
    }
    fn push(&mut self, _: u64) {
        self.pushes += 1;
    }
    fn pop(&mut self, _: u64) {
        self.pops += 1;
    }
}

/// The full-stack walk of `ray` (nearest order): its closest hit, its counts added to `counts`.
pub fn full_walk(tree: &RestartTree, prims: &Primitives, ray: &Ray, counts: &mut Counts) -> Option<Hit> {
    counts.rays += 1;
    trace(tree.bvh(), prims, ray, f32::INFINITY, ChildOrder::Nearest, counts)
}

/// Runs `walk` to its end against `stack`, one segment at a time, adding what it did to
/// `counts`. An error is a check that failed (the walk's, or a restart without a drop).
pub fn drive<W: Walk>(walk: &mut W, stack: &mut impl ShortStack, counts: &mut Counts) -> Result<(), String> {
    let mut ops = Vec::new();
    let mut answer = None;
    // Entries dropped since the walk last restarted.
    let mut dropped = 0u64;
    counts.rays += 1;
    loop {
        ops.clear();
        walk.resume(answer.take(), &mut ops)?;
        for (i, op) in ops.iter().enumerate() {
            match *op {
                RayOp::Visit { kind, .. } => {
                    counts.visits += 1;
                    match kind {
                        NodeKind::Internal => counts.internal += 1,
                        NodeKind::LeafDescriptor => counts.leaves += 1,
                        _ => {}
                    }
                }
                RayOp::Push(entry) => {
                    counts.pushes += 1;
                    if stack.push(entry).is_some() {
                        counts.drops += 1;
                        dropped += 1;
                    }
                }
                RayOp::Pop(_) if i + 1 != ops.len() => {
                    return Err(format!("a pop is operation {i} of a segment of {}, not its last", ops.len()))
                }
                RayOp::Pop(_) => {
                    counts.pops += 1;
                    answer = Some(match stack.pop() {
                        Some(entry) => Popped::Entry(entry),
                        None if dropped > 0 => {
                            dropped = 0;
                            counts.restarts += 1;
                            Popped::Restart
                        }
                        None => {
                            return Err(
                                "pop of an empty stack that dropped nothing: a restart without a drop".into(),
                            )
                        }
                    });
                }
            }
        }
        if answer.is_none() {
            return Ok(());
        }
    }
}

/// One ray's restart walk with trail rules `rules` and stack `stack`, checked against the
/// full-stack walk's hit `want`; its counts added to `counts`.
pub fn check_ray<R: TrailRules>(
    tree: &RestartTree,
    ray: &Ray,
    rules: R,
    stack: &mut impl ShortStack,
    want: Option<Hit>,
    counts: &mut Counts,
) -> Result<(), String> {
    let mut walk = RestartWalk::with_rules(tree, *ray, rules);
    drive(&mut walk, stack, counts)?;
    counts.refetched += walk.refetched();
    if walk.hit() != want {
        return Err(format!("closest hit {:?}, the full-stack walk's {want:?}", walk.hit()));
    }
    Ok(())
}

/// The restart walk's counts at one stack size.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SizeCounts {
    pub entries: usize,
    pub counts: Counts,
}

/// Every ray of one workload under each stack size, and the full-stack walk.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Steps {
    pub bvh: BvhKind,
    /// Trail levels the BVH needs (its depth) and has.
    pub depth: usize,
    pub levels: usize,
    pub full: Counts,
    pub sizes: Vec<SizeCounts>,
}

/// Runs `rays` over `tree` with a short stack of each of `entries`, every ray checked (module
/// docs); `progress(done, total)` after each ray.
pub fn measure(
    tree: &RestartTree,
    prims: &Primitives,
    rays: &[Ray],
    entries: &[usize],
    mut progress: impl FnMut(usize, usize),
) -> Result<Steps> {
    for &n in entries {
        DropOldest::new(n)?;
    }
    let mut full = Counts::default();
    let mut sizes: Vec<SizeCounts> =
        entries.iter().map(|&entries| SizeCounts { entries, counts: Counts::default() }).collect();
    for (i, ray) in rays.iter().enumerate() {
        let want = full_walk(tree, prims, ray, &mut full);
        for size in &mut sizes {
            let mut stack = DropOldest::new(size.entries)?;
            check_ray(tree, ray, RankedTrail, &mut stack, want, &mut size.counts).map_err(|e| {
                Error::DesignCheck(format!("ray {i}, a stack of {} entries: {e}", size.entries))
            })?;
        }
        progress(i + 1, rays.len());
    }
    Ok(Steps { bvh: tree.bvh().kind(), depth: tree.depth(), levels: tree.levels(), full, sizes })
}
