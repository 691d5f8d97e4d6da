//! Closest-hit traversal with a short stack that drops its oldest entry on overflow and restarts
//! from the root along a *restart trail*: [`RestartWalk`], a [`Walk`] over a flat BVH2 or BVH6
//! in the nearest-child order.
//!
//! Laine ("Restart trail for stackless BVH traversal", HPG 2010) keeps one bit per level of a
//! BVH2: which of the two children the walk is in, and whether the other is still to be visited.
//! Vaidyanathan, Woop and Benthin ("Wide BVH traversal with a short stack", HPG 2019) generalise
//! it to wide BVHs with a count per level of the children already taken, in the node's sorted
//! child order, and find that five stack entries come close to a full stack in traversal steps.
//! The trail here follows the same plan with one difference in what a level records.
//!
//! # The trail
//!
//! At an internal node at depth `l`, the walk orders *all* children whose box the ray hits
//! geometrically, tested with `tmax = +inf`, by (entry distance, slot): `Q_all`. The children
//! still worth visiting are those whose box is hit at the current `tmax`, the closest hit so far
//! (culled as [`trace`](crate::workload::traverse::trace) culls in the nearest order). The walk
//! descends into the first of `Q_all` that survives culling and pushes the surviving children
//! after it, far to near (nearest on top). Level `l` of the trail holds:
//!
//! * `rank`: the position in `Q_all` of the child the walk is in, `ceil(log2 W)` bits (1 for
//!   BVH2, 3 for BVH6);
//! * `last`: no sibling after it survived culling when it was entered (nothing of this level is
//!   on the stack).
//!
//! So a level costs 2 bits on a BVH2 and 4 on a BVH6.
//!
//! **Why ranks in the unculled order.** A restart recomputes each level's order from the node
//! and must find the same child again. Laine's one bit relies on the *culled* order reproducing
//! itself; but `tmax` shrinks between the descent and the restart, and a box whose entry face
//! holds the closest hit can pass the box test at the old `tmax` and fail it by one ulp at the
//! new one, which shifts the culled positions of every later child and sends the restart down
//! the wrong one. `Q_all` depends only on the ray and the boxes, never on `tmax`, so a rank
//! always names the same child; one more bit per level pays for it. Culling at the current `tmax`
//! is then a filter over `Q_all`, and since a box hit at a smaller `tmax` is hit at a larger one,
//! the children that survive at a restart are a subset of those that survived on the way down.
//!
//! # Stack entries
//!
//! An entry packs the node's address (below 2^40, [`ENTRY_ADDR_BITS`]) with the rank the child
//! will take at its level and its `last` bit in the address's unused high bits
//! ([`pack_entry`], [`unpack_entry`]):
//!
//! ```text
//!   63    60 59   58   56 55        40 39                        0
//!  ┌────────┬────┬───────┬────────────┬───────────────────────────┐
//!  │   0    │last│ rank  │     0      │       node address        │
//!  └────────┴────┴───────┴────────────┴───────────────────────────┘
//! ```
//!
//! Only the farthest pushed sibling of a node has its `last` bit set.
//!
//! # Finishing a subtree, pops and restarts
//!
//! When a subtree is finished (a leaf is done, or no child of a node survives), the deepest
//! trail level whose `last` bit is clear is the level with a sibling left. If there is none the
//! ray is done. Otherwise the walk pops ([`RayOp::Pop`] with the entry an unbounded stack would
//! return, the top of the reference stack the walk keeps for checking):
//!
//! * [`Popped::Entry`]: the entry must be that top. The popped node becomes that level's child
//!   (its rank and `last` from the entry), the deeper levels are cleared (the walk's depth is
//!   that level plus one) and the walk goes on at the popped node.
//! * [`Popped::Restart`]: every entry of the reference stack was dropped, so it is cleared and the
//!   walk descends from the root along the trail to that level. At each level above it, it
//!   fetches the node again (a re-fetch), recomputes `Q_all`, takes the child of the level's rank
//!   and pushes the level's surviving siblings after it again (the level becomes `last` if none
//!   survive). At the level itself it moves on to the first surviving sibling after the child of
//!   its rank: the finished part (that child and every rank before it) is never re-entered. If
//!   no sibling survives there, that level is finished too and the walk goes up to the next level
//!   with a sibling left, as after any finished subtree.
//!
//! With no entry ever dropped the walk visits exactly the nodes the full-stack walk visits, in
//! the same order.
//!
//! # Checks
//!
//! Besides the popped entry and the consistency of the trail with the reference stack (the ray is
//! done exactly when the reference stack is empty), the walk keeps, for checking only, the
//! subtrees finished so far as intervals of a fixed pre-order numbering of the BVH
//! ([`RestartTree`]) and refuses to visit a node inside one. The driver (`crate::run::steps`)
//! checks the closest hit against the full-stack walk and that a restart follows a drop.
//!
//! Planted bugs come in through [`TrailRules`]: the walk asks it for each choice of the trail,
//! and [`RankedTrail`], the product's, answers with the rules above.

