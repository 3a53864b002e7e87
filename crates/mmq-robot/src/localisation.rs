//! The absolute localiser (AMCL on a lidar map, or UWB beacons): a pose fix at a fixed
//! rate, the true pose plus a slowly varying bias plus white noise.
//!
//! The bias is a first-order Gauss–Markov process per component, sampled at the fixes:
//! b_{k+1} = ρ·b_k + √(1 − ρ²)·σ_b·ξ, ρ = exp(−Δt/τ), ξ ~ N(0, 1), started from its
//! stationary law N(0, σ_b²). A fix is z = truth + b + σ_w·ξ'. Latency is not modelled.

use mmq_core::Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::controller::wrap;
use crate::profile::RealisticConfig;

/// The localiser's state.
#[derive(Clone, Debug, PartialEq)]
pub struct Localiser {
    /// Time between fixes, seconds.
    pub period_s: f64,
    /// Time of the next fix, seconds since reset.
    pub next_s: f64,
    /// Bias (x m, y m, θ rad).
    bias: [f64; 3],
    /// Per fix bias autocorrelation ρ.
    rho: f64,
    /// Stationary bias standard deviations (x, y, θ).
    bias_sd: [f64; 3],
    /// White noise standard deviations (x, y, θ).
    white_sd: [f64; 3],
}

fn normal(rng: &mut Rng) -> f64 {
    StandardNormal.sample(rng)
}

impl Localiser {
    /// A localiser with the realistic model's parameters (bias at 0 until [`Localiser::reset`]).
    pub fn new(c: &RealisticConfig) -> Localiser {
        let period_s = 1.0 / c.fix_rate_hz;
        Localiser {
            period_s,
            next_s: period_s,
            bias: [0.0; 3],
            rho: libm::exp(-period_s / c.fix_bias_tau_s),
            bias_sd: [c.fix_bias_sd_m, c.fix_bias_sd_m, c.fix_bias_sd_rad],
            white_sd: [c.fix_sd_m, c.fix_sd_m, c.fix_sd_rad],
        }
    }

    /// Restarts at time 0: first fix after one period, bias drawn from its stationary law.
    pub fn reset(&mut self, rng: &mut Rng) {
        self.next_s = self.period_s;
        for i in 0..3 {
            self.bias[i] = self.bias_sd[i] * normal(rng);
        }
    }

    /// The variance the filter assumes for each component of a fix (white² + bias²).
    pub fn assumed_variance(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| self.white_sd[i] * self.white_sd[i] + self.bias_sd[i] * self.bias_sd[i])
    }

    /// A fix of the true pose `truth` if one is due at time `t_s` (then schedules the
    /// next); draws 6 normals per fix.
    pub fn poll(&mut self, t_s: f64, truth: (f64, f64, f64), rng: &mut Rng) -> Option<(f64, f64, f64)> {
        if t_s < self.next_s {
            return None;
        }
        self.next_s += self.period_s;
        let k = libm::sqrt((1.0 - self.rho * self.rho).max(0.0));
        let mut z = [truth.0, truth.1, truth.2];
        for (i, zi) in z.iter_mut().enumerate() {
            self.bias[i] = self.rho * self.bias[i] + k * self.bias_sd[i] * normal(rng);
            *zi += self.bias[i] + self.white_sd[i] * normal(rng);
        }
        Some((z[0], z[1], wrap(z[2])))
    }
}

#[cfg(test)]
mod tests {
    use mmq_core::seed::rng_from_seed;

    use super::*;
    use crate::config::Preset;

    #[test]
    fn fixes_come_at_the_rate() {
        let c = RealisticConfig { fix_rate_hz: 4.0, ..RealisticConfig::for_preset(Preset::default()) };
        let mut l = Localiser::new(&c);
        let mut rng = rng_from_seed(1);
        l.reset(&mut rng);
        let mut n = 0;
        for k in 1..=600 {
            // 10 s at 60 Hz.
            if l.poll(k as f64 / 60.0, (0.0, 0.0, 0.0), &mut rng).is_some() {
                n += 1;
            }
        }
        assert_eq!(n, 40);
    }

    #[test]
    fn error_statistics_match_the_model() {
        // Many fixes of a robot at rest: the error's variance is white² + bias², and
        // consecutive biases correlate with ρ = exp(−period/τ). Bounds are 5 standard
        // errors wide for 200 independent runs of 400 fixes.
        let c = RealisticConfig {
            fix_rate_hz: 5.0,
            fix_sd_m: 0.03,
            fix_bias_sd_m: 0.04,
            fix_bias_tau_s: 1.0,
            ..RealisticConfig::for_preset(Preset::default())
        };
        let mut rng = rng_from_seed(7);
        let (mut sum2, mut n) = (0.0, 0.0);
        let (mut lag, mut lag_n) = (0.0, 0.0);
        for _ in 0..200 {
            let mut l = Localiser::new(&c);
            l.reset(&mut rng);
            let mut prev: Option<f64> = None;
            for k in 1..=400 {
                let z = l.poll(k as f64 * 0.2 + 1e-9, (0.0, 0.0, 0.0), &mut rng).unwrap();
                sum2 += z.0 * z.0;
                n += 1.0;
                if let Some(p) = prev {
                    lag += p * z.0;
                    lag_n += 1.0;
                }
                prev = Some(z.0);
            }
        }
        let var = sum2 / n;
        assert!((var - 0.0025).abs() < 0.0025 * 0.05, "variance {var}");
        // Lag-1 covariance: ρ·σ_b² (white noise is independent) = e^{−0.2}·0.0016.
        let cov = lag / lag_n;
        let want = (-0.2f64).exp() * 0.0016;
        assert!((cov - want).abs() < want * 0.1, "lag-1 covariance {cov} vs {want}");
    }
}
