//! Invariants ARCHITECTURE.md states about the code's shape, checked: the crates depend
//! on each other only as its layering says, and no library prints (only the command
//! line and the Python package talk to a terminal).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::common::root;

/// The layering: each crate's allowed `mmq-*` dependencies (ARCHITECTURE.md, "Layering").
const LAYERS: &[(&str, &[&str])] = &[
    ("mmq-core", &[]),
    ("mmq-grid", &["mmq-core"]),
    ("mmq-robot", &["mmq-core"]),
    ("mmq-learn", &["mmq-core"]),
    ("mmq-log", &["mmq-core"]),
    ("mmq-plot", &["mmq-core"]),
    ("mmq-lab", &["mmq-core", "mmq-grid", "mmq-robot", "mmq-learn", "mmq-log"]),
    ("mmq-report", &["mmq-core", "mmq-learn", "mmq-lab", "mmq-log", "mmq-plot"]),
    ("mmq-py", &["mmq-core", "mmq-grid", "mmq-robot", "mmq-learn", "mmq-lab", "mmq-log"]),
    ("mmq", &["mmq-core", "mmq-learn", "mmq-lab", "mmq-log", "mmq-plot", "mmq-report"]),
];

/// The libraries that must not print.
const QUIET: &[&str] =
    &["mmq-core", "mmq-grid", "mmq-robot", "mmq-learn", "mmq-log", "mmq-plot", "mmq-lab", "mmq-report"];

/// The `mmq-*` names of a manifest's `[dependencies]` (not dev- or build-dependencies).
fn mmq_dependencies(manifest: &Path) -> Vec<String> {
    let text = std::fs::read_to_string(manifest).unwrap();
    let doc: toml::Table = toml::from_str(&text).unwrap();
    let mut deps: Vec<String> = doc
        .get("dependencies")
        .and_then(toml::Value::as_table)
        .map(|t| t.keys().filter(|k| k.starts_with("mmq-")).cloned().collect())
        .unwrap_or_default();
    deps.sort();
    deps
}

fn manifest(krate: &str) -> PathBuf {
    if krate == "mmq" {
        root().join("Cargo.toml")
    } else {
        root().join("crates").join(krate).join("Cargo.toml")
    }
}

#[test]
fn crates_depend_on_each_other_only_as_layered() {
    let mut found = BTreeMap::new();
    for e in std::fs::read_dir(root().join("crates")).unwrap() {
        let p = e.unwrap().path().join("Cargo.toml");
        if p.is_file() {
            let name = p.parent().unwrap().file_name().unwrap().to_string_lossy().into_owned();
            found.insert(name, ());
        }
    }
    // Every crate is in the table, and the table names no crate that is not there.
    let listed: Vec<&str> = LAYERS.iter().map(|l| l.0).filter(|c| *c != "mmq").collect();
    let mut present: Vec<&str> = found.keys().map(String::as_str).collect();
    present.sort();
    let mut sorted = listed.clone();
    sorted.sort();
    assert_eq!(present, sorted, "crates/ and the layering table differ: update both");
    for (krate, allowed) in LAYERS {
        let deps = mmq_dependencies(&manifest(krate));
        let extra: Vec<&String> = deps.iter().filter(|d| !allowed.contains(&d.as_str())).collect();
        assert!(extra.is_empty(), "{krate} depends on {extra:?}, which its layer does not allow");
    }
    // The check would catch a dependency: mmq-lab does depend on the learners.
    assert!(mmq_dependencies(&manifest("mmq-lab")).contains(&"mmq-learn".to_string()));
}

/// Every `.rs` file under `dir`.
fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            sources(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The lines of `text` that print to stdout or stderr, outside its test module (the
/// text from the first `#[cfg(test)]` on is left out) and outside comments.
fn printing_lines(text: &str) -> Vec<(usize, String)> {
    let code = text.split("#[cfg(test)]").next().unwrap_or("");
    code.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim_start().starts_with("//"))
        .filter(|(_, l)| {
            ["println!(", "eprintln!(", "print!(", "eprint!(", "dbg!("].iter().any(|m| {
                l.match_indices(m).any(|(i, _)| {
                    // `println!(` contains `print!(` only as `eprint!(`/`print!(` at a word start.
                    i == 0 || !l.as_bytes()[i - 1].is_ascii_alphanumeric() && l.as_bytes()[i - 1] != b'_'
                })
            })
        })
        .map(|(i, l)| (i + 1, l.trim().to_string()))
        .collect()
}

#[test]
fn no_library_prints() {
    let mut files = Vec::new();
    for krate in QUIET {
        sources(&root().join("crates").join(krate).join("src"), &mut files);
    }
    assert!(files.len() > 50, "found only {} library sources", files.len());
    let mut offenders = Vec::new();
    for f in &files {
        for (n, l) in printing_lines(&std::fs::read_to_string(f).unwrap()) {
            offenders.push(format!("{}:{n}: {l}", f.strip_prefix(root()).unwrap_or(f).display()));
        }
    }
    assert!(
        offenders.is_empty(),
        "libraries print (return text, or use a Progress):\n{}",
        offenders.join("\n")
    );
}

/// The print finder finds prints and skips comments, tests and look-alikes.
#[test]
fn the_print_finder_finds_prints() {
    let text = "fn a() {\n    println!(\"x\");\n    // eprintln!(\"comment\");\n    let s = my_print!(1);\n    eprint!(\"y\");\n}\n#[cfg(test)]\nmod tests { fn t() { println!(\"ok in tests\"); } }\n";
    let found: Vec<usize> = printing_lines(text).into_iter().map(|x| x.0).collect();
    assert_eq!(found, vec![2, 5]);
}
