//! `sms check`: the exhaustive model checker. By default a bounded search over a grid of small
//! configurations (bounds from the command line) or over the configurations named with `-c`
//! (the shared configuration flags, as every subcommand takes them); with `--full`, every
//! case of [`crate::run::verify::exhaustive::full_cases`] explored to its fixpoint
//! under a depth cap, every cover goal asserted.
//!
//! The verdict says what was examined: "all properties hold" / "every property proved" only
//! when every configuration's search reached its fixpoint (every reachable state explored). A
//! search stopped by the depth bound or the state limit without a violation is *bounded*: its
//! row and the verdict name the cap and the depth, and `sms` exits with 2 ([`Bounded`]); a
//! violation, a missed cover goal or bad input exits with 1.

use std::path::{Path, PathBuf};

use crate::run::verify::exhaustive::{
    check, describe, full_cases, is_large, large_cap, Action, Bounds, Case, Coverage, Model,
};
use anyhow::{bail, Result};
use rtl::config::{Config, RbSize, Realloc, ShPolicy};
use rtl::stack_manager::{Mutant, StackManager};
use rtl::trace::{Probe, Sink};

use crate::cli::stack_config::StackConfigArgs;
use crate::cli::{Bounded, Format, OutputArgs};
use crate::report::table::Table;
use crate::vcd::{Selection, VcdOptions, VcdSink};

/// The exit status, in `sms check --help`.
pub const EXIT_STATUS: &str =
    "Exit status: 0 when every configuration's search reached its fixpoint with no \
property violated (with --full: every cover goal reached too); 1 when a property is violated, a cover goal \
is missed, or the input is bad; 2 when no property is violated but some search stopped at a cap (the depth \
bound of the grid, or --max-states) before its fixpoint: a bounded check, not a proof.";

