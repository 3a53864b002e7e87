//! The one rule for a study's budget: what `--quick`, `--steps`, `--seeds` and `--seed`
//! do to a spec. The rule rewrites the spec's own fields, so a budgeted spec is a spec
//! like any other: its cells (and their ids) say the steps and windows that ran, its
//! store resumes and shards, and an edited spec's own seeds and steps are honoured
//! wherever no flag overrides them.
//!
//! - `--steps S`: every `steps` × S ÷ 150,000 and every `window` × ⌊S ÷ 60⌋ ÷ 2,500
//!   (a study that runs four times the paper's horizon still runs four times as long).
//! - `--quick` without `--steps`: steps ÷ 5 and windows × 2 ÷ 5 (30 curve points where
//!   the paper has 60); a spec on the robot or a swarm ÷ 50 and × 2 ÷ 50 (rapier takes
//!   longer per step).
//! - `--seeds N`: N seeds for every cell. `--quick` without `--seeds`: ⌈3n ÷ 10⌉ of a
//!   cell's n (20 → 6, 5 → 2, 2 → 1); a list of seeds is cut to as many.
//! - `--seed S`: the first master seed of every cell.
//!
//! A field the rule changed makes the spec's `curve` meaningless, so it is dropped (the
//! study's records keep every curve row).

use std::path::Path;

use toml::{Table, Value};

use crate::error::LabError;
use crate::sweep::SweepSpec;

/// The paper's budget, which the shipped specs state: steps per seed.
pub const PAPER_STEPS: u64 = 150_000;
/// Steps per curve point at [`PAPER_STEPS`].
pub const PAPER_WINDOW: u64 = 2500;

/// What the command line asks of a study's budget (see the module's rule).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Budget {
    /// The smoke-test budget.
    pub quick: bool,
    /// Decision steps per seed at the paper's horizon (150,000).
    pub steps: Option<u64>,
    /// Seeds of every cell.
    pub seeds: Option<u64>,
    /// First master seed of every cell.
    pub seed: Option<u64>,
}

impl Budget {
    /// Whether the rule changes nothing: the spec runs as written.
    pub fn is_spec(&self) -> bool {
        *self == Budget::default()
    }

    /// The study spec `name` (an edited copy in `folder`, else the built-in one) at this
    /// budget, its jobs keeping their seeds' records. The spec as written is checked
    /// first, so that its errors name its own lines.
    pub fn spec(&self, folder: Option<&Path>, name: &str) -> Result<SweepSpec, LabError> {
        self.check()?;
        let (text, file) = super::spec_text(folder, name)?;
        let written = SweepSpec::parse(&text, &file)?;
        if self.is_spec() {
            return Ok(written.with_records());
        }
        let mut doc: Table = toml::from_str(&text)
            .map_err(|e| LabError::Config { file: file.display().to_string(), message: e.to_string() })?;
        self.apply(&mut doc);
        let budgeted = toml::to_string(&doc).map_err(|e| LabError::Config {
            file: file.display().to_string(),
            message: format!("cannot write the spec at this budget: {e}"),
        })?;
        SweepSpec::parse(&budgeted, &file)
            .map_err(|e| {
                // The error's line is the rewritten text's: name the field alone.
                let (text, name) = (e.to_string(), file.display().to_string());
                let field_first = text
                    .strip_prefix(&format!("{name}:"))
                    .and_then(|rest| rest.split_once(": "))
                    .map_or(text.as_str(), |(_, m)| m);
                LabError::Config {
                    file: name.clone(),
                    message: format!("at the budget asked for ({}): {field_first}", self.describe()),
                }
            })
            .map(SweepSpec::with_records)
    }

    /// Refuses flags no spec could run: no seeds, no steps, more than a run takes.
    pub fn check(&self) -> Result<(), LabError> {
        if let Some(n) = self.seeds.filter(|n| !(1..=1_000_000).contains(n)) {
            return Err(LabError::param("seeds", n, "use a number of seeds in 1..=1000000"));
        }
        if let Some(n) = self.steps.filter(|n| !(1..=crate::config::MAX_STEPS).contains(n)) {
            return Err(LabError::param(
                "steps",
                n,
                "use a number of decision steps in 1..=10^10, e.g. 150000",
            ));
        }
        Ok(())
    }

    /// The flags this budget stands for, as a message names them.
    pub fn describe(&self) -> String {
        let mut v = Vec::new();
        if self.quick {
            v.push("--quick".to_string());
        }
        if let Some(s) = self.steps {
            v.push(format!("--steps {s}"));
        }
        if let Some(s) = self.seeds {
            v.push(format!("--seeds {s}"));
        }
        if let Some(s) = self.seed {
            v.push(format!("--seed {s}"));
        }
        if v.is_empty() { "the spec's own".into() } else { v.join(" ") }
    }

