//! Datasets: a spec (what to record), its hierarchical plan (every scene drawn, every viewpoint
//! placed, every clip on a timeline), and the capture bags `convert --spec` writes from it.

pub mod capture;
pub mod plan;
pub mod plan_report;
pub mod spec;

use std::path::PathBuf;

use crate::mcap_io::{BagReader, McapIoError};
use spec::Spec;

/// Why a source's length cannot be estimated.
#[derive(Debug, thiserror::Error)]
pub enum EstimateError {
    /// The source's bag cannot be opened.
    #[error("{key}: {source}")]
    Open {
        /// The spec key of the source, e.g. `class[2].sources[0]`.
        key: String,
        /// Why.
        #[source]
        source: McapIoError,
    },
    /// A bag without a readable message (nor summary statistics).
    #[error("{key}: {path} has no readable message to plan with")]
    NoSummary {
        /// The spec key of the source.
        key: String,
        /// The bag file.
        path: PathBuf,
    },
}

/// Each source's estimated length at the output rate, `[class][source]`: its bag's time range
/// (from the summary, no message read; for an unfinished bag, from its readable messages) at the
/// spec's speed, both ends included.
///
/// # Errors
/// [`EstimateError`]: a bag that cannot be opened or has no summary statistics, named.
pub fn estimated_frames(spec: &Spec) -> Result<Vec<Vec<u64>>, EstimateError> {
    let fps = spec.file.dataset.fps;
    let speed = spec.file.dsi.speed;
    spec.sources
        .iter()
        .enumerate()
        .map(|(k, sources)| {
            sources
                .iter()
                .enumerate()
                .map(|(i, s)| {
                    let key = format!("class[{k}].sources[{i}]");
                    let readers =
                        BagReader::open_all(&s.path).map_err(|source| EstimateError::Open {
                            key: key.clone(),
                            source,
                        })?;
                    let mut range: Option<(u64, u64)> = None;
                    for r in &readers {
                        let (a, b) =
                            r.time_range_or_scan()
                                .ok_or_else(|| EstimateError::NoSummary {
                                    key: key.clone(),
                                    path: r.path().to_path_buf(),
                                })?;
                        range = Some(range.map_or((a, b), |(x, y)| (x.min(a), y.max(b))));
                    }
                    let (a, b) = range.unwrap_or((0, 0));
                    #[expect(
                        clippy::cast_possible_truncation,
                        clippy::cast_sign_loss,
                        reason = "frame counts far inside f64's exact range"
                    )]
                    let frames = (crate::skeleton::pose::nanos_to_secs(b - a) * fps / speed).round()
                        as u64
                        + 1;
                    Ok(frames)
                })
                .collect()
        })
        .collect()
}
