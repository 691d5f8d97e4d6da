//! The paper's experiments (SPEC section 8) over a scene set, at the cycle level: the engine
//! behind `sms sweep`.
//!
//! ```text
//!   scenes ──► for each scene: load, build the Workload once
//!                 │
//!                 ▼  --jobs threads (one rayon pool, [`crate::run::pool`]) run every (configuration, L1D size),
//!                 │  plus one pass that records the stack-depth histogram
//!              Sweep { scenes, runs (sorted by scene, then plan order) }
//!                 │
//!                 ▼
//!              figures (tables + charts) ──► report folder (Markdown, CSV, JSON, SVG)
//! ```
//!
//! Scenes run one after the other so only one scene's geometry is in memory at a time (the
//! largest takes about 2 GB); the runs of a scene share its workload across threads. Every
//! result is stored at its place in the plan, so the report does not depend on thread count or
//! scheduling.
//!
//! With a [`cache`] folder, every result is written there as it finishes and read back instead of
//! simulated when its key (scene, workload, sampling, configuration, hardware, model version)
//! is there: a stopped sweep run again continues where it stopped. A scene whose results are all
//! cached is loaded (its content is part of the key) but its BVH and traces are not built.

pub mod cache;
mod progress;

use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use rtl::config::Config;
use rtl::trace::NullSink;
use serde::Serialize;

pub use cache::CacheStats;
pub use progress::Progress;

use crate::error::{Error, Result};
use crate::run::sampling::SamplePlan;
use crate::run::sim::{share_of, simulate, simulate_sampled, Fidelity, Hardware, Metric, Outcome, RunSpec};
use crate::run::{memory, pool};
use crate::workload::depth::{DepthHistogram, DepthReport};
use crate::workload::scene::{Scene, SceneLibrary};
use crate::workload::traverse::ChildOrder;
use crate::workload::{Accel, BvhKind, PathEnd, Workload, WorkloadOpts};

/// The configuration every performance figure is normalised to.
pub const BASELINE: &str = "RB_8";
/// What "with SMS" adds to an RB_N configuration.
pub const SMS_SUFFIX: &str = "+SH_8+SK+RA";
/// RB sizes of the RB-size sweep.
pub const RB_SIZES: [u32; 6] = [1, 2, 4, 8, 16, 32];
/// Unified L1D/shared-array sizes (KB) of the L1D-size sweep.
pub const L1D_KB: [u32; 5] = [16, 32, 64, 128, 256];

/// Fraction of each scene's pixel warps a sweep simulates by default, chosen from a measurement
/// (see [`SAMPLE_ERROR`]): every warp. A 25 % sample takes a quarter of the time (the 18-scene
/// sweep: 346 s against 1407 s) but underestimates the speed-ups over RB_8 by 1–3 points in the
/// geomean and by up to 18 points on one scene. `--sample F` still gives a cheap preview with
/// that error printed.
pub const DEFAULT_SAMPLE: f64 = 1.0;

/// What the measurement behind [`DEFAULT_SAMPLE`] found, printed in every sampled report
/// (`scripts/sample-error.py` on a 25 % and a full `sms sweep` of the 18 scenes, paper hardware).
pub const SAMPLE_ERROR: &str = "measured on the 18 scenes at LumiBench's settings on the paper hardware, a \
     25 % tile sample against every warp: geomean speed-ups over RB_8 off by up to 0.035 (RB_FULL 1.210 \
     sampled, 1.241 in full; SMS 1.160, 1.181: sampling underestimates the gains), one scene's speed-up \
     by up to 0.18 (lamborghini-huracan RB_FULL). Differences between designs sampled alike err less, \
     but use --sample 1 (the default) for conclusions";

/// Which comparison a sweep makes (`sms sweep --designs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Designs {
    /// The paper's evaluation (SPEC section 8): its configurations, the RB-size and L1D sweeps.
    Paper,
    /// Restart designs beside the spilling designs they compete with (`-c restart`).
    Restart,
}

/// `RB_N` with SMS.
pub fn with_sms(n: u32) -> String {
    format!("RB_{n}{SMS_SUFFIX}")
}

/// One simulation of a scene: a configuration on a unified L1D/shared array of `l1d_kb`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Variant {
    pub config: Config,
    pub l1d_kb: u32,
}

