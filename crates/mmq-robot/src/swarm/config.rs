//! The `[swarm]` table of a world file and its `KEY=VALUE` overrides (the CLI's
//! `--swarm`, a sweep's `swarm` list), resolved and checked against the world.
//!
//! ```toml
//! [swarm]
//! robots = 4                 # 1–64
//! starts = "random"          # or [[row, col], ...], 1-based, one per robot
//! bump_penalty = -1.0        # reward for bumping into another robot (default: the wall's)
//! consult = "peers"          # none | peers | server
//! k = 2                      # peers: replies needed (the other models ignore it)
//! radio_range_m = 1.5        # radio range, metres
//! hop_delay = "wifi"         # one hop's latency: any delay spec in seconds
//! loss = 0.05                # probability that one hop's attempt is lost (it is retried)
//! server = [5, 5]            # server: the base station's cell (default: the respawn cell)
//! learners = "independent"   # one learner per robot, or "shared": one table for all
//! ```
//!
//! `learners` is read by the lab, which assigns the learners; the environment keeps it
//! only so that a swarm is described by one table (and a sweep can vary it like the rest).

use mmq_core::delay::seconds::SecondsDist;
use mmq_core::{DelayDist, World};
use serde::Deserialize;
use toml::{Table, Value};

use crate::config::RobotError;

/// Largest swarm.
pub const MAX_ROBOTS: usize = 64;

/// The fields of the `[swarm]` table.
pub const SWARM_FIELDS: [&str; 10] = [
    "robots",
    "starts",
    "bump_penalty",
    "consult",
    "k",
    "radio_range_m",
    "hop_delay",
    "loss",
    "server",
    "learners",
];

/// How the robots' learners are assigned.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Learners {
    /// One learner per robot, each with its own tables.
    #[default]
    Independent,
    /// One learner for all robots (parameter sharing): every robot learns into the same
    /// tables, each with its own memory of its past steps.
    Shared,
}

impl Learners {
    /// The name in a `[swarm]` table.
    pub fn name(self) -> &'static str {
        match self {
            Learners::Independent => "independent",
            Learners::Shared => "shared",
        }
    }
}

/// How a robot's reward reaches it.
#[derive(Clone, Debug, PartialEq)]
pub enum Consult {
    /// At once (the single robot's behaviour).
    None,
    /// When `k` peers have answered over the radio.
    Peers {
        /// Replies needed.
        k: usize,
    },
    /// When the base station in this cell has answered over the radio.
    Server {
        /// The base station's cell.
        cell: usize,
    },
}

impl Consult {
    /// The name in the `[swarm]` table.
    pub fn name(&self) -> &'static str {
        match self {
            Consult::None => "none",
            Consult::Peers { .. } => "peers",
            Consult::Server { .. } => "server",
        }
    }
}

/// Where the robots start.
#[derive(Clone, Debug, PartialEq)]
pub enum Starts {
    /// Each robot draws its start as the single robot does (the world's start rule);
    /// a robot whose draw is taken starts at the next free cell in reading order.
    Random,
    /// These cells, one per robot.
    Cells(Vec<usize>),
}

/// A resolved, checked swarm configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct SwarmConfig {
    /// Number of robots.
    pub robots: usize,
    /// Where they start.
    pub starts: Starts,
    /// The reward for bumping into another robot.
    pub bump_penalty: f64,
    /// How rewards are delivered.
    pub consult: Consult,
    /// Radio range, metres.
    pub radio_range_m: f64,
    /// One hop's latency.
    pub hop_delay: SecondsDist,
    /// Probability that one attempt over one hop is lost.
    pub loss: f64,
    /// How the lab assigns the robots' learners.
    pub learners: Learners,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SwarmTable {
    robots: Option<i64>,
    starts: Option<Value>,
    bump_penalty: Option<f64>,
    consult: Option<String>,
    k: Option<i64>,
    radio_range_m: Option<f64>,
    hop_delay: Option<String>,
    loss: Option<f64>,
    server: Option<Vec<i64>>,
    learners: Option<String>,
}

