//! `sms cost`: hardware cost of stack designs, bit by bit.

use anyhow::{bail, Result};

use super::stack_config::StackConfigArgs;
use crate::report::cost::{comparison, CostReport};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub stack: StackConfigArgs,
    /// SMs per GPU (one RT unit each).
    #[arg(long, default_value_t = 8)]
    pub sms: u32,
    /// Depth RB_FULL is sized to (the deepest stack of a scene: see `sms depth`).
    #[arg(long, default_value_t = 64)]
    pub full_depth: u32,
    /// Output: text, markdown or json.
    #[arg(long, default_value = "text")]
    pub format: String,
    /// With several configurations, add the baselines RB_8, RB_16 and RB_FULL to the comparison.
    #[arg(long)]
    pub baselines: bool,
}

pub fn run(args: Args) -> Result<()> {
    if args.sms == 0 {
        bail!("--sms must be at least 1");
    }
    let mut configs = args.stack.resolve(&["SMS"])?;
    if args.baselines {
        for name in ["RB_8", "RB_16", "RB_FULL"] {
            let c = name.parse()?;
            if !configs.contains(&c) {
                configs.push(c);
            }
        }
    }
    let reports = configs
        .iter()
        .map(|c| CostReport::new(c, args.sms, args.full_depth))
        .collect::<Result<Vec<_>, _>>()?;
    match args.format.as_str() {
        "json" => println!("{}", serde_json::to_string_pretty(&reports)?),
        f @ ("text" | "markdown") => {
            let md = f == "markdown";
            for r in &reports {
                println!("{}", r.render(md));
            }
            if reports.len() > 1 {
                let t = comparison(&reports);
                println!("{}", if md { t.to_markdown() } else { t.to_text() });
            }
        }
        other => bail!("--format {other}: expected text, markdown or json"),
    }
    Ok(())
}
