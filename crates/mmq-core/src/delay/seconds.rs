//! Delay distributions in seconds of simulated time: network latencies and other delays
//! that do not count decisions. See the spec table in [`crate::delay`].
//!
//! A delay d ≥ 0 seconds is a real number; the channel delivers a reward emitted at time
//! t_e with the first decision that ends at or after t_e + d
//! ([`crate::channel::DelayedReward`]).

use std::fmt;

use rand::RngExt;
use rand_distr::Distribution;

use crate::seed::Rng;

/// Largest mean delay accepted, seconds (11.6 days of simulated time).
pub const MAX_MEAN_DELAY_S: f64 = 1.0e6;

/// The WiFi-latency preset (`wifi`): a two-lognormal mixture fitted to the one-hop WiFi
/// latency quantiles measured by Sui et al., *Characterizing and Improving WiFi Latency in
/// Large-Scale Operational Networks*, MobiSys 2016 (47,000 devices on a campus network):
/// the latency is "as low as 3 ms" (read here as the median; assumption), its 90th
/// percentile is about 20 ms and its 99th about 250 ms. The shape — a body (95 %) and a
/// congested tail (5 %), each log-normal — is an assumption; its four numbers were fitted
/// by least squares on the log of those three quantiles (the mixture has median 3.0 ms,
/// 90th percentile 19.6 ms, 99th 249 ms, mean 14.4 ms; checked in the tests). One reward
/// message is assumed to cross one WiFi hop; losses are not modelled.
pub const WIFI: [(f64, f64, f64); 2] = [
    // (weight, median s, σ of ln d)
    (0.95, 0.0028, 1.2),
    (0.05, 0.150, 0.6),
];

/// A delay distribution over d ≥ 0 seconds.
#[derive(Clone, Debug, PartialEq)]
pub enum SecondsDist {
    /// Always `d` seconds.
    Constant(f64),
    /// Uniform on [lo, hi] seconds.
    Uniform(f64, f64),
    /// Exponential with this mean, seconds.
    Exponential(f64),
    /// Log-normal: ln d ~ N(ln median, σ²); median in seconds, σ dimensionless.
    LogNormal {
        /// Median, seconds.
        median: f64,
        /// Standard deviation of ln d.
        sigma: f64,
    },
    /// A histogram: P(k·bin ≤ d < (k+1)·bin) ∝ `weights[k]`, uniform within a bin.
    Histogram {
        /// Bin width, seconds.
        bin_s: f64,
        /// Weight of every bin, from bin 0.
        weights: Vec<f64>,
    },
    /// The WiFi-latency preset ([`WIFI`]).
    Wifi,
    /// Mixture: (weight, component).
    Mixture(Vec<(f64, SecondsDist)>),
}

impl SecondsDist {
    /// Mean delay, seconds.
    pub fn mean(&self) -> f64 {
        match self {
            SecondsDist::Constant(d) => *d,
            SecondsDist::Uniform(lo, hi) => (lo + hi) / 2.0,
            SecondsDist::Exponential(m) => *m,
            SecondsDist::LogNormal { median, sigma } => median * (sigma * sigma / 2.0).exp(),
            SecondsDist::Histogram { bin_s, weights } => {
                let s: f64 = weights.iter().sum();
                bin_s * weights.iter().enumerate().map(|(k, w)| (k as f64 + 0.5) * w).sum::<f64>() / s
            }
            SecondsDist::Wifi => wifi().mean(),
            SecondsDist::Mixture(parts) => {
                let s: f64 = parts.iter().map(|p| p.0).sum();
                parts.iter().map(|(w, d)| w * d.mean()).sum::<f64>() / s
            }
        }
    }

