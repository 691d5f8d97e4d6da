//! The restart-trail walk (`tb::workload::restart`) driven by short stacks (`tb::run::steps`):
//! closest hits equal the full-stack walk's for every ray, a stack deeper than the BVH gives the
//! full walk exactly, and each check catches a bug planted through the walk's trail rules or
//! the stack it is driven by.

mod common;

use rtl::ray_op::{NodeKind, RayOp, Walk};
use tb::load_scene;
use tb::run::steps::{check_ray, drive, full_walk, measure, Counts, DropOldest, ShortStack};
use tb::workload::bvh::Bvh;
use tb::workload::geometry::Ray;
use tb::workload::restart::{default_levels, RankedTrail, RestartTree, RestartWalk, TrailRules};
use tb::workload::trace::{RayTrace, TraceOp};
use tb::workload::traverse::{trace, ChildOrder};
use tb::workload::{Accel, BvhKind, Workload, WorkloadOpts};
use tb::Scene;

const SCENES: [&str; 3] = ["wknd", "grid", "clutter"];
const KINDS: [BvhKind; 2] = [BvhKind::Bvh2, BvhKind::Bvh6];

/// 24×24 pixels, one sample, two bounces, nearest order on a flat `bvh`.
fn workload(scene: &Scene, bvh: BvhKind) -> Workload<'_> {
    let opts = WorkloadOpts {
        bvh,
        accel: Accel::Flat,
        order: ChildOrder::Nearest,
        width: 24,
        height: 24,
        spp: 1,
        max_bounces: 2,
        ..WorkloadOpts::for_scene(scene)
    };
    Workload::new(scene, opts).expect("workload")
}

fn tree<'a>(w: &'a Workload, scene: &'a Scene) -> RestartTree<'a> {
    let kind = w.bvh().kind();
    RestartTree::new(w.bvh(), &scene.primitives, ChildOrder::Nearest, default_levels(kind)).expect("tree")
}

#[test]
fn closest_hits_equal_the_full_walk_with_1_2_and_5_entries() {
    for name in SCENES {
        let scene = load_scene(name).unwrap();
        for kind in KINDS {
            let w = workload(&scene, kind);
            let t = tree(&w, &scene);
            let rays = w.rays();
            let steps = measure(&t, &scene.primitives, &rays, &[1, 2, 5], |_, _| {})
                .unwrap_or_else(|e| panic!("{name} {kind:?}: {e}"));
            assert_eq!(steps.full.rays, rays.len() as u64);
            for size in &steps.sizes {
                let c = &size.counts;
                assert_eq!(c.rays, rays.len() as u64);
                if size.entries < 5 {
                    assert!(c.restarts > 0, "{name} {kind:?} N={}: no restart exercised", size.entries);
                }
                // A restart re-fetches at least the root.
                assert!(c.refetched >= c.restarts);
            }
            // Fewer entries, more restarts.
            let restarts: Vec<u64> = steps.sizes.iter().map(|s| s.counts.restarts).collect();
            assert!(restarts.windows(2).all(|w| w[0] >= w[1]), "{name} {kind:?}: {restarts:?}");
        }
    }
}

/// The node visits of the full-stack walk of `ray` as RT-unit operations.
fn full_visits(t: &RestartTree, scene: &Scene, ray: &Ray) -> Vec<(u64, NodeKind)> {
    let mut rec = RayTrace::default();
    trace(t.bvh(), &scene.primitives, ray, f32::INFINITY, ChildOrder::Nearest, &mut rec);
    rec.ops()
        .filter_map(|op| match op {
            TraceOp::Visit { addr, kind } => Some((addr, tb::workload::trace::rtl_kind(kind))),
            _ => None,
        })
        .collect()
}

