//! The model an exhaustive search explores: one warp's stack manager and its reference
//! scoreboard, stepped one [`Action`] at a time with every property checked after it, and the
//! state key that decides which states are equal. Held apart from the search so the random and
//! Kani harnesses drive the same checked steps.

use std::hash::{Hash, Hasher};

use rtl::config::Config;
use rtl::stack_manager::{Cmd, Src, StackError, StackManager, StackRegs, Uop, POISON};

use crate::run::verify::harness::Scoreboard;
use crate::run::verify::invariants::{
    check_bank_map, check_placement, check_thread, check_warp_exit, check_warp_fields, fail, Property,
    Violation,
};
use crate::run::verify::sequence::{check_sequence, expected_flush_counts, Before};

use super::checks::{check_flush_counts, live_reads};
use super::coverage::{observe_covers, Coverage, Goal};
use super::key::{state_hash, KeyHasher};

/// One step of an explored sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Action {
    Cmd(u32, Cmd),
    /// Two threads' commands in one cycle, planned in this order (the second sees the stack
    /// registers the first changed).
    Both(u32, Cmd, u32, Cmd),
    /// Thread's next micro-op completes.
    Uop(u32),
    /// In one cycle the first thread's next micro-op completes and the second thread's
    /// command is planned (the two threads may be one: its command is then refused, the thread
    /// being busy as the cycle begins).
    UopWithCmd(u32, u32, Cmd),
}

/// The design under test and its reference, checked after every action.
#[derive(Debug)]
pub struct Model {
    pub sm: StackManager,
    pub sb: Scoreboard,
    /// Per thread of the warp: what its sequencer's data latch holds, and the values its
    /// pending global loads will read (captured when the command is accepted). Tracked here
    /// from the micro-ops so the state key can leave stale memory out.
    pub(super) shadow: Vec<Shadow>,
    /// Some thread of the warp borrowed on the way here: one bit of path history, part of the
    /// state so the warp-exit-after-a-borrow cover is not lost when paths merge.
    pub(super) borrowed: bool,
    /// Check [`Property::RequestSequence`] on every accepted command (on by default; off to
    /// show the state properties catch a bug on their own).
    pub request_sequence: bool,
    /// Offer the marked value [`MARKED`] to at most one push per run; every other push carries
    /// [`UNMARKED`] (see the module doc: one mark suffices). Off: every value 1..=values.
    pub one_mark: bool,
    /// A push of [`MARKED`] was accepted on the way here (path history, part of the state).
    pub(super) marked: bool,
    /// The warp explored ([`Bounds::warp`]).
    pub warp: u32,
    /// Offer commands to busy threads too ([`Bounds::busy_cmds`]).
    pub busy_cmds: bool,
    /// Offer two threads' commands in one cycle too ([`Bounds::pairs`]).
    pub pairs: bool,
    /// Overwrite dead SH words after every action ([`Bounds::scrub`]).
    pub scrub_dead: bool,
    /// Lanes never offered a command ([`Bounds::silent`]).
    pub silent: u32,
    /// Offer a micro-op completion and a command in one cycle too ([`Bounds::uop_cmds`]).
    pub uop_cmds: bool,
    /// Check [`Property::FlushCount`] ([`Bounds::flush_count`]).
    pub flush_count: bool,
    /// Per lane of the warp: the consecutive flushes of its stack as the checker counts them
    /// from the accepted commands and SPEC section 5 ([`expected_flush_counts`]), never from the
    /// design's Flush register. Not part of the state key: while [`Property::FlushCount`] holds
    /// it equals the registers the key hashes.
    pub(super) flushes: Vec<u32>,
}

/// The one distinguished push value of a [`Bounds::one_mark`] run.
pub const MARKED: u64 = 1;
/// Every other push value of such a run.
pub const UNMARKED: u64 = 2;

#[derive(Debug, Default, PartialEq, Eq, Hash)]
pub(super) struct Shadow {
    pub(super) latch: Option<u64>,
    pub(super) global_loads: std::collections::VecDeque<u64>,
}

impl Clone for Shadow {
    fn clone(&self) -> Self {
        Shadow { latch: self.latch, global_loads: self.global_loads.clone() }
    }
    fn clone_from(&mut self, src: &Self) {
        self.latch = src.latch;
        self.global_loads.clone_from(&src.global_loads);
    }
}

