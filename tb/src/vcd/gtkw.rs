//! GTKWave save files (`.gtkw`), so a dump opens with its signals already laid out.
//!
//! The format is GTKWave's line-oriented save file: `[directive] value` lines, `@flags` (hex
//! trace flags that apply to the following lines), `-label` for blank/comment traces (group
//! begin and end markers are comment traces with the group flags) and one fully qualified
//! signal name per trace line. GTKWave's VCD loader names a vector `path[msb:0]`, a scalar just
//! `path`, and keeps brackets in scope names (`warp[3]`), which we checked with GTKWave 3.3.118.
//!
//! Layout: one group per stack thread with the stack fields in [`FIELD_ORDER`] (the first
//! thread's group open, the others closed), then the unit-level scopes (bank arbiter, memory
//! scheduler, response FIFO, and in a GPU dump the RT unit's and memory system's), then the RT
//! unit's per-lane traversal states. The view ([`View`]) opens on the first RB → SH spill of
//! the dumped lanes, marked, with a few cycles before it and [`FOCUS_CYCLES`] in all; a dump
//! without a spill opens on its whole window.
//!
//! Each trace's display format follows the [`Kind`] its probe declares ([`Format::of`]), not
//! its name: addresses and data words in hex, masks (and one-bit signals) in binary, counts in
//! decimal, and encoded enumerations (command kinds, micro-ops, thread states, request kinds)
//! by name through a GTKWave translate filter file. Those files ([`filter_text`]: one `value
//! name` line per code, from the rtl enum's own name list) are written next to the save file as
//! `NAME.filter`, and the save file attaches them per trace the way GTKWave writes its own: the
//! flag word carries `TR_FTRANSLATED` and a `^N PATH` line before the trace names filter `N`.
//! `waves/*.filter` are the shipped copies (a test keeps them equal to the generated ones).

use rtl::trace::Kind;

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// The per-thread stack fields in display order: command, RB, SH queue, spill, RA, status.
/// Fields not listed (a future probe) follow in walk order.
pub const FIELD_ORDER: [&str; 17] = [
    "cmd_valid",
    "cmd_kind",
    "cmd_data",
    "uop",
    "rb_count",
    "rb_top",
    "top",
    "bottom",
    "sh_empty",
    "overflow",
    "spill_ptr",
    "idle",
    "next_tid",
    "priority",
    "flush",
    "busy",
    "done",
];

// GTKWave trace flags (gtkwave's `TR_*` bits).
const TR_HEX: u32 = 1 << 1;
const TR_DEC: u32 = 1 << 2;
const TR_BIN: u32 = 1 << 3;
const TR_RJUSTIFY: u32 = 1 << 5;
const TR_BLANK: u32 = 1 << 9;
const TR_COLLAPSED: u32 = 1 << 12;
const TR_FTRANSLATED: u32 = 1 << 13;
const TR_CLOSED: u32 = 1 << 22;
const TR_GRP_BEGIN: u32 = 1 << 23;
const TR_GRP_END: u32 = 1 << 24;

/// Window size written to the save file, and the part of it the wave pane gets.
const SIZE: (u32, u32) = (1400, 900);
const SIGNALS_WIDTH: u32 = 300;
const WAVE_PIXELS: f64 = 780.0;
/// Time units per pixel at zoom 0, and each zoom step halves it: measured with GTKWave 3.3.118
/// on a 1 ns timescale (zoom -5 shows 32 times the span of zoom 0).
const UNITS_PER_PIXEL_AT_ZOOM_0: f64 = 1.0 / 200.0;
/// GTKWave's time units per clock cycle: it keeps times in the timescale's unit times its
/// multiplier (100 ms → ms), so a cycle of [`super::UNITS_PER_CYCLE`] × 100 ms is 1000 of them.
/// The save file's start, marker and zoom are in these units.
const GTKWAVE_UNITS_PER_CYCLE: u64 = super::UNITS_PER_CYCLE * 100;
/// Cycles the view around a spill spans, and how many of them come before it.
pub const FOCUS_CYCLES: u64 = 96;
const FOCUS_BEFORE: u64 = 16;

/// What the save file shows first: cycles `start..end`, a marker, and the signal group opened
/// (by default the first stack thread's).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct View {
    pub start: u64,
    pub end: u64,
    pub marker: Option<u64>,
    pub open: Option<String>,
}

