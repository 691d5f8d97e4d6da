//! The analogues of the paper's figures, computed from a finished [`Sweep`]: each is a table
//! (Markdown and CSV), its numbers as JSON, and a chart.
//!
//! Performance is a whole-frame cycle count (SPEC section 8: the equivalent of IPC for a fixed
//! workload), so a configuration's speed-up on a scene is RB_8's cycles over its cycles, and
//! the figure over the scene set is the geometric mean of the per-scene speed-ups.

use serde_json::{json, Value};

use super::figure::Figure;
use super::plot::{family_shades, Bars, Chart, Line, Point};
use crate::error::{Error, Result};
use crate::report::cost::CostReport;
use crate::report::table::Table;
use crate::run::sim::Outcome;
use crate::run::sweep::{geomean, with_sms, Sweep, Variant, BASELINE};

/// Every figure, in report order; the RB-size and L1D sweeps only when the plan has them, the
/// restart figure only when restart designs ran.
pub fn all(s: &Sweep) -> Result<Vec<Figure>> {
    let mut all = vec![performance(s), offchip(s), bank_conflicts(s), skew(s)];
    if !s.plan.rb_sizes.is_empty() {
        all.push(rb_sweep(s));
    }
    if !s.plan.l1d_kb.is_empty() {
        all.push(l1d_sweep(s));
    }
    all.extend([depth(s), cost(s)?, super::breakdown::figure(s)]);
    if super::restart::applies(s) {
        all.push(super::restart::figure(s)?);
    }
    Ok(all)
}

fn f4(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v:.4}"))
}

impl Sweep {
    /// Configurations run on the base L1D size, in plan order.
    pub fn base_variants(&self) -> Vec<Variant> {
        self.variants.iter().copied().filter(|v| v.l1d_kb == self.base_kb()).collect()
    }

    /// RB_8's cycles (base L1D) over `config`'s on `scene`.
    pub fn speedup(&self, scene: &str, config: &str, l1d_kb: u32) -> Option<f64> {
        let base = self.cycles(scene, BASELINE, self.base_kb())? as f64;
        let c = self.cycles(scene, config, l1d_kb)? as f64;
        (c > 0.0).then(|| base / c)
    }

    /// Geometric mean of the speed-ups over the scene set.
    pub fn geomean_speedup(&self, config: &str, l1d_kb: u32) -> Option<f64> {
        let v: Option<Vec<f64>> =
            self.scenes.iter().map(|sc| self.speedup(&sc.name, config, l1d_kb)).collect();
        geomean(v?)
    }

    /// `f` summed over the scene set.
    pub fn sum(&self, config: &str, l1d_kb: u32, f: impl Fn(&Outcome) -> u64) -> Option<u64> {
        self.scenes.iter().map(|sc| self.run(&sc.name, config, l1d_kb).map(|r| f(&r.outcome))).sum()
    }

    fn scene_names(&self) -> Vec<String> {
        self.scenes.iter().map(|s| s.name.clone()).collect()
    }
}

/// Speed-ups over RB_8 per scene (rows: `configs` at `l1d_kb`, columns: scenes, then geomean).
fn speedup_table(s: &Sweep, configs: &[(String, u32)], label: &str) -> Table {
    let scenes = s.scene_names();
    let mut t =
        Table::new(std::iter::once(label.to_string()).chain(scenes.clone()).chain(["geomean".into()]));
    for (c, kb) in configs {
        let name = if *kb == s.base_kb() { c.clone() } else { format!("{c}@{kb}KB") };
        t.row(
            std::iter::once(name)
                .chain(scenes.iter().map(|sc| f4(s.speedup(sc, c, *kb))))
                .chain([f4(s.geomean_speedup(c, *kb))]),
        );
    }
    t
}

fn offchip_node(o: &Outcome) -> u64 {
    o.gpu.map_or(0, |g| g.offchip_node)
}

fn offchip_stack(o: &Outcome) -> u64 {
    o.gpu.map_or(0, |g| g.offchip_stack)
}

fn offchip_total(o: &Outcome) -> u64 {
    offchip_node(o) + offchip_stack(o)
}

/// A count of one run.
type Count = fn(&Outcome) -> u64;

