//! Summaries of a delay pmf over lags 0..=K: its mean, its median and the standard errors
//! of the median, and the truncation of a delay distribution to 0..=K. A leaf: it uses
//! nothing else of the crate, so that the delay estimate a learner reports
//! ([`crate::diagnostics`]) and the deconvolution that fits it ([`crate::deconv`]) can
//! both read it.

use mmq_core::DelayDist;

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

/// Standard errors of the median m̂ of a delay estimate (`median_se`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MedianSe {
    /// Of the cumulative probability F(m̂).
    pub cdf: f64,
    /// Of m̂ itself, steps.
    pub steps: f64,
}
