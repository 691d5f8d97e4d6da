//! Cycle-level RT unit and GPU: hand-worked timing, merging, the one-request port, and sanity of
//! whole runs on synthetic traversals (monotonicity in stack size, determinism, every pop
//! checked, a planted wrong pop caught, idle skipping equal to stepping).

use rtl::config::Config;
use rtl::gpu::{carve_out, Gpu, GpuReport};
use rtl::mem::MemParams;
use rtl::ray_op::{NodeKind, RayOp, WarpJob};
use rtl::rt_unit::{PortPriority, RtParams, RunError, StackParams, StackTiming, StoreGating, WarpSelect};
use rtl::trace::{NullSink, Sink};
use tb::hw::Hardware;

mod common;
use common::{gpu, run_gpu, synthetic_jobs as jobs};

/// A run of `cfg` with stack timing `stack` and memory `mem` (the SH stacks carved out of its
/// L1D), the default latencies.
fn run_with(
    cfg: &str,
    mem: MemParams,
    stack: StackParams,
    work: Vec<WarpJob>,
) -> Result<GpuReport, RunError> {
    run_on(cfg, Hardware { stack, mem, shared_carveout: true, ..Hardware::default() }, work)
}

fn run_on(cfg: &str, hw: Hardware, work: Vec<WarpJob>) -> Result<GpuReport, RunError> {
    run_gpu(gpu(cfg.parse().unwrap(), &hw), work)
}

/// The paper's memory system with a small L2, so spilled lines do reach DRAM: 2 banks of 16 sets
/// (the least IPOLY indexes).
fn small_l2() -> MemParams {
    MemParams { l2_bytes: 64 * 1024, l2_banks: 2, ..MemParams::default() }
}

fn run(cfg: &str, work: Vec<WarpJob>) -> GpuReport {
    run_with(cfg, small_l2(), StackParams::default(), work).unwrap()
}

fn one_sm() -> MemParams {
    MemParams { sms: 1, ..MemParams::default() }
}

fn single_warp(lane0: Vec<RayOp>) -> WarpJob {
    let mut lanes = vec![None; 32];
    lanes[0] = Some(lane0);
    WarpJob { lanes, walk: None }
}

/// One ray, one SM, RB_8, default latencies. Derivation (cycle c: what happens in it; a state
/// set in cycle c is seen from c + 1):
///
/// -    0: the job is dispatched; the lane is Busy with the BVH header (4) until cycle 4.
/// -    4: header done, next op Visit root → Fetch.
/// -    5: GTO picks warp 0; the 64-byte root is two sector requests, queued.
/// -  6, 7: the port sends sector 0, then sector 1 (one request per cycle).
/// - 266, 267: their responses (L1D miss, L2 miss: 260 cycles each).
/// -  267: last piece in → Busy with the internal-node latency (8) until 275.
/// -  275: → Stack (Push a). 276: push accepted (RB not full: no request) → Fetch (Visit b).
/// -  277: scheduled; 278, 279: sent; 538, 539: back (new lines: DRAM); Busy until 547.
/// -  547: → Stack (Pop a). 548: pop answered from RB, checked against the trace → Fetch.
/// -  549: scheduled; 550, 551: sent; 810, 811: back (a was never fetched); triangle Busy
///    until 819.
/// -  819: no ops left → Stack (Finish). 820: finish accepted → Done.
/// -  821: warp done and its stacks quiet: the slot frees. 822: nothing left: the run ends.
///
/// The derivation holds for both stack timings (`Overlapped` with `sh_latency` 2, and the
/// default `Blocking` with 20): the push and the pop move no entry (the RB never fills), so the
/// stack sequencer is idle in the cycle after each command and neither timing adds a cycle.
#[test]
fn single_ray_cycle_count_derived_by_hand() {
    for stack in [StackParams::default().overlapped(), StackParams::default()] {
        single_ray_with(stack);
    }
}

fn single_ray_with(stack: StackParams) {
    let (root, a, b) = (0x1_0000, 0x2_0000, 0x3_0000);
    let ops = vec![
        RayOp::Visit { addr: root, kind: NodeKind::Internal, bytes: 64 },
        RayOp::Push(a),
        RayOp::Visit { addr: b, kind: NodeKind::Internal, bytes: 64 },
        RayOp::Pop(a),
        RayOp::Visit { addr: a, kind: NodeKind::Triangle, bytes: 64 },
    ];
    let r = run_with("RB_8", one_sm(), stack, vec![single_warp(ops.clone())]).unwrap();
    assert_eq!(r.cycles, 822);
    assert_eq!((r.rays, r.visits, r.node_fetches, r.pops_checked), (1, 3, 6, 1));
    assert_eq!(r.dram_node, 6);
    assert_eq!(r.l1d_hit_rate, 0.0);
    assert!(r.evaluated_cycles < 100, "the waits on memory are skipped: {}", r.evaluated_cycles);

    // Step by step: the lane's state as the probe shows it after each cycle's step (the state it
    // has from the next cycle on), recorded when it changes. 0 Done, 1 Busy, 2 Fetch,
    // 3 WaitMem, 4 Stack.
    let mut watch = Watch::new("sm0.rt_unit.warp_buffer.warp[0].thread[0].state");
    let cfg: Config = "RB_8".parse().unwrap();
    Gpu::new(cfg, RtParams::default(), stack, one_sm())
        .unwrap()
        .run(vec![single_warp(ops)], &mut watch)
        .unwrap();
    let (done, busy, fetch, wait, stack) = (0, 1, 2, 3, 4);
    #[rustfmt::skip]
    let derived = [
        (0, busy), (4, fetch), (5, wait), (267, busy), (275, stack), (276, fetch), (277, wait),
        (539, busy), (547, stack), (548, fetch), (549, wait), (811, busy), (819, stack), (820, done),
    ];
    assert_eq!(watch.changes, derived);
}

