//! The exact optimum of a world under the paper's dynamics: the optimal average reward
//! per step (gain) and the optimal actions of every free cell.
//!
//! The dynamics are deterministic, so the optimal gain is the maximum mean reward of a
//! cycle in the state-action graph (Karp's algorithm, O(V·E) time, O(V) memory), and
//! the bias h solves h(s) = max_a [r(s,a) − g + h(s')] (Bellman–Ford style, no positive
//! cycles by construction). Actions within 1e-9 of the max are optimal. Every free cell
//! reaches the goal (validated), so the gain is the same from every state.

use crate::env::Move;
use crate::world::World;

/// The exact optimum of a world.
#[derive(Clone, Debug, PartialEq)]
pub struct Optimum {
    /// Optimal average reward per step (9×9 paper world: 10/17).
    pub gain: f64,
    /// Bias (relative value) of every cell; 0 for blocked cells.
    pub bias: Vec<f64>,
    /// For every cell, the optimal actions as a bit set over [`Move::ALL`] (0 for blocked).
    pub actions: Vec<u8>,
}

impl Optimum {
    /// Whether `action` is optimal in `cell`.
    pub fn is_optimal(&self, cell: usize, action: usize) -> bool {
        self.actions[cell] & (1 << action) != 0
    }
}

const TOL: f64 = 1e-9;

/// Computes the exact optimum of `world`.
pub fn optimum(world: &World) -> Optimum {
    let states: Vec<usize> = world.free_cells().collect();
    let n_cells = world.num_cells();
    let mut pos = vec![usize::MAX; n_cells];
    for (i, &c) in states.iter().enumerate() {
        pos[c] = i;
    }
    let n = states.len();
    // Edges (from, to, reward) of the deterministic state-action graph.
    let mut edges = Vec::with_capacity(n * 4);
    for (i, &c) in states.iter().enumerate() {
        for m in Move::ALL {
            let (next, r, _) = world.transition(c, m);
            edges.push((i, pos[next], r));
        }
    }
    let gain = karp_max_mean_cycle(n, &edges);
    // Bias: longest paths under r − g (no positive cycles), relaxed until stable.
    let mut h = vec![0.0f64; n];
    for _ in 0..=n {
        let mut changed = false;
        for &(u, v, r) in &edges {
            let cand = r - gain + h[v];
            if cand > h[u] + TOL {
                h[u] = cand;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let mut bias = vec![0.0; n_cells];
    let mut actions = vec![0u8; n_cells];
    for (i, &c) in states.iter().enumerate() {
        bias[c] = h[i];
        let q: Vec<f64> = edges[i * 4..i * 4 + 4].iter().map(|&(_, v, r)| r - gain + h[v]).collect();
        let best = q.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        for (a, &x) in q.iter().enumerate() {
            if x >= best - 1e-7 {
                actions[c] |= 1 << a;
            }
        }
    }
    Optimum { gain, bias, actions }
}

/// Karp's maximum mean cycle with a virtual source joined to every vertex, in two passes
/// so that memory stays O(V): pass 1 finds D_n, pass 2 takes the min over k.
fn karp_max_mean_cycle(n: usize, edges: &[(usize, usize, f64)]) -> f64 {
    let ninf = f64::NEG_INFINITY;
    let walk = |upto: usize, visit: &mut dyn FnMut(usize, &[f64])| {
        let mut d = vec![0.0f64; n];
        visit(0, &d);
        let mut next = vec![ninf; n];
        for k in 1..=upto {
            next.iter_mut().for_each(|x| *x = ninf);
            for &(u, v, r) in edges {
                if d[u] > ninf {
                    let c = d[u] + r;
                    if c > next[v] {
                        next[v] = c;
                    }
                }
            }
            std::mem::swap(&mut d, &mut next);
            visit(k, &d);
        }
    };
    let mut dn = vec![ninf; n];
    walk(n, &mut |k, d| {
        if k == n {
            dn.copy_from_slice(d)
        }
    });
    let mut worst = vec![f64::INFINITY; n];
    walk(n - 1, &mut |k, d| {
        for v in 0..n {
            if dn[v] > ninf && d[v] > ninf {
                let m = (dn[v] - d[v]) / (n - k) as f64;
                if m < worst[v] {
                    worst[v] = m;
                }
            }
        }
    });
    worst.into_iter().filter(|x| x.is_finite()).fold(ninf, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(n: usize) -> World {
        let mut map = String::new();
        for r in 0..n {
            for c in 0..n {
                map.push(if r == 0 && c == 0 {
                    'G'
                } else if r == n - 1 && c == n - 1 {
                    'S'
                } else {
                    '.'
                });
            }
            map.push('\n');
        }
        World::parse(&format!("map = \"\"\"\n{map}\"\"\""), "sq").unwrap()
    }

    #[test]
    fn paper_worlds_gain_is_ten_over_path_length_plus_one() {
        // Cycle: the goal action (1 step) then the shortest path S → G (2(n−1) steps).
        for (n, want) in [(3, 10.0 / 5.0), (5, 10.0 / 9.0), (9, 10.0 / 17.0)] {
            let o = optimum(&square(n));
            assert!((o.gain - want).abs() < 1e-12, "{n}: {} vs {want}", o.gain);
        }
    }

    #[test]
    fn optimal_actions_head_for_the_goal() {
        let w = square(9);
        let o = optimum(&w);
        // From S (bottom-right) up and left are optimal, down and right are not.
        let s = w.respawn;
        assert!(o.is_optimal(s, 0) && o.is_optimal(s, 3));
        assert!(!o.is_optimal(s, 1) && !o.is_optimal(s, 2));
        // Along the top row only "left" is optimal; in G every action is.
        assert_eq!(o.actions[w.index(0, 4)], 1 << 3);
        assert_eq!(o.actions[w.goal], 0b1111);
    }

    #[test]
    fn a_wall_in_the_way_lengthens_the_cycle() {
        // G . # . S in one row: the goal is only reachable around... it is not; use two rows.
        let w = World::parse("map = \"\"\"\nG#S\n...\n\"\"\"", "m").unwrap();
        // S(0,2) → (1,2) → (1,1) → (1,0) → (0,0)=G: 4 moves + the goal action = 5 steps.
        assert!((optimum(&w).gain - 2.0).abs() < 1e-12);
    }

    #[test]
    fn negative_step_reward_is_accounted() {
        let w = World::parse("map = \"G..S\"\n[rewards]\nstep = -0.5", "m").unwrap();
        // Cycle: goal (+10), then 3 moves at −0.5 → (10 − 1.5) / 4.
        assert!((optimum(&w).gain - 8.5 / 4.0).abs() < 1e-12);
    }
}
