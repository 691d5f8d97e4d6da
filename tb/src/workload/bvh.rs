//! The three hierarchies the traversal model walks, each with simulated device addresses.
//!
//! * BVH2: obvhs's binary BVH (one primitive per leaf), nodes 48 bytes as obvhs stores them.
//! * CWBVH: obvhs's compressed 8-wide BVH (80-byte nodes, primitives referenced from nodes).
//! * BVH6: the layout Vulkan-Sim's RT unit walks (SPEC section 7): 64-byte internal nodes with up
//!   to 6 children stored contiguously, one primitive per 64-byte leaf plus an 8-byte leaf
//!   descriptor. It is collapsed from the BVH2 greedily: a node's child list starts as its two
//!   BVH2 children and the internal child with the largest surface area is opened (replaced by its
//!   own two children) until there are 6 children or only leaves remain. Child boxes are stored
//!   exactly rather than quantized, so hits do not depend on a quantization scheme.
//!
//! Addresses: every node fetch in a trace is a byte address `region base + index * size`, with
//! internal nodes, leaves (BVH2 leaf nodes, BVH6 leaf descriptors) and primitive blocks in
//! separate 16 GiB regions, so addresses are unique across kinds and aligned to their size.
//!
//! Two-level ([`TwoLevel`], `--accel two-level`): a TLAS (a BVH6 over the instances' world
//! boxes, one instance per leaf) over one BLAS per mesh (a BVH6 over the mesh's primitives in its
//! own space, built once however many instances share it), as the Vulkan pipeline builds them.
//! Sizes are Vulkan-Sim's (`src/cuda-sim/vulkan_acceleration_structure_util.h`, lengths in
//! dwords): `GEN_RT_BVH_length` 16 (a 64-byte acceleration-structure header, line 76),
//! `GEN_RT_BVH_INTERNAL_NODE_length` 16 (64 B, line 96), `GEN_RT_BVH_INSTANCE_LEAF_length` 32
//! (128 B, line 213). Layout: the TLAS's internal nodes first in the internal region, then each
//! BLAS's in mesh order; BLAS leaf descriptors and primitive blocks likewise concatenated in their
//! regions; instance leaves (128 B each, in TLAS leaf order) and headers (the TLAS's, then one
//! per BLAS) in two more regions. Instances of one mesh share its BLAS's addresses, so the caches
//! see the sharing. A transformed instance's world box is the box of its BLAS's transformed
//! corners, widened by a relative 1e-5 so rounding in the transform never loses a hit.

use std::collections::VecDeque;
use std::ops::Range;
use std::time::Duration;

use obvhs::{
    aabb::Aabb,
    bvh2::{builder::build_bvh2, Bvh2},
    cwbvh::{builder::build_cwbvh, CwBvh},
    BvhBuildParams,
};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::workload::geometry::Primitives;
use crate::workload::scene::{Instance, MeshGeometry, Objects};
use crate::workload::trace::FetchKind;

/// Start of the internal-node region.
pub const INTERNAL_BASE: u64 = 0x4_0000_0000;
/// Start of the leaf region (BVH2 leaf nodes, BVH6 leaf descriptors).
pub const LEAF_BASE: u64 = 0x8_0000_0000;
/// Start of the primitive region: one 64-byte block per primitive reference.
pub const PRIM_BASE: u64 = 0xC_0000_0000;
/// Bytes per primitive block (a triangle, or a procedural primitive's record).
pub const PRIM_SIZE: u64 = 64;
pub const BVH2_NODE_SIZE: u64 = 48;
pub const CWBVH_NODE_SIZE: u64 = 80;
pub const BVH6_NODE_SIZE: u64 = 64;
pub const BVH6_LEAF_DESC_SIZE: u64 = 8;
/// Start of the instance-leaf region (two-level).
pub const INSTANCE_BASE: u64 = 0x10_0000_0000;
/// Start of the acceleration-structure header region (two-level).
pub const HEADER_BASE: u64 = 0x14_0000_0000;
/// `GEN_RT_BVH_INSTANCE_LEAF_length` 32 dwords.
pub const INSTANCE_LEAF_SIZE: u64 = 128;
/// `GEN_RT_BVH_length` 16 dwords.
pub const BVH_HEADER_SIZE: u64 = 64;
/// Most children a BVH6 node holds.
pub const BVH6_WIDTH: usize = 6;

