//! An installed `sms` works from any folder, on meshes and scene
//! descriptions given by path, and bad meshes given by path are clear errors.
//!
//! "Installed" here is the built binary copied alone into a temporary `bin/` folder, then run
//! from another temporary folder: that is what `cargo install` leaves (one file, no source tree
//! beside it). Running `cargo install` itself inside the test would rebuild `rtl` and `tb` with
//! another feature set (the test build turns on `rtl/mutants` through the dev-dependency), which
//! takes minutes on this machine and contends for the target folder; the copy tests the same
//! thing: nothing the binary needs may come from its source tree or from compile-time paths.

mod common;
use common::TmpDir;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::RwLock;

/// A unit cube (8 vertices, 6 quads), facing outwards.
const CUBE_OBJ: &str = "\
v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1
f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8
";

/// The same cube as ASCII PLY.
const CUBE_PLY: &str = "\
ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\nproperty float z
element face 6\nproperty list uchar int vertex_indices\nend_header
0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1
4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7
";

/// Held for reading while a test spawns a process, for writing while one copies the binary.
static FORKS: RwLock<()> = RwLock::new(());

/// A folder with `bin/sms` (the binary alone) and an empty working folder `work/`.
struct Installed {
    tmp: TmpDir,
}

impl Installed {
    fn new(test: &str) -> Self {
        let tmp = TmpDir::new("install", test);
        std::fs::create_dir_all(tmp.join("bin")).unwrap();
        std::fs::create_dir_all(tmp.join("work")).unwrap();
        // While the copy is open for writing, a child forked by another test thread inherits it
        // until its exec, and executing the copy then fails with "Text file busy": copies wait
        // for every spawn in progress, and spawns for every copy.
        let _copying = FORKS.write().unwrap();
        std::fs::copy(env!("CARGO_BIN_EXE_sms"), tmp.join("bin/sms")).unwrap();
        Installed { tmp }
    }

    fn work(&self) -> PathBuf {
        self.tmp.join("work")
    }

    /// Writes `bytes` to `work/<name>` (creating folders).
    fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.work().join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, bytes).unwrap();
        path
    }

    /// Runs the installed binary in `work/`, with no scene folder configured.
    fn sms(&self, args: &[&str]) -> Output {
        self.spawn(args, |c| c.env_remove("SMS_SCENES_DIR"))
    }

    /// Runs the installed binary in `work/` with `env` applied to its environment.
    fn spawn(&self, args: &[&str], env: impl FnOnce(&mut Command) -> &mut Command) -> Output {
        let mut cmd = Command::new(self.tmp.join("bin/sms"));
        cmd.args(args).current_dir(self.work()).env("RUST_BACKTRACE", "1");
        env(&mut cmd);
        cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
        let spawning = FORKS.read().unwrap();
        let child = cmd.spawn().unwrap();
        drop(spawning);
        child.wait_with_output().unwrap()
    }

    /// A tiny cycle-level run of `scene`; returns the parsed JSON report.
    fn run(&self, scene: &str, extra: &[&str]) -> serde_json::Value {
        let mut args = vec!["run", "--scene", scene, "--res", "8x8", "--spp", "1", "--bounces", "1"];
        args.extend_from_slice(&["-c", "RB_8", "--json"]);
        args.extend_from_slice(extra);
        let out = self.sms(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "sms {args:?} failed: {stderr}");
        serde_json::from_slice(&out.stdout)
            .unwrap_or_else(|e| panic!("{e}: {}", String::from_utf8_lossy(&out.stdout)))
    }

    /// Runs `sms run --scene <path>` expecting a clean failure; returns stderr.
    fn fails(&self, scene: &Path) -> String {
        let out = self.sms(&["run", "--scene", scene.to_str().unwrap(), "--res", "4x4", "-c", "RB_8"]);
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(!out.status.success(), "{} was accepted", scene.display());
        assert_eq!(out.status.code(), Some(1), "exit code of a bad input: {stderr}");
        assert!(!stderr.contains("panicked") && !stderr.contains("backtrace"), "a panic: {stderr}");
        let name = scene.file_name().unwrap().to_str().unwrap();
        assert!(stderr.contains(name), "the message names {name}: {stderr}");
        stderr
    }
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    gz.write_all(bytes).unwrap();
    gz.finish().unwrap()
}

