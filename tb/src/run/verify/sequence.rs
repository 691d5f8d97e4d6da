//! [`Property::RequestSequence`]: the micro-op program the stack manager loads when it accepts a
//! command equals the request sequence SPEC sections 3 and 5 (with DESIGN 9.1–9.4's choices)
//! give for that case.
//!
//! [`expected_program`] is the specification, written from the SPEC's case table over the
//! registers as they were *before* the command: it never calls the design's planner, and it
//! derives skewed base entries from DESIGN 9.6's formula ([`formula_base`]), not from
//! `Config::skew_base`. The case table:
//!
//! | command | case | sequence |
//! |---|---|---|
//! | push | RB not full | — |
//! | push | RB full, M = 0 | global store (oldest RB entry) at the spill pointer |
//! | push | RB full, top stack not full | SH store (oldest RB entry) at Top + 1 (at Top if empty) |
//! | push | RB full, top full, no RA, or RA with a one-stack chain at its flush limit | SH load (Bottom) → global store (latch) → SH store at Top + 1 |
//! | push | RB full, top full, RA, an empty member | SH store at the member's Top |
//! | push | … no empty member, chain shorter than 1 + borrow limit, an Idle stack | SH store at the lowest-numbered Idle stack's skewed base |
//! | push | … otherwise: flush the oldest member | its entries Bottom first: (SH load → global store (latch)) × count, then SH store at its old Top |
//! | pop | RB empty | refused: nothing |
//! | pop | M = 0, global holds entries | global load (newest slot) → RB bottom |
//! | pop | top stack not empty | SH load (Top) → RB bottom, then release if that drained a borrowed top stack |
//! | pop | then, global holds entries and the chain's oldest stack (after the release or demotion) has room | global load (newest slot) → SH store (latch) just below its Bottom (at Bottom if empty) |
//! | finish | | — |
//!
//! A refused command loads nothing.

use std::collections::VecDeque;

use rtl::config::Config;
use rtl::stack_manager::{Cmd, Entry, Src, StackRegs, ThreadRegs, Uop};

use super::invariants::{fail, formula_base, Property, Violation};

/// The registers of one warp before a command, as the specification reads them.
pub struct Before<'a> {
    pub cfg: &'a Config,
    /// Stack registers of every lane of the warp, lane order.
    pub stacks: &'a [StackRegs],
    /// The commanding thread's registers.
    pub thread: ThreadRegs,
    /// Its RB entries, oldest first.
    pub rb: &'a VecDeque<Entry>,
}

impl Before<'_> {
    fn m(&self) -> u32 {
        self.cfg.sh_entries
    }
    fn count(&self, lane: u32) -> u32 {
        self.stacks[lane as usize].count(self.m())
    }
    fn full(&self, lane: u32) -> bool {
        self.count(lane) == self.m()
    }
    /// The lanes of `lane`'s ring, from `lane`, following Next TID.
    fn ring(&self, lane: u32) -> Vec<u32> {
        let mut out = vec![lane];
        let mut s = self.stacks[lane as usize].next_tid;
        while s != lane && out.len() < self.stacks.len() {
            out.push(s);
            s = self.stacks[s as usize].next_tid;
        }
        out
    }
    fn top_of(&self, ring: &[u32]) -> u32 {
        *ring.iter().max_by_key(|&&s| self.stacks[s as usize].priority).expect("a ring is never empty")
    }
    fn oldest_of(&self, ring: &[u32]) -> u32 {
        *ring.iter().min_by_key(|&&s| self.stacks[s as usize].priority).expect("a ring is never empty")
    }
}

