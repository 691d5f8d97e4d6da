//! Embeds the shipped scene descriptions (`../scenes/*.toml`) in the library, so an installed
//! `sms` knows the described scenes without its source tree: `$OUT_DIR/shipped_scenes.rs` is
//! a `&[(name, text)]` list sorted by name, read by `tb::workload::scene::SHIPPED`.
//!
//! Also sets `SMS_MODEL_VERSION`, a hash of every source the model's results can depend on
//! (`rtl/src`, `tb/src`, both manifests, the workspace lock file and the enabled features): the
//! sweep's result cache keys on it, so any change to the model invalidates every cached result.
//!
//! And `SMS_GIT_COMMIT`: the commit the sources were built from, with `-dirty` when the model's
//! sources differ from it, or empty when there is no git checkout (a source tarball) or no git.
//! Every report states it beside the source hash (`tb::report::provenance`).

use std::path::{Path, PathBuf};

/// FNV-1a, 128 bits.
struct Fnv(u128);

impl Fnv {
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 = (self.0 ^ u128::from(x)).wrapping_mul(0x0000000001000000000000000000013B);
        }
    }
}

/// Every file under `dir`, recursively.
fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    if let Ok(entries) = std::fs::read_dir(dir) {
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                files(&path, out);
            } else {
                out.push(path);
            }
        }
    }
}

/// The model version: the hash of the sources under `manifest` (tb) and `manifest/../rtl`, by
/// path relative to the workspace and content.
fn model_version(manifest: &Path) -> String {
    let root = manifest.join("..");
    let mut sources = Vec::new();
    for dir in ["rtl/src", "tb/src"] {
        let dir = root.join(dir);
        println!("cargo:rerun-if-changed={}", dir.display());
        files(&dir, &mut sources);
    }
    for file in ["Cargo.lock", "Cargo.toml", "rtl/Cargo.toml", "tb/Cargo.toml"] {
        let file = root.join(file);
        println!("cargo:rerun-if-changed={}", file.display());
        sources.push(file);
    }
    sources.sort();
    let mut h = Fnv(0x6c62272e07bb014262b821756295c58d);
    for path in &sources {
        let name = path.strip_prefix(&root).unwrap_or(path);
        h.bytes(name.to_string_lossy().as_bytes());
        h.bytes(&[0]);
        let text = std::fs::read(path).unwrap_or_default();
        h.bytes(&(text.len() as u64).to_le_bytes());
        h.bytes(&text);
    }
    let mut features: Vec<String> =
        std::env::vars().map(|(k, _)| k).filter(|k| k.starts_with("CARGO_FEATURE_")).collect();
    features.sort();
    h.bytes(features.join(",").as_bytes());
    format!("{:032x}", h.0)
}

/// `git` run in `dir`, its trimmed stdout; `None` when git is missing or fails.
fn git(dir: &Path, args: &[&str]) -> Option<String> {
    let out = std::process::Command::new("git").arg("-C").arg(dir).args(args).output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).trim().to_owned())
}

/// The commit HEAD names (`-dirty` when the model's sources differ from it), or "" outside git.
/// Reruns when HEAD moves: HEAD itself, the branch it names and packed refs.
fn git_commit(manifest: &Path) -> String {
    let root = manifest.join("..");
    let Some(commit) = git(&root, &["rev-parse", "HEAD"]) else { return String::new() };
    for (flag, file) in [("--git-dir", "HEAD"), ("--git-common-dir", "packed-refs")] {
        if let Some(dir) = git(&root, &["rev-parse", flag]) {
            println!("cargo:rerun-if-changed={}", root.join(dir).join(file).display());
        }
    }
    if let (Some(dir), Some(branch)) =
        (git(&root, &["rev-parse", "--git-common-dir"]), git(&root, &["symbolic-ref", "-q", "HEAD"]))
    {
        println!("cargo:rerun-if-changed={}", root.join(dir).join(branch).display());
    }
    let sources = ["rtl/src", "tb/src", "Cargo.lock", "Cargo.toml", "rtl/Cargo.toml", "tb/Cargo.toml"];
    let mut status = vec!["status", "--porcelain", "--"];
    status.extend(sources);
    // Untracked sources count as changes, as edits do.
    let clean = git(&root, &status).is_some_and(|s| s.is_empty());
    if clean {
        commit
    } else {
        format!("{commit}-dirty")
    }
}

fn main() {
    let manifest = std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR");
    let dir = Path::new(&manifest).join("../scenes");
    println!("cargo:rerun-if-changed={}", dir.display());
    let mut scenes: Vec<(String, String)> = Vec::new();
    if let Ok(entries) = std::fs::read_dir(&dir) {
        for entry in entries.flatten() {
            let path = entry.path();
            if path.extension().is_some_and(|e| e == "toml") {
                let name = path.file_stem().and_then(|s| s.to_str()).expect("UTF-8 scene name").to_owned();
                let abs = path.canonicalize().expect("scene description path");
                scenes.push((name, abs.to_str().expect("UTF-8 path").to_owned()));
            }
        }
    }
    scenes.sort();
    let mut code = String::from("&[\n");
    for (name, path) in &scenes {
        code += &format!("    ({name:?}, include_str!({path:?})),\n");
    }
    code += "]\n";
    let out = Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("shipped_scenes.rs");
    std::fs::write(out, code).expect("write shipped_scenes.rs");
    println!("cargo:rustc-env=SMS_MODEL_VERSION={}", model_version(Path::new(&manifest)));
    println!("cargo:rustc-env=SMS_GIT_COMMIT={}", git_commit(Path::new(&manifest)));
}
