//! The live view: a Foxglove WebSocket server (the `foxglove` SDK) that shows a run as it
//! happens, with the topics, schemas and JSON bytes of the MCAP recording.
//!
//! - [`LiveServer::start`] listens on an address (loopback unless the user names another
//!   one; [`parse_addr`]) and advertises every mmq channel, with simulated time.
//! - [`LiveServer::tap`] gives the [`LiveTap`] a recorder sends its messages through
//!   ([`crate::McapRecorder::live_only`], [`crate::McapRecorder::with_live`]).
//! - Latched topics ([`crate::messages::LATCHED`]: the scenes and heat maps) keep their
//!   last message, which every new subscriber receives at once.
//! - With no client connected the recorder writes nothing live and the runner skips a
//!   live-only recorder's steps altogether (its step gate is the count of clients), so
//!   the run is not slowed; with one, [`LiveConfig::speed`] paces the run to that many
//!   seconds of simulated time per second of wall-clock time.
//! - What a client gets is thinned for watching, the recording never: poses at most every
//!   [`LIVE_POSE_PERIOD_NS`] of simulated time (10 Hz) and, like every other topic but
//!   contacts and notes, and like the time updates, at most once per [`LIVE_MIN_GAP`] of
//!   wall-clock time (30 a second). A run watched at real time loses nothing; a run
//!   watched unpaced costs a bounded amount per second instead of one socket write per
//!   message (and never overflows the client's queue, which would disconnect it).
//!
//! [`replay`] serves a recorded file instead, with playback control.

use std::collections::{HashMap, HashSet};
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, Weak};
use std::time::{Duration, Instant};

use foxglove::websocket::{Capability, ChannelView, Client, ClientId, ServerListener, Status};
use foxglove::{ChannelId, Context, PartialMetadata, RawChannel, Schema, WebSocketServerHandle};
use mmq_core::StepGate;

use crate::error::LogError;
use crate::messages::{CHANNELS, LATCHED, LOG_CHANNEL, topics};
use crate::writer::PoseJson;

mod catalog;
pub mod replay;

/// Simulated time between two poses sent to live clients (10 Hz), whatever rate the
/// recording keeps (`--record-rate 0` keeps every physics step).
pub const LIVE_POSE_PERIOD_NS: u64 = 100_000_000;

/// Wall-clock time between two messages of one topic (poses: two pose samples; and two
/// time updates) sent to live clients: at most 30 a second, about what the app draws.
/// Contacts (their starts and ends pair up) and notes are never thinned; latched topics
/// always keep their last message for new subscribers.
pub const LIVE_MIN_GAP: Duration = Duration::from_millis(33);

/// The default address of the live view: loopback only, Foxglove's usual port.
pub const DEFAULT_ADDR: SocketAddr = SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), 8765);

/// Reads a live-view address: `HOST:PORT` (`127.0.0.1:8765`, `[::1]:9000`,
/// `0.0.0.0:8765` to listen on every interface), `localhost:PORT`, or a bare `PORT`
/// (on 127.0.0.1). Port 0 asks the system for a free port.
pub fn parse_addr(text: &str) -> Result<SocketAddr, LogError> {
    let t = text.trim();
    let bad = |reason: &str| LogError::LiveAddress { addr: text.to_string(), reason: reason.to_string() };
    if let Ok(port) = t.parse::<u16>() {
        return Ok(SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), port));
    }
    if let Some(port) = t.strip_prefix("localhost:") {
        let port = port.parse::<u16>().map_err(|_| bad("the port must be a number from 0 to 65535"))?;
        return Ok(SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), port));
    }
    t.parse::<SocketAddr>().map_err(|_| {
        bad("expected HOST:PORT with an IP address (127.0.0.1:8765, [::1]:8765, 0.0.0.0:8765) or a port number")
    })
}

