//! [`serve_file`]: plays a recorded MCAP file to the Foxglove app over the WebSocket
//! protocol, with playback control (play, pause, seek, speed) from the app's timeline.
//!
//! The file is read through the hardened reader (`reader/walk.rs`) and streamed: one
//! pass builds an index of its chunks (offsets, times, latched topics; see
//! `catalog.rs`), then a player reads the messages a chunk at a time and sends them at
//! their log time scaled by the chosen speed. Memory stays bounded whatever the file's
//! size; a damaged chunk is skipped, a file that can only partly be read plays up to
//! where it stops, and a file with nothing to play is an error.
//!
//! Playback starts by itself at the first subscription (a viewer without playback
//! control, such as Lichtblick, plays the file), unless [`ServeOptions::paused`] asks to
//! wait for the app's play command. A seek jumps to the first message at or after the
//! time asked, first sending the last message of every latched topic up to that time
//! (the arena, the robot's body, the heat maps), which every new subscriber also gets.

use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use foxglove::websocket::{
    Capability, ChannelView, Client, PlaybackCommand, PlaybackControlRequest, PlaybackState, PlaybackStatus,
    ServerListener,
};
use foxglove::{ChannelId, Context, PartialMetadata, WebSocketServerHandle};

use super::catalog::{Catalog, CatalogError, Cursor, Msg};
use super::{Greeted, LiveConfig, start_server, stop_server};
use crate::error::LogError;

/// How a file is served.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ServeOptions {
    /// Wait for the app's play command instead of playing at the first subscription.
    pub paused: bool,
}

/// Most messages sent in one turn of the player (control requests wait no longer).
const BATCH: usize = 10_000;

/// The player's position and mode.
#[derive(Debug)]
struct Player {
    status: PlaybackStatus,
    speed: f32,
    /// Simulated time shown, ns.
    current: u64,
    /// Pacing reference: (wall clock, log time) when playing (re)started.
    anchor: Option<(Instant, u64)>,
    /// A seek to this time waits for the player.
    seek: Option<u64>,
    /// The app sent a playback command (no autoplay then).
    commanded: bool,
    /// Playback started by itself: the state is to be told to the clients.
    announce: bool,
    /// When the last time update was sent (at most one per [`super::LIVE_MIN_GAP`]:
    /// they go on the clients' control queue).
    time_sent: Option<Instant>,
}

struct Shared {
    cat: Catalog,
    slots: HashMap<ChannelId, usize>,
    /// Last message sent of each latched slot: what a new subscriber gets.
    latched: Mutex<Vec<Option<super::Latched>>>,
    autoplay: bool,
    player: Mutex<Player>,
}

impl Shared {
    fn state(&self, p: &Player, did_seek: bool, request_id: Option<String>) -> PlaybackState {
        PlaybackState {
            current_time: p.current,
            playback_speed: p.speed,
            status: p.status,
            did_seek,
            request_id,
        }
    }

    /// Sends a message to every subscriber, keeping it when its topic is latched.
    fn send(&self, (slot, log_time, data): Msg) {
        self.cat.channels[slot].log_with_meta(&data, PartialMetadata { log_time: Some(log_time) });
        if self.cat.latched(slot)
            && let Ok(mut l) = self.latched.lock()
        {
            l[slot] = Some((log_time, data));
        }
    }
}

struct Listener(Arc<Shared>, Greeted, usize);

impl ServerListener for Listener {
    fn on_subscribe(&self, client: Client, channel: ChannelView<'_>) {
        self.1.greet(&client, self.2);
        let s = &self.0;
        let Some(&slot) = s.slots.get(&channel.id()) else { return };
        let Some(sink) = client.sink_id() else { return };
        let last = s.latched.lock().ok().and_then(|l| l.get(slot).cloned().flatten());
        if let Some((log_time, data)) = last {
            s.cat.channels[slot].log_with_meta_to_sink(
                &data,
                PartialMetadata { log_time: Some(log_time) },
                Some(sink),
            );
        }
        if s.autoplay
            && let Ok(mut p) = s.player.lock()
            && !p.commanded
            && p.status == PlaybackStatus::Paused
        {
            p.status = PlaybackStatus::Playing;
            p.anchor = None;
            p.announce = true;
        }
    }

