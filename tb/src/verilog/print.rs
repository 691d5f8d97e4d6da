//! Verilog-2005 text of a [`Circuit`]: the warp module (its terms as `wire`s, its registers as
//! one clocked block that only does `q <= d`) and the stack manager's top module, which holds
//! one warp module per warp slot and numbers threads, stacks and the response FIFO's thread
//! across them.

use std::collections::HashMap;
use std::fmt::Write as _;

use rtl::config::Config;

use super::build::{Circuit, T};
use crate::prove::sym::{Node, Sort, B};

/// The properties of a formal block ([`super::formal`] builds them): input-protocol assumptions
/// and asserted clauses, each named, each one term over the warp module's registers and inputs.
pub struct Checks {
    pub assumes: Vec<(String, B)>,
    pub asserts: Vec<(String, B)>,
}

/// The warp module's name.
pub const WARP: &str = "sms_warp";
/// The top module's name.
pub const TOP: &str = "sms_stack_manager";

fn width(bits: u32) -> String {
    if bits == 1 {
        String::new()
    } else {
        format!("[{}:0] ", bits - 1)
    }
}

fn sort_bits(s: Sort) -> u32 {
    match s {
        Sort::Bool => 1,
        Sort::Word => 32,
        Sort::Val => 64,
    }
}

/// How term `i` is referred to; `narrow` names variables narrower than their sort (read through
/// a zero-extending `_w` wire).
fn name(c: &Circuit, narrow: &HashMap<String, u32>, i: u32) -> String {
    match c.sym.node(i) {
        Node::Bool(b) => format!("1'b{}", u8::from(*b)),
        Node::Word(w) => format!("32'd{w}"),
        Node::Val(v) => format!("64'h{v:x}"),
        Node::Var(_, n) if narrow.contains_key(n) => format!("{n}_w"),
        Node::Var(_, n) => n.clone(),
        _ => format!("t{i}"),
    }
}

/// The warp module's text.
pub fn warp_module(c: &Circuit) -> String {
    warp_module_with(c, None)
}

/// The warp module's text, with `checks` as its `ifdef FORMAL` block when given: the
/// assumptions and asserted clauses as named wires (`fa_<k>`, `wf_<k>`), checked from the
/// cycle after the first, which loads the warp.
pub fn warp_module_with(c: &Circuit, checks: Option<&Checks>) -> String {
    let mut narrow = HashMap::new();
    let mut declared = Vec::new();
    for r in c.regs.iter().filter(|r| r.bits > 0) {
        declared.push((r.name.clone(), r.bits, r.q.sort()));
    }
    for p in c.inputs.iter().filter(|p| p.bits > 0) {
        declared.push((p.name.clone(), p.bits, p.t.sort()));
    }
    for (n, bits, sort) in &declared {
        if *bits < sort_bits(*sort) {
            narrow.insert(n.clone(), *bits);
        }
    }
    let roots: Vec<u32> = c
        .regs
        .iter()
        .filter(|r| r.bits > 0)
        .map(|r| r.d.id())
        .chain(c.outputs.iter().map(|p| p.t.id()))
        .chain(checks.iter().flat_map(|k| k.assumes.iter().chain(&k.asserts).map(|x| x.1 .0)))
        .collect();
    let need = reachable(c, &roots);
    let mut s = String::new();
    let _ = writeln!(s, "module {WARP} (");
    let mut ports = vec!["    input wire clk".to_string()];
    for p in c.inputs.iter().filter(|p| p.bits > 0) {
        ports.push(format!("    input wire {}{}", width(p.bits), p.name));
    }
    for p in c.outputs.iter().filter(|p| p.bits > 0) {
        ports.push(format!("    output wire {}{}", width(p.bits), p.name));
    }
    let _ = writeln!(s, "{}\n);", ports.join(",\n"));
    let _ = writeln!(s, "\n    // Registers (q), at their widths.");
    for r in c.regs.iter().filter(|r| r.bits > 0) {
        let _ = writeln!(s, "    reg {}{};", width(r.bits), r.name);
    }
    let _ = writeln!(s, "\n    // Narrow registers and inputs, zero-extended to the description's words.");
    for (n, _, sort) in &declared {
        if let Some(&b) = narrow.get(n) {
            let full = sort_bits(*sort);
            let _ = writeln!(s, "    wire [{}:0] {n}_w = {{{}'d0, {n}}};", full - 1, full - b);
        }
    }
    let _ = writeln!(s, "\n    // Next-state and output logic.");
    for (i, &needed) in need.iter().enumerate() {
        if !needed {
            continue;
        }
        let i = i as u32;
        let n = |j: &u32| name(c, &narrow, *j);
        let e = match c.sym.node(i) {
            Node::Not(a) => format!("~{}", n(a)),
            Node::And(a, b) => format!("{} & {}", n(a), n(b)),
            Node::Or(a, b) => format!("{} | {}", n(a), n(b)),
            Node::Add(a, b) => format!("{} + {}", n(a), n(b)),
            Node::Sub(a, b) => format!("{} - {}", n(a), n(b)),
            Node::Div(a, b) => format!("{} / {}", n(a), n(b)),
            Node::Rem(a, b) => format!("{} % {}", n(a), n(b)),
            Node::Mask(a, b) => format!("{} & {}", n(a), n(b)),
            Node::Shr(a, b) => format!("{} >> {}", n(a), n(b)),
            Node::Eq(a, b) => format!("{} == {}", n(a), n(b)),
            Node::Lt(a, b) => format!("{} < {}", n(a), n(b)),
            Node::Ite(_, k, a, b) => format!("{} ? {} : {}", n(k), n(a), n(b)),
            _ => continue,
        };
        let bits = sort_bits(c.sym.sort(i));
        let _ = writeln!(s, "    wire {}t{i} = {e};", width(bits));
    }
    let _ = writeln!(s, "\n    // Outputs.");
    for p in c.outputs.iter().filter(|p| p.bits > 0) {
        let _ = writeln!(s, "    assign {} = {};", p.name, slice(c, &narrow, p.t, p.bits));
    }
    let _ = writeln!(s, "\n    // The clock edge.\n    always @(posedge clk) begin");
    for r in c.regs.iter().filter(|r| r.bits > 0) {
        let _ = writeln!(s, "        {} <= {};", r.name, slice(c, &narrow, r.d, r.bits));
    }
    let _ = writeln!(s, "    end");
    if let Some(k) = checks {
        formal_block(&mut s, c, &narrow, k);
    }
    let _ = writeln!(s, "endmodule");
    s
}

