//! mmq-log: MCAP run logs — the [`McapRecorder`] (an [`mmq_core::Observer`]), a reader
//! that recovers what it can from damaged files ([`read_log`]), a [`summary()`], an SVG
//! [`render()`] of the trajectory, and [`compare()`] for checking that two runs match.
//!
//! Logs are MCAP files with JSON messages described by `jsonschema` schemas, in zstd
//! chunks, written by the crate's own chunk writer (one zstd call per 1 MiB chunk, on a
//! writer thread; see `docs/logs.md`, "Cost") and read with the `mcap` crate. Geometry
//! uses Foxglove's well-known schemas so the Foxglove app draws it;
//! learning events use mmq's own (`mmq.*`). Topics, units and the time base are
//! documented in `docs/logs.md` and in [`recorder`].
//!
//! A swarm's run is recorded by the [`SwarmRecorder`] ([`swarm`]): every robot in one
//! file, fed by the swarm's own loop.
//!
//! The [`live`] view serves the same messages over Foxglove's WebSocket protocol while a
//! run goes on, and [`live::replay`] serves a recorded file with playback control.
//!
//! Architecture invariant: this is the only crate that knows MCAP and the Foxglove
//! protocol; it knows no learner
//! and no physics engine (it sees runs only through `mmq_core`'s observer hooks, and a
//! swarm's as plain `mmq_core` data).

pub mod compare;
pub mod error;
pub mod live;
mod mcap_out;
pub mod messages;
pub mod reader;
pub mod recorder;
pub mod render;
pub mod summary;
pub mod swarm;
mod writer;

pub use compare::{Mismatch, compare, compare_prefix};
pub use error::LogError;
pub use live::{LiveChannels, LiveConfig, LiveServer, LiveTap};
pub use reader::{LogAttachment, LogContents, PoseStamp, ReadStop, Stamped, TopicInfo, read_log};
pub use recorder::{
    McapRecorder, OutcomeHandle, RecordOutcome, RecordStats, RecorderConfig, StepWindow, TopicStats,
};
pub use render::{render, render_png, render_svg};
pub use summary::{LogSummary, summary};
pub use swarm::{SWARM_LIVE, SwarmDelivery, SwarmRecorder, SwarmSetup, SwarmStepIn};
