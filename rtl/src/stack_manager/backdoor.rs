//! The stack manager's back doors: state loaded from outside the design (a solver's
//! counterexample replayed, dead SH words poisoned by the exhaustive search) and the hash of its
//! architectural state the checkers key their visited sets on. Apart from the design's own
//! interface so that what only a testbench may do is in one place.

use super::*;

impl StackManager {
    /// Loads stack `s`'s registers from outside the design: a testbench's back door, for
    /// replaying a solver's counterexample state.
    pub fn load_stack(&mut self, s: u32, r: StackRegs) {
        self.stacks[s as usize] = r;
    }

    /// Writes SH entry `e` of stack `s` from outside the design: a testbench's back door, with
    /// which the exhaustive search overwrites dead words with [`POISON`] so that stale memory is
    /// never state.
    pub fn load_sh_entry(&mut self, s: u32, e: u32, v: Entry) {
        let i = self.sh_index(s, e);
        self.sh_data[i] = v;
    }

    /// Loads thread `t`'s registers, its RB entries (oldest first) and, when `busy`, a queued
    /// micro-op (a read of its own stack's Top) from outside the design: a testbench's back
    /// door, for replaying a solver's counterexample state.
    pub fn load_thread(&mut self, t: u32, th: ThreadRegs, rb: &[Entry], busy: bool) {
        self.threads[t as usize] = th;
        self.rb[t as usize] = rb.iter().copied().collect();
        self.seq[t as usize] = Sequencer::default();
        if busy {
            let entry = self.stacks[t as usize].top;
            self.seq[t as usize].uops.push_back(Uop::ShLoad { stack: t, entry });
        }
        self.sync_queued(t);
    }

    /// Hashes the architectural state: every register, queue, sequencer and memory word, but not
    /// the event counters, so equal states hash equal.
    pub fn hash_state<H: std::hash::Hasher>(&self, h: &mut H) {
        use std::hash::Hash;
        self.threads.hash(h);
        self.stacks.hash(h);
        self.rb.hash(h);
        self.seq.hash(h);
        self.sh_data.hash(h);
        self.global.hash(h);
    }
}
