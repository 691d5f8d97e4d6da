//! Node fetch unit: turns one scheduled warp's node visits into sector requests.
//!
//! ```text
//!  scheduled warp ──► coalesce: split each lane's node into sector pieces, merge identical
//!  (lanes, addr,        pieces across lanes (one request, a lane mask of waiters)
//!   bytes)                 │
//!                          ▼
//!                    request queue ──(head, when the port takes it)──► memory (id = slot)
//!                                                                          │
//!  lanes to wake ◄── waiter table [slot] = (warp, lane mask) ◄── response ─┘
//! ```
//!
//! Why: Vulkan-Sim merges identical node addresses within a warp and fetches in 32-byte sectors;
//! a node spanning two sectors costs two requests. Every lane waits for one response per piece
//! of its node, so a lane's node is complete when it has counted all its pieces. The waiter table
//! is a slab with a free list: slots are reused, nothing is allocated once it has grown to the
//! largest number of pieces in flight.
//!
//! A register file of the RT unit, not a [`crate::clock::Unit`]. The RT unit's eval reads it
//! ([`NodeFetch::head`], [`NodeFetch::waiters`]) and decides what it takes; its write ports
//! ([`NodeFetch::coalesce`], which merges the issued warp's visits into pieces as it writes them,
//! [`NodeFetch::taken`], [`NodeFetch::complete`]) are called only from the RT unit's commit. Its probe ([`Probe`]) shows the registers alone.

use std::collections::VecDeque;

use crate::config::bits_for;
use crate::mem::{MemReq, ReqKind};
use crate::ray_op::MAX_NODE_BYTES;
use crate::trace::{Kind, Probe, Sink};

/// One queued sector request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Piece {
    addr: u64,
    bytes: u32,
    slot: u32,
}

/// Who waits for a piece.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Waiters {
    warp: u32,
    lanes: u32,
}

#[derive(Clone, Debug, Default)]
pub struct NodeFetch {
    sector_bytes: u64,
    queue: VecDeque<Piece>,
    waiters: Vec<Waiters>,
    free: Vec<u32>,
    /// Scratch for coalescing: (addr, bytes, lanes).
    merge: Vec<(u64, u32, u32)>,
    /// Sector requests handed to memory.
    pub requests: u64,
    /// Lane pieces that joined another lane's request.
    pub merged: u64,
    /// Width of the queue and outstanding counts ([`NodeFetch::count_bits`]).
    count_bits: u32,
}

/// Number of sector pieces of a node of `bytes` bytes at `addr`.
/// `sector_bytes` is a power of two (the memory system's sector: validated), so the sector
/// numbers are shifts.
pub fn pieces(addr: u64, bytes: u32, sector_bytes: u64) -> u32 {
    debug_assert!(sector_bytes.is_power_of_two());
    let k = sector_bytes.trailing_zeros();
    let first = addr >> k;
    let last = (addr + u64::from(bytes.max(1)) - 1) >> k;
    (last - first + 1) as u32
}

impl NodeFetch {
    /// The fetch unit of an RT unit with `threads` threads, for memory of `sector_bytes`-byte
    /// sectors.
    pub fn new(sector_bytes: u32, threads: u32) -> Self {
        debug_assert!(sector_bytes.is_power_of_two(), "sectors are a power of two (MemParams::validate)");
        NodeFetch {
            sector_bytes: u64::from(sector_bytes),
            count_bits: NodeFetch::count_bits(sector_bytes, threads),
            ..Default::default()
        }
    }

    /// Width of the request queue's and the waiter table's occupancy: a thread has one node in
    /// flight at a time, and a node of at most [`MAX_NODE_BYTES`] spans at most
    /// `MAX_NODE_BYTES / sector + 1` sectors at any alignment, so at most `threads` times that
    /// many pieces are queued or outstanding (fewer when lanes merge).
    pub fn count_bits(sector_bytes: u32, threads: u32) -> u32 {
        let pieces = MAX_NODE_BYTES.div_ceil(sector_bytes.max(1)) + 1;
        bits_for(u64::from(threads) * u64::from(pieces))
    }

    #[inline]
    pub fn sector_bytes(&self) -> u64 {
        self.sector_bytes
    }

    /// Requests waiting for the port.
    #[inline]
    pub fn queue_len(&self) -> usize {
        self.queue.len()
    }

    /// No request waiting for the port.
    #[inline]
    pub fn queue_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// Requests in flight in memory or queued.
    pub fn outstanding(&self) -> usize {
        self.waiters.len() - self.free.len()
    }

    /// The request offered to memory this cycle; its id is `slot << 2 | tag`.
    pub fn head(&self, tag: u64) -> Option<MemReq> {
        self.queue
            .front()
            .map(|p| MemReq::read(u64::from(p.slot) << 2 | tag, p.addr, p.bytes, ReqKind::NodeFetch))
    }

