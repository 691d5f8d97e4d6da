//! The crate's modules are layered as `src/lib.rs` draws them: a top-level module names only
//! modules in lower layers (`LAYERS`, lowest first; modules in one layer do not name each other),
//! and no source file names another that names it back, directly or through others.
//!
//! The test reads the sources (no parser). A file's paths are those of its code outside comments
//! and outside its `#[cfg(test)]` modules (inline, or files declared under `#[cfg(test)]`):
//! `crate::a::b`, `super::a`, `self::a` and, in a module with child modules, `child::a`, with
//! `{..}` groups expanded, and an item the crate root re-exports read as the path it comes from.
//! Each names the deepest module file it reaches. A file naming a module that contains it
//! (`super::Item`) makes no circle. The tests fail naming each offending file and path, or each
//! circle.
//! `planted_violations_are_found` shows each check catches a synthetic import.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The layers, lowest first. A module may name modules of lower layers only.
const LAYERS: &[&[&str]] = &[
    // Errors, and digests of bytes (file hashes, model and hardware identities).
    &["error", "digest"],
    // Hardware descriptions and presets; waveform writing and checking.
    &["hw", "vcd"],
    // Scenes, BVHs, rays, recorded traversals, warps.
    &["workload"],
    // The proofs, and the specification the simulator's scoreboard and the verifier check against.
    &["prove"],
    // Simulation, sampling, the stack testbench and its verification, sweeps, the bench's and the
    // ablation's runs, and the provenance of what ran.
    &["run"],
    // Tables, figures, plots and report files.
    &["report"],
    // The Verilog printer, its co-simulation and synthesis (whose cost is a report).
    &["verilog"],
    // The `sms` commands; scene availability for tests; test helpers.
    &["cli", "prereq", "testing"],
];

/// Each source file under `src` (relative path, `/`-separated) and its text.
fn sources(src: &Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(src).unwrap().to_string_lossy().replace('\\', "/");
                out.push((rel, std::fs::read_to_string(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

/// The module path of a source file: `report/bench/mod.rs` → `report::bench`, `lib.rs` → ``.
/// `None` for binaries.
fn module_of(rel: &str) -> Option<String> {
    if rel.starts_with("bin/") || rel == "main.rs" {
        return None;
    }
    let stem = rel.strip_suffix(".rs").unwrap();
    let stem = stem.strip_suffix("/mod").unwrap_or(stem);
    Some(if stem == "lib" { String::new() } else { stem.replace('/', "::") })
}

fn join(a: &str, b: &str) -> String {
    if a.is_empty() {
        b.to_string()
    } else {
        format!("{a}::{b}")
    }
}

fn parent(m: &str) -> String {
    m.rsplit_once("::").map(|(p, _)| p.to_string()).unwrap_or_default()
}

/// Removes `{ .. }` starting at byte `open` (a `{`), braces balanced; returns the end.
fn block_end(s: &str, open: usize) -> usize {
    let mut depth = 0;
    for (i, c) in s[open..].char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    return open + i + 1;
                }
            }
            _ => {}
        }
    }
    s.len()
}

/// The code of a file without comments and without its inline `#[cfg(test)]` modules, and the
/// names of the child module files it declares under `#[cfg(test)]`.
fn code(src: &str) -> (String, Vec<String>) {
    let mut s: String = src.lines().map(|l| l.split("//").next().unwrap()).collect::<Vec<_>>().join("\n");
    let mut test_files = Vec::new();
    while let Some(i) = s.find("#[cfg(test)]") {
        let after = &s[i + "#[cfg(test)]".len()..];
        let item = after.trim_start();
        let Some(rest) = item.strip_prefix("mod ").or_else(|| item.strip_prefix("pub mod ")) else {
            s.replace_range(i..i + "#[cfg(test)]".len(), "");
            continue;
        };
        let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
        let tail = rest[name.len()..].trim_start();
        if tail.starts_with(';') {
            test_files.push(name);
            let end = s.len() - tail.len() + 1;
            s.replace_range(i..end, "");
        } else {
            let open = s.len() - tail.len();
            let end = block_end(&s, open);
            s.replace_range(i..end, "");
        }
    }
    (s, test_files)
}

