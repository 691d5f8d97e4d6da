//! The restart figure of a sweep that runs restart designs (`+RT`, `sms sweep --designs
//! restart`): what a stack that drops and restarts buys and what its re-walks cost, beside the
//! spilling designs of the same run.
//!
//! A restart design trades spills for re-walks: an entry it drops is never written anywhere,
//! and the ray that needs it walks again from the root along its trail, fetching the nodes on
//! the way through the memory system. So the figure sets the speed-up beside node fetches per
//! ray (the re-walks' cost), off-chip and DRAM accesses per ray (spills and re-fetches alike),
//! restarts and drops per ray, and the on-chip bytes per SM each design holds.
//!
//! Per-ray values over the scene set are totals over totals (every ray of every scene weighs
//! alike); the ratios to RB_8 and the speed-up are geometric means of the per-scene ratios (every
//! scene weighs alike), as the paper's figures are.

use serde_json::json;

use super::figure::Figure;
use super::plot::{family_shades, Bars, Chart};
use crate::error::{Error, Result};
use crate::report::cost::CostReport;
use crate::report::table::Table;
use crate::run::sim::Outcome;
use crate::run::sweep::{geomean, Sweep, BASELINE};
use rtl::config::{Config, Overflow};

/// Whether `s` ran a restart design (and so has the restart figure).
pub fn applies(s: &Sweep) -> bool {
    s.base_variants().iter().any(|v| v.config.overflow == Overflow::Drop)
}

/// What one run's per-ray columns count.
struct PerRay {
    rays: u64,
    node_fetches: u64,
    offchip: u64,
    dram: u64,
    restarts: u64,
    drops: u64,
}

impl PerRay {
    fn of(o: &Outcome) -> Option<PerRay> {
        let g = o.gpu?;
        Some(PerRay {
            rays: g.rays,
            node_fetches: g.node_fetches,
            offchip: g.offchip_node + g.offchip_stack,
            dram: g.dram_node + g.dram_stack,
            restarts: o.stack.restarts,
            drops: o.stack.drops,
        })
    }

    fn add(&mut self, o: &PerRay) {
        self.rays += o.rays;
        self.node_fetches += o.node_fetches;
        self.offchip += o.offchip;
        self.dram += o.dram;
        self.restarts += o.restarts;
        self.drops += o.drops;
    }

    fn per_ray(&self, count: u64) -> Option<f64> {
        (self.rays > 0).then(|| count as f64 / self.rays as f64)
    }

    /// Node fetches, off-chip, DRAM, restarts and drops per ray.
    fn cells(&self) -> [Option<f64>; 5] {
        [self.node_fetches, self.offchip, self.dram, self.restarts, self.drops].map(|c| self.per_ray(c))
    }
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or(String::new(), |v| format!("{v:.digits$}"))
}

