//! Loads one mesh file with one reader and prints the triangle count and the load time: `sms`
//! (the model's own reader, through `SceneLibrary::load` as `sms run --scene FILE` reads it),
//! `tobj` (OBJ) or `ply-rs` (PLY). Each result is the same triangle list the model uses, so the
//! peak memory `/usr/bin/time -v` reports compares like with like. `errors` prints what each
//! reader says about a few malformed files.

use std::io::{BufRead, BufReader};
use std::time::Instant;

use glam::Vec3A;
use obvhs::triangle::Triangle;

fn open(path: &str) -> Box<dyn BufRead> {
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    if path.ends_with(".gz") {
        Box::new(BufReader::with_capacity(1 << 16, flate2::read::GzDecoder::new(file)))
    } else {
        Box::new(BufReader::with_capacity(1 << 16, file))
    }
}

fn with_tobj(mut reader: impl BufRead) -> Result<Vec<Triangle>, String> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::GenericFailure))
        .map_err(|e| e.to_string())?;
    let mut tris = Vec::new();
    for m in models {
        let (p, idx) = (&m.mesh.positions, &m.mesh.indices);
        let v = |i: u32| Vec3A::new(p[3 * i as usize], p[3 * i as usize + 1], p[3 * i as usize + 2]);
        for t in idx.chunks_exact(3) {
            tris.push(Triangle { v0: v(t[0]), v1: v(t[1]), v2: v(t[2]) });
        }
    }
    Ok(tris)
}

fn with_ply_rs(mut reader: impl BufRead) -> Result<Vec<Triangle>, String> {
    use ply_rs::ply::{DefaultElement, Property};
    let ply =
        ply_rs::parser::Parser::<DefaultElement>::new().read_ply(&mut reader).map_err(|e| e.to_string())?;
    let f = |p: Option<&Property>| match p {
        Some(Property::Float(x)) => *x,
        Some(Property::Double(x)) => *x as f32,
        _ => f32::NAN,
    };
    let verts: Vec<Vec3A> = ply.payload["vertex"]
        .iter()
        .map(|e| Vec3A::new(f(e.get("x")), f(e.get("y")), f(e.get("z"))))
        .collect();
    let mut tris = Vec::new();
    for face in &ply.payload["face"] {
        let idx: Vec<usize> = match face.get("vertex_indices").or(face.get("vertex_index")) {
            Some(Property::ListInt(l)) => l.iter().map(|&i| i as usize).collect(),
            Some(Property::ListUInt(l)) => l.iter().map(|&i| i as usize).collect(),
            other => return Err(format!("face list {other:?}")),
        };
        for k in 1..idx.len().saturating_sub(1) {
            tris.push(Triangle { v0: verts[idx[0]], v1: verts[idx[k]], v2: verts[idx[k + 1]] });
        }
    }
    Ok(tris)
}

fn errors() {
    let cases: [(&str, &[u8]); 4] = [
        ("obj: a bad number on line 2", b"v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n"),
        ("obj: an index out of range on line 4", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
        ("obj: a Latin-1 material name", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl caf\xe9\nf 1 2 3\n"),
        ("ply: Blender's free-text header line", b"ply\nformat ascii 1.0\nCreated by Blender3D\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
    ];
    let dir = std::env::temp_dir().join(format!("mesh-readers-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (what, bytes) in cases {
        let ext = &what[..3];
        let path = dir.join(format!("case.{ext}"));
        std::fs::write(&path, bytes).unwrap();
        let sms =
            tb::SceneLibrary::default().load(path.to_str().unwrap()).map(|s| s.primitives.triangle_count());
        let other = if ext == "obj" { with_tobj(bytes) } else { with_ply_rs(bytes) }.map(|t| t.len());
        println!(
            "{what}\n  sms:   {:?}\n  {}: {:?}",
            sms.map_err(|e| e.to_string()),
            if ext == "obj" { "tobj" } else { "ply-rs" },
            other
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [reader, path] = match &args[..] {
        [e] if e == "errors" => return errors(),
        [r, p] => [r.as_str(), p.as_str()],
        _ => panic!("usage: mesh-readers sms|tobj|ply-rs FILE, or mesh-readers errors"),
    };
    let start = Instant::now();
    let triangles = match reader {
        "sms" => tb::SceneLibrary::default()
            .load(path)
            .map(|s| s.primitives.triangle_count())
            .map_err(|e| e.to_string()),
        "tobj" => with_tobj(open(path)).map(|t| t.len()),
        "ply-rs" => with_ply_rs(open(path)).map(|t| t.len()),
        _ => panic!("unknown reader {reader}"),
    };
    let ms = start.elapsed().as_millis();
    match triangles {
        Ok(n) => println!("{reader} {path}: {n} triangles in {ms} ms"),
        Err(e) => println!("{reader} {path}: error after {ms} ms: {e}"),
    }
}