impl View {
    /// The dumped cycles `from..end`, focused on `spill` (the first RB → SH spill: its cycle
    /// and the micro-op signal that showed it, whose thread is opened) if any.
    pub fn around(from: u64, end: u64, spill: Option<(u64, String)>) -> View {
        match spill {
            Some((c, path)) if (from..end).contains(&c) => {
                let start = c.saturating_sub(FOCUS_BEFORE).max(from);
                let open = path.rsplit_once('.').map(|(scope, _)| scope.to_string());
                View { start, end: (start + FOCUS_CYCLES).min(end), marker: Some(c), open }
            }
            _ => View { start: from, end, marker: None, open: None },
        }
    }
}

/// How GTKWave shows a trace.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Binary,
    Decimal,
    Hex,
    /// Decimal codes translated to names by the filter file of this enumeration.
    Names {
        name: &'static str,
        names: &'static [&'static str],
    },
}

impl Format {
    /// The format of a `width`-bit signal declared as `kind`.
    pub fn of(width: u32, kind: Kind) -> Format {
        match kind {
            _ if width == 1 => Format::Binary,
            Kind::Number => Format::Decimal,
            Kind::Address | Kind::Data => Format::Hex,
            Kind::Mask => Format::Binary,
            Kind::Enum { name, names } => Format::Names { name, names },
        }
    }

    /// GTKWave's trace flags for this format.
    pub fn flags(self) -> u32 {
        TR_RJUSTIFY
            | match self {
                Format::Binary => TR_BIN,
                Format::Decimal => TR_DEC,
                Format::Hex => TR_HEX,
                Format::Names { .. } => TR_DEC | TR_FTRANSLATED,
            }
    }
}

/// The translate filter file of an enumeration whose value `i` is `names[i]`: one line per
/// value, the value as GTKWave prints it in decimal, then the name.
pub fn filter_text(name: &str, names: &[&str]) -> String {
    let mut text = format!(
        "# {name}: GTKWave translate filter file, written by tb::vcd from the rtl enum
"
    );
    for (code, n) in names.iter().enumerate() {
        text.push_str(&format!(
            "{code} {n}
"
        ));
    }
    text
}

/// Every encoded enumeration the probes declare, for the shipped filter files (`waves/`; the
/// GPU dump test checks that each filter a dump uses is among them).
pub const ENUMS: [Kind; 4] = [
    rtl::stack_manager::Cmd::KIND,
    rtl::stack_manager::Uop::KIND,
    rtl::thread_fsm::ThreadState::KIND,
    rtl::mem::ReqKind::KIND,
];

/// Writes the filter file of every enumeration of [`ENUMS`] into `dir`.
pub fn write_filters(dir: &Path) -> io::Result<()> {
    for kind in ENUMS {
        if let Kind::Enum { name, names } = kind {
            std::fs::write(dir.join(filter_file(name)), filter_text(name, names))?;
        }
    }
    Ok(())
}

/// The file name of an enumeration's filter, next to the save file.
pub fn filter_file(name: &str) -> String {
    format!("{name}.filter")
}

