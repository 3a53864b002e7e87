//! Worlds: a W×H map of free and blocked cells with a goal `G` and a respawn cell `S`,
//! parsed from a TOML file and validated, plus the paper's tabular dynamics on it.
//!
//! File format (every field documented in `docs/worlds.md`):
//!
//! ```toml
//! name = "paper-3x3"
//! cell_size = 0.5        # metres
//! step_period_s = 0.1    # seconds of simulated time per grid step
//! start = "random"       # "random" (paper) or "respawn"
//! map = """
//! G..
//! ...
//! ..S
//! """
//! [rewards]
//! goal = 10.0
//! wall = -1.0
//! step = 0.0
//! ```
//!
//! Map row 0 is the top row. Cell index = row × width + column.

use std::collections::VecDeque;
use std::fmt;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::env::{Event, Move};

/// The grid's nominal duration of one decision step when the world file does not set
/// `step_period_s`, seconds. An assumption (the grid logs' time base): a real robot's
/// cell-to-cell move takes longer, and the robot environment keeps its own clock.
pub const DEFAULT_STEP_PERIOD_S: f64 = 0.1;

/// Largest accepted map side, in cells.
pub const MAX_SIDE: usize = 1000;
/// Largest accepted number of cells.
pub const MAX_CELLS: usize = 250_000;
/// Largest accepted world file, bytes (the largest map is a few hundred KiB).
pub const MAX_FILE_BYTES: u64 = 16 << 20;

/// What a map cell is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Cell {
    /// Free floor.
    Free,
    /// A blocked cell (a wall block).
    Blocked,
}

/// Reward values of a world. In a world file they are a table with named fields
/// (`[rewards]`, `goal = 10.0`); a bare list such as `rewards = [1, 2]` is refused, since
/// which number is which would be a guess.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Rewards {
    /// Reward for any action taken in the goal cell (paper: +10).
    #[serde(default = "default_goal")]
    pub goal: f64,
    /// Reward for moving into a boundary wall or a blocked cell (paper: −1).
    #[serde(default = "default_wall")]
    pub wall: f64,
    /// Reward for every other move (paper: 0).
    #[serde(default)]
    pub step: f64,
}

/// The `[rewards]` table as written: named fields only.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RewardsTable {
    #[serde(default = "default_goal")]
    goal: f64,
    #[serde(default = "default_wall")]
    wall: f64,
    #[serde(default)]
    step: f64,
}

impl<'de> Deserialize<'de> for Rewards {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Named;
        impl<'de> serde::de::Visitor<'de> for Named {
            type Value = Rewards;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a table of named rewards, e.g. [rewards] goal = 10.0, wall = -1.0, step = 0.0")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Rewards, A::Error> {
                let t = RewardsTable::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                Ok(Rewards { goal: t.goal, wall: t.wall, step: t.step })
            }
        }
        d.deserialize_map(Named)
    }
}

fn default_goal() -> f64 {
    10.0
}
fn default_wall() -> f64 {
    -1.0
}

impl Default for Rewards {
    fn default() -> Self {
        Self { goal: 10.0, wall: -1.0, step: 0.0 }
    }
}

/// How the initial state of a run is chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum StartRule {
    /// Uniformly random free non-goal cell (the paper).
    Random,
    /// The respawn cell `S`.
    Respawn,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct WorldFile {
    name: Option<String>,
    description: Option<String>,
    #[serde(default = "default_cell_size")]
    cell_size: f64,
    #[serde(default = "default_step_period")]
    step_period_s: f64,
    #[serde(default = "default_start")]
    start: StartRule,
    map: String,
    #[serde(default)]
    rewards: Rewards,
    robot: Option<toml::Table>,
    swarm: Option<toml::Table>,
}

fn default_cell_size() -> f64 {
    0.5
}
fn default_step_period() -> f64 {
    DEFAULT_STEP_PERIOD_S
}
fn default_start() -> StartRule {
    StartRule::Random
}

