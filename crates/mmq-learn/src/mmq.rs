//! Multiple-Model Q-learning (MMQ), Algorithm 1 of the paper, eqs. (5)–(7): one Q-table
//! per delay estimate λ̂ = 0..=λ̂max, all updated every step, acting on the best.
//!
//! ```text
//! (λ̂*, a*) = argmax_{λ̂, a} Q(s, a, λ̂)                                  eqs. (5)–(6)
//! for λ̂ = 0, 1, ..., λ̂max with t − λ̂ ≥ 0:
//!   Q(s_{t−λ̂}, a_{t−λ̂}, λ̂) ← (1 − α) Q(s_{t−λ̂}, a_{t−λ̂}, λ̂)
//!                            + α [ r_t + γ max_{λ̂', a} Q(s'_{t−λ̂}, a, λ̂') ]   eq. (7)
//! ```
//!
//! Speed-up, exact (every table entry and every decision bit-identical to the plain
//! transcription in [`crate::mmq_reference`], random tie-breaking draws included; see
//! docs/performance.md for the measurements):
//!
//! - The target's max over all models and actions of s' is the same for every model, so
//!   it is cached per state: the max, how many entries attain it, and which one when it
//!   is unique (`Top`).
//! - The same is kept per column (s, a): the max over the N models of Q(s, a, ·). The
//!   table is stored column by column, `[s][a][λ̂]`, so a column is one contiguous run.
//!   An update changes one entry; unless that entry was or becomes its column's
//!   maximiser (about one update in twenty on the paper's grid) one compare is all the
//!   bookkeeping. Otherwise the column's cache follows the change, and is rebuilt by a
//!   scan of its N entries only when its last maximiser decreases; the state's cache is
//!   then combined from its |A| column caches.
//! - Acting reads the state's cache: no scan unless the maximum is tied, and then the
//!   same draw and the same choice as [`crate::policy::argmax_random_tie`] over the
//!   block in the reference's `[λ̂][a]` order ([`pick_tie_in`]).
//! - The last N steps are kept twice in a ring of 2N, so the N updates of one step walk
//!   one slice without a modulo per model, each step with its column's offset already
//!   computed. (1 − α) is computed once; eq. (7) is otherwise evaluated with exactly the
//!   reference's operations in the reference's order.
//!
//! Tables are exported ([`Learner::tables`], [`MultipleModelQ::raw`]) in the
//! reference's `[s][λ̂][a]` order.

use mmq_core::{Action, Rng, State};
use serde::{Deserialize, Serialize};

use crate::diagnostics::Diagnostics;
use crate::diagnostics::Figure;
use crate::learner::{Decision, Experience, Learner, Table};
use crate::memory::Memory;
use crate::params::Params;
use crate::policy::{epsilon_greedy, pick_tie_in};

/// Settings of `mmq` and `mmq-reference`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MmqSettings {
    /// λ̂max of Algorithm 1, steps: N = λ̂max + 1 models (paper: 50).
    pub max_delay: usize,
}

impl Default for MmqSettings {
    fn default() -> Self {
        Self { max_delay: 50 }
    }
}

/// The cached maximum of a set of table entries (a state's block or one column).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Top {
    /// The maximum.
    max: f64,
    /// How many entries equal `max` (≥ 1).
    count: u32,
    /// Which entry is the maximiser when `count` is 1: λ̂ × |A| + a in a block (the
    /// reference's order), λ̂ in a column.
    first: u32,
}

impl Top {
    /// Follows a change of entry `j` from `old` to `new`. Returns false when the cache
    /// cannot tell the result (the last maximiser decreased, or the one left is
    /// unknown) and must be rebuilt.
    #[inline(always)]
    fn follow(&mut self, j: usize, old: f64, new: f64) -> bool {
        if new > self.max {
            *self = Top { max: new, count: 1, first: j as u32 };
        } else if old == self.max {
            if new != old {
                self.count -= 1;
                return self.count > 1;
            }
        } else if new == self.max {
            self.count += 1;
        }
        true
    }
}