#[test]
fn a_stack_deeper_than_any_ray_needs_gives_the_full_walk_exactly() {
    for name in SCENES {
        let scene = load_scene(name).unwrap();
        for kind in KINDS {
            let w = workload(&scene, kind);
            let t = tree(&w, &scene);
            // A BVH2 walk holds at most one entry per level, a BVH6 walk five.
            let n = t.depth() * if kind == BvhKind::Bvh2 { 1 } else { 5 } + 1;
            for (i, ray) in w.rays().iter().enumerate() {
                let mut walk = RestartWalk::new(&t, *ray);
                let mut stack = DropOldest::new(n).unwrap();
                let mut ops = Vec::new();
                let mut counts = Counts::default();
                // Drive it while keeping every visit it makes.
                let mut recorder = Recording { walk: &mut walk, ops: &mut ops };
                drive(&mut recorder, &mut stack, &mut counts)
                    .unwrap_or_else(|e| panic!("{name} ray {i}: {e}"));
                assert_eq!((counts.drops, counts.restarts), (0, 0));
                let visits: Vec<(u64, NodeKind)> = ops
                    .iter()
                    .filter_map(|op| match *op {
                        RayOp::Visit { addr, kind, .. } => Some((addr, kind)),
                        _ => None,
                    })
                    .collect();
                assert_eq!(visits, full_visits(&t, &scene, ray), "{name} {kind:?} ray {i}");
                let mut full = Counts::default();
                assert_eq!(walk.hit(), full_walk(&t, &scene.primitives, ray, &mut full));
                assert_eq!((counts.pushes, counts.pops), (full.pushes, full.pops));
                assert_eq!(walk.refetched(), 0);
            }
        }
    }
}

/// A walk that also keeps a copy of every operation it emits.
struct Recording<'a, W> {
    walk: &'a mut W,
    ops: &'a mut Vec<RayOp>,
}

impl<W: Walk> Walk for Recording<'_, W> {
    fn resume(&mut self, answer: Option<rtl::ray_op::Popped>, ops: &mut Vec<RayOp>) -> Result<(), String> {
        let start = ops.len();
        self.walk.resume(answer, ops)?;
        self.ops.extend_from_slice(&ops[start..]);
        Ok(())
    }
}

#[test]
fn one_entry_restarts_and_still_finds_every_hit() {
    let scene = load_scene("clutter").unwrap();
    for kind in KINDS {
        let w = workload(&scene, kind);
        let t = tree(&w, &scene);
        let steps = measure(&t, &scene.primitives, &w.rays(), &[1], |_, _| {}).unwrap();
        let c = &steps.sizes[0].counts;
        // Nearly every push overflows one entry.
        assert!(c.restarts * 2 > c.rays, "{kind:?}: {} restarts for {} rays", c.restarts, c.rays);
        assert!(c.steps() > steps.full.steps());
    }
}

/// The first error a walk with `rules` driven by stacks from `stack` meets over the rays of
/// `scene`'s small workload on `kind`, naming the ray.
fn first_error<R: TrailRules + Copy, S: ShortStack>(
    scene: &str,
    kind: BvhKind,
    rules: R,
    stack: impl Fn() -> S,
) -> Option<String> {
    let scene = load_scene(scene).unwrap();
    let w = workload(&scene, kind);
    let t = tree(&w, &scene);
    for (i, ray) in w.rays().iter().enumerate() {
        let want = full_walk(&t, &scene.primitives, ray, &mut Counts::default());
        if let Err(e) = check_ray(&t, ray, rules, &mut stack(), want, &mut Counts::default()) {
            return Some(format!("ray {i}: {e}"));
        }
    }
    None
}

fn entries(n: usize) -> impl Fn() -> DropOldest {
    move || DropOldest::new(n).unwrap()
}

#[test]
fn the_product_rules_pass_where_the_planted_bugs_are_caught() {
    for kind in KINDS {
        for n in [1, 2, 3] {
            assert_eq!(first_error("clutter", kind, RankedTrail, entries(n)), None, "{kind:?} N={n}");
        }
    }
}

/// At a restart, takes the child of a level's rank in the order culled at the current `tmax`
/// (Laine's one bit per level relies on it), not in `Q_all`.
#[derive(Clone, Copy)]
struct CulledRank;
impl TrailRules for CulledRank {
    fn path(&self, rank: usize, alive: &[bool]) -> Option<usize> {
        alive.iter().enumerate().filter(|(_, a)| **a).nth(rank).map(|(k, _)| k)
    }
}

