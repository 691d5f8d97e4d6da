//! The RT unit's stimulus: one ray's traversal as the RT unit performs it.
//!
//! ```text
//!   BVH traversal trace ──(testbench)──► WarpJob { lanes: [Option<[RayOp]>; warp_size] }
//!                                              │
//!        Visit ─► node fetch (sectors) ─► operation unit latency of its kind
//!        Push  ─► stack manager push
//!        Pop   ─► stack manager pop; the answer must equal the address given here
//!        (end) ─► Finish
//! ```
//!
//! A trace says *what* a ray does; the RT unit decides *when*. Keeping the popped address in the
//! trace lets the unit check every pop of the stack design under test against the traversal
//! that produced the trace. Stimulus, not hardware: nothing here is clocked.

/// Which operation unit a visited node goes to (SPEC section 7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NodeKind {
    /// Internal node: ray-box tests of its children.
    Internal,
    /// Acceleration-structure header (Vulkan-Sim's `BVH_STRUCTURE` transaction, 64 bytes): a
    /// two-level trace fetches each BLAS's header after its instance leaf
    /// (`vulkan_ray_tracing.cc:731`); costs the `bvh_header` latency.
    BvhHeader,
    /// Instance leaf: transform the ray into the instance's space.
    InstanceLeaf,
    /// Leaf descriptor, fetched before the primitive it describes.
    LeafDescriptor,
    /// Ray-triangle test.
    Triangle,
    /// Procedural primitive (custom intersection).
    Procedural,
}

/// The largest node the node fetch unit takes in one visit, in bytes. Every layout the model
/// builds fits (BVH6 64, CWBVH 80, BVH2 leaves 48); it bounds the fetch unit's queues (a node at
/// any alignment spans at most `MAX_NODE_BYTES / sector + 1` sectors).
pub const MAX_NODE_BYTES: u32 = 128;

/// One step of a ray's traversal, in RT-unit order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayOp {
    /// Fetch `bytes` bytes at `addr`, then spend the operation latency of `kind`.
    Visit { addr: u64, kind: NodeKind, bytes: u32 },
    /// Push a node address on the ray's stack.
    Push(u64),
    /// Pop the ray's stack; the stack must return this address.
    Pop(u64),
}

/// A pop's answer as a ray whose walk follows its stack sees it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Popped {
    /// The stack's newest entry.
    Entry(u64),
    /// The stack was empty because it dropped entries on overflow: the walk restarts from the
    /// root along its trail (the restart designs).
    Restart,
}

/// A ray whose operations depend on what its stack answers: with a stack that drops entries on
/// overflow, a pop may answer [`Popped::Restart`], and the walk goes on from the root instead of
/// the popped node. The testbench implements it over a real BVH; the RT unit pulls one segment
/// at a time. Stimulus, not hardware: the walk's own registers (the trail) are the design's, and
/// their cost is counted by `sms cost`, but the walk itself is not clocked.
pub trait Walk: Send {
    /// Appends the ray's next operations to `ops`: up to and including its next [`RayOp::Pop`],
    /// or to the end of its traversal (a segment without a Pop is the last). `answer` is what
    /// the Pop that ended the previous segment returned; `None` for the first segment. The
    /// Pop's address is the one an unbounded stack would return: the stack answers it or, if it
    /// dropped it, [`Popped::Restart`]. An error is a walk that cannot go on (a wrong answer).
    fn resume(&mut self, answer: Option<Popped>, ops: &mut Vec<RayOp>) -> Result<(), String>;
}

/// The walks of a run's walk-driven rays, by warp job and lane: the RT unit asks for a lane's
/// next segment when its warp loads and after each of its pops, at the edge of the cycle the
/// stack answers. The testbench implements it over a BVH (each ray a [`Walk`]); like the jobs,
/// it is the run's stimulus, handed to the run (`Gpu::run_walks`), not part of the hardware.
pub trait Walks {
    /// [`Walk::resume`] of the ray in lane `lane` of the job with walk id `job`.
    fn resume(
        &mut self,
        job: u64,
        lane: u32,
        answer: Option<Popped>,
        ops: &mut Vec<RayOp>,
    ) -> Result<(), String>;
}

/// One warp's rays: exactly `warp_size` lanes, `None` for an inactive lane. After its last
/// operation a lane sends Finish (its stack must then be empty).
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct WarpJob {
    pub lanes: Vec<Option<Vec<RayOp>>>,
    /// A walk-driven job (the restart designs): its id for the run's [`Walks`]. Its active
    /// lanes' operations (given empty) come from the walks, segment by segment, as the stack
    /// answers; `None`: the lanes hold whole traces.
    pub walk: Option<u64>,
}

impl WarpJob {
    /// Bit `l` set: lane `l` is active.
    pub fn active_mask(&self) -> u32 {
        self.lanes.iter().enumerate().fold(0, |m, (l, ops)| m | u32::from(ops.is_some()) << l)
    }

    /// Checks what the RT unit cannot run: a lane count other than `warp_size`, a node of zero
    /// bytes or more than [`MAX_NODE_BYTES`], or one that runs past the end of the address space. (Pushes and pops are checked
    /// against the stack as the job runs.)
    pub fn validate(&self, warp_size: u32) -> Result<(), String> {
        if self.lanes.len() != warp_size as usize {
            return Err(format!("{} lanes, the warp size is {warp_size}", self.lanes.len()));
        }
        for (l, ops) in self.lanes.iter().enumerate() {
            for (i, op) in ops.iter().flatten().enumerate() {
                if let RayOp::Visit { bytes, addr, .. } = *op {
                    if bytes > MAX_NODE_BYTES {
                        return Err(format!(
                            "lane {l}, operation {i}: visit of {bytes} bytes at {addr:#x} is larger than \
                             the node fetch unit's {MAX_NODE_BYTES}-byte limit"
                        ));
                    }
                    if bytes == 0 || addr.checked_add(u64::from(bytes)).is_none() {
                        return Err(format!(
                            "lane {l}, operation {i}: visit of {bytes} bytes at {addr:#x} is not a node"
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn job(bytes: u32, addr: u64) -> WarpJob {
        let visit = RayOp::Visit { addr, kind: NodeKind::Internal, bytes };
        WarpJob { lanes: vec![Some(vec![visit]), None], walk: None }
    }

    #[test]
    fn visits_the_fetch_unit_cannot_take_are_refused() {
        assert_eq!(job(MAX_NODE_BYTES, 0x40).validate(2), Ok(()));
        let e = job(MAX_NODE_BYTES + 1, 0x40).validate(2).unwrap_err();
        assert!(e.contains("larger than the node fetch unit's 128-byte limit"), "{e}");
        assert!(job(0, 0x40).validate(2).unwrap_err().contains("is not a node"));
        assert!(job(8, u64::MAX - 2).validate(2).unwrap_err().contains("is not a node"));
        assert!(job(8, 0).validate(4).unwrap_err().contains("2 lanes, the warp size is 4"));
    }
}
