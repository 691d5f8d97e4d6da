//! `sms depth --format`: the JSON parses and carries the statistics the text shows, the CSV and
//! JSON printed are the files written, and every format describes the same histogram.

mod common;

#[test]
fn depth_prints_every_format_of_one_report() {
    let dir = common::TmpDir::new("depth-formats", "all");
    let out = dir.path().to_str().unwrap();
    let args = [&["depth", "--scene", "clutter", "--out", out][..], &common::TINY].concat();
    let depth = |format: &str| common::sms(&args, &["--format", format]);
    let json = depth("json");
    let v: serde_json::Value = serde_json::from_str(&json).expect("valid JSON");
    assert_eq!(v["scene"], "clutter");
    assert_eq!(v["opts"]["width"], 16);
    let counts: Vec<u64> =
        v["histogram"]["counts"].as_array().unwrap().iter().map(|c| c.as_u64().unwrap()).collect();
    assert_eq!(counts[0], 0, "no push or pop happens at depth 0");
    assert_eq!(v["pushes_and_pops"].as_u64(), Some(counts.iter().sum()));
    let max = v["max"].as_u64().unwrap();
    assert_eq!(max as usize, counts.len() - 1);
    assert!(max > 1, "clutter's rays go deeper than one entry");

    // The text shows the same statistics.
    let text = depth("text");
    let stats = format!(
        "stack depth  max {max}  mean {:.3}  median {}",
        v["mean"].as_f64().unwrap(),
        v["median"].as_u64().unwrap()
    );
    assert!(text.contains(&stats), "{stats}\n{text}");
    assert_eq!(json, common::sms(&args, &["--json"]));

    // CSV and JSON printed are the files written.
    let written = |ext: &str| std::fs::read_to_string(dir.join(&format!("bvh6-vulkansim.{ext}"))).unwrap();
    assert_eq!(json.trim_end(), written("json"));
    let csv = depth("csv");
    assert_eq!(csv, written("csv"));
    // A provenance comment line, the header, one row per depth.
    assert!(csv.starts_with("# provenance: scene clutter · 16x16 px"), "{csv}");
    assert_eq!(csv.lines().filter(|l| !l.starts_with('#')).count(), 1 + max as usize);

    // Markdown: one table row per depth, the counts as in the JSON.
    let md = depth("markdown");
    for (d, c) in counts.iter().enumerate().skip(1) {
        assert!(md.contains(&format!("| {d} | {c} | ")), "depth {d}:\n{md}");
    }
}
