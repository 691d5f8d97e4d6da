//! Conservation of the logical stack through one tracked entry whose position is symbolic.
//!
//! A thread's logical stack, top first, is laid out over three stores (SPEC sections 3 and 5):
//! its RB from the newest entry back, then its chain's SH stacks from the highest Priority
//! down, each from Top back to Bottom, then its global region from the newest slot down. The
//! [`Layout`] here is that abstraction function, written from the SPEC over the registers; it
//! calls neither the design's policy nor the specification's case table.
//!
//! The query: for every register state satisfying the invariant ([`super::query::well_formed`])
//! and every position `p` of the commanding thread's stack, one accepted push or pop by the
//! design (the simulator's code) leaves the entry that was at `p` at the position the
//! reference unbounded stack gives it (`p + 1` after a push, `p − 1` after a pop; a pushed
//! entry at 0; the entry at 0 is what a pop returns). The stack manager only moves entries,
//! never computes with them, so it is enough to follow one entry tagged 1 among entries tagged
//! 0 (data independence): the tag travels through the RB changes the plan makes, the
//! micro-op program's SH and global loads and stores and the latch, to the location the
//! registers after the cycle name for its new position. With `p` symbolic, one query covers
//! every position, so the whole logical stack is conserved, at every depth the registers
//! allow. More parts: the logical depth moves by exactly one; a pop returns the top entry and
//! is refused only by an empty stack; and every SH store lands in a stack that is on the
//! thread's chain after the cycle and was on it before or Idle (so no other thread's entries
//! are touched: rings are disjoint cycles of Next TID).
//!
//! A restart design (`+RT`) may drop its oldest entries on a push: there the tracked entry must
//! be at its new position whenever that position is still held (so what is kept is the newest
//! entries, in order), and the depth may grow by less than one only with the Overflow bit set.

use rtl::config::{Config, Overflow};
use rtl::logic::Logic;
use rtl::stack_manager::policy::{Regs, Steps, Thread};

use super::query::{
    code, eq_bit, finish, implies, select, select_flag, side, well_formed, Enc, Kind, Query, RbChange, Side,
    State,
};
use super::sym::{Sym, B, V, W};

/// One member of a thread's ring: on the ring, its thread id, rank, entry count and Top.
#[derive(Clone, Copy, Debug)]
struct Member {
    on: B,
    stack: W,
    rank: W,
    count: W,
    top: W,
}

/// Where a thread's logical stack lives, from its registers.
struct Layout {
    rb_len: W,
    members: Vec<Member>,
    sh: W,
    spill_ptr: W,
    depth: W,
}

/// Where one logical position lives.
#[derive(Clone, Copy, Debug)]
struct Loc {
    in_rb: B,
    /// Entries above it in the RB (0: the RB's newest entry).
    rb_off: W,
    in_sh: B,
    stack: W,
    entry: W,
    in_global: B,
    slot: W,
}

/// The layout of thread `base + lane`'s stack: its ring walked from its own stack (at most
/// 1 + borrow limit members), each member's entry count (0 when empty, else
/// `(Top − Bottom) mod M + 1`).
fn layout(
    s: &mut Sym,
    cfg: &Config,
    base: u32,
    regs: &[Regs<Sym>],
    lane: u32,
    rb_len: W,
    spill_ptr: W,
) -> Layout {
    let m = cfg.sh_entries;
    let mut members = Vec::new();
    let mut sh = s.word(0);
    if m > 0 {
        let most = cfg.policy.chain_bound().min(cfg.warp_size);
        let me = s.word(lane);
        let mut cur = me;
        let mut on = s.bit(true);
        for k in 0..most {
            if k > 0 {
                cur = select(s, regs, cur, |r| r.next_tid);
                let home = s.eq(cur, me);
                let away = s.not(home);
                on = s.and(on, away);
            }
            let top = select(s, regs, cur, |r| r.top);
            let bottom = select(s, regs, cur, |r| r.bottom);
            let empty = select_flag(s, regs, cur, |r| r.empty);
            let rank = select(s, regs, cur, |r| r.priority);
            // M is a power of two (the configuration checks it): mod M keeps the low bits.
            let span = s.sub(top, bottom);
            let low = s.word(m - 1);
            let span = s.mask(span, low);
            let full = s.add_k(span, 1);
            let zero = s.word(0);
            let count = s.mux(empty, zero, full);
            let count = s.mux(on, count, zero);
            sh = s.add(sh, count);
            let stack = s.add_k(cur, base);
            members.push(Member { on, stack, rank, count, top });
        }
    }
    let d = s.add(rb_len, sh);
    let depth = s.add(d, spill_ptr);
    Layout { rb_len, members, sh, spill_ptr, depth }
}

