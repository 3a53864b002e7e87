//! [`McapRecorder`]: an [`Observer`](mmq_core::Observer) that writes a run to an MCAP file.
//!
//! Time base: every message's `log_time` (and `publish_time`) is simulated time in
//! nanoseconds since the start of the run, never reset. Grid runs have no continuous
//! time: step t starts at t × `step_period_ns` and ends one period later. Robot runs use
//! the environment's simulated clock; a step starts where the previous one ended.
//!
//! What a step writes (when it is inside the recording window):
//! - at the step's start: `/rl/decision`;
//! - during the step: `/robot/pose` + `/tf` for each kept pose sample (robot: the trace,
//!   thinned to `pose_rate_hz`, plus its last sample, the pose at the step's end; grid, or
//!   a step without a trace: one pose at the centre of s_{t+1}, at the step's end) and
//!   `/sim/contact` for each contact change; a robot that controls on an estimate adds,
//!   with each kept pose, its estimate (`/tf` world → robot_estimate,
//!   `/robot/pose_estimate`; the first one with `/viz/robot_estimate`), and
//!   `/robot/fix` for each localisation fix received;
//! - at the step's end: `/rl/reward/emitted` (if a non-zero reward was emitted),
//!   `/rl/reward/delivered` (if anything was delivered), `/rl/teleport` (after an action
//!   in the goal).
//!
//! The static scenes (`/viz/arena`, `/viz/robot`, and `/viz/robot_estimate` with the
//! first estimate) are written once, at the run's start: nothing in them changes during
//! a run, and a viewer keeps a scene entity until it is deleted (Foxglove's player, and
//! `mmq replay --serve`, send a topic's last message before the time it seeks to; the
//! live view sends it to every new subscriber). A recording's size so follows its
//! decisions, not its goals × the map's size.
//!
//! The file is flushed (the open chunk closed and written out) every `flush_every_steps`
//! steps and every `flush_interval` of wall-clock time, so a killed run leaves a readable
//! prefix; [`McapRecorder::finish`] (called by `on_finish`, and by `Drop` as a last
//! resort) writes the summary section that makes the file complete.
//!
//! The recording thread serializes the messages (poses: only their numbers) and hands
//! them over in batches to a writer thread of the recorder's own (see
//! [`RecorderConfig::writer_thread`]), which writes the pose JSON, fills, compresses and
//! writes the chunks; a flush waits for it and `finish` joins it. The file is the same
//! byte for byte with or without that thread.
//!
//! A recorder can also send every message to a live view ([`McapRecorder::with_live`],
//! [`McapRecorder::live_only`]; see [`crate::live`]): the same bytes as the file. A
//! message that goes nowhere (no file, and the live view's thinning holds it back) is
//! not built.
//!
//! The code is split by concern: this file (configuration, output, finishing),
//! `observe.rs` (what each observer hook writes), `scenes.rs` (the scene and grid
//! messages).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use mmq_core::{State, World};
use serde::Serialize;

use crate::error::LogError;
use crate::live::LiveTap;
use crate::mcap_out::{ChunkOptions, McapOut};
use crate::messages::{self as m, CHANNELS, LOG_CHANNEL};
use crate::writer::{Failure, LogWriter};

mod observe;
mod scenes;

pub(crate) use scenes::{arena_scene, robot_radius};

/// Which steps are recorded: the first `first` steps and the last `last` steps of a run
/// of `total` steps (everything else is skipped, except heat maps and the running reward
/// totals, which stay exact). Steps are counted from 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepWindow {
    /// Steps 0..first are recorded.
    pub first: u64,
    /// Steps total−last..total are recorded.
    pub last: u64,
    /// Planned length of the run, in steps.
    pub total: u64,
}

impl StepWindow {
    /// Whether step `t` is recorded.
    pub fn contains(&self, t: u64) -> bool {
        t < self.first || t >= self.total.saturating_sub(self.last)
    }
}

