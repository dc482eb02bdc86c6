//! `[randomise]` end to end: the capture bag records the spec's section, so `convert --spec` +
//! `render` draws `generate`'s frames (and `--no-randomise` does not); `jpeg_quality` draws each
//! clip's rawframe quality, the same in `generate` and in `trim --jpeg-quality`, rerun after
//! rerun.

#![expect(clippy::unwrap_used, reason = "test helpers fail loudly")]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::common::{self, arg, autoact, stderr};

/// One session (the wave in two scenes), every `[randomise]` key far from its default. `crf =
/// [0, 0]` encodes losslessly (and replaces `--crf`, so it checks that the drawn CRF reaches
/// `render` too): the decoded frames are then the drawn ones, whatever the keyframes.
fn spec_toml() -> String {
    format!(
        r#"[dataset]
name = "rz"
seed = 6
fps = 8.0
resolution = [320, 240]
lead_in_s = 0.1
lead_out_s = 0.1
session = "dataset"
[counts]
variants = 1
scenes = 2
viewpoints = 1
[randomise]
hue_jitter_deg = 60.0
saturation_jitter = 0.5
brightness_jitter = 0.4
sensor_noise = [0.04, 0.08]
motion_blur = [0.3, 0.6]
crf = [0, 0]
jpeg_quality = [6, 30]
[[class]]
category = "gesture"
action = "wave"
sources = ["{}"]
"#,
        common::repo("bags/bandai_wave.pose.mcap")
    )
}

/// The one file in `dir` whose name ends with `suffix`.
fn only(dir: &Path, suffix: &str) -> PathBuf {
    let found: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(suffix))
        .collect();
    assert_eq!(found.len(), 1, "{suffix} in {}: {found:?}", dir.display());
    found.into_iter().next().unwrap()
}

/// The MD5 of every decoded frame of `video` (ffmpeg's framemd5), in order.
fn frame_digests(ffmpeg: &autoact::video::Ffmpeg, video: &Path) -> Vec<String> {
    let o = std::process::Command::new(ffmpeg.ffmpeg_path())
        .args(["-v", "error", "-i", arg(video), "-f", "framemd5", "-"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8(o.stdout)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.rsplit(',').next().unwrap().trim().to_owned())
        .collect()
}

/// Renders `bag` to `dir/<name>.mp4` at 64×48 with `extra` options.
fn render(bag: &Path, dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let video = dir.join(format!("{name}.mp4"));
    let mut args = vec![
        "render",
        arg(bag),
        "-o",
        arg(&video),
        "--resolution",
        "64x48",
    ];
    args.extend(extra);
    let o = autoact(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    video
}

/// Every rawframe of a dataset folder: path relative to it → bytes.
fn rawframes(dataset: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let root = dataset.join("rawframes");
    for label in std::fs::read_dir(&root).unwrap() {
        for clip in std::fs::read_dir(label.unwrap().path()).unwrap() {
            for frame in std::fs::read_dir(clip.unwrap().path()).unwrap() {
                let path = frame.unwrap().path();
                let rel = path.strip_prefix(&root).unwrap().to_string_lossy().into();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    out
}

/// Each clip's recorded JPEG quality, from `manifest.jsonl`.
fn jpeg_qualities(dataset: &Path) -> BTreeMap<String, u64> {
    std::fs::read_to_string(dataset.join("manifest.jsonl"))
        .unwrap()
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            let id = v["clip_id"].as_str().unwrap().to_owned();
            (
                id,
                v["jpeg_quality"].as_u64().expect("a drawn jpeg_quality"),
            )
        })
        .collect()
}

/// Trims `capture`'s `video` into `out` with rawframes, at `--jpeg-quality quality` if given.
fn trim(capture: &Path, video: &Path, out: &Path, quality: Option<&str>) {
    let mut args = vec![
        "trim",
        arg(capture),
        arg(video),
        "-o",
        arg(out),
        "--rawframes",
    ];
    if let Some(q) = quality {
        args.extend(["--jpeg-quality", q]);
    }
    let o = autoact(&args);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn render_draws_generates_randomised_frames_and_rawframes_get_drawn_jpeg_qualities() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("spec.toml");
    std::fs::write(&spec, spec_toml()).unwrap();
    let generated = dir.path().join("gen");
    let o = autoact(&[
        "generate",
        arg(&spec),
        "-o",
        arg(&generated),
        "--resolution",
        "64x48",
        "--rawframes",
        "--keep-intermediates",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let generate_video = only(&generated.join("renders"), ".mp4");
    let want = frame_digests(&ffmpeg, &generate_video);
    assert!(want.len() > 10, "{} frames", want.len());

    // `convert --spec` + `render`: the same frames, from the recorded `[randomise]`.
    let bag = common::capture_bag_from_spec(dir.path(), &spec_toml());
    let rendered = render(&bag, dir.path(), "r", &[]);
    assert_eq!(frame_digests(&ffmpeg, &rendered), want);
    // `--no-randomise` draws other (clean) pictures: not one frame is the same.
    let clean = render(&bag, dir.path(), "clean", &["--no-randomise", "--crf", "0"]);
    let clean = frame_digests(&ffmpeg, &clean);
    assert_eq!(clean.len(), want.len());
    assert!(clean.iter().zip(&want).all(|(a, b)| a != b));

    // Rawframes: each clip's quality drawn in [6, 30], not all alike, as the manifest says.
    let dataset = generated.join("dataset");
    let drawn = jpeg_qualities(&dataset);
    assert_eq!(drawn.len(), 2, "{drawn:?}");
    assert!(drawn.values().all(|q| (6..=30).contains(q)), "{drawn:?}");
    assert!(drawn.values().min() != drawn.values().max(), "{drawn:?}");
    // Standalone `trim` draws the same (same seed and clip ids) from the range the capture bag
    // recorded: the same bytes as generate's; and again on a fresh rerun given the range.
    let capture = only(&generated.join("captures"), ".mcap");
    let again = dir.path().join("again");
    trim(&capture, &generate_video, &again, None);
    assert_eq!(jpeg_qualities(&again), drawn);
    let frames = rawframes(&dataset);
    assert!(
        rawframes(&again) == frames,
        "rawframes differ from generate's"
    );
    std::fs::remove_dir_all(&again).unwrap();
    trim(&capture, &generate_video, &again, Some("6,30"));
    assert!(rawframes(&again) == frames, "a rerun's rawframes differ");
    // At the best quality every clip's frames are larger than at its drawn one.
    let best = dir.path().join("best");
    trim(&capture, &generate_video, &best, Some("2"));
    let best_frames = rawframes(&best);
    for clip in drawn.keys() {
        let bytes = |f: &BTreeMap<String, Vec<u8>>| -> usize {
            f.iter()
                .filter(|(k, _)| k.contains(clip.as_str()))
                .map(|(_, v)| v.len())
                .sum()
        };
        assert!(
            bytes(&best_frames) > bytes(&frames),
            "{clip}: {} bytes at q 2, {} at q {}",
            bytes(&best_frames),
            bytes(&frames),
            drawn[clip]
        );
    }
}
