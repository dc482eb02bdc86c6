//! The embedded renderer: a software rasteriser on the CPU, deterministic bit for bit.
//!
//! One frame, in order:
//! 1. skin the body ([`crate::scene::body_mesh`]) for the frame's pose;
//! 2. shadow maps, orthographic along the key light: one fitted to the character every frame,
//!    one over the props once per scene;
//! 3. the character, props and backdrop, lit per vertex (hemisphere ambient + key light, fog)
//!    and shadowed per pixel (2×2 percentage-closer filtering, a depth bias plus a normal offset
//!    so lit surfaces show no acne);
//! 4. every pixel left empty is the ground (ray–plane, a mip-mapped texture, shadows, wet or
//!    water reflection of the sky, fog) or the sky;
//! 5. rain streaks or snowflakes, depth-tested;
//! 6. an edge-directed anti-aliasing pass over the final image.
//!
//! **Static shots.** When a frame comes from the same stage and camera as the renderer's
//! previous one, without a lightning flash, steps 3–6 start from the shot's still frame (props,
//! backdrop, ground and sky, drawn once): the character is drawn on a layer of its own and laid
//! over it where a whole frame's depth test would show it, the part of the picture its shadow
//! can reach (the screen box of its shadow map's beam) is drawn again, and anti-aliasing runs
//! only where the picture can differ from the still frame's (everywhere when it rains or
//! snows). Every step keeps a pixel's arithmetic (rows are stepped from their first pixel
//! whatever part is drawn), so the bits are a whole frame's: a property test over locations,
//! weathers, times, cameras and motions checks it.
//!
//! Frames are independent: parallel rendering uses one [`CpuRenderer`] per thread, and which
//! renderer draws a frame changes none of its bits.

use nalgebra::{Matrix3, Vector3};

use super::raster::{ClipVertex, Cull, PixelRect, ScreenVertex, clip_near, fill_triangle, floor};
use super::world::{GroundModel, GroundTexel, Surface};
use super::{FrameInput, Image, Renderer, Stage};
use crate::hash::unit2;
use crate::scene::color::{Encoder, Rgb, add, mix, mul, scale};
use crate::scene::environment::{Environment, fast_exp_neg};
use crate::scene::weather::Precipitation;

/// Side of the character's shadow map, texels, at most: smaller images use a map about as many
/// texels across as the image is tall (at least 256), which keeps its texels near pixel size.
const CHARACTER_SHADOW_SIZE: usize = 512;
/// The character's faces left out of its shadow map: those facing away from the light. The
/// body is closed, so the caster nearest the light over any texel is a face towards it; in
/// the light's frame (depth axis towards the light) those run clockwise on the map.
const CHARACTER_SHADOW_CULL: Cull = Cull::Front;
/// Side of the props' shadow map, texels.
const PROP_SHADOW_SIZE: usize = 1024;
/// Near clipping distance, metres.
const NEAR_M: f32 = 0.05;
/// Shadow depth bias, in texels of the map (along the light).
const BIAS_TEXELS: f32 = 2.0;
/// Receivers are moved this many texels along their normal before the lookup.
const NORMAL_OFFSET_TEXELS: f32 = 1.5;

/// An orthographic depth map seen from the key light.
#[derive(Debug, Clone, Default)]
struct ShadowMap {
    size: usize,
    /// Light-plane coordinates of texel (0, 0)'s corner, metres.
    origin: [f32; 2],
    /// Texels per metre.
    texels_per_m: f32,
    /// Offset that keeps stored heights ≥ 1 (0 is "nothing").
    height_offset: f32,
    /// Height towards the light of the nearest caster per texel (0 where none).
    heights: Vec<f32>,
    /// The depth bias, metres (`BIAS_TEXELS` texels), computed once per map.
    bias_m: f32,
    /// The casters' extent across the beam, `[u0, v0, u1, v1]`, metres.
    casters_uv_m: [f32; 4],
    /// The highest caster's coordinate towards the light, metres.
    top_l_m: f32,
    empty: bool,
    /// Per texel, whether the ground (z = 0) under the texel's centre is lit: one bit per texel,
    /// rows of [`ShadowMap::ground_row_words`] words (at least one spare, so that a texel and its
    /// right neighbour are read as one pair). Filled by [`ShadowMap::bake_ground`]; empty
    /// otherwise.
    ground_lit: Vec<u64>,
    ground_row_words: usize,
    /// [`draw_shadow_map`]'s scratch: the casters' vertices in light coordinates, then in the
    /// map's (texels across, and the stored height).
    light_coords: Vec<[f32; 3]>,
}

impl ShadowMap {
    /// The bilinear filter's texel at light-plane point `(u, v)` (the top-left of the four) and
    /// the weights `(fx, fy)` of its right and lower neighbours; `None` outside the map or when
    /// nothing casts a shadow.
    #[expect(clippy::inline_always, reason = "part of the per-pixel lookups below")]
    #[inline(always)]
    fn filter_at(&self, u: f32, v: f32) -> Option<(usize, usize, f32, f32)> {
        if self.empty {
            return None;
        }
        let x = (u - self.origin[0]) * self.texels_per_m - 0.5;
        let y = (v - self.origin[1]) * self.texels_per_m - 0.5;
        let n = self.size as f32;
        if !(x >= 0.0 && y >= 0.0 && x < n - 1.0 && y < n - 1.0) {
            return None;
        }
        // In range (checked above): a 32-bit cast is exact and cheaper than one to usize.
        let (xi, yi) = (x as i32, y as i32);
        Some((xi as usize, yi as usize, x - xi as f32, y - yi as f32))
    }

