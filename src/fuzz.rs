//! Entry points for fuzzing: each takes arbitrary bytes, runs them through one reader exactly as
//! the command that reads that kind of file does, and must return — never panic, never abort,
//! never hang — whatever the bytes. The `cargo fuzz` targets in `fuzz/` call these, and so do the
//! regression tests that replay every input a fuzzer found (`tests/it/fuzzing.rs`), so a crasher
//! once fixed stays fixed. Errors are the expected outcome for most inputs and are dropped here.

use std::path::Path;

use crate::formats::import::{ImportOptions, InputFormat, import};
use crate::ros::autoact_msgs::{BoneFrame, SceneState, Segment, Skeleton3D};
use crate::ros::cdr;
use crate::ros::tf2_msgs::TFMessage;
use crate::skeleton::rig::Rig;

/// The kinds of input there is an entry point for, by the name of their fuzz target.
pub const TARGETS: [&str; 12] = [
    "bvh",
    "ntu",
    "h36m",
    "zed_mat",
    "utd_mat",
    "mmpose_json",
    "panoptic_json",
    "spec",
    "layout",
    "cdr",
    "pose_mcap",
    "anim_mcap",
];

/// Runs `data` through the entry point named `target` (one of [`TARGETS`]); `false` for an
/// unknown name.
#[must_use]
pub fn run(target: &str, data: &[u8]) -> bool {
    match target {
        "bvh" => import_bytes(data, "clip.bvh", InputFormat::Bvh, None, None),
        "ntu" => import_bytes(
            data,
            "S001C001P001R001A001.skeleton",
            InputFormat::Ntu,
            None,
            None,
        ),
        "h36m" => import_bytes(
            data,
            "S1_walking_1.txt",
            InputFormat::H36mExpmap,
            None,
            None,
        ),
        "zed_mat" => import_bytes(data, "zed.mat", InputFormat::ZedMat, None, None),
        "utd_mat" => import_bytes(
            data,
            "a1_s1_t1_skeleton.mat",
            InputFormat::UtdMat,
            None,
            None,
        ),
        "mmpose_json" => import_bytes(
            data,
            "poses.json",
            InputFormat::MmposeJson,
            Some("coco-17"),
            Some(30.0),
        ),
        "panoptic_json" => import_bytes(
            data,
            "body3DScene_00000001.json",
            InputFormat::PanopticJson,
            None,
            None,
        ),
        "spec" => spec(data),
        "layout" => layout(data),
        "cdr" => cdr_messages(data),
        "pose_mcap" => pose_mcap(data),
        "anim_mcap" => anim_mcap(data),
        _ => return false,
    }
    true
}

/// Writes `data` as a file named `name` in a fresh temporary folder and passes its path to `f`
/// (the readers take paths, as the commands do).
fn with_file(data: &[u8], name: &str, f: impl FnOnce(&Path)) {
    let Ok(dir) = tempfile_dir() else { return };
    let path = dir.join(name);
    if std::fs::write(&path, data).is_ok() {
        f(&path);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A fresh folder under the system's temporary folder.
fn tempfile_dir() -> std::io::Result<std::path::PathBuf> {
    static COUNT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("autoact-fuzz-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}

fn import_bytes(
    data: &[u8],
    name: &str,
    format: InputFormat,
    layout: Option<&str>,
    fps: Option<f64>,
) {
    let options = ImportOptions {
        format,
        layout: layout.map(str::to_string),
        fps,
        axes: None,
        metres_per_unit: None,
        bvh_map: None,
        ground: crate::skeleton::ground::GroundMode::default(),
        lengths: crate::skeleton::lengths::LengthMode::default(),
    };
    with_file(data, name, |path| {
        let _ = import(path, &options);
    });
}

fn spec(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = crate::dataset::spec::Spec::parse(Path::new("spec.toml"), text);
    }
}

fn layout(data: &[u8]) {
    if let Ok(text) = std::str::from_utf8(data)
        && let Ok(layout) = crate::skeleton::layout::Layout::from_toml(text, "layout.toml")
    {
        let _ = layout.bind(&Rig::standard());
    }
}

/// Every CDR message type autoact reads from a bag.
fn cdr_messages(data: &[u8]) {
    let _ = cdr::decode::<Skeleton3D>(data);
    let _ = cdr::decode::<BoneFrame>(data);
    let _ = cdr::decode::<TFMessage>(data);
    let _ = cdr::decode::<SceneState>(data);
    let _ = cdr::decode::<Segment>(data);
}

/// A pose bag, read and converted as `autoact convert` does (the output goes to a file beside
/// it, which is dropped).
fn pose_mcap(data: &[u8]) {
    with_file(data, "in.pose.mcap", |path| {
        let _ = crate::inspect::inspect(path);
        let job = crate::pipeline::convert::ConvertJob {
            input: path.to_path_buf(),
            topic: None,
            layout: None,
            fps: 30.0,
            solve: crate::skeleton::convert::ConvertOptions::default(),
            dsi: None,
            max_gap_s: None,
            ground: crate::skeleton::ground::GroundMode::Auto,
            output: crate::bags::output::OutputOptions {
                path: path.with_file_name("out.mcap"),
                compression: crate::mcap_io::Compression::Zstd,
                rosbag2: None,
                journal: false,
                force: true,
            },
        };
        let _ = crate::pipeline::convert::convert_bag(&Rig::standard(), &job);
    });
}

/// An animation bag, read as `autoact export` and `render` read it.
fn anim_mcap(data: &[u8]) {
    with_file(data, "in.anim.mcap", |path| {
        let _ = crate::inspect::inspect(path);
        if let Ok(readers) = crate::mcap_io::BagReader::open_all(path) {
            let _ = crate::bags::animation::read_animation(&Rig::standard(), &readers, None);
        }
    });
}
