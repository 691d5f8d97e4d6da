//! `sms cost`: hardware cost of stack designs, bit by bit.

use anyhow::Result;

use super::stack_config::StackConfigArgs;
use super::{Format, HardwareArgs, OutputArgs};
use crate::report::cost::{comparison, fields_of_all, CostReport};
use crate::run::provenance::{Provenance, WithProvenance};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub stack: StackConfigArgs,
    /// SMs per GPU (one RT unit each, `--sms`) come from the hardware.
    #[command(flatten)]
    pub hardware: HardwareArgs,
    /// Depth RB_FULL is sized to (the deepest stack of a scene: see `sms depth`).
    #[arg(long, default_value_t = 64)]
    pub full_depth: u32,
    #[command(flatten)]
    pub output: OutputArgs,
    /// With several configurations, add the baselines RB_8, RB_16 and RB_FULL to the comparison.
    #[arg(long)]
    pub baselines: bool,
}

/// The largest `--full-depth`: far beyond any scene's stack (the deepest measured is under 100),
/// and small enough that no width overflows.
pub const MAX_FULL_DEPTH: u32 = 65536;

pub fn run(args: Args) -> Result<()> {
    if !(1..=MAX_FULL_DEPTH).contains(&args.full_depth) {
        anyhow::bail!(
            "--full-depth {}: RB_FULL needs 1 to {MAX_FULL_DEPTH} entries (the deepest stack of a scene: `sms depth` \
             reports it)",
            args.full_depth
        );
    }
    let hw = args.hardware.hardware()?;
    let sms = hw.mem.sms;
    let provenance = Provenance::new(None, Some(args.hardware.id(&hw)));
    let mut configs = args.stack.resolve(&["SMS"])?;
    if args.baselines {
        for name in ["RB_8", "RB_16", "RB_FULL"] {
            let c = name.parse()?;
            if !configs.contains(&c) {
                configs.push(c);
            }
        }
    }
    let reports =
        configs.iter().map(|c| CostReport::new(c, sms, args.full_depth)).collect::<Result<Vec<_>, _>>()?;
    match args.output.format() {
        Format::Json => {
            // Each report carries the provenance, so the array's layout stays as it was.
            let json: Vec<_> = reports
                .iter()
                .map(|r| WithProvenance { report: r.to_json(), provenance: &provenance })
                .collect();
            println!("{}", serde_json::to_string_pretty(&json)?);
        }
        Format::Csv => print!("{}{}", provenance.csv(), fields_of_all(&reports).to_csv()),
        f @ (Format::Text | Format::Markdown) => {
            let md = f == Format::Markdown;
            print!("{}", if md { provenance.markdown() } else { provenance.text() + "\n" });
            for r in &reports {
                println!("{}", r.render(md));
            }
            if reports.len() > 1 {
                let t = comparison(&reports);
                println!("{}", if md { t.to_markdown() } else { t.to_text() });
            }
        }
    }
    Ok(())
}
