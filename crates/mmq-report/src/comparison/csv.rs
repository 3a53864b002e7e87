//! The learner comparison's CSV files: `comparison.csv` (a row per setting),
//! `comparison-delay.csv` (the delay estimate over time) and `comparison-pmf.csv` (the
//! estimated pmf at the end beside the truth). Delay specs that hold commas are quoted.

use std::fmt::Write as _;

use mmq_lab::LabError;
use mmq_lab::comparison::{Outcome, truth};
use mmq_lab::output::csv_field;

/// One CSV row per setting.
pub(super) fn outcomes_csv(outs: &[Outcome]) -> String {
    let mut s = String::from(
        "world,delay,epsilon,learner,told,n,relative,relative_ci95,fraction,fraction_ci95,greedy,greedy_ci95,greedy_min,greedy_optimal_seeds,median_est_final,median_est_final_ci95,median_error_max_at_50k,lobe_low,lobe_high,seconds_per_seed,probes_per_seed,ceiling_fraction,ceiling_fraction_ci95,regret,regret_ci95\n",
    );
    for o in outs {
        let st = &o.setting;
        let last = o.median_curve.last().map(|x| x.1);
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            csv_field(&st.world),
            csv_field(&st.delay),
            st.epsilon,
            st.learner.name(),
            st.told,
            o.n,
            o.relative.mean,
            o.relative.ci95,
            o.fraction.mean,
            o.fraction.ci95,
            o.greedy.mean,
            o.greedy.ci95,
            o.greedy_min,
            o.greedy_optimal,
            last.map_or(String::new(), |m| m.mean.to_string()),
            last.map_or(String::new(), |m| m.ci95.to_string()),
            o.median_error_max.map_or(String::new(), |x| x.to_string()),
            o.lobes.map_or(String::new(), |l| l.0.mean.to_string()),
            o.lobes.map_or(String::new(), |l| l.1.mean.to_string()),
            o.seconds.mean,
            o.probes.map_or(String::new(), |p| p.mean.to_string()),
            o.ceiling.map_or(String::new(), |c| c.mean.to_string()),
            o.ceiling.map_or(String::new(), |c| c.ci95.to_string()),
            o.regret.mean,
            o.regret.ci95
        );
    }
    s
}

/// The delay estimate over time: one row per (setting, snapshot).
pub(super) fn delay_csv(outs: &[Outcome]) -> Result<String, LabError> {
    let mut s = String::from(
        "world,delay,epsilon,learner,step,median_est,median_ci95,mean_est,mean_ci95,true_median,true_mean\n",
    );
    for o in outs.iter().filter(|o| !o.median_curve.is_empty()) {
        let st = &o.setting;
        let (_, tmed, tmean) = truth(&st.delay)?;
        for ((t, m), (_, a)) in o.median_curve.iter().zip(&o.mean_curve) {
            let _ = writeln!(
                s,
                "{},{},{},{},{t},{},{},{},{},{tmed},{tmean}",
                csv_field(&st.world),
                csv_field(&st.delay),
                st.epsilon,
                st.learner.name(),
                m.mean,
                m.ci95,
                a.mean,
                a.ci95
            );
        }
    }
    Ok(s)
}

/// Estimated pmfs at the end (mean over seeds) next to the truth: one row per delay k.
pub(super) fn pmf_csv(outs: &[Outcome]) -> Result<String, LabError> {
    let mut s = String::from("world,delay,epsilon,learner,k,p_est,p_true\n");
    for o in outs.iter().filter(|o| !o.pmf.is_empty() && !o.setting.told) {
        let st = &o.setting;
        let (tp, _, _) = truth(&st.delay)?;
        for (k, (pe, pt)) in o.pmf.iter().zip(&tp).enumerate() {
            let (world, delay) = (csv_field(&st.world), csv_field(&st.delay));
            let _ = writeln!(s, "{world},{delay},{},{},{k},{pe},{pt}", st.epsilon, st.learner.name());
        }
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use mmq_core::stats::mean_ci;
    use mmq_lab::comparison::{DELAY_NAMES, Setting};
    use mmq_learn::LearnerKind;

    use super::*;

    const WIFI_HIST: &str = DELAY_NAMES[2].1;

    /// The WiFi histogram's spec holds commas: every CSV quotes it, so each row has the
    /// header's number of fields when read by a CSV reader (RFC 4180 quoting).
    #[test]
    fn csv_rows_quote_delay_specs_with_commas() {
        let m = |x: f64| mean_ci(&[x]);
        let o = Outcome {
            setting: Setting {
                world: "paper-9x9".into(),
                delay: WIFI_HIST.into(),
                delay_label: "wifi".into(),
                epsilon: 0.05,
                learner: LearnerKind::DeconvQ,
                told: false,
                headline: true,
            },
            n: 1,
            relative: m(1.0),
            fraction: m(0.9),
            ceiling: Some(m(0.91)),
            regret: m(100.0),
            greedy: m(0.58),
            greedy_min: 0.58,
            greedy_optimal: 1,
            seconds: m(2.0),
            median_curve: vec![(50_000, m(3.0))],
            mean_curve: vec![(50_000, m(4.0))],
            pmf: vec![1.0 / 51.0; 51],
            median_error_max: Some(0.5),
            lobes: None,
            probes: None,
        };
        let fields = |line: &str| {
            let (mut n, mut quoted) = (1, false);
            for ch in line.chars() {
                match ch {
                    '"' => quoted = !quoted,
                    ',' if !quoted => n += 1,
                    _ => {}
                }
            }
            n
        };
        let os = [o];
        for text in [outcomes_csv(&os), delay_csv(&os).unwrap(), pmf_csv(&os).unwrap()] {
            let mut lines = text.lines();
            let header = fields(lines.next().unwrap());
            let rows: Vec<&str> = lines.collect();
            assert!(!rows.is_empty());
            for row in rows {
                assert_eq!(fields(row), header, "{row}");
                assert!(row.contains(&format!("\"{WIFI_HIST}\"")), "{row}");
            }
        }
    }
}
