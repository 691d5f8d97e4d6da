//! Which implementation of the policy a stack manager runs, chosen when it is built.
//!
//! Each [`ShPolicy`] has one implementation of [`Steps`] (the paper's [`Design`] for dedicated
//! stacks and `+RA`; [`Group`] for `+RA_G`); [`for_policy`] is the one place that maps the
//! first to the second, for any code generic over the implementation (the simulator, `sms
//! prove`, the Verilog printer). The simulator holds its choice as a [`StackPolicy`]: the whole
//! cycle instantiated on integers, behind one pointer, so a manager built with any
//! implementation (a planted bug included) runs the same code path.

use std::sync::Arc;

use super::cycle::{self, CycleIn, CycleSteps, Journal};
use super::group::Group;
use super::policy::Design;
use super::regs::{Cmd, Entry, Uop};
use super::StackManager;
use crate::config::{Config, ShPolicy, Widths};
use crate::logic::Int;

/// An implementation of the policy the simulator can hold ([`StackPolicy`]): plain data.
pub trait Implementation: CycleSteps + Copy + Send + Sync + std::panic::RefUnwindSafe + 'static {}

impl<P: CycleSteps + Copy + Send + Sync + std::panic::RefUnwindSafe + 'static> Implementation for P {}

/// Code generic over the policy's implementation, run by [`for_policy`] with the one a
/// configuration names.
pub trait Visit {
    type Out;
    fn visit<P: Implementation>(self, steps: &P) -> Self::Out;
}

/// Runs `v` with the implementation of `policy`.
pub fn for_policy<V: Visit>(policy: &ShPolicy, v: V) -> V::Out {
    match policy {
        ShPolicy::Dedicated | ShPolicy::Realloc(_) => v.visit(&Design),
        ShPolicy::Group { .. } => v.visit(&Group),
    }
}

/// The cycle of one implementation on integers (what the simulator runs; the manager calls it
/// through its [`StackPolicy`]).
pub(super) trait IntCycle: Send + Sync + std::panic::RefUnwindSafe {
    fn name(&self) -> &'static str;
    fn eval(&self, cfg: &Config, w: &Widths, q: &StackManager, i: &CycleIn<'_, Entry>, d: &mut Journal<Int>);
    fn plan(&self, cfg: &Config, w: &Widths, q: &StackManager, cmds: &[(u32, Cmd)], d: &mut Journal<Int>);
    #[allow(clippy::too_many_arguments)]
    fn complete(
        &self,
        cfg: &Config,
        q: &StackManager,
        t: u32,
        u: Uop,
        latch: &mut Option<Entry>,
        d: &mut Journal<Int>,
    );
    fn skew_base(&self, q: &StackManager, lane: u32) -> u32;
}

impl<P: Implementation> IntCycle for P {
    fn name(&self) -> &'static str {
        Steps::name(self)
    }
    fn eval(&self, cfg: &Config, w: &Widths, q: &StackManager, i: &CycleIn<'_, Entry>, d: &mut Journal<Int>) {
        cycle::eval(&mut Int, self, cfg, w, q, i, d)
    }
    fn plan(&self, cfg: &Config, w: &Widths, q: &StackManager, cmds: &[(u32, Cmd)], d: &mut Journal<Int>) {
        cycle::plan(&mut Int, self, cfg, w, q, cmds, d)
    }
    fn complete(
        &self,
        cfg: &Config,
        q: &StackManager,
        t: u32,
        u: Uop,
        latch: &mut Option<Entry>,
        d: &mut Journal<Int>,
    ) {
        cycle::complete(&mut Int, self, cfg, q, t, u, latch, d)
    }
    fn skew_base(&self, q: &StackManager, lane: u32) -> u32 {
        q.base_with(self, lane)
    }
}

use super::policy::Steps;

/// The implementation a stack manager runs: cloned with the manager, compared by name.
#[derive(Clone)]
pub struct StackPolicy(pub(super) Arc<dyn IntCycle>);

struct Make;

impl Visit for Make {
    type Out = StackPolicy;
    fn visit<P: Implementation>(self, steps: &P) -> StackPolicy {
        StackPolicy::new(*steps)
    }
}

impl StackPolicy {
    /// The implementation `cfg`'s policy names.
    pub fn of(cfg: &Config) -> StackPolicy {
        for_policy(&cfg.policy, Make)
    }

    /// Any implementation (a test build's planted bug, a design under study).
    pub fn new<P: Implementation>(steps: P) -> StackPolicy {
        StackPolicy(Arc::new(steps))
    }

    pub fn name(&self) -> &'static str {
        self.0.name()
    }

    /// The same implementation: one pointer, or equal names.
    pub fn same(&self, other: &StackPolicy) -> bool {
        Arc::ptr_eq(&self.0, &other.0) || self.name() == other.name()
    }
}

impl std::fmt::Debug for StackPolicy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "StackPolicy({})", self.name())
    }
}

impl PartialEq for StackPolicy {
    fn eq(&self, other: &Self) -> bool {
        self.same(other)
    }
}

impl Eq for StackPolicy {}

impl std::hash::Hash for StackPolicy {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        self.name().hash(h)
    }
}
