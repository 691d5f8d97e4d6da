//! Address mapping: where a thread's local-memory (spill) slot lives, which L2 bank (memory
//! sub-partition) an address belongs to, and which set of that bank's cache it indexes.
//!
//! ```text
//!   (sm, thread, slot) ─► LocalMap::addr ─► byte address
//!   byte address ─► L2Map::bank_of ─► bank (sub-partition)
//!                ─► L2Map::partition_addr (bank bits removed) ─► set index (linear or IPOLY)
//! ```
//!
//! Sources (Vulkan-Sim, `ubc-aamodt-group/vulkan-sim`; the code here is this model's own):
//! - Local memory: `shader_core_ctx::translate_local_memaddr`, `src/gpgpu-sim/shader.cc:2029`
//!   (`-gpgpu_local_mem_map 1`, the default, `gpu-sim.cc:425`): word `d` of thread `T` lives at
//!   `(d·N + thread_base)·4` with `N` the GPU's concurrent threads, so the same word of
//!   consecutive threads is adjacent.
//! - Sub-partitions: `linear_to_raw_address_translation::addrdec_tlx`,
//!   `src/gpgpu-sim/addrdec.cc:96-201`; MOBILE `-gpgpu_mem_addr_mapping dramid@8;…` puts the
//!   channel bits at bit 8 (256-byte interleaving, CONSECUTIVE indexing,
//!   `-gpgpu_memory_partition_indexing 0`); with a channel count that is not a power of two the
//!   channel is `(addr >> 8) mod n` and the rest of the address is the quotient (`addrdec.cc:117`).
//! - L2 set index: `l2_cache_config::set_index`, `src/gpgpu-sim/gpu-cache.cc:156-165`, indexes
//!   the *partition address* (the channel bits removed, `addrdec.cc:78`), so each sub-partition's
//!   cache sees a dense address space; the MOBILE L2 (`-gpgpu_cache:dl2 S:64:128:16,L:B:m:L:P`)
//!   hashes it with IPOLY (`gpu-cache.cc:121-125`, `hashing.cc:9-104`).

use crate::config::{quot, rem};

/// How the spill slots of the GPU's threads are laid out in the device address space.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LocalLayout {
    /// GPGPU-Sim's local-memory mapping (`translate_local_memaddr` with `-gpgpu_local_mem_map
    /// 1`): slot `s` of all threads forms one contiguous array, threads ordered as in a CTA of one
    /// warp (lane, then SM, then warp slot): `(s · N + warp_size · (sm + sms · warp) + lane) ·
    /// entry_bytes`, `N` = every thread of the GPU. The source interleaves 4-byte words; a stack
    /// entry here is one request, so the unit interleaved is the entry (`entry_bytes`).
    Interleaved,
    /// Old behaviour: each thread owns a private region of `2^spill_ptr_bits` entries,
    /// `(sm · threads + t) · region + s · entry_bytes`.
    Linear,
}

/// Set index function of the L2 within one bank.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SetIndex {
    /// IPOLY hashing (GPGPU-Sim set-index letter `P`) of the partition address; see [`ipoly`].
    Ipoly,
    /// `partition line mod sets`; with `l2_interleave_bytes == line_bytes` this is the old
    /// single-array mapping `line mod sets` (banks `line mod banks`).
    Linear,
}

named_enum!(LocalLayout, LocalLayout::Interleaved => "interleaved", LocalLayout::Linear => "linear");
named_enum!(SetIndex, SetIndex::Ipoly => "ipoly", SetIndex::Linear => "linear");

/// Spill-slot addresses of every thread of the GPU.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LocalMap {
    pub layout: LocalLayout,
    /// First byte of local memory.
    pub base: u64,
    /// SMs in the GPU.
    pub sms: u32,
    /// Threads per SM (warp slots × warp size).
    pub threads: u32,
    pub warp_size: u32,
    pub entry_bytes: u32,
    /// Slots per thread (`2^spill_ptr_bits`).
    pub slots: u64,
}

