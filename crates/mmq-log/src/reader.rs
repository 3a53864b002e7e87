//! Reading logs back: [`read_log`] streams an MCAP file record by record with the `mcap`
//! crate's linear reader and keeps whatever is readable. A truncated or damaged file gives
//! the messages before the damage and a [`ReadStop`] saying where reading stopped, never
//! a panic.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use mcap::records::Record;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mmq_core::{World, WorldError};
use serde::de::DeserializeOwned;

use crate::error::LogError;
use crate::messages::{self as m, topics};
use crate::recorder::{DIGEST_START, digest_message};

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
    /// Messages read, all topics.
    pub messages: u64,
    /// The file was read to its end magic, and what was read agrees with the file's own
    /// statistics (no [`LogContents::problems`]).
    pub complete: bool,
    /// Where reading stopped early, if it did.
    pub stop: Option<ReadStop>,
    /// What is wrong with a file that reads to its end: message counts that disagree with
    /// its statistics record (a chunk removed or duplicated), payloads that do not decode.
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

#[derive(Debug)]
struct SchemaRec {
    name: String,
    encoding: String,
    text: String,
}

/// Reads a log, keeping what is readable.
///
/// Returns `Err` only when the file cannot be opened or is not an MCAP file at all; a
/// truncated or damaged file returns its readable prefix with [`LogContents::stop`] set.
/// Chunks are kept whole or not at all: a chunk that fails to decompress or to match its
/// CRC ends the reading at its first byte.
pub fn read_log(path: impl AsRef<Path>) -> Result<LogContents, LogError> {
    let path = path.as_ref();
    let io_err = |action, source| LogError::Io { path: path.to_path_buf(), action, source };
    // A FIFO would block the open forever, a device never end: only regular files.
    if std::fs::metadata(path).is_ok_and(|m| !m.is_file()) {
        return Err(io_err(
            "read the log",
            std::io::Error::other(
                "not a regular file (a FIFO, device or folder); give the path of an MCAP file",
            ),
        ));
    }
    let file = File::open(path).map_err(|e| io_err("open the log", e))?;
    let file_len = file.metadata().map_err(|e| io_err("read the log", e))?.len();
    let mut input = BufReader::with_capacity(1 << 16, file);
    // A file that does not start like an MCAP file is not a damaged log but another file.
    let head = input.fill_buf().map_err(|e| io_err("read the log", e))?;
    let n = head.len().min(mcap::MAGIC.len());
    if head[..n] != mcap::MAGIC[..n] {
        return Err(LogError::NotMcap { path: path.to_path_buf() });
    }
    let mut out = LogContents { path: path.to_path_buf(), file_len, ..Default::default() };
    let mut st = State::default();
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_emit_chunks(true)
            .with_record_length_limit(usize::try_from(file_len).unwrap_or(usize::MAX)),
    );
    // Offset of the next top-level record: the start magic, then opcode + length + body.
    let mut offset: u64 = mcap::MAGIC.len() as u64;
    let mut records_read = 0u64;
    let mut in_data_section = true;
    let stop_reason = loop {
        let Some(event) = reader.next_event() else { break None };
        match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let buf = reader.insert(need);
                let n = loop {
                    match input.read(buf) {
                        Ok(n) => break Ok(n),
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                        Err(e) => break Err(e),
                    }
                };
                match n {
                    Ok(n) => reader.notify_read(n),
                    Err(e) => return Err(io_err("read the log", e)),
                }
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                let len = 9 + data.len() as u64;
                let raw = (opcode, data);
                let result = check_lengths(opcode, data)
                    .and_then(|()| mcap::parse_record(opcode, data).map_err(|e| e.to_string()))
                    .and_then(|rec| st.top_level(rec, raw, &mut out, &mut in_data_section));
                if let Err(reason) = result {
                    break Some(reason);
                }
                offset += len;
                records_read += 1;
            }
            Err(mcap::McapError::BadMagic) if records_read == 0 && offset == mcap::MAGIC.len() as u64 => {
                return Err(LogError::NotMcap { path: path.to_path_buf() });
            }
            Err(mcap::McapError::UnexpectedEof) => {
                break Some(if records_read == 0 {
                    "the file ends before its first record".to_string()
                } else if offset >= file_len {
                    "the file ends without its summary and end magic (the run was not finished)".to_string()
                } else {
                    "the file ends in the middle of a record (truncated)".to_string()
                });
            }
            Err(mcap::McapError::RecordTooLarge { opcode, len: u64::MAX })
                if opcode == mcap::records::op::CHUNK =>
            {
                // The writer gives a chunk its length when it closes it.
                break Some("the file ends in an unfinished chunk (the run was not finished)".to_string());
            }
            Err(e) => break Some(e.to_string()),
        }
    };
    match stop_reason {
        None => {
            out.problems = st.problems(&out);
            out.complete = out.problems.is_empty();
        }
        Some(reason) => {
            // A file too short to hold the start magic stops at its first byte.
            let offset = if file_len < mcap::MAGIC.len() as u64 { 0 } else { offset };
            out.stop = Some(ReadStop { offset, file_len, messages: out.messages, reason });
        }
    }
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
}