#[test]
fn a_rank_taken_in_the_culled_order_leads_a_restart_astray() {
    // The path child is culled at the shrunk tmax, so the culled order has no child of that
    // rank, or another one there.
    let e = first_error("clutter", BvhKind::Bvh6, CulledRank, entries(1)).expect("caught");
    assert!(
        ["names none of the", "re-enters a finished subtree", "closest hit"].iter().any(|m| e.contains(m)),
        "{e}"
    );
}

/// Marks no pushed sibling `last`.
#[derive(Clone, Copy)]
struct NeverLast;
impl TrailRules for NeverLast {
    fn last(&self, _: usize, _: usize) -> bool {
        false
    }
}

/// Marks every pushed sibling `last`.
#[derive(Clone, Copy)]
struct AlwaysLast;
impl TrailRules for AlwaysLast {
    fn last(&self, _: usize, _: usize) -> bool {
        true
    }
}

#[test]
fn a_wrong_last_bit_on_a_pushed_entry_is_caught() {
    for kind in KINDS {
        let e = first_error("clutter", kind, NeverLast, entries(64)).expect("caught");
        assert!(e.contains("has a sibling left, but the reference stack is empty"), "{e}");
    }
    // A BVH2 node pushes one sibling, always its level's last: only a wider node can set the
    // bit on a nearer one.
    // A nearer sibling marked last makes the next pop land on a shallower level, which then
    // marks the wrong subtree finished, or ends the ray with entries left.
    let e = first_error("clutter", BvhKind::Bvh6, AlwaysLast, entries(64)).expect("caught");
    assert!(
        e.contains("entries are left on the reference stack") || e.contains("re-enters a finished subtree"),
        "{e}"
    );
}

/// Pushes again, at a restart, every surviving sibling but the path child: the finished ones
/// before it too.
#[derive(Clone, Copy)]
struct RepushFinished;
impl TrailRules for RepushFinished {
    fn repush(&self, alive: &[usize], path: usize) -> Vec<usize> {
        alive.iter().copied().filter(|&k| k != path).collect()
    }
}

#[test]
fn a_restart_that_pushes_finished_siblings_again_is_caught_re_entering_them() {
    for kind in KINDS {
        let e = first_error("clutter", kind, RepushFinished, entries(1)).expect("caught");
        assert!(e.contains("re-enters a finished subtree"), "{kind:?}: {e}");
    }
}

/// At a restart's target level, moves on to the second surviving sibling, skipping the first.
#[derive(Clone, Copy)]
struct SkipOne;
impl TrailRules for SkipOne {
    fn resume(&self, alive_after: &[usize]) -> Option<usize> {
        (alive_after.len() > 1).then_some(1)
    }
}

#[test]
fn a_restart_that_skips_a_sibling_loses_hits_the_full_walk_finds() {
    let e = first_error("clutter", BvhKind::Bvh6, SkipOne, entries(1)).expect("caught");
    assert!(e.contains("closest hit") && e.contains("the full-stack walk's"), "{e}");
}

/// Drops the entry being pushed when full, instead of the oldest.
struct DropNewest(Vec<u64>, usize);
impl ShortStack for DropNewest {
    fn push(&mut self, entry: u64) -> Option<u64> {
        if self.0.len() == self.1 {
            return Some(entry);
        }
        self.0.push(entry);
        None
    }
    fn pop(&mut self) -> Option<u64> {
        self.0.pop()
    }
}

#[test]
fn a_stack_that_drops_its_newest_entry_answers_a_pop_with_the_wrong_entry() {
    for kind in KINDS {
        let stack = || DropNewest(Vec::new(), 2);
        let e = first_error("clutter", kind, RankedTrail, stack).expect("caught");
        assert!(e.contains("the reference stack's top is"), "{kind:?}: {e}");
    }
}

/// Drops its oldest entry when full but does not say so.
struct SilentDrop(DropOldest);
impl ShortStack for SilentDrop {
    fn push(&mut self, entry: u64) -> Option<u64> {
        self.0.push(entry);
        None
    }
    fn pop(&mut self) -> Option<u64> {
        self.0.pop()
    }
}

#[test]
fn a_stack_that_hides_its_drops_is_caught_restarting_without_a_drop() {
    for kind in KINDS {
        let e = first_error("clutter", kind, RankedTrail, || SilentDrop(DropOldest::new(2).unwrap()))
            .expect("caught");
        assert!(e.contains("a restart without a drop"), "{kind:?}: {e}");
    }
}

