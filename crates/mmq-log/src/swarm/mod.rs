//! [`SwarmRecorder`]: an MCAP recording of a swarm, every robot in one file.
//!
//! The swarm is driven by its own loop (every robot decides when its primitive ends), so
//! this recorder is fed plain data rather than the single robot's observer hooks:
//! [`SwarmRecorder::start`] once, then, in simulated-time order, [`SwarmRecorder::frame`]
//! for every pose frame of the swarm and [`SwarmRecorder::step`] for every robot's step
//! that ended, and [`SwarmRecorder::finish`] at the end.
//!
//! What it writes (topics in [`topics`], the time base the single robot's: `log_time` is
//! simulated nanoseconds since the run's start):
//! - once, at the start: `/viz/arena` (the single robot's arena scene, plus the base
//!   station when the consultation asks one) and `/swarm/bodies` (every robot's body, a
//!   disc of its own colour with a heading arrow and its number, in its frame `robot<i>`;
//!   with a pose estimate, a translucent disc of the same colour in `robot<i>_estimate`);
//! - every frame: `/tf`, world → `robot<i>` for every robot (and world →
//!   `robot<i>_estimate` where the robot controls on an estimate), which moves the bodies;
//! - every [`TRAIL_PERIOD_S`] of simulated time: `/swarm/trails`, each robot's positions
//!   over the last [`TRAIL_S`] seconds as a line strip of its colour (a point every
//!   [`TRAIL_POINT_S`], or every frame when frames are rarer);
//! - every step that ended: `/swarm/step` (`mmq.SwarmStep`: the robot, its decision, the
//!   reward earned and delivered, the consultation), and when the step's reward was sent
//!   over the radio, `/swarm/links`: the hops it took, as lines between the robots (and the
//!   station) where they were, shown for a moment (a scene entity with a lifetime).
//!
//! A recorder can also show the swarm in a live view ([`SwarmRecorder::with_live`], or
//! [`SwarmRecorder::live_only`] without a file; the server advertises [`SWARM_LIVE`]):
//! the same bytes as the file, thinned as the single robot's live view thins them (frames
//! at most every [`crate::live::LIVE_POSE_PERIOD_NS`] of simulated time, the other topics
//! at most once per [`crate::live::LIVE_MIN_GAP`]), paced to the view's speed.
//!
//! Errors never stop the run: the first one is kept and returned by `finish` (and by
//! [`mmq_core::Observer::error`]), and recording stops there.

mod scenes;

use std::collections::{BTreeMap, VecDeque};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::time::Instant;

use mmq_core::{Action, Event, Observer, PoseSample, RunInfo, State};
use serde::{Deserialize, Serialize};

use crate::error::LogError;
use crate::live::{LiveChannels, LiveTap};
use crate::mcap_out::{ChunkOptions, McapOut};
use crate::messages as m;
use crate::recorder::{DIGEST_START, RecordStats, RecorderConfig, TopicStats};
use crate::writer::{Failure, LogWriter};

/// The swarm's topics.
pub mod topics {
    /// Every robot's pose (and estimate) as transforms of its frame.
    pub const TF: &str = crate::messages::topics::TF;
    /// The arena (and the base station), once.
    pub const ARENA: &str = crate::messages::topics::ARENA;
    /// Every robot's body in its own frame, once.
    pub const BODIES: &str = "/swarm/bodies";
    /// Every robot's recent path.
    pub const TRAILS: &str = "/swarm/trails";
    /// The radio hops of each consultation, for a moment.
    pub const LINKS: &str = "/swarm/links";
    /// Every robot's every step.
    pub const STEP: &str = "/swarm/step";
}

/// The schema of `/swarm/step`.
pub const STEP_SCHEMA: &str = include_str!("../../schemas/mmq.SwarmStep.json");

/// Every channel of a swarm recording: (topic, schema name, schema text), in the order
/// they are registered.
pub const SWARM_CHANNELS: [(&str, &str, &str); 6] = [
    (topics::TF, "foxglove.FrameTransform", m::schemas::FRAME_TRANSFORM),
    (topics::ARENA, "foxglove.SceneUpdate", m::schemas::SCENE_UPDATE),
    (topics::BODIES, "foxglove.SceneUpdate", m::schemas::SCENE_UPDATE),
    (topics::TRAILS, "foxglove.SceneUpdate", m::schemas::SCENE_UPDATE),
    (topics::LINKS, "foxglove.SceneUpdate", m::schemas::SCENE_UPDATE),
    (topics::STEP, "mmq.SwarmStep", STEP_SCHEMA),
];