    /// Light visibility at light-space point `(u, v, h)`, [0, 1], or 1 outside the map.
    /// Always inlined: called per pixel from the colour and ground passes, and a call per
    /// lookup (which `#[inline]` alone let the compiler choose in `draw`) costs more than the
    /// out-of-map early return it mostly takes.
    #[expect(
        clippy::inline_always,
        reason = "measured: per-pixel calls in the colour pass"
    )]
    #[inline(always)]
    fn visibility(&self, u: f32, v: f32, h: f32) -> f32 {
        let Some((xi, yi, fx, fy)) = self.filter_at(u, v) else {
            return 1.0;
        };
        let receiver = h + self.height_offset + self.bias_m;
        let i = yi * self.size + xi;
        // 0 marks a texel no caster covers. `|`, not `||`: both tests, no branch per texel.
        let lit = |k: usize| {
            let caster = self.heights[k];
            f32::from(u8::from(caster == 0.0) | u8::from(caster <= receiver))
        };
        let top = lit(i) * (1.0 - fx) + lit(i + 1) * fx;
        let bottom = lit(i + self.size) * (1.0 - fx) + lit(i + self.size + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Records, per texel, whether the ground plane at the texel's centre is lit (the test
    /// [`ShadowMap::visibility`] makes, with the receiver's height taken at the texel's centre
    /// instead of at the pixel's point). The props do not move, so this is done once per stage
    /// and the ground pass reads 4 bits (a 130 KiB table, which stays in cache) instead of 4
    /// heights of a 4 MiB map. The two differ only where a caster's height is within about a
    /// texel of the ground's, along the props' contact lines.
    fn bake_ground(&mut self, light: &LightFrame) {
        let n = self.size;
        self.ground_row_words = n / 64 + 2;
        self.ground_lit.clear();
        self.ground_lit.resize(self.ground_row_words * n, 0);
        if self.empty || light.l.z <= 1e-3 {
            // No caster, or the light at or below the horizon (the ground has no direct
            // light then): nothing is read.
            return;
        }
        let (du, dv) = light.ground_slopes();
        let texel_m = 1.0 / self.texels_per_m;
        let rows = self.heights.chunks_exact(n);
        for (y, (heights, row)) in rows
            .zip(self.ground_lit.chunks_exact_mut(self.ground_row_words))
            .enumerate()
        {
            let v = self.origin[1] + (y as f32 + 0.5) * texel_m;
            let row_offset = v * dv + self.height_offset + self.bias_m;
            // 64 texels to a word, built in a register (a row's last word may be short).
            for (k, (chunk, word)) in heights.chunks(64).zip(row.iter_mut()).enumerate() {
                let mut bits = 0u64;
                for (j, &caster) in chunk.iter().enumerate() {
                    let u = self.origin[0] + ((k * 64 + j) as f32 + 0.5) * texel_m;
                    let lit = caster == 0.0 || caster <= u * du + row_offset;
                    bits |= u64::from(lit) << j;
                }
                *word = bits;
            }
        }
    }

    /// Light visibility on the ground at light-plane point `(u, v)`, [0, 1], or 1 outside the
    /// map: the bilinear filter of [`ShadowMap::visibility`] over the bits of
    /// [`ShadowMap::bake_ground`].
    #[expect(
        clippy::inline_always,
        reason = "per-pixel calls in the ground pass, as `visibility`"
    )]
    #[inline(always)]
    fn ground_visibility(&self, u: f32, v: f32) -> f32 {
        let Some((xi, yi, fx, fy)) = self.filter_at(u, v) else {
            return 1.0;
        };
        // Texels xi and xi + 1 of a row as the two low bits (the row's spare word makes
        // `word + 1` valid; shifting the 128-bit pair never shifts by 128).
        let pair = |row: usize| {
            let at = row * self.ground_row_words + xi / 64;
            let wide =
                u128::from(self.ground_lit[at]) | (u128::from(self.ground_lit[at + 1]) << 64);
            (wide >> (xi % 64)) as u32 & 3
        };
        let (top, bottom) = (pair(yi), pair(yi + 1));
        if top == 3 && bottom == 3 {
            return 1.0;
        }
        let lit = |bits: u32, k: u32| ((bits >> k) & 1) as f32;
        let top = lit(top, 0) * (1.0 - fx) + lit(top, 1) * fx;
        let bottom = lit(bottom, 0) * (1.0 - fx) + lit(bottom, 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

/// The light's frame: `u`, `v` across the beam, `l` towards the light.
#[derive(Debug, Clone, Copy)]
struct LightFrame {
    u: Vector3<f32>,
    v: Vector3<f32>,
    l: Vector3<f32>,
}

impl LightFrame {
    fn new(towards_light: [f32; 3]) -> LightFrame {
        let l = Vector3::from(towards_light).normalize();
        let helper = if l.z.abs() < 0.9 {
            Vector3::z()
        } else {
            Vector3::x()
        };
        let u = helper.cross(&l).normalize();
        let v = l.cross(&u);
        LightFrame { u, v, l }
    }
    #[inline]
    fn coords(&self, p: &Vector3<f32>) -> [f32; 3] {
        [self.u.dot(p), self.v.dot(p), self.l.dot(p)]
    }

    /// `(∂h/∂u, ∂h/∂v)` of the ground plane in this frame: the ground point under light-plane
    /// point `(u, v)` has `h = u·∂h/∂u + v·∂h/∂v`. (A point `(u, v, h)` is `u·U + v·V + h·L` in
    /// the world; on the ground its z is 0.) Infinite or NaN when the light is level.
    fn ground_slopes(&self) -> (f32, f32) {
        (-self.u.z / self.l.z, -self.v.z / self.l.z)
    }
}

/// Renders `triangles` of `positions` into `map`, fitted to their extent (plus `margin_m`),
/// skipping the faces `cull` says.
fn draw_shadow_map(
    map: &mut ShadowMap,
    size: usize,
    light: &LightFrame,
    positions: &[[f32; 3]],
    indices: &[u32],
    margin_m: f32,
    cull: Cull,
) {
    map.size = size;
    map.heights.clear();
    map.heights.resize(size * size, 0.0);
    map.empty = indices.is_empty();
    if map.empty {
        return;
    }
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    map.light_coords.clear();
    map.light_coords
        .extend(positions.iter().map(|p| light.coords(&Vector3::from(*p))));
    for c in &map.light_coords {
        for k in 0..3 {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k]);
        }
    }
    let extent = (hi[0] - lo[0]).max(hi[1] - lo[1]) + 2.0 * margin_m;
    map.origin = [lo[0] - margin_m, lo[1] - margin_m];
    map.texels_per_m = size as f32 / extent.max(1e-3);
    map.bias_m = BIAS_TEXELS / map.texels_per_m;
    map.height_offset = 1.0 - lo[2];
    map.top_l_m = hi[2];
    map.casters_uv_m = [lo[0], lo[1], hi[0], hi[1]];
    // Each vertex to the map once (its triangles share it).
    let (origin, texels_per_m, height_offset) = (map.origin, map.texels_per_m, map.height_offset);
    for c in &mut map.light_coords {
        *c = [
            (c[0] - origin[0]) * texels_per_m,
            (c[1] - origin[1]) * texels_per_m,
            c[2] + height_offset,
        ];
    }
    for t in indices.chunks_exact(3) {
        let s = [t[0], t[1], t[2]].map(|k| {
            let [x, y, inv_z] = map.light_coords[k as usize];
            ScreenVertex { x, y, inv_z }
        });
        let all = PixelRect::full(size, size);
        fill_triangle(s, size, size, all, &mut map.heights, cull, |_, _, _| {});
    }
}

