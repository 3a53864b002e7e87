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
//! of the average-reward optimality equation g + h(s) = max_π [r_π(s) + Σ P_π(s'|s) h(s')]
//! (every free cell reaches the goal and the goal leads to S, so the ε-soft chain is
//! unichain and g is one number). For any h, min_s (T h − h)(s) ≤ g ≤ max_s (T h − h)(s),
//! with T the right-hand side; the computation stops when these bounds are within
//! [`TOLERANCE`] and returns their midpoint.
//!
//! **How h is found.** Every cycle of the chain passes through the goal, whose every
//! action leads back to S. Cut there, the equation is a stochastic shortest path: for a
//! guess g, V_g(s) = max_π E[Σ (r − g)] until the goal is reached, plus goal − g for the
//! goal's own step, so that V_g(S) = 0 exactly at the ceiling. V_g(S) falls with g at the
//! rate 1 + E[steps S → goal] of the policy greedy for V_g, and Newton's step on g with
//! that slope (Dinkelbach's ratio of the greedy policy's reward to its cycle length)
//! reaches the ceiling in a few rounds. Each round solves V_g by Gauss–Seidel sweeps
//! over the cells in order of their distance to the goal, nearest first, starting from
//! the previous round's V_g shifted by the change of g: a policy heading for the goal
//! finds the new values of the cells it moves into within the same sweep, so a sweep
//! accounts for a whole path and the sweeps needed grow with the number of random
//! (exploring) moves on the way to the goal, about ε × the path's length, not with the
//! square of that length as plain relative value iteration's do (minutes on a 500 × 500
//! open world; well under a second now at ε = 0.01).
//!
//! **Cost.** A sweep costs O(cells) (4 moves each). The work is capped at [`MAX_WORK`]
//! cell updates (a few seconds; reached only with much exploration on the largest
//! maps, e.g. ε ≥ 0.5 on 500 × 500, where the path to the goal is mostly random moves);
//! the bounds are then returned as they stand, wider than [`TOLERANCE`], and
//! [`Ceiling::is_tight`] says so.

use std::collections::VecDeque;

use crate::env::Move;
use crate::world::World;

/// The bounds on the ceiling are this close when the computation stops, reward per step.
pub const TOLERANCE: f64 = 1e-10;

/// At most this many cell updates (sweeps × cells, bound checks included) in the rounds,
/// and as many again in the relative value iteration that follows them when they did not
/// reach the tolerance.
pub const MAX_WORK: u64 = 400_000_000;

/// Sweeps in a row without a smaller change after which the rounds are taken to diverge.
const DIVERGING: u32 = 64;

/// Rounds in a row that move neither bound after which the rounds give way.
const STUCK_ROUNDS: u32 = 8;

/// Sweeps of one round after which the rounds give way (the shipped worlds need a few
/// hundred at most; worlds whose policies seldom reach the goal, millions).
const ROUND_SWEEPS: u32 = 20_000;

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

impl Ceiling {
    /// Whether the bounds are within [`TOLERANCE`] (false only when [`MAX_WORK`] or the
    /// precision of the world's rewards stopped the computation first).
    pub fn is_tight(&self) -> bool {
        self.upper - self.lower <= TOLERANCE
    }
}

/// The world's deterministic moves over its free cells, indexed 0..n.
struct Moves {
    /// next[i * 4 + a]: the successor of cell i under move a.
    next: Vec<usize>,
    /// reward[i * 4 + a].
    reward: Vec<f64>,
    /// The goal's and the respawn's indices.
    goal: usize,
    respawn: usize,
    /// Non-goal cells, nearest to the goal first (breadth-first distance).
    order: Vec<usize>,
}

impl Moves {
    fn of(world: &World) -> Moves {
        let cells: Vec<usize> = world.free_cells().collect();
        let mut pos = vec![usize::MAX; world.num_cells()];
        for (i, &c) in cells.iter().enumerate() {
            pos[c] = i;
        }
        let mut next = Vec::with_capacity(cells.len() * A);
        let mut reward = Vec::with_capacity(cells.len() * A);
        for &c in &cells {
            for m in Move::ALL {
                let (n, r, _) = world.transition(c, m);
                next.push(pos[n]);
                reward.push(r);
            }
        }
        // Moves are reversible on a grid: a breadth-first search from the goal over free
        // neighbours gives every cell's distance to it.
        let mut seen = vec![false; world.num_cells()];
        seen[world.goal] = true;
        let mut queue = VecDeque::from([world.goal]);
        let mut order = Vec::with_capacity(cells.len());
        while let Some(c) = queue.pop_front() {
            if c != world.goal {
                order.push(pos[c]);
            }
            for m in Move::ALL {
                if let Some(nb) = world.neighbour(c, m).filter(|&nb| world.is_free(nb) && !seen[nb]) {
                    seen[nb] = true;
                    queue.push_back(nb);
                }
            }
        }
        // Cells that cannot reach the goal (refused by world validation) go last.
        order.extend((0..cells.len()).filter(|&i| !seen[cells[i]]));
        Moves { next, reward, goal: pos[world.goal], respawn: pos[world.respawn], order }
    }
}

