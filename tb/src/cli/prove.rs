//! `sms prove`: SMT proofs of the stack manager's decision logic at a named configuration.

use std::time::Duration;

use anyhow::{bail, Result};
use rtl::config::Config;
use rtl::stack_manager::select::{for_policy, Implementation, Visit};
use rtl::stack_manager::Mutant;

use super::stack_config::StackConfigArgs;
use crate::prove::replay::replay;
use crate::prove::solver::{Solver, Verdict};
use crate::prove::{obligations, prove, Obligation, Outcome};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub stack: StackConfigArgs,
    /// Solvers to run every proof with, comma-separated: z3, boolector, cvc5 (Debian packages
    /// of the same names).
    #[arg(long, value_delimiter = ',', default_values_t = ["z3".to_string(), "boolector".to_string()])]
    pub solver: Vec<String>,
    /// Time limit per proof and solver, in seconds; past it the verdict is "unknown".
    #[arg(long, default_value_t = 600)]
    pub timeout: u64,
    /// Only the properties whose name contains TEXT; an error listing the properties if none
    /// does.
    #[arg(long, value_name = "TEXT")]
    pub only: Option<String>,
    /// Prove a planted bug instead of the design (builds with `--features mutants`): a
    /// counterexample is the expected answer.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(Mutant::NAMES))]
    pub mutant: Option<String>,
    /// Replay the first counterexample on the simulator and dump it to FILE (VCD, with a
    /// GTKWave save file beside it): time 0 is the solver's state, time 1 the cycle after.
    #[arg(long, value_name = "FILE")]
    pub vcd: Option<std::path::PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    if let Some(vcd) = &args.vcd {
        crate::cli::guard::outside_scene_data("--vcd", vcd, &crate::SceneLibrary::default().data)?;
    }
    let cfgs = args.stack.resolve(&["SMS"])?;
    if let Some(only) = &args.only {
        let mut names: Vec<String> = Vec::new();
        for ob in cfgs.iter().flat_map(obligations) {
            if !names.contains(&ob.name) {
                names.push(ob.name);
            }
        }
        if !names.iter().any(|n| n.contains(only.as_str())) {
            bail!("--only {only:?}: no property's name contains it; the properties: {}", names.join("; "));
        }
    }
    let mut solvers = Vec::new();
    for s in &args.solver {
        let Some(sv) = Solver::from_name(s) else {
            bail!("--solver {s}: unknown; one of z3, boolector, cvc5")
        };
        sv.check_installed()?;
        solvers.push(sv);
    }
    let limit = Duration::from_secs(args.timeout);
    let mut all = Vec::new();
    let mut dumped = false;
    for cfg in &cfgs {
        for ob in obligations(cfg) {
            if args.only.as_ref().is_some_and(|t| !ob.name.contains(t.as_str())) {
                continue;
            }
            crate::cli::note(format!("proving {} at {} ...", ob.name, cfg.name()));
            let outs = match args.mutant.as_deref() {
                None => for_policy(&cfg.policy, Prove { cfg, ob: &ob, solvers: &solvers, limit })?,
                Some(name) => prove_mutant(name, cfg, &ob, &solvers, limit)?,
            };
            for o in &outs {
                println!("{}", line(o));
            }
            if let (Some(path), Some(vals)) = (&args.vcd, outs.iter().find_map(counterexample)) {
                if !dumped {
                    let sm = design(rtl::stack_manager::StackManager::new(*cfg, 0)?, args.mutant.as_deref());
                    let r = replay(*cfg, sm, &ob, vals, path)?;
                    for a in r.answers {
                        println!("  replayed: {a}");
                    }
                    println!("  counterexample dumped to {} (+ .gtkw)", path.display());
                    dumped = true;
                }
            }
            all.extend(outs);
        }
    }
    let failed = all.iter().filter(|o| !matches!(o.verdict, Verdict::Proved)).count();
    if failed > 0 && args.mutant.is_none() {
        bail!("{failed} of {} proofs not proved", all.len());
    }
    Ok(())
}

/// `prove` with the implementation of the configuration's policy.
struct Prove<'a> {
    cfg: &'a Config,
    ob: &'a Obligation,
    solvers: &'a [Solver],
    limit: Duration,
}

impl Visit for Prove<'_> {
    type Out = Result<Vec<Outcome>>;
    fn visit<P: Implementation>(self, steps: &P) -> Self::Out {
        prove(self.cfg, steps, self.ob, self.solvers, self.limit)
    }
}

fn counterexample(o: &Outcome) -> Option<&Vec<(String, u64)>> {
    match &o.verdict {
        Verdict::Counterexample(v) => Some(v),
        _ => None,
    }
}

/// The stack manager as built, or with the planted bug `mutant`.
fn design(sm: rtl::stack_manager::StackManager, _mutant: Option<&str>) -> rtl::stack_manager::StackManager {
    #[cfg(feature = "mutants")]
    let sm = sm.with_mutant(_mutant.and_then(Mutant::from_name));
    sm
}

fn line(o: &Outcome) -> String {
    let what = match &o.verdict {
        Verdict::Proved => "proved".to_string(),
        Verdict::Counterexample(_) => format!("COUNTEREXAMPLE ({} differ)", o.differ.join("; ")),
        Verdict::Unknown(why) => format!("unknown ({why})"),
    };
    format!(
        "{:<44} {:<18} {:<5} {:>8.1} s  {:>7} terms  {}",
        o.property,
        o.config,
        o.solver.name(),
        o.seconds,
        o.terms,
        what
    )
}

#[cfg(feature = "mutants")]
fn prove_mutant(
    name: &str,
    cfg: &rtl::config::Config,
    ob: &crate::prove::Obligation,
    solvers: &[Solver],
    limit: Duration,
) -> Result<Vec<Outcome>> {
    let m = Mutant::from_name(name).expect("clap checked the name");
    prove(cfg, &rtl::stack_manager::mutants::Mutated(m), ob, solvers, limit)
}

#[cfg(not(feature = "mutants"))]
fn prove_mutant(
    name: &str,
    _: &rtl::config::Config,
    _: &crate::prove::Obligation,
    _: &[Solver],
    _: Duration,
) -> Result<Vec<Outcome>> {
    bail!("--mutant {name}: this build has no planted bugs; build with `--features mutants`")
}
