//! What the commands say on a terminal besides their reports: a sweep's plan and
//! progress lines, what a merge and a sweep report wrote, the learners, the shipped
//! worlds, a world file's check, a live view's and a replay's lines, and progress lines
//! for batch logs. Plain functions
//! from results to text, so that the command line only prints them.

use std::fmt::Write as _;
use std::net::SocketAddr;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use mmq_core::{World, optimum};
use mmq_lab::LabError;
use mmq_lab::output::RunWritten;
use mmq_lab::record::Verdict;
use mmq_lab::sweep::{MergeOutcome, Plan, Shard, SweepOutcome};
use mmq_log::ReadStop;

use crate::ReportError;
use crate::sweep::{SweepReport, plan_size};

/// `mmq sweep --dry-run`: the cells and jobs, the fixed fields, every axis and the seeds.
pub fn sweep_plan(plan: &Plan, shard: Option<Shard>) -> String {
    let mut t = format!("sweep {}: {}\n", plan.name, plan_size(plan, plan.jobs()));
    if let Some(s) = shard {
        let n = (0..plan.jobs()).filter(|&j| s.contains(j)).count();
        let _ = writeln!(t, "shard {s}: {n} jobs");
    }
    for (k, v) in plan.fixed() {
        let _ = writeln!(t, "  {k:<11} = {v}");
    }
    for a in &plan.axes {
        let _ = writeln!(t, "  {a:<11} ∈ {{{}}}", plan.axis_values(a).join(", "));
    }
    let seeds: Vec<String> = plan.seeds.iter().map(u64::to_string).collect();
    let _ = writeln!(t, "  {:<11} ∈ {{{}}}", "seed", seeds.join(", "));
    t.push_str("cells:\n");
    for (i, c) in plan.cells.iter().enumerate() {
        let _ = writeln!(t, "  {} {}", c.id, cell_axes(plan, i));
    }
    t
}

/// A cell's swept values: `learner=mmq delay=poisson:13`.
pub fn cell_axes(plan: &Plan, cell: usize) -> String {
    plan.axes.iter().map(|a| format!("{a}={}", plan.param(cell, a))).collect::<Vec<_>>().join(" ")
}

/// The line before a sweep runs: jobs in all, here, finished, to run, shared baselines.
pub fn sweep_planned(
    plan: &Plan,
    shard: Option<Shard>,
    jobs_total: usize,
    jobs_here: usize,
    done: usize,
    baselines: usize,
) -> String {
    let shard = shard.map_or(String::new(), |s| format!(", shard {s}"));
    format!(
        "sweep {}: {}{shard}: {jobs_here} here, {done} already finished, {} to run ({baselines} shared baselines)",
        plan.name,
        plan_size(plan, jobs_total),
        jobs_here - done,
    )
}

/// The line after a sweep ran, and a second one when it was interrupted.
pub fn sweep_ran(o: &SweepOutcome, sharded: bool, secs: f64) -> (String, Option<String>) {
    let ran = format!(
        "ran {} job(s), skipped {} already finished, {} left; {} rows in {} ({secs:.1} s)",
        o.ran,
        o.skipped,
        o.left,
        o.rows,
        o.results_csv.display()
    );
    let left = (o.left > 0).then(|| {
        format!(
            "interrupted: {} job(s) of this {} unfinished; run the same command again to resume",
            o.left,
            if sharded { "shard" } else { "sweep" }
        )
    });
    (ran, left)
}

/// What `mmq sweep merge` did, and a warning when jobs are missing from every input.
pub fn merged(inputs: usize, m: &MergeOutcome) -> (String, Option<String>) {
    let said = format!(
        "merged {inputs} director{}: {} of {} jobs finished ({} copied); wrote {}",
        if inputs == 1 { "y" } else { "ies" },
        m.done,
        m.jobs_total,
        m.copied,
        m.results_csv.display()
    );
    let missing = (m.done < m.jobs_total).then(|| {
        format!("warning: {} job(s) missing from every input; rerun their shards", m.jobs_total - m.done)
    });
    (said, missing)
}

