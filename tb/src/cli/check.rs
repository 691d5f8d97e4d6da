//! `sms check`: the exhaustive bounded model checker, with bounds from the command line.

use anyhow::{bail, Result};
use proofs::exhaustive::{check, describe, Bounds};
use rtl::config::{Config, RbSize, Realloc};

use crate::table::Table;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// RB entries to check, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [1, 2])]
    pub rb: Vec<u32>,
    /// SH entries per thread, comma-separated (0 or powers of two).
    #[arg(long, value_delimiter = ',', default_values_t = [0, 1, 2])]
    pub sh: Vec<u32>,
    /// Threads per warp, comma-separated (powers of two).
    #[arg(long, value_delimiter = ',', default_values_t = [2, 4])]
    pub warp_size: Vec<u32>,
    /// Borrow limits, comma-separated; 0 = reallocation off.
    #[arg(long, value_delimiter = ',', default_values_t = [0, 1])]
    pub borrow: Vec<u32>,
    /// Flush limit with reallocation.
    #[arg(long, default_value_t = 1)]
    pub flush_limit: u32,
    /// Longest action sequence (commands and micro-op completions) for 2-thread warps.
    #[arg(long, default_value_t = 16)]
    pub depth: u32,
    /// Longest action sequence for wider warps.
    #[arg(long, default_value_t = 9)]
    pub wide_depth: u32,
    /// Distinct push values.
    #[arg(long, default_value_t = 2)]
    pub values: u32,
    /// Stop a configuration after this many distinct states.
    #[arg(long, default_value_t = 20_000_000)]
    pub max_states: usize,
}

fn grid(a: &Args) -> Result<Vec<Config>> {
    let mut out = Vec::new();
    for &n in &a.rb {
        for &m in &a.sh {
            for &ws in &a.warp_size {
                for &borrow in &a.borrow {
                    if borrow > 0 && (m == 0 || borrow >= ws) {
                        continue;
                    }
                    let c = Config {
                        rb: RbSize::Entries(n),
                        sh_entries: m,
                        skew: m > 0 && ws > 2,
                        realloc: (borrow > 0)
                            .then_some(Realloc { borrow_limit: borrow, flush_limit: a.flush_limit }),
                        warp_size: ws,
                        warps: 1,
                        ..Config::default()
                    };
                    c.validate()?;
                    out.push(c);
                }
            }
        }
    }
    if out.is_empty() {
        bail!("no configuration to check: every combination was invalid (reallocation needs --sh > 0 and a borrow limit below the warp size)");
    }
    Ok(out)
}

pub fn run(args: Args) -> Result<()> {
    if args.values < 2 {
        bail!("--values {}: at least 2 distinct values are needed to see entries reordered", args.values);
    }
    let configs = grid(&args)?;
    let mut t = Table::new([
        "configuration",
        "depth",
        "states",
        "sequences",
        "seconds",
        "borrows",
        "flushes",
        "reloads",
        "releases",
        "complete",
    ]);
    let started = std::time::Instant::now();
    for c in &configs {
        let depth = if c.warp_size <= 2 { args.depth } else { args.wide_depth };
        eprintln!("checking {} to depth {depth} ...", describe(c));
        let bounds = Bounds { depth, values: args.values, max_states: args.max_states };
        match check(*c, bounds, |sm| sm) {
            Ok(cov) => t.row([
                describe(c),
                cov.depth_reached.to_string(),
                cov.states.to_string(),
                cov.sequences.to_string(),
                format!("{:.2}", cov.elapsed.as_secs_f64()),
                cov.borrows.to_string(),
                cov.flushes.to_string(),
                cov.global_reloads.to_string(),
                cov.releases.to_string(),
                if cov.complete { "yes".into() } else { "state cap".into() },
            ]),
            Err(cex) => {
                print!("{}", t.to_text());
                bail!(
                    "{}: property violated; shortest counterexample ({} actions):\n{cex}",
                    describe(c),
                    cex.trace.len()
                );
            }
        }
    }
    print!("{}", t.to_text());
    println!(
        "all properties hold on {} configurations ({:.1} s)",
        configs.len(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
