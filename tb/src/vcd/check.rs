//! A strict VCD reader, so tests can trust a dump: structure checked, values replayed.
//!
//! GTKWave's own converters accept junk (see `shared/FACTS.md`), so the tests read every dump
//! back with the `vcd` crate's parser and check, beyond its syntax: every identifier used is
//! declared, time strictly increases, every value has exactly its declared width and is 0/1,
//! and every signal has a value at the first timestamp. A dump in [`super::TIMESCALE`] has
//! [`super::UNITS_PER_CYCLE`] units a cycle: its times are read back as cycles, and its top-level
//! clock must rise at every cycle's timestamp and fall half-way, with nothing else changing
//! then (the clock is checked, not listed among the signals). Vectors may be written without
//! leading zeros, as VCD allows, never wider than their wire. [`Mode::Lenient`] accepts what other
//! writers legally do (shortened vectors, scalars into vectors, aliased identifiers), for files
//! that went through GTKWave's tools. [`Waves::replay`] gives every signal's value per cycle,
//! and [`compare`] matches that against the RTL's own values from a [`Recorder`] walk.

use std::collections::HashMap;
use std::fmt;
use std::io::BufRead;
use std::ops::RangeInclusive;

use rtl::trace::{Sink, Snapshot};
use vcd::{Command, IdCode, ScopeItem, Value};

/// How much of the VCD standard's leeway to accept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// What [`super::VcdSink`] writes: full-width vectors, one identifier per signal.
    Strict,
    /// Also shortened (zero-extended) vectors, scalars into vectors, shared identifiers.
    Lenient,
}

/// A problem found in a dump, with the line it was found at.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CheckError {
    pub line: u64,
    pub message: String,
}

impl fmt::Display for CheckError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "VCD line {}: {}", self.line, self.message)
    }
}

impl std::error::Error for CheckError {}

/// A checked dump: its signals and, per timestamp, the values that changed.
#[derive(Clone, Debug, Default)]
pub struct Waves {
    /// `(path, width)`; scopes joined by '.', as [`Snapshot`] names them.
    pub signals: Vec<(String, u32)>,
    changes: Vec<(u64, Vec<(usize, u64)>)>,
}

impl Waves {
    pub fn index(&self, path: &str) -> Option<usize> {
        self.signals.iter().position(|s| s.0 == path)
    }

    /// Timestamps, in order.
    pub fn times(&self) -> impl Iterator<Item = u64> + '_ {
        self.changes.iter().map(|c| c.0)
    }

    /// Number of value changes in the file.
    pub fn change_count(&self) -> usize {
        self.changes.iter().map(|c| c.1.len()).sum()
    }

    pub fn replay(&self) -> Replay<'_> {
        Replay { waves: self, next: 0, values: vec![0; self.signals.len()] }
    }
}

/// Walks a dump forward in time.
pub struct Replay<'a> {
    waves: &'a Waves,
    next: usize,
    values: Vec<u64>,
}

impl Replay<'_> {
    /// Every signal's value at `cycle` (indexed like [`Waves::signals`]); `None` before the
    /// first timestamp. Cycles must not decrease from call to call.
    pub fn at(&mut self, cycle: u64) -> Option<&[u64]> {
        let changes = &self.waves.changes;
        while let Some((_, vals)) = changes.get(self.next).filter(|c| c.0 <= cycle) {
            for &(i, v) in vals {
                self.values[i] = v;
            }
            self.next += 1;
        }
        (self.next > 0).then_some(&self.values[..])
    }
}

