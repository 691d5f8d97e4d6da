//! What produced a report: the workload (scenes, resolution, samples, bounces, seed, hierarchy,
//! acceleration structure), the hardware (its name and a hash of its whole description) and the
//! model (crate version, git commit, hash of the sources, SHA-256 of the `Cargo.lock` it was
//! built with). Scenes given by path add each file read, with its SHA-256. Every report of `sms run`, `depth`,
//! `cost`, `sweep` and `ablate` carries one: a `provenance` object in JSON, a line above the
//! table in text and Markdown, `# ` comment lines on top of CSV (docs/reports.md).
//!
//! Nothing here varies between identical runs (no time, no host), so reports stay
//! byte-identical whatever the thread count, sharding or cache.

use serde::Serialize;

use crate::digest::{fnv1a64, sha256_hex};
use crate::hw::Hardware;
use crate::workload::scene::SourceFile;
use crate::workload::traverse::ChildOrder;
use crate::workload::{Accel, BvhKind, PathEnd, WorkloadOpts};

/// The model's version, as every report states it.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct ModelId {
    /// The crate version (`Cargo.toml`).
    pub version: &'static str,
    /// The git commit built from, `-dirty` when the model's sources differed from it; `null`
    /// when built outside a git checkout (a source tarball).
    pub commit: Option<&'static str>,
    /// Hash of every source the results depend on (`tb/build.rs`): the result cache's key.
    pub sources: &'static str,
    /// SHA-256 of the workspace's `Cargo.lock` the binary was built with (embedded at build
    /// time): which version of every dependency went in, when built with `--locked`.
    pub cargo_lock: String,
}

/// The workspace's lock file as it was when this binary was built.
const CARGO_LOCK: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../Cargo.lock"));

impl ModelId {
    pub fn current() -> Self {
        let commit = env!("SMS_GIT_COMMIT");
        ModelId {
            version: env!("CARGO_PKG_VERSION"),
            commit: (!commit.is_empty()).then_some(commit),
            sources: crate::run::sweep::cache::MODEL_VERSION,
            cargo_lock: sha256_hex(CARGO_LOCK),
        }
    }

    fn describe(&self) -> String {
        let commit = self.commit.map_or("no git commit".to_string(), |c| format!("commit {}", short(c)));
        format!(
            "sms {} ({commit}, sources {}, Cargo.lock {})",
            self.version,
            &self.sources[..16.min(self.sources.len())],
            &self.cargo_lock[..16]
        )
    }
}

/// `c` cut to 12 hex digits, a `-dirty` suffix kept.
fn short(c: &str) -> String {
    match c.split_once('-') {
        Some((h, rest)) => format!("{}-{rest}", &h[..12.min(h.len())]),
        None => c[..12.min(c.len())].to_string(),
    }
}

/// The hardware as named on the command line, and a hash of the whole resolved description.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct HardwareId {
    /// The preset or file given to `--hw` (`paper` by default), with the flags that changed it.
    pub name: String,
    /// FNV-1a (64 bits) of the resolved description's canonical text: equal hashes, equal
    /// hardware, whatever the name.
    pub hash: String,
}

impl HardwareId {
    pub fn new(name: String, hw: &Hardware) -> Self {
        HardwareId { name, hash: hardware_hash(hw) }
    }
}

/// The hash of `hw`'s canonical text ([`canonical_text`]).
pub fn hardware_hash(hw: &Hardware) -> String {
    format!("{:016x}", fnv1a64(canonical_text(hw).as_bytes()))
}

/// Every parameter of `hw` by field name, integers in decimal and enums by variant name, in one
/// fixed layout: the RT unit's latencies, the run option `idle_skip`, the `[stack]` keys, the
/// warp scheduler, then the memory system (its `Debug` form, fields in declaration order) and the
/// carve-out. The layout does not follow how the structs group their fields, so regrouping them
/// keeps every hash; a new key changes every hash, and the pinned hashes in this file's tests
/// say so. The destructuring below names every field: a new field does not compile until it is
/// placed in the text.
pub fn canonical_text(hw: &Hardware) -> String {
    let Hardware { rt, stack, mem, shared_carveout, idle_skip } = hw;
    let rtl::rt_unit::RtParams {
        bvh_header,
        internal,
        instance_leaf,
        leaf_descriptor,
        triangle,
        procedural,
        warp_select,
    } = rt;
    let rtl::rt_unit::StackParams { timing, sh_latency, store_gating, store_queue, port_priority } = stack;
    format!(
        "Hardware {{ rt: RtParams {{ bvh_header: {bvh_header}, internal: {internal}, instance_leaf: \
         {instance_leaf}, leaf_descriptor: {leaf_descriptor}, triangle: {triangle}, procedural: \
         {procedural}, idle_skip: {idle_skip}, stack_timing: {timing:?}, sh_latency: {sh_latency}, \
         store_gating: {store_gating:?}, store_queue: {store_queue}, port_priority: {port_priority:?}, \
         warp_select: {warp_select:?} }}, mem: {mem:?}, shared_carveout: {shared_carveout} }}"
    )
}

