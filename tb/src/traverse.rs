//! Closest-hit traversal that reports every node fetch, push and pop in RT-unit order.
//!
//! BVH2 and BVH6 are walked by our own loop so the child order is ours to choose
//! ([`ChildOrder`]): at an internal node all children's boxes are tested against the current
//! closest hit, one hit child is descended into, the others are pushed; a leaf visits its
//! primitives; when a node leaves nothing to descend into, the next address is popped. A popped
//! node is always fetched (entries carry no distance to cull by), as in Vulkan-Sim.
//!
//! CWBVH is walked by obvhs's own `traverse!` loop (octant-ordered, Ylitie et al. 2017) with a
//! recording, unbounded stack: its entries are node *groups* (a child base index plus a hit mask),
//! recorded by the address of the group's first child node, and `ChildOrder` does not apply.

use glam::UVec2;
use obvhs::{cwbvh::CwBvh, faststack::FastStack, traverse};

use crate::bvh::{Bvh, NodeRef, CWBVH_NODE_SIZE, INTERNAL_BASE};
use crate::geometry::{Primitives, Ray};
use crate::workload::{ChildOrder, NodeKind};

/// Receives the operations of one traversal. `()` ignores them (for rendering only).
pub trait Recorder {
    /// The ray about to be traversed.
    fn ray(&mut self, _ray: &Ray) {}
    fn visit(&mut self, addr: u64, kind: NodeKind);
    fn push(&mut self, addr: u64);
    fn pop(&mut self, addr: u64);
}

impl Recorder for () {
    fn visit(&mut self, _: u64, _: NodeKind) {}
    fn push(&mut self, _: u64) {}
    fn pop(&mut self, _: u64) {}
}

/// A closest hit: the scene's primitive index and the distance along the ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub prim: u32,
    pub t: f32,
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
    match bvh {
        Bvh::Cwbvh(cw) => trace_cwbvh(cw, prims, ray, tmax, rec),
        _ => trace_tree(bvh, prims, ray, tmax, order, rec),
    }
}

/// The children of an internal BVH2/BVH6 node, with their boxes, in index order.
fn for_each_child(bvh: &Bvh, node: u32, mut f: impl FnMut(&obvhs::aabb::Aabb, NodeRef)) {
    match bvh {
        Bvh::Bvh2(b) => {
            let first = b.nodes[node as usize].first_index;
            for c in [first, first + 1] {
                let child = &b.nodes[c as usize];
                f(child.aabb(), if child.is_leaf() { NodeRef::Leaf(c) } else { NodeRef::Internal(c) });
            }
        }
        Bvh::Bvh6(b) => b.node_children(node).iter().for_each(|c| f(&c.aabb, c.node)),
        Bvh::Cwbvh(_) => unreachable!("CWBVH is traversed by trace_cwbvh"),
    }
}

/// Primitive slots of a leaf and the scene primitive in each.
fn leaf_prims(bvh: &Bvh, leaf: u32) -> impl Iterator<Item = (u32, u32)> + '_ {
    let (range, indices) = match bvh {
        Bvh::Bvh2(b) => {
            let n = &b.nodes[leaf as usize];
            (n.first_index..n.first_index + n.prim_count, &b.primitive_indices)
        }
        Bvh::Bvh6(b) => (b.leaves[leaf as usize].clone(), &b.prim_indices),
        Bvh::Cwbvh(_) => unreachable!("CWBVH is traversed by trace_cwbvh"),
    };
    range.map(move |slot| (slot, indices[slot as usize]))
}

fn trace_tree<R: Recorder>(
    bvh: &Bvh,
    prims: &Primitives,
    ray: &Ray,
    mut tmax: f32,
    order: ChildOrder,
    rec: &mut R,
) -> Option<Hit> {
    let root = match bvh {
        Bvh::Bvh2(b) if b.nodes[0].is_leaf() => NodeRef::Leaf(0),
        _ => NodeRef::Internal(0),
    };
    let mut best = None;
    let mut stack: Vec<NodeRef> = Vec::new();
    let mut hits: Vec<(f32, NodeRef)> = Vec::with_capacity(crate::bvh::BVH6_WIDTH);
    let mut current = Some(root);
    while let Some(node) = current {
        match node {
            NodeRef::Internal(i) => {
                rec.visit(bvh.node_addr(node), NodeKind::Internal);
                hits.clear();
                for_each_child(bvh, i, |aabb, child| {
                    if let Some(t) = ray.hit_box(aabb, tmax) {
                        hits.push((t, child));
                    }
                });
                if order == ChildOrder::Nearest {
                    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
                }
                current = hits.first().map(|h| h.1);
                let mut push = |child: NodeRef| {
                    rec.push(bvh.node_addr(child));
                    stack.push(child);
                };
                match order {
                    // Far to near, so the nearest remaining child is on top.
                    ChildOrder::Nearest => hits.iter().skip(1).rev().for_each(|h| push(h.1)),
                    ChildOrder::VulkanSim => hits.iter().skip(1).for_each(|h| push(h.1)),
                }
            }
            NodeRef::Leaf(j) => {
                rec.visit(bvh.node_addr(node), NodeKind::Leaf);
                for (slot, prim) in leaf_prims(bvh, j) {
                    rec.visit(Bvh::prim_addr(slot), prims.kind());
                    let t = prims.hit(prim as usize, ray, tmax);
                    if t < tmax {
                        tmax = t;
                        best = Some(Hit { prim, t });
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

fn trace_cwbvh<R: Recorder>(
    cw: &CwBvh,
    prims: &Primitives,
    ray: &Ray,
    tmax: f32,
    rec: &mut R,
) -> Option<Hit> {
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
            state.stack.rec.visit(INTERNAL_BASE + index as u64 * CWBVH_NODE_SIZE, NodeKind::Internal);
            node.intersect_ray(&oray, state.oct_inv4)
        },
        {
            let slot = state.primitive_id;
            state.stack.rec.visit(Bvh::prim_addr(slot), prims.kind());
            let prim = cw.primitive_indices[slot as usize];
            let t = prims.hit(prim as usize, ray, oray.tmax);
            if t < oray.tmax {
                oray.tmax = t;
                best = Some(Hit { prim, t });
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
    use crate::bvh::BvhKind;
    use crate::raygen::RayGen;
    use crate::rng::Rng;
    use crate::scene::{load_scene, Scene};

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
        let scene = load_scene(name).expect(name);
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
                    Bvh::Bvh6(_) => continue,
                };
                let got = found.then(|| Hit { prim: indices[hit.primitive_id as usize], t: hit.t });
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
            let (mut a, mut b) = (crate::workload::RayTrace::default(), crate::workload::RayTrace::default());
            let ha = trace(&bvh, &scene.primitives, &ray, f32::INFINITY, ChildOrder::Nearest, &mut a);
            let hb = trace(&bvh, &scene.primitives, &ray, f32::INFINITY, ChildOrder::VulkanSim, &mut b);
            assert_eq!(ha.map(|h| h.t), hb.map(|h| h.t));
            differing += usize::from(a != b);
        }
        assert!(differing > 0);
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
                .filter(|t| crate::geometry::hit_triangle(&ray, t, f32::INFINITY).is_finite())
                .count();
            assert!(hits >= 1, "ray through the shared edge at {s} fell through");
        }
    }
}
