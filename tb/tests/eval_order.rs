//! Evaluation order does not matter, and the two runners agree. Two real scenes run through the
//! whole GPU under every paper configuration with the RT units evaluated in a seeded random order
//! each cycle, with every kernel evaluated twice per cycle and with every unit evaluated every
//! cycle (the reference loop); each report equals the normal run's (by windows) bit for bit, and
//! so does the reference loop's, on one thread and two. A planted slip of each kind (`OrderBug`,
//! entering through the runners' `Steps`) is caught, each by the divergence it must cause; among
//! them a mechanism that couples the SMs outside the L2's exchange, which the windowed run cannot
//! run right and which only the comparison with the reference loop shows.

use rtl::clock::EvalCheck;
use rtl::config::Config;
use rtl::gpu::{Gpu, GpuReport};
use rtl::ray_op::WarpJob;
use rtl::rt_unit::RunError;
use rtl::sim::{OrderBug, Runner};
use tb::run::sim::Hardware;

mod common;
use common::{bits, gpu, report, run_gpu, run_gpu_guarded as guarded, scene_jobs as jobs};

/// The GPU of `cfg` on the default hardware under `check`, with slip `bug` planted.
fn planted(cfg: Config, check: EvalCheck, bug: Option<OrderBug>) -> Runner {
    let g = gpu(cfg, &Hardware::default()).with_eval_check(check);
    match bug {
        Some(b) => g.with_order_bug(b),
        None => g,
    }
}

/// A run on the default hardware: by windows under [`EvalCheck::Dataflow`], on the reference
/// loop under the other checks (and with a slip of that loop planted).
fn run(cfg: Config, jobs: &[WarpJob], check: EvalCheck, bug: Option<OrderBug>) -> GpuReport {
    report(planted(cfg, check, bug), jobs.iter().cloned(), &cfg.name())
}

#[test]
fn shuffled_twice_evaluated_and_every_unit_runs_equal_the_dataflow_run() {
    for (scene, res) in [("clutter", 16), ("wknd", 16)] {
        let jobs = jobs(scene, res);
        for cfg in Config::paper_set() {
            let normal = run(cfg, &jobs, EvalCheck::Dataflow, None);
            assert!(normal.pops_checked > 0 && normal.cycles > 0, "{scene} {}", cfg.name());
            for check in [EvalCheck::Shuffled { seed: 13 }, EvalCheck::Twice, EvalCheck::EveryUnit] {
                let other = run(cfg, &jobs, check, None);
                assert_eq!(bits(&other), bits(&normal), "{scene} {} under {check:?}", cfg.name());
            }
        }
    }
}

/// A dispatcher that hands jobs out in evaluation order makes one unit's job depend on when its
/// siblings were visited: the shuffled run's report differs from its own dataflow run's. A unit
/// whose evaluation is not idempotent (it counts an earlier pass's visits again) changes the
/// report under `Twice`.
#[test]
fn planted_order_dependences_are_caught() {
    let jobs = jobs("clutter", 16);
    let cfg = Config::sms();
    let dispatch = Some(OrderBug::DispatchInEvalOrder);
    let (a, b) = (
        run(cfg, &jobs, EvalCheck::Dataflow, dispatch),
        run(cfg, &jobs, EvalCheck::Shuffled { seed: 13 }, dispatch),
    );
    assert_ne!(bits(&a), bits(&b), "the shuffled run must expose dispatch in evaluation order");
    let stale = Some(OrderBug::StaleStep);
    let (a, b) = (run(cfg, &jobs, EvalCheck::Dataflow, stale), run(cfg, &jobs, EvalCheck::Twice, stale));
    assert_eq!(a.visits, run(cfg, &jobs, EvalCheck::Dataflow, None).visits, "harmless when evaluated once");
    assert_ne!(bits(&a), bits(&b), "evaluating twice must expose the stale step");
}

/// A wake-up skip that lets a unit sleep through a memory response loses the response: the ray
/// waiting for it never moves again, and the run stops as stalled, long before the run that
/// evaluates every unit every cycle (which never sleeps, so the slip cannot touch it) ends.
#[test]
fn a_wake_up_that_misses_a_response_is_caught() {
    let jobs = jobs("clutter", 16);
    let cfg = Config::sms();
    let deaf = |check| run_gpu(planted(cfg, check, Some(OrderBug::SleepThroughResponses)), jobs.clone());
    let every = deaf(EvalCheck::EveryUnit).expect("evaluating every unit never sleeps");
    assert_eq!(bits(&every), bits(&run(cfg, &jobs, EvalCheck::Dataflow, None)));
    match deaf(EvalCheck::Dataflow) {
        Err(RunError::Stalled { cycle }) => assert!(cycle < every.cycles, "stalled in cycle {cycle}"),
        other => panic!("the lost response must stall the run, got {other:?}"),
    }
}

