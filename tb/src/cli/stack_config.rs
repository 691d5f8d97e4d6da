//! Stack-configuration arguments shared by every subcommand: a list of names in the paper's
//! style plus overrides of the RT unit's shape, validated with the RTL's own errors.

use anyhow::{Context, Result};
use rtl::config::{Config, Realloc};

#[derive(clap::Args, Clone, Debug)]
pub struct StackConfigArgs {
    /// Stack configurations, comma-separated: RB_N, RB_FULL, RB_N+SH_M, +SK, +RA (or +RA_G:
    /// lending within groups of G lanes), +RT (drop the oldest entry on overflow and restart the
    /// walk: cycle level, flat BVH, nearest order), or SMS (= RB_8+SH_8+SK+RA); `paper` = every
    /// configuration of the paper's evaluation (SPEC section 8); `restart` = the restart designs
    /// beside the spilling ones they compete with. Default: `sms run` RB_8,RB_16,SMS (the first
    /// is the speed-ups' baseline), `sms bench` RB_8,RB_8+SH_8+SK,SMS, `sms sweep` paper (restart
    /// with --designs restart), `sms cost` SMS, `sms check` the grid of --rb, --sh, --warp-sizes
    /// and --borrow-limits; RB_8 is always run by bench and sweep. `--configs` is the same flag.
    #[arg(long, short = 'c', visible_alias = "configs", value_delimiter = ',')]
    pub config: Vec<String>,
    /// Warps per RT unit.
    #[arg(long)]
    pub warps: Option<u32>,
    /// Threads per warp.
    #[arg(long)]
    pub warp_size: Option<u32>,
    /// Most stacks a thread may borrow (reallocation only).
    #[arg(long)]
    pub borrow_limit: Option<u32>,
    /// Flush counter limit per stack (reallocation only).
    #[arg(long)]
    pub flush_limit: Option<u32>,
}

impl StackConfigArgs {
    /// For commands that simulate the configurations beside ones of their own (the baseline, the
    /// RB and L1D sweeps): the shape overrides would apply to some runs and not others, so they
    /// are refused.
    pub fn names_only(&self, command: &str) -> Result<()> {
        let set = [
            ("--warps", self.warps.is_some()),
            ("--warp-size", self.warp_size.is_some()),
            ("--borrow-limit", self.borrow_limit.is_some()),
            ("--flush-limit", self.flush_limit.is_some()),
        ];
        match set.iter().find(|(_, on)| *on) {
            Some((flag, _)) => anyhow::bail!(
                "{flag}: `sms {command}` runs configurations of its own beside these, so it takes names only"
            ),
            None => Ok(()),
        }
    }

    /// The configurations asked for (`default` when none is), each validated after the
    /// overrides.
    pub fn resolve(&self, default: &[&str]) -> Result<Vec<Config>> {
        let mut out = Vec::new();
        let names: Vec<String> = if self.config.is_empty() {
            default.iter().map(|s| s.to_string()).collect()
        } else {
            self.config.clone()
        };
        for name in &names {
            let base: Vec<Config> = if name.eq_ignore_ascii_case("paper") {
                Config::paper_set()
            } else if name.eq_ignore_ascii_case("restart") {
                Config::restart_set()
            } else {
                vec![name.parse().with_context(|| format!("--config {name}"))?]
            };
            for c in base {
                let mut c = self.apply(c);
                // The names' borrow limit (4) is for 32-thread warps: a smaller warp without
                // --borrow-limit takes the most it allows.
                if let (None, Some(ra)) = (self.borrow_limit, c.policy.realloc_mut()) {
                    if c.warp_size >= 2 && ra.borrow_limit >= c.warp_size {
                        crate::cli::note(format!(
                            "--config {name}: borrow limit {} (the most a {}-thread warp allows; --borrow-limit sets it)",
                            c.warp_size - 1,
                            c.warp_size
                        ));
                        ra.borrow_limit = c.warp_size - 1;
                    }
                }
                c.validate().with_context(|| format!("--config {name}"))?;
                out.push(c);
            }
        }
        Ok(out)
    }

    /// `c` with the shape overrides applied (not validated).
    pub fn apply(&self, mut c: Config) -> Config {
        c.warps = self.warps.unwrap_or(c.warps);
        c.warp_size = self.warp_size.unwrap_or(c.warp_size);
        if let Some(ra) = c.policy.realloc_mut() {
            let Realloc { borrow_limit, flush_limit } = ra;
            *borrow_limit = self.borrow_limit.unwrap_or(*borrow_limit);
            *flush_limit = self.flush_limit.unwrap_or(*flush_limit);
        }
        c
    }
}
