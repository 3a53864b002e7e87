//! Wheel odometry: quadrature encoders with a finite resolution on each wheel's motor
//! shaft, and dead reckoning from the measured wheel rotations with the *nominal* wheel
//! radius and wheel base.
//!
//! The encoders count the motors' rotation, not the ground's motion: a wheel whose true
//! rolling radius differs from the nominal one (calibration error), a wheel that slips
//! at its friction limit or against a wall, or a per-primitive speed gain error all move
//! the robot differently from what the encoders report, so dead reckoning drifts.

use std::f64::consts::TAU;

/// The two wheels' encoders: the true motor angle (radians, unbounded) and the tick
/// counts read from it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Encoders {
    /// True motor shaft angle of (left, right), radians.
    angle: [f64; 2],
    /// Ticks already consumed by the odometry, per wheel.
    read: [i64; 2],
    /// Ticks per wheel revolution.
    ticks_per_rev: f64,
}

impl Encoders {
    /// Encoders of `ticks_per_rev` ticks per revolution, at angle 0.
    pub fn new(ticks_per_rev: f64) -> Encoders {
        Encoders { angle: [0.0; 2], read: [0; 2], ticks_per_rev }
    }

    /// The motors turned by (left, right) radians.
    pub fn turn(&mut self, d_left: f64, d_right: f64) {
        self.angle[0] += d_left;
        self.angle[1] += d_right;
    }

    /// The tick count of each wheel (the angle quantised towards −∞).
    pub fn ticks(&self) -> [i64; 2] {
        self.angle.map(|a| libm::floor(a * self.ticks_per_rev / TAU) as i64)
    }

    /// Ticks counted since the last call, per wheel.
    pub fn take_ticks(&mut self) -> [i64; 2] {
        let now = self.ticks();
        let d = [now[0] - self.read[0], now[1] - self.read[1]];
        self.read = now;
        d
    }
}

/// Dead reckoning from encoder ticks with the nominal geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Odometry {
    /// Metres of wheel travel per tick: 2π·r_nominal / ticks_per_rev.
    m_per_tick: f64,
    /// Nominal wheel base, metres.
    wheel_base_m: f64,
}

impl Odometry {
    /// Odometry for wheels of nominal radius `wheel_radius_m`, `ticks_per_rev` ticks
    /// per revolution, on a wheel base of `wheel_base_m`.
    pub fn new(wheel_radius_m: f64, ticks_per_rev: f64, wheel_base_m: f64) -> Odometry {
        Odometry { m_per_tick: TAU * wheel_radius_m / ticks_per_rev, wheel_base_m }
    }

    /// The body motion (distance along the heading Δs, metres; heading change Δθ,
    /// radians) of tick increments (left, right): Δs = (s_l + s_r)/2, Δθ = (s_r − s_l)/b.
    pub fn increment(&self, ticks: [i64; 2]) -> (f64, f64) {
        let sl = ticks[0] as f64 * self.m_per_tick;
        let sr = ticks[1] as f64 * self.m_per_tick;
        (0.5 * (sl + sr), (sr - sl) / self.wheel_base_m)
    }
}

/// Integrates a body increment into a pose with the midpoint heading (exact for arcs
/// to second order): x += Δs·cos(θ + Δθ/2), y += Δs·sin(θ + Δθ/2), θ += Δθ (unwrapped).
pub fn integrate(pose: (f64, f64, f64), ds: f64, dth: f64) -> (f64, f64, f64) {
    let (x, y, th) = pose;
    let m = th + 0.5 * dth;
    (x + ds * libm::cos(m), y + ds * libm::sin(m), th + dth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_quantise_towards_minus_infinity() {
        let mut e = Encoders::new(4096.0);
        e.turn(TAU / 4096.0 * 2.5, -TAU / 4096.0 * 0.5);
        assert_eq!(e.ticks(), [2, -1]);
        assert_eq!(e.take_ticks(), [2, -1]);
        e.turn(TAU / 4096.0 * 0.6, 0.0); // 3.1 ticks: one more
        assert_eq!(e.take_ticks(), [1, 0]);
        assert_eq!(e.take_ticks(), [0, 0]);
    }

    #[test]
    fn straight_drive_by_hand() {
        // Burger: r = 0.033 m, 4096 ticks; one full revolution of both wheels is
        // 2π·0.033 = 0.207345 m straight ahead.
        let o = Odometry::new(0.033, 4096.0, 0.160);
        let (ds, dth) = o.increment([4096, 4096]);
        assert!((ds - 0.207_345_115_1).abs() < 1e-9, "{ds}");
        assert_eq!(dth, 0.0);
        let p = integrate((1.0, 2.0, std::f64::consts::FRAC_PI_2), ds, dth);
        assert!((p.0 - 1.0).abs() < 1e-12 && (p.1 - 2.207_345_115_1).abs() < 1e-9);
    }

    #[test]
    fn turn_in_place_by_hand() {
        // Wheels in opposite directions by a quarter revolution: each travels
        // 2π·0.033/4 = 0.051836 m, Δθ = 2·0.051836/0.160 = 0.647953 rad, no translation.
        let o = Odometry::new(0.033, 4096.0, 0.160);
        let (ds, dth) = o.increment([-1024, 1024]);
        assert_eq!(ds, 0.0);
        assert!((dth - 0.647_953_484_7).abs() < 1e-9, "{dth}");
    }

    #[test]
    fn an_arc_integrates_close_to_the_circle() {
        // Quarter circle of radius 1 m in 1000 steps: ends at (1, 1) facing north.
        let n = 1000;
        let (ds, dth) = (std::f64::consts::FRAC_PI_2 / n as f64, std::f64::consts::FRAC_PI_2 / n as f64);
        let mut p = (0.0, 0.0, 0.0);
        for _ in 0..n {
            p = integrate(p, ds, dth);
        }
        assert!((p.0 - 1.0).abs() < 1e-6 && (p.1 - 1.0).abs() < 1e-6, "{p:?}");
        assert!((p.2 - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }

    #[test]
    fn encoder_resolution_bounds_the_error() {
        // Drive 0.5 m in 1/60 s steps at 0.22 m/s: the reckoned distance is within one
        // tick of the truth (ticks are read from the accumulated angle, never lost).
        let (r, n) = (0.033, 4096.0);
        let mut e = Encoders::new(n);
        let o = Odometry::new(r, n, 0.16);
        let mut s = 0.0;
        let step = 0.22 / 60.0;
        let mut travelled = 0.0;
        while travelled < 0.5 {
            e.turn(step / r, step / r);
            travelled += step;
            s += o.increment(e.take_ticks()).0;
        }
        assert!((s - travelled).abs() <= TAU * r / n, "{s} vs {travelled}");
    }
}
