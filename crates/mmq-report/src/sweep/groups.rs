//! The settings of a sweep with a `learner` axis: its cells grouped by everything but
//! the learner (world, env, delay, robot, steps, ...), each cell labelled by its learner
//! and the learner-side values that tell it from the learner's other cells.

use mmq_lab::sweep::Plan;

/// Axes that belong to the learner rather than to the setting it learns in.
const LEARNER_SIDE: [&str; 8] =
    ["learner", "max_delay", "lambda_hat", "alpha", "gamma", "epsilon", "q0", "baseline"];

/// The learner setting a field of the `[settings]` table names (`settings.lasso` →
/// `lasso`; also under the prefix `beyond.` of stored specs).
fn setting_of(field: &str) -> Option<&str> {
    field.strip_prefix("settings.").or_else(|| field.strip_prefix("beyond."))
}

/// The settings of a sweep with a `learner` axis: every combination of the values of the
/// other axes (world, env, delay, robot, steps, ...), in order of first appearance, with
/// its cells as `(label, [(learner label, cell index)])`. A learner's label is its name,
/// with the learner-side axes (`max_delay`, `alpha`, ..., `settings.*`; not `baseline`)
/// whose values differ between its cells, e.g. `deconv-model-time (max_delay=200,
/// time_bin_s=1)`. The robot override `cell_diagnostics=true` (diagnostics, not a
/// setting) is left out of labels. Empty without a `learner` axis.
pub fn settings(plan: &Plan) -> Vec<(String, Vec<(String, usize)>)> {
    if !plan.axes.iter().any(|a| a == "learner") {
        return Vec::new();
    }
    let learner_side = |a: &str| LEARNER_SIDE.contains(&a) || setting_of(a).is_some();
    let others: Vec<&String> = plan.axes.iter().filter(|a| !learner_side(a)).collect();
    let tuning: Vec<&String> =
        plan.axes.iter().filter(|a| learner_side(a) && *a != "learner" && *a != "baseline").collect();
    let learner_label = |c: usize| -> String {
        let name = plan.param(c, "learner");
        let varied: Vec<String> = tuning
            .iter()
            .filter(|a| {
                (0..plan.cells.len())
                    .any(|d| plan.param(d, "learner") == name && plan.param(d, a) != plan.param(c, a))
            })
            .map(|a| format!("{}={}", setting_of(a).unwrap_or(a), plan.param(c, a)))
            .collect();
        if varied.is_empty() { name.to_string() } else { format!("{name} ({})", varied.join(", ")) }
    };
    let mut out: Vec<(String, Vec<(String, usize)>)> = Vec::new();
    for c in 0..plan.cells.len() {
        let label: Vec<String> =
            others.iter().map(|a| plan.param(c, a).replace(" cell_diagnostics=true", "")).collect();
        let label = if label.is_empty() { plan.name.clone() } else { label.join(" · ") };
        let learner = learner_label(c);
        match out.iter_mut().find(|s| s.0 == label) {
            Some(s) => s.1.push((learner, c)),
            None => out.push((label, vec![(learner, c)])),
        }
    }
    out
}

/// The learner labels of [`settings`], in order of first appearance.
pub fn learner_labels(sets: &[(String, Vec<(String, usize)>)]) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for (_, cells) in sets {
        for (l, _) in cells {
            if !out.contains(l) {
                out.push(l.clone());
            }
        }
    }
    out
}