    /// Variance of the delay, s².
    pub fn variance(&self) -> f64 {
        match self {
            SecondsDist::Constant(_) => 0.0,
            SecondsDist::Uniform(lo, hi) => (hi - lo) * (hi - lo) / 12.0,
            SecondsDist::Exponential(m) => m * m,
            SecondsDist::LogNormal { median, sigma } => {
                let s2 = sigma * sigma;
                (s2.exp() - 1.0) * median * median * s2.exp()
            }
            SecondsDist::Histogram { bin_s, weights } => {
                let s: f64 = weights.iter().sum();
                let m = self.mean();
                // Each bin contributes its centre's square plus the uniform spread b²/12.
                let second = bin_s
                    * bin_s
                    * weights
                        .iter()
                        .enumerate()
                        .map(|(k, w)| ((k as f64 + 0.5).powi(2) + 1.0 / 12.0) * w)
                        .sum::<f64>()
                    / s;
                second - m * m
            }
            SecondsDist::Wifi => wifi().variance(),
            SecondsDist::Mixture(parts) => {
                let s: f64 = parts.iter().map(|p| p.0).sum();
                let m = self.mean();
                parts.iter().map(|(w, d)| w * (d.variance() + d.mean() * d.mean())).sum::<f64>() / s - m * m
            }
        }
    }

    /// P(d ≤ x), x in seconds.
    pub fn cdf(&self, x: f64) -> f64 {
        if x < 0.0 {
            return 0.0;
        }
        match self {
            SecondsDist::Constant(d) => f64::from(x >= *d),
            SecondsDist::Uniform(lo, hi) if hi > lo => ((x - lo) / (hi - lo)).clamp(0.0, 1.0),
            SecondsDist::Uniform(lo, _) => f64::from(x >= *lo),
            SecondsDist::Exponential(m) if *m > 0.0 => 1.0 - (-x / m).exp(),
            SecondsDist::Exponential(_) => 1.0,
            SecondsDist::LogNormal { median, sigma } => {
                if x == 0.0 {
                    0.0
                } else if *sigma == 0.0 {
                    f64::from(x >= *median)
                } else {
                    0.5 * erfc(-(x / median).ln() / (sigma * std::f64::consts::SQRT_2))
                }
            }
            SecondsDist::Histogram { bin_s, weights } => {
                let s: f64 = weights.iter().sum();
                let pos = x / bin_s;
                let mut acc = 0.0;
                for (k, w) in weights.iter().enumerate() {
                    let k = k as f64;
                    acc += w * (pos - k).clamp(0.0, 1.0);
                }
                acc / s
            }
            SecondsDist::Wifi => wifi().cdf(x),
            SecondsDist::Mixture(parts) => {
                let s: f64 = parts.iter().map(|p| p.0).sum();
                parts.iter().map(|(w, d)| w * d.cdf(x)).sum::<f64>() / s
            }
        }
    }

    /// The p-quantile, seconds (bisection on [`Self::cdf`], to 1e-12 s relative).
    pub fn quantile(&self, p: f64) -> f64 {
        let (mut lo, mut hi) = (0.0_f64, self.mean().max(1e-9));
        while self.cdf(hi) < p {
            hi *= 2.0;
            if hi > 1e12 {
                return f64::INFINITY;
            }
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if self.cdf(mid) < p {
                lo = mid;
            } else {
                hi = mid;
            }
            if hi - lo <= 1e-12 * hi {
                break;
            }
        }
        hi
    }

    /// A sampler for this distribution.
    pub fn sampler(&self) -> SecondsSampler {
        SecondsSampler::new(self)
    }
}

/// The WiFi preset as a mixture of its lognormals.
fn wifi() -> SecondsDist {
    SecondsDist::Mixture(
        WIFI.iter().map(|&(w, median, sigma)| (w, SecondsDist::LogNormal { median, sigma })).collect(),
    )
}

/// The complementary error function (Numerical Recipes' `erfcc`, fractional error below
/// 1.2e-7 everywhere): enough for quantiles and tests.
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// A duration as written in a spec: seconds, printed with the `s` unit.
pub(crate) struct Secs(pub f64);

impl fmt::Display for Secs {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}s", self.0)
    }
}

