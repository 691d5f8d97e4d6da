//! The warp buffer of an RT unit: `warps` slots, each holding a resident warp's rays (their
//! traces), its age, and the state of each of its threads.
//!
//! ```text
//!  job (clock edge) ──► slot w: lanes' ops, age (0 = oldest resident), threads[w × ws + l]
//!                          │  per-lane masks by state (fetch, wait, busy, stack), live count
//!                          ▼
//!                 warp leaves (live = 0 and its stacks quiet): ranks of younger warps close up
//! ```
//!
//! The per-lane masks are derived registers kept in step with the thread states, so a cycle
//! visits only the lanes that can act (woken by a response, due to leave an operation unit,
//! scheduled, or holding a stack command) instead of all of them. The age is a rank among the
//! resident warps (what the GTO scheduler compares), so it is a warp index wide.

use crate::config::{warp_lane, Config, ConfigError, Widths};
use crate::ray_op::RayOp;
use crate::thread_fsm::{Thread, ThreadState};
use crate::trace::{Kind, Probe, Sink};

/// Per warp, which lanes are in which state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lanes {
    pub fetch: u32,
    pub wait: u32,
    pub busy: u32,
    pub stack: u32,
    /// Earliest `until` among the busy lanes (`u64::MAX` when none).
    pub busy_until: u64,
}

impl Lanes {
    pub const EMPTY: Lanes = Lanes { fetch: 0, wait: 0, busy: 0, stack: 0, busy_until: u64::MAX };

    /// Lanes not Done (the `live` count).
    #[inline]
    pub fn live(&self) -> u32 {
        (self.fetch | self.wait | self.busy | self.stack).count_ones()
    }

    /// Lane `l` moves from `old` to `new`: the mask of `old`'s state loses the lane and the mask
    /// of `new`'s gains it (Done has no mask). Each mask is computed from the states'
    /// [`ThreadState::code`]s in registers, with no branch. Masks kept in a small array, changed
    /// by index and read back as a whole, would make that read wait for the narrow store to
    /// reach the cache (a failed store-to-load forward) on every thread update.
    #[inline]
    fn set(&mut self, l: u32, old: ThreadState, new: ThreadState) {
        let bit = 1u32 << l;
        let (o, n) = (old.code(), new.code());
        let moved = |m: u32, c: u64| m & !(if o == c { bit } else { 0 }) | if n == c { bit } else { 0 };
        self.busy = moved(self.busy, ThreadState::BUSY);
        self.fetch = moved(self.fetch, ThreadState::FETCH);
        self.wait = moved(self.wait, ThreadState::WAIT_MEM);
        self.stack = moved(self.stack, ThreadState::STACK);
        if let ThreadState::Busy { until } = new {
            self.busy_until = self.busy_until.min(until);
        }
    }
}

/// Iterates the set bits of `m`, lowest first.
#[inline]
pub fn lanes_of(m: u32) -> Bits {
    Bits(u64::from(m))
}

/// The set bits of a mask, lowest first ([`lanes_of`], [`WarpBuffer::resident`]).
#[derive(Clone, Copy, Debug)]
pub struct Bits(u64);

impl Bits {
    /// The set bits of `m`.
    #[inline]
    pub fn of(m: u64) -> Bits {
        Bits(m)
    }
}

impl Iterator for Bits {
    type Item = u32;

    #[inline]
    fn next(&mut self) -> Option<u32> {
        if self.0 == 0 {
            return None;
        }
        let b = self.0.trailing_zeros();
        self.0 &= self.0 - 1;
        Some(b)
    }
}

/// A resident warp.
#[derive(Clone, Debug)]
struct Slot {
    /// Rank among the resident warps by load order: 0 is the oldest.
    age: u32,
    /// Load order within the RT unit (testbench bookkeeping: indexes the residence record).
    job: u64,
    /// Cycle the warp was loaded.
    landed: u64,
    /// A walk-driven warp's id for the run's walks (`WarpJob::walk`).
    walk: Option<u64>,
}

