//! The aggregates of the leaderboard, after Agarwal et al., "Deep Reinforcement Learning
//! at the Edge of the Statistical Precipice" (NeurIPS 2021), as their `rliable` package
//! computes them: the interquartile mean of all runs' scores, percentile intervals from
//! the stratified bootstrap (runs resampled with replacement within each task), score
//! distributions (performance profiles) and the probability of improvement. Every
//! bootstrap is seeded, so the numbers are the same on every machine.

use mmq_core::seed::{Rng, rng_from_seed};
use rand::RngExt;

/// Scores of one agent: per task, one score per run (seed).
pub type Scores = Vec<Vec<f64>>;

/// An estimate with its 95 % interval.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval {
    /// The point estimate on the scores as they are.
    pub estimate: f64,
    /// Lower end of the 95 % interval.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

/// Bootstrap settings.
#[derive(Clone, Copy, Debug)]
pub struct Bootstrap {
    /// Resamples.
    pub reps: usize,
    /// Seed of the resampling.
    pub seed: u64,
}

impl Default for Bootstrap {
    fn default() -> Self {
        Bootstrap { reps: 2000, seed: 0 }
    }
}

/// The interquartile mean: the mean of the middle half of all scores, as
/// `scipy.stats.trim_mean(x, 0.25)` gives it (⌊n/4⌋ cut from each end). NaN when empty.
pub fn iqm(scores: &[Vec<f64>]) -> f64 {
    let mut all: Vec<f64> = scores.iter().flatten().copied().collect();
    trimmed_mean(&mut all, 0.25)
}

fn trimmed_mean(xs: &mut [f64], cut: f64) -> f64 {
    let n = xs.len();
    let k = (cut * n as f64) as usize;
    if n == 0 || 2 * k >= n {
        return f64::NAN;
    }
    xs.sort_by(f64::total_cmp);
    let mid = &xs[k..n - k];
    mid.iter().sum::<f64>() / mid.len() as f64
}

/// The mean of all scores.
pub fn mean(scores: &[Vec<f64>]) -> f64 {
    let n: usize = scores.iter().map(Vec::len).sum();
    scores.iter().flatten().sum::<f64>() / n as f64
}

/// One stratified resample: per task, as many runs drawn with replacement.
fn resample(scores: &[Vec<f64>], rng: &mut Rng) -> Scores {
    scores
        .iter()
        .map(|runs| {
            if runs.is_empty() {
                return Vec::new();
            }
            (0..runs.len()).map(|_| runs[rng.random_range(0..runs.len())]).collect()
        })
        .collect()
}

/// The `q`-quantile of sorted values by linear interpolation (NumPy's default).
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let h = (sorted.len() - 1) as f64 * q;
    let (i, f) = (h.floor() as usize, h - h.floor());
    if i + 1 < sorted.len() { sorted[i] + f * (sorted[i + 1] - sorted[i]) } else { sorted[i] }
}

fn percentile_interval(estimate: f64, mut boots: Vec<f64>) -> Interval {
    boots.retain(|x| x.is_finite());
    boots.sort_by(f64::total_cmp);
    Interval { estimate, lo: quantile(&boots, 0.025), hi: quantile(&boots, 0.975) }
}

/// `stat` of the scores with its 95 % percentile interval from the stratified bootstrap.
pub fn with_interval(scores: &[Vec<f64>], stat: impl Fn(&[Vec<f64>]) -> f64, b: Bootstrap) -> Interval {
    let mut rng = rng_from_seed(b.seed);
    let boots = (0..b.reps).map(|_| stat(&resample(scores, &mut rng))).collect();
    percentile_interval(stat(scores), boots)
}

/// The interquartile mean with its stratified-bootstrap interval.
pub fn iqm_interval(scores: &[Vec<f64>], b: Bootstrap) -> Interval {
    with_interval(scores, iqm, b)
}

/// P(X > Y) for one task: the Mann–Whitney statistic over all pairs, ties counting ½.
fn prob_greater(x: &[f64], y: &[f64]) -> f64 {
    let mut s = 0.0;
    for a in x {
        for b in y {
            s += if a > b {
                1.0
            } else if a == b {
                0.5
            } else {
                0.0
            };
        }
    }
    s / (x.len() * y.len()) as f64
}

