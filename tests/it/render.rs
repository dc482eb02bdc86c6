//! `autoact render` on a small capture bag made here from the checked-in sample: frame count,
//! stamps and keyframes checked with ffprobe, the render bag, determinism, joints on the
//! silhouette, and every kind of bad input (no camera, no ffmpeg, ffmpeg dying, Ctrl-C, a full
//! disk). Without ffmpeg the video tests print `SKIPPED` and pass; CI installs ffmpeg.

#![expect(clippy::unwrap_used, reason = "test helpers fail loudly")]

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{self, arg, autoact, stderr, stdout};

use autoact::bags::capture::Capture;
use autoact::mcap_io::{BagReader, BagWriter, WriteConfig};
use autoact::render::annotate::{OCCLUDED, SURFACE_LANDMARKS, VISIBLE, annotate};
use autoact::render::cpu::CpuRenderer;
use autoact::render::world::Surface;
use autoact::render::{Camera, FrameInput, Image, Renderer, Stage};
use autoact::ros::autoact_msgs::{FrameAnnotation, VideoInfo};
use autoact::ros::cdr;
use autoact::ros::foxglove_msgs::CompressedVideo;
use autoact::ros::sensor_msgs::CompressedImage;
use autoact::skeleton::fk;
use autoact::skeleton::rig::Rig;
use autoact::video::probe;

/// A one-session capture bag: the wave in 2 scenes × 2 viewpoints (4 clips), in `dir`.
fn capture(dir: &Path) -> PathBuf {
    common::capture_bag_from_spec(
        dir,
        &format!(
            r#"[dataset]
name = "r"
seed = 5
fps = 30.0
resolution = [320, 240]
lead_in_s = 0.2
lead_out_s = 0.2
session = "dataset"
[counts]
variants = 1
scenes = 2
viewpoints = 2
[scene]
weather_weights = {{ RAIN = 1, CLEAR = 1 }}
[[class]]
category = "gesture"
action = "wave"
sources = ["{}"]
"#,
            common::repo("bags/bandai_wave.pose.mcap")
        ),
    )
}