impl LocalMap {
    /// Byte address of spill slot `slot` of thread `t` of SM `sm`.
    pub fn addr(&self, sm: u32, t: u32, slot: u32) -> u64 {
        let e = u64::from(self.entry_bytes);
        let (sm, t, slot) = (u64::from(sm), u64::from(t), u64::from(slot));
        let threads = u64::from(self.threads);
        match self.layout {
            LocalLayout::Linear => self.base + (sm * threads + t) * self.slots * e + slot * e,
            LocalLayout::Interleaved => {
                let ws = u64::from(self.warp_size);
                let all = u64::from(self.sms) * threads;
                let thread = ws * (sm + u64::from(self.sms) * (t / ws)) + t % ws;
                self.base + (slot * all + thread) * e
            }
        }
    }
}

/// IPOLY set counts GPGPU-Sim implements (`hashing.cc:38-104`), each as (sets, polynomial over
/// GF(2) with bit i the coefficient of x^i, highest bit of the address above the index that the
/// source's equations use). The equations there are exactly "the line number's bits
/// `0..=index_bits + top` reduced modulo the polynomial" (checked against them in the tests):
/// 16 sets: x^4 + x + 1 with a[0..=12]; 32 sets: x^5 + x^2 + 1 with a[0..=14]; 64 sets:
/// x^6 + x + 1 with a[0..=18].
const IPOLY: [(u32, u64, u32); 3] = [(16, 0b1_0011, 12), (32, 0b10_0101, 14), (64, 0b100_0011, 18)];

/// IPOLY index of `line` (an address divided by the line size) into `sets` sets, `sets` one of
/// 16, 32 or 64: `line mod P(x)` over GF(2), using the address bits the source uses.
pub fn ipoly(line: u64, sets: u32) -> u32 {
    let p = IPOLY.iter().position(|x| x.0 == sets).expect("IPOLY set count 16, 32 or 64");
    ipoly_reduce(line, p)
}

/// [`ipoly`] of every value of each byte of the hashed bits, per polynomial of [`IPOLY`]: the
/// reduction is linear over GF(2) (the index of `a ^ b` is the XOR of theirs), so the index of a
/// line is the XOR of its bytes' entries. Four bytes cover the widest (64 sets: 25 bits).
static IPOLY_BYTES: [[[u8; 256]; 4]; 3] = {
    let mut t = [[[0u8; 256]; 4]; 3];
    let mut p = 0;
    while p < IPOLY.len() {
        let mut byte = 0;
        while byte < 4 {
            let mut v = 0;
            while v < 256 {
                t[p][byte][v] = ipoly_reduce((v as u64) << (8 * byte), p) as u8;
                v += 1;
            }
            byte += 1;
        }
        p += 1;
    }
    t
};

/// `line mod P(x)` over GF(2) for polynomial `p` of [`IPOLY`], bit by bit: the definition, which
/// [`IPOLY_BYTES`] tabulates.
const fn ipoly_reduce(line: u64, p: usize) -> u32 {
    let (sets, poly, top) = IPOLY[p];
    let deg = sets.trailing_zeros();
    let width = deg + top + 1;
    let mut v = line & ((1u64 << width) - 1);
    let mut b = width;
    while b > deg {
        b -= 1;
        if v >> b & 1 != 0 {
            v ^= poly << (b - deg);
        }
    }
    v as u32
}

/// [`ipoly`] with polynomial `p` of [`IPOLY`] (as [`ipoly_part`] names it), from the byte
/// tables: four lookups instead of a branch per hashed bit.
#[inline]
fn ipoly_fast(line: u64, p: usize) -> u32 {
    let t = &IPOLY_BYTES[p];
    let b = |k: usize| usize::from((line >> (8 * k)) as u8);
    u32::from(t[0][b(0)] ^ t[1][b(1)] ^ t[2][b(2)] ^ t[3][b(3)])
}

