//! `sms bench`: what each way of running the model costs in time and in error, measured in one
//! process on one machine.
//!
//! ```text
//!   per scene: Workload ──► full cycle-level run of every configuration  (the truth)
//!                 │    └──► every Setting (level × sample) ──► Row { time, relative errors }
//!                 ├──► plain traversals of the same rays (our BVH6, obvhs CWBVH) ──► Throughput
//!                 └──► the same runs with work skipped and not skipped ──────────► Saving
//!   all rows ──► fastest_within(tolerance): the cheapest setting whose every headline error,
//!                in every scene and configuration, is within the tolerance
//! ```
//!
//! Headline metrics (SPEC section 8): performance normalised to RB_8 (RB_8's cycles over the
//! configuration's, both from the same setting), stack entries moved off chip, and bank-conflict
//! delay cycles. A setting that does not measure a headline metric (the functional level has no
//! cycles) cannot qualify on it. Times include tracing the rays on demand, not building the BVH.

use std::collections::BTreeMap;
use std::fmt;
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use rtl::config::Config;
use rtl::trace::{NullSink, Sink};
use serde::Serialize;

use crate::error::{Error, Result};
use crate::report::plot::{log_scatter, LabelledPoints};
use crate::report::table::Table;
use crate::run::functional;
use crate::run::sampling::{SampleMode, SamplePlan};
use crate::run::sim::{
    simulate, simulate_all, simulate_sampled, Fidelity, Hardware, Metric, Outcome, RunSpec, Sampled,
};
use crate::workload::bvh::{Bvh, BvhKind};
use crate::workload::geometry::Ray;
use crate::workload::scene::Scene;
use crate::workload::trace::{FetchKind, TraceOp};
use crate::workload::traverse::trace;
use crate::workload::{Workload, WorkloadOpts};

/// The baseline every cycle count is normalised to, and the RB size "never overflows" refers to.
pub const BASELINE: &str = "RB_8";

/// A sampled run's share of the warps and how they are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Sample {
    pub fraction: f64,
    pub mode: SampleMode,
}

/// One way of running the model: a level of detail, on all warps or on a sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Setting {
    pub fidelity: Fidelity,
    /// `None`: every warp in one run.
    pub sample: Option<Sample>,
}

impl Setting {
    pub const FULL_CYCLE: Setting = Setting { fidelity: Fidelity::Cycle, sample: None };
}

impl fmt::Display for Setting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let level = match self.fidelity {
            Fidelity::Cycle => "cycle",
            Fidelity::Functional => "functional",
        };
        match self.sample {
            None => write!(f, "{level} full"),
            Some(s) => {
                let mode = match s.mode {
                    SampleMode::Random => "random",
                    SampleMode::Tile => "tile",
                };
                write!(f, "{level} {} {mode}", s.fraction)
            }
        }
    }
}

/// A run's totals over the workload (estimates when sampled); `None` where the level does not
/// measure the metric.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Values {
    pub cycles: Option<f64>,
    pub stack_global: f64,
    pub dram_stack: Option<f64>,
    pub conflict_cycles: Option<f64>,
}

impl Values {
    pub fn of_outcome(o: &Outcome) -> Values {
        Values {
            cycles: Metric::Cycles.of(o),
            stack_global: o.stack.global_accesses() as f64,
            dram_stack: Metric::DramStack.of(o),
            conflict_cycles: Metric::ConflictCycles.of(o),
        }
    }

    pub fn of_sampled(s: &Sampled) -> Values {
        let get = |m| s.get(m).map(|e| e.value);
        Values {
            cycles: get(Metric::Cycles),
            stack_global: get(Metric::StackGlobal).unwrap_or(0.0),
            dram_stack: get(Metric::DramStack),
            conflict_cycles: get(Metric::ConflictCycles),
        }
    }
}

/// The headline metrics a setting must get right.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Headline {
    /// RB_8's cycles over the configuration's (performance normalised to RB_8).
    NormCycles,
    /// Stack entries moved to or from global memory.
    StackGlobal,
    /// Shared-memory bank-conflict delay cycles.
    ConflictCycles,
}

impl Headline {
    pub const ALL: [Headline; 3] = [Headline::NormCycles, Headline::StackGlobal, Headline::ConflictCycles];

    pub fn name(self) -> &'static str {
        match self {
            Headline::NormCycles => "perf vs RB_8",
            Headline::StackGlobal => "off-chip stack",
            Headline::ConflictCycles => "conflict cycles",
        }
    }
}

/// |got − truth| / |truth|; a zero truth is matched exactly or infinitely wrong.
pub fn relative_error(got: f64, truth: f64) -> f64 {
    if truth == 0.0 {
        if got == 0.0 {
            0.0
        } else {
            f64::INFINITY
        }
    } else {
        (got - truth).abs() / truth.abs()
    }
}

