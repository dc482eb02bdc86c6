//! `autoact import`: a dataset file → a pose bag.

use std::path::PathBuf;

use anyhow::Result;

use super::{Outcome, OutputArgs, print_stdout};
use crate::bags::output::BagOutput;
use crate::formats::import::{self, ImportOptions, Imported, InputFormat};
use crate::skeleton::frames::SourceAxes;
use crate::skeleton::ground::GroundMode;
use crate::skeleton::lengths::LengthMode;

/// Axis conventions a BVH or JSON file may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Axes {
    /// +Z up (autoact's own; 3ds Max and Blender scenes).
    ZUp,
    /// +Y up (OpenGL, Kinect, ZED; most BVH).
    YUp,
    /// +Y down (OpenCV camera frames; most 3D lifters).
    YDown,
}

impl From<Axes> for SourceAxes {
    fn from(a: Axes) -> Self {
        match a {
            Axes::ZUp => SourceAxes::ZUp,
            Axes::YUp => SourceAxes::YUp,
            Axes::YDown => SourceAxes::YDown,
        }
    }
}

/// Arguments of `autoact import`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The dataset file, or a folder of CMU Panoptic `body3DScene_<frame>.json` files (one
    /// sequence: its `hdPose3d_stage1_coco19` folder).
    pub input: PathBuf,
    /// Its format.
    #[arg(long, value_enum, default_value_t = InputFormat::Auto)]
    pub format: InputFormat,
    /// Keypoint layout of the output: for BVH the layout to map the mocap joints onto (default
    /// autoact-landmarks, the rig's own points, so every rig bone the mocap has a joint for is
    /// driven), for MMPose JSON the layout of its keypoints (default coco-wholebody-133). NTU,
    /// Human3.6M, ZED, UTD-MHAD and CMU Panoptic files have a layout of their own.
    #[arg(long, value_name = "LAYOUT")]
    pub layout: Option<String>,
    /// For BVH: a mapping file (TOML) from the file's joints onto layouts, for a skeleton with no
    /// built-in mapping (see docs/convert.md, "BVH mapping files").
    #[arg(long, value_name = "FILE.toml")]
    pub bvh_map: Option<PathBuf>,
    /// Frame rate, for formats that have none (MMPose JSON: required; CMU Panoptic files without
    /// a known `fpsType`); overrides NTU's and UTD-MHAD's 30.
    #[arg(long)]
    pub fps: Option<f64>,
    /// Axes of the coordinates of a BVH or MMPose JSON file (other formats state theirs).
    /// Default: MMPose JSON is y-down; a BVH file is z-up when its motion stands along +Z (and its
    /// rest pose not along +Y), else y-up.
    #[arg(long, value_enum)]
    pub axes: Option<Axes>,
    /// Metres per unit of the coordinates of a BVH or MMPose JSON file (0.001 for millimetres,
    /// 0.0254 for inches; other formats state theirs). Default: MMPose JSON is in metres; a BVH
    /// file's unit is its mapping file's, or else guessed from the size of its rest skeleton.
    #[arg(long)]
    pub metres_per_unit: Option<f64>,
    /// Stand the body on z = 0 facing +Y, up and ground estimated from the feet: `auto` for
    /// camera-frame sources (ZED, MMPose JSON, NTU, UTD-MHAD), never for world-frame ones (BVH,
    /// Human3.6M, CMU Panoptic).
    #[arg(long, value_enum, default_value_t = GroundMode::Auto)]
    pub ground: GroundMode,
    /// Bone lengths: as `measured` per frame, or `fixed` at the clip's median with limbs
    /// re-posed by two-bone IK (feet and hands kept, knees and elbows placed).
    #[arg(long, value_enum, default_value_t = LengthMode::Measured)]
    pub lengths: LengthMode,
    /// The instant the file's first frame is stamped at (ISO 8601 with a UTC offset): the files
    /// `import` reads carry no time of day, so their timelines start here.
    #[arg(long, value_name = "ISO_8601", default_value = crate::instant::DEFAULT_START_TIME,
          value_parser = crate::instant::nanos_since_epoch)]
    pub start_time: u64,
    /// Label: the action category (e.g. `daily`).
    #[arg(long)]
    pub category: Option<String>,
    /// Label: the action (e.g. `wave`).
    #[arg(long)]
    pub action: Option<String>,
    /// Output options.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// Runs `autoact import`.
///
/// # Errors
/// An unreadable input (the message names the file and the place), a bad option, or an output
/// that cannot be written.
pub fn run(args: Args) -> Result<Outcome> {
    let Args {
        input,
        format,
        layout,
        bvh_map,
        fps,
        axes,
        metres_per_unit,
        ground,
        lengths,
        start_time,
        category,
        action,
        output,
    } = args;
    let options = ImportOptions {
        format,
        layout,
        bvh_map,
        fps,
        axes: axes.map(SourceAxes::from),
        metres_per_unit,
        ground,
        lengths,
    };
    crate::atomic_file::refuse_input_as_output(&input, &output.output)?;
    output.options().refuse_existing()?;
    // MMPose JSON is measured on a sample, then read again frame by frame as it is written.
    let mut imported = import::measure(&input, &options)?;
    let mut metadata = imported.metadata(&input, category, action);
    metadata.insert(
        "start_time".to_string(),
        crate::instant::iso_8601(start_time),
    );
    let mut out = BagOutput::create(&output.options())?;
    let written = imported.write(&mut out.writer, metadata, start_time)?;
    let stats = out.finish()?;
    let notes = imported.notes();
    let Imported {
        sequences,
        layout: layout_name,
        ..
    } = imported;
    let (start, end) = stats.time_range.unwrap_or((0, 0));
    let seconds = crate::skeleton::pose::nanos_to_secs(end - start);
    print_stdout(&format!(
        "wrote {}: {written} skeletons ({} track{}), layout {layout_name}, {seconds:.2} s\n",
        output.output.display(),
        sequences.len(),
        if sequences.len() == 1 { "" } else { "s" },
    ))?;
    print_stdout(&notes)?;
    Ok(Outcome::Success)
}
