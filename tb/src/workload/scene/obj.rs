//! Wavefront OBJ positions and faces.
//!
//! A hand-written reader rather than tobj: it reports the line of every error, never stores
//! normals, texture coordinates or materials (so `mtllib` is never opened), and streams the
//! 130 MB forest file line by line. Faces are fan-triangulated; indices may be negative (relative).
//! Lines are bytes, not text: names and comments in any encoding (a Latin-1 material name) are
//! skipped unread, and only the keywords, numbers and indices read must be ASCII.
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

use super::sink::{checked_vertex, MeshFile, TriangleSink};
use crate::error::{Error, Result};

/// Reads the OBJ text in `reader` into `sink`.
pub(super) fn load(mut reader: impl BufRead, file: MeshFile, sink: &mut TriangleSink) -> Result<()> {
    let MeshFile { path, xf } = file;
    let mut vertices: Vec<Vec3A> = Vec::new();
    let mut face: Vec<Vec3A> = Vec::new();
    let mut buf = Vec::new();
    let mut line_no = 0usize;
    // A UTF-8 byte-order mark (some Windows exporters write one) is not part of the first line.
    if reader.fill_buf().map_err(|e| Error::io(path, e))?.starts_with(b"\xef\xbb\xbf") {
        reader.consume(3);
    }
    loop {
        buf.clear();
        if reader.read_until(b'\n', &mut buf).map_err(|e| Error::io(path, e))? == 0 {
            break;
        }
        line_no += 1;
        let at = || format!("line {line_no}");
        let mut tokens = buf.split(u8::is_ascii_whitespace).filter(|t| !t.is_empty());
        match tokens.next() {
            Some(b"v") => {
                let mut p = [0.0f32; 3];
                for c in &mut p {
                    let token = tokens
                        .next()
                        .ok_or_else(|| Error::format(path, at(), "vertex needs 3 coordinates"))?;
                    *c = parse(token).ok_or_else(|| {
                        Error::format(path, at(), format!("'{}' is not a number", shown(token)))
                    })?;
                }
                vertices.push(checked_vertex(path, at, xf, Vec3A::from(p))?);
            }
            Some(b"o") => sink.begin_object(),
            Some(b"f") => {
                face.clear();
                for token in tokens {
                    let index = token.split(|&b| b == b'/').next().unwrap_or_default();
                    let i: i64 = parse(index).ok_or_else(|| {
                        Error::format(path, at(), format!("'{}' is not a vertex index", shown(token)))
                    })?;
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

/// A number token; `None` when it is not one (or not ASCII).
fn parse<T: std::str::FromStr>(token: &[u8]) -> Option<T> {
    std::str::from_utf8(token).ok()?.parse().ok()
}

/// A token as an error message shows it (bytes that are not UTF-8 replaced).
fn shown(token: &[u8]) -> std::borrow::Cow<'_, str> {
    String::from_utf8_lossy(token)
}
