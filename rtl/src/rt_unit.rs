//! One RT unit: warp buffer ([`crate::warp_buffer`]), GTO warp scheduler
//! ([`crate::scheduler`]), per-thread traversal state machine ([`crate::thread_fsm`]), node fetch,
//! and the stack unit ([`crate::stack_unit`]: stack manager, bank arbiter, memory scheduler),
//! sharing one memory port.
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
//! SM, and spills and reloads are local-memory accesses through the same L1D. Priority goes by
//! default ([`PortPriority::Stack`]; the paper does not say) to the stack's requests: each blocks one thread's next stack command (a reload also holds an RB
//! slot empty), and there are few of them, while node fetches are the bulk of the traffic and
//! simply wait one cycle more.
//!
//! Thread states ([`crate::thread_fsm`]): a Pop's answer must equal the trace's address, else
//! the run stops with [`RunError::PopMismatch`]. With [`StackTiming::Blocking`] (the default) a
//! lane waiting to fetch is scheduled only once its stack sequencer is idle too: the pop's refill
//! and the pushes' spills (each global store until the L2 acknowledges it) finish before the next
//! node fetch, as in the paper's RT unit; since Finish also waits for `ready`, a warp cannot
//! leave with a store unacknowledged. With [`StackTiming::Overlapped`] stores are posted and the
//! refill overlaps the fetch. A ray spends the BVH-header latency once, when its warp is loaded
//! (Vulkan-Sim reads the acceleration structure's header before the root).
//!
//! Clocking: the RT unit is a [`Unit`]. Its eval reads registers only (thread states, lane
//! masks, the fetch queue, `ready` of the stack manager, the arbiter's and FIFO's registered
//! outputs) and this cycle's inputs ([`RtIn`]: the L1D's `ready` and responses, the job the
//! dispatcher sends), and writes an [`RtStep`]; its commit applies it. Each thread's next state is [`thread_fsm::next`] of its own state and those
//! inputs, so the order in which threads are visited does not matter. A warp that finished
//! leaves at the edge of the cycle it is seen done; a new job lands in a slot at the same edge.
//!
//! Threads of a warp advance independently (no SIMT reconvergence), as in Vulkan-Sim's RT unit:
//! each thread has its own access list (`abstract_hardware_model.cc` 925-941, 1025-1068), a
//! response wakes every thread waiting on that node and each counts down its own operation
//! latency (1087-1160); the scheduler merges whatever lanes of the picked warp wait to fetch.
//!
//! The choices the paper and Vulkan-Sim leave open or disagree on are keys of [`StackParams`]
//! (`store_gating`, `store_queue`, `port_priority`) and [`RtParams`] (`warp_select`), each with its sources in
//! docs/assumptions.md.
//!
//! Simplified, and why:
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
use crate::clock::Unit;
use crate::config::{Config, ConfigError, Widths, GM_POSTED_QUEUE_BITS};
use crate::mem::{MemReq, MemResp, ReqKind};
use crate::node_fetch::NodeFetch;
use crate::params::{check_bounds, Bound};
use crate::ray_op::{NodeKind, Popped, RayOp, Walks, WarpJob};
use crate::scheduler::WarpScheduler;
pub use crate::scheduler::WarpSelect;
pub use crate::stack_manager::StackTiming;
use crate::stack_manager::{Cmd, StackError, StackPolicy, StackStats, Uop};
use crate::stack_unit::{StackUnit, StackUnitIn, StackUnitStep};
use crate::thread_cycles::ThreadCycles;
use crate::thread_fsm::{self, Thread, ThreadIn, ThreadState};
use crate::trace::{Probe, Sink};
use crate::warp_buffer::{lanes_of, Bits, WarpBuffer};

/// Which stack stores hold a thread's next node fetch with [`StackTiming::Blocking`]
/// (`[stack] store_gating`; docs/assumptions.md). Loads always do: the paper's stack manager
/// issues "a subsequent request ... only after the prior load request has returned" (§VI-A); it
/// says nothing of stores holding the ray.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum StoreGating {
    /// Every stack request holds the next fetch, a global store until the L2 acknowledges it
    /// (the default: the paper's sequence read as "the stack is updated before the next node").
    #[default]
    Acked,
    /// Only the thread's loads hold it: global stores are posted (done when queued, no
    /// acknowledgement), and SH stores complete behind the fetch (Vulkan-Sim's stores go to a
    /// store queue whose acknowledgements hold only the warp's retirement, `shader.cc:2982-2997`,
    /// `3090`).
    Posted,
    /// SH stores complete behind the fetch; a global store holds it until its acknowledgement.
    ShPosted,
}

named_enum!(StoreGating, StoreGating::Acked => "acked", StoreGating::Posted => "posted", StoreGating::ShPosted => "sh-posted");

/// Which requests the RT unit's one memory port serves first (`[stack] port_priority`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PortPriority {
    /// The stack's requests before node fetches (default; see the module comment for why).
    #[default]
    Stack,
    /// Vulkan-Sim's order (`rt_unit::memory_cycle`, `shader.cc:3237-3254`, and `rt_unit::cycle`,
    /// `3040-3061`): the pieces of the node fetch under way first, then queued stores, then a
    /// new warp's fetch; no new warp is picked while a stack request waits.
    Node,
}

named_enum!(PortPriority, PortPriority::Stack => "stack", PortPriority::Node => "node");

