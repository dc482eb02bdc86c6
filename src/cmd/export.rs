//! `autoact export`: animations of an animation bag → BVH, GTA V `.onim` or glTF/GLB files.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use super::{Outcome, print_stdout, table};
use crate::export::{self, EncodeOptions, ExportFormat, onim};
use crate::mcap_io::BagReader;
use crate::skeleton::rig::Rig;

const AFTER_HELP: &str = "\
Output naming:
  One animation selected: OUT is the file (unless OUT is an existing folder).
  Several: OUT is a folder (made if missing) holding <bag>_track<T>_v<V>.<ext> per animation.
  Nothing is replaced without --force; files are written whole or not at all.

BVH: joints named as `autoact rig` names the bones, offsets in centimetres, Y up, facing +Z
  (autoact's x, y, z written as -x, z, y); root: Xposition Yposition Zposition Zrotation
  Xrotation Yrotation, other joints: Zrotation Xrotation Yrotation, i.e. Euler order ZXY,
  R = Rz * Rx * Ry, degrees. All channels zero = the rig's T-pose. Frame Time = 1 / fps.
  Blender: import with Scale 0.01 for metres.

.onim: Version 8 2, sequences of at most 128 samples sharing their boundary frame
  (SequenceFrameLimit 127), Duration = frames / fps, Static blocks for constant tracks, tracks
  by bone tag, rotations x y z w in GTA ped bone frames, the root moving from the ped's spot.
  The bone frames and bind translations come from --onim-template (the built-in default is
  printed by --print-onim-template, with the source of every choice).

glTF/GLB: the renderer's body as a skinned mesh (one primitive per material), the rig as joints,
  one animation (a rotation per bone and the root's translation per frame, LINEAR, k / fps s),
  and for capture bags the camera path as an animated camera; extras carry the label, scene
  and seed. The autoact frame (metres, Z up) sits under node `autoact_world`, turned -90 deg
  about x to glTF's Y up, so Blender shows autoact's coordinates. tools/render_blender.py
  renders it.";

/// Arguments of `autoact export`.
#[derive(Debug, clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// The animation bag (`autoact convert` output: a `.mcap` file or a rosbag2 folder).
    #[arg(
        value_name = "ANIMATION_BAG",
        required_unless_present = "print_onim_template"
    )]
    pub input: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, required_unless_present_any = ["list", "print_onim_template"])]
    pub format: Option<ExportFormat>,
    /// Output file (one animation) or folder (several); see "Output naming" below.
    #[arg(
        short,
        long,
        value_name = "OUT",
        required_unless_present_any = ["list", "print_onim_template"]
    )]
    pub output: Option<PathBuf>,
    /// Export only this animation: its track id (the person), as `--list` shows. Default: all.
    #[arg(long, value_name = "TRACK")]
    pub animation: Option<u64>,
    /// Export only this variant (0 = as converted, 1.. = DSI variants). Default: all.
    #[arg(long, value_name = "K")]
    pub variant: Option<u32>,
    /// Replace output files that exist.
    #[arg(long)]
    pub force: bool,
    /// List the bag's animations (track, variant, frames, duration, rate) and exit.
    #[arg(long, conflicts_with_all = ["format", "output", "print_onim_template"])]
    pub list: bool,
    /// Frame rate of the output, frames per second. Default: the rate the bag states (what
    /// `autoact convert` resampled to), else the one its stamps show.
    #[arg(long, value_name = "HZ")]
    pub fps: Option<f64>,
    /// `.onim` bone mapping: GTA bone frames and bind translations (TOML, the form
    /// `--print-onim-template` prints). Default: the built-in one.
    #[arg(long, value_name = "FILE")]
    pub onim_template: Option<PathBuf>,
    /// Print the built-in `.onim` mapping (to copy and edit for `--onim-template`) and exit.
    #[arg(long)]
    pub print_onim_template: bool,
    /// Test hook: beside every `X.bvh` also write `X.expected.json` (joints, frames, frame time,
    /// every joint's position per frame) for `tools/interop/check_bvh.py`.
    #[arg(long, hide = true)]
    pub write_expected_json: bool,
}

