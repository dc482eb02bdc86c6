//! `autoact trim` and the cuts under it: frame exactness (every clip holds exactly its
//! segment's frames, checked by decoding frames whose grey levels code their index), by stream
//! copy and by re-encoding.

#![expect(clippy::unwrap_used, reason = "test helpers fail loudly")]

use std::path::Path;
use std::process::Command;

use autoact::video::{
    CutClip, CutMethod, CutRequest, EncodeSettings, Ffmpeg, Mp4Source, Rational, ReencodeSettings,
    VideoEncoder, VideoError, cut, keyframe_frames, probe_packets,
};

const W: u32 = 160;
const H: u32 = 96;

/// Frame `k` as three flat grey strips: the nibbles of `k` (low first), 16 grey levels apart.
fn coded_frame(k: u64) -> Vec<u8> {
    let level = |n: u64| u8::try_from((n % 16) * 16 + 8).unwrap();
    let nibbles = [level(k), level(k / 16), level(k / 256)];
    let mut rgb = Vec::with_capacity((W * H * 3) as usize);
    for _y in 0..H {
        for x in 0..W {
            let v = nibbles[(x * 3 / W) as usize];
            rgb.extend_from_slice(&[v, v, v]);
        }
    }
    rgb
}

/// Encodes `frames` coded frames at 30 fps with keyframes at `keyframes`.
fn coded_video(ffmpeg: &Ffmpeg, path: &Path, frames: u64, keyframes: &[u64]) {
    let settings = EncodeSettings::new(W, H, 30.0).with_keyframes(keyframes.iter().copied());
    let mut enc = VideoEncoder::start(ffmpeg, path, &settings).unwrap();
    for k in 0..frames {
        enc.write_frame(&coded_frame(k)).unwrap();
    }
    enc.finish().unwrap();
}

/// Decodes a video and reads each frame's index back from its grey levels.
fn decoded_indices(ffmpeg: &Ffmpeg, path: &Path) -> Vec<u64> {
    let out = Command::new(ffmpeg.ffmpeg_path())
        .args(["-v", "error", "-i"])
        .arg(path)
        .args(["-f", "rawvideo", "-pix_fmt", "gray", "-"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let size = (W * H) as usize;
    assert_eq!(out.stdout.len() % size, 0);
    out.stdout
        .chunks(size)
        .map(|f| {
            let at = |strip: u32| u64::from(f[(H / 2 * W + W * (2 * strip + 1) / 6) as usize]) / 16;
            at(0) + 16 * at(1) + 256 * at(2)
        })
        .collect()
}

/// Cuts `frame_count` frames from `start_frame` of a 30 fps `input` into `output`.
fn cut30(
    ffmpeg: &Ffmpeg,
    input: &Path,
    output: &Path,
    start_frame: u64,
    frame_count: u64,
    method: CutMethod,
) -> Result<CutClip, VideoError> {
    let request = CutRequest {
        input,
        output,
        start_frame,
        frame_count,
        fps: Rational::new(30, 1).unwrap(),
        method,
    };
    cut(ffmpeg, &request, &ReencodeSettings::default())
}

#[test]
fn coded_frames_decode_back_to_their_index() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    coded_video(&ffmpeg, &src, 600, &[]);
    assert_eq!(decoded_indices(&ffmpeg, &src), (0..600).collect::<Vec<_>>());
}

#[test]
fn a_stream_with_b_frames_offers_no_keyframes_to_copy_from() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("b.mp4");
    // x264's default preset reorders frames (B-frames); frames are then stored out of order.
    let o = std::process::Command::new(ffmpeg.ffmpeg_path())
        .args([
            "-v",
            "error",
            "-nostdin",
            "-y",
            "-f",
            "lavfi",
            "-i",
            "testsrc=size=160x96:rate=30",
        ])
        .args(["-frames:v", "90", "-c:v", "libx264", "-bf", "2", "-g", "30"])
        .arg(&src)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (count, keys) = keyframe_frames(&ffmpeg, &src).unwrap();
    assert_eq!(count, 90);
    assert!(
        keys.is_empty(),
        "a reordered stream must be re-encoded: {keys:?}"
    );
}

#[test]
fn stream_copy_at_keyframes_is_frame_exact() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    let boundaries = [0, 37, 45, 90, 91, 150, 199];
    coded_video(&ffmpeg, &src, 200, &boundaries);
    let (count, keys) = keyframe_frames(&ffmpeg, &src).unwrap();
    assert_eq!(count, 200);
    for b in boundaries {
        assert!(keys.contains(&b), "{b} is not a keyframe: {keys:?}");
    }
    for w in boundaries.windows(2) {
        let out = dir.path().join(format!("copy_{}.mp4", w[0]));
        let clip = cut30(
            &ffmpeg,
            &src,
            &out,
            w[0],
            w[1] - w[0],
            CutMethod::StreamCopy,
        )
        .unwrap();
        assert_eq!(clip.frame_count, w[1] - w[0]);
        assert_eq!(
            decoded_indices(&ffmpeg, &out),
            (w[0]..w[1]).collect::<Vec<_>>(),
            "clip [{}, {})",
            w[0],
            w[1]
        );
    }
    // The last segment runs to the end of the video.
    let out = dir.path().join("tail.mp4");
    cut30(&ffmpeg, &src, &out, 199, 1, CutMethod::StreamCopy).unwrap();
    assert_eq!(decoded_indices(&ffmpeg, &out), vec![199]);
}

#[test]
fn in_process_copy_is_frame_exact_and_agrees_with_ffprobe() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    let boundaries = [0, 37, 45, 90, 91, 150, 199, 200];
    coded_video(&ffmpeg, &src, 200, &boundaries);
    let mp4 = Mp4Source::open(&src)
        .unwrap()
        .expect("our own render is copied in-process");
    let (count, keys) = keyframe_frames(&ffmpeg, &src).unwrap();
    assert_eq!((mp4.frame_count(), mp4.keyframes()), (count, keys));
    for w in boundaries.windows(2) {
        let out = dir.path().join(format!("copy_{}.mp4", w[0]));
        let clip = mp4.cut(&out, w[0], w[1] - w[0]).unwrap();
        assert_eq!(clip.frame_count, w[1] - w[0]);
        assert_eq!(clip.bytes, std::fs::metadata(&out).unwrap().len());
        assert_eq!(
            decoded_indices(&ffmpeg, &out),
            (w[0]..w[1]).collect::<Vec<_>>(),
            "clip [{}, {})",
            w[0],
            w[1]
        );
        // ffprobe sees the clip's frames timed from zero at 30 fps, the first one a keyframe.
        let packets = probe_packets(&ffmpeg, &out).unwrap();
        assert_eq!(packets.len() as u64, w[1] - w[0]);
        assert!(packets[0].key);
        assert_eq!(packets[0].pts, Some(0));
        // The same cut twice is the same file (shards agree byte for byte).
        let again = dir.path().join(format!("again_{}.mp4", w[0]));
        mp4.cut(&again, w[0], w[1] - w[0]).unwrap();
        assert_eq!(std::fs::read(&out).unwrap(), std::fs::read(&again).unwrap());
    }
    // Off a keyframe, or past the end: an error and no file.
    let out = dir.path().join("bad.mp4");
    assert!(mp4.cut(&out, 30, 5).is_err());
    assert!(matches!(
        mp4.cut(&out, 190, 20),
        Err(VideoError::FrameCountMismatch { found: 10, .. })
    ));
    assert!(!out.exists());
    assert!(
        !std::fs::read_dir(dir.path()).unwrap().any(|e| e
            .unwrap()
            .file_name()
            .to_string_lossy()
            .ends_with(".part")),
        "no .part file left"
    );
}

/// Encodes frames `frames` (their indices coded in grey) as one piece of a longer stream.
fn coded_piece(ffmpeg: &Ffmpeg, path: &Path, frames: std::ops::Range<u64>, keyframes: &[u64]) {
    let settings = EncodeSettings::new(W, H, 30.0).with_keyframes(keyframes.iter().copied());
    let mut enc = VideoEncoder::start(ffmpeg, path, &settings).unwrap();
    for k in frames {
        enc.write_frame(&coded_frame(k)).unwrap();
    }
    enc.finish().unwrap();
}

