//! VCD waveforms of every per-cycle signal, for debugging in GTKWave.
//!
//! [`VcdSink`] is an [`rtl::trace::Sink`]: it sits on the probe walk the RTL already does, so
//! any driver that takes a sink (the cycle-level harness, later a real-scene run) can dump waves
//! without knowing about VCD. Wires get exactly the hardware widths of [`rtl::config::Widths`],
//! as the probes report them. The first walk is recorded in a [`Snapshot`] and turned into the
//! declarations; after that the sink only compares each value with the last one at the same walk
//! position and writes what changed, with a timestamp only for cycles where something did.
//!
//! A [`Selection`] keeps files small: a cycle window and which warps and lanes to dump (the unit
//! level, bank arbiter and memory scheduler, is always dumped). [`VcdSink::create`] also writes a
//! GTKWave save file next to the dump ([`gtkw`]). [`check`] is the strict reader the tests use.
//!
//! Time: GTKWave knows only seconds and their fractions, so the dump reads cycles as seconds:
//! `$timescale 100 ms`, each cycle [`UNITS_PER_CYCLE`] units, so the time axis shows cycle `n`
//! at `n s` and a top-level `clk` rises at each cycle's start and falls half-way (docs/waveforms.md).
//! Vectors are written without leading zeros (`b101`), as VCD allows.
//!
//! A sink cannot return errors from inside the walk, so I/O and walk errors are kept and
//! reported by [`VcdSink::finish`], which the caller must call.

pub mod check;
pub mod gtkw;

use std::fmt;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::PathBuf;

use rtl::config::Config;
use rtl::trace::{Kind, Sink, Snapshot};
use vcd::{IdCode, TimescaleUnit};

/// Time units per clock cycle: the clock rises at `cycle × UNITS_PER_CYCLE` and falls half-way.
pub const UNITS_PER_CYCLE: u64 = 10;
/// The timescale those units are in: 100 ms, so that one cycle reads as 1 s in GTKWave.
pub const TIMESCALE: (u32, TimescaleUnit) = (100, TimescaleUnit::MS);
/// The clock's name, at the top of the dump.
pub const CLOCK: &str = "clk";
/// The micro-op of an RB → SH spill, whose first appearance the save file zooms to.
const SPILL_UOP: &str = "sh_store";

/// Which cycles and which threads go into the dump.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Selection {
    /// First cycle written (default 0).
    pub from: Option<u64>,
    /// Last cycle written, inclusive (default: the end of the run).
    pub to: Option<u64>,
    /// Warp slots to dump (default all).
    pub warps: Option<Vec<u32>>,
    /// Lanes (thread index within the warp) to dump (default all).
    pub lanes: Option<Vec<u32>>,
    /// SMs to dump in a whole-GPU run (scopes `sm<k>` and their L1Ds `mem.l1d<k>`; default
    /// all). The L2 and DRAM are always dumped.
    /// An SM the run does not have is reported by [`VcdSink::finish`].
    pub sms: Option<Vec<u32>>,
}

impl Selection {
    /// Checks the selection against the configuration; every error names the bad value.
    pub fn validate(&self, cfg: &Config) -> Result<(), VcdError> {
        if let (Some(from), Some(to)) = (self.from, self.to) {
            if from > to {
                return Err(VcdError::Window { from, to });
            }
        }
        if let Some(&warp) = self.warps.iter().flatten().find(|&&w| w >= cfg.warps) {
            return Err(VcdError::NoSuchWarp { warp, warps: cfg.warps });
        }
        if let Some(&lane) = self.lanes.iter().flatten().find(|&&l| l >= cfg.warp_size) {
            return Err(VcdError::NoSuchLane { lane, warp_size: cfg.warp_size });
        }
        Ok(())
    }

    fn in_window(&self, cycle: u64) -> bool {
        self.from.is_none_or(|f| cycle >= f) && self.to.is_none_or(|t| cycle <= t)
    }

