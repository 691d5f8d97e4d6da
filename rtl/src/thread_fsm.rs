//! The per-thread traversal state machine of the RT unit (SPEC 7: fetch → intersect → stack
//! update → next).
//!
//! ```text
//!   load ──► Busy(header) ──► decode ─┬─ Visit ──► Fetch ──scheduled──► WaitMem(left pieces)
//!                ▲                    │                                   │ all pieces arrived
//!                │                    └─ Push/Pop/end ──► Stack           ▼
//!                └──────── decode ◄── cmd accepted (stack ready) ◄── Busy(op latency)
//! ```
//!
//! A thread's next operation decides its state. A Visit waits in Fetch until the scheduler picks
//! its lanes, then waits for one response per sector piece of its node (WaitMem), then spends its
//! kind's latency (Busy). Push, Pop and the final Finish go to the stack manager one per cycle,
//! each when the stack manager shows the thread `ready`. [`next`] is the combinational logic of
//! one thread: its state and this cycle's inputs in, its next state and its command out.
//!
//! Combinational logic, not a [`crate::clock::Unit`]: a thread's registers ([`Thread`]) are an
//! entry of the warp buffer, and the RT unit's eval calls [`next`] for each lane that acts and
//! its commit writes the results there.

use crate::node_fetch::pieces;
use crate::ray_op::{NodeKind, RayOp};
use crate::stack_manager::Cmd;

// The base layer's count of states is this machine's.
const _: () = assert!(ThreadState::NAMES.len() as u64 == ThreadState::STATES);

/// Where a thread is in its traversal.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ThreadState {
    /// Inactive lane, or finished.
    #[default]
    Done,
    /// In an operation unit until cycle `until` (inclusive: it moves on in that cycle).
    Busy { until: u64 },
    /// Its next operation is a Visit: waits for the scheduler.
    Fetch,
    /// Waits for `left` sector responses, then spends `lat` cycles.
    WaitMem { left: u32, lat: u32 },
    /// Its next operation is a stack command (or the final Finish).
    Stack,
}

impl ThreadState {
    /// Number of states: the waveform's `state` field is `bits_for(STATES - 1)` wide (the base
    /// layer's [`crate::config::THREAD_STATES`], which the widths are derived from).
    pub const STATES: u64 = crate::config::THREAD_STATES;

    /// The states by waveform code ([`ThreadState::code`]): the names of the variants.
    pub const NAMES: &'static [&'static str] = &["done", "busy", "fetch", "wait_mem", "stack"];
    /// How a waveform shows the state.
    pub const KIND: crate::trace::Kind =
        crate::trace::Kind::Enum { name: "thread_state", names: ThreadState::NAMES };

    /// [`ThreadState::code`] of each state.
    pub const DONE: u64 = 0;
    pub const BUSY: u64 = 1;
    pub const FETCH: u64 = 2;
    pub const WAIT_MEM: u64 = 3;
    pub const STACK: u64 = 4;

    /// Waveform encoding: an index into [`ThreadState::NAMES`].
    #[inline]
    pub fn code(self) -> u64 {
        match self {
            ThreadState::Done => ThreadState::DONE,
            ThreadState::Busy { .. } => ThreadState::BUSY,
            ThreadState::Fetch => ThreadState::FETCH,
            ThreadState::WaitMem { .. } => ThreadState::WAIT_MEM,
            ThreadState::Stack => ThreadState::STACK,
        }
    }
}

/// One thread's registers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Thread {
    pub state: ThreadState,
    /// Index of the next operation not yet started.
    pub pos: u32,
}

/// One thread's inputs this cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ThreadIn {
    pub now: u64,
    /// The scheduler picked this lane to fetch its node.
    pub scheduled: bool,
    /// Sector responses of its node that arrived.
    pub arrived: u32,
    /// The stack manager takes a command from this thread (its sequencer is idle).
    pub stack_ready: bool,
    /// Sector size of the memory system.
    pub sector_bytes: u64,
}

/// One thread's outputs this cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ThreadOut {
    /// Command to the stack manager (`Cmd::None` for none).
    pub cmd: Cmd,
    /// For a pop: the address the trace popped, which the answer must equal.
    pub expected_pop: Option<u64>,
    /// The thread started a Visit.
    pub visit: bool,
}

/// The state a thread enters to perform operation `pos`.
#[inline]
pub fn decode(ops: &[RayOp], pos: u32) -> ThreadState {
    match ops.get(pos as usize) {
        Some(RayOp::Visit { .. }) => ThreadState::Fetch,
        _ => ThreadState::Stack,
    }
}

/// The thread's next state and outputs: pure. `latency` is the operation units' latency for a
/// node kind (the RT unit's `RtParams::latency`).
#[inline]
pub fn next(
    latency: impl Fn(NodeKind) -> u32,
    q: Thread,
    ops: &[RayOp],
    i: &ThreadIn,
) -> (Thread, ThreadOut) {
    let mut d = q;
    let mut out = ThreadOut::default();
    match q.state {
        ThreadState::Done => {}
        ThreadState::Busy { until } => {
            if i.now >= until {
                d.state = decode(ops, q.pos);
            }
        }
        ThreadState::Fetch => {
            if let (true, Some(RayOp::Visit { addr, kind, bytes })) = (i.scheduled, ops.get(q.pos as usize)) {
                d.state =
                    ThreadState::WaitMem { left: pieces(*addr, *bytes, i.sector_bytes), lat: latency(*kind) };
                d.pos += 1;
                out.visit = true;
            }
        }
        ThreadState::WaitMem { left, lat } => {
            d.state = if i.arrived >= left {
                ThreadState::Busy { until: i.now + u64::from(lat) }
            } else {
                ThreadState::WaitMem { left: left - i.arrived, lat }
            };
        }
        ThreadState::Stack => {
            if i.stack_ready {
                out.cmd = match ops.get(q.pos as usize) {
                    Some(RayOp::Push(a)) => Cmd::Push(*a),
                    Some(RayOp::Pop(a)) => {
                        out.expected_pop = Some(*a);
                        Cmd::Pop
                    }
                    _ => Cmd::Finish,
                };
                d.state = if out.cmd == Cmd::Finish {
                    ThreadState::Done
                } else {
                    d.pos += 1;
                    decode(ops, d.pos)
                };
            }
        }
    }
    (d, out)
}
