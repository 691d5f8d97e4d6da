//! Co-simulation: the generated Verilog replays a real run of the Rust stack manager, cycle by
//! cycle, under Icarus Verilog, and every lane's outputs and registers are compared with the
//! model's.
//!
//! - [`Recorder`] (a [`Scoreboard`] on SM 0's stack manager) records each committed cycle's
//!   inputs (commands, completions, the memory data a completing load reads, warp loads), and
//!   every lane's outputs and registers after the edge as one bit record ([`Layout`]).
//! - [`testbench`] is a Verilog testbench that reads the inputs ([`stimulus`]), clocks the
//!   generated module once per recorded cycle, and prints the record of each lane whose
//!   registers changed or whose outputs are valid.
//! - [`compare`] reads that trace beside the model's records and names the first cycle, lane
//!   and signal where they differ.
//!
//! Records mask what a register or output does not define: RB entries past the count, program
//! slots past the occupancy, the latch while empty, an output's fields while it is not valid.

use std::fmt::Write as _;
use std::path::Path;
use std::sync::{Arc, Mutex};

use rtl::stack_manager::cycle::WriteOf;
use rtl::stack_manager::{Cmd, Scoreboard, SrcOf, StackManager, StackStep, Uop, POISON};

use super::build::{answer_code, CMD_FINISH, CMD_NONE, CMD_POP, CMD_PUSH};
use super::print::TOP;
use super::Generated;
use crate::prove::query::code;

/// A field of a lane's record: its name (the warp module's signal without `lane{j}_`) and
/// width; `reg`: a register (after the edge) rather than an output (before it).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    pub name: String,
    pub bits: u32,
    pub reg: bool,
}

/// A lane's record: outputs first, then registers, most significant first.
#[derive(Clone, Debug)]
pub struct Layout {
    pub fields: Vec<Field>,
}

impl Layout {
    pub fn of(g: &Generated) -> Layout {
        let lane0 = |n: &str| n.strip_prefix("lane0_").map(str::to_string);
        let mut fields = Vec::new();
        for p in g.circuit.outputs.iter().filter(|p| p.bits > 0) {
            if let Some(name) = lane0(&p.name).filter(|n| n != "ready") {
                fields.push(Field { name, bits: p.bits, reg: false });
            }
        }
        for r in g.circuit.regs.iter().filter(|r| r.bits > 0) {
            if let Some(name) = lane0(&r.name) {
                fields.push(Field { name, bits: r.bits, reg: true });
            }
        }
        Layout { fields }
    }

    pub fn bits(&self) -> u32 {
        self.fields.iter().map(|f| f.bits).sum()
    }
}

/// The field a record's validity mask reads, and the condition (Verilog over the lane's
/// signals `p…`; Rust over the other values by name).
/// A validity mask: the field it reads and the test on that field's value.
type Mask = (String, Box<dyn Fn(u64) -> bool>);

fn mask_of(name: &str) -> Option<Mask> {
    if let Some(k) = name.strip_prefix("rb").and_then(|x| x.parse::<u64>().ok()) {
        return Some(("rb_count".into(), Box::new(move |c| c > k)));
    }
    if let Some(rest) = name.strip_prefix("seq") {
        if let Some((k, _)) = rest.split_once('_') {
            if let Ok(k) = k.parse::<u64>() {
                return Some(("seq_step".into(), Box::new(move |c| c > k)));
            }
        }
    }
    if name == "latch" {
        return Some(("latch_valid".into(), Box::new(|v| v != 0)));
    }
    if name == "answer_value" {
        return Some(("answer".into(), Box::new(|a| a == 2)));
    }
    for port in ["sh_req", "g_req", "sh_wr", "g_wr"] {
        if name.starts_with(&format!("{port}_")) && name != format!("{port}_valid") {
            return Some((format!("{port}_valid"), Box::new(|v| v != 0)));
        }
    }
    None
}

/// The Verilog condition of [`mask_of`] on lane signals named by `sig`.
fn mask_verilog(name: &str, sig: &dyn Fn(&str) -> String) -> Option<String> {
    if let Some(k) = name.strip_prefix("rb").and_then(|x| x.parse::<u64>().ok()) {
        return Some(format!("{} > {k}", sig("rb_count")));
    }
    if let Some(rest) = name.strip_prefix("seq") {
        if let Some((k, _)) = rest.split_once('_') {
            if let Ok(k) = k.parse::<u64>() {
                return Some(format!("{} > {k}", sig("seq_step")));
            }
        }
    }
    mask_of(name).map(|(by, _)| match by.as_str() {
        "answer" => format!("{} == 2", sig("answer")),
        _ => format!("{} != 0", sig(&by)),
    })
}

