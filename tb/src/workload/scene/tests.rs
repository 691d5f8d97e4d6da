//! Loader tests: every error names its file and place; degenerate triangles are counted.

use std::io::Write;
use std::path::PathBuf;

use glam::{vec3a, Affine3A};

use super::mesh::load_mesh;
use super::sink::TriangleSink;
use super::*;

/// A fresh folder for one test's files.
fn temp_dir(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tb-scene-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    std::fs::create_dir_all(dir).expect("dir");
    let path = dir.join(name);
    if name.ends_with(".gz") {
        let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        gz.write_all(bytes).expect("gzip");
        std::fs::write(&path, gz.finish().expect("gzip")).expect("write");
    } else {
        std::fs::write(&path, bytes).expect("write");
    }
    path
}

/// Loads one file; returns (triangles, dropped) or the error message.
fn load(path: &Path) -> Result<(Vec<obvhs::triangle::Triangle>, usize), String> {
    load_objects(path).map(|(t, d, _)| (t, d))
}

/// Loads one file with its object structure.
fn load_objects(path: &Path) -> Result<(Vec<obvhs::triangle::Triangle>, usize, Objects), String> {
    let mut triangles = Vec::new();
    let mut sink = TriangleSink::new(&mut triangles);
    load_mesh(path, &Affine3A::IDENTITY, &mut sink).map_err(|e| e.to_string())?;
    let (dropped, objects) = (sink.dropped, std::mem::take(&mut sink.objects));
    Ok((triangles, dropped, objects))
}

fn load_err(dir: &Path, name: &str, text: &str) -> String {
    let path = write(dir, name, text.as_bytes());
    let err = load(&path).expect_err("should fail");
    assert!(err.contains(name), "error names the file: {err}");
    err
}

const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

#[test]
fn obj_fans_negative_indices_and_gzip() {
    let dir = temp_dir("obj_ok");
    for name in ["quad.obj", "quad.obj.gz"] {
        let path = write(&dir, name, format!("{QUAD}vn 0 0 1\nf -4/1/1 -3//1 -2 -1\n").as_bytes());
        let (tris, dropped) = load(&path).expect("loads");
        assert_eq!((tris.len(), dropped), (2, 0));
        assert_eq!(tris[1].v2, vec3a(0.0, 1.0, 0.0));
    }
}

#[test]
fn obj_objects_split_on_o_lines_not_on_groups() {
    let dir = temp_dir("obj_objects");
    // A face before any `o`, an empty object, a `g` group inside object b (no split), object c.
    let text = format!(
        "{QUAD}f 1 2 3\no empty\no b\nf 1 2 3 4\ng inner\nf 2 3 4\nusemtl m\nf 1 3 4\no c\nf 1 2 4\n"
    );
    let (tris, _, objects) = load_objects(&write(&dir, "objs.obj", text.as_bytes())).expect("loads");
    assert_eq!(tris.len(), 6);
    assert_eq!(
        objects.meshes,
        [MeshGeometry::World(0..1), MeshGeometry::World(1..5), MeshGeometry::World(5..6)]
    );
    assert!(objects.instances.iter().enumerate().all(|(k, i)| i.mesh == k as u32 && i.to_world.is_none()));
    // No `o` line: the file is one object.
    let (_, _, one) =
        load_objects(&write(&dir, "one.obj", format!("{QUAD}g a\nf 1 2 3\ng b\nf 1 3 4\n").as_bytes()))
            .expect("loads");
    assert_eq!(one.meshes, [MeshGeometry::World(0..2)]);
}

#[test]
fn every_mesh_file_of_a_description_is_its_own_object() {
    let lib = library("desc_objects");
    write(&lib.data, "quad.obj", format!("{QUAD}f 1 2 3 4\n").as_bytes());
    let toml = "[[mesh]]\nfile = \"quad.obj\"\n[[mesh]]\nfile = \"quad.obj\"\n";
    let two = write(&lib.data, "two.toml", toml.as_bytes());
    let scene = lib.load(two.to_str().unwrap()).expect("loads");
    assert_eq!(scene.objects.meshes, [MeshGeometry::World(0..2), MeshGeometry::World(2..4)]);
    assert_eq!(scene.objects.instanced_primitives(), 4);
}

