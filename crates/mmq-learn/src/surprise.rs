//! Refits on surprise: a one-sided test of the reward model against the deliveries since
//! the last refit, which calls for a refit as soon as the agent is collecting less than
//! the model promised.
//!
//! Between two refits R̂ and p̂ are fixed, and (D1) predicts each delivery from the last
//! K + 1 pairs taken. With e_t = r_t − Σ_{k=0..K} p̂(k) R̂(x_{t−k}) the residual of step t,
//! S_n = Σ e over the n steps since the last refit and σ̂² the reward fit's residual
//! variance per step, a refit is called for once
//!
//! ```text
//! n ≥ max(K + 1, `refit_every`)   and   S_n < −z σ̂ √n                             (S)
//! ```
//!
//! (z = `refit_on_surprise`). Only the shortfall counts: a reward the model put on a pair
//! where there is none (a phantom that the agent now loops on), or a cost it put on the
//! moves around a wall bump (which then looks free, and the agent bumps), both make the
//! deliveries fall short of the prediction while the agent follows the plan built on the
//! error. Deliveries above the prediction (a reward not found yet, or one the fit shrank)
//! do not trigger: the agent is not led astray by them, and the geometric schedule of
//! refits catches up with them. Before K + 1 steps the in-flight deliveries of the old
//! model's pairs are still arriving, so no test is made; and no test before `refit_every`
//! steps either, so that a model with a lasting small bias (a cost shrunk towards zero)
//! refits at most as often as the early schedule does.

/// (D1)'s prediction of a delivery, Σ_k p̂(k) R̂(x_{t−k}), over `recent`: the pairs of
/// the current run, the latest first (`reward` gives R̂).
pub(crate) fn predicted(
    pmf: &[f64],
    recent: impl Iterator<Item = usize>,
    reward: impl Fn(usize) -> f64,
) -> f64 {
    pmf.iter().zip(recent).fold(0.0, |sum, (&p, x)| sum + p * reward(x))
}

/// The test (S) over the steps since the last refit.
#[derive(Clone, Debug)]
pub(crate) struct Surprise {
    /// z > 0.
    z: f64,
    /// The fewest steps of one trajectory since the last refit before a test,
    /// max(K + 1, `refit_every`); the test waits for that times `trajectories`, those
    /// feeding the fit (parameter sharing; [`Self::set_trajectories`]).
    min_steps: u64,
    trajectories: u64,
    /// S_n and n.
    sum: f64,
    n: u64,
}

impl Surprise {
    /// The test with threshold `z` > 0 for delays 0..=`max_delay`, made once `refit_every`
    /// steps have passed since the last refit (and K + 1).
    pub(crate) fn new(z: f64, max_delay: usize, refit_every: u64) -> Self {
        let min_steps = refit_every.max(max_delay as u64 + 1);
        Self { z, min_steps, trajectories: 1, sum: 0.0, n: 0 }
    }

    /// `n` trajectories feed the fit and take turns: a test waits for n times the steps,
    /// as many of each trajectory's own steps as one trajectory's test waits for.
    pub(crate) fn set_trajectories(&mut self, n: u64) {
        self.trajectories = n.max(1);
    }

    /// Adds the residual e = r − predicted of one step under residual variance `sigma2`
    /// per step; true when (S) calls for a refit.
    pub(crate) fn residual(&mut self, e: f64, sigma2: f64) -> bool {
        self.sum += e;
        self.n += 1;
        self.n >= self.min_steps * self.trajectories
            && self.sum < -self.z * (sigma2.max(0.0) * self.n as f64).sqrt()
    }

    /// A refit happened, or a new run started: the test starts again.
    pub(crate) fn restart(&mut self) {
        self.sum = 0.0;
        self.n = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// K = 1, p̂ = (½, ½), R̂ = (2, 0): pair 0 taken every step, nothing delivered. The
    /// predictions are 1 (only one pair in this run yet), then 2; the residual sums −1, −3,
    /// −5; with σ̂² = 1 and z = 2 the thresholds are −2√n: the first step is before
    /// K + 1 = 2 steps, and at n = 2, −3 < −2√2 = −2.83 calls for the refit.
    #[test]
    fn a_promised_reward_that_does_not_come_calls_a_refit_by_hand() {
        let pmf = [0.5, 0.5];
        let r = |x: usize| [2.0, 0.0][x];
        let mut s = Surprise::new(2.0, 1, 1);
        let p1 = predicted(&pmf, [0].into_iter(), r);
        assert_eq!(p1, 1.0);
        assert!(!s.residual(0.0 - p1, 1.0));
        let p2 = predicted(&pmf, [0, 0].into_iter(), r);
        assert_eq!(p2, 2.0);
        assert!(s.residual(0.0 - p2, 1.0));
        // With σ̂² = 4 the threshold at n = 2 is −2·2·√2 = −5.66: not yet; at n = 3,
        // −5 against −6.93: not yet either; at n = 4, −7 < −8: no; the sum falls by 2 a
        // step and the threshold by about 1.1, so n = 5 (−9 against −8.94) calls it.
        let mut s = Surprise::new(2.0, 1, 1);
        let calls: Vec<bool> = (1..=6)
            .map(|t| {
                let p = predicted(&pmf, std::iter::repeat_n(0, t), r);
                s.residual(-p, 4.0)
            })
            .collect();
        assert_eq!(calls, [false, false, false, false, true, true]);
    }

    /// Deliveries above the prediction never call a refit, however large.
    #[test]
    fn a_surplus_does_not_call_a_refit() {
        let pmf = [0.0, 1.0];
        let mut s = Surprise::new(1.0, 1, 1);
        for _ in 0..100 {
            let p = predicted(&pmf, [1, 1].into_iter(), |_| 0.0);
            assert!(!s.residual(10.0 - p, 1.0));
        }
    }

    /// No test before `refit_every` steps since the last refit; with three trajectories
    /// taking turns, before three times as many.
    #[test]
    fn no_test_before_refit_every_steps() {
        let mut s = Surprise::new(1.0, 1, 5);
        let calls: Vec<bool> = (0..6).map(|_| s.residual(-100.0, 1.0)).collect();
        assert_eq!(calls, [false, false, false, false, true, true]);
        let mut s = Surprise::new(1.0, 1, 5);
        s.set_trajectories(3);
        let first = (0..20).position(|_| s.residual(-100.0, 1.0));
        assert_eq!(first, Some(14));
    }

    /// The prediction sees only the pairs it is given (a new run's: the deconvolver's
    /// `recent_pairs`); a restart forgets the sum.
    #[test]
    fn the_prediction_sees_only_this_runs_pairs_and_a_restart_forgets_the_sum() {
        let pmf = [0.0, 1.0];
        let mut s = Surprise::new(1.0, 1, 1);
        assert_eq!(predicted(&pmf, [0].into_iter(), |_| 3.0), 0.0);
        assert_eq!(predicted(&pmf, [0, 0].into_iter(), |_| 3.0), 3.0);
        assert!(!s.residual(-100.0, 1.0));
        assert!(s.residual(-100.0, 1.0));
        s.restart();
        assert!(!s.residual(-100.0, 1.0));
    }
}
