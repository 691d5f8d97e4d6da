//! `sms run`: one scene under one or more stack configurations, at the cycle or functional level,
//! optionally sampled, optionally dumping waveforms. Prints one column per configuration (the
//! first is the baseline the speed-ups refer to), or JSON with `--json`.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::bail;
use rtl::trace::NullSink;
use serde::Serialize;

use crate::cli::stack_config::StackConfigArgs;
use crate::cli::{guard, Format, HardwareArgs, OutputArgs, SampleArgs, SceneArgs, WorkloadArgs};
use crate::report::breakdown::{self, Shares};
use crate::report::table::Table;
use crate::run::provenance::{Provenance, WorkloadId};
use crate::run::sampling::SamplePlan;
use crate::run::sim::{simulate, simulate_sampled, Fidelity, Metric, Outcome, RunSpec, Sampled, Tick};
use crate::vcd::{Selection, VcdOptions, VcdSink};
use crate::workload::{Workload, WorkloadOpts};

#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    #[arg(long, default_value = "clutter", help = crate::cli::SCENE_HELP)]
    pub scene: String,
    #[command(flatten)]
    pub stack: StackConfigArgs,
    #[command(flatten)]
    pub workload: WorkloadArgs,
    #[command(flatten)]
    pub hardware: HardwareArgs,
    /// cycle: clocked RT units, stack managers and memory hierarchy; functional: stack traffic
    /// counted from the traces, no timing (fastest).
    #[arg(long, value_enum, default_value = "cycle")]
    pub fidelity: Fidelity,
    #[command(flatten)]
    pub sampling: SampleArgs,
    #[command(flatten)]
    pub output: OutputArgs,
    /// Also write the rendered image here (PNG).
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
    /// Run even when the estimate of rays, memory and time is above the limits (half the
    /// available memory, 24 h).
    #[arg(long)]
    pub force: bool,
    /// Configurations simulated at once (default: the available cores). A run simulated alone
    /// (one configuration, or --jobs 1) uses a second core for itself: it traces its rays and
    /// steps its RT units on two more threads. The results are the same either way.
    #[arg(long)]
    pub jobs: Option<usize>,
    #[command(flatten)]
    pub vcd: VcdArgs,
    #[command(flatten)]
    pub scenes: SceneArgs,
}

/// Waveform dump of a cycle-level run (one configuration, no sampling).
#[derive(Clone, Debug, Default, clap::Args)]
pub struct VcdArgs {
    /// Dump every selected register and per-cycle signal to this VCD file (a GTKWave save file
    /// is written next to it; a relative path is relative to the current folder, e.g.
    /// waves/run.vcd; never inside the scene data folder). Inside the window every cycle is dumped; outside it idle cycles
    /// are skipped as usual.
    #[arg(long, value_name = "FILE")]
    pub vcd: Option<PathBuf>,
    /// First cycle dumped.
    #[arg(long, value_name = "CYCLE", requires = "vcd")]
    pub vcd_from: Option<u64>,
    /// Last cycle dumped (inclusive).
    #[arg(long, value_name = "CYCLE", requires = "vcd")]
    pub vcd_to: Option<u64>,
    /// SMs dumped, e.g. 0 or 0,3 (default all).
    #[arg(long, value_delimiter = ',', requires = "vcd")]
    pub vcd_sms: Option<Vec<u32>>,
    /// Warp slots dumped (default all).
    #[arg(long, value_delimiter = ',', requires = "vcd")]
    pub vcd_warps: Option<Vec<u32>>,
    /// Lanes dumped (default all).
    #[arg(long, value_delimiter = ',', requires = "vcd")]
    pub vcd_lanes: Option<Vec<u32>>,
}

impl VcdArgs {
    fn options(&self) -> Option<VcdOptions> {
        Some(VcdOptions {
            path: self.vcd.clone()?,
            select: Selection {
                from: self.vcd_from,
                to: self.vcd_to,
                warps: self.vcd_warps.clone(),
                lanes: self.vcd_lanes.clone(),
                sms: self.vcd_sms.clone(),
            },
        })
    }
}

/// One configuration's result.
#[derive(Serialize)]
struct ConfigResult {
    config: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    full: Option<Outcome>,
    #[serde(skip_serializing_if = "Option::is_none")]
    sampled: Option<Sampled>,
    /// Averages per ray of what was simulated.
    per_ray: PerRay,
    /// Shares of the RT units' thread-cycles of what was simulated (a sample: its warps'
    /// launch); `null` at the functional level.
    thread_cycles: Option<Shares>,
    /// Seconds from the start of the simulations to this configuration's end (its `wall` is
    /// how long it took).
    #[serde(serialize_with = "crate::run::sim::serialize_secs")]
    finished_at: Duration,
}