#[derive(clap::Args, Debug)]
#[command(after_help = EXIT_STATUS)]
pub struct Args {
    /// RB entries of the grid, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [1, 2])]
    pub rb: Vec<u32>,
    /// SH entries per thread of the grid, comma-separated (0 or powers of two).
    #[arg(long, value_delimiter = ',', default_values_t = [0, 1, 2])]
    pub sh: Vec<u32>,
    /// Threads per warp of the grid, comma-separated (powers of two); `--warp-size N` checks N
    /// alone.
    #[arg(long, value_delimiter = ',', default_values_t = [2, 4])]
    pub warp_sizes: Vec<u32>,
    /// Borrow limits of the grid, comma-separated; 0 = reallocation off. `--borrow-limit N`
    /// replaces the nonzero ones; reallocating configurations flush at 1 unless `--flush-limit`.
    #[arg(long, alias = "borrow", value_delimiter = ',', default_values_t = [0, 1])]
    pub borrow_limits: Vec<u32>,
    // With `-c`, the named configurations are checked instead of the grid, one warp of
    // `--warp-size` threads (which they then need: the names' 32 threads are too many).
    #[command(flatten)]
    pub stack: StackConfigArgs,
    /// Longest action sequence (commands and micro-op completions) for 2-thread warps [default:
    /// 16]; wider warps take --wide-depth. A configuration whose search is still finding new
    /// states at this depth is reported as bounded (exit status 2), not proved.
    #[arg(long)]
    pub depth: Option<u32>,
    /// Longest action sequence for wider warps.
    #[arg(long, default_value_t = 9)]
    pub wide_depth: u32,
    /// Distinct push values (with --full only together with --all-values).
    #[arg(long, default_value_t = 2)]
    pub values: u32,
    /// With --full: offer every value 1..=--values at every push, instead of one marked push
    /// per run (a distinguished value at most once, every other push one common value: enough
    /// for a data-independent design, and far fewer states).
    #[arg(long)]
    pub all_values: bool,
    /// Stop a configuration after this many distinct states, at least 1 (the initial state);
    /// a configuration stopped so is reported as bounded (exit status 2), not proved [default:
    /// 20000000; with --full 400000000: the largest case has 1.0 * 10^8 and peaked at 3.7 GB
    /// resident].
    #[arg(long)]
    pub max_states: Option<usize>,
    /// If a property fails, dump the shortest counterexample here as a VCD (one action per time
    /// step, every register of the warp) with a GTKWave save file next to it.
    #[arg(long, value_name = "FILE")]
    pub vcd: Option<PathBuf>,
    /// Plant a stack-manager bug to watch the checker catch it (needs a build with `--features
    /// mutants`).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(Mutant::NAMES))]
    pub mutant: Option<String>,
    /// Prove instead of search: explore every case of the full set (the small grid, skewed
    /// configurations with 4 and 8 banks, 4-thread warps with one active lane whose chains
    /// of three stacks rotate, and the design's own sizes with few lanes active: M = 4, 8, 16
    /// and 32, chains of 5, flush limit 3, lanes above 15, a second warp, two commands or a
    /// completion and a command in one cycle) to its fixpoint, every interleaving unbounded in
    /// time, under a cap on the entries the warp holds; a cover goal never reached fails the
    /// run, a case stopped by --max-states is reported as bounded (exit status 2). The two
    /// 4-thread warps with M = 2 and reallocation are searched depth first and take most of the
    /// time (measured here: 1.0 * 10^8 and 3.9 * 10^7 states, 14 and 6 minutes, 3.7 GB at the
    /// peak); --small-cap runs them under a smaller cap, --quick leaves them out.
    /// Ignores the grid (--rb, --sh, --warp-sizes, --borrow-limits), the configuration flags
    /// (-c, --warp-size, --borrow-limit, --flush-limit), --depth and --wide-depth.
    #[arg(long)]
    pub full: bool,
    #[command(flatten)]
    pub output: OutputArgs,
    /// The cap on the entries the warp holds: pushes are offered only while it holds fewer.
    /// Without it a grid search never runs out of new states, so it ends at the depth bound
    /// (bounded); with it the search can reach its fixpoint. With --full the default is per
    /// case: RB + SH × (1 + borrow limit) + 1, enough to fill a whole chain and reach global
    /// memory (the corner cases' own caps are in docs/verification.md).
    #[arg(long)]
    pub cap: Option<u32>,
    /// With --full: explore without the partial-order reduction (every interleaving of private
    /// micro-ops — global loads and stores, latch → RB bottom — with other threads' actions; same
    /// verdict and covers, more states).
    #[arg(long)]
    pub no_por: bool,
    /// With --full: prove only the cases whose description contains this text (e.g. "SH_2+SK+RA
    /// warp 4"); an error listing the cases if none does.
    #[arg(long, value_name = "TEXT")]
    pub only: Option<String>,
    /// With --full: explore every case depth first (by default only the 4-thread warps with M =
    /// 2 and reallocation are: their BFS levels hold millions of states); the same properties
    /// are checked on every reachable state, counterexamples are no longer shortest.
    #[arg(long)]
    pub dfs: bool,
    /// With --full: leave out the 4-thread warps with M = 2 and reallocation (about 20 minutes
    /// together).
    #[arg(long)]
    pub quick: bool,
    /// With --full: run the 4-thread warps with M = 2 and reallocation under RB + 2 × SH + 1 (6
    /// and 7 entries shared by the four lanes: every cover goal still reached, 1.1 * 10^7 and
    /// 4.8 * 10^6 states, 145 s here) instead of the cap that fills a whole chain and reaches global memory
    /// (8 and 9).
    #[arg(long, conflicts_with = "quick")]
    pub small_cap: bool,
}

/// The planted bug `--mutant` names, if any.
fn mutant(name: Option<&str>) -> Result<Option<Mutant>> {
    let Some(name) = name else { return Ok(None) };
    if !cfg!(feature = "mutants") {
        bail!("--mutant {name}: this build has no planted bugs; build with `--features mutants`");
    }
    match Mutant::from_name(name) {
        Some(m) => Ok(Some(m)),
        None => bail!("--mutant {name}: unknown; one of {}", Mutant::NAMES.join(", ")),
    }
}

/// The design under check: the stack manager as built, or with `mutant` planted.
fn design(_mutant: Option<Mutant>) -> impl Fn(StackManager) -> StackManager + Copy {
    move |sm| {
        #[cfg(feature = "mutants")]
        let sm = sm.with_mutant(_mutant);
        sm
    }
}

