//! Signal tracing, kept outside the logic.
//!
//! A unit implements [`Probe`] by walking its signals in a fixed order: scopes (`push_scope` /
//! `pop_scope`) and signals (`signal(name, width, value)`). The order and the set of signals is
//! the same every cycle, so a sink may declare on the first walk and only compare values after.
//! Widths are those of [`crate::config::Widths`]: the hardware's widths. A probe may also
//! declare what a signal's value means ([`Kind`], through [`Sink::signal_kind`]): a waveform
//! viewer picks its display format from that declaration, not from the signal's name.

/// What a signal's value means, as its probe declares it. [`Sink::signal`] declares
/// [`Kind::Number`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Kind {
    /// A count, index, pointer or flag.
    #[default]
    Number,
    /// A byte address.
    Address,
    /// A data word (a stack entry, a request id).
    Data,
    /// One bit per lane, bank or thread.
    Mask,
    /// An encoded enumeration: value `i` is `names[i]`; `name` names the encoding.
    Enum { name: &'static str, names: &'static [&'static str] },
}

/// Receives signal values. Generic callers monomorphise over the sink, so [`NullSink`] costs
/// nothing: `enabled()` is a constant `false` and every probe returns before walking.
pub trait Sink {
    fn enabled(&self) -> bool;
    /// The first cycle at or after `cycle` whose walk this sink wants, `None` for none. A driver
    /// may leave out the walks of other cycles and skip idle cycles up to the next wanted one
    /// (a VCD window): a dump outside its window then costs almost nothing.
    fn next_wanted(&self, cycle: u64) -> Option<u64> {
        self.enabled().then_some(cycle)
    }
    /// The run ended after `cycles` cycles (drivers that skip cycles call this, so a sink knows
    /// the run's length even when it saw none of the last cycles).
    fn end_run(&mut self, _cycles: u64) {}
    /// Marks the start of a new cycle's walk (a VCD timestamp).
    fn begin_cycle(&mut self, _cycle: u64) {}
    fn push_scope(&mut self, name: &str);
    fn pop_scope(&mut self);
    fn signal(&mut self, name: &str, width: u32, value: u64);
    /// A signal whose meaning is `kind` (the default forgets it: most sinks only want values).
    fn signal_kind(&mut self, name: &str, width: u32, value: u64, kind: Kind) {
        let _ = kind;
        self.signal(name, width, value);
    }
}

/// A unit that can show its registers and per-cycle signals to a [`Sink`].
pub trait Probe {
    fn probe<S: Sink>(&self, sink: &mut S);
}

/// Tracing off.
#[derive(Clone, Copy, Debug, Default)]
pub struct NullSink;

impl Sink for NullSink {
    #[inline(always)]
    fn enabled(&self) -> bool {
        false
    }
    #[inline(always)]
    fn push_scope(&mut self, _: &str) {}
    #[inline(always)]
    fn pop_scope(&mut self) {}
    #[inline(always)]
    fn signal(&mut self, _: &str, _: u32, _: u64) {}
    #[inline(always)]
    fn signal_kind(&mut self, _: &str, _: u32, _: u64, _: Kind) {}
}

/// A sink that records `(path, width, value)` for one walk; used by tests and by the VCD writer's
/// declaration pass.
#[derive(Clone, Debug, Default)]
pub struct Snapshot {
    scope: Vec<String>,
    pub signals: Vec<(String, u32, u64)>,
    /// The declared [`Kind`] of each signal, in the order of `signals`.
    pub kinds: Vec<Kind>,
}

impl Sink for Snapshot {
    fn enabled(&self) -> bool {
        true
    }
    fn push_scope(&mut self, name: &str) {
        self.scope.push(name.to_string());
    }
    fn pop_scope(&mut self) {
        self.scope.pop();
    }
    fn signal(&mut self, name: &str, width: u32, value: u64) {
        self.signal_kind(name, width, value, Kind::Number);
    }
    fn signal_kind(&mut self, name: &str, width: u32, value: u64, kind: Kind) {
        self.kinds.push(kind);
        let mut path = self.scope.join(".");
        if !path.is_empty() {
            path.push('.');
        }
        path.push_str(name);
        self.signals.push((path, width, value));
    }
}

impl Snapshot {
    /// Value of the signal at `path` (scopes joined by '.').
    pub fn get(&self, path: &str) -> Option<u64> {
        self.signals.iter().find(|(p, _, _)| p == path).map(|s| s.2)
    }
}

#[cfg(test)]
mod tests {
    use super::Kind;
    use crate::mem::ReqKind;
    use crate::stack_manager::{Cmd, Src, Uop};
    use crate::thread_fsm::ThreadState;

    /// `WaitMem { left: 1, lat: 2 }` → `wait_mem`: the variant's own name, as a waveform shows it.
    fn variant_name(debug: &str) -> String {
        let head = debug.split([' ', '(', '{']).next().unwrap_or_default();
        let mut out = String::new();
        for (i, c) in head.chars().enumerate() {
            if c.is_uppercase() && i > 0 {
                out.push('_');
            }
            out.push(c.to_ascii_lowercase());
        }
        out
    }

    /// Every value of an encoding is named by the variant that has that code, and every code
    /// is some variant's: the names are the enum's own, not a hand-kept list.
    fn check<T: std::fmt::Debug>(kind: Kind, values: &[(T, u64)], absent: Option<&str>) {
        let Kind::Enum { names, .. } = kind else { panic!("{kind:?} is not an enum") };
        let mut seen = vec![false; names.len()];
        for (v, code) in values {
            assert_eq!(names[*code as usize], variant_name(&format!("{v:?}")), "{v:?}");
            seen[*code as usize] = true;
        }
        if let Some(absent) = absent {
            assert_eq!(names[0], absent);
            seen[0] = true;
        }
        assert!(seen.iter().all(|&s| s), "{names:?}: a name no variant has");
    }

    #[test]
    fn enum_names_are_the_variants_names() {
        let cmds = [Cmd::None, Cmd::Push(7), Cmd::Pop, Cmd::Finish];
        check(Cmd::KIND, &cmds.map(|c| (c, c.code())), None);
        let states = [
            ThreadState::Done,
            ThreadState::Busy { until: 3 },
            ThreadState::Fetch,
            ThreadState::WaitMem { left: 1, lat: 2 },
            ThreadState::Stack,
        ];
        check(ThreadState::KIND, &states.map(|s| (s, s.code())), None);
        check(ReqKind::KIND, &ReqKind::ALL.map(|k| (k, k.code())), None);
        let uops = [
            Uop::ShLoad { stack: 0, entry: 0 },
            Uop::ShStore { stack: 0, entry: 0, src: Src::Latch },
            Uop::GlobalLoad { slot: 0 },
            Uop::GlobalStore { slot: 0, src: Src::Value(1) },
            Uop::RbBottom,
            Uop::Release { stack: 0 },
        ];
        check(Uop::KIND, &uops.map(|u| (u, Uop::code(Some(u)))), Some("none"));
        assert_eq!(Uop::code(None), 0);
        assert!(Uop::NAMES.len() <= 1 << Uop::CODE_BITS);
    }

    #[test]
    fn a_misnamed_value_is_caught() {
        let wrong = Kind::Enum { name: "cmd_kind", names: &["none", "push", "pull", "finish"] };
        let cmds = [Cmd::None, Cmd::Push(7), Cmd::Pop, Cmd::Finish];
        let r = std::panic::catch_unwind(|| check(wrong, &cmds.map(|c| (c, c.code())), None));
        assert!(r.is_err());
    }
}