    /// Whether the signal at `path` (scopes joined by '.') is dumped: anything under a
    /// `warp[w]`, `thread[l]`, `sm<k>` or `l1d<k>` scope outside the filters is not.
    pub fn selects(&self, path: &str) -> bool {
        let keep = |filter: &Option<Vec<u32>>, scope: &str| {
            path.split('.')
                .filter_map(|seg| seg.strip_prefix(scope)?.strip_suffix(']')?.parse().ok())
                .all(|i: u32| filter.as_ref().is_none_or(|f| f.contains(&i)))
        };
        let sm_kept = path
            .split('.')
            .filter_map(|seg| seg.strip_prefix("sm").or(seg.strip_prefix("l1d"))?.parse::<u32>().ok())
            .all(|k| self.sms.as_ref().is_none_or(|f| f.contains(&k)));
        keep(&self.warps, "warp[") && keep(&self.lanes, "thread[") && sm_kept
    }

    fn describe_window(&self) -> String {
        let to = self.to.map_or("end".to_string(), |t| t.to_string());
        format!("[{},{to}]", self.from.unwrap_or(0))
    }
}

/// What the command line asks for: `--vcd FILE --vcd-from A --vcd-to B --vcd-warps W,…
/// --vcd-lanes L,…`.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VcdOptions {
    pub path: PathBuf,
    pub select: Selection,
}

/// Why a dump was refused or failed. Every message names the offending value.
#[derive(Debug)]
pub enum VcdError {
    Window {
        from: u64,
        to: u64,
    },
    OutsideRun {
        window: String,
        cycles: u64,
    },
    NoSuchWarp {
        warp: u32,
        warps: u32,
    },
    NoSuchLane {
        lane: u32,
        warp_size: u32,
    },
    /// Found on the first probe walk: the SM count is the hardware's, not the configuration's.
    NoSuchSm {
        sm: u32,
        sms: u32,
    },
    Io {
        path: String,
        error: io::Error,
    },
    /// A probe walk that does not match the first one: the declarations would be wrong.
    Walk {
        cycle: u64,
        signals: usize,
        declared: usize,
    },
    /// A probe reported a value wider than its declared width.
    TooWide {
        cycle: u64,
        path: String,
        width: u32,
        value: u64,
    },
}

impl fmt::Display for VcdError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            VcdError::Window { from, to } => {
                write!(f, "VCD window: from {from} is after to {to}")
            }
            VcdError::OutsideRun { window, cycles } => {
                write!(f, "VCD window {window} is outside the run (0..{cycles} cycles)")
            }
            VcdError::NoSuchWarp { warp, warps } => {
                write!(f, "VCD warp {warp} does not exist: the configuration has {warps} warps (0..{warps})")
            }
            VcdError::NoSuchLane { lane, warp_size } => {
                write!(f, "VCD lane {lane} does not exist: warps have {warp_size} lanes (0..{warp_size})")
            }
            VcdError::NoSuchSm { sm, sms } => {
                write!(f, "VCD SM {sm} does not exist: the run has {sms} SMs (0..{sms})")
            }
            VcdError::Io { path, error } => write!(f, "cannot write {path}: {error}"),
            VcdError::Walk { cycle, signals, declared } => {
                write!(f, "probe walk of cycle {cycle} had {signals} signals, the first walk {declared}")
            }
            VcdError::TooWide { cycle, path, width, value } => {
                write!(f, "cycle {cycle}: {path} = {value} does not fit its {width} bits")
            }
        }
    }
}

impl std::error::Error for VcdError {}

/// One walk position: its wire (`None` when filtered out), width and last value.
#[derive(Clone, Copy, Debug)]
struct Slot {
    id: Option<IdCode>,
    width: u32,
    last: u64,
    /// The value that means an RB → SH spill, for a micro-op signal.
    spill: Option<u64>,
}

