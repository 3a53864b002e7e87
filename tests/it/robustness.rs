//! Robustness of the `mmq` binary, one module per topic: interruption (SIGINT, SIGTERM)
//! mid-run, the bad-input corpus for robot worlds, crashing inputs kept as regressions,
//! and determinism across thread counts (summaries and MCAP contents).
//!
//! See docs/robustness.md for what each guards.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use crate::common::*;

/// Tests that start long runs take turns: on a two-core machine, two of them at once
/// would measure each other rather than the binary.
static HEAVY: Mutex<()> = Mutex::new(());

fn heavy() -> std::sync::MutexGuard<'static, ()> {
    HEAVY.lock().unwrap_or_else(|e| e.into_inner())
}

mod interrupt {
    use super::*;

    /// How long a stopped run may take to exit: the runner looks at the stop flag every
    /// 1024 steps, then evaluates the greedy policy (1000 steps) and writes its outputs.
    /// A second or two on a quiet machine; the margin is for a loaded CI machine and the
    /// unoptimised test build.
    const EXIT_WITHIN: Duration = Duration::from_secs(6);

    fn spawn(args: &[&str]) -> Child {
        Command::new(env!("CARGO_BIN_EXE_mmq"))
            .args(args)
            .current_dir(root())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("the mmq binary starts")
    }

    /// Waits until `ready` holds (the run is under way), at most `limit`.
    fn wait_for(child: &mut Child, limit: Duration, ready: impl Fn() -> bool) {
        let t0 = Instant::now();
        while !ready() {
            if let Some(status) = child.try_wait().unwrap() {
                panic!("mmq ended before the signal ({status}): {}", stderr_of(child));
            }
            assert!(t0.elapsed() < limit, "the run did not get under way within {limit:?}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn stderr_of(child: &mut Child) -> String {
        use std::io::Read;
        let mut s = String::new();
        if let Some(e) = child.stderr.as_mut() {
            let _ = e.read_to_string(&mut s);
        }
        s
    }

    /// `kill -SIGNAL PID`.
    fn kill(signal: &str, pid: &str) {
        let st = Command::new("kill").args([&format!("-{signal}"), pid]).status().expect("kill runs");
        assert!(st.success(), "kill -{signal} {pid} failed");
    }

    /// Starts a recorded `mmq run` far longer than any test (3×3 world, 2 seeds × 50M
    /// steps, 2 threads) writing into `out`, and waits until its logs have data.
    fn start_recorded_run(out: &Path, env: &str) -> Child {
        let dir = out.to_string_lossy().into_owned();
        let mut child = spawn(&[
            "--threads",
            "2",
            "run",
            "--world",
            "worlds/paper-3x3.toml",
            "--env",
            env,
            "--steps",
            "50000000",
            "--seeds",
            "2",
            "--record",
            "-q",
            "--out",
            &dir,
        ]);
        wait_for(&mut child, Duration::from_secs(60), || log_started(out));
        child
    }

    /// Sends `signal` (INT or TERM) with `kill`, then waits for the exit; returns the
    /// output and how long the exit took.
    fn signal_and_wait(child: Child, signal: &str) -> (Output, Duration) {
        let pid = child.id().to_string();
        let t0 = Instant::now();
        kill(signal, &pid);
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let _ = tx.send(child.wait_with_output());
        });
        match rx.recv_timeout(Duration::from_secs(60)) {
            Ok(out) => (out.expect("wait for mmq"), t0.elapsed()),
            Err(_) => {
                // Leave no process behind: the second signal ends it at once.
                let _ = Command::new("kill").args(["-KILL", &pid]).status();
                panic!("mmq did not exit within 60 s of SIGINT/SIGTERM");
            }
        }
    }