#[test]
fn merged_lumibench_file_has_one_object_per_original_file() {
    // bath-partial merges 46 OBJ files that hold geometry, each with its `o` line (MANIFEST.md).
    let Some(scene) = crate::prereq::scene("bath-partial") else { return };
    assert_eq!(scene.objects.instances.len(), 46);
    assert_eq!(scene.objects.instanced_primitives(), scene.primitives.len() as u64);
}

#[test]
fn obj_errors_name_the_line() {
    let dir = temp_dir("obj_err");
    let e = load_err(&dir, "num.obj", "v 0 0 0\nv 1 x 0\n");
    assert!(e.contains("line 2") && e.contains("'x'"), "{e}");
    let e = load_err(&dir, "range.obj", &format!("{QUAD}f 1 2 5\n"));
    assert!(e.contains("line 5") && e.contains("out of range"), "{e}");
    let e = load_err(&dir, "zero.obj", &format!("{QUAD}f 0 1 2\n"));
    assert!(e.contains("line 5"), "{e}");
    let e = load_err(&dir, "nan.obj", "v 0 0 0\nv nan 0 0\n");
    assert!(e.contains("line 2") && e.contains("not finite"), "{e}");
    let e = load_err(&dir, "inf.obj", "v 0 inf 0\n");
    assert!(e.contains("line 1") && e.contains("not finite"), "{e}");
    let e = load_err(&dir, "short.obj", "v 0 0\n");
    assert!(e.contains("line 1") && e.contains("3 coordinates"), "{e}");
    let e = load_err(&dir, "empty.obj", "# nothing\n");
    assert!(e.ends_with("no triangles: the file holds no faces"), "{e}");
}

#[test]
fn degenerate_triangles_are_dropped_and_counted() {
    let dir = temp_dir("degenerate");
    // A good triangle, a repeated vertex, a zero-area (collinear) one and a 2-vertex face.
    let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 1 2\nf 1 2 4\nf 1 2\n";
    let (tris, dropped) = load(&write(&dir, "d.obj", text.as_bytes())).expect("loads");
    assert_eq!((tris.len(), dropped), (1, 3));
    let e = load_err(&dir, "all.obj", "v 0 0 0\nv 1 0 0\nf 1 2 2\n");
    assert!(e.ends_with("no triangles: all 1 of its faces have zero area"), "{e}");
}

#[test]
fn missing_file_is_an_io_error() {
    let path = temp_dir("missing").join("nope.ply.gz");
    let err = load(&path).expect_err("missing");
    assert!(err.contains("nope.ply.gz"), "{err}");
    let e = load_err(&temp_dir("unknown_ext"), "mesh.stl", "solid");
    assert!(e.contains("unknown mesh format"), "{e}");
}

fn ply_header(format: &str, vertices: usize, faces: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\ncomment test\nelement vertex {vertices}\nproperty float x\n\
         property float y\nproperty float z\nproperty uchar red\nelement face {faces}\n\
         property list uchar int vertex_indices\nend_header\n"
    )
}

fn binary_ply(vertices: &[[f32; 3]], faces: &[&[i32]]) -> Vec<u8> {
    let mut bytes = ply_header("binary_little_endian", vertices.len(), faces.len()).into_bytes();
    for v in vertices {
        v.iter().for_each(|c| bytes.extend(c.to_le_bytes()));
        bytes.push(7);
    }
    for f in faces {
        bytes.push(f.len() as u8);
        f.iter().for_each(|i| bytes.extend(i.to_le_bytes()));
    }
    bytes
}

