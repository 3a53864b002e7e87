//! [`LogWriter`]: the recorder's side of the MCAP writer. Messages are appended to an
//! open chunk on the recording thread; closed chunks, metadata, attachments, flushes and
//! the end of the file go, in order, to an [`McapOut`] that compresses and writes them,
//! either on a writer thread of its own (the default) or inline.
//!
//! Both ways write the same bytes: what goes into which chunk is decided here, on the
//! recording thread, and the writer handles the jobs in the order they were sent (test
//! `the_writer_thread_writes_the_same_bytes`). The thread gets at most [`QUEUE`] closed
//! chunks ahead of it (the recording thread waits for it beyond that), so memory stays at
//! a few chunks; chunk buffers go back to the recording thread for reuse.
//!
//! Errors: the thread stops at its first I/O error and returns it; the recording thread
//! learns of it at its next hand-over (a closed chunk, a flush, the end), as a
//! [`Failure`] naming what the thread was doing. A panic of the thread becomes a
//! [`Failure`] too, carrying the panic message (the panic hook has printed it as well).
//! A flush waits until the thread has written everything sent before it, so a file
//! flushed is on disk up to that point, as with the inline writer.

use std::collections::BTreeMap;
use std::io::{self, Write};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender};
use std::thread::JoinHandle;

use crate::mcap_out::{McapOut, OpenChunk};

/// Closed chunks that may wait for the writer thread.
const QUEUE: usize = 2;

/// A write that failed: what was being done, and the cause.
#[derive(Debug)]
pub(crate) struct Failure {
    pub action: &'static str,
    pub source: io::Error,
}

impl Failure {
    fn at(action: &'static str) -> impl FnOnce(io::Error) -> Self {
        move |source| Self { action, source }
    }
}

/// Work for the writer.
enum Job {
    Chunk(OpenChunk),
    Metadata { name: String, map: BTreeMap<String, String> },
    Attach { name: String, media_type: String, log_time: u64, data: Vec<u8> },
    Flush,
    Finish,
}

impl Job {
    /// Does it (the same calls whether on the thread or inline).
    fn run<W: Write>(self, out: &mut McapOut<W>, chunk_done: impl FnOnce(OpenChunk)) -> Result<(), Failure> {
        match self {
            Job::Chunk(mut c) => {
                out.write_chunk(&mut c).map_err(Failure::at("write a chunk of messages"))?;
                chunk_done(c);
                Ok(())
            }
            Job::Metadata { name, map } => {
                out.metadata(&name, &map).map_err(Failure::at("write a metadata record"))
            }
            Job::Attach { name, media_type, log_time, data } => {
                out.attach(&name, &media_type, log_time, &data).map_err(Failure::at("write an attachment"))
            }
            Job::Flush => out.flush().map_err(Failure::at("flush the log")),
            Job::Finish => unreachable!("Finish is handled by the caller"),
        }
    }
}

/// What the writer hands back at the end: the output, and the message digests by
/// channel id ([`McapOut::digests`]).
type Finished<W> = (W, Vec<u64>);

/// The writer thread and the channels to it.
struct Worker<W> {
    jobs: SyncSender<Job>,
    /// The digests, once per flush done.
    flushed: Receiver<Vec<u64>>,
    /// Emptied chunk buffers coming back.
    spare: Receiver<OpenChunk>,
    thread: Option<JoinHandle<Result<Finished<W>, Failure>>>,
}

impl<W> Worker<W> {
    /// Waits for the thread to end and returns why it did (its error, or its panic).
    fn failure(&mut self) -> Failure {
        let Some(thread) = self.thread.take() else {
            return Failure {
                action: "write the log",
                source: io::Error::other("the writer thread has ended"),
            };
        };
        match thread.join() {
            Ok(Err(f)) => f,
            Ok(Ok(_)) => Failure {
                action: "write the log",
                source: io::Error::other("the writer thread ended before the log was finished"),
            },
            Err(panic) => Failure { action: "write the log", source: panicked(panic.as_ref()) },
        }
    }
}

fn panicked(payload: &(dyn std::any::Any + Send)) -> io::Error {
    let what = payload
        .downcast_ref::<&str>()
        .copied()
        .or_else(|| payload.downcast_ref::<String>().map(String::as_str))
        .unwrap_or("(no message)");
    io::Error::other(format!("the log writer thread panicked: {what}"))
}

