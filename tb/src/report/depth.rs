//! The stack-depth report of `sms depth` and of every scene of a sweep: text, Markdown, CSV, JSON
//! and an SVG histogram drawn by [`crate::report::plot::histogram`].

use std::fmt::Write as _;
use std::path::Path;

use serde::Serialize;

use crate::error::Result;
use crate::report::plot;
use crate::report::table::Table;
use crate::workload::depth::DepthReport;

impl<Opts: Serialize> DepthReport<Opts> {
    /// Share of every depth from 1 up, of all pushes and pops.
    fn shares(&self) -> impl Iterator<Item = (usize, u64, f64)> + '_ {
        let total = self.pushes_and_pops.max(1) as f64;
        self.histogram.counts.iter().enumerate().skip(1).map(move |(d, &c)| (d, c, c as f64 / total))
    }

    /// Summary and distribution as a terminal table.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "scene {}: {} rays, {} pushes+pops", self.scene, self.rays, self.pushes_and_pops);
        let _ = writeln!(s, "stack depth  max {}  mean {:.3}  median {}", self.max, self.mean, self.median);
        let _ = writeln!(s, "{:>5} {:>12} {:>8}", "depth", "count", "share");
        for (d, c, share) in self.shares() {
            let bar = "#".repeat((share * 50.0).round() as usize);
            let _ = writeln!(s, "{d:>5} {c:>12} {:>7.3}% {bar}", share * 100.0);
        }
        s
    }

    /// The same summary and distribution in Markdown.
    pub fn markdown(&self) -> String {
        let mut t = Table::new(["depth", "count", "share"]);
        for (d, c, share) in self.shares() {
            t.row([d.to_string(), c.to_string(), format!("{:.3}%", share * 100.0)]);
        }
        format!(
            "# Stack depth: {}\n\n{} rays, {} pushes+pops; max {}, mean {:.3}, median {}.\n\n{}",
            self.scene,
            self.rays,
            self.pushes_and_pops,
            self.max,
            self.mean,
            self.median,
            t.to_markdown()
        )
    }

    /// One row per depth: `depth,count,fraction`.
    pub fn csv(&self) -> String {
        let mut s = String::from("depth,count,fraction\n");
        for (d, c, share) in self.shares() {
            let _ = writeln!(s, "{d},{c},{share:.6}");
        }
        s
    }

    /// Every field (layout: docs/json.md).
    pub fn json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_else(|e| format!("{{\"error\": \"{e}\"}}"))
    }

    /// Histogram of the depth distribution as an SVG file.
    pub fn write_svg(&self, path: &Path, title: &str) -> Result<()> {
        let shares: Vec<f64> = self.shares().map(|(_, _, share)| share).collect();
        plot::histogram(
            path,
            title,
            "stack depth at push/pop",
            "fraction of pushes and pops",
            self.max.max(1),
            &shares,
        )
    }
}

#[cfg(test)]
mod tests {
    use crate::workload::depth::{DepthHistogram, DepthReport};

    #[test]
    fn reports_render_as_table_markdown_csv_json_and_svg() {
        // Depths 1, 2, 2, 2, 2, 1 (push a, push b, pop b, push c, pop c, pop a).
        let h = DepthHistogram { counts: vec![0, 2, 4], traces: 1 };
        let report = DepthReport::new("test", "opts", 1, h);
        assert!(report.table().contains("max 2"));
        assert!(report.table().ends_with("    2            4  66.667% #################################\n"));
        assert!(report.markdown().contains("| 2 | 4 | 66.667% |"), "{}", report.markdown());
        assert_eq!(report.csv(), "depth,count,fraction\n1,2,0.333333\n2,4,0.666667\n");
        let json: serde_json::Value = serde_json::from_str(&report.json()).expect("json");
        assert_eq!(json["median"], 2);
        let path = std::env::temp_dir().join(format!("tb-depth-{}.svg", std::process::id()));
        report.write_svg(&path, "test").expect("svg");
        let svg = std::fs::read_to_string(&path).expect("svg");
        assert!(svg.starts_with("<svg"));
        std::fs::remove_file(&path).ok();
    }
}
