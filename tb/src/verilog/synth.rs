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
use crate::report::cost::{CostReport, Origin};
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
    /// Register bits of the accounting's fields (`sms cost`) and of its control registers.
    pub accounting: Accounting,
}

impl SynthReport {
    pub fn logic_cells(&self) -> u64 {
        self.cells.iter().map(|c| c.1).sum()
    }
}

/// The row of the accounting a cost report row's bits go to in the Verilog: the cost report
/// counts the bit the RTL adds to Priority (`priority_msb`) apart from the paper's bits, the
/// register holds both.
fn register_of(row: &str) -> &str {
    match row {
        "priority_msb" => "priority",
        r => r,
    }
}

/// Register bits by row of the accounting, and the rows' total: the accounted ones (`fields`)
/// and the control registers (`control`). `outside`: rows of registers that are not the stack
/// manager's, so not in its Verilog and not compared (a restart design's trail, origin
/// `restart`: the walk's registers, which the model does not clock). `unread`: register bits
/// of the accounted or control rows that no output depends on
/// ([`Generated::unread_register_bits`]), which synthesis removes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Accounting {
    pub accounted: u64,
    pub control: Vec<(String, u64)>,
    pub outside: Vec<(String, u64)>,
    pub unread: Vec<(String, u64)>,
}

impl Accounting {
    pub fn total(&self) -> u64 {
        self.accounted + self.control.iter().map(|x| x.1).sum::<u64>()
    }
}

/// The flip-flop cross-check against `sms cost`'s report of the generated configuration: see
/// [`cross_check_with`].
pub fn cross_check(g: &Generated, flip_flops: u64) -> Result<Accounting> {
    cross_check_with(g, &CostReport::new(&g.cfg, 1, 0)?, flip_flops)
}

/// The flip-flop cross-check: every row of the cost report (its accounted fields and its control
/// registers) has exactly its bits in the Verilog's registers of that row, every Verilog
/// register belongs to a row, and yosys's flip-flops are exactly the report's bits less the
/// register bits no output depends on ([`Accounting::unread`], named in the report). The rows of
/// origin `restart` (a restart design's trail) are the walk's registers, outside the stack
/// manager: they are listed apart ([`Accounting::outside`]) and left out of both sides. The
/// error names the row or the counts that differ.
pub fn cross_check_with(g: &Generated, cost: &CostReport, flip_flops: u64) -> Result<Accounting> {
    let name = g.cfg.name();
    let declared = g.register_bits();
    let (walk, rows): (Vec<_>, Vec<_>) =
        cost.fields.iter().chain(&cost.control).partition(|f| f.origin == Origin::Restart);
    let outside: Vec<(String, u64)> = walk.iter().map(|f| (f.name.to_string(), f.bits_per_sm())).collect();
    let outside_bits: u64 = outside.iter().map(|x| x.1).sum();
    let rows = rows.into_iter();
    let mut accounted = 0;
    let mut control = Vec::new();
    let mut regs: Vec<&str> = Vec::new();
    for f in rows.clone() {
        let reg = register_of(f.name);
        if regs.contains(&reg) {
            continue;
        }
        regs.push(reg);
        let want: u64 = rows.clone().filter(|x| register_of(x.name) == reg).map(|x| x.bits_per_sm()).sum();
        let have = declared.iter().find(|x| x.0 == reg).map_or(0, |x| x.1);
        if want != have {
            bail!("{name}: register {reg} has {have} bits in the Verilog, {want} in the bit accounting (sms cost)");
        }
        if f.origin == Origin::Control {
            control.push((reg.to_string(), want));
        } else {
            accounted += want;
        }
    }
    for (reg, bits) in &declared {
        if *bits > 0 && !regs.contains(reg) {
            bail!("{name}: register {reg} ({bits} bits) is not in the bit accounting (sms cost)");
        }
    }
    let report = cost.totals().bits_per_sm - outside_bits + cost.control_bits_per_sm();
    let unread: Vec<(String, u64)> =
        g.unread_register_bits().into_iter().map(|(r, b)| (r.to_string(), b)).collect();
    let unread_bits: u64 = unread.iter().map(|x| x.1).sum();
    if flip_flops + unread_bits != report {
        let less =
            if unread_bits > 0 { format!(", less {unread_bits} no output reads") } else { String::new() };
        bail!(
            "{name}: yosys kept {flip_flops} flip-flops, the bit accounting (sms cost) has {report} register bits \
             ({} accounted, {} control{less})",
            cost.totals().bits_per_sm - outside_bits,
            cost.control_bits_per_sm()
        );
    }
    Ok(Accounting { accounted, control, outside, unread })
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
    let accounting = cross_check(g, flip_flops)?;
    Ok(SynthReport { config: super::describe(&g.cfg, g.acked), flip_flops, cells, depth, accounting })
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
        "accounted (sms cost fields)",
        "control (sms cost control)",
        "logic cells",
        "largest kinds",
        "depth (levels)",
    ]);
    for r in reports {
        let control: Vec<String> = r.accounting.control.iter().map(|(n, b)| format!("{n} {b}")).collect();
        let kinds: Vec<String> = r.cells.iter().take(3).map(|(k, n)| format!("{k} {n}")).collect();
        t.row([
            r.config.clone(),
            r.flip_flops.to_string(),
            r.accounting.accounted.to_string(),
            control.join(", "),
            r.logic_cells().to_string(),
            kinds.join(", "),
            r.depth.to_string(),
        ]);
    }
    let mut out = format!(
        "{}\nyosys generic flow (techmap, abc map; no share/opt_muxtree/opt_dff): a technology-independent \
         estimate in generic gates, not a process node's area. Flip-flops are exact and equal, row by row, \
         the bit accounting of `sms cost`: its fields and its control registers.\n",
        t.to_text()
    );
    let rows = |x: &[(String, u64)]| x.iter().map(|(n, b)| format!("{n} {b}")).collect::<Vec<_>>().join(", ");
    for r in reports {
        let a = &r.accounting;
        if !a.unread.is_empty() {
            out += &format!(
                "{}: register bits no output reads, which synthesis removes (not among the flip-flops): {}.\n",
                r.config,
                rows(&a.unread)
            );
        }
        if !a.outside.is_empty() {
            out += &format!(
                "{}: not compared, the walk's registers (sms cost origin restart), outside the stack manager: {}.\n",
                r.config,
                rows(&a.outside)
            );
        }
    }
    out
}
