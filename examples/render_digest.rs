//! The embedded renderer's regression and speed harness: a fixed set of frames (every built-in
//! location, 14 weathers, four times of day, several poses of the waving sample, cameras near
//! and far, one close enough to cut the body at the near plane) at 320×240 and 640×360.
//!
//! ```sh
//! render_digest dump OUT            # every frame's colour, depth bits and surface ids to OUT
//! render_digest compare A B         # how two dumps differ (exit 1 if they do)
//! render_digest bench [REPEATS [WxH]]  # renders the set REPEATS times; prints CPU ms per frame
//! render_digest frames WxH NOISE BLUR > raw.rgb   # a capture-like sequence, raw rgb24
//! ```
//!
//! `frames` renders the waving sample's frames in order with one scene and a fixed camera, passes
//! them through `[randomise]`'s image effects with the sensor noise sigma `NOISE` (fraction of
//! full scale) and blur weight `BLUR`, writes them to stdout as raw `rgb24` (pipe into ffmpeg
//! with autoact's x264 settings to measure the encoder's cost) and prints the renderer's and the
//! effects' CPU ms per frame to stderr.
//!
//! `tools/bench_render_cpu.py` runs `bench` of two builds in turn and prints the ratio; a dump of
//! a build before a renderer change compared with one after shows whether its output moved.

#![expect(
    clippy::unwrap_used,
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a measuring tool"
)]

use std::io::{Read, Write};
use std::path::Path;

