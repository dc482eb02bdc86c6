//! The renderer's gallery: four weathers × four times of day × three characters, one contact
//! sheet per weather, written to `docs/render-<weather>.png` (or the folder given), and every one
//! of the 14 weathers × the four times of day for one character, `docs/render-weathers.png` (the
//! outdoor locations taken in turn). The pose is the waving sample's middle frame; every scene is
//! drawn from a fixed seed, so the sheets are byte-identical on every run (CI regenerates them
//! and compares).
//!
//! ```sh
//! cargo run --release --example render_gallery            # rewrites docs/render-*.png
//! cargo run --release --example render_gallery -- /tmp/g  # elsewhere
//! ```

#![expect(
    clippy::unwrap_used,
    clippy::print_stdout,
    reason = "a report generator"
)]

use std::path::PathBuf;

use autoact::bags::animation::read_animation;
use autoact::camera::{CameraPose, Intrinsics};
use autoact::mcap_io::BagReader;
use autoact::render::cpu::CpuRenderer;
use autoact::render::{Camera, FrameInput, Image, Renderer, Stage};
use autoact::scene::cast::{AgeGroup, Population, Sex};
use autoact::scene::location::Location;
use autoact::scene::sky::ClockTime;
use autoact::scene::weather::Weather;
use autoact::scene::{Scene, SceneConfig};
use autoact::skeleton::fk;
use autoact::skeleton::rig::Rig;
use autoact::video::{Tile, contact_sheet, write_png};
use nalgebra::{Point3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const WIDTH: u32 = 320;
const HEIGHT: u32 = 240;
const TILE_WIDTH: u32 = 200;
const WEATHERS_TILE_WIDTH: u32 = 160;

fn main() {
    let out = std::env::args().nth(1).map_or_else(
        || PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/docs")),
        PathBuf::from,
    );
    std::fs::create_dir_all(&out).unwrap();
    let rig = Rig::standard();
    let bag = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/bandai_wave.anim.mcap");
    let readers = BagReader::open_all(std::path::Path::new(bag)).unwrap();
    let (frames, _, _) = read_animation(&rig, &readers, None).unwrap();
    let mut pose = frames[frames.len() / 2].pose.clone();
    pose.root_translation_m = Vector3::zeros();

    // Three characters: a child, an adult woman, an older man (first draws that match).
    let population = Population::default();
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let mut looks = Vec::new();
    for (group, sex) in [
        (AgeGroup::Child, Sex::Male),
        (AgeGroup::Adult, Sex::Female),
        (AgeGroup::Older, Sex::Male),
    ] {
        let look = std::iter::repeat_with(|| population.draw(&mut rng).unwrap())
            .find(|l| l.age_group == group && l.sex == sex)
            .unwrap();
        looks.push(look);
    }
    let pool = Location::builtin_pool();
    let place = |name: &str| pool.iter().find(|l| l.name == name).unwrap();
    let times = [
        ("dawn", ClockTime::DAWN),
        ("noon", ClockTime::NOON),
        ("evening", ClockTime::EVENING),
        ("midnight", ClockTime::MIDNIGHT),
    ];
    let weathers = [
        (Weather::Clear, "tennis_court"),
        (Weather::Rain, "street"),
        (Weather::Foggy, "open_field"),
        (Weather::Snow, "parking_lot"),
    ];
    let config = SceneConfig::default();
    let mut drawer = Drawer {
        rig,
        pose,
        renderer: CpuRenderer::new(),
        image: Image::default(),
    };
    for (wi, (weather, location)) in weathers.into_iter().enumerate() {
        let mut tiles_rgb = Vec::new();
        let mut labels = Vec::new();
        let mut rng = ChaCha8Rng::seed_from_u64(100 + wi as u64);
        let instance = place(location).draw(&mut rng, config.clear_radius_m);
        for (name, clock) in times {
            for look in &looks {
                let scene = config.scene(weather, clock, instance.clone(), look.clone());
                tiles_rgb.push(drawer.draw(&scene, 7 + wi as u64, tiles_rgb.len()));
                labels
                    .push(format!("{name} {:?} {}", look.age_group, look.age_years).to_uppercase());
            }
        }
        let path = out.join(format!("render-{}.png", weather.name().to_lowercase()));
        write_sheet(&path, &tiles_rgb, &labels, 3, TILE_WIDTH);
        println!("{} ({location})", path.display());
    }
    // Every weather at every time, the adult character, the outdoor locations in turn.
    let outdoor: Vec<&Location> = pool.iter().filter(|l| !l.indoor).collect();
    let mut tiles_rgb = Vec::new();
    let mut labels = Vec::new();
    for (wi, weather) in Weather::ALL.into_iter().enumerate() {
        let mut rng = ChaCha8Rng::seed_from_u64(200 + wi as u64);
        let location = outdoor[wi % outdoor.len()];
        let instance = location.draw(&mut rng, config.clear_radius_m);
        for (name, clock) in times {
            let scene = config.scene(weather, clock, instance.clone(), looks[1].clone());
            tiles_rgb.push(drawer.draw(&scene, 300 + wi as u64, tiles_rgb.len()));
            labels.push(format!("{} {name}", weather.name()).to_uppercase());
        }
    }
    let path = out.join("render-weathers.png");
    write_sheet(&path, &tiles_rgb, &labels, 4, WEATHERS_TILE_WIDTH);
    println!("{} (14 weathers x 4 times)", path.display());
}

/// Draws the gallery's tiles: the waving pose from the gallery's camera, with a reused image.
struct Drawer {
    rig: Rig,
    pose: fk::BonePose,
    renderer: CpuRenderer,
    image: Image,
}

impl Drawer {
    /// `scene` (staged with `seed`, tile `index`) with the character in the pose: rgb24,
    /// WIDTH × HEIGHT.
    fn draw(&mut self, scene: &Scene, seed: u64, index: usize) -> Vec<u8> {
        let intrinsics = Intrinsics::from_horizontal_fov(WIDTH, HEIGHT, 60.0).unwrap();
        let stage = Stage::new(&self.rig, scene, seed, index as u64);
        let character = scene.look.character(&self.rig);
        let posed = fk::forward(&self.rig, &character, &self.pose, 1.0);
        let target = Point3::new(0.0, 0.0, 0.5 * scene.look.height_m);
        let eye = Point3::new(-1.5, 2.6, 1.2);
        let camera = CameraPose::looking_at(eye, target);
        let input = FrameInput {
            camera: Camera {
                world_from_optical: camera.isometry_world_from_optical(),
                intrinsics,
            },
            pose: &posed,
            time_s: 1.0,
        };
        self.renderer.render(&stage, &input, &mut self.image);
        self.image.rgb.clone()
    }
}

/// A contact sheet of `tiles_rgb` (WIDTH × HEIGHT each) with `labels`, `columns` wide, written
/// to `path`.
fn write_sheet(
    path: &std::path::Path,
    tiles_rgb: &[Vec<u8>],
    labels: &[String],
    columns: u32,
    tile_width: u32,
) {
    let tiles: Vec<Tile<'_>> = tiles_rgb
        .iter()
        .zip(labels)
        .map(|(rgb, label)| Tile {
            rgb24: rgb,
            width: WIDTH,
            height: HEIGHT,
            label,
        })
        .collect();
    let (w, h, rgb) = contact_sheet(&tiles, columns, tile_width).unwrap();
    write_png(path, w, h, &rgb).unwrap();
}