/// The latency bound's reason.
const LATENCY: Bound = Bound::at_least(1).because("operation latency must be at least 1 cycle");

params! {
    /// Operation-unit latencies in cycles (SPEC 7, Vulkan-Sim defaults) and the warp scheduler's
    /// choice (`[rt]`).
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub struct RtParams {
        /// Once per ray, when its warp is loaded (4).
        ["rt" "bvh_header", LATENCY]
        pub bvh_header: u32 = 4,
        /// Ray-box tests of an internal node (8).
        ["rt" "internal", LATENCY]
        pub internal: u32 = 8,
        /// Instance transform (8).
        ["rt" "instance_leaf", LATENCY]
        pub instance_leaf: u32 = 8,
        /// Leaf descriptor (4).
        ["rt" "leaf_descriptor", LATENCY]
        pub leaf_descriptor: u32 = 4,
        /// Ray-triangle test (8).
        ["rt" "triangle", LATENCY]
        pub triangle: u32 = 8,
        /// Procedural primitive (8).
        ["rt" "procedural", LATENCY]
        pub procedural: u32 = 8,
        /// How the scheduler picks a warp. Default [`WarpSelect::Gto`] (the paper's).
        ["rt" "warp_select"]
        pub warp_select: WarpSelect = WarpSelect::Gto,
    }
}

params! {
    /// The stack unit's timing in the RT unit (`[stack]`): whether stack traffic is on the ray's
    /// critical path, the SH access latency, which stores hold the next fetch, the store queue's
    /// bound and the memory port's priority.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub struct StackParams {
        /// Whether stack traffic is on the ray's critical path (`Blocking`, the paper's sequence and
        /// the default) or overlaps the next node fetch with posted stores (`Overlapped`, the `legacy`
        /// preset's). See [`StackTiming`].
        ["stack" "timing"]
        pub timing: StackTiming = StackTiming::Blocking,
        /// Total cycles of an unconflicted shared-memory (SH stack) access, from the cycle the
        /// sequencer issues it to the cycle it issues its next micro-op; each bank-conflict cycle adds
        /// one. Default 20: Vulkan-Sim's `-gpgpu_smem_latency 20`
        /// (`configs/tested-cfgs/MOBILE/gpgpusim.config` line 108; the ldst unit's pipeline depth,
        /// `shader.cc` ~3646). 2 (issue, then one bank cycle) is the `legacy` preset's and the
        /// least allowed ([`MIN_SH_LATENCY`]).
        ["stack" "sh_latency", Bound::at_least(MIN_SH_LATENCY)
            .because("an SH access takes at least {least} cycles (issue, then the bank)")]
        pub sh_latency: u32 = 20,
        /// Which stores hold the next node fetch under [`StackTiming::Blocking`] (ignored with
        /// `Overlapped`, where nothing does). Default [`StoreGating::Acked`].
        ["stack" "store_gating"]
        pub store_gating: StoreGating = StoreGating::Acked,
        /// Global stores that may wait in the memory scheduler's queue before the stack manager
        /// takes no new command (back-pressure on the RT unit's stack commands); 0 = unbounded, the
        /// default: Vulkan-Sim's RT store queue is a `std::deque` with no bound
        /// (`src/gpgpu-sim/shader.h:1344`), pushed without a check (`abstract_hardware_model.cc`
        /// `dec_thread_latency`, and `shader.cc:3516` on a reservation failure). At most
        /// `2^GM_POSTED_QUEUE_BITS - 1`.
        ["stack" "store_queue", Bound { least: 0, most: (1 << GM_POSTED_QUEUE_BITS) - 1, why: "" }
            .because("the memory scheduler's queue holds at most {most} requests (0 = unbounded)")]
        pub store_queue: u32 = 0,
        /// Which requests the memory port serves first. Default [`PortPriority::Stack`].
        ["stack" "port_priority"]
        pub port_priority: PortPriority = PortPriority::Stack,
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

    /// Every latency must be at least one cycle (a thread is Busy for exactly that many cycles).
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_bounds(RtParams::KEYS, self)
    }
}

impl StackParams {
    /// The `legacy` preset's stack timing ([`StackTiming::Overlapped`], `sh_latency` 2),
    /// other fields unchanged.
    pub fn overlapped(self) -> Self {
        StackParams { timing: StackTiming::Overlapped, sh_latency: MIN_SH_LATENCY, ..self }
    }

    /// Global stores wait for the L2's acknowledgement: with `Blocking`, unless posted.
    pub fn acked_stores(&self) -> bool {
        self.timing == StackTiming::Blocking && self.store_gating != StoreGating::Posted
    }

    /// `sh_latency` at least [`MIN_SH_LATENCY`]; `store_queue` within the scheduler queue's width.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_bounds(StackParams::KEYS, self)
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
    /// A pop the stack manager accepted without answering it (a model bug).
    PopMissing { cycle: u64, sm: u32, thread: u32, expected: u64 },
    /// A warp left with stack state behind (RB, SH or global entries, or with reallocation a
    /// stack not back with its finished owner): a stack-manager bug.
    ExitNotEmpty { cycle: u64, sm: u32, thread: u32 },
    /// Work remains but nothing can ever happen again (a model bug).
    Stalled { cycle: u64 },
    /// The stack manager's cycle disagreed with the scoreboard's specification (its message
    /// names the cycle, warp, lane and property).
    Decision { sm: u32, what: String },
    /// A walk-driven ray could not go on from its stack's answer (its walk's reason).
    Walk { cycle: u64, sm: u32, thread: u32, reason: String },
}

