//! Friedman's SuperSmoother (J. H. Friedman, "A Variable Span Smoother", SLAC-PUB-3477, 1984):
//! a local-linear smoother whose span adapts along the series, chosen at every sample by
//! cross-validation among three primary spans. DSI smooths joint-angle curves with it, as the
//! GTAutoAct paper's code did through the PyPI `supersmoother` 0.4 package (J. VanderPlas).
//!
//! The behaviour is that package's, for uniformly spaced samples with unit weights, called as
//! `SuperSmoother().fit(t, y).predict(t)`; `tools/check_supersmoother.py` runs both on synthetic
//! and real motion-capture curves and demands agreement to 1e-6 of the curve's magnitude. With
//! primary spans `p1 < p2 < p3`, middle span `m` and final span `f` (fractions of the length):
//!
//! 1. `c_j` = cross-validated linear smooth of `y` with span `p_j` (each sample left out of its
//!    own fit); residuals `r_j = |c_j − y|`.
//! 2. `e_j` = linear smooth of `r_j` with span `m`.
//! 3. The best span at each sample is the `p_j` of the least `e_j`, the first on ties (within
//!    1e-9 of the mean residual, as the package ties windows of equal content); with bass
//!    enhancement `α` it is moved towards `p3` by the factor `(min_j e_j / e_3)^(10 − α)`.
//! 4. The best spans are smoothed with span `m` and clamped into `[p1, p3]`.
//! 5. The output before the last pass interpolates linearly, in span, between the `c_j`.
//! 6. The output is that curve's linear smooth with span `f`.
//!
//! Two departures from Friedman's paper are the package's and are kept: step 5 interpolates
//! between the *cross-validated* curves `c_j` (Friedman uses the plain smooths), and the window
//! of a span `s` over `n` samples is `k = max(3, s·n)` truncated samples, `[i − k/2, i − k/2 + k)`
//! clipped to the series (no reflection at the ends).
//!
//! Where the package fails this module still answers:
//! - a window left with one sample (after the cross-validation exclusion; the package raises
//!   "Zero denominator in linear smooth", which happens below about 100 samples) gives that
//!   sample's value, a local constant; so every length works, `n = 1` returns the value and
//!   `n = 0` nothing;
//! - the bass factor is taken as the package computes it wherever that is finite (even when a
//!   smoothed residual is negative, which a local-linear smooth of non-negative data can give
//!   at the ends). Where the package's factor is not finite (NaN or infinite: `e_3 ≤ 0` with
//!   `min e_j / e_3` undefined or infinite, or a negative ratio to a fractional power) the
//!   factor is 1 when `e_3 ≤ 0` (nothing beats the woofer: take it) and otherwise the ratio
//!   clamped into `[0, 1]` to the power.
//!
//! The bass factor is unbounded (the package's smoothed residuals dip below zero at the ends of
//! many real curves, and `e_3` near zero makes the ratio huge), so chosen spans far outside
//! `[p1, p3]` are normal there; they are smoothed apart from the rest (see step 3 in the code)
//! to keep their rounding out of the distant windows, which the package's direct window sums
//! never see.
//!
//! Cost: O(n) per series whatever the spans. Each local line fit is evaluated from prefix sums
//! of `y` and `j·y` in coordinates local to the evaluated sample (`u = j − i`), so the window
//! geometry — counts, `Σu`, `Σu²` and the fit's denominator, exact in integers — depends on the
//! length alone and is computed once per length by [`SuperSmoother::plan`]. The data are
//! shifted by their middle sample and the index centred on the series before summing, so the
//! prefix sums carry the curve's variation, not its level. Rounding still accumulates along
//! the sums: against the exact fit, a ±2 curve on a level of 1000 is off by 1e-14 mid-series
//! and at most 5e-11 at the ends for 10⁶ samples (2e-12 for 10⁴); the package check sees
//! ≤ 3e-11 of the curve's magnitude. Likewise one sample of magnitude M adds rounding of order
//! 1e-16·M to every later window, and a non-finite sample makes the output non-finite from
//! its first window on, without panicking.

use thiserror::Error;

/// Friedman's variable-span smoother.
///
/// Spans are fractions of the series length. [`SuperSmoother::default`] is Friedman's (and the
/// package's) choice: primary spans 0.05, 0.2 and 0.5 (tweeter, midrange, woofer), middle and
/// final spans 0.2 and 0.05, no bass enhancement.
///
/// ```
/// use autoact::dsi::supersmoother::{SmoothScratch, SuperSmoother};
/// let smoother = SuperSmoother::default();
/// smoother.validate()?;
/// // Many channels of one length: one plan, one scratch, no allocation per channel.
/// let plan = smoother.plan(300);
/// let mut scratch = SmoothScratch::default();
/// let channel: Vec<f64> = (0..300).map(|i| (f64::from(i) / 20.0).sin()).collect();
/// let mut smoothed = vec![0.0; 300];
/// plan.smooth_into(&channel, &mut smoothed, &mut scratch);
/// assert!((smoothed[150] - channel[150]).abs() < 0.05);
/// # Ok::<(), autoact::dsi::supersmoother::SmootherError>(())
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SuperSmoother {
    /// Tweeter, midrange and woofer spans: strictly ascending, each in (0, 1].
    pub primary_spans: [f64; 3],
    /// Span smoothing the cross-validation residuals and the chosen spans, in (0, 1].
    pub middle_span: f64,
    /// Span of the last smooth of the span-interpolated curve, in (0, 1].
    pub final_span: f64,
    /// Bass enhancement α in [0, 10], or `None` for none: the larger, the more the woofer
    /// (the smoothest span) is favoured; 10 always takes it.
    pub bass: Option<f64>,
}