/// How a run is recorded.
#[derive(Clone, Debug, PartialEq)]
pub struct RecorderConfig {
    /// The MCAP file to write (its folder is created if needed).
    pub path: PathBuf,
    /// Robot pose samples kept per second of simulated time (default 10 Hz); 0 keeps
    /// every sample of the trace. Ignored by grid runs (one pose per step).
    pub pose_rate_hz: f64,
    /// Record only some steps (`None`: all).
    pub window: Option<StepWindow>,
    /// Flush the file every this many steps (0: only by time and at the end).
    pub flush_every_steps: u64,
    /// Also flush when this much wall-clock time has passed since the last flush.
    pub flush_interval: Option<Duration>,
    /// Grid runs: nominal duration of one step, nanoseconds of simulated time. `None`
    /// (default) takes the run fact `grid_step_period_s` when the runner gives it, else
    /// 100 ms (Foxglove then plays 10 steps per second at 1×).
    pub step_period_ns: Option<u64>,
    /// Write `/rl/heatmap/*` when the runner offers tables.
    pub heatmaps: bool,
    /// Write short human-readable notes to `/foxglove/log` (start, end, problems).
    pub notes: bool,
    /// zstd level of the chunks (default 1, [`Self::DEFAULT_COMPRESSION_LEVEL`]); negative
    /// levels compress faster into larger files, higher ones slower into smaller files.
    pub compression_level: i32,
    /// Write the pose JSON, compress and write the chunks on a thread of the recorder's
    /// own (default `true`), so the run waits for neither zstd nor the disk; `false` does
    /// it on the recording thread. The file is the same byte for byte either way.
    pub writer_thread: bool,
}

impl RecorderConfig {
    /// Default robot pose rate, Hz of simulated time.
    pub const DEFAULT_POSE_RATE_HZ: f64 = 10.0;
    /// Default grid step period, ns.
    pub const DEFAULT_STEP_PERIOD_NS: u64 = 100_000_000;
    /// Default zstd level: on pose-heavy robot logs level 1 is both faster and smaller
    /// than zstd's own default (3); see `docs/logs.md`, "Cost".
    pub const DEFAULT_COMPRESSION_LEVEL: i32 = 1;

    /// Records everything to `path` with the defaults.
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self {
            path: path.into(),
            pose_rate_hz: Self::DEFAULT_POSE_RATE_HZ,
            window: None,
            flush_every_steps: 10_000,
            flush_interval: Some(Duration::from_secs(5)),
            step_period_ns: None,
            heatmaps: true,
            notes: true,
            compression_level: Self::DEFAULT_COMPRESSION_LEVEL,
            writer_thread: true,
        }
    }

    /// Trace period asked of the environment when every sample is wanted
    /// (`pose_rate_hz` = 0): 1 ms, i.e. every physics step of 1 ms or more.
    pub const FULL_TRACE_PERIOD_S: f64 = 1e-3;

    /// The trace period the recorder asks the environment for (`Telemetry::set_trace`), in
    /// seconds of simulated time: 1 / `pose_rate_hz`, or [`Self::FULL_TRACE_PERIOD_S`]
    /// when `pose_rate_hz` is 0.
    pub fn trace_period_s(&self) -> f64 {
        if self.pose_rate_hz > 0.0 { 1.0 / self.pose_rate_hz } else { Self::FULL_TRACE_PERIOD_S }
    }
}

/// Messages written to one topic.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct TopicStats {
    /// How many.
    pub count: u64,
    /// Digest of every message's `log_time` and bytes (CRC-32 and length), in order;
    /// [`crate::read_log`] computes the same, so equal digests mean the messages
    /// were read back byte for byte.
    /// Computed by the writer as it writes the chunks; in [`McapRecorder::stats`] after
    /// `finish` (as the counts are).
    pub digest: u64,
}

/// What a recorder has written.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct RecordStats {
    /// Per topic (every registered topic, written to or not).
    pub topics: BTreeMap<String, TopicStats>,
    /// Steps the recorder was told about.
    pub steps_seen: u64,
    /// Steps inside the recording window.
    pub steps_recorded: u64,
    /// File size after `finish`, bytes (0 before).
    pub bytes: u64,
    /// `finish` completed.
    pub finished: bool,
}

impl RecordStats {
    /// Total messages written.
    pub fn messages(&self) -> u64 {
        self.topics.values().map(|s| s.count).sum()
    }
}

/// The digest of no message.
pub(crate) const DIGEST_START: u64 = 0xcbf2_9ce4_8422_2325;

