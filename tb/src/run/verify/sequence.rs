//! [`Property::RequestSequence`]: the micro-op program the stack manager loads when it accepts a
//! command equals the request sequence SPEC sections 3 and 5 (with docs/stack.md's SPEC 9.1–9.4)
//! give for that case.
//!
//! [`expected_program`] is the specification ([`crate::prove::spec`], SPEC's case table over the
//! registers as they were *before* the command, the same description `sms prove` checks the
//! policy against) run on integers: it never calls the design's planner, and it derives skewed
//! base entries from SPEC 4's formula, not from `Config::skew_base`.
//!
//! A refused command loads nothing.

use std::collections::VecDeque;

use rtl::config::Config;
use rtl::logic::Int;
use rtl::stack_manager::policy::{RbOp, Regfile};
use rtl::stack_manager::{Cmd, Entry, StackRegs, ThreadRegs, Uop};

use super::invariants::{fail, Property, Violation};
use crate::prove::spec::Spec;

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

/// The specification's register file on integers: a copy of the warp's stack registers, the
/// commanding thread's RB, and the program the specification gives.
struct IntWarp<'a> {
    base: u32,
    stacks: Vec<StackRegs>,
    rb: &'a VecDeque<Entry>,
    prog: Vec<Uop>,
}

impl Regfile<Int> for IntWarp<'_> {
    fn stack(&mut self, _: &mut Int, s: u32) -> StackRegs {
        self.stacks[(s - self.base) as usize]
    }
    fn stack_q(&mut self, l: &mut Int, s: u32) -> StackRegs {
        self.stack(l, s)
    }
    fn set_stack(&mut self, _: &mut Int, s: u32, r: StackRegs) {
        self.stacks[(s - self.base) as usize] = r;
    }
    fn done(&mut self, _: &mut Int, _: u32) -> bool {
        false
    }
    fn rb_len(&mut self, _: &mut Int) -> u32 {
        self.rb.len() as u32
    }
    fn rb_front(&mut self, _: &mut Int) -> Entry {
        self.rb.front().copied().unwrap_or(rtl::stack_manager::POISON)
    }
    fn rb_back(&mut self, _: &mut Int) -> Entry {
        self.rb.back().copied().unwrap_or(rtl::stack_manager::POISON)
    }
    fn rb(&mut self, _: &mut Int, _: RbOp<Entry>) {}
    fn emit(&mut self, _: &mut Int, valid: bool, u: Uop) {
        if valid {
            self.prog.push(u);
        }
    }
}

/// The micro-op program SPEC sections 3 and 5 give thread `t` (warp base `base`) for `cmd`
/// when it is accepted from the registers `b` (nothing when the specification refuses it).
pub fn expected_program(b: &Before, base: u32, t: u32, cmd: Cmd) -> Vec<Uop> {
    let mut rf = IntWarp { base, stacks: b.stacks.to_vec(), rb: b.rb, prog: Vec::new() };
    let mut spec = Spec { l: &mut Int, rf: &mut rf, cfg: b.cfg, t, base, th: b.thread };
    match spec.apply(cmd, false) {
        Ok(_) => rf.prog,
        Err(_) => Vec::new(),
    }
}

/// The Flush registers of the warp's lanes (lane order) after thread `t`'s `cmd` is accepted
/// from the registers `b`, as SPEC section 5 counts consecutive flushes (the specification's
/// case table, [`crate::prove::spec`]): a flush of a stack adds one, saturating at the flush
/// limit; a pop that drains a stack (so every release and demotion) sets it to 0, and so does a
/// borrow. The counts come from `b.stacks`' Flush fields, which the exhaustive checker fills
/// with its own counts, never the design's ([`Property::FlushCount`]). `None` when the
/// specification refuses the command.
pub fn expected_flush_counts(b: &Before, base: u32, t: u32, cmd: Cmd) -> Option<Vec<u32>> {
    let mut rf = IntWarp { base, stacks: b.stacks.to_vec(), rb: b.rb, prog: Vec::new() };
    let mut spec = Spec { l: &mut Int, rf: &mut rf, cfg: b.cfg, t, base, th: b.thread };
    spec.apply(cmd, false).ok()?;
    Some(rf.stacks.iter().map(|r| r.flush).collect())
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
