//! The sufficient statistics of the deconvolution: the lag co-occurrence counts
//! C_j(x, x') = #{t : x_{t−j} = x, x_t = x'} (sparse, [`super::counts`]) and the lagged
//! reward sums B_k(x) = Σ_t r_t 1[x_{t−k} = x], from which the reward fit's Gram matrix
//! and the pmf fit's least-squares system are built without the history.
//!
//! Several trajectories (the robots of a swarm sharing one learner) can feed one set of
//! statistics: each has its own [`Trail`] (its last pairs, its step count and the start of
//! its current run), so a lag only ever joins two steps of the same trajectory, and C_j
//! and B_k are the sums of each trajectory's counts. The trajectory being fed is the
//! active one ([`LagStats::set_trail`]); with one trajectory nothing changes.

use super::counts::{CoCounts, Merged};
use super::gram::{Edge, Gram};

/// No pair yet.
pub(crate) const UNSEEN: u32 = u32::MAX;

/// One trajectory's part of [`LagStats`]: the compact indices of its last 2(K + 1) steps,
/// its steps, the first step of its current run, and (when the pmf fit is reweighted) the
/// compact pair and delivery of every step of that run.
#[derive(Clone, Debug)]
pub(crate) struct Trail {
    /// Compact indices of the last 2(K + 1) steps, by t mod 2(K + 1).
    recent: Vec<u32>,
    /// Steps of this trajectory.
    pub(crate) t: u64,
    /// First step of the current run (after `reset_history`).
    pub(crate) start: u64,
    /// Compact pair index and delivered reward of every step of the current run (at most
    /// [`super::HISTORY_MAX`], the oldest half dropped when full), when kept.
    pub(crate) hist_x: Vec<u32>,
    pub(crate) hist_r: Vec<f64>,
}

impl Trail {
    fn new(k_n: usize) -> Self {
        Self { recent: vec![UNSEEN; 2 * k_n], t: 0, start: 0, hist_x: Vec::new(), hist_r: Vec::new() }
    }

    /// Compact index of the pair taken at step `u` (one of the last 2(K + 1)).
    #[inline]
    pub(crate) fn past(&self, u: u64) -> usize {
        self.recent[(u % self.recent.len() as u64) as usize] as usize
    }
}

/// C_j, B_k and each trajectory's last pairs, over compact pair indices (in the order
/// pairs were first taken).
#[derive(Clone, Debug)]
pub(crate) struct LagStats {
    /// K + 1.
    k_n: usize,
    /// Compact index of each pair id (UNSEEN until first taken).
    index: Vec<u32>,
    /// Pair id of each compact index.
    pub(crate) pairs: Vec<u32>,
    /// C_j(i, i'), when these statistics keep them (deconvolvers that see the same pairs
    /// share the counts of the first: [`crate::decode`]).
    counts: Option<CoCounts>,
    /// B_k(i) at i·(K + 1) + k.
    b: Vec<f64>,
    /// Each trajectory's last pairs (at least one), and the one being fed.
    trails: Vec<Trail>,
    active: usize,
    /// Σ_t r_t².
    pub(crate) sum_r2: f64,
    /// Steps observed, over every trajectory.
    pub(crate) t: u64,
}

impl LagStats {
    /// Empty statistics over `num_pairs` pair ids and lags 0..=`max_delay`; `counts`:
    /// whether they keep the co-occurrence counts.
    pub(crate) fn new(num_pairs: usize, max_delay: usize, counts: bool) -> Self {
        let k_n = max_delay + 1;
        Self {
            k_n,
            index: vec![UNSEEN; num_pairs],
            pairs: Vec::new(),
            counts: counts.then(CoCounts::default),
            b: Vec::new(),
            trails: vec![Trail::new(k_n)],
            active: 0,
            sum_r2: 0.0,
            t: 0,
        }
    }

    /// The trajectory being fed.
    pub(crate) fn trail(&self) -> &Trail {
        &self.trails[self.active]
    }

    /// Every trajectory's part, in the order they were first fed.
    pub(crate) fn trails(&self) -> &[Trail] {
        &self.trails
    }

    /// The index of the trajectory being fed.
    pub(crate) fn active(&self) -> usize {
        self.active
    }

    /// Feeds trajectory `i` from now on (trajectories are numbered from 0 in the order
    /// they start; those up to `i` not seen yet start empty).
    pub(crate) fn set_trail(&mut self, i: usize) {
        while self.trails.len() <= i {
            self.trails.push(Trail::new(self.k_n));
        }
        self.active = i;
    }

