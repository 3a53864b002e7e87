//! A small MCAP writer for the recorder's hot path: JSON messages appended to an in-memory
//! chunk ([`OpenChunk`]), each chunk compressed in one zstd call when it is full or
//! flushed ([`McapOut::write_chunk`]); both on the recorder's writer thread, or inline
//! (see `writer.rs`).
//!
//! It writes what the `mcap` crate's writer writes (same records, same layout: chunks with
//! a message index per channel after each, a summary section with schemas, channels,
//! statistics, chunk/attachment/metadata indexes and summary offsets, every CRC filled
//! in), without that writer's per-message costs: seven small writes through a streaming
//! compressor and two map look-ups per message. Schemas and channels are written once,
//! as top-level records, before any chunk. The record layouts are those of the MCAP
//! specification (<https://mcap.dev/spec>); `mcap::records::op` gives the opcodes.
//!
//! Why a chunk is compressed whole and at once rather than streamed: a message is ~230
//! bytes, and feeding the zstd stream seven pieces of it cost as much as compressing it.

use std::io::{self, Write};

use mcap::records::op;

use crate::recorder::{DIGEST_START, digest_message};

/// Compression of the chunks (zstd, the only codec mmq logs use).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ChunkOptions {
    /// zstd level (1 is zstd's fastest standard level; negative levels trade size for speed).
    pub level: i32,
}

/// Bytes of a message record before its data: opcode, length, channel id, sequence, log
/// time, publish time.
const MESSAGE_HEAD: usize = 1 + 8 + 2 + 4 + 8 + 8;

/// The chunk being filled: its message records, uncompressed, and their message index
/// entries. Filled by [`OpenChunk::message`]; written (and emptied) by
/// [`McapOut::write_chunk`]; the same buffers are reused from chunk to chunk.
#[derive(Debug)]
pub(crate) struct OpenChunk {
    /// Message records, uncompressed.
    records: Vec<u8>,
    /// Message index entries (log time, offset in the chunk), by channel id.
    entries: Vec<Vec<(u64, u64)>>,
}

impl OpenChunk {
    /// An empty chunk for `channels` channels (ids 1..=channels), with room for
    /// `capacity` bytes of records.
    pub fn new(capacity: usize, channels: usize) -> Self {
        Self { records: Vec::with_capacity(capacity), entries: vec![Vec::new(); channels + 1] }
    }

    /// Uncompressed bytes so far.
    pub fn len(&self) -> usize {
        self.records.len()
    }

    pub fn is_empty(&self) -> bool {
        self.records.is_empty()
    }

    /// Appends a message (publish time = log time) whose data `write` appends to the
    /// vector it is given (the chunk itself: the data is not copied). `channel` must be a
    /// registered id (at most the `channels` given to [`Self::new`]).
    pub fn message(&mut self, channel: u16, sequence: u32, log_time: u64, write: impl FnOnce(&mut Vec<u8>)) {
        let at = self.records.len();
        self.records.extend_from_slice(&[0; MESSAGE_HEAD]);
        write(&mut self.records);
        let len = (self.records.len() - at - 9) as u64;
        let head = &mut self.records[at..at + MESSAGE_HEAD];
        head[0] = op::MESSAGE;
        head[1..9].copy_from_slice(&len.to_le_bytes());
        head[9..11].copy_from_slice(&channel.to_le_bytes());
        head[11..15].copy_from_slice(&sequence.to_le_bytes());
        head[15..23].copy_from_slice(&log_time.to_le_bytes());
        head[23..31].copy_from_slice(&log_time.to_le_bytes());
        self.entries[usize::from(channel)].push((log_time, at as u64));
    }

    /// The data of the message whose record starts at `at`.
    fn data(&self, at: usize) -> &[u8] {
        let len = u64::from_le_bytes(self.records[at + 1..at + 9].try_into().expect("8 bytes")) as usize;
        &self.records[at + MESSAGE_HEAD..at + 9 + len]
    }

    fn clear(&mut self) {
        self.records.clear();
        for e in &mut self.entries {
            e.clear();
        }
    }
}

/// Little-endian record building.
trait Put {
    fn u16(&mut self, v: u16);
    fn u32(&mut self, v: u32);
    fn u64(&mut self, v: u64);
    fn str(&mut self, s: &str);
    fn str_map<'a>(&mut self, m: impl IntoIterator<Item = (&'a String, &'a String)>);
}