/// A warp that left: which job, and when it had landed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Left {
    pub job: u64,
    pub landed: u64,
}

#[derive(Clone, Debug)]
pub struct WarpBuffer {
    warp_size: u32,
    slots: Vec<Option<Slot>>,
    threads: Vec<Thread>,
    /// Each thread's trace (empty for an inactive lane or an empty slot), by thread: the RT unit
    /// reads a lane's next operation in one step.
    ops: Vec<Vec<RayOp>>,
    lanes: Vec<Lanes>,
    /// Bit w: slot w holds a warp (derived from `slots`, so scans visit only resident warps).
    occupied: u64,
    /// Bit w for every slot (a constant).
    slot_mask: u64,
    /// Derived from `lanes` at every edge, bit w per warp: lanes waiting to fetch, lanes holding
    /// a stack command, Busy lanes, and (resident warps only) no live lane. Each is a subset of
    /// `occupied`: a warp leaves only with no live lane, so its other bits are clear then. The RT unit's scans
    /// visit only the warps whose bit is set (most warps have nothing to do in a cycle).
    fetch_warps: u64,
    stack_warps: u64,
    busy_warps: u64,
    drained: u64,
    /// Lane-cycles in each state, by [`ThreadState::code`], as an integral kept at the edges: a
    /// lane entering a state in cycle `c` subtracts `c`, leaving it in cycle `c` adds `c`, so the
    /// lane-cycles over cycles `0..end` are this plus the lanes in the state now × `end`
    /// (wrapping arithmetic; [`WarpBuffer::lane_cycles`]). The RT unit's thread-cycle breakdown
    /// then costs nothing in the cycles no lane moves.
    state_cycles: [u64; ThreadState::STATES as usize],
    /// Warps loaded so far.
    loaded: u64,
    /// The widths of the waveform's fields.
    widths: Widths,
}

impl WarpBuffer {
    pub fn new(cfg: &Config) -> Result<Self, ConfigError> {
        Ok(WarpBuffer {
            warp_size: cfg.warp_size,
            slots: vec![None; cfg.warps as usize],
            threads: vec![Thread::default(); cfg.threads() as usize],
            ops: vec![Vec::new(); cfg.threads() as usize],
            lanes: vec![Lanes::EMPTY; cfg.warps as usize],
            occupied: 0,
            slot_mask: u64::MAX >> (64 - cfg.warps),
            fetch_warps: 0,
            stack_warps: 0,
            busy_warps: 0,
            drained: 0,
            state_cycles: [0; ThreadState::STATES as usize],
            loaded: 0,
            widths: cfg.widths()?,
        })
    }

    pub fn warps(&self) -> u32 {
        self.slots.len() as u32
    }

    /// A slot that can take a job this cycle.
    #[inline]
    pub fn free_slot(&self) -> Option<u32> {
        let free = !self.occupied & self.slot_mask;
        (free != 0).then(|| free.trailing_zeros())
    }

    /// No warp resident.
    #[inline]
    pub fn empty(&self) -> bool {
        self.occupied == 0
    }

    #[inline]
    pub fn occupied(&self, w: u32) -> bool {
        self.occupied & (1 << w) != 0
    }

    /// The resident warps' slots, lowest first.
    #[inline]
    pub fn resident(&self) -> Bits {
        Bits(self.occupied)
    }

    /// Warps with a lane waiting to fetch (bit w for slot w).
    #[inline]
    pub fn fetch_warps(&self) -> u64 {
        self.fetch_warps
    }

    /// Warps with a lane holding a stack command.
    #[inline]
    pub fn stack_warps(&self) -> u64 {
        self.stack_warps
    }

    /// Warps with a Busy lane. A warp without one has `busy_until == u64::MAX`: a lane leaves
    /// Busy only when due, and the edge that moves it recomputes its warp's deadline.
    #[inline]
    pub fn busy_warps(&self) -> u64 {
        self.busy_warps
    }

    /// Resident warps with no live lane (ready to leave once their stacks are quiet).
    #[inline]
    pub fn drained(&self) -> u64 {
        self.drained
    }

