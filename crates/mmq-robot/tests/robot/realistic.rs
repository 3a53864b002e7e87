//! The realistic profile: determinism, the believed vs true state, telemetry (estimates
//! and fixes), diagnostics, and its configuration's bad input.

use mmq_core::Telemetry;
use mmq_core::env::check_determinism;
use mmq_core::seed::rng_from_seed;
use mmq_core::{Env, Start, StepTrace};
use mmq_robot::{Profile, RobotConfig, RobotEnv, RobotError};
use rand::RngExt;

fn realistic() -> RobotConfig {
    RobotConfig::from_toml("profile = \"realistic\"").unwrap()
}

fn make(world: &str, cfg: RobotConfig) -> RobotEnv {
    RobotEnv::new(&crate::world(world), cfg).unwrap()
}

/// Runs `n` seeded random actions; returns the states, the stats and the number of
/// steps whose believed state differed from the true one.
fn run(env: &mut RobotEnv, seed: u64, n: usize) -> (Vec<usize>, Vec<(String, f64)>, usize) {
    let mut states = vec![env.reset(seed, Start::World).unwrap()];
    let mut rng = rng_from_seed(seed ^ 0xabc);
    let mut differ = 0;
    for _ in 0..n {
        let st = env.step(rng.random_range(0..env.num_actions())).unwrap();
        states.push(st.state);
        if env.true_state() != Some(st.state) {
            differ += 1;
        }
    }
    (states, env.stats(), differ)
}

fn get(stats: &[(String, f64)], k: &str) -> f64 {
    stats.iter().find(|(n, _)| n == k).map(|(_, v)| *v).unwrap_or_else(|| panic!("no {k}"))
}

#[test]
fn checker_passes() {
    check_determinism(|| make("paper-9x9", realistic()), 5, 150).unwrap();
    check_determinism(|| make("maze-15x15", realistic()), 6, 100).unwrap();
}

#[test]
fn diagnostics_are_reproducible_and_seed_dependent() {
    let mut e = make("paper-9x9", realistic());
    let a = run(&mut e, 11, 200);
    let b = run(&mut e, 11, 200);
    assert_eq!(a, b);
    let c = run(&mut make("paper-9x9", realistic()), 12, 200);
    assert_ne!(a.1, c.1, "another seed, other diagnostics");
    // The stats are consistent with what the steps showed.
    assert_eq!(get(&a.1, "robot/belief_error"), a.2 as f64 / 200.0);
    let err = get(&a.1, "robot/loc_error_m_mean");
    assert!(err > 0.0 && err < 0.25, "mean localisation error {err} m");
    assert!(get(&a.1, "robot/loc_error_m_p95") >= err);
    let dur = get(&a.1, "robot/primitive_s_mean");
    assert!(dur > 1.0 && dur < 10.0, "{dur}");
}

#[test]
fn ideal_has_no_estimate_and_no_mismatch() {
    let mut e = make("paper-9x9", RobotConfig::default());
    let (_, stats, _) = run(&mut e, 3, 150);
    assert_eq!(e.pose_estimate(), None);
    assert_eq!(e.true_state(), None);
    assert_eq!(get(&stats, "robot/grid_mismatch"), 0.0);
    assert_eq!(get(&stats, "robot/belief_error"), 0.0);
    assert!(!stats.iter().any(|(k, _)| k.starts_with("robot/loc_error")));
    let f = e.features();
    assert!(f.contains(&("robot.profile".to_string(), "ideal".to_string())));
}

#[test]
fn the_estimate_starts_at_the_truth_and_is_reset_at_the_goal() {
    let mut e = make("paper-9x9", realistic());
    let w = e.world().clone();
    let s = e.reset(4, Start::State(w.goal)).unwrap();
    assert_eq!(s, w.goal);
    let (p, q) = (e.pose(), e.pose_estimate().unwrap());
    assert!((p.x - q.x).abs() < 1e-6 && (p.y - q.y).abs() < 1e-6 && (p.theta - q.theta).abs() < 1e-6);
    // Drive around, then get to the goal state by teleport: from the goal any action
    // teleports to S and the estimate is the true S pose again.
    e.step(2).unwrap();
    e.step(0).unwrap();
    let at_goal = e.true_state() == Some(w.goal);
    let st = e.step(1).unwrap();
    if at_goal {
        assert_eq!(st.reward, w.rewards.goal);
        let (p, q) = (e.pose(), e.pose_estimate().unwrap());
        assert_eq!((p.x, p.y, p.theta), (q.x, q.y, q.theta));
        assert_eq!(st.state, w.respawn);
    }
}