#[test]
fn ply_ascii_and_binary() {
    let dir = temp_dir("ply_ok");
    let ascii = format!("{}0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0 1\n4 0 1 2 3\n", ply_header("ascii", 4, 1));
    assert_eq!(load(&write(&dir, "a.ply", ascii.as_bytes())).expect("ascii").0.len(), 2);
    let quad = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
    let bin = binary_ply(&quad, &[&[0, 1, 2, 3], &[0, 0, 1]]);
    let (tris, dropped) = load(&write(&dir, "b.ply.gz", &bin)).expect("binary");
    assert_eq!((tris.len(), dropped), (2, 1));
}

#[test]
fn ply_errors_name_the_element() {
    let dir = temp_dir("ply_err");
    let quad = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
    let path = write(&dir, "range.ply", &binary_ply(&quad, &[&[0, 1, 2], &[0, 1, 9]]));
    let e = load(&path).expect_err("range");
    assert!(e.contains("range.ply") && e.contains("face 1") && e.contains("out of range"), "{e}");
    let mut truncated = binary_ply(&quad, &[&[0, 1, 2]]);
    truncated.truncate(truncated.len() - 20);
    let e = load(&write(&dir, "short.ply", &truncated)).expect_err("short");
    assert!(e.contains("unexpected end of file"), "{e}");
    let nan = binary_ply(&[[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]], &[&[0, 1, 2]]);
    let e = load(&write(&dir, "nan.ply", &nan)).expect_err("nan");
    assert!(e.contains("vertex 1") && e.contains("not finite"), "{e}");
    let e = load_err(&dir, "magic.ply", "plx\n");
    assert!(e.contains("header line 1"), "{e}");
    let e = load_err(&dir, "be.ply", "ply\nformat binary_big_endian 1.0\nend_header\n");
    assert!(e.contains("binary_big_endian"), "{e}");
    let text = format!("{}0 0 0 1\n0 zz 0 1\n", ply_header("ascii", 2, 0));
    let e = load_err(&dir, "word.ply", &text);
    assert!(e.contains("vertex 1") && e.contains("'zz'"), "{e}");
}

/// One triangle's positions (3 × VEC3 float) then its indices (3 × u32): 48 bytes.
fn triangle_bin(indices: [u32; 3]) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    for c in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bin.extend(c.to_le_bytes());
    }
    indices.iter().for_each(|i| bin.extend(i.to_le_bytes()));
    bin
}

