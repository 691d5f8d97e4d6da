//! Cache tag store: set-associative (fully associative when ways = lines), true LRU per set,
//! one tag per line with a valid and a dirty bit per sector.
//!
//! ```text
//!   addr ─► line = addr / line_bytes ─► set (line mod sets, or L2Map) ─► ways ─► Hit
//!                                                                              ─► SectorMiss
//!                                                                              ─► LineMiss
//! ```
//!
//! The set count need not be a power of two (3 MB / (128 B × 16) = 1536 sets; 56 KB fully
//! associative = 448 ways), so the plain set index is a modulo. A banked L2 instead takes its set
//! from [`L2Map`] (bank, then the set within the bank: linear or IPOLY), its banks' sets laid end
//! to end in one array. LRU is exact: each set keeps its ways in a doubly linked recency list. [`TagStore::lookup`] and
//! [`TagStore::victim`] are pure; [`TagStore::touch`] and [`TagStore::fill`] are the updates the
//! owning unit applies at its clock edge. Policy (write-through or write-back) belongs to the
//! owner: a store is a `fill` with a dirty kind (write-allocate), a `touch` (write-through, no
//! allocate) or an [`TagStore::invalidate`] (write-evict).

use super::addr::L2Map;
use super::{Assoc, MemParams, ReqKind};
use crate::config::rem;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Shape of a cache.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Geometry {
    pub sets: u32,
    pub ways: u32,
    pub line_bytes: u32,
    pub sector_bytes: u32,
    /// Banked set mapping; `None`: `set = line mod sets`.
    pub banked: Option<L2Map>,
}

impl Geometry {
    /// A cache of `bytes` with the given associativity (parameters already validated).
    pub fn new(bytes: u32, assoc: Assoc, line_bytes: u32, sector_bytes: u32) -> Geometry {
        let lines = bytes / line_bytes;
        let ways = match assoc {
            Assoc::Full => lines,
            Assoc::Ways(w) => w,
        };
        Geometry { sets: lines / ways, ways, line_bytes, sector_bytes, banked: None }
    }

    /// The L2 of `p` (parameters already validated): banks' sets end to end when
    /// [`MemParams::l2_map`] gives a banked mapping, else one array indexed `line mod sets`.
    pub fn l2(p: &MemParams) -> Geometry {
        let plain = Geometry::new(p.l2_bytes, p.l2_assoc, p.line_bytes, p.sector_bytes);
        match p.l2_map() {
            None => plain,
            Some(map) => {
                let sets = map.sets_per_bank * map.banks;
                Geometry { sets, ways: plain.lines() / sets, banked: Some(map), ..plain }
            }
        }
    }

    pub fn lines(&self) -> u32 {
        self.sets * self.ways
    }

    /// Line number (address / line size; the line size is a power of two, so a shift: a
    /// 64-bit division costs tens of cycles on the host, and this runs for every access).
    #[inline]
    pub fn line_of(&self, addr: u64) -> u64 {
        debug_assert!(self.line_bytes.is_power_of_two());
        addr >> self.line_bytes.trailing_zeros()
    }

    pub fn set_of(&self, addr: u64) -> usize {
        match &self.banked {
            None => rem(self.line_of(addr), self.sets) as usize,
            Some(map) => map.set_of(addr),
        }
    }

    /// L2 bank (memory sub-partition) of `addr` among `banks`: the banked mapping's, else the old
    /// `line mod banks`.
    pub fn bank_of(&self, addr: u64, banks: u32) -> u32 {
        match &self.banked {
            Some(map) => map.bank_of(addr),
            None => rem(self.line_of(addr), banks) as u32,
        }
    }

    /// One-hot sector bit of `addr` within its line (both sizes are powers of two).
    #[inline]
    pub fn sector_bit(&self, addr: u64) -> u32 {
        debug_assert!(self.sector_bytes.is_power_of_two());
        1 << ((addr & (u64::from(self.line_bytes) - 1)) >> self.sector_bytes.trailing_zeros())
    }
}

/// Result of a tag lookup.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lookup {
    Hit,
    /// The line is present, the sector is not.
    SectorMiss,
    LineMiss,
}

impl Lookup {
    pub fn is_hit(self) -> bool {
        self == Lookup::Hit
    }
}