/// Writes the probe walks of a run as VCD. See the module docs.
pub struct VcdSink<W: Write> {
    out: W,
    /// Where `out` goes, for messages.
    name: String,
    select: Selection,
    /// The first walk, until it is declared.
    first: Option<Snapshot>,
    slots: Vec<Slot>,
    /// Declared signals, `(path, width)` in walk order.
    declared: Vec<(String, u32)>,
    /// Their declared kinds.
    kinds: Vec<Kind>,
    pos: usize,
    cycle: Option<u64>,
    /// A timestamp for the current cycle has been written.
    stamped: bool,
    /// Every selected value has been written once (at the window's first cycle).
    dumped: bool,
    /// Save file to write at the end, and the dump it opens (both absolute).
    gtkw: Option<(PathBuf, PathBuf)>,
    error: Option<VcdError>,
    /// The run's length, when the driver says ([`Sink::end_run`]).
    run_cycles: Option<u64>,
    /// The clock's identifier, once declared.
    clk: Option<IdCode>,
    /// First cycle a dumped micro-op signal shows an RB → SH spill, and that signal's walk
    /// position (the save file's focus).
    first_spill: Option<(u64, usize)>,
}

impl VcdSink<BufWriter<File>> {
    /// Opens `opts.path` for a run of configuration `cfg`; [`VcdSink::finish`] also writes
    /// the GTKWave save file next to it (same name, `.gtkw`).
    pub fn create(opts: &VcdOptions, cfg: &Config) -> Result<Self, VcdError> {
        opts.select.validate(cfg)?;
        let name = opts.path.display().to_string();
        let file = File::create(&opts.path).map_err(io_error(&name))?;
        // Absolute, so the save file opens from any directory; GTKWave also finds the dump
        // relative to the save file when both move together.
        let dump = std::fs::canonicalize(&opts.path).map_err(io_error(&name))?;
        let mut sink = VcdSink::new(BufWriter::new(file), opts.select.clone(), cfg)?;
        sink.name = name;
        sink.gtkw = Some((dump.with_extension("gtkw"), dump));
        Ok(sink)
    }
}

impl<W: Write> VcdSink<W> {
    /// Dumps to any writer (no save file).
    pub fn new(out: W, select: Selection, cfg: &Config) -> Result<Self, VcdError> {
        select.validate(cfg)?;
        Ok(VcdSink {
            out,
            name: "VCD output".to_string(),
            select,
            first: Some(Snapshot::default()),
            slots: Vec::new(),
            declared: Vec::new(),
            kinds: Vec::new(),
            pos: 0,
            cycle: None,
            stamped: false,
            dumped: false,
            gtkw: None,
            error: None,
            run_cycles: None,
            clk: None,
            first_spill: None,
        })
    }

    /// Declared signals, `(path, width)` in walk order (empty before the first walk ends).
    pub fn signals(&self) -> &[(String, u32)] {
        &self.declared
    }

    /// Ends the dump: reports any error met during the run, closes the last cycle, flushes,
    /// writes the save file if [`VcdSink::create`] made this sink, and returns the writer.
    pub fn finish(mut self) -> Result<W, VcdError> {
        self.end_walk();
        let cycles = self.run_cycles.unwrap_or(self.cycle.map_or(0, |c| c + 1));
        if !self.dumped {
            self.fail(VcdError::OutsideRun { window: self.select.describe_window(), cycles });
        }
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        // One more timestamp so the last written cycle has a width in a viewer.
        let end = self.select.to.map_or(cycles, |t| cycles.min(t + 1));
        let r = writeln!(self.out, "#{}", end * UNITS_PER_CYCLE).and_then(|()| self.out.flush());
        r.map_err(io_error(&self.name))?;
        if let Some((save, dump)) = &self.gtkw {
            let from = self.select.from.unwrap_or(0);
            let signals: Vec<_> =
                self.declared.iter().zip(&self.kinds).map(|((p, w), k)| (p.clone(), *w, *k)).collect();
            let spill = self.first_spill.map(|(cycle, pos)| (cycle, self.declared_path(pos)));
            let view = gtkw::View::around(from, end, spill);
            gtkw::write(save, dump, &signals, view).map_err(io_error(&save.display().to_string()))?;
        }
        Ok(self.out)
    }

    fn fail(&mut self, e: VcdError) {
        self.error.get_or_insert(e);
    }

    fn io(&mut self, r: io::Result<()>) {
        if let Err(e) = r {
            let e = io_error(&self.name)(e);
            self.fail(e);
        }
    }

