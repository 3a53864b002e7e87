//! A learner of your own crate on the benchmark suite, through the library: the suite's
//! tier becomes a sweep spec (`Suite::external_spec`), and `run_sweep_with` builds each
//! seed's learner with your factory instead of from a name. The results are stored,
//! resumed and written exactly as `mmq suite run` does (docs/suite.md).
//!
//! The learner here is expected SARSA (the mean over the ε-greedy policy's next action
//! in place of Q-learning's max), written against the `mmq_learn::Learner` trait only.
//!
//! ```sh
//! cargo run --release --example suite_own_learner -- lite suite/expected-sarsa-lite
//! mmq suite report suite/expected-sarsa-lite/results.json suite/q-lite/results.json --out suite/board
//! ```

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;

use mmq_core::{Action, Rng, State};
use mmq_lab::suite::{Suite, SuiteRun, results_of_dir, write_results};
use mmq_lab::sweep::run_sweep_with;
use mmq_lab::{Control, LabError};
use mmq_learn::policy::{argmax_random_tie, epsilon_greedy};
use mmq_learn::{Decision, Experience, Learner, Table};

/// Expected SARSA: Q(s,a) += α (r + γ Σ_a' π(a'|s') Q(s',a') − Q(s,a)), π ε-greedy.
#[derive(Debug)]
struct ExpectedSarsa {
    q: Vec<f64>,
    n_actions: usize,
    alpha: f64,
    gamma: f64,
    epsilon: f64,
}

impl ExpectedSarsa {
    fn row(&self, s: State) -> &[f64] {
        &self.q[s * self.n_actions..(s + 1) * self.n_actions]
    }

    /// The value of `s` under the ε-greedy policy: ε × the mean + (1 − ε) × the best
    /// (ties share the greedy mass, all at the best value).
    fn expected(&self, s: State) -> f64 {
        let row = self.row(s);
        let best = row.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mean = row.iter().sum::<f64>() / self.n_actions as f64;
        self.epsilon * mean + (1.0 - self.epsilon) * best
    }
}

impl Learner for ExpectedSarsa {
    fn name(&self) -> &'static str {
        "expected-sarsa"
    }

    fn act(&mut self, state: State, rng: &mut Rng) -> Decision {
        let (action, explored) =
            epsilon_greedy(self.epsilon, self.n_actions, rng, |r| argmax_random_tie(self.row(state), r));
        Decision { action, model: None, explored }
    }

    fn observe(&mut self, e: &Experience<'_>) {
        let target = e.reward + self.gamma * self.expected(e.next_state);
        let q = &mut self.q[e.state * self.n_actions + e.action];
        *q += self.alpha * (target - *q);
    }

    fn greedy(&self, state: State, rng: &mut Rng) -> Action {
        argmax_random_tie(self.row(state), rng)
    }

    fn action_values(&self, state: State, out: &mut [f64]) {
        out.copy_from_slice(self.row(state));
    }

    fn tables(&self) -> Vec<Table> {
        vec![Table {
            name: "q".into(),
            shape: vec![self.q.len() / self.n_actions, self.n_actions],
            data: self.q.clone(),
        }]
    }
}

fn run(tier: &str, out: PathBuf) -> Result<(), LabError> {
    let suite = Suite::builtin("v1")?;
    let agent = "expected-sarsa";
    let spec = suite.external_spec(tier, agent)?;
    let run = SuiteRun {
        suite: suite.version.clone(),
        tier: tier.into(),
        agent: agent.into(),
        tasks: suite.task_names(),
        subset: false,
    };
    std::fs::create_dir_all(&out).map_err(|source| LabError::Io { path: out.clone(), source })?;
    run.claim(&out)?;
    // The task's shared parameters (α, γ, ε, q0) are those of the spec's cell.
    let factory = |cell: usize, n_states: usize, n_actions: usize, _seed: u64| {
        let p = spec.config(cell).learner.params;
        let learner = ExpectedSarsa {
            q: vec![p.q0; n_states * n_actions],
            n_actions,
            alpha: p.alpha,
            gamma: p.gamma,
            epsilon: p.epsilon,
        };
        Ok(Box::new(learner) as Box<dyn Learner>)
    };
    let stop = AtomicBool::new(false);
    let ctl = Control { stop: &stop, progress: &|_| {} };
    let done = run_sweep_with(&spec, &out, None, ctl, &|_| {}, Some(&factory))?;
    let path = write_results(&out, &results_of_dir(&out)?)?;
    println!("ran {} seed(s), skipped {}; wrote {}", done.ran, done.skipped, path.display());
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [tier, out] = args.as_slice() else {
        eprintln!("usage: suite_own_learner lite|full OUT_DIR");
        return ExitCode::from(2);
    };
    match run(tier, PathBuf::from(out)) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}
