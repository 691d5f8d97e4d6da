//! `sms bench`'s tables: one row per run, per setting, and the throughput, work and savings
//! tables, rendered as text, Markdown or CSV by [`Table`].

use super::{by_setting, worse, Errors, Headline, Report, Setting};
use crate::report::table::Table;

/// A relative error as a percentage; `n/a` where not measured.
pub(super) fn pct(e: Option<f64>) -> String {
    match e {
        None => "n/a".into(),
        Some(e) if e.is_infinite() => "inf".into(),
        Some(e) => format!("{:.2}%", e * 100.0),
    }
}

impl Report {
    /// Full cycle-level time of each (scene, configuration).
    fn truth_wall(&self, scene: &str, config: &str) -> f64 {
        self.rows
            .iter()
            .find(|r| r.scene == scene && r.config == config && r.setting == Setting::FULL_CYCLE)
            .map_or(f64::NAN, |r| r.wall)
    }

    /// One row per scene, configuration and setting.
    pub fn rows_table(&self) -> Table {
        let mut t = Table::new([
            "scene",
            "config",
            "setting",
            "warps",
            "time s",
            "faster",
            "err perf",
            "err off-chip",
            "err conflicts",
            "err cycles",
            "err dram stack",
            "±95%",
        ]);
        for r in &self.rows {
            let e = &r.errors;
            t.row([
                r.scene.clone(),
                r.config.clone(),
                r.setting.to_string(),
                r.pixel_warps.to_string(),
                format!("{:.3}", r.wall),
                format!("{:.1}x", self.truth_wall(&r.scene, &r.config) / r.wall),
                pct(e.norm_cycles),
                pct(e.stack_global),
                pct(e.conflict_cycles),
                pct(e.cycles),
                pct(e.dram_stack),
                r.ci.map_or(String::new(), |c| pct(Some(c))),
            ]);
        }
        t
    }

    /// One row per setting: total time and worst errors over every scene and configuration.
    pub fn summary_table(&self, tolerance: f64) -> Table {
        let mut t = Table::new([
            "setting",
            "time s",
            "faster",
            "worst perf",
            "worst off-chip",
            "worst conflicts",
            "worst cycles",
            "all within",
        ]);
        let full: f64 = self.rows.iter().filter(|r| r.setting == Setting::FULL_CYCLE).map(|r| r.wall).sum();
        for (setting, rs) in by_setting(&self.rows) {
            let wall: f64 = rs.iter().map(|r| r.wall).sum();
            let worst = |f: fn(&Errors) -> Option<f64>| {
                rs.iter().map(|r| f(&r.errors)).try_fold(0.0, |w, e| Some(worse(w, e?)))
            };
            let ok = rs.iter().all(|r| r.errors.worst(&Headline::ALL).is_some_and(|w| w <= tolerance));
            t.row([
                setting.to_string(),
                format!("{wall:.3}"),
                format!("{:.1}x", full / wall),
                pct(worst(|e| e.norm_cycles)),
                pct(worst(|e| e.stack_global)),
                pct(worst(|e| e.conflict_cycles)),
                pct(worst(|e| e.cycles)),
                if ok { format!("yes ({}%)", tolerance * 100.0) } else { "no".into() },
            ]);
        }
        t
    }

    pub fn throughput_table(&self) -> Table {
        let mut t = Table::new([
            "scene",
            "config",
            "rays",
            "GPU cycles",
            "run s",
            "cycles/s",
            "evaluated/s",
            "stack ops/s",
            "BVH6 plain s",
            "obvhs CWBVH s",
            "run / obvhs",
        ]);
        for p in &self.throughput {
            t.row([
                p.scene.clone(),
                p.config.clone(),
                p.rays.to_string(),
                p.cycles.to_string(),
                format!("{:.3}", p.wall),
                format!("{:.0}", p.cycles_per_sec()),
                format!("{:.0}", p.evaluated_cycles as f64 / p.wall),
                format!("{:.0}", p.stack_ops_per_sec()),
                format!("{:.4}", p.plain_bvh6),
                format!("{:.4}", p.obvhs_cwbvh),
                format!("{:.0}x", p.vs_obvhs()),
            ]);
        }
        t
    }

    pub fn work_table(&self) -> Table {
        let mut t = Table::new([
            "scene",
            "triangles",
            "rays",
            "max depth",
            "rays ≤ 8 deep",
            "internal visits",
            "leaf visits",
            "triangle visits",
            "procedural visits",
        ]);
        for w in &self.work {
            t.row([
                w.scene.clone(),
                w.triangles.to_string(),
                w.rays.to_string(),
                w.max_depth.to_string(),
                format!(
                    "{} ({:.1}%)",
                    w.rays_within_rb8,
                    100.0 * w.rays_within_rb8 as f64 / w.rays.max(1) as f64
                ),
                w.internal.to_string(),
                w.leaf.to_string(),
                w.triangle.to_string(),
                w.procedural.to_string(),
            ]);
        }
        t
    }

    pub fn savings_table(&self) -> Table {
        let mut t = Table::new(["scene", "work skipped", "doing it s", "skipping s", "saving", "result"]);
        for s in &self.savings {
            t.row([
                s.scene.clone(),
                s.what.clone(),
                format!("{:.3}", s.with_work),
                format!("{:.3}", s.skipped),
                format!("{:.2}x", s.with_work / s.skipped),
                s.note.clone(),
            ]);
        }
        t
    }
}
