//! Rays, primitives and the two intersection tests every traversal shares.
//!
//! The traversal model must never lose or invent a hit because of floating-point corner cases, or
//! its node sequences would not be those of a correct RT unit. So the box test is a slab test that
//! treats axis-parallel directions (including `-0.0`) explicitly and widens the far distance by
//! the rounding bound of Ize ("Robust BVH Ray Traversal", JCGT 2013), and the triangle test is the
//! watertight test of Woop, Benthin and Wald (JCGT 2013): no NaN can reach a comparison.

use glam::{DVec3, Vec3, Vec3A};
use obvhs::{aabb::Aabb, triangle::Triangle, Boundable};

use crate::workload::trace::FetchKind;

/// A ray with its precomputed reciprocal direction. `tmax` is kept by the caller because it
/// shrinks as closer hits are found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3A,
    pub dir: Vec3A,
    inv_dir: Vec3A,
    pub tmin: f32,
}

impl Ray {
    pub fn new(origin: Vec3A, dir: Vec3A, tmin: f32) -> Self {
        Ray { origin, dir, inv_dir: dir.recip(), tmin }
    }

    /// The same ray in obvhs's representation. obvhs takes the CWBVH traversal octant from the
    /// direction's sign bits but its reciprocal from the value, so `-0.0` would disagree with
    /// itself and miss; adding `+0.0` turns `-0.0` into `+0.0` and changes nothing else.
    pub fn to_obvhs(&self, tmax: f32) -> obvhs::ray::Ray {
        obvhs::ray::Ray::new(self.origin, self.dir + Vec3A::ZERO, self.tmin, tmax)
    }

    pub fn at(&self, t: f32) -> Vec3A {
        self.origin + self.dir * t
    }

    /// Entry distance of the ray into `aabb` within `[tmin, tmax]`, or `None` on a miss.
    pub fn hit_box(&self, aabb: &Aabb, tmax: f32) -> Option<f32> {
        let mut near = self.tmin;
        let mut far = tmax;
        for axis in 0..3 {
            let (o, inv) = (self.origin[axis], self.inv_dir[axis]);
            let (lo, hi) = (aabb.min[axis], aabb.max[axis]);
            if !inv.is_finite() {
                // Parallel to this slab (direction component is +0, -0 or subnormal).
                if outside_slab(o, lo, hi) {
                    return None;
                }
                continue;
            }
            (near, far) = clip_to_slab(near, far, (lo - o) * inv, (hi - o) * inv);
            if near > far {
                return None;
            }
        }
        Some(near)
    }

    /// [`Ray::hit_box`] of up to [`BOX_LANES`] boxes (a BVH6 node's children): `near[k]` is box
    /// `k`'s entry distance where bit `k` of the returned mask is set (a hit), and the other bits
    /// are clear. Per box and axis the same operations in the same order as `hit_box`, so the
    /// same results to the bit (tested against it), but without its branches: the slab
    /// distances of all three axes in one vector operation, the axes the ray is parallel to
    /// found once for all boxes, and a box that misses on one axis still computed on the others
    /// (its near distance can only grow and its far distance only shrink, so it still misses; as
    /// in `hit_box`, a ray parallel to all three axes is never tested against `tmax`). Panics if
    /// there are more boxes than lanes.
    pub fn hit_boxes<'b>(
        &self,
        boxes: impl ExactSizeIterator<Item = &'b Aabb>,
        tmax: f32,
        near: &mut [f32; BOX_LANES],
    ) -> u32 {
        let n = boxes.len();
        assert!(n <= BOX_LANES, "{n} boxes, at most {BOX_LANES} at once");
        // The axes the ray is not parallel to (`hit_box` compares the distances only after one).
        let finite = [0, 1, 2].map(|axis| self.inv_dir[axis].is_finite());
        let compared = finite.contains(&true);
        let mut mask = 0;
        for (k, b) in boxes.enumerate() {
            // Both slabs' distances on all three axes at once (per axis the same operations).
            let (t0s, t1s) = ((b.min - self.origin) * self.inv_dir, (b.max - self.origin) * self.inv_dir);
            let mut miss = false;
            let (mut lo, mut hi) = (self.tmin, tmax);
            for axis in 0..3 {
                if finite[axis] {
                    (lo, hi) = clip_to_slab(lo, hi, t0s[axis], t1s[axis]);
                } else {
                    miss |= outside_slab(self.origin[axis], b.min[axis], b.max[axis]);
                }
            }
            // `hit_box`'s test (`near > far` is a miss), so that it agrees with it even on a NaN.
            miss |= compared && lo > hi;
            near[k] = lo;
            mask |= u32::from(!miss) << k;
        }
        mask
    }
}

