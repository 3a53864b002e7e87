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
    /// Figures, in a stable order: counters ([`Figure::DelayRefits`], [`Figure::Probes`],
    /// ...) and settings the learner derived ([`Figure::LambdaHat`], ...).
    pub figures: Vec<(Figure, f64)>,
    /// The delay estimate, for learners that keep a delay pmf (estimated or told).
    pub delay: Option<DelayEstimate>,
    /// The discrete reward values found by decoding deliveries, in the order found
    /// (empty unless the learner decodes values).
    pub reward_values: Vec<f64>,
}

impl Diagnostics {
    /// The figure `f`, if the learner reports it.
    pub fn figure(&self, f: Figure) -> Option<f64> {
        self.figures.iter().find(|(n, _)| *n == f).map(|(_, v)| *v)
    }
}

/// A figure a learner reports, typed: a counter or a setting it derived. Its name
/// ([`Figure::name`]) is the stable column name of the lab's outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Figure {
    /// `delay/refits`: counters: refits of the delay estimate.
    DelayRefits,
    /// `delay/surprise_refits`: refits the surprise test asked for.
    DelaySurpriseRefits,
    /// `delay/cold_starts`: refits started afresh beside the warm start.
    DelayColdStarts,
    /// `delay/cold_start_wins`: of those, fits the fresh start won.
    DelayColdStartWins,
    /// `delay/rounds`: rounds of the alternating fit.
    DelayRounds,
    /// `delay/joint_drops`: joint fits dropped for the plain one.
    DelayJointDrops,
    /// `delay/joint_factorisations`: factorisations of the joint system.
    DelayJointFactorisations,
    /// `learner/pairs_seen`: state–action pairs the fit has seen.
    PairsSeen,
    /// `learner/credited`: rewards credited to their pairs (the oracle).
    Credited,
    /// `learner/in_flight`: rewards emitted and not yet delivered (the oracle).
    InFlight,
    /// `learner/info_needed`: the information a pair needs before it is known.
    InfoNeeded,
    /// `learner/info_per_visit`: the information one visit gives.
    InfoPerVisit,
    /// `learner/known_pairs`: pairs whose model is known.
    KnownPairs,
    /// `learner/lambda_hat`: the fixed delay estimate λ̂.
    LambdaHat,
    /// `learner/model_star_mean`: mean index of the model MMQ acts on.
    ModelStarMean,
    /// `learner/model_star_mode`: most frequent index of the model MMQ acts on.
    ModelStarMode,
    /// `learner/probes`: delay probes taken.
    Probes,
    /// `learner/time_bin_s`: width of a time bin, seconds.
    TimeBinS,
    /// `learner/time_bins_idle`: time bins without a decision.
    TimeBinsIdle,
    /// `learner/time_bins_shifted`: time bins the window shifted by.
    TimeBinsShifted,
    /// `learner/trace_cuts`: eligibility traces cut at an exploratory action.
    TraceCuts,
    /// `learner/trace_decay`: the traces' decay γλ.
    TraceDecay,
    /// `learner/value_max`: the largest state value.
    ValueMax,
    /// `mmq/leader`: the leading model of the kernel.
    MmqLeader,
    /// `mmq/mean_chosen_model`: mean index of the chosen model.
    MmqMeanChosenModel,
    /// `reward/values_found`: discrete reward values decoded.
    RewardValuesFound,
    /// `reward/value_rebuilds`: rebuilds of the per-value fits.
    RewardValueRebuilds,
}

impl Figure {
    /// Every figure.
    pub const ALL: [Figure; 27] = [
        Figure::DelayRefits,
        Figure::DelaySurpriseRefits,
        Figure::DelayColdStarts,
        Figure::DelayColdStartWins,
        Figure::DelayRounds,
        Figure::DelayJointDrops,
        Figure::DelayJointFactorisations,
        Figure::PairsSeen,
        Figure::Credited,
        Figure::InFlight,
        Figure::InfoNeeded,
        Figure::InfoPerVisit,
        Figure::KnownPairs,
        Figure::LambdaHat,
        Figure::ModelStarMean,
        Figure::ModelStarMode,
        Figure::Probes,
        Figure::TimeBinS,
        Figure::TimeBinsIdle,
        Figure::TimeBinsShifted,
        Figure::TraceCuts,
        Figure::TraceDecay,
        Figure::ValueMax,
        Figure::MmqLeader,
        Figure::MmqMeanChosenModel,
        Figure::RewardValuesFound,
        Figure::RewardValueRebuilds,
    ];

    /// Its stable name (a column of the lab's outputs).
    pub fn name(self) -> &'static str {
        match self {
            Figure::DelayRefits => "delay/refits",
            Figure::DelaySurpriseRefits => "delay/surprise_refits",
            Figure::DelayColdStarts => "delay/cold_starts",
            Figure::DelayColdStartWins => "delay/cold_start_wins",
            Figure::DelayRounds => "delay/rounds",
            Figure::DelayJointDrops => "delay/joint_drops",
            Figure::DelayJointFactorisations => "delay/joint_factorisations",
            Figure::PairsSeen => "learner/pairs_seen",
            Figure::Credited => "learner/credited",
            Figure::InFlight => "learner/in_flight",
            Figure::InfoNeeded => "learner/info_needed",
            Figure::InfoPerVisit => "learner/info_per_visit",
            Figure::KnownPairs => "learner/known_pairs",
            Figure::LambdaHat => "learner/lambda_hat",
            Figure::ModelStarMean => "learner/model_star_mean",
            Figure::ModelStarMode => "learner/model_star_mode",
            Figure::Probes => "learner/probes",
            Figure::TimeBinS => "learner/time_bin_s",
            Figure::TimeBinsIdle => "learner/time_bins_idle",
            Figure::TimeBinsShifted => "learner/time_bins_shifted",
            Figure::TraceCuts => "learner/trace_cuts",
            Figure::TraceDecay => "learner/trace_decay",
            Figure::ValueMax => "learner/value_max",
            Figure::MmqLeader => "mmq/leader",
            Figure::MmqMeanChosenModel => "mmq/mean_chosen_model",
            Figure::RewardValuesFound => "reward/values_found",
            Figure::RewardValueRebuilds => "reward/value_rebuilds",
        }
    }

    /// The figure of a name, if there is one.
    pub fn of_name(name: &str) -> Option<Figure> {
        Figure::ALL.into_iter().find(|f| f.name() == name)
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
        let g = Diagnostics { figures: vec![(Figure::DelayRefits, 3.0)], ..Diagnostics::default() };
        assert_eq!((g.figure(Figure::DelayRefits), g.figure(Figure::Probes)), (Some(3.0), None));
    }

    /// Every figure has a name of its own, and the name finds it.
    #[test]
    fn figures_have_distinct_names() {
        let names: std::collections::BTreeSet<&str> = Figure::ALL.iter().map(|f| f.name()).collect();
        assert_eq!(names.len(), Figure::ALL.len());
        for f in Figure::ALL {
            assert_eq!(Figure::of_name(f.name()), Some(f));
        }
        assert_eq!(Figure::of_name("learner/nothing"), None);
    }
}
