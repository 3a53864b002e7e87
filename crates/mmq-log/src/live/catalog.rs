//! What the served replay knows of its file without holding its messages: one pass of
//! the hardened walker (`reader/walk.rs`) builds a [`Catalog`] — the channels, the time
//! range, and an index of blocks (a chunk, or a run of messages outside chunks) with the
//! byte offset, the time span and the latched topics of each — and a [`Cursor`] streams
//! the messages from any block on. Memory stays bounded whatever the file's size: the
//! index holds a few numbers per chunk, a cursor one chunk.

use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use foxglove::{Context, RawChannel, Schema};
use mcap::records::Record;

use crate::error::LogError;
use crate::messages::LATCHED;
use crate::reader::walk::{Inner, Item, SchemaRec, Stop, Walker};

/// Messages outside chunks gathered into one block.
const LOOSE_BLOCK: u32 = 4096;

/// A message to play: (channel slot, log time, bytes).
pub(crate) type Msg = (usize, u64, Vec<u8>);

/// A run of messages read together: a chunk, or messages outside chunks.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Block {
    /// Offset of its first top-level record.
    pub offset: u64,
    /// Earliest and latest log time of its messages, ns.
    pub first: u64,
    pub last: u64,
    /// Latched slots with a message in it, one bit per latched slot ([`Catalog::bit`]).
    pub latched: u64,
    /// A chunk (else messages outside chunks).
    chunk: bool,
    messages: u32,
}

/// The channels and the block index of a file.
pub(crate) struct Catalog {
    pub path: PathBuf,
    pub channels: Vec<Arc<RawChannel>>,
    /// Channel slot of each MCAP channel id.
    by_id: HashMap<u16, usize>,
    /// Bit of each latched slot in [`Block::latched`] (at most 64 latched channels).
    bit: Vec<Option<u32>>,
    pub blocks: Vec<Block>,
    /// First and last log time, ns.
    pub range: (u64, u64),
    pub messages: u64,
    /// What could not be read (damaged chunks, where reading stopped).
    pub warnings: Vec<String>,
}

/// Why a catalog could not be made.
#[derive(Debug)]
pub(crate) enum CatalogError {
    /// The stop flag was raised.
    Interrupted,
    Log(LogError),
}

impl From<LogError> for CatalogError {
    fn from(e: LogError) -> Self {
        Self::Log(e)
    }
}

impl Catalog {
    /// Reads `path` once, creating a channel of `ctx` per MCAP channel; stops early when
    /// `stop` is raised. A file with no message to play is an error that says why.
    pub fn build(ctx: &Arc<Context>, path: &Path, stop: &AtomicBool) -> Result<Self, CatalogError> {
        let mut walker = Walker::open(path)?;
        let mut cat = Catalog {
            path: path.to_path_buf(),
            channels: Vec::new(),
            by_id: HashMap::new(),
            bit: Vec::new(),
            blocks: Vec::new(),
            range: (u64::MAX, 0),
            messages: 0,
            warnings: Vec::new(),
        };
        let mut schemas: HashMap<u16, SchemaRec> = HashMap::new();
        loop {
            if stop.load(Ordering::Relaxed) {
                return Err(CatalogError::Interrupted);
            }
            let (offset, item) = match walker.next() {
                Ok(Some(x)) => x,
                Ok(None) => break,
                Err(Stop::Io(e)) => return Err(e.into()),
                Err(Stop::At { reason, .. }) => {
                    cat.warnings.push(format!(
                        "reading stopped at byte {} of {} ({reason}); what comes before it is served",
                        walker.offset(),
                        walker.file_len()
                    ));
                    break;
                }
            };
            match item {
                Item::Chunk(inner) => {
                    cat.blocks.push(Block::new(offset, true));
                    for r in inner {
                        match r {
                            Inner::Schema(id, s) => {
                                schemas.insert(id, s);
                            }
                            Inner::Channel(c) => cat.channel(ctx, &c, &schemas)?,
                            Inner::Message(h, _) => cat.message(h.channel_id, h.log_time),
                        }
                    }
                }
                Item::Damaged { reason, start_ns, end_ns } => cat.warnings.push(format!(
                    "the chunk at byte {offset} (log times {start_ns} to {end_ns} ns) cannot be read ({reason}); skipped"
                )),
                Item::Other(Record::Schema { header, data }) => {
                    let text = String::from_utf8_lossy(&data).into_owned();
                    schemas.insert(header.id, SchemaRec { name: header.name, encoding: header.encoding, text });
                }
                Item::Other(Record::Channel(c)) => cat.channel(ctx, &c, &schemas)?,
                Item::Other(Record::Message { header, .. }) => {
                    let open = cat.blocks.last().is_some_and(|b| !b.chunk && b.messages < LOOSE_BLOCK);
                    if !open {
                        cat.blocks.push(Block::new(offset, false));
                    }
                    cat.message(header.channel_id, header.log_time);
                }
                // The summary section repeats what came before.
                Item::Other(Record::DataEnd(_)) => break,
                Item::Other(_) => {}
            }
        }
        cat.blocks.retain(|b| b.messages > 0);
        if cat.messages == 0 {
            let why = match cat.warnings.first() {
                Some(w) => format!("no message could be read: {w}"),
                None => "the file holds no message to play".to_string(),
            };
            return Err(LogError::Unreadable { path: path.to_path_buf(), message: why }.into());
        }
        Ok(cat)
    }

