//! Test support shared by the test suites: how a test builds and runs the model, written once.
//! Not part of the tool (hidden from the documentation).
//!
//! It lives here because `tb` is the lowest crate every suite that runs the model can reach: the
//! `tb` and `proofs` integration tests use it, and whole-GPU tests sit in `tb/tests` for that
//! reason (an integration test of `rtl` cannot use a crate that depends on `rtl`). A
//! `tests/common` module is private to one crate's tests; `tb/tests/common` keeps only what needs
//! the `sms` binary built for those tests, and re-exports this module.
//!
//! Planted bugs (`OrderBug`, `Mutant`) exist only in builds with `rtl`'s `mutants` feature, which
//! the test suites turn on and the tool does not, so a test plants them itself on the [`Gpu`] or
//! the stack unit it gets from here.

use rtl::config::Config;
use rtl::gpu::{Gpu, GpuReport};
use rtl::ray_op::{NodeKind, RayOp, WarpJob};
use rtl::rt_unit::RunError;
use rtl::sim::Runner;
use rtl::stack_unit::{StandaloneStack, UnitStats};
use rtl::trace::NullSink;

use crate::run::sim::{rtl_job, simulate_all, Fidelity, Hardware, Outcome, RunSpec};
use crate::run::verify::harness::{run_cycle, CycleOpts, HarnessError, RunSummary, WarpWork};
use crate::run::verify::invariants::Property;
use crate::run::verify::streams::stream;
use crate::workload::scene::Scene;
use crate::workload::traverse::ChildOrder;
use crate::workload::{Workload, WorkloadOpts};

/// Cycles no test run comes near (a clean clutter 16×16 run takes tens of thousands): a run past
/// it panics, so that a planted bug that keeps a run going (a request taken again and again)
/// ends.
pub const RUNAWAY: u64 = 10_000_000;

/// A small square workload of `scene`: `res × res` pixels, 1 spp, 1 bounce, child order `order`.
pub fn small_workload(scene: &Scene, res: u32, order: ChildOrder) -> Workload<'_> {
    Workload::new(scene, WorkloadOpts { order, ..WorkloadOpts::quick(scene, res) }).unwrap()
}

/// The RT unit's jobs of the built-in scene `scene`'s small workload (`res × res`, Vulkan-Sim's
/// child order).
pub fn scene_jobs(scene: &str, res: u32) -> Vec<WarpJob> {
    let scene = crate::load_scene(scene).unwrap();
    let w = small_workload(&scene, res, ChildOrder::VulkanSim);
    let bvh = w.opts().bvh;
    w.warp_jobs().map(|j| rtl_job(&j, bvh)).collect()
}

/// Tiny deterministic generator (SplitMix64).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut x = self.0;
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^ (x >> 31)
    }

    fn chance(&mut self, percent: u64) -> bool {
        self.next() % 100 < percent
    }
}

/// The synthetic tree of [`synthetic_jobs`]: 4-ary, depth 6, nodes, leaf descriptors and
/// triangles at these addresses.
const ARITY: u64 = 4;
const DEPTH: u32 = 6;
const NODES: u64 = 0x1000_0000;
const LEAF_DESCS: u64 = 0x4000_0000;
const TRIANGLES: u64 = 0x5000_0000;

/// A random depth-first walk of a complete 4-ary tree of depth 6, as the RT unit would perform
/// it: internal nodes hit each child with `hit` percent chance, the nearest hit child is visited
/// next and the others pushed; a leaf fetches its descriptor and triangle; then the stack is
/// popped until empty. Node `i` (heap order) lives at `NODES + 64 i`.
fn synthetic_ray(rng: &mut Rng, hit: u64) -> Vec<RayOp> {
    let mut ops = Vec::new();
    let mut stack = Vec::new();
    let first_leaf = (ARITY.pow(DEPTH) - 1) / (ARITY - 1);
    let mut cur = Some(0u64);
    while let Some(i) = cur {
        if i >= first_leaf {
            ops.push(RayOp::Visit {
                addr: LEAF_DESCS + (i - first_leaf) * 8,
                kind: NodeKind::LeafDescriptor,
                bytes: 8,
            });
            ops.push(RayOp::Visit {
                addr: TRIANGLES + (i - first_leaf) * 64,
                kind: NodeKind::Triangle,
                bytes: 64,
            });
            cur = None;
        } else {
            ops.push(RayOp::Visit { addr: NODES + i * 64, kind: NodeKind::Internal, bytes: 64 });
            let hits: Vec<u64> = (1..=ARITY).map(|c| ARITY * i + c).filter(|_| rng.chance(hit)).collect();
            cur = hits.first().copied();
            for &c in hits.iter().skip(1).rev() {
                ops.push(RayOp::Push(NODES + c * 64));
                stack.push(c);
            }
        }
        if cur.is_none() {
            cur = stack.pop();
            if let Some(c) = cur {
                ops.push(RayOp::Pop(NODES + c * 64));
            }
        }
    }
    ops
}

