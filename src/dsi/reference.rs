//! The GTAutoAct reference code's interpolation, reproduced to measure against — never used to
//! make animations.
//!
//! What the published code runs (`../shared/reference/gtautoact-reference-code.md` §3): every
//! quaternion component of every bone is interpolated on its own by a monotone piecewise-cubic
//! Hermite (scipy's `PchipInterpolator`), then smoothed on its own by the SuperSmoother with
//! Friedman's fractional spans, with no sign alignment and no renormalisation. Its quaternions
//! come from scipy's Euler conversion, which puts them in the `w ≥ 0` hemisphere
//! ([`canonical`]). The published driver evaluates at `linspace(0, F, 6F)`, past the last key
//! ([`published_sample_times`]).

use nalgebra::{Quaternion, UnitQuaternion};

use super::supersmoother::SuperSmoother;

/// A monotone piecewise-cubic Hermite interpolant with scipy's `PchipInterpolator` rules
/// (Fritsch–Butland): interior slopes are the weighted harmonic mean of the neighbouring secants
/// when they agree in sign (else 0); end slopes come from the one-sided three-point formula,
/// set to 0 when its sign differs from the first secant's and limited to 3× that secant when the
/// secants change sign. Evaluation outside the knots extrapolates the end cubics, as scipy does by
/// default.
#[derive(Debug, Clone, PartialEq)]
pub struct Pchip {
    x: Vec<f64>,
    y: Vec<f64>,
    slopes: Vec<f64>,
}

impl Pchip {
    /// The interpolant through `(x[i], y[i])`; `x` strictly increasing, at least two points (one
    /// point gives a constant).
    #[must_use]
    pub fn new(x: &[f64], y: &[f64]) -> Pchip {
        let n = x.len().min(y.len());
        let (x, y) = (x[..n].to_vec(), y[..n].to_vec());
        if n < 2 {
            return Pchip {
                slopes: vec![0.0; n],
                x,
                y,
            };
        }
        let h: Vec<f64> = x.windows(2).map(|w| w[1] - w[0]).collect();
        let m: Vec<f64> = (0..n - 1).map(|k| (y[k + 1] - y[k]) / h[k]).collect();
        if n == 2 {
            return Pchip {
                slopes: vec![m[0]; 2],
                x,
                y,
            };
        }
        let mut d = vec![0.0; n];
        for k in 1..n - 1 {
            let (m0, m1) = (m[k - 1], m[k]);
            if m0 == 0.0 || m1 == 0.0 || m0.signum() != m1.signum() {
                d[k] = 0.0;
            } else {
                let w1 = 2.0 * h[k] + h[k - 1];
                let w2 = h[k] + 2.0 * h[k - 1];
                d[k] = (w1 + w2) / (w1 / m0 + w2 / m1);
            }
        }
        let edge = |h0: f64, h1: f64, m0: f64, m1: f64| {
            let d = ((2.0 * h0 + h1) * m0 - h0 * m1) / (h0 + h1);
            if d.signum() != m0.signum() || d == 0.0 || m0 == 0.0 {
                0.0
            } else if m0.signum() != m1.signum() && d.abs() > 3.0 * m0.abs() {
                3.0 * m0
            } else {
                d
            }
        };
        d[0] = edge(h[0], h[1], m[0], m[1]);
        d[n - 1] = edge(h[n - 2], h[n - 3], m[n - 2], m[n - 3]);
        Pchip { x, y, slopes: d }
    }

    /// The interpolant's value at `t`.
    #[must_use]
    pub fn at(&self, t: f64) -> f64 {
        let n = self.x.len();
        if n < 2 {
            return self.y.first().copied().unwrap_or(f64::NAN);
        }
        // The interval whose cubic applies (the end ones beyond the knots).
        let k = self.x.partition_point(|&xk| xk <= t).clamp(1, n - 1) - 1;
        let h = self.x[k + 1] - self.x[k];
        let s = (t - self.x[k]) / h;
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = s3 - 2.0 * s2 + s;
        let h01 = -2.0 * s3 + 3.0 * s2;
        let h11 = s3 - s2;
        h00 * self.y[k]
            + h10 * h * self.slopes[k]
            + h01 * self.y[k + 1]
            + h11 * h * self.slopes[k + 1]
    }
}

/// `q` in the `w ≥ 0` hemisphere, as scipy's Euler → quaternion conversion returns it.
#[must_use]
pub fn canonical(q: &UnitQuaternion<f64>) -> Quaternion<f64> {
    if q.w < 0.0 {
        -q.into_inner()
    } else {
        q.into_inner()
    }
}

