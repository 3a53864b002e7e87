//! The realistic profile's knowledge of the robot: its calibration error, encoders,
//! odometry, localiser and the filter that fuses them. It has its own random stream
//! (derived from the reset seed), so the ideal profile's stream is untouched.

use mmq_core::Rng;
use mmq_core::seed::{rng_from_seed, splitmix64};
use rand_distr::{Distribution, StandardNormal};

use crate::config::RobotConfig;
use crate::estimator::{Ekf, M3, diag};
use crate::localisation::Localiser;
use crate::odometry::{Encoders, Odometry};
use crate::profile::RealisticConfig;

/// Tag mixed into the reset seed for the realistic model's stream.
const STREAM_TAG: u64 = 0x5245_414C_4953_5449; // "REALISTI"

/// A drawn calibration error is clamped to this many standard deviations.
const CALIBRATION_CLAMP_SD: f64 = 3.0;

/// Standard deviation of the estimate's start (and re-localisation) covariance: the
/// start pose is known to a millimetre and a milliradian (assumption: the robot is put
/// at the start by hand, or re-localised after the goal's teleport).
const START_SD: [f64; 3] = [1e-3, 1e-3, 1e-3];

/// The realistic model of one robot.
#[derive(Clone, Debug)]
pub(crate) struct Realistic {
    pub cfg: RealisticConfig,
    /// Nominal wheel base, metres.
    wheel_base_m: f64,
    encoders: Encoders,
    odometry: Odometry,
    pub ekf: Ekf,
    pub localiser: Localiser,
    rng: Rng,
    /// Each wheel's true rolling radius ÷ the nominal one (left, right), fixed per reset.
    pub calibration: [f64; 2],
    /// The motors' speed gain of the running primitive (the actuation noise's wheel
    /// gain, 1 without noise): the motor shafts turn this much faster than commanded,
    /// and the encoders count it.
    pub motor_gain: [f64; 2],
}

fn start_cov() -> M3 {
    diag(START_SD.map(|s| s * s))
}

impl Realistic {
    pub fn new(cfg: &RobotConfig) -> Realistic {
        let c = cfg.realistic;
        Realistic {
            cfg: c,
            wheel_base_m: cfg.wheel_base_m,
            encoders: Encoders::new(c.encoder_ticks_per_rev),
            odometry: Odometry::new(c.wheel_radius_m, c.encoder_ticks_per_rev, cfg.wheel_base_m),
            ekf: Ekf::new((0.0, 0.0, 0.0), start_cov(), c.odom_sd_per_sqrt_m, c.odom_sd_per_sqrt_rad),
            localiser: Localiser::new(&c),
            rng: rng_from_seed(0),
            calibration: [1.0; 2],
            motor_gain: [1.0; 2],
        }
    }

    /// A new episode from the true pose `pose`: draws the calibration error and the
    /// localiser's bias from the seed's stream; the estimate starts at the truth.
    pub fn reset(&mut self, seed: u64, pose: (f64, f64, f64)) {
        self.rng = rng_from_seed(splitmix64(seed ^ STREAM_TAG));
        let sd = self.cfg.wheel_radius_error_sd;
        for g in &mut self.calibration {
            let e: f64 = StandardNormal.sample(&mut self.rng);
            *g = 1.0 + sd * e.clamp(-CALIBRATION_CLAMP_SD, CALIBRATION_CLAMP_SD);
        }
        self.motor_gain = [1.0; 2];
        self.encoders = Encoders::new(self.cfg.encoder_ticks_per_rev);
        self.ekf.reset(pose, start_cov());
        self.localiser.reset(&mut self.rng);
    }

    /// Re-localisation at a known true pose (after the goal's teleport).
    pub fn relocalise(&mut self, pose: (f64, f64, f64)) {
        self.ekf.reset(pose, start_cov());
    }

    /// After a physics step of `dt_s` in which the motors were commanded twist (v m/s,
    /// ω rad/s): the encoders count the motors' rotation (commanded wheel speed × motor
    /// gain ÷ nominal radius; what the wheels then do on the floor — a rolling radius off
    /// by the calibration error, slip — they do not see), the filter predicts with the odometry,
    /// and fuses a localisation fix if one is due at `t_s` (of the true pose `truth`).
    /// Returns the fix.
    pub fn after_physics(
        &mut self,
        v: f64,
        w: f64,
        dt_s: f64,
        t_s: f64,
        truth: (f64, f64, f64),
    ) -> Option<(f64, f64, f64)> {
        let r = self.cfg.wheel_radius_m;
        let half_b = 0.5 * self.wheel_base_m;
        let [gl, gr] = self.motor_gain;
        self.encoders.turn(gl * (v - w * half_b) / r * dt_s, gr * (v + w * half_b) / r * dt_s);
        let (ds, dth) = self.odometry.increment(self.encoders.take_ticks());
        self.ekf.predict(ds, dth);
        let fix = self.localiser.poll(t_s, truth, &mut self.rng)?;
        self.ekf.update(fix, self.localiser.assumed_variance());
        Some(fix)
    }

    /// The pose estimate (x m, y m, θ rad).
    pub fn estimate(&self) -> (f64, f64, f64) {
        self.ekf.mean
    }
}
