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
use crate::cli::{HardwareArgs, OutputArgs, SampleArgs, SceneArgs, WorkloadArgs};
use crate::report::table::Table;
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
    /// No progress output.
    #[arg(long, short)]
    pub quiet: bool,
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
    /// is written next to it). Inside the window every cycle is dumped; outside it idle cycles
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
}

#[derive(Serialize)]
struct RunReport<'a> {
    scene: &'a str,
    workload: WorkloadOpts,
    pixel_warps: u32,
    rays: u64,
    fidelity: Fidelity,
    results: Vec<ConfigResult>,
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

    let start = Instant::now();
    let scene = args.scenes.library().load(&args.scene)?;
    let opts = args.workload.opts(&scene);
    let log = |msg: String| {
        if !args.quiet {
            eprintln!("{msg}");
        }
    };
    log(format!("loaded {} ({} primitives) in {:.2} s", scene.name, scene.primitives.len(), secs(start)));
    let start = Instant::now();
    let w = Workload::new(&scene, opts)?;
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
    let jobs = args.jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    if jobs == 0 {
        bail!("--jobs 0: at least one worker is needed");
    }
    let names: Vec<String> = specs.iter().map(|s| s.config.name()).collect();
    let bar = ProgressLines::new(&names, args.quiet);
    let results = crate::run::pool::map_indexed(jobs.min(specs.len()), specs.len(), |i| {
        let r = run_one(&specs[i], &w, plan.as_ref(), vcd.as_ref(), |t| bar.tick(i, t));
        bar.done(i);
        r
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
    };
    match args.output.table(&table(&report)) {
        Some(text) => print!("{text}"),
        None => println!("{}", serde_json::to_string_pretty(&report)?),
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
    if rs.iter().any(|r| simulated(r).is_some_and(|o| o.gpu.is_some())) {
        let rate = |x: f64| format!("{:.1} %", 100.0 * x);
        row("L1D hit rate", full(&|o| o.gpu.map_or("-".into(), |g| rate(g.l1d_hit_rate))));
        row("L2 hit rate", full(&|o| o.gpu.map_or("-".into(), |g| rate(g.l2_hit_rate))));
        row(
            "warp jobs (traceRay calls) simulated",
            full(&|o| o.gpu.map_or("-".into(), |g| g.warp_jobs.to_string())),
        );
    }
    row("pops checked against the trace", full(&|o| o.pops_checked.to_string()));
    row(
        "wall time",
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
) -> anyhow::Result<ConfigResult> {
    let config = spec.config.name();
    Ok(match (plan, vcd) {
        (Some(p), _) => {
            ConfigResult { config, full: None, sampled: Some(simulate_sampled(spec, w, p, tick)?) }
        }
        (None, Some(v)) => {
            let mut sink = VcdSink::create(v, &spec.config)?;
            let o = simulate(spec, w, None, &mut sink, &mut tick)?;
            sink.finish()?;
            ConfigResult { config, full: Some(o), sampled: None }
        }
        (None, None) => {
            ConfigResult { config, full: Some(simulate(spec, w, None, &mut NullSink, tick)?), sampled: None }
        }
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

    fn done(&self, i: usize) {
        if self.quiet {
            return;
        }
        let mut st = self.state.lock().unwrap_or_else(|e| e.into_inner());
        st.1[i] = None;
        if self.tty {
            eprint!("\r\x1b[K");
        }
        eprintln!("{}: done at {:.2} s", self.names[i], secs(self.start));
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
        let argv = std::iter::once("run").chain(line.split_whitespace());
        super::run(Cli::try_parse_from(argv)?.args)
    }

    fn error(line: &str) -> String {
        format!("{:#}", run(line).expect_err(line))
    }

    #[test]
    fn bad_requests_are_clear_errors() {
        let tiny = "-q --scene wknd --res 8x8 --spp 1 --bounces 0";
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
        assert!(error("-q --scene no-such-scene").contains("unknown scene"));
    }

    #[test]
    fn a_tiny_run_at_both_levels_and_sampled_succeeds() {
        let tiny = "-q --scene clutter --res 16x16 --spp 1 --bounces 1 -c RB_4,RB_4+SH_4+SK+RA --json";
        run(tiny).unwrap();
        run(&format!("{tiny} --fidelity functional")).unwrap();
        run(&format!("{tiny} --sample 0.5 --batches 2")).unwrap();
    }
}