impl RunError {
    /// The SM whose RT unit stopped the run, if one did.
    pub fn sm(&self) -> Option<u32> {
        match self {
            RunError::Stack { sm, .. }
            | RunError::PopMismatch { sm, .. }
            | RunError::PopMissing { sm, .. }
            | RunError::ExitNotEmpty { sm, .. }
            | RunError::Decision { sm, .. }
            | RunError::Walk { sm, .. } => Some(*sm),
            RunError::BadJob { .. } | RunError::Stalled { .. } => None,
        }
    }
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
            RunError::PopMissing { cycle, sm, thread, expected } => write!(
                f,
                "cycle {cycle}, SM {sm}, thread {thread}: the accepted pop returned nothing, trace popped {expected:#x}"
            ),
            RunError::ExitNotEmpty { cycle, sm, thread } => {
                write!(f, "cycle {cycle}, SM {sm}, thread {thread}: warp left with stack entries behind")
            }
            RunError::Stalled { cycle } => write!(f, "cycle {cycle}: work remains but nothing can happen"),
            RunError::Decision { sm: _, what } => write!(f, "stack decision check: {what}"),
            RunError::Walk { cycle, sm, thread, reason } => {
                write!(f, "cycle {cycle}, SM {sm}, thread {thread}: walk: {reason}")
            }
        }
    }
}

impl std::error::Error for RunError {}

/// Memory request id tags (low two bits of the id).
const TAG_NODE: u64 = 0;
const TAG_LOAD: u64 = 1;
const TAG_STORE: u64 = 2;

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
    /// Thread-cycles waiting to fetch while the stack sequencer holds the fetch back, up to the
    /// last edge ([`RtUnit::thread_cycles`]).
    pub held_fetch_cycles: u64,
}

/// This cycle's inputs of an RT unit: the memory system's registered outputs for its SM, and
/// the dispatcher's job.
#[derive(Clone, Copy, Debug, Default)]
pub struct RtIn<'a> {
    pub now: u64,
    /// The L1D takes a request this cycle (what [`RtUnit::req`] was offered with).
    pub req_ready: bool,
    /// The L1D took the offered request (`req_valid && req_ready`).
    pub req_fire: bool,
    /// Responses the L1D shows this cycle.
    pub resp: &'a [MemResp],
    /// A warp job the dispatcher sends this cycle (checked), for the slot
    /// [`RtUnit::free_slot`] names; it lands there at the edge.
    pub job: Option<&'a WarpJob>,
}

/// An RT unit's cycle: its outputs and every decision its registers take at the clock edge
/// ([`Unit::eval`], [`Unit::commit`]). A reusable buffer: a cycle allocates nothing once it has
/// grown (a job's traces are copied into vectors it keeps).
#[derive(Clone, Debug, Default)]
pub struct RtStep {
    now: u64,
    /// The cycle's failed check, if any: a step that holds one is not committed (the run stops).
    error: Option<RunError>,
    port: Port,
    node_taken: bool,
    took_stack: bool,
    store_taken: bool,
    /// The slot a job dispatched this cycle lands in (free before the cycle).
    load_slot: Option<u32>,
    /// A job lands: `job` holds a copy of it.
    job_lands: bool,
    job: WarpJob,
    /// Warps that leave.
    leaving: Vec<u32>,
    /// The scheduler's issue: (warp, lanes).
    issue: Option<(u32, u32)>,
    /// Node responses (their waiter slots free at the edge).
    node_resp: Vec<u64>,
    /// Warps whose Busy lanes were due (their deadline is recomputed at the edge).
    due: Vec<u32>,
    /// Next state of every thread that acted.
    threads: Vec<(u32, Thread)>,
    visits: u64,
    /// Per thread: node pieces that arrived (scratch; `arrived_at` lists the nonzero entries).
    arrived: Vec<u32>,
    arrived_at: Vec<u32>,
    /// Per warp: lanes that got a node response (scratch; bit w of `woken_warps` marks the
    /// nonzero entries).
    woken: Vec<u32>,
    woken_warps: u64,
    completions: Vec<u32>,
    cmds: Vec<(u32, Cmd)>,
    expected_pops: Vec<(u32, u64)>,
    /// Pops of walk-driven threads and what the stack answered: their walks go on at the edge.
    walk_pops: Vec<(u32, Popped)>,
    stack: StackUnitStep,
    /// Lanes waiting to fetch that their sequencer holds back, so since the last edge for
    /// `held_cycles` cycles.
    held: u32,
    held_cycles: u64,
}

impl RtStep {
    /// The cycle's failed check: a refused stack command, a pop that disagrees with the trace,
    /// a warp leaving stack entries behind.
    pub fn check(&self) -> Result<(), RunError> {
        self.error.clone().map_or(Ok(()), Err)
    }

    /// Visits this cycle started (for [`crate::sim::OrderBug::StaleStep`]).
    #[cfg(feature = "mutants")]
    pub fn visits(&self) -> u64 {
        self.visits
    }

