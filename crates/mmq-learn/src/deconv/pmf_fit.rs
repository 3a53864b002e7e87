//! The fit of the delay pmf: p given R̂ (a quadratic programme over the simplex,
//! [`super::qp`], then reweighted passes on the stored history), the standard error of
//! its median, and their helpers ([`crate::pmf`] has the pmf's other summaries).

use super::Deconvolver;
use super::qp::{add_roughness, solve_pmf};
use super::stats::{LagStats, Trail};
use crate::pmf::{MedianSe, pmf_median};

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

/// Standard error of the median of `p`, in steps, from a quasi-likelihood system
/// ½ pᵀAp − cᵀp + ½ ν ‖p − uniform‖² whose A is weighted by inverse variances (so that
/// (A + νI)⁻¹ is the covariance of its solution): the cumulative probability F at the
/// median m̂, F = eᵀp (e: 1 below m̂'s bin, the fraction of that bin below m̂), has variance
/// eᵀCe with C = M⁻¹ − M⁻¹11ᵀM⁻¹ / 1ᵀM⁻¹1 (M = A + νI, C under Σp = 1), and an error δF
/// moves the median by δF / f, f the mean of p over the five bins around m̂ (delta method;
/// infinite when p has no mass there, as in a gap between two lobes). `None` when M is
/// not positive definite.
pub(crate) fn median_se(a: &[f64], nu: f64, p: &[f64]) -> Option<MedianSe> {
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

impl Deconvolver {
    /// The least-squares system of p given R̂, ½ pᵀAp − cᵀp: (A, c, R̂ by compact pair,
    /// max |R̂|); None when R̂ is zero.
    #[allow(clippy::type_complexity)]
    fn pmf_system(&self, counts: &LagStats) -> Option<(Vec<f64>, Vec<f64>, Vec<f64>, f64)> {
        let st = &self.stats;
        let n = st.n();
        let k_n = self.cfg.settings.max_delay + 1;
        let r: Vec<f64> = st.pairs.iter().map(|&x| self.r[x as usize]).collect();
        if r.iter().all(|&v| v == 0.0) {
            return None;
        }
        // q_j = Rᵀ C_j R over the support of R;  c_k = Σ_i R_i B_k(i).
        let support: Vec<usize> = (0..n).filter(|&i| r[i] != 0.0).collect();
        let q = counts.lag_products(&support, &r);
        let cvec = st.lagged_reward_sums(&r, &support);
        // A_{kk'} = Σ_t y_{t−k} y_{t−k'} = q_{|k−k'|} − E(|k−k'|, min(k, k')), where
        // E(j, m) = Σ_{u=T−m}^{T−1} y_{u−j} y_u removes the windows that end after now,
        // summed over the trajectories (each with its own T and run start).
        let mut e = vec![0.0; k_n * k_n];
        for (n_tr, tr) in st.trails().iter().enumerate() {
            let (big_t, start) = (tr.t, tr.start);
            let y_at = |u: u64| r[tr.past(u)];
            for j in 0..k_n {
                let mut acc = 0.0;
                for m in 1..k_n {
                    if big_t >= start + m as u64 + j as u64 {
                        let u = big_t - m as u64;
                        acc += y_at(u - j as u64) * y_at(u);
                    }
                    // The first trajectory's sums are written, not added, so that one
                    // trajectory gives the very bits it always did.
                    if n_tr == 0 { e[j * k_n + m] = acc } else { e[j * k_n + m] += acc }
                }
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
    /// on the sum of their systems ½ pᵀAp − cᵀp, then `passes` reweighted passes (with
    /// `pmf_weighted`; none: plain least squares). Returns false when there was nothing to
    /// fit (R̂ zero) or the solve failed: p̂ and its median's standard error are then left
    /// as they were.
    pub(super) fn fit_pmf_all(ds: &mut [Deconvolver], passes: usize) -> bool {
        ds[0].merge_counts();
        let k_n = ds[0].cfg.settings.max_delay + 1;
        let cfg = ds[0].cfg.clone();
        let mut systems: Vec<(usize, Vec<f64>, f64)> = Vec::new();
        let mut total: Option<System> = None;
        let mut rmax = 0.0f64;
        for (di, d) in ds.iter().enumerate() {
            let Some((amat, cvec, r, rm)) = d.pmf_system(&ds[0].stats) else { continue };
            rmax = rmax.max(rm);
            total = add_system(total, (amat, cvec));
            systems.push((di, r, rm));
        }
        let Some((mut amat, cvec)) = total else { return false };
        let nu = cfg.settings.pmf_prior * rmax * rmax;
        let rho = cfg.settings.pmf_smoothness * rmax * rmax;
        let trace_u: f64 = (0..k_n).map(|i| amat[i * k_n + i]).sum();
        if rho > 0.0 {
            add_roughness(&mut amat, k_n, rho);
        }
        let Some(mut p) = solve_pmf(&amat, &cvec, nu, &vec![0.0; k_n], &ds[0].pmf) else { return false };
        let mut last = None;
        if cfg.settings.pmf_weighted && passes > 0 {
            // Reweighted passes (quasi-likelihood): each step weighted by the inverse of
            // the variance its delivery would have under p, Σ_k (p(k)(1 − p(k)) + δ) y²_{t−k}.
            // R̂ does not change between the passes: its predictions are found once.
            // One set of predictions per deconvolver and trajectory.
            let preds: Vec<(&Trail, Predictions, f64)> = systems
                .iter()
                .flat_map(|(di, r, rm)| {
                    ds[*di].stats.trails().iter().map(move |tr| (tr, Predictions::of(tr, r, k_n), *rm))
                })
                .collect();
            for _ in 0..passes {
                let sum = preds
                    .iter()
                    .fold(None, |sum, (tr, pred, rm)| add_system(sum, weighted_stats(tr, pred, &p, *rm)));
                let Some((mut aw, cw)) = sum else { break };
                let trace_w: f64 = (0..k_n).map(|i| aw[i * k_n + i]).sum();
                if trace_w <= 0.0 {
                    break;
                }
                let nu_w = nu * trace_w / trace_u.max(f64::MIN_POSITIVE);
                if rho > 0.0 {
                    add_roughness(&mut aw, k_n, rho * trace_w / trace_u.max(f64::MIN_POSITIVE));
                }
                let lam: Vec<f64> = (0..k_n)
                    .map(|i| cfg.settings.pmf_significance * aw[i * k_n + i].max(0.0).sqrt())
                    .collect();
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
        true
    }
}

/// Σ_t w_t ỹ_t ỹ_tᵀ and Σ_t w_t r_t ỹ_t over a trajectory's stored history (`tr`),
/// ỹ_t(k) = y_{t−k}, w_t = 1 / (Σ_k (p(k)(1 − p(k)) + δ) y²_{t−k} + v₀), from the non-zero predictions
/// `pred`: a step whose last K + 1 predictions are all zero adds nothing and is skipped.
///
/// The sums are walked along diagonals: two predictions y_u, y_{u'} (u ≤ u' ≤ u + K)
/// meet in the windows t = u'..=u + K, where they add w_t y_u y_{u'} to
/// A(t − u, t − u'), an entry of the lower triangle one row and one column further on
/// at each t. Taking the pairs in the order of u, each entry receives its terms in the
/// order of t, so the lower triangle is bit for bit that of a pass over every step;
/// the upper triangle is its mirror, so A is exactly symmetric.
fn weighted_stats(tr: &Trail, pred: &Predictions, p: &[f64], rmax: f64) -> (Vec<f64>, Vec<f64>) {
    let k_n = p.len();
    let (var, v0) = delivery_variance(p, rmax);
    let (steps, ys) = (&pred.steps, &pred.y);
    // The weight w_t of each window, in window order.
    let w: Vec<f64> = pred
        .windows
        .iter()
        .map(|&(t, lo, hi)| {
            let (lo, hi) = (lo as usize, hi as usize);
            let v = steps[lo..hi]
                .iter()
                .zip(&ys[lo..hi])
                .fold(v0, |v, (&u, &yu)| v + var[(t - u) as usize] * yu * yu);
            1.0 / v
        })
        .collect();
    // The lower triangle by diagonals: `diags[k1 * k_n + s]` = A(k1 + s, s), so that
    // the terms of one pair of predictions fall on contiguous entries.
    let mut diags = vec![0.0; k_n * k_n];
    let mut c = vec![0.0; k_n];
    let mut wy1 = vec![0.0; k_n];
    let len = tr.hist_r.len();
    // The windows from t = u on are consecutive for K + 1 steps (u is in each of
    // them), so window first[j] + s is step steps[j] + s.
    let first = &pred.first;
    for (j1, (&u1, &y1)) in steps.iter().zip(ys).enumerate() {
        let u1 = u1 as usize;
        let span = (u1 + k_n).min(len) - u1; // The windows holding u1.
        let w1 = &w[first[j1]..first[j1] + span];
        // c: the deliveries r_t of the windows holding u1, at lags 0..span. The terms
        // of rt = 0 are ±0 (w and y finite) and c never holds −0, so adding them
        // changes nothing: they are added rather than branched around.
        for ((ck, &wt), &rt) in c.iter_mut().zip(w1).zip(&tr.hist_r[u1..u1 + span]) {
            *ck += wt * rt * y1;
        }
        // w_t y1 of each window holding u1 (a term w_t y1 y2 is (w_t y1) y2).
        let wy1 = &mut wy1[..span];
        wy1.iter_mut().zip(w1).for_each(|(x, &wt)| *x = wt * y1);
        // A's lower triangle: u1 against itself and every later prediction u2 within
        // K steps, in the windows t = u2..u1 + K (lags t − u1 ≥ t − u2).
        for (&u2, &y2) in steps[j1..].iter().zip(&ys[j1..]) {
            let u2 = u2 as usize;
            if u2 >= u1 + span {
                break;
            }
            let k1 = u2 - u1;
            let diag = &mut diags[k1 * k_n..k1 * k_n + span - k1];
            for (x, &wy) in diag.iter_mut().zip(&wy1[k1..]) {
                *x += wy * y2;
            }
        }
    }
    // A from its diagonals; the upper triangle is the lower one's mirror (the same sums).
    let mut a = vec![0.0; k_n * k_n];
    for k1 in 0..k_n {
        for s in 0..k_n - k1 {
            let x = diags[k1 * k_n + s];
            a[(k1 + s) * k_n + s] = x;
            a[s * k_n + k1 + s] = x;
        }
    }
    (a, c)
}

/// The variance model of a delivery under p (K + 1 = p.len() lags): its factor
/// p(k)(1 − p(k)) + δ for each lag, δ = 1/(4(K + 1)), and the floor v₀ = 0.01 r²_max, so
/// that a delivery of predictions y has the variance Σ_k factor(k) y²_{t−k} + v₀.
fn delivery_variance(p: &[f64], rmax: f64) -> (Vec<f64>, f64) {
    let delta = 0.25 / p.len() as f64;
    (p.iter().map(|&pk| pk * (1.0 - pk) + delta).collect(), 0.01 * rmax * rmax)
}

/// The steps of the stored history whose prediction y_t = R̂(x_t) is not zero, in step
/// order, and those predictions.
#[derive(Debug, Default)]
struct Predictions {
    steps: Vec<u32>,
    y: Vec<f64>,
    /// Each step t whose last K + 1 hold a prediction, in order, with those predictions'
    /// range lo..hi in `steps` and `y`: (t, lo, hi).
    windows: Vec<(u32, u32, u32)>,
    /// The index in `windows` of each prediction's own step (every prediction's step is a
    /// window, as it holds that prediction).
    first: Vec<usize>,
}

impl Predictions {
    /// The non-zero predictions y_t = R̂(x_t) over a trajectory's stored history, and the
    /// steps whose last K + 1 (`k_n` = K + 1) hold one.
    fn of(tr: &Trail, r: &[f64], k_n: usize) -> Self {
        let mut pred = Predictions::default();
        for (t, &i) in tr.hist_x.iter().enumerate() {
            let y = r[i as usize];
            if y != 0.0 {
                pred.steps.push(t as u32);
                pred.y.push(y);
            }
        }
        // The predictions of the last K + 1 steps of t are steps[lo..hi] (oldest first).
        let steps = &pred.steps;
        let (mut lo, mut hi, mut t) = (0, 0, 0);
        while t < tr.hist_r.len() {
            while hi < steps.len() && steps[hi] as usize <= t {
                // Steps come in order and none is skipped, so this one is t: its window
                // is the one pushed below.
                pred.first.push(pred.windows.len());
                hi += 1;
            }
            while lo < hi && steps[lo] as usize + k_n <= t {
                lo += 1;
            }
            if lo == hi {
                match steps.get(hi) {
                    Some(&u) => {
                        t = u as usize;
                        continue;
                    }
                    None => break,
                }
            }
            pred.windows.push((t as u32, lo as u32, hi as u32));
            t += 1;
        }
        pred
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deconv::tests::{cfg, feed_expected};
    use mmq_core::seed::rng_from_seed;
    use rand::RngExt;

    /// A noisy trace of one reward source: at each of `steps` steps pair 1 is taken with
    /// probability 0.2 (pair 0 otherwise), and each take delivers 1 after a delay drawn
    /// uniformly from `delays` (seeded by `seed`); with `refit_every`, a refit after every
    /// that many steps.
    fn feed_noisy(
        d: &mut Deconvolver,
        steps: usize,
        delays: std::ops::RangeInclusive<usize>,
        seed: u64,
        refit_every: Option<usize>,
    ) {
        let mut rng = rng_from_seed(seed);
        let mut due = vec![0.0; steps + delays.end() + 1];
        for t in 0..steps {
            let slot = rng.random_bool(0.2);
            if slot {
                due[t + rng.random_range(delays.clone())] += 1.0;
            }
            d.observe(usize::from(slot), due[t]);
            if refit_every.is_some_and(|n| (t + 1) % n == 0) {
                d.refit();
            }
        }
    }

    impl Deconvolver {
        /// [`Deconvolver::weighted_stats`] by a pass over every step with a window of the
        /// non-zero predictions among the last K + 1.
        fn weighted_stats_reference(&self, r: &[f64], p: &[f64], rmax: f64) -> (Vec<f64>, Vec<f64>) {
            let k_n = self.cfg.settings.max_delay + 1;
            let (var, v0) = delivery_variance(p, rmax);
            let mut a = vec![0.0; k_n * k_n];
            let mut c = vec![0.0; k_n];
            // The steps of the last K + 1 with y ≠ 0, oldest first: (step, y).
            let mut window: std::collections::VecDeque<(usize, f64)> = std::collections::VecDeque::new();
            let mut live: Vec<(usize, f64)> = Vec::with_capacity(k_n);
            let tr = self.stats.trail();
            for (t, (&i, &rt)) in tr.hist_x.iter().zip(tr.hist_r.iter()).enumerate() {
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
                    v += var[k] * yu * yu;
                    live.push((k, yu));
                }
                let w = 1.0 / v;
                // c never holds −0, so adding the zeros of rt = 0 would change nothing.
                if rt != 0.0 {
                    let wr = w * rt;
                    for &(k1, y1) in &live {
                        c[k1] += wr * y1;
                    }
                }
                for &(k1, y1) in &live {
                    let wy = w * y1;
                    let row = &mut a[k1 * k_n..(k1 + 1) * k_n];
                    for &(k2, y2) in &live {
                        row[k2] += wy * y2;
                    }
                }
            }
            (a, c)
        }
    }

    /// The reweighted pass from the non-zero predictions equals the pass over every step
    /// (c and A's lower triangle bit for bit, the upper triangle to rounding, as the
    /// mirror of the lower): a random history over five pairs (two with R̂ = 0, so that
    /// some windows are empty and long gaps are skipped), rewards of either sign and
    /// zeros, two pmfs.
    #[test]
    fn weighted_stats_equal_the_pass_over_every_step_and_are_symmetric() {
        let k = 7;
        let mut c = cfg(k, None);
        c.settings.pmf_weighted = true;
        let mut d = Deconvolver::new(c, 5, 1);
        let mut rng = rng_from_seed(31);
        for t in 0..5000 {
            // Rare non-zero pairs, in bursts and with long gaps.
            let x = if (t / 400) % 3 == 2 { rng.random_range(0..2) } else { rng.random_range(0..5) };
            let r = if rng.random_bool(0.3) { rng.random_range(-2.0..3.0) } else { 0.0 };
            d.record(x, r);
        }
        let r_by_id = [0.0, 0.0, 1.5, -0.75, 10.0];
        let r: Vec<f64> = d.stats.pairs.iter().map(|&x| r_by_id[x as usize]).collect();
        let tr = d.stats.trail();
        let pred = Predictions::of(tr, &r, k + 1);
        assert!(pred.steps.len() > 100 && pred.steps.len() < 5000);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for p in [vec![1.0 / 8.0; 8], vec![0.0, 0.1, 0.5, 0.2, 0.0, 0.1, 0.1, 0.0]] {
            let (a, c) = weighted_stats(tr, &pred, &p, 10.0);
            let (a_ref, c_ref) = d.weighted_stats_reference(&r, &p, 10.0);
            assert_eq!(bits(&c), bits(&c_ref));
            let n = k + 1;
            for i in 0..n {
                for j in 0..n {
                    let (x, reference) = (a[i * n + j], a_ref[i * n + j]);
                    if i >= j {
                        // The lower triangle, bit for bit.
                        assert_eq!(x.to_bits(), reference.to_bits(), "({i}, {j})");
                    } else {
                        // The upper triangle: the mirror, which the pass over every step
                        // sums as w y_{t−j} y_{t−i} instead of w y_{t−i} y_{t−j}.
                        assert_eq!(x.to_bits(), a[j * n + i].to_bits());
                        assert!(
                            (x - reference).abs() <= 1e-12 * reference.abs(),
                            "({i}, {j}): {x} {reference}"
                        );
                    }
                }
            }
            assert!(a.iter().any(|&x| x != 0.0) && c.iter().any(|&x| x != 0.0));
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
            c.settings.pmf_weighted = true;
            c.settings.refit_every = 1000;
            let mut d = Deconvolver::new(c, 2, 1);
            feed_noisy(&mut d, 4000, 0..=8, 100 + seed, None);
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

    /// Noise-free expected rewards, delay pmf unknown: alternating refits from the
    /// uniform pmf find both the pmf and the rewards.
    #[test]
    fn recovers_the_delay_pmf() {
        let k = 8;
        let p = vec![0.0, 0.0, 0.1, 0.6, 0.3, 0.0, 0.0, 0.0, 0.0];
        let truth = [0.0, 10.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut d = Deconvolver::new(cfg(k, None), truth.len(), 1);
        feed_expected(&mut d, &p, &truth, 20_000, 8);
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

    /// More rounds per refit (`pmf_rounds`) carry one refit further along the alternation:
    /// on the noise-free trace of `recovers_the_delay_pmf`, one refit with one round
    /// leaves p̂ short of p (an L1 error of about 0.007), one with twelve rounds reaches it
    /// (error below 10⁻⁵, the median exact to 10⁻³).
    #[test]
    fn more_rounds_converge_within_one_refit() {
        let k = 8;
        let p = vec![0.0, 0.0, 0.1, 0.6, 0.3, 0.0, 0.0, 0.0, 0.0];
        let truth = [0.0, 10.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let fit = |rounds: u32| {
            let mut c = cfg(k, None);
            c.settings.pmf_rounds = rounds;
            let mut d = Deconvolver::new(c, truth.len(), 1);
            feed_expected(&mut d, &p, &truth, 20_000, 8);
            d.refit();
            let err: f64 = d.pmf().iter().zip(&p).map(|(a, b)| (a - b).abs()).sum();
            (err, pmf_median(d.pmf()))
        };
        let (one, m1) = fit(1);
        let (many, m12) = fit(12);
        let want = 2.5 + 0.4 / 0.6;
        assert!(one > 1e-3 && many < 1e-5, "L1 error: one round {one} (median {m1}), twelve {many}");
        assert!((m12 - want).abs() < 1e-3, "median {m12} after twelve rounds, want {want}");
    }

    /// `pmf_weighted_rounds`: `every` runs the reweighted passes in every round of a
    /// refit, `last` in its last one only (in both starts when there is one round).
    #[test]
    fn weighted_passes_by_round() {
        use crate::deconv::WeightedRounds;
        use crate::deconv::{WEIGHTED_PASSES, weighted_passes};
        for (rule, rounds, want) in [
            (WeightedRounds::Every, 1, vec![WEIGHTED_PASSES]),
            (WeightedRounds::Every, 3, vec![WEIGHTED_PASSES; 3]),
            (WeightedRounds::Last, 1, vec![WEIGHTED_PASSES]),
            (WeightedRounds::Last, 3, vec![0, 0, WEIGHTED_PASSES]),
        ] {
            let got: Vec<usize> = (1..=rounds).map(|round| weighted_passes(rule, rounds, round)).collect();
            assert_eq!(got, want, "{rule:?}, {rounds} rounds");
        }
    }

    /// The rule reaches the refit: on a noisy trace (one reward source, uniform delay on
    /// 0..=8), `last` equals `every` bit for bit with one round, and with four rounds it
    /// fits another p̂ (plain least squares before the last round), still reweighted at
    /// the end (a median standard error) and as close to the truth (median 4).
    #[test]
    fn weighted_rounds_reach_the_refit() {
        use crate::deconv::WeightedRounds;
        let fit = |rule: WeightedRounds, rounds: u32| {
            let mut c = cfg(12, None);
            (c.settings.pmf_weighted, c.settings.pmf_weighted_rounds, c.settings.pmf_rounds) =
                (true, rule, rounds);
            let mut d = Deconvolver::new(c, 2, 1);
            feed_noisy(&mut d, 4000, 0..=8, 8, None);
            d.refit();
            (d.pmf().to_vec(), d.median_se())
        };
        let bits = |p: &[f64]| p.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let (every1, se1) = fit(WeightedRounds::Every, 1);
        let (last1, se1_last) = fit(WeightedRounds::Last, 1);
        assert_eq!(bits(&every1), bits(&last1));
        assert_eq!(se1, se1_last);
        let (every4, se4) = fit(WeightedRounds::Every, 4);
        let (last4, se4_last) = fit(WeightedRounds::Last, 4);
        assert_ne!(bits(&every4), bits(&last4));
        assert!(se4.is_some() && se4_last.is_some());
        for p in [&every4, &last4] {
            assert!((pmf_median(p) - 4.0).abs() < 0.5, "median {}", pmf_median(p));
        }
    }

    /// The settle rule of `pmf_tolerance`, by hand: from (½, ¼, ¼) to (½, ⅜, ⅛) every
    /// p̂(k) moved by at most ⅛, so a tolerance of ⅛ calls it settled and 0.1 does not.
    #[test]
    fn settled_by_hand() {
        use crate::deconv::settled;
        let (from, to) = ([0.5, 0.25, 0.25], [0.5, 0.375, 0.125]);
        assert!(settled(&from, &to, 0.125));
        assert!(!settled(&from, &to, 0.1));
        assert!(settled(&to, &to, 0.0));
    }

    /// `pmf_tolerance` stops a refit's rounds once p̂ settles, on the noise-free trace of
    /// `more_rounds_converge_within_one_refit`: a tolerance no round can meet runs all
    /// twelve rounds, bit for bit as with none; one every round meets stops after the
    /// first, bit for bit as one round; 10⁻³ stops in between, closer to p than one round.
    #[test]
    fn rounds_stop_once_the_pmf_settles() {
        let k = 8;
        let p = vec![0.0, 0.0, 0.1, 0.6, 0.3, 0.0, 0.0, 0.0, 0.0];
        let truth = [0.0, 10.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let fit = |rounds: u32, tolerance: f64| {
            let mut c = cfg(k, None);
            (c.settings.pmf_rounds, c.settings.pmf_tolerance) = (rounds, tolerance);
            let mut d = Deconvolver::new(c, truth.len(), 1);
            feed_expected(&mut d, &p, &truth, 20_000, 8);
            d.refit();
            let bits: Vec<u64> = d.pmf().iter().map(|x| x.to_bits()).collect();
            let err: f64 = d.pmf().iter().zip(&p).map(|(a, b)| (a - b).abs()).sum();
            (bits, err, d.rounds())
        };
        let (all, _, n_all) = fit(12, 0.0);
        assert_eq!(n_all, 12);
        let (tiny, _, n_tiny) = fit(12, 1e-300);
        assert_eq!((tiny, n_tiny), (all, 12));
        let (one, err_one, n_one) = fit(1, 0.0);
        assert_eq!(n_one, 1);
        let (first, _, n_first) = fit(12, 1.0);
        assert_eq!((first, n_first), (one, 1));
        let (_, err_mid, n_mid) = fit(12, 1e-3);
        assert!(1 < n_mid && n_mid < 12, "{n_mid} rounds at 1e-3");
        assert!(err_mid < err_one, "L1 error {err_mid} after {n_mid} rounds, {err_one} after one");
    }

    /// `cold_start_backoff` n = 2, by hand: losses 1 and 2 in a row, then 2^0 = 1 refit
    /// skips the cold start; a third loss, 2 skip; a fourth, 4; a win starts again; n = 0
    /// never skips.
    #[test]
    fn cold_start_backoff_by_hand() {
        let with = |n: u32| {
            let mut c = cfg(4, None);
            c.settings.cold_start_backoff = n;
            Deconvolver::new(c, 2, 1)
        };
        let mut d = with(2);
        let mut skips = Vec::new();
        for won in [false, false, false, false, true, false] {
            d.cold_start_ended(won);
            skips.push((d.cold_losses, d.cold_skip));
            d.cold_skip = 0;
        }
        assert_eq!(skips, [(1, 0), (2, 1), (3, 2), (4, 4), (0, 0), (1, 0)]);
        assert_eq!((d.cold_starts, d.cold_wins), (6, 1));
        let mut off = with(0);
        (0..10).for_each(|_| off.cold_start_ended(false));
        assert_eq!((off.cold_losses, off.cold_skip), (10, 0));
    }

    /// The backoff reaches the refits: on a noisy trace refitted every 500 steps, n = 1
    /// tries the cold start at fewer refits than n = 0 (which tries it at every one), and
    /// it lost some of those it tried (only a loss makes a refit skip it).
    #[test]
    fn cold_start_backoff_skips_refits() {
        let run = |n: u32| {
            let mut c = cfg(12, None);
            (c.settings.pmf_weighted, c.settings.cold_start_backoff) = (true, n);
            let mut d = Deconvolver::new(c, 2, 1);
            feed_noisy(&mut d, 12_000, 2..=6, 3, Some(500));
            (d.refits(), d.cold_starts(), d.cold_wins)
        };
        let (refits, every, _) = run(0);
        assert_eq!((refits, every), (24, 24));
        let (_, tried, won) = run(1);
        assert!(tried < refits && won < tried, "cold starts {tried} (won {won}) of {refits} refits");
    }
}
