//! A whole run for a front end: the world loaded, the live view started when asked
//! ([`crate::live`]), the seeds run with their progress, the outputs written
//! (`mmq_lab::record::run_recorded`), then the summary table and the closing line said.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use mmq_lab::{Control, Resolved};

use crate::live::LiveOptions;
use crate::{Progress, ReportError};

/// Runs `run` into `out`, its first seed served live with `live` when given; says the summary table and `wrote OUT` through `progress`, or a notice when the
/// stop flag cut the run short. Returns whether it did (the summary then marks the run
/// partial).
///
/// A seed that lost output it should have written (a recording) is an error after the
/// summary was said.
pub fn run(
    run: &Resolved,
    out: &Path,
    live: Option<&LiveOptions>,
    stop: &AtomicBool,
    progress: &dyn Progress,
) -> Result<bool, ReportError> {
    let cfg = run.cfg();
    let live = live.map(|o| crate::live::start(o, cfg, out, stop, progress)).transpose()?;
    progress.begin(cfg.total_steps(), cfg.learner.kind().name());
    let advance = |n: u64| progress.advance(n);
    let ctl = Control { stop, progress: &advance };
    let claimed = |replaced: usize| {
        // Said also when quiet: files are removed.
        if replaced > 0 {
            progress.notice(&format!("{}: replacing the previous run's {replaced} file(s)", out.display()));
        }
    };
    let written = mmq_lab::record::run_recorded(out, run, live, ctl, &claimed);
    progress.end();
    let written = written?;
    progress.say(&crate::text::run_summary(&written.summary));
    // The summary says incomplete; the error says why.
    written.check(out)?;
    if written.interrupted {
        progress.notice(&crate::terminal::run_interrupted(&written, out));
    } else {
        progress.say(&format!("wrote {}\n", out.display()));
    }
    Ok(written.interrupted)
}

#[cfg(test)]
mod tests {
    use std::sync::Mutex;

    use super::*;

    /// What a front end was told.
    #[derive(Default)]
    struct Told(Mutex<Vec<String>>);

    impl Progress for Told {
        fn notice(&self, text: &str) {
            self.0.lock().unwrap().push(format!("notice: {text}"));
        }
        fn say(&self, text: &str) {
            self.0.lock().unwrap().push(text.to_string());
        }
    }

    #[test]
    fn a_run_says_its_summary_and_where_it_wrote_then_replaces_its_files_on_a_rerun() {
        let tmp = std::env::temp_dir().join(format!("mmq-report-run-{}", std::process::id()));
        let world = "paper-9x9".into();
        let cfg = mmq_lab::RunConfig {
            world,
            steps: 200,
            window: 100,
            eval_steps: 10,
            baseline: false,
            ..mmq_lab::RunConfig::default()
        };
        let cfg = Resolved::new(cfg).unwrap();
        let stop = AtomicBool::new(false);
        let told = Told::default();
        assert!(!run(&cfg, &tmp, None, &stop, &told).unwrap());
        assert!(!run(&cfg, &tmp, None, &stop, &told).unwrap());
        let told = told.0.into_inner().unwrap();
        let _ = std::fs::remove_dir_all(&tmp);
        assert_eq!(told.len(), 5, "{told:?}");
        assert_eq!(told[1], format!("wrote {}\n", tmp.display()));
        assert!(told[2].starts_with("notice: ") && told[2].contains("replacing the previous run's"));
        assert_eq!(told[0], told[3]);
    }
}