/// The larger error; NaN (a broken measurement) wins, where `f64::max` would drop it.
fn worse(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Relative errors of a row against the full cycle-level run; `None`: not measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Errors {
    pub norm_cycles: Option<f64>,
    pub stack_global: Option<f64>,
    pub conflict_cycles: Option<f64>,
    /// Total cycles, not normalised (information: sampling biases it).
    pub cycles: Option<f64>,
    /// DRAM accesses of stack traffic (information).
    pub dram_stack: Option<f64>,
}

impl Errors {
    /// `got` and `got_base` (RB_8) come from the same setting, `truth` and `truth_base` from the
    /// full cycle-level runs.
    pub fn compute(got: &Values, got_base: &Values, truth: &Values, truth_base: &Values) -> Errors {
        let pair = |a: Option<f64>, b: Option<f64>| Some(relative_error(a?, b?));
        let speedup = |v: &Values, base: &Values| Some(base.cycles? / v.cycles?);
        Errors {
            norm_cycles: pair(speedup(got, got_base), speedup(truth, truth_base)),
            stack_global: Some(relative_error(got.stack_global, truth.stack_global)),
            conflict_cycles: pair(got.conflict_cycles, truth.conflict_cycles),
            cycles: pair(got.cycles, truth.cycles),
            dram_stack: pair(got.dram_stack, truth.dram_stack),
        }
    }

    pub fn get(&self, h: Headline) -> Option<f64> {
        match h {
            Headline::NormCycles => self.norm_cycles,
            Headline::StackGlobal => self.stack_global,
            Headline::ConflictCycles => self.conflict_cycles,
        }
    }

    /// The worst of the `which` errors; `None` if one is not measured, NaN if one is NaN.
    pub fn worst(&self, which: &[Headline]) -> Option<f64> {
        which.iter().map(|&h| self.get(h)).try_fold(0.0, |w, e| Some(worse(w, e?)))
    }
}

/// One setting of one configuration on one scene.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    pub scene: String,
    pub config: String,
    pub setting: Setting,
    /// Pixel warps simulated.
    pub pixel_warps: u32,
    /// Seconds.
    pub wall: f64,
    pub values: Values,
    pub errors: Errors,
    /// Largest 95 % half width of the headline estimates, relative (sampled settings).
    pub ci: Option<f64>,
}

/// The setting [`fastest_within`] picked.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Choice {
    pub setting: Setting,
    /// Seconds, summed over every scene and configuration.
    pub wall: f64,
    /// Its worst error over those rows and the metrics asked for.
    pub worst: f64,
}

/// Rows grouped by setting, in first-appearance order.
fn by_setting(rows: &[Row]) -> Vec<(Setting, Vec<&Row>)> {
    let mut groups: Vec<(Setting, Vec<&Row>)> = Vec::new();
    for r in rows {
        match groups.iter_mut().find(|(s, _)| *s == r.setting) {
            Some((_, g)) => g.push(r),
            None => groups.push((r.setting, vec![r])),
        }
    }
    groups
}

/// The (scene, configuration) pairs `rows` cover, sorted.
fn cases<'r>(rows: impl IntoIterator<Item = &'r Row>) -> Vec<(&'r str, &'r str)> {
    let mut c: Vec<_> = rows.into_iter().map(|r| (r.scene.as_str(), r.config.as_str())).collect();
    c.sort_unstable();
    c.dedup();
    c
}

/// The fastest setting whose every `which` error is at most `tolerance` in every (scene,
/// configuration) the rows cover. A setting missing a case, or not measuring a metric, fails.
pub fn fastest_within(rows: &[Row], tolerance: f64, which: &[Headline]) -> Option<Choice> {
    let all = cases(rows);
    by_setting(rows)
        .into_iter()
        .filter(|(_, rs)| cases(rs.iter().copied()) == all)
        .filter_map(|(setting, rs)| {
            let worst = rs.iter().map(|r| r.errors.worst(which)).try_fold(0.0, |w, e| Some(worse(w, e?)))?;
            // NaN fails this comparison too.
            (worst <= tolerance).then(|| Choice { setting, wall: rs.iter().map(|r| r.wall).sum(), worst })
        })
        .min_by(|a, b| a.wall.total_cmp(&b.wall))
}

/// Run time of the full model against plain traversals of the same rays.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Throughput {
    pub scene: String,
    pub config: String,
    pub rays: u64,
    pub cycles: u64,
    pub evaluated_cycles: u64,
    pub stack_ops: u64,
    /// Seconds of the full cycle-level run (tracing the rays included).
    pub wall: f64,
    /// Seconds of one closest-hit pass over the same rays with our BVH6 traversal, not recording.
    pub plain_bvh6: f64,
    /// Seconds of one pass of obvhs's own CWBVH traversal over the same rays.
    pub obvhs_cwbvh: f64,
}

impl Throughput {
    pub fn cycles_per_sec(&self) -> f64 {
        self.cycles as f64 / self.wall
    }
    pub fn stack_ops_per_sec(&self) -> f64 {
        self.stack_ops as f64 / self.wall
    }
    /// How many obvhs traversals of the rays fit in one full cycle-level run.
    pub fn vs_obvhs(&self) -> f64 {
        self.wall / self.obvhs_cwbvh
    }
}

