//! The ablation's table, per-scene table, JSON and chart ([`Ablation::figure`]): the arms
//! [`crate::run::ablate`] ran, as one figure of the report.

use serde_json::{json, Value};

use super::figure::Figure;
use super::plot::{Bars, Chart};
use crate::report::table::Table;
use crate::run::ablate::{Ablation, HEADLINE};
use crate::run::sweep::{Sweep, BASELINE};

fn f4(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v:.4}"))
}

/// The change from the reference, signed.
fn delta(v: Option<f64>, reference: Option<f64>) -> String {
    match (v, reference) {
        (Some(v), Some(r)) => format!("{:+.4}", v - r),
        _ => String::new(),
    }
}

impl Ablation {
    /// (row name, sweep) for the reference and every arm.
    fn rows(&self) -> Vec<(String, &Sweep)> {
        std::iter::once(("all on".to_string(), &self.reference))
            .chain(self.arms.iter().map(|(m, s)| (format!("{} off", m.name), s)))
            .collect()
    }

    /// The ablation table (geomeans), its per-scene table, JSON and chart, as one figure.
    pub fn figure(&self) -> Figure {
        let kb = self.reference.base_kb();
        let mut table = Table::new(
            std::iter::once("mechanism".to_string())
                .chain(HEADLINE.iter().flat_map(|(_, short)| [short.to_string(), format!("{short} Δ")])),
        );
        let mut per_scene = Table::new(
            ["mechanism".to_string(), "scene".to_string()]
                .into_iter()
                .chain(HEADLINE.iter().flat_map(|(_, short)| [short.to_string(), format!("{short} Δ")])),
        );
        let mut rows_json = Vec::new();
        let rows = self.rows();
        for (name, s) in &rows {
            let arm_kb = s.base_kb();
            let geo: Vec<Option<f64>> = HEADLINE.iter().map(|(c, _)| s.geomean_speedup(c, arm_kb)).collect();
            let refs: Vec<Option<f64>> =
                HEADLINE.iter().map(|(c, _)| self.reference.geomean_speedup(c, kb)).collect();
            table.row(
                std::iter::once(name.clone())
                    .chain(geo.iter().zip(&refs).flat_map(|(&g, &r)| [f4(g), delta(g, r)])),
            );
            let mut scenes_json = Vec::new();
            for sc in &s.scenes {
                let v: Vec<Option<f64>> =
                    HEADLINE.iter().map(|(c, _)| s.speedup(&sc.name, c, arm_kb)).collect();
                let r: Vec<Option<f64>> =
                    HEADLINE.iter().map(|(c, _)| self.reference.speedup(&sc.name, c, kb)).collect();
                per_scene.row(
                    [name.clone(), sc.name.clone()]
                        .into_iter()
                        .chain(v.iter().zip(&r).flat_map(|(&x, &y)| [f4(x), delta(x, y)])),
                );
                let cells: Vec<Value> =
                    HEADLINE.iter().zip(&v).map(|((c, _), x)| json!({ "config": c, "speedup": x })).collect();
                scenes_json.push(json!({ "scene": sc.name, "speedups": cells }));
            }
            let cells: Vec<Value> =
                HEADLINE.iter().zip(&geo).map(|((c, _), g)| json!({ "config": c, "geomean": g })).collect();
            rows_json.push(json!({ "arm": name, "geomean": cells, "per_scene": scenes_json }));
        }
        // Chart: one row per (configuration, arm), grouped by configuration; one colour per arm.
        let mut labels = Vec::new();
        let mut bars: Vec<Bars> =
            rows.iter().map(|(name, _)| Bars { name: name.clone(), values: Vec::new() }).collect();
        for (c, short) in HEADLINE {
            for (a, (name, s)) in rows.iter().enumerate() {
                labels.push(format!("{short} · {}", name.trim_end_matches(" off")));
                for (b, set) in bars.iter_mut().enumerate() {
                    set.values.push(if a == b { s.geomean_speedup(c, s.base_kb()) } else { None });
                }
            }
        }
        let mechanisms: Vec<Value> = self
            .arms
            .iter()
            .map(|(m, _)| json!({ "name": m.name, "what": m.what, "off_means": m.off_means }))
            .collect();
        let list: String = self
            .arms
            .iter()
            .map(|(m, _)| format!("\n- **{}**: {}. Off: {}.", m.name, m.what, m.off_means))
            .collect();
        Figure {
            name: "ablation",
            title: format!("Headline speed-ups over {BASELINE} with one mechanism off ({kb} KB L1D)"),
            note: format!(
                "Each row turns one simulator mechanism off, everything else as in the reference ('all on'); \
                 cells are geometric means over the scenes of {BASELINE}'s whole-frame cycles over the \
                 configuration's, Δ the change from the reference. A conclusion that holds in every row does not \
                 rest on any of these mechanisms.{list}"
            ),
            table,
            per_scene: Some(per_scene),
            json: json!({ "baseline": BASELINE, "l1d_kb": kb, "mechanisms": mechanisms, "rows": rows_json }),
            chart: Chart::HBars {
                x_desc: format!("speed-up over {BASELINE} (geomean over scenes)"),
                labels,
                bars,
                dots: Vec::new(),
                rule: Some(1.0),
                zoom: true,
            },
        }
    }
}