/// Which hierarchy to build and traverse.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum BvhKind {
    Bvh2,
    Cwbvh,
    Bvh6,
}

/// Bytes the RT unit fetches for a node of `kind` in hierarchy `bvh` (SPEC section 7 layouts).
pub fn node_bytes(bvh: BvhKind, kind: FetchKind) -> u32 {
    let bytes = match (kind, bvh) {
        (FetchKind::Internal, BvhKind::Bvh2) | (FetchKind::Leaf, BvhKind::Bvh2) => BVH2_NODE_SIZE,
        (FetchKind::Internal, BvhKind::Bvh6) => BVH6_NODE_SIZE,
        (FetchKind::Leaf, _) => BVH6_LEAF_DESC_SIZE,
        (FetchKind::Internal, BvhKind::Cwbvh) => CWBVH_NODE_SIZE,
        (FetchKind::Triangle | FetchKind::Procedural, _) => PRIM_SIZE,
        (FetchKind::Instance, _) => INSTANCE_LEAF_SIZE,
        (FetchKind::BvhHeader, _) => BVH_HEADER_SIZE,
    };
    bytes as u32
}

/// A reference to a node of a BVH2 or BVH6: internal nodes and leaves are numbered separately.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NodeRef {
    Internal(u32),
    Leaf(u32),
}

/// One child slot of a BVH6 node.
#[derive(Clone, Copy, Debug)]
pub struct Bvh6Child {
    pub aabb: Aabb,
    pub node: NodeRef,
}

/// A BVH6 internal node: `children[first..first + count]` of [`Bvh6::children`].
#[derive(Clone, Copy, Debug)]
pub struct Bvh6Node {
    pub first: u32,
    pub count: u32,
}

/// A 6-wide BVH in Vulkan-Sim's layout.
#[derive(Clone, Debug)]
pub struct Bvh6 {
    pub nodes: Vec<Bvh6Node>,
    pub children: Vec<Bvh6Child>,
    /// Leaf `j` covers primitive slots `leaves[j]`.
    pub leaves: Vec<Range<u32>>,
    /// Primitive slot to scene primitive index.
    pub prim_indices: Vec<u32>,
}

impl Bvh6 {
    /// Greedy collapse of a BVH2 (see the module docs). Nodes are laid out breadth-first, so
    /// the internal children of a node, and its leaf children, have consecutive indices.
    pub fn from_bvh2(bvh2: &Bvh2) -> Self {
        let mut out = Bvh6 {
            nodes: vec![Bvh6Node { first: 0, count: 0 }],
            children: Vec::new(),
            leaves: Vec::new(),
            prim_indices: Vec::new(),
        };
        let mut queue = VecDeque::from([(0u32, 0usize)]);
        let mut open: Vec<usize> = Vec::with_capacity(BVH6_WIDTH);
        while let Some((index, node2)) = queue.pop_front() {
            let n = &bvh2.nodes[node2];
            open.clear();
            if n.is_leaf() {
                open.push(node2);
            } else {
                open.extend([n.first_index as usize, n.first_index as usize + 1]);
            }
            while open.len() < BVH6_WIDTH {
                let largest = open
                    .iter()
                    .enumerate()
                    .filter(|(_, &c)| !bvh2.nodes[c].is_leaf())
                    .max_by(|a, b| {
                        let area = |i: usize| bvh2.nodes[i].aabb().half_area();
                        area(*a.1).total_cmp(&area(*b.1))
                    })
                    .map(|(slot, _)| slot);
                let Some(slot) = largest else { break };
                let first = bvh2.nodes[open[slot]].first_index as usize;
                open.splice(slot..=slot, [first, first + 1]);
            }
            out.nodes[index as usize] =
                Bvh6Node { first: out.children.len() as u32, count: open.len() as u32 };
            for &c in &open {
                let child = &bvh2.nodes[c];
                let node = if child.is_leaf() {
                    let start = out.prim_indices.len() as u32;
                    let range = child.first_index as usize..(child.first_index + child.prim_count) as usize;
                    out.prim_indices.extend_from_slice(&bvh2.primitive_indices[range]);
                    out.leaves.push(start..out.prim_indices.len() as u32);
                    NodeRef::Leaf(out.leaves.len() as u32 - 1)
                } else {
                    out.nodes.push(Bvh6Node { first: 0, count: 0 });
                    queue.push_back((out.nodes.len() as u32 - 1, c));
                    NodeRef::Internal(out.nodes.len() as u32 - 1)
                };
                out.children.push(Bvh6Child { aabb: *child.aabb(), node });
            }
        }
        out
    }