/// The probability of improvement of `x` over `y`: P(X > Y) per task, averaged over the
/// tasks both have runs of (rliable's `probability_of_improvement`). NaN with none.
pub fn probability_of_improvement(x: &[Vec<f64>], y: &[Vec<f64>]) -> f64 {
    let ps: Vec<f64> = x
        .iter()
        .zip(y)
        .filter(|(a, b)| !a.is_empty() && !b.is_empty())
        .map(|(a, b)| prob_greater(a, b))
        .collect();
    ps.iter().sum::<f64>() / ps.len() as f64
}

/// The probability of improvement with its interval: both agents' runs resampled within
/// each task, independently.
pub fn probability_of_improvement_interval(x: &[Vec<f64>], y: &[Vec<f64>], b: Bootstrap) -> Interval {
    let mut rng = rng_from_seed(b.seed);
    let boots = (0..b.reps)
        .map(|_| probability_of_improvement(&resample(x, &mut rng), &resample(y, &mut rng)))
        .collect();
    percentile_interval(probability_of_improvement(x, y), boots)
}

/// The performance profile (score distribution): at each threshold τ, the fraction of
/// all runs whose score exceeds τ.
pub fn profile(scores: &[Vec<f64>], taus: &[f64]) -> Vec<f64> {
    let all: Vec<f64> = scores.iter().flatten().copied().collect();
    taus.iter().map(|t| all.iter().filter(|x| *x > t).count() as f64 / all.len() as f64).collect()
}

/// The performance profile with a pointwise 95 % band from the stratified bootstrap.
pub fn profile_interval(scores: &[Vec<f64>], taus: &[f64], b: Bootstrap) -> Vec<Interval> {
    let mut rng = rng_from_seed(b.seed);
    let boots: Vec<Vec<f64>> = (0..b.reps).map(|_| profile(&resample(scores, &mut rng), taus)).collect();
    profile(scores, taus)
        .into_iter()
        .enumerate()
        .map(|(i, e)| percentile_interval(e, boots.iter().map(|p| p[i]).collect()))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn iqm_by_hand() {
        // 8 scores: cut 2 from each end, the mean of 3, 4, 5, 6.
        let s = vec![vec![1.0, 8.0, 3.0, 6.0], vec![2.0, 7.0, 4.0, 5.0]];
        assert_eq!(iqm(&s), 4.5);
        // 5 scores: ⌊1.25⌋ = 1 cut from each end.
        assert_eq!(iqm(&[vec![10.0, 0.0, 1.0, 2.0, 3.0]]), 2.0);
        assert!(iqm(&[vec![]]).is_nan());
        assert_eq!(mean(&s), 4.5);
    }

    #[test]
    fn probability_of_improvement_by_hand() {
        // Task 1: x beats y in 3 of 4 pairs; task 2: a tie (½).
        let x = vec![vec![2.0, 4.0], vec![1.0]];
        let y = vec![vec![1.0, 3.0], vec![1.0]];
        assert_eq!(probability_of_improvement(&x, &y), (0.75 + 0.5) / 2.0);
        assert_eq!(probability_of_improvement(&x, &x), 0.5);
    }

    #[test]
    fn profile_by_hand() {
        let s = vec![vec![0.1, 0.5], vec![0.9, 1.0]];
        assert_eq!(profile(&s, &[0.0, 0.5, 0.95]), [1.0, 0.5, 0.25]);
    }

    /// Seeded: the same interval twice; it holds the estimate; constant scores give a
    /// zero-width interval; a different seed moves the ends only a little.
    #[test]
    fn bootstrap_is_seeded_and_sane() {
        let s: Scores = (0..4).map(|t| (0..10).map(|i| (t * 10 + i) as f64 / 40.0).collect()).collect();
        let b = Bootstrap::default();
        let a = iqm_interval(&s, b);
        assert_eq!(a, iqm_interval(&s, b));
        assert!(a.lo < a.estimate && a.estimate < a.hi, "{a:?}");
        let c = iqm_interval(&s, Bootstrap { seed: 1, ..b });
        assert!((c.lo - a.lo).abs() < 0.03 && (c.hi - a.hi).abs() < 0.03, "{a:?} {c:?}");
        let flat = vec![vec![0.5; 5]; 3];
        let f = iqm_interval(&flat, b);
        assert_eq!((f.lo, f.estimate, f.hi), (0.5, 0.5, 0.5));
        let p = probability_of_improvement_interval(&s, &flat, b);
        assert!(p.lo <= p.estimate && p.estimate <= p.hi);
    }
}