    fn mcaps(dir: &Path) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
            .collect();
        v.sort();
        v
    }

    /// The run wrote some steps to its log(s): the first chunks are flushed.
    fn log_started(dir: &Path) -> bool {
        mcaps(dir).iter().any(|p| std::fs::metadata(p).is_ok_and(|m| m.len() > 20_000))
    }

    /// Robot settings at the edge of what is accepted (tiny physics step, slow drive:
    /// about 24 000 physics steps per primitive): SIGINT still stops the run at once,
    /// because the stop flag is read every step and a stopped run is not evaluated.
    #[test]
    fn a_slow_robot_stops_within_the_bound() {
        let _g = heavy();
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("slow");
        let dir = out.to_string_lossy().into_owned();
        let mut child = spawn(&[
            "run",
            "--env",
            "robot",
            "--robot",
            "dt_s=0.00145",
            "--robot",
            "max_speed_mps=0.05",
            "--steps",
            "100000000",
            "--no-baseline",
            "-q",
            "--out",
            &dir,
        ]);
        wait_for(&mut child, Duration::from_secs(60), || out.join("config.toml").exists());
        std::thread::sleep(Duration::from_millis(1500));
        let (o, took) = signal_and_wait(child, "INT");
        let (_, stderr) = text(&o);
        assert_eq!(o.status.code(), Some(130), "{stderr}");
        assert!(took < EXIT_WITHIN, "exited {took:?} after SIGINT (bound {EXIT_WITHIN:?})");
        assert_eq!(read_json(&out.join("summary.json"))["complete"], false);
    }

    /// `mmq run --record` with many steps, stopped by `signal` mid-run: exit 130 within
    /// seconds, a summary marked incomplete, config.toml, and every MCAP log finished
    /// explicitly (readable to its end, `end` record saying the run was not complete).
    fn run_stopped_by(signal: &str, env: &str) {
        let _g = heavy();
        let d = tempfile::tempdir().unwrap();
        let child = start_recorded_run(d.path(), env);
        std::thread::sleep(Duration::from_millis(1000));
        let (o, took) = signal_and_wait(child, signal);
        let (stdout, stderr) = text(&o);
        eprintln!("SIG{signal}, {env}: exited {took:?} after the signal");
        assert_eq!(o.status.code(), Some(130), "SIG{signal}, {env}: {stdout}\n{stderr}");
        assert!(took < EXIT_WITHIN, "SIG{signal}, {env}: exit took {took:?}");
        assert!(stderr.contains("interrupted"), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(d.path().join("config.toml").is_file());
        let s = read_json(&d.path().join("summary.json"));
        assert_eq!(s["complete"], false, "{s}");
        let seeds = s["seeds"].as_array().expect("per-seed results");
        assert_eq!(seeds.len(), 2, "both seeds had started: {s}");
        for seed in seeds {
            let steps = seed["steps"].as_f64().unwrap();
            assert!(steps > 0.0 && steps < 50_000_000.0, "{seed}");
        }
        for f in ["metrics.csv", "policy.csv"] {
            assert!(d.path().join(f).is_file(), "{f} missing");
        }
        // Atomic writes leave no temporary file behind.
        for e in std::fs::read_dir(d.path()).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.contains(".tmp"), "left behind: {name}");
        }
        let logs = mcaps(d.path());
        assert_eq!(logs.len(), 2, "{logs:?}");
        for p in &logs {
            let log = mmq_log::read_log(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            assert!(log.complete, "{}: {:?}", p.display(), log.stop);
            assert!(!log.decisions.is_empty(), "{}", p.display());
            let end = log.metadata.get("end").unwrap_or_else(|| panic!("{}: no end record", p.display()));
            assert_eq!(end.get("complete").map(String::as_str), Some("false"), "{end:?}");
            let steps: u64 = end["steps"].parse().unwrap();
            assert_eq!(log.decisions.len() as u64, steps, "{}", p.display());
        }
    }

    /// A second Ctrl-C, or SIGKILL, ends the run at once: the MCAP logs are not finished
    /// but read back as a prefix up to their last flush (every 10,000 steps or 5 s), and
    /// no half-written output file is left (atomic writes).
    fn run_killed_by(signals: &[&str]) {
        let _g = heavy();
        let d = tempfile::tempdir().unwrap();
        let child = start_recorded_run(d.path(), "grid");
        std::thread::sleep(Duration::from_millis(500));
        let pid = child.id().to_string();
        for sig in signals {
            kill(sig, &pid);
        }
        let o = child.wait_with_output().unwrap();
        let what = signals.join("+");
        if signals == ["KILL"] {
            assert_eq!(o.status.code(), None, "{what}: killed by the signal");
        } else {
            // The second signal exits with 130 at once (unless the first one already
            // finished the run's outputs).
            assert_eq!(o.status.code(), Some(130), "{what}: {:?}", text(&o));
        }
        assert!(d.path().join("config.toml").is_file());
        for e in std::fs::read_dir(d.path()).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            // A temporary file may be left by a kill mid-write, but never a partial
            // output under its real name: whatever exists parses.
            if name == "summary.json" {
                read_json(&d.path().join(&name));
            }
        }
        for p in mcaps(d.path()) {
            let log = mmq_log::read_log(&p).unwrap_or_else(|e| panic!("{what}: {}: {e}", p.display()));
            assert!(log.complete || log.stop.is_some(), "{what}: {}", p.display());
            assert!(!log.decisions.is_empty(), "{what}: {}: nothing recovered", p.display());
            for (i, dcs) in log.decisions.iter().enumerate() {
                assert_eq!(dcs.msg.t, i as u64, "{what}: decisions are a prefix");
            }
        }
    }

    #[test]
    fn a_second_sigint_exits_at_once_leaving_readable_logs() {
        run_killed_by(&["INT", "INT"]);
    }

    #[test]
    fn sigkill_leaves_readable_log_prefixes() {
        run_killed_by(&["KILL"]);
    }

    #[test]
    fn sigint_stops_a_grid_run_cleanly() {
        run_stopped_by("INT", "grid");
    }

    #[test]
    fn sigterm_stops_a_grid_run_cleanly() {
        run_stopped_by("TERM", "grid");
    }

    #[test]
    fn sigint_stops_a_robot_run_cleanly() {
        run_stopped_by("INT", "robot");
    }

    #[test]
    fn sigterm_stops_a_robot_run_cleanly() {
        run_stopped_by("TERM", "robot");
    }

    /// `mmq paper` stopped mid-figure still writes report.md (marked interrupted) and
    /// exits 130.
    #[test]
    fn sigint_stops_paper_with_a_report() {
        let _g = heavy();
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        // A budget far beyond the signal: the paper's own (20 seeds × 150,000 steps) can
        // finish within the wait on a fast machine.
        let mut child = spawn(&[
            "--threads",
            "2",
            "paper",
            "--fig",
            "6",
            "--steps",
            "50000000",
            "--seeds",
            "4",
            "-q",
            "--out",
            &out,
        ]);
        // The output folder exists before the runs start.
        wait_for(&mut child, Duration::from_secs(60), || d.path().is_dir());
        std::thread::sleep(Duration::from_millis(1500));
        let (o, took) = signal_and_wait(child, "INT");
        let (stdout, stderr) = text(&o);
        assert_eq!(o.status.code(), Some(130), "{stdout}\n{stderr}");
        assert!(took < EXIT_WITHIN + Duration::from_secs(4), "exit took {took:?}");
        let report = std::fs::read_to_string(d.path().join("report.md")).expect("report.md written");
        assert!(report.contains("Fig. 6"), "{report}");
        assert!(report.to_lowercase().contains("interrupted"), "the report must say it is partial");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
}