/// Reads and checks a whole dump.
pub fn read(input: impl BufRead, mode: Mode) -> Result<Waves, CheckError> {
    let mut p = vcd::Parser::new(input);
    let header = match p.parse_header() {
        Ok(h) => h,
        Err(e) => return fail(p.line(), format!("bad header: {e}")),
    };
    let mut waves = Waves::default();
    let mut ids: HashMap<IdCode, Vec<usize>> = HashMap::new();
    let mut clock: Option<IdCode> = None;
    if let Err(message) = declare(&header.items, &mut Vec::new(), &mut waves, &mut ids, &mut clock, mode) {
        return fail(p.line(), message);
    }
    let units = if header.timescale == Some(super::TIMESCALE) { super::UNITS_PER_CYCLE } else { 1 };
    let mut assigned = vec![false; waves.signals.len()];
    // The last timestamp as written, and whether it is half-way through a cycle.
    let mut last: Option<u64> = None;
    let mut half = false;
    while let Some(cmd) = p.next() {
        let line = p.line();
        let cmd = match cmd {
            Ok(c) => c,
            Err(e) => return fail(line, format!("syntax: {e}")),
        };
        let (id, bits, scalar): (IdCode, Vec<Value>, bool) = match cmd {
            Command::Timestamp(t) => {
                if let Some(prev) = last {
                    if t <= prev {
                        return fail(line, format!("time {t} does not follow time {prev}"));
                    }
                }
                last = Some(t);
                half = t % units != 0;
                if half {
                    if t % units != units / 2 || clock.is_none() {
                        return fail(
                            line,
                            format!("time {t} is not a cycle's start or middle ({units} units a cycle)"),
                        );
                    }
                    continue;
                }
                if waves.changes.len() == 1 {
                    unassigned(&waves, &assigned).map_or(Ok(()), |m| fail(line, m))?;
                }
                waves.changes.push((t / units, Vec::new()));
                continue;
            }
            Command::Comment(_) | Command::Begin(_) | Command::End(_) => continue,
            Command::ChangeScalar(id, v) => (id, vec![v], true),
            Command::ChangeVector(id, v) => (id, v.iter().collect(), false),
            other => return fail(line, format!("unexpected command {other:?}")),
        };
        if Some(id) == clock {
            let want = if half { Value::V0 } else { Value::V1 };
            if bits != [want] {
                let when = if half { "fall half-way through" } else { "rise at the start of" };
                return fail(line, format!("{}: the clock must {when} each cycle", super::CLOCK));
            }
            continue;
        }
        if half {
            return fail(
                line,
                format!("identifier {id} changes half-way through a cycle: only the clock may"),
            );
        }
        let Some(targets) = ids.get(&id) else {
            return fail(line, format!("identifier {id} is not declared"));
        };
        let Some((_, changes)) = waves.changes.last_mut() else {
            return fail(line, format!("value of {id} before the first timestamp"));
        };
        for &i in targets {
            let (path, width) = &waves.signals[i];
            // VCD zero-extends a vector written short (the sink drops leading zeros); a
            // scalar written to a vector is the lenient mode's alone.
            let ok = match mode {
                Mode::Strict => bits.len() <= *width as usize && (bits.len() > 1 || *width == 1 || !scalar),
                Mode::Lenient => bits.len() <= *width as usize,
            };
            if !ok {
                let n = bits.len();
                return fail(line, format!("{path}: {n} bits written to a {width}-bit wire"));
            }
            let mut value = 0u64;
            for b in &bits {
                value = match b {
                    Value::V0 => value << 1,
                    Value::V1 => value << 1 | 1,
                    _ => return fail(line, format!("{path}: value {b} is not 0/1")),
                };
            }
            changes.push((i, value));
            assigned[i] = true;
        }
    }
    match waves.changes.len() {
        0 => fail(p.line(), "no timestamps".to_string()),
        1 => unassigned(&waves, &assigned).map_or(Ok(waves), |m| fail(p.line(), m)),
        _ => Ok(waves),
    }
}

/// Every signal must have a value once the first timestamp's changes are read.
fn unassigned(waves: &Waves, assigned: &[bool]) -> Option<String> {
    let i = assigned.iter().position(|a| !a)?;
    let t = waves.changes[0].0;
    Some(format!("{} has no value at time {t}", waves.signals[i].0))
}

fn fail<T>(line: u64, message: String) -> Result<T, CheckError> {
    Err(CheckError { line, message })
}

