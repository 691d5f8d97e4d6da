//! VCD dumps of the stack unit are well formed and show exactly the RTL's values.
//!
//! Every dump is read back by the strict checker and replayed cycle by cycle against the values
//! the RTL reported in the same run (a [`Recorder`] beside the [`VcdSink`]). Planted bugs show
//! the checker can fail; GTKWave's own converters must round-trip the values.

mod common;
use common::TmpDir;

use std::path::Path;
use std::process::Command;

use rtl::config::Config;
use tb::run::verify::harness::RunSummary;
use tb::run::waves::{examples, write_examples, Example};
use tb::vcd::check::{compare, read, Mode, Recorder, Waves};
use tb::vcd::{Selection, Tee, VcdError, VcdOptions, VcdSink};

/// The first example's configuration (SMS on RB_2 + SH_4, 2 warp slots of 8 lanes) with a
/// bigger workload: 3 warps, so a slot is reused, deep enough to borrow and flush.
fn sms_small() -> Example {
    Example { warps: 3, max_peak: 16, ..examples().remove(0) }
}

/// Runs `ex` with a VCD sink (to memory) and a recorder side by side.
fn dump(ex: &Example, select: Selection) -> (String, Recorder, RunSummary) {
    let mut vcd = VcdSink::new(Vec::new(), select, &ex.config).unwrap();
    let mut rec = Recorder::default();
    let summary = ex.run(&mut Tee(&mut vcd, &mut rec)).unwrap();
    let text = String::from_utf8(vcd.finish().unwrap()).unwrap();
    (text, rec, summary)
}