fn bad(
    field: &'static str,
    value: impl ToString,
    problem: impl Into<String>,
    accepted: impl Into<String>,
) -> RobotError {
    RobotError::Swarm { field, value: value.to_string(), problem: problem.into(), accepted: accepted.into() }
}

/// Merges `overrides` (each `KEY=VALUE`, later ones winning) into a copy of `table`
/// (a world's `[swarm]` table, or none). Values are read as TOML (`4`, `"peers"`,
/// `[[1, 1], [9, 9]]`), else as bare strings (`peers`).
pub fn apply_swarm_overrides(table: Option<&Table>, overrides: &[String]) -> Result<Table, RobotError> {
    let mut out = table.cloned().unwrap_or_default();
    for text in overrides {
        let Some((key, value)) = mmq_core::text_value::key_value(text) else {
            return Err(RobotError::BadValue {
                text: text.clone(),
                problem: "it is not KEY=VALUE".into(),
                accepted: "KEY=VALUE, e.g. robots=4".into(),
            });
        };
        if !SWARM_FIELDS.contains(&key) {
            return Err(RobotError::UnknownKey { key: key.to_string(), known: SWARM_FIELDS.join(", ") });
        }
        out.insert(key.to_string(), value);
    }
    Ok(out)
}

impl SwarmConfig {
    /// The world's `[swarm]` table with `overrides` applied, resolved against `world`.
    pub fn from_world(world: &World, overrides: &[String]) -> Result<SwarmConfig, RobotError> {
        let table = apply_swarm_overrides(world.swarm.as_ref(), overrides)?;
        SwarmConfig::from_table(&table, world)
    }

    /// Resolves a `[swarm]` table against `world` and checks every field.
    pub fn from_table(table: &Table, world: &World) -> Result<SwarmConfig, RobotError> {
        let raw: SwarmTable = Table::try_into(table.clone())
            .map_err(|e| RobotError::Parse { message: format!("[swarm]: {}", e.message().trim()) })?;
        let robots = raw.robots.unwrap_or(1);
        if !(1..=MAX_ROBOTS as i64).contains(&robots) {
            return Err(bad("robots", robots, "a swarm has 1 to 64 robots", "robots = 1 … 64"));
        }
        let robots = robots as usize;
        let places = world.free_cells().filter(|&c| c != world.goal).count();
        if robots > places {
            return Err(bad(
                "robots",
                robots,
                format!("the world has only {places} free cells besides the goal to start in"),
                format!("at most {places} robots, or a larger world"),
            ));
        }
        let starts = starts_of(raw.starts.as_ref(), robots, world)?;
        let bump_penalty = raw.bump_penalty.unwrap_or(world.rewards.wall);
        if !bump_penalty.is_finite() {
            return Err(bad("bump_penalty", bump_penalty, "it is not finite", "a finite reward, e.g. -1"));
        }
        let consult = match raw.consult.as_deref().unwrap_or("none") {
            "none" => Consult::None,
            "peers" => {
                let k = raw.k.unwrap_or(1);
                if k < 1 || k as usize > robots - 1 {
                    let problem = if robots == 1 {
                        "a lone robot has no peer to consult".to_string()
                    } else {
                        format!("the swarm has {} peers besides the robot itself", robots - 1)
                    };
                    return Err(bad(
                        "k",
                        k,
                        problem,
                        format!("k = 1 … {} or more robots", robots.max(2) - 1),
                    ));
                }
                Consult::Peers { k: k as usize }
            }
            "server" => Consult::Server { cell: server_cell(raw.server.as_deref(), world)? },
            other => return Err(bad("consult", other, "unknown model", "none, peers or server")),
        };
        let radio_range_m = raw.radio_range_m.unwrap_or(1.5);
        if !(radio_range_m.is_finite() && radio_range_m > 0.0) {
            return Err(bad(
                "radio_range_m",
                radio_range_m,
                "a range is positive",
                "a range in metres, e.g. 1.5",
            ));
        }
        let spec = raw.hop_delay.unwrap_or_else(|| "wifi".into());
        let hop_delay = match DelayDist::parse(&spec) {
            Ok(d) => d.as_seconds().cloned().ok_or_else(|| {
                bad(
                    "hop_delay",
                    &spec,
                    "a hop's latency is in seconds",
                    "a spec in seconds: wifi, const:0.2s, exponential:0.05s, …",
                )
            })?,
            Err(e) => {
                return Err(bad("hop_delay", &spec, e.to_string(), "a delay spec in seconds, e.g. wifi"));
            }
        };
        let loss = raw.loss.unwrap_or(0.0);
        if !(0.0..0.99).contains(&loss) {
            return Err(bad(
                "loss",
                loss,
                "a loss probability is at least 0 and below 0.99",
                "loss = 0 … 0.98",
            ));
        }
        let learners = match raw.learners.as_deref().unwrap_or("independent") {
            "independent" => Learners::Independent,
            "shared" => Learners::Shared,
            other => return Err(bad("learners", other, "unknown assignment", "independent or shared")),
        };
        Ok(SwarmConfig { robots, starts, bump_penalty, consult, radio_range_m, hop_delay, loss, learners })
    }
}

