//! Where the RT units' thread-cycles go ([`rtl::thread_cycles`]): the shares `sms run` prints and
//! the sweep's stacked-bar figure, one bar per configuration whose length is its thread-cycles
//! relative to RB_8's (run time relative to RB_8: every configuration has the same thread slots)
//! and whose segments are the categories.

use rtl::thread_cycles::ThreadCycles;
use serde::Serialize;
use serde_json::{json, Value};

use super::figure::Figure;
use plotters::style::RGBColor;

use super::plot::{color, Bars, Chart};
use super::table::Table;
use crate::run::sim::Outcome;
use crate::run::sweep::{Sweep, BASELINE};

/// How the reports name the categories, in [`ThreadCycles::NAMES`] order.
pub const LABELS: [&str; 5] = ["node data", "fetch queue", "stack", "latency", "idle"];

/// The categories' colours, from the axis out: Okabe and Ito's blue, darkened yellow,
/// vermillion and bluish green, idle in light grey (neighbours differ in hue and lightness).
fn colors() -> [RGBColor; 5] {
    [color(0), color(6), color(3), color(2), RGBColor(200, 200, 200)]
}

/// Each category's share of the thread-cycles ([`ThreadCycles`]' fields; `sms run`'s JSON).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Shares {
    pub node_data: f64,
    pub fetch_queue: f64,
    pub stack: f64,
    pub latency: f64,
    pub idle: f64,
}

impl Shares {
    /// The shares of `t`; `None` for no thread-cycles at all.
    pub fn of(t: &ThreadCycles) -> Option<Shares> {
        let total = t.total();
        let [node_data, fetch_queue, stack, latency, idle] = t.values().map(|v| v as f64 / total as f64);
        (total > 0).then_some(Shares { node_data, fetch_queue, stack, latency, idle })
    }

    /// In [`LABELS`] order.
    pub fn values(&self) -> [f64; 5] {
        [self.node_data, self.fetch_queue, self.stack, self.latency, self.idle]
    }
}

/// The breakdown of a cycle-level outcome (`None` at the functional level).
pub fn of(o: &Outcome) -> Option<ThreadCycles> {
    o.gpu.map(|g| g.thread_cycles())
}

/// The counts as an object by category.
pub fn counts_json(t: &ThreadCycles) -> Value {
    ThreadCycles::NAMES.iter().zip(t.values()).map(|(n, v)| (n.to_string(), json!(v))).collect()
}

fn f4(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v:.4}"))
}

/// The figure: per configuration (base L1D) the categories summed over the scenes, in units of
/// RB_8's total thread-cycles over the same scenes; the per-scene table has each run's counts
/// and shares.
pub fn figure(s: &Sweep) -> Figure {
    let kb = s.base_kb();
    let configs: Vec<String> = s.base_variants().iter().map(|v| v.config.name()).collect();
    let summed = |c: &str| -> Option<ThreadCycles> {
        let mut t = ThreadCycles::default();
        for sc in &s.scenes {
            t.add(&of(&s.run(&sc.name, c, kb)?.outcome)?);
        }
        Some(t)
    };
    let base = summed(BASELINE).map(|t| t.total()).filter(|&t| t > 0);
    let headers = std::iter::once("config").chain(LABELS).chain(["total"]);
    let mut table = Table::new(headers);
    let per_scene_headers = ["scene", "config"]
        .into_iter()
        .map(String::from)
        .chain(ThreadCycles::NAMES.iter().map(|n| format!("{n} thread-cycles")))
        .chain(ThreadCycles::NAMES.iter().map(|n| format!("{n} share")));
    let mut per_scene = Table::new(per_scene_headers);
    let mut segments: Vec<Vec<Option<f64>>> = vec![Vec::new(); LABELS.len()];
    let mut rows = Vec::new();
    for c in &configs {
        let t = summed(c);
        let rel = |v: u64| base.map(|b| v as f64 / b as f64);
        let cells: Vec<Option<f64>> = match t {
            Some(t) => t.values().iter().map(|&v| rel(v)).collect(),
            None => vec![None; LABELS.len()],
        };
        table.row(
            std::iter::once(c.clone())
                .chain(cells.iter().map(|&v| f4(v)))
                .chain([f4(t.and_then(|t| rel(t.total())))]),
        );
        for (seg, v) in segments.iter_mut().zip(&cells) {
            seg.push(*v);
        }
        let mut scenes = Vec::new();
        for sc in &s.scenes {
            let Some(t) = s.run(&sc.name, c, kb).and_then(|r| of(&r.outcome)) else { continue };
            let shares = Shares::of(&t).map(|x| x.values());
            per_scene.row(
                [sc.name.clone(), c.clone()]
                    .into_iter()
                    .chain(t.values().iter().map(|v| v.to_string()))
                    .chain((0..LABELS.len()).map(|i| f4(shares.map(|x| x[i])))),
            );
            scenes.push(
                json!({ "scene": sc.name, "thread_cycles": counts_json(&t), "shares": Shares::of(&t) }),
            );
        }
        rows.push(json!({
            "config": c,
            "thread_cycles": t.as_ref().map(counts_json),
            "relative_to_baseline": cells,
            "shares": t.as_ref().and_then(Shares::of),
            "per_scene": scenes,
        }));
    }
    Figure {
        name: "thread_cycles",
        title: format!("Where the RT units' thread-cycles go ({kb} KB L1D, sums over the scenes)"),
        note: format!(
            "Every thread slot of every RT unit (warp-buffer slots × warp size) in every cycle, in one \
             category: node data (waiting for its node's sectors), fetch queue (waiting to fetch and \
             allowed to: for the scheduler or the memory port), stack (a stack command waiting for its \
             sequencer, or a fetch the busy sequencer holds back), latency (in an operation unit) and \
             idle (empty slot, inactive or finished lane). Sums over the scenes in units of {BASELINE}'s \
             total thread-cycles, so a bar's length is the run time relative to {BASELINE}'s. The \
             per-scene table has each run's counts and shares. None at the functional level."
        ),
        table,
        per_scene: Some(per_scene),
        json: json!({ "baseline": BASELINE, "l1d_kb": kb, "categories": ThreadCycles::NAMES, "rows": rows }),
        chart: Chart::Stacked {
            x_desc: format!("thread-cycles relative to {BASELINE}'s total"),
            labels: configs,
            segments: LABELS
                .iter()
                .zip(segments)
                .map(|(name, values)| Bars { name: name.to_string(), values })
                .collect(),
            colors: colors().to_vec(),
            rule: Some(1.0),
        },
    }
}
