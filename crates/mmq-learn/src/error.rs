//! Why a learner cannot be built ([`LearnError`]): a setting outside its domain, tables
//! that would not fit, or an unknown name. A leaf: it uses nothing else of the crate.

/// Why a learner cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LearnError {
    /// A hyper-parameter outside its domain.
    #[error("`{field}` = {value} is not accepted; {accepted}")]
    InvalidParam {
        /// The parameter, as the configuration names it.
        field: &'static str,
        /// The value given.
        value: String,
        /// What is accepted.
        accepted: &'static str,
    },
    /// Tables that would not fit in memory.
    #[error(
        "the {learner} tables would need {need_gib:.1} GiB ({entries} entries) but at most {limit_gib:.1} GiB is allowed; lower `max_delay` or use a smaller world"
    )]
    TooLarge {
        /// Learner name.
        learner: &'static str,
        /// Q entries requested.
        entries: u128,
        /// GiB needed.
        need_gib: f64,
        /// GiB allowed.
        limit_gib: f64,
    },
    /// No learner by that name.
    #[error("unknown learner `{name}`; known learners: {known}")]
    UnknownLearner {
        /// The name given.
        name: String,
        /// The known names.
        known: String,
    },
}

/// The error for `field` = `value`, which is not accepted; `accepted` says what is.
pub(crate) fn bad<T>(
    field: &'static str,
    value: impl ToString,
    accepted: &'static str,
) -> Result<T, LearnError> {
    Err(LearnError::InvalidParam { field, value: value.to_string(), accepted })
}
