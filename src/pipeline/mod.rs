//! The stages a command runs end to end, as library calls: each takes its options, does the
//! whole job and returns a summary that says what was written and what input was lost
//! ([`crate::loss::Losses`]), so every command maps lost input to its exit code by one rule.
//!
//! - [`convert::convert_bag`]: a pose bag → an animation bag (`autoact convert`), streamed frame
//!   by frame, or solved whole per person with DSI and variants ([`whole_clip`]);
//! - [`spec::convert_spec`]: a dataset spec → its capture sessions (`autoact convert --spec`).

pub mod convert;
pub mod spec;
pub mod whole_clip;

use std::path::PathBuf;

use crate::bags::output::BagOutputError;
use crate::bags::pose::PoseBagError;
use crate::dataset::capture::CaptureError;
use crate::dataset::spec::SpecError;
use crate::dsi::DsiError;
use crate::mcap_io::McapIoError;
use crate::skeleton::convert::ConvertError;
use crate::skeleton::layout::LayoutError;

/// Why a stage stopped.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PipelineError {
    /// The output is the input.
    #[error(transparent)]
    OutputIsInput(#[from] crate::atomic_file::OutputIsInput),
    /// An option out of its range, named as on the command line.
    #[error("{option} must be {expected}, not {value}")]
    OutOfRange {
        /// The option (`--fps`).
        option: &'static str,
        /// What it must be.
        expected: &'static str,
        /// What it was.
        value: String,
    },
    /// More variants than a `BoneFrame` can number.
    #[error("--variants is at most {}", u32::MAX)]
    TooManyVariants,
    /// The layout given for the input cannot be loaded.
    #[error(transparent)]
    Layout(#[from] LayoutError),
    /// The input's pose topics cannot be read.
    #[error(transparent)]
    PoseTopics(#[from] PoseBagError),
    /// A topic's messages name a layout that cannot be loaded.
    #[error("{topic}: its messages name the layout `{layout}`; give --layout")]
    TopicLayout {
        /// The topic.
        topic: String,
        /// The layout its messages name.
        layout: String,
        /// Why it cannot be loaded.
        source: Box<LayoutError>,
    },
    /// A person's poses cannot be prepared for solving (their joints are not the layout's).
    #[error("converting {topic} track {track_id}")]
    Prepare {
        /// The topic.
        topic: String,
        /// The person's tracker id.
        track_id: u64,
        /// Why.
        source: Box<ConvertError>,
    },
    /// A frame cannot be solved.
    #[error(transparent)]
    Solve(#[from] ConvertError),
    /// No frame of the input can be converted.
    #[error("{input}: no frames could be converted")]
    NoFrames {
        /// The input bag.
        input: PathBuf,
    },
    /// DSI failed on a person's clip.
    #[error("DSI on track {track_id}")]
    Dsi {
        /// The person's tracker id.
        track_id: u64,
        /// Why.
        source: DsiError,
    },
    /// The output bag cannot be created or finished.
    #[error(transparent)]
    Output(#[from] BagOutputError),
    /// Writing into the output bag failed.
    #[error(transparent)]
    Write(#[from] McapIoError),
    /// The dataset spec cannot be loaded.
    #[error(transparent)]
    Spec(#[from] SpecError),
    /// A source's length cannot be estimated for the plan.
    #[error(transparent)]
    Estimate(#[from] crate::dataset::EstimateError),
    /// The dataset cannot be planned.
    #[error(transparent)]
    Plan(#[from] crate::dataset::plan::PlanError),
    /// A source or a session of the dataset failed.
    #[error(transparent)]
    Capture(#[from] CaptureError),
    /// A file or folder of the output cannot be written.
    #[error("{action} {path}")]
    Io {
        /// What was being done ("creating", "writing").
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The plan cannot be encoded as JSON.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
}
