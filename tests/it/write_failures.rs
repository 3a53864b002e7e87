//! Writes that fail, with real faults rather than mocks: a file-size limit (`ulimit -f`
//! with SIGXFSZ ignored, so writes fail with EFBIG instead of killing the process) and a
//! full file system (a small tmpfs, mounted when the tests run as root; skipped with a
//! printed reason otherwise). Every such run must exit 1 with one message naming the file
//! and the operating system's reason once, and must never leave a summary saying
//! "complete", a cut figure or a temporary file behind. And a run killed (SIGKILL) while
//! it writes its outputs leaves only whole files, no summary claiming them, and a folder
//! that the next run into it cleans.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::common::*;

/// Runs `mmq ARGS` under `sh` with a file-size limit of `kib` KiB and SIGXFSZ ignored.
fn mmq_with_size_limit(kib: u64, args: &[&str]) -> Output {
    let script = format!("trap '' XFSZ; ulimit -f {kib}; exec \"$0\" \"$@\"");
    Command::new("sh")
        .arg("-c")
        .arg(script)
        .arg(env!("CARGO_BIN_EXE_mmq"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("sh starts")
}

/// The exit code, and stderr as text.
fn code_and_err(o: &Output) -> (Option<i32>, String) {
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// The summary of `dir` never says complete; returns whether it exists.
fn summary_not_complete(dir: &Path) -> bool {
    let path = dir.join("summary.json");
    let Ok(text) = std::fs::read_to_string(&path) else { return false };
    let v: serde_json::Value = serde_json::from_str(&text).expect("a summary, if written, is whole JSON");
    assert_eq!(v["complete"], false, "{}: says complete after a failed write", path.display());
    true
}

/// No temporary file (`.NAME.tmpPID`) is left in `dir`.
fn no_temporaries(dir: &Path) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        assert!(!name.contains(".tmp"), "{name} left behind in {}", dir.display());
    }
}

/// Every PNG in `dir` is whole: it ends with the IEND chunk.
fn pngs_whole(dir: &Path) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.extension().is_some_and(|x| x == "png") {
            let bytes = std::fs::read(&p).unwrap();
            assert!(
                bytes.len() >= 12 && &bytes[bytes.len() - 8..bytes.len() - 4] == b"IEND",
                "{} is cut",
                p.display()
            );
        }
    }
}

#[test]
fn a_recording_cut_by_a_file_size_limit_fails_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = mmq_with_size_limit(
        400,
        &[
            "run",
            "--world",
            "paper-9x9",
            "--steps",
            "30000",
            "--record",
            "-q",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    let (code, err) = code_and_err(&o);
    assert_eq!(code, Some(1), "exit code; stderr: {err}");
    assert!(err.contains("trajectory-seed0.mcap"), "the file is named: {err}");
    assert_eq!(err.matches("os error 27").count(), 1, "the OS error, once: {err}");
    assert_eq!(err.lines().filter(|l| l.starts_with("error:")).count(), 1, "one message: {err}");
    if summary_not_complete(&out) {
        let s: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
        let seed_error = s["seeds"][0]["error"].as_str().unwrap_or_default();
        assert!(seed_error.contains("trajectory-seed0.mcap"), "the seed says why: {s}");
    }
    no_temporaries(&out);
}

/// The swarm's recording, cut the same way, fails its seed the same way.
#[test]
fn a_swarms_recording_cut_by_a_file_size_limit_fails_the_run() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = mmq_with_size_limit(
        400,
        &[
            "run",
            "--env",
            "swarm",
            "--swarm",
            "robots=3",
            "--steps",
            "3000",
            "--no-baseline",
            "--record",
            "-q",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    let (code, err) = code_and_err(&o);
    assert_eq!(code, Some(1), "exit code; stderr: {err}");
    assert!(err.contains("trajectory-seed0.mcap"), "the file is named: {err}");
    assert_eq!(err.lines().filter(|l| l.starts_with("error:")).count(), 1, "one message: {err}");
    summary_not_complete(&out);
    no_temporaries(&out);
}

#[test]
fn outputs_cut_by_a_file_size_limit_fail_the_run() {
    // 100 KiB: the config and the CSVs fit, the 9×9 MMQ Q-table (129 KiB) does not.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let o = mmq_with_size_limit(
        100,
        &["run", "--world", "paper-9x9", "--steps", "3000", "-q", "--out", out.to_str().unwrap()],
    );
    let (code, err) = code_and_err(&o);
    assert_eq!(code, Some(1), "exit code; stderr: {err}");
    assert!(err.contains("q_seed0.npy") && err.matches("os error 27").count() == 1, "{err}");
    assert!(!out.join("summary.json").exists(), "no summary after a lost Q-table");
    no_temporaries(&out);
}

/// A tmpfs of `kib` KiB mounted for the test's life, or why not.
struct SmallDisk {
    path: PathBuf,
    _dir: tempfile::TempDir,
}

impl SmallDisk {
    fn mount(kib: u64) -> Result<Self, String> {
        let dir = tempfile::tempdir().map_err(|e| e.to_string())?;
        let path = dir.path().join("disk");
        std::fs::create_dir(&path).map_err(|e| e.to_string())?;
        let o = Command::new("mount")
            .args(["-t", "tmpfs", "-o", &format!("size={kib}k"), "tmpfs"])
            .arg(&path)
            .output()
            .map_err(|e| format!("mount does not run: {e}"))?;
        if !o.status.success() {
            return Err(format!(
                "cannot mount a tmpfs (needs root): {}",
                String::from_utf8_lossy(&o.stderr).trim()
            ));
        }
        Ok(Self { path, _dir: dir })
    }
}

impl Drop for SmallDisk {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.path).status();
    }
}