/// What a scene's traversals do, by node kind, and how deep they go.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Work {
    pub scene: String,
    pub triangles: usize,
    pub rays: u64,
    pub max_depth: u32,
    /// Rays whose stack never holds more than RB_8's 8 entries: they never leave the RB.
    pub rays_within_rb8: u64,
    pub internal: u64,
    pub leaf: u64,
    pub triangle: u64,
    pub procedural: u64,
    /// Instance leaves and acceleration-structure headers (two-level only).
    #[serde(skip_serializing_if = "is_zero")]
    pub instance: u64,
    #[serde(skip_serializing_if = "is_zero")]
    pub header: u64,
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

/// A piece of work the model skips when a run does not need it, timed both ways.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Saving {
    pub scene: String,
    pub what: String,
    /// Seconds doing the work.
    pub with_work: f64,
    /// Seconds skipping it.
    pub skipped: f64,
    /// Whether the results agree, and anything else worth knowing.
    pub note: String,
}

/// A waveform sink that is on but keeps nothing: the probe walk's own cost.
#[derive(Clone, Copy, Debug, Default)]
pub struct DiscardSink {
    pub signals: u64,
}

impl Sink for DiscardSink {
    fn enabled(&self) -> bool {
        true
    }
    fn push_scope(&mut self, _: &str) {}
    fn pop_scope(&mut self) {}
    fn signal(&mut self, _: &str, _: u32, value: u64) {
        self.signals += 1;
        black_box(value);
    }
}

/// What to measure.
#[derive(Clone, Debug)]
pub struct BenchOpts {
    /// Configurations; [`BASELINE`] is added first if missing.
    pub configs: Vec<Config>,
    pub fractions: Vec<f64>,
    pub modes: Vec<SampleMode>,
    pub batches: u32,
    pub sample_seed: u64,
    pub hw: Hardware,
    /// Bounces added for the "more bounces" comparison.
    pub more_bounces: u32,
}

impl BenchOpts {
    /// The settings timed, full cycle level first.
    pub fn settings(&self) -> Vec<Setting> {
        let mut out = Vec::new();
        for fidelity in [Fidelity::Cycle, Fidelity::Functional] {
            out.push(Setting { fidelity, sample: None });
            for &fraction in &self.fractions {
                for &mode in &self.modes {
                    out.push(Setting { fidelity, sample: Some(Sample { fraction, mode }) });
                }
            }
        }
        out
    }

    fn configs(&self) -> Result<Vec<Config>> {
        let base: Config = BASELINE.parse().map_err(|e| Error::Invalid(format!("{e}")))?;
        let mut out = vec![base];
        out.extend(self.configs.iter().filter(|c| **c != base));
        Ok(out)
    }

    /// The configuration the savings are measured on: the first with reallocation, else the last.
    fn focus(configs: &[Config]) -> Config {
        *configs.iter().find(|c| c.realloc.is_some()).unwrap_or(&configs[configs.len() - 1])
    }
}

/// Everything one `sms bench` measured.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    pub rows: Vec<Row>,
    pub throughput: Vec<Throughput>,
    pub work: Vec<Work>,
    pub savings: Vec<Saving>,
    pub scenes: Vec<SceneInfo>,
}

/// A scene's workload as benchmarked.
#[derive(Clone, Debug, Serialize)]
pub struct SceneInfo {
    pub scene: String,
    pub opts: WorkloadOpts,
    pub pixel_warps: u32,
    pub rays: u64,
    /// Seconds building the BVH and rendering (not in any row).
    pub build: f64,
}

fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}

/// Seconds of the fastest of at least 3 passes of `f`, repeated for at least 0.2 s.
fn best_of(mut f: impl FnMut()) -> f64 {
    let (start, mut best, mut passes) = (Instant::now(), f64::INFINITY, 0);
    while passes < 3 || start.elapsed() < Duration::from_millis(200) {
        let t = Instant::now();
        f();
        best = best.min(secs(t.elapsed()));
        passes += 1;
    }
    best
}

/// One closest-hit pass over `rays` with our traversal of `bvh`, recording nothing.
fn time_plain(bvh: &Bvh, scene: &Scene, rays: &[Ray], order: crate::workload::traverse::ChildOrder) -> f64 {
    best_of(|| {
        let hits =
            rays.iter().filter(|r| trace(bvh, &scene.primitives, r, f32::INFINITY, order, &mut ()).is_some());
        black_box(hits.count());
    })
}

/// One pass of obvhs's own CWBVH traversal over `rays` with the same primitive test.
fn time_obvhs(scene: &Scene, rays: &[Ray]) -> Result<f64> {
    let Bvh::Cwbvh(cw) = Bvh::build(&scene.primitives, BvhKind::Cwbvh)? else {
        unreachable!("Bvh::build returns the kind asked for")
    };
    let prims = &scene.primitives;
    Ok(best_of(|| {
        let mut hits = 0u32;
        for ray in rays {
            let mut hit = obvhs::ray::RayHit::none();
            let test = |r: &obvhs::ray::Ray, slot: usize| {
                prims.hit(cw.primitive_indices[slot] as usize, ray, r.tmax)
            };
            hits += u32::from(cw.ray_traverse(ray.to_obvhs(f32::INFINITY), &mut hit, test));
        }
        black_box(hits);
    }))
}