/// Averages per ray of a simulation (`None`: not measured at its fidelity).
#[derive(Clone, Copy, Debug, Default, Serialize)]
struct PerRay {
    cycles: Option<f64>,
    node_fetches: Option<f64>,
    /// Pushes and pops.
    stack_ops: Option<f64>,
    /// Requests leaving the SMs for L2 (node fetches and stack traffic).
    offchip: Option<f64>,
}

impl PerRay {
    /// Of what `o` simulated; `rays` when the GPU did not count them (the functional level).
    fn of(o: &Outcome, rays: u64) -> PerRay {
        let rays = o.gpu.map_or(rays, |g| g.rays);
        if rays == 0 {
            return PerRay::default();
        }
        let per = |x: u64| x as f64 / rays as f64;
        PerRay {
            cycles: o.gpu.map(|g| per(g.cycles)),
            node_fetches: o.gpu.map(|g| per(g.node_fetches)),
            stack_ops: Some(per(o.stack.pushes + o.stack.pops)),
            offchip: o.gpu.map(|g| per(g.offchip_node + g.offchip_stack)),
        }
    }
}

#[derive(Serialize)]
struct RunReport<'a> {
    scene: &'a str,
    workload: WorkloadOpts,
    pixel_warps: u32,
    rays: u64,
    fidelity: Fidelity,
    results: Vec<ConfigResult>,
    provenance: Provenance,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let configs = args.stack.resolve(&["RB_8", "RB_16", "SMS"])?;
    let hw = args.hardware.hardware()?;
    let plan = args.sampling.plan(args.workload.seed)?;
    let vcd = args.vcd.options();
    if let Some(v) = &vcd {
        if configs.len() != 1 {
            bail!("--vcd dumps one configuration; {} were given", configs.len());
        }
        if args.fidelity != Fidelity::Cycle || plan.is_some() {
            bail!("--vcd needs a full cycle-level run (no --sample, --fidelity cycle)");
        }
        if let Some(&sm) = v.select.sms.iter().flatten().find(|&&s| s >= hw.mem.sms) {
            bail!("--vcd-sms {sm}: the GPU has {} SMs (0..{})", hw.mem.sms, hw.mem.sms);
        }
        v.select.validate(&configs[0])?;
    }
    let specs: Vec<RunSpec> =
        configs.iter().map(|&config| RunSpec { config, hw, fidelity: args.fidelity }).collect();
    for s in &specs {
        s.validate()?;
    }
    let settings = args.workload.settings_for(&configs)?;

    let library = args.scenes.library()?;
    for (flag, path) in [("--vcd", vcd.as_ref().map(|v| &v.path)), ("--png", args.png.as_ref())] {
        if let Some(path) = path {
            guard::outside_scene_data(flag, path, &library.data)?;
            if flag == "--vcd" {
                guard::outside_scene_data(flag, &path.with_extension("gtkw"), &library.data)?;
            }
        }
    }
    let jobs = args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if jobs == 0 {
        bail!("--jobs 0: at least one worker is needed");
    }

    let start = Instant::now();
    let scene = library.load(&args.scene)?;
    let opts = settings.opts(&scene);
    let log = crate::cli::note;
    log(format!("loaded {} ({} primitives) in {:.2} s", scene.name, scene.primitives.len(), secs(start)));
    let estimate = guard::Estimate::new(&opts, scene.primitives.len(), specs.len(), jobs, args.fidelity);
    estimate.check(guard::available_memory(), args.force)?;
    log(format!("estimated {}", estimate.describe()));
    let start = Instant::now();
    let w = Workload::with_progress(&scene, opts, crate::cli::phase_progress("path-tracing"))?;
    log(format!(
        "built {:?} {:?} ({} nodes) and path-traced {}x{} x {} spp, ≤ {} bounces: {} rays in {} pixel warps, {:.2} s",
        opts.accel,
        opts.bvh,
        w.bvh().node_count(),
        opts.width,
        opts.height,
        opts.spp,
        opts.max_bounces,
        w.num_rays(),
        w.num_warps(),
        secs(start)
    ));
    if let Some(png) = &args.png {
        w.image().write_png(png)?;
        log(format!("wrote {}", png.display()));
    }

    // Configurations run in parallel (one thread each, up to --jobs); results keep their order.
    let names: Vec<String> = specs.iter().map(|s| s.config.name()).collect();
    let bar = ProgressLines::new(&names, crate::cli::quiet());
    let rays = w.num_rays();
    let results = crate::run::pool::map_indexed(jobs.min(specs.len()), specs.len(), |i| {
        let r = run_one(&specs[i], &w, plan.as_ref(), vcd.as_ref(), |t| bar.tick(i, t));
        let finished_at = bar.done(i);
        r.map(|(full, sampled)| {
            let simulated = full.or(sampled.as_ref().and_then(|s| s.launch));
            let per_ray = simulated.map_or(PerRay::default(), |o| PerRay::of(&o, rays));
            let thread_cycles = simulated.as_ref().and_then(breakdown::of).as_ref().and_then(Shares::of);
            ConfigResult {
                config: specs[i].config.name(),
                full,
                sampled,
                per_ray,
                thread_cycles,
                finished_at,
            }
        })
    })
    .into_iter()
    .collect::<anyhow::Result<Vec<ConfigResult>>>()?;
    if let Some(v) = &vcd {
        log(format!("wrote {} and {}", v.path.display(), v.path.with_extension("gtkw").display()));
    }

    let report = RunReport {
        scene: &scene.name,
        workload: opts,
        pixel_warps: w.num_warps(),
        rays: w.num_rays(),
        fidelity: args.fidelity,
        results,
        provenance: Provenance::new(
            Some(WorkloadId::new(vec![scene.name.clone()], &[opts]).with_files([&scene.files[..]])),
            Some(args.hardware.id(&hw)),
        ),
    };
    let p = &report.provenance;
    match args.output.format() {
        Format::Text => print!("{}{}", p.text(), table(&report).to_text()),
        Format::Markdown => print!("{}{}", p.markdown(), table(&report).to_markdown()),
        Format::Csv => print!("{}{}", p.csv(), table(&report).to_csv()),
        Format::Json => println!("{}", serde_json::to_string_pretty(&report)?),
    }
    Ok(())
}

