//! Ray-tracing workloads as an RT unit sees them: warps of 32 rays, each ray a recorded
//! traversal (node visits, pushes, pops).
//!
//! Launch order follows a GPU: pixels are numbered row-major and 32 consecutive pixels form a
//! warp. A warp's shader loops over samples and bounces, so for each warp, for sample `s`, for
//! bounce `b`, it issues one traceRay per lane whose path is still alive: that is one
//! [`WarpTraces`]. A job whose lanes are all finished is not issued. Warps are traced lazily, one at
//! a time, when [`Workload::warp_jobs`] is iterated, so no more than one warp's traces are held.
//!
//! The layer's modules, in dependency order (each uses only those before it): [`trace`](mod@trace) (the
//! recorded operations), [`geometry`], [`scene`], [`bvh`], [`raygen`], [`traverse`], [`restart`] (the
//! walk with a restart trail), then this module (warps in launch order) and [`depth`].

pub mod bvh;
pub mod depth;
pub mod geometry;
pub mod raygen;
pub mod restart;
mod rng;
pub mod scene;
pub mod trace;
pub mod traverse;

use glam::Vec3A;
use serde::Serialize;

pub use bvh::BvhKind;
use bvh::{Bvh, TwoLevel};
use geometry::Ray;
use raygen::{Image, RayGen, ALBEDO};
use scene::Scene;
use trace::{FetchKind, RayTrace, WarpTraces, WARP_SIZE};
use traverse::{hit_normal, trace, ChildOrder, Recorder};

use crate::error::{Error, Result};

/// Which acceleration structure the rays traverse.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Accel {
    /// One BVH over every primitive of the scene, instances flattened.
    #[default]
    Flat,
    /// A TLAS over one BLAS per mesh, as the Vulkan pipeline builds them (BVH6 only).
    TwoLevel,
}

impl Accel {
    pub fn is_flat(&self) -> bool {
        *self == Accel::Flat
    }
}

/// When a path ends besides a miss and the bounce limit. Neither has Russian roulette.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PathEnd {
    /// As LumiBench's path tracer: a Lambertian surface scatters only a ray arriving at its
    /// front (`isScattered = dot(direction, normal) < 0`, RayTracingInVulkan
    /// assets/shaders/Scatter.glsl:17), and the ray generation shader ends the path when a hit
    /// does not scatter (RayTracing.rgen:71-75). Front is the side the triangle's winding
    /// (LumiBench: the interpolated vertex normal) faces; a sphere's outside. Emitters, which
    /// also end a path there (Scatter.glsl:56-63), do not exist here: no scene has materials.
    #[default]
    Lumibench,
    /// Every hit scatters, from either side (the `legacy` preset's workload).
    Always,
}

/// What to trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct WorkloadOpts {
    pub bvh: BvhKind,
    /// Left out of serialised output when flat (outputs from before the option stay identical).
    #[serde(skip_serializing_if = "Accel::is_flat")]
    pub accel: Accel,
    pub order: ChildOrder,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Diffuse bounces after the primary ray.
    pub max_bounces: u32,
    pub seed: u64,
    /// When a hit ends the path.
    pub path_end: PathEnd,
}

impl WorkloadOpts {
    /// BVH6 (what Vulkan-Sim walks), nearest-first, and the scene's own render settings.
    pub fn for_scene(scene: &Scene) -> Self {
        Self::rendering(scene.render)
    }

    /// A quick look at `scene`: `res × res` pixels, one sample, one bounce, the rest as
    /// [`Self::for_scene`] (what the tests and previews run).
    pub fn quick(scene: &Scene, res: u32) -> Self {
        WorkloadOpts { width: res, height: res, spp: 1, max_bounces: 1, ..Self::for_scene(scene) }
    }

    fn rendering(r: crate::workload::scene::RenderSettings) -> Self {
        WorkloadOpts {
            bvh: BvhKind::Bvh6,
            accel: Accel::Flat,
            order: ChildOrder::Nearest,
            width: r.width,
            height: r.height,
            spp: r.spp,
            max_bounces: r.max_bounces,
            seed: 0,
            path_end: PathEnd::default(),
        }
    }
}

impl Default for WorkloadOpts {
    /// The SPEC's evaluation settings (section 8) on a BVH6.
    fn default() -> Self {
        Self::rendering(crate::workload::scene::RenderSettings::default())
    }
}

/// Records only the ray a traversal was asked for.
#[derive(Default)]
struct RayOnly(Option<Ray>);