/// Folds a message into a running digest: its log time and the CRC-32 and length of its
/// bytes, mixed into 64 bits. (A CRC runs at several bytes per cycle; the byte-at-a-time
/// FNV-1a used before cost as much as writing the message.)
pub(crate) fn digest_message(h: u64, log_time: u64, data: &[u8]) -> u64 {
    const K: u64 = 0x9e37_79b9_7f4a_7c15;
    let m = u64::from(crc32fast::hash(data)) | (data.len() as u64) << 32;
    let x = (h ^ log_time).wrapping_mul(K).rotate_left(29) ^ m;
    let x = x.wrapping_mul(K);
    x ^ (x >> 32)
}

/// Uncompressed size at which a chunk is closed (as the `mcap` crate's default).
const CHUNK_SIZE: usize = 1 << 20;

/// Channel slots: indices into [`CHANNELS`], then the log channel.
#[derive(Clone, Copy, Debug)]
enum Ch {
    Tf = 0,
    Pose,
    Arena,
    Robot,
    Decision,
    Emitted,
    Delivered,
    Teleport,
    Contact,
    Visits,
    Value,
    PoseEstimate,
    Fix,
    RobotEstimate,
    Log,
}

const NCH: usize = CHANNELS.len() + 1;

fn channel_def(i: usize) -> (&'static str, &'static str, &'static str) {
    if i < CHANNELS.len() { CHANNELS[i] } else { LOG_CHANNEL }
}

/// Seconds → nanoseconds (negative and non-finite times become 0).
fn ns(s: f64) -> u64 {
    if s.is_finite() && s > 0.0 { (s * 1e9).round() as u64 } else { 0 }
}

/// Per-run state, set by `on_start`.
#[derive(Debug)]
struct Run {
    world: World,
    grid: bool,
    action_names: Vec<String>,
    /// Serialized `/viz/arena` and `/viz/robot` messages (written once).
    arena_json: Vec<u8>,
    robot_json: Vec<u8>,
    /// Serialized `/viz/robot_estimate` (written once, with the first estimate).
    estimate_json: Vec<u8>,
    /// A pose estimate has been written (the estimate's scene is then written with the
    /// others).
    estimates_seen: bool,
}

/// Writes a run to an MCAP file; see the module documentation for what and when.
///
/// Errors while recording never stop the run: the first one is kept (see
/// [`McapRecorder::take_error`]) and recording stops there.
pub struct McapRecorder {
    config: RecorderConfig,
    writer: Option<LogWriter<BufWriter<File>>>,
    channel_ids: [u16; NCH],
    /// Messages written per channel slot, and their digest as last taken from the writer.
    topics: [TopicStats; NCH],
    stats: RecordStats,
    error: Option<LogError>,
    run: Option<Run>,
    /// Simulated time at the start of the current step, s (robot).
    step_start_s: f64,
    /// Added to the environment's clock if it ever goes back (keeps time monotonic).
    time_offset_s: f64,
    /// Next pose sample time to keep, s (robot thinning).
    next_pose_s: f64,
    /// Grid heading of the last pose, radians.
    heading: f64,
    /// Grid step period in use, ns.
    period_ns: u64,
    emitted_total: f64,
    delivered_total: f64,
    next_emission_id: u64,
    prev_recorded: bool,
    last_flush_step: u64,
    last_flush: Instant,
    outcome: OutcomeHandle,
    /// Writes to a file (false: live view only).
    file: bool,
    /// The live view the messages also go to.
    live: Option<LiveTap>,
    /// The last pose sample went live (its estimate follows it).
    live_pose: bool,
}

/// How a recording ended, as seen through an [`OutcomeHandle`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RecordOutcome {
    /// What was written (set by `finish`).
    pub stats: Option<RecordStats>,
    /// The first error met while recording, as text (the file is named in it).
    pub error: Option<String>,
}

/// Shared view of a recorder's [`RecordOutcome`]; see [`McapRecorder::outcome_handle`].
pub type OutcomeHandle = Arc<Mutex<RecordOutcome>>;

impl std::fmt::Debug for McapRecorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("McapRecorder")
            .field("config", &self.config)
            .field("open", &self.writer.is_some())
            .field("stats", &self.stats)
            .field("error", &self.error)
            .finish_non_exhaustive()
    }
}

