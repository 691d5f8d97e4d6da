//! One RT unit: warp buffer, GTO warp scheduler, per-thread traversal state, node fetch, and the
//! stack subsystem (stack manager, bank arbiter, memory scheduler), sharing one memory port.
//!
//! ```text
//!  warp job ──► warp buffer (≤ cfg.warps slots, oldest = lowest age)
//!                  │ per thread: Busy(header) → Fetch → WaitMem → Busy(op latency) → Stack → …
//!                  ▼
//!  GTO scheduler ──(one warp, when the fetch queue drains)──► node_fetch: sectors, merged
//!                                                                    │ node request
//!  Stack threads ──cmd (when ready)──► stack_manager ─SH─► bank_arbiter        ▼
//!        ▲  pop checked against the trace       └─global─► mem_sched ──► port (≤ 1 request
//!        │                                                   (first)       per cycle) ──► L1D
//!        └──── responses by id tag: node (wake lanes) / stack load (FIFO) / store ack ◄────┘
//! ```
//!
//! Why one port: the SPEC lets at most one new request enter the memory system per cycle per
//! SM, and spills and reloads are local-memory accesses through the same L1D. Priority goes to
//! the stack's requests: each blocks one thread's next stack command (a reload also holds an RB
//! slot empty), and there are few of them, while node fetches are the bulk of the traffic and
//! simply wait one cycle more.
//!
//! Thread states (SPEC 7, "fetch → intersect → stack update → next"): a thread's next operation
//! decides its state. A Visit waits in Fetch until the scheduler picks its warp, then waits for
//! one response per sector piece of its node (WaitMem), then spends its kind's latency (Busy).
//! Push, Pop and the final Finish go to the stack manager one per cycle, each when the stack
//! manager is `ready` for the thread; a Pop's answer must equal the trace's address, else the run
//! stops with [`RunError::PopMismatch`]. With [`StackTiming::Blocking`] (the default) a lane
//! waiting to fetch is scheduled only once its stack sequencer is idle too: the pop's refill and
//! the pushes' spills (each global store until the L2 acknowledges it) finish before the next
//! node fetch, as in the paper's RT unit; since Finish also waits for `ready`, a warp cannot leave
//! with a store unacknowledged. With [`StackTiming::Overlapped`] stores are posted and the refill
//! overlaps the fetch. A ray spends the BVH-header latency once, when its warp
//! is loaded (Vulkan-Sim reads the acceleration structure's header before the root).
//!
//! Clocking: every decision of a cycle reads registers only (thread states, fetch masks, the
//! fetch queue, `ready` of the stack manager, last cycle's arbiter and FIFO outputs, the
//! responses the L1D shows this cycle). Each thread's next state is a function of its own
//! state and those inputs, so the order in which threads are visited does not matter. A warp
//! that finished leaves at the start of a cycle; a new job lands in a slot at the end.
//!
//! Simplified, and why:
//! - Threads of a warp advance independently (no SIMT reconvergence): the RT unit works per ray,
//!   and the scheduler merges whatever lanes of the picked warp are waiting to fetch.
//! - The fetch unit handles one warp at a time: the scheduler picks the next warp only when the
//!   sector queue has drained. The port takes one request per cycle anyway, so a deeper queue
//!   would only reorder requests.
//! - Operation units are unlimited (every ray in an operation unit counts down its own latency):
//!   the traces carry no contention for them and the stack is what is under study.
//! - The triangle-hit latency (8) is not applied: a trace's Visit does not say whether its
//!   triangle was hit. The BVH header costs its latency but no fetch.
//! - Node data is not modelled, only addresses; stack entries are (the stack manager moves real
//!   values, which is how every pop is checked).

use crate::bank_arbiter::MIN_SH_LATENCY;
use crate::config::{Config, ConfigError};
use crate::mem::{MemReq, MemResp, ReqKind};
use crate::node_fetch::{pieces, NodeFetch};
use crate::ray_op::{NodeKind, RayOp, WarpJob};
pub use crate::stack_manager::StackTiming;
use crate::stack_manager::{Cmd, StackError};
use crate::stack_unit::{StackUnit, StackUnitIn, StackUnitStep};
use crate::trace::{Probe, Sink};

