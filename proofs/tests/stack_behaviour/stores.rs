//! Global stores and the sequencer: an acknowledged store holds it until the acknowledgement,
//! and acknowledged requests bound the memory scheduler's queue.

use rtl::config::Config;
use rtl::stack_manager::{Cmd, StackTiming};
use rtl::stack_unit::StandaloneStack;

/// RB_2, no SH, global latency 10: pushes 1, 2, 3 (the third spills 1 to global memory),
/// then pops 3, 2, 1. Returns the cycle the first pop is accepted. By hand: pushes in cycles
/// 0, 1, 2; the sequencer issues the store in 3. Posted (Overlapped): it is idle after that,
/// so the pop goes in 4. Acknowledged (Blocking): the scheduler sends the store in 4, the
/// memory reports the ack in 4 + 10 = 14, the FIFO takes it in 15 and delivers it in 16, the
/// sequencer completes the store in 17, the pop goes in 18.
fn pop_cycle(timing: StackTiming) -> u64 {
    let cfg: Config = "RB_2".parse().unwrap();
    let mut u = StandaloneStack::with_timing(cfg, 10, timing, 2).unwrap();
    for v in [1, 2, 3] {
        u.step(&[(0, Cmd::Push(v))]);
    }
    while !u.manager().ready(0) {
        u.step(&[]);
    }
    let at = u.cycle;
    u.step(&[(0, Cmd::Pop)]);
    assert_eq!(u.answer(0), Ok(Some(3)));
    for want in [2, 1] {
        while !u.manager().ready(0) {
            u.step(&[]);
        }
        u.step(&[(0, Cmd::Pop)]);
        assert_eq!(u.answer(0), Ok(Some(want)), "the spilled entry comes back");
    }
    while !u.idle() {
        u.step(&[]);
    }
    at
}

#[test]
fn acknowledged_stores_hold_the_sequencer_until_the_ack() {
    assert_eq!(pop_cycle(StackTiming::Overlapped), 4);
    assert_eq!(pop_cycle(StackTiming::Blocking), 18);
}

/// Every thread of RB_1 pushes whenever it is ready, so every push after the first spills.
/// Returns the most requests the memory scheduler's queue held.
fn fullest_queue(timing: StackTiming) -> usize {
    let cfg: Config = "RB_1".parse().unwrap();
    let threads = cfg.threads();
    let mut u = StandaloneStack::with_timing(cfg, 50, timing, 2).unwrap();
    let mut cmds = Vec::new();
    for cycle in 0..2000u64 {
        cmds.clear();
        cmds.extend((0..threads).filter(|&t| u.manager().ready(t)).map(|t| (t, Cmd::Push(cycle))));
        u.step(&cmds);
    }
    u.unit.sched.max_queue
}

/// The scheduler's queue holds one request per thread when each waits for its response
/// (`Widths::gm_queue`); posted stores pile up past that, which is why their queue is given
/// `GM_POSTED_QUEUE_BITS`.
#[test]
fn acknowledged_requests_bound_the_scheduler_queue_by_the_threads() {
    let cfg: Config = "RB_1".parse().unwrap();
    let (threads, bits) = (cfg.threads() as usize, cfg.widths().unwrap().gm_queue);
    let blocking = fullest_queue(StackTiming::Blocking);
    assert!(blocking <= threads && blocking < 1 << bits, "{blocking} queued, {threads} threads");
    assert!(blocking > threads / 2, "the run does fill the queue ({blocking})");
    let posted = fullest_queue(StackTiming::Overlapped);
    assert!(posted > threads, "posted stores: {posted} queued, {threads} threads");
}