/// A two-level trace fetches the acceleration structure's header as its first visit and pays the
/// header latency there, not again when its warp lands: the same ray with that first fetch marked
/// as another 4-cycle kind (the flat traces' case, which reads the header at load) takes
/// `bvh_header - 1` cycles more (the cycle in which the warp lands is spent either way), with the
/// same memory traffic.
#[test]
fn two_level_header_latency_is_paid_once() {
    let trace = |first: NodeKind| {
        vec![
            RayOp::Visit { addr: 0x8_0000, kind: first, bytes: 64 },
            RayOp::Visit { addr: 0x1_0000, kind: NodeKind::Internal, bytes: 64 },
            RayOp::Visit { addr: 0x3_0000, kind: NodeKind::Triangle, bytes: 64 },
        ]
    };
    let rt = RtParams::default();
    assert_eq!(rt.latency(NodeKind::BvhHeader), rt.latency(NodeKind::LeafDescriptor));
    let stack = StackParams::default();
    let fetched = run_with("RB_8", one_sm(), stack, vec![single_warp(trace(NodeKind::BvhHeader))]).unwrap();
    let at_load =
        run_with("RB_8", one_sm(), stack, vec![single_warp(trace(NodeKind::LeafDescriptor))]).unwrap();
    assert_eq!(at_load.cycles, fetched.cycles + u64::from(rt.bvh_header) - 1);
    assert_eq!((fetched.node_fetches, fetched.dram_node), (at_load.node_fetches, at_load.dram_node));
}

/// Records when one signal changes value: (cycle, new value); with `every`, every cycle's
/// non-zero value.
struct Watch {
    path: &'static str,
    scope: Vec<String>,
    cycle: u64,
    every: bool,
    changes: Vec<(u64, u64)>,
}

impl Watch {
    fn new(path: &'static str) -> Self {
        Watch { path, scope: Vec::new(), cycle: 0, every: false, changes: Vec::new() }
    }
}

impl Sink for Watch {
    fn enabled(&self) -> bool {
        true
    }
    fn begin_cycle(&mut self, cycle: u64) {
        self.cycle = cycle;
    }
    fn push_scope(&mut self, name: &str) {
        self.scope.push(name.to_string());
    }
    fn pop_scope(&mut self) {
        self.scope.pop();
    }
    fn signal(&mut self, name: &str, _: u32, value: u64) {
        let (scope, signal) = self.path.rsplit_once('.').unwrap();
        let record = if self.every { value != 0 } else { self.changes.last().map(|c| c.1) != Some(value) };
        if name == signal && self.scope.join(".") == scope && record {
            self.changes.push((self.cycle, value));
        }
    }
}

#[test]
fn identical_nodes_in_a_warp_make_one_fetch() {
    let visit = RayOp::Visit { addr: 0x4000, kind: NodeKind::Internal, bytes: 32 };
    let job = WarpJob { lanes: vec![Some(vec![visit]); 32], walk: None };
    let r = run_with("RB_8", one_sm(), StackParams::default(), vec![job]).unwrap();
    assert_eq!((r.rays, r.visits, r.node_fetches, r.dram_node), (32, 32, 1, 1));
    // Header until 4, scheduled at 5, sent at 6, back at 266, Busy (8) until 274, Finish at 275,
    // the slot frees at 276, the run ends at 277.
    assert_eq!(r.cycles, 277);
}

#[test]
fn one_memory_request_per_cycle() {
    // 32 lanes visit 32 different sectors: 32 requests leave on 32 consecutive cycles.
    let job = WarpJob {
        lanes: (0..32)
            .map(|l| Some(vec![RayOp::Visit { addr: 0x8000 + 32 * l, kind: NodeKind::Triangle, bytes: 32 }]))
            .collect(),
        walk: None,
    };
    let cfg: Config = "RB_8".parse().unwrap();
    let mut watch = Watch::new("sm0.rt_unit.port.req_node");
    let r = Gpu::new(cfg, RtParams::default(), StackParams::default(), one_sm())
        .unwrap()
        .run(vec![job], &mut watch)
        .unwrap();
    assert_eq!(r.node_fetches, 32);
    // The port drives a node request in cycles 6 to 37 and in no other.
    assert_eq!(watch.changes, [(0, 0), (6, 1), (38, 0)]);
}

/// Runs `cfgs` (stack sizes ascending) on the same traces; checks off-chip stack traffic never
/// grows with the size.
fn never_more_traffic(cfgs: &[&str]) -> Vec<GpuReport> {
    let work = jobs(1, 16, 45);
    let runs: Vec<GpuReport> = cfgs.iter().map(|c| run(c, work.clone())).collect();
    for (p, names) in runs.windows(2).zip(cfgs.windows(2)) {
        let (small, large) = (&p[0], &p[1]);
        let (a, b) = (small.stack, large.stack);
        assert!(b.global_stores() <= a.global_stores(), "{names:?}");
        assert!(b.global_loads() <= a.global_loads(), "{names:?}");
        assert!(
            large.dram_stack <= small.dram_stack,
            "{names:?}: {} > {}",
            large.dram_stack,
            small.dram_stack
        );
        assert_eq!(large.pops_checked, small.pops_checked);
    }
    runs
}

