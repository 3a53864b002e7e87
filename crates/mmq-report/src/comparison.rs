//! The learner comparison's section of the paper's report: runs the comparison (`mmq_lab::comparison`: every learner,
//! two worlds, Poisson and non-Poisson delays, three ε), draws its figures and returns
//! its section of `report.md` — relative performance, fraction of the optimum, greedy
//! evaluation and the delay estimate against the truth, each with its 95 % interval.

mod csv;

use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

use mmq_core::World;
use mmq_core::stats::MeanCi;
use mmq_lab::LabError;
use mmq_lab::comparison::{self as study, JUDGE_AT, Outcome};
use mmq_learn::LearnerKind;
use mmq_plot::{LineChart, RefLine, Series};

use crate::format::{mean_num as num, mean_pct as pct};
use crate::paper::Studies;

use crate::{Doc, ReportError};

/// Finds the outcome of one setting.
struct Index<'a> {
    by: HashMap<(String, String, u64, LearnerKind, bool), &'a Outcome>,
}

impl<'a> Index<'a> {
    fn new(outs: &'a [Outcome]) -> Self {
        let by = outs
            .iter()
            .map(|o| {
                let s = &o.setting;
                ((s.world.clone(), s.delay.clone(), s.epsilon.to_bits(), s.learner, s.told), o)
            })
            .collect();
        Self { by }
    }

    fn get(&self, world: &str, delay: &str, eps: f64, k: LearnerKind, told: bool) -> Option<&'a Outcome> {
        self.by.get(&(world.to_string(), delay.to_string(), eps.to_bits(), k, told)).copied()
    }
}

/// Runs the study into its store and returns its report section (none for a shard).
pub(crate) fn run(ctx: &Studies<'_>) -> Result<Option<Doc>, ReportError> {
    let spec = ctx.spec("paper-comparison")?;
    let written = mmq_lab::study::Budget::default().spec(ctx.specs, "paper-comparison")?;
    let plan = study::plan(&spec, &written);
    let budget = study::seed_budget(&spec, &plan);
    let Some(groups) = ctx.run("paper-comparison", &spec, "comparison")? else { return Ok(None) };
    let mut worlds: HashMap<std::path::PathBuf, World> = HashMap::new();
    let mut outs: Vec<Outcome> = Vec::with_capacity(plan.len());
    let mut sizes: HashMap<String, String> = HashMap::new();
    for (s, c) in &plan {
        let g = &groups[*c];
        let world = match worlds.entry(g.cfg.world.clone()) {
            std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::hash_map::Entry::Vacant(e) => {
                let w = World::load(e.key()).map_err(LabError::from)?;
                e.insert(w)
            }
        };
        sizes.entry(s.world.clone()).or_insert_with(|| format!("{}×{}", world.width, world.height));
        outs.push(study::outcome(s, g, world)?);
    }
    let steps = groups.first().map_or(0, |g| g.cfg.steps);
    let shipped = mmq_lab::study::edited_spec(ctx.specs, "paper-comparison").is_none();
    report(steps, budget, ctx.out, &outs, &sizes, shipped).map(Some)
}

/// The values of `f` over `items`, each once, in the order they first appear.
fn distinct<'a, T: PartialEq>(items: impl Iterator<Item = &'a Outcome>, f: impl Fn(&Outcome) -> T) -> Vec<T> {
    let mut v = Vec::new();
    for x in items {
        let y = f(x);
        if !v.contains(&y) {
            v.push(y);
        }
    }
    v
}

/// A delay as a column of the full grids: `λ = 13` for a Poisson delay, else its label.
fn column_label(delay: &str) -> String {
    match delay.strip_prefix("poisson:") {
        Some(l) => format!("λ = {l}"),
        None => study::delay_label(delay),
    }
}

