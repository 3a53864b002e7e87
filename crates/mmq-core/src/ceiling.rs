//! The ε-soft ceiling of a world: the best average reward per step that any policy can
//! earn when, as every ε-greedy learner of mmq does, it takes a uniformly random action
//! (over all of the world's moves, the chosen one included) with probability ε.
//!
//! Undelayed learning cannot beat it, and no learner exploring with ε can either, so it
//! is the honest "100 %" for performance *while learning*; the exact optimum
//! ([`crate::optimum()`]) is the ceiling of the greedy policy.
//!
//! An ε-soft policy π picks its action a = π(s) with probability 1 − ε + ε/|A| and every
//! other action with probability ε/|A|. Its expected one-step reward and successor law are
//!
//! ```text
//! r_π(s)     = (1 − ε)·r(s, π(s))      + (ε/|A|)·Σ_b r(s, b)
//! P_π(s' | s) = (1 − ε)·[s' = n(s, π(s))] + (ε/|A|)·Σ_b [s' = n(s, b)]
//! ```
//!
//! with n(s, a) and r(s, a) the world's deterministic transition. The ceiling is the gain g
//! of the average-reward optimality equation g + h(s) = max_π [r_π(s) + Σ P_π(s'|s) h(s')],
//! solved by relative value iteration with the aperiodicity transform h ← h + τ·(T h − h),
//! τ = ½ (every free cell reaches the goal and the goal leads to S, so the chain is
//! unichain). For any h, min_s (T h − h)(s) ≤ g ≤ max_s (T h − h)(s); the iteration stops
//! when these bounds are within [`TOLERANCE`] and returns their midpoint.

use crate::env::Move;
use crate::world::World;

/// The bounds on the ceiling are this close when the iteration stops, reward per step.
pub const TOLERANCE: f64 = 1e-10;

/// At most this many sweeps (the bounds are then returned as they are).
const MAX_SWEEPS: usize = 1_000_000;

/// The ε-soft ceiling of `world`: bounds and their midpoint, reward per step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ceiling {
    /// The exploration probability it is computed for.
    pub epsilon: f64,
    /// The ceiling (the midpoint of the bounds).
    pub gain: f64,
    /// A lower bound on the ceiling.
    pub lower: f64,
    /// An upper bound on the ceiling.
    pub upper: f64,
}

/// Computes the ε-soft ceiling of `world` for the four moves, `epsilon` in [0, 1].
pub fn epsilon_soft_ceiling(world: &World, epsilon: f64) -> Ceiling {
    let eps = epsilon.clamp(0.0, 1.0);
    let cells: Vec<usize> = world.free_cells().collect();
    let mut pos = vec![usize::MAX; world.num_cells()];
    for (i, &c) in cells.iter().enumerate() {
        pos[c] = i;
    }
    let n_actions = Move::ALL.len();
    // next[i * A + a], reward[i * A + a]
    let mut next = Vec::with_capacity(cells.len() * n_actions);
    let mut reward = Vec::with_capacity(cells.len() * n_actions);
    for &c in &cells {
        for m in Move::ALL {
            let (n, r, _) = world.transition(c, m);
            next.push(pos[n]);
            reward.push(r);
        }
    }
    let share = eps / n_actions as f64;
    let anchor = pos[world.respawn];
    let mut h = vec![0.0f64; cells.len()];
    let mut th = vec![0.0f64; cells.len()];
    let (mut lower, mut upper) = (f64::NEG_INFINITY, f64::INFINITY);
    for _ in 0..MAX_SWEEPS {
        for i in 0..cells.len() {
            let row = i * n_actions..(i + 1) * n_actions;
            let q = |k: usize| reward[k] + h[next[k]];
            let explore: f64 = row.clone().map(q).sum::<f64>() * share;
            let best = row.map(q).fold(f64::NEG_INFINITY, f64::max);
            th[i] = (1.0 - eps) * best + explore;
        }
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..cells.len() {
            let d = th[i] - h[i];
            lo = lo.min(d);
            hi = hi.max(d);
        }
        lower = lower.max(lo);
        upper = upper.min(hi);
        if upper - lower <= TOLERANCE {
            break;
        }
        for i in 0..cells.len() {
            h[i] += 0.5 * (th[i] - h[i]);
        }
        let base = h[anchor];
        for v in &mut h {
            *v -= base;
        }
    }
    Ceiling { epsilon: eps, gain: 0.5 * (lower + upper), lower, upper }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn world(map: &str) -> World {
        let text = format!(
            "name = \"t\"\ncell_size = 0.5\nstart = \"respawn\"\nmap = \"\"\"\n{map}\n\"\"\"\n[rewards]\ngoal = 10.0\nwall = -1.0\nstep = 0.0\n"
        );
        World::parse(&text, "t.toml").expect("test world")
    }

    /// Two cells, `GS`: from S the best policy moves W into G; with probability
    /// p = 1 − ε + ε/4 it gets there, otherwise it bumps (−1) and stays. From G every
    /// action gives +10 and goes back to S. A visit to S lasts 1/p steps with (1 − p)/p
    /// bumps, so g = (10 − (1 − p)/p) / (1/p + 1) = (10·p − (1 − p)) / (1 + p).
    #[test]
    fn two_cells_by_hand() {
        let w = world("GS");
        for eps in [0.0, 0.05, 0.1, 0.5, 1.0] {
            let p: f64 = 1.0 - eps + eps / 4.0;
            let by_hand = (10.0 * p - (1.0 - p)) / (1.0 + p);
            let c = epsilon_soft_ceiling(&w, eps);
            assert!((c.gain - by_hand).abs() < 1e-9, "ε {eps}: {} vs {by_hand}", c.gain);
            assert!(c.lower <= by_hand + 1e-12 && by_hand <= c.upper + 1e-12);
        }
    }

    /// With ε = 0 the ceiling is the exact optimum (a different algorithm).
    #[test]
    fn zero_epsilon_is_the_optimum() {
        for map in ["G....\n.....\n.....\n.....\n....S", "G.#..\n..#..\n.....\n.##..\n....S"] {
            let w = world(map);
            let c = epsilon_soft_ceiling(&w, 0.0);
            let opt = crate::optimum(&w).gain;
            assert!((c.gain - opt).abs() < 1e-9, "{} vs {opt}", c.gain);
        }
    }

    /// The paper's 9×9 world at ε = 0.05: 0.5584 per step, as an independent
    /// implementation measured it (value iteration on the same ε-soft model).
    #[test]
    fn paper_9x9_matches_an_independent_measurement() {
        let text = crate::shipped::world_text("paper-9x9").expect("shipped");
        let w = World::parse(text, "paper-9x9").expect("valid");
        let c = epsilon_soft_ceiling(&w, 0.05);
        assert!((c.gain - 0.5584).abs() < 5e-5, "{}", c.gain);
        assert!(c.upper - c.lower <= TOLERANCE);
    }

    /// The ceiling falls as ε grows and stays below the optimum.
    #[test]
    fn more_exploration_earns_less() {
        let w = world("G....\n.....\n.....\n.....\n....S");
        let opt = crate::optimum(&w).gain;
        let gains: Vec<f64> =
            [0.01, 0.05, 0.1, 0.3].iter().map(|&e| epsilon_soft_ceiling(&w, e).gain).collect();
        assert!(gains[0] < opt);
        assert!(gains.windows(2).all(|p| p[1] < p[0]), "{gains:?}");
    }
}