/// The camera of one frame, in the form the passes use.
#[derive(Debug, Clone, Copy)]
struct View {
    /// optical_from_world rotation.
    rotation: Matrix3<f32>,
    /// optical_from_world translation.
    translation: Vector3<f32>,
    /// Camera centre in the world.
    eye: Vector3<f32>,
    /// world_from_optical rotation (columns: the optical axes in the world).
    world_from_optical: Matrix3<f32>,
    fx: f32,
    fy: f32,
    cx: f32,
    cy: f32,
    width: usize,
    height: usize,
}

impl View {
    fn new(frame: &FrameInput<'_>) -> View {
        let iso = frame.camera.world_from_optical;
        let r64 = iso.rotation.to_rotation_matrix().into_inner();
        let world_from_optical: Matrix3<f32> = r64.cast();
        let rotation = world_from_optical.transpose();
        let eye: Vector3<f32> = iso.translation.vector.cast();
        let k = &frame.camera.intrinsics;
        View {
            rotation,
            translation: -(rotation * eye),
            eye,
            world_from_optical,
            fx: k.fx_px as f32,
            fy: k.fy_px as f32,
            cx: k.cx_px as f32,
            cy: k.cy_px as f32,
            width: k.width_px as usize,
            height: k.height_px as usize,
        }
    }
    #[inline]
    fn view_of(&self, p: &Vector3<f32>) -> [f32; 3] {
        let q = self.rotation * p + self.translation;
        [q.x, q.y, q.z]
    }
    /// The pixels (and one more around) whose centres lie in the screen box of view-space
    /// points; every pixel when one of them is not in front of the near plane.
    fn screen_box(&self, points: impl Iterator<Item = [f32; 3]>) -> PixelRect {
        let all = PixelRect::full(self.width, self.height);
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for q in points {
            if q[2] < NEAR_M || q[2].is_nan() {
                return all;
            }
            let s = self.project(q);
            lo = [lo[0].min(s.x), lo[1].min(s.y)];
            hi = [hi[0].max(s.x), hi[1].max(s.y)];
        }
        PixelRect::covering(lo, hi, 1, all)
    }

    #[inline]
    fn project(&self, q: [f32; 3]) -> ScreenVertex {
        let iz = 1.0 / q[2];
        ScreenVertex {
            x: self.fx * q[0] * iz + self.cx,
            y: self.fy * q[1] * iz + self.cy,
            inv_z: iz,
        }
    }
}

/// Pixels [`CpuRenderer::draw`] shaded and has not yet written, in the order shaded: linear
/// RGB and the pixel's index; `srgb` is scratch for their encoding.
#[derive(Debug, Default)]
struct Shaded {
    linear: Vec<f32>,
    at: Vec<usize>,
    srgb: Vec<u8>,
}

impl Shaded {
    /// Pixels kept before they are encoded and written (checked after each triangle, so a
    /// batch holds at most this plus one triangle's): enough for the lanes, few enough to stay
    /// in the cache whatever the picture's size.
    const BATCH: usize = 4096;

    /// Keeps pixel `i`'s linear colour `c`.
    #[inline]
    fn push(&mut self, i: usize, c: Rgb) {
        self.linear.extend_from_slice(&c);
        self.at.push(i);
    }

    /// Encodes the pixels kept (in lanes) and writes them into `rgb` in the order shaded, so a
    /// pixel shaded twice keeps its last shading.
    fn write(&mut self, encoder: &Encoder, rgb: &mut [u8]) {
        self.srgb.resize(self.linear.len(), 0);
        encoder.encode_slice(&self.linear, &mut self.srgb);
        for (&i, c) in self.at.iter().zip(self.srgb.chunks_exact(3)) {
            rgb[3 * i..3 * i + 3].copy_from_slice(c);
        }
        self.linear.clear();
        self.at.clear();
    }
}

/// The CPU renderer; one per thread.
#[derive(Debug, Default)]
pub struct CpuRenderer {
    encoder: Encoder,
    skinned_positions: Vec<[f32; 3]>,
    skinned_normals: Vec<[f32; 3]>,
    character_shadow: ShadowMap,
    prop_shadow: ShadowMap,
    /// Which stage `prop_shadow` belongs to.
    prop_shadow_stage: Option<u64>,
    /// Lit vertices: attributes are the fogged ambient colour (3), the fogged direct colour
    /// (3) and the light-space position (3).
    vertices: Vec<ClipVertex<9>>,
    polygon: Vec<ClipVertex<9>>,
    /// [`CpuRenderer::draw`]'s shaded pixels before their sRGB encoding (empty between draws).
    shaded: Shaded,
    unfiltered: Vec<u8>,
    /// What the last frame drawn was seen from.
    last_seen_from: Option<SeenFrom>,
    /// The still frame of the last static shot.
    still: Option<Still>,
    /// The character alone, when it is laid over a still frame.
    character_layer: Image,
}

impl CpuRenderer {
    /// A renderer with empty buffers (they grow on first use and are then reused).
    #[must_use]
    pub fn new() -> CpuRenderer {
        CpuRenderer::default()
    }

    /// Lights and transforms one mesh's vertices into `self.vertices`.
    #[allow(clippy::too_many_arguments)]
    fn prepare_vertices(
        &mut self,
        env: &Environment,
        view: &View,
        light: &LightFrame,
        positions: &[[f32; 3]],
        normals: &[[f32; 3]],
        albedo: &dyn Fn(usize) -> Rgb,
        flash: f32,
        normal_offset_m: f32,
    ) {
        self.vertices.clear();
        let key = Vector3::from(env.key_dir);
        for (i, (p, n)) in positions.iter().zip(normals).enumerate() {
            let pw = Vector3::from(*p);
            let nw = Vector3::from(*n);
            let a = albedo(i);
            let q = view.view_of(&pw);
            let distance = (pw - view.eye).norm();
            let keep = fast_exp_neg(env.fog_per_m * distance);
            let ambient = add(env.ambient(nw.z), [flash; 3]);
            let lit_ambient = add(
                scale(mul(a, ambient), keep),
                scale(env.horizon_rgb, 1.0 - keep),
            );
            let ndl = nw.dot(&key).max(0.0);
            let direct = scale(mul(a, env.key_rgb), ndl * keep);
            let l = light.coords(&(pw + nw * normal_offset_m));
            self.vertices.push(ClipVertex {
                view: q,
                attributes: [
                    lit_ambient[0],
                    lit_ambient[1],
                    lit_ambient[2],
                    direct[0],
                    direct[1],
                    direct[2],
                    l[0],
                    l[1],
                    l[2],
                ],
            });
        }
    }