    /// The paper's horizon (150,000 steps on the grid) at this budget.
    pub fn paper_steps(&self) -> u64 {
        self.steps_of(PAPER_STEPS, false)
    }

    /// Steps at this budget.
    fn steps_of(&self, steps: u64, slow: bool) -> u64 {
        match (self.steps, self.quick) {
            (Some(s), _) => scale(steps, s, PAPER_STEPS),
            (None, true) => steps / if slow { 50 } else { 5 },
            (None, false) => steps,
        }
    }

    /// A curve window at this budget.
    fn window_of(&self, window: u64, slow: bool) -> u64 {
        let w = match (self.steps, self.quick) {
            (Some(s), _) => scale(window, (s / 60).max(1), PAPER_WINDOW),
            (None, true) => scale(window, 2, if slow { 50 } else { 5 }),
            (None, false) => window,
        };
        w.max(1)
    }

    /// Seeds at this budget of a cell that runs `n`.
    fn seeds_of(&self, n: u64) -> u64 {
        match (self.seeds, self.quick) {
            (Some(s), _) => s,
            (None, true) => (3 * n).div_ceil(10),
            (None, false) => n,
        }
    }

    /// Rewrites the spec's budget fields, at its top and in every part.
    fn apply(&self, doc: &mut Table) {
        let slow = on_robot(doc);
        let scaled = self.steps.is_some() || self.quick;
        if scaled {
            doc.remove("curve");
        }
        self.apply_table(doc, slow);
        if let Some(Value::Array(parts)) = doc.get_mut("part") {
            for p in parts.iter_mut() {
                if let Value::Table(t) = p {
                    self.apply_table(t, slow);
                }
            }
        }
        if let Some(s) = self.seed {
            doc.insert("seed".into(), int(s));
        }
    }

    fn apply_table(&self, t: &mut Table, slow: bool) {
        map_ints(t, "steps", |x| self.steps_of(x, slow));
        map_ints(t, "window", |x| self.window_of(x, slow));
        match t.get("seeds") {
            Some(Value::Integer(n)) => {
                let n = self.seeds_of(u64::try_from(*n).unwrap_or(0));
                t.insert("seeds".into(), int(n));
            }
            Some(Value::Array(list)) => {
                let n = self.seeds_of(list.len() as u64);
                let v = if self.seeds.is_some() {
                    int(n)
                } else {
                    Value::Array(list.iter().take(n as usize).cloned().collect())
                };
                t.insert("seeds".into(), v);
            }
            None if self.seeds.is_some() => {
                t.insert("seeds".into(), int(self.seeds_of(0)));
            }
            _ => {}
        }
        if let Some(s) = self.seed
            && t.contains_key("seed")
        {
            t.insert("seed".into(), int(s));
        }
    }
}

/// x × by ÷ of, in whole numbers (no overflow below 2^64 for each).
fn scale(x: u64, by: u64, of: u64) -> u64 {
    (u128::from(x) * u128::from(by) / u128::from(of)) as u64
}

fn int(x: u64) -> Value {
    Value::Integer(i64::try_from(x).unwrap_or(i64::MAX))
}

/// Applies `f` to the whole number `key` of `t`, or to each of a list of them.
fn map_ints(t: &mut Table, key: &str, f: impl Fn(u64) -> u64) {
    let g = |v: &Value| match v {
        Value::Integer(x) if *x >= 0 => int(f(*x as u64)),
        other => other.clone(),
    };
    if let Some(v) = t.get(key) {
        let new = match v {
            Value::Array(xs) => Value::Array(xs.iter().map(g).collect()),
            x => g(x),
        };
        t.insert(key.into(), new);
    }
}