impl fmt::Display for SecondsDist {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SecondsDist::Constant(d) => write!(f, "const:{}", Secs(*d)),
            SecondsDist::Uniform(lo, hi) => write!(f, "uniform:{}:{}", Secs(*lo), Secs(*hi)),
            SecondsDist::Exponential(m) => write!(f, "exponential:{}", Secs(*m)),
            SecondsDist::LogNormal { median, sigma } => write!(f, "lognormal:{}:{sigma}", Secs(*median)),
            SecondsDist::Histogram { bin_s, weights } => {
                let s: Vec<String> = weights.iter().map(|x| x.to_string()).collect();
                write!(f, "hist@{}:{}", Secs(*bin_s), s.join(","))
            }
            SecondsDist::Wifi => write!(f, "wifi"),
            SecondsDist::Mixture(parts) => {
                let s: Vec<String> = parts.iter().map(|(w, d)| format!("{w}*{d}")).collect();
                write!(f, "mix:{}", s.join("+"))
            }
        }
    }
}

/// Draws delays in seconds from a [`SecondsDist`].
#[derive(Clone, Debug)]
pub enum SecondsSampler {
    /// Always this many seconds (draws nothing).
    Fixed(f64),
    /// Uniform on [lo, hi].
    Uniform(f64, f64),
    /// Exponential (rand_distr).
    Exp(rand_distr::Exp<f64>),
    /// Log-normal (rand_distr).
    LogNormal(rand_distr::LogNormal<f64>),
    /// Histogram: cumulative bin probabilities and the bin width; one draw picks the bin,
    /// a second the place within it.
    Table(Vec<f64>, f64),
    /// Mixture: cumulative weights and components.
    Mixture(Vec<f64>, Vec<SecondsSampler>),
}

impl SecondsSampler {
    fn new(d: &SecondsDist) -> Self {
        match d {
            SecondsDist::Constant(x) => SecondsSampler::Fixed(*x),
            SecondsDist::Uniform(lo, hi) if lo == hi => SecondsSampler::Fixed(*lo),
            SecondsDist::Uniform(lo, hi) => SecondsSampler::Uniform(*lo, *hi),
            SecondsDist::Exponential(m) if *m == 0.0 => SecondsSampler::Fixed(0.0),
            SecondsDist::Exponential(m) => {
                SecondsSampler::Exp(rand_distr::Exp::new(1.0 / m).expect("mean validated > 0 and finite"))
            }
            SecondsDist::LogNormal { median, sigma } => SecondsSampler::LogNormal(
                rand_distr::LogNormal::new(median.ln(), *sigma).expect("median > 0 and σ ≥ 0 validated"),
            ),
            SecondsDist::Histogram { bin_s, weights } => {
                let s: f64 = weights.iter().sum();
                let mut acc = 0.0;
                SecondsSampler::Table(
                    weights
                        .iter()
                        .map(|x| {
                            acc += x / s;
                            acc
                        })
                        .collect(),
                    *bin_s,
                )
            }
            SecondsDist::Wifi => SecondsSampler::new(&wifi()),
            SecondsDist::Mixture(parts) => {
                let s: f64 = parts.iter().map(|p| p.0).sum();
                let mut acc = 0.0;
                let cum = parts
                    .iter()
                    .map(|(w, _)| {
                        acc += w / s;
                        acc
                    })
                    .collect();
                SecondsSampler::Mixture(cum, parts.iter().map(|(_, d)| SecondsSampler::new(d)).collect())
            }
        }
    }

    /// One delay, seconds (finite, ≥ 0).
    pub fn sample(&self, rng: &mut Rng) -> f64 {
        match self {
            SecondsSampler::Fixed(x) => *x,
            SecondsSampler::Uniform(lo, hi) => lo + (hi - lo) * rng.random::<f64>(),
            SecondsSampler::Exp(e) => e.sample(rng),
            SecondsSampler::LogNormal(l) => l.sample(rng).min(1e12),
            SecondsSampler::Table(cdf, bin) => {
                let k = pick(cdf, rng.random::<f64>());
                bin * (k as f64 + rng.random::<f64>())
            }
            SecondsSampler::Mixture(cum, comps) => comps[pick(cum, rng.random::<f64>())].sample(rng),
        }
    }
}

fn pick(cdf: &[f64], u: f64) -> usize {
    cdf.iter().position(|&c| u < c).unwrap_or(cdf.len() - 1)
}

