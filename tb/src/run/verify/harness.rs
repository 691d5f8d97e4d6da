//! Drivers: feed per-thread operation streams to the RTL with the reference and the checks on.
//!
//! - [`run_functional`]: a sequence of `(thread, command)` applied one at a time at the
//!   functional level (micro-ops complete at once); after every command the thread and its warp
//!   are checked. Commands the reference calls invalid must be *reported* by the design.
//! - [`run_cycle`]: warps of per-lane streams run cycle by cycle through the stack unit (bank
//!   arbiter, memory scheduler, global latency), every pop checked by the [`Scoreboard`], every
//!   warp checked when it leaves.

use rtl::config::{Config, Overflow};
use rtl::stack_manager::{Cmd, StackError, StackManager};
use rtl::stack_unit::{StandaloneStack, UnitStats};
use rtl::trace::{Probe, Sink};

use super::invariants::{check_thread, check_warp, check_warp_exit, fail, Property, Violation};
use super::reference::RefStack;

/// One stack operation of a thread's stream; the stream ends with an implied finish.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Op {
    Push(u64),
    Pop,
}

/// Reference stacks of every thread, checking each pop the design answers.
///
/// Its hash covers the reference stacks and the finished flags only, not `pops_checked` (a
/// counter): two scoreboards that agree on everything that decides future answers hash equal,
/// so the exhaustive search merges them.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Scoreboard {
    refs: Vec<RefStack>,
    done: Vec<bool>,
    pub pops_checked: u64,
    /// The design drops entries on overflow (`+RT`): a pop may answer Restart.
    drops: bool,
}

/// Field by field, so that `clone_from` keeps the allocations.
impl Clone for Scoreboard {
    fn clone(&self) -> Self {
        let Scoreboard { refs, done, pops_checked, drops } = self;
        Scoreboard { refs: refs.clone(), done: done.clone(), pops_checked: *pops_checked, drops: *drops }
    }
    fn clone_from(&mut self, src: &Self) {
        let Scoreboard { refs, done, pops_checked, drops } = src;
        self.refs.clone_from(refs);
        self.done.clone_from(done);
        self.pops_checked = *pops_checked;
        self.drops = *drops;
    }
}

impl std::hash::Hash for Scoreboard {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        self.refs.hash(h);
        self.done.hash(h);
    }
}

impl Scoreboard {
    /// The reference stacks of `cfg`'s threads.
    pub fn new(cfg: &Config) -> Self {
        let threads = cfg.threads() as usize;
        Scoreboard {
            refs: vec![RefStack::default(); threads],
            done: vec![false; threads],
            pops_checked: 0,
            drops: cfg.overflow == Overflow::Drop,
        }
    }

    pub fn reference(&self, t: u32) -> &RefStack {
        &self.refs[t as usize]
    }

    /// A new warp in slot `w`: its threads start empty; inactive lanes start finished.
    pub fn load_warp(&mut self, threads: std::ops::Range<u32>, active: u32) {
        for t in threads.clone() {
            self.refs[t as usize] = RefStack::default();
            self.done[t as usize] = active & (1 << (t - threads.start)) == 0;
        }
    }

    /// Checks the design's answer to `cmd` from thread `t` against the reference, and advances
    /// the reference. Invalid commands must be refused with the matching error.
    pub fn check(&mut self, t: u32, cmd: Cmd, got: Result<Option<u64>, StackError>) -> Result<(), Violation> {
        let r = &mut self.refs[t as usize];
        let done = &mut self.done[t as usize];
        let expect: Result<Option<u64>, StackError> = match cmd {
            Cmd::None => Ok(None),
            _ if *done => Err(StackError::AfterFinish { thread: t }),
            Cmd::Push(v) => {
                r.push(v);
                Ok(None)
            }
            // A restart design answers Restart only when it dropped entries, so only when the
            // reference still holds some; every one of them was dropped (the checks after each
            // command see that the design holds the reference's newest entries).
            Cmd::Pop if self.drops && got == Ok(None) && !r.is_empty() => {
                r.clear();
                Ok(None)
            }
            Cmd::Pop => r.pop().map(Some).ok_or(StackError::PopEmpty { thread: t }),
            Cmd::Finish if !r.is_empty() => Err(StackError::FinishNonEmpty { thread: t }),
            Cmd::Finish => {
                *done = true;
                Ok(None)
            }
        };
        let same = match (&expect, &got) {
            (Ok(a), Ok(b)) => a == b,
            (Err(a), Err(b)) => a == b,
            _ => false,
        };
        if cmd == Cmd::Pop {
            self.pops_checked += 1;
        }
        if !same {
            // A refused push must not stay in the reference.
            if let (Cmd::Push(_), Err(_)) = (cmd, &got) {
                r.pop();
            }
            return fail(
                Property::Equivalence,
                format!("thread {t}: {cmd:?} answered {got:?}, reference {expect:?}"),
            );
        }
        Ok(())
    }
}