/// Moves per cell.
const A: usize = 4;

/// Computes the ε-soft ceiling of `world` for the four moves, `epsilon` in [0, 1].
pub fn epsilon_soft_ceiling(world: &World, epsilon: f64) -> Ceiling {
    match epsilon_soft_ceiling_until(world, epsilon, &|| false) {
        Some(c) => c,
        None => unreachable!("a computation that is never stopped ends with a ceiling"),
    }
}

/// [`epsilon_soft_ceiling`] that gives up (returns `None`) as soon as `stop()` says so;
/// `stop` is asked once per sweep over the cells (a few milliseconds on a 500 × 500 world).
pub fn epsilon_soft_ceiling_until(world: &World, epsilon: f64, stop: &dyn Fn() -> bool) -> Option<Ceiling> {
    if stop() {
        return None;
    }
    let eps = epsilon.clamp(0.0, 1.0);
    if eps == 0.0 {
        // No exploration: the exact optimum.
        let g = crate::optimum(world).gain;
        return Some(Ceiling { epsilon: eps, gain: g, lower: g, upper: g });
    }
    let mv = Moves::of(world);
    let n = mv.next.len() / A;
    let share = eps / A as f64;
    let greedy = 1.0 - eps;
    let goal_reward = mv.reward[mv.goal * A];
    // The rewards' scale: below this, changes are rounding.
    let scale = mv.reward.iter().fold(1.0f64, |m, r| m.max(r.abs()));
    // V_g (h with h(S) taken as 0) and the greedy policy's expected steps to the goal.
    let mut v = vec![0.0f64; n];
    let mut steps = vec![0.0f64; n];
    // Start from the optimum, an upper bound: V_g is then bounded, and Newton's steps
    // approach from below from the first round on.
    let mut g = crate::optimum(world).gain;
    let (mut lower, mut upper) = (f64::NEG_INFINITY, f64::INFINITY);
    let mut work: u64 = 0;
    let mut gap_before = f64::INFINITY;
    let mut stuck = 0u32;
    while work < MAX_WORK {
        v[mv.goal] = goal_reward - g;
        steps[mv.goal] = 0.0;
        // Gauss–Seidel sweeps until a sweep changes no value by more than rounding does
        // (or by a thousandth of the tolerance).
        let mut last = f64::INFINITY;
        // Sweeps in a row that changed values as much as the one before: a greedy policy
        // that never reaches the goal makes V_g grow without end, and the sweeps never
        // settle; the relative value iteration below takes over then.
        let mut rising = 0u32;
        let mut sweeps = 0u32;
        loop {
            let mut delta = 0.0f64;
            let mut vmax = 0.0f64;
            for &i in &mv.order {
                let row = i * A..(i + 1) * A;
                let (mut best, mut best_k, mut sum, mut tsum) = (f64::NEG_INFINITY, row.start, 0.0, 0.0);
                for k in row {
                    let q = mv.reward[k] - g + v[mv.next[k]];
                    sum += q;
                    tsum += steps[mv.next[k]];
                    if q > best {
                        best = q;
                        best_k = k;
                    }
                }
                let new = greedy * best + share * sum;
                delta = delta.max((new - v[i]).abs());
                vmax = vmax.max(new.abs());
                v[i] = new;
                steps[i] = 1.0 + greedy * steps[mv.next[best_k]] + share * tsum;
            }
            work += n as u64;
            if stop() {
                return None;
            }
            let floor = 64.0 * f64::EPSILON * (vmax + scale);
            let settled = delta <= (1e-3 * TOLERANCE).max(floor);
            // Near rounding, a sweep that changes as much as the one before ends it too.
            let stalled = delta >= last && delta <= 1e3 * floor;
            rising = if delta >= last { rising + 1 } else { 0 };
            sweeps += 1;
            if settled || stalled || work >= MAX_WORK || rising > DIVERGING || sweeps >= ROUND_SWEEPS {
                break;
            }
            last = delta;
        }
        if rising > DIVERGING {
            // Its values grew without end: no start for what follows.
            v.fill(f64::NAN);
            break;
        }
        if sweeps >= ROUND_SWEEPS {
            // A policy that seldom reaches the goal contracts too slowly for the rounds.
            break;
        }
        // The bounds this h gives: T h − h at every cell (at the goal, g + V_g(S)).
        let (lo, hi) = span(&mv, &v, eps);
        work += n as u64;
        lower = lower.max(lo);
        upper = upper.min(hi);
        let gap = upper - lower;
        let step = v[mv.respawn] / (1.0 + steps[mv.respawn]);
        if gap <= TOLERANCE || !step.is_finite() {
            break;
        }
        // No step left and no bound moved: the rewards' precision is reached.
        if step.abs() <= 1e-3 * TOLERANCE && gap >= gap_before {
            break;
        }
        // Rounds that move no bound (a policy that avoids the goal, where Newton's steps
        // cycle): the relative value iteration below takes over.
        stuck = if gap >= gap_before { stuck + 1 } else { 0 };
        if stuck >= STUCK_ROUNDS {
            break;
        }
        gap_before = gap;
        // Newton's step; V_g moves with g at −(1 + steps to the goal) in every cell.
        g += step;
        for (x, t) in v.iter_mut().zip(&steps) {
            *x -= step * (1.0 + t);
        }
    }
    // Rewards that make the goal worth avoiding (a step reward above the goal's) give
    // policies that rarely reach it, where the rounds above can stall: relative value
    // iteration from the h found, within what is left of the work.
    if v.iter().any(|x| !x.is_finite()) {
        v.fill(0.0);
    }
    let mut th = vec![0.0f64; n];
    let mut left = MAX_WORK;
    while upper - lower > TOLERANCE && left >= n as u64 {
        if stop() {
            return None;
        }
        left -= n as u64;
        for (i, t) in th.iter_mut().enumerate() {
            let row = i * A..(i + 1) * A;
            let (mut best, mut sum) = (f64::NEG_INFINITY, 0.0);
            for k in row {
                let q = mv.reward[k] + v[mv.next[k]];
                sum += q;
                best = best.max(q);
            }
            *t = greedy * best + share * sum;
        }
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for (x, t) in v.iter().zip(&th) {
            lo = lo.min(t - x);
            hi = hi.max(t - x);
        }
        lower = lower.max(lo);
        upper = upper.min(hi);
        for (x, t) in v.iter_mut().zip(&th) {
            *x += 0.5 * (t - *x);
        }
        let base = v[mv.respawn];
        v.iter_mut().for_each(|x| *x -= base);
    }
    Some(Ceiling { epsilon: eps, gain: 0.5 * (lower + upper), lower, upper })
}

