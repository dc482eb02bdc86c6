//! Colour conversions: sRGB ↔ linear light. The renderer shades in linear RGB and writes sRGB
//! bytes; scene descriptions ([`crate::scene::Look`]) give sRGB. The one place for both.

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
        // Float-to-integer casts saturate: negative and NaN give 0 (black), above 1 clips to
        // white; never a panic.
        // Clamped as a float first: the 32-bit cast then needs no saturation (cheaper than a
        // saturating cast to usize and a `min`), and NaN still gives 0.
        let i = (linear * (TABLE_SIZE - 1) as f32 + 0.5).clamp(0.0, (TABLE_SIZE - 1) as f32) as i32;
        self.table[i as usize & (TABLE_SIZE - 1)]
    }

    /// A pixel.
    #[inline]
    #[must_use]
    pub fn encode_rgb(&self, c: Rgb) -> [u8; 3] {
        [self.encode(c[0]), self.encode(c[1]), self.encode(c[2])]
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
}
