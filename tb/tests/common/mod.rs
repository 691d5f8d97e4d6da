//! Helpers shared by the integration tests (`mod common;` in each test file): the shared test
//! support ([`tb::testing`]: building and running the model) and what needs the `sms` binary
//! built for these tests.
// Each test crate uses a different part of this module.
#![allow(dead_code, unused_imports)]

pub use tb::testing::*;

use std::path::PathBuf;

/// The workload flags of a tiny end-to-end run: 16×16 pixels, 1 sample, 1 bounce.
pub const TINY: [&str; 6] = ["--res", "16x16", "--spp", "1", "--bounces", "1"];

/// Runs the `sms` binary built for the tests with `args`, then `more`; stdout on success, a panic
/// with stderr otherwise.
pub fn sms(args: &[&str], more: &[&str]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_sms"))
        .args(args)
        .args(more)
        .output()
        .expect("sms runs");
    assert!(out.status.success(), "sms {args:?} {more:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("utf-8")
}

/// What one run of the `sms` binary built for the tests ended with: its exit status (`None`
/// when a signal ended it), stdout and stderr.
pub struct Ran {
    pub code: Option<i32>,
    pub stdout: String,
    pub stderr: String,
}

/// Runs the `sms` binary built for the tests with `args`, whatever its exit status.
pub fn sms_status(args: &[&str]) -> Ran {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_sms")).args(args).output().expect("sms runs");
    Ran {
        code: out.status.code(),
        stdout: String::from_utf8(out.stdout).expect("utf-8"),
        stderr: String::from_utf8(out.stderr).expect("utf-8"),
    }
}

/// A scratch directory removed when the test ends.
pub struct TmpDir(PathBuf);

impl TmpDir {
    /// `<tmp>/sms-<suite>-<pid>-<test>`.
    pub fn new(suite: &str, test: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("sms-{suite}-{}-{test}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        TmpDir(dir)
    }

    pub fn path(&self) -> &std::path::Path {
        &self.0
    }

    pub fn join(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for TmpDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Every file of a report folder (recursively, the cache excluded) with its bytes; the run's wall
/// times and peak memory removed (`timing.json`, two lines of `summary.md`).
pub fn report_files(dir: &std::path::Path) -> Vec<(PathBuf, Vec<u8>)> {
    fn walk(root: &std::path::Path, dir: &std::path::Path, out: &mut Vec<(PathBuf, Vec<u8>)>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(root).unwrap().to_path_buf();
            if p.is_dir() {
                if rel != std::path::Path::new("cache") {
                    walk(root, &p, out);
                }
            } else if rel != std::path::Path::new("timing.json") {
                let mut bytes = std::fs::read(&p).unwrap();
                if rel == std::path::Path::new("summary.md") {
                    let text = String::from_utf8(bytes).unwrap();
                    let kept: Vec<&str> = text
                        .lines()
                        .map(|l| if l.contains(" s wall time") { "(wall time)" } else { l })
                        .filter(|l| !l.starts_with("Peak memory: "))
                        .collect();
                    bytes = kept.join("\n").into_bytes();
                }
                out.push((rel, bytes));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

pub fn assert_same_reports(a: &std::path::Path, b: &std::path::Path, what: &str) {
    let (x, y) = (report_files(a), report_files(b));
    assert_eq!(
        x.iter().map(|f| &f.0).collect::<Vec<_>>(),
        y.iter().map(|f| &f.0).collect::<Vec<_>>(),
        "{what}: the same files"
    );
    assert!(x.len() > 30, "every figure, depth histogram and report");
    for ((name, p), (_, q)) in x.iter().zip(&y) {
        assert!(p == q, "{what}: {} differs", name.display());
    }
}
