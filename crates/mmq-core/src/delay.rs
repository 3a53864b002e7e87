//! Reward delay distributions: how long after its emission a reward arrives, in decision
//! steps or in seconds of simulated time.
//!
//! Spec strings (CLI `--delay`, world and sweep files). In steps (the paper):
//!
//! | spec | distribution | mean |
//! |---|---|---|
//! | `none` | d = 0 | 0 |
//! | `const:K` | d = K | K |
//! | `poisson:L` | Poisson(L), the paper | L |
//! | `geometric:P` | failures before the first success, success probability P | (1−P)/P |
//! | `uniform:LO:HI` | uniform on the integers LO..=HI | (LO+HI)/2 |
//! | `hist:W0,W1,...` | P(d = k) ∝ Wk (an empirical histogram) | Σ k Wk / Σ Wk |
//! | `mix:P1*SPEC1+P2*SPEC2` | mixture with weights ∝ Pi | Σ Pi·mean_i / Σ Pi |
//!
//! In seconds (a number with the unit `s` or `ms`; printed in `s`):
//!
//! | spec | distribution | mean |
//! |---|---|---|
//! | `const:2s` | d = 2 s | 2 s |
//! | `uniform:0s:20s` | uniform on [0 s, 20 s] | (LO+HI)/2 |
//! | `exponential:4s` | exponential with mean 4 s (also `exp:4s`) | 4 s |
//! | `lognormal:0.5s:0.8` | ln d ~ N(ln 0.5 s, 0.8²): median 0.5 s, σ of ln d | median·e^{σ²/2} |
//! | `hist@0.5s:W0,W1,...` | P(k·0.5 s ≤ d < (k+1)·0.5 s) ∝ Wk, uniform within a bin | 0.5 s·Σ (k+½) Wk / Σ Wk |
//! | `wifi` | one WiFi hop's latency, after Sui et al., MobiSys 2016 ([`seconds::WIFI`]) | 14.4 ms |
//! | `mix:P1*SPEC1+P2*SPEC2` | mixture of specs in seconds | Σ Pi·mean_i / Σ Pi |
//!
//! A mixture is all in steps or all in seconds. A reward delayed by d seconds is delivered
//! with the first decision that ends at or after its emission time + d
//! ([`crate::channel::DelayedReward`]); the environment's clock is `Telemetry::sim_time_s` (the
//! robot's physics; the grid's nominal `step_period_s` per step).

use std::fmt;

use rand::RngExt;
use rand_distr::Distribution;

use crate::seed::Rng;

pub mod seconds;

pub use seconds::{SecondsDist, SecondsSampler};

/// Largest mean delay accepted (steps); bigger ones cannot be buffered sensibly.
pub const MAX_MEAN_DELAY: f64 = 1.0e6;

/// The unit a delay is drawn in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DelayUnit {
    /// Decision steps.
    Steps,
    /// Seconds of simulated time.
    Seconds,
}

impl DelayUnit {
    /// The unit's short name (`steps`, `s`).
    pub fn name(self) -> &'static str {
        match self {
            DelayUnit::Steps => "steps",
            DelayUnit::Seconds => "s",
        }
    }
}

/// A delay distribution over d ∈ {0, 1, 2, ...} steps, or (the variant
/// [`DelayDist::Seconds`]) over d ≥ 0 seconds of simulated time.
#[derive(Clone, Debug, PartialEq)]
pub enum DelayDist {
    /// No delay.
    None,
    /// Always K steps.
    Constant(u32),
    /// Poisson with mean λ (the paper).
    Poisson(f64),
    /// Geometric: failures before the first success with probability p.
    Geometric(f64),
    /// Uniform on lo..=hi.
    Uniform(u32, u32),
    /// P(d = k) ∝ `weights[k]`.
    Empirical(Vec<f64>),
    /// Mixture: (weight, component).
    Mixture(Vec<(f64, DelayDist)>),
    /// A delay in seconds of simulated time.
    Seconds(SecondsDist),
}

