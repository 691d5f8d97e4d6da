//! The generated Verilog: its registers against the bit accounting, its refusals, and a
//! co-simulation against the Rust stack manager on a real scene that also catches a planted
//! difference.

use rtl::config::Config;
use tb::verilog::cosim::{self, Layout, Recorder};
use tb::verilog::{generate, synth, Generated};

/// Configuration of the co-simulation: a real scene's warps are 32 lanes; one warp slot keeps
/// the module small enough for Icarus Verilog in CI.
fn cosim_config() -> Config {
    Config { warps: 1, ..Config::default() }
}

/// `cycles` cycles of SM 0's stack manager on the `clutter` scene, recorded for co-simulation.
fn record(cfg: Config, cycles: usize) -> (Generated, Vec<cosim::Cycle>) {
    let g = generate(&cfg, true).unwrap();
    let rec = Recorder::new(Layout::of(&g), cycles);
    let out = rec.out.clone();
    let hw = tb::hw::preset("paper").unwrap();
    let gpu = tb::testing::gpu(cfg, &hw).with_scoreboard(&|| Box::new(rec.clone()));
    tb::testing::report(gpu, tb::testing::scene_jobs("clutter", 16), "co-simulated run");
    let cycles = std::mem::take(&mut out.lock().unwrap().cycles);
    (g, cycles)
}

#[test]
fn declared_registers_match_the_bit_accounting_field_by_field() {
    for name in ["RB_8", "RB_16", "RB_8+SH_8", "SMS", "RB_2+SH_8+SK+RA"] {
        let cfg: Config = name.parse().unwrap();
        let g = generate(&cfg, true).unwrap();
        let (accounted, omitted) = synth::cross_check(&g, g.total_register_bits()).unwrap();
        let cost = tb::report::cost::CostReport::new(&cfg, 1, 0).unwrap();
        assert_eq!(accounted, cost.totals().bits_per_sm, "{name}");
        let omitted: u64 = omitted.iter().map(|x| x.1).sum();
        assert_eq!(accounted + omitted, g.total_register_bits(), "{name}");
        // The model's sequencer holds its program, not a step: those registers are named.
        assert!(omitted > 0, "{name}");
    }
}

#[test]
fn unbounded_rb_is_refused_in_one_line() {
    let e = generate(&"RB_FULL".parse().unwrap(), true).err().unwrap();
    assert!(e.contains("RB_FULL") && !e.contains('\n'), "{e}");
}

#[test]
fn a_wrong_flip_flop_count_fails_naming_both_counts() {
    let g = generate(&Config { warp_size: 4, warps: 1, ..Config::default() }, true).unwrap();
    let e = synth::cross_check(&g, g.total_register_bits() - 1).unwrap_err().to_string();
    assert!(e.contains("flip-flops") && e.contains(&g.total_register_bits().to_string()), "{e}");
}

#[test]
fn cosimulation_agrees_every_cycle_and_catches_a_planted_difference() {
    if !tb::prereq::tools(&["iverilog", "vvp"], "Icarus Verilog (apt-get install iverilog)") {
        return;
    }
    let (g, cycles) = record(cosim_config(), 2000);
    assert_eq!(cycles.len(), 2000, "the run is long enough");
    let dir = std::env::temp_dir().join(format!("sms-cosim-{}", std::process::id()));
    let r = cosim::run(&g, &g.text, &cycles, &dir.join("design")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(r.cycles, 2000);

    // Plant a difference: the first lane to make a global request says read where it writes.
    let layout = Layout::of(&g);
    let valid = layout.fields.iter().position(|f| f.name == "g_req_valid").unwrap();
    let (first, lane) = cycles
        .iter()
        .enumerate()
        .find_map(|(k, c)| c.records.iter().position(|r| r[valid] != 0).map(|t| (k, t)))
        .expect("a global request");
    let line = format!("    assign lane{lane}_g_req_write = ");
    let at = g.text.find(&line).expect("the assign to plant in");
    let mut bad = g.text.clone();
    bad.insert(at + line.len(), '~');
    let e = cosim::run(&g, &bad, &cycles, &dir.join("planted")).unwrap_err();
    assert!(e.starts_with(&format!("cycle {first} ")), "{e}");
    assert!(e.contains(&format!("thread {lane} ")) && e.contains("g_req_write"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
