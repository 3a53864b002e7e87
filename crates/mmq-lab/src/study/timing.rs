//! The reward-timing figure's steps: one seed of a study run again with an observer
//! that keeps the last steps' earned and received rewards (the same run, bit for bit,
//! as that seed's in the study's store).

use crate::config::RunConfig;
use crate::error::LabError;
use crate::resolved::Resolved;
use crate::resolved::run_seed;
use crate::runner::{Control, memory_limit};

/// One decision step as the reward-timing figure shows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepRewards {
    /// Decision step t.
    pub t: u64,
    /// Reward the environment emitted at t.
    pub earned: f64,
    /// Reward the channel delivered at t.
    pub received: f64,
}

/// Keeps the last `keep` steps' rewards of a run.
#[derive(Debug)]
struct LastSteps {
    keep: usize,
    out: std::sync::Arc<std::sync::Mutex<std::collections::VecDeque<StepRewards>>>,
}

impl mmq_core::Observer for LastSteps {
    fn on_step(&mut self, rec: &mmq_core::StepRecord<'_>) {
        let mut q = self.out.lock().unwrap_or_else(|p| p.into_inner());
        if q.len() == self.keep {
            q.pop_front();
        }
        q.push_back(StepRewards { t: rec.t, earned: rec.emitted, received: rec.delivered });
    }
}

/// The per-step earned and received rewards of the last `keep` steps of `run` with
/// `seed` (the same run, bit for bit, as that seed's in a study's store): where the
/// delay shows.
pub fn last_steps(
    run: &Resolved,
    seed: u64,
    keep: usize,
    ctl: Control<'_>,
) -> Result<Vec<StepRewards>, LabError> {
    let out = std::sync::Arc::new(std::sync::Mutex::new(std::collections::VecDeque::with_capacity(keep)));
    let observer = LastSteps { keep, out: out.clone() };
    let run = run.with_cfg(RunConfig { baseline: false, ..run.cfg().clone() });
    run_seed(&run, seed, Some(Box::new(observer)), ctl, memory_limit(1))?;
    let q = out.lock().unwrap_or_else(|p| p.into_inner());
    Ok(q.iter().copied().collect())
}