fn global(o: &Outcome) -> u64 {
    o.stack.global_accesses()
}

fn dram_total(o: &Outcome) -> u64 {
    dram_node(o) + dram_stack(o)
}

/// Columns of the off-chip figure, whole scene set or one scene.
const OFFCHIP_COLUMNS: [&str; 9] = [
    "off-chip node",
    "off-chip stack",
    "off-chip total",
    "off-chip vs RB_8",
    "DRAM node",
    "DRAM stack",
    "DRAM total",
    "DRAM vs RB_8",
    "stack entries to/from global",
];

/// The [`OFFCHIP_COLUMNS`] of a set of runs: `sum(f)` is `f` summed over them, `base(f)` over
/// RB_8's runs of the same scenes.
fn offchip_cells(sum: &dyn Fn(Count) -> Option<u64>, base: &dyn Fn(Count) -> Option<u64>) -> Vec<String> {
    let cell = |v: Option<u64>| v.map_or(String::new(), |v| v.to_string());
    vec![
        cell(sum(offchip_node)),
        cell(sum(offchip_stack)),
        cell(sum(offchip_total)),
        f4(ratio(sum(offchip_total), base(offchip_total))),
        cell(sum(dram_node)),
        cell(sum(dram_stack)),
        cell(sum(dram_total)),
        f4(ratio(sum(dram_total), base(dram_total))),
        cell(sum(global)),
    ]
}

fn dram_node(o: &Outcome) -> u64 {
    o.gpu.map_or(0, |g| g.dram_node)
}

fn dram_stack(o: &Outcome) -> u64 {
    o.gpu.map_or(0, |g| g.dram_stack)
}

fn conflicts(o: &Outcome) -> u64 {
    o.gpu.map_or(0, |g| g.bank_conflict_cycles)
}

fn ratio(a: Option<u64>, b: Option<u64>) -> Option<f64> {
    let (a, b) = (a? as f64, b? as f64);
    (b > 0.0).then(|| a / b)
}

/// The family a configuration's bar belongs to in the performance figure: RB sizes (no SH
/// stack), SH sizes (SH stacks, no skew or reallocation), the SMS steps (skew, reallocation, and
/// SMS at other RB sizes), restart designs.
fn family(c: &rtl::config::Config) -> usize {
    if c.overflow == rtl::config::Overflow::Drop {
        return 3;
    }
    match (c.sh_entries, c.skew || c.realloc().is_some()) {
        (0, _) => 0,
        (_, false) => 1,
        (_, true) => 2,
    }
}

/// Figure 1: Performance normalised to RB_8, per scene and as the geometric mean.
pub fn performance(s: &Sweep) -> Figure {
    let kb = s.base_kb();
    let scenes = s.scene_names();
    let variants = s.base_variants();
    let configs: Vec<String> = variants.iter().map(|v| v.config.name()).collect();
    let mut table =
        Table::new(std::iter::once("config".to_string()).chain(scenes.clone()).chain(["geomean".into()]));
    let mut rows = Vec::new();
    let mut series = Vec::new();
    for c in &configs {
        let per: Vec<Option<f64>> = scenes.iter().map(|sc| s.speedup(sc, c, kb)).collect();
        let g = s.geomean_speedup(c, kb);
        table.row(std::iter::once(c.clone()).chain(per.iter().map(|&v| f4(v))).chain([f4(g)]));
        series.push(Bars { name: c.clone(), values: per.iter().copied().chain([g]).collect() });
        let per_scene: Vec<Value> =
            scenes.iter().zip(&per).map(|(sc, v)| json!({ "scene": sc, "speedup": v })).collect();
        rows.push(json!({ "config": c, "per_scene": per_scene, "geomean": g }));
    }
    // The bars of a family side by side (in plan order within it), a hue per family.
    let mut families: Vec<(usize, Bars)> = variants.iter().map(|v| family(&v.config)).zip(series).collect();
    families.sort_by_key(|f| f.0);
    let (families, series): (Vec<usize>, Vec<Bars>) = families.into_iter().unzip();
    Figure {
        name: "performance",
        title: format!("Performance normalised to {BASELINE} ({kb} KB L1D)"),
        note: format!(
            "Speed-up = {BASELINE}'s cycles / the configuration's cycles for the whole frame; the last column \
             is the geometric mean over the scenes."
        ),
        table,
        per_scene: None,
        json: json!({ "baseline": BASELINE, "l1d_kb": kb, "rows": rows }),
        chart: Chart::Grouped {
            y_desc: format!("speed-up over {BASELINE}"),
            groups: scenes.iter().cloned().chain(["geomean".into()]).collect(),
            series,
            colors: family_shades(&families),
            rule: Some(1.0),
            zoom: true,
        },
    }
}

