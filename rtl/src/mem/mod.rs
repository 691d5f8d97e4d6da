//! Memory hierarchy of the RT unit: one L1D per SM, an L2 shared by all SMs, and DRAM.
//!
//! ```text
//!   SM 0 ──req/ready──► L1D 0 ──┐
//!   SM 1 ──req/ready──► L1D 1 ──┼──► L2 (banks, MSHR) ──► DRAM (latency + bandwidth queue)
//!   …                           │
//!   SM n ──req/ready──► L1D n ──┘
//! ```
//!
//! One unit per file: [`cache`] (tag store with true LRU), [`mshr`] (miss status holding
//! registers), [`l1d`], [`l2`], [`dram`], and [`hierarchy`], the L2 and DRAM together
//! ([`hierarchy::MemSystem`], the memory the SMs share). Each L1D is its SM's ([`crate::sm::Sm`]);
//! the GPU wires the L1Ds to the L2 ([`crate::gpu::Gpu`]).
//!
//! Clocking (see [`hierarchy`] for the dataflow and docs/memory.md "One cycle"):
//! every unit is a [`crate::clock::Unit`] with register outputs (`ready`, `down_req`,
//! `dram_req`, `resp`: functions of its registers alone), `eval(&self, In, &mut Step)`, a pure function of its registers and this
//! cycle's inputs that writes the cycle's combinational outputs (`Step::out`) and next-state
//! decisions into a step, and `commit(&mut self, &Step)`, the clock edge, which applies the step.
//! The state here is RAM-like (tag arrays, MSHR tables, queues), so a step holds the cycle's
//! decisions (accept, hit, merge, allocate, park, pop) rather than a copy of the state, and
//! `commit` writes them into the arrays as a register file's write port does, without deciding
//! anything new. One output is combinational: the L2's per-SM grant depends on this cycle's
//! requests (the banks' round-robin arbiters), so the L2 is evaluated before the L1Ds, which take
//! the grant as their `down_ready` input. Every other value a unit passes another in a cycle is a
//! register output, so the SMs (and their L1Ds) are siblings whose evaluation order does not
//! matter (the reference loop's evaluation checks evaluate them in a random order each cycle, and
//! every kernel twice). Probes show
//! a unit's registers and a step: sampled between `eval` and `commit`, the cycle's inputs and
//! decisions.
//!
//! Unloaded latencies, measured from the cycle a request is accepted to the cycle its response is
//! visible to the SM, with the defaults: L1D hit 1 (`l1d_hit_latency`, see below); L1D miss, L2
//! hit 160 (`l2_latency`); L1D miss, L2 miss 260 (`l2_latency + dram_latency`, plus
//! `ceil(sector_bytes / dram_bytes_per_cycle) - 1` bus cycles). Queueing adds to these.
//!
//! Write policy: the L1D is write-evict (default) or write-through, never write-allocate (a store
//! always goes on to L2; a store miss allocates nothing), as GPU L1s are for global stores. The
//! L2 is write-back, write-allocate without fetch: a store marks its sector valid and
//! dirty (the real L2 keeps byte masks), and a dirty line is written to DRAM when evicted. Stores
//! are acknowledged by the L2 (so a reload issued after the acknowledgement sees the data); DRAM
//! writes are posted (they use bandwidth but nobody waits for them).
//!
//! Memory path as Vulkan-Sim's RT unit uses it (each mechanism has its old behaviour as an
//! option; sources are Vulkan-Sim files, see also docs/memory.md "Memory path"):
//! - The RT unit accesses the L1D directly (`-gpgpu_rt_use_l1 1`; `rt_unit::memory_cycle`,
//!   `shader.cc:3233`, calls `cache->access` at `shader.cc:3502`) and uses a hit in the cycle of
//!   the lookup (`shader.cc:3557-3575`); the 20-cycle `l1_latency_queue` belongs to the load/store
//!   unit (`shader.cc:2352`). `l1d_hit_latency` counts from acceptance to the response visible to
//!   the RT unit; the L1D's responses are registered, so 1 (visible in the next cycle, where the
//!   RT unit's step consumes it) is the earliest and the default. Old: 20.
//! - Write policy (`-gpgpu_cache:dl1 S:1:128:256,L:L:s:N:L,A:256:8,16:0,32`): `L` =
//!   local write-back / global write-through, whose hit function (`gpu-cache.cc:1295-1305`)
//!   evicts on a global store, and RT-unit stores are global (`GLOBAL_ACC_W`, `shader.cc:3351`):
//!   a store hit invalidates its sector (`gpu-cache.cc:1289`) and goes on to L2
//!   ([`L1dWrite::WriteEvict`]); `N` = no write-allocate, a store miss just goes on
//!   (`gpu-cache.cc:1559`). Old: [`L1dWrite::WriteThrough`] (a hit refreshes LRU, sector kept).
//! - Streaming L1D (`s`): MSHRs = sets × ways × 4 × sectors = 1 × 256 × 4 × 4 = 4096 and merge
//!   = `MAX_WARP_PER_SM` = 64 (`gpu-cache.h:548-566`), miss queue 16 (the config string). Old: 32,
//!   8, 8. The MSHR table is a map, so its size costs nothing per cycle.
//! - Local memory interleaved across threads ([`addr::LocalLayout`]), L2 banks as memory
//!   sub-partitions interleaved every 256 bytes with their own IPOLY-indexed sets
//!   ([`addr::L2Map`]). Old: private per-thread regions, `bank = line mod banks`, `set = line mod
//!   sets`.
//!
//! Granularity: tags are per 128-byte line with a valid and a dirty bit per 32-byte sector; a miss
//! fetches one sector, and MSHRs merge misses to the same sector. With `sector_bytes ==
//! line_bytes` the caches are line-granular and MSHRs merge same-line misses.