/// One cycle of the testbench: the inputs, and each lane's expected record.
#[derive(Clone, Debug, Default)]
pub struct Cycle {
    pub now: u64,
    /// Warps loaded at this cycle's edge (bit per warp) and the lanes that start active.
    pub load_warps: u64,
    pub load_active: Vec<bool>,
    /// (thread, command kind, pushed value, SH completion, SH read data), threads with any.
    pub lanes: Vec<(u32, u32, u64, bool, u64)>,
    pub deq: Option<u32>,
    pub g_rdata: u64,
    /// Every lane's record after the cycle.
    pub records: Vec<Vec<u64>>,
}

/// What a recorder collects.
#[derive(Default)]
pub struct Recording {
    pub cycles: Vec<Cycle>,
    /// Records of every lane after the latest edge (loads detected against them).
    last: Vec<Vec<u64>>,
    pending: Cycle,
}

/// Records up to `limit` cycles of SM 0's stack manager.
#[derive(Clone)]
pub struct Recorder {
    pub out: Arc<Mutex<Recording>>,
    layout: Arc<Layout>,
    limit: usize,
}

impl Recorder {
    pub fn new(layout: Layout, limit: usize) -> Recorder {
        Recorder { out: Arc::default(), layout: Arc::new(layout), limit }
    }
}

/// A micro-op as the warp module's registers hold it: kind, a, b, latch flag, value.
fn uop_fields(u: Option<&Uop>, base: u32) -> [u64; 5] {
    let src = |s: &SrcOf<u64>| match *s {
        SrcOf::Value(v) => (0, v),
        SrcOf::Latch => (1, 0),
    };
    let Some(u) = u else { return [0; 5] };
    let (k, a, b, (l, v)) = match *u {
        Uop::ShLoad { stack, entry } => (code::SH_LOAD, stack - base, entry, (0, 0)),
        Uop::ShStore { stack, entry, src: s } => (code::SH_STORE, stack - base, entry, src(&s)),
        Uop::GlobalLoad { slot } => (code::GLOBAL_LOAD, slot, 0, (0, 0)),
        Uop::GlobalStore { slot, src: s } => (code::GLOBAL_STORE, slot, 0, src(&s)),
        Uop::RbBottom => (code::RB_BOTTOM, 0, 0, (0, 0)),
        Uop::Release { stack } => (code::RELEASE, stack - base, 0, (0, 0)),
    };
    [u64::from(k), u64::from(a), u64::from(b), l, v]
}

/// Thread `t`'s register values by field name.
fn reg_value(m: &StackManager, t: u32, name: &str) -> u64 {
    let ws = m.config().warp_size;
    let base = t - t % ws;
    let (s, th, rb) = (m.stack(t), m.thread(t), m.rb(t));
    let uops: Vec<&Uop> = m.pending_uops(t).collect();
    let uop = |u: Option<&Uop>, f: &str| {
        let i = ["kind", "a", "b", "latch", "value"].iter().position(|x| *x == f).expect("a micro-op field");
        uop_fields(u, base)[i]
    };
    match name {
        "top" => s.top.into(),
        "bottom" => s.bottom.into(),
        "sh_empty" => s.empty.into(),
        "idle" => s.idle.into(),
        "next_tid" => s.next_tid.into(),
        "priority" => s.priority.into(),
        "flush" => s.flush.into(),
        "overflow" => th.overflow.into(),
        "spill_ptr" => th.spill_ptr.into(),
        "done" => th.done.into(),
        "rb_count" => rb.len() as u64,
        "seq_step" => uops.len() as u64,
        "latch_valid" => m.latch(t).is_some().into(),
        "latch" => m.latch(t).unwrap_or(0),
        _ => {
            if let Some(k) = name.strip_prefix("rb").and_then(|x| x.parse::<usize>().ok()) {
                return rb.get(k).copied().unwrap_or(0);
            }
            if let Some(f) = name.strip_prefix("inflight_") {
                return uop(m.inflight_uop(t).as_ref(), f);
            }
            let (k, f) = name[3..].split_once('_').expect("a program slot field");
            uop(uops.get(k.parse::<usize>().expect("a slot")).copied(), f)
        }
    }
}

