//! The differential drive: two virtual wheels at ±b/2 on the robot's lateral axis, whose
//! motors follow a commanded twist under speed and acceleration limits, and whose ground
//! contact pushes the body with impulses capped by friction.
//!
//! Per physics step, given the commanded twist (v, ω):
//! 1. Limits: |ω| ≤ ω_max, then |v| ≤ min(v_max, v_max − |ω|·b/2) so that no wheel
//!    surface speed exceeds v_max (turning has priority over driving).
//! 2. Motors slew towards it: |Δv| ≤ a_max·dt, |Δω| ≤ α_max·dt.
//! 3. Wheel surface speeds u_l = g_l·(v − ω·b/2), u_r = g_r·(v + ω·b/2) (gains g from the
//!    noise model, 1 without noise) give the body twist the wheels want:
//!    forward speed (u_l + u_r)/2, no lateral speed, turn rate (u_r − u_l)/b.
//! 4. The impulse that would reach it in one step, P = m·Δv (world frame) and
//!    L = I·Δω, is split between the wheels, J_r = P/2 + (L/b)·f̂, J_l = P/2 − (L/b)·f̂
//!    (f̂ the heading; lateral grip is the lateral part of P), and each wheel's impulse is
//!    capped to its friction circle |J| ≤ μ·(m·g/2)·dt. Walls push back through rapier's
//!    contact solver; when they do, the wheels slip at the cap (the robot skids).

use rapier2d::prelude::{Real, Vector};

use crate::config::RobotConfig;

/// Standard gravity for the wheels' normal load (the simulation itself has no gravity),
/// m/s².
pub const G: f64 = 9.81;

/// Motor state and actuation parameters of one robot.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Drive {
    /// Wheel base b, metres.
    b: f64,
    v_max: f64,
    w_max: f64,
    a_max: f64,
    alpha_max: f64,
    mass: f64,
    inertia: f64,
    /// Friction cap per wheel per step without noise, N·s.
    cap: f64,
    dt: f64,
    /// Motor linear speed, m/s.
    pub v: f64,
    /// Motor turn rate, rad/s.
    pub w: f64,
    /// Wheel gains (left, right) for the current primitive.
    pub gain: [f64; 2],
    /// Friction multiplier for the current primitive (1 on a normal floor).
    pub traction: f64,
}

/// The body's state as the drive sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct BodyState {
    /// Heading, radians.
    pub theta: f64,
    /// Linear velocity, m/s (world frame).
    pub vx: f64,
    pub vy: f64,
    /// Turn rate, rad/s.
    pub w: f64,
}

impl Drive {
    pub fn new(cfg: &RobotConfig) -> Drive {
        Drive {
            b: cfg.wheel_base_m,
            v_max: cfg.max_speed_mps,
            w_max: cfg.max_turn_rate_radps,
            a_max: cfg.max_accel_mps2,
            alpha_max: cfg.max_angular_accel_radps2,
            mass: cfg.mass_kg,
            inertia: 0.5 * cfg.mass_kg * cfg.radius_m * cfg.radius_m,
            cap: cfg.wheel_friction * cfg.mass_kg * G / 2.0 * cfg.dt_s,
            dt: cfg.dt_s,
            v: 0.0,
            w: 0.0,
            gain: [1.0, 1.0],
            traction: 1.0,
        }
    }

    /// Stops the motors.
    pub fn stop(&mut self) {
        self.v = 0.0;
        self.w = 0.0;
    }

    /// Steps 1–2: limits, then slews the motors towards the commanded twist.
    pub fn command(&mut self, v_cmd: f64, w_cmd: f64) {
        let w = w_cmd.clamp(-self.w_max, self.w_max);
        let v_lim = (self.v_max - w.abs() * self.b / 2.0).max(0.0);
        let v = v_cmd.clamp(-v_lim, v_lim);
        let dv = self.a_max * self.dt;
        let dw = self.alpha_max * self.dt;
        self.v += (v - self.v).clamp(-dv, dv);
        self.w += (w - self.w).clamp(-dw, dw);
    }

    /// Steps 3–4: the linear impulse (world frame, N·s) and the angular impulse (N·m·s)
    /// the wheels apply to the body during this step.
    pub fn impulses(&self, s: &BodyState) -> (Vector, Real) {
        let half_b = self.b / 2.0;
        let ul = self.gain[0] * (self.v - self.w * half_b);
        let ur = self.gain[1] * (self.v + self.w * half_b);
        let v_want = 0.5 * (ul + ur);
        let w_want = (ur - ul) / self.b;
        let (sn, cs) = (libm::sin(s.theta), libm::cos(s.theta));
        // Needed total impulse.
        let px = self.mass * (v_want * cs - s.vx);
        let py = self.mass * (v_want * sn - s.vy);
        let l = self.inertia * (w_want - s.w);
        let (tx, ty) = (l / self.b * cs, l / self.b * sn);
        let cap = self.cap * self.traction;
        let clip = |x: f64, y: f64| {
            let n = libm::sqrt(x * x + y * y);
            if n > cap { (x * cap / n, y * cap / n) } else { (x, y) }
        };
        let (rx, ry) = clip(px / 2.0 + tx, py / 2.0 + ty);
        let (lx, ly) = clip(px / 2.0 - tx, py / 2.0 - ty);
        // Torque of the wheel impulses about the centre: (b/2)·f̂·(J_r − J_l).
        let torque = half_b * ((rx - lx) * cs + (ry - ly) * sn);
        (Vector::new((rx + lx) as Real, (ry + ly) as Real), torque as Real)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_and_slew() {
        let mut d = Drive::new(&RobotConfig::default());
        d.command(1.0, 0.0);
        assert!((d.v - 2.5 / 60.0).abs() < 1e-12);
        for _ in 0..100 {
            d.command(1.0, 0.0);
        }
        assert_eq!(d.v, 0.22);
        // Turning first: at full turn rate no wheel may exceed v_max.
        for _ in 0..200 {
            d.command(1.0, 10.0);
        }
        assert_eq!(d.w, 2.84);
        assert!((d.v - (0.22 - 2.84 * 0.08)).abs() < 1e-9 || d.v == 0.0);
    }

    #[test]
    fn impulse_reaches_the_wheel_twist_when_grip_suffices() {
        let mut d = Drive::new(&RobotConfig::default());
        d.v = 0.05;
        d.w = 0.5;
        let s = BodyState { theta: 0.3, vx: 0.0, vy: 0.0, w: 0.0 };
        let (p, l) = d.impulses(&s);
        let vx = p.x as f64 / d.mass;
        let vy = p.y as f64 / d.mass;
        assert!((vx - 0.05 * 0.3f64.cos()).abs() < 1e-6 && (vy - 0.05 * 0.3f64.sin()).abs() < 1e-6);
        assert!((l as f64 / d.inertia - 0.5).abs() < 1e-5);
        // Against a stuck body at full speed the cap binds.
        d.v = 10.0;
        d.w = 0.0;
        let (p, _) = d.impulses(&s);
        assert!((p.length() as f64 - 2.0 * d.cap).abs() < 1e-6);
    }
}