/// min and max over the cells of (T h − h), the bounds on the gain that `h` gives.
fn span(mv: &Moves, h: &[f64], eps: f64) -> (f64, f64) {
    let share = eps / A as f64;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (i, &hi_) in h.iter().enumerate() {
        let row = i * A..(i + 1) * A;
        let (mut best, mut sum) = (f64::NEG_INFINITY, 0.0);
        for k in row {
            let q = mv.reward[k] + h[mv.next[k]];
            sum += q;
            best = best.max(q);
        }
        let d = (1.0 - eps) * best + share * sum - hi_;
        lo = lo.min(d);
        hi = hi.max(d);
    }
    (lo, hi)
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
    fn a_stopped_computation_gives_up_and_an_unstopped_one_is_the_same() {
        let w = world("G....\n.....\n.....\n.....\n....S");
        assert!(epsilon_soft_ceiling_until(&w, 0.1, &|| true).is_none());
        let asked = std::cell::Cell::new(0u32);
        // Stopped at the third question: somewhere inside the sweeps.
        let third = || {
            asked.set(asked.get() + 1);
            asked.get() >= 3
        };
        assert!(epsilon_soft_ceiling_until(&w, 0.1, &third).is_none());
        assert_eq!(epsilon_soft_ceiling_until(&w, 0.1, &|| false), Some(epsilon_soft_ceiling(&w, 0.1)));
    }

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

#[cfg(test)]
mod reference {
    //! The ceiling against the implementation it replaced (relative value iteration with
    //! the aperiodicity transform, from h = 0, exact but slow on large maps) on random
    //! worlds with random rewards of either sign and random ε; and a large open world,
    //! where that implementation took minutes, computed to the tolerance.
    use rand::RngExt;

    use super::*;
    use crate::seed::rng_from_seed;

    fn relative_value_iteration(world: &World, eps: f64) -> (f64, f64) {
        let mv = Moves::of(world);
        let n = mv.next.len() / A;
        let mut h = vec![0.0f64; n];
        let mut th = vec![0.0f64; n];
        let (mut lower, mut upper) = (f64::NEG_INFINITY, f64::INFINITY);
        // Bounds hold at every iteration; a few slowly mixing worlds would need millions
        // of sweeps to close them, so the reference stops at 50,000.
        for _ in 0..50_000 {
            let (lo, hi) = span(&mv, &h, eps);
            lower = lower.max(lo);
            upper = upper.min(hi);
            if upper - lower <= TOLERANCE {
                break;
            }
            let share = eps / A as f64;
            for (i, t) in th.iter_mut().enumerate() {
                let (mut best, mut sum) = (f64::NEG_INFINITY, 0.0);
                for k in i * A..(i + 1) * A {
                    let q = mv.reward[k] + h[mv.next[k]];
                    best = best.max(q);
                    sum += q;
                }
                *t = (1.0 - eps) * best + share * sum;
            }
            for (x, t) in h.iter_mut().zip(&th) {
                *x += 0.5 * (t - *x);
            }
            let base = h[mv.respawn];
            h.iter_mut().for_each(|x| *x -= base);
        }
        (lower, upper)
    }

    #[test]
    fn matches_relative_value_iteration_on_random_worlds() {
        let mut rng = rng_from_seed(45);
        let (mut checked, mut closed) = (0, 0);
        while checked < 60 {
            let (wd, ht) = (rng.random_range(1..9usize), rng.random_range(1..9usize));
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
            let mut r = || f64::from(rng.random_range(-6..=24i32)) / 2.0;
            let text = format!(
                "map = \"\"\"\n{map}\"\"\"\n[rewards]\ngoal = {:?}\nwall = {:?}\nstep = {:?}\n",
                r(),
                r(),
                r()
            );
            let Ok(w) = World::parse(&text, "rand") else { continue };
            let eps = [0.01, 0.05, 0.2, 0.5, 1.0][checked % 5];
            let (lo, hi) = relative_value_iteration(&w, eps);
            closed += usize::from(hi - lo <= TOLERANCE);
            let c = epsilon_soft_ceiling(&w, eps);
            assert!(c.is_tight(), "ε {eps}: [{}, {}]\n{text}", c.lower, c.upper);
            assert!(
                c.lower <= hi + 1e-12 && lo <= c.upper + 1e-12,
                "ε {eps}: [{}, {}] vs [{lo}, {hi}]\n{text}",
                c.lower,
                c.upper
            );
            checked += 1;
        }
        // The comparison is with the reference's value, not only its loose bounds, on
        // nearly every world.
        assert!(closed >= 50, "the reference closed its bounds on {closed} of {checked} worlds");
    }

    /// A 150 × 150 open world (S and G in opposite corners): relative value iteration
    /// needs about (path length)² sweeps; the Newton rounds a few dozen.
    #[test]
    fn a_large_open_world_is_computed_to_the_tolerance() {
        let n = 150;
        let mut map = String::new();
        for r in 0..n {
            for c in 0..n {
                map.push(match (r, c) {
                    (0, 0) => 'G',
                    _ if (r, c) == (n - 1, n - 1) => 'S',
                    _ => '.',
                });
            }
            map.push('\n');
        }
        let w = World::parse(&format!("map = \"\"\"\n{map}\"\"\""), "open").unwrap();
        let c = epsilon_soft_ceiling(&w, 0.01);
        assert!(c.is_tight(), "[{}, {}]", c.lower, c.upper);
        let opt = crate::optimum(&w).gain;
        // Below the optimum (10 per 2·149 + 1 steps), and near what heading for the goal
        // earns: a random move (probability ε) goes away half the time, so the path of
        // 298 moves takes about 298 / (1 − ε) steps.
        assert!(c.upper < opt, "{} vs {opt}", c.upper);
        assert!(c.lower > 0.98 * 10.0 / (298.0 / 0.99 + 1.0), "{}", c.lower);
    }
}
