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
//! unit's per-lane traversal states. The zoom shows the whole written window.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

/// The per-thread stack fields in display order: command, RB, SH queue, spill, RA, status.
/// Fields not listed (a future probe) follow in walk order.
pub const FIELD_ORDER: [&str; 16] = [
    "cmd_valid",
    "cmd_kind",
    "cmd_data",
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

/// Shown in hex (addresses, data and bank masks); every other vector in decimal.
const HEX: [&str; 5] = ["cmd_data", "rb_top", "grant", "conflict", "req_addr"];

// GTKWave trace flags (gtkwave's `TR_*` bits).
const TR_HEX: u32 = 1 << 1;
const TR_DEC: u32 = 1 << 2;
const TR_BIN: u32 = 1 << 3;
const TR_RJUSTIFY: u32 = 1 << 5;
const TR_BLANK: u32 = 1 << 9;
const TR_COLLAPSED: u32 = 1 << 12;
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

/// Writes the save file `save` for the dump `dump` whose declared signals are `signals`
/// (`(path, width)` in walk order) and whose written cycles are `from..end`.
pub fn write(save: &Path, dump: &Path, signals: &[(String, u32)], from: u64, end: u64) -> io::Result<()> {
    let mut f = BufWriter::new(File::create(save)?);
    writeln!(f, "[*] sms waves, written by tb::vcd")?;
    writeln!(f, "[dumpfile] \"{}\"", dump.display())?;
    writeln!(f, "[savefile] \"{}\"", save.display())?;
    writeln!(f, "[timestart] {from}")?;
    writeln!(f, "[size] {} {}", SIZE.0, SIZE.1)?;
    writeln!(f, "[signals_width] {SIGNALS_WIDTH}")?;
    writeln!(f, "[sst_expanded] 1")?;
    let span = end.saturating_sub(from).max(1) as f64;
    let zoom = -(span / WAVE_PIXELS / UNITS_PER_PIXEL_AT_ZOOM_0).log2();
    writeln!(f, "*{zoom:.6} -1{}", " -1".repeat(26))?;
    let mut flags = 0;
    let mut set_flags = |f: &mut BufWriter<File>, new: u32| {
        if new != flags {
            flags = new;
            writeln!(f, "@{new:x}")?;
        }
        Ok::<(), io::Error>(())
    };
    let mut first_thread = true;
    for (scope, group) in groups(signals) {
        let closed = scope.contains("thread[") && !std::mem::take(&mut first_thread);
        let label = ["rt_unit.stack_manager.", "rt_unit."]
            .iter()
            .find_map(|p| scope.strip_prefix(p))
            .unwrap_or(&scope);
        let closed_bits = if closed { TR_CLOSED } else { 0 };
        set_flags(&mut f, TR_GRP_BEGIN | TR_BLANK | closed_bits)?;
        writeln!(f, "-{label}")?;
        for (path, width) in group {
            let name = path.rsplit('.').next().unwrap_or(path);
            let format = match *width {
                1 => TR_BIN,
                _ if HEX.contains(&name) => TR_HEX,
                _ => TR_DEC,
            };
            set_flags(&mut f, format | TR_RJUSTIFY)?;
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
fn groups(signals: &[(String, u32)]) -> Vec<(String, Vec<&(String, u32)>)> {
    let mut groups: Vec<(String, Vec<&(String, u32)>)> = Vec::new();
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
