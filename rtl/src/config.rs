//! The one configuration type, and every register width derived from it.
//!
//! Everything that has a width in the hardware (Top, Bottom, Next TID, Priority, Flush, the RB
//! count, the global spill pointer, …) gets it from [`Widths`], which is computed once from a
//! validated [`Config`]. The stack manager sizes its registers from it, the waveform dump
//! declares its wires from it and the cost report counts bits from it.

use std::fmt;
use std::str::FromStr;

use crate::logic::{Int, Logic};

/// Primary (ray-buffer) stack size per thread.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RbSize {
    /// N entries, 1 ≤ N ≤ 64.
    Entries(u32),
    /// Unbounded on chip: never spills (the paper's RB_FULL).
    Full,
}

impl RbSize {
    /// Capacity in entries; `None` for FULL.
    pub fn capacity(self) -> Option<u32> {
        match self {
            RbSize::Entries(n) => Some(n),
            RbSize::Full => None,
        }
    }
}

impl fmt::Display for RbSize {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RbSize::Entries(n) => write!(f, "{n}"),
            RbSize::Full => write!(f, "FULL"),
        }
    }
}

/// Dynamic intra-warp reallocation (SPEC section 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Realloc {
    /// Most stacks a thread may borrow at once (paper: 4).
    pub borrow_limit: u32,
    /// Most consecutive flushes counted per stack (paper: 3). The counter saturates there.
    pub flush_limit: u32,
}

impl Default for Realloc {
    fn default() -> Self {
        Realloc { borrow_limit: 4, flush_limit: 3 }
    }
}

/// How a warp's threads share their SH stacks: the stack policy's one parameter. Each variant
/// derives what depends on it (the chain bound, and through it the Priority width; whether Idle
/// and Next TID exist); the stack manager's decision logic for each is one implementation of
/// `stack_manager::policy::Steps`, chosen from this when the manager is built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ShPolicy {
    /// Each thread uses only its own SH stack (the paper's `+SH`, `+SK`).
    Dedicated,
    /// Dynamic intra-warp reallocation, SPEC section 5 (`+RA`): a thread whose chain is full
    /// borrows the lowest-numbered idle stack of its warp.
    Realloc(Realloc),
    /// Reallocation among neighbours (`+RA_G`): as [`ShPolicy::Realloc`], but a thread borrows
    /// only from the `lanes` lanes of its own group (lanes `G·⌊lane / G⌋` to `G·⌊lane / G⌋ + G − 1`),
    /// so the idle search is G inputs wide instead of the warp's width.
    Group { ra: Realloc, lanes: u32 },
}

impl From<Option<Realloc>> for ShPolicy {
    fn from(ra: Option<Realloc>) -> Self {
        ra.map_or(ShPolicy::Dedicated, ShPolicy::Realloc)
    }
}

impl ShPolicy {
    /// The reallocation parameters, when stacks are lent at all.
    pub fn realloc(&self) -> Option<Realloc> {
        match *self {
            ShPolicy::Dedicated => None,
            ShPolicy::Realloc(ra) | ShPolicy::Group { ra, .. } => Some(ra),
        }
    }

    pub fn realloc_mut(&mut self) -> Option<&mut Realloc> {
        match self {
            ShPolicy::Dedicated => None,
            ShPolicy::Realloc(ra) | ShPolicy::Group { ra, .. } => Some(ra),
        }
    }

    /// Most stacks one thread's chain holds: its own and the ones it may borrow.
    pub fn chain_bound(&self) -> u32 {
        self.realloc().map_or(1, |ra| ra.borrow_limit + 1)
    }

    /// The lanes an idle search of `lane`'s thread looks at, as (first lane, count), in a warp
    /// of `warp_size` lanes.
    pub fn lend_window(&self, lane: u32, warp_size: u32) -> (u32, u32) {
        match *self {
            ShPolicy::Group { lanes, .. } => (lane / lanes * lanes, lanes),
            _ => (0, warp_size),
        }
    }

    /// The name's part: `+RA`, `+RA_G`, or nothing.
    fn token(&self) -> String {
        match *self {
            ShPolicy::Dedicated => String::new(),
            ShPolicy::Realloc(_) => "+RA".into(),
            ShPolicy::Group { lanes, .. } => format!("+RA_{lanes}"),
        }
    }
}

