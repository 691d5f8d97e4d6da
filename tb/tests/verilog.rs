use rtl::config::{Config, Realloc};

#[test]
fn scratch_sizes() {
    for name in ["RB_8", "RB_8+SH_8", "RB_8+SH_8+SK+RA"] {
        for ws in [4u32, 8, 16, 32] {
            let mut cfg = Config { warp_size: ws, ..name.parse::<Config>().unwrap() };
            if let Some(r) = cfg.realloc { cfg.realloc = Some(Realloc { borrow_limit: r.borrow_limit.min(ws - 1), ..r }); }
            let t = std::time::Instant::now();
            let c = tb::verilog::build::warp(&cfg, true).unwrap();
            eprintln!("{name} ws={ws}: shapes {} paths {} max plan paths {} nodes {} in {:?}", c.shapes, c.paths, c.max_plan_paths, c.sym.size(), t.elapsed());
        }
    }
}