/// Figure 2: Off-chip accesses as the paper counts them (requests leaving the SMs for L2, which
/// it counts as off-chip), split into node fetches and stack traffic, beside DRAM accesses and
/// the stack entries moved to or from global memory.
pub fn offchip(s: &Sweep) -> Figure {
    let kb = s.base_kb();
    let configs: Vec<String> = s.base_variants().iter().map(|v| v.config.name()).collect();
    let mut table = Table::new(std::iter::once("config").chain(OFFCHIP_COLUMNS));
    let mut per_scene_table = Table::new(["scene", "config"].into_iter().chain(OFFCHIP_COLUMNS));
    let mut rows = Vec::new();
    let (mut stacked, mut node_bars) = (Vec::new(), Vec::new());
    let base = |f: Count| s.sum(BASELINE, kb, f);
    for c in &configs {
        let sum = |f: Count| s.sum(c, kb, f);
        table.row(std::iter::once(c.clone()).chain(offchip_cells(&sum, &base)));
        stacked.push(ratio(sum(offchip_total), base(offchip_total)));
        node_bars.push(ratio(sum(offchip_node), base(offchip_total)));
        let per_scene: Vec<Value> = s
            .scenes
            .iter()
            .filter_map(|sc| s.run(&sc.name, c, kb))
            .map(|r| {
                json!({
                    "scene": r.scene,
                    "offchip_node": offchip_node(&r.outcome),
                    "offchip_stack": offchip_stack(&r.outcome),
                    "dram_node": dram_node(&r.outcome),
                    "dram_stack": dram_stack(&r.outcome),
                    "stack_global": r.outcome.stack.global_accesses(),
                })
            })
            .collect();
        rows.push(json!({
            "config": c, "offchip_node": sum(offchip_node), "offchip_stack": sum(offchip_stack),
            "dram_node": sum(dram_node), "dram_stack": sum(dram_stack),
            "stack_global": sum(global), "per_scene": per_scene,
        }));
    }
    for sc in &s.scenes {
        let one = |c: &str, f: Count| s.run(&sc.name, c, kb).map(|r| f(&r.outcome));
        for c in configs.iter().filter(|c| s.run(&sc.name, c, kb).is_some()) {
            let cells = offchip_cells(&|f| one(c, f), &|f| one(BASELINE, f));
            per_scene_table.row([sc.name.clone(), c.clone()].into_iter().chain(cells));
        }
    }
    Figure {
        name: "offchip",
        title: format!("Off-chip accesses ({kb} KB L1D, sums over the scenes)"),
        note: "Off-chip accesses as the paper counts them (L2 is off-chip): requests leaving the SMs for L2 \
               (L1D fills and write-through stores), split into node fetches and stack spills/reloads. \
               Beside them the DRAM accesses (with write-backs of spilled lines) and the stack entries moved \
               to or from global memory before any cache filters them. Ratios are sums over the scenes \
               relative to RB_8's; the per-scene table gives each scene's counts."
            .into(),
        table,
        per_scene: Some(per_scene_table),
        json: json!({ "baseline": BASELINE, "l1d_kb": kb, "rows": rows }),
        chart: Chart::HBars {
            x_desc: format!("off-chip (SM to L2) requests relative to {BASELINE}'s total"),
            labels: configs,
            bars: vec![
                Bars { name: "stack".into(), values: stacked },
                Bars { name: "node".into(), values: node_bars },
            ],
            dots: Vec::new(),
            rule: Some(1.0),
            zoom: false,
        },
    }
}

