//! Domain randomisation: cheap variations of the picture that are known to help a model trained
//! on synthetic frames transfer to real footage — colour jitter on the clothes, props and
//! ground, camera sensor noise, motion blur, a jittered H.264 quality (per capture video) and a
//! jittered JPEG quality (per clip's rawframes). `[randomise]` in the dataset spec sets them
//! ([`Randomise`], every key with a modest default); the capture bag records them (the
//! `autoact.dataset` metadata record's `randomise` key), so `autoact render` draws the same
//! pictures as `generate` (the defaults for a bag without the key; none with `--no-randomise`).
//!
//! - Every draw comes from a ChaCha8 stream seeded by the scene's stream (the stage's seed) or
//!   the capture (the sensor noise's bytes from a SplitMix64 stream keyed the same way), so the
//!   same spec and seed give byte-identical pictures.
//! - Nothing here moves a label: the colour jitter changes albedo only (not geometry), and the
//!   image effects ([`ImageEffects`]) change the colour bytes of a frame after its depth,
//!   surfaces and annotations are made.
//! - Motion blur averages a frame with the previous frame's picture (as rendered, before its
//!   own blur and noise) with a weight drawn per scene; it never reaches across a keyframe (a
//!   clip boundary, a cut) or a scene change. It blurs the picture only: the joints and boxes
//!   stay those of the frame's own instant.

use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::Stage;
use crate::dataset::randomise::Randomise;
use crate::hash::{hash2, mix64};
use crate::scene::body_mesh::Material;
use crate::scene::color::Rgb;

impl Randomise {
    /// Jitters the colours of `stage`'s clothes, props and ground (one draw each per scene,
    /// from the stage's seed). Geometry, and so every label, is unchanged.
    pub fn jitter_stage(&self, stage: &mut Stage) {
        if self.hue_jitter_deg == 0.0
            && self.saturation_jitter == 0.0
            && self.brightness_jitter == 0.0
        {
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(hash2(stage.seed, 0x0071_77e5));
        let mut draw = || ColourJitter::draw(self, &mut rng);
        let (top, bottom, shoes, props, floor, surround) =
            (draw(), draw(), draw(), draw(), draw(), draw());
        for (&m, c) in stage
            .body
            .materials
            .iter()
            .zip(&mut stage.body_vertex_albedo)
        {
            match m {
                Material::Top => *c = top.apply(*c),
                Material::Bottom => *c = bottom.apply(*c),
                Material::Shoes => *c = shoes.apply(*c),
                _ => {}
            }
        }
        for (m, jitter) in [
            (Material::Top, top),
            (Material::Bottom, bottom),
            (Material::Shoes, shoes),
        ] {
            let c = &mut stage.body_albedo[m as usize];
            *c = jitter.apply(*c);
        }
        for c in &mut stage.world.props.albedo {
            *c = props.apply(*c);
        }
        stage.world.ground.floor.map_texels(|c| floor.apply(c));
        stage
            .world
            .ground
            .surround
            .map_texels(|c| surround.apply(c));
    }
}

/// One drawn colour change: a hue rotation about the grey axis, a saturation and a brightness
/// factor. Linear in the colour (so a texture's mip levels stay its averages), clamped to
/// `[0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColourJitter {
    /// Hue rotation, radians.
    pub hue_rad: f32,
    /// Saturation factor.
    pub saturation: f32,
    /// Brightness factor.
    pub brightness: f32,
}

impl ColourJitter {
    fn draw(r: &Randomise, rng: &mut impl Rng) -> ColourJitter {
        let mut sym = |x: f64| {
            if x > 0.0 {
                rng.random_range(-x..=x) as f32
            } else {
                0.0
            }
        };
        ColourJitter {
            hue_rad: sym(r.hue_jitter_deg).to_radians(),
            saturation: 1.0 + sym(r.saturation_jitter),
            brightness: 1.0 + sym(r.brightness_jitter),
        }
    }