/// The `ifdef FORMAL` block of [`warp_module_with`]. The registers start undefined: the first
/// cycle loads the warp (`load`), and the clauses hold from the second on.
fn formal_block(s: &mut String, c: &Circuit, narrow: &HashMap<String, u32>, k: &Checks) {
    let _ = writeln!(s, "\n`ifdef FORMAL");
    let _ = writeln!(s, "    // The first cycle loads the warp; the clauses hold from the next one on.");
    let _ = writeln!(s, "    reg f_started = 1'b0;\n    always @(posedge clk) f_started <= 1'b1;");
    let _ = writeln!(s, "    always @* if (!f_started) assume(load);");
    let _ = writeln!(s, "\n    // Input protocol.");
    for (i, (what, b)) in k.assumes.iter().enumerate() {
        let _ = writeln!(s, "    // {what}\n    wire fa_{i} = {};", name(c, narrow, b.0));
        let _ = writeln!(s, "    always @* assume(fa_{i});");
    }
    let _ = writeln!(s, "\n    // Asserted clauses.");
    for (i, (what, b)) in k.asserts.iter().enumerate() {
        let _ = writeln!(s, "    // {what}\n    (* keep *) wire wf_{i} = {};", name(c, narrow, b.0));
        let _ = writeln!(s, "    always @* if (f_started) assert(wf_{i});");
    }
    let _ = writeln!(s, "`endif");
}

/// Term `t` cut to its low `bits`.
fn slice(c: &Circuit, narrow: &HashMap<String, u32>, t: T, bits: u32) -> String {
    let n = name(c, narrow, t.id());
    if bits == sort_bits(t.sort()) {
        return n;
    }
    match c.sym.node(t.id()) {
        // A constant is cut by its width; a variable by its declared register.
        Node::Word(w) => format!("{bits}'d{}", u64::from(*w) & ((1u64 << bits) - 1)),
        Node::Val(v) => format!("{bits}'h{:x}", v & ((1u64 << bits) - 1)),
        Node::Var(_, v) if narrow.get(v) == Some(&bits) => v.clone(),
        _ => format!("{n}[{}:0]", bits - 1),
    }
}

/// Which terms `roots` depend on.
fn reachable(c: &Circuit, roots: &[u32]) -> Vec<bool> {
    let mut need = vec![false; c.sym.size()];
    let mut stack = roots.to_vec();
    while let Some(i) = stack.pop() {
        if std::mem::replace(&mut need[i as usize], true) {
            continue;
        }
        c.sym.node(i).push_operands(&mut stack);
    }
    need
}

