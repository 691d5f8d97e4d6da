//! The `sms` subcommands, one module each: a clap `Args` struct and `run(args)`. The binary only
//! dispatches, so new subcommands are added here without touching the others.

pub mod ablate;
pub mod bench;
pub mod check;
pub mod cost;
pub mod depth;
pub mod guard;
pub mod prove;
pub mod run;
pub mod scenes;
pub mod stack_config;
pub mod steps;
pub mod sweep;
pub mod verilog;

use std::path::PathBuf;

use crate::workload::scene::SceneLibrary;

/// The `sms` command line.
#[derive(clap::Parser)]
// The name is the binary's, not the crate's (`tb`), so `sms --version` says `sms`.
#[command(name = "sms", version, about = "SMS traversal-stack model tools")]
pub struct Cli {
    /// No progress or status lines on stderr (reports and errors still print), for every
    /// subcommand.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// How cycle-level runs check the stack manager's decisions against the specification's
    /// cycle, beside the data checks every run makes (every pop against the trace, every warp
    /// at exit): sample (every 64th cycle, the default: about 5 % more instructions), all
    /// (every cycle: about 3.7 times the instructions), off. docs/verification.md has the
    /// measurement.
    #[arg(long, global = true, value_enum, default_value = "sample")]
    pub decisions: Decisions,
    #[command(subcommand)]
    pub command: Command,
}

/// `--decisions`: which cycles the decision scoreboard checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Decisions {
    All,
    Sample,
    Off,
}

/// `-q/--quiet`, set once by [`Cli::run`] for the whole process.
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether progress and status lines are suppressed (`-q`).
pub fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

/// Suppresses (or allows) progress and status lines, as `-q` does.
pub fn set_quiet(on: bool) {
    QUIET.store(on, std::sync::atomic::Ordering::Relaxed);
}

/// A progress or status line on stderr, unless `-q`.
pub fn note(line: impl std::fmt::Display) {
    if !quiet() {
        eprintln!("{line}");
    }
}

/// The subcommands.
#[derive(clap::Subcommand)]
pub enum Command {
    /// List the scenes with triangle counts, BVH node counts and build times.
    Scenes(scenes::Args),
    /// Stack-depth statistics of a scene.
    Depth(depth::Args),
    /// Traversal steps of the restart-trail walk with short stacks that drop their oldest entry
    /// (N entries each), against the full stack: steps, restarts and re-fetched nodes per ray,
    /// every ray's closest hit checked against the full-stack walk's.
    Steps(steps::Args),
    /// Hardware cost of stack designs, bit by bit, from the RTL's width definitions.
    Cost(cost::Args),
    /// Simulate a scene under stack configurations: cycles, off-chip traffic, conflicts.
    Run(run::Args),
    /// Exhaustive model checking of stack consistency: a bounded grid, the configurations named
    /// with -c, or --full: small configurations and the design's own sizes with few lanes active,
    /// to the fixpoint.
    Check(check::Args),
    /// SMT proofs (z3, boolector; cvc5 selectable) at a named configuration that the stack
    /// manager's decision logic, the code the simulator runs, equals the specification of SPEC
    /// sections 3 and 5 in one step, that every cycle keeps the well-formedness invariant, and that
    /// a push or pop moves every entry of the logical stack where the reference stack puts it.
    Prove(prove::Args),
    /// Run the paper's experiments over a scene set and write the report.
    Sweep(sweep::Args),
    /// Turn each simulator mechanism off in turn and report how the headline speed-ups move.
    Ablate(ablate::Args),
    /// Run time against error of each level and sample rate, throughput, savings of skipped work.
    Bench(bench::Args),
    /// Write the stack manager as synthesizable Verilog-2005, generated from the cycle
    /// description the simulator runs; --synth adds yosys's flip-flop, cell and depth report.
    /// Every configuration the RTL accepts is generated (RB_FULL, unbounded, is refused).
    Verilog(verilog::Args),
}

