//! The shape of the code: no cycle among the top-level modules (the files and folders directly
//! under `src/` and `precompute/src/`), so that each crate reads as a flow from the scene
//! description to the image. A module uses another through `crate::NAME` (or `super::` reaching
//! the crate root); comments and doc links are not uses. The binary's `src/cli/` and `src/main.rs`
//! are another crate root and may use anything in the library.
//!
//! Run it alone with `cargo test --release --test main layout`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(sources(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files
}

/// The module path of a file below the crate root `src`: `integrators/dual/mod.rs` is
/// `[integrators, dual]`, `scene.rs` is `[scene]`.
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut parts: Vec<String> = rel.iter().map(|p| p.to_string_lossy().into_owned()).collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// The identifier starting `text` (empty when none).
fn ident(text: &str) -> &str {
    let end = text.find(|c: char| !(c.is_alphanumeric() || c == '_')).unwrap_or(text.len());
    &text[..end]
}

/// Adds the first name of the path `rest` to `uses`, or every first name of a `{A, B::c}` group.
fn heads(rest: &str, uses: &mut BTreeSet<String>) {
    let Some(group) = rest.strip_prefix('{') else {
        uses.insert(ident(rest).to_string());
        return;
    };
    let (mut depth, mut start) = (0, true);
    for (i, c) in group.char_indices() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => break,
            '}' => depth -= 1,
            ',' if depth == 0 => start = true,
            c if start && !c.is_whitespace() => {
                uses.insert(ident(&group[i..]).to_string());
                start = false;
            }
            _ => {}
        }
    }
}

/// The names used right below the crate root in `code`: `crate::NAME`, `crate::{A, B::c}`, and
/// `super::...::NAME` where the `super`s climb from `module` to the root.
fn root_uses(code: &str, module: &[String]) -> BTreeSet<String> {
    let mut uses = BTreeSet::new();
    for (at, _) in code.match_indices("crate::") {
        if !code[..at].ends_with('$') {
            // (`$crate` in a macro is the crate using the macro.)
            heads(&code[at + "crate::".len()..], &mut uses);
        }
    }
    for (at, _) in code.match_indices("super::") {
        if code[..at].ends_with("super::") {
            continue; // counted from the first `super` of the chain
        }
        let (mut rest, mut depth) = (&code[at..], module.len());
        while let Some(r) = rest.strip_prefix("super::") {
            rest = r;
            depth = depth.saturating_sub(1);
        }
        // Inside an inline `mod tests` a chain climbs one level less: only chains in the file's
        // own code before any such module are counted.
        if depth == 0 && code[..at].rfind("mod tests").is_none() {
            heads(rest, &mut uses);
        }
    }
    uses
}

/// The code of a file without its comments (`//` to the end of the line).
fn without_comments(text: &str) -> String {
    text.lines().map(|l| l.find("//").map_or(l, |i| &l[..i])).collect::<Vec<_>>().join("\n")
}

/// The graph of top-level modules of the crate rooted at `src` (skipping `skip`), as edges from
/// each module to the top-level modules it uses.
fn graph(src: &Path, skip: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in sources(src) {
        let module = module_path(src, &file);
        let Some(top) = module.first() else { continue };
        if ["lib", "main"].contains(&top.as_str()) || skip.contains(&top.as_str()) {
            continue;
        }
        let code = without_comments(&std::fs::read_to_string(&file).unwrap());
        let entry = edges.entry(top.clone()).or_default();
        entry.extend(root_uses(&code, &module).into_iter().filter(|u| u != top && !u.is_empty()));
    }
    let tops: BTreeSet<String> = edges.keys().cloned().collect();
    for uses in edges.values_mut() {
        uses.retain(|u| tops.contains(u));
    }
    edges
}

/// A cycle in `edges`, if there is one (depth-first search).
fn cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(node.to_string(), 1);
        stack.push(node.to_string());
        for next in edges.get(node).into_iter().flatten() {
            match state.get(next).copied().unwrap_or(0) {
                1 => {
                    let from = stack.iter().position(|n| n == next).unwrap();
                    return Some([&stack[from..], std::slice::from_ref(next)].concat());
                }
                0 => {
                    if let Some(c) = visit(next, edges, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(node.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for node in edges.keys() {
        if state.get(node).copied().unwrap_or(0) == 0
            && let Some(c) = visit(node, edges, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

fn show(edges: &BTreeMap<String, BTreeSet<String>>) -> String {
    edges.iter().map(|(m, uses)| format!("{m} -> {uses:?}\n")).collect()
}

fn assert_acyclic(src: &str, skip: &[&str]) {
    let edges = graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join(src), skip);
    assert!(edges.len() > 5, "{src}: found only {edges:?}");
    if let Some(c) = cycle(&edges) {
        panic!("{src}: the top-level modules form a cycle: {}\n{}", c.join(" -> "), show(&edges));
    }
    println!("{src}:\n{}", show(&edges));
}

#[test]
fn the_renderers_top_level_modules_have_no_cycle() {
    assert_acyclic("src", &["cli"]);
}

#[test]
fn precomputes_top_level_modules_have_no_cycle() {
    assert_acyclic("precompute/src", &[]);
}

#[test]
fn the_cycle_finder_finds_a_cycle_and_the_uses_it_reads() {
    // The check can fail: a cycle planted in a graph is found, and uses are read from every form.
    let module = vec!["integrators".to_string(), "dual".to_string()];
    let code = "use crate::{scene::Scene, film};\nlet x = crate::lights::sun();\nuse super::super::render;";
    let uses = root_uses(code, &module);
    assert_eq!(uses, ["film", "lights", "render", "scene"].map(String::from).into());
    let mut edges = BTreeMap::new();
    edges.insert("a".to_string(), BTreeSet::from(["b".to_string()]));
    edges.insert("b".to_string(), BTreeSet::from(["c".to_string()]));
    edges.insert("c".to_string(), BTreeSet::from(["a".to_string()]));
    assert_eq!(cycle(&edges), Some(["a", "b", "c", "a"].map(String::from).to_vec()));
    edges.get_mut("c").unwrap().clear();
    assert_eq!(cycle(&edges), None);
}
