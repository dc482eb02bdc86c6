//! Exact rationals for frame rates and time bases, so frame k's time is exactly `k / fps`.
//!
//! A frame rate given as `f64` becomes the rational with the smallest denominator that rounds to
//! the same `f64` (within 1e-12 relative): `30.0` → `30/1`, `29.97` → `2997/100`,
//! `30000.0 / 1001.0` → `30000/1001`. `ffmpeg` is then told the rational, never a decimal.

use std::fmt;

/// A positive or zero rational number `num / den` with `den > 0`, in lowest terms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rational {
    /// Numerator.
    pub num: i64,
    /// Denominator (> 0).
    pub den: i64,
}

impl Rational {
    /// `num / den` reduced to lowest terms; `None` when `den` is 0 or either side is negative.
    #[must_use]
    pub fn new(num: i64, den: i64) -> Option<Rational> {
        if den <= 0 || num < 0 {
            return None;
        }
        let g = gcd(num.unsigned_abs(), den.unsigned_abs());
        let g = i64::try_from(g).ok()?.max(1);
        Some(Rational {
            num: num / g,
            den: den / g,
        })
    }

    /// The smallest-denominator rational within 1e-12 (relative) of `value`; `None` for values
    /// that are not finite, not positive, or need a denominator above 1 000 000.
    #[must_use]
    pub fn from_f64(value: f64) -> Option<Rational> {
        if !value.is_finite() || value <= 0.0 || value > 1e9 {
            return None;
        }
        // Continued fraction convergents h/k.
        let (mut h0, mut h1) = (0_i64, 1_i64);
        let (mut k0, mut k1) = (1_i64, 0_i64);
        let mut x = value;
        for _ in 0..40 {
            let a = x.floor();
            #[expect(
                clippy::cast_possible_truncation,
                reason = "a <= value <= 1e9 fits an i64"
            )]
            let a_int = a as i64;
            let h2 = a_int.checked_mul(h1)?.checked_add(h0)?;
            let k2 = a_int.checked_mul(k1)?.checked_add(k0)?;
            if k2 > 1_000_000 {
                return None;
            }
            (h0, h1, k0, k1) = (h1, h2, k1, k2);
            #[expect(
                clippy::cast_precision_loss,
                reason = "h2 <= 1e15 and k2 <= 1e6 are exact in f64"
            )]
            let approx = h2 as f64 / k2 as f64;
            if (approx - value).abs() <= 1e-12 * value {
                return Rational::new(h2, k2);
            }
            let frac = x - a;
            if frac <= 0.0 {
                return Rational::new(h2, k2);
            }
            x = 1.0 / frac;
        }
        None
    }

    /// The value as `f64`.
    #[must_use]
    #[expect(
        clippy::cast_precision_loss,
        reason = "frame rates and time bases are small"
    )]
    pub fn as_f64(self) -> f64 {
        self.num as f64 / self.den as f64
    }

    /// Taking `self` as frames per second: the time of frame `frame` (frame 0 at 0), in
    /// nanoseconds, rounded to the nearest. Exact integer arithmetic, so stamps of a long video
    /// never drift from the encoded timestamps by more than half a nanosecond.
    #[must_use]
    pub fn frame_time_nanos(self, frame: u64) -> u64 {
        let num = u128::from(self.num.unsigned_abs()).max(1);
        let den = u128::from(self.den.unsigned_abs());
        let nanos = (u128::from(frame) * den * 1_000_000_000 * 2 + num) / (2 * num);
        u64::try_from(nanos).unwrap_or(u64::MAX)
    }

    /// Parses `ffmpeg`'s `num/den` (or a plain integer).
    #[must_use]
    pub fn parse(text: &str) -> Option<Rational> {
        let text = text.trim();
        match text.split_once('/') {
            Some((n, d)) => Rational::new(n.trim().parse().ok()?, d.trim().parse().ok()?),
            None => Rational::new(text.parse().ok()?, 1),
        }
    }
}

impl fmt::Display for Rational {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.num, self.den)
    }
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

#[cfg(test)]
mod tests {
    use super::Rational;

    #[test]
    fn frame_rates_become_the_rationals_people_mean() {
        let r = |v: f64| Rational::from_f64(v).unwrap();
        assert_eq!(r(30.0), Rational { num: 30, den: 1 });
        assert_eq!(
            r(29.97),
            Rational {
                num: 2997,
                den: 100
            }
        );
        assert_eq!(
            r(30000.0 / 1001.0),
            Rational {
                num: 30000,
                den: 1001
            }
        );
        assert_eq!(
            r(24000.0 / 1001.0),
            Rational {
                num: 24000,
                den: 1001
            }
        );
        assert_eq!(r(12.5), Rational { num: 25, den: 2 });
        assert_eq!(Rational::from_f64(0.0), None);
        assert_eq!(Rational::from_f64(f64::NAN), None);
        assert_eq!(Rational::from_f64(-30.0), None);
        assert_eq!(Rational::from_f64(30.000_000_1), None);
    }

    #[test]
    fn frame_times_are_exact_nanoseconds() {
        let ntsc = Rational::new(30000, 1001).unwrap();
        assert_eq!(ntsc.frame_time_nanos(0), 0);
        assert_eq!(ntsc.frame_time_nanos(1), 33_366_667);
        assert_eq!(ntsc.frame_time_nanos(30_000), 1_001_000_000_000);
        assert_eq!(
            Rational::new(30, 1).unwrap().frame_time_nanos(3),
            100_000_000
        );
    }

    #[test]
    fn parse_reads_ffprobe_rationals() {
        assert_eq!(Rational::parse("30000/1001"), Rational::new(30000, 1001));
        assert_eq!(Rational::parse("60/2"), Rational::new(30, 1));
        assert_eq!(Rational::parse("25"), Rational::new(25, 1));
        assert_eq!(Rational::parse("0/0"), None);
        assert_eq!(Rational::parse("x"), None);
    }
}