/// Operation-unit latencies in cycles (SPEC 7, Vulkan-Sim defaults) and run options.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct RtParams {
    /// Once per ray, when its warp is loaded (4).
    pub bvh_header: u32,
    /// Ray-box tests of an internal node (8).
    pub internal: u32,
    /// Instance transform (8).
    pub instance_leaf: u32,
    /// Leaf descriptor (4).
    pub leaf_descriptor: u32,
    /// Ray-triangle test (8).
    pub triangle: u32,
    /// Procedural primitive (8).
    pub procedural: u32,
    /// Jump over cycles in which every thread waits on memory (identical results, faster).
    pub idle_skip: bool,
    /// Whether stack traffic is on the ray's critical path (`Blocking`, the paper's sequence and
    /// the default) or overlaps the next node fetch with posted stores (`Overlapped`, the model
    /// before issue 12). See [`StackTiming`].
    pub stack_timing: StackTiming,
    /// Total cycles of an unconflicted shared-memory (SH stack) access, from the cycle the
    /// sequencer issues it to the cycle it issues its next micro-op; each bank-conflict cycle adds
    /// one. Default 20: Vulkan-Sim's `-gpgpu_smem_latency 20`
    /// (`configs/tested-cfgs/MOBILE/gpgpusim.config` line 108; the ldst unit's pipeline depth,
    /// `shader.cc` ~3646). 2 is the model before issue 12 (issue, then one bank cycle) and the
    /// least allowed ([`MIN_SH_LATENCY`]).
    pub sh_latency: u32,
}

impl Default for RtParams {
    fn default() -> Self {
        RtParams {
            bvh_header: 4,
            internal: 8,
            instance_leaf: 8,
            leaf_descriptor: 4,
            triangle: 8,
            procedural: 8,
            idle_skip: true,
            stack_timing: StackTiming::Blocking,
            sh_latency: 20,
        }
    }
}

impl RtParams {
    /// Latency of the operation unit for `kind`.
    pub fn latency(&self, kind: NodeKind) -> u32 {
        match kind {
            NodeKind::Internal => self.internal,
            NodeKind::BvhHeader => self.bvh_header,
            NodeKind::InstanceLeaf => self.instance_leaf,
            NodeKind::LeafDescriptor => self.leaf_descriptor,
            NodeKind::Triangle => self.triangle,
            NodeKind::Procedural => self.procedural,
        }
    }

    /// The timing of the model before issue 12 ([`StackTiming::Overlapped`], `sh_latency` 2),
    /// other fields unchanged.
    pub fn overlapped(self) -> Self {
        RtParams { stack_timing: StackTiming::Overlapped, sh_latency: MIN_SH_LATENCY, ..self }
    }

    /// Every latency must be at least one cycle (a thread is Busy for exactly that many cycles);
    /// `sh_latency` at least [`MIN_SH_LATENCY`].
    pub fn validate(&self) -> Result<(), ConfigError> {
        if self.sh_latency < MIN_SH_LATENCY {
            return Err(ConfigError {
                parameter: "sh_latency",
                value: self.sh_latency.to_string(),
                reason: format!("an SH access takes at least {MIN_SH_LATENCY} cycles (issue, then the bank)"),
            });
        }
        let named = [
            ("bvh_header", self.bvh_header),
            ("internal", self.internal),
            ("instance_leaf", self.instance_leaf),
            ("leaf_descriptor", self.leaf_descriptor),
            ("triangle", self.triangle),
            ("procedural", self.procedural),
        ];
        match named.iter().find(|(_, v)| *v == 0) {
            Some(&(parameter, v)) => Err(ConfigError {
                parameter,
                value: v.to_string(),
                reason: "operation latency must be at least 1 cycle".into(),
            }),
            None => Ok(()),
        }
    }
}