/// A line pushed out by a fill.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Victim {
    /// Byte address of the line.
    pub addr: u64,
    pub valid: u32,
    /// Dirty sectors, one bit each; nonzero means the line must be written back.
    pub dirty: u32,
    /// Kind of the last store that dirtied the line.
    pub dirty_kind: ReqKind,
}

#[derive(Clone, Copy, Debug)]
struct Way {
    line: u64,
    valid: u32,
    dirty: u32,
    dirty_kind: ReqKind,
}

/// No slot: the end of a set's recency list.
const NIL: u32 = u32::MAX;

/// Hashes a line number for the tag index: one multiply (Fibonacci hashing). Line numbers are
/// not adversarial, and the index is only looked up, never iterated, so the hash cannot change
/// a result.
#[derive(Clone, Copy, Debug, Default)]
pub struct LineHasher(u64);

impl Hasher for LineHasher {
    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        }
    }
    #[inline]
    fn write_u64(&mut self, n: u64) {
        self.0 = (n ^ self.0).wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(29);
    }
}

/// Tags, sector state and LRU order of one cache. Each set's ways form a doubly linked recency
/// list (most recently used at the head), so a use and an eviction are O(1) however many ways
/// the set has; one hash index maps a line to its slot.
#[derive(Clone, Debug)]
pub struct TagStore {
    geom: Geometry,
    /// `sets × ways` slots, set-major.
    slots: Vec<Option<Way>>,
    /// Line number → slot, for lookup only (never iterated).
    index: HashMap<u64, u32, BuildHasherDefault<LineHasher>>,
    /// Recency links per slot: toward the head (more recent) and toward the tail.
    prev: Vec<u32>,
    next: Vec<u32>,
    /// Per set: most and least recently used slot, [`NIL`] when the set holds no line.
    head: Vec<u32>,
    tail: Vec<u32>,
    /// Per set: empty ways, lowest popped first.
    free: Vec<Vec<u32>>,
}

impl TagStore {
    pub fn new(geom: Geometry) -> TagStore {
        let sets = geom.sets as usize;
        let lines = sets * geom.ways as usize;
        TagStore {
            geom,
            slots: vec![None; lines],
            index: HashMap::with_capacity_and_hasher(lines, BuildHasherDefault::default()),
            prev: vec![NIL; lines],
            next: vec![NIL; lines],
            head: vec![NIL; sets],
            tail: vec![NIL; sets],
            free: vec![(0..geom.ways).rev().collect(); sets],
        }
    }

    pub fn geometry(&self) -> Geometry {
        self.geom
    }

    /// Lines currently held.
    pub fn lines_held(&self) -> usize {
        self.index.len()
    }

    pub fn lookup(&self, addr: u64) -> Lookup {
        match self.find(addr) {
            None => Lookup::LineMiss,
            Some(slot) => {
                let way = self.slots[slot].as_ref().expect("indexed slot holds a line");
                if way.valid & self.geom.sector_bit(addr) != 0 {
                    Lookup::Hit
                } else {
                    Lookup::SectorMiss
                }
            }
        }
    }

    /// The line a fill of `addr` would evict now: none if its line is present or a way is free.
    pub fn victim(&self, addr: u64) -> Option<Victim> {
        if self.find(addr).is_some() {
            return None;
        }
        let set = self.geom.set_of(addr);
        if !self.free[set].is_empty() {
            return None;
        }
        let lru = self.tail[set];
        if lru == NIL {
            return None;
        }
        Some(self.evicted(self.slots[lru as usize].as_ref().expect("listed way holds a line")))
    }

    /// What evicting way `w` gives up.
    fn evicted(&self, w: &Way) -> Victim {
        Victim {
            addr: w.line * u64::from(self.geom.line_bytes),
            valid: w.valid,
            dirty: w.dirty,
            dirty_kind: w.dirty_kind,
        }
    }

    /// Makes the line of `addr` most recently used; no effect if absent.
    pub fn touch(&mut self, addr: u64) {
        if let Some(slot) = self.find(addr) {
            self.make_mru(slot);
        }
    }