pub mod addr;
pub mod cache;
pub mod dram;
pub mod hierarchy;
pub mod l1d;
pub mod l2;
pub mod mshr;

pub use addr::{LocalLayout, SetIndex};

use crate::config::{bits_for, ConfigError};
use crate::params::{check_bounds, Bound};
use std::fmt;

/// Width of an address signal in the waveform.
pub const ADDR_BITS: u32 = 64;
/// Width of a request id signal in the waveform.
pub const ID_BITS: u32 = 64;
/// Width of a one-bit signal (valid, ready, hit…) in the waveform.
pub const FLAG_BITS: u32 = 1;

/// Widths of the memory units' counter and occupancy signals, derived from [`MemParams`]: each is
/// the width of the largest value the register can hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemWidths {
    /// L1D MSHR entries in use, 0..=`l1d_mshrs`.
    pub l1d_mshr_occupancy: u32,
    /// L1D miss-queue depth, 0..=`l1d_miss_queue`.
    pub l1d_miss_queue_depth: u32,
    /// A count of L2 banks (accepts, hits, misses or stalls in one cycle), 0..=`l2_banks`.
    pub l2_bank_count: u32,
    /// L2 MSHR entries in use, 0..=`l2_mshrs`.
    pub l2_mshr_occupancy: u32,
    /// Depth of one L2 bank pipeline, 0..=`l2_bank_queue`.
    pub l2_pipeline_depth: u32,
    /// L2 DRAM-queue depth. Write-backs may push the queue past `l2_dram_queue` (a store or a
    /// fill over a dirty line queues its write-back regardless), so the register is sized for
    /// `2 × l2_dram_queue + l2_banks`.
    pub l2_dram_queue_depth: u32,
    /// Requests waiting for the DRAM bus, 0..=`dram_queue`.
    pub dram_queue_depth: u32,
}

/// What a request is for, so traffic can be counted separately.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum ReqKind {
    /// BVH node (or leaf, or triangle) fetch.
    NodeFetch,
    /// Stack entry stored to local memory (a spill).
    StackSpill,
    /// Stack entry loaded from local memory (a reload).
    StackReload,
}

impl ReqKind {
    pub const COUNT: usize = 3;
    pub const ALL: [ReqKind; ReqKind::COUNT] =
        [ReqKind::NodeFetch, ReqKind::StackSpill, ReqKind::StackReload];

    /// Index into per-kind counter arrays.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Width of [`ReqKind::code`].
    pub const BITS: u32 = bits_for(ReqKind::COUNT as u64 - 1);
    /// The kinds by waveform code ([`ReqKind::code`]): the names of the variants.
    pub const NAMES: &'static [&'static str] = &["node_fetch", "stack_spill", "stack_reload"];
    /// How a waveform shows the kind.
    pub const KIND: crate::trace::Kind = crate::trace::Kind::Enum { name: "req_kind", names: ReqKind::NAMES };

    /// Waveform encoding ([`ReqKind::BITS`] bits): an index into [`ReqKind::NAMES`].
    pub fn code(self) -> u64 {
        self as u64
    }
}

