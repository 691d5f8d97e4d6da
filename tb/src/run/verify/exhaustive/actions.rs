//! What a model state offers next: every command (valid or not) of a ready thread, every
//! pending micro-op completion, the combined same-cycle actions, the private micro-op the
//! partial-order reduction expands alone, and the byte decoding the random and Kani harnesses
//! use. Kept apart from the checked step ([`super::model`]) because the search's branching is
//! a subject of its own.

use rtl::stack_manager::{Cmd, Uop};

use super::model::{Action, Model, MARKED, UNMARKED};

impl Model {
    /// The lowest-numbered thread whose next micro-op is *private* — a global load, a global
    /// store or latch → RB bottom: it reads and writes only that thread's RB, spill region,
    /// sequencer and data latch, which no other thread's action reads or writes — or `None`.
    /// The ample set of the partial-order reduction (module doc).
    pub fn private_uop(&self) -> Option<u32> {
        self.sm.warp_threads(self.warp).find(|&t| {
            matches!(
                self.sm.pending_uops(t).next(),
                Some(Uop::GlobalLoad { .. } | Uop::GlobalStore { .. } | Uop::RbBottom)
            )
        })
    }

    /// Entries the warp holds (the reference's view).
    pub fn held(&self) -> u32 {
        self.sm.warp_threads(self.warp).map(|t| self.sb.reference(t).len() as u32).sum()
    }

    /// Every action possible now: commands (valid or not) of ready unfinished threads with push
    /// values 1..=values, and the next micro-op of each busy thread.
    pub fn actions(&self, values: u32) -> Vec<Action> {
        self.actions_capped(values, None)
    }

    /// [`Model::actions`], with pushes offered only while the warp holds fewer than `cap`
    /// entries.
    pub fn actions_capped(&self, values: u32, cap: Option<u32>) -> Vec<Action> {
        let sm = &self.sm;
        let push = cap.is_none_or(|c| self.held() < c);
        let mut out = Vec::new();
        for t in sm.warp_threads(self.warp) {
            if !sm.ready(t) {
                out.push(Action::Uop(t));
                if self.busy_cmds && !sm.thread(t).done {
                    out.extend([Cmd::Push(UNMARKED), Cmd::Pop, Cmd::Finish].map(|c| Action::Cmd(t, c)));
                }
                if self.uop_cmds {
                    self.uop_cmd_actions(t, push, &mut out);
                }
                continue;
            }
            if sm.thread(t).done || self.is_silent(t) {
                continue;
            }
            if push && self.one_mark {
                out.push(Action::Cmd(t, Cmd::Push(UNMARKED)));
                if !self.marked {
                    out.push(Action::Cmd(t, Cmd::Push(MARKED)));
                }
            } else if push {
                out.extend((1..=values as u64).map(|v| Action::Cmd(t, Cmd::Push(v))));
            }
            out.push(Action::Cmd(t, Cmd::Pop));
            out.push(Action::Cmd(t, Cmd::Finish));
        }
        if self.pairs {
            self.pair_actions(cap, &mut out);
        }
        out
    }

    /// Busy thread `u`'s next micro-op completing in the cycle of a command of `u` itself or of
    /// any ready, unfinished thread: every kind, pushes carrying [`UNMARKED`] while `push` (the
    /// cap leaves room).
    fn uop_cmd_actions(&self, u: u32, push: bool, out: &mut Vec<Action>) {
        let sm = &self.sm;
        let kinds: &[Cmd] =
            if push { &[Cmd::Push(UNMARKED), Cmd::Pop, Cmd::Finish] } else { &[Cmd::Pop, Cmd::Finish] };
        let open = |t: u32| t == u || (sm.ready(t) && !sm.thread(t).done && !self.is_silent(t));
        for t in sm.warp_threads(self.warp).filter(|&t| open(t)) {
            out.extend(kinds.iter().map(|&c| Action::UopWithCmd(u, t, c)));
        }
    }

    /// Two ready, unfinished threads' commands in one cycle, in lane order: every pair of
    /// kinds, pushes carrying [`UNMARKED`] (or value 2) while the cap leaves room for them.
    fn pair_actions(&self, cap: Option<u32>, out: &mut Vec<Action>) {
        let sm = &self.sm;
        let room = cap.map_or(u32::MAX, |c| c.saturating_sub(self.held()));
        let open: Vec<u32> = sm
            .warp_threads(self.warp)
            .filter(|&t| sm.ready(t) && !sm.thread(t).done && !self.is_silent(t))
            .collect();
        let kinds = [Cmd::Push(UNMARKED), Cmd::Pop, Cmd::Finish];
        for (i, &t) in open.iter().enumerate() {
            for &u in &open[i + 1..] {
                for a in kinds {
                    for b in kinds {
                        let pushes =
                            u32::from(matches!(a, Cmd::Push(_))) + u32::from(matches!(b, Cmd::Push(_)));
                        if pushes <= room {
                            out.push(Action::Both(t, a, u, b));
                        }
                    }
                }
            }
        }
    }

    /// Decodes one input byte pair into an action for the current state: the first byte picks
    /// the thread (a busy thread completes a micro-op), the second the command, biased to
    /// pushes so stacks get deep. `value` is the push value to use.
    pub fn decode(&self, (a, b): (u8, u8), value: u64) -> Action {
        let ws = self.sm.config().warp_size;
        let t = self.warp * ws + a as u32 % ws;
        if !self.sm.ready(t) {
            return Action::Uop(t);
        }
        match b {
            0..=139 => Action::Cmd(t, Cmd::Push(value)),
            140..=249 => Action::Cmd(t, Cmd::Pop),
            _ => Action::Cmd(t, Cmd::Finish),
        }
    }
}
