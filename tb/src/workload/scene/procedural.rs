//! Built-in scenes that need no files, generated deterministically from hash noise.
//!
//! They give three stack-depth profiles: `wknd` (Ray Tracing in One Weekend's sphere field, as
//! procedural primitives like LumiBench WKND), `grid` (a tessellated height field: shallow stacks,
//! rays hit the first surface they meet) and `clutter` (small triangles scattered through a volume:
//! many overlapping boxes along every ray, deep stacks).

use glam::{vec3a, Vec3A};
use obvhs::triangle::Triangle;

use super::{Camera, RenderSettings, Scene};
use crate::workload::geometry::{Primitives, Sphere};
use crate::workload::rng::Rng;

pub const NAMES: [&str; 3] = ["wknd", "grid", "clutter"];

pub fn build(name: &str) -> Option<Scene> {
    let (primitives, camera) = match name {
        "wknd" => (wknd(), Camera::look_at([13.0, 2.0, 3.0], [0.0, 0.0, 0.0], 20.0)),
        "grid" => (grid(96), Camera::look_at([0.0, 1.2, 2.2], [0.0, 0.0, 0.0], 45.0)),
        "clutter" => (clutter(20_000), Camera::look_at([0.0, 0.3, 3.2], [0.0, 0.0, 0.0], 45.0)),
        _ => return None,
    };
    Some(Scene {
        name: name.to_owned(),
        objects: super::Objects::single(primitives.len()),
        primitives,
        camera,
        render: RenderSettings::default(),
        dropped_degenerate: 0,
        files: Vec::new(),
    })
}

fn wknd() -> Primitives {
    let mut spheres = vec![Sphere { center: vec3a(0.0, -1000.0, 0.0), radius: 1000.0 }];
    for a in -11..11 {
        for b in -11..11 {
            let mut rng = Rng::new(&[1, a as u64, b as u64]);
            let center = vec3a(a as f32 + 0.9 * rng.next_f32(), 0.2, b as f32 + 0.9 * rng.next_f32());
            if (center - vec3a(4.0, 0.2, 0.0)).length() > 0.9 {
                spheres.push(Sphere { center, radius: 0.2 });
            }
        }
    }
    for x in [0.0, -4.0, 4.0] {
        spheres.push(Sphere { center: vec3a(x, 1.0, 0.0), radius: 1.0 });
    }
    Primitives::Spheres(spheres)
}

fn grid(n: u32) -> Primitives {
    let height = |i: u32, j: u32| {
        let (x, z) = (i as f32 / n as f32 * 2.0 - 1.0, j as f32 / n as f32 * 2.0 - 1.0);
        let noise = Rng::new(&[2, i as u64, j as u64]).next_f32();
        vec3a(x, 0.15 * (3.0 * x).sin() * (2.0 * z).cos() + 0.02 * noise, z)
    };
    let mut tris = Vec::with_capacity((n * n * 2) as usize);
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (height(i, j), height(i + 1, j), height(i + 1, j + 1), height(i, j + 1));
            tris.push(Triangle { v0: a, v1: b, v2: c });
            tris.push(Triangle { v0: a, v1: c, v2: d });
        }
    }
    Primitives::Triangles(tris)
}

fn clutter(count: u64) -> Primitives {
    let tris = (0..count)
        .map(|i| {
            let mut rng = Rng::new(&[3, i]);
            let mut point = || vec3a(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - Vec3A::ONE;
            let center = point();
            let (e1, e2) = (point() * 0.06, point() * 0.06);
            Triangle { v0: center, v1: center + e1, v2: center + e2 }
        })
        .collect();
    Primitives::Triangles(tris)
}
