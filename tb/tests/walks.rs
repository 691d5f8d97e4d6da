//! Walk-driven rays on the cycle-level GPU: the RT unit pulls each ray's operations from its walk
//! as the stack answers, in the cycle it answers, so a stack that drops entries (`+RT`) makes the
//! walk restart. A toy walk (no BVH) pins the coupling down: it must see every node it needs
//! exactly once outside restarts, whatever the stack dropped.

use std::collections::HashMap;

use rtl::config::Config;
use rtl::gpu::Gpu;
use rtl::ray_op::{NodeKind, Popped, RayOp, Walks, WarpJob};
use rtl::rt_unit::RunError;
use rtl::trace::NullSink;

/// Node `k` of a ray's list, at a 64-byte address of its own.
fn addr(job: u64, lane: u32, k: u64) -> u64 {
    0x10_0000 + ((job * 32 + u64::from(lane)) * 64 + k) * 64
}

fn visit(a: u64) -> RayOp {
    RayOp::Visit { addr: a, kind: NodeKind::Internal, bytes: 64 }
}

/// Each ray visits nodes 0..n in order: its first segment pushes n−1 … 1 and visits 0; each pop
/// visits the popped node. On Restart the walk knows the next node it needs (one past the last
/// it visited): it pushes what is left after that one again and visits it.
#[derive(Default)]
struct Countdown {
    n: u64,
    /// Per ray: the last node visited, the unbounded reference stack, restarts.
    rays: HashMap<(u64, u32), (u64, Vec<u64>, u64)>,
    /// Plant a walk that ignores Restart: it goes on as if the pop had answered.
    ignore_restart: bool,
}

impl Countdown {
    fn segment(&self, job: u64, lane: u32, from: u64, stack: &mut Vec<u64>, ops: &mut Vec<RayOp>) {
        for k in (from + 1..self.n).rev() {
            ops.push(RayOp::Push(addr(job, lane, k)));
            stack.push(addr(job, lane, k));
        }
        ops.push(visit(addr(job, lane, from)));
    }
}

impl Walks for Countdown {
    fn resume(
        &mut self,
        job: u64,
        lane: u32,
        answer: Option<Popped>,
        ops: &mut Vec<RayOp>,
    ) -> Result<(), String> {
        let me = self;
        let n = me.n;
        let ignore = me.ignore_restart;
        let mut ray = me.rays.remove(&(job, lane)).unwrap_or((0, Vec::new(), 0));
        let next = match answer {
            None => 0,
            Some(Popped::Entry(a)) => {
                let want = ray.1.pop().ok_or("a pop answered with nothing owed")?;
                if a != want {
                    return Err(format!("popped {a:#x}, expected {want:#x}"));
                }
                ray.0 + 1
            }
            Some(Popped::Restart) if ignore => {
                ray.1.pop();
                ray.0 + 1
            }
            Some(Popped::Restart) => {
                ray.1.clear();
                ray.2 += 1;
                let mut stack = Vec::new();
                me.segment(job, lane, ray.0 + 1, &mut stack, ops);
                ray.1 = stack;
                ray.0 += 1;
                if ray.0 + 1 < n {
                    ops.push(RayOp::Pop(*ray.1.last().unwrap()));
                }
                me.rays.insert((job, lane), ray);
                return Ok(());
            }
        };
        if answer.is_none() {
            me.segment(job, lane, 0, &mut ray.1, ops);
        } else {
            ops.push(visit(addr(job, lane, next)));
        }
        ray.0 = next;
        if next + 1 < n {
            ops.push(RayOp::Pop(*ray.1.last().ok_or("nothing left to pop")?));
        }
        me.rays.insert((job, lane), ray);
        Ok(())
    }
}

fn run(cfg: &str, n: u64, ignore_restart: bool) -> Result<(rtl::gpu::GpuReport, u64), RunError> {
    let cfg: Config = cfg.parse().unwrap();
    let mut walks = Countdown { n, ignore_restart, ..Countdown::default() };
    let jobs: Vec<WarpJob> =
        (0..6).map(|j| WarpJob { lanes: vec![Some(Vec::new()); 32], walk: Some(j) }).collect();
    let r = Gpu::paper(cfg).unwrap().run_walks(
        jobs,
        &mut walks,
        &mut NullSink,
        u64::MAX,
        |_| {},
        &mut Vec::new(),
    )?;
    let restarts = walks.rays.values().map(|r| r.2).sum();
    Ok((r, restarts))
}

#[test]
fn a_dropping_stack_makes_the_walk_restart_and_every_node_is_visited_once_outside_restarts() {
    let n = 7;
    let rays = 6 * 32;
    // A stack deep enough for the whole list never drops: the toy walk's visits and pops only.
    let (full, none) = run("RB_8+RT", n, false).unwrap();
    assert_eq!((none, full.stack.drops, full.stack.restarts), (0, 0, 0));
    assert_eq!(full.visits, rays * n);
    // RB_2 drops 3 of the 5 entries pushed at the start: the ray restarts after popping two.
    let (short, restarts) = run("RB_2+RT", n, false).unwrap();
    assert_eq!(short.stack.restarts, restarts, "every Restart the stack answered reached a walk");
    assert!(restarts >= rays, "each ray restarts at least once: {restarts}");
    assert!(short.stack.drops > 0);
    assert_eq!(short.visits, rays * n, "no node visited twice: the walk goes on where it was");
    // The same with an SH level below the RB.
    let (sms, r2) = run("RB_1+SH_2+SK+RA+RT", n, false).unwrap();
    assert_eq!((sms.stack.restarts, sms.visits), (r2, rays * n));
    assert_eq!(sms.stack.global_accesses(), 0, "a restart design never touches global memory");
}

