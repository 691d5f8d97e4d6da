//! `sms bench`'s data: the settings it times, the errors it measures against the full
//! cycle-level run, and the choice of the fastest setting within a tolerance. The measurements
//! are taken by [`crate::run::bench`]; the tables, files and plot are drawn by
//! [`crate::report::bench`].
//!
//! Headline metrics (SPEC section 8): performance normalised to RB_8 (RB_8's cycles over the
//! configuration's, both from the same setting), stack entries moved off chip, and bank-conflict
//! delay cycles. A setting that does not measure a headline metric (the functional level has no
//! cycles) cannot qualify on it. Times include tracing the rays on demand, not building the BVH.

use std::fmt;

use serde::Serialize;

use crate::run::sampling::SampleMode;
use crate::run::sim::{Fidelity, Metric, Outcome, Sampled};
use crate::workload::WorkloadOpts;

/// The baseline every cycle count is normalised to, and the RB size "never overflows" refers to.
pub use crate::run::sweep::BASELINE;

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
pub(crate) fn worse(a: f64, b: f64) -> f64 {
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
pub(crate) fn by_setting(rows: &[Row]) -> Vec<(Setting, Vec<&Row>)> {
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

#[derive(Clone, Debug, Default, Serialize)]
pub struct Report {
    pub rows: Vec<Row>,
    pub throughput: Vec<Throughput>,
    pub work: Vec<Work>,
    pub savings: Vec<Saving>,
    pub scenes: Vec<SceneInfo>,
    /// Peak resident memory of the whole bench, bytes (Linux `VmHWM`; `None` elsewhere).
    pub peak_rss: Option<u64>,
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
