//! End-to-end tests of the `mmq` binary, one module per topic (ripgrep's layout).

use crate::common::*;

mod bad_input {
    use super::*;

    /// Every malformed world in tests/bad-input exits 3 with its expected message (first
    /// line `# expect: ...`), names the file, and never panics.
    #[test]
    fn world_corpus() {
        let dir = root().join("tests/bad-input");
        let mut n = 0;
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_none_or(|x| x != "toml") {
                continue;
            }
            let expect = expectation(&p);
            let rel = format!("tests/bad-input/{}", p.file_name().unwrap().to_string_lossy());
            let o = mmq(&["world", "check", &rel]);
            let (_, err) = text(&o);
            assert_eq!(o.status.code(), Some(3), "{rel}: {err}");
            assert!(err.contains(&expect), "{rel}: expected `{expect}` in `{err}`");
            assert!(err.contains(&rel), "{rel}: the message must name the file: {err}");
            assert!(!err.contains("panicked") && !err.contains("RUST_BACKTRACE"), "{rel}: {err}");
            n += 1;
        }
        assert!(n >= 10);
    }

    /// Impossible flags exit 3 with one clear line naming the flag.
    #[test]
    fn flag_corpus() {
        let cases = std::fs::read_to_string(root().join("tests/bad-input/flags.txt")).unwrap();
        let out = tempfile::tempdir().unwrap();
        let out = out.path().to_string_lossy().into_owned();
        for line in cases.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty()) {
            let (flags, expect) = line.split_once('|').unwrap();
            let flags: Vec<&str> = flags.split_whitespace().collect();
            let mut args = vec!["run", "-q", "--out", &out];
            if !flags.contains(&"--steps") {
                args.extend(["--steps", "100"]);
            }
            args.extend(flags.iter().copied());
            let o = mmq(&args);
            let (_, err) = text(&o);
            assert_eq!(o.status.code(), Some(3), "{line}: {err}");
            assert!(err.contains(expect.trim()), "{line}: {err}");
            assert_eq!(err.lines().count(), 1, "{line}: one line expected: {err}");
            assert!(!err.contains("panicked"), "{line}: {err}");
        }
    }

    #[test]
    fn usage_errors_exit_2() {
        let o = mmq(&["run", "--no-such-flag"]);
        assert_eq!(o.status.code(), Some(2));
        // Recording settings without --record would be silently ignored.
        for flag in ["--record-rate", "--record-first", "--record-last"] {
            let o = mmq(&["run", flag, "5", "--steps", "10"]);
            let (_, err) = text(&o);
            assert_eq!(o.status.code(), Some(2), "{flag}: {err}");
            assert!(err.contains("--record"), "{err}");
        }
        // So would a live view's speed without the live view.
        let o = mmq(&["run", "--live-speed", "2", "--steps", "10"]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains("--live"), "{err}");
    }

    /// An empty replay window is refused, not drawn as an empty picture.
    #[test]
    fn empty_render_window_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        let o = mmq(&["run", "--world", "paper-3x3", "--steps", "100", "--record", "-q", "--out", &out]);
        assert!(o.status.success(), "{:?}", text(&o));
        let rec = d.path().join("trajectory-seed0.mcap");
        let svg = d.path().join("x.svg");
        let o = mmq(&[
            "replay",
            &rec.to_string_lossy(),
            "--render",
            &svg.to_string_lossy(),
            "--from",
            "50",
            "--to",
            "10",
        ]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(3), "{err}");
        assert!(err.contains("--from 50 --to 10") && !svg.exists(), "{err}");
    }

    /// An MCAP file of another tool (here the smallest valid one: a header, the data end
    /// and a footer) is not summarised as "run: ? on ?" but refused as bad input; a FIFO
    /// is refused at once instead of blocking.
    #[test]
    fn a_foreign_mcap_file_and_a_fifo_are_refused() {
        fn record(op: u8, body: &[u8]) -> Vec<u8> {
            [&[op][..], &(body.len() as u64).to_le_bytes(), body].concat()
        }
        let magic = b"\x89MCAP0\r\n";
        let header = [&0u32.to_le_bytes()[..], &5u32.to_le_bytes(), b"other"].concat();
        let file = [
            &magic[..],
            &record(0x01, &header),
            &record(0x0F, &0u32.to_le_bytes()),
            &record(0x02, &[0u8; 20]),
            &magic[..],
        ]
        .concat();
        let d = tempfile::tempdir().unwrap();
        let path = d.path().join("other.mcap");
        std::fs::write(&path, file).unwrap();
        let o = mmq(&["replay", &path.to_string_lossy()]);
        let (out, err) = text(&o);
        assert_eq!(o.status.code(), Some(3), "{out}{err}");
        assert!(err.contains("other.mcap") && err.contains("not a recording of this program"), "{err}");
        let fifo = d.path().join("pipe.mcap");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            let o = mmq(&["replay", &fifo.to_string_lossy()]);
            let (_, err) = text(&o);
            assert_eq!(o.status.code(), Some(3), "{err}");
            assert!(err.contains("pipe.mcap") && err.contains("not a regular file"), "{err}");
        }
    }
}

