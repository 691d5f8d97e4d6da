//! Real traversals drive the stack: each lane's pushes and pops of a recorded ray, 32 lanes to a
//! warp in launch order, as the work the harness runs through the cycle-level stack unit
//! ([`run_cycle`](crate::run::verify::harness::run_cycle)) or the functional level with the
//! scoreboard on (every pop checked against the reference stack, every warp checked when it
//! leaves).

use crate::run::verify::harness::{Op, WarpWork};
use crate::workload::trace::{RayTrace, TraceOp, WarpTraces};

/// A warp job's stack operations per lane. Node visits carry no stack work; they become the
/// driver's gaps between commands.
pub fn warp_work(job: &WarpTraces) -> WarpWork {
    WarpWork { lanes: job.lanes.iter().map(|lane| lane.as_ref().map(lane_ops)).collect() }
}

/// One ray's stack operations.
pub fn lane_ops(trace: &RayTrace) -> Vec<Op> {
    trace
        .ops()
        .filter_map(|op| match op {
            TraceOp::Push(a) => Some(Op::Push(a)),
            TraceOp::Pop(_) => Some(Op::Pop),
            TraceOp::Visit { .. } => None,
        })
        .collect()
}
