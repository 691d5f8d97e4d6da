//! The report folder of a sweep: every figure as Markdown, CSV, JSON and SVG, per-scene depth
//! histograms, `summary.md` with every table, `report.json` with every raw run and
//! `timing.json` with wall-clock times.
//!
//! Wall-clock times (and the peak memory in `summary.md`) are the only part that varies between
//! identical sweeps, so they are kept out of every JSON file but `timing.json`: the rest is
//! bit-identical whatever the thread count, and whether results came from the cache.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::figure::Figure;
use super::figures;
use crate::error::{Error, Result};
use crate::run::ablate::Ablation;
use crate::run::provenance::Provenance;
use crate::run::sweep::Sweep;

/// Creates `dir` and checks that files can be written there.
pub fn prepare(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    // One probe per process: shards started together prepare the same folder.
    let probe = dir.join(format!(".sms-sweep-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(|e| Error::io(&probe, e))?;
    std::fs::remove_file(&probe).map_err(|e| Error::io(&probe, e))
}

fn write(path: PathBuf, text: &str, written: &mut Vec<PathBuf>) -> Result<()> {
    std::fs::write(&path, text).map_err(|e| Error::io(&path, e))?;
    written.push(path);
    Ok(())
}

fn pretty(v: &Value) -> String {
    let mut s = serde_json::to_string_pretty(v).expect("a JSON value always serialises");
    s.push('\n');
    s
}

/// A figure's Markdown under `heading` (`#`, `## 1.`, ...).
pub fn figure_markdown(f: &Figure, heading: &str) -> String {
    let mut md = format!(
        "{heading} {}\n\n{}\n\n![{}]({}.svg)\n\n{}",
        f.title,
        f.note,
        f.title,
        f.name,
        f.table.to_markdown()
    );
    if let Some(t) = &f.per_scene {
        md += &format!("\nPer scene (also `{}_per_scene.csv`):\n\n{}", f.name, t.to_markdown());
    }
    md
}

/// A figure's JSON file (layout: docs/json.md).
pub fn figure_json(f: &Figure, p: &Provenance) -> Value {
    json!({
        "title": f.title, "note": f.note, "table": f.table, "per_scene_table": f.per_scene, "data": f.json,
        "provenance": p.json(),
    })
}

/// A figure's Markdown, CSV (and per-scene CSV), JSON and SVG, each stating `p`.
fn write_figure(f: &Figure, p: &Provenance, dir: &Path, written: &mut Vec<PathBuf>) -> Result<()> {
    write(dir.join(format!("{}.md", f.name)), &(p.markdown() + &figure_markdown(f, "#")), written)?;
    write(dir.join(format!("{}.csv", f.name)), &(p.csv() + &f.table.to_csv()), written)?;
    if let Some(t) = &f.per_scene {
        write(dir.join(format!("{}_per_scene.csv", f.name)), &(p.csv() + &t.to_csv()), written)?;
    }
    write(dir.join(format!("{}.json", f.name)), &pretty(&figure_json(f, p)), written)?;
    let svg = dir.join(format!("{}.svg", f.name));
    f.chart.write_svg(&svg, &f.title)?;
    written.push(svg);
    Ok(())
}

/// Writes an ablation's report into `dir`: the ablation figure, `summary.md`, `report.json`
/// with every arm's raw runs and `timing.json`. Returns the files written.
pub fn write_ablation(a: &Ablation, dir: &Path) -> Result<Vec<PathBuf>> {
    prepare(dir)?;
    let mut written = Vec::new();
    let f = a.figure();
    let r = &a.reference;
    let p = r.provenance();
    write_figure(&f, &p, dir, &mut written)?;
    let mut summary = format!(
        "# SMS ablation: {} mechanisms on {} scenes\n\n{}Rendered at {} (each mechanism's row says what it \
         changes).\n\n",
        a.arms.len(),
        r.scenes.len(),
        p.markdown(),
        r.settings.describe()
    );
    summary += &sampling_note(r);
    summary += &format!(
        "{} simulations per scene and arm, {} arms; {} worker thread(s), {:.1} s wall time.\n\n{}",
        r.variants.len(),
        a.arms.len() + 1,
        r.jobs,
        r.wall.as_secs_f64(),
        peak_memory_line(r)
    );
    summary += &figure_markdown(&f, "##");
    write(dir.join("summary.md"), &summary, &mut written)?;
    let mut arms = vec![json!({ "arm": "all on", "report": report_json(r)? })];
    for (m, s) in &a.arms {
        arms.push(json!({ "arm": m.name, "off_means": m.off_means, "report": report_json(s)? }));
    }
    write(dir.join("report.json"), &pretty(&json!({ "arms": arms, "provenance": p.json() })), &mut written)?;
    write(dir.join("timing.json"), &pretty(&timing_json(r)), &mut written)?;
    Ok(written)
}

/// Writes the whole report into `dir` and returns the files written.
pub fn write_all(s: &Sweep, dir: &Path) -> Result<Vec<PathBuf>> {
    prepare(dir)?;
    let mut written = Vec::new();
    let figures = figures::all(s)?;
    let p = s.provenance();
    for f in &figures {
        write_figure(f, &p, dir, &mut written)?;
    }
    let depth_dir = dir.join("depth");
    std::fs::create_dir_all(&depth_dir).map_err(|e| Error::io(&depth_dir, e))?;
    for sc in &s.scenes {
        let d = &sc.depth;
        write(depth_dir.join(format!("{}.csv", sc.name)), &(p.csv() + &d.csv()), &mut written)?;
        let svg = depth_dir.join(format!("{}.svg", sc.name));
        d.write_svg(&svg, &format!("{}: max {} mean {:.2} median {}", sc.name, d.max, d.mean, d.median))?;
        written.push(svg);
    }
    write(dir.join("summary.md"), &summary(s, &figures), &mut written)?;
    write(dir.join("report.json"), &pretty(&report_json(s)?), &mut written)?;
    write(dir.join("timing.json"), &pretty(&timing_json(s)), &mut written)?;
    Ok(written)
}

/// Every raw run with what produced it; wall-clock times removed.
pub fn report_json(s: &Sweep) -> Result<Value> {
    let mut runs = Vec::with_capacity(s.runs.len());
    for r in &s.runs {
        let mut outcome = to_value(&r.outcome)?;
        if let Some(o) = outcome.as_object_mut() {
            o.remove("wall");
        }
        runs.push(json!({
            "scene": r.scene, "config": r.config, "l1d_kb": r.l1d_kb, "outcome": outcome, "sample": r.sample,
        }));
    }
    Ok(json!({
        "settings": to_value(&s.settings)?,
        "sample": s.sample.map(|p| json!({
            "fraction": p.fraction, "mode": p.mode, "batches": p.batches, "seed": p.seed,
        })),
        "hardware": format!("{:?}", s.hw),
        "plan": {
            "configs": s.plan.configs.iter().map(|c| c.name()).collect::<Vec<_>>(),
            "rb_sizes": s.plan.rb_sizes,
            "l1d_kb": s.plan.l1d_kb,
            "runs_per_scene": s.variants.iter().map(|v| v.name()).collect::<Vec<_>>(),
        },
        "scenes": to_value(&s.scenes)?,
        "runs": runs,
        "provenance": s.provenance().json(),
    }))
}

fn to_value<T: serde::Serialize>(v: &T) -> Result<Value> {
    serde_json::to_value(v).map_err(|e| Error::Invalid(format!("report.json: {e}")))
}

fn timing_json(s: &Sweep) -> Value {
    json!({
        "jobs": s.jobs,
        "wall_secs": s.wall.as_secs_f64(),
        "scenes": s.scenes.iter().map(|sc| json!({
            "scene": sc.name, "load_secs": sc.load_secs, "workload_secs": sc.workload_secs,
        })).collect::<Vec<_>>(),
        // A cached result took no time here: its wall time is the run's that computed it.
        "runs": s.runs.iter().map(|r| json!({
            "scene": r.scene, "config": r.config, "l1d_kb": r.l1d_kb,
            "wall_secs": (!r.from_cache).then_some(r.outcome.wall.as_secs_f64()),
            "cached": r.from_cache,
            "simulated_secs": r.outcome.wall.as_secs_f64(),
        })).collect::<Vec<_>>(),
    })
}

fn summary(s: &Sweep, figures: &[Figure]) -> String {
    let what = if super::restart::applies(s) {
        "restart designs beside spilling ones"
    } else {
        "the paper's experiments"
    };
    let mut out =
        format!("# SMS sweep: {what} on {} scenes\n\n{}", s.scenes.len(), s.provenance().markdown());
    let _ = writeln!(
        out,
        "Rendered at {} (the scene table below gives each scene's workload).\n",
        s.settings.describe()
    );
    out += &sampling_note(s);
    let m = &s.hw.mem;
    let _ = writeln!(
        out,
        "Cycle level: {} SMs, {} KB unified L1D/shared array per SM (SH stacks carved out), L2 {} KB, DRAM \
         latency {} cycles. {} simulations per scene ({} in all) plus a stack-depth pass per scene; {} worker \
         thread(s), {:.1} s wall time.\n",
        m.sms,
        s.base_kb(),
        m.l2_bytes / 1024,
        m.dram_latency,
        s.variants.len(),
        s.runs.len(),
        s.jobs,
        s.wall.as_secs_f64()
    );
    out += &peak_memory_line(s);
    let scenes = crate::report::table::Table::of(
        &s.scenes,
        &[
            ("scene", &|sc| sc.name.clone()),
            ("resolution", &|sc| format!("{}x{}", sc.opts.width, sc.opts.height)),
            ("spp", &|sc| sc.opts.spp.to_string()),
            ("max bounces", &|sc| sc.opts.max_bounces.to_string()),
            ("primitives", &|sc| sc.primitives.to_string()),
            ("triangles", &|sc| sc.triangles.to_string()),
            ("pixel warps", &|sc| sc.pixel_warps.to_string()),
            ("rays", &|sc| sc.rays.to_string()),
        ],
    );
    out += &scenes.to_markdown();
    out += "\nEach figure is also in its own `.md`, `.csv`, `.json` and `.svg`; `report.json` holds every raw run, \
            `timing.json` the wall-clock times.\n";
    for (i, f) in figures.iter().enumerate() {
        out += "\n";
        out += &figure_markdown(f, &format!("## {}.", i + 1));
    }
    out
}

/// The process's peak resident memory, on a line of its own (it varies between identical runs,
/// like the wall time).
fn peak_memory_line(s: &Sweep) -> String {
    format!("Peak memory: {} resident.\n\n", crate::run::memory::describe(s.peak_rss))
}

/// How the counts were obtained: every warp, or a sample with its measured and estimated error.
pub fn sampling_note(s: &Sweep) -> String {
    match s.sample {
        None => "Every pixel warp of every scene was simulated.\n\n".into(),
        Some(p) => {
            let widths: Vec<f64> =
                s.runs.iter().filter_map(|r| r.sample.map(|x| x.cycles_rel_half_width)).collect();
            if widths.is_empty() {
                return format!(
                    "A {:.0} % sample was asked for, but it would hold every pixel warp of every scene (at \
                     least one per batch): every warp was simulated.\n\n",
                    p.fraction * 100.0
                );
            }
            let mean = widths.iter().sum::<f64>() / widths.len().max(1) as f64;
            let max = widths.iter().copied().fold(0.0, f64::max);
            format!(
                "Sampled: {:.0} % of each scene's pixel warps ({:?} mode, {} batches), simulated as one launch \
                 whose counts are scaled to the whole frame. Expected error: {}. The cycle estimates' own 95 % \
                 intervals are ±{:.2} % on average, ±{:.2} % at most (indicative). `--sample 1` simulates \
                 every warp.\n\n",
                p.fraction * 100.0,
                p.mode,
                p.batches,
                crate::run::sweep::SAMPLE_ERROR,
                mean * 100.0,
                max * 100.0
            )
        }
    }
}
