//! The crate's layers, and the test that keeps every import pointing down.
//!
//! Each top-level module of `src/` belongs to one layer. A module may use modules of its
//! own layer and of the layers below it, never one above, and the modules may not import
//! each other in a cycle (not even within one layer). The command (`src/main.rs`,
//! `src/cli/`) sits on top as its own crate: it sees the library only through `fdid::`.
//!
//! | layer | modules | holds |
//! |---|---|---|
//! | foundation | `scalar`, `error`, `stats`, `test_rng`, `progress`, `recycle` | the float trait, errors, distributions, progress reports, buffers kept between fits |
//! | linear algebra | `linalg`, `basis`, `roots` | least squares, SVD, Gram kernels, polynomial bases, roots |
//! | data | `data`, `simulate`, `io` | frequency and time data, signals and systems to simulate, file readers |
//! | model | `model`, `greybox` | structures θ ↦ G(θ, ω) and their factors: rational, modal, delay, noise model, grey box |
//! | criterion | `problem`, `criterion` | what is minimised, as problem kinds for the solvers |
//! | solver | `solver` | how one problem is minimised |
//! | fit | `fit`, `fitted`, `validation` | a fitted model with its statistics, covariance and validation |
//! | estimate | `estimate`, `ltv` | every strategy that runs criteria and solvers: chains, starts, delay search, stages |
//! | workflow | `workflow` | the discrepancy workflow: detectors, hypotheses, tests |
//!
//! The test reads every `crate::` path in the code of each file (comments and doc links
//! are not imports) and fails on a path into a higher layer, on a cycle between modules,
//! and on a module that the table does not place.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The layers, lowest first.
const LAYERS: &[(&str, &[&str])] = &[
    (
        "foundation",
        &[
            "scalar", "error", "stats", "test_rng", "progress", "recycle",
        ],
    ),
    ("linear algebra", &["linalg", "basis", "roots"]),
    ("data", &["data", "simulate", "io"]),
    ("model", &["model", "greybox"]),
    ("criterion", &["problem", "criterion"]),
    ("solver", &["solver"]),
    ("fit", &["fit", "fitted", "validation"]),
    ("estimate", &["estimate", "ltv", "mimo"]),
    ("workflow", &["workflow"]),
];

/// Files outside the layers: the crate root (its re-exports and prelude name every layer),
/// the guide's doc tests (`guide.rs`, compiled only for them) and the command, a crate of
/// its own.
fn outside_layers(rel: &Path) -> bool {
    ["lib.rs", "main.rs", "guide.rs"]
        .iter()
        .any(|f| rel == Path::new(f))
        || rel.starts_with("cli")
}

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|(_, ms)| ms.contains(&module))
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .expect("read src")
        .map(|e| e.expect("dir entry").path())
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

/// The code of a Rust file with comments, string literals (raw ones included) and
/// character literals blanked, so that a quote inside `'"'` or `r#"…"#` cannot hide code.
fn code_only(src: &str) -> String {
    let b = src.as_bytes();
    let mut out = String::with_capacity(src.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            i = block_comment_end(b, i);
        } else if let Some(end) = raw_string_end(b, i) {
            i = end;
            out.push_str("\"\"");
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += if b[i] == b'\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if let Some(end) = char_literal_end(src, i) {
            i = end;
            out.push_str("' '");
        } else {
            let c = src[i..].chars().next().expect("char");
            out.push(c);
            i += c.len_utf8();
        }
    }
    out
}

/// The index after the (nested) block comment starting at `i`.
fn block_comment_end(b: &[u8], mut i: usize) -> usize {
    let mut depth = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            depth += 1;
            i += 2;
        } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
            depth -= 1;
            i += 2;
            if depth == 0 {
                break;
            }
        } else {
            i += 1;
        }
    }
    i
}

