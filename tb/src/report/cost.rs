//! Hardware cost, bit by bit, from the RTL's own width definitions ([`rtl::config::Widths`]).
//!
//! Every field the stack design holds is listed with its width, its number of copies per SM and
//! per GPU, and where it comes from:
//! - *baseline*: the short RB stack has it too (RB entries, RB count, the spill pointer);
//! - *paper*: the fields SPEC section 6 counts (Top, Bottom, Overflow, Idle, Next TID, Priority,
//!   Flush);
//! - *rtl*: bits the verified RTL needs that the paper's accounting omits (the empty bit, the
//!   extra Priority bit, the sequencer's step and data latch).
//!
//! The paper's own figures are derived separately ([`PaperAccounting`]) from the same widths,
//! and every difference is named.
//!
//! Apart from those, [`CostReport::control`] lists the control registers of the sequencer as the
//! model builds it (origin *control*): the micro-op program a command loads, the micro-op in
//! flight, the latch's valid bit and each thread's done bit, in every configuration, the short
//! stack's too. They are in no total of the accounting above (docs/hardware.md, "Cost"), and they
//! are what the generated Verilog's flip-flops add to it (`sms verilog --synth` checks both).

use rtl::config::{bits_for, Config, ConfigError, Overflow, RbSize};
use serde::Serialize;

use crate::report::table::Table;
use crate::workload::bvh::BvhKind;
use crate::workload::restart::{default_levels, level_bits};

/// Where a field's cost belongs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Origin {
    Baseline,
    Paper,
    Rtl,
    Control,
    /// The restart trail of a restart design (`+RT`): the RT unit's walk, per ray.
    Restart,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Field {
    /// The register's name in the RTL and the VCD dump.
    pub name: &'static str,
    pub what: &'static str,
    pub origin: Origin,
    pub bits: u32,
    /// Copies per RT unit (= per SM: one RT unit per SM).
    pub copies_per_sm: u32,
    pub note: &'static str,
}

impl Field {
    pub fn bits_per_sm(&self) -> u64 {
        self.bits as u64 * self.copies_per_sm as u64
    }
}

/// SPEC section 6's accounting for this configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct PaperAccounting {
    /// Top + Bottom: 2 × log2 M bits per thread.
    pub top_bottom_bytes: u64,
    /// Overflow, Idle, Next TID, Priority, Flush.
    pub other_bytes: u64,
    pub total_bytes: u64,
    /// What enlarging the RB by M entries would cost instead.
    pub rb_enlarge_bytes: u64,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CostReport {
    pub config: String,
    pub sms: u32,
    pub threads_per_sm: u32,
    pub fields: Vec<Field>,
    /// The model's sequencer control registers, outside every total of `fields`.
    pub control: Vec<Field>,
    pub paper: PaperAccounting,
    /// Shared memory the SH stacks take, per SM.
    pub sh_bytes: u64,
    /// L1D left of the 64 KB unified array.
    pub l1d_bytes: u64,
    /// Every difference between the paper's accounting and the RTL's, explained.
    pub differences: Vec<String>,
}

/// Unified L1D/shared-memory array per SM (SPEC section 7).
pub const UNIFIED_BYTES: u64 = 64 * 1024;

fn bytes(bits: u64) -> u64 {
    bits.div_ceil(8)
}

