//! Whether a figure spec can make its figure, checked before anything runs. Each figure
//! varies one setting (its axis) and holds the others; a spec that varies another one,
//! repeats a value of the axis or lacks the axis is refused with the file, the field and
//! the fix, instead of a figure that mixes settings on one line.

use mmq_core::DelayDist;
use mmq_lab::RunConfig;
use mmq_learn::LearnerSettings;

use crate::ReportError;

/// A figure spec as its checks name it: the file it came from and the figure it makes.
pub(super) struct FigureSpec {
    /// The spec's file (an edited copy, or the built-in one).
    pub file: String,
    /// The figure, as the report names it (`Fig. 2`).
    pub figure: &'static str,
    /// How to give a setting one value (`give \`epsilon\` one value`, or where the figure
    /// joins two specs, the same value in both).
    pub one_value: &'static str,
}

impl FigureSpec {
    /// An error about `field` of this spec.
    pub fn error(&self, field: &str, message: String) -> ReportError {
        ReportError::FigureSpec { file: self.file.clone(), field: field.into(), message }
    }

    /// Refuses `cfgs` unless they differ only in the settings named by `axis` (as a
    /// spec names them), and unless there is at least one.
    pub fn varies_only(&self, cfgs: &[RunConfig], axis: &[&str]) -> Result<(), ReportError> {
        let Some(first) = cfgs.first() else {
            let field = axis.first().copied().unwrap_or("learner");
            return Err(
                self.error(field, format!("{} needs at least one setting; the spec has none", self.figure))
            );
        };
        for c in cfgs {
            if let Some(f) = differing(first, c).into_iter().find(|f| !axis.contains(f)) {
                let what = if axis.is_empty() {
                    "runs one setting".to_string()
                } else {
                    format!(
                        "varies only {}",
                        axis.iter().map(|a| format!("`{a}`")).collect::<Vec<_>>().join(", ")
                    )
                };
                return Err(self.error(
                    f,
                    format!(
                        "{} {what}, but this spec also varies `{f}`; give `{f}` {}",
                        self.figure, self.one_value
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Refuses a repeated value of the axis `field`: the figure draws one point per value.
    pub fn distinct(&self, field: &str, values: &[String]) -> Result<(), ReportError> {
        for (i, v) in values.iter().enumerate() {
            if values[..i].contains(v) {
                return Err(self.error(
                    field,
                    format!(
                        "two settings have {v}; {} draws one point per value of its axis, so list each once",
                        self.figure
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The fix for a setting that varies in a figure spec of its own.
pub(super) const ONE_VALUE: &str = "one value (a copy of the spec per value studies several)";

/// The settings in which two configurations differ, named as a spec names them.
pub(crate) fn differing(a: &RunConfig, b: &RunConfig) -> Vec<&'static str> {
    let mut v = Vec::new();
    let (pa, pb) = (a.learner.params, b.learner.params);
    if a.world != b.world {
        v.push("world");
    }
    if a.env != b.env {
        v.push("env");
    }
    let same_delay = match (DelayDist::parse(&a.delay), DelayDist::parse(&b.delay)) {
        (Ok(x), Ok(y)) => x == y,
        _ => a.delay == b.delay,
    };
    if !same_delay {
        v.push("delay");
    }
    if a.learner.kind() != b.learner.kind() {
        v.push("learner");
    } else if a.learner.settings != b.learner.settings {
        v.push(match &a.learner.settings {
            LearnerSettings::Fixed(_) => "lambda_hat",
            s if s.max_delay() != b.learner.settings.max_delay() => "max_delay",
            _ => "settings",
        });
    }
    for (name, x, y) in [
        ("alpha", pa.alpha, pb.alpha),
        ("gamma", pa.gamma, pb.gamma),
        ("epsilon", pa.epsilon, pb.epsilon),
        ("q0", pa.q0, pb.q0),
    ] {
        if x != y {
            v.push(name);
        }
    }
    for (name, x, y) in [
        ("steps", a.steps, b.steps),
        ("window", a.window, b.window),
        ("eval_steps", a.eval_steps, b.eval_steps),
        ("seeds", a.seeds, b.seeds),
    ] {
        if x != y {
            v.push(name);
        }
    }
    if a.robot != b.robot {
        v.push("robot");
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_are_named_as_a_spec_names_them() {
        let a = RunConfig { delay: "poisson:5".into(), ..RunConfig::default() };
        let b = RunConfig { delay: "poisson:5.0".into(), ..a.clone() };
        assert!(differing(&a, &b).is_empty());
        let mut c = RunConfig { delay: "poisson:6".into(), ..a.clone() };
        c.learner.params.epsilon = 0.5;
        assert_eq!(differing(&a, &c), ["delay", "epsilon"]);
        let spec = FigureSpec { file: "x.toml".into(), figure: "Fig. 2", one_value: ONE_VALUE };
        let e = spec.varies_only(&[a.clone(), c], &["delay"]).unwrap_err().to_string();
        assert!(e.starts_with("x.toml: `epsilon`: Fig. 2 varies only `delay`"), "{e}");
        assert!(spec.varies_only(&[], &["delay"]).is_err());
        let e = spec.distinct("delay", &["λ = 5".into(), "λ = 5".into()]).unwrap_err().to_string();
        assert!(e.contains("`delay`: two settings have λ = 5"), "{e}");
    }
}