/// The writer thread: does the jobs in order until `Finish` (returns the finished
/// output), its first error (returns it), or the recorder going away.
fn serve<W: Write>(
    mut out: McapOut<W>,
    jobs: Receiver<Job>,
    flushed: Sender<Vec<u64>>,
    spare: Sender<OpenChunk>,
) -> Result<Finished<W>, Failure> {
    while let Ok(job) = jobs.recv() {
        match job {
            Job::Finish => return finish(out),
            Job::Flush => {
                Job::Flush.run(&mut out, |_| {})?;
                // The recorder waits for this; if it has gone, nobody needs it.
                let _ = flushed.send(out.digests().to_vec());
            }
            job => job.run(&mut out, |c| {
                let _ = spare.send(c);
            })?,
        }
    }
    Err(Failure { action: "finish the log", source: io::Error::other("the recorder went away first") })
}

fn finish<W: Write>(out: McapOut<W>) -> Result<Finished<W>, Failure> {
    let digests = out.digests().to_vec();
    let w = out.finish().map_err(Failure::at("finish the log"))?;
    Ok((w, digests))
}

enum Back<W: Write> {
    Inline(Box<McapOut<W>>),
    Thread(Worker<W>),
}

/// Messages into chunks, and everything else to the [`McapOut`] (see the module
/// documentation). After an error the writer must not be used again (drop it; what was
/// written before stays a readable prefix).
pub(crate) struct LogWriter<W: Write> {
    chunk: OpenChunk,
    /// A chunk is closed once it holds this many uncompressed bytes.
    chunk_size: usize,
    channels: usize,
    /// Message digests by channel id as of the last flush (writer thread).
    digests: Vec<u64>,
    back: Back<W>,
}