mod bad_robot_worlds {
    use super::*;

    fn corpus(prefix: &str) -> Vec<PathBuf> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(root().join("tests/bad-input"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| {
                let name = p.file_name().unwrap().to_string_lossy();
                name.starts_with(prefix) && name.ends_with(".toml")
            })
            .collect();
        v.sort();
        v
    }

    /// Every `tests/bad-input/robot-*.toml` (a `[robot]` table that makes no physical
    /// sense, or does not parse) run with `mmq run --env robot` exits 3 with one line that
    /// names the file and the field, before any step runs.
    #[test]
    fn run_env_robot_refuses_each_with_file_and_field() {
        let files = corpus("robot-");
        assert!(files.len() >= 8, "{files:?}");
        for p in files {
            let rel = format!("tests/bad-input/{}", p.file_name().unwrap().to_string_lossy());
            let expect = expectation(&p);
            let d = tempfile::tempdir().unwrap();
            let out = d.path().to_string_lossy().into_owned();
            let o = mmq(&["run", "--env", "robot", "--world", &rel, "--steps", "10", "-q", "--out", &out]);
            let (stdout, err) = text(&o);
            assert_eq!(o.status.code(), Some(3), "{rel}: {stdout}{err}");
            assert!(err.contains(&expect), "{rel}: expected `{expect}` in `{err}`");
            assert!(err.contains(&rel), "{rel}: the message must name the file: {err}");
            assert_eq!(err.lines().count(), 1, "{rel}: one line expected: {err}");
            assert!(!err.contains("panicked"), "{rel}: {err}");
            assert!(!d.path().join("summary.json").exists(), "{rel}: no results for a refused run");
        }
    }