/// Why a world file was rejected. Displays as one line naming the file, the field and
/// the fix.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldError {
    /// The file (or `<string>` when parsed from memory).
    pub file: String,
    /// What is wrong, with the field and what would be accepted.
    pub message: String,
}

impl fmt::Display for WorldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.file, self.message)
    }
}

impl std::error::Error for WorldError {}

/// A validated world.
#[derive(Clone, Debug, PartialEq)]
pub struct World {
    /// Short name (defaults to the file stem).
    pub name: String,
    /// Free text.
    pub description: String,
    /// Width in cells.
    pub width: usize,
    /// Height in cells.
    pub height: usize,
    /// Row-major cells, row 0 at the top.
    pub cells: Vec<Cell>,
    /// Goal cell index.
    pub goal: usize,
    /// Respawn cell index.
    pub respawn: usize,
    /// Reward values.
    pub rewards: Rewards,
    /// Side of a cell in metres (robot arena scale).
    pub cell_size: f64,
    /// Simulated seconds one grid step takes (the grid's clock, which delays in seconds
    /// count; the robot keeps its own physical time).
    pub step_period_s: f64,
    /// Initial-state rule.
    pub start: StartRule,
    /// The raw `[robot]` table, validated by the robot environment.
    pub robot: Option<toml::Table>,
    /// The raw `[swarm]` table, validated by the swarm environment.
    pub swarm: Option<toml::Table>,
    /// The file the world came from, if any.
    pub path: Option<PathBuf>,
    /// The file's text (kept so logs can attach it).
    pub source: String,
}