/// Replays `trace` on a fresh warp of `cfg` built by `design` and dumps every register after
/// each action (time step i = after i actions) to `path`, with a GTKWave save file.
/// `active`: the lanes active when the warp loads (as the search had them).
pub fn dump_counterexample(
    cfg: Config,
    design: impl Fn(StackManager) -> StackManager,
    active: u32,
    trace: &[Action],
    path: &Path,
) -> Result<()> {
    let mut model = Model::new(cfg)?;
    model.sm = design(model.sm);
    model.sm.load_warp(0, active);
    model.sb.load_warp(model.sm.warp_threads(0), active);
    let opts = VcdOptions { path: path.to_path_buf(), select: Selection::default() };
    let mut sink = VcdSink::create(&opts, &Config { warps: 1, ..cfg })?;
    let mut cov = Coverage::default();
    sink.begin_cycle(0);
    model.sm.probe(&mut sink);
    for (i, &a) in trace.iter().enumerate() {
        // The last action is the one that breaks a property; its state is still dumped.
        let _ = model.act(a, &mut cov);
        sink.begin_cycle(i as u64 + 1);
        model.sm.probe(&mut sink);
    }
    sink.end_run(trace.len() as u64 + 1);
    sink.finish()?;
    Ok(())
}

/// The configurations to check: the names given with `-c`, else the grid; every shape override
/// applied, one warp each, without repeats.
fn grid(a: &Args) -> Result<Vec<Config>> {
    let stack = &a.stack;
    if let Some(w) = stack.warps.filter(|&w| w != 1) {
        bail!("--warps {w}: `sms check` explores one warp");
    }
    if !stack.config.is_empty() {
        if stack.warp_size.is_none() {
            bail!("--config: give --warp-size too (the names' 32 threads are too many to explore)");
        }
        let named = stack.resolve(&[])?.into_iter().map(|c| Config { warps: 1, ..c });
        return named.map(|c| c.validate().map(|()| c).map_err(Into::into)).collect();
    }
    let mut out: Vec<Config> = Vec::new();
    for &n in &a.rb {
        for &m in &a.sh {
            for &warp_size in &a.warp_sizes {
                for &borrow in &a.borrow_limits {
                    let c = stack.apply(Config {
                        rb: RbSize::Entries(n),
                        sh_entries: m,
                        policy: ShPolicy::from(
                            (borrow > 0).then_some(Realloc { borrow_limit: borrow, flush_limit: 1 }),
                        ),
                        warp_size,
                        warps: 1,
                        ..Config::default()
                    });
                    let c = Config { skew: m > 0 && c.warp_size > 2, ..c };
                    if c.realloc().is_some_and(|ra| m == 0 || ra.borrow_limit >= c.warp_size) {
                        continue;
                    }
                    c.validate()?;
                    if !out.contains(&c) {
                        out.push(c);
                    }
                }
            }
        }
    }
    if out.is_empty() {
        bail!("no configuration to check: every combination was invalid (reallocation needs --sh > 0 and a borrow limit below the warp size)");
    }
    Ok(out)
}

