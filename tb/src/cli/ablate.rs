//! `sms ablate`: the headline speed-ups over RB_8 (RB_16, RB_FULL, RB_8+SH_8, +SK, SMS, RB_2)
//! with each simulator mechanism turned off in turn, per scene and as the geometric mean. See
//! [`crate::run::ablate`].
//!
//! A subcommand rather than `sms sweep --ablate`: its plan is fixed (the headline set on the
//! base L1D, no RB or L1D sweeps), it runs one arm per mechanism and writes one table of
//! deltas, so none of the sweep's plan flags or figures would apply.

use std::path::PathBuf;

use crate::cli::sweep::{finish, print_figure, start, SweepArgs};
use crate::run::ablate;

#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    /// Scenes, workload, hardware and sampling of the reference, as `sms sweep` takes them (by
    /// default the paper's platform: the `paper` hardware, two-level structures, Vulkan-Sim's
    /// child order, LumiBench's workloads).
    #[command(flatten)]
    pub common: SweepArgs,
    /// Report folder.
    #[arg(long, default_value = "out/ablate")]
    pub out: PathBuf,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let mut req = args.common.request(ablate::plan()?)?;
    req.cache = args.common.cache_dir(&args.out);
    req.prune_cache = args.common.prune_cache;
    crate::cli::sweep::prepare(&args.common, &req, &args.out)?;
    let per_scene = req.plan.variants(req.base_kb())?.len();
    let mechanisms = ablate::MECHANISMS;
    let progress = start("ablate", &req, per_scene, mechanisms.len() + 1, &args.out);
    let result = ablate::run(&req, mechanisms, &args.common.library.library()?, &progress)?;
    if crate::cli::sweep::shard_done(&req, &result.reference).is_some() {
        return Ok(());
    }
    let written = crate::report::sweep::write_ablation(&result, &args.out)?;
    print_figure(&args.common.output, &result.figure(), &result.reference.provenance())?;
    finish(&format!("{} arms", mechanisms.len() + 1), &result.reference, written.len(), &args.out);
    Ok(())
}