/// A delay spec that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("delay `{spec}`: {reason}")]
pub struct DelayError {
    /// The spec as given.
    pub spec: String,
    /// What is wrong and what is accepted.
    pub reason: String,
}

const ACCEPTED: &str = "use none, const:K, poisson:L, geometric:P, uniform:LO:HI, hist:W0,W1,... or mix:P1*SPEC1+P2*SPEC2 (steps), or const:2s, uniform:0s:20s, exponential:4s, lognormal:0.5s:0.8, hist@0.5s:W0,W1,..., wifi (seconds)";

impl DelayDist {
    /// Parses a spec string (see the module docs).
    pub fn parse(spec: &str) -> Result<DelayDist, DelayError> {
        let fail = |reason: String| DelayError { spec: spec.to_string(), reason };
        let s = spec.trim();
        let (kind, arg) = s.split_once(':').unwrap_or((s, ""));
        let num = |x: &str, what: &str| -> Result<f64, DelayError> {
            x.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| fail(format!("{what} `{x}` is not a finite number")))
        };
        let int = |x: &str, what: &str| -> Result<u32, DelayError> {
            x.trim()
                .parse::<u32>()
                .map_err(|_| fail(format!("{what} `{x}` is not a whole number of steps ≥ 0")))
        };
        let kind = kind.to_ascii_lowercase();
        let in_seconds = matches!(kind.as_str(), "exponential" | "exp" | "lognormal" | "wifi")
            || kind.starts_with("hist@")
            || (matches!(kind.as_str(), "const" | "constant" | "uniform")
                && arg.split(':').any(seconds::has_unit));
        if in_seconds {
            let d = seconds::parse(&kind, arg).map_err(&fail)?;
            return Self::checked(DelayDist::Seconds(d), spec);
        }
        if matches!(kind.as_str(), "poisson" | "geometric" | "geom" | "hist" | "empirical")
            && arg.split([':', ',']).any(seconds::has_unit)
        {
            return Err(fail(format!(
                "{kind} counts decision steps and takes no time unit; for a delay in seconds use const:2s, uniform:0s:20s, exponential:4s, lognormal:0.5s:0.8, hist@0.5s:W0,W1,... or wifi"
            )));
        }
        let d = match kind.as_str() {
            "none" | "0" if arg.is_empty() => DelayDist::None,
            "const" | "constant" => DelayDist::Constant(int(arg, "K")?),
            "poisson" => {
                let l = num(arg, "λ")?;
                if l < 0.0 {
                    return Err(fail(format!("λ = {l} is negative; a Poisson mean must be ≥ 0")));
                }
                DelayDist::Poisson(l)
            }
            "geometric" | "geom" => {
                let p = num(arg, "P")?;
                if !(p > 0.0 && p <= 1.0) {
                    return Err(fail(format!("P = {p} must be in (0, 1]")));
                }
                DelayDist::Geometric(p)
            }
            "uniform" => {
                let (lo, hi) = arg
                    .split_once(':')
                    .ok_or_else(|| fail("write uniform:LO:HI, e.g. uniform:0:26".into()))?;
                let (lo, hi) = (int(lo, "LO")?, int(hi, "HI")?);
                if lo > hi {
                    return Err(fail(format!("LO = {lo} is above HI = {hi}")));
                }
                DelayDist::Uniform(lo, hi)
            }
            "hist" | "empirical" => {
                let w = arg.split(',').map(|x| num(x, "weight")).collect::<Result<Vec<_>, _>>()?;
                // A sum that overflows to infinity would make every probability 0 and the
                // mean NaN.
                let sum = w.iter().sum::<f64>();
                if w.iter().any(|&x| x < 0.0) || !(sum > 0.0 && sum.is_finite()) {
                    return Err(fail("weights must be ≥ 0 with a positive, finite sum".into()));
                }
                DelayDist::Empirical(w)
            }
            "mix" | "mixture" => {
                let mut parts = Vec::new();
                for part in arg.split('+') {
                    let (w, sub) = part
                        .split_once('*')
                        .ok_or_else(|| fail(format!("mixture part `{part}` must be WEIGHT*SPEC")))?;
                    let w = num(w, "weight")?;
                    if w <= 0.0 {
                        return Err(fail(format!("mixture weight {w} must be positive")));
                    }
                    let sub = DelayDist::parse(sub).map_err(|e| fail(e.reason))?;
                    parts.push((w, sub));
                }
                let sum: f64 = parts.iter().map(|p| p.0).sum();
                if !sum.is_finite() {
                    return Err(fail(format!(
                        "the mixture weights add up to {sum}; use finite weights, e.g. mix:0.5*poisson:3+0.5*poisson:25"
                    )));
                }
                let secs: Vec<(f64, SecondsDist)> =
                    parts.iter().filter_map(|(w, d)| d.as_seconds().map(|d| (*w, d.clone()))).collect();
                if secs.len() == parts.len() {
                    DelayDist::Seconds(SecondsDist::Mixture(secs))
                } else if !secs.is_empty() {
                    return Err(fail(
                        "a mixture is all in steps or all in seconds; give every part a time unit, e.g. mix:0.5*const:0s+0.5*exponential:4s".into(),
                    ));
                } else {
                    DelayDist::Mixture(parts)
                }
            }
            _ => return Err(fail(format!("unknown distribution; {ACCEPTED}"))),
        };
        Self::checked(d, spec)
    }

    /// Refuses a distribution whose mean is NaN or too large.
    fn checked(d: DelayDist, spec: &str) -> Result<DelayDist, DelayError> {
        // A NaN mean (e.g. hist weights whose k·w overflow) is refused too.
        let (m, v) = (d.mean(), d.variance());
        if m.is_nan() || m > MAX_MEAN_DELAY || (d.unit() == DelayUnit::Seconds && !v.is_finite()) {
            return Err(DelayError {
                spec: spec.to_string(),
                reason: format!(
                    "the mean delay {} {} is above the supported {MAX_MEAN_DELAY} {}",
                    crate::stats::compact(m),
                    d.unit().name(),
                    d.unit().name()
                ),
            });
        }
        Ok(d)
    }

    /// The unit the delay is drawn in.
    pub fn unit(&self) -> DelayUnit {
        match self {
            DelayDist::Seconds(_) => DelayUnit::Seconds,
            _ => DelayUnit::Steps,
        }
    }

    /// The distribution in seconds, if it is one.
    pub fn as_seconds(&self) -> Option<&SecondsDist> {
        match self {
            DelayDist::Seconds(d) => Some(d),
            _ => None,
        }
    }

    /// Mean delay in the distribution's [`unit`](Self::unit) (steps, or seconds).
    pub fn mean(&self) -> f64 {
        match self {
            DelayDist::Seconds(d) => d.mean(),
            DelayDist::None => 0.0,
            DelayDist::Constant(k) => *k as f64,
            DelayDist::Poisson(l) => *l,
            DelayDist::Geometric(p) => (1.0 - p) / p,
            DelayDist::Uniform(lo, hi) => (*lo as f64 + *hi as f64) / 2.0,
            DelayDist::Empirical(w) => {
                let s: f64 = w.iter().sum();
                w.iter().enumerate().map(|(k, x)| k as f64 * x).sum::<f64>() / s
            }
            DelayDist::Mixture(parts) => {
                let s: f64 = parts.iter().map(|p| p.0).sum();
                parts.iter().map(|(w, d)| w * d.mean()).sum::<f64>() / s
            }
        }
    }

    /// Variance of the delay in the distribution's unit, squared.
    pub fn variance(&self) -> f64 {
        match self {
            DelayDist::Seconds(d) => d.variance(),
            DelayDist::None | DelayDist::Constant(_) => 0.0,
            DelayDist::Poisson(l) => *l,
            DelayDist::Geometric(p) => (1.0 - p) / (p * p),
            DelayDist::Uniform(lo, hi) => {
                let n = (*hi - *lo + 1) as f64;
                (n * n - 1.0) / 12.0
            }
            _ => {
                let m = self.mean();
                self.second_moment() - m * m
            }
        }
    }

    fn second_moment(&self) -> f64 {
        match self {
            DelayDist::Empirical(w) => {
                let s: f64 = w.iter().sum();
                w.iter().enumerate().map(|(k, x)| (k * k) as f64 * x).sum::<f64>() / s
            }
            DelayDist::Mixture(parts) => {
                let s: f64 = parts.iter().map(|p| p.0).sum();
                parts.iter().map(|(w, d)| w * (d.variance() + d.mean() * d.mean())).sum::<f64>() / s
            }
            other => other.variance() + other.mean() * other.mean(),
        }
    }

    /// P(d = k) for a delay in steps; for a delay in seconds, P(k s ≤ d < (k+1) s).
    pub fn pmf(&self, k: u32) -> f64 {
        match self {
            DelayDist::Seconds(d) => d.cdf(f64::from(k) + 1.0) - d.cdf(f64::from(k)),
            DelayDist::None => f64::from(k == 0),
            DelayDist::Constant(c) => f64::from(k == *c),
            DelayDist::Poisson(l) => {
                if *l == 0.0 {
                    return f64::from(k == 0);
                }
                // exp(k ln λ − λ − ln k!)
                let lnfact: f64 = (1..=k).map(|i| (i as f64).ln()).sum();
                (k as f64 * l.ln() - l - lnfact).exp()
            }
            DelayDist::Geometric(p) => p * (1.0 - p).powi(k as i32),
            DelayDist::Uniform(lo, hi) => {
                if (*lo..=*hi).contains(&k) {
                    1.0 / (*hi - *lo + 1) as f64
                } else {
                    0.0
                }
            }
            DelayDist::Empirical(w) => w.get(k as usize).copied().unwrap_or(0.0) / w.iter().sum::<f64>(),
            DelayDist::Mixture(parts) => {
                let s: f64 = parts.iter().map(|p| p.0).sum();
                parts.iter().map(|(w, d)| w * d.pmf(k)).sum::<f64>() / s
            }
        }
    }

    /// A sampler for this distribution.
    pub fn sampler(&self) -> DelaySampler {
        DelaySampler::new(self)
    }
}

