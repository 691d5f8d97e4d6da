//! The path tracer that produces the rays: primary rays through jittered pixel positions,
//! cosine-weighted diffuse bounces, a sky that ends escaping paths.
//!
//! Every random number is a hash of (seed, pixel, sample, bounce), so a ray can be regenerated
//! in any order and two runs with one seed trace identical rays. Shading is deliberately simple
//! (grey albedo times sky): the image only shows what was traced.

use std::f32::consts::TAU;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use glam::Vec3A;

use crate::error::{Error, Result};
use crate::workload::geometry::Ray;
use crate::workload::rng::Rng;
use crate::workload::scene::Camera;

/// Reflectance of every surface.
pub const ALBEDO: f32 = 0.7;

/// Generates camera and bounce rays for one frame.
#[derive(Clone, Copy, Debug)]
pub struct RayGen {
    eye: Vec3A,
    /// Image-plane vectors at unit distance: right (full width) and up (full height).
    right: Vec3A,
    up: Vec3A,
    forward: Vec3A,
    width: u32,
    height: u32,
    seed: u64,
    /// Distance a bounce ray starts off its surface, relative to the scene's size.
    offset: f32,
}

impl RayGen {
    pub fn new(camera: &Camera, width: u32, height: u32, seed: u64, scene_size: f32) -> Self {
        let forward = (camera.look_at - camera.eye).normalize_or(Vec3A::NEG_Z);
        let right = forward.cross(camera.up).normalize_or(Vec3A::X);
        let up = right.cross(forward);
        let half_h = (0.5 * camera.vfov.to_radians()).tan();
        let aspect = width as f32 / height.max(1) as f32;
        RayGen {
            eye: camera.eye,
            right: right * (2.0 * half_h * aspect),
            up: up * (2.0 * half_h),
            forward,
            width,
            height,
            seed,
            offset: scene_size.max(f32::MIN_POSITIVE) * 1e-5,
        }
    }

    fn rng(&self, pixel: u32, sample: u32, bounce: u32) -> Rng {
        Rng::new(&[self.seed, pixel as u64, sample as u64, bounce as u64])
    }

    /// The primary ray of sample `sample` of pixel `pixel` (row-major index, row 0 at the top).
    pub fn primary(&self, pixel: u32, sample: u32) -> Ray {
        let mut rng = self.rng(pixel, sample, 0);
        let x = ((pixel % self.width) as f32 + rng.next_f32()) / self.width as f32 - 0.5;
        let y = 0.5 - ((pixel / self.width) as f32 + rng.next_f32()) / self.height as f32;
        let dir = (self.forward + x * self.right + y * self.up).normalize();
        Ray::new(self.eye, dir, 0.0)
    }

    /// The diffuse bounce `bounce` (1 = first bounce) leaving `point` with unit `normal`.
    pub fn bounce(&self, pixel: u32, sample: u32, bounce: u32, point: Vec3A, normal: Vec3A) -> Ray {
        let mut rng = self.rng(pixel, sample, bounce);
        let (r1, r2) = (rng.next_f32(), rng.next_f32());
        let (phi, r) = (TAU * r1, r2.sqrt());
        let tangent = normal.any_orthonormal_vector();
        let bitangent = normal.cross(tangent);
        let dir =
            (tangent * (r * phi.cos()) + bitangent * (r * phi.sin()) + normal * (1.0 - r2).max(0.0).sqrt())
                .normalize_or(normal);
        Ray::new(point + normal * self.offset, dir, 0.0)
    }

    /// Radiance of the sky seen in direction `dir`: white at the horizon, blue overhead.
    pub fn sky(&self, dir: Vec3A) -> Vec3A {
        let t = 0.5 * (dir.dot(self.up.normalize()) + 1.0);
        Vec3A::ONE.lerp(Vec3A::new(0.5, 0.7, 1.0), t)
    }
}

/// A linear-radiance image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first.
    pub pixels: Vec<Vec3A>,
}

impl Image {
    /// Writes an 8-bit sRGB-ish (gamma 2.2) PNG.
    pub fn write_png(&self, path: &Path) -> Result<()> {
        let file = File::create(path).map_err(|e| Error::io(path, e))?;
        let mut encoder = png::Encoder::new(BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let bytes: Vec<u8> = self
            .pixels
            .iter()
            .flat_map(|p| p.to_array())
            .map(|c| (c.clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0 + 0.5) as u8)
            .collect();
        let to_io = |e: png::EncodingError| Error::io(path, std::io::Error::other(e));
        encoder.write_header().and_then(|mut w| w.write_image_data(&bytes)).map_err(to_io)
    }
}