/// Where position `q` (0: the top) of `lay` lives.
fn locate(s: &mut Sym, cfg: &Config, lay: &Layout, q: W) -> Loc {
    let in_rb = s.lt(q, lay.rb_len);
    let q2 = s.sub(q, lay.rb_len);
    let below_sh = s.lt(q2, lay.sh);
    let not_rb = s.not(in_rb);
    let in_sh = s.and(not_rb, below_sh);
    let (mut stack, mut entry) = (s.word(0), s.word(0));
    let m = cfg.sh_entries;
    for (k, x) in lay.members.iter().enumerate() {
        // Entries above this member's: those of the members ranked above it.
        let mut start = s.word(0);
        for (j, y) in lay.members.iter().enumerate() {
            if j == k {
                continue;
            }
            let above = s.lt(x.rank, y.rank);
            let zero = s.word(0);
            let c = s.mux(above, y.count, zero);
            start = s.add(start, c);
        }
        let from = s.le(start, q2);
        let d = s.sub(q2, start);
        let within = s.lt(d, x.count);
        let here = s.and(from, within);
        let here = s.and(here, x.on);
        let e = s.sub(x.top, d);
        let low = s.word(m.max(1) - 1);
        let e = s.mask(e, low);
        stack = s.mux(here, x.stack, stack);
        entry = s.mux(here, e, entry);
    }
    let q3 = s.sub(q2, lay.sh);
    let not_sh = s.not(below_sh);
    let past = s.and(not_rb, not_sh);
    let in_depth = s.lt(q, lay.depth);
    let in_global = s.and(past, in_depth);
    let top_slot = s.sub_k(lay.spill_ptr, 1);
    let slot = s.sub(top_slot, q3);
    Loc { in_rb, rb_off: q, in_sh, stack, entry, in_global, slot }
}

