//! The worlds shipped with mmq, embedded in the binary so that they are found by name
//! (`--world paper-9x9`) from any folder; `mmq world list` names them.
//!
//! [`crate::World::load`] reads a file when it exists, exactly as always; only when the
//! file does not exist and its stem is a shipped world's name (`worlds/paper-9x9.toml`
//! run from another folder, say) is the embedded copy used.

/// (name, file text) of every shipped world.
pub const WORLDS: [(&str, &str); 8] = [
    ("paper-3x3", include_str!("../../../worlds/paper-3x3.toml")),
    ("paper-5x5", include_str!("../../../worlds/paper-5x5.toml")),
    ("paper-9x9", include_str!("../../../worlds/paper-9x9.toml")),
    ("corridor-7x3", include_str!("../../../worlds/corridor-7x3.toml")),
    ("room-12x6", include_str!("../../../worlds/room-12x6.toml")),
    ("maze-15x15", include_str!("../../../worlds/maze-15x15.toml")),
    ("open-30x30", include_str!("../../../worlds/open-30x30.toml")),
    ("open-50x50", include_str!("../../../worlds/open-50x50.toml")),
];

/// The text of the shipped world `name`, if there is one.
pub fn world_text(name: &str) -> Option<&'static str> {
    WORLDS.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// The names of the shipped worlds, comma-separated (for error messages).
pub fn world_names() -> String {
    WORLDS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every shipped world parses, and its name is its file's stem.
    #[test]
    fn every_shipped_world_is_valid() {
        for (name, text) in WORLDS {
            let w = crate::World::parse(text, name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(w.name, name);
        }
    }
}