    /// Appends pair `i` and delivery `reward` to the current run's history (the
    /// reweighted pmf fit's), dropping the oldest half when it holds `max` steps.
    pub(crate) fn push_history(&mut self, i: usize, reward: f64, max: usize) {
        let tr = &mut self.trails[self.active];
        if tr.hist_x.len() == max {
            tr.hist_x.drain(..max / 2);
            tr.hist_r.drain(..max / 2);
        }
        tr.hist_x.push(i as u32);
        tr.hist_r.push(reward);
    }

    /// Bytes of the statistics for `pairs` pairs and largest delay `max_delay`, without
    /// the co-occurrence counts (those grow with the run: 24 bytes per distinct
    /// (pair, pair, lag) triple in both orders, at most K + 1 new ones per step, and 28
    /// per pair).
    pub(crate) fn bytes(pairs: usize, max_delay: usize) -> u128 {
        let (p, k) = (pairs as u128, max_delay as u128 + 1);
        k * p * 8 + p * 24 + 16 * k
    }

    /// Bytes held by the co-occurrence counts now.
    pub(crate) fn count_bytes(&self) -> usize {
        self.counts.as_ref().map_or(0, CoCounts::bytes)
    }

    /// Distinct (pair, pair, lag) triples counted so far (merged).
    pub(crate) fn triples(&self) -> usize {
        self.counts.as_ref().map_or(0, CoCounts::len)
    }

    /// The number of pairs taken so far (compact indices 0..n).
    pub(crate) fn n(&self) -> usize {
        self.pairs.len()
    }

    fn compact(&mut self, x: usize) -> usize {
        if self.index[x] != UNSEEN {
            return self.index[x] as usize;
        }
        let i = self.pairs.len();
        self.index[x] = i as u32;
        self.pairs.push(x as u32);
        self.b.resize(self.b.len() + self.k_n, 0.0);
        i
    }

    /// One step: pair `x` taken, `reward` delivered. Returns the compact index of `x`.
    pub(crate) fn record(&mut self, x: usize, reward: f64) -> usize {
        let i = self.compact(x);
        let k_n = self.k_n;
        let tr = &mut self.trails[self.active];
        tr.recent[(tr.t % (2 * k_n) as u64) as usize] = i as u32;
        self.sum_r2 += reward * reward;
        let kmax = (k_n as u64 - 1).min(tr.t - tr.start) as usize;
        if let Some(counts) = self.counts.as_mut() {
            for k in 0..=kmax {
                let e = tr.recent[((tr.t - k as u64) % (2 * k_n) as u64) as usize] as usize;
                counts.add(e, i, k);
            }
        }
        // Adding a zero delivery would change no sum.
        if reward != 0.0 {
            for k in 0..=kmax {
                let e = tr.past(tr.t - k as u64);
                self.b[e * k_n + k] += reward;
            }
        }
        tr.t += 1;
        self.t += 1;
        i
    }

    /// Forgets the fed trajectory's last K steps and its history (a new run starts).
    pub(crate) fn reset_history(&mut self) {
        let tr = &mut self.trails[self.active];
        tr.start = tr.t;
        tr.hist_x.clear();
        tr.hist_r.clear();
    }

    /// Merges the pending co-occurrences (before [`Self::gram`] and
    /// [`Self::lag_products`]).
    pub(crate) fn merge(&mut self) {
        let n = self.n();
        if let Some(c) = self.counts.as_mut() {
            c.merge(n);
        }
    }

    /// Whether [`Self::merge`] has anything to do.
    pub(crate) fn merge_due(&self) -> bool {
        self.counts.as_ref().is_some_and(|c| c.merge_due(self.n()))
    }

    fn merged(&self) -> &std::sync::Arc<Merged> {
        self.counts.as_ref().expect("statistics with co-occurrence counts").merged()
    }

    /// G = Σ_{j≥0} a_j C_j + Σ_{j≥1} a_j C_jᵀ less the edge terms of the last K steps,
    /// a_j = Σ_k p(k) p(k+j); and the a_j. With H = a_0/2 C_0 + Σ_{j≥1} a_j C_j (summed
    /// over j in lag order, entry by entry), G(i, i') = H(i, i') + H(i', i): only pairs
    /// that co-occurred within K steps have an entry. Its rows are read from the merged
    /// counts when first needed ([`Gram`]).
    pub(crate) fn gram(&self, p: &[f64]) -> (Gram, Vec<f64>) {
        let k_n = self.k_n;
        // a_j = Σ_k p(k) p(k+j)
        let a: Vec<f64> = (0..k_n).map(|j| (0..k_n - j).map(|k| p[k] * p[k + j]).sum()).collect();
        let w: Vec<f64> = a.iter().enumerate().map(|(j, &aj)| if j == 0 { aj / 2.0 } else { aj }).collect();
        (Gram::new(self.n(), self.merged().clone(), w, self.edges(p)), a)
    }