impl CostReport {
    /// The cost of `cfg` on a GPU of `sms` SMs. `full_depth` sizes RB = FULL (the deepest stack
    /// seen on a scene); other configurations ignore it.
    pub fn new(cfg: &Config, sms: u32, full_depth: u32) -> Result<CostReport, ConfigError> {
        let w = cfg.widths()?;
        let t = cfg.threads();
        let m = cfg.sh_entries;
        let ra = cfg.realloc();
        let n = cfg.rb.capacity().unwrap_or(full_depth);
        let drops = cfg.overflow == Overflow::Drop;
        let rb_count_bits = match cfg.rb {
            RbSize::Entries(_) => w.rb_count,
            RbSize::Full => bits_for(full_depth as u64),
        };
        let mut fields = vec![
            Field {
                name: "rb_entries",
                what: "RB stack entries",
                origin: Origin::Baseline,
                bits: n * w.entry,
                copies_per_sm: t,
                note: if cfg.rb == RbSize::Full { "FULL sized to the deepest stack given" } else { "" },
            },
            Field {
                name: "rb_count",
                what: "RB occupancy",
                origin: Origin::Baseline,
                bits: rb_count_bits,
                copies_per_sm: t,
                note: "",
            },
            Field {
                name: "spill_ptr",
                what: "global spill pointer",
                origin: Origin::Baseline,
                bits: w.spill_ptr,
                copies_per_sm: t,
                note: if drops {
                    "none: a restart design has no global region"
                } else {
                    "the short stack's local-memory pointer"
                },
            },
            Field {
                name: "overflow",
                what: if drops { "entries were dropped" } else { "global holds entries" },
                origin: if m > 0 { Origin::Paper } else { Origin::Baseline },
                bits: w.overflow,
                copies_per_sm: t,
                note: "",
            },
        ];
        // A per-thread field of the paper's accounting.
        let paper =
            |name, what, bits| Field { name, what, origin: Origin::Paper, bits, copies_per_sm: t, note: "" };
        if m > 0 {
            fields.push(paper("top", "SH queue newest entry", w.top));
            fields.push(paper("bottom", "SH queue oldest entry", w.bottom));
            fields.push(Field {
                name: "sh_empty",
                what: "SH queue empty bit",
                origin: Origin::Rtl,
                bits: w.sh_empty,
                copies_per_sm: t,
                note: "settles Top == Bottom: empty or one entry (SPEC 9.1)",
            });
            fields.push(Field {
                name: "seq_step",
                what: "sequencer step",
                origin: Origin::Rtl,
                bits: w.seq_step,
                copies_per_sm: t,
                note: "position in the longest request sequence (a flush: 2M + 1 micro-ops)",
            });
            fields.push(Field {
                name: "seq_latch",
                what: "sequencer data latch",
                origin: Origin::Rtl,
                bits: w.entry,
                copies_per_sm: t,
                note: "one per thread in the model; a shared pool of a few would do",
            });
        }
        if let Some(r) = ra {
            fields.push(paper("idle", "finished, stack not lent", w.idle));
            fields.push(paper("next_tid", "borrow chain link", w.next_tid));
            fields.push(paper("priority", "rank in the chain", paper_priority_bits(r.borrow_limit)));
            fields.push(paper("flush", "consecutive flushes", w.flush));
            let extra = w.priority - paper_priority_bits(r.borrow_limit);
            if extra > 0 {
                fields.push(Field {
                    name: "priority_msb",
                    what: "rank of the dedicated stack",
                    origin: Origin::Rtl,
                    bits: extra,
                    copies_per_sm: t,
                    note: "the priority register's top bit: ranks 0..=borrow limit, as a flush can rotate the dedicated stack to the top",
                });
            }
        }
        if cfg.overflow == Overflow::Drop {
            // Sized for the default BVH6 (docs/stack.md, "Restart trail").
            let levels = default_levels(BvhKind::Bvh6);
            let per_level = level_bits(BvhKind::Bvh6);
            fields.push(Field {
                name: "trail",
                what: "restart trail",
                origin: Origin::Restart,
                bits: levels as u32 * per_level,
                copies_per_sm: t,
                note: "BVH6: 32 levels x (3-bit rank + last bit); a BVH2 needs 96 x 2; the entries' rank and last bit ride in their unused high address bits",
            });
            fields.push(Field {
                name: "trail_depth",
                what: "depth of the node being visited",
                origin: Origin::Restart,
                bits: bits_for(levels as u64),
                copies_per_sm: t,
                note: "which trail levels are meaningful",
            });
        }
        let log2m = w.top as u64;
        let paper_other_bits: u64 = fields
            .iter()
            .filter(|f| f.origin == Origin::Paper && f.name != "top" && f.name != "bottom")
            .map(|f| f.bits as u64)
            .sum();
        let top_bottom_bytes = bytes(2 * log2m * t as u64);
        let other_bytes = bytes(paper_other_bits * t as u64);
        let paper = PaperAccounting {
            top_bottom_bytes,
            other_bytes,
            total_bytes: top_bottom_bytes + other_bytes,
            rb_enlarge_bytes: m as u64 * cfg.entry_bytes as u64 * t as u64,
        };
        let sh_bytes = u64::from(rtl::gpu::shared_bytes(cfg));
        let unified =
            rtl::mem::MemParams { l1d_bytes: UNIFIED_BYTES as u32, ..rtl::mem::MemParams::default() };
        let differences = fields
            .iter()
            .filter(|f| f.origin == Origin::Rtl)
            .map(|f| {
                format!(
                    "{} ({} bit{} per thread): {}",
                    f.name,
                    f.bits,
                    if f.bits == 1 { "" } else { "s" },
                    f.note
                )
            })
            .collect();
        Ok(CostReport {
            config: cfg.name(),
            sms,
            threads_per_sm: t,
            control: control_fields(cfg)?,
            fields,
            paper,
            sh_bytes,
            l1d_bytes: u64::from(rtl::gpu::carve_out(cfg, unified).l1d_bytes),
            differences,
        })
    }

