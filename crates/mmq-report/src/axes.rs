//! The axes of the paper's figures, read from the settings that ran: a figure's labels,
//! x values and table rows come from each group's world, delay and learner, never from
//! its position in the plan, so an edited figure spec (more delays, other worlds, another
//! λ̂ range) is drawn and labelled by its own values.

use std::path::Path;

use mmq_core::{DelayDist, DelayUnit};
use mmq_lab::paper::Group;
use mmq_learn::LearnerSettings;

use crate::ReportError;

/// The delay a group ran under, parsed from its configuration.
pub(crate) fn delay(g: &Group) -> Result<DelayDist, ReportError> {
    Ok(g.cfg.validate()?)
}

/// The mean delay of a group, and its unit's short name.
pub(crate) fn mean_delay(g: &Group) -> Result<(f64, &'static str), ReportError> {
    let d = delay(g)?;
    let unit = match d.unit() {
        DelayUnit::Steps => "steps",
        DelayUnit::Seconds => "s",
    };
    Ok((d.mean(), unit))
}

/// A number as a label: whole numbers without a decimal point (`3`, not `3.0`).
pub(crate) fn number(x: f64) -> String {
    format!("{x}")
}

/// The world file's stem (`paper-3x3`), the name a spec gives it.
pub(crate) fn world_stem(g: &Group) -> String {
    Path::new(&g.cfg.world)
        .file_stem()
        .map_or_else(|| g.cfg.world.display().to_string(), |s| s.to_string_lossy().into())
}

/// A world's size as the paper writes it (`3×3`: width × height).
pub(crate) fn world_size(g: &Group) -> Result<String, ReportError> {
    let w = g.cfg.load_world()?;
    Ok(format!("{}×{}", w.width, w.height))
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
    match &g.cfg.learner.settings {
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
