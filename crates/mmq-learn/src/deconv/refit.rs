//! A refit: R̂ given p̂ and, when the delay is estimated, the alternation of (D2) from
//! two starts, the previous p̂ (warm) and the uniform pmf with R̂ zero (cold), of which
//! the one with the lower objective is kept and refined by `pmf_rounds` − 1 more rounds;
//! then the joint test. Also when refits come and how many reweighted passes a round's
//! pmf fit makes.
//!
//! The cold start runs on another thread when the process has a core to spare
//! ([`crate::spare`]), and each start then goes on with its later rounds as soon as it
//! may be the one kept. Nothing it computes depends on that: the fits are those of the
//! sequential order, bit for bit, on any number of threads.

use super::{DeconvSettings, Deconvolver, WEIGHTED_PASSES, WeightedRounds, gram};
use crate::spare;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// The step of the next refit after one at step `t`: every `refit_every` steps early on,
/// every t/g later, g = `refit_growth`, or g = `settled_refit_growth` when that refit
/// found the delay `settled` ([`Deconvolver::delay_settled`], `sparse_refits_below_se`).
pub(crate) fn next_refit_after(settings: &DeconvSettings, t: u64, settled: bool) -> u64 {
    let growth = if settled { settings.settled_refit_growth } else { settings.refit_growth };
    t + settings.refit_every.max(t / growth)
}

/// The reweighted passes of the fits of the delay pmf in round `round` (1: both starts) of
/// a refit's `rounds` (`pmf_rounds`): [`WEIGHTED_PASSES`] in the fits a refit can end with
/// (the last round) and, unless `rule` (`pmf_weighted_rounds`) is `last`, in every other.
pub(crate) fn weighted_passes(rule: WeightedRounds, rounds: u32, round: u32) -> usize {
    match rule {
        WeightedRounds::Last if round < rounds => 0,
        _ => WEIGHTED_PASSES,
    }
}

/// A Gram matrix of a refit with the p̂ it was built under and its a_0 = Σ p̂(k)².
type CachedGram = (Vec<f64>, gram::Gram, f64);

/// The uniform pmf on 0..`k_n`: the cold start of a refit.
fn uniform_pmf(k_n: usize) -> Vec<f64> {
    vec![1.0 / k_n as f64; k_n]
}

/// Whether a round of the alternation that took the delay pmf from `from` to `to` moved
/// no p̂(k) by more than `tolerance` (`pmf_tolerance`): the rounds of the refit stop.
pub(super) fn settled(from: &[f64], to: &[f64], tolerance: f64) -> bool {
    from.iter().zip(to).all(|(a, b)| (a - b).abs() <= tolerance)
}

impl Deconvolver {
    /// Refits R̂ given p̂, then (when estimating) p̂ given R̂ and R̂ again.
    ///
    /// When estimating, a second alternation starts from the uniform pmf (a cold start)
    /// and the fit with the lower penalised objective (D2) is kept: an alternation that
    /// locked onto a wrong delay early (or found no reward at all) gets out again. The
    /// kept fit then gets `pmf_rounds` − 1 more rounds of p̂ given R̂ and R̂ given p̂
    /// (fewer with `pmf_tolerance` > 0: they stop once a round leaves p̂ where it was).
    pub fn refit(&mut self) {
        Self::refit_all(std::slice::from_mut(self));
    }