/// What a stack does with the entry that overflows its last on-chip level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Overflow {
    /// Spill it to the thread's region of global memory and reload it on the way back (the
    /// paper's designs).
    #[default]
    Spill,
    /// Drop the oldest entry and set the thread's Overflow bit; a pop that finds the stack empty
    /// with the bit set answers Restart, and the walk goes on from the root along its restart
    /// trail (`+RT`: Laine, HPG 2010; Vaidyanathan, Woop and Benthin, HPG 2019). Nothing goes to
    /// global memory.
    Drop,
}

/// A stack design and the RT unit it sits in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Config {
    /// Primary stack entries per thread (N).
    pub rb: RbSize,
    /// Secondary (shared-memory) stack entries per thread (M); 0 = no SH level.
    pub sh_entries: u32,
    /// Skewed bank access (SK).
    pub skew: bool,
    /// How the warp's threads share SH stacks: dedicated, or reallocated (RA, RA_G).
    pub policy: ShPolicy,
    /// Spill the overflowing entry to global memory, or drop it and restart (RT).
    pub overflow: Overflow,
    /// Threads per warp (hardware: 32).
    pub warp_size: u32,
    /// Warps per RT unit (hardware: 4).
    pub warps: u32,
    /// Shared-memory banks (32).
    pub banks: u32,
    /// Bytes per bank word (4).
    pub bank_bytes: u32,
    /// Bytes per stack entry (8).
    pub entry_bytes: u32,
    /// Width of the per-thread global spill pointer: the deepest global spill region, in entries,
    /// is 2^bits - 1. Exceeding it is reported as an error, never wrapped.
    pub spill_ptr_bits: u32,
}

impl Default for Config {
    /// The paper's baseline, RB_8.
    fn default() -> Self {
        Config {
            rb: RbSize::Entries(8),
            sh_entries: 0,
            skew: false,
            policy: ShPolicy::Dedicated,
            overflow: Overflow::Spill,
            warp_size: 32,
            warps: 4,
            banks: 32,
            bank_bytes: 4,
            entry_bytes: 8,
            spill_ptr_bits: 16,
        }
    }
}

/// Why a configuration was rejected: which parameter, what value, and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigError {
    pub parameter: &'static str,
    pub value: String,
    pub reason: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "invalid configuration: {} = {}: {}", self.parameter, self.value, self.reason)
    }
}

impl std::error::Error for ConfigError {}

fn reject(parameter: &'static str, value: impl fmt::Display, reason: impl Into<String>) -> ConfigError {
    ConfigError { parameter, value: value.to_string(), reason: reason.into() }
}

/// RB count width the model uses for RB = FULL.
pub const RB_FULL_COUNT_BITS: u32 = 16;

/// `x mod m`, without a division when `m` is a power of two (warp sizes, bank and set counts
/// usually are: a division costs the host tens of cycles, and these run for every thread and
/// every access the model visits).
#[inline]
pub(crate) fn rem(x: u64, m: u32) -> u64 {
    if m.is_power_of_two() {
        x & (u64::from(m) - 1)
    } else {
        x % u64::from(m)
    }
}

/// `x / m`, as [`rem`].
#[inline]
pub(crate) fn quot(x: u64, m: u32) -> u64 {
    if m.is_power_of_two() {
        x >> m.trailing_zeros()
    } else {
        x / u64::from(m)
    }
}

/// [`rem`] on 32 bits.
#[inline]
pub(crate) fn rem32(x: u32, m: u32) -> u32 {
    if m.is_power_of_two() {
        x & (m - 1)
    } else {
        x % m
    }
}

/// Warp and lane of thread `t`: a shift and a mask, as the warp size is a power of two
/// ([`Config::validate`]), so no run-time test is needed as in [`rem32`].
#[inline]
pub(crate) fn warp_lane(t: u32, warp_size: u32) -> (u32, u32) {
    debug_assert!(warp_size.is_power_of_two(), "warp size {warp_size}");
    (t >> warp_size.trailing_zeros(), t & (warp_size - 1))
}

/// Bits needed to hold values 0..=max.
pub const fn bits_for(max: u64) -> u32 {
    if max == 0 {
        0
    } else {
        64 - max.leading_zeros()
    }
}

impl Config {
    /// The paper's proposed SMS: RB_8 + SH_8 + SK + RA.
    pub fn sms() -> Self {
        Config {
            sh_entries: 8,
            skew: true,
            policy: ShPolicy::Realloc(Realloc::default()),
            ..Config::default()
        }
    }