#[test]
fn larger_rb_never_adds_stack_traffic_and_full_has_none() {
    let rb = never_more_traffic(&["RB_2", "RB_4", "RB_8", "RB_16", "RB_FULL"]);
    assert!(rb[0].stack.global_accesses() > 0 && rb[0].dram_stack > 0, "the workload spills");
    assert!(rb[2].stack.global_accesses() > 0, "even RB_8 spills");
    let full = rb[4];
    let s = full.stack;
    assert_eq!(
        (s.rb_to_sh, s.sh_to_rb, s.sh_to_global, s.global_to_sh, s.rb_to_global, s.global_to_rb),
        (0, 0, 0, 0, 0, 0)
    );
    assert_eq!((full.dram_stack, full.bank_conflict_cycles), (0, 0));
}

#[test]
fn larger_sh_never_adds_stack_traffic() {
    let sh = never_more_traffic(&["RB_8", "RB_8+SH_4", "RB_8+SH_8", "RB_8+SH_16"]);
    assert!(sh[1].stack.rb_to_sh > 0 && sh[1].stack.sh_to_global > 0, "SH_4 overflows to global");
    let sms = run("SMS", jobs(1, 16, 45));
    assert_eq!(sms.pops_checked, sh[2].pops_checked);
    assert!(sms.stack.global_accesses() <= sh[2].stack.global_accesses(), "reallocation only saves");
}

#[test]
fn identical_inputs_give_identical_reports() {
    let work = jobs(2, 12, 45);
    for cfg in ["RB_2", "SMS"] {
        assert_eq!(run(cfg, work.clone()), run(cfg, work.clone()), "{cfg}");
    }
    assert_ne!(run("RB_2", work), run("RB_2", jobs(3, 12, 45)));
}

#[test]
fn every_pop_is_checked_and_a_wrong_pop_is_caught() {
    let work = jobs(4, 16, 45);
    let pops = work
        .iter()
        .flat_map(|j| j.lanes.iter().flatten().flatten())
        .filter(|o| matches!(o, RayOp::Pop(_)))
        .count();
    assert_eq!(run("RB_2+SH_8+SK+RA", work.clone()).pops_checked, pops as u64);
    // Plant a bug: one pop in the middle of some lane names the wrong node.
    let mut bad = work;
    let lane = bad[7]
        .lanes
        .iter_mut()
        .flatten()
        .find(|ops| ops.iter().filter(|o| matches!(o, RayOp::Pop(_))).count() > 2)
        .unwrap();
    let p = lane.iter_mut().filter(|o| matches!(o, RayOp::Pop(_))).nth(1).unwrap();
    *p = RayOp::Pop(0xBAD0);
    let e = run_with("RB_2+SH_8+SK+RA", small_l2(), StackParams::default(), bad).unwrap_err();
    assert!(matches!(e, RunError::PopMismatch { expected: 0xBAD0, .. }), "{e}");
}

#[test]
fn bad_jobs_are_errors() {
    let short = WarpJob { lanes: vec![None; 8], walk: None };
    assert!(matches!(
        run_with("RB_8", one_sm(), StackParams::default(), vec![short]),
        Err(RunError::BadJob { job: 0, .. })
    ));
    let unbalanced = single_warp(vec![RayOp::Push(8)]);
    assert!(matches!(
        run_with("RB_8", one_sm(), StackParams::default(), vec![unbalanced]),
        Err(RunError::Stack { .. })
    ));
    let e = RtParams { triangle: 0, ..RtParams::default() }.validate().unwrap_err();
    assert_eq!(e.parameter, "triangle");
}

#[test]
fn idle_skipping_equals_stepping_every_cycle() {
    // Dense (every SM full: little to skip) and sparse (one warp per SM: mostly waiting).
    // Both stack timings: Blocking adds waits on store acknowledgements, on the SH latency
    // pipeline and lanes that wait to fetch on their sequencer.
    let old = StackParams::default().overlapped();
    for (cfg, work, stack, min_skipped_percent) in [
        ("RB_2", jobs(5, 24, 45), old, 5),
        ("RB_8+SH_8+SK+RA", jobs(5, 24, 45), old, 5),
        ("RB_2+SH_4", jobs(6, 6, 45), old, 50),
        ("RB_2", jobs(5, 24, 45), StackParams::default(), 5),
        ("RB_8+SH_8+SK+RA", jobs(5, 24, 45), StackParams::default(), 5),
        ("RB_2+SH_4", jobs(6, 6, 45), StackParams::default(), 50),
    ] {
        let hw = Hardware { stack, mem: small_l2(), shared_carveout: true, ..Hardware::default() };
        let stepped = run_on(cfg, Hardware { idle_skip: false, ..hw }, work.clone()).unwrap();
        let skipped = run_on(cfg, hw, work).unwrap();
        assert_eq!(stepped, GpuReport { evaluated_cycles: stepped.evaluated_cycles, ..skipped }, "{cfg}");
        assert_eq!(stepped.evaluated_cycles, stepped.cycles);
        let skipped_percent = 100 - 100 * skipped.evaluated_cycles / stepped.cycles;
        assert!(skipped_percent >= min_skipped_percent, "{cfg}: skipped only {skipped_percent}%");
    }
}

