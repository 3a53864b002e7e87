//! Integration tests of mmq-robot, one module per topic.

mod config;
mod determinism;
mod heading;
mod motion;
mod realistic;
mod swarm;
mod trace;

use mmq_core::World;
use mmq_robot::RobotEnv;

/// A shipped world by name.
pub fn world(name: &str) -> World {
    World::load(format!("{}/../../worlds/{name}.toml", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

/// The environment of a shipped world with its own configuration.
pub fn env(name: &str) -> RobotEnv {
    RobotEnv::from_world(&world(name)).unwrap()
}

/// A named figure from `Telemetry::stats`.
pub fn stat(env: &RobotEnv, key: &str) -> f64 {
    use mmq_core::Telemetry;
    env.stats().into_iter().find(|(k, _)| k == key).map(|(_, v)| v).unwrap()
}