    /// The reallocation parameters, when the policy lends stacks.
    pub fn realloc(&self) -> Option<Realloc> {
        self.policy.realloc()
    }

    /// The stack configurations of SPEC section 8: RB_N for N in {2, 4, 8, 16, 32, FULL};
    /// RB_8+SH_M for M in {4, 8, 16}; RB_8+SH_8+SK; the full SMS; SMS on RB_2, RB_4, RB_16.
    pub fn paper_set() -> Vec<Config> {
        let names = [
            "RB_2",
            "RB_4",
            "RB_8",
            "RB_16",
            "RB_32",
            "RB_FULL",
            "RB_8+SH_4",
            "RB_8+SH_8",
            "RB_8+SH_16",
            "RB_8+SH_8+SK",
            "RB_8+SH_8+SK+RA",
            "RB_2+SH_8+SK+RA",
            "RB_4+SH_8+SK+RA",
            "RB_16+SH_8+SK+RA",
        ];
        names.iter().map(|n| n.parse().expect("paper configurations are valid")).collect()
    }

    /// The restart comparison: the paper's spilling designs a restart stack competes with (short
    /// RBs, RB_16, SMS at RB_8 and RB_2), restart stacks of 2 to 16 RB entries (N = 5 is where
    /// Vaidyanathan et al. find a BVH6 walk close to a full stack), and SMS whose SH overflow drops
    /// instead of spilling, with and without reallocation. RB_8, the baseline, is not in it.
    pub fn restart_set() -> Vec<Config> {
        let names = [
            "RB_2",
            "RB_4",
            "RB_16",
            "RB_8+SH_8+SK+RA",
            "RB_2+SH_8+SK+RA",
            "RB_2+RT",
            "RB_4+RT",
            "RB_5+RT",
            "RB_8+RT",
            "RB_16+RT",
            "RB_8+SH_8+SK+RT",
            "RB_8+SH_8+SK+RA+RT",
            "RB_2+SH_8+SK+RA+RT",
        ];
        names.iter().map(|n| n.parse().expect("restart configurations are valid")).collect()
    }

    /// Threads per RT unit.
    pub fn threads(&self) -> u32 {
        self.warps * self.warp_size
    }

    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<(), ConfigError> {
        if let RbSize::Entries(n) = self.rb {
            if !(1..=64).contains(&n) {
                return Err(reject("rb", n, "RB entries must be 1 to 64, or FULL"));
            }
        }
        let m = self.sh_entries;
        if m > 32 || (m != 0 && !m.is_power_of_two()) {
            return Err(reject("sh", m, "SH entries per thread must be 0 or a power of two up to 32"));
        }
        if self.warp_size == 0 || self.warp_size > 32 || !self.warp_size.is_power_of_two() {
            return Err(reject("warp_size", self.warp_size, "must be a power of two from 1 to 32"));
        }
        if !(1..=64).contains(&self.warps) {
            return Err(reject("warps", self.warps, "must be 1 to 64"));
        }
        if self.banks == 0 || !self.banks.is_power_of_two() || self.banks > 64 {
            return Err(reject("banks", self.banks, "must be a power of two from 1 to 64"));
        }
        if self.bank_bytes == 0 || !self.bank_bytes.is_power_of_two() || self.bank_bytes > 8 {
            return Err(reject("bank_bytes", self.bank_bytes, "must be 1, 2, 4 or 8"));
        }
        if self.entry_bytes == 0
            || self.entry_bytes > 8
            || !self.entry_bytes.is_power_of_two()
            || self.entry_bytes < self.bank_bytes
        {
            return Err(reject(
                "entry_bytes",
                self.entry_bytes,
                "must be a power of two, at most 8 and at least one bank word",
            ));
        }
        if !(4..=32).contains(&self.spill_ptr_bits) {
            return Err(reject("spill_ptr_bits", self.spill_ptr_bits, "must be 4 to 32"));
        }
        if let ShPolicy::Group { ra, lanes } = self.policy {
            if lanes < 2 || !lanes.is_power_of_two() || lanes > self.warp_size {
                return Err(reject(
                    "lend_group",
                    lanes,
                    format!(
                        "a lending group must be a power of two from 2 to the warp size ({})",
                        self.warp_size
                    ),
                ));
            }
            if ra.borrow_limit >= lanes {
                return Err(reject(
                    "borrow_limit",
                    ra.borrow_limit,
                    format!("a group of {lanes} lanes lends at most {} stacks to one thread", lanes - 1),
                ));
            }
        }
        if let Some(ra) = self.realloc() {
            if m == 0 {
                return Err(reject(
                    "realloc",
                    "on",
                    "reallocation lends SH stacks, so it needs SH entries (sh > 0)",
                ));
            }
            if self.rb == RbSize::Full {
                return Err(reject(
                    "realloc",
                    "on",
                    "with RB = FULL nothing ever spills, so there is nothing to reallocate",
                ));
            }
            if ra.borrow_limit == 0 || ra.borrow_limit >= self.warp_size {
                return Err(reject(
                    "borrow_limit",
                    ra.borrow_limit,
                    format!("must be 1 to warp_size - 1 = {}", self.warp_size.saturating_sub(1)),
                ));
            }
            if !(1..=15).contains(&ra.flush_limit) {
                return Err(reject("flush_limit", ra.flush_limit, "must be 1 to 15"));
            }
        }
        if self.skew && m == 0 {
            return Err(reject(
                "skew",
                "on",
                "skewed access places SH queues, so it needs SH entries (sh > 0)",
            ));
        }
        if self.rb == RbSize::Full && m != 0 {
            return Err(reject("sh", m, "with RB = FULL nothing spills to SH; use sh = 0"));
        }
        if self.overflow == Overflow::Drop && self.rb == RbSize::Full {
            return Err(reject(
                "restart",
                "on",
                "RT drops entries when the stack overflows, and RB = FULL never overflows: use RB_N",
            ));
        }
        Ok(())
    }