impl Cli {
    /// Runs the chosen subcommand.
    pub fn run(self) -> anyhow::Result<()> {
        set_quiet(self.quiet);
        crate::run::sim::check_decisions(match self.decisions {
            Decisions::All => 1,
            Decisions::Sample => crate::prove::scoreboard::SAMPLE_EVERY,
            Decisions::Off => 0,
        });
        match self.command {
            Command::Scenes(args) => scenes::run(args),
            Command::Depth(args) => depth::run(args),
            Command::Steps(args) => steps::run(args),
            Command::Cost(args) => cost::run(args),
            Command::Check(args) => check::run(args),
            Command::Run(args) => run::run(args),
            Command::Prove(args) => prove::run(args),
            Command::Sweep(args) => sweep::run(args),
            Command::Ablate(args) => ablate::run(args),
            Command::Bench(args) => bench::run(args),
            Command::Verilog(args) => verilog::run(args),
        }
    }
}

/// `--hw`'s long help: the presets, then every key of a description, from the registry.
fn hw_long_help() -> String {
    format!(
        "Hardware: a shipped preset — paper (default: the paper's text, the rest from Vulkan-Sim's MOBILE \
         config), vulkansim-mobile (that config file as it is), rtx2060, legacy (this model before it adopted \
         Vulkan-Sim's mechanisms) — or a TOML file applied to `paper`, with {}. The presets are in tb/hw/, \
         every key cited; docs/assumptions.md has each choice's sources.",
        crate::hw::key_list()
    )
}

/// A check that stopped at a cap before examining everything it was asked to, and found
/// nothing wrong on the way: not a proof, not a failure. `sms` prints it and exits with
/// [`EXIT_BOUNDED`], distinct from a failure's 1.
#[derive(Debug)]
pub struct Bounded(pub String);

impl std::fmt::Display for Bounded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Bounded {}

/// The exit status of a [`Bounded`] check.
pub const EXIT_BOUNDED: u8 = 2;

/// The process's command line, parsed; a value that must be text but is not UTF-8 is refused
/// with an error naming its argument (clap's own names none), like every other usage error
/// (exit status 2).
pub fn parse() -> Cli {
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    match <Cli as clap::Parser>::try_parse_from(&args) {
        Ok(cli) => cli,
        Err(e) if e.kind() == clap::error::ErrorKind::InvalidUtf8 => {
            eprintln!("error: {}", not_utf8(&args));
            std::process::exit(2)
        }
        Err(e) => e.exit(),
    }
}

/// Names the first argument whose value is not UTF-8 where the argument takes text (paths of
/// files sms writes may be any bytes; scene names, mesh paths and the like are text).
pub fn not_utf8(args: &[std::ffi::OsString]) -> String {
    use clap::CommandFactory;
    let mut cli = Cli::command();
    cli.build();
    let mut sub: Option<&clap::Command> = None;
    // The flag before the current token, when it takes a value.
    let mut pending: Option<&clap::Arg> = None;
    let mut positionals = 0;
    for token in args.iter().skip(1) {
        let cmd = sub.unwrap_or(&cli);
        let bytes = token.as_encoded_bytes();
        let (arg, value) = if let Some(arg) = pending.take() {
            (Some(arg), bytes)
        } else if let Some(rest) = bytes.strip_prefix(b"--") {
            let name_end = rest.iter().position(|&b| b == b'=').unwrap_or(rest.len());
            let name = std::str::from_utf8(&rest[..name_end]).unwrap_or_default();
            let arg = cmd.get_arguments().find(|a| a.get_long() == Some(name));
            if name_end == rest.len() {
                pending = arg.filter(|a| a.get_action().takes_values());
                continue;
            }
            (arg, &rest[name_end + 1..])
        } else if bytes.len() == 2 && bytes[0] == b'-' && bytes[1] != b'-' {
            let arg = cmd.get_arguments().find(|a| a.get_short() == Some(bytes[1] as char));
            pending = arg.filter(|a| a.get_action().takes_values());
            continue;
        } else {
            if sub.is_none() {
                if let Some(found) = token.to_str().and_then(|t| cli.find_subcommand(t)) {
                    sub = Some(found);
                    continue;
                }
            }
            let arg = cmd.get_positionals().nth(positionals);
            if arg.is_some_and(|a| matches!(a.get_action(), clap::ArgAction::Set)) {
                positionals += 1;
            }
            (arg, bytes)
        };
        if std::str::from_utf8(value).is_ok() {
            continue;
        }
        // Values clap takes as paths (files written) accept any bytes.
        let path = |a: &clap::Arg| {
            let t = a.get_value_parser().type_id();
            t == std::any::TypeId::of::<PathBuf>() || t == std::any::TypeId::of::<std::ffi::OsString>()
        };
        if arg.is_some_and(path) {
            continue;
        }
        let name = arg.map_or("an argument".to_string(), |a| match a.get_long() {
            Some(long) => format!("--{long}"),
            None => format!("<{}>", a.get_id().as_str().to_uppercase()),
        });
        return format!(
            "{name} '{}': not valid UTF-8; sms reads scene names, mesh and description paths and the other text \
             arguments as UTF-8 (rename the file, or link it under a UTF-8 name)",
            String::from_utf8_lossy(value)
        );
    }
    "an argument is not valid UTF-8; sms reads its text arguments as UTF-8".to_string()
}