/// The section of `outs` (in plan order), run for `steps` with `seeds` (as
/// [`study::seed_budget`] gives them); `sizes` names each world's size. Every table,
/// row, column and figure comes from the settings that ran: the worlds, learners, delays
/// and ε in the order the plan first names them, the headline settings those the spec
/// runs over the most seeds, the learners with a delay estimate those it also runs told
/// the pmf. `shipped`: the study is the shipped spec, whose introduction is written out.
fn report(
    steps: u64,
    seeds: [u64; 4],
    out: &Path,
    outs: &[Outcome],
    sizes: &HashMap<String, String>,
    shipped: bool,
) -> Result<Doc, ReportError> {
    let ix = Index::new(outs);
    let untold = || outs.iter().filter(|x| !x.setting.told);
    let worlds = distinct(outs.iter(), |x| x.setting.world.clone());
    let learners = distinct(untold(), |x| x.setting.learner);
    let estimators = distinct(outs.iter().filter(|x| x.setting.told), |x| x.setting.learner);
    let first_world = worlds.first().cloned().unwrap_or_default();
    let size0 = sizes.get(&first_world).cloned().unwrap_or_else(|| first_world.clone());
    let headline = || outs.iter().filter(|x| x.setting.headline && x.setting.world == first_world);
    // The headline's ε (its first), where the figures are drawn.
    let fig_eps = headline().next().or_else(|| outs.first()).map_or(0.05, |x| x.setting.epsilon);
    let mut sec = Doc::new(out);
    let md = &mut sec.md;
    if shipped {
        let _ = writeln!(
            md,
            "\n## The learner comparison: learners that reach the undelayed limit\n\n\
             Every learner on the paper's 9×9 world and on the 15×15 maze, {} steps per setting; seeds per setting: \
             9×9 {} for the headline settings (Poisson λ = 13 and the non-Poisson delays at ε = 0.05 and 0.1) and {} for \
             the rest of the λ × ε grid and the told-pmf ablation; maze {} and {}; \
             α = 0.1, γ = 0.9, q0 = 10, largest delay told to the learners λ̂max = 50. Relative performance \
             is against undelayed Q-learning with the same ε and q0 (100 % = as good as with no delay at all); it can pass \
             100 %, because undelayed Q-learning is itself still learning. The fraction of the ε-soft ceiling has no \
             learner in its denominator: earned reward per step ÷ the best any policy exploring with this ε earns \
             (100 % = the limit of exploration), and the regret is optimum × steps − earned reward. \
             \"Greedy optimal\" counts the seeds whose greedy policy scores as much as the optimal policy over \
             the 1000 evaluation steps from S (9×9: 0.580/step; maze: 0.300/step). `oracle` reads the channel's \
             ground truth: an upper bound, not a real agent. `deconv-q` and `deconv-model` are told only λ̂max and \
             estimate the delay distribution online (docs/algorithms/deconv-q.md, deconv-model.md); \"told pmf\" \
             rows give them the true distribution instead (ablation).\n",
            steps, seeds[0], seeds[1], seeds[2], seeds[3]
        );
    } else {
        let names = |v: Vec<String>| v.join(", ");
        let (first, others) = (seeds[0..2].to_vec(), seeds[2..4].to_vec());
        let _ = writeln!(
            md,
            "\n## The learner comparison: learners that reach the undelayed limit\n\n\
             The study of the spec given: {} on {}, under {}, at ε = {}; {steps} steps per setting; seeds per \
             setting on {}: {} for the headline settings (those it runs over the most seeds){}{}. \
             Relative performance is against undelayed Q-learning with the same ε and q0 (100 % = as good as with \
             no delay at all). The fraction of the ε-soft ceiling is earned reward per step ÷ the best any policy \
             exploring with this ε earns, and the regret is optimum × steps − earned reward. \"Greedy optimal\" \
             counts the seeds whose greedy policy scores as much as the optimal policy over the evaluation steps \
             from S; \"told pmf\" rows give a deconvolving learner the true delay distribution (ablation).\n",
            names(learners.iter().map(|k| format!("`{}`", k.name())).collect()),
            names(worlds.clone()),
            names(distinct(outs.iter(), |x| x.setting.delay_label.clone())),
            names(distinct(outs.iter(), |x| x.setting.epsilon.to_string())),
            first_world,
            first[0],
            if first[1] > 0 { format!(" and {} for the rest", first[1]) } else { String::new() },
            if worlds.len() > 1 {
                format!("; on the other worlds {} and {}", others[0], others[1])
            } else {
                String::new()
            },
        );
    }
    // Headline: the first world's headline settings, a table per delay (with the told-pmf
    // ablation's rows at the same delay and ε).
    let headline_delays: Vec<(String, String)> =
        distinct(headline(), |x| (x.setting.delay_label.clone(), x.setting.delay.clone()));
    for (label, delay) in &headline_delays {
        let _ = writeln!(
            md,
            "\n### {size0}, {label}\n\n| learner | ε | relative performance | fraction of the ε-soft ceiling | regret (reward) | fraction of optimum | greedy (reward/step) | worst seed | greedy optimal |\n|---|---|---|---|---|---|---|---|---|"
        );
        for eps in distinct(headline().filter(|x| x.setting.delay == *delay), |x| x.setting.epsilon) {
            let rows = learners.iter().map(|&k| (k, false)).chain(estimators.iter().map(|&k| (k, true)));
            for (k, told) in rows {
                let Some(x) = ix.get(&first_world, delay, eps, k, told) else { continue };
                let _ = writeln!(
                    md,
                    "| {} | {eps} | {} | {} | {} | {} | {} | {:.3} | {}/{} |",
                    x.setting.learner_label(),
                    pct(&x.relative),
                    x.ceiling.map_or("—".into(), |c| pct(&c)),
                    crate::format::mean_num(&x.regret, 0),
                    pct(&x.fraction),
                    num(&x.greedy, 3),
                    x.greedy_min,
                    x.greedy_optimal,
                    x.n
                );
            }
        }
    }
    // Full grids: relative performance per world and ε, learners × delays.
    for world in &worlds {
        let _ = writeln!(md, "\n### {world}: relative performance for every delay\n");
        let here = || untold().filter(|x| x.setting.world == *world);
        for eps in distinct(here(), |x| x.setting.epsilon) {
            let delays: Vec<(String, String)> = distinct(here().filter(|x| x.setting.epsilon == eps), |x| {
                (column_label(&x.setting.delay), x.setting.delay.clone())
            });
            let _ = write!(md, "\nε = {eps}\n\n| learner |");
            for (l, _) in &delays {
                let _ = write!(md, " {l} |");
            }
            let _ = write!(md, "\n|---|");
            for _ in &delays {
                md.push_str("---|");
            }
            md.push('\n');
            for &k in &learners {
                let _ = write!(md, "| {} |", k.name());
                for (_, d) in &delays {
                    let cell = ix.get(world, d, eps, k, false).map_or("—".to_string(), |x| {
                        format!("{} ({}/{} opt.)", pct(&x.relative), x.greedy_optimal, x.n)
                    });
                    let _ = write!(md, " {cell} |");
                }
                md.push('\n');
            }
        }
    }
    // Delay estimates.
    let _ = writeln!(
        md,
        "\n### Delay estimate against the truth\n\nMedian of the estimated pmf (interpolated; mean ± 95 % interval over seeds) at the end, \
         the worst seed's distance from the true median after {JUDGE_AT} steps, and for the mixture the estimated mass of each lobe \
         (delays below and from {} steps; truth ≈ 0.5 / 0.5), and the delay probes `deconv-model` took per seed \
         (docs/algorithms/deconv-model.md).\n\n| world | delay | ε | learner | true median | estimated median (end) | worst seed's error at {JUDGE_AT} (steps) | lobes (low / high) | probes per seed |\n|---|---|---|---|---|---|---|---|---|",
        study::LOBE_SPLIT
    );
    for x in outs.iter().filter(|x| !x.median_curve.is_empty()) {
        let s = &x.setting;
        let (_, tmed, _) = study::truth(&s.delay)?;
        let end = x.median_curve.last().map(|c| c.1);
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {tmed:.2} | {} | {} | {} | {} |",
            s.world,
            s.delay_label,
            s.epsilon,
            s.learner.name(),
            end.map_or("—".into(), |m| num(&m, 2)),
            x.median_error_max.map_or("—".into(), |e| format!("{e:.2}")),
            x.lobes.map_or("—".into(), |l| format!("{:.2} / {:.2}", l.0.mean, l.1.mean)),
            x.probes.map_or("—".into(), |p| format!("{:.0}", p.mean))
        );
    }
    let _ = writeln!(md, "\n### Figures\n");
    // Relative performance vs λ, per world at the headline's ε.
    for world in &worlds {
        let eps = fig_eps;
        let poisson: Vec<(f64, String)> =
            distinct(untold().filter(|x| x.setting.world == *world && x.setting.epsilon == eps), |x| {
                x.setting.delay.clone()
            })
            .into_iter()
            .filter_map(|d| Some((d.strip_prefix("poisson:")?.parse::<f64>().ok()?, d)))
            .collect();
        let mut chart = LineChart::new(
            format!("{world}, ε = {eps}: relative performance vs Poisson mean λ"),
            "mean delay λ (steps)",
            "relative performance (%)",
        );
        for &k in &learners {
            let pts: Vec<(f64, MeanCi)> = poisson
                .iter()
                .filter_map(|(l, d)| ix.get(world, d, eps, k, false).map(|x| (*l, x.relative)))
                .collect();
            let x: Vec<f64> = pts.iter().map(|p| p.0).collect();
            let y: Vec<f64> = pts.iter().map(|p| 100.0 * p.1.mean).collect();
            let lo: Vec<f64> = pts.iter().map(|p| 100.0 * (p.1.mean - p.1.ci95)).collect();
            let hi: Vec<f64> = pts.iter().map(|p| 100.0 * (p.1.mean + p.1.ci95)).collect();
            chart.series.push(Series::new(k.name(), x, y).with_band(lo, hi).with_markers());
        }
        chart.ref_lines.push(RefLine::new("undelayed Q-learning (100 %)", 100.0));
        chart.y_range = Some((-40.0, 130.0));
        let name = format!("comparison-relative-{world}");
        sec.figure(
            chart.write(&out.join(&name))?,
            &format!("{world}, ε = {eps}: relative performance of every learner vs the Poisson mean delay"),
        );
    }
    // Delay estimate over time (the first world, the headline's ε).
    for &k in &estimators {
        let mut chart = LineChart::new(
            format!("{size0}, ε = {fig_eps}: {}'s delay estimate over time", k.name()),
            "step",
            "median of the estimated delay pmf (steps)",
        );
        for (label, delay) in &headline_delays {
            let Some(x) = ix.get(&first_world, delay, fig_eps, k, false) else { continue };
            let (_, tmed, _) = study::truth(delay)?;
            let t: Vec<f64> = x.median_curve.iter().map(|c| c.0 as f64).collect();
            let y: Vec<f64> = x.median_curve.iter().map(|c| c.1.mean - tmed).collect();
            let lo: Vec<f64> = x.median_curve.iter().map(|c| c.1.mean - c.1.ci95 - tmed).collect();
            let hi: Vec<f64> = x.median_curve.iter().map(|c| c.1.mean + c.1.ci95 - tmed).collect();
            chart.series.push(Series::new(label.clone(), t, y).with_band(lo, hi).with_markers());
        }
        chart.ref_lines.push(RefLine::new("truth (error 0)", 0.0));
        chart.ref_lines.push(RefLine::new("±1.5 steps", 1.5));
        chart.ref_lines.push(RefLine::new("", -1.5));
        chart.y_label = "estimated − true median (steps)".into();
        let name = format!("comparison-delay-{}", k.name());
        sec.figure(
            chart.write(&out.join(&name))?,
            &format!(
                "{size0}, ε = {fig_eps}: error of {}'s median delay estimate over time (mean over seeds, 95 % band)",
                k.name()
            ),
        );
    }
    // Estimated pmf vs truth (the first world, the headline's ε).
    for (label, delay) in &headline_delays {
        let (tp, _, _) = study::truth(delay)?;
        let mut chart = LineChart::new(
            format!("{size0}, ε = {fig_eps}, {label}: delay pmf"),
            "delay k (steps)",
            "P(d = k)",
        );
        let ks: Vec<f64> = (0..tp.len()).map(|k| k as f64).collect();
        chart.series.push(Series::new("truth", ks.clone(), tp.clone()));
        for &k in &estimators {
            if let Some(x) = ix.get(&first_world, delay, fig_eps, k, false).filter(|x| !x.pmf.is_empty()) {
                chart.series.push(Series::new(
                    format!("{} (mean over seeds)", k.name()),
                    ks.clone(),
                    x.pmf.clone(),
                ));
            }
        }
        let slug: String =
            delay.chars().map(|c| if c.is_ascii_alphanumeric() { c } else { '-' }).take(24).collect();
        sec.figure(
            chart.write(&out.join(format!("comparison-pmf-{slug}")))?,
            &format!("{size0}, ε = {fig_eps}, {label}: estimated delay pmf at the end vs the truth"),
        );
    }
    sec.csv("comparison.csv", &csv::outcomes_csv(outs))?;
    sec.csv("comparison-delay.csv", &csv::delay_csv(outs)?)?;
    sec.csv("comparison-pmf.csv", &csv::pmf_csv(outs)?)?;
    Ok(sec)
}
