//! Float rounding and powers of two that vectorise. Rust's float-to-integer casts saturate (NaN gives 0), which
//! the compiler cannot do four lanes at a time on the default x86-64 target, so a loop with a
//! cast in it stays scalar. Adding 1.5·2²³ to a float of magnitude below 2²² instead rounds it
//! to an integer in its mantissa's low bits, with float additions and bit reads only.

/// 1.5·2²³: any `v` with `|v| < 2²²` added to it lands in [2²³, 2²⁴), where floats are the
/// integers.
const MAGIC: f32 = 12_582_912.0;

/// `⌊v⌋`, as a float and as an integer, for `|v| < 2²²` (the caller clamps; beyond that the
/// result is meaningless but never a panic).
#[inline]
#[must_use]
pub fn floor_small(v: f32) -> (f32, i32) {
    // To nearest (ties to even), then one down where that rounded up: 1.0's bits masked by
    // the comparison rather than a choice of two values, which the compiler made a branch in
    // scalar code (it mispredicts about every other value; `draw`'s inlined copy still
    // branches, the ground pass's no longer do).
    let rounded = (v + MAGIC) - MAGIC;
    let floor = rounded - f32::from_bits(u32::from(rounded > v) * 1.0f32.to_bits());
    let bits = (floor + MAGIC).to_bits().wrapping_sub(MAGIC.to_bits());
    (floor, bits as i32)
}

/// `2^e`, from its bits, for `e` in the normal range (−126..=127; the caller keeps it there).
#[inline]
#[must_use]
pub fn pow2(e: i32) -> f32 {
    f32::from_bits(((127 + e) as u32) << 23)
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    proptest! {
        #[test]
        fn floor_small_is_floor(v in -4_194_303.9f32..4_194_303.9) {
            let (f, i) = floor_small(v);
            prop_assert_eq!(f, v.floor());
            prop_assert_eq!(i as f32, v.floor());
        }
    }

    #[test]
    fn pow2_is_the_power() {
        for e in -126..=127 {
            assert_eq!(pow2(e), 2f32.powi(e), "{e}");
        }
    }

    #[test]
    fn floor_small_at_integers_halves_and_the_ends() {
        for v in [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.5,
            2.5,
            -2.5,
            4095.0,
            4094.5,
            -115.9,
            -1e-3,
            4_194_303.5,
            -4_194_304.0,
        ] {
            assert_eq!(floor_small(v), (v.floor(), v.floor() as i32), "{v}");
        }
    }
}
