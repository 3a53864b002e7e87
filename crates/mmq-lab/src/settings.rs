//! Learner settings by name, for the front ends that set them one at a time (the
//! command line, sweep specs, Python keyword arguments) and for configuration files:
//! a setting the chosen learner does not have is refused with its name, the learner's
//! own settings and the fix, never ignored.

use mmq_learn::spec::Params;
use mmq_learn::{LearnerKind, LearnerSpec};

use crate::error::LabError;

/// The names of the shared parameters (`[params]` of a learner's configuration).
pub const SHARED: [&str; 4] = ["alpha", "gamma", "epsilon", "q0"];

fn table_of(spec: &LearnerSpec) -> toml::Table {
    match toml::Value::try_from(spec) {
        Ok(toml::Value::Table(t)) => t,
        _ => toml::Table::new(),
    }
}

/// The settings of learner `kind`, by name, in alphabetical order (the shared parameters
/// not included).
pub fn setting_names(kind: LearnerKind) -> Vec<String> {
    // Every optional setting given, so that it is listed too.
    let mut full = LearnerSpec::new(kind);
    if let Some(d) = full.settings.deconv_mut() {
        d.told_delay = Some(String::new());
    }
    table_of(&full).keys().filter(|k| *k != "kind" && *k != "params").cloned().collect()
}

/// Whether learner `kind` has the setting `name` (a shared parameter counts).
pub fn has_setting(kind: LearnerKind, name: &str) -> bool {
    SHARED.contains(&name) || setting_names(kind).iter().any(|n| n == name)
}

/// The names of the learners that have the setting `name`, in `mmq learners` order.
pub fn learners_with(name: &str) -> Vec<&'static str> {
    mmq_learn::catalogue().into_iter().filter(|(k, ..)| has_setting(*k, name)).map(|c| c.1).collect()
}

/// The error for a setting `name` that learner `kind` does not have.
pub fn not_a_setting(kind: LearnerKind, name: &str) -> LabError {
    let own = setting_names(kind);
    let own = if own.is_empty() {
        "it has none besides alpha, gamma, epsilon and q0".to_string()
    } else {
        format!("its settings are {}", own.join(", "))
    };
    let with: Vec<&str> = learners_with(name).into_iter().filter(|&n| n != kind.name()).collect();
    let fix = if with.is_empty() {
        format!("remove `{name}`")
    } else {
        format!("remove `{name}`, or choose a learner that has it ({})", with.join(", "))
    };
    LabError::Setting {
        field: name.to_string(),
        message: format!("learner `{}` has no such setting; {own}; {fix}", kind.name()),
    }
}

/// `spec` with each `(name, value)` set: a shared parameter or one of the learner's own
/// settings (an integer is accepted for a decimal setting). A name the learner does not
/// have, or a value of the wrong type or out of range, is an error naming the setting.
pub fn with_settings(spec: &LearnerSpec, pairs: &[(&str, &toml::Value)]) -> Result<LearnerSpec, LabError> {
    let kind = spec.kind();
    let own = setting_names(kind);
    let mut table = table_of(spec);
    for &(name, value) in pairs {
        let slot = if SHARED.contains(&name) {
            match table.get_mut("params") {
                Some(toml::Value::Table(p)) => p,
                _ => return Err(not_a_setting(kind, name)),
            }
        } else if own.iter().any(|o| o == name) {
            &mut table
        } else {
            return Err(not_a_setting(kind, name));
        };
        let v = match (slot.get(name), value) {
            (Some(toml::Value::Float(_)), toml::Value::Integer(i)) => toml::Value::Float(*i as f64),
            _ => value.clone(),
        };
        slot.insert(name.to_string(), v);
    }
    let out: LearnerSpec = toml::Value::Table(table).try_into().map_err(|e: toml::de::Error| {
        let field = pairs.first().map_or("learner", |p| p.0).to_string();
        LabError::Setting { field, message: e.message().trim().replace('\n', "; ") }
    })?;
    out.validate()?;
    Ok(out)
}

