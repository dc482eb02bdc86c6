//! Colour conversions: sRGB ↔ linear light. The renderer shades in linear RGB and writes sRGB
//! bytes; scene descriptions ([`crate::scene::Look`]) give sRGB. The one place for both.

use super::fast_float::floor_small;

/// A linear RGB colour (or irradiance), components ≥ 0.
pub type Rgb = [f32; 3];

/// sRGB component in [0, 1] → linear light (IEC 61966-2-1).
#[must_use]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// sRGB colour → linear RGB.
#[must_use]
pub fn linear_from_srgb(c: [f32; 3]) -> Rgb {
    [
        srgb_to_linear(c[0]),
        srgb_to_linear(c[1]),
        srgb_to_linear(c[2]),
    ]
}

/// Linear light in [0, 1] → sRGB component in [0, 1].
#[must_use]
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Entries of [`Encoder`]'s table: linear values are quantised to 1/4095 before encoding,
/// finer than an 8-bit sRGB step everywhere above the darkest few codes.
const TABLE_SIZE: usize = 4096;

/// Linear → 8-bit sRGB through a table (a `powf` per channel per pixel would cost more than
/// the shading). Values above 1 clip to white.
#[derive(Debug, Clone)]
pub struct Encoder {
    table: Box<[u8; TABLE_SIZE]>,
}

impl Default for Encoder {
    fn default() -> Self {
        Encoder::new()
    }
}

impl Encoder {
    /// Builds the table.
    #[must_use]
    pub fn new() -> Encoder {
        let mut table = Box::new([0u8; TABLE_SIZE]);
        for (i, t) in table.iter_mut().enumerate() {
            let linear = i as f32 / (TABLE_SIZE - 1) as f32;
            *t = (linear_to_srgb(linear) * 255.0 + 0.5) as u8;
        }
        Encoder { table }
    }

    /// One channel.
    #[inline]
    #[must_use]
    pub fn encode(&self, linear: f32) -> u8 {
        self.table[Self::index(linear)]
    }

    /// The table entry for `linear`: `⌊linear·4095 + ½⌋` clamped to the table, 0 for NaN (and
    /// negatives), never a panic; without a float-to-integer cast, so that
    /// [`Encoder::encode_slice`] vectorises.
    #[inline]
    fn index(linear: f32) -> usize {
        // `max` first: NaN gives 0.
        let x = (linear * (TABLE_SIZE - 1) as f32 + 0.5)
            .max(0.0)
            .min((TABLE_SIZE - 1) as f32);
        floor_small(x).1 as usize & (TABLE_SIZE - 1)
    }

    /// A pixel.
    #[inline]
    #[must_use]
    pub fn encode_rgb(&self, c: Rgb) -> [u8; 3] {
        [self.encode(c[0]), self.encode(c[1]), self.encode(c[2])]
    }

    /// Every value of `linear` into `srgb`, as [`Encoder::encode`] would: the table indices of
    /// a block are computed first, a loop the compiler vectorises, then looked up.
    ///
    /// # Panics
    ///
    /// If the two slices' lengths differ.
    pub fn encode_slice(&self, linear: &[f32], srgb: &mut [u8]) {
        const BLOCK: usize = 64;
        assert_eq!(linear.len(), srgb.len(), "one byte per value");
        let mut index = [0u16; BLOCK];
        for (linear, srgb) in linear.chunks(BLOCK).zip(srgb.chunks_mut(BLOCK)) {
            for (i, &v) in index.iter_mut().zip(linear) {
                *i = Self::index(v) as u16;
            }
            for (s, &i) in srgb.iter_mut().zip(&index) {
                // The mask is a no-op that tells the compiler the read is in bounds.
                *s = self.table[usize::from(i) & (TABLE_SIZE - 1)];
            }
        }
    }
}

/// `a + (b − a)·t`, per channel.
#[inline]
#[must_use]
pub fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

/// Per-channel product.
#[inline]
#[must_use]
pub fn mul(a: Rgb, b: Rgb) -> Rgb {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

/// `a·s`.
#[inline]
#[must_use]
pub fn scale(a: Rgb, s: f32) -> Rgb {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a + b`.
#[inline]
#[must_use]
pub fn add(a: Rgb, b: Rgb) -> Rgb {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips_and_the_table_matches_the_formula() {
        for i in 0..=255u8 {
            let c = f32::from(i) / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5);
        }
        let e = Encoder::new();
        for i in 0..=1000 {
            let l = i as f32 / 1000.0;
            let exact = (linear_to_srgb(l) * 255.0).round();
            assert!((f32::from(e.encode(l)) - exact).abs() <= 1.0, "{l}");
        }
        assert_eq!(e.encode(f32::NAN), 0);
        assert_eq!(e.encode(7.0), 255);
        assert_eq!(e.encode(-1.0), 0);
    }

    /// The table index is `⌊linear·4095 + ½⌋` clamped to the table (what a saturating cast
    /// gives), and `encode_slice` encodes as `encode` does, whatever the slice's length.
    #[test]
    fn the_index_is_the_clamped_floor_and_slices_encode_alike() {
        let cast = |l: f32| (l * 4095.0 + 0.5).clamp(0.0, 4095.0) as usize;
        let mut values: Vec<f32> = (-200..=4400).map(|i| i as f32 / 4095.0).collect();
        // Both sides of every rounding boundary, and the odd ones.
        values.extend((0..4096).flat_map(|i| {
            let b = (i as f32 - 0.5) / 4095.0;
            [b.next_down(), b, b.next_up()]
        }));
        values.extend([
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -0.0,
            1e30,
            -1e30,
        ]);
        for &l in &values {
            assert_eq!(Encoder::index(l), cast(l), "{l}");
        }
        let e = Encoder::new();
        for len in [0, 1, 63, 64, 65, values.len()] {
            let mut out = vec![0u8; len];
            e.encode_slice(&values[..len], &mut out);
            let one_by_one: Vec<u8> = values[..len].iter().map(|&l| e.encode(l)).collect();
            assert_eq!(out, one_by_one);
        }
    }
}
