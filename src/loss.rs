//! Lost input of a conversion or an export: what of `convert`'s, `convert --spec`'s and
//! `export`'s input could not be used, each naming its file and the place. Collected as [`Losses`], logged with
//! [`Losses::warn`]; the exit code follows the one rule of [`crate::outcome`].

use std::path::Path;

use crate::bags::animation::AnimationLosses;
use crate::bags::pose::{PoseTopics, SkippedMessage};
use crate::mcap_io::ReadIssue;

/// How many losses of each kind [`Losses::warn`] logs in full before it counts the rest.
pub const WARN_LIMIT: usize = 5;

/// One piece of input that could not be used: each names its file, the place in it and what
/// was lost.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Loss {
    /// Part of a file that could not be read (a corrupt chunk, a tail cut short, a message on an
    /// undefined channel), with its file and chunk or message.
    Unreadable(ReadIssue),
    /// A message that was read but could not be used, with its file, topic and index.
    Skipped(SkippedMessage),
    /// Frames of one person dropped because their stamps did not advance.
    NonMonotonic {
        /// The file.
        file: String,
        /// The topic the person is on.
        topic: String,
        /// The person's tracker id.
        track_id: u64,
        /// The dropped frames: (frame index in the track, stamp in nanoseconds).
        frames: Vec<(usize, u64)>,
    },
}

/// The kinds of [`Loss`], in the order [`Losses::warn`] logs them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Unreadable,
    Skipped,
    NonMonotonic,
}

impl Kind {
    const ALL: [Kind; 3] = [Kind::Unreadable, Kind::Skipped, Kind::NonMonotonic];

    /// How a count of this kind reads: "... and 4 more {plural}".
    fn plural(self) -> &'static str {
        match self {
            Kind::Unreadable => "unreadable parts",
            Kind::Skipped => "skipped messages",
            Kind::NonMonotonic => "tracks with frames dropped",
        }
    }
}

impl Loss {
    fn kind(&self) -> Kind {
        match self {
            Loss::Unreadable(_) => Kind::Unreadable,
            Loss::Skipped(_) => Kind::Skipped,
            Loss::NonMonotonic { .. } => Kind::NonMonotonic,
        }
    }
}

impl std::fmt::Display for Loss {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Loss::Unreadable(issue) => issue.fmt(f),
            Loss::Skipped(message) => message.fmt(f),
            Loss::NonMonotonic {
                file,
                topic,
                track_id,
                frames,
            } => {
                write!(
                    f,
                    "{file}: {topic} track {track_id}: {} frames dropped for non-monotonic stamps",
                    frames.len()
                )?;
                if let Some((index, stamp_nanos)) = frames.first() {
                    write!(f, " (first: frame {index}, {stamp_nanos} ns)")?;
                }
                Ok(())
            }
        }
    }
}

/// Everything of an input that could not be used, in the order it was met.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Losses(Vec<Loss>);

impl Losses {
    /// No losses.
    #[must_use]
    pub fn new() -> Losses {
        Losses::default()
    }

    /// What reading pose topics lost: the unreadable parts, then the skipped messages.
    #[must_use]
    pub fn from_pose_topics(topics: &PoseTopics) -> Losses {
        let unreadable = topics.issues.iter().cloned().map(Loss::Unreadable);
        let skipped = topics.skipped.iter().cloned().map(Loss::Skipped);
        Losses(unreadable.chain(skipped).collect())
    }

    /// What reading an animation bag lost: the unreadable parts, then the skipped messages.
    #[must_use]
    pub fn from_animation(lost: &AnimationLosses) -> Losses {
        let unreadable = lost.unreadable.iter().cloned().map(Loss::Unreadable);
        let skipped = lost.skipped.iter().cloned().map(Loss::Skipped);
        Losses(unreadable.chain(skipped).collect())
    }

    /// Adds the losses of `other` that are not among these already (the same file read again
    /// for another animation loses the same parts again).
    pub fn merge(&mut self, other: Losses) {
        for loss in other.0 {
            if !self.0.contains(&loss) {
                self.0.push(loss);
            }
        }
    }

    /// Parts of a file that could not be read.
    #[must_use]
    pub fn from_read_issues(issues: impl IntoIterator<Item = ReadIssue>) -> Losses {
        Losses(issues.into_iter().map(Loss::Unreadable).collect())
    }

