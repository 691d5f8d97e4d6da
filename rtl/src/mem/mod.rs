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
//! registers), [`l1d`], [`l2`], [`dram`], and [`hierarchy`] which composes them into
//! [`hierarchy::MemSystem`].
//!
//! Clocking: every unit has `eval`, which reads only its current registers and its inputs and
//! records its decisions in a next-state step `d`, and `commit`, the clock edge, which applies `d`.
//! The state here is RAM-like (tag arrays, MSHR tables, queues), so `d` holds the cycle's
//! decisions (accept, hit, merge, allocate, park, pop) rather than a copy of the state, and
//! `commit` writes them into the arrays without deciding anything new. Every output a unit shows
//! another unit (ready, downstream request, responses) is a function of its registers alone, so
//! the order in which units are evaluated within a cycle does not matter. Probes show the cycle's
//! inputs and decisions when sampled between `eval` and `commit`.
//!
//! Unloaded latencies, measured from the cycle a request is accepted to the cycle its response is
//! visible to the SM, with the defaults: L1D hit 20 (`l1d_hit_latency`); L1D miss, L2 hit 160
//! (`l2_latency`); L1D miss, L2 miss 260 (`l2_latency + dram_latency`, plus
//! `ceil(sector_bytes / dram_bytes_per_cycle) - 1` bus cycles). Queueing adds to these.
//!
//! Write policy: the L1D is write-through, no write-allocate (a store updates a present sector and
//! always goes on to L2; a store miss allocates nothing), as GPU L1s do for global and local
//! stores. The L2 is write-back, write-allocate without fetch: a store marks its sector valid and
//! dirty (the real L2 keeps byte masks), and a dirty line is written to DRAM when evicted. Stores
//! are acknowledged by the L2 (so a reload issued after the acknowledgement sees the data); DRAM
//! writes are posted (they use bandwidth but nobody waits for them).
//!
//! Granularity: tags are per 128-byte line with a valid and a dirty bit per 32-byte sector; a miss
//! fetches one sector, and MSHRs merge misses to the same sector. With `sector_bytes ==
//! line_bytes` the caches are line-granular and MSHRs merge same-line misses.

pub mod cache;
pub mod dram;
pub mod hierarchy;
pub mod l1d;
pub mod l2;
pub mod mshr;

use crate::config::ConfigError;
use std::fmt;

/// Width of an address signal in the waveform.
pub const ADDR_BITS: u32 = 64;
/// Width of a request id signal in the waveform.
pub const ID_BITS: u32 = 64;

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
    pub const ALL: [ReqKind; ReqKind::COUNT] = [
        ReqKind::NodeFetch,
        ReqKind::StackSpill,
        ReqKind::StackReload,
    ];

    /// Index into per-kind counter arrays.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Waveform encoding (2 bits).
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
        MemReq {
            id,
            addr,
            write: false,
            bytes,
            kind,
        }
    }

    pub fn write(id: u64, addr: u64, bytes: u32, kind: ReqKind) -> MemReq {
        MemReq {
            id,
            addr,
            write: true,
            bytes,
            kind,
        }
    }

    /// The response that completes this request.
    pub fn response(&self) -> MemResp {
        MemResp {
            id: self.id,
            addr: self.addr,
        }
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

/// Associativity of a cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Assoc {
    /// One set holding every line.
    Full,
    /// This many ways per set.
    Ways(u32),
}

/// Every parameter of the memory hierarchy. Defaults follow SPEC section 7 (Vulkan-Sim MOBILE);
/// the DRAM bandwidth and the queue and MSHR sizes below L1D are this model's assumptions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemParams {
    /// SMs sharing the L2, one L1D each (8).
    pub sms: u32,
    /// Fill and merge granularity (32 B).
    pub sector_bytes: u32,
    /// Tag granularity (128 B).
    pub line_bytes: u32,
    /// L1D data capacity (64 KB minus the shared-memory carve-out; any multiple of the line size
    /// times the ways, e.g. 56 KB fully associative).
    pub l1d_bytes: u32,
    pub l1d_assoc: Assoc,
    /// Cycles from accepting a read that hits to its response (20).
    pub l1d_hit_latency: u32,
    /// Outstanding missed sectors per L1D (32).
    pub l1d_mshrs: u32,
    /// Requests one L1D MSHR entry can hold (8).
    pub l1d_mshr_merge: u32,
    /// Requests an L1D can hold waiting for the L2 port (8).
    pub l1d_miss_queue: u32,
    /// L2 capacity (3 MB).
    pub l2_bytes: u32,
    pub l2_assoc: Assoc,
    /// Cycles from an L1D accepting a read that misses it and hits L2 to its response (160).
    pub l2_latency: u32,
    /// L2 banks; sectors are interleaved over banks by line, and each bank accepts one request
    /// per cycle (8).
    pub l2_banks: u32,
    /// Requests one bank's pipeline can hold (256).
    pub l2_bank_queue: u32,
    /// Outstanding missed sectors in the whole L2 (256).
    pub l2_mshrs: u32,
    /// Requests one L2 MSHR entry can hold (16).
    pub l2_mshr_merge: u32,
    /// Requests the L2 can hold waiting for DRAM (64).
    pub l2_dram_queue: u32,
    /// Cycles an L2 miss adds to the L2 latency, unloaded (100).
    pub dram_latency: u32,
    /// DRAM data bandwidth (32 B/cycle); a request occupies the bus ceil(bytes / this) cycles.
    pub dram_bytes_per_cycle: u32,
    /// Requests waiting for the DRAM bus (64).
    pub dram_queue: u32,
}