/// The workload side of a report. A value the scenes of a sweep do not share (each scene's own
/// resolution, say) is `None`: the report's scene table gives each.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct WorkloadId {
    pub scenes: Vec<String>,
    /// `WIDTHxHEIGHT`.
    pub resolution: Option<String>,
    pub spp: Option<u32>,
    /// Diffuse bounces after the primary ray.
    pub bounces: Option<u32>,
    pub seed: Option<u64>,
    pub bvh: Option<BvhKind>,
    pub accel: Option<Accel>,
    pub order: Option<ChildOrder>,
    pub path_end: Option<PathEnd>,
    /// The files read for scenes given by path, with their SHA-256 (absent when every scene was
    /// named: a built-in or shipped scene is identified by its name).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub files: Vec<SourceFile>,
}

impl WorkloadId {
    /// The workloads `opts` of `scenes`: a value when every scene has the same.
    pub fn new(scenes: Vec<String>, opts: &[WorkloadOpts]) -> Self {
        fn same<T: PartialEq + Copy>(opts: &[WorkloadOpts], f: impl Fn(&WorkloadOpts) -> T) -> Option<T> {
            let first = f(opts.first()?);
            opts.iter().all(|o| f(o) == first).then_some(first)
        }
        WorkloadId {
            scenes,
            resolution: same(opts, |o| (o.width, o.height)).map(|(w, h)| format!("{w}x{h}")),
            spp: same(opts, |o| o.spp),
            bounces: same(opts, |o| o.max_bounces),
            seed: same(opts, |o| o.seed),
            bvh: same(opts, |o| o.bvh),
            accel: same(opts, |o| o.accel),
            order: same(opts, |o| o.order),
            path_end: same(opts, |o| o.path_end),
            files: Vec::new(),
        }
    }

    /// The same, stating the files `scenes` given by path were read from.
    pub fn with_files<'a>(mut self, scenes: impl IntoIterator<Item = &'a [SourceFile]>) -> Self {
        self.files = scenes.into_iter().flatten().cloned().collect();
        self
    }

    fn describe(&self) -> String {
        let each = "each scene's own";
        let or_each = |v: Option<String>| v.unwrap_or_else(|| each.to_string());
        // Named as in JSON and on the command line (`two-level`, `bvh6`).
        let name = |v: serde_json::Value| v.as_str().map_or_else(|| v.to_string(), str::to_string);
        let files = self
            .files
            .iter()
            .map(|f| format!(" · file {} (sha256 {})", f.path, &f.sha256[..16]))
            .collect::<String>();
        format!(
            "scene {}{files} · {} px · {} spp · {} bounce(s) · seed {} · {} {} ({} order, path end {})",
            self.scenes.join(","),
            or_each(self.resolution.clone()),
            or_each(self.spp.map(|v| v.to_string())),
            or_each(self.bounces.map(|v| v.to_string())),
            or_each(self.seed.map(|v| v.to_string())),
            or_each(self.accel.map(|v| name(serde_json::json!(v)))),
            or_each(self.bvh.map(|v| name(serde_json::json!(v)))),
            or_each(self.order.map(|v| name(serde_json::json!(v)))),
            or_each(self.path_end.map(|v| name(serde_json::json!(v)))),
        )
    }
}

/// What produced a report.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Provenance {
    /// `None` for reports of no workload (`sms cost`).
    #[serde(skip_serializing_if = "Option::is_none", flatten)]
    pub workload: Option<WorkloadId>,
    /// `None` for reports of no hardware (`sms depth`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub hardware: Option<HardwareId>,
    pub model: ModelId,
}

impl Provenance {
    pub fn new(workload: Option<WorkloadId>, hardware: Option<HardwareId>) -> Self {
        Provenance { workload, hardware, model: ModelId::current() }
    }

    /// One line: workload · hardware · model.
    pub fn line(&self) -> String {
        let mut parts = Vec::new();
        if let Some(w) = &self.workload {
            parts.push(w.describe());
        }
        if let Some(h) = &self.hardware {
            parts.push(format!("hardware {} (hash {})", h.name, h.hash));
        }
        parts.push(self.model.describe());
        parts.join(" · ")
    }

