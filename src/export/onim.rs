//! GTA V `.onim` writer (text animation, `Version 8 2`, as OpenIV and CodeWalker turn into
//! `.ycd`), the mapping from autoact's rig frames to GTA ped bone frames, and a reader of the
//! same layout ([`parse`]) for tests and checks.
//!
//! **Layout written** (the native one, as in GTA's own exports; see
//! `shared/reference/gtautoact-reference-code.md` §4):
//! - header `Flags FLAG_0 FLAG_4 FLAG_5 FLAG_6 FLAG_7 FLAG_8`, `Frames N`,
//!   `SequenceFrameLimit 127`, `Duration N / fps` seconds, `_f10 0`, `ExtraFlags`,
//!   `Sequences n1 n2 …`, `MaterialID -1`;
//! - the frames split into sequences of at most [`SEQUENCE_SAMPLES`] (128) samples, consecutive
//!   sequences sharing their boundary frame (`n1 + n2 + … − (count − 1) = N`); every track has
//!   one `FramesData SingleChannel` block per sequence;
//! - a track whose values never change is written `FramesData SingleChannel Static` with one
//!   line in each block;
//! - tracks ordered by bone tag, a bone's `BonePosition Float3` before its
//!   `BoneRotation Float4`;
//! - `BoneRotation` for every bone of the rig, as `x y z w` unit quaternions in the GTA bone
//!   frames, sign-continuous frame to frame (first frame `w ≥ 0`);
//! - `BonePosition Float3 0`: the root moving — the root translation relative to the first
//!   frame's ground point, turned so the first frame faces the ped's heading (+Y), height kept
//!   (0 = standing), plus the mapping's translation of tag 0 if it has one; the root's
//!   rotation likewise starts from the heading. The clip plays where the ped stands;
//! - a static `BonePosition Float3 <tag>` for every other bind translation of the mapping
//!   (metres, in the parent bone's GTA frame); bones without one get none and keep the ped
//!   skeleton's.
//!
//! Values have 6 decimals (the mapping's translations are written as given).
//!
//! **Mapping.** GTA ped bones have frames of their own: +X runs along the bone, 1-D hinges turn
//! about +Z. autoact's local rotations are relative to the T-pose in world-aligned frames. An
//! [`OnimMapping`] holds, per rig bone, the GTA bone's frame at autoact's rest T-pose
//! (`G_b = autoact_from_gta`); then `gta_local_b = G_parent⁻¹ · local_b · G_b`, which places
//! every GTA bone frame exactly where autoact's animation puts the bone. Rockstar's bind
//! orientations are not published, so the mapping is data: the built-in default
//! ([`DEFAULT_MAPPING_TOML`], `autoact export --print-onim-template`, with every choice and its
//! source documented in the file) or a user's file of the same form (`--onim-template`). A
//! mapping that leaves a rig bone out is an error naming the bones.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use serde::Deserialize;

use super::Clip;
use super::bvh::number;
use crate::skeleton::rig::{ROOT, Rig};

/// Samples per sequence at most: `SequenceFrameLimit` + 1.
pub const SEQUENCE_SAMPLES: usize = 128;

/// The `SequenceFrameLimit` written: frames per sequence after its first sample.
pub const SEQUENCE_FRAME_LIMIT: usize = SEQUENCE_SAMPLES - 1;

/// The built-in mapping onto the GTA V ped skeleton (TOML; the format is documented in it).
pub const DEFAULT_MAPPING_TOML: &str = include_str!("gta_ped.toml");

/// Flags of the header, as in the native files.
const FLAGS: &str = "FLAG_0 FLAG_4 FLAG_5 FLAG_6 FLAG_7 FLAG_8";