impl Variant {
    pub fn name(&self) -> String {
        format!("{}@{}KB", self.config.name(), self.l1d_kb)
    }
}

/// Which simulations to run on every scene.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Configurations on the base L1D size (performance, off-chip, bank-conflict and cost
    /// figures). RB_8 is always run.
    pub configs: Vec<Config>,
    /// N of the RB-size sweep: RB_N and RB_N+SH_8+SK+RA on the base L1D size.
    pub rb_sizes: Vec<u32>,
    /// Unified-array sizes (KB) of the L1D sweep, each with RB_8 and SMS.
    pub l1d_kb: Vec<u32>,
}

impl Default for Plan {
    /// SPEC section 8: the 14 paper configurations, N = 1 to 32 and 16 to 256 KB.
    fn default() -> Self {
        Plan { configs: Config::paper_set(), rb_sizes: RB_SIZES.to_vec(), l1d_kb: L1D_KB.to_vec() }
    }
}

impl Plan {
    /// Every run of a scene, without repeats: RB_8 first, then the configurations, the RB-size
    /// sweep and the L1D sweep, in that order.
    pub fn variants(&self, base_kb: u32) -> Result<Vec<Variant>> {
        let parse = |name: &str| name.parse::<Config>().map_err(|e| Error::Invalid(format!("{name}: {e}")));
        let mut at_base = vec![parse(BASELINE)?];
        at_base.extend(self.configs.iter().copied());
        for &n in &self.rb_sizes {
            at_base.push(parse(&format!("RB_{n}"))?);
            at_base.push(parse(&with_sms(n))?);
        }
        let mut all: Vec<Variant> =
            at_base.into_iter().map(|config| Variant { config, l1d_kb: base_kb }).collect();
        for &kb in &self.l1d_kb {
            for name in [BASELINE.to_string(), with_sms(8)] {
                all.push(Variant { config: parse(&name)?, l1d_kb: kb });
            }
        }
        let mut unique: Vec<Variant> = Vec::with_capacity(all.len());
        for v in all {
            if !unique.iter().any(|u| u.config.name() == v.config.name() && u.l1d_kb == v.l1d_kb) {
                unique.push(v);
            }
        }
        for v in &unique {
            let sh_kb = rtl::gpu::shared_bytes(&v.config).div_ceil(1024);
            if sh_kb >= v.l1d_kb {
                return Err(Error::Invalid(format!(
                    "{}: the SH stacks need {sh_kb} KB of shared memory, the unified array has {} KB",
                    v.config.name(),
                    v.l1d_kb
                )));
            }
        }
        Ok(unique)
    }
}

/// What every scene is rendered with: each scene's own render settings (its description's
/// `[render]`, LumiBench's by default), with `res`, `spp` and `bounces` overriding them for every
/// scene when given.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Settings {
    pub res: Option<(u32, u32)>,
    pub spp: Option<u32>,
    pub bounces: Option<u32>,
    pub bvh: BvhKind,
    pub order: ChildOrder,
    /// `None`: two-level with BVH6 (as the Vulkan pipeline builds it), flat otherwise.
    pub accel: Option<Accel>,
    pub path_end: PathEnd,
    pub seed: u64,
}

impl Settings {
    /// `scene`'s workload under these settings.
    pub fn opts(&self, scene: &Scene) -> WorkloadOpts {
        self.apply(WorkloadOpts::for_scene(scene))
    }

    /// `opts` (a scene's own) with these settings applied.
    pub fn apply(&self, mut opts: WorkloadOpts) -> WorkloadOpts {
        if let Some((w, h)) = self.res {
            (opts.width, opts.height) = (w, h);
        }
        opts.spp = self.spp.unwrap_or(opts.spp);
        opts.max_bounces = self.bounces.unwrap_or(opts.max_bounces);
        opts.bvh = self.bvh;
        opts.order = self.order;
        opts.accel =
            self.accel.unwrap_or(if self.bvh == BvhKind::Bvh6 { Accel::TwoLevel } else { Accel::Flat });
        opts.path_end = self.path_end;
        opts.seed = self.seed;
        opts
    }

