//! glTF 2.0 (binary .glb or .gltf with external buffers): triangle positions of every mesh
//! instance reached from the default scene's root nodes, with node transforms flattened, so a
//! mesh referenced by several nodes counts once per node (as the scene manifest counts them).

use std::path::Path;

use glam::{Affine3A, Mat4, Vec3A};
use gltf::{buffer::Source, mesh::Mode};

use super::mesh::{checked_vertex, TriangleSink};
use crate::error::{Error, Result};

fn buffers(doc: &gltf::Gltf, path: &Path) -> Result<Vec<Vec<u8>>> {
    doc.buffers()
        .map(|buffer| {
            let at = format!("buffer {}", buffer.index());
            let data = match buffer.source() {
                Source::Bin => {
                    doc.blob.clone().ok_or_else(|| Error::format(path, &at, "GLB has no binary chunk"))?
                }
                Source::Uri(uri) if uri.starts_with("data:") => {
                    return Err(Error::format(path, &at, "data: URIs are not supported"))
                }
                Source::Uri(uri) => {
                    let file = path.parent().unwrap_or(Path::new(".")).join(uri);
                    std::fs::read(&file).map_err(|e| Error::io(file, e))?
                }
            };
            if data.len() < buffer.length() {
                return Err(Error::format(
                    path,
                    &at,
                    format!("holds {} bytes, declares {}", data.len(), buffer.length()),
                ));
            }
            Ok(data)
        })
        .collect()
}

pub(super) fn load(bytes: &[u8], path: &Path, xf: &Affine3A, sink: &mut TriangleSink) -> Result<()> {
    let doc = gltf::Gltf::from_slice(bytes).map_err(|e| Error::format(path, "glTF", e.to_string()))?;
    let buffers = buffers(&doc, path)?;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| Error::format(path, "glTF", "no scene"))?;
    let node_count = doc.nodes().len();
    let mut pending: Vec<(gltf::Node, Mat4, usize)> =
        scene.nodes().map(|n| (n, Mat4::from(*xf), 0)).collect();
    let mut positions = Vec::new();
    while let Some((node, parent, depth)) = pending.pop() {
        if depth > node_count {
            return Err(Error::format(path, format!("node {}", node.index()), "node cycle"));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let world_xf = Affine3A::from_mat4(world);
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let at = || format!("mesh {} primitive {}", mesh.index(), prim.index());
                let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
                let Some(read) = reader.read_positions() else {
                    return Err(Error::format(path, at(), "no POSITION attribute"));
                };
                positions.clear();
                for (i, p) in read.enumerate() {
                    let v =
                        checked_vertex(path, || format!("{} vertex {i}", at()), &world_xf, Vec3A::from(p))?;
                    positions.push(v);
                }
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(ix) => ix.into_u32().collect(),
                    None => (0..positions.len() as u32).collect(),
                };
                if let Some(&bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
                    return Err(Error::format(
                        path,
                        at(),
                        format!("index {bad} out of range ({} vertices)", positions.len()),
                    ));
                }
                let v = |i: u32| positions[i as usize];
                match prim.mode() {
                    Mode::Triangles => {
                        if !indices.len().is_multiple_of(3) {
                            return Err(Error::format(path, at(), "index count is not a multiple of 3"));
                        }
                        for t in indices.chunks_exact(3) {
                            sink.add(v(t[0]), v(t[1]), v(t[2]));
                        }
                    }
                    Mode::TriangleStrip => {
                        for (k, w) in indices.windows(3).enumerate() {
                            let (a, b) = if k % 2 == 0 { (w[0], w[1]) } else { (w[1], w[0]) };
                            sink.add(v(a), v(b), v(w[2]));
                        }
                    }
                    Mode::TriangleFan => sink.add_fan(indices.iter().map(|&i| v(i))),
                    // Points and lines have no surface to hit.
                    Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => {}
                }
            }
        }
        pending.extend(node.children().map(|c| (c, world, depth + 1)));
    }
    Ok(())
}
