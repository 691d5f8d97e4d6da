//! Messages and flags as a careful user expects them: an error names the argument, says what is
//! wrong and what is allowed, and comes before any long work; conflicting flags are refused.

mod common;
use common::TmpDir;

use std::os::unix::ffi::OsStrExt;
use std::process::{Command, Output};

fn sms(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sms")).args(args).output().expect("sms runs")
}

/// The first line of a refused command's stderr, checked to be an error and not a panic.
fn refused(o: &Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "accepted: {}", String::from_utf8_lossy(&o.stdout));
    assert!(err.starts_with("error: ") && !err.contains("panicked"), "{err}");
    err.lines().next().unwrap().to_owned()
}

#[test]
fn json_and_another_format_together_are_refused() {
    for sub in [&["cost"][..], &["run", "--res", "4x4"], &["sweep", "--quick"], &["scenes"], &["check"]] {
        let o = sms(&[sub, &["--json", "--format", "csv"]].concat());
        assert_eq!(o.status.code(), Some(2), "{sub:?}");
        let err = refused(&o);
        assert!(err.contains("'--json' cannot be used with '--format <FORMAT>'"), "{sub:?}: {err}");
    }
    // Either alone is fine.
    assert!(sms(&["cost", "--json"]).status.success());
    assert!(sms(&["cost", "--format", "json"]).status.success());
}