/// Progress of a long phase on stderr unless `-q`: `what: done/total pixel warps` every 2 s
/// once the phase has run that long.
pub fn phase_progress(what: &'static str) -> impl FnMut(u32, u32) {
    let start = std::time::Instant::now();
    let mut last = start;
    move |done, total| {
        if quiet() || last.elapsed() < std::time::Duration::from_secs(2) {
            return;
        }
        last = std::time::Instant::now();
        eprintln!("{what}: {done}/{total} pixel warps, {:.0} s", start.elapsed().as_secs_f64());
    }
}

/// How a report is printed. The JSON layouts are documented in docs/json.md.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Aligned text tables.
    #[default]
    Text,
    Markdown,
    Csv,
    /// JSON (layout: docs/json.md in the source tree).
    Json,
}

/// The output format of a report printed on stdout, shared by the subcommands that print one.
#[derive(Clone, Copy, Debug, Default, clap::Args)]
pub struct OutputArgs {
    /// Output format: text, markdown, csv or json (JSON layout: docs/json.md).
    #[arg(long, value_enum, default_value = "text")]
    pub format: Format,
    /// Same as `--format json` (so not given with --format).
    #[arg(long, conflicts_with = "format")]
    pub json: bool,
}

impl OutputArgs {
    pub fn format(&self) -> Format {
        if self.json {
            Format::Json
        } else {
            self.format
        }
    }

    /// `table` in the text formats (`None` for JSON).
    pub fn table(&self, table: &crate::report::table::Table) -> Option<String> {
        match self.format() {
            Format::Text => Some(table.to_text()),
            Format::Markdown => Some(table.to_markdown()),
            Format::Csv => Some(table.to_csv()),
            Format::Json => None,
        }
    }
}

/// Where scene data are and how scenes are seen, shared by subcommands that load scenes.
#[derive(Clone, Debug, clap::Args)]
pub struct SceneArgs {
    /// Folder of the shared mesh files the shipped scene descriptions read [env: SMS_SCENES_DIR;
    /// default: the nearest shared/scenes folder in the current folder or a parent, else in the
    /// executable's folder or a parent]. Meshes and descriptions given by path do not need it.
    #[arg(long, value_name = "DIR")]
    pub scenes_dir: Option<PathBuf>,
    /// Camera position x,y,z, replacing the scene's (a mesh or description without a camera
    /// is framed from its bounds).
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::workload::scene::parse_vec3, allow_hyphen_values = true)]
    pub camera_eye: Option<[f32; 3]>,
    /// Point the camera looks at, x,y,z.
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::workload::scene::parse_vec3, allow_hyphen_values = true)]
    pub camera_look_at: Option<[f32; 3]>,
    /// Camera up vector x,y,z [default: the scene's; 0,1,0 for meshes].
    #[arg(long, value_name = "X,Y,Z", value_parser = crate::workload::scene::parse_vec3, allow_hyphen_values = true)]
    pub camera_up: Option<[f32; 3]>,
    /// Vertical field of view in degrees [default: the scene's; 45 for meshes].
    #[arg(long, value_name = "DEGREES")]
    pub vfov: Option<f32>,
}

