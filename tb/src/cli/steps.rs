//! `sms steps`: traversal steps of the restart-trail walk with short stacks of N entries against
//! the full stack, per scene and BVH, every ray checked ([`crate::run::steps`]).

use std::time::Instant;

use anyhow::bail;
use serde::Serialize;

use crate::cli::{note, parse_res, Format, OutputArgs, SceneArgs};
use crate::report::table::Table;
use crate::run::provenance::{Provenance, WithProvenance, WorkloadId};
use crate::run::steps::{measure, Steps};
use crate::run::sweep::Settings;
use crate::workload::restart::{default_levels, RestartTree};
use crate::workload::traverse::ChildOrder;
use crate::workload::{Accel, BvhKind, PathEnd, Workload, WorkloadOpts};

#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    /// Scenes, comma-separated: names or paths, as `sms run --scene` takes (`sms scenes` lists
    /// the names).
    #[arg(long, value_delimiter = ',', required_unless_present = "all", conflicts_with = "all")]
    pub scene: Vec<String>,
    /// Every built-in and described scene.
    #[arg(long)]
    pub all: bool,
    /// Short-stack sizes N, comma-separated (each at least 1).
    #[arg(long, value_delimiter = ',', default_value = "2,4,5,8")]
    pub entries: Vec<usize>,
    /// Hierarchies, comma-separated: bvh2 and/or bvh6 (cwbvh is refused: its child order is
    /// obvhs's own, which a restart cannot reproduce).
    #[arg(long, value_enum, value_delimiter = ',', default_value = "bvh2,bvh6")]
    pub bvh: Vec<BvhKind>,
    /// Child order: nearest (the only one a restart reproduces; vulkansim is refused).
    #[arg(long, value_enum, default_value = "nearest")]
    pub order: ChildOrder,
    /// Acceleration structure: flat (two-level is refused: the trail walks one BVH).
    #[arg(long, value_enum, default_value = "flat")]
    pub accel: Accel,
    /// Trail levels [default: 96 for bvh2, 32 for bvh6]; a deeper BVH is refused.
    #[arg(long)]
    pub levels: Option<usize>,
    /// Resolution as WIDTHxHEIGHT (default: the scene's; LumiBench's 128x128 unless its
    /// description says otherwise).
    #[arg(long, value_parser = parse_res)]
    pub res: Option<(u32, u32)>,
    /// Samples per pixel (default: the scene's; LumiBench's 2).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Diffuse bounces after the primary ray (default: the scene's; LumiBench's 16 rays per
    /// path, i.e. 15).
    #[arg(long)]
    pub bounces: Option<u32>,
    /// When a hit ends a path besides a miss and the bounce limit: lumibench (a hit on a
    /// surface's back does not scatter, as LumiBench's Lambertian material) or always (every
    /// hit scatters, from either side). No Russian roulette either way.
    #[arg(long, value_enum, default_value = "lumibench")]
    pub path_end: PathEnd,
    /// Seed of the ray generator: the same seed gives bit-identical results.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub scenes: SceneArgs,
}

/// One scene's measurements in the report.
#[derive(Serialize)]
struct SceneSteps {
    scene: String,
    #[serde(flatten)]
    steps: Steps,
}

#[derive(Serialize)]
struct Report<'a> {
    rows: &'a [SceneSteps],
}

/// The arguments a restart walk cannot take, each a one-line error naming the argument.
fn check(args: &Args) -> anyhow::Result<()> {
    if let Some(n) = args.entries.iter().find(|&&n| n == 0) {
        bail!("--entries {n}: a short stack of 0 entries holds nothing; give sizes of 1 or more");
    }
    if args.bvh.contains(&BvhKind::Cwbvh) {
        bail!("--bvh cwbvh: the restart trail needs a child order a restart can reproduce; use bvh2 or bvh6");
    }
    if args.order != ChildOrder::Nearest {
        bail!(
            "--order vulkansim: the restart trail needs a child order a restart can reproduce; use nearest"
        );
    }
    if args.accel != Accel::Flat {
        bail!("--accel two-level: the restart trail walks one flat BVH; use flat");
    }
    Ok(())
}