impl Put for Vec<u8> {
    fn u16(&mut self, v: u16) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.extend_from_slice(&v.to_le_bytes());
    }
    fn str(&mut self, s: &str) {
        self.u32(s.len() as u32);
        self.extend_from_slice(s.as_bytes());
    }
    fn str_map<'a>(&mut self, m: impl IntoIterator<Item = (&'a String, &'a String)>) {
        let at = self.len();
        self.u32(0);
        for (k, v) in m {
            self.str(k);
            self.str(v);
        }
        let n = (self.len() - at - 4) as u32;
        self[at..at + 4].copy_from_slice(&n.to_le_bytes());
    }
}

/// Appends a whole record (opcode, length, body) to `out`.
fn record(out: &mut Vec<u8>, opcode: u8, body: &[u8]) {
    out.push(opcode);
    out.u64(body.len() as u64);
    out.extend_from_slice(body);
}

struct Schema {
    id: u16,
    name: String,
    encoding: String,
    data: Vec<u8>,
}

struct Channel {
    id: u16,
    schema_id: u16,
    topic: String,
    message_encoding: String,
}

/// Writes one MCAP file to `out`. Any I/O error leaves the writer unusable (the caller
/// drops it); the bytes already written stay a readable prefix.
pub(crate) struct McapOut<W: Write> {
    out: W,
    /// Bytes written to `out`.
    pos: u64,
    /// CRC of the data section so far.
    data_crc: crc32fast::Hasher,
    zstd: zstd::bulk::Compressor<'static>,
    compressed: Vec<u8>,
    scratch: Vec<u8>,
    schemas: Vec<Schema>,
    channels: Vec<Channel>,
    /// Messages per channel id.
    counts: Vec<u64>,
    /// Digest of the messages written, per channel id ([`digest_message`]).
    digests: Vec<u64>,
    bounds: Option<(u64, u64)>,
    /// Serialized summary records, by group.
    chunk_indexes: Vec<u8>,
    chunk_count: u32,
    attachment_indexes: Vec<u8>,
    attachment_count: u32,
    metadata_indexes: Vec<u8>,
    metadata_count: u32,
}

impl<W: Write> McapOut<W> {
    /// Writes the magic and the header record.
    pub fn new(out: W, library: &str, opts: ChunkOptions) -> io::Result<Self> {
        let mut w = Self {
            out,
            pos: 0,
            data_crc: crc32fast::Hasher::new(),
            zstd: zstd::bulk::Compressor::new(opts.level)?,
            compressed: Vec::new(),
            scratch: Vec::with_capacity(256),
            schemas: Vec::new(),
            channels: Vec::new(),
            counts: Vec::new(),
            digests: Vec::new(),
            bounds: None,
            chunk_indexes: Vec::new(),
            chunk_count: 0,
            attachment_indexes: Vec::new(),
            attachment_count: 0,
            metadata_indexes: Vec::new(),
            metadata_count: 0,
        };
        w.emit(mcap::MAGIC)?;
        let mut body = Vec::new();
        body.str(""); // profile
        body.str(library);
        w.top_level(op::HEADER, &body)?;
        Ok(w)
    }

    /// Writes `bytes` to the data section.
    fn emit(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.out.write_all(bytes)?;
        self.data_crc.update(bytes);
        self.pos += bytes.len() as u64;
        Ok(())
    }

    fn top_level(&mut self, opcode: u8, body: &[u8]) -> io::Result<()> {
        let mut head = [0u8; 9];
        head[0] = opcode;
        head[1..].copy_from_slice(&(body.len() as u64).to_le_bytes());
        self.emit(&head)?;
        self.emit(body)
    }

    /// Registers a schema (an identical one already registered is reused) and writes it.
    pub fn add_schema(&mut self, name: &str, encoding: &str, data: &[u8]) -> io::Result<u16> {
        if let Some(s) =
            self.schemas.iter().find(|s| s.name == name && s.encoding == encoding && s.data == data)
        {
            return Ok(s.id);
        }
        let id = self.schemas.len() as u16 + 1;
        let s = Schema { id, name: name.into(), encoding: encoding.into(), data: data.into() };
        let mut body = Vec::new();
        schema_body(&mut body, &s);
        self.top_level(op::SCHEMA, &body)?;
        self.schemas.push(s);
        Ok(id)
    }

    /// Registers a channel (no metadata) and writes it.
    pub fn add_channel(&mut self, schema_id: u16, topic: &str, message_encoding: &str) -> io::Result<u16> {
        let id = self.channels.len() as u16 + 1;
        let c = Channel { id, schema_id, topic: topic.into(), message_encoding: message_encoding.into() };
        let mut body = Vec::new();
        channel_body(&mut body, &c);
        self.top_level(op::CHANNEL, &body)?;
        self.channels.push(c);
        self.counts.resize(usize::from(id) + 1, 0);
        self.digests.resize(usize::from(id) + 1, DIGEST_START);
        Ok(id)
    }