mod run {
    use super::*;

    /// A short run writes every output, and the summary agrees with itself.
    #[test]
    fn writes_config_summary_metrics_tables() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        let o = mmq(&[
            "run",
            "--world",
            "worlds/paper-3x3.toml",
            "--steps",
            "5000",
            "--seeds",
            "3",
            "-q",
            "--out",
            &out,
        ]);
        assert!(o.status.success(), "{:?}", text(&o));
        for f in ["config.toml", "summary.json", "metrics.csv", "policy.csv", "q_seed0.npy", "q_seed2.npy"] {
            assert!(d.path().join(f).is_file(), "{f} missing");
        }
        let s = read_json(&d.path().join("summary.json"));
        assert_eq!(s["complete"], true);
        assert_eq!(s["seeds"].as_array().unwrap().len(), 3);
        let rel = s["mean"]["perf/relative"]["mean"].as_f64().unwrap();
        let per_seed: Vec<f64> =
            s["seeds"].as_array().unwrap().iter().map(|x| x["perf/relative"].as_f64().unwrap()).collect();
        assert!((rel - per_seed.iter().sum::<f64>() / 3.0).abs() < 1e-12);
        assert!((s["optimum_per_step"].as_f64().unwrap() - 2.0).abs() < 1e-12);
        let csv = std::fs::read_to_string(d.path().join("metrics.csv")).unwrap();
        assert_eq!(csv.lines().count(), 1 + 3 * 5);
        let npy = std::fs::read(d.path().join("q_seed0.npy")).unwrap();
        assert_eq!(&npy[..6], b"\x93NUMPY");
        // 9 states × 51 models × 4 actions of f64 after the header.
        let hlen = u16::from_le_bytes([npy[8], npy[9]]) as usize;
        assert_eq!(npy.len() - 10 - hlen, 9 * 51 * 4 * 8);
    }

    /// A delay in seconds on the grid: the summary reports the delivered delays' mean in
    /// seconds and in steps, consistent through the world's 0.1 s step period (each
    /// delivered delay is its drawn delay rounded up to the end of a step, so the mean in
    /// seconds is within one period of the spec's 4 s, up to sampling noise).
    #[test]
    fn delay_in_seconds_reports_both_units() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        let o = mmq(&[
            "run",
            "--world",
            "worlds/paper-3x3.toml",
            "--learner",
            "deconv-model-time",
            "--delay",
            "exponential:4s",
            "--max-delay",
            "60",
            "--time-bin",
            "0.1",
            "--steps",
            "4000",
            "--no-baseline",
            "-q",
            "--out",
            &out,
        ]);
        let (stdout, err) = text(&o);
        assert!(o.status.success(), "{err}");
        assert!(stdout.contains("mean delay delivered, seconds"), "{stdout}");
        let s = read_json(&d.path().join("summary.json"));
        let seed = &s["seeds"][0];
        let (mean_s, mean_steps, n) = (
            seed["delay/delivered_mean_s"].as_f64().unwrap(),
            seed["delay/delivered_mean_steps"].as_f64().unwrap(),
            seed["delay/delivered"].as_f64().unwrap(),
        );
        assert!((mean_s - 0.1 * mean_steps).abs() < 1e-6, "{mean_s} s vs {mean_steps} steps");
        // The sample mean of n exponential delays has SE 4/√n.
        assert!((mean_s - 4.05).abs() < 0.05 + 5.0 * 4.0 / n.sqrt(), "{mean_s} s over {n}");
        assert_eq!(seed["learner/time_bins_shifted"].as_f64(), Some(0.0));
        assert!(std::fs::read_to_string(d.path().join("config.toml")).unwrap().contains("time_bin_s = 0.1"));
    }

    /// `--set KEY=VALUE` lands in the learner's settings: a number and a text, read back
    /// from the run's config.toml and in effect (exploration from confidence, on by
    /// default, is off, so its I* is not reported).
    #[test]
    fn set_gives_any_setting_of_the_learner() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        let o = mmq(&[
            "run",
            "-q",
            "--learner",
            "deconv-model",
            "--steps",
            "300",
            "--no-baseline",
            "--out",
            &out,
            "--set",
            "optimism_confidence=0",
            "--set",
            "told_delay=poisson:13",
        ]);
        let (_, err) = text(&o);
        assert!(o.status.success(), "{err}");
        let cfg = std::fs::read_to_string(d.path().join("config.toml")).unwrap();
        assert!(
            cfg.contains("optimism_confidence = 0.0") && cfg.contains("told_delay = \"poisson:13\""),
            "{cfg}"
        );
        let s = read_json(&d.path().join("summary.json"));
        assert!(s["seeds"][0]["learner/info_needed"].is_null(), "{s}");
    }

    /// Same seeds ⇒ identical summaries on 1 and 2 threads (wall time aside).
    #[test]
    fn thread_count_does_not_change_results() {
        let mut runs = Vec::new();
        for threads in ["1", "2"] {
            let d = tempfile::tempdir().unwrap();
            let out = d.path().to_string_lossy().into_owned();
            let o = mmq(&[
                "--threads",
                threads,
                "run",
                "--steps",
                "20000",
                "--seeds",
                "4",
                "-q",
                "--no-tables",
                "--out",
                &out,
            ]);
            assert!(o.status.success());
            let mut s = read_json(&d.path().join("summary.json"));
            // Timings are the only figures allowed to differ.
            for seed in s["seeds"].as_array_mut().unwrap() {
                seed.as_object_mut().unwrap().retain(|k, _| !k.starts_with("time/"));
            }
            s["mean"].as_object_mut().unwrap().retain(|k, _| !k.starts_with("time/"));
            let metrics = std::fs::read_to_string(d.path().join("metrics.csv")).unwrap();
            runs.push((s, metrics));
        }
        assert_eq!(runs[0], runs[1]);
    }
}

