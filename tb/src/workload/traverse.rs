//! Closest-hit traversal that reports every node fetch, push and pop in RT-unit order.
//!
//! BVH2 and BVH6 are walked by our own loop so the child order is ours to choose
//! ([`ChildOrder`]): at an internal node all children's boxes are tested against the current
//! closest hit, then the order picks the child to descend into and pushes the other hit
//! children; a leaf visits its primitives; when a node leaves nothing to descend into, the next
//! entry is popped. A popped node is always fetched (entries carry no distance to cull by), as in
//! Vulkan-Sim. The flat walk starts at the root's visit (no push or pop of the root).
//!
//! # Traversal as Vulkan-Sim does it (`ChildOrder::VulkanSim`)
//!
//! Vulkan-Sim's `traceRay` (`src/cuda-sim/vulkan_ray_tracing.cc`, lines cited from the mirrored
//! HEAD) tests a node's six children in index order (lines 621-640 and 797-815), keeping a child
//! only if its box is hit and its entry distance is below the closest hit so far
//! (`thit >= min_thit` culls, lines 630 and 806). It then walks the hit children in index order
//! (lines 649-686 and 824-861): the first hit *internal* child becomes the next node, every other hit child (later
//! internal children and every hit leaf, wherever it is in the order) is pushed. When an internal
//! node yields no internal child, the leaves on top of the stack are popped and processed one
//! by one (LIFO, lines 695-703 and 870-873), then the next internal entry is popped (lines
//! 591-595 and 764-768). The walk is two-level with one stack (`std::list<StackEntry>`, line 566)
//! holding TLAS and BLAS entries alike:
//!
//! 1. the TLAS header is read (`BVH_STRUCTURE`, line 545); the TLAS root is pushed if the ray hits
//!    the header's world box (lines 568-581), then popped (line 594);
//! 2. TLAS internal nodes follow the rule above; instance leaves are pushed and popped LIFO;
//! 3. a popped instance leaf is fetched (`BVH_INSTANCE_LEAF`, 128 B, line 707), then its BLAS's
//!    header (`BVH_STRUCTURE`, 64 B, line 731); the ray is transformed to object space
//!    (line 748) and the BLAS root pushed (line 751), then popped (line 768);
//! 4. BLAS internal nodes follow the same rule; a popped BLAS leaf is its leaf descriptor
//!    (`BVH_PRIMITIVE_LEAF_DESCRIPTOR`, 8 B, line 876) and its quad leaf (64 B, lines 938/1011);
//! 5. when the BLAS's entries are used up, the TLAS entries below them continue.
//!
//! [`trace`] follows this for a [`Bvh::TwoLevel`]; the flat BVH6 walk applies the same child
//! rule. Our rays are not normalised in object space, so object-space distances equal world
//! distances and one `tmax` culls both levels (Vulkan-Sim scales by `worldToObject_tMultiplier`).
//! Differences kept on purpose: Vulkan-Sim also records a triangle that is hit but farther than
//! the closest hit so far as the closest leaf (lines 920-931 only guard `min_thit`); we keep the
//! closest. With [`ChildOrder::Nearest`] the two-level walk has the same structure (header,
//! world-box test, instance leaf, BLAS header, BLAS root push and pop) and only the choice at
//! internal nodes differs.
//!
//! CWBVH is walked by obvhs's own `traverse!` loop (octant-ordered, Ylitie et al. 2017) with a
//! recording, unbounded stack: its entries are node *groups* (a child base index plus a hit mask),
//! recorded by the address of the group's first child node, and `ChildOrder` does not apply.

use glam::UVec2;
use obvhs::{cwbvh::CwBvh, faststack::FastStack, traverse};

use crate::workload::bvh::{Blas, Bvh, Bvh6Child, NodeRef, TwoLevel, CWBVH_NODE_SIZE, INTERNAL_BASE};
use crate::workload::geometry::{hit_triangle, Primitives, Ray, BOX_LANES};
use crate::workload::scene::{MeshGeometry, Scene};
use serde::Serialize;

use super::trace::{FetchKind, RayTrace, TraceOp};

/// Receives the operations of one traversal. `()` ignores them (for rendering only).
pub trait Recorder {
    /// The ray about to be traversed.
    fn ray(&mut self, _ray: &Ray) {}
    fn visit(&mut self, addr: u64, kind: FetchKind);
    fn push(&mut self, addr: u64);
    fn pop(&mut self, addr: u64);
}

impl Recorder for () {
    fn visit(&mut self, _: u64, _: FetchKind) {}
    fn push(&mut self, _: u64) {}
    fn pop(&mut self, _: u64) {}
}

impl Recorder for RayTrace {
    fn visit(&mut self, addr: u64, kind: FetchKind) {
        self.ops.push(TraceOp::Visit { addr, kind }.pack());
    }
    fn push(&mut self, addr: u64) {
        self.ops.push(TraceOp::Push(addr).pack());
        self.depth += 1;
        self.max_depth = self.max_depth.max(self.depth);
    }
    fn pop(&mut self, addr: u64) {
        self.ops.push(TraceOp::Pop(addr).pack());
        // Saturating so that a faulty traversal yields a trace `check_stack_history` rejects.
        self.depth = self.depth.saturating_sub(1);
    }
}