    /// Closes the walk in progress: the first one is declared and written, later ones checked.
    fn end_walk(&mut self) {
        let Some(cycle) = self.cycle else { return };
        if let Some(first) = self.first.take() {
            self.check_sms(&first);
            let r = self.declare(&first);
            self.io(r);
            for (i, &(_, _, value)) in first.signals.iter().enumerate() {
                self.value(cycle, i, value);
            }
        } else if self.pos != self.slots.len() {
            self.fail(VcdError::Walk { cycle, signals: self.pos, declared: self.slots.len() });
        }
        if self.select.in_window(cycle) {
            self.dumped = true;
            // The clock ticks in every dumped cycle, whether or not anything else changed.
            self.stamp(cycle);
            if let Some(clk) = self.clk {
                let r = writeln!(self.out, "#{}\n0{clk}", cycle * UNITS_PER_CYCLE + UNITS_PER_CYCLE / 2);
                self.io(r);
            }
        }
    }

    /// Opens cycle `cycle` in the dump (its timestamp and the clock's rise), once.
    fn stamp(&mut self, cycle: u64) {
        if self.stamped {
            return;
        }
        self.stamped = true;
        let r = writeln!(self.out, "#{}", cycle * UNITS_PER_CYCLE);
        self.io(r);
        if let Some(clk) = self.clk {
            let r = writeln!(self.out, "1{clk}");
            self.io(r);
        }
    }

    /// Every SM the selection names has an `sm<k>` scope in the walk.
    fn check_sms(&mut self, first: &Snapshot) {
        let Some(sms) = &self.select.sms else { return };
        let present = first
            .signals
            .iter()
            .filter_map(|(p, _, _)| p.split('.').next()?.strip_prefix("sm")?.parse::<u32>().ok())
            .max()
            .map_or(0, |k| k + 1);
        if let Some(&sm) = sms.iter().find(|&&k| k >= present) {
            self.fail(VcdError::NoSuchSm { sm, sms: present });
        }
    }

    fn declare(&mut self, first: &Snapshot) -> io::Result<()> {
        let w = &mut vcd::Writer::new(&mut self.out);
        w.version("sms tb::vcd")?;
        w.comment(&format!(
            "one clock cycle = {UNITS_PER_CYCLE} time units = 1 s on the time axis: read seconds as cycles; \
             {CLOCK} rises at each cycle's start"
        ))?;
        w.timescale(TIMESCALE.0, TIMESCALE.1)?;
        self.clk = Some(w.add_wire(1, CLOCK)?);
        let mut open: Vec<&str> = Vec::new();
        for (i, (path, width, _)) in first.signals.iter().enumerate() {
            // Zero-width fields do not exist in this configuration; VCD has no such wire.
            if !self.select.selects(path) || *width == 0 {
                self.slots.push(Slot { id: None, width: *width, last: 0, spill: None });
                continue;
            }
            let mut parts: Vec<&str> = path.split('.').collect();
            let name = parts.pop().unwrap_or_default();
            let common = open.iter().zip(&parts).take_while(|(a, b)| a == b).count();
            for _ in common..open.len() {
                w.upscope()?;
            }
            open.truncate(common);
            for scope in &parts[common..] {
                w.add_module(scope)?;
                open.push(scope);
            }
            let id = w.add_wire(*width, name)?;
            let kind = first.kinds.get(i).copied().unwrap_or_default();
            let spill = match kind {
                Kind::Enum { name: "uop", names } => {
                    names.iter().position(|n| *n == SPILL_UOP).map(|c| c as u64)
                }
                _ => None,
            };
            self.slots.push(Slot { id: Some(id), width: *width, last: 0, spill });
            self.declared.push((path.clone(), *width));
            self.kinds.push(kind);
        }
        for _ in &open {
            w.upscope()?;
        }
        w.enddefinitions()
    }

