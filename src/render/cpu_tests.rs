//! A static shot's frames drawn from its still frame are the bits of whole frames, the ground
//! pass puts every ground pixel on the ground, and the props' shadow baked for the ground is the
//! shadow map's.

use nalgebra::{Point3, UnitQuaternion, Vector3};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::CpuRenderer;
use crate::camera::{CameraPose, Intrinsics};
use crate::render::{Camera, FrameInput, Image, Renderer, Stage};
use crate::scene::SceneConfig;
use crate::scene::location::Location;
use crate::scene::sky::ClockTime;
use crate::scene::weather::Weather;
use crate::skeleton::character::Character;
use crate::skeleton::fk::{BonePose, WorldPose, forward};
use crate::skeleton::rig::Rig;

/// A stage at the `location`-th built-in location with the `weather`-th weather at `clock`,
/// and its character.
fn stage(
    rig: &Rig,
    location: usize,
    weather: usize,
    clock: ClockTime,
    seed: u64,
) -> (Stage, Character) {
    let pool = Location::builtin_pool();
    let config = SceneConfig {
        weather_weights: [(Weather::ALL[weather % Weather::ALL.len()], 1.0)]
            .into_iter()
            .collect(),
        clock_weights: [(clock, 1.0)].into_iter().collect(),
        locations: vec![pool[location % pool.len()].clone()],
        ..SceneConfig::default()
    };
    let scene = config
        .draw(&mut ChaCha8Rng::seed_from_u64(seed), &[])
        .expect("a valid config draws");
    (Stage::new(rig, &scene, seed, 7), scene.look.character(rig))
}

/// Frame `k` of a moving body: every bone swings, the root walks.
fn pose(rig: &Rig, character: &Character, k: usize, swing_rad: f64) -> WorldPose {
    let mut p = BonePose::rest(rig);
    for (b, q) in p.local_rotations.iter_mut().enumerate() {
        let phase = k as f64 * 0.7 + b as f64;
        let axis = Vector3::new(phase.sin(), phase.cos(), (2.0 * phase).sin());
        *q = UnitQuaternion::from_scaled_axis(axis.normalize() * swing_rad * (phase * 1.3).sin());
    }
    p.root_translation_m = Vector3::new(0.15 * k as f64, 0.05 * k as f64, 0.0);
    forward(rig, character, &p, 1.0)
}