/// Nothing of a render to `v.mp4` in `dir`: no video, render bag or `.v.mp4.part`.
fn assert_no_render_left(dir: &Path) {
    let left: Vec<String> = files_in(dir)
        .into_iter()
        .filter(|f| f.starts_with("v.") || f.starts_with(".v."))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn video_has_every_timeline_frame_at_its_stamp_with_keyframes_on_every_boundary() {
    let Some(ff) = common::ffmpeg_or_skip("video_has_every_timeline_frame") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let bag = capture(dir.path());
    let video = dir.path().join("cap.mp4");
    let o = autoact(&[
        "render",
        arg(&bag),
        "-o",
        arg(&video),
        "--resolution",
        "160x120",
        "--embed-video=both",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("rendered"), "{}", stdout(&o));

    let rig = Rig::standard();
    let cap = Capture::read(&rig, &bag).unwrap();
    let p = probe(&ff, &video).unwrap();
    assert_eq!(p.frames.len(), cap.frame_count());
    assert_eq!((p.width, p.height), (160, 120));
    assert!(!p.has_b_frames);
    let first = cap.stamps.first().unwrap();
    for (k, (f, c)) in p.frames.iter().zip(cap.stamps.iter()).enumerate() {
        // Video time k/30 s is the timeline's k-th stamp.
        assert!(
            (f.pts_s - k as f64 / 30.0).abs() < 1e-6,
            "frame {k}: {}",
            f.pts_s
        );
        assert!(((c - first) as f64 * 1e-9 - f.pts_s).abs() < 1e-6);
    }
    let keys = p.keyframe_indices();
    let boundaries = cap.boundary_frames();
    assert!(boundaries.len() >= 4, "{boundaries:?}");
    for b in &boundaries {
        assert!(keys.contains(b), "boundary {b} is not a keyframe: {keys:?}");
    }

    // The render bag: one VideoInfo, one annotation and one H.264 unit per frame, for Foxglove
    // (CompressedVideo) and for Rerun (the same unit as a CompressedImage of format h264).
    let render_bag = dir.path().join("cap.render.mcap");
    let r = BagReader::open(&render_bag).unwrap();
    let (mut info, mut notes, mut units) = (Vec::new(), Vec::new(), Vec::new());
    let mut images = Vec::new();
    for m in r.messages() {
        let m = m.unwrap();
        match m.channel.topic.as_str() {
            "/render/video" => info.push(cdr::decode::<VideoInfo>(&m.data).unwrap()),
            "/render/annotations" => notes.push(cdr::decode::<FrameAnnotation>(&m.data).unwrap()),
            "/render/camera/h264" => units.push(cdr::decode::<CompressedVideo>(&m.data).unwrap()),
            "/render/camera/image/h264" => {
                images.push(cdr::decode::<CompressedImage>(&m.data).unwrap());
            }
            other => panic!("unexpected topic {other}"),
        }
    }
    assert_eq!(info.len(), 1);
    assert_eq!(info[0].frame_count, cap.frame_count() as u64);
    assert_eq!(info[0].video_file, "cap.mp4");
    assert_eq!(info[0].forced_keyframes, boundaries);
    assert_eq!(notes.len(), cap.frame_count());
    assert_eq!(units.len(), cap.frame_count());
    assert_eq!(images.len(), cap.frame_count());
    for (u, i) in units.iter().zip(&images) {
        assert_eq!((&i.data, i.format.as_str()), (&u.data, "h264"));
        assert_eq!(
            (i.header.stamp, &i.header.frame_id),
            (u.timestamp, &u.frame_id)
        );
    }
    // Annex B; every keyframe carries its parameter sets (SPS, NAL type 7), as decoders need.
    assert!(
        images
            .iter()
            .all(|i| i.data.starts_with(&[0, 0, 0, 1]) || i.data.starts_with(&[0, 0, 1]))
    );
    assert!(
        images[0]
            .data
            .windows(5)
            .any(|w| w[..4] == [0, 0, 0, 1] && w[4] & 0x1f == 7
                || w[..3] == [0, 0, 1] && w[3] & 0x1f == 7)
    );
    for (k, (n, f)) in notes.iter().zip(cap.stamps.iter()).enumerate() {
        assert_eq!(n.frame_index, k as u64);
        assert_eq!(n.header.stamp.to_nanos(), Some(f));
        assert_eq!(n.keypoint_names.len(), rig.bones.len());
        assert_eq!(n.keypoints_2d.len(), 2 * rig.bones.len());
    }
    // Inside the clips the character is in view.
    let in_clip: Vec<&FrameAnnotation> =
        notes.iter().filter(|n| !n.segment_id.is_empty()).collect();
    assert!(in_clip.len() > cap.frame_count() / 2);
    assert!(
        in_clip
            .iter()
            .all(|n| n.bbox.width > 0 && n.silhouette_pixels > 0)
    );

    // Outputs exist only complete: no temporary files left.
    assert!(
        files_in(dir.path()).iter().all(|f| {
            !Path::new(f)
                .extension()
                .is_some_and(|e| e.eq_ignore_ascii_case("part"))
        }),
        "{:?}",
        files_in(dir.path())
    );
}

#[test]
fn two_renders_of_one_bag_are_identical_frame_for_frame() {
    let dir = tempfile::tempdir().unwrap();
    let bag = capture(dir.path());
    let render = |name: &str| {
        let out = dir.path().join(name);
        let o = autoact(&[
            "render",
            arg(&bag),
            "--frames-out",
            arg(&out),
            "--resolution",
            "160x120",
            "--limit",
            "40",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        out
    };
    let (a, b) = (render("a"), render("b"));
    let names = files_in(&a);
    assert_eq!(names.len(), 40);
    assert_eq!(names, files_in(&b));
    for n in &names {
        assert_eq!(
            std::fs::read(a.join(n)).unwrap(),
            std::fs::read(b.join(n)).unwrap(),
            "{n}"
        );
    }
}

#[test]
fn a_capture_recorded_live_reads_the_same_frames_stretch_by_stretch() {
    // The capture as a live recorder would log it: every message at its arrival on the wall
    // clock (an hour later, 3-40 ms late, out of order within a few frames), the stamps as
    // they were. Its frames, read in stretches from anywhere in the session, are the ones the
    // original gives.
    let dir = tempfile::tempdir().unwrap();
    let original = capture(dir.path());
    let live = dir.path().join("live.mcap");
    let reader = BagReader::open(&original).unwrap();
    let mut w = BagWriter::create(&live, WriteConfig::default()).unwrap();
    for (name, metadata) in reader.metadata() {
        w.write_metadata(&name, metadata).unwrap();
    }
    for (k, m) in reader.messages().enumerate() {
        let m = m.unwrap();
        let schema = m.channel.schema.clone().unwrap();
        let late_nanos = 3_000_000 + (k as u64 * 7_919 % 37) * 1_000_000;
        w.write_raw(
            &m.channel.topic,
            &schema.name,
            || String::from_utf8(schema.data.clone()).unwrap(),
            m.log_time + 3_600_000_000_000 + late_nanos,
            m.publish_time,
            &m.data,
        )
        .unwrap();
    }
    w.finish().unwrap();
    let rig = Rig::standard();
    let (a, b) = (
        Capture::read(&rig, &original).unwrap(),
        Capture::read(&rig, &live).unwrap(),
    );
    let n = a.frame_count();
    assert_eq!(b.frame_count(), n);
    for range in [0..1, 0..n, 5..77, n / 2..n / 2 + 90, n - 3..n] {
        assert_eq!(
            b.frames(&rig, range.clone()).unwrap(),
            a.frames(&rig, range.clone()).unwrap(),
            "{range:?}"
        );
    }
}

/// One frame of a capture rendered by [`render_every`].
struct RenderedFrame<'a> {
    frame: &'a autoact::bags::capture::CaptureFrame,
    character: &'a autoact::skeleton::character::Character,
    posed: &'a fk::WorldPose,
    camera: &'a Camera,
    image: &'a Image,
}

/// Renders every `step`-th frame of `cap` with the embedded renderer, its scene's stage and
/// character, and hands each to `each`.
fn render_every(rig: &Rig, cap: &Capture, step: usize, mut each: impl FnMut(RenderedFrame<'_>)) {
    let stages: Vec<Stage> = cap
        .scenes
        .iter()
        .enumerate()
        .map(|(i, s)| Stage::new(rig, &s.scene, s.stream, i as u64))
        .collect();
    let mut renderer = CpuRenderer::new();
    let mut image = Image::default();
    let frames = cap.frames(rig, 0..cap.frame_count()).unwrap();
    for f in frames.iter().step_by(step) {
        let character = cap.scenes[f.scene].scene.look.character(rig);
        let posed = fk::forward(rig, &character, &f.pose, 1.0);
        let camera = Camera {
            world_from_optical: f.world_from_optical,
            intrinsics: cap.intrinsics,
        };
        let input = FrameInput {
            camera,
            pose: &posed,
            time_s: 0.0,
        };
        renderer.render(&stages[f.scene], &input, &mut image);
        each(RenderedFrame {
            frame: f,
            character: &character,
            posed: &posed,
            camera: &camera,
            image: &image,
        });
    }
}

#[test]
fn projected_joints_lie_on_the_rendered_silhouette() {
    let dir = tempfile::tempdir().unwrap();
    let bag = capture(dir.path());
    let rig = Rig::standard();
    let cap = Capture::read(&rig, &bag).unwrap();
    let (mut visible, mut on_silhouette) = (0usize, 0usize);
    render_every(&rig, &cap, 7, |frame| {
        let RenderedFrame {
            posed,
            camera,
            image,
            ..
        } = frame;
        let a = annotate(posed, &[], &[], camera, image);
        let w = image.width as usize;
        for (p, &v) in a.keypoints_2d.iter().zip(&a.visibility) {
            if v != VISIBLE {
                continue;
            }
            visible += 1;
            // The pixel under the joint, or one of its 8 neighbours, shows the character.
            let (x, y) = (p[0] as i64, p[1] as i64);
            let hit = (-1..=1).any(|dy| {
                (-1..=1).any(|dx| {
                    let (xx, yy) = (x + dx, y + dy);
                    xx >= 0
                        && yy >= 0
                        && (xx as usize) < w
                        && (yy as u32) < image.height
                        && image.surface[yy as usize * w + xx as usize] == Surface::Character as u8
                })
            });
            on_silhouette += usize::from(hit);
        }
    });
    assert!(visible > 1000, "{visible} visible joints");
    let share = on_silhouette as f64 / visible as f64;
    assert!(
        share >= 0.95,
        "{on_silhouette}/{visible} = {share:.3} on the silhouette"
    );
}

/// Whether pixel `p` or one of its 8 neighbours shows the character.
fn on_character(image: &Image, p: [f64; 2]) -> bool {
    let w = image.width as usize;
    let (x, y) = (p[0] as i64, p[1] as i64);
    (-1..=1).any(|dy| {
        (-1..=1).any(|dx| {
            let (xx, yy) = (x + dx, y + dy);
            xx >= 0
                && yy >= 0
                && (xx as usize) < w
                && (yy as u32) < image.height
                && image.surface[yy as usize * w + xx as usize] == Surface::Character as u8
        })
    })
}

#[test]
fn face_landmarks_sit_on_the_rendered_head_and_hide_behind_it() {
    let dir = tempfile::tempdir().unwrap();
    let bag = capture(dir.path());
    let rig = Rig::standard();
    let cap = Capture::read(&rig, &bag).unwrap();
    let face: Vec<usize> = SURFACE_LANDMARKS
        .iter()
        .map(|n| rig.landmark_index(n).unwrap())
        .collect();
    let surface: Vec<bool> = (0..rig.landmarks.len())
        .map(|l| face.contains(&l))
        .collect();
    let (neck, crown) = (
        rig.landmark_index("neck").unwrap(),
        rig.landmark_index("head_top").unwrap(),
    );
    let centre = rig.landmark_index("head_center").unwrap();
    let (mut visible, mut on_head, mut hidden_by_body) = (0usize, 0usize, 0usize);
    render_every(&rig, &cap, 5, |frame| {
        let RenderedFrame {
            frame: f,
            character,
            posed,
            camera,
            image,
        } = frame;
        let landmarks: Vec<_> = (0..rig.landmarks.len())
            .map(|l| fk::landmark_position(&rig, character, posed, l))
            .collect();
        let a = annotate(posed, &landmarks, &surface, camera, image);
        assert_eq!(a.landmarks_2d.len(), rig.landmarks.len());
        // The head's size in pixels: neck to crown (21 cm on the default adult).
        let px = |l: usize| {
            let q = f.world_from_optical.inverse_transform_point(&landmarks[l]);
            cap.intrinsics.project(q.coords)
        };
        let (Some(n), Some(t), Some(h0)) = (px(neck), px(crown), px(centre)) else {
            return;
        };
        let head_px = ((t[0] - n[0]).powi(2) + (t[1] - n[1]).powi(2)).sqrt();
        for &l in &face {
            match a.landmark_visibility[l] {
                VISIBLE => {
                    visible += 1;
                    let p = a.landmarks_2d[l];
                    let near_head = ((p[0] - h0[0]).powi(2) + (p[1] - h0[1]).powi(2)).sqrt()
                        <= 0.75 * head_px + 1.5;
                    on_head += usize::from(on_character(image, p) && near_head);
                }
                OCCLUDED => {
                    let p = a.landmarks_2d[l];
                    hidden_by_body += usize::from(on_character(image, p));
                }
                _ => {}
            }
        }
    });
    assert!(visible > 100, "{visible} visible face points");
    let share = on_head as f64 / visible as f64;
    assert!(
        share >= 0.95,
        "{on_head}/{visible} = {share:.3} visible face points on the rendered head"
    );
    // Seen from the side or behind, some face points are hidden by the head itself.
    assert!(hidden_by_body > 0, "no face point hidden by the body");
}

#[test]
fn a_bag_without_camera_or_scene_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.mp4");
    let o = autoact(&[
        "render",
        &common::repo("bags/bandai_wave.anim.mcap"),
        "-o",
        arg(&out),
    ]);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert!(e.contains("bandai_wave.anim.mcap"), "{e}");
    assert!(e.contains("camera path (/camera/pose)"), "{e}");
    assert!(e.contains("convert --spec"), "{e}");
    assert!(files_in(dir.path()).is_empty());
    let o = autoact(&["render", &common::repo("bags/bandai_wave.anim.mcap")]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("nothing to write"), "{}", stderr(&o));
}

#[test]
fn missing_or_failing_ffmpeg_leaves_no_video_and_says_why() {
    let dir = tempfile::tempdir().unwrap();
    let bag = capture(dir.path());
    let out = dir.path().join("v.mp4");
    let run = |ffmpeg: &str| {
        Command::new(env!("CARGO_BIN_EXE_autoact"))
            .args([
                "render",
                arg(&bag),
                "-o",
                arg(&out),
                "--resolution",
                "160x120",
            ])
            .env("AUTOACT_FFMPEG", ffmpeg)
            .output()
            .unwrap()
    };
    let o = run("/nonexistent/ffmpeg");
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("apt-get install ffmpeg"),
        "{}",
        stderr(&o)
    );

    // An "ffmpeg" that takes a few frames, complains and dies.
    let fake = dir.path().join("fake-ffmpeg");
    std::fs::write(
        &fake,
        "#!/bin/sh\nhead -c 200000 >/dev/null\necho 'encoder exploded: out of dilithium' >&2\nexit 1\n",
    )
    .unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let o = run(arg(&fake));
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("out of dilithium"), "{}", stderr(&o));
    assert_no_render_left(dir.path());
}

#[test]
fn ctrl_c_leaves_no_file_that_looks_complete() {
    if common::ffmpeg_or_skip("ctrl_c_leaves_no_file_that_looks_complete").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let bag = capture(dir.path());
    let out = dir.path().join("v.mp4");
    let child = Command::new(env!("CARGO_BIN_EXE_autoact"))
        .args([
            "render",
            arg(&bag),
            "-o",
            arg(&out),
            "--resolution",
            "640x480",
            "--threads",
            "1",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until the encoder has started writing, then interrupt.
    let part = dir.path().join(".v.mp4.part");
    let started = std::time::Instant::now();
    while !part.exists() && started.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert!(part.exists(), "the render never started writing");
    std::thread::sleep(std::time::Duration::from_millis(300));
    let pid = child.id().to_string();
    let _ = Command::new("kill").args(["-INT", &pid]).status();
    let o = child.wait_with_output().unwrap();
    assert_ne!(
        o.status.code(),
        Some(0),
        "an interrupted render must not report success"
    );
    assert!(stderr(&o).contains("interrupted"), "{}", stderr(&o));
    assert_no_render_left(dir.path());
}

#[test]
#[expect(clippy::print_stderr, reason = "a loud skip")]
fn a_full_disk_is_an_error_and_leaves_no_complete_looking_file() {
    if common::ffmpeg_or_skip("a_full_disk_is_an_error").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let bag = capture(dir.path());
    let mount = dir.path().join("small");
    std::fs::create_dir(&mount).unwrap();
    // A private mount namespace with a 256 KiB tmpfs as the output folder; 77 if not allowed.
    let script = format!(
        "mount -t tmpfs -o size=256k autoact-test '{m}' || exit 77; \"$@\"; code=$?; echo \"left: $(ls -A '{m}')\" >&2; exit $code",
        m = arg(&mount)
    );
    let out = mount.join("v.mp4");
    let o = Command::new("unshare")
        .args(["-m", "--propagation", "private", "sh", "-c", &script, "sh"])
        .arg(env!("CARGO_BIN_EXE_autoact"))
        .args([
            "render",
            arg(&bag),
            "-o",
            arg(&out),
            "--resolution",
            "320x240",
            "--crf",
            "0",
        ])
        .output()
        .unwrap();
    if o.status.code() == Some(77) || stderr(&o).contains("unshare failed") {
        eprintln!("SKIPPED a_full_disk_is_an_error: cannot mount a tmpfs here");
        return;
    }
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("No space left on device"), "{e}");
    // What the full folder holds afterwards: nothing.
    assert!(e.lines().any(|l| l.trim_end() == "left:"), "{e}");
}

/// A grey PNG's size and values (8- or 16-bit).
fn read_grey(path: &Path) -> (u32, u32, Vec<u16>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(
        info.color_type,
        png::ColorType::Grayscale,
        "{}",
        path.display()
    );
    let values = match info.bit_depth {
        png::BitDepth::Eight => buf[..info.buffer_size()]
            .iter()
            .map(|&v| u16::from(v))
            .collect(),
        png::BitDepth::Sixteen => buf[..info.buffer_size()]
            .chunks_exact(2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
            .collect(),
        other => panic!("{}: {other:?}", path.display()),
    };
    (info.width, info.height, values)
}

#[test]
fn depth_and_mask_passes_agree_with_the_video_and_the_annotations() {
    if common::ffmpeg_or_skip("depth_and_mask_passes").is_none() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let bag = capture(dir.path());
    let video = dir.path().join("v.mp4");
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            arg(&bag),
            "-o",
            arg(&video),
            "--resolution",
            "160x120",
        ];
        args.extend_from_slice(extra);
        autoact(&args)
    };
    let o = render(&["--limit", "40", "--depth", "--masks"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("v.depth"), "{}", stdout(&o));
    let annotations: Vec<FrameAnnotation> = BagReader::open(&dir.path().join("v.render.mcap"))
        .unwrap()
        .messages()
        .map(Result::unwrap)
        .filter(|m| m.channel.topic == "/render/annotations")
        .map(|m| cdr::decode(&m.data).unwrap())
        .collect();
    assert_eq!(annotations.len(), 40);
    for pass in ["v.depth", "v.mask"] {
        assert_eq!(files_in(&dir.path().join(pass)).len(), 40, "{pass}");
    }
    let pelvis = Rig::standard().bone_index("pelvis").unwrap();
    for (k, a) in annotations.iter().enumerate() {
        let name = format!("frame_{k:06}.png");
        let (w, h, mask) = read_grey(&dir.path().join("v.mask").join(&name));
        let (_, _, depth) = read_grey(&dir.path().join("v.depth").join(&name));
        assert_eq!((w, h), (160, 120));
        // The mask is the silhouette the annotations measured: same pixel count, same box.
        let person: Vec<usize> = (0..mask.len()).filter(|&i| mask[i] == 1).collect();
        assert!(
            mask.iter().all(|&v| v <= 1),
            "frame {k}: ids other than 0 and 1"
        );
        assert_eq!(person.len(), a.silhouette_pixels as usize, "frame {k}");
        let (xs, ys): (Vec<u32>, Vec<u32>) =
            person.iter().map(|&i| (i as u32 % w, i as u32 / w)).unzip();
        let bbox = (
            *xs.iter().min().unwrap(),
            *ys.iter().min().unwrap(),
            xs.iter().max().unwrap() - xs.iter().min().unwrap() + 1,
            ys.iter().max().unwrap() - ys.iter().min().unwrap() + 1,
        );
        assert_eq!(
            bbox,
            (
                a.bbox.x_offset,
                a.bbox.y_offset,
                a.bbox.width,
                a.bbox.height
            ),
            "frame {k}"
        );
        // Depth on the person is the body's distance along the optical axis: its median within
        // 0.3 m of the pelvis joint's z.
        let mut on_person: Vec<u16> = person.iter().map(|&i| depth[i]).collect();
        on_person.sort_unstable();
        let median_m = f64::from(on_person[on_person.len() / 2]) / 1000.0;
        let pelvis_z = a.keypoints_3d[pelvis].z;
        assert!(
            (median_m - pelvis_z).abs() < 0.3,
            "frame {k}: depth {median_m} m, pelvis at {pelvis_z} m"
        );
        assert!(
            on_person.iter().all(|&d| d > 0),
            "frame {k}: the person has no depth somewhere"
        );
    }
    // Outputs that exist are not replaced without --force; with it they are.
    let again = render(&["--limit", "40", "--depth"]);
    assert!(
        !again.status.success() && stderr(&again).contains("--force"),
        "{}",
        stderr(&again)
    );
    let forced = render(&["--limit", "20", "--depth", "--force"]);
    assert!(forced.status.success(), "{}", stderr(&forced));
    assert_eq!(files_in(&dir.path().join("v.depth")).len(), 20);
    // The masks showed the video replaced: they are gone, not left stale.
    assert!(!dir.path().join("v.mask").exists());
    assert!(
        !files_in(dir.path()).iter().any(|f| f.contains(".part")),
        "{:?}",
        files_in(dir.path())
    );
}

#[test]
fn a_walk_at_the_pool_never_crosses_water_and_no_prop_hides_the_walker() {
    use autoact::scene::location::{
        BODY_RADIUS_M, FLAT_PROP_M, SIGHT_RADIUS_M, distance_to_rect, distance_to_segment,
    };
    let dir = tempfile::tempdir().unwrap();
    let bag = common::capture_bag_from_spec(
        dir.path(),
        &format!(
            r#"[dataset]
name = "pool"
seed = 8
fps = 30.0
resolution = [320, 240]
session = "dataset"
[counts]
variants = 1
scenes = 4
viewpoints = 2
[[class]]
category = "daily"
action = "walk"
sources = ["{}"]
requires = ["pool"]
"#,
            common::repo("bags/bandai_walk.pose.mcap")
        ),
    );
    let rig = Rig::standard();
    let cap = Capture::read(&rig, &bag).unwrap();
    let mut frames_checked = 0;
    let mut farthest_m = 0.0f64;
    for f in &cap.frames(&rig, 0..cap.frame_count()).unwrap() {
        let scene = &cap.scenes[f.scene];
        assert_eq!(scene.scene.location.name, "swimming_pool");
        let stage = Stage::new(&rig, &scene.scene, scene.stream, 0);
        let water = stage.world.ground.water.expect("the pool is drawn");
        let posed = fk::forward(&rig, &scene.scene.look.character(&rig), &f.pose, 1.0);
        let root = posed.heads_m[0];
        let ground = [root.x, root.y];
        farthest_m = farthest_m.max(root.x.hypot(root.y));
        let rect = water.map(f64::from);
        assert!(
            distance_to_rect(ground, rect) >= BODY_RADIUS_M - 1e-3,
            "{}: the walker at {ground:?} is over the water {rect:?}",
            scene.scene_id
        );
        let eye = f.world_from_optical.translation.vector;
        for p in &scene.scene.location.props {
            if p.size_m[2] <= FLAT_PROP_M {
                continue;
            }
            let c = [p.position_m[0], p.position_m[1]];
            let r = 0.5 * p.size_m[0].hypot(p.size_m[1]);
            let d = distance_to_segment(c, [eye.x, eye.y], ground);
            assert!(
                d >= r + SIGHT_RADIUS_M - 1e-3,
                "{}: a {} at {c:?} stands between the camera and the walker",
                scene.scene_id,
                p.kind
            );
        }
        frames_checked += 1;
    }
    assert!(frames_checked > 100, "{frames_checked} frames");
    assert!(farthest_m > 3.0, "the walk goes somewhere: {farthest_m} m");
}
