//! A solver's counterexample run on the simulator: the state the solver found is loaded into a
//! [`StackManager`] through its back door, the obligation's commands are planned in one cycle
//! (eval, then commit at the clock edge), and the warp's registers before and after are dumped
//! as a VCD with its GTKWave save file (time 0: the counterexample's state; time 1: after the
//! cycle).

use std::path::Path;

use anyhow::{Context, Result};
use rtl::clock::Unit;
use rtl::config::Config;
use rtl::stack_manager::{Cmd, StackIn, StackManager, StackRegs, StackStep, ThreadRegs};
use rtl::trace::Sink;

use super::query::Kind;
use super::Obligation;
use crate::vcd::{Selection, VcdOptions, VcdSink};

/// What the replay saw: every command's answer in the simulator.
pub struct Replayed {
    pub answers: Vec<String>,
}

/// Loads the counterexample `vals` (variable name → value) into `sm` (built for `cfg`, with
/// whatever design the caller planted), plans `ob`'s commands in one cycle and dumps the warp
/// before and after to `path` (+ `.gtkw`).
pub fn replay(
    cfg: Config,
    mut sm: StackManager,
    ob: &Obligation,
    vals: &[(String, u64)],
    path: &Path,
) -> Result<Replayed> {
    let get = |name: String| vals.iter().find(|v| v.0 == name).map_or(0, |v| v.1);
    let w32 = |name: String| get(name) as u32;
    let ws = cfg.warp_size;
    for j in 0..ws {
        let s = ob.base + j;
        sm.load_stack(
            s,
            StackRegs {
                top: w32(format!("top_{j}")),
                bottom: w32(format!("bottom_{j}")),
                empty: get(format!("empty_{j}")) != 0,
                idle: get(format!("idle_{j}")) != 0,
                next_tid: w32(format!("next_tid_{j}")),
                priority: w32(format!("priority_{j}")),
                flush: w32(format!("flush_{j}")),
            },
        );
        let done = get(format!("done_{j}")) != 0;
        let th = ThreadRegs { done, ..*sm.thread(s) };
        sm.load_thread(s, th, &[], false);
    }
    let mut cmds = Vec::new();
    for &(lane, kind) in &ob.cmds {
        let t = ob.base + lane;
        let th = ThreadRegs {
            overflow: get(format!("overflow_{lane}")) != 0,
            spill_ptr: w32(format!("spill_ptr_{lane}")),
            done: get(format!("done_{lane}")) != 0,
        };
        // The RB: the solver's oldest and newest entries at its ends, distinct fillers between.
        let len = (w32(format!("rb_len_{lane}")) as usize).min(1 << 12);
        let rb: Vec<u64> = (0..len)
            .map(|i| match i {
                0 => get(format!("rb_front_{lane}")),
                i if i + 1 == len => get(format!("rb_back_{lane}")),
                i => 0x5EED_0000 + i as u64,
            })
            .collect();
        sm.load_thread(t, th, &rb, get(format!("busy_{lane}")) != 0);
        let cmd = match kind {
            Kind::Push => Cmd::Push(get(format!("push_value_{lane}"))),
            Kind::Pop => Cmd::Pop,
            Kind::Finish => Cmd::Finish,
        };
        cmds.push((t, cmd));
    }
    let warp = ob.base / ws;
    let opts = VcdOptions {
        path: path.to_path_buf(),
        select: Selection { warps: Some(vec![warp]), ..Selection::default() },
    };
    let mut sink = VcdSink::create(&opts, &cfg).with_context(|| format!("--vcd {}", path.display()))?;
    sink.begin_cycle(0);
    sm.probe_cycle(&cmds, &[], &mut sink);
    let mut d = StackStep::default();
    sm.eval(StackIn { cmds: &cmds, done: &[], deq: None, now: 0 }, &mut d);
    let answers = cmds.iter().map(|&(t, cmd)| format!("thread {t} {cmd:?}: {:?}", d.answer(t))).collect();
    sm.commit(&d);
    sink.begin_cycle(1);
    sm.probe_cycle(&[], d.pops(), &mut sink);
    sink.end_run(2);
    sink.finish().with_context(|| format!("--vcd {}", path.display()))?;
    Ok(Replayed { answers })
}
