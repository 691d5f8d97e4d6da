//! The `sms` subcommands, one module each: a clap `Args` struct and `run(args)`. The binary only
//! dispatches, so new subcommands are added here without touching the others.

pub mod ablate;
pub mod bench;
pub mod check;
pub mod cost;
pub mod depth;
pub mod run;
pub mod scenes;
pub mod stack_config;
pub mod sweep;

use std::path::PathBuf;

use crate::scene::SceneLibrary;

/// Where scene descriptions and data are, shared by subcommands that load scenes.
#[derive(Clone, Debug, clap::Args)]
pub struct SceneArgs {
    /// Folder of the shared mesh files (default: ../shared/scenes beside the project).
    #[arg(long)]
    pub scenes_dir: Option<PathBuf>,
}

impl SceneArgs {
    pub fn library(&self) -> SceneLibrary {
        match &self.scenes_dir {
            Some(dir) => SceneLibrary::with_data_dir(dir),
            None => SceneLibrary::default(),
        }
    }
}

/// What to trace: scene, hierarchy, child order, resolution, samples, bounces, path end, seed.
/// Shared by the subcommands that simulate a workload.
#[derive(Clone, Debug, clap::Args)]
pub struct WorkloadArgs {
    /// Hierarchy: bvh6 (Vulkan-Sim's 6-wide layout, 64-byte nodes), bvh2 or cwbvh (obvhs).
    #[arg(long, value_enum, default_value = "bvh6")]
    pub bvh: crate::workload::BvhKind,
    /// Child order: nearest hit child first, others pushed far to near; or vulkansim (index
    /// order).
    #[arg(long, value_enum, default_value = "nearest")]
    pub order: crate::workload::ChildOrder,
    /// Resolution as WIDTHxHEIGHT (default: the scene's; LumiBench's 128x128 unless its
    /// description says otherwise).
    #[arg(long, value_parser = parse_res)]
    pub res: Option<(u32, u32)>,
    /// Samples per pixel (default: the scene's; LumiBench's 2).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Diffuse bounces after the primary ray (default: the scene's; LumiBench's 16 rays per
    /// path, i.e. 15).
    #[arg(long)]
    pub bounces: Option<u32>,
    /// When a hit ends a path besides a miss and the bounce limit: lumibench (a hit on a
    /// surface's back does not scatter, as LumiBench's Lambertian material) or always (every
    /// hit scatters: the model before issue 12). No Russian roulette either way.
    #[arg(long, value_enum, default_value = "lumibench")]
    pub path_end: crate::workload::PathEnd,
    /// Seed of the ray generator: the same seed gives bit-identical results.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

impl WorkloadArgs {
    /// The overrides of every scene's own render settings.
    pub fn settings(&self) -> crate::sweep::Settings {
        crate::sweep::Settings {
            res: self.res,
            spp: self.spp,
            bounces: self.bounces,
            bvh: self.bvh,
            order: self.order,
            path_end: self.path_end,
            seed: self.seed,
        }
    }

