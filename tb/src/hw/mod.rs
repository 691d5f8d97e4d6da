//! The hardware around the stack, and its description format: the TOML of `--hw` and of the
//! shipped presets ([`presets`]).
//!
//! A description has three tables: `[rt]` (operation latencies), `[stack]` (how stack traffic is
//! timed) and `[mem]` (the memory system). Keys a file does not name keep their value from the
//! hardware it is applied to; an unknown key, a wrong type or a value outside its set is an error
//! naming the key. The default hardware is the `paper` preset.

use rtl::mem::{Assoc, L1dWrite, LocalLayout, MemParams, SetIndex};
use rtl::rt_unit::{PortPriority, RtParams, StackTiming, StoreGating, WarpSelect};

pub mod presets;

/// Hardware parameters around the stack: operation latencies, stack timing and the memory system.
/// `mem.l1d_bytes` is the L1D, or with `shared_carveout` the whole unified L1D/shared array from
/// which each configuration's SH stacks are carved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hardware {
    pub rt: RtParams,
    pub mem: MemParams,
    /// The SH stacks' shared memory comes out of the L1D array (the paper, SPEC section 8);
    /// `false`: shared memory sits beside the L1D (Vulkan-Sim's configs, adaptive cache off).
    pub shared_carveout: bool,
}

impl Default for Hardware {
    /// The `paper` preset.
    fn default() -> Self {
        preset(presets::DEFAULT).expect("the shipped default preset is valid")
    }
}

impl Hardware {
    /// The memory system a configuration runs on: the SH stacks carved out of the L1D array when
    /// shared memory is unified with it.
    pub fn mem_for(&self, cfg: &rtl::config::Config) -> MemParams {
        if self.shared_carveout {
            rtl::gpu::carve_out(cfg, self.mem)
        } else {
            self.mem
        }
    }

    /// Every value checked: the error names the first bad parameter.
    pub fn validate(&self) -> Result<(), String> {
        self.rt.validate().map_err(|e| e.to_string())?;
        self.mem.validate().map_err(|e| e.to_string())
    }
}

/// The model's built-in parameters before any description is applied (rtl's defaults).
fn base() -> Hardware {
    Hardware { rt: RtParams::default(), mem: MemParams::default(), shared_carveout: true }
}

/// The shipped preset `name`, checked.
pub fn preset(name: &str) -> Result<Hardware, String> {
    let p =
        presets::find(name).ok_or_else(|| format!("no hardware preset '{name}' ({})", presets::names()))?;
    let mut hw = base();
    apply_toml(&mut hw, p.toml).map_err(|e| format!("preset {}: {e}", p.name))?;
    hw.validate().map_err(|e| format!("preset {}: {e}", p.name))?;
    Ok(hw)
}

/// The hardware `spec` names: a preset name, or a TOML file applied to the default (`paper`).
pub fn resolve(spec: &str) -> Result<Hardware, String> {
    if presets::find(spec).is_some() {
        return preset(spec);
    }
    let (origin, text) = presets::text_of(spec)?;
    let mut hw = Hardware::default();
    apply_toml(&mut hw, &text).map_err(|e| format!("{origin}: {e}"))?;
    Ok(hw)
}

/// One of `names`, given as a TOML string.
fn choice<T>(
    name: &str,
    v: &toml::Value,
    names: &[&str],
    from: impl Fn(&str) -> Option<T>,
) -> Result<T, String> {
    v.as_str().and_then(from).ok_or_else(|| {
        let allowed: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
        format!("{name} = {v}: expected one of {}", allowed.join(", "))
    })
}