use autoact::bags::animation::read_animation;
use autoact::camera::{CameraPose, Intrinsics};
use autoact::dataset::randomise::Randomise;
use autoact::mcap_io::BagReader;
use autoact::render::cpu::CpuRenderer;
use autoact::render::randomise::ImageEffects;
use autoact::render::{Camera, FrameInput, Image, Renderer, Stage};
use autoact::scene::SceneConfig;
use autoact::scene::cast::Population;
use autoact::scene::location::Location;
use autoact::scene::sky::ClockTime;
use autoact::scene::weather::Weather;
use autoact::skeleton::fk::{self, WorldPose};
use autoact::skeleton::rig::Rig;
use nalgebra::{Point3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// The sizes measured: the NTU-like benchmark's and the 640×360 target's.
const SIZES: [(u32, u32); 2] = [(320, 240), (640, 360)];

/// One frame to draw: which stage, which pose, where the camera stands.
struct Shot {
    stage: usize,
    pose: usize,
    eye: Point3<f64>,
    target: Point3<f64>,
    time_s: f64,
}

struct Set {
    stages: Vec<Stage>,
    poses: Vec<WorldPose>,
    shots: Vec<Shot>,
}

fn build() -> Set {
    let rig = Rig::standard();
    let bag = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/bandai_wave.anim.mcap");
    let readers = BagReader::open_all(Path::new(bag)).unwrap();
    let (frames, _, _) = read_animation(&rig, &readers, None).unwrap();
    let population = Population::default();
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let clocks = [
        ClockTime::NOON,
        ClockTime::DAWN,
        ClockTime::EVENING,
        ClockTime::MIDNIGHT,
    ];
    let mut stages = Vec::new();
    let mut poses = Vec::new();
    let mut shots = Vec::new();
    for (li, location) in Location::builtin_pool().iter().enumerate() {
        let instance = location.draw(&mut rng, 2.5);
        for k in 0..2 {
            let n = stages.len();
            let weather = Weather::ALL[n % Weather::ALL.len()];
            let look = population.draw(&mut rng).unwrap();
            let clock = clocks[(li + k) % clocks.len()];
            let scene =
                SceneConfig::default().scene(weather, clock, instance.clone(), look.clone());
            stages.push(Stage::new(&rig, &scene, 11 + n as u64, n as u64));
            let character = look.character(&rig);
            let height = look.height_m;
            for p in 0..3 {
                let mut pose = frames[(frames.len() - 1) * (n * 3 + p) / 59].pose.clone();
                pose.root_translation_m = Vector3::new(0.3 * p as f64, -0.2 * p as f64, 0.0);
                poses.push(fk::forward(&rig, &character, &pose, 1.0));
                let root = Vector3::new(0.3 * p as f64, -0.2 * p as f64, 0.0);
                let target = Point3::from(root + Vector3::new(0.0, 0.0, 0.5 * height));
                let angle = 0.9 * (n * 3 + p) as f64;
                let (distance, eye_z) = match p {
                    0 => (4.5, 1.5),
                    1 => (2.4, 0.4),
                    // Close enough that the near plane cuts the body in some frames.
                    _ => (0.45, 1.1),
                };
                let eye = Point3::from(
                    root + Vector3::new(distance * angle.cos(), distance * angle.sin(), eye_z),
                );
                shots.push(Shot {
                    stage: n,
                    pose: poses.len() - 1,
                    eye,
                    target,
                    time_s: 0.37 * (n * 3 + p) as f64,
                });
            }
        }
    }
    Set {
        stages,
        poses,
        shots,
    }
}

/// Renders every shot at `width`×`height`, handing each image to `each`; each stage's shots
/// `repeats` times in a row (a capture renders many frames per scene, so the props' shadow map,
/// drawn once per scene, should not dominate).
fn render_all(set: &Set, width: u32, height: u32, repeats: usize, mut each: impl FnMut(&Image)) {
    let intrinsics = Intrinsics::from_horizontal_fov(width, height, 60.0).unwrap();
    let mut renderer = CpuRenderer::new();
    let mut image = Image::default();
    let mut order = Vec::new();
    for group in set.shots.chunk_by(|a, b| a.stage == b.stage) {
        for _ in 0..repeats {
            order.extend(group);
        }
    }
    for shot in order {
        let camera = CameraPose::looking_at(shot.eye, shot.target);
        let input = FrameInput {
            camera: Camera {
                world_from_optical: camera.isometry_world_from_optical(),
                intrinsics,
            },
            pose: &set.poses[shot.pose],
            time_s: shot.time_s,
        };
        renderer.render(&set.stages[shot.stage], &input, &mut image);
        each(&image);
    }
}

/// This thread's CPU time, nanoseconds (Linux: `/proc/thread-self/schedstat`).
fn thread_cpu_ns() -> u64 {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").unwrap();
    text.split_whitespace().next().unwrap().parse().unwrap()
}

fn dump(out: &Path) {
    let set = build();
    let mut file = std::io::BufWriter::new(std::fs::File::create(out).unwrap());
    for (w, h) in SIZES {
        render_all(&set, w, h, 1, |image| {
            file.write_all(&image.width.to_le_bytes()).unwrap();
            file.write_all(&image.height.to_le_bytes()).unwrap();
            file.write_all(&image.rgb).unwrap();
            for d in &image.depth {
                file.write_all(&d.to_bits().to_le_bytes()).unwrap();
            }
            file.write_all(&image.surface).unwrap();
        });
    }
    file.flush().unwrap();
    println!("{} frames per size", set.shots.len());
}

/// Per size: frames, pixels whose colour differs, the largest channel difference, pixels whose
/// depth bits differ, the largest relative depth difference, pixels whose surface differs.
fn compare(a: &Path, b: &Path) -> bool {
    let read = |p: &Path| {
        let mut v = Vec::new();
        std::fs::File::open(p).unwrap().read_to_end(&mut v).unwrap();
        v
    };
    let (a, b) = (read(a), read(b));
    if a.len() != b.len() {
        println!("dumps differ in length: {} and {}", a.len(), b.len());
        return false;
    }
    let mut at = 0;
    let mut same = true;
    let u32_at = |v: &[u8], i: usize| u32::from_le_bytes(v[i..i + 4].try_into().unwrap());
    let mut frame = 0;
    println!(
        "| frame size | colour pixels differing | max channel difference | mean channel difference (all pixels) | depth pixels differing | max relative depth difference | surface pixels differing |"
    );
    println!("|---|---|---|---|---|---|---|");
    let mut totals = std::collections::BTreeMap::new();
    while at < a.len() {
        let (w, h) = (u32_at(&a, at) as usize, u32_at(&a, at + 4) as usize);
        at += 8;
        let n = w * h;
        let (rgb_a, rgb_b) = (&a[at..at + 3 * n], &b[at..at + 3 * n]);
        let (depth_a, depth_b) = (&a[at + 3 * n..at + 7 * n], &b[at + 3 * n..at + 7 * n]);
        let (surf_a, surf_b) = (&a[at + 7 * n..at + 8 * n], &b[at + 7 * n..at + 8 * n]);
        at += 8 * n;
        let t = totals
            .entry((w, h))
            .or_insert((0usize, 0usize, 0u8, 0usize, 0f32, 0usize, 0u64));
        t.0 += 1;
        for i in 0..n {
            let pa = &rgb_a[3 * i..3 * i + 3];
            let pb = &rgb_b[3 * i..3 * i + 3];
            if pa != pb {
                t.1 += 1;
                for (x, y) in pa.iter().zip(pb) {
                    t.2 = t.2.max(x.abs_diff(*y));
                    t.6 += u64::from(x.abs_diff(*y));
                }
            }
            let da = f32::from_bits(u32_at(depth_a, 4 * i));
            let db = f32::from_bits(u32_at(depth_b, 4 * i));
            if da.to_bits() != db.to_bits() {
                t.3 += 1;
                let rel = (da - db).abs() / da.abs().max(db.abs()).max(1e-12);
                t.4 = t.4.max(rel);
            }
            if surf_a[i] != surf_b[i] {
                t.5 += 1;
            }
        }
        frame += 1;
    }
    for ((w, h), t) in &totals {
        println!(
            "| {w}×{h} ({} frames) | {} | {} | {:.2e} | {} | {:.3e} | {} |",
            t.0,
            t.1,
            t.2,
            t.6 as f64 / (3 * w * h * t.0) as f64,
            t.3,
            t.4,
            t.5
        );
        same &= t.1 == 0 && t.3 == 0 && t.5 == 0;
    }
    eprintln!("{frame} frames compared");
    same
}

fn bench(repeats: usize, only: Option<&str>) {
    let set = build();
    for (w, h) in SIZES {
        if only.is_some_and(|o| o != format!("{w}x{h}")) {
            continue;
        }
        // One untimed pass: buffers grow, the props' shadow maps are drawn.
        render_all(&set, w, h, 1, |_| {});
        let start = thread_cpu_ns();
        render_all(&set, w, h, repeats, |_| {});
        let ns = thread_cpu_ns() - start;
        let frames = repeats * set.shots.len();
        println!(
            "{w}x{h} {frames} frames {:.4} cpu_ms_per_frame",
            ns as f64 / 1e6 / frames as f64
        );
    }
}

fn frames(size: &str, noise: f64, blur: f64) {
    let (w, h) = size.split_once('x').unwrap();
    let (width, height): (u32, u32) = (w.parse().unwrap(), h.parse().unwrap());
    let rig = Rig::standard();
    let bag = concat!(env!("CARGO_MANIFEST_DIR"), "/bags/bandai_wave.anim.mcap");
    let readers = BagReader::open_all(Path::new(bag)).unwrap();
    let (anim, _, _) = read_animation(&rig, &readers, None).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    let location = &Location::builtin_pool()[0];
    let instance = location.draw(&mut rng, 2.5);
    let look = Population::default().draw(&mut rng).unwrap();
    let clock = ClockTime::NOON;
    let scene = SceneConfig::default().scene(Weather::ALL[0], clock, instance, look.clone());
    let stage = Stage::new(&rig, &scene, 11, 0);
    let character = look.character(&rig);
    let intrinsics = Intrinsics::from_horizontal_fov(width, height, 60.0).unwrap();
    let target = Point3::new(0.0, 0.0, 0.5 * look.height_m);
    let camera = CameraPose::looking_at(Point3::new(3.5, -2.0, 1.5), target);
    let config = Randomise {
        sensor_noise: [noise, noise],
        motion_blur: [blur, blur],
        ..Randomise::default()
    };
    let mut effects = ImageEffects::new(&config);
    let mut renderer = CpuRenderer::new();
    let mut image = Image::default();
    let (mut render_ns, mut effects_ns) = (0, 0);
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    for (k, frame) in anim.iter().enumerate() {
        let pose = fk::forward(&rig, &character, &frame.pose, 1.0);
        let input = FrameInput {
            camera: Camera {
                world_from_optical: camera.isometry_world_from_optical(),
                intrinsics,
            },
            pose: &pose,
            time_s: k as f64 / 30.0,
        };
        let start = thread_cpu_ns();
        renderer.render(&stage, &input, &mut image);
        let mid = thread_cpu_ns();
        effects.apply(k as u64, stage.seed, k == 0, &mut image.rgb);
        effects_ns += thread_cpu_ns() - mid;
        render_ns += mid - start;
        out.write_all(&image.rgb).unwrap();
    }
    out.flush().unwrap();
    let n = anim.len() as f64;
    eprintln!(
        "{width}x{height} {} frames: render {:.4} cpu_ms_per_frame, effects {:.4} cpu_ms_per_frame",
        anim.len(),
        render_ns as f64 / 1e6 / n,
        effects_ns as f64 / 1e6 / n
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("dump") => dump(Path::new(&args[1])),
        Some("compare") => {
            if !compare(Path::new(&args[1]), Path::new(&args[2])) {
                std::process::exit(1);
            }
        }
        Some("bench") => bench(
            args.get(1).map_or(3, |r| r.parse().unwrap()),
            args.get(2).map(String::as_str),
        ),
        Some("frames") => frames(&args[1], args[2].parse().unwrap(), args[3].parse().unwrap()),
        _ => {
            eprintln!(
                "usage: render_digest dump OUT | compare A B | bench [REPEATS [WxH]] | frames WxH NOISE BLUR"
            );
            std::process::exit(2);
        }
    }
}
