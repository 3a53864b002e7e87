//! The hardened record walker under every reader of logs ([`crate::read_log`], the served
//! replay): streams an MCAP file top-level record by top-level record with the `mcap`
//! crate's linear reader, one record in memory at a time, every length prefix checked
//! against its record before the crate parses it, every chunk decompressed within a bound
//! and checked against its CRC before anything of it is used.
//!
//! Only regular files are read (a FIFO would block, a device never end). A chunk whose
//! framing is intact but whose contents are damaged (CRC, compression) is skipped and
//! reported ([`Item::Damaged`]); reading goes on after it. Anything else that cannot be
//! read ends the walk ([`Stop`]), saying whether the file was cut short there (an
//! interrupted write) or is damaged with bytes after the damage.

use std::fs::File;
use std::io::{BufRead, BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use mcap::records::{Channel, MessageHeader, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

use crate::error::LogError;

/// A schema record's contents.
#[derive(Clone, Debug)]
pub(crate) struct SchemaRec {
    pub name: String,
    pub encoding: String,
    pub text: String,
}

/// A record from inside a chunk (owned: the chunk was checked whole first).
#[derive(Debug)]
pub(crate) enum Inner {
    Schema(u16, SchemaRec),
    Channel(Channel),
    Message(MessageHeader, Vec<u8>),
}

/// One top-level record.
#[derive(Debug)]
pub(crate) enum Item {
    /// A chunk, read whole: its schemas, channels and messages in file order.
    Chunk(Vec<Inner>),
    /// A chunk whose framing is intact but whose contents cannot be read (CRC,
    /// compression, a damaged record inside): skipped.
    Damaged {
        /// Why.
        reason: String,
        /// The chunk header's first and last message time, ns.
        start_ns: u64,
        end_ns: u64,
    },
    /// Any other record (a schema, channel or message outside chunks, metadata, an
    /// attachment, statistics, indexes, ...).
    Other(Record<'static>),
}

/// Why a walk ended before the file's end magic.
#[derive(Debug)]
pub(crate) enum Stop {
    /// The file cannot be read at all (an I/O error).
    Io(LogError),
    /// Reading stopped at a record.
    At {
        /// Why.
        reason: String,
        /// The file ends there (cut short, e.g. an interrupted write) rather than
        /// holding damaged bytes with more of the file after them.
        cut: bool,
    },
}

/// A walk over the top-level records of one file.
pub(crate) struct Walker {
    path: PathBuf,
    input: BufReader<File>,
    reader: LinearReader,
    /// Offset of the next top-level record.
    offset: u64,
    file_len: u64,
    /// Top-level records read.
    records: u64,
    /// The walk started at the file's start (not at an offset).
    from_start: bool,
}

impl std::fmt::Debug for Walker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Walker")
            .field("path", &self.path)
            .field("offset", &self.offset)
            .finish_non_exhaustive()
    }
}

/// Opens a regular file for reading, with its length.
fn open_regular(path: &Path) -> Result<(File, u64), LogError> {
    let io_err = |action, source| LogError::Io { path: path.to_path_buf(), action, source };
    // A FIFO would block the open forever, a device never end: only regular files.
    let meta = std::fs::metadata(path).map_err(|e| io_err("read the log", e))?;
    if !meta.is_file() {
        let what = if meta.is_dir() { "a folder" } else { "not a regular file (a FIFO, socket or device)" };
        return Err(io_err(
            "read the log",
            std::io::Error::other(format!("{what}; give the path of an MCAP file")),
        ));
    }
    let file = File::open(path).map_err(|e| io_err("open the log", e))?;
    let file_len = file.metadata().map_err(|e| io_err("read the log", e))?.len();
    Ok((file, file_len))
}

impl Walker {
    /// Opens `path` at its start. A file that does not start like an MCAP file is
    /// [`LogError::NotMcap`].
    pub fn open(path: &Path) -> Result<Self, LogError> {
        let (file, file_len) = open_regular(path)?;
        let mut input = BufReader::with_capacity(1 << 16, file);
        let head = input.fill_buf().map_err(|e| LogError::Io {
            path: path.to_path_buf(),
            action: "read the log",
            source: e,
        })?;
        let n = head.len().min(mcap::MAGIC.len());
        if head[..n] != mcap::MAGIC[..n] {
            return Err(LogError::NotMcap { path: path.to_path_buf() });
        }
        Ok(Self::new(path, input, file_len, mcap::MAGIC.len() as u64, true))
    }

    /// Opens `path` at the top-level record at `offset` (one a previous walk reported).
    pub fn open_at(path: &Path, offset: u64) -> Result<Self, LogError> {
        let (mut file, file_len) = open_regular(path)?;
        file.seek(SeekFrom::Start(offset)).map_err(|e| LogError::Io {
            path: path.to_path_buf(),
            action: "read the log",
            source: e,
        })?;
        Ok(Self::new(path, BufReader::with_capacity(1 << 16, file), file_len, offset, false))
    }

    fn new(path: &Path, input: BufReader<File>, file_len: u64, offset: u64, from_start: bool) -> Self {
        let reader = LinearReader::new_with_options(
            LinearReaderOptions::default()
                .with_skip_start_magic(!from_start)
                .with_emit_chunks(true)
                .with_record_length_limit(usize::try_from(file_len).unwrap_or(usize::MAX)),
        );
        Self { path: path.to_path_buf(), input, reader, offset, file_len, records: 0, from_start }
    }

    /// The file's size, bytes.
    pub fn file_len(&self) -> u64 {
        self.file_len
    }

    /// Offset of the next top-level record (after a [`Stop`]: of the record that could
    /// not be read).
    pub fn offset(&self) -> u64 {
        self.offset
    }

    /// The next top-level record and its offset; `Ok(None)` at the end magic.
    pub fn next(&mut self) -> Result<Option<(u64, Item)>, Stop> {
        loop {
            let Some(event) = self.reader.next_event() else { return Ok(None) };
            match event {
                Ok(LinearReadEvent::ReadRequest(need)) => {
                    let buf = self.reader.insert(need);
                    let n = loop {
                        match self.input.read(buf) {
                            Ok(n) => break n,
                            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                            Err(e) => {
                                return Err(Stop::Io(LogError::Io {
                                    path: self.path.clone(),
                                    action: "read the log",
                                    source: e,
                                }));
                            }
                        }
                    };
                    self.reader.notify_read(n);
                }
                Ok(LinearReadEvent::Record { opcode, data }) => {
                    let at = self.offset;
                    let item = check_lengths(opcode, data)
                        .and_then(|()| mcap::parse_record(opcode, data).map_err(|e| e.to_string()))
                        .map(|rec| match rec {
                            Record::Chunk { header, .. } => match read_chunk((opcode, data)) {
                                Ok(inner) => Item::Chunk(inner),
                                Err(reason) => Item::Damaged {
                                    reason,
                                    start_ns: header.message_start_time,
                                    end_ns: header.message_end_time,
                                },
                            },
                            other => Item::Other(other.into_owned()),
                        });
                    let len = 9 + data.len() as u64;
                    return match item {
                        Ok(item) => {
                            self.offset += len;
                            self.records += 1;
                            Ok(Some((at, item)))
                        }
                        // The record's bytes are all there: damage, not a cut.
                        Err(reason) => Err(Stop::At { reason, cut: false }),
                    };
                }
                Err(mcap::McapError::BadMagic)
                    if self.from_start && self.records == 0 && self.offset == mcap::MAGIC.len() as u64 =>
                {
                    return Err(Stop::Io(LogError::NotMcap { path: self.path.clone() }));
                }
                Err(mcap::McapError::UnexpectedEof) => {
                    let reason = if self.records == 0 && self.from_start {
                        "the file ends before its first record"
                    } else if self.offset >= self.file_len {
                        "the file ends without its summary and end magic (the run was not finished)"
                    } else {
                        "the file ends in the middle of a record (truncated)"
                    };
                    return Err(Stop::At { reason: reason.to_string(), cut: true });
                }
                Err(mcap::McapError::RecordTooLarge { opcode, len: u64::MAX })
                    if opcode == mcap::records::op::CHUNK =>
                {
                    // The writer gives a chunk its length when it closes it.
                    return Err(Stop::At {
                        reason: "the file ends in an unfinished chunk (the run was not finished)".to_string(),
                        cut: true,
                    });
                }
                Err(mcap::McapError::RecordTooLarge { len, .. }) => {
                    // A record said to run past the end of the file: cut there, or a
                    // damaged length (the two look the same).
                    return Err(Stop::At {
                        reason: format!(
                            "a record of {len} bytes at byte {} runs past the end of the file (truncated or damaged)",
                            self.offset
                        ),
                        cut: true,
                    });
                }
                Err(e) => return Err(Stop::At { reason: e.to_string(), cut: false }),
            }
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
fn read_chunk((opcode, body): (u8, &[u8])) -> Result<Vec<Inner>, String> {
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
    let mut inner = Vec::new();
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
                    Record::Schema { header, data } => inner.push(Inner::Schema(
                        header.id,
                        SchemaRec {
                            name: header.name,
                            encoding: header.encoding,
                            text: String::from_utf8_lossy(&data).into_owned(),
                        },
                    )),
                    Record::Channel(c) => inner.push(Inner::Channel(c)),
                    Record::Message { header, data } => inner.push(Inner::Message(header, data.into_owned())),
                    _ => {}
                }
            }
        }
    }
    Ok(inner)
}