    /// The jittered colour of linear `c`.
    #[must_use]
    pub fn apply(&self, c: Rgb) -> Rgb {
        let grey = (c[0] + c[1] + c[2]) / 3.0;
        let d = [c[0] - grey, c[1] - grey, c[2] - grey];
        // Rodrigues' rotation of the chroma `d` (orthogonal to the grey axis k) about k.
        let (s, co) = self.hue_rad.sin_cos();
        let k = 1.0 / 3f32.sqrt();
        let cross = [k * (d[2] - d[1]), k * (d[0] - d[2]), k * (d[1] - d[0])];
        let limit = if c.iter().all(|&v| v <= 1.0) {
            1.0
        } else {
            f32::MAX
        };
        std::array::from_fn(|i| {
            let rotated = d[i] * co + cross[i] * s;
            ((grey + rotated * self.saturation) * self.brightness).clamp(0.0, limit)
        })
    }
}

/// One scene's drawn image effects.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneEffects {
    /// Sensor noise's standard deviation, fraction of full scale.
    pub noise_sigma: f32,
    /// The previous frame's weight.
    pub blur_weight: f32,
}

impl SceneEffects {
    /// The effects of the scene whose stage seed is `seed`.
    #[must_use]
    pub fn draw(r: &Randomise, seed: u64) -> SceneEffects {
        let mut rng = ChaCha8Rng::seed_from_u64(hash2(seed, 0x1e5f));
        let mut pick = |[lo, hi]: [f64; 2]| {
            if hi > lo {
                rng.random_range(lo..=hi) as f32
            } else {
                lo as f32
            }
        };
        let noise_sigma = pick(r.sensor_noise);
        let blur_weight = pick(r.motion_blur);
        SceneEffects {
            noise_sigma,
            blur_weight,
        }
    }
}

/// The image effects over a stream of frames in output order: keeps the previous frame's
/// picture for the blur and a noise buffer. One per render.
#[derive(Debug, Default)]
pub struct ImageEffects {
    config: Option<Randomise>,
    /// The seed of the scene whose effects are in `scene`.
    scene_seed: Option<u64>,
    scene: Option<SceneEffects>,
    /// The previous frame's picture before its effects (empty after a cut).
    previous: Vec<u8>,
    current: Vec<u8>,
    /// Noise offset (8-bit units) by noise byte, for the scene's sigma.
    noise_table: Option<Box<[i16; 256]>>,
    /// Scratch: the noise offset of every byte of a frame.
    noise_offsets: Vec<i16>,
}

impl ImageEffects {
    /// Effects as `config` says.
    #[must_use]
    pub fn new(config: &Randomise) -> ImageEffects {
        ImageEffects {
            config: Some(config.clone()),
            ..ImageEffects::default()
        }
    }

    /// Applies the effects to frame `k`'s picture `rgb` (sRGB bytes) of the scene seeded
    /// `scene_seed`; `cut` says the frame starts a shot (a keyframe), so it is not blurred
    /// with the one before.
    pub fn apply(&mut self, k: u64, scene_seed: u64, cut: bool, rgb: &mut [u8]) {
        let Some(config) = &self.config else {
            return;
        };
        if self.scene_seed != Some(scene_seed) {
            let effects = SceneEffects::draw(config, scene_seed);
            self.scene_seed = Some(scene_seed);
            self.scene = Some(effects);
            self.previous.clear();
            self.noise_table = Some(noise_table(effects.noise_sigma));
        }
        let Some(effects) = self.scene else {
            return;
        };
        if cut {
            self.previous.clear();
        }
        if effects.blur_weight > 0.0 {
            self.current.clear();
            self.current.extend_from_slice(rgb);
            if self.previous.len() == rgb.len() {
                blend(rgb, &self.previous, effects.blur_weight);
            }
            std::mem::swap(&mut self.previous, &mut self.current);
        }
        if effects.noise_sigma > 0.0
            && let Some(table) = &self.noise_table
        {
            add_noise(
                rgb,
                table,
                hash2(scene_seed ^ 0x0153, k),
                &mut self.noise_offsets,
            );
        }
    }
}

/// Adds `table[byte]` to every byte of `rgb`, the bytes from the SplitMix64 stream that starts
/// at `key` (eight per 64-bit value); `offsets` is scratch. A counter-based stream, not ChaCha8,
/// and in two passes: the offsets looked up (the only part that cannot run on vectors), then
/// added with saturation over the whole frame at once (the compiler vectorises it). Per byte
/// the one-pass loop cost about 18 instructions.
fn add_noise(rgb: &mut [u8], table: &[i16; 256], key: u64, offsets: &mut Vec<i16>) {
    offsets.resize(rgb.len(), 0);
    for (j, chunk) in offsets.chunks_mut(8).enumerate() {
        let bits = mix64(key.wrapping_add((j as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)));
        for (o, b) in chunk.iter_mut().zip(bits.to_le_bytes()) {
            *o = table[usize::from(b)];
        }
    }
    for (v, &o) in rgb.iter_mut().zip(offsets.iter()) {
        *v = (i16::from(*v) + o).clamp(0, 255) as u8;
    }
}