    /// Validates and derives every width.
    pub fn widths(&self) -> Result<Widths, ConfigError> {
        self.validate()?;
        Ok(Widths::derive(self))
    }

    /// Entry index at which thread `tid` (index within its warp) starts its SH queue.
    ///
    /// Without skew, 0. With skew, `(tid / k) mod M` with `k = max(1, W / (M · e))`, where W is
    /// the bank count and e the bank words per entry (32 / (2M) for the paper's 32 banks and
    /// 8-byte entries). When a thread's queue spans the whole bank row or more (2M ≥ 32), k = 1:
    /// consecutive threads start one entry apart, the best spread there is.
    pub fn skew_base(&self, tid: u32) -> u32 {
        self.skew_base_of(&mut Int, tid)
    }

    /// [`Config::skew_base`] over any [`Logic`] (the stack manager's policy borrows a stack at
    /// its skewed base with this).
    pub fn skew_base_of<L: Logic>(&self, l: &mut L, tid: L::Word) -> L::Word {
        let m = self.sh_entries;
        if !self.skew || m == 0 {
            return l.word(0);
        }
        let words_per_entry = self.entry_bytes / self.bank_bytes;
        let k = (self.banks / (m * words_per_entry)).max(1);
        let (kw, mw) = (l.word(k), l.word(m));
        let row = l.div(tid, kw);
        l.rem(row, mw)
    }

    /// Short name in the paper's style: `RB_8`, `RB_8+SH_8+SK+RA`, `RB_FULL`.
    pub fn name(&self) -> String {
        let mut s = format!("RB_{}", self.rb);
        if self.sh_entries > 0 {
            s += &format!("+SH_{}", self.sh_entries);
        }
        if self.skew {
            s += "+SK";
        }
        s += &self.policy.token();
        if self.overflow == Overflow::Drop {
            s += "+RT";
        }
        s
    }
}

impl FromStr for Config {
    type Err = ConfigError;

