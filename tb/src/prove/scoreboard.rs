//! The specification as a scoreboard beside the simulator: at every clock edge of every stack
//! manager, for each warp the cycle touched, the specification's cycle ([`spec_cycle`], run on
//! integers) is run from the registers as the cycle began with the cycle's commands and
//! completions, and its next state, requests and answers are compared with what the design
//! committed. Real runs then check decisions (where an entry goes, whether a command is
//! refused, when a micro-op issues), not only data.

use std::collections::VecDeque;

use rtl::logic::Int;
use rtl::stack_manager::cycle::WriteOf;
use rtl::stack_manager::{Cmd, Entry, Scoreboard, StackManager, StackRegsOf, StackStep, POISON};

use super::cycle::{spec_cycle, Outputs, RbEvent, RbState, SeqState, WarpState};
use rtl::stack_manager::policy::RbOp;

/// What the specification expects of one warp after the cycle.
struct Expected {
    warp: u32,
    state: WarpState<Int>,
    out: Outputs<u32, Entry>,
    /// The RBs the specification changed, as the cycle began: (lane, entries).
    rb: Vec<(usize, VecDeque<Entry>)>,
}

/// The cycles `--decisions sample` checks: one in this many.
pub const SAMPLE_EVERY: u64 = 64;

/// The scoreboard: the specification's cycle for every warp a cycle touches, on every
/// `every`-th cycle.
pub struct SpecBoard {
    expected: Vec<Expected>,
    every: u64,
    /// Cycles checked.
    pub cycles: u64,
}

impl SpecBoard {
    pub fn every(every: u64) -> SpecBoard {
        SpecBoard { expected: Vec::new(), every: every.max(1), cycles: 0 }
    }
}

/// The warp `w` of `sm` as the specification's register file; the global regions of the lanes
/// in `global` are read in full, the others are not needed this cycle.
fn snapshot(sm: &StackManager, w: u32, global: &[u32]) -> WarpState<Int> {
    let c = sm.config();
    let threads = sm.warp_threads(w);
    let m = c.sh_entries;
    WarpState {
        base: threads.start,
        m,
        acked: sm.acked_stores(),
        stacks: threads.clone().map(|t| *sm.stack(t)).collect(),
        threads: threads.clone().map(|t| *sm.thread(t)).collect(),
        seq: threads
            .clone()
            .map(|t| SeqState {
                inflight: sm.inflight_uop(t),
                queue: sm.pending_uops(t).map(|u| (true, *u)).collect(),
                latch: sm.latch(t),
            })
            .collect(),
        rb: threads
            .clone()
            .map(|t| {
                let rb = sm.rb(t);
                RbState {
                    len: rb.len() as u32,
                    front: rb.front().copied().unwrap_or(POISON),
                    back: rb.back().copied().unwrap_or(POISON),
                    log: Vec::new(),
                }
            })
            .collect(),
        sh: threads.clone().flat_map(|t| (0..m).map(move |e| sm.sh_entry(t, e))).collect(),
        global: threads
            .clone()
            .map(|t| if global.contains(&t) { sm.global_region(t).to_vec() } else { Vec::new() })
            .collect(),
        global_far: vec![POISON; c.warp_size as usize],
        global_writes: vec![Vec::new(); c.warp_size as usize],
        outside: StackRegsOf::default(),
    }
}

/// The thread a write or request of the cycle belongs to (a stack's owner for its registers).
fn touched(d: &StackStep, ws: u32) -> Vec<u32> {
    let j = d.journal();
    let mut warps: Vec<u32> = Vec::new();
    let mut add = |t: u32| {
        let w = t / ws;
        if !warps.contains(&w) {
            warps.push(w);
        }
    };
    j.done.iter().chain(j.deq.iter()).for_each(|&t| add(t));
    j.stacks.iter().for_each(|s| add(s.0));
    for x in &j.writes {
        match *x {
            WriteOf::Cmd(t, _)
            | WriteOf::Thread(t, _)
            | WriteOf::Rb(t, _)
            | WriteOf::RbPushFront(t, _)
            | WriteOf::Emit(t, _, _) => add(t),
            WriteOf::Global { thread, .. } | WriteOf::Seq { thread, .. } => add(thread),
            WriteOf::Sh { stack, .. } => add(stack),
        }
    }
    warps
}

impl Scoreboard for SpecBoard {
    fn before(&mut self, q: &StackManager, d: &StackStep) {
        let c = *q.config();
        let ws = c.warp_size;
        let j = d.journal();
        self.expected.clear();
        if j.now % self.every != 0 {
            return;
        }
        self.cycles += 1;
        for w in touched(d, ws) {
            let range = q.warp_threads(w);
            let inside = |t: &u32| range.contains(t);
            let cmds: Vec<(u32, Cmd)> = j
                .writes
                .iter()
                .filter_map(|x| match *x {
                    WriteOf::Cmd(t, c) if inside(&t) => Some((t, c)),
                    _ => None,
                })
                .collect();
            let done: Vec<u32> = j.done.iter().copied().filter(inside).collect();
            let deq = j.deq.filter(inside);
            let mut state = snapshot(q, w, &deq.into_iter().collect::<Vec<_>>());
            let out = spec_cycle(&mut Int, &c, &mut state, &cmds, &done, deq);
            let changed = state.rb.iter().enumerate().filter(|(_, r)| !r.log.is_empty());
            let rb = changed.map(|(k, _)| (k, q.rb(range.start + k as u32).clone())).collect();
            self.expected.push(Expected { warp: w, state, out, rb });
        }
    }