    /// "each scene's own" or the override, for summaries.
    pub fn describe(&self) -> String {
        let res = self.res.map_or("each scene's own resolution".into(), |(w, h)| format!("{w}x{h} pixels"));
        let spp =
            self.spp.map_or("each scene's samples per pixel".into(), |n| format!("{n} sample(s) per pixel"));
        let b = self
            .bounces
            .map_or("each scene's bounce limit".into(), |n| format!("{n} bounce(s) after the primary ray"));
        format!(
            "{res}, {spp}, {b}, {:?} hierarchy, {} acceleration structure, {:?} child order, path end {:?}, seed {}",
            self.bvh,
            self.accel.map_or("default (two-level with BVH6)".to_string(), |a| format!("{a:?}")),
            self.order,
            self.path_end,
            self.seed
        )
    }
}

/// Changes a sweep arm makes to the hardware and to each scene's workload (the ablation turns
/// one mechanism off this way). The hardware change is made once, with a default workload, and
/// the workload change per scene with default hardware: neither may depend on the other.
pub type Tweak = fn(&mut Hardware, &mut WorkloadOpts);

/// Everything a sweep needs.
#[derive(Clone, Debug)]
pub struct Request {
    pub scenes: Vec<String>,
    pub settings: Settings,
    /// The hardware; `mem.l1d_bytes` is the base unified-array size.
    pub hw: Hardware,
    /// The hardware as named on the command line (reports state it).
    pub hw_name: String,
    pub plan: Plan,
    /// Worker threads.
    pub jobs: usize,
    /// Simulate a sample of each scene's pixel warps (cycle level: one launch of the sample,
    /// counts scaled to the whole frame); `None` simulates every warp.
    pub sample: Option<SamplePlan>,
    /// Folder of the result cache ([`cache`]); `None` computes everything and stores nothing.
    pub cache: Option<PathBuf>,
    /// Delete the cache's stale files before the sweep ([`cache::Cache::open_pruning`]).
    pub prune_cache: bool,
    /// Compute only this share of the results into the cache ([`Shard`]); no reports.
    pub shard: Option<Shard>,
    /// Simulate nothing: every result must be in the cache (the shards' work, collected).
    pub collect: bool,
}

/// Share `index` of `count` (0 ≤ index < count) of a sweep's work: the results (a scene's
/// simulation in one arm, or a scene's depth pass) numbered in plan order, every `count`-th
/// from `index` on. Shards of one sweep together compute every result once.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for Shard {
    type Err = String;

    /// `K/N`, 0 ≤ K < N (Slurm's `$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT` with `--array=0-(N-1)`).
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let (k, n) = s.split_once('/').ok_or_else(|| format!("'{s}': expected K/N, e.g. 0/4"))?;
        let parse = |v: &str| v.trim().parse::<usize>().map_err(|e| format!("'{s}': {v}: {e}"));
        let (index, count) = (parse(k)?, parse(n)?);
        if count == 0 || index >= count {
            return Err(format!("'{s}': K must be 0 to N-1 (shards are numbered from 0), and N at least 1"));
        }
        Ok(Shard { index, count })
    }
}

/// What a shard did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ShardCounts {
    /// Of this shard's results: simulated now, and found in the cache.
    pub computed: usize,
    pub cached: usize,
    /// Results left to the other shards.
    pub others: usize,
}

impl Request {
    pub fn base_kb(&self) -> u32 {
        self.hw.mem.l1d_bytes / 1024
    }
}

/// One simulation's result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Run {
    pub scene: String,
    pub config: String,
    pub l1d_kb: u32,
    /// The whole frame's counts: measured, or estimated from a sample.
    pub outcome: Outcome,
    /// How the counts were estimated, for a sampled run.
    pub sample: Option<RunSample>,
    /// Read from the cache, not simulated by this process: its `outcome.wall` is the time the
    /// simulation took when it ran.
    #[serde(skip)]
    pub from_cache: bool,
}

/// A sampled run: what was simulated and the 95 % half width of the cycle estimate.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RunSample {
    pub fraction: f64,
    pub sampled_warps: u32,
    /// Half width of the cycles' 95 % interval relative to the estimate (indicative: see
    /// `crate::run::sampling`).
    pub cycles_rel_half_width: f64,
}