    /// Parses the paper's names: `RB_8`, `RB_FULL`, `RB_8+SH_8`, `RB_8+SH_8+SK`,
    /// `RB_8+SH_8+SK+RA`, `SMS` (= RB_8+SH_8+SK+RA), `+RA_G` (lending within groups of G lanes),
    /// `+RT` (drop on overflow, restart). Case-insensitive. The result is validated.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let mut cfg = Config::default();
        let name = s.trim();
        if name.eq_ignore_ascii_case("SMS") {
            return Ok(Config::sms());
        }
        let mut saw_rb = false;
        for part in name.split('+') {
            // Matched in upper case; errors quote what was written.
            let upper = part.to_ascii_uppercase();
            if let Some(n) = upper.strip_prefix("RB_") {
                saw_rb = true;
                cfg.rb = if n == "FULL" {
                    RbSize::Full
                } else {
                    RbSize::Entries(
                        n.parse().map_err(|_| reject("rb", &part[3..], "expected a number or FULL"))?,
                    )
                };
            } else if let Some(m) = upper.strip_prefix("SH_") {
                cfg.sh_entries = m.parse().map_err(|_| reject("sh", &part[3..], "expected a number"))?;
            } else if upper == "SK" {
                cfg.skew = true;
            } else if upper == "RT" {
                cfg.overflow = Overflow::Drop;
            } else if upper == "RA" {
                cfg.policy = ShPolicy::Realloc(Realloc::default());
            } else if let Some(g) = upper.strip_prefix("RA_") {
                let lanes: u32 =
                    g.parse().map_err(|_| reject("lend_group", &part[3..], "expected a number of lanes"))?;
                // A group of G lanes has G − 1 stacks to lend: the paper's limit of 4, or fewer.
                let d = Realloc::default();
                let ra = Realloc { borrow_limit: d.borrow_limit.min(lanes.max(2) - 1), ..d };
                cfg.policy = ShPolicy::Group { ra, lanes };
            } else if upper == "SMS" {
                return Err(reject(
                    "config",
                    s,
                    "SMS stands alone (it is RB_8+SH_8+SK+RA); to change it, write its parts out",
                ));
            } else if part.is_empty() {
                return Err(reject(
                    "config",
                    s,
                    "an empty part: expected RB_N or RB_FULL, then +SH_M, +SK, +RA, +RA_G or +RT",
                ));
            } else {
                return Err(reject(
                    "config",
                    s,
                    format!(
                        "unknown part '{part}': expected RB_N, RB_FULL, SH_M, SK, RA, RA_G or RT (or SMS alone)"
                    ),
                ));
            }
        }
        if !saw_rb {
            return Err(reject("config", s, "a configuration name needs an RB part: RB_N or RB_FULL"));
        }
        cfg.validate()?;
        Ok(cfg)
    }
}

/// Width in bits of every register field, derived once from a validated [`Config`].
///
/// A width of 0 means the field does not exist in this configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Widths {
    /// One stack entry (a node address).
    pub entry: u32,
    /// RB occupancy counter, 0..=N. FULL has no hardware bound; the model gives it
    /// [`RB_FULL_COUNT_BITS`], and the cost report sizes FULL to a scene's deepest stack.
    pub rb_count: u32,
    /// SH Top and Bottom pointers: log2 M each.
    pub top: u32,
    pub bottom: u32,
    /// The empty bit that settles Top == Bottom (SPEC 9.1): 1 when M > 0.
    pub sh_empty: u32,
    /// Overflow: global memory holds entries of this thread.
    pub overflow: u32,
    /// Idle: finished, and its SH stack not lent (RA only).
    pub idle: u32,
    /// Next TID: link of the borrow chain (RA only): log2 warp size.
    pub next_tid: u32,
    /// Priority: rank of a stack in its chain, 0..=borrow_limit (RA only).
    pub priority: u32,
    /// Flush: consecutive flushes of a stack, 0..=flush_limit (RA only).
    pub flush: u32,
    /// Global spill pointer: entries this thread holds in global memory.
    pub spill_ptr: u32,
    /// Thread id within the warp (for probes and bank math).
    pub tid: u32,
    /// Thread index within the RT unit (`warps × warp_size` threads): tags the stack's SH and
    /// global requests.
    pub thread: u32,
    /// Occupancy of the bank arbiter's pending list and of its pipeline: each thread has at most
    /// one SH request outstanding, so 0..=threads.
    pub sh_requests: u32,
    /// Warp slot index in the warp buffer (at least 1 bit).
    pub warp: u32,
    /// Live-lane count of a warp, 0..=warp_size.
    pub live: u32,
    /// A thread's traversal state ([`THREAD_STATES`] of them).
    pub thread_state: u32,
    /// Sequencer step: position in the longest micro-op program a command loads (a flush of M
    /// entries, 2M micro-ops, with the spill and the refill around it): 2M + 4 states.
    pub seq_step: u32,
    /// Micro-op slots of a sequencer's program: the longest program a command loads (a flush of
    /// M entries, 2M micro-ops, and the spill after it; or a pop's five) fits, 2M + 4, and the
    /// occupancy fits [`Widths::seq_step`].
    pub seq_slots: u32,
    /// A held micro-op's operands: `uop_a` a stack's lane or a spill slot, `uop_b` an SH entry.
    /// With its kind ([`UOP_CODE_BITS`]), a from-the-latch flag and an immediate entry value they
    /// make one program slot ([`Widths::uop_bits`]).
    pub uop_a: u32,
    pub uop_b: u32,
    /// Occupancy of the response FIFO of the memory scheduler, 0..=threads: a thread has at most
    /// one global request that waits for a response (a load, or an acknowledged store).
    pub gm_responses: u32,
    /// Occupancy of the memory scheduler's request queue when every request waits for its
    /// response (acknowledged stores, `StackTiming::Blocking`): 0..=threads, one each. Posted
    /// stores (`Overlapped`) have no such bound; see [`GM_POSTED_QUEUE_BITS`].
    pub gm_queue: u32,
}

