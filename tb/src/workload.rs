//! Ray-tracing workloads as an RT unit sees them: warps of 32 rays, each ray a recorded
//! traversal (node visits, pushes, pops).
//!
//! Launch order follows a GPU: pixels are numbered row-major and 32 consecutive pixels form a
//! warp. A warp's shader loops over samples and bounces, so for each warp, for sample `s`, for
//! bounce `b`, it issues one traceRay per lane whose path is still alive: that is one
//! [`WarpJob`]. A job whose lanes are all finished is not issued. Warps are traced lazily, one at
//! a time, when [`Workload::warp_jobs`] is iterated, so no more than one warp's traces are held.
//!
//! Traces are packed one `u64` per operation: 2 bits of operation, 2 bits of node kind and a
//! 60-bit address.

use glam::Vec3A;
use serde::Serialize;

use crate::bvh::Bvh;
pub use crate::bvh::BvhKind;
use crate::error::{Error, Result};
use crate::raygen::{Image, RayGen, ALBEDO};
use crate::scene::Scene;
use crate::traverse::{trace, Recorder};

/// Threads per warp.
pub const WARP_SIZE: usize = 32;

/// What a node fetch is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub enum NodeKind {
    Internal,
    Leaf,
    Triangle,
    Procedural,
}

/// One operation of a traversal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TraceOp {
    Visit { addr: u64, kind: NodeKind },
    Push(u64),
    Pop(u64),
}

const OP_SHIFT: u32 = 62;
const KIND_SHIFT: u32 = 60;
const ADDR_MASK: u64 = (1 << KIND_SHIFT) - 1;
const KINDS: [NodeKind; 4] = [NodeKind::Internal, NodeKind::Leaf, NodeKind::Triangle, NodeKind::Procedural];

impl TraceOp {
    fn pack(self) -> u64 {
        let (op, kind, addr) = match self {
            TraceOp::Visit { addr, kind } => (0, kind as u64, addr),
            TraceOp::Push(addr) => (1, 0, addr),
            TraceOp::Pop(addr) => (2, 0, addr),
        };
        debug_assert!(addr <= ADDR_MASK, "device addresses fit in 60 bits");
        op << OP_SHIFT | kind << KIND_SHIFT | (addr & ADDR_MASK)
    }

    fn unpack(word: u64) -> Self {
        let addr = word & ADDR_MASK;
        match word >> OP_SHIFT {
            0 => TraceOp::Visit {
                addr,
                kind: KINDS[(word >> KIND_SHIFT & 3) as usize],
            },
            1 => TraceOp::Push(addr),
            _ => TraceOp::Pop(addr),
        }
    }
}

/// The recorded traversal of one ray: a valid stack history (every pop takes the most recent
/// unpopped push, and the stack is empty at the end); the first operation visits the root.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RayTrace {
    ops: Vec<u64>,
    depth: u32,
    max_depth: u32,
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
}

impl Recorder for RayTrace {
    fn visit(&mut self, addr: u64, kind: NodeKind) {
        self.ops.push(TraceOp::Visit { addr, kind }.pack());
    }
    fn push(&mut self, addr: u64) {
        self.ops.push(TraceOp::Push(addr).pack());
        self.depth += 1;
        self.max_depth = self.max_depth.max(self.depth);
    }
    fn pop(&mut self, addr: u64) {
        self.ops.push(TraceOp::Pop(addr).pack());
        self.depth -= 1;
    }
}

/// One traceRay call of a warp: exactly [`WARP_SIZE`] lanes, `None` for lanes whose path ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WarpJob {
    pub lanes: Vec<Option<RayTrace>>,
}

/// How an internal node orders the children it descends into and pushes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ChildOrder {
    /// Descend the nearest hit child, push the others far to near (nearest remaining on top).
    #[default]
    Nearest,
    /// Descend the first hit child in index order, push the others in index order.
    #[value(name = "vulkansim")]
    VulkanSim,
}

/// What to trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct WorkloadOpts {
    pub bvh: BvhKind,
    pub order: ChildOrder,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Diffuse bounces after the primary ray.
    pub max_bounces: u32,
    pub seed: u64,
}

impl WorkloadOpts {
    /// BVH6 (what Vulkan-Sim walks), nearest-first, and the scene's own render settings.
    pub fn for_scene(scene: &Scene) -> Self {
        let r = scene.render;
        WorkloadOpts {
            bvh: BvhKind::Bvh6,
            order: ChildOrder::Nearest,
            width: r.width,
            height: r.height,
            spp: r.spp,
            max_bounces: r.max_bounces,
            seed: 0,
        }
    }
}

impl Default for WorkloadOpts {
    /// The SPEC's evaluation settings (section 8) on a BVH6.
    fn default() -> Self {
        let r = crate::scene::RenderSettings::default();
        WorkloadOpts {
            bvh: BvhKind::Bvh6,
            order: ChildOrder::Nearest,
            width: r.width,
            height: r.height,
            spp: r.spp,
            max_bounces: r.max_bounces,
            seed: 0,
        }
    }
}

