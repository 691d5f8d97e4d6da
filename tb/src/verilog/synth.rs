//! Synthesis of the generated Verilog with yosys's generic, technology-independent flow, and
//! the cross-check of its flip-flops against the bit accounting of `sms cost`.
//!
//! The flow maps the module to yosys's internal gate library (`$_AND_`, `$_MUX_`, `$_DFF_P_`,
//! …) with ABC (`strash; dretime; map`), whose `print_stats` gives the logic depth; it leaves out the coarse passes that share resources and
//! simplify multiplexer trees and flip-flops (`share`, `opt_muxtree`, `opt_dff`), which take
//! hours on these netlists. The cell counts are therefore an upper estimate of the logic, in
//! generic gates, not a process node's area; the flip-flop count is exact (no pass removes a
//! register), and the depth is ABC's level count of the mapped warp module (gates on the longest
//! register-to-register or port path).

use std::path::Path;

use anyhow::{bail, Context, Result};

use super::print::TOP;
use super::Generated;
use crate::report::cost::CostReport;
use crate::report::table::Table;

/// The yosys script for `file`.
pub fn script(file: &str) -> String {
    format!(
        "read_verilog {file}\nhierarchy -top {TOP}\nproc\nopt_expr\nopt_clean\nwreduce\nopt_clean\nalumacc\n\
         techmap\nopt_expr\nopt_clean\nabc -script +strash;dretime;map;print_stats\nopt_clean\n\
         tee -o stat.txt stat -top {TOP}\n"
    )
}

/// One configuration's synthesis.
#[derive(Clone, Debug)]
pub struct SynthReport {
    pub config: String,
    pub flip_flops: u64,
    /// Logic cells by yosys cell type (flip-flops excluded), most first.
    pub cells: Vec<(String, u64)>,
    /// Logic levels of the mapped warp module (ABC's `lev`).
    pub depth: u64,
    /// Register bits of the accounting's fields (`sms cost`) and of the registers it does not
    /// count, by name.
    pub accounted: u64,
    pub unaccounted: Vec<(String, u64)>,
}

impl SynthReport {
    pub fn logic_cells(&self) -> u64 {
        self.cells.iter().map(|c| c.1).sum()
    }
}

/// The Verilog register an accounting field is part of: the cost report counts the bit the RTL
/// adds to Priority (`priority_msb`) apart from the paper's bits, the register holds both.
fn register_of(field: &str) -> &str {
    match field {
        "priority_msb" => "priority",
        f => f,
    }
}

/// The flip-flop cross-check: every register field the cost report counts is declared with the
/// report's bits, and yosys's flip-flops are exactly the declared register bits. The error
/// names the field that differs.
pub fn cross_check(g: &Generated, flip_flops: u64) -> Result<(u64, Vec<(String, u64)>)> {
    let cost = CostReport::new(&g.cfg, 1, 0)?;
    let declared = g.register_bits();
    let mut accounted = 0;
    for f in &cost.fields {
        let reg = register_of(f.name);
        let want: u64 =
            cost.fields.iter().filter(|x| register_of(x.name) == reg).map(|x| x.bits_per_sm()).sum();
        let have = declared.iter().find(|x| x.0 == Some(reg)).map_or(0, |x| x.1);
        if want != have {
            bail!(
                "{}: register {reg} has {have} bits in the Verilog, {want} in the bit accounting (sms cost)",
                g.cfg.name()
            );
        }
    }
    for (name, bits) in &declared {
        let Some(name) = name else { continue };
        if *bits > 0 && !cost.fields.iter().any(|f| register_of(f.name) == *name) {
            bail!("{}: register {name} ({bits} bits) is not in the bit accounting (sms cost)", g.cfg.name());
        }
        accounted += bits;
    }
    let total = g.total_register_bits();
    if flip_flops != total {
        bail!("{}: yosys kept {flip_flops} flip-flops of the {total} register bits declared", g.cfg.name());
    }
    Ok((accounted, unaccounted_by_name(g)))
}

/// Register bits the accounting does not count, by register (lane prefix and slot number
/// dropped), over every warp.
fn unaccounted_by_name(g: &Generated) -> Vec<(String, u64)> {
    let mut out: Vec<(String, u64)> = Vec::new();
    for r in g.circuit.regs.iter().filter(|r| r.field.is_none() && r.bits > 0) {
        let name = r.name.split_once('_').map_or(r.name.as_str(), |x| x.1);
        let name = match name.strip_prefix("seq").and_then(|x| x.split_once('_')) {
            Some((_, f)) => format!("seq_slot_{f}"),
            None => name.to_string(),
        };
        let bits = u64::from(r.bits) * u64::from(g.cfg.warps);
        match out.iter_mut().find(|x| x.0 == name) {
            Some(x) => x.1 += bits,
            None => out.push((name, bits)),
        }
    }
    out
}

