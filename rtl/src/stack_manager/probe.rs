//! The stack manager's signals, for waveforms.

use super::{Cmd, Entry, StackManager, Uop};
use crate::trace::{Kind, Probe, Sink};

/// The registers alone (no command this cycle).
impl Probe for StackManager {
    fn probe<S: Sink>(&self, s: &mut S) {
        self.probe_cycle(&[], &[], s);
    }
}

impl StackManager {
    /// The registers, and the cycle's commands `cmds` (the input) with the pops that answered
    /// them (`pops`, from [`super::StackStep::pops`]).
    pub fn probe_cycle<S: Sink>(&self, cmds: &[(u32, Cmd)], pops: &[(u32, Entry)], s: &mut S) {
        self.probe_signals(|t| cmds.iter().find(|c| c.0 == t).map_or(Cmd::None, |c| c.1), pops, s);
    }

    /// The registers, each thread's command `cmd(t)` and the pops that answered them.
    pub(super) fn probe_signals<S: Sink>(&self, cmd: impl Fn(u32) -> Cmd, pops: &[(u32, Entry)], s: &mut S) {
        if !s.enabled() {
            return;
        }
        let w = &self.w;
        for wp in 0..self.cfg.warps {
            s.push_scope(&format!("warp[{wp}]"));
            for t in self.warp_threads(wp) {
                let lane = t % self.cfg.warp_size;
                s.push_scope(&format!("thread[{lane}]"));
                let cmd = cmd(t);
                let data = match cmd {
                    Cmd::Push(v) => v,
                    Cmd::Pop => pops.iter().find(|p| p.0 == t).map_or(0, |p| p.1),
                    Cmd::None | Cmd::Finish => 0,
                };
                s.signal("cmd_valid", 1, u64::from(cmd != Cmd::None));
                s.signal_kind("cmd_kind", 2, cmd.code(), Cmd::KIND);
                s.signal_kind("cmd_data", w.entry, data, Kind::Data);
                s.signal_kind("uop", Uop::CODE_BITS, Uop::code(self.seq[t as usize].inflight), Uop::KIND);
                let th = &self.threads[t as usize];
                let st = &self.stacks[t as usize];
                s.signal("rb_count", w.rb_count, self.rb[t as usize].len() as u64);
                s.signal_kind(
                    "rb_top",
                    w.entry,
                    self.rb[t as usize].back().copied().unwrap_or(0),
                    Kind::Data,
                );
                if w.top > 0 {
                    s.signal("top", w.top, st.top as u64);
                    s.signal("bottom", w.bottom, st.bottom as u64);
                }
                if w.sh_empty > 0 {
                    s.signal("sh_empty", w.sh_empty, u64::from(st.empty));
                }
                s.signal("overflow", w.overflow, u64::from(th.overflow));
                if self.cfg.realloc().is_some() {
                    s.signal("idle", w.idle, u64::from(st.idle));
                    s.signal("next_tid", w.next_tid, st.next_tid as u64);
                    s.signal("priority", w.priority, st.priority as u64);
                    s.signal("flush", w.flush, st.flush as u64);
                }
                s.signal("spill_ptr", w.spill_ptr, th.spill_ptr as u64);
                s.signal("done", 1, u64::from(th.done));
                s.signal("busy", 1, u64::from(!self.ready(t)));
                s.pop_scope();
            }
            s.pop_scope();
        }
    }
}