/// The warning for an address that is not loopback-only: every interface (`0.0.0.0`,
/// `[::]`) or another machine's view of this one lets anyone on the network watch, and
/// for a served file (`playback`) also pause, seek and change its speed; `None` for a
/// loopback address.
pub fn exposure_warning(addr: SocketAddr, playback: bool) -> Option<String> {
    if addr.ip().is_loopback() {
        return None;
    }
    let reach = if addr.ip().is_unspecified() { "every network interface" } else { "a network interface" };
    let control = if playback { " and control its playback (play, pause, seek, speed)" } else { "" };
    Some(format!(
        "warning: listening on {addr}, {reach}: anyone who can reach this machine can watch{control}, \
         with no password; use 127.0.0.1:PORT (the default) to keep it on this machine"
    ))
}

/// The channels a live view advertises: (topic, schema name, schema text) in the
/// recorder's slot order, which of them are latched (every new subscriber gets their last
/// message) and which are sent per sample rather than thinned per topic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiveChannels {
    /// Every channel, in slot order.
    pub channels: &'static [(&'static str, &'static str, &'static str)],
    /// Topics whose last message is kept for new subscribers.
    pub latched: &'static [&'static str],
    /// Topics not thinned per topic (poses go per sample; contacts and notes whole).
    pub per_sample: &'static [&'static str],
}

/// The single robot's live channels: the recording's [`CHANNELS`], then the log channel.
pub const ROBOT_CHANNELS: LiveChannels = LiveChannels {
    channels: &ROBOT_LIVE,
    latched: &LATCHED,
    per_sample: &[topics::TF, topics::POSE, topics::POSE_ESTIMATE, topics::CONTACT, topics::LOG],
};

const ROBOT_LIVE: [(&str, &str, &str); CHANNELS.len() + 1] = {
    let mut all = [LOG_CHANNEL; CHANNELS.len() + 1];
    let mut i = 0;
    while i < CHANNELS.len() {
        all[i] = CHANNELS[i];
        i += 1;
    }
    all
};

/// How the live view is served.
#[derive(Clone, Debug, PartialEq)]
pub struct LiveConfig {
    /// Where to listen ([`DEFAULT_ADDR`]: loopback only).
    pub addr: SocketAddr,
    /// Real-time factor while a client is connected: seconds of simulated time per
    /// second of wall-clock time (1 = real time; 0 = as fast as the run goes).
    pub speed: f64,
    /// Server name shown by the Foxglove app.
    pub name: String,
    /// Messages queued per client ([`CLIENT_BACKLOG`]): a client that does not read
    /// loses the oldest beyond this many, and is disconnected when as many control
    /// messages (time updates) wait for it.
    pub backlog: usize,
    /// What it shows ([`ROBOT_CHANNELS`]; a swarm: [`crate::swarm::SWARM_LIVE`]).
    pub channels: LiveChannels,
}

impl LiveConfig {
    /// Loopback on Foxglove's usual port, in real time.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            addr: DEFAULT_ADDR,
            speed: 1.0,
            name: name.into(),
            backlog: CLIENT_BACKLOG,
            channels: ROBOT_CHANNELS,
        }
    }
}

/// A latched topic's last message: (log time, bytes).
type Latched = (u64, Vec<u8>);

/// What the server, its listener and the taps share.
struct Shared {
    /// The SDK context the channels and the server belong to (kept alive with them).
    _ctx: Arc<Context>,
    /// The channels, in recorder slot order ([`LiveChannels`]).
    channels: Vec<Arc<RawChannel>>,
    /// Slot of each channel id.
    slots: HashMap<ChannelId, usize>,
    /// Last message of each latched slot, by slot: (log time, bytes).
    latched: Mutex<Vec<Option<Latched>>>,
    latched_slot: Vec<bool>,
    /// Slots thinned per topic to one message per [`LIVE_MIN_GAP`] (poses are thinned
    /// per sample instead; contacts and notes not at all).
    gated_slot: Vec<bool>,
    /// Clients connected: open while there is one (the runner skips the steps of a
    /// live-only run while it is closed).
    clients: StepGate,
    /// A coarse wall clock for the thinning, milliseconds since the server started: set
    /// by a thread of its own every [`CLOCK_TICK`] while clients are connected (reading
    /// the system clock for every message cost more than the message on a busy machine).
    clock_ms: AtomicU64,
    /// The clock's thread runs while this is set.
    ticking: AtomicBool,
}

