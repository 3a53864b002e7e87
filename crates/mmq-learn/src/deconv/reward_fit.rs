//! The fit of R given p: a lasso on the Gram matrix G and the right-hand side b of the
//! sufficient statistics, solved by coordinate descent from the previous R̂, with reward
//! features per pair and per group of pairs, and the joint test of the active pairs.

use nalgebra::DMatrix;

use super::gram::Gram;
use super::linalg::{joint_failure, joint_inverse, update_inverse};
use super::stats::UNSEEN;
use super::{CD_SWEEPS, Deconvolver, ELIM_SWEEPS, MIXED, PAIR_PENALTY};

/// The reward groups, as (a member's pair id, compact members).
pub(crate) type Groups = Vec<(usize, Vec<usize>)>;

/// The penalised least-squares problem of R given p (D2 with p fixed).
struct Lasso<'a> {
    g: &'a Gram,
    bvec: Vec<f64>,
    /// μ a_0: the ridge on every feature.
    ridge: f64,
    /// κ √(2 ln m) σ̂: the significance part of the threshold, per √information.
    kappa: f64,
    /// λ₁.
    lasso: f64,
    /// Sign every feature must have (0: free).
    sign: f64,
    /// Penalty factor of a pair's own feature.
    pair_factor: f64,
    grouped: bool,
    groups: Groups,
    /// 1ᵀ G_g 1 of each group g.
    gss: Vec<f64>,
    /// G(i, i) of each compact pair.
    diag: Vec<f64>,
    /// The threshold of each pair's own feature.
    pair_thr: Vec<f64>,
    /// The sweep, laid out in its order: the compact pairs of the groups one after
    /// another (group g's at `start[g]..start[g + 1]`), and per position the pair's b,
    /// G(i, i), its feature's threshold and G(i, i) + ridge.
    sweep: Sweep,
}

/// The pair features of a coordinate-descent sweep in the order they are tested, with
/// what each test reads besides the iterate.
#[derive(Default)]
struct Sweep {
    start: Vec<usize>,
    /// The groups whose own feature is tested (grouped, more than one pair,
    /// 1ᵀG_g1 > 0), in order.
    groups_on: Vec<usize>,
    pair: Vec<usize>,
    b: Vec<f64>,
    gii: Vec<f64>,
    thr: Vec<f64>,
    den: Vec<f64>,
}

impl Lasso<'_> {
    /// The threshold of a feature with information `info` and penalty `factor`.
    fn threshold(&self, info: f64, factor: f64) -> f64 {
        factor * (self.lasso * info + self.kappa * info.sqrt())
    }

    /// The exact minimiser along one feature; with a sign constraint, clipped at zero
    /// (still exact: the one-dimensional problem is convex).
    fn soft(&self, z: f64, info: f64, factor: f64) -> f64 {
        self.soft_at(z, self.threshold(info, factor), info + self.ridge)
    }

    /// [`Self::soft`] with its threshold `thr` and denominator `den` = info + ridge.
    #[inline]
    fn soft_at(&self, z: f64, thr: f64, den: f64) -> f64 {
        let v = if z > thr {
            (z - thr) / den
        } else if z < -thr {
            (z + thr) / den
        } else {
            0.0
        };
        if v * self.sign < 0.0 { 0.0 } else { v }
    }
}

/// The coordinate-descent iterate: pair parts, group parts, their sums and G R.
struct Iterate {
    rp: Vec<f64>,
    rs: Vec<f64>,
    /// Total R̂ per compact pair.
    r: Vec<f64>,
    /// G r.
    gr: Vec<f64>,
    /// Pairs dropped by the joint test; they stay at zero for this fit.
    excluded: Vec<bool>,
    /// The screening of the pair features at zero ([`Screen`]).
    screen: Screen,
}

/// Safe screening of the pair features at zero: a test that left feature i at zero with
/// |z| ≤ thr by a margin leaves it at zero again, bit for bit, as long as G r at i has
/// moved by less than that margin. Every change of G r is d · G(j, ·) for a feature j that
/// moved by d, so G r at any pair has moved by at most Σ |d| max_c |G(j, c)| over the
/// moves since (`reach`), plus rounding. A skipped test is one that would have found
/// d = 0: the fit is the same number for number.
struct Screen {
    /// Σ |d| max_c |G(j, c)| over the moves so far, and the moves.
    reach: f64,
    moves: usize,
    /// `reach` rounded up by the largest rounding error of its sum (∞ once there have
    /// been too many moves for that bound).
    reach_hi: f64,
    /// Per sweep position, the reach up to which its test is known to give zero (−∞:
    /// test it).
    until: Vec<f64>,
}