/// Whether two frames are the same bits; else the first pixel that differs.
fn same(a: &Image, b: &Image) -> Result<(), String> {
    let first =
        |x: &[u8], y: &[u8], per: usize| x.iter().zip(y).position(|(p, q)| p != q).map(|i| i / per);
    if let Some(i) = first(&a.rgb, &b.rgb, 3) {
        return Err(format!("colour differs at pixel {i}"));
    }
    if let Some(i) = a
        .depth
        .iter()
        .zip(&b.depth)
        .position(|(p, q)| p.to_bits() != q.to_bits())
    {
        return Err(format!("depth differs at pixel {i}"));
    }
    if let Some(i) = first(&a.surface, &b.surface, 1) {
        return Err(format!("surface differs at pixel {i}"));
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Law: a static shot drawn by one renderer (every frame after the first from the still
    /// frame) is, bit for bit, the same frames drawn whole by fresh renderers; whatever the
    /// location, weather (rain, snow, lightning), time of day, camera and motion.
    #[test]
    fn a_still_frame_changes_no_bit(
        location in 0usize..16,
        weather in 0usize..14,
        clock in prop::sample::select(vec![ClockTime::DAWN, ClockTime::NOON, ClockTime::EVENING, ClockTime::MIDNIGHT]),
        seed in 0u64..1000,
        distance_m in 1.5f64..14.0,
        height_m in 0.2f64..5.0,
        azimuth in 0.0f64..std::f64::consts::TAU,
        swing_rad in 0.0f64..0.8,
        start_s in 0.0f64..30.0,
    ) {
        let rig = Rig::standard();
        let (stage, character) = stage(&rig, location, weather, clock, seed);
        let eye = Point3::new(distance_m * azimuth.cos(), distance_m * azimuth.sin(), height_m);
        let camera = Camera {
            world_from_optical: CameraPose::looking_at(eye, Point3::new(0.3, 0.1, 0.9))
                .isometry_world_from_optical(),
            intrinsics: Intrinsics::from_horizontal_fov(96, 72, 60.0).expect("a lens"),
        };
        let mut reusing = CpuRenderer::new();
        let mut reused = 0;
        for k in 0..5 {
            let posed = pose(&rig, &character, k, swing_rad);
            let input = FrameInput { camera, pose: &posed, time_s: start_s + k as f64 / 30.0 };
            let (mut a, mut b) = (Image::default(), Image::default());
            reusing.render(&stage, &input, &mut a);
            reused += usize::from(reusing.still.is_some() && k > 0);
            CpuRenderer::new().render(&stage, &input, &mut b);
            prop_assert!(same(&a, &b).is_ok(), "frame {}: {}", k, same(&a, &b).unwrap_err());
        }
        // Only lightning draws every frame whole.
        prop_assert!(reused > 0 || stage.environment.lightning);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Law: every ground pixel's depth puts the point it shows on the ground (z = 0), whether
    /// the camera is rolled or not (a row's rays then differ in height).
    #[test]
    fn ground_pixels_lie_on_the_ground_with_and_without_roll(
        location in 0usize..16,
        seed in 0u64..1000,
        distance_m in 1.5f64..14.0,
        height_m in 0.2f64..5.0,
        azimuth in 0.0f64..std::f64::consts::TAU,
        roll_rad in prop::sample::select(vec![0.0, 0.002, -0.3, 0.7]),
    ) {
        let rig = Rig::standard();
        let (stage, character) = stage(&rig, location, 0, ClockTime::NOON, seed);
        let eye = Point3::new(distance_m * azimuth.cos(), distance_m * azimuth.sin(), height_m);
        // Aimed low: the ground fills at least the lower part of the frame.
        let aimed = CameraPose::looking_at(eye, Point3::new(0.3, 0.1, 0.3));
        let roll = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), roll_rad);
        let mut iso = aimed.isometry_world_from_optical();
        iso.rotation *= roll;
        let intrinsics = Intrinsics::from_horizontal_fov(96, 72, 60.0).expect("a lens");
        let camera = Camera { world_from_optical: iso, intrinsics };
        let posed = pose(&rig, &character, 0, 0.0);
        let input = FrameInput { camera, pose: &posed, time_s: 0.0 };
        let mut image = Image::default();
        CpuRenderer::new().render(&stage, &input, &mut image);
        let mut ground = 0;
        for (i, (&s, &inv_depth)) in image.surface.iter().zip(&image.depth).enumerate() {
            if s != crate::render::world::Surface::Ground as u8 {
                continue;
            }
            ground += 1;
            let w = image.width as usize;
            let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let ray = Vector3::new(
                (x - intrinsics.cx_px) / intrinsics.fx_px,
                (y - intrinsics.cy_px) / intrinsics.fy_px,
                1.0,
            );
            let point = iso * Point3::from(ray / f64::from(inv_depth));
            // f32 rays: a few parts in 10⁶ of the distance.
            prop_assert!(point.z.abs() < 1e-5 * (point - eye).norm() + 1e-5, "pixel {}: z = {}", i, point.z);
        }
        // Outdoors the ground fills the lower part of the frame; a room seen from outside shows
        // only its walls.
        prop_assert!(ground > 0 || stage.environment.indoor, "no ground pixel outdoors");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Law: the props' shadow on the ground read from the baked bits is the shadow map's own
    /// lookup with the receiver's height taken at each texel's centre: at every point where
    /// moving the receiver to the texel centres flips none of the four texels' tests, the two
    /// are equal; and the bits shadow some ground wherever the map does.
    #[test]
    fn baked_ground_shadow_is_the_maps_at_texel_centres(
        location in 0usize..16,
        seed in 0u64..1000,
        clock in prop::sample::select(vec![ClockTime::DAWN, ClockTime::NOON, ClockTime::EVENING]),
    ) {
        let rig = Rig::standard();
        let (stage, character) = stage(&rig, location, 0, clock, seed);
        prop_assume!(stage.environment.key_shadows && !stage.world.props.indices.is_empty());
        let camera = Camera {
            world_from_optical: CameraPose::looking_at(Point3::new(6.0, 2.0, 2.0), Point3::origin())
                .isometry_world_from_optical(),
            intrinsics: Intrinsics::from_horizontal_fov(32, 24, 60.0).expect("a lens"),
        };
        let posed = pose(&rig, &character, 0, 0.0);
        let mut renderer = CpuRenderer::new();
        renderer.render(&stage, &FrameInput { camera, pose: &posed, time_s: 0.0 }, &mut Image::default());
        let light = super::LightFrame::new(stage.environment.key_dir);
        prop_assume!(light.l.z > 0.05);
        let map = &renderer.prop_shadow;
        // Light height of the ground point under light-plane point (u, v).
        let (du, dv) = light.ground_slopes();
        let ground_h = |u: f32, v: f32| u * du + v * dv;
        let [u0, v0, u1, v1] = map.casters_uv_m;
        let (mut compared, mut shadowed, mut shadowed_by_map) = (0, 0, 0);
        for i in 0..=60 {
            for j in 0..=60 {
                let (u, v) = (u0 + (u1 - u0) * i as f32 / 60.0, v0 + (v1 - v0) * j as f32 / 60.0);
                let h = ground_h(u, v);
                let baked = map.ground_visibility(u, v);
                shadowed += usize::from(baked < 1.0);
                shadowed_by_map += usize::from(map.visibility(u, v, h) < 1.0);
                let (xi, yi, _, _) = map.filter_at(u, v).expect("the casters lie inside the map");
                let unflipped = [(0, 0), (1, 0), (0, 1), (1, 1)].iter().all(|&(dx, dy)| {
                    let caster = map.heights[(yi + dy) * map.size + xi + dx];
                    let centre_h = ground_h(
                        map.origin[0] + ((xi + dx) as f32 + 0.5) / map.texels_per_m,
                        map.origin[1] + ((yi + dy) as f32 + 0.5) / map.texels_per_m,
                    );
                    let lit = |h: f32| caster == 0.0 || caster <= h + map.height_offset + map.bias_m;
                    lit(h) == lit(centre_h)
                });
                if unflipped {
                    compared += 1;
                    let direct = map.visibility(u, v, h);
                    prop_assert!(
                        (baked - direct).abs() < 1e-6,
                        "at ({}, {}): baked {} against the map's {}", u, v, baked, direct
                    );
                }
            }
        }
        prop_assert!(compared > 3000, "only {} of 3721 points compared", compared);
        // Thin props (poles) can fall between the sampled points: then neither shows shadow.
        prop_assert!(
            shadowed > 0 || shadowed_by_map == 0,
            "the map shadows {} sampled ground points, the baked bits none", shadowed_by_map
        );
    }
}