/// The index after a raw string `r"…"`, `r#"…"#`, … starting at `i`, if one starts there
/// (and `r` does not end an identifier).
fn raw_string_end(b: &[u8], i: usize) -> Option<usize> {
    let ident_before = i > 0 && (b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'_');
    if b[i] != b'r' || ident_before {
        return None;
    }
    let hashes = b[i + 1..].iter().take_while(|c| **c == b'#').count();
    let open = i + 1 + hashes;
    if b.get(open) != Some(&b'"') {
        return None;
    }
    let mut k = open + 1;
    while k < b.len() {
        if b[k] == b'"'
            && b[k + 1..]
                .iter()
                .take(hashes)
                .filter(|c| **c == b'#')
                .count()
                == hashes
        {
            return Some(k + 1 + hashes);
        }
        k += 1;
    }
    Some(b.len())
}

/// The index after a character literal (`'x'`, `'\n'`, `'\u{…}'`) starting at `i`;
/// `None` for a lifetime or a label (`'a`).
fn char_literal_end(src: &str, i: usize) -> Option<usize> {
    let rest = src.get(i..)?;
    let mut chars = rest.char_indices();
    if chars.next()?.1 != '\'' {
        return None;
    }
    let (_, first) = chars.next()?;
    if first == '\\' {
        // an escape: up to the closing quote
        return rest[2..].find('\'').map(|k| i + 2 + k + 1);
    }
    let (k, second) = chars.next()?;
    (second == '\'').then_some(i + k + 1)
}

fn ident_at(s: &str) -> &str {
    let end = s
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(s.len());
    &s[..end]
}

/// The first segments of every `crate::` path in `code`: `crate::a::b` gives `a`, and a
/// group `crate::{a::X, b}` gives `a` and `b`.
fn crate_paths(code: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (at, _) in code.match_indices("crate::") {
        // `$crate::` and identifiers ending in `crate` are not the crate root
        if at > 0 {
            let prev = code[..at].chars().next_back().expect("char");
            if prev.is_ascii_alphanumeric() || prev == '_' || prev == '$' {
                continue;
            }
        }
        let rest = &code[at + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let (mut depth, mut start) = (0usize, 0usize);
            for (k, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => {
                        out.insert(ident_at(group[start..k].trim()).to_string());
                        break;
                    }
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.insert(ident_at(group[start..k].trim()).to_string());
                        start = k + 1;
                    }
                    _ => {}
                }
            }
        } else {
            out.insert(ident_at(rest).to_string());
        }
    }
    out.retain(|m| !m.is_empty());
    out
}

/// Module → (module it uses → files that use it).
type Graph = BTreeMap<String, BTreeMap<String, BTreeSet<String>>>;

fn import_graph() -> (Graph, BTreeSet<String>) {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = vec![];
    rust_files(&src, &mut files);
    let mut graph = Graph::new();
    let mut modules = BTreeSet::new();
    for file in files {
        let rel = file.strip_prefix(&src).expect("under src").to_path_buf();
        if outside_layers(&rel) {
            continue;
        }
        let first = rel.components().next().expect("component");
        let module = Path::new(first.as_os_str())
            .file_stem()
            .expect("stem")
            .to_string_lossy()
            .to_string();
        modules.insert(module.clone());
        let code = code_only(&std::fs::read_to_string(&file).expect("read file"));
        for used in crate_paths(&code) {
            // root re-exports (`crate::Real`) are names, not modules: the layering is kept
            // by naming the module (`crate::scalar::Real`)
            if used != module {
                graph
                    .entry(module.clone())
                    .or_default()
                    .entry(used)
                    .or_default()
                    .insert(rel.display().to_string());
            }
        }
    }
    (graph, modules)
}

