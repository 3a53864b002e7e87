//! Rewards per outcome (`outcome_rewards`): `deconv-model`'s reward fit credits each
//! delivery to the transition (s, a, s') that earned it instead of to the pair (s, a),
//! and plans with the reward a pair earns on average over its counted outcomes:
//!
//! ```text
//! R̂(s, a) = Σ_s' P̂(s' | s, a) R̂(s, a, s'),   P̂(s' | s, a) = N(s, a, s') / N(s, a)      (M3)
//! ```
//!
//! Transitions are seen at once and only rewards are late, so P̂ is as good as without a
//! delay; the deconvolution only has to find what each outcome pays. Where the cell the
//! agent believes it is in is sometimes not the one it is in (a robot's localisation), a
//! reward earned from the wrong cell comes with an outcome of its own (a bump leaves the
//! believed cell where it was; the goal teleports to the start), so the fit puts it on a
//! transition whose probability the counts keep small, as an undelayed average would,
//! rather than on the whole pair, where one such reward looks like a pair worth chasing.
//! On a deterministic world each pair has one outcome and (M3) is the pair's reward.
//!
//! Outcome ids: each state numbers its successors in the order they are first seen, up
//! to [`SLOTS`]; the successors after that share the last slot. The reward fit's feature
//! of (s, a, slot o) is (s · SLOTS + o) · |A| + a, so the fit's "state" is a (state,
//! successor) and its successor groups (`successor_groups`) are the actions of s that
//! lead to the same s': the goal's actions (all teleport) and a cell's wall bumps (all
//! stay put) still share a reward.
//!
//! Told the true cells (the diagnostic `told_cells`), the features and the outcome counts
//! of (M3) are those of the cells the reward fit is told.

use crate::decode::ValueDeconvolver;

/// Successors numbered per state; the later ones share the last slot.
pub const SLOTS: usize = 8;

/// The successors each state has led to, in the order first seen (at most [`SLOTS`]),
/// and each pair's counted successors, (s', N(s, a, s'), the reward feature of
/// (s, a, s')) in the order first seen. The counts are those of the cells the reward fit
/// is given: the agent's (then they are the model's transition counts), or a diagnostic's
/// true cells (`told_cells`).
#[derive(Clone, Debug)]
pub(super) struct Outcomes {
    succ: Vec<Vec<u32>>,
    counts: Vec<Vec<(u32, u32, u32)>>,
    num_actions: usize,
}

impl Outcomes {
    pub(super) fn new(num_states: usize, num_actions: usize) -> Self {
        Self {
            succ: vec![Vec::new(); num_states],
            counts: vec![Vec::new(); num_states * num_actions],
            num_actions,
        }
    }

    /// The slot of successor `s2` of state `s`, numbering it if it is new.
    fn slot_or_new(&mut self, s: usize, s2: usize) -> usize {
        let list = &mut self.succ[s];
        match list.iter().position(|&x| x as usize == s2) {
            Some(o) => o,
            None if list.len() < SLOTS => {
                list.push(s2 as u32);
                list.len() - 1
            }
            None => SLOTS - 1,
        }
    }

    /// Counts transition (s, a, s') and returns its reward feature, (s · SLOTS + o) · |A|
    /// + a with o the slot of s', numbering s' if it is new.
    pub(super) fn observe(&mut self, s: usize, a: usize, s2: usize) -> usize {
        let x = s * self.num_actions + a;
        if let Some(e) = self.counts[x].iter_mut().find(|e| e.0 as usize == s2) {
            e.1 += 1;
            return e.2 as usize;
        }
        let feature = (s * SLOTS + self.slot_or_new(s, s2)) * self.num_actions + a;
        self.counts[x].push((s2 as u32, 1, feature as u32));
        feature
    }