/// A memory request. It must lie within one sector: `addr % sector_bytes + bytes <=
/// sector_bytes`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemReq {
    /// Chosen by the requester; returned in the response. Ids in flight from one SM must differ.
    pub id: u64,
    /// Byte address.
    pub addr: u64,
    pub write: bool,
    pub bytes: u32,
    pub kind: ReqKind,
}

impl MemReq {
    pub fn read(id: u64, addr: u64, bytes: u32, kind: ReqKind) -> MemReq {
        MemReq { id, addr, write: false, bytes, kind }
    }

    pub fn write(id: u64, addr: u64, bytes: u32, kind: ReqKind) -> MemReq {
        MemReq { id, addr, write: true, bytes, kind }
    }

    /// The response that completes this request.
    pub fn response(&self) -> MemResp {
        MemResp { id: self.id, addr: self.addr }
    }
}

/// Completion of a request: read data is available, or a write is acknowledged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemResp {
    pub id: u64,
    pub addr: u64,
}

/// Traffic of one kind at one level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KindCounters {
    pub accesses: u64,
    pub misses: u64,
    pub bytes: u64,
}

/// Event counts of one level. At DRAM every access is an off-chip access and `by_kind` splits
/// them by the kind of request that caused them (a write-back takes the kind of the store that
/// dirtied the line); hits and misses stay zero there.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    pub accesses: u64,
    pub reads: u64,
    pub writes: u64,
    pub hits: u64,
    pub misses: u64,
    /// Read misses that joined an outstanding MSHR entry instead of going down (subset of misses).
    pub merged: u64,
    /// Dirty lines written to the next level on eviction.
    pub write_backs: u64,
    /// Cycles in which a request had to wait (MSHR full, queue full).
    pub stall_cycles: u64,
    pub by_kind: [KindCounters; ReqKind::COUNT],
}

impl Counters {
    /// Traffic of one kind.
    pub fn kind(&self, kind: ReqKind) -> KindCounters {
        self.by_kind[kind.index()]
    }

    /// Adds `other`'s counts to these (totals over SMs).
    pub fn add(&mut self, other: &Counters) {
        self.accesses += other.accesses;
        self.reads += other.reads;
        self.writes += other.writes;
        self.hits += other.hits;
        self.misses += other.misses;
        self.merged += other.merged;
        self.write_backs += other.write_backs;
        self.stall_cycles += other.stall_cycles;
        for (k, o) in self.by_kind.iter_mut().zip(&other.by_kind) {
            k.accesses += o.accesses;
            k.misses += o.misses;
            k.bytes += o.bytes;
        }
    }

    pub(crate) fn access(&mut self, req: &MemReq) {
        self.accesses += 1;
        if req.write {
            self.writes += 1;
        } else {
            self.reads += 1;
        }
        let k = &mut self.by_kind[req.kind.index()];
        k.accesses += 1;
        k.bytes += u64::from(req.bytes);
    }

    pub(crate) fn lookup(&mut self, req: &MemReq, hit: bool) {
        self.access(req);
        if hit {
            self.hits += 1;
        } else {
            self.misses += 1;
            self.by_kind[req.kind.index()].misses += 1;
        }
    }
}

/// What an L1D store hit does to the cached sector (a store always goes on to L2, and a store miss
/// allocates nothing in either policy).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum L1dWrite {
    /// Vulkan-Sim's dl1 policy `L` for the RT unit's global stores: the sector is invalidated
    /// (`data_cache::wr_hit_we`, `gpu-cache.cc:1274-1292`), so a reload misses.
    WriteEvict,
    /// Old behaviour: the sector stays valid and the line becomes most recently used.
    WriteThrough,
}

named_enum!(L1dWrite, L1dWrite::WriteEvict => "evict", L1dWrite::WriteThrough => "through");

/// Associativity of a cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Assoc {
    /// One set holding every line.
    Full,
    /// This many ways per set.
    Ways(u32),
}

/// A cache's ways as a description spells them: 0 for fully associative.
impl crate::params::Param for Assoc {
    const KIND: crate::params::Kind = crate::params::Kind::Ways;
    fn value(self) -> crate::params::Value {
        crate::params::Value::Uint(match self {
            Assoc::Full => 0,
            Assoc::Ways(w) => w,
        })
    }
    fn from_value(v: crate::params::Value) -> Option<Assoc> {
        match v {
            crate::params::Value::Uint(0) => Some(Assoc::Full),
            crate::params::Value::Uint(w) => Some(Assoc::Ways(w)),
            _ => None,
        }
    }
}

