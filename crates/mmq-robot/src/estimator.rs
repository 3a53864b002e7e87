//! The pose estimator: an extended Kalman filter on (x, y, θ) that predicts with the
//! odometry's body increments and corrects with absolute pose fixes.
//!
//! Predict with an increment (Δs, Δθ), θm = θ + Δθ/2:
//! μ ← (x + Δs·cos θm, y + Δs·sin θm, θ + Δθ),
//! P ← F·P·Fᵀ + V·diag(k_s²·|Δs|, k_θ²·|Δθ|)·Vᵀ, with
//! F = [[1, 0, −Δs·sin θm], [0, 1, Δs·cos θm], [0, 0, 1]] and
//! V = [[cos θm, −Δs/2·sin θm], [sin θm, Δs/2·cos θm], [0, 1]].
//!
//! Update with a fix z = (x, y, θ) of covariance R (the measurement is the pose, H = I):
//! ν = z − μ (heading wrapped to (−π, π]), S = P + R, K = P·S⁻¹, μ ← μ + K·ν,
//! P ← (I − K)·P (then symmetrised). The filter takes the fixes' noise as white with
//! variance white² + bias², though the localiser's bias is correlated in time.

use crate::controller::wrap;
use crate::odometry::integrate;

/// A 3×3 matrix, row-major.
pub type M3 = [[f64; 3]; 3];

fn mul(a: &M3, b: &M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    c
}

fn transpose(a: &M3) -> M3 {
    let mut t = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            t[i][j] = a[j][i];
        }
    }
    t
}

/// The inverse of a 3×3 matrix by cofactors; `None` when (nearly) singular.
pub fn inverse(a: &M3) -> Option<M3> {
    let c = |i: usize, j: usize| {
        let (r0, r1) = ((i + 1) % 3, (i + 2) % 3);
        let (c0, c1) = ((j + 1) % 3, (j + 2) % 3);
        a[r0][c0] * a[r1][c1] - a[r0][c1] * a[r1][c0]
    };
    let det = a[0][0] * c(0, 0) + a[0][1] * c(0, 1) + a[0][2] * c(0, 2);
    if !det.is_finite() || det.abs() <= 1e-300 {
        return None;
    }
    let mut inv = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            inv[j][i] = c(i, j) / det;
        }
    }
    Some(inv)
}

/// The filter's state: mean pose and covariance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ekf {
    /// Mean (x m, y m, θ rad; θ kept in (−π, π]).
    pub mean: (f64, f64, f64),
    /// Covariance (m², m·rad, rad²).
    pub cov: M3,
    /// Odometry distance noise density, m^½.
    pub k_s: f64,
    /// Odometry heading noise density, rad^½.
    pub k_th: f64,
}

impl Ekf {
    /// A filter at `pose` with covariance `cov`.
    pub fn new(pose: (f64, f64, f64), cov: M3, k_s: f64, k_th: f64) -> Ekf {
        Ekf { mean: (pose.0, pose.1, wrap(pose.2)), cov, k_s, k_th }
    }

    /// Restarts at a known pose with covariance `cov`.
    pub fn reset(&mut self, pose: (f64, f64, f64), cov: M3) {
        self.mean = (pose.0, pose.1, wrap(pose.2));
        self.cov = cov;
    }

    /// The prediction step with an odometry increment.
    pub fn predict(&mut self, ds: f64, dth: f64) {
        if ds == 0.0 && dth == 0.0 {
            return;
        }
        let th = self.mean.2;
        let m = th + 0.5 * dth;
        let (sn, cs) = (libm::sin(m), libm::cos(m));
        let p = integrate(self.mean, ds, dth);
        self.mean = (p.0, p.1, wrap(p.2));
        let f = [[1.0, 0.0, -ds * sn], [0.0, 1.0, ds * cs], [0.0, 0.0, 1.0]];
        let (qs, qt) = (self.k_s * self.k_s * ds.abs(), self.k_th * self.k_th * dth.abs());
        let v = [[cs, -0.5 * ds * sn], [sn, 0.5 * ds * cs], [0.0, 1.0]];
        let mut fp = mul(&mul(&f, &self.cov), &transpose(&f));
        for i in 0..3 {
            for j in 0..3 {
                fp[i][j] += v[i][0] * qs * v[j][0] + v[i][1] * qt * v[j][1];
            }
        }
        self.cov = fp;
    }

    /// The update step with a pose fix `z` of diagonal covariance `r` (x m², y m², θ
    /// rad²). Returns false (and changes nothing) if the innovation covariance is
    /// singular.
    pub fn update(&mut self, z: (f64, f64, f64), r: [f64; 3]) -> bool {
        let mut s = self.cov;
        for (i, ri) in r.iter().enumerate() {
            s[i][i] += ri;
        }
        let Some(si) = inverse(&s) else { return false };
        let k = mul(&self.cov, &si);
        let nu = [z.0 - self.mean.0, z.1 - self.mean.1, wrap(z.2 - self.mean.2)];
        let d: Vec<f64> = (0..3).map(|i| k[i][0] * nu[0] + k[i][1] * nu[1] + k[i][2] * nu[2]).collect();
        self.mean = (self.mean.0 + d[0], self.mean.1 + d[1], wrap(self.mean.2 + d[2]));
        let mut ikp = self.cov;
        for i in 0..3 {
            for j in 0..3 {
                ikp[i][j] -= k[i][0] * self.cov[0][j] + k[i][1] * self.cov[1][j] + k[i][2] * self.cov[2][j];
            }
        }
        for i in 0..3 {
            for j in 0..i {
                let m = 0.5 * (ikp[i][j] + ikp[j][i]);
                ikp[i][j] = m;
                ikp[j][i] = m;
            }
        }
        self.cov = ikp;
        true
    }
}