/// A swarm's live view: its channels, the arena and the bodies latched, frames thinned
/// per sample.
pub const SWARM_LIVE: LiveChannels = LiveChannels {
    channels: &SWARM_CHANNELS,
    latched: &[topics::ARENA, topics::BODIES],
    per_sample: &[topics::TF],
};

/// Channel slots, indices into [`SWARM_CHANNELS`].
#[derive(Clone, Copy)]
enum Ch {
    Tf = 0,
    Arena,
    Bodies,
    Trails,
    Links,
    Step,
}

const NCH: usize = SWARM_CHANNELS.len();

/// Seconds of path a trail shows.
pub const TRAIL_S: f64 = 30.0;
/// Simulated seconds between two points of a trail (at least a frame apart).
pub const TRAIL_POINT_S: f64 = 1.0;
/// Simulated seconds between two `/swarm/trails` messages.
pub const TRAIL_PERIOD_S: f64 = 2.0;
/// How long a consultation's links are shown at least, and at most, seconds (in
/// between: as long as the consultation took).
pub const LINK_SHOWN_S: (f64, f64) = (1.0, 5.0);

/// Uncompressed size at which a chunk is closed (as the single robot's recorder).
const CHUNK_SIZE: usize = 1 << 20;

/// A reward delivered to a robot at a step.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SwarmDelivery {
    /// The robot's decision step that earned it.
    pub t_emit: u64,
    /// Its value.
    pub value: f64,
    /// When it was earned, simulated seconds.
    pub t_emit_s: f64,
    /// How long its consultation took, seconds.
    pub delay_s: f64,
    /// One-way hops of the reply that completed the consultation.
    pub hops: u32,
}

/// One robot's step that ended, as the swarm's loop knows it.
#[derive(Clone, Copy, Debug)]
pub struct SwarmStepIn<'a> {
    /// The robot.
    pub robot: usize,
    /// Its decision step (0, 1, …).
    pub t: u64,
    /// Simulated time at the end of the step, seconds.
    pub time_s: f64,
    /// The state the robot decided in (what its learner saw).
    pub state: State,
    /// The action taken.
    pub action: Action,
    /// The delay model the learner acted on, if it has one.
    pub model: Option<usize>,
    /// The action was exploratory.
    pub explored: bool,
    /// The state reached.
    pub next_state: State,
    /// What happened.
    pub event: Event,
    /// The reward earned (before any consultation).
    pub earned: f64,
    /// The sum delivered to the robot at this step.
    pub delivered: f64,
    /// What was delivered.
    pub deliveries: &'a [SwarmDelivery],
    /// The earned reward's consultation, `(delay s, hops)`; `None` when it will never
    /// complete or the reward is zero.
    pub consultation: Option<(f64, u32)>,
    /// The radio hops (from, to) the consultation sent messages over.
    pub links: &'a [(u32, u32)],
    /// Where the nodes of `links` were: robots in order, then the base station.
    pub nodes: &'a [(f64, f64)],
}

/// What the swarm is, for the recording's start.
#[derive(Clone, Copy, Debug)]
pub struct SwarmSetup {
    /// Robots.
    pub robots: usize,
    /// The base station, metres, when the consultation asks one.
    pub station: Option<(f64, f64)>,
    /// The robots control on a pose estimate (the realistic profile).
    pub estimates: bool,
}

/// `mmq.SwarmStep` on `/swarm/step`: one robot's step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SwarmStepMsg {
    /// The robot (0, 1, …).
    pub robot: u64,
    /// Its decision step.
    pub t: u64,
    /// Simulated time at the end of the step, s.
    pub time_s: f64,
    /// State s_t.
    pub state: u64,
    /// Action a_t.
    pub action: u64,
    /// Its name.
    pub action_name: String,
    /// The delay model acted on, left out for learners without one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<u64>,
    /// Exploratory (ε) rather than greedy.
    pub explored: bool,
    /// State s_{t+1}.
    pub next_state: u64,
    /// `moved`, `wall`, `goal` or `timeout`.
    pub event: String,
    /// The reward earned.
    pub earned: f64,
    /// The sum delivered at this step.
    pub delivered: f64,
    /// The robot's earned rewards so far.
    pub earned_total: f64,
    /// The robot's delivered rewards so far.
    pub delivered_total: f64,
    /// The earned reward's consultation: `none` (nothing earned), `done` (it completes,
    /// `delay_s` and `hops` say how) or `lost` (it never completes: the reward is lost).
    pub consult: String,
    /// How long the consultation takes, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_s: Option<f64>,
    /// One-way hops of the reply that completes it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hops: Option<u32>,
    /// Radio hops the consultation sent messages over.
    pub links: u64,
    /// What was delivered at this step.
    pub deliveries: Vec<SwarmDelivery>,
}