impl fmt::Display for DelayDist {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DelayDist::None => write!(f, "none"),
            DelayDist::Constant(k) => write!(f, "const:{k}"),
            DelayDist::Poisson(l) => write!(f, "poisson:{l}"),
            DelayDist::Geometric(p) => write!(f, "geometric:{p}"),
            DelayDist::Uniform(lo, hi) => write!(f, "uniform:{lo}:{hi}"),
            DelayDist::Empirical(w) => {
                let s: Vec<String> = w.iter().map(|x| x.to_string()).collect();
                write!(f, "hist:{}", s.join(","))
            }
            DelayDist::Mixture(parts) => {
                let s: Vec<String> = parts.iter().map(|(w, d)| format!("{w}*{d}")).collect();
                write!(f, "mix:{}", s.join("+"))
            }
            DelayDist::Seconds(d) => write!(f, "{d}"),
        }
    }
}

impl std::str::FromStr for DelayDist {
    type Err = DelayError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        DelayDist::parse(s)
    }
}

/// Draws delays from a [`DelayDist`].
#[derive(Clone, Debug)]
pub enum DelaySampler {
    /// Always this many steps.
    Fixed(u32),
    /// Poisson via rand_distr.
    Poisson(rand_distr::Poisson<f64>),
    /// Geometric via rand_distr.
    Geometric(rand_distr::Geometric),
    /// Uniform on lo..=hi.
    Uniform(u32, u32),
    /// Inverse CDF over a finite histogram.
    Table(Vec<f64>),
    /// Mixture: cumulative weights and components.
    Mixture(Vec<f64>, Vec<DelaySampler>),
    /// A delay in seconds ([`DelaySampler::sample`] rounds it up to whole seconds; the
    /// channel draws with [`SecondsSampler::sample`]).
    Seconds(SecondsSampler),
}

