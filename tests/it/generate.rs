//! `autoact generate` and `autoact merge` through the binary: a sharded run merged equals one
//! run byte for byte, and a run killed at many points then re-run equals an uninterrupted one.

#![expect(clippy::unwrap_used, reason = "test helpers fail loudly")]

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use crate::common::{self, arg, autoact, stderr, stdout};

/// Four sessions (one per source animation), at 8 fps: `wave`'s segments one clip each (the
/// animation, its leads left out), `walk`'s cut into 4-frame windows 6 frames apart (the frames
/// between windows and the tail left out), so a run without `--keep-intermediates` draws fewer
/// frames than the plan holds.
fn spec_toml() -> String {
    let wave = common::repo("bags/bandai_wave.pose.mcap");
    let walk = common::repo("bags/bandai_walk.pose.mcap");
    format!(
        r#"[dataset]
name = "g"
seed = 3
fps = 8.0
resolution = [320, 240]
lead_in_s = 0.1
lead_out_s = 0.1
session = "animation"
[counts]
variants = 1
scenes = 2
viewpoints = 1
[[class]]
category = "gesture"
action = "wave"
sources = ["{wave}", "{walk}"]
[[class]]
category = "locomotion"
action = "walk"
sources = ["{walk}", "{wave}"]
clips = {{ policy = "windows", length_frames = 4, stride_frames = 6, tail = "drop" }}
"#
    )
}

/// Options every run here shares: small, fast frames; every segment a render piece of its own
/// (a killed render resumes at its interrupted segment); lossless video (`--crf 0`), so a clip's
/// decoded frames are the frames drawn, whatever frames the encoder saw around them.
const OPTIONS: [&str; 6] = ["--resolution", "64x48", "--piece-frames", "1", "--crf", "0"];

/// The frames of each batch a `--drawn-log` text says were drawn: (session, frame).
fn drawn_frames(log: &str) -> Vec<(String, u64)> {
    let mut out = Vec::new();
    for line in log.lines() {
        let [session, first, count] = line.split(' ').collect::<Vec<_>>()[..] else {
            panic!("--drawn-log line `{line}`");
        };
        let (first, count): (u64, u64) = (first.parse().unwrap(), count.parse().unwrap());
        out.extend((first..first + count).map(|k| (session.to_owned(), k)));
    }
    out
}

/// The plan's frames in all, and its largest segment's: from a segment's first frame to the
/// next one's (or its session's end).
fn plan_frames(plan: &Path) -> (u64, u64) {
    let plan: serde_json::Value = serde_json::from_slice(&std::fs::read(plan).unwrap()).unwrap();
    let plan = &plan["plan"];
    let (mut total, mut largest) = (0, 0);
    for session in plan["sessions"].as_array().unwrap() {
        let frames = session["frames"].as_u64().unwrap();
        total += frames;
        let leaves = &session["leaves"];
        let range = leaves["start"].as_u64().unwrap()..leaves["end"].as_u64().unwrap();
        let mut starts: Vec<u64> = range
            .map(|i| plan["leaves"][i as usize]["start_frame"].as_u64().unwrap())
            .collect();
        starts.push(frames);
        largest = starts
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(largest, u64::max);
    }
    (total, largest)
}

