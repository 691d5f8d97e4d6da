//! A formal check of the generated netlist with yosys's own SAT solver (`sat -tempinduct`): the
//! well-formedness invariant the SMT proofs assume ([`well_formed_parts`]), built over the warp
//! module's registers by the same code and printed as Verilog assertions, proved on the warp
//! module yosys reads from the Verilog text, from a warp load on, for every input sequence the
//! input protocol allows.
//!
//! What is checked ([`checks`]): every clause of [`well_formed_parts`] over every lane (the
//! quiescent clauses with the lane's `busy` as the registers say: a micro-op in flight or a
//! program queued), and, as strengthening clauses, the state assumption the SMT whole-cycle
//! proofs add to it (`tb/src/prove/cycle.rs`): every micro-op in flight or queued names a lane
//! of the warp and an entry below M, and every queued release names another lane's finished,
//! unlinked, empty, not yet Idle stack. The inputs are free except for the protocol those
//! proofs' cycle shapes encode: an SH completion only for a lane whose micro-op in flight is an
//! SH access, a response-FIFO completion only for a lane whose micro-op in flight is a global
//! load (or, acknowledged, a global store). Commands (any kind, to any lane, in any cycle),
//! completion data and warp loads are unconstrained.
//!
//! The verdicts ([`Verdict`]) say what yosys established: a k-induction proof, a bounded check
//! of the first k cycles after a warp load when induction does not close within the steps
//! allowed, or a counterexample from a warp load naming the clauses that fail.

use std::path::Path;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use rtl::config::Config;
use rtl::logic::Logic;
use rtl::stack_manager::policy::{Regs, Thread};
use rtl::stack_manager::{StackRegsOf, ThreadRegsOf};

use super::build::{Circuit, T};
use super::print::{self, Checks};
use super::Generated;
use crate::prove::query::{code, well_formed_parts};
use crate::prove::sym::{Sym, B, W};

/// Most lanes of a warp the formal check takes: its SAT problems grow with the lanes' programs
/// (`2M + 4` slots each) times the steps.
pub const MAX_LANES: u32 = 4;
/// Most SH entries per stack the formal check takes.
pub const MAX_SH_ENTRIES: u32 = 4;
/// Most RB entries the formal check takes.
pub const MAX_RB_ENTRIES: u32 = 4;

/// The warp module of one configuration with its formal block.
#[derive(Clone)]
pub struct Formal {
    /// The configuration in one line ([`super::describe`]).
    pub config: String,
    /// The names of the asserted clauses, in the order of the `wf_<k>` wires.
    pub asserts: Vec<String>,
    /// The names of the assumptions, in the order of the `fa_<k>` wires.
    pub assumes: Vec<String>,
    /// The Verilog yosys reads: the warp module with its `ifdef FORMAL` block.
    pub text: String,
}

/// The one-line refusal of a configuration too large for the formal check, if it is.
pub fn too_large(cfg: &Config) -> Option<String> {
    let rb = cfg.rb.capacity().unwrap_or(0);
    if cfg.warp_size > MAX_LANES || cfg.sh_entries > MAX_SH_ENTRIES || rb > MAX_RB_ENTRIES {
        return Some(format!(
            "{}: warp size {}, {} SH entries, {} RB entries is too large for the formal check: at most \
             {MAX_LANES} lanes (--warp-size), {MAX_SH_ENTRIES} SH entries and {MAX_RB_ENTRIES} RB entries",
            cfg.name(),
            cfg.warp_size,
            cfg.sh_entries,
            rb
        ));
    }
    None
}

/// The warp module of `g` with its formal block ([`checks`]).
pub fn build(g: &mut Generated) -> Result<Formal> {
    if let Some(e) = too_large(&g.cfg) {
        bail!(e);
    }
    let checks = checks(&mut g.circuit, &g.cfg, g.acked);
    let text = format!(
        "// {}: the warp module of {} with its formal block (`sms verilog --prove`,\n\
         // tb/src/verilog/formal.rs). Do not edit.\n\n{}",
        print::WARP,
        super::describe(&g.cfg, g.acked),
        print::warp_module_with(&g.circuit, Some(&checks))
    );
    Ok(Formal {
        config: super::describe(&g.cfg, g.acked),
        asserts: checks.asserts.into_iter().map(|x| x.0).collect(),
        assumes: checks.assumes.into_iter().map(|x| x.0).collect(),
        text,
    })
}