#[test]
fn trace_has_estimates_at_the_pose_times_and_fixes_at_the_rate() {
    let cfg = RobotConfig::from_toml("profile = \"realistic\"\n[realistic]\nfix_rate_hz = 5").unwrap();
    let mut e = make("paper-9x9", cfg);
    e.set_trace(Some(0.1));
    e.reset(2, Start::World).unwrap();
    let mut tr = StepTrace::default();
    let (mut fixes, mut t_prev) = (0usize, e.sim_time_s());
    for a in [0, 1, 2, 3, 0, 1] {
        e.step(a).unwrap();
        e.take_trace(&mut tr);
        assert_eq!(tr.poses.len(), tr.estimates.len());
        for (p, q) in tr.poses.iter().zip(&tr.estimates) {
            assert_eq!(p.time_s, q.time_s);
            // The estimate stays within a few σ of the truth.
            assert!(((p.x - q.x).powi(2) + (p.y - q.y).powi(2)).sqrt() < 0.5);
        }
        assert_eq!(*tr.estimates.last().unwrap(), e.pose_estimate().unwrap());
        assert!(tr.fixes.iter().all(|f| f.time_s > t_prev && f.time_s <= e.sim_time_s()));
        fixes += tr.fixes.len();
        t_prev = e.sim_time_s();
    }
    let expected = e.sim_time_s() * 5.0;
    assert!((fixes as f64 - expected).abs() <= 1.0, "{fixes} fixes in {} s", e.sim_time_s());
}

#[test]
fn the_robot_drives_on_its_estimate() {
    // A localiser with a large, slowly varying bias and rare fixes: the robot ends its
    // primitives where it believes the cell centres are, so the true end points spread
    // while the ideal robot's do not.
    let cfg = RobotConfig::from_toml(
        "profile = \"realistic\"\n[realistic]\nfix_rate_hz = 1\nfix_bias_sd_m = 0.1\nfix_bias_tau_s = 100",
    )
    .unwrap();
    let spread = |cfg: RobotConfig| {
        let mut e = make("paper-9x9", cfg);
        e.reset(8, Start::World).unwrap();
        let mut off = 0.0f64;
        let mut rng = rng_from_seed(1);
        for _ in 0..60 {
            e.step(rng.random_range(0..4)).unwrap();
            let p = e.pose();
            let c = e.world().cell_at(p.x, p.y).unwrap();
            let (cx, cy) = e.world().cell_center(c);
            off = off.max(((p.x - cx).powi(2) + (p.y - cy).powi(2)).sqrt());
        }
        off
    };
    let ideal = spread(RobotConfig::default());
    let real = spread(cfg);
    assert!(ideal < 0.02, "ideal ends within the tolerance: {ideal}");
    assert!(real > 0.05, "realistic ends off the centres: {real}");
}

#[test]
fn profile_defaults_and_roundtrip() {
    let c = realistic();
    assert_eq!(c.profile, Profile::Realistic);
    // The realistic profile turns actuation noise on with its defaults.
    assert!(c.noise.is_some());
    assert_eq!(c.realistic.encoder_ticks_per_rev, 4096.0);
    assert_eq!(c.realistic.wheel_radius_m, 0.033);
    let text = toml::to_string(&c).unwrap();
    let back: RobotConfig = toml::from_str(&text).unwrap();
    assert_eq!(back, c, "{text}");
    let kobuki = RobotConfig::from_toml("profile = \"realistic\"\npreset = \"kobuki\"").unwrap();
    assert_eq!(kobuki.realistic.wheel_radius_m, 0.035);
}

#[test]
fn bad_realistic_fields_are_named() {
    let field = |text: &str| match RobotConfig::from_toml(text) {
        Err(RobotError::Invalid { field, .. }) => field.to_string(),
        other => panic!("{text}: {other:?}"),
    };
    let r = "profile = \"realistic\"\n[realistic]\n";
    assert_eq!(field(&format!("{r}fix_rate_hz = 0")), "realistic.fix_rate_hz");
    assert_eq!(field(&format!("{r}fix_sd_m = -0.1")), "realistic.fix_sd_m");
    assert_eq!(field(&format!("{r}wheel_radius_error_sd = 0.5")), "realistic.wheel_radius_error_sd");
    assert_eq!(field(&format!("{r}encoder_ticks_per_rev = 0.5")), "realistic.encoder_ticks_per_rev");
    assert_eq!(field(&format!("{r}fix_bias_tau_s = nan")), "realistic.fix_bias_tau_s");
    assert_eq!(field(&format!("{r}fix_sd_m = 0\nfix_bias_sd_m = 0")), "realistic.fix_sd_m");
    assert_eq!(field("[realistic]\nfix_rate_hz = 2"), "realistic");
    let e = RobotConfig::from_toml("profile = \"fuzzy\"").unwrap_err();
    assert!(matches!(e, RobotError::Parse { .. }) && e.to_string().contains("fuzzy"), "{e}");
    let e = RobotConfig::from_toml("profile = \"realistic\"\n[realistic]\nrate = 2").unwrap_err();
    assert!(e.to_string().contains("rate"), "{e}");
    let msg = RobotConfig::from_toml(&format!("{r}fix_rate_hz = 0")).unwrap_err().to_string();
    assert!(msg.contains("(0, 1000]"), "{msg}");
}