/// The polynomial of [`IPOLY`] (its index) with the largest set count dividing `sets`, if any.
fn ipoly_part(sets: u32) -> Option<usize> {
    (0..IPOLY.len()).rev().find(|&p| sets.is_multiple_of(IPOLY[p].0))
}

/// Bank and set of an L2 address.
///
/// Banks are GPGPU-Sim's memory sub-partitions: `bank = (addr / interleave) mod banks`, and the
/// partition address (the bank digit removed, `(addr / interleave / banks) · interleave + addr mod
/// interleave`) indexes the bank's own `sets_per_bank` sets. IPOLY exists for 16, 32 and 64 sets
/// only (GPGPU-Sim asserts otherwise, `hashing.cc:96`); a bank of `m · p` sets, `p` the largest of
/// those dividing it (e.g. the 3 MB / 8 banks / 16 ways default: 192 = 3 · 64), is split the way
/// `addrdec_tlx` handles a channel count that is not a power of two: slice `line mod m`, and IPOLY
/// over `p` sets of `line / m`. One set per bank is always set 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct L2Map {
    pub banks: u32,
    pub interleave_bytes: u32,
    pub line_bytes: u32,
    pub sets_per_bank: u32,
    pub index: SetIndex,
}

impl L2Map {
    pub fn bank_of(&self, addr: u64) -> u32 {
        rem(quot(addr, self.interleave_bytes), self.banks) as u32
    }

    /// `addr` with its bank digit removed: the address the bank's cache indexes.
    pub fn partition_addr(&self, addr: u64) -> u64 {
        let i = self.interleave_bytes;
        quot(quot(addr, i), self.banks) * u64::from(i) + rem(addr, i)
    }

    /// Set within the bank.
    pub fn set_in_bank(&self, addr: u64) -> u32 {
        let line = quot(self.partition_addr(addr), self.line_bytes);
        let sets = self.sets_per_bank;
        match self.index {
            SetIndex::Linear => rem(line, sets) as u32,
            SetIndex::Ipoly if sets == 1 => 0,
            SetIndex::Ipoly => {
                let poly = ipoly_part(sets).expect("validated IPOLY set count");
                let p = IPOLY[poly].0;
                let m = u64::from(sets / p);
                (line % m) as u32 * p + ipoly_fast(line / m, poly)
            }
        }
    }

    /// Set in the whole L2 (banks' sets laid end to end).
    pub fn set_of(&self, addr: u64) -> usize {
        self.bank_of(addr) as usize * self.sets_per_bank as usize + self.set_in_bank(addr) as usize
    }

