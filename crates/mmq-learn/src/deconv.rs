//! Reward deconvolution with an online estimate of the delay distribution: the part of
//! `deconv-q` and `deconv-model` that turns delivered rewards back into a reward table.
//!
//! Transitions are seen at once; only rewards are late. With x_t = (s_t, a_t), R(x) the
//! expected reward of a pair and p(k) = P(d = k) the delay pmf (k = 0..=K, K the
//! largest delay the learner is told of), the reward delivered at t has expectation
//!
//! ```text
//! E[r_t | x_0..x_t] = Σ_{k=0..K} p(k) · R(x_{t−k})                               (D1)
//! ```
//!
//! Both unknowns are fitted to everything seen so far by penalised least squares,
//!
//! ```text
//! min_{R, p ∈ simplex}  ½ Σ_t ( r_t − Σ_k p(k) R(x_{t−k}) )²
//!                       + Σ_x λ₁ G(x, x) |R(x)| + ½ μ Σ_k p(k)² Σ_x R(x)²          (D2)
//! ```
//!
//! (λ₁ = `lasso` in reward units: an isolated pair's estimate is biased towards zero by
//! λ₁ and evidence weaker than that gives exactly zero; μ = `reward_prior`, in visits),
//! by alternating exact minimisations at refit times:
//!
//! * **R given p** is a lasso with Gram matrix G = Σ_t ψ_t ψ_tᵀ, ψ_t(x) = Σ_{k: x_{t−k}=x}
//!   p(k), and b = Σ_t r_t ψ_t, solved by coordinate descent from the previous R̂;
//! * **p given R** is a 51-dimensional quadratic programme over the simplex, solved by
//!   accelerated projected gradient (FISTA) from the previous p̂.
//!
//! Neither needs the history: with the lag co-occurrence counts
//! C_j(x, x') = #{t : x_{t−j} = x, x_t = x'} and the lagged reward sums
//! B_k(x) = Σ_t r_t 1[x_{t−k} = x] (j, k = 0..=K, both updated in O(K) per step),
//!
//! ```text
//! G = Σ_{j≥0} a_j C_j + Σ_{j≥1} a_j C_jᵀ,   a_j = Σ_k p(k) p(k+j),   b(x) = Σ_k p(k) B_k(x)
//! Σ_t y_{t−k} y_{t−k'} = Rᵀ C_{|k−k'|} R,   Σ_t r_t y_{t−k} = Σ_x R(x) B_k(x)        (y_u = R(x_u))
//! ```
//!
//! up to edge terms of the last K steps. Memory is (K + 1)·X² counts for the X pairs
//! visited so far. p̂ starts uniform on 0..=K; when the learner is told the pmf, only R
//! is fitted.
//!
//! R(x) is a sum of features: one per pair, and one per *group* of pairs that share a
//! reward — with `successor_groups`, the actions of a state that have only ever led to
//! one and the same next state (the goal's actions, which all teleport; a cell's wall
//! bumps, which all stay put). A pair's own feature pays 1.25× a group's lasso penalty,
//! so of two explanations that fit alike the coarser wins; that is what credits the
//! goal's reward to the goal rather than to the move into it one step earlier.

use mmq_core::DelayDist;

use crate::Table;

/// Penalty of a pair feature relative to a state feature (state features on).
const PAIR_PENALTY: f64 = 1.25;
/// Reweighted passes of the pmf fit per refit.
const WEIGHTED_PASSES: usize = 3;
/// Iterations of the projected-gradient solve for p.
const QP_ITERS: usize = 300;
/// Coordinate-descent sweeps for R (at most; stops when no estimate moves by 1e-12).
const CD_SWEEPS: usize = 200;
/// Sweeps between two drops of the joint test (the last fit runs to `CD_SWEEPS`).
const ELIM_SWEEPS: usize = 10;
/// Steps of history kept for the reweighted pmf fit.
pub const HISTORY_MAX: usize = 1 << 21;
/// No pair yet.
const UNSEEN: u32 = u32::MAX;
/// A pair that led to more than one next state.
const MIXED: u32 = u32::MAX - 1;

/// Steps between two snapshots of the delay estimate (reported by `metrics`).
pub const SNAPSHOT_EVERY: u64 = 10_000;

/// Configuration of a [`Deconvolver`].
#[derive(Clone, Debug, PartialEq)]
pub struct DeconvConfig {
    /// K: the largest delay considered, steps.
    pub max_delay: usize,
    /// μ of (D2): ridge strength on R̂, in visits' worth of information.
    pub reward_prior: f64,
    /// λ₁ of (D2), reward units.
    pub lasso: f64,
    /// κ: an estimate is kept only when it is more than κ·√(2 ln m) standard errors from
    /// zero, m the number of reward features (the threshold of (D2) grows by
    /// κ √(2 ln m) σ̂ √G(x, x), σ̂ the residual deviation; κ = 1 is the universal threshold).
    pub significance: f64,
    /// Reward features per state (shared by its actions) besides those per pair.
    pub state_rewards: bool,
    /// Reward features per transition: the actions of a state that have only ever led to
    /// one and the same next state share a feature (besides their own).
    pub successor_groups: bool,
    /// κ_J: the joint test keeps a pair's reward only when it lies more than
    /// κ_J κ √(2 ln m) σ̂ joint standard errors from zero (0: off; pair features only).
    pub joint_test: f64,
    /// Refine the pmf by reweighted least squares on the stored history (each step
    /// weighted by the inverse of its delivery's variance under p̂).
    pub pmf_weighted: bool,
    /// κ_p: in the reweighted fit a lag keeps its mass only with more than κ_p standard
    /// errors of evidence (an L1 penalty κ_p √A_kk over {p ≥ 0, Σ p ≤ 1}, then
    /// renormalised); without it non-negativity turns noise into mass at every lag.
    pub pmf_significance: f64,
    /// ν: pull ½ ν max_x R̂(x)² ‖p − uniform‖² of the pmf fit towards the uniform pmf,
    /// in visits of the largest reward: it dominates while few rewards were seen and
    /// fades as data come in, so early fits stay broad instead of locking onto a lag.
    pub pmf_prior: f64,
    /// ρ: roughness penalty ½ ρ max_x R̂(x)² Σ_k (p(k+1) − p(k))² of the pmf fit, in
    /// visits of the largest reward (0: off).
    pub pmf_smoothness: f64,
    /// Steps between two refits early on; later refits come every max(this, t/8) steps.
    pub refit_every: u64,
    /// A known pmf over 0..=K (then p̂ is not estimated).
    pub told: Option<Vec<f64>>,
    /// Decode each delivery into the discrete reward values it is a sum of and fit one
    /// reward table per value with a shared pmf ([`crate::decode`]); read by
    /// [`crate::decode::ValueDeconvolver`], not by [`Deconvolver`].
    pub decode_values: bool,
}

/// The delay pmf of `dist` over 0..=`max_delay`, the tail beyond folded into the last bin.
pub fn truncated_pmf(dist: &DelayDist, max_delay: usize) -> Vec<f64> {
    let mut p: Vec<f64> = (0..=max_delay as u32).map(|k| dist.pmf(k)).collect();
    let total: f64 = p.iter().sum();
    if let Some(last) = p.last_mut() {
        *last += (1.0 - total).max(0.0);
    }
    p
}

/// Mean of a pmf over 0, 1, 2, ...
pub fn pmf_mean(p: &[f64]) -> f64 {
    let s: f64 = p.iter().sum();
    p.iter().enumerate().map(|(k, x)| k as f64 * x).sum::<f64>() / s
}

/// Median of a pmf over 0, 1, 2, ..., interpolated inside the bin where the cumulative
/// probability crosses one half (each bin k spread uniformly over [k − ½, k + ½]).
pub fn pmf_median(p: &[f64]) -> f64 {
    let s: f64 = p.iter().sum();
    let mut acc = 0.0;
    for (k, &x) in p.iter().enumerate() {
        let x = x / s;
        if x > 0.0 && acc + x >= 0.5 {
            return k as f64 - 0.5 + (0.5 - acc) / x;
        }
        acc += x;
    }
    p.len() as f64 - 0.5
}

/// (G_S + ridge·I)⁻¹ for the pairs `active` of the `n`×`n` Gram matrix `g` (None when it
/// is not positive definite): the joint covariance of their estimates, in units of σ̂².
pub fn joint_inverse(g: &[f64], n: usize, active: &[usize], ridge: f64) -> Option<nalgebra::DMatrix<f64>> {
    let s_n = active.len();
    let gs = nalgebra::DMatrix::from_fn(s_n, s_n, |a, b| {
        g[active[a] * n + active[b]] + if a == b { ridge } else { 0.0 }
    });
    Some(gs.cholesky()?.inverse())
}