/// How an internal node orders the children it descends into and pushes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ChildOrder {
    /// Descend the nearest hit child, push the others far to near (nearest remaining on top).
    #[default]
    Nearest,
    /// Vulkan-Sim's rule: descend the first hit internal child in index order, push every other
    /// hit child (leaves included) in index order, pop leaves LIFO.
    #[value(name = "vulkansim")]
    VulkanSim,
}

/// A closest hit: the primitive, the distance along the ray and (two-level) the instance. The
/// primitive indexes `Scene::primitives`, or `Objects::local` when the instance's mesh is local.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub prim: u32,
    pub t: f32,
    pub instance: Option<u32>,
}

/// Unit world-space geometric normal at `point` of `hit`, facing against `dir`.
pub fn hit_normal(scene: &Scene, hit: &Hit, point: glam::Vec3A, dir: glam::Vec3A) -> glam::Vec3A {
    let o = &scene.objects;
    match hit.instance.map(|i| o.instances[i as usize]) {
        Some(inst) if matches!(o.meshes[inst.mesh as usize], MeshGeometry::Local(_)) => {
            let n = o.local[hit.prim as usize].compute_normal();
            let n = match inst.to_world {
                Some(m) => (m.matrix3.inverse().transpose() * n).normalize_or_zero(),
                None => n,
            };
            if n.dot(dir) > 0.0 {
                -n
            } else {
                n
            }
        }
        _ => scene.primitives.normal(hit.prim as usize, point, dir),
    }
}

/// Traces `ray` over `(ray.tmin, tmax)` and returns the closest hit, reporting every operation.
pub fn trace<R: Recorder>(
    bvh: &Bvh,
    prims: &Primitives,
    ray: &Ray,
    tmax: f32,
    order: ChildOrder,
    rec: &mut R,
) -> Option<Hit> {
    rec.ray(ray);
    let q = Query { prims, ray, tmax, order };
    match bvh {
        Bvh::Cwbvh(cw) => trace_cwbvh(cw, q, rec),
        Bvh::TwoLevel(tl) => trace_two_level(tl, q, rec),
        _ => trace_tree(bvh, q, rec),
    }
}

/// What every walk is asked: the closest hit among `prims` of `ray` before `tmax`, children
/// visited in `order`.
#[derive(Clone, Copy)]
struct Query<'a> {
    prims: &'a Primitives,
    ray: &'a Ray,
    tmax: f32,
    order: ChildOrder,
}

/// Primitive slots of a leaf and the scene primitive in each.
pub(crate) fn leaf_prims(bvh: &Bvh, leaf: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
    let (range, indices) = match bvh {
        Bvh::Bvh2(b) => {
            let n = &b.nodes[leaf as usize];
            (n.first_index..n.first_index + n.prim_count, &b.primitive_indices)
        }
        Bvh::Bvh6(b) => (b.leaves[leaf as usize].clone(), &b.prim_indices),
        Bvh::Cwbvh(_) | Bvh::TwoLevel(_) => unreachable!("traversed by their own walks"),
    };
    range.map(move |slot| (slot, indices[slot as usize]))
}

/// The root of a BVH2 or BVH6: a leaf when the BVH2 holds one primitive.
pub(crate) fn tree_root(bvh: &Bvh) -> NodeRef {
    match bvh {
        Bvh::Bvh2(b) if b.nodes[0].is_leaf() => NodeRef::Leaf(0),
        _ => NodeRef::Internal(0),
    }
}

fn trace_tree<R: Recorder>(bvh: &Bvh, q: Query, rec: &mut R) -> Option<Hit> {
    let Query { prims, ray, mut tmax, order } = q;
    let root = tree_root(bvh);
    let mut best = None;
    let mut stack: Vec<NodeRef> = Vec::new();
    let mut hits: Vec<(f32, NodeRef)> = Vec::with_capacity(crate::workload::bvh::BVH6_WIDTH);
    let mut current = Some(root);
    while let Some(node) = current {
        match node {
            NodeRef::Internal(i) => {
                rec.visit(bvh.node_addr(node), FetchKind::Internal);
                hits.clear();
                hit_node_children(bvh, i, ray, tmax, order, &mut hits);
                current = choose(&mut hits, order, |child| {
                    rec.push(bvh.node_addr(child));
                    stack.push(child);
                });
            }
            NodeRef::Leaf(j) => {
                rec.visit(bvh.node_addr(node), FetchKind::Leaf);
                for (slot, prim) in leaf_prims(bvh, j) {
                    rec.visit(Bvh::prim_addr(slot), prims.kind());
                    let t = prims.hit(prim as usize, ray, tmax);
                    if t < tmax {
                        tmax = t;
                        best = Some(Hit { prim, t, instance: None });
                    }
                }
                current = None;
            }
        }
        if current.is_none() {
            current = stack.pop();
            if let Some(n) = current {
                rec.pop(bvh.node_addr(n));
            }
        }
    }
    best
}