/// Why a run stopped.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RunError {
    /// A warp job that cannot run (wrong lane count, an empty node).
    BadJob { job: u64, reason: String },
    /// The stack manager refused a command (pop on empty, finish with entries, spill region full).
    Stack { cycle: u64, sm: u32, error: StackError },
    /// A pop returned another address than the trace says was popped.
    PopMismatch { cycle: u64, sm: u32, thread: u32, expected: u64, got: u64 },
    /// A warp left with stack state behind (RB, SH or global entries, or with reallocation a
    /// stack not back with its finished owner): a stack-manager bug.
    ExitNotEmpty { cycle: u64, sm: u32, thread: u32 },
    /// Work remains but nothing can ever happen again (a model bug).
    Stalled { cycle: u64 },
}

impl std::fmt::Display for RunError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RunError::BadJob { job, reason } => write!(f, "warp job {job}: {reason}"),
            RunError::Stack { cycle, sm, error } => write!(f, "cycle {cycle}, SM {sm}: {error}"),
            RunError::PopMismatch { cycle, sm, thread, expected, got } => write!(
                f,
                "cycle {cycle}, SM {sm}, thread {thread}: pop returned {got:#x}, trace popped {expected:#x}"
            ),
            RunError::ExitNotEmpty { cycle, sm, thread } => {
                write!(f, "cycle {cycle}, SM {sm}, thread {thread}: warp left with stack entries behind")
            }
            RunError::Stalled { cycle } => write!(f, "cycle {cycle}: work remains but nothing can happen"),
        }
    }
}

impl std::error::Error for RunError {}

/// Memory request id tags (low two bits of the id).
const TAG_NODE: u64 = 0;
const TAG_LOAD: u64 = 1;
const TAG_STORE: u64 = 2;

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
    /// Waveform encoding (3 bits).
    pub fn code(self) -> u64 {
        match self {
            ThreadState::Done => 0,
            ThreadState::Busy { .. } => 1,
            ThreadState::Fetch => 2,
            ThreadState::WaitMem { .. } => 3,
            ThreadState::Stack => 4,
        }
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Thread {
    state: ThreadState,
    /// Index of the next operation not yet started.
    pos: u32,
}

/// Per warp, which lanes are in which state: derived registers kept in step with the thread
/// states, so a cycle visits only the lanes that can act (woken by a response, due to leave an
/// operation unit, scheduled, or holding a stack command) instead of all of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Lanes {
    fetch: u32,
    wait: u32,
    busy: u32,
    stack: u32,
    /// Earliest `until` among the busy lanes (`u64::MAX` when none).
    busy_until: u64,
    /// Lanes not Done.
    live: u32,
}

impl Lanes {
    const EMPTY: Lanes = Lanes { fetch: 0, wait: 0, busy: 0, stack: 0, busy_until: u64::MAX, live: 0 };

    fn mask(&mut self, state: ThreadState) -> Option<&mut u32> {
        match state {
            ThreadState::Done => None,
            ThreadState::Busy { .. } => Some(&mut self.busy),
            ThreadState::Fetch => Some(&mut self.fetch),
            ThreadState::WaitMem { .. } => Some(&mut self.wait),
            ThreadState::Stack => Some(&mut self.stack),
        }
    }

    /// Lane `l` moves from `old` to `new`.
    fn set(&mut self, l: u32, old: ThreadState, new: ThreadState) {
        if let Some(m) = self.mask(old) {
            *m &= !(1 << l);
        }
        if let Some(m) = self.mask(new) {
            *m |= 1 << l;
        }
        if let ThreadState::Busy { until } = new {
            self.busy_until = self.busy_until.min(until);
        }
        self.live = (self.fetch | self.wait | self.busy | self.stack).count_ones();
    }
}

/// Iterates the set bits of `m`, lowest first.
fn lanes_of(mut m: u32) -> impl Iterator<Item = u32> {
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let l = m.trailing_zeros();
            m &= m - 1;
            l
        })
    })
}