/// Field by field, so that `clone_from` reuses every allocation of the model it overwrites: the
/// searches clone a model for each transition they try, and most of those land on a state seen
/// before. Both functions name every field, so a new field not cloned here does not compile.
impl Clone for Model {
    fn clone(&self) -> Self {
        let Model {
            sm,
            sb,
            shadow,
            borrowed,
            request_sequence,
            one_mark,
            marked,
            warp,
            busy_cmds,
            pairs,
            scrub_dead,
            silent,
            uop_cmds,
            flush_count,
            flushes,
        } = self;
        Model {
            sm: sm.clone(),
            sb: sb.clone(),
            shadow: shadow.clone(),
            borrowed: *borrowed,
            request_sequence: *request_sequence,
            one_mark: *one_mark,
            marked: *marked,
            warp: *warp,
            busy_cmds: *busy_cmds,
            pairs: *pairs,
            scrub_dead: *scrub_dead,
            silent: *silent,
            uop_cmds: *uop_cmds,
            flush_count: *flush_count,
            flushes: flushes.clone(),
        }
    }
    fn clone_from(&mut self, src: &Self) {
        let Model {
            sm,
            sb,
            shadow,
            borrowed,
            request_sequence,
            one_mark,
            marked,
            warp,
            busy_cmds,
            pairs,
            scrub_dead,
            silent,
            uop_cmds,
            flush_count,
            flushes,
        } = src;
        self.sm.clone_from(sm);
        self.sb.clone_from(sb);
        self.shadow.clone_from(shadow);
        self.borrowed = *borrowed;
        self.request_sequence = *request_sequence;
        self.one_mark = *one_mark;
        self.marked = *marked;
        self.warp = *warp;
        self.busy_cmds = *busy_cmds;
        self.pairs = *pairs;
        self.scrub_dead = *scrub_dead;
        self.silent = *silent;
        self.uop_cmds = *uop_cmds;
        self.flush_count = *flush_count;
        self.flushes.clone_from(flushes);
    }
}

impl Model {
    /// One warp of `cfg` (its `warps` is forced to 1).
    pub fn new(cfg: Config) -> Result<Model, rtl::config::ConfigError> {
        Model::on_warp(cfg, 0)
    }

    /// Warp `warp` of `cfg`, whose `warps` is forced to `warp + 1` (the warps below stay as
    /// reset and take no commands).
    pub fn on_warp(cfg: Config, warp: u32) -> Result<Model, rtl::config::ConfigError> {
        let cfg = Config { warps: warp + 1, ..cfg };
        Ok(Model {
            sm: StackManager::new(cfg, 0)?,
            sb: Scoreboard::new(&cfg),
            shadow: vec![Shadow::default(); cfg.threads() as usize],
            borrowed: false,
            request_sequence: true,
            one_mark: false,
            marked: false,
            warp,
            busy_cmds: false,
            pairs: false,
            scrub_dead: true,
            silent: 0,
            uop_cmds: false,
            flush_count: true,
            flushes: vec![0; cfg.warp_size as usize],
        })
    }

    /// Thread `t` is never offered a command ([`Bounds::silent`]).
    pub(super) fn is_silent(&self, t: u32) -> bool {
        self.silent >> (t % self.sm.config().warp_size) & 1 == 1
    }

    /// The explored warp's threads.
    pub fn threads(&self) -> std::ops::Range<u32> {
        self.sm.warp_threads(self.warp)
    }

    /// The state key: a 128-bit hash of everything that decides the warp's future behaviour —
    /// thread and stack registers, RB entries, pending micro-ops, data latches, the values
    /// pending global loads will read, every SH word of the warp's stacks, the global slots
    /// and the reference stacks — and no event counter. Stale SH words are not state because
    /// every action ends by overwriting them with [`POISON`] ([`Model::scrub`]): the model
    /// itself holds no history in dead memory, so two states with equal keys behave alike
    /// forever. A design that reads a dead word ([`Property::LiveReads`]) or moves a pointer
    /// over one it never stored reads POISON, which no push carries.
    pub fn key(&self) -> u128 {
        let mut h = KeyHasher::new();
        self.hash_live(&mut h);
        h.key()
    }

    fn hash_live<H: Hasher>(&self, h: &mut H) {
        let sm = &self.sm;
        let m = sm.config().sh_entries;
        for t in sm.warp_threads(self.warp) {
            sm.thread(t).hash(h);
            let st = sm.stack(t);
            st.hash(h);
            sm.rb(t).hash(h);
            sm.global(t).hash(h);
            for e in 0..m {
                sm.sh_entry(t, e).hash(h);
            }
            h.write_u8(0xEE);
            for u in sm.pending_uops(t) {
                u.hash(h);
            }
            h.write_u8(0xEF);
        }
        self.shadow.hash(h);
        self.borrowed.hash(h);
        self.marked.hash(h);
        self.sb.hash(h);
    }