/// A 1-based `[row, col]` as a free, non-goal cell of `world`.
fn cell_of(field: &'static str, rc: &[i64], world: &World) -> Result<usize, RobotError> {
    let text = format!("{rc:?}");
    let &[r, c] = rc else {
        return Err(bad(field, text, "a cell is [row, column]", "[row, column], 1-based"));
    };
    if r < 1 || c < 1 || r as usize > world.height || c as usize > world.width {
        return Err(bad(
            field,
            text,
            format!("the map has {} rows and {} columns", world.height, world.width),
            "a cell inside the map, 1-based",
        ));
    }
    let cell = world.index(r as usize - 1, c as usize - 1);
    if !world.is_free(cell) {
        return Err(bad(field, text, "that cell is blocked (`#`)", "a free cell of the map"));
    }
    Ok(cell)
}

fn starts_of(v: Option<&Value>, robots: usize, world: &World) -> Result<Starts, RobotError> {
    let list = match v {
        None => return Ok(Starts::Random),
        Some(Value::String(s)) if s == "random" => return Ok(Starts::Random),
        Some(Value::Array(a)) => a,
        Some(other) => {
            return Err(bad(
                "starts",
                other,
                "not a list of cells",
                "\"random\" or [[row, col], ...], 1-based",
            ));
        }
    };
    if list.len() != robots {
        return Err(bad(
            "starts",
            list.len(),
            format!("{robots} robots need {robots} starts"),
            "one [row, col] per robot, or \"random\"",
        ));
    }
    let mut cells = Vec::with_capacity(robots);
    for item in list {
        let rc: Vec<i64> = match item {
            Value::Array(xs) => xs.iter().map(|x| x.as_integer().unwrap_or(0)).collect(),
            other => return Err(bad("starts", other, "a start is [row, col]", "[[row, col], ...], 1-based")),
        };
        let cell = cell_of("starts", &rc, world)?;
        if cell == world.goal {
            return Err(bad(
                "starts",
                format!("{rc:?}"),
                "that is the goal cell",
                "a free cell that is not `G`",
            ));
        }
        if cells.contains(&cell) {
            return Err(bad(
                "starts",
                format!("{rc:?}"),
                "two robots start in that cell",
                "a different cell per robot",
            ));
        }
        cells.push(cell);
    }
    Ok(Starts::Cells(cells))
}