    /// Rasterises `indices` over `self.vertices` into the image, within `scissor`; `shadowed`
    /// meshes look up the shadow maps per pixel (the far backdrop does not).
    fn draw(
        &mut self,
        view: &View,
        indices: &[u32],
        surface: Surface,
        shadowed: bool,
        scissor: PixelRect,
        image: &mut Image,
    ) {
        let (w, h) = (view.width, view.height);
        let shadows = [&self.character_shadow, &self.prop_shadow];
        let polygon = &mut self.polygon;
        let surfaces = &mut image.surface;
        let depth = &mut image.depth;
        // Shaded pixels are encoded to sRGB a batch at a time, in lanes: one at a time, the
        // encoding's rounding was a branch that mispredicted.
        let encoder = &self.encoder;
        let rgb = &mut image.rgb;
        let shaded = &mut self.shaded;
        for t in indices.chunks_exact(3) {
            let tri = [
                self.vertices[t[0] as usize],
                self.vertices[t[1] as usize],
                self.vertices[t[2] as usize],
            ];
            if tri.iter().all(|v| v.view[2] >= NEAR_M) {
                polygon.clear();
                polygon.extend_from_slice(&tri);
            } else {
                clip_near(tri, NEAR_M, polygon);
            }
            // A fan over the (clipped) convex polygon: one or two triangles.
            for k in 1..polygon.len().saturating_sub(1) {
                let part = [polygon[0], polygon[k], polygon[k + 1]];
                let s = part.map(|v| view.project(v.view));
                let [a0, a1, a2] = part.map(|v| v.attributes);
                fill_triangle(s, w, h, scissor, depth, Cull::Back, |i, _, b| {
                    let get = |k: usize| a0[k] * b[0] + a1[k] * b[1] + a2[k] * b[2];
                    let lit = if shadowed {
                        let (u, v, l) = (get(6), get(7), get(8));
                        shadows[0]
                            .visibility(u, v, l)
                            .min(shadows[1].visibility(u, v, l))
                    } else {
                        1.0
                    };
                    let c = [
                        get(0) + lit * get(3),
                        get(1) + lit * get(4),
                        get(2) + lit * get(5),
                    ];
                    shaded.push(i, c);
                    surfaces[i] = surface as u8;
                });
            }
            if shaded.at.len() >= Shaded::BATCH {
                shaded.write(encoder, rgb);
            }
        }
        shaded.write(encoder, rgb);
    }
}

impl Renderer for CpuRenderer {
    fn render(&mut self, stage: &Stage, frame: &FrameInput<'_>, image: &mut Image) {
        let view = View::new(frame);
        let (w, h) = (view.width, view.height);
        image.resize(w as u32, h as u32);
        let env = &stage.environment;
        let light = LightFrame::new(env.key_dir);
        let flash = env.lightning_flash(frame.time_s, stage.seed);
        // The second frame in a row from one camera on one stage, without a flash: what does
        // not move is drawn once and reused (`still`), for the same bits as a whole frame.
        let seen_from = SeenFrom {
            stage: stage.id,
            camera: frame.camera,
        };
        let reuse = flash == 0.0 && self.last_seen_from == Some(seen_from);
        self.last_seen_from = Some(seen_from);

        // Shadow maps: the props' once per stage, then (after a new still frame, which is
        // drawn without the character) the character's.
        if env.key_shadows {
            if self.prop_shadow_stage != Some(stage.id) {
                draw_shadow_map(
                    &mut self.prop_shadow,
                    PROP_SHADOW_SIZE,
                    &light,
                    &stage.world.props.positions,
                    &stage.world.props.indices,
                    0.5,
                    Cull::None,
                );
                self.prop_shadow.bake_ground(&light);
                self.prop_shadow_stage = Some(stage.id);
            }
        } else {
            self.prop_shadow.empty = true;
            self.prop_shadow_stage = None;
        }
        self.character_shadow.empty = true;
        let still = if reuse {
            match self.still.take() {
                Some(still) if still.seen_from == seen_from => Some(still),
                _ => Some(self.draw_still(stage, &view, &light, seen_from)),
            }
        } else {
            None
        };

        // 1. The body for this pose.
        let skinning = crate::scene::body_mesh::Skinning::new(&stage.rest_pose, frame.pose);
        stage.body.skin_into(
            &skinning,
            &mut self.skinned_positions,
            &mut self.skinned_normals,
        );
        if env.key_shadows {
            draw_shadow_map(
                &mut self.character_shadow,
                CHARACTER_SHADOW_SIZE.min(h.max(256)),
                &light,
                &self.skinned_positions,
                &stage.body.indices,
                0.1,
                CHARACTER_SHADOW_CULL,
            );
        }

        match still {
            Some(still) => {
                self.compose(stage, &view, &light, &still, frame.time_s, image);
                self.still = Some(still);
            }
            None => self.draw_whole(stage, &view, &light, flash, frame.time_s, image),
        }
    }
}

/// What a frame is seen from: a stage and a camera (not [`crate::camera::Shot`], how a
/// clip's camera moves).
#[derive(Debug, Clone, Copy, PartialEq)]
struct SeenFrom {
    stage: u64,
    camera: super::Camera,
}

/// A static shot's still frame: what its camera sees without the character, its shadow and
/// the rain, as the passes before anti-aliasing leave it, and anti-aliased.
#[derive(Debug)]
struct Still {
    seen_from: SeenFrom,
    image: Image,
    antialiased: Vec<u8>,
    /// The lowest point a shadow can fall on (the ground or a prop), metres.
    lowest_z_m: f32,
    /// The props' extent across the key light's beam, `[u0, v0, u1, v1]`, metres.
    props_uv_m: [f32; 4],
}