impl World {
    /// Reads and validates a world file. A bare name (`paper-9x9`), or a path that does
    /// not exist whose stem is a shipped world's name, gives the shipped world
    /// ([`crate::shipped`]).
    pub fn load(path: impl AsRef<Path>) -> Result<World, WorldError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
        let shipped = || {
            let by_name = path.extension().is_none() && path.components().count() == 1;
            (by_name || !path.exists())
                .then(|| stem.as_deref().and_then(crate::shipped::world_text))
                .flatten()
        };
        if let Some(text) = shipped() {
            let mut w = Self::parse_named(text, &file, stem.as_deref())?;
            w.path = None;
            return Ok(w);
        }
        // At most MAX_FILE_BYTES, and only a regular file: `--world /dev/zero`, a FIFO or a
        // huge file must neither hang nor take all memory.
        let text = crate::files::read_text_bounded(path, MAX_FILE_BYTES).map_err(|e| {
            let message = match e {
                crate::files::ReadError::Io(e) if e.kind() == std::io::ErrorKind::NotFound => format!(
                    "no such world file, and no shipped world of that name; give a path to a world file or one of: {}",
                    crate::shipped::world_names()
                ),
                crate::files::ReadError::TooLarge { .. } => format!(
                    "the world file is larger than {} MiB; a world file is a small text file (see docs/worlds.md)",
                    MAX_FILE_BYTES >> 20
                ),
                e => format!("cannot read the world file: {e}"),
            };
            WorldError { file: file.clone(), message }
        })?;
        let mut w = Self::parse_named(&text, &file, stem.as_deref())?;
        w.path = Some(path.to_path_buf());
        Ok(w)
    }

    /// Parses and validates world text; `file` names it in errors.
    pub fn parse(text: &str, file: &str) -> Result<World, WorldError> {
        Self::parse_named(text, file, None)
    }

    fn parse_named(text: &str, file: &str, stem: Option<&str>) -> Result<World, WorldError> {
        let err = |message: String| WorldError { file: file.to_string(), message };
        let raw: WorldFile = toml::from_str(text).map_err(|e| {
            let msg = e.message().trim().to_string();
            let at = e
                .span()
                .map(|s| {
                    let (line, col) = line_col(text, s.start);
                    format!("line {line}, column {col}: ")
                })
                .unwrap_or_default();
            err(format!("{at}{msg}"))
        })?;
        for (field, text) in [("name", raw.name.as_deref()), ("description", raw.description.as_deref())] {
            if text.is_some_and(|t| t.chars().any(|c| c.is_control() && c != '\n' && c != '\t')) {
                return Err(err(format!(
                    "field `{field}` holds a control character; use printable text (names reach terminals and reports)"
                )));
            }
        }
        if !(raw.cell_size.is_finite() && raw.cell_size > 0.0 && raw.cell_size <= 100.0) {
            return Err(err(format!(
                "field `cell_size` = {} is not a size in metres; use a number in (0, 100], e.g. 0.5",
                crate::stats::compact(raw.cell_size)
            )));
        }
        if !(raw.step_period_s.is_finite() && raw.step_period_s > 0.0 && raw.step_period_s <= 3600.0) {
            return Err(err(format!(
                "field `step_period_s` = {} is not a step duration in seconds; use a number in (0, 3600], e.g. 0.1",
                raw.step_period_s
            )));
        }
        for (field, v) in [
            ("rewards.goal", raw.rewards.goal),
            ("rewards.wall", raw.rewards.wall),
            ("rewards.step", raw.rewards.step),
        ] {
            if !v.is_finite() || v.abs() > 1e9 {
                return Err(err(format!(
                    "field `{field}` = {} must be a finite number of magnitude at most 1e9",
                    crate::stats::compact(v)
                )));
            }
        }
        let rows: Vec<&str> = raw.map.lines().map(|l| l.trim()).filter(|l| !l.is_empty()).collect();
        if rows.is_empty() {
            return Err(err("field `map` is empty; draw the map with `.` free, `#` blocked, one `G` goal and one `S` respawn".into()));
        }
        let width = rows[0].chars().count();
        let height = rows.len();
        if width > MAX_SIDE || height > MAX_SIDE || width * height > MAX_CELLS {
            return Err(err(format!(
                "field `map` is {width}×{height} cells; at most {MAX_SIDE} per side and {MAX_CELLS} cells are accepted"
            )));
        }
        let mut cells = Vec::with_capacity(width * height);
        let (mut goal, mut respawn) = (Vec::new(), Vec::new());
        for (r, row) in rows.iter().enumerate() {
            let n = row.chars().count();
            if n != width {
                return Err(err(format!(
                    "field `map`: row {} has {n} cells but row 1 has {width}; every row must have the same width",
                    r + 1
                )));
            }
            for (c, ch) in row.chars().enumerate() {
                let idx = r * width + c;
                cells.push(match ch {
                    '.' => Cell::Free,
                    '#' => Cell::Blocked,
                    'G' => {
                        goal.push(idx);
                        Cell::Free
                    }
                    'S' => {
                        respawn.push(idx);
                        Cell::Free
                    }
                    other => {
                        return Err(err(format!(
                            "field `map`: row {}, column {}: unknown cell {other:?}; use `.` free, `#` blocked, `G` goal, `S` respawn",
                            r + 1,
                            c + 1
                        )));
                    }
                });
            }
        }
        let goal = match goal.as_slice() {
            [g] => *g,
            [] => return Err(err("field `map` has no goal `G`; mark exactly one goal cell".into())),
            _ => return Err(err(format!("field `map` has {} goals `G`; mark exactly one", goal.len()))),
        };
        let respawn = match respawn.as_slice() {
            [s] => *s,
            [] => return Err(err("field `map` has no respawn cell `S`; mark exactly one".into())),
            _ => {
                return Err(err(format!(
                    "field `map` has {} respawn cells `S`; mark exactly one",
                    respawn.len()
                )));
            }
        };
        let world = World {
            name: raw
                .name
                .or(stem.map(|s| s.chars().map(|c| if c.is_control() { '?' } else { c }).collect()))
                .unwrap_or_else(|| "world".into()),
            description: raw.description.unwrap_or_default(),
            width,
            height,
            cells,
            goal,
            respawn,
            rewards: raw.rewards,
            cell_size: raw.cell_size,
            step_period_s: raw.step_period_s,
            start: raw.start,
            robot: raw.robot,
            swarm: raw.swarm,
            path: None,
            source: text.to_string(),
        };
        if let Some(cell) = world.first_cell_not_reaching_goal() {
            let (r, c) = world.row_col(cell);
            return Err(err(format!(
                "field `map`: the goal `G` cannot be reached from row {}, column {}; open a path or block that cell with `#`",
                r + 1,
                c + 1
            )));
        }
        Ok(world)
    }

    /// Number of cells (W × H); states of the grid environment are cell indices.
    pub fn num_cells(&self) -> usize {
        self.width * self.height
    }

    /// (row, column) of a cell index, row 0 at the top.
    pub fn row_col(&self, cell: usize) -> (usize, usize) {
        (cell / self.width, cell % self.width)
    }

    /// Cell index of (row, column).
    pub fn index(&self, row: usize, col: usize) -> usize {
        row * self.width + col
    }

    /// Whether a cell index is free.
    pub fn is_free(&self, cell: usize) -> bool {
        self.cells.get(cell) == Some(&Cell::Free)
    }

    /// Free cells in index order.
    pub fn free_cells(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.num_cells()).filter(|&c| self.is_free(c))
    }

    /// Centre of a cell in the world frame (x right, y up, metres, origin at the
    /// arena's bottom-left corner).
    pub fn cell_center(&self, cell: usize) -> (f64, f64) {
        let (r, c) = self.row_col(cell);
        let x = (c as f64 + 0.5) * self.cell_size;
        let y = ((self.height - 1 - r) as f64 + 0.5) * self.cell_size;
        (x, y)
    }

    /// The cell holding world point (x, y), or `None` outside the arena.
    pub fn cell_at(&self, x: f64, y: f64) -> Option<usize> {
        if !(x >= 0.0 && y >= 0.0) {
            return None;
        }
        let c = (x / self.cell_size).floor() as usize;
        let row_from_bottom = (y / self.cell_size).floor() as usize;
        if c >= self.width || row_from_bottom >= self.height {
            return None;
        }
        Some(self.index(self.height - 1 - row_from_bottom, c))
    }

    /// The neighbour of `cell` in direction `m`, or `None` past the boundary.
    pub fn neighbour(&self, cell: usize, m: Move) -> Option<usize> {
        let (r, c) = self.row_col(cell);
        let (dr, dc) = m.delta();
        let (nr, nc) = (r as isize + dr, c as isize + dc);
        if nr < 0 || nc < 0 || nr as usize >= self.height || nc as usize >= self.width {
            None
        } else {
            Some(self.index(nr as usize, nc as usize))
        }
    }

    /// The paper's tabular dynamics: the next cell, the emitted reward and the event of
    /// taking move `m` in `cell`.
    ///
    /// Any action in `G` yields the goal reward and moves to `S`; moving into the
    /// boundary or a blocked cell yields the wall reward and stays; anything else moves
    /// and yields the step reward.
    pub fn transition(&self, cell: usize, m: Move) -> (usize, f64, Event) {
        if cell == self.goal {
            return (self.respawn, self.rewards.goal, Event::Teleport);
        }
        match self.neighbour(cell, m) {
            Some(n) if self.is_free(n) => (n, self.rewards.step, Event::Moved),
            _ => (cell, self.rewards.wall, Event::WallBump),
        }
    }

    /// A free cell that cannot reach the goal, if any (breadth-first search backwards).
    fn first_cell_not_reaching_goal(&self) -> Option<usize> {
        let mut reach = vec![false; self.num_cells()];
        reach[self.goal] = true;
        let mut queue = VecDeque::from([self.goal]);
        while let Some(c) = queue.pop_front() {
            for m in Move::ALL {
                if let Some(n) = self.neighbour(c, m) {
                    // n can step into c (moves are reversible on a grid).
                    if self.is_free(n) && !reach[n] {
                        reach[n] = true;
                        queue.push_back(n);
                    }
                }
            }
        }
        self.free_cells().find(|&c| !reach[c])
    }

    /// The map as ASCII, as in the world file.
    pub fn ascii(&self) -> String {
        let mut s = String::new();
        for r in 0..self.height {
            for c in 0..self.width {
                let i = self.index(r, c);
                s.push(if i == self.goal {
                    'G'
                } else if i == self.respawn {
                    'S'
                } else if self.is_free(i) {
                    '.'
                } else {
                    '#'
                });
            }
            s.push('\n');
        }
        s
    }
}