/// Thread `t`'s outputs in cycle `d` (registers `q` as it began) by field name.
fn out_value(q: &StackManager, d: &StackStep, t: u32, name: &str) -> u64 {
    let j = d.journal();
    let base = t - t % q.config().warp_size;
    let sh = j.sh_req.iter().find(|r| r.thread == t);
    let g = j.g_req.iter().find(|r| r.thread == t);
    // The SH write of a completing store: the thread whose store was in flight.
    let completes = |u: u32| j.done.contains(&u) || j.deq == Some(u);
    let sh_wr = j.writes.iter().find_map(|w| match *w {
        WriteOf::Sh { stack, entry, value } => {
            let mine = matches!(q.inflight_uop(t), Some(Uop::ShStore { stack: s, entry: e, .. }) if s == stack && e == entry);
            (mine && completes(t)).then_some((stack, entry, value))
        }
        _ => None,
    });
    let g_wr = j.writes.iter().find_map(|w| match *w {
        WriteOf::Global { thread, slot, value } if thread == t => Some((slot, value)),
        _ => None,
    });
    let cmd = j.writes.iter().find_map(|w| match *w {
        WriteOf::Cmd(u, c) if u == t => Some(c),
        _ => None,
    });
    let answer = j.answer(t);
    let b = |x: bool| u64::from(x);
    match name {
        "sh_req_valid" => b(sh.is_some()),
        "sh_req_stack" => sh.map_or(0, |r| (r.stack - base).into()),
        "sh_req_entry" => sh.map_or(0, |r| r.entry.into()),
        "sh_req_write" => sh.map_or(0, |r| b(r.write)),
        "g_req_valid" => b(g.is_some()),
        "g_req_write" => g.map_or(0, |r| b(r.write)),
        "g_req_slot" => g.map_or(0, |r| r.slot.into()),
        "sh_wr_valid" => b(sh_wr.is_some()),
        "sh_wr_stack" => sh_wr.map_or(0, |w| (w.0 - base).into()),
        "sh_wr_entry" => sh_wr.map_or(0, |w| w.1.into()),
        "sh_wr_data" => sh_wr.map_or(0, |w| w.2),
        "g_wr_valid" => b(g_wr.is_some()),
        "g_wr_slot" => g_wr.map_or(0, |w| w.0.into()),
        "g_wr_data" => g_wr.map_or(0, |w| w.1),
        "answer" => answer_code(&answer, cmd.is_some()).into(),
        "answer_value" => answer.ok().flatten().unwrap_or(0),
        "restart" => b(j.restarts.contains(&t)),
        _ => unreachable!("no output {name}"),
    }
}

/// `values` (in `layout` order) with undefined fields zeroed.
fn masked(layout: &Layout, mut values: Vec<u64>) -> Vec<u64> {
    let by_name = |n: &str, v: &[u64]| layout.fields.iter().position(|f| f.name == n).map_or(0, |i| v[i]);
    let keep: Vec<bool> = layout
        .fields
        .iter()
        .map(|f| mask_of(&f.name).is_none_or(|(by, ok)| ok(by_name(&by, &values))))
        .collect();
    for (v, k) in values.iter_mut().zip(keep) {
        if !k {
            *v = 0;
        }
    }
    values
}

/// Every lane's record: outputs from `outs` (none: zero), registers from `m`.
fn records(layout: &Layout, m: &StackManager, outs: Option<&[Vec<u64>]>) -> Vec<Vec<u64>> {
    (0..m.config().threads())
        .map(|t| {
            let v = layout
                .fields
                .iter()
                .enumerate()
                .map(|(i, f)| match (f.reg, outs) {
                    (true, _) => reg_value(m, t, &f.name),
                    (false, Some(o)) => o[t as usize][i],
                    (false, None) => 0,
                })
                .collect();
            masked(layout, v)
        })
        .collect()
}

/// Every lane's outputs in cycle `d` (zero in register fields).
fn outputs(layout: &Layout, q: &StackManager, d: &StackStep) -> Vec<Vec<u64>> {
    (0..q.config().threads())
        .map(|t| layout.fields.iter().map(|f| if f.reg { 0 } else { out_value(q, d, t, &f.name) }).collect())
        .collect()
}