    /// Applies `a` and checks every property. Returns false if `a` does not apply (a micro-op of
    /// a thread with none pending). Then overwrites every dead SH word with [`POISON`]
    /// ([`Model::scrub`]).
    pub fn act(&mut self, a: Action, cov: &mut Coverage) -> Result<bool, Violation> {
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| self.act_checked(a, cov)));
        r.unwrap_or_else(|p| {
            let why = p
                .downcast_ref::<String>()
                .map(String::as_str)
                .or_else(|| p.downcast_ref::<&str>().copied())
                .unwrap_or("no message");
            fail(Property::InRange, format!("the design panicked on {a:?}: {why}"))
        })
    }

    fn act_checked(&mut self, a: Action, cov: &mut Coverage) -> Result<bool, Violation> {
        let r = match a {
            Action::Cmd(t, cmd) if !self.sm.ready(t) => self.refuse_busy(t, cmd, cov),
            Action::Both(t, c, u, d) => self.same_cycle((t, c), (u, d), cov),
            Action::UopWithCmd(u, t, c) => self.uop_with_cmd(u, (t, c), cov),
            Action::Cmd(..) | Action::Uop(_) => self.act_one(a, cov),
        };
        if r == Ok(true) && self.scrub_dead {
            self.scrub();
        }
        r
    }

    /// A command to a busy thread: the design must refuse it (Busy) and change nothing.
    fn refuse_busy(&mut self, t: u32, cmd: Cmd, cov: &mut Coverage) -> Result<bool, Violation> {
        let before = state_hash(&self.sm);
        let got = self.sm.accept(t, cmd);
        if got != Err(StackError::Busy { thread: t }) {
            return fail(Property::Busy, format!("thread {t} is busy: {cmd:?} answered {got:?}"));
        }
        if state_hash(&self.sm) != before {
            return fail(
                Property::Busy,
                format!("thread {t} is busy: the refused {cmd:?} changed the state"),
            );
        }
        cov.covers.hit(Goal::BusyRefusal);
        Ok(true)
    }

    /// Two threads' commands planned in one cycle: the design must answer and leave the state
    /// exactly as planning them one after the other does ([`Property::SameCycle`]); every other
    /// property is checked on the way, command by command.
    fn same_cycle(&mut self, a: (u32, Cmd), b: (u32, Cmd), cov: &mut Coverage) -> Result<bool, Violation> {
        let start = self.sm.clone();
        let mut one_by_one = start.clone();
        let want = [one_by_one.accept(a.0, a.1), one_by_one.accept(b.0, b.1)];
        let got = self.sm.accept_all(&[a, b]);
        if got != want || state_hash(&self.sm) != state_hash(&one_by_one) {
            return fail(
                Property::SameCycle,
                format!(
                    "threads {} and {} in one cycle ({:?}, {:?}) answered {got:?} and left another state \
                     than one after the other ({want:?})",
                    a.0, b.0, a.1, b.1
                ),
            );
        }
        // The same commands once more, one by one through the checked path, from the state
        // before the cycle (they end in the state the cycle left).
        self.sm = start;
        let b0 = self.sm.stats.borrows;
        self.act_one(Action::Cmd(a.0, a.1), cov)?;
        let b1 = self.sm.stats.borrows;
        self.act_one(Action::Cmd(b.0, b.1), cov)?;
        if b1 > b0 && self.sm.stats.borrows > b1 {
            cov.covers.hit(Goal::SameCycleBorrow);
        }
        Ok(true)
    }

    /// Thread `u`'s next micro-op completes and thread `t`'s command is planned in one cycle
    /// ([`StackManager::complete_and_accept`]). The design must answer and leave the state
    /// exactly as completing the micro-op and then planning the command one after the other
    /// does, except that a command of `u` itself is refused (Busy: `ready` is a register, so a
    /// thread is busy for the whole cycle its last micro-op completes in) and changes nothing
    /// ([`Property::SameCycle`]). Every other property is checked on the way, action by action.
    fn uop_with_cmd(&mut self, u: u32, (t, cmd): (u32, Cmd), cov: &mut Coverage) -> Result<bool, Violation> {
        let Some(&uop) = self.sm.pending_uops(u).next() else { return Ok(false) };
        let last = self.sm.pending_uops(u).count() == 1;
        let start = self.sm.clone();
        let mut one_by_one = start.clone();
        one_by_one.complete_next(u);
        let want = if t == u { Err(StackError::Busy { thread: t }) } else { one_by_one.accept(t, cmd) };
        let got = self.sm.complete_and_accept(&[u], &[(t, cmd)]);
        let then = if t == u { "refusing the command" } else { "then planning the command" };
        let cycle = format!("thread {u}'s {uop:?} completing in the cycle of thread {t}'s {cmd:?}");
        if got != [want] {
            return fail(
                Property::SameCycle,
                format!("{cycle} answered {got:?}; completing it and {then}: {want:?}"),
            );
        }
        if state_hash(&self.sm) != state_hash(&one_by_one) {
            return fail(
                Property::SameCycle,
                format!("{cycle} left another state than completing it and {then} (both answered {want:?})"),
            );
        }
        // The same cycle once more through the checked path, from the state before it.
        self.sm = start;
        self.act_one(Action::Uop(u), cov)?;
        if t == u {
            if last {
                cov.covers.hit(Goal::BusyAsLastUopCompletes);
            }
            return Ok(true);
        }
        self.act_one(Action::Cmd(t, cmd), cov)?;
        if let Uop::Release { stack } = uop {
            if self.sm.chain(t).contains(&stack) {
                cov.covers.hit(Goal::ReleaseMeetsBorrow);
            }
        }
        Ok(true)
    }

    /// Overwrites every SH word of the warp that is dead — outside its stack's Bottom..Top and
    /// named by no pending micro-op — with [`POISON`], which no push carries. Stale memory is
    /// then never state (the key hashes every word), and a design that revives a dead word
    /// without storing it shows POISON in the logical stack ([`Property::Conservation`]), what
    /// ever the word held before.
    pub(super) fn scrub(&mut self) {
        let sm = &self.sm;
        let m = sm.config().sh_entries;
        if m == 0 {
            return;
        }
        let base = self.warp * sm.config().warp_size;
        let mut live = vec![false; (sm.config().warp_size * m) as usize];
        for s in sm.warp_threads(self.warp) {
            let st = sm.stack(s);
            if !st.empty {
                let mut e = st.bottom;
                for _ in 0..st.count(m) {
                    live[((s - base) * m + e) as usize] = true;
                    e = (e + 1) % m;
                }
            }
            for u in sm.pending_uops(s) {
                if let Uop::ShLoad { stack, entry } | Uop::ShStore { stack, entry, .. } = *u {
                    live[((stack - base) * m + entry) as usize] = true;
                }
            }
        }
        for (i, _) in live.iter().enumerate().filter(|x| !x.1) {
            let (s, e) = (base + i as u32 / m, i as u32 % m);
            if self.sm.sh_entry(s, e) != POISON {
                self.sm.load_sh_entry(s, e, POISON);
            }
        }
    }

    fn act_one(&mut self, a: Action, cov: &mut Coverage) -> Result<bool, Violation> {
        let base = self.warp * self.sm.config().warp_size;
        let sm = &mut self.sm;
        let before = sm.stats;
        let ra = sm.config().realloc();
        // The chain before a pop, in ring order with each member's Priority then, for the
        // rotated-release cover.
        let ring_before: Option<Vec<(u32, u32)>> = match a {
            Action::Cmd(t, _) if ra.is_some() => {
                Some(sm.chain(t).into_iter().map(|s| (s, sm.stack(s).priority)).collect())
            }
            _ => None,
        };
        match a {
            Action::Cmd(t, cmd) => {
                let stacks: Vec<_> = sm.warp_threads(self.warp).map(|s| *sm.stack(s)).collect();
                let global = sm.global(t).to_vec();
                let (thread, rb) = (*sm.thread(t), sm.rb(t).clone());
                let got = sm.accept(t, cmd);
                let accepted = got.is_ok();
                self.marked |= self.one_mark && accepted && cmd == Cmd::Push(MARKED);
                self.sb.check(t, cmd, got)?;
                if self.request_sequence {
                    let before = Before { cfg: sm.config(), stacks: &stacks, thread, rb: &rb };
                    check_sequence(&before, base, t, cmd, accepted, sm.pending_uops(t))?;
                }
                if accepted && ra.is_some() {
                    // The checker's counts in place of the design's Flush registers.
                    let counted: Vec<StackRegs> = stacks
                        .iter()
                        .zip(&self.flushes)
                        .map(|(r, &flush)| StackRegs { flush, ..*r })
                        .collect();
                    let before = Before { cfg: sm.config(), stacks: &counted, thread, rb: &rb };
                    if let Some(f) = expected_flush_counts(&before, base, t, cmd) {
                        self.flushes = f;
                    }
                }
                let loads = live_reads(sm, t, &stacks, &global)?;
                self.shadow[t as usize].global_loads = loads;
            }
            Action::Uop(t) => {
                let Some(&u) = sm.pending_uops(t).next() else { return Ok(false) };
                if let Uop::ShLoad { stack, entry } | Uop::ShStore { stack, entry, .. } = u {
                    check_bank_map(sm.config(), stack, entry, sm.sh_read_request(stack, entry).words())?;
                }
                let sh = &mut self.shadow[t as usize];
                match u {
                    Uop::ShLoad { stack, entry } => sh.latch = Some(sm.sh_entry(stack, entry)),
                    Uop::GlobalLoad { .. } => sh.latch = sh.global_loads.pop_front(),
                    Uop::ShStore { src: Src::Latch, .. }
                    | Uop::GlobalStore { src: Src::Latch, .. }
                    | Uop::RbBottom => sh.latch = None,
                    _ => {}
                }
                sm.complete_next(t);
            }
            Action::Both(..) | Action::UopWithCmd(..) => {
                unreachable!(
                    "a cycle of several actions goes through Model::same_cycle or Model::uop_with_cmd"
                )
            }
        }
        let d = sm.stats.since(&before);
        cov.borrows += d.borrows;
        self.borrowed |= d.borrows > 0;
        cov.flushes += d.flushes;
        cov.global_reloads += d.global_loads();
        cov.releases += d.releases;
        if let Action::Cmd(t, _) = a {
            if let (true, Some(ring)) = (d.borrows > 0, &ring_before) {
                for s in sm.chain(t).into_iter().filter(|s| !ring.iter().any(|r| r.0 == *s)) {
                    check_placement(sm, s)?;
                }
            }
            let ring = ring_before.as_deref().filter(|_| matches!(a, Action::Cmd(_, Cmd::Pop)));
            observe_covers(sm, t, &d, ring, &mut cov.covers);
        }
        let quiescent = sm.quiescent();
        check_warp_fields(sm, self.warp, quiescent)?;
        if self.flush_count && ra.is_some() {
            check_flush_counts(sm, self.warp, &self.flushes)?;
        }
        for t in sm.warp_threads(self.warp).filter(|&t| sm.ready(t)) {
            check_thread(sm, t, self.sb.reference(t))?;
        }
        if quiescent && sm.warp_done(self.warp) {
            check_warp_exit(sm, self.warp)?;
            cov.warp_exits += 1;
            if self.borrowed {
                cov.covers.hit(Goal::ExitAfterBorrow);
            }
        }
        Ok(true)
    }

    /// Bytes the model occupies: its inline size plus the heap blocks it owns (an estimate from
    /// lengths through the public accessors, each block rounded up to 16 bytes with 16 bytes of
    /// allocator overhead; the stack manager's own vectors are counted from the configuration).
    pub fn bytes(&self) -> usize {
        let block = |n: usize| if n == 0 { 0 } else { n.div_ceil(16) * 16 + 16 };
        let sm = &self.sm;
        let n = sm.config().warp_size as usize;
        let m = sm.config().sh_entries as usize;
        let mut b = std::mem::size_of::<Model>();
        // threads, stacks, rb, seq, queued, sh_data, global: one block each.
        b += block(n * std::mem::size_of::<rtl::stack_manager::ThreadRegs>());
        b += block(n * std::mem::size_of::<StackRegs>());
        b += block(n * std::mem::size_of::<std::collections::VecDeque<u64>>());
        b += block(n * (std::mem::size_of::<std::collections::VecDeque<Uop>>() + 48));
        b += block(8) + block(n * m * 8);
        b += block(n * std::mem::size_of::<Vec<u64>>());
        for t in sm.warp_threads(self.warp) {
            b += block(sm.rb(t).len() * 8);
            b += block(sm.pending_uops(t).count() * std::mem::size_of::<Uop>());
            b += block(sm.global(t).len() * 8);
            b += block(self.sb.reference(t).len() * 8);
        }
        b += block(n * std::mem::size_of::<crate::run::verify::reference::RefStack>()) + block(n);
        b += block(n * std::mem::size_of::<Shadow>()) + block(n * 4);
        b += self.shadow.iter().map(|s| block(s.global_loads.len() * 8)).sum::<usize>();
        b
    }
}
