//! `sms sweep`: the paper's experiments (SPEC section 8) over a scene set at the cycle level,
//! written as one report folder. See [`crate::sweep`].

use std::path::PathBuf;

use anyhow::{bail, Context};
use rtl::config::Config;

use crate::cli::{parse_res, HardwareArgs, SceneArgs};
use crate::sweep::{self, Plan, Progress, Request, Settings};
use crate::workload::{BvhKind, ChildOrder};

/// Render settings of the full sweep, chosen so that every scene (25 simulations each) finishes
/// on two cores in about ten minutes: 96x96 pixels is 288 pixel warps, nine times the 32 warp
/// slots of the 8 SMs, so caches and stacks reach a steady state.
pub const DEFAULT_RES: (u32, u32) = (96, 96);
pub const DEFAULT_SPP: u32 = 1;
pub const DEFAULT_BOUNCES: u32 = 2;
/// `--quick`: the built-in scenes, tiny.
pub const QUICK_RES: (u32, u32) = (16, 16);

#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    /// Scenes, comma-separated (default: every built-in and described scene; with --quick, the
    /// built-in ones).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Configurations run on the base L1D size, comma-separated: paper names (RB_8,
    /// RB_8+SH_8+SK+RA, RB_FULL, SMS, ...) or `paper` for the 14 of SPEC section 8. RB_8, the
    /// baseline, is always run.
    #[arg(long, short = 'c', value_delimiter = ',', default_value = "paper")]
    pub configs: Vec<String>,
    /// N of the RB-size sweep: RB_N and RB_N+SH_8+SK+RA for each.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32")]
    pub rb_sizes: Vec<u32>,
    /// Unified L1D/shared-array sizes in KB of the L1D sweep, each with RB_8 and SMS.
    #[arg(long, value_delimiter = ',', default_value = "16,32,64,128,256")]
    pub l1d_sizes: Vec<u32>,
    /// Resolution as WIDTHxHEIGHT, the same for every scene [default: 96x96; --quick: 16x16].
    #[arg(long, value_parser = parse_res)]
    pub res: Option<(u32, u32)>,
    /// Samples per pixel [default: 1].
    #[arg(long)]
    pub spp: Option<u32>,
    /// Diffuse bounces after the primary ray [default: 2].
    #[arg(long)]
    pub bounces: Option<u32>,
    /// Hierarchy the RT unit walks.
    #[arg(long, value_enum, default_value = "bvh6")]
    pub bvh: BvhKind,
    /// Order in which an internal node's hit children are descended and pushed.
    #[arg(long, value_enum, default_value = "nearest")]
    pub order: ChildOrder,
    /// Seed of the ray generator: the same seed gives bit-identical results.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Smoke run: the built-in scenes at 16x16 pixels (--scenes and --res still apply).
    #[arg(long)]
    pub quick: bool,
    /// Worker threads [default: the available cores]. Results do not depend on it.
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Report folder.
    #[arg(long, default_value = "out/sweep")]
    pub out: PathBuf,
    /// No progress bar on stderr.
    #[arg(long)]
    pub quiet: bool,
    #[command(flatten)]
    pub hardware: HardwareArgs,
    #[command(flatten)]
    pub library: SceneArgs,
}

impl Args {
    /// The sweep these arguments ask for, checked before any simulation starts.
    pub fn request(&self) -> anyhow::Result<Request> {
        let library = self.library.library();
        let scenes = match (&self.scenes[..], self.quick) {
            ([], false) => library.names()?,
            ([], true) => crate::scene::procedural::NAMES.iter().map(|s| s.to_string()).collect(),
            (names, _) => names.to_vec(),
        };
        sweep::check_scenes(&library, &scenes)?;
        let mut configs = Vec::new();
        for name in &self.configs {
            if name.eq_ignore_ascii_case("paper") {
                configs.extend(Config::paper_set());
            } else {
                configs.push(name.parse::<Config>().with_context(|| format!("--configs {name}"))?);
            }
        }
        let (width, height) = self.res.unwrap_or(if self.quick { QUICK_RES } else { DEFAULT_RES });
        let settings = Settings {
            width,
            height,
            spp: self.spp.unwrap_or(DEFAULT_SPP),
            bounces: self.bounces.unwrap_or(DEFAULT_BOUNCES),
            bvh: self.bvh,
            order: self.order,
            seed: self.seed,
        };
        if width == 0 || height == 0 || settings.spp == 0 {
            bail!("--res {width}x{height} with --spp {}: nothing to trace", settings.spp);
        }
        let jobs = match self.jobs {
            Some(0) => bail!("--jobs must be at least 1"),
            Some(n) => n,
            None => std::thread::available_parallelism().map_or(1, |n| n.get()),
        };
        let hw = self.hardware.hardware()?;
        if hw.mem.l1d_bytes % 1024 != 0 {
            bail!("the unified L1D/shared array must be a whole number of KB");
        }
        let plan = Plan { configs, rb_sizes: self.rb_sizes.clone(), l1d_kb: self.l1d_sizes.clone() };
        let req = Request { scenes, settings, hw, plan, jobs };
        req.plan.variants(req.base_kb())?;
        Ok(req)
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let req = args.request()?;
    sweep::report::prepare(&args.out).with_context(|| format!("report folder {}", args.out.display()))?;
    let variants = req.plan.variants(req.base_kb())?.len();
    let s = &req.settings;
    eprintln!(
        "sweep: {} scenes × {variants} simulations at {}x{}, {} spp, {} bounce(s), {} jobs → {}",
        req.scenes.len(),
        s.width,
        s.height,
        s.spp,
        s.bounces,
        req.jobs,
        args.out.display()
    );
    // One depth pass per scene counts as a run.
    let total = req.scenes.len() * (variants + 1);
    let progress = if args.quiet { Progress::hidden() } else { Progress::new(total) };
    let result = sweep::run(&req, &args.library.library(), &progress)?;
    let written = sweep::report::write_all(&result, &args.out)?;
    let cost = sweep::figures::cost(&result)?;
    println!("{}", cost.table.to_text());
    eprintln!(
        "{} simulations in {:.1} s; wrote {} files, summary: {}",
        result.runs.len(),
        result.wall.as_secs_f64(),
        written.len(),
        args.out.join("summary.md").display()
    );
    Ok(())
}