impl Scoreboard for Recorder {
    fn before(&mut self, q: &StackManager, d: &StackStep) {
        if q.sm() != 0 {
            return;
        }
        let mut out = self.out.lock().expect("recording");
        if out.cycles.len() >= self.limit {
            return;
        }
        let threads = q.config().threads();
        let ws = q.config().warp_size;
        let now_regs = records(&self.layout, q, None);
        let first = out.cycles.is_empty() && out.last.is_empty();
        if first {
            // The testbench's first cycle loads every warp as the model's registers stand.
            let active = (0..threads).map(|t| !q.thread(t).done).collect();
            let all = (1u64 << q.config().warps) - 1;
            out.cycles.push(Cycle {
                load_warps: all,
                load_active: active,
                records: now_regs.clone(),
                ..Cycle::default()
            });
        } else {
            // Warps loaded since the last edge: their registers changed outside a cycle.
            let (mut warps, mut active) = (0u64, vec![false; threads as usize]);
            for t in 0..threads {
                if now_regs[t as usize] != out.last[t as usize] {
                    warps |= 1 << (t / ws);
                }
            }
            for t in 0..threads {
                active[t as usize] = warps & (1 << (t / ws)) != 0 && !q.thread(t).done;
            }
            if let Some(c) = out.cycles.last_mut() {
                c.load_warps = warps;
                c.load_active = active;
                if warps != 0 {
                    for t in 0..threads {
                        if warps & (1 << (t / ws)) != 0 {
                            let (rec, fields) = (&mut c.records[t as usize], &self.layout.fields);
                            for (i, _) in fields.iter().enumerate().filter(|x| x.1.reg) {
                                rec[i] = now_regs[t as usize][i];
                            }
                            let m = masked(&self.layout, rec.clone());
                            *rec = m;
                        }
                    }
                }
            }
        }
        let j = d.journal();
        let mut c = Cycle { now: j.now, load_active: vec![false; threads as usize], ..Cycle::default() };
        let read = |t: u32| match q.inflight_uop(t) {
            Some(Uop::ShLoad { stack, entry }) => (q.sh_entry(stack, entry), None),
            Some(Uop::GlobalLoad { slot }) => {
                (0, Some(q.global_region(t).get(slot as usize).copied().unwrap_or(POISON)))
            }
            _ => (0, None),
        };
        for t in 0..threads {
            let cmd = j.writes.iter().find_map(|w| match *w {
                WriteOf::Cmd(u, c) if u == t => Some(c),
                _ => None,
            });
            let (kind, value) = match cmd {
                Some(Cmd::Push(v)) => (CMD_PUSH, v),
                Some(Cmd::Pop) => (CMD_POP, 0),
                Some(Cmd::Finish) => (CMD_FINISH, 0),
                _ => (CMD_NONE, 0),
            };
            let done = j.done.contains(&t);
            let completes = done || j.deq == Some(t);
            let (sh, g) = if completes { read(t) } else { (0, None) };
            if let Some(g) = g {
                c.g_rdata = g;
            }
            if kind != CMD_NONE || done || sh != 0 {
                c.lanes.push((t, kind, value, done, sh));
            }
        }
        c.deq = j.deq;
        c.records = outputs(&self.layout, q, d);
        out.pending = c;
    }

    fn after(&mut self, next: &StackManager, d: &StackStep) -> Option<String> {
        if next.sm() != 0 {
            return None;
        }
        let mut out = self.out.lock().expect("recording");
        if out.cycles.len() >= self.limit {
            return None;
        }
        let _ = d;
        let mut c = std::mem::take(&mut out.pending);
        c.records = records(&self.layout, next, Some(&c.records));
        out.last = records(&self.layout, next, None);
        out.cycles.push(c);
        None
    }

    fn clone_box(&self) -> Box<dyn Scoreboard> {
        Box::new(self.clone())
    }
}