impl Screen {
    /// At most this many moves per fit are screened (bounds the rounding of the sums).
    const MOVES: usize = 1 << 20;

    fn new(n: usize) -> Self {
        let until = vec![f64::NEG_INFINITY; n];
        #[cfg(test)]
        if tests::UNSCREENED.with(std::cell::Cell::get) {
            return Self { reach: 0.0, moves: Self::MOVES, reach_hi: f64::INFINITY, until };
        }
        Self { reach: 0.0, moves: 0, reach_hi: 0.0, until }
    }

    /// A row with largest |entry| `max_abs` was added to G r with factor d.
    #[inline]
    fn moved(&mut self, d: f64, max_abs: f64) {
        self.reach += d.abs() * max_abs;
        self.moves += 1;
        // A sum of m ≤ 2^20 non-negative terms is within m ε ≤ 2^-33 of its exact value.
        self.reach_hi =
            if self.moves < Self::MOVES { self.reach * (1.0 + 2f64.powi(-30)) } else { f64::INFINITY };
    }

    /// The test at position `p` left its feature at zero with z = b − (G r)_i (+ 0),
    /// threshold `thr`, (G r)_i = `gr`. With δ the exact change of (G r)_i since, the next
    /// z is within (1 + ε)(|z| / (1 − ε) + (1 + ε) δ + m ε (|gr| + 2δ)) of zero (m ≤ 2^20
    /// additions, each rounded): at most thr whenever δ is below the budget below.
    #[inline]
    fn at_zero(&mut self, p: usize, z: f64, thr: f64, gr: f64) {
        let e = 2f64.powi(-50);
        let budget =
            (thr * (1.0 - e) - z.abs() * (1.0 + e) - gr.abs() * 2f64.powi(-32)) / (1.0 + 2f64.powi(-31));
        self.until[p] =
            if budget > 0.0 { self.reach * (1.0 - 2f64.powi(-30)) + budget } else { f64::NEG_INFINITY };
    }
}

impl Iterate {
    /// R̂ of compact pair i moved by d: r(i) += d, G r += d · G(i, ·).
    fn shift(&mut self, g: &Gram, i: usize, d: f64) {
        self.r[i] += d;
        let max_abs = g.add_row(i, d, &mut self.gr);
        self.screen.moved(d, max_abs);
    }

    /// At most `sweeps` sweeps of coordinate descent over every feature (fewer once no
    /// estimate moves by 1e-12). A sweep takes the groups in order, each group's own
    /// feature (when it has one) before its pairs' features; the pairs of consecutive
    /// groups without a feature of their own are one stretch of the sweep.
    fn descend(&mut self, l: &Lasso<'_>, sweeps: usize) {
        let sw = &l.sweep;
        for _ in 0..sweeps {
            let mut moved: f64 = 0.0;
            let mut from = 0;
            for &gi in &sw.groups_on {
                self.test_pairs(l, from, sw.start[gi], &mut moved);
                from = sw.start[gi];
                // The group feature: one value shared by the group's pairs.
                let members = &l.groups[gi].1;
                let z: f64 =
                    members.iter().map(|&i| l.bvec[i] - self.gr[i]).sum::<f64>() + l.gss[gi] * self.rs[gi];
                let d = l.soft(z, l.gss[gi], 1.0) - self.rs[gi];
                if d != 0.0 {
                    self.rs[gi] += d;
                    for &i in members {
                        self.shift(l.g, i, d);
                    }
                    moved = moved.max(d.abs());
                }
            }
            self.test_pairs(l, from, sw.pair.len(), &mut moved);
            if moved < 1e-12 {
                break;
            }
        }
    }

    /// The pair features at sweep positions `from..to`, in order; the largest move is
    /// raised into `moved`. Positions the screen rules out are passed over four at a
    /// time while no feature moves (the screen's reach changes only with a move).
    fn test_pairs(&mut self, l: &Lasso<'_>, from: usize, to: usize, moved: &mut f64) {
        let sw = &l.sweep;
        let mut p = from;
        while p < to {
            let reach_hi = self.screen.reach_hi;
            while p + 4 <= to && self.screen.until[p..p + 4].iter().fold(true, |all, &u| all & (reach_hi < u))
            {
                #[cfg(test)]
                tests::SKIPPED.with(|c| c.set(c.get() + 4));
                p += 4;
            }
            if p == to {
                break;
            }
            if reach_hi < self.screen.until[p] {
                #[cfg(test)]
                tests::SKIPPED.with(|c| c.set(c.get() + 1));
                p += 1;
                continue;
            }
            let (i, gii) = (sw.pair[p], sw.gii[p]);
            if gii > 0.0 && !self.excluded[i] {
                let rp = self.rp[i];
                let z = sw.b[p] - self.gr[i] + gii * rp;
                let d = l.soft_at(z, sw.thr[p], sw.den[p]) - rp;
                if d != 0.0 {
                    self.screen.until[p] = f64::NEG_INFINITY;
                    self.rp[i] += d;
                    self.shift(l.g, i, d);
                    *moved = moved.max(d.abs());
                } else if rp == 0.0 && z.abs() <= sw.thr[p] {
                    self.screen.at_zero(p, z, sw.thr[p], self.gr[i]);
                } else {
                    self.screen.until[p] = f64::NEG_INFINITY;
                }
            }
            p += 1;
        }
    }
}