    pub fn node_children(&self, node: u32) -> &[Bvh6Child] {
        let n = self.nodes[node as usize];
        &self.children[n.first as usize..(n.first + n.count) as usize]
    }
}

/// One mesh's bottom-level BVH6 and where its nodes live.
#[derive(Clone, Debug)]
pub struct Blas {
    pub bvh: Bvh6,
    /// Where the mesh's primitives are (the BVH's primitive indices are relative to its start).
    pub geometry: MeshGeometry,
    /// Object-space bounds.
    pub bounds: Aabb,
    /// Index of this BLAS's first internal node, leaf and primitive slot in their regions.
    node_base: u64,
    leaf_base: u64,
    slot_base: u64,
}

impl Blas {
    pub fn node_addr(&self, node: NodeRef) -> u64 {
        match node {
            NodeRef::Internal(i) => INTERNAL_BASE + (self.node_base + i as u64) * BVH6_NODE_SIZE,
            NodeRef::Leaf(j) => LEAF_BASE + (self.leaf_base + j as u64) * BVH6_LEAF_DESC_SIZE,
        }
    }

    pub fn prim_addr(&self, slot: u32) -> u64 {
        PRIM_BASE + (self.slot_base + slot as u64) * PRIM_SIZE
    }
}

/// A TLAS over instances of per-mesh BLASes (see the module docs).
#[derive(Clone, Debug)]
pub struct TwoLevel {
    /// Primitive indices are instance indices.
    pub tlas: Bvh6,
    pub blas: Vec<Blas>,
    pub instances: Vec<Instance>,
    /// World-to-object transform of each instance (`None`: identity).
    pub to_object: Vec<Option<glam::Affine3A>>,
    /// The TLAS header's bounds: the union of the instances' world boxes.
    pub world: Aabb,
    /// Object-space triangles of the local meshes (a copy of [`Objects::local`]).
    pub local: Vec<obvhs::triangle::Triangle>,
}

