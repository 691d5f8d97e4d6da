//! `sms verilog`: the stack manager as synthesizable Verilog, with `--synth` its yosys report.

use std::path::PathBuf;

use anyhow::{bail, Result};

use super::note;
use super::stack_config::StackConfigArgs;
use crate::verilog;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub stack: StackConfigArgs,
    /// Folder the Verilog goes to (`<folder>/sms_stack_manager.v`, one subfolder per
    /// configuration when several are given).
    #[arg(long)]
    pub out: PathBuf,
    /// Global stores posted (the overlapped timing) instead of acknowledged (blocking).
    #[arg(long)]
    pub overlapped: bool,
    /// Synthesize each with yosys's generic flow and report flip-flops (checked against the
    /// bit accounting of `sms cost`), logic cells by kind and logic depth.
    #[arg(long)]
    pub synth: bool,
    /// Prove the well-formedness invariant on each warp module with yosys's SAT solver
    /// (`sat -tempinduct`) from a warp load on; inputs free but for the SMT cycle proofs' input
    /// protocol. Verdict: proved by k-induction, bounded (holds for the first cycles only, when
    /// induction does not close within --steps; the clauses its induction step breaks are
    /// named), or a counterexample naming the failing clauses.
    /// At most 4 lanes, 4 SH and 4 RB entries. docs/verilog.md, section Formal
    #[arg(long)]
    pub prove: bool,
    /// Most time steps of --prove's induction (the first loads the warp): the SAT problems grow
    /// with it (2 lanes, RB_1+SH_2: 3 steps take about 10 s of CPU, 5 steps over a minute)
    #[arg(long, default_value_t = 4)]
    pub steps: u32,
}

pub fn run(args: Args) -> Result<()> {
    let configs = args.stack.resolve(&["SMS"])?;
    if args.prove {
        if args.steps < 2 {
            bail!("--steps {}: the first step loads the warp, so at least 2 are needed", args.steps);
        }
        if let Some(e) = configs.iter().find_map(verilog::formal::too_large) {
            bail!(e);
        }
    }
    let mut reports = Vec::new();
    let mut proofs = Vec::new();
    for cfg in &configs {
        let start = std::time::Instant::now();
        let mut g = match verilog::generate(cfg, !args.overlapped) {
            Ok(g) => g,
            Err(e) => bail!("{}: {e}", cfg.name()),
        };
        let dir =
            if configs.len() > 1 { args.out.join(cfg.name().replace('+', "_")) } else { args.out.clone() };
        let path = verilog::write(&g, &dir)?;
        note(format!(
            "{}: {} ({} paths over {} control shapes, {} terms, {:.1} s)",
            verilog::describe(cfg, g.acked),
            path.display(),
            g.circuit.paths,
            g.circuit.shapes,
            g.circuit.sym.size(),
            start.elapsed().as_secs_f64()
        ));
        if args.synth {
            reports.push(verilog::synth::synthesize(&g, &path)?);
        }
        if args.prove {
            let f = verilog::formal::build(&mut g)?;
            let o = verilog::formal::prove(&f, &dir.join("formal"), args.steps)?;
            note(format!("{}: {} ({:.1} s)", o.config, o.verdict, o.seconds));
            proofs.push(o);
        }
    }
    if !reports.is_empty() {
        print!("{}", verilog::synth::render(&reports));
    }
    if !proofs.is_empty() {
        print!("{}", verilog::formal::render(&proofs));
    }
    if proofs.iter().any(|o| matches!(o.verdict, verilog::formal::Verdict::Counterexample { .. })) {
        bail!("the formal check found a counterexample (above)");
    }
    Ok(())
}