    /// Bits per SM of one origin.
    pub fn bits_per_sm(&self, origin: Origin) -> u64 {
        self.fields.iter().filter(|f| f.origin == origin).map(Field::bits_per_sm).sum()
    }

    /// Bytes per SM the design adds over the short stack (paper + RTL fields; not the SH array,
    /// which is carved out of L1D).
    pub fn added_bytes_per_sm(&self) -> u64 {
        bytes(self.bits_per_sm(Origin::Paper) + self.bits_per_sm(Origin::Rtl))
    }

    /// All on-chip stack storage per SM: RB entries and every field, plus the SH array.
    pub fn on_chip_bytes_per_sm(&self) -> u64 {
        bytes(self.fields.iter().map(Field::bits_per_sm).sum()) + self.sh_bytes
    }

    pub fn fields_table(&self) -> Table {
        let mut tbl =
            Table::new(["field", "origin", "bits", "copies/SM", "bits/SM", "bytes/SM", "bytes/GPU", "note"]);
        for f in &self.fields {
            let b = f.bits_per_sm();
            tbl.row([
                f.name.to_string(),
                format!("{:?}", f.origin).to_lowercase(),
                f.bits.to_string(),
                f.copies_per_sm.to_string(),
                b.to_string(),
                bytes(b).to_string(),
                bytes(b * self.sms as u64).to_string(),
                f.note.to_string(),
            ]);
        }
        tbl
    }

    pub fn summary_table(&self) -> Table {
        let mut tbl = Table::new(["item", "bytes/SM"]);
        let p = &self.paper;
        tbl.row(["paper: Top + Bottom".to_string(), p.top_bottom_bytes.to_string()]);
        tbl.row(["paper: Overflow, Idle, Next TID, Priority, Flush".to_string(), p.other_bytes.to_string()]);
        tbl.row(["paper: total".to_string(), p.total_bytes.to_string()]);
        tbl.row(["paper: enlarge RB by M entries instead".to_string(), p.rb_enlarge_bytes.to_string()]);
        tbl.row(["RTL: bits the paper omits".to_string(), bytes(self.bits_per_sm(Origin::Rtl)).to_string()]);
        tbl.row(["RTL: total added over the short stack".to_string(), self.added_bytes_per_sm().to_string()]);
        tbl.row([
            "baseline fields (RB entries, count, spill pointer)".to_string(),
            bytes(self.bits_per_sm(Origin::Baseline)).to_string(),
        ]);
        if self.bits_per_sm(Origin::Restart) > 0 {
            tbl.row([
                "restart: the trail and its depth, per ray".to_string(),
                bytes(self.bits_per_sm(Origin::Restart)).to_string(),
            ]);
        }
        tbl.row(["shared memory for SH stacks".to_string(), self.sh_bytes.to_string()]);
        tbl.row(["L1D left of 64 KB".to_string(), self.l1d_bytes.to_string()]);
        tbl.row([
            "control: the model's sequencer program and flags (in no total above)".to_string(),
            bytes(self.control_bits_per_sm()).to_string(),
        ]);
        tbl
    }

