//! [`LogWriter`]: the recorder's side of the MCAP writer. The recording thread puts the
//! messages, in order, into batches: JSON it has serialized, or just the numbers of a
//! pose. A [`Sink`] turns batches into chunks (formats the poses, closes a chunk once it
//! holds 1 MiB, compresses and writes it, with metadata, attachments, flushes and the end
//! of the file in between), either on a writer thread of its own (the default) or inline.
//!
//! Both ways write the same bytes: the sink sees the same messages and markers in the
//! same order, and everything it does depends only on them (test
//! `the_writer_thread_writes_the_same_bytes`). The thread gets at most [`QUEUE`] batches
//! ahead of it (the recording thread waits for it beyond that), so memory stays small;
//! batch buffers go back to the recording thread for reuse.
//!
//! Errors: the thread stops at its first I/O error and returns it; the recording thread
//! learns of it at its next hand-over (a batch, a flush, the end), as a [`Failure`]
//! naming what the thread was doing. A panic of the thread becomes a [`Failure`] too,
//! carrying the panic message (the panic hook has printed it as well). A flush waits
//! until the thread has written everything sent before it, so a file flushed is on disk
//! up to that point, as with the inline writer.

use std::collections::BTreeMap;
use std::io::{self, Write};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender};
use std::thread::JoinHandle;

use crate::mcap_out::{McapOut, OpenChunk};
use crate::messages as m;

/// Batches that may wait for the writer thread.
const QUEUE: usize = 2;

/// Messages per batch.
const BATCH: usize = 4096;

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

/// One message to write.
#[derive(Clone, Copy, Debug)]
enum Item {
    /// JSON serialized by the recording thread: the batch's bytes from the previous
    /// `Json` item's end to `end`.
    Json { channel: u16, log_time: u64, end: usize },
    /// A pose: `foxglove.FrameTransform` world → robot on channel `tf`, then
    /// `foxglove.PoseInFrame` in frame world on channel `pose`, both at `log_time`.
    Pose { tf: u16, pose: u16, log_time: u64, x: f64, y: f64, theta: f64 },
    /// A swarm robot's pose: `foxglove.FrameTransform` world → `robot<robot>` (or
    /// `robot<robot>_estimate`) on channel `tf`.
    Transform { tf: u16, log_time: u64, robot: u32, estimate: bool, x: f64, y: f64, theta: f64 },
}

/// Messages in the order written.
#[derive(Debug, Default)]
struct Batch {
    items: Vec<Item>,
    bytes: Vec<u8>,
}

impl Batch {
    fn clear(&mut self) {
        self.items.clear();
        self.bytes.clear();
    }
}

/// Work for the writer.
enum Job {
    Batch(Batch),
    Metadata { name: String, map: BTreeMap<String, String> },
    Attach { name: String, media_type: String, log_time: u64, data: Vec<u8> },
    Flush,
    Finish,
}

/// What the writer hands back at the end: the output, and the message digests by
/// channel id ([`McapOut::digests`]).
type Finished<W> = (W, Vec<u64>);

/// Messages into chunks into the file; the same on the writer thread or inline.
struct Sink<W: Write> {
    out: McapOut<W>,
    chunk: OpenChunk,
    /// A chunk is closed once it holds this many uncompressed bytes.
    chunk_size: usize,
    /// Next sequence number, by channel id.
    sequence: Vec<u32>,
    pose: PoseJson,
}

impl<W: Write> Sink<W> {
    fn new(out: McapOut<W>, chunk_size: usize) -> Self {
        let channels = out.channel_count();
        Self {
            out,
            chunk: OpenChunk::new(chunk_size + (64 << 10), channels),
            chunk_size,
            sequence: vec![0; channels + 1],
            pose: PoseJson::default(),
        }
    }

    fn message(
        &mut self,
        channel: u16,
        log_time: u64,
        write: impl FnOnce(&mut Vec<u8>),
    ) -> Result<(), Failure> {
        let seq = &mut self.sequence[usize::from(channel)];
        self.chunk.message(channel, *seq, log_time, write);
        *seq = seq.wrapping_add(1);
        if self.chunk.len() >= self.chunk_size { self.close_chunk() } else { Ok(()) }
    }

