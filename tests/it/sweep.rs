//! End-to-end tests of `mmq sweep`: sharding and merging give the unsharded results
//! byte for byte, whatever the thread count; an interrupted or damaged sweep resumes
//! with only the missing jobs; Ctrl-C stops at once and keeps finished results; bad
//! specs and flags exit 3 with one line naming the file, line, column and field.

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common::*;

fn ok(o: Output) -> String {
    let (out, err) = text(&o);
    assert!(o.status.success(), "exit {:?}\nstdout: {out}\nstderr: {err}", o.status.code());
    out
}

/// Writes a spec into `dir` with `world` pointing at a world file of the repository.
fn write_spec(dir: &Path, world: &str, body: &str) -> String {
    let p = dir.join("spec.toml");
    let w = root().join("worlds").join(world);
    std::fs::write(&p, format!("world = {:?}\n{body}", w.to_string_lossy())).unwrap();
    p.to_string_lossy().into_owned()
}

/// Two learners × three delays (one with a comma, quoted in the CSV) × two λ̂max × 3
/// seeds = 36 tiny jobs.
const SMALL: &str = r#"name = "small"
learner = ["q", "mmq"]
delay = ["none", "poisson:2", "hist:1,2,1"]
max_delay = [2, 5]
epsilon = 0.05
q0 = 10
steps = 1500
window = 500
eval_steps = 100
seeds = 3
seed = 11
"#;

fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

fn ran_count(stdout: &str) -> (usize, usize) {
    let line =
        stdout.lines().find(|l| l.starts_with("ran ")).unwrap_or_else(|| panic!("no summary: {stdout}"));
    let n = |after: &str| -> usize {
        line.split(after).nth(1).and_then(|r| r.split_whitespace().next()).unwrap().parse().unwrap()
    };
    (line.split_whitespace().nth(1).unwrap().parse().unwrap(), n("skipped "))
}

mod shards {
    use super::*;

    /// Three shards (one thread each) merged give the unsharded CSV (two threads) byte
    /// for byte; the shards are disjoint and cover every job.
    #[test]
    fn merged_shards_equal_the_unsharded_sweep() {
        let d = tempfile::tempdir().unwrap();
        let spec = write_spec(d.path(), "paper-3x3.toml", SMALL);
        let whole = d.path().join("whole");
        let o = mmq(&["--threads", "2", "sweep", &spec, "--out", &s(&whole), "-q"]);
        // -q: no line per finished job.
        assert!(!text(&o).1.contains("] cell "), "{}", text(&o).1);
        let out = ok(o);
        assert_eq!(ran_count(&out), (36, 0), "{out}");
        let mut shard_dirs = Vec::new();
        let mut total = 0;
        for k in 1..=3 {
            let dir = d.path().join(format!("shard-{k}"));
            let out = ok(mmq(&[
                "--threads",
                "1",
                "sweep",
                &spec,
                "--shard",
                &format!("{k}/3"),
                "--out",
                &s(&dir),
                "-q",
            ]));
            let (ran, skipped) = ran_count(&out);
            assert_eq!((ran, skipped), (12, 0), "{out}");
            total += ran;
            shard_dirs.push(s(&dir));
        }
        assert_eq!(total, 36);
        let merged = d.path().join("merged");
        let mut args = vec!["sweep", "merge"];
        args.extend(shard_dirs.iter().map(String::as_str));
        let m = s(&merged);
        args.extend(["--out", &m]);
        let out = ok(mmq(&args));
        assert!(out.contains("36 of 36 jobs finished"), "{out}");
        let a = std::fs::read(whole.join("results.csv")).unwrap();
        let b = std::fs::read(merged.join("results.csv")).unwrap();
        assert!(
            a == b,
            "merged CSV differs:\n{}\n---\n{}",
            String::from_utf8_lossy(&a),
            String::from_utf8_lossy(&b)
        );
        let csv = String::from_utf8(a).unwrap();
        assert_eq!(csv.lines().count(), 1 + 36);
        let header = csv.lines().next().unwrap();
        assert!(header.starts_with("cell,learner,delay,max_delay,seed,"), "{header}");
        assert!(header.contains(",perf/relative,") && !header.contains("time/"), "{header}");
        assert!(csv.contains(",\"hist:1,2,1\","), "delay with a comma is quoted");
        // Shards hold only their own jobs; merging a shard with itself adds nothing.
        let one = std::fs::read_to_string(d.path().join("shard-2/results.csv")).unwrap();
        assert_eq!(one.lines().count(), 1 + 12);
        let out = ok(mmq(&["sweep", "merge", &shard_dirs[0], &shard_dirs[0], "--out", &m]));
        assert!(out.contains("(0 copied)"), "{out}");
    }