    /// The control registers' table, with the columns of [`CostReport::fields_table`].
    pub fn control_table(&self) -> Table {
        let mut tbl = Table::new([
            "register",
            "origin",
            "bits",
            "copies/SM",
            "bits/SM",
            "bytes/SM",
            "bytes/GPU",
            "note",
        ]);
        for f in &self.control {
            let b = f.bits_per_sm();
            tbl.row([
                f.name.to_string(),
                "control".to_string(),
                f.bits.to_string(),
                f.copies_per_sm.to_string(),
                b.to_string(),
                bytes(b).to_string(),
                bytes(b * self.sms as u64).to_string(),
                f.note.to_string(),
            ]);
        }
        tbl
    }

    /// Bits per SM of the control registers.
    pub fn control_bits_per_sm(&self) -> u64 {
        self.control.iter().map(Field::bits_per_sm).sum()
    }

    /// The whole report as terminal text or Markdown.
    pub fn render(&self, markdown: bool) -> String {
        let t = |tbl: Table| if markdown { tbl.to_markdown() } else { tbl.to_text() };
        let mut out = format!(
            "{}Hardware cost of {} ({} threads per SM, {} SMs)\n\n",
            if markdown { "## " } else { "" },
            self.config,
            self.threads_per_sm,
            self.sms
        );
        out += &t(self.fields_table());
        out += "\n";
        out += &t(self.summary_table());
        if !self.differences.is_empty() {
            out += "\nWhat the verified RTL holds beyond the paper's accounting:\n";
            for d in &self.differences {
                out += &format!("- {d}\n");
            }
        }
        out += "\nControl registers of the model's sequencer (every configuration; in no total above: the \
                accounting counts a sequencer as its step and data latch):\n\n";
        out += &t(self.control_table());
        out
    }
}

/// One configuration's totals, as the text's tables show them: bits per SM by origin (the
/// `bits/SM` column summed), per GPU, and the summary's bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct CostTotals {
    pub baseline_bits_per_sm: u64,
    pub paper_bits_per_sm: u64,
    pub rtl_bits_per_sm: u64,
    /// Every field's bits per SM.
    pub bits_per_sm: u64,
    /// The control registers' bits per SM ([`CostReport::control`]), apart from `bits_per_sm`.
    pub control_bits_per_sm: u64,
    pub bits_per_gpu: u64,
    pub added_bytes_per_sm: u64,
    pub on_chip_bytes_per_sm: u64,
}

/// A report as `sms cost --json` writes it: every field of [`CostReport`] plus `totals`.
#[derive(Clone, Debug, Serialize)]
pub struct CostJson<'a> {
    #[serde(flatten)]
    pub report: &'a CostReport,
    pub totals: CostTotals,
}

impl CostReport {
    pub fn totals(&self) -> CostTotals {
        let bits_per_sm = self.fields.iter().map(Field::bits_per_sm).sum();
        CostTotals {
            baseline_bits_per_sm: self.bits_per_sm(Origin::Baseline),
            paper_bits_per_sm: self.bits_per_sm(Origin::Paper),
            rtl_bits_per_sm: self.bits_per_sm(Origin::Rtl),
            bits_per_sm,
            control_bits_per_sm: self.control_bits_per_sm(),
            bits_per_gpu: bits_per_sm * self.sms as u64,
            added_bytes_per_sm: self.added_bytes_per_sm(),
            on_chip_bytes_per_sm: self.on_chip_bytes_per_sm(),
        }
    }

    pub fn to_json(&self) -> CostJson<'_> {
        CostJson { report: self, totals: self.totals() }
    }
}

/// Every configuration's fields in one table (the CSV of `sms cost`): the fields table with the
/// configuration in front.
pub fn fields_of_all(reports: &[CostReport]) -> Table {
    let mut out: Option<Table> = None;
    for r in reports {
        let t = r.fields_table();
        let all = out.get_or_insert_with(|| {
            Table::new(std::iter::once("config".to_string()).chain(t.headers.clone()))
        });
        for row in t.rows {
            all.row(std::iter::once(r.config.clone()).chain(row));
        }
    }
    out.unwrap_or_else(|| Table::new(["config"]))
}

