//! Stack-depth statistics (SPEC section 8): maximum, mean and median depth and the distribution
//! of depths over all pushes and pops.
//!
//! The depth of a push is the stack size after it, the depth of a pop the size before it (the
//! depth of the entry it takes), so each entry counts once at the same depth going on and off.
//! Counts are kept as an integer histogram and every statistic is derived from it, so results do
//! not depend on accumulation order and merge exactly.

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::error::{Error, Result};
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

    /// Summary and distribution as a terminal table.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "scene {}: {} rays, {} pushes+pops", self.scene, self.rays, self.pushes_and_pops);
        let _ = writeln!(s, "stack depth  max {}  mean {:.3}  median {}", self.max, self.mean, self.median);
        let _ = writeln!(s, "{:>5} {:>12} {:>8}", "depth", "count", "share");
        let total = self.pushes_and_pops.max(1) as f64;
        for (d, &c) in self.histogram.counts.iter().enumerate().skip(1) {
            let share = c as f64 / total;
            let bar = "#".repeat((share * 50.0).round() as usize);
            let _ = writeln!(s, "{d:>5} {c:>12} {:>7.3}% {bar}", share * 100.0);
        }
        s
    }

    /// One row per depth: `depth,count,fraction`.
    pub fn csv(&self) -> String {
        let total = self.pushes_and_pops.max(1) as f64;
        let mut s = String::from("depth,count,fraction\n");
        for (d, &c) in self.histogram.counts.iter().enumerate().skip(1) {
            let _ = writeln!(s, "{d},{c},{:.6}", c as f64 / total);
        }
        s
    }

    pub fn json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }

    /// Histogram of the depth distribution as an SVG file.
    pub fn write_svg(&self, path: &Path, title: &str) -> Result<()> {
        use plotters::prelude::*;
        let to_err = |e: &dyn std::fmt::Display| Error::io(path, std::io::Error::other(e.to_string()));
        let total = self.pushes_and_pops.max(1) as f64;
        let max_depth = self.max.max(1);
        let top = self.histogram.counts.iter().map(|&c| c as f64 / total).fold(0.0, f64::max).max(1e-6);
        let root = SVGBackend::new(path, (800, 480)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| to_err(&e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d((1..max_depth + 1).into_segmented(), 0.0..top * 1.1)
            .map_err(|e| to_err(&e))?;
        chart
            .configure_mesh()
            .x_desc("stack depth at push/pop")
            .y_desc("fraction of pushes and pops")
            .disable_x_mesh()
            .draw()
            .map_err(|e| to_err(&e))?;
        // One bar per depth in depth order (plotters' Histogram sums through a hash map, so its
        // SVG element order changed from run to run).
        chart
            .draw_series(self.histogram.counts.iter().enumerate().skip(1).map(|(d, &c)| {
                let d = d as u32;
                let span = [(SegmentValue::Exact(d), 0.0), (SegmentValue::Exact(d + 1), c as f64 / total)];
                let mut bar = Rectangle::new(span, BLUE.filled());
                bar.set_margin(0, 0, 2, 2);
                bar
            }))
            .map_err(|e| to_err(&e))?;
        root.present().map_err(|e| to_err(&e))
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

    #[test]
    fn reports_render_as_table_csv_json_and_svg() {
        let mut h = DepthHistogram::default();
        h.add_trace(&trace());
        let report = DepthReport::new("test", "opts", 1, h);
        assert!(report.table().contains("max 2"));
        assert_eq!(report.csv(), "depth,count,fraction\n1,2,0.333333\n2,4,0.666667\n");
        let json: serde_json::Value = serde_json::from_str(&report.json()).expect("json");
        assert_eq!(json["median"], 2);
        let path = std::env::temp_dir().join(format!("tb-depth-{}.svg", std::process::id()));
        report.write_svg(&path, "test").expect("svg");
        assert!(std::fs::read_to_string(&path).expect("svg").starts_with("<svg"));
    }
}
