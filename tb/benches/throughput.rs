//! `cargo bench -p tb --bench throughput`: throughput of the full cycle-level model on the
//! built-in `clutter` scene (simulated GPU cycles per second, stack operations per second) and
//! its run time against obvhs's own traversal of the same rays. A run traces its rays on a second
//! thread ahead of the simulation and runs its SMs by windows, split between itself and a helper
//! thread (`run::sim`, as any run with a core to spare), so each run's process CPU time (all its
//! threads) is printed beside
//! its wall time; the ratio to obvhs is of wall time. `-- --serial` keeps the model on one
//! thread. Each configuration runs [`PASSES`] times (the reports must agree) and the fastest
//! counts, as obvhs's time is the fastest of its passes; the slowest pass is printed too (this
//! virtual machine's speed swings by 15 % and more between runs).
//!
//! `-- --overhead` times only the SMS run with a `NullSink` (best of 3) and prints one
//! `overhead_run_seconds BUILD WALL CPU` line, for `scripts/trace-overhead.sh`, which compares
//! this build with one whose probe calls are compiled out (`--features untraced`). CPU is the
//! main thread's time on a CPU (Linux schedstat; the simulation, not the tracing thread), which
//! other processes' load disturbs far less than wall time; it is NaN where unavailable.
//!
//! `-- --once` runs the SMS configuration once and prints `once_run_cycles N` (the GPU cycles):
//! the run `scripts/instructions.sh` counts instructions of (with `--serial`: valgrind runs one
//! thread at a time, and a helper thread would spin).

use std::time::Duration;

use tb::run::bench::throughput;
use tb::run::sim::{simulate_all, Fidelity, Hardware, RunSpec};
use tb::workload::{Workload, WorkloadOpts};

const SCENE: &str = "clutter";
const RES: u32 = 64;
/// Runs of each configuration; the fastest is the one compared with obvhs.
const PASSES: usize = 3;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let overhead = std::env::args().any(|a| a == "--overhead");
    let once = std::env::args().any(|a| a == "--once");
    if std::env::args().any(|a| a == "--serial") {
        tb::run::sim::allow_helper_thread(false);
    }
    // `--decisions=all|sample|off`: the decision scoreboard, as `sms --decisions` sets it.
    if let Some(d) = std::env::args().find_map(|a| a.strip_prefix("--decisions=").map(str::to_string)) {
        tb::run::sim::check_decisions(match d.as_str() {
            "all" => 1,
            "sample" => tb::prove::scoreboard::SAMPLE_EVERY,
            "off" => 0,
            _ => return Err(format!("--decisions={d}: expected all, sample or off").into()),
        });
    }
    let scene = tb::load_scene(SCENE)?;
    let opts = WorkloadOpts { width: RES, height: RES, ..WorkloadOpts::for_scene(&scene) };
    let w = Workload::new(&scene, opts)?;
    let run = |name: &str| -> Result<_, Box<dyn std::error::Error>> {
        let spec = RunSpec { config: name.parse()?, hw: Hardware::default(), fidelity: Fidelity::Cycle };
        Ok((spec.config, simulate_all(&spec, &w)?))
    };
    let build = if cfg!(feature = "untraced") { "untraced" } else { "traced" };
    if once {
        let cycles = run("SMS")?.1.gpu.map_or(0, |g| g.cycles);
        println!("once_run_cycles {cycles}");
        return Ok(());
    }
    if overhead {
        let (mut wall, mut cpu) = (Duration::MAX, f64::INFINITY);
        for _ in 0..3 {
            let before = on_cpu_seconds();
            wall = wall.min(run("SMS")?.1.wall);
            cpu = cpu.min(on_cpu_seconds() - before);
        }
        println!("overhead_run_seconds {build} {:.4} {cpu:.4}", wall.as_secs_f64());
        return Ok(());
    }
    let two_threads = tb::run::sim::helper_thread();
    println!(
        "{SCENE} {RES}x{RES}, {} spp, {} bounces, {} rays ({build} build, model on {} thread{})",
        opts.spp,
        opts.max_bounces,
        w.num_rays(),
        if two_threads { 2 } else { 1 },
        if two_threads { "s" } else { "" },
    );
    // Process CPU of each run (its tracing and helper threads included), beside its wall time.
    let mut cpu = Vec::new();
    let mut runs = Vec::new();
    let mut slowest = Vec::new();
    for name in ["RB_8", "SMS"] {
        let mut best: Option<(_, tb::run::sim::Outcome, f64)> = None;
        let mut slow = Duration::ZERO;
        for _ in 0..PASSES {
            let before = tb::run::memory::process_cpu_seconds().unwrap_or(f64::NAN);
            let (config, o) = run(name)?;
            let spent = tb::run::memory::process_cpu_seconds().unwrap_or(f64::NAN) - before;
            slow = slow.max(o.wall);
            if let Some((_, b, _)) = &best {
                let same = |o: &tb::run::sim::Outcome| (o.gpu.map(|g| g.cycles), o.stack, o.pops_checked);
                if same(b) != same(&o) {
                    return Err(format!("{name}: two passes of one run disagree").into());
                }
            }
            if best.as_ref().is_none_or(|(_, b, _)| o.wall < b.wall) {
                best = Some((config, o, spent));
            }
        }
        let (config, o, spent) = best.expect("at least one pass");
        runs.push((config, o));
        cpu.push(spent);
        slowest.push(slow.as_secs_f64());
    }
    for ((t, cpu), slow) in throughput(&scene, &w, &runs)?.into_iter().zip(cpu).zip(slowest) {
        println!(
            "{:<16} {:>8} GPU cycles in {:.3} s (best of {PASSES}, slowest {slow:.3} s; CPU {cpu:.2} s, all \
             threads): {:>9.0} cycles/s, {:>9.0} stack ops/s; obvhs CWBVH {:.4} s, our BVH6 {:.4} s: \
             full model = {:.0}x obvhs",
            t.config,
            t.cycles,
            t.wall,
            t.cycles_per_sec(),
            t.stack_ops_per_sec(),
            t.obvhs_cwbvh,
            t.plain_bvh6,
            t.vs_obvhs()
        );
    }
    Ok(())
}

/// Seconds this thread has spent on a CPU (Linux), NaN elsewhere.
fn on_cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap_or_default();
    stat.split_whitespace().next().and_then(|ns| ns.parse::<f64>().ok()).map_or(f64::NAN, |ns| ns * 1e-9)
}
