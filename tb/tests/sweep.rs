//! `sms sweep` end to end on two built-in scenes at a tiny resolution: the report folder has
//! every promised file, the numbers follow from the raw runs, thread count changes nothing, and
//! bad input gives an error instead of a panic.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

mod common;

const FIGURES: [&str; 9] = [
    "performance",
    "offchip",
    "bank_conflicts",
    "skew",
    "rb_sweep",
    "l1d_sweep",
    "depth",
    "cost",
    "thread_cycles",
];
const SCENES: [&str; 2] = ["wknd", "clutter"];

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("sms-sweep-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn sms(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sms")).args(args).output().expect("run sms")
}

/// The default plan (14 paper configurations, RB and L1D sweeps) on two scenes, tiny; what it
/// prints with `--format json`.
fn sweep(out: &Path, jobs: &str) -> String {
    let scenes = SCENES.join(",");
    let args = ["sweep", "--scenes", &scenes, "--jobs", jobs, "--quiet", "--out", out.to_str().unwrap()];
    let o = sms(&[&args[..], &common::TINY, &["--format", "json"]].concat());
    assert!(o.status.success(), "sms sweep failed: {}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout).unwrap()
}

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Files whose bytes must not depend on the thread count: every figure (our SVGs draw elements in
/// data order) and report.json; not the wall-clock times in timing.json and summary.md.
fn deterministic_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            let name = p.file_name().unwrap().to_str().unwrap();
            p.is_file() && name != "timing.json" && name != "summary.md"
        })
        .collect();
    files.sort();
    files
}

#[test]
fn a_sweep_writes_every_file_and_does_not_depend_on_thread_count() {
    let (one, two) = (out_dir("jobs1"), out_dir("jobs2"));
    let printed = sweep(&one, "1");
    sweep(&two, "2");
    // --format json prints the headline figures' files: the speed-ups per scene, then cost.
    let printed: Value = serde_json::from_str(&printed).unwrap();
    assert_eq!(printed.as_object().unwrap().keys().collect::<Vec<_>>(), ["cost", "performance"]);
    for f in ["performance", "cost"] {
        assert_eq!(printed[f], json(&one.join(format!("{f}.json"))), "{f}");
    }

    for f in FIGURES {
        for ext in ["md", "csv", "json", "svg"] {
            let path = one.join(format!("{f}.{ext}"));
            let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(!text.trim().is_empty(), "{} is empty", path.display());
            if ext == "svg" {
                assert!(text.starts_with("<svg"), "{} is not an SVG", path.display());
            }
        }
    }
    for scene in SCENES {
        for ext in ["svg", "csv"] {
            let name = format!("{scene}.{ext}");
            let a = std::fs::read(one.join("depth").join(&name)).unwrap();
            assert_eq!(a, std::fs::read(two.join("depth").join(&name)).unwrap(), "depth/{name} differs");
        }
    }
    for f in FIGURES {
        let md = std::fs::read_to_string(one.join(format!("{f}.md"))).unwrap();
        for scene in SCENES {
            assert!(md.contains(&format!("| {scene} |")), "{f}.md has no table row for {scene}");
        }
    }
    let summary = std::fs::read_to_string(one.join("summary.md")).unwrap();
    assert!(summary.contains("16x16 pixels"), "summary states the render settings");
    for f in FIGURES {
        let title = json(&one.join(format!("{f}.json")))["title"].as_str().unwrap().to_string();
        assert!(summary.contains(&title), "summary lacks {f}");
    }
    let report = json(&one.join("report.json"));
    let runs = report["runs"].as_array().unwrap();
    let per_scene = report["plan"]["runs_per_scene"].as_array().unwrap().len();
    assert_eq!(
        per_scene,
        14 + 3 + 8,
        "14 paper configurations, RB_1, RB_1 and RB_32 with SMS, 4 L1D sizes × 2"
    );
    assert_eq!(runs.len(), SCENES.len() * per_scene);
    assert!(runs.iter().all(|r| r["outcome"]["gpu"]["cycles"].as_u64().unwrap() > 0));
    assert!(json(&one.join("timing.json"))["runs"].as_array().unwrap().len() == runs.len());

    let (a, b) = (deterministic_files(&one), deterministic_files(&two));
    assert_eq!(a.len(), b.len());
    assert!(a.len() > 4 * FIGURES.len(), "every figure and report.json");
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(x.file_name(), y.file_name());
        assert!(
            std::fs::read(x).unwrap() == std::fs::read(y).unwrap(),
            "{} differs between --jobs 1 and 2",
            x.display()
        );
    }

    check_performance(&one, &report);
    check_thread_cycles(&one, &report);
    check_pareto(&one);
    let _ = std::fs::remove_dir_all(&one);
    let _ = std::fs::remove_dir_all(&two);
}