/// Learner `name` with the shared parameters `params` and the settings given (`None`:
/// the learner's default), checked as [`with_settings`] checks them; a setting given
/// twice is an error, and so is an unknown name (naming `learner`).
pub fn learner(
    name: &str,
    params: Params,
    given: &[(&str, Option<toml::Value>)],
) -> Result<LearnerSpec, LabError> {
    let named: Vec<&str> = given.iter().filter(|(_, v)| v.is_some()).map(|(k, _)| *k).collect();
    if let Some((i, _)) = named.iter().enumerate().find(|(i, k)| named[..*i].contains(k)) {
        return Err(LabError::GivenTwice(named[i].to_string()));
    }
    let kind = LearnerKind::parse(name)
        .map_err(|e| LabError::Setting { field: "learner".into(), message: e.to_string() })?;
    let pairs: Vec<(&str, &toml::Value)> =
        given.iter().filter_map(|(k, v)| v.as_ref().map(|v| (*k, v))).collect();
    with_settings(&LearnerSpec { params, ..LearnerSpec::new(kind) }, &pairs)
}

/// The learner's own settings from a `[learner]` table in the flat layout that older
/// recordings carry in their `config.toml`: `lambda_hat`, `max_delay` and a `[beyond]`
/// table of every learner's settings, written for every learner. The learner read only
/// its own, so keeping those and dropping the rest describes the same run; `None` when
/// the table is not in that layout.
pub fn from_flat_layout(learner: &toml::Table) -> Option<toml::Table> {
    let Some(toml::Value::Table(flat)) = learner.get("beyond") else { return None };
    if !(learner.contains_key("lambda_hat") && learner.contains_key("max_delay")) {
        return None;
    }
    let kind = LearnerKind::parse(learner.get("kind")?.as_str()?).ok()?;
    let own = setting_names(kind);
    let mut out = toml::Table::new();
    for (k, v) in flat.iter().chain(learner) {
        if k == "kind" || k == "params" || own.iter().any(|o| o == k) {
            out.insert(k.clone(), v.clone());
        }
    }
    Some(out)
}

