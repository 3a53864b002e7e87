//! Reading logs back: [`read_log`] streams an MCAP file record by record through the
//! hardened walker of `reader/walk.rs` (bounded reads, checked lengths, checked chunks)
//! and keeps whatever is readable. A truncated file gives the messages before the cut and
//! a [`ReadStop`] saying where reading stopped; a damaged chunk is skipped and named in
//! [`LogContents::problems`]; never a panic.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use mcap::records::Record;
use mmq_core::{World, WorldError};
use serde::de::DeserializeOwned;

use crate::error::LogError;
use crate::messages::{self as m, topics};
use crate::recorder::{DIGEST_START, digest_message};

pub(crate) mod walk;

use walk::{Inner, Item, SchemaRec, Stop, Walker};

/// A message with its `log_time` (simulated ns since the start of the run).
#[derive(Clone, Debug, PartialEq)]
pub struct Stamped<T> {
    /// Simulated time, ns since the start of the run.
    pub log_time: u64,
    /// The message.
    pub msg: T,
}

/// A robot pose read from `/robot/pose`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseStamp {
    /// Simulated time, ns.
    pub log_time: u64,
    /// x, metres.
    pub x: f64,
    /// y, metres.
    pub y: f64,
    /// Heading about +z, radians.
    pub theta: f64,
}

/// One topic of a log.
#[derive(Clone, Debug, PartialEq)]
pub struct TopicInfo {
    /// Schema name (`foxglove.Grid`, `mmq.Decision`, ...).
    pub schema: String,
    /// Schema encoding (`jsonschema`).
    pub schema_encoding: String,
    /// Schema text.
    pub schema_text: String,
    /// Message encoding (`json`).
    pub message_encoding: String,
    /// Messages read.
    pub count: u64,
    /// `log_time` of the first and last message read.
    pub first_ns: u64,
    /// See `first_ns`.
    pub last_ns: u64,
    /// Digest of the messages, as [`crate::RecordStats`] computes it.
    pub digest: u64,
    /// Messages whose JSON did not decode as the topic's message type.
    pub undecodable: u64,
}

/// An attachment of a log (the world file, the resolved config).
#[derive(Clone, Debug, PartialEq)]
pub struct LogAttachment {
    /// Name (`world.toml`, `config.toml`).
    pub name: String,
    /// Media type.
    pub media_type: String,
    /// Time, ns.
    pub log_time: u64,
    /// Contents.
    pub data: Vec<u8>,
}

/// Where and why reading stopped before the end of a file.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadStop {
    /// Byte offset of the first record that could not be read (everything before it was
    /// kept).
    pub offset: u64,
    /// Size of the file, bytes.
    pub file_len: u64,
    /// Messages recovered before the stop.
    pub messages: u64,
    /// Why reading stopped.
    pub reason: String,
}

impl std::fmt::Display for ReadStop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "reading stopped at byte {} of {} ({}); {} messages recovered before it",
            self.offset, self.file_len, self.reason, self.messages
        )
    }
}

/// Everything read from a log.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LogContents {
    /// The file.
    pub path: PathBuf,
    /// Its size, bytes.
    pub file_len: u64,
    /// Topics by name (every channel seen, with or without messages).
    pub topics: BTreeMap<String, TopicInfo>,
    /// Metadata records by name (`run`, `recorder`, `end`).
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// Attachments in file order.
    pub attachments: Vec<LogAttachment>,
    /// `/rl/decision`.
    pub decisions: Vec<Stamped<m::Decision>>,
    /// `/rl/reward/emitted`.
    pub emitted: Vec<Stamped<m::RewardEmitted>>,
    /// `/rl/reward/delivered`.
    pub delivered: Vec<Stamped<m::RewardDelivered>>,
    /// `/rl/teleport`.
    pub teleports: Vec<Stamped<m::Teleport>>,
    /// `/sim/contact`.
    pub contacts: Vec<Stamped<m::Contact>>,
    /// `/robot/pose`.
    pub poses: Vec<PoseStamp>,
    /// `/foxglove/log`.
    pub notes: Vec<Stamped<m::Log>>,
    /// The last `/rl/heatmap/visits` grid.
    pub last_visits: Option<Stamped<m::Grid>>,
    /// The last `/rl/heatmap/value` grid.
    pub last_value: Option<Stamped<m::Grid>>,
    /// `/swarm/step` (a swarm's recording: every robot's steps).
    pub swarm_steps: Vec<Stamped<crate::swarm::SwarmStepMsg>>,
    /// Messages read, all topics.
    pub messages: u64,
    /// Messages whose log time is earlier than the message read before them (0 in a
    /// file written in log-time order, as the recorders write).
    pub out_of_order: u64,
    /// The file was read to its end magic, and what was read agrees with the file's own
    /// statistics (no [`LogContents::problems`]).
    pub complete: bool,
    /// Where reading stopped early, if it did.
    pub stop: Option<ReadStop>,
    /// What is wrong with the file besides a cut end: chunks skipped as damaged (a CRC or
    /// decompression failure; the chunks after them are read), damaged bytes that ended
    /// the reading with more of the file after them, and, for a file read to its end,
    /// message counts that disagree with its statistics record (a chunk removed or
    /// duplicated) and payloads that do not decode.
    pub problems: Vec<String>,
}

