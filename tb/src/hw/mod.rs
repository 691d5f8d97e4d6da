//! The hardware around the stack, and its description format: the TOML of `--hw` and of the
//! shipped presets ([`presets`]).
//!
//! A description has three tables: `[rt]` (operation latencies), `[stack]` (how stack traffic is
//! timed) and `[mem]` (the memory system). Keys a file does not name keep their value from the
//! hardware it is applied to; an unknown key, a wrong type or a value outside its set is an error
//! naming the key. The default hardware is the `paper` preset.

use rtl::mem::MemParams;
use rtl::params::{Bound, Key, Kind, Value};
use rtl::rt_unit::{RtParams, StackParams};

pub mod presets;

/// What a description sets: the hardware around the stack (operation latencies, stack timing and
/// the memory system) and the one run option a description may carry. `mem.l1d_bytes` is the
/// L1D, or with `shared_carveout` the whole unified L1D/shared array from which each
/// configuration's SH stacks are carved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hardware {
    /// `[rt]`: the RT unit's operation latencies and warp scheduler.
    pub rt: RtParams,
    /// `[stack]`: the stack unit's timing.
    pub stack: StackParams,
    /// `[mem]`: the memory system.
    pub mem: MemParams,
    /// The key `mem.shared_carveout` ([`HARDWARE_KEYS`]).
    pub shared_carveout: bool,
    /// The run option `rt.idle_skip` ([`HARDWARE_KEYS`]): the runner jumps over cycles in which
    /// every thread waits on memory (the same report, in less wall time). Not hardware: the GPU
    /// never sees it, the runner does (`Runner::with_idle_skip`).
    pub idle_skip: bool,
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
        self.stack.validate().map_err(|e| e.to_string())?;
        self.mem.validate().map_err(|e| e.to_string())
    }
}