fn strict(text: &str) -> Waves {
    read(text.as_bytes(), Mode::Strict).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn dump_is_strictly_valid_and_replays_every_rtl_value() {
    let ex = sms_small();
    let (text, rec, summary) = dump(&ex, Selection::default());
    let st = summary.stats.stack;
    assert!(st.borrows > 0 && st.flushes > 0, "workload too tame: {st:?}");
    let waves = strict(&text);
    // Every RTL signal with a width is dumped, none invented.
    let expected: Vec<_> = rec.signals().filter(|s| s.1 > 0).collect();
    let got: Vec<_> = waves.signals.iter().map(|s| (s.0.as_str(), s.1)).collect();
    assert_eq!(got, expected);
    let compared = compare(&waves, &rec, 0..=u64::MAX).unwrap();
    assert_eq!(compared, rec.cycles().len() * expected.len());
    // Timestamps only where something changed: never more than the cycles (plus the end).
    assert!(waves.times().count() <= rec.cycles().len() + 1);
}

/// Returns `text` with its first line matching `pick` replaced by `edit(line)`.
fn plant(text: &str, pick: impl Fn(&str) -> bool, edit: impl Fn(&str) -> String) -> String {
    let mut done = false;
    text.lines()
        .map(|l| {
            if !done && pick(l) {
                done = true;
                edit(l)
            } else {
                l.to_string()
            }
        })
        .map(|l| l + "\n")
        .collect()
}

#[test]
fn planted_bugs_are_caught() {
    let ex = sms_small();
    let (text, rec, _) = dump(&ex, Selection::default());
    let body = text.find("$enddefinitions").unwrap();
    let (head, tail) = text.split_at(body);
    // A vector change late in the run, at a time after the first timestamp.
    let late = |l: &str| l.starts_with('b') && l.contains(" ");
    let flip = |l: &str| {
        let (bits, id) = l[1..].split_once(' ').unwrap();
        let flipped: String = bits
            .chars()
            .enumerate()
            .map(|(i, c)| match (i + 1 == bits.len(), c) {
                (true, '0') => '1',
                (true, _) => '0',
                _ => c,
            })
            .collect();
        format!("b{flipped} {id}")
    };
    let second_stamp = tail.match_indices("\n#").nth(1).unwrap().0;
    let (early, rest) = tail.split_at(second_stamp);
    let corrupted = format!("{head}{early}{}", plant(rest, late, flip));
    let waves = strict(&corrupted);
    let err = compare(&waves, &rec, 0..=u64::MAX).unwrap_err();
    assert!(err.contains("in the dump"), "{err}");

    let undeclared = plant(&text, |l| l.starts_with("$var"), |_| String::new());
    let err = read(undeclared.as_bytes(), Mode::Strict).unwrap_err();
    assert!(err.message.contains("is not declared"), "{err}");

    let stamp = |l: &str| l.starts_with('#') && l != "#0";
    let backwards = format!("{head}{}", plant(tail, stamp, |_| "#0".into()));
    let err = read(backwards.as_bytes(), Mode::Strict).unwrap_err();
    assert!(err.message.contains("does not follow"), "{err}");

    // Vectors are written without leading zeros (legal VCD); one wider than its wire is not.
    let wide = |l: &str| format!("b{} {}", "1".repeat(65), l.split_once(' ').unwrap().1);
    let too_wide = format!("{head}{}", plant(tail, late, wide));
    for mode in [Mode::Strict, Mode::Lenient] {
        let err = read(too_wide.as_bytes(), mode).unwrap_err();
        assert!(err.message.contains("bits written to"), "{err}");
    }

    // The clock rises at every cycle's start and falls half-way, and nothing else changes then.
    let clk_line = head.lines().find(|l| l.starts_with("$var") && l.contains(" clk $end")).expect("a clock");
    let clk = clk_line.split_whitespace().nth(3).unwrap();
    let fall = format!("0{clk}");
    let stuck = plant(tail, |l| l == fall, |_| format!("1{clk}"));
    let err = read(format!("{head}{stuck}").as_bytes(), Mode::Strict).unwrap_err();
    assert!(err.message.contains("the clock must fall"), "{err}");
    let vector = tail.lines().find(|l| late(l)).unwrap().to_string();
    let half_way = |l: &str| l.starts_with('#') && l.ends_with('5');
    let busy = plant(tail, half_way, |l| format!("{l}\n{vector}"));
    let err = read(format!("{head}{busy}").as_bytes(), Mode::Strict).unwrap_err();
    assert!(err.message.contains("half-way through a cycle"), "{err}");

    let missing = format!("{head}{}", plant(tail, |l| l.starts_with('b'), |_| String::new()));
    let err = read(missing.as_bytes(), Mode::Strict).unwrap_err();
    assert!(err.message.contains("has no value at time 0"), "{err}");
}

#[test]
fn window_and_filters_dump_only_the_selection() {
    let ex = sms_small();
    let select =
        Selection { from: Some(40), to: Some(160), warps: Some(vec![0]), lanes: Some(vec![0, 3]), sms: None };
    let (full, rec, _) = dump(&ex, Selection::default());
    let (part, _, _) = dump(&ex, select.clone());
    assert!(part.len() * 5 < full.len(), "{} vs {}", part.len(), full.len());
    let waves = strict(&part);
    let expected: Vec<&str> = rec
        .signals()
        .filter(|s| s.1 > 0)
        .map(|s| s.0)
        .filter(|p| {
            !p.contains("warp[") || p.contains("warp[0].thread[0].") || p.contains("warp[0].thread[3].")
        })
        .collect();
    let got: Vec<&str> = waves.signals.iter().map(|s| s.0.as_str()).collect();
    assert_eq!(got, expected);
    assert!(got.iter().any(|p| p.contains("bank_arbiter")));
    let times: Vec<u64> = waves.times().collect();
    assert_eq!(times.first(), Some(&40));
    assert_eq!(times.last(), Some(&161));
    compare(&waves, &rec, 40..=160).unwrap();
}

fn expect_err(select: Selection, cfg: &Config, path: &Path) -> String {
    let opts = VcdOptions { path: path.to_path_buf(), select };
    match VcdSink::create(&opts, cfg) {
        Ok(_) => panic!("{opts:?} accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_options_are_errors_naming_the_value() {
    let ex = sms_small();
    let tmp = TmpDir::new("vcd", "errors");
    let path = tmp.join("errors.vcd");
    let window = Selection { from: Some(9), to: Some(3), ..Selection::default() };
    assert_eq!(expect_err(window, &ex.config, &path), "VCD window: from 9 is after to 3");
    let warp = Selection { warps: Some(vec![0, 2]), ..Selection::default() };
    let msg = expect_err(warp, &ex.config, &path);
    assert!(msg.contains("warp 2 does not exist") && msg.contains("2 warps"), "{msg}");
    let lane = Selection { lanes: Some(vec![8]), ..Selection::default() };
    let msg = expect_err(lane, &ex.config, &path);
    assert!(msg.contains("lane 8 does not exist") && msg.contains("8 lanes"), "{msg}");
    let nowhere = Path::new("/nonexistent-dir/x.vcd");
    let msg = expect_err(Selection::default(), &ex.config, nowhere);
    assert!(msg.starts_with("cannot write /nonexistent-dir/x.vcd: "), "{msg}");

    let late = Selection { from: Some(1_000_000), ..Selection::default() };
    let opts = VcdOptions { path, select: late };
    let mut sink = VcdSink::create(&opts, &ex.config).unwrap();
    let cycles = ex.run(&mut sink).unwrap().stats.cycles;
    let err = sink.finish().unwrap_err();
    assert!(matches!(err, VcdError::OutsideRun { .. }));
    assert_eq!(err.to_string(), format!("VCD window [1000000,end] is outside the run (0..{cycles} cycles)"));
}

#[test]
fn save_file_opens_the_dump_with_grouped_signals() {
    let ex = sms_small();
    let tmp = TmpDir::new("vcd", "gtkw");
    let opts = VcdOptions { path: tmp.join("grouped.vcd"), select: Selection::default() };
    let mut sink = VcdSink::create(&opts, &ex.config).unwrap();
    ex.run(&mut sink).unwrap();
    sink.finish().unwrap();
    let save = std::fs::read_to_string(opts.path.with_extension("gtkw")).unwrap();
    // Beside its save file, the dump is named by file name (the pair can be moved).
    assert!(save.contains("[dumpfile] \"grouped.vcd\"\n"), "{save}");
    let waves = strict(&std::fs::read_to_string(&opts.path).unwrap());
    for (path, width) in &waves.signals {
        let trace = match width {
            1 => path.clone(),
            w => format!("{path}[{}:0]", w - 1),
        };
        assert!(save.lines().any(|l| l == trace), "{trace} missing");
    }
    let labels: Vec<&str> = save.lines().filter_map(|l| l.strip_prefix('-')).collect();
    assert_eq!(labels.len() % 2, 0, "groups open and close");
    assert_eq!(labels[0], "warp[0].thread[0]", "the first stack thread leads");
    assert!(labels.contains(&"bank_arbiter"));
    assert!(labels.contains(&"warp[1].thread[7]"));
    // Thread fields in display order.
    let thread0: Vec<&str> = save
        .lines()
        .filter_map(|l| l.strip_prefix("rt_unit.stack_manager.warp[0].thread[0]."))
        .map(|l| l.split('[').next().unwrap())
        .collect();
    assert_eq!(&thread0[..5], ["cmd_valid", "cmd_kind", "cmd_data", "uop", "rb_count"]);
    assert_eq!(thread0.last(), Some(&"done"));
}

/// Each trace of a save file with the flag word in force and the filter line before it.
fn traces(save: &str) -> Vec<(String, u32, Option<String>)> {
    let (mut flags, mut filter, mut out) = (0, None, Vec::new());
    for line in save.lines() {
        if let Some(hex) = line.strip_prefix('@') {
            flags = u32::from_str_radix(hex, 16).unwrap();
        } else if let Some(f) = line.strip_prefix('^') {
            filter = Some(f.to_string());
        } else if line.starts_with("rt_unit.") {
            let path = line.rsplit_once('[').filter(|(_, bits)| bits.contains(':')).map_or(line, |(p, _)| p);
            out.push((path.to_string(), flags, filter.take()));
        }
    }
    out
}

const TR_HEX: u32 = 1 << 1;
const TR_DEC: u32 = 1 << 2;
const TR_BIN: u32 = 1 << 3;
const TR_FTRANSLATED: u32 = 1 << 13;
const FORMATS: u32 = TR_HEX | TR_DEC | TR_BIN;

/// Addresses and data in hex, masks in binary, counts in decimal, encoded enumerations by name
/// through a filter file that lists every value of the rtl enum; chosen from the kind each probe
/// declares.
#[test]
fn save_file_formats_follow_the_declared_kinds() {
    use rtl::stack_manager::{Cmd, Uop};
    use rtl::trace::Kind;
    use tb::vcd::gtkw::{filter_file, filter_text};
    let ex = sms_small();
    let tmp = TmpDir::new("vcd", "formats");
    let opts = VcdOptions { path: tmp.join("formats.vcd"), select: Selection::default() };
    let mut sink = VcdSink::create(&opts, &ex.config).unwrap();
    ex.run(&mut sink).unwrap();
    sink.finish().unwrap();
    let save = std::fs::read_to_string(opts.path.with_extension("gtkw")).unwrap();
    let traces = traces(&save);
    let flags_of = |path: &str| {
        let t = traces.iter().find(|t| t.0 == path).unwrap_or_else(|| panic!("{path} not in the save file"));
        (t.1, t.2.clone())
    };
    let thread = "rt_unit.stack_manager.warp[0].thread[0]";
    assert_eq!(flags_of(&format!("{thread}.cmd_data")).0 & FORMATS, TR_HEX, "data in hex");
    assert_eq!(flags_of("rt_unit.mem_sched.req_addr").0 & FORMATS, TR_HEX, "addresses in hex");
    assert_eq!(flags_of("rt_unit.bank_arbiter.grant").0 & FORMATS, TR_BIN, "masks in binary");
    assert_eq!(flags_of(&format!("{thread}.rb_count")).0 & FORMATS, TR_DEC, "counts in decimal");
    assert_eq!(flags_of(&format!("{thread}.rb_count")).1, None);
    let dir = std::fs::canonicalize(tmp.path()).unwrap();
    for (field, kind) in [("cmd_kind", Cmd::KIND), ("uop", Uop::KIND)] {
        let Kind::Enum { name, names } = kind else { unreachable!() };
        let (flags, filter) = flags_of(&format!("{thread}.{field}"));
        assert_eq!(flags & (FORMATS | TR_FTRANSLATED), TR_DEC | TR_FTRANSLATED, "{field} translated");
        let filter = filter.unwrap_or_else(|| panic!("{field} has no filter line"));
        let (index, path) = filter.split_once(' ').unwrap();
        assert!(index.parse::<u32>().unwrap() >= 1, "{filter}");
        // Named beside the save file (GTKWave resolves it against the save file's folder).
        assert_eq!(path, filter_file(name));
        // The file GTKWave reads names every code of the enum, in decimal as GTKWave prints it.
        let text = std::fs::read_to_string(dir.join(path)).unwrap();
        let lines: Vec<(u64, &str)> = text
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(|l| l.split_once(' ').map(|(v, n)| (v.parse().unwrap(), n)).unwrap())
            .collect();
        assert_eq!(lines.len(), names.len(), "{name}: one line per value");
        for (code, n) in names.iter().enumerate() {
            assert!(lines.contains(&(code as u64, n)), "{name}: {code} {n} missing");
        }
    }
    // Every thread's cmd_kind uses the same filter (one `^N` index per enum).
    let cmd_filters: Vec<_> =
        traces.iter().filter(|t| t.0.ends_with(".cmd_kind")).map(|t| t.2.clone()).collect();
    assert!(cmd_filters.len() > 1 && cmd_filters.windows(2).all(|w| w[0] == w[1]));
    // The shipped copies in waves/ are the generated files.
    let waves = Path::new(env!("CARGO_MANIFEST_DIR")).join("../waves");
    for kind in tb::vcd::gtkw::ENUMS {
        let Kind::Enum { name, names } = kind else { unreachable!() };
        let shipped = std::fs::read_to_string(waves.join(filter_file(name)))
            .unwrap_or_else(|e| panic!("waves/{}: {e}", filter_file(name)));
        assert_eq!(
            shipped,
            filter_text(name, names),
            "waves/{} is stale: cargo run -p tb --example waves",
            filter_file(name)
        );
    }
}

#[test]
fn gtkwave_round_trip_keeps_every_value() {
    if !tb::prereq::tools(&["vcd2fst", "fst2vcd"], "GTKWave (apt-get install gtkwave)") {
        return;
    }
    let ex = sms_small();
    let (text, rec, _) = dump(&ex, Selection::default());
    let tmp = TmpDir::new("vcd", "round");
    let (vcd, fst) = (tmp.join("round.vcd"), tmp.join("round.fst"));
    std::fs::write(&vcd, &text).unwrap();
    let status = Command::new("vcd2fst").arg(&vcd).arg(&fst).status().unwrap();
    assert!(status.success());
    let out = Command::new("fst2vcd").arg(&fst).output().unwrap();
    assert!(out.status.success());
    let back = read(out.stdout.as_slice(), Mode::Lenient).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.signals, strict(&text).signals);
    let compared = compare(&back, &rec, 0..=u64::MAX).unwrap();
    assert_eq!(compared, rec.cycles().len() * back.signals.len());
}

#[test]
fn examples_are_valid_and_small() {
    let tmp = TmpDir::new("vcd", "examples");
    let paths = write_examples(tmp.path()).unwrap();
    assert_eq!(paths.len(), examples().len());
    let mut sizes = Vec::new();
    for p in &paths {
        let text = std::fs::read_to_string(p).unwrap();
        let save = std::fs::metadata(p.with_extension("gtkw")).unwrap().len() as usize;
        sizes.push((p.file_name().unwrap().to_owned(), text.len() + save));
        assert!(strict(&text).change_count() > 0);
    }
    let total: usize = sizes.iter().map(|s| s.1).sum();
    assert!(total < 200_000, "{total} bytes: {sizes:?}");
}