/// The joint test's state between two of its rounds: the active set (in the order of its
/// inverse) and (G_S + ridge)⁻¹.
type JointState = Option<(Vec<usize>, DMatrix<f64>)>;

/// What one round of the joint test decided.
enum JointStep {
    /// Every active pair passes: the fit is final.
    Done,
    /// Every pair passes, but the last fit was cut short: run it to convergence.
    Converge,
    /// This compact pair was dropped: refit the rest.
    Dropped(usize),
}

impl Deconvolver {
    /// Whether the joint test runs (on, and pair features only).
    pub(super) fn joint_on(&self) -> bool {
        self.cfg.settings.joint_test > 0.0 && !self.cfg.settings.state_rewards
    }

    /// The reward groups, as (a member's pair id, compact members): the pairs of each
    /// state (`state_rewards`), or the pairs of a state that have only ever led to one
    /// and the same next state (`successor_groups`; a pair seen leading to two next
    /// states is a group of its own), or one group per state when neither is on (then
    /// unused). Groups of one pair carry no feature of their own.
    pub(crate) fn groups(&self) -> Groups {
        let a_n = self.num_actions;
        let mut groups: Groups = Vec::new();
        // The groups of each state so far, as (key, group index): a state's pairs make at
        // most `a_n` groups, found by a short scan rather than a hash.
        let mut slots = vec![(0u64, 0usize); self.succ.len()];
        let mut used = vec![0usize; self.succ.len().div_ceil(a_n)];
        for (i, &x) in self.stats.pairs.iter().enumerate() {
            let st = x as usize / a_n;
            let succ = self.succ[x as usize];
            let key = if !self.cfg.settings.successor_groups || self.cfg.settings.state_rewards {
                0
            } else if succ == UNSEEN || succ == MIXED {
                u64::from(u32::MAX) + 1 + i as u64
            } else {
                u64::from(succ)
            };
            let own = &slots[st * a_n..st * a_n + used[st]];
            let g_i = match own.iter().find(|&&(k, _)| k == key) {
                Some(&(_, g_i)) => g_i,
                None => {
                    groups.push((x as usize, Vec::new()));
                    slots[st * a_n + used[st]] = (key, groups.len() - 1);
                    used[st] += 1;
                    groups.len() - 1
                }
            };
            groups[g_i].1.push(i);
        }
        groups
    }

    /// Whether pairs share group features (per state or per successor).
    fn grouped(&self) -> bool {
        self.cfg.settings.state_rewards || self.cfg.settings.successor_groups
    }

    /// R given p: lasso by coordinate descent on (G, b), warm-started; `g` and a_0 = Σ p(k)²
    /// from the counts under the current p̂ ([`super::stats::LagStats::gram`]). Returns the
    /// penalised objective (D2) at the fit (½ RSS + penalties).
    pub(super) fn fit_rewards(&mut self, g: &Gram, a0: f64, sigma: f64, joint: bool) -> f64 {
        let l = self.lasso_problem(g, a0, sigma);
        let mut it = self.start_iterate(&l);
        let mut last: JointState = None;
        // Between two drops of the joint test the refit is cut short (ELIM_SWEEPS);
        // before the test may pass, the fit is run to convergence.
        let mut sweeps = CD_SWEEPS;
        loop {
            it.descend(&l, sweeps);
            if !joint || !self.joint_on() {
                break;
            }
            match self.joint_round(&l, &it, &mut last, sweeps < CD_SWEEPS) {
                JointStep::Done => break,
                JointStep::Converge => sweeps = CD_SWEEPS,
                JointStep::Dropped(i) => {
                    sweeps = ELIM_SWEEPS;
                    self.joint_drops += 1;
                    let d = -it.rp[i];
                    it.rp[i] = 0.0;
                    it.shift(g, i, d);
                    it.excluded[i] = true;
                }
            }
        }
        self.store_fit(&l, &it)
    }