/// The conservation query for one `kind` command (push or pop) on `lane` of the warp at `base`,
/// built in the order the entry travels: where the tracked entry is before the cycle, the RB
/// changes of the plan, the micro-op program, then the parts checked after the cycle.
pub fn conserves<P: Steps>(cfg: &Config, steps: &P, base: u32, lane: u32, kind: Kind) -> Query {
    assert!(kind != Kind::Finish, "a finish moves no entry");
    let mut s = Sym::default();
    let st = State::new(&mut s, cfg, base, &[(lane, kind)]);
    let x = st.lanes[0];
    let lanes: Vec<(u32, Thread<Sym>, W, B)> = vec![(x.lane, x.th, x.rb_len, x.busy)];
    let mut assume = well_formed(&mut s, cfg, &st.regs, &st.done, &lanes);
    let p = s.var_word("tracked_position");
    let (tag, other) = (s.val(1), s.val(0));

    // Sums of registers stay far from wrapping: an unbounded RB is at most 2^24 entries.
    if cfg.rb.capacity().is_none() {
        let small = s.lt_k(x.rb_len, 1 << 24);
        assume = s.and(assume, small);
    }
    let pre = layout(&mut s, cfg, base, &st.regs, lane, x.rb_len, x.th.spill_ptr);
    let (at, is_new) = tracked_before(&mut s, cfg, &pre, kind, p, &mut assume);
    // The entry values the plan can see carry the tags: the RB's two ends and the pushed entry.
    let front_off = s.sub_k(x.rb_len, 1);
    let at_front = s.eq(at.rb_off, front_off);
    let at_front = s.and(at.in_rb, at_front);
    let at_back = s.eq_k(at.rb_off, 0);
    let at_back = s.and(at.in_rb, at_back);
    for (v, tracked) in [(x.rb_front, at_front), (x.rb_back, at_back), (x.value, is_new)] {
        let want = s.mux_val(tracked, tag, other);
        let same = s.eq_val(v, want);
        assume = s.and(assume, same);
    }
    let idle = s.not(x.busy);
    assume = s.and(assume, idle);

    let slots = 2 * cfg.sh_entries as usize + 4;
    let d = side(&mut s, cfg, &st, &Side::Design(steps), slots);
    let a = &d.lanes[0];
    let accepted = s.lt_k(a.code, 2);
    let rb = rb_after_plan(&mut s, &a.rb, &at, x.rb_len, tag);
    let prog = run_program(&mut s, &a.prog, &at, rb.len, tag);

    // After the cycle (its program done): where the tracked entry's new position lives, and
    // whether that place holds it.
    let post = layout(&mut s, cfg, base, &d.regs, lane, prog.len, a.th.spill_ptr);
    let drops = cfg.overflow == Overflow::Drop;
    let n = lane;
    let mut parts = Vec::new();
    let held = tracked_after(&mut s, cfg, &post, kind, p, &at, &rb, &prog);
    let need = implies(&mut s, accepted, held);
    parts.push((format!("lane {n}: the tracked entry at its new position"), need));
    let depth_ok = match kind {
        Kind::Push if drops => {
            // One deeper, or (entries dropped) no deeper than that with the Overflow bit set.
            let up = s.add_k(pre.depth, 1);
            let grew = s.eq(post.depth, up);
            let within = s.le(post.depth, up);
            let dropped = s.and(within, a.th.overflow);
            s.or(grew, dropped)
        }
        Kind::Push => {
            let up = s.add_k(pre.depth, 1);
            s.eq(post.depth, up)
        }
        _ => {
            let down = s.sub_k(pre.depth, 1);
            s.eq(post.depth, down)
        }
    };
    let depth_ok = implies(&mut s, accepted, depth_ok);
    parts.push((format!("lane {n}: logical depth moves by one"), depth_ok));
    if kind == Kind::Pop {
        let top = s.eq_k(p, 0);
        let got = s.eq_val(a.value, tag);
        let same = eq_bit(&mut s, got, top);
        let ok = implies(&mut s, accepted, same);
        parts.push((format!("lane {n}: a pop returns the top entry, only it"), ok));
        // Between commands (not busy) a live thread with entries anywhere has one in its RB.
        let live = s.not(x.th.done);
        let refused = s.not(accepted);
        let wrong = s.and(live, refused);
        let fine = s.not(wrong);
        parts.push((format!("lane {n}: a pop with entries left is accepted"), fine));
    }
    let own = stores_in_own_chain(&mut s, &st.regs, base, &pre, &post, &prog.sh_stacks);
    let own = implies(&mut s, accepted, own);
    parts.push((format!("lane {n}: SH stores land in its own chain or a free stack it takes"), own));
    finish(s, assume, parts)
}

/// The tracked entry's place before the cycle, and whether it is the entry a push brings
/// (position 0 after a push; position `p` is the one that was at `p − 1`). Adds to `assume`
/// that `p` names an entry the command moves.
fn tracked_before(s: &mut Sym, cfg: &Config, pre: &Layout, kind: Kind, p: W, assume: &mut B) -> (Loc, B) {
    let (pre_q, pre_valid, is_new) = match kind {
        Kind::Push => {
            let zero = s.eq_k(p, 0);
            let q = s.sub_k(p, 1);
            let inside = s.lt(q, pre.depth);
            let old = s.not(zero);
            let valid = s.and(old, inside);
            let range = s.or(zero, inside);
            *assume = s.and(*assume, range);
            (q, valid, zero)
        }
        _ => {
            let valid = s.lt(p, pre.depth);
            *assume = s.and(*assume, valid);
            let no = s.bit(false);
            (p, valid, no)
        }
    };
    let at = locate(s, cfg, pre, pre_q);
    let at = Loc {
        in_rb: s.and(pre_valid, at.in_rb),
        in_sh: s.and(pre_valid, at.in_sh),
        in_global: s.and(pre_valid, at.in_global),
        ..at
    };
    (at, is_new)
}

