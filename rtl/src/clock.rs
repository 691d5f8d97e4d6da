//! How a cycle is evaluated, and the checks that show evaluation order does not matter.
//!
//! Every unit computes its outputs and its next register values from its current registers and
//! this cycle's inputs; registers change only when the runner commits at the clock edge. Units
//! with no combinational path between them (the SMs) are *siblings*: the order in which they are
//! evaluated cannot matter, and evaluating a unit twice in a cycle must give the same outputs and
//! next state. [`EvalCheck`] makes a run evaluate siblings in a seeded random order each cycle,
//! or every kernel twice, so tests can compare its report with the normal run's bit for bit (the
//! reference loop evaluates the GPU so, `sim/check.rs`). [`Unit`] is the shape every clocked
//! unit has.

use crate::trace::Sink;

/// A clocked unit: its registers are `self`; [`Unit::eval`] is its combinational logic and
/// [`Unit::commit`] its clock edge.
///
/// - `eval(&self, inputs, &mut step)` reads only the registers and this cycle's inputs and
///   overwrites the step with the cycle's outputs and register writes. It is the pure
///   `next(&Regs, &In) -> (Out, Regs')` of a hardware description, written into a buffer the
///   caller reuses so that a cycle allocates nothing once warm ([`Unit::step`] is the same
///   function returning a fresh step). Evaluating twice from the same registers gives the same
///   step ([`EvalCheck::Twice`]).
/// - `commit(&mut self, &step)` is the clock edge: it applies the step and takes no other
///   input, so the registers after the edge follow from the registers and the step alone. Most
///   commits only write what the eval decided; a register file does its write port's own work
///   there (the RT unit's fetch queue coalesces the issued warp's pieces, the L1D's write-through
///   looks its sector up in the tags). Nothing changes a unit's registers between `eval` and `commit`, so a
///   value computed this cycle travels only as a step's output passed in another unit's `In`.
/// - `probe(&self, &step, sink)` shows the registers and the cycle's signals from the step. A
///   register file that a parent writes in its own commit (the warp buffer, the node fetch's
///   queues), or a whole design that keeps its steps itself, implements
///   [`crate::trace::Probe`] instead.
/// - A unit that can act without an input also tells when ([`Unit::next_event`]; the bank
///   arbiter, which does not count cycles, answers `busy` and `pipe_due` to its parent), and a
///   unit with a clock of its own moves it over quiet cycles ([`Unit::skip_to`]): the runners'
///   idle skip asks.
///
/// A parent holds its children by value in its registers, its `In` and `Step` hold theirs, its
/// `eval` calls theirs in dataflow order wiring outputs to inputs by hand, its `commit` calls
/// theirs, and its probe asks only its direct children.
pub trait Unit {
    /// This cycle's inputs: other units' register outputs, or the combinational outputs of units
    /// evaluated before this one.
    type In<'a>;
    /// One cycle's outputs and register writes.
    type Step: Default;

    /// The cycle's combinational logic, written into `step` (see the trait's documentation).
    fn eval(&self, i: Self::In<'_>, step: &mut Self::Step);

    /// The clock edge: applies `step`, this cycle's evaluation.
    fn commit(&mut self, step: &Self::Step);

    /// The registers and the cycle's signals from `step`, to `sink`.
    fn probe<S: Sink>(&self, step: &Self::Step, sink: &mut S);

    /// The first cycle, from the last commit on, in which this unit does something with no new
    /// input; `None` while it only waits for one. The runners' idle skip asks every unit. The
    /// default is a unit that acts only on its inputs.
    fn next_event(&self) -> Option<u64> {
        None
    }

    /// Moves the unit's clock to `cycle` over cycles in which nothing happens (never past
    /// [`Unit::next_event`]): all that committing a quiet step in each would do. The default is a
    /// unit without a clock of its own.
    fn skip_to(&mut self, _cycle: u64) {}

    /// [`Unit::eval`] into a fresh step: the pure form, for tests and one-off evaluations.
    fn step(&self, i: Self::In<'_>) -> Self::Step {
        let mut step = Self::Step::default();
        self.eval(i, &mut step);
        step
    }
}

/// How a runner evaluates sibling units within a cycle.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EvalCheck {
    /// Siblings in index order, each once (the normal build).
    #[default]
    Dataflow,
    /// Siblings in a random order drawn afresh each cycle from `seed` and the cycle number.
    Shuffled { seed: u64 },
    /// Every kernel evaluated twice per cycle into the same step; the second evaluation's results
    /// are the ones committed (a kernel that reads its own step back changes the report).
    Twice,
    /// Every unit evaluated every cycle, including those the runner would let sleep (no event
    /// due, no input): shows the wake-up skip changes nothing.
    EveryUnit,
}

impl EvalCheck {
    /// How many times each kernel is evaluated per cycle.
    pub fn passes(self) -> u32 {
        if self == EvalCheck::Twice {
            2
        } else {
            1
        }
    }

    /// Whether a runner may skip a unit that has nothing to do this cycle.
    pub fn skips_quiet_units(self) -> bool {
        self != EvalCheck::EveryUnit
    }
}
