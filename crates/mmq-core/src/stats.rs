//! Small statistics over seeds: mean and a two-sided 95 % confidence interval from
//! Student's t distribution.

use serde::{Deserialize, Serialize};

/// Mean and 95 % interval half-width of a sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeanCi {
    /// Sample mean.
    pub mean: f64,
    /// Half-width of the 95 % confidence interval of the mean (0 for one sample).
    pub ci95: f64,
    /// Sample standard deviation.
    pub std: f64,
    /// Number of samples.
    pub n: usize,
}

/// t_{0.975, df} for df = 1..=30; beyond 30 a smooth approximation is used.
const T975: [f64; 30] = [
    12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
    2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042,
];

/// The 97.5 % quantile of Student's t with `df` degrees of freedom.
pub fn t975(df: usize) -> f64 {
    match df {
        0 => f64::NAN,
        1..=30 => T975[df - 1],
        // Cornish–Fisher style expansion around the normal quantile; error < 1e-3 here.
        _ => {
            let z = 1.959_964;
            let d = df as f64;
            z + (z * z * z + z) / (4.0 * d) + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * d * d)
        }
    }
}

/// A number for a message: plain where that is short (`0.5`, `-1`, `150000`), in
/// scientific notation where the plain form would run to many digits (`1e308`, `1e-9`).
pub fn compact(x: f64) -> String {
    let plain = x.to_string();
    let tiny = x != 0.0 && x.abs() < 1e-4;
    if plain.len() <= 16 && !tiny { plain } else { format!("{x:e}") }
}

/// Mean and 95 % interval of `xs`.
pub fn mean_ci(xs: &[f64]) -> MeanCi {
    let n = xs.len();
    if n == 0 {
        return MeanCi { mean: f64::NAN, ci95: f64::NAN, std: f64::NAN, n };
    }
    let mean = xs.iter().sum::<f64>() / n as f64;
    if n == 1 {
        return MeanCi { mean, ci95: 0.0, std: 0.0, n };
    }
    let var = xs.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1) as f64;
    let std = var.sqrt();
    MeanCi { mean, ci95: t975(n - 1) * std / (n as f64).sqrt(), std, n }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_in_messages_stay_short() {
        assert_eq!(compact(0.5), "0.5");
        assert_eq!(compact(-1.0), "-1");
        assert_eq!(compact(1e308), "1e308");
        assert_eq!(compact(1e-9), "1e-9");
        assert_eq!(compact(f64::NAN), "NaN");
    }

    #[test]
    fn interval_by_hand() {
        // xs = 1, 2, 3: mean 2, s = 1, t(2) = 4.303, half-width 4.303/√3.
        let m = mean_ci(&[1.0, 2.0, 3.0]);
        assert_eq!(m.mean, 2.0);
        assert!((m.std - 1.0).abs() < 1e-12);
        assert!((m.ci95 - 4.303 / 3f64.sqrt()).abs() < 1e-12);
        assert_eq!(mean_ci(&[5.0]).ci95, 0.0);
        assert!((t975(40) - 2.021).abs() < 2e-3);
        assert!((t975(120) - 1.980).abs() < 2e-3);
    }
}