/// Per-run state, set by `start`.
struct Run {
    action_names: Vec<String>,
    robots: usize,
    estimates: bool,
    radius: f64,
    /// Each robot's trail, oldest point first.
    trails: Vec<VecDeque<(f64, f64)>>,
    earned: Vec<f64>,
    delivered: Vec<f64>,
    decisions: Vec<u64>,
    frames: u64,
}

/// Writes a swarm's run to an MCAP file; see the module documentation.
pub struct SwarmRecorder {
    config: RecorderConfig,
    writer: Option<LogWriter<BufWriter<File>>>,
    channel_ids: [u16; NCH],
    counts: [u64; NCH],
    error: Option<LogError>,
    /// The error `finish` returned, as text.
    failed: Option<String>,
    run: Option<Run>,
    /// The last log time written, ns (keeps time monotonic).
    last_ns: u64,
    next_trail_point_s: f64,
    next_trail_msg_s: f64,
    steps: u64,
    last_flush: Instant,
    stats: RecordStats,
    /// The live view the messages also go to.
    live: Option<LiveTap>,
}

impl std::fmt::Debug for SwarmRecorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SwarmRecorder")
            .field("path", &self.config.path)
            .field("open", &self.writer.is_some())
            .field("error", &self.error)
            .finish_non_exhaustive()
    }
}

/// Seconds → nanoseconds (negative and non-finite times become 0).
fn ns(s: f64) -> u64 {
    if s.is_finite() && s > 0.0 { (s * 1e9).round() as u64 } else { 0 }
}