    /// The planted bugs of [`crate::sim::OrderBug::StaleStep`] and
    /// [`crate::sim::OrderBug::SmsShareACounter`]: visits counted again.
    #[cfg(feature = "mutants")]
    pub fn count_visits_again(&mut self, earlier: u64) {
        self.visits += earlier;
    }

    fn clear(&mut self, threads: usize, warps: usize) {
        self.error = None;
        self.job_lands = false;
        for &t in &self.arrived_at {
            self.arrived[t as usize] = 0;
        }
        self.arrived_at.clear();
        if self.arrived.len() != threads {
            self.arrived.resize(threads, 0);
        }
        for w in Bits::of(self.woken_warps) {
            self.woken[w as usize] = 0;
        }
        self.woken_warps = 0;
        if self.woken.len() != warps {
            self.woken.resize(warps, 0);
        }
        self.leaving.clear();
        self.issue = None;
        self.node_resp.clear();
        self.due.clear();
        self.threads.clear();
        self.visits = 0;
        self.completions.clear();
        self.cmds.clear();
        self.expected_pops.clear();
        self.walk_pops.clear();
    }
}

#[derive(Clone, Debug)]
pub struct RtUnit {
    id: u32,
    cfg: Config,
    rt: RtParams,
    stack: StackParams,
    w: Widths,
    /// Stack manager, bank arbiter and memory scheduler.
    pub stack_unit: StackUnit,
    pub fetch: NodeFetch,
    warp_buffer: WarpBuffer,
    scheduler: WarpScheduler,
    /// Cycles each warp job spent in the warp buffer, by load order (0 while resident): a
    /// per-job share of the run time, used to attribute cycles to sampled warps.
    pub residence: Vec<u64>,
    /// Distinguishes posted stores in flight (with acknowledged stores a store's id names its
    /// thread, which has at most one store in flight, so the acknowledgement finds its sequencer).
    store_seq: u64,
    next_event: Option<u64>,
    /// Cycles before this one are in `stats.thread_cycles` (the cycle after the last edge).
    counted_to: u64,
    pub stats: RtStats,
    /// Walk-driven threads whose walks go on at this edge: (thread, the pop's answer; `None`
    /// for a warp that just landed).
    walk_pending: Vec<(u32, Option<Popped>)>,
    /// A walk that could not go on at the last edge: the next cycle's error.
    walk_error: Option<RunError>,
}

impl RtUnit {
    /// What a report reads of this unit beyond [`RtUnit::stats`]: the stack manager's counters,
    /// node fetches sent, and bank-conflict cycles.
    pub fn counters(&self) -> (&StackStats, u64, u64) {
        (self.stack_unit.stats(), self.fetch.requests, self.stack_unit.conflict_cycles())
    }

    /// RT unit `id` (its SM) with stack configuration `cfg`, its operation latencies `rt` and
    /// stack timing `stack`, its stack manager running `policy`; `sector_bytes` is the memory
    /// system's fetch granularity.
    pub fn new(
        id: u32,
        cfg: Config,
        rt: RtParams,
        stack: StackParams,
        sector_bytes: u32,
        policy: StackPolicy,
    ) -> Result<Self, ConfigError> {
        rt.validate()?;
        stack.validate()?;
        // The node fetch splits nodes into sectors with shifts and masks.
        if !sector_bytes.is_power_of_two() {
            return Err(ConfigError {
                parameter: "sector_bytes",
                value: sector_bytes.to_string(),
                reason: "must be a power of two".into(),
            });
        }
        Ok(RtUnit {
            id,
            cfg,
            rt,
            stack,
            w: cfg.widths()?,
            stack_unit: StackUnit::with_stores(cfg, id, stack.acked_stores(), stack.sh_latency, policy)?,
            fetch: NodeFetch::new(sector_bytes, cfg.threads()),
            warp_buffer: WarpBuffer::new(&cfg)?,
            scheduler: WarpScheduler::default(),
            residence: Vec::new(),
            store_seq: 0,
            next_event: None,
            counted_to: 0,
            stats: RtStats::default(),
            walk_pending: Vec::new(),
            walk_error: None,
        })
    }

    /// The rest of the clock edge for walk-driven warps (the runner calls it right after
    /// [`Unit::commit`]): each thread whose pop was answered, or whose warp landed, has its
    /// walk append its next segment from `walks`, and takes the state of its next operation.
    pub fn follow_walks(&mut self, walks: &mut Option<&mut dyn Walks>, now: u64) {
        if self.walk_pending.is_empty() {
            return;
        }
        let pending = std::mem::take(&mut self.walk_pending);
        for &(t, answer) in &pending {
            match walks {
                Some(w) => self.walk_on(&mut **w, t, answer, now),
                None => {
                    self.walk_error = Some(RunError::Walk {
                        cycle: now,
                        sm: self.id,
                        thread: t,
                        reason: "a walk-driven warp in a run given no walks".into(),
                    })
                }
            }
        }
        self.walk_pending = pending;
        self.walk_pending.clear();
        self.next_event = self.next_event_after(now);
    }

    /// A warp slot that can take a job this cycle.
    pub fn free_slot(&self) -> Option<u32> {
        self.warp_buffer.free_slot()
    }

    /// No warp resident.
    pub fn empty(&self) -> bool {
        self.warp_buffer.empty()
    }

