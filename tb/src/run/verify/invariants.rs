//! The properties every stack design must keep, checked against the RTL's own registers.
//!
//! Each check names the [`Property`] it enforces, so a failure (or a caught mutant) says which
//! one caught it.

use rtl::config::Overflow;
use rtl::stack_manager::StackManager;

use super::reference::RefStack;

/// The stack's properties, one name each.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Property {
    /// Every pop returns what the reference returns; pop on empty is reported.
    Equivalence,
    /// RB + SH chain + global, read top first, is exactly the reference stack: nothing lost or
    /// duplicated. A restart design (`+RT`) holds the reference's newest entries, in order: what
    /// it lost is only ever the oldest part.
    Conservation,
    /// Top and Bottom in range; empty ⇒ Top == Bottom.
    Pointers,
    /// Overflow set exactly when the thread's global region holds entries; in a restart design,
    /// exactly when it holds fewer entries than the reference (it dropped some), with nothing in
    /// global memory.
    Overflow,
    /// Idle set exactly for finished threads whose stack is not lent.
    Idle,
    /// No stack in two chains, no active thread's stack lent, chains ring-shaped with Priority a
    /// permutation of 0..len, at most 1 + borrow limit stacks; only the top stack or the
    /// dedicated one may be empty.
    Chains,
    /// Flush never above its limit, and 0 on every empty stack.
    Flush,
    /// Every stack's Flush register equals the consecutive flushes the checker counts for it
    /// from the accepted commands and SPEC section 5: one more per flush of the stack
    /// (saturating at the flush limit), 0 after a pop drains it (so after every release and
    /// demotion) and when it is borrowed.
    FlushCount,
    /// At warp exit every queue is empty and every stack back with its owner.
    WarpExit,
    /// The request sequences of SPEC section 3.
    RequestSequence,
    /// A command's program reads only live data: every SH load an entry inside its stack's
    /// Bottom..Top when the command is accepted (or stored earlier by the same program), every
    /// global load a slot below the thread's spill pointer. The exhaustive search relies on it
    /// to ignore stale memory words (see [`super::exhaustive`]).
    LiveReads,
    /// Every register that indexes an array (Next TID, a stack or entry number) holds an index
    /// inside it: the design never panics.
    InRange,
    /// A command offered to a busy thread (its program still running) is refused as Busy and
    /// changes nothing.
    Busy,
    /// Several threads' commands planned in one cycle answer and leave the registers, programs
    /// and memory exactly as planning them one after the other in the same order does; a
    /// micro-op completing in the cycle of a command leaves them as completing it and then
    /// planning the command does, except that the completing thread's own command is refused
    /// (Busy) and changes nothing.
    SameCycle,
    /// Skew placement (docs/stack.md, SPEC section 4): every lane's stack starts at base entry
    /// `(lane / k) mod M`, `k = max(1, banks / (M × words per entry))` — at warp load and
    /// whenever the stack is lent; every SH entry's words sit in the banks SPEC section 4's
    /// address formula gives (thread t owns M entries from byte t × M × entry bytes); and no two
    /// entries of any stacks share a word (no two lanes' stacks overlap).
    Placement,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Violation {
    pub property: Property,
    pub detail: String,
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{:?} violated: {}", self.property, self.detail)
    }
}

impl std::error::Error for Violation {}

pub(crate) fn fail<T>(property: Property, detail: impl Into<String>) -> Result<T, Violation> {
    Err(Violation { property, detail: detail.into() })
}

/// The stacks of thread `t`'s chain, top stack first (highest Priority first).
pub fn chain_by_priority(sm: &StackManager, t: u32) -> Vec<u32> {
    let mut c = sm.chain(t);
    c.sort_by_key(|&s| std::cmp::Reverse(sm.stack(s).priority));
    c
}