    /// Lane-cycles of the resident warps' lanes in the state whose [`ThreadState::code`] is
    /// `code` (not Done) over cycles `0..end`, `end` after the last edge.
    pub fn lane_cycles(&self, code: u64, end: u64) -> u64 {
        let mask = |m: Lanes| match code {
            ThreadState::FETCH => m.fetch,
            ThreadState::WAIT_MEM => m.wait,
            ThreadState::BUSY => m.busy,
            ThreadState::STACK => m.stack,
            _ => unreachable!("Done lanes are not counted"),
        };
        let now: u64 = self.resident().map(|w| u64::from(mask(self.lanes(w)).count_ones())).sum();
        self.state_cycles[code as usize].wrapping_add(now.wrapping_mul(end))
    }

    /// Brings warp `w`'s bits of the summaries in line with its lanes (after any change).
    #[inline]
    fn sync_warp(&mut self, w: u32) {
        let m = self.lanes[w as usize];
        let bit = 1u64 << w;
        // Branch-free: each bit is cleared, then set from its condition.
        let on = |c: bool| u64::from(c) << w;
        self.fetch_warps = self.fetch_warps & !bit | on(m.fetch != 0);
        self.stack_warps = self.stack_warps & !bit | on(m.stack != 0);
        self.busy_warps = self.busy_warps & !bit | on(m.busy != 0);
        self.drained = self.drained & !bit | (self.occupied & bit) & on(m.live() == 0);
    }

    /// Age rank of the warp in slot `w` (`u32::MAX` for an empty slot).
    #[inline]
    pub fn age(&self, w: u32) -> u32 {
        self.slots[w as usize].as_ref().map_or(u32::MAX, |s| s.age)
    }

    #[inline]
    pub fn lanes(&self, w: u32) -> Lanes {
        self.lanes[w as usize]
    }

    #[inline]
    pub fn thread(&self, t: u32) -> Thread {
        self.threads[t as usize]
    }

    /// The trace of lane `l` of the warp in slot `w` (empty for an inactive lane or slot).
    #[inline]
    pub fn ops(&self, w: u32, l: u32) -> &[RayOp] {
        &self.ops[(w * self.warp_size + l) as usize]
    }

    /// Lane `l`'s operations of the warp in slot `w`, for a walk to append its next segment to
    /// (clock edge).
    pub fn ops_mut(&mut self, w: u32, l: u32) -> &mut Vec<RayOp> {
        &mut self.ops[(w * self.warp_size + l) as usize]
    }

    /// The walk id of the warp in slot `w`: `Some` for a walk-driven warp.
    #[inline]
    pub fn walk(&self, w: u32) -> Option<u64> {
        self.slots[w as usize].as_ref().and_then(|s| s.walk)
    }

    /// Clock edge: the warp in slot `w` leaves; younger warps move up one rank.
    pub fn leave(&mut self, w: u32) -> Option<Left> {
        let slot = self.slots[w as usize].take()?;
        let ws = self.warp_size as usize;
        for ops in &mut self.ops[w as usize * ws..(w as usize + 1) * ws] {
            *ops = Vec::new();
        }
        self.occupied &= !(1 << w);
        self.sync_warp(w);
        for s in self.slots.iter_mut().flatten() {
            if s.age > slot.age {
                s.age -= 1;
            }
        }
        Some(Left { job: slot.job, landed: slot.landed })
    }