    fn after(&mut self, next: &StackManager, d: &StackStep) -> Option<String> {
        let c = *next.config();
        let ws = c.warp_size;
        let j = d.journal();
        for e in &self.expected {
            let at = |lane: u32, what: &str, design: String, spec: String| {
                format!(
                    "cycle {}, SM {}, warp {}, lane {lane} (thread {}): {what}: design {design}, specification {spec}",
                    j.now,
                    next.sm(),
                    e.warp,
                    e.warp * ws + lane
                )
            };
            for lane in 0..ws {
                let (k, t) = (lane as usize, e.warp * ws + lane);
                let x = &e.state;
                if *next.stack(t) != x.stacks[k] {
                    return Some(at(
                        lane,
                        "stack registers",
                        format!("{:?}", next.stack(t)),
                        format!("{:?}", x.stacks[k]),
                    ));
                }
                if *next.thread(t) != x.threads[k] {
                    let (a, b) = (format!("{:?}", next.thread(t)), format!("{:?}", x.threads[k]));
                    return Some(at(lane, "Overflow, spill pointer, done", a, b));
                }
                let xs = &x.seq[k];
                let same_queue =
                    next.pending_uops(t).copied().eq(xs.queue.iter().filter(|u| u.0).map(|u| u.1));
                if next.inflight_uop(t) != xs.inflight || next.latch(t) != xs.latch || !same_queue {
                    let queue =
                        |s: &SeqState<Int>| s.queue.iter().filter(|u| u.0).map(|u| u.1).collect::<Vec<_>>();
                    let design = format!(
                        "in flight {:?}, latch {:?}, queue {:?}",
                        next.inflight_uop(t),
                        next.latch(t),
                        next.pending_uops(t).collect::<Vec<_>>()
                    );
                    let spec =
                        format!("in flight {:?}, latch {:?}, queue {:?}", xs.inflight, xs.latch, queue(xs));
                    return Some(at(lane, "sequencer", design, spec));
                }
                for e2 in 0..c.sh_entries {
                    let (got, want) = (next.sh_entry(t, e2), x.sh[k * c.sh_entries as usize + e2 as usize]);
                    if got != want {
                        return Some(at(
                            lane,
                            &format!("SH word {e2}"),
                            format!("{got:#x}"),
                            format!("{want:#x}"),
                        ));
                    }
                }
                match e.rb.iter().find(|r| r.0 == k) {
                    Some((_, before)) => {
                        let mut rb = before.clone();
                        for ev in &x.rb[k].log {
                            match *ev {
                                RbEvent::Op(RbOp::PushBack(v)) => rb.push_back(v),
                                RbEvent::Op(RbOp::PopBack) => drop(rb.pop_back()),
                                RbEvent::Op(RbOp::PopFront) => drop(rb.pop_front()),
                                RbEvent::PushFront(v) => rb.push_front(v),
                            }
                        }
                        if *next.rb(t) != rb {
                            return Some(at(lane, "RB", format!("{:?}", next.rb(t)), format!("{rb:?}")));
                        }
                    }
                    // Unchanged by the specification: its length and ends as they were.
                    None => {
                        let rb = next.rb(t);
                        let (front, back) =
                            (rb.front().copied().unwrap_or(POISON), rb.back().copied().unwrap_or(POISON));
                        let r = &x.rb[k];
                        if rb.len() as u32 != r.len || front != r.front || back != r.back {
                            let design = format!("{} entries", rb.len());
                            return Some(at(lane, "RB", design, format!("{} entries, unchanged", r.len)));
                        }
                    }
                }
                let writes: Vec<(u32, Entry)> = j
                    .writes
                    .iter()
                    .filter_map(|w| match *w {
                        WriteOf::Global { thread, slot, value } if thread == t => Some((slot, value)),
                        _ => None,
                    })
                    .collect();
                if writes != x.global_writes[k] {
                    return Some(at(
                        lane,
                        "global writes",
                        format!("{writes:?}"),
                        format!("{:?}", x.global_writes[k]),
                    ));
                }
                let sh = j.sh_req.iter().find(|r| r.thread == t).map(|r| (r.stack, r.entry, r.write));
                let xsh = e.out.sh_req.iter().find(|r| r.0 == lane).map(|r| (r.1, r.2, r.3));
                if sh != xsh {
                    return Some(at(lane, "SH request", format!("{sh:?}"), format!("{xsh:?}")));
                }
                let g = j.g_req.iter().find(|r| r.thread == t).map(|r| (r.slot, r.write));
                let xg = e.out.g_req.iter().find(|r| r.0 == lane).map(|r| (r.1, r.2));
                if g != xg {
                    return Some(at(lane, "global request", format!("{g:?}"), format!("{xg:?}")));
                }
                if let Some((_, a)) = e.out.answers.iter().find(|a| a.0 == lane) {
                    if d.answer(t) != *a {
                        return Some(at(lane, "answer", format!("{:?}", d.answer(t)), format!("{a:?}")));
                    }
                }
            }
        }
        None
    }

    fn clone_box(&self) -> Box<dyn Scoreboard> {
        Box::new(SpecBoard::every(self.every))
    }
}
