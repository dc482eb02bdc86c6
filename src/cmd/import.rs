//! `autoact import`: a dataset file → a pose bag.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use super::{Outcome, OutputArgs, print_stdout};
use crate::bags;
use crate::bags::output::BagOutput;
use crate::file_name;
use crate::formats::{bvh, bvh_map::BvhMapping, h36m_expmap, mmpose_json, ntu, zed_mat};
use crate::skeleton::frames::SourceAxes;
use crate::skeleton::layout::Layout;
use crate::skeleton::pose::PoseSequence;

/// Input formats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum InputFormat {
    /// From the file extension: .bvh, .skeleton, .txt, .mat, .json.
    #[default]
    Auto,
    /// BVH motion capture.
    Bvh,
    /// NTU RGB+D `.skeleton` (Kinect v2).
    Ntu,
    /// Human3.6M exponential-map text (the motion-prediction release).
    H36mExpmap,
    /// ZED BODY_34 `.mat` (MATLAB v5).
    ZedMat,
    /// MMPose-style whole-body JSON (a list of frames of keypoint instances).
    MmposeJson,
}

/// Axis conventions a JSON file may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Axes {
    /// +Z up (autoact's own).
    ZUp,
    /// +Y up (OpenGL, Kinect, ZED).
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
    /// The dataset file.
    pub input: PathBuf,
    /// Its format.
    #[arg(long, value_enum, default_value_t = InputFormat::Auto)]
    pub format: InputFormat,
    /// Keypoint layout of the output: for BVH the layout to map the mocap joints onto (default
    /// coco-wholebody-133), for JSON the layout of its keypoints (default coco-wholebody-133).
    /// NTU, Human3.6M and ZED files have a layout of their own.
    #[arg(long, value_name = "LAYOUT")]
    pub layout: Option<String>,
    /// Frame rate, for formats that have none (JSON: required); overrides NTU's 30.
    #[arg(long)]
    pub fps: Option<f64>,
    /// Axes of a JSON file's coordinates.
    #[arg(long, value_enum, default_value_t = Axes::YDown)]
    pub axes: Axes,
    /// Metres per unit of a JSON file's coordinates (0.001 for millimetres).
    #[arg(long, default_value_t = 1.0)]
    pub metres_per_unit: f64,
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
        fps,
        axes,
        metres_per_unit,
        category,
        action,
        output,
    } = args;
    if let Some(f) = fps
        && !(f.is_finite() && f > 0.0)
    {
        bail!("--fps must be a positive number of frames per second, not {f}");
    }
    let format = resolve_format(format, &input)?;
    let (sequences, layout_name, rate) = read_input(
        &input,
        format,
        layout.as_deref(),
        fps,
        axes.into(),
        metres_per_unit,
    )?;
    let frames: usize = sequences.iter().map(|s| s.frames.len()).sum();
    if frames == 0 {
        bail!("{} holds no frames", input.display());
    }
    let mut metadata = BTreeMap::new();
    metadata.insert("source".to_string(), file_name(&input));
    metadata.insert("format".to_string(), format!("{format:?}"));
    metadata.insert("layout".to_string(), layout_name.clone());
    metadata.insert("rate".to_string(), rate);
    metadata.insert("category".to_string(), category.unwrap_or_default());
    metadata.insert("action".to_string(), action.unwrap_or_default());
    let mut out = BagOutput::create(&output.options())?;
    let written = bags::pose::write_pose_bag(&mut out.writer, &sequences, &layout_name, metadata)?;
    let stats = out.finish()?;
    let (start, end) = stats.time_range.unwrap_or((0, 0));
    let seconds = crate::skeleton::pose::nanos_to_secs(end - start);
    print_stdout(&format!(
        "wrote {}: {written} skeletons ({} track{}), layout {layout_name}, {seconds:.2} s\n",
        output.output.display(),
        sequences.len(),
        if sequences.len() == 1 { "" } else { "s" },
    ))?;
    Ok(Outcome::Success)
}

fn resolve_format(format: InputFormat, input: &Path) -> Result<InputFormat> {
    if format != InputFormat::Auto {
        return Ok(format);
    }
    let ext = input
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    Ok(match ext.as_str() {
        "bvh" => InputFormat::Bvh,
        "skeleton" => InputFormat::Ntu,
        "txt" => InputFormat::H36mExpmap,
        "mat" => InputFormat::ZedMat,
        "json" => InputFormat::MmposeJson,
        _ => bail!(
            "cannot tell the format of {} from its extension `{ext}`: give --format",
            input.display()
        ),
    })
}