/// Resolution of the thinning's clock while clients are connected (without: 10×).
const CLOCK_TICK: Duration = Duration::from_millis(4);

/// Keeps `shared.clock_ms` up to date until the server stops (or is dropped).
fn run_clock(shared: Weak<Shared>) {
    let t0 = Instant::now();
    loop {
        let Some(s) = shared.upgrade() else { return };
        if !s.ticking.load(Ordering::Relaxed) {
            return;
        }
        s.clock_ms.store(t0.elapsed().as_millis() as u64, Ordering::Relaxed);
        let idle = !s.clients.is_open();
        drop(s);
        std::thread::sleep(if idle { 10 * CLOCK_TICK } else { CLOCK_TICK });
    }
}

impl Shared {
    fn new(ctx: &Arc<Context>, which: &LiveChannels) -> Result<Self, String> {
        let mut channels = Vec::new();
        let mut slots = HashMap::new();
        let mut latched_slot = Vec::new();
        let mut gated_slot = Vec::new();
        let (latched, per_sample) = (which.latched, which.per_sample);
        for (topic, schema, text) in which.channels {
            let ch = ctx
                .channel_builder(*topic)
                .message_encoding("json")
                .schema(Schema::new(*schema, "jsonschema", text.as_bytes().to_vec()))
                .build_raw()
                .map_err(|e| format!("cannot create the channel {topic}: {e}"))?;
            slots.insert(ch.id(), channels.len());
            latched_slot.push(latched.contains(topic));
            gated_slot.push(!per_sample.contains(topic));
            channels.push(ch);
        }
        Ok(Self {
            _ctx: Arc::clone(ctx),
            channels,
            slots,
            latched: Mutex::new(vec![None; latched_slot.len()]),
            latched_slot,
            gated_slot,
            clients: StepGate::new(),
            clock_ms: AtomicU64::new(0),
            ticking: AtomicBool::new(true),
        })
    }
}

/// Connect/disconnect counting, latched re-sends, the backlog's status message.
struct Listener(Arc<Shared>, Greeted, usize);

impl ServerListener for Listener {
    fn on_subscribe(&self, client: Client, channel: ChannelView<'_>) {
        self.1.greet(&client, self.2);
        let Some(&slot) = self.0.slots.get(&channel.id()) else { return };
        let Some(sink) = client.sink_id() else { return };
        let last = self.0.latched.lock().ok().and_then(|l| l.get(slot).cloned().flatten());
        if let Some((log_time, bytes)) = last {
            let meta = PartialMetadata { log_time: Some(log_time) };
            self.0.channels[slot].log_with_meta_to_sink(&bytes, meta, Some(sink));
        }
    }
    fn on_client_connect(&self) {
        self.0.clients.open();
    }
    fn on_client_disconnect(&self) {
        self.0.clients.close();
    }
}

/// A running live view; see the module documentation.
pub struct LiveServer {
    handle: Arc<Mutex<Option<WebSocketServerHandle>>>,
    shared: Arc<Shared>,
    addr: SocketAddr,
    speed: f64,
}

impl std::fmt::Debug for LiveServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveServer")
            .field("addr", &self.addr)
            .field("speed", &self.speed)
            .finish_non_exhaustive()
    }
}

/// Messages queued per client (and control messages, such as time updates, per client):
/// a client that does not read loses the oldest data messages once its queue holds this
/// many, and is disconnected (with a status saying why) once its control queue does, so
/// that it costs at most this many messages of memory. 1024 by default in the SDK: with
/// the arena or heat maps of a large map, hundreds of megabytes per stalled client.
pub const CLIENT_BACKLOG: usize = 256;

/// Clients told how the view drops messages (each once, at its first subscription).
#[derive(Debug, Default)]
pub(crate) struct Greeted(Mutex<HashSet<ClientId>>);

