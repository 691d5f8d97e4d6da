//! The crate's modules are layered: no cycle of `crate::` paths between its top-level modules.
//! The base layer (`config`, `logic`, `trace`, `clock`) depends on no unit; a unit depends on the
//! units inside it and the base; one SM's wiring (`sm`) and the GPU's netlist (`gpu`) on the
//! units; the runners (`sim`) on the units, `sm` and `gpu`, and nothing below them on the runners.
//! A cycle means two modules can only be read together.
//!
//! The test reads the sources (no parser: every `crate::a::b` path outside comments and outside a
//! file's `#[cfg(test)] mod tests` is an edge from the file's top-level module to `a`) and fails
//! naming each cycle. `a_planted_cycle_is_found` shows it finds one.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Top-level module of each source file under `src` (relative path, `/`-separated) and its text.
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

/// The top-level module a source file belongs to (`None` for the crate root).
fn top_module(rel: &str) -> Option<String> {
    let first = rel.split('/').next().unwrap();
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (name != "lib").then(|| name.to_string())
}

/// The code of a file without comments and without its unit tests.
fn code(src: &str) -> String {
    let mut s: String = src.lines().map(|l| l.split("//").next().unwrap()).collect::<Vec<_>>().join("\n");
    if let Some(i) = s.find("#[cfg(test)]\nmod tests") {
        s.truncate(i);
    }
    s
}

/// Edges between top-level modules: module → the top-level modules its code names by `crate::`.
fn graph(files: &[(String, String)]) -> BTreeMap<String, BTreeSet<String>> {
    let modules: BTreeSet<String> = files.iter().filter_map(|(rel, _)| top_module(rel)).collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (rel, src) in files {
        let Some(from) = top_module(rel) else { continue };
        let code = code(src);
        for (i, _) in code.match_indices("crate::") {
            let before = code[..i].chars().next_back();
            if before.is_some_and(|c| c.is_alphanumeric() || c == '_') {
                continue;
            }
            let rest = &code[i + "crate::".len()..];
            let to: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            if to != from && modules.contains(&to) {
                g.entry(from.clone()).or_default().insert(to);
            }
        }
        g.entry(from).or_default();
    }
    g
}

/// Every cycle's modules (strongly connected components of more than one module), sorted.
fn cycles(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<Vec<String>> {
    let reach = |from: &str| {
        let mut seen = BTreeSet::new();
        let mut todo = vec![from.to_string()];
        while let Some(m) = todo.pop() {
            for n in g.get(&m).into_iter().flatten() {
                if seen.insert(n.clone()) {
                    todo.push(n.clone());
                }
            }
        }
        seen
    };
    let reached: BTreeMap<&String, BTreeSet<String>> = g.keys().map(|m| (m, reach(m))).collect();
    let mut out: Vec<Vec<String>> = Vec::new();
    for m in g.keys() {
        if !reached[m].contains(m) || out.iter().any(|c| c.contains(m)) {
            continue;
        }
        let comp: Vec<String> = g
            .keys()
            .filter(|n| *n == m || (reached[m].contains(*n) && reached[*n].contains(m)))
            .cloned()
            .collect();
        out.push(comp);
    }
    out
}

#[test]
fn the_modules_form_no_cycle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let g = graph(&sources(&src));
    assert!(g.contains_key("config") && g.contains_key("gpu"), "modules read: {:?}", g.keys());
    let found = cycles(&g);
    assert!(found.is_empty(), "import cycles between modules: {found:?}\ngraph: {g:#?}");
}

#[test]
fn the_base_layer_depends_on_no_unit() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let g = graph(&sources(&src));
    for base in ["config", "logic", "trace", "clock"] {
        let deps: Vec<&String> =
            g[base].iter().filter(|d| !["config", "logic", "trace", "clock"].contains(&d.as_str())).collect();
        assert!(deps.is_empty(), "{base} depends on {deps:?}");
    }
}

/// The modules `from` reaches through `g`'s edges.
fn reach(g: &BTreeMap<String, BTreeSet<String>>, from: &str) -> BTreeSet<String> {
    let mut seen = BTreeSet::new();
    let mut todo = vec![from.to_string()];
    while let Some(m) = todo.pop() {
        for n in g.get(&m).into_iter().flatten() {
            if seen.insert(n.clone()) {
                todo.push(n.clone());
            }
        }
    }
    seen
}

/// The netlist modules that reach the runners (`sim`): each names a module that must stand below
/// them.
fn above_the_netlist(g: &BTreeMap<String, BTreeSet<String>>) -> Vec<&'static str> {
    ["gpu", "sm"].into_iter().filter(|m| reach(g, m).contains("sim")).collect()
}

#[test]
fn the_netlist_stands_below_its_runners() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let g = graph(&sources(&src));
    assert!(g.contains_key("sm") && g.contains_key("sim"), "modules read: {:?}", g.keys());
    assert!(
        above_the_netlist(&g).is_empty(),
        "the netlist depends on its runners: {:?}",
        above_the_netlist(&g)
    );
    // The runners clock the netlist: they name it.
    assert!(g["sim"].contains("gpu") && g["sim"].contains("sm"), "sim: {:?}", g["sim"]);
}

#[test]
fn a_netlist_that_names_its_runner_is_found() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = sources(&src);
    // The GPU naming a runner's type: the netlist standing on its runners.
    let gpu = files.iter_mut().find(|(rel, _)| rel == "gpu.rs").unwrap();
    gpu.1.insert_str(0, "pub use crate::sim::Runner;\n");
    assert_eq!(above_the_netlist(&graph(&files)), ["gpu"]);
    // Through another module too: `sm` naming a module that names `sim`.
    let mut files = sources(&src);
    let sm = files.iter_mut().find(|(rel, _)| rel == "sm.rs").unwrap();
    sm.1.insert_str(0, "use crate::stack_unit::Planted;\n");
    let unit = files.iter_mut().find(|(rel, _)| rel == "stack_unit.rs").unwrap();
    unit.1.insert_str(0, "use crate::sim::helper::Helper;\n");
    assert_eq!(above_the_netlist(&graph(&files)), ["gpu", "sm"]);
}

#[test]
fn a_planted_cycle_is_found() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = sources(&src);
    // The cycle this crate had: the widths sized a thread's state from the state machine itself.
    let config = files.iter_mut().find(|(rel, _)| rel == "config.rs").unwrap();
    config.1.insert_str(0, "const PLANTED: u64 = crate::thread_fsm::ThreadState::STATES;\n");
    let found = cycles(&graph(&files));
    assert!(
        found.iter().any(|c| c.contains(&"config".to_string()) && c.contains(&"thread_fsm".to_string())),
        "the planted cycle is not found: {found:?}"
    );
    // A path in a comment or a unit test is no edge.
    let files = vec![
        ("a.rs".to_string(), "use crate::b::X;\n".to_string()),
        (
            "b.rs".to_string(),
            "// crate::a::Y\n#[cfg(test)]\nmod tests {\n    use crate::a::Y;\n}\n".to_string(),
        ),
    ];
    assert!(cycles(&graph(&files)).is_empty());
    let files = vec![
        ("a.rs".to_string(), "use crate::b::X;\n".to_string()),
        ("b/mod.rs".to_string(), "mod c;\n".to_string()),
        ("b/c.rs".to_string(), "fn f() -> crate::a::Y { todo!() }\n".to_string()),
    ];
    assert_eq!(cycles(&graph(&files)), vec![vec!["a".to_string(), "b".to_string()]]);
}
