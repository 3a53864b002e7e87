//! The motion controllers of the primitives: turn in place to a heading, and drive to a
//! point (forwards or backwards, whichever faces it). Both command a twist (v, ω) that
//! the drive then limits and slews; both brake along a profile that stops at the target
//! under a fraction of the acceleration limit.

use std::f64::consts::PI;

/// Fraction of the acceleration limits the braking profiles plan with (margin for the
/// one-step lag of the motors).
pub const BRAKE_MARGIN: f64 = 0.8;
/// Turn-rate gain near the target heading, 1/s.
pub const K_TURN: f64 = 8.0;
/// Speed gain near the target point, 1/s.
pub const K_DRIVE: f64 = 6.0;
/// Heading gain while driving, 1/s.
pub const K_HEADING: f64 = 4.0;
/// Within this distance of the target the drive stops steering, metres.
pub const STEER_DEADBAND_M: f64 = 0.03;

/// Wraps an angle to (−π, π].
pub fn wrap(a: f64) -> f64 {
    let mut a = libm::remainder(a, 2.0 * PI);
    if a <= -PI {
        a += 2.0 * PI;
    }
    a
}

/// The controller's limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// m/s.
    pub v_max: f64,
    /// rad/s.
    pub w_max: f64,
    /// m/s².
    pub a_max: f64,
    /// rad/s².
    pub alpha_max: f64,
}

/// Speed that still stops within `d` under deceleration `a`, also bounded by `k·d` and
/// `limit`.
fn brake_profile(d: f64, a: f64, k: f64, limit: f64) -> f64 {
    libm::sqrt(2.0 * BRAKE_MARGIN * a * d).min(k * d).min(limit)
}

/// Turn in place: the twist towards heading error `err` (target − current, wrapped).
pub fn turn(err: f64, lim: &Limits) -> (f64, f64) {
    let w = brake_profile(err.abs(), lim.alpha_max, K_TURN, lim.w_max);
    (0.0, w.copysign(err))
}

/// Drive to `(tx, ty)` from pose `(x, y, theta)`: the twist, and the distance left.
pub fn drive_to(x: f64, y: f64, theta: f64, tx: f64, ty: f64, lim: &Limits) -> (f64, f64, f64) {
    let (dx, dy) = (tx - x, ty - y);
    let dist = libm::sqrt(dx * dx + dy * dy);
    let (sn, cs) = (libm::sin(theta), libm::cos(theta));
    let along = dx * cs + dy * sn;
    let dir = if along >= 0.0 { 1.0 } else { -1.0 };
    let mut err = 0.0;
    if dist > STEER_DEADBAND_M {
        let bearing = libm::atan2(dy, dx);
        err = wrap(if dir > 0.0 { bearing } else { bearing + PI } - theta);
    }
    let speed = brake_profile(along.abs(), lim.a_max, K_DRIVE, lim.v_max) * libm::cos(err).max(0.0);
    let w = (K_HEADING * err).clamp(-lim.w_max, lim.w_max);
    (dir * speed, w, dist)
}

#[cfg(test)]
mod tests {
    use super::*;

    const L: Limits = Limits { v_max: 0.22, w_max: 2.84, a_max: 2.5, alpha_max: 3.2 };

    #[test]
    fn wraps() {
        assert_eq!(wrap(PI), PI);
        assert_eq!(wrap(-PI), PI);
        assert!((wrap(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
        assert!((wrap(-0.1) + 0.1).abs() < 1e-15);
    }

    #[test]
    fn drives_backwards_to_a_point_behind() {
        let (v, w, d) = drive_to(0.0, 0.0, 0.0, -0.2, 0.0, &L);
        assert!(v < 0.0 && w.abs() < 1e-12 && (d - 0.2).abs() < 1e-12);
        let (v, _, _) = drive_to(0.0, 0.0, PI / 2.0, 0.0, 0.5, &L);
        assert_eq!(v, 0.22);
    }

    #[test]
    fn turns_the_short_way() {
        assert!(turn(0.5, &L).1 > 0.0);
        assert!(turn(-0.5, &L).1 < 0.0);
        assert_eq!(turn(0.0, &L).1, 0.0);
    }
}