use std::collections::BTreeMap;

use rtl::ray_op::{Popped, RayOp, Walk};

use crate::error::{Error, Result};
use crate::workload::bvh::{node_bytes, Bvh, BvhKind, NodeRef};
use crate::workload::geometry::{Primitives, Ray};
use crate::workload::trace::{rtl_kind, FetchKind};
use crate::workload::traverse::{hit_node_children, leaf_prims, tree_root, ChildOrder, Hit};

/// Node addresses in stack entries are below 2^40 (the regions of `bvh.rs` end below 2^36).
pub const ENTRY_ADDR_BITS: u32 = 40;
/// Lowest bit of an entry's rank field (3 bits: a BVH6 node's 6 children).
pub const ENTRY_RANK_SHIFT: u32 = 56;
/// Bits of the rank field.
pub const ENTRY_RANK_BITS: u32 = 3;
/// An entry's `last` bit.
pub const ENTRY_LAST_SHIFT: u32 = 59;

const ADDR_MASK: u64 = (1 << ENTRY_ADDR_BITS) - 1;
const RANK_MASK: u64 = (1 << ENTRY_RANK_BITS) - 1;

/// A stack entry: `addr` with `rank` and `last` in its high bits (module docs). `addr` must be
/// below 2^40 and `rank` below 8.
pub fn pack_entry(addr: u64, rank: u8, last: bool) -> u64 {
    assert!(addr <= ADDR_MASK && u64::from(rank) <= RANK_MASK, "entry {addr:#x} rank {rank} does not fit");
    addr | u64::from(rank) << ENTRY_RANK_SHIFT | u64::from(last) << ENTRY_LAST_SHIFT
}

/// The address, rank and `last` bit of an entry made by [`pack_entry`].
pub fn unpack_entry(entry: u64) -> (u64, u8, bool) {
    (entry & ADDR_MASK, (entry >> ENTRY_RANK_SHIFT & RANK_MASK) as u8, entry >> ENTRY_LAST_SHIFT & 1 == 1)
}

/// Trail levels for `kind` by default: 96 for a BVH2 (192 bits), 32 for a BVH6 (128 bits). The
/// deepest BVHs the model builds from the shared scenes are party-partial's (954k triangles, a
/// long thin scene): a BVH2 of 73 levels and a BVH6 of 25; every other scene's BVH2 is at most
/// 48 levels deep, its BVH6 at most 17. A deeper BVH is refused before any ray runs.
pub fn default_levels(kind: BvhKind) -> usize {
    match kind {
        BvhKind::Bvh2 | BvhKind::Cwbvh => 96,
        BvhKind::Bvh6 => 32,
    }
}

/// Bits of one trail level: the rank (`ceil(log2 W)`) and the `last` bit.
pub fn level_bits(kind: BvhKind) -> u32 {
    match kind {
        BvhKind::Bvh2 => 1 + 1,
        BvhKind::Bvh6 | BvhKind::Cwbvh => ENTRY_RANK_BITS + 1,
    }
}

