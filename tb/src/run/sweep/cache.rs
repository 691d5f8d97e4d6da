//! The sweep's result cache: every finished simulation (and every scene's stack-depth pass) is
//! written to disk as soon as it ends, so a sweep that is stopped (Ctrl-C, a crash, a reboot)
//! and run again picks up where it stopped.
//!
//! ```text
//!   key = model version  (SMS_MODEL_VERSION: hash of rtl/src, tb/src, manifests, lock file; tb/build.rs)
//!       + scene          (name and content: every primitive, mesh, instance, camera, render settings)
//!       + workload       (resolution, spp, bounces, path end, seed, BVH, child order, acceleration structure)
//!       + sampling       (fraction, mode, batches, seed; or every warp)
//!       + configuration + hardware (the whole resolved Hardware, L1D size included)
//!   file = DIR/<128-bit hash of the key>.json, holding the key itself and the result
//! ```
//!
//! A file is used only if the key it holds equals the key asked for, so a hash collision, a
//! file from another version or anything else that changed is recomputed, never reused. Files
//! are written to a temporary name and renamed into place, so a run killed mid-write leaves no
//! partial file under a final name; a file that cannot be read or parsed anyway (truncated by a
//! full disk, edited) is counted as ignored and recomputed. Results are stored bit for bit
//! (floats by their bit patterns), so a report built from cached results is byte-identical to
//! one built from fresh ones.
//!
//! Results of other model versions can never be used again (the version is part of every key):
//! opening a cache counts them, with files that cannot be parsed and temporary files a killed run
//! left behind, as *stale*; the sweep says how many and how large, and with `--prune-cache`
//! deletes them first ([`Cache::open_pruning`]). Files not named like the cache's are never
//! touched.
//!
//! Testing hook (not a user feature): with `SMS_SWEEP_STOP_AFTER=N` in the environment, the sweep
//! fails after storing N fresh results, as if it had been killed there.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use rtl::config::Config;
use rtl::stack_manager::StackStats;
use serde::{Deserialize, Serialize};

use super::{Measured, RunSample, SceneInfo};
use crate::error::{Error, Result};
use crate::run::sampling::SamplePlan;
use crate::run::sim::{Fidelity, GpuCounts, Hardware, Outcome};
use crate::workload::depth::DepthHistogram;
use crate::workload::geometry::Primitives;
use crate::workload::scene::{MeshGeometry, Scene};
use crate::workload::WorkloadOpts;

/// Results stored by this process, in every cache (what an interrupted sweep says it kept).
pub static STORED: AtomicUsize = AtomicUsize::new(0);

/// The model's version: a hash of its sources, computed at build time (see `tb/build.rs`).
pub const MODEL_VERSION: &str = env!("SMS_MODEL_VERSION");

/// The environment variable of the testing hook (see the module documentation).
pub const STOP_AFTER_ENV: &str = "SMS_SWEEP_STOP_AFTER";

/// Bumped when the file layout changes, so that files of another layout are stale (and a
/// result lacking a field a figure needs is never read as one with it). 2: the GPU counts end
/// with the thread-cycle breakdown.
const FORMAT: &str = "sms-sweep-cache 2";

/// FNV-1a, 128 bits: the scene content hash and the file names.
struct Fnv(u128);

impl Fnv {
    fn new() -> Self {
        Fnv(0x6c62272e07bb014262b821756295c58d)
    }

    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ u128::from(x)).wrapping_mul(0x0000000001000000000000000000013B);
        }
    }

    fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }

    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
}