/// The paths a piece of code names from byte `i` on (after its first segment), with `{..}`
/// groups expanded: `a::{b, c::d}` → `[a::b, a::c::d]`.
fn paths_at(code: &str, i: usize, prefix: &str, out: &mut Vec<String>) -> usize {
    let b = code.as_bytes();
    let mut i = i;
    let mut path = prefix.to_string();
    loop {
        while i < b.len() && b[i].is_ascii_whitespace() {
            i += 1;
        }
        if i < b.len() && b[i] == b'{' {
            i += 1;
            loop {
                while i < b.len() && (b[i].is_ascii_whitespace() || b[i] == b',') {
                    i += 1;
                }
                if i >= b.len() || b[i] == b'}' {
                    return i + 1;
                }
                let before = out.len();
                i = paths_at(code, i, &path, out);
                if out.len() == before {
                    i += 1;
                }
            }
        }
        let start = i;
        while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
            i += 1;
        }
        if start == i {
            out.push(path);
            return i;
        }
        let seg = &code[start..i];
        path = if seg == "self" { path } else { join(&path, seg) };
        if code[i..].starts_with("::") {
            i += 2;
        } else {
            out.push(path);
            // `a::b as c`: `c` is a new name, not a path.
            let rest = code[i..].trim_start();
            if let Some(alias) = rest.strip_prefix("as ") {
                let alias = alias.trim_start();
                let len = alias.chars().take_while(|c| c.is_alphanumeric() || *c == '_').count();
                return code.len() - alias.len() + len;
            }
            return i;
        }
    }
}

/// Every path a file's code names, resolved to an absolute module path (`crate::` dropped).
/// `children`: the child modules of the file's module.
fn named_paths(code: &str, module: &str, children: &BTreeSet<String>) -> Vec<String> {
    let b = code.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let word_start =
            i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_' || b[i - 1] == b':');
        if !word_start || !(b[i].is_ascii_alphabetic() || b[i] == b'_') {
            i += 1;
            continue;
        }
        let start = i;
        while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
            i += 1;
        }
        if !code[i..].starts_with("::") {
            continue;
        }
        let first = &code[start..i];
        let mut base = match first {
            "crate" => String::new(),
            "self" => module.to_string(),
            "super" => parent(module),
            c if children.contains(c) => join(module, c),
            _ => continue,
        };
        let mut j = i + 2;
        while first == "super" && code[j..].starts_with("super::") {
            base = parent(&base);
            j += "super::".len();
        }
        j = paths_at(code, j, &base, &mut out);
        i = j.max(i);
    }
    out
}

/// Files and what their code names: module path → (relative path, named module paths).
struct Crate {
    files: BTreeMap<String, (String, BTreeSet<String>)>,
}

fn read(files: &[(String, String)]) -> Crate {
    let mut modules: BTreeMap<String, String> = BTreeMap::new();
    for (rel, _) in files {
        if let Some(m) = module_of(rel) {
            modules.insert(m, rel.clone());
        }
    }
    let mut test_modules = BTreeSet::new();
    let mut codes = BTreeMap::new();
    for (rel, src) in files {
        let Some(m) = module_of(rel) else { continue };
        let (code, tests) = code(src);
        for t in tests {
            test_modules.insert(join(&m, &t));
        }
        codes.insert(m, (rel.clone(), code));
    }
    // A module declared under `#[cfg(test)]`, and everything inside it, is test code.
    let is_test = |m: &str| test_modules.iter().any(|t| m == t || m.starts_with(&format!("{t}::")));
    let children_of = |m: &str| -> BTreeSet<String> {
        modules
            .keys()
            .filter(|c| !c.is_empty() && parent(c) == m)
            .map(|c| c.rsplit("::").next().unwrap().to_string())
            .collect()
    };
    // What the crate root re-exports (`pub use workload::scene::Scene`): `Scene` → its path, so
    // `crate::Scene` names the module it comes from.
    let root_items: BTreeMap<String, String> = codes
        .get("")
        .map(|(_, code)| named_paths(code, "", &children_of("")))
        .into_iter()
        .flatten()
        .filter(|p| !modules.contains_key(p))
        .map(|p| (p.rsplit("::").next().unwrap().to_string(), p))
        .collect();
    let mut out = Crate { files: BTreeMap::new() };
    for (m, (rel, code)) in &codes {
        if is_test(m) {
            continue;
        }
        let mut named = BTreeSet::new();
        for p in named_paths(code, m, &children_of(m)) {
            let (first, rest) = p.split_once("::").unwrap_or((&p, ""));
            let p = match root_items.get(first) {
                Some(item) if !m.is_empty() => {
                    format!("{item}{}{rest}", if rest.is_empty() { "" } else { "::" })
                }
                _ => p.clone(),
            };
            // The deepest module file the path reaches.
            let mut q = p.as_str();
            loop {
                if modules.contains_key(q) {
                    break;
                }
                match q.rsplit_once("::") {
                    Some((a, _)) => q = a,
                    None => {
                        q = "";
                        break;
                    }
                }
            }
            if !q.is_empty() && q != m && !is_test(q) {
                named.insert(q.to_string());
            }
        }
        out.files.insert(m.clone(), (rel.clone(), named));
    }
    out
}