    /// A spec in parts (each part with its own seeds) shards and merges like any other:
    /// two shards merged give the whole sweep's CSV byte for byte, each cell with its
    /// part's seeds, and the report counts the jobs per part.
    #[test]
    fn a_spec_in_parts_shards_merges_and_reports() {
        let d = tempfile::tempdir().unwrap();
        let body = "learner = [\"q\", \"mmq\"]\nsteps = 400\neval_steps = 10\nmax_delay = 4\n\
                    [[part]]\ndelay = [\"poisson:1\", \"poisson:2\"]\nseeds = 2\n\
                    [[part]]\nlearner = \"deconv-q\"\ndelay = \"poisson:2\"\nseeds = [5, 6, 7]\n\
                    [part.settings]\ntold_delay = \"poisson:2\"\n";
        let spec = write_spec(d.path(), "paper-3x3.toml", body);
        let whole = d.path().join("whole");
        let out = ok(mmq(&["sweep", &spec, "--out", &s(&whole), "-q"]));
        assert_eq!(ran_count(&out), (11, 0), "{out}");
        let mut dirs = Vec::new();
        for k in 1..=2 {
            let dir = s(&d.path().join(format!("shard-{k}")));
            ok(mmq(&["--threads", "1", "sweep", &spec, "--shard", &format!("{k}/2"), "--out", &dir, "-q"]));
            dirs.push(dir);
        }
        let merged = s(&d.path().join("merged"));
        let out = ok(mmq(&["sweep", "merge", &dirs[0], &dirs[1], "--out", &merged]));
        assert!(out.contains("11 of 11 jobs finished"), "{out}");
        let a = std::fs::read_to_string(whole.join("results.csv")).unwrap();
        assert_eq!(a, std::fs::read_to_string(Path::new(&merged).join("results.csv")).unwrap());
        let seeds: Vec<(&str, &str)> = a
            .lines()
            .skip(1)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                (f[1], f[4])
            })
            .collect();
        assert_eq!(seeds.iter().filter(|(l, _)| *l == "q").count(), 4);
        let told: Vec<&str> = seeds.iter().filter(|(l, _)| *l == "deconv-q").map(|x| x.1).collect();
        assert_eq!(told, ["5", "6", "7"]);
        assert!(a.starts_with("cell,learner,delay,settings.told_delay,seed,"), "{a}");
        let out = ok(mmq(&["sweep", "report", &merged]));
        assert!(out.contains("11 of 11 jobs finished"), "{out}");
        let md = std::fs::read_to_string(Path::new(&merged).join("report/report.md")).unwrap();
        assert!(md.contains("5 cells, 11 jobs (seeds per part); 11 finished"), "{md}");
    }

    /// Merging the outputs of two different specs is refused.
    #[test]
    fn merge_refuses_different_sweeps() {
        let d = tempfile::tempdir().unwrap();
        let a = d.path().join("a");
        let b = d.path().join("b");
        std::fs::create_dir_all(&a).unwrap();
        std::fs::create_dir_all(&b).unwrap();
        let sa = write_spec(
            &a,
            "paper-3x3.toml",
            "steps = 300\neval_steps = 10\nlearner = [\"q\", \"mmq\"]\nmax_delay = 2\n",
        );
        let sb = write_spec(
            &b,
            "paper-3x3.toml",
            "steps = 400\neval_steps = 10\nlearner = [\"q\", \"mmq\"]\nmax_delay = 2\n",
        );
        ok(mmq(&["sweep", &sa, "--out", &s(&a.join("out")), "-q"]));
        ok(mmq(&["sweep", &sb, "--out", &s(&b.join("out")), "-q"]));
        let o = mmq(&[
            "sweep",
            "merge",
            &s(&a.join("out")),
            &s(&b.join("out")),
            "--out",
            &s(&d.path().join("m")),
        ]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(3), "{err}");
        assert!(err.contains("holds another sweep"), "{err}");
    }
}