#[test]
fn a_bvh_deeper_than_the_trail_is_refused_before_any_ray() {
    let scene = load_scene("clutter").unwrap();
    let w = workload(&scene, BvhKind::Bvh2);
    let depth = tree(&w, &scene).depth();
    assert!(RestartTree::new(w.bvh(), &scene.primitives, ChildOrder::Nearest, depth).is_ok());
    let e = RestartTree::new(w.bvh(), &scene.primitives, ChildOrder::Nearest, depth - 1).err().unwrap();
    assert_eq!(
        e.to_string(),
        format!(
            "invalid option: the BVH2 is {depth} levels deep, deeper than the restart trail's {} levels",
            depth - 1
        )
    );
}

#[test]
fn hierarchies_and_orders_a_restart_cannot_reproduce_are_refused() {
    let scene = load_scene("grid").unwrap();
    let prims = &scene.primitives;
    let cw = Bvh::build(prims, BvhKind::Cwbvh).unwrap();
    let e = RestartTree::new(&cw, prims, ChildOrder::Nearest, 64).err().unwrap().to_string();
    assert!(e.contains("bvh cwbvh") && e.contains("use bvh bvh2 or bvh6"), "{e}");
    let b6 = Bvh::build(prims, BvhKind::Bvh6).unwrap();
    let e = RestartTree::new(&b6, prims, ChildOrder::VulkanSim, 64).err().unwrap().to_string();
    assert!(e.contains("order vulkansim") && e.contains("use order nearest"), "{e}");
    let tl = Bvh::TwoLevel(Box::new(
        tb::workload::bvh::TwoLevel::build(prims, &scene.objects).expect("two-level"),
    ));
    let e = RestartTree::new(&tl, prims, ChildOrder::Nearest, 64).err().unwrap().to_string();
    assert!(e.contains("accel two-level") && e.contains("use accel flat"), "{e}");
}

#[test]
fn sms_steps_refuses_what_a_restart_cannot_do_in_one_line() {
    for (args, want) in [
        (&["--entries", "2,0"][..], "--entries 0: a short stack of 0 entries holds nothing"),
        (&["--bvh", "cwbvh"], "--bvh cwbvh: the restart trail needs a child order"),
        (&["--order", "vulkansim"], "--order vulkansim: the restart trail needs a child order"),
        (&["--accel", "two-level"], "--accel two-level: the restart trail walks one flat BVH"),
    ] {
        let ran = common::sms_status(&[&["steps", "--scene", "grid"][..], args].concat());
        assert_eq!(ran.code, Some(1), "{args:?}");
        assert_eq!(ran.stderr.lines().count(), 1, "{args:?}: {}", ran.stderr);
        assert!(ran.stderr.starts_with(&format!("error: {want}")), "{args:?}: {}", ran.stderr);
    }
}

#[test]
fn sms_steps_reports_every_size_deterministically_with_provenance() {
    let args = ["steps", "--scene", "grid", "--res", "16x16", "--spp", "1", "--bounces", "1", "--json", "-q"];
    let out = common::sms(&args, &[]);
    assert_eq!(out, common::sms(&args, &[]), "same seed, same report");
    let json: serde_json::Value = serde_json::from_str(&out).expect("JSON");
    let rows = json["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 2, "BVH2 and BVH6");
    for row in rows {
        let sizes: Vec<u64> =
            row["sizes"].as_array().unwrap().iter().map(|s| s["entries"].as_u64().unwrap()).collect();
        assert_eq!(sizes, [2, 4, 5, 8]);
        assert!(row["full"]["rays"].as_u64().unwrap() > 0);
    }
    assert_eq!(json["provenance"]["order"], "nearest");
    let text = common::sms(&args[..args.len() - 2], &[]);
    assert!(text.starts_with("provenance: scene grid"), "{text}");
    assert!(text.contains("× full stack"), "{text}");
    let help = common::sms(&["steps", "--help"], &[]);
    for flag in ["--entries", "--all", "--levels", "--bvh", "--json"] {
        assert!(help.contains(flag), "{flag} missing from --help");
    }
}