    /// The lasso of R given the current p̂, with Gram matrix `g`, a_0 = Σ p(k)² and the
    /// residual deviation `sigma`.
    fn lasso_problem<'a>(&self, g: &'a Gram, a0: f64, sigma: f64) -> Lasso<'a> {
        let n = g.n();
        // With hundreds of pairs a plain 2σ test would pass several spurious rewards per
        // fit: κ × the universal threshold over the fit's features.
        let tau = super::threshold_in_se(self.cfg.settings.significance, n, self.num_actions);
        // With group features, a pair's own reward pays PAIR_PENALTY × a group's penalty:
        // of two explanations that fit equally (the goal's actions, or the only pair that
        // enters the goal), the coarser one wins.
        let grouped = self.grouped();
        let groups = self.groups();
        // Without group features the groups' sums are never read (their features stay 0).
        let gss = groups
            .iter()
            .map(|(_, members)| match grouped {
                true => members.iter().map(|&i| members.iter().map(|&i2| g.get(i, i2)).sum::<f64>()).sum(),
                false => 0.0,
            })
            .collect();
        let mut l = Lasso {
            g,
            bvec: self.stats.bvec(&self.pmf),
            ridge: self.cfg.settings.reward_prior * a0,
            kappa: tau * sigma,
            lasso: self.cfg.settings.lasso,
            sign: self.sign,
            pair_factor: if grouped { PAIR_PENALTY } else { 1.0 },
            grouped,
            groups,
            gss,
            diag: (0..n).map(|i| g.diag(i)).collect(),
            pair_thr: Vec::new(),
            sweep: Sweep::default(),
        };
        l.pair_thr = l.diag.iter().map(|&gii| l.threshold(gii, l.pair_factor)).collect();
        let mut sw = Sweep::default();
        for (gi, (_, members)) in l.groups.iter().enumerate() {
            sw.start.push(sw.pair.len());
            if l.grouped && members.len() > 1 && l.gss[gi] > 0.0 {
                sw.groups_on.push(gi);
            }
            for &i in members {
                sw.pair.push(i);
                sw.b.push(l.bvec[i]);
                sw.gii.push(l.diag[i]);
                sw.thr.push(l.pair_thr[i]);
                sw.den.push(l.diag[i] + l.ridge);
            }
        }
        sw.start.push(sw.pair.len());
        l.sweep = sw;
        l
    }

    /// The warm start: the previous fit's parts, their sums and G R.
    fn start_iterate(&self, l: &Lasso<'_>) -> Iterate {
        let n = l.g.n();
        let rp: Vec<f64> = self.stats.pairs.iter().map(|&x| self.r_pair[x as usize]).collect();
        let mut rs: Vec<f64> = l.groups.iter().map(|(x0, _)| self.r_group[*x0]).collect();
        if !l.grouped {
            rs.iter_mut().for_each(|x| *x = 0.0);
        }
        let mut r: Vec<f64> = vec![0.0; n];
        for (gi, (_, members)) in l.groups.iter().enumerate() {
            for &i in members {
                r[i] = rs[gi] + rp[i];
            }
        }
        let support: Vec<usize> = (0..n).filter(|&i| r[i] != 0.0).collect();
        let gr = l.g.times_sparse(&support, &r);
        Iterate { rp, rs, r, gr, excluded: vec![false; n], screen: Screen::new(n) }
    }

    /// One round of the joint test (once per refit, on its final fit): a pair that passed
    /// the lasso's test given the others must also stand out jointly with them,
    /// |R̂(x)| > κ_J κ √(2 ln m) σ̂ √[(G_S + ridge)⁻¹]_xx over the active set S.
    /// Two pairs that always come close together in time (a corridor step and its way
    /// back) are nearly collinear: each can carry a large reward of opposite sign that the
    /// per-pair test passes, while their joint standard errors are large. The pair
    /// furthest below its threshold is dropped and the rest refitted (backward
    /// elimination: of two collinear pairs one goes, and the other then carries what the
    /// data support — two wall bumps in a corner keep one −1 between them, where dropping
    /// every failing pair at once lost both), until every active pair passes. `cut_short`:
    /// the last descent stopped at ELIM_SWEEPS.
    fn joint_round(
        &mut self,
        l: &Lasso<'_>,
        it: &Iterate,
        last: &mut JointState,
        cut_short: bool,
    ) -> JointStep {
        let n = l.g.n();
        let now: Vec<usize> = (0..n).filter(|&i| it.rp[i] != 0.0).collect();
        if now.len() < 2 {
            return JointStep::Done;
        }
        // After a drop the refit changes the set by a few pairs: the inverse is then
        // updated pair by pair in O(s²) each, instead of refactored in O(s³).
        let updated = last
            .take()
            .and_then(|(order, inv)| update_inverse(l.g, l.ridge, order, inv, &now, (now.len() / 4).max(4)));
        let (active, inv) = match updated {
            Some(x) => x,
            None => {
                self.joint_factorisations += 1;
                match joint_inverse(l.g, &now, l.ridge) {
                    Some(inv) => (now, inv),
                    None => return JointStep::Done,
                }
            }
        };
        let failure = joint_failure(&inv, &active, &it.rp, self.cfg.settings.joint_test * l.kappa);
        let step = match failure {
            None if cut_short => JointStep::Converge,
            None => return JointStep::Done,
            Some(pos) => JointStep::Dropped(active[pos]),
        };
        *last = Some((active, inv));
        step
    }

    /// Stores the fit in R̂ and its parts and the RSS; returns the penalised objective.
    fn store_fit(&mut self, l: &Lasso<'_>, it: &Iterate) -> f64 {
        // RSS = Σ r² − 2 Rᵀb + Rᵀ G R
        let rb: f64 = it.r.iter().zip(&l.bvec).map(|(x, y)| x * y).sum();
        let rgr: f64 = it.r.iter().zip(&it.gr).map(|(x, y)| x * y).sum();
        let rss = self.stats.sum_r2 - 2.0 * rb + rgr;
        self.rss = Some(rss);
        let mut penalty = 0.0;
        for (i, &x) in self.stats.pairs.iter().enumerate() {
            self.r[x as usize] = it.r[i];
            self.r_pair[x as usize] = it.rp[i];
            penalty += l.threshold(l.g.diag(i), l.pair_factor) * it.rp[i].abs()
                + 0.5 * l.ridge * it.rp[i] * it.rp[i];
        }
        for (gi, (_, members)) in l.groups.iter().enumerate() {
            for &i in members {
                self.r_group[self.stats.pairs[i] as usize] = it.rs[gi];
            }
            penalty += l.threshold(l.gss[gi], 1.0) * it.rs[gi].abs() + 0.5 * l.ridge * it.rs[gi] * it.rs[gi];
        }
        0.5 * rss + penalty
    }
}

