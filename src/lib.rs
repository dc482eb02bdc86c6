//! autoact: 3D human pose-estimation output → rotation-based animation on a 53-bone rig →
//! labelled action-recognition datasets, with every step stored in ROS 2 MCAP.
//!
//! The core flow, on a synthetic pose:
//! ```
//! use autoact::skeleton::{convert, fk, layout::Layout, rig::Rig, character::Character};
//! let rig = Rig::standard();
//! let layout = Layout::builtin("h36m-17").unwrap();
//! // Pose the rig's default adult at rest and read the layout's joints off it ...
//! let rest = fk::forward(&rig, &Character::standard(&rig), &fk::BonePose::rest(&rig), 1.0);
//! # let _ = (&layout, &rest);
//! ```

pub mod atomic_file;
pub mod bags;
pub mod camera;
pub mod cli;
pub mod cmd;
pub mod dataset;
pub mod dsi;
pub mod export;
pub mod formats;
pub mod frame_ranges;
pub mod fuzz;
pub mod generate;
pub mod hash;
pub mod inspect;
pub mod instant;
pub mod interrupt;
pub mod loss;
pub mod mcap_io;
pub mod outcome;
pub mod pipeline;
pub mod progress;
pub mod record;
pub mod recover;
pub mod render;
pub mod ros;
pub mod scene;
pub mod skeleton;
pub mod table;
pub mod text_file;
pub mod trim;
pub mod video;

/// The file name of a path (lossily as text; the whole path where it has none, `/` or `..`), for
/// metadata and clip records: never the full path, for outputs must not depend on where the
/// input happened to live.
pub(crate) fn file_name(path: &std::path::Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}
