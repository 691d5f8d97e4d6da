//! The functional executor: the same plan as the clocked eval and commit, with a command
//! accepted at once and its micro-ops completed at once or one at a time (for exploring every
//! interleaving of micro-ops across threads). The checkers and the reference runs drive the
//! manager through these; the clocked run through [`Unit`].

use super::*;

impl StackManager {
    /// Completes `u` of thread `t` at once (the functional level): the data effect the cycle
    /// gives a completion ([`cycle::complete`]), committed.
    fn complete(&mut self, t: u32, u: Uop) {
        let mut d = std::mem::take(&mut self.scratch);
        d.clear();
        let mut latch = self.seq[t as usize].latch;
        self.complete_with(t, u, &mut latch, &mut d);
        self.seq[t as usize].latch = latch;
        self.commit(&d);
        d.clear();
        self.scratch = d;
    }

    fn complete_with(&self, t: u32, u: Uop, latch: &mut Option<Entry>, d: &mut StackStep) {
        self.policy.0.complete(&self.cfg, self, t, u, latch, &mut d.j)
    }

    /// Completes thread `t`'s next micro-op at once (for exploring every interleaving of
    /// micro-ops across threads). Returns false if it had none.
    pub fn complete_next(&mut self, t: u32) -> bool {
        match self.seq[t as usize].uops.pop_front() {
            Some(u) => {
                self.sync_queued(t);
                self.complete(t, u);
                true
            }
            None => false,
        }
    }

    /// Accepts a command from a ready thread: updates registers and loads the sequencer (plan,
    /// then commit). Returns the popped entry for a pop.
    pub fn accept(&mut self, t: u32, cmd: Cmd) -> Result<Option<Entry>, StackError> {
        let mut d = std::mem::take(&mut self.scratch);
        d.clear();
        self.plan(&[(t, cmd)], &mut d);
        let r = d.answer(t);
        self.commit(&d);
        d.clear();
        self.scratch = d;
        r
    }

    /// Accepts several threads' commands in one cycle, planned in order (a plan sees the stack
    /// registers earlier ones changed), as the eval plans a cycle's commands.
    /// Returns each command's answer, in order; a thread that is not ready is refused (Busy).
    pub fn accept_all(&mut self, cmds: &[(u32, Cmd)]) -> Vec<Result<Option<Entry>, StackError>> {
        let mut d = std::mem::take(&mut self.scratch);
        d.clear();
        self.plan(cmds, &mut d);
        let r = cmds.iter().map(|c| d.answer(c.0)).collect();
        self.commit(&d);
        d.clear();
        self.scratch = d;
        r
    }

    /// One cycle in which the next micro-op of each thread in `complete` (each at most once)
    /// completes and `cmds` are planned, in the cycle's order ([`cycle::eval`]): the completions
    /// land first, so a release completing now is seen by this cycle's plans; `ready` is a
    /// register, so a thread whose micro-op completes now is still busy for a command in the
    /// same cycle (refused Busy). Returns each command's answer, in order.
    pub fn complete_and_accept(
        &mut self,
        complete: &[u32],
        cmds: &[(u32, Cmd)],
    ) -> Vec<Result<Option<Entry>, StackError>> {
        let mut d = std::mem::take(&mut self.scratch);
        d.clear();
        for &t in complete {
            let Some(&u) = self.seq[t as usize].uops.front() else { continue };
            let mut latch = self.seq[t as usize].latch;
            self.complete_with(t, u, &mut latch, &mut d);
            d.j.writes.push(WriteOf::Seq { thread: t, issued: true, inflight: None, latch });
        }
        self.plan(cmds, &mut d);
        let r = cmds.iter().map(|c| d.answer(c.0)).collect();
        self.commit(&d);
        d.clear();
        self.scratch = d;
        r
    }

    /// Functional level: accept the command and complete its whole program at once.
    pub fn apply(&mut self, t: u32, cmd: Cmd) -> Result<Option<Entry>, StackError> {
        let r = self.accept(t, cmd)?;
        while let Some(u) = self.seq[t as usize].uops.pop_front() {
            self.complete(t, u);
        }
        self.sync_queued(t);
        Ok(r)
    }
}
