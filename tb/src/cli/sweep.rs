//! `sms sweep`: the paper's experiments (SPEC section 8) over a scene set at the cycle level,
//! written as one report folder. See [`crate::run::sweep`]. The arguments every sweep-like command
//! shares (scenes, workload, hardware, sampling, threads, report folder) are [`SweepArgs`];
//! `sms ablate` uses them too.

use std::path::PathBuf;

use anyhow::bail;

use crate::cli::stack_config::StackConfigArgs;
use crate::cli::{Format, HardwareArgs, OutputArgs, SampleArgs, SceneArgs, WorkloadArgs};
use crate::report::figure::Figure;
use crate::report::sweep::{figure_json, figure_markdown};
use crate::run::provenance::Provenance;
use crate::run::sweep::{self, Designs, Plan, Progress, Request, DEFAULT_SAMPLE, SAMPLE_ERROR};

/// `--quick`: the built-in scenes, tiny.
pub const QUICK_RES: (u32, u32) = (16, 16);

/// What `sms sweep` and `sms ablate` share.
#[derive(Clone, Debug, clap::Args)]
pub struct SweepArgs {
    /// Scenes, comma-separated: names, or paths to meshes or TOML descriptions, as `sms run
    /// --scene` takes (default: every built-in and described scene; with --quick, the built-in
    /// ones).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    #[command(flatten)]
    pub workload: WorkloadArgs,
    #[command(flatten)]
    pub sampling: SampleArgs,
    /// Smoke run: the built-in scenes at 16x16 pixels (--scenes and --res still apply).
    #[arg(long)]
    pub quick: bool,
    /// Simulations at once [default: the available cores]. With 1, each run uses a second core
    /// for itself (tracing, and its RT units on a helper thread). Results do not depend on it.
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Result cache folder [default: cache/ in the report folder]. Each simulation's result is
    /// stored there as it finishes, under a key of scene content, workload, sampling,
    /// configuration, hardware and model version (a hash of sms's sources: a rebuilt sms with
    /// changed sources recomputes everything); a stopped sweep run again continues where it
    /// stopped, and recomputes whatever changed. Results of other model versions can never be
    /// used again: the sweep counts them and --prune-cache deletes them.
    #[arg(long, value_name = "DIR", conflicts_with = "no_cache")]
    pub cache: Option<PathBuf>,
    /// Compute every result; read and write no cache.
    #[arg(long)]
    pub no_cache: bool,
    /// Delete the cache's stale files first: results of other model versions (never usable
    /// again), files that cannot be parsed, and temporary files of killed runs.
    #[arg(long, conflicts_with = "no_cache")]
    pub prune_cache: bool,
    /// Run even when the estimate of rays, memory and time is above the limits (half the
    /// available memory, 24 h).
    #[arg(long)]
    pub force: bool,
    /// Compute only share K of N (K from 0) of the results into the cache and write no report:
    /// N processes (e.g. a Slurm job array, scripts/slurm-sweep.sh) with the same arguments and
    /// one shared --cache, then one --collect, give the report of one process.
    #[arg(long, value_name = "K/N", conflicts_with_all = ["no_cache", "collect"])]
    pub shard: Option<sweep::Shard>,
    /// Simulate nothing: write the report from the cache alone, which the shards filled; an
    /// error says how many results are missing.
    #[arg(long, conflicts_with = "no_cache")]
    pub collect: bool,
    #[command(flatten)]
    pub hardware: HardwareArgs,
    #[command(flatten)]
    pub library: SceneArgs,
    // What is printed: the headline tables (sweep: the speed-ups per scene, then cost against
    // performance; ablate: the deltas); the folder gets every format.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// Prints `f`'s table in the format asked for (JSON: the figure's `.json` file), stating `p`.
pub fn print_figure(output: &OutputArgs, f: &Figure, p: &Provenance) -> anyhow::Result<()> {
    match output.format() {
        Format::Text => println!("{}{}", p.text(), f.table.to_text()),
        Format::Markdown => print!("{}{}", p.markdown(), figure_markdown(f, "#")),
        Format::Csv => print!("{}{}", p.csv(), f.table.to_csv()),
        Format::Json => println!("{}", serde_json::to_string_pretty(&figure_json(f, p))?),
    }
    Ok(())
}

/// Prints several figures' tables, each under its title, stating `p` once: text and Markdown
/// one after the other; CSV each table after a `# title` comment line, a blank line between;
/// JSON one object with each figure's `.json` content under its name.
pub fn print_figures(output: &OutputArgs, figures: &[Figure], p: &Provenance) -> anyhow::Result<()> {
    let each = |f: &dyn Fn(&Figure) -> String| figures.iter().map(f).collect::<Vec<_>>();
    match output.format() {
        Format::Text => {
            print!("{}{}", p.text(), each(&|f| format!("\n{}\n{}", f.title, f.table.to_text())).concat())
        }
        Format::Markdown => print!("{}{}", p.markdown(), each(&|f| figure_markdown(f, "#")).join("\n")),
        Format::Csv => {
            print!("{}{}", p.csv(), each(&|f| format!("# {}\n{}", f.title, f.table.to_csv())).join("\n"))
        }
        Format::Json => {
            let all: serde_json::Map<String, serde_json::Value> =
                figures.iter().map(|f| (f.name.to_string(), figure_json(f, p))).collect();
            println!("{}", serde_json::to_string_pretty(&all)?)
        }
    }
    Ok(())
}

impl SweepArgs {
    /// The result cache folder for a report in `out`: `--cache`, else `out/cache`; none with
    /// `--no-cache`.
    pub fn cache_dir(&self, out: &std::path::Path) -> Option<PathBuf> {
        (!self.no_cache).then(|| self.cache.clone().unwrap_or_else(|| out.join("cache")))
    }

