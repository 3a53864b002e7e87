//! Learner selection: [`LearnerSpec`], a learner with its own settings
//! ([`crate::settings`]) and the shared parameters ([`crate::params`]), validated before
//! anything is allocated, and [`build`], which builds it.

use serde::{Deserialize, Serialize};

pub use crate::error::LearnError;
pub use crate::kind::{LearnerKind, catalogue};
use crate::learner::Learner;
pub use crate::params::Params;
use crate::settings::LearnerSettings;

/// A fully specified learner: its own settings, tagged by `kind`, and the shared
/// parameters. In a configuration: `kind = "mmq"`, the learner's settings
/// (`max_delay = 50`) and a `[params]` table; a setting the learner does not have is
/// refused by name.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LearnerSpec {
    /// Which learner, with its own settings.
    #[serde(flatten)]
    pub settings: LearnerSettings,
    /// Shared hyper-parameters.
    pub params: Params,
}

impl Default for LearnerSpec {
    fn default() -> Self {
        Self::new(LearnerKind::Mmq)
    }
}

impl LearnerSpec {
    /// Learner `kind` with its default settings and the default shared parameters.
    pub fn new(kind: LearnerKind) -> Self {
        Self { settings: LearnerSettings::of(kind), params: Params::default() }
    }

    /// Which learner.
    pub fn kind(&self) -> LearnerKind {
        self.settings.kind()
    }

    /// The learner's name, its shared parameters and its own settings, for reports.
    pub fn describe(&self) -> String {
        let p = self.params;
        format!(
            "{} (α = {}, γ = {}, ε = {}, q0 = {}{})",
            self.kind().name(),
            p.alpha,
            p.gamma,
            p.epsilon,
            p.q0,
            self.settings.describe()
        )
    }

    /// Checks every parameter's domain.
    pub fn validate(&self) -> Result<(), LearnError> {
        let p = &self.params;
        let bad = |field, v: f64, accepted| {
            Err(LearnError::InvalidParam { field, value: mmq_core::stats::compact(v), accepted })
        };
        if !(0.0..=1.0).contains(&p.alpha) {
            return bad("alpha", p.alpha, "use a learning rate in [0, 1], e.g. 0.1");
        }
        if !(0.0..1.0).contains(&p.gamma) {
            return bad("gamma", p.gamma, "use a discount factor in [0, 1), e.g. 0.9");
        }
        if !(0.0..=1.0).contains(&p.epsilon) {
            return bad("epsilon", p.epsilon, "use an exploration rate in [0, 1], e.g. 0.02");
        }
        if !p.q0.is_finite() || p.q0.abs() > 1e12 {
            return bad("q0", p.q0, "use a finite initial value, e.g. 10");
        }
        self.settings.validate()
    }

    /// Entries and bytes of the tables for `num_states` × `num_actions` (exact for the
    /// big tables).
    pub fn table_bytes(&self, num_states: usize, num_actions: usize) -> (u128, u128) {
        let entries = self.settings.table_entries(num_states, num_actions);
        (entries, entries * 8 + num_states as u128 * 12)
    }

    /// Builds the learner after validating it and checking that its tables fit within
    /// `limit_bytes`.
    pub fn build(
        &self,
        num_states: usize,
        num_actions: usize,
        limit_bytes: u128,
    ) -> Result<Box<dyn Learner>, LearnError> {
        self.validate()?;
        // deconv-model-time adds an idle state.
        let features = self.settings.reward_features_per_pair();
        if self.settings.deconv().is_some()
            && (num_states + 1).saturating_mul(num_actions).saturating_mul(features)
                > crate::deconv::MAX_PAIRS
        {
            return Err(LearnError::InvalidParam {
                field: "world",
                value: format!("{num_states} cells × {num_actions} actions"),
                accepted: "the deconvolving learners accept at most 8,388,608 state-action pairs (with outcome_rewards, 8 times fewer); use a smaller world",
            });
        }
        let (entries, bytes) = self.table_bytes(num_states, num_actions);
        if bytes > limit_bytes {
            return Err(LearnError::TooLarge {
                learner: self.kind().name(),
                entries,
                need_gib: bytes as f64 / (1u128 << 30) as f64,
                limit_gib: limit_bytes as f64 / (1u128 << 30) as f64,
            });
        }
        self.settings.build(self.params, num_states, num_actions)
    }
}