    fn close_chunk(&mut self) -> Result<(), Failure> {
        self.out.write_chunk(&mut self.chunk).map_err(Failure::at("write a chunk of messages"))
    }

    fn batch(&mut self, b: &Batch) -> Result<(), Failure> {
        let mut from = 0;
        for item in &b.items {
            match *item {
                Item::Json { channel, log_time, end } => {
                    self.message(channel, log_time, |out| out.extend_from_slice(&b.bytes[from..end]))?;
                    from = end;
                }
                Item::Transform { tf, log_time, robot, estimate, x, y, theta } => {
                    let mut p = std::mem::take(&mut self.pose);
                    p.set(log_time, x, y, theta);
                    let r = self.message(tf, log_time, |out| p.robot_transform(out, robot, estimate));
                    self.pose = p;
                    r?;
                }
                Item::Pose { tf, pose, log_time, x, y, theta } => {
                    let mut p = std::mem::take(&mut self.pose);
                    p.set(log_time, x, y, theta);
                    let r = self
                        .message(tf, log_time, |out| p.frame_transform(out))
                        .and_then(|()| self.message(pose, log_time, |out| p.pose_in_frame(out)));
                    self.pose = p;
                    r?;
                }
            }
        }
        Ok(())
    }

    /// Does `job` (not `Finish`); returns the emptied batch of a `Batch` job.
    fn run(&mut self, job: Job) -> Result<Option<Batch>, Failure> {
        match job {
            Job::Batch(mut b) => {
                self.batch(&b)?;
                b.clear();
                return Ok(Some(b));
            }
            Job::Metadata { name, map } => {
                self.close_chunk()?;
                self.out.metadata(&name, &map).map_err(Failure::at("write a metadata record"))?;
            }
            Job::Attach { name, media_type, log_time, data } => {
                self.close_chunk()?;
                self.out
                    .attach(&name, &media_type, log_time, &data)
                    .map_err(Failure::at("write an attachment"))?;
            }
            Job::Flush => {
                self.close_chunk()?;
                self.out.flush().map_err(Failure::at("flush the log"))?;
            }
            Job::Finish => unreachable!("Sink::finish ends the file"),
        }
        Ok(None)
    }

    fn finish(mut self) -> Result<Finished<W>, Failure> {
        self.close_chunk()?;
        let digests = self.out.digests().to_vec();
        let w = self.out.finish().map_err(Failure::at("finish the log"))?;
        Ok((w, digests))
    }
}

/// The writer thread and the channels to it.
struct Worker<W> {
    jobs: SyncSender<Job>,
    /// The digests, once per flush done.
    flushed: Receiver<Vec<u64>>,
    /// Emptied batches coming back.
    spare: Receiver<Batch>,
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
    mut sink: Sink<W>,
    jobs: Receiver<Job>,
    flushed: Sender<Vec<u64>>,
    spare: Sender<Batch>,
) -> Result<Finished<W>, Failure> {
    while let Ok(job) = jobs.recv() {
        match job {
            Job::Finish => return sink.finish(),
            Job::Flush => {
                sink.run(Job::Flush)?;
                // The recorder waits for this; if it has gone, nobody needs it.
                let _ = flushed.send(sink.out.digests().to_vec());
            }
            job => {
                if let Some(b) = sink.run(job)? {
                    let _ = spare.send(b);
                }
            }
        }
    }
    Err(Failure { action: "finish the log", source: io::Error::other("the recorder went away first") })
}

enum Back<W: Write> {
    Inline(Box<Sink<W>>),
    Thread(Worker<W>),
}

/// Messages into batches, and batches and everything else to the [`Sink`] (see the
/// module documentation). After an error the writer must not be used again (drop it;
/// what was written before stays a readable prefix).
pub(crate) struct LogWriter<W: Write> {
    batch: Batch,
    /// Message digests by channel id as of the last flush (writer thread).
    digests: Vec<u64>,
    back: Back<W>,
}

