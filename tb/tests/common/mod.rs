//! Helpers shared by the integration tests (`mod common;` in each test file).
// Each test crate uses a different part of this module.
#![allow(dead_code)]

use std::path::PathBuf;

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
    let opts = WorkloadOpts {
        width: res,
        height: res,
        spp: 1,
        max_bounces: 1,
        order,
        ..WorkloadOpts::for_scene(scene)
    };
    Workload::new(scene, opts).unwrap()
}