    /// Which source drives the port when it is ready (from registers): by `port_priority`, the
    /// stack's head request or the node fetch queue's head.
    fn port(&self) -> Port {
        let (stack, node) = (self.stack_unit.req().is_some(), !self.fetch.queue_empty());
        match self.stack.port_priority {
            PortPriority::Stack if stack => Port::Stack,
            PortPriority::Node if node => Port::Node,
            _ if stack => Port::Stack,
            _ if node => Port::Node,
            _ => Port::Idle,
        }
    }

    /// The request offered to the L1D this cycle (from registers), as [`RtUnit::port`] chooses;
    /// none unless `req_ready`.
    pub fn req(&self, req_ready: bool) -> Option<MemReq> {
        if !req_ready {
            return None;
        }
        let bytes = self.cfg.entry_bytes;
        match self.port() {
            Port::Stack => {
                let g = self.stack_unit.req()?;
                Some(if g.write {
                    let tag = if self.stack.acked_stores() { u64::from(g.thread) } else { self.store_seq };
                    MemReq::write(tag << 2 | TAG_STORE, g.addr, bytes, ReqKind::StackSpill)
                } else {
                    MemReq::read(u64::from(g.thread) << 2 | TAG_LOAD, g.addr, bytes, ReqKind::StackReload)
                })
            }
            Port::Node => self.fetch.head(TAG_NODE),
            Port::Idle => None,
        }
    }

    /// The cycle's decisions into `d` (cleared), for [`Unit::eval`], in dataflow order: the
    /// port and the job, the warps that leave, the scheduler's pick, the responses, the threads,
    /// then the stack subsystem and the pops it answered. The first problem is the error, and
    /// leaves the rest of `d` unfinished.
    fn decide(&self, i: &RtIn, d: &mut RtStep) -> Result<(), RunError> {
        if let Some(e) = &self.walk_error {
            return Err(e.clone());
        }
        d.now = i.now;
        if let Some(what) = self.stack_unit.manager.scoreboard_failure() {
            return Err(RunError::Decision { sm: self.id, what: what.to_string() });
        }
        self.decide_port(i, d);
        // The lanes waiting to fetch, sorted once: the warps the scheduler may pick, and the lanes
        // the sequencer holds back, whose registers have held since the last edge (this cycle and
        // any skipped before it).
        let (fetch_ready, held) = self.fetch_census();
        d.held = held;
        d.held_cycles = i.now + 1 - self.counted_to;
        self.decide_leaving(d)?;
        self.decide_issue(fetch_ready, d);
        self.route_responses(i, d);
        self.decide_threads(d);
        self.decide_stack(d)?;
        self.match_pops(d)
    }

    /// The job that lands, the free slot it lands in, and which request the memory port takes.
    fn decide_port(&self, i: &RtIn, d: &mut RtStep) {
        d.load_slot = self.free_slot();
        if let Some(job) = i.job {
            d.job.lanes.clone_from(&job.lanes);
            d.job.walk = job.walk;
            d.job_lands = true;
        }
        d.port = if i.req_ready { self.port() } else { Port::Idle };
        d.node_taken = i.req_fire && d.port == Port::Node;
        d.took_stack = i.req_fire && d.port == Port::Stack;
        d.store_taken = d.took_stack && self.stack_unit.req().is_some_and(|g| g.write);
    }

    /// Warp buffer: a warp whose threads all finished and whose stacks are quiet leaves, and
    /// must leave nothing behind.
    fn decide_leaving(&self, d: &mut RtStep) -> Result<(), RunError> {
        let manager = &self.stack_unit.manager;
        for w in Bits::of(self.warp_buffer.drained()) {
            if manager.warp_done(w) {
                if let Some(thread) = manager.warp_threads(w).find(|&t| !self.stack_clear(t)) {
                    return Err(RunError::ExitNotEmpty { cycle: d.now, sm: self.id, thread });
                }
                d.leaving.push(w);
            }
        }
        Ok(())
    }

    /// Scheduler: picks a warp of `fetch_ready` in the cycle the fetch queue drains (the port
    /// taking the last piece is the queue's ready signal); with the node-first port, not while a
    /// stack request waits (Vulkan-Sim schedules no new warp while stores are queued).
    fn decide_issue(&self, fetch_ready: u64, d: &mut RtStep) {
        let stack_waits = self.stack.port_priority == PortPriority::Node && self.stack_unit.req().is_some();
        if self.fetch.queue_len() == usize::from(d.node_taken) && !stack_waits {
            let leaving = &d.leaving;
            let ready = leaving.iter().fold(fetch_ready, |m, &w| m & !(1 << w));
            if let Some(w) = self.scheduler.pick(
                self.rt.warp_select,
                |w| leaving.contains(&w),
                self.cfg.warps,
                |w| ready & (1 << w) != 0,
                |w| self.warp_buffer.age(w),
            ) {
                d.issue = Some((w, self.fetchable(w)));
            }
        }
    }

