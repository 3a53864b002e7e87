//! The robot's profile — `ideal` (controllers on the true pose) or `realistic` (controllers
//! on an estimate from wheel odometry fused with noisy localisation fixes) — and the
//! parameters of the realistic model, each with its unit and its source in
//! `docs/robot.md`.

use serde::{Deserialize, Serialize};

use crate::config::{Preset, RobotError, check_range};

/// How the robot knows its pose.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Profile {
    /// Controllers on the true pose; the state is the true cell (with noise off, the
    /// grid's transitions exactly).
    #[default]
    Ideal,
    /// Controllers on the pose estimate (odometry + localisation fixes, fused by an
    /// extended Kalman filter); the state is the believed cell; rewards from the truth.
    Realistic,
}

impl Profile {
    /// The name used in the `[robot]` table.
    pub fn name(self) -> &'static str {
        match self {
            Profile::Ideal => "ideal",
            Profile::Realistic => "realistic",
        }
    }
}

/// The realistic model's parameters (the `[robot.realistic]` table, resolved). Defaults
/// depend on the preset only through the wheel radius and the encoder resolution.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RealisticConfig {
    /// Nominal wheel radius the odometry assumes, metres (Burger, Waffle: 0.033; Kobuki:
    /// 0.035).
    pub wheel_radius_m: f64,
    /// Encoder resolution, ticks per wheel revolution (Dynamixel XL430/XM430: 4096;
    /// Kobuki: 2578.33).
    pub encoder_ticks_per_rev: f64,
    /// Systematic calibration error: each wheel's true rolling radius is the nominal one
    /// times (1 + N(0, sd²)), drawn once per reset and fixed for the run; relative.
    pub wheel_radius_error_sd: f64,
    /// Rate of absolute localisation fixes, Hz.
    pub fix_rate_hz: f64,
    /// White (independent per fix) position noise of a fix, per axis, metres.
    pub fix_sd_m: f64,
    /// White heading noise of a fix, radians.
    pub fix_sd_rad: f64,
    /// Slowly varying position bias of the localiser (first-order Gauss–Markov), per
    /// axis, stationary standard deviation, metres.
    pub fix_bias_sd_m: f64,
    /// Stationary standard deviation of the heading bias, radians.
    pub fix_bias_sd_rad: f64,
    /// Correlation time of the bias, seconds.
    pub fix_bias_tau_s: f64,
    /// Odometry distance noise the filter assumes: variance k²·|Δs| per step, k in m^½.
    pub odom_sd_per_sqrt_m: f64,
    /// Odometry heading noise the filter assumes: variance k²·|Δθ| per step, k in rad^½.
    pub odom_sd_per_sqrt_rad: f64,
}

impl RealisticConfig {
    /// The defaults for a preset.
    pub fn for_preset(p: Preset) -> RealisticConfig {
        let (r, ticks) = match p {
            Preset::Turtlebot3Burger | Preset::Turtlebot3Waffle => (0.033, 4096.0),
            Preset::Kobuki => (0.035, 2578.33),
        };
        RealisticConfig {
            wheel_radius_m: r,
            encoder_ticks_per_rev: ticks,
            wheel_radius_error_sd: 0.01,
            fix_rate_hz: 4.0,
            fix_sd_m: 0.05,
            fix_sd_rad: 0.05,
            fix_bias_sd_m: 0.12,
            fix_bias_sd_rad: 0.03,
            fix_bias_tau_s: 10.0,
            odom_sd_per_sqrt_m: 0.035,
            odom_sd_per_sqrt_rad: 0.045,
        }
    }