mod world {
    use super::*;

    #[test]
    fn check_accepts_every_shipped_world() {
        let mut args = vec!["world".to_string(), "check".to_string()];
        for e in std::fs::read_dir(root().join("worlds")).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                args.push(format!("worlds/{}", p.file_name().unwrap().to_string_lossy()));
            }
        }
        // A loop over no world would check nothing: the 8 shipped worlds must be there.
        assert!(args.len() >= 2 + 8, "expected the 8 shipped worlds in worlds/: {args:?}");
        let refs: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = mmq(&refs);
        assert!(o.status.success(), "{:?}", text(&o));
    }

    #[test]
    fn show_gives_the_exact_optimum() {
        let o = mmq(&["world", "show", "worlds/paper-9x9.toml"]);
        let (out, _) = text(&o);
        assert!(out.contains("0.588235 per step"), "{out}");
        assert!(out.contains("↑←") || out.contains("←↑"), "{out}");
    }

    /// `world show --toml` prints a world file: saved and loaded, it is the same world.
    #[test]
    fn show_toml_is_a_world_file() {
        let d = tempfile::tempdir().unwrap();
        for name in ["paper-9x9", "maze-15x15"] {
            let o = mmq(&["world", "show", name, "--toml"]);
            let (out, err) = text(&o);
            assert!(o.status.success(), "{err}");
            let copy = d.path().join(format!("my-{name}.toml"));
            std::fs::write(&copy, &out).unwrap();
            let (mine, shipped) =
                (mmq_core::World::load(&copy).unwrap(), mmq_core::World::load(name).unwrap());
            assert_eq!(
                (mine.width, mine.height, &mine.cells),
                (shipped.width, shipped.height, &shipped.cells)
            );
            assert_eq!(
                (mine.goal, mine.respawn, mine.rewards),
                (shipped.goal, shipped.respawn, shipped.rewards)
            );
            assert_eq!(
                (mine.cell_size, mine.start, &mine.robot),
                (shipped.cell_size, shipped.start, &shipped.robot)
            );
            assert!(mmq(&["world", "check", &copy.to_string_lossy()]).status.success());
        }
    }

    #[test]
    fn learners_lists_names_first() {
        let (out, _) = text(&mmq(&["learners"]));
        let names: Vec<&str> = out.lines().map(|l| l.split_whitespace().next().unwrap()).collect();
        assert!(names.starts_with(&["q", "fixed", "mmq"]), "{names:?}");
    }
}

