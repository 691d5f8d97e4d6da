//! The stack manager as synthesizable Verilog-2005, printed from the same description the
//! simulator runs and `sms prove` proves ([`build`]: the cycle on symbolic terms; [`print`]:
//! the terms as Verilog), synthesized by yosys ([`synth`]) and co-simulated against the Rust
//! model by Icarus Verilog ([`cosim`]). docs/verilog.md describes the flow and its limits.

pub mod build;
pub mod cosim;
pub mod formal;
pub mod print;
pub mod synth;

use std::path::{Path, PathBuf};

use rtl::config::{Config, Overflow};

use crate::digest::fnv1a64;
use crate::run::provenance::ModelId;

/// Generated Verilog of one configuration.
pub struct Generated {
    pub cfg: Config,
    /// Global stores stay in flight until acknowledged (the blocking timing).
    pub acked: bool,
    /// The whole file: header, warp module, top module.
    pub text: String,
    /// FNV-1a of the modules' text (the header excluded).
    pub hash: String,
    pub circuit: build::Circuit,
}

impl Generated {
    /// Register bits the top module declares, by the cost report's row, over every warp.
    pub fn register_bits(&self) -> Vec<(&'static str, u64)> {
        by_row(&self.cfg, self.circuit.regs.iter())
    }

    /// Register bits no output depends on, by row, over every warp: written but never read (a
    /// restart design with reallocation counts its flushes but never compares the count with
    /// the limit). Synthesis removes their flip-flops (yosys's `opt_clean` keeps the logic an
    /// output depends on).
    pub fn unread_register_bits(&self) -> Vec<(&'static str, u64)> {
        let c = &self.circuit;
        let mut seen = vec![false; c.sym.size()];
        let mut live = vec![false; c.regs.len()];
        let mut stack: Vec<u32> = c.outputs.iter().map(|p| p.t.id()).collect();
        loop {
            while let Some(i) = stack.pop() {
                if !std::mem::replace(&mut seen[i as usize], true) {
                    c.sym.node(i).push_operands(&mut stack);
                }
            }
            // A register an output depends on reads its next value: its cone is live too.
            for (k, r) in c.regs.iter().enumerate() {
                if r.bits > 0 && !live[k] && seen[r.q.id() as usize] {
                    live[k] = true;
                    stack.push(r.d.id());
                }
            }
            if stack.is_empty() {
                break;
            }
        }
        let unread = c.regs.iter().zip(&live).filter(|(r, &l)| r.bits > 0 && !l).map(|x| x.0);
        by_row(&self.cfg, unread)
    }

    /// Every register bit of the top module.
    pub fn total_register_bits(&self) -> u64 {
        self.register_bits().iter().map(|x| x.1).sum()
    }
}

/// Bits of `regs` by the cost report's row, over every warp.
fn by_row<'a>(cfg: &Config, regs: impl Iterator<Item = &'a build::Reg>) -> Vec<(&'static str, u64)> {
    let mut out: Vec<(&'static str, u64)> = Vec::new();
    for r in regs {
        let bits = u64::from(r.bits) * u64::from(cfg.warps);
        match out.iter_mut().find(|x| x.0 == r.field) {
            Some(x) => x.1 += bits,
            None => out.push((r.field, bits)),
        }
    }
    out
}

/// The configuration in one line, as the header and reports state it.
pub fn describe(cfg: &Config, acked: bool) -> String {
    let ra = cfg.realloc().map_or(String::new(), |r| {
        format!(", borrow limit {}, flush limit {}", r.borrow_limit, r.flush_limit)
    });
    let rt = if cfg.overflow == Overflow::Drop { ", overflow dropped (restart)" } else { "" };
    format!(
        "{}, warp size {}, warps {}{ra}{rt}, global stores {}",
        cfg.name(),
        cfg.warp_size,
        cfg.warps,
        if acked { "acknowledged (blocking timing)" } else { "posted (overlapped timing)" }
    )
}

/// Generates the stack manager of `cfg` (global stores acknowledged when `acked`).
pub fn generate(cfg: &Config, acked: bool) -> Result<Generated, String> {
    cfg.validate().map_err(|e| e.to_string())?;
    if let rtl::config::ShPolicy::Group { lanes, .. } = cfg.policy {
        return Err(format!(
            "the Verilog printer emits the paper's policy (RA); reallocation within groups of {lanes} lanes (RA_{lanes}) is simulated and proved but not printed"
        ));
    }
    let circuit = build::warp(cfg, acked)?;
    let body = format!("{}\n{}", print::warp_module(&circuit), print::top_module(cfg, &circuit));
    let hash = format!("{:016x}", fnv1a64(body.as_bytes()));
    let model = ModelId::current();
    let overflow = match cfg.overflow {
        Overflow::Spill => "",
        Overflow::Drop => {
            "// Overflow: dropped (a restart design). When its last on-chip level overflows, a stack\n\
             // drops its oldest entry (with reallocation, a chain's oldest member drops its entries)\n\
             // and sets the thread's Overflow bit; nothing goes to global memory (no spill pointer).\n\
             // A pop of an empty stack whose Overflow bit is set is answered Restart (output\n\
             // `restart`, `answer` accepted) and clears the bit: the walk restarts from the root.\n"
        }
    };
    let header = format!(
        "// {top}: the SMS stack manager of one RT unit, synthesizable Verilog-2005.\n\
         // Generated by `sms verilog` from the stack manager's cycle description\n\
         // (rtl/src/stack_manager/cycle.rs, policy.rs), the code the simulator runs and `sms prove`\n\
         // proves, run on symbolic terms lane by lane (tb/src/verilog/build.rs). Do not edit.\n\
         // Configuration: {}.\n\
         {overflow}\
         // Model: sms {} (commit {}); modules' FNV-1a hash {hash}.\n\
         // Paths explored: {} over {} control shapes; {} terms.\n\n",
        describe(cfg, acked),
        model.version,
        model.commit.unwrap_or("none"),
        circuit.paths,
        circuit.shapes,
        circuit.sym.size(),
        top = print::TOP,
    );
    Ok(Generated { cfg: *cfg, acked, text: header + &body, hash, circuit })
}

/// Writes `g` to `dir/sms_stack_manager.v`; returns the path.
pub fn write(g: &Generated, dir: &Path) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let path = dir.join(format!("{}.v", print::TOP));
    std::fs::write(&path, &g.text)?;
    Ok(path)
}