/// The tracked entry in the RB after the plan's changes: whether it is there, its offset from
/// the newest entry, and the RB's length.
struct RbTrack {
    in_rb: B,
    off: W,
    len: W,
}

/// The RB changes of the plan, in the order a plan makes them: the top leaves, the oldest
/// leaves, the new entry arrives.
fn rb_after_plan(s: &mut Sym, rb: &RbChange, at: &Loc, rb_len: W, tag: V) -> RbTrack {
    let mut in_rb = at.in_rb;
    let mut off = at.rb_off;
    let mut len = rb_len;
    // An entry leaving from back-offset `at` (when `happened`): the tracked one (at `off`)
    // leaves if it sits there, and the RB is one shorter.
    let leave = |s: &mut Sym, in_rb: B, off: W, len: W, at: W, happened: B| {
        let here = s.eq(off, at);
        let gone = s.and(happened, here);
        let keep = s.not(gone);
        let shorter = s.sub_k(len, 1);
        (s.and(in_rb, keep), s.mux(happened, shorter, len))
    };
    let top = s.word(0);
    (in_rb, len) = leave(s, in_rb, off, len, top, rb.pop_back);
    let down = s.sub_k(off, 1);
    off = s.mux(rb.pop_back, down, off);
    let front = s.sub_k(len, 1);
    (in_rb, len) = leave(s, in_rb, off, len, front, rb.pop_front);
    let up = s.add_k(off, 1);
    off = s.mux(rb.push_back, up, off);
    let longer = s.add_k(len, 1);
    len = s.mux(rb.push_back, longer, len);
    let new = s.eq_val(rb.pushed, tag);
    let new = s.and(rb.push_back, new);
    let zero = s.word(0);
    off = s.mux(new, zero, off);
    in_rb = s.or(in_rb, new);
    RbTrack { in_rb, off, len }
}

/// A store of the program, to SH (`a`: stack, `b`: entry) or global memory (`a`: slot), and
/// whether it writes the tracked entry.
struct Store {
    on: B,
    sh: bool,
    a: W,
    b: W,
    tag: B,
}

/// What the program did: its stores (for what a later load or the end sees), the entry it put
/// under the RB (when `from_latch`, at offset `latch_off`), the RB's length after it, and the
/// SH stacks it stored to (when the store happened).
struct Program {
    stores: Vec<Store>,
    from_latch: B,
    latch_off: W,
    len: W,
    sh_stacks: Vec<(B, W)>,
}

/// Whether SH entry (`a`, `b`) (`sh`) or global slot `a` holds the tracked entry: where it was
/// before the cycle, unless a store in `stores` wrote there since.
fn content(s: &mut Sym, at: &Loc, stores: &[Store], sh: bool, a: W, b: W) -> B {
    let mut c = if sh {
        let x = s.eq(at.stack, a);
        let y = s.eq(at.entry, b);
        let xy = s.and(x, y);
        s.and(at.in_sh, xy)
    } else {
        let x = s.eq(at.slot, a);
        s.and(at.in_global, x)
    };
    for st in stores.iter().filter(|st| st.sh == sh) {
        let x = s.eq(st.a, a);
        let hit = if sh {
            let y = s.eq(st.b, b);
            s.and(x, y)
        } else {
            x
        };
        let hit = s.and(st.on, hit);
        c = s.mux_bit(hit, st.tag, c);
    }
    c
}