fn fixed_layout(format: &str, own: &str, asked: Option<&str>) -> Result<String> {
    match asked {
        Some(l) if Layout::load(l)?.name != own => {
            bail!("{format} files are in the `{own}` layout; drop --layout {l}")
        }
        _ => Ok(own.to_string()),
    }
}

/// Reads the input: its pose sequences, their layout name, and a description of its rate.
fn read_input(
    input: &Path,
    format: InputFormat,
    layout: Option<&str>,
    fps: Option<f64>,
    axes: SourceAxes,
    metres_per_unit: f64,
) -> Result<(Vec<PoseSequence>, String, String)> {
    Ok(match format {
        InputFormat::Auto => bail!("internal bug: format not resolved"),
        InputFormat::Bvh => {
            let clip = bvh::read(input)?;
            let mapping = BvhMapping::detect(&clip)?;
            let layout = Layout::load(layout.unwrap_or("coco-wholebody-133"))?;
            if fps.is_some() {
                bail!("BVH files state their own frame time; drop --fps");
            }
            let seq = mapping
                .keypoints(&clip, &layout)?
                .without_unobserved_joints();
            (
                vec![seq],
                layout.name,
                format!("{:.3} fps (BVH frame time)", clip.fps()),
            )
        }
        InputFormat::Ntu => {
            let layout = fixed_layout("NTU", "ntu-25", layout)?;
            let rate = fps.unwrap_or(ntu::FPS);
            (
                ntu::read(input)?.to_pose_sequences(rate),
                layout,
                format!("{rate} fps"),
            )
        }
        InputFormat::H36mExpmap => {
            let layout = fixed_layout("Human3.6M exp-map", "h36m-32", layout)?;
            if fps.is_some() {
                bail!("Human3.6M exp-map files are 50 fps; drop --fps");
            }
            let clip = h36m_expmap::read(input)?;
            (
                vec![clip.to_pose_sequence(h36m_expmap::RootMode::Trajectory)],
                layout,
                format!("{} fps", h36m_expmap::FPS),
            )
        }
        InputFormat::ZedMat => {
            let layout = fixed_layout("ZED", "zed-body-34", layout)?;
            if fps.is_some() {
                bail!("ZED recordings carry their own timestamps; drop --fps");
            }
            (
                vec![zed_mat::read(input)?.to_pose_sequence()],
                layout,
                "recorded timestamps".to_string(),
            )
        }
        InputFormat::MmposeJson => {
            let layout = Layout::load(layout.unwrap_or("coco-wholebody-133"))?;
            let Some(fps) = fps else {
                bail!(
                    "{}: MMPose JSON has no frame rate: give --fps",
                    input.display()
                );
            };
            if !(metres_per_unit.is_finite() && metres_per_unit > 0.0) {
                bail!("--metres-per-unit must be positive, not {metres_per_unit}");
            }
            let options = mmpose_json::JsonOptions {
                fps,
                metres_per_unit,
                axes,
                joint_names: layout.joints.clone(),
            };
            let seqs = mmpose_json::read(input, &options)
                .with_context(|| format!("reading {} as {}", input.display(), layout.name))?;
            warn_if_implausible_size(&seqs, metres_per_unit);
            (seqs, layout.name, format!("{fps} fps"))
        }
    })
}

/// A body that spans more than 3 m or less than 0.3 m is almost always a unit mistake.
fn warn_if_implausible_size(seqs: &[PoseSequence], metres_per_unit: f64) {
    let mut extent: f64 = 0.0;
    for f in seqs.iter().flat_map(|s| s.frames.iter()).take(200) {
        let zs: Vec<f64> = f
            .positions_m
            .iter()
            .map(|p| p.z)
            .filter(|z| z.is_finite())
            .collect();
        if let (Some(lo), Some(hi)) = (
            zs.iter().copied().reduce(f64::min),
            zs.iter().copied().reduce(f64::max),
        ) {
            extent = extent.max(hi - lo);
        }
    }
    if extent > 3.0 || (extent > 0.0 && extent < 0.3) {
        tracing::warn!(
            "the skeleton is {extent:.2} m tall with --metres-per-unit {metres_per_unit}: check the units (0.001 for millimetres) and --axes"
        );
    }
}