pub fn run(args: Args) -> Result<()> {
    if let Some(vcd) = &args.vcd {
        crate::cli::guard::outside_scene_data("--vcd", vcd, &crate::SceneLibrary::default().data)?;
    }
    if args.values < 2 {
        bail!("--values {}: at least 2 distinct values are needed to see entries reordered", args.values);
    }
    if args.cap == Some(0) {
        bail!("--cap 0: the warp must be able to hold at least one entry");
    }
    if args.max_states == Some(0) {
        bail!("--max-states 0: a search holds at least its initial state; give 1 or more");
    }
    if args.full {
        return run_full(&args);
    }
    let configs = grid(&args)?;
    if let Some(d) = args.depth.filter(|_| configs.iter().all(|c| c.warp_size > 2)) {
        bail!(
            "--depth {d}: bounds 2-thread warps only, and every warp here is wider; give --wide-depth (now {})",
            args.wide_depth
        );
    }
    let design = design(mutant(args.mutant.as_deref())?);
    let mut t = Table::new([
        "configuration",
        "depth",
        "states",
        "sequences",
        "seconds",
        "borrows",
        "flushes",
        "reloads",
        "releases",
        "searched",
    ]);
    let started = std::time::Instant::now();
    let mut capped = Vec::new();
    for c in &configs {
        let depth = if c.warp_size <= 2 { args.depth.unwrap_or(16) } else { args.wide_depth };
        let under = args.cap.map_or(String::new(), |c| format!(" under cap {c}"));
        crate::cli::note(format!("checking {} to depth {depth}{under} ...", describe(c)));
        let bounds = Bounds {
            depth,
            values: args.values,
            max_states: args.max_states.unwrap_or(MAX_STATES),
            cap: args.cap,
            ..Bounds::default()
        };
        match check(*c, bounds, design) {
            Ok(cov) => {
                let searched = searched(&cov, bounds.max_states);
                if !cov.fixpoint {
                    capped.push(format!("{} ({searched})", describe(c)));
                }
                t.row([
                    describe(c),
                    cov.depth_reached.to_string(),
                    cov.states.to_string(),
                    cov.sequences.to_string(),
                    format!("{:.2}", cov.elapsed.as_secs_f64()),
                    cov.borrows.to_string(),
                    cov.flushes.to_string(),
                    cov.global_reloads.to_string(),
                    cov.releases.to_string(),
                    searched,
                ]);
            }
            Err(cex) => {
                print_report(&args.output, &t, None)?;
                if let Some(path) = &args.vcd {
                    dump_counterexample(*c, design, u32::MAX >> (32 - c.warp_size), &cex.trace, path)?;
                    crate::cli::note(format!(
                        "wrote {} and {} (time step i = after action i)",
                        path.display(),
                        path.with_extension("gtkw").display()
                    ));
                }
                bail!(
                    "{}: property violated; shortest counterexample ({} actions):\n{cex}",
                    describe(c),
                    cex.trace.len()
                );
            }
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    if !capped.is_empty() {
        let verdict = format!(
            "bounded: no property violated, but {} of {} configurations stopped at a cap before their \
             fixpoint, so nothing is proved for them: {} ({seconds:.1} s)",
            capped.len(),
            configs.len(),
            capped.join("; ")
        );
        print_report(&args.output, &t, Some(&verdict))?;
        return Err(Bounded(verdict).into());
    }
    let verdict = format!(
        "all properties hold on {} configurations, each searched to its fixpoint ({seconds:.1} s)",
        configs.len()
    );
    print_report(&args.output, &t, Some(&verdict))
}

/// How far a search went, for its row: to its fixpoint, or stopped by the state limit or the
/// depth bound (and at which depth).
fn searched(cov: &Coverage, max_states: usize) -> String {
    if cov.fixpoint {
        format!("fixpoint at depth {}", cov.depth_reached)
    } else if !cov.complete {
        format!("state cap {max_states} at depth {}", cov.depth_reached)
    } else {
        format!("depth cap {}", cov.depth_reached)
    }
}

/// Prints the table and, when every property held, the verdict line, in the format asked for
/// (CSV: the table alone; JSON: `{ table, verdict }`, `verdict` null on a failure).
fn print_report(output: &OutputArgs, t: &Table, verdict: Option<&str>) -> Result<()> {
    match (output.format(), output.table(t)) {
        (Format::Csv, Some(table)) => print!("{table}"),
        (Format::Markdown, Some(table)) => {
            print!("{table}{}", verdict.map_or(String::new(), |v| format!("\n{v}\n")))
        }
        (_, Some(table)) => print!("{table}{}", verdict.map_or(String::new(), |v| format!("{v}\n"))),
        (_, None) => println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({ "table": t, "verdict": verdict }))?
        ),
    }
    Ok(())
}

/// Default state limits: of a bounded search, and of a `--full` case (a safety net above the
/// largest case's 1.0 · 10⁸ states, which peaked at 3.7 GB resident; memory grows about
/// linearly in the states, so the limit stays within this 24 GB machine).
const MAX_STATES: usize = 20_000_000;
const MAX_STATES_FULL: usize = 400_000_000;

/// The cases of the full set `--quick` and `--only` leave.
fn selected_cases(args: &Args) -> Result<Vec<Case>> {
    let mut cases = full_cases();
    if args.quick {
        cases.retain(|c| !c.dfs);
    }
    if args.small_cap {
        for c in cases.iter_mut().filter(|c| is_large(&c.cfg) && !c.partial()) {
            c.cap = large_cap(&c.cfg);
        }
    }
    if let Some(only) = &args.only {
        let names: Vec<String> = cases.iter().map(Case::describe).collect();
        cases.retain(|c| c.describe().contains(only.as_str()));
        if cases.is_empty() {
            bail!("--only {only:?}: no case of the full set matches; the cases: {}", names.join("; "));
        }
    }
    Ok(cases)
}

