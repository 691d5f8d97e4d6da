//! Numerical stability under stress: adversarial rays must never slip through a closed mesh,
//! never produce NaN, and box tests must be right for ±0 directions and origins on faces — at
//! unit scale, at 1e30 and 1e-30, and far from the origin.

use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::triangle::Triangle;
use proptest::prelude::*;
use tb::workload::bvh::{Bvh, BvhKind};
use tb::workload::geometry::{hit_triangle, Primitives, Ray};
use tb::workload::traverse::trace;
use tb::workload::traverse::ChildOrder;

/// A closed cube surface, each face split into `n × n` quads of two triangles: every interior
/// edge is shared by two triangles and every interior vertex by six.
fn closed_cube(n: u32, center: Vec3A, half: f32) -> (Vec<Triangle>, Vec<Vec3A>) {
    let mut tris = Vec::new();
    let mut points = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let p = |i: u32, j: u32| {
                let (u, v) = (i as f32 / n as f32 * 2.0 - 1.0, j as f32 / n as f32 * 2.0 - 1.0);
                let mut c = [0.0f32; 3];
                c[axis] = sign;
                c[(axis + 1) % 3] = u;
                c[(axis + 2) % 3] = v;
                center + Vec3A::from(c) * half
            };
            for i in 0..n {
                for j in 0..n {
                    let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
                    tris.push(Triangle { v0: a, v1: b, v2: c });
                    tris.push(Triangle { v0: a, v1: c, v2: d });
                    // Adversarial targets: a vertex, an edge midpoint, the shared diagonal.
                    points.extend([a, (a + b) * 0.5, (a + c) * 0.5]);
                }
            }
        }
    }
    (tris, points)
}

/// Shoots rays from `origin` (inside the closed mesh) at every target and at `random` pseudo-
/// random directions; returns (rays, leaks, NaN distances).
fn shoot(
    tris: &[Triangle],
    targets: &[Vec3A],
    origin: Vec3A,
    random: u32,
    through_bvh: bool,
) -> (u64, u64, u64) {
    let prims = Primitives::Triangles(tris.to_vec());
    let bvh = through_bvh.then(|| Bvh::build(&prims, BvhKind::Bvh6).unwrap());
    let mut dirs: Vec<Vec3A> = targets.iter().map(|&t| t - origin).collect();
    let mut s = 0x1234_5678u64;
    for _ in 0..random {
        let mut c = [0.0f32; 3];
        for x in &mut c {
            s = tb::run::verify::harness::mix(s);
            *x = (s >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0;
        }
        dirs.push(Vec3A::from(c));
    }
    let (mut leaks, mut nans) = (0, 0);
    for d in dirs.iter().filter(|d| d.length_squared() > 0.0) {
        let ray = Ray::new(origin, *d, 0.0);
        let t = match &bvh {
            Some(b) => trace(b, &prims, &ray, f32::INFINITY, ChildOrder::Nearest, &mut ())
                .map_or(f32::INFINITY, |h| h.t),
            None => {
                tris.iter().map(|tri| hit_triangle(&ray, tri, f32::INFINITY)).fold(f32::INFINITY, f32::min)
            }
        };
        nans += u64::from(t.is_nan());
        leaks += u64::from(!t.is_finite());
    }
    (dirs.len() as u64, leaks, nans)
}

#[test]
fn no_ray_slips_through_shared_edges_and_vertices() {
    let (tris, targets) = closed_cube(8, Vec3A::ZERO, 1.0);
    // Off-centre origin so targets are not symmetric.
    let (rays, leaks, nans) = shoot(&tris, &targets, Vec3A::new(0.1, -0.2, 0.05), 20_000, false);
    assert_eq!((leaks, nans), (0, 0), "{rays} rays");
}

#[test]
fn a_million_adversarial_rays_through_the_bvh() {
    let (tris, targets) = closed_cube(16, Vec3A::ZERO, 1.0);
    let mut total = 0;
    for origin in [Vec3A::ZERO, Vec3A::new(0.3, 0.3, -0.7), Vec3A::new(-0.9, 0.0, 0.0)] {
        let (rays, leaks, nans) = shoot(&tris, &targets, origin, 330_000, true);
        assert_eq!((leaks, nans), (0, 0), "origin {origin}: {rays} rays");
        total += rays;
    }
    assert!(total >= 1_000_000, "{total} rays");
}

#[test]
fn huge_tiny_and_far_off_scenes_stay_watertight() {
    for (center, half) in [
        (Vec3A::ZERO, 1e30f32),
        (Vec3A::ZERO, 1e-30),
        (Vec3A::splat(1e6), 1e3),
        (Vec3A::new(-3e7, 1e7, 5e6), 1e5),
    ] {
        let (tris, targets) = closed_cube(6, center, half);
        let origin = center + Vec3A::new(0.1, -0.2, 0.05) * half;
        for bvh in [false, true] {
            let (rays, leaks, nans) = shoot(&tris, &targets, origin, 5_000, bvh);
            assert_eq!((leaks, nans), (0, 0), "center {center} half {half} bvh {bvh}: {rays} rays");
        }
    }
}

fn axis_value() -> impl Strategy<Value = f32> {
    prop_oneof![Just(0.0f32), Just(-0.0f32), -1.0f32..1.0, Just(1e-30f32), Just(-1e-30f32)]
}

proptest! {
    /// An origin inside a box (faces included) always hits it, whatever the direction,
    /// including ±0 and subnormal components; the entry distance is never NaN.
    #[test]
    fn origin_inside_or_on_a_face_always_hits(
        lo in prop::array::uniform3(-100.0f32..100.0),
        size in prop::array::uniform3(0.0f32..50.0),
        at in prop::array::uniform3(0.0f32..=1.0),
        on_face in 0usize..4,
        dir in prop::array::uniform3(axis_value()),
    ) {
        let lo = Vec3A::from(lo);
        let hi = lo + Vec3A::from(size);
        let mut o = lo + (hi - lo) * Vec3A::from(at);
        if on_face < 3 {
            o[on_face] = if at[on_face] < 0.5 { lo[on_face] } else { hi[on_face] };
        }
        prop_assume!(Vec3A::from(dir).length_squared() > 0.0);
        let ray = Ray::new(o, Vec3A::from(dir), 0.0);
        let hit = ray.hit_box(&Aabb::new(lo, hi), f32::INFINITY);
        prop_assert!(matches!(hit, Some(t) if !t.is_nan()), "{hit:?}");
    }

    /// A direction parallel to a slab (±0 component) with the origin outside that slab misses.
    #[test]
    fn parallel_outside_a_slab_misses(
        axis in 0usize..3,
        neg_zero in any::<bool>(),
        offset in 0.001f32..10.0,
        dir in prop::array::uniform3(-1.0f32..1.0),
    ) {
        let mut d = Vec3A::from(dir);
        d[axis] = if neg_zero { -0.0 } else { 0.0 };
        prop_assume!(d.length_squared() > 0.0);
        let mut o = Vec3A::splat(0.5);
        o[axis] = 1.0 + offset;
        let ray = Ray::new(o, d, 0.0);
        prop_assert_eq!(ray.hit_box(&Aabb::new(Vec3A::ZERO, Vec3A::ONE), f32::INFINITY), None);
    }
}
