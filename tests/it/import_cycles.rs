//! No module-level import cycle in mmq-learn or mmq-lab: the modules of each crate's
//! `src/` and what each uses of its siblings, read from the source, must form a graph
//! without a cycle.
//!
//! A module is a top-level file of `src/` (`mmq.rs` is `mmq`) or a folder module with
//! everything inside it (`deconv/mod.rs`, `deconv/gram.rs`, ... are all `deconv`). Its
//! dependencies are the sibling modules named by `crate::…` paths (in `use` or inline,
//! `$crate::` in macros included) and by `super::…` paths that climb to the crate root,
//! tests included, comments and string literals not. `lib.rs`, the crate root, only
//! declares modules and re-exports, so it is outside the graph; a path through one of its
//! re-exports (`crate::Learner`) counts as a use of the module the item comes from.
//!
//! [`module_graph`] and [`find_cycle`] take any crate's `src` folder, so that other crates
//! can be held to the same rule.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

/// Module → the sibling modules it uses.
type Graph = BTreeMap<String, BTreeSet<String>>;

/// The text with comments removed and string and character literals blanked, so that
/// only code is searched for paths (line structure is kept).
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        let next = c.get(i + 1).copied();
        if c[i] == '/' && next == Some('/') {
            while i < c.len() && c[i] != '\n' {
                i += 1;
            }
        } else if c[i] == '/' && next == Some('*') {
            let mut depth = 0;
            while i < c.len() {
                if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                    depth += 1;
                    i += 2;
                } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else if c[i] == 'r' && (next == Some('#') || next == Some('"')) && !ident_before(&c, i) {
            // A raw string r#"…"#: ends at a quote followed by as many hashes.
            let mut j = i + 1;
            let mut hashes = 0;
            while c.get(j) == Some(&'#') {
                hashes += 1;
                j += 1;
            }
            if c.get(j) != Some(&'"') {
                out.push(c[i]);
                i += 1;
                continue;
            }
            j += 1;
            while j < c.len() {
                if c[j] == '"' && (0..hashes).all(|h| c.get(j + 1 + h) == Some(&'#')) {
                    j += 1 + hashes;
                    break;
                }
                j += 1;
            }
            out.push_str("\"\"");
            i = j;
        } else if c[i] == '"' {
            i += 1;
            while i < c.len() && c[i] != '"' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("\"\"");
        } else if c[i] == '\'' && (next == Some('\\') || c.get(i + 2) == Some(&'\'')) {
            // A character literal ('x', '\n', '\u{..}'); a lifetime ('a) is kept.
            i += 1;
            while i < c.len() && c[i] != '\'' {
                i += if c[i] == '\\' { 2 } else { 1 };
            }
            i += 1;
            out.push_str("' '");
        } else {
            out.push(c[i]);
            i += 1;
        }
    }
    out
}

fn ident_before(c: &[char], i: usize) -> bool {
    i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '_')
}

/// Identifiers and the punctuation `::`, `{`, `}`, `,`, `;` of code.
fn tokens(code: &str) -> Vec<String> {
    let c: Vec<char> = code.chars().collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < c.len() {
        if c[i].is_alphabetic() || c[i] == '_' {
            let start = i;
            while i < c.len() && (c[i].is_alphanumeric() || c[i] == '_') {
                i += 1;
            }
            out.push(c[start..i].iter().collect());
        } else if c[i] == ':' && c.get(i + 1) == Some(&':') {
            out.push("::".into());
            i += 2;
        } else {
            if matches!(c[i], '{' | '}' | ',' | ';' | '*') {
                out.push(c[i].to_string());
            } else if !c[i].is_whitespace() {
                out.push("#".into());
            }
            i += 1;
        }
    }
    out
}

/// The first segments of the paths a path continues with after `crate::` (or after
/// `super::` that reached the root) at `t[i]`: one name, or those of a `{…}` group.
fn heads(t: &[String], i: usize) -> Vec<String> {
    match t.get(i).map(String::as_str) {
        Some("{") => {
            let (mut depth, mut j, mut at_start, mut out) = (0, i, true, Vec::new());
            while j < t.len() {
                match t[j].as_str() {
                    "{" => {
                        depth += 1;
                        at_start = depth == 1;
                    }
                    "}" => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    "," => at_start = depth == 1,
                    s if at_start => {
                        out.push(s.to_string());
                        at_start = false;
                    }
                    _ => {}
                }
                j += 1;
            }
            out
        }
        Some(s) => vec![s.to_string()],
        None => Vec::new(),
    }
}