    /// `scene`'s own render settings with these arguments applied.
    pub fn opts(&self, scene: &crate::scene::Scene) -> crate::workload::WorkloadOpts {
        self.settings().opts(scene)
    }
}

/// Sampling of pixel warps, shared by `sms run`, `sms sweep` and `sms ablate`.
#[derive(Clone, Debug, clap::Args)]
pub struct SampleArgs {
    /// Simulate this fraction (0 < f ≤ 1) of the pixel warps and estimate every metric of the
    /// whole frame with a 95 % confidence interval. At the cycle level the sample is one launch
    /// and the intervals of cycles, DRAM and conflicts are indicative only: `sms bench` measures
    /// the real error, and a sampled sweep prints the error measured at LumiBench's settings
    /// (speed-ups off by up to 2 % at 0.25) [default: every warp].
    #[arg(long, value_name = "FRACTION")]
    pub sample: Option<f64>,
    /// How sampled warps are drawn.
    #[arg(long, value_enum, default_value = "tile")]
    pub sample_mode: crate::sampling::SampleMode,
    /// Independent batches of a sampled run (at least 2).
    #[arg(long, default_value_t = 8)]
    pub batches: u32,
}

impl SampleArgs {
    /// The sample asked for (`None`: every warp), checked; drawn with `seed`.
    pub fn plan(&self, seed: u64) -> anyhow::Result<Option<crate::sampling::SamplePlan>> {
        let Some(fraction) = self.sample else { return Ok(None) };
        let plan =
            crate::sampling::SamplePlan { fraction, mode: self.sample_mode, batches: self.batches, seed };
        plan.validate().map_err(|e| anyhow::anyhow!("--sample: {e}"))?;
        Ok(Some(plan))
    }
}

pub fn parse_res(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WIDTHxHEIGHT, e.g. 128x128")?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|e| format!("'{v}': {e}"));
    Ok((parse(w)?, parse(h)?))
}

/// The hardware around the stack: SPEC section 7 defaults, then a TOML file, then flags.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct HardwareArgs {
    /// TOML file overriding RT-unit and memory parameters: `[rt]` keys bvh_header, internal,
    /// instance_leaf, leaf_descriptor, triangle, procedural, idle_skip; `[mem]` keys sms,
    /// sector_bytes, line_bytes, l1d_bytes, l1d_ways (0 = fully associative), l1d_hit_latency,
    /// l1d_mshrs, l1d_mshr_merge, l1d_miss_queue, l2_bytes, l2_ways, l2_latency, l2_banks,
    /// l2_bank_queue, l2_mshrs, l2_mshr_merge, l2_dram_queue, dram_latency,
    /// dram_bytes_per_cycle, dram_queue.
    #[arg(long, value_name = "FILE")]
    pub hw: Option<PathBuf>,
    /// Unified L1D/shared-memory size per SM in KB (default 64); the SH stacks are carved out.
    #[arg(long)]
    pub l1d_kb: Option<u32>,
    /// SMs, one RT unit each (default 8).
    #[arg(long)]
    pub sms: Option<u32>,
    /// DRAM latency in cycles beyond the L2's (default 100).
    #[arg(long)]
    pub dram_latency: Option<u32>,
}