/// The inverse of a symmetric positive definite M without its row and column `pos`,
/// from `inv` = M⁻¹: with M⁻¹ = [[A, b], [bᵀ, c]] (pos last), it is A − b bᵀ / c.
pub fn drop_from_inverse(inv: &nalgebra::DMatrix<f64>, pos: usize) -> nalgebra::DMatrix<f64> {
    let c = inv[(pos, pos)];
    let b = inv.column(pos).into_owned().remove_row(pos);
    let mut a = inv.clone().remove_row(pos).remove_column(pos);
    a -= &b * b.transpose() / c;
    a
}

/// The inverse of M + a row and column for pair `x` (Gram column `u` = G(order, x), diagonal
/// `d` = G(x, x) + ridge), from `inv` = M⁻¹ (bordering, O(s²)): with w = M⁻¹u and the
/// Schur complement σ = d − uᵀw, [[M⁻¹ + w wᵀ/σ, −w/σ], [−wᵀ/σ, 1/σ]]. None when σ is not
/// clearly positive (the enlarged matrix is singular to working precision).
pub fn add_to_inverse(
    inv: &nalgebra::DMatrix<f64>,
    u: &nalgebra::DVector<f64>,
    d: f64,
) -> Option<nalgebra::DMatrix<f64>> {
    let s_n = inv.nrows();
    let w = inv * u;
    let sigma = d - u.dot(&w);
    // NaN fails too.
    if sigma.is_nan() || sigma <= 1e-9 * d.abs().max(1e-300) {
        return None;
    }
    let mut out = nalgebra::DMatrix::zeros(s_n + 1, s_n + 1);
    out.view_mut((0, 0), (s_n, s_n)).copy_from(&(inv + &w * w.transpose() / sigma));
    for a in 0..s_n {
        out[(a, s_n)] = -w[a] / sigma;
        out[(s_n, a)] = -w[a] / sigma;
    }
    out[(s_n, s_n)] = 1.0 / sigma;
    Some(out)
}

/// Brings (`order`, `inv` = (G_order + ridge)⁻¹) to the set `now` by dropping and adding
/// pairs one at a time ([`drop_from_inverse`], [`add_to_inverse`]); the returned order
/// lists `now` in the inverse's order. None when more than `max_changes` pairs differ or
/// an addition is numerically singular (refactor instead).
fn update_inverse(
    g: &[f64],
    n: usize,
    ridge: f64,
    mut order: Vec<usize>,
    mut inv: nalgebra::DMatrix<f64>,
    now: &[usize],
    max_changes: usize,
) -> Option<(Vec<usize>, nalgebra::DMatrix<f64>)> {
    let gone: Vec<usize> = order.iter().copied().filter(|x| now.binary_search(x).is_err()).collect();
    let new: Vec<usize> = now.iter().copied().filter(|x| !order.contains(x)).collect();
    if gone.len() + new.len() > max_changes {
        return None;
    }
    for x in gone {
        let pos = order.iter().position(|&y| y == x)?;
        inv = drop_from_inverse(&inv, pos);
        order.remove(pos);
    }
    for x in new {
        let u = nalgebra::DVector::from_iterator(order.len(), order.iter().map(|&y| g[y * n + x]));
        inv = add_to_inverse(&inv, &u, g[x * n + x] + ridge)?;
        order.push(x);
    }
    Some((order, inv))
}

/// The joint test of the deconvolution's reward fit: of the pairs `active` (their
/// joint inverse `inv` from [`joint_inverse`]) whose estimate `rp[i]` lies less than
/// `thr` joint standard errors from zero, |rp[i]| < thr √inv_ii (`thr` includes σ̂),
/// the position in `active` of the one furthest below (the smallest |rp[i]| / √inv_ii).
/// None when every pair passes or fewer than two are active.
pub fn joint_failure(inv: &nalgebra::DMatrix<f64>, active: &[usize], rp: &[f64], thr: f64) -> Option<usize> {
    if active.len() < 2 {
        return None;
    }
    active
        .iter()
        .enumerate()
        .map(|(a, &i)| (a, rp[i].abs() / inv[(a, a)].max(0.0).sqrt()))
        .filter(|&(_, z)| z < thr)
        .min_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(a, _)| a)
}

/// A least-squares system ½ pᵀAp − cᵀp of the pmf fit: (A, c).
type System = (Vec<f64>, Vec<f64>);

/// `total` + `system`, elementwise over (A, c); the first system is taken as it is (so
/// that one deconvolver's fit is bit for bit its own).
fn add_system(total: Option<System>, system: System) -> Option<System> {
    Some(match total {
        None => system,
        Some((mut a, mut c)) => {
            a.iter_mut().zip(&system.0).for_each(|(x, y)| *x += y);
            c.iter_mut().zip(&system.1).for_each(|(x, y)| *x += y);
            (a, c)
        }
    })
}

/// The step of the next refit after one at step `t`: every `refit_every` steps early on,
/// every t/8 later.
pub(crate) fn next_refit_after(refit_every: u64, t: u64) -> u64 {
    t + refit_every.max(t / 8)
}

/// Projects `v` onto the probability simplex (Euclidean; Duchi et al. 2008).
pub fn project_simplex(v: &mut [f64]) {
    let mut u: Vec<f64> = v.to_vec();
    u.sort_by(|a, b| b.total_cmp(a));
    let mut acc = 0.0;
    let mut theta = 0.0;
    for (i, &x) in u.iter().enumerate() {
        acc += x;
        let t = (acc - 1.0) / (i + 1) as f64;
        if x - t > 0.0 {
            theta = t;
        }
    }
    v.iter_mut().for_each(|x| *x = (*x - theta).max(0.0));
}

/// Projects `v` onto {p ≥ 0, Σ p ≤ 1}.
pub fn project_capped_simplex(v: &mut [f64]) {
    let pos: f64 = v.iter().map(|x| x.max(0.0)).sum();
    if pos <= 1.0 {
        v.iter_mut().for_each(|x| *x = x.max(0.0));
    } else {
        project_simplex(v);
    }
}

/// Adds ρ DᵀD to the `k_n`×`k_n` matrix `m`, D the first-difference operator: the
/// Hessian of ½ ρ Σ_k (p(k+1) − p(k))².
pub fn add_roughness(m: &mut [f64], k_n: usize, rho: f64) {
    for k in 0..k_n.saturating_sub(1) {
        m[k * k_n + k] += rho;
        m[(k + 1) * k_n + k + 1] += rho;
        m[k * k_n + k + 1] -= rho;
        m[(k + 1) * k_n + k] -= rho;
    }
}

/// Standard error of the median of `p`, in steps, from a quasi-likelihood system
/// ½ pᵀAp − cᵀp + ½ ν ‖p − uniform‖² whose A is weighted by inverse variances (so that
/// (A + νI)⁻¹ is the covariance of its solution): the cumulative probability F at the
/// median m̂, F = eᵀp (e: 1 below m̂'s bin, the fraction of that bin below m̂), has variance
/// eᵀCe with C = M⁻¹ − M⁻¹11ᵀM⁻¹ / 1ᵀM⁻¹1 (M = A + νI, C under Σp = 1), and an error δF
/// moves the median by δF / f, f the mean of p over the five bins around m̂ (delta method;
/// infinite when p has no mass there, as in a gap between two lobes). `None` when M is
/// not positive definite.
pub fn median_se(a: &[f64], nu: f64, p: &[f64]) -> Option<MedianSe> {
    let k_n = p.len();
    let mut m = nalgebra::DMatrix::from_row_slice(k_n, k_n, a);
    for i in 0..k_n {
        m[(i, i)] += nu;
    }
    let chol = m.cholesky()?;
    let median = pmf_median(p);
    let bin = (median.round().max(0.0) as usize).min(k_n - 1);
    let e = nalgebra::DVector::from_fn(k_n, |k, _| match k.cmp(&bin) {
        std::cmp::Ordering::Less => 1.0,
        std::cmp::Ordering::Equal => (median - (bin as f64 - 0.5)).clamp(0.0, 1.0),
        std::cmp::Ordering::Greater => 0.0,
    });
    let ones = nalgebra::DVector::from_element(k_n, 1.0);
    let (ce, c1) = (chol.solve(&e), chol.solve(&ones));
    let var = e.dot(&ce) - e.dot(&c1).powi(2) / ones.dot(&c1);
    let (lo, hi) = (bin.saturating_sub(2), (bin + 2).min(k_n - 1));
    let f = p[lo..=hi].iter().sum::<f64>() / (hi - lo + 1) as f64;
    let cdf = var.max(0.0).sqrt();
    cdf.is_finite().then(|| MedianSe { cdf, steps: if f > 0.0 { cdf / f } else { f64::INFINITY } })
}

/// Standard errors of the median m̂ of a delay estimate ([`median_se`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MedianSe {
    /// Of the cumulative probability F(m̂).
    pub cdf: f64,
    /// Of m̂ itself, steps.
    pub steps: f64,
}