/// Throughput of full cycle-level runs of `w` (one per configuration) against plain traversals
/// of the same rays, timed now.
pub fn throughput(scene: &Scene, w: &Workload, runs: &[(Config, Outcome)]) -> Result<Vec<Throughput>> {
    let rays = w.rays();
    let plain = time_plain(w.bvh(), scene, &rays, w.opts().order);
    let obvhs = time_obvhs(scene, &rays)?;
    Ok(runs
        .iter()
        .map(|(config, o)| {
            let g = o.gpu.unwrap_or_default();
            Throughput {
                scene: scene.name.clone(),
                config: config.name(),
                rays: rays.len() as u64,
                cycles: g.cycles,
                evaluated_cycles: g.evaluated_cycles,
                stack_ops: o.stack.pushes + o.stack.pops,
                wall: secs(o.wall),
                plain_bvh6: plain,
                obvhs_cwbvh: obvhs,
            }
        })
        .collect())
}

/// Visits by kind and stack depths of every ray of `w`.
fn work(scene: &Scene, w: &Workload) -> Work {
    let limit = 8; // RB_8 entries
    let mut out =
        Work { scene: scene.name.clone(), triangles: scene.primitives.triangle_count(), ..Work::default() };
    for jobs in w.warps() {
        for t in jobs.iter().flat_map(|j| j.lanes.iter().flatten()) {
            out.rays += 1;
            out.max_depth = out.max_depth.max(t.max_depth());
            out.rays_within_rb8 += u64::from(t.max_depth() <= limit);
            for op in t.ops() {
                if let TraceOp::Visit { kind, .. } = op {
                    *match kind {
                        FetchKind::Internal => &mut out.internal,
                        FetchKind::Leaf => &mut out.leaf,
                        FetchKind::Triangle => &mut out.triangle,
                        FetchKind::Procedural => &mut out.procedural,
                        FetchKind::Instance => &mut out.instance,
                        FetchKind::BvhHeader => &mut out.header,
                    } += 1;
                }
            }
        }
    }
    out
}

/// The outcome without its timings, for comparing runs that must agree.
fn results(o: &Outcome) -> Outcome {
    let mut o = *o;
    o.wall = Duration::ZERO;
    if let Some(g) = o.gpu.as_mut() {
        g.evaluated_cycles = 0;
    }
    o
}

fn agree(a: &Outcome, b: &Outcome) -> &'static str {
    if results(a) == results(b) {
        "identical results"
    } else {
        "RESULTS DIFFER"
    }
}

