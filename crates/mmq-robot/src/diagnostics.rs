//! Per-run diagnostics of how far the robot is from the grid it stands for:
//! `robot/grid_mismatch`, `robot/belief_error`, localisation error, primitive durations
//! and reward per simulated hour (names stable; see `docs/robot.md`), and on request the
//! grid mismatch and belief error of every cell (`robot/cells/...`).

use mmq_core::{Event, Move, World};

/// What the grid would do for the true start cell and the primitive's move (`None`: a
/// turn in place, which the grid would answer with the same cell and the step reward).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Expected {
    /// True cell when the primitive was chosen.
    pub cell: usize,
    /// The grid move of the primitive.
    pub mv: Option<Move>,
    /// Simulated time at the start, seconds.
    pub t0: f64,
}

impl Expected {
    /// The grid's (next cell, reward) for this start and move.
    fn grid_outcome(&self, world: &World) -> (usize, f64) {
        match self.mv {
            Some(m) => {
                let (c, r, _) = world.transition(self.cell, m);
                (c, r)
            }
            None if self.cell == world.goal => {
                let (c, r, _) = world.transition(self.cell, Move::N);
                (c, r)
            }
            None => (self.cell, world.rewards.step),
        }
    }
}

/// Accumulated since the last reset.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Diagnostics {
    /// Decisions (steps) finished.
    pub decisions: u64,
    /// Steps whose true outcome differs from the grid's.
    pub mismatches: u64,
    /// Decisions whose believed cell is not the true cell.
    pub belief_errors: u64,
    /// Sum of the emitted (true) rewards.
    pub reward_sum: f64,
    /// Position error of the estimate at each decision, metres (realistic only).
    pub loc_errors: Vec<f32>,
    /// Duration of each primitive that ran (teleports excluded), seconds.
    pub durations: Vec<f32>,
    /// Per-cell counts, when asked for (`cell_diagnostics`).
    pub cells: Option<CellCounts>,
}

/// Counts per true cell (index row × width + column).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct CellCounts {
    /// Width of the world, cells.
    pub width: usize,
    /// Free cells (the others are never counted).
    pub free: Vec<bool>,
    /// Steps that started in the cell.
    pub started: Vec<u64>,
    /// Of those, steps whose true outcome differs from the grid's.
    pub mismatches: Vec<u64>,
    /// Steps that ended in the cell.
    pub ended: Vec<u64>,
    /// Of those, steps after which the believed cell is another one.
    pub belief_errors: Vec<u64>,
}