/// The children of internal node `i` of a BVH2 or BVH6 the ray must visit before `tmax`, appended
/// to `hits` in slot order with their entry distances (as [`hit_children`] tests a BVH6 node's).
pub(crate) fn hit_node_children(
    bvh: &Bvh,
    i: u32,
    ray: &Ray,
    tmax: f32,
    order: ChildOrder,
    hits: &mut Vec<(f32, NodeRef)>,
) {
    match bvh {
        Bvh::Bvh2(b) => {
            let first = b.nodes[i as usize].first_index;
            for c in [first, first + 1] {
                let child = &b.nodes[c as usize];
                let node = if child.is_leaf() { NodeRef::Leaf(c) } else { NodeRef::Internal(c) };
                if let Some(t) = child_hit(ray, child.aabb(), tmax, order) {
                    hits.push((t, node));
                }
            }
        }
        Bvh::Bvh6(b) => hit_children(ray, b.node_children(i), tmax, order, hits),
        Bvh::Cwbvh(_) | Bvh::TwoLevel(_) => unreachable!("traversed by their own walks"),
    }
}

/// Entry distance of a child box the ray must visit, if any: hit within `[tmin, tmax]` and not
/// culled ([`entered_in_time`]).
fn child_hit(ray: &Ray, aabb: &obvhs::aabb::Aabb, tmax: f32, order: ChildOrder) -> Option<f32> {
    let t = ray.hit_box(aabb, tmax)?;
    entered_in_time(t, tmax, order).then_some(t)
}

/// A hit child box entered at `t` is visited: always in the nearest-child order, and in
/// Vulkan-Sim's only if entered before the closest hit (`thit >= min_thit` culls,
/// `vulkan_ray_tracing.cc:630`).
#[inline]
fn entered_in_time(t: f32, tmax: f32, order: ChildOrder) -> bool {
    order == ChildOrder::Nearest || t < tmax
}

/// [`child_hit`] of every child of a BVH6 node, the hit ones appended to `hits` in index order
/// (the boxes tested together: [`Ray::hit_boxes`]).
fn hit_children(
    ray: &Ray,
    children: &[Bvh6Child],
    tmax: f32,
    order: ChildOrder,
    hits: &mut Vec<(f32, NodeRef)>,
) {
    let mut near = [0.0; BOX_LANES];
    let mask = ray.hit_boxes(children.iter().map(|c| &c.aabb), tmax, &mut near);
    for (k, c) in children.iter().enumerate() {
        let t = near[k];
        if mask & 1 << k != 0 && entered_in_time(t, tmax, order) {
            hits.push((t, c.node));
        }
    }
}

/// From the hit children of an internal node (in index order), returns the child to descend into
/// and pushes the others through `push`.
///
/// * `Nearest`: the nearest child (of any kind); the others pushed far to near.
/// * `VulkanSim`: the first *internal* child in index order; every other hit child, leaves
///   included, pushed in index order (`vulkan_ray_tracing.cc:653-686`).
fn choose(hits: &mut [(f32, NodeRef)], order: ChildOrder, mut push: impl FnMut(NodeRef)) -> Option<NodeRef> {
    match order {
        ChildOrder::Nearest => {
            hits.sort_by(|a, b| a.0.total_cmp(&b.0));
            hits.iter().skip(1).rev().for_each(|h| push(h.1));
            hits.first().map(|h| h.1)
        }
        ChildOrder::VulkanSim => {
            let mut next = None;
            for &(_, child) in hits.iter() {
                if next.is_none() && matches!(child, NodeRef::Internal(_)) {
                    next = Some(child);
                } else {
                    push(child);
                }
            }
            next
        }
    }
}

/// A stack entry of the two-level walk: a TLAS node or a node of the current instance's BLAS.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Entry {
    Top(NodeRef),
    Bottom(NodeRef),
}

/// The instance being traversed: its index, BLAS and the ray in its object space.
struct Current<'a> {
    instance: u32,
    blas: &'a Blas,
    ray: Ray,
}

fn entry_addr(tl: &TwoLevel, cur: Option<&Current>, e: Entry) -> u64 {
    match e {
        Entry::Top(n) => tl.tlas_addr(n),
        Entry::Bottom(n) => cur.expect("BLAS entries lie above their instance's").blas.node_addr(n),
    }
}

