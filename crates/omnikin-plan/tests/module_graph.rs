//! The planner's modules import each other in one direction: no `use super::…` cycle among
//! the files of a folder module (e.g. `src/planner/`), so each file can be read knowing only
//! the ones it names. Reads the sources; a new cycle fails with the path of the loop.

use std::collections::BTreeMap;
use std::path::Path;

/// The sibling modules each file of `dir` names through `super::NAME` in code (comment lines,
/// doc links included, are skipped).
fn sibling_imports(dir: &Path) -> BTreeMap<String, Vec<String>> {
    let mut files = BTreeMap::new();
    for entry in std::fs::read_dir(dir).expect("module folder readable") {
        let path = entry.expect("dir entry").path();
        let name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default()
            .to_owned();
        if path.extension().is_some_and(|e| e == "rs") && name != "mod" {
            files.insert(
                name,
                std::fs::read_to_string(&path).expect("source readable"),
            );
        }
    }
    let mut graph = BTreeMap::new();
    for (name, text) in &files {
        let mut deps: Vec<String> = Vec::new();
        for line in text.lines().filter(|l| !l.trim_start().starts_with("//")) {
            for (i, _) in line.match_indices("super::") {
                let rest = &line[i + "super::".len()..];
                // `super::a::b`, and every `x::` inside `super::{a::b, c::d}`.
                let names: Vec<&str> = match rest.strip_prefix('{') {
                    Some(group) => group
                        .split('}')
                        .next()
                        .unwrap_or_default()
                        .split(',')
                        .filter_map(|p| p.trim().split_once("::").map(|(m, _)| m))
                        .collect(),
                    None => rest.split_once("::").map(|(m, _)| m).into_iter().collect(),
                };
                for m in names {
                    if m != name && files.contains_key(m) && !deps.iter().any(|d| d == m) {
                        deps.push(m.to_owned());
                    }
                }
            }
        }
        graph.insert(name.clone(), deps);
    }
    graph
}

/// A cycle in `graph` as the list of modules around it, if there is one.
fn find_cycle(graph: &BTreeMap<String, Vec<String>>) -> Option<Vec<String>> {
    fn visit(
        node: &str,
        graph: &BTreeMap<String, Vec<String>>,
        done: &mut Vec<String>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        if let Some(at) = stack.iter().position(|s| s == node) {
            let mut cycle = stack[at..].to_vec();
            cycle.push(node.to_owned());
            return Some(cycle);
        }
        if done.iter().any(|d| d == node) {
            return None;
        }
        stack.push(node.to_owned());
        for dep in graph.get(node).into_iter().flatten() {
            if let Some(c) = visit(dep, graph, done, stack) {
                return Some(c);
            }
        }
        stack.pop();
        done.push(node.to_owned());
        None
    }
    let (mut done, mut stack) = (Vec::new(), Vec::new());
    graph
        .keys()
        .find_map(|k| visit(k, graph, &mut done, &mut stack))
}

#[test]
fn cycle_finder_sees_a_loop() {
    let g: BTreeMap<String, Vec<String>> = [("a", vec!["b"]), ("b", vec!["c"]), ("c", vec!["a"])]
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v.into_iter().map(str::to_owned).collect()))
        .collect();
    assert_eq!(
        find_cycle(&g),
        Some(
            vec!["a", "b", "c", "a"]
                .into_iter()
                .map(str::to_owned)
                .collect()
        )
    );
}

#[test]
fn planner_modules_import_in_one_direction() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src/planner");
    let graph = sibling_imports(&dir);
    // The parser found the planner's imports at all (a silent parser would pass anything).
    assert!(graph["timing"].iter().any(|d| d == "grid"), "{graph:?}");
    assert!(
        graph["timing"].iter().any(|d| d == "time_optimal"),
        "{graph:?}"
    );
    assert_eq!(
        find_cycle(&graph),
        None,
        "import cycle among src/planner/*.rs; graph {graph:?}"
    );
}