impl Greeted {
    /// Tells `client`, once, that a client falling more than `backlog` messages behind
    /// loses the oldest ones (a status message the app shows).
    pub(crate) fn greet(&self, client: &Client, backlog: usize) {
        let new = self.0.lock().is_ok_and(|mut g| g.insert(client.id()));
        if new {
            client.send_status(Status::info(format!(
                "mmq: at most {backlog} messages wait for each viewer; a viewer that falls further behind \
                 loses the oldest of them (the arena and the heat maps are re-sent on subscribing again), \
                 and one that stops reading is disconnected"
            )));
        }
    }
}

/// Starts a server on `addr` (port 0: a free one) with the given capabilities.
fn start_server(
    ctx: &Arc<Context>,
    config: &LiveConfig,
    capabilities: Vec<Capability>,
    listener: Arc<dyn ServerListener>,
    time_range: Option<(u64, u64)>,
) -> Result<WebSocketServerHandle, LogError> {
    let addr = config.addr;
    let mut server = ctx
        .websocket_server()
        .message_backlog_size(config.backlog.max(1))
        .name(&config.name)
        .capabilities(capabilities)
        .listener(listener)
        .bind(addr.ip().to_string(), addr.port());
    if let Some((start, end)) = time_range {
        server = server.playback_time_range(start, end);
    }
    server.start_blocking().map_err(|e| {
        let text = e.to_string();
        let hint = if text.contains("in use") {
            "; another program (another live view?) has that port: stop it or name another port"
        } else if text.contains("assign") || text.contains("not available") {
            "; that address is not one of this machine's"
        } else {
            ""
        };
        LogError::LiveServer { addr, message: format!("{text}{hint}") }
    })
}

impl LiveServer {
    /// Starts listening; returns once the server accepts connections.
    pub fn start(config: &LiveConfig) -> Result<Self, LogError> {
        if !(config.speed.is_finite() && config.speed >= 0.0) {
            return Err(LogError::LiveAddress {
                addr: config.addr.to_string(),
                reason: format!("the real-time factor must be ≥ 0 (0: no pacing), got {}", config.speed),
            });
        }
        let ctx = Context::new();
        let shared = Arc::new(
            Shared::new(&ctx, &config.channels)
                .map_err(|message| LogError::LiveServer { addr: config.addr, message })?,
        );
        let listener = Arc::new(Listener(Arc::clone(&shared), Greeted::default(), config.backlog));
        let handle = start_server(&ctx, config, vec![Capability::Time], listener, None)?;
        let weak = Arc::downgrade(&shared);
        std::thread::Builder::new().name("mmq-live-clock".into()).spawn(move || run_clock(weak)).map_err(
            |e| LogError::LiveServer { addr: config.addr, message: format!("cannot start a thread: {e}") },
        )?;
        let addr = SocketAddr::new(config.addr.ip(), handle.port());
        Ok(Self { handle: Arc::new(Mutex::new(Some(handle))), shared, addr, speed: config.speed })
    }

    /// The address it listens on (with the port the system chose for port 0).
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// Clients connected now.
    pub fn clients(&self) -> usize {
        self.shared.clients.count()
    }