params! {
    /// Every parameter of the memory hierarchy. Defaults follow SPEC section 7 (Vulkan-Sim MOBILE);
    /// the DRAM bandwidth and the queue and MSHR sizes below L1D are this model's assumptions.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub struct MemParams {
        /// SMs sharing the L2, one L1D each (8).
        ["mem" "sms", Bound::at_least(1)]
        pub sms: u32 = 8,
        /// Fill and merge granularity (32 B).
        ["mem" "sector_bytes"]
        pub sector_bytes: u32 = 32,
        /// Tag granularity (128 B).
        ["mem" "line_bytes"]
        pub line_bytes: u32 = 128,
        /// L1D data capacity (64 KB minus the shared-memory carve-out; any multiple of the line size
        /// times the ways, e.g. 56 KB fully associative).
        ["mem" "l1d_bytes"]
        pub l1d_bytes: u32 = 64 * 1024,
        /// Ways of an L1D set; 0 = fully associative (the default).
        ["mem" "l1d_ways"]
        pub l1d_assoc: Assoc = Assoc::Full,
        /// Cycles from accepting a read that hits to its response being visible to the RT unit (1:
        /// Vulkan-Sim's RT unit uses an L1D hit in the cycle of the lookup, and 1 is the earliest a
        /// registered response allows; `legacy`'s 20 is the load/store unit's `-gpgpu_l1_latency`).
        ["mem" "l1d_hit_latency", Bound::at_least(1)]
        pub l1d_hit_latency: u32 = 1,
        /// Outstanding missed sectors per L1D (4096: Vulkan-Sim's streaming L1D, `gpu-cache.h:562`;
        /// old 32).
        ["mem" "l1d_mshrs", Bound::at_least(1)]
        pub l1d_mshrs: u32 = 4096,
        /// Requests one L1D MSHR entry can hold (64 = `MAX_WARP_PER_SM`, `gpu-cache.h:564`; old 8).
        ["mem" "l1d_mshr_merge", Bound::at_least(1)]
        pub l1d_mshr_merge: u32 = 64,
        /// Requests an L1D can hold waiting for the L2 port (16: the dl1 config string; old 8).
        ["mem" "l1d_miss_queue", Bound::at_least(1)]
        pub l1d_miss_queue: u32 = 16,
        /// What a store hit does (write-evict; old write-through).
        ["mem" "l1d_write"]
        pub l1d_write: L1dWrite = L1dWrite::WriteEvict,
        /// L2 capacity (3 MB).
        ["mem" "l2_bytes"]
        pub l2_bytes: u32 = 3 * 1024 * 1024,
        /// Ways of an L2 set; 0 = fully associative (16).
        ["mem" "l2_ways"]
        pub l2_assoc: Assoc = Assoc::Ways(16),
        /// Cycles from an L1D accepting a read that misses it and hits L2 to its response (160).
        ["mem" "l2_latency", Bound::at_least(4)
            .because("must be at least {least} (two port registers, one response register and one pipeline stage)")]
        pub l2_latency: u32 = 160,
        /// L2 banks (memory sub-partitions), each with its own sets (`l2_bytes / l2_banks`); each bank
        /// accepts one request per cycle (8).
        ["mem" "l2_banks", Bound::at_least(1)]
        pub l2_banks: u32 = 8,
        /// Bytes of consecutive addresses per bank before the next bank: `bank = addr /
        /// interleave mod banks` (256: MOBILE `-gpgpu_mem_addr_mapping dramid@8`; `legacy`'s 128 = the
        /// line, which with [`SetIndex::Linear`] is one array: `line mod banks`, `line mod sets`). A power of
        /// two, at least the line.
        ["mem" "l2_interleave_bytes"]
        pub l2_interleave_bytes: u32 = 256,
        /// Set index within a bank, over the address with the bank digit removed (IPOLY; old linear).
        ["mem" "l2_set_index"]
        pub l2_set_index: SetIndex = SetIndex::Ipoly,
        /// Requests one bank's pipeline can hold (256).
        ["mem" "l2_bank_queue", Bound::at_least(1)]
        pub l2_bank_queue: u32 = 256,
        /// Outstanding missed sectors in the whole L2 (256).
        ["mem" "l2_mshrs", Bound::at_least(1)]
        pub l2_mshrs: u32 = 256,
        /// Requests one L2 MSHR entry can hold (16).
        ["mem" "l2_mshr_merge", Bound::at_least(1)]
        pub l2_mshr_merge: u32 = 16,
        /// Requests the L2 can hold waiting for DRAM (64).
        ["mem" "l2_dram_queue", Bound::at_least(1)]
        pub l2_dram_queue: u32 = 64,
        /// Cycles an L2 miss adds to the L2 latency, unloaded (100).
        ["mem" "dram_latency", Bound::at_least(2).because("must be at least {least} (the request port and the response register)")]
        pub dram_latency: u32 = 100,
        /// DRAM data bandwidth (32 B/cycle); a request occupies the bus ceil(bytes / this) cycles.
        ["mem" "dram_bytes_per_cycle", Bound::at_least(1)]
        pub dram_bytes_per_cycle: u32 = 32,
        /// Requests waiting for the DRAM bus (64).
        ["mem" "dram_queue", Bound::at_least(1)]
        pub dram_queue: u32 = 64,
        /// Where threads' spill slots live (interleaved across threads; old per-thread regions).
        ["mem" "local_layout"]
        pub local_layout: LocalLayout = LocalLayout::Interleaved,
    }
}

