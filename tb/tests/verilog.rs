//! The generated Verilog: its registers against the bit accounting, its refusals, and a
//! co-simulation against the Rust stack manager on a real scene that also catches a planted
//! difference; the restart designs (`+RT`) co-simulated on walk-driven runs.

use rtl::config::Config;
use tb::report::cost::{CostReport, Origin};
use tb::verilog::cosim::{self, Layout, Recorder};
use tb::verilog::{generate, synth, Generated};

/// Configuration of the co-simulation: a real scene's warps are 32 lanes; one warp slot keeps
/// the module small enough for Icarus Verilog in CI.
fn cosim_config() -> Config {
    Config { warps: 1, ..Config::default() }
}

/// Configuration `name` (one with reallocation) at one slot of `warp_size`-lane warps, lending
/// chains of at most `borrow_limit` borrowed stacks.
fn lending(name: &str, warp_size: u32, borrow_limit: u32) -> Config {
    let mut cfg = Config { warp_size, warps: 1, ..name.parse().unwrap() };
    cfg.policy.realloc_mut().expect("a configuration with reallocation").borrow_limit = borrow_limit;
    cfg
}

/// Icarus Verilog is installed (or its absence is reported, failing unless `SMS_SKIP_MISSING`).
fn icarus() -> bool {
    tb::prereq::tools(&["iverilog", "vvp"], "Icarus Verilog (apt-get install iverilog)")
}

/// `cycles` cycles of SM 0's stack manager on `scene` at 16 × 16 pixels, recorded for
/// co-simulation. The scene's 32-ray warps are regrouped into warps of `cfg.warp_size` rays, in
/// order.
fn record(cfg: Config, scene: &str, cycles: usize) -> (Generated, Vec<cosim::Cycle>) {
    let g = generate(&cfg, true).unwrap();
    let rec = Recorder::new(Layout::of(&g), cycles);
    let out = rec.out.clone();
    let hw = tb::hw::preset("paper").unwrap();
    let gpu = tb::testing::gpu(cfg, &hw).with_scoreboard(&|| Box::new(rec.clone()));
    let jobs = tb::testing::scene_jobs(scene, 16).into_iter().flat_map(|j| {
        let lanes: Vec<_> = j.lanes.chunks(cfg.warp_size as usize).map(|c| c.to_vec()).collect();
        lanes.into_iter().map(|lanes| rtl::ray_op::WarpJob { lanes, walk: None })
    });
    tb::testing::report(gpu, jobs, "co-simulated run");
    let cycles = std::mem::take(&mut out.lock().unwrap().cycles);
    (g, cycles)
}

/// `cycles` cycles of SM 0's stack manager of a restart design `cfg` on the `clutter` scene,
/// recorded for co-simulation: a walk-driven run (a flat BVH6 walked nearest first, as
/// `sms run` walks it for a restart design), each ray re-walking from the root when its stack
/// answers Restart. The scene's 32-ray warps are regrouped into warps of `cfg.warp_size` rays.
fn record_walks(cfg: Config, cycles: usize) -> (Generated, Vec<cosim::Cycle>) {
    use tb::run::walked::TreeWalks;
    use tb::workload::restart::{default_levels, RestartTree};
    use tb::workload::{traverse::ChildOrder, Accel, Workload, WorkloadOpts};
    let g = generate(&cfg, true).unwrap();
    let rec = Recorder::new(Layout::of(&g), cycles);
    let out = rec.out.clone();
    let scene = tb::load_scene("clutter").unwrap();
    let opts =
        WorkloadOpts { order: ChildOrder::Nearest, accel: Accel::Flat, ..WorkloadOpts::quick(&scene, 32) };
    let w = Workload::new(&scene, opts).unwrap();
    let o = w.opts();
    let tree = RestartTree::new(w.bvh(), &scene.primitives, o.order, default_levels(o.bvh)).unwrap();
    let rays: Vec<_> = (0..w.num_warps())
        .flat_map(|i| w.warp_rays(i))
        .flat_map(|lanes| lanes.chunks(cfg.warp_size as usize).map(<[_]>::to_vec).collect::<Vec<_>>())
        .filter(|lanes| lanes.iter().any(Option::is_some))
        .collect();
    let mut walks = TreeWalks::new(&tree, &scene.primitives, rays);
    let jobs = walks.jobs();
    let hw = tb::hw::preset("paper").unwrap();
    let gpu = tb::testing::gpu(cfg, &hw).with_scoreboard(&|| Box::new(rec.clone()));
    gpu.run_walks(jobs, &mut walks, &mut rtl::trace::NullSink, u64::MAX, |_| {}, &mut Vec::new())
        .unwrap_or_else(|e| panic!("walk-driven run: {e}"));
    assert_eq!((walks.live(), walks.counts.rays_checked), (0, walks.rays()), "every ray's hit checked");
    assert!(walks.counts.restarts > 0, "the run restarts walks");
    let cycles = std::mem::take(&mut out.lock().unwrap().cycles);
    (g, cycles)
}

