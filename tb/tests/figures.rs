//! Every chart the reports write reads cleanly: rendered from a tiny sweep and a tiny bench, and
//! as shipped in docs/figures, no text overlaps other text, is struck through by a line or
//! covers a point, no point hides under a legend, and the bars of one family of configurations
//! in the performance figure are told apart by colour. The checks themselves catch a planted
//! overlap and a planted shade too close to its neighbour's.

mod common;

use std::path::{Path, PathBuf};

use tb::report::layout::{delta_e, faults, read};
use tb::report::plot::{family_shades, grouped_bars, Bars};

const SWEEP_FIGURES: [&str; 9] = [
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

/// Two colours side by side this far apart (CIE76) read as different at a glance.
const MIN_DELTA_E: f64 = 10.0;

fn svg(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn assert_clean(path: &Path) {
    let f = faults(&read(&svg(path)));
    assert!(f.is_empty(), "{}:\n{}", path.display(), f.join("\n"));
}

/// The performance figure's family of a configuration, read from its name: RB sizes alone, SH
/// stacks alone, with skew or reallocation, or a restart design.
fn family(name: &str) -> usize {
    if name.contains("+RT") {
        return 3;
    }
    match (name.contains("SH_"), name.contains("+SK") || name.contains("+RA")) {
        (false, _) => 0,
        (true, false) => 1,
        (true, true) => 2,
    }
}

/// The legend of a grouped-bar chart: each entry's name and its key's fill, in order.
fn legend(svg: &str) -> Vec<(String, (u8, u8, u8))> {
    let texts: Vec<_> = read(svg).labels;
    let keys: Vec<((f64, f64), (u8, u8, u8))> = svg
        .split("<rect ")
        .skip(1)
        .filter_map(|r| {
            // The rect's own attributes only: the text after its tag has attributes of the same
            // names. A leading space makes the first attribute match like the others.
            let tag = format!(" {}", r.split('>').next()?);
            let get = |a: &str| tag.split(&format!(" {a}=\"")).nth(1)?.split('"').next();
            let (w, h) = (get("width")?.parse::<f64>().ok()?, get("height")?.parse::<f64>().ok()?);
            let fill = get("fill")?.strip_prefix('#')?;
            let byte = |i: usize| u8::from_str_radix(&fill[i..i + 2], 16).ok();
            // Legend keys are the 14 × 10 swatches.
            ((w, h) == (14.0, 10.0)).then_some(())?;
            let (x, y) = (get("x")?.parse().ok()?, get("y")?.parse().ok()?);
            Some(((x, y), (byte(0)?, byte(2)?, byte(4)?)))
        })
        .collect();
    keys.iter()
        .map(|&((x, y), c)| {
            let name = texts
                .iter()
                .filter(|t| t.rect.x0 > x && t.rect.x0 < x + 30.0 && (t.rect.y0 - y).abs() < 4.0)
                .map(|t| t.text.clone())
                .next()
                .unwrap_or_else(|| panic!("no name beside the key at ({x}, {y})"));
            (name, c)
        })
        .collect()
}

/// Every two entries of one family whose key colours are too close to tell apart.
fn family_clashes(svg: &str) -> Vec<String> {
    let entries = legend(svg);
    let mut out = Vec::new();
    for (i, (a, ca)) in entries.iter().enumerate() {
        for (b, cb) in entries[i + 1..].iter().filter(|(b, _)| family(b) == family(a)) {
            let de = delta_e(*ca, *cb);
            if de < MIN_DELTA_E {
                out.push(format!("{a} {ca:?} and {b} {cb:?} differ by {de:.1}"));
            }
        }
    }
    out
}

fn assert_families_distinct(path: &Path) {
    let text = svg(path);
    let entries = legend(&text);
    assert!(entries.len() >= 3, "{}: legend {entries:?}", path.display());
    let clashes = family_clashes(&text);
    assert!(clashes.is_empty(), "{}:\n{}", path.display(), clashes.join("\n"));
}

fn tiny_reports() -> (common::TmpDir, PathBuf, PathBuf) {
    let dir = common::TmpDir::new("figures", "render");
    let (sweep, bench) = (dir.path().join("sweep"), dir.path().join("bench"));
    let out = |p: &Path| p.to_str().unwrap().to_string();
    let sweep_args = ["sweep", "--scenes", "wknd,clutter", "--quiet", "--no-cache", "--out", &out(&sweep)];
    common::sms(&[&sweep_args[..], &common::TINY].concat(), &[]);
    let bench_args = ["bench", "--scenes", "wknd,clutter", "--fractions", "1,0.5", "--batches", "2", "--out"];
    common::sms(&[&bench_args[..], &[out(&bench).as_str()], &common::TINY].concat(), &["--quiet"]);
    (dir, sweep, bench)
}

/// The restart comparison's charts: its own figure, and the performance figure with the restart
/// designs as a fourth family.
#[test]
fn the_restart_figures_read_cleanly() {
    let dir = common::TmpDir::new("figures", "restart");
    let out = dir.path().join("sweep");
    let args =
        ["sweep", "--designs", "restart", "--scenes", "wknd,clutter", "--quiet", "--no-cache", "--out"];
    common::sms(&[&args[..], &[out.to_str().unwrap()], &common::TINY].concat(), &[]);
    for f in ["restart", "performance", "cost", "offchip"] {
        assert_clean(&out.join(format!("{f}.svg")));
    }
    assert_families_distinct(&out.join("performance.svg"));
}

#[test]
fn every_figure_reads_cleanly() {
    let (_dir, sweep, bench) = tiny_reports();
    for f in SWEEP_FIGURES {
        assert_clean(&sweep.join(format!("{f}.svg")));
    }
    assert_clean(&bench.join("time-vs-error.svg"));
    assert_families_distinct(&sweep.join("performance.svg"));
    // The figures README shows.
    let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/figures");
    for f in ["performance", "thread_cycles"] {
        assert_clean(&docs.join(format!("{f}.svg")));
    }
    assert_families_distinct(&docs.join("performance.svg"));
}

#[test]
fn the_checks_catch_a_planted_overlap_and_a_planted_shade() {
    // A performance chart of three families, drawn as the sweep draws it.
    let dir = common::TmpDir::new("figures", "planted");
    let names = ["RB_8", "RB_2", "RB_16", "RB_8+SH_8", "RB_8+SH_16", "RB_8+SH_8+SK", "RB_8+SH_8+SK+RA"];
    let series: Vec<Bars> = names
        .iter()
        .enumerate()
        .map(|(i, n)| Bars { name: n.to_string(), values: vec![Some(1.0 + i as f64 / 50.0); 3] })
        .collect();
    let groups: Vec<String> = ["wknd", "clutter", "geomean"].map(String::from).to_vec();
    let colors = family_shades(&names.map(family));
    let path = dir.path().join("performance.svg");
    grouped_bars(&path, "Performance", "speed-up", &groups, &series, &colors, Some(1.0), true).unwrap();
    let text = svg(&path);
    assert_eq!(faults(&read(&text)), Vec::<String>::new());
    // A copy of the first legend name, moved down by half its height onto itself.
    let start = text.find("<text").unwrap();
    let legend_text = text[start..]
        .match_indices("<text")
        .map(|(i, _)| &text[start + i..])
        .find(|t| t[..t.find("</text>").unwrap()].ends_with(">\nRB_8\n"))
        .expect("RB_8's legend entry");
    let element = &legend_text[..legend_text.find("</text>").unwrap() + "</text>".len()];
    let y: i32 = element.split(" y=\"").nth(1).unwrap().split('"').next().unwrap().parse().unwrap();
    let moved =
        element.replace(&format!(" y=\"{y}\""), &format!(" y=\"{}\"", y + 5)).replace("RB_8\n", "RB_2x\n");
    let planted = text.replacen("</svg>", &format!("{moved}\n</svg>"), 1);
    let f = faults(&read(&planted));
    assert!(f.iter().any(|f| f.contains("'RB_2x' overlaps") || f.contains("overlaps 'RB_2x'")), "{f:?}");
    // The legend reader finds every entry, in order, with its bar's colour.
    let entries = legend(&text);
    let read_names: Vec<&str> = entries.iter().map(|e| e.0.as_str()).collect();
    assert_eq!(read_names, names);
    for ((_, c), want) in entries.iter().zip(&colors) {
        assert_eq!(*c, (want.0, want.1, want.2));
    }
    assert_eq!(family_clashes(&text), Vec::<String>::new());
    // RB_16's key planted three steps off RB_2's shade: too close to tell apart.
    let hex = |c: (u8, u8, u8)| format!("fill=\"#{:02X}{:02X}{:02X}\"", c.0, c.1, c.2);
    let (rb2, rb16) = (entries[1].1, entries[2].1);
    let near = (rb2.0.saturating_add(3), rb2.1.saturating_add(3), rb2.2.saturating_add(3));
    let clashes = family_clashes(&text.replace(&hex(rb16), &hex(near)));
    assert_eq!(clashes.len(), 1, "{clashes:?}");
    assert!(clashes[0].starts_with("RB_2 ") && clashes[0].contains("RB_16"), "{clashes:?}");
}
