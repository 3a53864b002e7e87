//! End-to-end tests of the `mmq` binary, one module per topic (ripgrep's layout).

mod common;
use common::*;

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

    #[test]
    fn learners_lists_names_first() {
        let (out, _) = text(&mmq(&["learners"]));
        let names: Vec<&str> = out.lines().map(|l| l.split_whitespace().next().unwrap()).collect();
        assert!(names.starts_with(&["q", "fixed", "mmq"]), "{names:?}");
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