mod honest_numbers {
    use super::*;

    /// A 1×40 corridor, S at one end and G at the other: in 300 steps undelayed
    /// Q-learning bumps far more often than it reaches G, so its cumulative reward is
    /// negative and a ratio to it would mean nothing.
    const CORRIDOR: &str =
        "name = \"corridor\"\nstart = \"respawn\"\nmap = \"G.......................................S\"\n";

    #[test]
    fn relative_is_absent_where_the_baseline_earns_nothing() {
        let d = tempfile::tempdir().unwrap();
        let world = d.path().join("corridor.toml");
        std::fs::write(&world, CORRIDOR).unwrap();
        let out = d.path().join("out");
        let o = mmq(&[
            "run",
            "--world",
            &world.to_string_lossy(),
            "--learner",
            "q",
            "--delay",
            "poisson:3",
            "--q0",
            "0",
            "--steps",
            "300",
            "--seeds",
            "2",
            "--window",
            "100",
            "--out",
            &out.to_string_lossy(),
        ]);
        let (stdout, stderr) = text(&o);
        assert!(o.status.success(), "{stderr}");
        let s = read_json(&out.join("summary.json"));
        // The premise: the undelayed baseline earned ≤ 0 in every seed.
        for seed in s["seeds"].as_array().unwrap() {
            assert!(seed["baseline/earned_per_step"].as_f64().unwrap() <= 0.0, "{seed}");
            assert!(seed.get("perf/relative").is_none(), "{seed}");
            assert!(seed["seed"].is_u64() && seed["complete"].is_boolean(), "{seed}");
            assert!(seed["perf/regret"].as_f64().unwrap() > 0.0);
            assert!(seed["perf/fraction_of_ceiling"].as_f64().is_some());
        }
        assert!(s["mean"].get("perf/relative").is_none());
        let notes = s["notes"].as_array().unwrap();
        assert!(notes.iter().any(|n| n.as_str().unwrap().contains("perf/relative is absent")), "{notes:?}");
        assert!(!stdout.contains("relative performance vs"), "{stdout}");
        assert!(stdout.contains("note: perf/relative is absent"), "{stdout}");
        assert!(stdout.contains("regret against the optimum"), "{stdout}");
        // metrics.csv leaves the column empty.
        let csv = std::fs::read_to_string(out.join("metrics.csv")).unwrap();
        assert!(csv.lines().skip(1).all(|l| l.ends_with(',')), "{csv}");
    }

    /// Regret and the fraction of the ε-soft ceiling agree with the earned reward, and
    /// one seed has no interval.
    #[test]
    fn regret_and_ceiling_are_reported() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        let o = mmq(&["run", "--world", "paper-5x5", "--epsilon", "0.05", "--steps", "3000", "--out", &out]);
        let (stdout, stderr) = text(&o);
        assert!(o.status.success(), "{stderr}");
        let s = read_json(&d.path().join("summary.json"));
        let seed = &s["seeds"][0];
        let (opt, earned) =
            (s["optimum_per_step"].as_f64().unwrap(), seed["reward/earned_total"].as_f64().unwrap());
        let regret = seed["perf/regret"].as_f64().unwrap();
        assert!((regret - (opt * 3000.0 - earned)).abs() < 1e-9, "{regret}");
        let ceiling = s["ceiling_per_step"].as_f64().unwrap();
        assert!(ceiling > 0.0 && ceiling < opt, "{ceiling} vs {opt}");
        let frac = seed["perf/fraction_of_ceiling"].as_f64().unwrap();
        assert!((frac - earned / 3000.0 / ceiling).abs() < 1e-12);
        assert!(stdout.contains("± n/a"), "one seed has no interval: {stdout}");
        assert!(stdout.contains("fraction of the ε-soft ceiling"), "{stdout}");
    }
}

mod anywhere {
    use super::*;

