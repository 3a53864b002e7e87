//! The live view and the replay server, seen by a WebSocket client speaking Foxglove's
//! protocol (subprotocol `foxglove.sdk.v1`): what arrives validates against the
//! advertised schemas, latched scenes reach late subscribers, seeking works, a client
//! that leaves does not hold the run, and stopping frees the port. Servers bind to free
//! ports on 127.0.0.1 only.

use std::collections::HashMap;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use mmq_log::live::{LiveConfig, LiveServer, parse_addr, replay};
use mmq_log::messages::topics;
use mmq_log::{McapRecorder, RecorderConfig};
use serde_json::Value;
use tungstenite::client::IntoClientRequest;
use tungstenite::{Message, WebSocket};

use crate::common;
use crate::schemas::check;

/// A message from the server.
#[derive(Debug)]
pub(crate) enum In {
    Json(Value),
    Data { sub: u32, log_time: u64, payload: Vec<u8> },
    Time(u64),
    Playback { status: u8, current: u64, did_seek: bool },
    Closed,
}

/// A Foxglove WebSocket client.
pub(crate) struct Client {
    pub(crate) ws: WebSocket<TcpStream>,
    /// Advertised channels by topic: (id, schema).
    pub(crate) channels: HashMap<String, (u64, Value)>,
    /// Subscription id → topic.
    subs: HashMap<u32, String>,
    /// The server's `serverInfo`.
    pub(crate) info: Value,
}

impl Client {
    pub(crate) fn connect(addr: SocketAddr) -> Self {
        let stream = TcpStream::connect(addr).unwrap();
        stream.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
        let mut req = format!("ws://{addr}").into_client_request().unwrap();
        req.headers_mut().insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().unwrap());
        let (ws, resp) = tungstenite::client::client(req, stream).unwrap();
        assert_eq!(resp.headers()["Sec-WebSocket-Protocol"], "foxglove.sdk.v1");
        let mut c = Self { ws, channels: HashMap::new(), subs: HashMap::new(), info: Value::Null };
        let deadline = Instant::now() + Duration::from_secs(10);
        while c.channels.len() < 5 {
            assert!(Instant::now() < deadline, "no advertisement");
            let _ = c.next();
        }
        c
    }

    /// The next message, `None` on a read timeout.
    pub(crate) fn next(&mut self) -> Option<In> {
        let msg = match self.ws.read() {
            Ok(m) => m,
            Err(tungstenite::Error::Io(e))
                if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut) =>
            {
                return None;
            }
            Err(_) => return Some(In::Closed),
        };
        Some(match msg {
            Message::Text(t) => {
                let v: Value = serde_json::from_str(&t).unwrap();
                if v["op"] == "advertise" {
                    for ch in v["channels"].as_array().unwrap() {
                        assert_eq!(ch["encoding"], "json");
                        assert_eq!(ch["schemaEncoding"], "jsonschema");
                        let schema = serde_json::from_str(ch["schema"].as_str().unwrap()).unwrap();
                        self.channels.insert(
                            ch["topic"].as_str().unwrap().into(),
                            (ch["id"].as_u64().unwrap(), schema),
                        );
                    }
                }
                if v["op"] == "serverInfo" {
                    self.info = v.clone();
                }
                In::Json(v)
            }
            Message::Binary(b) => {
                let u64_at = |i: usize| u64::from_le_bytes(b[i..i + 8].try_into().unwrap());
                match b[0] {
                    1 => In::Data {
                        sub: u32::from_le_bytes(b[1..5].try_into().unwrap()),
                        log_time: u64_at(5),
                        payload: b[13..].to_vec(),
                    },
                    2 => In::Time(u64_at(1)),
                    5 => In::Playback { status: b[1], current: u64_at(2), did_seek: b[14] != 0 },
                    op => panic!("unexpected binary opcode {op}"),
                }
            }
            Message::Close(_) => In::Closed,
            _ => return None,
        })
    }

    pub(crate) fn subscribe(&mut self, topics: &[&str]) {
        let mut subs = Vec::new();
        for t in topics {
            let id = self.subs.len() as u32 + 1;
            let (ch, _) = self.channels.get(*t).unwrap_or_else(|| panic!("{t} not advertised"));
            subs.push(serde_json::json!({"id": id, "channelId": ch}));
            self.subs.insert(id, t.to_string());
        }
        let m = serde_json::json!({"op": "subscribe", "subscriptions": subs});
        self.ws.send(Message::Text(m.to_string().into())).unwrap();
    }

    /// Reads until `want` returns true for a message, or `secs` pass; returns the
    /// messages read, (topic, log time, JSON), each checked against its schema.
    pub(crate) fn until(
        &mut self,
        secs: f64,
        mut want: impl FnMut(&In, Option<&str>) -> bool,
    ) -> (bool, Vec<(String, u64, Value)>) {
        let deadline = Instant::now() + Duration::from_secs_f64(secs);
        let mut got = Vec::new();
        while Instant::now() < deadline {
            let Some(m) = self.next() else { continue };
            let topic = match &m {
                In::Data { sub, log_time, payload } => {
                    let topic = self.subs[sub].clone();
                    let v: Value = serde_json::from_slice(payload).unwrap();
                    let schema = &self.channels[&topic].1;
                    if let Err(e) = check(schema, &v, "") {
                        panic!("{topic} at {log_time} does not validate: {e}\n{v}");
                    }
                    got.push((topic.clone(), *log_time, v));
                    Some(topic)
                }
                _ => None,
            };
            if want(&m, topic.as_deref()) {
                return (true, got);
            }
        }
        (false, got)
    }

    pub(crate) fn playback(&mut self, play: bool, speed: f32, seek: Option<u64>) {
        let mut b = vec![3u8, if play { 0 } else { 1 }];
        b.extend_from_slice(&speed.to_le_bytes());
        b.push(u8::from(seek.is_some()));
        b.extend_from_slice(&seek.unwrap_or(0).to_le_bytes());
        b.extend_from_slice(&2u32.to_le_bytes());
        b.extend_from_slice(b"r1");
        self.ws.send(Message::Binary(b.into())).unwrap();
    }
}