/// argmin over {p ≥ 0, Σ p ≤ 1} of ½ pᵀAp − cᵀp + ½ ν ‖p − uniform‖² + Σ_k λ_k p_k by
/// FISTA from `warm`, renormalised to sum to one (`None` when A carries no information).
pub fn solve_pmf(a: &[f64], c: &[f64], nu: f64, lam: &[f64], warm: &[f64]) -> Option<Vec<f64>> {
    let k_n = c.len();
    let mut v = vec![1.0; k_n];
    let mut lmax = 0.0;
    for _ in 0..30 {
        let w: Vec<f64> = (0..k_n).map(|i| (0..k_n).map(|j| a[i * k_n + j] * v[j]).sum()).collect();
        let norm = w.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm == 0.0 || !norm.is_finite() {
            return None;
        }
        lmax = norm / v.iter().map(|x| x * x).sum::<f64>().sqrt();
        v = w.iter().map(|x| x / norm).collect();
    }
    let uni = 1.0 / k_n as f64;
    let step = 1.0 / ((lmax + nu) * 1.05);
    let mut p = warm.to_vec();
    let mut z = p.clone();
    let mut theta: f64 = 1.0;
    let mut next = vec![0.0; k_n];
    for _ in 0..QP_ITERS {
        for i in 0..k_n {
            let row = &a[i * k_n..(i + 1) * k_n];
            let grad: f64 =
                row.iter().zip(&z).map(|(x, y)| x * y).sum::<f64>() - c[i] + nu * (z[i] - uni) + lam[i];
            next[i] = z[i] - step * grad;
        }
        project_capped_simplex(&mut next);
        let theta2 = (1.0 + (1.0 + 4.0 * theta * theta).sqrt()) / 2.0;
        let mom = (theta - 1.0) / theta2;
        for i in 0..k_n {
            z[i] = next[i] + mom * (next[i] - p[i]);
        }
        p.copy_from_slice(&next);
        theta = theta2;
    }
    let total: f64 = p.iter().sum();
    (total > 0.0).then(|| p.iter().map(|x| x / total).collect())
}

/// One snapshot of the delay estimate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Snapshot {
    /// Steps observed.
    pub t: u64,
    /// Mean of p̂.
    pub mean: f64,
    /// Median of p̂ ([`pmf_median`]).
    pub median: f64,
    /// Standard errors of the median ([`median_se`]; `None` when unknown).
    pub median_se: Option<MedianSe>,
}

/// The reward table R̂ and delay pmf p̂ of (D1)–(D2), refitted as data comes in.
#[derive(Clone, Debug)]
pub struct Deconvolver {
    cfg: DeconvConfig,
    /// p̂(0..=K).
    pmf: Vec<f64>,
    /// R̂ by pair id (0 for pairs never seen): the state part plus the pair part.
    r: Vec<f64>,
    /// The pair part of R̂, by pair id.
    r_pair: Vec<f64>,
    /// The group part of R̂ (shared by the pairs of a group), by pair id.
    r_group: Vec<f64>,
    /// The one next state each pair id has led to (UNSEEN before its first transition,
    /// MIXED once it led to two).
    succ: Vec<u32>,
    /// |A|: pair id x belongs to state x / |A|.
    num_actions: usize,
    /// Compact index of each pair id (UNSEEN until first taken).
    index: Vec<u32>,
    /// Pair id of each compact index.
    pairs: Vec<u32>,
    /// Capacity of the compact index (stride of `c`).
    cap: usize,
    /// C_j(i, i') at (j·cap + i)·cap + i', i the earlier pair.
    c: Vec<u32>,
    /// B_k(i) at k·cap + i.
    b: Vec<f64>,
    /// Compact indices of the last 2(K + 1) steps, by t mod 2(K + 1).
    recent: Vec<u32>,
    /// Σ_t r_t².
    sum_r2: f64,
    /// Compact pair index and delivered reward of every step of the current run (for
    /// the reweighted pmf fit; at most [`HISTORY_MAX`] steps, the oldest dropped).
    hist_x: Vec<u32>,
    hist_r: Vec<f64>,
    /// Residual sum of squares of the last fit of R (None before the first).
    rss: Option<f64>,
    /// Steps observed.
    t: u64,
    /// First step of the current history (after `reset_history`).
    start: u64,
    next_refit: u64,
    refits: u64,
    /// Refits at which the cold start (from the uniform pmf) won.
    cold_wins: u64,
    /// Pairs dropped by the joint test, over all refits, and refactorisations of its
    /// inverse (the rest were O(s²) updates).
    joint_drops: u64,
    joint_factorisations: u64,
    snapshots: Vec<Snapshot>,
    /// Sign every reward feature must have (+1, −1; 0: free): a deconvolver of one reward
    /// value's deliveries ([`crate::decode`]) only fits rewards of that value's sign.
    sign: f64,
    /// Standard errors of p̂'s median from the last reweighted fit ([`median_se`]).
    median_se: Option<MedianSe>,
}

impl Deconvolver {
    /// A deconvolver over `num_states` × `num_actions` pairs (pair id s·|A| + a); p̂
    /// uniform on 0..=K unless told.
    pub fn new(cfg: DeconvConfig, num_states: usize, num_actions: usize) -> Self {
        let num_pairs = num_states * num_actions;
        let k = cfg.max_delay;
        let pmf = match &cfg.told {
            Some(p) => {
                let mut p = p.clone();
                p.resize(k + 1, 0.0);
                let s: f64 = p.iter().sum();
                p.iter_mut().for_each(|x| *x /= s);
                p
            }
            None => vec![1.0 / (k + 1) as f64; k + 1],
        };
        let cap = 16.min(num_pairs.max(1));
        Self {
            next_refit: cfg.refit_every,
            cfg,
            pmf,
            r: vec![0.0; num_pairs],
            r_pair: vec![0.0; num_pairs],
            r_group: vec![0.0; num_pairs],
            succ: vec![UNSEEN; num_pairs],
            num_actions,
            index: vec![UNSEEN; num_pairs],
            pairs: Vec::new(),
            cap,
            c: vec![0; (k + 1) * cap * cap],
            b: vec![0.0; (k + 1) * cap],
            recent: vec![UNSEEN; 2 * (k + 1)],
            sum_r2: 0.0,
            hist_x: Vec::new(),
            hist_r: Vec::new(),
            rss: None,
            t: 0,
            start: 0,
            refits: 0,
            cold_wins: 0,
            joint_drops: 0,
            joint_factorisations: 0,
            snapshots: Vec::new(),
            sign: 0.0,
            median_se: None,
        }
    }

    /// R̂(x).
    #[inline]
    pub fn reward(&self, x: usize) -> f64 {
        self.r[x]
    }

    /// The whole reward table R̂ by pair id.
    pub fn rewards(&self) -> &[f64] {
        &self.r
    }

    /// The delay pmf p̂(0..=K).
    pub fn pmf(&self) -> &[f64] {
        &self.pmf
    }

    /// Standard errors of p̂'s median from the last reweighted fit ([`median_se`]);
    /// `None` before the first, when told the pmf, or unweighted.
    pub fn median_se(&self) -> Option<MedianSe> {
        self.median_se
    }

    /// R̂ (`r_hat`, shape [states, actions]) and p̂ (`delay_pmf`), for export.
    pub fn tables(&self) -> [Table; 2] {
        [
            Table {
                name: "r_hat".into(),
                shape: vec![self.r.len() / self.num_actions, self.num_actions],
                data: self.r.clone(),
            },
            Table { name: "delay_pmf".into(), shape: vec![self.pmf.len()], data: self.pmf.clone() },
        ]
    }

    /// Snapshots of the delay estimate, every [`SNAPSHOT_EVERY`] steps.
    pub fn snapshots(&self) -> &[Snapshot] {
        &self.snapshots
    }

    /// Whether p̂ is estimated (not told).
    pub fn estimates_delay(&self) -> bool {
        self.cfg.told.is_none()
    }

    /// Steps observed.
    pub fn steps(&self) -> u64 {
        self.t
    }

    /// Refits so far.
    pub fn refits(&self) -> u64 {
        self.refits
    }

    /// Pairs taken so far.
    pub fn pairs_seen(&self) -> usize {
        self.pairs.len()
    }