/// The micro-op program SPEC sections 3 and 5 give thread `t` (warp base `base`) for `cmd`
/// when it is accepted from the registers `b`.
pub fn expected_program(b: &Before, base: u32, t: u32, cmd: Cmd) -> Vec<Uop> {
    let m = b.m();
    let lane = t - base;
    let sp = b.thread.spill_ptr;
    let id = |lane: u32| base + lane;
    let mut out = Vec::new();
    match cmd {
        Cmd::None | Cmd::Finish => {}
        Cmd::Push(_) => {
            let full = b.cfg.rb.capacity().is_some_and(|n| b.rb.len() as u32 >= n);
            if !full {
                return out;
            }
            let v = *b.rb.front().expect("a full RB holds entries");
            if m == 0 {
                out.push(Uop::GlobalStore { slot: sp, src: Src::Value(v) });
                return out;
            }
            let ring = b.ring(lane);
            let top = b.top_of(&ring);
            let above = |s: u32| {
                let r = b.stacks[s as usize];
                if r.empty {
                    r.top
                } else {
                    (r.top + 1) % m
                }
            };
            let store = |s: u32, entry: u32| Uop::ShStore { stack: id(s), entry, src: Src::Value(v) };
            if !b.full(top) {
                out.push(store(top, above(top)));
                return out;
            }
            if let Some(ra) = b.cfg.realloc {
                if let Some(&e) = ring.iter().find(|&&s| b.stacks[s as usize].empty) {
                    out.push(store(e, b.stacks[e as usize].top));
                    return out;
                }
                let idle = (0..b.stacks.len() as u32).find(|&s| b.stacks[s as usize].idle);
                if let (true, Some(s)) = (ring.len() as u32 <= ra.borrow_limit, idle) {
                    out.push(store(s, formula_base(b.cfg, s)));
                    return out;
                }
                let oldest = b.oldest_of(&ring);
                let r = b.stacks[oldest as usize];
                if ring.len() > 1 || r.flush < ra.flush_limit {
                    for i in 0..b.count(oldest) {
                        out.push(Uop::ShLoad { stack: id(oldest), entry: (r.bottom + i) % m });
                        out.push(Uop::GlobalStore { slot: sp + i, src: Src::Latch });
                    }
                    // Drained from the Bottom, the queue's pointers rest at its old Top.
                    out.push(store(oldest, r.top));
                    return out;
                }
            }
            // SPEC 3, push case 3.
            let r = b.stacks[top as usize];
            out.push(Uop::ShLoad { stack: id(top), entry: r.bottom });
            out.push(Uop::GlobalStore { slot: sp, src: Src::Latch });
            out.push(store(top, (r.top + 1) % m));
        }
        Cmd::Pop => {
            if b.rb.is_empty() {
                return out;
            }
            let global = sp > 0;
            if m == 0 {
                if global {
                    out.push(Uop::GlobalLoad { slot: sp - 1 });
                    out.push(Uop::RbBottom);
                }
                return out;
            }
            let mut ring = b.ring(lane);
            let top = b.top_of(&ring);
            let after = |s: u32| b.stacks[s as usize];
            let mut top_after = after(top);
            // The chain's oldest stack once this pop's SH part is done.
            let mut oldest = b.oldest_of(&ring);
            if !top_after.empty {
                out.push(Uop::ShLoad { stack: id(top), entry: top_after.top });
                out.push(Uop::RbBottom);
                if b.count(top) == 1 {
                    top_after.empty = true;
                    if ring.len() > 1 && top != lane {
                        out.push(Uop::Release { stack: id(top) });
                        ring.retain(|&s| s != top);
                        oldest = b.oldest_of(&ring);
                    } else if ring.len() > 1 {
                        // Demotion: the drained dedicated stack becomes the chain's oldest.
                        oldest = lane;
                    }
                } else {
                    top_after.top = (top_after.top + m - 1) % m;
                }
            }
            let o = if oldest == top { top_after } else { after(oldest) };
            if global && o.count(m) < m {
                let entry = if o.empty { o.bottom } else { (o.bottom + m - 1) % m };
                out.push(Uop::GlobalLoad { slot: sp - 1 });
                out.push(Uop::ShStore { stack: id(oldest), entry, src: Src::Latch });
            }
        }
    }
    out
}

/// [`Property::RequestSequence`] for thread `t`'s command `cmd`, just accepted (`accepted`:
/// not refused) from the registers `b`: the program now queued in its sequencer, `got`, must be
/// [`expected_program`]'s (nothing for a refused command).
pub fn check_sequence<'a>(
    b: &Before,
    base: u32,
    t: u32,
    cmd: Cmd,
    accepted: bool,
    got: impl Iterator<Item = &'a Uop>,
) -> Result<(), Violation> {
    let want = if accepted { expected_program(b, base, t, cmd) } else { Vec::new() };
    let got: Vec<Uop> = got.copied().collect();
    if got != want {
        return fail(
            Property::RequestSequence,
            format!("thread {t}: {cmd:?} loaded {got:?}, SPEC sections 3 and 5 say {want:?}"),
        );
    }
    Ok(())
}