/// The names `lib.rs` re-exports, each with the module it comes from
/// (`pub use diagnostics::{DelayEstimate, Diagnostics};` maps both to `diagnostics`).
fn reexports(lib: &str, modules: &BTreeSet<String>) -> BTreeMap<String, String> {
    let t = tokens(&code_only(lib));
    let mut out = BTreeMap::new();
    let mut i = 0;
    while i < t.len() {
        if t[i] == "use" {
            let end = (i..t.len()).find(|&j| t[j] == ";").unwrap_or(t.len());
            let stmt = &t[i + 1..end];
            let first =
                if stmt.first().map(String::as_str) == Some("crate") { stmt.get(2) } else { stmt.first() };
            if let Some(m) = first.filter(|m| modules.contains(*m)) {
                // The leaves: an identifier followed by `,`, `}`, `;` or the end (after
                // `as`, the alias).
                for k in 0..stmt.len() {
                    let follows = stmt.get(k + 1).map(String::as_str);
                    let leaf = matches!(follows, None | Some(",") | Some("}"));
                    if leaf && !matches!(stmt[k].as_str(), "::" | "{" | "}" | "," | "*" | "self") {
                        out.insert(stmt[k].clone(), m.clone());
                    }
                }
            }
            i = end;
        }
        i += 1;
    }
    out
}

/// The module graph of a crate's `src` folder (see the file's head for what counts).
pub fn module_graph(src: &Path) -> Graph {
    let mut files: Vec<PathBuf> = Vec::new();
    let mut dirs = vec![src.to_path_buf()];
    while let Some(d) = dirs.pop() {
        for e in fs::read_dir(&d).unwrap_or_else(|e| panic!("{}: {e}", d.display())) {
            let p = e.unwrap().path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                files.push(p);
            }
        }
    }
    files.sort();
    // Each file's module path below the root, e.g. deconv/gram.rs → [deconv, gram].
    let path_of = |f: &Path| -> Vec<String> {
        let rel = f.strip_prefix(src).unwrap();
        let mut parts: Vec<String> = rel.iter().map(|s| s.to_string_lossy().into_owned()).collect();
        let last = parts.pop().unwrap();
        let stem = last.trim_end_matches(".rs");
        if stem != "mod" && !(parts.is_empty() && (stem == "lib" || stem == "main")) {
            parts.push(stem.to_string());
        }
        parts
    };
    let modules: BTreeSet<String> = files.iter().filter_map(|f| path_of(f).first().cloned()).collect();
    let root = ["lib.rs", "main.rs"].iter().map(|n| src.join(n)).find(|p| p.exists());
    let names = root.map(|p| reexports(&fs::read_to_string(p).unwrap(), &modules)).unwrap_or_default();
    let mut graph: Graph = modules.iter().map(|m| (m.clone(), BTreeSet::new())).collect();
    for f in &files {
        let file_path = path_of(f);
        let Some(this) = file_path.first().cloned() else { continue };
        let t = tokens(&code_only(&fs::read_to_string(f).unwrap()));
        let deps = graph.get_mut(&this).unwrap();
        // Inline modules (`mod tests { … }`) open at a brace depth; `super` counts them.
        let (mut depth, mut inline): (usize, Vec<usize>) = (0, Vec::new());
        let mut i = 0;
        while i < t.len() {
            match t[i].as_str() {
                "{" => {
                    if i >= 2 && t[i - 2] == "mod" {
                        inline.push(depth);
                    }
                    depth += 1;
                }
                "}" => {
                    depth -= 1;
                    if inline.last() == Some(&depth) {
                        inline.pop();
                    }
                }
                "crate" | "super" if t.get(i + 1).map(String::as_str) == Some("::") => {
                    let prev = if i > 0 { t[i - 1].as_str() } else { "" };
                    // `super` inside a path (`x::super`) is not a start; `crate::` is
                    // checked the same way.
                    if prev != "::" {
                        let mut level = file_path.len() + inline.len();
                        let mut j = i;
                        if t[i] == "crate" {
                            level = 0;
                            j += 2;
                        } else {
                            while t.get(j).map(String::as_str) == Some("super")
                                && t.get(j + 1).map(String::as_str) == Some("::")
                            {
                                level = level.saturating_sub(1);
                                j += 2;
                            }
                        }
                        // Below the root: still inside the top-level module `this`
                        // (its own items, or climbing inside a folder module).
                        if level == 0 {
                            for h in heads(&t, j) {
                                let target =
                                    if modules.contains(&h) { Some(h) } else { names.get(&h).cloned() };
                                if let Some(m) = target.filter(|m| *m != this) {
                                    deps.insert(m);
                                }
                            }
                        }
                    }
                }
                _ => {}
            }
            i += 1;
        }
    }
    graph
}

