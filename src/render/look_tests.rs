//! The embedded renderer's look, measured on rendered frames: the picture's brightness follows
//! the sun and the weather, and snow and wet ground are continuous textures.

use nalgebra::Point3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::cpu::CpuRenderer;
use super::world::Surface;
use super::{Camera, FrameInput, Image, Renderer, Stage};
use crate::camera::{CameraPose, Intrinsics};
use crate::scene::color::srgb_to_linear;
use crate::scene::location::Location;
use crate::scene::sky::ClockTime;
use crate::scene::weather::{Precipitation, Weather};
use crate::scene::{Scene, SceneConfig};
use crate::skeleton::rig::Rig;

/// A scene at the built-in `location` (its props drawn from `seed`) with `weather` at `clock`.
fn scene_at(location: &str, weather: Weather, clock: ClockTime, seed: u64) -> Scene {
    let config = SceneConfig {
        weather_weights: [(weather, 1.0)].into_iter().collect(),
        clock_weights: [(clock, 1.0)].into_iter().collect(),
        locations: Location::builtin_pool()
            .into_iter()
            .filter(|l| l.name == location)
            .collect(),
        ..SceneConfig::default()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    config.draw(&mut rng, &[]).expect("a valid config draws")
}

/// Renders `scene`'s character at rest, seen from `eye` looking at its chest, at `w`×`h`, at a
/// moment without lightning.
fn render(rig: &Rig, scene: &Scene, eye: Point3<f64>, w: u32, h: u32) -> Image {
    let stage = Stage::new(rig, scene, 5, 0);
    let time_s = (0..1000)
        .map(|k| f64::from(k) * 0.1)
        .find(|&t| stage.environment.lightning_flash(t, stage.seed) == 0.0)
        .unwrap_or(0.0);
    let target = Point3::new(0.0, 0.0, 0.5 * scene.look.height_m);
    let camera = Camera {
        world_from_optical: CameraPose::looking_at(eye, target).isometry_world_from_optical(),
        intrinsics: Intrinsics::from_horizontal_fov(w, h, 60.0).expect("a valid lens"),
    };
    let input = FrameInput {
        camera,
        pose: &stage.rest_pose,
        time_s,
    };
    let mut image = Image::default();
    CpuRenderer::new().render(&stage, &input, &mut image);
    image
}

/// Mean luminance of a frame, in linear light.
fn mean_luminance(image: &Image) -> f64 {
    let lin = |b: u8| f64::from(srgb_to_linear(f32::from(b) / 255.0));
    let total: f64 = image
        .rgb
        .chunks_exact(3)
        .map(|p| 0.2126 * lin(p[0]) + 0.7152 * lin(p[1]) + 0.0722 * lin(p[2]))
        .sum();
    total / (image.rgb.len() / 3) as f64
}

#[test]
fn frame_brightness_follows_the_sun_over_the_clock_in_every_weather() {
    let rig = Rig::standard();
    let eye = Point3::new(-2.5, -3.5, 1.6);
    for weather in Weather::ALL {
        // (sun elevation, mean luminance) every hour, morning and afternoon apart: the sun
        // rises through the first and sets through the second.
        let mut halves = [Vec::new(), Vec::new()];
        let mut midnight = 0.0;
        let mut noon = 0.0;
        for hour in 0..24u16 {
            let clock = ClockTime::new(hour, 0).expect("a clock");
            let scene = scene_at("beach", weather, clock, 3);
            let lum = mean_luminance(&render(&rig, &scene, eye, 64, 48));
            halves[usize::from(hour >= 12)].push((scene.sun.elevation_deg, lum));
            if hour == 0 {
                midnight = lum;
            }
            if hour == 12 {
                noon = lum;
            }
        }
        for half in &mut halves {
            half.sort_by(|a, b| a.0.total_cmp(&b.0));
            for pair in half.windows(2) {
                let ((el0, l0), (el1, l1)) = (pair[0], pair[1]);
                assert!(
                    l1 >= l0 * 0.995,
                    "{weather}: the frame darkens from {l0:.4} to {l1:.4} as the sun rises from \
                     {el0:.1}° to {el1:.1}°"
                );
            }
        }
        assert!(
            noon > 1.5 * midnight,
            "{weather}: noon {noon:.4} vs midnight {midnight:.4}"
        );
    }
}

#[test]
fn night_is_darker_than_day_outdoors_and_a_noon_storm_is_not_darker_than_midnight() {
    let rig = Rig::standard();
    let eye = Point3::new(-2.5, -3.5, 1.6);
    for location in Location::builtin_pool().iter().filter(|l| !l.indoor) {
        let lum = |weather, clock| {
            mean_luminance(&render(
                &rig,
                &scene_at(&location.name, weather, clock, 4),
                eye,
                64,
                48,
            ))
        };
        let clear_midnight = lum(Weather::Clear, ClockTime::MIDNIGHT);
        let clear_noon = lum(Weather::Clear, ClockTime::NOON);
        let storm_noon = lum(Weather::Thunder, ClockTime::NOON);
        let storm_midnight = lum(Weather::Thunder, ClockTime::MIDNIGHT);
        let name = &location.name;
        assert!(
            clear_noon > 2.0 * clear_midnight,
            "{name}: {clear_noon} vs {clear_midnight}"
        );
        assert!(
            storm_noon >= clear_midnight && storm_noon > storm_midnight,
            "{name}: a noon storm {storm_noon} vs midnights {clear_midnight}, {storm_midnight}"
        );
    }
}

/// Of the horizontally adjacent pairs of ground pixels (both inside the ground, away from any
/// other surface), the fraction whose luma differs by more than `step` of 255.
fn ground_edge_fraction(image: &Image, step: i32) -> f64 {
    let (w, h) = (image.width as usize, image.height as usize);
    let ground = Surface::Ground as u8;
    let luma = |i: usize| {
        let p = &image.rgb[3 * i..3 * i + 3];
        (i32::from(p[0]) * 2 + i32::from(p[1]) * 5 + i32::from(p[2])) / 8
    };
    let (mut pairs, mut edges) = (0usize, 0usize);
    for y in 1..h - 1 {
        for x in 1..w - 2 {
            let i = y * w + x;
            let around = [i - 1, i, i + 1, i + 2, i - w, i + w, i + 1 - w, i + 1 + w];
            if around.iter().any(|&k| image.surface[k] != ground) {
                continue;
            }
            pairs += 1;
            edges += usize::from((luma(i) - luma(i + 1)).abs() > step);
        }
    }
    assert!(pairs > 1000, "{pairs} ground pairs");
    edges as f64 / pairs as f64
}

#[test]
fn snow_and_wet_ground_are_continuous_textures_without_blocks() {
    let rig = Rig::standard();
    // Looking down at the ground from standing height.
    let eye = Point3::new(-1.5, -2.5, 1.7);
    for (weather, location) in [
        (Weather::SnowLight, "parking_lot"),
        (Weather::Snow, "parking_lot"),
        (Weather::Xmas, "open_field"),
        (Weather::Rain, "street"),
        (Weather::Thunder, "tennis_court"),
    ] {
        let mut scene = scene_at(location, weather, ClockTime::NOON, 6);
        // Only the ground: no props to cast shadow edges, no falling snow or rain drawn over it.
        scene.location.props.clear();
        scene.weather_params.precipitation = Precipitation::None;
        let image = render(&rig, &scene, eye, 320, 240);
        let edges = ground_edge_fraction(&image, 40);
        if let Some(dir) = std::env::var_os("AUTOACT_LOOK_DUMP") {
            let path = std::path::Path::new(&dir).join(format!("{weather}-{location}.png"));
            crate::video::write_png(&path, image.width, image.height, &image.rgb).expect("png");
        }
        assert!(
            edges < 0.01,
            "{weather} on {location}: {:.2} % of neighbouring ground pixels jump by > 40 levels",
            100.0 * edges
        );
    }
}

/// A 320×240 close-up of a stage's character at rest from `eye` looking at `target` (written as
/// `name` under `$AUTOACT_LOOK_DUMP` when that is set), for the face's tests.
struct CloseUp {
    camera: Camera,
    image: Image,
    width: usize,
}

impl CloseUp {
    fn new(stage: &Stage, eye: Point3<f64>, target: Point3<f64>, name: &str) -> CloseUp {
        let (w, h) = (320u32, 240u32);
        let camera = Camera {
            world_from_optical: CameraPose::looking_at(eye, target).isometry_world_from_optical(),
            intrinsics: Intrinsics::from_horizontal_fov(w, h, 50.0).expect("a lens"),
        };
        let input = FrameInput {
            camera,
            pose: &stage.rest_pose,
            time_s: 0.0,
        };
        let mut image = Image::default();
        CpuRenderer::new().render(stage, &input, &mut image);
        if let Some(dir) = std::env::var_os("AUTOACT_LOOK_DUMP") {
            let path = std::path::Path::new(&dir).join(name);
            crate::video::write_png(&path, w, h, &image.rgb).expect("png");
        }
        CloseUp {
            camera,
            image,
            width: w as usize,
        }
    }

    /// The pixel a world point projects onto.
    fn pixel(&self, p: Point3<f64>) -> (usize, usize) {
        let k = &self.camera.intrinsics;
        let q = self.camera.world_from_optical.inverse_transform_point(&p);
        let x = k.fx_px * q.x / q.z + k.cx_px;
        let y = k.fy_px * q.y / q.z + k.cy_px;
        (x as usize, y as usize)
    }

    /// A pixel's luma, 0–255.
    fn luma(&self, (x, y): (usize, usize)) -> u32 {
        let i = 3 * (y * self.width + x);
        let p = &self.image.rgb[i..i + 3];
        (u32::from(p[0]) * 2 + u32::from(p[1]) * 5 + u32::from(p[2])) / 8
    }

    /// The darkest luma within one pixel of `(x, y)`.
    fn darkest_around(&self, (x, y): (usize, usize)) -> u32 {
        (y - 1..=y + 1)
            .flat_map(|yy| (x - 1..=x + 1).map(move |xx| (xx, yy)))
            .map(|at| self.luma(at))
            .min()
            .unwrap_or(255)
    }

    /// Whether a pixel shows the character.
    fn on_character(&self, (x, y): (usize, usize)) -> bool {
        self.image.surface[y * self.width + x] == Surface::Character as u8
    }
}

#[test]
fn the_face_shows_dark_eyes_where_cocos_eye_points_project() {
    use crate::skeleton::fk;
    let rig = Rig::standard();
    let mut scene = scene_at("open_field", Weather::Clear, ClockTime::NOON, 2);
    // A light skin and short hair, lit from the front, so the face is plain to see.
    scene.look.skin_rgb = [0.86, 0.69, 0.58];
    scene.sun.azimuth_deg = 20.0;
    let character = scene.look.character(&rig);
    let stage = Stage::new(&rig, &scene, 5, 0);
    let point = |name: &str| {
        let l = rig.landmark_index(name).expect("a face landmark");
        fk::landmark_position(&rig, &character, &stage.rest_pose, l)
    };
    let nose = point("nose");
    // A close-up from straight in front (the rest pose faces +y): the landmarks lie about a
    // centimetre inside the head, on the rays through the drawn eyes, so seen from the front
    // they project onto them.
    let eye = nose + nalgebra::Vector3::new(0.0, 0.45, 0.03);
    let view = CloseUp::new(&stage, eye, point("head_center"), "face.png");
    // The skin of the nose's tip, beside the eyes.
    let nose_tip = view.pixel(nose);
    assert!(view.on_character(nose_tip));
    for name in ["l_eye", "r_eye"] {
        let at = view.pixel(point(name));
        // The darkest pixel within one of the eye point.
        let darkest = view.darkest_around(at);
        assert!(view.on_character(at), "{name} is on the character");
        assert!(
            darkest * 2 < view.luma(nose_tip),
            "{name}: {darkest} is not darker than the nose's {}",
            view.luma(nose_tip)
        );
    }
}

/// Which pattern a stage's top has, read off its vertices' colours: 0 plain, 1 two-tone, 2
/// striped, 3 a chest print, 4 colour-blocked sleeves.
fn top_pattern(stage: &Stage) -> Result<usize, String> {
    use crate::scene::body_mesh::Material;
    let base = stage.body_albedo[Material::Top as usize];
    let peak = base.iter().fold(0.0f32, |a, &c| a.max(c));
    let body = &stage.body;
    let stature = body
        .rest_positions_m
        .iter()
        .map(|p| p[2])
        .fold(0.0f32, f32::max);
    let torso = body
        .parts
        .iter()
        .find(|p| p.name == "torso")
        .expect("a torso");
    // (vertex, position, whether it has another colour than the top's, beyond the ±6 % grain).
    let mut top: Vec<(usize, [f32; 3], bool)> = (0..body.materials.len())
        .filter(|&i| body.materials[i] == Material::Top)
        .map(|i| {
            let c = stage.body_vertex_albedo[i];
            let other = (0..3).any(|k| (c[k] - base[k]).abs() > 0.07 * peak + 0.005);
            (i, body.rest_positions_m[i], other)
        })
        .collect();
    let other: Vec<(usize, [f32; 3], bool)> = top.iter().copied().filter(|v| v.2).collect();
    if other.is_empty() {
        return Ok(0);
    }
    let on_torso = |i: usize| torso.vertices.contains(&i);
    // Sleeves: exactly the top's vertices off the torso.
    if top.iter().all(|&(i, _, o)| o != on_torso(i)) {
        return Ok(4);
    }
    // A print: only on the torso's front, within a chest-sized patch.
    if other.iter().all(|&(i, p, _)| {
        on_torso(i)
            && p[1] > 0.0
            && p[0].abs() < 0.06 * stature
            && (0.6 * stature..0.8 * stature).contains(&p[2])
    }) {
        return Ok(3);
    }
    top.sort_by(|a, b| a.1[2].total_cmp(&b.1[2]));
    match top.windows(2).filter(|w| w[0].2 != w[1].2).count() {
        1 => Ok(1),
        s if s >= 4 => Ok(2),
        s => Err(format!(
            "{} vertices of another colour, {s} switches",
            other.len()
        )),
    }
}

#[test]
fn tops_come_plain_striped_two_tone_printed_or_blocked_and_fabrics_have_grain() {
    use crate::scene::body_mesh::Material;
    let rig = Rig::standard();
    let scene = scene_at("open_field", Weather::Clear, ClockTime::NOON, 2);
    let mut seen = [0usize; 5];
    for seed in 0..40 {
        let stage = Stage::new(&rig, &scene, seed, 0);
        let kind = top_pattern(&stage)
            .unwrap_or_else(|e| panic!("seed {seed}: a top that is none of the patterns: {e}"));
        seen[kind] += 1;
        // Grain: the trousers' vertices are not all one colour, but within ±6 % of it.
        let bottom = stage.body_albedo[Material::Bottom as usize];
        let ratios: Vec<f32> = stage
            .body
            .materials
            .iter()
            .zip(&stage.body_vertex_albedo)
            .filter(|(m, _)| **m == Material::Bottom)
            .map(|(_, c)| c[1] / bottom[1])
            .collect();
        assert!(
            ratios.iter().all(|r| (0.93..=1.07).contains(r)),
            "seed {seed}"
        );
        assert!(
            ratios.iter().any(|r| (r - ratios[0]).abs() > 0.02),
            "seed {seed}"
        );
    }
    assert!(
        seen.iter().all(|&n| n >= 3),
        "plain, two-tone, striped, printed, blocked: {seen:?}"
    );
}

#[test]
fn a_tops_pattern_changes_its_pixels_but_not_the_labels() {
    let rig = Rig::standard();
    let scene = scene_at("open_field", Weather::Clear, ClockTime::NOON, 2);
    let a = Stage::new(&rig, &scene, 0, 0);
    let kind = top_pattern(&a).expect("a pattern");
    // The same stage with another seed's pattern on its clothes.
    let other = (1..64)
        .map(|seed| super::clothes_pattern(&a.body, &a.body_albedo, seed))
        .find(|albedo| {
            let mut b = a.clone();
            b.body_vertex_albedo.clone_from(albedo);
            top_pattern(&b).is_ok_and(|k| k != kind)
        })
        .expect("another pattern among 63 seeds");
    let mut b = a.clone();
    b.body_vertex_albedo = other;
    let height = scene.look.height_m;
    let (eye, target) = (
        Point3::new(0.0, 2.2, 0.7 * height),
        Point3::new(0.0, 0.0, 0.65 * height),
    );
    let (ia, _) = render_view(&a, eye, target);
    let (ib, _) = render_view(&b, eye, target);
    if let Some(dir) = std::env::var_os("AUTOACT_LOOK_DUMP") {
        for (name, image) in [("top_a.png", &ia), ("top_b.png", &ib)] {
            let path = std::path::Path::new(&dir).join(name);
            crate::video::write_png(&path, image.width, image.height, &image.rgb).expect("png");
        }
    }
    assert_eq!(ia.depth, ib.depth);
    assert_eq!(ia.surface, ib.surface);
    let changed = ia
        .rgb
        .chunks_exact(3)
        .zip(ib.rgb.chunks_exact(3))
        .zip(&ia.surface)
        .filter(|((p, q), s)| **s == Surface::Character as u8 && p != q)
        .count();
    let character = ia
        .surface
        .iter()
        .filter(|&&s| s == Surface::Character as u8)
        .count();
    assert!(
        changed * 10 > character,
        "{changed} of {character} character pixels changed"
    );
}

#[test]
fn the_face_has_a_dark_mouth_and_brows_in_the_hairs_colour() {
    let rig = Rig::standard();
    let mut scene = scene_at("open_field", Weather::Clear, ClockTime::NOON, 2);
    scene.look.skin_rgb = [0.86, 0.69, 0.58];
    scene.look.hair_rgb = [0.12, 0.08, 0.05];
    scene.sun.azimuth_deg = 20.0;
    let stage = Stage::new(&rig, &scene, 5, 0);
    let centroid = |name: &str| {
        let part = stage
            .body
            .parts
            .iter()
            .find(|p| p.name == name)
            .expect(name);
        let n = part.vertices.len() as f64;
        let sum = part.vertices.clone().fold([0.0f64; 3], |s, i| {
            let p = stage.body.rest_positions_m[i];
            [
                s[0] + f64::from(p[0]),
                s[1] + f64::from(p[1]),
                s[2] + f64::from(p[2]),
            ]
        });
        Point3::new(sum[0] / n, sum[1] / n, sum[2] / n)
    };
    let mouth = centroid("mouth");
    let eyes = nalgebra::center(&centroid("l_eye"), &centroid("r_eye"));
    // Below the nose and the eyes, on the face's midline.
    assert!(
        mouth.z < eyes.z - 0.04 && mouth.x.abs() < 0.005,
        "{mouth:?}"
    );
    let eye = mouth + nalgebra::Vector3::new(0.0, 0.45, 0.05);
    let view = CloseUp::new(
        &stage,
        eye,
        mouth + nalgebra::Vector3::z() * 0.05,
        "mouth.png",
    );
    let up = nalgebra::Vector3::z();
    // The skin around each feature: 2.5 cm below the mouth (the chin), 2 cm above each brow
    // (the forehead), both on the face.
    for (name, skin) in [
        ("mouth", mouth - up * 0.025),
        ("l_brow", centroid("l_brow") + up * 0.02),
        ("r_brow", centroid("r_brow") + up * 0.02),
    ] {
        let at = view.pixel(centroid(name));
        let skin = view.pixel(skin);
        assert!(view.on_character(at) && view.on_character(skin), "{name}");
        assert!(
            view.darkest_around(at) * 2 < view.luma(skin),
            "{name}: {} is not darker than the skin's {}",
            view.darkest_around(at),
            view.luma(skin)
        );
    }
}

/// Renders `stage`'s character at rest from `eye` looking at `target`, at 160×120, at `time_s`.
fn render_view(stage: &Stage, eye: Point3<f64>, target: Point3<f64>) -> (Image, Camera) {
    let camera = Camera {
        world_from_optical: CameraPose::looking_at(eye, target).isometry_world_from_optical(),
        intrinsics: Intrinsics::from_horizontal_fov(160, 120, 70.0).expect("a valid lens"),
    };
    let input = FrameInput {
        camera,
        pose: &stage.rest_pose,
        time_s: 0.0,
    };
    let mut image = Image::default();
    CpuRenderer::new().render(stage, &input, &mut image);
    (image, camera)
}

/// Mean sRGB colour (0–1) of the pixels showing `surface`, and how many there are.
fn mean_colour_of(image: &Image, surface: Surface) -> ([f64; 3], usize) {
    let mut sum = [0.0; 3];
    let mut n = 0;
    for (p, &s) in image.rgb.chunks_exact(3).zip(&image.surface) {
        if s == surface as u8 {
            for c in 0..3 {
                sum[c] += f64::from(p[c]) / 255.0;
            }
            n += 1;
        }
    }
    (sum.map(|v| v / n.max(1) as f64), n)
}

#[test]
fn backdrops_of_one_location_vary_between_scenes_and_repeat_for_one_seed() {
    let rig = Rig::standard();
    for (location, eye, target) in [
        ("open_field", [0.0, -5.0, 1.6], [0.0, 200.0, 30.0]),
        ("swimming_pool", [0.0, -3.0, 1.6], [0.0, 30.0, 5.0]),
        ("street", [0.0, -3.0, 1.6], [0.0, 60.0, 15.0]),
        ("office", [0.0, -3.0, 1.6], [0.0, 10.0, 1.5]),
    ] {
        // One location instance (same props, same placement), different scene seeds.
        let scene = scene_at(location, Weather::Clear, ClockTime::NOON, 1);
        let (eye, target) = (Point3::from(eye), Point3::from(target));
        let means: Vec<[f64; 3]> = (0..8u64)
            .map(|seed| {
                let stage = Stage::new(&rig, &scene, seed, 0);
                let (image, _) = render_view(&stage, eye, target);
                let (mean, n) = mean_colour_of(&image, Surface::Backdrop);
                assert!(n > 500, "{location}: only {n} backdrop pixels");
                mean
            })
            .collect();
        // The backdrop's palette (a season, a facade, a wall paint) is drawn per scene: its
        // average colour differs between scenes, not only its layout.
        let spread = means
            .iter()
            .flat_map(|a| {
                means
                    .iter()
                    .map(move |b| (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f64>())
            })
            .fold(0.0, f64::max);
        assert!(spread > 0.3, "{location}: backdrop colours {means:.3?}");
        // The same seed gives the same picture.
        let stage = Stage::new(&rig, &scene, 3, 0);
        assert_eq!(
            render_view(&stage, eye, target).0,
            render_view(&Stage::new(&rig, &scene, 3, 0), eye, target).0
        );
    }
    // Two scenes of one location drawn from two seeds (character, props, backdrop) differ
    // measurably over the whole picture.
    let (eye, target) = (Point3::new(-2.0, -4.0, 1.6), Point3::new(0.0, 4.0, 1.0));
    let frame = |seed| {
        let scene = scene_at("tennis_court", Weather::Clear, ClockTime::NOON, seed);
        render_view(&Stage::new(&rig, &scene, seed, 0), eye, target).0
    };
    let (a, b) = (frame(11), frame(12));
    let mean_abs = a
        .rgb
        .iter()
        .zip(&b.rgb)
        .map(|(&x, &y)| f64::from(x.abs_diff(y)))
        .sum::<f64>()
        / a.rgb.len() as f64;
    assert!(mean_abs > 8.0, "mean difference {mean_abs:.1} of 255");
    assert_eq!(frame(11), a);
}

#[test]
fn randomisation_changes_the_picture_but_not_the_labels() {
    use super::annotate::{SURFACE_LANDMARKS, annotate};
    use super::randomise::ImageEffects;
    use crate::dataset::randomise::Randomise;
    use crate::skeleton::fk::landmark_position;
    let rig = Rig::standard();
    let scene = scene_at("street", Weather::Clear, ClockTime::NOON, 3);
    let character = scene.look.character(&rig);
    let plain = Stage::new(&rig, &scene, 7, 0);
    let mut jittered = plain.clone();
    Randomise::default().jitter_stage(&mut jittered);
    let mut again = plain.clone();
    Randomise::default().jitter_stage(&mut again);
    assert_eq!(
        jittered.body_vertex_albedo, again.body_vertex_albedo,
        "reproducible"
    );
    assert_eq!(jittered.world, again.world, "reproducible");
    let (eye, target) = (Point3::new(-1.5, -3.0, 1.5), Point3::new(0.0, 0.0, 1.0));
    let (a, camera) = render_view(&plain, eye, target);
    let (b, _) = render_view(&jittered, eye, target);
    let landmarks: Vec<_> = (0..rig.landmarks.len())
        .map(|l| landmark_position(&rig, &character, &plain.rest_pose, l))
        .collect();
    let surface: Vec<bool> = rig
        .landmarks
        .iter()
        .map(|l| SURFACE_LANDMARKS.contains(&l.name.as_str()))
        .collect();
    let labels = |image: &Image| annotate(&plain.rest_pose, &landmarks, &surface, &camera, image);
    // Colour jitter: another picture, the same depth, surfaces and labels.
    assert_ne!(a.rgb, b.rgb);
    assert_eq!((&a.depth, &a.surface), (&b.depth, &b.surface));
    assert_eq!(labels(&a), labels(&b));
    assert!(labels(&a).bbox.is_some(), "the character is in view");
    // Noise and blur: the picture changes, its labels do not.
    let effects = Randomise {
        sensor_noise: [0.01, 0.01],
        motion_blur: [0.3, 0.3],
        ..Randomise::default()
    };
    let mut fx = ImageEffects::new(&effects);
    let mut first = a.clone();
    fx.apply(0, plain.seed, true, &mut first.rgb);
    let mut second = b.clone();
    fx.apply(1, plain.seed, false, &mut second.rgb);
    assert_ne!(second.rgb, b.rgb);
    assert_eq!(labels(&second), labels(&b));
    assert_eq!(labels(&first), labels(&a));
}