/// RB_8 is exactly 1.0; every speed-up and geomean is recomputed from the raw cycles.
fn check_performance(dir: &Path, report: &Value) {
    let cycles = |scene: &str, config: &str| {
        report["runs"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["scene"] == scene && r["config"] == config && r["l1d_kb"] == 64)
            .and_then(|r| r["outcome"]["gpu"]["cycles"].as_u64())
            .unwrap_or_else(|| panic!("no run {scene} {config}")) as f64
    };
    let perf = json(&dir.join("performance.json"));
    let rows = perf["data"]["rows"].as_array().unwrap();
    assert_eq!(rows[0]["config"], "RB_8");
    for row in rows {
        let config = row["config"].as_str().unwrap();
        let per: Vec<f64> =
            row["per_scene"].as_array().unwrap().iter().map(|p| p["speedup"].as_f64().unwrap()).collect();
        assert_eq!(per.len(), SCENES.len());
        let expected: Vec<f64> = SCENES.iter().map(|s| cycles(s, "RB_8") / cycles(s, config)).collect();
        let geomean = row["geomean"].as_f64().unwrap();
        let hand = (expected[0] * expected[1]).sqrt();
        if config == "RB_8" {
            assert!(per.iter().all(|&v| v == 1.0), "RB_8 normalises to exactly 1: {per:?}");
            assert_eq!(geomean, 1.0);
        }
        for (p, e) in per.iter().zip(&expected) {
            assert!((p - e).abs() <= 1e-12 * e, "{config}: {p} vs {e}");
        }
        assert!((geomean - hand).abs() <= 1e-12 * hand, "{config}: geomean {geomean} vs {hand}");
    }
    let csv = std::fs::read_to_string(dir.join("performance.csv")).unwrap();
    assert!(csv.starts_with("# provenance: scene wknd,clutter · 16x16 px"), "{csv}");
    let mut rows = csv.lines().filter(|l| !l.starts_with('#'));
    assert!(rows.nth(1).unwrap().starts_with("RB_8,1.0000,1.0000,1.0000"), "{csv}");
}