/// The two-level walk with one stack across both levels (see the module docs).
fn trace_two_level<R: Recorder>(tl: &TwoLevel, q: Query, rec: &mut R) -> Option<Hit> {
    let Query { prims, ray, mut tmax, order } = q;
    rec.visit(tl.header_addr(None), FetchKind::BvhHeader);
    let mut best = None;
    let mut stack: Vec<Entry> = Vec::new();
    let mut hits: Vec<(f32, NodeRef)> = Vec::with_capacity(crate::workload::bvh::BVH6_WIDTH);
    let mut cur: Option<Current> = None;
    let mut next: Option<Entry> = None;
    if ray.hit_box(&tl.world, tmax).is_some() {
        let root = Entry::Top(NodeRef::Internal(0));
        rec.push(entry_addr(tl, None, root));
        stack.push(root);
    }
    loop {
        let entry = match next.take() {
            Some(e) => e,
            None => match stack.pop() {
                Some(e) => {
                    rec.pop(entry_addr(tl, cur.as_ref(), e));
                    e
                }
                None => break,
            },
        };
        match entry {
            Entry::Top(node @ NodeRef::Internal(i)) => {
                rec.visit(tl.tlas_addr(node), FetchKind::Internal);
                hits.clear();
                hit_children(ray, tl.tlas.node_children(i), tmax, order, &mut hits);
                next = choose(&mut hits, order, |child| {
                    rec.push(tl.tlas_addr(child));
                    stack.push(Entry::Top(child));
                })
                .map(Entry::Top);
            }
            Entry::Top(node @ NodeRef::Leaf(j)) => {
                rec.visit(tl.tlas_addr(node), FetchKind::Instance);
                let instance = tl.leaf_instance(j);
                let mesh = tl.instances[instance as usize].mesh;
                rec.visit(tl.header_addr(Some(mesh)), FetchKind::BvhHeader);
                let obj_ray = match &tl.to_object[instance as usize] {
                    Some(m) => {
                        Ray::new(m.transform_point3a(ray.origin), m.transform_vector3a(ray.dir), ray.tmin)
                    }
                    None => *ray,
                };
                let c = Current { instance, blas: &tl.blas[mesh as usize], ray: obj_ray };
                // The BLAS root goes through the stack (pushed, then popped next).
                let root = Entry::Bottom(NodeRef::Internal(0));
                rec.push(c.blas.node_addr(NodeRef::Internal(0)));
                stack.push(root);
                cur = Some(c);
            }
            Entry::Bottom(node @ NodeRef::Internal(i)) => {
                let c = cur.as_ref().expect("a BLAS entry has its instance");
                rec.visit(c.blas.node_addr(node), FetchKind::Internal);
                hits.clear();
                hit_children(&c.ray, c.blas.bvh.node_children(i), tmax, order, &mut hits);
                next = choose(&mut hits, order, |child| {
                    rec.push(c.blas.node_addr(child));
                    stack.push(Entry::Bottom(child));
                })
                .map(Entry::Bottom);
            }
            Entry::Bottom(node @ NodeRef::Leaf(j)) => {
                let c = cur.as_ref().expect("a BLAS entry has its instance");
                rec.visit(c.blas.node_addr(node), FetchKind::Leaf);
                let b = c.blas;
                for slot in b.bvh.leaves[j as usize].clone() {
                    let local = b.bvh.prim_indices[slot as usize];
                    let (prim, t) = match &b.geometry {
                        MeshGeometry::World(r) => {
                            rec.visit(b.prim_addr(slot), prims.kind());
                            let prim = r.start + local;
                            (prim, prims.hit(prim as usize, &c.ray, tmax))
                        }
                        MeshGeometry::Local(r) => {
                            rec.visit(b.prim_addr(slot), FetchKind::Triangle);
                            let prim = r.start + local;
                            (prim, hit_triangle(&c.ray, &tl.local[prim as usize], tmax))
                        }
                    };
                    if t < tmax {
                        tmax = t;
                        best = Some(Hit { prim, t, instance: Some(c.instance) });
                    }
                }
            }
        }
    }
    best
}

/// An unbounded stack of CWBVH node groups that reports its pushes and pops.
struct RecordingStack<'r, R> {
    entries: Vec<UVec2>,
    rec: &'r mut R,
}

fn group_addr(group: UVec2) -> u64 {
    INTERNAL_BASE + group.x as u64 * CWBVH_NODE_SIZE
}

impl<R: Recorder> FastStack<UVec2> for RecordingStack<'_, R> {
    fn push(&mut self, v: UVec2) {
        self.rec.push(group_addr(v));
        self.entries.push(v);
    }
    fn pop_fast(&mut self) -> UVec2 {
        self.pop().unwrap_or_default()
    }
    fn pop(&mut self) -> Option<UVec2> {
        let v = self.entries.pop()?;
        self.rec.pop(group_addr(v));
        Some(v)
    }
    fn len(&self) -> usize {
        self.entries.len()
    }
    fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
    fn clear(&mut self) {
        self.entries.clear();
    }
}

/// The state `obvhs::traverse!` expects.
struct CwState<'r, R> {
    stack: RecordingStack<'r, R>,
    current_group: UVec2,
    primitive_group: UVec2,
    oct_inv4: u32,
    hitmask: u32,
    primitive_id: u32,
}