/// A resident warp.
#[derive(Clone, Debug)]
struct Slot {
    lanes: Vec<Option<Vec<RayOp>>>,
    /// Load order: lower is older.
    age: u64,
    /// Cycle the warp was loaded.
    landed: u64,
}

/// Which source drives the memory port this cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Port {
    #[default]
    Idle,
    Node,
    Stack,
}

/// Event counts of one RT unit (besides the stack manager's and the arbiter's).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RtStats {
    pub warps: u64,
    pub rays: u64,
    /// Visit operations (lanes), before merging.
    pub visits: u64,
    pub pops_checked: u64,
}

/// Greedy-then-oldest: the warp issued last if it is `ready`, else the ready warp of lowest `age`.
fn gto(
    greedy: Option<u32>,
    warps: u32,
    ready: impl Fn(u32) -> bool,
    age: impl Fn(u32) -> u64,
) -> Option<u32> {
    greedy.filter(|&w| ready(w)).or_else(|| (0..warps).filter(|&w| ready(w)).min_by_key(|&w| age(w)))
}

/// The state a thread enters to perform operation `pos`.
fn decode(ops: &[RayOp], pos: u32) -> ThreadState {
    match ops.get(pos as usize) {
        Some(RayOp::Visit { .. }) => ThreadState::Fetch,
        _ => ThreadState::Stack,
    }
}

#[derive(Clone, Debug)]
pub struct RtUnit {
    id: u32,
    cfg: Config,
    rt: RtParams,
    /// Stack manager, bank arbiter and memory scheduler.
    pub stack_unit: StackUnit,
    /// The stack unit's cycle (its outputs, read by the checks and the probe).
    stack_d: StackUnitStep,
    pub fetch: NodeFetch,
    slots: Vec<Option<Slot>>,
    threads: Vec<Thread>,
    lanes: Vec<Lanes>,
    /// GTO: the warp issued last.
    greedy: Option<u32>,
    next_age: u64,
    /// Cycles each warp job spent in the warp buffer, by load order (0 while resident): a
    /// per-job share of the run time, used to attribute cycles to sampled warps.
    pub residence: Vec<u64>,
    /// Distinguishes posted stores in flight (Overlapped; with Blocking a store's id names its
    /// thread, which has at most one store in flight, so the acknowledgement finds its sequencer).
    store_seq: u64,
    /// Per-cycle signals.
    port: Port,
    scheduled: Option<u32>,
    /// Lanes of the scheduled warp that start their fetch.
    scheduled_lanes: u32,
    next_event: Option<u64>,
    /// Scratch, reused every cycle.
    arrived: Vec<u32>,
    /// Per warp: lanes that got a node response this cycle.
    woken: Vec<u32>,
    completions: Vec<u32>,
    cmds: Vec<(u32, Cmd)>,
    expected_pops: Vec<(u32, u64)>,
    pub stats: RtStats,
}

impl RtUnit {
    /// RT unit `id` (its SM) with stack configuration `cfg`; `sector_bytes` is the memory
    /// system's fetch granularity.
    pub fn new(id: u32, cfg: Config, rt: RtParams, sector_bytes: u32) -> Result<Self, ConfigError> {
        rt.validate()?;
        let warps = cfg.warps as usize;
        let threads = cfg.threads() as usize;
        Ok(RtUnit {
            id,
            cfg,
            rt,
            stack_unit: StackUnit::new(cfg, id, rt.stack_timing, rt.sh_latency)?,
            stack_d: StackUnitStep::default(),
            fetch: NodeFetch::new(sector_bytes),
            slots: vec![None; warps],
            threads: vec![Thread::default(); threads],
            lanes: vec![Lanes::EMPTY; warps],
            greedy: None,
            next_age: 0,
            residence: Vec::new(),
            store_seq: 0,
            port: Port::Idle,
            scheduled: None,
            scheduled_lanes: 0,
            next_event: None,
            arrived: vec![0; threads],
            woken: vec![0; warps],
            completions: Vec::new(),
            cmds: Vec::new(),
            expected_pops: Vec::new(),
            stats: RtStats::default(),
        })
    }

