//! `sms prove`: the stack manager's decision logic, the same code the simulator runs
//! ([`rtl::stack_manager::policy`] over [`rtl::logic::Logic`]), checked by SMT solvers against
//! the specification ([`spec`]) at a named configuration.
//!
//! - [`sym`]: the symbolic [`rtl::logic::Logic`] instance (SMT-LIB 2 terms);
//! - [`spec`]: SPEC sections 3 and 5 as a second, independent description;
//! - [`query`]: the well-formedness invariant, the one-step equivalence and induction queries;
//! - [`conserve`]: conservation of the logical stack through one tracked entry;
//! - [`solver`]: z3 and cvc5 as processes;
//! - [`replay`]: a counterexample run on the simulator and dumped as a waveform.

pub mod conserve;
pub mod cycle;
pub mod query;
pub mod replay;
pub mod scoreboard;
pub mod solver;
pub mod spec;
pub mod sym;

use std::time::Duration;

use anyhow::Result;
use rtl::config::Config;
use rtl::stack_manager::cycle::CycleSteps;

use query::Kind;
use solver::{Solver, Verdict};

/// A proof obligation: one cycle's commands (lanes of the warp at `base`, planned in order),
/// and what is proved of that cycle.
#[derive(Clone, Debug)]
pub struct Obligation {
    pub name: String,
    pub base: u32,
    pub cmds: Vec<(u32, Kind)>,
    pub what: What,
    /// The cycle's control shape ([`What::Cycle`] only).
    pub shape: Vec<cycle::LaneShape>,
    /// Global stores wait for their acknowledgement ([`What::Cycle`] only).
    pub acked: bool,
}

/// What an obligation proves of one cycle, from every state satisfying the invariant
/// ([`query::well_formed`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum What {
    /// The design's answers, programs and register writes equal the specification's.
    Equivalence,
    /// The design's cycle leaves a state satisfying the invariant (an induction step; with the
    /// reset state satisfying it, the invariant holds in every reachable state).
    Invariant,
    /// The entry at a symbolic position of the commanding thread's logical stack is at the
    /// position the reference stack gives it after the cycle ([`conserve`]).
    Conservation,
    /// The design's whole cycle (completions, issue, plans, the merge of their writes, the
    /// edge) leaves the next state, requests and answers the specification's cycle gives, for
    /// one control shape ([`cycle`]).
    Cycle,
}

/// The one-step equivalence obligations at `cfg`: each command kind on one lane, and two
/// lanes' pushes planned in one cycle (the second sees the first's borrow). The warp is the
/// second one when the RT unit has several, so thread ids and lanes differ.
pub fn obligations(cfg: &Config) -> Vec<Obligation> {
    let ws = cfg.warp_size;
    let base = if cfg.warps > 1 { ws } else { 0 };
    let a = 5.min(ws - 1);
    let b = (a + ws / 2) % ws;
    let mut cycles: Vec<(String, Vec<(u32, Kind)>)> = [Kind::Push, Kind::Pop, Kind::Finish]
        .into_iter()
        .map(|k| (k.name().to_string(), vec![(a, k)]))
        .collect();
    if b != a {
        cycles.push(("push+push (two lanes, one cycle)".into(), vec![(a, Kind::Push), (b, Kind::Push)]));
    }
    let mut out = Vec::new();
    for (what, prefix) in [(What::Equivalence, "one-step"), (What::Invariant, "invariant kept by")] {
        for (name, cmds) in &cycles {
            let name = format!("{prefix} {name}");
            out.push(Obligation { name, base, cmds: cmds.clone(), what, shape: Vec::new(), acked: false });
        }
    }
    for k in [Kind::Push, Kind::Pop] {
        let name = format!("conservation through {}", k.name());
        let (cmds, shape) = (vec![(a, k)], Vec::new());
        out.push(Obligation { name, base, cmds, what: What::Conservation, shape, acked: false });
    }
    out.extend(cycle_obligations(cfg));
    out
}

/// The whole-cycle obligations at `cfg` ([`cycle::shapes`]), with posted and with
/// acknowledged global stores.
pub fn cycle_obligations(cfg: &Config) -> Vec<Obligation> {
    let base = if cfg.warps > 1 { cfg.warp_size } else { 0 };
    let mut out = Vec::new();
    for acked in [false, true] {
        let stores = if acked { "acked stores" } else { "posted stores" };
        for (name, shape) in cycle::shapes(cfg, acked) {
            let name = format!("whole cycle, {stores}: {name}");
            out.push(Obligation { name, base, cmds: Vec::new(), what: What::Cycle, shape, acked });
        }
    }
    out
}

/// What one solver said about one obligation.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub property: String,
    pub config: String,
    pub solver: Solver,
    pub verdict: Verdict,
    pub seconds: f64,
    /// Terms in the query's DAG.
    pub terms: usize,
    /// The compared parts that differ in the counterexample.
    pub differ: Vec<String>,
}

/// Proves `ob` for the design with `steps` at `cfg` with each of `solvers`.
pub fn prove<P: CycleSteps>(
    cfg: &Config,
    steps: &P,
    ob: &Obligation,
    solvers: &[Solver],
    limit: Duration,
) -> Result<Vec<Outcome>> {
    let q = match ob.what {
        What::Equivalence => query::one_step(cfg, steps, ob.base, &ob.cmds),
        What::Invariant => query::preserves(cfg, steps, ob.base, &ob.cmds),
        What::Conservation => conserve::conserves(cfg, steps, ob.base, ob.cmds[0].0, ob.cmds[0].1),
        What::Cycle => cycle::whole_cycle(cfg, steps, ob.base, &ob.shape, ob.acked),
    };
    let mut out = Vec::new();
    for &sv in solvers {
        let (verdict, took) = solver::check(sv, &q.text, &q.vars, limit)?;
        let differ = match &verdict {
            Verdict::Counterexample(vals) => q
                .parts
                .iter()
                .enumerate()
                .filter(|(k, _)| vals.iter().any(|(n, v)| *n == format!("agree_{k}") && *v == 0))
                .map(|(_, p)| p.clone())
                .collect(),
            _ => Vec::new(),
        };
        out.push(Outcome {
            property: ob.name.clone(),
            config: cfg.name(),
            solver: sv,
            verdict,
            seconds: took.as_secs_f64(),
            terms: q.terms,
            differ,
        });
    }
    Ok(out)
}