    /// The line for a text report.
    pub fn text(&self) -> String {
        format!("provenance: {}\n", self.line())
    }

    /// The line for a Markdown report, a paragraph of its own.
    pub fn markdown(&self) -> String {
        format!("Provenance: {}\n\n", self.line())
    }

    /// The lines on top of a CSV report, each a `#` comment (`pandas.read_csv(f, comment='#')`).
    pub fn csv(&self) -> String {
        format!("# provenance: {}\n", self.line())
    }

    pub fn json(&self) -> serde_json::Value {
        serde_json::to_value(self).expect("provenance always serialises")
    }
}

/// A JSON report object with a `provenance` field after its own, which keep their order.
#[derive(Serialize)]
pub struct WithProvenance<'a, T: Serialize> {
    #[serde(flatten)]
    pub report: T,
    pub provenance: &'a Provenance,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hardware_hash_is_fnv1a_of_the_description_and_tells_presets_apart() {
        // FNV-1a's published test vectors.
        assert_eq!(fnv1a64(b""), 0xcbf29ce484222325);
        assert_eq!(fnv1a64(b"a"), 0xaf63dc4c8601ec8c);
        let paper = crate::hw::preset("paper").unwrap();
        let legacy = crate::hw::preset("legacy").unwrap();
        assert_eq!(hardware_hash(&paper), hardware_hash(&Hardware::default()));
        assert_ne!(hardware_hash(&paper), hardware_hash(&legacy));
        assert_eq!(hardware_hash(&paper).len(), 16);
    }

    /// Published hashes stay: each shipped preset's, and descriptions that change a run option or
    /// `[stack]` keys, hash as they always have. A changed layout or a dropped field fails here.
    #[test]
    fn hashes_are_pinned() {
        let of = |name: &str| hardware_hash(&crate::hw::preset(name).unwrap());
        assert_eq!(of("paper"), "c7826ef13b1fe6b9");
        assert_eq!(of("legacy"), "1c6ce17f25f65928");
        assert_eq!(of("vulkansim-mobile"), "df2e196594acb362");
        assert_eq!(of("rtx2060"), "fff996fd15de36b4");
        let with = |toml: &str| {
            let mut hw = Hardware::default();
            crate::hw::apply_toml(&mut hw, toml).unwrap();
            hardware_hash(&hw)
        };
        assert_eq!(with("[rt]\nidle_skip = false\n"), "3d19713b2887cc00");
        assert_eq!(with("[stack]\nsh_latency = 7\nstore_queue = 3\n"), "f17ee64acdf83a9f");
    }

    /// Every key of a description is in the text: changing any one changes the hash.
    #[test]
    fn every_key_moves_the_hash() {
        let base = Hardware::default();
        for k in crate::hw::keys() {
            let mut hw = base;
            let other = match (k.kind(), k.get(&base)) {
                (rtl::params::Kind::Choice(names), rtl::params::Value::Name(n)) => {
                    rtl::params::Value::Name(names.iter().find(|m| **m != n).unwrap())
                }
                (_, rtl::params::Value::Uint(v)) => rtl::params::Value::Uint(v + 1),
                (_, rtl::params::Value::Bool(b)) => rtl::params::Value::Bool(!b),
                (kind, v) => panic!("{}.{}: {v} is not a {kind:?}", k.section(), k.key()),
            };
            assert!(k.set(&mut hw, other));
            assert_ne!(hardware_hash(&hw), hardware_hash(&base), "{}.{}", k.section(), k.key());
        }
    }

    #[test]
    fn values_the_scenes_do_not_share_are_left_open() {
        let a = WorkloadOpts { width: 16, height: 16, spp: 1, ..WorkloadOpts::default() };
        let b = WorkloadOpts { width: 32, ..a };
        let w = WorkloadId::new(vec!["x".into(), "y".into()], &[a, b]);
        assert_eq!((w.resolution, w.spp), (None, Some(1)));
        let p = Provenance::new(Some(WorkloadId::new(vec!["x".into()], &[a])), None);
        assert!(p.line().starts_with("scene x · 16x16 px · 1 spp"), "{}", p.line());
        assert!(p.csv().starts_with("# provenance: ") && p.csv().lines().count() == 1);
        assert_eq!(p.json()["resolution"], "16x16");
        assert_eq!(p.json()["model"]["version"], env!("CARGO_PKG_VERSION"));
    }
}