fn table(rows: &[SceneSteps]) -> Table {
    let mut t =
        Table::new(["scene", "BVH", "N", "steps/ray", "× full stack", "restarts/ray", "re-fetched/ray"]);
    for r in rows {
        let s = &r.steps;
        let bvh = format!("{:?}", s.bvh).to_uppercase();
        let full = s.full.per_ray(s.full.steps());
        t.row([
            r.scene.clone(),
            bvh.clone(),
            "full".into(),
            format!("{full:.2}"),
            "1.000".into(),
            "".into(),
            "".into(),
        ]);
        for size in &s.sizes {
            let c = &size.counts;
            let steps = c.per_ray(c.steps());
            t.row([
                r.scene.clone(),
                bvh.clone(),
                size.entries.to_string(),
                format!("{steps:.2}"),
                format!("{:.3}", if full > 0.0 { steps / full } else { 1.0 }),
                format!("{:.3}", c.per_ray(c.restarts)),
                format!("{:.2}", c.per_ray(c.refetched)),
            ]);
        }
    }
    t
}

pub fn run(args: Args) -> anyhow::Result<()> {
    check(&args)?;
    let library = args.scenes.library()?;
    let names = if args.all { library.names()? } else { args.scene.clone() };
    let settings = |bvh| Settings {
        res: args.res,
        spp: args.spp,
        bounces: args.bounces,
        bvh,
        order: args.order,
        accel: Some(args.accel),
        path_end: args.path_end,
        seed: args.seed,
    };
    let mut rows = Vec::new();
    let mut opts_all: Vec<WorkloadOpts> = Vec::new();
    let mut files = Vec::new();
    let mut scene_names = Vec::new();
    for name in &names {
        let start = Instant::now();
        let scene = library.load(name)?;
        note(format!(
            "loaded {} ({} primitives) in {:.2} s",
            scene.name,
            scene.primitives.len(),
            start.elapsed().as_secs_f64()
        ));
        for &bvh in &args.bvh {
            let opts = settings(bvh).opts(&scene);
            let start = Instant::now();
            let workload = Workload::new(&scene, opts)?;
            let levels = args.levels.unwrap_or_else(|| default_levels(bvh));
            let tree = RestartTree::new(workload.bvh(), &scene.primitives, opts.order, levels)
                .map_err(|e| anyhow::anyhow!("{}: {e}", scene.name))?;
            let rays = workload.rays();
            note(format!(
                "{} {bvh:?}: {} rays, BVH {} levels deep, built and rendered in {:.2} s",
                scene.name,
                rays.len(),
                tree.depth(),
                start.elapsed().as_secs_f64()
            ));
            let what = format!("{} {bvh:?}", scene.name);
            let steps = measure(&tree, &scene.primitives, &rays, &args.entries, progress(&what))?;
            rows.push(SceneSteps { scene: scene.name.clone(), steps });
            opts_all.push(opts);
        }
        files.push(scene.files.clone());
        scene_names.push(scene.name.clone());
    }
    let p = Provenance::new(
        Some(WorkloadId::new(scene_names, &opts_all).with_files(files.iter().map(Vec::as_slice))),
        None,
    );
    let t = table(&rows);
    match args.output.format() {
        Format::Text => print!("{}{}", p.text(), t.to_text()),
        Format::Markdown => print!("{}{}", p.markdown(), t.to_markdown()),
        Format::Csv => print!("{}{}", p.csv(), t.to_csv()),
        Format::Json => {
            println!(
                "{}",
                serde_json::to_string_pretty(&WithProvenance {
                    report: Report { rows: &rows },
                    provenance: &p
                })?
            )
        }
    }
    Ok(())
}

/// Progress of one scene's rays on stderr every 2 s, unless `-q`.
fn progress(what: &str) -> impl FnMut(usize, usize) + '_ {
    let start = Instant::now();
    let mut last = start;
    move |done, total| {
        if crate::cli::quiet() || last.elapsed() < std::time::Duration::from_secs(2) {
            return;
        }
        last = Instant::now();
        eprintln!("{what}: {done}/{total} rays, {:.0} s", start.elapsed().as_secs_f64());
    }
}