impl SwarmRecorder {
    /// Creates the file (and its folder), writes the MCAP header and registers every
    /// channel. Of `config`, the path, the pose rate (frames are asked of the swarm at
    /// [`RecorderConfig::trace_period_s`]), the flush interval, the compression level and
    /// the writer thread are used; a window is not (the swarm records every step).
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
        let mut schema_ids: BTreeMap<&str, u16> = BTreeMap::new();
        for (i, id) in channel_ids.iter_mut().enumerate() {
            let (topic, schema, text) = SWARM_CHANNELS[i];
            let sid = match schema_ids.get(schema) {
                Some(&s) => s,
                None => {
                    let s = writer
                        .add_schema(schema, "jsonschema", text.as_bytes())
                        .map_err(|e| mcap_err("register a schema", e))?;
                    schema_ids.insert(schema, s);
                    s
                }
            };
            *id = writer.add_channel(sid, topic, "json").map_err(|e| mcap_err("register a channel", e))?;
        }
        let writer = LogWriter::new(writer, CHUNK_SIZE, config.writer_thread)
            .map_err(|e| mcap_err("start the log writer thread", e))?;
        Ok(Self::with_outputs(config, Some(writer), channel_ids, None))
    }

    /// A recorder that writes no file and shows the swarm in a live view only (of
    /// `config`, the pose rate is used).
    pub fn live_only(config: RecorderConfig, live: LiveTap) -> Self {
        Self::with_outputs(config, None, [0; NCH], Some(live))
    }

    /// A recorder writing to `writer` (channels `channel_ids`) and/or showing on `live`,
    /// before its start.
    fn with_outputs(
        config: RecorderConfig,
        writer: Option<LogWriter<BufWriter<File>>>,
        channel_ids: [u16; NCH],
        live: Option<LiveTap>,
    ) -> Self {
        Self {
            config,
            writer,
            channel_ids,
            counts: [0; NCH],
            error: None,
            failed: None,
            run: None,
            last_ns: 0,
            next_trail_point_s: 0.0,
            next_trail_msg_s: 0.0,
            steps: 0,
            last_flush: Instant::now(),
            stats: RecordStats::default(),
            live,
        }
    }

    /// Also shows the swarm in a live view, with the same messages as the file.
    pub fn with_live(mut self, live: LiveTap) -> Self {
        self.live = Some(live);
        self
    }

    /// Whether what happens now is written or shown (a live view without viewers shows
    /// nothing: then the messages are not even built).
    fn active(&self) -> bool {
        self.writer.is_some() || self.live.as_ref().is_some_and(LiveTap::has_clients)
    }

    /// The frame period to ask of the swarm, seconds of simulated time.
    pub fn frame_period_s(&self) -> f64 {
        self.config.trace_period_s()
    }

    /// The file being written.
    pub fn path(&self) -> &std::path::Path {
        &self.config.path
    }

    fn fail(&mut self, Failure { action, source }: Failure) {
        if self.error.is_none() {
            self.error = Some(LogError::Mcap {
                path: self.config.path.clone(),
                action,
                source: mcap::McapError::Io(source),
            });
        }
        self.writer = None;
    }

    /// A log time no earlier than the last one written.
    fn stamp(&mut self, time_s: f64) -> u64 {
        self.last_ns = self.last_ns.max(ns(time_s));
        self.last_ns
    }

    fn write<T: Serialize>(&mut self, ch: Ch, log_time: u64, msg: &T) {
        // Our own plain structs into a Vec: cannot fail.
        let json =
            |out: &mut Vec<u8>| serde_json::to_writer(out, msg).expect("JSON serialization of a log message");
        let i = ch as usize;
        let Self { live, writer, channel_ids, .. } = self;
        let r = match live.as_mut().and_then(|l| if l.wants(i) { Some(l) } else { None }) {
            // Serialized once, for the view and the file.
            Some(tap) => {
                let bytes = tap.send(i, log_time, json);
                writer
                    .as_mut()
                    .map(|w| w.message(channel_ids[i], log_time, |out| out.extend_from_slice(bytes)))
            }
            None => writer.as_mut().map(|w| w.message(channel_ids[i], log_time, json)),
        };
        match r {
            Some(Ok(())) => self.counts[i] += 1,
            Some(Err(e)) => self.fail(e),
            None => {}
        }
    }

    /// Robot `robot`'s pose (or estimate) on `/tf`; the writer writes the JSON (as
    /// serde_json writes [`m::FrameTransform`]).
    fn transform(&mut self, log_time: u64, robot: usize, estimate: bool, p: &PoseSample, live: bool) {
        let robot = u32::try_from(robot).unwrap_or(u32::MAX);
        if live && let Some(tap) = self.live.as_mut() {
            tap.robot_transform(Ch::Tf as usize, log_time, robot, estimate, [p.x, p.y, p.theta]);
        }
        let Some(w) = self.writer.as_mut() else { return };
        let tf = self.channel_ids[Ch::Tf as usize];
        match w.robot_transform(tf, log_time, robot, estimate, p.x, p.y, p.theta) {
            Ok(()) => self.counts[Ch::Tf as usize] += 1,
            Err(e) => self.fail(e),
        }
    }

    /// The run's start: metadata (`run`: the run's facts and the swarm's; `recorder`),
    /// attachments (`world.toml`, `config.toml`) and the static scenes, at simulated time
    /// `sim_time_s`.
    pub fn start(&mut self, info: &RunInfo<'_>, swarm: SwarmSetup, sim_time_s: f64) {
        let world = info.world;
        let start_ns = self.stamp(sim_time_s);
        let radius = crate::recorder::robot_radius(info);
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
        put("robots", swarm.robots.to_string());
        if let Some((x, y)) = swarm.station {
            put("station_m", format!("{x},{y}"));
        }
        put("mmq_log_version", env!("CARGO_PKG_VERSION").to_string());
        put("mcap_library", mcap::LIBRARY_IDENTIFIER.to_string());
        for (k, v) in info.facts {
            put(k, v.clone());
        }
        let recorder: BTreeMap<String, String> = [
            ("time_base", "log_time = simulated ns since run start".to_string()),
            ("frame_rate_hz", (1.0 / self.frame_period_s()).to_string()),
            ("trail_s", TRAIL_S.to_string()),
            ("trail_point_s", TRAIL_POINT_S.to_string()),
            ("trail_period_s", TRAIL_PERIOD_S.to_string()),
            (
                "compression",
                format!("zstd level {}, chunks of {} KiB", self.config.compression_level, CHUNK_SIZE >> 10),
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
        let ts = m::Time::from_ns(start_ns);
        let mut arena = crate::recorder::arena_scene(world, ts);
        if let Some(station) = swarm.station {
            arena.entities.push(scenes::station(station, world.cell_size, ts));
        }
        self.write(Ch::Arena, start_ns, &arena);
        let bodies = scenes::bodies(swarm.robots, radius, swarm.estimates, ts);
        self.write(Ch::Bodies, start_ns, &bodies);
        let n = swarm.robots;
        self.run = Some(Run {
            action_names: info.action_names.to_vec(),
            robots: n,
            estimates: swarm.estimates,
            radius,
            trails: vec![VecDeque::new(); n],
            earned: vec![0.0; n],
            delivered: vec![0.0; n],
            decisions: vec![0; n],
            frames: 0,
        });
        self.next_trail_point_s = sim_time_s;
        self.next_trail_msg_s = sim_time_s;
    }

    /// A frame: every robot's true pose and, where it has one, its estimate, at
    /// `time_s`.
    pub fn frame(&mut self, time_s: f64, poses: &[PoseSample], estimates: &[Option<PoseSample>]) {
        let Some(mut run) = self.run.take() else { return };
        if self.active() {
            let log_time = self.stamp(time_s);
            let ts = m::Time::from_ns(log_time);
            // The whole frame goes to the view, or none of it.
            let live = self.live.as_mut().is_some_and(|l| l.pose_due(log_time));
            for (i, p) in poses.iter().enumerate().take(run.robots) {
                self.transform(log_time, i, false, p, live);
                if run.estimates
                    && let Some(Some(e)) = estimates.get(i)
                {
                    self.transform(log_time, i, true, e, live);
                }
            }
            run.frames += 1;
            if time_s >= self.next_trail_point_s {
                let keep = (TRAIL_S / TRAIL_POINT_S).ceil() as usize + 1;
                for (trail, p) in run.trails.iter_mut().zip(poses) {
                    if trail.len() >= keep {
                        trail.pop_front();
                    }
                    trail.push_back((p.x, p.y));
                }
                self.next_trail_point_s = next_after(self.next_trail_point_s, TRAIL_POINT_S, time_s);
            }
            if time_s >= self.next_trail_msg_s {
                let trails = scenes::trails(&run.trails, ts);
                self.write(Ch::Trails, log_time, &trails);
                self.next_trail_msg_s = next_after(self.next_trail_msg_s, TRAIL_PERIOD_S, time_s);
            }
        }
        self.run = Some(run);
    }

    /// One robot's step that ended.
    pub fn step(&mut self, s: &SwarmStepIn<'_>) {
        let Some(mut run) = self.run.take() else { return };
        if let (Some(e), Some(d), Some(n)) =
            (run.earned.get_mut(s.robot), run.delivered.get_mut(s.robot), run.decisions.get_mut(s.robot))
        {
            *e += s.earned;
            *d += s.delivered;
            *n += 1;
        }
        self.steps += 1;
        if self.active() {
            let log_time = self.stamp(s.time_s);
            let consult = match s.consultation {
                _ if s.earned == 0.0 => "none",
                Some(_) => "done",
                None => "lost",
            };
            let msg = SwarmStepMsg {
                robot: s.robot as u64,
                t: s.t,
                time_s: s.time_s,
                state: s.state as u64,
                action: s.action as u64,
                action_name: run.action_names.get(s.action).cloned().unwrap_or_else(|| s.action.to_string()),
                model: s.model.map(|x| x as u64),
                explored: s.explored,
                next_state: s.next_state as u64,
                event: s.event.name().to_string(),
                earned: s.earned,
                delivered: s.delivered,
                earned_total: run.earned.get(s.robot).copied().unwrap_or(0.0),
                delivered_total: run.delivered.get(s.robot).copied().unwrap_or(0.0),
                consult: consult.to_string(),
                delay_s: s.consultation.map(|c| c.0),
                hops: s.consultation.map(|c| c.1),
                links: s.links.len() as u64,
                deliveries: s.deliveries.to_vec(),
            };
            self.write(Ch::Step, log_time, &msg);
            if !s.links.is_empty() {
                let shown =
                    s.consultation.map_or(LINK_SHOWN_S.0, |c| c.0).clamp(LINK_SHOWN_S.0, LINK_SHOWN_S.1);
                let links = scenes::links(s, run.radius, shown, m::Time::from_ns(log_time));
                self.write(Ch::Links, log_time, &links);
            }
            if let Some(tap) = self.live.as_mut() {
                tap.step_end(log_time);
            }
        }
        self.run = Some(run);
        self.maybe_flush();
    }

    fn maybe_flush(&mut self) {
        let by_steps =
            self.config.flush_every_steps > 0 && self.steps.is_multiple_of(self.config.flush_every_steps);
        let by_time = self.steps.is_multiple_of(64)
            && self.config.flush_interval.is_some_and(|d| self.last_flush.elapsed() >= d);
        if by_steps || by_time {
            self.last_flush = Instant::now();
            if let Some(w) = self.writer.as_mut()
                && let Err(e) = w.flush()
            {
                self.fail(e);
            }
        }
    }

    /// Finishes the file: an `end` metadata record (steps per robot, whether the run was
    /// `complete`, reward totals), then the summary section. Later calls do nothing.
    /// Returns what was written, or the first error met while recording.
    pub fn finish(&mut self, complete: bool) -> Result<RecordStats, LogError> {
        if let Some(mut w) = self.writer.take() {
            let mut end: BTreeMap<String, String> = BTreeMap::new();
            end.insert("steps".into(), self.steps.to_string());
            end.insert("complete".into(), complete.to_string());
            end.insert("end_time_ns".into(), self.last_ns.to_string());
            if let Some(run) = &self.run {
                let list = |xs: &[f64]| xs.iter().map(f64::to_string).collect::<Vec<_>>().join(",");
                end.insert("frames".into(), run.frames.to_string());
                end.insert(
                    "decisions".into(),
                    run.decisions.iter().map(u64::to_string).collect::<Vec<_>>().join(","),
                );
                end.insert("earned_totals".into(), list(&run.earned));
                end.insert("delivered_totals".into(), list(&run.delivered));
            }
            let path = self.config.path.clone();
            let mcap_err = |Failure { action, source }| LogError::Mcap {
                path: path.clone(),
                action,
                source: mcap::McapError::Io(source),
            };
            let finished = w.metadata("end", &end).and_then(|()| w.finish()).map_err(mcap_err);
            let result = finished.and_then(|(mut inner, digests)| {
                for (i, &id) in self.channel_ids.iter().enumerate() {
                    let digest = digests.get(usize::from(id)).copied().unwrap_or(DIGEST_START);
                    self.stats.topics.insert(
                        SWARM_CHANNELS[i].0.to_string(),
                        TopicStats { count: self.counts[i], digest },
                    );
                }
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
                    self.stats.steps_seen = self.steps;
                    self.stats.steps_recorded = self.steps;
                }
                Err(e) => {
                    self.error.get_or_insert(e);
                }
            }
        }
        match self.error.take() {
            Some(e) => {
                self.failed = Some(e.to_string());
                Err(e)
            }
            None => Ok(self.stats.clone()),
        }
    }
}

/// The first multiple of `period` after `from` that is past `now`.
fn next_after(from: f64, period: f64, now: f64) -> f64 {
    let mut next = from + period;
    if next <= now {
        next = from + ((now - from) / period).floor() * period + period;
    }
    next
}

impl Drop for SwarmRecorder {
    fn drop(&mut self) {
        if self.writer.is_some() {
            let _ = self.finish(false);
        }
    }
}

/// The swarm's recorder travels to the swarm's loop as an observer (the runner hands
/// observers over per seed); the loop takes it back with [`Observer::into_any`] and feeds
/// it itself.
impl Observer for SwarmRecorder {
    fn on_finish(&mut self, _t: u64, complete: bool) {
        let _ = self.finish(complete);
    }

    fn error(&self) -> Option<String> {
        self.error.as_ref().map(ToString::to_string).or_else(|| self.failed.clone())
    }

    fn into_any(self: Box<Self>) -> Option<Box<dyn std::any::Any + Send>> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trail_times_step_past_now() {
        assert_eq!(next_after(0.0, 1.0, 0.0), 1.0);
        assert_eq!(next_after(0.0, 1.0, 3.5), 4.0);
        assert_eq!(next_after(2.0, 0.5, 2.1), 2.5);
    }

    #[test]
    fn recorder_can_move_to_another_thread() {
        fn send<T: Send>() {}
        send::<SwarmRecorder>();
    }
}