/// Writes the save file `save` for the dump `dump` whose declared signals are `signals`
/// (`(path, width, kind)` in walk order) and whose written cycles are `from..end`, and the
/// translate filter file of every enumeration among them next to it.
pub fn write(save: &Path, dump: &Path, signals: &[(String, u32, Kind)], view: View) -> io::Result<()> {
    let units = GTKWAVE_UNITS_PER_CYCLE;
    let dir = save.parent().unwrap_or(Path::new("."));
    let mut filters: Vec<&'static str> = Vec::new();
    for (_, width, kind) in signals {
        if let Format::Names { name, names } = Format::of(*width, *kind) {
            if !filters.contains(&name) {
                filters.push(name);
                std::fs::write(dir.join(filter_file(name)), filter_text(name, names))?;
            }
        }
    }
    let mut f = BufWriter::new(File::create(save)?);
    writeln!(f, "[*] sms waves, written by tb::vcd")?;
    // Beside its dump, a save file names both by file name only, so the pair can be moved
    // (GTKWave resolves a relative dump path against the save file's folder).
    let beside = dump.parent() == save.parent();
    let name =
        |p: &Path| if beside { p.file_name().map_or(p.into(), PathBuf::from) } else { p.to_path_buf() };
    writeln!(f, "[dumpfile] \"{}\"", name(dump).display())?;
    writeln!(f, "[savefile] \"{}\"", name(save).display())?;
    writeln!(f, "[timestart] {}", view.start * units)?;
    writeln!(f, "[size] {} {}", SIZE.0, SIZE.1)?;
    writeln!(f, "[signals_width] {SIGNALS_WIDTH}")?;
    writeln!(f, "[sst_expanded] 1")?;
    let span = (view.end.saturating_sub(view.start).max(1) * units) as f64;
    let zoom = -(span / WAVE_PIXELS / UNITS_PER_PIXEL_AT_ZOOM_0).log2();
    let marker = view.marker.map_or(-1, |c| (c * units) as i64);
    writeln!(f, "*{zoom:.6} {marker}{}", " -1".repeat(26))?;
    // The clock first, as a viewer expects it.
    writeln!(f, "@{:x}", Format::Binary.flags())?;
    writeln!(f, "{}", super::CLOCK)?;
    let mut flags = Format::Binary.flags();
    let mut set_flags = |f: &mut BufWriter<File>, new: u32| {
        if new != flags {
            flags = new;
            writeln!(f, "@{new:x}")?;
        }
        Ok::<(), io::Error>(())
    };
    let mut first_thread = true;
    for (scope, group) in groups(signals) {
        let first = scope.contains("thread[") && std::mem::take(&mut first_thread);
        let open = view.open.as_ref().map_or(first, |o| *o == scope);
        let closed = scope.contains("thread[") && !open;
        let label = ["rt_unit.stack_manager.", "rt_unit."]
            .iter()
            .find_map(|p| scope.strip_prefix(p))
            .unwrap_or(&scope);
        let closed_bits = if closed { TR_CLOSED } else { 0 };
        set_flags(&mut f, TR_GRP_BEGIN | TR_BLANK | closed_bits)?;
        writeln!(f, "-{label}")?;
        for (path, width, kind) in group {
            let format = Format::of(*width, *kind);
            set_flags(&mut f, format.flags())?;
            if let Format::Names { name, .. } = format {
                let index = filters.iter().position(|n| *n == name).unwrap_or(0) + 1;
                // Written beside the save file, so named by file name (resolved as the dump is).
                writeln!(f, "^{index} {}", filter_file(name))?;
            }
            if *width == 1 {
                writeln!(f, "{path}")?;
            } else {
                writeln!(f, "{path}[{}:0]", width - 1)?;
            }
        }
        let collapsed = if closed { TR_COLLAPSED } else { 0 };
        set_flags(&mut f, TR_GRP_END | TR_BLANK | closed_bits | collapsed)?;
        writeln!(f, "-{label}")?;
    }
    f.flush()
}

/// Signals grouped by their scope: stack threads, unit-level scopes, lane states, each in walk
/// order; thread fields sorted by [`FIELD_ORDER`].
type Signal = (String, u32, Kind);

fn groups(signals: &[Signal]) -> Vec<(String, Vec<&Signal>)> {
    let mut groups: Vec<(String, Vec<&Signal>)> = Vec::new();
    for s in signals {
        let scope = s.0.rsplit_once('.').map_or("", |(scope, _)| scope);
        match groups.iter_mut().find(|g| g.0 == scope) {
            Some(g) => g.1.push(s),
            None => groups.push((scope.to_string(), vec![s])),
        }
    }
    let rank = |path: &str| {
        let name = path.rsplit('.').next().unwrap_or(path);
        FIELD_ORDER.iter().position(|f| *f == name).unwrap_or(FIELD_ORDER.len())
    };
    for g in &mut groups {
        g.1.sort_by_key(|s| rank(&s.0));
    }
    // Stack threads first (what a stack designer looks at), then unit-level scopes, then the
    // RT unit's per-lane traversal states; walk order within each.
    groups.sort_by_key(|g| match (g.0.contains("thread["), g.0.contains("warp_buffer")) {
        (true, false) => 0,
        (false, _) => 1,
        (true, true) => 2,
    });
    groups
}

#[cfg(test)]
mod tests {
    use super::View;

    #[test]
    fn the_view_opens_on_the_first_spill_and_its_thread() {
        let spill = Some((500, "sm0.rt_unit.stack_manager.warp[0].thread[3].uop".to_string()));
        let v = View::around(0, 3001, spill);
        assert_eq!((v.start, v.end, v.marker), (484, 484 + super::FOCUS_CYCLES, Some(500)));
        assert_eq!(v.open.as_deref(), Some("sm0.rt_unit.stack_manager.warp[0].thread[3]"));
        // Near the window's edges the view stays inside it; without a spill it is the window.
        assert_eq!(View::around(490, 520, Some((495, "a.uop".into()))).start, 490);
        assert_eq!(View::around(490, 520, Some((495, "a.uop".into()))).end, 520);
        assert_eq!(View::around(0, 100, Some((100, "a.uop".into()))).marker, None, "outside the dump");
        assert_eq!(View::around(7, 100, None), View { start: 7, end: 100, marker: None, open: None });
    }
}
