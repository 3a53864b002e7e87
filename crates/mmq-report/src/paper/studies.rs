//! The studies behind the paper's report: each figure's spec at the request's budget
//! (`mmq_lab::study::Budget`), run by the sweep engine into its store in the report's
//! folder (`OUT/runs/NAME`), then read back as one group per cell. A run that stopped
//! resumes where it stopped; a shard runs its part of every study and draws nothing.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use mmq_lab::Control;
use mmq_lab::study::{self, Budget, Group};
use mmq_lab::sweep::{Shard, SweepEvent, SweepSpec};

use crate::{Progress, ReportError};

/// Where and how the report's studies run.
pub(crate) struct Studies<'a> {
    /// The budget every spec is run at.
    pub budget: Budget,
    /// A folder of edited specs that replace the built-in ones by name.
    pub specs: Option<&'a Path>,
    /// The report's folder (the stores are in its `runs/`).
    pub out: &'a Path,
    /// The part of every study's jobs this process runs (then nothing is drawn).
    pub shard: Option<Shard>,
    /// Report folders (shards' outputs) whose finished jobs are taken first.
    pub merge: &'a [PathBuf],
    /// Ctrl-C.
    pub stop: &'a AtomicBool,
    /// Progress.
    pub prog: &'a dyn Progress,
}

impl Studies<'_> {
    /// The study spec `name` at the budget.
    pub fn spec(&self, name: &str) -> Result<SweepSpec, ReportError> {
        Ok(self.budget.spec(self.specs, name)?)
    }

    /// The spec `name` as messages name it: the edited file, or the built-in copy.
    pub fn source(&self, name: &str) -> String {
        study::spec_source(self.specs, name)
    }

    /// Runs the jobs of `spec` (the study `name`) its store does not hold yet, under the
    /// progress label `label`, and reads its groups back; `None` for a shard, which
    /// draws nothing.
    pub fn run(&self, name: &str, spec: &SweepSpec, label: &str) -> Result<Option<Vec<Group>>, ReportError> {
        let store = study::store_of(self.out, name);
        for from in self.merge.iter().map(|m| study::store_of(m, name)).filter(|d| d.is_dir()) {
            mmq_lab::sweep::merge_jobs(spec, &from, &store)?;
        }
        let advance = |n: u64| self.prog.advance(n);
        let ctl = Control { stop: self.stop, progress: &advance };
        // A study whose store holds every job (a redraw, or Fig. 6 for the sensitivity
        // table) shows no progress.
        let began = AtomicBool::new(false);
        let events = |e: &SweepEvent<'_>| {
            if let SweepEvent::Planned { steps, .. } = e
                && *steps > 0
            {
                began.store(true, Ordering::Relaxed);
                self.prog.begin(*steps, label);
            }
        };
        let ran = mmq_lab::sweep::run_sweep(spec, &store, self.shard, ctl, &events);
        if began.load(Ordering::Relaxed) {
            self.prog.end();
        }
        ran?;
        Ok(self.shard.is_none().then(|| study::groups(spec, &store)))
    }
}