    /// The same files on the grid: the `[robot]` table is the robot's business, so a grid
    /// run of a world whose table is merely out of range goes ahead (tables that do not
    /// parse as TOML types are the world's business and refused).
    #[test]
    fn grid_runs_ignore_an_out_of_range_robot_table() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        let o = mmq(&[
            "run",
            "--world",
            "tests/bad-input/robot-wider-than-cell.toml",
            "--steps",
            "200",
            "--no-tables",
            "-q",
            "--out",
            &out,
        ]);
        assert!(o.status.success(), "{:?}", text(&o));
    }

    /// Maps too large to accept, generated here rather than kept as files: each exits 3
    /// naming the file, the size and the limits, in `world check` and in `run`.
    #[test]
    fn absurd_map_sizes_are_refused() {
        let d = tempfile::tempdir().unwrap();
        let cases =
            [("tall.toml", 1, 1001), ("too-many-cells.toml", 600, 600), ("long-row.toml", 100_000, 1)];
        for (name, w, h) in cases {
            let mut map = String::with_capacity((w + 1) * h);
            for r in 0..h {
                for c in 0..w {
                    map.push(match (r, c) {
                        (0, 0) => 'G',
                        _ if r == h - 1 && c == w - 1 => 'S',
                        _ => '.',
                    });
                }
                map.push('\n');
            }
            let p = d.path().join(name);
            std::fs::write(&p, format!("map = \"\"\"\n{map}\"\"\"\n")).unwrap();
            let ps = p.to_string_lossy().into_owned();
            let want = format!("field `map` is {w}×{h} cells; at most 1000 per side and 250000 cells");
            let out = d.path().join("out").to_string_lossy().into_owned();
            let run = vec!["run", "--world", &ps, "--steps", "10", "-q", "--out", &out];
            for args in [vec!["world", "check", &ps], run] {
                let o = mmq(&args);
                let (_, err) = text(&o);
                assert_eq!(o.status.code(), Some(3), "{name}: {err}");
                assert!(err.contains(&want) && err.contains(&ps), "{name}: {err}");
            }
        }
    }
}

mod determinism {
    use super::*;

    /// A summary without its wall-clock times.
    fn summary_sans_time(dir: &Path) -> serde_json::Value {
        let mut s = read_json(&dir.join("summary.json"));
        fn strip(v: &mut serde_json::Value) {
            match v {
                serde_json::Value::Object(m) => {
                    m.retain(|k, _| !k.starts_with("time/"));
                    m.values_mut().for_each(strip);
                }
                serde_json::Value::Array(a) => a.iter_mut().for_each(strip),
                _ => {}
            }
        }
        strip(&mut s);
        s
    }