    /// Bytes of the statistics for `pairs` pairs and largest delay `max_delay`.
    pub fn stats_bytes(pairs: usize, max_delay: usize) -> u128 {
        let (p, k) = (pairs as u128, max_delay as u128 + 1);
        k * p * p * 4 + k * p * 8 + p * 24
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
        let (old, new) = (self.cap, (self.cap * 2).min(self.r.len()).max(self.cap + 1));
        let k_n = self.cfg.max_delay + 1;
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

    /// One step: pair `x` was taken, led to `next_state`, and `reward` was delivered.
    /// Refits when due; returns true when it did.
    pub fn observe_transition(&mut self, x: usize, next_state: usize, reward: f64) -> bool {
        self.record_successor(x, next_state);
        self.observe(x, reward)
    }

    /// One step: pair `x` was taken and `reward` was delivered. Refits when due; returns
    /// true when it did.
    pub fn observe(&mut self, x: usize, reward: f64) -> bool {
        self.record(x, reward);
        let mut refitted = false;
        if self.t >= self.next_refit {
            self.refit();
            self.next_refit = next_refit_after(self.cfg.refit_every, self.t);
            refitted = true;
        }
        if self.t.is_multiple_of(SNAPSHOT_EVERY) {
            self.push_snapshot();
        }
        refitted
    }

    /// Records the successor of pair `x` (for the successor groups).
    pub(crate) fn record_successor(&mut self, x: usize, next_state: usize) {
        let s2 = next_state as u32;
        self.succ[x] = match self.succ[x] {
            UNSEEN => s2,
            v if v == s2 => s2,
            _ => MIXED,
        };
    }

    /// One step's statistics (no refit, no snapshot): pair `x` taken, `reward` delivered.
    pub(crate) fn record(&mut self, x: usize, reward: f64) {
        let i = self.compact(x);
        let k_n = self.cfg.max_delay + 1;
        let cap = self.cap;
        self.recent[(self.t % (2 * k_n) as u64) as usize] = i as u32;
        self.sum_r2 += reward * reward;
        if self.cfg.pmf_weighted && self.cfg.told.is_none() {
            if self.hist_x.len() == HISTORY_MAX {
                self.hist_x.drain(..HISTORY_MAX / 2);
                self.hist_r.drain(..HISTORY_MAX / 2);
            }
            self.hist_x.push(i as u32);
            self.hist_r.push(reward);
        }
        let kmax = (self.cfg.max_delay as u64).min(self.t - self.start) as usize;
        for k in 0..=kmax {
            let e = self.past(self.t - k as u64);
            self.c[(k * cap + e) * cap + i] += 1;
            self.b[k * cap + e] += reward;
        }
        self.t += 1;
    }

    /// Takes over `other`'s delay estimate, its snapshots and its counters (refits,
    /// cold-start wins, joint-test drops): a deconvolver rebuilt from the history
    /// continues where `other` was.
    pub(crate) fn inherit(&mut self, other: &Deconvolver) {
        self.pmf.clone_from(&other.pmf);
        self.snapshots.clone_from(&other.snapshots);
        self.refits = other.refits;
        self.cold_wins = other.cold_wins;
        self.joint_drops = other.joint_drops;
        self.joint_factorisations = other.joint_factorisations;
    }

    /// Restricts every reward feature to the sign of `sign` (0: free).
    pub(crate) fn set_sign(&mut self, sign: f64) {
        self.sign = if sign == 0.0 { 0.0 } else { sign.signum() };
    }

    /// Appends a snapshot of the delay estimate at the current step.
    pub(crate) fn push_snapshot(&mut self) {
        self.snapshots.push(Snapshot {
            t: self.t,
            mean: pmf_mean(&self.pmf),
            median: pmf_median(&self.pmf),
            median_se: self.median_se,
        });
    }

    /// Compact index of the pair taken at step `u` (one of the last 2(K + 1)).
    #[inline]
    fn past(&self, u: u64) -> usize {
        self.recent[(u % self.recent.len() as u64) as usize] as usize
    }

    /// Refits R̂ given p̂, then (when estimating) p̂ given R̂ and R̂ again.
    ///
    /// When estimating, a second alternation starts from the uniform pmf (a cold start)
    /// and the fit with the lower penalised objective (D2) is kept: an alternation that
    /// locked onto a wrong delay early (or found no reward at all) gets out again.
    pub fn refit(&mut self) {
        Self::refit_all(std::slice::from_mut(self));
    }

    /// [`Self::refit`] for deconvolvers that see the same pairs and share one delay pmf
    /// (one per reward value, [`crate::decode`]): R̂ of each given p̂, then p̂ given all
    /// of them (their least-squares systems summed), with the cold start compared on the
    /// summed objective. One deconvolver: exactly `refit`.
    pub(crate) fn refit_all(ds: &mut [Deconvolver]) {
        if ds.is_empty() || ds[0].pairs.is_empty() {
            return;
        }
        // σ̂ from the previous fit (Σ r² before the first: an upper bound), shared by
        // both starts so that their objectives compare.
        let sigmas: Vec<f64> =
            ds.iter().map(|d| (d.rss.unwrap_or(d.sum_r2).max(0.0) / d.t.max(1) as f64).sqrt()).collect();
        let fit_all = |ds: &mut [Deconvolver]| -> f64 {
            ds.iter_mut().zip(&sigmas).map(|(d, &sigma)| d.fit_rewards(sigma, false)).sum()
        };
        fit_all(ds);
        if ds[0].cfg.told.is_none() {
            Self::fit_pmf_all(ds);
            let warm_objective = fit_all(ds);
            let warm: Vec<_> = ds
                .iter()
                .map(|d| {
                    (d.pmf.clone(), d.r.clone(), d.r_pair.clone(), d.r_group.clone(), d.rss, d.median_se)
                })
                .collect();
            for d in ds.iter_mut() {
                let k_n = d.cfg.max_delay + 1;
                d.pmf = vec![1.0 / k_n as f64; k_n];
                d.r.iter_mut().chain(d.r_pair.iter_mut()).chain(d.r_group.iter_mut()).for_each(|x| *x = 0.0);
            }
            fit_all(ds);
            Self::fit_pmf_all(ds);
            if fit_all(ds) < warm_objective {
                ds.iter_mut().for_each(|d| d.cold_wins += 1);
            } else {
                for (d, w) in ds.iter_mut().zip(warm) {
                    (d.pmf, d.r, d.r_pair, d.r_group, d.rss, d.median_se) = w;
                }
            }
        }
        for (d, &sigma) in ds.iter_mut().zip(&sigmas) {
            if d.joint_on() {
                d.fit_rewards(sigma, true);
            }
            d.refits += 1;
        }
    }

    /// Whether the joint test runs (on, and pair features only).
    fn joint_on(&self) -> bool {
        self.cfg.joint_test > 0.0 && !self.cfg.state_rewards
    }

    /// The reward groups, as (a member's pair id, compact members): the pairs of each
    /// state (`state_rewards`), or the pairs of a state that have only ever led to one
    /// and the same next state (`successor_groups`; a pair seen leading to two next
    /// states is a group of its own), or one group per state when neither is on (then
    /// unused). Groups of one pair carry no feature of their own.
    fn groups(&self) -> Vec<(usize, Vec<usize>)> {
        let a_n = self.num_actions;
        let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
        let mut slot = std::collections::HashMap::new();
        for (i, &x) in self.pairs.iter().enumerate() {
            let st = x as usize / a_n;
            let succ = self.succ[x as usize];
            let key = if !self.cfg.successor_groups || self.cfg.state_rewards {
                (st, 0)
            } else if succ == UNSEEN || succ == MIXED {
                (st, u64::from(u32::MAX) + 1 + i as u64)
            } else {
                (st, u64::from(succ))
            };
            let g_i = *slot.entry(key).or_insert_with(|| {
                groups.push((x as usize, Vec::new()));
                groups.len() - 1
            });
            groups[g_i].1.push(i);
        }
        groups
    }

    /// Whether pairs share group features (per state or per successor).
    fn grouped(&self) -> bool {
        self.cfg.state_rewards || self.cfg.successor_groups
    }

    /// R given p: lasso by coordinate descent on (G, b), warm-started. Returns the
    /// penalised objective (D2) at the fit (½ RSS + penalties).
    fn fit_rewards(&mut self, sigma: f64, joint: bool) -> f64 {
        let n = self.pairs.len();
        let cap = self.cap;
        let k_n = self.cfg.max_delay + 1;
        let p = &self.pmf;
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
        // Edge terms: a pair (u − j, u) with u among the last K steps has fewer than K + 1
        // windows after it; C_j counted it with the full weight a_j.
        let big_t = self.t;
        for u in self.start.max(big_t.saturating_sub(k_n as u64 - 1))..big_t {
            let left = (big_t - 1 - u) as usize; // windows end at t = u..=T−1, k' ≤ left
            for j in 0..=((k_n - 1).min((u - self.start) as usize)) {
                let deficit: f64 = (left + 1..k_n - j).map(|k2| p[k2 + j] * p[k2]).sum();
                if deficit == 0.0 {
                    continue;
                }
                let (v, w) = (self.past(u - j as u64), self.past(u));
                g[v * n + w] -= deficit;
                if j > 0 {
                    g[w * n + v] -= deficit;
                }
            }
        }
        let bvec: Vec<f64> = (0..n).map(|i| (0..k_n).map(|k| p[k] * self.b[k * cap + i]).sum()).collect();
        let ridge = self.cfg.reward_prior * a[0];
        // κ × the universal threshold √(2 ln m) of m features (Donoho & Johnstone): with
        // hundreds of pairs a plain 2σ test would pass several spurious rewards per fit.
        let m = (self.pairs.len() + self.pairs.len() / self.num_actions.max(1)).max(2) as f64;
        let kappa = self.cfg.significance * (2.0 * m.ln()).sqrt() * sigma;
        let lasso = self.cfg.lasso;
        // The exact minimiser along one feature; with a sign constraint, clipped at zero
        // (still exact: the one-dimensional problem is convex).
        let sign = self.sign;
        let soft = |z: f64, info: f64, factor: f64| {
            let thr = factor * (lasso * info + kappa * info.sqrt());
            let v = if z > thr {
                (z - thr) / (info + ridge)
            } else if z < -thr {
                (z + thr) / (info + ridge)
            } else {
                0.0
            };
            if v * sign < 0.0 { 0.0 } else { v }
        };
        // With group features, a pair's own reward pays PAIR_PENALTY × a group's penalty:
        // of two explanations that fit equally (the goal's actions, or the only pair that
        // enters the goal), the coarser one wins.
        let grouped = self.grouped();
        let pair_factor = if grouped { PAIR_PENALTY } else { 1.0 };
        let groups = self.groups();
        let mut rp: Vec<f64> = self.pairs.iter().map(|&x| self.r_pair[x as usize]).collect();
        let mut rs: Vec<f64> = groups.iter().map(|(x0, _)| self.r_group[*x0]).collect();
        if !grouped {
            rs.iter_mut().for_each(|x| *x = 0.0);
        }
        // r = total R̂ per compact pair; gr = G r.
        let mut r: Vec<f64> = vec![0.0; n];
        for (gi, (_, members)) in groups.iter().enumerate() {
            for &i in members {
                r[i] = rs[gi] + rp[i];
            }
        }
        let mut gr: Vec<f64> =
            (0..n).map(|i| g[i * n..(i + 1) * n].iter().zip(&r).map(|(x, y)| x * y).sum()).collect();
        let mut gss: Vec<f64> = vec![0.0; groups.len()];
        for (gi, (_, members)) in groups.iter().enumerate() {
            gss[gi] = members.iter().map(|&i| members.iter().map(|&i2| g[i * n + i2]).sum::<f64>()).sum();
        }
        // gr += d · G(i, ·): R̂ of compact pair i moved by d.
        let shift = |gr: &mut [f64], i: usize, d: f64| {
            for (gv, &gc) in gr.iter_mut().zip(&g[i * n..(i + 1) * n]) {
                *gv += gc * d;
            }
        };
        // Pairs dropped by the joint test below; they stay at zero for this fit.
        let mut excluded = vec![false; n];
        // The joint test's active set (in the order of its inverse) and (G_S + ridge)⁻¹.
        let mut last: Option<(Vec<usize>, nalgebra::DMatrix<f64>)> = None;
        // Between two drops of the joint test the refit is cut short (ELIM_SWEEPS);
        // before the test may pass, the fit is run to convergence.
        let mut sweeps = CD_SWEEPS;
        loop {
            for _ in 0..sweeps {
                let mut moved: f64 = 0.0;
                for (gi, (_, members)) in groups.iter().enumerate() {
                    // The group feature: one value shared by the group's pairs.
                    if grouped && members.len() > 1 && gss[gi] > 0.0 {
                        let z: f64 = members.iter().map(|&i| bvec[i] - gr[i]).sum::<f64>() + gss[gi] * rs[gi];
                        let d = soft(z, gss[gi], 1.0) - rs[gi];
                        if d != 0.0 {
                            rs[gi] += d;
                            for &i in members {
                                r[i] += d;
                                shift(&mut gr, i, d);
                            }
                            moved = moved.max(d.abs());
                        }
                    }
                    // The pair features.
                    for &i in members {
                        let gii = g[i * n + i];
                        if gii <= 0.0 || excluded[i] {
                            continue;
                        }
                        let z = bvec[i] - gr[i] + gii * rp[i];
                        let d = soft(z, gii, pair_factor) - rp[i];
                        if d != 0.0 {
                            rp[i] += d;
                            r[i] += d;
                            shift(&mut gr, i, d);
                            moved = moved.max(d.abs());
                        }
                    }
                }
                if moved < 1e-12 {
                    break;
                }
            }
            // The joint test (once per refit, on its final fit): a pair that passed the
            // lasso's test given the others must also stand out jointly with them,
            // |R̂(x)| > κ_J κ √(2 ln m) σ̂ √[(G_S + ridge)⁻¹]_xx over the active set S.
            // Two pairs that always come close together in time (a corridor step and
            // its way back) are nearly collinear: each can carry a large reward of
            // opposite sign that the per-pair test passes, while their joint standard
            // errors are large. The pair furthest below its threshold is dropped and
            // the rest refitted (backward elimination: of two collinear pairs one goes,
            // and the other then carries what the data support — two wall bumps in a
            // corner keep one −1 between them, where dropping every failing pair at
            // once lost both), until every active pair passes.
            if !joint || !self.joint_on() {
                break;
            }
            let now: Vec<usize> = (0..n).filter(|&i| rp[i] != 0.0).collect();
            if now.len() < 2 {
                break;
            }
            // After a drop the refit changes the set by a few pairs: the inverse is then
            // updated pair by pair in O(s²) each, instead of refactored in O(s³).
            let updated = last.take().and_then(|(order, inv)| {
                update_inverse(&g, n, ridge, order, inv, &now, (now.len() / 4).max(4))
            });
            let (active, inv) = match updated {
                Some(x) => x,
                None => {
                    self.joint_factorisations += 1;
                    match joint_inverse(&g, n, &now, ridge) {
                        Some(inv) => (now, inv),
                        None => break,
                    }
                }
            };
            let Some(pos) = joint_failure(&inv, &active, &rp, self.cfg.joint_test * kappa) else {
                if sweeps < CD_SWEEPS {
                    sweeps = CD_SWEEPS;
                    last = Some((active, inv));
                    continue;
                }
                break;
            };
            sweeps = ELIM_SWEEPS;
            let i = active[pos];
            last = Some((active, inv));
            self.joint_drops += 1;
            let d = -rp[i];
            rp[i] = 0.0;
            r[i] += d;
            shift(&mut gr, i, d);
            excluded[i] = true;
        }
        // RSS = Σ r² − 2 Rᵀb + Rᵀ G R
        let rb: f64 = r.iter().zip(&bvec).map(|(x, y)| x * y).sum();
        let rgr: f64 = r.iter().zip(&gr).map(|(x, y)| x * y).sum();
        let rss = self.sum_r2 - 2.0 * rb + rgr;
        self.rss = Some(rss);
        let thr = |info: f64, factor: f64| factor * (lasso * info + kappa * info.sqrt());
        let mut penalty = 0.0;
        for (i, &x) in self.pairs.iter().enumerate() {
            self.r[x as usize] = r[i];
            self.r_pair[x as usize] = rp[i];
            penalty += thr(g[i * n + i], pair_factor) * rp[i].abs() + 0.5 * ridge * rp[i] * rp[i];
        }
        for (gi, (_, members)) in groups.iter().enumerate() {
            for &i in members {
                self.r_group[self.pairs[i] as usize] = rs[gi];
            }
            penalty += thr(gss[gi], 1.0) * rs[gi].abs() + 0.5 * ridge * rs[gi] * rs[gi];
        }
        0.5 * rss + penalty
    }

    /// The least-squares system of p given R̂, ½ pᵀAp − cᵀp: (A, c, R̂ by compact pair,
    /// max |R̂|); None when R̂ is zero.
    #[allow(clippy::type_complexity)]
    fn pmf_system(&self) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>, f64)> {
        let n = self.pairs.len();
        let cap = self.cap;
        let k_n = self.cfg.max_delay + 1;
        let r: Vec<f64> = self.pairs.iter().map(|&x| self.r[x as usize]).collect();
        if r.iter().all(|&v| v == 0.0) {
            return None;
        }
        // q_j = Rᵀ C_j R over the support of R;  c_k = Σ_i R_i B_k(i).
        let support: Vec<usize> = (0..n).filter(|&i| r[i] != 0.0).collect();
        let mut q = vec![0.0; k_n];
        for (j, qj) in q.iter_mut().enumerate() {
            let mut acc = 0.0;
            for &i in &support {
                let row = &self.c[(j * cap + i) * cap..(j * cap + i) * cap + n];
                let s: f64 = support.iter().map(|&i2| row[i2] as f64 * r[i2]).sum();
                acc += r[i] * s;
            }
            *qj = acc;
        }
        let cvec: Vec<f64> = (0..k_n).map(|k| (0..n).map(|i| r[i] * self.b[k * cap + i]).sum()).collect();
        // A_{kk'} = Σ_t y_{t−k} y_{t−k'} = q_{|k−k'|} − E(|k−k'|, min(k, k')), where
        // E(j, m) = Σ_{u=T−m}^{T−1} y_{u−j} y_u removes the windows that end after now.
        let big_t = self.t;
        let y_at = |u: u64| r[self.past(u)];
        let mut e = vec![0.0; k_n * k_n];
        for j in 0..k_n {
            let mut acc = 0.0;
            for m in 1..k_n {
                if big_t >= self.start + m as u64 + j as u64 {
                    let u = big_t - m as u64;
                    acc += y_at(u - j as u64) * y_at(u);
                }
                e[j * k_n + m] = acc;
            }
        }
        let mut amat = vec![0.0; k_n * k_n];
        for i in 0..k_n {
            for j in 0..k_n {
                let d = i.abs_diff(j);
                amat[i * k_n + j] = q[d] - e[d * k_n + i.min(j)];
            }
        }
        let rmax = r.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        Some((amat, cvec, r, rmax))
    }