/// The control registers of a thread's sequencer as the model builds it: a command loads its
/// whole micro-op program (up to `2M + 4` micro-ops, each with its operands and immediate), one
/// micro-op is in flight, the latch has a valid bit and the thread a done bit. With an SH level
/// the accounting counts the step and the latch (origin *rtl*); without one they are here too.
fn control_fields(cfg: &Config) -> Result<Vec<Field>, ConfigError> {
    let w = cfg.widths()?;
    let t = cfg.threads();
    let uop: u32 = w.uop_bits().iter().sum();
    let row =
        |name, what, bits, note| Field { name, what, origin: Origin::Control, bits, copies_per_sm: t, note };
    let mut out = Vec::new();
    if cfg.sh_entries == 0 {
        out.push(row("seq_step", "sequencer program occupancy", w.seq_step, "0..=4 micro-ops"));
        out.push(row("seq_latch", "sequencer data latch", w.entry, "the entry a load brings back"));
    }
    out.push(row(
        "seq_program",
        "micro-op program slots",
        w.seq_slots * uop,
        "2M + 4 slots of (kind 3, lane or spill slot, SH entry, latch flag 1, entry value)",
    ));
    out.push(row("seq_inflight", "micro-op in flight", uop, "one slot's fields"));
    out.push(row("seq_latch_valid", "data latch holds a value", 1, ""));
    out.push(row("done", "thread finished", 1, ""));
    Ok(out)
}

/// The paper's Priority width: the order of the borrowed stacks only.
fn paper_priority_bits(borrow_limit: u32) -> u32 {
    bits_for(borrow_limit.saturating_sub(1) as u64).max(1)
}

/// Several configurations side by side.
pub fn comparison(reports: &[CostReport]) -> Table {
    let mut tbl = Table::new([
        "config",
        "paper bytes/SM",
        "RTL added bytes/SM",
        "RB entry bytes/SM",
        "SH bytes/SM",
        "on-chip stack bytes/SM",
        "L1D bytes",
    ]);
    for r in reports {
        let rb_entries = r.fields.iter().find(|f| f.name == "rb_entries").map_or(0, Field::bits_per_sm);
        tbl.row([
            r.config.clone(),
            r.paper.total_bytes.to_string(),
            r.added_bytes_per_sm().to_string(),
            bytes(rb_entries).to_string(),
            r.sh_bytes.to_string(),
            r.on_chip_bytes_per_sm().to_string(),
            r.l1d_bytes.to_string(),
        ]);
    }
    tbl
}

#[cfg(test)]
mod tests {
    use rtl::stack_manager::StackManager;
    use rtl::trace::{Probe, Snapshot};

    use super::*;

    #[test]
    fn a_restart_design_counts_its_trail_and_no_spill_pointer() {
        let rt = CostReport::new(&"RB_4+RT".parse().unwrap(), 8, 0).unwrap();
        let bits = |r: &CostReport, name: &str| r.fields.iter().find(|f| f.name == name).map(|f| f.bits);
        assert_eq!(bits(&rt, "trail"), Some(32 * 4), "BVH6: 32 levels of a 3-bit rank and a last bit");
        assert_eq!(bits(&rt, "trail_depth"), Some(6));
        assert_eq!(bits(&rt, "spill_ptr"), Some(0));
        assert_eq!(rt.bits_per_sm(Origin::Restart), 128 * (128 + 6));
        let spill = CostReport::new(&"RB_4".parse().unwrap(), 8, 0).unwrap();
        assert_eq!(spill.bits_per_sm(Origin::Restart), 0);
        assert_eq!(bits(&spill, "trail"), None);
        // SMS with restart: the paper's accounting of its SH fields is unchanged.
        let sms_rt = CostReport::new(&"RB_8+SH_8+SK+RA+RT".parse().unwrap(), 8, 0).unwrap();
        assert_eq!(sms_rt.paper.total_bytes, 272);
    }