    fn channel(
        &mut self,
        ctx: &Arc<Context>,
        c: &mcap::records::Channel,
        schemas: &HashMap<u16, SchemaRec>,
    ) -> Result<(), CatalogError> {
        if self.by_id.contains_key(&c.id) {
            return Ok(());
        }
        let mut b = ctx.channel_builder(c.topic.clone()).message_encoding(c.message_encoding.clone());
        if let Some(s) = schemas.get(&c.schema_id) {
            b = b.schema(Schema::new(s.name.clone(), s.encoding.clone(), s.text.as_bytes().to_vec()));
        }
        let ch = b.build_raw().map_err(|e| LogError::Unreadable {
            path: self.path.clone(),
            message: format!("cannot serve topic {}: {e}", c.topic),
        })?;
        let latched = LATCHED.contains(&c.topic.as_str());
        let used = self.bit.iter().flatten().count() as u32;
        self.bit.push((latched && used < 64).then_some(used));
        self.by_id.insert(c.id, self.channels.len());
        self.channels.push(ch);
        Ok(())
    }

    fn message(&mut self, channel_id: u16, log_time: u64) {
        let Some(&slot) = self.by_id.get(&channel_id) else { return };
        let Some(b) = self.blocks.last_mut() else { return };
        if b.messages == 0 {
            (b.first, b.last) = (log_time, log_time);
        }
        b.first = b.first.min(log_time);
        b.last = b.last.max(log_time);
        b.messages += 1;
        if let Some(bit) = self.bit[slot] {
            b.latched |= 1 << bit;
        }
        self.messages += 1;
        self.range = (self.range.0.min(log_time), self.range.1.max(log_time));
    }

    /// Whether the channel slot is latched (its last message goes to every new
    /// subscriber and is re-sent on a seek).
    pub fn latched(&self, slot: usize) -> bool {
        self.bit.get(slot).is_some_and(Option::is_some)
    }

    /// Index of the first block holding messages at or after `t` (blocks in file order,
    /// the recorder's times non-decreasing).
    pub fn block_at(&self, t: u64) -> usize {
        self.blocks.partition_point(|b| b.last < t)
    }

    /// The last message of every latched slot at or before `t`, read from the blocks
    /// that hold them (one block per latched topic at most, when times go forward).
    pub fn latched_at(&self, t: u64) -> Result<Vec<Msg>, LogError> {
        let mut out = Vec::new();
        let upto = self.blocks.partition_point(|b| b.first <= t);
        for (slot, bit) in self.bit.iter().enumerate() {
            let Some(bit) = bit else { continue };
            for i in (0..upto).rev().filter(|&i| self.blocks[i].latched & (1 << bit) != 0) {
                let mut cursor = Cursor::open(self, i, i + 1, 0)?;
                let mut found = None;
                while let Some((s, time, data)) = cursor.next(self)? {
                    if s == slot && time <= t {
                        found = Some((s, time, data));
                    }
                }
                if let Some(m) = found {
                    out.push(m);
                    break;
                }
            }
        }
        out.sort_by_key(|m| m.1);
        Ok(out)
    }
}

impl Block {
    fn new(offset: u64, chunk: bool) -> Self {
        Self { offset, first: 0, last: 0, latched: 0, chunk, messages: 0 }
    }
}

/// Messages of a file in file order from a block on, one block in memory at a time.
pub(crate) struct Cursor {
    walker: Walker,
    /// Messages of the block read last, not yet taken.
    pending: VecDeque<Msg>,
    /// Index of the next block to read.
    block: usize,
    /// Index of the block where reading stops.
    until: usize,
    /// Messages before this log time are skipped (a seek).
    from: u64,
}

impl Cursor {
    /// A cursor at block `block`, skipping messages before `from`, up to block `until`
    /// (excluded).
    pub fn open(cat: &Catalog, block: usize, until: usize, from: u64) -> Result<Self, LogError> {
        let offset = cat.blocks.get(block).map_or(mcap::MAGIC.len() as u64, |b| b.offset);
        let walker = Walker::open_at(&cat.path, offset)?;
        let until = until.min(cat.blocks.len());
        Ok(Self { walker, pending: VecDeque::new(), block, until, from })
    }

    /// The next message (`None` at the end of what can be read).
    pub fn next(&mut self, cat: &Catalog) -> Result<Option<Msg>, LogError> {
        self.peek_time(cat)?;
        Ok(self.pending.pop_front())
    }

    /// Log time of the next message, reading ahead a block as needed.
    pub fn peek_time(&mut self, cat: &Catalog) -> Result<Option<u64>, LogError> {
        while self.pending.is_empty() {
            if !self.fill(cat)? {
                return Ok(None);
            }
        }
        Ok(self.pending.front().map(|m| m.1))
    }

    /// Reads the next block; returns whether there was one.
    fn fill(&mut self, cat: &Catalog) -> Result<bool, LogError> {
        if self.block >= self.until {
            return Ok(false);
        }
        let end = cat.blocks.get(self.block + 1).map_or(u64::MAX, |b| b.offset);
        self.block += 1;
        // Records up to the next block (the chunk, its message indexes; or the messages
        // outside chunks).
        while self.walker.offset() < end {
            let item = match self.walker.next() {
                Ok(Some((_, item))) => item,
                Ok(None) | Err(Stop::At { .. }) => break,
                Err(Stop::Io(e)) => return Err(e),
            };
            let mut take = |id: u16, t: u64, data: Vec<u8>| {
                if let Some(&slot) = cat.by_id.get(&id)
                    && t >= self.from
                {
                    self.pending.push_back((slot, t, data));
                }
            };
            match item {
                Item::Chunk(inner) => {
                    for r in inner {
                        if let Inner::Message(h, data) = r {
                            take(h.channel_id, h.log_time, data);
                        }
                    }
                }
                Item::Other(Record::Message { header, data }) => {
                    take(header.channel_id, header.log_time, data.into_owned());
                }
                Item::Other(Record::DataEnd(_)) => break,
                _ => {}
            }
        }
        Ok(true)
    }
}