    /// Shipped worlds are found by name, and the paper runs, from a folder that holds no
    /// `worlds/`.
    #[test]
    fn shipped_worlds_work_from_any_folder() {
        let d = tempfile::tempdir().unwrap();
        let o = mmq_in(d.path(), &["run", "--world", "paper-3x3", "--steps", "500", "-q", "--out", "r"]);
        assert!(o.status.success(), "{:?}", text(&o));
        assert!(d.path().join("r/summary.json").is_file());
        let o = mmq_in(
            d.path(),
            &["paper", "--quick", "--fig", "2", "--seeds", "1", "--steps", "300", "-q", "--out", "p"],
        );
        assert!(o.status.success(), "{:?}", text(&o));
        assert!(d.path().join("p/report.md").is_file());
        let (out, _) = text(&mmq_in(d.path(), &["world", "list"]));
        for name in ["paper-3x3", "paper-9x9", "maze-15x15"] {
            assert!(out.contains(name), "{out}");
        }
        let o = mmq_in(d.path(), &["run", "--world", "no-such-world", "-q", "--out", "x"]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(3), "{err}");
        assert!(err.contains("paper-9x9"), "the error lists the shipped worlds: {err}");
    }

    /// With stderr in a file (not a terminal), a run logs plain progress lines with a rate.
    #[test]
    fn progress_lines_when_stderr_is_not_a_terminal() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().to_string_lossy().into_owned();
        let o = mmq(&["run", "--world", "paper-3x3", "--steps", "2000", "--out", &out]);
        let (_, err) = text(&o);
        assert!(o.status.success(), "{err}");
        // 2000 learning steps and as many of the undelayed baseline.
        assert!(err.lines().any(|l| l.contains("4000 of 4000 steps") && l.contains("steps/s")), "{err}");
        let o = mmq(&["run", "--world", "paper-3x3", "--steps", "2000", "-q", "--out", &out]);
        // Under -q only the notice that the previous run's files are replaced is said.
        let (_, err) = text(&o);
        assert!(
            err.lines().all(|l| l.contains("replacing the previous run's")),
            "-q prints no progress: {err}"
        );
    }

    /// A second run into the same folder replaces the first run's files (no stale
    /// tables or recordings are left beside the new summary); a folder holding files of
    /// its own is refused untouched.
    #[test]
    fn output_folders_hold_one_run() {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("r");
        let o = |seeds: &str| {
            mmq(&[
                "run",
                "--world",
                "paper-3x3",
                "--steps",
                "500",
                "--seeds",
                seeds,
                "-q",
                "--out",
                &out.to_string_lossy(),
            ])
        };
        assert!(o("3").status.success());
        assert!(out.join("q_seed2.npy").is_file());
        // The replacement is said, also under -q.
        let again = o("1");
        assert!(again.status.success());
        assert!(text(&again).1.contains("replacing the previous run's"), "{:?}", text(&again));
        assert!(out.join("q_seed0.npy").is_file());
        assert!(!out.join("q_seed2.npy").exists(), "a stale table from the first run is left");
        std::fs::write(out.join("notes.txt"), "mine").unwrap();
        let r = o("1");
        let (_, err) = text(&r);
        assert_eq!(r.status.code(), Some(3), "{err}");
        assert!(err.contains("notes.txt") && err.contains("--out"), "{err}");
        assert!(out.join("notes.txt").is_file() && out.join("summary.json").is_file());
    }

    /// `--threads` outside 1..=256 is bad input, not a panic.
    #[test]
    fn thread_count_is_bounded() {
        for n in ["0", "300"] {
            let o = mmq(&["--threads", n, "learners"]);
            let (_, err) = text(&o);
            assert_eq!(o.status.code(), Some(3), "{n}: {err}");
            assert!(err.contains("--threads") && err.contains("256"), "{err}");
        }
    }
}

mod live {
    use super::*;

    /// A port in use stops `mmq run --live` before the run, with one line naming the
    /// address and the fix (a runtime failure, exit 1), and writes nothing.
    #[test]
    fn a_port_in_use_is_one_clear_error() {
        let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = taken.local_addr().unwrap().to_string();
        let out = tempfile::tempdir().unwrap();
        let dir = out.path().join("run");
        let o = mmq(&["run", "-q", "--steps", "100", "--out", dir.to_str().unwrap(), "--live", &addr]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(&addr) && err.contains("in use"), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(!dir.exists(), "nothing is written when the server cannot start");
    }

    /// With no client the run goes through as usual and says where it served.
    #[test]
    fn a_run_with_no_client_completes() {
        let out = tempfile::tempdir().unwrap();
        let o = mmq(&[
            "run",
            "-q",
            "--steps",
            "2000",
            "--seeds",
            "2",
            "--out",
            out.path().to_str().unwrap(),
            "--live",
            "0",
            "--record",
        ]);
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(0), "{err}");
        assert!(err.contains("live view: ws://127.0.0.1:"), "{err}");
        // Both seeds recorded; the file of the seed shown live is the file without --live.
        let plain = tempfile::tempdir().unwrap();
        let o = mmq(&[
            "run",
            "-q",
            "--steps",
            "2000",
            "--seeds",
            "2",
            "--out",
            plain.path().to_str().unwrap(),
            "--record",
        ]);
        assert_eq!(o.status.code(), Some(0));
        for seed in ["trajectory-seed0.mcap", "trajectory-seed1.mcap"] {
            let a = std::fs::read(out.path().join(seed)).unwrap();
            let b = std::fs::read(plain.path().join(seed)).unwrap();
            assert!(a == b, "{seed} differs with --live");
        }
    }
}

