//! What a sweep job keeps of its seed beside its metrics when its spec asks
//! ([`super::SweepSpec::with_records`]), as a study does: the learning curves (its own and
//! its undelayed baseline's), the maps of the first-seed figures (visits, policies, the
//! greedy path) and the learner's delay estimate over time. The paper's report is drawn
//! from these records, read back from the sweep store bit for bit: every number is stored
//! as the text of Rust's shortest round-trip form (`NaN` and `inf` included).

use mmq_learn::Figure;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::runner::SeedResult;
use crate::trajectory::{CurveRow, Trajectory};

/// A seed's record, as a study stores it with the seed's metrics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SeedRecord {
    /// Master seed.
    pub seed: u64,
    /// The learner's run under delay.
    pub run: RunRecord,
    /// Its undelayed baseline's run (when the setting has one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baseline: Option<RunRecord>,
    /// Visits of every state during learning (empty without maps).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub visits: Vec<u64>,
    /// Average reward per step of the greedy policy from `S`.
    #[serde(with = "text")]
    pub greedy_per_step: f64,
    /// The first states of the greedy evaluation, from `S` (empty without maps).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub greedy_path: Vec<usize>,
    /// Greedy actions of every state as a bit set, all maximisers (empty without maps).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub policy_arrows: Vec<u8>,
    /// The probabilistic policy of every state (empty without maps).
    #[serde(default, skip_serializing_if = "Vec::is_empty", with = "text_rows")]
    pub policy_probs: Vec<Vec<f64>>,
    /// Wall-clock seconds of the seed.
    #[serde(with = "text")]
    pub wall_time_s: f64,
    /// The learner's delay estimate at each diagnostics sample: (step, median, mean).
    #[serde(default, skip_serializing_if = "Vec::is_empty", with = "samples")]
    pub delay_samples: Vec<(u64, f64, f64)>,
    /// Whether the learner's delay pmf is estimated (false: told, or none).
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub delay_estimated: bool,
    /// The learner's delay pmf at the end (learners that keep one).
    #[serde(default, skip_serializing_if = "Option::is_none", with = "opt_text_vec")]
    pub delay_pmf: Option<Vec<f64>>,
    /// The learner's figures at the end ([`Figure::Probes`], ...), stored by name.
    #[serde(default, skip_serializing_if = "Vec::is_empty", with = "named")]
    pub figures: Vec<(Figure, f64)>,
}

/// A run's totals and learning curve.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunRecord {
    /// Steps completed.
    pub steps_done: u64,
    /// Total reward emitted.
    #[serde(with = "text")]
    pub earned_total: f64,
    /// Total reward delivered.
    #[serde(with = "text")]
    pub received_total: f64,
    /// The learning curve: step, then earned, received, earned since the start and
    /// received since the start.
    #[serde(with = "curve")]
    pub curve: Vec<CurveRow>,
}

impl RunRecord {
    fn of(t: &Trajectory) -> Self {
        RunRecord {
            steps_done: t.steps_done,
            earned_total: t.earned_total,
            received_total: t.received_total,
            curve: t.curve.clone(),
        }
    }

    /// Earned reward per step.
    pub fn earned_per_step(&self) -> f64 {
        self.earned_total / self.steps_done.max(1) as f64
    }
}

impl SeedRecord {
    /// The record of a finished seed, with its maps (visits, policies, the greedy path)
    /// when `maps` (a study keeps them for each cell's first seed, which Figs. 7–12 draw).
    pub fn of(r: &SeedResult, maps: bool) -> Self {
        let delay_samples = r
            .run
            .diagnostics
            .iter()
            .filter_map(|s| s.diagnostics.delay.as_ref().map(|d| (s.step, d.median, d.mean)))
            .collect();
        SeedRecord {
            seed: r.seed,
            run: RunRecord::of(&r.run),
            baseline: r.baseline.as_ref().map(RunRecord::of),
            visits: if maps { r.run.visits.clone() } else { Vec::new() },
            greedy_per_step: r.greedy_per_step,
            greedy_path: if maps { r.greedy_path.clone() } else { Vec::new() },
            policy_arrows: if maps { r.policy_arrows.clone() } else { Vec::new() },
            policy_probs: if maps { r.policy_probs.clone() } else { Vec::new() },
            wall_time_s: r.wall_time_s,
            delay_samples,
            delay_estimated: r.diagnostics.delay.as_ref().is_some_and(|d| d.estimated),
            delay_pmf: r.diagnostics.delay.as_ref().map(|d| d.pmf.clone()),
            figures: r.diagnostics.figures.clone(),
        }
    }

    /// Relative performance: cumulative earned reward ÷ the baseline's; absent without a
    /// baseline and where the baseline earned nothing positive (as
    /// [`SeedResult::relative`]).
    pub fn relative(&self) -> Option<f64> {
        let b = self.baseline.as_ref()?;
        (b.earned_total > 0.0).then(|| self.run.earned_total / b.earned_total)
    }

    /// Earned reward per step.
    pub fn earned_per_step(&self) -> f64 {
        self.run.earned_per_step()
    }

    /// Whether it holds the seed's maps (visits, policies, the greedy path).
    pub fn has_maps(&self) -> bool {
        !self.policy_arrows.is_empty()
    }

    /// The learner's figure `f` at the end, if it reports it.
    pub fn figure(&self, f: Figure) -> Option<f64> {
        self.figures.iter().find(|(n, _)| *n == f).map(|(_, v)| *v)
    }
}

use super::store::encode;

fn decode<E: serde::de::Error>(s: &str) -> Result<f64, E> {
    s.parse::<f64>().map_err(|_| E::custom(format!("not a number: {s:?}")))
}

