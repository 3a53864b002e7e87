//! Limits of the `mmq` binary's output folders and worlds: one process writes into an
//! output folder at a time (a second run, report or sweep into a folder in use is
//! refused, and the first one's outputs stay whole), and a run on a large world spends
//! little on its summary.
//!
//! See docs/robustness.md for what each guards.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::*;

mod out_lock {
    use super::*;

    /// Steps of the first run: long enough (seconds in the test build) for the other
    /// commands to start and be refused while it runs.
    const STEPS: &str = "150000";

    fn refused(o: &std::process::Output, pid: u32, what: &str) {
        let (_, err) = text(o);
        assert_eq!(o.status.code(), Some(3), "{what}: {err}");
        assert!(err.contains(&format!("PID {pid}")) && err.contains("--out"), "{what}: {err}");
        assert!(!err.contains("panicked"), "{what}: {err}");
    }

    /// Run A records into a folder; run B, a report and a sweep into the same folder are
    /// refused with exit 3 naming A's process; A ends normally with its own outputs: its
    /// configuration, a complete summary and its whole recording.
    #[test]
    fn a_second_command_into_a_folder_in_use_is_refused_and_the_first_run_stays_whole() {
        let d = tempfile::tempdir().unwrap();
        let x = d.path().join("cc");
        let dir = x.to_string_lossy().into_owned();
        let mut a = Command::new(env!("CARGO_BIN_EXE_mmq"))
            .args(["--threads", "1", "run", "--world", "paper-9x9", "--steps", STEPS, "--seed", "1"])
            .args(["--record", "-q", "--out", &dir])
            .current_dir(root())
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("the mmq binary starts");
        let t0 = Instant::now();
        while !x.join("config.toml").exists() {
            assert!(a.try_wait().unwrap().is_none(), "run A ended before the test could start B");
            assert!(t0.elapsed() < Duration::from_secs(60), "run A did not start within 60 s");
            std::thread::sleep(Duration::from_millis(10));
        }
        let pid = a.id();
        let b = mmq(&["run", "--world", "paper-3x3", "--steps", "2000", "--seed", "7", "--out", &dir]);
        refused(&b, pid, "run");
        refused(&mmq(&["paper", "--fig", "2", "--quick", "-q", "--out", &dir]), pid, "paper");
        refused(&mmq(&["sweep", "worlds/sweeps/max-delay.toml", "-q", "--out", &dir]), pid, "sweep");
        assert!(a.try_wait().unwrap().is_none(), "run A ended before the others were refused: raise STEPS");
        let o = a.wait_with_output().unwrap();
        assert!(o.status.success(), "{:?}", text(&o));
        let config: toml::Table = std::fs::read_to_string(x.join("config.toml")).unwrap().parse().unwrap();
        assert_eq!(config["seed"].as_integer(), Some(1), "{config}");
        assert_eq!(config["steps"].as_integer(), Some(STEPS.parse().unwrap()), "{config}");
        assert!(config["world"].as_str().is_some_and(|w| w.contains("paper-9x9")), "{config}");
        let s = read_json(&x.join("summary.json"));
        assert_eq!(s["complete"], true, "{s}");
        assert_eq!((s["config"]["seed"].as_u64(), s["world"].as_str()), (Some(1), Some("paper-9x9")));
        let log = mmq_log::read_log(x.join("trajectory-seed1.mcap")).unwrap();
        assert!(log.complete, "{:?}", log.stop);
        assert_eq!(log.decisions.len().to_string(), STEPS);
        assert!(!x.join("trajectory-seed7.mcap").exists() && !x.join(".mmq.lock").exists());
    }

    /// The lock file of a process that has ended (killed, say) is taken over.
    #[test]
    fn a_lock_left_by_an_ended_process_is_taken_over() {
        let d = tempfile::tempdir().unwrap();
        let mut ended = Command::new("true").spawn().unwrap();
        ended.wait().unwrap();
        std::fs::write(d.path().join(".mmq.lock"), format!("{}\n", ended.id())).unwrap();
        let dir = d.path().to_string_lossy().into_owned();
        let o = mmq(&["run", "--world", "paper-3x3", "--steps", "500", "-q", "--out", &dir]);
        assert!(o.status.success(), "{:?}", text(&o));
        assert_eq!(read_json(&d.path().join("summary.json"))["complete"], true);
        assert!(!d.path().join(".mmq.lock").exists());
    }
}

mod large_world {
    use super::*;

    /// An open world of `n` × `n` cells, S and G in opposite corners.
    fn open_world(dir: &Path, n: usize) -> String {
        let mut map = String::new();
        for r in 0..n {
            for c in 0..n {
                map.push(match (r, c) {
                    (0, 0) => 'G',
                    _ if (r, c) == (n - 1, n - 1) => 'S',
                    _ => '.',
                });
            }
            map.push('\n');
        }
        let p = dir.join(format!("open{n}.toml"));
        std::fs::write(&p, format!("name = \"open{n}\"\nstart = \"respawn\"\nmap = \"\"\"\n{map}\"\"\"\n"))
            .unwrap();
        p.to_string_lossy().into_owned()
    }

    /// A short run on a 200 × 200 open world (its summary's ε-soft ceiling took 21 s in
    /// a release build, far longer in this one) writes a summary with the ceiling.
    #[test]
    fn a_short_run_on_a_large_open_world_has_its_summary() {
        let d = tempfile::tempdir().unwrap();
        let world = open_world(d.path(), 200);
        let out = d.path().join("run").to_string_lossy().into_owned();
        let o = mmq(&[
            "run",
            "--world",
            &world,
            "--learner",
            "q",
            "--steps",
            "50",
            "--no-tables",
            "-q",
            "--out",
            &out,
        ]);
        assert!(o.status.success(), "{:?}", text(&o));
        let s = read_json(&Path::new(&out).join("summary.json"));
        assert_eq!(s["complete"], true);
        let (ceiling, optimum) =
            (s["ceiling_per_step"].as_f64().unwrap(), s["optimum_per_step"].as_f64().unwrap());
        assert!(ceiling > 0.95 * optimum && ceiling < optimum, "{ceiling} vs {optimum}");
    }
}