impl Default for SuperSmoother {
    fn default() -> Self {
        SuperSmoother {
            primary_spans: [0.05, 0.2, 0.5],
            middle_span: 0.2,
            final_span: 0.05,
            bass: None,
        }
    }
}

/// A [`SuperSmoother`] setting out of its domain.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum SmootherError {
    /// A primary span is not finite or not in (0, 1].
    #[error("primary span #{index} is {value}; spans must be finite and in (0, 1]")]
    PrimarySpan {
        /// Position in `primary_spans` (0, 1 or 2).
        index: usize,
        /// The offending span.
        value: f64,
    },
    /// The primary spans are not strictly ascending.
    #[error("primary spans {spans:?} are not strictly ascending (tweeter < midrange < woofer)")]
    PrimaryOrder {
        /// The offending spans.
        spans: [f64; 3],
    },
    /// The middle span is not finite or not in (0, 1].
    #[error("middle span is {0}; it must be finite and in (0, 1]")]
    MiddleSpan(f64),
    /// The final span is not finite or not in (0, 1].
    #[error("final span is {0}; it must be finite and in (0, 1]")]
    FinalSpan(f64),
    /// The bass enhancement is not finite or not in [0, 10].
    #[error("bass is {0}; it must be finite and in [0, 10]")]
    Bass(f64),
}

fn span_ok(span: f64) -> bool {
    span.is_finite() && span > 0.0 && span <= 1.0
}

impl SuperSmoother {
    /// Checks every span and the bass against their domains.
    ///
    /// # Errors
    /// The first setting out of its domain, naming its value.
    pub fn validate(&self) -> Result<(), SmootherError> {
        for (index, &value) in self.primary_spans.iter().enumerate() {
            if !span_ok(value) {
                return Err(SmootherError::PrimarySpan { index, value });
            }
        }
        let [p1, p2, p3] = self.primary_spans;
        if !(p1 < p2 && p2 < p3) {
            return Err(SmootherError::PrimaryOrder {
                spans: self.primary_spans,
            });
        }
        if !span_ok(self.middle_span) {
            return Err(SmootherError::MiddleSpan(self.middle_span));
        }
        if !span_ok(self.final_span) {
            return Err(SmootherError::FinalSpan(self.final_span));
        }
        if let Some(bass) = self.bass
            && !(bass.is_finite() && (0.0..=10.0).contains(&bass))
        {
            return Err(SmootherError::Bass(bass));
        }
        Ok(())
    }

    /// Precomputes everything that depends only on the series length `n`: the window geometry
    /// and line-fit coefficients of every span. Reuse the plan for every series of that length.
    ///
    /// Call [`SuperSmoother::validate`] first: an invalid setting does not panic here or in
    /// smoothing, but its output is unspecified.
    #[must_use]
    pub fn plan(&self, n: usize) -> SmoothPlan {
        let [p1, p2, p3] = self.primary_spans;
        let half = n / 2;
        SmoothPlan {
            n,
            spans: self.primary_spans,
            interpolation_slopes: [1.0 / (p2 - p1), 1.0 / (p3 - p2)],
            bass_exponent: self.bass.map(BassExponent::new),
            primary: self
                .primary_spans
                .map(|span| LinearSmooth::new(span, n, true)),
            middle: LinearSmooth::new(self.middle_span, n, false),
            last: LinearSmooth::new(self.final_span, n, false),
            #[expect(
                clippy::cast_precision_loss,
                reason = "sample indices are far below 2^52: exact in f64"
            )]
            centred_index: (0..n).map(|i| i as f64 - half as f64).collect(),
        }
    }

    /// Smooths one series (a plan and scratch made for it; use [`SmoothPlan::smooth_into`] to
    /// smooth many series of one length without allocating).
    #[must_use]
    pub fn smooth(&self, y: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; y.len()];
        self.plan(y.len())
            .smooth_into(y, &mut out, &mut SmoothScratch::default());
        out
    }
}

/// Window length, in samples, of span fraction `span` over `n` samples, as the package computes
/// it: `span·n` clipped to at least 3, then truncated. Capped at `2n + 2`, from which every window
/// is the whole series anyway (reached only by invalid spans above 2).
fn window_len(span: f64, n: usize) -> usize {
    #[expect(
        clippy::cast_precision_loss,
        reason = "series lengths are far below 2^52: exact in f64"
    )]
    let k = (span * n as f64).max(3.0).floor();
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "k ≥ 3 and whole; `as` saturates a huge (invalid-span) value, capped next"
    )]
    let k = k as usize;
    k.min(2 * n + 2)
}

/// Weights of one local line fit: the fitted value at the evaluated sample `i` is
/// `sum·Σ y_j + moment·Σ (j − i)·y_j` over its window.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Coef {
    sum: f64,
    moment: f64,
}

impl Coef {
    /// The least-squares line through the samples `a..b` (less `i` itself when `cv`), evaluated
    /// at `i`, with `a ≤ i < b`. A single sample gives its value; no sample gives 0.
    fn new(i: usize, a: usize, b: usize, cv: bool) -> Coef {
        let wide = |x: usize| i128::try_from(x).unwrap_or(i128::MAX);
        let (i, a, b) = (wide(i), wide(a), wide(b));
        // u = j − i runs over first..=last; leaving u = 0 out changes only the count.
        let (first, last) = (a - i, b - 1 - i);
        let m = b - a;
        let twice_centre = first + last;
        let count = if cv { m - 1 } else { m };
        let twice_su = m * twice_centre;
        // Σu² = Σ(u − centre)² + m·centre² = m(m² − 1)/12 + m·centre², times 12.
        let twelve_suu = m * (m * m - 1) + 3 * m * twice_centre * twice_centre;
        // 12·(count·Σu² − (Σu)²): the normal equations' determinant, exact.
        let twelve_det = count * twelve_suu - 3 * twice_su * twice_su;
        if twelve_det == 0 {
            // Fewer than two distinct samples: a local constant (the package divides by zero).
            return Coef {
                sum: if count == 1 { 1.0 } else { 0.0 },
                moment: 0.0,
            };
        }
        #[expect(
            clippy::cast_precision_loss,
            reason = "exact integers rounded once to f64: the weights are accurate to 1 ulp"
        )]
        let (twelve_suu, twice_su, twelve_det) =
            (twelve_suu as f64, twice_su as f64, twelve_det as f64);
        // Intercept of the fit in u: (Σu²·Σy − Σu·Σuy) / det.
        Coef {
            sum: twelve_suu / twelve_det,
            moment: -6.0 * twice_su / twelve_det,
        }
    }
}