fn reject(parameter: &'static str, value: impl fmt::Display, reason: impl Into<String>) -> ConfigError {
    ConfigError { parameter, value: value.to_string(), reason: reason.into() }
}

fn check_cache(
    bytes_name: &'static str,
    bytes: u32,
    assoc_name: &'static str,
    assoc: Assoc,
    line: u32,
) -> Result<(), ConfigError> {
    if bytes == 0 || !bytes.is_multiple_of(line) {
        return Err(reject(
            bytes_name,
            bytes,
            format!("must be a positive multiple of the line size ({line} B)"),
        ));
    }
    if let Assoc::Ways(w) = assoc {
        if w == 0 {
            return Err(reject(assoc_name, w, "ways must be at least 1"));
        }
        if !bytes.is_multiple_of(line * w) {
            return Err(reject(
                bytes_name,
                bytes,
                format!("must be a multiple of line size × ways = {line} × {w}"),
            ));
        }
    }
    Ok(())
}

impl MemParams {
    /// These parameters with `shared_bytes` of the unified L1D/shared array given to shared
    /// memory: the rest is L1D. The one place the carve-out is computed (`gpu::carve_out` gives
    /// a configuration's SH stacks' bytes).
    pub fn with_shared_carveout(self, shared_bytes: u32) -> MemParams {
        MemParams { l1d_bytes: self.l1d_bytes.saturating_sub(shared_bytes), ..self }
    }

    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ConfigError> {
        check_bounds(MemParams::KEYS, self)?;
        let s = self.sector_bytes;
        if s < 4 || !s.is_power_of_two() {
            return Err(reject("sector_bytes", s, "must be a power of two, at least 4"));
        }
        let l = self.line_bytes;
        if !l.is_power_of_two() || l < s || l / s > 32 {
            return Err(reject(
                "line_bytes",
                l,
                format!("must be a power of two from sector_bytes ({s}) to 32 sectors"),
            ));
        }
        check_cache("l1d_bytes", self.l1d_bytes, "l1d_assoc", self.l1d_assoc, l)?;
        check_cache("l2_bytes", self.l2_bytes, "l2_assoc", self.l2_assoc, l)?;
        let i = self.l2_interleave_bytes;
        if !i.is_power_of_two() || i < l {
            return Err(reject(
                "l2_interleave_bytes",
                i,
                format!("must be a power of two, at least line_bytes ({l})"),
            ));
        }
        if let Some(map) = self.l2_map() {
            if map.sets_per_bank == 0 {
                let ways = match self.l2_assoc {
                    Assoc::Full => "1 set".to_string(),
                    Assoc::Ways(w) => format!("{w} ways"),
                };
                return Err(reject(
                    "l2_bytes",
                    self.l2_bytes,
                    format!(
                        "must split into whole sets per bank: a multiple of line size ({l}) × {ways} × {} banks",
                        self.l2_banks
                    ),
                ));
            }
            if let Some(why) = addr::L2Map::unsupported(map.sets_per_bank, self.l2_set_index) {
                return Err(reject("l2_set_index", self.l2_set_index, why));
            }
        }
        Ok(())
    }