impl CpuRenderer {
    /// Steps 3–6 of a frame, every pixel drawn.
    fn draw_whole(
        &mut self,
        stage: &Stage,
        view: &View,
        light: &LightFrame,
        flash: f32,
        time_s: f64,
        image: &mut Image,
    ) {
        let all = PixelRect::full(view.width, view.height);
        // 3. Character, props, backdrop: nearest first, so the depth test rejects early.
        self.draw_character(stage, view, light, flash, image);
        self.draw_world(stage, view, light, flash, all, image);
        // 4. Ground and sky behind everything drawn.
        self.ground_and_sky(stage, view, light, flash, all, image);
        // 5. Rain or snow on top.
        precipitation(&stage.environment, stage.seed, time_s, view, image);
        // 6. Anti-aliasing.
        antialias(image, &mut self.unfiltered);
    }

    /// The still frame seen from `seen_from`: props, backdrop, ground and sky, without the character's
    /// shadow (which the caller has emptied) or a flash.
    fn draw_still(
        &mut self,
        stage: &Stage,
        view: &View,
        light: &LightFrame,
        seen_from: SeenFrom,
    ) -> Still {
        let all = PixelRect::full(view.width, view.height);
        let mut image = Image::new(view.width as u32, view.height as u32);
        self.draw_world(stage, view, light, 0.0, all, &mut image);
        self.ground_and_sky(stage, view, light, 0.0, all, &mut image);
        let mut antialiased = image.clone();
        antialias(&mut antialiased, &mut self.unfiltered);
        let lowest_z_m = stage
            .world
            .props
            .positions
            .iter()
            .fold(0.0f32, |z, p| z.min(p[2]));
        let mut props_uv_m = [
            f32::INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ];
        for p in &stage.world.props.positions {
            let c = light.coords(&Vector3::from(*p));
            props_uv_m = [
                props_uv_m[0].min(c[0]),
                props_uv_m[1].min(c[1]),
                props_uv_m[2].max(c[0]),
                props_uv_m[3].max(c[1]),
            ];
        }
        Still {
            seen_from,
            image,
            antialiased: antialiased.rgb,
            lowest_z_m,
            props_uv_m,
        }
    }

    /// Steps 3–6 of a frame of a static shot, from its still frame: the character on a layer
    /// of its own, the still frame with the part the character's shadow can reach drawn again,
    /// the character laid over it where it is nearer (as the depth test of a whole frame would
    /// have it), rain or snow, and anti-aliasing where anything differs from the still frame.
    /// The bits are those of [`CpuRenderer::draw_whole`].
    fn compose(
        &mut self,
        stage: &Stage,
        view: &View,
        light: &LightFrame,
        still: &Still,
        time_s: f64,
        image: &mut Image,
    ) {
        let all = PixelRect::full(view.width, view.height);
        let mut layer = std::mem::take(&mut self.character_layer);
        layer.resize(view.width as u32, view.height as u32);
        let body = self.draw_character(stage, view, light, 0.0, &mut layer);

        image.rgb.copy_from_slice(&still.image.rgb);
        image.depth.copy_from_slice(&still.image.depth);
        image.surface.copy_from_slice(&still.image.surface);
        let shadow = self.shadow_reach(view, light, still);
        if !shadow.is_empty() {
            for y in shadow.y0..shadow.y1 {
                let row = y * view.width;
                image.depth[row + shadow.x0..row + shadow.x1].fill(0.0);
                image.surface[row + shadow.x0..row + shadow.x1].fill(Surface::Sky as u8);
            }
            self.draw_world(stage, view, light, 0.0, shadow, image);
            self.ground_and_sky(stage, view, light, 0.0, shadow, image);
        }
        // A character pixel shows where it is at least as near as the props and backdrop
        // (drawn first in a whole frame, it keeps ties); the ground and sky are behind it.
        let flat = [Surface::Sky as u8, Surface::Ground as u8];
        for y in body.y0..body.y1 {
            for i in y * view.width + body.x0..y * view.width + body.x1 {
                let c = layer.depth[i];
                if drawn(c) && (flat.contains(&image.surface[i]) || c >= image.depth[i]) {
                    image.depth[i] = c;
                    image.surface[i] = layer.surface[i];
                    image.rgb[3 * i..3 * i + 3].copy_from_slice(&layer.rgb[3 * i..3 * i + 3]);
                }
            }
        }
        self.character_layer = layer;

        if precipitation(&stage.environment, stage.seed, time_s, view, image) {
            antialias(image, &mut self.unfiltered);
        } else {
            let source = &mut self.unfiltered;
            source.clear();
            source.extend_from_slice(&image.rgb);
            image.rgb.copy_from_slice(&still.antialiased);
            for rect in [shadow, body] {
                antialias_within(image, source, rect.grown(1, all));
            }
        }
    }

    /// The pixels whose colour the character's shadow can change: the screen box of the part
    /// of the beam through its casters (widened by two texels for the lookups' filter and by
    /// the receivers' normal offset) between the highest caster and the lowest receiver, or
    /// only where it meets the ground when no prop is in it; every pixel when the light is too
    /// low for that part to be bounded or it reaches behind the camera.
    fn shadow_reach(&self, view: &View, light: &LightFrame, still: &Still) -> PixelRect {
        let all = PixelRect::full(view.width, view.height);
        let map = &self.character_shadow;
        if map.empty {
            return PixelRect::EMPTY;
        }
        if light.l.z < 0.05 {
            return all;
        }
        let offset_m = NORMAL_OFFSET_TEXELS / self.prop_shadow.texels_per_m.max(1.0);
        let grow = offset_m + 2.0 / map.texels_per_m;
        let [u0, v0, u1, v1] = map.casters_uv_m;
        let (u0, v0, u1, v1) = (u0 - grow, v0 - grow, u1 + grow, v1 + grow);
        let [p0, q0, p1, q1] = still.props_uv_m;
        let props_in_beam = p0 <= u1 && u0 <= p1 && q0 <= v1 && v0 <= q1;
        let corners = [(u0, v0), (u1, v0), (u0, v1), (u1, v1)].map(|(u, v)| {
            let across = light.u * u + light.v * v;
            let floor_l = (still.lowest_z_m - offset_m - across.z) / light.l.z;
            let top_l = if props_in_beam {
                map.top_l_m + offset_m
            } else {
                (offset_m - across.z) / light.l.z
            };
            [top_l, floor_l].map(|l| view.view_of(&(across + light.l * l)))
        });
        view.screen_box(corners.iter().flatten().copied())
    }