pub(crate) fn local(speed: f64) -> LiveConfig {
    LiveConfig { addr: "127.0.0.1:0".parse().unwrap(), speed, ..LiveConfig::new("test") }
}

/// Runs a live-only grid run of `steps` on its own thread (seed 5, tables every 200
/// steps), waiting after its start; returns it.
fn run_live(
    server: &LiveServer,
    steps: u64,
    started: Arc<AtomicBool>,
    go: Arc<AtomicBool>,
) -> std::thread::JoinHandle<Duration> {
    run_live_waiting_at(server, steps, 0, started, go)
}

/// [`run_live`], waiting at step `wait_at` instead (0: after its start; else a multiple
/// of 200, at the tables).
fn run_live_waiting_at(
    server: &LiveServer,
    steps: u64,
    wait_at: u64,
    started: Arc<AtomicBool>,
    go: Arc<AtomicBool>,
) -> std::thread::JoinHandle<Duration> {
    let tap = server.tap();
    std::thread::spawn(move || {
        let rec = McapRecorder::live_only(RecorderConfig::new(""), tap);
        let mut gate = Gate { rec, wait_at, started, go };
        let t0 = Instant::now();
        common::run_grid(&common::world("paper-9x9"), &mut gate, steps, 5, 200);
        t0.elapsed()
    })
}

/// Passes everything to the recorder (its step gate too), and waits at step `wait_at`
/// (after `on_start`, or at the tables) until told to go.
struct Gate {
    rec: McapRecorder,
    wait_at: u64,
    started: Arc<AtomicBool>,
    go: Arc<AtomicBool>,
}

