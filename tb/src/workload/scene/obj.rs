//! Wavefront OBJ positions and faces.
//!
//! A hand-written reader rather than tobj: it reports the line of every error, never stores
//! normals, texture coordinates or materials (so `mtllib` is never opened), and streams the
//! 130 MB forest file line by line. Faces are fan-triangulated; indices may be negative (relative).
//!
//! Objects: an `o` line starts a new object (a BLAS and its instance in a two-level
//! acceleration structure); a file without `o` lines is one object. `g` (and `usemtl`) groups do
//! not split objects: LumiBench's loader merges every shape tinyobjloader reports for a file
//! (its `o` and `g` groups alike) into one `Model` (RayTracingInVulkan `src/Assets/Model.cpp:97`)
//! and builds one BLAS per `Model` (`src/Vulkan/RayTracing/Application.cpp:263-287`), so a BLAS
//! is a whole OBJ file there. The merged `*-partial` scene files keep the `o` line of each
//! original file, so splitting on `o` recovers LumiBench's objects.

use std::io::BufRead;

use glam::Vec3A;

use super::mesh::{checked_vertex, MeshFile, TriangleSink};
use crate::error::{Error, Result};

/// Reads the OBJ text in `reader` into `sink`.
pub(super) fn load(mut reader: impl BufRead, file: MeshFile, sink: &mut TriangleSink) -> Result<()> {
    let MeshFile { path, xf } = file;
    let mut vertices: Vec<Vec3A> = Vec::new();
    let mut face: Vec<Vec3A> = Vec::new();
    let mut buf = Vec::new();
    let mut line_no = 0usize;
    loop {
        buf.clear();
        if reader.read_until(b'\n', &mut buf).map_err(|e| Error::io(path, e))? == 0 {
            break;
        }
        line_no += 1;
        let at = || format!("line {line_no}");
        let line = std::str::from_utf8(&buf).map_err(|_| Error::format(path, at(), "not valid UTF-8"))?;
        let mut tokens = line.split_ascii_whitespace();
        match tokens.next() {
            Some("v") => {
                let mut p = [0.0f32; 3];
                for c in &mut p {
                    let token = tokens
                        .next()
                        .ok_or_else(|| Error::format(path, at(), "vertex needs 3 coordinates"))?;
                    *c = token
                        .parse()
                        .map_err(|_| Error::format(path, at(), format!("'{token}' is not a number")))?;
                }
                vertices.push(checked_vertex(path, at, xf, Vec3A::from(p))?);
            }
            Some("o") => sink.begin_object(),
            Some("f") => {
                face.clear();
                for token in tokens {
                    let index = token.split('/').next().unwrap_or_default();
                    let i: i64 = index
                        .parse()
                        .map_err(|_| Error::format(path, at(), format!("'{token}' is not a vertex index")))?;
                    let n = vertices.len() as i64;
                    let resolved = if i > 0 { i - 1 } else { n + i };
                    if i == 0 || !(0..n).contains(&resolved) {
                        return Err(Error::format(
                            path,
                            at(),
                            format!("vertex index {i} out of range ({n} vertices defined so far)"),
                        ));
                    }
                    face.push(vertices[resolved as usize]);
                }
                sink.add_fan(face.iter().copied());
            }
            _ => {}
        }
    }
    Ok(())
}