/// One past step (s, a, s') as the updates need it.
#[derive(Clone, Copy, Debug, Default)]
struct Past {
    /// Offset of column (s, a) in the table: (s × |A| + a) × N.
    at: usize,
    /// Column index s × |A| + a.
    c: u32,
    /// s.
    s: u32,
    /// Where max Q(s', ·, ·) is mirrored: S × |A| + s'.
    m2: u32,
}

/// Multiple-Model Q-learning with exact cached maxima.
#[derive(Clone, Debug)]
pub struct MultipleModelQ {
    p: Params,
    /// N = λ̂max + 1 models.
    n: usize,
    num_actions: usize,
    /// Q[(s × |A| + a) × N + λ̂]: column by column.
    q: Vec<f64>,
    /// Cache of column (s, a), max_λ̂ Q(s, a, λ̂), at [s × |A| + a].
    cols: Vec<Top>,
    /// Cache of the block of s, max_{λ̂, a} Q(s, a, λ̂), combined from its columns.
    top: Vec<Top>,
    /// `cols[c].max` at `[c]` and `top[s].max` at `[S × |A| + s]` again, densely, for the
    /// update loop.
    maxes: Vec<f64>,
    /// The last N steps at t mod N and again at t mod N + N.
    history: Vec<Past>,
    /// The step expected next and its position t mod N + N in `history`.
    next: (u64, usize),
    /// How often each model was λ̂* of a greedy decision.
    chosen: Vec<u64>,
}

/// max(x, y) by `>` (one `maxsd`).
#[inline(always)]
fn gt_max(x: f64, y: f64) -> f64 {
    if x > y { x } else { y }
}

/// Rebuilds the cache of one column by scanning its N entries, without branches on the
/// values (where the maximum sits is unpredictable): the max over eight lanes
/// (`maxpd`), then one exact sum over the maximisers of 2^26 + their index, which holds
/// both their number and, when there is one, where it is. Entries past the last full
/// eight are read as the column's last eight (lanes already seen add nothing).
#[cold]
#[inline(never)]
fn scan_column(col: &[f64]) -> Top {
    const TAG: f64 = (1u64 << 26) as f64;
    let n = col.len();
    let Some(last) = n.checked_sub(8).and_then(|k| <&[f64; 8]>::try_from(&col[k..]).ok()) else {
        return scan_plain(col);
    };
    if n > 8192 {
        // Sums of indices could reach 2^26.
        return scan_plain(col);
    }
    let (chunks, _) = col.as_chunks::<8>();
    let mut acc = *last;
    for c in chunks {
        for k in 0..8 {
            acc[k] = gt_max(acc[k], c[k]);
        }
    }
    let acc =
        [gt_max(acc[0], acc[4]), gt_max(acc[1], acc[5]), gt_max(acc[2], acc[6]), gt_max(acc[3], acc[7])];
    let max = gt_max(gt_max(acc[0], acc[2]), gt_max(acc[1], acc[3]));
    // Integers below 2^53: every sum is exact, in any order.
    let mut sum = [0.0f64; 8];
    let mut tag = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0].map(|l| TAG + l);
    for c in chunks {
        for k in 0..8 {
            sum[k] += if c[k] == max { tag[k] } else { 0.0 };
            tag[k] += 8.0;
        }
    }
    // The last eight start at n − 8; their lanes below 8 × chunks (seen) count 0.
    let seen = (8 * chunks.len()) as f64;
    for k in 0..8 {
        let l = (n - 8 + k) as f64;
        let tag = if l >= seen { TAG + l } else { 0.0 };
        sum[k] += if last[k] == max { tag } else { 0.0 };
    }
    let sum = sum.iter().sum::<f64>() as u64;
    let count = (sum >> 26) as u32;
    Top { max, count, first: if count == 1 { (sum & ((1 << 26) - 1)) as u32 } else { 0 } }
}

/// [`scan_column`] for columns shorter than eight or longer than 8192 entries.
fn scan_plain(col: &[f64]) -> Top {
    col.iter().enumerate().fold(Top { max: f64::NEG_INFINITY, count: 0, first: 0 }, |t, (l, &x)| {
        if x > t.max {
            Top { max: x, count: 1, first: l as u32 }
        } else if x == t.max {
            Top { count: t.count + 1, ..t }
        } else {
            t
        }
    })
}