    /// Responses: node pieces wake lanes; stack loads go to the response FIFO; store
    /// acknowledgements too when stores are acknowledged (their sequencer waits), and need
    /// nothing when they are posted.
    fn route_responses(&self, i: &RtIn, d: &mut RtStep) {
        let ws = self.cfg.warp_size;
        for r in i.resp {
            match r.id & 3 {
                TAG_NODE => {
                    let (w, lanes) = self.fetch.waiters(r.id);
                    for l in lanes_of(lanes) {
                        let t = (w * ws + l) as usize;
                        if d.arrived[t] == 0 {
                            d.arrived_at.push(t as u32);
                        }
                        d.arrived[t] += 1;
                    }
                    d.woken[w as usize] |= lanes;
                    d.woken_warps |= 1 << w;
                    d.node_resp.push(r.id);
                }
                TAG_LOAD => d.completions.push((r.id >> 2) as u32),
                _ => {
                    debug_assert_eq!(r.id & 3, TAG_STORE);
                    if self.stack.acked_stores() {
                        d.completions.push((r.id >> 2) as u32);
                    }
                }
            }
        }
    }

    /// Threads: only the lanes that can act this cycle, in warps that have such lanes: one
    /// woken by a response, scheduled, holding a stack command, or Busy (a warp with no Busy
    /// lane is never due).
    fn decide_threads(&self, d: &mut RtStep) {
        let (ws, now) = (self.cfg.warp_size, d.now);
        let manager = &self.stack_unit.manager;
        let sector_bytes = self.fetch.sector_bytes();
        // (All of them resident: responses and the scheduler serve resident warps only, and the
        // summaries hold resident warps only.)
        let b = &self.warp_buffer;
        let issued = d.issue.map_or(0, |x| 1u64 << x.0);
        let room = self.store_room();
        for w in Bits::of(d.woken_warps | issued | b.stack_warps() | b.busy_warps()) {
            let q = b.lanes(w);
            let due = now >= q.busy_until;
            let scheduled = d.issue.filter(|x| x.0 == w).map_or(0, |x| x.1);
            // A Stack lane whose sequencer is busy, or whose command the full store queue holds
            // back, stays as it is: not visited.
            let stack_ready = if q.stack == 0 || !room { 0 } else { q.stack & manager.ready_lanes(w) };
            let todo = stack_ready | d.woken[w as usize] | scheduled | if due { q.busy } else { 0 };
            for l in lanes_of(todo) {
                let t = w * ws + l;
                let q = b.thread(t);
                let ti = ThreadIn {
                    now,
                    scheduled: scheduled & (1 << l) != 0,
                    arrived: d.arrived[t as usize],
                    // Only a thread with a stack command asks (the sequencer's state is far away).
                    stack_ready: q.state == ThreadState::Stack && room && manager.ready(t),
                    sector_bytes,
                };
                let (th, out) = thread_fsm::next(|k| self.rt.latency(k), q, b.ops(w, l), &ti);
                if th != q {
                    d.threads.push((t, th));
                }
                d.visits += u64::from(out.visit);
                if out.cmd != Cmd::None {
                    d.cmds.push((t, out.cmd));
                }
                if let Some(a) = out.expected_pop {
                    d.expected_pops.push((t, a));
                }
            }
            if due {
                d.due.push(w);
            }
        }
    }

    /// Stack subsystem: the threads' commands, the port's grant and the completions; a refused
    /// command is the cycle's error.
    fn decide_stack(&self, d: &mut RtStep) -> Result<(), RunError> {
        let now = d.now;
        let stack_in =
            StackUnitIn { now, cmds: &d.cmds, req_ready: d.took_stack, completions: &d.completions };
        self.stack_unit.eval(stack_in, &mut d.stack);
        if let Some(&error) = d.stack.manager.errors().first() {
            return Err(RunError::Stack { cycle: now, sm: self.id, error });
        }
        Ok(())
    }

    /// Each pop the traces expect is matched by thread: a pop the manager did not answer is an
    /// error too, not a check skipped.
    fn match_pops(&self, d: &mut RtStep) -> Result<(), RunError> {
        let (ws, now) = (self.cfg.warp_size, d.now);
        let pops = d.stack.manager.pops();
        for &(thread, expected) in &d.expected_pops {
            let walked = self.warp_buffer.walk(thread / ws).is_some();
            if walked && d.stack.manager.restarts().contains(&thread) {
                // The stack had dropped the entry (its own decision, which the scoreboard
                // checks): the walk restarts.
                d.walk_pops.push((thread, Popped::Restart));
                continue;
            }
            match pops.iter().find(|p| p.0 == thread) {
                Some(&(_, got)) if got == expected => {
                    if walked {
                        d.walk_pops.push((thread, Popped::Entry(got)));
                    }
                }
                Some(&(_, got)) => {
                    return Err(RunError::PopMismatch { cycle: now, sm: self.id, thread, expected, got })
                }
                None => return Err(RunError::PopMissing { cycle: now, sm: self.id, thread, expected }),
            }
        }
        Ok(())
    }
}

impl Unit for RtUnit {
    /// The first cycle after the last commit in which this unit does something even if no
    /// memory response arrives; `None` when it only waits for memory (or is empty).
    fn next_event(&self) -> Option<u64> {
        self.next_event
    }

    type In<'a> = RtIn<'a>;
    type Step = RtStep;

    /// One clock cycle, combinational: reads the registers and `i`, writes the outputs and the
    /// next state into `d`; nothing in `self` changes. The first problem (a refused stack
    /// command, a pop that disagrees with the trace, a warp leaving stack entries behind) is the
    /// step's error ([`RtStep::check`]).
    fn eval(&self, i: RtIn<'_>, d: &mut RtStep) {
        d.clear(self.cfg.threads() as usize, self.cfg.warps as usize);
        if let Err(e) = self.decide(&i, d) {
            d.error = Some(e);
        }
    }

