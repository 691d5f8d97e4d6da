//! Hardware presets shipped with the project: TOML files in `tb/hw/`, embedded in the binary so an
//! installed `sms` has them too. Each file sets every hardware key and cites its source line by
//! line; `--hw NAME` selects one, `--hw PATH` reads a file of the same format.

use std::path::Path;

/// One shipped hardware description.
#[derive(Clone, Copy, Debug)]
pub struct Preset {
    pub name: &'static str,
    pub about: &'static str,
    pub toml: &'static str,
}

/// The default hardware: the paper's text, the rest from Vulkan-Sim's MOBILE configuration.
pub const DEFAULT: &str = "paper";

/// Every shipped preset, the default first.
pub const PRESETS: [Preset; 4] = [
    Preset {
        name: "paper",
        about: "the paper's text (8 SMs, 64 KB unified L1D/shared, 3 MB L2, 160/100-cycle L2/DRAM); \
                the rest from Vulkan-Sim MOBILE (default)",
        toml: include_str!("../../hw/paper.toml"),
    },
    Preset {
        name: "vulkansim-mobile",
        about: "Vulkan-Sim's MOBILE config file as it is (32 KB L1D beside 64 KB shared, 512 KB L2, 56 GB/s)",
        toml: include_str!("../../hw/vulkansim-mobile.toml"),
    },
    Preset {
        name: "rtx2060",
        about: "Vulkan-Sim's RTX 2060 config (30 SMs, 64 KB L1D, 3 MB L2 in 24 slices, 336 GB/s)",
        toml: include_str!("../../hw/rtx2060.toml"),
    },
    Preset {
        name: "legacy",
        about: "this model before it adopted Vulkan-Sim's mechanisms: overlapped stack timing, \
                per-thread spill regions, linear L2, write-through L1D (reproduces its reports)",
        toml: include_str!("../../hw/legacy.toml"),
    },
];

/// The preset called `name`.
pub fn find(name: &str) -> Option<&'static Preset> {
    PRESETS.iter().find(|p| p.name.eq_ignore_ascii_case(name))
}

/// Names of the presets, comma-separated (for help and errors).
pub fn names() -> String {
    PRESETS.iter().map(|p| p.name).collect::<Vec<_>>().join(", ")
}

/// The TOML text `spec` names: a preset name, else a file path. The error says which names exist.
pub fn text_of(spec: &str) -> Result<(String, String), String> {
    if let Some(p) = find(spec) {
        return Ok((p.name.to_string(), p.toml.to_string()));
    }
    let path = Path::new(spec);
    match std::fs::read_to_string(path) {
        Ok(text) => Ok((path.display().to_string(), text)),
        Err(e) => Err(format!("{spec}: not a preset ({}) and cannot read it as a file: {e}", names())),
    }
}