    /// The L2's bank and set mapping, or `None` for the single-array mapping (linear index,
    /// line interleaving: `bank = line mod banks`, `set = line mod sets`). `sets_per_bank` is 0
    /// when the L2 does not split into whole sets per bank (rejected by `validate`). A fully
    /// associative L2 is one set per bank.
    pub fn l2_map(&self) -> Option<addr::L2Map> {
        if self.l2_set_index == SetIndex::Linear && self.l2_interleave_bytes == self.line_bytes {
            return None;
        }
        let lines = self.l2_bytes / self.line_bytes;
        let per_bank = lines / self.l2_banks.max(1);
        let sets_per_bank = match self.l2_assoc {
            _ if !lines.is_multiple_of(self.l2_banks.max(1)) => 0,
            Assoc::Full => 1,
            Assoc::Ways(w) if w > 0 && per_bank.is_multiple_of(w) => per_bank / w,
            Assoc::Ways(_) => 0,
        };
        Some(addr::L2Map {
            banks: self.l2_banks,
            interleave_bytes: self.l2_interleave_bytes,
            line_bytes: self.line_bytes,
            sets_per_bank,
            index: self.l2_set_index,
        })
    }

    /// Widths of the memory units' signals.
    pub fn widths(&self) -> MemWidths {
        let w = |max: u32| bits_for(u64::from(max));
        MemWidths {
            l1d_mshr_occupancy: w(self.l1d_mshrs),
            l1d_miss_queue_depth: w(self.l1d_miss_queue),
            l2_bank_count: w(self.l2_banks),
            l2_mshr_occupancy: w(self.l2_mshrs),
            l2_pipeline_depth: w(self.l2_bank_queue),
            l2_dram_queue_depth: bits_for(2 * u64::from(self.l2_dram_queue) + u64::from(self.l2_banks)),
            dram_queue_depth: w(self.dram_queue),
        }
    }

    /// Address of the sector holding `addr`.
    #[inline]
    pub fn sector_of(&self, addr: u64) -> u64 {
        // A power of two (validated): a mask, not a division.
        debug_assert!(self.sector_bytes.is_power_of_two());
        addr & !(u64::from(self.sector_bytes) - 1)
    }

    /// Panics unless `req` lies within one sector: a requester bug, not a memory condition.
    pub(crate) fn check_request(&self, req: &MemReq) {
        let s = u64::from(self.sector_bytes);
        assert!(
            req.bytes >= 1 && (req.addr & (s - 1)) + u64::from(req.bytes) <= s,
            "memory request {req:?} must lie within one {s}-byte sector"
        );
    }
}

#[cfg(test)]
pub(crate) mod testutil {
    use super::l2::{L2In, L2Step, L2};
    use super::{MemParams, MemReq, MemResp};
    use crate::clock::Unit;
    use std::collections::VecDeque;

    /// An L2 with a stand-in DRAM answering every read `dram` cycles after it is offered.
    pub struct L2Bench {
        pub l2: L2,
        pub dram: u64,
        pub in_dram: VecDeque<(u64, MemResp)>,
        pub dram_out: Vec<MemResp>,
        pub dram_log: Vec<MemReq>,
        pub resp_log: Vec<(u64, usize, MemResp)>,
        pub cycle: u64,
    }

    impl L2Bench {
        pub fn new(p: MemParams, dram: u64) -> L2Bench {
            L2Bench {
                l2: L2::new(&p),
                dram,
                in_dram: VecDeque::new(),
                dram_out: Vec::new(),
                dram_log: Vec::new(),
                resp_log: Vec::new(),
                cycle: 0,
            }
        }

        /// One cycle on the SMs' down requests `reqs`; returns the grants.
        pub fn step(&mut self, reqs: &[Option<MemReq>]) -> Vec<bool> {
            self.step_committing(reqs, |l2, d| l2.commit(d))
        }

        /// [`L2Bench::step`], the clock edge made by `commit`.
        pub fn step_committing(
            &mut self,
            reqs: &[Option<MemReq>],
            commit: impl FnOnce(&mut L2, &L2Step),
        ) -> Vec<bool> {
            for sm in 0..self.l2.params().sms as usize {
                for r in self.l2.resp(sm) {
                    self.resp_log.push((self.cycle, sm, *r));
                }
            }
            let to_dram = self.l2.dram_req();
            let fills = std::mem::take(&mut self.dram_out);
            let mut d = L2Step::default();
            self.l2.eval(L2In { reqs, dram_ready: true, fills: &fills }, &mut d);
            let granted = d.out.granted.clone();
            commit(&mut self.l2, &d);
            if let Some(r) = to_dram {
                self.dram_log.push(r);
                if !r.write {
                    self.in_dram.push_back((self.cycle + self.dram, r.response()));
                }
            }
            while self.in_dram.front().is_some_and(|&(c, _)| c <= self.cycle + 1) {
                self.dram_out.push(self.in_dram.pop_front().unwrap().1);
            }
            self.cycle += 1;
            granted
        }