impl DelaySampler {
    fn new(d: &DelayDist) -> Self {
        match d {
            DelayDist::None => DelaySampler::Fixed(0),
            DelayDist::Constant(k) => DelaySampler::Fixed(*k),
            DelayDist::Poisson(l) if *l == 0.0 => DelaySampler::Fixed(0),
            DelayDist::Poisson(l) => {
                DelaySampler::Poisson(rand_distr::Poisson::new(*l).expect("λ validated > 0 and finite"))
            }
            DelayDist::Geometric(p) if *p >= 1.0 => DelaySampler::Fixed(0),
            DelayDist::Geometric(p) => {
                DelaySampler::Geometric(rand_distr::Geometric::new(*p).expect("p validated in (0, 1)"))
            }
            DelayDist::Uniform(lo, hi) => DelaySampler::Uniform(*lo, *hi),
            DelayDist::Seconds(d) => DelaySampler::Seconds(d.sampler()),
            DelayDist::Empirical(w) => {
                let s: f64 = w.iter().sum();
                let mut acc = 0.0;
                DelaySampler::Table(
                    w.iter()
                        .map(|x| {
                            acc += x / s;
                            acc
                        })
                        .collect(),
                )
            }
            DelayDist::Mixture(parts) => {
                let s: f64 = parts.iter().map(|p| p.0).sum();
                let mut acc = 0.0;
                let cum = parts
                    .iter()
                    .map(|(w, _)| {
                        acc += w / s;
                        acc
                    })
                    .collect();
                DelaySampler::Mixture(cum, parts.iter().map(|(_, d)| DelaySampler::new(d)).collect())
            }
        }
    }