/// Functional level: applies `seq` one command at a time; after each, checks the thread and its
/// warp. Returns the scoreboard.
pub fn run_functional(sm: &mut StackManager, seq: &[(u32, Cmd)]) -> Result<Scoreboard, Violation> {
    let mut sb = Scoreboard::new(sm.config());
    for &(t, cmd) in seq {
        let got = sm.apply(t, cmd);
        sb.check(t, cmd, got)?;
        check_thread(sm, t, sb.reference(t))?;
        check_warp(sm, sm.warp_of(t))?;
    }
    Ok(sb)
}

/// Per-lane streams of one warp; `None` = inactive lane.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WarpWork {
    pub lanes: Vec<Option<Vec<Op>>>,
}

/// Options of a cycle-level run.
#[derive(Clone, Copy, Debug)]
pub struct CycleOpts {
    /// Most idle cycles a lane waits between its commands (its "intersection work"); the actual
    /// gap is drawn per command from a hash of (seed, thread, command index).
    pub max_gap: u32,
    pub seed: u64,
    /// Check every quiescent warp's fields and stacks each cycle (slow; for tests).
    pub check_every_cycle: bool,
    /// Give up after this many cycles (a deadlock would otherwise run forever).
    pub max_cycles: u64,
    /// SIMT-style: a warp's lanes issue together, only when every unfinished lane is ready.
    pub lockstep: bool,
}

impl Default for CycleOpts {
    fn default() -> Self {
        CycleOpts { max_gap: 8, seed: 1, check_every_cycle: false, max_cycles: u64::MAX, lockstep: false }
    }
}

/// Why a cycle-level run stopped.
#[derive(Debug)]
pub enum HarnessError {
    Violation { cycle: u64, violation: Violation },
    Stack { cycle: u64, error: StackError },
    Timeout { cycles: u64 },
}

impl std::fmt::Display for HarnessError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            HarnessError::Violation { cycle, violation } => write!(f, "cycle {cycle}: {violation}"),
            HarnessError::Stack { cycle, error } => write!(f, "cycle {cycle}: {error}"),
            HarnessError::Timeout { cycles } => write!(f, "no progress after {cycles} cycles"),
        }
    }
}

impl std::error::Error for HarnessError {}

/// What a cycle-level run did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct RunSummary {
    pub stats: UnitStats,
    pub pops_checked: u64,
    pub warps: u64,
    pub skipped_cycles: u64,
}

#[derive(Clone, Debug)]
struct Lane {
    ops: Vec<Op>,
    pos: usize,
    next_at: u64,
    finished: bool,
}