    /// Makes the sector of `addr` valid (and dirty with `dirty = Some(kind)`), allocating its line
    /// over the LRU way if absent, and makes the line most recently used. Returns the evicted
    /// line, which is [`TagStore::victim`] as it was before the fill.
    pub fn fill(&mut self, addr: u64, dirty: Option<ReqKind>) -> Option<Victim> {
        let line = self.geom.line_of(addr);
        let set = self.geom.set_of(addr);
        // One index lookup: a present line is refilled in place; otherwise a free way, else the
        // LRU way is evicted (what `victim` reports).
        let (slot, victim) = match self.find(addr) {
            Some(slot) => (slot, None),
            None => {
                let (slot, victim) = match self.free[set].pop() {
                    Some(way) => (self.slot(set, way), None),
                    None => {
                        let slot = self.tail[set] as usize;
                        assert!(slot != NIL as usize, "full set has an LRU way");
                        self.unlink(set, slot);
                        let old = self.slots[slot].take().expect("LRU way");
                        self.index.remove(&old.line);
                        (slot, Some(self.evicted(&old)))
                    }
                };
                self.slots[slot] = Some(Way { line, valid: 0, dirty: 0, dirty_kind: ReqKind::NodeFetch });
                self.index.insert(line, slot as u32);
                self.push_head(set, slot);
                (slot, victim)
            }
        };
        let bit = self.geom.sector_bit(addr);
        let way = self.slots[slot].as_mut().expect("filled slot");
        way.valid |= bit;
        if let Some(kind) = dirty {
            way.dirty |= bit;
            way.dirty_kind = kind;
        }
        self.make_mru(slot);
        victim
    }

    /// Clears the valid (and dirty) bit of the sector of `addr` (write-evict); a line left with no
    /// valid sector frees its way, as GPGPU-Sim treats a line whose sectors are all invalid as an
    /// invalid line (`tag_array::probe`, `gpu-cache.cc:282-285`). No effect if absent.
    pub fn invalidate(&mut self, addr: u64) {
        let Some(slot) = self.find(addr) else { return };
        let bit = self.geom.sector_bit(addr);
        let way = self.slots[slot].as_mut().expect("indexed slot holds a line");
        way.valid &= !bit;
        way.dirty &= !bit;
        if way.valid == 0 {
            let ways = self.geom.ways as usize;
            let (set, w) = (slot / ways, (slot % ways) as u32);
            let old = self.slots[slot].take().expect("line");
            self.index.remove(&old.line);
            self.unlink(set, slot);
            self.free[set].push(w);
        }
    }

    /// Slot holding the line of `addr`, if present.
    #[inline]
    fn find(&self, addr: u64) -> Option<usize> {
        self.index.get(&self.geom.line_of(addr)).map(|&slot| slot as usize)
    }

    fn slot(&self, set: usize, way: u32) -> usize {
        set * self.geom.ways as usize + way as usize
    }

    /// Takes `slot` out of its set's recency list.
    fn unlink(&mut self, set: usize, slot: usize) {
        let (p, n) = (self.prev[slot], self.next[slot]);
        match p {
            NIL => self.head[set] = n,
            p => self.next[p as usize] = n,
        }
        match n {
            NIL => self.tail[set] = p,
            n => self.prev[n as usize] = p,
        }
        self.prev[slot] = NIL;
        self.next[slot] = NIL;
    }

    /// Puts an unlisted `slot` at the head (most recently used) of its set's list.
    fn push_head(&mut self, set: usize, slot: usize) {
        let old = self.head[set];
        self.prev[slot] = NIL;
        self.next[slot] = old;
        match old {
            NIL => self.tail[set] = slot as u32,
            o => self.prev[o as usize] = slot as u32,
        }
        self.head[set] = slot as u32;
    }

    fn make_mru(&mut self, slot: usize) {
        let set = slot / self.geom.ways as usize;
        if self.head[set] != slot as u32 {
            self.unlink(set, slot);
            self.push_head(set, slot);
        }
    }
}

/// Reference caches for tests: plain vectors, no cleverness.
#[cfg(test)]
pub(crate) mod reference {
    use super::{Geometry, Lookup};

    /// Per set, lines with their valid sectors, least recently used first.
    pub struct RefLru {
        pub geom: Geometry,
        pub sets: Vec<Vec<(u64, u32)>>,
        /// Planted bug for checker tests: hits do not refresh the order (FIFO replacement).
        pub fifo: bool,
    }

    impl RefLru {
        pub fn new(geom: Geometry) -> RefLru {
            RefLru { geom, sets: vec![Vec::new(); geom.sets as usize], fifo: false }
        }

        pub fn lookup(&self, addr: u64) -> Lookup {
            let line = self.geom.line_of(addr);
            match self.sets[self.geom.set_of(addr)].iter().find(|(l, _)| *l == line) {
                None => Lookup::LineMiss,
                Some((_, v)) if v & self.geom.sector_bit(addr) != 0 => Lookup::Hit,
                Some(_) => Lookup::SectorMiss,
            }
        }

