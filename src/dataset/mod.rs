//! Datasets: a spec (what to record), its hierarchical plan (every scene drawn, every viewpoint
//! placed, every clip on a timeline), and the capture bags `convert --spec` writes from it.

pub mod capture;
pub mod plan;
pub mod plan_report;
pub mod spec;

use crate::mcap_io::BagReader;
use spec::Spec;

/// Each source's estimated length at the output rate, `[class][source]`: its bag's time range
/// (from the summary, no message read) at the spec's speed, both ends included.
///
/// # Errors
/// A bag that cannot be opened or has no summary statistics, named.
pub fn estimated_frames(spec: &Spec) -> Result<Vec<Vec<u64>>, String> {
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
                    let readers = BagReader::open_all(&s.path).map_err(|e| format!("{key}: {e}"))?;
                    let mut range: Option<(u64, u64)> = None;
                    for r in &readers {
                        let (a, b) = r.time_range().ok_or_else(|| {
                            format!(
                                "{key}: {} has no summary statistics to plan with (was it finished?)",
                                r.path().display()
                            )
                        })?;
                        range = Some(range.map_or((a, b), |(x, y)| (x.min(a), y.max(b))));
                    }
                    let (a, b) = range.unwrap_or((0, 0));
                    #[expect(
                        clippy::cast_possible_truncation,
                        clippy::cast_sign_loss,
                        reason = "frame counts far inside f64's exact range"
                    )]
                    let frames =
                        (crate::skeleton::pose::nanos_to_secs(b - a) * fps / speed).round() as u64 + 1;
                    Ok(frames)
                })
                .collect()
        })
        .collect()
}
