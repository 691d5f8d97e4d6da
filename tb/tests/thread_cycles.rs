//! Where the RT units' thread-cycles go (`rtl::thread_cycles`), on real scenes: every thread slot
//! of every RT unit is in one category in every cycle; each category holds exactly the slots a
//! waveform of every thread's state and stack sequencer puts there, cycle by cycle; the runners
//! agree; and the designs differ where they must.

use rtl::clock::EvalCheck;
use rtl::config::Config;
use rtl::gpu::GpuReport;
use rtl::ray_op::WarpJob;
use rtl::stack_manager::StackTiming;
use rtl::thread_cycles::ThreadCycles;
use rtl::thread_fsm::ThreadState;
use rtl::trace::Sink;
use tb::run::sim::Hardware;

mod common;
use common::{gpu, report, scene_jobs};

fn run(cfg: &str, hw: &Hardware, jobs: &[WarpJob]) -> GpuReport {
    let cfg: Config = cfg.parse().unwrap();
    report(gpu(cfg, hw), jobs.iter().cloned(), &cfg.name())
}

/// Thread slots of the whole GPU of `cfg` on `hw`.
fn slots(cfg: &str, hw: &Hardware) -> u64 {
    let cfg: Config = cfg.parse().unwrap();
    u64::from(hw.mem.sms) * u64::from(cfg.threads())
}

fn share(t: &ThreadCycles, part: u64) -> f64 {
    part as f64 / t.total() as f64
}

/// Every slot in every cycle in exactly one category: the categories add up to cycles × slots
/// (idle is the rest; a report fails if the other four overfill an RT unit's slots), and none is empty on a real
/// scene where rays wait for memory, for the port, on their stacks and in operation units.
#[test]
fn the_categories_fill_every_slot_in_every_cycle() {
    let hw = Hardware::default();
    for scene in ["clutter", "wknd"] {
        let jobs = scene_jobs(scene, 16);
        for cfg in Config::paper_set() {
            let name = cfg.name();
            let r = run(&name, &hw, &jobs);
            let t = r.thread_cycles;
            assert_eq!(t.total(), r.cycles * slots(&name, &hw), "{scene} {name}: {t:?}");
            assert!(
                t.node_data > 0 && t.fetch_queue > 0 && t.latency > 0 && t.idle > 0,
                "{scene} {name}: {t:?}"
            );
            assert!(t.stack > 0, "{scene} {name}: every ray pushes and pops");
        }
    }
}

/// The breakdown does not depend on how the run was driven: the windowed run (one thread and
/// two), the reference loop, the loop stepping every cycle (no idle skip) and the loop
/// evaluating every unit every cycle count the same thread-cycles, though they evaluate each
/// RT unit in different cycles.
#[test]
fn every_runner_counts_the_same_thread_cycles() {
    let jobs = scene_jobs("clutter", 16);
    let mut stepped = Hardware::default();
    stepped.idle_skip = false;
    for name in ["RB_2", "RB_8", "SMS"] {
        let cfg: Config = name.parse().unwrap();
        let hw = Hardware::default();
        let windowed = run(name, &hw, &jobs);
        let runs = [
            ("two threads", report(gpu(cfg, &hw).with_helper_thread(true), jobs.clone(), name)),
            ("reference loop", report(gpu(cfg, &hw).with_windows(false), jobs.clone(), name)),
            ("no idle skip", report(gpu(cfg, &stepped), jobs.clone(), name)),
            ("every unit", report(gpu(cfg, &hw).with_eval_check(EvalCheck::EveryUnit), jobs.clone(), name)),
        ];
        for (how, r) in &runs {
            assert_eq!(r.thread_cycles, windowed.thread_cycles, "{name}, {how}");
            assert_eq!(r.cycles, windowed.cycles, "{name}, {how}");
        }
        // The runs evaluate different cycles, else the comparison would show nothing.
        let stepping = &runs[2].1;
        assert!(stepping.evaluated_cycles == stepping.cycles && windowed.evaluated_cycles < stepping.cycles);
    }
}

/// A waveform sink that sorts every thread slot into a category in every cycle from what the
/// waveform shows: the thread's `state` (warp buffer) and its sequencer's `busy` (stack manager),
/// with the rule written out independently: Done idle, Busy latency, WaitMem node data, Stack
/// stack, Fetch stack while its sequencer is busy under Blocking timing with acknowledged stores,
/// else fetch queue.
struct Oracle {
    warp_size: usize,
    blocking: bool,
    /// Per SM, per thread: state code and sequencer busy, as the last walk showed them.
    state: Vec<Vec<u64>>,
    busy: Vec<Vec<u64>>,
    scope: Vec<String>,
    /// The cycle of the walk under way.
    walk: Option<u64>,
    /// Cycles walked, in order.
    walked: Vec<u64>,
    /// Each walk's census (the registers after its edge: the next cycle's).
    censuses: Vec<ThreadCycles>,
    /// Slot-cycles waiting to fetch while the sequencer was busy (what Blocking holds back).
    held: u64,
    end: Option<u64>,
}

impl Oracle {
    fn new(sms: usize, threads: usize, warp_size: usize, blocking: bool) -> Oracle {
        Oracle {
            warp_size,
            blocking,
            state: vec![vec![0; threads]; sms],
            busy: vec![vec![0; threads]; sms],
            scope: Vec::new(),
            walk: None,
            walked: Vec::new(),
            censuses: Vec::new(),
            held: 0,
            end: None,
        }
    }

    fn index(&self, prefix: &str) -> Option<usize> {
        self.scope.iter().rev().find_map(|s| s.strip_prefix(prefix)?.strip_suffix(']')?.parse().ok())
    }