/// The stimulus file the testbench reads: per cycle one line
/// `now load_warps load_active deq_valid deq_thread g_rdata n`, then `n` lines
/// `thread cmd_kind cmd_value sh_done sh_rdata` (numbers in hex).
pub fn stimulus(cycles: &[Cycle]) -> String {
    let mut s = String::new();
    for c in cycles {
        let active = c.load_active.iter().rev().fold(String::new(), |mut a, &b| {
            a.push(if b { '1' } else { '0' });
            a
        });
        let active = if active.is_empty() { "0".to_string() } else { active };
        let _ = writeln!(
            s,
            "{:x} {:x} {active} {} {:x} {:x} {:x}",
            c.now,
            c.load_warps,
            u8::from(c.deq.is_some()),
            c.deq.unwrap_or(0),
            c.g_rdata,
            c.lanes.len()
        );
        for &(t, k, v, done, sh) in &c.lanes {
            let _ = writeln!(s, "{t:x} {k:x} {v:x} {} {sh:x}", u8::from(done));
        }
    }
    s
}

/// The testbench: drives [`TOP`] from `stimulus.txt`, writes `trace.txt`: per cycle and lane
/// whose registers changed or whose outputs are valid, `cycle thread record` (hex).
pub fn testbench(g: &Generated, layout: &Layout) -> String {
    let cfg = &g.cfg;
    let w = cfg.widths().expect("a valid configuration");
    let (t_n, ws) = (cfg.threads(), cfg.warp_size);
    let bits = layout.bits();
    let out_bits: u32 = layout.fields.iter().filter(|f| !f.reg).map(|f| f.bits).sum();
    let width = |b: u32| if b <= 1 { String::new() } else { format!("[{}:0] ", b - 1) };
    let mut s = String::new();
    let _ = writeln!(s, "`timescale 1ns/1ps\nmodule {TOP}_tb;");
    let _ = writeln!(
        s,
        "    reg clk = 0;\n    reg deq_valid = 0;\n    reg {}deq_thread = 0;",
        width(w.thread.max(1))
    );
    let _ = writeln!(
        s,
        "    reg [63:0] g_rdata = 0;\n    reg {}load_warps = 0;\n    reg {}load_active = 0;",
        width(cfg.warps),
        width(t_n)
    );
    let _ = writeln!(s, "    reg [1:0] cmd_kind [0:{}];\n    reg [63:0] cmd_value [0:{}];", t_n - 1, t_n - 1);
    let _ = writeln!(s, "    reg sh_done [0:{}];\n    reg [63:0] sh_rdata [0:{}];", t_n - 1, t_n - 1);
    let _ = writeln!(
        s,
        "    reg {}prev [0:{}];\n    reg {}outs [0:{}];",
        width(bits - out_bits),
        t_n - 1,
        width(out_bits.max(1)),
        t_n - 1
    );
    let mut conn = vec![".clk(clk)".to_string(), ".deq_valid(deq_valid)".into()];
    if w.thread > 0 {
        conn.push(".deq_thread(deq_thread)".into());
    }
    conn.extend([
        ".g_rdata(g_rdata)".to_string(),
        ".load_warps(load_warps)".into(),
        ".load_active(load_active)".into(),
    ]);
    for t in 0..t_n {
        conn.push(format!(".t{t}_cmd_kind(cmd_kind[{t}])"));
        conn.push(format!(".t{t}_cmd_value(cmd_value[{t}])"));
        conn.push(format!(".t{t}_sh_done(sh_done[{t}])"));
        conn.push(format!(".t{t}_sh_rdata(sh_rdata[{t}])"));
    }
    let _ = writeln!(s, "    {TOP} dut (\n        {}\n    );", conn.join(",\n        "));
    // Each lane's outputs and registers, masked, as the record's two halves.
    for t in 0..t_n {
        let sig = |n: &str| format!("dut.warp{}.lane{}_{n}", t / ws, t % ws);
        let part = |reg: bool| {
            let xs: Vec<String> = layout
                .fields
                .iter()
                .filter(|f| f.reg == reg)
                .map(|f| match mask_verilog(&f.name, &sig) {
                    Some(m) => format!("(({m}) ? {} : {}'d0)", sig(&f.name), f.bits),
                    None => sig(&f.name),
                })
                .collect();
            if xs.is_empty() {
                "1'b0".to_string()
            } else {
                format!("{{{}}}", xs.join(", "))
            }
        };
        let _ = writeln!(s, "    wire {}out_{t} = {};", width(out_bits.max(1)), part(false));
        let _ = writeln!(s, "    wire {}reg_{t} = {};", width(bits - out_bits), part(true));
    }
    let _ = writeln!(
        s,
        "    integer fi, fo, r, n, i, t, k, dn, cyc;\n    reg [63:0] now, v, rd, lw, dv, dt, gr;\n    reg [{}:0] la;",
        t_n.max(1) - 1
    );
    let _ = writeln!(s, "    initial begin");
    let _ = writeln!(s, "        fi = $fopen(\"stimulus.txt\", \"r\");\n        fo = $fopen(\"trace.txt\", \"w\");\n        cyc = 0;");
    let _ = writeln!(s, "        for (t = 0; t < {t_n}; t = t + 1) prev[t] = 0;");
    let _ = writeln!(
        s,
        "        while ($fscanf(fi, \"%h %h %b %h %h %h %h\\n\", now, lw, la, dv, dt, gr, n) == 7) begin"
    );
    let _ = writeln!(s, "            for (t = 0; t < {t_n}; t = t + 1) begin cmd_kind[t] = 0; cmd_value[t] = 0; sh_done[t] = 0; sh_rdata[t] = 0; end");
    let _ = writeln!(s, "            for (i = 0; i < n; i = i + 1) begin");
    let _ = writeln!(s, "                r = $fscanf(fi, \"%h %h %h %h %h\\n\", t, k, v, dn, rd);");
    let _ = writeln!(s, "                cmd_kind[t] = k; cmd_value[t] = v; sh_done[t] = dn; sh_rdata[t] = rd;\n            end");
    let _ = writeln!(
        s,
        "            load_warps = lw; load_active = la; deq_valid = dv; deq_thread = dt; g_rdata = gr;"
    );
    let _ = writeln!(s, "            #1;");
    for t in 0..t_n {
        let _ = writeln!(s, "            outs[{t}] = out_{t};");
    }
    let _ = writeln!(s, "            clk = 1; #1; clk = 0; #1;");
    for t in 0..t_n {
        let _ = writeln!(
            s,
            "            if (reg_{t} !== prev[{t}] || outs[{t}] != 0 || cyc == 0) begin $fdisplay(fo, \"%0d {t} %h\", cyc, {{outs[{t}], reg_{t}}}); prev[{t}] = reg_{t}; end"
        );
    }
    let _ = writeln!(
        s,
        "            cyc = cyc + 1;\n        end\n        $fclose(fo);\n        $finish;\n    end\nendmodule"
    );
    s
}

