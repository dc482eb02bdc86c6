//! Deterministic integer hashing for procedural detail (textures, particles, layouts): the same
//! inputs give the same values on every machine, so renders are reproducible bit for bit.

/// SplitMix64's finaliser: a well-mixed 64-bit value from any 64-bit input.
#[inline]
#[must_use]
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Hash of two values.
#[inline]
#[must_use]
pub fn hash2(a: u64, b: u64) -> u64 {
    mix64(a ^ mix64(b))
}

/// FNV-1a, 64 bits, of `text`: a stable number for a name (a scene's stream, a session's or a
/// clip's key).
#[must_use]
pub fn of_str(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// A uniform value in [0, 1) from a hash of `(a, b)`.
#[inline]
#[must_use]
pub fn unit2(a: u64, b: u64) -> f32 {
    (hash2(a, b) >> 40) as f32 / (1u64 << 24) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_values_are_spread_over_the_interval() {
        let mut buckets = [0u32; 10];
        for i in 0..10_000 {
            let u = unit2(3, i);
            assert!((0.0..1.0).contains(&u));
            buckets[(u * 10.0) as usize] += 1;
        }
        assert!(
            buckets.iter().all(|&b| (800..1200).contains(&b)),
            "{buckets:?}"
        );
        assert_ne!(hash2(1, 2), hash2(2, 1));
    }
}