    /// [`Self::refit`] for deconvolvers that see the same pairs and share one delay pmf
    /// (one per reward value, [`crate::decode`]): R̂ of each given p̂, then p̂ given all
    /// of them (their least-squares systems summed), with the cold start compared on the
    /// summed objective. One deconvolver: exactly `refit`.
    pub(crate) fn refit_all(ds: &mut [Deconvolver]) {
        if ds.is_empty() || ds[0].stats.pairs.is_empty() {
            return;
        }
        ds[0].merge_counts();
        // σ̂ from the previous fit (Σ r² before the first: an upper bound), shared by
        // both starts so that their objectives compare.
        let sigmas: Vec<f64> = ds
            .iter()
            .map(|d| (d.rss.unwrap_or(d.stats.sum_r2).max(0.0) / d.stats.t.max(1) as f64).sqrt())
            .collect();
        // The Gram matrices of this refit by pmf (the counts do not change during it): the
        // joint test's is one of those before it, and rows read once are kept.
        let mut grams: Vec<CachedGram> = Vec::new();
        if ds[0].cfg.told.is_some() {
            Self::fit_all(ds, &mut grams, &sigmas);
        } else {
            let rounds = ds[0].cfg.settings.pmf_rounds;
            let passes = weighted_passes(ds[0].cfg.settings.pmf_weighted_rounds, rounds, 1);
            let previous = ds[0].pmf.clone();
            let (start, done) = if ds[0].cold_skip > 0 {
                ds.iter_mut().for_each(|d| d.cold_skip -= 1);
                Self::first_round(ds, &mut grams, &sigmas, passes);
                (previous, None)
            } else {
                Self::warm_or_cold(ds, &mut grams, &sigmas, previous, passes)
            };
            let later = done
                .or_else(|| Self::later_rounds(ds, &mut grams, &sigmas, start, None))
                .expect("rounds without a stop run to the end");
            ds.iter_mut().for_each(|d| d.rounds += 1 + later);
        }
        if ds.iter().any(Deconvolver::joint_on) {
            let (g, a0) = Self::cached_gram(ds, &mut grams);
            Self::fit_each(ds, g, a0, &sigmas, true);
        }
        ds.iter_mut().for_each(|d| d.refits += 1);
    }

    /// The first round from the previous p̂ (the warm start) and from the uniform pmf
    /// with R̂ zero (the cold start), their pmf fits with `passes` reweighted passes;
    /// keeps the one with the lower objective (D2) and returns the pmf its later rounds
    /// start from, with the number of later rounds when they have run already.
    ///
    /// The cold start runs on copies that share the statistics and the history (both only
    /// read during a refit), on another thread when one is free. Meanwhile each start goes
    /// on with its later rounds once it may be the one kept: the warm start as soon as
    /// its first round ends (and it stops when the cold start is known to have won), the
    /// cold start when it ends with the lower objective. Every computation is one the
    /// sequential order makes, so the result is the same bit for bit on any number of
    /// threads.
    fn warm_or_cold(
        ds: &mut [Deconvolver],
        grams: &mut Vec<CachedGram>,
        sigmas: &[f64],
        previous: Vec<f64>,
        passes: usize,
    ) -> (Vec<f64>, Option<u64>) {
        let uniform = uniform_pmf(ds[0].pmf.len());
        let mut cold: Vec<Deconvolver> = ds
            .iter()
            .map(|d| {
                let mut c = d.clone();
                c.pmf.clone_from(&uniform);
                c.r.iter_mut().chain(c.r_pair.iter_mut()).chain(c.r_group.iter_mut()).for_each(|x| *x = 0.0);
                c
            })
            .collect();
        let mut cold_grams: Vec<CachedGram> = Vec::new();
        // The warm start's objective once known (NaN before), whether the cold start has
        // begun, and whether it has won.
        let warm_known = AtomicU64::new(f64::NAN.to_bits());
        let (cold_begun, cold_won) = (AtomicBool::new(false), AtomicBool::new(false));
        let warm_start = |ds: &mut [Deconvolver], grams: &mut Vec<CachedGram>| {
            let (objective, _) = Self::first_round(ds, grams, sigmas, passes);
            warm_known.store(objective.to_bits(), Ordering::Release);
            let se: Vec<_> = ds.iter().map(|d| d.median_se).collect();
            let ahead = if cold_begun.load(Ordering::Acquire) {
                Self::later_rounds(ds, grams, sigmas, previous.clone(), Some(&cold_won))
            } else {
                None
            };
            (objective, se, ahead)
        };
        let cold_start = |cold: &mut [Deconvolver], grams: &mut Vec<CachedGram>| {
            cold_begun.store(true, Ordering::Release);
            let (objective, fitted) = Self::first_round(cold, grams, sigmas, passes);
            let warm = f64::from_bits(warm_known.load(Ordering::Acquire));
            let ahead = (objective < warm).then(|| {
                cold_won.store(true, Ordering::Release);
                Self::later_rounds(cold, grams, sigmas, uniform.clone(), None)
            });
            (objective, fitted, ahead.flatten())
        };
        let ((warm_objective, warm_se, warm_ahead), (cold_objective, cold_fitted, cold_ahead)) =
            spare::beside(|| warm_start(ds, grams), || cold_start(&mut cold, &mut cold_grams));
        grams.append(&mut cold_grams);
        let won = cold_objective < warm_objective;
        ds.iter_mut().for_each(|d| d.cold_start_ended(won));
        if !won {
            return (previous, warm_ahead);
        }
        for ((d, c), se) in ds.iter_mut().zip(cold).zip(warm_se) {
            (d.pmf, d.r, d.r_pair, d.r_group, d.rss) = (c.pmf, c.r, c.r_pair, c.r_group, c.rss);
            // A cold pmf fit with nothing to fit (R̂ zero, which its later rounds leave as
            // it is) leaves the warm start's first round's.
            d.median_se = if cold_fitted { c.median_se } else { se };
        }
        (uniform, cold_ahead)
    }