impl TwoLevel {
    /// Builds one BLAS per mesh and the TLAS over the instances. `prims` is the scene's
    /// world-space primitive list the world meshes are slices of.
    pub fn build(prims: &Primitives, objects: &Objects) -> Result<Self> {
        if objects.instances.is_empty() {
            return Err(Error::Invalid("cannot build a TLAS over no instances".into()));
        }
        let p = params(BvhKind::Bvh6);
        let mut time = Duration::ZERO;
        let (mut node_base, mut leaf_base, mut slot_base) = (0u64, 0u64, 0u64);
        let mut blas = Vec::with_capacity(objects.meshes.len());
        for geometry in &objects.meshes {
            let r = geometry.range();
            let r = r.start as usize..r.end as usize;
            let bvh2 = match (geometry, prims) {
                (MeshGeometry::World(_), Primitives::Triangles(t)) => build_bvh2(&t[r], p, &mut time),
                (MeshGeometry::World(_), Primitives::Spheres(s)) => build_bvh2(&s[r], p, &mut time),
                (MeshGeometry::Local(_), _) => build_bvh2(&objects.local[r], p, &mut time),
            };
            let bvh = Bvh6::from_bvh2(&bvh2);
            let bounds = bvh.node_children(0).iter().fold(Aabb::empty(), |b, c| b.union(&c.aabb));
            let b = Blas { bvh, geometry: geometry.clone(), bounds, node_base, leaf_base, slot_base };
            node_base += b.bvh.nodes.len() as u64;
            leaf_base += b.bvh.leaves.len() as u64;
            slot_base += b.bvh.prim_indices.len() as u64;
            blas.push(b);
        }
        let boxes: Vec<Aabb> = objects
            .instances
            .iter()
            .map(|inst| world_box(&blas[inst.mesh as usize].bounds, inst.to_world.as_ref()))
            .collect();
        let tlas = Bvh6::from_bvh2(&build_bvh2(&boxes, p, &mut time));
        // The TLAS's internal nodes come first in the internal region.
        let tlas_nodes = tlas.nodes.len() as u64;
        blas.iter_mut().for_each(|b| b.node_base += tlas_nodes);
        let world = boxes.iter().fold(Aabb::empty(), |w, b| w.union(b));
        Ok(TwoLevel {
            tlas,
            blas,
            instances: objects.instances.clone(),
            to_object: objects.instances.iter().map(|i| i.to_world.map(|m| m.inverse())).collect(),
            world,
            local: objects.local.clone(),
        })
    }

    /// Address of a TLAS node: an internal node, or leaf `j`'s instance leaf.
    pub fn tlas_addr(&self, node: NodeRef) -> u64 {
        match node {
            NodeRef::Internal(i) => INTERNAL_BASE + i as u64 * BVH6_NODE_SIZE,
            NodeRef::Leaf(j) => INSTANCE_BASE + j as u64 * INSTANCE_LEAF_SIZE,
        }
    }

    /// Address of the TLAS's header (`None`) or BLAS `mesh`'s.
    pub fn header_addr(&self, mesh: Option<u32>) -> u64 {
        HEADER_BASE + mesh.map_or(0, |m| m as u64 + 1) * BVH_HEADER_SIZE
    }

    /// The instance in TLAS leaf `leaf`.
    pub fn leaf_instance(&self, leaf: u32) -> u32 {
        self.tlas.prim_indices[self.tlas.leaves[leaf as usize].start as usize]
    }

    /// TLAS nodes plus every BLAS's nodes.
    pub fn node_count(&self) -> usize {
        let count = |b: &Bvh6| b.nodes.len() + b.leaves.len();
        count(&self.tlas) + self.blas.iter().map(|b| count(&b.bvh)).sum::<usize>()
    }
}

/// World box of an instance: its BLAS's bounds, or the box of their transformed corners widened
/// by a relative 1e-5 (module docs).
fn world_box(bounds: &Aabb, to_world: Option<&glam::Affine3A>) -> Aabb {
    let Some(m) = to_world else { return *bounds };
    let mut b = Aabb::empty();
    for corner in 0..8 {
        let pick = |bit: usize, axis: usize| {
            if corner >> bit & 1 == 0 {
                bounds.min[axis]
            } else {
                bounds.max[axis]
            }
        };
        let p = glam::Vec3A::new(pick(0, 0), pick(1, 1), pick(2, 2));
        b = b.union(&Aabb::new(m.transform_point3a(p), m.transform_point3a(p)));
    }
    let pad = (b.max.abs().max(b.min.abs()) + b.diagonal()) * 1e-5;
    Aabb::new(b.min - pad, b.max + pad)
}