#[cfg(test)]
mod tests {
    use crate::deconv::Deconvolver;
    use crate::deconv::tests::{cfg, noisy_walk};

    thread_local! {
        /// Whether the fits of this thread test every feature in every sweep.
        pub(super) static UNSCREENED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
        /// Tests skipped by the screening in this thread.
        pub(super) static SKIPPED: std::cell::Cell<u64> = const { std::cell::Cell::new(0) };
    }

    /// The screened coordinate descent gives the fit of the one that tests every feature
    /// in every sweep, bit for bit: a random walk over 30 pairs (some rewarded, some not),
    /// noisy deliveries, the lasso, the significance threshold, successor groups and the
    /// joint test on, the delay estimated, several refits.
    #[test]
    fn screening_changes_no_fit() {
        let k = 6;
        let mut c = cfg(k, None);
        let s = &mut c.settings;
        (s.lasso, s.significance, s.reward_prior, s.joint_test, s.successor_groups, s.refit_every) =
            (0.05, 1.0, 1.0, 1.0, true, 700);
        let walk = noisy_walk(&[0.1, 0.2, 0.4, 0.2, 0.1, 0.0, 0.0], 6000, 17);
        let run = |screened: bool| {
            UNSCREENED.with(|u| u.set(!screened));
            let mut d = Deconvolver::new(c.clone(), 10, 3);
            for &(x, next, delivered) in &walk {
                d.observe_transition(x, next, delivered);
            }
            UNSCREENED.with(|u| u.set(false));
            d
        };
        let a = run(true);
        let skipped = SKIPPED.with(std::cell::Cell::get);
        let b = run(false);
        assert!(skipped > 100 && SKIPPED.with(std::cell::Cell::get) == skipped, "{skipped} skipped");
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert!(a.refits() > 3 && a.rewards().iter().filter(|&&r| r != 0.0).count() > 2);
        assert_eq!(bits(a.rewards()), bits(b.rewards()));
        assert_eq!(bits(&a.r_pair), bits(&b.r_pair));
        assert_eq!(bits(&a.r_group), bits(&b.r_group));
        assert_eq!(bits(a.pmf()), bits(b.pmf()));
        assert_eq!(a.rss.map(f64::to_bits), b.rss.map(f64::to_bits));
    }
}
