//! The generated Verilog: co-simulated against the Rust stack manager on a real scene.

use rtl::config::Config;
use tb::verilog::cosim::{self, Layout, Recorder};

fn record(cfg: Config, cycles: usize) -> (tb::verilog::Generated, Vec<cosim::Cycle>) {
    let g = tb::verilog::generate(&cfg, true).unwrap();
    let rec = Recorder::new(Layout::of(&g), cycles);
    let out = rec.out.clone();
    let hw = tb::hw::preset("paper").unwrap();
    let gpu = tb::testing::gpu(cfg, &hw).with_scoreboard(&|| Box::new(rec.clone()));
    let jobs = tb::testing::scene_jobs("clutter", 16);
    tb::testing::report(gpu, jobs, "co-simulated run");
    let cycles = std::mem::take(&mut out.lock().unwrap().cycles);
    (g, cycles)
}

#[test]
fn scratch_cosim() {
    let name = std::env::var("CFG").unwrap_or("SMS".into());
    let n: usize = std::env::var("N").map(|x| x.parse().unwrap()).unwrap_or(2000);
    let mut cfg: Config = name.parse().unwrap();
    cfg.warp_size = std::env::var("WS").map(|x| x.parse().unwrap()).unwrap_or(32);
    cfg.warps = std::env::var("WARPS").map(|x| x.parse().unwrap()).unwrap_or(4);
    let t = std::time::Instant::now();
    let (g, cycles) = record(cfg, n);
    eprintln!("recorded {} cycles, generated {} bytes in {:?}", cycles.len(), g.text.len(), t.elapsed());
    let dir = std::path::PathBuf::from("/tmp/vscratch/cosim");
    let r = cosim::run(&g, &g.text, &cycles, &dir);
    eprintln!("{r:?} in {:?}", t.elapsed());
}
