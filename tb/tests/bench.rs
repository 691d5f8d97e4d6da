//! `sms bench` end to end on two built-in scenes at a tiny resolution: every file it promises,
//! one row per scene, configuration and setting, and the report it prints is the one it writes.

mod common;

#[test]
fn bench_runs_end_to_end_and_writes_its_files() {
    let dir = common::TmpDir::new("bench", "end-to-end");
    let out = dir.path().to_str().unwrap();
    let args = ["bench", "--scenes", "wknd,clutter", "--fractions", "1,0.5", "--batches", "2"];
    let more = ["--more-bounces", "1", "--out", out, "--format", "json"];
    let printed = common::sms(&[&args[..], &common::TINY, &more].concat(), &[]);
    let read = |file: &str| std::fs::read_to_string(dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
    for file in [
        "bench.txt",
        "bench.md",
        "bench.csv",
        "bench.json",
        "summary.csv",
        "throughput.csv",
        "work.csv",
        "savings.csv",
        "time-vs-error.svg",
    ] {
        assert!(!read(file).is_empty(), "{file}");
    }
    assert_eq!(printed.trim_end(), read("bench.json"), "--format json prints bench.json");
    let csv = read("bench.csv");
    // 2 scenes × 3 configurations × 2 levels × (full + 2 fractions × 2 modes).
    assert_eq!(csv.lines().count(), 1 + 2 * 3 * 2 * 5);
    assert!(csv.contains("clutter,RB_8+SH_8+SK+RA,cycle full,"));
    let json: serde_json::Value = serde_json::from_str(&printed).unwrap();
    assert!(json["fastest"]["setting"].is_object(), "the full cycle level always qualifies");
    let work = &json["report"]["work"];
    assert_eq!(work[0]["scene"], "wknd");
    assert_eq!(work[0]["triangle"], 0, "the procedural scene does no triangle work");
    assert!(work[0]["procedural"].as_u64().unwrap() > 0);
    assert!(work[1]["triangle"].as_u64().unwrap() > 0);
    // A sample of every warp is the full run at its level: its values and errors, no interval;
    // at the cycle level every error is 0.
    let rows = json["report"]["rows"].as_array().unwrap();
    let every_warp: Vec<&serde_json::Value> =
        rows.iter().filter(|r| r["setting"]["sample"]["fraction"] == 1.0).collect();
    assert_eq!(every_warp.len(), 2 * 3 * 2 * 2, "each scene, configuration, level and mode");
    for r in every_warp {
        if r["setting"]["fidelity"] == "cycle" {
            for (name, e) in r["errors"].as_object().unwrap() {
                assert!(e.is_null() || e.as_f64() == Some(0.0), "{name} error {e} of {r}");
            }
        }
        assert!(r["ci"].is_null(), "no interval: {r}");
        let full = rows
            .iter()
            .find(|f| {
                f["scene"] == r["scene"]
                    && f["config"] == r["config"]
                    && f["setting"]["fidelity"] == r["setting"]["fidelity"]
                    && f["setting"]["sample"].is_null()
            })
            .unwrap();
        assert_eq!((&full["values"], &full["errors"]), (&r["values"], &r["errors"]), "{r}");
        assert_eq!(full["pixel_warps"], r["pixel_warps"]);
    }
    let text = read("bench.txt");
    assert!(text.contains("fastest within 1% on every headline metric"));
    assert!(!text.contains("DIFFER"), "skipping work never changes results:\n{text}");
    assert!(read("bench.md").starts_with("# sms bench\n"));
    // The bench's own peak memory, from /proc (this is Linux): a real number of bytes.
    let rss = json["report"]["peak_rss"].as_u64().expect("peak_rss on Linux");
    assert!(rss > 1 << 20, "{rss} bytes");
    assert!(text.contains("peak resident memory of this bench"));
    assert!(read("time-vs-error.svg").starts_with("<svg"));
}