    /// Frames of one person dropped for non-monotonic stamps (nothing when `frames` is empty).
    #[must_use]
    pub fn non_monotonic(
        file: &str,
        topic: &str,
        track_id: u64,
        frames: &[(usize, u64)],
    ) -> Losses {
        if frames.is_empty() {
            return Losses::new();
        }
        Losses(vec![Loss::NonMonotonic {
            file: file.to_string(),
            topic: topic.to_string(),
            track_id,
            frames: frames.to_vec(),
        }])
    }

    /// Whether all input was used.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// How many losses.
    #[must_use]
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Each loss, in the order met.
    pub fn iter(&self) -> std::slice::Iter<'_, Loss> {
        self.0.iter()
    }

    /// Adds one loss.
    pub fn push(&mut self, loss: Loss) {
        self.0.push(loss);
    }

    /// Adds every loss of `other`, after these.
    pub fn append(&mut self, other: Losses) {
        self.0.extend(other.0);
    }

    /// Logs the losses as warnings, kind by kind (unreadable parts, skipped messages, tracks
    /// with frames dropped): at most `limit` of each in full, then a count of the rest.
    pub fn warn(&self, limit: usize) {
        for kind in Kind::ALL {
            let mut of_kind = self.0.iter().filter(|l| l.kind() == kind);
            for loss in of_kind.by_ref().take(limit) {
                tracing::warn!("{loss}");
            }
            let rest = of_kind.count();
            if rest > 0 {
                tracing::warn!("... and {rest} more {}", kind.plural());
            }
        }
    }

    /// Logs the closing error line of a run that lost input from `input` (nothing when none was
    /// lost): the losses counted, and that the output holds everything else.
    pub fn log_closing(&self, input: &Path) {
        if !self.is_empty() {
            tracing::error!(
                "{}: some input could not be used ({}); the output holds everything else",
                input.display(),
                self.tally()
            );
        }
    }

    /// The losses counted, for a closing line: "2 unreadable parts, 0 skipped messages", and the
    /// frames dropped for non-monotonic stamps where there are any.
    #[must_use]
    pub fn tally(&self) -> String {
        let count = |kind| self.0.iter().filter(|l| l.kind() == kind).count();
        let mut text = format!(
            "{} unreadable parts, {} skipped messages",
            count(Kind::Unreadable),
            count(Kind::Skipped)
        );
        let dropped: usize = self
            .0
            .iter()
            .map(|l| match l {
                Loss::NonMonotonic { frames, .. } => frames.len(),
                _ => 0,
            })
            .sum();
        if dropped > 0 {
            text.push_str(&format!(
                ", {dropped} frames dropped for non-monotonic stamps"
            ));
        }
        text
    }
}

impl<'a> IntoIterator for &'a Losses {
    type Item = &'a Loss;
    type IntoIter = std::slice::Iter<'a, Loss>;

    fn into_iter(self) -> Self::IntoIter {
        self.0.iter()
    }
}

impl crate::outcome::LostInput for Losses {
    fn lost_input(&self) -> bool {
        !self.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn skipped(index: u64) -> Loss {
        Loss::Skipped(SkippedMessage {
            path: "in.mcap".to_string(),
            topic: "/skeleton".to_string(),
            index,
            log_time: index * 10,
            reason: "bad".to_string(),
        })
    }

    #[test]
    fn losses_name_their_file_place_and_what_was_lost() {
        let mut losses = Losses::new();
        assert!(losses.is_empty());
        assert_eq!(losses.tally(), "0 unreadable parts, 0 skipped messages");
        losses.push(skipped(3));
        losses.append(Losses::non_monotonic(
            "in.mcap",
            "/skeleton",
            7,
            &[(4, 99), (9, 120)],
        ));
        losses.append(Losses::non_monotonic("in.mcap", "/skeleton", 8, &[]));
        assert_eq!(losses.len(), 2);
        let text: Vec<String> = losses.iter().map(ToString::to_string).collect();
        assert_eq!(text[0], "in.mcap: /skeleton message 3 (30 ns): bad");
        assert_eq!(
            text[1],
            "in.mcap: /skeleton track 7: 2 frames dropped for non-monotonic stamps (first: frame 4, 99 ns)"
        );
        assert_eq!(
            losses.tally(),
            "0 unreadable parts, 1 skipped messages, 2 frames dropped for non-monotonic stamps"
        );
    }
}