/// What identifies a scene's content: its name and a hash of everything the loaders produced
/// (every primitive, the meshes and instances of the two-level structure, the camera and the
/// render settings).
pub fn scene_key(scene: &Scene) -> String {
    let mut h = Fnv::new();
    match &scene.primitives {
        Primitives::Triangles(t) => {
            h.bytes(b"triangles");
            h.u32(t.len() as u32);
            for t in t {
                h.f32s(&[t.v0.to_array(), t.v1.to_array(), t.v2.to_array()].concat());
            }
        }
        Primitives::Spheres(s) => {
            h.bytes(b"spheres");
            h.u32(s.len() as u32);
            for s in s {
                h.f32s(&s.center.to_array());
                h.f32s(&[s.radius]);
            }
        }
    }
    let o = &scene.objects;
    h.u32(o.local.len() as u32);
    for t in &o.local {
        h.f32s(&[t.v0.to_array(), t.v1.to_array(), t.v2.to_array()].concat());
    }
    for m in &o.meshes {
        let (tag, r) = match m {
            MeshGeometry::World(r) => (0, r),
            MeshGeometry::Local(r) => (1, r),
        };
        h.bytes(&[tag]);
        h.u32(r.start);
        h.u32(r.end);
    }
    for i in &o.instances {
        h.u32(i.mesh);
        match i.to_world {
            None => h.bytes(&[0]),
            Some(a) => {
                h.bytes(&[1]);
                h.f32s(&a.to_cols_array());
            }
        }
    }
    let c = &scene.camera;
    h.f32s(&[c.eye.to_array(), c.look_at.to_array(), c.up.to_array(), [c.vfov, 0.0, 0.0]].concat());
    format!("{} content {:032x} render {:?}", scene.name, h.0, scene.render)
}

/// The key of one simulation.
pub fn run_key(
    scene_key: &str,
    opts: &WorkloadOpts,
    sample: Option<SamplePlan>,
    config: &Config,
    hw: &Hardware,
) -> String {
    format!(
        "{FORMAT}: run\nmodel {MODEL_VERSION}\nscene {scene_key}\nworkload {opts:?}\nsample {sample:?}\n\
         fidelity cycle\nconfig {}\nhardware {hw:?}",
        config.name()
    )
}

/// The key of a scene's workload statistics (rays, warps, depth histogram): they depend on the
/// traces alone.
pub fn scene_info_key(scene_key: &str, opts: &WorkloadOpts) -> String {
    format!("{FORMAT}: scene\nmodel {MODEL_VERSION}\nscene {scene_key}\nworkload {opts:?}")
}

#[derive(Serialize, Deserialize)]
struct RunRecord {
    key: String,
    functional: bool,
    pixel_warps: u32,
    stack: Vec<u64>,
    /// [`GpuCounts`] in declaration order, floats as bit patterns.
    gpu: Option<Vec<u64>>,
    pops_checked: u64,
    wall_nanos: u64,
    sample: Option<SampleRecord>,
}

#[derive(Serialize, Deserialize)]
struct SampleRecord {
    fraction_bits: u64,
    sampled_warps: u32,
    cycles_rel_half_width_bits: u64,
}

#[derive(Serialize, Deserialize)]
struct SceneRecord {
    key: String,
    rays: u64,
    pixel_warps: u32,
    depth_counts: Vec<u64>,
    depth_traces: u64,
}

impl RunRecord {
    fn new(key: &str, (o, s): &Measured) -> Self {
        RunRecord {
            key: key.to_owned(),
            functional: o.fidelity == Fidelity::Functional,
            pixel_warps: o.pixel_warps,
            stack: o.stack.values().to_vec(),
            gpu: o.gpu.as_ref().map(GpuCounts::to_words),
            pops_checked: o.pops_checked,
            wall_nanos: u64::try_from(o.wall.as_nanos()).unwrap_or(u64::MAX),
            sample: s.map(|s| SampleRecord {
                fraction_bits: s.fraction.to_bits(),
                sampled_warps: s.sampled_warps,
                cycles_rel_half_width_bits: s.cycles_rel_half_width.to_bits(),
            }),
        }
    }