    /// The port took the head.
    pub fn taken(&mut self) {
        self.queue.pop_front();
        self.requests += 1;
    }

    /// Queues the pieces of `warp`'s visits `(lane, addr, bytes)`, merged, in order of first
    /// appearance (lane order, then address order within a node).
    pub fn coalesce(&mut self, warp: u32, visits: impl Iterator<Item = (u32, u64, u32)>) {
        self.merge.clear();
        let s = self.sector_bytes;
        for (lane, addr, bytes) in visits {
            let end = addr + u64::from(bytes.max(1));
            let mut a = addr;
            while a < end {
                // The next sector boundary (sectors are a power of two: no division).
                let piece_end = end.min((a | (s - 1)) + 1);
                let n = (piece_end - a) as u32;
                match self.merge.iter_mut().find(|m| m.0 == a && m.1 == n) {
                    Some(m) => {
                        m.2 |= 1 << lane;
                        self.merged += 1;
                    }
                    None => self.merge.push((a, n, 1 << lane)),
                }
                a = piece_end;
            }
        }
        for i in 0..self.merge.len() {
            let (addr, bytes, lanes) = self.merge[i];
            let w = Waiters { warp, lanes };
            let slot = match self.free.pop() {
                Some(slot) => {
                    self.waiters[slot as usize] = w;
                    slot
                }
                None => {
                    self.waiters.push(w);
                    (self.waiters.len() - 1) as u32
                }
            };
            self.queue.push_back(Piece { addr, bytes, slot });
        }
    }

    /// Who waits for the response to request id `id`: (warp, lanes to wake).
    #[inline]
    pub fn waiters(&self, id: u64) -> (u32, u32) {
        let w = self.waiters[(id >> 2) as usize];
        (w.warp, w.lanes)
    }

    /// Clock edge: the response to request id `id` arrived; frees its slot and returns
    /// [`NodeFetch::waiters`].
    pub fn complete(&mut self, id: u64) -> (u32, u32) {
        let w = self.waiters(id);
        self.free.push((id >> 2) as u32);
        w
    }
}

impl Probe for NodeFetch {
    fn probe<S: Sink>(&self, s: &mut S) {
        if !s.enabled() {
            return;
        }
        s.push_scope("node_fetch");
        s.signal("queue", self.count_bits, self.queue.len() as u64);
        s.signal_kind(
            "head_addr",
            crate::mem::ADDR_BITS,
            self.queue.front().map_or(0, |p| p.addr),
            Kind::Address,
        );
        s.signal("outstanding", self.count_bits, self.outstanding() as u64);
        s.pop_scope();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nodes_split_into_sector_pieces_and_identical_pieces_merge() {
        assert_eq!(pieces(0x40, 64, 32), 2);
        assert_eq!(pieces(0x48, 8, 32), 1);
        assert_eq!(pieces(0x30, 32, 32), 2, "straddles a sector boundary");
        let mut f = NodeFetch::new(32, 4);
        // Lanes 0 and 1 visit the same 64-byte node, lane 2 one straddling two sectors.
        f.coalesce(3, [(0, 0x100, 64), (1, 0x100, 64), (2, 0x210, 32)].into_iter());
        let reqs: Vec<(u64, u32)> = std::iter::from_fn(|| {
            let r = f.head(0)?;
            f.taken();
            Some((r.addr, r.bytes))
        })
        .collect();
        assert_eq!(reqs, [(0x100, 32), (0x120, 32), (0x210, 16), (0x220, 16)]);
        assert_eq!((f.requests, f.merged), (4, 2));
        assert_eq!(f.complete(0), (3, 0b011));
        assert_eq!(f.complete(2 << 2), (3, 0b100));
        assert_eq!(f.outstanding(), 2);
    }

    /// Four threads, each with a node of the largest size one byte past a sector boundary: 5
    /// pieces each, 20 in all, the bound [`NodeFetch::count_bits`] sizes for (5 bits); one more
    /// byte of bound would be a sixth bit.
    #[test]
    fn the_widest_unmerged_warp_fills_the_declared_count() {
        let mut f = NodeFetch::new(32, 4);
        let visits = (0..4u32).map(|l| (l, 0x1000 * u64::from(l + 1) + 1, MAX_NODE_BYTES));
        f.coalesce(0, visits);
        assert_eq!(f.queue_len(), 4 * (MAX_NODE_BYTES as usize / 32 + 1));
        assert_eq!(f.outstanding(), f.queue_len());
        assert_eq!(NodeFetch::count_bits(32, 4), 5);
        assert!(f.outstanding() < 1 << NodeFetch::count_bits(32, 4));
        assert!(f.outstanding() >= 1 << (NodeFetch::count_bits(32, 4) - 1), "the bound is tight");
    }
}
