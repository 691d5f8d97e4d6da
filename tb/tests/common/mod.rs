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