impl Recorder for RayOnly {
    fn ray(&mut self, ray: &Ray) {
        self.0 = Some(*ray);
    }
    fn visit(&mut self, _: u64, _: FetchKind) {}
    fn push(&mut self, _: u64) {}
    fn pop(&mut self, _: u64) {}
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
        Self::with_progress(scene, opts, |_, _| {})
    }

    /// As [`Workload::new`], calling `progress(pixel warps traced, of)` after each pixel warp.
    pub fn with_progress(
        scene: &'s Scene,
        opts: WorkloadOpts,
        mut progress: impl FnMut(u32, u32),
    ) -> Result<Self> {
        if opts.width == 0 || opts.height == 0 || opts.spp == 0 {
            return Err(Error::Invalid(format!(
                "resolution {}x{} with {} spp traces nothing",
                opts.width, opts.height, opts.spp
            )));
        }
        opts.width.checked_mul(opts.height).ok_or_else(|| Error::Invalid("resolution too large".into()))?;
        let bvh = match opts.accel {
            Accel::Flat => Bvh::build(&scene.primitives, opts.bvh)?,
            Accel::TwoLevel if opts.bvh != BvhKind::Bvh6 => {
                return Err(Error::Invalid(format!(
                    "accel two-level is built as BVH6 only: bvh {} asked, use bvh bvh6",
                    format!("{:?}", opts.bvh).to_lowercase()
                )))
            }
            Accel::TwoLevel => Bvh::TwoLevel(Box::new(TwoLevel::build(&scene.primitives, &scene.objects)?)),
        };
        let size = scene.primitives.bounds().diagonal().length();
        let raygen = RayGen::new(&scene.camera, opts.width, opts.height, opts.seed, size);
        let mut w = Workload {
            scene,
            bvh,
            opts,
            raygen,
            image: Image { width: opts.width, height: opts.height, pixels: Vec::new() },
            num_rays: 0,
        };
        let pixel_count = (opts.width * opts.height) as usize;
        let mut pixels = Vec::with_capacity(pixel_count);
        for warp in 0..w.num_warps() {
            let run = w.run_warp::<()>(warp);
            w.num_rays += run.jobs.iter().flatten().flatten().count() as u64;
            pixels.extend(run.radiance.iter().map(|r| *r / opts.spp as f32));
            progress(warp + 1, w.num_warps());
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
    pub fn warp_jobs(&self) -> impl Iterator<Item = WarpTraces> + '_ {
        self.warps().flatten()
    }

    /// The jobs of each warp in launch order, one warp at a time, traced on demand.
    pub fn warps(&self) -> impl Iterator<Item = Vec<WarpTraces>> + '_ {
        (0..self.num_warps()).map(move |warp| self.warp(warp))
    }

    /// The jobs of pixel warp `warp` (one per sample and bounce with a live lane), traced now.
    pub fn warp(&self, warp: u32) -> Vec<WarpTraces> {
        self.run_warp::<RayTrace>(warp).jobs.into_iter().map(|lanes| WarpTraces { lanes }).collect()
    }

    /// The scene the workload renders.
    pub fn scene(&self) -> &Scene {
        self.scene
    }

    /// The rays of pixel warp `warp`: per warp job (sample × bounce, as [`Workload::warp`]),
    /// each lane's ray (`None` where its path ended).
    pub fn warp_rays(&self, warp: u32) -> Vec<Vec<Option<Ray>>> {
        let jobs = self.run_warp::<RayOnly>(warp).jobs;
        jobs.into_iter().map(|lanes| lanes.into_iter().map(|r| r.and_then(|r| r.0)).collect()).collect()
    }

    /// Every ray of the workload in launch order (warp, sample, bounce, lane), e.g. to time
    /// another traversal of the same rays.
    pub fn rays(&self) -> Vec<Ray> {
        let rays = (0..self.num_warps()).flat_map(|warp| self.run_warp::<RayOnly>(warp).jobs);
        rays.flatten().flatten().filter_map(|r| r.0).collect()
    }

    fn run_warp<R: Recorder + Default>(&self, warp: u32) -> WarpRun<R> {
        let o = &self.opts;
        let prims = &self.scene.primitives;
        let pixel_count = o.width * o.height;
        let pixels: Vec<Option<u32>> = (0..WARP_SIZE as u32)
            .map(|lane| Some(warp * WARP_SIZE as u32 + lane).filter(|&p| p < pixel_count))
            .collect();
        let mut run = WarpRun { jobs: Vec::new(), radiance: [Vec3A::ZERO; WARP_SIZE] };
        for sample in 0..o.spp {
            // Each live lane's next ray and path throughput.
            let mut paths: Vec<Option<_>> =
                pixels.iter().map(|p| p.map(|p| (self.raygen.primary(p, sample), Vec3A::ONE))).collect();
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
                            Some(h)
                                if o.path_end == PathEnd::Lumibench
                                    && prims.outward_normal(h.prim as usize, ray.at(h.t)).dot(ray.dir)
                                        >= 0.0 =>
                            {
                                None
                            }
                            Some(h) => {
                                let point = ray.at(h.t);
                                let normal = hit_normal(self.scene, &h, point, ray.dir);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workload::scene::load_scene;
    use crate::workload::trace::TraceOp;

    fn small(bvh: BvhKind, order: ChildOrder, seed: u64) -> WorkloadOpts {
        WorkloadOpts {
            bvh,
            accel: Accel::Flat,
            order,
            width: 16,
            height: 12,
            spp: 1,
            max_bounces: 2,
            seed,
            path_end: PathEnd::Always,
        }
    }

    const KINDS: [BvhKind; 3] = [BvhKind::Bvh2, BvhKind::Bvh6, BvhKind::Cwbvh];
    const ORDERS: [ChildOrder; 2] = [ChildOrder::Nearest, ChildOrder::VulkanSim];

    #[test]
    fn traces_are_valid_stack_histories() {
        for name in ["wknd", "grid", "clutter"] {
            let scene = load_scene(name).expect(name);
            for bvh in KINDS {
                for order in ORDERS {
                    let w = Workload::new(&scene, small(bvh, order, 1)).expect("workload");
                    let mut rays = 0;
                    let mut deepest = 0;
                    for job in w.warp_jobs() {
                        assert_eq!(job.lanes.len(), WARP_SIZE);
                        for trace in job.lanes.iter().flatten() {
                            rays += 1;
                            deepest = deepest.max(trace.max_depth());
                            trace
                                .check_stack_history()
                                .unwrap_or_else(|e| panic!("{name} {bvh:?} {order:?}: {e}"));
                            assert_eq!(
                                trace.ops().next(),
                                Some(TraceOp::Visit {
                                    addr: crate::workload::bvh::INTERNAL_BASE,
                                    kind: FetchKind::Internal
                                })
                            );
                            if bvh != BvhKind::Cwbvh {
                                // A popped node is fetched next.
                                let ops: Vec<_> = trace.ops().collect();
                                for pair in ops.windows(2) {
                                    if let TraceOp::Pop(a) = pair[0] {
                                        assert!(matches!(pair[1], TraceOp::Visit { addr, .. } if addr == a));
                                    }
                                }
                            }
                        }
                    }
                    assert_eq!(rays, w.num_rays());
                    assert_eq!(w.rays().len() as u64, rays);
                    assert!(deepest > 0, "{name} {bvh:?} {order:?} never pushed");
                }
            }
        }
    }

    #[test]
    fn two_level_traces_are_valid_stack_histories_and_render_like_flat() {
        for name in ["wknd", "clutter"] {
            let scene = load_scene(name).expect(name);
            for order in ORDERS {
                let flat = Workload::new(&scene, small(BvhKind::Bvh6, order, 1)).expect("flat");
                let opts = WorkloadOpts { accel: Accel::TwoLevel, ..small(BvhKind::Bvh6, order, 1) };
                let w = Workload::new(&scene, opts).expect("two-level");
                let mut instances = 0;
                for job in w.warp_jobs() {
                    for trace in job.lanes.iter().flatten() {
                        trace.check_stack_history().unwrap_or_else(|e| panic!("{name} {order:?}: {e}"));
                        instances += trace
                            .ops()
                            .filter(|o| matches!(o, TraceOp::Visit { kind: FetchKind::Instance, .. }))
                            .count();
                    }
                }
                assert!(instances > 0);
                // One identity instance per scene: the same rays, hits and image.
                assert_eq!(w.num_rays(), flat.num_rays());
                assert_eq!(w.image(), flat.image(), "{name} {order:?}");
            }
        }
        let scene = load_scene("grid").expect("grid");
        let opts = WorkloadOpts { accel: Accel::TwoLevel, ..small(BvhKind::Bvh2, ChildOrder::Nearest, 0) };
        let e = Workload::new(&scene, opts).err().expect("two-level BVH2 is refused").to_string();
        assert!(e.contains("two-level") && e.contains("BVH6"), "{e}");
    }

    #[test]
    fn a_wrong_pop_is_caught() {
        let mut good = RayTrace::default();
        good.visit(crate::workload::bvh::INTERNAL_BASE, FetchKind::Internal);
        good.push(0x40);
        good.push(0x80);
        good.pop(0x80);
        good.pop(0x40);
        assert_eq!(good.check_stack_history(), Ok(()));
        assert_eq!(good.max_depth(), 2);
        let mut swapped = good.clone();
        swapped.ops.swap(3, 4);
        assert!(swapped.check_stack_history().is_err());
        let mut unbalanced = good.clone();
        unbalanced.ops.pop();
        assert!(unbalanced.check_stack_history().is_err());
    }

    #[test]
    fn same_seed_same_traces_other_seed_other_traces() {
        let scene = load_scene("clutter").expect("clutter");
        let jobs = |seed| {
            let w =
                Workload::new(&scene, small(BvhKind::Bvh6, ChildOrder::VulkanSim, seed)).expect("workload");
            (w.warp_jobs().collect::<Vec<_>>(), w.image().clone())
        };
        let (a, image_a) = jobs(7);
        let (b, image_b) = jobs(7);
        assert_eq!(a, b);
        assert_eq!(image_a, image_b);
        assert_ne!(a, jobs(8).0);
    }

    #[test]
    fn partial_last_warp_has_inactive_lanes() {
        let scene = load_scene("grid").expect("grid");
        let mut opts = small(BvhKind::Bvh2, ChildOrder::Nearest, 0);
        (opts.width, opts.height, opts.spp) = (10, 5, 2);
        let w = Workload::new(&scene, opts).expect("workload");
        assert_eq!(w.num_warps(), 2);
        assert_eq!(w.image().pixels.len(), 50);
        let jobs: Vec<_> = w.warp_jobs().collect();
        let last_warp_jobs = jobs.iter().rev().take_while(|j| j.lanes[18..].iter().all(Option::is_none));
        assert!(last_warp_jobs.count() >= opts.spp as usize);
        assert!(jobs.iter().all(|j| j.lanes.iter().any(Option::is_some)));
    }

    /// A quad filling the view, wound to face the camera (`front`) or away from it.
    fn quad(front: bool) -> Scene {
        use crate::workload::geometry::Primitives;
        use glam::vec3a;
        let (a, b, c, d) = (
            vec3a(-50.0, -50.0, 0.0),
            vec3a(50.0, -50.0, 0.0),
            vec3a(50.0, 50.0, 0.0),
            vec3a(-50.0, 50.0, 0.0),
        );
        let tris = if front {
            vec![
                obvhs::triangle::Triangle { v0: a, v1: b, v2: c },
                obvhs::triangle::Triangle { v0: a, v1: c, v2: d },
            ]
        } else {
            vec![
                obvhs::triangle::Triangle { v0: a, v1: c, v2: b },
                obvhs::triangle::Triangle { v0: a, v1: d, v2: c },
            ]
        };
        Scene {
            name: "quad".into(),
            objects: crate::workload::scene::Objects::single(tris.len()),
            primitives: Primitives::Triangles(tris),
            camera: crate::workload::scene::Camera::look_at([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], 45.0),
            render: crate::workload::scene::RenderSettings { width: 8, height: 8, spp: 1, max_bounces: 3 },
            dropped_degenerate: 0,
            files: Vec::new(),
        }
    }

    /// LumiBench's Lambertian scatters only rays that arrive at a surface's front
    /// (Scatter.glsl:17), and a hit that does not scatter ends the path (RayTracing.rgen:71-75).
    #[test]
    fn a_back_face_hit_ends_a_lumibench_path_and_scatters_otherwise() {
        let rays = |front: bool, path_end: PathEnd| {
            let scene = quad(front);
            let opts = WorkloadOpts { path_end, ..WorkloadOpts::for_scene(&scene) };
            Workload::new(&scene, opts).unwrap().num_rays()
        };
        // Every primary ray hits the quad; a bounce off its front leaves it and misses.
        assert_eq!(rays(true, PathEnd::Lumibench), 2 * 64);
        assert_eq!(rays(true, PathEnd::Always), 2 * 64);
        // Seen from behind: the path ends at the primary hit, unless every hit scatters.
        assert_eq!(rays(false, PathEnd::Lumibench), 64);
        assert_eq!(rays(false, PathEnd::Always), 2 * 64);
        assert_eq!(WorkloadOpts::default().path_end, PathEnd::Lumibench);
    }

    #[test]
    fn the_default_workload_is_lumibench_s() {
        let o = WorkloadOpts::default();
        // 16 traceRay calls per path at most: the primary ray and 15 bounces.
        assert_eq!((o.width, o.height, o.spp, o.max_bounces + 1), (128, 128, 2, 16));
    }

    #[test]
    fn empty_resolution_is_an_error() {
        let scene = load_scene("grid").expect("grid");
        let mut opts = small(BvhKind::Bvh6, ChildOrder::Nearest, 0);
        opts.width = 0;
        assert!(Workload::new(&scene, opts).is_err());
    }
}