    /// (M3): the reward of pair x = s · |A| + a, its fitted outcome rewards weighted by
    /// its counted successors; 0 when untried.
    pub(super) fn pair_reward(&self, r: &ValueDeconvolver, x: usize) -> f64 {
        match &self.counts[x][..] {
            [] => 0.0,
            // One outcome so far: its reward, exactly (N·R / N need not be R in floating point).
            [(_, _, f)] => r.reward(*f as usize),
            next => {
                let n: u32 = next.iter().map(|e| e.1).sum();
                next.iter().map(|&(_, c, f)| f64::from(c) * r.reward(f as usize)).sum::<f64>() / f64::from(n)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deconv::{DeconvConfig, DeconvSettings};
    use crate::deconv_model::{DeconvModel, Probes};
    use crate::learner::{Learner, exp};
    use crate::params::Params;

    /// No delay (told p = (1, 0)), no penalties, refit every 4 steps: each outcome's R̂ is
    /// the mean of its rewards. From state 0 the one action leads to 1 (reward 4) three
    /// times in four and back to 0 (reward −2) once; from 1 it always leads to 0
    /// (reward 1). (M3): R̂(0, a) = ¾·4 + ¼·(−2) = 2.5 (a uniform weight over outcomes
    /// would give 1), R̂(1, a) = 1; features (0·8 + 0)·1 = 0, (0·8 + 1)·1 = 1 and
    /// (1·8 + 0)·1 = 8. Planned with γ = ½: Q(1) = 1 + ½ Q(0) and
    /// Q(0) = 2.5 + ½ (¾ Q(1) + ¼ Q(0)) = 2.875 + 0.3125 Q(0), so Q(0) = 46/11 and
    /// Q(1) = 34/11.
    #[test]
    fn pair_reward_weights_each_outcome_by_its_count() {
        let p = Params { alpha: 0.5, gamma: 0.5, epsilon: 0.0, q0: 0.0 };
        let settings = DeconvSettings { refit_every: 4, ..DeconvSettings::unpenalised(1) };
        let cfg = DeconvConfig { settings, told: Some(vec![1.0, 0.0]) };
        let mut l = DeconvModel::new(p, cfg, 1, Probes::OFF, 2, 1).with_outcome_rewards();
        // One cycle: 0 → 1 (4), 1 → 0 (1), 0 → 1 (4), 1 → 0 (1), 0 → 0 (−2), 0 → 1 (4), 1 → 0 (1).
        let cycle =
            [(0, 1, 4.0), (1, 0, 1.0), (0, 1, 4.0), (1, 0, 1.0), (0, 0, -2.0), (0, 1, 4.0), (1, 0, 1.0)];
        let mut t = 0;
        for _ in 0..40 {
            for &(s, s2, r) in &cycle {
                l.observe(&exp(t, s, 0, s2, r));
                t += 1;
            }
        }
        let r = l.deconvolver().rewards();
        assert!((r[0] - 4.0).abs() < 1e-9 && (r[1] + 2.0).abs() < 1e-9 && (r[8] - 1.0).abs() < 1e-9, "{r:?}");
        assert!((l.pair_reward(0) - 2.5).abs() < 1e-9 && (l.pair_reward(1) - 1.0).abs() < 1e-9);
        for _ in 0..200 {
            l.plan();
        }
        let (q0, q1) = (l.q(0, 0), l.q(1, 0));
        assert!((q0 - 46.0 / 11.0).abs() < 1e-9 && (q1 - 34.0 / 11.0).abs() < 1e-9, "{q0} {q1}");
        // The exported R̂ is per pair, (M3).
        let t = l.tables().into_iter().find(|t| t.name == "r_hat").unwrap();
        assert_eq!(t.shape, vec![2, 1]);
        assert!((t.data[0] - 2.5).abs() < 1e-9);
    }

    /// On a deterministic world every pair has one outcome: rewards per outcome are
    /// rewards per pair, bit for bit (the same fit, features numbered differently), under
    /// the reward-first defaults and a delay.
    #[test]
    fn a_deterministic_world_learns_the_same_bit_for_bit() {
        use crate::deconv_model::DeconvModelSettings;
        use rand::RngExt;
        let p = Params { alpha: 0.1, gamma: 0.9, epsilon: 0.1, q0: 5.0 };
        let s = DeconvModelSettings::default();
        let build = |outcomes: bool| {
            let l = DeconvModel::new(p, s.deconv.config().unwrap(), 10, s.explore.probes(), 6, 2)
                .planning_exploration();
            let l = if outcomes { l.with_outcome_rewards() } else { l };
            l.with_confidence(s.optimism_confidence)
        };
        let run = |mut l: DeconvModel| {
            // A ring of 6 cells: action 1 moves on (reward 3 into cell 0), action 0 bumps
            // (−1). Rewards arrive 2 or 3 steps late.
            let (mut rng, mut s, mut pending) = (mmq_core::seed::rng_from_seed(7), 0usize, vec![0.0; 8]);
            for t in 0..3000u64 {
                let a = l.act(s, &mut rng).action;
                let (s2, r) = if a == 1 { ((s + 1) % 6, if s == 5 { 3.0 } else { 0.0 }) } else { (s, -1.0) };
                pending[(t as usize + 2 + rng.random_range(0..2)) % 8] += r;
                let delivered = std::mem::take(&mut pending[t as usize % 8]);
                l.observe(&exp(t, s, a, s2, delivered));
                s = s2;
            }
            (0..12).map(|x| l.q(x / 2, x % 2).to_bits()).collect::<Vec<_>>()
        };
        assert_eq!(run(build(false)), run(build(true)));
    }

    /// Successors after the eighth share the last slot, in `observe` and in `pair_reward`.
    #[test]
    fn successors_past_the_slots_share_the_last() {
        let mut o = Outcomes::new(20, 2);
        let ids: Vec<usize> = (0..12).map(|s2| o.observe(3, 1, s2)).collect();
        let want: Vec<usize> = (0..12).map(|s2: usize| (3 * SLOTS + s2.min(SLOTS - 1)) * 2 + 1).collect();
        assert_eq!(ids, want);
        // Seen again, each keeps its feature; the ninth on shares the last slot's.
        assert_eq!(o.observe(3, 1, 11), (3 * SLOTS + SLOTS - 1) * 2 + 1);
        assert_eq!(o.observe(3, 1, 2), (3 * SLOTS + 2) * 2 + 1);
        assert_eq!(o.observe(4, 0, 3), 4 * SLOTS * 2);
    }
}
