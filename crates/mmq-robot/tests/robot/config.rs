//! The `[robot]` table: presets, overrides, and validation messages.

use mmq_core::World;
use mmq_robot::{ActionSet, NoiseConfig, Preset, RobotConfig, RobotEnv};

fn err(table: &str) -> String {
    RobotConfig::from_toml(table).unwrap_err().to_string()
}

fn world_with(robot: &str, cell_size: f64) -> World {
    World::parse(&format!("cell_size = {cell_size}\nmap = \"G.S\"\n[robot]\n{robot}"), "w.toml").unwrap()
}

#[test]
fn defaults_and_presets() {
    let c = RobotConfig::default();
    assert_eq!(c.preset, Preset::Turtlebot3Burger);
    assert_eq!(
        (
            c.wheel_base_m,
            c.radius_m,
            c.max_speed_mps,
            c.max_turn_rate_radps,
            c.max_accel_mps2,
            c.max_angular_accel_radps2
        ),
        (0.160, 0.105, 0.22, 2.84, 2.5, 3.2)
    );
    assert_eq!(c.dt_s, 1.0 / 60.0);
    assert_eq!(c.actions, ActionSet::Moves);
    assert_eq!(c.noise, None);
    // A world without a [robot] table gets the default.
    let w = World::parse("map = \"G.S\"", "w.toml").unwrap();
    assert_eq!(RobotConfig::from_world(&w).unwrap(), c);
    // Presets by name, with overrides.
    let w = world_with("preset = \"turtlebot3-waffle\"\nmax_speed_mps = 0.2\nactions = \"heading\"", 0.5);
    let c = RobotConfig::from_world(&w).unwrap();
    assert_eq!(
        (c.preset, c.wheel_base_m, c.max_speed_mps, c.actions),
        (Preset::Turtlebot3Waffle, 0.287, 0.2, ActionSet::Heading)
    );
    let c = RobotConfig::from_toml("preset = \"kobuki\"\n[noise]\nwheel_gain_sd = 0.1").unwrap();
    assert_eq!(c.noise, Some(NoiseConfig { wheel_gain_sd: 0.1, ..NoiseConfig::default() }));
    assert_eq!(c.max_speed_mps, 0.7);
}

#[test]
fn the_resolved_config_round_trips() {
    let c = RobotConfig::from_toml("preset = \"kobuki\"\ntimeout_factor = 4.0\n[noise]\n").unwrap();
    let text = toml::to_string(&c).unwrap();
    assert!(text.contains("preset = \"kobuki\"") && text.contains("max_speed_mps = 0.7"), "{text}");
    assert_eq!(RobotConfig::from_toml(&text).unwrap(), c);
}

#[test]
fn parse_errors_name_the_field() {
    let e = err("max_sped_mps = 0.3");
    assert!(e.starts_with("robot config: ") && e.contains("unknown field `max_sped_mps`"), "{e}");
    let e = err("preset = \"roomba\"");
    assert!(e.contains("unknown variant `roomba`") && e.contains("turtlebot3-burger"), "{e}");
    let e = err("max_speed_mps = \"fast\"");
    assert!(e.contains("invalid type"), "{e}");
    let e = err("[noise]\nwheel_gain = 0.1");
    assert!(e.contains("unknown field `wheel_gain`"), "{e}");
}

#[test]
fn invalid_values_say_what_is_accepted() {
    assert_eq!(
        err("max_speed_mps = -0.1"),
        "robot config: field `max_speed_mps` = -0.1 is not accepted: it is not positive; use a speed in m/s in (0, 20]"
    );
    assert_eq!(
        err("dt_s = 0.0"),
        "robot config: field `dt_s` = 0 is not accepted: it is not positive; use a physics step in seconds in (0, 0.1], e.g. 0.016667"
    );
    assert_eq!(
        err("max_accel_mps2 = nan"),
        "robot config: field `max_accel_mps2` = NaN is not accepted: it is not a number; use an acceleration in m/s² in (0, 100]"
    );
    assert_eq!(
        err("max_turn_rate_radps = inf"),
        "robot config: field `max_turn_rate_radps` = inf is not accepted: it is not finite; use a turn rate in rad/s in (0, 50]"
    );
    assert_eq!(
        err("timeout_factor = 0.5"),
        "robot config: field `timeout_factor` = 0.5 is not accepted: it is below 1; use a multiple in [1, 100], e.g. 3"
    );
    assert_eq!(
        err("dt_s = 0.5"),
        "robot config: field `dt_s` = 0.5 is not accepted: it is above 0.1; use a physics step in seconds in (0, 0.1], e.g. 0.016667"
    );
    let e = err("wheel_base_m = 0.3");
    assert!(e.contains("`wheel_base_m` = 0.3") && e.contains("at most 2 × `radius_m`"), "{e}");
    let e = err("[noise]\nslip_probability = 1.5");
    assert!(e.contains("`noise.slip_probability` = 1.5") && e.contains("a probability in [0, 1]"), "{e}");
}

#[test]
fn a_robot_wider_than_a_cell_is_rejected() {
    let w = world_with("preset = \"turtlebot3-waffle\"", 0.4);
    let e = RobotConfig::from_world(&w).unwrap_err().to_string();
    assert_eq!(
        e,
        "robot config: field `radius_m` = 0.22 is not accepted: the robot is too wide for the world's cells: \
         diameter 0.44 m plus 2 × 0.02 m clearance exceeds `cell_size` = 0.4 m; \
         use a radius at most 0.18 m, or a `cell_size` of at least 0.48 m in the world file"
    );
    // The same check guards RobotEnv::new with an explicit configuration.
    let w = World::parse("cell_size = 0.2\nmap = \"G.S\"", "w.toml").unwrap();
    let e = RobotEnv::new(&w, RobotConfig::default()).unwrap_err().to_string();
    assert!(e.contains("too wide"), "{e}");
}