        pub fn touch(&mut self, addr: u64) {
            if self.fifo {
                return;
            }
            let line = self.geom.line_of(addr);
            let set = &mut self.sets[self.geom.set_of(addr)];
            if let Some(i) = set.iter().position(|(l, _)| *l == line) {
                let e = set.remove(i);
                set.push(e);
            }
        }

        /// Clears the sector of `addr`; a line with no valid sector leaves the set.
        pub fn invalidate(&mut self, addr: u64) {
            let (line, bit) = (self.geom.line_of(addr), self.geom.sector_bit(addr));
            let set = &mut self.sets[self.geom.set_of(addr)];
            if let Some(i) = set.iter().position(|(l, _)| *l == line) {
                set[i].1 &= !bit;
                if set[i].1 == 0 {
                    set.remove(i);
                }
            }
        }

        /// Returns the evicted line's byte address.
        pub fn fill(&mut self, addr: u64) -> Option<u64> {
            let (line, bit, ways) =
                (self.geom.line_of(addr), self.geom.sector_bit(addr), self.geom.ways as usize);
            let line_bytes = u64::from(self.geom.line_bytes);
            let set = &mut self.sets[self.geom.set_of(addr)];
            if let Some(i) = set.iter().position(|(l, _)| *l == line) {
                set[i].1 |= bit;
                self.touch(addr);
                return None;
            }
            let victim = if set.len() == ways { Some(set.remove(0).0 * line_bytes) } else { None };
            set.push((line, bit));
            victim
        }
    }
}

#[cfg(test)]
mod tests {
    use super::reference::RefLru;
    use super::*;
    use crate::mem::testutil::XorShift;

    fn geom(sets: u32, ways: u32) -> Geometry {
        Geometry { sets, ways, line_bytes: 128, sector_bytes: 32, banked: None }
    }

    /// Drives the tag store and the reference with one address stream (hit: touch; miss: fill,
    /// as a read-allocate cache does) and returns the first disagreement in lookup result or
    /// evicted line.
    fn compare(g: Geometry, addrs: impl IntoIterator<Item = u64>, fifo_ref: bool) -> Result<(), String> {
        let mut dut = TagStore::new(g);
        let mut r = RefLru::new(g);
        r.fifo = fifo_ref;
        for (step, addr) in addrs.into_iter().enumerate() {
            let got = dut.lookup(addr);
            let want = r.lookup(addr);
            if got != want {
                return Err(format!("step {step} addr {addr:#x}: {got:?} vs {want:?}"));
            }
            if got.is_hit() {
                dut.touch(addr);
                r.touch(addr);
            } else {
                let predicted = dut.victim(addr).map(|v| v.addr);
                let got = dut.fill(addr, None).map(|v| v.addr);
                let want = r.fill(addr);
                if got != want || predicted != got {
                    return Err(format!(
                        "step {step} addr {addr:#x}: evicted {got:x?} (predicted {predicted:x?}) vs {want:x?}"
                    ));
                }
            }
        }
        Ok(())
    }

    /// Random addresses over three times the capacity: hits, sector misses and evictions.
    fn random(g: Geometry, seed: u64, steps: usize) -> impl Iterator<Item = u64> {
        let mut rng = XorShift(seed);
        let span = u64::from(g.lines() * g.line_bytes) * 3;
        (0..steps).map(move |_| rng.below(span))
    }

    #[test]
    fn lru_matches_reference_exhaustively_on_small_bounds() {
        // Every sequence of 6 accesses over 3 lines × 2 sectors, into 2 ways: 6^6 streams.
        let g = geom(1, 2);
        let addrs: Vec<u64> = (0..3).flat_map(|l| [l * 128, l * 128 + 32]).collect();
        let n = addrs.len();
        let addrs = &addrs;
        let stream = |code: usize| (0..6).map(move |i| addrs[code / n.pow(i) % n]);
        for code in 0..n.pow(6) {
            compare(g, stream(code), false).unwrap();
        }
        // The same enumeration finds FIFO out.
        let caught = (0..n.pow(6)).any(|code| compare(g, stream(code), true).is_err());
        assert!(caught);
    }