/// Thread `t`'s stack as the hardware holds it, newest first: RB top → bottom, then the chain's
/// SH stacks from the top stack down (each Top → Bottom), then global memory newest → oldest.
pub fn logical_stack(sm: &StackManager, t: u32) -> Vec<u64> {
    let m = sm.config().sh_entries;
    let mut out: Vec<u64> = sm.rb(t).iter().rev().copied().collect();
    if m > 0 {
        // A finished thread's ring may be a borrower's now; it then owns no SH entries.
        let lent = sm.thread(t).done
            && sm
                .warp_threads(sm.warp_of(t))
                .any(|u| u != t && !sm.thread(u).done && sm.chain(u).contains(&t));
        let stacks = if lent {
            vec![]
        } else if sm.thread(t).done {
            vec![t]
        } else {
            chain_by_priority(sm, t)
        };
        for s in stacks {
            let st = sm.stack(s);
            let mut e = st.top;
            for _ in 0..st.count(m) {
                out.push(sm.sh_entry(s, e));
                e = (e + m - 1) % m;
            }
        }
    }
    out.extend(sm.global(t).iter().rev());
    out
}

/// Per-thread properties; the thread must be quiescent (`sm.ready(t)`).
pub fn check_thread(sm: &StackManager, t: u32, reference: &RefStack) -> Result<(), Violation> {
    let got = logical_stack(sm, t);
    if sm.config().overflow == Overflow::Drop {
        return check_dropping_thread(sm, t, &got, reference);
    }
    if !got.iter().copied().eq(reference.top_first()) {
        return fail(
            Property::Conservation,
            format!(
                "thread {t}: hardware holds {got:x?}, reference {:x?}",
                reference.top_first().collect::<Vec<_>>()
            ),
        );
    }
    let th = sm.thread(t);
    if th.overflow != (th.spill_ptr > 0) {
        return fail(
            Property::Overflow,
            format!("thread {t}: overflow {} with {} global entries", th.overflow, th.spill_ptr),
        );
    }
    Ok(())
}

/// [`check_thread`] for a restart design: the hardware holds the reference's newest entries, and
/// its Overflow bit says whether it lost any.
fn check_dropping_thread(
    sm: &StackManager,
    t: u32,
    got: &[u64],
    reference: &RefStack,
) -> Result<(), Violation> {
    let newest: Vec<u64> = reference.top_first().take(got.len()).collect();
    if got.len() > reference.len() || got != newest {
        return fail(
            Property::Conservation,
            format!(
                "thread {t}: hardware holds {got:x?}, not the newest entries of the reference {:x?}",
                reference.top_first().collect::<Vec<_>>()
            ),
        );
    }
    let th = sm.thread(t);
    let lost = got.len() < reference.len();
    if th.overflow != lost || th.spill_ptr != 0 || !sm.global(t).is_empty() {
        return fail(
            Property::Overflow,
            format!(
                "thread {t}: overflow {} holding {} of the reference's {} entries, spill pointer {}",
                th.overflow,
                got.len(),
                reference.len(),
                th.spill_ptr
            ),
        );
    }
    Ok(())
}

/// Field properties of one warp; every thread of the warp must be quiescent.
pub fn check_warp(sm: &StackManager, w: u32) -> Result<(), Violation> {
    check_warp_fields(sm, w, true)
}

