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
        // 1 + 2 * gamma(3): the relative error bound of the far distance (Ize 2013).
        const FAR_SCALE: f32 = 1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);
        let mut near = self.tmin;
        let mut far = tmax;
        for axis in 0..3 {
            let (o, inv) = (self.origin[axis], self.inv_dir[axis]);
            let (lo, hi) = (aabb.min[axis], aabb.max[axis]);
            if !inv.is_finite() {
                // Parallel to this slab (direction component is +0, -0 or subnormal).
                if o < lo || o > hi {
                    return None;
                }
                continue;
            }
            let (mut t0, mut t1) = ((lo - o) * inv, (hi - o) * inv);
            if t0 > t1 {
                std::mem::swap(&mut t0, &mut t1);
            }
            near = near.max(t0);
            far = far.min(t1 * FAR_SCALE);
            if near > far {
                return None;
            }
        }
        Some(near)
    }
}

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