    /// The request for `plan`, checked before any simulation starts.
    pub fn request(&self, plan: Plan) -> anyhow::Result<Request> {
        let library = self.library.library()?;
        let scenes = match (&self.scenes[..], self.quick) {
            ([], false) => library.names()?,
            ([], true) => crate::workload::scene::procedural::NAMES.iter().map(|s| s.to_string()).collect(),
            (names, _) => names.to_vec(),
        };
        sweep::check_scenes(&library, &scenes)?;
        let mut settings = self.workload.settings_for(&plan.configs)?;
        if self.quick && settings.res.is_none() {
            settings.res = Some(QUICK_RES);
        }
        if let Some((w, h)) = settings.res {
            if w == 0 || h == 0 {
                bail!("--res {w}x{h}: nothing to trace");
            }
        }
        if settings.spp == Some(0) {
            bail!("--spp 0: nothing to trace");
        }
        let sampling =
            SampleArgs { sample: Some(self.sampling.sample.unwrap_or(DEFAULT_SAMPLE)), ..self.sampling };
        let sample = sampling.plan(settings.seed)?;
        let jobs = match self.jobs {
            Some(0) => bail!("--jobs must be at least 1"),
            Some(n) => n,
            None => std::thread::available_parallelism().map_or(1, |n| n.get()),
        };
        let hw = self.hardware.hardware()?;
        if hw.mem.l1d_bytes % 1024 != 0 {
            bail!("the unified L1D/shared array must be a whole number of KB");
        }
        let hw_name = self.hardware.name();
        // The estimate of every scene at the settings asked for (LumiBench's where a scene's
        // own are kept: the descriptions' settings are of that size). The scenes are not loaded
        // yet, so their own memory (BYTES_PER_PRIMITIVE) is not in it.
        let opts = settings.apply(crate::workload::WorkloadOpts::default());
        let sims = scenes.len() * plan.variants(hw.mem.l1d_bytes / 1024)?.len();
        let estimate =
            crate::cli::guard::Estimate::new(&opts, 0, sims, jobs, crate::run::sim::Fidelity::Cycle);
        estimate.check(crate::cli::guard::available_memory(), self.force)?;
        let req = Request {
            scenes,
            settings,
            hw,
            hw_name,
            plan,
            jobs,
            sample,
            cache: None,
            prune_cache: false,
            shard: self.shard,
            collect: self.collect,
        };
        req.plan.variants(req.base_kb())?;
        Ok(req)
    }
}

#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    pub common: SweepArgs,
    /// Configurations run on the base L1D size (RB_8, the baseline, is always run).
    #[command(flatten)]
    pub stack: StackConfigArgs,
    /// Which comparison: paper (the paper's evaluation: its configurations, the RB-size and the
    /// L1D sweeps) or restart (`-c restart`: restart designs beside the spilling designs they
    /// compete with, on a flat BVH in nearest order, no RB-size or L1D sweep unless asked; the
    /// report adds the restart figure). -c replaces the comparison's configurations.
    #[arg(long, value_enum, default_value = "paper")]
    pub designs: Designs,
    /// N of the RB-size sweep: RB_N and RB_N+SH_8+SK+RA for each [default: 1,2,4,8,16,32 with
    /// --designs paper, none with restart].
    #[arg(long, value_delimiter = ',')]
    pub rb_sizes: Option<Vec<u32>>,
    /// Unified L1D/shared-array sizes in KB of the L1D sweep, each with RB_8 and SMS [default:
    /// 16,32,64,128,256 with --designs paper, none with restart].
    #[arg(long, value_delimiter = ',')]
    pub l1d_sizes: Option<Vec<u32>>,
    /// Report folder.
    #[arg(long, default_value = "out/sweep")]
    pub out: PathBuf,
}