impl LogContents {
    /// The attachment called `name`.
    pub fn attachment(&self, name: &str) -> Option<&LogAttachment> {
        self.attachments.iter().find(|a| a.name == name)
    }

    /// A fact of the `run` metadata record (`seed`, `learner`, `env_kind`, ...).
    pub fn run_fact(&self, key: &str) -> Option<&str> {
        self.metadata.get("run")?.get(key).map(String::as_str)
    }

    /// The world the run used, parsed from the `world.toml` attachment.
    pub fn world(&self) -> Result<World, LogError> {
        let a = self.attachment("world.toml").ok_or_else(|| LogError::NoWorld {
            path: self.path.clone(),
            message: "the log has no world.toml attachment".into(),
        })?;
        let text = String::from_utf8_lossy(&a.data);
        World::parse(&text, &format!("{}#world.toml", self.path.display()))
            .map_err(|e: WorldError| LogError::NoWorld { path: self.path.clone(), message: e.to_string() })
    }
}

/// Reads a log, keeping what is readable.
///
/// Returns `Err` only when the file cannot be opened, is not a regular file, or is not an
/// MCAP file at all; a truncated or damaged file returns what could be read, with
/// [`LogContents::stop`] set where reading stopped. Chunks are kept whole or not at all:
/// a chunk that fails to decompress or to match its CRC is skipped and named in
/// [`LogContents::problems`], and reading goes on after it. The file is streamed (one
/// chunk in memory at a time; see `reader/walk.rs`).
pub fn read_log(path: impl AsRef<Path>) -> Result<LogContents, LogError> {
    let path = path.as_ref();
    let mut walker = Walker::open(path)?;
    let file_len = walker.file_len();
    let mut out = LogContents { path: path.to_path_buf(), file_len, ..Default::default() };
    let mut st = State::default();
    let mut in_data_section = true;
    let stop = loop {
        match walker.next() {
            Ok(None) => break None,
            Ok(Some((offset, item))) => st.top_level(offset, item, &mut out, &mut in_data_section),
            Err(Stop::Io(e)) => return Err(e),
            Err(Stop::At { reason, cut }) => break Some((reason, cut)),
        }
    };
    out.problems = std::mem::take(&mut st.damaged);
    match stop {
        None => {
            let more = st.problems(&out);
            out.problems.extend(more);
        }
        Some((reason, cut)) => {
            // A file too short to hold the start magic stops at its first byte.
            let offset = if file_len < mcap::MAGIC.len() as u64 { 0 } else { walker.offset() };
            if !cut {
                out.problems.push(format!(
                    "damaged bytes at byte {offset} of {file_len} ({reason}); the {} bytes after them were not read",
                    file_len.saturating_sub(offset)
                ));
            }
            out.stop = Some(ReadStop { offset, file_len, messages: out.messages, reason });
        }
    }
    out.complete = out.stop.is_none() && out.problems.is_empty();
    Ok(out)
}

/// Schemas and channels seen so far.
#[derive(Debug, Default)]
struct State {
    schemas: HashMap<u16, SchemaRec>,
    channels: HashMap<u16, String>,
    /// Message records read per channel id (known channel or not).
    counts: BTreeMap<u16, u64>,
    /// The file's statistics record (summary section), if it has one.
    stats: Option<mcap::records::Statistics>,
    /// Chunks skipped as damaged, as problems.
    damaged: Vec<String>,
    /// The log time of the last message read.
    last_log_time: u64,
}

impl State {
    fn top_level(&mut self, offset: u64, item: Item, out: &mut LogContents, data: &mut bool) {
        let rec = match item {
            Item::Chunk(inner) => {
                for p in inner {
                    match p {
                        Inner::Schema(id, s) => {
                            self.schemas.insert(id, s);
                        }
                        Inner::Channel(c) => self.channel(c, out),
                        Inner::Message(h, d) => self.message(h, &d, out),
                    }
                }
                return;
            }
            Item::Damaged { reason, start_ns, end_ns } => {
                self.damaged.push(format!(
                    "the chunk at byte {offset} (log times {start_ns} to {end_ns} ns) cannot be read ({reason}); \
                     its messages are missing, the chunks after it were read"
                ));
                return;
            }
            Item::Other(rec) => rec,
        };
        match rec {
            Record::Schema { header, data: bytes } if *data => {
                let text = String::from_utf8_lossy(&bytes).into_owned();
                self.schemas
                    .insert(header.id, SchemaRec { name: header.name, encoding: header.encoding, text });
            }
            Record::Channel(c) if *data => self.channel(c, out),
            Record::Message { header, data: bytes } if *data => self.message(header, &bytes, out),
            Record::Metadata(md) => {
                out.metadata.insert(md.name, md.metadata);
            }
            Record::Attachment { header, data: bytes, .. } => out.attachments.push(LogAttachment {
                name: header.name,
                media_type: header.media_type,
                log_time: header.log_time,
                data: bytes.into_owned(),
            }),
            Record::DataEnd(_) => *data = false,
            Record::Statistics(s) => self.stats = Some(s),
            _ => {}
        }
    }

