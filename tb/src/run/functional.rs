//! Functional fidelity: stack traffic counted per ray from the traces, no timing.
//!
//! Each pixel warp's jobs run through one stack manager at the functional level (micro-ops
//! complete at once, lanes take turns one command each), every pop checked against the
//! reference. It answers "how many spills, reloads, borrows and flushes" in the least time.
//! Without reallocation every thread's decisions depend on its own history only, so the counts
//! equal the cycle level's exactly; with reallocation, borrowing depends on when lanes finish,
//! and the difference is this level's error (measured by `sms bench`).
//!
//! Fast path ([`run_with`], `shallow_fast_path`): without reallocation, a ray whose stack never
//! holds more than the RB's N entries moves nothing between levels, so its pushes and pops are
//! counted from the trace and the stack manager never sees it. Those pops are not checked
//! against the reference (they are counted in [`FunctionalRun::rays_fast`], not
//! `pops_checked`); the counts equal the full run's exactly (tested).

use crate::run::verify::harness::run_functional_warps;
use crate::run::verify::invariants::Violation;
use rtl::config::{Config, ConfigError};
use rtl::stack_manager::{StackManager, StackStats};

use crate::run::stack_tb::{lane_ops, warp_work};
use crate::workload::trace::{TraceOp, WarpTraces};

/// Stack counts of a whole workload and of each pixel warp.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FunctionalRun {
    pub total: StackStats,
    pub per_warp: Vec<StackStats>,
    pub pops_checked: u64,
    /// Rays counted by the fast path, without the stack manager.
    pub rays_fast: u64,
}

/// Counts pixel warps' stack traffic (each item: the jobs of one pixel warp, in order), every
/// ray through the stack manager.
pub fn run<I>(cfg: Config, warps: I) -> Result<FunctionalRun, FunctionalError>
where
    I: IntoIterator<Item = Vec<WarpTraces>>,
{
    run_with(cfg, warps, false)
}

/// As [`run`]; with `shallow_fast_path` and a configuration without reallocation, rays that fit
/// in the RB are counted from their traces instead.
pub fn run_with<I>(cfg: Config, warps: I, shallow_fast_path: bool) -> Result<FunctionalRun, FunctionalError>
where
    I: IntoIterator<Item = Vec<WarpTraces>>,
{
    // Deepest stack a ray may reach and still never leave the RB (FULL: any).
    let shallow =
        (shallow_fast_path && cfg.realloc().is_none()).then(|| cfg.rb.capacity().unwrap_or(u32::MAX));
    let mut sm = StackManager::new(cfg, 0)?;
    let mut out = FunctionalRun::default();
    let mut fast = StackStats::default();
    for jobs in warps {
        let before = sm.stats;
        let fast_before = fast;
        let sb = match shallow {
            None => run_functional_warps(&mut sm, jobs.iter().map(warp_work))?,
            Some(depth) => {
                let mut split = |job: &WarpTraces| {
                    let lanes = job.lanes.iter().map(|lane| match lane {
                        Some(t) if t.max_depth() <= depth => {
                            let pushes = t.ops().filter(|op| matches!(op, TraceOp::Push(_))).count() as u64;
                            fast.pushes += pushes;
                            fast.pops += pushes;
                            out.rays_fast += 1;
                            None
                        }
                        lane => lane.as_ref().map(lane_ops),
                    });
                    crate::run::verify::harness::WarpWork { lanes: lanes.collect() }
                };
                let work: Vec<_> =
                    jobs.iter().map(&mut split).filter(|w| w.lanes.iter().any(Option::is_some)).collect();
                run_functional_warps(&mut sm, work)?
            }
        };
        out.pops_checked += sb.pops_checked;
        let mut warp = sm.stats.since(&before);
        warp.add(&fast.since(&fast_before));
        out.per_warp.push(warp);
    }
    out.total = sm.stats;
    out.total.add(&fast);
    Ok(out)
}

#[derive(Debug)]
pub enum FunctionalError {
    Config(ConfigError),
    Violation(Violation),
}

impl std::fmt::Display for FunctionalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            FunctionalError::Config(e) => write!(f, "{e}"),
            FunctionalError::Violation(v) => write!(f, "stack mismatch at the functional level: {v}"),
        }
    }
}

impl std::error::Error for FunctionalError {}

impl From<ConfigError> for FunctionalError {
    fn from(e: ConfigError) -> Self {
        FunctionalError::Config(e)
    }
}

impl From<Violation> for FunctionalError {
    fn from(v: Violation) -> Self {
        FunctionalError::Violation(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workload::{Workload, WorkloadOpts};

    #[test]
    fn fast_path_counts_equal_the_full_run() {
        for name in crate::workload::scene::procedural::NAMES {
            let scene = crate::load_scene(name).unwrap();
            let opts = WorkloadOpts { width: 24, height: 24, ..WorkloadOpts::for_scene(&scene) };
            let w = Workload::new(&scene, opts).unwrap();
            for cfg in ["RB_2", "RB_8", "RB_4+SH_4", "RB_2+SH_2+SK", "RB_FULL", "RB_2+SH_2+SK+RA"] {
                let cfg: Config = cfg.parse().unwrap();
                let full = run(cfg, w.warps()).unwrap();
                let fast = run_with(cfg, w.warps(), true).unwrap();
                let what = format!("{name} {}", cfg.name());
                assert_eq!(fast.total, full.total, "{what}");
                assert_eq!(fast.per_warp, full.per_warp, "{what}");
                assert_eq!(full.rays_fast, 0, "{what}: the fast path is opt-in");
                if cfg.realloc().is_some() {
                    assert_eq!(fast.rays_fast, 0, "{what}: lanes lend their stacks, so all run");
                    assert_eq!(fast.pops_checked, full.pops_checked, "{what}");
                } else {
                    assert!(fast.rays_fast > 0, "{what}: some rays fit the RB");
                    assert!(fast.pops_checked < full.pops_checked, "{what}: fast rays skip the checks");
                }
                if cfg.name() == "RB_2" && name == "clutter" {
                    assert!(fast.rays_fast < w.num_rays(), "clutter has rays deeper than 2");
                    assert!(fast.total.rb_to_global > 0);
                }
            }
        }
    }
}