/// A field's value in a trace record; `None`: unknown (`x` or `z` bits).
fn fields_of(layout: &Layout, hex: &str) -> Result<Vec<Option<u64>>, String> {
    let mut bits: Vec<Option<bool>> = Vec::with_capacity(hex.len() * 4);
    for ch in hex.chars() {
        match ch.to_digit(16) {
            Some(d) => bits.extend((0..4).rev().map(|i| Some(d >> i & 1 == 1))),
            None if "xXzZ".contains(ch) => bits.extend([None; 4]),
            None => return Err(format!("trace: '{hex}' is not a hex record")),
        }
    }
    let total = layout.bits() as usize;
    if bits.len() < total {
        return Err(format!("trace: a record of {} bits, expected {total}", bits.len()));
    }
    let mut at = bits.len() - total;
    let mut out = Vec::new();
    for f in &layout.fields {
        let mut v = Some(0u64);
        for b in &bits[at..at + f.bits as usize] {
            v = v.zip(*b).map(|(v, b)| v << 1 | u64::from(b));
        }
        at += f.bits as usize;
        out.push(v);
    }
    Ok(out)
}

/// The first difference between the model's `cycles` and the testbench's `trace`:
/// "cycle k (simulation cycle n), thread t (warp w, lane j): signal: verilog …, model …".
pub fn compare(layout: &Layout, cycles: &[Cycle], warp_size: u32, trace: &str) -> Result<(), String> {
    let mut lines: Vec<Vec<(u32, Vec<Option<u64>>)>> = vec![Vec::new(); cycles.len()];
    for line in trace.lines() {
        let mut it = line.split_whitespace();
        let (Some(k), Some(t), Some(hex)) = (it.next(), it.next(), it.next()) else {
            return Err(format!("trace: malformed line '{line}'"));
        };
        let k: usize = k.parse().map_err(|_| format!("trace: malformed line '{line}'"))?;
        let t: u32 = t.parse().map_err(|_| format!("trace: malformed line '{line}'"))?;
        if k >= cycles.len() {
            return Err(format!("trace: cycle {k} past the {} recorded", cycles.len()));
        }
        lines[k].push((t, fields_of(layout, hex)?));
    }
    let threads = cycles.first().map_or(0, |c| c.records.len());
    let mut verilog: Vec<Vec<Option<u64>>> = vec![vec![None; layout.fields.len()]; threads];
    let mut model_prev: Vec<Vec<u64>> = vec![vec![0; layout.fields.len()]; threads];
    for (k, c) in cycles.iter().enumerate() {
        for t in 0..threads {
            let exp = &c.records[t];
            let line = lines[k].iter().find(|x| x.0 == t as u32).map(|x| &x.1);
            let regs_changed =
                layout.fields.iter().enumerate().any(|(i, f)| f.reg && exp[i] != model_prev[t][i]);
            let outs = layout.fields.iter().enumerate().any(|(i, f)| !f.reg && exp[i] != 0);
            let got: Vec<Option<u64>> = match line {
                Some(l) => l.clone(),
                None => layout
                    .fields
                    .iter()
                    .enumerate()
                    .map(|(i, f)| if f.reg { verilog[t][i] } else { Some(0) })
                    .collect(),
            };
            if line.is_some() || regs_changed || outs || k == 0 {
                // The reset cycle's outputs come from registers not yet loaded.
                for (i, f) in layout.fields.iter().enumerate().filter(|x| k > 0 || x.1.reg) {
                    if got[i] != Some(exp[i]) {
                        let v = got[i].map_or("x".to_string(), |v| format!("{v:#x}"));
                        let when =
                            if k == 0 { "reset".to_string() } else { format!("simulation cycle {}", c.now) };
                        return Err(format!(
                            "cycle {k} ({when}), thread {t} (warp {}, lane {}): {}{}: verilog {v}, model {:#x}",
                            t as u32 / warp_size,
                            t as u32 % warp_size,
                            f.name,
                            if f.reg { "" } else { " (output)" },
                            exp[i]
                        ));
                    }
                }
            }
            for (i, _) in layout.fields.iter().enumerate().filter(|x| x.1.reg) {
                verilog[t][i] = got[i];
                model_prev[t][i] = exp[i];
            }
        }
    }
    Ok(())
}