fn top(m: &str) -> &str {
    m.split("::").next().unwrap()
}

fn layer_of(m: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&top(m)))
}

/// Each path from a module to one it may not name: `file names module (top → top)`.
fn layer_violations(c: &Crate) -> Vec<String> {
    let mut out = Vec::new();
    for (m, (rel, named)) in &c.files {
        if m.is_empty() {
            continue;
        }
        let Some(from) = layer_of(m) else {
            out.push(format!("{rel}: module `{}` is in no layer", top(m)));
            continue;
        };
        for n in named {
            if top(n) == top(m) {
                continue;
            }
            match layer_of(n) {
                Some(to) if to < from => {}
                _ => out.push(format!("{rel} names {n} ({} → {})", top(m), top(n))),
            }
        }
    }
    out.sort();
    out.dedup();
    out
}

/// Every circle of files (strongly connected components of more than one file), each sorted.
/// A file naming a module that contains it (`super::Item` of the enclosing `mod.rs`) is no edge
/// here: a module's files use what the module declares, and the module reaches into them.
fn circles(c: &Crate) -> Vec<Vec<String>> {
    let g: BTreeMap<&String, BTreeSet<String>> = c
        .files
        .iter()
        .map(|(m, (_, n))| (m, n.iter().filter(|n| !m.starts_with(&format!("{n}::"))).cloned().collect()))
        .collect();
    let reach = |from: &String| {
        let mut seen = BTreeSet::new();
        let mut todo = vec![from.clone()];
        while let Some(m) = todo.pop() {
            for n in g.get(&m).into_iter().flatten() {
                if seen.insert(n.clone()) {
                    todo.push(n.clone());
                }
            }
        }
        seen
    };
    let reached: BTreeMap<&String, BTreeSet<String>> = g.keys().map(|m| (*m, reach(m))).collect();
    let mut out: Vec<Vec<String>> = Vec::new();
    for m in g.keys() {
        if !reached[*m].contains(*m) || out.iter().any(|c| c.contains(*m)) {
            continue;
        }
        let comp: Vec<String> = g
            .keys()
            .filter(|n| **n == *m || (reached[*m].contains(**n) && reached[**n].contains(*m)))
            .map(|n| n.to_string())
            .collect();
        out.push(comp);
    }
    out
}