    /// Lights, transforms and draws the character (skinned into `skinned_positions`) into
    /// `image`; returns the pixels it can cover.
    fn draw_character(
        &mut self,
        stage: &Stage,
        view: &View,
        light: &LightFrame,
        flash: f32,
        image: &mut Image,
    ) -> PixelRect {
        let all = PixelRect::full(view.width, view.height);
        let offset_m = NORMAL_OFFSET_TEXELS / self.character_shadow.texels_per_m.max(1.0);
        let positions = std::mem::take(&mut self.skinned_positions);
        let normals = std::mem::take(&mut self.skinned_normals);
        let body_albedo = |i: usize| stage.body_vertex_albedo[i];
        self.prepare_vertices(
            &stage.environment,
            view,
            light,
            &positions,
            &normals,
            &body_albedo,
            flash,
            offset_m,
        );
        self.draw(
            view,
            &stage.body.indices,
            Surface::Character,
            true,
            all,
            image,
        );
        self.skinned_positions = positions;
        self.skinned_normals = normals;
        // Every covered pixel centre lies in the hull of the projected vertices.
        view.screen_box(self.vertices.iter().map(|v| v.view))
    }

    /// Lights, transforms and draws the props and the backdrop into `image`, within
    /// `scissor`.
    fn draw_world(
        &mut self,
        stage: &Stage,
        view: &View,
        light: &LightFrame,
        flash: f32,
        scissor: PixelRect,
        image: &mut Image,
    ) {
        let offset_m = NORMAL_OFFSET_TEXELS / self.prop_shadow.texels_per_m.max(1.0);
        for (mesh, surface) in [
            (&stage.world.props, Surface::Prop),
            (&stage.world.backdrop, Surface::Backdrop),
        ] {
            let albedo = |i: usize| mesh.albedo[i];
            self.prepare_vertices(
                &stage.environment,
                view,
                light,
                &mesh.positions,
                &mesh.normals,
                &albedo,
                flash,
                offset_m,
            );
            self.draw(
                view,
                &mesh.indices,
                surface,
                surface == Surface::Prop,
                scissor,
                image,
            );
        }
    }
}

/// Pixels the ground pass takes at a time: a block's buffers live on the stack.
const LANES: usize = 16;

/// Each lane's pixel column from the block's first, as floats (`(block + j) as f32` would be a
/// conversion from `usize` per lane, which does not vectorise; the sum is exact below 2²⁴).
const LANE_X: [f32; LANES] = {
    let mut x = [0.0; LANES];
    let mut j = 0;
    while j < LANES {
        x[j] = j as f32;
        j += 1;
    }
    x
};

/// What the rays of [`LANES`] neighbouring pixels give before any lookup, one lane per pixel.
/// Filled without a branch, so that the compiler vectorises it.
#[derive(Debug, Default)]
struct RayLanes {
    /// The pixel's ray (not unit: optical z component 1), world axes.
    d: [[f32; LANES]; 3],
    len: [f32; LANES],
    /// What the ground shows where the ray meets it (meaningless for sky rays).
    texel: [GroundTexel; LANES],
    /// The ground point in the key light's frame.
    light: [[f32; LANES]; 3],
    /// The fog's transmittance to the ground point.
    fog: [f32; LANES],
}

/// A row of the ground pass's rays: pixel column `x`'s ray is `d0 + x·step` (world axes, optical
/// z component 1), from `eye`; in the key light's frame, `eye_light` + t·(`d0_light` +
/// x·`step_light`) at ray parameter t.
struct RowRays<'a> {
    d0: Vector3<f32>,
    step: Vector3<f32>,
    eye: Vector3<f32>,
    d0_light: [f32; 3],
    step_light: [f32; 3],
    eye_light: [f32; 3],
    inv_fx: f32,
    fog_per_m: f32,
    ground: &'a GroundModel,
}

impl RayLanes {
    /// The rays of the block of pixels from column `block_x`, every lane (lanes past the row's
    /// end, lanes drawn on already and the sky's get ground values nobody reads).
    #[inline]
    fn fill(&mut self, row: &RowRays<'_>, block_x: f32) {
        let RowRays { d0, step, eye, .. } = *row;
        for (j, lane_x) in LANE_X.iter().enumerate() {
            let xf = block_x + lane_x;
            let d = [d0.x + step.x * xf, d0.y + step.y * xf, d0.z + step.z * xf];
            let len_sq = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let len = len_sq.sqrt();
            let inv_dz = 1.0 / d[2];
            let t = -eye.z * inv_dz;
            let distance = t * len;
            // t = −eye_z / d_z, and with cos = −d_z / |d| the footprint
            // t·|d| / (f_x·cos) = t·|d|² / (f_x·(−d_z)). cos ≥ 0.05, i.e. −d_z ≥ 0.05·|d|;
            // grazing rays keep the footprint of 0.05.
            let footprint_m = if -d[2] >= 0.05 * len {
                -t * row.inv_fx * len_sq * inv_dz
            } else {
                distance * row.inv_fx * 20.0
            };
            self.texel[j] = row
                .ground
                .texel(eye.x + t * d[0], eye.y + t * d[1], footprint_m);
            for (k, &d_k) in d.iter().enumerate() {
                self.light[k][j] =
                    row.eye_light[k] + t * (row.d0_light[k] + xf * row.step_light[k]);
                self.d[k][j] = d_k;
            }
            self.fog[j] = fast_exp_neg(row.fog_per_m * distance);
            self.len[j] = len;
        }
    }
}

/// Whether a pixel of depth `z` (1/z per metre, 0 where nothing is) has been drawn on.
fn drawn(z: f32) -> bool {
    z > 0.0
}