    /// The clock edge: applies `d`; the job sent this cycle lands in its slot. A step with a
    /// failed check is not committed.
    fn commit(&mut self, d: &RtStep) {
        debug_assert!(d.error.is_none(), "a failed step committed");
        let ws = self.cfg.warp_size;
        if d.node_taken {
            self.fetch.taken();
        }
        if d.store_taken {
            self.store_seq += 1;
        }
        for &w in &d.leaving {
            if let Some(left) = self.warp_buffer.leave(w) {
                self.residence[left.job as usize] = d.now - left.landed;
            }
        }
        self.scheduler.commit(d.issue.map(|x| x.0), |w| d.leaving.contains(&w));
        if let Some((w, mask)) = d.issue {
            let b = &self.warp_buffer;
            self.fetch.coalesce(
                w,
                lanes_of(mask).filter_map(|l| match b.ops(w, l).get(b.thread(w * ws + l).pos as usize)? {
                    RayOp::Visit { addr, bytes, .. } => Some((l, *addr, *bytes)),
                    _ => None,
                }),
            );
        }
        for &id in &d.node_resp {
            self.fetch.complete(id);
        }
        self.warp_buffer.apply(&d.threads, &d.due, d.now);
        self.walk_pending.extend(d.walk_pops.iter().map(|&(t, a)| (t, Some(a))));
        self.stats.visits += d.visits;
        self.stats.pops_checked += d.expected_pops.len() as u64;
        self.stats.held_fetch_cycles += u64::from(d.held) * d.held_cycles;
        self.counted_to = d.now + 1;
        self.stack_unit.commit(&d.stack);
        if let (true, Some(w)) = (d.job_lands, d.load_slot) {
            self.load(w, &d.job, d.now);
        }
        self.next_event = self.next_event_after(d.now);
    }

    /// Registers, and the cycle `d`.
    fn probe<S: Sink>(&self, d: &RtStep, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("rt_unit");
        self.warp_buffer.probe(s);
        self.scheduler.probe(d.issue, &self.w, self.cfg.warp_size, s);
        // The memory port's request handshake: which source the mux offers (`req_stack` wins) and
        // whether the L1D took it.
        s.push_scope("port");
        s.signal("req_node", 1, u64::from(d.port == Port::Node));
        s.signal("req_stack", 1, u64::from(d.port == Port::Stack));
        s.signal("req_fire", 1, u64::from(d.node_taken || d.took_stack));
        s.pop_scope();
        self.fetch.probe(s);
        self.stack_unit.probe(&d.stack, s);
        s.pop_scope();
    }
}

impl RtUnit {
    /// Next event after cycle `now` (registers after the edge): anything that acts next cycle
    /// without a memory response, else the first operation unit to finish.
    fn next_event_after(&self, now: u64) -> Option<u64> {
        let manager = &self.stack_unit.manager;
        let acts_next = !self.fetch.queue_empty()
            || self.stack_unit.arb.busy()
            || !self.stack_unit.sched.is_idle()
            || self.warp_buffer.drained() != 0
            || Bits::of(self.warp_buffer.fetch_warps()).any(|w| self.fetchable(w) != 0)
            || Bits::of(self.warp_buffer.stack_warps())
                .any(|w| self.warp_buffer.lanes(w).stack & manager.ready_lanes(w) != 0)
            || manager.can_issue();
        if acts_next {
            return Some(now + 1);
        }
        // A lane waiting to fetch on its sequencer (Blocking) moves when the sequencer completes,
        // which one of the events here or a memory response causes.
        // Warps with no Busy lane have no deadline (`WarpBuffer::busy_warps`).
        let event = Bits::of(self.warp_buffer.busy_warps())
            .map(|w| self.warp_buffer.lanes(w).busy_until)
            .chain(self.stack_unit.arb.pipe_due())
            .min()
            .unwrap_or(u64::MAX);
        (event != u64::MAX).then_some(event)
    }

    /// Thread-cycles by category over the run's first `cycles` cycles (the last edge at most at
    /// cycle `cycles - 1`): the warp buffer's lane-cycles by state, with the lanes waiting to
    /// fetch that their sequencer held back moved from the fetch queue to the stack. They sum to
    /// `cycles` × thread slots.
    pub fn thread_cycles(&self, cycles: u64) -> ThreadCycles {
        let b = &self.warp_buffer;
        let since = cycles.checked_sub(self.counted_to).expect("a report covers every edge");
        let held = self.stats.held_fetch_cycles + u64::from(self.fetch_census().1) * since;
        // A held fetch is a lane waiting to fetch, and the states' lanes fit in the slots: a model
        // bug otherwise, never a count that wraps.
        let fetch = b.lane_cycles(ThreadState::FETCH, cycles);
        let t = ThreadCycles {
            node_data: b.lane_cycles(ThreadState::WAIT_MEM, cycles),
            fetch_queue: fetch.checked_sub(held).expect("held fetches outnumber the lanes waiting to fetch"),
            stack: b.lane_cycles(ThreadState::STACK, cycles) + held,
            latency: b.lane_cycles(ThreadState::BUSY, cycles),
            idle: 0,
        };
        let slots = cycles * u64::from(self.cfg.threads());
        ThreadCycles { idle: slots.checked_sub(t.total()).expect("more lane-cycles than slots"), ..t }
    }