fn crate_sources() -> Vec<(String, String)> {
    sources(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"))
}

#[test]
fn every_module_names_only_lower_layers() {
    let files = crate_sources();
    let c = read(&files);
    let tops: BTreeSet<&str> = c.files.keys().filter(|m| !m.is_empty()).map(|m| top(m)).collect();
    let declared: BTreeSet<&str> = LAYERS.iter().flat_map(|l| l.iter().copied()).collect();
    assert_eq!(tops, declared, "the crate's top-level modules and the declared layers differ");
    let bad = layer_violations(&c);
    assert!(bad.is_empty(), "modules naming a module of their own or a higher layer:\n{}", bad.join("\n"));
}

#[test]
fn no_files_name_each_other_in_a_circle() {
    let c = read(&crate_sources());
    assert!(c.files.len() > 50, "files read: {}", c.files.len());
    let found = circles(&c);
    assert!(found.is_empty(), "files naming each other in a circle: {found:?}");
}

/// The layers a crate-root doc picture draws, top to bottom: each line of the picture that
/// starts with a module name lists its layer's modules, comma-separated, up to two spaces.
fn picture(lib: &str) -> Vec<Vec<String>> {
    lib.lines()
        .filter_map(|l| l.strip_prefix("//!   "))
        .filter(|l| l.starts_with(|c: char| c.is_ascii_lowercase()))
        .map(|l| l.split("  ").next().unwrap().split(',').map(|m| m.trim().to_string()).collect())
        .collect()
}

/// `LAYERS` top to bottom, as the picture draws them.
fn layers_top_down() -> Vec<Vec<String>> {
    LAYERS.iter().rev().map(|l| l.iter().map(|m| m.to_string()).collect()).collect()
}

#[test]
fn the_crate_root_draws_the_layers() {
    let lib = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs")).unwrap();
    assert_eq!(picture(&lib), layers_top_down(), "src/lib.rs's picture and LAYERS differ");
}

#[test]
fn planted_violations_are_found() {
    let mut files = crate_sources();
    let before = layer_violations(&read(&files));
    // A run module reaching up into the reports, in a `use` group.
    let sim = files.iter_mut().find(|(rel, _)| rel == "run/sim.rs").unwrap();
    sim.1.push_str("\nuse crate::{error::Error as _E, report::table::Table as _T};\n");
    // A layer's files naming each other: each is a circle of two.
    files.push(("workload/planted_a.rs".into(), "use super::planted_b::B;\npub struct A;\n".into()));
    files.push(("workload/planted_b.rs".into(), "pub struct B(crate::workload::planted_a::A);\n".into()));
    // A module naming one beside it in its layer.
    let vcd = files.iter_mut().find(|(rel, _)| rel == "vcd/mod.rs").unwrap();
    vcd.1.push_str("\nfn planted(_: crate::hw::Hardware) {}\n");
    // A module below workload naming a workload type through the crate root's re-export.
    let hw = files.iter_mut().find(|(rel, _)| rel == "hw/mod.rs").unwrap();
    hw.1.push_str("\nfn planted(_: &crate::Scene) {}\n");
    // A module in no layer.
    files.push(("planted.rs".into(), "pub struct P;\n".into()));
    let c = read(&files);
    let found: Vec<String> = layer_violations(&c).into_iter().filter(|v| !before.contains(v)).collect();
    assert_eq!(
        found,
        vec![
            "hw/mod.rs names workload::scene (hw → workload)".to_string(),
            "planted.rs: module `planted` is in no layer".to_string(),
            "run/sim.rs names report::table (run → report)".to_string(),
            "vcd/mod.rs names hw (vcd → hw)".to_string(),
        ]
    );
    assert!(
        circles(&c).contains(&vec!["workload::planted_a".to_string(), "workload::planted_b".to_string()]),
        "the planted circle is not found: {:?}",
        circles(&c)
    );

    // A picture with two layers swapped, or a module left out, is not `LAYERS`.
    let lib = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/lib.rs")).unwrap();
    let swapped =
        lib.replacen("//!   report ", "//!   REPORT ", 1).replacen("//!   run ", "//!   report ", 1);
    let swapped = swapped.replacen("//!   REPORT ", "//!   run ", 1);
    assert_ne!(picture(&swapped), layers_top_down());
    assert_ne!(picture(&lib.replacen("hw, vcd", "hw", 1)), layers_top_down());

    // What is no edge: comments, unit tests (inline or a file declared under `#[cfg(test)]`),
    // other crates' paths.
    let files = vec![
        ("lib.rs".to_string(), "pub mod a;\npub mod b;\n".to_string()),
        ("a/mod.rs".to_string(), "use crate::b::X;\n#[cfg(test)]\nmod tests;\n".to_string()),
        ("a/tests.rs".to_string(), "use crate::b::Y;\n".to_string()),
        (
            "b.rs".to_string(),
            "// crate::a::Y\nuse rtl::a::Z;\n#[cfg(test)]\nmod tests {\n    use crate::a::Y;\n}\n"
                .to_string(),
        ),
    ];
    let c = read(&files);
    assert!(circles(&c).is_empty(), "{:?}", circles(&c));
    assert_eq!(c.files["b"].1, BTreeSet::new());
    // A child module, `super::super::` and nested groups resolve to the files they reach.
    let files = vec![
        ("lib.rs".to_string(), "pub mod a;\n".to_string()),
        ("a/mod.rs".to_string(), "mod b;\nmod c;\nfn f() { b::g(); }\n".to_string()),
        ("a/b.rs".to_string(), "pub fn g() {}\n".to_string()),
        ("a/c/mod.rs".to_string(), "mod d;\n".to_string()),
        ("a/c/d.rs".to_string(), "use super::super::{b::g, c::{self}};\n".to_string()),
    ];
    let c = read(&files);
    assert_eq!(c.files["a"].1, BTreeSet::from(["a::b".to_string()]));
    assert_eq!(c.files["a::c::d"].1, BTreeSet::from(["a::b".to_string(), "a::c".to_string()]));
}
