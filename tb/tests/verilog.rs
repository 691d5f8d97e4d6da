//! The generated Verilog: its registers against the bit accounting, its refusals, and a
//! co-simulation against the Rust stack manager on a real scene that also catches a planted
//! difference.

use rtl::config::Config;
use tb::report::cost::CostReport;
use tb::verilog::cosim::{self, Layout, Recorder};
use tb::verilog::{generate, synth, Generated};

/// Configuration of the co-simulation: a real scene's warps are 32 lanes; one warp slot keeps
/// the module small enough for Icarus Verilog in CI.
fn cosim_config() -> Config {
    Config { warps: 1, ..Config::default() }
}

/// `cycles` cycles of SM 0's stack manager on the `clutter` scene, recorded for co-simulation.
/// The scene's 32-ray warps are regrouped into warps of `cfg.warp_size` rays, in order.
fn record(cfg: Config, cycles: usize) -> (Generated, Vec<cosim::Cycle>) {
    let g = generate(&cfg, true).unwrap();
    let rec = Recorder::new(Layout::of(&g), cycles);
    let out = rec.out.clone();
    let hw = tb::hw::preset("paper").unwrap();
    let gpu = tb::testing::gpu(cfg, &hw).with_scoreboard(&|| Box::new(rec.clone()));
    let jobs = tb::testing::scene_jobs("clutter", 16).into_iter().flat_map(|j| {
        let lanes: Vec<_> = j.lanes.chunks(cfg.warp_size as usize).map(|c| c.to_vec()).collect();
        lanes.into_iter().map(|lanes| rtl::ray_op::WarpJob { lanes, walk: None })
    });
    tb::testing::report(gpu, jobs, "co-simulated run");
    let cycles = std::mem::take(&mut out.lock().unwrap().cycles);
    (g, cycles)
}

#[test]
fn declared_registers_match_the_bit_accounting_row_by_row() {
    for name in ["RB_8", "RB_16", "RB_8+SH_8", "SMS", "RB_2+SH_8+SK+RA"] {
        let cfg: Config = name.parse().unwrap();
        let g = generate(&cfg, true).unwrap();
        let a = synth::cross_check(&g, g.total_register_bits()).unwrap();
        let cost = CostReport::new(&cfg, 1, 0).unwrap();
        assert_eq!(a.accounted, cost.totals().bits_per_sm, "{name}");
        assert_eq!(a.total(), g.total_register_bits(), "{name}");
        assert_eq!(a.total() - a.accounted, cost.control_bits_per_sm(), "{name}");
        // The model's sequencer holds its program: the control rows name it.
        assert!(a.control.iter().any(|(r, bits)| r == "seq_program" && *bits > 0), "{name}: {:?}", a.control);
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

/// Co-simulates `n` cycles of `cfg` and plants a difference: the first lane to make a request
/// of `signal`'s kind (`g_req` or `sh_req`) says read where it writes; the report must name that
/// cycle, thread and signal.
fn cosimulate_and_plant(cfg: Config, n: usize, signal: &str) {
    let (g, cycles) = record(cfg, n);
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
}

#[test]
fn cosimulation_agrees_every_cycle_and_catches_a_planted_difference() {
    if !tb::prereq::tools(&["iverilog", "vvp"], "Icarus Verilog (apt-get install iverilog)") {
        return;
    }
    cosimulate_and_plant(cosim_config(), 2000, "g_req");
}

/// An SH design with reallocation at 4-lane warps (the scene's rays regrouped): spills to SH and
/// to global memory, refills, borrowing and releases on a real scene.
#[test]
fn sh_design_cosimulation_agrees_every_cycle_and_catches_a_planted_difference() {
    if !tb::prereq::tools(&["iverilog", "vvp"], "Icarus Verilog (apt-get install iverilog)") {
        return;
    }
    let cfg: Config = "RB_2+SH_8+SK+RA".parse().unwrap();
    let mut cfg = Config { warp_size: 4, warps: 1, ..cfg };
    if let Some(ra) = cfg.policy.realloc_mut() {
        ra.borrow_limit = 2;
    }
    cosimulate_and_plant(cfg, 3000, "sh_req");
}