    /// Per topic: message count and digest (FNV-1a over log times and message bytes).
    fn digests(log: &mmq_log::LogContents) -> Vec<(String, u64, u64)> {
        log.topics.iter().map(|(k, t)| (k.clone(), t.count, t.digest)).collect()
    }

    /// Same seeds of `learner` on 1 and 2 worker threads: bit-identical summaries (wall
    /// time aside), learning curves, Q-tables and MCAP message contents. Three seeds, so
    /// that on two threads the seeds finish out of order; one, so that the learner has a
    /// core to spare.
    fn same_on_one_and_two_threads(env: &str, learner: &str, steps: &str, seeds: u64) {
        let _g = heavy();
        let mut runs = Vec::new();
        for threads in ["1", "2"] {
            let d = tempfile::tempdir().unwrap();
            let out = d.path().to_string_lossy().into_owned();
            let o = mmq(&[
                "--threads",
                threads,
                "run",
                "--world",
                "worlds/paper-5x5.toml",
                "--env",
                env,
                "--learner",
                learner,
                "--steps",
                steps,
                "--seeds",
                &seeds.to_string(),
                "--seed",
                "11",
                "--window",
                "50",
                "--record",
                "-q",
                "--out",
                &out,
            ]);
            assert!(o.status.success(), "{env}, {threads} thread(s): {:?}", text(&o));
            runs.push(d);
        }
        let (a, b) = (runs[0].path(), runs[1].path());
        assert_eq!(summary_sans_time(a), summary_sans_time(b), "{env}: summaries differ");
        let tables = (11..11 + seeds).map(|s| format!("q_seed{s}.npy"));
        for f in ["metrics.csv".to_string(), "policy.csv".to_string()].into_iter().chain(tables) {
            let (x, y) = (std::fs::read(a.join(&f)).unwrap(), std::fs::read(b.join(&f)).unwrap());
            assert!(x == y, "{env}: {f} differs between 1 and 2 threads");
        }
        for seed in 11..11 + seeds {
            let name = format!("trajectory-seed{seed}.mcap");
            let la = mmq_log::read_log(a.join(&name)).unwrap();
            let lb = mmq_log::read_log(b.join(&name)).unwrap();
            assert!(la.complete && lb.complete, "{env}: {name} not finished");
            assert!(la.decisions.len() as u64 == steps.parse::<u64>().unwrap(), "{env}: {name}");
            assert_eq!(digests(&la), digests(&lb), "{env}: {name}: topic digests differ");
            if let Err(m) = mmq_log::compare(&la, &lb) {
                panic!("{env}: {name}: {m}");
            }
        }
    }

    #[test]
    fn grid_is_bit_identical_on_one_and_two_threads() {
        same_on_one_and_two_threads("grid", "mmq", "3000", 3);
    }

    #[test]
    fn robot_is_bit_identical_on_one_and_two_threads() {
        same_on_one_and_two_threads("robot", "mmq", "150", 3);
    }

    /// One seed of `deconv-model` on two threads runs its refits' cold starts on the
    /// spare core.
    #[test]
    fn deconv_model_is_bit_identical_with_a_spare_core() {
        same_on_one_and_two_threads("grid", "deconv-model", "6000", 1);
    }
}

mod regressions {
    //! Every input kept under tests/regressions/<target>/ (crashes, hangs or huge
    //! allocations found by fuzzing, see docs/robustness.md) goes through the code path
    //! that failed: it must give a clear one-line error, or for files named `ok-*` a
    //! value, and never panic.
    use super::*;

    fn cases(target: &str) -> Vec<(String, Vec<u8>)> {
        // A missing or empty folder is a failure: the test would otherwise pass having
        // checked nothing.
        let dir = root().join("tests/regressions").join(target);
        let rd = std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        let mut v: Vec<(String, Vec<u8>)> = rd
            .map(|e| e.unwrap().path())
            .filter(|p| p.is_file())
            .map(|p| (p.file_name().unwrap().to_string_lossy().into_owned(), std::fs::read(&p).unwrap()))
            .collect();
        v.sort();
        assert!(!v.is_empty(), "{}: no regression cases", dir.display());
        v
    }

