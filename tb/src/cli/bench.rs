//! `sms bench`: run time against error of every level and sample rate, the model's throughput
//! against a plain traversal, and the savings of skipping unneeded work, on the built-in scenes
//! by default. Prints the report (text, Markdown, CSV or JSON) and writes it in every format with
//! an SVG plot.

use std::path::PathBuf;
use std::time::Instant;

use crate::cli::stack_config::StackConfigArgs;
use crate::cli::{Format, HardwareArgs, OutputArgs, SceneArgs, WorkloadArgs};
use crate::run::bench::data::Report;
use crate::run::bench::{bench_scene, BenchOpts};
use crate::run::sampling::SampleMode;

/// Resolution when `--res` is not given: the whole default run takes about a minute on one core.
pub const DEFAULT_RES: (u32, u32) = (64, 64);

/// Configurations when `--config` is not given.
pub const DEFAULT_CONFIGS: [&str; 3] = ["RB_8", "RB_8+SH_8+SK", "SMS"];

#[derive(Clone, Debug, clap::Args)]
pub struct Args {
    /// Scenes, comma-separated: names, or paths to meshes or TOML descriptions, as `sms run
    /// --scene` takes (default: the built-in ones).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    #[command(flatten)]
    pub stack: StackConfigArgs,
    /// Sample rates, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,0.5,0.25,0.1")]
    pub fractions: Vec<f64>,
    /// How sampled warps are drawn, comma-separated.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "random,tile")]
    pub modes: Vec<SampleMode>,
    /// Batches per sampled run (the confidence intervals' degrees of freedom + 1).
    #[arg(long, default_value_t = 8)]
    pub batches: u32,
    /// Seed of the warp sampler.
    #[arg(long, default_value_t = 1)]
    pub sample_seed: u64,
    /// Largest relative error a setting may make on a headline metric to qualify.
    #[arg(long, default_value_t = 0.01)]
    pub tolerance: f64,
    /// Bounces added for the "more bounces" comparison.
    #[arg(long, default_value_t = 2)]
    pub more_bounces: u32,
    /// Output folder.
    #[arg(long, default_value = "out/bench")]
    pub out: PathBuf,
    // What is printed (csv: one row per scene, configuration and setting, as bench.csv); the
    // folder gets every format.
    #[command(flatten)]
    pub output: OutputArgs,
    #[command(flatten)]
    pub workload: WorkloadArgs,
    #[command(flatten)]
    pub hardware: HardwareArgs,
    #[command(flatten)]
    pub scene_files: SceneArgs,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let start = Instant::now();
    crate::cli::guard::output_folder("--out", &args.out, &args.scene_files.library()?.data)?;
    args.stack.names_only("bench")?;
    let configs = args.stack.resolve(&DEFAULT_CONFIGS)?;
    if let Some(c) = configs.iter().find(|c| c.overflow == rtl::config::Overflow::Drop) {
        anyhow::bail!(
            "--config {}: a restart design runs at the cycle level only, and the bench measures both levels; \
             `sms run` or `sms sweep --designs restart` run it",
            c.name()
        );
    }
    let opts = BenchOpts {
        configs,
        fractions: args.fractions.clone(),
        modes: args.modes.clone(),
        batches: args.batches,
        sample_seed: args.sample_seed,
        hw: args.hardware.hardware()?,
        more_bounces: args.more_bounces,
    };
    let scenes: Vec<String> = if args.scenes.is_empty() {
        crate::workload::scene::procedural::NAMES.iter().map(|s| s.to_string()).collect()
    } else {
        args.scenes.clone()
    };
    let library = args.scene_files.library()?;
    let mut report = Report::default();
    for name in &scenes {
        let scene = library.load(name)?;
        let mut wopts = args.workload.opts(&scene);
        if args.workload.res.is_none() {
            (wopts.width, wopts.height) = DEFAULT_RES;
        }
        bench_scene(&scene, wopts, &opts, &mut report, &mut |line| crate::cli::note(line))?;
    }
    report.peak_rss = crate::run::memory::peak_rss_bytes();
    match args.output.format() {
        Format::Text => print!("{}", report.text(args.tolerance, false)),
        Format::Markdown => print!("{}", report.markdown(args.tolerance)),
        Format::Csv => print!("{}", report.rows_table().to_csv()),
        Format::Json => println!("{}", report.json(args.tolerance)?),
    }
    report.write(&args.out, args.tolerance)?;
    crate::cli::note(format!(
        "wrote {}/bench.{{txt,md,csv,json}}, summary/throughput/work/savings.csv and time-vs-error.svg; {:.1} s in all",
        args.out.display(),
        start.elapsed().as_secs_f64()
    ));
    Ok(())
}