    /// Why `sets_per_bank` cannot be indexed with `index`, if it cannot.
    pub fn unsupported(sets_per_bank: u32, index: SetIndex) -> Option<String> {
        (index == SetIndex::Ipoly && sets_per_bank > 1 && ipoly_part(sets_per_bank).is_none()).then(|| {
            format!(
                "ipoly needs 1 set per bank or a multiple of 16 (GPGPU-Sim implements 16, 32 and 64); \
                 this L2 has {sets_per_bank} sets per bank"
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeSet;

    /// The 64-set equations of `hashing.cc:69-86`, transcribed as lists of the higher-address
    /// bits `a[j]` (j counts from bit 13 of the address, i.e. 7 line bits + 6 index bits) XORed
    /// into each index bit `b[i]`.
    const SRC64: [&[u32]; 6] = [
        &[18, 17, 16, 15, 12, 10, 6, 5, 0],
        &[15, 13, 12, 11, 10, 7, 5, 1, 0],
        &[16, 14, 13, 12, 11, 8, 6, 2, 1],
        &[17, 15, 14, 13, 12, 9, 7, 3, 2],
        &[18, 16, 15, 14, 13, 10, 8, 4, 3],
        &[17, 16, 15, 14, 11, 9, 5, 4],
    ];
    /// The 16-set equations (`hashing.cc:38-50`), higher bits from bit 11.
    const SRC16: [&[u32]; 4] = [
        &[11, 10, 9, 8, 6, 4, 3, 0],
        &[12, 8, 7, 6, 5, 3, 1, 0],
        &[9, 8, 7, 6, 4, 2, 1],
        &[10, 9, 8, 7, 5, 3, 2],
    ];

    /// The 32-set equations (`hashing.cc:52-67`), higher bits from bit 12.
    const SRC32: [&[u32]; 5] = [
        &[13, 12, 11, 10, 9, 6, 5, 3, 0],
        &[14, 13, 12, 11, 10, 7, 6, 4, 1],
        &[14, 10, 9, 8, 7, 6, 3, 2, 0],
        &[11, 10, 9, 8, 7, 4, 3, 1],
        &[12, 11, 10, 9, 8, 5, 4, 2],
    ];

    fn source_eq(addr: u64, eqs: &[&[u32]], index_bits: u32) -> u32 {
        let higher = addr >> (7 + index_bits);
        let index = (addr >> 7) & ((1 << index_bits) - 1);
        let mut out = 0;
        for (i, bits) in eqs.iter().enumerate() {
            let x = bits.iter().fold(index >> i & 1, |acc, &j| acc ^ (higher >> j & 1));
            out |= (x as u32) << i;
        }
        out
    }

    #[test]
    fn ipoly_matches_hand_computed_values() {
        // By hand from hashing.cc:69-86 (64 sets). 0x2000 = bit 13: a[0] = 1, index 0 →
        // b0 = a0 = 1, b1 = a0 = 1, others 0 → 3.
        assert_eq!(ipoly(0x2000 >> 7, 64), 3);
        // 0x4000 = a[1]: enters b1 and b2 → 6.
        assert_eq!(ipoly(0x4000 >> 7, 64), 6);
        // 0x2080: a[0] and index 1: b0 = 1 ^ 1 = 0, b1 = 1 → 2.
        assert_eq!(ipoly(0x2080 >> 7, 64), 2);
        // Below bit 13 IPOLY is the plain index.
        assert_eq!(ipoly(0x1f80 >> 7, 64), 63);
        // a[18] (bit 31) enters b0 and b4 → 17; a[19] (bit 32) is beyond the source's equations.
        assert_eq!(ipoly(0x8000_0000 >> 7, 64), 17);
        assert_eq!(ipoly(0x1_0000_0000 >> 7, 64), 0);
    }

    #[test]
    fn ipoly_tables_equal_the_bitwise_reduction() {
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        for k in 0..200_000u64 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            // Each single bit first, then random lines of widths from 40 to 64 bits.
            let line = if k < 64 { 1u64 << k } else { x >> (k % 24) };
            for (p, &(sets, ..)) in IPOLY.iter().enumerate() {
                assert_eq!(ipoly_fast(line, p), ipoly(line, sets), "line {line:#x}, {sets} sets");
            }
        }
    }

    #[test]
    fn ipoly_matches_the_source_equations() {
        let mut x = crate::mem::testutil::XorShift(5);
        for _ in 0..20_000 {
            let addr = x.next() & 0xffff_ffff_ff80;
            assert_eq!(ipoly(addr >> 7, 64), source_eq(addr, &SRC64, 6), "{addr:#x}");
            assert_eq!(ipoly(addr >> 7, 16), source_eq(addr, &SRC16, 4), "{addr:#x}");
            assert_eq!(ipoly(addr >> 7, 32), source_eq(addr, &SRC32, 5), "{addr:#x}");
        }
    }

    #[test]
    fn ipoly_spreads_power_of_two_strides_over_every_set() {
        // The reason for IPOLY (hashing.cc:30): 2^n strides are conflict-free.
        for stride_log2 in 7..20 {
            let sets: BTreeSet<u32> = (0..64u64).map(|i| ipoly((i << stride_log2) >> 7, 64)).collect();
            assert_eq!(sets.len(), 64, "stride 2^{stride_log2}");
        }
    }

    fn mobile_like(banks: u32, sets: u32, index: SetIndex) -> L2Map {
        L2Map { banks, interleave_bytes: 256, line_bytes: 128, sets_per_bank: sets, index }
    }

    #[test]
    fn banks_interleave_at_256_bytes_and_partition_address_drops_the_bank_digit() {
        let m = mobile_like(4, 64, SetIndex::Ipoly);
        assert_eq!((0..8).map(|k| m.bank_of(k * 128)).collect::<Vec<_>>(), vec![0, 0, 1, 1, 2, 2, 3, 3]);
        // As addrdec_tlx / partition_address with dramid@8 and 4 channels: bits 8-9 removed.
        assert_eq!(m.partition_addr(0x0000_0480), 0x180);
        assert_eq!(m.partition_addr(0x0001_2345), ((0x12345 >> 10) << 8) | 0x45);
        // Not a power of two (8 banks of a 6-bank test): the quotient, as addrdec.cc:117-120.
        let g = mobile_like(6, 64, SetIndex::Linear);
        assert_eq!(g.bank_of(7 * 256), 1);
        assert_eq!(g.partition_addr(7 * 256 + 5), 256 + 5);
    }

    #[test]
    fn non_power_of_two_sets_use_slices_of_64() {
        let m = mobile_like(8, 192, SetIndex::Ipoly);
        let all: BTreeSet<usize> = (0..1u64 << 16).map(|l| m.set_of(l * 128)).collect();
        assert_eq!(all.len(), 8 * 192, "every set of every bank is reachable");
        assert!(L2Map::unsupported(192, SetIndex::Ipoly).is_none());
        assert!(L2Map::unsupported(24, SetIndex::Ipoly).unwrap().contains("24 sets per bank"));
        assert!(L2Map::unsupported(24, SetIndex::Linear).is_none());
    }

    #[test]
    fn interleaved_local_layout_puts_one_slot_of_consecutive_threads_side_by_side() {
        let map = |layout| LocalMap {
            layout,
            base: 0x1000_0000,
            sms: 8,
            threads: 128,
            warp_size: 32,
            entry_bytes: 8,
            slots: 1 << 16,
        };
        let i = map(LocalLayout::Interleaved);
        assert_eq!(i.addr(0, 1, 0) - i.addr(0, 0, 0), 8);
        // Lane 0 of warp 0 on SM 1 follows the 32 lanes of SM 0's warp 0.
        assert_eq!(i.addr(1, 0, 0) - i.addr(0, 0, 0), 32 * 8);
        // Warp 1 of SM 0 follows warp 0 of all 8 SMs.
        assert_eq!(i.addr(0, 32, 0) - i.addr(0, 0, 0), 8 * 32 * 8);
        // The next slot is one whole GPU's threads further.
        assert_eq!(i.addr(0, 0, 1) - i.addr(0, 0, 0), 8 * 128 * 8);
        // Every (sm, thread, slot) has its own entry.
        let addrs: BTreeSet<u64> =
            (0..8).flat_map(|s| (0..128).flat_map(move |t| (0..4).map(move |k| i.addr(s, t, k)))).collect();
        assert_eq!(addrs.len(), 8 * 128 * 4);
        assert_eq!(addrs.last().unwrap() - addrs.first().unwrap(), (8 * 128 * 4 - 1) * 8);
        let l = map(LocalLayout::Linear);
        assert_eq!(l.addr(0, 1, 0) - l.addr(0, 0, 0), 8 << 16);
        assert_eq!(l.addr(1, 0, 3), 0x1000_0000 + 128 * (8 << 16) + 24);
    }
}