mod resume {
    use super::*;

    struct KillOnDrop(Option<std::process::Child>);

    impl Drop for KillOnDrop {
        fn drop(&mut self) {
            if let Some(c) = self.0.as_mut() {
                let _ = c.kill();
                let _ = c.wait();
            }
        }
    }

    /// Delete one job's result: a rerun computes that job only and rebuilds the same CSV.
    #[test]
    fn rerun_computes_only_missing_jobs() {
        let d = tempfile::tempdir().unwrap();
        let spec = write_spec(d.path(), "paper-3x3.toml", SMALL);
        let out_dir = d.path().join("out");
        let out = s(&out_dir);
        ok(mmq(&["sweep", &spec, "--out", &out, "-q"]));
        let before = std::fs::read(out_dir.join("results.csv")).unwrap();
        // A rerun of a finished sweep runs nothing.
        let o = ok(mmq(&["sweep", &spec, "--out", &out, "-q"]));
        assert_eq!(ran_count(&o), (0, 36), "{o}");
        // Remove one result (the 2nd cell, seed 12).
        let cell = std::fs::read_to_string(out_dir.join("results.csv")).unwrap();
        let row = cell.lines().nth(1 + 3 + 1).unwrap().to_string();
        let id = row.split(',').next().unwrap();
        let victim = out_dir.join("cells").join(id).join("seed-12.json");
        std::fs::remove_file(&victim).unwrap();
        let o = mmq(&["sweep", &spec, "--out", &out]);
        let (stdout, stderr) = text(&o);
        assert!(o.status.success(), "{stderr}");
        assert_eq!(ran_count(&stdout), (1, 35), "{stdout}");
        assert!(stdout.contains("35 already finished, 1 to run"), "{stdout}");
        // The log names the recomputed job.
        let jobs: Vec<&str> = stderr.lines().filter(|l| l.starts_with('[')).collect();
        assert_eq!(jobs.len(), 1, "{stderr}");
        assert!(jobs[0].contains(id) && jobs[0].contains("seed 12"), "{stderr}");
        assert!(victim.is_file());
        assert!(std::fs::read(out_dir.join("results.csv")).unwrap() == before);
        // A result from another cell copied in place is not trusted: it is recomputed.
        let other = std::fs::read_dir(out_dir.join("cells"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| !p.ends_with(id))
            .unwrap();
        std::fs::copy(other.join("seed-12.json"), &victim).unwrap();
        let o = ok(mmq(&["sweep", &spec, "--out", &out, "-q"]));
        assert_eq!(ran_count(&o), (1, 35), "{o}");
        assert!(std::fs::read(out_dir.join("results.csv")).unwrap() == before);
    }

    /// SIGINT stops within a second, exits 130, keeps every finished job, and marks the
    /// directory incomplete.
    #[test]
    fn ctrl_c_stops_at_once_and_keeps_finished_jobs() {
        let d = tempfile::tempdir().unwrap();
        // Four tiny jobs, then four that would take hours.
        let spec = write_spec(
            d.path(),
            "paper-9x9.toml",
            "learner = \"mmq\"\nmax_delay = 20\ndelay = \"poisson:3\"\nsteps = [2000, 2000000000]\neval_steps = 100\nseeds = 4\n",
        );
        let out_dir = d.path().join("out");
        let child = Command::new(env!("CARGO_BIN_EXE_mmq"))
            .args(["--threads", "2", "sweep", &spec, "--out", &s(&out_dir), "-q"])
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Killed when the test fails: the long jobs must not outlive it.
        let mut guard = KillOnDrop(Some(child));
        let child = guard.0.as_mut().unwrap();
        let started = Instant::now();
        let count = || {
            std::fs::read_dir(out_dir.join("cells"))
                .map(|cells| {
                    cells
                        .flatten()
                        .flat_map(|c| std::fs::read_dir(c.path()).into_iter().flatten().flatten())
                        .filter(|f| f.file_name().to_string_lossy().ends_with(".json"))
                        .count()
                })
                .unwrap_or(0)
        };
        while count() < 4 {
            assert!(started.elapsed() < Duration::from_secs(120), "the tiny jobs did not finish");
            std::thread::sleep(Duration::from_millis(50));
        }
        std::thread::sleep(Duration::from_millis(300));
        let sent = Instant::now();
        let k = Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
        assert!(k.success());
        let status = loop {
            if let Some(st) = child.try_wait().unwrap() {
                break st;
            }
            assert!(sent.elapsed() < Duration::from_secs(10), "no exit 10 s after SIGINT");
            std::thread::sleep(Duration::from_millis(10));
        };
        let took = sent.elapsed();
        let o = guard.0.take().unwrap().wait_with_output().unwrap();
        let (stdout, stderr) = text(&o);
        assert_eq!(status.code(), Some(130), "{stdout}\n{stderr}");
        assert!(took < Duration::from_secs(2), "took {took:?} to stop");
        assert_eq!(ran_count(&stdout), (4, 0), "{stdout}");
        assert!(stderr.contains("interrupted: 4 job(s)"), "{stderr}");
        assert_eq!(count(), 4);
        let m: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out_dir.join("sweep.json")).unwrap()).unwrap();
        assert_eq!(m["complete"], false);
        assert_eq!(m["done"], 4);
        let csv = std::fs::read_to_string(out_dir.join("results.csv")).unwrap();
        assert_eq!(csv.lines().count(), 1 + 4);
    }
}

