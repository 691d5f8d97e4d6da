//! VCD dumps of the whole GPU: a real-scene run of all SMs (RT units, stack managers, memory
//! system) dumped through [`VcdSink`] with a cycle window and SM/warp/lane filters is strictly
//! valid VCD, and the values replayed from it are the RTL's own, cycle by cycle, also after
//! GTKWave's `vcd2fst` → `fst2vcd` round trip. Bad requests are clear errors.

mod common;
use common::TmpDir;

use std::ops::RangeInclusive;
use std::path::Path;
use std::process::Command;

use rtl::config::Config;
use rtl::trace::Sink;
use tb::run::sim::{simulate, simulate_all, Fidelity, GpuCounts, Hardware, Outcome, RunSpec};
use tb::vcd::check::{compare, read, Mode, Recorder, Waves};
use tb::vcd::{Selection, Tee, VcdError, VcdOptions, VcdSink};
use tb::workload::{Workload, WorkloadOpts};

/// Cycles recorded and dumped: well inside the run, while both warp slots of every SM are busy.
const WINDOW: RangeInclusive<u64> = 2_000..=3_499;

/// Records the RTL's values only in `window`: a whole-GPU walk has ~20 000 signals, too many to
/// keep for every cycle of the run.
struct Windowed {
    window: RangeInclusive<u64>,
    on: bool,
    rec: Recorder,
}

impl Sink for Windowed {
    fn enabled(&self) -> bool {
        true
    }
    fn begin_cycle(&mut self, cycle: u64) {
        self.on = self.window.contains(&cycle);
        if self.on {
            self.rec.begin_cycle(cycle);
        }
    }
    fn push_scope(&mut self, name: &str) {
        if self.on {
            self.rec.push_scope(name);
        }
    }
    fn pop_scope(&mut self) {
        if self.on {
            self.rec.pop_scope();
        }
    }
    fn signal(&mut self, name: &str, width: u32, value: u64) {
        if self.on {
            self.rec.signal(name, width, value);
        }
    }
}

/// The full SMS on 8 SMs; ship at 16 × 16, one bounce: 16 warp jobs, two per SM.
fn spec() -> RunSpec {
    RunSpec { config: Config::sms(), hw: Hardware::default(), fidelity: Fidelity::Cycle }
}

fn ship_workload(scene: &tb::Scene, res: u32) -> Workload<'_> {
    Workload::new(scene, WorkloadOpts::quick(scene, res)).unwrap()
}

/// Runs ship through the GPU with a VCD sink writing `path` (and its save file) and a windowed
/// recorder side by side; returns the dump's text. `None` when ship's mesh is missing and the
/// test is skipped.
fn dump(path: &Path) -> Option<(String, Recorder, Outcome)> {
    let ship = tb::prereq::scene("ship")?;
    let w = ship_workload(&ship, 16);
    let spec = spec();
    let opts = VcdOptions { path: path.to_path_buf(), select: selection() };
    let mut vcd = VcdSink::create(&opts, &spec.config).unwrap();
    let mut rec = Windowed { window: WINDOW, on: false, rec: Recorder::default() };
    let out = simulate(&spec, &w, None, &mut Tee(&mut vcd, &mut rec), |_| {}).unwrap();
    vcd.finish().unwrap();
    Some((std::fs::read_to_string(path).unwrap(), rec.rec, out))
}

fn selection() -> Selection {
    Selection {
        from: Some(*WINDOW.start()),
        to: Some(*WINDOW.end()),
        warps: Some(vec![1]),
        lanes: Some(vec![0, 7, 31]),
        sms: Some(vec![0, 5]),
    }
}

/// Whether `path` is in [`selection`], decided from the path's scopes independently of
/// [`Selection::selects`]. A warp slot is `warp[w]` and a lane `thread[l]`, in the stack manager
/// and in the RT unit's warp buffer alike; SM `k` is `sm<k>` and its L1D `mem.l1d<k>`.
fn expected(path: &str) -> bool {
    let index = |prefix: &str, suffix: &str| -> Vec<u32> {
        path.split('.').filter_map(|s| s.strip_prefix(prefix)?.strip_suffix(suffix)?.parse().ok()).collect()
    };
    let warps = index("warp[", "]");
    let lanes = index("thread[", "]");
    [index("sm", ""), index("l1d", "")].concat().iter().all(|&k| k == 0 || k == 5)
        && warps.iter().all(|&w| w == 1)
        && lanes.iter().all(|l| [0, 7, 31].contains(l))
}

