//! `sms depth`: stack-depth statistics of one scene, BVH and child order, printed as text,
//! Markdown, CSV or JSON and written as CSV, JSON, an SVG histogram and the rendered PNG.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;

use crate::cli::{guard, note, Format, OutputArgs, SceneArgs, WorkloadArgs};
use crate::run::provenance::{Provenance, WithProvenance, WorkloadId};
use crate::workload::depth::{DepthHistogram, DepthReport};
use crate::workload::Workload;

#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    #[arg(long, help = crate::cli::SCENE_HELP)]
    pub scene: String,
    #[command(flatten)]
    pub workload: WorkloadArgs,
    /// Output folder (default: out/depth/<scene>).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub scenes: SceneArgs,
    /// Run even when the estimate of rays, memory and time is above the limits (half the
    /// available memory, 24 h).
    #[arg(long)]
    pub force: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let start = Instant::now();
    let library = args.scenes.library()?;
    // Checked before any work, so that a bad folder costs nothing.
    let out = match &args.out {
        Some(out) => out.clone(),
        None => PathBuf::from("out/depth").join(library.name_of(&args.scene)?),
    };
    guard::output_folder("--out", &out, &library.data)?;
    let scene = library.load(&args.scene)?;
    note(format!(
        "loaded {} ({} primitives, {} degenerate triangles dropped) in {:.2} s",
        scene.name,
        scene.primitives.len(),
        scene.dropped_degenerate,
        start.elapsed().as_secs_f64()
    ));
    let opts = args.workload.opts(&scene);
    let estimate =
        guard::Estimate::new(&opts, scene.primitives.len(), 0, 1, crate::run::sim::Fidelity::Functional);
    estimate.check(guard::available_memory(), args.force)?;
    note(format!("estimated {}", estimate.describe()));

    let start = Instant::now();
    let workload = Workload::with_progress(&scene, opts, crate::cli::phase_progress("path-tracing"))?;
    note(format!(
        "built {:?} {:?} ({} nodes) and rendered {} rays in {:.2} s",
        opts.accel,
        opts.bvh,
        workload.bvh().node_count(),
        workload.num_rays(),
        start.elapsed().as_secs_f64()
    ));

    let start = Instant::now();
    let mut histogram = DepthHistogram::default();
    let warps = workload.num_warps();
    for (i, jobs) in workload.warps().enumerate() {
        for job in &jobs {
            job.lanes.iter().flatten().for_each(|t| histogram.add_trace(t));
        }
        let done = i as u32 + 1;
        if done.is_multiple_of(warps.div_ceil(10)) || done == warps {
            note(format!("  traced {done}/{warps} warps"));
        }
    }
    note(format!("recorded traces in {:.2} s", start.elapsed().as_secs_f64()));

    let report = DepthReport::new(&scene.name, opts, workload.num_rays(), histogram);
    let p = Provenance::new(
        Some(WorkloadId::new(vec![scene.name.clone()], &[opts]).with_files([&scene.files[..]])),
        None,
    );
    let csv = p.csv() + &report.csv();
    let json = serde_json::to_string_pretty(&WithProvenance { report: &report, provenance: &p })?;
    match args.output.format() {
        Format::Text => print!("{}{}", p.text(), report.table()),
        Format::Markdown => print!("{}{}", p.markdown(), report.markdown()),
        Format::Csv => print!("{csv}"),
        Format::Json => println!("{json}"),
    }

    let stem = format!("{:?}-{:?}", opts.bvh, opts.order).to_lowercase();
    let write = |name: String, text: String| {
        let path = out.join(name);
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))
    };
    write(format!("{stem}.csv"), csv)?;
    write(format!("{stem}.json"), json)?;
    let title =
        format!("{} {stem}: max {} mean {:.2} median {}", scene.name, report.max, report.mean, report.median);
    report.write_svg(&out.join(format!("{stem}.svg")), &title)?;
    workload.image().write_png(&out.join("render.png"))?;
    note(format!("wrote {}/{stem}.{{csv,json,svg}} and render.png", out.display()));
    Ok(())
}