/// One linear smooth (a span, with or without cross-validation) over one series length.
#[derive(Debug, Clone, PartialEq)]
struct LinearSmooth {
    /// Window length `k`: sample `i`'s window is `[i − half, i − half + k)` within the series.
    len: usize,
    /// `k / 2`.
    half: usize,
    /// Leave each sample out of its own fit.
    cv: bool,
    /// Samples whose window lies wholly inside the series, where the weights are `interior`.
    interior_start: usize,
    interior_end: usize,
    interior: Coef,
    /// Weights of the samples before `interior_start`, then of those from `interior_end` on.
    edges: Vec<Coef>,
}

impl LinearSmooth {
    fn new(span: f64, n: usize, cv: bool) -> LinearSmooth {
        let len = window_len(span, n);
        let half = len / 2;
        let interior_start = half.min(n);
        // i + len − half ≤ n  ⇔  i < n + half + 1 − len.
        let interior_end = (n + half + 1)
            .saturating_sub(len)
            .min(n)
            .max(interior_start);
        let mut smooth = LinearSmooth {
            len,
            half,
            cv,
            interior_start,
            interior_end,
            interior: Coef::default(),
            edges: Vec::new(),
        };
        if interior_start < interior_end {
            let (a, b) = smooth.window(interior_start, n);
            smooth.interior = Coef::new(interior_start, a, b, cv);
        }
        smooth.edges = (0..interior_start)
            .chain(interior_end..n)
            .map(|i| {
                let (a, b) = smooth.window(i, n);
                Coef::new(i, a, b, cv)
            })
            .collect();
        smooth
    }

    /// Sample `i`'s window `a..b`.
    #[inline]
    fn window(&self, i: usize, n: usize) -> (usize, usize) {
        (
            i.saturating_sub(self.half),
            (i + self.len - self.half).min(n),
        )
    }

    /// Evaluates the smooth of the series whose prefix sums are `sums` (`Σ_{j<J} v_j`) and
    /// `moments` (`Σ_{j<J} x_j·v_j`, with `x` = `centred`), both of length n + 1; `own` is the
    /// series itself (read only with cross-validation). Writes `fit + add` into `out`.
    fn apply(
        &self,
        sums: &[f64],
        moments: &[f64],
        own: &[f64],
        centred: &[f64],
        add: f64,
        out: &mut [f64],
    ) {
        if self.cv {
            self.apply_impl::<true>(sums, moments, own, centred, add, out);
        } else {
            self.apply_impl::<false>(sums, moments, own, centred, add, out);
        }
    }

    #[inline]
    fn apply_impl<const CV: bool>(
        &self,
        sums: &[f64],
        moments: &[f64],
        own: &[f64],
        centred: &[f64],
        add: f64,
        out: &mut [f64],
    ) {
        let n = out.len();
        let fit = |coef: Coef, a: usize, b: usize, own_i: f64, x_i: f64| {
            let sy = sums[b] - sums[a];
            // Σ(j − i)·v_j = Σ x_j·v_j − x_i·Σ v_j: the evaluated sample's own term is zero.
            let suy = (moments[b] - moments[a]) - x_i * sy;
            let sy = if CV { sy - own_i } else { sy };
            coef.sum * sy + coef.moment * suy + add
        };
        let (start, end) = (self.interior_start, self.interior_end);
        let (left, right) = self.edges.split_at(start.min(self.edges.len()));
        for (i, &coef) in left.iter().enumerate() {
            let (a, b) = self.window(i, n);
            out[i] = fit(coef, a, b, if CV { own[i] } else { 0.0 }, centred[i]);
        }
        for (i, &coef) in (end..n).zip(right) {
            let (a, b) = self.window(i, n);
            out[i] = fit(coef, a, b, if CV { own[i] } else { 0.0 }, centred[i]);
        }
        if start < end {
            // The bulk: fixed window offsets, contiguous slices, no bounds checks.
            let (lo, hi) = (start - self.half, end - self.half);
            let Coef { sum, moment } = self.interior;
            let sums_a = &sums[lo..hi];
            let sums_b = &sums[lo + self.len..hi + self.len];
            let moments_a = &moments[lo..hi];
            let moments_b = &moments[lo + self.len..hi + self.len];
            let x = &centred[start..end];
            let out = &mut out[start..end];
            if CV {
                let own = &own[start..end];
                for j in 0..out.len() {
                    let sy = sums_b[j] - sums_a[j];
                    let suy = (moments_b[j] - moments_a[j]) - x[j] * sy;
                    out[j] = sum * (sy - own[j]) + moment * suy + add;
                }
            } else {
                for j in 0..out.len() {
                    let sy = sums_b[j] - sums_a[j];
                    let suy = (moments_b[j] - moments_a[j]) - x[j] * sy;
                    out[j] = sum * sy + moment * suy + add;
                }
            }
        }
    }
}

