//! The sufficient statistics of the deconvolution: the lag co-occurrence counts
//! C_j(x, x') = #{t : x_{t−j} = x, x_t = x'} and the lagged reward sums
//! B_k(x) = Σ_t r_t 1[x_{t−k} = x], from which the reward fit's Gram matrix and the pmf
//! fit's least-squares system are built without the history.

use super::linalg::Gram;

/// No pair yet.
pub(crate) const UNSEEN: u32 = u32::MAX;

/// C_j, B_k and the pairs of the last 2(K + 1) steps, over compact pair indices (in the
/// order pairs were first taken).
#[derive(Clone, Debug)]
pub(crate) struct LagStats {
    /// K + 1.
    k_n: usize,
    /// Compact index of each pair id (UNSEEN until first taken).
    index: Vec<u32>,
    /// Pair id of each compact index.
    pub(crate) pairs: Vec<u32>,
    /// Capacity of the compact index (stride of `c`).
    cap: usize,
    /// C_j(i, i') at (j·cap + i)·cap + i', i the earlier pair.
    c: Vec<u32>,
    /// B_k(i) at k·cap + i.
    b: Vec<f64>,
    /// Compact indices of the last 2(K + 1) steps, by t mod 2(K + 1).
    recent: Vec<u32>,
    /// Σ_t r_t².
    pub(crate) sum_r2: f64,
    /// Steps observed.
    pub(crate) t: u64,
    /// First step of the current run (after `reset_history`).
    pub(crate) start: u64,
}

impl LagStats {
    /// Empty statistics over `num_pairs` pair ids and lags 0..=`max_delay`.
    pub(crate) fn new(num_pairs: usize, max_delay: usize) -> Self {
        let k_n = max_delay + 1;
        let cap = 16.min(num_pairs.max(1));
        Self {
            k_n,
            index: vec![UNSEEN; num_pairs],
            pairs: Vec::new(),
            cap,
            c: vec![0; k_n * cap * cap],
            b: vec![0.0; k_n * cap],
            recent: vec![UNSEEN; 2 * k_n],
            sum_r2: 0.0,
            t: 0,
            start: 0,
        }
    }

    /// Bytes of the statistics for `pairs` pairs and largest delay `max_delay`.
    pub(crate) fn bytes(pairs: usize, max_delay: usize) -> u128 {
        let (p, k) = (pairs as u128, max_delay as u128 + 1);
        k * p * p * 4 + k * p * 8 + p * 24
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
        if i == self.cap {
            self.grow();
        }
        self.index[x] = i as u32;
        self.pairs.push(x as u32);
        i
    }

    /// Doubles the compact capacity, keeping every count.
    fn grow(&mut self) {
        let (old, new) = (self.cap, (self.cap * 2).min(self.index.len()).max(self.cap + 1));
        let k_n = self.k_n;
        let mut c = vec![0u32; k_n * new * new];
        let mut b = vec![0.0; k_n * new];
        for j in 0..k_n {
            for i in 0..old {
                let src = (j * old + i) * old;
                let dst = (j * new + i) * new;
                c[dst..dst + old].copy_from_slice(&self.c[src..src + old]);
            }
            b[j * new..j * new + old].copy_from_slice(&self.b[j * old..(j + 1) * old]);
        }
        self.c = c;
        self.b = b;
        self.cap = new;
    }

    /// One step: pair `x` taken, `reward` delivered. Returns the compact index of `x`.
    pub(crate) fn record(&mut self, x: usize, reward: f64) -> usize {
        let i = self.compact(x);
        let k_n = self.k_n;
        let cap = self.cap;
        self.recent[(self.t % (2 * k_n) as u64) as usize] = i as u32;
        self.sum_r2 += reward * reward;
        let kmax = (k_n as u64 - 1).min(self.t - self.start) as usize;
        for k in 0..=kmax {
            let e = self.past(self.t - k as u64);
            self.c[(k * cap + e) * cap + i] += 1;
            self.b[k * cap + e] += reward;
        }
        self.t += 1;
        i
    }