/// Why an `.onim` could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OnimError {
    /// The mapping file is not valid.
    #[error("{source_name}: {message}")]
    Template {
        /// `built-in` or the file.
        source_name: String,
        /// What is wrong, and where.
        message: String,
    },
    /// The mapping file cannot be read.
    #[error("{}: cannot read", path.display())]
    Read {
        /// The file.
        path: std::path::PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The mapping file is not TOML of the mapping's form.
    #[error("{source_name}")]
    Toml {
        /// `built-in` or the file.
        source_name: String,
        /// The cause, with its place in the file.
        #[source]
        source: toml::de::Error,
    },
    /// A `[frames]` entry's axes do not make a frame.
    #[error("{source_name}: [frames] `{name}`")]
    Frame {
        /// `built-in` or the file.
        source_name: String,
        /// The entry's bone name.
        name: String,
        /// What is wrong with its axes.
        #[source]
        source: AxesError,
    },
    /// The mapping has no frame for some bones of the rig.
    #[error(
        "the .onim mapping {source_name} does not cover {} of rig {rig}'s bones: {}; add a `[frames]` entry for each (`autoact export --print-onim-template` shows the form)",
        bones.len(), bones.join(", ")
    )]
    Uncovered {
        /// `built-in` or the file.
        source_name: String,
        /// The rig.
        rig: String,
        /// GTA names of the bones left out.
        bones: Vec<String>,
    },
}

/// Why two axes do not make a bone frame.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AxesError {
    /// An axis has no direction.
    #[error("`{axis}` is zero or not finite")]
    Degenerate {
        /// `x` or `y`.
        axis: &'static str,
    },
    /// The axes are not perpendicular (within 0.06°).
    #[error("`x` and `y` are {apart_deg:.3}° apart; they must be perpendicular")]
    NotPerpendicular {
        /// The angle between them, degrees.
        apart_deg: f64,
    },
}

