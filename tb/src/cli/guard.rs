//! Guards against careless input, checked before any work: a workload too large for the machine
//! (estimated rays, memory and time, refused above [`MEMORY_SHARE`] of the available memory or
//! [`MAX_HOURS`] unless `--force`), and output paths inside the scene data folder, which `sms`
//! never writes.

use std::path::{Path, PathBuf};

use anyhow::bail;

use crate::run::sim::Fidelity;
use crate::workload::trace::WARP_SIZE;
use crate::workload::WorkloadOpts;

// The constants come from `/usr/bin/time -v sms run -c RB_8,SMS --jobs 2` (peak resident memory,
// wall time) on scenes from 6 255 to 6.9 M triangles (docs/experiments.md, "The workload
// estimate"). Memory terms are rounded up from the largest measured value; time is counted for
// every path at its full bounce limit, about 10× the rays LumiBench's settings trace, so the
// estimate stays above what a run takes.

/// Bytes a recorded ray trace takes while its pixel warp is traced or simulated (about 250).
const BYTES_PER_RAY: f64 = 256.0;
/// Pixel warps in memory per simulation at once: the one simulated and those traced ahead.
const WARPS_IN_FLIGHT: f64 = 17.0;
/// Memory of the process besides the scene and the traces (the GPU model; 24 MB measured).
const BASE_BYTES: f64 = 64e6;
/// Bytes per primitive of the loaded scene: its triangles, its BVH and what loading and building
/// them hold at their peak (measured 65–145 bytes).
const BYTES_PER_PRIMITIVE: f64 = 160.0;
/// Seconds per primitive to load the scene and build its BVH (measured 0.9 µs).
const SECS_PER_PRIMITIVE: f64 = 1e-6;
/// Seconds per ray: path tracing, and simulating it at each level (one core of the 2-core
/// development machine; measured 37–176 µs per traced ray at the cycle level, two jobs at once).
const TRACE_SECS_PER_RAY: f64 = 15e-6;
const CYCLE_SECS_PER_RAY: f64 = 100e-6;
const FUNCTIONAL_SECS_PER_RAY: f64 = 5e-6;

/// A run is refused above this share of the available memory ...
pub const MEMORY_SHARE: f64 = 0.5;
/// ... or above this many hours.
pub const MAX_HOURS: f64 = 24.0;

/// What a workload will cost, at most: every path is counted at its full bounce limit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    pub rays: f64,
    pub bytes: f64,
    pub secs: f64,
}

impl Estimate {
    /// The cost of tracing `opts` on a scene of `primitives` and simulating it `sims` times at
    /// `fidelity`, `parallel` at once.
    pub fn new(
        opts: &WorkloadOpts,
        primitives: usize,
        sims: usize,
        parallel: usize,
        fidelity: Fidelity,
    ) -> Self {
        let per_path = f64::from(opts.spp) * (f64::from(opts.max_bounces) + 1.0);
        let rays = f64::from(opts.width) * f64::from(opts.height) * per_path;
        let warp_bytes = WARP_SIZE as f64 * per_path * BYTES_PER_RAY;
        let parallel = parallel.clamp(1, sims.max(1)) as f64;
        let scene = primitives as f64;
        let bytes =
            BASE_BYTES + scene * BYTES_PER_PRIMITIVE + warp_bytes * (1.0 + parallel * WARPS_IN_FLIGHT);
        let sim = match fidelity {
            Fidelity::Cycle => CYCLE_SECS_PER_RAY,
            Fidelity::Functional => FUNCTIONAL_SECS_PER_RAY,
        };
        let secs = scene * SECS_PER_PRIMITIVE + rays * (TRACE_SECS_PER_RAY + sim * sims as f64 / parallel);
        Estimate { rays, bytes, secs }
    }

    pub fn describe(&self) -> String {
        let rays = if self.rays < 1e12 { format!("{:.0}", self.rays) } else { plain(self.rays) };
        format!("at most {rays} rays, {} of memory, {}", bytes(self.bytes), duration(self.secs))
    }

    /// An error naming the estimate and `--force` when it exceeds the limits of a machine with
    /// `available` bytes of memory.
    pub fn check(&self, available: Option<u64>, force: bool) -> anyhow::Result<()> {
        if force {
            return Ok(());
        }
        let limit = available.map(|a| a as f64 * MEMORY_SHARE);
        let too_big = limit.is_some_and(|l| self.bytes > l);
        if too_big || self.secs > MAX_HOURS * 3600.0 {
            let limit = limit.map_or(String::new(), |l| format!("{} of memory or ", bytes(l)));
            bail!(
                "estimated {}: above the limit of {limit}{MAX_HOURS} h; lower --res, --spp or --bounces, or \
                 pass --force to run anyway",
                self.describe()
            );
        }
        Ok(())
    }
}

