//! mmq-robot: a rapier2d differential-drive robot in the grid arena, as an
//! [`mmq_core::Env`] whose actions are motion primitives between cells.
//!
//! Architecture invariant: this is the only crate of mmq that knows rapier. It knows no
//! learner and no log format; what loggers need (poses, contacts, build features) goes
//! out through the `Env` trait and [`features`].
//!
//! ```no_run
//! use mmq_core::{Env, Start, World};
//! use mmq_robot::{RobotConfig, RobotEnv};
//! let world = World::load("worlds/paper-9x9.toml").unwrap();
//! let cfg = RobotConfig::from_world(&world).unwrap();
//! let mut env = RobotEnv::new(&world, cfg).unwrap();
//! let s0 = env.reset(7, Start::World).unwrap();
//! let step = env.step(0).unwrap(); // drive to the northern neighbour
//! # let _ = (s0, step);
//! ```

pub mod arena;
pub mod config;
pub mod controller;
mod diagnostics;
mod drive;
mod env;
pub mod estimator;
pub mod localisation;
pub mod odometry;
pub mod overrides;
mod physics;
mod primitive;
pub mod profile;
mod realistic;
mod robot;
pub mod swarm;

pub use arena::{Wall, walls};
pub use config::{ActionSet, DEFAULT_DT_S, NoiseConfig, Preset, RobotConfig, RobotError, RobotTable};
pub use env::RobotEnv;
pub use overrides::apply_overrides;
pub use profile::{Profile, RealisticConfig, RealisticTable};
pub use swarm::{SwarmConfig, SwarmEnv, SwarmStep};

/// The rapier2d version this crate was built against.
pub const RAPIER_VERSION: &str = rapier2d::VERSION;

/// Build facts that bear on determinism, for run logs: the rapier version and the
/// features this crate enables, the scalar type, and the default physics step.
///
/// `enhanced-determinism` is enabled by this crate's manifest (rapier then uses `libm`
/// for its transcendental functions and deterministic hash maps); the controllers use
/// `libm` too, so a trajectory does not depend on the platform's maths library.
pub fn features() -> Vec<(String, String)> {
    [
        ("rapier2d.version", RAPIER_VERSION.to_string()),
        ("rapier2d.enhanced-determinism", "on".to_string()),
        ("rapier2d.scalar", "f32".to_string()),
        ("rapier2d.parallel", "not enabled by mmq-robot".to_string()),
        ("rapier2d.simd", "not enabled by mmq-robot".to_string()),
        ("controller.maths", "libm".to_string()),
        ("physics.default_dt_s", DEFAULT_DT_S.to_string()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}
