//! Structured diagnostics of a learner at one moment: named figures (counters and
//! settings) and, for learners that work with a delay pmf, the delay estimate itself.
//!
//! A learner reports what it knows *now* ([`crate::learner::Learner::diagnostics`]); whoever runs
//! it samples that on a schedule to get a time series (the lab's runner does). Names of
//! output columns are not chosen here: the lab flattens these values into its files.

use crate::pmf::{MedianSe, pmf_mean, pmf_median};

/// What a learner reports about itself at one moment.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Diagnostics {
    /// Named figures, in a stable order: counters (`delay/refits`, `learner/probes`, ...)
    /// and settings the learner derived (`learner/lambda_hat`, ...).
    pub figures: Vec<(&'static str, f64)>,
    /// The delay estimate, for learners that keep a delay pmf (estimated or told).
    pub delay: Option<DelayEstimate>,
    /// The discrete reward values found by decoding deliveries, in the order found
    /// (empty unless the learner decodes values).
    pub reward_values: Vec<f64>,
}

impl Diagnostics {
    /// The figure named `name`, if the learner reports one.
    pub fn figure(&self, name: &str) -> Option<f64> {
        self.figures.iter().find(|(n, _)| *n == name).map(|(_, v)| *v)
    }
}

/// A learner's estimate of the reward delay's distribution.
#[derive(Clone, Debug, PartialEq)]
pub struct DelayEstimate {
    /// p̂ over lags 0..=K; a lag counts decision steps, or time bins of `time_bin_s`
    /// seconds for a learner on time bins.
    pub pmf: Vec<f64>,
    /// Mean of p̂, lags ([`pmf_mean`]).
    pub mean: f64,
    /// Median of p̂, lags ([`pmf_median`]).
    pub median: f64,
    /// Standard errors of the median from the last reweighted fit (`None` when unknown).
    pub median_se: Option<MedianSe>,
    /// Whether p̂ is estimated (false: the pmf was told).
    pub estimated: bool,
    /// Width of one lag in seconds, for a learner whose lags are time bins.
    pub time_bin_s: Option<f64>,
}

impl DelayEstimate {
    /// The estimate of p̂ (mean and median from it), estimated or told, lags in steps.
    pub fn of_pmf(pmf: &[f64], median_se: Option<MedianSe>, estimated: bool) -> Self {
        Self {
            pmf: pmf.to_vec(),
            mean: pmf_mean(pmf),
            median: pmf_median(pmf),
            median_se,
            estimated,
            time_bin_s: None,
        }
    }

    /// The mean in seconds (the centre of its bin, (mean + ½)·b), for time bins.
    pub fn mean_s(&self) -> Option<f64> {
        self.time_bin_s.map(|b| (self.mean + 0.5) * b)
    }

    /// The median in seconds (the centre of its bin, (median + ½)·b), for time bins.
    pub fn median_s(&self) -> Option<f64> {
        self.time_bin_s.map(|b| (self.median + 0.5) * b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// p = (0.2, 0.3, 0.5): mean 0·0.2 + 1·0.3 + 2·0.5 = 1.3; the cumulative sum first
    /// reaches ½ at lag 1 (0.5); on bins of 0.1 s the mean's bin centre is 1.8·0.1 s.
    #[test]
    fn the_delay_estimate_by_hand() {
        let mut d = DelayEstimate::of_pmf(&[0.2, 0.3, 0.5], None, true);
        assert!((d.mean - 1.3).abs() < 1e-12, "{}", d.mean);
        assert_eq!(d.mean_s(), None);
        d.time_bin_s = Some(0.1);
        assert!((d.mean_s().unwrap() - 0.18).abs() < 1e-12);
        assert_eq!(d.median_s().unwrap(), (d.median + 0.5) * 0.1);
        let g = Diagnostics { figures: vec![("delay/refits", 3.0)], ..Diagnostics::default() };
        assert_eq!((g.figure("delay/refits"), g.figure("learner/probes")), (Some(3.0), None));
    }
}
