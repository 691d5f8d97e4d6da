//! The checks the model makes itself, beyond the state properties of
//! [`crate::run::verify::invariants`]: the values a command's global loads will read must be
//! live ([`Property::LiveReads`]), and the Flush registers must equal the counts taken from the
//! specification's table ([`Property::FlushCount`]).

use rtl::stack_manager::{StackManager, StackRegs, Uop};

use crate::run::verify::invariants::{fail, Property, Violation};

/// [`Property::LiveReads`] for the program thread `t`'s command just queued; `stacks` are the
/// warp's stack registers and `global` the thread's live global slots before the command.
/// Returns the values its global loads will read, in order.
pub(super) fn live_reads(
    sm: &StackManager,
    t: u32,
    stacks: &[StackRegs],
    global: &[u64],
) -> Result<std::collections::VecDeque<u64>, Violation> {
    let m = sm.config().sh_entries;
    let base = t - t % sm.config().warp_size;
    let live = |s: u32, e: u32| {
        let st = &stacks[(s - base) as usize];
        !st.empty && (e + m - st.bottom) % m < st.count(m)
    };
    let mut stored: Vec<(u32, u32)> = Vec::new();
    let mut loads = std::collections::VecDeque::new();
    for (i, u) in sm.pending_uops(t).enumerate() {
        match *u {
            Uop::ShStore { stack, entry, .. } => stored.push((stack, entry)),
            Uop::ShLoad { stack, entry } if !live(stack, entry) && !stored.contains(&(stack, entry)) => {
                return fail(
                    Property::LiveReads,
                    format!("thread {t}: micro-op {i} loads SH entry {entry} of stack {stack}, not live"),
                );
            }
            Uop::GlobalLoad { slot } => match global.get(slot as usize) {
                Some(&v) => loads.push_back(v),
                None => {
                    return fail(
                        Property::LiveReads,
                        format!(
                            "thread {t}: micro-op {i} loads global slot {slot} with {} live",
                            global.len()
                        ),
                    )
                }
            },
            _ => {}
        }
    }
    Ok(loads)
}

/// [`Property::FlushCount`]: every stack's Flush register of warp `w` equals `counted`, the
/// consecutive flushes the checker counted for it (lane order).
pub(super) fn check_flush_counts(sm: &StackManager, w: u32, counted: &[u32]) -> Result<(), Violation> {
    for (s, &want) in sm.warp_threads(w).zip(counted) {
        let got = sm.stack(s).flush;
        if got != want {
            return fail(
                Property::FlushCount,
                format!("stack {s}: Flush {got}, SPEC section 5 counts {want} consecutive flushes"),
            );
        }
    }
    Ok(())
}
