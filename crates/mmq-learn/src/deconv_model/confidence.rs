//! The state of `deconv-model`'s exploration from confidence, (M2) of the learner's
//! module documentation: how much information on each pair's reward the fit has, how much
//! a pair needs before it is known, and the pairs whose information is still in flight.

use crate::decode::ValueDeconvolver;

/// The state of the confidence rule (M2).
#[derive(Clone, Debug)]
pub(super) struct Confidence {
    /// z.
    pub(super) z: f64,
    /// κ √(2 ln m): the reward fit's significance threshold, in standard errors.
    pub(super) detect: f64,
    /// c(j) = Σ_{k ≤ j} p̂(k)², j = 0..=K (c(K) = Σ p̂²).
    pub(super) cum: Vec<f64>,
    /// I* = (κ √(2 ln m) + z)² σ̂² / v_max².
    pub(super) needed: f64,
    /// The deconvolver's refits when `cum` and `needed` were computed (None: never).
    pub(super) refits: Option<u64>,
    /// The pairs of the last K steps, the latest last.
    pub(super) recent: std::collections::VecDeque<u32>,
    /// Scratch: c(K) − I(x) of the pairs in `recent` (0 elsewhere).
    pub(super) deficit: Vec<f64>,
    /// Pairs known once: they stay known.
    pub(super) latched: Vec<bool>,
}

impl Confidence {
    pub(super) fn new(z: f64, detect: f64, pairs: usize) -> Self {
        Self {
            z,
            detect,
            cum: Vec::new(),
            needed: 0.0,
            refits: None,
            recent: std::collections::VecDeque::new(),
            deficit: vec![0.0; pairs],
            latched: vec![false; pairs],
        }
    }

    /// Recomputes c(j) and I* from the deconvolver's last fit.
    pub(super) fn update(&mut self, d: &ValueDeconvolver) {
        let mut acc = 0.0;
        self.cum = d
            .pmf()
            .iter()
            .map(|p| {
                acc += p * p;
                acc
            })
            .collect();
        let t = self.detect + self.z;
        self.needed = t * t * d.noise_to_scale();
        self.refits = Some(d.refits());
    }

    /// Σ p̂(k)².
    pub(super) fn a0(&self) -> f64 {
        self.cum.last().copied().unwrap_or(0.0)
    }

    /// Fills `deficit` with Σ over the recent visits of x of c(K) − c(lag): the part of
    /// their information still in flight.
    pub(super) fn fill_deficits(&mut self) {
        let (a0, len) = (self.a0(), self.recent.len());
        for (j, &x) in self.recent.iter().enumerate() {
            let lag = len - 1 - j;
            self.deficit[x as usize] += a0 - self.cum[lag.min(self.cum.len() - 1)];
        }
    }

    pub(super) fn clear_deficits(&mut self) {
        for &x in &self.recent {
            self.deficit[x as usize] = 0.0;
        }
    }

    /// Whether pair `x`, tried `n` times with the fitted reward `r`, is known by (M2), with
    /// `deficit` filled; latches it when it is.
    pub(super) fn known(&mut self, x: usize, n: u32, r: f64) -> bool {
        if !self.latched[x]
            && n >= 1
            && (r != 0.0 || self.a0() * f64::from(n) - self.deficit[x] >= self.needed)
        {
            self.latched[x] = true;
        }
        self.latched[x]
    }
}
