//! Rendering a capture: the character on its rig, in its drawn scene, seen by the capture's
//! camera — the embedded stand-in for the paper's game engine.
//!
//! - [`Renderer`] is the seam a GPU backend would implement; [`cpu::CpuRenderer`] is the
//!   embedded default, pure Rust and deterministic (the same inputs give the same bytes).
//! - A [`Stage`] is one scene made ready to draw: its [`environment::Environment`] (light, sky,
//!   fog, weather), its [`world::World`] (ground, props, backdrop) and the character's
//!   [`crate::scene::body_mesh::BodyMesh`]. Build it once per scene.
//! - A [`FrameInput`] is what changes per frame: the camera and the body's pose.
//! - [`timeline`] reads a capture bag into stages and frames; [`annotate`] projects the
//!   character's keypoints and finds its box in the rendered mask.

pub mod annotate;
pub mod blender;
pub mod cpu;
pub mod job;
pub mod passes;
pub mod randomise;
pub(crate) mod raster;
pub mod session;
pub mod world;

#[cfg(test)]
mod look_tests;

use nalgebra::Isometry3;

use crate::camera::Intrinsics;
use crate::scene::Scene;
use crate::scene::body_mesh::{BodyMesh, BodyShape, Material, albedo_srgb};
use crate::scene::color::{Rgb, linear_from_srgb};
use crate::scene::environment::Environment;
use crate::skeleton::fk::{BonePose, WorldPose, forward};
use crate::skeleton::rig::Rig;
use world::World;

/// Draws frames. Implementations keep their own scratch buffers; use one per thread.
pub trait Renderer {
    /// Renders `frame` of `stage` into `image`, resizing it to the camera's resolution.
    fn render(&mut self, stage: &Stage, frame: &FrameInput<'_>, image: &mut Image);
}

/// One scene, ready to draw.
#[derive(Debug, Clone)]
pub struct Stage {
    /// Distinguishes stages for per-renderer caches; unique within a run.
    pub id: u64,
    /// Seeds the procedural detail (backdrop layout, textures, lightning, rain).
    pub seed: u64,
    /// Light, sky, fog and weather.
    pub environment: Environment,
    /// Ground, props and backdrop.
    pub world: World,
    /// The character's body at rest.
    pub body: BodyMesh,
    /// Linear albedo per body [`Material`] (indexed by `Material as usize`).
    pub body_albedo: Vec<Rgb>,
    /// Linear albedo per body vertex: its material's, with the clothes' pattern (stripes, a
    /// two-tone top, a chest print, colour-blocked sleeves, a fabric's grain) drawn from the
    /// stage's seed.
    pub body_vertex_albedo: Vec<Rgb>,
    /// The rest pose the body mesh was built in.
    pub rest_pose: WorldPose,
}

impl Stage {
    /// Prepares `scene` for drawing: its character (the scene's [`crate::scene::Look`] on
    /// `rig`), environment and world. `seed` drives procedural detail; `id` must differ between
    /// stages of one run.
    #[must_use]
    pub fn new(rig: &Rig, scene: &Scene, seed: u64, id: u64) -> Stage {
        let character = scene.look.character(rig);
        let environment = Environment::from_scene(scene, seed);
        let world = World::build(&scene.location, &environment, seed);
        let body = BodyMesh::build(rig, &character, &BodyShape::from_look(&scene.look));
        let body_albedo: Vec<Rgb> = Material::ALL
            .iter()
            .map(|&m| linear_from_srgb(albedo_srgb(&scene.look, m)))
            .collect();
        let body_vertex_albedo = clothes_pattern(&body, &body_albedo, seed);
        let rest_pose = forward(rig, &character, &BonePose::rest(rig), 1.0);
        Stage {
            id,
            seed,
            environment,
            world,
            body,
            body_albedo,
            body_vertex_albedo,
            rest_pose,
        }
    }
}

/// How a top is patterned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum TopPattern {
    Plain,
    Stripes,
    TwoTone,
    /// A print on the chest's front.
    ChestPrint,
    /// Sleeves (the top's part of each arm) in another hue.
    ColourBlock,
}

/// The chest print's extent: heights as fractions of the stature, and its half-width as one.
const CHEST_PRINT_Z: [f32; 2] = [0.64, 0.76];
const CHEST_PRINT_HALF_WIDTH: f32 = 0.05;