/// Figure 3: Delay cycles from shared-memory bank conflicts, with and without skewed access.
pub fn bank_conflicts(s: &Sweep) -> Figure {
    let kb = s.base_kb();
    let configs: Vec<String> =
        s.base_variants().iter().filter(|v| v.config.sh_entries > 0).map(|v| v.config.name()).collect();
    let mut table = Table::new(std::iter::once("scene".to_string()).chain(configs.clone()));
    for sc in &s.scenes {
        let cells = configs
            .iter()
            .map(|c| s.run(&sc.name, c, kb).map_or(String::new(), |r| conflicts(&r.outcome).to_string()));
        table.row(std::iter::once(sc.name.clone()).chain(cells));
    }
    let totals: Vec<Option<u64>> = configs.iter().map(|c| s.sum(c, kb, conflicts)).collect();
    table.row(
        std::iter::once("total".to_string())
            .chain(totals.iter().map(|t| t.map_or(String::new(), |t| t.to_string()))),
    );
    let (plain, skewed) = ("RB_8+SH_8", "RB_8+SH_8+SK");
    let note = match (s.sum(plain, kb, conflicts), s.sum(skewed, kb, conflicts)) {
        (Some(p), Some(k)) if p > 0 => format!(
            "Skewed access (SK) changes the delay cycles of {plain} from {p} to {k} ({:+.1} %) over the scene set.",
            (k as f64 / p as f64 - 1.0) * 100.0
        ),
        _ => "Delay cycles the bank arbiter adds when a warp's shared-memory accesses hit one bank.".into(),
    };
    let per: Vec<(usize, f64)> = configs
        .iter()
        .enumerate()
        .flat_map(|(i, c)| {
            s.scenes
                .iter()
                .filter_map(move |sc| s.run(&sc.name, c, kb))
                .map(move |r| (i, conflicts(&r.outcome) as f64))
        })
        .collect();
    let rows: Vec<Value> = configs
        .iter()
        .zip(&totals)
        .map(|(c, t)| {
            let per_scene: Vec<Value> = s
                .scenes
                .iter()
                .filter_map(|sc| s.run(&sc.name, c, kb))
                .map(|r| json!({ "scene": r.scene, "bank_conflict_cycles": conflicts(&r.outcome) }))
                .collect();
            json!({ "config": c, "total": t, "per_scene": per_scene })
        })
        .collect();
    Figure {
        name: "bank_conflicts",
        title: format!("Bank-conflict delay cycles ({kb} KB L1D)"),
        note: format!("{note} Only configurations with SH stacks use shared memory."),
        table,
        per_scene: None,
        json: json!({ "l1d_kb": kb, "rows": rows }),
        chart: Chart::HBars {
            x_desc: "bank-conflict delay cycles (bars: sum over scenes, dots: scenes)".into(),
            labels: configs,
            bars: vec![Bars {
                name: "total".into(),
                values: totals.iter().map(|t| t.map(|t| t as f64)).collect(),
            }],
            dots: per,
            rule: None,
            zoom: false,
        },
    }
}

/// Shared-memory accesses of a run: each RB→SH spill and global→SH refill is one SH store, each
/// SH→RB reload and SH→global spill one SH load (exact without reallocation, whose flushes move
/// whole stacks).
fn sh_accesses(o: &Outcome) -> u64 {
    let st = &o.stack;
    st.rb_to_sh + st.sh_to_rb + st.sh_to_global + st.global_to_sh
}