/// Release-build speed on ~1000 warps: `cargo test --release -p tb --test gpu -- --ignored
/// --nocapture speed`.
#[test]
#[ignore]
fn speed() {
    let warps = std::env::var("SPEED_WARPS").map_or(1024, |v| v.parse().unwrap());
    let work = jobs(9, warps, 40);
    let ops: usize = work.iter().flat_map(|j| j.lanes.iter().flatten()).map(Vec::len).sum();
    for cfg in ["RB_8", "SMS"] {
        let t = std::time::Instant::now();
        let r = run(cfg, work.clone());
        let s = t.elapsed().as_secs_f64();
        eprintln!(
            "{cfg}: {ops} ops, {} cycles ({} evaluated) in {s:.2} s: {:.0} cycles/s, {:.0} evaluated/s, {:.0} ops/s",
            r.cycles,
            r.evaluated_cycles,
            r.cycles as f64 / s,
            r.evaluated_cycles as f64 / s,
            ops as f64 / s
        );
    }
}

#[test]
fn probes_name_every_unit_and_progress_is_reported() {
    use rtl::trace::{Probe, Snapshot};
    let gpu = Gpu::paper(Config::sms()).unwrap();
    let mut s = Snapshot::default();
    gpu.probe(&mut s);
    assert_eq!(gpu.memory().params().l1d_bytes, 56 << 10, "SMS carves 8 KB out of 64 KB");
    for path in [
        "sm0.rt_unit.warp_buffer.warp[0].valid",
        "sm0.rt_unit.warp_buffer.warp[3].thread[31].state",
        "sm7.rt_unit.scheduler.greedy",
        "sm0.rt_unit.port.req_node",
        "sm0.rt_unit.node_fetch.queue",
        "sm0.rt_unit.stack_manager.warp[0].thread[0].top",
        "sm0.rt_unit.bank_arbiter.conflict",
        "sm0.rt_unit.mem_sched.queue",
        "mem.l2.mshr_occupancy",
    ] {
        assert!(s.get(path).is_some(), "{path}");
    }
    let mut calls = Vec::new();
    let r = gpu.run_with_progress(jobs(7, 4, 45), &mut NullSink, 1000, |p| calls.push(p.cycle)).unwrap();
    assert!(calls.len() as u64 >= r.cycles / 1000 / 2 && calls.windows(2).all(|w| w[0] < w[1]));
}

/// Planted stack-manager bugs, run through whole GPUs: each must stop the run with an error
/// (a wrong pop, a refused command or a warp leaving entries behind), never pass or panic.
/// (`FlushKeepsCount` is left out: it changes only the Flush counter, which no pop can see; the
/// proofs crate's invariants catch it.)
#[test]
fn planted_stack_bugs_stop_the_run() {
    use rtl::stack_manager::Mutant;
    let work = jobs(8, 8, 45);
    let cases = [
        (Mutant::QueueWrapOffByOne, "RB_2+SH_4"),
        (Mutant::ReloadWrongEntry, "RB_2+SH_4"),
        (Mutant::SpillDropsEntry, "RB_2+SH_4"),
        (Mutant::MissingGlobalReload, "RB_2+SH_4"),
        (Mutant::SkipOverflowClear, "RB_2+SH_4"),
        (Mutant::EarlyRelease, "RB_2+SH_4+SK+RA"),
        // Only the exit check sees it: a released stack left with its rank.
        (Mutant::PriorityKeptOnRelease, "RB_2+SH_4+SK+RA"),
    ];
    for (m, cfg) in cases {
        let c: Config = cfg.parse().unwrap();
        let clean = Gpu::paper(c).unwrap().run(work.clone(), &mut NullSink);
        assert!(clean.is_ok(), "{cfg}: {clean:?}");
        let r = Gpu::paper_with(c, m.policy()).unwrap().run(work.clone(), &mut NullSink);
        assert!(
            matches!(
                r,
                Err(RunError::PopMismatch { .. } | RunError::Stack { .. } | RunError::ExitNotEmpty { .. })
            ),
            "{m:?} on {cfg}: {r:?}"
        );
    }
}

