//! The axes of the paper's figures, read from the settings that ran: a figure's labels,
//! x values and table rows come from each group's world, delay and learner, never from
//! its position in the plan, so an edited figure spec (more delays, other worlds, another
//! λ̂ range) is drawn and labelled by its own values.

use std::path::Path;

use mmq_core::{DelayDist, DelayUnit};
use mmq_lab::RunConfig;
use mmq_lab::study::Group;
use mmq_learn::LearnerSettings;

use crate::ReportError;

/// The mean delay of a group, and its unit's short name.
pub(crate) fn mean_delay(g: &Group) -> Result<(f64, &'static str), ReportError> {
    mean_delay_of(&g.cfg)
}

/// The mean delay of a configuration, and its unit's short name.
pub(crate) fn mean_delay_of(cfg: &RunConfig) -> Result<(f64, &'static str), ReportError> {
    let d = DelayDist::parse(&cfg.delay).map_err(mmq_lab::LabError::from)?;
    let unit = match d.unit() {
        DelayUnit::Steps => "steps",
        DelayUnit::Seconds => "s",
    };
    Ok((d.mean(), unit))
}

/// A configuration's delay as a heading states it: `Poisson λ = 13`, or the spec's own
/// words for another distribution (`delay uniform:0:26`).
pub(crate) fn delay_words(cfg: &RunConfig) -> String {
    match DelayDist::parse(&cfg.delay) {
        Ok(DelayDist::Poisson(l)) => format!("Poisson λ = {}", number(l)),
        _ => format!("delay {}", cfg.delay),
    }
}

/// Whether a configuration's delay is Poisson (none counts as Poisson with λ = 0).
pub(crate) fn is_poisson(cfg: &RunConfig) -> bool {
    matches!(DelayDist::parse(&cfg.delay), Ok(DelayDist::Poisson(_) | DelayDist::None))
}

/// A configuration's delay as a setting line states it: `λ = 13` for a Poisson delay,
/// the spec's own words for another distribution (`delay uniform:0:26`).
pub(crate) fn lambda_words(cfg: &RunConfig) -> String {
    match DelayDist::parse(&cfg.delay) {
        Ok(DelayDist::Poisson(l)) => format!("λ = {}", number(l)),
        _ => format!("delay {}", cfg.delay),
    }
}

/// A world's size as the paper writes it (`9×9`), from a configuration.
pub(crate) fn world_size_of(cfg: &RunConfig) -> Result<String, ReportError> {
    let w = cfg.load_world()?;
    Ok(format!("{}×{}", w.width, w.height))
}

/// A learner's name as the report writes it (`MMQ`, `Q-learning`, or the learner's own
/// name), with MMQ's largest delay where it has one (`MMQ (λ̂max = 50)`).
pub(crate) fn learner_label(cfg: &RunConfig) -> String {
    use mmq_learn::LearnerKind;
    match (cfg.learner.kind(), cfg.learner.settings.max_delay()) {
        (LearnerKind::Mmq, Some(m)) => format!("MMQ (λ̂max = {m})"),
        (LearnerKind::Q, _) => "Q-learning".into(),
        (k, Some(m)) => format!("{} (λ̂max = {m})", k.name()),
        (k, None) => k.name().into(),
    }
}

/// A number as a label: whole numbers without a decimal point (`3`, not `3.0`).
pub(crate) fn number(x: f64) -> String {
    format!("{x}")
}

/// The world file's stem (`paper-3x3`), the name a spec gives it.
pub(crate) fn world_stem(g: &Group) -> String {
    world_stem_of(&g.cfg)
}

/// The world file's stem of a configuration.
pub(crate) fn world_stem_of(cfg: &RunConfig) -> String {
    Path::new(&cfg.world)
        .file_stem()
        .map_or_else(|| cfg.world.display().to_string(), |s| s.to_string_lossy().into())
}

/// A world's size as the paper writes it (`3×3`: width × height).
pub(crate) fn world_size(g: &Group) -> Result<String, ReportError> {
    world_size_of(&g.cfg)
}

/// One label per group naming its world: the size where every group's size differs
/// (the paper's `3×3`, `5×5`, `9×9`), else the size with the world's file name.
pub(crate) fn world_labels(groups: &[Group]) -> Result<Vec<String>, ReportError> {
    let sizes = groups.iter().map(world_size).collect::<Result<Vec<_>, _>>()?;
    let unique = sizes.iter().enumerate().all(|(i, s)| !sizes[..i].contains(s));
    Ok(if unique {
        sizes
    } else {
        sizes.iter().zip(groups).map(|(s, g)| format!("{s} ({})", world_stem(g))).collect()
    })
}

/// The fixed delay estimate λ̂ of a group's `fixed` learner, if it is one.
pub(crate) fn lambda_hat(g: &Group) -> Option<u64> {
    lambda_hat_of(&g.cfg)
}

/// The fixed delay estimate λ̂ of a configuration's `fixed` learner, if it is one.
pub(crate) fn lambda_hat_of(cfg: &RunConfig) -> Option<u64> {
    match &cfg.learner.settings {
        LearnerSettings::Fixed(s) => Some(s.lambda_hat as u64),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_as_written() {
        assert_eq!(number(3.0), "3");
        assert_eq!(number(0.0), "0");
        assert_eq!(number(2.5), "2.5");
        assert_eq!(number(17.0), "17");
    }
}