/// How many boxes [`Ray::hit_boxes`] tests at once: a BVH6 node's children, rounded up.
pub const BOX_LANES: usize = 8;

/// The entry and exit distances `(near, far)` narrowed by one slab the ray crosses at `t0` and
/// `t1` (in either order), the exit widened by its rounding bound: the step [`Ray::hit_box`] and
/// [`Ray::hit_boxes`] share, so that they agree to the bit.
#[inline]
fn clip_to_slab(near: f32, far: f32, mut t0: f32, mut t1: f32) -> (f32, f32) {
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    (near.max(t0), far.min(t1 * FAR_SCALE))
}

/// A ray parallel to a slab, at `o` on its axis, misses every box whose slab `[lo, hi]` does
/// not hold `o` (written so that a NaN misses nothing, as both box tests need).
#[inline]
fn outside_slab(o: f32, lo: f32, hi: f32) -> bool {
    o < lo || o > hi
}

/// 1 + 2 * gamma(3): the relative error bound of a box's far distance (Ize 2013).
const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Watertight ray-triangle distance in `(ray.tmin, tmax)`, or `f32::INFINITY` on a miss.
///
/// Woop, Benthin and Wald's test, evaluated in `f64`: the products of the `f32` inputs are exact
/// there, so neighbouring triangles agree on every shared edge (no ray slips between them), and
/// nothing overflows or underflows for coordinates from 1e-30 to 1e30 (in `f32` the edge
/// functions overflow at about 1e19 and every ray would leak).
pub fn hit_triangle(ray: &Ray, tri: &Triangle, tmax: f32) -> f32 {
    let d = DVec3::from(Vec3::from(ray.dir));
    let kz = d.abs().max_position();
    let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    let o = DVec3::from(Vec3::from(ray.origin));
    let rel = |v: Vec3A| DVec3::from(Vec3::from(v)) - o;
    let (a, b, c) = (rel(tri.v0), rel(tri.v1), rel(tri.v2));
    let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
    let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
    let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
    let (u, v, w) = (cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax);
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return f32::INFINITY;
    }
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return f32::INFINITY;
    }
    let t = ((u * (sz * a[kz]) + v * (sz * b[kz]) + w * (sz * c[kz])) / det) as f32;
    if t > ray.tmin && t < tmax {
        t
    } else {
        f32::INFINITY
    }
}

/// A sphere, traced as a procedural primitive (intersection shader) the way WKND is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3A,
    pub radius: f32,
}

impl Boundable for Sphere {
    fn aabb(&self) -> Aabb {
        Aabb::new(self.center - Vec3A::splat(self.radius), self.center + Vec3A::splat(self.radius))
    }
}

impl Sphere {
    /// Nearest distance in `(ray.tmin, tmax)`, or `f32::INFINITY`.
    pub fn hit(&self, ray: &Ray, tmax: f32) -> f32 {
        let oc = ray.origin - self.center;
        let a = ray.dir.length_squared();
        let half_b = oc.dot(ray.dir);
        let c = oc.length_squared() - self.radius * self.radius;
        let disc = half_b * half_b - a * c;
        // Also rejects a NaN discriminant.
        if disc.is_nan() || disc < 0.0 {
            return f32::INFINITY;
        }
        let root = disc.sqrt();
        [(-half_b - root) / a, (-half_b + root) / a]
            .into_iter()
            .find(|&t| t > ray.tmin && t < tmax)
            .unwrap_or(f32::INFINITY)
    }
}