/// What decides whether skewed bank access can pay, per scene: how often the SH stacks are used
/// (SH accesses per SM-cycle), the share of SM-cycles with a bank conflict, with and without
/// skew, and skew's effect on the conflict cycles and on the speed-up over RB_8 (the table); the
/// chart and its title show the last of these alone.
pub fn skew(s: &Sweep) -> Figure {
    let kb = s.base_kb();
    let (plain, skewed) = ("RB_8+SH_8", "RB_8+SH_8+SK");
    let sms = f64::from(s.hw.mem.sms);
    let sm_cycles = |r: &crate::run::sweep::Run| r.outcome.gpu.map(|g| g.cycles as f64 * sms);
    let share = |r: Option<&crate::run::sweep::Run>| {
        let r = r?;
        let c = sm_cycles(r)?;
        (c > 0.0).then(|| conflicts(&r.outcome) as f64 / c * 100.0)
    };
    let mut table = Table::new([
        "scene",
        "SH accesses / SM-cycle",
        "conflict cycles % (SH_8)",
        "conflict cycles % (+SK)",
        "skew: conflict cycles Δ %",
        "skew: speed-up Δ PP",
    ]);
    let mut rows = Vec::new();
    let mut pp_bars = Vec::new();
    for sc in &s.scenes {
        let (p, k) = (s.run(&sc.name, plain, kb), s.run(&sc.name, skewed, kb));
        let rate = p.and_then(|r| Some(sh_accesses(&r.outcome) as f64 / sm_cycles(r)?));
        let (cp, ck) = (share(p), share(k));
        let dconf = match (p, k) {
            (Some(p), Some(k)) if conflicts(&p.outcome) > 0 => {
                Some((conflicts(&k.outcome) as f64 / conflicts(&p.outcome) as f64 - 1.0) * 100.0)
            }
            _ => None,
        };
        let dpp = match (s.speedup(&sc.name, skewed, kb), s.speedup(&sc.name, plain, kb)) {
            (Some(k), Some(p)) => Some((k - p) * 100.0),
            _ => None,
        };
        let f = |v: Option<f64>, d: usize| v.map_or(String::new(), |v| format!("{v:.d$}"));
        table.row([sc.name.clone(), f(rate, 4), f(cp, 3), f(ck, 3), f(dconf, 1), f(dpp, 2)]);
        rows.push(json!({
            "scene": sc.name, "sh_accesses_per_sm_cycle": rate, "conflict_cycle_share_pct": cp,
            "conflict_cycle_share_pct_skewed": ck, "skew_conflict_cycles_delta_pct": dconf,
            "skew_speedup_delta_pp": dpp,
        }));
        pp_bars.push(dpp);
    }
    let geo = match (s.geomean_speedup(skewed, kb), s.geomean_speedup(plain, kb)) {
        (Some(k), Some(p)) => Some((k - p) * 100.0),
        _ => None,
    };
    let note = match geo {
        Some(g) => format!(
            "Skew ({skewed} against {plain}) moves the geomean speed-up over RB_8 by {g:+.2} PP. An SM-cycle is one \
             cycle of one SM; a conflict cycle is one in which the bank arbiter serves a word late."
        ),
        None => format!("Needs {plain} and {skewed} in the sweep's plan."),
    };
    Figure {
        name: "skew",
        title: format!("Skew's effect on the speed-up over {BASELINE}, per scene ({kb} KB L1D)"),
        note,
        table,
        per_scene: None,
        json: json!({ "l1d_kb": kb, "geomean_skew_speedup_delta_pp": geo, "per_scene": rows }),
        chart: Chart::HBars {
            x_desc: format!("{skewed} minus {plain}: speed-up over {BASELINE} (percentage points)"),
            labels: s.scene_names(),
            bars: vec![Bars { name: "skew's effect".into(), values: pp_bars }],
            dots: Vec::new(),
            rule: Some(0.0),
            zoom: false,
        },
    }
}