/// Bits of a micro-op's kind code (none and the six kinds of `stack_manager::Uop`).
pub const UOP_CODE_BITS: u32 = 3;

impl Widths {
    /// One micro-op as a sequencer holds it: kind, `a`, `b`, the flag that takes the stored data
    /// from the latch, and the immediate entry value.
    pub fn uop_bits(&self) -> [u32; 5] {
        [UOP_CODE_BITS, self.uop_a, self.uop_b, 1, self.entry]
    }
}

/// States of a thread's traversal state machine (`thread_fsm::ThreadState`: done, busy, fetch,
/// wait for memory, stack), which sizes its waveform field ([`Widths::thread_state`]). Declared
/// here, in the base layer, so that the widths depend on no unit; the state machine checks it
/// against its list of states at compile time.
pub const THREAD_STATES: u64 = 5;

/// Bits of the memory scheduler's request queue with posted stores (`StackTiming::Overlapped`):
/// a thread keeps taking commands while its stores wait for the port, so the model declares no
/// hardware bound; a dump that sees more than `2^16 - 1` queued requests reports it as an error
/// (docs/stack.md, "Widths of the queues").
pub const GM_POSTED_QUEUE_BITS: u32 = 16;

impl Widths {
    fn derive(c: &Config) -> Widths {
        let m = c.sh_entries;
        let log2m = if m == 0 { 0 } else { m.trailing_zeros() };
        let ra = c.realloc();
        // A stack that drops its overflow has no global region, so no spill pointer.
        let spill_ptr = if c.overflow == Overflow::Drop { 0 } else { c.spill_ptr_bits };
        Widths {
            entry: c.entry_bytes * 8,
            rb_count: c.rb.capacity().map_or(RB_FULL_COUNT_BITS, |n| bits_for(n as u64)),
            top: log2m,
            bottom: log2m,
            sh_empty: u32::from(m > 0),
            overflow: 1,
            idle: u32::from(ra.is_some()),
            next_tid: ra.map_or(0, |_| bits_for(c.warp_size as u64 - 1)),
            priority: ra.map_or(0, |_| bits_for(u64::from(c.policy.chain_bound() - 1))),
            flush: ra.map_or(0, |r| bits_for(r.flush_limit as u64)),
            spill_ptr,
            tid: bits_for(c.warp_size as u64 - 1),
            thread: bits_for(c.threads() as u64 - 1),
            sh_requests: bits_for(c.threads() as u64),
            warp: bits_for(u64::from(c.warps.max(2) - 1)),
            live: bits_for(c.warp_size as u64),
            thread_state: bits_for(THREAD_STATES - 1),
            seq_step: bits_for(u64::from(2 * m + 4)),
            seq_slots: 2 * m + 4,
            uop_a: bits_for(c.warp_size as u64 - 1).max(spill_ptr),
            uop_b: log2m,
            gm_responses: bits_for(c.threads() as u64),
            gm_queue: bits_for(c.threads() as u64),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_configuration_widths() {
        let w = Config::sms().widths().unwrap();
        assert_eq!((w.top, w.bottom, w.sh_empty), (3, 3, 1));
        assert_eq!((w.overflow, w.idle, w.next_tid, w.flush), (1, 1, 5, 2));
        // Priority ranks 0..=4 (dedicated + 4 borrowed): 3 bits, one more than the paper's 2.
        assert_eq!(w.priority, 3);
        assert_eq!(w.rb_count, 4);
    }

    #[test]
    fn names_round_trip() {
        for name in [
            "RB_8",
            "RB_FULL",
            "RB_8+SH_8",
            "RB_8+SH_8+SK",
            "RB_8+SH_8+SK+RA",
            "RB_2+SH_8+SK+RA",
            "RB_8+SH_8+SK+RA_8",
            "RB_4+RT",
            "RB_2+SH_8+SK+RA+RT",
        ] {
            let c: Config = name.parse().unwrap();
            assert_eq!(c.name(), name);
        }
        assert_eq!("sms".parse::<Config>().unwrap(), Config::sms());
    }

    #[test]
    fn bad_configurations_name_the_parameter() {
        let cases: [(&str, &str); 8] = [
            ("RB_0", "rb"),
            ("RB_65", "rb"),
            ("RB_8+SH_6", "sh"),
            ("RB_8+SH_64", "sh"),
            ("RB_8+RA", "realloc"),
            ("RB_8+SK", "skew"),
            ("RB_FULL+SH_8", "sh"),
            ("RB_X", "rb"),
        ];
        for (name, param) in cases {
            let e = name.parse::<Config>().unwrap_err();
            assert_eq!(e.parameter, param, "{name}: {e}");
        }
        let e = "SH_8".parse::<Config>().unwrap_err();
        assert_eq!(e.parameter, "config");
        let bad = Config { warp_size: 12, ..Config::default() };
        assert_eq!(bad.validate().unwrap_err().parameter, "warp_size");
        let bad = Config {
            policy: ShPolicy::Realloc(Realloc { borrow_limit: 0, flush_limit: 3 }),
            ..Config::sms()
        };
        assert_eq!(bad.validate().unwrap_err().parameter, "borrow_limit");
    }

    #[test]
    fn a_lending_group_derives_its_limits() {
        let g: Config = "RB_8+SH_8+SK+RA_4".parse().unwrap();
        assert_eq!(g.policy, ShPolicy::Group { ra: Realloc { borrow_limit: 3, flush_limit: 3 }, lanes: 4 });
        assert_eq!(g.policy.chain_bound(), 4);
        assert_eq!(g.widths().unwrap().priority, 2, "ranks 0..=3");
        assert_eq!(g.policy.lend_window(6, 32), (4, 4));
        let wide: Config = "RB_8+SH_8+SK+RA_32".parse().unwrap();
        assert_eq!(wide.realloc(), Config::sms().realloc(), "a warp-wide group keeps the paper's limits");
        assert_eq!(wide.widths().unwrap(), Config::sms().widths().unwrap());
        for bad in ["RB_8+SH_8+RA_3", "RB_8+SH_8+RA_1", "RB_8+SH_8+RA_64", "RB_8+SH_8+RA_x"] {
            assert_eq!(bad.parse::<Config>().unwrap_err().parameter, "lend_group", "{bad}");
        }
        let narrow = Config { warp_size: 2, ..g };
        assert_eq!(narrow.validate().unwrap_err().parameter, "lend_group", "a group wider than the warp");
        let greedy = Config { policy: ShPolicy::Group { ra: Realloc::default(), lanes: 2 }, ..g };
        assert_eq!(greedy.validate().unwrap_err().parameter, "borrow_limit");
    }

    #[test]
    fn a_restart_design_drops_instead_of_spilling_and_has_no_spill_pointer() {
        let rt: Config = "rb_4+rt".parse().unwrap();
        assert_eq!((rt.overflow, rt.name()), (Overflow::Drop, "RB_4+RT".to_string()));
        assert_eq!(rt.widths().unwrap().spill_ptr, 0, "no global region to point into");
        assert_eq!(Config::sms().widths().unwrap().spill_ptr, 16);
        let e = "RB_FULL+RT".parse::<Config>().unwrap_err();
        assert_eq!(e.parameter, "restart");
        assert!(e.to_string().contains("RB = FULL never overflows"), "{e}");
    }

    #[test]
    fn skew_matches_the_spec_example() {
        let c = Config { skew: true, ..Config::sms() };
        // M = 8, k = 2: threads 0 and 16 start at entry 0, 2 and 18 at entry 1, 3 and 19 at 1.
        assert_eq!([0, 16, 2, 18, 1, 17, 3, 19].map(|t| c.skew_base(t)), [0, 0, 1, 1, 0, 0, 1, 1]);
        let m32 = Config { sh_entries: 32, ..c };
        assert_eq!(m32.skew_base(5), 5, "2M > 32: k = 1");
        let no_skew = Config { skew: false, ..c };
        assert_eq!(no_skew.skew_base(5), 0);
    }
}