/// The port gives the stack's requests priority over queued node pieces. RB_2, no SH: lane 0
/// pushes three entries (the third spills the oldest to global memory) and pops them, while
/// lanes 1–31 each fetch their own sector. Derivation: header until 4; cycle 5 the warp is
/// scheduled (31 pieces, sent from 6) and lane 0 pushes 1; 6 pushes 2; 7 pushes 3, which plans
/// a global store; 8 the sequencer issues it to the memory scheduler; 9 the port sends it
/// instead of a node piece, and the sequencer is free again, so lane 0 pops 3, planning a
/// reload of 1; 10 the reload is issued; 11 the port sends it. The 31 node pieces take cycles
/// 6–8, 10 and 12–38. (Posted stores: the `Overlapped` timing; with `Blocking` the pop waits
/// for the store's acknowledgement, see `blocking_stores_wait_for_the_l2_ack`.)
#[test]
fn stack_requests_go_before_node_pieces() {
    let mut lanes: Vec<Option<Vec<RayOp>>> = (0..32)
        .map(|l| Some(vec![RayOp::Visit { addr: 0x8000 + 32 * l, kind: NodeKind::Triangle, bytes: 32 }]))
        .collect();
    lanes[0] = Some([1, 2, 3].map(RayOp::Push).into_iter().chain([3, 2, 1].map(RayOp::Pop)).collect());
    let cfg: Config = "RB_2".parse().unwrap();
    let run = |path| {
        let mut watch = Watch::new(path);
        let job = WarpJob { lanes: lanes.clone(), walk: None };
        Gpu::new(cfg, RtParams::default(), StackParams::default().overlapped(), one_sm())
            .unwrap()
            .run(vec![job], &mut watch)
            .unwrap();
        watch.changes
    };
    assert_eq!(run("sm0.rt_unit.port.req_stack"), [(0, 0), (9, 1), (10, 0), (11, 1), (12, 0)]);
    assert_eq!(
        run("sm0.rt_unit.port.req_node"),
        [(0, 0), (6, 1), (9, 0), (10, 1), (11, 0), (12, 1), (39, 0)]
    );
}

#[test]
fn residence_times_account_for_every_job() {
    let cfg: Config = "RB_8+SH_8+SK+RA".parse().unwrap();
    let work = jobs(21, 40, 3);
    let n = work.len();
    let mut residence = Vec::new();
    let gpu =
        Gpu::new(cfg, RtParams::default(), StackParams::default(), carve_out(&cfg, small_l2())).unwrap();
    let r = gpu.run_timed(work, &mut NullSink, u64::MAX, |_| {}, &mut residence).unwrap();
    assert_eq!(residence.len(), n, "one time per job, in launch order");
    assert!(residence.iter().all(|&c| c > 0 && c < r.cycles), "{residence:?}");
    // At most sms × warps jobs are resident at once, and the buffers are busy most of the run.
    let slots = u64::from(small_l2().sms * cfg.warps);
    let busy: u64 = residence.iter().sum();
    assert!(busy <= slots * r.cycles, "{busy} > {slots} slots × {} cycles", r.cycles);
    // A job alone in the GPU resides from its load to the cycle its slot frees: the hand-worked
    // single ray loads at the end of cycle 0 and frees in cycle 821.
    let lone = jobs(5, 1, 3);
    let mut one = Vec::new();
    let r1 = Gpu::new(cfg, RtParams::default(), StackParams::default(), carve_out(&cfg, one_sm()))
        .unwrap()
        .run_timed(lone, &mut NullSink, u64::MAX, |_| {}, &mut one)
        .unwrap();
    assert_eq!(one.len(), 1);
    assert!(one[0] + 3 >= r1.cycles && one[0] < r1.cycles, "{} of {} cycles", one[0], r1.cycles);
}

