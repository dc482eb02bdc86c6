//! Triangle rasterisation: near-plane clipping, edge functions, a `1/z` depth buffer and
//! perspective-correct barycentrics. Shared by the shadow pass and the colour pass.
//!
//! Screen coordinates are continuous pixels (pixel `(i, j)` covers `[i, i+1) × [j, j+1)`, the
//! convention of [`crate::camera::Intrinsics`]); a pixel is covered when its centre
//! `(i + ½, j + ½)` lies inside the triangle. The depth buffer stores `1/z` (z along the view
//! axis), so a greater value is nearer and a cleared buffer holds 0.

use crate::scene::fast_float::floor_small;

/// A vertex after projection: continuous pixel coordinates and the reciprocal view depth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ScreenVertex {
    /// x, pixels.
    pub x: f32,
    /// y, pixels (down).
    pub y: f32,
    /// 1 / z, per metre (z along the view axis, > 0).
    pub inv_z: f32,
}

/// Largest magnitude [`floor`] and [`ceil`] handle exactly; beyond it they saturate, which only
/// ever moves a bound further off screen.
const ROUNDING_LIMIT: f32 = 1.0e9;

/// `⌊v⌋` through an integer cast (the default x86-64 target has no rounding instruction, and a
/// libm call per row of every triangle is measurable). NaN gives 0.
#[inline]
pub(crate) fn floor(v: f32) -> f32 {
    let v = v.clamp(-ROUNDING_LIMIT, ROUNDING_LIMIT);
    let i = v as i64 as f32;
    if i > v { i - 1.0 } else { i }
}

/// `⌈v⌉`, as [`floor`].
#[inline]
fn ceil(v: f32) -> f32 {
    let v = v.clamp(-ROUNDING_LIMIT, ROUNDING_LIMIT);
    let i = v as i64 as f32;
    if i < v { i + 1.0 } else { i }
}

/// Which faces to skip.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Cull {
    /// Draw both sides (shadow casters, thin props).
    None,
    /// Skip triangles whose vertices run clockwise as the viewer sees them: faces seen from
    /// behind, for meshes wound counter-clockwise seen from outside.
    Back,
    /// Skip triangles whose vertices run counter-clockwise as the viewer sees them (the other
    /// side of [`Cull::Back`], for a view whose depth axis points towards the viewer).
    Front,
}

/// A rectangle of pixels: columns `x0..x1`, rows `y0..y1` (ends excluded).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct PixelRect {
    pub x0: usize,
    pub y0: usize,
    pub x1: usize,
    pub y1: usize,
}

