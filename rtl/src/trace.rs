//! Signal tracing, kept outside the logic.
//!
//! A unit implements [`Probe`] by walking its signals in a fixed order: scopes (`push_scope` /
//! `pop_scope`) and signals (`signal(name, width, value)`). The order and the set of signals is
//! the same every cycle, so a sink may declare on the first walk and only compare values after.
//! Widths are those of [`crate::config::Widths`]: the hardware's widths.

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
}

/// A sink that records `(path, width, value)` for one walk; used by tests and by the VCD writer's
/// declaration pass.
#[derive(Clone, Debug, Default)]
pub struct Snapshot {
    scope: Vec<String>,
    pub signals: Vec<(String, u32, u64)>,
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