/// A BVH2 or BVH6 ready for restart walks: checked (flat, nearest order, no deeper than the
/// trail) and numbered in pre-order for the finished-subtree check.
pub struct RestartTree<'a> {
    bvh: &'a Bvh,
    prims: &'a Primitives,
    levels: usize,
    depth: usize,
    /// Per node ([`Self::key`]): its pre-order position and the size of its subtree.
    order: Vec<(u32, u32)>,
    /// Internal nodes before leaves in the key space (BVH6; 0 for a BVH2, whose nodes share one
    /// array).
    leaf_key_base: usize,
}

impl<'a> RestartTree<'a> {
    /// Checks that `bvh` can be walked with a restart trail of `levels` levels in `order`.
    pub fn new(bvh: &'a Bvh, prims: &'a Primitives, order: ChildOrder, levels: usize) -> Result<Self> {
        match bvh {
            Bvh::Bvh2(_) | Bvh::Bvh6(_) => {}
            Bvh::Cwbvh(_) => {
                return Err(Error::Invalid(
                    "bvh cwbvh: the restart trail needs a child order a restart can reproduce; use bvh bvh2 or bvh6"
                        .into(),
                ))
            }
            Bvh::TwoLevel(_) => {
                return Err(Error::Invalid(
                    "accel two-level: the restart trail walks one flat BVH; use accel flat (with bvh bvh2 or bvh6)"
                        .into(),
                ))
            }
        }
        if order != ChildOrder::Nearest {
            return Err(Error::Invalid(format!(
                "order {}: the restart trail needs a child order a restart can reproduce; use order nearest",
                format!("{order:?}").to_lowercase()
            )));
        }
        let (leaf_key_base, keys) = match bvh {
            Bvh::Bvh2(b) => (0, b.nodes.len()),
            Bvh::Bvh6(b) => (b.nodes.len(), b.nodes.len() + b.leaves.len()),
            _ => unreachable!("refused above"),
        };
        let mut tree = RestartTree { bvh, prims, levels, depth: 0, order: vec![(0, 0); keys], leaf_key_base };
        tree.number();
        if tree.depth > levels {
            return Err(Error::Invalid(format!(
                "the {} is {} levels deep, deeper than the restart trail's {levels} levels",
                format!("{:?}", bvh.kind()).to_uppercase(),
                tree.depth
            )));
        }
        Ok(tree)
    }

    /// Internal nodes on the longest root-to-leaf path: the trail levels a walk needs.
    pub fn depth(&self) -> usize {
        self.depth
    }

    pub fn levels(&self) -> usize {
        self.levels
    }

    pub fn bvh(&self) -> &Bvh {
        self.bvh
    }

    fn key(&self, node: NodeRef) -> usize {
        match node {
            NodeRef::Internal(i) => i as usize,
            NodeRef::Leaf(j) => self.leaf_key_base + j as usize,
        }
    }

    fn children(&self, i: u32) -> Vec<NodeRef> {
        match self.bvh {
            Bvh::Bvh2(b) => {
                let first = b.nodes[i as usize].first_index;
                [first, first + 1]
                    .map(
                        |c| {
                            if b.nodes[c as usize].is_leaf() {
                                NodeRef::Leaf(c)
                            } else {
                                NodeRef::Internal(c)
                            }
                        },
                    )
                    .to_vec()
            }
            Bvh::Bvh6(b) => b.node_children(i).iter().map(|c| c.node).collect(),
            _ => unreachable!("refused by new"),
        }
    }

    /// Numbers the nodes in pre-order (children in slot order), sizes their subtrees and
    /// measures the depth.
    fn number(&mut self) {
        let mut stack = vec![(tree_root(self.bvh), 0usize)];
        let mut preorder: Vec<NodeRef> = Vec::with_capacity(self.order.len());
        while let Some((node, depth)) = stack.pop() {
            let key = self.key(node);
            self.order[key].0 = preorder.len() as u32;
            preorder.push(node);
            match node {
                NodeRef::Leaf(_) => self.depth = self.depth.max(depth),
                NodeRef::Internal(i) => {
                    stack.extend(self.children(i).into_iter().rev().map(|c| (c, depth + 1)));
                }
            }
        }
        // Reverse pre-order meets every child before its parent.
        for &node in preorder.iter().rev() {
            let size = match node {
                NodeRef::Leaf(_) => 1,
                NodeRef::Internal(i) => {
                    1 + self.children(i).iter().map(|&c| self.order[self.key(c)].1).sum::<u32>()
                }
            };
            let key = self.key(node);
            self.order[key].1 = size;
        }
    }