/// Applies the `[rt]`, `[stack]` and `[mem]` tables of `text` to `hw`.
pub fn apply_toml(hw: &mut Hardware, text: &str) -> Result<(), String> {
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
            let boolean = || v.as_bool().ok_or_else(|| format!("{name} = {v}: expected true or false"));
            let ways = |w: u32| if w == 0 { Assoc::Full } else { Assoc::Ways(w) };
            let (rt, m) = (&mut hw.rt, &mut hw.mem);
            match (section.as_str(), key.as_str()) {
                ("rt", "bvh_header") => rt.bvh_header = uint()?,
                ("rt", "internal") => rt.internal = uint()?,
                ("rt", "instance_leaf") => rt.instance_leaf = uint()?,
                ("rt", "leaf_descriptor") => rt.leaf_descriptor = uint()?,
                ("rt", "triangle") => rt.triangle = uint()?,
                ("rt", "procedural") => rt.procedural = uint()?,
                ("rt", "idle_skip") => rt.idle_skip = boolean()?,
                ("rt", "warp_select") => {
                    rt.warp_select = choice(&name, v, WarpSelect::NAMES, WarpSelect::from_name)?
                }
                ("stack", "timing") => {
                    rt.stack_timing = choice(&name, v, StackTiming::NAMES, StackTiming::from_name)?
                }
                ("stack", "sh_latency") => rt.sh_latency = uint()?,
                ("stack", "store_gating") => {
                    rt.store_gating = choice(&name, v, StoreGating::NAMES, StoreGating::from_name)?
                }
                ("stack", "store_queue") => rt.store_queue = uint()?,
                ("stack", "port_priority") => {
                    rt.port_priority = choice(&name, v, PortPriority::NAMES, PortPriority::from_name)?
                }
                ("mem", "sms") => m.sms = uint()?,
                ("mem", "sector_bytes") => m.sector_bytes = uint()?,
                ("mem", "line_bytes") => m.line_bytes = uint()?,
                ("mem", "l1d_bytes") => m.l1d_bytes = uint()?,
                ("mem", "shared_carveout") => hw.shared_carveout = boolean()?,
                ("mem", "l1d_ways") => m.l1d_assoc = ways(uint()?),
                ("mem", "l1d_hit_latency") => m.l1d_hit_latency = uint()?,
                ("mem", "l1d_mshrs") => m.l1d_mshrs = uint()?,
                ("mem", "l1d_mshr_merge") => m.l1d_mshr_merge = uint()?,
                ("mem", "l1d_miss_queue") => m.l1d_miss_queue = uint()?,
                ("mem", "l1d_write") => m.l1d_write = choice(&name, v, L1dWrite::NAMES, L1dWrite::from_name)?,
                ("mem", "l2_bytes") => m.l2_bytes = uint()?,
                ("mem", "l2_ways") => m.l2_assoc = ways(uint()?),
                ("mem", "l2_latency") => m.l2_latency = uint()?,
                ("mem", "l2_banks") => m.l2_banks = uint()?,
                ("mem", "l2_interleave_bytes") => m.l2_interleave_bytes = uint()?,
                ("mem", "l2_set_index") => {
                    m.l2_set_index = choice(&name, v, SetIndex::NAMES, SetIndex::from_name)?
                }
                ("mem", "l2_bank_queue") => m.l2_bank_queue = uint()?,
                ("mem", "l2_mshrs") => m.l2_mshrs = uint()?,
                ("mem", "l2_mshr_merge") => m.l2_mshr_merge = uint()?,
                ("mem", "l2_dram_queue") => m.l2_dram_queue = uint()?,
                ("mem", "dram_latency") => m.dram_latency = uint()?,
                ("mem", "dram_bytes_per_cycle") => m.dram_bytes_per_cycle = uint()?,
                ("mem", "dram_queue") => m.dram_queue = uint()?,
                ("mem", "local_layout") => {
                    m.local_layout = choice(&name, v, LocalLayout::NAMES, LocalLayout::from_name)?
                }
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
    fn every_preset_is_valid_and_sets_every_parameter() {
        // Applied to two bases that differ in every value a file can set, a complete file gives
        // the same hardware: a key it forgot would keep the base's value. The second base names
        // every field, so a new parameter must be added here (and to every preset) to compile.
        let a = base();
        let (r, m) = (a.rt, a.mem);
        let b = Hardware {
            rt: RtParams {
                bvh_header: r.bvh_header + 1,
                internal: r.internal + 1,
                instance_leaf: r.instance_leaf + 1,
                leaf_descriptor: r.leaf_descriptor + 1,
                triangle: r.triangle + 1,
                procedural: r.procedural + 1,
                idle_skip: r.idle_skip, // a run option, not hardware: no preset sets it
                stack_timing: StackTiming::Overlapped,
                sh_latency: r.sh_latency + 1,
                store_gating: StoreGating::ShPosted,
                store_queue: r.store_queue + 1,
                port_priority: PortPriority::Node,
                warp_select: WarpSelect::Oldest,
            },
            mem: MemParams {
                sms: m.sms + 1,
                sector_bytes: m.sector_bytes * 2,
                line_bytes: m.line_bytes * 2,
                l1d_bytes: m.l1d_bytes + 1,
                l1d_assoc: Assoc::Ways(3),
                l1d_hit_latency: m.l1d_hit_latency + 1,
                l1d_mshrs: m.l1d_mshrs + 1,
                l1d_mshr_merge: m.l1d_mshr_merge + 1,
                l1d_miss_queue: m.l1d_miss_queue + 1,
                l1d_write: L1dWrite::WriteThrough,
                l2_bytes: m.l2_bytes + 1,
                l2_assoc: Assoc::Ways(5),
                l2_latency: m.l2_latency + 1,
                l2_banks: m.l2_banks + 1,
                l2_interleave_bytes: m.l2_interleave_bytes * 2,
                l2_set_index: SetIndex::Linear,
                l2_bank_queue: m.l2_bank_queue + 1,
                l2_mshrs: m.l2_mshrs + 1,
                l2_mshr_merge: m.l2_mshr_merge + 1,
                l2_dram_queue: m.l2_dram_queue + 1,
                dram_latency: m.dram_latency + 1,
                dram_bytes_per_cycle: m.dram_bytes_per_cycle + 1,
                dram_queue: m.dram_queue + 1,
                local_layout: LocalLayout::Linear,
            },
            shared_carveout: !a.shared_carveout,
        };
        assert_eq!(
            (a.rt.stack_timing, a.mem.l1d_write, a.mem.l2_set_index, a.mem.local_layout),
            (StackTiming::Blocking, L1dWrite::WriteEvict, SetIndex::Ipoly, LocalLayout::Interleaved),
            "the two bases differ in the enums too"
        );
        assert_eq!(
            (a.rt.store_gating, a.rt.port_priority, a.rt.warp_select),
            (StoreGating::Acked, PortPriority::Stack, WarpSelect::Gto),
            "and in the open choices"
        );
        for p in presets::PRESETS {
            let (mut on_a, mut on_b) = (a, b);
            apply_toml(&mut on_a, p.toml).unwrap();
            apply_toml(&mut on_b, p.toml).unwrap();
            assert_eq!(on_a, on_b, "{} leaves a parameter unset", p.name);
            assert_eq!(on_a, preset(p.name).unwrap());
        }
        // A file that forgets one key is caught.
        let forgetful = presets::find("paper").unwrap().toml.replace("\ndram_queue", "\n# dram_queue");
        let (mut on_a, mut on_b) = (a, b);
        apply_toml(&mut on_a, &forgetful).unwrap();
        apply_toml(&mut on_b, &forgetful).unwrap();
        assert_ne!(on_a, on_b);
    }

    #[test]
    fn the_default_is_the_paper_preset_and_its_text_values() {
        let hw = Hardware::default();
        assert_eq!(hw, preset("paper").unwrap());
        // SPEC section 7 / the paper's text.
        assert_eq!((hw.mem.sms, hw.mem.l1d_bytes, hw.mem.l2_bytes), (8, 64 << 10, 3 << 20));
        assert_eq!((hw.mem.l2_latency, hw.mem.dram_latency), (160, 100));
        assert_eq!(hw.rt.stack_timing, StackTiming::Blocking);
        // The open choices as docs/assumptions.md settles them: the paper's text where it speaks
        // (GTO), Vulkan-Sim's source where only it does (an unbounded store queue), and the
        // model's reading of the paper's sequence otherwise.
        assert_eq!(
            (hw.rt.store_gating, hw.rt.store_queue, hw.rt.port_priority, hw.rt.warp_select),
            (StoreGating::Acked, 0, PortPriority::Stack, WarpSelect::Gto)
        );
        let mobile = preset("vulkansim-mobile").unwrap();
        assert_eq!(
            (mobile.mem.l1d_bytes, mobile.mem.l2_bytes, mobile.shared_carveout),
            (32 << 10, 512 << 10, false)
        );
        assert_eq!(preset("rtx2060").unwrap().mem.sms, 30);
    }

    #[test]
    fn legacy_preset_is_the_old_model() {
        let hw = preset("legacy").unwrap();
        assert_eq!(hw.rt, RtParams::default().overlapped());
        assert_eq!(
            (
                hw.mem.l1d_write,
                hw.mem.l2_set_index,
                hw.mem.local_layout,
                hw.mem.l1d_hit_latency,
                hw.mem.l1d_mshrs
            ),
            (L1dWrite::WriteThrough, SetIndex::Linear, LocalLayout::Linear, 20, 32)
        );
    }

    #[test]
    fn descriptions_override_and_reject_bad_input() {
        let mut hw = Hardware::default();
        apply_toml(
            &mut hw,
            "[rt]\ntriangle = 12\nidle_skip = false\n[mem]\nl1d_ways = 4\nl2_latency = 200\n",
        )
        .unwrap();
        assert_eq!((hw.rt.triangle, hw.rt.idle_skip, hw.mem.l2_latency), (12, false, 200));
        assert_eq!(hw.mem.l1d_assoc, Assoc::Ways(4));
        assert_eq!(hw.rt.internal, 8, "keys not named keep their value");
        apply_toml(
            &mut hw,
            "[stack]\ntiming = \"overlapped\"\nsh_latency = 2\n[mem]\nl1d_write = \"through\"\nl2_set_index = \"linear\"\nlocal_layout = \"linear\"\nshared_carveout = false\n",
        )
        .unwrap();
        assert_eq!(
            (hw.rt.stack_timing, hw.rt.sh_latency, hw.shared_carveout),
            (StackTiming::Overlapped, 2, false)
        );
        assert_eq!(
            (hw.mem.l1d_write, hw.mem.l2_set_index, hw.mem.local_layout),
            (L1dWrite::WriteThrough, SetIndex::Linear, LocalLayout::Linear)
        );

        let err = |text: &str| apply_toml(&mut Hardware::default(), text).unwrap_err();
        assert_eq!(err("[mem]\nl2_waysx = 3"), "unknown parameter mem.l2_waysx");
        assert!(err("[rt]\ntriangle = -1").contains("rt.triangle = -1: expected a whole number"));
        assert!(err("[rt]\nidle_skip = 3").contains("expected true or false"));
        assert_eq!(
            err("[stack]\ntiming = \"posted\""),
            "stack.timing = \"posted\": expected one of \"blocking\", \"overlapped\""
        );
        assert_eq!(
            err("[mem]\nl1d_write = \"back\""),
            "mem.l1d_write = \"back\": expected one of \"evict\", \"through\""
        );
        assert!(err("[mem]\nl2_set_index = 1")
            .contains("mem.l2_set_index = 1: expected one of \"ipoly\", \"linear\""));
        assert!(err("[mem]\nlocal_layout = \"x\"").contains("expected one of \"interleaved\", \"linear\""));
        assert_eq!(
            err("[stack]\nstore_gating = \"none\""),
            "stack.store_gating = \"none\": expected one of \"acked\", \"posted\", \"sh-posted\""
        );
        assert!(err("[stack]\nport_priority = 1").contains("expected one of \"stack\", \"node\""));
        assert!(err("[rt]\nwarp_select = \"lrr\"").contains("expected one of \"gto\", \"oldest\""));
        assert!(err("[stack]\nstore_queue = -1").contains("stack.store_queue = -1: expected a whole number"));
        let mut hw = Hardware::default();
        apply_toml(&mut hw, "[stack]\nstore_queue = 70000\n").unwrap();
        assert!(hw.validate().unwrap_err().contains("store_queue"), "beyond the queue's width");
        apply_toml(
            &mut hw,
            "[stack]\nstore_gating = \"sh-posted\"\nstore_queue = 16\nport_priority = \"node\"\n[rt]\nwarp_select = \"oldest\"\n",
        )
        .unwrap();
        assert_eq!(
            (hw.rt.store_gating, hw.rt.store_queue, hw.rt.port_priority, hw.rt.warp_select),
            (StoreGating::ShPosted, 16, PortPriority::Node, WarpSelect::Oldest)
        );
        assert!(err("[mem]\nshared_carveout = 1").contains("expected true or false"));
        assert!(err("mem = 3").contains("must be a table"));
        assert!(err("[mem\n").contains("not valid TOML"));
    }

    #[test]
    fn names_and_paths_resolve_and_bad_ones_say_what_exists() {
        assert_eq!(resolve("VulkanSim-Mobile").unwrap(), preset("vulkansim-mobile").unwrap());
        let e = resolve("/nonexistent/hw.toml").unwrap_err();
        assert!(e.contains("not a preset (paper, vulkansim-mobile, rtx2060, legacy)"), "{e}");
        let dir = std::env::temp_dir().join(format!("sms-hw-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let f = dir.join("slow-dram.toml");
        std::fs::write(&f, "[mem]\ndram_latency = 300\n").unwrap();
        let hw = resolve(f.to_str().unwrap()).unwrap();
        assert_eq!(
            hw,
            Hardware {
                mem: MemParams { dram_latency: 300, ..Hardware::default().mem },
                ..Hardware::default()
            }
        );
        std::fs::write(&f, "[mem]\ndram_latency = true\n").unwrap();
        assert!(resolve(f.to_str().unwrap())
            .unwrap_err()
            .contains("slow-dram.toml: mem.dram_latency = true"));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
