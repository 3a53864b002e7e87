//! The settings the paper's figures and the independent reference's measurements were
//! made at. A report shows the paper's or the reference's value next to ours only where
//! the setting that ran is that one: the paper's world, learner, Poisson delay, α and γ
//! (the paper states no ε or q0), and for the reference also its ε and q0.

use mmq_core::DelayDist;
use mmq_lab::RunConfig;
use mmq_learn::LearnerKind;

use crate::axes;

/// A setting of the paper: the world (file stem), the learner and the Poisson delay's mean.
#[derive(Clone, Copy, Debug)]
pub(super) struct Theirs {
    /// The world's file stem (`paper-3x3`).
    pub world: &'static str,
    /// The learner.
    pub learner: LearnerKind,
    /// The Poisson delay's mean, steps.
    pub lambda: f64,
}

/// α and γ of every figure of the paper.
const ALPHA_GAMMA: (f64, f64) = (0.1, 0.9);
/// λ̂max of the paper's MMQ.
const MAX_DELAY: usize = 50;

impl Theirs {
    /// Whether `cfg` is this setting of the paper, on any fidelity.
    pub fn is(&self, cfg: &RunConfig) -> bool {
        axes::world_stem_of(cfg) == self.world && self.is_but_world(cfg)
    }

    /// Whether `cfg` is this setting of the paper but for its world.
    pub fn is_but_world(&self, cfg: &RunConfig) -> bool {
        let p = cfg.learner.params;
        let poisson = match DelayDist::parse(&cfg.delay) {
            Ok(DelayDist::Poisson(l)) => l == self.lambda,
            Ok(DelayDist::None) => self.lambda == 0.0,
            _ => false,
        };
        let max_delay_ok =
            self.learner != LearnerKind::Mmq || cfg.learner.settings.max_delay() == Some(MAX_DELAY);
        cfg.learner.kind() == self.learner && poisson && (p.alpha, p.gamma) == ALPHA_GAMMA && max_delay_ok
    }

    /// Whether `cfg` is this setting of the paper with the reference's ε and q0.
    pub fn with(&self, cfg: &RunConfig, epsilon: f64, q0: f64) -> bool {
        let p = cfg.learner.params;
        self.is(cfg) && (p.epsilon, p.q0) == (epsilon, q0)
    }
}

/// ε and q0 of the reference's measurements for Figs. 2–4.
pub(super) const EARLY_EPSILON_Q0: (f64, f64) = (0.05, 10.0);

/// The paper's comparison values only for matching settings: `value` where `matches`,
/// else "—".
pub(super) fn only_if(matches: bool, value: &'static str) -> &'static str {
    if matches { value } else { "—" }
}

/// The note under a figure whose spec is not the paper's setting: its values are shown
/// only where a setting matches.
pub(super) fn variant_note(paper: &str) -> String {
    format!(
        "this spec is not exactly the paper's setting ({paper}); the paper's and the reference's values are \
         shown only where a setting that ran is theirs, and are \"—\" elsewhere."
    )
}