/// Issue 22's resume criterion over the frames `runs` drew (every run but the last was killed,
/// `kills` of them) into `out` (without `--keep-intermediates`, so its renders draw only the
/// clips' frames): every clip frame is drawn, and no frame is drawn twice beyond the segment a
/// kill interrupted: what a killed run drew that a later run draws again lies inside one segment
/// of one session, and all runs together drew at most `kills` segments more than the clips hold.
fn assert_no_frame_redrawn_beyond_the_interrupted_segment(
    runs: &[Vec<(String, u64)>],
    kills: usize,
    out: &Path,
    what: &str,
) {
    use std::collections::BTreeSet;
    let (_, segment) = plan_frames(&out.join("plan.json"));
    let total = clip_frames(&out.join("dataset")).len() as u64;
    let all: BTreeSet<&(String, u64)> = runs.iter().flatten().collect();
    assert_eq!(
        all.len() as u64,
        total,
        "{what}: frames drawn at least once"
    );
    for (r, run) in runs.iter().enumerate() {
        let later: BTreeSet<&(String, u64)> = runs[r + 1..].iter().flatten().collect();
        let again: BTreeSet<&(String, u64)> = run.iter().filter(|f| later.contains(f)).collect();
        let (Some(first), Some(last)) = (again.first(), again.last()) else {
            continue;
        };
        assert!(
            first.0 == last.0 && last.1 - first.1 < segment,
            "{what}: run {r} drew {} frames that later runs drew again, from {first:?} to {last:?}: more than the interrupted segment ({segment} frames)",
            again.len()
        );
    }
    let drawn: usize = runs.iter().map(Vec::len).sum();
    assert!(
        drawn as u64 <= total + kills as u64 * segment,
        "{what}: {drawn} frames drawn for {total}, {kills} kills, segments of at most {segment}"
    );
}

/// The frames drawn by the run that appended to `log` from byte `from` on.
fn drawn_since(log: &Path, from: &mut usize) -> Vec<(String, u64)> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let run = drawn_frames(&text[*from..]);
    *from = text.len();
    run
}

/// Runs `generate` on `spec` into `out` with `extra` options.
fn generate(spec: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["generate", arg(spec), "-o", arg(out)];
    args.extend(OPTIONS);
    args.extend(extra);
    autoact(&args)
}

/// Every file under `dir` (relative path → bytes), lock files aside.
fn tree(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let path = e.unwrap().path();
            if path.is_dir() {
                walk(root, &path, out);
            } else if !path.to_string_lossy().ends_with(".lock") {
                let rel = path.strip_prefix(root).unwrap().to_path_buf();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// The files of `a` and `b` are the same, byte for byte.
fn assert_same_tree(a: &Path, b: &Path) {
    let (ta, tb) = (tree(a), tree(b));
    let names = |t: &BTreeMap<PathBuf, Vec<u8>>| t.keys().cloned().collect::<Vec<_>>();
    assert_eq!(names(&ta), names(&tb), "{} vs {}", a.display(), b.display());
    for (name, bytes) in &ta {
        assert!(
            *bytes == tb[name],
            "{} differs between {} and {}",
            name.display(),
            a.display(),
            b.display()
        );
    }
}

/// One uninterrupted run with intermediates kept, made once for every test here; `None` (a loud
/// skip) without ffmpeg.
fn reference() -> Option<&'static (tempfile::TempDir, PathBuf, PathBuf)> {
    static REFERENCE: OnceLock<Option<(tempfile::TempDir, PathBuf, PathBuf)>> = OnceLock::new();
    REFERENCE
        .get_or_init(|| {
            common::ffmpeg_or_skip(module_path!())?;
            let dir = tempfile::tempdir().unwrap();
            let spec = dir.path().join("spec.toml");
            std::fs::write(&spec, spec_toml()).unwrap();
            let out = dir.path().join("single");
            let o = generate(&spec, &out, &["--keep-intermediates"]);
            assert!(o.status.success(), "{}", stderr(&o));
            Some((dir, spec, out))
        })
        .as_ref()
}

/// One uninterrupted run without `--keep-intermediates` (its renders draw only the clips'
/// frames), with the frames it drew logged: the output folder, the log and the run's wall time.
fn skipping() -> Option<&'static (tempfile::TempDir, PathBuf, PathBuf, std::time::Duration)> {
    type Skipping = (tempfile::TempDir, PathBuf, PathBuf, std::time::Duration);
    static SKIPPING: OnceLock<Option<Skipping>> = OnceLock::new();
    SKIPPING
        .get_or_init(|| {
            let (_, spec, _) = reference()?;
            let dir = tempfile::tempdir().unwrap();
            let out = dir.path().join("skipping");
            let log = dir.path().join("drawn.log");
            let start = std::time::Instant::now();
            let o = generate(spec, &out, &["--drawn-log", arg(&log)]);
            let took = start.elapsed();
            assert!(o.status.success(), "{}", stderr(&o));
            Some((dir, out, log, took))
        })
        .as_ref()
}