/// `x` with at most one decimal and thousands grouped, or as `m × 10^e` beyond a trillion.
fn plain(x: f64) -> String {
    if x >= 1e12 {
        let e = x.log10().floor();
        return format!("{:.1} × 10^{e}", x / 10f64.powf(e));
    }
    let whole = format!("{:.0}", x.trunc());
    let grouped: Vec<String> =
        whole.as_bytes().rchunks(3).rev().map(|c| String::from_utf8_lossy(c).into_owned()).collect();
    let tenth = ((x.fract() * 10.0).round() as u32).min(9);
    if x < 100.0 && tenth > 0 {
        format!("{}.{tenth}", grouped.join(","))
    } else {
        grouped.join(",")
    }
}

fn bytes(b: f64) -> String {
    match b {
        b if b >= 1e12 => format!("{} TB", plain(b / 1e12)),
        b if b >= 1e9 => format!("{:.1} GB", b / 1e9),
        b => format!("{:.0} MB", b / 1e6),
    }
}

fn duration(s: f64) -> String {
    const YEAR: f64 = 3600.0 * 24.0 * 365.0;
    match s {
        s if s >= YEAR => format!("{} years", plain(s / YEAR)),
        s if s >= 3600.0 * 24.0 * 2.0 => format!("{} days", plain(s / (3600.0 * 24.0))),
        s if s >= 3600.0 => format!("{:.1} h", s / 3600.0),
        s if s >= 60.0 => format!("{:.0} min", s / 60.0),
        s => format!("{s:.0} s"),
    }
}

/// The machine's available memory (`MemAvailable` of `/proc/meminfo`), where known.
pub fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// `path` made absolute with its symbolic links resolved, as far as it exists (an output file
/// usually does not yet).
fn resolved(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut existing = abs.as_path();
    let mut rest = Vec::new();
    while !existing.exists() {
        match (existing.parent(), existing.file_name()) {
            (Some(p), Some(name)) => {
                rest.push(name.to_os_string());
                existing = p;
            }
            _ => return abs,
        }
    }
    let mut out = existing.canonicalize().unwrap_or_else(|_| existing.to_path_buf());
    out.extend(rest.iter().rev());
    out
}

/// Refuses an output `path` (given as `flag`) inside the scene data folder `data`: the shared
/// scenes are read-only input.
pub fn outside_scene_data(flag: &str, path: &Path, data: &Path) -> anyhow::Result<()> {
    if !data.is_dir() {
        return Ok(());
    }
    let (p, d) = (resolved(path), resolved(data));
    if p.starts_with(&d) {
        bail!(
            "{flag} {}: inside the scene data folder {}, which sms never writes; choose another path",
            path.display(),
            d.display()
        );
    }
    Ok(())
}

