//! [`McapRecorder`]: an [`Observer`] that writes a run to an MCAP file.
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
//!   `/sim/contact` for each contact change;
//! - at the step's end: `/rl/reward/emitted` (if a non-zero reward was emitted),
//!   `/rl/reward/delivered` (if anything was delivered), `/rl/teleport` and a fresh
//!   `/viz/arena` + `/viz/robot` (after an action in the goal).
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

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use base64::Engine;
use mmq_core::{Event, Move, Observer, RunInfo, State, StepRecord, World};
use serde::Serialize;

use crate::error::LogError;
use crate::mcap_out::{ChunkOptions, McapOut};
use crate::messages::{self as m, CHANNELS, LOG_CHANNEL};
use crate::writer::{Failure, LogWriter};

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

    /// The trace period the recorder asks the environment for (`Env::set_trace`), in
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

/// Heading of a grid move: E 0, N π/2, W π, S −π/2.
fn move_heading(a: usize) -> Option<f64> {
    use std::f64::consts::{FRAC_PI_2, PI};
    Move::from_index(a).map(|m| match m {
        Move::E => 0.0,
        Move::N => FRAC_PI_2,
        Move::W => PI,
        Move::S => -FRAC_PI_2,
    })
}

/// Per-run state, set by `on_start`.
#[derive(Debug)]
struct Run {
    world: World,
    grid: bool,
    action_names: Vec<String>,
    /// Serialized `/viz/arena` and `/viz/robot` messages (republished unchanged).
    arena_json: Vec<u8>,
    robot_json: Vec<u8>,
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
        Ok(Self {
            config,
            writer: Some(writer),
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
        })
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

    /// Writes one message, whose bytes `write` appends.
    fn emit(&mut self, ch: Ch, log_time: u64, write: impl FnOnce(&mut Vec<u8>)) {
        let Some(w) = self.writer.as_mut() else { return };
        let i = ch as usize;
        if let Err(e) = w.message(self.channel_ids[i], log_time, write) {
            self.fail(e);
            return;
        }
        self.topics[i].count += 1;
    }

    fn write<T: Serialize>(&mut self, ch: Ch, log_time: u64, msg: &T) {
        // Serializing our own plain structs into a Vec cannot fail.
        self.emit(ch, log_time, |out| {
            serde_json::to_writer(out, msg).expect("JSON serialization of a log message")
        });
    }

    fn write_bytes(&mut self, ch: Ch, log_time: u64, bytes: &[u8]) {
        self.emit(ch, log_time, |out| out.extend_from_slice(bytes));
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
        let Some(w) = self.writer.as_mut() else { return };
        let (tf, pose) = (Ch::Tf as usize, Ch::Pose as usize);
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
        self.run = Some(run);
    }