/// What `mmq sweep report` wrote.
pub fn sweep_reported(r: &SweepReport) -> String {
    format!(
        "sweep {}: {} cells, {} of {} jobs finished; wrote {}, {} and {} figure(s)",
        r.name,
        r.cells,
        r.done,
        r.jobs,
        r.csv.display(),
        r.markdown.display(),
        r.figures,
    )
}

/// `mmq learners`: one learner a line, name first, then what it is.
pub fn learners() -> String {
    mmq_learn::catalogue().into_iter().map(|(_, name, desc)| format!("{name:<16} {desc}\n")).collect()
}

/// The line of a run the stop flag cut short: how many seeds finished, and where.
pub fn run_interrupted(written: &RunWritten, out: &Path) -> String {
    let seeds = written.summary.mean.get("steps").map_or(0, |m| m.n);
    format!("interrupted: wrote the {seeds} finished seed(s) to {}, marked partial", out.display())
}

/// `mmq world list`: every shipped world with its size, optimum and description.
pub fn shipped_worlds() -> Result<String, mmq_core::WorldError> {
    let mut t = String::from("shipped worlds (use the name as --world, or copy the file to change it):\n");
    for (name, text) in mmq_core::shipped::WORLDS {
        let w = World::parse(text, name)?;
        let _ = writeln!(
            t,
            "  {name:<14} {}×{:<3} optimum {:.4}/step  {}",
            w.width,
            w.height,
            optimum(&w).gain,
            w.description
        );
    }
    Ok(t)
}

/// `mmq world check`: the line of a valid world file.
pub fn world_ok(file: &Path, w: &World) -> String {
    format!(
        "ok  {}: {} {}×{}, {} free cells, optimum {:.4} reward/step",
        file.display(),
        w.name,
        w.width,
        w.height,
        w.free_cells().count(),
        optimum(w).gain
    )
}

/// `mmq replay --verify`: the verdict as a line, and whether it is a success (a
/// difference is a failure; an interruption concludes nothing).
pub fn verdict(v: &Verdict) -> (String, bool) {
    match v {
        Verdict::Identical { decisions, poses, steps, truncated } => {
            let held = if *truncated {
                format!("; the file holds only the first {steps} steps of its run, and those were checked")
            } else {
                String::new()
            };
            (
                format!(
                    "verify: OK: the re-run matches the log bit for bit ({decisions} decisions, {poses} poses{held})"
                ),
                true,
            )
        }
        Verdict::Differs(m) => (format!("verify: {m}"), false),
        Verdict::Interrupted { steps } => {
            (format!("verify: interrupted after re-running {steps} steps; nothing concluded"), true)
        }
    }
}

/// The line of `mmq run --live`: where the live view is served and which seed it shows.
pub fn live_view(addr: SocketAddr, seed: u64) -> String {
    format!(
        "live view: ws://{addr} (Foxglove app: Open connection → Foxglove WebSocket); showing seed {seed}"
    )
}

/// The line of `mmq replay --serve`: what is served where, and how to watch it.
pub fn serving(file: &Path, messages: usize, (t0, t1): (u64, u64), addr: SocketAddr) -> String {
    format!(
        "serving {} ({messages} messages, {:.1} s of simulated time) on ws://{addr}: open it in the \
         Foxglove app (Open connection → Foxglove WebSocket), press play; Ctrl-C stops",
        file.display(),
        t1.saturating_sub(t0) as f64 * 1e-9,
    )
}

/// The warning for a recording whose reading stopped early.
pub fn read_stopped(file: &Path, stop: &ReadStop) -> String {
    format!(
        "warning: {}: read stopped at byte {} of {} ({}); recovered {} messages",
        file.display(),
        stop.offset,
        stop.file_len,
        stop.reason,
        stop.messages
    )
}

/// Progress for a batch log (stderr a file or a pipe): a line at most every `every`,
/// with steps done of the total, the rate and the time left; shared between threads.
#[derive(Debug)]
pub struct LineProgress {
    label: String,
    start: Instant,
    every: Duration,
    done: AtomicU64,
    total: u64,
    last: Mutex<Instant>,
}

impl LineProgress {
    /// Progress over `total` steps, saying so at most every `every`.
    pub fn new(label: &str, total: u64, every: Duration) -> Self {
        let now = Instant::now();
        LineProgress {
            label: label.to_string(),
            start: now,
            every,
            done: AtomicU64::new(0),
            total,
            last: Mutex::new(now),
        }
    }

