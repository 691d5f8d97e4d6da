//! The report folder of a sweep: every figure as Markdown, CSV, JSON and SVG, per-scene depth
//! histograms, `summary.md` with every table, `report.json` with every raw run and
//! `timing.json` with wall-clock times.
//!
//! Wall-clock times are the only part that varies between identical sweeps, so they are kept out
//! of every JSON file but `timing.json`: the rest is bit-identical whatever the thread count.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::{json, Value};

use super::figures::{self, Figure};
use super::Sweep;
use crate::error::{Error, Result};

/// Creates `dir` and checks that files can be written there, before any simulation starts.
pub fn prepare(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    let probe = dir.join(".sms-sweep-write-test");
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

fn figure_markdown(f: &Figure, heading: &str) -> String {
    format!(
        "{heading} {}\n\n{}\n\n![{}]({}.svg)\n\n{}",
        f.title,
        f.note,
        f.title,
        f.name,
        f.table.to_markdown()
    )
}

/// Writes the whole report into `dir` and returns the files written.
pub fn write_all(s: &Sweep, dir: &Path) -> Result<Vec<PathBuf>> {
    prepare(dir)?;
    let mut written = Vec::new();
    let figures = figures::all(s)?;
    for f in &figures {
        write(dir.join(format!("{}.md", f.name)), &figure_markdown(f, "#"), &mut written)?;
        write(dir.join(format!("{}.csv", f.name)), &f.table.to_csv(), &mut written)?;
        let v = json!({ "title": f.title, "note": f.note, "table": f.table, "data": f.json });
        write(dir.join(format!("{}.json", f.name)), &pretty(&v), &mut written)?;
        let svg = dir.join(format!("{}.svg", f.name));
        f.chart.write_svg(&svg, &f.title)?;
        written.push(svg);
    }
    let depth_dir = dir.join("depth");
    std::fs::create_dir_all(&depth_dir).map_err(|e| Error::io(&depth_dir, e))?;
    for sc in &s.scenes {
        let d = &sc.depth;
        write(depth_dir.join(format!("{}.csv", sc.name)), &d.csv(), &mut written)?;
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
        runs.push(json!({ "scene": r.scene, "config": r.config, "l1d_kb": r.l1d_kb, "outcome": outcome }));
    }
    Ok(json!({
        "settings": to_value(&s.settings)?,
        "hardware": format!("{:?}", s.hw),
        "plan": {
            "configs": s.plan.configs.iter().map(|c| c.name()).collect::<Vec<_>>(),
            "rb_sizes": s.plan.rb_sizes,
            "l1d_kb": s.plan.l1d_kb,
            "runs_per_scene": s.variants.iter().map(|v| v.name()).collect::<Vec<_>>(),
        },
        "scenes": to_value(&s.scenes)?,
        "runs": runs,
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
        "runs": s.runs.iter().map(|r| json!({
            "scene": r.scene, "config": r.config, "l1d_kb": r.l1d_kb, "wall_secs": r.outcome.wall.as_secs_f64(),
        })).collect::<Vec<_>>(),
    })
}

fn summary(s: &Sweep, figures: &[Figure]) -> String {
    let st = &s.settings;
    let mut out = format!("# SMS sweep: the paper's experiments on {} scenes\n\n", s.scenes.len());
    let _ = writeln!(
        out,
        "Rendered at {}x{} pixels, {} sample(s) per pixel, {} bounce(s) after the primary ray, {:?} hierarchy, \
         {:?} child order, seed {}. Every scene uses these settings.\n",
        st.width, st.height, st.spp, st.bounces, st.bvh, st.order, st.seed
    );
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
    let mut scenes = crate::table::Table::new(["scene", "primitives", "triangles", "pixel warps", "rays"]);
    for sc in &s.scenes {
        scenes.row([
            sc.name.clone(),
            sc.primitives.to_string(),
            sc.triangles.to_string(),
            sc.pixel_warps.to_string(),
            sc.rays.to_string(),
        ]);
    }
    out += &scenes.to_markdown();
    out += "\nEach figure is also in its own `.md`, `.csv`, `.json` and `.svg`; `report.json` holds every raw run, \
            `timing.json` the wall-clock times.\n";
    for (i, f) in figures.iter().enumerate() {
        out += "\n";
        out += &figure_markdown(f, &format!("## {}.", i + 1));
    }
    out
}