/// A built hierarchy.
#[derive(Clone)]
pub enum Bvh {
    Bvh2(Bvh2),
    Cwbvh(CwBvh),
    Bvh6(Bvh6),
    /// A TLAS over BLASes, all BVH6.
    TwoLevel(Box<TwoLevel>),
}

/// Build settings shared by all kinds: obvhs's "fast" preset (PLOC plus reinsertion); BVH2 and
/// BVH6 use one primitive per leaf, as Vulkan-Sim's BVH does.
fn params(kind: BvhKind) -> BvhBuildParams {
    let mut p = BvhBuildParams::fast_build();
    if kind != BvhKind::Cwbvh {
        p.max_prims_per_leaf = 1;
    }
    p
}

impl Bvh {
    pub fn build(prims: &Primitives, kind: BvhKind) -> Result<Self> {
        if prims.is_empty() {
            return Err(Error::Invalid("cannot build a BVH over no primitives".into()));
        }
        let mut time = Duration::ZERO;
        let p = params(kind);
        let bvh2 = |time: &mut Duration| match prims {
            Primitives::Triangles(t) => build_bvh2(t, p, time),
            Primitives::Spheres(s) => build_bvh2(s, p, time),
        };
        Ok(match kind {
            BvhKind::Bvh2 => Bvh::Bvh2(bvh2(&mut time)),
            BvhKind::Bvh6 => Bvh::Bvh6(Bvh6::from_bvh2(&bvh2(&mut time))),
            BvhKind::Cwbvh => Bvh::Cwbvh(match prims {
                Primitives::Triangles(t) => build_cwbvh(t, p, &mut time),
                Primitives::Spheres(s) => build_cwbvh(s, p, &mut time),
            }),
        })
    }

    pub fn kind(&self) -> BvhKind {
        match self {
            Bvh::Bvh2(_) => BvhKind::Bvh2,
            Bvh::Cwbvh(_) => BvhKind::Cwbvh,
            Bvh::Bvh6(_) | Bvh::TwoLevel(_) => BvhKind::Bvh6,
        }
    }

    /// Node count: all BVH2 nodes, CWBVH nodes, or BVH6 internal nodes plus leaves.
    pub fn node_count(&self) -> usize {
        match self {
            Bvh::Bvh2(b) => b.nodes.len(),
            Bvh::Cwbvh(b) => b.nodes.len(),
            Bvh::Bvh6(b) => b.nodes.len() + b.leaves.len(),
            Bvh::TwoLevel(t) => t.node_count(),
        }
    }

    /// Device address of a BVH2/BVH6 node (a BVH6 leaf's address is its descriptor's).
    pub fn node_addr(&self, node: NodeRef) -> u64 {
        let (internal, leaf) = match self {
            Bvh::Bvh2(_) => (BVH2_NODE_SIZE, BVH2_NODE_SIZE),
            Bvh::Cwbvh(_) => (CWBVH_NODE_SIZE, CWBVH_NODE_SIZE),
            Bvh::Bvh6(_) => (BVH6_NODE_SIZE, BVH6_LEAF_DESC_SIZE),
            Bvh::TwoLevel(_) => unreachable!("two-level nodes are addressed by TwoLevel"),
        };
        match node {
            NodeRef::Internal(i) => INTERNAL_BASE + i as u64 * internal,
            NodeRef::Leaf(j) => LEAF_BASE + j as u64 * leaf,
        }
    }

    /// Device address of the primitive block in slot `slot`.
    pub fn prim_addr(slot: u32) -> u64 {
        PRIM_BASE + slot as u64 * PRIM_SIZE
    }
}

#[cfg(test)]
mod tests {
    use std::collections::HashSet;

    use super::*;

    fn contains(outer: &Aabb, inner: &Aabb) -> bool {
        outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all()
    }