/// Why an `.onim` text could not be read.
#[derive(Debug, thiserror::Error)]
#[error("{source_name}:{line}: {message}")]
pub struct OnimParseError {
    /// The file.
    pub source_name: String,
    /// 1-based line (the last line for what is missing at the end).
    pub line: usize,
    /// What was wrong.
    pub message: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MappingFile {
    frames: BTreeMap<String, FrameAxes>,
    #[serde(default)]
    translations: BTreeMap<String, [f64; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FrameAxes {
    x: [f64; 3],
    y: [f64; 3],
}

/// How autoact's rig maps onto GTA ped bones (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct OnimMapping {
    /// Where it came from: `built-in` or the file's path.
    pub source_name: String,
    /// Per rig bone (rig order), the GTA bone's frame at the rig's rest T-pose:
    /// `autoact_from_gta`.
    pub frames: Vec<UnitQuaternion<f64>>,
    /// Bind translations by GTA bone tag: metres, in the parent bone's GTA frame.
    pub translations: BTreeMap<u16, Vector3<f64>>,
}

impl OnimMapping {
    /// The built-in mapping ([`DEFAULT_MAPPING_TOML`]).
    ///
    /// # Errors
    /// [`OnimError`] if it does not fit `rig` (a test guards the standard rig).
    pub fn builtin(rig: &Rig) -> Result<OnimMapping, OnimError> {
        OnimMapping::from_toml(rig, DEFAULT_MAPPING_TOML, "built-in")
    }

    /// Reads a mapping file.
    ///
    /// # Errors
    /// [`OnimError::Read`] for an unreadable file; as [`OnimMapping::from_toml`] for an invalid
    /// one.
    pub fn load(rig: &Rig, path: &Path) -> Result<OnimMapping, OnimError> {
        let text = crate::text_file::read_to_string(path).map_err(|source| OnimError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        OnimMapping::from_toml(rig, &text, &path.display().to_string())
    }

    /// Parses a mapping: `[frames]` maps GTA bone names (or autoact bone names) to
    /// `{ x = [..], y = [..] }`, the GTA bone's +X and +Y axes in the autoact frame at the rig's
    /// rest T-pose (normalised; they must be perpendicular within 0.06°); `[translations]` maps
    /// GTA bone tags to `[x, y, z]`, metres in the parent's GTA frame.
    ///
    /// # Errors
    /// [`OnimError::Toml`] for text not of the mapping's form, [`OnimError::Template`] or
    /// [`OnimError::Frame`] naming the entry at fault, [`OnimError::Uncovered`] listing every
    /// rig bone without a frame.
    pub fn from_toml(rig: &Rig, text: &str, source_name: &str) -> Result<OnimMapping, OnimError> {
        let err = |message: String| OnimError::Template {
            source_name: source_name.to_string(),
            message,
        };
        let file: MappingFile = toml::from_str(text).map_err(|source| OnimError::Toml {
            source_name: source_name.to_string(),
            source,
        })?;
        let mut frames: Vec<Option<UnitQuaternion<f64>>> = vec![None; rig.bones.len()];
        for (name, axes) in &file.frames {
            let b = rig.bone_index(name).ok_or_else(|| {
                err(format!(
                    "[frames] `{name}` is not a bone of rig {} (`autoact rig` lists them)",
                    rig.name
                ))
            })?;
            if frames[b].is_some() {
                return Err(err(format!(
                    "[frames] `{name}`: bone `{}` is given twice",
                    rig.bones[b].gta_name
                )));
            }
            frames[b] = Some(frame_from_axes(axes).map_err(|source| OnimError::Frame {
                source_name: source_name.to_string(),
                name: name.clone(),
                source,
            })?);
        }
        let mut translations = BTreeMap::new();
        for (key, v) in &file.translations {
            let tag: u16 = key.parse().map_err(|_| {
                err(format!(
                    "[translations] `{key}` is not a GTA bone tag (a number from 0 to 65535)"
                ))
            })?;
            if !v.iter().all(|c| c.is_finite()) {
                return Err(err(format!("[translations] `{key}` is not finite")));
            }
            translations.insert(tag, Vector3::from(*v));
        }
        let uncovered: Vec<String> = rig
            .bones
            .iter()
            .zip(&frames)
            .filter(|(_, f)| f.is_none())
            .map(|(b, _)| b.gta_name.to_string())
            .collect();
        if !uncovered.is_empty() {
            return Err(OnimError::Uncovered {
                source_name: source_name.to_string(),
                rig: rig.name.to_string(),
                bones: uncovered,
            });
        }
        Ok(OnimMapping {
            source_name: source_name.to_string(),
            frames: frames.into_iter().flatten().collect(),
            translations,
        })
    }

    /// GTA local rotations (rig order) of one pose's autoact local rotations:
    /// `G_parent⁻¹ · local · G_bone`, and for the root `heading⁻¹ · local · G_root`.
    #[must_use]
    pub fn to_gta(
        &self,
        rig: &Rig,
        local: &[UnitQuaternion<f64>],
        heading: &UnitQuaternion<f64>,
    ) -> Vec<UnitQuaternion<f64>> {
        self.bone_frames(rig, heading)
            .zip(local)
            .map(|((parent, own), l)| parent.inverse() * l * own)
            .collect()
    }

    /// The inverse of [`OnimMapping::to_gta`]: autoact local rotations of GTA local rotations.
    #[must_use]
    pub fn to_rig(
        &self,
        rig: &Rig,
        gta: &[UnitQuaternion<f64>],
        heading: &UnitQuaternion<f64>,
    ) -> Vec<UnitQuaternion<f64>> {
        self.bone_frames(rig, heading)
            .zip(gta)
            .map(|((parent, own), g)| parent * g * own.inverse())
            .collect()
    }

    /// Per bone in rig order, `(G_parent, G_bone)`: the GTA frame of its parent (`heading` for
    /// the root) and its own.
    fn bone_frames<'a>(
        &'a self,
        rig: &'a Rig,
        heading: &'a UnitQuaternion<f64>,
    ) -> impl Iterator<Item = (UnitQuaternion<f64>, UnitQuaternion<f64>)> + 'a {
        rig.bones.iter().enumerate().map(move |(b, bone)| {
            (
                bone.parent.map_or(*heading, |p| self.frames[p]),
                self.frames[b],
            )
        })
    }
}

/// The rotation whose columns are `x`, `y` and `x × y`, from two perpendicular axes.
fn frame_from_axes(axes: &FrameAxes) -> Result<UnitQuaternion<f64>, AxesError> {
    let x = crate::skeleton::geom::direction(Vector3::from(axes.x))
        .ok_or(AxesError::Degenerate { axis: "x" })?;
    let y = crate::skeleton::geom::direction(Vector3::from(axes.y))
        .ok_or(AxesError::Degenerate { axis: "y" })?;
    let cos = x.dot(&y);
    if cos.abs() > 1e-3 {
        return Err(AxesError::NotPerpendicular {
            apart_deg: cos.clamp(-1.0, 1.0).acos().to_degrees(),
        });
    }
    // Remove the residue of rounding so the frame is exactly orthonormal.
    let y = (y.into_inner() - x.into_inner() * cos).normalize();
    let m = Matrix3::from_columns(&[x.into_inner(), y, x.cross(&y)]);
    Ok(UnitQuaternion::from_rotation_matrix(
        &Rotation3::from_matrix_unchecked(m),
    ))
}

/// The heading a clip starts with: the yaw of its first frame's root rotation.
#[must_use]
pub fn heading(rig: &Rig, clip: &Clip) -> UnitQuaternion<f64> {
    clip.poses
        .first()
        .map_or_else(UnitQuaternion::identity, |p| {
            rig.bones[ROOT].constrain(&p.local_rotations[ROOT])
        })
}

/// Sample counts of the sequences `frames` frames are split into (see the module docs).
#[must_use]
pub fn sequence_lengths(frames: usize) -> Vec<usize> {
    if frames <= SEQUENCE_SAMPLES {
        return vec![frames];
    }
    let mut out = Vec::new();
    let mut start = 0;
    while start + 1 < frames {
        let end = (start + SEQUENCE_FRAME_LIMIT).min(frames - 1);
        out.push(end - start + 1);
        start = end;
    }
    out
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Kind {
    Position,
    Rotation,
}

/// One track's lines: one per frame, or one for all.
struct Track {
    tag: u16,
    kind: Kind,
    lines: Vec<String>,
}

impl Track {
    fn is_static(&self) -> bool {
        self.lines.windows(2).all(|w| w[0] == w[1])
    }
}

fn quaternion_line(q: &UnitQuaternion<f64>) -> String {
    let q = q.as_ref();
    format!(
        "{} {} {} {}",
        number(q.i, 6),
        number(q.j, 6),
        number(q.k, 6),
        number(q.w, 6)
    )
}

/// The `.onim` text of `clip` with `mapping` (see the module docs for the layout).
///
/// # Errors
/// [`OnimError::Uncovered`] when the mapping was made for another rig.
pub fn write(rig: &Rig, clip: &Clip, mapping: &OnimMapping) -> Result<String, OnimError> {
    if mapping.frames.len() != rig.bones.len() {
        return Err(OnimError::Uncovered {
            source_name: mapping.source_name.clone(),
            rig: rig.name.to_string(),
            bones: rig
                .bones
                .iter()
                .skip(mapping.frames.len())
                .map(|b| b.gta_name.to_string())
                .collect(),
        });
    }
    let heading = heading(rig, clip);
    let origin = clip.poses.first().map_or_else(Vector3::zeros, |p| {
        Vector3::new(p.root_translation_m.x, p.root_translation_m.y, 0.0)
    });
    let root_bind = mapping.translations.get(&0).copied().unwrap_or_default();

    let mut tracks: Vec<Track> = Vec::new();
    tracks.push(Track {
        tag: rig.bones[ROOT].gta_tag,
        kind: Kind::Position,
        lines: clip
            .poses
            .iter()
            .map(|p| {
                let v = heading.inverse() * (p.root_translation_m - origin) + root_bind;
                format!("{} {} {}", number(v.x, 6), number(v.y, 6), number(v.z, 6))
            })
            .collect(),
    });
    let mut rotations: Vec<Vec<String>> =
        vec![Vec::with_capacity(clip.poses.len()); rig.bones.len()];
    let mut previous: Vec<Option<UnitQuaternion<f64>>> = vec![None; rig.bones.len()];
    for pose in &clip.poses {
        for (b, q) in mapping
            .to_gta(rig, &pose.local_rotations, &heading)
            .into_iter()
            .enumerate()
        {
            let reference = previous[b].unwrap_or_else(UnitQuaternion::identity);
            let q = crate::skeleton::geom::align_hemisphere(q, &reference);
            previous[b] = Some(q);
            rotations[b].push(quaternion_line(&q));
        }
    }
    for (b, lines) in rotations.into_iter().enumerate() {
        tracks.push(Track {
            tag: rig.bones[b].gta_tag,
            kind: Kind::Rotation,
            lines,
        });
    }
    for (&tag, v) in &mapping.translations {
        if tag != rig.bones[ROOT].gta_tag {
            tracks.push(Track {
                tag,
                kind: Kind::Position,
                lines: vec![format!("{} {} {}", v.x, v.y, v.z)],
            });
        }
    }
    tracks.sort_by_key(|t| (t.tag, t.kind));

    let frames = clip.poses.len();
    let sequences = sequence_lengths(frames);
    let mut s = String::new();
    #[expect(clippy::cast_precision_loss, reason = "frame counts far below 2^52")]
    let duration_secs = frames as f64 / clip.fps_hz;
    let _ = write!(
        s,
        "Version 8 2\n{{\n\tFlags {FLAGS}\n\tFrames {frames}\n\tSequenceFrameLimit {SEQUENCE_FRAME_LIMIT}\n\tDuration {}\n\t_f10 0\n\tExtraFlags\n\tSequences {}\n\tMaterialID -1\n\tAnimation\n\t{{\n",
        number(duration_secs, 6),
        sequences
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(" ")
    );
    for track in &tracks {
        let word = match track.kind {
            Kind::Position => "BonePosition Float3",
            Kind::Rotation => "BoneRotation Float4",
        };
        let _ = write!(s, "\t\t{word} {}\n\t\t{{\n", track.tag);
        let is_static = track.is_static();
        let mut start = 0;
        for &n in &sequences {
            if is_static {
                let line = track.lines.first().map_or("", String::as_str);
                let _ = write!(
                    s,
                    "\t\t\tFramesData SingleChannel Static\n\t\t\t{{\n\t\t\t\t{line}\n\t\t\t}}\n"
                );
            } else {
                s.push_str("\t\t\tFramesData SingleChannel\n\t\t\t{\n");
                for line in &track.lines[start..start + n] {
                    let _ = writeln!(s, "\t\t\t\t{line}");
                }
                s.push_str("\t\t\t}\n");
            }
            start += n.saturating_sub(1);
        }
        s.push_str("\t\t}\n");
    }
    s.push_str("\t}\n}\n");
    Ok(s)
}

/// The kind of an `.onim` track.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum TrackKind {
    /// `BonePosition Float3`: `x y z`, metres.
    Position,
    /// `BoneRotation Float4`: `x y z w`.
    Rotation,
}

/// One `FramesData` block of a track.
#[derive(Debug, Clone, PartialEq)]
pub struct FramesData {
    /// `Static`: one line stands for every sample of the sequence.
    pub is_static: bool,
    /// The value lines.
    pub values: Vec<Vec<f64>>,
}

/// One track of an `.onim`.
#[derive(Debug, Clone, PartialEq)]
pub struct OnimTrack {
    /// Position or rotation.
    pub kind: TrackKind,
    /// GTA bone tag.
    pub tag: u16,
    /// One block per sequence.
    pub blocks: Vec<FramesData>,
}

/// An `.onim` as [`parse`] reads it.
#[derive(Debug, Clone, PartialEq)]
pub struct OnimFile {
    /// `Version a b`.
    pub version: (u32, u32),
    /// The `Flags` words.
    pub flags: Vec<String>,
    /// `Frames`.
    pub frames: usize,
    /// `SequenceFrameLimit`.
    pub sequence_frame_limit: usize,
    /// `Duration`, seconds.
    pub duration_secs: f64,
    /// `Sequences`: samples per sequence.
    pub sequences: Vec<usize>,
    /// The tracks, in file order.
    pub tracks: Vec<OnimTrack>,
}

impl OnimFile {
    /// A track's value per frame: its sequences joined, each shared boundary frame once, a
    /// `Static` block repeated over its sequence.
    #[must_use]
    pub fn samples(&self, track: &OnimTrack) -> Vec<Vec<f64>> {
        let mut out = Vec::with_capacity(self.frames);
        for (i, (block, &n)) in track.blocks.iter().zip(&self.sequences).enumerate() {
            let skip = usize::from(i > 0);
            if block.is_static {
                let v = block.values.first().cloned().unwrap_or_default();
                out.extend(std::iter::repeat_n(v, n.saturating_sub(skip)));
            } else {
                out.extend(block.values.iter().skip(skip).cloned());
            }
        }
        out
    }
}

/// Reads `.onim` text of the layout [`write()`] produces (GTA's native one): the header fields,
/// every `BonePosition Float3` / `BoneRotation Float4` track and its `FramesData` blocks.
///
/// # Errors
/// [`OnimParseError`] naming the line: unexpected or missing words, bad numbers, a value line of
/// the wrong width, a track whose block count is not the sequence count or whose block length is
/// not its sequence's, sequences that do not add up to `Frames`.
pub fn parse(text: &str, source_name: &str) -> Result<OnimFile, OnimParseError> {
    let mut r = Reader {
        lines: text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.split_whitespace().collect::<Vec<_>>()))
            .filter(|(_, w)| !w.is_empty())
            .collect(),
        at: 0,
        last_line: text.lines().count().max(1),
        source_name,
    };
    let header = r.header()?;
    r.expect_next(&["Animation"], "`Animation`")?;
    r.expect_next(&["{"], "`{`")?;
    let mut tracks = Vec::new();
    while let Some(track) = r.track(&header.sequences)? {
        tracks.push(track);
    }
    r.expect_next(&["}"], "`}`")?;
    if let Some((line, words)) = r.lines.get(r.at) {
        return Err(r.err(
            *line,
            format!("unexpected `{}` after the end", words.join(" ")),
        ));
    }
    Ok(OnimFile {
        version: header.version,
        flags: header.flags,
        frames: header.frames,
        sequence_frame_limit: header.sequence_frame_limit,
        duration_secs: header.duration_secs,
        sequences: header.sequences,
        tracks,
    })
}