/// The frames of `dataset`'s clips, once each however many clips hold them: (session, frame
/// of the session's timeline).
fn clip_frames(dataset: &Path) -> std::collections::BTreeSet<(String, u64)> {
    let manifest = std::fs::read_to_string(dataset.join("manifest.jsonl")).unwrap();
    let mut frames = std::collections::BTreeSet::new();
    for line in manifest.lines() {
        let r: serde_json::Value = serde_json::from_str(line).unwrap();
        let start = r["start_frame"].as_u64().unwrap();
        let count = r["frame_count"].as_u64().unwrap();
        let session = r["session"].as_str().unwrap();
        frames.extend((start..start + count).map(|k| (session.to_owned(), k)));
    }
    frames
}

/// The MD5 of each decoded frame of `video` (ffmpeg's `framemd5`, the digests alone).
fn frame_digests(ffmpeg: &autoact::video::Ffmpeg, video: &Path) -> Vec<String> {
    let o = std::process::Command::new(ffmpeg.ffmpeg_path())
        .args(["-v", "error", "-i", arg(video), "-f", "framemd5", "-"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    stdout(&o)
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.rsplit(',').next().unwrap().trim().to_owned())
        .collect()
}

/// Issue 22 item 4: without `--keep-intermediates` a render draws only the frames some clip
/// uses, once each, and `trim` finds every clip's frames in that shorter video: the clips'
/// decoded frames, their labels, the lists and the manifest are those of a run that drew every
/// frame.
#[test]
fn a_run_that_draws_only_the_clips_frames_makes_the_same_dataset() {
    let (Some((_keep, _, single)), Some((_dir, out, log, _))) = (reference(), skipping()) else {
        return;
    };
    let ffmpeg = common::ffmpeg_or_skip(module_path!()).unwrap();
    let drawn = drawn_frames(&std::fs::read_to_string(log).unwrap());
    let wanted = clip_frames(&out.join("dataset"));
    assert_eq!(clip_frames(&single.join("dataset")), wanted);
    assert_eq!(
        drawn.len(),
        wanted.len(),
        "frames drawn, distinct clip frames"
    );
    let distinct: std::collections::BTreeSet<_> = drawn.iter().collect();
    assert_eq!(distinct.len(), drawn.len(), "a frame drawn twice");
    let (plan_total, _) = plan_frames(&out.join("plan.json"));
    assert!(
        (drawn.len() as u64) < plan_total,
        "{} frames drawn of {plan_total}: the spec leaves frames out of every clip",
        drawn.len()
    );
    let (a, b) = (tree(&single.join("dataset")), tree(&out.join("dataset")));
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    let mut videos = 0;
    for (name, bytes) in &a {
        if name.starts_with("videos") {
            let digests = |root: &Path| frame_digests(&ffmpeg, &root.join("dataset").join(name));
            let (full, sparse) = (digests(single), digests(out));
            assert!(!full.is_empty(), "{}", name.display());
            assert_eq!(full, sparse, "{}: decoded frames", name.display());
            videos += 1;
        } else {
            assert!(*bytes == b[name], "{} differs", name.display());
        }
    }
    assert!(videos > 8, "{videos} clips");
}

#[test]
fn three_shards_merged_equal_one_run_byte_for_byte() {
    let Some((_keep, spec, single)) = reference() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let parts: Vec<PathBuf> = (0..3)
        .map(|k| dir.path().join(format!("part{k}")))
        .collect();
    // Shards in reverse order: they do not talk, so order cannot matter.
    for (k, part) in parts.iter().enumerate().rev() {
        let shard = format!("{k}/3");
        let o = generate(spec, part, &["--shard", &shard, "--keep-intermediates"]);
        assert!(o.status.success(), "shard {shard}: {}", stderr(&o));
    }
    // Each part holds a share of the sessions, none of them all.
    let clips: Vec<usize> = parts
        .iter()
        .map(|p| {
            std::fs::read_to_string(p.join("dataset/manifest.jsonl"))
                .map_or(0, |m| m.lines().count())
        })
        .collect();
    let all = std::fs::read_to_string(single.join("dataset/manifest.jsonl"))
        .unwrap()
        .lines()
        .count();
    assert!(all > 8, "{all} clips in the single run");
    assert_eq!(clips.iter().sum::<usize>(), all, "{clips:?}");
    assert!(clips.iter().all(|&c| c < all), "{clips:?}");
    let merged = dir.path().join("merged");
    let mut args = vec!["merge"];
    args.extend(parts.iter().rev().map(|p| arg(p)));
    args.extend(["-o", arg(&merged)]);
    let o = autoact(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains(&format!("{all} clips")),
        "{}",
        stdout(&o)
    );
    // Every file: lists, splits, label ids, manifests, annotations, clips, and the intermediates.
    assert_same_tree(single, &merged);
    assert!(
        single
            .join("dataset/annotations/train_list_videos.txt")
            .is_file()
    );
    // Merging twice into the same folder is refused; a missing shard is named.
    let o = autoact(&args);
    assert!(
        !o.status.success() && stderr(&o).contains("exists"),
        "{}",
        stderr(&o)
    );
    let o = autoact(&[
        "merge",
        arg(&parts[0]),
        arg(&parts[2]),
        "-o",
        arg(&dir.path().join("m2")),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("1/3"),
        "{}",
        stderr(&o)
    );
    // Parts made with and without --keep-intermediates are not merged: the setting is named.
    let other = dir.path().join("other1");
    let o = generate(spec, &other, &["--shard", "1/3"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = autoact(&[
        "merge",
        arg(&parts[0]),
        arg(&other),
        arg(&parts[2]),
        "-o",
        arg(&dir.path().join("m3")),
    ]);
    assert!(
        !o.status.success() && stderr(&o).contains("keep_intermediates"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_run_killed_at_many_points_then_rerun_equals_an_uninterrupted_one() {
    let (Some((_keep, spec, _)), Some((_dir, skipped, _, _))) = (reference(), skipping()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("resumed");
    // Events are frames rendered, clips cut and units recorded (about 450 in this dataset);
    // each run resumes the one before and is killed (exit 86, no clean-up) at its N-th event:
    // after the first capture, inside renders, inside trims, between units.
    let log = dir.path().join("drawn.log");
    let (mut from, mut runs) = (0, Vec::new());
    let mut killed = 0;
    for n in [1, 2, 3, 30, 7, 150, 80, 9, 250, 2, 350] {
        let o = generate(
            spec,
            &out,
            &["--abort-after", &n.to_string(), "--drawn-log", arg(&log)],
        );
        runs.push(drawn_since(&log, &mut from));
        match o.status.code() {
            Some(86) => killed += 1,
            Some(0) => break,
            other => panic!("--abort-after {n}: exit {other:?}: {}", stderr(&o)),
        }
    }
    assert!(killed >= 6, "only {killed} runs were killed");
    let o = generate(spec, &out, &["--drawn-log", arg(&log)]);
    assert!(o.status.success(), "{}", stderr(&o));
    runs.push(drawn_since(&log, &mut from));
    assert_no_frame_redrawn_beyond_the_interrupted_segment(&runs, killed, &out, "--abort-after");
    assert_same_tree(&skipped.join("dataset"), &out.join("dataset"));
    // The same as the uninterrupted run with the same settings (keep_intermediates included).
    for file in ["plan.json", "generate.json"] {
        let (a, b) = (skipped.join(file), out.join(file));
        assert_eq!(
            std::fs::read(a).unwrap(),
            std::fs::read(b).unwrap(),
            "{file}"
        );
    }
    // Without --keep-intermediates nothing of the captures and renders is left, not even their
    // empty folders.
    for sub in ["captures", "renders", "previews"] {
        assert!(!out.join(sub).exists(), "{sub} is left");
    }
    // A finished folder: a re-run renders nothing and cuts nothing.
    let o = generate(spec, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("4 sessions (4 finished before)")
            && stdout(&o).contains("0 frames rendered"),
        "{}",
        stdout(&o)
    );
    // Other settings in the same folder are refused, naming what differs.
    let o = autoact(&[
        "generate",
        arg(spec),
        "-o",
        arg(&out),
        "--resolution",
        "96x72",
    ]);
    assert!(!o.status.success(), "{}", stdout(&o));
    assert!(stderr(&o).contains("resolution"), "{}", stderr(&o));
    // So is the other `--keep-intermediates` (its renders draw other frames), by its name.
    let o = generate(spec, &out, &["--keep-intermediates"]);
    assert!(!o.status.success(), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("keep_intermediates was false, now true"),
        "{}",
        stderr(&o)
    );
    // And another x264 thread count: the videos' bytes depend on it.
    let o = generate(spec, &out, &["--encoder-threads", "2"]);
    assert!(!o.status.success(), "{}", stdout(&o));
    assert!(
        stderr(&o).contains("encoder_threads was 1, now 2"),
        "{}",
        stderr(&o)
    );
}

/// The dataset-wide files (lists, splits, QA report, label files, contact sheets) are written
/// once, after a run's last session, not after each (they cover every clip, so rewriting them
/// per session made a run's time grow with the square of its sessions): a run killed once a
/// session's clips are final has written none of them, and the run that finishes writes them
/// as an uninterrupted run does.
#[test]
fn the_dataset_wide_files_are_written_once_after_the_last_session() {
    let (Some((_keep, spec, _)), Some((_dir, skipped, _, _))) = (reference(), skipping()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("partial");
    let sessions_done = || {
        let journal = std::fs::read_to_string(out.join("generate.json")).unwrap_or_default();
        journal.matches("\"clips\"").count()
    };
    // Runs killed at their 100th event, each resuming the one before, until one dies with a
    // session's clips final.
    for _ in 0..20 {
        let o = generate(spec, &out, &["--abort-after", "100"]);
        assert_eq!(o.status.code(), Some(86), "{}", stderr(&o));
        if sessions_done() > 0 {
            break;
        }
    }
    assert!(sessions_done() > 0, "no run got a session's clips done");
    let dataset = out.join("dataset");
    let manifest = std::fs::read_to_string(dataset.join("manifest.jsonl")).unwrap();
    assert!(!manifest.is_empty());
    for file in [
        "train_list_videos.txt",
        "clips.jsonl",
        "qa.json",
        "skeleton_3d_ntu25.pkl",
        "contact_sheets",
    ] {
        let path = dataset.join("annotations").join(file);
        assert!(
            !path.exists(),
            "{} written before the run's end",
            path.display()
        );
    }
    let o = generate(spec, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_same_tree(&skipped.join("dataset"), &dataset);
}

/// A real `kill -9` (SIGKILL: no handler, no clean-up, its ffmpeg orphaned) at seeded random
/// moments, five seeds: each seed kills successive runs in one folder (at most six times), each
/// either after 2–90 % of an uninterrupted run's wall time or once it has drawn from one frame to
/// all but one of that run's (so kills land inside the run however fast the machine is, and
/// inside renders past a session's first segment too, however slow the start-up), then lets a
/// run finish; every folder ends byte-identical to an uninterrupted run, with no intermediate
/// left, and no frame was drawn twice beyond the segment each kill interrupted.
#[test]
fn runs_killed_with_sigkill_at_random_moments_then_rerun_equal_an_uninterrupted_one() {
    use std::process::{Command, Stdio};
    use std::time::{Duration, Instant};
    let (Some((_keep, spec, _)), Some((_dir, skipped, skipped_log, took))) =
        (reference(), skipping())
    else {
        return;
    };
    let drawn = drawn_frames(&std::fs::read_to_string(skipped_log).unwrap()).len() as u64;
    let dir = tempfile::tempdir().unwrap();
    let mut kills = 0;
    for seed in 1..=5_u64 {
        let out = dir.path().join(format!("seed{seed}"));
        // splitmix64: the kill moments are the same fractions of the run on every run of the
        // test.
        let mut state = seed;
        let mut next = || {
            state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        };
        let log = dir.path().join(format!("seed{seed}.log"));
        let (mut from, mut runs, mut seed_kills) = (0, Vec::new(), 0);
        for _ in 0..6 {
            #[expect(clippy::cast_precision_loss, reason = "below 1,000")]
            let delay = took.mul_f64(0.02 + 0.88 * (next() % 1000) as f64 / 1000.0);
            let frames = (next() % 2 == 0).then(|| 1 + next() % drawn.saturating_sub(1).max(1));
            let mut args = vec!["-q", "generate", arg(spec), "-o", arg(&out)];
            args.extend(OPTIONS);
            args.extend(["--drawn-log", arg(&log)]);
            // Its stderr to a file, for the message if it fails.
            let errors = dir.path().join(format!("seed{seed}.stderr"));
            let mut child = Command::new(env!("CARGO_BIN_EXE_autoact"))
                .args(&args)
                .stdout(Stdio::null())
                .stderr(std::fs::File::create(&errors).unwrap())
                .spawn()
                .unwrap();
            let start = Instant::now();
            let finished = loop {
                if let Some(status) = child.try_wait().unwrap() {
                    break Some(status);
                }
                let due = match frames {
                    Some(n) => {
                        let text = std::fs::read_to_string(&log).unwrap_or_default();
                        drawn_frames(&text[from..]).len() as u64 >= n
                    }
                    None => start.elapsed() >= delay,
                };
                if due {
                    break None;
                }
                std::thread::sleep(Duration::from_millis(5));
            };
            if let Some(status) = finished {
                assert!(
                    status.success(),
                    "seed {seed}: a run failed: {status}: {}",
                    std::fs::read_to_string(&errors).unwrap_or_default()
                );
                runs.push(drawn_since(&log, &mut from));
                break;
            }
            child.kill().unwrap(); // SIGKILL on Unix
            child.wait().unwrap();
            runs.push(drawn_since(&log, &mut from));
            kills += 1;
            seed_kills += 1;
        }
        let o = generate(spec, &out, &["--drawn-log", arg(&log)]);
        assert!(o.status.success(), "seed {seed}: {}", stderr(&o));
        runs.push(drawn_since(&log, &mut from));
        assert_no_frame_redrawn_beyond_the_interrupted_segment(
            &runs,
            seed_kills,
            &out,
            &format!("seed {seed}"),
        );
        assert_same_tree(&skipped.join("dataset"), &out.join("dataset"));
        for file in ["plan.json", "generate.json"] {
            assert_eq!(
                std::fs::read(skipped.join(file)).unwrap(),
                std::fs::read(out.join(file)).unwrap(),
                "seed {seed}: {file}"
            );
        }
        for sub in ["captures", "renders", "previews"] {
            assert!(!out.join(sub).exists(), "seed {seed}: {sub} is left");
        }
    }
    assert!(kills >= 5, "only {kills} runs were killed before finishing");
}

/// Standalone `autoact trim` of a `generate` output's captures and renders finds the plan
/// where `generate` keeps it (`DIR/plan.json`, one folder above `DIR/captures/`), so its splits
/// are `generate`'s: every split list the same, and no warning that the splits are drawn over
/// the clips so far.
#[test]
fn standalone_trim_of_a_generate_output_splits_as_generate_did() {
    let Some((dir, _, single)) = reference() else {
        return;
    };
    let out = dir.path().join("trimmed-standalone");
    let mut captures: Vec<PathBuf> = std::fs::read_dir(single.join("captures"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    captures.sort();
    assert_eq!(captures.len(), 4, "{captures:?}");
    for bag in &captures {
        let name = bag.file_name().unwrap().to_string_lossy();
        let session = name.strip_suffix(".capture.mcap").unwrap();
        let video = single.join("renders").join(format!("{session}.mp4"));
        let o = autoact(&["trim", arg(bag), arg(&video), "-o", arg(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            !stderr(&o).contains("so far"),
            "{name}: the plan was not found: {}",
            stderr(&o)
        );
    }
    for split in ["train", "val", "test"] {
        let list = format!("annotations/{split}_list_videos.txt");
        let want = std::fs::read_to_string(single.join("dataset").join(&list)).unwrap();
        assert!(!want.is_empty(), "{list}");
        assert_eq!(
            std::fs::read_to_string(out.join(&list)).unwrap(),
            want,
            "{list}"
        );
    }
}

/// A temporary folder holding [`spec_toml`] as `spec.toml`, and the output folder to give
/// `generate` (`out`, not made); `None` (the test skips) without ffmpeg.
fn fresh_run() -> Option<(tempfile::TempDir, PathBuf, PathBuf)> {
    common::ffmpeg_or_skip(module_path!())?;
    let dir = tempfile::tempdir().unwrap();
    let spec = dir.path().join("spec.toml");
    std::fs::write(&spec, spec_toml()).unwrap();
    let out = dir.path().join("out");
    Some((dir, spec, out))
}

/// The progress line, written to a log (stderr not a terminal), gives the clip total from its
/// first line: the clips the plan's policies cut (here `walk`'s 4-frame windows, several per
/// segment), not the plan's segments; and `autoact plan` gave the same total beforehand.
#[test]
fn the_progress_line_gives_the_clips_to_be_cut_from_its_first_line() {
    let Some((_dir, spec, out)) = fresh_run() else {
        return;
    };
    let o = generate(&spec, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let log = stderr(&o);
    let lines: Vec<&str> = log.lines().filter(|l| l.starts_with("generate ")).collect();
    // The first line comes at once, the last at the end: two at least, whatever the speed.
    assert!(lines.len() >= 2, "progress lines:\n{log}");
    let first = lines[0];
    let total: usize = first
        .split("clips ")
        .nth(1)
        .and_then(|rest| rest.split(',').next())
        .and_then(|done_total| done_total.split('/').nth(1))
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no clip total in {first:?}"));
    let manifest = std::fs::read_to_string(out.join("dataset/manifest.jsonl")).unwrap();
    let segments = std::fs::read_to_string(out.join("plan.json"))
        .map(|plan| plan.matches("\"start_frame\"").count())
        .unwrap_or_default();
    assert_eq!(total, manifest.lines().count(), "first line: {first}");
    assert!(total > segments, "{total} clips, {segments} segments");
    // `autoact plan` promises the same clips before anything is made.
    let plan = stdout(&autoact(&["plan", arg(&spec)]));
    assert!(
        plan.contains(&format!("expected size: {total} clips,")),
        "{total} clips cut; the plan said:\n{plan}"
    );
}

/// x264 options (or a preset) x264 does not take stop `generate` before it writes its journal
/// or a capture, so the folder is not bound to settings that cannot work: the run with the
/// typo corrected goes on in the same folder.
#[test]
fn x264_options_x264_refuses_leave_the_folder_free_for_corrected_ones() {
    let Some((_dir, spec, out)) = fresh_run() else {
        return;
    };
    for bad in [
        ["--x264-options", "cabca=1"],
        ["--x264-options", "cabac=1 :deblock=0,0"],
        ["--preset", "ludicrous"],
    ] {
        let o = generate(&spec, &out, &bad);
        assert!(!o.status.success(), "{bad:?} was taken");
        let named = bad[1].split(' ').next().unwrap().trim_end_matches("=1");
        assert!(stderr(&o).contains(named), "{bad:?}: {}", stderr(&o));
        let left: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|name| name != ".autoact-generate.lock")
            .collect();
        assert!(left.is_empty(), "{bad:?} left {left:?}");
    }
    let o = generate(&spec, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.join("dataset/manifest.jsonl").is_file());
}