        /// Steps with no request until the L2 and the stand-in DRAM are idle.
        pub fn settle(&mut self, sms: usize) {
            for _ in 0..10_000 {
                if self.l2.next_event().is_none() && self.in_dram.is_empty() && self.dram_out.is_empty() {
                    return;
                }
                self.step(&vec![None; sms]);
            }
            panic!("did not settle");
        }
    }

    /// Tiny deterministic generator for test streams (xorshift64).
    pub struct XorShift(pub u64);

    impl XorShift {
        pub fn next(&mut self) -> u64 {
            let mut x = self.0;
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            self.0 = x;
            x
        }

        /// Uniform-enough value in 0..n.
        pub fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }

        /// An L1D's input in cycle `now` of a bursty stream: in the first 100 cycles of every 300,
        /// a request half the time (a 32-byte-aligned address among 64, one in five a stack
        /// store, the rest node reads); none in the pauses.
        pub fn burst_request(&mut self, now: u64) -> Option<super::MemReq> {
            use super::{MemReq, ReqKind};
            (now % 300 < 100 && self.below(2) == 0).then(|| {
                let addr = self.below(64) * 32;
                match self.below(5) {
                    0 => MemReq::write(now, addr, 8, ReqKind::StackSpill),
                    _ => MemReq::read(now, addr, 8, ReqKind::NodeFetch),
                }
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_56k_fully_associative_works() {
        MemParams::default().validate().unwrap();
        let p = MemParams::default().with_shared_carveout(8 * 1024);
        assert_eq!(p.l1d_bytes, 56 * 1024);
        p.validate().unwrap();
    }

    #[test]
    fn bad_parameters_are_named() {
        let d = MemParams::default();
        let cases: Vec<(MemParams, &str)> = vec![
            (MemParams { sms: 0, ..d }, "sms"),
            (MemParams { sector_bytes: 24, ..d }, "sector_bytes"),
            (MemParams { line_bytes: 16, ..d }, "line_bytes"),
            (MemParams { l1d_bytes: 1000, ..d }, "l1d_bytes"),
            (MemParams { l2_bytes: 3 * 1024 * 1024 + 128, ..d }, "l2_bytes"),
            (MemParams { l2_assoc: Assoc::Ways(0), ..d }, "l2_assoc"),
            (MemParams { l1d_hit_latency: 0, ..d }, "l1d_hit_latency"),
            (MemParams { l2_latency: 3, ..d }, "l2_latency"),
            (MemParams { dram_latency: 0, ..d }, "dram_latency"),
            (MemParams { dram_bytes_per_cycle: 0, ..d }, "dram_bytes_per_cycle"),
            (MemParams { l1d_mshrs: 0, ..d }, "l1d_mshrs"),
            (MemParams { l2_interleave_bytes: 64, ..d }, "l2_interleave_bytes"),
            (MemParams { l2_interleave_bytes: 384, ..d }, "l2_interleave_bytes"),
            // 3 MB over 5 banks is not whole lines per bank.
            (MemParams { l2_banks: 5, ..d }, "l2_bytes"),
            // 2 MB / 8 banks / 16 ways = 128 sets: fine; 1.5 MB → 96 sets: fine; 3 MB / 8 / 32
            // ways = 96; 3 MB / 16 banks / 64 ways = 24 sets: no IPOLY.
            (MemParams { l2_banks: 16, l2_assoc: Assoc::Ways(64), ..d }, "l2_set_index"),
        ];
        for (p, name) in cases {
            let e = p.validate().unwrap_err();
            assert_eq!(e.parameter, name, "{e}");
        }
        // 3 MB is 1536 sets of 16 ways: not a power of two, still valid; per bank 192 = 3 × 64.
        assert_eq!(d.l2_bytes / (128 * 16), 1536);
        assert_eq!(d.l2_map().unwrap().sets_per_bank, 192);
        // The same sizes with the linear index are valid, and the old mapping has no bank split.
        MemParams { l2_banks: 16, l2_assoc: Assoc::Ways(64), l2_set_index: SetIndex::Linear, ..d }
            .validate()
            .unwrap();
        let old = MemParams { l2_set_index: SetIndex::Linear, l2_interleave_bytes: 128, l2_banks: 5, ..d };
        assert!(old.l2_map().is_none());
        old.validate().unwrap();
    }

    /// (bank, set) of the first spill slot (slot 0) of each of `threads` threads on each of `sms`
    /// SMs, as the real stack managers compute the address and the L2 maps it.
    fn first_slots(p: &MemParams, sms: u32) -> Vec<(u32, usize)> {
        use crate::config::Config;
        use crate::stack_manager::StackManager;
        let g = cache::Geometry::l2(p);
        let cfg = Config::default();
        (0..sms)
            .flat_map(|sm| {
                let mut m = StackManager::new(cfg, sm).unwrap();
                m.set_local_layout(p.local_layout, p.sms);
                (0..cfg.threads()).map(move |t| m.spill_addr(t, 0)).collect::<Vec<_>>()
            })
            .map(|a| (g.bank_of(a, p.l2_banks), g.set_of(a)))
            .collect()
    }

    /// Largest number of distinct lines (ignoring sectors) falling into one set.
    fn worst_set(p: &MemParams, sms: u32) -> usize {
        use std::collections::BTreeMap;
        let mut lines: BTreeMap<usize, std::collections::BTreeSet<u64>> = BTreeMap::new();
        let cfg = crate::config::Config::default();
        let g = cache::Geometry::l2(p);
        for sm in 0..sms {
            let mut m = crate::stack_manager::StackManager::new(cfg, sm).unwrap();
            m.set_local_layout(p.local_layout, p.sms);
            for t in 0..cfg.threads() {
                let a = m.spill_addr(t, 0);
                lines.entry(g.set_of(a)).or_default().insert(a / 128);
            }
        }
        lines.values().map(|l| l.len()).max().unwrap()
    }

    #[test]
    fn first_spill_slots_spread_over_banks_and_sets() {
        use std::collections::BTreeSet;
        let new = MemParams::default();
        let old = MemParams {
            local_layout: LocalLayout::Linear,
            l2_set_index: SetIndex::Linear,
            l2_interleave_bytes: 128,
            ..new
        };
        let count = |v: &[(u32, usize)]| {
            let banks: BTreeSet<u32> = v.iter().map(|x| x.0).collect();
            let sets: BTreeSet<usize> = v.iter().map(|x| x.1).collect();
            (banks.len(), sets.len())
        };
        // Old: 128 threads 512 KB apart are 128 lines in 3 sets of bank 0, 43 lines per set
        // against 16 ways (the issue's "evicted to DRAM"); 8 SMs still only 3 sets of bank 0.
        assert_eq!(count(&first_slots(&old, 1)), (1, 3));
        assert_eq!(worst_set(&old, 1), 43);
        assert_eq!(count(&first_slots(&old, 8)), (1, 3));
        assert_eq!(worst_set(&old, 8), 342);
        // New: one SM's 128 first slots are 1 KB, 8 lines (4 warps × 256 B), each in its own set
        // (a 256-byte chunk of one warp, two lines, is in one bank; warp slots are 8 SMs' warps
        // apart, so one SM's warps share a bank as they share a channel in GPGPU-Sim); all 8 SMs'
        // are 8 KB over every bank, one line per set.
        assert_eq!(count(&first_slots(&new, 1)), (1, 8));
        assert_eq!(worst_set(&new, 1), 1);
        assert_eq!(count(&first_slots(&new, 8)), (8, 64));
        assert_eq!(worst_set(&new, 8), 1);
        // The new layout alone, with the old L2 mapping, is as dense (8 KB over 64 line sets).
        let layout_only = MemParams { local_layout: LocalLayout::Interleaved, ..old };
        assert_eq!(count(&first_slots(&layout_only, 8)), (8, 64));
        // The new L2 mapping alone spreads the old layout's lines over many sets (IPOLY), though
        // 512 KB strides keep them in one bank.
        let map_only = MemParams { local_layout: LocalLayout::Linear, ..new };
        let (banks, sets) = count(&first_slots(&map_only, 8));
        assert_eq!(banks, 1);
        assert!(sets >= 64, "{sets} sets");
        assert!(worst_set(&map_only, 8) <= 16, "at most one set's ways per set");
    }
}