    /// R̂ of each of `ds` given the current p̂ (the Gram matrix from `grams`); returns the
    /// summed penalised objective (D2).
    fn fit_all(ds: &mut [Deconvolver], grams: &mut Vec<CachedGram>, sigmas: &[f64]) -> f64 {
        let (g, a0) = Self::cached_gram(ds, grams);
        Self::fit_each(ds, g, a0, sigmas, false)
    }

    /// R̂ of each of `ds` given the Gram matrix `g` and a_0, with the joint test if
    /// `joint` (then only those that run it); returns their objectives (D2) summed in
    /// order. With two or more and a spare core, the others are fitted there beside the
    /// first ([`spare::beside`]): each fit reads `g` and writes only its own deconvolver,
    /// so the fits are the same on any number of threads.
    fn fit_each(ds: &mut [Deconvolver], g: &gram::Gram, a0: f64, sigmas: &[f64], joint: bool) -> f64 {
        let fit = |d: &mut Deconvolver, sigma: f64| {
            (!joint || d.joint_on()).then(|| d.fit_rewards(g, a0, sigma, joint))
        };
        let fit_all = |ds: &mut [Deconvolver], sigmas: &[f64]| -> Vec<Option<f64>> {
            ds.iter_mut().zip(sigmas).map(|(d, &sigma)| fit(d, sigma)).collect()
        };
        let objectives = if ds.len() >= 2 {
            let (head, rest) = ds.split_at_mut(1);
            let (first, mut others) =
                spare::beside(|| fit(&mut head[0], sigmas[0]), || fit_all(rest, &sigmas[1..]));
            others.insert(0, first);
            others
        } else {
            fit_all(ds, sigmas)
        };
        objectives.into_iter().flatten().sum()
    }

    /// One round of the alternation from the current p̂ and R̂: R̂ given p̂, p̂ given R̂
    /// (`passes` reweighted passes), R̂ again. Returns the summed objective (D2) at the end
    /// and whether the pmf fit fitted.
    fn first_round(
        ds: &mut [Deconvolver],
        grams: &mut Vec<CachedGram>,
        sigmas: &[f64],
        passes: usize,
    ) -> (f64, bool) {
        Self::fit_all(ds, grams, sigmas);
        let fitted = Self::fit_pmf_all(ds, passes);
        (Self::fit_all(ds, grams, sigmas), fitted)
    }

    /// Rounds 2..=`pmf_rounds` of p̂ given R̂ and R̂ given p̂ for the kept start, whose
    /// first round started from `start` (with `pmf_tolerance` > 0 they stop once a round
    /// leaves p̂ where it was). Returns the number run; None when `stop` was set before
    /// they all ran (the start is not kept, and its state is left partway).
    fn later_rounds(
        ds: &mut [Deconvolver],
        grams: &mut Vec<CachedGram>,
        sigmas: &[f64],
        mut start: Vec<f64>,
        stop: Option<&AtomicBool>,
    ) -> Option<u64> {
        let settings = &ds[0].cfg.settings;
        let (rule, rounds, tolerance) =
            (settings.pmf_weighted_rounds, settings.pmf_rounds, settings.pmf_tolerance);
        let stopped = || stop.is_some_and(|s| s.load(Ordering::Acquire));
        let mut ran = 0;
        for round in 2..=rounds {
            if tolerance > 0.0 && settled(&start, &ds[0].pmf, tolerance) {
                break;
            }
            if stopped() {
                return None;
            }
            start.clone_from(&ds[0].pmf);
            Self::fit_pmf_all(ds, weighted_passes(rule, rounds, round));
            if stopped() {
                return None;
            }
            Self::fit_all(ds, grams, sigmas);
            ran += 1;
        }
        Some(ran)
    }