fn reg(c: &Circuit, name: &str) -> T {
    c.regs.iter().find(|r| r.name == name).map(|r| r.q).unwrap_or_else(|| panic!("no register {name}"))
}

fn input(c: &Circuit, name: &str) -> T {
    c.inputs.iter().find(|p| p.name == name).map(|p| p.t).unwrap_or_else(|| panic!("no input {name}"))
}

fn word(t: T) -> W {
    match t {
        T::W(w) => w,
        x => panic!("{x:?} is not a word"),
    }
}

fn bit(t: T) -> B {
    match t {
        T::B(b) => b,
        x => panic!("{x:?} is not a bit"),
    }
}

/// A micro-op register's kind and operands (`a`: a lane or spill slot, `b`: an entry).
#[derive(Clone, Copy)]
struct Uop {
    kind: W,
    a: W,
    b: W,
}

fn uop(c: &Circuit, prefix: &str) -> Uop {
    let f = |x: &str| word(reg(c, &format!("{prefix}_{x}")));
    Uop { kind: f("kind"), a: f("a"), b: f("b") }
}

fn any_of(s: &mut Sym, x: W, codes: &[u32]) -> B {
    let mut ok = s.bit(false);
    for &k in codes {
        let e = s.eq_k(x, k);
        ok = s.or(ok, e);
    }
    ok
}

fn implies(s: &mut Sym, a: B, b: B) -> B {
    let na = s.not(a);
    s.or(na, b)
}