/// Runs yosys on `path` (in its folder) and checks the flip-flops.
pub fn synthesize(g: &Generated, path: &Path) -> Result<SynthReport> {
    let dir = path.parent().context("the Verilog's folder")?;
    let file = path.file_name().context("the Verilog's name")?.to_string_lossy().to_string();
    std::fs::write(dir.join("synth.ys"), script(&file))?;
    let out = std::process::Command::new("yosys")
        .args(["-q", "-l", "synth.log", "synth.ys"])
        .current_dir(dir)
        .output()
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => {
                anyhow::anyhow!("yosys is not on PATH: install it (apt-get install yosys)")
            }
            _ => anyhow::anyhow!("yosys: {e}"),
        })?;
    if !out.status.success() {
        let log = std::fs::read_to_string(dir.join("synth.log")).unwrap_or_default();
        let tail: Vec<&str> = log.lines().rev().take(10).collect();
        bail!(
            "yosys failed on {}:\n{}",
            path.display(),
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        );
    }
    let stat = std::fs::read_to_string(dir.join("stat.txt"))?;
    let log = std::fs::read_to_string(dir.join("synth.log"))?;
    let (flip_flops, cells) = parse_stat(&stat)?;
    let depth = parse_levels(&log)?;
    let (accounted, unaccounted) = cross_check(g, flip_flops)?;
    Ok(SynthReport {
        config: super::describe(&g.cfg, g.acked),
        flip_flops,
        cells,
        depth,
        accounted,
        unaccounted,
    })
}

/// Flip-flops and logic cells by type from `stat -top`'s hierarchy summary (its last cell
/// list).
pub fn parse_stat(stat: &str) -> Result<(u64, Vec<(String, u64)>)> {
    let summary = stat.rsplit("=== design hierarchy ===").next().context("stat: no hierarchy summary")?;
    let mut ff = 0;
    let mut cells = Vec::new();
    // The summary's totals follow its last "Number of cells" line.
    let last = summary.rfind("Number of cells").context("stat: no cell count")?;
    for line in summary[last..].lines().skip(1) {
        let mut it = line.split_whitespace();
        let (Some(kind), Some(n)) = (it.next(), it.next()) else { break };
        let Ok(n) = n.parse::<u64>() else { break };
        if !kind.starts_with('$') {
            break;
        }
        if kind.contains("DFF") {
            ff += n;
        } else {
            cells.push((kind.trim_start_matches('$').trim_matches('_').to_string(), n));
        }
    }
    cells.sort_by_key(|c| std::cmp::Reverse(c.1));
    Ok((ff, cells))
}

/// The deepest logic level ABC reports (`print_stats`: `lev = N`) over the mapped modules.
pub fn parse_levels(log: &str) -> Result<u64> {
    let levels = log.lines().filter_map(|l| {
        let at = l.find("lev =")?;
        l[at + 5..].split_whitespace().next()?.parse::<u64>().ok()
    });
    levels.max().context("yosys log: ABC reported no logic levels")
}

/// The reports as a table.
pub fn render(reports: &[SynthReport]) -> String {
    let mut t = Table::new([
        "configuration",
        "flip-flops",
        "of which sms cost counts",
        "registers sms cost omits",
        "logic cells",
        "largest kinds",
        "depth (levels)",
    ]);
    for r in reports {
        let omit: Vec<String> = r.unaccounted.iter().map(|(n, b)| format!("{n} {b}")).collect();
        let kinds: Vec<String> = r.cells.iter().take(3).map(|(k, n)| format!("{k} {n}")).collect();
        t.row([
            r.config.clone(),
            r.flip_flops.to_string(),
            r.accounted.to_string(),
            omit.join(", "),
            r.logic_cells().to_string(),
            kinds.join(", "),
            r.depth.to_string(),
        ]);
    }
    format!(
        "{}\nyosys generic flow (techmap, abc map; no share/opt_muxtree/opt_dff): a technology-independent \
         estimate in generic gates, not a process node's area. Flip-flops are exact and checked against the \
         declared registers and, field by field, against the bit accounting of `sms cost`.\n",
        t.to_text()
    )
}