/// Builds a learner (see [`LearnerSpec::build`]).
pub fn build(
    spec: &LearnerSpec,
    num_states: usize,
    num_actions: usize,
    limit_bytes: u128,
) -> Result<Box<dyn Learner>, LearnError> {
    spec.build(num_states, num_actions, limit_bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::{DeconvModelSettings, KernelSettings};

    #[test]
    fn refuses_impossible_parameters_and_huge_tables() {
        let mut s = LearnerSpec::default();
        s.params.alpha = 1.5;
        assert!(s.build(81, 4, 1 << 30).unwrap_err().to_string().contains("`alpha` = 1.5"));
        s.params.alpha = 0.1;
        s.params.epsilon = f64::NAN;
        assert!(s.build(81, 4, 1 << 30).unwrap_err().to_string().contains("`epsilon`"));
        s.params.epsilon = 0.1;
        let mut m = DeconvModelSettings::default();
        m.deconv.joint_test = f64::NAN;
        let e = |settings: &LearnerSettings| {
            LearnerSpec { settings: settings.clone(), params: s.params }
                .build(81, 4, 1 << 30)
                .unwrap_err()
                .to_string()
        };
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("joint_test"));
        m.deconv.joint_test = 1.0;
        m.deconv.pmf_smoothness = -1.0;
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("pmf_smoothness"));
        m.deconv.pmf_smoothness = 0.0;
        m.deconv.refit_growth = 0;
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("refit_growth"));
        m.deconv.refit_growth = 8;
        m.deconv.settled_refit_growth = 0;
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("settled_refit_growth"));
        m.deconv.settled_refit_growth = 3;
        m.deconv.pmf_rounds = 0;
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("pmf_rounds"));
        m.deconv.pmf_rounds = 1;
        m.deconv.pmf_tolerance = -1e-4;
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("pmf_tolerance"));
        m.deconv.pmf_tolerance = 0.0;
        m.deconv.sparse_refits_below_se = f64::INFINITY;
        let msg = e(&LearnerSettings::DeconvModel(m.clone()));
        assert!(msg.contains("sparse_refits_below_se") && msg.contains("e.g. 0.5"), "{msg}");
        m.deconv.sparse_refits_below_se = 0.0;
        m.deconv.refit_on_surprise = f64::NAN;
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("refit_on_surprise"));
        m.deconv.refit_on_surprise = 0.0;
        m.explore.probe_rate = 1.5;
        let msg = e(&LearnerSettings::DeconvModel(m.clone()));
        assert!(msg.contains("probe_rate") && msg.contains("[0, 1]"), "{msg}");
        m.explore.probe_rate = 0.02;
        m.explore.probe_precision = 0.0;
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("probe_precision"));
        m.explore.probe_precision = 0.5;
        m.optimism_confidence = -2.0;
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("optimism_confidence"));
        m.optimism_confidence = 0.0;
        m.deconv.told_delay = Some("exponential:4s".into());
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("give it in steps"));
        m.deconv.told_delay = Some("poisson:13".into());
        m.deconv.max_delay = 70_000;
        assert!(e(&LearnerSettings::DeconvModel(m.clone())).contains("at most 65536"));
        let k = KernelSettings { kernel_width: 0.0, ..KernelSettings::default() };
        assert!(e(&LearnerSettings::MmqKernel(k)).contains("kernel_width"));
        let mut t = LearnerSettings::of(LearnerKind::DeconvModelTime);
        if let LearnerSettings::DeconvModelTime(x) = &mut t {
            x.time_bin_s = 0.0;
        }
        assert!(e(&t).contains("time_bin_s"));
        let mut q = LearnerSettings::of(LearnerKind::QLambda);
        if let LearnerSettings::QLambda(x) = &mut q {
            x.trace_decay = 1.5;
        }
        assert!(e(&q).contains("trace_decay"));
        // Every default is valid.
        for (k, ..) in catalogue() {
            LearnerSpec::new(k).validate().unwrap();
        }
        s.settings = LearnerSettings::Mmq(crate::settings::MmqSettings { max_delay: 1_000_000_000 });
        let e = s.build(81, 4, 8 << 30).unwrap_err().to_string();
        assert!(e.contains("`max_delay`") && e.contains("GiB"), "{e}");
        assert!(
            LearnerKind::parse("sarsa-x").unwrap_err().to_string().contains("known learners: q, fixed, mmq")
        );
        for (k, name, _) in catalogue() {
            assert_eq!(LearnerKind::parse(name).unwrap(), k);
            assert_eq!(LearnerSettings::of(k).kind(), k);
        }
    }

    /// Table sizes by hand: Q is |S||A|, fixed adds its λ̂-step history, MMQ has λ̂max + 1
    /// tables, `deconv-model-time` counts an idle state more than `deconv-model` per pair,
    /// and rewards per outcome fit eight slots per pair.
    #[test]
    fn each_learner_counts_its_own_tables() {
        let entries = |k| LearnerSpec::new(k).table_bytes(81, 4).0;
        assert_eq!(entries(LearnerKind::Q), 324);
        assert_eq!(entries(LearnerKind::Fixed), 324 + 13);
        assert_eq!(entries(LearnerKind::Mmq), 324 * 51);
        assert_eq!(entries(LearnerKind::MmqKernel), 324 * 51);
        assert_eq!(entries(LearnerKind::SarsaLambda), 324);
        // Per pair, deconv-model keeps what deconv-q keeps; per outcome (its default) Q and
        // eight slots of R̂ and the lagged sums per pair.
        let model = |outcomes: bool| {
            let s = crate::settings::DeconvModelSettings { outcome_rewards: outcomes, ..Default::default() };
            LearnerSpec {
                settings: LearnerSettings::DeconvModel(s),
                ..LearnerSpec::new(LearnerKind::DeconvModel)
            }
            .table_bytes(81, 4)
            .0
        };
        assert_eq!(model(true), entries(LearnerKind::DeconvModel));
        assert_eq!(entries(LearnerKind::DeconvQ), model(false));
        let deconv = crate::settings::DeconvModelSettings::default().deconv;
        assert_eq!(model(true), crate::decode::ValueDeconvolver::table_entries(&deconv, 324, 324 * 8));
        assert_eq!(model(false), crate::decode::ValueDeconvolver::table_entries(&deconv, 324, 324));
        assert!(entries(LearnerKind::DeconvModelTime) > model(false));
        assert_eq!(LearnerSpec::new(LearnerKind::Q).table_bytes(81, 4).1, 324 * 8 + 81 * 12);
    }

    /// A configuration lists the learner's own settings only, and a setting of another
    /// learner is refused by name.
    #[test]
    fn each_learner_serialises_and_accepts_only_its_own_settings() {
        let text = |k| toml::to_string(&LearnerSpec::new(k)).unwrap();
        let mmq = text(LearnerKind::Mmq);
        assert!(mmq.starts_with("kind = \"mmq\"\nmax_delay = 50\n"), "{mmq}");
        assert!(
            !mmq.contains("lasso") && !mmq.contains("lambda_hat") && !mmq.contains("trace_decay"),
            "{mmq}"
        );
        let q = text(LearnerKind::Q);
        assert!(q.starts_with("kind = \"q\"\n\n[params]"), "{q}");
        let dm = text(LearnerKind::DeconvModel);
        assert!(
            dm.contains("lasso = 0.1") && dm.contains("probe_rate") && !dm.contains("replay_lag"),
            "{dm}"
        );
        assert!(!dm.contains("time_bin_s") && !dm.contains("kernel_width"), "{dm}");
        for (k, ..) in catalogue() {
            let back: LearnerSpec = toml::from_str(&text(k)).unwrap();
            assert_eq!(back, LearnerSpec::new(k));
        }
        let params = "[params]\nalpha = 0.1\ngamma = 0.9\nepsilon = 0.01\nq0 = 20.0\n";
        let parse = |head: &str| toml::from_str::<LearnerSpec>(&format!("{head}{params}"));
        let e = parse("kind = \"mmq\"\nlasso = 0.2\n").unwrap_err().to_string();
        assert!(e.contains("unknown field `lasso`"), "{e}");
        let e = parse("kind = \"q\"\nmax_delay = 5\n").unwrap_err().to_string();
        assert!(e.contains("unknown field `max_delay`"), "{e}");
        let e = parse("kind = \"deconv-q\"\nprobe_rate = 0.1\n").unwrap_err().to_string();
        assert!(e.contains("unknown field `probe_rate`"), "{e}");
        let e = parse("kind = \"deconv-model\"\ntime_bin_s = 1.0\n").unwrap_err().to_string();
        assert!(e.contains("unknown field `time_bin_s`"), "{e}");
        let e = parse("kind = \"fixed\"\nmax_delay = 5\n").unwrap_err().to_string();
        assert!(e.contains("unknown field `max_delay`"), "{e}");
        // Missing settings take their defaults; given ones land where the learner reads them.
        let s =
            parse("kind = \"deconv-model-time\"\ntime_bin_s = 1\nlasso = 0.3\nmax_delay = 200\n").unwrap();
        match &s.settings {
            LearnerSettings::DeconvModelTime(t) => {
                assert_eq!((t.time_bin_s, t.deconv.lasso, t.deconv.max_delay), (1.0, 0.3, 200));
                assert_eq!(t.explore.probe_rate, 0.02);
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(parse("kind = \"fixed\"\nlambda_hat = 7\n").unwrap().settings.describe(), ", λ̂ = 7");
    }

    /// `deconv-model`'s defaults put the reward first, while a configuration that does not
    /// give a setting reads it as off: a recording made before the setting existed replays
    /// as it ran, and one that gives it (every recording now lists them all) keeps it.
    #[test]
    fn deconv_model_defaults_put_the_reward_first_and_absent_settings_read_as_off() {
        use crate::deconv_model::ProbeSteps;
        let LearnerSettings::DeconvModel(d) = LearnerSettings::of(LearnerKind::DeconvModel) else {
            panic!("not deconv-model")
        };
        assert_eq!((d.optimism_confidence, d.plan_exploration), (2.0, true));
        assert_eq!((d.deconv.refit_every, d.deconv.pmf_rounds, d.deconv.refit_on_surprise), (100, 4, 3.0));
        assert_eq!((d.deconv.sparse_refits_below_se, d.deconv.settled_refit_growth), (0.5, 3));
        assert_eq!(d.explore.probe_steps, ProbeSteps::Any);
        // The rest is the shared deconvolution's and exploration's defaults.
        assert_eq!(d.deconv.lasso, 0.1);
        assert_eq!(d.explore.optimism_visits, 10);
        // deconv-q and deconv-model-time keep the schedule and the single round.
        let LearnerSettings::DeconvQ(q) = LearnerSettings::of(LearnerKind::DeconvQ) else { panic!() };
        assert_eq!((q.deconv.refit_every, q.deconv.pmf_rounds, q.deconv.refit_on_surprise), (250, 1, 0.0));
        let params = "[params]\nalpha = 0.1\ngamma = 0.9\nepsilon = 0.01\nq0 = 20.0\n";
        let parse = |head: &str| toml::from_str::<LearnerSpec>(&format!("{head}{params}")).unwrap().settings;
        let LearnerSettings::DeconvModel(absent) = parse("kind = \"deconv-model\"\nlasso = 0.2\n") else {
            panic!()
        };
        let off = DeconvModelSettings::when_absent();
        let lasso = crate::settings::DeconvSettings { lasso: 0.2, ..off.deconv.clone() };
        assert_eq!(absent, DeconvModelSettings { deconv: lasso, ..off });
        assert_eq!((absent.optimism_confidence, absent.plan_exploration), (0.0, false));
        assert_eq!((absent.deconv.refit_every, absent.deconv.pmf_rounds), (250, 1));
        assert_eq!(absent.explore.probe_steps, ProbeSteps::Greedy);
        // A recording lists every setting, so the defaults come back as they were.
        let text = toml::to_string(&LearnerSpec::new(LearnerKind::DeconvModel)).unwrap();
        assert_eq!(toml::from_str::<LearnerSpec>(&text).unwrap().settings, LearnerSettings::DeconvModel(d));
    }
}