/// A run on hardware `hw`, by windows or on the reference loop, on one thread or two, with a
/// planted slip: its report or error, or "panic".
fn windowed(
    cfg: Config,
    hw: &Hardware,
    jobs: &[WarpJob],
    windows: bool,
    parallel: bool,
    bug: Option<OrderBug>,
) -> Result<Result<GpuReport, RunError>, String> {
    let g = gpu(cfg, hw).with_windows(windows).with_helper_thread(parallel);
    let g = match bug {
        Some(b) => g.with_order_bug(b),
        None => g,
    };
    guarded(g, jobs.to_vec())
}

/// The hardware the windowed run is compared on: the default; the legacy preset (a miss queue
/// of 8 and 32 MSHRs, so SMs stop for their queue's length); a one-entry miss queue (they stop
/// all the time); Vulkan-Sim's RTX 2060 (30 SMs); an L2 whose pipeline leaves windows of five
/// cycles; one too short for windows (the reference loop runs); overlapped stack timing
/// (posted stores, still queued when warps leave).
fn window_hardware() -> Vec<(&'static str, Hardware)> {
    let d = Hardware::default();
    let with = |f: &dyn Fn(&mut Hardware)| {
        let mut h = d;
        f(&mut h);
        h
    };
    vec![
        ("paper", d),
        ("legacy", tb::hw::preset("legacy").unwrap()),
        ("miss queue 1", with(&|h| h.mem.l1d_miss_queue = 1)),
        ("rtx2060", tb::hw::preset("rtx2060").unwrap()),
        ("l2 latency 13", with(&|h| h.mem.l2_latency = 13)),
        ("l2 latency 8", with(&|h| h.mem.l2_latency = 8)),
        ("overlapped", with(&|h| h.stack = h.stack.overlapped())),
        ("vulkansim-mobile", tb::hw::preset("vulkansim-mobile").unwrap()),
        (
            "sh-posted, store queue 4",
            with(&|h| {
                h.stack.store_gating = rtl::rt_unit::StoreGating::ShPosted;
                h.stack.store_queue = 4;
            }),
        ),
    ]
}

/// The windowed run (each SM runs a window of cycles on its own and meets the L2
/// between windows) gives the reference loop's report bit for bit — cycles, evaluated
/// cycles, every count — on one thread and on two, on two scenes, under every paper
/// configuration on the default hardware and under three configurations on each other kind.
#[test]
fn windows_equal_the_reference_loop() {
    for (scene, res) in [("clutter", 16), ("wknd", 16)] {
        let jobs = jobs(scene, res);
        for (name, hw) in window_hardware() {
            let cfgs: Vec<Config> = if name == "paper" {
                Config::paper_set()
            } else {
                ["RB_8", "RB_8+SH_8", "SMS"].iter().map(|c| c.parse().unwrap()).collect()
            };
            for cfg in cfgs {
                let what = format!("{scene}, {name}, {}", cfg.name());
                let plain = windowed(cfg, &hw, &jobs, false, false, None).expect("no panic").expect(&what);
                assert!(plain.pops_checked > 0, "{what}");
                for parallel in [false, true] {
                    let w = windowed(cfg, &hw, &jobs, true, parallel, None).expect("no panic").expect(&what);
                    assert_eq!(bits(&w), bits(&plain), "{what}, by windows, two threads: {parallel}");
                }
            }
        }
    }
}

/// A failed check stops the windowed run with the error the reference loop stops with (the
/// earliest cycle's, and in it the lowest SM's), on one thread and on two: every broken stack
/// manager that fails the loop, on the paper's and the legacy hardware. A broken stack manager
/// either leaves this workload's report alone or fails one of the RT unit's stack checks; no
/// run panics or stalls, so a harness that broke the run some other way fails the test.
#[test]
fn windows_fail_as_the_reference_loop() {
    use rtl::stack_manager::Mutant;
    let jobs = jobs("clutter", 16);
    let cfg = Config::sms();
    let mut failed = 0;
    for hw in [Hardware::default(), tb::hw::preset("legacy").unwrap()] {
        for m in Mutant::ALL {
            let attempt = |windows: bool, parallel: bool| {
                let g = Gpu::build(cfg, hw.rt, hw.stack, hw.mem_for(&cfg), m.policy())
                    .unwrap()
                    .with_windows(windows)
                    .with_helper_thread(parallel);
                guarded(g, jobs.clone()).unwrap_or_else(|p| panic!("{m:?}, windows: {windows}: {p}"))
            };
            let plain = attempt(false, false);
            if let Err(e) = &plain {
                assert!(
                    matches!(
                        e,
                        RunError::PopMismatch { .. }
                            | RunError::PopMissing { .. }
                            | RunError::Stack { .. }
                            | RunError::ExitNotEmpty { .. }
                    ),
                    "{m:?}: a stack check must fail, not {e:?}"
                );
                failed += 1;
            }
            for parallel in [false, true] {
                let w = attempt(true, parallel);
                assert_eq!(format!("{w:?}"), format!("{plain:?}"), "{m:?}, two threads: {parallel}");
            }
        }
    }
    assert!(failed > 0, "some broken stack manager fails the run");
}