    /// [`Self::shared_gram`] under the current p̂, from `cache` when it holds the matrix
    /// for the same p̂ (bit for bit; the counts must not have changed since), and a_0.
    fn cached_gram<'c>(ds: &mut [Deconvolver], cache: &'c mut Vec<CachedGram>) -> (&'c gram::Gram, f64) {
        let same = |p: &[f64]| p.iter().zip(&ds[0].pmf).all(|(x, y)| x.to_bits() == y.to_bits());
        let at = match cache.iter().position(|(p, _, _)| same(p)) {
            Some(at) => at,
            None => {
                let (g, a) = Self::shared_gram(ds);
                cache.push((ds[0].pmf.clone(), g, a[0]));
                cache.len() - 1
            }
        };
        let (_, g, a0) = &cache[at];
        (g, *a0)
    }

    /// The Gram matrix of the first deconvolver's counts under its p̂, shared by all of
    /// `ds` (they see the same pairs and share p̂), and the a_j.
    pub(super) fn shared_gram(ds: &mut [Deconvolver]) -> (gram::Gram, Vec<f64>) {
        debug_assert!(ds.iter().all(|d| d.pmf == ds[0].pmf && d.stats.t == ds[0].stats.t));
        ds[0].merge_counts();
        ds[0].stats.gram(&ds[0].pmf)
    }

    /// Merges the pending co-occurrences into the counts (copying the statistics only when
    /// a merge is due while a copy shares them).
    pub(super) fn merge_counts(&mut self) {
        if self.stats.merge_due() {
            std::sync::Arc::make_mut(&mut self.stats).merge();
        }
    }

    /// Whether the delay estimate has settled for `sparse_refits_below_se` s > 0: it is
    /// estimated (not told) and the standard error of its median, from the last refit, is
    /// below s. The next refit then comes after t/`settled_refit_growth` steps instead of
    /// t/`refit_growth`.
    pub(crate) fn delay_settled(&self) -> bool {
        let s = self.cfg.settings.sparse_refits_below_se;
        s > 0.0 && self.cfg.told.is_none() && self.median_se.is_some_and(|m| m.steps < s)
    }

    /// Counts a cold start and whether it `won`. With `cold_start_backoff` n > 0, after
    /// the n-th loss in a row the next 2^(losses − n) refits (at most 64) skip it; a win
    /// starts the count again.
    pub(super) fn cold_start_ended(&mut self, won: bool) {
        self.cold_starts += 1;
        if won {
            self.cold_wins += 1;
            self.cold_losses = 0;
            return;
        }
        self.cold_losses = self.cold_losses.saturating_add(1);
        let n = self.cfg.settings.cold_start_backoff;
        if n > 0 && self.cold_losses >= n {
            self.cold_skip = 1 << (self.cold_losses - n).min(6);
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::deconv::Deconvolver;
    use crate::deconv::tests::{cfg, noisy_walk};
    use crate::spare::FORCE;

    /// The refit in the plain sequential order, on the deconvolvers themselves: the warm
    /// start's first round, the cold start's in place (the warm start's fit put back
    /// when it loses), the kept start's later rounds, the joint test.
    fn refit_in_place(ds: &mut [Deconvolver]) {
        ds[0].merge_counts();
        let sigmas: Vec<f64> = ds
            .iter()
            .map(|d| (d.rss.unwrap_or(d.stats.sum_r2).max(0.0) / d.stats.t.max(1) as f64).sqrt())
            .collect();
        let mut grams = Vec::new();
        let passes = super::WEIGHTED_PASSES;
        let previous = ds[0].pmf.clone();
        Deconvolver::fit_all(ds, &mut grams, &sigmas);
        Deconvolver::fit_pmf_all(ds, passes);
        let warm_objective = Deconvolver::fit_all(ds, &mut grams, &sigmas);
        let warm: Vec<_> = ds
            .iter()
            .map(|d| (d.pmf.clone(), d.r.clone(), d.r_pair.clone(), d.r_group.clone(), d.rss, d.median_se))
            .collect();
        for d in ds.iter_mut() {
            d.pmf = super::uniform_pmf(d.pmf.len());
            d.r.iter_mut().chain(d.r_pair.iter_mut()).chain(d.r_group.iter_mut()).for_each(|x| *x = 0.0);
        }
        Deconvolver::fit_all(ds, &mut grams, &sigmas);
        Deconvolver::fit_pmf_all(ds, passes);
        let won = Deconvolver::fit_all(ds, &mut grams, &sigmas) < warm_objective;
        ds.iter_mut().for_each(|d| d.cold_start_ended(won));
        let start = if won {
            super::uniform_pmf(ds[0].pmf.len())
        } else {
            for (d, w) in ds.iter_mut().zip(warm) {
                (d.pmf, d.r, d.r_pair, d.r_group, d.rss, d.median_se) = w;
            }
            previous
        };
        let later = Deconvolver::later_rounds(ds, &mut grams, &sigmas, start, None).expect("no stop");
        let (g, a0) = Deconvolver::cached_gram(ds, &mut grams);
        for (d, &sigma) in ds.iter_mut().zip(&sigmas) {
            d.rounds += 1 + later;
            if d.joint_on() {
                d.fit_rewards(g, a0, sigma, true);
            }
            d.refits += 1;
        }
    }

    /// The refit schedule by hand: every `refit_every` (100) steps early on, then t/g with
    /// g = `refit_growth` (8), or t/g_s (g_s = `settled_refit_growth`, 4) after a refit
    /// that found the delay settled.
    #[test]
    fn refit_schedule_by_hand() {
        let mut s = cfg(3, None).settings;
        (s.refit_every, s.refit_growth, s.settled_refit_growth) = (100, 8, 4);
        assert_eq!(super::next_refit_after(&s, 400, false), 500);
        assert_eq!(super::next_refit_after(&s, 400, true), 500);
        assert_eq!(super::next_refit_after(&s, 8000, false), 9000);
        assert_eq!(super::next_refit_after(&s, 8000, true), 10_000);
        s.settled_refit_growth = 1;
        assert_eq!(super::next_refit_after(&s, 8000, true), 16_000);
        assert_eq!(super::next_refit_after(&s, 8000, false), 9000);
    }

    /// `sparse_refits_below_se`: the refits of a run through `observe` come on the
    /// schedule, t + max(`refit_every`, t/g), except after a refit that found the delay
    /// median's standard error below the setting, where the next comes at
    /// t + max(`refit_every`, t/g_s); the refits themselves are untouched (bit for bit
    /// those of refits called at the same steps). Off (0), below every error, or with the
    /// delay told, the schedule is the plain one. A noisy walk of 12,000 steps, four rounds,
    /// reweighted passes, `refit_every` 200, g = 4, g_s = 2.
    #[test]
    fn sparse_refits_come_every_t_over_g_s_once_the_delay_settles() {
        let mut c = cfg(8, None);
        let s = &mut c.settings;
        (s.lasso, s.significance, s.reward_prior, s.successor_groups) = (0.05, 1.0, 1.0, true);
        (s.pmf_weighted, s.pmf_rounds, s.pmf_significance, s.pmf_prior) = (true, 4, 1.0, 0.1);
        (s.refit_every, s.refit_growth, s.settled_refit_growth) = (200, 4, 2);
        let walk = noisy_walk(&[0.05, 0.1, 0.2, 0.3, 0.2, 0.1, 0.05, 0.0, 0.0], 12_000, 29);
        // The steps of the refits, the error each found and the deconvolver at the end.
        let run = |c: &crate::deconv::DeconvConfig| {
            let mut d = Deconvolver::new(c.clone(), 10, 3);
            let (mut at, mut errors) = (Vec::new(), Vec::new());
            for &(x, next, delivered) in &walk {
                d.record_successor(x, next);
                if d.observe(x, delivered) {
                    at.push(d.steps());
                    errors.push(d.median_se().map_or(f64::INFINITY, |m| m.steps));
                }
            }
            (at, errors, d)
        };
        let bits = |d: &Deconvolver| {
            let b = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            (b(d.rewards()), b(d.pmf()), d.rss.map(f64::to_bits), d.rounds)
        };
        // The gap after the refit at t, with the delay settled or not.
        let gap = |t: u64, settled: bool| 200.max(t / if settled { 2 } else { 4 });
        let (plain_at, errors, plain) = run(&c);
        for w in plain_at.windows(2) {
            assert_eq!(w[1] - w[0], gap(w[0], false));
        }
        c.settings.sparse_refits_below_se = 1e-9;
        let (at, _, d) = run(&c);
        assert_eq!((&at, bits(&d)), (&plain_at, bits(&plain)));
        // A threshold some errors fall below: the gap follows each refit's own error.
        let mut sorted = errors.clone();
        sorted.sort_by(f64::total_cmp);
        let s = (sorted[sorted.len() / 2] + sorted[sorted.len() / 2 + 1]) / 2.0;
        c.settings.sparse_refits_below_se = s;
        let (at, errors, d) = run(&c);
        let settled: Vec<bool> = errors.iter().map(|&e| e < s).collect();
        assert!(settled.iter().any(|&x| x) && at.len() < plain_at.len(), "{errors:?}");
        for (w, &settled) in at.windows(2).zip(&settled) {
            assert_eq!(w[1] - w[0], gap(w[0], settled), "after the refit at {}", w[0]);
        }
        // The refits are those of refits called at the same steps.
        let mut by_hand = Deconvolver::new(c.clone(), 10, 3);
        for &(x, next, delivered) in &walk {
            by_hand.record_successor(x, next);
            by_hand.record(x, delivered);
            if at.contains(&by_hand.steps()) {
                by_hand.refit();
            }
        }
        assert_eq!(bits(&d), bits(&by_hand));
        // A told delay: never settled, the plain schedule.
        let mut told = cfg(8, Some(vec![1.0 / 9.0; 9]));
        let t = &mut told.settings;
        (t.refit_every, t.refit_growth, t.settled_refit_growth) = (200, 4, 2);
        told.settings.sparse_refits_below_se = 1e9;
        let (at, _, _) = run(&told);
        assert_eq!(at, plain_at);
    }

    /// A refit with its cold start on copies, on one thread or beside the warm start on
    /// a second, is the refit in the plain sequential order, bit for bit: a random walk
    /// over 30 pairs (some rewarded), noisy deliveries, the settings of `deconv-model`
    /// that shape a refit (reweighted passes, four rounds or one, the lasso, successor
    /// groups, the joint test on or off) and a refit every 400 steps, of which the cold start wins
    /// some and loses others. Three runs on two threads (each may take a different order
    /// of events: which start ends first, whether the warm start's later rounds run and
    /// are stopped).
    #[test]
    fn a_cold_start_on_another_thread_changes_no_fit() {
        for (rounds, joint) in [(4, 1.0), (1, 0.0)] {
            same_fits_on_any_thread(rounds, joint);
        }
    }

    fn same_fits_on_any_thread(rounds: u32, joint: f64) {
        let k = 8;
        let mut c = cfg(k, None);
        let s = &mut c.settings;
        (s.lasso, s.significance, s.reward_prior, s.joint_test, s.successor_groups) =
            (0.05, 1.0, 1.0, joint, true);
        (s.pmf_weighted, s.pmf_rounds, s.pmf_significance, s.pmf_prior) = (true, rounds, 1.0, 0.1);
        let walk = noisy_walk(&[0.05, 0.1, 0.2, 0.3, 0.2, 0.1, 0.05, 0.0, 0.0], 8000, 23);
        // beside: None for the plain order, else whether the cold start may have a thread.
        let run = |beside: Option<bool>| {
            FORCE.with(|f| f.set(beside));
            let mut d = Deconvolver::new(c.clone(), 10, 3);
            for (t, &(x, next, delivered)) in walk.iter().enumerate() {
                d.record_successor(x, next);
                d.record(x, delivered);
                if (t + 1) % 400 == 0 {
                    match beside {
                        None => refit_in_place(std::slice::from_mut(&mut d)),
                        Some(_) => d.refit(),
                    }
                }
            }
            FORCE.with(|f| f.set(None));
            d
        };
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let plain = run(None);
        assert_eq!(plain.refits(), 20);
        assert!(
            plain.cold_wins > 0 && plain.cold_wins < plain.cold_starts,
            "cold start won {} of {}",
            plain.cold_wins,
            plain.cold_starts
        );
        for beside in [false, true, true, true] {
            let d = run(Some(beside));
            assert_eq!(bits(d.rewards()), bits(plain.rewards()));
            assert_eq!(bits(&d.r_pair), bits(&plain.r_pair));
            assert_eq!(bits(&d.r_group), bits(&plain.r_group));
            assert_eq!(bits(d.pmf()), bits(plain.pmf()));
            assert_eq!(d.rss.map(f64::to_bits), plain.rss.map(f64::to_bits));
            assert_eq!(
                d.median_se().map(|m| m.steps.to_bits()),
                plain.median_se().map(|m| m.steps.to_bits())
            );
            let counts = |d: &Deconvolver| (d.refits(), d.cold_starts, d.cold_wins, d.rounds, d.joint_drops);
            assert_eq!(counts(&d), counts(&plain));
        }
    }
}