    /// Checks every field's range; errors name the field as `realistic.<field>`.
    pub fn validate(&self) -> Result<(), RobotError> {
        check_range(
            "realistic.wheel_radius_m",
            self.wheel_radius_m,
            0.0,
            false,
            1.0,
            "a wheel radius in metres in (0, 1], e.g. 0.033",
        )?;
        check_range(
            "realistic.encoder_ticks_per_rev",
            self.encoder_ticks_per_rev,
            1.0,
            true,
            1e7,
            "ticks per wheel revolution in [1, 10^7], e.g. 4096",
        )?;
        check_range(
            "realistic.wheel_radius_error_sd",
            self.wheel_radius_error_sd,
            0.0,
            true,
            0.2,
            "a relative standard deviation in [0, 0.2], e.g. 0.01",
        )?;
        check_range(
            "realistic.fix_rate_hz",
            self.fix_rate_hz,
            0.0,
            false,
            1000.0,
            "a rate in Hz in (0, 1000], e.g. 4",
        )?;
        for (field, v) in
            [("realistic.fix_sd_m", self.fix_sd_m), ("realistic.fix_bias_sd_m", self.fix_bias_sd_m)]
        {
            check_range(field, v, 0.0, true, 1.0, "a standard deviation in metres in [0, 1]")?;
        }
        for (field, v) in
            [("realistic.fix_sd_rad", self.fix_sd_rad), ("realistic.fix_bias_sd_rad", self.fix_bias_sd_rad)]
        {
            check_range(field, v, 0.0, true, 1.0, "a standard deviation in radians in [0, 1]")?;
        }
        check_range(
            "realistic.fix_bias_tau_s",
            self.fix_bias_tau_s,
            0.0,
            false,
            1e6,
            "a correlation time in seconds in (0, 10^6], e.g. 10",
        )?;
        check_range(
            "realistic.odom_sd_per_sqrt_m",
            self.odom_sd_per_sqrt_m,
            0.0,
            true,
            1.0,
            "a noise density in m^½ in [0, 1], e.g. 0.035",
        )?;
        check_range(
            "realistic.odom_sd_per_sqrt_rad",
            self.odom_sd_per_sqrt_rad,
            0.0,
            true,
            1.0,
            "a noise density in rad^½ in [0, 1], e.g. 0.045",
        )?;
        if self.fix_sd_m + self.fix_bias_sd_m == 0.0 || self.fix_sd_rad + self.fix_bias_sd_rad == 0.0 {
            let (field, v) = if self.fix_sd_m + self.fix_bias_sd_m == 0.0 {
                ("realistic.fix_sd_m", self.fix_sd_m)
            } else {
                ("realistic.fix_sd_rad", self.fix_sd_rad)
            };
            return Err(RobotError::Invalid {
                field,
                value: v.to_string(),
                problem: "a fix without any noise (white and bias both 0) makes the filter's update singular"
                    .into(),
                accepted: "a positive white or bias standard deviation".into(),
            });
        }
        Ok(())
    }
}

/// The `[robot.realistic]` table as written: every field optional, defaulting to
/// [`RealisticConfig::for_preset`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RealisticTable {
    pub wheel_radius_m: Option<f64>,
    pub encoder_ticks_per_rev: Option<f64>,
    pub wheel_radius_error_sd: Option<f64>,
    pub fix_rate_hz: Option<f64>,
    pub fix_sd_m: Option<f64>,
    pub fix_sd_rad: Option<f64>,
    pub fix_bias_sd_m: Option<f64>,
    pub fix_bias_sd_rad: Option<f64>,
    pub fix_bias_tau_s: Option<f64>,
    pub odom_sd_per_sqrt_m: Option<f64>,
    pub odom_sd_per_sqrt_rad: Option<f64>,
}

/// The fields of `[robot.realistic]`, for override checks.
pub const REALISTIC_FIELDS: [&str; 11] = [
    "wheel_radius_m",
    "encoder_ticks_per_rev",
    "wheel_radius_error_sd",
    "fix_rate_hz",
    "fix_sd_m",
    "fix_sd_rad",
    "fix_bias_sd_m",
    "fix_bias_sd_rad",
    "fix_bias_tau_s",
    "odom_sd_per_sqrt_m",
    "odom_sd_per_sqrt_rad",
];

impl RealisticTable {
    /// Resolves over the preset's defaults.
    pub fn resolve(&self, preset: Preset) -> RealisticConfig {
        let mut c = RealisticConfig::for_preset(preset);
        macro_rules! take {
            ($($f:ident),*) => { $( if let Some(v) = self.$f { c.$f = v; } )* };
        }
        take!(
            wheel_radius_m,
            encoder_ticks_per_rev,
            wheel_radius_error_sd,
            fix_rate_hz,
            fix_sd_m,
            fix_sd_rad,
            fix_bias_sd_m,
            fix_bias_sd_rad,
            fix_bias_tau_s,
            odom_sd_per_sqrt_m,
            odom_sd_per_sqrt_rad
        );
        c
    }

    /// Every field written.
    pub fn from_config(c: &RealisticConfig) -> RealisticTable {
        RealisticTable {
            wheel_radius_m: Some(c.wheel_radius_m),
            encoder_ticks_per_rev: Some(c.encoder_ticks_per_rev),
            wheel_radius_error_sd: Some(c.wheel_radius_error_sd),
            fix_rate_hz: Some(c.fix_rate_hz),
            fix_sd_m: Some(c.fix_sd_m),
            fix_sd_rad: Some(c.fix_sd_rad),
            fix_bias_sd_m: Some(c.fix_bias_sd_m),
            fix_bias_sd_rad: Some(c.fix_bias_sd_rad),
            fix_bias_tau_s: Some(c.fix_bias_tau_s),
            odom_sd_per_sqrt_m: Some(c.odom_sd_per_sqrt_m),
            odom_sd_per_sqrt_rad: Some(c.odom_sd_per_sqrt_rad),
        }
    }
}