/// A line of an `.onim`: its 1-based number and its words.
type Line<'t> = (usize, Vec<&'t str>);

/// The fields before `Animation`.
struct Header {
    version: (u32, u32),
    flags: Vec<String>,
    frames: usize,
    sequence_frame_limit: usize,
    duration_secs: f64,
    sequences: Vec<usize>,
}

/// [`parse`]'s cursor over the non-blank lines of an `.onim`.
struct Reader<'t> {
    lines: Vec<Line<'t>>,
    /// The next line's index in `lines`.
    at: usize,
    /// The text's last line number: where what is missing at the end is reported.
    last_line: usize,
    source_name: &'t str,
}

impl<'t> Reader<'t> {
    fn err(&self, line: usize, message: String) -> OnimParseError {
        OnimParseError {
            source_name: self.source_name.to_string(),
            line,
            message,
        }
    }

    /// The next line; `what` names what was expected if the text ends.
    fn next(&mut self, what: &str) -> Result<Line<'t>, OnimParseError> {
        let item =
            self.lines.get(self.at).cloned().ok_or_else(|| {
                self.err(self.last_line, format!("file ends early, expected {what}"))
            })?;
        self.at += 1;
        Ok(item)
    }

    /// The next line, which must be exactly `words`.
    fn expect_next(&mut self, words: &[&str], what: &str) -> Result<(), OnimParseError> {
        let item = self.next(what)?;
        if item.1 == words {
            Ok(())
        } else {
            Err(self.err(
                item.0,
                format!("expected {what}, found `{}`", item.1.join(" ")),
            ))
        }
    }

    /// The values of the next line, which must start with `key`.
    fn field(&mut self, key: &str) -> Result<(usize, Vec<String>), OnimParseError> {
        let item = self.next(&format!("`{key}`"))?;
        if item.1.first() == Some(&key) {
            Ok((
                item.0,
                item.1[1..].iter().map(ToString::to_string).collect(),
            ))
        } else {
            Err(self.err(
                item.0,
                format!("expected `{key}`, found `{}`", item.1.join(" ")),
            ))
        }
    }

    /// The one value of the next line, which must start with `key`.
    fn single(&mut self, key: &str) -> Result<(usize, String), OnimParseError> {
        let (line, v) = self.field(key)?;
        match <[String; 1]>::try_from(v) {
            Ok([one]) => Ok((line, one)),
            Err(_) => Err(self.err(line, format!("`{key}` takes one value"))),
        }
    }

    fn number_at(&self, line: usize, word: &str) -> Result<f64, OnimParseError> {
        word.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| self.err(line, format!("`{word}` is not a finite number")))
    }

    fn count_at(&self, line: usize, word: &str) -> Result<usize, OnimParseError> {
        word.parse::<usize>()
            .map_err(|_| self.err(line, format!("`{word}` is not a count")))
    }

    /// `Version a b`, `{`, then `Flags` … `MaterialID`.
    fn header(&mut self) -> Result<Header, OnimParseError> {
        let v = self.next("`Version 8 2`")?;
        let version = match v.1.as_slice() {
            ["Version", a, b] => (
                a.parse()
                    .map_err(|_| self.err(v.0, format!("bad version `{a}`")))?,
                b.parse()
                    .map_err(|_| self.err(v.0, format!("bad version `{b}`")))?,
            ),
            _ => {
                return Err(self.err(
                    v.0,
                    format!("expected `Version 8 2`, found `{}`", v.1.join(" ")),
                ));
            }
        };
        self.expect_next(&["{"], "`{`")?;
        let (_, flags) = self.field("Flags")?;
        let (line, word) = self.single("Frames")?;
        let frames = self.count_at(line, &word)?;
        let (line, word) = self.single("SequenceFrameLimit")?;
        let sequence_frame_limit = self.count_at(line, &word)?;
        let (line, word) = self.single("Duration")?;
        let duration_secs = self.number_at(line, &word)?;
        self.field("_f10")?;
        self.field("ExtraFlags")?;
        let sequences = self.sequences(frames)?;
        self.field("MaterialID")?;
        Ok(Header {
            version,
            flags,
            frames,
            sequence_frame_limit,
            duration_secs,
            sequences,
        })
    }

    /// `Sequences n1 n2 …`, which must cover `frames` frames, sharing boundary frames.
    fn sequences(&mut self, frames: usize) -> Result<Vec<usize>, OnimParseError> {
        let (line, words) = self.field("Sequences")?;
        let sequences = words
            .iter()
            .map(|w| self.count_at(line, w))
            .collect::<Result<Vec<_>, _>>()?;
        if sequences.is_empty() {
            return Err(self.err(line, "`Sequences` lists no sequence".to_string()));
        }
        let covered = sequences.iter().sum::<usize>() - (sequences.len() - 1);
        if covered != frames {
            return Err(self.err(
                line,
                format!(
                    "sequences {sequences:?} share boundary frames and so cover {covered} frames, not Frames {frames}"
                ),
            ));
        }
        Ok(sequences)
    }

    /// The next track and its `FramesData` blocks, one per sequence; `None` at the `}` that
    /// closes `Animation`.
    fn track(&mut self, sequences: &[usize]) -> Result<Option<OnimTrack>, OnimParseError> {
        let head = self.next("a track or `}`")?;
        let (kind, width) = match head.1.as_slice() {
            ["}"] => return Ok(None),
            ["BonePosition", "Float3", _] => (TrackKind::Position, 3),
            ["BoneRotation", "Float4", _] => (TrackKind::Rotation, 4),
            _ => {
                return Err(self.err(
                    head.0,
                    format!(
                        "expected `BonePosition Float3 <tag>`, `BoneRotation Float4 <tag>` or `}}`, found `{}`",
                        head.1.join(" ")
                    ),
                ));
            }
        };
        let tag: u16 = head.1[2]
            .parse()
            .map_err(|_| self.err(head.0, format!("`{}` is not a bone tag", head.1[2])))?;
        self.expect_next(&["{"], "`{`")?;
        let mut blocks = Vec::new();
        while let Some(block) = self.block(tag, width, sequences.get(blocks.len()), blocks.len())? {
            blocks.push(block);
        }
        if blocks.len() != sequences.len() {
            return Err(self.err(
                head.0,
                format!(
                    "track {tag} has {} FramesData blocks for {} sequences",
                    blocks.len(),
                    sequences.len()
                ),
            ));
        }
        Ok(Some(OnimTrack { kind, tag, blocks }))
    }

    /// Block `k` (0-based) of track `tag`, of value lines `width` numbers wide, for a sequence of
    /// `samples` samples; `None` at the `}` that closes the track.
    fn block(
        &mut self,
        tag: u16,
        width: usize,
        samples: Option<&usize>,
        k: usize,
    ) -> Result<Option<FramesData>, OnimParseError> {
        let b = self.next("`FramesData` or `}`")?;
        let is_static = match b.1.as_slice() {
            ["}"] => return Ok(None),
            ["FramesData", "SingleChannel"] => false,
            ["FramesData", "SingleChannel", "Static"] => true,
            _ => {
                return Err(self.err(
                    b.0,
                    format!(
                        "expected `FramesData SingleChannel [Static]` or `}}`, found `{}`",
                        b.1.join(" ")
                    ),
                ));
            }
        };
        self.expect_next(&["{"], "`{`")?;
        let mut values = Vec::new();
        loop {
            let line = self.next("a value line or `}`")?;
            if line.1 == ["}"] {
                break;
            }
            if line.1.len() != width {
                return Err(self.err(
                    line.0,
                    format!("expected {width} numbers, found {}", line.1.len()),
                ));
            }
            values.push(
                line.1
                    .iter()
                    .map(|w| self.number_at(line.0, w))
                    .collect::<Result<Vec<_>, _>>()?,
            );
        }
        let want = if is_static {
            1
        } else {
            samples.copied().unwrap_or(0)
        };
        if values.len() != want {
            return Err(self.err(
                b.0,
                format!(
                    "block {} of track {tag} has {} lines; sequence {} wants {want}",
                    k + 1,
                    values.len(),
                    k + 1
                ),
            ));
        }
        Ok(Some(FramesData { is_static, values }))
    }
}

#[cfg(test)]
#[path = "onim_tests.rs"]
mod tests;