/// What a co-simulation did.
#[derive(Clone, Debug)]
pub struct CosimReport {
    pub cycles: usize,
    pub lanes: u32,
    pub seconds: f64,
}

/// Writes the module (`text`: [`Generated::text`], or a variant of it), the testbench and the
/// stimulus of `cycles` under `dir`, simulates them with Icarus Verilog and compares.
pub fn run(g: &Generated, text: &str, cycles: &[Cycle], dir: &Path) -> Result<CosimReport, String> {
    let layout = Layout::of(g);
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let write = |name: &str, body: &str| {
        std::fs::write(dir.join(name), body).map_err(|e| format!("{}: {e}", dir.join(name).display()))
    };
    write(&format!("{TOP}.v"), text)?;
    write(&format!("{TOP}_tb.v"), &testbench(g, &layout))?;
    write("stimulus.txt", &stimulus(cycles))?;
    let start = std::time::Instant::now();
    let tool = |cmd: &mut std::process::Command, what: &str| -> Result<(), String> {
        let out = cmd.current_dir(dir).output().map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => {
                format!("{what} is not on PATH: install Icarus Verilog (apt-get install iverilog)")
            }
            _ => format!("{what}: {e}"),
        })?;
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            let tail: Vec<&str> = err.lines().rev().take(10).collect();
            return Err(format!(
                "{what} failed in {}:\n{}",
                dir.display(),
                tail.into_iter().rev().collect::<Vec<_>>().join("\n")
            ));
        }
        Ok(())
    };
    tool(
        std::process::Command::new("iverilog").args([
            "-g2005",
            "-o",
            "sim.vvp",
            &format!("{TOP}_tb.v"),
            &format!("{TOP}.v"),
        ]),
        "iverilog",
    )?;
    tool(std::process::Command::new("vvp").args(["-n", "sim.vvp"]), "vvp")?;
    let trace = std::fs::read_to_string(dir.join("trace.txt")).map_err(|e| format!("trace.txt: {e}"))?;
    compare(&layout, cycles, g.cfg.warp_size, &trace)?;
    Ok(CosimReport { cycles: cycles.len(), lanes: g.cfg.threads(), seconds: start.elapsed().as_secs_f64() })
}