/// Parses a duration `Xs` or `Xms` into seconds; `None` when the unit is missing.
pub(crate) fn duration(x: &str) -> Option<Result<f64, String>> {
    let x = x.trim();
    let (num, scale) = if let Some(n) = x.strip_suffix("ms") {
        (n, 1e3)
    } else if let Some(n) = x.strip_suffix('s') {
        (n, 1.0)
    } else {
        return None;
    };
    Some(
        num.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .map(|v| v / scale)
            .ok_or_else(|| format!("`{x}` is not a duration ≥ 0; write seconds like 2s, 0.5s or 20ms")),
    )
}

/// Whether an argument carries a time unit (`s` or `ms` after a number).
pub(crate) fn has_unit(x: &str) -> bool {
    let x = x.trim();
    x.ends_with('s') && x.trim_end_matches("ms").trim_end_matches('s').parse::<f64>().is_ok()
}

/// Parses the seconds forms `const:`, `uniform:`, `exponential:`, `lognormal:`, `hist@`
/// and `wifi` (the caller has seen a unit, or one of the names that only exist in
/// seconds); the error is the reason alone.
pub(crate) fn parse(kind: &str, arg: &str) -> Result<SecondsDist, String> {
    let need = |x: &str, what: &str, example: &str| -> Result<f64, String> {
        duration(x).unwrap_or_else(|| {
            Err(format!("{what} `{}` has no time unit; write it in seconds, e.g. {example}", x.trim()))
        })
    };
    let num = |x: &str, what: &str| -> Result<f64, String> {
        x.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("{what} `{}` is not a finite number", x.trim()))
    };
    let d = match kind {
        "const" | "constant" => SecondsDist::Constant(need(arg, "the delay", "const:2s")?),
        "uniform" => {
            let (lo, hi) = arg.split_once(':').ok_or("write uniform:LOs:HIs, e.g. uniform:0s:20s")?;
            if has_unit(lo) != has_unit(hi) {
                return Err(format!(
                    "LO `{lo}` and HI `{hi}` must both be in seconds (uniform:0s:20s) or both in steps (uniform:0:26)"
                ));
            }
            let (lo, hi) = (need(lo, "LO", "uniform:0s:20s")?, need(hi, "HI", "uniform:0s:20s")?);
            if lo > hi {
                return Err(format!("LO = {lo} s is above HI = {hi} s"));
            }
            SecondsDist::Uniform(lo, hi)
        }
        "exponential" | "exp" => SecondsDist::Exponential(need(arg, "the mean", "exponential:4s")?),
        "lognormal" => {
            let (m, s) = arg.split_once(':').ok_or(
                "write lognormal:MEDIANs:SIGMA, e.g. lognormal:0.5s:0.8 (median in seconds, σ of ln d)",
            )?;
            let median = need(m, "the median", "lognormal:0.5s:0.8")?;
            let sigma = num(s, "σ")?;
            if median <= 0.0 {
                return Err("the median must be above 0 s, e.g. lognormal:0.5s:0.8".into());
            }
            if !(0.0..=5.0).contains(&sigma) {
                return Err(format!("σ = {sigma} must be in [0, 5] (the spread of ln d)"));
            }
            SecondsDist::LogNormal { median, sigma }
        }
        "wifi" if arg.is_empty() => SecondsDist::Wifi,
        "wifi" => return Err("the preset wifi takes no argument; write wifi".into()),
        k if k.starts_with("hist@") => {
            let bin = &k["hist@".len()..];
            let bin_s = need(bin, "the bin width", "hist@0.5s:1,2,1")?;
            if bin_s <= 0.0 {
                return Err("the bin width must be above 0 s, e.g. hist@0.5s:1,2,1".into());
            }
            let w = arg.split(',').map(|x| num(x, "weight")).collect::<Result<Vec<_>, _>>()?;
            let sum = w.iter().sum::<f64>();
            if w.iter().any(|&x| x < 0.0) || !(sum > 0.0 && sum.is_finite()) {
                return Err("weights must be ≥ 0 with a positive, finite sum".into());
            }
            SecondsDist::Histogram { bin_s, weights: w }
        }
        _ => return Err("not a delay in seconds".into()),
    };
    Ok(d)
}