/// Per-vertex albedo of `body`: its material's (`albedo`, per material) with a pattern on the
/// clothes chosen by `seed` — a top plain, striped (bands 7 cm high), two-tone (a yoke over
/// the shoulders) in a contrasting shade of its colour, with a print on the chest's front (a
/// light, dark or contrasting patch), or colour-blocked (the sleeves in another hue: the top's
/// colour with its channels turned, or a strong colour on a grey top); and a fabric's grain (±6 % per vertex) on tops and
/// trousers. Per-vertex colours only: the renderer interpolates them as it does any albedo, at
/// no extra cost per pixel.
fn clothes_pattern(body: &BodyMesh, albedo: &[Rgb], seed: u64) -> Vec<Rgb> {
    use crate::hash::unit2;
    let top = albedo[Material::Top as usize];
    // Drawn from the seed and the top's colour, so two characters of one seed differ too.
    let key = crate::hash::hash2(
        seed ^ 0xc107,
        u64::from(top[0].to_bits() ^ top[1].to_bits()),
    );
    let pattern = match key % 5 {
        0 => TopPattern::Plain,
        1 => TopPattern::Stripes,
        2 => TopPattern::TwoTone,
        3 => TopPattern::ChestPrint,
        _ => TopPattern::ColourBlock,
    };
    let light = 0.2126 * top[0] + 0.7152 * top[1] + 0.0722 * top[2];
    // The contrasting shade: darker for a light top, lighter for a dark one.
    let contrast = if light > 0.25 {
        top.map(|c| c * 0.45)
    } else {
        top.map(|c| c + (0.55 - c) * 0.6)
    };
    let stature = body
        .rest_positions_m
        .iter()
        .map(|p| p[2])
        .fold(0.0f32, f32::max)
        .max(0.5);
    // The print: a near-black on a light top, a near-white on a dark one, or the contrasting
    // shade, drawn with the pattern.
    let print = match ((key / 5) % 2, light > 0.25) {
        (0, true) => [0.03, 0.03, 0.035],
        (0, false) => [0.8, 0.8, 0.78],
        _ => contrast,
    };
    // Another hue: the channels turned, or for a nearly grey top a strong colour (red, navy,
    // green or mustard, linear).
    let chroma =
        top.iter().fold(0.0f32, |a, &c| a.max(c)) - top.iter().fold(1.0f32, |a, &c| a.min(c));
    let blocked = if chroma > 0.25 {
        [top[2], top[0], top[1]]
    } else {
        [
            [0.5, 0.05, 0.04],
            [0.03, 0.08, 0.35],
            [0.05, 0.3, 0.1],
            [0.6, 0.45, 0.05],
        ][((key / 10) % 4) as usize]
    };
    let on_torso = |i: usize| {
        body.parts
            .iter()
            .find(|p| p.vertices.contains(&i))
            .is_some_and(|p| p.name == "torso")
    };
    body.materials
        .iter()
        .zip(&body.rest_positions_m)
        .enumerate()
        .map(|(i, (&m, p))| {
            let base = albedo[m as usize];
            let grain = 0.94 + 0.12 * unit2(seed ^ 0xfab, i as u64);
            match m {
                Material::Top => {
                    let c = match pattern {
                        TopPattern::Stripes if (p[2] / 0.07).floor() as i64 % 2 == 0 => contrast,
                        TopPattern::TwoTone if p[2] > 0.78 * stature => contrast,
                        TopPattern::ChestPrint
                            if p[1] > 0.0
                                && p[0].abs() < CHEST_PRINT_HALF_WIDTH * stature
                                && (CHEST_PRINT_Z[0] * stature..CHEST_PRINT_Z[1] * stature)
                                    .contains(&p[2])
                                && on_torso(i) =>
                        {
                            print
                        }
                        TopPattern::ColourBlock if !on_torso(i) => blocked,
                        _ => base,
                    };
                    c.map(|v| v * grain)
                }
                Material::Bottom => base.map(|v| v * grain),
                _ => base,
            }
        })
        .collect()
}

/// A camera for one frame: where it is and its lens, at the resolution to render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Pose of the optical frame (z forward, x right, y down) in the world.
    pub world_from_optical: Isometry3<f64>,
    /// The lens, in the continuous pixel convention of [`crate::camera::Intrinsics`].
    pub intrinsics: Intrinsics,
}

/// What changes from frame to frame.
#[derive(Debug, Clone, Copy)]
pub struct FrameInput<'a> {
    /// The camera.
    pub camera: Camera,
    /// The character's posed skeleton (world rotations and joint positions).
    pub pose: &'a WorldPose,
    /// Seconds since the scene started (falling rain, lightning).
    pub time_s: f64,
}

/// A rendered frame: colour, depth and what each pixel shows.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Image {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// sRGB, 3 bytes per pixel, row-major from the top-left.
    pub rgb: Vec<u8>,
    /// 1 / view depth (metres⁻¹) of the surface seen at each pixel; 0 for the sky.
    pub depth: Vec<f32>,
    /// [`world::Surface`] per pixel, as its `u8`.
    pub surface: Vec<u8>,
}

impl Image {
    /// An empty image of the given size.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Image {
        let mut image = Image::default();
        image.resize(width, height);
        image
    }

    /// Resizes and clears depth and surface (colour is overwritten by every render).
    pub fn resize(&mut self, width: u32, height: u32) {
        let n = width as usize * height as usize;
        self.width = width;
        self.height = height;
        self.rgb.resize(3 * n, 0);
        self.depth.clear();
        self.depth.resize(n, 0.0);
        self.surface.clear();
        self.surface.resize(n, world::Surface::Sky as u8);
    }
}