    /// p given R̂ of every deconvolver in `ds` (sharing one pmf): FISTA over the simplex
    /// on the sum of their systems ½ pᵀAp − cᵀp, then the reweighted passes.
    fn fit_pmf_all(ds: &mut [Deconvolver]) {
        let k_n = ds[0].cfg.max_delay + 1;
        let cfg = ds[0].cfg.clone();
        let mut systems: Vec<(usize, Vec<f64>, f64)> = Vec::new();
        let mut total: Option<System> = None;
        let mut rmax = 0.0f64;
        for (di, d) in ds.iter().enumerate() {
            let Some((amat, cvec, r, rm)) = d.pmf_system() else { continue };
            rmax = rmax.max(rm);
            total = add_system(total, (amat, cvec));
            systems.push((di, r, rm));
        }
        let Some((mut amat, cvec)) = total else { return };
        let nu = cfg.pmf_prior * rmax * rmax;
        let rho = cfg.pmf_smoothness * rmax * rmax;
        let trace_u: f64 = (0..k_n).map(|i| amat[i * k_n + i]).sum();
        if rho > 0.0 {
            add_roughness(&mut amat, k_n, rho);
        }
        let Some(mut p) = solve_pmf(&amat, &cvec, nu, &vec![0.0; k_n], &ds[0].pmf) else { return };
        let mut last = None;
        if cfg.pmf_weighted {
            // Reweighted passes (quasi-likelihood): each step weighted by the inverse of
            // the variance its delivery would have under p, Σ_k (p(k)(1 − p(k)) + δ) y²_{t−k}.
            for _ in 0..WEIGHTED_PASSES {
                let sum = systems
                    .iter()
                    .fold(None, |sum, (di, r, rm)| add_system(sum, ds[*di].weighted_stats(r, &p, *rm)));
                let Some((mut aw, cw)) = sum else { break };
                let trace_w: f64 = (0..k_n).map(|i| aw[i * k_n + i]).sum();
                if trace_w <= 0.0 {
                    break;
                }
                let nu_w = nu * trace_w / trace_u.max(f64::MIN_POSITIVE);
                if rho > 0.0 {
                    add_roughness(&mut aw, k_n, rho * trace_w / trace_u.max(f64::MIN_POSITIVE));
                }
                let lam: Vec<f64> =
                    (0..k_n).map(|i| cfg.pmf_significance * aw[i * k_n + i].max(0.0).sqrt()).collect();
                match solve_pmf(&aw, &cw, nu_w, &lam, &p) {
                    Some(next) => p = next,
                    None => break,
                }
                last = Some((aw, nu_w));
            }
        }
        let se = last.and_then(|(aw, nu_w)| median_se(&aw, nu_w, &p));
        for d in ds.iter_mut() {
            d.pmf.clone_from(&p);
            d.median_se = se;
        }
    }