    /// Waits until a client is connected, `timeout` has passed (`None`: no limit) or
    /// `stop` is raised; returns whether a client is connected.
    pub fn wait_for_client(&self, timeout: Option<Duration>, stop: &AtomicBool) -> bool {
        let deadline = timeout.map(|t| Instant::now() + t);
        while !self.shared.clients.is_open() {
            if stop.load(Ordering::Relaxed) || deadline.is_some_and(|d| Instant::now() >= d) {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        true
    }

    /// A tap for a recorder (one per run shown).
    pub fn tap(&self) -> LiveTap {
        LiveTap {
            shared: Arc::clone(&self.shared),
            handle: Arc::clone(&self.handle),
            scratch: Vec::new(),
            pose: PoseJson::default(),
            speed: self.speed,
            anchor: None,
            last_time_sent: None,
            time_until: 0,
            next_pose_ns: 0,
            pose_until: 0,
            sent_until: vec![0; self.shared.channels.len()],
        }
    }

    /// Stops the server: clients are disconnected (one that does not read is dropped
    /// after [`STOP_GRACE`]), the port is freed. Waits for it.
    pub fn stop(self) {
        self.shared.ticking.store(false, Ordering::Relaxed);
        let h = self.handle.lock().ok().and_then(|mut h| h.take());
        if let Some(h) = h {
            stop_server(h, self.addr);
        }
    }
}

/// How long stopping a server waits for its clients to take their close message: a
/// client that does not read (its socket full) would otherwise hold the process forever.
pub const STOP_GRACE: Duration = Duration::from_millis(500);

/// Stops a server: waits at most [`STOP_GRACE`] for the clients to be closed, then drops
/// the ones left (their tasks are aborted), and waits until the port is free.
pub(crate) fn stop_server(handle: WebSocketServerHandle, addr: SocketAddr) {
    use std::future::Future;
    // The SDK's wait, polled here until it is done or the grace has passed; dropping it
    // then drops the shutdown handle, which aborts the client tasks still running.
    let mut wait = Box::pin(handle.stop().wait());
    let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
    let deadline = Instant::now() + STOP_GRACE;
    while wait.as_mut().poll(&mut cx).is_pending() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(5));
    }
    drop(wait);
    wait_port_free(addr);
}

/// The server's accepting task closes its socket shortly after the client tasks end;
/// waits (at most two seconds) until the port can be bound again, so a new server on
/// the same address starts at once.
pub(crate) fn wait_port_free(addr: SocketAddr) {
    let deadline = Instant::now() + Duration::from_secs(2);
    while std::net::TcpListener::bind(addr).is_err() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A recorder's way to the live view: sends messages to the subscribed clients, keeps
/// the latched topics' last message, advertises simulated time and paces the run.
pub struct LiveTap {
    shared: Arc<Shared>,
    handle: Arc<Mutex<Option<WebSocketServerHandle>>>,
    scratch: Vec<u8>,
    pose: PoseJson,
    speed: f64,
    /// Pacing reference: (wall clock, simulated ns) when pacing started.
    anchor: Option<(Instant, u64)>,
    last_time_sent: Option<u64>,
    /// Server clock (ms) before which no time update is sent ([`LIVE_MIN_GAP`] after
    /// the last one; 0: none sent yet).
    time_until: u64,
    /// Simulated time from which the next pose may be sent, ns.
    next_pose_ns: u64,
    /// Server clock (ms) before which no pose is sent (as `time_until`).
    pose_until: u64,
    /// Server clock (ms) before which no message is sent, per slot (as `time_until`).
    sent_until: Vec<u64>,
}

/// [`LIVE_MIN_GAP`] in milliseconds of the server's clock.
const GAP_MS: u64 = LIVE_MIN_GAP.as_millis() as u64;

/// Whether the gap that ends at `until` has passed at `now_ms` (then the next one ends
/// [`LIVE_MIN_GAP`] from now); times in milliseconds of the server's clock.
fn gap_passed(until: &mut u64, now_ms: u64) -> bool {
    if now_ms < *until {
        return false;
    }
    *until = now_ms + GAP_MS;
    true
}

impl std::fmt::Debug for LiveTap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveTap").field("speed", &self.speed).finish_non_exhaustive()
    }
}

/// Pacing lets the run fall this far behind before it stops trying to catch up.
const MAX_LAG: Duration = Duration::from_millis(250);

/// Longest single sleep while pacing.
const PACE_SLICE: Duration = Duration::from_millis(20);

impl LiveTap {
    /// The server's coarse clock, ms.
    fn now_ms(&self) -> u64 {
        self.shared.clock_ms.load(Ordering::Relaxed)
    }

    /// A client is connected.
    pub(crate) fn has_clients(&self) -> bool {
        self.shared.clients.is_open()
    }

    /// Open while a client is connected: a live-only recorder hands it to the runner,
    /// which skips the steps while it is closed ([`mmq_core::Observer::step_gate`]).
    pub(crate) fn gate(&self) -> StepGate {
        self.shared.clients.clone()
    }