/// A glTF holding one primitive of `mode` (0 points, 1 lines, 3 line strip, 4 triangles) over
/// three vertices, the buffer embedded.
fn gltf_triangle(mode: u32) -> String {
    let floats: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    let bytes: Vec<u8> = floats.iter().flat_map(|f| f.to_le_bytes()).collect();
    let uri = format!("data:application/octet-stream;base64,{}", {
        use base64::Engine;
        base64::engine::general_purpose::STANDARD.encode(&bytes)
    });
    serde_json::json!({
        "asset": { "version": "2.0" },
        "buffers": [{ "byteLength": 36, "uri": uri }],
        "bufferViews": [{ "buffer": 0, "byteLength": 36 }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "max": [1, 1, 0], "min": [0, 0, 0] }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "mode": mode }] }],
        "nodes": [{ "mesh": 0 }],
        "scenes": [{ "nodes": [0] }],
        "scene": 0
    })
    .to_string()
}

/// Rays and cycles of a one-configuration report.
fn rays_cycles(report: &serde_json::Value) -> (u64, u64) {
    let gpu = &report["results"][0]["full"]["gpu"];
    (report["rays"].as_u64().unwrap(), gpu["cycles"].as_u64().unwrap())
}

#[test]
fn installed_binary_runs_meshes_and_descriptions_given_by_path() {
    let sms = Installed::new("paths");
    sms.file("cube.obj", CUBE_OBJ.as_bytes());
    sms.file("meshes/cube.ply", CUBE_PLY.as_bytes());
    sms.file("cube.obj.gz", &gzip(CUBE_OBJ.as_bytes()));
    // A description in its own folder; its mesh path is relative to it.
    sms.file("desc/two-cubes.toml", b"[[mesh]]\nfile = \"../meshes/cube.ply\"\n[[mesh]]\nfile = \"../cube.obj\"\ntransform = [[1,0,0,3],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n[render]\nwidth = 16\nheight = 16\n");

    let pixels = 8 * 8;
    let mut seen = Vec::new();
    for scene in ["cube.obj", "meshes/cube.ply", "cube.obj.gz", "desc/two-cubes.toml"] {
        let report = sms.run(scene, &[]);
        let (rays, cycles) = rays_cycles(&report);
        // The framed camera sees the cube: some primary rays hit and bounce.
        assert!(rays > pixels && cycles > 0, "{scene}: {rays} rays, {cycles} cycles");
        seen.push((scene, rays, cycles));
    }
    // The same cube read three ways traces the same rays.
    assert_eq!(seen[0].1..=seen[0].2, seen[2].1..=seen[2].2, "obj and obj.gz");
    assert_eq!(seen[0].1, seen[1].1, "obj and ply");
    // An absolute path works as well, and a hardware preset needs no file either.
    let abs = sms.work().join("cube.obj");
    let report = sms.run(abs.to_str().unwrap(), &["--hw", "rtx2060"]);
    assert!(rays_cycles(&report).1 > 0);
    // A built-in scene needs no data at all.
    assert!(rays_cycles(&sms.run("clutter", &[])).0 > 0);

    // The camera flags override the framing: looking away from the cube, every primary ray
    // misses and no path bounces.
    let away = sms.run("cube.obj", &["--camera-eye", "0.5,0.5,5", "--camera-look-at", "0.5,0.5,10"]);
    assert_eq!(rays_cycles(&away).0, pixels, "{away}");
    let toward =
        sms.run("cube.obj", &["--camera-eye", "0.5,0.5,5", "--camera-look-at", "0.5,0.5,0", "--vfov", "30"]);
    assert!(rays_cycles(&toward).0 > pixels);
}