#[test]
fn a_walk_that_ignores_restart_is_stopped() {
    let e = run("RB_2+RT", 7, true).unwrap_err();
    assert!(matches!(e, RunError::Walk { .. } | RunError::Stack { .. }), "{e}");
    println!("{e}");
}

/// A flat BVH in the nearest-child order (what the restart trail walks) on the built-in clutter
/// scene.
fn flat_workload(
    scene: &tb::workload::scene::Scene,
    bvh: tb::workload::bvh::BvhKind,
) -> tb::workload::Workload<'_> {
    use tb::workload::{traverse::ChildOrder, Accel, Workload, WorkloadOpts};
    let opts = WorkloadOpts {
        order: ChildOrder::Nearest,
        accel: Accel::Flat,
        bvh,
        ..WorkloadOpts::quick(scene, 24)
    };
    Workload::new(scene, opts).unwrap()
}

/// On a real scene the restart designs run at the cycle level with every ray's closest hit
/// checked against the full-stack walk (the run fails otherwise), on both BVH layouts, with and
/// without an SH level and reallocation; short stacks restart, and nothing goes off chip for the
/// stack.
#[test]
fn restart_designs_walk_a_real_scene_with_every_hit_checked() {
    use tb::run::sim::Fidelity;
    use tb::workload::bvh::BvhKind;
    let scene = tb::load_scene("clutter").unwrap();
    for bvh in [BvhKind::Bvh6, BvhKind::Bvh2] {
        let w = flat_workload(&scene, bvh);
        for name in ["RB_1+RT", "RB_2+SH_2+SK+RA+RT"] {
            let o = tb::testing::simulate_named(name, Fidelity::Cycle, &w);
            println!("{bvh:?} {name}: {:?}", o.stack);
            assert!(o.stack.drops > 0 && o.stack.restarts > 0, "{bvh:?} {name}: {:?}", o.stack);
            assert_eq!(o.stack.global_accesses(), 0, "{bvh:?} {name}");
            assert!(o.pops_checked > 0);
        }
    }
}

/// The stack's planted drop bugs, on a real scene's walks: the walk's own check of each popped
/// entry against its unbounded reference stack stops the run.
#[test]
fn a_stack_that_drops_wrongly_is_caught_by_the_walks_on_a_real_scene() {
    use rtl::stack_manager::Mutant;
    use tb::run::walked::TreeWalks;
    use tb::workload::bvh::BvhKind;
    use tb::workload::restart::{default_levels, RestartTree};
    let scene = tb::load_scene("clutter").unwrap();
    let w = flat_workload(&scene, BvhKind::Bvh6);
    let o = w.opts();
    let tree = RestartTree::new(w.bvh(), &scene.primitives, o.order, default_levels(o.bvh)).unwrap();
    let rays: Vec<_> = (0..w.num_warps()).flat_map(|i| w.warp_rays(i)).collect();
    let cfg: Config = "RB_2+SH_2+RT".parse().unwrap();
    for (policy, what) in [(None, "the design"), (Some(Mutant::DropsNewest), "drops-newest")] {
        let mut walks = TreeWalks::new(&tree, &scene.primitives, rays.clone());
        let jobs = walks.jobs();
        let policy = policy.map_or(rtl::stack_manager::StackPolicy::of(&cfg), |m| m.policy());
        let gpu = Gpu::paper_with(cfg, policy).unwrap();
        let r = gpu.run_walks(jobs, &mut walks, &mut NullSink, u64::MAX, |_| {}, &mut Vec::new());
        match (what, r) {
            ("the design", r) => {
                r.unwrap();
                assert_eq!((walks.live(), walks.counts.rays_checked), (0, walks.rays()));
            }
            (_, Ok(_)) => panic!("{what} survived the walks"),
            (_, Err(e)) => {
                println!("{what}: {e}");
                assert!(matches!(e, RunError::Walk { .. } | RunError::PopMismatch { .. }), "{e}");
            }
        }
    }
}

/// From the command line: with a restart design among the configurations, every configuration of
/// the run walks a flat BVH in nearest order by default (and the report says so); asking for
/// another order or structure, or for the bench (which also runs the functional level), is a
/// one-line error naming the flag and the design.
#[test]
fn restart_designs_set_the_workload_they_need_or_say_why_not() {
    let sms = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_sms")).args(args).output().expect("sms runs")
    };
    let tiny = ["--scene", "wknd", "--res", "16x16", "--spp", "1", "-q", "--json"];
    let o = sms(&[&["run", "-c", "RB_8,RB_2+RT"][..], &tiny].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let w = &report["workload"];
    // The JSON leaves out `accel` when it is flat (docs/json.md).
    assert_eq!(
        (w["accel"].as_str().unwrap_or("flat"), w["order"].as_str()),
        ("flat", Some("nearest")),
        "{w}"
    );
    // Without a restart design the defaults are the paper's.
    let o = sms(&[&["run", "-c", "RB_8"][..], &tiny].concat());
    let report: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let w = &report["workload"];
    assert_eq!((w["accel"].as_str(), w["order"].as_str()), (Some("two-level"), Some("vulkansim")), "{w}");
    for (args, expected) in [
        (
            &["run", "-c", "RB_2+RT", "--order", "vulkansim"][..],
            "--order vulkansim: RB_2+RT is a restart design",
        ),
        (
            &["run", "-c", "RB_8,RB_2+RT", "--accel", "two-level"][..],
            "--accel two-level: RB_2+RT is a restart design",
        ),
        (
            &["bench", "-c", "RB_4+RT", "--scenes", "wknd"][..],
            "--config RB_4+RT: a restart design runs at the cycle level only",
        ),
    ] {
        let o = sms(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(err.contains(expected), "{args:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: one line: {err}");
    }
}