/// One number as its text.
mod text {
    use super::*;
    pub fn serialize<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&encode(*x))
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        decode(&String::deserialize(d)?)
    }
}

/// Numbers as their texts.
fn to_texts(xs: &[f64]) -> Vec<String> {
    xs.iter().map(|&x| encode(x)).collect()
}

fn from_texts<E: serde::de::Error>(xs: &[String]) -> Result<Vec<f64>, E> {
    xs.iter().map(|s| decode(s)).collect()
}

/// Rows of numbers as texts.
mod text_rows {
    use super::*;
    pub fn serialize<S: Serializer>(x: &[Vec<f64>], s: S) -> Result<S::Ok, S::Error> {
        x.iter().map(|r| to_texts(r)).collect::<Vec<_>>().serialize(s)
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Vec<f64>>, D::Error> {
        Vec::<Vec<String>>::deserialize(d)?.iter().map(|r| from_texts(r)).collect()
    }
}

/// An optional list of numbers as texts.
mod opt_text_vec {
    use super::*;
    pub fn serialize<S: Serializer>(x: &Option<Vec<f64>>, s: S) -> Result<S::Ok, S::Error> {
        x.as_deref().map(to_texts).serialize(s)
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Vec<f64>>, D::Error> {
        Option::<Vec<String>>::deserialize(d)?.map(|v| from_texts(&v)).transpose()
    }
}

/// Curve rows as `[step, earned, received, earned_cum, received_cum]`, numbers as texts.
mod curve {
    use super::*;
    pub fn serialize<S: Serializer>(x: &[CurveRow], s: S) -> Result<S::Ok, S::Error> {
        x.iter()
            .map(|r| {
                [
                    r.step.to_string(),
                    encode(r.earned),
                    encode(r.received),
                    encode(r.earned_cum),
                    encode(r.received_cum),
                ]
            })
            .collect::<Vec<_>>()
            .serialize(s)
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<CurveRow>, D::Error> {
        Vec::<[String; 5]>::deserialize(d)?
            .iter()
            .map(|r| {
                Ok(CurveRow {
                    step: r[0]
                        .parse()
                        .map_err(|_| serde::de::Error::custom(format!("not a step: {:?}", r[0])))?,
                    earned: decode(&r[1])?,
                    received: decode(&r[2])?,
                    earned_cum: decode(&r[3])?,
                    received_cum: decode(&r[4])?,
                })
            })
            .collect()
    }
}

/// Delay samples as `[step, median, mean]`.
mod samples {
    use super::*;
    pub fn serialize<S: Serializer>(x: &[(u64, f64, f64)], s: S) -> Result<S::Ok, S::Error> {
        x.iter().map(|r| [r.0.to_string(), encode(r.1), encode(r.2)]).collect::<Vec<_>>().serialize(s)
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<(u64, f64, f64)>, D::Error> {
        Vec::<[String; 3]>::deserialize(d)?
            .iter()
            .map(|r| {
                let t =
                    r[0].parse().map_err(|_| serde::de::Error::custom(format!("not a step: {:?}", r[0])))?;
                Ok((t, decode(&r[1])?, decode(&r[2])?))
            })
            .collect()
    }
}

/// Figures as `[[name, value], ...]`; a name no figure has is an error (the job is run
/// again by a version that knows it).
mod named {
    use super::*;
    pub fn serialize<S: Serializer>(x: &[(Figure, f64)], s: S) -> Result<S::Ok, S::Error> {
        x.iter().map(|(k, v)| [k.name().to_string(), encode(*v)]).collect::<Vec<_>>().serialize(s)
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<(Figure, f64)>, D::Error> {
        Vec::<[String; 2]>::deserialize(d)?
            .into_iter()
            .map(|[k, v]| {
                let f = Figure::of_name(&k)
                    .ok_or_else(|| serde::de::Error::custom(format!("no learner figure is named {k:?}")))?;
                Ok((f, decode(&v)?))
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A record reads back bit for bit, awkward numbers included.
    #[test]
    fn a_record_reads_back_bit_for_bit() {
        let row = |step, x: f64| CurveRow {
            step,
            earned: x,
            received: -x,
            earned_cum: x / 3.0,
            received_cum: 0.1 + 0.2,
        };
        let run = RunRecord {
            steps_done: 7,
            earned_total: 1.0 / 3.0,
            received_total: f64::NAN,
            curve: vec![row(5, 0.1), row(7, f64::INFINITY)],
        };
        let r = SeedRecord {
            seed: u64::MAX,
            run: run.clone(),
            baseline: Some(RunRecord { received_total: 2.0, ..run }),
            visits: vec![0, 3],
            greedy_per_step: 0.58,
            greedy_path: vec![1, 2],
            policy_arrows: vec![0, 15],
            policy_probs: vec![vec![0.25; 4], vec![f64::NAN; 4]],
            wall_time_s: 1e-300,
            delay_samples: vec![(5000, 13.0, 12.999999999999998)],
            delay_estimated: true,
            delay_pmf: Some(vec![0.1, 0.9]),
            figures: vec![(Figure::Probes, 3.0)],
        };
        let text = serde_json::to_string(&r).unwrap();
        let back: SeedRecord = serde_json::from_str(&text).unwrap();
        // NaN is not equal to itself: compare the texts of both, and a number by its bits.
        assert_eq!(serde_json::to_string(&back).unwrap(), text);
        assert_eq!(back.run.earned_total.to_bits(), (1.0f64 / 3.0).to_bits());
        assert_eq!(back.delay_samples[0].2.to_bits(), 12.999999999999998f64.to_bits());
        assert!(back.run.received_total.is_nan() && back.run.curve[1].earned.is_infinite());
        assert_eq!(back.seed, u64::MAX);
    }
}