mod report {
    use super::*;

    #[test]
    fn means_intervals_markdown_and_figures() {
        let d = tempfile::tempdir().unwrap();
        let spec = write_spec(d.path(), "paper-3x3.toml", SMALL);
        let out = d.path().join("out");
        ok(mmq(&["sweep", &spec, "--out", &s(&out), "-q"]));
        let o = ok(mmq(&["sweep", "report", &s(&out)]));
        assert!(o.contains("36 of 36 jobs finished"), "{o}");
        let rep = out.join("report");
        let csv = std::fs::read_to_string(rep.join("summary.csv")).unwrap();
        assert!(csv.starts_with("cell,learner,delay,max_delay,metric,n,mean,ci95,std\n"), "{csv}");
        let rel: Vec<&str> = csv.lines().filter(|l| l.contains(",perf/relative,")).collect();
        assert_eq!(rel.len(), 12);
        assert!(rel.iter().all(|l| l.contains(",perf/relative,3,")));
        let md = std::fs::read_to_string(rep.join("report.md")).unwrap();
        assert!(md.contains("| cell | learner | delay | max_delay | seeds |"), "{md}");
        assert!(
            md.contains("![max_delay](by-max_delay.png)") && md.contains("![delay](by-delay.png)"),
            "{md}"
        );
        for f in ["by-delay.svg", "by-delay.png", "by-max_delay.svg", "by-max_delay.png"] {
            assert!(rep.join(f).is_file(), "{f} missing");
        }
        // The per-cell mean is the mean of the seeds in results.csv.
        let results = std::fs::read_to_string(out.join("results.csv")).unwrap();
        let header: Vec<&str> = results.lines().next().unwrap().split(',').collect();
        let col = header.iter().position(|h| *h == "perf/relative").unwrap();
        let first_cell: Vec<f64> = results
            .lines()
            .skip(1)
            .take(3)
            .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
            .collect();
        let mean: f64 = rel[0].split(',').nth(6).unwrap().parse().unwrap();
        assert!((mean - first_cell.iter().sum::<f64>() / 3.0).abs() < 1e-12);
    }

