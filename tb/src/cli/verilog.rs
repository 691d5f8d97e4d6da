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
}

pub fn run(args: Args) -> Result<()> {
    let configs = args.stack.resolve(&["SMS"])?;
    let mut reports = Vec::new();
    for cfg in &configs {
        let start = std::time::Instant::now();
        let g = match verilog::generate(cfg, !args.overlapped) {
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
    }
    if !reports.is_empty() {
        print!("{}", verilog::synth::render(&reports));
    }
    Ok(())
}