/// The formal block's properties over `c`'s registers and inputs (module doc).
pub fn checks(c: &mut Circuit, cfg: &Config, acked: bool) -> Checks {
    let ws = c.lanes;
    let slots = super::build::queue_slots(cfg);
    let lane = |j: u32, x: &str| format!("lane{j}_{x}");
    let stacks: Vec<Regs<Sym>> = (0..ws)
        .map(|j| StackRegsOf {
            top: word(reg(c, &lane(j, "top"))),
            bottom: word(reg(c, &lane(j, "bottom"))),
            empty: bit(reg(c, &lane(j, "sh_empty"))),
            idle: bit(reg(c, &lane(j, "idle"))),
            next_tid: word(reg(c, &lane(j, "next_tid"))),
            priority: word(reg(c, &lane(j, "priority"))),
            flush: word(reg(c, &lane(j, "flush"))),
        })
        .collect();
    let threads: Vec<Thread<Sym>> = (0..ws)
        .map(|j| ThreadRegsOf {
            overflow: bit(reg(c, &lane(j, "overflow"))),
            spill_ptr: word(reg(c, &lane(j, "spill_ptr"))),
            done: bit(reg(c, &lane(j, "done"))),
        })
        .collect();
    let rb_len: Vec<W> = (0..ws).map(|j| word(reg(c, &lane(j, "rb_count")))).collect();
    let count: Vec<W> = (0..ws).map(|j| word(reg(c, &lane(j, "seq_step")))).collect();
    let inflight: Vec<Uop> = (0..ws).map(|j| uop(c, &lane(j, "inflight"))).collect();
    let queued: Vec<Vec<Uop>> =
        (0..ws).map(|j| (0..slots).map(|k| uop(c, &lane(j, &format!("seq{k}")))).collect()).collect();
    let sh_done: Vec<B> = (0..ws).map(|j| bit(input(c, &lane(j, "sh_done")))).collect();
    let deq_valid = bit(input(c, "deq_valid"));
    let deq_lane = word(input(c, "deq_lane"));

    let s = &mut c.sym;
    let done: Vec<B> = threads.iter().map(|t| t.done).collect();
    let lanes: Vec<(u32, Thread<Sym>, W, B)> = (0..ws as usize)
        .map(|j| {
            let z = s.word(0);
            let a = s.ne(inflight[j].kind, z);
            let q = s.ne(count[j], z);
            let busy = s.or(a, q);
            (j as u32, threads[j], rb_len[j], busy)
        })
        .collect();
    let mut asserts = well_formed_parts(s, cfg, &stacks, &done, &lanes);

    // The whole-cycle proofs' state assumption, asserted here as strengthening clauses.
    let sh_kinds = [code::SH_LOAD, code::SH_STORE];
    let m = cfg.sh_entries.max(1);
    for j in 0..ws as usize {
        let mut addressed = s.bit(true);
        let mut releasable = s.bit(true);
        let held = std::iter::once((inflight[j], None))
            .chain(queued[j].iter().enumerate().map(|(k, u)| (*u, Some(k))));
        for (u, slot) in held {
            let valid = match slot {
                None => {
                    let z = s.word(0);
                    s.ne(u.kind, z)
                }
                Some(k) => {
                    let k = s.word(k as u32);
                    s.lt(k, count[j])
                }
            };
            let sh = any_of(s, u.kind, &sh_kinds);
            let lane_ok = s.lt_k(u.a, ws);
            let entry_ok = s.lt_k(u.b, m);
            let both = s.and(lane_ok, entry_ok);
            let sh_ok = implies(s, sh, both);
            let release = s.eq_k(u.kind, code::RELEASE);
            let rel_ok = implies(s, release, lane_ok);
            let ok = s.and(sh_ok, rel_ok);
            let ok = implies(s, valid, ok);
            addressed = s.and(addressed, ok);
            if slot.is_some() {
                // Another lane's stack: its thread finished, alone on its ring at rank 0, empty
                // and not yet Idle.
                let mut fits = s.bit(false);
                for (k, r) in stacks.iter().enumerate() {
                    if k == j {
                        continue;
                    }
                    let here = s.eq_k(u.a, k as u32);
                    let alone = s.eq_k(r.next_tid, k as u32);
                    let rank0 = s.eq_k(r.priority, 0);
                    let awake = s.not(r.idle);
                    let x = s.and(here, done[k]);
                    let x = s.and(x, alone);
                    let x = s.and(x, rank0);
                    let x = s.and(x, r.empty);
                    let x = s.and(x, awake);
                    fits = s.or(fits, x);
                }
                let c = s.and(valid, release);
                let ok = implies(s, c, fits);
                releasable = s.and(releasable, ok);
            }
        }
        asserts.push((
            format!("lane {j}: every micro-op in flight or queued names a lane and an entry below M (cycle proofs' assumption)"),
            addressed,
        ));
        asserts.push((
            format!(
                "lane {j}: every queued release names another lane's finished, unlinked, empty, not Idle stack (cycle proofs' assumption)"
            ),
            releasable,
        ));
    }

    // The input protocol of the cycle proofs' shapes.
    let global_kinds: Vec<u32> =
        [code::GLOBAL_LOAD].into_iter().chain(acked.then_some(code::GLOBAL_STORE)).collect();
    let mut assumes = Vec::new();
    for j in 0..ws as usize {
        let sh = any_of(s, inflight[j].kind, &sh_kinds);
        let a = implies(s, sh_done[j], sh);
        assumes.push((format!("lane {j}: an SH completion only for an SH access in flight"), a));
        let here = s.eq_k(deq_lane, j as u32);
        let deq_here = s.and(deq_valid, here);
        let g = any_of(s, inflight[j].kind, &global_kinds);
        let a = implies(s, deq_here, g);
        let what = if acked { "a global load or store" } else { "a global load" };
        assumes.push((format!("lane {j}: a response-FIFO completion only for {what} in flight"), a));
    }
    let named = s.lt_k(deq_lane, ws);
    let a = implies(s, deq_valid, named);
    assumes.push(("a response-FIFO completion names a lane of the warp".into(), a));
    Checks { assumes, asserts }
}