#[test]
fn a_full_disk_fails_runs_and_reports_with_nothing_half_written() {
    let disk = match SmallDisk::mount(300) {
        Ok(d) => d,
        Err(why) => {
            eprintln!("skipped: {why}");
            return;
        }
    };
    // A run with four seeds: the second Q-table does not fit.
    let run = disk.path.join("run");
    let o = mmq(&[
        "run",
        "--world",
        "paper-9x9",
        "--steps",
        "3000",
        "--seeds",
        "4",
        "-q",
        "--out",
        run.to_str().unwrap(),
    ]);
    let (code, err) = code_and_err(&o);
    assert_eq!(code, Some(1), "run exit code; stderr: {err}");
    assert!(
        err.contains(&disk.path.display().to_string()) && err.matches("os error 28").count() == 1,
        "{err}"
    );
    summary_not_complete(&run);
    no_temporaries(&run);
    std::fs::remove_dir_all(&run).unwrap();
    // A report: its figures fill the disk; none is left cut.
    let report = disk.path.join("report");
    let o = mmq(&["paper", "--quick", "--fig", "6", "-q", "--out", report.to_str().unwrap()]);
    let (code, err) = code_and_err(&o);
    assert_eq!(code, Some(1), "paper exit code; stderr: {err}");
    assert_eq!(err.matches("os error 28").count(), 1, "{err}");
    assert!(!report.join("report.md").exists(), "no report after a lost figure");
    pngs_whole(&report);
    no_temporaries(&report);
}

/// Whether a `.npy` file is whole: its header's shape accounts for every byte after it.
fn npy_whole(p: &Path) -> bool {
    let b = std::fs::read(p).unwrap();
    if b.len() < 10 || &b[..6] != b"\x93NUMPY" {
        return false;
    }
    let (len_at, len_size) = if b[6] == 1 { (8, 2) } else { (8, 4) };
    let mut n = [0u8; 4];
    n[..len_size].copy_from_slice(&b[len_at..len_at + len_size]);
    let start = len_at + len_size + u32::from_le_bytes(n) as usize;
    let Some(header) = b.get(len_at + len_size..start).map(String::from_utf8_lossy) else { return false };
    let shape = header.split("'shape': (").nth(1).and_then(|r| r.split(')').next()).unwrap_or_default();
    let cells: usize = shape.split(',').filter_map(|d| d.trim().parse::<usize>().ok()).product();
    header.contains("'<f8'") && b.len() == start + 8 * cells
}

/// The files in `dir` that are not temporary (`.NAME.tmpPID`) are whole.
fn outputs_whole(dir: &Path) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let (p, name) = (e.path(), e.file_name().to_string_lossy().into_owned());
        if name.starts_with('.') && name.contains(".tmp") {
            continue;
        }
        if name.ends_with(".npy") {
            assert!(npy_whole(&p), "{name} is cut");
        } else if name.ends_with(".csv") || name.ends_with(".toml") {
            let text = std::fs::read_to_string(&p).unwrap();
            assert!(text.ends_with('\n'), "{name} is cut");
        }
    }
}

/// Starts `mmq run` with 16 seeds of MMQ on the 50×50 room (its 16 Q-tables of 4 MB each
/// take a while to write), waits until the first output after `config.toml` appears, then
/// SIGKILLs it. Returns whether the kill came before the run ended.
fn kill_during_final_writes(out: &Path) -> bool {
    let mut child = Command::new(env!("CARGO_BIN_EXE_mmq"))
        .args(["run", "--world", "open-50x50", "--learner", "mmq", "--steps", "2000", "--seeds", "16"])
        .args(["--no-baseline", "-q", "--out", out.to_str().unwrap()])
        .current_dir(root())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("mmq starts");
    let begun = Instant::now();
    let writing = || {
        std::fs::read_dir(out).into_iter().flatten().flatten().any(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name != "config.toml" && !name.starts_with(".config.toml")
        })
    };
    while !writing() && begun.elapsed() < Duration::from_secs(300) {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    let killed = child.try_wait().unwrap().is_none();
    let _ = child.kill();
    let status = child.wait().unwrap();
    killed && status.code().is_none()
}

#[test]
fn a_run_killed_during_its_final_writes_leaves_whole_files_and_no_false_summary() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    // The final writes take seconds (16 × 4 MB, each synced to disk); a kill lands in them
    // at the first try on this machine. Three tries keep the test honest on a faster disk.
    let mut caught = false;
    for _ in 0..3 {
        let _ = std::fs::remove_dir_all(&out);
        caught = kill_during_final_writes(&out);
        outputs_whole(&out);
        if let Ok(text) = std::fs::read_to_string(out.join("summary.json")) {
            // Only a kill after the summary's rename leaves one: then it speaks for all.
            let v: serde_json::Value = serde_json::from_str(&text).expect("a summary is whole JSON");
            assert_eq!(v["complete"], true, "a summary is written last, for a complete run");
            for s in 0..16 {
                assert!(npy_whole(&out.join(format!("q_seed{s}.npy"))), "summary without q_seed{s}.npy");
            }
        }
        if caught {
            break;
        }
    }
    assert!(caught, "no kill landed during the final writes in three tries");
    // The next run into the folder removes the killed run's files and temporaries.
    let o = mmq(&[
        "run",
        "--world",
        "paper-9x9",
        "--steps",
        "500",
        "--seeds",
        "2",
        "-q",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (code, err) = code_and_err(&o);
    assert_eq!(code, Some(0), "the next run; stderr: {err}");
    no_temporaries(&out);
    assert!(!out.join("q_seed15.npy").exists(), "the killed run's Q-tables are removed");
    assert_eq!(read_json(&out.join("summary.json"))["complete"], true);
    outputs_whole(&out);
}