/// Field properties of one warp. With `quiescent` false (micro-ops still pending), the checks
/// that hold only between commands — Idle (a release may be pending) and the flush count of an
/// empty stack (a flush may be half done) — are skipped.
pub fn check_warp_fields(sm: &StackManager, w: u32, quiescent: bool) -> Result<(), Violation> {
    let cfg = sm.config();
    let m = cfg.sh_entries;
    let ws = cfg.warp_size;
    let base = w * ws;
    let mut holder = vec![None::<u32>; ws as usize];
    // Chains are walked from active threads only: a lent stack's ring is its borrower's.
    for t in sm.warp_threads(w).filter(|&t| !sm.thread(t).done) {
        let chain = sm.chain(t);
        let limit = 1 + cfg.realloc().map_or(0, |r| r.borrow_limit) as usize;
        if chain.len() > limit {
            return fail(Property::Chains, format!("thread {t}: chain {chain:?} longer than {limit}"));
        }
        let mut prios: Vec<u32> = chain.iter().map(|&s| sm.stack(s).priority).collect();
        prios.sort_unstable();
        if prios.iter().enumerate().any(|(i, &p)| p != i as u32) {
            return fail(
                Property::Chains,
                format!("thread {t}: priorities {prios:?} of chain {chain:?} not 0..len"),
            );
        }
        if m > 0 && quiescent {
            let by_prio = chain_by_priority(sm, t);
            for (i, &s) in by_prio.iter().enumerate() {
                if sm.stack(s).empty && i != 0 && s != t {
                    return fail(
                        Property::Chains,
                        format!("thread {t}: borrowed stack {s} empty below the top"),
                    );
                }
            }
        }
        for &s in &chain {
            let lane = (s - base) as usize;
            if let rtl::config::ShPolicy::Group { lanes, .. } = cfg.policy {
                if (s - base) / lanes != (t - base) / lanes {
                    return fail(
                        Property::Chains,
                        format!("thread {t} holds stack {s} from outside its group of {lanes} lanes"),
                    );
                }
            }
            if let Some(other) = holder[lane] {
                return fail(Property::Chains, format!("stack {s} in the chains of threads {other} and {t}"));
            }
            holder[lane] = Some(t);
            if s != t && !sm.thread(s).done {
                return fail(Property::Chains, format!("thread {t} holds the stack of active thread {s}"));
            }
        }
    }
    for t in sm.warp_threads(w).filter(|&t| sm.thread(t).done) {
        let lane = (t - base) as usize;
        if holder[lane].is_none() {
            let chain = sm.chain(t);
            if chain != [t] || sm.stack(t).priority != 0 {
                return fail(
                    Property::Chains,
                    format!("finished thread {t} with its stack not lent has chain {chain:?}"),
                );
            }
            holder[lane] = Some(t);
        }
    }
    for s in sm.warp_threads(w) {
        let st = sm.stack(s);
        if m > 0 && (st.top >= m || st.bottom >= m || (st.empty && st.top != st.bottom)) {
            return fail(
                Property::Pointers,
                format!("stack {s}: top {} bottom {} empty {} with M = {m}", st.top, st.bottom, st.empty),
            );
        }
        let lent = holder[(s - base) as usize].is_some_and(|h| h != s);
        let want_idle = cfg.realloc().is_some() && sm.thread(s).done && !lent;
        if quiescent && st.idle != want_idle {
            return fail(
                Property::Idle,
                format!("stack {s}: idle {} but done {} lent {lent}", st.idle, sm.thread(s).done),
            );
        }
        if let Some(ra) = cfg.realloc() {
            if st.flush > ra.flush_limit || (quiescent && st.empty && st.flush != 0) {
                return fail(
                    Property::Flush,
                    format!("stack {s}: flush {} (limit {}, empty {})", st.flush, ra.flush_limit, st.empty),
                );
            }
        }
    }
    Ok(())
}

/// Warp-exit properties: everything empty and back with its owner.
pub fn check_warp_exit(sm: &StackManager, w: u32) -> Result<(), Violation> {
    check_warp(sm, w)?;
    for t in sm.warp_threads(w) {
        let st = sm.stack(t);
        let th = sm.thread(t);
        let lane = t % sm.config().warp_size;
        if !th.done || !sm.rb(t).is_empty() || !st.empty || th.spill_ptr != 0 || th.overflow {
            return fail(
                Property::WarpExit,
                format!(
                    "thread {t} leaves with done {} rb {} sh empty {} global {}",
                    th.done,
                    sm.rb(t).len(),
                    st.empty,
                    th.spill_ptr
                ),
            );
        }
        if st.next_tid != lane || st.priority != 0 || sm.chain(t) != [t] {
            return fail(
                Property::WarpExit,
                format!("stack {t} not back with its owner: chain {:?}", sm.chain(t)),
            );
        }
    }
    Ok(())
}

/// The skewed base entry of `lane` (docs/stack.md), written from the formula (not through the
/// design's `Config::skew_base`).
pub fn formula_base(c: &rtl::config::Config, lane: u32) -> u32 {
    crate::prove::spec::formula_base(&mut rtl::logic::Int, c, lane)
}