fn secs(t: Instant) -> f64 {
    t.elapsed().as_secs_f64()
}

/// One value per configuration: the full run's, or the estimate with its 95 % half width.
fn cell(r: &ConfigResult, m: Metric) -> Option<(f64, Option<f64>)> {
    match (&r.full, &r.sampled) {
        (Some(o), _) => Some((m.of(o)?, None)),
        (None, Some(s)) => s.get(m).map(|e| (e.value, Some(e.half_width))),
        (None, None) => None,
    }
}

fn fmt_value(v: Option<(f64, Option<f64>)>) -> String {
    match v {
        None => "-".into(),
        Some((x, None)) => format!("{x:.0}"),
        Some((x, Some(h))) => format!("{x:.0} ± {h:.0}"),
    }
}

fn table(report: &RunReport) -> Table {
    let rs = &report.results;
    let mut t = Table::new(std::iter::once("metric".to_string()).chain(rs.iter().map(|r| r.config.clone())));
    let mut row = |label: &str, cells: Vec<String>| t.row(std::iter::once(label.to_string()).chain(cells));
    let metric_row = |m: Metric| rs.iter().map(|r| fmt_value(cell(r, m))).collect::<Vec<_>>();
    if rs.iter().any(|r| cell(r, Metric::Cycles).is_some()) {
        row("cycles", metric_row(Metric::Cycles));
    }
    // A speed-up needs something to be faster than: no row for one configuration.
    if rs.len() > 1 && rs.iter().any(|r| cell(r, Metric::Cycles).is_some()) {
        let base = cell(&rs[0], Metric::Cycles).map(|c| c.0);
        row(
            &format!("speed-up over {}", rs[0].config),
            rs.iter()
                .map(|r| match (base, cell(r, Metric::Cycles)) {
                    (Some(b), Some((c, _))) if c > 0.0 => format!("{:.3}", b / c),
                    _ => "-".into(),
                })
                .collect(),
        );
    }
    let labelled = [
        (Metric::Offchip, "off-chip accesses (SM → L2 requests)"),
        (Metric::OffchipNode, "  of which node fetches"),
        (Metric::OffchipStack, "  of which stack traffic"),
        (Metric::DramNode, "DRAM accesses: node fetches"),
        (Metric::DramStack, "DRAM accesses: stack traffic"),
        (Metric::StackGlobal, "stack entries to/from global memory"),
        (Metric::ShSpills, "RB → SH spills"),
        (Metric::ShToGlobal, "SH → global spills"),
        (Metric::GlobalToSh, "global → SH reloads"),
        (Metric::Borrows, "SH stacks borrowed"),
        (Metric::Flushes, "flushes"),
        (Metric::ConflictCycles, "bank-conflict delay cycles"),
    ];
    for (m, label) in labelled {
        if rs.iter().any(|r| cell(r, m).is_some()) {
            row(label, metric_row(m));
        }
    }
    // What was simulated: the full run, or a cycle-level sample's one launch.
    let simulated = |r: &ConfigResult| r.full.or(r.sampled.as_ref().and_then(|s| s.launch));
    let full = |f: &dyn Fn(&Outcome) -> String| {
        rs.iter().map(|r| simulated(r).map_or("-".into(), |o| f(&o))).collect()
    };
    // The restart designs' own counts: only in a run that has one.
    if rs.iter().any(|r| simulated(r).is_some_and(|o| o.stack.drops + o.stack.restarts > 0)) {
        row("entries dropped (+RT)", full(&|o| o.stack.drops.to_string()));
        row("restarts from the root (+RT)", full(&|o| o.stack.restarts.to_string()));
    }
    if rs.iter().any(|r| simulated(r).is_some_and(|o| o.gpu.is_some())) {
        let rate = |x: f64| format!("{:.1} %", 100.0 * x);
        row("L1D hit rate", full(&|o| o.gpu.map_or("-".into(), |g| rate(g.l1d_hit_rate))));
        row("L2 hit rate", full(&|o| o.gpu.map_or("-".into(), |g| rate(g.l2_hit_rate))));
        row(
            "warp jobs (traceRay calls) simulated",
            full(&|o| o.gpu.map_or("-".into(), |g| g.warp_jobs.to_string())),
        );
    }
    // Where the thread-cycles went, as shares; a sample's are those of its warps' launch.
    let sampled = rs.iter().any(|r| r.full.is_none() && r.sampled.is_some());
    let of = if sampled { " (sampled warps)" } else { "" };
    if rs.iter().any(|r| r.thread_cycles.is_some()) {
        for (i, label) in breakdown::LABELS.iter().enumerate() {
            let share = |r: &ConfigResult| {
                r.thread_cycles.map_or("-".into(), |s| format!("{:.1} %", 100.0 * s.values()[i]))
            };
            row(&format!("thread-cycles: {label}{of}"), rs.iter().map(share).collect());
        }
    } else {
        row("thread-cycles", rs.iter().map(|_| "n/a (functional)".to_string()).collect());
    }
    /// A per-ray figure of a result.
    type PerRayField<'f> = &'f dyn Fn(&PerRay) -> Option<f64>;
    let per_ray = |f: PerRayField, digits: usize| -> Vec<String> {
        rs.iter().map(|r| f(&r.per_ray).map_or("-".into(), |x| format!("{x:.digits$}"))).collect()
    };
    let per_ray_rows: [(&str, PerRayField, usize); 4] = [
        ("per ray: cycles", &|p| p.cycles, 2),
        ("per ray: node fetches", &|p| p.node_fetches, 2),
        ("per ray: stack operations", &|p| p.stack_ops, 2),
        ("per ray: off-chip accesses", &|p| p.offchip, 3),
    ];
    for (label, f, digits) in per_ray_rows {
        if rs.iter().any(|r| f(&r.per_ray).is_some()) {
            row(label, per_ray(f, digits));
        }
    }
    row("pops checked against the trace", full(&|o| o.pops_checked.to_string()));
    // The decision scoreboard (`--decisions`) runs beside cycle-level simulations only.
    let decisions = match crate::run::sim::decisions_checked() {
        0 => "off".to_string(),
        1 => "every cycle".to_string(),
        n => format!("1 cycle in {n}"),
    };
    if rs.iter().any(|r| simulated(r).is_some_and(|o| o.gpu.is_some())) {
        row(
            "stack decisions checked against the spec",
            full(&|o| o.gpu.map_or("-".into(), |_| decisions.clone())),
        );
    }
    row(
        "finished at (since the simulations started)",
        rs.iter().map(|r| format!("{:.2} s", r.finished_at.as_secs_f64())).collect(),
    );
    row(
        "wall time (this configuration's simulation)",
        rs.iter()
            .map(|r| {
                let wall = r.full.as_ref().map(|o| o.wall).or(r.sampled.as_ref().map(|s| s.wall));
                wall.map_or("-".into(), |d| format!("{:.2} s", d.as_secs_f64()))
            })
            .collect(),
    );
    t
}