    /// Edge terms, in the order they are subtracted: a pair (u − j, u) with u among the
    /// last K steps of a trajectory's current run has fewer than K + 1 windows after it;
    /// C_j counted it with the full weight a_j. (A finished run's last pairs keep their
    /// full windows: their rewards still arrive.)
    pub(crate) fn edges(&self, p: &[f64]) -> Vec<Edge> {
        let k_n = self.k_n;
        let mut out = Vec::new();
        for tr in &self.trails {
            let big_t = tr.t;
            for u in tr.start.max(big_t.saturating_sub(k_n as u64 - 1))..big_t {
                let left = (big_t - 1 - u) as usize; // windows end at t = u..=T−1, k' ≤ left
                for j in 0..=((k_n - 1).min((u - tr.start) as usize)) {
                    let deficit: f64 = (left + 1..k_n - j).map(|k2| p[k2 + j] * p[k2]).sum();
                    if deficit == 0.0 {
                        continue;
                    }
                    let (v, w) = (tr.past(u - j as u64) as u32, tr.past(u) as u32);
                    out.push(Edge { v, w, lagged: j > 0, deficit });
                }
            }
        }
        out
    }

    /// b(i) = Σ_k p(k) B_k(i) for every compact pair i.
    pub(crate) fn bvec(&self, p: &[f64]) -> Vec<f64> {
        let k_n = self.k_n;
        (0..self.n()).map(|i| (0..k_n).map(|k| p[k] * self.b[i * k_n + k]).sum()).collect()
    }

    /// q_j = Rᵀ C_j R over the compact pairs `support` (exactly those with R ≠ 0), j = 0..=K:
    /// for each j, Σ over i in `support` of R(i) Σ_{i'} C_j(i, i') R(i'), in that order.
    pub(crate) fn lag_products(&self, support: &[usize], r: &[f64]) -> Vec<f64> {
        let counts = self.merged();
        let mut q = vec![0.0; self.k_n];
        let mut inner = vec![0.0; self.k_n];
        for &i in support {
            inner.iter_mut().for_each(|x| *x = 0.0);
            // The triples (i, i2, ·) with i2 in the support, in (i2, lag) order either way:
            // looked up pair by pair, or, when that takes more reads, all of i's triples
            // read in order and those outside the support passed over.
            if support.len() * 16 < counts.len_from(i) {
                for &i2 in support {
                    for (j, c) in counts.pair_run(i, i2) {
                        inner[j] += c as f64 * r[i2];
                    }
                }
            } else {
                for (i2, j, c) in counts.triples_from(i) {
                    let y = r[i2];
                    if y != 0.0 {
                        inner[j] += c as f64 * y;
                    }
                }
            }
            for (qj, s) in q.iter_mut().zip(&inner) {
                *qj += r[i] * s;
            }
        }
        q
    }