impl SceneArgs {
    /// The scene library these arguments give; a data folder named by `--scenes-dir` or
    /// `SMS_SCENES_DIR` must be one.
    pub fn library(&self) -> anyhow::Result<SceneLibrary> {
        let mut library = match &self.scenes_dir {
            Some(dir) => SceneLibrary::with_data_dir(dir),
            None => SceneLibrary::default(),
        };
        let named = match library.origin {
            crate::workload::scene::DataOrigin::Flag => Some("--scenes-dir ".to_string()),
            crate::workload::scene::DataOrigin::Env => {
                Some(format!("{}=", crate::workload::scene::SCENES_DIR_ENV))
            }
            _ => None,
        };
        if let Some(named) = named.filter(|_| !library.data.is_dir()) {
            let what = if library.data.exists() { "not a folder" } else { "no such folder" };
            anyhow::bail!(
                "{named}{}: {what}; give the folder that holds the scene data (`sms scenes --fetch DIR` lays one out)",
                library.data.display()
            );
        }
        library.camera = crate::workload::scene::CameraOverride {
            eye: self.camera_eye,
            look_at: self.camera_look_at,
            up: self.camera_up,
            vfov: self.vfov,
        };
        Ok(library)
    }
}

/// Help text of every `--scene` flag.
pub const SCENE_HELP: &str =
    "Scene: a built-in or described name (`sms scenes` lists them), or a path to a mesh \
(.obj, .ply, .glb, .gltf, each optionally .gz; the camera frames it, see --camera-eye) or to a TOML scene \
description (its mesh paths relative to it; the format: `sms scenes --help`)";

/// What to trace: scene, hierarchy, child order, resolution, samples, bounces, path end, seed.
/// Shared by the subcommands that simulate a workload.
#[derive(Clone, Debug, clap::Args)]
pub struct WorkloadArgs {
    /// Hierarchy: bvh6 (Vulkan-Sim's 6-wide layout, 64-byte nodes), bvh2 or cwbvh (obvhs).
    #[arg(long, value_enum, default_value = "bvh6")]
    pub bvh: crate::workload::BvhKind,
    /// Child order: vulkansim (Vulkan-Sim's: hit children in index order, the first hit internal
    /// child descended, every other hit child pushed, leaves included) or nearest (the nearest
    /// hit child descended, the others pushed far to near) [default: vulkansim; nearest when a
    /// restart design (+RT) is among the configurations, for every configuration of the run].
    #[arg(long, value_enum)]
    pub order: Option<crate::workload::traverse::ChildOrder>,
    /// Acceleration structure: two-level (a TLAS over one BLAS per mesh, as the Vulkan pipeline
    /// builds it, one stack across both levels; bvh6 only) or flat (one BVH over every
    /// primitive, instances flattened) [default: two-level with bvh6, else flat; flat when a
    /// restart design (+RT) is among the configurations, for every configuration of the run].
    #[arg(long, value_enum)]
    pub accel: Option<crate::workload::Accel>,
    /// Resolution as WIDTHxHEIGHT (default: the scene's; LumiBench's 128x128 unless its
    /// description says otherwise).
    #[arg(long, value_parser = parse_res)]
    pub res: Option<(u32, u32)>,
    /// Samples per pixel (default: the scene's; LumiBench's 2).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Diffuse bounces after the primary ray (default: the scene's; LumiBench's 16 rays per
    /// path, i.e. 15).
    #[arg(long)]
    pub bounces: Option<u32>,
    /// When a hit ends a path besides a miss and the bounce limit: lumibench (a hit on a
    /// surface's back does not scatter, as LumiBench's Lambertian material) or always (every
    /// hit scatters, from either side). No Russian roulette either way.
    #[arg(long, value_enum, default_value = "lumibench")]
    pub path_end: crate::workload::PathEnd,
    /// Seed of the ray generator: the same seed gives bit-identical results.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

impl WorkloadArgs {
    /// The overrides of every scene's own render settings, for runs of no restart design.
    pub fn settings(&self) -> crate::run::sweep::Settings {
        self.settings_for(&[]).expect("without a restart design every order and structure is allowed")
    }