/// [`Property::Placement`] for stack `s`, which has just been loaded or lent and holds at most
/// one entry: its Bottom is the formula's base entry.
pub fn check_placement(sm: &StackManager, s: u32) -> Result<(), Violation> {
    let c = sm.config();
    if c.sh_entries == 0 {
        return Ok(());
    }
    let want = formula_base(c, s % c.warp_size);
    let st = sm.stack(s);
    if st.bottom != want {
        return fail(
            Property::Placement,
            format!("stack {s}: starts at entry {} (top {}), skew says {want}", st.bottom, st.top),
        );
    }
    Ok(())
}

/// SPEC section 4's word address of word `i` of entry `e` of stack `s` (its thread index in the
/// RT unit): thread s owns M entries from byte s × M × entry bytes.
pub fn formula_word(c: &rtl::config::Config, s: u32, e: u32, i: u32) -> u32 {
    ((s * c.sh_entries + e) * c.entry_bytes + i * c.bank_bytes) / c.bank_bytes
}

/// SPEC section 4's bank of word `i` of entry `e` of stack `s`: (byte address / bank bytes) mod
/// banks.
pub fn formula_bank(c: &rtl::config::Config, s: u32, e: u32, i: u32) -> u32 {
    formula_word(c, s, e, i) % c.banks
}

/// [`Property::Placement`]'s bank map for entry `e` of stack `s`, addressed by the design as
/// the word addresses `words`: one word per bank-width of the entry, each in the bank the
/// formula gives.
pub fn check_bank_map(c: &rtl::config::Config, s: u32, e: u32, words: &[u32]) -> Result<(), Violation> {
    let wpe = c.entry_bytes / c.bank_bytes;
    let banks: Vec<u32> = words.iter().map(|w| w % c.banks).collect();
    let want: Vec<u32> = (0..wpe).map(|i| formula_bank(c, s, e, i)).collect();
    if banks != want {
        return fail(
            Property::Placement,
            format!("stack {s} entry {e}: words {words:?} in banks {banks:?}, SPEC section 4 says {want:?}"),
        );
    }
    Ok(())
}

/// [`Property::Placement`] over the whole SH array of `sm`: every entry of every stack in the
/// banks the formula gives, and no word shared by two entries (no two lanes' stacks overlap).
pub fn check_no_overlap(sm: &StackManager) -> Result<(), Violation> {
    let c = sm.config();
    let mut owner = std::collections::HashMap::new();
    for s in 0..c.threads() {
        for e in 0..c.sh_entries {
            let req = sm.sh_read_request(s, e);
            check_bank_map(c, s, e, req.words())?;
            for &w in req.words() {
                if let Some((s2, e2)) = owner.insert(w, (s, e)) {
                    return fail(
                        Property::Placement,
                        format!("word {w} belongs to entry {e2} of stack {s2} and entry {e} of stack {s}"),
                    );
                }
            }
        }
    }
    Ok(())
}

/// The most distinct words one bank must serve when every lane of a `warp_size`-thread warp
/// (warp slot `w`) accesses the entry the same distance from its skewed base (docs/stack.md "Skew",
/// [`formula_base`]) — the largest over the M distances. In lockstep, one such access round
/// costs at most this many bank cycles, so `bound − 1` conflict cycles: RB_8+SH_8+SK gives 2
/// (lanes t and t + 16 share a bank pair), RB_8+SH_8 without skew 16.
pub fn lockstep_bank_load(c: &rtl::config::Config, w: u32) -> u32 {
    let m = c.sh_entries;
    let wpe = c.entry_bytes / c.bank_bytes;
    let mut worst = 0;
    for j in 0..m {
        let mut words: Vec<Vec<u32>> = vec![Vec::new(); c.banks as usize];
        for lane in 0..c.warp_size {
            let s = w * c.warp_size + lane;
            let e = (formula_base(c, lane) + j) % m;
            for i in 0..wpe {
                let word = formula_word(c, s, e, i);
                let b = &mut words[(word % c.banks) as usize];
                if !b.contains(&word) {
                    b.push(word);
                }
            }
        }
        worst = worst.max(words.iter().map(Vec::len).max().unwrap_or(0) as u32);
    }
    worst
}