    /// Σ_t w_t ỹ_t ỹ_tᵀ and Σ_t w_t r_t ỹ_t over the stored history, ỹ_t(k) = y_{t−k},
    /// w_t = 1 / (Σ_k (p(k)(1 − p(k)) + δ) y²_{t−k} + v₀).
    fn weighted_stats(&self, r: &[f64], p: &[f64], rmax: f64) -> (Vec<f64>, Vec<f64>) {
        let k_n = self.cfg.max_delay + 1;
        let delta = 0.25 / k_n as f64;
        let v0 = 0.01 * rmax * rmax;
        let mut a = vec![0.0; k_n * k_n];
        let mut c = vec![0.0; k_n];
        let mut window: std::collections::VecDeque<(usize, f64)> = std::collections::VecDeque::new();
        let mut live: Vec<(usize, f64)> = Vec::with_capacity(k_n);
        for (t, (&i, &rt)) in self.hist_x.iter().zip(&self.hist_r).enumerate() {
            let y = r[i as usize];
            if y != 0.0 {
                window.push_back((t, y));
            }
            while window.front().is_some_and(|&(u, _)| u + k_n <= t) {
                window.pop_front();
            }
            if window.is_empty() {
                continue;
            }
            live.clear();
            let mut v = v0;
            for &(u, yu) in &window {
                let k = t - u;
                v += (p[k] * (1.0 - p[k]) + delta) * yu * yu;
                live.push((k, yu));
            }
            let w = 1.0 / v;
            for &(k1, y1) in &live {
                c[k1] += w * rt * y1;
                for &(k2, y2) in &live {
                    a[k1 * k_n + k2] += w * y1 * y2;
                }
            }
        }
        (a, c)
    }

    /// Forgets the last K steps (a new run starts); statistics, R̂ and p̂ are kept.
    pub fn reset_history(&mut self) {
        self.start = self.t;
        self.hist_x.clear();
        self.hist_r.clear();
    }

