//! The pmf fit's quadratic programme: argmin over {p ≥ 0, Σ p ≤ 1} of a convex quadratic
//! by FISTA (accelerated projected gradient) with adaptive restart, run until the iterate
//! stops moving, its matrix-vector product and its projection, and the roughness
//! penalty's Hessian.

use super::{QP_ITERS, QP_TOL};

/// Projects `v` onto the probability simplex (Euclidean; Duchi et al. 2008). `order` is
/// scratch for the indices of `v` in decreasing order: kept from a previous call, it is
/// sorted again by insertion, which costs little when the order of the values has barely
/// changed, as between the iterations of a solver (any content of the wrong length is
/// replaced).
pub(crate) fn project_simplex(v: &mut [f64], order: &mut Vec<usize>) {
    if order.len() != v.len() {
        order.clear();
        order.extend(0..v.len());
    }
    for i in 1..order.len() {
        let x = order[i];
        let mut j = i;
        while j > 0 && v[order[j - 1]].total_cmp(&v[x]).is_lt() {
            order[j] = order[j - 1];
            j -= 1;
        }
        order[j] = x;
    }
    // Values equal under the total order are the same bits: any permutation that sorts
    // them gives the same sequence of values, so the same sums.
    let mut acc = 0.0;
    let mut theta = 0.0;
    for (i, &o) in order.iter().enumerate() {
        let x = v[o];
        acc += x;
        let t = (acc - 1.0) / (i + 1) as f64;
        if x - t > 0.0 {
            theta = t;
        }
    }
    v.iter_mut().for_each(|x| *x = (*x - theta).max(0.0));
}

/// Projects `v` onto {p ≥ 0, Σ p ≤ 1} (`order` as for [`project_simplex`]).
pub(crate) fn project_capped_simplex(v: &mut [f64], order: &mut Vec<usize>) {
    let pos: f64 = v.iter().map(|x| x.max(0.0)).sum();
    if pos <= 1.0 {
        v.iter_mut().for_each(|x| *x = x.max(0.0));
    } else {
        project_simplex(v, order);
    }
}

/// Adds ρ DᵀD to the `k_n`×`k_n` matrix `m`, D the first-difference operator: the
/// Hessian of ½ ρ Σ_k (p(k+1) − p(k))².
pub(crate) fn add_roughness(m: &mut [f64], k_n: usize, rho: f64) {
    for k in 0..k_n.saturating_sub(1) {
        m[k * k_n + k] += rho;
        m[(k + 1) * k_n + k + 1] += rho;
        m[k * k_n + k + 1] -= rho;
        m[(k + 1) * k_n + k] -= rho;
    }
}

/// A row-major square matrix laid out for [`Panels::mat_vec`]: its rows in groups of
/// eight, each group stored column by column (the eight entries of a column together),
/// the last group filled up with rows of zeros.
pub(crate) struct Panels {
    k_n: usize,
    octets: Vec<f64>,
}

impl Panels {
    /// The panels of the row-major `k_n`×`k_n` matrix `a`.
    pub(crate) fn new(a: &[f64], k_n: usize) -> Self {
        debug_assert_eq!(a.len(), k_n * k_n);
        let rows = k_n.div_ceil(8) * 8;
        let mut octets = Vec::with_capacity(rows * k_n);
        for q in (0..rows).step_by(8) {
            for j in 0..k_n {
                octets.extend((q..q + 8).map(|r| if r < k_n { a[r * k_n + j] } else { 0.0 }));
            }
        }
        Self { k_n, octets }
    }

    /// `out` = A v: each entry Σ_j a(i, j) v(j) summed in j order from −0, as
    /// `Iterator::sum` does (the same number bit for bit), eight rows at a time so that
    /// their sums overlap instead of waiting on one another.
    pub(crate) fn mat_vec(&self, v: &[f64], out: &mut [f64]) {
        let k_n = self.k_n;
        debug_assert!(v.len() == k_n && out.len() == k_n);
        for (q, panel) in self.octets.chunks_exact(8 * k_n).enumerate() {
            let mut s = [-0.0f64; 8];
            for (x, &vj) in panel.chunks_exact(8).zip(v) {
                for (si, &xi) in s.iter_mut().zip(x) {
                    *si += xi * vj;
                }
            }
            let rows = 8 * q..(8 * q + 8).min(k_n);
            let n = rows.len();
            out[rows].copy_from_slice(&s[..n]);
        }
    }
}

/// argmin over {p ≥ 0, Σ p ≤ 1} of ½ pᵀAp − cᵀp + ½ ν ‖p − uniform‖² + Σ_k λ_k p_k by
/// [`fista`] from `warm`, renormalised to sum to one (`None` when A carries no information).
pub(crate) fn solve_pmf(a: &[f64], c: &[f64], nu: f64, lam: &[f64], warm: &[f64]) -> Option<Vec<f64>> {
    let (p, _) = fista(a, c, nu, lam, warm)?;
    let total: f64 = p.iter().sum();
    (total > 0.0).then(|| p.iter().map(|x| x / total).collect())
}

