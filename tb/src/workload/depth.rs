//! Stack-depth statistics (SPEC section 8): maximum, mean and median depth and the distribution
//! of depths over all pushes and pops.
//!
//! The depth of a push is the stack size after it, the depth of a pop the size before it (the
//! depth of the entry it takes), so each entry counts once at the same depth going on and off.
//! Counts are kept as an integer histogram and every statistic is derived from it, so results do
//! not depend on accumulation order and merge exactly. The report is rendered by
//! [`crate::report::depth`].

use serde::Serialize;

use crate::workload::trace::{RayTrace, TraceOp};

/// Histogram of stack depths over pushes and pops.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DepthHistogram {
    /// `counts[d]` = number of pushes and pops at depth `d`.
    pub counts: Vec<u64>,
    /// Traces added.
    pub traces: u64,
}

impl DepthHistogram {
    pub fn add_trace(&mut self, trace: &RayTrace) {
        self.traces += 1;
        let mut depth = 0usize;
        for op in trace.ops() {
            let at = match op {
                TraceOp::Push(_) => {
                    depth += 1;
                    depth
                }
                TraceOp::Pop(_) => {
                    depth -= 1;
                    depth + 1
                }
                TraceOp::Visit { .. } => continue,
            };
            if self.counts.len() <= at {
                self.counts.resize(at + 1, 0);
            }
            self.counts[at] += 1;
        }
    }

    /// Pushes plus pops.
    pub fn total(&self) -> u64 {
        self.counts.iter().sum()
    }

    pub fn max(&self) -> u32 {
        self.counts.iter().rposition(|&c| c > 0).unwrap_or(0) as u32
    }

    pub fn mean(&self) -> f64 {
        let total = self.total();
        if total == 0 {
            return 0.0;
        }
        let weighted: u128 = self.counts.iter().enumerate().map(|(d, &c)| d as u128 * c as u128).sum();
        weighted as f64 / total as f64
    }

    /// Lower median depth.
    pub fn median(&self) -> u32 {
        let half = self.total().div_ceil(2);
        let mut seen = 0;
        for (d, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen >= half && seen > 0 {
                return d as u32;
            }
        }
        0
    }
}

/// The statistics of one run, with what produced them.
#[derive(Clone, Debug, Serialize)]
pub struct DepthReport<Opts: Serialize> {
    pub scene: String,
    pub opts: Opts,
    pub rays: u64,
    pub max: u32,
    pub mean: f64,
    pub median: u32,
    pub pushes_and_pops: u64,
    pub histogram: DepthHistogram,
}

impl<Opts: Serialize> DepthReport<Opts> {
    pub fn new(scene: &str, opts: Opts, rays: u64, histogram: DepthHistogram) -> Self {
        DepthReport {
            scene: scene.to_owned(),
            opts,
            rays,
            max: histogram.max(),
            mean: histogram.mean(),
            median: histogram.median(),
            pushes_and_pops: histogram.total(),
            histogram,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workload::trace::FetchKind;
    use crate::workload::traverse::Recorder;

    /// Root, push a, push b, pop b, push c, pop c, pop a: depths 1, 2, 2, 2, 2, 1.
    fn trace() -> RayTrace {
        let mut t = RayTrace::default();
        t.visit(0, FetchKind::Internal);
        t.push(1);
        t.push(2);
        t.pop(2);
        t.push(3);
        t.pop(3);
        t.pop(1);
        t
    }

    #[test]
    fn statistics_come_from_the_histogram() {
        let mut h = DepthHistogram::default();
        h.add_trace(&trace());
        assert_eq!(h.counts, [0, 2, 4]);
        assert_eq!((h.total(), h.max(), h.median()), (6, 2, 2));
        assert!((h.mean() - 10.0 / 6.0).abs() < 1e-12);
        h.add_trace(&RayTrace::default());
        assert_eq!(h.traces, 2);
        let empty = DepthHistogram::default();
        assert_eq!((empty.max(), empty.median(), empty.mean()), (0, 0, 0.0));
    }
}
