//! Functional fidelity: stack traffic counted per ray from the traces, no timing.
//!
//! Each pixel warp's jobs run through one stack manager at the functional level (micro-ops
//! complete at once, lanes take turns one command each), every pop checked against the
//! reference. It answers "how many spills, reloads, borrows and flushes" in the least time.
//! Without reallocation every thread's decisions depend on its own history only, so the counts
//! equal the cycle level's exactly; with reallocation, borrowing depends on when lanes finish,
//! and the difference is this level's error (measured by `sms bench`).

use proofs::harness::run_functional_warps;
use proofs::invariants::Violation;
use rtl::config::{Config, ConfigError};
use rtl::stack_manager::{StackManager, StackStats};

use crate::stack_tb::warp_work;
use crate::workload::WarpJob;

/// Stack counts of a whole workload and of each pixel warp.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FunctionalRun {
    pub total: StackStats,
    pub per_warp: Vec<StackStats>,
    pub pops_checked: u64,
}

/// Counts pixel warps' stack traffic (each item: the jobs of one pixel warp, in order).
pub fn run<I>(cfg: Config, warps: I) -> Result<FunctionalRun, FunctionalError>
where
    I: IntoIterator<Item = Vec<WarpJob>>,
{
    let mut sm = StackManager::new(cfg, 0)?;
    let mut out = FunctionalRun::default();
    for jobs in warps {
        let before = sm.stats;
        let sb = run_functional_warps(&mut sm, jobs.iter().map(warp_work))?;
        out.pops_checked += sb.pops_checked;
        out.per_warp.push(diff(&sm.stats, &before));
    }
    out.total = sm.stats;
    Ok(out)
}

fn diff(a: &StackStats, b: &StackStats) -> StackStats {
    StackStats {
        pushes: a.pushes - b.pushes,
        pops: a.pops - b.pops,
        rb_to_sh: a.rb_to_sh - b.rb_to_sh,
        sh_to_rb: a.sh_to_rb - b.sh_to_rb,
        sh_to_global: a.sh_to_global - b.sh_to_global,
        global_to_sh: a.global_to_sh - b.global_to_sh,
        rb_to_global: a.rb_to_global - b.rb_to_global,
        global_to_rb: a.global_to_rb - b.global_to_rb,
        borrows: a.borrows - b.borrows,
        releases: a.releases - b.releases,
        flushes: a.flushes - b.flushes,
        flushes_saturated: a.flushes_saturated - b.flushes_saturated,
        demotions: a.demotions - b.demotions,
    }
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