/// Everything of a [`SuperSmoother`] that depends only on the series length: made by
/// [`SuperSmoother::plan`], it smooths any number of series of that length.
#[derive(Debug, Clone, PartialEq)]
pub struct SmoothPlan {
    n: usize,
    spans: [f64; 3],
    /// `1/(p2 − p1)` and `1/(p3 − p2)`.
    interpolation_slopes: [f64; 2],
    /// `10 − α`, with bass enhancement.
    bass_exponent: Option<BassExponent>,
    primary: [LinearSmooth; 3],
    middle: LinearSmooth,
    last: LinearSmooth,
    /// `i − n/2` for every sample: the moment's abscissa, centred to keep the prefix sums small.
    centred_index: Vec<f64>,
}

/// Reusable buffers for [`SmoothPlan::smooth_into`]: they grow to the longest series smoothed and
/// are then reused without allocating.
#[derive(Debug, Clone, Default)]
pub struct SmoothScratch {
    /// The series less its offset.
    shifted: Vec<f64>,
    /// Prefix sums (and moments) of the series being smoothed next.
    sums: Vec<f64>,
    moments: Vec<f64>,
    /// Cross-validated primary smooths.
    primary: [Vec<f64>; 3],
    /// Prefix sums (and moments) of the primary residuals.
    residual_sums: [Vec<f64>; 3],
    residual_moments: [Vec<f64>; 3],
    /// Smoothed residuals.
    errors: [Vec<f64>; 3],
    /// Smoothed best spans.
    spans: Vec<f64>,
}

impl SmoothScratch {
    fn prepare(&mut self, n: usize) {
        let all = [&mut self.shifted, &mut self.spans]
            .into_iter()
            .chain(&mut self.primary)
            .chain(&mut self.errors);
        for v in all {
            v.resize(n, 0.0);
        }
        let prefixes = [&mut self.sums, &mut self.moments]
            .into_iter()
            .chain(&mut self.residual_sums)
            .chain(&mut self.residual_moments);
        for v in prefixes {
            v.resize(n + 1, 0.0);
        }
    }
}

/// Writes the prefix sums of `values` and of `x·values` (both starting at 0).
fn prefix_sums(
    values: impl Iterator<Item = f64>,
    x: &[f64],
    sums: &mut [f64],
    moments: &mut [f64],
) {
    let (mut s, mut m) = (0.0, 0.0);
    sums[0] = 0.0;
    moments[0] = 0.0;
    for (((v, &x), s_out), m_out) in values.zip(x).zip(&mut sums[1..]).zip(&mut moments[1..]) {
        s += v;
        m += x * v;
        *s_out = s;
        *m_out = m;
    }
}

/// Smoothed residuals this close, relative to the mean residual, are a tie (won by the smaller
/// span). The package sums each window directly, so windows of equal content (two spans' windows
/// coincide at the ends when their lengths are adjacent integers) tie exactly there; differences
/// of prefix sums only agree to rounding, some 1e-14 of the mean residual for the default spans.
const TIE_TOLERANCE: f64 = 1e-9;

/// The largest of the three mean absolute residuals, from their prefix sums.
fn mean_residual(residual_sums: &[Vec<f64>; 3]) -> f64 {
    let n = residual_sums[0].len().saturating_sub(1).max(1);
    let largest = residual_sums
        .iter()
        .map(|s| s.last().copied().unwrap_or(0.0))
        .fold(0.0, f64::max);
    #[expect(
        clippy::cast_precision_loss,
        reason = "series lengths are far below 2^52: exact in f64"
    )]
    let n = n as f64;
    largest / n
}

/// The bass exponent `10 − α` (α clamped into [0, 10]), raised by `powi` when whole: the common
/// choices are, and `powi` costs a fraction of `powf` (within an ulp or two of it).
#[derive(Debug, Clone, Copy, PartialEq)]
struct BassExponent {
    real: f64,
    whole: Option<i32>,
}

impl BassExponent {
    fn new(alpha: f64) -> BassExponent {
        let real = 10.0 - alpha.clamp(0.0, 10.0);
        #[expect(
            clippy::cast_possible_truncation,
            reason = "whole and within [0, 10] when the test passes"
        )]
        let whole = (real.fract() == 0.0 && (0.0..=10.0).contains(&real)).then_some(real as i32);
        BassExponent { real, whole }
    }

    #[inline]
    fn pow(self, x: f64) -> f64 {
        match self.whole {
            Some(k) => x.powi(k),
            None => x.powf(self.real),
        }
    }
}

/// The bass factor for the least smoothed residual `least` and the woofer's `woofer`: the
/// package's `(least/woofer)^exponent` where that is finite, else the guards of the module doc.
#[inline]
fn bass_factor(least: f64, woofer: f64, exponent: BassExponent) -> f64 {
    let ratio = least / woofer;
    let factor = exponent.pow(ratio);
    if factor.is_finite() {
        factor
    } else if woofer > 0.0 {
        exponent.pow(ratio.clamp(0.0, 1.0))
    } else {
        1.0
    }
}