/// What a scene is, and its stack-depth statistics.
#[derive(Clone, Debug, Serialize)]
pub struct SceneResult {
    pub name: String,
    /// The workload the scene was rendered with.
    pub opts: WorkloadOpts,
    pub primitives: usize,
    pub triangles: usize,
    pub rays: u64,
    pub pixel_warps: u32,
    pub depth: DepthReport<WorkloadOpts>,
    /// The files a scene given by path was read from (stated in the provenance).
    #[serde(skip)]
    pub files: Vec<crate::workload::scene::SourceFile>,
    /// Seconds to load the scene and to build its BVH and render it (not part of the results).
    #[serde(skip)]
    pub load_secs: f64,
    #[serde(skip)]
    pub workload_secs: f64,
}

/// A finished sweep.
#[derive(Clone, Debug)]
pub struct Sweep {
    pub settings: Settings,
    pub hw: Hardware,
    /// The requested hardware's name ([`Request::hw_name`]; an arm's tweak does not rename it).
    pub hw_name: String,
    pub plan: Plan,
    pub variants: Vec<Variant>,
    pub scenes: Vec<SceneResult>,
    /// Sorted by scene (in request order), then by variant (in plan order).
    pub runs: Vec<Run>,
    pub jobs: usize,
    pub sample: Option<SamplePlan>,
    pub wall: Duration,
    /// The process's peak resident memory at the end of the sweep ([`memory::peak_rss_bytes`]).
    pub peak_rss: Option<u64>,
    /// How many results came from the cache (not part of any report: a resumed sweep's reports
    /// equal an uninterrupted one's).
    pub cache: Option<CacheStats>,
    /// A shard's counts; a shard's sweep holds no runs or scenes (its results are in the cache).
    pub shard: Option<ShardCounts>,
}

impl Sweep {
    pub fn base_kb(&self) -> u32 {
        self.hw.mem.l1d_bytes / 1024
    }

    /// What produced this sweep's reports: scenes and their workloads, hardware, model.
    pub fn provenance(&self) -> crate::run::provenance::Provenance {
        use crate::run::provenance::{HardwareId, Provenance, WorkloadId};
        let names = self.scenes.iter().map(|s| s.name.clone()).collect();
        let opts: Vec<WorkloadOpts> = self.scenes.iter().map(|s| s.opts).collect();
        Provenance::new(
            Some(WorkloadId::new(names, &opts).with_files(self.scenes.iter().map(|s| &s.files[..]))),
            Some(HardwareId::new(self.hw_name.clone(), &self.hw)),
        )
    }

    pub fn run(&self, scene: &str, config: &str, l1d_kb: u32) -> Option<&Run> {
        self.runs.iter().find(|r| r.scene == scene && r.config == config && r.l1d_kb == l1d_kb)
    }

    pub fn cycles(&self, scene: &str, config: &str, l1d_kb: u32) -> Option<u64> {
        Some(self.run(scene, config, l1d_kb)?.outcome.gpu?.cycles)
    }
}

/// Checks scene names (and that scene files given by path exist) before any work, so a typo
/// costs nothing.
pub fn check_scenes(library: &SceneLibrary, scenes: &[String]) -> Result<()> {
    for name in scenes {
        library.resolve(name)?;
    }
    if scenes.is_empty() {
        return Err(Error::Invalid("no scenes to sweep".into()));
    }
    Ok(())
}

/// Runs the sweep. `progress` shows runs done, what is running, elapsed time and an estimate
/// of the rest.
pub fn run(req: &Request, library: &SceneLibrary, progress: &Progress) -> Result<Sweep> {
    let mut arms = run_arms(req, &[None], library, progress)?;
    Ok(arms.pop().expect("one arm"))
}

