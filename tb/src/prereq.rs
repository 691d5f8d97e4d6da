//! What a test needs from the machine beyond the repository: the shared scene data, GTKWave's
//! converters, Debian's assimp test models. Every test that needs one of them asks here first.
//!
//! When something is missing the test fails with one line saying what to install or set; it
//! never passes unchecked. With `SMS_SKIP_MISSING=1` in the environment it is skipped instead:
//! the helper returns `None`/`false`, the test returns early, and one line goes straight to the
//! terminal (not through the test harness, which would swallow a passing test's output):
//!
//! ```text
//! SKIPPED 3 in this cargo run: vcd_gpu::gtkwave_round_trip: vcd2fst is not on PATH: install GTKWave (apt-get install gtkwave)
//! ```
//!
//! The count is kept in a file named after the `cargo test` process (every test binary's
//! parent), so it runs across the test binaries of one run and the last such line carries the
//! run's total.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::Error;
use crate::workload::scene::{Scene, SceneLibrary};

/// The opt-out: set to `1` to skip, rather than fail, the tests whose prerequisites are missing.
pub const SKIP_ENV: &str = "SMS_SKIP_MISSING";

/// A shipped (or built-in) scene by name. Its mesh missing from the data folder fails the test
/// with the loader's one-line message, or skips it (`None`) under [`SKIP_ENV`]. Any other load
/// error is a failure.
pub fn scene(name: &str) -> Option<Scene> {
    match SceneLibrary::default().load(name) {
        Ok(scene) => Some(scene),
        Err(e @ Error::MissingData { .. }) => missing(skip(), e.to_string(), &mut std::io::stderr()),
        Err(e) => panic!("{name}: {e}"),
    }
}

/// Whether every mesh the shipped descriptions read is in the data folder (what a test running
/// `sms` on shipped scenes needs). The first missing one fails or skips as [`scene`] does.
pub fn scene_data() -> bool {
    absent_mesh(&SceneLibrary::default())
        .map_or(true, |what| missing::<()>(skip(), what, &mut std::io::stderr()).is_some())
}

/// Whether every program in `tools` runs; a missing one fails or skips naming `install`, what
/// installs it.
pub fn tools(tools: &[&str], install: &str) -> bool {
    absent_tool(tools, install)
        .map_or(true, |what| missing::<()>(skip(), what, &mut std::io::stderr()).is_some())
}

/// Whether `path` exists; a missing one fails or skips naming `install`, what provides it.
pub fn files(path: &Path, install: &str) -> bool {
    absent_file(path, install)
        .map_or(true, |what| missing::<()>(skip(), what, &mut std::io::stderr()).is_some())
}

/// The first shipped description's missing mesh in `library`, as the loader words it.
fn absent_mesh(library: &SceneLibrary) -> Option<String> {
    library.first_missing_mesh().map(|e| e.to_string())
}

fn absent_tool(tools: &[&str], install: &str) -> Option<String> {
    let absent = tools.iter().find(|t| std::process::Command::new(t).arg("--help").output().is_err())?;
    Some(format!("{absent} is not on PATH: install {install}"))
}

fn absent_file(path: &Path, install: &str) -> Option<String> {
    (!path.exists()).then(|| format!("{} is missing: install {install}", path.display()))
}

/// The running test's name, as the harness names its thread.
fn test_name() -> String {
    std::thread::current().name().filter(|n| *n != "main").unwrap_or("a test").to_owned()
}

/// This run's skip file when [`SKIP_ENV`] asks to skip, named after the `cargo test` process that
/// started every test binary; `None` when missing prerequisites fail.
fn skip() -> Option<PathBuf> {
    let run = std::os::unix::process::parent_id();
    std::env::var(SKIP_ENV)
        .is_ok_and(|v| v == "1")
        .then(|| std::env::temp_dir().join(format!("sms-skipped-{run}")))
}

/// A missing prerequisite described by `what`: a panic (failing the test) naming the opt-out, or
/// with a skip file a skip line to `out`, counted in that file, and `None`. The callers' `out` is
/// the process's stderr itself: the harness captures `eprintln!` of a passing test.
fn missing<T>(skip: Option<PathBuf>, what: String, out: &mut dyn Write) -> Option<T> {
    let Some(file) = skip else { panic!("{what} (or set {SKIP_ENV}=1 to skip the tests that need it)") };
    let test = test_name();
    let count = count_line(&file, &test).map_or_else(String::new, |n| format!(" {n} in this cargo run"));
    let _ = writeln!(out, "SKIPPED{count}: {test}: {what}");
    None
}

/// Appends `line` to `path` and returns how many lines it holds; `None` when the file cannot be
/// written (the skip line then carries no count).
fn count_line(path: &Path, line: &str) -> Option<usize> {
    let mut file = std::fs::OpenOptions::new().create(true).append(true).open(path).ok()?;
    // One short write with O_APPEND: lines from parallel tests do not interleave.
    file.write_all(format!("{line}\n").as_bytes()).ok()?;
    Some(std::fs::read_to_string(path).ok()?.lines().count())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_prerequisite_fails_with_one_line_naming_the_fix() {
        let no_data = SceneLibrary::with_data_dir("/nonexistent/sms-scenes");
        let mesh = absent_mesh(&no_data).expect("nothing is in a folder that does not exist");
        assert!(mesh.contains("no such mesh file") && mesh.contains("SMS_SCENES_DIR"), "{mesh}");
        let tool = absent_tool(&["sh", "sms-no-such-tool"], "nothing").expect("no such tool");
        assert_eq!(tool, "sms-no-such-tool is not on PATH: install nothing");
        assert_eq!(absent_tool(&["sh"], "nothing"), None);
        let file = absent_file(Path::new("/nonexistent/models"), "the models").expect("no such file");
        assert_eq!(file, "/nonexistent/models is missing: install the models");
        assert_eq!(absent_file(Path::new("/"), "nothing"), None);
        for what in [mesh, tool, file] {
            assert!(!what.contains('\n'), "one line: {what}");
            let e = std::panic::catch_unwind(|| missing::<()>(None, what.clone(), &mut Vec::new()))
                .expect_err("a failure");
            let e = e.downcast_ref::<String>().expect("a formatted message");
            assert_eq!(*e, format!("{what} (or set SMS_SKIP_MISSING=1 to skip the tests that need it)"));
        }
    }

    #[test]
    fn a_scene_that_fails_to_load_for_another_reason_is_a_failure_not_a_skip() {
        assert!(std::panic::catch_unwind(|| scene("no-such-scene")).is_err());
        assert!(scene("wknd").is_some());
    }

    #[test]
    fn skips_are_counted_across_the_run() {
        let path = std::env::temp_dir().join(format!("sms-prereq-count-{}", std::process::id()));
        let _ = std::fs::remove_file(&path);
        let mut out = Vec::new();
        for _ in 0..2 {
            assert_eq!(missing::<()>(Some(path.clone()), "x is missing".into(), &mut out), None, "a skip");
        }
        let test = test_name();
        assert!(test.ends_with("skips_are_counted_across_the_run") || test == "a test", "{test}");
        assert_eq!(
            String::from_utf8(out).unwrap(),
            format!("SKIPPED 1 in this cargo run: {test}: x is missing\nSKIPPED 2 in this cargo run: {test}: x is missing\n")
        );
        assert_eq!(count_line(&path, "another test"), Some(3), "each skip adds one line to the run's file");
        std::fs::remove_file(&path).unwrap();
    }
}
