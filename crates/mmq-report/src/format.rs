//! Numbers as every report and the CLI print them: one way throughout. Means carry their
//! 95 % interval as "99.3 ± 3.2 %", negative numbers a Unicode minus ("−5.1"), a single
//! seed "± n/a" (one sample has no interval), and an absent value "—".

use mmq_core::stats::MeanCi;

/// `x` with `digits` decimals and a Unicode minus; "—" when not finite.
pub fn signed(x: f64, digits: usize) -> String {
    if !x.is_finite() {
        return "—".into();
    }
    let s = format!("{x:.digits$}");
    // "-0.0" reads as "0.0"
    if s.starts_with('-') && s[1..].chars().all(|c| c == '0' || c == '.') {
        return s[1..].to_string();
    }
    s.replacen('-', "−", 1)
}

/// The interval part: "± 3.2", or "± n/a" for fewer than two samples.
fn interval(m: &MeanCi, scale: f64, digits: usize) -> String {
    if m.n < 2 || !m.ci95.is_finite() {
        "± n/a".into()
    } else {
        format!("± {}", signed(scale * m.ci95, digits))
    }
}

/// A mean of fractions as a percentage: "99.3 ± 3.2 %" ("—" when absent).
pub fn mean_pct(m: &MeanCi) -> String {
    if !m.mean.is_finite() {
        return "—".into();
    }
    format!("{} {} %", signed(100.0 * m.mean, 1), interval(m, 100.0, 1))
}

/// A mean as a plain number: "0.512 ± 0.060" ("—" when absent).
pub fn mean_num(m: &MeanCi, digits: usize) -> String {
    if !m.mean.is_finite() {
        return "—".into();
    }
    format!("{} {}", signed(m.mean, digits), interval(m, 1.0, digits))
}

/// A mean as a percentage or a plain number with four decimals.
pub fn mean(m: &MeanCi, pct: bool) -> String {
    if pct { mean_pct(m) } else { mean_num(m, 4) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mmq_core::stats::mean_ci;

    #[test]
    fn one_way_throughout() {
        assert_eq!(mean_pct(&mean_ci(&[0.98, 1.0])), "99.0 ± 12.7 %");
        assert_eq!(mean_pct(&mean_ci(&[-0.051])), "−5.1 ± n/a %");
        assert_eq!(mean_num(&mean_ci(&[0.5, 0.5]), 3), "0.500 ± 0.000");
        assert_eq!(mean_num(&mean_ci(&[]), 3), "—");
        assert_eq!(signed(-0.00001, 2), "0.00");
        assert_eq!(signed(-1234.5, 1), "−1234.5");
        assert_eq!(signed(f64::NAN, 1), "—");
    }
}