    /// Compact index of the pair taken at step `u` (one of the last 2(K + 1)).
    #[inline]
    pub(crate) fn past(&self, u: u64) -> usize {
        self.recent[(u % self.recent.len() as u64) as usize] as usize
    }

    /// Forgets the last K steps (a new run starts).
    pub(crate) fn reset_history(&mut self) {
        self.start = self.t;
    }

    /// G = Σ_{j≥0} a_j C_j + Σ_{j≥1} a_j C_jᵀ less the edge terms of the last K steps,
    /// a_j = Σ_k p(k) p(k+j); and the a_j.
    pub(crate) fn gram(&self, p: &[f64]) -> (Gram, Vec<f64>) {
        let n = self.n();
        let cap = self.cap;
        let k_n = self.k_n;
        // a_j = Σ_k p(k) p(k+j)
        let a: Vec<f64> = (0..k_n).map(|j| (0..k_n - j).map(|k| p[k] * p[k + j]).sum()).collect();
        // H = a_0/2 C_0 + Σ_{j≥1} a_j C_j, then G = H + Hᵀ.
        let mut g = vec![0.0; n * n];
        for (j, &aj) in a.iter().enumerate() {
            let w = if j == 0 { aj / 2.0 } else { aj };
            if w == 0.0 {
                continue;
            }
            for i in 0..n {
                let src = &self.c[(j * cap + i) * cap..(j * cap + i) * cap + n];
                let row = &mut g[i * n..(i + 1) * n];
                for (gv, &cv) in row.iter_mut().zip(src) {
                    *gv += w * cv as f64;
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
        let mut g = Gram::from_dense(n, g);
        self.subtract_edges(&mut g, p);
        (g, a)
    }

    /// Edge terms: a pair (u − j, u) with u among the last K steps has fewer than K + 1
    /// windows after it; C_j counted it with the full weight a_j.
    fn subtract_edges(&self, g: &mut Gram, p: &[f64]) {
        let k_n = self.k_n;
        let big_t = self.t;
        for u in self.start.max(big_t.saturating_sub(k_n as u64 - 1))..big_t {
            let left = (big_t - 1 - u) as usize; // windows end at t = u..=T−1, k' ≤ left
            for j in 0..=((k_n - 1).min((u - self.start) as usize)) {
                let deficit: f64 = (left + 1..k_n - j).map(|k2| p[k2 + j] * p[k2]).sum();
                if deficit == 0.0 {
                    continue;
                }
                let (v, w) = (self.past(u - j as u64), self.past(u));
                g.sub(v, w, deficit);
                if j > 0 {
                    g.sub(w, v, deficit);
                }
            }
        }
    }

    /// b(i) = Σ_k p(k) B_k(i) for every compact pair i.
    pub(crate) fn bvec(&self, p: &[f64]) -> Vec<f64> {
        let cap = self.cap;
        (0..self.n()).map(|i| (0..self.k_n).map(|k| p[k] * self.b[k * cap + i]).sum()).collect()
    }

    /// q_j = Rᵀ C_j R over the compact pairs `support` (those with R ≠ 0), j = 0..=K.
    pub(crate) fn lag_products(&self, support: &[usize], r: &[f64]) -> Vec<f64> {
        let (n, cap) = (self.n(), self.cap);
        let mut q = vec![0.0; self.k_n];
        for (j, qj) in q.iter_mut().enumerate() {
            let mut acc = 0.0;
            for &i in support {
                let row = &self.c[(j * cap + i) * cap..(j * cap + i) * cap + n];
                let s: f64 = support.iter().map(|&i2| row[i2] as f64 * r[i2]).sum();
                acc += r[i] * s;
            }
            *qj = acc;
        }
        q
    }

    /// c_k = Σ_i R_i B_k(i), k = 0..=K.
    pub(crate) fn lagged_reward_sums(&self, r: &[f64]) -> Vec<f64> {
        let (n, cap) = (self.n(), self.cap);
        (0..self.k_n).map(|k| (0..n).map(|i| r[i] * self.b[k * cap + i]).sum()).collect()
    }
}