    /// Signal at walk position `pos` has `value` in `cycle`: written if selected, in the window,
    /// and changed (or not yet written at all).
    fn value(&mut self, cycle: u64, pos: usize, value: u64) {
        let slot = self.slots[pos];
        self.slots[pos].last = value;
        let Some(id) = slot.id else { return };
        if !self.select.in_window(cycle) || (self.dumped && slot.last == value) {
            return;
        }
        if slot.width < 64 && value >> slot.width != 0 {
            let path = self.declared_path(pos);
            return self.fail(VcdError::TooWide { cycle, path, width: slot.width, value });
        }
        self.stamp(cycle);
        if slot.spill == Some(value) && self.first_spill.is_none() {
            self.first_spill = Some((cycle, pos));
        }
        let out = &mut self.out;
        let r = if slot.width == 1 { writeln!(out, "{value}{id}") } else { writeln!(out, "b{value:b} {id}") };
        self.io(r);
    }

    fn declared_path(&self, pos: usize) -> String {
        let index = self.slots[..pos].iter().filter(|s| s.id.is_some()).count();
        self.declared[index].0.clone()
    }
}

impl<W: Write> Sink for VcdSink<W> {
    fn enabled(&self) -> bool {
        self.error.is_none()
    }

    /// Every cycle until the declarations are made (first walk), then only the window's.
    fn next_wanted(&self, cycle: u64) -> Option<u64> {
        if !self.enabled() {
            return None;
        }
        if self.first.is_some() {
            return Some(cycle);
        }
        let from = cycle.max(self.select.from.unwrap_or(0));
        self.select.to.is_none_or(|to| from <= to).then_some(from)
    }

    fn end_run(&mut self, cycles: u64) {
        self.run_cycles = Some(cycles);
    }

    fn begin_cycle(&mut self, cycle: u64) {
        self.end_walk();
        self.cycle = Some(cycle);
        self.pos = 0;
        self.stamped = false;
    }

    fn push_scope(&mut self, name: &str) {
        if let Some(first) = &mut self.first {
            first.push_scope(name);
        }
    }

    fn pop_scope(&mut self) {
        if let Some(first) = &mut self.first {
            first.pop_scope();
        }
    }

    fn signal(&mut self, name: &str, width: u32, value: u64) {
        self.signal_kind(name, width, value, Kind::Number);
    }

    fn signal_kind(&mut self, name: &str, width: u32, value: u64, kind: Kind) {
        if let Some(first) = &mut self.first {
            return first.signal_kind(name, width, value, kind);
        }
        let Some(cycle) = self.cycle else { return };
        if self.pos < self.slots.len() {
            self.value(cycle, self.pos, value);
        }
        self.pos += 1;
    }
}

fn io_error(path: &str) -> impl FnOnce(io::Error) -> VcdError {
    let path = path.to_string();
    move |error| VcdError::Io { path, error }
}

/// Feeds one probe walk to two sinks, e.g. a [`VcdSink`] and a [`check::Recorder`].
pub struct Tee<'a, A: Sink, B: Sink>(pub &'a mut A, pub &'a mut B);

impl<A: Sink, B: Sink> Sink for Tee<'_, A, B> {
    fn enabled(&self) -> bool {
        self.0.enabled() || self.1.enabled()
    }
    fn next_wanted(&self, cycle: u64) -> Option<u64> {
        match (self.0.next_wanted(cycle), self.1.next_wanted(cycle)) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }
    fn begin_cycle(&mut self, cycle: u64) {
        self.0.begin_cycle(cycle);
        self.1.begin_cycle(cycle);
    }
    fn end_run(&mut self, cycles: u64) {
        self.0.end_run(cycles);
        self.1.end_run(cycles);
    }
    fn push_scope(&mut self, name: &str) {
        self.0.push_scope(name);
        self.1.push_scope(name);
    }
    fn pop_scope(&mut self) {
        self.0.pop_scope();
        self.1.pop_scope();
    }
    fn signal(&mut self, name: &str, width: u32, value: u64) {
        self.0.signal(name, width, value);
        self.1.signal(name, width, value);
    }
    fn signal_kind(&mut self, name: &str, width: u32, value: u64, kind: Kind) {
        self.0.signal_kind(name, width, value, kind);
        self.1.signal_kind(name, width, value, kind);
    }
}