    /// c_k = Σ_i R_i B_k(i), k = 0..=K, each summed over i in order from −0 (as
    /// `Iterator::sum`), where `support` lists (ascending) the i with R_i ≠ 0.
    ///
    /// Only the support is read, row by row: the terms left out are ±0, which leave a
    /// non-zero partial sum as it is and can change a zero one only in its sign, so a
    /// non-zero c_k is the full sum's, bit for bit; a c_k of zero is summed again in full.
    pub(crate) fn lagged_reward_sums(&self, r: &[f64], support: &[usize]) -> Vec<f64> {
        let k_n = self.k_n;
        let mut c = vec![-0.0; k_n];
        for &i in support {
            for (ck, &bk) in c.iter_mut().zip(&self.b[i * k_n..(i + 1) * k_n]) {
                *ck += r[i] * bk;
            }
        }
        for (k, ck) in c.iter_mut().enumerate() {
            if *ck == 0.0 {
                *ck = (0..self.n()).map(|i| r[i] * self.b[i * k_n + k]).sum();
            }
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mmq_core::seed::rng_from_seed;
    use rand::RngExt;

    /// The dense statistics the sparse ones replace: C_j(i, i') at (j·n + i)·n + i' for
    /// `n` compact pairs, counted step by step, and G built from them entry by entry
    /// exactly as before (H = a_0/2 C_0 + Σ_{j≥1} a_j C_j over every entry, G = H + Hᵀ).
    struct Dense {
        n: usize,
        k_n: usize,
        c: Vec<u32>,
    }

    impl Dense {
        fn gram(&self, st: &LagStats, p: &[f64]) -> Vec<f64> {
            let (n, k_n) = (self.n, self.k_n);
            let a: Vec<f64> = (0..k_n).map(|j| (0..k_n - j).map(|k| p[k] * p[k + j]).sum()).collect();
            let mut g = vec![0.0; n * n];
            for (j, &aj) in a.iter().enumerate() {
                let w = if j == 0 { aj / 2.0 } else { aj };
                if w == 0.0 {
                    continue;
                }
                for i in 0..n {
                    for i2 in 0..n {
                        g[i * n + i2] += w * self.c[(j * n + i) * n + i2] as f64;
                    }
                }
            }
            for i in 0..n {
                for i2 in i..n {
                    let s = g[i * n + i2] + g[i2 * n + i];
                    g[i * n + i2] = s;
                    g[i2 * n + i] = s;
                }
            }
            for e in st.edges(p) {
                let (v, w) = (e.v as usize, e.w as usize);
                g[v * n + w] -= e.deficit;
                if e.lagged {
                    g[w * n + v] -= e.deficit;
                }
            }
            g
        }

        fn lag_products(&self, support: &[usize], r: &[f64]) -> Vec<f64> {
            let n = self.n;
            (0..self.k_n)
                .map(|j| {
                    let mut acc = 0.0;
                    for &i in support {
                        let s: f64 =
                            support.iter().map(|&i2| self.c[(j * n + i) * n + i2] as f64 * r[i2]).sum();
                        acc += r[i] * s;
                    }
                    acc
                })
                .collect()
        }
    }

    /// c = Σ_i R_i B_k(i) from the support alone equals the sum over every pair, bit for
    /// bit, for R̂ with zeros of both signs, a sum that cancels to zero, and R̂ = 0.
    #[test]
    fn lagged_reward_sums_from_the_support_equal_the_full_sums() {
        let (num_pairs, k) = (9, 4);
        let k_n = k + 1;
        let mut rng = rng_from_seed(8);
        let mut st = LagStats::new(num_pairs, k, true);
        for _ in 0..2000 {
            let x = rng.random_range(0..num_pairs);
            let r = if rng.random_bool(0.3) { f64::from(rng.random_range(-2i32..4)) } else { 0.0 };
            st.record(x, r);
        }
        st.merge();
        let n = st.n();
        let full = |r: &[f64]| -> Vec<f64> {
            (0..k_n).map(|kk| (0..n).map(|i| r[i] * st.b[i * k_n + kk]).sum()).collect()
        };
        let mut cases: Vec<Vec<f64>> = vec![vec![0.0; n], vec![-0.0; n]];
        cases.push((0..n).map(|i| if i % 2 == 0 { -0.0 } else { i as f64 * 0.37 - 1.1 }).collect());
        // Two pairs whose terms cancel exactly at a lag where both saw rewards:
        // R_0 = B_k(1), R_1 = −B_k(0), so c_k = B_k(1) B_k(0) − B_k(0) B_k(1) = +0.
        let lag = (0..k_n).find(|&kk| st.b[kk] != 0.0 && st.b[k_n + kk] != 0.0).expect("both saw rewards");
        let mut cancel = vec![0.0; n];
        (cancel[0], cancel[1]) = (st.b[k_n + lag], -st.b[lag]);
        cases.push(cancel);
        for r in &cases {
            let support: Vec<usize> = (0..n).filter(|&i| r[i] != 0.0).collect();
            let got = st.lagged_reward_sums(r, &support);
            let want = full(r);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&want), "R̂ {r:?}");
        }
        assert!(full(&cases[2]).iter().any(|&c| c != 0.0));
        assert_eq!(full(&cases[3])[lag], 0.0);
    }

