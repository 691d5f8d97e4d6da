//! Deterministic random stack streams: valid push/pop histories that end empty.

use super::harness::{mix, Op, WarpWork};

/// A stream that climbs to about `peak` entries (with random pushes and pops on the way), wanders,
/// and drains. Values are unique per (seed, position), so a lost, duplicated or reordered entry
/// cannot hide behind an equal value.
pub fn stream(seed: u64, peak: u32) -> Vec<Op> {
    let mut ops = Vec::new();
    let mut depth = 0u32;
    let mut i = 0u64;
    let next = |i: &mut u64| {
        *i += 1;
        mix(seed ^ i.wrapping_mul(0x2545_F491_4F6C_DD1D))
    };
    // Climb to the peak with 70 % pushes, wander 4 × peak steps at 50 %, drain at 25 %.
    type Done<'a> = &'a dyn Fn(u32, u32) -> bool;
    let phases: [(u64, Done); 3] =
        [(70, &|depth, _| depth >= peak), (50, &|_, steps| steps >= 4 * peak), (25, &|depth, _| depth == 0)];
    for (push_pct, done) in phases {
        let mut steps = 0;
        while !done(depth, steps) {
            let r = next(&mut i);
            if depth == 0 || r % 100 < push_pct {
                ops.push(Op::Push(r >> 8 | 1));
                depth += 1;
            } else {
                ops.push(Op::Pop);
                depth -= 1;
            }
            steps += 1;
        }
    }
    while depth > 0 {
        ops.push(Op::Pop);
        depth -= 1;
    }
    ops
}

/// `count` warps of `warp_size` lanes; each lane's peak depth is drawn from 0..=max_peak, some
/// lanes inactive, so threads finish at very different times.
pub fn warps(seed: u64, count: u32, warp_size: u32, max_peak: u32) -> Vec<WarpWork> {
    (0..count)
        .map(|w| WarpWork {
            lanes: (0..warp_size)
                .map(|l| {
                    let h = mix(seed ^ ((w as u64) << 32) ^ l as u64);
                    if h.is_multiple_of(16) {
                        None
                    } else {
                        Some(stream(h, (h >> 8) as u32 % (max_peak + 1)))
                    }
                })
                .collect(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_valid_histories() {
        for seed in 0..50 {
            let s = stream(seed, 120);
            let mut depth: i64 = 0;
            let mut peak = 0;
            for op in &s {
                depth += if matches!(op, Op::Push(_)) { 1 } else { -1 };
                assert!(depth >= 0);
                peak = peak.max(depth);
            }
            assert_eq!(depth, 0);
            assert!(peak >= 120);
        }
    }
}