/// Measures one scene; `log` hears about every run.
pub fn bench_scene(
    scene: &Scene,
    wopts: WorkloadOpts,
    opts: &BenchOpts,
    report: &mut Report,
    log: &mut dyn FnMut(String),
) -> Result<()> {
    let configs = opts.configs()?;
    let (w, build) = {
        let t = Instant::now();
        (Workload::new(scene, wopts)?, secs(t.elapsed()))
    };
    let info = SceneInfo {
        scene: scene.name.clone(),
        opts: wopts,
        pixel_warps: w.num_warps(),
        rays: w.num_rays(),
        build,
    };
    log(info.to_string());
    report.scenes.push(info);
    let spec = |config: Config, fidelity| RunSpec { config, hw: opts.hw, fidelity };

    // Every setting of every configuration, then the errors (they need RB_8's value alike).
    let mut runs: Vec<(Config, Setting, Values, f64, Option<f64>, u32)> = Vec::new();
    let mut truth: BTreeMap<String, Outcome> = BTreeMap::new();
    for setting in opts.settings() {
        for &config in &configs {
            let s = spec(config, setting.fidelity);
            let (values, wall, ci, warps) = match setting.sample {
                None => {
                    let o = simulate_all(&s, &w)?;
                    if setting == Setting::FULL_CYCLE {
                        truth.insert(config.name(), o);
                    }
                    (Values::of_outcome(&o), secs(o.wall), None, o.pixel_warps)
                }
                Some(sample) => {
                    let plan = SamplePlan {
                        fraction: sample.fraction,
                        mode: sample.mode,
                        batches: opts.batches,
                        seed: opts.sample_seed,
                    };
                    let sampled = simulate_sampled(&s, &w, &plan, |_| {})?;
                    let ci = [Metric::Cycles, Metric::StackGlobal, Metric::ConflictCycles]
                        .into_iter()
                        .filter_map(|m| sampled.get(m).map(|e| e.relative()))
                        .fold(None, |a: Option<f64>, r| Some(a.map_or(r, |a| a.max(r))));
                    let warps = sampled.batches.iter().map(|b| b.pixel_warps).sum();
                    (Values::of_sampled(&sampled), secs(sampled.wall), ci, warps)
                }
            };
            log(format!("  {:<16} {:<22} {:>7.2} s", config.name(), setting.to_string(), wall));
            runs.push((config, setting, values, wall, ci, warps));
        }
    }
    let value_of = |config: &Config, setting: Setting| {
        runs.iter().find(|r| r.0 == *config && r.1 == setting).map(|r| r.2).unwrap_or_default()
    };
    let base = configs[0];
    for (config, setting, values, wall, ci, pixel_warps) in &runs {
        let errors = Errors::compute(
            values,
            &value_of(&base, *setting),
            &value_of(config, Setting::FULL_CYCLE),
            &value_of(&base, Setting::FULL_CYCLE),
        );
        report.rows.push(Row {
            scene: scene.name.clone(),
            config: config.name(),
            setting: *setting,
            pixel_warps: *pixel_warps,
            wall: *wall,
            values: *values,
            errors,
            ci: *ci,
        });
    }

    let full: Vec<(Config, Outcome)> = configs.iter().map(|c| (*c, truth[&c.name()])).collect();
    report.throughput.extend(throughput(scene, &w, &full)?);
    report.work.push(work(scene, &w));

    // Savings, on the focus configuration.
    let focus = BenchOpts::focus(&configs);
    let on = &truth[&focus.name()];
    let name = focus.name();
    let mut no_skip = spec(focus, Fidelity::Cycle);
    no_skip.hw.rt.idle_skip = false;
    let off = simulate(&no_skip, &w, None, &mut NullSink, |_| {})?;
    let evaluated = on.gpu.map_or(0.0, |g| g.evaluated_cycles as f64 / g.cycles.max(1) as f64);
    report.savings.push(Saving {
        scene: scene.name.clone(),
        what: format!("idle-cycle skipping, {name}"),
        with_work: secs(off.wall),
        skipped: secs(on.wall),
        note: format!("{}; {:.1} % of cycles evaluated", agree(on, &off), 100.0 * evaluated),
    });
    log(format!("  idle skipping off {:.2} s, on {:.2} s", secs(off.wall), secs(on.wall)));
    // The probe walk is slow: time it on every eighth warp, both ways.
    let sample: Vec<u32> = (0..w.num_warps()).step_by(8).collect();
    let quiet = simulate(&no_skip, &w, Some(&sample), &mut NullSink, |_| {})?;
    let mut sink = DiscardSink::default();
    let probed = simulate(&no_skip, &w, Some(&sample), &mut sink, |_| {})?;
    report.savings.push(Saving {
        scene: scene.name.clone(),
        what: format!("probe walk: sink on but discarding vs NullSink, {name}, no skipping"),
        with_work: secs(probed.wall),
        skipped: secs(quiet.wall),
        note: format!(
            "{}; every 8th warp ({} of {}), {} signal values walked",
            agree(&probed, &quiet),
            sample.len(),
            w.num_warps(),
            sink.signals
        ),
    });
    log(format!("  probe walk {:.2} s, NullSink {:.2} s", secs(probed.wall), secs(quiet.wall)));

    let more = WorkloadOpts { max_bounces: wopts.max_bounces + opts.more_bounces, ..wopts };
    let t = Instant::now();
    let w_more = Workload::new(scene, more)?;
    let o_more = simulate_all(&spec(focus, Fidelity::Cycle), &w_more)?;
    let more_wall = secs(t.elapsed());
    report.savings.push(Saving {
        scene: scene.name.clone(),
        what: format!("bounces: {} as configured vs {}, {name}", wopts.max_bounces, more.max_bounces),
        with_work: more_wall,
        skipped: build + secs(on.wall),
        note: format!(
            "{} vs {} rays, {} vs {} GPU cycles (workload build included)",
            w.num_rays(),
            w_more.num_rays(),
            on.gpu.map_or(0, |g| g.cycles),
            o_more.gpu.map_or(0, |g| g.cycles)
        ),
    });
    log(format!("  {} bounces {more_wall:.2} s", more.max_bounces));

    for &config in configs.iter().filter(|c| c.realloc.is_none()) {
        let time = |fast| {
            let t = Instant::now();
            functional::run_with(config, w.warps(), fast).map(|r| (r, secs(t.elapsed())))
        };
        let err = |e: functional::FunctionalError| Error::Invalid(format!("{}: {e}", config.name()));
        let (full, full_wall) = time(false).map_err(err)?;
        let (fast, fast_wall) = time(true).map_err(err)?;
        let same = if fast.total == full.total { "identical counts" } else { "COUNTS DIFFER" };
        report.savings.push(Saving {
            scene: scene.name.clone(),
            what: format!("functional fast path for rays within the RB, {}", config.name()),
            with_work: full_wall,
            skipped: fast_wall,
            note: format!("{same}; {} of {} rays fast", fast.rays_fast, w.num_rays()),
        });
    }
    Ok(())
}

impl fmt::Display for SceneInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let o = &self.opts;
        write!(
            f,
            "{}: {}x{}, {} spp, {} bounces, {:?}, {} pixel warps, {} rays; workload built in {:.2} s",
            self.scene,
            o.width,
            o.height,
            o.spp,
            o.max_bounces,
            o.bvh,
            self.pixel_warps,
            self.rays,
            self.build
        )
    }
}

fn pct(e: Option<f64>) -> String {
    match e {
        None => "n/a".into(),
        Some(e) if e.is_infinite() => "inf".into(),
        Some(e) => format!("{:.2}%", e * 100.0),
    }
}

impl Report {
    /// Full cycle-level time of each (scene, configuration).
    fn truth_wall(&self, scene: &str, config: &str) -> f64 {
        self.rows
            .iter()
            .find(|r| r.scene == scene && r.config == config && r.setting == Setting::FULL_CYCLE)
            .map_or(f64::NAN, |r| r.wall)
    }

