//! `autoact export`: animations of an animation bag → BVH, GTA V `.onim` or glTF/GLB files.

use std::path::PathBuf;

use anyhow::Result;

use super::{Outcome, print_stdout};
use crate::export::job::{ExportRequest, export};
use crate::export::{ExportFormat, onim};
use crate::loss::WARN_LIMIT;

const AFTER_HELP: &str = "\
Output naming:
  One animation selected: OUT is the file (unless OUT is an existing folder).
  Several: OUT is a folder (made if missing) holding <bag>_track<T>_v<V>.<ext> per animation.
  Nothing is replaced without --force; files are written whole or not at all.

Capture bags (autoact convert --spec): every scene draws a new character (body proportions),
  so an animation is exported as one file per scene, each with that scene's skeleton and its
  frames, which put every joint where the bag's /tf and /tf_static do:
  <bag>_track<T>_v<V>_scene<I>.<ext>, I = the scene's index on the capture's timeline. Each
  file's frame 0 is the scene's first capture frame; the report line names the scene id and
  the capture frames (first..end), and glTF extras carry scene_id, scene_index and
  timeline_first_frame. --scene I exports one scene.

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
#[expect(
    clippy::struct_excessive_bools,
    reason = "clap flags: each bool is an independent command-line switch"
)]
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
    /// Capture bags: export only scene I (0 = the first on the timeline; the files and the
    /// report of a full export name each scene's index and id). Default: all.
    #[arg(long, value_name = "I")]
    pub scene: Option<usize>,
    /// Replace output files that exist.
    #[arg(long)]
    pub force: bool,
    /// List the bag's animations (track, variant, frames, duration, rate) and exit; for a
    /// capture bag one row per animation and scene (scene index and id, capture frames).
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

/// Runs `autoact export`: exit code 3 when part of the bag could not be read or used.
///
/// # Errors
/// See [`crate::export::job::ExportJobError`].
pub fn run(args: Args) -> Result<Outcome> {
    if args.print_onim_template {
        print_stdout(onim::DEFAULT_MAPPING_TOML)?;
        return Ok(Outcome::Success);
    }
    let request = ExportRequest {
        input: args.input,
        format: args.format,
        output: args.output,
        animation: args.animation,
        variant: args.variant,
        scene: args.scene,
        force: args.force,
        list: args.list,
        fps: args.fps,
        onim_template: args.onim_template,
        write_expected_json: args.write_expected_json,
    };
    let report = export(&request)?;
    print_stdout(&report.text)?;
    report.losses.warn(WARN_LIMIT);
    if let Some(input) = &request.input {
        report.losses.log_closing(input);
    }
    Ok(Outcome::from_run(&report))
}