/// Checks a configuration's `[learner]` table before it is read: a `[learner.beyond]`
/// table or a setting the learner does not have is an error naming it and the fix.
pub fn check_learner_table(learner: &toml::Table) -> Result<(), LabError> {
    let Some(kind) = learner.get("kind").and_then(|k| k.as_str()).and_then(|k| LearnerKind::parse(k).ok())
    else {
        return Ok(()); // the typed read reports a missing or unknown kind
    };
    let own = setting_names(kind);
    if let Some(toml::Value::Table(b)) = learner.get("beyond") {
        let keep: Vec<&str> = b.keys().map(String::as_str).filter(|k| own.iter().any(|o| o == k)).collect();
        let fix = if keep.is_empty() {
            "delete the table".to_string()
        } else {
            format!("move {} into [learner] and delete the table", keep.join(", "))
        };
        return Err(LabError::Setting {
            field: "learner.beyond".into(),
            message: format!(
                "a learner's settings sit in [learner] itself, only those it has (`{}`: {}); {fix}",
                kind.name(),
                if own.is_empty() { "none".to_string() } else { own.join(", ") }
            ),
        });
    }
    for k in learner.keys() {
        if k != "kind" && k != "params" && !own.iter().any(|o| o == k) {
            return Err(not_a_setting(kind, k));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: impl Into<toml::Value>) -> toml::Value {
        x.into()
    }

    #[test]
    fn a_setting_given_twice_is_refused_before_the_learner_is_read() {
        let p = Params::default();
        let given = [("lambda_hat", Some(v(5))), ("max_delay", None), ("lambda_hat", Some(v(3)))];
        let e = learner("no-such-learner", p, &given).unwrap_err();
        assert_eq!(e.to_string(), "`lambda_hat` is given twice; give it once");
        assert!(e.is_input_error() && !e.names_fields());
        // Not given (`None`) does not count.
        let given = [("lambda_hat", None), ("lambda_hat", Some(v(3)))];
        assert_eq!(learner("fixed", p, &given).unwrap().kind(), LearnerKind::parse("fixed").unwrap());
    }

    #[test]
    fn each_learner_names_its_own_settings() {
        assert!(setting_names(LearnerKind::Q).is_empty());
        assert_eq!(setting_names(LearnerKind::Fixed), ["lambda_hat"]);
        assert_eq!(setting_names(LearnerKind::Mmq), ["max_delay"]);
        assert_eq!(setting_names(LearnerKind::MmqKernel), ["bootstrap", "kernel_width", "max_delay"]);
        assert_eq!(setting_names(LearnerKind::QLambda), ["trace_decay"]);
        let dq = setting_names(LearnerKind::DeconvQ);
        assert!(dq.iter().any(|n| n == "lasso") && dq.iter().any(|n| n == "replay_lag"), "{dq:?}");
        assert!(!dq.iter().any(|n| n == "probe_rate" || n == "time_bin_s"), "{dq:?}");
        let dt = setting_names(LearnerKind::DeconvModelTime);
        assert!(dt.iter().any(|n| n == "time_bin_s") && !dt.iter().any(|n| n == "optimism_confidence"));
        assert!(has_setting(LearnerKind::Q, "alpha") && !has_setting(LearnerKind::Q, "max_delay"));
    }

    #[test]
    fn settings_by_name_land_where_the_learner_reads_them_and_others_are_refused() {
        let mmq = LearnerSpec::new(LearnerKind::Mmq);
        let s = with_settings(&mmq, &[("max_delay", &v(7)), ("alpha", &v(1))]).unwrap();
        assert_eq!(s.settings.max_delay(), Some(7));
        assert_eq!(s.params.alpha, 1.0);
        let e = with_settings(&mmq, &[("lasso", &v(0.2))]).unwrap_err().to_string();
        assert!(
            e.starts_with("`lasso`: learner `mmq` has no such setting; its settings are max_delay"),
            "{e}"
        );
        assert!(
            e.contains("choose a learner that has it (deconv-q, deconv-model, deconv-model-time)"),
            "{e}"
        );
        let q = LearnerSpec::new(LearnerKind::Q);
        let e = with_settings(&q, &[("max_delay", &v(7))]).unwrap_err().to_string();
        assert!(e.contains("has none besides alpha") && e.contains("mmq, mmq-reference, mmq-kernel"), "{e}");
        let e = with_settings(&q, &[("speed", &v(7))]).unwrap_err().to_string();
        assert!(e.ends_with("remove `speed`"), "{e}");
        // Wrong type, out of range.
        let k = LearnerSpec::new(LearnerKind::MmqKernel);
        let e = with_settings(&k, &[("kernel_width", &v("wide"))]).unwrap_err().to_string();
        assert!(e.contains("kernel_width") && e.contains("invalid type"), "{e}");
        let e = with_settings(&k, &[("kernel_width", &v(-1.0))]).unwrap_err().to_string();
        assert!(e.contains("`kernel_width` = -1"), "{e}");
        let s = with_settings(&k, &[("kernel_width", &v(3)), ("bootstrap", &v("own"))]).unwrap();
        assert_eq!(toml::to_string(&s).unwrap().lines().nth(2), Some("kernel_width = 3.0"));
        // A setting absent by default.
        let d = LearnerSpec::new(LearnerKind::DeconvQ);
        let s = with_settings(&d, &[("told_delay", &v("poisson:13"))]).unwrap();
        assert_eq!(s.settings.deconv().unwrap().told_delay.as_deref(), Some("poisson:13"));
        assert!(with_settings(&q, &[("told_delay", &v("poisson:13"))]).is_err());
    }

    #[test]
    fn a_learner_by_name_takes_its_parameters_and_the_settings_given() {
        let params = Params { alpha: 0.5, ..Params::default() };
        let s = learner("mmq", params, &[("max_delay", Some(v(7))), ("lambda_hat", None)]).unwrap();
        assert_eq!((s.kind(), s.params.alpha, s.settings.max_delay()), (LearnerKind::Mmq, 0.5, Some(7)));
        let e = learner("sarsa", params, &[]).unwrap_err().to_string();
        assert!(e.starts_with("`learner`: unknown learner `sarsa`"), "{e}");
        let e = learner("q", params, &[("max_delay", Some(v(4)))]).unwrap_err().to_string();
        assert!(e.starts_with("`max_delay`: learner `q` has no such setting"), "{e}");
    }
}