/// A cycle of `graph` as the path that closes it (`[a, b, a]`), or `None`.
pub fn find_cycle(graph: &Graph) -> Option<Vec<String>> {
    // Depth-first search; 1 = on the current path, 2 = done.
    fn visit<'a>(
        g: &'a Graph,
        m: &'a str,
        state: &mut BTreeMap<&'a str, u8>,
        path: &mut Vec<&'a str>,
    ) -> Option<Vec<String>> {
        state.insert(m, 1);
        path.push(m);
        for d in g.get(m).into_iter().flatten() {
            match state.get(d.as_str()) {
                Some(1) => {
                    let from = path.iter().position(|p| p == d).unwrap();
                    let mut cycle: Vec<String> = path[from..].iter().map(|s| s.to_string()).collect();
                    cycle.push(d.clone());
                    return Some(cycle);
                }
                Some(_) => {}
                None => {
                    if let Some(c) = visit(g, d, state, path) {
                        return Some(c);
                    }
                }
            }
        }
        path.pop();
        state.insert(m, 2);
        None
    }
    let mut state = BTreeMap::new();
    for m in graph.keys() {
        if !state.contains_key(m.as_str())
            && let Some(c) = visit(graph, m, &mut state, &mut Vec::new())
        {
            return Some(c);
        }
    }
    None
}

/// Fails, naming the cycle, if the modules of the crate folder `src` import each other in
/// a circle; returns the graph otherwise.
pub fn assert_no_import_cycle(src: &Path) -> Graph {
    let graph = module_graph(src);
    assert!(!graph.is_empty(), "no modules found in {}", src.display());
    if let Some(cycle) = find_cycle(&graph) {
        let deps: Vec<String> = graph.iter().map(|(m, d)| format!("  {m} → {d:?}")).collect();
        panic!(
            "module import cycle in {}: {}\nthe graph:\n{}",
            src.display(),
            cycle.join(" → "),
            deps.join("\n")
        );
    }
    graph
}

fn learn_src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/mmq-learn/src")
}

fn lab_src() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/mmq-lab/src")
}

#[test]
fn mmq_lab_has_no_module_import_cycle() {
    let g = assert_no_import_cycle(&lab_src());
    // The reader sees real code: the runner drives the step loop, the executor the
    // runner, and the step loop and executor share the trajectory types.
    for (m, d) in
        [("runner", "stepper"), ("exec", "runner"), ("stepper", "trajectory"), ("comparison", "study")]
    {
        assert!(g[m].contains(d), "{m} should use {d}: {:?}", g[m]);
    }
}

#[test]
fn mmq_learn_has_no_module_import_cycle() {
    let g = assert_no_import_cycle(&learn_src());
    // The reader sees real code: the learners use the shared parameters and the core
    // types, the deconvolving learners the deconvolution, and the dispatch every learner.
    for (m, d) in [("mmq", "params"), ("mmq", "learner"), ("deconv_q", "deconv"), ("settings", "mmq")] {
        assert!(g[m].contains(d), "{m} should use {d}: {:?}", g[m]);
    }
    // The leaves import nothing from the crate.
    assert!(g["params"].is_empty(), "params uses {:?}", g["params"]);
}