    /// `n` more steps done: the line to print when one is due.
    pub fn inc(&self, n: u64) -> Option<String> {
        let d = self.done.fetch_add(n, Ordering::Relaxed) + n;
        let mut last = self.last.try_lock().ok()?;
        if last.elapsed() < self.every {
            return None;
        }
        *last = Instant::now();
        Some(progress_line(&self.label, d, self.total, self.start.elapsed().as_secs_f64()))
    }

    /// The closing line: how much was done and how fast.
    pub fn finish(&self) -> String {
        let (d, t) = (self.done.load(Ordering::Relaxed), self.total);
        progress_done(&self.label, d, t, self.start.elapsed().as_secs_f64())
    }
}

/// A progress line for a batch log: steps done of the total, the rate and the time left.
fn progress_line(label: &str, done: u64, total: u64, secs: f64) -> String {
    let secs = secs.max(1e-9);
    let rate = done as f64 / secs;
    let left = if total > done && rate > 0.0 {
        format!(", about {} left", duration((total - done) as f64 / rate))
    } else {
        String::new()
    };
    let pct =
        if total > 0 { format!(" ({:.0} %)", 100.0 * done as f64 / total as f64) } else { String::new() };
    format!("{label}: {done} of {total} steps{pct}, {rate:.0} steps/s, {} elapsed{left}", duration(secs))
}

/// The closing progress line for a batch log: how much was done and how fast.
fn progress_done(label: &str, done: u64, total: u64, secs: f64) -> String {
    let secs = secs.max(1e-9);
    format!("{label}: {done} of {total} steps in {}, {:.0} steps/s", duration(secs), done as f64 / secs)
}

/// An error and its causes on one line, each said once (a message that already quotes
/// its cause, as most I/O errors do, is not followed by it again), with control
/// characters escaped so that a name from a file cannot drive the terminal.
pub fn one_line(causes: impl IntoIterator<Item = String>) -> String {
    let mut text = String::new();
    for c in causes {
        if text.contains(&c) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&c);
    }
    text.chars().flat_map(|c| if c.is_control() { c.escape_debug().collect() } else { vec![c] }).collect()
}

