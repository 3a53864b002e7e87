//! The exact optimum of a world under the paper's dynamics: the optimal average reward
//! per step (gain) and the optimal actions of every free cell.
//!
//! The dynamics are deterministic, so the optimal gain is the maximum mean reward of a
//! cycle in the state-action graph. That graph has three kinds of simple cycles (a mean
//! over any closed walk is a mix of those of simple cycles): a wall bump in a non-goal
//! cell (a self-loop, mean = wall reward), moves among non-goal cells (mean = step
//! reward; a pair of adjacent non-goal cells gives one), and the goal action followed by
//! a path S → G of L moves (mean = (goal + L·step)/(L + 1)). The last is best at the
//! shortest L when goal ≥ step; when goal < step, a step-reward cycle beats it whenever
//! one exists, and when none does every path S → G has L = 1. So the gain is the largest
//! of those means with L the breadth-first distance S → G: O(V) time instead of Karp's
//! O(V·E), which took minutes on the largest accepted maps (Karp's algorithm is kept in
//! the tests as the reference). The bias h solves h(s) = max_a [r(s,a) − g + h(s')]
//! (longest walks under r − g, no positive cycles by construction), found with a work
//! list. Actions within 1e-7 of the max are optimal. Every free cell reaches the goal
//! (validated).

use std::collections::VecDeque;