/// One configuration, full or sampled, with or without waves.
fn run_one(
    spec: &RunSpec,
    w: &Workload,
    plan: Option<&SamplePlan>,
    vcd: Option<&VcdOptions>,
    mut tick: impl FnMut(Tick),
) -> anyhow::Result<(Option<Outcome>, Option<Sampled>)> {
    Ok(match (plan, vcd) {
        (Some(p), _) => (None, Some(simulate_sampled(spec, w, p, tick)?)),
        (None, Some(v)) => {
            let mut sink = VcdSink::create(v, &spec.config)?;
            let o = simulate(spec, w, None, &mut sink, &mut tick)?;
            sink.finish()?;
            (Some(o), None)
        }
        (None, None) => (Some(simulate(spec, w, None, &mut NullSink, tick)?), None),
    })
}

/// Progress of the configurations running at once, as one line on stderr: rewritten in place
/// on a terminal, a line every few seconds otherwise; a line per finished configuration.
struct ProgressLines<'a> {
    names: &'a [String],
    quiet: bool,
    tty: bool,
    start: Instant,
    state: std::sync::Mutex<(Instant, Vec<Option<Tick>>)>,
}

impl<'a> ProgressLines<'a> {
    fn new(names: &'a [String], quiet: bool) -> Self {
        let now = Instant::now();
        ProgressLines {
            names,
            quiet,
            tty: std::io::stderr().is_terminal(),
            start: now,
            state: std::sync::Mutex::new((now, vec![None; names.len()])),
        }
    }