/// `out = (1 − w)·out + w·previous`, rounded.
fn blend(out: &mut [u8], previous: &[u8], w: f32) {
    let wp = (w * 256.0).round() as u16;
    let wc = 256 - wp;
    for (o, &p) in out.iter_mut().zip(previous) {
        *o = ((u16::from(*o) * wc + u16::from(p) * wp + 128) >> 8) as u8;
    }
}

/// The noise offset (8-bit units) for every uniform noise byte: the normal distribution's
/// quantile at the byte's midpoint, `(b + ½) / 256`, times `sigma` of full scale, rounded — a
/// Gaussian noise from one byte per channel.
fn noise_table(sigma: f32) -> Box<[i16; 256]> {
    let scale = f64::from(sigma) * 255.0;
    Box::new(std::array::from_fn(|b| {
        (normal_quantile((b as f64 + 0.5) / 256.0) * scale).round() as i16
    }))
}

/// The standard normal distribution's quantile at `p` in (0, 1) (Acklam's rational
/// approximation, relative error under 1.2e-9).
fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.024_25 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.024_25 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn colour_jitter_keeps_grey_and_rotates_hue() {
        let j = ColourJitter {
            hue_rad: 120f32.to_radians(),
            saturation: 1.0,
            brightness: 1.0,
        };
        let grey = j.apply([0.4, 0.4, 0.4]);
        assert!(grey.iter().all(|&v| (v - 0.4).abs() < 1e-6), "{grey:?}");
        // A third of a turn takes red to green.
        let red = j.apply([0.6, 0.2, 0.2]);
        assert!(red[1] > red[0] && red[1] > red[2], "{red:?}");
    }

    #[test]
    fn the_normal_quantile_is_right() {
        assert!(normal_quantile(0.5).abs() < 1e-9);
        assert!((normal_quantile(0.975) - 1.959_964).abs() < 1e-5);
        assert!((normal_quantile(0.001) + 3.090_232).abs() < 1e-5);
    }

    #[test]
    fn noise_has_the_drawn_spread_and_is_reproducible() {
        let config = Randomise {
            sensor_noise: [0.02, 0.02],
            motion_blur: [0.0, 0.0],
            ..Randomise::default()
        };
        let frame = vec![128u8; 3 * 64 * 64];
        let mut a = frame.clone();
        ImageEffects::new(&config).apply(3, 11, true, &mut a);
        let mut b = frame.clone();
        ImageEffects::new(&config).apply(3, 11, true, &mut b);
        assert_eq!(a, b);
        let n = a.len() as f64;
        let var = a
            .iter()
            .map(|&v| (f64::from(v) - 128.0).powi(2))
            .sum::<f64>()
            / n;
        let sd = var.sqrt() / 255.0;
        assert!((sd - 0.02).abs() < 0.002, "{sd}");
        let mut c = frame.clone();
        ImageEffects::new(&config).apply(4, 11, true, &mut c);
        assert_ne!(a, c, "each frame draws its own noise");
    }

    #[test]
    fn blur_mixes_in_the_previous_frame_but_not_across_a_cut() {
        let config = Randomise {
            sensor_noise: [0.0, 0.0],
            motion_blur: [0.5, 0.5],
            ..Randomise::default()
        };
        let mut fx = ImageEffects::new(&config);
        let mut first = vec![0u8; 12];
        fx.apply(0, 1, true, &mut first);
        assert_eq!(first, vec![0u8; 12]);
        let mut second = vec![200u8; 12];
        fx.apply(1, 1, false, &mut second);
        assert_eq!(second, vec![100u8; 12]);
        let mut cut = vec![50u8; 12];
        fx.apply(2, 1, true, &mut cut);
        assert_eq!(cut, vec![50u8; 12]);
        // A new scene starts afresh too.
        let mut other = vec![10u8; 12];
        fx.apply(3, 2, false, &mut other);
        assert_eq!(other, vec![10u8; 12]);
    }
}