/// `warps` warps of synthetic traversals ([`synthetic_ray`]) from `seed`, every fifth warp with
/// a third of its lanes inactive.
pub fn synthetic_jobs(seed: u64, warps: usize, hit: u64) -> Vec<WarpJob> {
    let mut rng = Rng(seed);
    (0..warps)
        .map(|w| WarpJob {
            lanes: (0..32)
                .map(|l| (w % 5 != 4 || l % 3 != 0).then(|| synthetic_ray(&mut rng, hit)))
                .collect(),
            walk: None,
        })
        .collect()
}

/// The GPU of stack configuration `cfg` on hardware `hw` (its L1D carved as `hw` says), to run
/// with `hw`'s run option (idle-cycle skipping).
pub fn gpu(cfg: Config, hw: &Hardware) -> Runner {
    Gpu::new(cfg, hw.rt, hw.stack, hw.mem_for(&cfg))
        .unwrap_or_else(|e| panic!("{}: {e}", cfg.name()))
        .with_idle_skip(hw.idle_skip)
}

/// Runs `gpu` (a GPU, or a GPU with run options) on `jobs`: its report or the error that stopped
/// it. Panics past [`RUNAWAY`] cycles.
pub fn run_gpu(
    gpu: impl Into<Runner>,
    jobs: impl IntoIterator<Item = WarpJob>,
) -> Result<GpuReport, RunError> {
    gpu.into().run_with_progress(jobs, &mut NullSink, RUNAWAY / 10, |p| {
        assert!(p.cycle < RUNAWAY, "ran away: {} cycles", p.cycle)
    })
}

/// [`run_gpu`] with a panic caught (a planted bug may panic, or run away): `Err("panic")`.
pub fn run_gpu_guarded(
    gpu: impl Into<Runner>,
    jobs: Vec<WarpJob>,
) -> Result<Result<GpuReport, RunError>, String> {
    let gpu = gpu.into();
    std::panic::catch_unwind(move || run_gpu(gpu, jobs)).map_err(|_| "panic".to_string())
}

/// The report of a run that must end without an error (`what` names it in the panic).
pub fn report(gpu: impl Into<Runner>, jobs: impl IntoIterator<Item = WarpJob>, what: &str) -> GpuReport {
    run_gpu(gpu, jobs).unwrap_or_else(|e| panic!("{what}: {e}"))
}

/// A report bit for bit, floats included, for comparing two runs.
pub fn bits(r: &GpuReport) -> String {
    format!("{r:?} {} {}", r.l1d_hit_rate.to_bits(), r.l2_hit_rate.to_bits())
}

/// `w` simulated at `fidelity` under `config` on `hw`; panics naming the configuration.
pub fn simulate(config: Config, hw: Hardware, fidelity: Fidelity, w: &Workload) -> Outcome {
    let spec = RunSpec { config, hw, fidelity };
    simulate_all(&spec, w).unwrap_or_else(|e| panic!("{} {fidelity:?}: {e}", config.name()))
}

/// [`simulate`] of a configuration given by name, on the default hardware.
pub fn simulate_named(name: &str, fidelity: Fidelity, w: &Workload) -> Outcome {
    simulate(name.parse().unwrap(), Hardware::default(), fidelity, w)
}

/// The cycle-level stack testbench: `work` through `unit` with `opts`, scoreboard on; panics
/// naming the configuration if a check fails.
pub fn run_stack(
    unit: &mut StandaloneStack,
    work: impl IntoIterator<Item = WarpWork>,
    opts: CycleOpts,
) -> RunSummary {
    let cfg = *unit.manager().config();
    run_cycle(unit, work, opts, &mut NullSink).unwrap_or_else(|e| panic!("{}: {e}", cfg.name()))
}

/// The stack testbench's options for random streams: gaps of up to 6 idle cycles between a
/// lane's commands, drawn from `seed`; the scoreboard checks every pop, not every cycle.
pub fn stack_opts(seed: u64) -> CycleOpts {
    CycleOpts { max_gap: 6, seed, check_every_cycle: false, max_cycles: 20_000_000, lockstep: false }
}

/// One warp of `cfg` (a single warp of its size) whose lanes all run the same random stream in
/// lockstep, global latency 50: every SH access of a round hits the same entry index in every
/// thread's queue. `plant` may plant a bug in the stack unit first. The run's costs.
pub fn run_lockstep(cfg: Config, plant: impl FnOnce(&mut StandaloneStack)) -> UnitStats {
    let lanes = cfg.warp_size as usize;
    let work = vec![WarpWork { lanes: vec![Some(stream(9, 40)); lanes] }];
    let mut unit = StandaloneStack::new(Config { warps: 1, ..cfg }, 50).unwrap();
    plant(&mut unit);
    let o = CycleOpts { max_gap: 0, lockstep: true, ..stack_opts(4) };
    run_stack(&mut unit, work, o).stats
}

/// The property the scoreboard finds violated when `work` runs through `unit` (which carries a
/// planted bug); panics if the run ends clean or stops for another reason.
pub fn violated(unit: &mut StandaloneStack, work: Vec<WarpWork>, opts: CycleOpts) -> Property {
    let name = unit.manager().config().name();
    match run_cycle(unit, work, opts, &mut NullSink) {
        Err(HarnessError::Violation { violation, .. }) => violation.property,
        other => panic!("{name}: the planted bug escaped the scoreboard: {other:?}"),
    }
}
