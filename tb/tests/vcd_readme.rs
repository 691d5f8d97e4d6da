//! README's waveform command, run as README prints it: the dumped lanes spill RB → SH inside the
//! window, the save file it writes opens on that spill (marker, time range, the spilling
//! thread's group open), the shipped `waves/clutter_sms.gtkw` is that save file, and the
//! screenshot script runs the same command.

mod common;
use common::TmpDir;

use std::path::Path;

use rtl::stack_manager::Uop;
use tb::vcd::check::{read, Mode};
use tb::vcd::gtkw::FOCUS_CYCLES;

/// GTKWave's time units per cycle in a save file (docs/waveforms.md: `1000 × cycle`).
const GTKWAVE_UNITS_PER_CYCLE: u64 = 1000;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap()
}

/// README's Waveforms section: the `sms` arguments of its `cargo run` command (continuation
/// lines joined) and the arguments of its `gtkwave` line.
fn readme_commands() -> (Vec<String>, Vec<String>) {
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    let section = readme.split("\n## Waveforms\n").nth(1).expect("README has a Waveforms section");
    let block = section.split("```sh\n").nth(1).and_then(|b| b.split("```").next()).expect("a sh block");
    let joined = block.replace("\\\n", " ");
    let line = |start: &str| {
        joined
            .lines()
            .find(|l| l.trim_start().starts_with(start))
            .unwrap_or_else(|| panic!("no {start} line"))
    };
    let run = line("cargo run");
    let args = run.split(" -- ").nth(1).expect("sms arguments after --");
    let words = |s: &str| s.split_whitespace().map(String::from).collect::<Vec<_>>();
    (words(args), words(line("gtkwave")).split_off(1))
}

/// The `sms` arguments of `scripts/waves-screenshot.sh`'s `sms run`, which makes
/// docs/waves-spill.png.
fn screenshot_command() -> Vec<String> {
    let script = std::fs::read_to_string(root().join("scripts/waves-screenshot.sh")).unwrap();
    let joined = script.replace("\\\n", " ");
    let run = joined.lines().find(|l| l.contains("--bin sms -- run")).expect("the script runs sms");
    let args = run.split(" -- ").nth(1).unwrap();
    args.split_whitespace().take_while(|w| !w.starts_with('>')).map(String::from).collect()
}

fn flag<'a>(args: &'a [String], name: &str) -> &'a str {
    let i = args.iter().position(|a| a == name).unwrap_or_else(|| panic!("README's command has no {name}"));
    &args[i + 1]
}

#[test]
fn readme_waveform_command_opens_on_a_spill_of_its_lanes() {
    let (mut args, gtkwave) = readme_commands();
    let dump = flag(&args, "--vcd").to_string();
    assert_eq!(
        gtkwave,
        [dump.clone(), dump.replace(".vcd", ".gtkw")],
        "gtkwave opens the dump and its save file"
    );
    assert_eq!(screenshot_command(), args, "the screenshot comes from README's command");
    let tmp = TmpDir::new("vcd-readme", "spill");
    let file = Path::new(&dump).file_name().unwrap();
    let i = args.iter().position(|a| *a == dump).unwrap();
    args[i] = tmp.path().join(file).to_str().unwrap().to_string();
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    common::sms(&argv, &["-q"]);

    let from: u64 = flag(&args, "--vcd-from").parse().unwrap();
    let to: u64 = flag(&args, "--vcd-to").parse().unwrap();
    let (sm, warp) = (flag(&args, "--vcd-sms"), flag(&args, "--vcd-warps"));
    let lanes: Vec<&str> = flag(&args, "--vcd-lanes").split(',').collect();
    let text = std::fs::read(tmp.path().join(file)).unwrap();
    let waves = read(&text[..], Mode::Strict).expect("a strictly valid dump");

    // The dumped stack threads are exactly the selected lanes of the selected warp.
    let prefix = format!("sm{sm}.rt_unit.stack_manager.warp[{warp}].thread[");
    let uops: Vec<(usize, &str)> = waves
        .signals
        .iter()
        .enumerate()
        .filter(|(_, s)| s.0.ends_with(".uop") && s.0.contains("stack_manager"))
        .map(|(i, s)| (i, s.0.as_str()))
        .collect();
    let dumped: Vec<&str> = uops
        .iter()
        .map(|(_, p)| p.strip_prefix(&prefix).and_then(|t| t.split(']').next()).unwrap())
        .collect();
    assert_eq!(dumped, lanes, "the stack threads dumped");

    // The first RB → SH spill (a thread's sequencer storing to its SH stack) in the window, and
    // the SH stack it filled holding an entry in the cycles after it.
    let store = Uop::NAMES.iter().position(|n| *n == "sh_store").unwrap() as u64;
    let mut replay = waves.replay();
    let mut spill = None;
    for cycle in from..=to {
        let Some(v) = replay.at(cycle) else { continue };
        if let Some(&(_, path)) = uops.iter().find(|(i, _)| v[*i] == store) {
            spill = Some((cycle, path.trim_end_matches(".uop").to_string()));
            break;
        }
    }
    let (cycle, thread) = spill.expect("a dumped lane spills RB → SH inside the window");
    let sh_empty = waves.index(&format!("{thread}.sh_empty")).unwrap();
    let mut replay = waves.replay();
    let filled = (cycle..=(cycle + 8).min(to)).any(|c| replay.at(c).is_some_and(|v| v[sh_empty] == 0));
    assert!(filled, "{thread}'s SH stack holds the spilled entry after cycle {cycle}");

    // The save file: its marker on that cycle, its time range around it, that thread open.
    let save = std::fs::read_to_string(tmp.path().join(file).with_extension("gtkw")).unwrap();
    let start: u64 = save.lines().find_map(|l| l.strip_prefix("[timestart] ")).unwrap().parse().unwrap();
    let marker: u64 =
        save.lines().find(|l| l.starts_with('*')).unwrap().split(' ').nth(1).unwrap().parse().unwrap();
    assert_eq!(marker, cycle * GTKWAVE_UNITS_PER_CYCLE, "the marker is on the spill");
    let first = start / GTKWAVE_UNITS_PER_CYCLE;
    assert!(first <= cycle && cycle < first + FOCUS_CYCLES, "cycles {first}.. show the spill at {cycle}");
    let lines: Vec<&str> = save.lines().collect();
    let group = lines.iter().position(|l| *l == format!("-{thread}")).expect("a group per thread");
    let group_flags = u32::from_str_radix(lines[group - 1].trim_start_matches('@'), 16).unwrap();
    assert_eq!(group_flags & (1 << 22), 0, "the spilling thread's group is open: @{group_flags:x}");

    // The save file shipped in waves/ is the one this command writes.
    let shipped = std::fs::read_to_string(root().join(dump.replace(".vcd", ".gtkw"))).unwrap();
    assert_eq!(shipped, save, "{} is what README's command writes", dump.replace(".vcd", ".gtkw"));
}