/// Whether an error of mmq's libraries is bad input (a world file, a configuration, an
/// impossible parameter) rather than a failure while running or writing: a front end's
/// exit code.
pub fn is_input_error(e: &(dyn std::error::Error + 'static)) -> bool {
    match (e.downcast_ref::<LabError>(), e.downcast_ref::<ReportError>()) {
        (Some(l), _) => l.is_input_error(),
        (_, Some(r)) => r.is_input_error(),
        _ => e.is::<mmq_core::WorldError>(),
    }
}

/// Whether an error of mmq's libraries names run-configuration fields in backticks, which
/// a front end shows as its own names for them (`mmq_lab::fields`).
pub fn names_fields(e: &(dyn std::error::Error + 'static)) -> bool {
    if let Some(l) = e.downcast_ref::<mmq_learn::LearnError>() {
        return LabError::Learner(l.clone()).names_fields();
    }
    e.downcast_ref::<LabError>()
        .map(LabError::names_fields)
        .or(e.downcast_ref::<ReportError>().map(ReportError::names_fields))
        .unwrap_or(false)
}

/// A duration as "1 h 02 min", "3 min 05 s" or "42 s".
pub fn duration(secs: f64) -> String {
    let s = secs.round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, (s % 3600) / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_read_as_one_line_each_cause_once() {
        let causes = ["cannot write a.csv: disk full", "disk full", "bad\x1b[31m name"].map(String::from);
        assert_eq!(one_line(causes), "cannot write a.csv: disk full: bad\\u{1b}[31m name");
    }

    #[test]
    fn errors_are_told_apart_by_kind() {
        let param = LabError::param("alpha", 2, "use a rate in [0, 1]");
        let io = LabError::Io { path: "a.csv".into(), source: std::io::Error::other("disk full") };
        assert!(is_input_error(&param) && names_fields(&param));
        assert!(!is_input_error(&io) && !names_fields(&io));
        let figure = ReportError::UnknownFigure("5".into());
        assert!(is_input_error(&figure) && names_fields(&figure));
        assert!(is_input_error(&ReportError::Lab(param)) && !is_input_error(&ReportError::Lab(io)));
        let world = mmq_core::World::parse("map = \"\"", "w").unwrap_err();
        assert!(is_input_error(&world) && !names_fields(&world));
        let learn = mmq_learn::LearnError::InvalidParam { field: "gamma", value: "1".into(), accepted: "<1" };
        assert!(names_fields(&learn) && !is_input_error(&learn));
        let unknown = mmq_learn::LearnError::UnknownLearner { name: "x".into(), known: "q".into() };
        assert!(!names_fields(&unknown));
        let plain = std::io::Error::other("x");
        assert!(!is_input_error(&plain) && !names_fields(&plain));
    }

    #[test]
    fn durations_read_as_text() {
        assert_eq!(duration(42.4), "42 s");
        assert_eq!(duration(185.0), "3 min 05 s");
        assert_eq!(duration(3720.0), "1 h 02 min");
    }

    #[test]
    fn progress_lines_give_share_rate_and_time_left() {
        // 250 of 1000 steps in 5 s: 50 steps/s, 750 left take 15 s.
        assert_eq!(
            progress_line("sweep", 250, 1000, 5.0),
            "sweep: 250 of 1000 steps (25 %), 50 steps/s, 5 s elapsed, about 15 s left"
        );
        assert_eq!(progress_line("x", 10, 0, 2.0), "x: 10 of 0 steps, 5 steps/s, 2 s elapsed");
        assert_eq!(progress_done("run", 600, 600, 120.0), "run: 600 of 600 steps in 2 min 00 s, 5 steps/s");
        // Lines come no more often than asked, and the last one counts everything.
        let p = LineProgress::new("run", 200, Duration::from_secs(3600));
        assert_eq!((p.inc(40), p.inc(60)), (None, None));
        assert!(p.finish().starts_with("run: 100 of 200 steps in "), "{}", p.finish());
        let p = LineProgress::new("run", 100, Duration::ZERO);
        assert!(p.inc(40).is_some_and(|l| l.starts_with("run: 40 of 100 steps (40 %), ")));
    }

    #[test]
    fn verdicts_say_what_was_checked() {
        let v = Verdict::Identical { decisions: 3, poses: 4, steps: 5, truncated: true };
        let (text, ok) = verdict(&v);
        assert!(
            ok && text.contains("(3 decisions, 4 poses; the file holds only the first 5 steps"),
            "{text}"
        );
        let (text, ok) = verdict(&Verdict::Interrupted { steps: 7 });
        assert!(ok && text.ends_with("after re-running 7 steps; nothing concluded"), "{text}");
    }

    #[test]
    fn live_and_served_lines_say_where_and_what() {
        let addr: SocketAddr = "127.0.0.1:8765".parse().unwrap();
        assert_eq!(
            serving(Path::new("t.mcap"), 12, (1_000_000_000, 3_500_000_000), addr),
            "serving t.mcap (12 messages, 2.5 s of simulated time) on ws://127.0.0.1:8765: open it in the \
             Foxglove app (Open connection → Foxglove WebSocket), press play; Ctrl-C stops"
        );
        assert!(
            live_view(addr, 7).starts_with("live view: ws://127.0.0.1:8765 (")
                && live_view(addr, 7).ends_with("showing seed 7")
        );
        let stop = ReadStop { offset: 10, file_len: 20, messages: 3, reason: "truncated".into() };
        assert_eq!(
            read_stopped(Path::new("t.mcap"), &stop),
            "warning: t.mcap: read stopped at byte 10 of 20 (truncated); recovered 3 messages"
        );
        let names: Vec<String> =
            learners().lines().map(|l| l.split(' ').next().unwrap().to_string()).collect();
        assert_eq!(names, mmq_learn::catalogue().iter().map(|c| c.1).collect::<Vec<_>>());
    }

    #[test]
    fn the_shipped_worlds_are_listed_by_name() {
        let t = shipped_worlds().unwrap();
        assert_eq!(t.lines().count(), 1 + mmq_core::shipped::WORLDS.len());
        assert!(t.contains("  paper-9x9      9×9   optimum 0.5882/step"), "{t}");
    }
}