    fn sm(&self) -> usize {
        self.scope.iter().find_map(|s| s.strip_prefix("sm")?.parse().ok()).expect("inside an SM")
    }

    fn finish_walk(&mut self) {
        if self.walk.take().is_none() {
            return;
        }
        let mut c = ThreadCycles::default();
        for (states, busy) in self.state.iter().zip(&self.busy) {
            for (&s, &b) in states.iter().zip(busy) {
                self.held += u64::from(s == ThreadState::FETCH && b == 1);
                let slot = match s {
                    ThreadState::DONE => &mut c.idle,
                    ThreadState::BUSY => &mut c.latency,
                    ThreadState::WAIT_MEM => &mut c.node_data,
                    ThreadState::STACK => &mut c.stack,
                    ThreadState::FETCH if self.blocking && b == 1 => &mut c.stack,
                    ThreadState::FETCH => &mut c.fetch_queue,
                    other => panic!("state code {other}"),
                };
                *slot += 1;
            }
        }
        self.censuses.push(c);
    }

    /// The thread-cycles of the run: cycle 0 all idle (nothing has landed), then cycle c + 1 as
    /// the walk of cycle c left the registers, up to the last cycle of the run.
    fn thread_cycles(&self) -> ThreadCycles {
        let end = self.end.expect("the run ended");
        assert_eq!(self.walked, (0..end).collect::<Vec<_>>(), "every cycle walked once");
        let slots = self.state.iter().map(Vec::len).sum::<usize>() as u64;
        let mut t = ThreadCycles { idle: slots, ..Default::default() };
        for c in &self.censuses[..end as usize - 1] {
            t.add(c);
        }
        t
    }
}

impl Sink for Oracle {
    fn enabled(&self) -> bool {
        true
    }

    fn end_run(&mut self, cycles: u64) {
        self.finish_walk();
        self.end = Some(cycles);
    }

    fn begin_cycle(&mut self, cycle: u64) {
        self.finish_walk();
        self.walk = Some(cycle);
        self.walked.push(cycle);
    }

    fn push_scope(&mut self, name: &str) {
        self.scope.push(name.to_owned());
    }

    fn pop_scope(&mut self) {
        self.scope.pop();
    }

    fn signal(&mut self, name: &str, _width: u32, value: u64) {
        let table = match name {
            "state" if self.scope.iter().any(|s| s == "warp_buffer") => 0,
            "busy" if self.scope.iter().any(|s| s == "stack_manager") => 1,
            _ => return,
        };
        let (Some(w), Some(l)) = (self.index("warp["), self.index("thread[")) else { return };
        let (sm, t) = (self.sm(), w * self.warp_size + l);
        if table == 0 {
            self.state[sm][t] = value;
        } else {
            self.busy[sm][t] = value;
        }
    }
}

/// Each category holds exactly the thread-cycles the waveform puts there, cycle by cycle and
/// thread by thread: with Blocking timing (a fetch waits for its spills' acknowledgements, so
/// lanes are held back from the scheduler) and with Overlapped timing (nothing holds a fetch).
/// RB_2 spills to global memory all the time; SMS through its SH stacks.
#[test]
fn each_category_holds_the_slots_the_waveform_shows_there() {
    let jobs: Vec<WarpJob> = scene_jobs("clutter", 16).into_iter().take(24).collect();
    let mut hw = Hardware::default();
    hw.mem.sms = 2;
    let mut overlapped = hw;
    overlapped.stack.timing = StackTiming::Overlapped;
    for (timing, hw) in [("blocking", hw), ("overlapped", overlapped)] {
        for name in ["RB_2", "SMS"] {
            let cfg: Config = name.parse().unwrap();
            let blocking = hw.stack.timing == StackTiming::Blocking;
            let mut oracle =
                Oracle::new(hw.mem.sms as usize, cfg.threads() as usize, cfg.warp_size as usize, blocking);
            let r = gpu(cfg, &hw).run(jobs.iter().cloned(), &mut oracle).unwrap();
            let want = oracle.thread_cycles();
            assert_eq!(r.thread_cycles, want, "{timing} {name}");
            if blocking && name == "RB_2" {
                assert!(oracle.held > 0, "{name}: the sequencer must hold fetches back");
            }
        }
    }
}

/// The designs differ where they must: with a two-entry register-file stack a ray spills to
/// global memory on most pushes and waits for it, so a larger share of the thread-cycles goes
/// to the stack than with a stack that never spills (RB_FULL); with the stack off the critical
/// path (Overlapped timing: posted stores, the refill overlapping the fetch) a smaller share
/// than with Blocking, at the same SH latency.
#[test]
fn the_stack_share_follows_the_design() {
    let hw = Hardware::default();
    let jobs = scene_jobs("clutter", 16);
    let stack_share = |cfg: &str, hw: &Hardware| {
        let t = run(cfg, hw, &jobs).thread_cycles;
        share(&t, t.stack)
    };
    let (rb2, full) = (stack_share("RB_2", &hw), stack_share("RB_FULL", &hw));
    assert!(rb2 > 1.5 * full, "RB_2 {rb2:.4} vs RB_FULL {full:.4}");
    let mut overlapped = hw;
    overlapped.stack.timing = StackTiming::Overlapped;
    for cfg in ["RB_2", "RB_8+SH_8", "SMS"] {
        let (blocking, posted) = (stack_share(cfg, &hw), stack_share(cfg, &overlapped));
        assert!(posted < blocking, "{cfg}: overlapped {posted:.4} vs blocking {blocking:.4}");
    }
}