use crate::env::{Event, Move};
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
    // Edges (from, to, reward) of the deterministic state-action graph, 4 per state.
    let mut edges = Vec::with_capacity(n * 4);
    for (i, &c) in states.iter().enumerate() {
        for m in Move::ALL {
            let (next, r, _) = world.transition(c, m);
            edges.push((i, pos[next], r));
        }
    }
    let gain = max_mean_cycle(world);
    // Bias: longest walks under r − g from h = 0. A state is looked at again when a
    // successor's h rose; every state once to begin with.
    let mut into: Vec<Vec<usize>> = vec![Vec::new(); n];
    for &(u, v, _) in &edges {
        if into[v].last() != Some(&u) {
            into[v].push(u);
        }
    }
    let mut h = vec![0.0f64; n];
    let mut queued = vec![true; n];
    let mut queue: VecDeque<usize> = (0..n).collect();
    // Bellman–Ford's bound, never reached without positive cycles.
    let mut budget = (n as u128 + 1) * (n as u128).max(1);
    while let Some(u) = queue.pop_front() {
        queued[u] = false;
        budget = budget.saturating_sub(1);
        if budget == 0 {
            break;
        }
        let best = edges[u * 4..u * 4 + 4]
            .iter()
            .map(|&(_, v, r)| r - gain + h[v])
            .fold(f64::NEG_INFINITY, f64::max);
        if best > h[u] + TOL {
            h[u] = best;
            for &p in &into[u] {
                if !queued[p] {
                    queued[p] = true;
                    queue.push_back(p);
                }
            }
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

/// The maximum mean reward of a cycle (see the module docs for why these three kinds of
/// cycle are all there is).
fn max_mean_cycle(world: &World) -> f64 {
    let rw = world.rewards;
    let mut gain = f64::NEG_INFINITY;
    for c in world.free_cells().filter(|&c| c != world.goal) {
        for m in Move::ALL {
            let (next, _, event) = world.transition(c, m);
            if event == Event::WallBump {
                gain = gain.max(rw.wall);
            } else if next != world.goal {
                gain = gain.max(rw.step);
            }
        }
    }
    // Breadth-first distance S → G through non-goal cells.
    let mut dist = vec![u64::MAX; world.num_cells()];
    dist[world.respawn] = 0;
    let mut queue = VecDeque::from([world.respawn]);
    while let Some(c) = queue.pop_front() {
        if c == world.goal {
            let l = dist[c] as f64;
            gain = gain.max((rw.goal + l * rw.step) / (l + 1.0));
            break;
        }
        for m in Move::ALL {
            if let Some(nb) = world.neighbour(c, m).filter(|&nb| world.is_free(nb))
                && dist[nb] == u64::MAX
            {
                dist[nb] = dist[c] + 1;
                queue.push_back(nb);
            }
        }
    }
    gain
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Karp's maximum mean cycle with a virtual source joined to every vertex, in two passes
    /// so that memory stays O(V): pass 1 finds D_n, pass 2 takes the min over k.
    pub(super) fn karp_max_mean_cycle(n: usize, edges: &[(usize, usize, f64)]) -> f64 {
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

#[cfg(test)]
mod reference {
    //! The closed-form gain and the work-list bias against Karp's algorithm and plain
    //! Bellman–Ford sweeps (the implementation they replaced), on random worlds with
    //! random rewards of either sign.
    use rand::RngExt;

    use super::tests::karp_max_mean_cycle;
    use super::*;
    use crate::seed::rng_from_seed;

    fn edges_of(w: &World) -> (usize, Vec<(usize, usize, f64)>) {
        let states: Vec<usize> = w.free_cells().collect();
        let mut pos = vec![usize::MAX; w.num_cells()];
        for (i, &c) in states.iter().enumerate() {
            pos[c] = i;
        }
        let mut edges = Vec::new();
        for (i, &c) in states.iter().enumerate() {
            for m in Move::ALL {
                let (next, r, _) = w.transition(c, m);
                edges.push((i, pos[next], r));
            }
        }
        (states.len(), edges)
    }

    fn sweeps_bias(n: usize, edges: &[(usize, usize, f64)], gain: f64) -> Vec<f64> {
        let mut h = vec![0.0f64; n];
        for _ in 0..=n {
            let mut changed = false;
            for &(u, v, r) in edges {
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
        h
    }

    #[test]
    fn closed_form_matches_karp_and_bias_matches_sweeps() {
        let mut rng = rng_from_seed(2024);
        let mut checked = 0;
        while checked < 400 {
            let (wd, ht) = (rng.random_range(1..7usize), rng.random_range(1..7usize));
            if wd * ht < 2 {
                continue;
            }
            let mut cells: Vec<char> =
                (0..wd * ht).map(|_| if rng.random_bool(0.25) { '#' } else { '.' }).collect();
            let g = rng.random_range(0..wd * ht);
            let mut s = rng.random_range(0..wd * ht);
            while s == g {
                s = rng.random_range(0..wd * ht);
            }
            cells[g] = 'G';
            cells[s] = 'S';
            let map: String = cells.chunks(wd).map(|r| r.iter().collect::<String>() + "\n").collect();
            // Rewards of both signs, small integers and halves so ties happen.
            let mut r = || f64::from(rng.random_range(-6..=24i32)) / 2.0;
            let text = format!(
                "map = \"\"\"\n{map}\"\"\"\n[rewards]\ngoal = {:?}\nwall = {:?}\nstep = {:?}\n",
                r(),
                r(),
                r()
            );
            let Ok(w) = World::parse(&text, "rand") else { continue };
            let (n, edges) = edges_of(&w);
            let want = karp_max_mean_cycle(n, &edges);
            let o = optimum(&w);
            assert!((o.gain - want).abs() < 1e-9, "gain {} vs Karp {want}\n{text}", o.gain);
            let h = sweeps_bias(n, &edges, o.gain);
            for (i, c) in w.free_cells().enumerate() {
                assert!((o.bias[c] - h[i]).abs() < 1e-6, "bias of {c}: {} vs {}\n{text}", o.bias[c], h[i]);
            }
            checked += 1;
        }
    }

    /// The largest accepted maps take well under a second (Karp took minutes).
    #[test]
    fn largest_maps_are_fast() {
        let n = 500;
        let mut map = String::new();
        for r in 0..n {
            for c in 0..n {
                map.push(if (r, c) == (0, 0) {
                    'G'
                } else if (r, c) == (n - 1, n - 1) {
                    'S'
                } else if c % 4 == 2 && r != (c / 4 % 2) * (n - 1) {
                    '#'
                } else {
                    '.'
                });
            }
            map.push('\n');
        }
        let w = World::parse(&format!("map = \"\"\"\n{map}\"\"\""), "big").unwrap();
        let t = std::time::Instant::now();
        let o = optimum(&w);
        assert!(o.gain > 0.0);
        assert!(t.elapsed().as_secs_f64() < 20.0, "{:?}", t.elapsed());
    }
}