    /// A warp slot that can take a job this cycle.
    pub fn free_slot(&self) -> Option<u32> {
        self.slots.iter().position(Option::is_none).map(|w| w as u32)
    }

    /// No warp resident.
    pub fn empty(&self) -> bool {
        self.slots.iter().all(Option::is_none)
    }

    /// The first cycle after the last `step` in which this unit does something even if no memory
    /// response arrives; `None` when it only waits for memory (or is empty).
    pub fn next_event(&self) -> Option<u64> {
        self.next_event
    }

    /// Drives the memory port for this cycle (from registers): the stack's head request first,
    /// else the node fetch queue's head. `mem_ready`: the L1D takes a request this cycle.
    pub fn offer(&mut self, mem_ready: bool) -> Option<MemReq> {
        self.port = Port::Idle;
        if !mem_ready {
            return None;
        }
        let bytes = self.cfg.entry_bytes;
        if let Some(g) = self.stack_unit.req() {
            self.port = Port::Stack;
            return Some(if g.write {
                let tag = match self.rt.stack_timing {
                    StackTiming::Blocking => u64::from(g.thread),
                    StackTiming::Overlapped => self.store_seq,
                };
                MemReq::write(tag << 2 | TAG_STORE, g.addr, bytes, ReqKind::StackSpill)
            } else {
                MemReq::read(u64::from(g.thread) << 2 | TAG_LOAD, g.addr, bytes, ReqKind::StackReload)
            });
        }
        let r = self.fetch.head(TAG_NODE)?;
        self.port = Port::Node;
        Some(r)
    }