/// `--full`: every configuration of the full set to its fixpoint, every cover goal asserted.
fn run_full(args: &Args) -> Result<()> {
    let design = design(mutant(args.mutant.as_deref())?);
    let mut t = Table::new([
        "configuration",
        "cap",
        "states",
        "depth",
        "seconds",
        "peak frontier",
        "frontier MB",
        "visited MB",
        "reduced",
        "fixpoint",
        "covers missing",
    ]);
    let started = std::time::Instant::now();
    let (mut capped, mut uncovered) = (Vec::new(), Vec::new());
    let cases = selected_cases(args)?;
    for case in &cases {
        let c = &case.cfg;
        let cap = args.cap.unwrap_or(case.cap);
        let name = case.describe();
        crate::cli::note(format!("proving {name} under cap {cap} ..."));
        let bounds = Bounds {
            values: args.values,
            max_states: args.max_states.unwrap_or(MAX_STATES_FULL),
            cap: Some(cap),
            one_mark: !args.all_values,
            por: !args.no_por,
            dfs: args.dfs || case.dfs,
            progress: true,
            ..case.bounds()
        };
        let cov = match check(*c, bounds, design) {
            Ok(cov) => cov,
            Err(cex) => {
                print_report(&args.output, &t, None)?;
                if let Some(path) = &args.vcd {
                    dump_counterexample(*c, design, case.active, &cex.trace, path)?;
                }
                bail!(
                    "{name}: property violated; shortest counterexample ({} actions):\n{cex}",
                    cex.trace.len()
                );
            }
        };
        let missing = cov.covers.missing_of(&case.goals());
        crate::cli::note(format!(
            "  {} states, depth {}, {:.2} s, fixpoint {}, missing {missing:?}",
            cov.states,
            cov.depth_reached,
            cov.elapsed.as_secs_f64(),
            cov.fixpoint
        ));
        let max_states = bounds.max_states;
        if !cov.fixpoint {
            capped.push(format!("{name} (state cap {max_states} at depth {})", cov.depth_reached));
        } else if !missing.is_empty() {
            uncovered.push(format!("{name} ({missing:?})"));
        }
        t.row([
            name,
            cap.to_string(),
            cov.states.to_string(),
            cov.depth_reached.to_string(),
            format!("{:.2}", cov.elapsed.as_secs_f64()),
            cov.peak_frontier.to_string(),
            format!("{:.1}", cov.peak_frontier_bytes as f64 / 1e6),
            format!("{:.1}", cov.visited_bytes as f64 / 1e6),
            cov.reduced.to_string(),
            if cov.fixpoint { "yes".into() } else { "state cap".into() },
            if missing.is_empty() {
                "-".into()
            } else {
                missing.iter().map(|g| format!("{g:?}")).collect::<Vec<_>>().join(" ")
            },
        ]);
    }
    if !uncovered.is_empty() {
        print_report(&args.output, &t, None)?;
        bail!(
            "not proved: the fixpoint was reached but a cover goal never was, so the check is vacuous \
             there: {}",
            uncovered.join("; ")
        );
    }
    if !capped.is_empty() {
        let verdict = format!(
            "bounded: no property violated, but {} of {} cases stopped at the state cap before their \
             fixpoint, so nothing is proved for them: {} ({:.1} s)",
            capped.len(),
            cases.len(),
            capped.join("; "),
            started.elapsed().as_secs_f64()
        );
        print_report(&args.output, &t, Some(&verdict))?;
        return Err(Bounded(verdict).into());
    }
    let verdict = format!(
        "every property proved on {} configurations to the fixpoint, every cover reached ({:.1} s)",
        cases.len(),
        started.elapsed().as_secs_f64()
    );
    print_report(&args.output, &t, Some(&verdict))
}

#[cfg(test)]
mod mutant_tests {
    use super::*;

    #[test]
    fn mutant_names_come_from_the_one_list() {
        assert_eq!(Mutant::ALL.len(), Mutant::NAMES.len());
        for m in Mutant::ALL {
            assert_eq!(Mutant::from_name(m.name()), Some(m));
        }
        assert!(mutant(None).unwrap().is_none());
        let e = mutant(Some("no-such-bug")).unwrap_err().to_string();
        assert!(e.contains("--mutant no-such-bug"), "{e}");
        match mutant(Some("eager-release")) {
            Ok(m) => assert!(cfg!(feature = "mutants") && m == Some(Mutant::EagerRelease)),
            Err(e) => {
                assert!(!cfg!(feature = "mutants") && e.to_string().contains("--features mutants"), "{e}")
            }
        }
    }
}

