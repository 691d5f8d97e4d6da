//! `sms bench`'s measurements: what each way of running the model costs in time and in error,
//! measured in one process on one machine.
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
//! The data, its headline metrics and the choice of setting are in [`data`]; they are drawn by
//! [`crate::report::bench`]. Times include tracing the rays on demand, not building the BVH.

pub mod data;

use std::collections::BTreeMap;
use std::hint::black_box;
use std::time::{Duration, Instant};

use rtl::config::Config;
use rtl::trace::{NullSink, Sink};

use crate::error::{Error, Result};
use crate::run::bench::data::{
    Errors, Report, Row, Sample, Saving, SceneInfo, Setting, Throughput, Values, Work, BASELINE,
};
use crate::run::functional;
use crate::run::sampling::{SampleMode, SamplePlan};
use crate::run::sim::{
    simulate, simulate_all, simulate_sampled, Fidelity, Hardware, Metric, Outcome, RunSpec,
};
use crate::workload::bvh::{Bvh, BvhKind};
use crate::workload::geometry::Ray;
use crate::workload::scene::Scene;
use crate::workload::trace::{FetchKind, TraceOp};
use crate::workload::traverse::{trace, ChildOrder};
use crate::workload::{Workload, WorkloadOpts};

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
        *configs.iter().find(|c| c.realloc().is_some()).unwrap_or(&configs[configs.len() - 1])
    }
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
fn time_plain(bvh: &Bvh, scene: &Scene, rays: &[Ray], order: ChildOrder) -> f64 {
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
            let plan = setting.sample.map(|sample| SamplePlan {
                fraction: sample.fraction,
                mode: sample.mode,
                batches: opts.batches,
                seed: opts.sample_seed,
            });
            // A sample of every warp is the full run.
            let (values, wall, ci, warps) = match plan.filter(|p| !p.every_warp()) {
                None => {
                    let o = simulate_all(&s, &w)?;
                    if setting == Setting::FULL_CYCLE {
                        truth.insert(config.name(), o);
                    }
                    (Values::of_outcome(&o), secs(o.wall), None, o.pixel_warps)
                }
                Some(plan) => {
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
    no_skip.hw.idle_skip = false;
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

    for &config in configs.iter().filter(|c| c.realloc().is_none()) {
        let time = |fast| {
            let t = Instant::now();
            functional::run_with(config, w.warps(), fast).map(|r| (r, secs(t.elapsed())))
        };
        let err = |e: functional::FunctionalError| crate::run::sim::functional_failure(&config, e);
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