fn line_col(text: &str, byte: usize) -> (usize, usize) {
    let before = &text[..byte.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, col)
}

#[cfg(test)]
mod tests {
    use super::*;

    const W3: &str = "map = \"\"\"\nG..\n...\n..S\n\"\"\"\n";

    #[test]
    fn parses_the_paper_3x3() {
        let w = World::parse(W3, "t.toml").unwrap();
        assert_eq!((w.width, w.height, w.goal, w.respawn), (3, 3, 0, 8));
        assert_eq!(w.rewards, Rewards::default());
        assert_eq!(w.start, StartRule::Random);
        assert_eq!(w.ascii(), "G..\n...\n..S\n");
    }

    #[test]
    fn dynamics_match_the_paper() {
        let w = World::parse(W3, "t.toml").unwrap();
        assert_eq!(w.transition(0, Move::S), (8, 10.0, Event::Teleport));
        assert_eq!(w.transition(8, Move::S), (8, -1.0, Event::WallBump));
        assert_eq!(w.transition(8, Move::N), (5, 0.0, Event::Moved));
        assert_eq!(w.transition(8, Move::W), (7, 0.0, Event::Moved));
        assert_eq!(w.transition(3, Move::W), (3, -1.0, Event::WallBump));
    }

    #[test]
    fn frame_is_bottom_left_origin() {
        let w = World::parse(W3, "t.toml").unwrap();
        assert_eq!(w.cell_center(6), (0.25, 0.25));
        assert_eq!(w.cell_center(2), (1.25, 1.25));
        assert_eq!(w.cell_at(0.1, 1.4), Some(0));
        assert_eq!(w.cell_at(1.4, 0.1), Some(8));
        assert_eq!(w.cell_at(-0.1, 0.1), None);
    }