impl PixelRect {
    /// Every pixel of a `width` × `height` image.
    pub fn full(width: usize, height: usize) -> PixelRect {
        PixelRect {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// No pixel.
    pub const EMPTY: PixelRect = PixelRect {
        x0: 0,
        y0: 0,
        x1: 0,
        y1: 0,
    };

    /// Whether it holds no pixel.
    pub fn is_empty(&self) -> bool {
        self.x0 >= self.x1 || self.y0 >= self.y1
    }

    /// The pixels whose centres lie in the continuous box `[lo, hi]` (pixel coordinates),
    /// grown by `margin` pixels on every side and cut to `within`.
    pub fn covering(lo: [f32; 2], hi: [f32; 2], margin: usize, within: PixelRect) -> PixelRect {
        let m = margin as f32;
        // `floor` and `ceil` saturate, and the clamps below keep every bound inside `within`.
        let start = |v: f32, min: usize| (floor(v - 0.5 - m).max(min as f32)) as usize;
        let end = |v: f32, max: usize| (ceil(v - 0.5 + m) + 1.0).clamp(0.0, max as f32) as usize;
        let r = PixelRect {
            x0: start(lo[0], within.x0),
            y0: start(lo[1], within.y0),
            x1: end(hi[0], within.x1),
            y1: end(hi[1], within.y1),
        };
        if r.is_empty() { PixelRect::EMPTY } else { r }
    }

    /// Grown by `n` pixels on every side, cut to `within`.
    pub fn grown(&self, n: usize, within: PixelRect) -> PixelRect {
        if self.is_empty() {
            return PixelRect::EMPTY;
        }
        PixelRect {
            x0: self.x0.saturating_sub(n).max(within.x0),
            y0: self.y0.saturating_sub(n).max(within.y0),
            x1: (self.x1 + n).min(within.x1),
            y1: (self.y1 + n).min(within.y1),
        }
    }
}

/// Rasterises one triangle into `depth` (`width` pixels per row, `height` rows), calling
/// `shade(pixel_index, inv_z, weights)` for every covered pixel inside `scissor` that passes
/// the depth test (`inv_z` greater than the stored value, which is then replaced). `weights`
/// are the perspective-correct barycentric weights of the three vertices. A pixel's values do
/// not depend on the scissor: it only skips pixels.
#[inline]
pub(crate) fn fill_triangle(
    v: [ScreenVertex; 3],
    width: usize,
    height: usize,
    scissor: PixelRect,
    depth: &mut [f32],
    cull: Cull,
    mut shade: impl FnMut(usize, f32, [f32; 3]),
) {
    // Twice the signed area. On a y-down screen it is negative when the vertices run
    // counter-clockwise as the viewer sees them: a front face of a mesh wound counter-clockwise
    // seen from outside.
    let area = (v[1].x - v[0].x) * (v[2].y - v[0].y) - (v[1].y - v[0].y) * (v[2].x - v[0].x);
    if area.is_nan() || area.abs() <= 1e-12 || scissor.is_empty() {
        return;
    }
    if (cull == Cull::Back && area > 0.0) || (cull == Cull::Front && area < 0.0) {
        return;
    }
    let (v, area) = if area < 0.0 {
        ([v[0], v[2], v[1]], -area)
    } else {
        (v, area)
    };
    let swapped = v;
    let min_x = swapped.iter().map(|p| p.x).fold(f32::INFINITY, f32::min);
    let max_x = swapped
        .iter()
        .map(|p| p.x)
        .fold(f32::NEG_INFINITY, f32::max);
    let min_y = swapped.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
    let max_y = swapped
        .iter()
        .map(|p| p.y)
        .fold(f32::NEG_INFINITY, f32::max);
    // Pixels whose centres can be inside.
    let row_start = ceil(min_y - 0.5).max(0.0);
    let row_end = floor(max_y - 0.5).min(height as f32 - 1.0);
    let col_start = ceil(min_x - 0.5).max(0.0);
    let col_end = floor(max_x - 0.5).min(width as f32 - 1.0);
    if !(row_start <= row_end && col_start <= col_end) {
        return;
    }
    // Edge i is opposite vertex i: e_i(x, y) = a·x + b·y + c, ≥ 0 inside, e_i(v_i) = area.
    let edge = |p: ScreenVertex, q: ScreenVertex| (q.y - p.y, p.x - q.x, q.x * p.y - p.x * q.y);
    let edges = [
        edge(swapped[2], swapped[1]),
        edge(swapped[0], swapped[2]),
        edge(swapped[1], swapped[0]),
    ];
    let inv_area = 1.0 / area;
    let iz = [swapped[0].inv_z, swapped[1].inv_z, swapped[2].inv_z];
    let (rows, last_row) = (row_start as usize, row_end as usize);
    let last_col = col_end as usize;
    let (first_row, end_row) = (rows.max(scissor.y0), last_row.min(scissor.y1 - 1));
    for block in (first_row..=end_row).step_by(ROWS) {
        // The spans of up to `ROWS` rows at once: the same arithmetic as row by row, lane by
        // lane (the divisions and roundings vectorise; most triangles here span a few rows).
        let (los, his) = row_spans(&edges, block, col_start, col_end);
        for (row, (lo, hi)) in (block..=end_row).zip(los.into_iter().zip(his)) {
            let y = row as f32 + 0.5;
            if lo > hi {
                continue;
            }
            let (lo, hi) = (lo as usize, (hi as usize).min(last_col));
            let x0 = lo as f32 + 0.5;
            let mut e = [
                edges[0].0 * x0 + edges[0].1 * y + edges[0].2,
                edges[1].0 * x0 + edges[1].1 * y + edges[1].2,
                edges[2].0 * x0 + edges[2].1 * y + edges[2].2,
            ];
            let base = row * width;
            // The edge values are stepped from the span's start whatever the scissor, so that a
            // pixel's weights are the same bits with and without it.
            let first = lo.max(scissor.x0);
            for _ in lo..first {
                e[0] += edges[0].0;
                e[1] += edges[1].0;
                e[2] += edges[2].0;
            }
            for col in first..=hi.min(scissor.x1 - 1) {
                let l = [
                    (e[0] * inv_area).max(0.0),
                    (e[1] * inv_area).max(0.0),
                    (e[2] * inv_area).max(0.0),
                ];
                let inv_z = l[0] * iz[0] + l[1] * iz[1] + l[2] * iz[2];
                let slot = &mut depth[base + col];
                if inv_z > *slot {
                    *slot = inv_z;
                    let k = 1.0 / inv_z;
                    shade(
                        base + col,
                        inv_z,
                        [l[0] * iz[0] * k, l[1] * iz[1] * k, l[2] * iz[2] * k],
                    );
                }
                e[0] += edges[0].0;
                e[1] += edges[1].0;
                e[2] += edges[2].0;
            }
        }
    }
}

/// Rows whose spans [`row_spans`] computes at once.
const ROWS: usize = 4;

/// Largest magnitude the lanes of [`row_spans`] round exactly (below 2²², as
/// [`floor_small`] needs). A bound beyond it is clamped to it, which moves it no nearer the
/// screen (at most 4 million pixels wide): the spans are those of [`floor`] and [`ceil`].
const LANE_LIMIT: f32 = 4.0e6;

/// [`floor`] for one lane, without a branch: NaN gives 0, and magnitudes beyond
/// [`LANE_LIMIT`] saturate.
#[inline]
fn floor_lane(v: f32) -> f32 {
    // NaN's bits cleared to +0 by a mask, then a clamp by comparisons: both vectorise.
    let v = f32::from_bits(v.to_bits() & u32::from(!v.is_nan()).wrapping_neg());
    let v = if v < -LANE_LIMIT { -LANE_LIMIT } else { v };
    let v = if v > LANE_LIMIT { LANE_LIMIT } else { v };
    floor_small(v).0
}

/// The columns `lo..=hi` (as floats; empty when `lo > hi`) where all three edge functions are
/// ≥ 0 at the centres of rows `row..row + ROWS`, within `col_start..=col_end`.
#[inline]
fn row_spans(
    edges: &[(f32, f32, f32); 3],
    row: usize,
    col_start: f32,
    col_end: f32,
) -> ([f32; ROWS], [f32; ROWS]) {
    const LANE: [f32; ROWS] = [0.5, 1.5, 2.5, 3.5];
    let first = row as f32;
    let mut lo = [col_start; ROWS];
    let mut hi = [col_end; ROWS];
    for &(a, b, c) in edges {
        let mut x = [0.0; ROWS];
        for j in 0..ROWS {
            x[j] = -(b * (first + LANE[j]) + c) / a - 0.5;
        }
        if a > 0.0 {
            for j in 0..ROWS {
                // ⌈v⌉ = −⌊−v⌋; neither bound is NaN, so a comparison is the maximum.
                let bound = -floor_lane(-x[j]);
                lo[j] = if bound > lo[j] { bound } else { lo[j] };
            }
        } else if a < 0.0 {
            for j in 0..ROWS {
                let bound = floor_lane(x[j]);
                hi[j] = if bound < hi[j] { bound } else { hi[j] };
            }
        } else {
            for j in 0..ROWS {
                if b * (first + LANE[j]) + c < 0.0 {
                    hi[j] = -1.0;
                }
            }
        }
    }
    (lo, hi)
}

/// A vertex in view space (before projection) with the attributes the caller interpolates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ClipVertex<const N: usize> {
    /// Position in the view frame (z forward, x right, y down), metres.
    pub view: [f32; 3],
    /// Attributes, interpolated linearly in view space.
    pub attributes: [f32; N],
}

/// Clips a triangle against the plane `z = near_m` in view space; writes the resulting convex
/// polygon (0, 3 or 4 vertices) into `out`.
pub(crate) fn clip_near<const N: usize>(
    tri: [ClipVertex<N>; 3],
    near_m: f32,
    out: &mut Vec<ClipVertex<N>>,
) {
    out.clear();
    for i in 0..3 {
        let (a, b) = (tri[i], tri[(i + 1) % 3]);
        let (da, db) = (a.view[2] - near_m, b.view[2] - near_m);
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            let mut v = a;
            for k in 0..3 {
                v.view[k] = a.view[k] + (b.view[k] - a.view[k]) * t;
            }
            for k in 0..N {
                v.attributes[k] = a.attributes[k] + (b.attributes[k] - a.attributes[k]) * t;
            }
            out.push(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    fn sv(x: f32, y: f32, z: f32) -> ScreenVertex {
        ScreenVertex {
            x,
            y,
            inv_z: 1.0 / z,
        }
    }

    fn coverage(tris: &[[ScreenVertex; 3]], w: usize, h: usize) -> Vec<u32> {
        let mut depth = vec![0.0; w * h];
        let mut hits = vec![0u32; w * h];
        for &t in tris {
            // A fresh depth buffer per triangle: counts coverage, not visibility.
            depth.fill(0.0);
            fill_triangle(
                t,
                w,
                h,
                PixelRect::full(w, h),
                &mut depth,
                Cull::None,
                |i, _, _| hits[i] += 1,
            );
        }
        hits
    }

    #[test]
    fn a_square_of_two_triangles_covers_each_pixel_once_or_twice_on_the_diagonal_only() {
        let (a, b, c, d) = (
            sv(2.0, 2.0, 1.0),
            sv(10.0, 2.0, 1.0),
            sv(10.0, 10.0, 1.0),
            sv(2.0, 10.0, 1.0),
        );
        let hits = coverage(&[[a, b, c], [a, c, d]], 16, 16);
        for y in 0..16 {
            for x in 0..16 {
                let inside = (2..10).contains(&x) && (2..10).contains(&y);
                let n = hits[y * 16 + x];
                assert_eq!(n > 0, inside, "pixel {x},{y}");
                if n > 1 {
                    assert_eq!(x, y, "double coverage off the shared edge at {x},{y}");
                }
            }
        }
    }

    #[test]
    fn depth_test_keeps_the_nearer_triangle_and_weights_sum_to_one() {
        let w = 8;
        let mut depth = vec![0.0; w * w];
        let far = [sv(0.0, 0.0, 4.0), sv(8.0, 0.0, 4.0), sv(0.0, 8.0, 4.0)];
        let near = [sv(0.0, 0.0, 2.0), sv(8.0, 0.0, 2.0), sv(0.0, 8.0, 2.0)];
        let mut owner = vec![0u8; w * w];
        fill_triangle(
            near,
            w,
            w,
            PixelRect::full(w, w),
            &mut depth,
            Cull::None,
            |i, _, b| {
                assert!((b.iter().sum::<f32>() - 1.0).abs() < 1e-5);
                owner[i] = 1;
            },
        );
        fill_triangle(
            far,
            w,
            w,
            PixelRect::full(w, w),
            &mut depth,
            Cull::None,
            |i, _, _| owner[i] = 2,
        );
        assert!(owner.iter().all(|&o| o != 2));
        assert!((depth[0] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn back_faces_are_culled_by_winding() {
        let cw = [sv(0.0, 0.0, 1.0), sv(8.0, 0.0, 1.0), sv(0.0, 8.0, 1.0)];
        let ccw = [cw[0], cw[2], cw[1]];
        let count = |t| {
            let mut depth = vec![0.0; 64];
            let mut n = 0;
            fill_triangle(
                t,
                8,
                8,
                PixelRect::full(8, 8),
                &mut depth,
                Cull::Back,
                |_, _, _| n += 1,
            );
            n
        };
        // (0,0) → (8,0) → (0,8) runs clockwise on a y-down screen: a back face.
        assert_eq!(count(cw), 0);
        assert!(count(ccw) > 0);
    }

    #[test]
    fn weights_are_perspective_correct() {
        // A triangle receding in depth: at the screen midpoint between a near and a far vertex,
        // the perspective-correct weight of the near vertex is larger than one half.
        let w = 64;
        let mut depth = vec![0.0; w * w];
        let t = [sv(0.0, 0.0, 1.0), sv(64.0, 0.0, 3.0), sv(0.0, 64.0, 1.0)];
        let mut seen = None;
        fill_triangle(
            t,
            w,
            w,
            PixelRect::full(w, w),
            &mut depth,
            Cull::None,
            |i, _, b| {
                if i == 31 {
                    seen = Some(b);
                }
            },
        );
        let b = seen.expect("pixel 31 of row 0 is covered");
        // Screen barycentric of vertex 1 at x = 31.5 is ~0.49; in view space it is
        // l1·(1/3) / (l0·1 + l1/3) ≈ 0.24.
        assert!((b[1] - 0.245).abs() < 0.02, "{b:?}");
    }

    #[test]
    fn fast_rounding_matches_the_standard_library() {
        for v in [
            -3.5f32,
            -3.0,
            -0.2,
            0.0,
            0.2,
            2.0,
            2.7,
            1e7 + 0.5,
            -1e7,
            123.999,
        ] {
            assert_eq!(floor(v), v.floor(), "{v}");
            assert_eq!(ceil(v), v.ceil(), "{v}");
        }
        assert_eq!(floor(f32::NAN), 0.0);
        assert_eq!(ceil(f32::INFINITY), 1.0e9);
    }

    #[test]
    fn near_clipping_cuts_a_crossing_triangle_into_a_quad() {
        let v = |z: f32| ClipVertex {
            view: [0.0, 0.0, z],
            attributes: [z],
        };
        let mut out = Vec::new();
        clip_near([v(-1.0), v(2.0), v(3.0)], 0.1, &mut out);
        assert_eq!(out.len(), 4);
        assert!(out.iter().all(|p| p.view[2] >= 0.1 - 1e-6));
        assert!(
            out.iter()
                .all(|p| (p.attributes[0] - p.view[2]).abs() < 1e-6)
        );
        clip_near([v(-1.0), v(-2.0), v(-3.0)], 0.1, &mut out);
        assert!(out.is_empty());
    }

    /// One row's span the way it was computed before [`row_spans`]: row by row, with
    /// [`floor`] and [`ceil`]. `None` when empty, else the columns as the rasteriser uses them.
    fn span_reference(
        edges: &[(f32, f32, f32); 3],
        row: usize,
        col_start: f32,
        col_end: f32,
    ) -> Option<(usize, usize)> {
        let y = row as f32 + 0.5;
        let (mut lo, mut hi) = (col_start, col_end);
        for &(a, b, c) in edges {
            let rest = b * y + c;
            if a > 0.0 {
                lo = lo.max(ceil(-rest / a - 0.5));
            } else if a < 0.0 {
                hi = hi.min(floor(-rest / a - 0.5));
            } else if rest < 0.0 {
                hi = -1.0;
            }
        }
        (lo <= hi).then_some((lo as usize, hi as usize))
    }

    /// A coordinate: mostly on a small screen, some far off it, some not finite.
    fn coordinate() -> impl Strategy<Value = f32> {
        prop_oneof![
            8 => -50.0f32..400.0,
            2 => -1.0e8f32..1.0e8,
            1 => Just(f32::NAN),
            1 => Just(f32::INFINITY),
            1 => Just(f32::NEG_INFINITY),
            1 => (0i32..64).prop_map(|k| k as f32 * 0.5),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2_000))]

        /// The lanes give every row exactly the span the row-by-row code gave, so a
        /// triangle covers the same pixels: for edges of any three points, finite or not.
        #[test]
        fn row_spans_are_the_row_by_row_spans(
            points in proptest::array::uniform3((coordinate(), coordinate())),
            row in 0usize..300,
            cols in (0u32..320, 0u32..320),
        ) {
            let p = points.map(|(x, y)| ScreenVertex { x, y, inv_z: 1.0 });
            let edge = |p: ScreenVertex, q: ScreenVertex| {
                (q.y - p.y, p.x - q.x, q.x * p.y - p.x * q.y)
            };
            let edges = [edge(p[2], p[1]), edge(p[0], p[2]), edge(p[1], p[0])];
            let (col_start, col_end) = (cols.0.min(cols.1) as f32, cols.0.max(cols.1) as f32);
            let (lo, hi) = row_spans(&edges, row, col_start, col_end);
            for j in 0..ROWS {
                let lanes = (lo[j] <= hi[j]).then_some((lo[j] as usize, hi[j] as usize));
                prop_assert_eq!(
                    lanes,
                    span_reference(&edges, row + j, col_start, col_end),
                    "row {}", row + j
                );
            }
        }
    }
}