fn server_cell(v: Option<&[i64]>, world: &World) -> Result<usize, RobotError> {
    match v {
        None => Ok(world.respawn),
        Some(rc) => cell_of("server", rc, world),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn world() -> World {
        World::parse("map = \"\"\"\n...G\n.#..\nS...\n\"\"\"", "t").unwrap()
    }

    fn cfg(xs: &[&str]) -> Result<SwarmConfig, RobotError> {
        let ov: Vec<String> = xs.iter().map(|s| s.to_string()).collect();
        SwarmConfig::from_world(&world(), &ov)
    }

    fn field_of(e: RobotError) -> &'static str {
        match e {
            RobotError::Swarm { field, .. } => field,
            other => panic!("not a swarm field error: {other}"),
        }
    }

    #[test]
    fn defaults_are_one_robot_without_consultation() {
        let c = cfg(&[]).unwrap();
        assert_eq!((c.robots, &c.starts, &c.consult), (1, &Starts::Random, &Consult::None));
        assert_eq!((c.bump_penalty, c.loss, c.radio_range_m), (-1.0, 0.0, 1.5));
        assert_eq!(c.hop_delay, SecondsDist::Wifi);
        assert_eq!(c.learners, Learners::Independent);
    }

    #[test]
    fn overrides_set_every_field() {
        let c = cfg(&[
            "robots=2",
            "starts=[[1, 1], [3, 4]]",
            "consult=peers",
            "k=1",
            "radio_range_m=3",
            "hop_delay=const:0.1s",
            "loss=0.25",
            "bump_penalty=-2",
            "learners=shared",
        ])
        .unwrap();
        assert_eq!(c.learners, Learners::Shared);
        let w = world();
        assert_eq!(c.starts, Starts::Cells(vec![w.index(0, 0), w.index(2, 3)]));
        assert_eq!(
            (c.consult.clone(), c.radio_range_m, c.loss, c.bump_penalty),
            (Consult::Peers { k: 1 }, 3.0, 0.25, -2.0)
        );
        assert_eq!(c.hop_delay, SecondsDist::Constant(0.1));
        let s = cfg(&["robots=2", "consult=server", "server=[2, 1]"]).unwrap();
        assert_eq!(s.consult, Consult::Server { cell: w.index(1, 0) });
        assert_eq!(cfg(&["consult=server"]).unwrap().consult, Consult::Server { cell: w.respawn });
    }

    #[test]
    fn the_worlds_table_is_read_and_overrides_win() {
        let text =
            "map = \"\"\"\n...G\n.#..\nS...\n\"\"\"\n[swarm]\nrobots = 3\nconsult = \"peers\"\nk = 2\n";
        let w = World::parse(text, "t").unwrap();
        let c = SwarmConfig::from_world(&w, &[]).unwrap();
        assert_eq!((c.robots, c.consult), (3, Consult::Peers { k: 2 }));
        let c = SwarmConfig::from_world(&w, &["k=1".to_string()]).unwrap();
        assert_eq!(c.consult, Consult::Peers { k: 1 });
    }

    #[test]
    fn bad_settings_name_their_field() {
        let cases: [(&[&str], &str); 13] = [
            (&["learners=pooled"], "learners"),
            (&["robots=0"], "robots"),
            (&["robots=65"], "robots"),
            (&["robots=11"], "robots"), // 10 free cells besides the goal
            (&["robots=2", "starts=[[1, 1], [1, 1]]"], "starts"),
            (&["robots=2", "starts=[[1, 1], [2, 2]]"], "starts"), // blocked
            (&["robots=1", "starts=[[1, 4]]"], "starts"),         // the goal
            (&["robots=2", "starts=[[1, 1]]"], "starts"),
            (&["robots=3", "consult=peers", "k=3"], "k"),
            (&["consult=peers"], "k"),
            (&["radio_range_m=-1"], "radio_range_m"),
            (&["loss=-0.1"], "loss"),
            (&["hop_delay=poisson:3"], "hop_delay"),
        ];
        for (ov, field) in cases {
            let e = cfg(ov).unwrap_err();
            let text = e.to_string();
            assert_eq!(field_of(e), field, "{ov:?}: {text}");
            assert!(text.contains("use "), "{text}");
        }
        assert!(matches!(cfg(&["size=3"]), Err(RobotError::UnknownKey { .. })));
        assert!(matches!(cfg(&["consult=mesh"]).map_err(field_of), Err("consult")));
        assert!(matches!(
            cfg(&["robots=2", "consult=server", "server=[9, 9]"]).map_err(field_of),
            Err("server")
        ));
    }
}