fn strict(text: &str) -> Waves {
    read(text.as_bytes(), Mode::Strict).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn gpu_dump_is_strictly_valid_and_replays_the_rtl_values() {
    let tmp = TmpDir::new("vcd-gpu", "dump");
    let Some((text, rec, out)) = dump(&tmp.join("gpu.vcd")) else { return };
    let g = out.gpu.unwrap();
    assert!(g.cycles > *WINDOW.end() + 1_000, "window must lie inside the run ({} cycles)", g.cycles);
    assert_eq!(g.warp_jobs, 16);
    assert_eq!(rec.cycles().len() as u64, WINDOW.end() - WINDOW.start() + 1, "every cycle is walked");
    // Probing changes nothing but the idle skipping it turns off: the same report as a run
    // without waves, every cycle evaluated.
    let ship = tb::load_scene("ship").unwrap();
    let quiet = simulate_all(&spec(), &ship_workload(&ship, 16)).unwrap();
    let q = quiet.gpu.unwrap();
    assert_eq!(g.evaluated_cycles, g.cycles);
    assert!(q.evaluated_cycles < q.cycles, "idle cycles are skipped without a sink");
    assert_eq!(GpuCounts { evaluated_cycles: 0, ..g }, GpuCounts { evaluated_cycles: 0, ..q });
    assert_eq!((out.stack, out.pops_checked), (quiet.stack, quiet.pops_checked));

    let waves = strict(&text);

    // Exactly the selected signals with a width, in walk order.
    let want: Vec<(&str, u32)> = rec.signals().filter(|&(p, w)| w > 0 && expected(p)).collect();
    let got: Vec<(&str, u32)> = waves.signals.iter().map(|(p, w)| (p.as_str(), *w)).collect();
    assert_eq!(got, want);
    let all = rec.signals().count();
    assert!(got.len() * 10 < all, "{} of {all} signals dumped: the filters did not apply", got.len());
    for scope in [
        "sm0.rt_unit.",
        "sm5.rt_unit.",
        "mem.",
        ".stack_manager.warp[1].thread[31].",
        ".warp_buffer.warp[1].thread[7].state",
        "mem.l1d5.",
    ] {
        assert!(got.iter().any(|s| s.0.contains(scope)), "nothing under {scope}");
    }
    for other in ["sm1.", ".warp[0].", ".warp_buffer.warp[0].", ".thread[1].", "mem.l1d1."] {
        assert!(!got.iter().any(|s| s.0.contains(other)), "{other} is not selected");
    }

    let times: Vec<u64> = waves.times().collect();
    assert_eq!(times.first(), Some(WINDOW.start()));
    assert_eq!(times.last(), Some(&(WINDOW.end() + 1)), "closing timestamp");
    let compared = compare(&waves, &rec, WINDOW).unwrap();
    assert_eq!(compared, rec.cycles().len() * got.len());
    // The window shows traversal, not a quiet machine: the selected threads' stacks move.
    let paths: Vec<&str> = rec.signals().map(|s| s.0).collect();
    let changes = |path: &str| {
        let i = paths.iter().position(|p| *p == path).unwrap();
        (1..rec.cycles().len()).filter(|&k| rec.walk(k)[i] != rec.walk(k - 1)[i]).count()
    };
    let moves: usize = got
        .iter()
        .filter(|s| s.0.contains(".stack_manager.warp[1].") && s.0.ends_with(".rb_count"))
        .map(|s| changes(s.0))
        .sum();
    assert!(moves > 10, "the selected stacks changed depth only {moves} times in the window");
    println!(
        "{} cycles; window {WINDOW:?}: {} of {all} signals, {} changes, {} bytes, {compared} values compared, {moves} RB depth changes of the selected threads",
        g.cycles,
        got.len(),
        waves.change_count(),
        text.len()
    );

    // The save file opens this dump and lists every dumped signal, in balanced groups.
    let save = std::fs::read_to_string(tmp.join("gpu.gtkw")).unwrap();
    assert!(save.contains("[dumpfile] \"gpu.vcd\"\n"), "{save:.300}");
    for (path, width) in &got {
        let trace = if *width == 1 { path.to_string() } else { format!("{path}[{}:0]", width - 1) };
        assert!(save.lines().any(|l| l == trace), "{trace} missing from the save file");
    }
    assert_eq!(save.lines().filter(|l| l.starts_with('-')).count() % 2, 0, "groups open and close");
    // Every translate filter the dump uses is written beside it and shipped in waves/.
    let filters: Vec<&str> =
        save.lines().filter_map(|l| l.strip_prefix('^')?.split_once(' ').map(|f| f.1)).collect();
    assert!(filters.iter().any(|f| f.ends_with("thread_state.filter")), "lane states by name");
    assert!(filters.iter().any(|f| f.ends_with("req_kind.filter")), "L1D request kinds by name");
    let waves = Path::new(env!("CARGO_MANIFEST_DIR")).join("../waves");
    for f in filters {
        let name = Path::new(f).file_name().unwrap();
        // Named beside the save file.
        assert_eq!(Path::new(f), Path::new(name), "{f} is not named by file name");
        assert_eq!(
            std::fs::read(tmp.join(f)).unwrap(),
            std::fs::read(waves.join(name)).unwrap(),
            "{f} not shipped"
        );
    }

    // The comparison can fail: one value flipped after the first timestamp is found.
    let second = text.match_indices("\n#").nth(1).unwrap().0;
    let (head, tail) = text.split_at(second);
    let line = tail.lines().find(|l| l.starts_with('b')).unwrap();
    let (bits, id) = line[1..].split_once(' ').unwrap();
    let flipped = format!("b{}{} {id}", &bits[..bits.len() - 1], if bits.ends_with('0') { '1' } else { '0' });
    let corrupted = format!("{head}{}", tail.replacen(line, &flipped, 1));
    let err = compare(&strict(&corrupted), &rec, WINDOW).unwrap_err();
    assert!(err.contains("in the dump"), "{err}");
}

#[test]
fn gtkwave_round_trip_keeps_the_gpu_values() {
    if !tb::prereq::tools(&["vcd2fst", "fst2vcd"], "GTKWave (apt-get install gtkwave)") {
        return;
    }
    let tmp = TmpDir::new("vcd-gpu", "round");
    let (vcd, fst) = (tmp.join("gpu.vcd"), tmp.join("gpu.fst"));
    let Some((text, rec, _)) = dump(&vcd) else { return };
    let status = Command::new("vcd2fst").arg(&vcd).arg(&fst).output().unwrap();
    assert!(status.status.success(), "vcd2fst: {}", String::from_utf8_lossy(&status.stderr));
    let out = Command::new("fst2vcd").arg(&fst).output().unwrap();
    assert!(out.status.success(), "fst2vcd: {}", String::from_utf8_lossy(&out.stderr));
    let back = read(out.stdout.as_slice(), Mode::Lenient).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.signals, strict(&text).signals);
    let compared = compare(&back, &rec, WINDOW).unwrap();
    assert_eq!(compared, rec.cycles().len() * back.signals.len());
}