    fn bad(text: &str) -> String {
        World::parse(text, "bad.toml").unwrap_err().to_string()
    }

    #[test]
    fn rejects_bad_worlds_with_clear_messages() {
        assert!(bad("map = ").contains("bad.toml: line 1"));
        assert!(bad("mapp = \"G.S\"").contains("mapp"));
        assert!(bad("map = \"...S\"").contains("no goal"));
        assert!(bad("map = \"G..\"").contains("no respawn"));
        assert!(bad("map = \"\"").contains("empty"));
        assert!(bad("map = \"G#S\"").contains("cannot be reached"));
        assert!(bad("map = \"\"\"\nG.\n.S.\n\"\"\"").contains("row 2"));
        assert!(bad("map = \"GxS\"").contains("unknown cell 'x'"));
        assert!(bad("map = \"GGS\"").contains("2 goals"));
        assert!(bad("cell_size = -1\nmap = \"G.S\"").contains("cell_size"));
        assert!(bad("step_period_s = 0\nmap = \"G.S\"").contains("field `step_period_s` = 0"));
        assert!(bad("step_period_s = inf\nmap = \"G.S\"").contains("(0, 3600]"));
        assert!(bad("start = \"corner\"\nmap = \"G.S\"").contains("line 1"));
    }
}

#[cfg(test)]
mod shipped {
    use super::*;
    use crate::optimum::optimum;

    /// Every world file in `worlds/` parses and validates.
    #[test]
    fn all_shipped_worlds_load() {
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../worlds");
        let mut n = 0;
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                let w = World::load(&p).unwrap_or_else(|e| panic!("{e}"));
                assert!(optimum(&w).gain > 0.0, "{}", p.display());
                n += 1;
            }
        }
        assert!(n >= 5);
        let w = World::load(format!("{dir}/paper-9x9.toml")).unwrap();
        assert!((optimum(&w).gain - 10.0 / 17.0).abs() < 1e-12);
    }
}