#[cfg(test)]
mod grid_tests {
    use clap::Parser;

    use super::*;

    #[derive(clap::Parser)]
    struct Cli {
        #[command(flatten)]
        args: Args,
    }

    fn cases(argv: &[&str]) -> Result<Vec<String>> {
        let cli = Cli::try_parse_from(["check", "--full"].into_iter().chain(argv.iter().copied()))?;
        Ok(selected_cases(&cli.args)?.iter().map(Case::describe).collect())
    }

    #[test]
    fn quick_and_only_select_cases_of_the_full_set() {
        let all = cases(&[]).unwrap();
        let quick = cases(&["--quick"]).unwrap();
        assert_eq!(all.len(), quick.len() + 2, "--quick leaves out the two large cases");
        assert!(!quick
            .iter()
            .any(|c| c.starts_with("RB_1+SH_2+SK+RA warp 4 borrow 2 flush 1") && !c.contains("lanes")));
        assert_eq!(cases(&["--only", "lanes 0001"]).unwrap().len(), 2);
        // --small-cap lowers the two large cases' caps (8, 9 → 6, 7) and nothing else.
        let caps = |argv: &[&str]| -> Vec<u32> {
            let cli =
                Cli::try_parse_from(["check", "--full"].into_iter().chain(argv.iter().copied())).unwrap();
            selected_cases(&cli.args).unwrap().iter().map(|c| c.cap).collect()
        };
        let (default, small) = (caps(&[]), caps(&["--small-cap"]));
        let lowered: Vec<_> =
            default.iter().zip(&small).filter(|(d, s)| d != s).map(|(d, s)| (*d, *s)).collect();
        assert_eq!(lowered, [(8, 6), (9, 7)]);
        assert!(Cli::try_parse_from(["check", "--full", "--quick", "--small-cap"]).is_err());
        let e = cases(&["--only", "no such case"]).unwrap_err().to_string();
        assert!(e.contains("--only \"no such case\""), "{e}");
    }

    fn configs(argv: &[&str]) -> Result<Vec<String>> {
        let cli = Cli::try_parse_from(std::iter::once("check").chain(argv.iter().copied()))?;
        Ok(grid(&cli.args)?.iter().map(describe).collect())
    }

    #[test]
    fn the_shared_configuration_flags_narrow_the_grid_or_replace_it() {
        let all = configs(&[]).unwrap();
        assert_eq!(all.len(), 20, "the default grid: {all:?}");
        // --warp-size means threads per warp, as in every subcommand: the grid's other sizes go.
        let two = configs(&["--warp-size", "2"]).unwrap();
        assert_eq!(two, configs(&["--warp-sizes", "2"]).unwrap());
        // The grid's borrow list was `--borrow` before the shared flags came in; it still parses.
        assert_eq!(configs(&["--borrow", "0"]).unwrap(), configs(&["--borrow-limits", "0"]).unwrap());
        assert!(two.len() < all.len());
        // --borrow-limit replaces the grid's nonzero limits; borrowing 2 of 2 threads is invalid.
        assert_eq!(
            configs(&["--warp-sizes", "4", "--borrow-limit", "2"]).unwrap(),
            configs(&["--warp-sizes", "4", "--borrow-limits", "0,2"]).unwrap()
        );
        // -c replaces the grid: the names, one warp of --warp-size threads.
        let named =
            configs(&["-c", "RB_2+SH_1+RA", "--warp-size", "2", "--borrow-limit", "1", "--flush-limit", "3"]);
        let mut want = "RB_2+SH_1+RA".parse::<Config>().unwrap();
        want.warps = 1;
        want.warp_size = 2;
        want.policy = ShPolicy::Realloc(Realloc { borrow_limit: 1, flush_limit: 3 });
        assert_eq!(named.unwrap(), [describe(&want)]);
        for (argv, flag) in [
            (&["-c", "RB_2"][..], "--config"),
            (&["--warps", "2"], "--warps 2"),
            (&["-c", "RB_2+SH_1+RA", "--warp-size", "1"], "--config RB_2+SH_1+RA"),
        ] {
            let e = format!("{:#}", configs(argv).unwrap_err());
            assert!(e.starts_with(flag), "{argv:?}: {e}");
        }
    }
}
