//! The joint test's linear algebra: the inverse of the Gram matrix's restriction to the
//! active pairs, kept up to date as pairs come and go.

use nalgebra::{DMatrix, DVector};

use super::gram::Gram;

/// (G_S + ridge·I)⁻¹ for the pairs `active` of `g` (None when it is not positive
/// definite): the joint covariance of their estimates, in units of σ̂².
pub(crate) fn joint_inverse(g: &Gram, active: &[usize], ridge: f64) -> Option<DMatrix<f64>> {
    let s_n = active.len();
    let gs =
        DMatrix::from_fn(s_n, s_n, |a, b| g.get(active[a], active[b]) + if a == b { ridge } else { 0.0 });
    Some(gs.cholesky()?.inverse())
}

/// The inverse of a symmetric positive definite M without its row and column `pos`,
/// from `inv` = M⁻¹: with M⁻¹ = [[A, b], [bᵀ, c]] (pos last), it is A − b bᵀ / c.
pub(crate) fn drop_from_inverse(inv: &DMatrix<f64>, pos: usize) -> DMatrix<f64> {
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
pub(crate) fn add_to_inverse(inv: &DMatrix<f64>, u: &DVector<f64>, d: f64) -> Option<DMatrix<f64>> {
    let s_n = inv.nrows();
    let w = inv * u;
    let sigma = d - u.dot(&w);
    // NaN fails too.
    if sigma.is_nan() || sigma <= 1e-9 * d.abs().max(1e-300) {
        return None;
    }
    let mut out = DMatrix::zeros(s_n + 1, s_n + 1);
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
pub(crate) fn update_inverse(
    g: &Gram,
    ridge: f64,
    mut order: Vec<usize>,
    mut inv: DMatrix<f64>,
    now: &[usize],
    max_changes: usize,
) -> Option<(Vec<usize>, DMatrix<f64>)> {
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
        let u = DVector::from_iterator(order.len(), order.iter().map(|&y| g.get(y, x)));
        inv = add_to_inverse(&inv, &u, g.get(x, x) + ridge)?;
        order.push(x);
    }
    Some((order, inv))
}

/// The joint test of the deconvolution's reward fit: of the pairs `active` (their
/// joint inverse `inv` from [`joint_inverse`]) whose estimate `rp[i]` lies less than
/// `thr` joint standard errors from zero, |`rp[i]`| < thr √inv_ii (`thr` includes σ̂),
/// the position in `active` of the one furthest below (the smallest |`rp[i]`| / √inv_ii).
/// None when every pair passes or fewer than two are active.
pub(crate) fn joint_failure(inv: &DMatrix<f64>, active: &[usize], rp: &[f64], thr: f64) -> Option<usize> {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The joint test's statistic on a 2 × 2 active set: G_S + ridge = [[4.1, 3.9],
    /// [3.9, 4.1]] has determinant 1.6 and inverse diagonal 4.1 / 1.6 = 2.5625, so a joint
    /// standard error of √2.5625 = 1.6008; uncorrelated, 1 / √4.1 = 0.4939.
    #[test]
    fn joint_failure_by_hand() {
        #[rustfmt::skip]
        let g = Gram::from_dense(3, vec![
            4.0, 3.9, 0.0,
            3.9, 4.0, 0.0,
            0.0, 0.0, 9.0,
        ]);
        let inv = joint_inverse(&g, &[0, 1], 0.1).unwrap();
        assert!((inv[(0, 0)] - 2.5625).abs() < 1e-12 && (inv[(0, 1)] + 3.9 / 1.6).abs() < 1e-12);
        let rp = [1.5, -1.7, 0.0];
        // Scores 1.5 / 1.6008 = 0.937 and 1.7 / 1.6008 = 1.062: positions in `active`.
        assert_eq!(joint_failure(&inv, &[0, 1], &rp, 1.0), Some(0));
        assert_eq!(joint_failure(&inv, &[0, 1], &rp, 1.07), Some(0));
        assert_eq!(joint_failure(&inv, &[0, 1], &rp, 0.93), None);
        // Uncorrelated: scores 1.5 / 0.4939 = 3.037 and 1.7 / 0.4939 = 3.442.
        let diag = Gram::from_dense(3, vec![4.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 9.0]);
        let inv = joint_inverse(&diag, &[1, 0], 0.1).unwrap();
        assert_eq!(joint_failure(&inv, &[1, 0], &rp, 3.0), None);
        // Both below 3.5: the one furthest below (pair 0, at position 1) goes first.
        assert_eq!(joint_failure(&inv, &[1, 0], &rp, 3.5), Some(1));
        // One active pair: the lasso's own test already was the joint one.
        assert_eq!(joint_failure(&inv, &[0], &rp, 100.0), None);
        // Not positive definite: no test.
        assert!(joint_inverse(&Gram::from_dense(2, vec![1.0, 2.0, 2.0, 1.0]), &[0, 1], 0.0).is_none());
    }

    /// Dropping a pair from the inverse by the O(s²) update equals inverting again.
    #[test]
    fn drop_from_inverse_matches_a_fresh_inverse() {
        #[rustfmt::skip]
        let raw = vec![
            5.0, 1.0, 0.5, 0.2,
            1.0, 4.0, 1.5, 0.0,
            0.5, 1.5, 6.0, 2.0,
            0.2, 0.0, 2.0, 3.0,
        ];
        let g = Gram::from_dense(4, raw.clone());
        let all = joint_inverse(&g, &[0, 1, 2, 3], 0.3).unwrap();
        for pos in 0..4 {
            let rest: Vec<usize> = (0..4).filter(|&i| i != pos).collect();
            let fresh = joint_inverse(&g, &rest, 0.3).unwrap();
            let updated = drop_from_inverse(&all, pos);
            assert!((fresh - updated).abs().max() < 1e-12, "pos {pos}");
        }
        // Bordering adds a pair back: {0, 1, 3} + 2 (last in the new order).
        let three = joint_inverse(&g, &[0, 1, 3], 0.3).unwrap();
        let u = DVector::from_vec(vec![raw[2], raw[4 + 2], raw[3 * 4 + 2]]);
        let grown = add_to_inverse(&three, &u, raw[2 * 4 + 2] + 0.3).unwrap();
        let fresh = joint_inverse(&g, &[0, 1, 3, 2], 0.3).unwrap();
        assert!((fresh - grown).abs().max() < 1e-12);
        // And update_inverse does both: from {0, 1, 2} to {1, 2, 3}.
        let start = joint_inverse(&g, &[0, 1, 2], 0.3).unwrap();
        let (order, inv) = update_inverse(&g, 0.3, vec![0, 1, 2], start, &[1, 2, 3], 4).unwrap();
        assert_eq!(order, vec![1, 2, 3]);
        assert!((joint_inverse(&g, &order, 0.3).unwrap() - inv).abs().max() < 1e-12);
        assert!(
            update_inverse(&g, 0.3, vec![0], joint_inverse(&g, &[0], 0.3).unwrap(), &[1, 2, 3], 2).is_none()
        );
    }
}