    /// What disagrees in a file read to its end (see [`LogContents::problems`]).
    fn problems(&self, out: &LogContents) -> Vec<String> {
        let mut found = Vec::new();
        if let Some(stats) = &self.stats {
            let read: u64 = self.counts.values().sum();
            if read != stats.message_count {
                found.push(format!(
                    "the file's statistics count {} messages, {read} were read: a chunk is missing or repeated",
                    stats.message_count
                ));
            }
            let ids: std::collections::BTreeSet<u16> =
                stats.channel_message_counts.keys().chain(self.counts.keys()).copied().collect();
            for id in ids {
                let want = stats.channel_message_counts.get(&id).copied().unwrap_or(0);
                let got = self.counts.get(&id).copied().unwrap_or(0);
                if want != got {
                    let topic = self.channels.get(&id).map_or_else(|| format!("channel {id}"), Clone::clone);
                    found.push(format!("{topic}: {got} messages read, the statistics count {want}"));
                }
            }
        }
        for (topic, t) in &out.topics {
            if t.undecodable > 0 {
                found.push(format!("{topic}: {} of {} messages do not decode", t.undecodable, t.count));
            }
        }
        found
    }

    fn channel(&mut self, c: mcap::records::Channel, out: &mut LogContents) {
        let schema = self.schemas.get(&c.schema_id);
        out.topics.entry(c.topic.clone()).or_insert_with(|| TopicInfo {
            schema: schema.map(|s| s.name.clone()).unwrap_or_default(),
            schema_encoding: schema.map(|s| s.encoding.clone()).unwrap_or_default(),
            schema_text: schema.map(|s| s.text.clone()).unwrap_or_default(),
            message_encoding: c.message_encoding.clone(),
            count: 0,
            first_ns: 0,
            last_ns: 0,
            digest: DIGEST_START,
            undecodable: 0,
        });
        self.channels.insert(c.id, c.topic);
    }

    fn message(&mut self, h: mcap::records::MessageHeader, data: &[u8], out: &mut LogContents) {
        *self.counts.entry(h.channel_id).or_insert(0) += 1;
        let Some(topic) = self.channels.get(&h.channel_id) else { return };
        let Some(info) = out.topics.get_mut(topic) else { return };
        if info.count == 0 {
            info.first_ns = h.log_time;
        }
        info.count += 1;
        info.last_ns = h.log_time;
        info.digest = digest_message(info.digest, h.log_time, data);
        if h.log_time < self.last_log_time {
            out.out_of_order += 1;
        }
        self.last_log_time = h.log_time;
        out.messages += 1;
        let t = h.log_time;
        fn push<T: DeserializeOwned>(v: &mut Vec<Stamped<T>>, t: u64, data: &[u8]) -> bool {
            serde_json::from_slice(data).map(|msg| v.push(Stamped { log_time: t, msg })).is_ok()
        }
        let ok = match topic.as_str() {
            topics::DECISION => push(&mut out.decisions, t, data),
            topics::EMITTED => push(&mut out.emitted, t, data),
            topics::DELIVERED => push(&mut out.delivered, t, data),
            topics::TELEPORT => push(&mut out.teleports, t, data),
            topics::CONTACT => push(&mut out.contacts, t, data),
            topics::LOG => push(&mut out.notes, t, data),
            crate::swarm::topics::STEP => push(&mut out.swarm_steps, t, data),
            topics::POSE => serde_json::from_slice::<m::PoseInFrame>(data)
                .map(|p| {
                    let q = p.pose.orientation;
                    out.poses.push(PoseStamp {
                        log_time: t,
                        x: p.pose.position.x,
                        y: p.pose.position.y,
                        theta: q.to_yaw(),
                    })
                })
                .is_ok(),
            topics::VISITS | topics::VALUE => match serde_json::from_slice::<m::Grid>(data) {
                Ok(g) => {
                    let slot =
                        if topic == topics::VISITS { &mut out.last_visits } else { &mut out.last_value };
                    *slot = Some(Stamped { log_time: t, msg: g });
                    true
                }
                Err(_) => false,
            },
            _ => serde_json::from_slice::<serde_json::Value>(data).is_ok(),
        };
        if !ok {
            info.undecodable += 1;
        }
    }
}
