//! Policies over action values: ε-greedy with random tie-breaking, greedy, and the
//! paper's probabilistic policy (eq. 8, normalised).

use mmq_core::Rng;
use rand::RngExt;

/// Index of a maximum of `xs`, ties broken uniformly at random.
///
/// Draws from `rng` only when there is more than one maximum, so runs without ties
/// consume no randomness here.
#[inline(always)]
pub fn argmax_random_tie(xs: &[f64], rng: &mut Rng) -> usize {
    if let Ok(xs) = <&[f64; 4]>::try_from(xs) {
        return argmax4(xs, rng);
    }
    let mut best = f64::NEG_INFINITY;
    let mut count = 0usize;
    for &x in xs {
        if x > best {
            best = x;
            count = 1;
        } else if x == best {
            count += 1;
        }
    }
    if count <= 1 {
        return xs.iter().position(|&x| x == best).unwrap_or(0);
    }
    pick_tie(xs, best, count, rng)
}

/// [`argmax_random_tie`] for four values (the paper's moves) without branches unless
/// there is a tie: the same maximum (a `>` scan from −∞), count and choice.
#[inline(always)]
fn argmax4(xs: &[f64; 4], rng: &mut Rng) -> usize {
    let best = greedy_value(xs);
    let count: usize = xs.iter().map(|&x| usize::from(x == best)).sum();
    if count > 1 {
        return pick_tie(xs, best, count, rng);
    }
    // The first index holding the maximum (0 if none, as `position(..).unwrap_or(0)`).
    let mut first = 0;
    for k in (0..4).rev() {
        first = if xs[k] == best { k } else { first };
    }
    first
}

/// max(xs) by a `>` scan from −∞ (one `maxsd` per value; NaNs are passed over), the
/// maximum [`argmax_random_tie`] finds.
#[inline(always)]
pub fn greedy_value(xs: &[f64]) -> f64 {
    let scan = |xs: &[f64]| xs.iter().fold(f64::NEG_INFINITY, |best, &x| if x > best { x } else { best });
    match <&[f64; 4]>::try_from(xs) {
        Ok(xs) => scan(xs), // unrolled
        Err(_) => scan(xs),
    }
}

/// One of the `count` (≥ 2) indices of `xs` whose value equals `best`, uniformly at
/// random: exactly the draw and the choice of [`argmax_random_tie`], for callers that
/// keep the maximum and its count cached.
#[inline]
pub fn pick_tie(xs: &[f64], best: f64, count: usize, rng: &mut Rng) -> usize {
    pick_tie_in(xs.iter().copied(), best, count, rng)
}

/// [`pick_tie`] over values given in order by an iterator (e.g. a table stored in
/// another order than the one ties are counted in).
#[inline]
pub fn pick_tie_in(xs: impl IntoIterator<Item = f64>, best: f64, count: usize, rng: &mut Rng) -> usize {
    let mut k = rng.random_range(0..count);
    for (i, x) in xs.into_iter().enumerate() {
        if x == best {
            if k == 0 {
                return i;
            }
            k -= 1;
        }
    }
    unreachable!("count ties of best are in xs")
}

/// ε-greedy: with probability ε a uniformly random action (`true`), else `greedy()`.
///
/// Always draws one uniform number first, then either the random action or whatever
/// `greedy` draws.
#[inline]
pub fn epsilon_greedy(
    epsilon: f64,
    num_actions: usize,
    rng: &mut Rng,
    greedy: impl FnOnce(&mut Rng) -> usize,
) -> (usize, bool) {
    let u: f64 = rng.random();
    if u < epsilon { (rng.random_range(0..num_actions), true) } else { (greedy(rng), false) }
}

/// The paper's probabilistic policy, eq. (8), normalised so that it sums to one:
///
/// p(a|s) = (Q(s,a,λ̂*) − min_a Q(s,a,λ̂*)) / Σ_a' (Q(s,a',λ̂*) − min_a Q(s,a,λ̂*)).
///
/// The paper's denominator Σ_a Q(s,a,λ̂*) does not make the numerators sum to one (and
/// can be zero or negative); see docs/algorithms/deviations.md. When all values are
/// equal every action gets 1/|A|.
pub fn probabilistic(values: &[f64]) -> Vec<f64> {
    let min = values.iter().copied().fold(f64::INFINITY, f64::min);
    let shifted: Vec<f64> = values.iter().map(|q| q - min).collect();
    let total: f64 = shifted.iter().sum();
    if total > 0.0 && total.is_finite() {
        shifted.iter().map(|x| x / total).collect()
    } else {
        vec![1.0 / values.len() as f64; values.len()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mmq_core::seed::rng_from_seed;

    #[test]
    fn ties_are_broken_uniformly() {
        let mut rng = rng_from_seed(1);
        let mut counts = [0usize; 4];
        for _ in 0..40_000 {
            counts[argmax_random_tie(&[1.0, 3.0, 3.0, 3.0], &mut rng)] += 1;
        }
        assert_eq!(counts[0], 0);
        for c in &counts[1..] {
            assert!((*c as f64 - 40_000.0 / 3.0).abs() < 400.0, "{counts:?}");
        }
        assert_eq!(argmax_random_tie(&[0.0, -1.0, 2.0], &mut rng), 2);
    }

    /// The four-value path finds the same index and draws the same numbers as the
    /// general scan, ties, zeros of both signs and NaN included.
    #[test]
    fn four_values_as_the_general_scan() {
        fn general(xs: &[f64], rng: &mut Rng) -> usize {
            // The scan of argmax_random_tie for lengths other than four.
            let padded: Vec<f64> = xs.iter().copied().chain([f64::NEG_INFINITY]).collect();
            let i = argmax_random_tie(&padded, rng);
            assert!(i < 4);
            i
        }
        let vals = [1.0, 2.0, -1.0, 0.0, -0.0, f64::NAN, f64::NEG_INFINITY, 2.0];
        let (mut r1, mut r2) = (rng_from_seed(3), rng_from_seed(3));
        for a in vals {
            for b in vals {
                for c in vals {
                    for d in vals {
                        let xs = [a, b, c, d];
                        if xs.iter().all(|x| *x == f64::NEG_INFINITY || x.is_nan()) {
                            continue; // the padding would tie with them
                        }
                        assert_eq!(argmax_random_tie(&xs, &mut r1), general(&xs, &mut r2), "{xs:?}");
                    }
                }
            }
        }
        assert_eq!(r1.random::<u64>(), r2.random::<u64>());
    }

    #[test]
    fn eq8_normalised_by_hand() {
        // Q = 1, 2, 3, 4: shifted 0, 1, 2, 3 over 6.
        let p = probabilistic(&[1.0, 2.0, 3.0, 4.0]);
        assert_eq!(p, vec![0.0, 1.0 / 6.0, 2.0 / 6.0, 3.0 / 6.0]);
        assert_eq!(probabilistic(&[5.0; 4]), vec![0.25; 4]);
        let n = probabilistic(&[-3.0, -1.0, -1.0, -2.0]);
        assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn epsilon_one_always_explores_and_zero_never() {
        let mut rng = rng_from_seed(2);
        for _ in 0..100 {
            assert!(epsilon_greedy(1.0, 4, &mut rng, |_| 0).1);
            assert_eq!(epsilon_greedy(0.0, 4, &mut rng, |_| 3), (3, false));
        }
    }
}