impl Args {
    /// The sweep these arguments ask for, checked before any simulation starts.
    pub fn request(&self) -> anyhow::Result<Request> {
        let paper = self.designs == Designs::Paper;
        let rb_sizes =
            self.rb_sizes.clone().unwrap_or_else(|| if paper { sweep::RB_SIZES.to_vec() } else { vec![] });
        let l1d_sizes =
            self.l1d_sizes.clone().unwrap_or_else(|| if paper { sweep::L1D_KB.to_vec() } else { vec![] });
        // Each size named by its flag, before the plan's own checks name configurations.
        for &n in &rb_sizes {
            let c: rtl::config::Config =
                format!("RB_{n}").parse().map_err(|e| anyhow::anyhow!("--rb-sizes {n}: {e}"))?;
            c.validate().map_err(|e| anyhow::anyhow!("--rb-sizes {n}: {e}"))?;
        }
        let sms: rtl::config::Config = sweep::with_sms(8).parse()?;
        let sh_kb = rtl::gpu::shared_bytes(&sms).div_ceil(1024);
        if let Some(kb) = l1d_sizes.iter().find(|&&kb| kb <= sh_kb) {
            bail!(
                "--l1d-sizes {kb}: each size (in KB) must be above {sh_kb}, the SH stacks of {} that the L1D \
                 sweep runs on it (e.g. 16,32,64,128,256)",
                sms.name()
            );
        }
        if let Some(kb) = l1d_sizes.iter().find(|&&kb| kb > u32::MAX / 1024) {
            bail!("--l1d-sizes {kb}: too large; each size (in KB) must be at most {}", u32::MAX / 1024);
        }
        let plan = Plan {
            configs: {
                self.stack.names_only("sweep")?;
                self.stack.resolve(&[if paper { "paper" } else { "restart" }])?
            },
            rb_sizes,
            l1d_kb: l1d_sizes,
        };
        self.common.request(plan)
    }
}