    fn tick(&self, i: usize, t: Tick) {
        if self.quiet {
            return;
        }
        let every = if self.tty { Duration::from_millis(200) } else { Duration::from_secs(5) };
        let mut st = self.state.lock().unwrap_or_else(|e| e.into_inner());
        st.1[i] = Some(t);
        if st.0.elapsed() < every {
            return;
        }
        st.0 = Instant::now();
        let parts: Vec<String> =
            st.1.iter()
                .zip(self.names)
                .filter_map(|(t, n)| {
                    let t = t.as_ref()?;
                    Some(format!("{n}: warps {}/{}, cycle {}", t.pixel_warps_done, t.pixel_warps, t.cycle))
                })
                .collect();
        let line = format!("{} · {:.1} s", parts.join(" · "), secs(self.start));
        if self.tty {
            eprint!("\r{line}\x1b[K");
        } else {
            eprintln!("{line}");
        }
    }

    /// Marks configuration `i` done; returns when, since the bar started.
    fn done(&self, i: usize) -> Duration {
        let at = self.start.elapsed();
        if self.quiet {
            return at;
        }
        let mut st = self.state.lock().unwrap_or_else(|e| e.into_inner());
        st.1[i] = None;
        if self.tty {
            eprint!("\r\x1b[K");
        }
        eprintln!("{}: done at {:.2} s", self.names[i], at.as_secs_f64());
        at
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        args: super::Args,
    }

    fn run(line: &str) -> anyhow::Result<()> {
        crate::cli::set_quiet(true);
        let argv = std::iter::once("run").chain(line.split_whitespace());
        super::run(Cli::try_parse_from(argv)?.args)
    }

    fn error(line: &str) -> String {
        format!("{:#}", run(line).expect_err(line))
    }

    #[test]
    fn bad_requests_are_clear_errors() {
        let tiny = "--scene wknd --res 8x8 --spp 1 --bounces 0";
        assert!(
            error(&format!("{tiny} -c RB_8,SMS --vcd /tmp/x.vcd")).contains("--vcd dumps one configuration")
        );
        assert!(
            error(&format!("{tiny} -c SMS --vcd /tmp/x.vcd --sample 0.5")).contains("full cycle-level run")
        );
        assert!(error(&format!("{tiny} --sample 1.5")).contains("sample fraction 1.5 must be in (0, 1]"));
        assert!(error(&format!("{tiny} -c RB_8+SH_32 --l1d-kb 32")).contains("the SH stacks need 32 KB"));
        assert!(error(&format!("{tiny} -c RB_9+SH_3")).contains("--config RB_9+SH_3"));
        assert!(error(&format!("{tiny} -c SMS --vcd /tmp/x.vcd --vcd-sms 8")).contains("the GPU has 8 SMs"));
        assert!(error(&format!("{tiny} --jobs 0")).contains("--jobs 0"));
        assert!(error("--scene no-such-scene").contains("unknown scene"));
    }

    #[test]
    fn a_tiny_run_at_both_levels_and_sampled_succeeds() {
        let tiny = "--scene clutter --res 16x16 --spp 1 --bounces 1 -c RB_4,RB_4+SH_4+SK+RA --json";
        run(tiny).unwrap();
        run(&format!("{tiny} --fidelity functional")).unwrap();
        run(&format!("{tiny} --sample 0.5 --batches 2")).unwrap();
    }
}