    /// A grid sweep and a robot sweep (other seeds, robot settings, per-cell
    /// diagnostics, learning curves) reported together: tables per learner and
    /// setting with the change from the grid, curves, robot diagnostics, heat maps.
    #[test]
    fn grid_and_robot_sweeps_in_one_report() {
        let d = tempfile::tempdir().unwrap();
        let common = "learner = [\"q\", \"mmq\"]\ndelay = \"poisson:2\"\nmax_delay = 4\nsteps = 400\nwindow = 100\ncurve = 2\neval_steps = 20\n";
        let (g, r) = (d.path().join("g"), d.path().join("r"));
        std::fs::create_dir_all(&g).unwrap();
        std::fs::create_dir_all(&r).unwrap();
        let gs = write_spec(&g, "paper-3x3.toml", &format!("name = \"g\"\n{common}seeds = 3\n"));
        let rs = write_spec(
            &r,
            "paper-3x3.toml",
            &format!(
                "name = \"r\"\nenv = \"robot\"\nrobot = [\"profile=ideal\", \"profile=realistic cell_diagnostics=true\"]\n{common}seeds = 2\n"
            ),
        );
        let (go, ro) = (d.path().join("go"), d.path().join("ro"));
        ok(mmq(&["sweep", &gs, "--out", &s(&go), "-q"]));
        ok(mmq(&["sweep", &rs, "--out", &s(&ro), "-q"]));
        let rep = d.path().join("rep");
        let o = ok(mmq(&["sweep", "report", &s(&go), &s(&ro), "--out", &s(&rep)]));
        assert!(o.contains("sweep g + r: 6 cells, 14 of 14 jobs finished"), "{o}");
        let md = std::fs::read_to_string(rep.join("report.md")).unwrap();
        for part in [
            "# Sweeps `g` + `r`",
            "| cell | env | learner | robot | seeds |",
            "## Per learner and setting",
            "Settings: 1 = `grid · –`; 2 = `robot · profile=ideal`; 3 = `robot · profile=realistic`.",
            "Change from `grid · –` (percentage points):",
            "## Learning curves",
            "## Robot diagnostics",
            "![3. robot · profile=realistic: belief error](cells-3-belief-error.png)",
        ] {
            assert!(md.contains(part), "{part}\n{md}");
        }
        // The ideal robot has no per-cell diagnostics: no heat map for setting 2.
        assert!(!rep.join("cells-2-grid-mismatch.png").exists());
        for f in ["by-setting.png", "curves-1.png", "curves-3.png", "cells-3-grid-mismatch.png"] {
            assert!(rep.join(f).is_file(), "{f} missing");
        }
        // The ideal robot is the grid: over the same seeds its curve points are the
        // grid's (seeds 0 and 1 of both).
        let curve = |dir: &Path, robot: Option<&str>| -> Vec<String> {
            let csv = std::fs::read_to_string(dir.join("results.csv")).unwrap();
            let mut lines = csv.lines();
            let head: Vec<&str> = lines.next().unwrap().split(',').collect();
            let at = |name: &str| head.iter().position(|h| *h == name);
            let cols: Vec<usize> =
                head.iter().enumerate().filter(|h| h.1.starts_with("curve/")).map(|h| h.0).collect();
            assert_eq!(cols.len(), 2, "{head:?}");
            lines
                .map(|l| l.split(',').collect::<Vec<_>>())
                .filter(|f| f[at("learner").unwrap()] == "q" && ["0", "1"].contains(&f[at("seed").unwrap()]))
                .filter(|f| robot.is_none_or(|r| f[at("robot").unwrap()] == r))
                .map(|f| cols.iter().map(|&c| f[c]).collect::<Vec<_>>().join(","))
                .collect()
        };
        let grid = curve(&go, None);
        assert_eq!(grid.len(), 2);
        assert_eq!(grid, curve(&ro, Some("profile=ideal")));
    }
}

mod bad_specs {
    use super::*;