impl McapRecorder {
    /// Creates the file, writes the MCAP header and registers every channel.
    pub fn create(config: RecorderConfig) -> Result<Self, LogError> {
        let path = config.path.clone();
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| LogError::Io {
                path: path.clone(),
                action: "create the log's folder",
                source,
            })?;
        }
        let file = File::create(&path).map_err(|source| LogError::Io {
            path: path.clone(),
            action: "create the log",
            source,
        })?;
        let mcap_err = |action, e: std::io::Error| LogError::Mcap {
            path: path.clone(),
            action,
            source: mcap::McapError::Io(e),
        };
        let library =
            format!("mmq-log/{} (MCAP records as {})", env!("CARGO_PKG_VERSION"), mcap::LIBRARY_IDENTIFIER);
        let mut writer = McapOut::new(
            BufWriter::with_capacity(1 << 16, file),
            &library,
            ChunkOptions { level: config.compression_level },
        )
        .map_err(|e| mcap_err("write the MCAP header", e))?;
        let mut channel_ids = [0u16; NCH];
        let mut stats = RecordStats::default();
        for (i, id) in channel_ids.iter_mut().enumerate() {
            let (topic, schema, text) = channel_def(i);
            if i == Ch::Log as usize && !config.notes {
                continue;
            }
            let sid = writer
                .add_schema(schema, "jsonschema", text.as_bytes())
                .map_err(|e| mcap_err("register a schema", e))?;
            *id = writer.add_channel(sid, topic, "json").map_err(|e| mcap_err("register a channel", e))?;
            stats.topics.insert(topic.to_string(), TopicStats { count: 0, digest: DIGEST_START });
        }
        let writer = LogWriter::new(writer, CHUNK_SIZE, config.writer_thread)
            .map_err(|e| mcap_err("start the log writer thread", e))?;
        Ok(Self::with_output(config, Some(writer), channel_ids, stats))
    }

    fn with_output(
        config: RecorderConfig,
        writer: Option<LogWriter<BufWriter<File>>>,
        channel_ids: [u16; NCH],
        stats: RecordStats,
    ) -> Self {
        Self {
            config,
            file: writer.is_some(),
            writer,
            channel_ids,
            topics: [TopicStats { count: 0, digest: DIGEST_START }; NCH],
            stats,
            error: None,
            run: None,
            step_start_s: 0.0,
            time_offset_s: 0.0,
            next_pose_s: 0.0,
            heading: 0.0,
            period_ns: RecorderConfig::DEFAULT_STEP_PERIOD_NS,
            emitted_total: 0.0,
            delivered_total: 0.0,
            next_emission_id: 0,
            prev_recorded: true,
            last_flush_step: 0,
            last_flush: Instant::now(),
            outcome: OutcomeHandle::default(),
            live: None,
            live_pose: false,
        }
    }

    /// A recorder that writes no file and shows the run in a live view only (`config`'s
    /// path is not used). While no client is connected it writes nothing but the latched
    /// scenes and heat maps, and its step gate ([`mmq_core::Observer::step_gate`]) is
    /// closed: the runner skips its steps, so the run is not slowed; when a client
    /// connects it picks up the running totals from the runner
    /// ([`mmq_core::Observer::on_resume`]). With a client, a message is built only when
    /// the live view's thinning lets it through.
    pub fn live_only(config: RecorderConfig, live: LiveTap) -> Self {
        let mut stats = RecordStats::default();
        for i in 0..NCH {
            if i == Ch::Log as usize && !config.notes {
                continue;
            }
            stats.topics.insert(channel_def(i).0.to_string(), TopicStats { count: 0, digest: DIGEST_START });
        }
        let mut r = Self::with_output(config, None, [0; NCH], stats);
        r.live = Some(live);
        r
    }

    /// Also shows the run in a live view, with the same messages as the file.
    pub fn with_live(mut self, live: LiveTap) -> Self {
        self.live = Some(live);
        self
    }

    /// Whether a step's messages are wanted: always with a file, else while a live
    /// client is connected.
    fn active(&self) -> bool {
        self.file || self.live.as_ref().is_some_and(LiveTap::has_clients)
    }

    /// The configuration.
    pub fn config(&self) -> &RecorderConfig {
        &self.config
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.config.path
    }

    /// What has been written so far: steps as they come; per-topic counts and digests
    /// once `finish` has run.
    pub fn stats(&self) -> &RecordStats {
        &self.stats
    }

    /// The first error met while recording, if any (recording stopped there).
    pub fn take_error(&mut self) -> Option<LogError> {
        self.error.take()
    }

    fn fail(&mut self, Failure { action, source }: Failure) {
        if self.error.is_none() {
            self.error = Some(LogError::Mcap {
                path: self.config.path.clone(),
                action,
                source: mcap::McapError::Io(source),
            });
        }
        // A failed writer refuses further writes; what it wrote before stays readable.
        self.writer = None;
    }

    /// Where a message on `ch` goes now: `Some(live)` when it goes anywhere (to the
    /// file if there is one, and to the live view when `live`: its thinning then counts
    /// it as sent, so emit it next), `None` when nowhere (then it need not be built).
    fn route(&mut self, ch: Ch) -> Option<bool> {
        let i = ch as usize;
        // The estimate's `/tf` and pose go live with their pose sample, or not at all.
        let live_ok = !matches!(ch, Ch::Tf | Ch::PoseEstimate) || self.live_pose;
        let live = live_ok && self.live.as_mut().is_some_and(|l| l.wants(i));
        (live || self.writer.is_some()).then_some(live)
    }

    /// Writes one message routed by [`Self::route`], whose bytes `write` appends.
    fn emit_routed(&mut self, ch: Ch, live: bool, log_time: u64, write: impl FnOnce(&mut Vec<u8>)) {
        let i = ch as usize;
        if live && let Some(tap) = self.live.as_mut() {
            let bytes = tap.send(i, log_time, write);
            let r = match self.writer.as_mut() {
                Some(w) => w.message(self.channel_ids[i], log_time, |out| out.extend_from_slice(bytes)),
                None if self.file => return,
                None => Ok(()),
            };
            match r {
                Ok(()) => self.topics[i].count += 1,
                Err(e) => self.fail(e),
            }
            return;
        }
        let Some(w) = self.writer.as_mut() else { return };
        if let Err(e) = w.message(self.channel_ids[i], log_time, write) {
            self.fail(e);
            return;
        }
        self.topics[i].count += 1;
    }

    fn write<T: Serialize>(&mut self, ch: Ch, log_time: u64, msg: &T) {
        if let Some(live) = self.route(ch) {
            // Serializing our own plain structs into a Vec cannot fail.
            self.emit_routed(ch, live, log_time, |out| {
                serde_json::to_writer(out, msg).expect("JSON serialization of a log message")
            });
        }
    }

    /// Writes the message `build` makes, building it only if it goes anywhere (a live
    /// view thins what it sends; the file keeps every message).
    fn write_with<T: Serialize>(&mut self, ch: Ch, log_time: u64, build: impl FnOnce(&Self) -> T) {
        if let Some(live) = self.route(ch) {
            let msg = build(self);
            self.emit_routed(ch, live, log_time, |out| {
                serde_json::to_writer(out, &msg).expect("JSON serialization of a log message")
            });
        }
    }

    /// Writes a scene: bytes serialized once (the live view keeps them for new subscribers).
    fn write_bytes(&mut self, ch: Ch, log_time: u64, bytes: &[u8]) {
        let i = ch as usize;
        if let Some(live) = self.live.as_mut() {
            live.send_unchanged(i, log_time, bytes);
            if !self.file {
                self.topics[i].count += 1;
                return;
            }
        }
        let Some(w) = self.writer.as_mut() else { return };
        match w.message(self.channel_ids[i], log_time, |out| out.extend_from_slice(bytes)) {
            Ok(()) => self.topics[i].count += 1,
            Err(e) => self.fail(e),
        }
    }

    /// Takes the per-topic digests from the writer (which computes them as it writes the
    /// chunks): complete after `finish`, else as of the last flush.
    fn take_digests(&mut self, by_channel: &[u64]) {
        for (t, &id) in self.topics.iter_mut().zip(&self.channel_ids) {
            if let Some(&d) = by_channel.get(usize::from(id)).filter(|_| id > 0) {
                t.digest = d;
            }
        }
    }

    fn note(&mut self, log_time: u64, level: u8, message: String) {
        if self.config.notes {
            let msg = m::Log {
                timestamp: m::Time::from_ns(log_time),
                level,
                message,
                name: "mmq".into(),
                file: String::new(),
                line: 0,
            };
            self.write(Ch::Log, log_time, &msg);
        }
    }

    /// `/tf` and `/robot/pose` at one pose. The writer writes the JSON (by hand, byte for
    /// byte as serde_json writes [`m::FrameTransform`] and [`m::PoseInFrame`]).
    fn write_pose(&mut self, log_time: u64, x: f64, y: f64, theta: f64) {
        let (tf, pose) = (Ch::Tf as usize, Ch::Pose as usize);
        if let Some(live) = self.live.as_mut() {
            self.live_pose = live.pose_due(log_time);
            if self.live_pose {
                live.pose(tf, pose, log_time, x, y, theta);
            }
            if !self.file {
                self.topics[tf].count += 1;
                self.topics[pose].count += 1;
                return;
            }
        }
        let Some(w) = self.writer.as_mut() else { return };
        if let Err(e) = w.pose(self.channel_ids[tf], self.channel_ids[pose], log_time, x, y, theta) {
            self.fail(e);
            return;
        }
        self.topics[tf].count += 1;
        self.topics[pose].count += 1;
    }

    fn write_cell_pose(&mut self, log_time: u64, state: State) {
        let Some(run) = &self.run else { return };
        if state < run.world.num_cells() {
            let (x, y) = run.world.cell_center(state);
            self.write_pose(log_time, x, y, self.heading);
        }
    }

    fn write_scenes(&mut self, log_time: u64) {
        let Some(run) = self.run.take() else { return };
        self.write_bytes(Ch::Arena, log_time, &run.arena_json);
        self.write_bytes(Ch::Robot, log_time, &run.robot_json);
        if run.estimates_seen {
            self.write_bytes(Ch::RobotEstimate, log_time, &run.estimate_json);
        }
        self.run = Some(run);
    }

    fn maybe_flush(&mut self) {
        if self.writer.is_none() {
            return;
        }
        let steps = self.stats.steps_seen;
        let by_steps = self.config.flush_every_steps > 0
            && steps - self.last_flush_step >= self.config.flush_every_steps;
        // Looking at the clock every 64 steps keeps its cost out of the step loop.
        let by_time = steps.is_multiple_of(64)
            && self.config.flush_interval.is_some_and(|d| self.last_flush.elapsed() >= d);
        if by_steps || by_time {
            self.flush();
        }
    }

    /// Closes the open chunk and writes everything buffered to the file.
    pub fn flush(&mut self) {
        self.last_flush_step = self.stats.steps_seen;
        self.last_flush = Instant::now();
        let Some(w) = self.writer.as_mut() else { return };
        match w.flush() {
            Ok(()) => {
                let digests = w.digests().to_vec();
                self.take_digests(&digests);
            }
            Err(e) => self.fail(e),
        }
    }

    fn sync_stats(&mut self) {
        for (i, d) in self.topics.iter().enumerate() {
            if i == Ch::Log as usize && !self.config.notes {
                continue;
            }
            self.stats.topics.insert(channel_def(i).0.to_string(), *d);
        }
    }

    /// Finishes the file: an "end" metadata record (steps `t`, whether the run was
    /// `complete`, reward totals), then the summary section. Later calls do nothing.
    /// Returns what was written, or the first error met while recording.
    pub fn finish(&mut self, t: u64, complete: bool) -> Result<RecordStats, LogError> {
        let end_time = self.end_time_ns();
        let live_open = !self.file && self.live.is_some() && !self.stats.finished;
        if self.writer.is_some() || live_open {
            self.note(
                end_time,
                if complete { m::LOG_INFO } else { m::LOG_WARNING },
                format!(
                    "run {} after {t} steps: emitted {}, delivered {}",
                    if complete { "finished" } else { "interrupted" },
                    self.emitted_total,
                    self.delivered_total
                ),
            );
        }
        if let Some(mut w) = self.writer.take() {
            let end: BTreeMap<String, String> = [
                ("steps", t.to_string()),
                ("complete", complete.to_string()),
                ("steps_seen", self.stats.steps_seen.to_string()),
                ("steps_recorded", self.stats.steps_recorded.to_string()),
                ("emitted_total", self.emitted_total.to_string()),
                ("delivered_total", self.delivered_total.to_string()),
                ("end_time_ns", end_time.to_string()),
            ]
            .into_iter()
            .map(|(k, v)| (k.to_string(), v))
            .collect();
            let path = self.config.path.clone();
            let mcap_err = |Failure { action, source }| LogError::Mcap {
                path: path.clone(),
                action,
                source: mcap::McapError::Io(source),
            };
            let finished = w.metadata("end", &end).and_then(|()| w.finish()).map_err(mcap_err);
            let result = finished.and_then(|(mut inner, digests)| {
                self.take_digests(&digests);
                inner.flush().map_err(|source| LogError::Io {
                    path: path.clone(),
                    action: "write the log",
                    source,
                })?;
                inner.get_ref().metadata().map(|m| m.len()).map_err(|source| LogError::Io {
                    path: path.clone(),
                    action: "measure the log",
                    source,
                })
            });
            match result {
                Ok(bytes) => {
                    self.stats.bytes = bytes;
                    self.stats.finished = true;
                }
                Err(e) => {
                    if self.error.is_none() {
                        self.error = Some(e);
                    }
                }
            }
        }
        if live_open {
            self.stats.finished = true;
        }
        self.sync_stats();
        let result = match self.error.take() {
            Some(e) => Err(e),
            None => Ok(self.stats.clone()),
        };
        if let Ok(mut o) = self.outcome.lock() {
            o.stats = Some(self.stats.clone());
            if let Err(e) = &result {
                o.error.get_or_insert_with(|| e.to_string());
            }
        }
        result
    }

    /// A handle that receives the outcome when the recorder finishes, for owners that
    /// only keep the recorder as a `Box<dyn Observer>`.
    pub fn outcome_handle(&self) -> OutcomeHandle {
        Arc::clone(&self.outcome)
    }

    fn end_time_ns(&self) -> u64 {
        match &self.run {
            Some(r) if r.grid => self.stats.steps_seen * self.period_ns,
            _ => ns(self.step_start_s),
        }
    }
}