impl<W: Write + Send + 'static> LogWriter<W> {
    /// Takes over `out` (header, schemas and channels written), on a thread of its own
    /// when `thread`.
    pub fn new(out: McapOut<W>, chunk_size: usize, thread: bool) -> io::Result<Self> {
        let channels = out.channel_count();
        let digests = out.digests().to_vec();
        let back = if thread {
            let (jobs, jobs_rx) = mpsc::sync_channel(QUEUE);
            let (flushed_tx, flushed) = mpsc::channel();
            let (spare_tx, spare) = mpsc::channel();
            let thread = std::thread::Builder::new()
                .name("mmq-log-writer".into())
                .spawn(move || serve(out, jobs_rx, flushed_tx, spare_tx))?;
            Back::Thread(Worker { jobs, flushed, spare, thread: Some(thread) })
        } else {
            Back::Inline(Box::new(out))
        };
        Ok(Self {
            chunk: OpenChunk::new(Self::capacity(chunk_size), channels),
            chunk_size,
            channels,
            digests,
            back,
        })
    }

    fn capacity(chunk_size: usize) -> usize {
        chunk_size + (64 << 10)
    }

    /// Appends a message (publish time = log time) whose data `write` appends to the
    /// vector it is given, to the open chunk; closes the chunk when it is full. `channel`
    /// must be one registered before [`Self::new`].
    pub fn message(
        &mut self,
        channel: u16,
        sequence: u32,
        log_time: u64,
        write: impl FnOnce(&mut Vec<u8>),
    ) -> Result<(), Failure> {
        self.chunk.message(channel, sequence, log_time, write);
        if self.chunk.len() >= self.chunk_size { self.close_chunk() } else { Ok(()) }
    }

    fn send(&mut self, job: Job) -> Result<(), Failure> {
        match &mut self.back {
            Back::Inline(out) => job.run(out, |_| {}),
            Back::Thread(w) => w.jobs.send(job).map_err(|_| w.failure()),
        }
    }

    /// Hands the open chunk (if it holds anything) to the writer.
    fn close_chunk(&mut self) -> Result<(), Failure> {
        if self.chunk.is_empty() {
            return Ok(());
        }
        match &mut self.back {
            Back::Inline(out) => {
                out.write_chunk(&mut self.chunk).map_err(Failure::at("write a chunk of messages"))
            }
            Back::Thread(w) => {
                let fresh = w
                    .spare
                    .try_recv()
                    .unwrap_or_else(|_| OpenChunk::new(Self::capacity(self.chunk_size), self.channels));
                let full = std::mem::replace(&mut self.chunk, fresh);
                self.send(Job::Chunk(full))
            }
        }
    }

    /// Closes the open chunk and writes everything sent so far to the file; returns when
    /// that is done.
    pub fn flush(&mut self) -> Result<(), Failure> {
        self.close_chunk()?;
        self.send(Job::Flush)?;
        if let Back::Thread(w) = &mut self.back {
            match w.flushed.recv() {
                Ok(d) => self.digests = d,
                Err(_) => return Err(w.failure()),
            }
        }
        Ok(())
    }

    /// Digest of the messages written, by channel id (index 0 is no channel), as of the
    /// last flush (complete after [`Self::finish`], which returns them).
    pub fn digests(&self) -> &[u64] {
        match &self.back {
            Back::Inline(out) => out.digests(),
            Back::Thread(_) => &self.digests,
        }
    }

    /// Writes a metadata record (after closing the open chunk).
    pub fn metadata(&mut self, name: &str, map: &BTreeMap<String, String>) -> Result<(), Failure> {
        self.close_chunk()?;
        self.send(Job::Metadata { name: name.into(), map: map.clone() })
    }

    /// Writes an attachment record (after closing the open chunk).
    pub fn attach(
        &mut self,
        name: &str,
        media_type: &str,
        log_time: u64,
        data: &[u8],
    ) -> Result<(), Failure> {
        self.close_chunk()?;
        self.send(Job::Attach {
            name: name.into(),
            media_type: media_type.into(),
            log_time,
            data: data.into(),
        })
    }

    /// Closes the open chunk, finishes the file (summary section, footer, end magic),
    /// waits for the writer thread, and returns the output and the message digests by
    /// channel id.
    pub fn finish(mut self) -> Result<Finished<W>, Failure> {
        self.close_chunk()?;
        match self.back {
            Back::Inline(out) => finish(*out),
            Back::Thread(mut w) => {
                if w.jobs.send(Job::Finish).is_err() {
                    return Err(w.failure());
                }
                match w.thread.take().map(JoinHandle::join) {
                    Some(Ok(r)) => r,
                    Some(Err(panic)) => {
                        Err(Failure { action: "write the log", source: panicked(panic.as_ref()) })
                    }
                    None => Err(w.failure()),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mcap_out::ChunkOptions;

    /// Accepts `limit` bytes, then fails (`panic` false: an I/O error, as a full disk) or
    /// panics.
    struct Limited {
        written: usize,
        limit: usize,
        panic: bool,
    }

    impl Write for Limited {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            if self.written + buf.len() > self.limit {
                assert!(!self.panic, "a bug in the output");
                return Err(io::Error::new(io::ErrorKind::StorageFull, "no space left"));
            }
            self.written += buf.len();
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    fn writer(limit: usize, panic: bool, thread: bool) -> LogWriter<Limited> {
        let mut out =
            McapOut::new(Limited { written: 0, limit, panic }, "test", ChunkOptions { level: 1 }).unwrap();
        let s = out.add_schema("s", "jsonschema", b"{}").unwrap();
        out.add_channel(s, "/t", "json").unwrap();
        LogWriter::new(out, 4096, thread).unwrap()
    }

    /// Writes messages until the writer reports a failure; returns it.
    fn first_failure(w: &mut LogWriter<Limited>) -> Failure {
        let msg = [b'x'; 300];
        for i in 0..10_000u32 {
            let r = w
                .message(1, i, u64::from(i), |o| o.extend_from_slice(&msg))
                .and_then(|()| if i % 50 == 49 { w.flush() } else { Ok(()) });
            if let Err(f) = r {
                return f;
            }
        }
        panic!("no failure reported");
    }

    #[test]
    fn write_errors_of_the_thread_reach_the_recorder() {
        for thread in [true, false] {
            let mut w = writer(20_000, false, thread);
            let f = first_failure(&mut w);
            assert_eq!(f.source.kind(), io::ErrorKind::StorageFull, "thread {thread}: {f:?}");
            assert!(matches!(f.action, "write a chunk of messages" | "flush the log"), "{f:?}");
        }
        // An error met while finishing too (the open chunk is the first written).
        let mut w = writer(300, false, true);
        for i in 0..5u32 {
            w.message(1, i, 0, |o| o.extend_from_slice(&[b'y'; 300])).unwrap();
        }
        let f = w.finish().map(|_| ()).unwrap_err();
        assert_eq!(f.source.kind(), io::ErrorKind::StorageFull, "{f:?}");
    }

    #[test]
    fn a_panic_of_the_thread_is_reported_with_its_message() {
        let mut w = writer(20_000, true, true);
        let f = first_failure(&mut w);
        let text = f.source.to_string();
        assert!(text.contains("panicked") && text.contains("a bug in the output"), "{text}");
        // Later calls keep failing rather than hang or panic.
        assert!(w.flush().is_err());
        assert!(w.finish().is_err());
    }

    #[test]
    fn a_finished_log_is_whole() {
        for thread in [true, false] {
            let mut w = writer(usize::MAX, false, thread);
            for i in 0..1000u32 {
                w.message(1, i, u64::from(i), |o| o.extend_from_slice(format!("{{\"i\":{i}}}").as_bytes()))
                    .unwrap();
            }
            let (out, _) = w.finish().map_err(|f| f.source).unwrap();
            assert!(out.written > 1000 * 31 / 20, "{}", out.written);
        }
    }
}