/// The model's built-in parameters before any description is applied (rtl's defaults).
fn base() -> Hardware {
    Hardware {
        rt: RtParams::default(),
        stack: StackParams::default(),
        mem: MemParams::default(),
        shared_carveout: true,
        idle_skip: true,
    }
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

/// The keys of the description that are not [`RtParams`]', [`StackParams`]' or [`MemParams`]'.
pub const HARDWARE_KEYS: &[Key<Hardware>] = &[
    rtl::param_key!(
        Hardware,
        "mem",
        "shared_carveout",
        shared_carveout: bool,
        "SH stacks carved out of the L1D array (the paper, SPEC section 8); false: shared memory beside the L1D \
         (Vulkan-Sim's configs, adaptive cache off).",
        Bound::ANY,
        false
    ),
    rtl::param_key!(
        Hardware,
        "rt",
        "idle_skip",
        idle_skip: bool,
        "Jump over cycles in which every thread waits on memory (identical results, faster).",
        Bound::ANY,
        true
    ),
];

/// One key of a description, whichever struct it sets.
#[derive(Clone, Copy)]
pub enum AnyKey {
    Rt(&'static Key<RtParams>),
    Stack(&'static Key<StackParams>),
    Mem(&'static Key<MemParams>),
    Hardware(&'static Key<Hardware>),
}

/// `$e` on the key inside `$k`, whichever struct it sets (`$key` names it).
macro_rules! on_key {
    ($k:expr, $key:ident => $e:expr) => {
        match $k {
            AnyKey::Rt($key) => $e,
            AnyKey::Stack($key) => $e,
            AnyKey::Mem($key) => $e,
            AnyKey::Hardware($key) => $e,
        }
    };
}

impl AnyKey {
    pub fn section(&self) -> &'static str {
        on_key!(self, k => k.section)
    }
    pub fn key(&self) -> &'static str {
        on_key!(self, k => k.key)
    }
    pub fn kind(&self) -> Kind {
        on_key!(self, k => k.kind)
    }
    pub fn summary(&self) -> &'static str {
        on_key!(self, k => k.summary())
    }
    pub fn bound(&self) -> Bound {
        on_key!(self, k => k.bound)
    }
    /// A run option rather than hardware: presets need not set it.
    pub fn run_option(&self) -> bool {
        on_key!(self, k => k.run_option)
    }
    pub fn get(&self, hw: &Hardware) -> Value {
        match self {
            AnyKey::Rt(k) => (k.get)(&hw.rt),
            AnyKey::Stack(k) => (k.get)(&hw.stack),
            AnyKey::Mem(k) => (k.get)(&hw.mem),
            AnyKey::Hardware(k) => (k.get)(hw),
        }
    }
    /// Sets the key; `false` when `v` is not of its kind.
    pub fn set(&self, hw: &mut Hardware, v: Value) -> bool {
        match self {
            AnyKey::Rt(k) => (k.set)(&mut hw.rt, v),
            AnyKey::Stack(k) => (k.set)(&mut hw.stack, v),
            AnyKey::Mem(k) => (k.set)(&mut hw.mem, v),
            AnyKey::Hardware(k) => (k.set)(hw, v),
        }
    }
}

/// Every key of a hardware description, `[rt]`, then `[stack]`, then `[mem]`.
pub fn keys() -> Vec<AnyKey> {
    let all: Vec<AnyKey> = RtParams::KEYS
        .iter()
        .map(AnyKey::Rt)
        .chain(StackParams::KEYS.iter().map(AnyKey::Stack))
        .chain(MemParams::KEYS.iter().map(AnyKey::Mem))
        .chain(HARDWARE_KEYS.iter().map(AnyKey::Hardware))
        .collect();
    ["rt", "stack", "mem"]
        .iter()
        .flat_map(|s| all.iter().filter(move |k| k.section() == *s).copied())
        .collect()
}

/// The key `section.key`.
pub fn find_key(section: &str, key: &str) -> Option<AnyKey> {
    keys().into_iter().find(|k| k.section() == section && k.key() == key)
}

/// The keys of every table, for `--hw`'s help: `[rt]` keys a, b ("x" or "y"), ….
pub fn key_list() -> String {
    let keys = keys();
    let mut tables = Vec::new();
    for section in ["rt", "stack", "mem"] {
        let names: Vec<String> = keys
            .iter()
            .filter(|k| k.section() == section)
            .map(|k| match k.kind() {
                Kind::Choice(names) => {
                    let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
                    let (last, rest) = quoted.split_last().expect("a choice has names");
                    match rest {
                        [] => format!("{} ({last})", k.key()),
                        _ => format!("{} ({} or {last})", k.key(), rest.join(", ")),
                    }
                }
                Kind::Ways => format!("{} (0 = fully associative)", k.key()),
                Kind::Bool => format!("{} (true or false)", k.key()),
                Kind::Uint => match k.bound() {
                    b if b.most < u32::MAX => format!("{} ({} to {})", k.key(), b.least, b.most),
                    b if b.least > 1 => format!("{} (at least {})", k.key(), b.least),
                    _ => k.key().to_string(),
                },
            })
            .collect();
        tables.push(format!("[{section}] keys {}", names.join(", ")));
    }
    tables.join("; ")
}

/// `v`, read as a value of `name`'s `kind`.
fn value_of(name: &str, kind: Kind, v: &toml::Value) -> Result<Value, String> {
    match kind {
        Kind::Uint | Kind::Ways => v
            .as_integer()
            .and_then(|i| u32::try_from(i).ok())
            .map(Value::Uint)
            .ok_or_else(|| format!("{name} = {v}: expected a whole number ≥ 0")),
        Kind::Bool => {
            v.as_bool().map(Value::Bool).ok_or_else(|| format!("{name} = {v}: expected true or false"))
        }
        Kind::Choice(names) => {
            v.as_str().and_then(|s| names.iter().find(|n| **n == s)).map(|n| Value::Name(n)).ok_or_else(
                || {
                    let allowed: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
                    format!("{name} = {v}: expected one of {}", allowed.join(", "))
                },
            )
        }
    }
}

/// Applies the `[rt]`, `[stack]` and `[mem]` tables of `text` to `hw`.
pub fn apply_toml(hw: &mut Hardware, text: &str) -> Result<(), String> {
    let doc: toml::Table = text.parse().map_err(|e| format!("not valid TOML: {e}"))?;
    for (section, value) in &doc {
        let table = value.as_table().ok_or_else(|| format!("'{section}' must be a table ([{section}])"))?;
        for (key, v) in table {
            let name = format!("{section}.{key}");
            let k = find_key(section, key).ok_or_else(|| format!("unknown parameter {name}"))?;
            let value = value_of(&name, k.kind(), v)?;
            if !k.set(hw, value) {
                return Err(format!("{name} = {v}: not a value of this key"));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rtl::mem::{Assoc, L1dWrite, LocalLayout, SetIndex};
    use rtl::rt_unit::{PortPriority, StackTiming, StoreGating, WarpSelect};

    #[test]
    fn every_preset_is_valid_and_sets_every_parameter() {
        // Applied to two bases that differ in every key a file can set (made from the registry,
        // so a declared key is covered), a complete file gives the same hardware: a key it
        // forgot would keep the base's value. Run options are not hardware: no preset sets them.
        let a = base();
        // A field of `Hardware` outside the registry would not be compared: name them all.
        let Hardware { rt: _, stack: _, mem: _, shared_carveout: _, idle_skip: _ } = a;
        let mut b = a;
        for k in keys().into_iter().filter(|k| !k.run_option()) {
            let other = match (k.kind(), k.get(&a)) {
                (Kind::Choice(names), Value::Name(n)) => {
                    Value::Name(names.iter().find(|m| **m != n).unwrap())
                }
                (_, Value::Uint(v)) => Value::Uint(v + 3),
                (_, Value::Bool(x)) => Value::Bool(!x),
                (kind, v) => panic!("{}.{}: {v} is not a {kind:?}", k.section(), k.key()),
            };
            assert!(k.set(&mut b, other));
            assert_ne!(k.get(&b), k.get(&a), "{}.{}", k.section(), k.key());
        }
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
    fn the_key_list_names_every_key_once_in_its_table() {
        let list = key_list();
        let all = keys();
        assert_eq!(
            all.len(),
            RtParams::KEYS.len() + StackParams::KEYS.len() + MemParams::KEYS.len() + HARDWARE_KEYS.len()
        );
        for k in &all {
            let table = list.split("; ").find(|t| t.starts_with(&format!("[{}]", k.section()))).unwrap();
            let names: Vec<&str> = table
                .split_once(" keys ")
                .unwrap()
                .1
                .split(", ")
                .map(|n| n.split(' ').next().unwrap())
                .collect();
            assert_eq!(names.iter().filter(|n| **n == k.key()).count(), 1, "{} in {table}", k.key());
        }
        assert!(list.contains("timing (\"blocking\" or \"overlapped\")"), "{list}");
        assert!(list.contains("l2_ways (0 = fully associative)"), "{list}");
        assert!(list.contains("store_gating (\"acked\", \"posted\" or \"sh-posted\")"), "{list}");
        assert!(
            list.contains("sh_latency (at least 2)") && list.contains("store_queue (0 to 65535)"),
            "{list}"
        );
    }

    #[test]
    fn the_default_is_the_paper_preset_and_its_text_values() {
        let hw = Hardware::default();
        assert_eq!(hw, preset("paper").unwrap());
        // SPEC section 7 / the paper's text.
        assert_eq!((hw.mem.sms, hw.mem.l1d_bytes, hw.mem.l2_bytes), (8, 64 << 10, 3 << 20));
        assert_eq!((hw.mem.l2_latency, hw.mem.dram_latency), (160, 100));
        assert_eq!(hw.stack.timing, StackTiming::Blocking);
        // The open choices as docs/assumptions.md settles them: the paper's text where it speaks
        // (GTO), Vulkan-Sim's source where only it does (an unbounded store queue), and the
        // model's reading of the paper's sequence otherwise.
        assert_eq!(
            (hw.stack.store_gating, hw.stack.store_queue, hw.stack.port_priority, hw.rt.warp_select),
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
        assert_eq!((hw.rt, hw.stack), (RtParams::default(), StackParams::default().overlapped()));
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
        assert_eq!((hw.rt.triangle, hw.idle_skip, hw.mem.l2_latency), (12, false, 200));
        assert_eq!(hw.mem.l1d_assoc, Assoc::Ways(4));
        assert_eq!(hw.rt.internal, 8, "keys not named keep their value");
        apply_toml(
            &mut hw,
            "[stack]\ntiming = \"overlapped\"\nsh_latency = 2\n[mem]\nl1d_write = \"through\"\nl2_set_index = \"linear\"\nlocal_layout = \"linear\"\nshared_carveout = false\n",
        )
        .unwrap();
        assert_eq!(
            (hw.stack.timing, hw.stack.sh_latency, hw.shared_carveout),
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
            (hw.stack.store_gating, hw.stack.store_queue, hw.stack.port_priority, hw.rt.warp_select),
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