#[test]
fn pieces_encoded_apart_join_into_one_frame_exact_video() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // Three pieces of a 100-frame stream (each encoder's own frame 0 is a keyframe), one with a
    // keyframe inside.
    let bounds = [0, 37, 45, 100];
    let mut parts = Vec::new();
    for (i, w) in bounds.windows(2).enumerate() {
        let path = dir.path().join(format!("piece{i}.mp4"));
        coded_piece(&ffmpeg, &path, w[0]..w[1], if i == 2 { &[20] } else { &[] });
        parts.push(Mp4Source::open(&path).unwrap().unwrap());
    }
    let joined = dir.path().join("joined.mp4");
    let bytes = autoact::video::concat_mp4(&parts, &joined).unwrap();
    assert_eq!(bytes, std::fs::metadata(&joined).unwrap().len());
    assert_eq!(
        decoded_indices(&ffmpeg, &joined),
        (0..100).collect::<Vec<_>>()
    );
    let mp4 = Mp4Source::open(&joined).unwrap().unwrap();
    assert_eq!(mp4.keyframes(), vec![0, 37, 45, 65]);
    let (count, keys) = keyframe_frames(&ffmpeg, &joined).unwrap();
    assert_eq!((count, keys), (100, vec![0, 37, 45, 65]));
    // Timed as one stream: frame k at k/30 s.
    let packets = probe_packets(&ffmpeg, &joined).unwrap();
    assert_eq!(packets.len(), 100);
    assert_eq!(packets[99].pts, packets[1].pts.map(|p| p * 99));
    // A clip cut from the join across a piece boundary is the frames asked for.
    let clip = dir.path().join("clip.mp4");
    mp4.cut(&clip, 37, 30).unwrap();
    assert_eq!(
        decoded_indices(&ffmpeg, &clip),
        (37..67).collect::<Vec<_>>()
    );
    // Joining the same pieces again gives the same bytes.
    let again = dir.path().join("again.mp4");
    autoact::video::concat_mp4(&parts, &again).unwrap();
    assert_eq!(
        std::fs::read(&joined).unwrap(),
        std::fs::read(&again).unwrap()
    );
    // Pieces of another size are not pieces of one stream: refused, no file left.
    let other = dir.path().join("other.mp4");
    let settings = EncodeSettings::new(W + 16, H, 30.0);
    let mut enc = VideoEncoder::start(&ffmpeg, &other, &settings).unwrap();
    enc.write_frame(&vec![0; ((W + 16) * H * 3) as usize])
        .unwrap();
    enc.finish().unwrap();
    parts.push(Mp4Source::open(&other).unwrap().unwrap());
    let refused = dir.path().join("refused.mp4");
    assert!(autoact::video::concat_mp4(&parts, &refused).is_err());
    assert!(!refused.exists());
}

#[test]
fn in_process_copy_declines_what_it_cannot_copy_exactly() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // B-frames (reordered), and a Matroska file: both left to ffmpeg.
    for (name, extra) in [("b.mp4", ["-bf", "2"]), ("m.mkv", ["-bf", "0"])] {
        let path = dir.path().join(name);
        let o = Command::new(ffmpeg.ffmpeg_path())
            .args(["-v", "error", "-nostdin", "-y", "-f", "lavfi"])
            .args(["-i", "testsrc=size=160x96:rate=30", "-frames:v", "30"])
            .args(["-c:v", "libx264"])
            .args(extra)
            .arg(&path)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(Mp4Source::open(&path).unwrap().is_none(), "{name}");
    }
    let junk = dir.path().join("junk.mp4");
    std::fs::write(&junk, b"not an mp4 at all").unwrap();
    assert!(Mp4Source::open(&junk).unwrap().is_none());
    assert!(Mp4Source::open(&dir.path().join("missing.mp4")).is_err());
}

#[test]
fn stream_copy_off_a_keyframe_is_rejected_and_leaves_nothing() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    coded_video(&ffmpeg, &src, 120, &[60]);
    let out = dir.path().join("clip.mp4");
    let err = cut30(&ffmpeg, &src, &out, 30, 20, CutMethod::StreamCopy).unwrap_err();
    assert!(
        matches!(err, VideoError::FrameCountMismatch { .. }),
        "{err}"
    );
    assert_eq!(
        std::fs::read_dir(dir.path()).unwrap().count(),
        1,
        "only src.mp4 left"
    );
}

#[test]
fn reencode_anywhere_is_frame_exact() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    // Keyframes only every 250 frames: nothing below lands on one except frame 0.
    coded_video(&ffmpeg, &src, 240, &[]);
    for (start, count) in [(0, 10), (1, 1), (17, 33), (100, 77), (239, 1)] {
        let out = dir.path().join(format!("re_{start}.mp4"));
        cut30(&ffmpeg, &src, &out, start, count, CutMethod::Reencode).unwrap();
        assert_eq!(
            decoded_indices(&ffmpeg, &out),
            (start..start + count).collect::<Vec<_>>(),
            "clip at {start}"
        );
    }
}

#[test]
fn a_cut_past_the_end_is_an_error_naming_the_clip() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("src.mp4");
    coded_video(&ffmpeg, &src, 60, &[]);
    let out = dir.path().join("late.mp4");
    let err = cut30(&ffmpeg, &src, &out, 50, 30, CutMethod::Reencode).unwrap_err();
    assert!(err.to_string().contains("late.mp4"), "{err}");
    assert!(!out.exists());
}

#[test]
fn a_corrupt_video_is_an_error_with_ffmpegs_words() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("broken.mp4");
    std::fs::write(&src, b"not a video at all").unwrap();
    let out = dir.path().join("clip.mp4");
    let err = cut30(&ffmpeg, &src, &out, 0, 3, CutMethod::StreamCopy).unwrap_err();
    let text = err.to_string();
    assert!(
        text.contains("clip.mp4") && text.contains("broken.mp4"),
        "{text}"
    );
    assert!(!out.exists());
}

// ---------------------------------------------------------------------------------------------
// `autoact trim` end to end, on a capture bag from a tiny spec and a synthetic capture video whose
// frame k carries k.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;

use crate::common::{self, autoact, stderr, stdout};
use autoact::bags::capture::Capture;
use autoact::ros::builtin_interfaces::Time;
use autoact::skeleton::rig::Rig;
use autoact::trim::planned::PlannedClips;
use autoact::trim::split::SplitItem;

/// A one-session capture bag with two classes; the wave class is labelled `wave_label`.
fn capture_bag(dir: &Path, wave_label: &str) -> PathBuf {
    capture_bag_of(dir, wave_label, "pose")
}

/// A dataset spec of two classes, `wave_label` and `walk`, from the sample bags of `kind` (`pose`
/// or `anim`): `name`, `seed`, `session` and `[variants, scenes, viewpoints]` as given.
fn two_class_spec(
    name: &str,
    seed: u32,
    session: &str,
    counts: [u32; 3],
    wave_label: &str,
    kind: &str,
) -> String {
    let [variants, scenes, viewpoints] = counts;
    format!(
        r#"[dataset]
name = "{name}"
seed = {seed}
fps = 30.0
resolution = [320, 240]
lead_in_s = 0.1
lead_out_s = 0.1
session = "{session}"
[counts]
variants = {variants}
scenes = {scenes}
viewpoints = {viewpoints}
[[class]]
category = "gesture"
action = {wave_label:?}
sources = ["{wave}"]

[[class]]
category = "locomotion"
action = "walk"
sources = ["{walk}"]
"#,
        wave = common::repo(&format!("bags/bandai_wave.{kind}.mcap")),
        walk = common::repo(&format!("bags/bandai_walk.{kind}.mcap")),
    )
}

/// [`capture_bag`] with the sample bags of `kind` (`pose` or `anim`) as sources: the same
/// classes, other clip ids.
fn capture_bag_of(dir: &Path, wave_label: &str, kind: &str) -> PathBuf {
    let spec = two_class_spec("t", 5, "dataset", [3, 1, 2], wave_label, kind);
    common::capture_bag_from_spec(dir, &spec)
}

/// The capture's frame index for every segment: (segment id, start frame, end frame).
fn segment_frames(capture: &Capture) -> Vec<(String, u64, u64)> {
    frames_of(capture, |s| (s.start, s.end))
}

/// The capture's frame index for every segment's animation, which the default clip policy
/// (`whole`, leads excluded) cuts: (segment id, first frame, end frame).
fn animation_frames(capture: &Capture) -> Vec<(String, u64, u64)> {
    frames_of(capture, |s| (s.content_start, s.content_end))
}

/// The capture's frame indices of the times `span` picks from each segment.
fn frames_of(
    capture: &Capture,
    span: impl Fn(&autoact::ros::autoact_msgs::Segment) -> (Time, Time),
) -> Vec<(String, u64, u64)> {
    let index = |t: Time| {
        let ns = t.to_nanos().unwrap();
        capture.stamps.count_before(ns) as u64
    };
    capture
        .segments
        .iter()
        .map(|s| {
            let (a, b) = span(s);
            (s.id.clone(), index(a), index(b))
        })
        .collect()
}