/// The cache of a block from the caches of its |A| columns.
#[inline]
fn combine(cols: &[Top]) -> Top {
    if let Ok(cols) = <&[Top; 4]>::try_from(cols) {
        // The paper's four moves, without branches.
        let max = gt_max(gt_max(cols[0].max, cols[1].max), gt_max(cols[2].max, cols[3].max));
        let mut top = Top { max, count: 0, first: 0 };
        for (a, c) in cols.iter().enumerate() {
            let at_max = u32::from(c.max == max);
            top.count += at_max * c.count;
            top.first += at_max * (c.first * 4 + a as u32);
        }
        return top;
    }
    let a_n = cols.len() as u32;
    let max = cols.iter().fold(f64::NEG_INFINITY, |m, c| gt_max(c.max, m));
    let mut top = Top { max, count: 0, first: 0 };
    for (a, c) in cols.iter().enumerate() {
        if c.max == max {
            top.count += c.count;
            top.first = c.first * a_n + a as u32;
        }
    }
    top
}

/// The caches after entry λ̂ = `l` of the column of `h` (whose values are `col`) went
/// from `old` to `new`, and was or became the column's maximiser.
#[inline(never)]
fn follow(
    h: &Past,
    l: usize,
    old: f64,
    new: f64,
    col: &[f64],
    cols: &mut [Top],
    top: &mut [Top],
    a_n: usize,
) {
    let (c, s) = (h.c as usize, h.s as usize);
    if !cols[c].follow(l, old, new) {
        cols[c] = scan_column(col);
    }
    top[s] = combine(&cols[s * a_n..(s + 1) * a_n]);
}

impl MultipleModelQ {
    /// N = `max_delay` + 1 models over `num_states` × `num_actions`, every entry q0.
    pub fn new(p: Params, max_delay: usize, num_states: usize, num_actions: usize) -> Self {
        let n = max_delay + 1;
        assert!(
            u32::try_from(num_states * (num_actions + 1)).is_ok() && u32::try_from(n * num_actions).is_ok(),
            "MMQ tables of {num_states} states × {num_actions} actions × {n} models are too large"
        );
        let all = |count: usize| Top { max: p.q0, count: count as u32, first: 0 };
        Self {
            p,
            n,
            num_actions,
            q: vec![p.q0; num_states * num_actions * n],
            cols: vec![all(n); num_states * num_actions],
            top: vec![all(n * num_actions); num_states],
            maxes: vec![p.q0; num_states * num_actions + num_states],
            history: vec![Past::default(); 2 * n],
            next: (0, n),
            chosen: vec![0; n],
        }
    }

    /// Q(s, a, λ̂).
    pub fn q(&self, s: State, a: Action, model: usize) -> f64 {
        self.q[(s * self.num_actions + a) * self.n + model]
    }

    /// Q(s, ·, λ̂) into `out`.
    fn row(&self, s: State, model: usize, out: &mut [f64]) {
        for (a, x) in out.iter_mut().enumerate() {
            *x = self.q(s, a, model);
        }
    }

