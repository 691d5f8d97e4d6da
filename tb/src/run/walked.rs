//! Walk-driven cycle-level runs: the restart designs (`+RT`), whose walk depends on what their
//! stack does.
//!
//! ```text
//!   pixel warps ──► rays per warp job ──► WarpJob { lanes: empty, walk: Some(job) }
//!                                │
//!   Gpu::run_walks ◄─segments──► TreeWalks: one RestartWalk per live ray, over the workload's BVH
//!        (pop answers, Restart)     │ a ray's walk ends: its closest hit against the full-stack walk
//! ```
//!
//! The RT unit asks for a ray's next segment when its warp lands and at the edge of the cycle
//! each of its pops is answered (`rtl::rt_unit`), so an entry the stack dropped at a push (which,
//! with reallocation, depends on what the other lanes hold at that moment) forces a restart that
//! re-walks from the root along the trail, re-fetching nodes through the memory model. Every ray
//! is checked when its walk ends: its closest hit equals the full-stack walk's; the walk itself
//! checks every popped entry against its unbounded reference stack and refuses a visit inside a
//! finished subtree ([`crate::workload::restart`]).

use std::collections::HashMap;

use rtl::ray_op::{Popped, RayOp, Walk, Walks};
use serde::Serialize;

use crate::workload::geometry::{Primitives, Ray};
use crate::workload::restart::{RestartTree, RestartWalk};
use crate::workload::traverse::{trace, ChildOrder};

/// What the walks of a run did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct WalkCounts {
    /// Rays whose walk ended, each with its closest hit checked against the full-stack walk.
    pub rays_checked: u64,
    /// Restarts taken.
    pub restarts: u64,
    /// Node visits made while descending the trail after a restart.
    pub refetched: u64,
}

/// The walks of one cycle-level run: the rays of each warp job (by the job's walk id, launch
/// order), each ray's walk while it lives.
pub struct TreeWalks<'t> {
    tree: &'t RestartTree<'t>,
    prims: &'t Primitives,
    rays: Vec<Vec<Option<Ray>>>,
    live: HashMap<(u64, u32), RestartWalk<'t>>,
    pub counts: WalkCounts,
}

impl<'t> TreeWalks<'t> {
    /// The walks of the warp jobs whose lanes' rays are `rays` (walk id = index).
    pub fn new(tree: &'t RestartTree<'t>, prims: &'t Primitives, rays: Vec<Vec<Option<Ray>>>) -> Self {
        TreeWalks { tree, prims, rays, live: HashMap::new(), counts: WalkCounts::default() }
    }

    /// The warp jobs, in launch order, for the RT units.
    pub fn jobs(&self) -> Vec<rtl::ray_op::WarpJob> {
        let job = |(id, lanes): (usize, &Vec<Option<Ray>>)| rtl::ray_op::WarpJob {
            lanes: lanes.iter().map(|r| r.map(|_| Vec::new())).collect(),
            walk: Some(id as u64),
        };
        self.rays.iter().enumerate().map(job).collect()
    }

    /// Rays of the run's jobs.
    pub fn rays(&self) -> u64 {
        self.rays.iter().flatten().filter(|r| r.is_some()).count() as u64
    }

    /// Rays still walking (none after a run that ended).
    pub fn live(&self) -> usize {
        self.live.len()
    }
}

impl Walks for TreeWalks<'_> {
    fn resume(
        &mut self,
        job: u64,
        lane: u32,
        answer: Option<Popped>,
        ops: &mut Vec<RayOp>,
    ) -> Result<(), String> {
        let key = (job, lane);
        if answer.is_none() {
            let ray = self
                .rays
                .get(job as usize)
                .and_then(|l| l.get(lane as usize).copied().flatten())
                .ok_or_else(|| format!("warp job {job} has no ray in lane {lane}"))?;
            self.live.insert(key, RestartWalk::new(self.tree, ray));
        }
        let walk = self.live.get_mut(&key).ok_or_else(|| format!("no walk for job {job} lane {lane}"))?;
        walk.resume(answer, ops)?;
        if walk.is_done() {
            let walk = self.live.remove(&key).expect("just found");
            let ray = self.rays[job as usize][lane as usize].expect("a walk's ray");
            let want = trace(self.tree.bvh(), self.prims, &ray, f32::INFINITY, ChildOrder::Nearest, &mut ());
            if walk.hit() != want {
                return Err(format!(
                    "job {job} lane {lane}: closest hit {:?}, the full-stack walk's {want:?}",
                    walk.hit()
                ));
            }
            self.counts.rays_checked += 1;
            self.counts.restarts += walk.restarts();
            self.counts.refetched += walk.refetched();
        }
        Ok(())
    }
}