    fn measured(&self) -> Option<Measured> {
        let stack = StackStats::from_values(self.stack.as_slice().try_into().ok()?);
        let gpu = match &self.gpu {
            None => None,
            Some(w) => Some(GpuCounts::from_words(w)?),
        };
        let outcome = Outcome {
            fidelity: if self.functional { Fidelity::Functional } else { Fidelity::Cycle },
            pixel_warps: self.pixel_warps,
            stack,
            gpu,
            pops_checked: self.pops_checked,
            wall: Duration::from_nanos(self.wall_nanos),
        };
        let sample = self.sample.as_ref().map(|s| RunSample {
            fraction: f64::from_bits(s.fraction_bits),
            sampled_warps: s.sampled_warps,
            cycles_rel_half_width: f64::from_bits(s.cycles_rel_half_width_bits),
        });
        Some((outcome, sample))
    }
}

/// How a sweep used its cache.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CacheStats {
    pub dir: PathBuf,
    /// Simulation results read from the cache.
    pub hits: usize,
    /// Simulation results computed (and stored).
    pub fresh: usize,
    /// Files under a wanted key that could not be used (unreadable, corrupt, another key).
    pub ignored: usize,
    /// Stale files found when the cache was opened (see the module documentation), and their
    /// bytes; with `pruned`, they were deleted.
    pub stale: usize,
    pub stale_bytes: u64,
    pub pruned: bool,
}

impl CacheStats {
    /// One line for stderr.
    pub fn describe(&self) -> String {
        let ignored = match self.ignored {
            0 => String::new(),
            n => format!("; {n} unusable cache file(s) ignored and recomputed"),
        };
        let stale = match (self.stale, self.pruned) {
            (0, _) => String::new(),
            (n, true) => format!(
                "; {n} stale file(s) ({}) deleted first",
                crate::run::memory::describe(Some(self.stale_bytes))
            ),
            (n, false) => format!(
                "; {n} stale file(s) ({}) of other model versions or killed runs: --prune-cache deletes them",
                crate::run::memory::describe(Some(self.stale_bytes))
            ),
        };
        format!(
            "{} of {} simulation results from the cache {}, {} computed{ignored}{stale}",
            self.hits,
            self.hits + self.fresh,
            self.dir.display(),
            self.fresh
        )
    }
}

/// A temporary file of another process younger than this may still be in use.
const TEMP_GRACE: Duration = Duration::from_secs(600);

/// A cache file whose key is of this model version and file format.
#[derive(Deserialize)]
struct KeyOnly {
    key: String,
}

fn current(key: &str) -> bool {
    key.starts_with(FORMAT) && key.contains(&format!("\nmodel {MODEL_VERSION}\n"))
}

/// Whether the cache folder's file `path` (named `name`) is stale; `None` for a file the cache
/// does not own (left alone).
fn stale(path: &Path, name: &str) -> Option<bool> {
    if let Some(rest) = name.strip_prefix(".tmp-") {
        let ours = rest.split('-').next() == Some(&std::process::id().to_string());
        let age = std::fs::metadata(path).and_then(|m| m.modified()).ok()?.elapsed().unwrap_or_default();
        return Some(!ours && age > TEMP_GRACE);
    }
    let stem = name.strip_suffix(".json")?;
    if stem.len() != 32 || !stem.bytes().all(|b| b.is_ascii_hexdigit()) {
        return None;
    }
    let text = std::fs::read(path).ok()?;
    Some(serde_json::from_slice::<KeyOnly>(&text).map_or(true, |k| !current(&k.key)))
}

/// A cache folder in use by one sweep.
pub struct Cache {
    dir: PathBuf,
    hits: AtomicUsize,
    fresh: AtomicUsize,
    ignored: AtomicUsize,
    temp_counter: AtomicUsize,
    stop_after: Option<usize>,
    stopped: AtomicBool,
    /// Stale files found at opening, their bytes, and whether they were deleted.
    stale: (usize, u64, bool),
}

impl Cache {
    /// The cache in `dir`, created if missing; stale files are counted, not deleted.
    pub fn open(dir: &Path) -> Result<Self> {
        Cache::open_with(dir, false)
    }

    /// [`Cache::open`], deleting stale files first.
    pub fn open_pruning(dir: &Path) -> Result<Self> {
        Cache::open_with(dir, true)
    }