    /// One clock cycle at `now`. `accepted`: the L1D took the request [`RtUnit::offer`] drove;
    /// `resp`: responses the L1D shows this cycle; `job`: a warp job for the slot that
    /// [`RtUnit::free_slot`] named before this step (the dispatcher checked it).
    pub fn step(
        &mut self,
        now: u64,
        accepted: bool,
        resp: &[MemResp],
        job: Option<WarpJob>,
    ) -> Result<(), RunError> {
        let ws = self.cfg.warp_size;
        let load_slot = self.free_slot();
        let took_stack = accepted && self.port == Port::Stack;
        if accepted && self.port == Port::Node {
            self.fetch.taken();
        }
        if took_stack && self.stack_unit.req().is_some_and(|g| g.write) {
            self.store_seq += 1;
        }

        // Warp buffer: a warp whose threads all finished and whose stacks are quiet leaves, and
        // must leave nothing behind.
        for w in 0..self.cfg.warps {
            if self.slots[w as usize].is_some()
                && self.lanes[w as usize].live == 0
                && self.stack_unit.manager.warp_done(w)
            {
                if let Some(thread) = self.stack_unit.manager.warp_threads(w).find(|&t| !self.stack_clear(t))
                {
                    return Err(RunError::ExitNotEmpty { cycle: now, sm: self.id, thread });
                }
                if let Some(slot) = self.slots[w as usize].take() {
                    self.residence[slot.age as usize] = now - slot.landed;
                }
                if self.greedy == Some(w) {
                    self.greedy = None;
                }
            }
        }

        // Scheduler: picks a warp in the cycle the fetch queue drains (the port taking the last
        // piece is the queue's ready signal).
        self.scheduled = None;
        self.scheduled_lanes = 0;
        if self.fetch.queue_empty() {
            let ready = |w: u32| self.fetchable(w) != 0;
            let age = |w: u32| self.slots[w as usize].as_ref().map_or(u64::MAX, |s| s.age);
            if let Some(w) = gto(self.greedy, self.cfg.warps, ready, age) {
                self.greedy = Some(w);
                self.scheduled = Some(w);
                self.scheduled_lanes = self.fetchable(w);
                let (slot, threads, mask) = (&self.slots[w as usize], &self.threads, self.scheduled_lanes);
                let lanes = slot.as_ref().map_or(&[][..], |s| &s.lanes[..]);
                self.fetch.coalesce(
                    w,
                    lanes_of(mask).filter_map(|l| {
                        let th = threads[(w * ws + l) as usize];
                        match lanes[l as usize].as_ref()?.get(th.pos as usize)? {
                            RayOp::Visit { addr, bytes, .. } => Some((l, *addr, *bytes)),
                            _ => None,
                        }
                    }),
                );
            }
        }

        // Responses: node pieces wake lanes; stack loads go to the response FIFO; store
        // acknowledgements too with Blocking (their sequencer waits), and need nothing with
        // Overlapped (stores are posted).
        self.completions.clear();
        for r in resp {
            match r.id & 3 {
                TAG_NODE => {
                    let (w, lanes) = self.fetch.complete(r.id);
                    for l in lanes_of(lanes) {
                        self.arrived[(w * ws + l) as usize] += 1;
                    }
                    self.woken[w as usize] |= lanes;
                }
                TAG_LOAD => self.completions.push((r.id >> 2) as u32),
                _ => {
                    debug_assert_eq!(r.id & 3, TAG_STORE);
                    if self.rt.stack_timing == StackTiming::Blocking {
                        self.completions.push((r.id >> 2) as u32);
                    }
                }
            }
        }

        // Threads: only the lanes that can act this cycle.
        self.cmds.clear();
        self.expected_pops.clear();
        let sector = self.fetch.sector_bytes();
        for w in 0..self.cfg.warps {
            let Some(slot) = &self.slots[w as usize] else { continue };
            let q = self.lanes[w as usize];
            let due = now >= q.busy_until;
            let todo = q.stack
                | std::mem::take(&mut self.woken[w as usize])
                | if self.scheduled == Some(w) { self.scheduled_lanes } else { 0 }
                | if due { q.busy } else { 0 };
            for l in lanes_of(todo) {
                let t = w * ws + l;
                let th = self.threads[t as usize];
                let ops = slot.lanes[l as usize].as_deref().unwrap_or(&[]);
                let mut d = th;
                match th.state {
                    ThreadState::Done => {}
                    ThreadState::Busy { until } => {
                        if now >= until {
                            d.state = decode(ops, th.pos);
                        }
                    }
                    ThreadState::Fetch => {
                        if let Some(RayOp::Visit { addr, kind, bytes }) = ops.get(th.pos as usize) {
                            d.state = ThreadState::WaitMem {
                                left: pieces(*addr, *bytes, sector),
                                lat: self.rt.latency(*kind),
                            };
                            d.pos += 1;
                            self.stats.visits += 1;
                        }
                    }
                    ThreadState::WaitMem { left, lat } => {
                        let a = std::mem::take(&mut self.arrived[t as usize]);
                        d.state = if a >= left {
                            ThreadState::Busy { until: now + u64::from(lat) }
                        } else {
                            ThreadState::WaitMem { left: left - a, lat }
                        };
                    }
                    ThreadState::Stack => {
                        if self.stack_unit.manager.ready(t) {
                            let cmd = match ops.get(th.pos as usize) {
                                Some(RayOp::Push(a)) => Cmd::Push(*a),
                                Some(RayOp::Pop(a)) => {
                                    self.expected_pops.push((t, *a));
                                    Cmd::Pop
                                }
                                _ => Cmd::Finish,
                            };
                            self.cmds.push((t, cmd));
                            d.state = if cmd == Cmd::Finish {
                                ThreadState::Done
                            } else {
                                d.pos += 1;
                                decode(ops, d.pos)
                            };
                        }
                    }
                }
                self.lanes[w as usize].set(l, th.state, d.state);
                self.threads[t as usize] = d;
            }
            if due {
                let threads = &self.threads[(w * ws) as usize..((w + 1) * ws) as usize];
                let lanes = &mut self.lanes[w as usize];
                lanes.busy_until = lanes_of(lanes.busy)
                    .map(|l| match threads[l as usize].state {
                        ThreadState::Busy { until } => until,
                        _ => u64::MAX,
                    })
                    .min()
                    .unwrap_or(u64::MAX);
            }
        }

        // Stack subsystem.
        let stack_in =
            StackUnitIn { cmds: &self.cmds, req_ready: took_stack, completions: &self.completions };
        self.stack_unit.eval(now, &stack_in, &mut self.stack_d);
        self.stack_unit.commit(&self.stack_d);
        if let Some(&error) = self.stack_d.manager.errors.first() {
            return Err(RunError::Stack { cycle: now, sm: self.id, error });
        }
        for (&(thread, expected), &(_, got)) in self.expected_pops.iter().zip(&self.stack_d.manager.pops) {
            if got != expected {
                return Err(RunError::PopMismatch { cycle: now, sm: self.id, thread, expected, got });
            }
        }
        self.stats.pops_checked += self.expected_pops.len() as u64;

        if let (Some(job), Some(w)) = (job, load_slot) {
            self.load(w, job, now);
        }

        // Next event: anything that acts next cycle without a memory response, else the first
        // operation unit to finish.
        let acts_next = !self.fetch.queue_empty()
            || self.stack_unit.arb.busy()
            || !self.stack_unit.sched.is_idle()
            || (0..self.cfg.warps).any(|w| {
                let m = &self.lanes[w as usize];
                self.slots[w as usize].is_some()
                    && (self.fetchable(w) != 0
                        || m.live == 0
                        || lanes_of(m.stack).any(|l| self.stack_unit.manager.ready(w * ws + l)))
            })
            || self.stack_unit.manager.can_issue();
        // A lane waiting to fetch on its sequencer (Blocking) moves when the sequencer completes,
        // which one of the events here or a memory response causes.
        let event = self
            .lanes
            .iter()
            .map(|m| m.busy_until)
            .chain(self.stack_unit.arb.pipe_due())
            .min()
            .unwrap_or(u64::MAX);
        self.next_event = if acts_next { Some(now + 1) } else { (event != u64::MAX).then_some(event) };
        Ok(())
    }