    /// Learner metrics: the delay estimate now and at every snapshot, and p̂ itself.
    pub fn metrics(&self) -> Vec<(String, f64)> {
        let mut m = vec![
            ("delay/mean_est".to_string(), pmf_mean(&self.pmf)),
            ("delay/median_est".to_string(), pmf_median(&self.pmf)),
            ("delay/refits".to_string(), self.refits as f64),
            ("delay/cold_start_wins".to_string(), self.cold_wins as f64),
            ("delay/joint_drops".to_string(), self.joint_drops as f64),
            ("delay/joint_factorisations".to_string(), self.joint_factorisations as f64),
            ("delay/estimated".to_string(), f64::from(u8::from(self.estimates_delay()))),
            ("learner/pairs_seen".to_string(), self.pairs.len() as f64),
        ];
        let push_se = |m: &mut Vec<(String, f64)>, se: Option<MedianSe>, at: &str| {
            if let Some(se) = se {
                m.push((format!("delay/median_se{at}"), se.steps));
                m.push((format!("delay/median_cdf_se{at}"), se.cdf));
            }
        };
        push_se(&mut m, self.median_se, "");
        for s in &self.snapshots {
            m.push((format!("delay/mean_est@{}", s.t), s.mean));
            m.push((format!("delay/median_est@{}", s.t), s.median));
            push_se(&mut m, s.median_se, &format!("@{}", s.t));
        }
        for (k, p) in self.pmf.iter().enumerate() {
            m.push((format!("delay/pmf/{k:03}"), *p));
        }
        m
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use mmq_core::seed::rng_from_seed;
    use rand::RngExt;

    pub(crate) fn cfg(k: usize, told: Option<Vec<f64>>) -> DeconvConfig {
        DeconvConfig {
            max_delay: k,
            reward_prior: 0.0,
            lasso: 0.0,
            significance: 0.0,
            state_rewards: false,
            successor_groups: false,
            joint_test: 0.0,
            pmf_weighted: false,
            pmf_significance: 0.0,
            pmf_prior: 0.0,
            pmf_smoothness: 0.0,
            refit_every: 1_000_000,
            told,
            decode_values: false,
        }
    }

    /// The sign constraint of one reward value's deconvolver, by hand. Told p = (½, ½),
    /// two pairs alternating: deliveries 2, 3, 3, 3 are exactly ½ R(x_t) + ½ R(x_{t−1})
    /// with R = (4, 2). Free or held non-negative, the unpenalised fit finds (4, 2); held
    /// non-positive, both stay at 0 — the constrained least-squares optimum when every
    /// delivery is positive and every regressor non-negative.
    #[test]
    fn sign_constraint_by_hand() {
        for (sign, want) in [(0.0, [4.0, 2.0]), (1.0, [4.0, 2.0]), (-1.0, [0.0, 0.0])] {
            let mut c = cfg(1, Some(vec![0.5, 0.5]));
            c.refit_every = 4;
            let mut d = Deconvolver::new(c, 2, 1);
            d.set_sign(sign);
            for (t, r) in [2.0, 3.0, 3.0, 3.0].into_iter().enumerate() {
                d.observe_transition(t % 2, (t + 1) % 2, r);
            }
            for (x, w) in want.iter().enumerate() {
                assert!((d.reward(x) - w).abs() < 1e-9, "sign {sign}: R̂ = {:?}", d.rewards());
            }
        }
    }

    /// Two lags, A = diag(2, 2), ν = 0, p = (½, ½): the median is 0.5 (bin 1, none of
    /// it below 0.5, so e = (1, 0)); Var F = eᵀM⁻¹e − (eᵀM⁻¹1)² / 1ᵀM⁻¹1 = ½ − ¼ / 1 = ¼;
    /// f = mean of p over bins 0..=1 = ½; SE = ½ / ½ = 1. Four times the information
    /// halves it; a singular system: none. A median in a gap between two lobes: F's
    /// error is ordinary, the median's huge.
    #[test]
    fn median_se_by_hand() {
        let p = [0.5, 0.5];
        let close = |se: Option<MedianSe>, cdf: f64, steps: f64| {
            let se = se.expect("positive definite");
            assert!((se.cdf - cdf).abs() < 1e-12 && (se.steps - steps).abs() < 1e-12, "{se:?}");
        };
        close(median_se(&[2.0, 0.0, 0.0, 2.0], 0.0, &p), 0.5, 1.0);
        close(median_se(&[8.0, 0.0, 0.0, 8.0], 0.0, &p), 0.25, 0.5);
        // ν adds to the diagonal: A = diag(1, 1), ν = 1 is the first case again.
        close(median_se(&[1.0, 0.0, 0.0, 1.0], 1.0, &p), 0.5, 1.0);
        assert_eq!(median_se(&[0.0; 4], 0.0, &p), None);
        // Three lags, p = (1, 0, 0): median 0, e = (½, 0, 0); M = I: Var F = ¼ − ¼ / 3 = 1/6,
        // f = mean over bins 0..=2 = 1/3, SE = √(1/6) · 3.
        let eye3 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        close(median_se(&eye3, 0.0, &[1.0, 0.0, 0.0]), 6f64.sqrt().recip(), 3.0 / 6f64.sqrt());
        // Eleven lags, two lobes and 0.02 between them: the median 5.0 lies in bin 5, half of
        // it below, so e = (1, 1, 1, 1, 1, ½, 0, …); M = I: Var F = 5¼ − 5½² / 11 = 2½, and
        // f = (0 + 0 + 0.02 + 0 + 0) / 5 = 0.004: F is known as well as anywhere, m̂ is not.
        let mut eye11 = [0.0; 121];
        (0..11).for_each(|i| eye11[i * 12] = 1.0);
        let lobes = [0.3, 0.19, 0.0, 0.0, 0.0, 0.02, 0.0, 0.0, 0.0, 0.19, 0.3];
        assert!((pmf_median(&lobes) - 5.0).abs() < 1e-12);
        close(median_se(&eye11, 0.0, &lobes), 2.5f64.sqrt(), 2.5f64.sqrt() / 0.004);
    }

    /// The standard error matches the spread of the median over independent runs: one
    /// reward source, 1 at random times, each reward late by a uniform draw from 0..=8;
    /// over 40 runs of 4,000 steps the median's standard deviation and the mean reported
    /// SE agree within a factor 1.5.
    #[test]
    fn median_se_matches_the_spread_over_runs() {
        let k = 12;
        let (mut medians, mut ses) = (Vec::new(), Vec::new());
        for seed in 0..40 {
            let mut c = cfg(k, None);
            c.pmf_weighted = true;
            c.refit_every = 1000;
            let mut d = Deconvolver::new(c, 2, 1);
            let mut rng = rng_from_seed(100 + seed);
            let steps = 4000;
            let mut due = vec![0.0; steps + k + 1];
            for t in 0..steps {
                let slot = rng.random_bool(0.2);
                if slot {
                    due[t + rng.random_range(0..=8)] += 1.0;
                }
                d.observe(usize::from(slot), due[t]);
            }
            d.refit();
            medians.push(pmf_median(d.pmf()));
            ses.push(d.median_se().expect("a reweighted fit").steps);
        }
        let n = medians.len() as f64;
        let mean = medians.iter().sum::<f64>() / n;
        let sd = (medians.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let se = ses.iter().sum::<f64>() / n;
        assert!((mean - 4.0).abs() < 0.5, "median {mean}");
        assert!(sd / se < 1.5 && se / sd < 1.5, "sd of the median {sd}, mean SE {se}");
    }

    /// Noise-free expected rewards: the fit recovers R exactly.
    #[test]
    fn recovers_rewards_from_expected_deliveries() {
        let k = 6;
        let p = vec![0.0, 0.1, 0.2, 0.4, 0.2, 0.1, 0.0];
        let truth = [0.0, 10.0, -1.0, 0.0, 3.0, 0.0, -2.0, 0.5];
        let mut d = Deconvolver::new(cfg(k, Some(p.clone())), truth.len(), 1);
        let mut rng = rng_from_seed(7);
        let mut xs = Vec::new();
        for t in 0..5000 {
            let x = rng.random_range(0..truth.len());
            xs.push(x);
            let r: f64 = (0..=k.min(t)).map(|j| p[j] * truth[xs[t - j]]).sum();
            d.observe(x, r);
        }
        d.refit();
        for (x, &want) in truth.iter().enumerate() {
            assert!((d.reward(x) - want).abs() < 1e-9, "R̂({x}) = {} vs {want}", d.reward(x));
        }
    }

    /// Noise-free expected rewards, delay pmf unknown: alternating refits from the
    /// uniform pmf find both the pmf and the rewards.
    #[test]
    fn recovers_the_delay_pmf() {
        let k = 8;
        let p = vec![0.0, 0.0, 0.1, 0.6, 0.3, 0.0, 0.0, 0.0, 0.0];
        let truth = [0.0, 10.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut d = Deconvolver::new(cfg(k, None), truth.len(), 1);
        let mut rng = rng_from_seed(8);
        let mut xs = Vec::new();
        for t in 0..20_000 {
            let x = rng.random_range(0..truth.len());
            xs.push(x);
            let r: f64 = (0..=k.min(t)).map(|j| p[j] * truth[xs[t - j]]).sum();
            d.observe(x, r);
        }
        for _ in 0..50 {
            d.refit();
        }
        for (j, &want) in p.iter().enumerate() {
            assert!((d.pmf()[j] - want).abs() < 1e-3, "p̂({j}) = {} vs {want}", d.pmf()[j]);
        }
        for (x, &want) in truth.iter().enumerate() {
            assert!((d.reward(x) - want).abs() < 1e-2, "R̂({x}) = {} vs {want}", d.reward(x));
        }
        assert!((pmf_median(d.pmf()) - (2.5 + 0.4 / 0.6)).abs() < 0.01);
    }

    /// ρ DᵀD for three lags and ρ = 2: the Hessian of ρ/2 [(p1 − p0)² + (p2 − p1)²].
    #[test]
    fn roughness_by_hand() {
        let mut m = vec![1.0; 9];
        add_roughness(&mut m, 3, 2.0);
        assert_eq!(m, vec![3.0, -1.0, 1.0, -1.0, 5.0, -1.0, 1.0, -1.0, 3.0]);
        let mut one = vec![0.0];
        add_roughness(&mut one, 1, 2.0);
        assert_eq!(one, vec![0.0]);
    }

    /// The groups of `successor_groups`: actions of a state that have only led to one
    /// and the same next state share a group; a pair seen leading to two next states
    /// leaves it; `state_rewards` groups whole states instead.
    #[test]
    fn successor_groups_follow_the_observed_transitions() {
        let grouped = |d: &Deconvolver| -> Vec<Vec<u32>> {
            let mut g: Vec<Vec<u32>> =
                d.groups().into_iter().map(|(_, m)| m.iter().map(|&i| d.pairs[i]).collect()).collect();
            g.iter_mut().for_each(|m| m.sort_unstable());
            g.sort();
            g
        };
        let mut c = cfg(3, None);
        c.successor_groups = true;
        // 3 states × 3 actions, pair id s·3 + a.
        let mut d = Deconvolver::new(c.clone(), 3, 3);
        d.observe_transition(0, 1, 0.0); // (0, 0) → 1
        d.observe_transition(1, 1, 0.0); // (0, 1) → 1
        d.observe_transition(2, 0, 0.0); // (0, 2) → 0
        d.observe_transition(3, 1, 0.0); // (1, 0) → 1: other state, same successor
        assert_eq!(grouped(&d), vec![vec![0, 1], vec![2], vec![3]]);
        d.observe_transition(1, 1, 0.0); // again the same: still grouped
        assert_eq!(grouped(&d), vec![vec![0, 1], vec![2], vec![3]]);
        d.observe_transition(0, 2, 0.0); // (0, 0) also led to 2: on its own now
        assert_eq!(grouped(&d), vec![vec![0], vec![1], vec![2], vec![3]]);
        // State features take precedence: every action of a state in one group.
        c.state_rewards = true;
        let mut d = Deconvolver::new(c, 3, 3);
        for (x, s2) in [(0, 1), (1, 1), (2, 0), (3, 1)] {
            d.observe_transition(x, s2, 0.0);
        }
        assert_eq!(grouped(&d), vec![vec![0, 1, 2], vec![3]]);
    }

    /// The aliasing of the paper's goal: +10 for either action in G (2), and G is only
    /// entered by (1, 0), so "(G, ·) rewarded at delay d" and "(1, 0) rewarded at delay
    /// d + 1" predict the same deliveries. Pair features alone prefer the entering move:
    /// one pair with all the visits clears the significance threshold (which grows as the
    /// square root of the visits) more cheaply than G's two pairs that share them, and the
    /// delay comes out one step late. With successor groups G's actions (both teleport to
    /// 0) share one feature, cheaper than a pair's own, and the fit credits G at the true
    /// delay. Delays uniform on {1, 2, 3}, rewards delivered as sampled.
    #[test]
    fn successor_groups_resolve_the_goal_aliasing() {
        let k = 6;
        // States 0 (start), 1, 2 (goal); actions 0 (forward), 1 (back to 0).
        let step = |s: usize, a: usize| match (s, a) {
            (2, _) => 0,
            (s, 0) => s + 1,
            _ => 0,
        };
        let fit = |groups: bool| {
            let mut c = cfg(k, None);
            c.successor_groups = groups;
            (c.lasso, c.significance, c.reward_prior, c.refit_every) = (0.1, 1.0, 1.0, 1000);
            let mut d = Deconvolver::new(c, 3, 2);
            let mut rng = rng_from_seed(11);
            let (mut s, mut pending) = (0, vec![0.0; 40_000 + 8]);
            for t in 0..40_000 {
                let a = usize::from(rng.random_bool(0.3));
                if s == 2 {
                    pending[t + rng.random_range(1..=3)] += 10.0;
                }
                let s2 = step(s, a);
                d.observe_transition(s * 2 + a, s2, pending[t]);
                s = s2;
            }
            d.refit();
            d
        };
        let mut d = fit(true);
        assert!((pmf_mean(d.pmf()) - 2.0).abs() < 0.1, "p̂ = {:?}", d.pmf());
        for a in 0..2 {
            assert!((d.reward(2 * 2 + a) - 10.0).abs() < 0.5, "R̂(G, {a}) = {}", d.reward(4 + a));
        }
        assert!(d.reward(2).abs() < 0.5, "R̂ of the entering move (1, 0) = {}", d.reward(2));
        // The penalised objective (D2) of the two explanations, R refitted for each pmf:
        // with the groups the true delay is the cheaper, without them the late one.
        let (truth, late) = (
            vec![0.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 0.0, 0.0, 0.0],
            vec![0.0, 0.0, 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0, 0.0, 0.0],
        );
        let objective = |d: &mut Deconvolver, p: &[f64]| {
            d.pmf = p.to_vec();
            let sigma = (d.rss.unwrap() / d.t as f64).sqrt();
            d.fit_rewards(sigma, false)
        };
        let (o_truth, o_late) = (objective(&mut d, &truth), objective(&mut d, &late));
        assert!(o_truth < o_late, "with groups: {o_truth} vs {o_late}");
        let mut d = fit(false);
        let (o_truth, o_late) = (objective(&mut d, &truth), objective(&mut d, &late));
        assert!(o_late < o_truth, "pair features only: {o_late} vs {o_truth}");
        assert!((d.reward(2) - 10.0).abs() < 0.5, "R̂ of the entering move (1, 0) = {}", d.reward(2));
    }

    /// The joint test's statistic on a 2 × 2 active set: G_S + ridge = [[4.1, 3.9],
    /// [3.9, 4.1]] has determinant 1.6 and inverse diagonal 4.1 / 1.6 = 2.5625, so a joint
    /// standard error of √2.5625 = 1.6008; uncorrelated, 1 / √4.1 = 0.4939.
    #[test]
    fn joint_failure_by_hand() {
        #[rustfmt::skip]
        let g = [
            4.0, 3.9, 0.0,
            3.9, 4.0, 0.0,
            0.0, 0.0, 9.0,
        ];
        let inv = joint_inverse(&g, 3, &[0, 1], 0.1).unwrap();
        assert!((inv[(0, 0)] - 2.5625).abs() < 1e-12 && (inv[(0, 1)] + 3.9 / 1.6).abs() < 1e-12);
        let rp = [1.5, -1.7, 0.0];
        // Scores 1.5 / 1.6008 = 0.937 and 1.7 / 1.6008 = 1.062: positions in `active`.
        assert_eq!(joint_failure(&inv, &[0, 1], &rp, 1.0), Some(0));
        assert_eq!(joint_failure(&inv, &[0, 1], &rp, 1.07), Some(0));
        assert_eq!(joint_failure(&inv, &[0, 1], &rp, 0.93), None);
        // Uncorrelated: scores 1.5 / 0.4939 = 3.037 and 1.7 / 0.4939 = 3.442.
        let diag = [4.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 9.0];
        let inv = joint_inverse(&diag, 3, &[1, 0], 0.1).unwrap();
        assert_eq!(joint_failure(&inv, &[1, 0], &rp, 3.0), None);
        // Both below 3.5: the one furthest below (pair 0, at position 1) goes first.
        assert_eq!(joint_failure(&inv, &[1, 0], &rp, 3.5), Some(1));
        // One active pair: the lasso's own test already was the joint one.
        assert_eq!(joint_failure(&inv, &[0], &rp, 100.0), None);
        // Not positive definite: no test.
        assert!(joint_inverse(&[1.0, 2.0, 2.0, 1.0], 2, &[0, 1], 0.0).is_none());
    }

    /// Dropping a pair from the inverse by the O(s²) update equals inverting again.
    #[test]
    fn drop_from_inverse_matches_a_fresh_inverse() {
        #[rustfmt::skip]
        let g = [
            5.0, 1.0, 0.5, 0.2,
            1.0, 4.0, 1.5, 0.0,
            0.5, 1.5, 6.0, 2.0,
            0.2, 0.0, 2.0, 3.0,
        ];
        let all = joint_inverse(&g, 4, &[0, 1, 2, 3], 0.3).unwrap();
        for pos in 0..4 {
            let rest: Vec<usize> = (0..4).filter(|&i| i != pos).collect();
            let fresh = joint_inverse(&g, 4, &rest, 0.3).unwrap();
            let updated = drop_from_inverse(&all, pos);
            assert!((fresh - updated).abs().max() < 1e-12, "pos {pos}");
        }
        // Bordering adds a pair back: {0, 1, 3} + 2 (last in the new order).
        let three = joint_inverse(&g, 4, &[0, 1, 3], 0.3).unwrap();
        let u = nalgebra::DVector::from_vec(vec![g[2], g[4 + 2], g[3 * 4 + 2]]);
        let grown = add_to_inverse(&three, &u, g[2 * 4 + 2] + 0.3).unwrap();
        let fresh = joint_inverse(&g, 4, &[0, 1, 3, 2], 0.3).unwrap();
        assert!((fresh - grown).abs().max() < 1e-12);
        // And update_inverse does both: from {0, 1, 2} to {1, 2, 3}.
        let start = joint_inverse(&g, 4, &[0, 1, 2], 0.3).unwrap();
        let (order, inv) = update_inverse(&g, 4, 0.3, vec![0, 1, 2], start, &[1, 2, 3], 4).unwrap();
        assert_eq!(order, vec![1, 2, 3]);
        assert!((joint_inverse(&g, 4, &order, 0.3).unwrap() - inv).abs().max() < 1e-12);
        assert!(
            update_inverse(&g, 4, 0.3, vec![0], joint_inverse(&g, 4, &[0], 0.3).unwrap(), &[1, 2, 3], 2)
                .is_none()
        );
    }

    /// Two pairs that always come together (1 then 2, as a step and its way back) and
    /// carry no reward, a third that pays 5 and is often followed by them; the learner is
    /// told a pmf broader than the true one (uniform on 0..=6 instead of always 3), so
    /// the fit is misspecified, as with an estimated pmf. The per-pair lasso test lets a
    /// small spurious reward through on one of the collinear two (R̂(2) ≈ 0.05: it
    /// reshapes the predicted reward mass in time); the joint test removes it and keeps
    /// the real reward. (In the maze the same mechanism gave +11.4 and −10.7 on a
    /// corridor step and its way back.)
    #[test]
    fn joint_test_drops_collinear_spurious_rewards() {
        let k = 6;
        let told = vec![1.0 / 7.0; 7];
        let truth = [0.0, 0.0, 0.0, 5.0, 0.0];
        let fit = |joint_test: f64| {
            let mut c = cfg(k, Some(told.clone()));
            (c.lasso, c.significance, c.reward_prior, c.joint_test) = (0.1, 1.0, 1.0, joint_test);
            let mut d = Deconvolver::new(c, truth.len(), 1);
            let mut rng = rng_from_seed(11);
            let mut xs: Vec<usize> = Vec::new();
            while xs.len() < 30_000 {
                match rng.random_range(0..4) {
                    0 => xs.extend([3, 1, 2]),
                    1 => xs.extend([1, 2]),
                    2 => xs.push(3),
                    _ => xs.push(if rng.random_bool(0.5) { 0 } else { 4 }),
                }
            }
            for t in 0..xs.len() {
                let mean = if t >= 3 { truth[xs[t - 3]] } else { 0.0 };
                let noise = 2.0 * (rng.random::<f64>() - 0.5);
                d.observe(xs[t], mean + noise);
            }
            d.refit();
            (0..truth.len()).map(|x| d.reward(x)).collect::<Vec<f64>>()
        };
        let (plain, joint) = (fit(0.0), fit(1.0));
        assert!(plain[2] > 0.0, "the per-pair test alone keeps a spurious reward: {plain:?}");
        assert_eq!((joint[1], joint[2]), (0.0, 0.0), "{joint:?}");
        assert!((joint[3] - 5.0).abs() < 0.5, "{joint:?}");
    }
}
