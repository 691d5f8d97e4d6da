//! Sampling: simulate a fraction of the warps and estimate every reported metric of the whole
//! workload with a confidence interval.
//!
//! The sample is split into `batches` disjoint groups of warps (batch means). A batch's metric
//! divided by its warp count is one observation of the per-warp metric; the estimate of the total
//! is the mean observation times the workload's warp count, and the 95 % interval is
//! `mean ± t(0.975, batches − 1) · s / √batches`, scaled alike. Warps are drawn either uniformly
//! at random or stratified by screen tile (every tile contributes in proportion to its warps, so a
//! sample cannot miss a region of the image).
//!
//! At the functional level each batch is simulated on its own, and the additive metrics (stack
//! entries moved off chip, spills, borrows, flushes: a warp's counts depend on its own traces) are
//! estimated without bias; a test checks the intervals' coverage over 40 seeds.
//!
//! At the cycle level metrics depend on what else is in flight (cycles, DRAM accesses behind the
//! caches, bank conflicts), so separate launches per batch would each pay a GPU fill and drain
//! and see less contention (measured: raw cycles off by 125 % even sampling every warp). Instead
//! `sim::simulate_sampled` runs the whole sample as one launch and gives each batch the share of
//! every count that its warps' warp-buffer residence is of the launch's. The estimate is then the
//! launch's count scaled by total/sampled warps, except cycles: only the part up to the last
//! dispatch scales with the work, the drain after it is kept as measured (a batch gets its warp
//! share of it). The interval assumes counts accrue with
//! residence, so it reflects how much warps differ in run time, not where e.g. a spill burst
//! happened. `sms bench` measures the resulting error against the full run.

use crate::run::verify::harness::mix;

/// A counter-based stream of 64-bit numbers from [`mix`].
struct Stream(u64);

impl Stream {
    fn next_u32(&mut self) -> u32 {
        self.0 = self.0.wrapping_add(1);
        (mix(self.0) >> 32) as u32
    }
}

/// How warps are drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum SampleMode {
    /// Uniformly at random.
    Random,
    /// Stratified by screen tile.
    Tile,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SamplePlan {
    /// Fraction of warps to simulate, in (0, 1].
    pub fraction: f64,
    pub mode: SampleMode,
    pub batches: u32,
    pub seed: u64,
}

impl SamplePlan {
    /// Whether the plan takes every warp: then it is no sample, and callers run the full
    /// simulation instead (batch estimates of a whole frame would only add rounding and
    /// intervals to exact counts).
    pub fn every_warp(&self) -> bool {
        self.fraction >= 1.0
    }

    pub fn validate(&self) -> Result<(), String> {
        if !(self.fraction > 0.0 && self.fraction <= 1.0) {
            return Err(format!("sample fraction {} must be in (0, 1]", self.fraction));
        }
        if self.batches < 2 {
            return Err(format!("{} batches: a confidence interval needs at least 2", self.batches));
        }
        Ok(())
    }
}

/// Picks the sampled warps and splits them into batches. `tile_of(w)` names warp `w`'s screen
/// tile (used by [`SampleMode::Tile`]). Every batch gets at least one warp, so with few warps
/// the sample may be larger than the fraction asks.
pub fn choose(num_warps: u32, plan: &SamplePlan, tile_of: impl Fn(u32) -> u32) -> Vec<Vec<u32>> {
    let want =
        ((num_warps as f64 * plan.fraction).round() as u32).clamp(plan.batches.min(num_warps), num_warps);
    let mut rng = Stream(mix(plan.seed ^ 0x5a3b));
    let mut picked: Vec<u32> = match plan.mode {
        SampleMode::Random => {
            let mut all: Vec<u32> = (0..num_warps).collect();
            shuffle(&mut all, &mut rng);
            all.truncate(want as usize);
            all
        }
        SampleMode::Tile => {
            let mut tiles: std::collections::BTreeMap<u32, Vec<u32>> = Default::default();
            for w in 0..num_warps {
                tiles.entry(tile_of(w)).or_default().push(w);
            }
            // Largest-remainder apportionment of `want` over the tiles.
            let mut quota: Vec<(u32, f64, Vec<u32>)> = tiles
                .into_values()
                .map(|mut ws| {
                    shuffle(&mut ws, &mut rng);
                    let exact = ws.len() as f64 * want as f64 / num_warps as f64;
                    (exact.floor() as u32, exact.fract(), ws)
                })
                .collect();
            let mut left = want - quota.iter().map(|q| q.0).sum::<u32>();
            let mut order: Vec<usize> = (0..quota.len()).collect();
            order.sort_by(|&a, &b| quota[b].1.total_cmp(&quota[a].1));
            for i in order {
                if left == 0 {
                    break;
                }
                quota[i].0 += 1;
                left -= 1;
            }
            quota.into_iter().flat_map(|(n, _, ws)| ws.into_iter().take(n as usize)).collect()
        }
    };
    shuffle(&mut picked, &mut rng);
    let b = plan.batches.min(picked.len() as u32).max(1) as usize;
    let mut out = vec![Vec::new(); b];
    for (i, w) in picked.into_iter().enumerate() {
        out[i % b].push(w);
    }
    for batch in &mut out {
        batch.sort_unstable();
    }
    out
}