    /// The overrides of every scene's own render settings for a run of `configs`. A restart design
    /// (`+RT`) walks a flat BVH in nearest order (its trail records ranks in that order), so with
    /// one among them those are the defaults for every configuration (one workload, compared
    /// alike); asking for another is an error naming the flag.
    pub fn settings_for(
        &self,
        configs: &[rtl::config::Config],
    ) -> anyhow::Result<crate::run::sweep::Settings> {
        use crate::workload::traverse::ChildOrder;
        use crate::workload::Accel;
        let restart = configs.iter().find(|c| c.overflow == rtl::config::Overflow::Drop);
        let (order, accel) = match restart {
            None => (self.order.unwrap_or(ChildOrder::VulkanSim), self.accel),
            Some(c) => {
                if self.order == Some(ChildOrder::VulkanSim) {
                    anyhow::bail!(
                        "--order vulkansim: {} is a restart design, whose trail follows the nearest order; use \
                         --order nearest (the default with a restart design)",
                        c.name()
                    );
                }
                if self.accel == Some(Accel::TwoLevel) {
                    anyhow::bail!(
                        "--accel two-level: {} is a restart design, whose trail describes one flat BVH; use \
                         --accel flat (the default with a restart design)",
                        c.name()
                    );
                }
                (ChildOrder::Nearest, Some(Accel::Flat))
            }
        };
        Ok(crate::run::sweep::Settings {
            res: self.res,
            spp: self.spp,
            bounces: self.bounces,
            bvh: self.bvh,
            order,
            accel,
            path_end: self.path_end,
            seed: self.seed,
        })
    }

    /// `scene`'s own render settings with these arguments applied.
    pub fn opts(&self, scene: &crate::workload::scene::Scene) -> crate::workload::WorkloadOpts {
        self.settings().opts(scene)
    }
}

/// Sampling of pixel warps, shared by `sms run`, `sms sweep` and `sms ablate`.
#[derive(Clone, Debug, clap::Args)]
pub struct SampleArgs {
    /// Simulate this fraction (0 < f ≤ 1) of the pixel warps and estimate every metric of the
    /// whole frame with a 95 % confidence interval; 1 is every warp, the full run exactly (its
    /// report, no intervals). At the cycle level the sample is one launch
    /// and the intervals of cycles, DRAM and conflicts are indicative only: `sms bench` measures
    /// the real error, and a sampled sweep prints the error measured at LumiBench's settings
    /// (geomean speed-ups up to 3.5 points low at 0.25) [default: every warp].
    #[arg(long, value_name = "FRACTION")]
    pub sample: Option<f64>,
    /// How sampled warps are drawn.
    #[arg(long, value_enum, default_value = "tile")]
    pub sample_mode: crate::run::sampling::SampleMode,
    /// Independent batches of a sampled run (at least 2).
    #[arg(long, default_value_t = 8)]
    pub batches: u32,
}

impl SampleArgs {
    /// The sample asked for (`None`: every warp, which `--sample 1` is too), checked; drawn
    /// with `seed`.
    pub fn plan(&self, seed: u64) -> anyhow::Result<Option<crate::run::sampling::SamplePlan>> {
        let Some(fraction) = self.sample else { return Ok(None) };
        let plan = crate::run::sampling::SamplePlan {
            fraction,
            mode: self.sample_mode,
            batches: self.batches,
            seed,
        };
        plan.validate().map_err(|e| anyhow::anyhow!("--sample: {e}"))?;
        Ok((!plan.every_warp()).then_some(plan))
    }
}

pub fn parse_res(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or("expected WIDTHxHEIGHT, e.g. 128x128")?;
    let parse = |v: &str| v.trim().parse::<u32>().map_err(|e| format!("'{v}': {e}"));
    Ok((parse(w)?, parse(h)?))
}

/// The hardware around the stack: a shipped preset or a TOML file, then flags.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct HardwareArgs {
    /// Hardware: a shipped preset — paper (default: the paper's text, the rest from Vulkan-Sim's
    /// MOBILE config), vulkansim-mobile (that config file as it is), rtx2060, legacy (this model
    /// before it adopted Vulkan-Sim's mechanisms) — or a TOML file applied to `paper`
    /// (`--help` lists its keys).
    #[arg(long, value_name = "PRESET|FILE", long_help = hw_long_help())]
    pub hw: Option<String>,
    /// Stack timing: blocking (the paper's RT unit: a ray's next node fetch waits for its stack
    /// requests, stores wait for the L2's acknowledgement) or overlapped (posted stores, the
    /// refill runs beside the next node fetch). Default: the hardware's (paper: blocking).
    #[arg(long, value_parser = |s: &str| s.parse::<rtl::rt_unit::StackTiming>())]
    pub stack_timing: Option<rtl::rt_unit::StackTiming>,
    /// Unified L1D/shared-memory size per SM in KB (paper: 64); the SH stacks are carved out.
    #[arg(long)]
    pub l1d_kb: Option<u32>,
    /// SMs, one RT unit each (paper: 8).
    #[arg(long)]
    pub sms: Option<u32>,
    /// DRAM latency in cycles beyond the L2's (paper: 100).
    #[arg(long)]
    pub dram_latency: Option<u32>,
}