/// `lib.rs` only declares modules and re-exports: after its attributes and visibility,
/// every item is a `mod …;` or a `use …;`.
#[test]
fn the_roots_only_declare_and_reexport() {
    for src in [learn_src(), lab_src()] {
        root_only_declares_and_reexports(&src);
    }
}

fn root_only_declares_and_reexports(src: &Path) {
    let lib = code_only(&fs::read_to_string(src.join("lib.rs")).unwrap());
    for item in lib.split(';').map(str::trim).filter(|i| !i.is_empty()) {
        let mut rest = item;
        while let Some(attr) = rest.strip_prefix("#[") {
            rest = attr[attr.find(']').expect("an attribute without `]`") + 1..].trim_start();
        }
        if let Some(r) = rest.strip_prefix("pub") {
            rest = match r.trim_start().strip_prefix('(') {
                Some(v) => v[v.find(')').unwrap() + 1..].trim_start(),
                None => r.trim_start(),
            };
        }
        assert!(
            rest.starts_with("mod ") || rest.starts_with("use "),
            "{}/lib.rs should only declare modules and re-export, found: {item}",
            src.display()
        );
    }
}

/// The cycle finder on hand-made graphs: it finds a cycle that is there, names it, and
/// finds none in a graph without one (so the check above cannot pass vacuously).
#[test]
fn the_cycle_finder_on_hand_made_graphs() {
    let graph = |edges: &[(&str, &str)]| {
        let mut g = Graph::new();
        for (a, b) in edges {
            g.entry(a.to_string()).or_default().insert(b.to_string());
            g.entry(b.to_string()).or_default();
        }
        g
    };
    let acyclic = graph(&[("a", "b"), ("a", "c"), ("b", "c"), ("c", "d"), ("e", "d")]);
    assert_eq!(find_cycle(&acyclic), None);
    let cyclic = graph(&[("a", "b"), ("b", "c"), ("c", "d"), ("d", "b"), ("e", "a")]);
    assert_eq!(find_cycle(&cyclic).unwrap(), ["b", "c", "d", "b"]);
    assert_eq!(find_cycle(&graph(&[("x", "x")])).unwrap(), ["x", "x"]);
}

/// The reader of sources on a hand-made crate: `use crate::`, grouped imports, inline
/// paths, `super::` from a submodule and from a test module, re-exports of the root, and
/// nothing from comments or strings.
#[test]
fn the_source_reader_on_a_hand_made_crate() {
    let dir = std::env::temp_dir().join(format!("mmq-learn-cycles-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(dir.join("f")).unwrap();
    let files = [
        (
            "lib.rs",
            "pub mod a;\npub mod b;\npub mod c;\npub mod d;\npub mod e;\npub mod f;\npub use d::{Thing, Other as Renamed};\n",
        ),
        ("a.rs", "//! A.\nuse crate::{b, c::X};\n// use crate::e;\nconst S: &str = \"crate::e::Y\";\n"),
        (
            "b.rs",
            "fn f() -> crate::Thing { todo!() }\n#[cfg(test)]\nmod tests {\n    use super::*;\n    use super::super::e::Z;\n}\n",
        ),
        ("c.rs", "fn g() { let _ = crate::Renamed; let c = '\"'; }\n"),
        ("d.rs", "/* crate::a */\n"),
        ("e.rs", ""),
        ("f/mod.rs", "mod g;\nuse super::a;\n"),
        ("f/g.rs", "use super::mod_item;\nuse super::super::e;\n"),
    ];
    for (name, text) in files {
        fs::write(dir.join(name), text).unwrap();
    }
    let g = module_graph(&dir);
    let deps = |m: &str| g[m].iter().map(String::as_str).collect::<Vec<_>>();
    assert_eq!(deps("a"), ["b", "c"]);
    assert_eq!(deps("b"), ["d", "e"]);
    assert_eq!(deps("c"), ["d"]);
    assert!(deps("d").is_empty());
    assert_eq!(deps("f"), ["a", "e"]);
    assert_eq!(find_cycle(&g), None);
    fs::write(dir.join("e.rs"), "use crate::f::G;\n").unwrap();
    let cycle = find_cycle(&module_graph(&dir)).unwrap();
    assert_eq!(cycle.join(" → "), "a → b → e → f → a");
    fs::remove_dir_all(&dir).unwrap();
}
