//! `rgb24` → `yuv420p` (BT.601, limited range), the one colour conversion before the encoder.
//!
//! The encoder is fed `yuv420p` made here rather than `rgb24` for ffmpeg to convert. Measured on
//! a 2-core EPYC at 2.0 GHz (2,000 rendered 320×240 frames of the bench's walk, 3 runs each):
//! ffmpeg (x264 `superfast`, one thread) took 1.10 ms of CPU per frame given `rgb24` and 0.76 ms
//! given `yuv420p`; this conversion takes 0.12–0.15 ms, on the encoder's pipe thread, beside the
//! renderer, and the pipe carries half the bytes. The matrix and range are swscale's defaults
//! (ITU-R BT.601, Y in [16, 235], Cb and Cr in [16, 240]), so the videos'
//! colours are as before, within a code value; each chroma sample is the mean of its 2×2 pixels.

/// Fixed-point scale of the coefficients: 2^16.
const SHIFT: u32 = 16;
/// `219/255 · (0.299, 0.587, 0.114)`, `224/255 · (−0.169, −0.331, 0.5)` and
/// `224/255 · (0.5, −0.419, −0.081)` in units of 2^−16; each chroma row sums to 0, so greys have
/// no colour.
const Y: [i32; 3] = [16_829, 33_039, 6_416];
const CB: [i32; 3] = [-9_714, -19_070, 28_784];
const CR: [i32; 3] = [28_784, -24_103, -4_681];

/// Bytes of a `yuv420p` frame of `width × height` (both even).
#[must_use]
pub(crate) fn yuv420p_bytes(width: usize, height: usize) -> usize {
    width * height * 3 / 2
}