    /// One row per scene, configuration and setting.
    pub fn rows_table(&self) -> Table {
        let mut t = Table::new([
            "scene",
            "config",
            "setting",
            "warps",
            "time s",
            "faster",
            "err perf",
            "err off-chip",
            "err conflicts",
            "err cycles",
            "err dram stack",
            "±95%",
        ]);
        for r in &self.rows {
            let e = &r.errors;
            t.row([
                r.scene.clone(),
                r.config.clone(),
                r.setting.to_string(),
                r.pixel_warps.to_string(),
                format!("{:.3}", r.wall),
                format!("{:.1}x", self.truth_wall(&r.scene, &r.config) / r.wall),
                pct(e.norm_cycles),
                pct(e.stack_global),
                pct(e.conflict_cycles),
                pct(e.cycles),
                pct(e.dram_stack),
                r.ci.map_or(String::new(), |c| pct(Some(c))),
            ]);
        }
        t
    }

    /// One row per setting: total time and worst errors over every scene and configuration.
    pub fn summary_table(&self, tolerance: f64) -> Table {
        let mut t = Table::new([
            "setting",
            "time s",
            "faster",
            "worst perf",
            "worst off-chip",
            "worst conflicts",
            "worst cycles",
            "all within",
        ]);
        let full: f64 = self.rows.iter().filter(|r| r.setting == Setting::FULL_CYCLE).map(|r| r.wall).sum();
        for (setting, rs) in by_setting(&self.rows) {
            let wall: f64 = rs.iter().map(|r| r.wall).sum();
            let worst = |f: fn(&Errors) -> Option<f64>| {
                rs.iter().map(|r| f(&r.errors)).try_fold(0.0, |w, e| Some(worse(w, e?)))
            };
            let ok = rs.iter().all(|r| r.errors.worst(&Headline::ALL).is_some_and(|w| w <= tolerance));
            t.row([
                setting.to_string(),
                format!("{wall:.3}"),
                format!("{:.1}x", full / wall),
                pct(worst(|e| e.norm_cycles)),
                pct(worst(|e| e.stack_global)),
                pct(worst(|e| e.conflict_cycles)),
                pct(worst(|e| e.cycles)),
                if ok { format!("yes ({}%)", tolerance * 100.0) } else { "no".into() },
            ]);
        }
        t
    }

    pub fn throughput_table(&self) -> Table {
        let mut t = Table::new([
            "scene",
            "config",
            "rays",
            "GPU cycles",
            "run s",
            "cycles/s",
            "evaluated/s",
            "stack ops/s",
            "BVH6 plain s",
            "obvhs CWBVH s",
            "run / obvhs",
        ]);
        for p in &self.throughput {
            t.row([
                p.scene.clone(),
                p.config.clone(),
                p.rays.to_string(),
                p.cycles.to_string(),
                format!("{:.3}", p.wall),
                format!("{:.0}", p.cycles_per_sec()),
                format!("{:.0}", p.evaluated_cycles as f64 / p.wall),
                format!("{:.0}", p.stack_ops_per_sec()),
                format!("{:.4}", p.plain_bvh6),
                format!("{:.4}", p.obvhs_cwbvh),
                format!("{:.0}x", p.vs_obvhs()),
            ]);
        }
        t
    }

    pub fn work_table(&self) -> Table {
        let mut t = Table::new([
            "scene",
            "triangles",
            "rays",
            "max depth",
            "rays ≤ 8 deep",
            "internal visits",
            "leaf visits",
            "triangle visits",
            "procedural visits",
        ]);
        for w in &self.work {
            t.row([
                w.scene.clone(),
                w.triangles.to_string(),
                w.rays.to_string(),
                w.max_depth.to_string(),
                format!(
                    "{} ({:.1}%)",
                    w.rays_within_rb8,
                    100.0 * w.rays_within_rb8 as f64 / w.rays.max(1) as f64
                ),
                w.internal.to_string(),
                w.leaf.to_string(),
                w.triangle.to_string(),
                w.procedural.to_string(),
            ]);
        }
        t
    }

    pub fn savings_table(&self) -> Table {
        let mut t = Table::new(["scene", "work skipped", "doing it s", "skipping s", "saving", "result"]);
        for s in &self.savings {
            t.row([
                s.scene.clone(),
                s.what.clone(),
                format!("{:.3}", s.with_work),
                format!("{:.3}", s.skipped),
                format!("{:.2}x", s.with_work / s.skipped),
                s.note.clone(),
            ]);
        }
        t
    }