/// A diagonal covariance.
pub fn diag(d: [f64; 3]) -> M3 {
    [[d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_by_hand() {
        let a = [[2.0, 0.0, 1.0], [0.0, 4.0, 0.0], [1.0, 0.0, 1.0]];
        // det = 2·4·1 − 1·4·1 = 4; inverse = [[1, 0, −1], [0, 1/4, 0], [−1, 0, 2]].
        let inv = inverse(&a).unwrap();
        let want = [[1.0, 0.0, -1.0], [0.0, 0.25, 0.0], [-1.0, 0.0, 2.0]];
        for i in 0..3 {
            for j in 0..3 {
                assert!((inv[i][j] - want[i][j]).abs() < 1e-12, "{inv:?}");
            }
        }
        assert!(inverse(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }

    #[test]
    fn diagonal_fusion_by_hand() {
        // Prior (0, 0, 0) with P = diag(0.01, 0.04, 0.01); fix (0.1, −0.2, 0.3) with
        // R = diag(0.01, 0.01, 0.03). Gains p/(p+r) = 0.5, 0.8, 0.25:
        // mean (0.05, −0.16, 0.075), P = diag(0.005, 0.008, 0.0075).
        let mut f = Ekf::new((0.0, 0.0, 0.0), diag([0.01, 0.04, 0.01]), 0.0, 0.0);
        assert!(f.update((0.1, -0.2, 0.3), [0.01, 0.01, 0.03]));
        let (x, y, th) = f.mean;
        assert!(
            (x - 0.05).abs() < 1e-12 && (y + 0.16).abs() < 1e-12 && (th - 0.075).abs() < 1e-12,
            "{:?}",
            f.mean
        );
        assert!((f.cov[0][0] - 0.005).abs() < 1e-12);
        assert!((f.cov[1][1] - 0.008).abs() < 1e-12);
        assert!((f.cov[2][2] - 0.0075).abs() < 1e-12);
        assert_eq!(f.cov[0][1], 0.0);
    }

    #[test]
    fn correlated_fusion_by_hand() {
        // P with an x–θ correlation: a heading fix moves x too. P = [[0.02, 0, 0.01],
        // [0, 0.01, 0], [0.01, 0, 0.02]], R = diag(1e6, 1e6, 0.02) (position fix
        // useless): K's θ column ≈ P[:, 2] / (P22 + R22) = (0.25, 0, 0.5). A heading
        // innovation of 0.2 rad moves x by 0.05 and θ by 0.1.
        let p = [[0.02, 0.0, 0.01], [0.0, 0.01, 0.0], [0.01, 0.0, 0.02]];
        let mut f = Ekf::new((1.0, 1.0, 0.0), p, 0.0, 0.0);
        f.update((1.0, 1.0, 0.2), [1e6, 1e6, 0.02]);
        assert!((f.mean.0 - 1.05).abs() < 1e-6, "{:?}", f.mean);
        assert!((f.mean.1 - 1.0).abs() < 1e-12);
        assert!((f.mean.2 - 0.1).abs() < 1e-6);
        // P_xx = 0.02 − 0.01²/0.04 = 0.0175.
        assert!((f.cov[0][0] - 0.0175).abs() < 1e-6, "{:?}", f.cov);
    }

    #[test]
    fn heading_innovation_wraps() {
        // Estimate just below +π, fix just above −π: the short way round.
        let mut f = Ekf::new((0.0, 0.0, 3.1), diag([1.0, 1.0, 0.01]), 0.0, 0.0);
        f.update((0.0, 0.0, -3.1), [1.0, 1.0, 0.01]);
        // Innovation 2π − 6.2 = 0.0832; half of it: θ = 3.1 + 0.0416 = 3.1416 → wraps.
        let want = wrap(3.1 + 0.5 * (2.0 * std::f64::consts::PI - 6.2));
        assert!((f.mean.2 - want).abs() < 1e-12, "{}", f.mean.2);
    }

    #[test]
    fn predict_moves_the_mean_and_grows_the_covariance() {
        let mut f = Ekf::new((0.0, 0.0, 0.0), diag([0.0; 3]), 0.1, 0.2);
        f.predict(0.5, 0.0);
        assert_eq!(f.mean, (0.5, 0.0, 0.0));
        // Along-track variance k_s²·|Δs| = 0.01·0.5; no cross-track or heading growth.
        assert!((f.cov[0][0] - 0.005).abs() < 1e-15 && f.cov[1][1] == 0.0 && f.cov[2][2] == 0.0);
        f.predict(0.0, 1.0);
        assert!((f.cov[2][2] - 0.04).abs() < 1e-15);
        // Driving 1 m on at heading 1 rad with P_θθ = 0.04: P_yy = Δs²·cos²(1)·P_θθ
        // (heading uncertainty) + sin²(1)·k_s²·Δs (along-track noise).
        f.predict(1.0, 0.0);
        let want = 1f64.cos().powi(2) * 0.04 + 1f64.sin().powi(2) * 0.01;
        assert!((f.cov[1][1] - want).abs() < 1e-12, "{:?}", f.cov);
    }
}