/// The first cycle and thread at which field `name` of a lane's record is non-zero.
fn first_set(g: &Generated, cycles: &[cosim::Cycle], name: &str) -> Option<(usize, usize)> {
    let i =
        Layout::of(g).fields.iter().position(|f| f.name == name).unwrap_or_else(|| panic!("no field {name}"));
    cycles.iter().enumerate().find_map(|(k, c)| c.records.iter().position(|r| r[i] != 0).map(|t| (k, t)))
}

/// `g.text` with the right-hand side of the line starting `line` (a register's edge or an
/// output's assign, to its `;`) replaced by `rhs`, in which `{old}` stands for the original.
fn plant(g: &Generated, line: &str, rhs: &str) -> String {
    let at = g.text.find(line).unwrap_or_else(|| panic!("no line '{line}'")) + line.len();
    let end = at + g.text[at..].find(';').unwrap();
    let old = &g.text[at..end];
    format!("{}{}{}", &g.text[..at], rhs.replace("{old}", old), &g.text[end..])
}

/// Co-simulates the recorded `cycles` of `g`, then each planted variant `(what, text, cycle,
/// thread, signal)`: the report must name that first cycle, thread and signal.
fn cosimulate_with_plants(
    g: &Generated,
    cycles: &[cosim::Cycle],
    plants: &[(&str, String, usize, usize, &str)],
) {
    let dir = std::env::temp_dir().join(format!("sms-cosim-{}-{}", std::process::id(), g.cfg.name()));
    let r = cosim::run(g, &g.text, cycles, &dir.join("design")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.cycles, cycles.len());
    for (k, (what, text, cycle, thread, signal)) in plants.iter().enumerate() {
        let e = cosim::run(g, text, cycles, &dir.join(format!("planted{k}"))).unwrap_err();
        println!("{}, planted {what}: {e}", g.cfg.name());
        assert!(e.starts_with(&format!("cycle {cycle} ")), "{what}: {e}");
        assert!(
            e.contains(&format!("thread {thread} ")) && e.contains(&format!(": {signal}")),
            "{what}: {e}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// At 32 lanes, spill and restart designs: every row's bits in the Verilog. A restart design's
/// trail rows (origin restart) are the walk's, listed apart; with reallocation its Flush count is
/// written but never read (the drop ignores the flush limit), which synthesis removes.
#[test]
fn declared_registers_match_the_bit_accounting_row_by_row() {
    let restart = ["RB_2+RT", "RB_8+RT", "RB_8+SH_8+SK+RT", "RB_8+SH_8+SK+RA+RT", "RB_2+SH_8+SK+RA+RT"];
    for name in ["RB_8", "RB_16", "RB_8+SH_8", "SMS", "RB_2+SH_8+SK+RA"].into_iter().chain(restart) {
        let cfg: Config = name.parse().unwrap();
        let g = generate(&cfg, true).unwrap();
        let unread: u64 = g.unread_register_bits().iter().map(|x| x.1).sum();
        let a = synth::cross_check(&g, g.total_register_bits() - unread).unwrap();
        let cost = CostReport::new(&cfg, 1, 0).unwrap();
        let walk = cost.bits_per_sm(Origin::Restart);
        assert_eq!(a.accounted, cost.totals().bits_per_sm - walk, "{name}");
        assert_eq!(a.total(), g.total_register_bits(), "{name}");
        assert_eq!(a.total() - a.accounted, cost.control_bits_per_sm(), "{name}");
        // The model's sequencer holds its program: the control rows name it.
        assert!(a.control.iter().any(|(r, bits)| r == "seq_program" && *bits > 0), "{name}: {:?}", a.control);
        let outside: Vec<&str> = a.outside.iter().map(|x| x.0.as_str()).collect();
        let unread: Vec<(&str, u64)> = a.unread.iter().map(|x| (x.0.as_str(), x.1)).collect();
        if restart.contains(&name) {
            assert_eq!(outside, ["trail", "trail_depth"], "{name}");
            assert_eq!(a.outside.iter().map(|x| x.1).sum::<u64>(), walk, "{name}");
            let flush = u64::from(cfg.widths().unwrap().flush * cfg.threads());
            let want = if cfg.realloc().is_some() { vec![("flush", flush)] } else { vec![] };
            assert_eq!(unread, want, "{name}");
        } else {
            assert!(outside.is_empty() && unread.is_empty() && walk == 0, "{name}: {outside:?} {unread:?}");
        }
    }
}

#[test]
fn a_planted_accounting_difference_fails_naming_the_row() {
    let g = generate(&Config { warp_size: 4, warps: 1, ..Config::default() }, true).unwrap();
    let good = CostReport::new(&g.cfg, 1, 0).unwrap();
    synth::cross_check_with(&g, &good, g.total_register_bits()).unwrap();
    // A control row one bit short.
    let mut short = good.clone();
    short.control.iter_mut().find(|f| f.name == "seq_program").unwrap().bits -= 1;
    let e = synth::cross_check_with(&g, &short, g.total_register_bits()).unwrap_err().to_string();
    assert!(e.contains("register seq_program") && e.contains("bit accounting"), "{e}");
    // A row the accounting leaves out.
    let mut without = good.clone();
    without.control.retain(|f| f.name != "done");
    let e = synth::cross_check_with(&g, &without, g.total_register_bits()).unwrap_err().to_string();
    assert!(e.contains("register done") && e.contains("not in the bit accounting"), "{e}");
    // An accounted field's width.
    let mut wide = good;
    wide.fields.iter_mut().find(|f| f.name == "rb_count").unwrap().bits += 1;
    let e = synth::cross_check_with(&g, &wide, g.total_register_bits()).unwrap_err().to_string();
    assert!(e.contains("register rb_count"), "{e}");
    // A restart design's trail rows are left out by their origin: counted as the stack
    // manager's, the Verilog has none of their bits.
    let g = generate(&Config { warp_size: 4, warps: 1, .."RB_2+RT".parse().unwrap() }, true).unwrap();
    let good = CostReport::new(&g.cfg, 1, 0).unwrap();
    synth::cross_check_with(&g, &good, g.total_register_bits()).unwrap();
    let mut inside = good;
    inside.fields.iter_mut().find(|f| f.name == "trail").unwrap().origin = Origin::Paper;
    let e = synth::cross_check_with(&g, &inside, g.total_register_bits()).unwrap_err().to_string();
    assert!(e.contains("register trail has 0 bits in the Verilog"), "{e}");
}

#[test]
fn unbounded_rb_is_refused_in_one_line() {
    let e = generate(&"RB_FULL".parse().unwrap(), true).err().unwrap();
    assert!(e.contains("RB_FULL") && !e.contains('\n'), "{e}");
}

#[test]
fn a_wrong_flip_flop_count_fails_naming_both_counts() {
    let g = generate(&Config { warp_size: 4, warps: 1, ..Config::default() }, true).unwrap();
    let n = g.total_register_bits();
    let e = synth::cross_check(&g, n - 1).unwrap_err().to_string();
    assert!(
        e.contains(&format!("{} flip-flops", n - 1)) && e.contains(&format!("has {n} register bits")),
        "{e}"
    );
}

#[test]
fn yosys_flip_flops_equal_the_bit_accounting_and_a_dropped_register_is_caught() {
    if !tb::prereq::tools(&["yosys"], "yosys (apt-get install yosys)") {
        return;
    }
    // One lane with an SH level: every row of the accounting and of its control registers.
    let cfg = Config { warp_size: 1, warps: 1, .."RB_2+SH_4".parse().unwrap() };
    let g = generate(&cfg, true).unwrap();
    let cost = CostReport::new(&cfg, 1, 0).unwrap();
    let dir = std::env::temp_dir().join(format!("sms-synth-{}", std::process::id()));
    let path = tb::verilog::write(&g, &dir.join("design")).unwrap();
    let r = synth::synthesize(&g, &path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.flip_flops, cost.totals().bits_per_sm + cost.control_bits_per_sm());
    assert_eq!(r.accounting.accounted, cost.totals().bits_per_sm);
    assert!(r.logic_cells() > 0 && r.depth > 0, "{r:?}");

    // Plant a difference: lane 0's done bit is never clocked, so yosys keeps no flip-flop for it.
    let line = "        lane0_done <= ";
    let at = g.text.find(line).expect("the done register's edge");
    let end = at + g.text[at..].find('\n').unwrap() + 1;
    let bad = format!("{}{}", &g.text[..at], &g.text[end..]);
    let planted = dir.join("planted");
    std::fs::create_dir_all(&planted).unwrap();
    let path = planted.join("sms_stack_manager.v");
    std::fs::write(&path, bad).unwrap();
    let e = synth::synthesize(&g, &path).unwrap_err().to_string();
    assert!(e.contains(&format!("yosys kept {} flip-flops", r.flip_flops - 1)), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A restart design with reallocation on two lanes under yosys: its flip-flops are the bit
/// accounting's less the trail (the walk's) and less the Flush count, which it writes but never
/// reads; a register that loses its clock edge is still caught.
#[test]
fn yosys_flip_flops_of_a_restart_design_equal_the_accounting_less_what_no_output_reads() {
    if !tb::prereq::tools(&["yosys"], "yosys (apt-get install yosys)") {
        return;
    }
    let cfg = lending("RB_1+SH_2+SK+RA+RT", 2, 1);
    let g = generate(&cfg, true).unwrap();
    let cost = CostReport::new(&cfg, 1, 0).unwrap();
    let dir = std::env::temp_dir().join(format!("sms-synth-rt-{}", std::process::id()));
    let path = tb::verilog::write(&g, &dir.join("design")).unwrap();
    let r = synth::synthesize(&g, &path).unwrap_or_else(|e| panic!("{e}"));
    let flush = u64::from(cfg.widths().unwrap().flush) * 2;
    assert!(flush > 0);
    assert_eq!(r.accounting.unread, [("flush".to_string(), flush)]);
    let walk = cost.bits_per_sm(Origin::Restart);
    assert!(walk > 0);
    assert_eq!(r.flip_flops, cost.totals().bits_per_sm - walk + cost.control_bits_per_sm() - flush);

    let line = "        lane1_overflow <= ";
    let at = g.text.find(line).expect("the Overflow register's edge");
    let end = at + g.text[at..].find('\n').unwrap() + 1;
    let planted = dir.join("planted");
    std::fs::create_dir_all(&planted).unwrap();
    let path = planted.join("sms_stack_manager.v");
    std::fs::write(&path, format!("{}{}", &g.text[..at], &g.text[end..])).unwrap();
    let e = synth::synthesize(&g, &path).unwrap_err().to_string();
    assert!(e.contains(&format!("yosys kept {} flip-flops", r.flip_flops - 1)), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Co-simulates `n` cycles of `cfg` on `scene` and plants a difference: the first lane to make a
/// request of `signal`'s kind (`g_req` or `sh_req`) says read where it writes; the report must
/// name that cycle, thread and signal. Returns the module and the recorded cycles.
fn cosimulate_and_plant(cfg: Config, scene: &str, n: usize, signal: &str) -> (Generated, Vec<cosim::Cycle>) {
    let (g, cycles) = record(cfg, scene, n);
    assert_eq!(cycles.len(), n, "the run is long enough");
    let dir = std::env::temp_dir().join(format!("sms-cosim-{}-{signal}", std::process::id()));
    let r = cosim::run(&g, &g.text, &cycles, &dir.join("design")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.cycles, n);

    let layout = Layout::of(&g);
    let valid = layout.fields.iter().position(|f| f.name == format!("{signal}_valid")).unwrap();
    let (first, lane) = cycles
        .iter()
        .enumerate()
        .find_map(|(k, c)| c.records.iter().position(|r| r[valid] != 0).map(|t| (k, t)))
        .unwrap_or_else(|| panic!("a {signal} request"));
    let (warp, lane_in_warp) = (lane as u32 / cfg.warp_size, lane as u32 % cfg.warp_size);
    assert_eq!(warp, 0, "one warp slot");
    let line = format!("    assign lane{lane_in_warp}_{signal}_write = ");
    let at = g.text.find(&line).expect("the assign to plant in");
    let mut bad = g.text.clone();
    bad.insert(at + line.len(), '~');
    let e = cosim::run(&g, &bad, &cycles, &dir.join("planted")).unwrap_err();
    assert!(e.starts_with(&format!("cycle {first} ")), "{e}");
    assert!(e.contains(&format!("thread {lane} ")) && e.contains(&format!("{signal}_write")), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
    (g, cycles)
}

#[test]
fn cosimulation_agrees_every_cycle_and_catches_a_planted_difference() {
    if !icarus() {
        return;
    }
    cosimulate_and_plant(cosim_config(), "clutter", 2000, "g_req");
}

/// Random stack streams (climb, wander, drain: `run::verify::streams`) on 8-lane warps of an SH
/// design with one SH entry per stack and reallocation: most lanes overflow at once, so several
/// lanes borrow, flush and release in the same cycles, which a real scene's shallow stacks
/// rarely make. The generated Verilog agrees every cycle; a link planted wrong only when a
/// lane's Next TID changes is caught at the first cycle it changes.
#[test]
fn random_streams_cosimulation_agrees_where_lanes_borrow_in_the_same_cycles() {
    use rtl::stack_manager::StackTiming;
    use rtl::stack_unit::StandaloneStack;
    use tb::run::verify::harness::{run_cycle, CycleOpts};
    if !icarus() {
        return;
    }
    let cfg = lending("RB_1+SH_1+SK+RA", 8, 3);
    let g = generate(&cfg, true).unwrap();
    let rec = Recorder::new(Layout::of(&g), 4000);
    let out = rec.out.clone();
    let mut unit = StandaloneStack::with_timing(cfg, 30, StackTiming::Blocking, 2).unwrap();
    unit.manager_mut().set_scoreboard(Box::new(rec));
    let work = tb::run::verify::streams::warps(11, 8, cfg.warp_size, 10);
    let opts = CycleOpts { max_gap: 1, max_cycles: 200_000, ..CycleOpts::default() };
    let run = run_cycle(&mut unit, work, opts, &mut rtl::trace::NullSink).unwrap_or_else(|e| panic!("{e}"));
    let s = run.stats.stack;
    assert!(s.borrows > 50 && s.releases > 50 && s.flushes > 0, "the streams borrow and flush: {s:?}");
    let cycles = std::mem::take(&mut out.lock().unwrap().cycles);
    assert_eq!(cycles.len(), 4000, "the run is long enough");

    // Cycles in which two or more lanes' Next TID changes: borrows and releases side by side.
    let i = Layout::of(&g).fields.iter().position(|f| f.name == "next_tid").unwrap();
    let changed = |k: usize, t: usize| k > 0 && cycles[k].records[t][i] != cycles[k - 1].records[t][i];
    let together = (1..cycles.len()).filter(|&k| (0..8).filter(|&t| changed(k, t)).count() >= 2).count();
    assert!(together > 5, "lanes relink in the same cycle {together} times");
    let (first, thread) = (1..cycles.len())
        .find_map(|k| (0..8).find(|&t| changed(k, t)).map(|t| (k, t)))
        .expect("a lane's Next TID changes");
    let line = format!("        lane{thread}_next_tid <= ");
    // Flipped when the value changes, not at reset (from x): a simulation-only plant.
    let (q, d) = (format!("lane{thread}_next_tid"), "({old})");
    let wrong = plant(&g, &line, &format!("({d} === {q}) || (^{q} === 1'bx) ? {d} : {d} ^ 1"));
    cosimulate_with_plants(&g, &cycles, &[("a wrong link", wrong, first, thread, "next_tid")]);
}

/// The paper's SMS at its own 32-lane warps (one warp slot) on the `clutter` scene: spills to SH
/// and refills; the first lane to request SH made to say read where it writes is caught.
#[test]
fn sms_at_32_lanes_cosimulation_agrees_every_cycle_and_catches_a_planted_difference() {
    if !icarus() {
        return;
    }
    let n = 6000;
    let (g, cycles) =
        cosimulate_and_plant(Config { warps: 1, ..Config::sms() }, "party-partial", n, "sh_req");
    let i = Layout::of(&g).fields.iter().position(|f| f.name == "next_tid").unwrap();
    let relinks = (1..cycles.len())
        .map(|k| (0..32).filter(|&t| cycles[k].records[t][i] != cycles[k - 1].records[t][i]).count())
        .sum::<usize>();
    println!("{relinks} relinks");
    assert!(relinks > 0, "the run borrows");
}

/// An SH design with reallocation at 4-lane warps (the scene's rays regrouped): spills to SH and
/// to global memory, refills, borrowing and releases on a real scene.
#[test]
fn sh_design_cosimulation_agrees_every_cycle_and_catches_a_planted_difference() {
    if !icarus() {
        return;
    }
    cosimulate_and_plant(lending("RB_2+SH_8+SK+RA", 4, 2), "clutter", 3000, "sh_req");
}

/// A restart design without an SH level (RB_2+RT, one slot of 4-lane warps, a walk-driven run):
/// drops, restarts and re-walks agree every cycle; planted in the Verilog of the drop path, a
/// push into the full RB that keeps the oldest entry (the newest but one is lost instead), and a
/// restart that never reaches its output, are caught at their first cycle.
#[test]
fn restart_design_cosimulation_agrees_every_cycle_and_catches_a_planted_drop() {
    if !icarus() {
        return;
    }
    let cfg = Config { warp_size: 4, warps: 1, .."RB_2+RT".parse().unwrap() };
    let (g, cycles) = record_walks(cfg, 3000);
    assert_eq!(cycles.len(), 3000, "the run is long enough");
    // The first drop: a push into a full RB sets the Overflow bit.
    let (drop, t) = first_set(&g, &cycles, "overflow").expect("a drop in the recorded cycles");
    let keeps_oldest = plant(
        &g,
        &format!("        lane{t}_rb0 <= "),
        &format!("(lane{t}_cmd_kind == 2'd1 && lane{t}_rb_count == 2'd2) ? lane{t}_rb0 : {{old}}"),
    );
    let (restart, u) = first_set(&g, &cycles, "restart").expect("a restart in the recorded cycles");
    let no_restart = plant(&g, &format!("    assign lane{u}_restart = "), "1'b0");
    cosimulate_with_plants(
        &g,
        &cycles,
        &[
            ("keeps the oldest", keeps_oldest, drop, t, "rb0"),
            ("no restart", no_restart, restart, u, "restart"),
        ],
    );
}

/// A restart design with SH stacks and reallocation (RB_2+SH_4+SK+RA+RT, borrow limit 2: chains
/// of up to three stacks of four entries, short enough that the scene's walks overflow them; one
/// slot of 4-lane warps): spills to SH, borrowing, the drops of a full chain and restarts agree every
/// cycle; planted, a drop that leaves the Overflow bit clear is caught at the first drop.
#[test]
fn sh_restart_design_cosimulation_agrees_every_cycle_and_catches_a_planted_drop() {
    if !icarus() {
        return;
    }
    let cfg = lending("RB_2+SH_4+SK+RA+RT", 4, 2);
    let (g, cycles) = record_walks(cfg, 3000);
    assert_eq!(cycles.len(), 3000, "the run is long enough");
    let (drop, t) = first_set(&g, &cycles, "overflow").expect("a drop in the recorded cycles");
    assert!(first_set(&g, &cycles, "restart").is_some(), "a restart in the recorded cycles");
    let no_overflow = plant(&g, &format!("        lane{t}_overflow <= "), "1'b0");
    cosimulate_with_plants(&g, &cycles, &[("Overflow bit not set", no_overflow, drop, t, "overflow")]);
}