impl HardwareArgs {
    pub fn hardware(&self) -> anyhow::Result<crate::sim::Hardware> {
        let mut hw = crate::sim::Hardware::default();
        if let Some(path) = &self.hw {
            let text = std::fs::read_to_string(path)
                .map_err(|e| anyhow::anyhow!("cannot read hardware file {}: {e}", path.display()))?;
            apply_hardware_toml(&mut hw, &text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        }
        if let Some(kb) = self.l1d_kb {
            hw.mem.l1d_bytes =
                kb.checked_mul(1024).ok_or_else(|| anyhow::anyhow!("--l1d-kb {kb}: too large"))?;
        }
        hw.mem.sms = self.sms.unwrap_or(hw.mem.sms);
        hw.mem.dram_latency = self.dram_latency.unwrap_or(hw.mem.dram_latency);
        // The memory system checks every value; report its reason before any work starts.
        rtl::mem::hierarchy::MemSystem::new(hw.mem).map_err(|e| anyhow::anyhow!("hardware: {e}"))?;
        Ok(hw)
    }
}

/// Applies `[rt]` and `[mem]` tables of `text` to `hw`; unknown keys and wrong types are errors.
pub fn apply_hardware_toml(hw: &mut crate::sim::Hardware, text: &str) -> Result<(), String> {
    use rtl::mem::Assoc;
    let doc: toml::Table = text.parse().map_err(|e| format!("not valid TOML: {e}"))?;
    for (section, value) in &doc {
        let table = value.as_table().ok_or_else(|| format!("'{section}' must be a table ([{section}])"))?;
        for (key, v) in table {
            let name = format!("{section}.{key}");
            let uint = || -> Result<u32, String> {
                v.as_integer()
                    .and_then(|i| u32::try_from(i).ok())
                    .ok_or_else(|| format!("{name} = {v}: expected a whole number ≥ 0"))
            };
            let ways = |w: u32| if w == 0 { Assoc::Full } else { Assoc::Ways(w) };
            let (rt, m) = (&mut hw.rt, &mut hw.mem);
            match (section.as_str(), key.as_str()) {
                ("rt", "bvh_header") => rt.bvh_header = uint()?,
                ("rt", "internal") => rt.internal = uint()?,
                ("rt", "instance_leaf") => rt.instance_leaf = uint()?,
                ("rt", "leaf_descriptor") => rt.leaf_descriptor = uint()?,
                ("rt", "triangle") => rt.triangle = uint()?,
                ("rt", "procedural") => rt.procedural = uint()?,
                ("rt", "idle_skip") => {
                    rt.idle_skip =
                        v.as_bool().ok_or_else(|| format!("{name} = {v}: expected true or false"))?
                }
                ("mem", "sms") => m.sms = uint()?,
                ("mem", "sector_bytes") => m.sector_bytes = uint()?,
                ("mem", "line_bytes") => m.line_bytes = uint()?,
                ("mem", "l1d_bytes") => m.l1d_bytes = uint()?,
                ("mem", "l1d_ways") => m.l1d_assoc = ways(uint()?),
                ("mem", "l1d_hit_latency") => m.l1d_hit_latency = uint()?,
                ("mem", "l1d_mshrs") => m.l1d_mshrs = uint()?,
                ("mem", "l1d_mshr_merge") => m.l1d_mshr_merge = uint()?,
                ("mem", "l1d_miss_queue") => m.l1d_miss_queue = uint()?,
                ("mem", "l2_bytes") => m.l2_bytes = uint()?,
                ("mem", "l2_ways") => m.l2_assoc = ways(uint()?),
                ("mem", "l2_latency") => m.l2_latency = uint()?,
                ("mem", "l2_banks") => m.l2_banks = uint()?,
                ("mem", "l2_bank_queue") => m.l2_bank_queue = uint()?,
                ("mem", "l2_mshrs") => m.l2_mshrs = uint()?,
                ("mem", "l2_mshr_merge") => m.l2_mshr_merge = uint()?,
                ("mem", "l2_dram_queue") => m.l2_dram_queue = uint()?,
                ("mem", "dram_latency") => m.dram_latency = uint()?,
                ("mem", "dram_bytes_per_cycle") => m.dram_bytes_per_cycle = uint()?,
                ("mem", "dram_queue") => m.dram_queue = uint()?,
                _ => return Err(format!("unknown parameter {name}")),
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hardware_toml_overrides_defaults_and_rejects_bad_input() {
        let mut hw = crate::sim::Hardware::default();
        apply_hardware_toml(
            &mut hw,
            "[rt]\ntriangle = 12\nidle_skip = false\n[mem]\nl1d_ways = 4\nl2_latency = 200\n",
        )
        .unwrap();
        assert_eq!((hw.rt.triangle, hw.rt.idle_skip, hw.mem.l2_latency), (12, false, 200));
        assert_eq!(hw.mem.l1d_assoc, rtl::mem::Assoc::Ways(4));
        assert_eq!(hw.rt.internal, 8, "keys not named keep their SPEC default");

        let err = |text: &str| apply_hardware_toml(&mut crate::sim::Hardware::default(), text).unwrap_err();
        assert_eq!(err("[mem]\nl2_waysx = 3"), "unknown parameter mem.l2_waysx");
        assert!(err("[rt]\ntriangle = -1").contains("rt.triangle = -1: expected a whole number"));
        assert!(err("[rt]\nidle_skip = 3").contains("expected true or false"));
        assert!(err("mem = 3").contains("must be a table"));
        assert!(err("[mem\n").contains("not valid TOML"));
    }

    #[test]
    fn hardware_flags_are_checked_by_the_memory_system() {
        let args = HardwareArgs { l1d_kb: Some(64), sms: Some(2), ..HardwareArgs::default() };
        let hw = args.hardware().unwrap();
        assert_eq!((hw.mem.l1d_bytes, hw.mem.sms), (64 * 1024, 2));
        let zero = HardwareArgs { sms: Some(0), ..HardwareArgs::default() };
        assert!(zero.hardware().unwrap_err().to_string().starts_with("hardware: "));
        let missing = HardwareArgs { hw: Some("/nonexistent/hw.toml".into()), ..HardwareArgs::default() };
        assert!(missing.hardware().unwrap_err().to_string().contains("cannot read hardware file"));
    }
}