fn trace_cwbvh<R: Recorder>(cw: &CwBvh, q: Query, rec: &mut R) -> Option<Hit> {
    let Query { prims, ray, tmax, .. } = q;
    let mut oray = ray.to_obvhs(tmax);
    let seed = cw.new_traversal(oray.direction);
    let mut state = CwState {
        stack: RecordingStack { entries: Vec::new(), rec },
        current_group: seed.current_group,
        primitive_group: seed.primitive_group,
        oct_inv4: seed.oct_inv4,
        hitmask: 0,
        primitive_id: 0,
    };
    let mut best = None;
    let mut node;
    traverse!(
        cw,
        node,
        state,
        {
            // The macro hands us the node, not its index: recover it from the node's position.
            let index = (std::ptr::from_ref(node) as usize - cw.nodes.as_ptr() as usize)
                / std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>();
            state.stack.rec.visit(INTERNAL_BASE + index as u64 * CWBVH_NODE_SIZE, FetchKind::Internal);
            node.intersect_ray(&oray, state.oct_inv4)
        },
        {
            let slot = state.primitive_id;
            state.stack.rec.visit(Bvh::prim_addr(slot), prims.kind());
            let prim = cw.primitive_indices[slot as usize];
            let t = prims.hit(prim as usize, ray, oray.tmax);
            if t < oray.tmax {
                oray.tmax = t;
                best = Some(Hit { prim, t, instance: None });
            }
        }
    );
    best
}

#[cfg(test)]
mod tests {
    use glam::Vec3A;
    use obvhs::ray::RayHit;

    use super::*;
    use crate::workload::bvh::BvhKind;
    use crate::workload::raygen::RayGen;
    use crate::workload::rng::Rng;
    use crate::workload::scene::{load_scene, Scene};

    /// Camera rays over a 16x16 image plus rays from random points in the scene's box in random
    /// directions (these start inside the geometry, like bounce rays).
    fn sample_rays(scene: &Scene) -> Vec<Ray> {
        let bounds = scene.primitives.bounds();
        let raygen = RayGen::new(&scene.camera, 16, 16, 3, bounds.diagonal().length());
        let mut rays: Vec<Ray> = (0..256).map(|p| raygen.primary(p, 0)).collect();
        for i in 0..256 {
            let mut rng = Rng::new(&[99, i]);
            let mut unit = || Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let origin = bounds.min + unit() * bounds.diagonal();
            let dir = (unit() * 2.0 - Vec3A::ONE).normalize_or(Vec3A::X);
            rays.push(Ray::new(origin, dir, 0.0));
        }
        // Axis-parallel directions, including negative zeros, through the middle of the scene.
        let center = bounds.center();
        for dir in [Vec3A::new(-0.0, -1.0, 0.0), Vec3A::new(0.0, 0.0, -1.0), Vec3A::new(1.0, -0.0, -0.0)] {
            rays.push(Ray::new(center - dir * bounds.diagonal().length(), dir, 0.0));
        }
        rays
    }

    /// Same distance; the primitive may differ only on an exact tie.
    fn assert_same(what: &str, got: Option<Hit>, want: Option<(usize, f32)>) {
        match (got, want) {
            (None, None) => {}
            (Some(h), Some((p, t))) => {
                assert!(h.t == t, "{what}: hit {h:?}, brute force ({p}, {t})")
            }
            _ => panic!("{what}: hit {got:?}, brute force {want:?}"),
        }
    }

    fn check_closest_hits(name: &str) {
        let Some(scene) = crate::prereq::scene(name) else { return };
        let prims = &scene.primitives;
        let rays = sample_rays(&scene);
        let oracle: Vec<_> = rays.iter().map(|r| prims.brute_force_hit(r, f32::INFINITY)).collect();
        assert!(oracle.iter().filter(|h| h.is_some()).count() > rays.len() / 10, "{name}: rays should hit");
        for kind in [BvhKind::Bvh2, BvhKind::Bvh6, BvhKind::Cwbvh] {
            let bvh = Bvh::build(prims, kind).expect("bvh");
            for order in [ChildOrder::Nearest, ChildOrder::VulkanSim] {
                for (i, (ray, want)) in rays.iter().zip(&oracle).enumerate() {
                    let got = trace(&bvh, prims, ray, f32::INFINITY, order, &mut ());
                    assert_same(&format!("{name} {kind:?} {order:?} ray {i}"), got, *want);
                }
            }
            // obvhs's own traversal of the same hierarchy, with the same primitive test.
            for (i, (ray, want)) in rays.iter().zip(&oracle).enumerate() {
                let mut hit = RayHit::none();
                let oray = ray.to_obvhs(f32::INFINITY);
                let (found, indices) = match &bvh {
                    Bvh::Bvh2(b) => {
                        let test = |r: &obvhs::ray::Ray, slot: usize| {
                            prims.hit(b.primitive_indices[slot] as usize, ray, r.tmax)
                        };
                        (b.ray_traverse(oray, &mut hit, test), &b.primitive_indices)
                    }
                    Bvh::Cwbvh(b) => {
                        let test = |r: &obvhs::ray::Ray, slot: usize| {
                            prims.hit(b.primitive_indices[slot] as usize, ray, r.tmax)
                        };
                        (b.ray_traverse(oray, &mut hit, test), &b.primitive_indices)
                    }
                    Bvh::Bvh6(_) | Bvh::TwoLevel(_) => continue,
                };
                let got =
                    found.then(|| Hit { prim: indices[hit.primitive_id as usize], t: hit.t, instance: None });
                assert_same(&format!("{name} obvhs {kind:?} ray {i}"), got, *want);
            }
        }
    }