/// A record from inside a chunk, owned until the whole chunk has been checked.
enum Pending {
    Schema(u16, SchemaRec),
    Channel(mcap::records::Channel),
    Message(mcap::records::MessageHeader, Vec<u8>),
}

impl State {
    fn top_level(
        &mut self,
        rec: Record<'_>,
        raw: (u8, &[u8]),
        out: &mut LogContents,
        data: &mut bool,
    ) -> Result<(), String> {
        match rec {
            Record::Chunk { .. } => {
                for p in read_chunk(raw)? {
                    match p {
                        Pending::Schema(id, s) => {
                            self.schemas.insert(id, s);
                        }
                        Pending::Channel(c) => self.channel(c, out),
                        Pending::Message(h, d) => self.message(h, &d, out),
                    }
                }
            }
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
        Ok(())
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

/// Checks that every length prefix inside a record body (strings, byte arrays, maps and
/// arrays, per the MCAP specification's layout of each opcode) fits in the body, before
/// the `mcap` crate parses it: the crate reserves a prefix's length before reading, so a
/// damaged 4-byte length in a 30 KiB file would otherwise allocate 4 GiB (found by
/// fuzzing; `tests/regressions/mcap_read/`).
fn check_lengths(opcode: u8, body: &[u8]) -> Result<(), String> {
    use mcap::records::op;
    struct Cursor<'a> {
        rest: &'a [u8],
        opcode: u8,
    }
    impl Cursor<'_> {
        fn skip(&mut self, n: u64) -> Result<(), String> {
            match usize::try_from(n).ok().filter(|&n| n <= self.rest.len()) {
                Some(n) => {
                    self.rest = &self.rest[n..];
                    Ok(())
                }
                None => Err(format!(
                    "damaged record (opcode 0x{:02x}): a length of {n} bytes exceeds the {} left in the record",
                    self.opcode,
                    self.rest.len()
                )),
            }
        }
        fn len(&mut self, width: usize) -> Result<u64, String> {
            if self.rest.len() < width {
                // Too short for the prefix itself: the parser reports it without allocating.
                self.rest = &[];
                return Ok(0);
            }
            let mut b = [0u8; 8];
            b[..width].copy_from_slice(&self.rest[..width]);
            self.rest = &self.rest[width..];
            Ok(u64::from_le_bytes(b))
        }
        /// A u32- or u64-prefixed run of bytes (string, byte array, map or array).
        fn prefixed(&mut self, width: usize) -> Result<(), String> {
            let n = self.len(width)?;
            self.skip(n)
        }
        /// A map of string to string, read as the crate reads it: key-value pairs while
        /// fewer than the map's byte length were read, so the last pair may run past the
        /// map (and every prefix is checked against the whole record).
        fn string_map(&mut self) -> Result<(), String> {
            let n = self.len(4)?;
            let start = self.rest.len();
            while ((start - self.rest.len()) as u64) < n && !self.rest.is_empty() {
                self.prefixed(4)?;
                self.prefixed(4)?;
            }
            Ok(())
        }
    }
    let mut c = Cursor { rest: body, opcode };
    let fixed = |c: &mut Cursor<'_>, n: u64| c.skip(n.min(c.rest.len() as u64));
    match opcode {
        op::HEADER => {
            c.prefixed(4)?;
            c.prefixed(4)
        }
        op::SCHEMA => {
            fixed(&mut c, 2)?;
            c.prefixed(4)?;
            c.prefixed(4)?;
            c.prefixed(4)
        }
        op::CHANNEL => {
            fixed(&mut c, 4)?;
            c.prefixed(4)?;
            c.prefixed(4)?;
            c.string_map()
        }
        op::CHUNK => {
            fixed(&mut c, 28)?;
            c.prefixed(4)?;
            c.prefixed(8)
        }
        op::MESSAGE_INDEX => {
            fixed(&mut c, 2)?;
            c.prefixed(4)
        }
        op::CHUNK_INDEX => {
            fixed(&mut c, 32)?;
            c.prefixed(4)?;
            fixed(&mut c, 8)?;
            c.prefixed(4)
        }
        op::ATTACHMENT => {
            fixed(&mut c, 16)?;
            c.prefixed(4)?;
            c.prefixed(4)?;
            // Data length, data, CRC: the crate slices up to 4 bytes before the end
            // after the length field, and panics when fewer than 4 bytes follow it.
            if c.rest.len() < 12 {
                return Err(format!(
                    "damaged record (opcode 0x{opcode:02x}): {} bytes left for an attachment's data length and CRC (12 at least)",
                    c.rest.len()
                ));
            }
            let n = c.len(8)?;
            c.rest = &c.rest[..c.rest.len() - 4];
            c.skip(n)
        }
        op::ATTACHMENT_INDEX => {
            fixed(&mut c, 40)?;
            c.prefixed(4)?;
            c.prefixed(4)
        }
        op::STATISTICS => {
            fixed(&mut c, 42)?;
            c.prefixed(4)
        }
        op::METADATA => {
            c.prefixed(4)?;
            c.string_map()
        }
        op::METADATA_INDEX => {
            fixed(&mut c, 16)?;
            c.prefixed(4)
        }
        _ => Ok(()),
    }
}

/// Largest uncompressed chunk accepted: a damaged size field must not make the reader
/// allocate without bound.
fn chunk_limit(compressed_len: usize) -> usize {
    compressed_len.saturating_mul(64).clamp(64 << 20, 1 << 30)
}

/// Decodes one chunk record (`opcode`, body) with the crate's own linear reader, which
/// checks the chunk's CRC before yielding anything from it and bounds every buffer.
fn read_chunk((opcode, body): (u8, &[u8])) -> Result<Vec<Pending>, String> {
    let mut bytes = Vec::with_capacity(9 + body.len());
    bytes.push(opcode);
    bytes.extend_from_slice(&(body.len() as u64).to_le_bytes());
    bytes.extend_from_slice(body);
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(chunk_limit(body.len())),
    );
    let mut input: &[u8] = &bytes;
    let mut pending = Vec::new();
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| format!("damaged chunk: {e}"))? {
            LinearReadEvent::ReadRequest(need) => {
                let n = need.min(input.len());
                reader.insert(n).copy_from_slice(&input[..n]);
                reader.notify_read(n);
                input = &input[n..];
            }
            LinearReadEvent::Record { opcode, data } => {
                check_lengths(opcode, data).map_err(|e| format!("damaged chunk: {e}"))?;
                match mcap::parse_record(opcode, data).map_err(|e| format!("damaged chunk: {e}"))? {
                    Record::Schema { header, data } => pending.push(Pending::Schema(
                        header.id,
                        SchemaRec {
                            name: header.name,
                            encoding: header.encoding,
                            text: String::from_utf8_lossy(&data).into_owned(),
                        },
                    )),
                    Record::Channel(c) => pending.push(Pending::Channel(c)),
                    Record::Message { header, data } => {
                        pending.push(Pending::Message(header, data.into_owned()))
                    }
                    _ => {}
                }
            }
        }
    }
    Ok(pending)
}