/// Declares the variables under `items`, scopes joined by '.'.
fn declare(
    items: &[ScopeItem],
    scope: &mut Vec<String>,
    waves: &mut Waves,
    ids: &mut HashMap<IdCode, Vec<usize>>,
    clock: &mut Option<IdCode>,
    mode: Mode,
) -> Result<(), String> {
    for item in items {
        match item {
            ScopeItem::Scope(s) => {
                scope.push(s.identifier.clone());
                declare(&s.items, scope, waves, ids, clock, mode)?;
                scope.pop();
            }
            ScopeItem::Var(v) if scope.is_empty() && v.reference == super::CLOCK && v.size == 1 => {
                *clock = Some(v.code);
            }
            ScopeItem::Var(v) => {
                let mut path = scope.join(".");
                path.push('.');
                path.push_str(&v.reference);
                if scope.is_empty() {
                    return Err(format!("{} is declared outside any scope", v.reference));
                }
                if !(1..=64).contains(&v.size) {
                    return Err(format!("{path}: width {} is not 1..=64", v.size));
                }
                if waves.index(&path).is_some() {
                    return Err(format!("{path} is declared twice"));
                }
                let same = ids.entry(v.code).or_default();
                if mode == Mode::Strict && !same.is_empty() {
                    return Err(format!("identifier {} is declared twice ({path})", v.code));
                }
                same.push(waves.signals.len());
                waves.signals.push((path, v.size));
            }
            _ => {}
        }
    }
    Ok(())
}

/// Records every probe walk of a run: the first walk's paths (through a [`Snapshot`]) and
/// every walk's values.
#[derive(Clone, Debug, Default)]
pub struct Recorder {
    first: Snapshot,
    cycles: Vec<u64>,
    values: Vec<u64>,
}

impl Recorder {
    /// `(path, width)` of every signal, in walk order.
    pub fn signals(&self) -> impl Iterator<Item = (&str, u32)> {
        self.first.signals.iter().map(|s| (s.0.as_str(), s.1))
    }

    /// Cycles walked, in order.
    pub fn cycles(&self) -> &[u64] {
        &self.cycles
    }

    /// Values of walk `i` (of cycle `cycles()[i]`), in walk order.
    pub fn walk(&self, i: usize) -> &[u64] {
        let n = self.first.signals.len();
        &self.values[i * n..(i + 1) * n]
    }
}

impl Sink for Recorder {
    fn enabled(&self) -> bool {
        true
    }
    fn begin_cycle(&mut self, cycle: u64) {
        self.cycles.push(cycle);
    }
    fn push_scope(&mut self, name: &str) {
        if self.cycles.len() == 1 {
            self.first.push_scope(name);
        }
    }
    fn pop_scope(&mut self) {
        if self.cycles.len() == 1 {
            self.first.pop_scope();
        }
    }
    fn signal(&mut self, name: &str, width: u32, value: u64) {
        if self.cycles.len() == 1 {
            self.first.signal(name, width, value);
        }
        self.values.push(value);
    }
}

/// Checks that the dump shows, at every recorded cycle in `window`, exactly the values the RTL
/// reported, for every signal in the dump (each must be a recorded signal of the same width).
/// Returns how many values were compared.
pub fn compare(waves: &Waves, rec: &Recorder, window: RangeInclusive<u64>) -> Result<usize, String> {
    let recorded: HashMap<&str, (usize, u32)> =
        rec.signals().enumerate().map(|(i, (path, width))| (path, (i, width))).collect();
    let mut map = Vec::new();
    for (path, width) in &waves.signals {
        match recorded.get(path.as_str()) {
            Some(&(i, w)) if w == *width => map.push(i),
            Some(&(_, w)) => return Err(format!("{path}: dump width {width}, RTL width {w}")),
            None => return Err(format!("{path} is not an RTL signal")),
        }
    }
    let mut replay = waves.replay();
    let mut compared = 0;
    for (k, &cycle) in rec.cycles().iter().enumerate() {
        if !window.contains(&cycle) {
            continue;
        }
        let Some(dumped) = replay.at(cycle) else {
            return Err(format!("cycle {cycle}: the dump has no values yet"));
        };
        let rtl = rec.walk(k);
        for (j, &i) in map.iter().enumerate() {
            if dumped[j] != rtl[i] {
                let path = &waves.signals[j].0;
                let (d, r) = (dumped[j], rtl[i]);
                return Err(format!("cycle {cycle}: {path} is {d} in the dump, {r} in the RTL"));
            }
        }
        compared += map.len();
    }
    Ok(compared)
}