impl Gate {
    fn wait(&self) {
        self.started.store(true, Ordering::SeqCst);
        while !self.go.load(Ordering::SeqCst) {
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl mmq_core::Observer for Gate {
    fn on_start(&mut self, info: &mmq_core::RunInfo<'_>, s: usize, t: f64) {
        self.rec.on_start(info, s, t);
        if self.wait_at == 0 {
            self.wait();
        }
    }
    fn step_gate(&self) -> Option<mmq_core::StepGate> {
        self.rec.step_gate()
    }
    fn ledger_history(&self) -> bool {
        self.rec.ledger_history()
    }
    fn on_resume(&mut self, at: &mmq_core::Resume) {
        self.rec.on_resume(at);
    }
    fn on_step(&mut self, r: &mmq_core::StepRecord<'_>) {
        self.rec.on_step(r);
    }
    fn on_tables(&mut self, t: u64, s: f64, v: &[f64], q: &[f64]) {
        self.rec.on_tables(t, s, v, q);
        if t == self.wait_at {
            self.wait();
        }
    }
    fn on_finish(&mut self, t: u64, c: bool) {
        self.rec.on_finish(t, c);
    }
}

fn wait_for(flag: &AtomicBool) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while !flag.load(Ordering::SeqCst) {
        assert!(Instant::now() < deadline);
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_client_sees_the_run_and_a_late_one_gets_the_arena() {
    // 50× real time: 1000 steps of 0.1 s in 2 s while the client watches.
    let server = LiveServer::start(&local(50.0)).unwrap();
    assert!(server.addr().ip().is_loopback() && server.addr().port() != 0);
    let (started, go) = (Arc::new(AtomicBool::new(false)), Arc::new(AtomicBool::new(false)));
    let run = run_live(&server, 1000, started.clone(), go.clone());
    wait_for(&started);
    let mut c = Client::connect(server.addr());
    assert!(c.info["capabilities"].as_array().unwrap().contains(&Value::from("time")), "{}", c.info);
    for t in [topics::TF, topics::ARENA, topics::ROBOT, topics::DECISION, topics::EMITTED, topics::VISITS] {
        assert!(c.channels.contains_key(t), "{t}");
    }
    c.subscribe(&[topics::TF, topics::ARENA, topics::DECISION, topics::VISITS]);
    // The arena was drawn before anyone connected: it is latched.
    let (ok, _) = c.until(60.0, |_, t| t == Some(topics::ARENA));
    assert!(ok, "no arena");
    go.store(true, Ordering::SeqCst);
    // Simulated time is advertised as the run goes.
    let mut times = Vec::new();
    let (ok, got) = c.until(60.0, |m, _| {
        if let In::Time(t) = m {
            times.push(*t);
        }
        times.len() >= 20
    });
    assert!(ok, "{} time messages", times.len());
    assert!(times.windows(2).all(|w| w[0] < w[1]) && times.iter().all(|t| t % 100_000_000 == 0), "{times:?}");
    let tf: Vec<_> = got.iter().filter(|(t, _, _)| t == topics::TF).collect();
    let decisions: Vec<_> = got.iter().filter(|(t, _, _)| t == topics::DECISION).collect();
    assert!(!tf.is_empty() && !decisions.is_empty(), "{} tf, {} decisions", tf.len(), decisions.len());
    // Simulated time: a decision at step t is stamped t × 100 ms.
    for (_, time, v) in &decisions {
        assert_eq!(*time, v["t"].as_u64().unwrap() * 100_000_000);
    }
    // A second client, late: it gets the arena at once.
    let mut late = Client::connect(server.addr());
    late.subscribe(&[topics::ARENA]);
    let (ok, got) = late.until(60.0, |_, t| t == Some(topics::ARENA));
    assert!(ok, "the late client got no arena");
    assert_eq!(got.last().unwrap().2["entities"][0]["id"], "arena");
    run.join().unwrap();
    server.stop();
}

#[test]
fn a_client_that_leaves_does_not_hold_the_run() {
    // Paced at 1/10 of real time while a client watches: 3000 steps of 0.1 s would take
    // 50 minutes. The client leaves, and the run goes on at full speed. (A decision logged
    // before the server has taken the subscription is missed; the next comes a second
    // later.)
    let server = LiveServer::start(&local(0.1)).unwrap();
    let (started, go) = (Arc::new(AtomicBool::new(false)), Arc::new(AtomicBool::new(false)));
    let run = run_live(&server, 3000, started.clone(), go.clone());
    wait_for(&started);
    let mut c = Client::connect(server.addr());
    c.subscribe(&[topics::TF, topics::DECISION]);
    go.store(true, Ordering::SeqCst);
    // Generous: on a loaded machine the first step can be slow to come.
    let t0 = Instant::now();
    let (ok, _) = c.until(60.0, |_, t| t == Some(topics::DECISION));
    assert!(ok, "no decision after {:?}", t0.elapsed());
    drop(c);
    let deadline = Instant::now() + Duration::from_secs(30);
    while !run.is_finished() {
        assert!(Instant::now() < deadline, "the run is still held after its client left");
        std::thread::sleep(Duration::from_millis(20));
    }
    run.join().unwrap();
    assert_eq!(server.clients(), 0);
    server.stop();
}

#[test]
fn stopping_closes_clients_and_frees_the_port() {
    let server = LiveServer::start(&local(1.0)).unwrap();
    let addr = server.addr();
    let mut c = Client::connect(addr);
    server.stop();
    let (closed, _) = c.until(60.0, |m, _| matches!(m, In::Closed));
    assert!(closed, "the client was not disconnected");
    // The port is free again.
    let again = LiveServer::start(&LiveConfig { addr, ..local(1.0) }).unwrap();
    again.stop();
}

#[test]
fn a_port_in_use_and_bad_addresses_are_clear_errors() {
    let taken = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap();
    let e = LiveServer::start(&LiveConfig { addr, ..local(1.0) }).unwrap_err();
    let text = e.to_string();
    assert!(text.contains(&addr.to_string()) && text.contains("in use"), "{text}");
    assert!(!e.is_input_error());
    for bad in ["localhost:http", "127.0.0.1:99999", "my laptop", ""] {
        let e = parse_addr(bad).unwrap_err();
        let text = e.to_string();
        assert!(e.is_input_error() && text.contains(&format!("`{bad}`")), "{text}");
        assert!(text.contains("HOST:PORT") || text.contains("port must be a number"), "{text}");
    }
    assert_eq!(parse_addr("9000").unwrap(), "127.0.0.1:9000".parse().unwrap());
    assert_eq!(parse_addr("localhost:9000").unwrap(), "127.0.0.1:9000".parse().unwrap());
    assert_eq!(parse_addr("[::1]:9000").unwrap(), "[::1]:9000".parse().unwrap());
    assert_eq!(mmq_log::live::DEFAULT_ADDR, "127.0.0.1:8765".parse().unwrap());
}

#[test]
fn a_served_file_plays_pauses_and_seeks() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.mcap");
    common::record_grid(&path, |_| {}, 2000, 9);
    let never = AtomicBool::new(false);
    let paused = replay::ServeOptions { paused: true };
    let server = replay::serve_file(&path, &local(1.0), paused, &never).unwrap().unwrap();
    let (t0, t1) = server.time_range();
    assert_eq!((t0, t1), (0, 2000 * 100_000_000));
    let addr = server.addr();
    let stop = Arc::new(AtomicBool::new(false));
    let player = {
        let stop = stop.clone();
        std::thread::spawn(move || server.run(&stop).unwrap())
    };
    let mut c = Client::connect(addr);
    assert!(
        c.info["capabilities"].as_array().unwrap().contains(&Value::from("playbackControl")),
        "{}",
        c.info
    );
    c.subscribe(&[topics::DECISION, topics::ARENA, topics::TF]);
    // A late subscriber to a paused file gets the arena all the same.
    let (ok, _) = c.until(60.0, |_, t| t == Some(topics::ARENA));
    assert!(ok, "no arena before playing");
    // Seek to step 1500 and play at 10×: decisions from step 1500 on, after the arena.
    let seek = 1500 * 100_000_000;
    c.playback(true, 10.0, Some(seek));
    let mut seen_state = false;
    let (ok, got) = c.until(60.0, |m, t| {
        if let In::Playback { did_seek, current, status } = m {
            assert!(*did_seek && *current == seek && *status == 0, "{m:?}");
            seen_state = true;
        }
        t == Some(topics::DECISION)
    });
    assert!(ok && seen_state, "no decision after the seek");
    let first = got.iter().find(|(t, _, _)| t == topics::DECISION).unwrap();
    assert_eq!(first.1, seek, "the first decision after the seek");
    assert!(got.iter().any(|(t, _, _)| t == topics::ARENA), "the arena is re-sent on seek");
    // Pause: the decisions stop.
    c.playback(false, 10.0, None);
    let _ = c.until(0.5, |_, _| false);
    let (any, _) = c.until(1.0, |_, t| t == Some(topics::DECISION));
    assert!(!any, "decisions while paused");
    stop.store(true, Ordering::SeqCst);
    player.join().unwrap();
    let (closed, _) = c.until(60.0, |m, _| matches!(m, In::Closed));
    assert!(closed);
}

/// A client watching an unpaced run (`--live-speed 0`) changes nothing in the recording,
/// byte for byte, and gets the poses thinned: at most one per 100 ms of simulated time
/// and one per 33 ms of wall-clock time, where the file keeps every sample.
#[test]
fn a_watched_recording_is_the_recording_and_live_poses_are_thinned() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, watched) = (dir.path().join("plain.mcap"), dir.path().join("watched.mcap"));
    let world = common::world("paper-9x9");
    // Every pose sample recorded (60 per step), so the live view has something to thin.
    let config = |p: &std::path::Path| {
        let mut c = RecorderConfig::new(p);
        c.pose_rate_hz = 0.0;
        c
    };
    let steps = 400;
    let mut rec = McapRecorder::create(config(&plain)).unwrap();
    common::run_robot_with(&world, &mut rec, steps, 3, true);
    assert!(rec.take_error().is_none());
    let server = LiveServer::start(&local(0.0)).unwrap();
    let tap = server.tap();
    let (started, go) = (Arc::new(AtomicBool::new(false)), Arc::new(AtomicBool::new(false)));
    let run = {
        let (started, go, path, world) = (started.clone(), go.clone(), watched.clone(), world.clone());
        std::thread::spawn(move || {
            let rec = McapRecorder::create(config(&path)).unwrap().with_live(tap);
            let mut gate = Gate { rec, wait_at: 0, started, go };
            let t0 = Instant::now();
            common::run_robot_with(&world, &mut gate, steps, 3, true);
            (t0.elapsed(), gate.rec.take_error().is_none())
        })
    };
    wait_for(&started);
    let mut c = Client::connect(server.addr());
    c.subscribe(&[topics::TF, topics::POSE, topics::POSE_ESTIMATE, topics::DECISION, topics::ARENA]);
    // The arena comes on subscription (latched): the subscriptions are in place.
    let (ok, _) = c.until(60.0, |_, t| t == Some(topics::ARENA));
    assert!(ok, "no arena");
    go.store(true, Ordering::SeqCst);
    let mut got = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(120);
    while !run.is_finished() && Instant::now() < deadline {
        got.extend(c.until(0.2, |_, _| false).1);
    }
    got.extend(c.until(1.0, |_, _| false).1);
    let (elapsed, ok) = run.join().unwrap();
    assert!(ok, "the watched recording failed");
    server.stop();
    assert!(
        std::fs::read(&plain).unwrap() == std::fs::read(&watched).unwrap(),
        "the recording differs while a client watches"
    );
    let times = |topic: &str| -> Vec<u64> {
        got.iter().filter(|(t, _, _)| t == topic).map(|(_, time, _)| *time).collect()
    };
    let (poses, decisions) = (times(topics::POSE), times(topics::DECISION));
    assert!(
        !poses.is_empty() && !decisions.is_empty(),
        "{} poses, {} decisions",
        poses.len(),
        decisions.len()
    );
    assert!(poses.windows(2).all(|w| w[1] >= w[0] + 100_000_000), "poses closer than 100 ms: {poses:?}");
    let most = elapsed.as_secs_f64() / 0.033 + 2.0;
    assert!(poses.len() as f64 <= most, "{} poses in {elapsed:?}", poses.len());
    assert!(decisions.len() as f64 <= most, "{} decisions in {elapsed:?}", decisions.len());
    // Each estimate goes with its pose sample.
    assert_eq!(times(topics::POSE_ESTIMATE), poses);
}

/// A client that connects mid-run to a live-only run (whose steps were skipped while
/// nobody watched) gets the recording's messages: each decision, reward and pose it
/// receives is the one a recording of the same run holds at that time (the reward
/// totals and emission ids picked up where the skipped steps left them).
#[test]
fn a_client_joining_mid_run_gets_the_recordings_messages() {
    // 50× real time while watched: the 1200 steps left take some 2.4 s.
    joining_mid_run_gets_the_recordings_messages(50.0, 2400);
}

/// The same at 1000× real time (some 3 s for the 28,800 steps left): nearly every
/// watched step sends nothing (the thinning holds its messages back, some 300 steps in a
/// row) and keeps only the running figures, which the messages that do go out show.
#[test]
fn a_client_joining_a_fast_run_mid_run_gets_the_recordings_messages() {
    joining_mid_run_gets_the_recordings_messages(1000.0, 30_000);
}

/// A client joins at step 1200 of a live-only run of `steps` paced at `speed`.
fn joining_mid_run_gets_the_recordings_messages(speed: f64, steps: u64) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("g.mcap");
    let join_at = 1200;
    // The same run (seed 5, tables every 200 steps) recorded to a file.
    let mut rec = McapRecorder::create(RecorderConfig::new(&path)).unwrap();
    common::run_grid(&common::world("paper-9x9"), &mut rec, steps, 5, 200);
    assert!(rec.take_error().is_none());
    drop(rec);
    let bytes = std::fs::read(&path).unwrap();
    let mut recorded: HashMap<(String, u64), Vec<Value>> = HashMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let v: Value = serde_json::from_slice(&m.data).unwrap();
        recorded.entry((m.channel.topic.clone(), m.log_time)).or_default().push(v);
    }
    let server = LiveServer::start(&local(speed)).unwrap();
    let (started, go) = (Arc::new(AtomicBool::new(false)), Arc::new(AtomicBool::new(false)));
    let run = run_live_waiting_at(&server, steps, join_at, started.clone(), go.clone());
    wait_for(&started);
    let mut c = Client::connect(server.addr());
    let watched = [topics::DECISION, topics::EMITTED, topics::DELIVERED, topics::TF, topics::POSE];
    c.subscribe(&[watched.as_slice(), &[topics::ARENA]].concat());
    let (ok, _) = c.until(60.0, |_, t| t == Some(topics::ARENA));
    assert!(ok, "no arena");
    go.store(true, Ordering::SeqCst);
    let mut got = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(120);
    while !run.is_finished() && Instant::now() < deadline {
        got.extend(c.until(0.2, |_, _| false).1);
    }
    got.extend(c.until(0.5, |_, _| false).1);
    run.join().unwrap();
    server.stop();
    for topic in watched {
        let mine: Vec<_> = got.iter().filter(|(t, _, _)| t == topic).collect();
        assert!(!mine.is_empty(), "nothing on {topic}");
        for (_, time, v) in mine {
            assert!(*time >= join_at * 100_000_000, "{topic} at {time}: from a skipped step");
            // The pose where the first decision shown is taken has the heading of the
            // last step shown (none here: the start's); the recording's, that of the
            // step before. Its place is the same.
            let place = |v: &Value| {
                let mut v = v.clone();
                v.as_object_mut().unwrap().remove("rotation");
                if let Some(p) = v.get_mut("pose") {
                    p.as_object_mut().unwrap().remove("orientation");
                }
                v
            };
            let at_join = *time == join_at * 100_000_000 && [topics::TF, topics::POSE].contains(&topic);
            let same = recorded.get(&(topic.to_string(), *time)).is_some_and(|r| {
                if at_join { r.iter().any(|x| place(x) == place(v)) } else { r.contains(v) }
            });
            assert!(same, "{topic} at {time} is not the recording's: {v}");
        }
    }
}
