//! One robot's memory in a shared `deconv-model` (parameter sharing, [`crate::memory`]):
//! which trajectory its deconvolver feeds ([`crate::decode::ValueDeconvolver::set_stream`])
//! and, under (M2), its last K pairs, whose information is still in flight. Counts, R̂,
//! p̂ and the planned values are the shared tables.

use std::collections::VecDeque;

use super::DeconvModel;
use crate::memory::Memory;

/// A trajectory's memory while another one feeds the learner.
#[derive(Debug, Default)]
pub(crate) struct Trajectory {
    /// Its stream in the deconvolver (None: a trajectory that has not started).
    stream: Option<usize>,
    /// (M2)'s recent pairs.
    recent: VecDeque<u32>,
}

impl DeconvModel {
    /// Takes the current trajectory's memory out of the learner (moves, no copy).
    pub(crate) fn take_trajectory(&mut self) -> Trajectory {
        let recent = self.confidence.as_mut().map(|c| std::mem::take(&mut c.recent)).unwrap_or_default();
        Trajectory { stream: Some(self.deconv.stream()), recent }
    }

    /// Makes `t` the current trajectory (a new stream for one that has not started).
    pub(crate) fn put_trajectory(&mut self, t: Trajectory) {
        self.deconv.enter(t.stream);
        if let Some(c) = self.confidence.as_mut() {
            c.recent = t.recent;
        }
    }

    /// [`crate::Learner::swap_memory`].
    pub(super) fn swap_trajectory(&mut self, other: &mut Memory) {
        let mut mine = self.take_trajectory();
        other.swap_with(&mut mine, Trajectory::default);
        self.put_trajectory(mine);
    }
}