/// Figure 4: The RB-size sweep, with and without SMS.
pub fn rb_sweep(s: &Sweep) -> Figure {
    let kb = s.base_kb();
    let mut table = Table::new([
        "N",
        "RB_N speed-up",
        "RB_N+SMS speed-up",
        "RB_N global entries",
        "RB_N+SMS global entries",
        "RB_N DRAM stack",
        "RB_N+SMS DRAM stack",
    ]);
    let (mut plain, mut sms, mut rows) = (Vec::new(), Vec::new(), Vec::new());
    for &n in &s.plan.rb_sizes {
        let (a, b) = (format!("RB_{n}"), with_sms(n));
        let (ga, gb) = (s.geomean_speedup(&a, kb), s.geomean_speedup(&b, kb));
        let cell = |v: Option<u64>| v.map_or(String::new(), |v| v.to_string());
        let glob = |c: &str| s.sum(c, kb, |o| o.stack.global_accesses());
        let dram = |c: &str| s.sum(c, kb, dram_stack);
        table.row([
            n.to_string(),
            f4(ga),
            f4(gb),
            cell(glob(&a)),
            cell(glob(&b)),
            cell(dram(&a)),
            cell(dram(&b)),
        ]);
        plain.extend(ga.map(|g| (n as f64, g)));
        sms.extend(gb.map(|g| (n as f64, g)));
        rows.push(json!({
            "n": n,
            "rb": { "config": a, "speedup": ga, "stack_global": glob(&a), "dram_stack": dram(&a) },
            "sms": { "config": b, "speedup": gb, "stack_global": glob(&b), "dram_stack": dram(&b) },
        }));
    }
    Figure {
        name: "rb_sweep",
        title: format!("RB size sweep with and without SMS ({kb} KB L1D)"),
        note: format!(
            "RB_N alone and RB_N{} (SMS); speed-ups are geometric means over the scenes relative to {BASELINE}; \
             entry and DRAM counts are sums.",
            crate::run::sweep::SMS_SUFFIX
        ),
        table,
        json: json!({ "baseline": BASELINE, "l1d_kb": kb, "rows": rows }),
        chart: Chart::Lines {
            x_desc: "RB entries per thread (N)".into(),
            y_desc: format!("speed-up over {BASELINE} (geomean)"),
            log2_x: true,
            zoom: true,
            series: vec![Line { name: "RB_N".into(), points: plain }, Line { name: "RB_N+SMS".into(), points: sms }],
        },
        per_scene: {
            let configs: Vec<(String, u32)> =
                s.plan.rb_sizes.iter().flat_map(|&n| [(format!("RB_{n}"), kb), (with_sms(n), kb)]).collect();
            Some(speedup_table(s, &configs, "config"))
        },
    }
}

/// Figure 5: The L1D-size sweep for RB_8 and SMS.
pub fn l1d_sweep(s: &Sweep) -> Figure {
    let sms_name = with_sms(8);
    let mut table = Table::new([
        "unified KB",
        "RB_8 speed-up",
        "SMS speed-up",
        "SMS over RB_8",
        "RB_8 L1D hit rate",
        "SMS L1D hit rate",
        "SMS L1D KB",
    ]);
    let mean_hit = |c: &str, kb: u32| {
        let rates: Option<Vec<f64>> = s
            .scenes
            .iter()
            .map(|sc| s.run(&sc.name, c, kb).and_then(|r| r.outcome.gpu).map(|g| g.l1d_hit_rate))
            .collect();
        rates.filter(|r| !r.is_empty()).map(|r| r.iter().sum::<f64>() / r.len() as f64)
    };
    let sms_cfg = sms_name.parse().ok();
    let (mut plain, mut sms, mut rows) = (Vec::new(), Vec::new(), Vec::new());
    for &kb in &s.plan.l1d_kb {
        let (ga, gb) = (s.geomean_speedup(BASELINE, kb), s.geomean_speedup(&sms_name, kb));
        let over = match (ga, gb) {
            (Some(a), Some(b)) => Some(b / a),
            _ => None,
        };
        let array = rtl::mem::MemParams { l1d_bytes: kb * 1024, ..rtl::mem::MemParams::default() };
        let sms_l1d = sms_cfg.map(|c| f64::from(rtl::gpu::carve_out(&c, array).l1d_bytes) / 1024.0);
        let (ha, hb) = (mean_hit(BASELINE, kb), mean_hit(&sms_name, kb));
        table.row([
            kb.to_string(),
            f4(ga),
            f4(gb),
            f4(over),
            f4(ha),
            f4(hb),
            sms_l1d.map_or(String::new(), |v| v.to_string()),
        ]);
        plain.extend(ga.map(|g| (kb as f64, g)));
        sms.extend(gb.map(|g| (kb as f64, g)));
        rows.push(json!({
            "unified_kb": kb,
            "rb_8": { "speedup": ga, "l1d_hit_rate": ha },
            "sms": { "config": sms_name, "speedup": gb, "l1d_hit_rate": hb, "l1d_kb": sms_l1d },
        }));
    }
    Figure {
        name: "l1d_sweep",
        title: "L1D size sweep: RB_8 and SMS".into(),
        note: format!(
            "The unified L1D/shared array per SM; SMS's SH stacks are carved out of it and the rest is L1D. \
             Speed-ups are geometric means over the scenes relative to {BASELINE} on {} KB; hit rates are \
             means over the scenes.",
            s.base_kb()
        ),
        table,
        json: json!({ "baseline": BASELINE, "base_kb": s.base_kb(), "rows": rows }),
        chart: Chart::Lines {
            x_desc: "unified L1D/shared array per SM (KB)".into(),
            y_desc: format!("speed-up over {BASELINE} at {} KB (geomean)", s.base_kb()),
            log2_x: true,
            zoom: true,
            series: vec![
                Line { name: BASELINE.into(), points: plain },
                Line { name: sms_name.clone(), points: sms },
            ],
        },
        per_scene: {
            let configs: Vec<(String, u32)> = s
                .plan
                .l1d_kb
                .iter()
                .flat_map(|&kb| [(BASELINE.to_string(), kb), (sms_name.clone(), kb)])
                .collect();
            Some(speedup_table(s, &configs, "config@unified KB"))
        },
    }
}