/// Lane 0 alone on one SM, RB_2 (no SH: a spill goes straight to global memory): push 1, 2, 3
/// (the third spills 1), pop 3 (reloads 1 into the RB), visit a fresh 32-byte triangle, pop 2,
/// pop 1. Returns, per watched signal, its changes.
fn spill_then_fetch(stack: StackParams, paths: &[&'static str]) -> (GpuReport, Vec<Vec<(u64, u64)>>) {
    let mut ops: Vec<RayOp> = [1, 2, 3].map(RayOp::Push).into();
    ops.push(RayOp::Pop(3));
    ops.push(RayOp::Visit { addr: 0x9000, kind: NodeKind::Triangle, bytes: 32 });
    ops.extend([2, 1].map(RayOp::Pop));
    let cfg: Config = "RB_2".parse().unwrap();
    let mut report = None;
    let changes = paths
        .iter()
        .map(|&p| {
            let mut watch = Watch::new(p);
            let gpu = Gpu::new(cfg, RtParams::default(), stack, one_sm()).unwrap();
            report = Some(gpu.run(vec![single_warp(ops.clone())], &mut watch).unwrap());
            watch.changes
        })
        .collect();
    (report.unwrap(), changes)
}

const PORT_STACK: &str = "sm0.rt_unit.port.req_stack";
const PORT_NODE: &str = "sm0.rt_unit.port.req_node";
/// 0 none, 1 push, 2 pop, 3 finish: the command the stack manager accepted in a cycle.
const CMD: &str = "sm0.rt_unit.stack_manager.warp[0].thread[0].cmd_kind";

/// With `Blocking` a global store completes only when the L2's
/// acknowledgement comes back through the response FIFO, so the thread's next stack command
/// waits for it. `spill_then_fetch`, derived by hand (memory defaults: a store is acknowledged
/// `l2_latency` = 160 cycles after the L1D takes it, as a load that hits in L2 answers):
///
/// - Both: header until 4; pushes accepted in 5, 6, 7; the push in 7 plans the global store of 1;
///   8 the sequencer issues it; 9 the port sends it.
/// - Overlapped: the store is posted, the sequencer is idle after 8, so the pop is accepted in 9.
/// - Blocking: the ack is visible in 9 + 160 = 169 and enters the response FIFO; 170 the FIFO
///   delivers it; 171 the sequencer completes the store; 172 the pop is accepted.
#[test]
fn blocking_stores_wait_for_the_l2_ack() {
    let (_, old) = spill_then_fetch(StackParams::default().overlapped(), &[CMD, PORT_STACK]);
    let (_, new) = spill_then_fetch(StackParams::default(), &[CMD, PORT_STACK]);
    let pop_at = |c: &[(u64, u64)]| c.iter().find(|&&(_, k)| k == 2).unwrap().0;
    assert_eq!((pop_at(&old[0]), pop_at(&new[0])), (9, 172));
    // The store leaves through the port in cycle 9 in both.
    assert_eq!((old[1][1], new[1][1]), ((9, 1), (9, 1)));
}

/// With `Blocking` the node fetch after a pop that reloads from global memory
/// waits for the reload; with `Overlapped` it goes right after. `spill_then_fetch`, by hand
/// (continuing `blocking_stores_wait_for_the_l2_ack`; the reload hits in L2: 160 cycles; the
/// triangle is a fresh line: L1D and L2 miss, 260 cycles):
///
/// - Overlapped: pop accepted in 9 (→ Fetch); 10 the warp is scheduled (one piece queued) and
///   the sequencer issues the reload; 11 the port sends the reload (stack first), 12 the node
///   piece. 12 + 260 = 272 the piece is back: Busy (8) until 280, → Stack; pops in 281, 282;
///   finish 283; the slot frees in 284; the run ends at 285.
/// - Blocking: pop accepted in 172; 173 the reload is issued (the lane waits in Fetch, not
///   schedulable); 174 the port sends it; 334 back, into the FIFO; 335 delivered; 336 the
///   sequencer completes the load and moves the entry to the RB bottom: idle; 337 the warp is
///   scheduled; 338 the port sends the node piece; 598 back; Busy until 606; pops 607, 608;
///   finish 609; frees 610; ends 611.
#[test]
fn blocking_node_fetch_waits_for_the_reload() {
    let (old_r, old) = spill_then_fetch(StackParams::default().overlapped(), &[PORT_STACK, PORT_NODE, CMD]);
    let (new_r, new) = spill_then_fetch(StackParams::default(), &[PORT_STACK, PORT_NODE, CMD]);
    assert_eq!(old[0], [(0, 0), (9, 1), (10, 0), (11, 1), (12, 0)], "store, reload");
    assert_eq!(old[1], [(0, 0), (12, 1), (13, 0)], "node piece right after the reload");
    assert_eq!(new[0], [(0, 0), (9, 1), (10, 0), (174, 1), (175, 0)]);
    assert_eq!(new[1], [(0, 0), (338, 1), (339, 0)], "node piece after the reload is back");
    let finish_at = |c: &[(u64, u64)]| c.iter().find(|&&(_, k)| k == 3).unwrap().0;
    assert_eq!((finish_at(&old[2]), finish_at(&new[2])), (283, 609));
    assert_eq!((old_r.cycles, new_r.cycles), (285, 611));
    assert_eq!((old_r.pops_checked, new_r.pops_checked), (3, 3));
}

/// RB_FULL moves no entry, so the stack sequencer is idle in the cycle after every command and
/// both timings give the same run, cycle for cycle (SH latency plays no part either).
#[test]
fn stack_timing_is_invisible_without_stack_traffic() {
    assert_eq!(StackParams::default().timing, StackTiming::Blocking, "the paper's timing is the default");
    let work = jobs(11, 16, 45);
    let old = run_with("RB_FULL", small_l2(), StackParams::default().overlapped(), work.clone()).unwrap();
    let new = run_with("RB_FULL", small_l2(), StackParams::default(), work.clone()).unwrap();
    assert_eq!(old, new);
    // With traffic the timings differ (and Blocking is slower).
    let old = run_with("RB_2+SH_4", small_l2(), StackParams::default().overlapped(), work.clone()).unwrap();
    let new = run_with("RB_2+SH_4", small_l2(), StackParams::default(), work).unwrap();
    assert!(new.cycles > old.cycles, "{} vs {}", new.cycles, old.cycles);
    assert_eq!((old.stack, old.pops_checked), (new.stack, new.pops_checked), "same traffic");
}

/// The SH latency alone (Overlapped, so only `sh_latency` differs): RB_2+SH_4, lane 0 pushes
/// 1, 2, 3; the third spills 1 to SH (one SH store), and the next push waits for it. Accepted
/// in 5, 6, 7; the store is issued in 8 and completes `sh_latency` cycles later (the sequencer
/// is idle after that cycle), so the fourth push is accepted in 8 + sh_latency + 1: 11 with the
/// old 2, 29 with Vulkan-Sim's 20.
#[test]
fn sh_accesses_take_the_shared_memory_latency() {
    let mut ops: Vec<RayOp> = [1, 2, 3, 4].map(RayOp::Push).into();
    ops.extend([4, 3, 2, 1].map(RayOp::Pop));
    let cfg: Config = "RB_2+SH_4".parse().unwrap();
    let pushes = |sh_latency: u32| {
        let mut watch = Watch { every: true, ..Watch::new(CMD) };
        let stack = StackParams { sh_latency, ..StackParams::default().overlapped() };
        Gpu::new(cfg, RtParams::default(), stack, one_sm())
            .unwrap()
            .run(vec![single_warp(ops.clone())], &mut watch)
            .unwrap();
        watch.changes.iter().filter(|&&(_, k)| k == 1).map(|c| c.0).collect::<Vec<_>>()
    };
    assert_eq!(pushes(2), [5, 6, 7, 11]);
    assert_eq!(pushes(20), [5, 6, 7, 29]);
    let e = StackParams { sh_latency: 1, ..StackParams::default() }.validate().unwrap_err();
    assert_eq!(e.parameter, "sh_latency");
}

/// The paper's "off-chip accesses" are requests leaving the SM for L2. A ray that fetches `n`
/// distinct 32-byte sectors sends exactly `n` requests down; the same ray again on the same SM
/// hits its L1D and sends none. Pushes beyond RB_1 spill: with a write-through L1D every spilled
/// entry's store leaves the SM, so the stack's L2 requests are at least the entries spilled.
#[test]
fn l2_requests_count_what_leaves_the_sm() {
    let visits: Vec<RayOp> = (0..6)
        .map(|i| RayOp::Visit { addr: 0x10_0000 + i * 0x1000, kind: NodeKind::Internal, bytes: 32 })
        .collect();
    let once = run_with("RB_8", one_sm(), StackParams::default(), vec![single_warp(visits.clone())]).unwrap();
    assert_eq!((once.l2_node, once.l2_stack, once.dram_node), (6, 0, 6));
    let twice = run_with(
        "RB_8",
        one_sm(),
        StackParams::default(),
        vec![single_warp(visits.clone()), single_warp(visits.clone())],
    )
    .unwrap();
    assert_eq!(twice.l2_node, 6, "the second ray hits the L1D: nothing more leaves the SM");
    assert_eq!(twice.node_fetches, 12);

    let mut deep = vec![visits[0]];
    deep.extend((1..=4).map(|i| RayOp::Push(0x20_0000 + i * 0x1000)));
    deep.extend((1..=4).rev().flat_map(|i| {
        let a = 0x20_0000 + i * 0x1000;
        [RayOp::Pop(a), RayOp::Visit { addr: a, kind: NodeKind::Triangle, bytes: 32 }]
    }));
    let r = run_with("RB_1", one_sm(), StackParams::default(), vec![single_warp(deep.clone())]).unwrap();
    let spilled = r.stack.rb_to_global;
    assert!(spilled >= 3, "4 pushes into 1 entry spill at least 3: {spilled}");
    assert!(r.l2_stack >= spilled, "every spill store leaves the SM: {} < {spilled}", r.l2_stack);
    assert_eq!(r.l2_node, 5, "root and four triangles, each a distinct sector");
    let full = run_with("RB_FULL", one_sm(), StackParams::default(), vec![single_warp(deep)]).unwrap();
    assert_eq!((full.l2_stack, full.l2_node), (0, 5), "no spills, no stack requests");
}

/// Lane 0 alone on one SM: pushes 1, 2, 3 on `cfg` (the third spills 1), then visits a fresh
/// 32-byte triangle, then pops 3, 2, 1. Returns the cycle the node piece leaves through the port.
fn push_spill_then_fetch(cfg: &str, stack: StackParams) -> u64 {
    let mut ops: Vec<RayOp> = [1, 2, 3].map(RayOp::Push).into();
    ops.push(RayOp::Visit { addr: 0x9000, kind: NodeKind::Triangle, bytes: 32 });
    ops.extend([3, 2, 1].map(RayOp::Pop));
    let cfg: Config = cfg.parse().unwrap();
    let mut watch = Watch::new(PORT_NODE);
    let r = Gpu::new(cfg, RtParams::default(), stack, carve_out(&cfg, one_sm()))
        .unwrap()
        .run(vec![single_warp(ops)], &mut watch)
        .unwrap();
    assert_eq!(r.pops_checked, 3);
    watch.changes.iter().find(|c| c.1 == 1).unwrap().0
}

/// RB_2: the third push spills 1 to global memory (a global store). By hand (as
/// `blocking_stores_wait_for_the_l2_ack`): pushes accepted in 5, 6, 7; the sequencer issues the
/// store in 8, the port sends it in 9. Acknowledged (`acked`, and `sh-posted`, which posts only
/// SH stores): the ack completes the store in 171, the lane is scheduled in 172 and its piece
/// leaves in 173. Posted: the only work left in 8 is the store, which is posted, so the lane is
/// scheduled in 8; the port sends the store in 9 (stack first) and the piece in 10.
#[test]
fn posted_global_stores_let_the_fetch_go_before_the_ack() {
    let at = |g: StoreGating| {
        push_spill_then_fetch("RB_2", StackParams { store_gating: g, ..StackParams::default() })
    };
    assert_eq!(at(StoreGating::Acked), 173);
    assert_eq!(at(StoreGating::ShPosted), 173, "a global store still waits for its ack");
    assert_eq!(at(StoreGating::Posted), 10);
    // A posted store needs no acknowledgement: the next stack command (a fourth push, spilling
    // again) is accepted in 9, where an acknowledged one waits for the ack until 172 (as in
    // `blocking_stores_wait_for_the_l2_ack`).
    let fourth_push = |g: StoreGating| {
        let mut ops: Vec<RayOp> = [1, 2, 3, 4].map(RayOp::Push).into();
        ops.extend([4, 3, 2, 1].map(RayOp::Pop));
        let cfg: Config = "RB_2".parse().unwrap();
        let mut watch = Watch { every: true, ..Watch::new(CMD) };
        let stack = StackParams { store_gating: g, ..StackParams::default() };
        Gpu::new(cfg, RtParams::default(), stack, one_sm())
            .unwrap()
            .run(vec![single_warp(ops)], &mut watch)
            .unwrap();
        watch.changes.iter().filter(|c| c.1 == 1).nth(3).unwrap().0
    };
    assert_eq!((fourth_push(StoreGating::Acked), fourth_push(StoreGating::ShPosted)), (172, 172));
    assert_eq!(fourth_push(StoreGating::Posted), 9);
}

/// RB_2+SH_4: the third push spills 1 to SH (one SH store, `sh_latency` 20). Pushes accepted in
/// 5, 6, 7; the sequencer issues the SH store in 8 and completes it 20 cycles later, idle after
/// 28. Acked: the lane is scheduled in 29, its piece leaves in 30. Both posted gatings: the only
/// work left is the SH store, so the lane is scheduled in 8 (the cycle the store issues) and its
/// piece leaves in 9.
#[test]
fn posted_sh_stores_let_the_fetch_go_before_the_sh_store_completes() {
    let at = |g: StoreGating| {
        push_spill_then_fetch("RB_2+SH_4", StackParams { store_gating: g, ..StackParams::default() })
    };
    assert_eq!(at(StoreGating::Acked), 30);
    assert_eq!(at(StoreGating::ShPosted), 9);
    assert_eq!(at(StoreGating::Posted), 9);
}

/// `spill_then_fetch` with `Overlapped` timing: in 10 the warp is scheduled (its piece queued for
/// 11) and the sequencer issues the reload (queued for 11). With the stack first the reload
/// leaves in 11 and the piece in 12; with Vulkan-Sim's order the piece under way goes first, in
/// 11, and the reload in 12.
#[test]
fn node_first_port_serves_the_fetch_under_way_before_the_stack() {
    let with = |p: PortPriority| StackParams { port_priority: p, ..StackParams::default().overlapped() };
    let (_, stack) = spill_then_fetch(with(PortPriority::Stack), &[PORT_STACK, PORT_NODE]);
    let (_, node) = spill_then_fetch(with(PortPriority::Node), &[PORT_STACK, PORT_NODE]);
    assert_eq!(stack[0], [(0, 0), (9, 1), (10, 0), (11, 1), (12, 0)], "store, reload");
    assert_eq!(stack[1], [(0, 0), (12, 1), (13, 0)]);
    assert_eq!(node[0], [(0, 0), (9, 1), (10, 0), (12, 1), (13, 0)], "the reload waits for the piece");
    assert_eq!(node[1], [(0, 0), (11, 1), (12, 0)]);
}

/// Many warps on one SM: GTO and oldest-first issue warps in different orders, and move the same
/// stack traffic.
#[test]
fn oldest_first_changes_which_warp_fetches_next() {
    let issues = |select: WarpSelect| {
        let cfg: Config = "RB_4".parse().unwrap();
        let mut watch = Watch { every: true, ..Watch::new("sm0.rt_unit.scheduler.issue_warp") };
        let rt = RtParams { warp_select: select, ..RtParams::default() };
        let r = Gpu::new(cfg, rt, StackParams::default(), carve_out(&cfg, one_sm()))
            .unwrap()
            .run(jobs(5, 8, 45), &mut watch)
            .unwrap();
        (r, watch.changes)
    };
    let (gto, gto_issues) = issues(WarpSelect::Gto);
    let (oldest, oldest_issues) = issues(WarpSelect::Oldest);
    assert_ne!(gto_issues, oldest_issues, "the issue order differs");
    assert_eq!((gto.stack, gto.pops_checked), (oldest.stack, oldest.pops_checked), "same traffic");
}

/// RB_1, posted stores: every push after the first spills one global store. With
/// `store_queue = 1` a push is taken only while no store waits for the port, so the run takes
/// longer than unbounded and the scheduler's queue never holds more stores than one command
/// adds after the bound.
#[test]
fn a_full_store_queue_holds_stack_commands() {
    let mut ops: Vec<RayOp> = (1..=12).map(RayOp::Push).collect();
    ops.extend((1..=12).rev().map(RayOp::Pop));
    let cfg: Config = "RB_1".parse().unwrap();
    let run = |store_queue: u32| {
        let stack = StackParams { store_gating: StoreGating::Posted, store_queue, ..StackParams::default() };
        let gpu = Gpu::new(cfg, RtParams::default(), stack, carve_out(&cfg, one_sm())).unwrap();
        let job = WarpJob { lanes: (0..32).map(|_| Some(ops.clone())).collect(), walk: None };
        let mut watch = Watch::new("sm0.rt_unit.mem_sched.queue");
        let r = gpu.run(vec![job], &mut watch).unwrap();
        (r, watch.changes.iter().map(|c| c.1).max().unwrap())
    };
    let (free, free_queue) = run(0);
    let (held, held_queue) = run(1);
    assert!(held.cycles > free.cycles, "{} vs {}", held.cycles, free.cycles);
    assert!(free_queue > 32, "unbounded: stores pile up ({free_queue})");
    assert!(held_queue <= 32, "one store per lane past the bound at most ({held_queue})");
    assert_eq!(held.stack, free.stack);
    let e = StackParams { store_queue: 1 << 16, ..StackParams::default() }.validate().unwrap_err();
    assert_eq!(e.parameter, "store_queue");
}