/// Runs the sweep once per arm, each with its tweak applied to the hardware and to every
/// scene's workload (`None`: as requested). Scenes are the outer loop, so each is loaded once;
/// arms whose workloads are equal share one. One [`Sweep`] per arm, in order; `wall` is the
/// whole run's.
pub fn run_arms(
    req: &Request,
    arms: &[Option<Tweak>],
    library: &SceneLibrary,
    progress: &Progress,
) -> Result<Vec<Sweep>> {
    check_scenes(library, &req.scenes)?;
    let hws = arm_hardware(req.hw, arms);
    let variants: Vec<Vec<Variant>> =
        hws.iter().map(|hw| req.plan.variants(hw.mem.l1d_bytes / 1024)).collect::<Result<_>>()?;
    let open = if req.prune_cache { cache::Cache::open_pruning } else { cache::Cache::open };
    let cache = req.cache.as_deref().map(open).transpose()?;
    let start = Instant::now();
    let mut out: Vec<Sweep> = hws.iter().zip(&variants).map(|(&hw, v)| empty_sweep(req, hw, v)).collect();
    if (req.shard.is_some() || req.collect) && cache.is_none() {
        return Err(Error::Invalid(
            "--shard and --collect work through the result cache: drop --no-cache".into(),
        ));
    }
    let mut tally = Tally::default();
    for name in &req.scenes {
        sweep_scene(req, arms, library, name, cache.as_ref(), &mut out, &mut tally, progress)?;
    }
    progress.finish();
    if tally.missing > 0 {
        return Err(Error::Invalid(format!(
            "--collect: {} result(s) are not in the cache {}: run the shards that compute them (the \
             same arguments with --shard K/N) first",
            tally.missing,
            req.cache.as_deref().map_or("?".into(), |d| d.display().to_string())
        )));
    }
    let wall = start.elapsed();
    let peak_rss = memory::peak_rss_bytes();
    let stats = cache.as_ref().map(cache::Cache::stats);
    for sw in &mut out {
        sw.wall = wall;
        sw.peak_rss = peak_rss;
        sw.cache = stats.clone();
        sw.shard = req.shard.map(|_| tally.counts);
    }
    Ok(out)
}

/// Each arm's hardware: the request's with the arm's tweak applied.
fn arm_hardware(hw: Hardware, arms: &[Option<Tweak>]) -> Vec<Hardware> {
    arms.iter()
        .map(|t| {
            let mut hw = hw;
            if let Some(t) = t {
                t(&mut hw, &mut WorkloadOpts::default());
            }
            hw
        })
        .collect()
}

/// An arm's sweep before any scene has run: the request's settings on the arm's hardware.
fn empty_sweep(req: &Request, hw: Hardware, variants: &[Variant]) -> Sweep {
    Sweep {
        settings: req.settings,
        hw,
        hw_name: req.hw_name.clone(),
        plan: req.plan.clone(),
        variants: variants.to_vec(),
        scenes: Vec::with_capacity(req.scenes.len()),
        runs: Vec::with_capacity(req.scenes.len() * variants.len()),
        jobs: req.jobs,
        sample: req.sample,
        wall: Duration::ZERO,
        peak_rss: None,
        cache: None,
        shard: None,
    }
}

/// Where the sweep stands in its plan: results are numbered in plan order (scene, arm, variant,
/// then the scene's depth pass) so that every shard splits them alike; what this shard found, and
/// how many results `--collect` did not find in the cache.
#[derive(Default)]
struct Tally {
    number: usize,
    counts: ShardCounts,
    missing: usize,
}

impl Tally {
    /// Numbers the next `n` results and says which of them this process computes.
    fn own(&mut self, shard: Option<Shard>, n: usize) -> Vec<bool> {
        (0..n)
            .map(|_| {
                self.number += 1;
                shard.is_none_or(|s| (self.number - 1) % s.count == s.index)
            })
            .collect()
    }

    /// Counts a shard's results by owner and by whether they are known (`have`, by index).
    fn count(&mut self, owned: &[bool], have: impl Fn(usize) -> bool) {
        for (j, &own) in owned.iter().enumerate() {
            match (own, have(j)) {
                (false, _) => self.counts.others += 1,
                (true, true) => self.counts.cached += 1,
                (true, false) => self.counts.computed += 1,
            }
        }
    }
}

/// Each arm's workload options for `scene`: the request's with the arm's tweak applied.
fn arm_workload_opts(req: &Request, scene: &Scene, arms: &[Option<Tweak>]) -> Vec<WorkloadOpts> {
    arms.iter()
        .map(|tweak| {
            let mut opts = req.settings.opts(scene);
            if let Some(t) = tweak {
                t(&mut Hardware::default(), &mut opts);
            }
            opts
        })
        .collect()
}

/// The index in `built` of the workload built with `opts`, added (unbuilt, with its statistics
/// from the cache when there) if no arm before used it.
fn shared_workload<'s>(
    built: &mut Vec<Built<'s>>,
    opts: WorkloadOpts,
    cache: Option<&cache::Cache>,
    scene_key: Option<&str>,
) -> usize {
    if let Some(i) = built.iter().position(|b| b.opts == opts) {
        return i;
    }
    let info = match (cache, scene_key) {
        (Some(c), Some(k)) => c.get_scene(&cache::scene_info_key(k, &opts)),
        _ => None,
    };
    built.push(Built { opts, workload: None, secs: 0.0, info });
    built.len() - 1
}