#[test]
fn a_text_argument_that_is_not_utf8_is_named() {
    let bad = std::ffi::OsStr::from_bytes(b"\xffscene.obj");
    let cases: [(Vec<&std::ffi::OsStr>, &str); 5] = [
        (vec!["run".as_ref(), "--scene".as_ref(), bad], "--scene"),
        (vec!["-q".as_ref(), "depth".as_ref(), "--scene".as_ref(), bad], "--scene"),
        (vec!["sweep".as_ref(), "--scenes".as_ref(), bad], "--scenes"),
        (vec!["scenes".as_ref(), bad], "<NAMES>"),
        (vec!["run".as_ref(), "--hw".as_ref(), bad], "--hw"),
    ];
    for (args, flag) in cases {
        let o = Command::new(env!("CARGO_BIN_EXE_sms")).args(&args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}");
        let err = refused(&o);
        assert!(err.starts_with(&format!("error: {flag} '\u{fffd}scene.obj': not valid UTF-8;")), "{err}");
    }
    // --name=value names the flag too; a path sms writes may be any bytes.
    let mut eq = b"--scene=".to_vec();
    eq.extend_from_slice(bad.as_bytes());
    let o = Command::new(env!("CARGO_BIN_EXE_sms"))
        .arg("run")
        .arg(std::ffi::OsStr::from_bytes(&eq))
        .output()
        .unwrap();
    assert!(refused(&o).starts_with("error: --scene '\u{fffd}scene.obj'"));
    let tmp = TmpDir::new("messages", "utf8");
    let png = tmp.path().join(std::ffi::OsStr::from_bytes(b"\xffrender.png"));
    let o = Command::new(env!("CARGO_BIN_EXE_sms"))
        .args(["run", "-q", "--res", "4x4", "--spp", "1", "--bounces", "0", "-c", "RB_8", "--png"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(o.status.success() && png.exists(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn output_folders_are_checked_before_any_work() {
    let tmp = TmpDir::new("messages", "out");
    let file = tmp.join("a-file");
    std::fs::write(&file, b"x").unwrap();
    let f = file.to_str().unwrap();
    let under = file.join("sub");
    let u = under.to_str().unwrap();
    let tiny = ["--res", "8x8", "--spp", "1", "--bounces", "1"];
    for (sub, more) in [
        ("sweep", &["--quick"][..]),
        ("ablate", &["--quick"]),
        ("bench", &["--scenes", "clutter"]),
        ("depth", &["--scene", "clutter"]),
    ] {
        // Without -q: the refusal comes before the first progress line.
        let o = sms(&[&[sub, "--out", f], more, &tiny].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(
            refused(&o),
            format!("error: --out {f}: not a folder (a file has that name); give a folder to write into")
        );
        assert_eq!(err.lines().count(), 1, "{sub}: nothing ran first: {err}");
        let o = sms(&[&[sub, "--out", u], more, &tiny].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(refused(&o).starts_with(&format!("error: --out {u}: cannot create the folder (")), "{err}");
        assert_eq!(err.lines().count(), 1, "{sub}: nothing ran first: {err}");
    }
    // depth's default folder is checked as early, named after the scene.
    let o = Command::new(env!("CARGO_BIN_EXE_sms"))
        .args(["depth", "--scene", "clutter"])
        .args(tiny)
        .current_dir(&file.parent().unwrap())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(tmp.join("out/depth/clutter/render.png").exists());
}

#[test]
fn plan_and_size_flags_say_what_is_allowed() {
    let cases: [(&[&str], &str); 6] = [
        (
            &["sweep", "--quick", "--l1d-sizes", "32,0"],
            "error: --l1d-sizes 0: each size (in KB) must be above 8, the SH stacks of RB_8+SH_8+SK+RA",
        ),
        (&["sweep", "--quick", "--l1d-sizes", "5000000"], "error: --l1d-sizes 5000000: too large"),
        (&["sweep", "--quick", "--rb-sizes", "4,0"], "error: --rb-sizes 0: invalid configuration: rb = 0"),
        (
            &["cost", "--full-depth", "0"],
            "error: --full-depth 0: RB_FULL needs 1 to 65536 entries",
        ),
        (&["cost", "--full-depth", "70000", "-c", "RB_FULL"], "error: --full-depth 70000: RB_FULL needs 1 to 65536"),
        (
            &["check", "-c", "SMS", "--warp-size", "32", "--depth", "20"],
            "error: --depth 20: bounds 2-thread warps only, and every warp here is wider; give --wide-depth (now 9)",
        ),
    ];
    for (args, want) in cases {
        let err = refused(&sms(args));
        assert!(err.starts_with(want), "{args:?}: {err}");
    }
    // --depth still bounds a 2-thread warp, and the default applies without it.
    // (Exit status 2: a search stopped at depth 4 is bounded, not proved.)
    let o = sms(&["check", "-q", "-c", "SMS", "--warp-size", "2", "--depth", "4"]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("depth cap 4"));
}

/// A reallocating configuration's default borrow limit (4) is the paper's, for 32-thread warps:
/// on a smaller warp it becomes the most that warp allows, and says so; an explicit limit is
/// checked as given.
#[test]
fn a_small_warps_borrow_limit_defaults_to_what_it_allows() {
    let o = sms(&["cost", "-c", "RB_2+SH_2+SK+RA", "--warp-size", "4", "--json"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("--config RB_2+SH_2+SK+RA: borrow limit 3 (the most a 4-thread warp allows"),
        "{err}"
    );
    assert!(sms(&["cost", "-q", "-c", "RB_2+SH_2+SK+RA", "--warp-size", "4"]).stderr.is_empty(), "-q");
    let err = refused(&sms(&["cost", "-c", "RB_2+SH_2+SK+RA", "--warp-size", "4", "--borrow-limit", "4"]));
    assert!(err.contains("borrow_limit = 4: must be 1 to warp_size - 1 = 3"), "{err}");
    // At the names' own 32 threads nothing changes.
    let o = sms(&["cost", "-c", "SMS"]);
    assert!(o.status.success() && !String::from_utf8_lossy(&o.stderr).contains("borrow limit"));
}

#[test]
fn a_run_too_large_states_its_estimate_in_plain_numbers() {
    let err = refused(&sms(&["run", "-q", "--spp", "1000000000"]));
    assert!(err.contains(" years: above the limit"), "{err}");
    let years = err.split(" years").next().unwrap().rsplit(", ").next().unwrap();
    assert!(years.parse::<f64>().is_ok() || years.replace(',', "").parse::<u64>().is_ok(), "{years}: {err}");
}

#[test]
fn cost_rows_have_one_name_each() {
    let o = sms(&["cost", "-c", "SMS", "--format", "csv"]);
    let csv = String::from_utf8(o.stdout).unwrap();
    let names: Vec<&str> =
        csv.lines().filter(|l| !l.starts_with('#')).skip(1).map(|l| l.split(',').nth(1).unwrap()).collect();
    let mut unique = names.clone();
    unique.sort_unstable();
    unique.dedup();
    assert_eq!(unique.len(), names.len(), "{csv}");
    assert!(names.contains(&"priority") && names.contains(&"priority_msb"), "{csv}");
}

/// `sms sweep` prints the speed-ups per scene and the cost table, each under its title.
#[test]
fn a_sweep_prints_its_speedups_and_cost() {
    let tmp = TmpDir::new("messages", "sweep-stdout");
    let args = ["sweep", "-q", "--scenes", "wknd", "--res", "8x8", "--spp", "1", "--bounces", "1"];
    let plan = ["-c", "SMS", "--rb-sizes", "8", "--l1d-sizes", "64", "--out", tmp.path().to_str().unwrap()];
    let text = String::from_utf8(sms(&[&args[..], &plan].concat()).stdout).unwrap();
    let perf = text.find("\nPerformance normalised to RB_8 (64 KB L1D)\n").expect(&text);
    let cost = text.find("\nCost versus performance (64 KB L1D)\n").expect(&text);
    assert!(text.starts_with("provenance: ") && perf < cost, "{text}");
    assert!(text.contains("RB_8+SH_8+SK+RA") && text.contains("geomean"), "{text}");
    let csv = String::from_utf8(sms(&[&args[..], &plan, &["--format", "csv"]].concat()).stdout).unwrap();
    let titles: Vec<&str> = csv.lines().filter(|l| l.starts_with("# ")).collect();
    assert_eq!(titles.len(), 3, "provenance and two titles: {csv}");
    assert_eq!(titles[1], "# Performance normalised to RB_8 (64 KB L1D)");
}

#[test]
fn a_reader_that_closes_the_pipe_ends_sms_quietly() {
    use std::os::unix::process::ExitStatusExt;
    use std::process::Stdio;
    // `sms cost | true`: the reader has gone before sms writes its table.
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let child = Command::new(env!("CARGO_BIN_EXE_sms"))
        .arg("cost")
        .stdout(writer)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.is_empty(), "{err}");
    // Ended by SIGPIPE (13 on Linux), as a Unix filter is.
    assert_eq!(o.status.signal(), Some(13), "{:?}", o.status);
}
