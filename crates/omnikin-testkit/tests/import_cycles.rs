//! No import cycles between the modules (files) of any workspace crate.
//!
//! A module that uses another which uses it back is one concept split over two files, or two
//! concepts tangled; either way neither can be read, tested or moved alone. This test builds,
//! for every crate under `crates/`, the graph "file A names a path `crate::…`, `super::…` or
//! `self::…` that lands in file B" (outside comments and after the first `#[cfg(test)]`, which
//! the crates keep at the end of a file), ignores edges to a module's own ancestors (a parent's
//! re-exports), and fails on every strongly connected component of more than one file that is
//! not in [`KNOWN`] — and on a [`KNOWN`] entry that no longer matches, so the list only shrinks.
//! (It replaces the planner's own check of `src/planner/`, which it covers.)

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Cycles that exist and are still to be untangled: crate, then the files of the cycle as
/// module paths. A cycle found here must be exactly one of these, or a subset of one (part of
/// it untangled: then shrink the entry). None today: keep it so.
const KNOWN: &[(&str, &[&str])] = &[];

type Module = Vec<String>;

fn module_of(src: &Path, file: &Path) -> Module {
    let rel = file.strip_prefix(src).expect("under src");
    let mut parts: Module = rel
        .iter()
        .map(|p| p.to_string_lossy().trim_end_matches(".rs").to_string())
        .collect();
    if matches!(
        parts.last().map(String::as_str),
        Some("mod" | "lib" | "main")
    ) {
        parts.pop();
    }
    parts
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .expect("readable source folder")
        .map(|e| e.expect("entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The code of a file that counts: before its first `#[cfg(test)]`, without comment lines.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

fn is_ident(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// Every path that starts with `crate`, `super` or `self` in `code`, as its segments; a group
/// `a::{b::C, d}` gives one path per item (first segment of each item).
fn paths(code: &str) -> Vec<Vec<String>> {
    let bytes: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let at_word = i == 0 || !is_ident(bytes[i - 1]);
        let rest: String = bytes[i..bytes.len().min(i + 8)].iter().collect();
        let head = ["crate::", "super::", "self::"]
            .into_iter()
            .find(|h| at_word && rest.starts_with(h));
        let Some(head) = head else {
            i += 1;
            continue;
        };
        let mut segs = vec![head.trim_end_matches("::").to_string()];
        let mut j = i + head.len();
        loop {
            if bytes.get(j) == Some(&'{') {
                // One level of a use group: the first segment of each item.
                let close = bytes[j..].iter().position(|&c| c == '}').map(|k| j + k);
                let inner: String = bytes[j + 1..close.unwrap_or(bytes.len())].iter().collect();
                for item in inner.split(',') {
                    let first: String = item.trim().chars().take_while(|&c| is_ident(c)).collect();
                    if !first.is_empty() {
                        let mut p = segs.clone();
                        p.push(first);
                        out.push(p);
                    }
                }
                segs.clear();
                j = close.unwrap_or(bytes.len());
                break;
            }
            let start = j;
            while j < bytes.len() && is_ident(bytes[j]) {
                j += 1;
            }
            if j > start {
                segs.push(bytes[start..j].iter().collect());
            }
            if j + 2 < bytes.len() && bytes[j] == ':' && bytes[j + 1] == ':' {
                j += 2;
                continue;
            }
            break;
        }
        if !segs.is_empty() {
            out.push(segs);
        }
        i = j.max(i + 1);
    }
    out
}

/// The module-to-module edges of one crate's `src/`.
fn graph(src: &Path) -> BTreeMap<Module, BTreeSet<Module>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    let modules: BTreeMap<Module, PathBuf> = files
        .iter()
        .map(|f| (module_of(src, f), f.clone()))
        .collect();
    let mut g: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for (m, f) in &modules {
        let text = std::fs::read_to_string(f).expect("readable source");
        let mut edges = BTreeSet::new();
        for p in paths(&code(&text)) {
            let mut path: Module = match p[0].as_str() {
                "crate" => Vec::new(),
                "super" => m[..m.len().saturating_sub(1)].to_vec(),
                _ => m.clone(),
            };
            for s in &p[1..] {
                if s == "super" {
                    path.pop();
                } else {
                    path.push(s.clone());
                }
            }
            let target = (0..=path.len())
                .rev()
                .map(|k| path[..k].to_vec())
                .find(|k| modules.contains_key(k));
            if let Some(t) = target
                && t != *m
                && !m.starts_with(&t)
            {
                edges.insert(t);
            }
        }
        g.insert(m.clone(), edges);
    }
    g
}

/// Strongly connected components with more than one module (Tarjan).
fn cycles(g: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<BTreeSet<Module>> {
    struct State<'a> {
        g: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<&'a Module, usize>,
        low: BTreeMap<&'a Module, usize>,
        stack: Vec<&'a Module>,
        on: BTreeSet<&'a Module>,
        out: Vec<BTreeSet<Module>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a Module) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on.insert(v);
        for w in &s.g[v] {
            if !s.index.contains_key(w) {
                visit(s, w);
                let lw = s.low[w];
                let lv = s.low.get_mut(v).expect("visited");
                *lv = (*lv).min(lw);
            } else if s.on.contains(w) {
                let iw = s.index[w];
                let lv = s.low.get_mut(v).expect("visited");
                *lv = (*lv).min(iw);
            }
        }
        if s.low[v] == s.index[v] {
            let mut comp = BTreeSet::new();
            while let Some(w) = s.stack.pop() {
                s.on.remove(w);
                comp.insert(w.clone());
                if w == v {
                    break;
                }
            }
            if comp.len() > 1 {
                s.out.push(comp);
            }
        }
    }
    let mut s = State {
        g,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in g.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out
}

fn shown(c: &BTreeSet<Module>) -> String {
    let names: Vec<String> = c.iter().map(|m| m.join("::")).collect();
    names.join(", ")
}

#[test]
fn no_crate_has_an_import_cycle_beyond_the_known_ones() {
    let crates = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut found: Vec<(String, BTreeSet<Module>)> = Vec::new();
    let mut names: Vec<_> = std::fs::read_dir(&crates)
        .expect("crates/")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.join("src").is_dir())
        .collect();
    names.sort();
    assert!(
        names.len() >= 5,
        "the workspace's crates are not beside this one"
    );
    for dir in names {
        let name = dir.file_name().expect("name").to_string_lossy().to_string();
        let g = graph(&dir.join("src"));
        if name == "omnikin-plan" {
            // The parser sees imports at all (a silent parser would pass anything): `timing`
            // names `grid` and `time_optimal` through `use super::…`.
            let timing = &g[&vec!["planner".to_string(), "timing".to_string()]];
            for t in ["grid", "time_optimal"] {
                assert!(
                    timing.contains(&vec!["planner".to_string(), t.to_string()]),
                    "planner::timing -> planner::{t} not seen: {timing:?}"
                );
            }
        }
        for c in cycles(&g) {
            found.push((name.clone(), c));
        }
    }
    let known: Vec<(String, BTreeSet<Module>)> = KNOWN
        .iter()
        .map(|(k, ms)| {
            let set = ms
                .iter()
                .map(|m| m.split("::").map(str::to_string).collect())
                .collect();
            (k.to_string(), set)
        })
        .collect();
    let mut problems = Vec::new();
    for (k, c) in &found {
        if !known.iter().any(|(kk, kc)| kk == k && c.is_subset(kc)) {
            problems.push(format!("{k}: a new import cycle between {}", shown(c)));
        }
    }
    for (k, kc) in &known {
        if !found.iter().any(|(fk, c)| fk == k && c == kc) {
            problems.push(format!(
                "{k}: the known cycle {} is gone or smaller: shrink or remove its entry in KNOWN",
                shown(kc)
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_detector_sees_a_cycle_through_a_use_group() {
    let dir = std::env::temp_dir().join(format!("omnikin-cycles-{}", std::process::id()));
    let src = dir.join("src");
    std::fs::create_dir_all(src.join("a")).expect("temp dir");
    std::fs::write(src.join("lib.rs"), "mod a;\nmod b;\n").expect("write");
    std::fs::write(src.join("a/mod.rs"), "mod inner;\n").expect("write");
    std::fs::write(
        src.join("a/inner.rs"),
        "// use crate::b; (a comment: no edge)\nuse crate::{b::Thing, c};\n",
    )
    .expect("write");
    std::fs::write(src.join("b.rs"), "pub struct Thing(super::a::inner::X);\n").expect("write");
    let found = cycles(&graph(&src));
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(shown(&found[0]), "a::inner, b");
}
