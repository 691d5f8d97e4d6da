//! The cheaper fidelities agree with the cycle-level GPU on real traces. The functional
//! level counts exactly the cycle level's stack traffic without reallocation (with it, the
//! difference is measured), and sampled runs' 95 % intervals cover the full run's totals.

use rtl::config::Config;
use rtl::stack_manager::StackStats;
use tb::run::sampling::{SampleMode, SamplePlan};
use tb::run::sim::{simulate_sampled, Fidelity, Hardware, Metric, Outcome, RunSpec, Sampled};
use tb::workload::traverse::ChildOrder;
use tb::workload::Workload;

mod common;
use common::small_workload as workload;

fn run(config: Config, fidelity: Fidelity, w: &Workload) -> Outcome {
    common::simulate(config, Hardware::default(), fidelity, w)
}

/// Procedural spheres (wknd), generated triangles (clutter) and a real mesh (ship), each in both
/// child orders; `false` (nothing run) when ship's mesh is missing and the test is skipped.
fn for_each_workload(mut f: impl FnMut(&str, &Workload)) -> bool {
    let Some(ship) = tb::prereq::scene("ship") else { return false };
    for scene in [tb::load_scene("wknd").unwrap(), tb::load_scene("clutter").unwrap(), ship] {
        for order in [ChildOrder::Nearest, ChildOrder::VulkanSim] {
            let w = workload(&scene, 32, order);
            f(&format!("{} {order:?}", scene.name), &w);
        }
    }
    true
}

#[test]
fn functional_equals_cycle_without_reallocation() {
    let configs: Vec<Config> = Config::paper_set().into_iter().filter(|c| c.realloc().is_none()).collect();
    assert_eq!(configs.len(), 10);
    for_each_workload(|tag, w| {
        let (mut spilled, mut shared) = (false, false);
        for &cfg in &configs {
            let f = run(cfg, Fidelity::Functional, w);
            let c = run(cfg, Fidelity::Cycle, w);
            let name = cfg.name();
            assert_eq!(f.stack, c.stack, "{tag} {name}");
            assert_eq!(f.pops_checked, c.pops_checked, "{tag} {name}");
            assert_eq!(f.pixel_warps, c.pixel_warps, "{tag} {name}");
            assert!(f.gpu.is_none() && c.gpu.is_some());
            spilled |= f.stack.global_accesses() > 0;
            shared |= f.stack.rb_to_sh > 0 && cfg.sh_entries > 0;
        }
        let deepest = w.warp_jobs().flat_map(|j| j.lanes.into_iter().flatten()).map(|t| t.max_depth()).max();
        assert!(spilled, "{tag}: no configuration spilled off chip");
        assert_eq!(shared, deepest > Some(8), "{tag}: RB_8 spills to SH iff a stack exceeds 8 entries");
    });
}

/// Counters that balance in any correct run: every stack ends empty and every loan is returned.
fn balanced(s: &StackStats) -> bool {
    s.rb_to_sh == s.sh_to_rb
        && s.sh_to_global == s.global_to_sh
        && s.rb_to_global == s.global_to_rb
        && s.borrows == s.releases
        && s.pushes == s.pops
}

#[test]
fn reallocation_difference_between_levels_is_measured() {
    let configs: Vec<Config> = Config::paper_set().into_iter().filter(|c| c.realloc().is_some()).collect();
    assert_eq!(configs.len(), 4);
    let mut borrowed = false;
    println!("RA, functional − cycle: stack_global, borrows, flushes, demotions (functional / cycle)");
    if !for_each_workload(|tag, w| {
        for &cfg in &configs {
            let (f, c) = (run(cfg, Fidelity::Functional, w), run(cfg, Fidelity::Cycle, w));
            let (fs, cs) = (f.stack, c.stack);
            let name = cfg.name();
            // What a thread does with its own RB depends on its own trace only; only when lanes
            // finish (and so which SH stacks are idle to lend) depends on timing.
            assert_eq!(
                (fs.pushes, fs.pops, fs.rb_to_sh, fs.sh_to_rb),
                (cs.pushes, cs.pops, cs.rb_to_sh, cs.sh_to_rb)
            );
            assert_eq!(
                fs.rb_to_global + cs.rb_to_global,
                0,
                "{tag} {name}: with an SH level the RB never spills off chip"
            );
            assert_eq!(f.pops_checked, c.pops_checked, "{tag} {name}");
            assert!(balanced(&fs) && balanced(&cs), "{tag} {name}: {fs:?} / {cs:?}");
            borrowed |= fs.borrows > 0 && cs.borrows > 0;
            let d = |a: u64, b: u64| a as i64 - b as i64;
            println!(
                "  {tag:18} {name:18} {:+6} ({} / {}), {:+5} ({} / {}), {:+4} ({} / {}), {:+3}",
                d(fs.global_accesses(), cs.global_accesses()),
                fs.global_accesses(),
                cs.global_accesses(),
                d(fs.borrows, cs.borrows),
                fs.borrows,
                cs.borrows,
                d(fs.flushes, cs.flushes),
                fs.flushes,
                cs.flushes,
                d(fs.demotions, cs.demotions)
            );
        }
    }) {
        return;
    }
    assert!(borrowed, "no workload made reallocation borrow at both levels");
}