    /// The block of s in the reference's order: Q(s, a, λ̂) at λ̂ × |A| + a.
    fn block_values(&self, s: State) -> impl Iterator<Item = f64> + '_ {
        let (n, w) = (self.n, self.n * self.num_actions);
        let block = &self.q[s * w..(s + 1) * w];
        // Model λ̂ of every action: entries λ̂, λ̂ + N, λ̂ + 2N, ... of the block.
        (0..n).flat_map(move |l| block[l..].iter().step_by(n).copied())
    }

    /// The whole table in the reference's order, `[s][λ̂][a]` (a copy).
    pub fn raw(&self) -> Vec<f64> {
        let states = self.top.len();
        (0..states).flat_map(|s| self.block_values(s)).collect()
    }

    /// Number of models N.
    pub fn num_models(&self) -> usize {
        self.n
    }

    /// How often each model was the acting model λ̂* of a greedy decision.
    pub fn chosen_counts(&self) -> &[u64] {
        &self.chosen
    }

    /// The model whose greedy value max_a Q(s, a, λ̂) is highest in s (lowest λ̂ on ties).
    pub fn best_model(&self, s: State) -> usize {
        let mut row = vec![0.0; self.num_actions];
        let mut best = (f64::NEG_INFINITY, 0);
        for l in 0..self.n {
            self.row(s, l, &mut row);
            let v = crate::learner::max_of(&row);
            if v > best.0 {
                best = (v, l);
            }
        }
        best.1
    }

    /// The greedy choice in s as a block index λ̂ × |A| + a: the cached maximiser, or
    /// the tie-break of [`crate::policy::argmax_random_tie`] (same draw, same choice)
    /// when it is tied.
    #[inline]
    fn greedy_index(&self, s: State, rng: &mut Rng) -> usize {
        let top = self.top[s];
        if top.count == 1 {
            top.first as usize
        } else {
            pick_tie_in(self.block_values(s), top.max, top.count as usize, rng)
        }
    }

    /// Records step t in the history; returns its position `now` (history[now − λ̂] is
    /// step t − λ̂) and the number of updates, min(t, N − 1) + 1.
    #[inline]
    fn remember(&mut self, e: &Experience<'_>) -> (usize, usize) {
        assert!(
            e.action < self.num_actions && e.state < self.top.len() && e.next_state < self.top.len(),
            "step outside the tables: {e:?}"
        );
        let n = self.n;
        let t = e.t as usize;
        // Steps come one after the other: no division but on a jump.
        let now = if e.t == self.next.0 { self.next.1 } else { t % n + n };
        self.next = (e.t.wrapping_add(1), if now + 1 == 2 * n { n } else { now + 1 });
        let c = e.state * self.num_actions + e.action;
        let m2 = self.cols.len() + e.next_state;
        let past = Past { at: c * n, c: c as u32, s: e.state as u32, m2: m2 as u32 };
        self.history[now - n] = past;
        self.history[now] = past;
        (now, t.min(n - 1) + 1)
    }
}

impl Learner for MultipleModelQ {
    fn name(&self) -> &'static str {
        "mmq"
    }

    fn act(&mut self, s: State, rng: &mut Rng) -> Decision {
        let a_n = self.num_actions;
        let mut model = 0;
        let (action, explored) = epsilon_greedy(self.p.epsilon, a_n, rng, |r| {
            let i = self.greedy_index(s, r);
            let (l, a) = if a_n == 4 { (i >> 2, i & 3) } else { (i / a_n, i % a_n) };
            model = l;
            a
        });
        if !explored {
            self.chosen[model] += 1;
        }
        Decision { action, model: (!explored).then_some(model), explored }
    }

    /// Algorithm 1's updates of one step, eq. (7), for λ̂ = 0..=min(t, N − 1) in
    /// increasing λ̂.
    fn observe(&mut self, e: &Experience<'_>) {
        let (now, len) = self.remember(e);
        let (alpha, gamma, r) = (self.p.alpha, self.p.gamma, e.reward);
        let one_minus_alpha = 1.0 - alpha;
        let Self { n, num_actions, q, cols, top, maxes, history, .. } = self;
        for (l, h) in history[now + 1 - len..=now].iter().rev().enumerate() {
            let m = maxes[h.m2 as usize];
            let i = h.at + l;
            let old = q[i];
            // eq. (7)
            let new = one_minus_alpha * old + alpha * (r + gamma * m);
            q[i] = new;
            // Nothing else changes unless the entry was or becomes its column's maximiser.
            if gt_max(new, old) >= maxes[h.c as usize] {
                follow(h, l, old, new, &q[h.at..h.at + *n], cols, top, *num_actions);
                maxes[h.c as usize] = cols[h.c as usize].max;
                maxes[cols.len() + h.s as usize] = top[h.s as usize].max;
            }
        }
    }

    fn greedy(&self, s: State, rng: &mut Rng) -> Action {
        self.greedy_index(s, rng) % self.num_actions
    }

    fn action_values(&self, s: State, out: &mut [f64]) {
        self.row(s, self.best_model(s), out);
    }

    fn tables(&self) -> Vec<Table> {
        vec![Table {
            name: "q".into(),
            shape: vec![self.top.len(), self.n, self.num_actions],
            data: self.raw(),
        }]
    }

    fn diagnostics(&self) -> Diagnostics {
        let total: u64 = self.chosen.iter().sum();
        let mode = self
            .chosen
            .iter()
            .enumerate()
            .max_by_key(|&(i, &c)| (c, std::cmp::Reverse(i)))
            .map_or(0, |x| x.0);
        let mean = if total > 0 {
            self.chosen.iter().enumerate().map(|(i, &c)| i as f64 * c as f64).sum::<f64>() / total as f64
        } else {
            f64::NAN
        };
        let figures = vec![(Figure::ModelStarMode, mode as f64), (Figure::ModelStarMean, mean)];
        Diagnostics { figures, ..Diagnostics::default() }
    }

    fn reset_history(&mut self) {
        self.history.iter_mut().for_each(|h| *h = Past::default());
        self.next = (0, self.n);
    }

    fn shares_tables(&self) -> bool {
        true
    }

    fn swap_memory(&mut self, other: &mut Memory) {
        let n = self.n;
        let mut mine = (std::mem::take(&mut self.history), self.next);
        other.swap_with(&mut mine, || (vec![Past::default(); 2 * n], (0, n)));
        (self.history, self.next) = mine;
    }
}

