//! `sms bench`'s tables: one row per run, per setting, and the throughput, work and savings
//! tables, rendered as text, Markdown or CSV by [`Table`].

use crate::report::table::Table;
use crate::run::bench::data::{by_setting, worse, Errors, Headline, Report, Setting, Work};

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
        Table::of(
            &self.rows,
            &[
                ("scene", &|r| r.scene.clone()),
                ("config", &|r| r.config.clone()),
                ("setting", &|r| r.setting.to_string()),
                ("warps", &|r| r.pixel_warps.to_string()),
                ("time s", &|r| format!("{:.3}", r.wall)),
                ("faster", &|r| format!("{:.1}x", self.truth_wall(&r.scene, &r.config) / r.wall)),
                ("err perf", &|r| pct(r.errors.norm_cycles)),
                ("err off-chip", &|r| pct(r.errors.stack_global)),
                ("err conflicts", &|r| pct(r.errors.conflict_cycles)),
                ("err cycles", &|r| pct(r.errors.cycles)),
                ("err dram stack", &|r| pct(r.errors.dram_stack)),
                ("±95%", &|r| r.ci.map_or(String::new(), |c| pct(Some(c)))),
            ],
        )
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
        Table::of(
            &self.throughput,
            &[
                ("scene", &|p| p.scene.clone()),
                ("config", &|p| p.config.clone()),
                ("rays", &|p| p.rays.to_string()),
                ("GPU cycles", &|p| p.cycles.to_string()),
                ("run s", &|p| format!("{:.3}", p.wall)),
                ("cycles/s", &|p| format!("{:.0}", p.cycles_per_sec())),
                ("evaluated/s", &|p| format!("{:.0}", p.evaluated_cycles as f64 / p.wall)),
                ("stack ops/s", &|p| format!("{:.0}", p.stack_ops_per_sec())),
                ("BVH6 plain s", &|p| format!("{:.4}", p.plain_bvh6)),
                ("obvhs CWBVH s", &|p| format!("{:.4}", p.obvhs_cwbvh)),
                ("run / obvhs", &|p| format!("{:.0}x", p.vs_obvhs())),
            ],
        )
    }

    pub fn work_table(&self) -> Table {
        let share = |w: &Work| 100.0 * w.rays_within_rb8 as f64 / w.rays.max(1) as f64;
        Table::of(
            &self.work,
            &[
                ("scene", &|w| w.scene.clone()),
                ("triangles", &|w| w.triangles.to_string()),
                ("rays", &|w| w.rays.to_string()),
                ("max depth", &|w| w.max_depth.to_string()),
                ("rays ≤ 8 deep", &|w| format!("{} ({:.1}%)", w.rays_within_rb8, share(w))),
                ("internal visits", &|w| w.internal.to_string()),
                ("leaf visits", &|w| w.leaf.to_string()),
                ("triangle visits", &|w| w.triangle.to_string()),
                ("procedural visits", &|w| w.procedural.to_string()),
            ],
        )
    }

    pub fn savings_table(&self) -> Table {
        Table::of(
            &self.savings,
            &[
                ("scene", &|s| s.scene.clone()),
                ("work skipped", &|s| s.what.clone()),
                ("doing it s", &|s| format!("{:.3}", s.with_work)),
                ("skipping s", &|s| format!("{:.3}", s.skipped)),
                ("saving", &|s| format!("{:.2}x", s.with_work / s.skipped)),
                ("result", &|s| s.note.clone()),
            ],
        )
    }
}