    fn maybe_flush(&mut self) {
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
        if self.writer.is_some() {
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

fn robot_radius(info: &RunInfo<'_>) -> f64 {
    let from_facts = info
        .facts
        .iter()
        .find(|(k, _)| matches!(k.as_str(), "robot.radius_m" | "robot_radius_m" | "radius_m"))
        .and_then(|(_, v)| v.parse::<f64>().ok());
    let from_world = info
        .world
        .robot
        .as_ref()
        .and_then(|t| t.get("radius_m"))
        .and_then(|v| v.as_float().or_else(|| v.as_integer().map(|i| i as f64)));
    from_facts.or(from_world).filter(|r| r.is_finite() && *r > 0.0).unwrap_or(0.3 * info.world.cell_size)
}

/// `/viz/arena`: floor, boundary walls, blocked cells, goal and respawn, cell lines.
pub(crate) fn arena_scene(world: &World, timestamp: m::Time) -> m::SceneUpdate {
    let cs = world.cell_size;
    let (w, h) = (world.width as f64 * cs, world.height as f64 * cs);
    let wall_h = 0.5 * cs;
    let th = 0.1 * cs;
    let wall = m::Color::rgba(0.35, 0.35, 0.4, 1.0);
    let mut e = m::SceneEntity::new(timestamp, "world", "arena");
    let cube = |x: f64, y: f64, z: f64, sx: f64, sy: f64, sz: f64, color: m::Color| m::CubePrimitive {
        pose: m::Pose::planar(x, y, z, 0.0),
        size: m::Vector3 { x: sx, y: sy, z: sz },
        color,
    };
    e.cubes.push(cube(w / 2.0, h / 2.0, -0.005, w, h, 0.01, m::Color::rgba(0.93, 0.93, 0.9, 1.0)));
    e.cubes.push(cube(w / 2.0, h + th / 2.0, wall_h / 2.0, w + 2.0 * th, th, wall_h, wall));
    e.cubes.push(cube(w / 2.0, -th / 2.0, wall_h / 2.0, w + 2.0 * th, th, wall_h, wall));
    e.cubes.push(cube(-th / 2.0, h / 2.0, wall_h / 2.0, th, h, wall_h, wall));
    e.cubes.push(cube(w + th / 2.0, h / 2.0, wall_h / 2.0, th, h, wall_h, wall));
    for c in 0..world.num_cells() {
        if !world.is_free(c) {
            let (x, y) = world.cell_center(c);
            e.cubes.push(cube(x, y, wall_h / 2.0, cs, cs, wall_h, wall));
        }
    }
    for (cell, color, label) in [
        (world.goal, m::Color::rgba(0.2, 0.75, 0.3, 0.8), "G"),
        (world.respawn, m::Color::rgba(0.25, 0.45, 0.9, 0.8), "S"),
    ] {
        let (x, y) = world.cell_center(cell);
        e.cubes.push(cube(x, y, 0.002, cs, cs, 0.004, color));
        e.texts.push(m::TextPrimitive {
            pose: m::Pose::planar(x, y, wall_h, 0.0),
            billboard: true,
            font_size: 0.5 * cs,
            scale_invariant: false,
            color: m::Color::rgba(0.1, 0.1, 0.1, 1.0),
            text: label.into(),
        });
    }
    let mut points = Vec::with_capacity(2 * (world.width + world.height + 2));
    for i in 0..=world.width {
        let x = i as f64 * cs;
        points.push(m::Vector3 { x, y: 0.0, z: 0.003 });
        points.push(m::Vector3 { x, y: h, z: 0.003 });
    }
    for j in 0..=world.height {
        let y = j as f64 * cs;
        points.push(m::Vector3 { x: 0.0, y, z: 0.003 });
        points.push(m::Vector3 { x: w, y, z: 0.003 });
    }
    e.lines.push(m::LinePrimitive {
        kind: m::LINE_LIST,
        pose: m::Pose::default(),
        thickness: 1.0,
        scale_invariant: true,
        points,
        color: m::Color::rgba(0.6, 0.6, 0.6, 1.0),
        colors: Vec::new(),
        indices: Vec::new(),
    });
    e.metadata.push(m::KeyValuePair { key: "world".into(), value: world.name.clone() });
    m::SceneUpdate { deletions: Vec::new(), entities: vec![e] }
}

/// `/viz/robot`: a disc (short cylinder) and a heading arrow in the "robot" frame, which
/// `/tf` moves.
pub(crate) fn robot_scene(radius: f64, timestamp: m::Time) -> m::SceneUpdate {
    let height = 0.4 * radius;
    let mut e = m::SceneEntity::new(timestamp, "robot", "robot");
    e.frame_locked = true;
    e.cylinders.push(m::CylinderPrimitive {
        pose: m::Pose::planar(0.0, 0.0, height / 2.0, 0.0),
        size: m::Vector3 { x: 2.0 * radius, y: 2.0 * radius, z: height },
        bottom_scale: 1.0,
        top_scale: 1.0,
        color: m::Color::rgba(0.95, 0.55, 0.1, 0.9),
    });
    e.arrows.push(m::ArrowPrimitive {
        pose: m::Pose::planar(0.0, 0.0, height + 0.01, 0.0),
        shaft_length: 0.8 * radius,
        shaft_diameter: 0.15 * radius,
        head_length: 0.5 * radius,
        head_diameter: 0.4 * radius,
        color: m::Color::rgba(0.1, 0.1, 0.1, 1.0),
    });
    e.metadata.push(m::KeyValuePair { key: "radius_m".into(), value: radius.to_string() });
    m::SceneUpdate { deletions: Vec::new(), entities: vec![e] }
}

impl Observer for McapRecorder {
    fn trace_period_s(&self) -> Option<f64> {
        Some(self.config.trace_period_s())
    }

    fn on_start(&mut self, info: &RunInfo<'_>, initial_state: State, sim_time_s: f64) {
        let world = info.world.clone();
        let grid = info.env_kind == "grid";
        let fact_period = info
            .facts
            .iter()
            .find(|(k, _)| k == "grid_step_period_s")
            .and_then(|(_, v)| v.parse::<f64>().ok())
            .filter(|p| p.is_finite() && *p > 0.0)
            .map(ns);
        self.period_ns = self
            .config
            .step_period_ns
            .or(fact_period)
            .unwrap_or(RecorderConfig::DEFAULT_STEP_PERIOD_NS)
            .max(1);
        let start_ns = if grid { 0 } else { ns(sim_time_s) };
        self.step_start_s = sim_time_s;
        // The start pose is written below; the trace's samples follow one period later.
        self.next_pose_s =
            sim_time_s + if self.config.pose_rate_hz > 0.0 { 1.0 / self.config.pose_rate_hz } else { 0.0 };
        let radius = robot_radius(info);
        let ts = m::Time::from_ns(start_ns);
        let arena_json = serde_json::to_vec(&arena_scene(&world, ts)).expect("JSON of a scene");
        let robot_json = serde_json::to_vec(&robot_scene(radius, ts)).expect("JSON of a scene");
        let config = &self.config;
        let mut run: BTreeMap<String, String> = BTreeMap::new();
        let mut put = |k: &str, v: String| {
            run.insert(k.to_string(), v);
        };
        put("seed", info.seed.to_string());
        put("learner", info.learner.to_string());
        put("env_kind", info.env_kind.to_string());
        put("world", world.name.clone());
        put("world_size", format!("{}x{}", world.width, world.height));
        put("cell_size_m", world.cell_size.to_string());
        put("actions", info.action_names.join(","));
        put("initial_state", initial_state.to_string());
        put("mmq_log_version", env!("CARGO_PKG_VERSION").to_string());
        put("mcap_library", mcap::LIBRARY_IDENTIFIER.to_string());
        for (k, v) in info.facts {
            put(k, v.clone());
        }
        let recorder: BTreeMap<String, String> = [
            ("time_base", "log_time = simulated ns since run start".to_string()),
            ("step_period_ns", if grid { self.period_ns.to_string() } else { "n/a (robot clock)".into() }),
            ("pose_rate_hz", config.pose_rate_hz.to_string()),
            (
                "window",
                config.window.map_or("all".into(), |w| {
                    format!("first {} and last {} of {}", w.first, w.last, w.total)
                }),
            ),
            ("flush_every_steps", config.flush_every_steps.to_string()),
            (
                "compression",
                format!("zstd level {}, chunks of {} KiB", config.compression_level, CHUNK_SIZE >> 10),
            ),
            ("robot_radius_m", radius.to_string()),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
        if let Some(w) = self.writer.as_mut() {
            let r = w
                .metadata("run", &run)
                .and_then(|()| w.metadata("recorder", &recorder))
                .and_then(|()| w.attach("world.toml", "application/toml", start_ns, world.source.as_bytes()))
                .and_then(|()| {
                    w.attach("config.toml", "application/toml", start_ns, info.config_toml.as_bytes())
                });
            if let Err(e) = r {
                self.fail(e);
            }
        }
        self.run =
            Some(Run { world, grid, action_names: info.action_names.to_vec(), arena_json, robot_json });
        self.write_scenes(start_ns);
        self.heading = 0.0;
        if grid || initial_state < info.world.num_cells() {
            self.write_cell_pose(start_ns, initial_state);
        }
        self.prev_recorded = true;
        self.note(
            start_ns,
            m::LOG_INFO,
            format!(
                "run start: {} on {} ({}), seed {}, initial state {initial_state}",
                info.learner, info.world.name, info.env_kind, info.seed
            ),
        );
    }

    fn on_step(&mut self, rec: &StepRecord<'_>) {
        let Some(run) = &self.run else { return };
        let grid = run.grid;
        let t = rec.t;
        let period = self.period_ns;
        // Step times (robot: keep the clock monotonic even if the environment resets it).
        let mut end_s = rec.sim_time_s + self.time_offset_s;
        if !grid && end_s + 1e-9 < self.step_start_s {
            self.time_offset_s = self.step_start_s;
            end_s = rec.sim_time_s + self.time_offset_s;
        }
        let (start_ns, end_ns) =
            if grid { (t * period, (t + 1) * period) } else { (ns(self.step_start_s), ns(end_s)) };
        // Running figures are kept over every step, recorded or not.
        let emission = (rec.emitted != 0.0).then(|| {
            let (id, delay) = match rec.emission() {
                Some(e) => (e.id, e.delay),
                None => (self.next_emission_id, rec.delay.unwrap_or(0)),
            };
            self.next_emission_id = id + 1;
            self.emitted_total += rec.emitted;
            (id, delay)
        });
        self.delivered_total += rec.delivered;
        let recorded = self.config.window.is_none_or(|w| w.contains(t));
        self.stats.steps_seen += 1;
        if recorded {
            self.stats.steps_recorded += 1;
            let action_name =
                run.action_names.get(rec.action).cloned().unwrap_or_else(|| rec.action.to_string());
            if (grid || rec.trace.poses.is_empty()) && !self.prev_recorded {
                // Entering a window: show where the decision is taken.
                self.write_cell_pose(start_ns, rec.state);
            }
            let decision = m::Decision {
                t,
                state: rec.state as u64,
                action: rec.action as u64,
                action_name,
                model: rec.model.map(|x| x as u64),
                explored: rec.explored,
                next_state: rec.next_state as u64,
                event: rec.event.name().to_string(),
            };
            self.write(Ch::Decision, start_ns, &decision);
            self.write_motion(rec, grid, end_ns);
            if let Some((id, delay)) = emission {
                let cause = match rec.event {
                    Event::WallBump => "wall",
                    Event::Teleport => "goal",
                    Event::Moved | Event::TimedOut => "step",
                };
                let msg = m::RewardEmitted {
                    id,
                    t,
                    value: rec.emitted,
                    cause: cause.into(),
                    delay,
                    due: t + u64::from(delay),
                    total: self.emitted_total,
                };
                self.write(Ch::Emitted, end_ns, &msg);
            }
            if rec.delivered != 0.0 || !rec.delivered_ids.is_empty() {
                let parts = rec
                    .ledger
                    .map(|l| {
                        rec.delivered_ids
                            .iter()
                            .filter_map(|&id| l.get(id))
                            .map(|e| m::DeliveredPart {
                                id: e.id,
                                t_emit: e.t_emit,
                                delay: e.delay,
                                value: e.value,
                            })
                            .collect()
                    })
                    .unwrap_or_default();
                let msg = m::RewardDelivered {
                    t,
                    sum: rec.delivered,
                    ids: rec.delivered_ids.to_vec(),
                    parts,
                    total: self.delivered_total,
                };
                self.write(Ch::Delivered, end_ns, &msg);
            }
            if rec.event == Event::Teleport {
                let center = |s: State| {
                    let w = &self.run.as_ref().expect("run started").world;
                    let (x, y) = if s < w.num_cells() { w.cell_center(s) } else { (f64::NAN, f64::NAN) };
                    m::Point2 { x, y }
                };
                let msg = m::Teleport {
                    t,
                    from_state: rec.state as u64,
                    to_state: rec.next_state as u64,
                    from: center(rec.state),
                    to: center(rec.next_state),
                };
                self.write(Ch::Teleport, end_ns, &msg);
                self.write_scenes(end_ns);
            }
        } else if let Some(p) = rec.trace.poses.last() {
            // Keep the thinning clock moving while skipping.
            self.next_pose_s = self.next_pose_s.max(p.time_s + self.time_offset_s);
        }
        self.prev_recorded = recorded;
        self.step_start_s = if grid { ((t + 1) * period) as f64 * 1e-9 } else { end_s };
        self.maybe_flush();
    }

    fn on_tables(&mut self, t: u64, sim_time_s: f64, visits: &[f64], values: &[f64]) {
        if !self.config.heatmaps {
            return;
        }
        let Some(run) = &self.run else { return };
        let log_time = if run.grid { t * self.period_ns } else { ns(sim_time_s + self.time_offset_s) };
        let n = run.world.num_cells();
        if visits.len() != n || values.len() != n {
            let msg = format!(
                "heat maps skipped at step {t}: {} visit and {} value entries for {n} cells",
                visits.len(),
                values.len()
            );
            self.note(log_time, m::LOG_WARNING, msg);
            return;
        }
        let visits = heatmap(&run.world, log_time, "visits", visits);
        let value = heatmap(&run.world, log_time, "value", values);
        self.write(Ch::Visits, log_time, &visits);
        self.write(Ch::Value, log_time, &value);
    }

    fn on_finish(&mut self, t: u64, complete: bool) {
        if let Err(e) = self.finish(t, complete) {
            self.error = Some(e);
        }
    }
}

impl McapRecorder {
    /// Poses and contacts of a step, in time order.
    fn write_motion(&mut self, rec: &StepRecord<'_>, grid: bool, end_ns: u64) {
        let trace = rec.trace;
        if grid || trace.poses.is_empty() {
            if let Some(h) = move_heading(rec.action).filter(|_| grid) {
                self.heading = h;
            }
            if rec.event == Event::Teleport {
                self.heading = 0.0;
            }
            for c in &trace.contacts {
                self.write_contact(rec.t, c);
            }
            self.write_cell_pose(end_ns, rec.next_state);
            return;
        }
        let period = if self.config.pose_rate_hz > 0.0 { 1.0 / self.config.pose_rate_hz } else { 0.0 };
        let off = self.time_offset_s;
        let mut contacts = trace.contacts.iter().peekable();
        let last = trace.poses.len() - 1;
        for (i, p) in trace.poses.iter().enumerate() {
            let time = p.time_s + off;
            while let Some(c) = contacts.next_if(|c| c.time_s + off <= time) {
                self.write_contact(rec.t, c);
            }
            // The step's last sample (its end pose, after a teleport too) is always kept.
            if period == 0.0 || time + 1e-9 >= self.next_pose_s || i == last {
                self.write_pose(ns(time), p.x, p.y, p.theta);
                if period > 0.0 {
                    self.next_pose_s = ((time / period + 1e-9).floor() + 1.0) * period;
                }
            }
        }
        for c in contacts {
            self.write_contact(rec.t, c);
        }
    }

    fn write_contact(&mut self, t: u64, c: &mmq_core::ContactSample) {
        let time_s = c.time_s + self.time_offset_s;
        let msg = m::Contact { t, time_s, started: c.started, wall: c.wall.clone() };
        self.write(Ch::Contact, ns(time_s), &msg);
    }
}

/// A `foxglove.Grid` of one FLOAT32 field per cell, rows from the bottom of the map
/// (y = 0) up, origin at the arena's bottom-left corner.
pub(crate) fn heatmap(world: &World, log_time: u64, field: &str, per_cell: &[f64]) -> m::Grid {
    let (w, h) = (world.width, world.height);
    let mut bytes = Vec::with_capacity(4 * w * h);
    for row_from_bottom in 0..h {
        let r = h - 1 - row_from_bottom;
        for c in 0..w {
            bytes.extend_from_slice(&(per_cell[world.index(r, c)] as f32).to_le_bytes());
        }
    }
    m::Grid {
        timestamp: m::Time::from_ns(log_time),
        frame_id: "world".into(),
        pose: m::Pose::default(),
        column_count: w as u32,
        cell_size: m::Vector2 { x: world.cell_size, y: world.cell_size },
        row_stride: 4 * w as u32,
        cell_stride: 4,
        fields: vec![m::PackedElementField { name: field.into(), offset: 0, kind: m::FLOAT32 }],
        data: base64::engine::general_purpose::STANDARD.encode(&bytes),
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

    #[test]
    fn heatmap_rows_go_up_from_the_bottom() {
        let w = World::parse("map = \"\"\"\nG.\n.S\n\"\"\"", "t").unwrap();
        let g = heatmap(&w, 5, "v", &[1.0, 2.0, 3.0, 4.0]);
        let bytes = base64::engine::general_purpose::STANDARD.decode(&g.data).unwrap();
        let vals: Vec<f32> = bytes.chunks(4).map(|b| f32::from_le_bytes(b.try_into().unwrap())).collect();
        // Bottom row (cells 2, 3) first.
        assert_eq!(vals, vec![3.0, 4.0, 1.0, 2.0]);
        assert_eq!((g.column_count, g.row_stride, g.cell_stride), (2, 8, 4));
        assert_eq!(g.timestamp, m::Time { sec: 0, nsec: 5 });
    }
}
