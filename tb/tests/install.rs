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
    let rows: Vec<&str> = stdout.lines().skip(1).collect();
    assert_eq!(rows.len(), names.len(), "one row per scene: {stdout}");
    for (row, name) in rows.iter().zip(&names) {
        assert!(row.starts_with(&format!("{name:<20} ")), "{row}");
        let builtin = tb::workload::scene::procedural::NAMES.contains(&name.as_str());
        assert_eq!(row.contains(" mesh missing: "), !builtin, "{row}");
    }
    let described = names.len() - tb::workload::scene::procedural::NAMES.len();
    let note = format!("{described} scenes' meshes are missing (no scenes folder: ");
    assert!(stderr.lines().last().unwrap().starts_with(&note), "{stderr}");
}