impl CpuRenderer {
    /// Shades every pixel of `rect` nothing was drawn on: the ground where the pixel's ray
    /// goes down, else the sky. A pixel's ray is its row's first ray plus `x` steps (not a sum
    /// of steps), so its bits do not depend on the rect.
    ///
    /// A ground pixel needs one division, `1/d_z`, which gives the hit distance, the footprint
    /// and the depth (wet ground and water a second one, for the reflected ray). The pixels
    /// of a row are taken [`LANES`] at a time: their rays first (vectorised), then the lookups
    /// pixel by pixel, then the sRGB encoding (vectorised).
    fn ground_and_sky(
        &mut self,
        stage: &Stage,
        view: &View,
        light: &LightFrame,
        flash: f32,
        rect: PixelRect,
        image: &mut Image,
    ) {
        if rect.is_empty() {
            return;
        }
        let env = &stage.environment;
        let ground = &stage.world.ground;
        // Ambient on the flat ground; the key light is added per pixel with its shadow.
        let ambient = add(env.ambient(1.0), [flash; 3]);
        let direct = scale(env.key_rgb, env.key_dir[2].max(0.0));
        let step = view.world_from_optical.column(0).into_owned() / view.fx;
        let step_light = light.coords(&step);
        let eye = view.eye;
        let eye_light = light.coords(&eye);
        // The depth 1/t = −d_z / eye_z.
        let neg_inv_eye_z = -1.0 / eye.z;
        let flash_sky = [flash * 0.8, flash * 0.8, flash * 0.9];
        let [character, props] = [&self.character_shadow, &self.prop_shadow];
        let shadows = env.key_shadows;
        let mirror_wet = if env.indoor { 0.0 } else { 0.55 * env.wetness };
        let encoder = &self.encoder;
        let w = view.width;
        let mut rays = RayLanes::default();
        let mut linear = [0.0f32; 3 * LANES];
        let mut srgb = [0u8; 3 * LANES];
        for row in rect.y0..rect.y1 {
            let y = (row as f32 + 0.5 - view.cy) / view.fy;
            // World direction through the row's first pixel centre (optical z component 1).
            let d0 = view.world_from_optical * Vector3::new((0.5 - view.cx) / view.fx, y, 1.0);
            let row_rays = RowRays {
                d0,
                step,
                eye,
                d0_light: light.coords(&d0),
                step_light,
                eye_light,
                inv_fx: 1.0 / view.fx,
                fog_per_m: env.fog_per_m,
                ground,
            };
            for block in (rect.x0..rect.x1).step_by(LANES) {
                let lanes = LANES.min(rect.x1 - block);
                let first = row * w + block;
                let depth = &mut image.depth[first..first + lanes];
                let surface = &mut image.surface[first..first + lanes];
                let mut todo = [false; LANES];
                for (todo, z) in todo.iter_mut().zip(depth.iter()) {
                    *todo = !drawn(*z);
                }
                // Blocks the character, props or backdrop cover whole are left alone.
                if !todo.contains(&true) {
                    continue;
                }
                // 1. The rays, every lane (vectorised).
                rays.fill(&row_rays, block as f32);
                // 2. The lookups, pixel by pixel, in linear light.
                for j in 0..lanes {
                    if !todo[j] {
                        continue;
                    }
                    let d = Vector3::new(rays.d[0][j], rays.d[1][j], rays.d[2][j]);
                    let colour = if d.z < -1e-6 {
                        let (albedo, water) = ground.albedo_of(rays.texel[j]);
                        let lit = if shadows {
                            let [u, v, h] = [0, 1, 2].map(|k| rays.light[k][j]);
                            character
                                .visibility(u, v, h)
                                .min(props.ground_visibility(u, v))
                        } else {
                            1.0
                        };
                        let mut colour = mul(
                            albedo,
                            [
                                ambient[0] + lit * direct[0],
                                ambient[1] + lit * direct[1],
                                ambient[2] + lit * direct[2],
                            ],
                        );
                        let mirror = if water { 1.0 } else { mirror_wet };
                        if mirror > 0.0 {
                            let inv_len = 1.0 / rays.len[j];
                            let cos = -d.z * inv_len;
                            let fresnel = 0.02 + 0.98 * (1.0 - cos).powi(5);
                            let reflected = env.sky([d.x * inv_len, d.y * inv_len, cos]);
                            colour = mix(colour, add(reflected, flash_sky), fresnel * mirror);
                        }
                        depth[j] = d.z * neg_inv_eye_z;
                        surface[j] = Surface::Ground as u8;
                        mix(env.horizon_rgb, colour, rays.fog[j])
                    } else {
                        let inv_len = 1.0 / rays.len[j];
                        add(env.sky((d * inv_len).into()), flash_sky)
                    };
                    linear[3 * j..3 * j + 3].copy_from_slice(&colour);
                }
                // 3. sRGB, every lane (vectorised), then into the image where the pass drew.
                encoder.encode_slice(&linear, &mut srgb);
                let rgb = &mut image.rgb[3 * first..3 * (first + lanes)];
                for j in (0..lanes).filter(|&j| todo[j]) {
                    rgb[3 * j..3 * j + 3].copy_from_slice(&srgb[3 * j..3 * j + 3]);
                }
            }
        }
    }
}

