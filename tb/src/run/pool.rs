//! The one thread pool: independent simulations on `jobs` rayon threads, results in input order so
//! that nothing downstream depends on the thread count or on scheduling.

use rayon::prelude::*;

/// `f(0)`, …, `f(n - 1)` on `jobs` threads (at least one), in index order. With one job they
/// run on the calling thread, one after the other: not as a pool's worker, so that each run may
/// use the cores a pool would leave idle ([`crate::run::sim::spare_core`]).
pub fn map_indexed<T: Send>(jobs: usize, n: usize, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    if jobs <= 1 {
        return (0..n).map(f).collect();
    }
    match rayon::ThreadPoolBuilder::new().num_threads(jobs).build() {
        Ok(pool) => pool.install(|| (0..n).into_par_iter().map(&f).collect()),
        // No threads to be had: the same results, one after the other.
        Err(_) => (0..n).map(f).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_keep_input_order_whatever_the_thread_count() {
        let serial: Vec<u64> = (0..200u64).map(|i| i * i + 1).collect();
        for jobs in [1, 2, 7] {
            assert_eq!(map_indexed(jobs, 200, |i| (i as u64) * (i as u64) + 1), serial, "{jobs} threads");
        }
    }
}