/// A small deterministic hash (SplitMix64 finaliser).
pub fn mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// Cycle level: runs `work` through `unit`, up to `warps` warps resident at once, every pop
/// checked, every warp checked at exit. Signals go to `sink` every cycle.
pub fn run_cycle<I, S>(
    unit: &mut StandaloneStack,
    work: I,
    opts: CycleOpts,
    sink: &mut S,
) -> Result<RunSummary, HarnessError>
where
    I: IntoIterator<Item = WarpWork>,
    S: Sink,
{
    let cfg = *unit.manager().config();
    let ws = cfg.warp_size;
    let mut work = work.into_iter();
    let mut slots: Vec<Option<Vec<Lane>>> = vec![None; cfg.warps as usize];
    let mut sb = Scoreboard::new(&cfg);
    let mut summary = RunSummary::default();
    let mut cmds: Vec<(u32, Cmd)> = Vec::new();
    let mut exhausted = false;
    let violation = |cycle, violation| HarnessError::Violation { cycle, violation };
    loop {
        let now = unit.cycle;
        for (w, slot) in slots.iter_mut().enumerate() {
            if slot.is_some() || exhausted {
                continue;
            }
            let Some(job) = work.next() else {
                exhausted = true;
                break;
            };
            let mut active = 0u32;
            let lanes = (0..ws as usize)
                .map(|l| {
                    let ops = job.lanes.get(l).cloned().flatten();
                    active |= u32::from(ops.is_some()) << l;
                    Lane { ops: ops.unwrap_or_default(), pos: 0, next_at: now, finished: false }
                })
                .collect();
            unit.manager_mut().load_warp(w as u32, active);
            sb.load_warp(unit.manager().warp_threads(w as u32), active);
            *slot = Some(lanes);
            summary.warps += 1;
        }
        if exhausted && slots.iter().all(Option::is_none) {
            break;
        }
        cmds.clear();
        let mut earliest = u64::MAX;
        for (w, slot) in slots.iter_mut().enumerate() {
            let Some(lanes) = slot else { continue };
            let warp_threads = unit.manager().warp_threads(w as u32);
            if opts.lockstep && !warp_threads.clone().all(|t| unit.manager().ready(t)) {
                continue;
            }
            for (l, lane) in lanes.iter_mut().enumerate() {
                let t = w as u32 * ws + l as u32;
                if lane.finished || unit.manager().thread(t).done || !unit.manager().ready(t) {
                    continue;
                }
                if lane.next_at > now {
                    earliest = earliest.min(lane.next_at);
                    continue;
                }
                let cmd = match lane.ops.get(lane.pos) {
                    Some(Op::Push(v)) => Cmd::Push(*v),
                    Some(Op::Pop) => Cmd::Pop,
                    None => {
                        lane.finished = true;
                        Cmd::Finish
                    }
                };
                let h = mix(opts.seed ^ ((t as u64) << 40) ^ lane.pos as u64);
                lane.next_at = now + 1 + h % (opts.max_gap as u64 + 1);
                lane.pos += 1;
                cmds.push((t, cmd));
            }
        }
        unit.step(&cmds);
        for &(t, cmd) in &cmds {
            let got = unit.answer(t);
            if let Err(error @ StackError::SpillRegionFull { .. }) = got {
                return Err(HarnessError::Stack { cycle: now, error });
            }
            sb.check(t, cmd, got).map_err(|v| violation(now, v))?;
        }
        if sink.enabled() {
            sink.begin_cycle(now);
            unit.probe(sink);
        }
        for (w, slot) in slots.iter_mut().enumerate() {
            let w = w as u32;
            if slot.is_none() {
                continue;
            }
            if unit.manager().warp_done(w) {
                check_warp_exit(unit.manager(), w).map_err(|v| violation(now, v))?;
                *slot = None;
            } else if opts.check_every_cycle
                && unit.manager().warp_threads(w).all(|t| unit.manager().ready(t))
            {
                check_warp(unit.manager(), w).map_err(|v| violation(now, v))?;
                for t in unit.manager().warp_threads(w) {
                    check_thread(unit.manager(), t, sb.reference(t)).map_err(|v| violation(now, v))?;
                }
            }
        }
        if cmds.is_empty() && !sink.enabled() {
            summary.skipped_cycles += unit.skip_to_next_event(earliest);
        }
        if unit.cycle >= opts.max_cycles {
            return Err(HarnessError::Timeout { cycles: unit.cycle });
        }
    }
    summary.stats = unit.stats();
    summary.pops_checked = sb.pops_checked;
    Ok(summary)
}

/// Functional level over whole warps: lanes take turns, one command each per round (lockstep
/// order), micro-ops complete at once; every pop checked, every warp checked at exit.
/// Without reallocation the counts equal the cycle level's exactly (each thread's decisions depend
/// on its own history only); with it, borrowing depends on when threads finish.
pub fn run_functional_warps<I>(sm: &mut StackManager, work: I) -> Result<Scoreboard, Violation>
where
    I: IntoIterator<Item = WarpWork>,
{
    let cfg = *sm.config();
    let mut sb = Scoreboard::new(&cfg);
    for job in work {
        let w = 0;
        let active = (0..cfg.warp_size)
            .fold(0u32, |a, l| a | u32::from(matches!(job.lanes.get(l as usize), Some(Some(_)))) << l);
        sm.load_warp(w, active);
        sb.load_warp(sm.warp_threads(w), active);
        let longest = job.lanes.iter().flatten().map(Vec::len).max().unwrap_or(0);
        for i in 0..=longest {
            for (l, ops) in job.lanes.iter().enumerate() {
                let Some(ops) = ops else { continue };
                let t = w * cfg.warp_size + l as u32;
                let cmd = match ops.get(i) {
                    Some(Op::Push(v)) => Cmd::Push(*v),
                    Some(Op::Pop) => Cmd::Pop,
                    None if i == ops.len() => Cmd::Finish,
                    None => continue,
                };
                let got = sm.apply(t, cmd);
                sb.check(t, cmd, got)?;
            }
        }
        check_warp_exit(sm, w)?;
    }
    Ok(sb)
}