    /// Clock edge: `lanes` (the job's rays; `active` the lanes that have one) land in slot `w`
    /// and start Busy until `start`. Returns the job's load order.
    pub fn load(
        &mut self,
        w: u32,
        lanes: &[Option<Vec<RayOp>>],
        walk: Option<u64>,
        active: u32,
        start: u64,
        now: u64,
    ) -> u64 {
        let ws = self.warp_size;
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
        debug_assert_eq!(lanes.len(), ws as usize, "a job has one lane per thread of the warp");
        let first = (w * ws) as usize;
        // Copied into the vectors the slots keep: a landing allocates nothing once they have grown.
        for (slot, ops) in self.ops[first..first + ws as usize].iter_mut().zip(lanes) {
            match ops {
                Some(ops) => slot.clone_from(ops),
                None => slot.clear(),
            }
        }
        self.lanes[w as usize] = Lanes { busy: active, busy_until: start, ..Lanes::EMPTY };
        // The slot's lanes were Done (a warp leaves with none live) and are Busy from the next cycle.
        let busy = &mut self.state_cycles[ThreadState::BUSY as usize];
        *busy = busy.wrapping_sub(u64::from(active.count_ones()) * (now + 1));
        let age = self.occupied.count_ones();
        let job = self.loaded;
        self.slots[w as usize] = Some(Slot { age, job, landed: now, walk });
        self.occupied |= 1 << w;
        self.sync_warp(w);
        self.loaded += 1;
        job
    }

    /// Clock edge of cycle `now`: each thread of `threads` takes its state; then each warp of
    /// `due` (whose due Busy lanes moved on) recomputes its earliest Busy deadline; then the
    /// summaries of the warps touched follow their lanes (once per warp, not per thread).
    pub fn apply(&mut self, threads: &[(u32, Thread)], due: &[u32], now: u64) {
        let mut touched = 0u64;
        let from = now + 1;
        for &(t, d) in threads {
            let (w, l) = warp_lane(t, self.warp_size);
            let old = self.threads[t as usize].state;
            self.lanes[w as usize].set(l, old, d.state);
            let acc = &mut self.state_cycles;
            acc[old.code() as usize] = acc[old.code() as usize].wrapping_add(from);
            acc[d.state.code() as usize] = acc[d.state.code() as usize].wrapping_sub(from);
            self.threads[t as usize] = d;
            touched |= 1 << w;
        }
        for &w in due {
            self.refresh_busy_until(w);
        }
        for w in Bits(touched) {
            self.sync_warp(w);
        }
    }