/// One scene in every arm: loads it, runs what is neither cached nor another shard's, and appends
/// each arm's results to its sweep in `out`. Arms with equal workloads share one (built only if
/// some result is not cached), and its statistics (they depend on the traces alone), from the
/// cache or the first arm's pass.
#[allow(clippy::too_many_arguments)]
fn sweep_scene(
    req: &Request,
    arms: &[Option<Tweak>],
    library: &SceneLibrary,
    name: &str,
    cache: Option<&cache::Cache>,
    out: &mut [Sweep],
    tally: &mut Tally,
    progress: &Progress,
) -> Result<()> {
    progress.status(&format!("loading {name}"));
    let t = Instant::now();
    let scene = library.load(name)?;
    let load_secs = t.elapsed().as_secs_f64();
    let scene_key = cache.map(|_| cache::scene_key(&scene));
    let mut built: Vec<Built> = Vec::new();
    let arm_opts = arm_workload_opts(req, &scene, arms);
    for (a, &opts) in arm_opts.iter().enumerate() {
        let i = shared_workload(&mut built, opts, cache, scene_key.as_deref());
        let sw = &mut out[a];
        let keys: Vec<Option<String>> = sw
            .variants
            .iter()
            .map(|v| {
                let k = scene_key.as_ref()?;
                Some(cache::run_key(k, &opts, req.sample, &v.config, &variant_hw(&sw.hw, v)))
            })
            .collect();
        let cached: Vec<Option<Measured>> = keys.iter().map(|k| cache?.get_run(k.as_ref()?)).collect();
        let from_cache: Vec<bool> = cached.iter().map(Option::is_some).collect();
        let b = &mut built[i];
        // Which results (the variants', then the depth pass) this process computes.
        let mut owned = tally.own(req.shard, cached.len() + 1);
        let info_known = b.info.is_some();
        if req.shard.is_some() {
            tally.count(&owned, |j| if j < cached.len() { cached[j].is_some() } else { info_known });
        }
        if req.collect {
            let absent = cached.iter().filter(|c| c.is_none()).count() + usize::from(!info_known);
            if absent > 0 {
                tally.missing += absent;
                continue;
            }
        }
        if tally.missing > 0 {
            continue;
        }
        // A depth pass already known is not run again, whoever owns it.
        owned[cached.len()] &= !info_known;
        let needed =
            owned.iter().zip(cached.iter().map(Option::is_none).chain([!info_known])).any(|(o, n)| *o && n);
        if b.workload.is_none() && needed {
            progress.status(&format!("building {name}"));
            let t = Instant::now();
            b.workload = Some(Workload::new(&scene, opts)?);
            b.secs = t.elapsed().as_secs_f64();
        }
        let job = SceneJob {
            req,
            hw: &sw.hw,
            workload: b.workload.as_ref(),
            variants: &sw.variants,
            cached,
            keys: &keys,
            cache,
            scene: name,
            progress,
        };
        let info_key = scene_key.as_ref().map(|k| cache::scene_info_key(k, &opts));
        let (outcomes, info) = run_scene(job, b.info.clone(), info_key.as_deref(), &owned)?;
        // Only one workload in memory at a time: dropped after the last arm that renders it.
        let last_use = !arm_opts[a + 1..].contains(&opts);
        if req.shard.is_some() {
            b.info = b.info.clone().or(info);
            if last_use {
                b.workload = None;
            }
            continue;
        }
        let outcomes: Vec<Measured> = outcomes.into_iter().flatten().collect();
        let info = info.expect("the depth pass ran or its result was known");
        b.info = Some(info.clone());
        sw.runs.extend(outcomes.into_iter().zip(&sw.variants).zip(from_cache).map(
            |(((outcome, sample), v), from_cache)| Run {
                scene: name.to_owned(),
                config: v.config.name(),
                l1d_kb: v.l1d_kb,
                outcome,
                sample,
                from_cache,
            },
        ));
        sw.scenes.push(scene_result(&scene, opts, info, load_secs, b.secs));
        if last_use {
            b.workload = None;
        }
    }
    Ok(())
}

