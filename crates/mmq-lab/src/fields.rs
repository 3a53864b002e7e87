//! Run-configuration fields (and a run's options besides, such as its live view's) as
//! errors name them, in backticks ("`max_delay` = 70000 is not accepted; …"), and the
//! command-line flag of each. Library errors speak the
//! configuration; a front end that speaks flags (the command line) rewrites them with
//! [`as_flags`], one that takes the fields by name (Python's keyword arguments) with
//! [`as_names`].

/// Each field an error can name, with its flag.
pub const FLAGS: &[(&str, &str)] = &[
    ("steps", "--steps"),
    ("seeds", "--seeds"),
    ("seed", "--seed"),
    ("window", "--window"),
    ("eval_steps", "--eval-steps"),
    ("record.pose_rate_hz", "--record-rate"),
    ("robot", "--robot"),
    ("delay", "--delay"),
    ("learner", "--learner"),
    ("alpha", "--alpha"),
    ("gamma", "--gamma"),
    ("epsilon", "--epsilon"),
    ("q0", "--q0"),
    ("max_delay", "--max-delay"),
    ("lambda_hat", "--lambda-hat"),
    ("time_bin_s", "--time-bin"),
    ("shard", "--shard"),
    ("merge", "--merge"),
    ("save_tables = false", "--no-tables"),
    ("out", "--out"),
    ("fig", "--fig"),
    ("threads", "--threads"),
    ("live", "--live"),
    ("record", "--record"),
    ("live_speed", "--live-speed"),
    ("live_wait", "--live-wait"),
    ("serve", "--serve"),
    ("render", "--render"),
    ("from", "--from"),
    ("to", "--to"),
];

fn rewrite(text: &str, to: impl Fn(&str, &str) -> String) -> String {
    let mut out = text.to_string();
    for (field, flag) in FLAGS {
        out = out.replace(&format!("`{field}`"), &to(field, flag));
    }
    out
}

/// `text` with every field of [`FLAGS`] in backticks written as its flag.
pub fn as_flags(text: &str) -> String {
    rewrite(text, |_, flag| flag.to_string())
}

/// `text` with the backticks around every field of [`FLAGS`] dropped.
pub fn as_names(text: &str) -> String {
    rewrite(text, |field, _| field.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_become_flags_or_plain_names_and_nothing_else_changes() {
        let t = "`max_delay` = 70000 is not accepted; lower `max_delay`, use fewer `seeds` or `save_tables = false`; unknown key `speed`";
        assert_eq!(
            as_flags(t),
            "--max-delay = 70000 is not accepted; lower --max-delay, use fewer --seeds or --no-tables; unknown key `speed`"
        );
        assert_eq!(
            as_names(t),
            "max_delay = 70000 is not accepted; lower max_delay, use fewer seeds or save_tables = false; unknown key `speed`"
        );
        // A field inside a longer name is not one.
        assert_eq!(as_flags("`seeds_x` and `seed`"), "`seeds_x` and --seed");
    }
}
