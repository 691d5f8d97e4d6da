//! Embeds the shipped scene descriptions (`../scenes/*.toml`) in the library, so an installed
//! `sms` knows the described scenes without its source tree: `$OUT_DIR/shipped_scenes.rs` is
//! a `&[(name, text)]` list sorted by name, read by `tb::workload::scene::SHIPPED`.

use std::path::Path;

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
}
