//! mmq-core: what every part of mmq shares — the [`Env`] trait, worlds, seeds, reward
//! delay distributions, the [`DelayedReward`] channel, the exact optimum of a world, the
//! radio network a swarm consults over before a reward ([`consult`]) and the [`Observer`]
//! hooks.
//!
//! Architecture invariant: this crate knows no learner, no physics engine, no log format
//! and no plotting library.

pub mod ceiling;
pub mod channel;
pub mod consult;
pub mod delay;
pub mod env;
pub mod files;
pub mod observer;
pub mod optimum;
pub mod seed;
pub mod shipped;
pub mod stats;
pub mod text_value;
pub mod world;

pub use ceiling::{Ceiling, epsilon_soft_ceiling, epsilon_soft_ceiling_until};
pub use channel::{DelayStats, DelayedReward, DelayedStep, Emission, Ledger};
pub use consult::{ConsultModel, Consultation, Network, Radio};
pub use delay::{DelayDist, DelayError, DelaySampler, DelayUnit, SecondsDist, SecondsSampler};
pub use env::{
    Action, ContactSample, Env, EnvError, Event, Move, PoseSample, Start, State, Step, StepTrace, Telemetry,
};
pub use observer::{Observer, Resume, RunInfo, StepGate, StepRecord};
pub use optimum::{Optimum, optimum};
pub use seed::{Rng, SeedTree, Stream};
pub use world::{Cell, Rewards, StartRule, World, WorldError};