impl Default for MemParams {
    fn default() -> Self {
        MemParams {
            sms: 8,
            sector_bytes: 32,
            line_bytes: 128,
            l1d_bytes: 64 * 1024,
            l1d_assoc: Assoc::Full,
            l1d_hit_latency: 20,
            l1d_mshrs: 32,
            l1d_mshr_merge: 8,
            l1d_miss_queue: 8,
            l2_bytes: 3 * 1024 * 1024,
            l2_assoc: Assoc::Ways(16),
            l2_latency: 160,
            l2_banks: 8,
            l2_bank_queue: 256,
            l2_mshrs: 256,
            l2_mshr_merge: 16,
            l2_dram_queue: 64,
            dram_latency: 100,
            dram_bytes_per_cycle: 32,
            dram_queue: 64,
        }
    }
}

fn reject(
    parameter: &'static str,
    value: impl fmt::Display,
    reason: impl Into<String>,
) -> ConfigError {
    ConfigError {
        parameter,
        value: value.to_string(),
        reason: reason.into(),
    }
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

fn at_least(name: &'static str, value: u32, min: u32, why: &str) -> Result<(), ConfigError> {
    if value < min {
        Err(reject(name, value, format!("must be at least {min}{why}")))
    } else {
        Ok(())
    }
}

impl MemParams {
    /// The defaults with `shared_bytes` of the L1D array given to shared memory.
    pub fn with_shared_carveout(shared_bytes: u32) -> MemParams {
        let d = MemParams::default();
        MemParams {
            l1d_bytes: d.l1d_bytes.saturating_sub(shared_bytes),
            ..d
        }
    }

    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ConfigError> {
        at_least("sms", self.sms, 1, "")?;
        let s = self.sector_bytes;
        if s < 4 || !s.is_power_of_two() {
            return Err(reject(
                "sector_bytes",
                s,
                "must be a power of two, at least 4",
            ));
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
        at_least("l1d_hit_latency", self.l1d_hit_latency, 1, "")?;
        at_least("l1d_mshrs", self.l1d_mshrs, 1, "")?;
        at_least("l1d_mshr_merge", self.l1d_mshr_merge, 1, "")?;
        at_least("l1d_miss_queue", self.l1d_miss_queue, 1, "")?;
        check_cache("l2_bytes", self.l2_bytes, "l2_assoc", self.l2_assoc, l)?;
        at_least(
            "l2_latency",
            self.l2_latency,
            4,
            " (two port registers, one response register and one pipeline stage)",
        )?;
        at_least("l2_banks", self.l2_banks, 1, "")?;
        at_least("l2_bank_queue", self.l2_bank_queue, 1, "")?;
        at_least("l2_mshrs", self.l2_mshrs, 1, "")?;
        at_least("l2_mshr_merge", self.l2_mshr_merge, 1, "")?;
        at_least("l2_dram_queue", self.l2_dram_queue, 1, "")?;
        at_least(
            "dram_latency",
            self.dram_latency,
            2,
            " (the request port and the response register)",
        )?;
        at_least("dram_bytes_per_cycle", self.dram_bytes_per_cycle, 1, "")?;
        at_least("dram_queue", self.dram_queue, 1, "")?;
        Ok(())
    }

    /// Address of the sector holding `addr`.
    pub fn sector_of(&self, addr: u64) -> u64 {
        addr - addr % u64::from(self.sector_bytes)
    }

    /// Panics unless `req` lies within one sector: a requester bug, not a memory condition.
    pub(crate) fn check_request(&self, req: &MemReq) {
        let s = u64::from(self.sector_bytes);
        assert!(
            req.bytes >= 1 && req.addr % s + u64::from(req.bytes) <= s,
            "memory request {req:?} must lie within one {s}-byte sector"
        );
    }
}

#[cfg(test)]
pub(crate) mod testutil {
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
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_56k_fully_associative_works() {
        MemParams::default().validate().unwrap();
        let p = MemParams::with_shared_carveout(8 * 1024);
        assert_eq!(p.l1d_bytes, 56 * 1024);
        p.validate().unwrap();
    }

    #[test]
    fn bad_parameters_are_named() {
        let d = MemParams::default();
        let cases: Vec<(MemParams, &str)> = vec![
            (MemParams { sms: 0, ..d }, "sms"),
            (
                MemParams {
                    sector_bytes: 24,
                    ..d
                },
                "sector_bytes",
            ),
            (
                MemParams {
                    line_bytes: 16,
                    ..d
                },
                "line_bytes",
            ),
            (
                MemParams {
                    l1d_bytes: 1000,
                    ..d
                },
                "l1d_bytes",
            ),
            (
                MemParams {
                    l2_bytes: 3 * 1024 * 1024 + 128,
                    ..d
                },
                "l2_bytes",
            ),
            (
                MemParams {
                    l2_assoc: Assoc::Ways(0),
                    ..d
                },
                "l2_assoc",
            ),
            (
                MemParams {
                    l1d_hit_latency: 0,
                    ..d
                },
                "l1d_hit_latency",
            ),
            (MemParams { l2_latency: 3, ..d }, "l2_latency"),
            (
                MemParams {
                    dram_latency: 0,
                    ..d
                },
                "dram_latency",
            ),
            (
                MemParams {
                    dram_bytes_per_cycle: 0,
                    ..d
                },
                "dram_bytes_per_cycle",
            ),
            (MemParams { l1d_mshrs: 0, ..d }, "l1d_mshrs"),
        ];
        for (p, name) in cases {
            let e = p.validate().unwrap_err();
            assert_eq!(e.parameter, name, "{e}");
        }
        // 3 MB is 1536 sets of 16 ways: not a power of two, still valid.
        assert_eq!(d.l2_bytes / (128 * 16), 1536);
    }
}