    /// The message of `slot` is worth serializing: it is latched (kept for later
    /// subscribers), or someone listens and the topic's thinning lets it through (which
    /// counts it as sent: call [`Self::send`] next).
    pub(crate) fn wants(&mut self, slot: usize) -> bool {
        if self.shared.latched_slot.get(slot).copied().unwrap_or(false) {
            return true;
        }
        let Some(ch) = self.shared.channels.get(slot) else { return false };
        if !self.shared.gated_slot[slot] {
            return ch.has_sinks();
        }
        // The clock first: asking the channel for its subscribers costs more (a few
        // atomic operations) and most messages of an unpaced run fall within the gap.
        let now = self.now_ms();
        if now < self.sent_until[slot] || !ch.has_sinks() {
            return false;
        }
        self.sent_until[slot] = now + GAP_MS;
        true
    }

    /// Serializes a message with `write` into the tap's buffer, sends it (a latched
    /// message: keeps it, and sends it when its topic's thinning lets it through), and
    /// returns its bytes.
    pub(crate) fn send(&mut self, slot: usize, log_time: u64, write: impl FnOnce(&mut Vec<u8>)) -> &[u8] {
        self.scratch.clear();
        write(&mut self.scratch);
        let ch = &self.shared.channels[slot];
        let mut sinks = ch.has_sinks();
        if self.shared.latched_slot[slot] {
            if let Ok(mut l) = self.shared.latched.lock() {
                match &mut l[slot] {
                    // The scenes are republished unchanged: keep the bytes, move the time.
                    Some((t, b)) if *b == self.scratch => *t = log_time,
                    Some((t, b)) => {
                        *t = log_time;
                        b.clear();
                        b.extend_from_slice(&self.scratch);
                    }
                    None => l[slot] = Some((log_time, self.scratch.clone())),
                }
            }
            let now = self.now_ms();
            sinks = sinks && gap_passed(&mut self.sent_until[slot], now);
        }
        if sinks {
            ch.log_with_meta(&self.scratch, PartialMetadata { log_time: Some(log_time) });
            self.pace(log_time);
        }
        &self.scratch
    }

    /// Sends a message serialized once (the static scenes): a latched slot keeps its
    /// first bytes, which every new subscriber gets; sent now when someone listens and
    /// the topic's thinning lets it through.
    pub(crate) fn send_unchanged(&mut self, slot: usize, log_time: u64, bytes: &[u8]) {
        if self.shared.latched_slot[slot]
            && let Ok(mut l) = self.shared.latched.lock()
        {
            match &mut l[slot] {
                Some((t, _)) => *t = log_time,
                None => l[slot] = Some((log_time, bytes.to_vec())),
            }
        }
        let ch = &self.shared.channels[slot];
        let now = self.now_ms();
        if now < self.sent_until[slot] || !ch.has_sinks() {
            return;
        }
        self.sent_until[slot] = now + GAP_MS;
        ch.log_with_meta(bytes, PartialMetadata { log_time: Some(log_time) });
        self.pace(log_time);
    }

    /// Whether every message of the given `slots` (thinned per topic: not latched, not
    /// contacts or notes), the next pose and the next time update fall within
    /// [`LIVE_MIN_GAP`] of the last one of their kind sent: then none of them would go
    /// to the clients now. One load of the server's clock: a recorder skips such a step
    /// after keeping its running figures (and pacing it, [`Self::pace_step`]).
    #[inline]
    pub(crate) fn quiet(&self, slots: &[usize]) -> bool {
        let now = self.now_ms();
        now < self.pose_until
            && now < self.time_until
            && slots.iter().all(|&i| self.sent_until.get(i).is_some_and(|&u| now < u))
    }

    /// Paces a step that sends nothing (see [`Self::quiet`]): what [`Self::step_end`]
    /// does for it.
    pub(crate) fn pace_step(&mut self, log_time: u64) {
        if self.speed > 0.0 && self.has_clients() {
            self.pace(log_time);
        }
    }