/// The thread-cycle figure has every configuration of the base L1D, each category summed over
/// the scenes from the raw runs in units of RB_8's total (RB_8's bar is exactly 1), and the
/// per-scene CSV a row of counts for every scene and configuration.
fn check_thread_cycles(dir: &Path, report: &Value) {
    const NAMES: [&str; 5] = ["node_data", "fetch_queue", "stack", "latency", "idle"];
    let base_runs: Vec<&Value> =
        report["runs"].as_array().unwrap().iter().filter(|r| r["l1d_kb"] == 64).collect();
    let counts = |scene: &str, config: &str| -> Vec<u64> {
        let run = base_runs.iter().find(|r| r["scene"] == scene && r["config"] == config).unwrap();
        NAMES.map(|n| run["outcome"]["gpu"][format!("thread_cycles_{n}")].as_u64().unwrap()).to_vec()
    };
    let total = |config: &str| -> f64 { SCENES.iter().flat_map(|s| counts(s, config)).sum::<u64>() as f64 };
    let performance = json(&dir.join("performance.json"));
    let configs: Vec<&str> = performance["data"]["rows"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["config"].as_str().unwrap())
        .collect();
    assert_eq!(configs.len() * SCENES.len(), base_runs.len(), "every configuration of the base L1D");
    let figure = json(&dir.join("thread_cycles.json"));
    let rows = figure["data"]["rows"].as_array().unwrap();
    let drawn: Vec<&str> = rows.iter().map(|r| r["config"].as_str().unwrap()).collect();
    assert_eq!(drawn, configs, "every configuration, in plan order");
    for row in rows {
        let c = row["config"].as_str().unwrap();
        let rel: Vec<f64> =
            row["relative_to_baseline"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
        for (i, r) in rel.iter().enumerate() {
            let hand = SCENES.iter().map(|s| counts(s, c)[i]).sum::<u64>() as f64 / total("RB_8");
            assert!((r - hand).abs() <= 1e-12, "{c} {}: {r} vs {hand}", NAMES[i]);
        }
        assert!(rel[2] > 0.0 && rel[0] > 0.0, "{c}: stack and node data thread-cycles");
        let height: f64 = rel.iter().sum();
        if c == "RB_8" {
            assert!((height - 1.0).abs() < 1e-12, "RB_8's bar is 1: {height}");
        }
    }
    let csv = std::fs::read_to_string(dir.join("thread_cycles_per_scene.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(lines.len(), 1 + SCENES.len() * configs.len(), "{csv}");
    for scene in SCENES {
        for c in &configs {
            let want = counts(scene, c).iter().map(u64::to_string).collect::<Vec<_>>().join(",");
            let row = format!("{scene},{c},{want},");
            assert!(lines.iter().any(|l| l.starts_with(&row)), "no row {row} in {csv}");
        }
    }
    let svg = std::fs::read_to_string(dir.join("thread_cycles.svg")).unwrap();
    for label in ["node data", "fetch queue", "stack", "latency", "idle"] {
        assert!(svg.contains(label), "the legend names {label}");
    }
    for c in &configs {
        assert!(svg.contains(c), "the figure labels {c}");
    }
}

/// Every design marked Pareto-optimal is undominated, every other one is dominated.
fn check_pareto(dir: &Path) {
    let cost = json(&dir.join("cost.json"));
    let rows = cost["data"]["rows"].as_array().unwrap();
    let pts: Vec<(f64, f64, bool)> = rows
        .iter()
        .map(|r| {
            (
                r["added_bytes_per_sm"].as_f64().unwrap(),
                r["speedup"].as_f64().unwrap(),
                r["pareto_optimal"].as_bool().unwrap(),
            )
        })
        .collect();
    assert!(pts.iter().any(|p| p.2));
    for &(c, s, optimal) in &pts {
        let dominated = pts.iter().any(|&(c2, s2, _)| c2 <= c && s2 >= s && (c2 < c || s2 > s));
        assert_eq!(optimal, !dominated, "({c}, {s})");
    }
    let sms = rows.iter().find(|r| r["config"] == "RB_8+SH_8+SK+RA").unwrap();
    assert!(
        sms["field_bytes_per_sm"].as_u64().unwrap() > 272,
        "the paper's 272 bytes plus the RTL's extra bits"
    );
    assert_eq!(sms["sh_bytes_per_sm"], 8192);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let out = out_dir("bad");
    let out_s = out.to_str().unwrap();
    let cases: [(&[&str], &str); 10] = [
        (&["sweep", "--scenes", "wknd,nosuchscene", "--out", out_s], "unknown scene 'nosuchscene'"),
        (&["sweep", "--quick", "--configs", "RB_8+SH_6", "--out", out_s], "--config RB_8+SH_6"),
        (&["sweep", "--quick", "--jobs", "0", "--out", out_s], "--jobs"),
        (
            &["sweep", "--quick", "--l1d-sizes", "8", "--out", out_s],
            "--l1d-sizes 8: each size (in KB) must be above 8",
        ),
        (
            &["sweep", "--quick", "--out", "/proc/sms-sweep-cannot-write-here"],
            "/proc/sms-sweep-cannot-write-here",
        ),
        (&["sweep", "--quick", "--cache", out_s, "--no-cache", "--out", out_s], "--no-cache"),
        (
            &["sweep", "--quick", "--designs", "restart", "--order", "vulkansim", "--out", out_s],
            "--order vulkansim: RB_2+RT is a restart design",
        ),
        (
            &["sweep", "--quick", "-c", "RB_8,RB_4+RT", "--accel", "two-level", "--out", out_s],
            "--accel two-level: RB_4+RT is a restart design",
        ),
        (&["sweep", "--quick", "--designs", "spill", "--out", out_s], "--designs"),
        (
            &["sweep", "--scenes", "nosuchscene", "--cache", "/proc/sms-no-cache-here", "--out", out_s],
            "unknown scene",
        ),
    ];
    for (args, expected) in cases {
        let o = sms(args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(err.contains(expected), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    assert!(!out.exists(), "nothing is written when the input is bad");
}

/// The ablation on two tiny scenes: one row per mechanism after the reference, and the
/// reference row's speed-ups are bit-identical to a plain sweep's with the same settings.
#[test]
fn the_ablation_reference_is_the_sweep_and_every_mechanism_has_a_row() {
    let (abl, sw) = (out_dir("ablate"), out_dir("ablate-sweep"));
    let tiny = ["--scenes", "wknd,clutter", "--res", "8x8", "--spp", "1", "--bounces", "1", "--quiet"];
    let run = |args: &[&str]| {
        let o = sms(args);
        assert!(o.status.success(), "{args:?}: {}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8(o.stdout).unwrap()
    };
    let printed = run(&[&["ablate", "--out", abl.to_str().unwrap(), "--format", "csv"], &tiny[..]].concat());
    let headline = "RB_16,RB_FULL,RB_8+SH_8,RB_8+SH_8+SK,RB_8+SH_8+SK+RA,RB_2,RB_2+SH_8+SK+RA";
    run(&[
        &["sweep", "--order", "vulkansim", "-c", headline, "--rb-sizes", "8", "--l1d-sizes", "64"],
        &tiny[..],
        &["--out", sw.to_str().unwrap()],
    ]
    .concat());

    let csv = std::fs::read_to_string(abl.join("ablation.csv")).unwrap();
    assert_eq!(printed, csv, "--format csv prints the ablation table as written");
    let table = |csv: &str| csv.lines().filter(|l| !l.starts_with("# provenance: ")).count();
    let rows: Vec<&str> =
        csv.lines().filter(|l| !l.starts_with('#')).skip(1).map(|l| l.split(',').next().unwrap()).collect();
    assert_eq!(rows[0], "all on");
    let mechanisms = tb::run::ablate::MECHANISMS;
    assert_eq!(rows.len(), 1 + mechanisms.len(), "{csv}");
    for (row, m) in rows[1..].iter().zip(mechanisms) {
        assert_eq!(*row, format!("{} off", m.name));
    }
    let per_scene = std::fs::read_to_string(abl.join("ablation_per_scene.csv")).unwrap();
    assert_eq!(table(&per_scene), 1 + 2 * (1 + mechanisms.len()));

    let ablation = json(&abl.join("ablation.json"));
    let reference = &ablation["data"]["rows"][0];
    assert_eq!(reference["arm"], "all on");
    let perf = json(&sw.join("performance.json"));
    let sweep_speedup = |config: &str, scene: &str| {
        let row = perf["data"]["rows"].as_array().unwrap().iter().find(|r| r["config"] == config).unwrap();
        row["per_scene"].as_array().unwrap().iter().find(|p| p["scene"] == scene).unwrap()["speedup"].clone()
    };
    let mut compared = 0;
    for scene in reference["per_scene"].as_array().unwrap() {
        for cell in scene["speedups"].as_array().unwrap() {
            let (config, name) = (cell["config"].as_str().unwrap(), scene["scene"].as_str().unwrap());
            assert_eq!(cell["speedup"], sweep_speedup(config, name), "{config} on {name}");
            compared += 1;
        }
    }
    assert_eq!(compared, 2 * tb::run::ablate::HEADLINE.len());
    let _ = std::fs::remove_dir_all(&abl);
    let _ = std::fs::remove_dir_all(&sw);
}

/// A sampled sweep simulates a part of each frame, scales it to the whole frame and says so,
/// with the measured error, in its summary.
#[test]
fn a_sampled_sweep_reports_its_sample_and_error() {
    let out = out_dir("sampled");
    let args = [
        "sweep",
        "--scenes",
        "clutter",
        "--spp",
        "1",
        "--bounces",
        "1",
        "-c",
        "RB_8",
        "--rb-sizes",
        "8",
        "--l1d-sizes",
        "64",
        "--sample",
        "0.25",
        "--batches",
        "4",
    ];
    let o = sms(&[&args[..], &["--res", "64x32", "--out", out.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let report = json(&out.join("report.json"));
    let runs = report["runs"].as_array().unwrap();
    assert_eq!(runs.len(), 2, "RB_8 and SMS");
    for r in runs {
        assert_eq!(r["sample"]["sampled_warps"], 16, "a quarter of 64 warps");
        assert_eq!(r["outcome"]["pixel_warps"], 64, "counts stand for the whole frame");
    }
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("Sampled: 25 %") && summary.contains(tb::run::sweep::SAMPLE_ERROR), "{summary}");
    assert!(summary.contains(" s wall time") && summary.contains("Peak memory: "), "{summary}");
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(&format!("sampled: {}", tb::run::sweep::SAMPLE_ERROR)), "{err}");
    assert!(err.contains(" s wall time, peak memory "), "{err}");

    // Sampled results come back from the cache bit for bit (their intervals included).
    let first = std::fs::read(out.join("report.json")).unwrap();
    let o = sms(&[&args[..], &["--res", "64x32", "--out", out.to_str().unwrap()]].concat());
    assert!(String::from_utf8_lossy(&o.stderr).contains("cache: 2 of 2 "));
    assert!(first == std::fs::read(out.join("report.json")).unwrap(), "report.json from the cache differs");

    // A sample that would hold every warp is not one, and the summary says so.
    let o = sms(&[&args[..], &["--res", "8x8", "--out", out.to_str().unwrap()]].concat());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("not sampled: a 25 % sample"), "{err}");
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("every warp was simulated") && !summary.contains("Sampled:"), "{summary}");
    let _ = std::fs::remove_dir_all(&out);
}

/// `(from the cache, in all)` from the sweep's stderr line `cache: K of N simulation results …`.
fn cache_counts(stderr: &str) -> (usize, usize) {
    let line = stderr.lines().find_map(|l| l.strip_prefix("cache: ")).unwrap_or_else(|| panic!("{stderr}"));
    let words: Vec<&str> = line.split(' ').collect();
    (words[0].parse().unwrap(), words[2].parse().unwrap())
}

fn tiny_sweep(out: &Path, extra: &[&str], env: Option<(&str, &str)>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_sms"));
    cmd.args(["sweep", "--scenes", &SCENES.join(","), "--res", "16x16", "--spp", "1", "--bounces", "1"])
        .args(["--jobs", "2", "--out", out.to_str().unwrap()])
        .args(extra)
        .env_remove("SMS_SWEEP_STOP_AFTER");
    if let Some((k, v)) = env {
        cmd.env(k, v);
    }
    cmd.output().expect("run sms")
}

fn ok(o: Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "sms sweep failed: {err}");
    err
}

/// A sweep stopped part-way and run again gives byte-identical reports to one that ran
/// through, taking what was finished from the cache; a changed key part (seed, hardware) is
/// recomputed, and corrupt cache files are recomputed, never used.
#[test]
fn an_interrupted_sweep_resumes_from_its_cache_with_identical_reports() {
    let (whole, resumed) = (out_dir("whole"), out_dir("resumed"));
    let err = ok(tiny_sweep(&whole, &["--no-cache"], None));
    assert!(!err.contains("cache: "), "--no-cache: {err}");
    assert!(!whole.join("cache").exists(), "--no-cache writes no cache");
    let total = SCENES.len() * 25;

    // Stopped after 30 fresh results (the testing hook), as a kill would stop it.
    let o = tiny_sweep(&resumed, &[], Some(("SMS_SWEEP_STOP_AFTER", "30")));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("stopped after 30"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!resumed.join("report.json").exists(), "no report from a stopped sweep");
    let stored = std::fs::read_dir(resumed.join("cache")).unwrap().count();
    assert!((30..total).contains(&stored), "{stored} results stored before the stop");

    let (hits, all) = cache_counts(&ok(tiny_sweep(&resumed, &[], None)));
    assert_eq!(all, total);
    assert!((30..total).contains(&hits), "resumed with {hits} results from the cache");
    common::assert_same_reports(&whole, &resumed, "resumed");

    // Everything cached now; a plan that is a subset reuses the same results.
    let sub_out = out_dir("subset");
    let cache = resumed.join("cache");
    // This sweep's files (the seed and hardware changes below add others, which it never reads).
    let mut files: Vec<PathBuf> = std::fs::read_dir(&cache).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    let subset =
        ["--configs", "RB_8,SMS", "--rb-sizes", "8", "--l1d-sizes", "64", "--cache", cache.to_str().unwrap()];
    assert_eq!(cache_counts(&ok(tiny_sweep(&sub_out, &subset, None))), (4, 4));
    assert!(!sub_out.join("cache").exists(), "--cache DIR replaces the report folder's");

    // A changed seed (workload) or hardware parameter recomputes everything.
    assert_eq!(cache_counts(&ok(tiny_sweep(&resumed, &["--seed", "7"], None))), (0, total));
    let hw = sub_out.join("slow-dram.toml");
    std::fs::write(&hw, "[mem]\ndram_latency = 101\n").unwrap();
    let (hits, _) = cache_counts(&ok(tiny_sweep(&resumed, &["--hw", hw.to_str().unwrap()], None)));
    assert_eq!(hits, 0, "a hardware change recomputes");

    // Corrupt files of this sweep: one truncated, one garbage, one holding another result's key.
    // (Files of the other sweeps would not be read, whichever way their hashed names sort.)
    let first = std::fs::read(&files[0]).unwrap();
    std::fs::write(&files[0], &first[..first.len() / 2]).unwrap();
    std::fs::write(&files[1], b"\x00\x01 not json").unwrap();
    std::fs::copy(&files[3], &files[2]).unwrap();
    let err = ok(tiny_sweep(&resumed, &[], None));
    assert!(err.contains("unusable cache file(s) ignored"), "{err}");
    let (hits, _) = cache_counts(&err);
    assert!(hits < total, "the damaged results were recomputed: {err}");
    common::assert_same_reports(&whole, &resumed, "after corrupt cache files");
    // and repaired: everything from the cache again.
    assert_eq!(cache_counts(&ok(tiny_sweep(&resumed, &[], None))), (total, total));
    common::assert_same_reports(&whole, &resumed, "all from the cache");

    for d in [whole, resumed, sub_out] {
        let _ = std::fs::remove_dir_all(d);
    }
}

/// `--designs restart` on two tiny scenes: the restart designs run on a flat BVH in nearest order,
/// the report has the restart figure and no RB-size or L1D sweep, and the figure's numbers follow
/// from the raw runs in report.json (per-ray values as totals over totals, the node-fetch ratio
/// as a geometric mean of per-scene ratios, bytes per SM as `sms cost` counts them).
#[test]
fn a_restart_sweep_reports_what_dropping_buys_and_costs() {
    let out = out_dir("restart");
    let scenes = SCENES.join(",");
    let args =
        ["sweep", "--designs", "restart", "--scenes", &scenes, "--quiet", "--out", out.to_str().unwrap()];
    let o = sms(&[&args[..], &common::TINY].concat());
    assert!(o.status.success(), "sms sweep --designs restart failed: {}", String::from_utf8_lossy(&o.stderr));
    for gone in ["rb_sweep", "l1d_sweep"] {
        assert!(!out.join(format!("{gone}.md")).exists(), "{gone}: the restart comparison has no such sweep");
    }
    let report = json(&out.join("report.json"));
    assert_eq!(report["settings"]["order"], "nearest", "{}", report["settings"]);
    assert_eq!(report["settings"]["accel"], "flat", "{}", report["settings"]);
    let figure = json(&out.join("restart.json"));
    let rows = figure["data"]["rows"].as_array().unwrap();
    let names: Vec<&str> = rows.iter().map(|r| r["config"].as_str().unwrap()).collect();
    for c in
        ["RB_8", "RB_2", "RB_8+SH_8+SK+RA", "RB_2+RT", "RB_5+RT", "RB_8+SH_8+SK+RA+RT", "RB_2+SH_8+SK+RA+RT"]
    {
        assert!(names.contains(&c), "{c} missing from the restart figure: {names:?}");
    }
    let runs = report["runs"].as_array().unwrap();
    let total = |config: &str, f: &dyn Fn(&Value) -> u64| -> u64 {
        runs.iter().filter(|r| r["config"] == config).map(f).sum()
    };
    let rays = |r: &Value| r["outcome"]["gpu"]["rays"].as_u64().unwrap();
    let per_scene_fetches = |config: &str, scene: &str| {
        let r = runs.iter().find(|r| r["config"] == config && r["scene"] == scene).unwrap();
        r["outcome"]["gpu"]["node_fetches"].as_f64().unwrap() / rays(r) as f64
    };
    let mut restarted = false;
    for row in rows {
        let c = row["config"].as_str().unwrap();
        let restart = c.ends_with("+RT");
        assert_eq!(row["restart"], restart, "{c}");
        let restarts = total(c, &|r| r["outcome"]["stack"]["restarts"].as_u64().unwrap_or(0));
        let drops = total(c, &|r| r["outcome"]["stack"]["drops"].as_u64().unwrap_or(0));
        let n = total(c, &rays) as f64;
        assert!((row["restarts_per_ray"].as_f64().unwrap() - restarts as f64 / n).abs() < 1e-12, "{c}");
        assert!((row["drops_per_ray"].as_f64().unwrap() - drops as f64 / n).abs() < 1e-12, "{c}");
        let fetches = total(c, &|r| r["outcome"]["gpu"]["node_fetches"].as_u64().unwrap()) as f64 / n;
        assert!((row["node_fetches_per_ray"].as_f64().unwrap() - fetches).abs() < 1e-9, "{c}");
        let ratio = SCENES
            .iter()
            .map(|sc| (per_scene_fetches(c, sc) / per_scene_fetches("RB_8", sc)).ln())
            .sum::<f64>()
            / SCENES.len() as f64;
        assert!((row["node_fetches_vs_baseline"].as_f64().unwrap() - ratio.exp()).abs() < 1e-9, "{c}");
        if !restart {
            assert_eq!((restarts, drops), (0, 0), "{c}: a spilling design never drops");
        }
        restarted |= restarts > 0;
        // Bytes per SM as sms cost counts them: the restart designs' trail included.
        let cost = sms(&["cost", "-c", c, "--format", "json"]);
        assert!(cost.status.success(), "sms cost -c {c}: {}", String::from_utf8_lossy(&cost.stderr));
        let cost: Value = serde_json::from_slice(&cost.stdout).unwrap();
        assert_eq!(row["on_chip_bytes_per_sm"], cost[0]["totals"]["on_chip_bytes_per_sm"], "{c}");
    }
    assert!(restarted, "RB_2+RT restarts somewhere on two scenes");
    let _ = std::fs::remove_dir_all(&out);
}