impl Drop for McapRecorder {
    fn drop(&mut self) {
        if self.writer.is_some() {
            let _ = self.finish(self.stats.steps_seen, false);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_keep_the_first_and_last_steps() {
        let w = StepWindow { first: 3, last: 2, total: 10 };
        let kept: Vec<u64> = (0..12).filter(|&t| w.contains(t)).collect();
        assert_eq!(kept, vec![0, 1, 2, 8, 9, 10, 11]);
        // Overlapping windows keep everything; empty ones nothing before the end.
        let all = StepWindow { first: 6, last: 6, total: 10 };
        assert!((0..10).all(|t| all.contains(t)));
        let none = StepWindow { first: 0, last: 0, total: 10 };
        assert!((0..10).all(|t| !none.contains(t)));
    }

    #[test]
    fn recorder_can_move_to_another_thread() {
        fn send<T: Send>() {}
        send::<McapRecorder>();
    }

    #[test]
    fn trace_period_follows_the_pose_rate() {
        let mut c = RecorderConfig::new("x.mcap");
        assert_eq!(c.trace_period_s(), 0.1);
        c.pose_rate_hz = 0.0;
        assert_eq!(c.trace_period_s(), RecorderConfig::FULL_TRACE_PERIOD_S);
    }

    #[test]
    fn digests_see_every_byte_time_and_order() {
        let d = |msgs: &[(u64, &[u8])]| msgs.iter().fold(DIGEST_START, |h, (t, b)| digest_message(h, *t, b));
        let base = d(&[(1, b"ab"), (2, b"cd")]);
        assert_ne!(base, d(&[(1, b"ab"), (2, b"ce")]));
        assert_ne!(base, d(&[(1, b"ab"), (3, b"cd")]));
        assert_ne!(base, d(&[(2, b"cd"), (1, b"ab")]));
        assert_ne!(base, d(&[(1, b"ab"), (2, b"cd"), (2, b"")]));
        assert_eq!(base, d(&[(1, b"ab"), (2, b"cd")]));
    }
}