impl SmoothPlan {
    /// The series length this plan smooths.
    #[must_use]
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether this plan is for empty series.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Smooths one series of the plan's length into `out` (same length), reusing `scratch`
    /// (no allocation once it has served a series this long). Any data values, NaN and
    /// infinities included, are accepted without panicking.
    ///
    /// # Panics
    /// When `y` or `out` is not of the plan's length.
    pub fn smooth_into(&self, y: &[f64], out: &mut [f64], scratch: &mut SmoothScratch) {
        let n = self.n;
        assert_eq!(y.len(), n, "series length differs from the plan's");
        assert_eq!(out.len(), n, "output length differs from the plan's");
        if n <= 1 {
            out.copy_from_slice(y);
            return;
        }
        scratch.prepare(n);
        let SmoothScratch {
            shifted,
            sums,
            moments,
            primary,
            residual_sums,
            residual_moments,
            errors,
            spans,
        } = scratch;
        let x = &self.centred_index[..];

        // Shift by a sample so that the sums are of the curve's variation, not its level.
        let offset = Some(y[n / 2]).filter(|v| v.is_finite()).unwrap_or(0.0);
        for (s, &v) in shifted.iter_mut().zip(y) {
            *s = v - offset;
        }
        prefix_sums(shifted.iter().copied(), x, sums, moments);

        // 1. Cross-validated primary smooths, and the prefix sums of their absolute residuals.
        for (smooth, c) in self.primary.iter().zip(primary.iter_mut()) {
            smooth.apply(sums, moments, shifted, x, 0.0, c);
        }
        residual_prefix_sums(primary, shifted, x, residual_sums, residual_moments);

        // 2. The residuals smoothed with the middle span.
        for ((s, m), e) in residual_sums
            .iter()
            .zip(residual_moments.iter())
            .zip(errors.iter_mut())
        {
            self.middle.apply(s, m, shifted, x, 0.0, e);
        }

        // 3. The best span at each sample (first least smoothed residual), with bass, summed.
        let outliers =
            self.best_span_sums(errors, x, sums, moments, residual_sums, residual_moments);

        // 4. The best spans smoothed with the middle span.
        self.middle.apply(sums, moments, shifted, x, 0.0, spans);
        if outliers {
            let excess = &mut errors[0];
            let (excess_sums, excess_moments) = (&residual_sums[0], &residual_moments[0]);
            self.middle
                .apply(excess_sums, excess_moments, shifted, x, 0.0, excess);
            for (span, excess) in spans.iter_mut().zip(excess.iter()) {
                *span += excess;
            }
        }

        // 5. Interpolate between the primary smooths at the (clamped) smoothed span.
        self.interpolated_sums(primary, spans, x, sums, moments);

        // 6. The final smooth, shifted back.
        self.last.apply(sums, moments, shifted, x, offset, out);
    }

    /// Step 3 of [`SmoothPlan::smooth_into`]: the prefix sums (and moments) of the best span at
    /// each sample — the first whose smoothed residual in `errors` is least, within the tie
    /// tolerance — moved towards the woofer by the bass. Returns whether the bass threw any span
    /// outside `[p1, p3]`; the excess is then summed apart into `residual_sums[0]` and
    /// `residual_moments[0]` (the residuals' sums are no longer needed).
    fn best_span_sums(
        &self,
        errors: &[Vec<f64>; 3],
        x: &[f64],
        sums: &mut [f64],
        moments: &mut [f64],
        residual_sums: &mut [Vec<f64>; 3],
        residual_moments: &mut [Vec<f64>; 3],
    ) -> bool {
        let n = self.n;
        let [p1, p2, p3] = self.spans;
        let tie = TIE_TOLERANCE * mean_residual(residual_sums);
        let mut outliers = false;
        let [e1, e2, e3] = errors;
        let choose = |i: usize| {
            let (e1, e2, e3) = (e1[i], e2[i], e3[i]);
            let least = e1.min(e2).min(e3);
            let best = if e1 <= least + tie {
                p1
            } else if e2 <= least + tie {
                p2
            } else {
                p3
            };
            (best, least, e3)
        };
        match self.bass_exponent {
            None => prefix_sums((0..n).map(|i| choose(i).0), x, sums, moments),
            Some(exponent) => {
                // Bass can throw a span far outside [p1, p3] (a negative or tiny woofer
                // residual, taken as the package takes it). Such a value would drown every
                // later window's prefix-sum difference in its rounding, so the excess over
                // [p1, p3] is summed apart: away from it its sums are exactly constant.
                let excess_sums = &mut residual_sums[0];
                let excess_moments = &mut residual_moments[0];
                let (mut s, mut m, mut es, mut em) = (0.0, 0.0, 0.0, 0.0);
                sums[0] = 0.0;
                moments[0] = 0.0;
                excess_sums[0] = 0.0;
                excess_moments[0] = 0.0;
                for i in 0..n {
                    let (best, least, woofer) = choose(i);
                    let best = best + bass_factor(least, woofer, exponent) * (p3 - best);
                    let base = best.max(p1).min(p3);
                    let excess = best - base;
                    outliers |= excess != 0.0;
                    s += base;
                    m += x[i] * base;
                    es += excess;
                    em += x[i] * excess;
                    sums[i + 1] = s;
                    moments[i + 1] = m;
                    excess_sums[i + 1] = es;
                    excess_moments[i + 1] = em;
                }
            }
        }
        outliers
    }

    /// Step 5 of [`SmoothPlan::smooth_into`]: the prefix sums (and moments) of the primary smooths
    /// interpolated at each sample's smoothed span, clamped into `[p1, p3]`.
    fn interpolated_sums(
        &self,
        primary: &[Vec<f64>; 3],
        spans: &[f64],
        x: &[f64],
        sums: &mut [f64],
        moments: &mut [f64],
    ) {
        let n = self.n;
        let [p1, p2, p3] = self.spans;
        let [c1, c2, c3] = primary;
        let [lower_slope, upper_slope] = self.interpolation_slopes;
        let raw = (0..n).map(|i| {
            let span = spans[i].max(p1).min(p3);
            if span < p2 {
                c1[i] + (span - p1) * (c2[i] - c1[i]) * lower_slope
            } else {
                c2[i] + (span - p2) * (c3[i] - c2[i]) * upper_slope
            }
        });
        prefix_sums(raw, x, sums, moments);
    }
}