/// The JSON of a glTF whose one triangle mesh (in [`triangle_bin`]'s layout) is used by three
/// nodes: a root, a translated root, and a scaled child of the translated one. `buffer` is the
/// buffer object.
fn gltf_json(buffer: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"mesh":0}},{{"mesh":0,"translation":[5,0,0],"children":[2]}},{{"mesh":0,"scale":[2,2,2]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
        "buffers":[{buffer}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":12}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5125,"count":3,"type":"SCALAR"}}]}}"#
    )
}

/// A GLB of [`gltf_json`]'s scene.
fn glb(indices: [u32; 3]) -> Vec<u8> {
    let bin = triangle_bin(indices);
    let mut json = gltf_json(&format!(r#"{{"byteLength":{}}}"#, bin.len())).into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((12 + 8 + json.len() as u32 + 8 + bin.len() as u32).to_le_bytes());
    out.extend((json.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(json);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(bin);
    out
}

#[test]
fn glb_flattens_node_transforms() {
    let dir = temp_dir("glb_ok");
    let (tris, dropped) = load(&write(&dir, "m.glb", &glb([0, 1, 2]))).expect("glb");
    assert_eq!((tris.len(), dropped), (3, 0));
    let mut xs: Vec<f32> = tris.iter().map(|t| t.v1.x).collect();
    xs.sort_by(f32::total_cmp);
    // v1 = (1,0,0): as is, translated by 5, scaled by 2 then translated by 5.
    assert_eq!(xs, [1.0, 6.0, 7.0]);
}

#[test]
fn glb_nodes_are_instances_of_one_shared_mesh() {
    let dir = temp_dir("glb_instances");
    let (tris, _, objects) = load_objects(&write(&dir, "m.glb", &glb([0, 1, 2]))).expect("glb");
    assert_eq!(objects.meshes, [MeshGeometry::Local(0..1)], "the mesh is stored once");
    assert_eq!(objects.local[0].v1, vec3a(1.0, 0.0, 0.0), "in its own space");
    assert_eq!(objects.instances.len(), 3);
    assert!(objects.instances.iter().all(|i| i.mesh == 0));
    // Each instance's transform places the local triangle where the flattened list has it.
    let mut placed: Vec<f32> = objects
        .instances
        .iter()
        .map(|i| i.to_world.unwrap_or(Affine3A::IDENTITY).transform_point3a(objects.local[0].v1).x)
        .collect();
    placed.sort_by(f32::total_cmp);
    let mut flat: Vec<f32> = tris.iter().map(|t| t.v1.x).collect();
    flat.sort_by(f32::total_cmp);
    assert_eq!(placed, flat);
    assert_eq!(
        objects.instances.iter().filter(|i| i.to_world.is_none()).count(),
        1,
        "the untransformed root"
    );
}

#[test]
fn gallery_has_36_instances_of_shared_meshes() {
    let Some(scene) = crate::prereq::scene("gallery-instanced") else { return };
    let o = &scene.objects;
    // 36 instanced nodes plus the ground; 4 meshes (3 models and the ground), stored once.
    assert_eq!(o.meshes.len(), 4);
    assert_eq!(o.instances.len(), 37);
    assert_eq!(o.instances.iter().filter(|i| o.meshes[i.mesh as usize].range().len() > 2).count(), 36);
    assert_eq!(o.local.len(), 577_000);
    assert_eq!(o.instanced_primitives(), 6_923_978);
    assert_eq!(scene.primitives.len(), 6_923_978);
}

#[test]
fn glb_errors() {
    let dir = temp_dir("glb_err");
    let e = load(&write(&dir, "range.glb", &glb([0, 1, 3]))).expect_err("range");
    assert!(e.contains("range.glb") && e.contains("mesh 0 primitive 0") && e.contains("out of range"), "{e}");
    let e = load_err(&dir, "junk.glb", "not a gltf file at all");
    assert!(e.contains("glTF"), "{e}");
}

#[test]
fn gltf_buffers_in_data_uris_load_like_external_and_glb_ones() {
    use base64::Engine;
    let dir = temp_dir("gltf_data_uri");
    // One byte past the data, so the base64 text ends in padding (which some writers omit).
    let mut bin = triangle_bin([0, 1, 2]);
    bin.push(0);
    let uri = |engine: &base64::engine::GeneralPurpose| {
        let buffer = format!(
            r#"{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}"#,
            bin.len(),
            engine.encode(&bin)
        );
        gltf_json(&buffer)
    };
    let padded = uri(&base64::engine::general_purpose::STANDARD);
    assert!(padded.contains("==\""), "the payload is padded");
    let unpadded = uri(&base64::engine::general_purpose::STANDARD_NO_PAD);
    write(&dir, "m.bin", &bin);
    let external = gltf_json(&format!(r#"{{"byteLength":{},"uri":"m.bin"}}"#, bin.len()));
    let from_glb = load(&write(&dir, "m.glb", &glb([0, 1, 2]))).expect("glb");
    assert_eq!(from_glb.0.len(), 3);
    for (name, json) in [("padded.gltf", padded), ("unpadded.gltf", unpadded), ("external.gltf", external)] {
        let loaded = load(&write(&dir, name, json.as_bytes())).expect(name);
        assert_eq!(format!("{loaded:?}"), format!("{from_glb:?}"), "{name}");
    }
}

#[test]
fn bad_data_uris_are_one_line_errors() {
    let dir = temp_dir("gltf_bad_data_uri");
    for (name, uri, what) in [
        (
            "text.gltf",
            "data:text/plain,abc",
            "data: URI is not base64-encoded (only base64 payloads are read)",
        ),
        ("comma.gltf", "data:application/octet-stream;base64", "data: URI has no ',' before its payload"),
        (
            "symbol.gltf",
            "data:application/octet-stream;base64,AA!A",
            "data: URI is not valid base64 (Invalid symbol 33, offset 2.)",
        ),
    ] {
        let json = gltf_json(&format!(r#"{{"byteLength":48,"uri":"{uri}"}}"#));
        let path = write(&dir, name, json.as_bytes());
        assert_eq!(load(&path).expect_err(name), format!("{}: buffer 0: {what}", path.display()));
    }
}

/// A Draco-compressed file: its accessors have no buffer views (the extension holds the data),
/// which plain validation reports once per accessor.
#[test]
fn a_required_gltf_extension_is_one_line_naming_it() {
    let dir = temp_dir("gltf_extension");
    let body = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1,
            "extensions":{"KHR_draco_mesh_compression":{"bufferView":0,"attributes":{"POSITION":0}}}}]}],
        "accessors":[{"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                     {"componentType":5125,"count":3,"type":"SCALAR"}],
        "buffers":[{"byteLength":4,"uri":"data:application/octet-stream;base64,AAAAAA=="}],
        "bufferViews":[{"buffer":0,"byteLength":4}],
        "extensionsUsed":["KHR_draco_mesh_compression"]"#;
    let json = format!(r#"{body},"extensionsRequired":["KHR_draco_mesh_compression"]}}"#);
    let path = write(&dir, "draco.gltf", json.as_bytes());
    assert_eq!(
        load(&path).expect_err("draco"),
        format!(
            "{}: glTF: requires the extension KHR_draco_mesh_compression, which sms does not read",
            path.display()
        )
    );
    // Without the extension, the same accessors are invalid: the first is named, the rest counted.
    let plain = format!("{body}}}");
    let path = write(&dir, "plain.gltf", plain.as_bytes());
    assert_eq!(
        load(&path).expect_err("no buffer views"),
        format!("{}: glTF: invalid: accessors[0].bufferView: Missing data (and 1 more)", path.display())
    );
}

#[test]
fn gltf_1_files_are_refused_by_version() {
    let dir = temp_dir("gltf_1");
    let json = r#"{"asset":{"version":"1.0"},"accessors":{"a":{"bufferView":"b"}},"scene":"s"}"#;
    let path = write(&dir, "old.gltf", json.as_bytes());
    let want = |version: &str| {
        format!("{}: glTF: version {version}; sms reads glTF 2.0 (convert the file)", path.display())
    };
    assert_eq!(load(&path).expect_err("gltf 1"), want("1.0"));
    let mut glb1 = b"glTF".to_vec();
    glb1.extend(1u32.to_le_bytes());
    glb1.extend([0; 12]);
    let path = write(&dir, "old.glb", &glb1);
    assert_eq!(
        load(&path).expect_err("glb 1"),
        format!("{}: glTF: version 1; sms reads glTF 2.0 (convert the file)", path.display())
    );
}

#[test]
fn obj_names_and_comments_need_not_be_utf8() {
    let dir = temp_dir("obj_bytes");
    // Latin-1 'é' (0xE9) in a comment, an object name, a group, a material library and name.
    let mut text =
        b"# caf\xe9\nmtllib caf\xe9.mtl\no caf\xe9\ng terrain\xe6\nusemtl Terraind\xe6k\n".to_vec();
    text.extend(format!("{QUAD}f 1 2 3 4\n").as_bytes());
    let (tris, dropped) = load(&write(&dir, "latin1.obj", &text)).expect("loads");
    assert_eq!((tris.len(), dropped), (2, 0));
    // In a number it is an error naming the line, the byte shown replaced.
    let path = write(&dir, "number.obj", b"v 0 0 0\nv 1 2\xe9 0\n");
    assert_eq!(
        load(&path).expect_err("number"),
        format!("{}: line 2: '2\u{FFFD}' is not a number", path.display())
    );
    let path = write(&dir, "index.obj", &[QUAD.as_bytes(), b"f 1 2 3\xe9\n"].concat());
    assert_eq!(
        load(&path).expect_err("index"),
        format!("{}: line 5: '3\u{FFFD}' is not a vertex index", path.display())
    );
}

#[test]
fn ply_header_comments_and_free_text_are_skipped() {
    let dir = temp_dir("ply_header");
    // Blender 2.4x writes a bare free-text line; comments and obj_info may hold any bytes.
    let header: &[u8] = b"ply\nformat ascii 1.0\n\
        Created by Blender3D 247 - www.blender.org, source file: caf\xe9.blend\n\
        comment caf\xe9\nobj_info made by hand\nelement vertex 4\nproperty float x\n\
        property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n\
        end_header\n";
    let ply = [header, b"0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"].concat();
    let quad = load(&write(&dir, "quad.obj", format!("{QUAD}f 1 2 3 4\n").as_bytes())).unwrap();
    let loaded = load(&write(&dir, "blender.ply", &ply)).expect("loads");
    assert_eq!(format!("{loaded:?}"), format!("{quad:?}"));
    // The keywords the reader needs are still checked.
    for (name, line, what) in [
        ("count.ply", "element vertex many", "header line 3: bad element count"),
        ("type.ply", "property quad x", "header line 3: unknown property type"),
        ("short.ply", "element vertex", "header line 3: malformed header line 'element vertex'"),
    ] {
        let text = format!("ply\nformat ascii 1.0\n{line}\nend_header\n");
        let path = write(&dir, name, text.as_bytes());
        assert_eq!(load(&path).expect_err(name), format!("{}: {what}", path.display()));
    }
}

#[test]
fn a_directory_is_not_a_scene() {
    let lib = library("dir_scene");
    let dir = lib.data.join("meshes.obj");
    std::fs::create_dir_all(&dir).unwrap();
    for path in [&lib.data, &dir] {
        let e = lib.load(path.to_str().unwrap()).expect_err("a directory").to_string();
        assert_eq!(
            e,
            format!(
                "{}: is a directory; a scene is a name, a mesh file (.obj, .ply, .glb, .gltf, optionally .gz) or a .toml description",
                path.display()
            )
        );
    }
}

/// The example `sms scenes --help` and docs/scenes.md show is a working description.
#[test]
fn the_description_example_loads_and_is_documented() {
    let lib = library("example");
    write(&lib.data, "ship.obj.gz", format!("{QUAD}f 1 2 3 4\n").as_bytes());
    let path = write(&lib.data, "example.toml", DESCRIPTION_EXAMPLE.as_bytes());
    let scene = lib.load(path.to_str().unwrap()).expect("the example loads");
    assert_eq!(scene.primitives.triangle_count(), 2);
    assert_eq!(scene.camera, Camera::look_at([378.0, 278.0, 500.0], [178.0, 278.0, 0.0], 50.0));
    assert_eq!(scene.render, RenderSettings { max_bounces: 3, ..RenderSettings::default() });
    let docs = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/scenes.md"));
    assert!(docs.contains(DESCRIPTION_EXAMPLE), "docs/scenes.md shows DESCRIPTION_EXAMPLE as it is");
    assert!(description_help().contains("[[mesh]]"));
}

fn library(test: &str) -> SceneLibrary {
    SceneLibrary::with_data_dir(temp_dir(test))
}

#[test]
fn descriptions_load_and_report_errors() {
    let lib = library("desc");
    write(&lib.data, "quad.obj", format!("{QUAD}f 1 2 3 4\n").as_bytes());
    let shift = "transform = [[1,0,0,10],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";
    let toml = format!("[[mesh]]\nfile = \"quad.obj\"\n{shift}\n[render]\nwidth = 8\nheight = 4\n");
    let quad = write(&lib.data, "quad.toml", toml.as_bytes());
    let scene = lib.load(quad.to_str().unwrap()).expect("loads");
    assert_eq!(scene.name, "quad");
    assert_eq!(scene.primitives.triangle_count(), 2);
    assert_eq!(scene.primitives.bounds().min.x, 10.0);
    assert_eq!((scene.render.width, scene.render.height, scene.render.spp), (8, 4, 2));

    let load = |name: &str, text: &[u8]| {
        let path = write(&lib.data, name, text);
        lib.load(path.to_str().unwrap()).expect_err(name).to_string()
    };
    let e = load("bad.toml", b"[[mesh]]\nfile = \"quad.obj\"\ncolour = 3\n");
    assert!(e.contains("bad.toml") && e.contains("line 3"), "{e}");
    let e = load("eye.toml", b"[[mesh]]\nfile = \"quad.obj\"\n[camera]\neye = [0,0,1]\n");
    assert!(e.contains("look_at"), "{e}");
    let e = load("gone.toml", b"[[mesh]]\nfile = \"gone.obj\"\n");
    assert!(e.contains("gone.obj"), "{e}");
}

/// Mesh paths of a description given by path are relative to its folder, not to the data
/// folder or the current folder.
#[test]
fn description_meshes_are_relative_to_the_description() {
    let lib = library("relative");
    write(&lib.data.join("meshes"), "quad.obj", format!("{QUAD}f 1 2 3 4\n").as_bytes());
    let desc = write(&lib.data.join("desc"), "quad.toml", b"[[mesh]]\nfile = \"../meshes/quad.obj\"\n");
    let scene = lib.load(desc.to_str().unwrap()).expect("relative to desc/");
    assert_eq!(scene.primitives.triangle_count(), 2);
    let flat = write(&lib.data.join("desc"), "flat.toml", b"[[mesh]]\nfile = \"meshes/quad.obj\"\n");
    let e = lib.load(flat.to_str().unwrap()).expect_err("not relative to the data folder").to_string();
    assert!(e.contains("desc/meshes/quad.obj"), "{e}");
}

/// A mesh given by path is framed by the camera; the override moves it, and bad overrides are
/// errors naming the flag.
#[test]
fn meshes_by_path_and_camera_override() {
    let mut lib = library("bypath");
    let quad = write(&lib.data, "quad.obj", format!("{QUAD}f 1 2 3 4\n").as_bytes());
    let spec = quad.to_str().unwrap();
    let framed = lib.load(spec).expect("mesh by path");
    assert_eq!(framed.name, "quad");
    assert_eq!(framed.render, RenderSettings::default());
    assert_eq!(framed.camera.vfov, 45.0);
    lib.camera = CameraOverride { vfov: Some(20.0), ..CameraOverride::default() };
    let narrow = lib.load(spec).unwrap();
    assert_eq!(narrow.camera.look_at, framed.camera.look_at);
    assert!(
        narrow.camera.eye.distance(narrow.camera.look_at) > framed.camera.eye.distance(framed.camera.look_at)
    );
    lib.camera = CameraOverride { eye: Some([0.0, 0.0, 9.0]), ..CameraOverride::default() };
    let moved = lib.load(spec).unwrap();
    assert_eq!((moved.camera.eye, moved.camera.look_at), (Vec3A::new(0.0, 0.0, 9.0), framed.camera.look_at));
    let wknd = lib.load("wknd").unwrap();
    assert_eq!(wknd.camera.eye, Vec3A::new(0.0, 0.0, 9.0), "built-in scenes too");
    for (bad, flag) in [
        (CameraOverride { vfov: Some(180.0), ..CameraOverride::default() }, "--vfov"),
        (CameraOverride { up: Some([0.0; 3]), ..CameraOverride::default() }, "--camera-up"),
        (
            CameraOverride { look_at: Some([f32::NAN, 0.0, 0.0]), ..CameraOverride::default() },
            "--camera-look-at",
        ),
    ] {
        lib.camera = bad;
        let e = lib.load(spec).expect_err(flag).to_string();
        assert!(e.contains(flag), "{e}");
    }
    assert_eq!(parse_vec3("1, 2.5,-3"), Ok([1.0, 2.5, -3.0]));
    assert!(parse_vec3("1,2").is_err() && parse_vec3("1,x,3").unwrap_err().contains("'x'"));
}

#[test]
fn unknown_scene_lists_known_names() {
    let lib = library("unknown");
    let e = lib.load("nonesuch").expect_err("unknown").to_string();
    assert!(
        e.contains("nonesuch") && e.contains("wknd") && e.contains("clutter") && e.contains("bunny69k"),
        "{e}"
    );
    assert!(e.contains(".obj") && e.contains(".toml"), "says paths are accepted: {e}");
    let e = lib.load("missing/cube.obj").expect_err("no such file").to_string();
    assert!(e.contains("missing/cube.obj"), "{e}");
    let stl = write(&lib.data, "cube.stl", b"solid\n");
    let e = lib.load(stl.to_str().unwrap()).expect_err("stl").to_string();
    assert!(e.contains("cube.stl") && e.contains("unknown scene file type"), "{e}");
}

/// Shipped descriptions are embedded; without the data folder their meshes are a clear error
/// that says how to point sms at the data.
#[test]
fn shipped_description_without_data_says_where_to_look() {
    let lib = library("nodata");
    let e = lib.load("bunny69k").expect_err("no data").to_string();
    for needle in
        ["stanford-bunny-69k.obj.gz", "--scenes-dir", "SMS_SCENES_DIR", "shipped description 'bunny69k'"]
    {
        assert!(e.contains(needle), "{needle}: {e}");
    }
    let lib = SceneLibrary { origin: DataOrigin::NotFound, ..lib };
    let e = lib.load("bunny69k").expect_err("no data").to_string();
    assert!(e.contains("no scenes folder"), "{e}");
}

#[test]
fn every_shipped_description_parses() {
    let lib = SceneLibrary::default();
    let names = lib.described().expect("shipped");
    assert!(names.len() >= 15, "{names:?}");
    // The embedded list is the project's scenes/ folder.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    for (name, text) in SHIPPED {
        assert_eq!(std::fs::read_to_string(dir.join(format!("{name}.toml"))).unwrap(), *text, "{name}");
        let desc: SceneDesc = toml::from_str(text).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!desc.mesh.is_empty(), "{name}");
    }
    let on_disk = std::fs::read_dir(&dir)
        .unwrap()
        .filter(|e| e.as_ref().unwrap().path().extension().is_some_and(|x| x == "toml"));
    assert_eq!(on_disk.count(), SHIPPED.len());
    // And the data folder holds every mesh they read.
    crate::prereq::scene_data();
}

#[test]
fn the_first_missing_mesh_is_named_with_its_description() {
    let lib = library("partial");
    let e = lib.first_missing_mesh().expect("an empty folder has no mesh").to_string();
    assert!(e.starts_with(&lib.data.join("2CylinderEngine.glb").display().to_string()), "{e}");
    assert!(e.contains("shipped description '2cylinderengine'"), "{e}");
    // With that file there, the next description's mesh is the first missing one.
    write(&lib.data, "2CylinderEngine.glb", b"");
    let e = lib.first_missing_mesh().expect("the others are missing").to_string();
    assert!(e.contains("bath-partial.obj.gz") && e.contains("'bath-partial'"), "{e}");
}

#[test]
fn builtin_scenes_are_deterministic() {
    for name in procedural::NAMES {
        let (a, b) = (load_scene(name).expect(name), load_scene(name).expect(name));
        assert_eq!(format!("{:?}", a.primitives), format!("{:?}", b.primitives));
    }
    let wknd = load_scene("wknd").expect("wknd");
    assert_eq!(wknd.primitives.triangle_count(), 0);
    assert!((470..=490).contains(&wknd.primitives.len()));
}
