//! Tests of several trajectories feeding one deconvolver (parameter sharing): each
//! delivery is explained by its own trajectory's past pairs only, whatever the order in
//! which the trajectories take turns, and the edge terms of every unfinished trajectory
//! are removed.

use super::tests::cfg;
use super::*;
use mmq_core::seed::rng_from_seed;
use rand::RngExt;

const P: [f64; 5] = [0.0, 0.2, 0.5, 0.3, 0.0];
const TOL: f64 = 1e-7;
const TRUTH: [f64; 8] = [0.0, 10.0, -1.0, 0.0, 3.0, 0.0, -2.0, 0.5];

/// Three trajectories, the third starting late, taking irregular turns, then a fourth. Each step's delivery is the expected reward Σ_j p(j) R(x_{t−j})
/// over its own trajectory's current run. `mixed`: every step is fed as one trajectory
/// (the memory a learner would have without [`Deconvolver::set_stream`]).
fn feed(d: &mut Deconvolver, steps: usize, mixed: bool) {
    let mut rng = rng_from_seed(5);
    let mut runs: Vec<Vec<usize>> = vec![Vec::new(); 3];
    for t in 0..steps {
        let who = match rng.random_range(0..10) {
            0..5 => 0,
            5..8 => 1,
            _ if t > steps / 3 => 2,
            _ => 1,
        };
        if !mixed {
            d.set_stream(who);
        }
        let x = rng.random_range(0..TRUTH.len());
        let run = &mut runs[who];
        run.push(x);
        let n = run.len();
        let r: f64 = (0..P.len().min(n)).map(|j| P[j] * TRUTH[run[n - 1 - j]]).sum();
        d.observe(x, r);
    }
    // A fourth trajectory takes three steps of the unrewarded pair 0 last: fed last, it
    // alone has nothing to tell of p.
    if !mixed {
        d.set_stream(3);
    }
    for _ in 0..3 {
        d.observe(0, 0.0);
    }
}

/// Told p̂: the unpenalised fit of noise-free deliveries recovers R exactly when each
/// trajectory's steps are lagged against its own (every trajectory stops mid-run, so
/// the edge terms of all of them must come off), and not when they are mixed.
#[test]
fn each_trajectory_is_lagged_against_its_own_steps() {
    let fit = |mixed: bool| {
        let mut d = Deconvolver::new(cfg(P.len() - 1, Some(P.to_vec())), TRUTH.len(), 1);
        feed(&mut d, 6000, mixed);
        d.refit();
        d.rewards().to_vec()
    };
    let worst = |r: &[f64]| r.iter().zip(TRUTH).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    let own = fit(false);
    assert!(worst(&own) < 1e-9, "R̂ = {own:?}");
    let mixed = fit(true);
    assert!(worst(&mixed) > 0.1, "mixing the trajectories went unseen: R̂ = {mixed:?}");
}

/// Estimated p̂, plain and with the reweighted passes over each trajectory's history:
/// the alternating fit of the same deliveries finds the pmf and the rewards (the plain
/// fit only if the windows still open at every trajectory's end are taken out).
#[test]
fn the_delay_is_estimated_from_every_trajectory() {
    for weighted in [false, true] {
        let mut c = cfg(P.len() - 1, None);
        (c.settings.pmf_weighted, c.settings.refit_every) = (weighted, 1000);
        let mut d = Deconvolver::new(c, TRUTH.len(), 1);
        feed(&mut d, 6000, false);
        for _ in 0..5 {
            d.refit();
        }
        for (k, (&got, want)) in d.pmf().iter().zip(P).enumerate() {
            assert!((got - want).abs() < TOL, "weighted {weighted}: p̂({k}) = {got}, want {want}");
        }
        for (x, (&got, want)) in d.rewards().iter().zip(TRUTH).enumerate() {
            assert!((got - want).abs() < TOL, "weighted {weighted}: R̂({x}) = {got}, want {want}");
        }
        // The reweighted passes ran over every trajectory's history (the last one's alone
        // holds no reward to weigh, and would leave no system to take the error from).
        assert_eq!(d.median_se().is_some(), weighted);
    }
}
