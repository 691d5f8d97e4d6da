//! The 128-bit state key's hasher (hash compaction): the bytes a state's `Hash` impls write,
//! packed into words and mixed in two lanes. Its own file because the key's soundness argument
//! (what is hashed, in what stream) is read apart from the model that feeds it.

use std::hash::Hasher;

use rtl::stack_manager::StackManager;

/// A 128-bit hash of the stack manager's whole architectural state
/// ([`StackManager::hash_state`]).
pub(super) fn state_hash(sm: &StackManager) -> u128 {
    let mut h = KeyHasher::new();
    sm.hash_state(&mut h);
    h.key()
}

/// The state key's hasher. The bytes the state's `Hash` impls write form one stream (each
/// write's bytes in order, as SipHash takes its input; the impls write lengths before contents,
/// so the stream is unambiguous), packed into 64-bit words; each word goes through the SplitMix64
/// finaliser ([`crate::run::verify::harness::mix`]) in two lanes with different seeds, the two halves of the
/// 128-bit key. Packing mixes once per 8 bytes rather than once per field written.
pub(super) struct KeyHasher {
    lanes: [u64; 2],
    /// Bits written and not yet mixed (fewer than 64 between writes).
    acc: u128,
    bits: u32,
    len: u64,
}

impl KeyHasher {
    pub(super) fn new() -> Self {
        KeyHasher { lanes: [0x5EED_0001, 0xC0FF_EE02], acc: 0, bits: 0, len: 0 }
    }
    /// Appends the low `n` bits of `x` (`n` ≤ 64; the higher bits of `x` are zero).
    #[inline]
    fn push(&mut self, x: u64, n: u32) {
        self.acc |= u128::from(x) << self.bits;
        self.bits += n;
        self.len += u64::from(n);
        if self.bits >= 64 {
            let w = self.acc as u64;
            self.lanes = self.lanes.map(|h| crate::run::verify::harness::mix(h ^ w));
            self.acc >>= 64;
            self.bits -= 64;
        }
    }
    pub(super) fn key(mut self) -> u128 {
        let (rest, len) = (self.acc as u64, self.len);
        self.lanes = self
            .lanes
            .map(|h| crate::run::verify::harness::mix(crate::run::verify::harness::mix(h ^ rest) ^ len));
        u128::from(self.lanes[0]) << 64 | u128::from(self.lanes[1])
    }
}

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        unreachable!("the state key is taken with KeyHasher::key")
    }
    fn write(&mut self, bytes: &[u8]) {
        for c in bytes.chunks(8) {
            let mut w = [0u8; 8];
            w[..c.len()].copy_from_slice(c);
            self.push(u64::from_le_bytes(w), 8 * c.len() as u32);
        }
    }
    fn write_u8(&mut self, x: u8) {
        self.push(x.into(), 8);
    }
    fn write_u16(&mut self, x: u16) {
        self.push(x.into(), 16);
    }
    fn write_u32(&mut self, x: u32) {
        self.push(x.into(), 32);
    }
    fn write_u64(&mut self, x: u64) {
        self.push(x, 64);
    }
    fn write_usize(&mut self, x: usize) {
        self.push(x as u64, 64);
    }
}
