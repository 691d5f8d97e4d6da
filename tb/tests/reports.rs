//! What every report states and how `sms` treats careless input: provenance in every format,
//! per-ray figures, SMS's SH ↔ global traffic, no self-comparison, the workload estimate and its
//! limit, no writes into the scene data, `-q` everywhere, Ctrl-C on a sweep, sharded sweeps.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

mod common;
use common::TmpDir;

/// The smallest real run: 8×8 pixels, one sample, no bounce.
const TINY: [&str; 8] = ["--scene", "clutter", "--res", "8x8", "--spp", "1", "--bounces", "0"];

fn sms(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sms")).args(args).output().expect("sms runs")
}

fn stdout(o: &Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout.clone()).unwrap()
}

/// The one-line error of a failed run.
fn error(o: &Output) -> String {
    assert!(!o.status.success(), "should fail: {}", String::from_utf8_lossy(&o.stdout));
    let err = String::from_utf8(o.stderr.clone()).unwrap();
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.starts_with("error: ") && !err.contains("panicked"), "{err}");
    err
}

fn run_json(more: &[&str]) -> Value {
    let o = sms(&[&["run", "-q"], &TINY[..], &["--json"], more].concat());
    serde_json::from_str(&stdout(&o)).unwrap()
}

#[test]
fn run_json_states_provenance_and_the_hardware_hash_tells_presets_apart() {
    let paper = run_json(&["-c", "SMS", "--hw", "paper"]);
    let legacy = run_json(&["-c", "SMS", "--hw", "legacy"]);
    for key in ["scene", "workload", "pixel_warps", "rays", "fidelity", "results"] {
        assert!(paper.get(key).is_some(), "existing field {key} kept");
    }
    let p = &paper["provenance"];
    assert_eq!(p["scenes"], serde_json::json!(["clutter"]));
    assert_eq!(
        (p["resolution"].as_str(), p["spp"].as_u64(), p["bounces"].as_u64()),
        (Some("8x8"), Some(1), Some(0))
    );
    assert_eq!(
        (p["seed"].as_u64(), p["accel"].as_str(), p["bvh"].as_str()),
        (Some(0), Some("two-level"), Some("bvh6"))
    );
    assert_eq!(p["hardware"]["name"], "paper");
    assert_eq!(legacy["provenance"]["hardware"]["name"], "legacy");
    let hash = |v: &Value| v["provenance"]["hardware"]["hash"].as_str().unwrap().to_string();
    assert_eq!(hash(&paper).len(), 16);
    assert_ne!(hash(&paper), hash(&legacy), "paper and legacy hardware differ");
    assert_eq!(hash(&paper), hash(&run_json(&["-c", "SMS"])), "the default is paper, the hash stable");
    assert_eq!(p["model"]["version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(p["model"]["sources"], tb::run::sweep::cache::MODEL_VERSION);
    assert!(p["model"].get("commit").is_some());
    // The lock file the binary was built with, hashed as `sha256sum Cargo.lock` hashes it.
    let lock = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../Cargo.lock")).unwrap();
    assert_eq!(p["model"]["cargo_lock"], tb::digest::sha256_hex(&lock));
    assert!(p.get("files").is_none(), "a named scene states no files");

    // Per-ray figures: what was simulated, divided by its rays.
    let r = &paper["results"][0];
    let g = &r["full"]["gpu"];
    let rays = g["rays"].as_f64().unwrap();
    let per_ray = &r["per_ray"];
    assert_eq!(per_ray["cycles"].as_f64().unwrap(), g["cycles"].as_f64().unwrap() / rays);
    assert_eq!(per_ray["node_fetches"].as_f64().unwrap(), g["node_fetches"].as_f64().unwrap() / rays);
    let s = &r["full"]["stack"];
    let ops = s["pushes"].as_f64().unwrap() + s["pops"].as_f64().unwrap();
    assert_eq!(per_ray["stack_ops"].as_f64().unwrap(), ops / rays);
    // Finished no earlier than it took since the simulations started.
    assert!(r["finished_at"].as_f64().unwrap() >= r["full"]["wall"].as_f64().unwrap());
}

/// SHA-256's published test vector, so the lock-file and mesh hashes are SHA-256 indeed.
#[test]
fn file_hashes_are_sha256() {
    assert_eq!(
        tb::digest::sha256_hex(b"abc"),
        "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
    );
}

/// A mesh or description given by path is named in the provenance with the SHA-256 of each
/// file read, in every format; another file of the same name gets another hash.
#[test]
fn a_scene_given_by_path_states_its_files_and_their_hashes() {
    let tmp = TmpDir::new("reports", "mesh-provenance");
    let cube = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";
    let mesh = tmp.join("quad.obj");
    std::fs::write(&mesh, cube).unwrap();
    let desc = tmp.join("scene.toml");
    std::fs::write(&desc, "[[mesh]]\nfile = \"quad.obj\"\n").unwrap();
    let args = ["run", "-q", "--res", "4x4", "--spp", "1", "--bounces", "0", "-c", "RB_8"];
    let run = |scene: &Path, more: &[&str]| {
        stdout(&sms(&[&args[..], &["--scene", scene.to_str().unwrap()], more].concat()))
    };
    let sha = tb::digest::sha256_hex(cube.as_bytes());
    let json: Value = serde_json::from_str(&run(&mesh, &["--json"])).unwrap();
    let files = &json["provenance"]["files"];
    assert_eq!(files, &serde_json::json!([{ "path": mesh.to_str().unwrap(), "sha256": sha }]));
    let text = run(&mesh, &[]);
    let line = text.lines().next().unwrap();
    assert!(line.contains(&format!("file {} (sha256 {})", mesh.display(), &sha[..16])), "{line}");
    let json: Value = serde_json::from_str(&run(&desc, &["--json"])).unwrap();
    let paths: Vec<&str> =
        json["provenance"]["files"].as_array().unwrap().iter().map(|f| f["path"].as_str().unwrap()).collect();
    assert_eq!(paths, [desc.to_str().unwrap(), tmp.join("quad.obj").to_str().unwrap()]);
    std::fs::write(&mesh, cube.replace("1 1 0", "1 2 0")).unwrap();
    let json: Value = serde_json::from_str(&run(&mesh, &["--json"])).unwrap();
    assert_ne!(json["provenance"]["files"][0]["sha256"], sha, "the content, not the name");
}

/// `--sample 1` samples every warp: that is the full run, report for report.
#[test]
fn a_sample_of_every_warp_is_the_full_run() {
    // Wall-clock fields aside.
    let strip = |mut v: Value| {
        for r in v["results"].as_array_mut().unwrap() {
            r["finished_at"] = Value::Null;
            r["full"]["wall"] = Value::Null;
        }
        v
    };
    for level in ["cycle", "functional"] {
        let full = strip(run_json(&["-c", "RB_2,SMS", "--fidelity", level]));
        let sampled = strip(run_json(&["-c", "RB_2,SMS", "--fidelity", level, "--sample", "1"]));
        assert_eq!(full, sampled, "{level}");
        assert!(sampled["results"][0]["sampled"].is_null(), "no estimate, no interval");
    }
    let text = stdout(&sms(&[&["run", "-q"], &TINY[..], &["-c", "RB_2", "--sample", "1"]].concat()));
    assert!(!text.contains('±'), "{text}");
    // Planted: a sample of nearly every warp is a sample, with intervals.
    let almost = run_json(&["-c", "RB_2", "--sample", "0.99", "--batches", "2"]);
    assert!(almost["results"][0]["sampled"].is_object(), "{almost}");
}

#[test]
fn the_run_table_has_per_ray_rows_sms_global_traffic_and_no_self_comparison() {
    let one = stdout(&sms(&[&["run", "-q"], &TINY[..], &["-c", "RB_2+SH_2+SK+RA"]].concat()));
    assert!(one.starts_with("provenance: scene clutter · 8x8 px · 1 spp · 0 bounce(s) · seed 0"), "{one}");
    assert!(one.contains("hardware paper (hash ") && one.contains(" · sms "), "{one}");
    for row in [
        "per ray: cycles",
        "per ray: node fetches",
        "per ray: stack operations",
        "per ray: off-chip accesses",
        "RB → SH spills",
        "SH → global spills",
        "global → SH reloads",
        "finished at",
        "wall time",
    ] {
        assert!(one.contains(row), "no {row} row:\n{one}");
    }
    assert!(!one.contains("speed-up over"), "one configuration has nothing to compare with:\n{one}");
    let two = stdout(&sms(&[&["run", "-q"], &TINY[..], &["-c", "RB_8,SMS"]].concat()));
    assert!(two.contains("speed-up over RB_8"), "{two}");

    let csv = stdout(&sms(&[&["run", "-q"], &TINY[..], &["-c", "SMS", "--format", "csv"]].concat()));
    let mut lines = csv.lines();
    assert!(lines.next().unwrap().starts_with("# provenance: scene clutter"), "{csv}");
    assert!(lines.next().unwrap().starts_with("metric,"), "{csv}");
    let md = stdout(&sms(&[&["run", "-q"], &TINY[..], &["-c", "SMS", "--format", "markdown"]].concat()));
    assert!(md.starts_with("Provenance: scene clutter"), "{md}");
}

/// `sms run` shows where the thread-cycles went: a row per category in the table, shares
/// summing to 1 in the JSON (the raw counts in the GPU counts, summing to the thread slots ×
/// cycles), the sampled warps' shares for a sampled run, and n/a at the functional level.
#[test]
fn the_run_reports_the_thread_cycle_breakdown() {
    const NAMES: [&str; 5] = ["node_data", "fetch_queue", "stack", "latency", "idle"];
    let text = stdout(&sms(&[&["run", "-q"], &TINY[..], &["-c", "RB_2,SMS"]].concat()));
    for label in ["node data", "fetch queue", "stack", "latency", "idle"] {
        assert!(text.lines().any(|l| l.starts_with(&format!("thread-cycles: {label} "))), "{label}:\n{text}");
    }
    let full = run_json(&["-c", "RB_2,SMS"]);
    for r in full["results"].as_array().unwrap() {
        let shares: f64 = NAMES.iter().map(|n| r["thread_cycles"][n].as_f64().unwrap()).sum();
        assert!((shares - 1.0).abs() < 1e-9, "{r}");
        let gpu = &r["full"]["gpu"];
        let counts: u64 = NAMES.iter().map(|n| gpu[format!("thread_cycles_{n}")].as_u64().unwrap()).sum();
        // The paper's GPU: 8 SMs, 4 warp slots of 32 lanes each.
        assert_eq!(counts, gpu["cycles"].as_u64().unwrap() * 8 * 4 * 32, "{r}");
        let stack = r["thread_cycles"]["stack"].as_f64().unwrap();
        assert!(stack > 0.0, "{r}");
    }
    let functional = run_json(&["-c", "SMS", "--fidelity", "functional"]);
    assert!(functional["results"][0]["thread_cycles"].is_null());
    let text =
        stdout(&sms(&[&["run", "-q"], &TINY[..], &["-c", "SMS", "--fidelity", "functional"]].concat()));
    assert!(text.lines().any(|l| l.starts_with("thread-cycles ") && l.contains("n/a")), "{text}");
    let sampled = stdout(&sms(&[&["run", "-q"], &TINY[..], &["-c", "SMS", "--sample", "0.5"]].concat()));
    assert!(sampled.contains("thread-cycles: stack (sampled warps)"), "{sampled}");
}

#[test]
fn cost_and_depth_reports_state_their_provenance() {
    let cost: Value = serde_json::from_str(&stdout(&sms(&["cost", "-c", "SMS,RB_8", "--json"]))).unwrap();
    for r in cost.as_array().unwrap() {
        assert!(r["totals"].is_object(), "existing fields kept");
        assert_eq!(r["provenance"]["hardware"]["name"], "paper");
        assert!(r["provenance"].get("scenes").is_none(), "a cost has no workload");
    }
    assert!(stdout(&sms(&["cost", "--format", "csv"])).starts_with("# provenance: hardware paper"));
    assert!(stdout(&sms(&["cost", "--hw", "legacy"])).starts_with("provenance: hardware legacy"));

    let out = TmpDir::new("reports", "depth");
    let dir = out.path().to_str().unwrap();
    let depth: Value =
        serde_json::from_str(&stdout(&sms(
            &[&["depth", "-q", "--out", dir], &TINY[..], &["--json"]].concat()
        )))
        .unwrap();
    assert!(depth["histogram"].is_object(), "existing fields kept");
    assert_eq!(depth["provenance"]["resolution"], "8x8");
    assert!(depth["provenance"].get("hardware").is_none(), "depth does not depend on the hardware");
}

#[test]
fn a_workload_too_large_is_refused_with_its_estimate_before_any_work() {
    let start = Instant::now();
    let err = error(&sms(&["run", "-q", "--scene", "clutter", "--spp", "1000000000"]));
    assert!(err.starts_with("error: estimated at most ") && err.contains(" rays, "), "{err}");
    assert!(err.contains("--force"), "names the override: {err}");
    let err = error(&sms(&["depth", "-q", "--scene", "clutter", "--res", "100000x100000", "--spp", "1000"]));
    assert!(err.contains("--force"), "{err}");
    for sub in ["sweep", "ablate"] {
        let err = error(&sms(&[sub, "-q", "--quick", "--spp", "1000000000", "--out", "/nonexistent/never"]));
        assert!(err.starts_with("error: estimated at most ") && err.contains("--force"), "{err}");
    }
    assert!(start.elapsed() < Duration::from_secs(30), "refused at once, not after tracing");
    // A run within the limits says what it expects on stderr.
    let o = sms(&[&["run"], &TINY[..], &["-c", "SMS"]].concat());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("estimated at most 64 rays"), "{err}");
}

#[test]
fn nothing_is_written_into_the_scene_data_folder() {
    let tmp = TmpDir::new("reports", "scene-data");
    let data = tmp.join("data");
    std::fs::create_dir_all(&data).unwrap();
    let d = data.to_str().unwrap();
    let inside = |name: &str| data.join(name).to_str().unwrap().to_string();
    let with_data = |args: &[&str]| sms(&[args, &["--scenes-dir", d]].concat());
    let cases: [(Vec<String>, &str); 5] = [
        (vec!["run".into(), "-c".into(), "SMS".into(), "--vcd".into(), inside("w.vcd")], "--vcd"),
        (vec!["run".into(), "--png".into(), inside("sub/r.png")], "--png"),
        (vec!["depth".into(), "--out".into(), inside("depth")], "--out"),
        (vec!["sweep".into(), "--quick".into(), "--out".into(), inside("sweep")], "--out"),
        (vec!["ablate".into(), "--quick".into(), "--cache".into(), inside("cache")], "--cache"),
    ];
    for (args, flag) in cases {
        let mut argv: Vec<&str> = args.iter().map(String::as_str).collect();
        if argv[0] != "sweep" && argv[0] != "ablate" {
            argv.extend(TINY);
        }
        let err = error(&with_data(&argv));
        assert!(err.starts_with(&format!("error: {flag} ")), "{err}");
        assert!(err.contains("inside the scene data folder"), "{err}");
    }
    // Commands without --scenes-dir find the data folder themselves: SMS_SCENES_DIR here.
    for (argv, flag) in [
        (vec!["check".to_string(), "--vcd".into(), inside("cex.vcd")], "--vcd"),
        (vec!["prove".to_string(), "--vcd".into(), inside("cex.vcd")], "--vcd"),
        (vec!["bench".to_string(), "--out".into(), inside("bench")], "--out"),
    ] {
        let o =
            Command::new(env!("CARGO_BIN_EXE_sms")).args(&argv).env("SMS_SCENES_DIR", d).output().unwrap();
        let err = error(&o);
        assert!(
            err.starts_with(&format!("error: {flag} ")) && err.contains("inside the scene data folder"),
            "{err}"
        );
    }
    assert_eq!(std::fs::read_dir(&data).unwrap().count(), 0, "nothing written");
}

#[test]
fn quiet_is_accepted_by_every_subcommand_and_silences_progress() {
    for sub in ["scenes", "depth", "cost", "run", "check", "prove", "sweep", "ablate", "bench"] {
        for argv in [vec!["-q", sub, "--help"], vec![sub, "--quiet", "--help"]] {
            let o = sms(&argv);
            assert!(o.status.success(), "sms {argv:?}: {}", String::from_utf8_lossy(&o.stderr));
        }
    }
    let o = sms(&[&["run", "-q"], &TINY[..], &["-c", "SMS,RB_8"]].concat());
    assert!(o.status.success() && o.stderr.is_empty(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = TmpDir::new("reports", "quiet-depth");
    let o = sms(&[&["-q", "depth", "--out", out.path().to_str().unwrap()], &TINY[..]].concat());
    assert!(o.status.success() && o.stderr.is_empty(), "{}", String::from_utf8_lossy(&o.stderr));
    let noisy = sms(&[&["run"], &TINY[..], &["-c", "SMS"]].concat());
    assert!(String::from_utf8_lossy(&noisy.stderr).contains("done at"), "progress without -q");
    // Sweep-like commands: nothing but the report, with -q; their status lines without it.
    let tmp = TmpDir::new("reports", "quiet-sweep");
    let tiny = ["--scenes", "wknd", "--res", "8x8", "--spp", "1", "--bounces", "1"];
    for sub in ["sweep", "ablate"] {
        let out = tmp.join(sub);
        let args = [&[sub, "--out", out.to_str().unwrap()], &tiny[..]].concat();
        let quiet = sms(&[&args[..], &["-q"]].concat());
        assert!(
            quiet.status.success() && quiet.stderr.is_empty(),
            "{sub}: {}",
            String::from_utf8_lossy(&quiet.stderr)
        );
        assert!(!quiet.stdout.is_empty(), "{sub} prints its report");
        let noisy = sms(&args);
        let err = String::from_utf8_lossy(&noisy.stderr);
        assert!(err.contains(" s wall time") && err.contains("cache: "), "{sub}: {err}");
    }
}

/// A sweep of two built-in scenes, a small plan (RB_8 and SMS on the base L1D, no RB or L1D
/// sweep), tiny, with `extra` arguments.
fn small_sweep(out: &Path, extra: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sms"));
    cmd.args(["sweep", "--scenes", "wknd,clutter", "--res", "8x8", "--spp", "1", "--bounces", "1"])
        .args(["--configs", "SMS", "--rb-sizes", "8", "--l1d-sizes", "64", "--jobs", "1"])
        .args(["--out", out.to_str().unwrap()])
        .args(extra)
        .env_remove(tb::run::sweep::cache::STOP_AFTER_ENV);
    cmd
}

fn ok(mut cmd: Command) -> String {
    let o = cmd.output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stderr).unwrap()
}

#[test]
fn three_shards_and_a_collect_write_the_reports_of_one_process() {
    let tmp = TmpDir::new("reports", "shards");
    let (whole, sharded, cache) = (tmp.join("whole"), tmp.join("sharded"), tmp.join("cache"));
    ok(small_sweep(&whole, &["--no-cache"]));
    let c = cache.to_str().unwrap();

    let err = error(&small_sweep(&sharded, &["--cache", c, "--collect", "-q"]).output().unwrap());
    assert!(err.contains("--collect: 6 result(s) are not in the cache"), "{err}");
    // Refused by the argument parser: its one-line error, then clap's pointer to --help.
    for (shard, why) in [("3/3", "K must be 0 to N-1"), ("1", "expected K/N"), ("0/0", "N at least 1")] {
        let o = small_sweep(&sharded, &["--cache", c, "--shard", shard]).output().unwrap();
        let err = String::from_utf8(o.stderr).unwrap();
        let first = err.lines().next().unwrap();
        assert!(!o.status.success() && first.starts_with("error: ") && first.contains(why), "{err}");
    }
    let o = small_sweep(&sharded, &["--no-cache", "--collect"]).output().unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert!(!o.status.success() && err.lines().next().unwrap().contains("cannot be used with"), "{err}");

    // Three processes at once, each its share, into one cache.
    let shards: Vec<_> = (0..3)
        .map(|k| {
            let mut cmd = small_sweep(&sharded, &["--cache", c, "--shard", &format!("{k}/3")]);
            cmd.stderr(Stdio::piped()).spawn().unwrap()
        })
        .collect();
    let mut computed = 0;
    for s in shards {
        let o = s.wait_with_output().unwrap();
        let err = String::from_utf8(o.stderr).unwrap();
        assert!(o.status.success(), "{err}");
        let n: usize =
            err.split(" result(s) computed").next().unwrap().rsplit(' ').next().unwrap().parse().unwrap();
        assert_eq!(n, 2, "each shard computes its third of 2 scenes × (2 runs + depth): {err}");
        computed += n;
    }
    assert_eq!(computed, 6);
    assert!(!sharded.join("report.json").exists(), "a shard writes no report");
    let err = ok(small_sweep(&sharded, &["--cache", c, "--collect"]));
    assert!(err.contains("cache: 4 of 4"), "everything from the cache: {err}");
    common::assert_same_reports(&whole, &sharded, "3 shards and a collect");
    // A collected result took no time here: the timing file says so instead of copying old times.
    let timing: Value =
        serde_json::from_str(&std::fs::read_to_string(sharded.join("timing.json")).unwrap()).unwrap();
    for r in timing["runs"].as_array().unwrap() {
        assert_eq!((r["cached"].as_bool(), r["wall_secs"].is_null()), (Some(true), true), "{r}");
    }
}

#[test]
fn ctrl_c_on_a_sweep_says_what_is_cached_and_a_rerun_resumes() {
    let tmp = TmpDir::new("reports", "ctrl-c");
    let out = tmp.join("sweep");
    let cache = out.join("cache");
    // Large enough to be interrupted part-way: 32x32 pixels, the default plan, one job.
    let sweep = || {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_sms"));
        cmd.args(["sweep", "--scenes", "wknd,clutter", "--res", "32x32", "--spp", "1", "--bounces", "1"])
            .args(["--jobs", "1", "--out", out.to_str().unwrap()])
            .env_remove(tb::run::sweep::cache::STOP_AFTER_ENV)
            .stderr(Stdio::piped());
        cmd
    };
    let child = sweep().spawn().unwrap();
    let start = Instant::now();
    while std::fs::read_dir(&cache).map_or(0, |d| d.count()) < 2 {
        assert!(start.elapsed() < Duration::from_secs(120), "no result cached");
        std::thread::sleep(Duration::from_millis(50));
    }
    let kill = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(kill.success());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8(o.stderr).unwrap();
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted: ") && err.contains("run the same command again to resume"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.join("report.json").exists());
    let stored: usize =
        err.split("interrupted: ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    // Run again: what was stored is read back, the rest computed, the report written.
    let err = ok(sweep());
    let line = err.lines().find_map(|l| l.strip_prefix("cache: ")).unwrap_or_else(|| panic!("{err}"));
    let hits: usize = line.split(' ').next().unwrap().parse().unwrap();
    assert!(hits >= stored && stored >= 1, "{stored} stored, {hits} read back: {err}");
    assert!(out.join("report.json").exists());
}

#[test]
fn a_dump_has_a_clock_reads_in_cycles_and_its_save_file_opens_on_the_first_spill() {
    let tmp = TmpDir::new("reports", "waves");
    let vcd = tmp.join("clutter.vcd");
    let args = ["run", "-q", "--scene", "clutter", "--res", "16x16", "--spp", "1", "--bounces", "1"];
    let dump = ["-c", "RB_2+SH_2+SK+RA", "--vcd", vcd.to_str().unwrap(), "--vcd-to", "3000"];
    stdout(&sms(
        &[&args[..], &dump, &["--vcd-sms", "0", "--vcd-warps", "0", "--vcd-lanes", "0,1,2,3"]].concat()
    ));
    let text = std::fs::read_to_string(&vcd).unwrap();
    assert!(
        text.contains("$timescale 100 ms $end") && text.contains("$var wire 1 ! clk $end"),
        "{}",
        &text[..400]
    );
    assert!(!text.contains("\nb0000"), "vectors are written without leading zeros");
    let waves = tb::vcd::check::read(text.as_bytes(), tb::vcd::check::Mode::Strict).unwrap();
    // The first cycle a dumped micro-op is an SH store (an RB → SH spill), from the dump itself.
    let uops: Vec<usize> =
        (0..waves.signals.len()).filter(|&i| waves.signals[i].0.ends_with(".uop")).collect();
    let mut replay = waves.replay();
    let spill = waves
        .times()
        .collect::<Vec<_>>()
        .into_iter()
        .find(|&t| replay.at(t).is_some_and(|v| uops.iter().any(|&i| v[i] == 2)))
        .expect("the dump has a spill");
    let save = std::fs::read_to_string(tmp.join("clutter.gtkw")).unwrap();
    let mut lines = save.lines();
    let start: u64 = lines.find_map(|l| l.strip_prefix("[timestart] ")).unwrap().parse().unwrap();
    let zoom = lines.find(|l| l.starts_with('*')).unwrap();
    let marker: u64 = zoom.split(' ').nth(1).unwrap().parse().unwrap();
    // GTKWave's units are ms here: 1000 a cycle.
    assert_eq!(marker, spill * 1000, "{zoom}");
    assert!(start < marker && marker - start <= 16_000, "a few cycles before the spill: {start}");
    assert_eq!(lines.nth(1), Some("clk"), "the clock first");
}