    /// One delay in steps (a delay in seconds: rounded up to whole seconds).
    pub fn sample(&self, rng: &mut Rng) -> u32 {
        match self {
            DelaySampler::Seconds(s) => s.sample(rng).ceil().min(u32::MAX as f64) as u32,
            DelaySampler::Fixed(k) => *k,
            DelaySampler::Poisson(p) => {
                let x: f64 = p.sample(rng);
                x.min(u32::MAX as f64) as u32
            }
            DelaySampler::Geometric(g) => g.sample(rng).min(u32::MAX as u64) as u32,
            DelaySampler::Uniform(lo, hi) => rng.random_range(*lo..=*hi),
            DelaySampler::Table(cdf) => pick(cdf, rng.random::<f64>()) as u32,
            DelaySampler::Mixture(cum, comps) => comps[pick(cum, rng.random::<f64>())].sample(rng),
        }
    }
}

fn pick(cdf: &[f64], u: f64) -> usize {
    cdf.iter().position(|&c| u < c).unwrap_or(cdf.len() - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seed::rng_from_seed;

    #[test]
    fn parses_and_prints_round_trip() {
        for s in [
            "none",
            "const:3",
            "poisson:13",
            "geometric:0.25",
            "uniform:0:26",
            "hist:1,0,2",
            "mix:0.5*poisson:3+0.5*poisson:25",
        ] {
            let d = DelayDist::parse(s).unwrap();
            assert_eq!(d.to_string(), s);
            assert_eq!(DelayDist::parse(&d.to_string()).unwrap(), d);
        }
    }

    #[test]
    fn rejects_impossible_specs() {
        for (s, needle) in [
            ("poisson:-1", "negative"),
            ("poisson:NaN", "not a finite"),
            ("poisson:1e9", "above the supported"),
            ("uniform:5:2", "above HI"),
            ("geometric:0", "(0, 1]"),
            ("gauss:3", "unknown distribution"),
            ("hist:0,0", "positive, finite sum"),
            ("hist:1e308,1e308", "positive, finite sum"),
            ("mix:1e308*geom:1+1e308*geom:1", "mixture weights add up to inf"),
        ] {
            let e = DelayDist::parse(s).unwrap_err().to_string();
            assert!(e.contains(needle), "{s}: {e}");
        }
    }

    fn moments(d: &DelayDist, n: usize, seed: u64) -> (f64, f64) {
        let s = d.sampler();
        let mut rng = rng_from_seed(seed);
        let xs: Vec<f64> = (0..n).map(|_| s.sample(&mut rng) as f64).collect();
        let m = xs.iter().sum::<f64>() / n as f64;
        let v = xs.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n as f64 - 1.0);
        (m, v)
    }

    /// Sample mean and variance lie within 5 standard errors of the truth (a fixed seed
    /// makes this deterministic; the bound makes it a real check, not a snapshot).
    #[test]
    fn sample_moments_match_the_distribution() {
        let n = 200_000;
        for spec in [
            "poisson:13",
            "poisson:0.5",
            "geometric:0.2",
            "uniform:0:26",
            "hist:1,2,3,4",
            "mix:0.5*poisson:3+0.5*poisson:25",
        ] {
            let d = DelayDist::parse(spec).unwrap();
            let (m, v) = moments(&d, n, 42);
            let se_mean = (d.variance() / n as f64).sqrt();
            assert!((m - d.mean()).abs() < 5.0 * se_mean, "{spec}: mean {m} vs {}", d.mean());
            // Var of the sample variance ≈ (μ4 − σ⁴)/n; bound μ4 by 3σ⁴ + σ² (Poisson-like tails).
            let sig2 = d.variance();
            let se_var = ((3.0 * sig2 * sig2 + sig2 + 20.0 * sig2 * sig2) / n as f64).sqrt();
            assert!((v - sig2).abs() < 5.0 * se_var, "{spec}: var {v} vs {sig2}");
        }
    }

    #[test]
    fn poisson_histogram_matches_pmf() {
        let d = DelayDist::Poisson(13.0);
        let s = d.sampler();
        let mut rng = rng_from_seed(1);
        let n = 100_000;
        let mut hist = vec![0usize; 60];
        for _ in 0..n {
            hist[(s.sample(&mut rng) as usize).min(59)] += 1;
        }
        // Pearson χ² over bins 3..=25 (expected counts ≥ 40), 23 bins: the 99.99 % quantile is ≈ 55.
        let chi2: f64 = (3..=25u32)
            .map(|k| {
                let e = d.pmf(k) * n as f64;
                let o = hist[k as usize] as f64;
                (o - e) * (o - e) / e
            })
            .sum();
        assert!(chi2 < 55.0, "χ² = {chi2}");
        let total: f64 = (0..200).map(|k| d.pmf(k)).sum();
        assert!((total - 1.0).abs() < 1e-12);
    }

    #[test]
    fn pmfs_sum_to_one_and_match_means() {
        for spec in
            ["poisson:13", "geometric:0.3", "uniform:2:9", "hist:3,0,1", "mix:1*const:2+3*uniform:0:4"]
        {
            let d = DelayDist::parse(spec).unwrap();
            let total: f64 = (0..400).map(|k| d.pmf(k)).sum();
            let mean: f64 = (0..400).map(|k| k as f64 * d.pmf(k)).sum();
            assert!((total - 1.0).abs() < 1e-9, "{spec}");
            assert!((mean - d.mean()).abs() < 1e-6, "{spec}");
        }
    }
}