    /// Lanes of warp `w` the scheduler may start fetching: those waiting to fetch, and with
    /// Blocking only those whose stack sequencer is idle.
    fn fetchable(&self, w: u32) -> u32 {
        let m = self.lanes[w as usize].fetch;
        match self.rt.stack_timing {
            StackTiming::Overlapped => m,
            StackTiming::Blocking => {
                let ws = self.cfg.warp_size;
                lanes_of(m).filter(|&l| self.stack_unit.manager.ready(w * ws + l)).fold(0, |a, l| a | 1 << l)
            }
        }
    }

    /// Thread `t` holds no stack entry anywhere, and with reallocation its own SH stack is idle
    /// (back from any borrower).
    fn stack_clear(&self, t: u32) -> bool {
        let st = self.stack_unit.manager.stack(t);
        self.stack_unit.manager.rb(t).is_empty()
            && (self.cfg.sh_entries == 0 || st.empty)
            && self.stack_unit.manager.thread(t).spill_ptr == 0
            && (self.cfg.realloc.is_none() || st.idle)
    }

    /// Puts `job` in slot `w` (clock edge): its rays start with the BVH-header latency.
    fn load(&mut self, w: u32, job: WarpJob, now: u64) {
        let ws = self.cfg.warp_size;
        let active = job.active_mask();
        self.stack_unit.manager.load_warp(w, active);
        // A two-level trace fetches the acceleration structure's header as its first visit and
        // pays the header latency there; a flat trace reads it without a fetch, here.
        let header_fetched =
            job.lanes.iter().flatten().next().is_some_and(|ops| {
                matches!(ops.first(), Some(RayOp::Visit { kind: NodeKind::BvhHeader, .. }))
            });
        let start = now + if header_fetched { 0 } else { u64::from(self.rt.bvh_header) };
        for l in 0..ws {
            self.threads[(w * ws + l) as usize] = Thread {
                state: if active & (1 << l) != 0 {
                    ThreadState::Busy { until: start }
                } else {
                    ThreadState::Done
                },
                pos: 0,
            };
        }
        self.lanes[w as usize] =
            Lanes { busy: active, busy_until: start, live: active.count_ones(), ..Lanes::EMPTY };
        self.slots[w as usize] = Some(Slot { lanes: job.lanes, age: self.next_age, landed: now });
        self.residence.push(0);
        self.next_age += 1;
        self.stats.warps += 1;
        self.stats.rays += u64::from(active.count_ones());
    }
}