    /// The verdict lines: the fastest setting within `tolerance` on every headline metric, then on
    /// each alone.
    pub fn verdict(&self, tolerance: f64) -> String {
        let full: f64 = self.rows.iter().filter(|r| r.setting == Setting::FULL_CYCLE).map(|r| r.wall).sum();
        let line = |which: &[Headline], what: String| {
            match fastest_within(&self.rows, tolerance, which) {
            Some(c) => format!(
                "fastest within {}% on {what}: {} ({:.3} s against {:.3} s for the full cycle level, {:.1}x faster; worst error {:.2}%)\n",
                tolerance * 100.0,
                c.setting,
                c.wall,
                full,
                full / c.wall,
                c.worst * 100.0
            ),
            None => format!("no setting is within {}% on {what}\n", tolerance * 100.0),
        }
        };
        let mut out = line(&Headline::ALL, "every headline metric (all scenes and configurations)".into());
        for h in Headline::ALL {
            out += &line(&[h], format!("{} alone", h.name()));
        }
        // Reallocation makes the functional level's counts differ from the cycle level's.
        let functional = Setting { fidelity: Fidelity::Functional, sample: None };
        let ra = self.rows.iter().filter(|r| r.setting == functional && r.config.ends_with("+RA"));
        let worst = ra.map(|r| r.errors.stack_global.unwrap_or(f64::NAN)).reduce(worse);
        if let Some(e) = worst {
            out += &format!(
                "functional level with reallocation (all warps): off-chip stack error {} at worst\n",
                pct(Some(e))
            );
        }
        out
    }

    /// The terminal and Markdown reports.
    pub fn text(&self, tolerance: f64, markdown: bool) -> String {
        let render = |t: Table| if markdown { t.to_markdown() } else { t.to_text() };
        let heading = |s: &str| if markdown { format!("\n## {s}\n\n") } else { format!("\n{s}\n") };
        let mut out = String::new();
        out += &heading("Workloads");
        for info in &self.scenes {
            out += &format!("{}{info}\n", if markdown { "- " } else { "" });
        }
        out += &heading("Run time against error (errors relative to the full cycle-level run)");
        out += "err = |value − full cycle-level value| / full cycle-level value, on workload totals \
                (sampled: estimates); perf = RB_8's cycles / the configuration's, both from the same \
                setting; n/a = not measured at that level; ±95% = widest relative 95 % interval of the \
                sampled estimates; time includes tracing the rays, not building the BVH.\n";
        if markdown {
            out += "\n";
        }
        out += &render(self.rows_table());
        out += &heading("Per setting, over every scene and configuration");
        out += &render(self.summary_table(tolerance));
        out += "\n";
        out += &self.verdict(tolerance);
        out += &heading("Throughput of the full cycle-level model");
        out += &render(self.throughput_table());
        out += &heading("Work by kind and stack depth");
        out += &render(self.work_table());
        out += &heading("Savings of skipping work a run does not need");
        out += &render(self.savings_table());
        out
    }