/// Share of pushes and pops deeper than `n` entries.
fn deeper_than(counts: &[u64], n: usize) -> f64 {
    let total: u64 = counts.iter().sum();
    let deep: u64 = counts.iter().skip(n + 1).sum();
    if total == 0 {
        0.0
    } else {
        deep as f64 / total as f64
    }
}

/// Figure 6: The stack-depth distribution per scene.
pub fn depth(s: &Sweep) -> Figure {
    let mut table =
        Table::new(["scene", "triangles", "rays", "pushes+pops", "max", "mean", "median", "deeper than 8"]);
    let mut series = Vec::new();
    for sc in &s.scenes {
        let d = &sc.depth;
        let total = d.pushes_and_pops.max(1) as f64;
        table.row([
            sc.name.clone(),
            sc.triangles.to_string(),
            sc.rays.to_string(),
            d.pushes_and_pops.to_string(),
            d.max.to_string(),
            format!("{:.3}", d.mean),
            d.median.to_string(),
            format!("{:.4}", deeper_than(&d.histogram.counts, 8)),
        ]);
        let points = d
            .histogram
            .counts
            .iter()
            .enumerate()
            .skip(1)
            .map(|(k, &c)| (k as f64, c as f64 / total))
            .collect();
        series.push(Line { name: sc.name.clone(), points });
    }
    let reports: Vec<Value> = s.scenes.iter().map(|sc| json!(sc.depth)).collect();
    Figure {
        name: "depth",
        title: "Stack depth per scene".into(),
        note: "Depth of a push = stack size after it, of a pop = size before it, over every push and pop of \
               every ray; 'deeper than 8' is the share beyond what RB_8 holds. Per-scene histograms: depth/*.svg."
            .into(),
        table,
        per_scene: None,
        json: json!({ "scenes": reports }),
        chart: Chart::Lines {
            x_desc: "stack depth at push/pop".into(),
            y_desc: "fraction of pushes and pops".into(),
            log2_x: false,
            zoom: false,
            series,
        },
    }
}

/// Which points are Pareto-optimal when a lower cost and a higher performance are better:
/// `(cost, performance)` is dominated when another point costs no more and performs no worse,
/// and is strictly better in one of the two. Equal points do not dominate each other.
pub fn pareto_optimal(points: &[(f64, f64)]) -> Vec<bool> {
    points
        .iter()
        .map(|&(c, p)| !points.iter().any(|&(c2, p2)| c2 <= c && p2 >= p && (c2 < c || p2 > p)))
        .collect()
}

/// Stack storage in the RT unit per SM (RB entries and every stack register), without the SH
/// array, which comes out of the unified L1D.
fn register_bytes(r: &CostReport) -> i64 {
    (r.on_chip_bytes_per_sm() - r.sh_bytes) as i64
}