/// Runs `autoact export`.
///
/// # Errors
/// An unreadable bag or one without animation frames, an unknown `--animation`/`--variant`, an
/// output that exists (without `--force`) or cannot be written, a `.onim` mapping that is
/// invalid or does not cover the rig.
pub fn run(args: Args) -> Result<Outcome> {
    if args.print_onim_template {
        print_stdout(onim::DEFAULT_MAPPING_TOML)?;
        return Ok(Outcome::Success);
    }
    let Some(input) = args.input.as_deref() else {
        bail!("give the animation bag to export");
    };
    if let Some(f) = args.fps
        && !(f.is_finite() && f > 0.0)
    {
        bail!("--fps must be a positive number of frames per second, not {f}");
    }
    let readers = BagReader::open_all(input)?;
    let available = export::list(input, &readers)?;
    if args.list {
        print_stdout(&listing(
            &available,
            args.fps.or_else(|| export::stated_frame_rate(&readers)),
        ))?;
        return Ok(Outcome::Success);
    }
    let (Some(format), Some(output)) = (args.format, args.output.as_deref()) else {
        bail!("give `--format` and `-o OUT`");
    };
    if args.write_expected_json && format != ExportFormat::Bvh {
        bail!("--write-expected-json is for --format bvh only");
    }
    let rig = Rig::standard();
    let options = EncodeOptions {
        onim_mapping: match (format, &args.onim_template) {
            (ExportFormat::Onim, Some(path)) => Some(onim::OnimMapping::load(&rig, path)?),
            (ExportFormat::Onim, None) => Some(onim::OnimMapping::builtin(&rig)?),
            (_, _) => None,
        },
        gltf_scene: None,
    };
    if args.onim_template.is_some() && format != ExportFormat::Onim {
        tracing::warn!("--onim-template is only used with --format onim");
    }
    let keys = export::select(input, &available, args.animation, args.variant)?;
    let (targets, mut folder) = targets(input, output, &keys, format)?;
    // Every target is checked before anything is written, and the folder is made only when the
    // first file is ready, so a refused export writes nothing.
    for path in &targets {
        export::check_writable(path, args.force)?;
        if args.write_expected_json {
            export::check_writable(&expected_path(path), args.force)?;
        }
    }
    let mut text = String::new();
    for (key, path) in keys.iter().zip(&targets) {
        let clip = export::read_clip(&rig, input, &readers, *key, args.fps)?;
        let bytes = if matches!(format, ExportFormat::Gltf | ExportFormat::Glb) {
            let scene = export::gltf::SceneContext::read(&rig, input, &readers, &clip)?;
            let options = EncodeOptions {
                gltf_scene: Some(scene),
                ..options.clone()
            };
            export::encode(&rig, &clip, format, &options)?
        } else {
            export::encode(&rig, &clip, format, &options)?
        };
        if let Some(folder) = folder.take() {
            std::fs::create_dir_all(folder)
                .with_context(|| format!("cannot create the output folder {}", folder.display()))?;
        }
        export::write_atomically(path, &bytes, args.force)?;
        if args.write_expected_json {
            let json = serde_json::to_vec(&export::bvh::expected_json(&rig, &clip))
                .context("cannot encode the expected JSON")?;
            export::write_atomically(&expected_path(path), &json, args.force)?;
        }
        text.push_str(&format!(
            "wrote {}: {key}, {} frames at {} fps\n",
            path.display(),
            clip.poses.len(),
            clip.fps_hz
        ));
    }
    print_stdout(&text)?;
    Ok(Outcome::Success)
}

/// The file each animation goes to (see "Output naming" in the help), and the folder they go in
/// when `output` names one (created only once every target is known to be writable).
fn targets<'o>(
    input: &Path,
    output: &'o Path,
    keys: &[export::AnimationKey],
    format: ExportFormat,
) -> Result<(Vec<PathBuf>, Option<&'o Path>)> {
    if keys.len() == 1 && !output.is_dir() {
        return Ok((vec![output.to_path_buf()], None));
    }
    if keys.len() > 1
        && output
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case(format.extension()))
    {
        bail!(
            "{} animations are selected, and `{}` names one .{} file: give a folder for them, or pick one with `--animation` and `--variant` (`--list` shows them)",
            keys.len(),
            output.display(),
            format.extension()
        );
    }
    let paths = keys
        .iter()
        .map(|k| output.join(export::output_name(input, *k, format)))
        .collect();
    Ok((paths, Some(output)))
}

/// `X.bvh` → `X.expected.json`.
fn expected_path(path: &Path) -> PathBuf {
    path.with_extension("expected.json")
}

/// The `--list` table.
fn listing(available: &[export::AnimationListing], fps: Option<f64>) -> String {
    let rows: Vec<Vec<String>> = available
        .iter()
        .map(|a| {
            let seconds = crate::skeleton::pose::nanos_to_secs(
                a.last_stamp_nanos.saturating_sub(a.first_stamp_nanos),
            );
            vec![
                a.key.track_id.to_string(),
                a.key.variant.to_string(),
                a.frames.to_string(),
                format!("{seconds:.3}"),
                fps.or(a.frame_rate_hz)
                    .map_or_else(|| "-".to_string(), |f| format!("{f:.2}")),
                a.rig.clone(),
            ]
        })
        .collect();
    table(
        &["track", "variant", "frames", "seconds", "fps", "rig"],
        &rows,
    )
}