    /// Recomputes warp `w`'s earliest Busy deadline (after its due lanes moved on).
    fn refresh_busy_until(&mut self, w: u32) {
        let ws = self.warp_size;
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

/// The warp buffer is a register file the RT unit writes in its own commit (`load`, `apply`,
/// `leave`): its probe shows the registers alone.
impl Probe for WarpBuffer {
    fn probe<S: Sink>(&self, s: &mut S) {
        if !s.enabled() {
            return;
        }
        let w = &self.widths;
        let ws = self.warp_size;
        s.push_scope("warp_buffer");
        for wp in 0..self.warps() {
            let slot = self.slots[wp as usize].as_ref();
            s.push_scope(&format!("warp[{wp}]"));
            s.signal("valid", 1, u64::from(slot.is_some()));
            s.signal("age", w.warp, slot.map_or(0, |x| u64::from(x.age)));
            let m = self.lanes[wp as usize];
            s.signal("live", w.live, u64::from(m.live()));
            s.signal_kind("fetch_mask", ws, u64::from(m.fetch), Kind::Mask);
            s.signal_kind("wait_mask", ws, u64::from(m.wait), Kind::Mask);
            s.signal_kind("busy_mask", ws, u64::from(m.busy), Kind::Mask);
            s.signal_kind("stack_mask", ws, u64::from(m.stack), Kind::Mask);
            for l in 0..ws {
                let th = self.threads[(wp * ws + l) as usize];
                s.push_scope(&format!("thread[{l}]"));
                s.signal_kind("state", w.thread_state, th.state.code(), ThreadState::KIND);
                s.pop_scope();
            }
            s.pop_scope();
        }
        s.pop_scope();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The per-warp summaries equal what the lane masks say after every edge: random thread
    /// moves, loads and leaves (a summary that missed an update would make the RT unit skip a
    /// warp with work).
    #[test]
    fn warp_summaries_follow_the_lanes() {
        let cfg: Config = "RB_8".parse().unwrap();
        let cfg = Config { warps: 4, ..cfg };
        let mut b = WarpBuffer::new(&cfg).unwrap();
        let mut x = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = |n: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % n
        };
        let check = |b: &WarpBuffer| {
            let want = |f: &dyn Fn(Lanes) -> bool| {
                (0..4).filter(|&w| b.occupied(w) && f(b.lanes(w))).fold(0u64, |m, w| m | 1 << w)
            };
            assert_eq!(b.fetch_warps(), want(&|m| m.fetch != 0));
            assert_eq!(b.stack_warps(), want(&|m| m.stack != 0));
            assert_eq!(b.busy_warps(), want(&|m| m.busy != 0));
            assert_eq!(b.drained(), want(&|m| m.live() == 0));
            // Each lane mask is exactly the lanes in its state.
            for w in (0..4).filter(|&w| b.occupied(w)) {
                let of = |f: &dyn Fn(ThreadState) -> bool| {
                    (0..32).filter(|&l| f(b.thread(w * 32 + l).state)).fold(0u32, |a, l| a | 1 << l)
                };
                let m = b.lanes(w);
                assert_eq!(m.fetch, of(&|s| s == ThreadState::Fetch));
                assert_eq!(m.wait, of(&|s| matches!(s, ThreadState::WaitMem { .. })));
                assert_eq!(m.busy, of(&|s| matches!(s, ThreadState::Busy { .. })));
                assert_eq!(m.stack, of(&|s| s == ThreadState::Stack));
            }
        };
        // Lane-cycles by state, counted cycle by cycle: the registers after the edge of `step`
        // hold in cycle `step + 1`.
        let mut counted = [0u64; ThreadState::STATES as usize];
        for step in 0..20_000u64 {
            let w = next(4) as u32;
            match next(8) {
                0 if !b.occupied(w) => {
                    b.load(w, &vec![None; 32], None, next(16) as u32, step + 1, step);
                }
                1 if b.occupied(w) && b.lanes(w).live() == 0 => {
                    b.leave(w);
                }
                _ if b.occupied(w) => {
                    let t = w * 32 + next(4) as u32;
                    let state = match next(6) {
                        0 | 5 => ThreadState::Done,
                        1 => ThreadState::Fetch,
                        2 => ThreadState::WaitMem { left: 1, lat: 1 },
                        3 => ThreadState::Busy { until: step + next(9) },
                        _ => ThreadState::Stack,
                    };
                    b.apply(&[(t, Thread { state, pos: 0 })], &[], step);
                }
                _ => {}
            }
            check(&b);
            for w in (0..4).filter(|&w| b.occupied(w)) {
                for l in 0..32 {
                    counted[b.thread(w * 32 + l).state.code() as usize] += 1;
                }
            }
            for code in [ThreadState::FETCH, ThreadState::WAIT_MEM, ThreadState::BUSY, ThreadState::STACK] {
                assert_eq!(b.lane_cycles(code, step + 2), counted[code as usize], "state {code}");
            }
        }
        assert!(b.loaded > 4, "warps came and went");
    }

    #[test]
    fn ages_are_ranks_that_close_up_when_a_warp_leaves() {
        let cfg: Config = "RB_8".parse().unwrap();
        let mut b = WarpBuffer::new(&Config { warps: 3, ..cfg }).unwrap();
        for w in 0..3 {
            assert_eq!(b.load(w, &vec![None; 32], None, 0, 0, 0), u64::from(w));
        }
        assert_eq!((0..3).map(|w| b.age(w)).collect::<Vec<_>>(), [0, 1, 2]);
        assert_eq!(b.leave(1), Some(Left { job: 1, landed: 0 }));
        assert_eq!((b.age(0), b.age(1), b.age(2)), (0, u32::MAX, 1));
        assert_eq!(b.load(1, &vec![None; 32], None, 0, 0, 5), 3);
        assert_eq!(b.age(1), 2, "the newest is the youngest");
        assert!(b.age(1) < 1 << Config { warps: 3, ..cfg }.widths().unwrap().warp, "fits its width");
    }
}