struct Setup {
    dir: tempfile::TempDir,
    bag: PathBuf,
    capture: Capture,
}

fn setup(wave_label: &str) -> Setup {
    let dir = tempfile::tempdir().unwrap();
    let bag = capture_bag(dir.path(), wave_label);
    let capture = Capture::read(&Rig::standard(), &bag).unwrap();
    Setup { dir, bag, capture }
}

impl Setup {
    /// `capture.mp4` beside the bag: one index-coded frame per timeline frame, keyframes on
    /// every boundary (what `autoact render` makes).
    fn coded_capture_video(&self, ffmpeg: &Ffmpeg) -> PathBuf {
        let video = self.dir.path().join("capture.mp4");
        let frames = self.capture.frame_count() as u64;
        coded_video(ffmpeg, &video, frames, &self.capture.boundary_frames());
        video
    }

    /// The coded video, trimmed once into `ds` (`--video-start 0`): (video, dataset folder).
    fn trimmed_once(&self, ffmpeg: &Ffmpeg) -> (PathBuf, PathBuf) {
        let video = self.coded_capture_video(ffmpeg);
        let out = self.dir.path().join("ds");
        let o = run_trim(&self.bag, &video, &out, &["--video-start", "0"]);
        assert!(o.status.success(), "{}", stderr(&o));
        (video, out)
    }
}

fn run_trim(bag: &Path, video: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "trim",
        bag.to_str().unwrap(),
        video.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    autoact(&args)
}

fn read_jsonl(path: &Path) -> Vec<serde_json::Value> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect()
}

/// Every list line names a complete clip on disk; returns the clips listed per split.
fn check_lists(out: &Path) -> BTreeMap<String, Vec<String>> {
    let mut listed = BTreeMap::new();
    for split in ["train", "val", "test"] {
        let text =
            std::fs::read_to_string(out.join(format!("annotations/{split}_list_videos.txt")))
                .unwrap();
        let mut clips = Vec::new();
        for line in text.lines() {
            let parts: Vec<&str> = line.split(' ').collect();
            assert_eq!(parts.len(), 2, "{line:?}");
            assert!(out.join(parts[0]).is_file(), "{line} names a missing clip");
            parts[1].parse::<u32>().unwrap();
            clips.push(parts[0].to_owned());
        }
        let csv =
            std::fs::read_to_string(out.join(format!("annotations/kinetics_{split}.csv"))).unwrap();
        assert!(csv.starts_with("label,youtube_id,time_start,time_end,split\n"));
        assert_eq!(csv.lines().count() - 1, clips.len());
        listed.insert(split.to_owned(), clips);
    }
    listed
}

#[test]
fn trim_cuts_every_segment_frame_exact_by_stream_copy() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    let video = s.coded_capture_video(&ffmpeg);
    let out = s.dir.path().join("ds");
    // Split by variant: three variants per class, so all three splits get clips and a variant
    // seen in two splits would show.
    let o = run_trim(
        &s.bag,
        &video,
        &out,
        &[
            "--video-start",
            "0",
            "--split-by",
            "variant",
            "--split-ratios",
            "0.34,0.33,0.33",
        ],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("by stream copy"), "{}", stdout(&o));
    let clips = read_jsonl(&out.join("annotations/clips.jsonl"));
    let expected = animation_frames(&s.capture);
    assert_eq!(clips.len(), expected.len());
    for (id, start, end) in &expected {
        let c = clips
            .iter()
            .find(|c| c["segment_id"] == id.as_str())
            .unwrap();
        assert_eq!(c["method"], "stream_copy", "{c}");
        assert_eq!(c["frame_count"], end - start);
        // `whole`: the animation, leads excluded; the action is the whole clip.
        assert_eq!(c["policy"], "whole");
        let span = &c["action_span"];
        assert_eq!(span["start_frame"], 0, "{c}");
        assert_eq!(span["end_frame"], end - start);
        assert_eq!(span["animation_start_frame"], 0);
        assert_eq!(span["animation_end_frame"], end - start);
        assert!((span["video_start_s"].as_f64().unwrap() - *start as f64 / 30.0).abs() < 1e-9);
        let path = out.join(c["video"].as_str().unwrap());
        assert_eq!(
            decoded_indices(&ffmpeg, &path),
            (*start..*end).collect::<Vec<_>>(),
            "{id}"
        );
        for key in [
            "animation",
            "variant",
            "weather",
            "time",
            "location",
            "character",
            "camera",
            "seed",
            "split",
        ] {
            assert!(!c[key].is_null(), "{key} missing in {c}");
        }
    }
    let listed = check_lists(&out);
    assert_eq!(listed.values().map(Vec::len).sum::<usize>(), expected.len());
    assert_eq!(
        std::fs::read_to_string(out.join("annotations/classes.txt")).unwrap(),
        "walk\nwave\n"
    );
    // No variant of a source animation in two splits, and every split used.
    let mut by_variant: BTreeMap<(String, String), BTreeSet<String>> = BTreeMap::new();
    for c in &clips {
        by_variant
            .entry((
                c["animation"].as_str().unwrap().to_owned(),
                c["variant"].to_string(),
            ))
            .or_default()
            .insert(c["split"].as_str().unwrap().to_owned());
    }
    assert_eq!(by_variant.len(), 6, "{by_variant:?}");
    assert!(by_variant.values().all(|s| s.len() == 1), "{by_variant:?}");
    let used: BTreeSet<&String> = by_variant.values().flatten().collect();
    assert_eq!(
        used.len(),
        3,
        "train, val and test all hold clips: {by_variant:?}"
    );
    let anet: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("annotations/activitynet.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(
        anet["database"]["capture"]["annotations"]
            .as_array()
            .unwrap()
            .len(),
        expected.len()
    );
}

#[test]
fn trim_reencodes_a_foreign_video_placed_with_video_start() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    // A "screen recording" that starts 10 frames into the timeline, keyframes every 2 s only.
    let video = s.dir.path().join("recording.mp4");
    let n = s.capture.frame_count() as u64;
    let settings = EncodeSettings::new(W, H, 30.0);
    let mut enc = VideoEncoder::start(&ffmpeg, &video, &settings).unwrap();
    for k in 10..n {
        enc.write_frame(&coded_frame(k)).unwrap();
    }
    enc.finish().unwrap();
    let out = s.dir.path().join("ds");
    let o = run_trim(&s.bag, &video, &out, &["--video-start", "0.3333333333"]);
    let expected = animation_frames(&s.capture);
    let lost = expected.iter().filter(|(_, a, _)| *a < 10).count();
    assert!(
        lost > 0,
        "the first segment starts at frame {}",
        expected[0].1
    );
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains("left out"), "{}", stderr(&o));
    let clips = read_jsonl(&out.join("annotations/clips.jsonl"));
    assert_eq!(clips.len(), expected.len() - lost);
    for c in &clips {
        let (_, start, end) = expected
            .iter()
            .find(|(id, ..)| c["segment_id"] == id.as_str())
            .unwrap();
        let path = out.join(c["video"].as_str().unwrap());
        // The clip's frames, by their index on the capture timeline.
        assert_eq!(
            decoded_indices(&ffmpeg, &path),
            (*start..*end).collect::<Vec<_>>()
        );
    }
    assert!(clips.iter().any(|c| c["method"] == "reencode"));
    check_lists(&out);
}

/// Every annotation file's bytes (the contact sheets' folder too), by path in the folder.
fn annotation_files(out: &Path) -> BTreeMap<String, Vec<u8>> {
    fn walk(dir: &Path, prefix: &str, files: &mut BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let e = e.unwrap();
            let name = format!("{prefix}{}", e.file_name().to_string_lossy());
            if e.file_type().unwrap().is_dir() {
                walk(&e.path(), &format!("{name}/"), files);
            } else {
                files.insert(name, std::fs::read(e.path()).unwrap());
            }
        }
    }
    let mut files = BTreeMap::new();
    walk(&out.join("annotations"), "", &mut files);
    files
}