    /// A random walk over 12 pairs (some frequent, some rare), two runs, K = 5: the
    /// sparse Gram matrix and lag products equal the dense ones bit for bit, at several
    /// points of the run (merges in between) and for several pmfs, including one with a
    /// zero lag; and G equals its definition Σ_t ψ_t ψ_tᵀ, ψ_t(x) = Σ_{k: x_{t−k} = x} p(k)
    /// over the windows of each run that end by now, to rounding.
    #[test]
    fn sparse_statistics_equal_the_dense_reference() {
        let (num_pairs, k) = (12, 5);
        let k_n = k + 1;
        let mut rng = rng_from_seed(21);
        let mut st = LagStats::new(num_pairs, k, true);
        let mut dense = Dense { n: 0, k_n, c: Vec::new() };
        // Dense counts over pair ids (compact order differs): remapped at the end.
        let mut c_ids = vec![0u32; k_n * num_pairs * num_pairs];
        let mut runs: Vec<Vec<usize>> = vec![Vec::new()];
        let pmfs =
            [vec![0.1, 0.2, 0.4, 0.2, 0.1, 0.0], vec![1.0 / 6.0; 6], vec![0.0, 0.5, 0.0, 0.3, 0.2, 0.0]];
        for t in 0..3000 {
            if t == 1700 {
                st.reset_history();
                runs.push(Vec::new());
            }
            let x =
                if rng.random_bool(0.8) { rng.random_range(0..4) } else { rng.random_range(4..num_pairs) };
            let run = runs.last_mut().unwrap();
            run.push(x);
            for j in 0..=k.min(run.len() - 1) {
                c_ids[(j * num_pairs + run[run.len() - 1 - j]) * num_pairs + x] += 1;
            }
            st.record(x, 0.0);
            if [10, 999, 2999].contains(&t) {
                st.merge();
                let n = st.n();
                dense.n = n;
                dense.c = vec![0; k_n * n * n];
                for j in 0..k_n {
                    for i in 0..n {
                        for i2 in 0..n {
                            let (x1, x2) = (st.pairs[i] as usize, st.pairs[i2] as usize);
                            dense.c[(j * n + i) * n + i2] = c_ids[(j * num_pairs + x1) * num_pairs + x2];
                        }
                    }
                }
                for p in &pmfs {
                    let (g, _) = st.gram(p);
                    // Rows are read when first needed: the diagonal needs none.
                    let d: Vec<f64> = (0..n).map(|i| g.diag(i)).collect();
                    assert_eq!(g.rows_read(), 0);
                    g.get(0, n - 1);
                    assert_eq!(g.rows_read(), 1);
                    for (i, di) in d.iter().enumerate() {
                        assert_eq!(di.to_bits(), g.get(i, i).to_bits());
                    }
                    let want = dense.gram(&st, p);
                    for e in 0..n * n {
                        assert_eq!(g.get(e / n, e % n).to_bits(), want[e].to_bits(), "t {t}, entry {e}");
                    }
                    // Σ_t ψ_t ψ_tᵀ over the windows that end by now; a finished run's last
                    // pairs keep all K + 1 windows after them (its rewards still arrive).
                    let mut def = vec![0.0; n * n];
                    for (ri, run) in runs.iter().enumerate() {
                        let end = if ri + 1 == runs.len() { run.len() } else { run.len() + k };
                        for u in 0..end {
                            let mut psi = vec![0.0; n];
                            for (kk, &pk) in p.iter().enumerate().take(u + 1) {
                                if u - kk < run.len() {
                                    psi[st.index[run[u - kk]] as usize] += pk;
                                }
                            }
                            for a in 0..n {
                                for b in 0..n {
                                    def[a * n + b] += psi[a] * psi[b];
                                }
                            }
                        }
                    }
                    // The current run's windows end at T − 1: the edge terms remove exactly
                    // what C counted for later ones.
                    for e in 0..n * n {
                        assert!(
                            (g.get(e / n, e % n) - def[e]).abs() < 1e-9 * (1.0 + def[e].abs()),
                            "t {t}, entry {e}"
                        );
                    }
                }
                let r: Vec<f64> = (0..n).map(|i| if i % 3 == 0 { 0.0 } else { i as f64 - 4.5 }).collect();
                let support: Vec<usize> = (0..n).filter(|&i| r[i] != 0.0).collect();
                let (q, want) = (st.lag_products(&support, &r), dense.lag_products(&support, &r));
                assert_eq!(
                    q.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    want.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
                );
            }
        }
        // Memory: at most K + 1 triples per step, and at most the dense (K + 1) n².
        assert!(st.triples() <= (3000 * k_n).min(k_n * num_pairs * num_pairs));
    }
}