/// A workload of a scene shared by the arms that render it alike.
struct Built<'s> {
    opts: WorkloadOpts,
    /// Built only when something is not cached.
    workload: Option<Workload<'s>>,
    /// Seconds to build it.
    secs: f64,
    info: Option<SceneInfo>,
}

/// What a scene's workload is, beside the simulations: computed by the depth pass, or cached.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneInfo {
    pub rays: u64,
    pub pixel_warps: u32,
    pub depth: DepthHistogram,
}

/// The hardware of variant `v`: `hw` with the variant's unified-array size.
fn variant_hw(hw: &Hardware, v: &Variant) -> Hardware {
    Hardware { mem: rtl::mem::MemParams { l1d_bytes: v.l1d_kb * 1024, ..hw.mem }, ..*hw }
}

fn scene_result(
    scene: &Scene,
    opts: WorkloadOpts,
    info: SceneInfo,
    load_secs: f64,
    workload_secs: f64,
) -> SceneResult {
    SceneResult {
        name: scene.name.clone(),
        opts,
        primitives: scene.primitives.len(),
        triangles: scene.primitives.triangle_count(),
        rays: info.rays,
        pixel_warps: info.pixel_warps,
        depth: DepthReport::new(&scene.name, opts, info.rays, info.depth),
        files: scene.files.clone(),
        load_secs,
        workload_secs,
    }
}

/// A variant's whole-frame counts and, when sampled, how.
type Measured = (Outcome, Option<RunSample>);

/// One variant on `workload`: every pixel warp, or the request's sample scaled to the frame.
fn simulate_variant(
    req: &Request,
    spec: &RunSpec,
    workload: &Workload,
    progress: &Progress,
) -> Result<Measured> {
    // A sample that would hold every warp (small frames: at least one warp per batch) is the
    // full run.
    let n = workload.num_warps();
    let partial =
        |p: &SamplePlan| p.fraction < 1.0 && ((f64::from(n) * p.fraction).round() as u32).max(p.batches) < n;
    match req.sample.filter(partial) {
        None => Ok((simulate(spec, workload, None, &mut NullSink, |_| progress.tick())?, None)),
        Some(plan) => {
            let s = simulate_sampled(spec, workload, &plan, |_| progress.tick())?;
            let launch = s.launch.expect("a cycle-level sample has one launch");
            let total = workload.num_warps();
            // Every count scaled by total/sampled warps (the launch's ratio estimate), cycles
            // from their estimate (dispatch phase scaled, drain kept).
            let mut o = share_of(&launch, f64::from(total) / f64::from(launch.pixel_warps.max(1)), total);
            o.wall = s.wall;
            let cycles = s.get(Metric::Cycles).expect("cycle level estimates cycles");
            if let Some(g) = o.gpu.as_mut() {
                g.cycles = cycles.value.round() as u64;
            }
            let info = RunSample {
                fraction: plan.fraction,
                sampled_warps: launch.pixel_warps,
                cycles_rel_half_width: cycles.relative(),
            };
            Ok((o, Some(info)))
        }
    }
}

/// One arm's simulations of one scene.
struct SceneJob<'a> {
    req: &'a Request,
    hw: &'a Hardware,
    /// `None` only when every result and the scene's statistics are known.
    workload: Option<&'a Workload<'a>>,
    variants: &'a [Variant],
    /// Results read from the cache, by variant.
    cached: Vec<Option<Measured>>,
    /// Cache keys by variant (`None` without a cache).
    keys: &'a [Option<String>],
    cache: Option<&'a cache::Cache>,
    scene: &'a str,
    progress: &'a Progress,
}