    /// Channels registered so far (their ids are 1..=this).
    pub fn channel_count(&self) -> usize {
        self.channels.len()
    }

    /// Digest of the messages written so far (in chunks written), by channel id (index 0
    /// is no channel): [`digest_message`] folded over each channel's messages in order.
    pub fn digests(&self) -> &[u64] {
        &self.digests
    }

    /// Compresses and writes `chunk` (if it holds anything) and its message indexes, and
    /// empties it.
    pub fn write_chunk(&mut self, chunk: &mut OpenChunk) -> io::Result<()> {
        if chunk.is_empty() {
            return Ok(());
        }
        let (mut start, mut end) = (u64::MAX, 0);
        for (c, entries) in chunk.entries.iter().enumerate() {
            let mut digest = self.digests[c];
            for &(t, at) in entries {
                start = start.min(t);
                end = end.max(t);
                digest = digest_message(digest, t, chunk.data(at as usize));
            }
            self.digests[c] = digest;
            self.counts[c] += entries.len() as u64;
        }
        let uncompressed_crc = crc32fast::hash(&chunk.records);
        self.compressed.clear();
        self.compressed.reserve(zstd::zstd_safe::compress_bound(chunk.records.len()));
        self.zstd.compress_to_buffer(chunk.records.as_slice(), &mut self.compressed)?;
        let chunk_start = self.pos;
        let mut head = std::mem::take(&mut self.scratch);
        head.clear();
        head.push(op::CHUNK);
        head.u64(8 + 8 + 8 + 4 + (4 + 4) + 8 + self.compressed.len() as u64);
        head.u64(start);
        head.u64(end);
        head.u64(chunk.records.len() as u64);
        head.u32(uncompressed_crc);
        head.str("zstd");
        head.u64(self.compressed.len() as u64);
        let r = self.emit(&head);
        self.scratch = head;
        r?;
        let compressed = std::mem::take(&mut self.compressed);
        let r = self.emit(&compressed);
        self.compressed = compressed;
        r?;
        let chunk_length = self.pos - chunk_start;
        // Message indexes, by channel id, for the channels with messages in the chunk.
        let index_start = self.pos;
        let mut offsets: Vec<(u16, u64)> = Vec::new();
        let mut body = std::mem::take(&mut self.scratch);
        for (c, entries) in chunk.entries.iter().enumerate() {
            if entries.is_empty() {
                continue;
            }
            offsets.push((c as u16, self.pos));
            body.clear();
            body.push(op::MESSAGE_INDEX);
            body.u64(2 + 4 + 16 * entries.len() as u64);
            body.u16(c as u16);
            body.u32(16 * entries.len() as u32);
            for &(t, o) in entries {
                body.u64(t);
                body.u64(o);
            }
            if let Err(e) = self.emit(&body) {
                self.scratch = body;
                return Err(e);
            }
        }
        self.scratch = body;
        let index_length = self.pos - index_start;
        let mut ci = Vec::with_capacity(96);
        ci.u64(start);
        ci.u64(end);
        ci.u64(chunk_start);
        ci.u64(chunk_length);
        ci.u32(10 * offsets.len() as u32);
        for (c, o) in offsets {
            ci.u16(c);
            ci.u64(o);
        }
        ci.u64(index_length);
        ci.str("zstd");
        ci.u64(self.compressed.len() as u64);
        ci.u64(chunk.records.len() as u64);
        record(&mut self.chunk_indexes, op::CHUNK_INDEX, &ci);
        self.chunk_count += 1;
        self.bounds = Some(match self.bounds {
            None => (start, end),
            Some((a, b)) => (a.min(start), b.max(end)),
        });
        chunk.clear();
        Ok(())
    }

    /// Flushes `out`.
    pub fn flush(&mut self) -> io::Result<()> {
        self.out.flush()
    }

    /// Writes a metadata record.
    pub fn metadata(
        &mut self,
        name: &str,
        map: &std::collections::BTreeMap<String, String>,
    ) -> io::Result<()> {
        let mut body = Vec::new();
        body.str(name);
        body.str_map(map);
        let offset = self.pos;
        self.top_level(op::METADATA, &body)?;
        let mut ix = Vec::new();
        ix.u64(offset);
        ix.u64(self.pos - offset);
        ix.str(name);
        record(&mut self.metadata_indexes, op::METADATA_INDEX, &ix);
        self.metadata_count += 1;
        Ok(())
    }