/// Writes `rgb24` (`width × height × 3` bytes, rows top to bottom; both sides even) into `out`
/// as `yuv420p`: the Y plane, then Cb and Cr at half the width and height. One pass over each
/// pair of rows, a 2×2 block at a time.
pub(crate) fn yuv420p_from_rgb24(width: usize, height: usize, rgb24: &[u8], out: &mut Vec<u8>) {
    debug_assert!(width.is_multiple_of(2) && height.is_multiple_of(2));
    debug_assert_eq!(rgb24.len(), width * height * 3);
    out.clear();
    out.resize(yuv420p_bytes(width, height), 0);
    let (luma, chroma) = out.split_at_mut(width * height);
    let (cb, cr) = chroma.split_at_mut(width * height / 4);
    let half = width / 2;
    let dot = |k: [i32; 3], rgb: [i32; 3]| k[0] * rgb[0] + k[1] * rgb[1] + k[2] * rgb[2];
    // In range by construction: Y in [16, 235], Cb and Cr in [16, 240].
    #[expect(
        clippy::cast_sign_loss,
        clippy::cast_possible_truncation,
        reason = "see above"
    )]
    let luma_of =
        |rgb: [i32; 3]| ((dot(Y, rgb) + (16 << SHIFT) + (1 << (SHIFT - 1))) >> SHIFT) as u8;
    // From the sum of the block's four pixels: two more bits of shift.
    #[expect(
        clippy::cast_sign_loss,
        clippy::cast_possible_truncation,
        reason = "see above"
    )]
    let chroma_of = |k: [i32; 3], sum: [i32; 3]| {
        ((dot(k, sum) + (128 << (SHIFT + 2)) + (1 << (SHIFT + 1))) >> (SHIFT + 2)) as u8
    };
    let rows = rgb24
        .chunks_exact(6 * width)
        .zip(luma.chunks_exact_mut(2 * width))
        .zip(cb.chunks_exact_mut(half).zip(cr.chunks_exact_mut(half)));
    for ((pixels, luma), (cb, cr)) in rows {
        let (top, bottom) = pixels.split_at(3 * width);
        let (luma_top, luma_bottom) = luma.split_at_mut(width);
        let blocks = top
            .chunks_exact(6)
            .zip(bottom.chunks_exact(6))
            .zip(
                luma_top
                    .chunks_exact_mut(2)
                    .zip(luma_bottom.chunks_exact_mut(2)),
            )
            .zip(cb.iter_mut().zip(cr.iter_mut()));
        for (((t, b), (lt, lb)), (cb, cr)) in blocks {
            let at = |s: &[u8], k: usize| [s[k], s[k + 1], s[k + 2]].map(i32::from);
            let quad = [at(t, 0), at(t, 3), at(b, 0), at(b, 3)];
            lt[0] = luma_of(quad[0]);
            lt[1] = luma_of(quad[1]);
            lb[0] = luma_of(quad[2]);
            lb[1] = luma_of(quad[3]);
            let sum = [0, 1, 2].map(|c| quad.iter().map(|p| p[c]).sum());
            *cb = chroma_of(CB, sum);
            *cr = chroma_of(CR, sum);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The planes of one `w × h` frame of colour `rgb`.
    fn convert(w: usize, h: usize, rgb: [u8; 3]) -> Vec<u8> {
        let frame: Vec<u8> = std::iter::repeat_n(rgb, w * h).flatten().collect();
        let mut out = Vec::new();
        yuv420p_from_rgb24(w, h, &frame, &mut out);
        out
    }

    #[test]
    fn greys_have_no_colour_and_span_the_limited_range() {
        for g in 0..=255u8 {
            let out = convert(2, 2, [g; 3]);
            let expected = (16.0 + 219.0 * f64::from(g) / 255.0).round() as u8;
            assert_eq!(
                out,
                [expected, expected, expected, expected, 128, 128],
                "grey {g}"
            );
        }
    }

    /// The BT.601 limited-range values of the primaries and secondaries (ITU-R BT.601 with
    /// Y = 16 + 219·E'y, Cb, Cr = 128 + 224·E'c, rounded).
    #[test]
    fn primaries_are_bt601_limited_range() {
        for (rgb, yuv) in [
            ([255, 0, 0], [81, 90, 240]),
            ([0, 255, 0], [145, 54, 34]),
            ([0, 0, 255], [41, 240, 110]),
            ([255, 255, 0], [210, 16, 146]),
            ([0, 255, 255], [170, 166, 16]),
            ([255, 0, 255], [106, 202, 222]),
        ] {
            let out = convert(2, 2, rgb);
            assert_eq!([out[0], out[4], out[5]], yuv, "{rgb:?}");
        }
    }

    proptest! {
        /// Each pixel's Y and its block's mean colour's Cb and Cr, inverted with BT.601's
        /// matrix, give back the block's colour within rounding, wherever the block is.
        #[test]
        fn blocks_of_one_colour_come_back(
            w in 1usize..6, h in 1usize..6, bx in 0usize..6, by in 0usize..6,
            rgb in any::<[u8; 3]>(),
        ) {
            let (w, h) = (2 * w, 2 * h);
            let (bx, by) = (bx % (w / 2), by % (h / 2));
            let mut frame = vec![0u8; w * h * 3];
            for (x, y) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let i = 3 * ((2 * by + y) * w + 2 * bx + x);
                frame[i..i + 3].copy_from_slice(&rgb);
            }
            let mut out = Vec::new();
            yuv420p_from_rgb24(w, h, &frame, &mut out);
            prop_assert_eq!(out.len(), w * h * 3 / 2);
            let luma = f64::from(out[2 * by * w + 2 * bx]) - 16.0;
            let c = w * h + by * (w / 2) + bx;
            let cb = f64::from(out[c]) - 128.0;
            let cr = f64::from(out[c + w * h / 4]) - 128.0;
            let (y, u, v) = (luma * 255.0 / 219.0, cb * 255.0 / 224.0, cr * 255.0 / 224.0);
            let back = [
                y + 1.402 * v,
                y - 0.344_136 * u - 0.714_136 * v,
                y + 1.772 * u,
            ];
            for (b, o) in back.iter().zip(rgb) {
                prop_assert!((b - f64::from(o)).abs() <= 2.5, "{rgb:?} came back as {back:?}");
            }
        }
    }
}
