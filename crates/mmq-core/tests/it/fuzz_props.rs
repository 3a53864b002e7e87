//! Property-based fuzzing of mmq-core's parsers (proptest; seconds in CI): random world
//! texts and maps for `World::parse`, random delay specs for `DelayDist::parse`. Nothing
//! may panic; what is accepted must be consistent; what is refused gets a message naming
//! the file. The long-running coverage-guided fuzzers are in `fuzz/` (docs/robustness.md).

use mmq_core::delay::MAX_MEAN_DELAY;
use mmq_core::world::{MAX_CELLS, MAX_SIDE};
use mmq_core::{Cell, DelayDist, World, optimum};
use proptest::prelude::*;

fn config() -> ProptestConfig {
    ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() }
}

/// An accepted world is consistent; a refused one names the file in one line.
fn check_world(text: &str) {
    match World::parse(text, "prop.toml") {
        Ok(w) => {
            assert_eq!(w.cells.len(), w.width * w.height);
            assert!(w.width <= MAX_SIDE && w.height <= MAX_SIDE && w.num_cells() <= MAX_CELLS);
            assert_ne!(w.goal, w.respawn);
            assert_eq!(w.cells[w.goal], Cell::Free);
            assert_eq!(w.cells[w.respawn], Cell::Free);
            assert!(w.cell_size.is_finite() && w.cell_size > 0.0);
            let o = optimum(&w);
            assert!(o.gain.is_finite(), "{text}");
            // The goal is reachable from everywhere, so an optimal action exists in
            // every free cell.
            for c in w.free_cells() {
                assert_ne!(o.actions[c], 0, "cell {c} has no optimal action\n{text}");
            }
        }
        Err(e) => {
            let msg = e.to_string();
            assert!(msg.starts_with("prop.toml: "), "{msg}");
            assert!(!msg.trim().is_empty());
        }
    }
}

/// A map of `.`, `#`, `G`, `S` and the odd stray character.
fn map_strategy() -> impl Strategy<Value = String> {
    (1usize..12, 1usize..12).prop_flat_map(|(w, h)| {
        prop::collection::vec(
            prop_oneof![
                6 => Just('.'),
                3 => Just('#'),
                1 => Just('G'),
                1 => Just('S'),
                1 => prop::sample::select(vec!['?', ' ', '\t', 'g', 'é', '"', '\\']),
            ],
            w * h,
        )
        .prop_map(move |cells| cells.chunks(w).map(|r| r.iter().collect::<String>() + "\n").collect())
    })
}

/// A world file: a map plus optional fields with numbers from the awkward end.
fn world_text_strategy() -> impl Strategy<Value = String> {
    let num = prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("0".to_string()),
        Just("-0.0".to_string()),
        Just("1e308".to_string()),
        Just("1e-320".to_string()),
        (-1e3f64..1e3).prop_map(|x| format!("{x:?}")),
    ];
    (
        map_strategy(),
        prop::option::of(num.clone()),
        prop::option::of(num.clone()),
        prop::option::of(prop::sample::select(vec!["random", "respawn", "anywhere"])),
        prop::option::of(prop::sample::select(vec!["", "radius_m = 0.3", "dt_s = nan", "preset = \"x\""])),
    )
        .prop_map(|(map, cell, goal, start, robot)| {
            let mut t = String::new();
            if let Some(c) = cell {
                t += &format!("cell_size = {c}\n");
            }
            if let Some(s) = start {
                t += &format!("start = \"{s}\"\n");
            }
            t += &format!("map = \"\"\"\n{map}\"\"\"\n");
            if let Some(g) = goal {
                t += &format!("[rewards]\ngoal = {g}\n");
            }
            if let Some(r) = robot {
                t += &format!("[robot]\n{r}\n");
            }
            t
        })
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn world_parse_never_panics_on_any_text(text in "\\PC{0,200}") {
        check_world(&text);
    }

    #[test]
    fn world_parse_never_panics_on_toml_like_text(
        text in "(map|name|cell_size|start|\\[rewards\\]|\\[robot\\]|goal|wall|step| |=|\"|\"\"\"|\n|G|S|\\.|#|[0-9]|nan|inf|-|e){0,60}"
    ) {
        check_world(&text);
    }

    #[test]
    fn world_parse_on_random_maps_and_fields(text in world_text_strategy()) {
        check_world(&text);
    }

    /// A map with exactly one G and one S parses unless some free cell cannot reach G,
    /// and then the message says so.
    #[test]
    fn maps_with_one_goal_and_respawn(map in map_strategy()) {
        let n_g = map.matches('G').count();
        let n_s = map.matches('S').count();
        let clean = map.chars().all(|c| matches!(c, '.' | '#' | 'G' | 'S' | '\n'));
        let text = format!("map = \"\"\"\n{map}\"\"\"\n");
        check_world(&text);
        if n_g == 1 && n_s == 1 && clean
            && let Err(e) = World::parse(&text, "prop.toml")
        {
            prop_assert!(e.message.contains("cannot be reached"), "{e}\n{map}");
        }
    }
}

