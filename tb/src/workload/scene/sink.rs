//! What every mesh loader writes into and the check every format shares: a [`TriangleSink`]
//! collects the triangles and objects of a scene, [`checked_vertex`] rejects a non-finite
//! vertex naming where it is, and a zero-area triangle is dropped and counted.

use std::path::Path;

use glam::{Affine3A, Vec3A};
use obvhs::triangle::Triangle;

use super::Objects;
use crate::error::{Error, Result};

/// Collects the triangles of one or more meshes into the scene's (flattened, world-space)
/// triangle list, and the scene's object structure: world-space objects (ranges of that list,
/// opened by [`TriangleSink::begin_object`]) and glTF meshes with their instances.
pub(crate) struct TriangleSink<'a> {
    pub triangles: &'a mut Vec<Triangle>,
    pub dropped: usize,
    /// Faces offered (triangles and polygons, kept or dropped): none means the file had none.
    pub offered: usize,
    /// glTF primitives of points or lines, skipped: they have no surface to hit.
    pub non_surface: usize,
    pub objects: Objects,
    /// Start of the open world-space object.
    open: Option<usize>,
}

impl<'a> TriangleSink<'a> {
    pub fn new(triangles: &'a mut Vec<Triangle>) -> Self {
        TriangleSink {
            triangles,
            dropped: 0,
            offered: 0,
            non_surface: 0,
            objects: Objects::default(),
            open: None,
        }
    }

    /// Closes the open world-space object (if any) and opens one at the next triangle.
    pub fn begin_object(&mut self) {
        self.end_object();
        self.open = Some(self.triangles.len());
    }

    /// Closes the open world-space object: one mesh and one identity instance of it, unless it
    /// holds no triangles.
    pub fn end_object(&mut self) {
        if let Some(start) = self.open.take() {
            if self.triangles.len() > start {
                self.objects.add_world(start as u32..self.triangles.len() as u32);
            }
        }
    }
    /// Adds a triangle, or counts it as dropped when its area is zero.
    pub fn add(&mut self, v0: Vec3A, v1: Vec3A, v2: Vec3A) {
        self.offered += 1;
        if (v1 - v0).cross(v2 - v0) == Vec3A::ZERO {
            self.dropped += 1;
        } else {
            self.triangles.push(Triangle { v0, v1, v2 });
        }
    }

    /// Adds the fan triangulation of a polygon given by vertex positions.
    pub fn add_fan(&mut self, polygon: impl IntoIterator<Item = Vec3A>) {
        let mut it = polygon.into_iter();
        let (Some(first), Some(mut prev)) = (it.next(), it.next()) else {
            self.offered += 1;
            self.dropped += 1;
            return;
        };
        let mut any = false;
        for next in it {
            self.add(first, prev, next);
            prev = next;
            any = true;
        }
        if !any {
            self.offered += 1;
            self.dropped += 1;
        }
    }
}

/// The mesh file a loader reads: its path (named by every error) and its transform to world
/// space.
#[derive(Clone, Copy)]
pub(crate) struct MeshFile<'a> {
    pub path: &'a Path,
    pub xf: &'a Affine3A,
}

/// Transforms a vertex and rejects it if it (or its image) is not finite.
pub(crate) fn checked_vertex(
    path: &Path,
    at: impl FnOnce() -> String,
    xf: &Affine3A,
    p: Vec3A,
) -> Result<Vec3A> {
    let q = xf.transform_point3a(p);
    if p.is_finite() && q.is_finite() {
        Ok(q)
    } else {
        Err(Error::format(path, at(), format!("vertex {p} is not finite")))
    }
}