    /// Time against worst headline error per setting (functional: the metrics it measures).
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        const FLOOR: f64 = 1e-4;
        let points: Vec<(Setting, f64, f64)> = by_setting(&self.rows)
            .into_iter()
            .map(|(s, rs)| {
                let measured: Vec<Headline> = Headline::ALL
                    .into_iter()
                    .filter(|&h| rs.iter().all(|r| r.errors.get(h).is_some()))
                    .collect();
                let worst = rs.iter().filter_map(|r| r.errors.worst(&measured)).fold(0.0, f64::max);
                let wall: f64 = rs.iter().map(|r| r.wall).sum();
                (s, wall.max(1e-4), (worst * 100.0).clamp(FLOOR, 1e4))
            })
            .collect();
        let series =
            [(Fidelity::Cycle, "cycle level"), (Fidelity::Functional, "functional level (no cycle metrics)")]
                .map(|(fidelity, name)| LabelledPoints {
                    name: name.into(),
                    points: points
                        .iter()
                        .filter(|p| p.0.fidelity == fidelity)
                        .map(|p| (p.1, p.2, p.0.to_string()))
                        .collect(),
                });
        log_scatter(
            path,
            "run time against worst headline error",
            "seconds, all scenes and configurations",
            &format!("worst relative error, % (0 drawn at {FLOOR:e})"),
            FLOOR,
            &series,
            Some((1.0, "1 % tolerance")),
        )
    }

    /// Writes bench.{txt,md,csv,json}, the other tables as CSV and the plot into `dir`.
    pub fn write(&self, dir: &Path, tolerance: f64) -> Result<()> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let write = |name: &str, text: String| {
            let path = dir.join(name);
            std::fs::write(&path, text).map_err(|e| Error::io(&path, e))
        };
        write("bench.txt", self.text(tolerance, false))?;
        write("bench.md", format!("# sms bench\n{}", self.text(tolerance, true)))?;
        write("bench.csv", self.rows_table().to_csv())?;
        write("summary.csv", self.summary_table(tolerance).to_csv())?;
        write("throughput.csv", self.throughput_table().to_csv())?;
        write("work.csv", self.work_table().to_csv())?;
        write("savings.csv", self.savings_table().to_csv())?;
        let json = serde_json::json!({
            "tolerance": tolerance,
            "fastest": fastest_within(&self.rows, tolerance, &Headline::ALL),
            "report": self,
        });
        write("bench.json", serde_json::to_string_pretty(&json).map_err(|e| Error::Invalid(e.to_string()))?)?;
        self.write_svg(&dir.join("time-vs-error.svg"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn values(cycles: f64, global: f64, conflicts: f64) -> Values {
        Values {
            cycles: Some(cycles),
            stack_global: global,
            dram_stack: Some(global / 2.0),
            conflict_cycles: Some(conflicts),
        }
    }

    #[test]
    fn errors_are_relative_to_the_full_cycle_run() {
        // Truth: RB_8 takes 1000 cycles, the configuration 800 (1.25x); sampled: 1100 and 1000 (1.1x).
        let (truth_base, truth) = (values(1000.0, 50.0, 0.0), values(800.0, 20.0, 40.0));
        let (got_base, got) = (values(1100.0, 55.0, 0.0), values(1000.0, 19.0, 42.0));
        let e = Errors::compute(&got, &got_base, &truth, &truth_base);
        assert!((e.norm_cycles.unwrap() - 0.12).abs() < 1e-12, "|1.1 - 1.25| / 1.25");
        assert!((e.cycles.unwrap() - 0.25).abs() < 1e-12, "|1000 - 800| / 800");
        assert!((e.stack_global.unwrap() - 0.05).abs() < 1e-12);
        assert!((e.conflict_cycles.unwrap() - 0.05).abs() < 1e-12);
        assert!((e.dram_stack.unwrap() - 0.05).abs() < 1e-12);
        assert_eq!(e.worst(&Headline::ALL), e.norm_cycles);
        // The baseline against itself: performance is exactly 1, a zero truth matched exactly.
        let b = Errors::compute(&got_base, &got_base, &truth_base, &truth_base);
        assert_eq!((b.norm_cycles, b.conflict_cycles), (Some(0.0), Some(0.0)));
        // The functional level measures no cycles: it cannot qualify on every metric.
        let functional = Values { cycles: None, dram_stack: None, conflict_cycles: None, stack_global: 20.0 };
        let f = Errors::compute(&functional, &functional, &truth, &truth_base);
        assert_eq!((f.norm_cycles, f.stack_global, f.conflict_cycles), (None, Some(0.0), None));
        assert_eq!(f.worst(&Headline::ALL), None);
        assert_eq!(f.worst(&[Headline::StackGlobal]), Some(0.0));
        assert_eq!(relative_error(3.0, 0.0), f64::INFINITY);
    }

    fn row(scene: &str, config: &str, setting: Setting, wall: f64, err: [Option<f64>; 3]) -> Row {
        Row {
            scene: scene.into(),
            config: config.into(),
            setting,
            pixel_warps: 1,
            wall,
            values: Values::default(),
            errors: Errors {
                norm_cycles: err[0],
                stack_global: err[1],
                conflict_cycles: err[2],
                ..Errors::default()
            },
            ci: None,
        }
    }

    #[test]
    fn fastest_within_picks_the_cheapest_setting_that_is_right_everywhere() {
        let sampled =
            |fidelity, fraction, mode| Setting { fidelity, sample: Some(Sample { fraction, mode }) };
        let full = Setting::FULL_CYCLE;
        let half = sampled(Fidelity::Cycle, 0.5, SampleMode::Tile);
        let tenth = sampled(Fidelity::Cycle, 0.1, SampleMode::Random);
        let quarter = sampled(Fidelity::Cycle, 0.25, SampleMode::Random);
        let functional = Setting { fidelity: Fidelity::Functional, sample: None };
        let nan = sampled(Fidelity::Cycle, 0.2, SampleMode::Tile);
        let ok = [Some(0.0), Some(0.0), Some(0.0)];
        let mut rows = Vec::new();
        for (scene, config) in [("a", "RB_8"), ("a", "SMS"), ("b", "RB_8"), ("b", "SMS")] {
            rows.push(row(scene, config, full, 10.0, ok));
            rows.push(row(scene, config, half, 5.0, [Some(0.004), Some(0.009), Some(0.0)]));
            rows.push(row(scene, config, functional, 0.1, [None, Some(0.0), None]));
            // Planted: the fastest cycle setting, right everywhere but one metric in one case.
            let bad = (scene, config) == ("b", "SMS");
            rows.push(row(
                scene,
                config,
                tenth,
                1.0,
                [Some(0.002), Some(if bad { 0.013 } else { 0.0 }), Some(0.0)],
            ));
            rows.push(row(scene, config, nan, 0.5, [Some(f64::NAN), Some(0.0), Some(0.0)]));
            // Fast and exact, but never run on scene b.
            if scene == "a" {
                rows.push(row(scene, config, quarter, 0.2, ok));
            }
        }
        let pick = fastest_within(&rows, 0.01, &Headline::ALL).unwrap();
        assert_eq!(
            pick.setting, half,
            "the planted 1.3 % error, the NaN, the missing metric and the missing case are rejected"
        );
        assert_eq!(pick.wall, 20.0);
        assert_eq!(pick.worst, 0.009);
        // With a looser tolerance the planted row passes and its setting wins.
        assert_eq!(fastest_within(&rows, 0.02, &Headline::ALL).unwrap().setting, tenth);
        // On off-chip stack traffic alone the functional level qualifies and is fastest.
        assert_eq!(fastest_within(&rows, 0.01, &[Headline::StackGlobal]).unwrap().setting, functional);
        // Tight enough that only the truth remains.
        assert_eq!(fastest_within(&rows, 0.0, &Headline::ALL).unwrap().setting, full);
    }
}