/// The p-quantile (nearest rank) of `xs`, 0 when empty.
pub(crate) fn quantile(xs: &[f32], p: f64) -> f64 {
    if xs.is_empty() {
        return 0.0;
    }
    let mut v = xs.to_vec();
    let k = ((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    let (_, x, _) = v.select_nth_unstable_by(k, |a, b| a.total_cmp(b));
    *x as f64
}

fn mean(xs: &[f32]) -> f64 {
    if xs.is_empty() { 0.0 } else { xs.iter().map(|&x| x as f64).sum::<f64>() / xs.len() as f64 }
}

impl Diagnostics {
    /// Empty diagnostics for `world`, with per-cell counts when `per_cell`.
    pub fn new(world: &World, per_cell: bool) -> Self {
        let n = world.num_cells();
        let cells = per_cell.then(|| CellCounts {
            width: world.width,
            free: (0..n).map(|c| world.is_free(c)).collect(),
            started: vec![0; n],
            mismatches: vec![0; n],
            ended: vec![0; n],
            belief_errors: vec![0; n],
        });
        Diagnostics { cells, ..Diagnostics::default() }
    }

    /// Clears everything (keeps the buffers' capacity).
    pub fn clear(&mut self) {
        if let Some(c) = &mut self.cells {
            for v in [&mut c.started, &mut c.mismatches, &mut c.ended, &mut c.belief_errors] {
                v.iter_mut().for_each(|x| *x = 0);
            }
        }
        self.decisions = 0;
        self.mismatches = 0;
        self.belief_errors = 0;
        self.reward_sum = 0.0;
        self.loc_errors.clear();
        self.durations.clear();
    }

    /// Books a finished step: its expectation, its true outcome, the believed cell and
    /// (realistic) the estimate's position error.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &mut self,
        world: &World,
        expected: &Expected,
        true_cell: usize,
        reward: f64,
        event: Event,
        believed_cell: usize,
        loc_error_m: Option<f64>,
        t_end: f64,
    ) {
        self.decisions += 1;
        self.reward_sum += reward;
        let mismatch = expected.grid_outcome(world) != (true_cell, reward);
        let belief_error = believed_cell != true_cell;
        self.mismatches += u64::from(mismatch);
        self.belief_errors += u64::from(belief_error);
        if let Some(c) = &mut self.cells
            && expected.cell < c.started.len()
            && true_cell < c.ended.len()
        {
            c.started[expected.cell] += 1;
            c.mismatches[expected.cell] += u64::from(mismatch);
            c.ended[true_cell] += 1;
            c.belief_errors[true_cell] += u64::from(belief_error);
        }
        if let Some(e) = loc_error_m {
            self.loc_errors.push(e as f32);
        }
        if event != Event::Teleport {
            self.durations.push((t_end - expected.t0) as f32);
        }
    }

    /// The diagnostics as `(name, value)`; localisation error only when `realistic`.
    pub fn stats(&self, sim_time_s: f64, realistic: bool) -> Vec<(String, f64)> {
        let n = self.decisions.max(1) as f64;
        let mut out = vec![
            ("robot/grid_mismatch", self.mismatches as f64 / n),
            ("robot/belief_error", self.belief_errors as f64 / n),
            ("robot/primitive_s_mean", mean(&self.durations)),
            ("robot/primitive_s_p95", quantile(&self.durations, 0.95)),
            (
                "robot/reward_per_hour",
                if sim_time_s > 0.0 { self.reward_sum / (sim_time_s / 3600.0) } else { 0.0 },
            ),
        ];
        if realistic {
            out.push(("robot/loc_error_m_mean", mean(&self.loc_errors)));
            out.push(("robot/loc_error_m_p95", quantile(&self.loc_errors, 0.95)));
        }
        out.into_iter().map(|(k, v)| (k.to_string(), v)).collect()
    }

    /// The per-cell diagnostics (empty unless asked for), for every free cell that a
    /// step started in (grid mismatch) or ended in (belief error), as
    /// `robot/cells/grid_mismatch/r{row}c{col}` and `robot/cells/belief_error/r{row}c{col}`
    /// (fractions; row and column 1-based from the map's top-left corner, as in
    /// collider names).
    pub fn cell_stats(&self) -> Vec<(String, f64)> {
        let Some(c) = &self.cells else { return Vec::new() };
        let name =
            |what: &str, i: usize| format!("robot/cells/{what}/r{}c{}", i / c.width + 1, i % c.width + 1);
        let mut out = Vec::new();
        for (what, num, den) in
            [("grid_mismatch", &c.mismatches, &c.started), ("belief_error", &c.belief_errors, &c.ended)]
        {
            for i in 0..den.len() {
                if c.free[i] && den[i] > 0 {
                    out.push((name(what, i), num[i] as f64 / den[i] as f64));
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_by_hand() {
        let xs: Vec<f32> = (1..=20).map(|i| i as f32).collect();
        assert_eq!(quantile(&xs, 0.95), 19.0);
        assert_eq!(quantile(&xs, 0.5), 10.0);
        assert_eq!(quantile(&xs, 1.0), 20.0);
        assert_eq!(quantile(&[], 0.95), 0.0);
        assert_eq!(mean(&xs), 10.5);
    }

    #[test]
    fn mismatch_and_belief_by_hand() {
        let w = World::parse("cell_size = 0.5\nmap = \"\"\"\nG..\n...\n..S\n\"\"\"", "t").unwrap();
        let mut d = Diagnostics::default();
        // Cell 4 (centre), move N: the grid goes to cell 1 with reward 0.
        let e = Expected { cell: 4, mv: Some(Move::N), t0: 0.0 };
        d.record(&w, &e, 1, 0.0, Event::Moved, 1, Some(0.01), 4.0);
        assert_eq!((d.mismatches, d.belief_errors), (0, 0));
        // The robot ended in cell 5 and believes it is in 1: both count.
        d.record(&w, &e, 5, 0.0, Event::Moved, 1, Some(0.3), 8.0);
        assert_eq!((d.mismatches, d.belief_errors), (1, 1));
        // Cell 1, move N: the wall, −1, stays.
        let e = Expected { cell: 1, mv: Some(Move::N), t0: 8.0 };
        d.record(&w, &e, 1, -1.0, Event::WallBump, 1, Some(0.02), 10.0);
        assert_eq!(d.mismatches, 1);
        // A turn in the goal teleports (+10 to S = 8); a turn elsewhere stays.
        let e = Expected { cell: 0, mv: None, t0: 10.0 };
        d.record(&w, &e, 8, 10.0, Event::Teleport, 8, Some(0.0), 10.0);
        let e = Expected { cell: 3, mv: None, t0: 10.0 };
        d.record(&w, &e, 3, 0.0, Event::Moved, 3, Some(0.0), 12.0);
        assert_eq!((d.mismatches, d.belief_errors, d.decisions), (1, 1, 5));
        let s = d.stats(3600.0, true);
        let get = |k: &str| s.iter().find(|(n, _)| n == k).unwrap().1;
        assert_eq!(get("robot/grid_mismatch"), 0.2);
        assert_eq!(get("robot/reward_per_hour"), 9.0);
        // Durations 4, 8 (started at 0, ended at 8), 2, 2; the teleport has none.
        assert_eq!(get("robot/primitive_s_mean"), 4.0);
        assert_eq!(get("robot/primitive_s_p95"), 8.0);
        assert!((get("robot/loc_error_m_p95") - 0.3).abs() < 1e-6);
        assert!(!d.stats(1.0, false).iter().any(|(k, _)| k.starts_with("robot/loc_error")));
        assert!(d.cell_stats().is_empty());
    }

    #[test]
    fn per_cell_counts_by_hand() {
        let w = World::parse("cell_size = 0.5\nmap = \"\"\"\nG..\n.#.\n..S\n\"\"\"", "t").unwrap();
        let mut d = Diagnostics::new(&w, true);
        // From cell 5 (row 2, column 3) north to cell 2: as the grid, believed right.
        let e = Expected { cell: 5, mv: Some(Move::N), t0: 0.0 };
        d.record(&w, &e, 2, 0.0, Event::Moved, 2, None, 1.0);
        // From cell 5 north again, but the robot ended in cell 8 believing cell 2.
        d.record(&w, &e, 8, 0.0, Event::Moved, 2, None, 2.0);
        // From cell 2 west to cell 1, believed in cell 0.
        let e = Expected { cell: 2, mv: Some(Move::W), t0: 2.0 };
        d.record(&w, &e, 1, 0.0, Event::Moved, 0, None, 3.0);
        let s = d.cell_stats();
        let get = |k: &str| s.iter().find(|(n, _)| n == k).map(|x| x.1);
        assert_eq!(get("robot/cells/grid_mismatch/r2c3"), Some(0.5));
        assert_eq!(get("robot/cells/grid_mismatch/r1c3"), Some(0.0));
        assert_eq!(get("robot/cells/belief_error/r1c3"), Some(0.0));
        assert_eq!(get("robot/cells/belief_error/r3c3"), Some(1.0));
        assert_eq!(get("robot/cells/belief_error/r1c2"), Some(1.0));
        // Cells no step started or ended in have no figure; the blocked centre never.
        assert_eq!(s.len(), 5);
        assert_eq!(get("robot/cells/grid_mismatch/r2c2"), None);
        d.clear();
        assert!(d.cell_stats().is_empty());
        assert_eq!(d.cells.as_ref().map(|c| c.free.len()), Some(9));
    }
}