#[test]
fn trim_resumes_without_duplicates_and_relists_only_complete_clips() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    let (video, out) = s.trimmed_once(&ffmpeg);
    let lists_before = check_lists(&out);
    let files_before = annotation_files(&out);
    let manifest = out.join("manifest.jsonl");
    let lines = std::fs::read_to_string(&manifest).unwrap().lines().count();

    let o = run_trim(&s.bag, &video, &out, &["--video-start", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("0 by stream copy, 0 re-encoded"),
        "{}",
        stdout(&o)
    );
    assert_eq!(
        std::fs::read_to_string(&manifest).unwrap().lines().count(),
        lines
    );
    assert_eq!(check_lists(&out), lists_before, "same seed, same splits");
    assert_eq!(
        annotation_files(&out),
        files_before,
        "a re-run rewrites identical bytes"
    );

    // A half-finished run: one clip gone, a torn manifest line.
    let victim = out.join(lists_before.values().flatten().next().unwrap());
    std::fs::remove_file(&victim).unwrap();
    let mut text = std::fs::read_to_string(&manifest).unwrap();
    text.push_str("{\"clip_id\":\"torn");
    std::fs::write(&manifest, text).unwrap();
    let o = run_trim(&s.bag, &video, &out, &["--video-start", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("1 by stream copy"), "{}", stdout(&o));
    assert!(victim.is_file());
    assert_eq!(check_lists(&out), lists_before);
    let clips = read_jsonl(&out.join("annotations/clips.jsonl"));
    let ids: BTreeSet<&str> = clips
        .iter()
        .map(|c| c["clip_id"].as_str().unwrap())
        .collect();
    assert_eq!(ids.len(), clips.len(), "no duplicated clip");
}

#[test]
fn trim_extracts_each_clips_frames_for_rawframe_datasets() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    // First without frames; asking for them later extracts them for the clips already cut.
    let (video, out) = s.trimmed_once(&ffmpeg);
    assert!(!out.join("rawframes").exists());
    let o = run_trim(&s.bag, &video, &out, &["--video-start", "0", "--rawframes"]);
    assert!(o.status.success(), "{}", stderr(&o));

    let clips = read_jsonl(&out.join("annotations/clips.jsonl"));
    let expected = animation_frames(&s.capture);
    assert_eq!(clips.len(), expected.len());
    let mut listed = BTreeSet::new();
    for split in ["train", "val", "test"] {
        let list =
            std::fs::read_to_string(out.join(format!("annotations/{split}_list_rawframes.txt")))
                .unwrap();
        listed.extend(list.lines().map(str::to_owned));
    }
    for (id, start, end) in &expected {
        let c = clips
            .iter()
            .find(|c| c["segment_id"] == id.as_str())
            .unwrap();
        let rel = c["rawframes"].as_str().unwrap();
        let dir = out.join(rel);
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        let wanted: Vec<String> = (1..=end - start)
            .map(|k| format!("img_{k:05}.jpg"))
            .collect();
        assert_eq!(names, wanted, "{id}");
        assert_eq!(
            decoded_indices(&ffmpeg, &dir.join("img_%05d.jpg")),
            (*start..*end).collect::<Vec<_>>(),
            "{id}: the clip's own frames, in order"
        );
        let line = format!("{rel} {} {}", end - start, c["label_id"]);
        assert!(listed.contains(&line), "{line} not in {listed:?}");
    }
    assert_eq!(listed.len(), expected.len());
    // No half-written frame folder is left beside the complete ones.
    for label in std::fs::read_dir(out.join("rawframes")).unwrap() {
        for e in std::fs::read_dir(label.unwrap().path()).unwrap() {
            let name = e.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.starts_with('.'), "{name}");
        }
    }
}

