//! `mmq paper` behaves like a sweep: its studies run into stores in the report's `runs/`,
//! so a report interrupted by Ctrl-C and run again, and one drawn from two shards
//! merged, are the uninterrupted report, file for file (its wall-time line aside).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Fig. 6 on the grid (with its horizon study, four times as long), three seeds: long
/// enough per job that Ctrl-C lands while jobs are left.
const ARGS: [&str; 8] = ["paper", "--fig", "6", "--env", "grid", "--seeds", "3", "-q"];
const STEPS: &str = "600000";

fn mmq(args: &[&str], out: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(ARGS)
        .args(["--steps", STEPS])
        .args(args)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap()
}

fn ok(o: &std::process::Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The report's files (not its stores), `report.md` without its wall-time line.
fn report_files(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut m = BTreeMap::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if !e.file_type().unwrap().is_file() || name.starts_with('.') {
            continue;
        }
        let mut bytes = std::fs::read(e.path()).unwrap();
        if name == "report.md" {
            let text = String::from_utf8(bytes).unwrap();
            bytes = text
                .lines()
                .filter(|l| !l.starts_with("Wall time"))
                .collect::<Vec<_>>()
                .join("\n")
                .into_bytes();
        }
        m.insert(name, bytes);
    }
    m
}

/// Every job file of the stores in `dir/runs`, by its path inside `runs`.
fn job_files(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, d: &Path, m: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for e in std::fs::read_dir(d).into_iter().flatten().flatten() {
            let p = e.path();
            if p.is_dir() {
                walk(root, &p, m);
            } else if p.parent().and_then(Path::parent).is_some_and(|c| c.ends_with("cells")) {
                m.insert(p.strip_prefix(root).unwrap().to_path_buf(), std::fs::read(&p).unwrap());
            }
        }
    }
    let mut m = BTreeMap::new();
    walk(&dir.join("runs"), &dir.join("runs"), &mut m);
    m
}

fn same_report(a: &Path, b: &Path) {
    let (fa, fb) = (report_files(a), report_files(b));
    assert_eq!(fa.keys().collect::<Vec<_>>(), fb.keys().collect::<Vec<_>>());
    assert!(fa.len() > 20, "{:?}", fa.keys());
    for (name, bytes) in &fa {
        assert!(fb[name] == *bytes, "{name} differs between {} and {}", a.display(), b.display());
    }
}

#[test]
fn an_interrupted_report_resumes_to_the_uninterrupted_one() {
    let d = tempfile::tempdir().unwrap();
    let whole = d.path().join("whole");
    ok(&mmq(&[], &whole));

    let resumed = d.path().join("resumed");
    let mut child = Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(ARGS)
        .args(["--steps", STEPS, "--out"])
        .arg(&resumed)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while job_files(&resumed).is_empty() {
        assert!(started.elapsed() < Duration::from_secs(120), "no job finished");
        std::thread::sleep(Duration::from_millis(10));
    }
    assert!(Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap().success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "an interrupted report exits 130");
    let finished = job_files(&resumed).len();
    let all = job_files(&whole).len();
    assert!(finished < all, "Ctrl-C came after every job ({finished} of {all})");
    let md = std::fs::read_to_string(resumed.join("report.md")).unwrap();
    assert!(md.contains("**Interrupted**") && md.contains("resumes"), "{md}");

    // The same command again runs only what is left, and the report is the whole one.
    let kept = job_files(&resumed);
    ok(&mmq(&[], &resumed));
    let after = job_files(&resumed);
    assert_eq!(after.len(), all);
    for (p, bytes) in &kept {
        assert!(after[p] == *bytes, "{} was run again", p.display());
    }
    same_report(&whole, &resumed);
}

#[test]
fn two_shards_merged_draw_the_uninterrupted_report() {
    let d = tempfile::tempdir().unwrap();
    let whole = d.path().join("whole");
    ok(&mmq(&[], &whole));
    let (one, two) = (d.path().join("one"), d.path().join("two"));
    for (k, dir) in [("1/2", &one), ("2/2", &two)] {
        let o = mmq(&["--shard", k], dir);
        ok(&o);
        assert!(String::from_utf8_lossy(&o.stdout).contains("--merge"), "a shard says how to merge");
        assert!(!dir.join("report.md").exists(), "a shard draws nothing");
    }
    let (a, b) = (job_files(&one), job_files(&two));
    assert!(!a.is_empty() && !b.is_empty() && a.keys().all(|k| !b.contains_key(k)), "disjoint shards");

    let merged = d.path().join("merged");
    ok(&mmq(&["--merge", &one.to_string_lossy(), "--merge", &two.to_string_lossy()], &merged));
    // Every job came from a shard (a job run again would differ in its wall time).
    let m = job_files(&merged);
    assert_eq!(m.len(), a.len() + b.len());
    for (p, bytes) in a.iter().chain(&b) {
        assert!(m[p] == *bytes, "{} was not taken from its shard", p.display());
    }
    same_report(&whole, &merged);
}