/// Warp-level inputs of the warp module, which the top module drives from its own.
const WARP_INPUTS: [&str; 4] = ["deq_valid", "deq_lane", "g_rdata", "load"];

/// The top module's text: `cfg.warps` warp modules; per-thread ports `t{thread}_…`.
pub fn top_module(cfg: &Config, c: &Circuit) -> String {
    let w = cfg.widths().expect("a valid configuration");
    let ws = cfg.warp_size;
    let warp_bits = w.thread - w.tid;
    let mut s = String::new();
    let mut ports = vec!["    input wire clk".to_string()];
    ports.push("    input wire deq_valid".into());
    if w.thread > 0 {
        ports.push(format!("    input wire {}deq_thread", width(w.thread)));
    }
    ports.push(format!("    input wire {}g_rdata", width(w.entry)));
    // A warp load: the warps loaded at this edge, and which of their lanes start active.
    ports.push(format!("    input wire {}load_warps", width(cfg.warps)));
    ports.push(format!("    input wire {}load_active", width(cfg.threads())));
    let lane_of =
        |n: &str| n.split_once('_').map(|(l, rest)| (l[4..].parse::<u32>().unwrap(), rest.to_string()));
    let is_stack = |f: &str| f.ends_with("_stack");
    for wp in 0..cfg.warps {
        for p in c.inputs.iter().filter(|p| p.bits > 0 && !WARP_INPUTS.contains(&p.name.as_str())) {
            let (j, f) = lane_of(&p.name).expect("a lane input");
            if f == "load_active" {
                continue;
            }
            ports.push(format!("    input wire {}t{}_{f}", width(p.bits), wp * ws + j));
        }
        for p in c.outputs.iter().filter(|p| p.bits > 0 || is_stack(&p.name)) {
            let (j, f) = lane_of(&p.name).expect("a lane output");
            let bits = if is_stack(&f) { w.thread } else { p.bits };
            if bits > 0 {
                ports.push(format!("    output wire {}t{}_{f}", width(bits), wp * ws + j));
            }
        }
    }
    let _ = writeln!(s, "module {TOP} (\n{}\n);", ports.join(",\n"));
    for wp in 0..cfg.warps {
        let mut conn = vec![".clk(clk)".to_string()];
        let here = if warp_bits > 0 {
            format!(" && deq_thread[{}:{}] == {wp}", w.thread - 1, w.tid)
        } else {
            String::new()
        };
        conn.push(format!(".deq_valid(deq_valid{here})"));
        if w.tid > 0 {
            conn.push(format!(".deq_lane(deq_thread[{}:0])", w.tid - 1));
        }
        conn.push(".g_rdata(g_rdata)".into());
        conn.push(if cfg.warps > 1 {
            format!(".load(load_warps[{wp}])")
        } else {
            ".load(load_warps)".into()
        });
        for p in c.inputs.iter().filter(|p| p.bits > 0 && !WARP_INPUTS.contains(&p.name.as_str())) {
            let (j, f) = lane_of(&p.name).expect("a lane input");
            if f == "load_active" {
                let bit = if cfg.threads() > 1 { format!("[{}]", wp * ws + j) } else { String::new() };
                conn.push(format!(".{}(load_active{bit})", p.name));
            } else {
                conn.push(format!(".{}(t{}_{f})", p.name, wp * ws + j));
            }
        }
        for p in c.outputs.iter() {
            let (j, f) = lane_of(&p.name).expect("a lane output");
            let t = wp * ws + j;
            if is_stack(&f) {
                // A stack's number in the RT unit: the warp slot above the lane.
                if p.bits > 0 {
                    let _ = writeln!(s, "    wire {}w{wp}_lane{j}_{f};", width(p.bits));
                    conn.push(format!(".{}(w{wp}_lane{j}_{f})", p.name));
                }
                if w.thread == 0 {
                    continue;
                }
                let lane = if p.bits > 0 { format!("w{wp}_lane{j}_{f}") } else { String::new() };
                let warp = if warp_bits > 0 { format!("{warp_bits}'d{wp}") } else { String::new() };
                let cat = [warp, lane].into_iter().filter(|x| !x.is_empty()).collect::<Vec<_>>().join(", ");
                let _ = writeln!(s, "    assign t{t}_{f} = {{{cat}}};");
            } else if p.bits > 0 {
                conn.push(format!(".{}(t{t}_{f})", p.name));
            }
        }
        let _ = writeln!(s, "    {WARP} warp{wp} (\n        {}\n    );", conn.join(",\n        "));
    }
    let _ = writeln!(s, "endmodule");
    s
}