    /// The warps with a fetchable lane (a mask), and the lanes waiting to fetch that are not
    /// fetchable: with Blocking timing, those whose stack sequencer holds the fetch back.
    fn fetch_census(&self) -> (u64, u32) {
        let b = &self.warp_buffer;
        Bits::of(b.fetch_warps()).fold((0, 0), |(ready, held), w| {
            let f = self.fetchable(w);
            (if f != 0 { ready | 1 << w } else { ready }, held + (b.lanes(w).fetch & !f).count_ones())
        })
    }

    /// Lanes of warp `w` the scheduler may start fetching: those waiting to fetch, and with
    /// Blocking only those whose stack sequencer is idle, or has only posted stores left
    /// (`store_gating`).
    fn fetchable(&self, w: u32) -> u32 {
        let m = self.warp_buffer.lanes(w).fetch;
        let manager = &self.stack_unit.manager;
        match (self.stack.timing, self.stack.store_gating) {
            (StackTiming::Overlapped, _) => m,
            (StackTiming::Blocking, _) if m == 0 => 0,
            (StackTiming::Blocking, StoreGating::Acked) => m & manager.ready_lanes(w),
            (StackTiming::Blocking, gating) => {
                let ready = m & manager.ready_lanes(w);
                let ws = self.cfg.warp_size;
                lanes_of(m & !ready)
                    .filter(|&l| self.only_posted_stores_left(w * ws + l, gating))
                    .fold(ready, |acc, l| acc | 1 << l)
            }
        }
    }

    /// Everything thread `t`'s sequencer still has to do (in flight and queued) is a store the
    /// fetch need not wait for under `gating`: an SH store, or with `Posted` a global store.
    fn only_posted_stores_left(&self, t: u32, gating: StoreGating) -> bool {
        let manager = &self.stack_unit.manager;
        let posted = |u: &Uop| match u {
            Uop::ShStore { .. } => true,
            Uop::GlobalStore { .. } => gating == StoreGating::Posted,
            _ => false,
        };
        manager.inflight_uop(t).iter().chain(manager.pending_uops(t)).all(posted)
    }

    /// The stack manager may take commands: fewer than `store_queue` global stores wait for
    /// the port (always, when unbounded).
    fn store_room(&self) -> bool {
        self.stack.store_queue == 0 || self.stack_unit.sched.queued_stores() < self.stack.store_queue
    }

    /// Thread `t` holds no stack entry anywhere, and with reallocation its own SH stack is idle
    /// (back from any borrower).
    fn stack_clear(&self, t: u32) -> bool {
        let manager = &self.stack_unit.manager;
        let st = manager.stack(t);
        let th = manager.thread(t);
        let lane = t % self.cfg.warp_size;
        // As the proofs' WarpExit: every queue empty, and every stack back with its owner
        // (alone on its ring, rank 0).
        manager.rb(t).is_empty()
            && (self.cfg.sh_entries == 0 || st.empty)
            && th.spill_ptr == 0
            && !th.overflow
            && st.next_tid == lane
            && st.priority == 0
            && (self.cfg.realloc().is_none() || st.idle)
    }

    /// Clock edge: thread `t`'s walk appends its next segment after `answer` (`None`: its first),
    /// and the thread takes the state of its next operation (a pop's decode saw none yet).
    fn walk_on(&mut self, walks: &mut dyn Walks, t: u32, answer: Option<Popped>, now: u64) {
        let ws = self.cfg.warp_size;
        let (w, l) = (t / ws, t % ws);
        let Some(job) = self.warp_buffer.walk(w) else { return };
        let ops = self.warp_buffer.ops_mut(w, l);
        if let Err(reason) = walks.resume(job, l, answer, ops) {
            self.walk_error = Some(RunError::Walk { cycle: now, sm: self.id, thread: t, reason });
            return;
        }
        if answer.is_some() {
            let q = self.warp_buffer.thread(t);
            let state = thread_fsm::decode(self.warp_buffer.ops(w, l), q.pos);
            if state != q.state {
                self.warp_buffer.apply(&[(t, Thread { state, ..q })], &[], now);
            }
        }
    }

    /// Puts `job` in slot `w` (clock edge): its rays start with the BVH-header latency.
    fn load(&mut self, w: u32, job: &WarpJob, now: u64) {
        let active = job.active_mask();
        self.stack_unit.manager.load_warp(w, active);
        // A two-level trace fetches the acceleration structure's header as its first visit and
        // pays the header latency there; a flat trace reads it without a fetch, here.
        let header_fetched =
            job.lanes.iter().flatten().next().is_some_and(|ops| {
                matches!(ops.first(), Some(RayOp::Visit { kind: NodeKind::BvhHeader, .. }))
            });
        let start = now + if header_fetched { 0 } else { u64::from(self.rt.bvh_header) };
        self.warp_buffer.load(w, &job.lanes, job.walk, active, start, now);
        if job.walk.is_some() {
            // Each ray's first segment, before its header latency ends.
            let ws = self.cfg.warp_size;
            self.walk_pending.extend(lanes_of(active).map(|l| (w * ws + l, None)));
        }
        self.residence.push(0);
        self.stats.warps += 1;
        self.stats.rays += u64::from(active.count_ones());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