/// A scene, its BVH and ray generator, and the rendered image.
pub struct Workload<'s> {
    scene: &'s Scene,
    bvh: Bvh,
    opts: WorkloadOpts,
    raygen: RayGen,
    image: Image,
    num_rays: u64,
}

/// Traces of one warp (indexed `[job][lane]`) and each lane's summed radiance.
struct WarpRun<R> {
    jobs: Vec<Vec<Option<R>>>,
    radiance: [Vec3A; WARP_SIZE],
}

impl<'s> Workload<'s> {
    /// Builds the BVH and renders the image (without recording traces).
    pub fn new(scene: &'s Scene, opts: WorkloadOpts) -> Result<Self> {
        if opts.width == 0 || opts.height == 0 || opts.spp == 0 {
            return Err(Error::Invalid(format!(
                "resolution {}x{} with {} spp traces nothing",
                opts.width, opts.height, opts.spp
            )));
        }
        opts.width
            .checked_mul(opts.height)
            .ok_or_else(|| Error::Invalid("resolution too large".into()))?;
        let bvh = Bvh::build(&scene.primitives, opts.bvh)?;
        let size = scene.primitives.bounds().diagonal().length();
        let raygen = RayGen::new(&scene.camera, opts.width, opts.height, opts.seed, size);
        let mut w = Workload {
            scene,
            bvh,
            opts,
            raygen,
            image: Image {
                width: opts.width,
                height: opts.height,
                pixels: Vec::new(),
            },
            num_rays: 0,
        };
        let pixel_count = (opts.width * opts.height) as usize;
        let mut pixels = Vec::with_capacity(pixel_count);
        for warp in 0..w.num_warps() {
            let run = w.run_warp::<()>(warp);
            w.num_rays += run.jobs.iter().flatten().flatten().count() as u64;
            pixels.extend(run.radiance.iter().map(|r| *r / opts.spp as f32));
        }
        pixels.truncate(pixel_count);
        w.image.pixels = pixels;
        Ok(w)
    }

    pub fn opts(&self) -> &WorkloadOpts {
        &self.opts
    }

    pub fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    pub fn num_warps(&self) -> u32 {
        (self.opts.width * self.opts.height).div_ceil(WARP_SIZE as u32)
    }

    /// Number of traceRay calls (rays) in the workload.
    pub fn num_rays(&self) -> u64 {
        self.num_rays
    }

    /// The rendered image: average radiance per pixel.
    pub fn image(&self) -> &Image {
        &self.image
    }

    /// All warp jobs in launch order, traced on demand.
    pub fn warp_jobs(&self) -> impl Iterator<Item = WarpJob> + '_ {
        (0..self.num_warps()).flat_map(move |warp| {
            self.run_warp::<RayTrace>(warp)
                .jobs
                .into_iter()
                .map(|lanes| WarpJob { lanes })
        })
    }

    fn run_warp<R: Recorder + Default>(&self, warp: u32) -> WarpRun<R> {
        let o = &self.opts;
        let prims = &self.scene.primitives;
        let pixel_count = o.width * o.height;
        let pixels: Vec<Option<u32>> = (0..WARP_SIZE as u32)
            .map(|lane| Some(warp * WARP_SIZE as u32 + lane).filter(|&p| p < pixel_count))
            .collect();
        let mut run = WarpRun {
            jobs: Vec::new(),
            radiance: [Vec3A::ZERO; WARP_SIZE],
        };
        for sample in 0..o.spp {
            // Each live lane's next ray and path throughput.
            let mut paths: Vec<Option<_>> = pixels
                .iter()
                .map(|p| p.map(|p| (self.raygen.primary(p, sample), Vec3A::ONE)))
                .collect();
            for bounce in 0..=o.max_bounces {
                if paths.iter().all(Option::is_none) {
                    break;
                }
                let lanes = (0..WARP_SIZE)
                    .map(|lane| {
                        let (ray, throughput) = paths[lane]?;
                        let mut rec = R::default();
                        let hit = trace(&self.bvh, prims, &ray, f32::INFINITY, o.order, &mut rec);
                        paths[lane] = match hit {
                            None => {
                                run.radiance[lane] += throughput * self.raygen.sky(ray.dir);
                                None
                            }
                            Some(_) if bounce == o.max_bounces => None,
                            Some(h) => {
                                let point = ray.at(h.t);
                                let normal = prims.normal(h.prim as usize, point, ray.dir);
                                let pixel = pixels[lane]?;
                                let next = self.raygen.bounce(pixel, sample, bounce + 1, point, normal);
                                Some((next, throughput * ALBEDO))
                            }
                        };
                        Some(rec)
                    })
                    .collect();
                run.jobs.push(lanes);
            }
        }
        run
    }
}
