//! Recorded traversals: what a node fetch is for ([`FetchKind`]), one operation ([`TraceOp`]), a
//! ray's whole stack history ([`RayTrace`]) and one traceRay call of a warp ([`WarpTraces`]).
//!
//! Traces are packed one `u64` per operation: 2 bits of operation, 3 bits of node kind and a
//! 59-bit address.

use rtl::ray_op::NodeKind;
use serde::Serialize;

/// Threads per warp.
pub const WARP_SIZE: usize = 32;

/// What a node fetch is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum FetchKind {
    Internal,
    Leaf,
    Triangle,
    Procedural,
    /// A TLAS instance leaf (two-level, 128 bytes).
    Instance,
    /// An acceleration structure's header (two-level, 64 bytes): the TLAS's at the start of a
    /// ray, a BLAS's after each instance leaf.
    BvhHeader,
}

/// The RT unit's operation for a node kind. An instance leaf costs the instance-transform latency
/// and an acceleration-structure header the `BVH_STRUCTURE` latency (`bvh_header`), as Vulkan-Sim
/// costs every transaction by its type (`-gpgpu_rt_intersection_latency 4,8,8,4,8,8,8`:
/// structure, internal, instance leaf, leaf descriptor, quad, quad hit, procedural;
/// `src/gpgpu-sim/shader.h:1604-1611`, `configs/tested-cfgs/MOBILE/gpgpusim.config:197`).
pub fn rtl_kind(kind: FetchKind) -> NodeKind {
    match kind {
        FetchKind::Instance => NodeKind::InstanceLeaf,
        FetchKind::BvhHeader => NodeKind::BvhHeader,
        FetchKind::Internal => NodeKind::Internal,
        FetchKind::Leaf => NodeKind::LeafDescriptor,
        FetchKind::Triangle => NodeKind::Triangle,
        FetchKind::Procedural => NodeKind::Procedural,
    }
}

/// One operation of a traversal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceOp {
    Visit { addr: u64, kind: FetchKind },
    Push(u64),
    Pop(u64),
}

const OP_SHIFT: u32 = 62;
const KIND_SHIFT: u32 = 59;
const ADDR_MASK: u64 = (1 << KIND_SHIFT) - 1;
const KINDS: [FetchKind; 6] = [
    FetchKind::Internal,
    FetchKind::Leaf,
    FetchKind::Triangle,
    FetchKind::Procedural,
    FetchKind::Instance,
    FetchKind::BvhHeader,
];

impl TraceOp {
    pub(super) fn pack(self) -> u64 {
        let (op, kind, addr) = match self {
            TraceOp::Visit { addr, kind } => (0, kind as u64, addr),
            TraceOp::Push(addr) => (1, 0, addr),
            TraceOp::Pop(addr) => (2, 0, addr),
        };
        debug_assert!(addr <= ADDR_MASK, "device addresses fit in 59 bits");
        op << OP_SHIFT | kind << KIND_SHIFT | (addr & ADDR_MASK)
    }

    fn unpack(word: u64) -> Self {
        let addr = word & ADDR_MASK;
        match word >> OP_SHIFT {
            0 => TraceOp::Visit { addr, kind: KINDS[(word >> KIND_SHIFT & 7) as usize] },
            1 => TraceOp::Push(addr),
            _ => TraceOp::Pop(addr),
        }
    }
}

/// The recorded traversal of one ray: a valid stack history (every pop takes the most recent
/// unpopped push, and the stack is empty at the end); the first operation visits the root.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RayTrace {
    pub(super) ops: Vec<u64>,
    pub(super) depth: u32,
    pub(super) max_depth: u32,
}

impl RayTrace {
    pub fn ops(&self) -> impl Iterator<Item = TraceOp> + '_ {
        self.ops.iter().map(|&w| TraceOp::unpack(w))
    }

    pub fn len(&self) -> usize {
        self.ops.len()
    }

    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }

    /// Largest number of entries on the stack at any point.
    pub fn max_depth(&self) -> u32 {
        self.max_depth
    }

    /// Checks that the trace is a valid stack history: it starts by visiting a node, every pop
    /// takes the most recent unpopped push, the stack ends empty, and `max_depth` is right.
    pub fn check_stack_history(&self) -> Result<(), String> {
        if !matches!(self.ops().next(), Some(TraceOp::Visit { .. })) {
            return Err("does not start with a visit of the root".into());
        }
        let mut stack = Vec::new();
        let mut max = 0;
        for (i, op) in self.ops().enumerate() {
            match op {
                TraceOp::Push(addr) => {
                    stack.push(addr);
                    max = max.max(stack.len() as u32);
                }
                TraceOp::Pop(addr) => match stack.pop() {
                    Some(top) if top == addr => {}
                    top => return Err(format!("op {i}: pop of {addr:#x}, stack top {top:x?}")),
                },
                TraceOp::Visit { .. } => {}
            }
        }
        if !stack.is_empty() {
            return Err(format!("{} entries left on the stack", stack.len()));
        }
        if max != self.max_depth {
            return Err(format!("max depth {} recorded, {max} replayed", self.max_depth));
        }
        Ok(())
    }
}

/// One traceRay call of a warp: exactly [`WARP_SIZE`] lanes, `None` for lanes whose path ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WarpTraces {
    pub lanes: Vec<Option<RayTrace>>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ops_round_trip_through_packing() {
        for (i, kind) in KINDS.into_iter().enumerate() {
            let addr = ADDR_MASK - i as u64;
            for op in [TraceOp::Visit { addr, kind }, TraceOp::Push(addr), TraceOp::Pop(addr)] {
                assert_eq!(TraceOp::unpack(op.pack()), op);
            }
        }
    }
}