#[test]
fn a_described_scene_without_its_data_says_how_to_point_sms_at_it() {
    let sms = Installed::new("nodata");
    let out = sms.sms(&["run", "--scene", "bunny69k", "--res", "4x4", "-c", "RB_8"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    for needle in ["stanford-bunny-69k.obj.gz", "--scenes-dir", "SMS_SCENES_DIR"] {
        assert!(stderr.contains(needle), "{needle} not in: {stderr}");
    }
    // Pointed at a folder that has the mesh, the same name loads.
    let data = sms.tmp.join("data");
    std::fs::create_dir_all(&data).unwrap();
    std::fs::write(data.join("stanford-bunny-69k.obj.gz"), gzip(CUBE_OBJ.as_bytes())).unwrap();
    let report = sms.run("bunny69k", &["--scenes-dir", data.to_str().unwrap()]);
    assert!(rays_cycles(&report).0 > 0);
    let args = ["run", "--scene", "bunny69k", "--res", "4x4", "--spp", "1", "--bounces", "0", "-c", "RB_8"];
    let out = sms.spawn(&args, |c| c.env("SMS_SCENES_DIR", &data));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn bad_meshes_given_by_path_are_clear_errors() {
    let sms = Installed::new("bad");
    let nan = sms.file("nan.obj", b"v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n");
    let e = sms.fails(&nan);
    assert!(e.contains("line 2") && e.contains("not finite"), "{e}");

    let range = sms.file("range.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    let e = sms.fails(&range);
    assert!(e.contains("line 4") && e.contains("out of range"), "{e}");

    let ply = sms.file("range.ply", CUBE_PLY.replace("4 3 0 4 7", "4 3 0 4 8").as_bytes());
    let e = sms.fails(&ply);
    assert!(e.contains("out of range"), "{e}");

    let whole = gzip(CUBE_OBJ.as_bytes());
    let truncated = sms.file("truncated.obj.gz", &whole[..whole.len() / 2]);
    let e = sms.fails(&truncated);
    assert!(e.contains("corrupt or truncated gzip data"), "{e}");

    let junk = sms.file("junk.gltf", b"this is not a glTF file");
    let e = sms.fails(&junk);
    assert!(e.contains("glTF"), "{e}");

    let junk_glb = sms.file("junk.glb.gz", &gzip(b"glTF but not really"));
    let e = sms.fails(&junk_glb);
    assert!(e.contains("glTF"), "{e}");

    let missing = sms.work().join("nowhere/missing.ply");
    let e = sms.fails(&missing);
    assert!(e.contains("No such file"), "{e}");

    let unknown = sms.file("cube.stl", b"solid cube\n");
    let e = sms.fails(&unknown);
    assert!(e.contains(".obj") && e.contains(".gltf"), "{e}");

    let bad_desc = sms.file("bad.toml", b"[[mesh]]\nfile = \"cube.obj\"\ncolour = 3\n");
    let e = sms.fails(&bad_desc);
    assert!(e.contains("line 3"), "{e}");

    // What a file named .obj is instead of OBJ text, and why a mesh has no triangles.
    let utf16: Vec<u8> =
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".encode_utf16().flat_map(u16::to_le_bytes).collect();
    let with_bom = [&[0xff, 0xfe][..], &utf16].concat();
    for (name, bytes, want) in [
        ("utf16.obj", with_bom.clone(), "UTF-16 text; sms reads OBJ as ASCII or UTF-8 text"),
        ("utf16-no-bom.obj", utf16.clone(), "UTF-16 text"),
        ("utf16.obj.gz", gzip(&with_bom), "UTF-16 text"),
        ("binary.obj", (0u8..=255).cycle().take(600).collect(), "binary data, not OBJ text"),
        (
            "model.obj",
            b"glTF\x02\0\0\0rest".to_vec(),
            "binary glTF (GLB) data, not OBJ text: name the file .glb",
        ),
        ("packed.obj", gzip(CUBE_OBJ.as_bytes()), "gzip-compressed data: name the file .obj.gz"),
        ("cube.ply.obj", CUBE_PLY.as_bytes().to_vec(), "a PLY file, not OBJ text"),
        ("comments.obj", b"# only a comment\nv 0 0 0\n".to_vec(), "no triangles: the file holds no faces"),
        (
            "flat.obj",
            b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n".to_vec(),
            "no triangles: all 1 of its faces have zero area",
        ),
    ] {
        let e = sms.fails(&sms.file(name, &bytes));
        assert!(e.contains(want), "{name}: {e}");
    }
    // A UTF-8 byte-order mark is read past.
    sms.file("bom.obj", &[b"\xef\xbb\xbf", CUBE_OBJ.as_bytes()].concat());
    assert!(rays_cycles(&sms.run("bom.obj", &[])).1 > 0);
    // glTF: primitives of points or lines only; glTF 1 with its version as a number.
    for (mode, name) in [(0, "points.gltf"), (1, "lines.gltf"), (3, "strip.gltf")] {
        let e = sms.fails(&sms.file(name, gltf_triangle(mode).as_bytes()));
        assert!(e.contains("no triangles: its 1 primitive(s) are points or lines"), "{name}: {e}");
    }
    assert!(
        rays_cycles(&sms.run(sms.file("tri.gltf", gltf_triangle(4).as_bytes()).to_str().unwrap(), &[])).1 > 0
    );
    let v1 = sms.file("v1.gltf", br#"{"asset": {"version": 1.0}, "meshes": {}}"#);
    let e = sms.fails(&v1);
    assert!(e.contains("glTF: version 1.0; sms reads glTF 2.0"), "{e}");

    for dir in ["meshes", "meshes.obj"] {
        let path = sms.work().join(dir);
        std::fs::create_dir_all(&path).unwrap();
        let e = sms.fails(&path);
        let want = format!(
            "error: {}: is a directory; a scene is a name, a mesh file (.obj, .ply, .glb, .gltf, optionally .gz) or a .toml description\n",
            path.display()
        );
        assert_eq!(e, want);
    }
}

#[test]
fn scenes_lists_every_name_marking_missing_meshes() {
    let sms = Installed::new("scenes");
    let out = sms.sms(&["scenes"]);
    let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{stderr}");
    let library = tb::workload::scene::SceneLibrary::default();
    let names = library.names().unwrap();
    let rows: Vec<&str> = stdout.lines().skip(2).collect();
    assert_eq!(rows.len(), names.len(), "one row per scene: {stdout}");
    for (row, name) in rows.iter().zip(&names) {
        assert!(row.starts_with(&format!("{name:<19} ")), "{row}");
        let builtin = tb::workload::scene::procedural::NAMES.contains(&name.as_str());
        assert_eq!(row.contains(": missing"), !builtin, "{row}");
    }
    let described = names.len() - tb::workload::scene::procedural::NAMES.len();
    assert!(stderr.contains("scene data: no scenes folder: "), "{stderr}");
    let note = format!("{described} scene(s) lack data; `sms scenes --fetch DIR --from URL` lays out");
    assert!(stderr.lines().last().unwrap().starts_with(&note), "{stderr}");
    assert!(sms.sms(&["scenes", "-q"]).stderr.is_empty(), "-q: the listing only");

    // The listing reads the manifest and the files' sizes, never a mesh: a file of the listed
    // size counts as present whatever it holds (--fetch checks the SHA-256, --build loads it).
    let data = sms.tmp.join("data");
    std::fs::create_dir_all(&data).unwrap();
    let listed = tb::workload::scene::manifest::Manifest::shipped();
    let bunny = listed.file("stanford-bunny-69k.obj.gz").unwrap();
    std::fs::write(data.join(&bunny.file), vec![b'x'; bunny.bytes as usize]).unwrap();
    std::fs::write(data.join("karimSchooner.obj.gz"), b"too short").unwrap();
    let d = data.to_str().unwrap();
    let out = sms.sms(&["scenes", "bunny69k", "ship", "--scenes-dir", d, "--format", "json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let scenes = json["scenes"].as_array().unwrap();
    assert_eq!((&scenes[0]["name"], &scenes[0]["triangles"]), (&"bunny69k".into(), &69_451.into()));
    assert_eq!(scenes[0]["files"][0]["state"], "present");
    assert_eq!(scenes[1]["files"][0]["state"], "wrong size");
    let csv =
        String::from_utf8(sms.sms(&["scenes", "bunny69k", "--scenes-dir", d, "--format", "csv"]).stdout)
            .unwrap();
    assert_eq!(csv, "scene,kind,triangles,bytes,data,files\nbunny69k,described,69451,819403,present,stanford-bunny-69k.obj.gz\n");
    let out = sms.sms(&["scenes", "--build", "bunny69k", "--scenes-dir", d]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("stanford-bunny-69k.obj.gz"), "--build reads it: {e}");

    // A data folder that is not one is an error, whichever way it is given.
    let file = data.join("karimSchooner.obj.gz");
    let f = file.to_str().unwrap();
    let out = sms.sms(&["scenes", "--scenes-dir", f]);
    let e = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{e}");
    assert!(e.starts_with(&format!("error: --scenes-dir {f}: not a folder;")), "{e}");
    let out = sms.spawn(&["scenes"], |c| c.env("SMS_SCENES_DIR", sms.tmp.join("nowhere")));
    let e = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && e.contains("SMS_SCENES_DIR=") && e.contains(": no such folder;"), "{e}");
    let out = sms.sms(&["run", "--scene", "clutter", "--scenes-dir", f]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("not a folder"), "every command checks it");
}
