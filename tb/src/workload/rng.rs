//! Counter-based random numbers: every value is a hash of where it is used (seed, pixel, sample,
//! bounce, dimension), so results never depend on evaluation order and any ray can be regenerated
//! alone. The mixing function is the PCG output permutation (Jarzynski and Olano, "Hash Functions
//! for GPU Rendering", JCGT 2020).

fn pcg(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// A stream of uniform numbers keyed by a list of integers.
#[derive(Clone, Copy, Debug)]
pub struct Rng(u32);

impl Rng {
    pub fn new(keys: &[u64]) -> Self {
        let h = keys.iter().fold(0x9e37_79b9u32, |h, &k| pcg(pcg(h ^ k as u32) ^ (k >> 32) as u32));
        Rng(h)
    }

    /// Uniform in `[0, 1)`.
    pub fn next_f32(&mut self) -> f32 {
        self.0 = pcg(self.0);
        (self.0 >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }
}