#[test]
fn trim_gives_each_clip_its_own_depth_and_mask_frames() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    let video = s.coded_capture_video(&ffmpeg);
    let frames = s.capture.frame_count();
    // What `render --depth --masks` leaves beside the video; each file names its frame.
    for pass in ["capture.depth", "capture.mask"] {
        let dir = s.dir.path().join(pass);
        std::fs::create_dir_all(&dir).unwrap();
        for k in 0..frames {
            std::fs::write(dir.join(format!("frame_{k:06}.png")), format!("{pass} {k}")).unwrap();
        }
    }
    let out = s.dir.path().join("ds");
    let o = run_trim(&s.bag, &video, &out, &["--video-start", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let clips = read_jsonl(&out.join("annotations/clips.jsonl"));
    let expected = animation_frames(&s.capture);
    assert_eq!(clips.len(), expected.len());
    for (id, start, end) in &expected {
        let c = clips
            .iter()
            .find(|c| c["segment_id"] == id.as_str())
            .unwrap();
        for (key, pass) in [("depth", "capture.depth"), ("masks", "capture.mask")] {
            let dir = out.join(c[key].as_str().unwrap());
            let got: Vec<String> = (1..=end - start)
                .map(|k| std::fs::read_to_string(dir.join(format!("img_{k:05}.png"))).unwrap())
                .collect();
            let want: Vec<String> = (*start..*end).map(|k| format!("{pass} {k}")).collect();
            assert_eq!(got, want, "{id} {key}");
            assert!(!dir.join(format!("img_{:05}.png", end - start + 1)).exists());
        }
    }
    // A pass folder that is not this video's (a frame missing) is refused, naming it.
    std::fs::remove_file(
        s.dir
            .path()
            .join(format!("capture.mask/frame_{:06}.png", frames - 1)),
    )
    .unwrap();
    let o = run_trim(
        &s.bag,
        &video,
        &s.dir.path().join("ds2"),
        &["--video-start", "0"],
    );
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("capture.mask") && stderr(&o).contains("--force"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn trim_same_seed_gives_identical_lists_in_another_folder() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    let video = s.coded_capture_video(&ffmpeg);
    let read = |d: &Path| {
        [
            "classes.txt",
            "train_list_videos.txt",
            "val_list_videos.txt",
            "test_list_videos.txt",
            "kinetics_train.csv",
        ]
        .map(|n| std::fs::read_to_string(d.join("annotations").join(n)).unwrap())
    };
    let a = s.dir.path().join("a");
    let b = s.dir.path().join("b");
    for d in [&a, &b] {
        let o = run_trim(
            &s.bag,
            &video,
            d,
            &[
                "--video-start",
                "0",
                "--split-by",
                "clip",
                "--split-ratios",
                "0.5,0,0.5",
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(read(&a), read(&b));
}

#[test]
fn trim_sanitises_label_paths_and_keeps_the_label_in_the_csv() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    // `autoact convert` refuses labels with `/` or a leading `.`; `sanitize_name`'s unit test
    // covers `../`.
    let label = "air drumming ñandú";
    let s = setup(label);
    let video = s.coded_capture_video(&ffmpeg);
    let out = s.dir.path().join("ds");
    let o = run_trim(&s.bag, &video, &out, &["--video-start", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dirs: Vec<String> = std::fs::read_dir(out.join("videos"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(dirs.contains(&"air_drumming_ñandú".to_owned()), "{dirs:?}");
    let classes = std::fs::read_to_string(out.join("annotations/classes.txt")).unwrap();
    assert_eq!(classes, format!("{label}\nwalk\n"));
    let csv = std::fs::read_to_string(out.join("annotations/kinetics_train.csv")).unwrap();
    assert!(csv.contains("\"air drumming ñandú\","), "{csv}");
    check_lists(&out);
}

#[test]
fn trim_places_the_video_by_its_render_bag_and_refuses_another_captures() {
    use autoact::bags::render::{VIDEO_TOPIC, render_bag_beside};
    use autoact::mcap_io::{BagWriter, WriteConfig};
    use autoact::ros::autoact_msgs::VideoInfo;
    use autoact::ros::builtin_interfaces::Time;

    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    let video = s.coded_capture_video(&ffmpeg);
    let write_render_bag = |session: &str| {
        let mut info = VideoInfo {
            session: session.into(),
            capture_bag: "capture.mcap".into(),
            video_file: "capture.mp4".into(),
            fps: s.capture.fps,
            ..VideoInfo::default()
        };
        let first = s.capture.stamps.first().unwrap();
        info.header.stamp = Time::from_nanos(first);
        let mut w = BagWriter::create(&render_bag_beside(&video), WriteConfig::default()).unwrap();
        w.write(VIDEO_TOPIC, first, &info).unwrap();
        w.finish().unwrap();
    };

    write_render_bag(&s.capture.session);
    let by_bag = s.dir.path().join("by_bag");
    let o = run_trim(&s.bag, &video, &by_bag, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let by_start = s.dir.path().join("by_start");
    let o = run_trim(&s.bag, &video, &by_start, &["--video-start", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(annotation_files(&by_bag), annotation_files(&by_start));

    // A render of another session would put every cut in the wrong place.
    write_render_bag("another");
    let out = s.dir.path().join("other");
    let o = run_trim(&s.bag, &video, &out, &[]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("capture.render.mcap")
            && err.contains("session `another`")
            && err.contains(&format!("session `{}`", s.capture.session))
            && err.contains("--render-bag"),
        "{err}"
    );
    assert!(!out.join("annotations").exists(), "nothing cut");
}

#[test]
fn trim_without_ffmpeg_or_with_a_corrupt_video_fails_clearly() {
    let s = setup("wave");
    let video = s.dir.path().join("capture.mp4");
    std::fs::write(&video, b"garbage").unwrap();
    let out = s.dir.path().join("ds");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_autoact"))
        .args([
            "trim",
            s.bag.to_str().unwrap(),
            video.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--video-start",
            "0",
        ])
        .env("AUTOACT_FFMPEG", "/nonexistent/ffmpeg")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("apt-get install ffmpeg"),
        "{}",
        stderr(&o)
    );
    if common::ffmpeg_or_skip(module_path!()).is_none() {
        return;
    }
    let o = run_trim(&s.bag, &video, &out, &["--video-start", "0"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("capture.mp4"), "{}", stderr(&o));
    // Without a render bag or --video-start: told what to pass.
    let o = run_trim(&s.bag, &video, &out, &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--video-start"), "{}", stderr(&o));
}

#[test]
#[expect(clippy::print_stderr, reason = "a loud skip")]
fn trim_on_a_full_disk_fails_and_no_list_names_an_incomplete_clip() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    let video = s.coded_capture_video(&ffmpeg);
    // How much a full run writes.
    let full = s.dir.path().join("full");
    assert!(
        run_trim(&s.bag, &video, &full, &["--video-start", "0"])
            .status
            .success()
    );
    let bytes: u64 = std::fs::read_dir(full.join("videos"))
        .unwrap()
        .flat_map(|d| std::fs::read_dir(d.unwrap().path()).unwrap())
        .map(|f| f.unwrap().metadata().unwrap().len())
        .sum();
    // A tmpfs with room for about half the clips, in a private mount namespace; the result is
    // copied out before the namespace (and its tmpfs) goes away.
    let mount = s.dir.path().join("mnt");
    let copy = s.dir.path().join("copy");
    std::fs::create_dir(&mount).unwrap();
    let size = (bytes / 2).max(16 * 1024);
    let script = format!(
        "mount -t tmpfs -o size={size} autoact-test \"$1\" || exit 77; \
         \"$2\" trim \"$3\" \"$4\" -o \"$1/ds\" --video-start 0; echo \"rc=$?\" >&2; \
         cp -a \"$1/ds\" \"$5\""
    );
    let o = Command::new("unshare")
        .args(["-m", "--propagation", "private", "sh", "-c", &script, "sh"])
        .arg(&mount)
        .arg(env!("CARGO_BIN_EXE_autoact"))
        .arg(&s.bag)
        .arg(&video)
        .arg(&copy)
        .output()
        .unwrap();
    let err = stderr(&o);
    if o.status.code() == Some(77) || !copy.exists() {
        eprintln!("SKIPPED trim_on_a_full_disk…: cannot mount a tmpfs here: {err}");
        return;
    }
    assert!(err.contains("rc=1"), "{err}");
    assert!(err.contains("No space left"), "{err}");
    // Whatever lists exist name only clips that are complete: every one decodes fully.
    let clips = std::fs::read_to_string(copy.join("manifest.jsonl")).unwrap_or_default();
    let records: BTreeMap<String, u64> = clips
        .lines()
        .filter_map(|l| serde_json::from_str::<serde_json::Value>(l).ok())
        .map(|v| {
            (
                v["video"].as_str().unwrap().to_owned(),
                v["frame_count"].as_u64().unwrap(),
            )
        })
        .collect();
    assert!(
        records.len() < s.capture.segments.len(),
        "the disk was not full"
    );
    for split in ["train", "val", "test"] {
        let Ok(text) =
            std::fs::read_to_string(copy.join(format!("annotations/{split}_list_videos.txt")))
        else {
            continue;
        };
        for line in text.lines() {
            let path = line.split(' ').next().unwrap();
            let (count, _) = keyframe_frames(&ffmpeg, &copy.join(path)).unwrap();
            assert_eq!(Some(&count), records.get(path), "{line}");
        }
    }
    // No partial files left visible.
    for d in std::fs::read_dir(copy.join("videos")).unwrap() {
        for f in std::fs::read_dir(d.unwrap().path()).unwrap() {
            let name = f.unwrap().file_name().to_string_lossy().into_owned();
            assert!(!name.starts_with('.'), "{name} left behind");
        }
    }
}

#[test]
fn two_trims_into_one_folder_take_turns_and_list_every_clip() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    // Two captures of the same classes from different bags (so other clip ids), trimmed at
    // once into one folder: the second waits for the first, and the lists name both's clips.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("ds");
    let mut runs = Vec::new();
    let mut clips = 0;
    for kind in ["pose", "anim"] {
        let own = dir.path().join(kind);
        std::fs::create_dir(&own).unwrap();
        let bag = capture_bag_of(&own, "wave", kind);
        let capture = Capture::read(&Rig::standard(), &bag).unwrap();
        clips += capture.segments.len();
        let video = own.join("capture.mp4");
        coded_video(
            &ffmpeg,
            &video,
            capture.frame_count() as u64,
            &capture.boundary_frames(),
        );
        runs.push((bag, video));
    }
    let children: Vec<std::process::Child> = runs
        .iter()
        .map(|(bag, video)| {
            std::process::Command::new(env!("CARGO_BIN_EXE_autoact"))
                .args([
                    "trim",
                    bag.to_str().unwrap(),
                    video.to_str().unwrap(),
                    "-o",
                    out.to_str().unwrap(),
                    "--video-start",
                    "0",
                ])
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for child in children {
        let o = child.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let listed: usize = check_lists(&out).values().map(Vec::len).sum();
    assert_eq!(listed, clips, "every clip of both captures listed once");
    assert_eq!(read_jsonl(&out.join("manifest.jsonl")).len(), clips);
}

/// The demo's shape (`examples/dataset.toml`): two classes of one source animation each, 2
/// variants × 2 scenes × 3 viewpoints, one session (capture bag) per animation.
fn demo_like_bags(dir: &Path) -> Vec<PathBuf> {
    let spec = two_class_spec("d", 7, "animation", [2, 2, 3], "wave", "pose");
    common::capture_bags_from_spec(dir, &spec)
}

/// Every clip's `(label, animation, variant, scene, split, split_by)` in `clips.jsonl`, by id.
fn clip_splits(out: &Path) -> BTreeMap<String, [String; 6]> {
    read_jsonl(&out.join("annotations/clips.jsonl"))
        .into_iter()
        .map(|c| {
            let field = |k: &str| match &c[k] {
                serde_json::Value::String(s) => s.clone(),
                other => other.to_string(),
            };
            (
                field("clip_id"),
                [
                    "label",
                    "animation",
                    "variant",
                    "scene",
                    "split",
                    "split_by",
                ]
                .map(field),
            )
        })
        .collect()
}

#[test]
fn splits_come_from_the_plan_whatever_order_the_captures_are_trimmed_in() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let bags = demo_like_bags(dir.path());
    assert_eq!(bags.len(), 2, "{bags:?}");
    let videos: Vec<PathBuf> = bags
        .iter()
        .enumerate()
        .map(|(i, bag)| {
            let capture = Capture::read(&Rig::standard(), bag).unwrap();
            let video = dir.path().join(format!("capture{i}.mp4"));
            coded_video(
                &ffmpeg,
                &video,
                capture.frame_count() as u64,
                &capture.boundary_frames(),
            );
            video
        })
        .collect();
    let trim = |i: usize, out: &Path| {
        let o = run_trim(&bags[i], &videos[i], out, &["--video-start", "0"]);
        assert!(o.status.success(), "{}", stderr(&o));
        o
    };
    // First one capture, then the other, into `ab`; the other way round into `ba`.
    let (ab, ba) = (dir.path().join("ab"), dir.path().join("ba"));
    let first = trim(0, &ab);
    assert!(
        stdout(&first).contains("over the 24 clips of"),
        "{}",
        stdout(&first)
    );
    assert!(
        stderr(&first).contains("1 source animation for 3 splits, split by scene instead"),
        "{}",
        stderr(&first)
    );
    let after_first = clip_splits(&ab);
    assert_eq!(after_first.len(), 12);
    trim(1, &ab);
    trim(1, &ba);
    let after_other = clip_splits(&ba);
    trim(0, &ba);
    let (all_ab, all_ba) = (clip_splits(&ab), clip_splits(&ba));
    assert_eq!(all_ab.len(), 24);
    assert_eq!(all_ab, all_ba, "the same splits whatever the order");
    for (id, c) in after_first.iter().chain(&after_other) {
        assert_eq!(&all_ab[id], c, "{id} moved when the other capture arrived");
    }
    // Each class: 4 scenes of 3 clips, 2/1/1 scenes; no scene in two splits.
    let mut counts: BTreeMap<(String, String), usize> = BTreeMap::new();
    let mut scenes: BTreeMap<(String, String, String), BTreeSet<String>> = BTreeMap::new();
    for [label, animation, variant, scene, split, split_by] in all_ab.values() {
        assert_eq!(split_by, "scene");
        *counts.entry((label.clone(), split.clone())).or_default() += 1;
        scenes
            .entry((animation.clone(), variant.clone(), scene.clone()))
            .or_default()
            .insert(split.clone());
    }
    for label in ["walk", "wave"] {
        let n = |s: &str| counts.get(&(label.to_owned(), s.to_owned())).copied();
        assert_eq!(
            [n("train"), n("val"), n("test")],
            [Some(6), Some(3), Some(3)],
            "{label}"
        );
    }
    assert!(scenes.values().all(|s| s.len() == 1), "{scenes:?}");
    let listed: usize = check_lists(&ab).values().map(Vec::len).sum();
    assert_eq!(listed, 24);
    // The plan describes each clip as trim does: same id, class and values to group or hold
    // out by (else a clip would be split apart from its planned self).
    let plan = PlannedClips::read(&bags[0].parent().unwrap().join("plan.json")).unwrap();
    let planned: BTreeMap<String, SplitItem> = plan
        .items
        .into_iter()
        .map(|i| (i.clip_id.clone(), i))
        .collect();
    let cut: BTreeMap<String, SplitItem> = read_jsonl(&ab.join("manifest.jsonl"))
        .into_iter()
        .map(|v| {
            let r: autoact::trim::ClipRecord = serde_json::from_value(v).unwrap();
            (r.clip_id.clone(), SplitItem::from(&r))
        })
        .collect();
    assert_eq!(planned, cut);
    assert!(
        !stderr(&first).contains("not in the plan"),
        "{}",
        stderr(&first)
    );
}

#[test]
fn trim_refuses_another_datasets_plan_and_says_when_there_is_none() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    let video = s.coded_capture_video(&ffmpeg);
    let plan = s.bag.parent().unwrap().join("plan.json");
    // A plan whose seed is not the capture's, given with --plan: refused, naming both files.
    let mut other: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&plan).unwrap()).unwrap();
    other["plan"]["seed"] = serde_json::json!(6);
    let other_path = s.dir.path().join("other-plan.json");
    std::fs::write(&other_path, other.to_string()).unwrap();
    let out = s.dir.path().join("ds");
    let args = ["--video-start", "0", "--plan", other_path.to_str().unwrap()];
    let o = run_trim(&s.bag, &video, &out, &args);
    assert!(!o.status.success());
    let err = stderr(&o);
    assert!(
        err.contains("other-plan.json") && err.contains("seed"),
        "{err}"
    );
    // Not a plan at all.
    std::fs::write(&other_path, "{}").unwrap();
    let o = run_trim(&s.bag, &video, &out, &args);
    assert!(!o.status.success());
    assert!(
        stderr(&o).contains("is not a dataset plan"),
        "{}",
        stderr(&o)
    );
    assert!(!out.join("manifest.jsonl").exists(), "nothing cut");
    // No plan beside the bag: the clips trimmed so far decide, and trim says so.
    std::fs::remove_file(&plan).unwrap();
    let o = run_trim(&s.bag, &video, &out, &["--video-start", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("plan.json` beside the capture bag"),
        "{}",
        stderr(&o)
    );
    assert!(stdout(&o).contains("no plan"), "{}", stdout(&o));
}

/// A render bag for `s`'s coded video, every frame annotated with a small body (pelvis, hips,
/// neck, hands): in the `walk` class the body holds still, in the wave class its hands wave; in
/// the first wave clip the character is out of sight from its 5th frame on. Returns that clip's
/// id.
fn write_qa_render_bag(s: &Setup, video: &Path) -> String {
    use autoact::bags::render::{ANNOTATIONS_TOPIC, VIDEO_TOPIC, render_bag_beside};
    use autoact::mcap_io::{BagWriter, WriteConfig};
    use autoact::ros::autoact_msgs::{FrameAnnotation, VideoInfo};
    use autoact::ros::builtin_interfaces::Time;
    use autoact::ros::geometry_msgs::Point;
    use autoact::ros::sensor_msgs::RegionOfInterest;

    let names = ["pelvis", "l_thigh", "r_thigh", "neck", "l_hand", "r_hand"];
    let first = s.capture.stamps.first().unwrap();
    let mut info = VideoInfo {
        session: s.capture.session.clone(),
        fps: s.capture.fps,
        width: 320,
        height: 240,
        ..VideoInfo::default()
    };
    info.header.stamp = Time::from_nanos(first);
    let mut w = BagWriter::create(&render_bag_beside(video), WriteConfig::default()).unwrap();
    w.write(VIDEO_TOPIC, first, &info).unwrap();
    let segments = segment_frames(&s.capture);
    let hidden = segments
        .iter()
        .zip(&s.capture.segments)
        .find(|(_, seg)| seg.action != "walk")
        .map(|((id, a, b), _)| (id.clone(), *a, *b))
        .unwrap();
    for (k, stamp) in s.capture.stamps.iter().enumerate() {
        let k = k as u64;
        let seg = segments.iter().position(|(_, a, b)| (*a..*b).contains(&k));
        let waving = seg.is_some_and(|i| s.capture.segments[i].action != "walk");
        let hand = if waving {
            0.2 * (6.0 * k as f64 / s.capture.fps).sin()
        } else {
            0.0
        };
        let out_of_sight = (hidden.1 + 5..hidden.2).contains(&k);
        let p = |x: f64, y: f64| Point { x, y, z: 3.0 };
        let annotation = FrameAnnotation {
            frame_index: k,
            segment_id: seg.map(|i| segments[i].0.clone()).unwrap_or_default(),
            keypoint_names: names.iter().map(|n| (*n).to_owned()).collect(),
            keypoints_3d: vec![
                p(0.0, 0.0),
                p(0.1, 0.0),
                p(-0.1, 0.0),
                p(0.0, -0.5),
                p(0.3, -0.2 - hand),
                p(-0.3, -0.2 + hand),
            ],
            visibility: vec![if out_of_sight { 1 } else { 2 }; names.len()],
            bbox: RegionOfInterest {
                height: 120,
                width: 40,
                ..RegionOfInterest::default()
            },
            silhouette_pixels: if out_of_sight { 0 } else { 900 },
            ..FrameAnnotation::default()
        };
        w.write(ANNOTATIONS_TOPIC, stamp, &annotation).unwrap();
    }
    w.finish().unwrap();
    autoact::trim::clip_id(&hidden.0)
}

#[test]
fn trim_flags_a_hidden_clip_and_a_class_that_does_not_move() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let s = setup("wave");
    let video = s.coded_capture_video(&ffmpeg);
    let hidden = write_qa_render_bag(&s, &video);
    let out = s.dir.path().join("ds");
    let o = run_trim(&s.bag, &video, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains(&format!(
            "clip {hidden}: most joints hidden, character out of sight"
        )),
        "{err}"
    );
    let summary = common::stdout(&o);
    assert!(summary.contains("class `walk` barely moves"), "{summary}");
    assert!(!summary.contains("class `wave` barely moves"), "{summary}");

    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("annotations/qa.json")).unwrap())
            .unwrap();
    let clips = read_jsonl(&out.join("annotations/clips.jsonl"));
    assert_eq!(report["clips_checked"], clips.len());
    assert_eq!(report["classes"]["walk"]["still"], true);
    assert_eq!(report["classes"]["wave"]["still"], false);
    let flagged: BTreeMap<String, Vec<String>> = report["flagged"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            let flags = f["qa"]["flags"].as_array().unwrap();
            (
                f["clip_id"].as_str().unwrap().to_owned(),
                flags
                    .iter()
                    .map(|v| v.as_str().unwrap().to_owned())
                    .collect(),
            )
        })
        .collect();
    assert_eq!(flagged[&hidden], ["occluded", "hidden"]);
    // Every walk clip barely moves; no other wave clip is flagged.
    for c in &clips {
        let id = c["clip_id"].as_str().unwrap();
        let motion = c["qa"]["motion_m_per_s"].as_f64().unwrap();
        if c["label"] == "walk" {
            assert_eq!(flagged[id], ["still"], "{id}");
            assert!(motion < 1e-9, "{id}: {motion}");
        } else {
            assert!(motion > 0.1, "{id}: {motion}");
            assert_eq!(flagged.contains_key(id), id == hidden, "{id}");
        }
    }
    check_contact_sheets(&out, &clips, &flagged, &hidden);
    // A second run over the same clips leaves the sheets as they are.
    let again = run_trim(&s.bag, &video, &out, &[]);
    assert!(again.status.success(), "{}", stderr(&again));
    let summary = common::stdout(&again);
    assert!(
        summary.contains("contact sheets: 2 classes in"),
        "{summary}"
    );
    assert!(summary.contains("(0 drawn now)"), "{summary}");
}

/// Each class's sheet shows its flagged clips first, framed in red, then the others, each tile
/// at the middle frame of the clip's action span: read back from the coded frames' grey strips.
fn check_contact_sheets(
    out: &Path,
    clips: &[serde_json::Value],
    flagged: &BTreeMap<String, Vec<String>>,
    hidden: &str,
) {
    let start_of: BTreeMap<&str, u64> = clips
        .iter()
        .map(|c| {
            (
                c["clip_id"].as_str().unwrap(),
                c["start_frame"].as_u64().unwrap(),
            )
        })
        .collect();
    for label in ["walk", "wave"] {
        let dir = out.join("annotations/contact_sheets");
        let index: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join(format!("{label}.json"))).unwrap(),
        )
        .unwrap();
        let (sheet_w, _, rgb) =
            autoact::video::read_png(&dir.join(format!("{label}.png"))).unwrap();
        let tiles = index["tiles"].as_array().unwrap();
        let of_class = clips.iter().filter(|c| c["label"] == label).count();
        assert_eq!(tiles.len(), of_class.min(24), "{label}");
        assert_eq!(index["clips"], of_class);
        assert_eq!(
            (index["tile_width"].as_u64(), index["tile_height"].as_u64()),
            (Some(u64::from(W)), Some(u64::from(H)))
        );
        if label == "wave" {
            assert_eq!(tiles[0]["clip_id"], hidden);
            assert_eq!(tiles[0]["flags"], serde_json::json!(["occluded", "hidden"]));
            assert_eq!(index["flagged"], 1);
        } else {
            assert_eq!(index["flagged"], of_class);
        }
        let columns = index["columns"].as_u64().unwrap().min(tiles.len() as u64) as u32;
        for (k, t) in (0_u32..).zip(tiles) {
            let id = t["clip_id"].as_str().unwrap();
            let (x0, y0) = (2 + (k % columns) * (W + 2), 2 + (k / columns) * (H + 2));
            let at = |x: u32, y: u32| {
                let i = ((y * sheet_w + x) * 3) as usize;
                [rgb[i], rgb[i + 1], rgb[i + 2]]
            };
            let grey = |strip: u32| u64::from(at(x0 + W * (2 * strip + 1) / 6, y0 + H / 2)[0]) / 16;
            let shown = grey(0) + 16 * grey(1) + 256 * grey(2);
            let frame = t["frame"].as_u64().unwrap();
            assert_eq!(shown, start_of[id] + frame, "{id}: tile {k}");
            let red = at(x0, y0 + H / 2) == [230, 30, 30];
            assert_eq!(red, flagged.contains_key(id), "{id}: tile {k}");
        }
    }
}

/// A spec of the two sample classes with `clips` as its `[clips]` table (and the wave class's own
/// `[class.clips]` keys `wave_clips`), its capture, and that capture's index-coded video.
fn policy_setup(ffmpeg: &Ffmpeg, clips: &str, wave_clips: &str) -> (Setup, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let mut spec = two_class_spec("t", 5, "dataset", [1, 1, 2], "wave", "pose");
    spec = spec.replacen(
        "[[class]]\ncategory = \"locomotion\"",
        &format!("[class.clips]\n{wave_clips}\n\n[[class]]\ncategory = \"locomotion\""),
        1,
    );
    spec.push_str(&format!("\n[clips]\n{clips}\n"));
    let bag = common::capture_bag_from_spec(dir.path(), &spec);
    let capture = Capture::read(&Rig::standard(), &bag).unwrap();
    let s = Setup { dir, bag, capture };
    let video = s.coded_capture_video(ffmpeg);
    (s, video)
}

/// Every clip of `out` decodes to the capture frames its record says, and its action span lies
/// within it and within its segment's animation (`animations`: segment id → frames).
fn check_clips_and_spans(
    ffmpeg: &Ffmpeg,
    out: &Path,
    animations: &[(String, u64, u64)],
) -> Vec<serde_json::Value> {
    let clips = read_jsonl(&out.join("annotations/clips.jsonl"));
    for c in &clips {
        let (_, a, b) = animations
            .iter()
            .find(|(id, ..)| c["segment_id"] == id.as_str())
            .unwrap();
        let start = c["start_frame"].as_u64().unwrap();
        let n = c["frame_count"].as_u64().unwrap();
        assert_eq!(
            decoded_indices(ffmpeg, &out.join(c["video"].as_str().unwrap())),
            (start..start + n).collect::<Vec<_>>(),
            "{c}"
        );
        let span = &c["action_span"];
        let (s0, s1) = (
            span["start_frame"].as_u64().unwrap(),
            span["end_frame"].as_u64().unwrap(),
        );
        assert!(s0 < s1 && s1 <= n, "{c}");
        // The same span, seen from the animation.
        assert_eq!(
            span["animation_start_frame"].as_u64().unwrap(),
            start + s0 - a
        );
        assert!(start + s1 <= *b, "{c}");
    }
    clips
}

#[test]
fn trim_cuts_windows_and_instances_by_the_spec_and_its_options_and_splits_by_segment() {
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    // The spec: windows of 20 frames every 15 (tail dropped) for walk; the wave class's own
    // keys make it windows of 16 every 16 with the shifted tail.
    let (s, video) = policy_setup(
        &ffmpeg,
        "policy = \"windows\"\nlength_frames = 20\nstride_frames = 15\ntail = \"drop\"",
        "length_frames = 16\nstride_frames = 16\ntail = \"shift\"",
    );
    let animations = animation_frames(&s.capture);
    let out = s.dir.path().join("ds");
    let o = run_trim(&s.bag, &video, &out, &["--video-start", "0"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let clips = check_clips_and_spans(&ffmpeg, &out, &animations);
    let mut expected = 0;
    for (id, a, b) in &animations {
        let n = b - a;
        let ours: Vec<&serde_json::Value> = clips
            .iter()
            .filter(|c| c["segment_id"] == id.as_str())
            .collect();
        let (len, stride, count) = if id.contains("/wave/") {
            (16, 16, n.div_ceil(16))
        } else {
            (20, 15, (n - 20) / 15 + 1)
        };
        assert_eq!(ours.len() as u64, count, "{id}: {n} frames");
        expected += ours.len();
        for (k, c) in ours.iter().enumerate() {
            assert_eq!(c["policy"], "windows");
            assert_eq!(c["part"], k);
            assert_eq!(c["frame_count"], len, "{c}");
            let start = c["start_frame"].as_u64().unwrap();
            let k = k as u64;
            if id.contains("/wave/") && k + 1 == count && n % 16 != 0 {
                assert_eq!(
                    start + len,
                    *b,
                    "the shifted tail ends on the animation's end"
                );
            } else {
                assert_eq!(start, a + k * stride);
            }
            assert!(
                c["clip_id"]
                    .as_str()
                    .unwrap()
                    .ends_with(&format!("-w{k:03}"))
            );
        }
    }
    assert_eq!(clips.len(), expected);
    // Clips of one segment share its split (`--split-by clip` groups by segment).
    let o = run_trim(
        &s.bag,
        &video,
        &out,
        &["--video-start", "0", "--split-by", "clip"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let clips = read_jsonl(&out.join("annotations/clips.jsonl"));
    let mut by_segment: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for c in &clips {
        by_segment
            .entry(c["segment_id"].as_str().unwrap().to_owned())
            .or_default()
            .insert(c["split"].as_str().unwrap().to_owned());
    }
    assert!(by_segment.values().all(|s| s.len() == 1), "{by_segment:?}");

    // `--clips instances` overrides the spec: the windows' clips leave the folder and its lists.
    let o = run_trim(
        &s.bag,
        &video,
        &out,
        &["--video-start", "0", "--clips", "instances"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("removed"), "{}", stderr(&o));
    let clips = check_clips_and_spans(&ffmpeg, &out, &animations);
    assert!(!clips.is_empty());
    for c in &clips {
        assert_eq!(c["policy"], "instances", "{c}");
        let n = c["frame_count"].as_u64().unwrap();
        assert!((10..=300 + 10).contains(&n), "{c}");
    }
    let listed: usize = check_lists(&out).values().map(Vec::len).sum();
    assert_eq!(listed, clips.len());
    assert!(
        !std::fs::read_dir(out.join("videos/walk"))
            .unwrap()
            .any(|e| e.unwrap().file_name().to_string_lossy().contains("-w0"))
    );
    let anet: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("annotations/activitynet.json")).unwrap(),
    )
    .unwrap();
    for a in anet["database"]["capture"]["annotations"]
        .as_array()
        .unwrap()
    {
        let (seg, clip) = (&a["segment"], &a["clip_segment"]);
        assert!(
            seg[0].as_f64() >= clip[0].as_f64() && seg[1].as_f64() <= clip[1].as_f64(),
            "{a}"
        );
        assert_eq!(a["action_span"]["video_start_s"], seg[0]);
    }

    // `--include-lead` with `whole`: the segments as before clip policies.
    let segments = segment_frames(&s.capture);
    let o = run_trim(
        &s.bag,
        &video,
        &out,
        &["--video-start", "0", "--clips", "whole", "--include-lead"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let clips = read_jsonl(&out.join("annotations/clips.jsonl"));
    assert_eq!(clips.len(), segments.len());
    for (id, a, b) in &segments {
        let c = clips
            .iter()
            .find(|c| c["segment_id"] == id.as_str())
            .unwrap();
        assert_eq!(
            (c["start_frame"].as_u64(), c["frame_count"].as_u64()),
            (Some(*a), Some(b - a))
        );
        let (_, ca, cb) = animations.iter().find(|(i, ..)| i == id).unwrap();
        assert_eq!(
            c["action_span"]["start_frame"].as_u64(),
            Some(ca - a),
            "{c}"
        );
        assert_eq!(c["action_span"]["end_frame"].as_u64(), Some(cb - a), "{c}");
    }
}

/// An instance clip's first and end frame, and its action span (video frames).
type InstanceClip = (u64, u64, std::ops::Range<u64>);

/// The instances a `[clips] policy = "instances"` capture of the real clip `rel` (under
/// `../shared/data`, one segment) gives: the animation's frames and each instance's clip and span.
fn real_instances(rel: &str) -> ((u64, u64), Vec<InstanceClip>) {
    use autoact::dataset::clips::{ClipMode, ClipPolicy};
    use autoact::trim::motion::video_frame_speeds;
    use autoact::trim::plan::{VideoTiming, frame_ranges};
    use autoact::trim::policy::clips_of;
    let source = common::repo(&format!("../shared/data/{rel}"));
    let dir = tempfile::tempdir().unwrap();
    let spec = format!(
        "[dataset]\nname = \"r\"\nseed = 1\nfps = 30.0\n[counts]\nvariants = 1\nscenes = 1\nviewpoints = 1\n[dsi]\nthreshold = \"off\"\n[clips]\npolicy = \"instances\"\n[[class]]\ncategory = \"c\"\naction = \"a\"\nsources = [\"{source}\"]\n"
    );
    let bag = common::capture_bag_from_spec(dir.path(), &spec);
    let capture = Capture::read(&Rig::standard(), &bag).unwrap();
    let timing = VideoTiming {
        frame0_nanos: i128::from(capture.stamps.first().unwrap()),
        fps: autoact::video::Rational::new(30, 1).unwrap(),
        frame_count: capture.frame_count() as u64,
    };
    let (segments, truncated) = frame_ranges(&capture.segments, &timing);
    assert!(truncated.is_empty());
    assert_eq!(segments.len(), 1);
    let seg = &segments[0];
    let speeds =
        video_frame_speeds(&Rig::standard(), &capture, &timing, seg.action.clone()).unwrap();
    let policy = ClipPolicy {
        policy: ClipMode::Instances,
        ..ClipPolicy::default()
    };
    let clips = clips_of(seg, &policy, Some(&speeds));
    (
        (seg.action.start, seg.action.end),
        clips
            .iter()
            .map(|c| (c.start_frame, c.end_frame(), c.action.clone()))
            .collect(),
    )
}

#[test]
#[ignore = "needs ../shared/data (Bandai-Namco punches, CC BY-NC 4.0)"]
fn real_punches_are_cut_into_one_clip_per_punch() {
    let ((a, b), clips) = real_instances("bvh/bandai_namco/dataset-1_punch_normal_001.bvh");
    // The file's five punches: the bursts of its arm joints' rotation channels (summed change
    // per frame, read from the BVH text independently) peak at source frames 24, 66, 108, 150
    // and 192 (30 fps, like the capture), with rests of ≈ 0.5 s between them.
    assert_eq!(clips.len(), 5, "{clips:?}");
    for ((start, end, span), peak) in clips.iter().zip([24, 66, 108, 150, 192]) {
        assert!(a <= *start && *start <= span.start && span.end <= *end && *end <= b);
        assert!(
            (span.start - a..span.end - a).contains(&peak),
            "{span:?} (animation from {a}) misses the punch at {peak}"
        );
        assert!(span.end - span.start <= 40, "{span:?} is one punch");
    }
}

/// A render that drew only the frames of the default clips (`whole` animations, leads left out,
/// as `generate` without `--keep-intermediates` renders): `trim` cuts those clips from it, and
/// refuses clips whose frames it does not hold (the leads, with `--include-lead`), naming the
/// video and the missing frame's stamp rather than cutting other frames.
#[test]
fn a_render_of_some_frames_gives_its_clips_and_refuses_others() {
    use autoact::render::session::{Outputs, RenderSettings, render_capture};
    use std::sync::atomic::AtomicBool;
    let Some(ffmpeg) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let bag = capture_bag(dir.path(), "wave");
    let rig = Rig::standard();
    let capture = Capture::read(&rig, &bag).unwrap();
    let timing = autoact::trim::plan::VideoTiming {
        frame0_nanos: i128::from(capture.stamps.first().unwrap()),
        fps: Rational::from_f64(capture.fps).unwrap(),
        frame_count: capture.frame_count() as u64,
    };
    let policies = autoact::trim::policy::ClipPolicies::default();
    let only = autoact::trim::run::clip_frames(&capture, &timing, &policies).unwrap();
    let drawn: u64 = only.iter().map(|r| r.end - r.start).sum();
    assert!(drawn > 0 && drawn < timing.frame_count, "{only:?}");
    let video = dir.path().join("some.mp4");
    let settings = RenderSettings {
        width: 64,
        height: 48,
        fps: None,
        limit: None,
        crf: 23,
        preset: "ultrafast".into(),
        x264_options: String::new(),
        gop_frames: None,
        encoder_threads: autoact::video::DEFAULT_ENCODER_THREADS,
        embed_video: None,
        extra_keyframes: autoact::trim::run::clip_start_frames(&capture, &timing, &policies)
            .unwrap(),
        only_frames: Some(only),
        engine: autoact::render::blender::Engine::Embedded,
        randomise: autoact::dataset::randomise::Randomise::default(),
    };
    let outputs = Outputs {
        video: Some(video.clone()),
        ..Outputs::default()
    };
    let summary = render_capture(
        &rig,
        &capture,
        &settings,
        &outputs,
        Some(&ffmpeg),
        &|_| {},
        &AtomicBool::new(false),
    )
    .unwrap();
    assert_eq!(summary.frames, drawn);
    let trim = |out: &str, extra: &[&str]| {
        let out = dir.path().join(out);
        let mut args = vec!["trim", common::arg(&bag), common::arg(&video), "-o"];
        args.push(common::arg(&out));
        args.extend(extra);
        autoact(&args)
    };
    let o = trim("clips", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let manifest = std::fs::read_to_string(dir.path().join("clips/manifest.jsonl")).unwrap();
    let frames: u64 = manifest
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["frame_count"]
                .as_u64()
                .unwrap()
        })
        .sum();
    assert_eq!(frames, drawn, "{manifest}");
    let o = trim("leads", &["--include-lead"]);
    assert!(!o.status.success(), "{}", stdout(&o));
    let e = stderr(&o);
    assert!(
        e.contains("some.mp4") && e.contains("holds only some frames") && e.contains(" ns)"),
        "{e}"
    );
}