    #[test]
    fn bvh6_structure() {
        for name in ["wknd", "grid", "clutter", "ship"] {
            let Some(scene) = crate::prereq::scene(name) else { continue };
            let bvh = Bvh::build(&scene.primitives, BvhKind::Bvh6).expect("bvh");
            let Bvh::Bvh6(b) = &bvh else { unreachable!() };
            let (mut internal_refs, mut leaf_refs) = (vec![0; b.nodes.len()], vec![0; b.leaves.len()]);
            // Collapsing removes most BVH2 internal nodes (leaf-heavy nodes near the bottom stay narrow).
            let mean_children = b.children.len() as f64 / b.nodes.len() as f64;
            assert!(mean_children > 3.5, "{name}: {mean_children} children per node");
            for (i, node) in b.nodes.iter().enumerate() {
                let children = b.node_children(i as u32);
                assert!(
                    (2..=BVH6_WIDTH).contains(&children.len()),
                    "{name} node {i}: {} children",
                    children.len()
                );
                let internal: Vec<u32> = children
                    .iter()
                    .filter_map(|c| match c.node {
                        NodeRef::Internal(j) => Some(j),
                        _ => None,
                    })
                    .collect();
                let leaves: Vec<u32> = children
                    .iter()
                    .filter_map(|c| match c.node {
                        NodeRef::Leaf(j) => Some(j),
                        _ => None,
                    })
                    .collect();
                for run in [&internal, &leaves] {
                    assert!(
                        run.windows(2).all(|w| w[1] == w[0] + 1),
                        "{name} node {i}: children not contiguous"
                    );
                }
                internal.iter().for_each(|&j| internal_refs[j as usize] += 1);
                leaves.iter().for_each(|&j| leaf_refs[j as usize] += 1);
                for c in children {
                    let inner: Vec<Aabb> = match c.node {
                        NodeRef::Internal(j) => b.node_children(j).iter().map(|g| g.aabb).collect(),
                        NodeRef::Leaf(j) => b.leaves[j as usize]
                            .clone()
                            .map(|s| {
                                let p = b.prim_indices[s as usize] as usize;
                                match &scene.primitives {
                                    crate::workload::geometry::Primitives::Triangles(t) => {
                                        obvhs::Boundable::aabb(&t[p])
                                    }
                                    crate::workload::geometry::Primitives::Spheres(s) => {
                                        obvhs::Boundable::aabb(&s[p])
                                    }
                                }
                            })
                            .collect(),
                    };
                    assert!(
                        inner.iter().all(|a| contains(&c.aabb, a)),
                        "{name} node {i}: child box too small"
                    );
                }
                assert!(node.count as usize == children.len());
            }
            assert_eq!(internal_refs[0], 0);
            assert!(internal_refs[1..].iter().all(|&r| r == 1), "{name}: every internal node has one parent");
            assert!(leaf_refs.iter().all(|&r| r == 1), "{name}: every leaf has one parent");
            assert!(b.leaves.iter().all(|l| l.len() == 1), "{name}: one primitive per leaf");
            let mut prims = b.prim_indices.clone();
            prims.sort_unstable();
            assert!(
                prims.iter().copied().eq(0..scene.primitives.len() as u32),
                "{name}: primitives covered once"
            );

            let mut addrs = HashSet::new();
            for i in 0..b.nodes.len() as u32 {
                let a = bvh.node_addr(NodeRef::Internal(i));
                assert!(a.is_multiple_of(BVH6_NODE_SIZE) && (INTERNAL_BASE..LEAF_BASE).contains(&a));
                assert!(addrs.insert(a));
            }
            for j in 0..b.leaves.len() as u32 {
                let a = bvh.node_addr(NodeRef::Leaf(j));
                assert!(a.is_multiple_of(BVH6_LEAF_DESC_SIZE) && (LEAF_BASE..PRIM_BASE).contains(&a));
                assert!(addrs.insert(a));
                let p = Bvh::prim_addr(j);
                assert!(p.is_multiple_of(PRIM_SIZE) && p >= PRIM_BASE);
                assert!(addrs.insert(p));
            }
        }
    }
}
