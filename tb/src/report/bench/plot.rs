//! `sms bench`'s plot: run time against the worst headline error of every setting.

use std::path::Path;

use crate::error::Result;
use crate::report::plot::{log_scatter, LabelledPoints};
use crate::run::bench::data::{by_setting, Headline, Report, Setting};
use crate::run::sim::Fidelity;

impl Report {
    /// Time against worst headline error per setting (functional: the metrics it measures).
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        const FLOOR: f64 = 1e-4;
        let points: Vec<(Setting, f64, f64)> = by_setting(&self.rows)
            .into_iter()
            .map(|(s, rs)| {
                let measured: Vec<Headline> = Headline::ALL
                    .into_iter()
                    .filter(|&h| rs.iter().all(|r| r.errors.get(h).is_some()))
                    .collect();
                let worst = rs.iter().filter_map(|r| r.errors.worst(&measured)).fold(0.0, f64::max);
                let wall: f64 = rs.iter().map(|r| r.wall).sum();
                (s, wall.max(1e-4), (worst * 100.0).clamp(FLOOR, 1e4))
            })
            .collect();
        let series =
            [(Fidelity::Cycle, "cycle level"), (Fidelity::Functional, "functional level (no cycle metrics)")]
                .map(|(fidelity, name)| LabelledPoints {
                    name: name.into(),
                    points: points
                        .iter()
                        .filter(|p| p.0.fidelity == fidelity)
                        .map(|p| (p.1, p.2, p.0.to_string()))
                        .collect(),
                });
        log_scatter(
            path,
            "run time against worst headline error",
            "seconds, all scenes and configurations",
            &format!("worst relative error, % (0 drawn at {FLOOR:e})"),
            FLOOR,
            &series,
            Some((1.0, "1 % tolerance")),
        )
    }
}