/// Every variant of one scene not in the cache on `req.jobs` threads, plus the depth pass unless
/// the workload's statistics are `known`; outcomes in plan order. Fresh results are stored in the
/// cache as each finishes, the statistics under `info_key`. Only the `owned` results (by index,
/// the depth pass last) are computed: the others are `None`, as is the statistics if neither
/// known nor owned.
fn run_scene(
    job: SceneJob,
    known: Option<SceneInfo>,
    info_key: Option<&str>,
    owned: &[bool],
) -> Result<(Vec<Option<Measured>>, Option<SceneInfo>)> {
    let SceneJob { req, hw, workload, variants, cached, keys, cache, scene, progress } = job;
    let need = |what: &str| {
        workload.ok_or_else(|| Error::Invalid(format!("{scene} {what}: no workload built (internal)")))
    };
    // Index `variants.len()` is the depth pass.
    let info = Mutex::new(known.clone());
    let results = pool::map_indexed(req.jobs, variants.len() + 1, |i| -> Result<Option<Measured>> {
        if i == variants.len() {
            let label = format!("{scene} depth");
            if !owned[i] && known.is_none() {
                progress.skipped(&format!("{label} (another shard's)"));
                return Ok(None);
            }
            if known.is_some() {
                // Counted as a run of the progress total, with nothing to do.
                progress.skipped(&format!("{label} (known)"));
                return Ok(None);
            }
            progress.started(&label);
            let workload = need("depth")?;
            let mut h = DepthHistogram::default();
            for jobs in workload.warps() {
                jobs.iter().flat_map(|j| j.lanes.iter().flatten()).for_each(|t| h.add_trace(t));
                progress.tick();
            }
            let computed =
                SceneInfo { rays: workload.num_rays(), pixel_warps: workload.num_warps(), depth: h };
            if let (Some(c), Some(k)) = (cache, info_key) {
                c.put_scene(k, &computed)?;
            }
            *info.lock().expect("info lock") = Some(computed);
            progress.done(&label);
            return Ok(None);
        }
        let v = variants[i];
        let label = format!("{scene} {}", v.name());
        if let Some(m) = &cached[i] {
            progress.skipped(&format!("{label} (cached)"));
            return Ok(Some(*m));
        }
        if !owned[i] {
            progress.skipped(&format!("{label} (another shard's)"));
            return Ok(None);
        }
        if let Some(c) = cache {
            c.check_stop()?;
        }
        progress.started(&label);
        let spec = RunSpec { config: v.config, hw: variant_hw(hw, &v), fidelity: Fidelity::Cycle };
        let r = need(&v.name())
            .and_then(|w| simulate_variant(req, &spec, w, progress))
            .map_err(|e| Error::Invalid(format!("{label}: {e}")));
        progress.done(&label);
        let m = r?;
        if let (Some(c), Some(k)) = (cache, &keys[i]) {
            c.put_run(k, &m)?;
        }
        Ok(Some(m))
    });
    let mut outcomes = results.into_iter().collect::<Result<Vec<_>>>()?;
    outcomes.pop(); // the depth pass's place
    Ok((outcomes, info.into_inner().expect("info lock")))
}

/// Geometric mean; `None` for no values or a value that is not positive.
pub fn geomean(values: impl IntoIterator<Item = f64>) -> Option<f64> {
    let (mut sum, mut n) = (0.0, 0u32);
    for v in values {
        if !(v > 0.0 && v.is_finite()) {
            return None;
        }
        sum += v.ln();
        n += 1;
    }
    (n > 0).then(|| (sum / n as f64).exp())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_plan_runs_each_variant_once() {
        let v = Plan::default().variants(64).unwrap();
        let names: Vec<String> = v.iter().map(Variant::name).collect();
        assert_eq!(names[0], "RB_8@64KB");
        // 14 paper configurations, RB_1, RB_1 and RB_32 with SMS, and 4 other L1D sizes × 2.
        assert_eq!(v.len(), 14 + 3 + 8);
        for (i, n) in names.iter().enumerate() {
            assert!(!names[i + 1..].contains(n), "{n} twice");
        }
        assert!(names.contains(&"RB_8+SH_8+SK+RA@16KB".to_string()));
    }

    #[test]
    fn a_plan_whose_stacks_fill_the_array_is_refused() {
        let plan = Plan { configs: vec![], rb_sizes: vec![], l1d_kb: vec![8] };
        assert!(plan.variants(64).is_err(), "SMS needs 8 KB of SH: nothing left of 8 KB");
    }

    #[test]
    fn geomean_of_known_values() {
        assert_eq!(geomean([1.0, 1.0]), Some(1.0));
        assert!((geomean([2.0, 8.0]).unwrap() - 4.0).abs() < 1e-12);
        assert_eq!(geomean([]), None);
        assert_eq!(geomean([1.0, 0.0]), None);
    }
}
