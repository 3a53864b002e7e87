//! [`serve_file`]: plays a recorded MCAP file to the Foxglove app over the WebSocket
//! protocol, with playback control (play, pause, seek, speed) from the app's timeline.
//!
//! The file's messages are loaded once (in log-time order), and a player sends them at
//! their log time scaled by the chosen speed. Playback starts paused at the first
//! message; a seek jumps to the first message at or after the time asked, first sending
//! the last message of every latched topic up to that time (the arena, the robot's body,
//! the heat maps), which every new subscriber also gets. A file that the reader can only
//! partly read plays up to where it stops.

use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use foxglove::websocket::{
    Capability, ChannelView, Client, PlaybackCommand, PlaybackControlRequest, PlaybackState, PlaybackStatus,
    ServerListener,
};
use foxglove::{ChannelId, Context, PartialMetadata, RawChannel, Schema};

use super::{LiveConfig, start_server};
use crate::error::LogError;
use crate::messages::LATCHED;

/// One message of the file.
struct Msg {
    channel: usize,
    log_time: u64,
    data: Vec<u8>,
}

/// The player's position and mode.
#[derive(Debug)]
struct Player {
    status: PlaybackStatus,
    speed: f32,
    /// Index of the next message to send.
    next: usize,
    /// Simulated time shown, ns.
    current: u64,
    /// Pacing reference: (wall clock, log time) when playing (re)started.
    anchor: Option<(Instant, u64)>,
    /// A seek happened: latched topics must be re-sent before playing on.
    reseed: bool,
}

struct Shared {
    /// The SDK context the channels and the server belong to (kept alive with them).
    _ctx: Arc<Context>,
    channels: Vec<Arc<RawChannel>>,
    slots: HashMap<ChannelId, usize>,
    latched: Vec<bool>,
    messages: Vec<Msg>,
    range: (u64, u64),
    player: Mutex<Player>,
}

impl Shared {
    /// Index of the first message at or after `t`.
    fn index_at(&self, t: u64) -> usize {
        self.messages.partition_point(|m| m.log_time < t)
    }

    /// The last message of channel `slot` at or before time `t`.
    fn latched_at(&self, slot: usize, t: u64) -> Option<&Msg> {
        let upto = self.messages.partition_point(|m| m.log_time <= t);
        self.messages[..upto].iter().rev().find(|m| m.channel == slot)
    }

    fn state(&self, p: &Player, did_seek: bool, request_id: Option<String>) -> PlaybackState {
        PlaybackState {
            current_time: p.current,
            playback_speed: p.speed,
            status: p.status,
            did_seek,
            request_id,
        }
    }
}

struct Listener(Arc<Shared>);

impl ServerListener for Listener {
    fn on_subscribe(&self, client: Client, channel: ChannelView<'_>) {
        let s = &self.0;
        let Some(&slot) = s.slots.get(&channel.id()) else { return };
        let Some(sink) = client.sink_id() else { return };
        if !s.latched[slot] {
            return;
        }
        let now = s.player.lock().map(|p| p.current).unwrap_or(s.range.0);
        if let Some(m) = s.latched_at(slot, now) {
            s.channels[slot].log_with_meta_to_sink(
                &m.data,
                PartialMetadata { log_time: Some(m.log_time) },
                Some(sink),
            );
        }
    }

    fn on_playback_control_request(&self, request: PlaybackControlRequest) -> Option<PlaybackState> {
        let s = &self.0;
        let mut p = s.player.lock().ok()?;
        let did_seek = request.seek_time.is_some();
        if let Some(t) = request.seek_time {
            let t = t.clamp(s.range.0, s.range.1);
            p.next = s.index_at(t);
            p.current = t;
            p.anchor = None;
            p.reseed = true;
            if p.status == PlaybackStatus::Ended {
                p.status = PlaybackStatus::Paused;
            }
        }
        if request.playback_speed.is_finite() && request.playback_speed > 0.0 {
            p.speed = request.playback_speed;
            p.anchor = None;
        }
        match request.playback_command {
            PlaybackCommand::Play if p.status != PlaybackStatus::Ended => p.status = PlaybackStatus::Playing,
            PlaybackCommand::Pause if p.status != PlaybackStatus::Ended => {
                p.status = PlaybackStatus::Paused;
                p.anchor = None;
            }
            _ => {}
        }
        Some(s.state(&p, did_seek, Some(request.request_id)))
    }
}

/// Loads the messages of `path` in log-time order, with a channel per (topic, schema).
fn load(ctx: &Arc<Context>, path: &Path) -> Result<(Vec<Arc<RawChannel>>, Vec<Msg>), LogError> {
    let bytes = std::fs::read(path).map_err(|source| LogError::Io {
        path: path.to_path_buf(),
        action: "read the log",
        source,
    })?;
    if !bytes.starts_with(mcap::MAGIC) {
        return Err(LogError::NotMcap { path: path.to_path_buf() });
    }
    let mut channels: Vec<Arc<RawChannel>> = Vec::new();
    let mut by_id: HashMap<u16, usize> = HashMap::new();
    let mut messages = Vec::new();
    let stream = mcap::MessageStream::new(&bytes).map_err(|source| LogError::Mcap {
        path: path.to_path_buf(),
        action: "read the log",
        source,
    })?;
    for m in stream {
        // A damaged tail: play what came before it.
        let Ok(m) = m else { break };
        let slot = match by_id.get(&m.channel.id) {
            Some(&s) => s,
            None => {
                let mut b = ctx
                    .channel_builder(m.channel.topic.clone())
                    .message_encoding(m.channel.message_encoding.clone());
                if let Some(sc) = &m.channel.schema {
                    b = b.schema(Schema::new(sc.name.clone(), sc.encoding.clone(), sc.data.to_vec()));
                }
                let ch = b.build_raw().map_err(|e| LogError::NoWorld {
                    path: path.to_path_buf(),
                    message: format!("cannot serve topic {}: {e}", m.channel.topic),
                })?;
                channels.push(ch);
                by_id.insert(m.channel.id, channels.len() - 1);
                channels.len() - 1
            }
        };
        messages.push(Msg { channel: slot, log_time: m.log_time, data: m.data.into_owned() });
    }
    // Stable: messages of one time keep their file order.
    messages.sort_by_key(|m| m.log_time);
    Ok((channels, messages))
}