    #[test]
    fn the_papers_figures_for_its_configuration() {
        let r = CostReport::new(&Config::sms(), 8, 0).unwrap();
        assert_eq!(r.paper.top_bottom_bytes, 96);
        assert_eq!(r.paper.other_bytes, 176);
        assert_eq!(r.paper.total_bytes, 272);
        assert_eq!(r.paper.rb_enlarge_bytes, 8 * 1024);
        assert_eq!(r.sh_bytes, 8 * 1024);
        assert_eq!(r.l1d_bytes, 56 * 1024);
        // The RTL adds: empty bit 1, sequencer step bits_for(20) = 5, latch 64, priority +1.
        assert_eq!(r.bits_per_sm(Origin::Rtl), (1 + 5 + 64 + 1) * 128);
        assert_eq!(r.differences.len(), 4);
        // Every row has its own name.
        let mut names: Vec<&str> = r.fields.iter().map(|f| f.name).collect();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), r.fields.len(), "{names:?}");
    }

    /// The report's widths are the RTL's: the same names, the same widths as the stack manager's
    /// probe (which the VCD dump declares its wires from).
    #[test]
    fn widths_are_the_rtl_registers_widths() {
        for cfg in [Config::sms(), "RB_4+SH_16+SK+RA".parse().unwrap(), "RB_8+SH_4".parse().unwrap()] {
            let r = CostReport::new(&cfg, 8, 0).unwrap();
            let sm = StackManager::new(cfg, 0).unwrap();
            let mut snap = Snapshot::default();
            sm.probe(&mut snap);
            let probe_width = |name: &str| {
                snap.signals.iter().find(|(p, _, _)| p == &format!("warp[0].thread[0].{name}")).map(|s| s.1)
            };
            let w = cfg.widths().unwrap();
            for f in r.fields.iter().filter(|f| f.origin != Origin::Rtl || f.name == "sh_empty") {
                // The paper's priority and the bit the RTL adds to it make one register.
                let total: u32 = r
                    .fields
                    .iter()
                    .filter(|g| g.name == f.name || g.name.strip_suffix("_msb") == Some(f.name))
                    .map(|g| g.bits)
                    .sum();
                match probe_width(f.name) {
                    Some(pw) => assert_eq!(pw, total, "{}: {} report vs probe", cfg.name(), f.name),
                    None => assert_eq!(f.name, "rb_entries", "{}: {} has no probe", cfg.name(), f.name),
                }
            }
            assert_eq!(probe_width("priority"), (w.priority > 0).then_some(w.priority));
            assert_eq!(probe_width("top"), Some(w.top));
        }
    }

    #[test]
    fn changing_m_and_warps_changes_the_report_as_arithmetic_says() {
        // M = 16: Top + Bottom 2 × 4 bits × 128 threads = 128 bytes; SH 16 × 8 × 128 = 16 KB.
        let m16 = CostReport::new(&"RB_8+SH_16+SK+RA".parse().unwrap(), 8, 0).unwrap();
        assert_eq!(m16.paper.top_bottom_bytes, 128);
        assert_eq!(m16.paper.other_bytes, 176);
        assert_eq!(m16.sh_bytes, 16 * 1024);
        assert_eq!(m16.l1d_bytes, 48 * 1024);
        // M = 4: 2 × 2 × 128 bits = 64 bytes.
        let m4 = CostReport::new(&"RB_8+SH_4".parse().unwrap(), 8, 0).unwrap();
        assert_eq!(m4.paper.top_bottom_bytes, 64);
        assert_eq!(m4.paper.other_bytes, 16, "Overflow only without RA: 128 bits");
        // 2 warps: every per-thread figure halves.
        let two = Config { warps: 2, ..Config::sms() };
        let r2 = CostReport::new(&two, 8, 0).unwrap();
        assert_eq!((r2.paper.top_bottom_bytes, r2.paper.other_bytes, r2.paper.total_bytes), (48, 88, 136));
        assert_eq!(r2.sh_bytes, 4 * 1024);
        // Warp size 16: Next TID 4 bits, so the other fields are 10 bits × 64 threads = 80 bytes.
        let ws16 = Config { warp_size: 16, ..Config::sms() };
        let r16 = CostReport::new(&ws16, 8, 0).unwrap();
        assert_eq!(r16.paper.other_bytes, 80);
        // RB_FULL sized to a depth of 40: 40 × 64 bits × 128 threads.
        let full = CostReport::new(&"RB_FULL".parse().unwrap(), 8, 40).unwrap();
        assert_eq!(full.fields[0].bits_per_sm(), 40 * 64 * 128);
        assert_eq!(full.fields[1].bits, 6, "count 0..=40");
    }

    #[test]
    fn invalid_configurations_give_the_config_error() {
        let bad = Config { sh_entries: 6, ..Config::sms() };
        let e = CostReport::new(&bad, 8, 0).unwrap_err();
        assert_eq!(e.parameter, "sh");
    }
}