    fn on_playback_control_request(&self, request: PlaybackControlRequest) -> Option<PlaybackState> {
        let s = &self.0;
        let mut p = s.player.lock().ok()?;
        p.commanded = true;
        let did_seek = request.seek_time.is_some();
        if let Some(t) = request.seek_time {
            let t = t.clamp(s.cat.range.0, s.cat.range.1);
            p.seek = Some(t);
            p.current = t;
            p.anchor = None;
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

/// A file being served; [`ReplayServer::run`] plays it until `stop`.
pub struct ReplayServer {
    shared: Arc<Shared>,
    handle: Option<WebSocketServerHandle>,
    addr: std::net::SocketAddr,
    _ctx: Arc<Context>,
}

impl std::fmt::Debug for ReplayServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReplayServer").field("addr", &self.addr).finish_non_exhaustive()
    }
}

/// Starts serving `path` (see the module documentation); `config.speed` is the initial
/// playback speed (0 is taken as 1). Returns `Ok(None)` when `stop` was raised while the
/// file was being indexed.
pub fn serve_file(
    path: &Path,
    config: &LiveConfig,
    options: ServeOptions,
    stop: &AtomicBool,
) -> Result<Option<ReplayServer>, LogError> {
    let ctx = Context::new();
    let cat = match Catalog::build(&ctx, path, stop) {
        Ok(c) => c,
        Err(CatalogError::Interrupted) => return Ok(None),
        Err(CatalogError::Log(e)) => return Err(e),
    };
    let range = cat.range;
    let mut latched = vec![None; cat.channels.len()];
    for (slot, t, data) in cat.latched_at(range.0)? {
        latched[slot] = Some((t, data));
    }
    let slots = cat.channels.iter().enumerate().map(|(i, c)| (c.id(), i)).collect();
    let speed = if config.speed > 0.0 { config.speed as f32 } else { 1.0 };
    let player = Player {
        status: PlaybackStatus::Paused,
        speed,
        current: range.0,
        anchor: None,
        seek: None,
        commanded: false,
        announce: false,
        time_sent: None,
    };
    let shared = Arc::new(Shared {
        cat,
        slots,
        latched: Mutex::new(latched),
        autoplay: !options.paused,
        player: Mutex::new(player),
    });
    let listener = Arc::new(Listener(Arc::clone(&shared), Greeted::default(), config.backlog));
    let handle = start_server(
        &ctx,
        config,
        vec![Capability::PlaybackControl, Capability::Time],
        listener,
        Some(range),
    )?;
    let addr = std::net::SocketAddr::new(config.addr.ip(), handle.port());
    Ok(Some(ReplayServer { shared, handle: Some(handle), addr, _ctx: ctx }))
}

impl ReplayServer {
    /// The address it listens on.
    pub fn addr(&self) -> std::net::SocketAddr {
        self.addr
    }

    /// Messages in the file (those that can be read).
    pub fn messages(&self) -> usize {
        usize::try_from(self.shared.cat.messages).unwrap_or(usize::MAX)
    }

    /// First and last log time, ns.
    pub fn time_range(&self) -> (u64, u64) {
        self.shared.cat.range
    }

    /// What of the file cannot be served (damaged chunks skipped, where reading stopped).
    pub fn warnings(&self) -> &[String] {
        &self.shared.cat.warnings
    }

    /// Plays on requests from the app until `stop` is set; then stops the server (a
    /// client that does not read is dropped, not waited for).
    pub fn run(mut self, stop: &AtomicBool) -> Result<(), LogError> {
        let Some(handle) = self.handle.take() else { return Ok(()) };
        let result = self.play(&handle, stop);
        stop_server(handle, self.addr);
        result
    }

    fn play(&self, handle: &WebSocketServerHandle, stop: &AtomicBool) -> Result<(), LogError> {
        let s = &self.shared;
        let mut cursor = Cursor::open(&s.cat, 0, usize::MAX, s.cat.range.0)?;
        while !stop.load(Ordering::Relaxed) {
            match self.tick(handle, &mut cursor)? {
                Some(new) => cursor = new,
                None => std::thread::sleep(Duration::from_millis(5)),
            }
        }
        Ok(())
    }

    /// One turn of the player: a seek (returns the new cursor), or the messages due.
    fn tick(&self, handle: &WebSocketServerHandle, cursor: &mut Cursor) -> Result<Option<Cursor>, LogError> {
        let s = &self.shared;
        let seek = s.player.lock().ok().and_then(|mut p| p.seek.take());
        if let Some(t) = seek {
            // Disk reads without the lock: control requests are answered meanwhile.
            let new = Cursor::open(&s.cat, s.cat.block_at(t), usize::MAX, t)?;
            for m in s.cat.latched_at(t)? {
                s.send(m);
            }
            handle.broadcast_time(t);
            return Ok(Some(new));
        }
        let Ok(mut p) = s.player.lock() else { return Ok(None) };
        if std::mem::take(&mut p.announce) {
            handle.broadcast_playback_state(s.state(&p, false, None));
        }
        if p.status != PlaybackStatus::Playing || p.seek.is_some() {
            return Ok(None);
        }
        let now = Instant::now();
        let current = p.current;
        let (wall0, t0) = *p.anchor.get_or_insert((now, current));
        let speed = f64::from(p.speed);
        // Log time reached by now.
        let reached = t0.saturating_add((now.duration_since(wall0).as_secs_f64() * speed * 1e9) as u64);
        let mut sent = 0;
        while sent < BATCH && cursor.peek_time(&s.cat)?.is_some_and(|t| t <= reached) {
            if let Some(m) = cursor.next(&s.cat)? {
                s.send(m);
            }
            sent += 1;
        }
        p.current = reached.min(s.cat.range.1).max(p.current);
        if p.time_sent.is_none_or(|t| now.duration_since(t) >= super::LIVE_MIN_GAP) {
            p.time_sent = Some(now);
            handle.broadcast_time(p.current);
        }
        if cursor.peek_time(&s.cat)?.is_none() {
            p.status = PlaybackStatus::Ended;
            p.current = s.cat.range.1;
            handle.broadcast_playback_state(s.state(&p, false, None));
        }
        Ok(None)
    }
}