/// The primitives of a scene: triangles, or spheres for the procedural WKND scene.
#[derive(Clone, Debug)]
pub enum Primitives {
    Triangles(Vec<Triangle>),
    Spheres(Vec<Sphere>),
}

impl Primitives {
    pub fn len(&self) -> usize {
        match self {
            Primitives::Triangles(t) => t.len(),
            Primitives::Spheres(s) => s.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of triangles (0 for procedural scenes).
    pub fn triangle_count(&self) -> usize {
        match self {
            Primitives::Triangles(t) => t.len(),
            Primitives::Spheres(_) => 0,
        }
    }

    /// The node kind an RT unit reports when it tests one of these primitives.
    pub fn kind(&self) -> FetchKind {
        match self {
            Primitives::Triangles(_) => FetchKind::Triangle,
            Primitives::Spheres(_) => FetchKind::Procedural,
        }
    }

    pub fn hit(&self, prim: usize, ray: &Ray, tmax: f32) -> f32 {
        match self {
            Primitives::Triangles(t) => hit_triangle(ray, &t[prim], tmax),
            Primitives::Spheres(s) => s[prim].hit(ray, tmax),
        }
    }

    /// Unit geometric normal at `point` on primitive `prim`, facing against `dir`.
    pub fn normal(&self, prim: usize, point: Vec3A, dir: Vec3A) -> Vec3A {
        let n = self.outward_normal(prim, point);
        if n.dot(dir) > 0.0 {
            -n
        } else {
            n
        }
    }

    /// The unit normal of primitive `prim` at `point` as its geometry defines it, not turned
    /// towards any ray: a triangle's by its winding (counter-clockwise front), a sphere's
    /// outwards.
    pub fn outward_normal(&self, prim: usize, point: Vec3A) -> Vec3A {
        match self {
            Primitives::Triangles(t) => t[prim].compute_normal(),
            Primitives::Spheres(s) => (point - s[prim].center).normalize_or_zero(),
        }
    }

    /// Bounding box of the whole scene.
    pub fn bounds(&self) -> Aabb {
        let mut b = Aabb::empty();
        match self {
            Primitives::Triangles(t) => t.iter().for_each(|t| b = b.union(&t.aabb())),
            Primitives::Spheres(s) => s.iter().for_each(|s| b = b.union(&s.aabb())),
        }
        b
    }

    /// Closest hit by testing every primitive: the oracle for the traversals.
    pub fn brute_force_hit(&self, ray: &Ray, tmax: f32) -> Option<(usize, f32)> {
        let mut best = None;
        let mut t_best = tmax;
        for prim in 0..self.len() {
            let t = self.hit(prim, ray, t_best);
            if t < t_best {
                t_best = t;
                best = Some((prim, t));
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A coordinate: ordinary values, the box and ray corner cases (zeros of both signs, values
    /// on a slab's plane, infinities as empty boxes have) and, rarely, NaN.
    fn coord() -> impl Strategy<Value = f32> {
        prop_oneof![
            8 => -4.0f32..4.0,
            2 => prop::sample::select(vec![0.0, -0.0, 1.0, -1.0, 0.5]),
            1 => prop::sample::select(vec![f32::INFINITY, f32::NEG_INFINITY, 1e-40, -1e-40, 3e38]),
            1 => Just(f32::NAN),
        ]
    }

    fn vec3() -> impl Strategy<Value = Vec3A> {
        (coord(), coord(), coord()).prop_map(|(x, y, z)| Vec3A::new(x, y, z))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]

        /// The batched box test answers every box exactly as the one-box test: the same hits
        /// and the same entry distances to the bit.
        #[test]
        fn hit_boxes_agree_with_hit_box(
            origin in vec3(),
            dir in vec3(),
            tmin in prop_oneof![Just(0.0f32), 0.0f32..1.0],
            tmax in prop_oneof![Just(f32::INFINITY), 0.0f32..10.0],
            corners in prop::collection::vec((vec3(), vec3()), 0..=BOX_LANES),
        ) {
            let ray = Ray::new(origin, dir, tmin);
            let boxes: Vec<Aabb> = corners.iter().map(|&(a, b)| Aabb { min: a, max: b }).collect();
            let mut near = [f32::NAN; BOX_LANES];
            let mask = ray.hit_boxes(boxes.iter(), tmax, &mut near);
            prop_assert_eq!(mask >> boxes.len(), 0, "bits beyond the boxes");
            for (k, b) in boxes.iter().enumerate() {
                let batched = (mask & 1 << k != 0).then_some(near[k]);
                prop_assert_eq!(batched.map(f32::to_bits), ray.hit_box(b, tmax).map(f32::to_bits), "box {}", k);
            }
        }
    }

    /// Every ray of a grid of corner cases (directions parallel to one, two or all three axes,
    /// with zeros of both signs and a subnormal; origins on the boxes' planes and NaN; `tmin`
    /// above and below `tmax`) against boxes that are flat, empty, unbounded or ordinary: the
    /// same answers as the one-box test, and one box hit only thanks to the widened far distance.
    /// Deterministic, unlike the random search above, which
    /// found the ray parallel to all three axes with `tmin > tmax` only now and then.
    #[test]
    fn hit_boxes_agree_with_hit_box_on_corner_cases() {
        let dirs = [0.0, -0.0, 1e-40, 1.0, -1.0];
        let origins = [-1.0, 0.0, 0.5, f32::NAN];
        let boxes = [
            Aabb { min: Vec3A::ZERO, max: Vec3A::ONE },
            Aabb { min: Vec3A::ZERO, max: Vec3A::ZERO },
            Aabb { min: Vec3A::splat(0.5), max: Vec3A::new(0.5, 2.0, 0.5) },
            Aabb::empty(),
            Aabb { min: Vec3A::NEG_INFINITY, max: Vec3A::INFINITY },
            Aabb { min: Vec3A::new(-2.0, 0.0, -0.0), max: Vec3A::new(-1.0, 1e-40, 0.0) },
            // Entered on y one rounding step after it is left on x: a hit only by the widened
            // far distance (for the ray from the origin along (1, 1, 0)).
            Aabb { min: Vec3A::new(0.0, 1.0 + f32::EPSILON, -1.0), max: Vec3A::new(1.0, 2.0, 1.0) },
        ];
        let mut checked = 0;
        for d in grid3(&dirs) {
            for o in grid3(&origins) {
                for (tmin, tmax) in [(0.0, f32::INFINITY), (0.0, 0.0), (0.6, 0.0), (0.6, 3.0)] {
                    let ray = Ray::new(o, d, tmin);
                    let mut near = [0.0; BOX_LANES];
                    let mask = ray.hit_boxes(boxes.iter(), tmax, &mut near);
                    for (k, b) in boxes.iter().enumerate() {
                        let batched = (mask & 1 << k != 0).then_some(near[k].to_bits());
                        assert_eq!(batched, ray.hit_box(b, tmax).map(f32::to_bits), "{ray:?} {tmax} box {k}");
                        checked += 1;
                    }
                }
            }
        }
        assert_eq!(checked, 125 * 64 * 4 * boxes.len());
    }

    /// Every vector with components from `v`.
    fn grid3(v: &[f32]) -> impl Iterator<Item = Vec3A> + '_ {
        v.iter().flat_map(move |&x| v.iter().flat_map(move |&y| v.iter().map(move |&z| Vec3A::new(x, y, z))))
    }

    #[test]
    #[should_panic(expected = "at most 8 at once")]
    fn hit_boxes_refuses_more_boxes_than_lanes() {
        let ray = Ray::new(Vec3A::ZERO, Vec3A::X, 0.0);
        let boxes = vec![Aabb { min: Vec3A::ZERO, max: Vec3A::ONE }; BOX_LANES + 1];
        ray.hit_boxes(boxes.iter(), 1.0, &mut [0.0; BOX_LANES]);
    }
}