/// Figure 7: Cost versus performance: bytes added per SM against the speed-up over RB_8.
pub fn cost(s: &Sweep) -> Result<Figure> {
    let kb = s.base_kb();
    let full_depth = s.scenes.iter().map(|sc| sc.depth.max).max().unwrap_or(0).max(1);
    let sms = s.hw.mem.sms;
    let report = |cfg: &rtl::config::Config| {
        CostReport::new(cfg, sms, full_depth).map_err(|e| Error::Invalid(format!("{}: {e}", cfg.name())))
    };
    let base = report(&BASELINE.parse().map_err(|e| Error::Invalid(format!("{BASELINE}: {e}")))?)?;
    let mut designs = Vec::new();
    for v in s.base_variants() {
        let r = report(&v.config)?;
        let name = v.config.name();
        if let Some(g) = s.geomean_speedup(&name, kb) {
            designs.push((name, r, g));
        }
    }
    let points: Vec<(f64, f64)> =
        designs.iter().map(|(_, r, g)| ((register_bytes(r) - register_bytes(&base)) as f64, *g)).collect();
    let optimal = pareto_optimal(&points);
    let mut table = Table::new([
        "config",
        "bytes added/SM vs RB_8",
        "stack fields bytes/SM",
        "SH bytes/SM (from L1D)",
        "speed-up (geomean)",
        "Pareto-optimal",
    ]);
    let mut rows = Vec::new();
    let mut plotted = Vec::new();
    for (((name, r, g), &(added, _)), &opt) in designs.iter().zip(&points).zip(&optimal) {
        table.row([
            name.clone(),
            format!("{added}"),
            r.added_bytes_per_sm().to_string(),
            r.sh_bytes.to_string(),
            format!("{g:.4}"),
            if opt { "yes" } else { "no" }.to_string(),
        ]);
        rows.push(json!({
            "config": name, "added_bytes_per_sm": added, "field_bytes_per_sm": r.added_bytes_per_sm(),
            "sh_bytes_per_sm": r.sh_bytes, "speedup": g, "pareto_optimal": opt,
        }));
        plotted.push(Point { name: name.clone(), x: added, y: *g, highlight: opt });
    }
    Ok(Figure {
        name: "cost",
        title: format!("Cost versus performance ({kb} KB L1D)"),
        note: format!(
            "Bytes added per SM = the RT unit's stack storage (RB entries plus every stack register, widths \
             from tb::cost, the RTL's definitions) minus {BASELINE}'s; negative for smaller RBs. The SH \
             stacks' shared memory is carved out of the unified L1D and listed separately; 'stack fields' \
             are the registers the design adds over its own short stack. RB_FULL is sized to the deepest \
             stack of the scene set ({full_depth}). Pareto-optimal: no other design is at least as cheap \
             and as fast and strictly better in one."
        ),
        table,
        per_scene: Some(speedup_table(
            s,
            &designs.iter().map(|(name, _, _)| (name.clone(), kb)).collect::<Vec<_>>(),
            "config",
        )),
        json: json!({ "baseline": BASELINE, "l1d_kb": kb, "full_depth": full_depth, "rows": rows }),
        chart: Chart::Scatter {
            x_desc: format!("bytes added per SM over {BASELINE}"),
            y_desc: format!("speed-up over {BASELINE} (geomean)"),
            points: plotted,
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_marks_exactly_the_undominated_points() {
        // (cost, performance)
        let points = [
            (0.0, 1.0),  // cheapest: optimal
            (10.0, 1.5), // optimal
            (10.0, 1.2), // same cost, slower than the one above: dominated
            (20.0, 1.5), // dearer, no faster than (10, 1.5): dominated
            (30.0, 2.0), // fastest: optimal
            (-5.0, 0.8), // cheaper than everything: optimal
            (5.0, 0.9),  // dearer and slower than (0, 1): dominated
            (30.0, 2.0), // equal to another point: neither dominates
        ];
        assert_eq!(pareto_optimal(&points), [true, true, false, false, true, true, false, true]);
        assert_eq!(pareto_optimal(&[]), Vec::<bool>::new());
        assert_eq!(pareto_optimal(&[(1.0, 1.0)]), [true]);
    }

    #[test]
    fn share_deeper_than_counts_only_deeper_entries() {
        // depths 1, 2, 9, 10 with counts 1, 1, 1, 1
        let counts = [0, 1, 1, 0, 0, 0, 0, 0, 0, 1, 1];
        assert_eq!(deeper_than(&counts, 8), 0.5);
        assert_eq!(deeper_than(&[], 8), 0.0);
    }
}