    /// Whether the pose sample at `log_time` goes to the clients (with its estimate):
    /// someone listens, [`LIVE_POSE_PERIOD_NS`] of simulated time and [`LIVE_MIN_GAP`] of
    /// wall-clock time have passed since the last one sent.
    pub(crate) fn pose_due(&mut self, log_time: u64) -> bool {
        if !self.has_clients() || log_time < self.next_pose_ns {
            return false;
        }
        let now = self.now_ms();
        if !gap_passed(&mut self.pose_until, now) {
            return false;
        }
        self.next_pose_ns = (log_time / LIVE_POSE_PERIOD_NS + 1) * LIVE_POSE_PERIOD_NS;
        true
    }

    /// Sends robot `robot`'s transform (world → `robot<i>`, or `robot<i>_estimate`) on
    /// `/tf` (slot `tf`), as a swarm recording writes it.
    pub(crate) fn robot_transform(
        &mut self,
        tf: usize,
        log_time: u64,
        robot: u32,
        estimate: bool,
        p: [f64; 3],
    ) {
        let ch = &self.shared.channels[tf];
        if !ch.has_sinks() {
            return;
        }
        self.pose.set(log_time, p[0], p[1], p[2]);
        self.scratch.clear();
        self.pose.robot_transform(&mut self.scratch, robot, estimate);
        ch.log_with_meta(&self.scratch, PartialMetadata { log_time: Some(log_time) });
        self.pace(log_time);
    }

    /// Sends a pose on `/tf` (slot `tf`) and `/robot/pose` (slot `pose`), with the
    /// recording's bytes.
    pub(crate) fn pose(&mut self, tf: usize, pose: usize, log_time: u64, x: f64, y: f64, theta: f64) {
        let (c_tf, c_pose) = (&self.shared.channels[tf], &self.shared.channels[pose]);
        let (a, b) = (c_tf.has_sinks(), c_pose.has_sinks());
        if !(a || b) {
            return;
        }
        self.pose.set(log_time, x, y, theta);
        let meta = PartialMetadata { log_time: Some(log_time) };
        if a {
            self.scratch.clear();
            self.pose.frame_transform(&mut self.scratch);
            c_tf.log_with_meta(&self.scratch, meta);
        }
        if b {
            self.scratch.clear();
            self.pose.pose_in_frame(&mut self.scratch);
            c_pose.log_with_meta(&self.scratch, meta);
        }
        self.pace(log_time);
    }

    /// The end of a step at simulated time `log_time`: paces the run and advertises the
    /// time (at most once
    /// per [`LIVE_MIN_GAP`]: time updates go on the clients' control queue, which
    /// disconnects a client when it overflows).
    pub(crate) fn step_end(&mut self, log_time: u64) {
        if !self.has_clients() {
            return;
        }
        // Paced at every step, not only at the messages sent: thinned, they can be far
        // apart.
        if self.speed > 0.0 {
            self.pace(log_time);
        }
        if self.last_time_sent == Some(log_time) {
            return;
        }
        let now = self.now_ms();
        if !gap_passed(&mut self.time_until, now) {
            return;
        }
        self.last_time_sent = Some(log_time);
        if let Ok(h) = self.handle.lock()
            && let Some(h) = h.as_ref()
        {
            h.broadcast_time(log_time);
        }
    }

    /// Waits until wall-clock time catches up with `log_time` at the tap's speed.
    fn pace(&mut self, log_time: u64) {
        if self.speed <= 0.0 || !self.has_clients() {
            self.anchor = None;
            return;
        }
        let now = Instant::now();
        let (wall0, sim0) = *self.anchor.get_or_insert((now, log_time));
        let ahead_s = log_time.saturating_sub(sim0) as f64 * 1e-9 / self.speed;
        let due = wall0.checked_add(Duration::from_secs_f64(ahead_s.min(1e9))).unwrap_or(now);
        if due > now {
            // In slices, so that a client leaving lets the run go at once.
            loop {
                let left = due.saturating_duration_since(Instant::now());
                if left.is_zero() || !self.has_clients() {
                    break;
                }
                std::thread::sleep(left.min(PACE_SLICE));
            }
        } else if now - due > MAX_LAG {
            // Behind (a slow step, a time jump): start again from here, no burst.
            self.anchor = Some((now, log_time));
        }
    }
}