    /// Each bad spec exits 3 with one line `FILE:LINE:COLUMN: FIELD: message`.
    #[test]
    fn corpus() {
        let d = tempfile::tempdir().unwrap();
        let cases: &[(&str, &str)] = &[
            ("learnr = \"q\"\n", ":2:1: learnr: unknown field `learnr`"),
            ("steps = \"many\"\n", ":2:9: steps: invalid type: string \"many\""),
            ("alpha = [0.1, 1.5]\n", ":2:9: alpha[1]: 1.5 is not accepted; use a learning rate in [0, 1]"),
            ("learner = [\"q\",\n  \"sarsa-x\"]\n", ":2:11: learner[1]: unknown learner `sarsa-x`"),
            ("delay = \"poisson:-2\"\n", ":2:9: delay: "),
            ("delay = []\n", ":2:9: delay: the list is empty"),
            ("delay = [\"none\", \"none\"]\n", ":2:9: delay: `none` is listed twice"),
            ("env = \"lab\"\n", ":2:7: env: `lab` is not an environment"),
            ("steps = [100, 0]\n", ":2:9: steps[1]: 0 is not accepted"),
            ("seeds = 0\n", ":2:9: seeds: 0 is not accepted"),
            (
                "seeds = [1, 2]\nseed = 4\n",
                ":3:8: seed: `seed` (the first of `seeds` seeds) cannot be combined",
            ),
            ("max_delay = -3\n", ":2:13: max_delay: invalid value: integer `-3`, expected u64"),
            ("steps = [1, 2\n", ":2:"),
        ];
        for (i, (body, expect)) in cases.iter().enumerate() {
            let dir = d.path().join(format!("case{i}"));
            std::fs::create_dir_all(&dir).unwrap();
            let spec = write_spec(&dir, "paper-3x3.toml", body);
            let o = mmq(&["sweep", &spec, "--out", &s(&dir.join("out"))]);
            let (_, err) = text(&o);
            assert_eq!(o.status.code(), Some(3), "{body}: {err}");
            assert!(err.contains(&format!("{spec}{expect}")), "{body}: expected `{spec}{expect}` in `{err}`");
            assert_eq!(err.lines().count(), 1, "{body}: one line expected: {err}");
            assert!(!err.contains("panicked"), "{body}: {err}");
            assert!(!dir.join("out").exists(), "{body}: nothing is written for a bad spec");
        }
        // No world, and a world that is not there.
        let p = d.path().join("noworld.toml");
        std::fs::write(&p, "steps = 10\n").unwrap();
        let (_, err) = text(&mmq(&["sweep", &s(&p), "--out", &s(&d.path().join("o"))]));
        assert!(err.contains("noworld.toml:1:1: world: missing field `world`"), "{err}");
        std::fs::write(&p, "world = [\"nope.toml\"]\n").unwrap();
        let (_, err) = text(&mmq(&["sweep", &s(&p), "--out", &s(&d.path().join("o"))]));
        assert!(
            err.contains("noworld.toml:1:9: world[0]: ") && err.contains("nope.toml: no such world file"),
            "{err}"
        );
    }

    #[test]
    fn bad_flags_and_directories() {
        let d = tempfile::tempdir().unwrap();
        let spec = write_spec(d.path(), "paper-3x3.toml", "steps = 100\n");
        for shard in ["0/3", "4/3", "2", "x/y"] {
            let o = mmq(&["sweep", &spec, "--shard", shard, "--out", &s(&d.path().join("o"))]);
            let (_, err) = text(&o);
            assert_eq!(o.status.code(), Some(3), "{shard}: {err}");
            assert!(err.contains("--shard") && err.contains("1 <= K <= N"), "{err}");
        }
        let o = mmq(&["sweep", "report", &s(d.path())]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(3), "{err}");
        assert!(err.contains("sweep.json") && err.contains("not a sweep output directory"), "{err}");
        assert_eq!(mmq(&["sweep", &spec]).status.code(), Some(2), "--out is required");
        let o = mmq(&["sweep", "missing-spec.toml", "--out", &s(&d.path().join("o"))]);
        assert_eq!(o.status.code(), Some(3));
        assert!(text(&o).1.contains("missing-spec.toml: cannot read the sweep spec"));
    }

    /// Every example spec in worlds/sweeps is valid.
    #[test]
    fn shipped_specs_are_valid() {
        let mut n = 0;
        for e in std::fs::read_dir(root().join("worlds/sweeps")).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                let o = mmq(&["sweep", &s(&p), "--out", "unused", "--dry-run"]);
                let (out, err) = text(&o);
                assert!(o.status.success(), "{}: {err}", p.display());
                assert!(out.contains(" jobs"), "{out}");
                n += 1;
            }
        }
        assert!(n >= 2);
    }

    /// --dry-run prints the plan and writes nothing.
    #[test]
    fn dry_run_lists_cells_and_shard_sizes() {
        let d = tempfile::tempdir().unwrap();
        let spec = write_spec(d.path(), "paper-3x3.toml", SMALL);
        let out = d.path().join("o");
        let o = ok(mmq(&["sweep", &spec, "--out", &s(&out), "--dry-run", "--shard", "2/5"]));
        assert!(o.contains("12 cells × 3 seeds = 36 jobs"), "{o}");
        assert!(o.contains("shard 2/5: 7 jobs"), "{o}");
        assert_eq!(o.lines().filter(|l| l.contains("learner=")).count(), 12, "{o}");
        assert!(!out.exists());
    }
}