/// Whether any cell of the spec runs the robot or a swarm.
fn on_robot(doc: &Table) -> bool {
    let slow = |v: Option<&Value>| match v {
        Some(Value::String(s)) => s != "grid",
        Some(Value::Array(xs)) => xs.iter().any(|x| x.as_str().is_some_and(|s| s != "grid")),
        _ => false,
    };
    slow(doc.get("env"))
        || doc
            .get("part")
            .and_then(Value::as_array)
            .is_some_and(|ps| ps.iter().any(|p| p.as_table().is_some_and(|t| slow(t.get("env")))))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fig(name: &str, b: Budget) -> SweepSpec {
        b.spec(None, name).unwrap()
    }

    /// The rule by hand, on the shipped specs: the quick budget is 30,000 steps in
    /// windows of 1,000 with 6 of 20 seeds on the grid, 3,000 in windows of 100 with 2
    /// of 5 on the robot; `--steps` keeps the horizon study four times as long.
    #[test]
    fn the_budget_rule_by_hand() {
        let quick = Budget { quick: true, ..Budget::default() };
        let s = fig("paper-fig2", quick);
        let c = s.config(0);
        assert_eq!((c.steps, c.window, s.plan.seeds.len()), (30_000, 1000, 6));
        let s = fig("paper-fig6-robot", quick);
        let c = s.config(0);
        assert_eq!((c.steps, c.window, s.plan.seeds.len()), (3000, 100, 2));
        let s =
            fig("paper-horizon", Budget { steps: Some(6000), seeds: Some(2), seed: Some(9), quick: true });
        let c = s.config(0);
        assert_eq!((c.steps, c.window, s.plan.seeds.as_slice()), (24_000, 400, &[9u64, 10][..]));
        // The comparison's parts keep their own seeds: 20 → 6, 5 → 2, 2 → 1.
        let s = fig("paper-comparison", quick);
        let mut counts: Vec<usize> = (0..s.plan.cells.len()).map(|c| s.plan.seeds_of(c).len()).collect();
        counts.sort_unstable();
        counts.dedup();
        assert_eq!(counts, [1, 2, 6]);
        // The spec's own budget: every cell as written, with its curve points.
        let s = fig("paper-fig2", Budget::default());
        assert_eq!((s.config(0).steps, s.config(0).window, s.plan.seeds.len()), (150_000, 2500, 20));
        assert!(s.keeps_records());
    }

    /// A budget gives cells of their own (their ids say the steps that ran), so two
    /// budgets share a store without mixing.
    #[test]
    fn budgets_give_their_own_cells() {
        let a = fig("paper-fig6", Budget { steps: Some(3000), ..Budget::default() });
        let b = fig("paper-fig6", Budget { steps: Some(6000), ..Budget::default() });
        assert_ne!(a.plan.cells[0].id, b.plan.cells[0].id);
        let c = fig("paper-fig6", Budget { steps: Some(3000), seeds: Some(4), ..Budget::default() });
        assert_eq!(a.plan.cells[0].id, c.plan.cells[0].id, "seeds are jobs of a cell, not another cell");
    }

    /// An explicit list of seeds is cut by `--quick` and replaced by `--seeds`.
    #[test]
    fn seed_lists_follow_the_rule() {
        let mut doc: Table = toml::from_str("seeds = [5, 6, 7, 8]\n[[part]]\nseeds = 10\n").unwrap();
        Budget { quick: true, ..Budget::default() }.apply(&mut doc);
        assert_eq!(doc["seeds"].as_array().unwrap().len(), 2);
        assert_eq!(doc["part"].as_array().unwrap()[0]["seeds"].as_integer(), Some(3));
        let mut doc: Table =
            toml::from_str("seeds = [5, 6, 7, 8]\nenv = \"robot\"\nsteps = [1000, 5000]\n").unwrap();
        Budget { seeds: Some(3), quick: true, ..Budget::default() }.apply(&mut doc);
        assert_eq!(doc["seeds"].as_integer(), Some(3));
        let steps: Vec<i64> = doc["steps"].as_array().unwrap().iter().filter_map(Value::as_integer).collect();
        assert_eq!(steps, [20, 100]);
    }

    /// Flags no spec could run are refused by their field before a spec is read; an
    /// error the budget causes in a spec names the spec and the field, not a line of the
    /// rewritten text.
    #[test]
    fn bad_budgets_are_refused_by_their_field() {
        for (b, field) in [
            (Budget { seeds: Some(0), ..Budget::default() }, "`seeds` = 0"),
            (Budget { steps: Some(0), ..Budget::default() }, "`steps` = 0"),
            (Budget { steps: Some(u64::MAX), ..Budget::default() }, "`steps` = 18446744073709551615"),
        ] {
            let e = b.spec(None, "paper-fig6").unwrap_err();
            assert!(e.is_input_error() && e.to_string().starts_with(field), "{e}");
        }
        let d = tempfile::tempdir().unwrap();
        let f6 = super::super::SPECS.iter().find(|s| s.0 == "paper-fig6").unwrap().1;
        // A window the budget shrinks below what `curve` needs is fine (curve is dropped),
        // but a spec whose steps the rule scales to nothing is refused, naming `steps`.
        let tiny = f6
            .replace("steps = 150000", "steps = 4")
            .replace("window = 2500", "window = 1")
            .replace("curve = 60\n", "");
        std::fs::write(d.path().join("paper-fig6.toml"), tiny).unwrap();
        let e = Budget { quick: true, ..Budget::default() }.spec(Some(d.path()), "paper-fig6").unwrap_err();
        let e = e.to_string();
        assert!(e.contains("paper-fig6.toml") && e.contains("(--quick): steps: 0 is not accepted"), "{e}");
    }
}