/// The figure: one row per configuration over the scene set, one per scene and configuration,
/// and node fetches per ray relative to RB_8 charted per scene.
pub fn figure(s: &Sweep) -> Result<Figure> {
    let kb = s.base_kb();
    let full_depth = s.scenes.iter().map(|sc| sc.depth.max).max().unwrap_or(0).max(1);
    let configs: Vec<Config> = s.base_variants().iter().map(|v| v.config).collect();
    let scenes: Vec<String> = s.scenes.iter().map(|sc| sc.name.clone()).collect();
    let per_ray = |scene: &str, c: &str| s.run(scene, c, kb).and_then(|r| PerRay::of(&r.outcome));
    // A configuration's node fetches per ray over RB_8's, on one scene.
    let fetch_ratio = |scene: &str, c: &str| {
        let (a, b) = (per_ray(scene, c)?, per_ray(scene, BASELINE)?);
        let (a, b) = (a.per_ray(a.node_fetches)?, b.per_ray(b.node_fetches)?);
        (b > 0.0).then(|| a / b)
    };
    let columns = [
        "on-chip bytes/SM",
        "speed-up (geomean)",
        "node fetches/ray",
        "node fetches vs RB_8 (geomean)",
        "off-chip/ray",
        "DRAM/ray",
        "restarts/ray",
        "drops/ray",
    ];
    let mut table = Table::new(std::iter::once("config").chain(columns));
    let mut per_scene = Table::new(
        [
            "scene",
            "config",
            "speed-up",
            "node fetches/ray",
            "off-chip/ray",
            "DRAM/ray",
            "restarts/ray",
            "drops/ray",
        ]
        .into_iter(),
    );
    let mut rows = Vec::new();
    let mut series = Vec::new();
    for cfg in &configs {
        let name = cfg.name();
        let bytes = CostReport::new(cfg, s.hw.mem.sms, full_depth)
            .map_err(|e| Error::Invalid(format!("{name}: {e}")))?
            .on_chip_bytes_per_sm();
        let mut total = PerRay { rays: 0, node_fetches: 0, offchip: 0, dram: 0, restarts: 0, drops: 0 };
        let mut scene_rows = Vec::new();
        for sc in &scenes {
            let Some(p) = per_ray(sc, &name) else { continue };
            total.add(&p);
            let speedup = s.speedup(sc, &name, kb);
            let [fetches, offchip, dram, restarts, drops] = p.cells();
            per_scene.row([
                sc.clone(),
                name.clone(),
                cell(speedup, 4),
                cell(fetches, 3),
                cell(offchip, 3),
                cell(dram, 3),
                cell(restarts, 4),
                cell(drops, 4),
            ]);
            scene_rows.push(json!({
                "scene": sc, "speedup": speedup, "node_fetches_per_ray": fetches, "offchip_per_ray": offchip,
                "dram_per_ray": dram, "restarts_per_ray": restarts, "drops_per_ray": drops,
                "node_fetches_vs_baseline": fetch_ratio(sc, &name),
            }));
        }
        let speedup = s.geomean_speedup(&name, kb);
        let ratios: Option<Vec<f64>> = scenes.iter().map(|sc| fetch_ratio(sc, &name)).collect();
        let fetch_vs = ratios.clone().and_then(geomean);
        let [fetches, offchip, dram, restarts, drops] = total.cells();
        table.row([
            name.clone(),
            bytes.to_string(),
            cell(speedup, 4),
            cell(fetches, 3),
            cell(fetch_vs, 4),
            cell(offchip, 3),
            cell(dram, 3),
            cell(restarts, 4),
            cell(drops, 4),
        ]);
        rows.push(json!({
            "config": name, "restart": cfg.overflow == Overflow::Drop, "on_chip_bytes_per_sm": bytes,
            "speedup": speedup, "node_fetches_per_ray": fetches, "node_fetches_vs_baseline": fetch_vs,
            "offchip_per_ray": offchip, "dram_per_ray": dram, "restarts_per_ray": restarts,
            "drops_per_ray": drops, "per_scene": scene_rows,
        }));
        let values = scenes.iter().map(|sc| fetch_ratio(sc, &name)).chain([fetch_vs]).collect();
        series.push(Bars { name, values });
    }
    // Spilling designs in one hue, restart designs in another.
    let families: Vec<usize> = configs.iter().map(|c| usize::from(c.overflow == Overflow::Drop)).collect();
    Ok(Figure {
        name: "restart",
        title: format!("Restart designs beside spilling ones ({kb} KB L1D)"),
        note: format!(
            "A restart design (+RT) drops its oldest entry when full and walks again from the root when it \
             pops an empty stack that dropped something; the re-walk's nodes are fetched again. On-chip \
             bytes/SM: RB entries, every stack register (a restart design's trail included) and the SH \
             array. Per-ray values over the scene set are totals over all rays; the speed-up over \
             {BASELINE} and the node fetches relative to {BASELINE}'s are geometric means over the scenes. \
             The chart: node fetches per ray relative to {BASELINE}'s, per scene."
        ),
        table,
        per_scene: Some(per_scene),
        json: json!({ "baseline": BASELINE, "l1d_kb": kb, "full_depth": full_depth, "rows": rows }),
        chart: Chart::Grouped {
            y_desc: format!("node fetches per ray / {BASELINE}'s"),
            groups: scenes.iter().cloned().chain(["geomean".into()]).collect(),
            series,
            colors: family_shades(&families),
            rule: Some(1.0),
            zoom: true,
        },
    })
}