impl HardwareArgs {
    /// The hardware as named here: the preset or file, then the flags that change it.
    pub fn name(&self) -> String {
        let mut name = self.hw.clone().unwrap_or_else(|| crate::hw::presets::DEFAULT.to_string());
        let mut flag = |f: &str, v: Option<String>| {
            if let Some(v) = v {
                name += &format!(" {f} {v}");
            }
        };
        flag("--stack-timing", self.stack_timing.map(|t| format!("{t:?}").to_lowercase()));
        flag("--l1d-kb", self.l1d_kb.map(|v| v.to_string()));
        flag("--sms", self.sms.map(|v| v.to_string()));
        flag("--dram-latency", self.dram_latency.map(|v| v.to_string()));
        name
    }

    /// What reports state about this hardware: its name and a hash of `hw`, its resolution.
    pub fn id(&self, hw: &crate::hw::Hardware) -> crate::run::provenance::HardwareId {
        crate::run::provenance::HardwareId::new(self.name(), hw)
    }

    pub fn hardware(&self) -> anyhow::Result<crate::hw::Hardware> {
        let mut hw = match &self.hw {
            Some(spec) => crate::hw::resolve(spec).map_err(|e| anyhow::anyhow!("--hw {e}"))?,
            None => crate::hw::Hardware::default(),
        };
        if let Some(kb) = self.l1d_kb {
            hw.mem.l1d_bytes =
                kb.checked_mul(1024).ok_or_else(|| anyhow::anyhow!("--l1d-kb {kb}: too large"))?;
        }
        hw.stack.timing = self.stack_timing.unwrap_or(hw.stack.timing);
        hw.mem.sms = self.sms.unwrap_or(hw.mem.sms);
        hw.mem.dram_latency = self.dram_latency.unwrap_or(hw.mem.dram_latency);
        // Every value checked before any work starts.
        hw.validate().map_err(|e| anyhow::anyhow!("hardware: {e}"))?;
        Ok(hw)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hardware_flags_are_checked_by_the_memory_system() {
        let args = HardwareArgs { l1d_kb: Some(64), sms: Some(2), ..HardwareArgs::default() };
        let hw = args.hardware().unwrap();
        assert_eq!((hw.mem.l1d_bytes, hw.mem.sms), (64 * 1024, 2));
        let zero = HardwareArgs { sms: Some(0), ..HardwareArgs::default() };
        assert!(zero.hardware().unwrap_err().to_string().starts_with("hardware: "));
        let missing = HardwareArgs { hw: Some("/nonexistent/hw.toml".into()), ..HardwareArgs::default() };
        assert!(missing.hardware().unwrap_err().to_string().contains("not a preset (paper, "));
        let legacy = HardwareArgs { hw: Some("legacy".into()), ..HardwareArgs::default() };
        assert_eq!(legacy.hardware().unwrap(), crate::hw::preset("legacy").unwrap());
        let blocking = HardwareArgs { stack_timing: Some(rtl::rt_unit::StackTiming::Blocking), ..legacy };
        assert_eq!(blocking.hardware().unwrap().stack.timing, rtl::rt_unit::StackTiming::Blocking);
    }
}