/// The line announcing a sweep-like run on stderr, and its progress bar over `runs_per_scene`
/// simulations (plus a depth pass) per scene and arm.
pub fn start(
    what: &str,
    req: &Request,
    runs_per_scene: usize,
    arms: usize,
    out: &std::path::Path,
) -> Progress {
    let quiet = crate::cli::quiet();
    let sample =
        req.sample.map_or("every warp".into(), |p| format!("{:.0} % of the warps", p.fraction * 100.0));
    crate::cli::note(format!(
        "{what}: {} scenes × {runs_per_scene} simulations{} at {}, {sample}, {} jobs → {}",
        req.scenes.len(),
        if arms > 1 { format!(" × {arms} arms") } else { String::new() },
        req.settings.describe(),
        req.jobs,
        out.display()
    ));
    if req.sample.is_some() {
        crate::cli::note(format!("sampling; expected error: {SAMPLE_ERROR}"));
    }
    let total = req.scenes.len() * arms * (runs_per_scene + 1);
    if quiet {
        Progress::hidden()
    } else {
        Progress::new(total)
    }
}

/// The lines every sweep-like command ends with on stderr unless `-q`: wall time, peak memory,
/// the cache's use, and the error a sample is expected to have (the summary states it too).
pub fn finish(what: &str, result: &sweep::Sweep, written: usize, out: &std::path::Path) {
    let note = crate::cli::note;
    note(format!(
        "{what} in {:.1} s wall time, peak memory {}; wrote {written} files, summary: {}",
        result.wall.as_secs_f64(),
        crate::run::memory::describe(result.peak_rss),
        out.join("summary.md").display()
    ));
    if let Some(c) = &result.cache {
        note(format!("cache: {}", c.describe()));
    }
    if result.runs.iter().any(|r| r.sample.is_some()) {
        note(format!("sampled: {SAMPLE_ERROR}"));
    } else if let Some(p) = result.sample {
        note(format!(
            "not sampled: a {:.0} % sample of every scene would hold every warp (at least one per batch)",
            p.fraction * 100.0
        ));
    }
}

/// Says (unless `-q`) what shard `result` was of and what it did; `None` unless it was one.
pub fn shard_done(req: &Request, result: &sweep::Sweep) -> Option<()> {
    let (s, c) = (req.shard?, result.shard?);
    crate::cli::note(format!(
        "shard {}/{}: {} result(s) computed, {} already in the cache {}, {} left to the other shards; when \
         every shard is done, the same arguments with --collect (instead of --shard) write the report",
        s.index,
        s.count,
        c.computed,
        c.cached,
        req.cache.as_deref().map_or("?".into(), |d| d.display().to_string()),
        c.others
    ));
    Some(())
}

/// Checks that the report folder and cache are writable and not in the scene data, and prints
/// a line on Ctrl-C saying how many results the cache holds (a re-run resumes from them).
pub fn prepare(common: &SweepArgs, req: &Request, out: &std::path::Path) -> anyhow::Result<()> {
    let data = common.library.library()?.data;
    crate::cli::guard::output_folder("--out", out, &data)?;
    if let Some(c) = &req.cache {
        crate::cli::guard::outside_scene_data("--cache", c, &data)?;
    }
    crate::cli::guard::on_interrupt(req.cache.clone());
    Ok(())
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut req = args.request()?;
    req.cache = args.common.cache_dir(&args.out);
    req.prune_cache = args.common.prune_cache;
    prepare(&args.common, &req, &args.out)?;
    let variants = req.plan.variants(req.base_kb())?.len();
    let progress = start("sweep", &req, variants, 1, &args.out);
    let result = sweep::run(&req, &args.common.library.library()?, &progress)?;
    if shard_done(&req, &result).is_some() {
        return Ok(());
    }
    let written = crate::report::sweep::write_all(&result, &args.out)?;
    let mut headline =
        vec![crate::report::figures::performance(&result), crate::report::figures::cost(&result)?];
    if crate::report::restart::applies(&result) {
        headline.push(crate::report::restart::figure(&result)?);
    }
    print_figures(&args.common.output, &headline, &result.provenance())?;
    finish(&format!("{} simulations", result.runs.len()), &result, written.len(), &args.out);
    Ok(())
}