    /// The pre-order interval `[first, end)` of `node`'s subtree.
    fn interval(&self, node: NodeRef) -> (u32, u32) {
        let (pos, size) = self.order[self.key(node)];
        (pos, pos + size)
    }

    fn addr(&self, node: NodeRef) -> u64 {
        self.bvh.node_addr(node)
    }

    /// The node at a BVH address, as a popped entry names it.
    fn node_at(&self, addr: u64) -> std::result::Result<NodeRef, String> {
        use crate::workload::bvh::{INTERNAL_BASE, LEAF_BASE, PRIM_BASE};
        let kind = self.bvh.kind();
        let (base, kind_of, make): (u64, FetchKind, fn(u32) -> NodeRef) = match addr {
            a if (INTERNAL_BASE..LEAF_BASE).contains(&a) => {
                (INTERNAL_BASE, FetchKind::Internal, NodeRef::Internal)
            }
            a if (LEAF_BASE..PRIM_BASE).contains(&a) => (LEAF_BASE, FetchKind::Leaf, NodeRef::Leaf),
            _ => return Err(format!("popped address {addr:#x} is not a node of the BVH")),
        };
        let size = u64::from(node_bytes(kind, kind_of));
        let index = (addr - base) / size;
        let node = make(index as u32);
        if (addr - base) % size != 0 || self.order.get(self.key(node)).is_none() || self.addr(node) != addr {
            return Err(format!("popped address {addr:#x} is not a node of the BVH"));
        }
        Ok(node)
    }

    fn visit_op(&self, addr: u64, kind: FetchKind) -> RayOp {
        RayOp::Visit { addr, kind: rtl_kind(kind), bytes: node_bytes(self.bvh.kind(), kind) }
    }
}

/// The choices of the trail, asked by [`RestartWalk`]; positions are indices into `Q_all`.
/// [`RankedTrail`] is the product's; a test swaps in another to plant a bug.
pub trait TrailRules: Send {
    /// The position in `Q_all` of the path child of a level whose trail holds `rank`, at a
    /// restart, `alive` telling which children survive culling now: position `rank`, whatever
    /// survives (`None`: no such child).
    fn path(&self, rank: usize, alive: &[bool]) -> Option<usize> {
        (rank < alive.len()).then_some(rank)
    }

    /// The `last` bit of the `index`-th of `count` siblings pushed at one node, nearest first:
    /// set on the farthest only.
    fn last(&self, index: usize, count: usize) -> bool {
        index + 1 == count
    }

    /// The siblings a restart pushes again at a level above its target, from the level's
    /// surviving positions `alive` and its path child's `path`: those after the path child.
    fn repush(&self, alive: &[usize], path: usize) -> Vec<usize> {
        alive.iter().copied().filter(|&k| k > path).collect()
    }

    /// Which of `alive_after` (the surviving positions after the path child at a restart's target
    /// level, nearest first) the walk moves on to: the first.
    fn resume(&self, alive_after: &[usize]) -> Option<usize> {
        (!alive_after.is_empty()).then_some(0)
    }
}

/// The trail of the module docs.
#[derive(Clone, Copy, Debug, Default)]
pub struct RankedTrail;

impl TrailRules for RankedTrail {}

/// One trail level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Level {
    /// Position of the path child in the level's `Q_all`.
    pub rank: u8,
    /// No sibling of this level is left on the stack.
    pub last: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Start,
    /// A Pop was emitted for the sibling left at trail level `level`.
    Popping {
        level: usize,
    },
    Done,
}

/// Subtrees finished so far, as disjoint pre-order intervals (checking only).
#[derive(Clone, Debug, Default)]
struct Finished {
    /// Start to end of each interval.
    spans: BTreeMap<u32, u32>,
}