/// Rain streaks or snowflakes in a box in front of the camera, falling with time and slanted
/// by the wind, each hidden where the scene is nearer. Whether there are any.
fn precipitation(
    env: &Environment,
    seed: u64,
    time_s: f64,
    view: &View,
    image: &mut Image,
) -> bool {
    let (kind, rate) = env.precipitation;
    if kind == Precipitation::None || rate <= 0.0 || env.indoor {
        return false;
    }
    let rain = kind == Precipitation::Rain;
    let count = if rain {
        (rate * 120.0).clamp(300.0, 3000.0)
    } else {
        (rate * 900.0).clamp(400.0, 3000.0)
    } as u64;
    let fall_m_per_s = if rain { 7.0 } else { 1.0 };
    let box_m = 16.0f32;
    let forward = view.world_from_optical.column(2).into_owned();
    let centre = view.eye + forward * (box_m * 0.5);
    let t = time_s as f32;
    let wind = env.wind_m_per_s.min(20.0);
    let tint = add(env.sky_ambient_rgb, scale(env.key_rgb, 0.3));
    let lum = (0.2 + tint[1]).min(1.0);
    let (colour, alpha) = if rain {
        (
            [200u8, 205, 215].map(|c| (f32::from(c) * lum) as u8),
            0.35f32,
        )
    } else {
        (
            [245u8, 247, 250].map(|c| (f32::from(c) * (0.3 + lum)).min(255.0) as u8),
            0.85,
        )
    };
    for k in 0..count {
        let r = |j: u64| unit2(seed ^ 0x9ec1, k * 4 + j);
        let wrap = |v: f32| v - floor(v / box_m) * box_m;
        let phase = r(3) * std::f32::consts::TAU;
        let sway = if rain {
            0.0
        } else {
            0.3 * (t * 1.3 + phase).sin()
        };
        let local = [
            wrap(r(0) * box_m + wind * t + sway - centre.x) - box_m / 2.0,
            wrap(r(1) * box_m - centre.y) - box_m / 2.0,
            wrap(r(2) * box_m - fall_m_per_s * t - centre.z) - box_m / 2.0,
        ];
        let p = centre + Vector3::from(local);
        if p.z < 0.0 {
            continue;
        }
        let streak = if rain {
            Vector3::new(wind, 0.0, -fall_m_per_s) * 0.035
        } else {
            Vector3::zeros()
        };
        let (a, b) = (view.view_of(&p), view.view_of(&(p + streak)));
        if a[2] < NEAR_M || b[2] < NEAR_M {
            continue;
        }
        let (sa, sb) = (view.project(a), view.project(b));
        let steps = (sb.x - sa.x)
            .abs()
            .max((sb.y - sa.y).abs())
            .ceil()
            .clamp(1.0, 64.0) as usize;
        let radius = if rain {
            0
        } else {
            (0.015 * view.fx * sa.inv_z).clamp(0.0, 2.0) as i64
        };
        for s in 0..=steps {
            let f = s as f32 / steps as f32;
            let (x, y) = (sa.x + (sb.x - sa.x) * f, sa.y + (sb.y - sa.y) * f);
            let iz = sa.inv_z + (sb.inv_z - sa.inv_z) * f;
            let (x0, y0) = (floor(x) as i64, floor(y) as i64);
            for dy in -radius..=radius {
                for dx in -radius..=radius {
                    let (px, py) = (x0 + dx, y0 + dy);
                    if px < 0 || py < 0 || px >= view.width as i64 || py >= view.height as i64 {
                        continue;
                    }
                    let i = py as usize * view.width + px as usize;
                    if image.depth[i] > iz {
                        continue;
                    }
                    for (old, new) in image.rgb[3 * i..3 * i + 3].iter_mut().zip(colour) {
                        let o = f32::from(*old);
                        *old = (o + (f32::from(new) - o) * alpha).round() as u8;
                    }
                }
            }
        }
    }
    true
}

/// Edge-directed smoothing at geometric edges: where a pixel and a neighbour show different
/// surfaces, or the same surface at clearly different depths (a limb in front of the body), it
/// is blended with its neighbours across the edge's luma gradient (a light FXAA). Silhouettes
/// stop stair-stepping and crawling; textures and flat areas are untouched.
fn antialias(image: &mut Image, source: &mut Vec<u8>) {
    source.clear();
    source.extend_from_slice(&image.rgb);
    let all = PixelRect::full(image.width as usize, image.height as usize);
    antialias_within(image, source, all);
}

/// [`antialias`] within `rect`, from the unfiltered colours `source` (the same image's): every
/// pixel of `rect` is written, smoothed or as `source` has it.
#[expect(
    clippy::needless_bitwise_bool,
    reason = "the edge test without a branch, so that it vectorises"
)]
fn antialias_within(image: &mut Image, source: &[u8], rect: PixelRect) {
    /// Pixels whose edge test is made at a time, without a branch (so vectorised).
    const BLOCK: usize = 64;
    let (w, h) = (image.width as usize, image.height as usize);
    let luma = |i: usize| {
        i32::from(source[3 * i]) * 2
            + i32::from(source[3 * i + 1]) * 5
            + i32::from(source[3 * i + 2])
    };
    // The ground is one plane and the sky has no depth: only objects can hide parts of
    // themselves, so only their pixels need the depth test.
    let (sky, ground) = (Surface::Sky as u8, Surface::Ground as u8);
    let depth_edge = |a: f32, b: f32| (a - b).abs() > 0.06 * a.max(b);
    let (x_lo, x_hi) = (rect.x0.max(1), rect.x1.min(w.saturating_sub(1)));
    let mut keep = [false; BLOCK];
    for y in rect.y0..rect.y1 {
        let row = y * w;
        image.rgb[3 * (row + rect.x0)..3 * (row + rect.x1)]
            .copy_from_slice(&source[3 * (row + rect.x0)..3 * (row + rect.x1)]);
        if y == 0 || y + 1 >= h {
            continue;
        }
        for start in (x_lo..x_hi).step_by(BLOCK) {
            let n = BLOCK.min(x_hi - start);
            // This row from one pixel left of the block to one right of it; the rows above
            // and below over the block.
            let i0 = row + start;
            let (surface, depth) = (&image.surface, &image.depth);
            let (mid, up, down) = (
                &surface[i0 - 1..=i0 + n],
                &surface[i0 - w..i0 - w + n],
                &surface[i0 + w..i0 + w + n],
            );
            let (depth_mid, depth_up, depth_down) = (
                &depth[i0 - 1..=i0 + n],
                &depth[i0 - w..i0 - w + n],
                &depth[i0 + w..i0 + w + n],
            );
            // A pixel is kept where its four neighbours show its surface and, on an object,
            // none is at a clearly different depth.
            for k in 0..n {
                let s = mid[k + 1];
                let same = (s == mid[k + 2]) & (s == mid[k]) & (s == down[k]) & (s == up[k]);
                let z = depth_mid[k + 1];
                let edge = depth_edge(z, depth_mid[k + 2])
                    | depth_edge(z, depth_mid[k])
                    | depth_edge(z, depth_down[k])
                    | depth_edge(z, depth_up[k]);
                keep[k] = same & ((s == sky) | (s == ground) | !edge);
            }
            for i in (0..n).filter(|&k| !keep[k]).map(|k| i0 + k) {
                let (m, n, s, e, west) =
                    (luma(i), luma(i - w), luma(i + w), luma(i + 1), luma(i - 1));
                let vertical_edge = (e + west - 2 * m).abs() >= (n + s - 2 * m).abs();
                let (a, b) = if vertical_edge {
                    (i - 1, i + 1)
                } else {
                    (i - w, i + w)
                };
                for c in 0..3 {
                    let v = 2 * u16::from(source[3 * i + c])
                        + u16::from(source[3 * a + c])
                        + u16::from(source[3 * b + c]);
                    image.rgb[3 * i + c] = ((v + 2) / 4) as u8;
                }
            }
        }
    }
}

#[cfg(test)]
#[path = "cpu_tests.rs"]
mod tests;