mod replay_verify {
    use super::*;
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};

    /// Records a grid run of `steps` into `dir`; returns the file.
    fn record(dir: &std::path::Path, env: &str, steps: &str) -> std::path::PathBuf {
        let out = dir.to_string_lossy().into_owned();
        let o =
            mmq(&["run", "--env", env, "--steps", steps, "--record", "--no-baseline", "-q", "--out", &out]);
        assert!(o.status.success(), "{:?}", text(&o));
        dir.join("trajectory-seed0.mcap")
    }

    /// An interrupted write (the MCAP holds a prefix) verifies what it holds, with one
    /// warning; a missing scratch folder is named; no scratch file stays behind.
    #[test]
    fn a_truncated_recording_verifies_with_one_warning() {
        let d = tempfile::tempdir().unwrap();
        let file = record(d.path(), "grid", "30000");
        let bytes = std::fs::read(&file).unwrap();
        let cut = d.path().join("cut.mcap");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        let scratch = tempfile::tempdir().unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_mmq"))
            .args(["replay", &cut.to_string_lossy(), "--verify"])
            .env("TMPDIR", scratch.path())
            .output()
            .unwrap();
        let (out, err) = text(&o);
        assert_eq!(o.status.code(), Some(0), "{out}\n{err}");
        assert!(out.contains("verify: OK") && out.contains("holds only the first"), "{out}");
        assert_eq!(err.matches("read stopped").count(), 1, "{err}");
        assert_eq!(std::fs::read_dir(scratch.path()).unwrap().count(), 0, "scratch files left behind");
        let missing = scratch.path().join("gone");
        let o = Command::new(env!("CARGO_BIN_EXE_mmq"))
            .args(["replay", &file.to_string_lossy(), "--verify"])
            .env("TMPDIR", &missing)
            .output()
            .unwrap();
        let (_, err) = text(&o);
        assert_eq!(o.status.code(), Some(1), "{err}");
        assert!(err.contains(&missing.display().to_string()), "{err}");
    }

    /// The first Ctrl-C stops a long verification: exit 130, nothing concluded, no
    /// scratch file left.
    #[test]
    fn ctrl_c_stops_a_verification() {
        let d = tempfile::tempdir().unwrap();
        let file = record(d.path(), "grid", "300000");
        let scratch = tempfile::tempdir().unwrap();
        let mut child = Command::new(env!("CARGO_BIN_EXE_mmq"))
            .args(["replay", &file.to_string_lossy(), "--verify"])
            .env("TMPDIR", scratch.path())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Once the re-run writes its log, it is under way.
        let t0 = Instant::now();
        while std::fs::read_dir(scratch.path()).unwrap().count() == 0
            && t0.elapsed() < Duration::from_secs(60)
        {
            std::thread::sleep(Duration::from_millis(20));
        }
        let pid = child.id().to_string();
        let st = Command::new("kill").args(["-INT", &pid]).status().unwrap();
        assert!(st.success());
        let deadline = Instant::now() + Duration::from_secs(60);
        while child.try_wait().unwrap().is_none() {
            if Instant::now() > deadline {
                let _ = child.kill();
                panic!("verify did not stop within 60 s of Ctrl-C");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let o = child.wait_with_output().unwrap();
        let (out, err) = text(&o);
        assert_eq!(o.status.code(), Some(130), "{out}\n{err}");
        assert!(err.contains("interrupted") && !out.contains("verify: OK"), "{out}\n{err}");
        assert_eq!(std::fs::read_dir(scratch.path()).unwrap().count(), 0, "scratch files left behind");
    }
}