impl Finished {
    fn insert(&mut self, (start, end): (u32, u32)) {
        let inside: Vec<u32> = self.spans.range(start..end).map(|(&s, _)| s).collect();
        inside.iter().for_each(|s| {
            self.spans.remove(s);
        });
        self.spans.insert(start, end);
    }

    fn contains(&self, position: u32) -> bool {
        self.spans.range(..=position).next_back().is_some_and(|(_, &end)| position < end)
    }
}

/// One ray's closest-hit walk with a restart trail (module docs).
pub struct RestartWalk<'t, R: TrailRules = RankedTrail> {
    tree: &'t RestartTree<'t>,
    rules: R,
    ray: Ray,
    tmax: f32,
    best: Option<Hit>,
    trail: Vec<Level>,
    /// Depth of the node being visited (the trail levels above it are meaningful).
    depth: usize,
    state: State,
    /// Every entry pushed and not popped, as an unbounded stack holds them (checking).
    reference: Vec<u64>,
    /// The node at each depth down to the current one (checking: finished subtrees).
    path: Vec<NodeRef>,
    finished: Finished,
    restarts: u64,
    refetched: u64,
    /// This node's `Q_all` and which of it survive at `tmax`.
    all: Vec<(f32, NodeRef)>,
    alive: Vec<bool>,
    scratch: Vec<(f32, NodeRef)>,
}

impl<'t> RestartWalk<'t, RankedTrail> {
    pub fn new(tree: &'t RestartTree<'t>, ray: Ray) -> Self {
        Self::with_rules(tree, ray, RankedTrail)
    }
}

impl<'t, R: TrailRules> RestartWalk<'t, R> {
    /// A walk whose trail choices `rules` makes.
    pub fn with_rules(tree: &'t RestartTree<'t>, ray: Ray, rules: R) -> Self {
        RestartWalk {
            tree,
            rules,
            ray,
            tmax: f32::INFINITY,
            best: None,
            trail: vec![Level::default(); tree.levels],
            depth: 0,
            state: State::Start,
            reference: Vec::new(),
            path: Vec::new(),
            finished: Finished::default(),
            restarts: 0,
            refetched: 0,
            all: Vec::new(),
            alive: Vec::new(),
            scratch: Vec::new(),
        }
    }

    /// The closest hit found so far (the ray's, once done).
    pub fn hit(&self) -> Option<Hit> {
        self.best
    }

    pub fn is_done(&self) -> bool {
        self.state == State::Done
    }

    /// Restarts taken.
    pub fn restarts(&self) -> u64 {
        self.restarts
    }

    /// Node visits made while descending the trail after a restart.
    pub fn refetched(&self) -> u64 {
        self.refetched
    }

    /// Emits a visit of `node`, refusing one inside a finished subtree.
    fn visit(&self, node: NodeRef, kind: FetchKind, ops: &mut Vec<RayOp>) -> std::result::Result<(), String> {
        let (position, _) = self.tree.interval(node);
        if self.finished.contains(position) {
            return Err(format!(
                "visit of {:#x} re-enters a finished subtree (depth {}, {} restarts so far)",
                self.tree.addr(node),
                self.depth,
                self.restarts
            ));
        }
        ops.push(self.tree.visit_op(self.tree.addr(node), kind));
        Ok(())
    }

    /// `Q_all` of internal node `i` and which of it survive at the current `tmax`.
    fn rank_children(&mut self, i: u32) -> std::result::Result<(), String> {
        let bvh = self.tree.bvh;
        self.all.clear();
        hit_node_children(bvh, i, &self.ray, f32::INFINITY, ChildOrder::Nearest, &mut self.all);
        self.all.sort_by(|a, b| a.0.total_cmp(&b.0));
        self.scratch.clear();
        hit_node_children(bvh, i, &self.ray, self.tmax, ChildOrder::Nearest, &mut self.scratch);
        self.alive.clear();
        for &(_, node) in &self.all {
            self.alive.push(self.scratch.iter().any(|s| s.1 == node));
        }
        if let Some(&(_, lost)) = self.scratch.iter().find(|s| !self.all.iter().any(|a| a.1 == s.1)) {
            return Err(format!(
                "child {:#x} is hit at tmax {} but not at +inf",
                self.tree.addr(lost),
                self.tmax
            ));
        }
        Ok(())
    }

