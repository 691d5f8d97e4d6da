//! Helpers shared by the integration tests (`mod common;` in each test file).
// Each test crate uses a different part of this module.
#![allow(dead_code)]

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

/// A small square workload of `scene`: `res × res` pixels, 1 spp, 1 bounce, child order `order`.
pub fn small_workload(
    scene: &tb::workload::scene::Scene,
    res: u32,
    order: tb::workload::traverse::ChildOrder,
) -> tb::workload::Workload<'_> {
    use tb::workload::{Workload, WorkloadOpts};
    Workload::new(scene, WorkloadOpts { order, ..WorkloadOpts::quick(scene, res) }).unwrap()
}