    fn open_with(dir: &Path, prune: bool) -> Result<Self> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let mut stale_files = (0, 0, prune);
        for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
            let entry = entry.map_err(|e| Error::io(dir, e))?;
            let (path, name) = (entry.path(), entry.file_name());
            if stale(&path, &name.to_string_lossy()) != Some(true) {
                continue;
            }
            stale_files.0 += 1;
            stale_files.1 += entry.metadata().map_or(0, |m| m.len());
            if prune {
                std::fs::remove_file(&path).map_err(|e| Error::io(&path, e))?;
            }
        }
        let stop_after = match std::env::var(STOP_AFTER_ENV) {
            Ok(v) => Some(v.trim().parse().map_err(|_| {
                Error::Invalid(format!("{STOP_AFTER_ENV}={v}: expected a number of results"))
            })?),
            Err(_) => None,
        };
        Ok(Cache {
            dir: dir.to_path_buf(),
            hits: AtomicUsize::new(0),
            fresh: AtomicUsize::new(0),
            ignored: AtomicUsize::new(0),
            temp_counter: AtomicUsize::new(0),
            stop_after,
            stopped: AtomicBool::new(false),
            stale: stale_files,
        })
    }

    pub fn stats(&self) -> CacheStats {
        CacheStats {
            dir: self.dir.clone(),
            hits: self.hits.load(Ordering::Relaxed),
            fresh: self.fresh.load(Ordering::Relaxed),
            ignored: self.ignored.load(Ordering::Relaxed),
            stale: self.stale.0,
            stale_bytes: self.stale.1,
            pruned: self.stale.2,
        }
    }

    fn path(&self, key: &str) -> PathBuf {
        let mut h = Fnv::new();
        h.bytes(key.as_bytes());
        self.dir.join(format!("{:032x}.json", h.0))
    }

    /// The record stored under `key`, if a usable one is there.
    fn read<T: serde::de::DeserializeOwned>(&self, key: &str, key_of: impl Fn(&T) -> &str) -> Option<T> {
        let text = match std::fs::read(self.path(key)) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
            Err(_) => {
                self.ignored.fetch_add(1, Ordering::Relaxed);
                return None;
            }
        };
        match serde_json::from_slice::<T>(&text) {
            Ok(r) if key_of(&r) == key => Some(r),
            _ => {
                self.ignored.fetch_add(1, Ordering::Relaxed);
                None
            }
        }
    }

    /// Writes `record` under `key`: to a temporary file, then renamed into place.
    fn write<T: Serialize>(&self, key: &str, record: &T) -> Result<()> {
        let path = self.path(key);
        let n = self.temp_counter.fetch_add(1, Ordering::Relaxed);
        let temp = self.dir.join(format!(".tmp-{}-{n}", std::process::id()));
        let text = serde_json::to_vec(record).map_err(|e| Error::Invalid(format!("cache record: {e}")))?;
        std::fs::write(&temp, text).map_err(|e| Error::io(&temp, e))?;
        std::fs::rename(&temp, &path).map_err(|e| Error::io(&path, e))
    }

    /// A simulation's result, if cached.
    pub fn get_run(&self, key: &str) -> Option<Measured> {
        let m = self.read::<RunRecord>(key, |r| &r.key)?.measured();
        match m {
            Some(_) => self.hits.fetch_add(1, Ordering::Relaxed),
            None => self.ignored.fetch_add(1, Ordering::Relaxed),
        };
        m
    }

    /// Stores a fresh simulation result. Fails (the testing hook) once the environment's stop
    /// count is reached.
    pub fn put_run(&self, key: &str, m: &Measured) -> Result<()> {
        self.write(key, &RunRecord::new(key, m))?;
        STORED.fetch_add(1, Ordering::Relaxed);
        let fresh = self.fresh.fetch_add(1, Ordering::Relaxed) + 1;
        if self.stop_after.is_some_and(|n| fresh >= n) {
            self.stopped.store(true, Ordering::Relaxed);
        }
        self.check_stop()
    }

    /// The testing hook's error once it has fired.
    pub fn check_stop(&self) -> Result<()> {
        if self.stopped.load(Ordering::Relaxed) {
            return Err(Error::Invalid(format!(
                "stopped after {} fresh results ({STOP_AFTER_ENV})",
                self.stop_after.unwrap_or(0)
            )));
        }
        Ok(())
    }

    pub fn get_scene(&self, key: &str) -> Option<SceneInfo> {
        let r = self.read::<SceneRecord>(key, |r| &r.key)?;
        Some(SceneInfo {
            rays: r.rays,
            pixel_warps: r.pixel_warps,
            depth: DepthHistogram { counts: r.depth_counts, traces: r.depth_traces },
        })
    }

    pub fn put_scene(&self, key: &str, info: &SceneInfo) -> Result<()> {
        let r = SceneRecord {
            key: key.to_owned(),
            rays: info.rays,
            pixel_warps: info.pixel_warps,
            depth_counts: info.depth.counts.clone(),
            depth_traces: info.depth.traces,
        };
        self.write(key, &r)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rtl::thread_cycles::ThreadCycles;

    fn measured() -> Measured {
        let gpu = GpuCounts {
            cycles: 12345,
            l1d_hit_rate: 0.1 + 0.2,
            l2_hit_rate: 1.0 / 3.0,
            thread_cycles_stack: 77,
            ..Default::default()
        };
        let outcome = Outcome {
            fidelity: Fidelity::Cycle,
            pixel_warps: 7,
            stack: StackStats::from_values(std::array::from_fn(|i| i as u64 * 3 + 1)),
            gpu: Some(gpu),
            pops_checked: 99,
            wall: Duration::from_nanos(123_456_789),
        };
        let sample = RunSample { fraction: 0.25, sampled_warps: 3, cycles_rel_half_width: 0.0123456789 };
        (outcome, Some(sample))
    }

    fn temp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("sms-cache-unit-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        d
    }

    #[test]
    fn a_result_comes_back_bit_for_bit_under_its_key_only() {
        let dir = temp("roundtrip");
        let c = Cache::open(&dir).unwrap();
        let m = measured();
        assert_eq!(c.get_run("k"), None);
        c.put_run("k", &m).unwrap();
        let back = c.get_run("k").unwrap();
        assert_eq!(back, m);
        assert_eq!(back.0.gpu.unwrap().l1d_hit_rate.to_bits(), (0.1f64 + 0.2).to_bits());
        assert_eq!(c.get_run("other"), None);
        // A file holding another key (a hash collision, or a renamed file) is not used.
        std::fs::copy(c.path("k"), c.path("other")).unwrap();
        assert_eq!(c.get_run("other"), None);
        assert_eq!(c.stats().hits, 1);
        assert_eq!(c.stats().ignored, 1);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn corrupt_or_truncated_files_are_ignored() {
        let dir = temp("corrupt");
        let c = Cache::open(&dir).unwrap();
        c.put_run("k", &measured()).unwrap();
        let full = std::fs::read(c.path("k")).unwrap();
        for bad in [&full[..full.len() / 2], b"", b"{\"key\":\"k\"}", &[0xff, 0xfe, 0x00][..]] {
            std::fs::write(c.path("k"), bad).unwrap();
            assert_eq!(c.get_run("k"), None);
        }
        // A stack counter missing: parsed, but not a result.
        let mut r: serde_json::Value = serde_json::from_slice(&full).unwrap();
        r["stack"].as_array_mut().unwrap().pop();
        std::fs::write(c.path("k"), serde_json::to_vec(&r).unwrap()).unwrap();
        assert_eq!(c.get_run("k"), None);
        assert_eq!(c.stats().ignored, 5);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn stale_files_are_counted_and_pruned_and_nothing_else_is_touched() {
        let dir = temp("prune");
        let c = Cache::open(&dir).unwrap();
        let key = run_key("scene", &WorkloadOpts::default(), None, &Config::default(), &Hardware::default());
        c.put_run(&key, &measured()).unwrap();
        // The same result under another model version's key, a corrupt file, a temporary file a
        // killed run left an hour ago, and one another run may still be writing.
        let old_key = key.replace(MODEL_VERSION, "0123456789abcdef");
        assert_ne!(old_key, key);
        c.put_run(&old_key, &measured()).unwrap();
        std::fs::write(c.path("corrupt"), b"{ not json").unwrap();
        let old_temp = dir.join(".tmp-1-0");
        std::fs::write(&old_temp, b"partial").unwrap();
        let hour_ago = std::time::SystemTime::now() - Duration::from_secs(3600);
        std::fs::File::options().write(true).open(&old_temp).unwrap().set_modified(hour_ago).unwrap();
        std::fs::write(dir.join(".tmp-1-1"), b"being written").unwrap();
        // Not the cache's: left alone.
        std::fs::write(dir.join("notes.txt"), b"mine").unwrap();
        std::fs::write(dir.join("abc.json"), b"{}").unwrap();
        let files = || std::fs::read_dir(&dir).unwrap().count();
        assert_eq!(files(), 7);

        let counted = Cache::open(&dir).unwrap();
        let s = counted.stats();
        assert_eq!((s.stale, s.pruned), (3, false));
        assert!(s.stale_bytes > 0);
        assert!(s.describe().contains("3 stale file(s)") && s.describe().contains("--prune-cache"));
        assert_eq!(files(), 7, "counting deletes nothing");

        let pruned = Cache::open_pruning(&dir).unwrap();
        assert_eq!((pruned.stats().stale, pruned.stats().pruned), (3, true));
        assert!(pruned.stats().describe().contains("deleted first"));
        assert_eq!(files(), 4);
        assert!(!c.path(&old_key).exists() && !old_temp.exists() && dir.join(".tmp-1-1").exists());
        assert_eq!(pruned.get_run(&key), Some(measured()), "the current result stays usable");
        assert_eq!(Cache::open(&dir).unwrap().stats().stale, 0);
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A result stored in the layout without the thread-cycle breakdown (five GPU words fewer)
    /// is recomputed, not read with the breakdown missing; under the previous format's key it
    /// is stale besides.
    #[test]
    fn a_result_without_the_thread_cycle_breakdown_is_recomputed() {
        let dir = temp("breakdown");
        let c = Cache::open(&dir).unwrap();
        let key = run_key("scene", &WorkloadOpts::default(), None, &Config::default(), &Hardware::default());
        c.put_run(&key, &measured()).unwrap();
        let mut r: serde_json::Value = serde_json::from_slice(&std::fs::read(c.path(&key)).unwrap()).unwrap();
        let words = r["gpu"].as_array_mut().unwrap();
        words.truncate(words.len() - ThreadCycles::NAMES.len());
        std::fs::write(c.path(&key), serde_json::to_vec(&r).unwrap()).unwrap();
        assert_eq!(c.get_run(&key), None, "a record without the breakdown is no result");
        assert_eq!(c.stats().ignored, 1);
        let old_key = key.replacen(FORMAT, "sms-sweep-cache 1", 1);
        assert_ne!(old_key, key);
        c.put_run(&old_key, &measured()).unwrap();
        assert_eq!(Cache::open(&dir).unwrap().stats().stale, 1, "the previous format's file is stale");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn scene_content_changes_the_key() {
        let a = crate::workload::scene::procedural::build("wknd").unwrap();
        let mut b = a.clone();
        assert_eq!(scene_key(&a), scene_key(&b));
        if let Primitives::Spheres(s) = &mut b.primitives {
            s[0].radius = f32::from_bits(s[0].radius.to_bits() + 1);
        } else if let Primitives::Triangles(t) = &mut b.primitives {
            t[0].v0.x = f32::from_bits(t[0].v0.x.to_bits() + 1);
        }
        assert_ne!(scene_key(&a), scene_key(&b));
        let mut c = a.clone();
        c.camera.vfov += 1.0;
        assert_ne!(scene_key(&a), scene_key(&c));
    }
}