/// Modules that lie on a cycle of the import graph (Tarjan's strongly connected components
/// of more than one module).
fn cycles(graph: &Graph) -> Vec<Vec<String>> {
    struct Tarjan<'a> {
        graph: &'a Graph,
        index: BTreeMap<&'a str, usize>,
        low: BTreeMap<&'a str, usize>,
        stack: Vec<&'a str>,
        out: Vec<Vec<String>>,
    }
    impl<'a> Tarjan<'a> {
        fn visit(&mut self, v: &'a str) {
            let i = self.index.len();
            self.index.insert(v, i);
            self.low.insert(v, i);
            self.stack.push(v);
            for w in self.graph.get(v).into_iter().flat_map(|m| m.keys()) {
                let w = w.as_str();
                if !self.index.contains_key(w) {
                    self.visit(w);
                    let lw = self.low[w];
                    let lv = self.low.get_mut(v).expect("low");
                    *lv = (*lv).min(lw);
                } else if self.stack.contains(&w) {
                    let iw = self.index[w];
                    let lv = self.low.get_mut(v).expect("low");
                    *lv = (*lv).min(iw);
                }
            }
            if self.low[v] == self.index[v] {
                let mut scc = vec![];
                while let Some(w) = self.stack.pop() {
                    scc.push(w.to_string());
                    if w == v {
                        break;
                    }
                }
                if scc.len() > 1 {
                    scc.sort();
                    self.out.push(scc);
                }
            }
        }
    }
    let mut t = Tarjan {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: vec![],
        out: vec![],
    };
    for v in graph.keys() {
        if !t.index.contains_key(v.as_str()) {
            t.visit(v);
        }
    }
    t.out
}

#[test]
fn every_module_has_a_layer() {
    let (_, modules) = import_graph();
    let unplaced: Vec<_> = modules.iter().filter(|m| layer_of(m).is_none()).collect();
    assert!(
        unplaced.is_empty(),
        "modules of src/ missing from LAYERS in tests/suite/architecture.rs: {unplaced:?}"
    );
    let placed: Vec<_> = LAYERS.iter().flat_map(|(_, ms)| ms.iter()).collect();
    let gone: Vec<_> = placed
        .iter()
        .filter(|m| !modules.contains(**m as &str))
        .collect();
    assert!(
        gone.is_empty(),
        "LAYERS names modules src/ does not have: {gone:?}"
    );
}

#[test]
fn imports_only_point_down() {
    let (graph, _) = import_graph();
    let mut upward = vec![];
    for (from, uses) in &graph {
        let Some(lf) = layer_of(from) else { continue };
        for (to, files) in uses {
            match layer_of(to) {
                Some(lt) if lt > lf => upward.push(format!(
                    "{from} ({}) uses {to} ({}) in {}",
                    LAYERS[lf].0,
                    LAYERS[lt].0,
                    files.iter().cloned().collect::<Vec<_>>().join(", ")
                )),
                Some(_) => {}
                None => upward.push(format!(
                    "{from} uses crate::{to}, which is not a module of a layer (name the \
                     module, not the crate root's re-export) in {}",
                    files.iter().cloned().collect::<Vec<_>>().join(", ")
                )),
            }
        }
    }
    assert!(
        upward.is_empty(),
        "{} upward imports:\n{}",
        upward.len(),
        upward.join("\n")
    );
}

#[test]
fn no_import_cycles() {
    let (graph, _) = import_graph();
    let found = cycles(&graph);
    assert!(found.is_empty(), "modules in import cycles: {found:?}");
}

#[test]
fn the_reader_finds_paths_in_groups_and_skips_comments() {
    let code = code_only(
        "use crate::a::X;\n// crate::b\nuse crate::{c::Y, d};\nlet s = \"crate::e\";\n\
         /* crate::f */ let v = crate::g::h();\nmacro_rules! m { () => { $crate::i } }\n\
         let q = '\"'; let v = crate::j::k(); let r = r#\"crate::l \" \"#;\n\
         fn f<'a>(x: &'a str) -> &'a str { crate::m::n(x) }",
    );
    let found: Vec<_> = crate_paths(&code).into_iter().collect();
    assert_eq!(found, ["a", "c", "d", "g", "j", "m"]);
    let mut g = Graph::new();
    for (a, b) in [("x", "y"), ("y", "z"), ("z", "x"), ("z", "w")] {
        g.entry(a.into()).or_default().entry(b.into()).or_default();
    }
    assert_eq!(cycles(&g), vec![vec!["x", "y", "z"]]);
}

/// The front page stays a front page: README.md within 250 lines (the details live in
/// `docs/`).
#[test]
fn the_readme_is_at_most_250_lines() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md");
    let lines = std::fs::read_to_string(&path).unwrap().lines().count();
    assert!(lines <= 250, "README.md has {lines} lines (at most 250)");
}