    /// The rank of the child at `position` of `Q_all`: its position, in the trail's bits.
    fn rank_of(position: usize) -> std::result::Result<u8, String> {
        u8::try_from(position)
            .ok()
            .filter(|&r| u64::from(r) <= RANK_MASK)
            .ok_or_else(|| format!("rank {position} does not fit the trail's {ENTRY_RANK_BITS} bits"))
    }

    /// Pushes the children at `positions` (nearest first) far to near, nearest on top.
    fn push_siblings(
        &mut self,
        positions: &[usize],
        ops: &mut Vec<RayOp>,
    ) -> std::result::Result<(), String> {
        for (index, &k) in positions.iter().enumerate().rev() {
            let entry = pack_entry(
                self.tree.addr(self.all[k].1),
                Self::rank_of(k)?,
                self.rules.last(index, positions.len()),
            );
            self.reference.push(entry);
            ops.push(RayOp::Push(entry));
        }
        Ok(())
    }

    /// From the internal node at depth `d` (its children ranked), descends into its first
    /// surviving child after position `after` (all of them: `None`), pushing the surviving ones
    /// after that child. `None` when no child is left to descend into.
    fn descend(
        &mut self,
        d: usize,
        after: Option<usize>,
        ops: &mut Vec<RayOp>,
    ) -> std::result::Result<Option<NodeRef>, String> {
        let start = after.map_or(0, |r| r + 1);
        let alive: Vec<usize> = (start..self.all.len()).filter(|&k| self.alive[k]).collect();
        let pick = match after {
            None => (!alive.is_empty()).then_some(0),
            Some(_) => self.rules.resume(&alive),
        };
        let Some(pick) = pick.filter(|&p| p < alive.len()) else { return Ok(None) };
        if d >= self.tree.levels {
            return Err(format!("depth {d} is beyond the trail's {} levels", self.tree.levels));
        }
        let k = alive[pick];
        let rest = &alive[pick + 1..];
        self.trail[d] = Level { rank: Self::rank_of(k)?, last: rest.is_empty() };
        self.push_siblings(rest, ops)?;
        let child = self.all[k].1;
        self.depth = d + 1;
        self.path.truncate(d + 1);
        self.path.push(child);
        Ok(Some(child))
    }

    /// Visits `node` at the current depth: a leaf's primitives, or an internal node's descent.
    /// Returns the node to visit next, `None` when `node`'s subtree is finished.
    fn step(&mut self, node: NodeRef, ops: &mut Vec<RayOp>) -> std::result::Result<Option<NodeRef>, String> {
        match node {
            NodeRef::Internal(i) => {
                self.visit(node, FetchKind::Internal, ops)?;
                self.rank_children(i)?;
                self.descend(self.depth, None, ops)
            }
            NodeRef::Leaf(j) => {
                self.visit(node, FetchKind::Leaf, ops)?;
                let prims = self.tree.prims;
                for (slot, prim) in leaf_prims(self.tree.bvh, j) {
                    ops.push(self.tree.visit_op(Bvh::prim_addr(slot), prims.kind()));
                    let t = prims.hit(prim as usize, &self.ray, self.tmax);
                    if t < self.tmax {
                        self.tmax = t;
                        self.best = Some(Hit { prim, t, instance: None });
                    }
                }
                Ok(None)
            }
        }
    }

    /// The subtree at the current depth is finished: pop for the deepest level with a sibling
    /// left, or end the ray.
    fn finish(&mut self, ops: &mut Vec<RayOp>) -> std::result::Result<(), String> {
        let level = (0..self.depth).rev().find(|&l| !self.trail[l].last);
        let done = self.path[level.map_or(0, |p| p + 1)];
        self.finished.insert(self.tree.interval(done));
        match level {
            None if self.reference.is_empty() => {
                self.state = State::Done;
                Ok(())
            }
            None => Err(format!(
                "every trail level is last, but {} entries are left on the reference stack",
                self.reference.len()
            )),
            Some(p) => {
                let top = *self.reference.last().ok_or_else(|| {
                    format!("trail level {p} has a sibling left, but the reference stack is empty")
                })?;
                ops.push(RayOp::Pop(top));
                self.state = State::Popping { level: p };
                Ok(())
            }
        }
    }