impl<W: Write + Send + 'static> LogWriter<W> {
    /// Takes over `out` (header, schemas and channels written), on a thread of its own
    /// when `thread`; chunks are closed once they hold `chunk_size` bytes.
    pub fn new(out: McapOut<W>, chunk_size: usize, thread: bool) -> io::Result<Self> {
        let digests = out.digests().to_vec();
        let sink = Sink::new(out, chunk_size);
        let back = if thread {
            let (jobs, jobs_rx) = mpsc::sync_channel(QUEUE);
            let (flushed_tx, flushed) = mpsc::channel();
            let (spare_tx, spare) = mpsc::channel();
            let thread = std::thread::Builder::new()
                .name("mmq-log-writer".into())
                .spawn(move || serve(sink, jobs_rx, flushed_tx, spare_tx))?;
            Back::Thread(Worker { jobs, flushed, spare, thread: Some(thread) })
        } else {
            Back::Inline(Box::new(sink))
        };
        Ok(Self { batch: Self::new_batch(), digests, back })
    }

    fn new_batch() -> Batch {
        Batch { items: Vec::with_capacity(BATCH), bytes: Vec::with_capacity(64 << 10) }
    }

    /// Writes a message (publish time = log time; sequence numbers counted per channel)
    /// whose JSON `write` appends to the vector it is given. `channel` must be one
    /// registered before [`Self::new`].
    pub fn message(
        &mut self,
        channel: u16,
        log_time: u64,
        write: impl FnOnce(&mut Vec<u8>),
    ) -> Result<(), Failure> {
        write(&mut self.batch.bytes);
        let end = self.batch.bytes.len();
        self.push(Item::Json { channel, log_time, end })
    }

    /// Writes a pose (see [`PoseJson`]) as `foxglove.FrameTransform` on channel `tf` and
    /// `foxglove.PoseInFrame` on channel `pose`; the JSON is written by the sink.
    pub fn pose(
        &mut self,
        tf: u16,
        pose: u16,
        log_time: u64,
        x: f64,
        y: f64,
        theta: f64,
    ) -> Result<(), Failure> {
        self.push(Item::Pose { tf, pose, log_time, x, y, theta })
    }

    /// Writes a swarm robot's pose (see [`PoseJson::robot_transform`]) on channel `tf`;
    /// the JSON is written by the sink.
    #[allow(clippy::too_many_arguments)]
    pub fn robot_transform(
        &mut self,
        tf: u16,
        log_time: u64,
        robot: u32,
        estimate: bool,
        x: f64,
        y: f64,
        theta: f64,
    ) -> Result<(), Failure> {
        self.push(Item::Transform { tf, log_time, robot, estimate, x, y, theta })
    }

    fn push(&mut self, item: Item) -> Result<(), Failure> {
        self.batch.items.push(item);
        if self.batch.items.len() >= BATCH || self.batch.bytes.len() >= 1 << 20 {
            self.hand_over()
        } else {
            Ok(())
        }
    }

    fn send(&mut self, job: Job) -> Result<(), Failure> {
        match &mut self.back {
            Back::Inline(sink) => sink.run(job).map(|_| ()),
            Back::Thread(w) => w.jobs.send(job).map_err(|_| w.failure()),
        }
    }

    /// Hands the batch (if it holds anything) to the sink.
    fn hand_over(&mut self) -> Result<(), Failure> {
        if self.batch.items.is_empty() {
            return Ok(());
        }
        match &mut self.back {
            Back::Inline(sink) => {
                let r = sink.batch(&self.batch);
                self.batch.clear();
                r
            }
            Back::Thread(w) => {
                let fresh = w.spare.try_recv().unwrap_or_else(|_| Self::new_batch());
                let full = std::mem::replace(&mut self.batch, fresh);
                self.send(Job::Batch(full))
            }
        }
    }

    /// Closes the open chunk and writes everything sent so far to the file; returns when
    /// that is done.
    pub fn flush(&mut self) -> Result<(), Failure> {
        self.hand_over()?;
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
            Back::Inline(sink) => sink.out.digests(),
            Back::Thread(_) => &self.digests,
        }
    }

    /// Writes a metadata record (after closing the open chunk).
    pub fn metadata(&mut self, name: &str, map: &BTreeMap<String, String>) -> Result<(), Failure> {
        self.hand_over()?;
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
        self.hand_over()?;
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
        self.hand_over()?;
        match self.back {
            Back::Inline(sink) => sink.finish(),
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

/// The JSON of one pose, byte for byte as serde_json writes [`m::FrameTransform`] and
/// [`m::PoseInFrame`] (test `pose_json_is_serde_json_s`), written by hand: the numbers are
/// formatted once for both messages, and the position (orientation) is reused as it is
/// while x and y (θ) stay the same bit for bit (a robot turning in place, or waiting).
#[derive(Default)]
pub(crate) struct PoseJson {
    /// `"timestamp":{"sec":…,"nsec":…}`.
    time: Vec<u8>,
    /// `{"x":…,"y":…,"z":0.0}`.
    position: Vec<u8>,
    /// `{"x":0.0,"y":0.0,"z":…,"w":…}`.
    orientation: Vec<u8>,
    /// Bits of the x, y and θ formatted.
    xy: Option<(u64, u64)>,
    theta: Option<u64>,
}

/// Appends `v` as serde_json writes an `f64` (shortest round-trip form; `null` when not
/// finite).
fn json_f64(out: &mut Vec<u8>, v: f64) {
    if v.to_bits() == 0 {
        out.extend_from_slice(b"0.0");
    } else if v.is_finite() {
        out.extend_from_slice(zmij::Buffer::new().format_finite(v).as_bytes());
    } else {
        out.extend_from_slice(b"null");
    }
}

impl PoseJson {
    pub(crate) fn set(&mut self, log_time: u64, x: f64, y: f64, theta: f64) {
        let t = m::Time::from_ns(log_time);
        let mut ib = itoa::Buffer::new();
        let b = &mut self.time;
        b.clear();
        b.extend_from_slice(b"\"timestamp\":{\"sec\":");
        b.extend_from_slice(ib.format(t.sec).as_bytes());
        b.extend_from_slice(b",\"nsec\":");
        b.extend_from_slice(ib.format(t.nsec).as_bytes());
        b.push(b'}');
        let xy = (x.to_bits(), y.to_bits());
        if self.xy != Some(xy) {
            self.xy = Some(xy);
            let b = &mut self.position;
            b.clear();
            b.extend_from_slice(b"{\"x\":");
            json_f64(b, x);
            b.extend_from_slice(b",\"y\":");
            json_f64(b, y);
            b.extend_from_slice(b",\"z\":0.0}");
        }
        if self.theta != Some(theta.to_bits()) {
            self.theta = Some(theta.to_bits());
            let q = m::Quaternion::yaw(theta);
            let b = &mut self.orientation;
            b.clear();
            b.extend_from_slice(b"{\"x\":");
            json_f64(b, q.x);
            b.extend_from_slice(b",\"y\":");
            json_f64(b, q.y);
            b.extend_from_slice(b",\"z\":");
            json_f64(b, q.z);
            b.extend_from_slice(b",\"w\":");
            json_f64(b, q.w);
            b.push(b'}');
        }
    }

    /// `foxglove.FrameTransform`, world → robot.
    pub(crate) fn frame_transform(&self, out: &mut Vec<u8>) {
        out.push(b'{');
        out.extend_from_slice(&self.time);
        out.extend_from_slice(
            b",\"parent_frame_id\":\"world\",\"child_frame_id\":\"robot\",\"translation\":",
        );
        out.extend_from_slice(&self.position);
        out.extend_from_slice(b",\"rotation\":");
        out.extend_from_slice(&self.orientation);
        out.push(b'}');
    }

    /// `foxglove.FrameTransform`, world → `robot<robot>` (`robot<robot>_estimate` when
    /// `estimate`): a swarm robot's frame.
    pub(crate) fn robot_transform(&self, out: &mut Vec<u8>, robot: u32, estimate: bool) {
        out.push(b'{');
        out.extend_from_slice(&self.time);
        out.extend_from_slice(b",\"parent_frame_id\":\"world\",\"child_frame_id\":\"robot");
        out.extend_from_slice(itoa::Buffer::new().format(robot).as_bytes());
        if estimate {
            out.extend_from_slice(b"_estimate");
        }
        out.extend_from_slice(b"\",\"translation\":");
        out.extend_from_slice(&self.position);
        out.extend_from_slice(b",\"rotation\":");
        out.extend_from_slice(&self.orientation);
        out.push(b'}');
    }

    /// `foxglove.PoseInFrame` in frame world.
    pub(crate) fn pose_in_frame(&self, out: &mut Vec<u8>) {
        out.push(b'{');
        out.extend_from_slice(&self.time);
        out.extend_from_slice(b",\"frame_id\":\"world\",\"pose\":{\"position\":");
        out.extend_from_slice(&self.position);
        out.extend_from_slice(b",\"orientation\":");
        out.extend_from_slice(&self.orientation);
        out.extend_from_slice(b"}}");
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
                .message(1, u64::from(i), |o| o.extend_from_slice(&msg))
                .and_then(|()| if i % 50 == 49 { w.flush() } else { Ok(()) });
            if let Err(f) = r {
                return f;
            }
        }
        panic!("no failure reported");
    }

    #[test]
    fn pose_json_is_serde_json_s() {
        let mut r = 0x1234_5678_9abc_def0u64;
        let mut next = || {
            r = mmq_core::seed::splitmix64(r);
            r
        };
        let mut values = vec![0.0, -0.0, 1.0, -1.5, 1e-300, 3.758157253265381, 1e21, f64::NAN, f64::INFINITY];
        values.extend((0..200).map(|_| f64::from_bits(next() >> 2) % 1e3 - 500.0));
        values.extend((0..50).map(|_| (next() as f32 / 7.0) as f64));
        let n = values.len();
        // One PoseJson throughout, as in a run: the position or the orientation stays
        // from one pose to the next in two of every three poses (reused as formatted).
        let mut p = PoseJson::default();
        let poses = (0..n).flat_map(|i| {
            let (x, y, th) = (values[i], values[(i * 7 + 3) % n], values[(i * 13 + 1) % n]);
            let (x2, th2) = (values[(i * 5 + 2) % n], values[(i * 11 + 4) % n]);
            [(i, x, y, th), (i + 1, x, y, th2), (i + 2, x2, y, th2)]
        });
        for (i, x, y, th) in poses {
            let t = [0, 999_999_999, 1_000_000_000, next(), u64::MAX][i % 5];
            p.set(t, x, y, th);
            let ts = m::Time::from_ns(t);
            let mut got = Vec::new();
            p.frame_transform(&mut got);
            let tf = m::FrameTransform {
                timestamp: ts,
                parent_frame_id: "world".into(),
                child_frame_id: "robot".into(),
                translation: m::Vector3 { x, y, z: 0.0 },
                rotation: m::Quaternion::yaw(th),
            };
            assert_eq!(String::from_utf8(got).unwrap(), serde_json::to_string(&tf).unwrap());
            let mut got = Vec::new();
            p.pose_in_frame(&mut got);
            let pose = m::PoseInFrame {
                timestamp: ts,
                frame_id: "world".into(),
                pose: m::Pose::planar(x, y, 0.0, th),
            };
            assert_eq!(String::from_utf8(got).unwrap(), serde_json::to_string(&pose).unwrap());
            let (robot, estimate) = ((i % 17) as u32, i % 2 == 0);
            let mut got = Vec::new();
            p.robot_transform(&mut got, robot, estimate);
            let child = format!("robot{robot}{}", if estimate { "_estimate" } else { "" });
            let tf = m::FrameTransform { child_frame_id: child, ..tf };
            assert_eq!(String::from_utf8(got).unwrap(), serde_json::to_string(&tf).unwrap());
        }
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
        for _ in 0..5 {
            w.message(1, 0, |o| o.extend_from_slice(&[b'y'; 300])).unwrap();
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
                w.message(1, u64::from(i), |o| o.extend_from_slice(format!("{{\"i\":{i}}}").as_bytes()))
                    .unwrap();
            }
            let (out, _) = w.finish().map_err(|f| f.source).unwrap();
            assert!(out.written > 1000 * 31 / 20, "{}", out.written);
        }
    }
}