/// Accepted delay specs have a finite mean within the supported range and a sampler that
/// works; the printed form parses again.
fn check_delay(spec: &str) {
    let Ok(d) = DelayDist::parse(spec) else { return };
    let m = d.mean();
    assert!(m.is_finite() && (0.0..=MAX_MEAN_DELAY).contains(&m), "{spec}: mean {m}");
    assert!(!d.variance().is_nan(), "{spec}: variance");
    let s = d.sampler();
    let mut rng = mmq_core::seed::rng_from_seed(3);
    for _ in 0..8 {
        let _ = s.sample(&mut rng);
    }
    let printed = d.to_string();
    let back = DelayDist::parse(&printed);
    assert!(back.is_ok(), "{spec} printed as {printed}: {back:?}");
}

fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("-1".to_string()),
        Just("0".to_string()),
        Just("1e308".to_string()),
        Just("1e-308".to_string()),
        Just("4294967296".to_string()),
        Just("".to_string()),
        (0u32..100).prop_map(|x| x.to_string()),
        (0.0f64..1.0).prop_map(|x| x.to_string()),
    ]
}

fn leaf_spec() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("none".to_string()),
        number().prop_map(|x| format!("const:{x}")),
        number().prop_map(|x| format!("poisson:{x}")),
        number().prop_map(|x| format!("geometric:{x}")),
        (number(), number()).prop_map(|(a, b)| format!("uniform:{a}:{b}")),
        prop::collection::vec(number(), 0..5).prop_map(|w| format!("hist:{}", w.join(","))),
        "[a-z]{0,8}:[0-9.:,*+e-]{0,10}",
    ]
}

fn spec_strategy() -> impl Strategy<Value = String> {
    prop_oneof![
        3 => leaf_spec(),
        2 => prop::collection::vec((number(), leaf_spec()), 1..4).prop_map(|parts| {
            let p: Vec<String> = parts.into_iter().map(|(w, s)| format!("{w}*{s}")).collect();
            format!("mix:{}", p.join("+"))
        }),
    ]
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn delay_parse_never_panics_on_any_text(spec in "\\PC{0,40}") {
        check_delay(&spec);
    }

    #[test]
    fn delay_parse_on_structured_specs(spec in spec_strategy()) {
        check_delay(&spec);
    }

    /// Specs that are well formed by construction parse and print back to themselves.
    #[test]
    fn well_formed_specs_round_trip(
        k in 0u32..1000,
        l in 0.0f64..1000.0,
        p in 0.001f64..=1.0,
        lo in 0u32..50,
        span in 0u32..50,
        w in prop::collection::vec(0.0f64..10.0, 1..6),
    ) {
        let hist = if w.iter().sum::<f64>() > 0.0 {
            format!("hist:{}", w.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(","))
        } else {
            "none".to_string()
        };
        for spec in [
            format!("const:{k}"),
            format!("poisson:{l}"),
            format!("geometric:{p}"),
            format!("uniform:{lo}:{}", lo + span),
            hist,
            format!("mix:0.25*const:{k}+0.75*poisson:{l}"),
        ] {
            let d = DelayDist::parse(&spec).unwrap();
            prop_assert_eq!(d.to_string(), spec.clone());
            prop_assert_eq!(DelayDist::parse(&d.to_string()).unwrap(), d);
        }
    }
}