/// What yosys established about the asserted clauses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// k-induction closed at length `k`: the clauses hold in every cycle after a warp load.
    Proved { k: u32 },
    /// The clauses hold in the first `depth` cycles after a warp load (bounded model check); the
    /// induction step still failed at length `depth`, so nothing is claimed past it.
    /// `step_fails`: the clauses the last induction step's model makes false (from a state
    /// unreachable or not, the solver does not say which).
    Bounded { depth: u32, step_fails: Vec<String> },
    /// `step` cycles after a warp load the clauses `failed` are false.
    Counterexample { step: u32, failed: Vec<String> },
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Verdict::Proved { k } => {
                write!(f, "proved by {k}-induction: holds in every cycle after a warp load")
            }
            Verdict::Bounded { depth, step_fails } => {
                write!(
                    f,
                    "bounded: holds in the first {depth} cycles after a warp load; induction did not close (not a proof beyond {depth} cycles)"
                )?;
                if !step_fails.is_empty() {
                    write!(f, "; the induction step fails at: {}", step_fails.join("; "))?;
                }
                Ok(())
            }
            Verdict::Counterexample { step, failed } => {
                write!(f, "counterexample {step} cycles after a warp load: {}", failed.join("; "))
            }
        }
    }
}

/// One formal check's result.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub config: String,
    pub verdict: Verdict,
    pub asserts: usize,
    pub assumes: usize,
    pub steps: u32,
    pub seconds: f64,
}

/// The yosys script proving the asserted clauses of `file` with at most `steps` time steps.
///
/// Before the proof the module's outputs become internal wires and the term wires lose their
/// names, so `opt_clean` keeps only the logic the registers, assumptions and assertions depend
/// on (the data path drops out: no clause reads an entry value); `techmap`, `opt` and ABC
/// (`-g AND`) reduce it to single-bit gates, where the description's 32-bit words, zero-extended
/// from narrow registers, fold to their live bits. Each of these passes keeps the module's
/// sequential behaviour on what it keeps.
pub fn script(file: &str, f: &Formal, steps: u32) -> String {
    let show: Vec<String> = (0..f.asserts.len()).map(|i| format!("wf_{i}")).collect();
    format!(
        "read_verilog -formal {file}\nhierarchy -top {}\nproc\ndelete -output o:*\nrename -hide w:t* w:*_w\n\
         opt_expr\nopt_clean\nwreduce\nopt_clean\ntechmap\nopt -fast\nabc -g AND\nopt_clean\n\
         tee -o formal_stat.txt stat\n\
         sat -tempinduct -prove-asserts -set-assumes -set-init-zero -maxsteps {steps} -show {} \
         -dump_vcd counterexample.vcd\n",
        print::WARP,
        show.join(",")
    )
}

/// Proves `f`'s asserted clauses with yosys `sat -tempinduct` (at most `steps` time steps, the
/// first being the warp load), in folder `dir`: the Verilog (`sms_formal.v`), the script
/// (`formal.ys`), yosys's log (`formal.log`) and, on a counterexample, its waveform
/// (`counterexample.vcd`) go there.
pub fn prove(f: &Formal, dir: &Path, steps: u32) -> Result<Outcome> {
    if steps < 2 {
        bail!("--steps {steps}: the first step loads the warp, so at least 2 are needed");
    }
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let file = "sms_formal.v";
    std::fs::write(dir.join(file), &f.text)?;
    std::fs::write(dir.join("formal.ys"), script(file, f, steps))?;
    let start = Instant::now();
    let out = std::process::Command::new("yosys")
        .args(["-l", "formal.log", "-s", "formal.ys"])
        .current_dir(dir)
        .stdout(std::process::Stdio::null())
        .output()
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => {
                anyhow::anyhow!("yosys is not on PATH: install it (apt-get install yosys)")
            }
            _ => anyhow::anyhow!("yosys: {e}"),
        })?;
    let seconds = start.elapsed().as_secs_f64();
    let log = std::fs::read_to_string(dir.join("formal.log")).unwrap_or_default();
    if !out.status.success() {
        let tail: Vec<&str> = log.lines().rev().take(10).collect();
        bail!(
            "yosys failed in {}:\n{}",
            dir.display(),
            tail.into_iter().rev().collect::<Vec<_>>().join("\n")
        );
    }
    let verdict =
        parse(&log, &f.asserts).with_context(|| format!("yosys log {}", dir.join("formal.log").display()))?;
    Ok(Outcome {
        config: f.config.clone(),
        verdict,
        asserts: f.asserts.len(),
        assumes: f.assumes.len(),
        steps,
        seconds,
    })
}