/// Each of the windowed run's three stops, planted away, is caught by comparing with the
/// reference loop: an SM that runs on while its miss queue may be full (on a one-entry queue),
/// one that runs on with a free warp slot instead of stopping for the dispatch, and an L2 back end
/// that runs further ahead than its pipelines' delay allows; and so is a skip over an SM's quiet
/// cycles that wakes its RT unit a cycle late. Each run still does every ray's work
/// and checks every pop (the slips are of timing, not of traversal), but its cycles differ from
/// the reference loop's; the late jobs also show in the last dispatch's cycle.
#[test]
fn the_windowed_runs_planted_slips_are_caught() {
    // More warps than the RT units' slots, so that jobs are dispatched as warps leave.
    let jobs = jobs("clutter", 32);
    assert!(jobs.len() > 32, "more jobs than the 8 RT units' 4 slots");
    let cfg = Config::sms();
    let hws = window_hardware();
    let hw_of = |name: &str| hws.iter().find(|h| h.0 == name).unwrap().1;
    for (bug, hw) in [
        (OrderBug::WindowIgnoresFullQueue, hw_of("miss queue 1")),
        (OrderBug::WindowSkipsJobStop, hw_of("paper")),
        (OrderBug::WindowBackEndTooFar, hw_of("paper")),
        (OrderBug::WindowWakesLate, hw_of("paper")),
    ] {
        let plain = windowed(cfg, &hw, &jobs, false, false, None).unwrap().unwrap();
        let slipped = windowed(cfg, &hw, &jobs, true, false, Some(bug))
            .unwrap_or_else(|p| panic!("{bug:?}: {p}"))
            .unwrap_or_else(|e| panic!("{bug:?}: {e}"));
        assert_eq!(
            (slipped.rays, slipped.visits, slipped.pops_checked),
            (plain.rays, plain.visits, plain.pops_checked),
            "{bug:?}: the same work"
        );
        assert_ne!(slipped.cycles, plain.cycles, "{bug:?} must show in the cycles");
        if bug == OrderBug::WindowSkipsJobStop {
            assert_ne!(slipped.last_dispatch, plain.last_dispatch, "the late jobs must show");
        }
        // The reference loop ignores it.
        let loop_run = windowed(cfg, &hw, &jobs, false, false, Some(bug)).unwrap().unwrap();
        assert_eq!(bits(&loop_run), bits(&plain));
    }
}

/// A run in which nothing can happen any more while work remains stops as stalled, in the last
/// cycle in which anything happened, rather than going on for ever: the windowed run's SMs drop
/// the L2's responses (a planted bug), so every ray that missed its L1D waits for ever.
#[test]
fn a_windowed_run_that_can_never_finish_stops_as_stalled() {
    let jobs = jobs("clutter", 16);
    let cfg = Config::sms();
    let hw = Hardware::default();
    let clean = windowed(cfg, &hw, &jobs, true, false, None).unwrap().unwrap();
    for parallel in [false, true] {
        match windowed(cfg, &hw, &jobs, true, parallel, Some(OrderBug::WindowLosesResponses)) {
            Ok(Err(RunError::Stalled { cycle })) => {
                assert!(cycle > 0 && cycle < clean.cycles, "stalled in cycle {cycle} of {}", clean.cycles)
            }
            other => panic!("expected a stall, got {other:?}"),
        }
    }
}

/// The windowed run's coupling rule: the SMs meet only through the L2's grants and responses and
/// the dispatch. A mechanism that couples them any other way breaks the windowed run silently,
/// and comparing it with the reference loop catches that: planted, the RT units share one visit
/// counter outside the L2 (`OrderBug::SmsShareACounter`: each evaluation reads it and adds to
/// it, and counts its own visits twice when it finds it odd). The windowed run ends without an
/// error, in the same cycles, with the same rays and pops checked, every count the same but the
/// visits, which differ from the reference loop's run of the same mechanism: what an SM read
/// depended on how far the other SMs had run through their windows.
#[test]
fn a_mechanism_coupling_sms_outside_the_l2_is_caught() {
    let jobs = jobs("clutter", 16);
    let hw = Hardware::default();
    let bug = Some(OrderBug::SmsShareACounter);
    for cfg in [Config::sms(), "RB_8".parse().unwrap()] {
        let clean = windowed(cfg, &hw, &jobs, false, false, None).unwrap().unwrap();
        let reference = windowed(cfg, &hw, &jobs, false, false, bug).unwrap().unwrap();
        let by_windows = windowed(cfg, &hw, &jobs, true, false, bug)
            .expect("no panic")
            .expect("the coupling is silent: no error");
        assert!(reference.visits > clean.visits, "{}: the mechanism counts visits again", cfg.name());
        assert_ne!(by_windows.visits, reference.visits, "{}: the windowed run must diverge", cfg.name());
        let but_visits = |r: &GpuReport| bits(&GpuReport { visits: 0, ..*r });
        assert_eq!(but_visits(&by_windows), but_visits(&reference), "{}: only the visits differ", cfg.name());
    }
}