    #[test]
    fn lru_matches_reference_set_associative() {
        for seed in 1..=8 {
            compare(geom(4, 4), random(geom(4, 4), seed, 4000), false).unwrap();
        }
    }

    #[test]
    fn lru_matches_reference_fully_associative_non_power_of_two() {
        for seed in 1..=4 {
            compare(geom(1, 7), random(geom(1, 7), seed, 4000), false).unwrap();
        }
        // 1536 sets, as the default L2 has.
        compare(geom(1536, 2), random(geom(1536, 2), 9, 20000), false).unwrap();
    }

    /// Random reads (hit: touch; miss: fill) and store hits that invalidate their sector, against
    /// the reference; `planted`: the tag store only clears the bit and never frees the way.
    fn compare_with_invalidate(g: Geometry, seed: u64, planted: bool) -> Result<(), String> {
        let mut dut = TagStore::new(g);
        let mut r = RefLru::new(g);
        let mut rng = XorShift(seed);
        let span = u64::from(g.lines() * g.line_bytes) * 2;
        for step in 0..6000 {
            let addr = rng.below(span);
            let (got, want) = (dut.lookup(addr), r.lookup(addr));
            if got != want {
                return Err(format!("step {step} addr {addr:#x}: {got:?} vs {want:?}"));
            }
            if got.is_hit() && rng.below(3) == 0 {
                if planted {
                    let slot = dut.find(addr).unwrap();
                    dut.slots[slot].as_mut().unwrap().valid &= !g.sector_bit(addr);
                } else {
                    dut.invalidate(addr);
                }
                r.invalidate(addr);
            } else if got.is_hit() {
                dut.touch(addr);
                r.touch(addr);
            } else {
                let (got, want) = (dut.fill(addr, None).map(|v| v.addr), r.fill(addr));
                if got != want {
                    return Err(format!("step {step} addr {addr:#x}: evicted {got:x?} vs {want:x?}"));
                }
            }
        }
        Ok(())
    }

    #[test]
    fn invalidate_matches_reference_and_frees_empty_lines() {
        for seed in 1..=4 {
            compare_with_invalidate(geom(4, 4), seed, false).unwrap();
            compare_with_invalidate(geom(1, 7), seed, false).unwrap();
        }
        // A line whose sectors are all invalid must become a free way (GPGPU-Sim's invalid line).
        assert!(compare_with_invalidate(geom(4, 4), 1, true).is_err());
        let mut t = TagStore::new(geom(1, 2));
        t.fill(0x20, Some(ReqKind::StackSpill));
        t.invalidate(0x20);
        assert_eq!((t.lines_held(), t.lookup(0x20)), (0, Lookup::LineMiss));
        t.invalidate(0x20);
    }

    #[test]
    fn checker_catches_a_fifo_reference() {
        // The comparison above would pass for any replacement policy if it never looked at the
        // order; a FIFO reference must be caught.
        assert!(compare(geom(4, 4), random(geom(4, 4), 1, 4000), true).is_err());
        assert!(compare(geom(1, 7), random(geom(1, 7), 1, 4000), true).is_err());
    }

    #[test]
    fn default_geometries() {
        let l1 = Geometry::new(56 * 1024, Assoc::Full, 128, 32);
        assert_eq!((l1.sets, l1.ways), (1, 448));
        let l2 = Geometry::new(3 * 1024 * 1024, Assoc::Ways(16), 128, 32);
        assert_eq!((l2.sets, l2.ways), (1536, 16));
    }

    #[test]
    fn sectors_and_dirty_write_back() {
        let g = geom(1, 2);
        let mut t = TagStore::new(g);
        assert_eq!(t.lookup(0x00), Lookup::LineMiss);
        assert_eq!(t.fill(0x20, Some(ReqKind::StackSpill)), None);
        assert_eq!(t.lookup(0x20), Lookup::Hit);
        assert_eq!(t.lookup(0x00), Lookup::SectorMiss);
        assert_eq!(t.lookup(0x7f), Lookup::SectorMiss);
        t.fill(0x100, None);
        t.touch(0x100);
        // Line 0 is LRU: filling a third line evicts it with its dirty sector 1.
        let v = t.fill(0x200, None).unwrap();
        assert_eq!(v, Victim { addr: 0, valid: 0b10, dirty: 0b10, dirty_kind: ReqKind::StackSpill });
        assert_eq!(t.lines_held(), 2);
        assert_eq!(t.lookup(0x20), Lookup::LineMiss);
    }
}