/// Makes `path` (given as `flag`) a folder to write into, before any work: outside the scene
/// data, a folder (created if missing) and writable; an error names the flag and what is wrong.
pub fn output_folder(flag: &str, path: &Path, data: &Path) -> anyhow::Result<()> {
    outside_scene_data(flag, path, data)?;
    let shown = path.display();
    if path.exists() && !path.is_dir() {
        bail!("{flag} {shown}: not a folder (a file has that name); give a folder to write into");
    }
    if let Err(e) = std::fs::create_dir_all(path) {
        bail!("{flag} {shown}: cannot create the folder ({e}); give a folder you can write into");
    }
    // One probe per process: shards started together prepare the same folder.
    let probe = path.join(format!(".sms-write-test-{}", std::process::id()));
    if let Err(e) = std::fs::write(&probe, b"") {
        bail!("{flag} {shown}: cannot write into the folder ({e}); give a folder you can write into");
    }
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// On Ctrl-C (SIGINT, or SIGTERM as Slurm sends it), says how many results the cache `dir`
/// holds and that running the same command again resumes from them, then exits with 130. The
/// cache is never left half-written: each result is renamed into place once complete.
pub fn on_interrupt(dir: Option<PathBuf>) {
    let handler = move || {
        let stored = crate::run::sweep::cache::STORED.load(std::sync::atomic::Ordering::Relaxed);
        let line = match &dir {
            Some(d) => {
                let files = std::fs::read_dir(d).map_or(0, |e| {
                    e.flatten().filter(|f| f.path().extension().is_some_and(|x| x == "json")).count()
                });
                format!(
                    "interrupted: {stored} result(s) stored by this run, {files} file(s) in the cache {}; run the \
                     same command again to resume from them",
                    d.display()
                )
            }
            None => "interrupted: --no-cache, so nothing was kept; a re-run starts over".to_string(),
        };
        eprintln!("\n{line}");
        std::process::exit(130);
    };
    // A second handler (a test calling this twice) is refused; the first stays.
    let _ = ctrlc::set_handler(handler);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_billion_samples_are_refused_with_the_estimate_and_force_overrides() {
        let opts = WorkloadOpts {
            width: 128,
            height: 128,
            spp: 1_000_000_000,
            max_bounces: 15,
            ..Default::default()
        };
        let e = Estimate::new(&opts, 20_000, 3, 2, Fidelity::Cycle);
        let err = e.check(Some(16 << 30), false).unwrap_err().to_string();
        assert!(err.starts_with("estimated at most 2.6 × 10^14 rays") && err.contains("--force"), "{err}");
        assert!(e.check(Some(16 << 30), true).is_ok());
        let lumibench =
            WorkloadOpts { width: 128, height: 128, spp: 2, max_bounces: 15, ..Default::default() };
        let e = Estimate::new(&lumibench, 20_000, 3, 2, Fidelity::Cycle);
        assert!(e.check(Some(4 << 30), false).is_ok(), "{}", e.describe());
        assert!(e.check(None, false).is_ok());
    }

    /// The estimate stays above what runs measured (docs/experiments.md), scene included: the
    /// forest's 2.7 M triangles at 32×32 pixels took 419 MB and 3.3 s, the 6.9 M-triangle gallery
    /// 471 MB, clutter at LumiBench's settings 24 MB and 6.8 s (two configurations, two jobs).
    #[test]
    fn the_estimate_covers_measured_runs() {
        let at = |res: u32| WorkloadOpts {
            width: res,
            height: res,
            spp: 2,
            max_bounces: 15,
            ..Default::default()
        };
        for (primitives, res, bytes, secs) in
            [(2_724_530, 32, 419e6, 3.3), (6_923_978, 32, 471e6, 1.4), (20_000, 128, 24e6, 6.8)]
        {
            let e = Estimate::new(&at(res), primitives, 2, 2, Fidelity::Cycle);
            assert!(e.bytes >= bytes && e.secs >= secs, "{primitives}: {}", e.describe());
            // Not wildly above either: within 4× on memory for the large scenes.
            assert!(primitives < 1_000_000 || e.bytes < 4.0 * bytes, "{primitives}: {}", e.describe());
        }
    }

    #[test]
    fn large_estimates_read_as_plain_numbers() {
        const YEAR: f64 = 3600.0 * 24.0 * 365.0;
        assert_eq!(duration(1.2 * YEAR), "1.2 years");
        assert_eq!(duration(1400.0 * YEAR), "1,400 years");
        assert_eq!(duration(3.0e15 * YEAR), "3.0 × 10^15 years");
        assert_eq!(duration(3.0 * 24.0 * 3600.0), "3 days");
        assert_eq!(duration(25.0 * 3600.0), "25.0 h");
        assert_eq!(bytes(4.588e15), "4,588 TB");
        assert_eq!(bytes(2.5e9), "2.5 GB");
        for s in [duration(1.2 * YEAR), duration(1e30), bytes(1e30)] {
            let exponent =
                s.as_bytes().windows(3).any(|w| w[0].is_ascii_digit() && w[1] == b'e' && w[2] != b' ');
            assert!(!exponent, "no exponent notation: {s}");
        }
    }

    #[test]
    fn an_output_folder_must_be_a_writable_folder() {
        let tmp = std::env::temp_dir().join(format!("sms-guard-out-{}", std::process::id()));
        let data = tmp.join("data");
        std::fs::create_dir_all(&data).unwrap();
        let file = tmp.join("file");
        std::fs::write(&file, b"x").unwrap();
        let e = output_folder("--out", &file, &data).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "--out {}: not a folder (a file has that name); give a folder to write into",
                file.display()
            )
        );
        let e = output_folder("--out", &file.join("sub"), &data).unwrap_err().to_string();
        assert!(e.starts_with("--out ") && e.contains("cannot create the folder"), "{e}");
        let e = output_folder("--out", &data.join("x"), &data).unwrap_err().to_string();
        assert!(e.contains("inside the scene data folder"), "{e}");
        output_folder("--out", &tmp.join("new/deep"), &data).unwrap();
        assert_eq!(std::fs::read_dir(tmp.join("new/deep")).unwrap().count(), 0, "the probe is removed");
        std::fs::remove_dir_all(&tmp).unwrap();
    }

    #[test]
    fn outputs_inside_the_scene_data_are_refused() {
        let data = std::env::temp_dir().join(format!("sms-guard-{}", std::process::id()));
        std::fs::create_dir_all(data.join("sub")).unwrap();
        let err = outside_scene_data("--vcd", &data.join("sub/new/x.vcd"), &data).unwrap_err().to_string();
        assert!(err.starts_with("--vcd ") && err.contains("inside the scene data folder"), "{err}");
        assert!(outside_scene_data("--vcd", &data.join("sub/../../x.vcd"), &data).is_ok());
        assert!(outside_scene_data("--vcd", Path::new("waves/x.vcd"), &data).is_ok());
        std::fs::remove_dir_all(&data).unwrap();
    }
}