    /// Descends the trail from the root to `target` after the stack dropped what was left
    /// (module docs). Returns the node to visit next, `None` when `target` is finished too.
    fn restart(
        &mut self,
        target: usize,
        ops: &mut Vec<RayOp>,
    ) -> std::result::Result<Option<NodeRef>, String> {
        self.reference.clear();
        self.restarts += 1;
        let mut node = tree_root(self.tree.bvh);
        self.path.clear();
        self.path.push(node);
        for l in 0..=target {
            self.depth = l;
            let NodeRef::Internal(i) = node else {
                return Err(format!("the trail leads through leaf {:#x} at level {l}", self.tree.addr(node)));
            };
            self.visit(node, FetchKind::Internal, ops)?;
            self.refetched += 1;
            self.rank_children(i)?;
            let rank = self.trail[l].rank as usize;
            let path =
                self.rules.path(rank, &self.alive).filter(|&k| k < self.all.len()).ok_or_else(|| {
                    format!(
                        "trail level {l}'s rank {rank} names none of the {} children the ray hits",
                        self.all.len()
                    )
                })?;
            if l == target {
                return self.descend(l, Some(path), ops);
            }
            let alive: Vec<usize> = (0..self.all.len()).filter(|&k| self.alive[k]).collect();
            let pushes = self.rules.repush(&alive, path);
            self.trail[l].last = pushes.is_empty();
            self.push_siblings(&pushes, ops)?;
            node = self.all[path].1;
            self.path.push(node);
        }
        unreachable!("returns at the target level")
    }
}

impl<R: TrailRules> Walk for RestartWalk<'_, R> {
    fn resume(&mut self, answer: Option<Popped>, ops: &mut Vec<RayOp>) -> std::result::Result<(), String> {
        let mut next = match (self.state, answer) {
            (State::Start, None) => {
                let root = tree_root(self.tree.bvh);
                self.path.push(root);
                Some(root)
            }
            (State::Popping { level }, Some(Popped::Entry(entry))) => {
                let expected = self.reference.pop().expect("a Pop is emitted only with an entry to expect");
                if entry != expected {
                    return Err(format!("popped {entry:#x}, the reference stack's top is {expected:#x}"));
                }
                let (addr, rank, last) = unpack_entry(entry);
                self.trail[level] = Level { rank, last };
                self.depth = level + 1;
                let node = self.tree.node_at(addr)?;
                self.path.truncate(level + 1);
                self.path.push(node);
                Some(node)
            }
            (State::Popping { level }, Some(Popped::Restart)) => self.restart(level, ops)?,
            (State::Done, _) => return Err("resumed after the ray's end".into()),
            (State::Start, Some(a)) => return Err(format!("answer {a:?} before the first segment")),
            (State::Popping { .. }, None) => return Err("no answer to the pop that ended the segment".into()),
        };
        loop {
            match next {
                Some(node) => next = self.step(node, ops)?,
                None => return self.finish(ops),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_round_trip_and_keep_the_address_bits_clear() {
        for (addr, rank, last) in [(0x4_0000_0040, 5, true), (ADDR_MASK, 7, false), (0, 0, true)] {
            let e = pack_entry(addr, rank, last);
            assert_eq!(unpack_entry(e), (addr, rank, last));
            assert_eq!(e & ADDR_MASK, addr);
        }
        assert_eq!(pack_entry(0x40, 1, true), 0x40 | 1 << 56 | 1 << 59);
    }

    #[test]
    fn finished_spans_merge_and_answer_containment() {
        let mut f = Finished::default();
        f.insert((4, 6));
        f.insert((10, 11));
        assert!(f.contains(4) && f.contains(5) && !f.contains(6) && !f.contains(3));
        f.insert((2, 12));
        assert_eq!(f.spans.len(), 1);
        assert!(f.contains(10) && f.contains(2) && !f.contains(12));
    }
}