    /// Writes an attachment record.
    pub fn attach(&mut self, name: &str, media_type: &str, log_time: u64, data: &[u8]) -> io::Result<()> {
        let mut body = Vec::new();
        body.u64(log_time);
        body.u64(log_time); // create time
        body.str(name);
        body.str(media_type);
        body.u64(data.len() as u64);
        body.extend_from_slice(data);
        let crc = crc32fast::hash(&body);
        body.u32(crc);
        let offset = self.pos;
        self.top_level(op::ATTACHMENT, &body)?;
        let mut ix = Vec::new();
        ix.u64(offset);
        ix.u64(self.pos - offset);
        ix.u64(log_time);
        ix.u64(log_time);
        ix.u64(data.len() as u64);
        ix.str(name);
        ix.str(media_type);
        record(&mut self.attachment_indexes, op::ATTACHMENT_INDEX, &ix);
        self.attachment_count += 1;
        Ok(())
    }

    /// Writes the data end, the summary section, the footer and the end magic, flushes,
    /// and returns `out`.
    pub fn finish(mut self) -> io::Result<W> {
        let mut body = Vec::new();
        body.u32(self.data_crc.clone().finalize());
        self.top_level(op::DATA_END, &body)?;
        let summary_start = self.pos;
        let mut s: Vec<u8> = Vec::with_capacity(self.chunk_indexes.len() + (64 << 10));
        let mut groups: Vec<(u8, u64, u64)> = Vec::new();
        let mut group = |s: &mut Vec<u8>, opcode: u8, from: usize| {
            if s.len() > from {
                groups.push((opcode, summary_start + from as u64, (s.len() - from) as u64));
            }
        };
        let at = s.len();
        for sc in &self.schemas {
            body.clear();
            schema_body(&mut body, sc);
            record(&mut s, op::SCHEMA, &body);
        }
        group(&mut s, op::SCHEMA, at);
        let at = s.len();
        for c in &self.channels {
            body.clear();
            channel_body(&mut body, c);
            record(&mut s, op::CHANNEL, &body);
        }
        group(&mut s, op::CHANNEL, at);
        let at = s.len();
        let (start, end) = self.bounds.unwrap_or((0, 0));
        body.clear();
        body.u64(self.counts.iter().sum());
        body.u16(self.schemas.len() as u16);
        body.u32(self.channels.len() as u32);
        body.u32(self.attachment_count);
        body.u32(self.metadata_count);
        body.u32(self.chunk_count);
        body.u64(start);
        body.u64(end);
        let used: Vec<(u16, u64)> =
            self.counts.iter().enumerate().filter(|(_, n)| **n > 0).map(|(c, n)| (c as u16, *n)).collect();
        body.u32(10 * used.len() as u32);
        for (c, n) in used {
            body.u16(c);
            body.u64(n);
        }
        record(&mut s, op::STATISTICS, &body);
        group(&mut s, op::STATISTICS, at);
        for (opcode, records) in [
            (op::CHUNK_INDEX, &self.chunk_indexes),
            (op::ATTACHMENT_INDEX, &self.attachment_indexes),
            (op::METADATA_INDEX, &self.metadata_indexes),
        ] {
            let at = s.len();
            s.extend_from_slice(records);
            group(&mut s, opcode, at);
        }
        let offsets_start = summary_start + s.len() as u64;
        for (opcode, from, len) in groups {
            body.clear();
            body.push(opcode);
            body.u64(from);
            body.u64(len);
            record(&mut s, op::SUMMARY_OFFSET, &body);
        }
        s.push(op::FOOTER);
        s.u64(20);
        s.u64(summary_start);
        s.u64(offsets_start);
        let crc = crc32fast::hash(&s);
        s.u32(crc);
        s.extend_from_slice(mcap::MAGIC);
        self.out.write_all(&s)?;
        self.out.flush()?;
        Ok(self.out)
    }
}

fn schema_body(body: &mut Vec<u8>, s: &Schema) {
    body.u16(s.id);
    body.str(&s.name);
    body.str(&s.encoding);
    body.u32(s.data.len() as u32);
    body.extend_from_slice(&s.data);
}

fn channel_body(body: &mut Vec<u8>, c: &Channel) {
    body.u16(c.id);
    body.u16(c.schema_id);
    body.str(&c.topic);
    body.str(&c.message_encoding);
    body.u32(0); // no metadata
}