/// The minimiser of [`solve_pmf`]'s objective over {p ≥ 0, Σ p ≤ 1}, not renormalised,
/// and the iterations it took: projected gradient steps of 1/L (L bounded by power
/// iteration on A, plus ν, with a 5 % margin) with Nesterov's momentum, restarted
/// whenever the step just taken and the last move point apart, (z − p⁺)ᵀ(p⁺ − p) > 0
/// (O'Donoghue and Candès's gradient restart, which keeps the momentum from overshooting
/// on a strongly convex objective), until an iteration moves no coordinate by more than
/// [`QP_TOL`], or [`QP_ITERS`] iterations. `None` when A carries no information.
fn fista(a: &[f64], c: &[f64], nu: f64, lam: &[f64], warm: &[f64]) -> Option<(Vec<f64>, usize)> {
    let k_n = c.len();
    let a = Panels::new(a, k_n);
    let mut v = vec![1.0; k_n];
    let mut lmax = 0.0;
    for _ in 0..30 {
        let mut w = vec![0.0; k_n];
        a.mat_vec(&v, &mut w);
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
    let mut az = vec![0.0; k_n];
    let mut order = Vec::with_capacity(k_n);
    for iteration in 1..=QP_ITERS {
        a.mat_vec(&z, &mut az);
        for i in 0..k_n {
            let grad: f64 = az[i] - c[i] + nu * (z[i] - uni) + lam[i];
            next[i] = z[i] - step * grad;
        }
        project_capped_simplex(&mut next, &mut order);
        let apart: f64 = (0..k_n).map(|i| (z[i] - next[i]) * (next[i] - p[i])).sum();
        if apart > 0.0 {
            theta = 1.0;
        }
        let theta2 = (1.0 + (1.0 + 4.0 * theta * theta).sqrt()) / 2.0;
        let mom = (theta - 1.0) / theta2;
        let mut moved = 0.0f64;
        for i in 0..k_n {
            z[i] = next[i] + mom * (next[i] - p[i]);
            moved = moved.max((next[i] - p[i]).abs());
        }
        p.copy_from_slice(&next);
        theta = theta2;
        if moved <= QP_TOL {
            return Some((p, iteration));
        }
    }
    Some((p, QP_ITERS))
}

#[cfg(test)]
mod tests {
    use super::*;
    use mmq_core::seed::rng_from_seed;
    use rand::RngExt;

    /// The projection onto the simplex by the order kept between calls equals the one by
    /// a full sort, bit for bit, whatever order is kept (none, the previous vector's, a
    /// stale one of another length), with ties and zeros among the values.
    #[test]
    fn simplex_projection_by_kept_order_equals_the_sorted_one() {
        let by_sort = |v: &[f64]| {
            let mut u = v.to_vec();
            u.sort_unstable_by(|a, b| b.total_cmp(a));
            let (mut acc, mut theta) = (0.0, 0.0);
            for (i, &x) in u.iter().enumerate() {
                acc += x;
                let t = (acc - 1.0) / (i + 1) as f64;
                if x - t > 0.0 {
                    theta = t;
                }
            }
            v.iter().map(|x| (x - theta).max(0.0)).collect::<Vec<f64>>()
        };
        let mut rng = rng_from_seed(5);
        let mut order = vec![0, 1, 2];
        let mut v: Vec<f64> = (0..51).map(|_| rng.random_range(-0.2..0.3)).collect();
        for round in 0..400 {
            if round % 50 == 0 {
                // A vector of a new length, with ties and exact zeros.
                let n = rng.random_range(1..60);
                v = (0..n).map(|_| rng.random_range(-2..5) as f64 * 0.125).collect();
            } else {
                // Nudged, as between iterations, or scrambled.
                let scale = if round % 7 == 0 { 0.5 } else { 0.001 };
                v.iter_mut().for_each(|x| *x += rng.random_range(-scale..scale));
            }
            let expect = by_sort(&v);
            let mut got = v.clone();
            project_simplex(&mut got, &mut order);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&expect), "round {round}");
            assert!(order.windows(2).all(|w| v[w[0]] >= v[w[1]]));
        }
    }

    /// The matrix-vector product eight rows at a time equals the row sums one by one,
    /// bit for bit, for sizes with and without a remainder of rows.
    #[test]
    fn mat_vec_equals_row_sums() {
        let mut rng = rng_from_seed(5);
        for k_n in [1, 3, 4, 7, 8, 9, 16, 51] {
            let a: Vec<f64> = (0..k_n * k_n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let v: Vec<f64> = (0..k_n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let mut out = vec![0.0; k_n];
            Panels::new(&a, k_n).mat_vec(&v, &mut out);
            for i in 0..k_n {
                let want: f64 = a[i * k_n..(i + 1) * k_n].iter().zip(&v).map(|(x, y)| x * y).sum();
                assert_eq!(out[i].to_bits(), want.to_bits(), "k_n {k_n}, row {i}");
            }
        }
    }

    /// Three problems solved by hand (A = 2I, ν = λ = 0, so ½ pᵀAp − cᵀp = Σ p² − cᵀp):
    /// c = (1, 0.2) has its minimum (c/2 = (0.5, 0.1)) inside Σ p ≤ 1, renormalised to
    /// (5/6, 1/6); c = (3, 1) presses on the cap, where p = (1, 0) (on p₀ + p₁ = 1 the
    /// objective is 2p₀² − 4p₀); c = (2, 1, −1) leaves p₂ at zero and splits the cap
    /// as 2p₀² − 3p₀ is least, p = (3/4, 1/4, 0). A penalty λ = (0, 0.4) on the first
    /// problem moves the minimum to c − λ over 2, (0.5, 0).
    #[test]
    fn solves_by_hand() {
        let two = |k: usize| {
            let mut a = vec![0.0; k * k];
            (0..k).for_each(|i| a[i * k + i] = 2.0);
            a
        };
        let close = |got: &[f64], want: &[f64]| {
            assert_eq!(got.len(), want.len());
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() < 1e-10, "{got:?} against {want:?}");
            }
        };
        let raw =
            |c: &[f64], lam: &[f64]| fista(&two(c.len()), c, 0.0, lam, &vec![1.0 / c.len() as f64; c.len()]);
        close(&raw(&[1.0, 0.2], &[0.0, 0.0]).unwrap().0, &[0.5, 0.1]);
        close(
            &solve_pmf(&two(2), &[1.0, 0.2], 0.0, &[0.0, 0.0], &[0.5, 0.5]).unwrap(),
            &[5.0 / 6.0, 1.0 / 6.0],
        );
        close(&raw(&[3.0, 1.0], &[0.0, 0.0]).unwrap().0, &[1.0, 0.0]);
        close(&raw(&[2.0, 1.0, -1.0], &[0.0; 3]).unwrap().0, &[0.75, 0.25, 0.0]);
        close(&raw(&[1.0, 0.2], &[0.0, 0.4]).unwrap().0, &[0.5, 0.0]);
        // No information in A: no solve.
        assert!(solve_pmf(&[0.0; 4], &[1.0, 0.0], 0.0, &[0.0; 2], &[0.5, 0.5]).is_none());
    }

    /// On random problems of the pmf fit's size (A = BᵀB + a roughness term, ν > 0) the
    /// solve stops well before its cap at a point that satisfies the optimality
    /// conditions: a projected gradient step from it moves no coordinate by more than
    /// 1e-9 (p is then the projection of itself minus the gradient, the fixed point that
    /// characterises the minimum over a convex set), from any warm start.
    #[test]
    fn stops_at_the_minimum() {
        let mut rng = rng_from_seed(11);
        for trial in 0..20 {
            let k_n = rng.random_range(3..52);
            let rows = k_n + 5;
            let b: Vec<f64> = (0..rows * k_n).map(|_| rng.random_range(-1.0..1.0)).collect();
            let mut a = vec![0.0; k_n * k_n];
            for i in 0..k_n {
                for j in 0..k_n {
                    a[i * k_n + j] = (0..rows).map(|r| b[r * k_n + i] * b[r * k_n + j]).sum();
                }
            }
            add_roughness(&mut a, k_n, 0.5);
            let c: Vec<f64> = (0..k_n).map(|_| rng.random_range(-2.0..4.0)).collect();
            let lam: Vec<f64> = (0..k_n).map(|_| rng.random_range(0.0..0.5)).collect();
            let nu = 0.01;
            let warm: Vec<f64> = if trial % 2 == 0 {
                vec![1.0 / k_n as f64; k_n]
            } else {
                let w: Vec<f64> = (0..k_n).map(|_| rng.random_range(0.0..1.0)).collect();
                let t: f64 = w.iter().sum();
                w.iter().map(|x| x / t).collect()
            };
            let (p, iterations) = fista(&a, &c, nu, &lam, &warm).unwrap();
            assert!(iterations < QP_ITERS, "trial {trial}: {iterations} iterations");
            assert!(p.iter().all(|&x| x >= 0.0) && p.iter().sum::<f64>() <= 1.0 + 1e-12);
            let uni = 1.0 / k_n as f64;
            let mut stepped: Vec<f64> = (0..k_n)
                .map(|i| {
                    let ap: f64 = (0..k_n).map(|j| a[i * k_n + j] * p[j]).sum();
                    p[i] - 0.01 * (ap - c[i] + nu * (p[i] - uni) + lam[i])
                })
                .collect();
            project_capped_simplex(&mut stepped, &mut Vec::new());
            let residual = stepped.iter().zip(&p).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(residual < 1e-9, "trial {trial} (K + 1 = {k_n}): residual {residual:e}");
        }
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
}