impl MultipleModelQ {
    /// Checks the caches against full scans (tests).
    #[cfg(test)]
    fn check_caches(&self) {
        let a_n = self.num_actions;
        let scan = |xs: &[f64]| {
            let max = crate::learner::max_of(xs);
            (max, xs.iter().filter(|&&x| x == max).count() as u32, xs.iter().position(|&x| x == max).unwrap())
        };
        for s in 0..self.top.len() {
            let block: Vec<f64> = self.block_values(s).collect();
            let (max, count, first) = scan(&block);
            let t = self.top[s];
            assert_eq!((t.max, t.count), (max, count), "state {s}");
            assert_eq!(self.maxes[self.cols.len() + s], max, "state {s}");
            if count == 1 {
                assert_eq!(t.first as usize, first, "state {s}");
            }
            for a in 0..a_n {
                let col: Vec<f64> = block.iter().skip(a).step_by(a_n).copied().collect();
                let (max, count, first) = scan(&col);
                let c = self.cols[s * a_n + a];
                assert_eq!((c.max, c.count), (max, count), "state {s}, action {a}");
                assert_eq!(self.maxes[s * a_n + a], max, "state {s}, action {a}");
                if count == 1 {
                    assert_eq!(c.first as usize, first, "state {s}, action {a}");
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learner::exp;
    use crate::mmq_reference::MmqReference;
    use mmq_core::seed::rng_from_seed;
    use rand::RngExt;

    /// Algorithm 1 by hand: λ̂max = 1 (two models), 2 states, 1 action, α = 0.5,
    /// γ = 0.5, q0 = 0.
    #[test]
    fn eq7_by_hand() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        for fast in [true, false] {
            let mut l: Box<dyn Learner> = if fast {
                Box::new(MultipleModelQ::new(p, 1, 2, 1))
            } else {
                Box::new(MmqReference::new(p, 1, 2, 1))
            };
            let q = |l: &dyn Learner| l.tables()[0].data.clone();
            // t = 0: (s=0, a=0, s'=1), r = 4. Only λ̂ = 0 (t − 1 < 0):
            // Q(0,0,0) ← 0.5·0 + 0.5 (4 + 0.5·max Q(1,·,·)=0) = 2
            l.observe(&exp(0, 0, 0, 1, 4.0));
            assert_eq!(q(&*l), vec![2.0, 0.0, 0.0, 0.0]);
            // t = 1: (s=1, a=0, s'=0), r = 2.
            // λ̂ = 0: Q(1,0,0) ← 0 + 0.5 (2 + 0.5·max Q(0,·,·)=2) = 1.5
            // λ̂ = 1: pair of t = 0 (s=0, s'=1): Q(0,0,1) ← 0 + 0.5 (2 + 0.5·max Q(1,·,·)=1.5) = 1.375
            l.observe(&exp(1, 1, 0, 0, 2.0));
            assert_eq!(q(&*l), vec![2.0, 1.375, 1.5, 0.0]);
            // t = 2: (s=0, a=0, s'=1), r = 0.
            // λ̂ = 0: Q(0,0,0) ← 0.5·2 + 0.5 (0 + 0.5·1.5) = 1.375
            // λ̂ = 1: pair of t = 1 (s=1, s'=0), max Q(0,·,·) is now 1.375 (both models):
            //         Q(1,0,1) ← 0 + 0.5 (0 + 0.5·1.375) = 0.34375
            l.observe(&exp(2, 0, 0, 1, 0.0));
            assert_eq!(q(&*l), vec![1.375, 1.375, 1.5, 0.34375]);
        }
    }

    /// One random trace through both learners: decisions (ε-greedy and greedy, with the
    /// RNG streams compared afterwards), acting values and tables must agree bit for bit.
    fn compare(p: Params, max_delay: usize, states: usize, actions: usize, steps: u64, seed: u64) {
        let mut fast = MultipleModelQ::new(p, max_delay, states, actions);
        let mut slow = MmqReference::new(p, max_delay, states, actions);
        let mut env_rng = rng_from_seed(seed);
        let (mut r1, mut r2) = (rng_from_seed(seed + 100), rng_from_seed(seed + 100));
        let (mut v1, mut v2) = (vec![0.0; actions], vec![0.0; actions]);
        let mut s = 0usize;
        let ctx = format!("{p:?}, λ̂max {max_delay}, {states} states, {actions} actions, seed {seed}");
        for t in 0..steps {
            if t == steps / 2 {
                // A new run on the same tables.
                fast.reset_history();
                slow.reset_history();
            }
            // The second run's clock jumps once (steps need not be consecutive).
            let t = match t {
                t if t >= steps * 3 / 4 => t - steps / 2 + 7,
                t if t >= steps / 2 => t - steps / 2,
                t => t,
            };
            let d1 = fast.act(s, &mut r1);
            let d2 = slow.act(s, &mut r2);
            assert_eq!(d1, d2, "decision at t = {t}, {ctx}");
            let g = env_rng.random_range(0..states);
            assert_eq!(fast.greedy(g, &mut r1), slow.greedy(g, &mut r2), "greedy at t = {t}, {ctx}");
            fast.action_values(g, &mut v1);
            slow.action_values(g, &mut v2);
            assert_eq!(v1, v2, "action values at t = {t}, {ctx}");
            // Few next states and few reward values make ties and repeated states common.
            let s2 = if env_rng.random_range(0..4) == 0 { s } else { env_rng.random_range(0..states) };
            let r = match env_rng.random_range(0..10) {
                0 => 10.0,
                1 | 2 => -1.0,
                3 => 9.0,
                _ => 0.0,
            };
            fast.observe(&exp(t, s, d1.action, s2, r));
            slow.observe(&exp(t, s, d1.action, s2, r));
            if t % 997 == 0 {
                fast.check_caches();
            }
            s = s2;
        }
        fast.check_caches();
        let (a, b) = (fast.raw(), slow.raw());
        assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()), "tables differ, {ctx}");
        assert_eq!(r1.random::<u64>(), r2.random::<u64>(), "RNG streams diverged, {ctx}");
    }

    /// The fast learner equals the plain transcription bit for bit, tables and
    /// decisions, on long random traces: optimistic, zero and negative initialisation,
    /// ε = 0, the default and 1, α = 0 (everything stays tied) and α = 1, γ = 0, one
    /// model, one action, one state.
    #[test]
    fn fast_equals_reference_bit_for_bit() {
        let p = |alpha, gamma, epsilon, q0| Params { alpha, gamma, epsilon, q0 };
        let cases = [
            (p(0.1, 0.9, 0.1, 10.0), 50, 9, 4, 1u64),
            (p(0.1, 0.9, 0.1, 0.0), 7, 5, 4, 2),
            (p(0.1, 0.9, 0.1, 20.0), 13, 81, 4, 3),
            (p(0.1, 0.9, 0.0, 20.0), 50, 81, 4, 4),
            (p(0.1, 0.9, 0.0, 0.0), 50, 81, 4, 5),
            (p(0.1, 0.9, 1.0, 20.0), 50, 81, 4, 6),
            (p(0.1, 0.9, 0.01, -5.0), 20, 12, 4, 7),
            (p(0.0, 0.9, 0.05, 1.0), 5, 6, 4, 8),
            (p(1.0, 0.0, 0.05, 0.0), 5, 6, 4, 9),
            (p(0.5, 0.5, 0.0, 0.0), 0, 7, 4, 10),
            (p(0.3, 0.9, 0.2, 2.0), 9, 4, 1, 11),
            (p(0.3, 0.9, 0.2, 2.0), 3, 1, 3, 12),
            (p(0.1, 0.99, 0.02, 0.0), 60, 30, 5, 13),
        ];
        for (p, max_delay, states, actions, seed) in cases {
            compare(p, max_delay, states, actions, 20_000, seed);
        }
    }

    /// The column rescan against a plain scan: lengths around the eight lanes and past
    /// the limit of its index sums, one maximiser anywhere, ties, all equal.
    #[test]
    fn column_scan_counts_and_finds() {
        let plain = |col: &[f64]| {
            let max = crate::learner::max_of(col);
            let count = col.iter().filter(|&&x| x == max).count() as u32;
            let first = if count == 1 { col.iter().position(|&x| x == max).unwrap() as u32 } else { 0 };
            Top { max, count, first }
        };
        let mut rng = rng_from_seed(5);
        for n in (1..40).chain([51, 64, 100, 8192, 8193, 10_000]) {
            for _ in 0..20 {
                let levels = rng.random_range(1..6);
                let col: Vec<f64> = (0..n).map(|_| rng.random_range(0..levels) as f64 - 2.0).collect();
                let got = scan_column(&col);
                let want = plain(&col);
                assert_eq!((got.max, got.count), (want.max, want.count), "n = {n}");
                if want.count == 1 {
                    assert_eq!(got.first, want.first, "n = {n}");
                }
            }
            let mut col = vec![0.5; n];
            let j = rng.random_range(0..n);
            col[j] = 1.5;
            assert_eq!(scan_column(&col), Top { max: 1.5, count: 1, first: j as u32 }, "n = {n}");
        }
    }

    #[test]
    fn acts_on_the_joint_argmax() {
        let p = Params { alpha: 0.5, gamma: 0.0, epsilon: 0.0, q0: 0.0 };
        let mut l = MultipleModelQ::new(p, 2, 1, 4);
        // Actions 3, 1, 2, 1, 0, 2 with rewards 0, 0, 8, −8, −8, −8 (γ = 0, α = 0.5):
        // t = 2 sets Q(0,2,0) = Q(0,1,1) = Q(0,3,2) = 4; the −8s at t = 3, 4, 5 pull
        // Q(0,1,1) (λ̂=1 at t=4) and Q(0,2,0) (λ̂=0 at t=5) down to −2, leaving
        // Q(0, a=3, λ̂=2) = 4 the single largest entry.
        for (t, (a, r)) in
            [(3, 0.0), (1, 0.0), (2, 8.0), (1, -8.0), (0, -8.0), (2, -8.0)].into_iter().enumerate()
        {
            l.observe(&exp(t as u64, 0, a, 0, r));
        }
        assert_eq!((l.q(0, 1, 1), l.q(0, 2, 0)), (-2.0, -2.0));
        let mut rng = rng_from_seed(0);
        assert_eq!(l.q(0, 3, 2), 4.0);
        let d = l.act(0, &mut rng);
        assert_eq!((d.action, d.model, d.explored), (3, Some(2), false));
        assert_eq!(l.best_model(0), 2);
    }
}