/// Step 1 of [`SmoothPlan::smooth_into`], second half: the prefix sums (and moments) of the
/// absolute residuals `|c_k − v|` of the three primary smooths.
fn residual_prefix_sums(
    primary: &[Vec<f64>; 3],
    shifted: &[f64],
    x: &[f64],
    residual_sums: &mut [Vec<f64>; 3],
    residual_moments: &mut [Vec<f64>; 3],
) {
    let n = shifted.len();
    let [c1, c2, c3] = primary;
    let [s1, s2, s3] = residual_sums;
    let [m1, m2, m3] = residual_moments;
    let (mut a1, mut a2, mut a3, mut b1, mut b2, mut b3) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for i in 0..n {
        let (v, xi) = (shifted[i], x[i]);
        let (r1, r2, r3) = ((c1[i] - v).abs(), (c2[i] - v).abs(), (c3[i] - v).abs());
        a1 += r1;
        a2 += r2;
        a3 += r3;
        b1 += xi * r1;
        b2 += xi * r2;
        b3 += xi * r3;
        s1[i + 1] = a1;
        s2[i + 1] = a2;
        s3[i + 1] = a3;
        m1[i + 1] = b1;
        m2[i + 1] = b2;
        m3[i + 1] = b3;
    }
    for v in [s1, s2, s3, m1, m2, m3] {
        v[0] = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The linear smooth straight from its definition: a least-squares line through the window
    /// (less the sample itself with `cv`), in coordinates centred on the window's points.
    fn naive_linear(y: &[f64], span: f64, cv: bool) -> Vec<f64> {
        let n = y.len();
        let k = window_len(span, n);
        let h = k / 2;
        (0..n)
            .map(|i| {
                let a = i.saturating_sub(h);
                let b = (i + k - h).min(n);
                let pts: Vec<(f64, f64)> = (a..b)
                    .filter(|&j| !(cv && j == i))
                    .map(|j| (j as f64, y[j]))
                    .collect();
                match pts.len() {
                    0 => 0.0,
                    1 => pts[0].1,
                    m => {
                        let m = m as f64;
                        let tm = pts.iter().map(|p| p.0).sum::<f64>() / m;
                        let ym = pts.iter().map(|p| p.1).sum::<f64>() / m;
                        let stt: f64 = pts.iter().map(|p| (p.0 - tm).powi(2)).sum();
                        let sty: f64 = pts.iter().map(|p| (p.0 - tm) * (p.1 - ym)).sum();
                        ym + sty / stt * (i as f64 - tm)
                    }
                }
            })
            .collect()
    }

    /// The SuperSmoother straight from its definition (module doc), on the naive smooths.
    fn naive_super(sm: &SuperSmoother, y: &[f64]) -> Vec<f64> {
        let n = y.len();
        if n <= 1 {
            return y.to_vec();
        }
        let p = sm.primary_spans;
        let c: Vec<Vec<f64>> = p.iter().map(|&s| naive_linear(y, s, true)).collect();
        let r: Vec<Vec<f64>> = c
            .iter()
            .map(|cj| cj.iter().zip(y).map(|(c, y)| (c - y).abs()).collect())
            .collect();
        let e_mean_residual = r
            .iter()
            .map(|r| r.iter().sum::<f64>() / n as f64)
            .fold(0.0, f64::max);
        let e: Vec<Vec<f64>> = r
            .iter()
            .map(|r| naive_linear(r, sm.middle_span, false))
            .collect();
        let best: Vec<f64> = (0..n)
            .map(|i| {
                let least = e[0][i].min(e[1][i]).min(e[2][i]);
                let j = (0..3)
                    .find(|&j| e[j][i] <= least + 1e-9 * e_mean_residual)
                    .unwrap_or(2);
                let mut best = p[j];
                if let Some(alpha) = sm.bass {
                    let ratio = least / e[2][i];
                    let exponent = 10.0 - alpha.clamp(0.0, 10.0);
                    let mut factor = ratio.powf(exponent);
                    if !factor.is_finite() {
                        factor = if e[2][i] > 0.0 {
                            ratio.clamp(0.0, 1.0).powf(exponent)
                        } else {
                            1.0
                        };
                    }
                    best += factor * (p[2] - best);
                }
                best
            })
            .collect();
        let s = naive_linear(&best, sm.middle_span, false);
        let raw: Vec<f64> = (0..n)
            .map(|i| {
                let s = s[i].clamp(p[0], p[2]);
                if s < p[1] {
                    c[0][i] + (s - p[0]) * (c[1][i] - c[0][i]) / (p[1] - p[0])
                } else {
                    c[1][i] + (s - p[1]) * (c[2][i] - c[1][i]) / (p[2] - p[1])
                }
            })
            .collect();
        naive_linear(&raw, sm.final_span, false)
    }

    fn max_abs(v: &[f64]) -> f64 {
        v.iter().fold(0.0, |m, x| m.max(x.abs()))
    }

    fn max_diff(a: &[f64], b: &[f64]) -> f64 {
        assert_eq!(a.len(), b.len());
        a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
    }

    /// The plan's linear smooth alone, for testing it against the naive one.
    /// (Shifted by the middle sample, as `smooth_into` shifts the series.)
    fn planned_linear(y: &[f64], span: f64, cv: bool) -> Vec<f64> {
        let n = y.len();
        let smooth = LinearSmooth::new(span, n, cv);
        let x: Vec<f64> = (0..n).map(|i| i as f64 - (n / 2) as f64).collect();
        let offset = y.get(n / 2).copied().unwrap_or(0.0);
        let shifted: Vec<f64> = y.iter().map(|v| v - offset).collect();
        let (mut sums, mut moments) = (vec![0.0; n + 1], vec![0.0; n + 1]);
        prefix_sums(shifted.iter().copied(), &x, &mut sums, &mut moments);
        let mut out = vec![f64::NAN; n];
        smooth.apply(&sums, &moments, &shifted, &x, offset, &mut out);
        out
    }

    /// A small deterministic generator: uniform in [0, 1) and standard normal.
    struct Rng(u64);
    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
        fn normal(&mut self) -> f64 {
            let (u, v) = (self.uniform().max(1e-300), self.uniform());
            (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
        }
    }

    fn spans_strategy() -> impl Strategy<Value = SuperSmoother> {
        (
            prop::array::uniform3(0.01f64..=1.0),
            0.01f64..=1.0,
            0.01f64..=1.0,
            prop::option::of(0.0f64..=10.0),
        )
            .prop_filter_map("distinct primary spans", |(mut p, m, f, bass)| {
                p.sort_by(f64::total_cmp);
                (p[0] < p[1] && p[1] < p[2]).then_some(SuperSmoother {
                    primary_spans: p,
                    middle_span: m,
                    final_span: f,
                    bass,
                })
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn linear_smooth_matches_naive(
            y in prop::collection::vec(-100.0f64..100.0, 2..300),
            span in 0.0f64..=1.0,
            cv: bool,
        ) {
            let (ours, naive) = (planned_linear(&y, span, cv), naive_linear(&y, span, cv));
            let tol = 1e-9 * max_abs(&naive).max(1.0);
            prop_assert!(max_diff(&ours, &naive) <= tol, "{} > {tol}", max_diff(&ours, &naive));
        }

        #[test]
        fn supersmoother_matches_naive(
            sm in spans_strategy(),
            noise in prop::collection::vec(-1.0f64..1.0, 2..300),
            level in -50.0f64..50.0,
            amplitude in 0.0f64..5.0,
        ) {
            prop_assert!(sm.validate().is_ok());
            // The curvature term keeps shrinking from making stretches exactly linear: there the
            // residuals are rounding noise in both implementations and their argmin arbitrary.
            let n = noise.len() as f64;
            let y: Vec<f64> = noise
                .iter()
                .enumerate()
                .map(|(i, e)| {
                    let t = i as f64 / n;
                    level + amplitude * (6.0 * t).sin() + 0.5 * t * t + e
                })
                .collect();
            let (ours, naive) = (sm.smooth(&y), naive_super(&sm, &y));
            let tol = 1e-9 * max_abs(&naive);
            prop_assert!(max_diff(&ours, &naive) <= tol, "{} > {tol}", max_diff(&ours, &naive));
        }
    }

    #[test]
    fn lines_and_constants_are_kept() {
        for n in [2usize, 3, 5, 17, 99, 100, 137, 1000, 5000] {
            let line: Vec<f64> = (0..n).map(|i| 3.5 - 0.25 * i as f64).collect();
            let constant = vec![-7.25; n];
            for (y, is_line) in [(&line, true), (&constant, false)] {
                let tol = 1e-9 * max_abs(y);
                for span in [0.01, 0.05, 0.2, 0.5, 1.0] {
                    for cv in [false, true] {
                        // A line needs two samples in every window: with cross-validation the
                        // end sample's window keeps `k − k/2 − 1` of them.
                        let k = window_len(span, n);
                        if is_line && cv && k - k / 2 < 3 {
                            continue;
                        }
                        let d = max_diff(&planned_linear(y, span, cv), y);
                        assert!(d <= tol, "n {n} span {span} cv {cv}: off by {d}");
                    }
                }
                // The default tweeter keeps a line from 100 samples on (as in the package).
                if is_line && n < 100 {
                    continue;
                }
                for bass in [None, Some(0.0), Some(3.0), Some(10.0)] {
                    let sm = SuperSmoother {
                        bass,
                        ..SuperSmoother::default()
                    };
                    let d = max_diff(&sm.smooth(y), y);
                    assert!(d <= tol, "n {n} bass {bass:?}: off by {d}");
                }
            }
        }
    }

    #[test]
    fn bass_beyond_the_woofer_matches_naive() {
        // Noise that stops 20 samples before the end of a line: there the smoothed residuals,
        // the woofer's too, extrapolate below zero and the package's bass factor reaches ~4e4.
        let n = 200;
        let y: Vec<f64> = (0..n)
            .map(|i| {
                let noise = f64::from((i * 37) % 11) / 5.0 - 1.0;
                0.01 * f64::from(i) + if i < n - 20 { noise } else { 0.0 }
            })
            .collect();
        for bass in [0.0, 3.0, 8.0, 2.5] {
            let sm = SuperSmoother {
                bass: Some(bass),
                ..SuperSmoother::default()
            };
            let (ours, naive) = (sm.smooth(&y), naive_super(&sm, &y));
            let d = max_diff(&ours, &naive);
            assert!(d <= 1e-9 * max_abs(&naive), "bass {bass}: off by {d}");
        }
    }

    #[test]
    fn short_series_give_finite_output() {
        let sm = SuperSmoother::default();
        assert!(sm.smooth(&[]).is_empty());
        assert_eq!(sm.smooth(&[4.5]), vec![4.5]);
        let mut rng = Rng(7);
        for n in [2, 3, 5, 17, 99] {
            let y: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
            for bass in [None, Some(5.0)] {
                let out = SuperSmoother { bass, ..sm }.smooth(&y);
                assert_eq!(out.len(), n);
                assert!(out.iter().all(|v| v.is_finite()), "n {n}: {out:?}");
            }
        }
    }

    #[test]
    fn non_finite_input_does_not_panic() {
        let mut rng = Rng(11);
        for n in [2, 5, 150] {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut y: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
                y[n / 2] = bad;
                for bass in [None, Some(2.0)] {
                    assert_eq!(
                        SuperSmoother {
                            bass,
                            ..Default::default()
                        }
                        .smooth(&y)
                        .len(),
                        n
                    );
                }
                assert_eq!(SuperSmoother::default().smooth(&vec![bad; n]).len(), n);
            }
        }
    }

    #[test]
    fn plan_and_scratch_are_reusable() {
        let sm = SuperSmoother::default();
        let mut rng = Rng(3);
        let mut scratch = SmoothScratch::default();
        for n in [300, 20, 300] {
            let plan = sm.plan(n);
            assert_eq!(plan.len(), n);
            let y: Vec<f64> = (0..n).map(|_| rng.normal()).collect();
            let mut out = vec![0.0; n];
            plan.smooth_into(&y, &mut out, &mut scratch);
            assert_eq!(out, sm.smooth(&y));
        }
    }

    #[test]
    fn validate_names_the_bad_value() {
        let ok = SuperSmoother::default();
        assert_eq!(ok.validate(), Ok(()));
        let cases = [
            (
                SuperSmoother {
                    primary_spans: [0.05, 1.5, 2.0],
                    ..ok
                },
                "1.5",
            ),
            (
                SuperSmoother {
                    primary_spans: [f64::NAN, 0.2, 0.5],
                    ..ok
                },
                "NaN",
            ),
            (
                SuperSmoother {
                    primary_spans: [0.2, 0.05, 0.5],
                    ..ok
                },
                "[0.2, 0.05, 0.5]",
            ),
            (
                SuperSmoother {
                    primary_spans: [0.05, 0.05, 0.5],
                    ..ok
                },
                "not strictly ascending",
            ),
            (
                SuperSmoother {
                    middle_span: 0.0,
                    ..ok
                },
                "middle span is 0",
            ),
            (
                SuperSmoother {
                    final_span: -0.25,
                    ..ok
                },
                "final span is -0.25",
            ),
            (
                SuperSmoother {
                    bass: Some(10.5),
                    ..ok
                },
                "bass is 10.5",
            ),
            (
                SuperSmoother {
                    bass: Some(f64::INFINITY),
                    ..ok
                },
                "bass is inf",
            ),
        ];
        for (sm, needle) in cases {
            let message = sm.validate().expect_err("invalid").to_string();
            assert!(message.contains(needle), "{message:?} lacks {needle:?}");
        }
        for bass in [0.0, 10.0] {
            assert!(
                SuperSmoother {
                    bass: Some(bass),
                    ..ok
                }
                .validate()
                .is_ok()
            );
        }
    }

    #[test]
    fn noisy_sine_is_denoised() {
        let n = 1000;
        let sigma = 0.3;
        let mut rng = Rng(42);
        let clean: Vec<f64> = (0..n)
            .map(|i| (std::f64::consts::TAU * 3.0 * f64::from(i) / f64::from(n)).sin())
            .collect();
        let noisy: Vec<f64> = clean.iter().map(|c| c + sigma * rng.normal()).collect();
        let rms = |a: &[f64]| {
            (a.iter()
                .zip(&clean)
                .map(|(x, c)| (x - c).powi(2))
                .sum::<f64>()
                / f64::from(n))
            .sqrt()
        };
        let input_rms = rms(&noisy);
        assert!(
            (input_rms - sigma).abs() < 0.05 * sigma,
            "noise {input_rms}"
        );
        for bass in [None, Some(5.0)] {
            let out = SuperSmoother {
                bass,
                ..Default::default()
            }
            .smooth(&noisy);
            let output_rms = rms(&out);
            assert!(
                output_rms < 0.35 * input_rms,
                "bass {bass:?}: output error {output_rms} vs input noise {input_rms}"
            );
        }
    }

    #[test]
    fn long_series_stay_accurate() {
        // 10⁶ samples of a ±2 variation on a level of 1000: the prefix sums must not drown it.
        let n = 1_000_000;
        let level = 1000.0;
        let y: Vec<f64> = (0..n)
            .map(|i| level + (i as f64 * 1e-4).sin() + 1e-3 * ((i * 7919) % 1000) as f64)
            .collect();
        for span in [0.05, 0.5] {
            let ours = planned_linear(&y, span, true);
            // Spot-check against the naive fit (O(n·k)) at a few samples, both ends included.
            let k = window_len(span, n);
            for i in [0, 1, k / 3, n / 2, n - k / 3, n - 1] {
                let a = i.saturating_sub(k / 2);
                let b = (i + k - k / 2).min(n);
                let d = (ours[i] - level - naive_point(&y, a, b, i, true, level)).abs();
                // Measured: ≤ 5e-11 (the last sample of the 0.05 span), 1e-14 mid-series.
                assert!(d <= 1e-10, "span {span} i {i}: off by {d}");
            }
        }
    }

    /// The fit at `i` through the samples `a..b` (less `i` with `cv`), less `level`.
    fn naive_point(y: &[f64], a: usize, b: usize, i: usize, cv: bool, level: f64) -> f64 {
        let pts: Vec<(f64, f64)> = (a..b)
            .filter(|&j| !(cv && j == i))
            .map(|j| (j as f64 - i as f64, y[j] - level))
            .collect();
        let m = pts.len() as f64;
        let tm = pts.iter().map(|p| p.0).sum::<f64>() / m;
        let ym = pts.iter().map(|p| p.1).sum::<f64>() / m;
        let stt: f64 = pts.iter().map(|p| (p.0 - tm).powi(2)).sum();
        let sty: f64 = pts.iter().map(|p| (p.0 - tm) * (p.1 - ym)).sum();
        ym - sty / stt * tm
    }
}