/// A file being served; [`ReplayServer::run`] plays it until `stop`.
pub struct ReplayServer {
    shared: Arc<Shared>,
    handle: Option<foxglove::WebSocketServerHandle>,
    addr: std::net::SocketAddr,
}

impl std::fmt::Debug for ReplayServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReplayServer").field("addr", &self.addr).finish_non_exhaustive()
    }
}

/// Starts serving `path` (see the module documentation); `config.speed` is the initial
/// playback speed (0 is taken as 1).
pub fn serve_file(path: &Path, config: &LiveConfig) -> Result<ReplayServer, LogError> {
    let ctx = Context::new();
    let (channels, messages) = load(&ctx, path)?;
    let range = match (messages.first(), messages.last()) {
        (Some(a), Some(b)) => (a.log_time, b.log_time),
        _ => (0, 0),
    };
    let slots = channels.iter().enumerate().map(|(i, c)| (c.id(), i)).collect();
    let latched = channels.iter().map(|c| LATCHED.contains(&c.topic())).collect();
    let speed = if config.speed > 0.0 { config.speed as f32 } else { 1.0 };
    let player = Player {
        status: PlaybackStatus::Paused,
        speed,
        next: 0,
        current: range.0,
        anchor: None,
        reseed: false,
    };
    let shared = Arc::new(Shared {
        _ctx: Arc::clone(&ctx),
        channels,
        slots,
        latched,
        messages,
        range,
        player: Mutex::new(player),
    });
    let listener = Arc::new(Listener(Arc::clone(&shared)));
    let handle = start_server(
        &ctx,
        config.addr,
        &config.name,
        vec![Capability::PlaybackControl, Capability::Time],
        listener,
        Some(range),
    )?;
    let addr = std::net::SocketAddr::new(config.addr.ip(), handle.port());
    Ok(ReplayServer { shared, handle: Some(handle), addr })
}

impl ReplayServer {
    /// The address it listens on.
    pub fn addr(&self) -> std::net::SocketAddr {
        self.addr
    }

    /// Messages in the file.
    pub fn messages(&self) -> usize {
        self.shared.messages.len()
    }

    /// First and last log time, ns.
    pub fn time_range(&self) -> (u64, u64) {
        self.shared.range
    }

    /// Plays on requests from the app until `stop` is set; then stops the server.
    pub fn run(mut self, stop: &AtomicBool) {
        let handle = self.handle.take().expect("a server that has not run");
        while !stop.load(Ordering::Relaxed) {
            let wait = self.tick(&handle);
            std::thread::sleep(wait);
        }
        handle.stop().wait_blocking();
        super::wait_port_free(self.addr);
    }

    /// Sends what is due; returns how long to wait before the next call.
    fn tick(&self, handle: &foxglove::WebSocketServerHandle) -> Duration {
        let s = &self.shared;
        let Ok(mut p) = s.player.lock() else { return Duration::from_millis(10) };
        if p.reseed {
            p.reseed = false;
            for slot in (0..s.channels.len()).filter(|&i| s.latched[i]) {
                if let Some(m) = s.latched_at(slot, p.current) {
                    s.channels[slot].log_with_meta(&m.data, PartialMetadata { log_time: Some(m.log_time) });
                }
            }
            handle.broadcast_time(p.current);
        }
        if p.status != PlaybackStatus::Playing {
            return Duration::from_millis(10);
        }
        let now = Instant::now();
        let current = p.current;
        let (wall0, t0) = *p.anchor.get_or_insert((now, current));
        let speed = f64::from(p.speed);
        // Log time reached by now.
        let reached = t0.saturating_add((now.duration_since(wall0).as_secs_f64() * speed * 1e9) as u64);
        let mut sent = 0;
        while let Some(m) = s.messages.get(p.next).filter(|m| m.log_time <= reached) {
            s.channels[m.channel].log_with_meta(&m.data, PartialMetadata { log_time: Some(m.log_time) });
            p.next += 1;
            sent += 1;
            // Yield now and then so control requests get the lock.
            if sent >= 10_000 {
                break;
            }
        }
        p.current = reached.min(s.range.1).max(p.current);
        handle.broadcast_time(p.current);
        if p.next >= s.messages.len() {
            p.status = PlaybackStatus::Ended;
            p.current = s.range.1;
            handle.broadcast_playback_state(s.state(&p, false, None));
            return Duration::from_millis(10);
        }
        let due = s.messages[p.next].log_time.saturating_sub(p.current) as f64 * 1e-9 / speed;
        Duration::from_secs_f64(due.clamp(0.0, 0.02))
    }
}