    /// Checks one outcome: `ok-*` files must be accepted, others refused with a message
    /// of one line (a few for TOML syntax errors, which quote the line).
    fn check<T>(target: &str, name: &str, r: Result<T, String>) {
        match (name.starts_with("ok-"), r) {
            (true, Ok(_)) => {}
            (true, Err(e)) => panic!("{target}/{name}: refused: {e}"),
            (false, Ok(_)) => panic!("{target}/{name}: accepted, but it was kept as a bad input"),
            (false, Err(e)) => {
                assert!(!e.trim().is_empty(), "{target}/{name}: empty message");
                assert!(e.lines().count() <= 6, "{target}/{name}: {e}");
            }
        }
    }

    #[test]
    fn world_parse() {
        for (name, bytes) in cases("world_parse") {
            let text = String::from_utf8_lossy(&bytes);
            let r = mmq_core::World::parse(&text, "regression.toml").map(|w| mmq_core::optimum(&w));
            check("world_parse", &name, r.map_err(|e| e.to_string()));
        }
    }

    #[test]
    fn delay_parse() {
        for (name, bytes) in cases("delay_parse") {
            let text = String::from_utf8_lossy(&bytes);
            let r = mmq_core::DelayDist::parse(&text).map(|d| {
                let m = d.mean();
                assert!(m.is_finite() && m >= 0.0, "delay_parse/{name}: mean {m}");
                let s = d.sampler();
                let mut rng = mmq_core::seed::rng_from_seed(7);
                (0..16).map(|_| s.sample(&mut rng)).max()
            });
            check("delay_parse", &name, r.map_err(|e| e.to_string()));
        }
    }

    #[test]
    fn run_config() {
        for (name, bytes) in cases("run_config") {
            let text = String::from_utf8_lossy(&bytes);
            let r = mmq_lab::RunConfig::from_toml(&text, "regression.toml").and_then(|c| c.validate());
            check("run_config", &name, r.map_err(|e| e.to_string()));
        }
    }

    #[test]
    fn sweep_spec() {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("w.toml"), "map = \"\"\"\nG..\n...\n..S\n\"\"\"\n").unwrap();
        let spec = d.path().join("spec.toml");
        for (name, bytes) in cases("sweep_spec") {
            let text = String::from_utf8_lossy(&bytes);
            let r = mmq_lab::sweep::SweepSpec::parse(&text, &spec);
            check("sweep_spec", &name, r.map_err(|e| e.to_string()));
        }
    }

    /// MCAP inputs must read (a prefix, with the reason reading stopped) or be refused as
    /// not MCAP; `ok-*` files must read.
    #[test]
    fn mcap_read() {
        let d = tempfile::tempdir().unwrap();
        for (name, bytes) in cases("mcap_read") {
            let p = d.path().join(&name);
            std::fs::write(&p, &bytes).unwrap();
            match mmq_log::read_log(&p) {
                Ok(log) => {
                    assert_eq!(log.file_len, bytes.len() as u64);
                    assert!(log.complete != log.stop.is_some(), "mcap_read/{name}");
                    let _ = mmq_log::summary(&log);
                    // A length prefix larger than its record (which made the `mcap` crate
                    // reserve gigabytes) is refused by name, before any allocation.
                    if name.starts_with("oom-") {
                        let reason = log.stop.as_ref().map(|s| s.reason.clone()).unwrap_or_default();
                        assert!(reason.contains("exceeds the"), "mcap_read/{name}: {reason}");
                    }
                }
                Err(e) => assert!(!name.starts_with("ok-"), "mcap_read/{name}: {e}"),
            }
        }
    }
}

mod endless_files {
    use super::*;