/// The sample times of the published driver for `keys` key frames, in key units:
/// `linspace(0, F, 6F)` (past the last key at `F − 1`).
#[must_use]
pub fn published_sample_times(keys: usize) -> Vec<f64> {
    let n = 6 * keys;
    #[expect(
        clippy::cast_precision_loss,
        reason = "frame counts are far below 2^52"
    )]
    let (last, step) = (keys as f64, keys as f64 / (n.max(2) - 1) as f64);
    (0..n)
        .map(|i| {
            #[expect(
                clippy::cast_precision_loss,
                reason = "frame counts are far below 2^52"
            )]
            let t = i as f64 * step;
            if i + 1 == n { last } else { t }
        })
        .collect()
}

/// One bone's track through the reference method: per-component PCHIP of `track` (taken as
/// given, signs and all) at `key_times`, evaluated at `times`, then — when `smooth` — per
/// component SuperSmoother with Friedman's defaults. The result is not normalised, exactly as
/// the reference leaves it.
#[must_use]
pub fn interpolate_track(
    track: &[Quaternion<f64>],
    key_times: &[f64],
    times: &[f64],
    smooth: bool,
) -> Vec<Quaternion<f64>> {
    let mut components: [Vec<f64>; 4] = std::array::from_fn(|c| {
        let y: Vec<f64> = track.iter().map(|q| q.coords[c]).collect();
        let p = Pchip::new(key_times, &y);
        times.iter().map(|&t| p.at(t)).collect()
    });
    if smooth {
        let smoother = SuperSmoother::default();
        for c in &mut components {
            *c = smoother.smooth(c);
        }
    }
    (0..times.len())
        .map(|i| {
            Quaternion::from(nalgebra::Vector4::new(
                components[0][i],
                components[1][i],
                components[2][i],
                components[3][i],
            ))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pchip_matches_scipy_on_small_cases() {
        // Values printed by scipy 1.17.1's PchipInterpolator for the same knots.
        type Case<'a> = (&'a [f64], &'a [f64], &'a [f64], &'a [f64]);
        let cases: [Case<'_>; 2] = [
            (
                &[0.0, 1.0, 2.0, 4.0],
                &[0.0, 1.0, 0.5, 3.0],
                &[0.5, 1.5, 3.0, 5.0],
                &[0.71875, 0.75, 1.145_833_333_333_333_5, 5.9375],
            ),
            (
                &[0.0, 1.0, 1.5, 3.0, 4.0, 6.0],
                &[0.0, 0.1, 2.0, 2.1, 5.0, 5.0],
                &[0.2, 1.2, 2.5, 5.5, 7.0],
                &[
                    0.003_429_299_363_057_325_8,
                    0.776_988_186_022_161_7,
                    2.060_492_338_914_257,
                    5.0,
                    5.0,
                ],
            ),
        ];
        for (x, y, at, want) in cases {
            let p = Pchip::new(x, y);
            for (t, w) in at.iter().zip(want) {
                assert!((p.at(*t) - w).abs() < 1e-12, "at {t}: {} vs {w}", p.at(*t));
            }
        }
    }

    #[test]
    fn pchip_is_monotone_and_hits_its_knots() {
        let x = [0.0, 1.0, 1.5, 3.0, 4.0, 6.0];
        let y = [0.0, 0.1, 2.0, 2.1, 5.0, 5.0];
        let p = Pchip::new(&x, &y);
        for (xi, yi) in x.iter().zip(y) {
            assert!((p.at(*xi) - yi).abs() < 1e-12);
        }
        let mut last = p.at(0.0);
        for i in 1..=600 {
            let v = p.at(f64::from(i) * 0.01);
            assert!(v >= last - 1e-12, "not monotone at {i}");
            last = v;
        }
    }

    #[test]
    fn the_published_times_overrun_the_last_key() {
        let t = published_sample_times(5);
        assert_eq!(t.len(), 30);
        assert_eq!(t[0], 0.0);
        assert_eq!(t[29], 5.0);
        assert!((t[1] - 5.0 / 29.0).abs() < 1e-15);
    }

    #[test]
    fn per_component_interpolation_across_a_sign_flip_leaves_the_unit_sphere() {
        // Yaw +179° and −179° in the w ≥ 0 hemisphere: nearly the same rotation, opposite z.
        let a = canonical(&UnitQuaternion::from_axis_angle(
            &nalgebra::Vector3::z_axis(),
            179f64.to_radians(),
        ));
        let b = canonical(&UnitQuaternion::from_axis_angle(
            &nalgebra::Vector3::z_axis(),
            -179f64.to_radians(),
        ));
        let out = interpolate_track(&[a, b], &[0.0, 1.0], &[0.5], false);
        assert!(
            out[0].norm() < 0.05,
            "the midpoint collapses: |q| = {}",
            out[0].norm()
        );
    }
}