fn create_err(select: Selection, path: &Path) -> String {
    let opts = VcdOptions { path: path.to_path_buf(), select };
    match VcdSink::create(&opts, &spec().config) {
        Ok(_) => panic!("{opts:?} accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_gpu_dump_requests_are_clear_errors() {
    let tmp = TmpDir::new("vcd-gpu", "errors");
    let path = tmp.join("bad.vcd");
    let warp = Selection { warps: Some(vec![4]), ..Selection::default() };
    assert_eq!(create_err(warp, &path), "VCD warp 4 does not exist: the configuration has 4 warps (0..4)");
    let lane = Selection { lanes: Some(vec![0, 32]), ..Selection::default() };
    assert_eq!(create_err(lane, &path), "VCD lane 32 does not exist: warps have 32 lanes (0..32)");
    let nowhere = tmp.join("missing-dir").join("x.vcd");
    let msg = create_err(Selection::default(), &nowhere);
    assert!(msg.starts_with(&format!("cannot write {}: ", nowhere.display())), "{msg}");
    let msg = create_err(Selection::default(), tmp.path());
    assert!(msg.starts_with(&format!("cannot write {}: ", tmp.path().display())), "a directory: {msg}");

    // The SM count is the hardware's, not the configuration's: an unknown SM is found on the
    // first probe walk and reported when the dump is finished, as is a window after the end of
    // the run (a small one here).
    let Some(ship) = tb::prereq::scene("ship") else { return };
    let w = ship_workload(&ship, 8);
    let opts = VcdOptions {
        path: path.clone(),
        select: Selection { sms: Some(vec![3, 8]), ..Selection::default() },
    };
    let mut sink = VcdSink::create(&opts, &spec().config).unwrap();
    simulate(&spec(), &w, None, &mut sink, |_| {}).unwrap();
    let err = sink.finish().unwrap_err();
    assert_eq!(err.to_string(), "VCD SM 8 does not exist: the run has 8 SMs (0..8)");
    let late = Selection { from: Some(10_000_000), to: Some(10_000_100), ..Selection::default() };
    let opts = VcdOptions { path: path.clone(), select: late };
    let mut sink = VcdSink::create(&opts, &spec().config).unwrap();
    let cycles = simulate(&spec(), &w, None, &mut sink, |_| {}).unwrap().gpu.unwrap().cycles;
    let err = sink.finish().unwrap_err();
    assert!(matches!(err, VcdError::OutsideRun { .. }), "{err:?}");
    assert_eq!(
        err.to_string(),
        format!("VCD window [10000000,10000100] is outside the run (0..{cycles} cycles)")
    );
}