fn shuffle(v: &mut [u32], rng: &mut Stream) {
    for i in (1..v.len()).rev() {
        let j = (rng.next_u32() as usize) % (i + 1);
        v.swap(i, j);
    }
}

/// An estimate of a workload total with its 95 % confidence interval.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Estimate {
    pub value: f64,
    pub half_width: f64,
}

impl Estimate {
    pub fn contains(&self, x: f64) -> bool {
        (x - self.value).abs() <= self.half_width
    }
    /// Half width relative to the value.
    pub fn relative(&self) -> f64 {
        if self.value == 0.0 {
            0.0
        } else {
            self.half_width / self.value.abs()
        }
    }
}

/// Two-sided 95 % Student t quantile for `df` degrees of freedom.
pub fn t95(df: u32) -> f64 {
    const T: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145,
        2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048,
        2.045, 2.042,
    ];
    match df {
        0 => f64::INFINITY,
        1..=30 => T[df as usize - 1],
        _ => 1.96 + 2.4 / df as f64,
    }
}

/// Estimates the total of a metric over `total_warps` warps from per-batch `(metric, warps)`
/// observations. Uses Welford's update so long sums stay accurate.
pub fn estimate(batches: &[(f64, u32)], total_warps: u32) -> Estimate {
    let (mut n, mut mean, mut m2) = (0u32, 0.0f64, 0.0f64);
    for &(value, warps) in batches.iter().filter(|b| b.1 > 0) {
        let x = value / warps as f64;
        n += 1;
        let delta = x - mean;
        mean += delta / n as f64;
        m2 += delta * (x - mean);
    }
    let scale = total_warps as f64;
    let half =
        if n > 1 { t95(n - 1) * (m2 / (n - 1) as f64).sqrt() / (n as f64).sqrt() } else { f64::INFINITY };
    Estimate { value: mean * scale, half_width: half * scale }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(fraction: f64, mode: SampleMode, seed: u64) -> SamplePlan {
        SamplePlan { fraction, mode, batches: 8, seed }
    }

    #[test]
    fn batches_are_disjoint_and_the_right_size() {
        for mode in [SampleMode::Random, SampleMode::Tile] {
            let b = choose(1000, &plan(0.1, mode, 3), |w| w / 50);
            let all: Vec<u32> = b.iter().flatten().copied().collect();
            assert_eq!(all.len(), 100);
            let mut dedup = all.clone();
            dedup.sort_unstable();
            dedup.dedup();
            assert_eq!(dedup.len(), 100, "no warp twice");
            assert_eq!(b.len(), 8);
        }
    }

    #[test]
    fn tile_sampling_covers_every_tile() {
        let b = choose(1000, &plan(0.2, SampleMode::Tile, 5), |w| w / 100);
        for tile in 0..10 {
            let n = b.iter().flatten().filter(|&&w| w / 100 == tile).count();
            assert_eq!(n, 20, "tile {tile}");
        }
    }

    #[test]
    fn intervals_cover_the_truth_about_95_percent_of_the_time() {
        // A skewed per-warp metric (most warps cheap, a few expensive regions).
        let metric = |w: u32| if w % 97 < 10 { 500.0 } else { 20.0 + (w % 13) as f64 };
        let total: f64 = (0..2000).map(metric).sum();
        let mut covered = 0;
        let trials = 200;
        for seed in 0..trials {
            let batches = choose(2000, &plan(0.1, SampleMode::Random, seed), |_| 0);
            let obs: Vec<(f64, u32)> =
                batches.iter().map(|b| (b.iter().map(|&w| metric(w)).sum(), b.len() as u32)).collect();
            covered += u32::from(estimate(&obs, 2000).contains(total));
        }
        let rate = covered as f64 / trials as f64;
        assert!((0.88..=1.0).contains(&rate), "coverage {rate}");
    }

    #[test]
    fn bad_plans_are_rejected() {
        assert!(plan(0.0, SampleMode::Random, 0).validate().is_err());
        assert!(plan(1.5, SampleMode::Random, 0).validate().is_err());
        assert!(SamplePlan { batches: 1, ..plan(0.5, SampleMode::Random, 0) }.validate().is_err());
    }
}