    #[test]
    fn closest_hits_match_brute_force_and_obvhs_wknd() {
        check_closest_hits("wknd");
    }

    #[test]
    fn closest_hits_match_brute_force_and_obvhs_grid() {
        check_closest_hits("grid");
    }

    #[test]
    fn closest_hits_match_brute_force_and_obvhs_clutter() {
        check_closest_hits("clutter");
    }

    #[test]
    fn closest_hits_match_brute_force_and_obvhs_ship() {
        check_closest_hits("ship");
    }

    #[test]
    fn child_orders_differ_but_find_the_same_hits() {
        let scene = load_scene("clutter").expect("clutter");
        let bvh = Bvh::build(&scene.primitives, BvhKind::Bvh6).expect("bvh");
        let mut differing = 0;
        for ray in sample_rays(&scene) {
            let (mut a, mut b) =
                (crate::workload::trace::RayTrace::default(), crate::workload::trace::RayTrace::default());
            let ha = trace(&bvh, &scene.primitives, &ray, f32::INFINITY, ChildOrder::Nearest, &mut a);
            let hb = trace(&bvh, &scene.primitives, &ray, f32::INFINITY, ChildOrder::VulkanSim, &mut b);
            assert_eq!(ha.map(|h| h.t), hb.map(|h| h.t));
            differing += usize::from(a != b);
        }
        assert!(differing > 0);
    }

    /// A hand-built BVH6 and the sequence Vulkan-Sim's rule gives on it, written out from the rule
    /// (not from our walk). Triangles lie in planes z = const, the ray runs along +z from the
    /// origin, so a box's entry distance is its nearest z.
    ///
    /// ```text
    /// N0: [L0 z5, N1, L1 (missed), N2]      N1: [L2 z3, L3 z4]
    /// N2: [N3, L4 z2]                       N3: [L5 z1, L6 (missed)]
    /// ```
    #[test]
    fn vulkansim_order_is_vulkan_sims_rule_on_a_hand_built_bvh() {
        use crate::workload::bvh::{
            Bvh6, Bvh6Child, Bvh6Node, BVH6_LEAF_DESC_SIZE, BVH6_NODE_SIZE, LEAF_BASE, PRIM_BASE,
        };
        use crate::workload::trace::{RayTrace, TraceOp};
        use obvhs::triangle::Triangle;
        let tri = |x: f32, z: f32| Triangle {
            v0: Vec3A::new(x - 1.0, -1.0, z),
            v1: Vec3A::new(x + 3.0, -1.0, z),
            v2: Vec3A::new(x - 1.0, 3.0, z),
        };
        // Leaf j holds triangle j.
        let tris = vec![
            tri(0.0, 5.0),
            tri(10.0, 5.0),
            tri(0.0, 3.0),
            tri(0.0, 4.0),
            tri(0.0, 2.0),
            tri(0.0, 1.0),
            tri(10.0, 1.0),
        ];
        let leaf = |j: u32| Bvh6Child { aabb: tris[j as usize].aabb(), node: NodeRef::Leaf(j) };
        let union = |cs: &[Bvh6Child]| cs.iter().fold(obvhs::aabb::Aabb::empty(), |b, c| b.union(&c.aabb));
        let n3 = [leaf(5), leaf(6)];
        let n2 = [Bvh6Child { aabb: union(&n3), node: NodeRef::Internal(3) }, leaf(4)];
        let n1 = [leaf(2), leaf(3)];
        let n0 = [
            leaf(0),
            Bvh6Child { aabb: union(&n1), node: NodeRef::Internal(1) },
            leaf(1),
            Bvh6Child { aabb: union(&n2), node: NodeRef::Internal(2) },
        ];
        let bvh = Bvh::Bvh6(Bvh6 {
            nodes: vec![
                Bvh6Node { first: 0, count: 4 },
                Bvh6Node { first: 4, count: 2 },
                Bvh6Node { first: 6, count: 2 },
                Bvh6Node { first: 8, count: 2 },
            ],
            children: [&n0[..], &n1, &n2, &n3].concat(),
            leaves: (0..7).map(|j| j..j + 1).collect(),
            prim_indices: (0..7).collect(),
        });
        let prims = Primitives::Triangles(tris);
        let ray = Ray::new(Vec3A::ZERO, Vec3A::Z, 0.0);
        let n = |i: u64| INTERNAL_BASE + i * BVH6_NODE_SIZE;
        let l = |j: u64| LEAF_BASE + j * BVH6_LEAF_DESC_SIZE;
        let visit_n = |i| TraceOp::Visit { addr: n(i), kind: FetchKind::Internal };
        let visit_leaf = |j: u64| {
            [
                TraceOp::Visit { addr: l(j), kind: FetchKind::Leaf },
                TraceOp::Visit { addr: PRIM_BASE + j * 64, kind: FetchKind::Triangle },
            ]
        };
        use TraceOp::{Pop, Push};
        // N0: L0 hit (leaf: pushed), N1 first internal (descended), L1 missed, N2 pushed.
        let mut want = vec![visit_n(0), Push(l(0)), Push(n(2)), visit_n(1)];
        // N1: two leaves, both pushed; no internal child, so leaves pop LIFO: L3 (z4) then L2 (z3).
        want.extend([Push(l(2)), Push(l(3)), Pop(l(3))]);
        want.extend(visit_leaf(3));
        want.push(Pop(l(2)));
        want.extend(visit_leaf(2));
        // N2 (entered at z1 < 3): N3 descended, L4 (z2 < 3) pushed.
        want.extend([Pop(n(2)), visit_n(2), Push(l(4)), visit_n(3)]);
        // N3: L5 pushed, L6 missed; L5 popped (hit at z1); then L4 and L0, fetched although
        // farther than the hit (popped entries are not culled).
        want.extend([Push(l(5)), Pop(l(5))]);
        want.extend(visit_leaf(5));
        want.push(Pop(l(4)));
        want.extend(visit_leaf(4));
        want.push(Pop(l(0)));
        want.extend(visit_leaf(0));

        let mut rec = RayTrace::default();
        let hit = trace(&bvh, &prims, &ray, f32::INFINITY, ChildOrder::VulkanSim, &mut rec);
        assert_eq!(hit, Some(Hit { prim: 5, t: 1.0, instance: None }));
        assert_eq!(rec.ops().collect::<Vec<_>>(), want);
        rec.check_stack_history().expect("valid history");

        // Nearest-first descends N2 (z1) first, pushing L0 and N1 far to near; in N2 it descends
        // N3 and pushes L4; in N3 it descends L5 without a push. After the hit at z1, N1's
        // leaves are culled.
        let mut near = RayTrace::default();
        let hit = trace(&bvh, &prims, &ray, f32::INFINITY, ChildOrder::Nearest, &mut near);
        assert_eq!(hit.map(|h| h.t), Some(1.0));
        assert_eq!(near.ops().nth(1), Some(TraceOp::Push(l(0))));
        let pushes: Vec<_> = near.ops().filter(|o| matches!(o, Push(_))).collect();
        assert_eq!(pushes, [Push(l(0)), Push(n(1)), Push(l(4))]);
    }