    /// A FIFO as a world or a sweep spec is refused at once (opening it would block
    /// until a writer came), and a world file over the size limit by its size.
    #[test]
    fn fifos_and_huge_files_are_refused() {
        let d = tempfile::tempdir().unwrap();
        let fifo = d.path().join("w.toml");
        let made = Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available");
            return;
        }
        let f = fifo.to_string_lossy().into_owned();
        for args in [vec!["world", "check", &f], vec!["sweep", &f, "--out", "/nonexistent-out"]] {
            let t0 = Instant::now();
            let o = mmq(&args);
            let (_, err) = text(&o);
            assert_eq!(o.status.code(), Some(3), "{args:?}: {err}");
            assert!(err.contains("not a regular file"), "{err}");
            assert!(t0.elapsed() < Duration::from_secs(30), "{:?}", t0.elapsed());
        }
        let big = d.path().join("big.toml");
        std::fs::File::create(&big).unwrap().set_len(17 << 20).unwrap();
        let o = mmq(&["world", "check", &big.to_string_lossy()]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(3), "{err}");
        assert!(err.contains("larger than 16 MiB"), "{err}");
    }

    /// A sweep job file replaced by a link to /dev/zero is not a finished job: the
    /// resumed sweep runs that job again instead of reading without end.
    #[test]
    fn a_job_file_linked_to_dev_zero_is_run_again() {
        if !Path::new("/dev/zero").exists() {
            return;
        }
        let d = tempfile::tempdir().unwrap();
        let spec = d.path().join("s.toml");
        std::fs::copy(root().join("worlds/paper-3x3.toml"), d.path().join("w.toml")).unwrap();
        std::fs::write(&spec, "world = \"w.toml\"\nlearner = \"q\"\nsteps = 500\nseeds = 2\n").unwrap();
        let out = d.path().join("o");
        let (spec, out_s) = (spec.to_string_lossy().into_owned(), out.to_string_lossy().into_owned());
        assert!(mmq(&["sweep", &spec, "--out", &out_s, "-q"]).status.success());
        let jobs: Vec<PathBuf> = walk(&out.join("cells"))
            .into_iter()
            .filter(|p| p.extension().is_some_and(|e| e == "json"))
            .collect();
        assert_eq!(jobs.len(), 2, "{jobs:?}");
        let results = |p: &Path| {
            let mut j = read_json(p);
            j["metrics"].as_object_mut().unwrap().retain(|k, _| !k.starts_with("time/"));
            j
        };
        let before = results(&jobs[0]);
        std::fs::remove_file(&jobs[0]).unwrap();
        std::os::unix::fs::symlink("/dev/zero", &jobs[0]).unwrap();
        let t0 = Instant::now();
        let o = mmq(&["sweep", &spec, "--out", &out_s, "-q"]);
        assert!(o.status.success(), "{:?}", text(&o));
        assert!(t0.elapsed() < Duration::from_secs(60), "{:?}", t0.elapsed());
        assert_eq!(results(&jobs[0]), before, "the job ran again, with the same results (timings aside)");
    }

    fn walk(dir: &Path) -> Vec<PathBuf> {
        let mut v = Vec::new();
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() { v.extend(walk(&p)) } else { v.push(p) }
        }
        v.sort();
        v
    }

    /// A world "file" that never ends (`/dev/zero`) is refused at once as not a regular
    /// file, instead of being read until memory runs out.
    #[test]
    fn dev_zero_as_a_world_is_refused() {
        if !Path::new("/dev/zero").exists() {
            return;
        }
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        for args in
            [vec!["world", "check", "/dev/zero"], vec!["run", "--world", "/dev/zero", "-q", "--out", &out]]
        {
            let t0 = Instant::now();
            let o = mmq(&args);
            let (_, err) = text(&o);
            assert_eq!(o.status.code(), Some(3), "{args:?}: {err}");
            assert!(err.contains("/dev/zero: cannot read the world file: not a regular file"), "{err}");
            assert!(t0.elapsed() < Duration::from_secs(30), "{:?}", t0.elapsed());
        }
    }
}