/// The verdict in yosys's `sat -tempinduct` log; `asserts` names the `wf_<k>` wires.
pub fn parse(log: &str, asserts: &[String]) -> Result<Verdict> {
    let last_step = |tag: &str| {
        log.lines()
            .filter_map(|l| l.trim_start().strip_prefix(tag)?.split(']').next()?.trim().parse::<u32>().ok())
            .max()
    };
    if let Some(at) = log.find("model found for base case: FAIL!") {
        let (step, failed) =
            false_at_last_step(&log[at..], asserts).context("a failed base case without its model")?;
        // Step 1 is the warp load's cycle.
        return Ok(Verdict::Counterexample { step: step - 1, failed });
    }
    if log.contains("Induction step proven: SUCCESS!") {
        let k = last_step("[induction step").context("a proof without its induction length")?;
        return Ok(Verdict::Proved { k });
    }
    if log.contains("Reached maximum number of time steps") {
        let depth = last_step("[base case").context("no base case in the log")?;
        // The last induction step's model: the clauses it makes false after the assumed steps.
        let step_fails = log
            .rfind("Induction step failed")
            .and_then(|at| false_at_last_step(&log[at..], asserts))
            .map(|x| x.1)
            .unwrap_or_default();
        // Base case n checks steps 1..=n, step 1 being the load's cycle.
        return Ok(Verdict::Bounded { depth: depth - 1, step_fails });
    }
    bail!("no verdict in the log")
}

/// The last time step of the model table at the start of `log` (`<step> \\wf_<k> <dec> …` rows)
/// and the clauses false at it, named by `asserts`; `None` without a false clause.
fn false_at_last_step(log: &str, asserts: &[String]) -> Option<(u32, Vec<String>)> {
    let mut rows = Vec::new();
    for l in log.lines() {
        let mut it = l.split_whitespace();
        let (Some(step), Some(sig), Some(v)) = (it.next(), it.next(), it.next()) else { continue };
        let (Ok(step), Some(k), Ok(v)) = (
            step.parse::<u32>(),
            sig.strip_prefix("\\wf_").and_then(|k| k.parse::<usize>().ok()),
            v.parse::<u64>(),
        ) else {
            continue;
        };
        rows.push((step, k, v));
    }
    let step = rows.iter().map(|r| r.0).max()?;
    let failed: Vec<String> = rows
        .iter()
        .filter(|r| r.0 == step && r.2 == 0)
        .map(|r| asserts.get(r.1).cloned().unwrap_or_else(|| format!("wf_{}", r.1)))
        .collect();
    (!failed.is_empty()).then_some((step, failed))
}

/// The outcomes as a table.
pub fn render(outcomes: &[Outcome]) -> String {
    let mut t = crate::report::table::Table::new([
        "configuration",
        "verdict",
        "asserted clauses",
        "assumptions",
        "most steps",
        "seconds",
    ]);
    for o in outcomes {
        t.row([
            o.config.clone(),
            o.verdict.to_string(),
            o.asserts.to_string(),
            o.assumes.to_string(),
            o.steps.to_string(),
            format!("{:.1}", o.seconds),
        ]);
    }
    format!(
        "{}\nyosys sat -tempinduct on the warp module: the well-formedness invariant of the SMT proofs \
         (tb/src/prove/query.rs well_formed_parts) and the cycle proofs' state assumption, from a warp \
         load on, inputs free but for the input protocol (docs/verilog.md, section Formal).\n",
        t.to_text()
    )
}