/// The program, slot by slot: every store so far, the latch's tag, and entries the program puts
/// under the RB (`len`: the RB's length after the plan).
fn run_program(s: &mut Sym, prog: &[(B, Enc)], at: &Loc, len: W, tag: V) -> Program {
    let mut stores: Vec<Store> = Vec::new();
    let mut len = len;
    let mut latch = s.bit(false);
    let (mut from_latch, mut latch_off) = (s.bit(false), s.word(0));
    let mut sh_stacks: Vec<(B, W)> = Vec::new();
    for (valid, u) in prog {
        let is = |s: &mut Sym, k: u32| {
            let e = s.eq_k(u.kind, k);
            s.and(*valid, e)
        };
        let (shl, shs, gl, gs, rbb) = (
            is(s, code::SH_LOAD),
            is(s, code::SH_STORE),
            is(s, code::GLOBAL_LOAD),
            is(s, code::GLOBAL_STORE),
            is(s, code::RB_BOTTOM),
        );
        let z = s.word(0);
        let from_sh = content(s, at, &stores, true, u.a, u.b);
        let from_gl = content(s, at, &stores, false, u.a, z);
        let src = {
            let v = s.eq_val(u.value, tag);
            s.mux_bit(u.latch, latch, v)
        };
        if s.maybe(shs) {
            stores.push(Store { on: shs, sh: true, a: u.a, b: u.b, tag: src });
            sh_stacks.push((shs, u.a));
        }
        if s.maybe(gs) {
            stores.push(Store { on: gs, sh: false, a: u.a, b: z, tag: src });
        }
        // An entry put under the RB lands below every entry there.
        let lands = s.and(rbb, latch);
        from_latch = s.or(from_latch, lands);
        latch_off = s.mux(lands, len, latch_off);
        let longer = s.add_k(len, 1);
        len = s.mux(rbb, longer, len);
        latch = s.mux_bit(shl, from_sh, latch);
        latch = s.mux_bit(gl, from_gl, latch);
    }
    Program { stores, from_latch, latch_off, len, sh_stacks }
}

/// Whether the tracked entry is at its new position after the cycle, whenever that position
/// is held (`p + 1` after a push, `p − 1` after a pop; a restart design keeps the newest
/// entries, so past the depth held the tracked one is gone, dropped).
#[allow(clippy::too_many_arguments)]
fn tracked_after(
    s: &mut Sym,
    cfg: &Config,
    post: &Layout,
    kind: Kind,
    p: W,
    at: &Loc,
    rb: &RbTrack,
    prog: &Program,
) -> B {
    let drops = cfg.overflow == Overflow::Drop;
    let (post_q, post_valid) = match kind {
        Kind::Push if drops => (p, s.lt(p, post.depth)),
        Kind::Push => (p, s.bit(true)),
        _ => {
            let q = s.sub_k(p, 1);
            let zero = s.eq_k(p, 0);
            (q, s.not(zero))
        }
    };
    let to = locate(s, cfg, post, post_q);
    let held = {
        let here = s.eq(rb.off, to.rb_off);
        let in_rb_here = s.and(rb.in_rb, here);
        let under = s.eq(prog.latch_off, to.rb_off);
        let under = s.and(prog.from_latch, under);
        let rb_ok = s.or(in_rb_here, under);
        let sh_ok = content(s, at, &prog.stores, true, to.stack, to.entry);
        let z = s.word(0);
        let gl_ok = content(s, at, &prog.stores, false, to.slot, z);
        let c = s.mux_bit(to.in_sh, sh_ok, gl_ok);
        s.mux_bit(to.in_rb, rb_ok, c)
    };
    implies(s, post_valid, held)
}

/// A stack written is on the chain after the cycle, and was on it before or Idle (free).
fn stores_in_own_chain(
    s: &mut Sym,
    regs: &[Regs<Sym>],
    base: u32,
    pre: &Layout,
    post: &Layout,
    sh_stacks: &[(B, W)],
) -> B {
    let member = |s: &mut Sym, lay: &Layout, stack: W| {
        let mut inside = s.bit(false);
        for mbr in &lay.members {
            let e = s.eq(mbr.stack, stack);
            let e = s.and(mbr.on, e);
            inside = s.or(inside, e);
        }
        inside
    };
    let mut own = s.bit(true);
    for &(on, stack) in sh_stacks {
        let after = member(s, post, stack);
        let before = member(s, pre, stack);
        let lane_of = s.sub_k(stack, base);
        let free = select_flag(s, regs, lane_of, |r| r.idle);
        let ours = s.or(before, free);
        let ok = s.and(after, ours);
        let ok = implies(s, on, ok);
        own = s.and(own, ok);
    }
    own
}
