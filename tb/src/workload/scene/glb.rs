//! glTF 2.0 (binary .glb, or .gltf with external or embedded `data:` base64 buffers): triangle
//! positions of every mesh instance reached from the default scene's root nodes, with node
//! transforms flattened, so a mesh referenced by several nodes counts once per node (as the scene
//! manifest counts them).
//!
//! For two-level acceleration structures the loader also keeps each mesh once in its own space
//! (all its primitives: one BLAS) and each node that references a mesh as an instance of it with
//! the node's world transform (the description's transform included).

use std::collections::HashMap;
use std::path::Path;

use base64::engine::{DecodePaddingMode, GeneralPurpose, GeneralPurposeConfig};
use base64::Engine;
use glam::{Affine3A, Mat4, Vec3A};
use gltf::{buffer::Source, mesh::Mode};

use super::sink::{checked_vertex, TriangleSink};
use super::{Instance, MeshGeometry};
use crate::error::{Error, Result};

/// Parses and validates the document. Required extensions are refused by name before
/// validation: this reader implements none of them, and the validation errors one causes (a
/// Draco-compressed accessor has no buffer view) would bury the reason under one per accessor.
fn parse(bytes: &[u8], path: &Path) -> Result<gltf::Gltf> {
    let gltf::Gltf { document, blob } = gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| {
        let what = match version_1(bytes) {
            Some(version) => format!("version {version}; sms reads glTF 2.0 (convert the file)"),
            None => e.to_string(),
        };
        Error::format(path, "glTF", what)
    })?;
    let required: Vec<&str> = document.extensions_required().collect();
    if !required.is_empty() {
        let s = if required.len() == 1 { "" } else { "s" };
        return Err(Error::format(
            path,
            "glTF",
            format!("requires the extension{s} {}, which sms does not read", required.join(", ")),
        ));
    }
    let document = gltf::Document::from_json(document.into_json()).map_err(|e| {
        let what = match e {
            gltf::Error::Validation(errors) => match errors.split_first() {
                Some(((at, error), [])) => format!("invalid: {at}: {error}"),
                Some(((at, error), more)) => format!("invalid: {at}: {error} (and {} more)", more.len()),
                None => "invalid".to_owned(),
            },
            e => e.to_string(),
        };
        Error::format(path, "glTF", what)
    })?;
    Ok(gltf::Gltf { document, blob })
}

/// The version of a glTF 1 file (`None` for any other), from a GLB container's header or the
/// JSON's `asset.version`: the 2.0 parser rejects such a file at its first 1.0-only construct
/// without saying why.
fn version_1(bytes: &[u8]) -> Option<String> {
    let version = match bytes.strip_prefix(b"glTF") {
        Some(rest) => u32::from_le_bytes(rest.get(..4)?.try_into().ok()?).to_string(),
        None => {
            // Some glTF 1 exporters wrote the version as a number (`"version": 1.0`).
            let json: serde_json::Value = serde_json::from_slice(bytes).ok()?;
            match &json["asset"]["version"] {
                serde_json::Value::String(v) => v.clone(),
                serde_json::Value::Number(n) => n.to_string(),
                _ => return None,
            }
        }
    };
    version.starts_with('1').then_some(version)
}

/// The bytes of a `data:` URI's payload (`data:[<media type>];base64,<payload>`). Padding is
/// optional: some exporters leave it out.
fn decode_data_uri(uri: &str) -> std::result::Result<Vec<u8>, String> {
    let (meta, payload) = uri.split_once(',').ok_or("data: URI has no ',' before its payload")?;
    if !meta.ends_with(";base64") {
        return Err("data: URI is not base64-encoded (only base64 payloads are read)".into());
    }
    let engine = GeneralPurpose::new(
        &base64::alphabet::STANDARD,
        GeneralPurposeConfig::new().with_decode_padding_mode(DecodePaddingMode::Indifferent),
    );
    engine.decode(payload).map_err(|e| format!("data: URI is not valid base64 ({e})"))
}

fn buffers(doc: &gltf::Gltf, path: &Path) -> Result<Vec<Vec<u8>>> {
    doc.buffers()
        .map(|buffer| {
            let at = format!("buffer {}", buffer.index());
            let data = match buffer.source() {
                Source::Bin => {
                    doc.blob.clone().ok_or_else(|| Error::format(path, &at, "GLB has no binary chunk"))?
                }
                Source::Uri(uri) if uri.starts_with("data:") => {
                    decode_data_uri(uri).map_err(|what| Error::format(path, &at, what))?
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
    let doc = parse(bytes, path)?;
    let buffers = buffers(&doc, path)?;
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| Error::format(path, "glTF", "no scene"))?;
    let node_count = doc.nodes().len();
    let mut pending: Vec<(gltf::Node, Mat4, usize)> =
        scene.nodes().map(|n| (n, Mat4::from(*xf), 0)).collect();
    // glTF mesh index to the scene's mesh (None: every triangle of it is degenerate).
    let mut meshes: HashMap<usize, Option<u32>> = HashMap::new();
    while let Some((node, parent, depth)) = pending.pop() {
        if depth > node_count {
            return Err(Error::format(path, format!("node {}", node.index()), "node cycle"));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let world_xf = Affine3A::from_mat4(world);
        if let Some(mesh) = node.mesh() {
            add_mesh(&mesh, &buffers, path, &world_xf, sink)?;
            // The mesh once in its own space (a BLAS), and this node as an instance of it.
            let id = match meshes.get(&mesh.index()) {
                Some(&id) => id,
                None => {
                    let mut local = std::mem::take(&mut sink.objects.local);
                    let start = local.len() as u32;
                    add_mesh(&mesh, &buffers, path, &Affine3A::IDENTITY, &mut TriangleSink::new(&mut local))?;
                    let end = local.len() as u32;
                    sink.objects.local = local;
                    let id = (end > start).then(|| {
                        sink.objects.meshes.push(MeshGeometry::Local(start..end));
                        sink.objects.meshes.len() as u32 - 1
                    });
                    meshes.insert(mesh.index(), id);
                    id
                }
            };
            if let Some(mesh) = id {
                let to_world = (world_xf != Affine3A::IDENTITY).then_some(world_xf);
                sink.objects.instances.push(Instance { mesh, to_world });
            }
        }
        pending.extend(node.children().map(|c| (c, world, depth + 1)));
    }
    Ok(())
}

/// Adds the triangles of every primitive of `mesh`, transformed by `xf`, to `sink`.
fn add_mesh(
    mesh: &gltf::Mesh,
    buffers: &[Vec<u8>],
    path: &Path,
    xf: &Affine3A,
    sink: &mut TriangleSink,
) -> Result<()> {
    let mut positions = Vec::new();
    for prim in mesh.primitives() {
        let at = || format!("mesh {} primitive {}", mesh.index(), prim.index());
        let reader = prim.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let Some(read) = reader.read_positions() else {
            return Err(Error::format(path, at(), "no POSITION attribute"));
        };
        positions.clear();
        for (i, p) in read.enumerate() {
            let v = checked_vertex(path, || format!("{} vertex {i}", at()), xf, Vec3A::from(p))?;
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
            Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => sink.non_surface += 1,
        }
    }
    Ok(())
}