// Coverage of the sampled estimates. The truth is the full run of the same workload; each seed
// draws an independent sample, so over n seeds the number of intervals that cover the truth is
// Binomial(n, p) with p the true coverage. With n = 40, requiring at least 33 covered rejects a
// correct 95 % interval with probability P(X ≤ 32 | p = 0.95) = 7.1e-4, and accepts an interval
// that covers half the time with probability P(X ≥ 33 | p = 0.5) = 2.1e-5. (Sampling a quarter
// of the warps without replacement makes the batch-means interval slightly conservative, so
// p ≥ 0.95 for a well-behaved metric; 300 seeds measured 94–100 % here.)
const SEEDS: u64 = 40;
const MIN_COVERED: u32 = 33;
const BATCHES: u32 = 8;
/// Two-sided 95 % Student t quantile for 7 degrees of freedom (from the tables).
const T95_DF7: f64 = 2.365;
const ADDITIVE: [Metric; 2] = [Metric::StackGlobal, Metric::ShSpills];

/// How the test turns a sampled run's batches into an interval.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Estimator {
    /// Batch means with the t quantile, derived here independently of the library.
    Correct,
    /// Planted bug: the half width a quarter of what it should be (as if the t quantile were
    /// dropped and the interval shrunk).
    QuarterWidth,
    /// Planted bug: per-warp mean scaled by the sampled warps, not the workload's.
    SampleScale,
}

impl Estimator {
    /// `(value, half_width)` of metric `m`'s workload total from `s`'s batches.
    fn interval(self, s: &Sampled, m: Metric, total_warps: u32) -> (f64, f64) {
        let x: Vec<f64> = s.batches.iter().map(|o| m.of(o).unwrap() / o.pixel_warps as f64).collect();
        assert_eq!(x.len() as u32, BATCHES);
        let n = x.len() as f64;
        let mean = x.iter().sum::<f64>() / n;
        let sd = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let sampled: u32 = s.batches.iter().map(|o| o.pixel_warps).sum();
        let (scale, half) = match self {
            Estimator::Correct => (total_warps, T95_DF7 * sd / n.sqrt()),
            Estimator::QuarterWidth => (total_warps, T95_DF7 * sd / n.sqrt() / 4.0),
            Estimator::SampleScale => (sampled, T95_DF7 * sd / n.sqrt()),
        };
        (mean * scale as f64, half * scale as f64)
    }
}

/// Sampled runs of a quarter of ship's 128 warps (functional level) for seeds 0..SEEDS, with the
/// full run they estimate.
/// `None` when ship's mesh is missing and the test is skipped.
fn trials(mode: SampleMode) -> Option<(Outcome, Vec<Sampled>, u32)> {
    let ship = tb::prereq::scene("ship")?;
    let w = workload(&ship, 64, ChildOrder::Nearest);
    let spec = RunSpec {
        config: "RB_4+SH_4".parse().unwrap(),
        hw: Hardware::default(),
        fidelity: Fidelity::Functional,
    };
    let full = common::simulate(spec.config, spec.hw, spec.fidelity, &w);
    let runs = (0..SEEDS)
        .map(|seed| {
            let plan = SamplePlan { fraction: 0.25, mode, batches: BATCHES, seed };
            simulate_sampled(&spec, &w, &plan, |_| {}).unwrap()
        })
        .collect();
    Some((full, runs, w.num_warps()))
}

/// How many of the trials' intervals for `m` cover the full run's value.
fn covered(e: Estimator, full: &Outcome, runs: &[Sampled], total_warps: u32, m: Metric) -> u32 {
    let truth = m.of(full).unwrap();
    assert!(truth > 0.0, "{m:?} is zero: nothing to estimate");
    runs.iter()
        .map(|s| {
            let (value, half) = e.interval(s, m, total_warps);
            u32::from((truth - value).abs() <= half)
        })
        .sum()
}

#[test]
fn sampled_intervals_cover_the_full_run() {
    for mode in [SampleMode::Random, SampleMode::Tile] {
        let Some((full, runs, warps)) = trials(mode) else { return };
        assert_eq!(warps, 128);
        for m in ADDITIVE {
            // The library's interval is the one derived here.
            for s in &runs {
                let lib = s.get(m).unwrap();
                let (value, half) = Estimator::Correct.interval(s, m, warps);
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(1.0);
                assert!(
                    close(lib.value, value) && close(lib.half_width, half),
                    "{m:?}: {lib:?} vs ({value}, {half})"
                );
            }
            let lib_covered =
                runs.iter().filter(|s| s.get(m).unwrap().contains(m.of(&full).unwrap())).count();
            let n = covered(Estimator::Correct, &full, &runs, warps, m);
            assert_eq!(lib_covered as u32, n);
            let rel = runs.iter().map(|s| s.get(m).unwrap().relative()).sum::<f64>() / runs.len() as f64;
            println!(
                "{mode:?} {m:?}: {n}/{SEEDS} intervals cover {}, mean relative half width {rel:.2}",
                m.of(&full).unwrap()
            );
            assert!(n >= MIN_COVERED, "{mode:?} {m:?}: only {n} of {SEEDS} intervals cover the full run");
        }
    }
}

#[test]
fn coverage_check_catches_planted_estimator_bugs() {
    // Random mode: stratifying by tile makes batch-means intervals conservative, which would
    // partly hide a too-narrow interval.
    let Some((full, runs, warps)) = trials(SampleMode::Random) else { return };
    for m in ADDITIVE {
        for e in [Estimator::QuarterWidth, Estimator::SampleScale] {
            let n = covered(e, &full, &runs, warps, m);
            println!("planted {e:?} {m:?}: {n}/{SEEDS} intervals cover the full run");
            assert!(n < MIN_COVERED, "{e:?} {m:?}: {n} of {SEEDS} covered, the check missed the bug");
        }
        assert!(covered(Estimator::Correct, &full, &runs, warps, m) >= MIN_COVERED);
    }
}