    /// Closest hit of `ray` over the instances of `scene` by testing every primitive of every
    /// instance in its object space: the oracle for the two-level walk (same arithmetic).
    fn instance_brute_force(scene: &Scene, tl: &crate::workload::bvh::TwoLevel, ray: &Ray) -> Option<f32> {
        let mut best = f32::INFINITY;
        for (k, inst) in scene.objects.instances.iter().enumerate() {
            let r = match &tl.to_object[k] {
                Some(m) => Ray::new(m.transform_point3a(ray.origin), m.transform_vector3a(ray.dir), ray.tmin),
                None => *ray,
            };
            match &scene.objects.meshes[inst.mesh as usize] {
                MeshGeometry::World(range) => {
                    range.clone().for_each(|p| best = best.min(scene.primitives.hit(p as usize, &r, best)))
                }
                MeshGeometry::Local(range) => range
                    .clone()
                    .for_each(|p| best = best.min(hit_triangle(&r, &scene.objects.local[p as usize], best))),
            }
        }
        best.is_finite().then_some(best)
    }

    /// Two-level closest hits equal the instance oracle exactly and the flat BVH6's within float
    /// rounding of the instance transforms (exactly when every instance is the identity).
    fn check_two_level(name: &str) {
        let Some(scene) = crate::prereq::scene(name) else { return };
        let tl = crate::workload::bvh::TwoLevel::build(&scene.primitives, &scene.objects).expect("two-level");
        let two = Bvh::TwoLevel(Box::new(tl.clone()));
        let flat = Bvh::build(&scene.primitives, BvhKind::Bvh6).expect("flat");
        let identity = scene.objects.instances.iter().all(|i| i.to_world.is_none());
        let rays = sample_rays(&scene);
        let (mut hits, mut off) = (0, 0);
        for (i, ray) in rays.iter().enumerate() {
            let want = instance_brute_force(&scene, &tl, ray);
            let f = trace(&flat, &scene.primitives, ray, f32::INFINITY, ChildOrder::Nearest, &mut ())
                .map(|h| h.t);
            for order in [ChildOrder::Nearest, ChildOrder::VulkanSim] {
                let mut rec = crate::workload::trace::RayTrace::default();
                let got = trace(&two, &scene.primitives, ray, f32::INFINITY, order, &mut rec);
                rec.check_stack_history().unwrap_or_else(|e| panic!("{name} ray {i}: {e}"));
                assert_eq!(
                    got.map(|h| h.t),
                    want,
                    "{name} {order:?} ray {i}: two-level vs instance brute force"
                );
                if identity {
                    assert_eq!(got.map(|h| h.t), f, "{name} {order:?} ray {i}: two-level vs flat");
                } else {
                    let close = match (got, f) {
                        (Some(a), Some(b)) => (a.t - b).abs() <= 1e-4 * b.abs().max(1.0),
                        (a, b) => a.is_none() && b.is_none(),
                    };
                    off += usize::from(!close);
                }
            }
            hits += usize::from(want.is_some());
        }
        assert!(hits > rays.len() / 10, "{name}: rays should hit");
        // Transformed rays may graze a silhouette differently from the world-space triangles.
        assert!(off * 100 <= rays.len(), "{name}: {off} of {} rays disagree with the flat BVH", rays.len());
    }