impl Probe for RtUnit {
    fn probe<S: Sink>(&self, s: &mut S) {
        if !s.enabled() {
            return;
        }
        let ws = self.cfg.warp_size;
        let wbits = crate::config::bits_for(u64::from(self.cfg.warps.max(2) - 1));
        s.push_scope("rt_unit");
        s.push_scope("warp_buffer");
        for w in 0..self.cfg.warps {
            let slot = self.slots[w as usize].as_ref();
            s.push_scope(&format!("warp[{w}]"));
            s.signal("valid", 1, u64::from(slot.is_some()));
            s.signal("age", 32, slot.map_or(0, |x| x.age));
            let m = self.lanes[w as usize];
            s.signal("live", 6, u64::from(m.live));
            s.signal("fetch_mask", ws, u64::from(m.fetch));
            s.signal("wait_mask", ws, u64::from(m.wait));
            s.signal("busy_mask", ws, u64::from(m.busy));
            s.signal("stack_mask", ws, u64::from(m.stack));
            for l in 0..ws {
                let th = self.threads[(w * ws + l) as usize];
                s.push_scope(&format!("thread[{l}]"));
                s.signal("state", 3, th.state.code());
                s.pop_scope();
            }
            s.pop_scope();
        }
        s.pop_scope();
        s.push_scope("scheduler");
        s.signal("greedy_valid", 1, u64::from(self.greedy.is_some()));
        s.signal("greedy", wbits, u64::from(self.greedy.unwrap_or(0)));
        s.signal("issue_valid", 1, u64::from(self.scheduled.is_some()));
        s.signal("issue_warp", wbits, u64::from(self.scheduled.unwrap_or(0)));
        s.signal("issue_lanes", ws, u64::from(self.scheduled_lanes));
        s.pop_scope();
        s.push_scope("port");
        s.signal("node", 1, u64::from(self.port == Port::Node));
        s.signal("stack", 1, u64::from(self.port == Port::Stack));
        s.pop_scope();
        self.fetch.probe(s);
        self.stack_unit.probe(&self.cmds, &self.stack_d, s);
        s.pop_scope();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gto_keeps_the_greedy_warp_then_takes_the_oldest() {
        let ages = [7, 3, 9, 5];
        let age = |w: u32| ages[w as usize];
        let ready_mask = |m: u32| move |w: u32| m & (1 << w) != 0;
        assert_eq!(gto(Some(2), 4, ready_mask(0b1111), age), Some(2), "greedy while ready");
        assert_eq!(gto(Some(2), 4, ready_mask(0b1011), age), Some(1), "stalled: oldest ready");
        assert_eq!(gto(None, 4, ready_mask(0b1001), age), Some(3));
        assert_eq!(gto(Some(0), 4, ready_mask(0), age), None);
    }

    #[test]
    fn latencies_follow_the_spec_defaults() {
        let p = RtParams::default();
        let kinds = [
            NodeKind::Internal,
            NodeKind::InstanceLeaf,
            NodeKind::LeafDescriptor,
            NodeKind::Triangle,
            NodeKind::Procedural,
        ];
        assert_eq!(kinds.map(|k| p.latency(k)), [8, 8, 4, 8, 8]);
        assert_eq!(p.bvh_header, 4);
        p.validate().unwrap();
    }
}