    #[test]
    fn two_level_closest_hits_match_brute_force_builtin() {
        for name in ["wknd", "clutter"] {
            check_two_level(name);
        }
    }

    #[test]
    fn two_level_closest_hits_match_brute_force_obj_objects() {
        // 46 `o` objects, identity instances: exactly the flat BVH's hits.
        check_two_level("bath-partial");
    }

    #[test]
    fn two_level_closest_hits_match_brute_force_gltf_instances() {
        // 29 meshes placed by 67 nodes with their transforms.
        let Some(scene) = crate::prereq::scene("2cylinderengine") else { return };
        assert_eq!(scene.objects.instances.len(), 67);
        assert_eq!(scene.objects.meshes.len(), 29);
        check_two_level("2cylinderengine");
    }

    #[test]
    fn two_level_walk_enters_each_blas_through_its_header_and_the_stack() {
        use crate::workload::trace::{RayTrace, TraceOp};
        let Some(scene) = crate::prereq::scene("bath-partial") else { return };
        let tl = crate::workload::bvh::TwoLevel::build(&scene.primitives, &scene.objects).expect("two-level");
        let header = tl.header_addr(None);
        let two = Bvh::TwoLevel(Box::new(tl));
        let mut instances = 0;
        for ray in sample_rays(&scene) {
            let mut rec = RayTrace::default();
            trace(&two, &scene.primitives, &ray, f32::INFINITY, ChildOrder::VulkanSim, &mut rec);
            let ops: Vec<TraceOp> = rec.ops().collect();
            assert_eq!(ops[0], TraceOp::Visit { addr: header, kind: FetchKind::BvhHeader });
            if ops.len() > 1 {
                // World box hit: the TLAS root is pushed and popped before its visit.
                assert_eq!(
                    ops[1..4],
                    [
                        TraceOp::Push(INTERNAL_BASE),
                        TraceOp::Pop(INTERNAL_BASE),
                        TraceOp::Visit { addr: INTERNAL_BASE, kind: FetchKind::Internal }
                    ]
                );
            }
            for (k, w) in ops.windows(5).enumerate() {
                if let TraceOp::Visit { kind: FetchKind::Instance, addr } = w[0] {
                    instances += 1;
                    // Every instance leaf was pushed (vulkansim pushes leaves) and popped just before.
                    assert_eq!(ops[k - 1], TraceOp::Pop(addr));
                    assert!(matches!(w[1], TraceOp::Visit { kind: FetchKind::BvhHeader, .. }));
                    let TraceOp::Push(root) = w[2] else { panic!("BLAS root not pushed: {w:?}") };
                    assert_eq!(w[3], TraceOp::Pop(root));
                    assert_eq!(w[4], TraceOp::Visit { addr: root, kind: FetchKind::Internal });
                }
            }
        }
        assert!(instances > 100, "{instances} instance leaves visited");
    }

    #[test]
    fn slab_test_handles_zero_directions_without_nan() {
        let aabb = obvhs::aabb::Aabb::new(Vec3A::ZERO, Vec3A::ONE);
        let on_face = Ray::new(Vec3A::new(0.0, 0.5, -1.0), Vec3A::new(-0.0, 0.0, 1.0), 0.0);
        assert_eq!(on_face.hit_box(&aabb, f32::INFINITY), Some(1.0));
        let outside = Ray::new(Vec3A::new(2.0, 0.5, -1.0), Vec3A::new(0.0, -0.0, 1.0), 0.0);
        assert_eq!(outside.hit_box(&aabb, f32::INFINITY), None);
        let on_plane = Ray::new(Vec3A::new(0.0, 0.0, -1.0), Vec3A::new(0.0, 0.0, 1.0), 0.0);
        assert_eq!(on_plane.hit_box(&aabb, f32::INFINITY), Some(1.0));
        assert_eq!(on_plane.hit_box(&aabb, 0.5), None);
    }

    #[test]
    fn triangle_test_is_watertight_on_a_shared_edge() {
        let (a, b) = (Vec3A::new(0.0, 0.0, 0.0), Vec3A::new(1.0, 1.0, 0.0));
        let t1 = obvhs::triangle::Triangle { v0: a, v1: Vec3A::new(1.0, 0.0, 0.0), v2: b };
        let t2 = obvhs::triangle::Triangle { v0: a, v1: b, v2: Vec3A::new(0.0, 1.0, 0.0) };
        for i in 0..1000 {
            let s = i as f32 / 1000.0;
            let ray = Ray::new(Vec3A::new(s, s, 1.0), Vec3A::new(0.0, 0.0, -1.0), 0.0);
            let hits = [&t1, &t2]
                .iter()
                .filter(|t| crate::workload::geometry::hit_triangle(&ray, t, f32::INFINITY).is_finite())
                .count();
            assert!(hits >= 1, "ray through the shared edge at {s} fell through");
        }
    }
}
