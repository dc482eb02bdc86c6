//! BVH (Biovision Hierarchy) reader with forward kinematics.
//!
//! **Responsibility:** turn the text of a `.bvh` file into a [`Bvh`] (skeleton + per-frame
//! channel values, exactly as written in the file), compute world joint transforms from it
//! ([`Bvh::world_transforms`]) and convert it once into a [`PoseSequence`] in metres in the
//! autoact frame ([`Bvh::to_pose_sequence`]). Nothing else in this module converts axes or units.
//!
//! **Hierarchy.** Any tree (several `ROOT`s are accepted); joints are stored in file order, so a
//! parent always precedes its children. Joint names are one or more tokens up to the end of the
//! line (a trailing `{` on the same line is accepted), so Mixamo names like `mixamorig:Hips`
//! work. Every `End Site` becomes a joint named `<parent name>_End` (made unique with a number
//! suffix if that name is taken) with no channels and `is_end_site = true`. Tokens may be
//! separated by any ASCII whitespace (spaces, tabs, trailing spaces, CRLF line ends), keywords are
//! case-sensitive, channel names are not.
//!
//! **Channels and offsets.** Any joint may have any channels, in any order.
//! - *Rotation:* the joint's local rotation is the product of its rotation channels in the order
//!   they are listed, each an angle in degrees about the parent frame's axis:
//!   `R = R_first · R_second · R_third`, applied to column vectors (the standard BVH convention;
//!   `Zrotation Xrotation Yrotation` gives `Rz · Rx · Ry`).
//! - *Translation:* a joint's local translation is its `OFFSET`, **except** that each position
//!   channel **replaces** the matching offset component (it does not add to it). So a joint with
//!   `Xposition Yposition Zposition` is translated by exactly the channel values. This is the
//!   standard rule, and the one that makes files that put 6 channels on every joint
//!   (Bandai-Namco) keep their bone lengths: there the position values equal the offsets.
//! - World transform: `world_from_joint = world_from_parent · (translation, rotation)`.
//!
//! **Motion.** `Frames:` and `Frame Time:` are followed by exactly one frame per line, each line
//! holding one value per channel in hierarchy order. Blank lines are skipped.
//!
//! **Errors.** [`parse`] and [`read`] never panic on any input; they return a [`BvhError`] naming
//! the source file and the 1-based line (and, for motion lines, the 0-based frame index) at fault:
//! unexpected or missing tokens, missing braces, bad numbers, NaN/infinite values, a motion line
//! with the wrong number of values, fewer (or more) frame lines than `Frames:` declares, an empty
//! file, zero frames, or a frame time that is not a finite positive number.
//!
//! **Physical values.** A finite value can still be absurd (`-1e308` makes a root translation of
//! 5e305 m). The parser refuses an offset or a position value beyond [`MAX_ABS_UNITS`] file
//! units and a rotation beyond [`MAX_ABS_DEG`] degrees, naming the line and the channel; once the
//! units are known, [`Bvh::check_translations`] refuses a position channel beyond a distance in
//! metres (the import uses [`MAX_TRANSLATION_M`]).

use std::collections::HashSet;
use std::fmt;
use std::path::Path;

use nalgebra::{Point3, UnitQuaternion, Vector3};

use crate::skeleton::frames::SourceAxes;
use crate::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};

/// The largest magnitude of an `OFFSET` or position value, in file units: 1e4 m in
/// millimetres, far beyond any capture volume in any unit; larger values are refused.
pub const MAX_ABS_UNITS: f64 = 1e7;

/// The largest magnitude of a rotation value, degrees; larger values have lost all precision
/// (at 1e16° one step of an `f64` exceeds a full turn) and are refused.
pub const MAX_ABS_DEG: f64 = 1e6;

/// The largest translation, metres, that [`Bvh::check_translations`] accepts by default use.
pub const MAX_TRANSLATION_M: f64 = 1e4;

/// One BVH channel: a translation or a rotation (degrees) along/about one axis of the parent frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Channel {
    /// Translation along X.
    Xposition,
    /// Translation along Y.
    Yposition,
    /// Translation along Z.
    Zposition,
    /// Rotation about X, degrees.
    Xrotation,
    /// Rotation about Y, degrees.
    Yrotation,
    /// Rotation about Z, degrees.
    Zrotation,
}

impl Channel {
    /// All channels, positions first.
    pub const ALL: [Channel; 6] = [
        Channel::Xposition,
        Channel::Yposition,
        Channel::Zposition,
        Channel::Xrotation,
        Channel::Yrotation,
        Channel::Zrotation,
    ];

    /// The channel with this name (`Xposition` … `Zrotation`, ASCII case-insensitive).
    #[must_use]
    pub fn from_name(name: &str) -> Option<Channel> {
        Channel::ALL
            .into_iter()
            .find(|c| c.name().eq_ignore_ascii_case(name))
    }

    /// The channel's name as written in BVH files.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Channel::Xposition => "Xposition",
            Channel::Yposition => "Yposition",
            Channel::Zposition => "Zposition",
            Channel::Xrotation => "Xrotation",
            Channel::Yrotation => "Yrotation",
            Channel::Zrotation => "Zrotation",
        }
    }

    /// Whether this is a translation channel.
    #[must_use]
    pub fn is_position(self) -> bool {
        matches!(
            self,
            Channel::Xposition | Channel::Yposition | Channel::Zposition
        )
    }

    /// Whether this is a rotation channel.
    #[must_use]
    pub fn is_rotation(self) -> bool {
        !self.is_position()
    }

    /// The axis index (0 = X, 1 = Y, 2 = Z).
    #[must_use]
    pub fn axis(self) -> usize {
        match self {
            Channel::Xposition | Channel::Xrotation => 0,
            Channel::Yposition | Channel::Yrotation => 1,
            Channel::Zposition | Channel::Zrotation => 2,
        }
    }
}

impl fmt::Display for Channel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One joint (or End Site) of a BVH hierarchy.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhJoint {
    /// Name as in the file; End Sites are named `<parent name>_End` (unique).
    pub name: String,
    /// Index of the parent joint in [`Bvh::joints`] (always smaller than this joint's index);
    /// `None` for a root.
    pub parent: Option<usize>,
    /// `OFFSET`, in file units and file axes.
    pub offset: Vector3<f64>,
    /// Channels in file order (empty for End Sites).
    pub channels: Vec<Channel>,
    /// Whether this joint is an `End Site`.
    pub is_end_site: bool,
}

/// A parsed BVH file: the skeleton and the raw channel values of every frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Bvh {
    /// Where the data came from (the path given to [`read`] or the `source` given to [`parse`]).
    pub source: String,
    /// Joints in file order (End Sites included); parents precede children.
    pub joints: Vec<BvhJoint>,
    /// Seconds per frame (`Frame Time:`), finite and > 0.
    pub frame_time_secs: f64,
    /// Channel values per frame, in file order (joint order, then each joint's channel order);
    /// every frame has [`Bvh::channel_count`] values, all finite. Positions in file units,
    /// rotations in degrees.
    pub frames: Vec<Vec<f64>>,
    /// 1-based line of each frame in the file (blank lines are skipped, so not always
    /// consecutive), for errors found after parsing.
    pub frame_lines: Vec<usize>,
}

/// Why a BVH file could not be read. Every variant names the file; all but [`BvhError::Io`]
/// name the 1-based line, and motion-line variants also the 0-based frame index.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BvhError {
    /// The file could not be read.
    #[error("{file}: cannot read file: {err}")]
    Io {
        /// The file.
        file: String,
        /// The underlying error.
        #[source]
        err: std::io::Error,
    },
    /// The file has no tokens at all.
    #[error("{file}:1: empty file, expected HIERARCHY")]
    Empty {
        /// The file.
        file: String,
    },
    /// A token that does not fit the BVH grammar at this point.
    #[error("{file}:{line}: expected {expected}, found '{found}'")]
    UnexpectedToken {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// What the grammar allows here.
        expected: &'static str,
        /// The token found.
        found: String,
    },
    /// The file ends before the hierarchy or the motion header is complete.
    #[error("{file}:{line}: file ends early, expected {expected}")]
    UnexpectedEof {
        /// The file.
        file: String,
        /// 1-based line of the last line of the file.
        line: usize,
        /// What the grammar expected next.
        expected: &'static str,
    },
    /// A `{` after a joint name or a `}` closing a joint is missing.
    #[error("{file}:{line}: missing '{brace}' {context}, found {found}")]
    MissingBrace {
        /// The file.
        file: String,
        /// 1-based line where the brace was expected.
        line: usize,
        /// The missing brace, `{` or `}`.
        brace: char,
        /// Which joint it belongs to, e.g. `after joint 'Hips'`.
        context: String,
        /// What was found instead (a quoted token, or `end of file`).
        found: String,
    },
    /// A number in the hierarchy or motion header that does not parse or is out of range.
    #[error("{file}:{line}: bad {what} '{token}', expected {expected}")]
    BadNumber {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// Which number, e.g. `OFFSET value`.
        what: &'static str,
        /// The token.
        token: String,
        /// What it should be.
        expected: &'static str,
    },
    /// The hierarchy declares no channels, so the motion cannot hold anything.
    #[error("{file}:{line}: the hierarchy declares no channels")]
    NoChannels {
        /// The file.
        file: String,
        /// 1-based line of `MOTION`.
        line: usize,
    },
    /// `Frames:` is 0.
    #[error("{file}:{line}: zero frames (Frames: 0), the clip is empty")]
    ZeroFrames {
        /// The file.
        file: String,
        /// 1-based line of `Frames:`.
        line: usize,
    },
    /// `Frame Time:` is not a finite number > 0.
    #[error("{file}:{line}: bad Frame Time {value}, expected a finite number of seconds > 0")]
    BadFrameTime {
        /// The file.
        file: String,
        /// 1-based line of `Frame Time:`.
        line: usize,
        /// The value read.
        value: f64,
    },
    /// A motion value that does not parse as a number.
    #[error(
        "{file}:{line}: frame {frame}: bad value '{token}' in column {column}, expected a number"
    )]
    BadValue {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// 0-based frame index.
        frame: usize,
        /// 0-based column (channel index).
        column: usize,
        /// The token.
        token: String,
    },
    /// A motion value that is NaN or infinite.
    #[error("{file}:{line}: frame {frame}: value '{token}' in column {column} is not finite")]
    NonFinite {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// 0-based frame index.
        frame: usize,
        /// 0-based column (channel index).
        column: usize,
        /// The token.
        token: String,
    },
    /// An offset or motion value that is finite but not physical: beyond [`MAX_ABS_UNITS`]
    /// (positions, offsets), [`MAX_ABS_DEG`] (rotations), or, after unit scaling, the largest
    /// translation allowed.
    #[error("{file}:{line}: {place}: value {value:e} is not physical ({why})")]
    NotPhysical {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// Where on the line: `frame F, column C (Joint Xposition)` or `OFFSET of Joint`.
        place: String,
        /// The value as read.
        value: f64,
        /// The bound it breaks.
        why: String,
    },
    /// A motion line whose number of values is not the number of channels.
    #[error(
        "{file}:{line}: frame {frame} has {found} values, expected {expected} (one per channel)"
    )]
    WrongValueCount {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// 0-based frame index.
        frame: usize,
        /// Channels in the hierarchy.
        expected: usize,
        /// Values on the line.
        found: usize,
    },
    /// The file ends with fewer frame lines than `Frames:` declares (a truncated file).
    #[error("{file}:{line}: file ends after {found} frame lines, but Frames: declares {declared}")]
    FewerFramesThanDeclared {
        /// The file.
        file: String,
        /// 1-based line of the last line of the file.
        line: usize,
        /// `Frames:` value.
        declared: usize,
        /// Frame lines present.
        found: usize,
    },
    /// There are more frame lines than `Frames:` declares.
    #[error("{file}:{line}: extra frame line, Frames: declares only {declared}")]
    MoreFramesThanDeclared {
        /// The file.
        file: String,
        /// 1-based line of the first extra line.
        line: usize,
        /// `Frames:` value.
        declared: usize,
    },
}

/// Reads and parses a BVH file. Invalid UTF-8 is replaced (joint names only can be affected).
///
/// # Errors
/// [`BvhError::Io`] if the file cannot be read, otherwise as [`parse`].
pub fn read(path: &Path) -> Result<Bvh, BvhError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|err| BvhError::Io {
        file: file.clone(),
        err,
    })?;
    parse(&String::from_utf8_lossy(&bytes), &file)
}

/// Parses the text of a BVH file; `source` names it in errors and in [`Bvh::source`].
///
/// # Errors
/// Any [`BvhError`] but `Io`, naming `source` and the line (and frame) at fault.
pub fn parse(text: &str, source: &str) -> Result<Bvh, BvhError> {
    Parser::new(text, source).parse()
}

impl Bvh {
    /// Refuses a position channel whose value, at `metres_per_unit`, is farther than `max_m`
    /// metres from the origin, naming the line, frame, column and channel: a clip whose values
    /// are finite but absurd must not come out as a body kilometres away.
    ///
    /// # Errors
    /// [`BvhError::NotPhysical`] for the first such value.
    pub fn check_translations(&self, metres_per_unit: f64, max_m: f64) -> Result<(), BvhError> {
        let columns: Vec<(&str, Channel)> = self
            .joints
            .iter()
            .flat_map(|j| j.channels.iter().map(|c| (j.name.as_str(), *c)))
            .collect();
        for (frame, values) in self.frames.iter().enumerate() {
            for (column, (&v, &(joint, channel))) in values.iter().zip(&columns).enumerate() {
                let metres = (v * metres_per_unit).abs();
                if channel.is_position() && (metres > max_m || metres.is_nan()) {
                    return Err(BvhError::NotPhysical {
                        file: self.source.clone(),
                        line: self.frame_lines.get(frame).copied().unwrap_or(0),
                        place: format!("frame {frame}, column {column} ({joint} {channel})"),
                        value: v,
                        why: format!(
                            "{metres:.3e} m at {metres_per_unit} m per unit; translations are at most {max_m:e} m"
                        ),
                    });
                }
            }
        }
        Ok(())
    }

    /// Total number of channels (values per frame).
    #[must_use]
    pub fn channel_count(&self) -> usize {
        self.joints.iter().map(|j| j.channels.len()).sum()
    }

    /// Number of frames.
    #[must_use]
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// Frames per second, `1 / frame_time_secs`.
    #[must_use]
    pub fn fps(&self) -> f64 {
        1.0 / self.frame_time_secs
    }

    /// Index of the first joint with this name.
    #[must_use]
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Joint names in file order (End Sites included).
    #[must_use]
    pub fn joint_names(&self) -> Vec<String> {
        self.joints.iter().map(|j| j.name.clone()).collect()
    }

    /// Per joint, the index of its first channel in a frame's values.
    #[must_use]
    pub fn channel_starts(&self) -> Vec<usize> {
        let mut next = 0;
        self.joints
            .iter()
            .map(|j| {
                let start = next;
                next += j.channels.len();
                start
            })
            .collect()
    }

    /// Forward kinematics of frame `frame`: per joint (file order), its world position and
    /// orientation (`world_from_joint`), in file units and file axes. See the module docs for the
    /// channel and offset rules.
    ///
    /// # Panics
    /// If `frame >= self.frame_count()` (like slice indexing).
    #[must_use]
    pub fn world_transforms(&self, frame: usize) -> Vec<(Point3<f64>, UnitQuaternion<f64>)> {
        let mut out = Vec::with_capacity(self.joints.len());
        self.fk_into(Some(&self.frames[frame]), &mut out);
        out
    }

    /// Joint positions of the rest skeleton (all rotations zero, every joint translated by its
    /// `OFFSET` only; position channels ignored), in file units and file axes.
    #[must_use]
    pub fn rest_positions(&self) -> Vec<Point3<f64>> {
        let mut out = Vec::with_capacity(self.joints.len());
        self.fk_into(None, &mut out);
        out.into_iter().map(|(p, _)| p).collect()
    }

    /// World orientations (`autoact_from_joint'`) of frame `frame`, each converted with
    /// [`SourceAxes::orientation_to_autoact`], i.e. the same body frames with their axes mapped
    /// like the world axes. Units do not matter for orientations.
    ///
    /// # Panics
    /// If `frame >= self.frame_count()`.
    #[must_use]
    pub fn world_orientations_autoact(
        &self,
        frame: usize,
        source_axes: SourceAxes,
    ) -> Vec<UnitQuaternion<f64>> {
        self.world_transforms(frame)
            .into_iter()
            .map(|(_, q)| source_axes.orientation_to_autoact(q))
            .collect()
    }

    /// Size of the rest skeleton along each file axis: the extent (max − min) of
    /// [`Bvh::rest_positions`], End Sites included, in file units.
    #[must_use]
    pub fn rest_extent(&self) -> Vector3<f64> {
        let rest = self.rest_positions();
        let Some(first) = rest.first() else {
            return Vector3::zeros();
        };
        let (lo, hi) = rest
            .iter()
            .fold((first.coords, first.coords), |(lo, hi), p| {
                (lo.inf(&p.coords), hi.sup(&p.coords))
            });
        hi - lo
    }

    /// Guesses the file unit from the size of the rest skeleton, the largest component of
    /// [`Bvh::rest_extent`]: 100–250 → `0.01` (centimetres), 1–2.5 → `1.0` (metres), 40–100 →
    /// `0.0254` (inches), anything else → `None` (the caller must give a scale; e.g. CMU-style
    /// files are 25–30 units tall).
    ///
    /// The largest extent is used rather than the extent along Y (up) because some rest
    /// skeletons do not stand upright: the Bandai-Namco rest pose lies along X (its rotations
    /// raise it), with a Y extent of ≈100 cm, right at the cm/inch boundary, and an X extent of
    /// ≈190 cm. For an upright rest pose the largest extent is the height or the arm span, which
    /// are about equal for a human.
    #[must_use]
    pub fn guess_metres_per_unit(&self) -> Option<f64> {
        let size = self.rest_extent().max();
        if (100.0..=250.0).contains(&size) {
            Some(0.01)
        } else if (1.0..=2.5).contains(&size) {
            Some(1.0)
        } else if (40.0..100.0).contains(&size) {
            Some(0.0254)
        } else {
            None
        }
    }

    /// World joint positions of every frame as a [`PoseSequence`]: joint names in file order
    /// (End Sites included), positions scaled by `metres_per_unit` and then converted once with
    /// [`SourceAxes::point_to_autoact`] (BVH files are normally [`SourceAxes::YUp`]), stamps from
    /// [`stamp_nanos_at`] at `1 / frame_time_secs`, confidence 1 everywhere, track id 0.
    #[must_use]
    pub fn to_pose_sequence(&self, metres_per_unit: f64, source_axes: SourceAxes) -> PoseSequence {
        let fps = self.fps();
        let mut world = Vec::with_capacity(self.joints.len());
        let frames = self
            .frames
            .iter()
            .enumerate()
            .map(|(i, values)| {
                self.fk_into(Some(values), &mut world);
                PoseFrame {
                    stamp_nanos: stamp_nanos_at(i, fps),
                    positions_m: world
                        .iter()
                        .map(|(p, _)| {
                            source_axes.point_to_autoact(Point3::from(p.coords * metres_per_unit))
                        })
                        .collect(),
                    confidence: vec![1.0; world.len()],
                }
            })
            .collect();
        PoseSequence {
            source: self.source.clone(),
            track_id: 0,
            joint_names: self.joint_names(),
            frames,
        }
    }

    /// FK into `out` (cleared first). `values = None` is the rest pose (offsets only).
    /// Missing values (a hand-edited `Bvh`) count as 0; a parent index that does not precede its
    /// child counts as the world.
    fn fk_into(&self, values: Option<&[f64]>, out: &mut Vec<(Point3<f64>, UnitQuaternion<f64>)>) {
        out.clear();
        let mut cursor = 0;
        for joint in &self.joints {
            let mut translation = joint.offset;
            let mut rotation = UnitQuaternion::identity();
            if let Some(values) = values {
                for &channel in &joint.channels {
                    let v = values.get(cursor).copied().unwrap_or(0.0);
                    cursor += 1;
                    let axis = channel.axis();
                    if channel.is_position() {
                        translation[axis] = v;
                    } else {
                        let unit = match axis {
                            0 => Vector3::x_axis(),
                            1 => Vector3::y_axis(),
                            _ => Vector3::z_axis(),
                        };
                        rotation *= UnitQuaternion::from_axis_angle(&unit, v.to_radians());
                    }
                }
            }
            let parent = joint.parent.and_then(|p| out.get(p).copied());
            let world = match parent {
                Some((pp, pq)) => (pp + pq * translation, pq * rotation),
                None => (Point3::from(translation), rotation),
            };
            out.push(world);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Parser
// ---------------------------------------------------------------------------------------------

/// Splits text into whitespace-separated tokens, remembering 1-based line numbers.
struct Lexer<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    tokens: std::str::SplitAsciiWhitespace<'a>,
    /// 1-based number of the line `tokens` comes from (0 before the first line).
    line: usize,
}

impl<'a> Lexer<'a> {
    fn new(text: &'a str) -> Self {
        Lexer {
            lines: text.lines().enumerate(),
            tokens: "".split_ascii_whitespace(),
            line: 0,
        }
    }

    /// The next token and its line, crossing line ends.
    fn next(&mut self) -> Option<(usize, &'a str)> {
        loop {
            if let Some(t) = self.tokens.next() {
                return Some((self.line, t));
            }
            let (i, l) = self.lines.next()?;
            self.line = i + 1;
            self.tokens = l.split_ascii_whitespace();
        }
    }

    /// The next token on the current line only.
    fn next_on_line(&mut self) -> Option<&'a str> {
        self.tokens.next()
    }

    /// The next whole line and its 1-based number (after the current one).
    fn next_line(&mut self) -> Option<(usize, &'a str)> {
        let (i, l) = self.lines.next()?;
        self.line = i + 1;
        self.tokens = "".split_ascii_whitespace();
        Some((self.line, l))
    }
}

/// An open `{ … }` of a joint during hierarchy parsing.
struct Open {
    joint: usize,
    line: usize,
    has_offset: bool,
    has_channels: bool,
}

/// What the motion section holds: the frame time, the frames, and each frame's line.
type Motion = (f64, Vec<Vec<f64>>, Vec<usize>);

struct Parser<'a> {
    lex: Lexer<'a>,
    file: &'a str,
}

/// Shows a token (or end of file) in an error.
fn quoted(tok: Option<(usize, &str)>) -> String {
    match tok {
        Some((_, t)) => format!("'{t}'"),
        None => "end of file".to_owned(),
    }
}

impl<'a> Parser<'a> {
    fn new(text: &'a str, file: &'a str) -> Self {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        Parser {
            lex: Lexer::new(text),
            file,
        }
    }

    fn unexpected(&self, line: usize, expected: &'static str, found: &str) -> BvhError {
        BvhError::UnexpectedToken {
            file: self.file.to_owned(),
            line,
            expected,
            found: found.to_owned(),
        }
    }

    fn eof(&self, expected: &'static str) -> BvhError {
        BvhError::UnexpectedEof {
            file: self.file.to_owned(),
            line: self.lex.line.max(1),
            expected,
        }
    }

    fn token(&mut self, expected: &'static str) -> Result<(usize, &'a str), BvhError> {
        match self.lex.next() {
            Some(t) => Ok(t),
            None => Err(self.eof(expected)),
        }
    }

    fn bad_number(
        &self,
        line: usize,
        what: &'static str,
        token: &str,
        expected: &'static str,
    ) -> BvhError {
        BvhError::BadNumber {
            file: self.file.to_owned(),
            line,
            what,
            token: token.to_owned(),
            expected,
        }
    }

    fn finite(&mut self, what: &'static str) -> Result<(usize, f64), BvhError> {
        let (line, tok) = self.token(what)?;
        match tok.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok((line, v)),
            _ => Err(self.bad_number(line, what, tok, "a finite number")),
        }
    }

    /// The rest of the current line as a joint name; returns whether a `{` ended the line.
    fn joint_name(&mut self, line: usize) -> Result<(String, bool), BvhError> {
        let mut parts: Vec<&str> = Vec::new();
        while let Some(t) = self.lex.next_on_line() {
            parts.push(t);
        }
        let brace = parts.last() == Some(&"{");
        if brace {
            parts.pop();
        }
        if parts.is_empty() {
            let found = if brace { "{" } else { "end of line" };
            return Err(self.unexpected(line, "a joint name", found));
        }
        Ok((parts.join(" "), brace))
    }

    fn parse(mut self) -> Result<Bvh, BvhError> {
        let Some((line, tok)) = self.lex.next() else {
            return Err(BvhError::Empty {
                file: self.file.to_owned(),
            });
        };
        if tok != "HIERARCHY" {
            return Err(self.unexpected(line, "HIERARCHY", tok));
        }
        let (joints, motion_line) = self.hierarchy()?;
        let channel_count: usize = joints.iter().map(|j| j.channels.len()).sum();
        if channel_count == 0 {
            return Err(BvhError::NoChannels {
                file: self.file.to_owned(),
                line: motion_line,
            });
        }
        let columns: Vec<(&str, Channel)> = joints
            .iter()
            .flat_map(|j| j.channels.iter().map(|c| (j.name.as_str(), *c)))
            .collect();
        let (frame_time_secs, frames, frame_lines) = self.motion(&columns)?;
        Ok(Bvh {
            source: self.file.to_owned(),
            joints,
            frame_time_secs,
            frames,
            frame_lines,
        })
    }

    /// Parses from after `HIERARCHY` up to and including `MOTION`; returns the joints and the
    /// line of `MOTION`.
    fn hierarchy(&mut self) -> Result<(Vec<BvhJoint>, usize), BvhError> {
        let mut joints: Vec<BvhJoint> = Vec::new();
        let mut stack: Vec<Open> = Vec::new();
        loop {
            let next = self.lex.next();
            let Some(top) = stack.last_mut() else {
                // Between roots.
                match next {
                    Some((line, "ROOT")) => {
                        self.open_joint(line, None, &mut joints, &mut stack)?;
                    }
                    Some((line, "MOTION")) if !joints.is_empty() => {
                        if let Some(t) = self.lex.next_on_line() {
                            return Err(self.unexpected(line, "end of line after MOTION", t));
                        }
                        assign_end_site_names(&mut joints);
                        return Ok((joints, line));
                    }
                    Some((line, t)) => {
                        let expected = if joints.is_empty() {
                            "ROOT"
                        } else {
                            "ROOT or MOTION"
                        };
                        return Err(self.unexpected(line, expected, t));
                    }
                    None => {
                        return Err(self.eof(if joints.is_empty() { "ROOT" } else { "MOTION" }));
                    }
                }
                continue;
            };
            let Some((line, tok)) = next else {
                let joint = joints
                    .get(top.joint)
                    .map_or_else(String::new, |j| j.name.clone());
                return Err(BvhError::MissingBrace {
                    file: self.file.to_owned(),
                    line: self.lex.line.max(1),
                    brace: '}',
                    context: format!("closing joint '{joint}' (opened at line {})", top.line),
                    found: "end of file".to_owned(),
                });
            };
            match tok {
                "OFFSET" if !top.has_offset => {
                    top.has_offset = true;
                    let joint = top.joint;
                    let name = joints.get(joint).map_or("", |j| j.name.as_str());
                    let offset = self.offset(&format!("OFFSET of {name}"))?;
                    if let Some(j) = joints.get_mut(joint) {
                        j.offset = offset;
                    }
                }
                "CHANNELS" if !top.has_channels => {
                    top.has_channels = true;
                    let joint = top.joint;
                    let channels = self.channels()?;
                    if let Some(j) = joints.get_mut(joint) {
                        j.channels = channels;
                    }
                }
                "JOINT" => {
                    let parent = top.joint;
                    self.open_joint(line, Some(parent), &mut joints, &mut stack)?;
                }
                "End" => {
                    let parent = top.joint;
                    self.end_site(line, parent, &mut joints)?;
                }
                "}" => {
                    stack.pop();
                }
                "MOTION" | "ROOT" => {
                    let joint = joints
                        .get(top.joint)
                        .map_or_else(String::new, |j| j.name.clone());
                    return Err(BvhError::MissingBrace {
                        file: self.file.to_owned(),
                        line,
                        brace: '}',
                        context: format!("closing joint '{joint}' (opened at line {})", top.line),
                        found: format!("'{tok}'"),
                    });
                }
                _ => {
                    let expected = match (top.has_offset, top.has_channels) {
                        (false, false) => "OFFSET, CHANNELS, JOINT, End Site or '}'",
                        (true, false) => "CHANNELS, JOINT, End Site or '}'",
                        (false, true) => "OFFSET, JOINT, End Site or '}'",
                        (true, true) => "JOINT, End Site or '}'",
                    };
                    return Err(self.unexpected(line, expected, tok));
                }
            }
        }
    }

    /// After `ROOT`/`JOINT` at `line`: name, `{`; pushes the joint and its open brace.
    fn open_joint(
        &mut self,
        line: usize,
        parent: Option<usize>,
        joints: &mut Vec<BvhJoint>,
        stack: &mut Vec<Open>,
    ) -> Result<(), BvhError> {
        let (name, brace_on_line) = self.joint_name(line)?;
        let brace_line = if brace_on_line {
            line
        } else {
            let next = self.lex.next();
            match next {
                Some((l, "{")) => l,
                other => {
                    return Err(BvhError::MissingBrace {
                        file: self.file.to_owned(),
                        line: other.map_or(self.lex.line.max(1), |(l, _)| l),
                        brace: '{',
                        context: format!("after joint '{name}'"),
                        found: quoted(other),
                    });
                }
            }
        };
        joints.push(BvhJoint {
            name,
            parent,
            offset: Vector3::zeros(),
            channels: Vec::new(),
            is_end_site: false,
        });
        stack.push(Open {
            joint: joints.len() - 1,
            line: brace_line,
            has_offset: false,
            has_channels: false,
        });
        Ok(())
    }

    /// After `End` at `line`: `Site { OFFSET x y z }`. The name is assigned later.
    fn end_site(
        &mut self,
        line: usize,
        parent: usize,
        joints: &mut Vec<BvhJoint>,
    ) -> Result<(), BvhError> {
        let (l, t) = self.token("Site")?;
        if t != "Site" {
            return Err(self.unexpected(l, "Site (after End)", t));
        }
        let next = self.lex.next();
        if !matches!(next, Some((_, "{"))) {
            return Err(BvhError::MissingBrace {
                file: self.file.to_owned(),
                line: next.map_or(self.lex.line.max(1), |(l, _)| l),
                brace: '{',
                context: format!("after End Site (line {line})"),
                found: quoted(next),
            });
        }
        let mut offset = None;
        loop {
            match self.lex.next() {
                Some((_, "OFFSET")) if offset.is_none() => {
                    let name = joints.get(parent).map_or("", |j| j.name.as_str());
                    offset = Some(self.offset(&format!("OFFSET of the End Site of {name}"))?);
                }
                Some((_, "}")) => break,
                Some((l, t)) => {
                    let expected = if offset.is_none() {
                        "OFFSET or '}' in End Site"
                    } else {
                        "'}' closing End Site"
                    };
                    return Err(self.unexpected(l, expected, t));
                }
                None => {
                    return Err(BvhError::MissingBrace {
                        file: self.file.to_owned(),
                        line: self.lex.line.max(1),
                        brace: '}',
                        context: format!("closing End Site (line {line})"),
                        found: "end of file".to_owned(),
                    });
                }
            }
        }
        joints.push(BvhJoint {
            name: String::new(),
            parent: Some(parent),
            offset: offset.unwrap_or_else(Vector3::zeros),
            channels: Vec::new(),
            is_end_site: true,
        });
        Ok(())
    }

    /// `x y z` of an `OFFSET`; `place` names it in errors.
    fn offset(&mut self, place: &str) -> Result<Vector3<f64>, BvhError> {
        let mut xyz = [0.0; 3];
        for v in &mut xyz {
            let (line, value) = self.finite("OFFSET value")?;
            if value.abs() > MAX_ABS_UNITS {
                return Err(BvhError::NotPhysical {
                    file: self.file.to_owned(),
                    line,
                    place: place.to_owned(),
                    value,
                    why: format!("offsets are at most {MAX_ABS_UNITS:e} file units"),
                });
            }
            *v = value;
        }
        Ok(Vector3::from(xyz))
    }

    fn channels(&mut self) -> Result<Vec<Channel>, BvhError> {
        let (line, tok) = self.token("CHANNELS count")?;
        let Ok(n) = tok.parse::<usize>() else {
            return Err(self.bad_number(line, "CHANNELS count", tok, "a non-negative integer"));
        };
        // `n` comes from the file: do not trust it for allocation.
        let mut channels = Vec::with_capacity(n.min(6));
        for _ in 0..n {
            let (line, tok) = self.token("a channel name")?;
            match Channel::from_name(tok) {
                Some(c) => channels.push(c),
                None => {
                    return Err(self.unexpected(
                        line,
                        "a channel name (Xposition … Zrotation)",
                        tok,
                    ));
                }
            }
        }
        Ok(channels)
    }

    /// Parses from after `MOTION`: the header and every frame line.
    /// `columns` are the channels in file order, with their joint's name. Returns the frame
    /// time, the frames and the line of each frame.
    fn motion(&mut self, columns: &[(&str, Channel)]) -> Result<Motion, BvhError> {
        let declared = self.frame_count()?;
        let frame_time = self.frame_time()?;
        let (frames, lines) = self.frame_lines(declared, columns)?;
        Ok((frame_time, frames, lines))
    }

    /// `Frames: N` (also `Frames:N` and `Frames : N`), N at least 1.
    fn frame_count(&mut self) -> Result<usize, BvhError> {
        let (line, tok) = self.token("Frames:")?;
        let count_tok = match tok {
            "Frames:" => self.token("Frames count")?.1,
            "Frames" => {
                let (l, t) = self.token("':' after Frames")?;
                if t == ":" {
                    self.token("Frames count")?.1
                } else if let Some(rest) = t.strip_prefix(':') {
                    rest
                } else {
                    return Err(self.unexpected(l, "':' after Frames", t));
                }
            }
            t => match t.strip_prefix("Frames:") {
                Some(rest) => rest,
                None => return Err(self.unexpected(line, "Frames:", t)),
            },
        };
        let Ok(declared) = count_tok.parse::<usize>() else {
            return Err(self.bad_number(
                self.lex.line,
                "Frames count",
                count_tok,
                "a non-negative integer",
            ));
        };
        if declared == 0 {
            return Err(BvhError::ZeroFrames {
                file: self.file.to_owned(),
                line: self.lex.line,
            });
        }
        Ok(declared)
    }

    /// `Frame Time: T` (also `Frame Time:T` and `Frame Time : T`), T positive seconds, alone
    /// on the rest of its line.
    fn frame_time(&mut self) -> Result<f64, BvhError> {
        let (line, tok) = self.token("Frame Time:")?;
        if tok != "Frame" {
            return Err(self.unexpected(line, "Frame Time:", tok));
        }
        let (line, tok) = self.token("Time: (after Frame)")?;
        let time_tok = match tok {
            "Time:" => self.token("Frame Time value")?.1,
            "Time" => {
                let (l, t) = self.token("':' after Frame Time")?;
                if t == ":" {
                    self.token("Frame Time value")?.1
                } else if let Some(rest) = t.strip_prefix(':') {
                    rest
                } else {
                    return Err(self.unexpected(l, "':' after Frame Time", t));
                }
            }
            t => match t.strip_prefix("Time:") {
                Some(rest) => rest,
                None => return Err(self.unexpected(line, "Time: (after Frame)", t)),
            },
        };
        let time_line = self.lex.line;
        let Ok(frame_time) = time_tok.parse::<f64>() else {
            return Err(self.bad_number(time_line, "Frame Time", time_tok, "a number of seconds"));
        };
        if !(frame_time.is_finite() && frame_time > 0.0) {
            return Err(BvhError::BadFrameTime {
                file: self.file.to_owned(),
                line: time_line,
                value: frame_time,
            });
        }
        if let Some(t) = self.lex.next_on_line() {
            return Err(self.unexpected(time_line, "end of line after Frame Time", t));
        }
        Ok(frame_time)
    }

    /// One frame per non-blank line to the end: exactly `declared` frames of `channel_count`
    /// values each.
    fn frame_lines(
        &mut self,
        declared: usize,
        columns: &[(&str, Channel)],
    ) -> Result<(Vec<Vec<f64>>, Vec<usize>), BvhError> {
        // `declared` comes from the file: cap the reservation.
        let mut frames: Vec<Vec<f64>> = Vec::with_capacity(declared.min(1 << 16));
        let mut lines: Vec<usize> = Vec::with_capacity(declared.min(1 << 16));
        while let Some((line, text)) = self.lex.next_line() {
            if text.split_ascii_whitespace().next().is_none() {
                continue;
            }
            let frame = frames.len();
            if frame == declared {
                return Err(BvhError::MoreFramesThanDeclared {
                    file: self.file.to_owned(),
                    line,
                    declared,
                });
            }
            frames.push(self.frame_values(line, frame, text, columns)?);
            lines.push(line);
        }
        if frames.len() < declared {
            return Err(BvhError::FewerFramesThanDeclared {
                file: self.file.to_owned(),
                line: self.lex.line.max(1),
                declared,
                found: frames.len(),
            });
        }
        Ok((frames, lines))
    }

    /// The finite, physical values of frame `frame` (one per entry of `columns`), the text of
    /// line `line`.
    fn frame_values(
        &self,
        line: usize,
        frame: usize,
        text: &str,
        columns: &[(&str, Channel)],
    ) -> Result<Vec<f64>, BvhError> {
        let channel_count = columns.len();
        let mut tokens = text.split_ascii_whitespace();
        let mut values = Vec::with_capacity(channel_count);
        for (column, tok) in tokens.by_ref().enumerate() {
            if column == channel_count {
                return Err(BvhError::WrongValueCount {
                    file: self.file.to_owned(),
                    line,
                    frame,
                    expected: channel_count,
                    found: channel_count + 1 + tokens.count(),
                });
            }
            match tok.parse::<f64>() {
                Ok(v) if v.is_finite() => {
                    if let Some(&(joint, channel)) = columns.get(column) {
                        let (bound, unit) = if channel.is_position() {
                            (MAX_ABS_UNITS, "file units")
                        } else {
                            (MAX_ABS_DEG, "degrees")
                        };
                        if v.abs() > bound {
                            return Err(BvhError::NotPhysical {
                                file: self.file.to_owned(),
                                line,
                                place: format!(
                                    "frame {frame}, column {column} ({joint} {channel})"
                                ),
                                value: v,
                                why: format!("{channel} values are at most {bound:e} {unit}"),
                            });
                        }
                    }
                    values.push(v);
                }
                Ok(_) => {
                    return Err(BvhError::NonFinite {
                        file: self.file.to_owned(),
                        line,
                        frame,
                        column,
                        token: tok.to_owned(),
                    });
                }
                Err(_) => {
                    return Err(BvhError::BadValue {
                        file: self.file.to_owned(),
                        line,
                        frame,
                        column,
                        token: tok.to_owned(),
                    });
                }
            }
        }
        if values.len() != channel_count {
            return Err(BvhError::WrongValueCount {
                file: self.file.to_owned(),
                line,
                frame,
                expected: channel_count,
                found: values.len(),
            });
        }
        Ok(values)
    }
}

/// Names every End Site `<parent name>_End`, adding `2`, `3`, … if the name is already taken.
fn assign_end_site_names(joints: &mut [BvhJoint]) {
    let mut taken: HashSet<String> = joints
        .iter()
        .filter(|j| !j.is_end_site)
        .map(|j| j.name.clone())
        .collect();
    for i in 0..joints.len() {
        let Some(joint) = joints.get(i) else { break };
        if !joint.is_end_site {
            continue;
        }
        let parent_name = joint
            .parent
            .and_then(|p| joints.get(p))
            .map_or("", |p| p.name.as_str());
        let base = format!("{parent_name}_End");
        let mut name = base.clone();
        let mut k = 2;
        while taken.contains(&name) {
            name = format!("{base}{k}");
            k += 1;
        }
        taken.insert(name.clone());
        if let Some(joint) = joints.get_mut(i) {
            joint.name = name;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;
    use proptest::prelude::*;

    const CHAIN: &str = "HIERARCHY
ROOT Root
{
  OFFSET 5 5 5
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Mid
  {
    OFFSET 1 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 1 0 0
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.5
0 0 0 90 0 0 0 0 0
10 20 30 0 0 0 0 0 90
0 0 0 0 0 0 0 0 0
";

    fn ok(text: &str) -> Bvh {
        match parse(text, "test.bvh") {
            Ok(b) => b,
            Err(e) => panic!("unexpected error: {e}"),
        }
    }

    fn err(text: &str) -> BvhError {
        match parse(text, "test.bvh") {
            Ok(_) => panic!("parsed, expected an error"),
            Err(e) => e,
        }
    }

    fn close(a: Point3<f64>, b: Point3<f64>) -> bool {
        (a - b).norm() < 1e-9
    }

    fn positions(bvh: &Bvh, frame: usize) -> Vec<Point3<f64>> {
        bvh.world_transforms(frame)
            .into_iter()
            .map(|(p, _)| p)
            .collect()
    }

    /// A one-bone file: root with the given rotation channels and values, child at (0, 1, 0).
    fn one_bone(channels: &str, values: &str) -> Bvh {
        ok(&format!(
            "HIERARCHY\nROOT A\n{{\n OFFSET 0 0 0\n CHANNELS 3 {channels}\n End Site\n {{\n  OFFSET 0 1 0\n }}\n}}\nMOTION\nFrames: 1\nFrame Time: 0.1\n{values}\n"
        ))
    }

    #[test]
    fn parses_chain_structure() {
        let b = ok(CHAIN);
        assert_eq!(b.source, "test.bvh");
        assert_eq!(b.joint_names(), ["Root", "Mid", "Mid_End"]);
        assert_eq!(b.joints[0].parent, None);
        assert_eq!(b.joints[1].parent, Some(0));
        assert_eq!(b.joints[2].parent, Some(1));
        assert!(b.joints[2].is_end_site && b.joints[2].channels.is_empty());
        assert_eq!(
            b.joints[1].channels,
            [Channel::Zrotation, Channel::Xrotation, Channel::Yrotation]
        );
        assert_eq!(b.joints[0].offset, Vector3::new(5.0, 5.0, 5.0));
        assert_eq!(b.channel_count(), 9);
        assert_eq!(b.channel_starts(), [0, 6, 9]);
        assert_eq!(b.frame_count(), 3);
        assert!((b.fps() - 2.0).abs() < 1e-12);
        assert_eq!(
            b.frames[1],
            [10.0, 20.0, 30.0, 0.0, 0.0, 0.0, 0.0, 0.0, 90.0]
        );
    }

    #[test]
    fn fk_rotation_about_z_moves_child() {
        let b = ok(CHAIN);
        // Frame 0: root at (0,0,0) (position channels replace the offset 5 5 5), rotated 90° about Z.
        let p = positions(&b, 0);
        assert!(close(p[0], Point3::origin()), "{:?}", p[0]);
        assert!(close(p[1], Point3::new(0.0, 1.0, 0.0)), "{:?}", p[1]);
        assert!(close(p[2], Point3::new(0.0, 2.0, 0.0)), "{:?}", p[2]);
        // Frame 1: root at (10,20,30), Mid rotated 90° about Y: its +X child goes to −Z.
        let p = positions(&b, 1);
        assert!(close(p[0], Point3::new(10.0, 20.0, 30.0)));
        assert!(close(p[1], Point3::new(11.0, 20.0, 30.0)));
        assert!(close(p[2], Point3::new(11.0, 20.0, 29.0)), "{:?}", p[2]);
        // Orientations compose: the end site inherits Mid's world rotation.
        let (_, q) = b.world_transforms(1)[2];
        assert!((q * Vector3::x() - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-9);
    }

    #[test]
    fn rest_positions_use_offsets_only() {
        let b = ok(CHAIN);
        let rest = b.rest_positions();
        assert!(close(rest[0], Point3::new(5.0, 5.0, 5.0)));
        assert!(close(rest[1], Point3::new(6.0, 5.0, 5.0)));
        assert!(close(rest[2], Point3::new(7.0, 5.0, 5.0)));
        assert_eq!(b.rest_extent(), Vector3::new(2.0, 0.0, 0.0));
        // 2 units across: read as metres.
        assert_eq!(b.guess_metres_per_unit(), Some(1.0));
    }

    #[test]
    fn rotation_order_is_intrinsic_as_listed() {
        // Z then X: Rz(90)·Rx(90)·(0,1,0) = Rz(90)·(0,0,1) = (0,0,1).
        let zxy = one_bone("Zrotation Xrotation Yrotation", "90 90 0");
        assert!(close(positions(&zxy, 0)[1], Point3::new(0.0, 0.0, 1.0)));
        // X then Z: Rx(90)·Rz(90)·(0,1,0) = Rx(90)·(−1,0,0) = (−1,0,0).
        let xyz = one_bone("Xrotation Yrotation Zrotation", "90 0 90");
        assert!(close(positions(&xyz, 0)[1], Point3::new(-1.0, 0.0, 0.0)));
    }

    #[test]
    fn rotation_matches_matrix_product_for_any_order() {
        let (a, b, c) = (23.0_f64, -71.0_f64, 142.0_f64);
        let rot = |axis: char, deg: f64| {
            let unit = match axis {
                'X' => Vector3::x_axis(),
                'Y' => Vector3::y_axis(),
                _ => Vector3::z_axis(),
            };
            Rotation3::from_axis_angle(&unit, deg.to_radians())
        };
        for order in ["XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"] {
            let axes: Vec<char> = order.chars().collect();
            let names: Vec<String> = axes.iter().map(|c| format!("{c}rotation")).collect();
            let bvh = one_bone(&names.join(" "), &format!("{a} {b} {c}"));
            let expected = rot(axes[0], a) * rot(axes[1], b) * rot(axes[2], c);
            let (_, q) = bvh.world_transforms(0)[0];
            let diff = (q.to_rotation_matrix().matrix() - expected.matrix()).norm();
            assert!(diff < 1e-12, "{order}: {diff}");
        }
    }

    #[test]
    fn six_channels_replace_offset() {
        // Bandai-Namco style: every joint has 6 channels whose positions equal the offset.
        let text = "HIERARCHY\nROOT R\n{\n OFFSET 0 0 0\n CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n JOINT B\n {\n  OFFSET 2 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  End Site\n  {\n   OFFSET 0 0 0\n  }\n }\n}\nMOTION\nFrames: 2\nFrame Time: 0.0333333\n0 0 0 0 0 0 2 0 0 0 0 0\n1 1 1 30 40 50 2 0 0 10 0 0\n";
        let b = ok(text);
        for f in 0..2 {
            let p = positions(&b, f);
            assert!(
                ((p[1] - p[0]).norm() - 2.0).abs() < 1e-12,
                "frame {f}: bone length doubled?"
            );
        }
        assert!(close(positions(&b, 0)[1], Point3::new(2.0, 0.0, 0.0)));
        // A single position channel replaces only its own component.
        let text = "HIERARCHY\nROOT R\n{\n OFFSET 1 2 3\n CHANNELS 1 Yposition\n}\nMOTION\nFrames: 1\nFrame Time: 1\n7\n";
        assert!(close(
            positions(&ok(text), 0)[0],
            Point3::new(1.0, 7.0, 3.0)
        ));
    }

    #[test]
    fn end_site_names_are_unique() {
        let text = "HIERARCHY\nROOT A\n{\n OFFSET 0 0 0\n CHANNELS 3 Xrotation Yrotation Zrotation\n End Site\n {\n  OFFSET 0 1 0\n }\n End Site\n {\n  OFFSET 0 2 0\n }\n JOINT A_End\n {\n  OFFSET 1 0 0\n  End Site\n  {\n   OFFSET 1 0 0\n  }\n }\n}\nMOTION\nFrames: 1\nFrame Time: 1\n0 0 0\n";
        let b = ok(text);
        assert_eq!(
            b.joint_names(),
            ["A", "A_End2", "A_End3", "A_End", "A_End_End"]
        );
        assert_eq!(b.joints.iter().filter(|j| j.is_end_site).count(), 3);
    }

    #[test]
    fn colon_names_tabs_crlf_and_trailing_spaces() {
        let text = "\u{feff}HIERARCHY\r\nROOT mixamorig:Hips\r\n{\r\n\tOFFSET\t0.0\t0.0\t0.0 \r\n\tCHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation \r\n\tJOINT mixamorig:Spine {\r\n\t\tOFFSET 0 1e1 -1.5E0\r\n\t\tCHANNELS 3 zrotation YROTATION Xrotation\r\n\t\tJOINT mixamorig:HeadTop_End\r\n\t\t{\r\n\t\t\tOFFSET 0 1 0\r\n\t\t\tCHANNELS 3 Zrotation Yrotation Xrotation\r\n\t\t\tEnd Site\r\n\t\t\t{\r\n\t\t\t\tOFFSET 0 0 0\r\n\t\t\t}\r\n\t\t}\r\n\t}\r\n}\r\nMOTION\r\nFrames:\t2\r\nFrame Time:\t0.0333333 \r\n\t1 2 3 0 0 0 0 0 0 0 0 0 \r\n\r\n1 2 3 0 0 0 0 0 0 0 0 0\r\n\r\n";
        let b = ok(text);
        assert_eq!(
            b.joint_names(),
            [
                "mixamorig:Hips",
                "mixamorig:Spine",
                "mixamorig:HeadTop_End",
                "mixamorig:HeadTop_End_End"
            ]
        );
        assert_eq!(b.joints[1].offset, Vector3::new(0.0, 10.0, -1.5));
        assert_eq!(b.joints[2].channels.len(), 3);
        assert_eq!(b.frame_count(), 2);
        assert!((b.frame_time_secs - 0.033_333_3).abs() < 1e-12);
        assert_eq!(b.joint_index("mixamorig:HeadTop_End"), Some(2));
    }

    #[test]
    fn joint_names_with_spaces_and_several_roots() {
        let text = "HIERARCHY\nROOT Left Arm\n{\n OFFSET 0 0 0\n CHANNELS 1 Xrotation\n}\nROOT Prop\n{\n OFFSET 1 0 0\n CHANNELS 3 Xposition Yposition Zposition\n}\nMOTION\nFrames: 1\nFrame Time: 1\n0 4 5 6\n";
        let b = ok(text);
        assert_eq!(b.joint_names(), ["Left Arm", "Prop"]);
        assert_eq!(b.joints[1].parent, None);
        assert!(close(positions(&b, 0)[1], Point3::new(4.0, 5.0, 6.0)));
    }

    #[test]
    fn pose_sequence_is_metres_autoact_frame() {
        let b = ok(CHAIN);
        let seq = b.to_pose_sequence(0.01, SourceAxes::YUp);
        assert_eq!(seq.source, "test.bvh");
        assert_eq!(seq.joint_names, ["Root", "Mid", "Mid_End"]);
        assert_eq!(seq.frames.len(), 3);
        assert_eq!(seq.frames[0].stamp_nanos, 0);
        assert_eq!(seq.frames[1].stamp_nanos, 500_000_000);
        assert_eq!(seq.frames[2].stamp_nanos, 1_000_000_000);
        // Frame 0: Mid_End at BVH (0, 2, 0) = 2 units up → 0.02 m along autoact +Z.
        assert!(close(
            seq.frames[0].positions_m[2],
            Point3::new(0.0, 0.0, 0.02)
        ));
        // Frame 1: root at BVH (10, 20, 30) → autoact (−0.1, 0.3, 0.2).
        assert!(close(
            seq.frames[1].positions_m[0],
            Point3::new(-0.1, 0.3, 0.2)
        ));
        assert!(
            seq.frames
                .iter()
                .all(|f| f.confidence.iter().all(|&c| c == 1.0))
        );
        // Orientations convert by change of basis: a BVH rotation about Y (up) is about autoact Z.
        let q = b.world_orientations_autoact(1, SourceAxes::YUp)[1];
        let axis = q
            .axis()
            .map_or_else(Vector3::zeros, nalgebra::Unit::into_inner);
        assert!(
            (axis - Vector3::z()).norm() < 1e-9 && (q.angle() - 90_f64.to_radians()).abs() < 1e-9
        );
    }

    // --- errors -------------------------------------------------------------------------------

    #[test]
    fn empty_file_is_an_error() {
        assert!(matches!(err(""), BvhError::Empty { .. }));
        assert!(matches!(err(" \n\t\r\n\n"), BvhError::Empty { .. }));
    }

    #[test]
    fn truncated_motion_line_names_line_and_counts() {
        let text = CHAIN.replace("10 20 30 0 0 0 0 0 90\n", "10 20 30 0 0\n");
        match err(&text) {
            BvhError::WrongValueCount {
                file,
                line,
                frame,
                expected,
                found,
            } => {
                assert_eq!(
                    (file.as_str(), line, frame, expected, found),
                    ("test.bvh", 20, 1, 9, 5)
                );
            }
            e => panic!("wrong error {e:?}"),
        }
        // A file cut in the middle of its last line.
        let cut = CHAIN.trim_end().strip_suffix(" 0 0").unwrap_or_default();
        assert!(matches!(
            err(cut),
            BvhError::WrongValueCount {
                line: 21,
                frame: 2,
                expected: 9,
                found: 7,
                ..
            }
        ));
    }

    #[test]
    fn too_many_values_is_wrong_count() {
        let text = CHAIN.replace("10 20 30 0 0 0 0 0 90\n", "10 20 30 0 0 0 0 0 90 1 2\n");
        let e = err(&text);
        assert!(
            matches!(
                e,
                BvhError::WrongValueCount {
                    line: 20,
                    frame: 1,
                    expected: 9,
                    found: 11,
                    ..
                }
            ),
            "{e:?}"
        );
        let msg = e.to_string();
        assert!(
            msg.starts_with("test.bvh:20: frame 1 has 11 values, expected 9"),
            "{msg}"
        );
    }

    #[test]
    fn nan_and_inf_are_errors() {
        for bad in ["NaN", "nan", "inf", "-infinity", "1e999"] {
            let text = CHAIN.replace(
                "10 20 30 0 0 0 0 0 90\n",
                &format!("10 20 {bad} 0 0 0 0 0 90\n"),
            );
            let e = err(&text);
            assert!(
                matches!(
                    e,
                    BvhError::NonFinite {
                        line: 20,
                        frame: 1,
                        column: 2,
                        ..
                    }
                ),
                "{bad}: {e:?}"
            );
        }
        let text = CHAIN.replace("OFFSET 1 0 0\n    CHANNELS", "OFFSET 1 nan 0\n    CHANNELS");
        assert!(matches!(
            err(&text),
            BvhError::BadNumber {
                line: 8,
                what: "OFFSET value",
                ..
            }
        ));
    }

    #[test]
    fn bad_value_is_an_error() {
        let text = CHAIN.replace("10 20 30 0 0 0 0 0 90\n", "10 20 30 0 0 0 0 0 9O\n");
        assert!(matches!(
            err(&text),
            BvhError::BadValue {
                line: 20,
                frame: 1,
                column: 8,
                ..
            }
        ));
    }

    #[test]
    fn missing_closing_brace_is_an_error() {
        // Drop the brace that closes Mid: MOTION arrives while Root is still open.
        let text = CHAIN.replace("    }\n  }\n}\nMOTION", "    }\n  }\nMOTION");
        let e = err(&text);
        match &e {
            BvhError::MissingBrace {
                line,
                brace,
                context,
                ..
            } => {
                assert_eq!((*line, *brace), (15, '}'));
                assert!(context.contains("'Root'"), "{context}");
            }
            e => panic!("wrong error {e:?}"),
        }
        assert!(
            e.to_string()
                .starts_with("test.bvh:15: missing '}' closing joint 'Root'"),
            "{e}"
        );
        // Missing at end of file.
        let text = "HIERARCHY\nROOT A\n{\n OFFSET 0 0 0\n";
        assert!(matches!(
            err(text),
            BvhError::MissingBrace {
                line: 4,
                brace: '}',
                ..
            }
        ));
    }

    #[test]
    fn missing_opening_brace_is_an_error() {
        let text = CHAIN.replace("JOINT Mid\n  {\n", "JOINT Mid\n");
        let e = err(&text);
        assert!(
            matches!(
                e,
                BvhError::MissingBrace {
                    line: 7,
                    brace: '{',
                    ..
                }
            ),
            "{e:?}"
        );
        assert!(e.to_string().contains("after joint 'Mid'"), "{e}");
    }

    #[test]
    fn fewer_frames_than_declared_is_an_error() {
        let text = CHAIN.replace("Frames: 3", "Frames: 5");
        let e = err(&text);
        assert!(
            matches!(
                e,
                BvhError::FewerFramesThanDeclared {
                    line: 21,
                    declared: 5,
                    found: 3,
                    ..
                }
            ),
            "{e:?}"
        );
        assert_eq!(
            e.to_string(),
            "test.bvh:21: file ends after 3 frame lines, but Frames: declares 5"
        );
    }

    #[test]
    fn more_frames_than_declared_is_an_error() {
        let text = CHAIN.replace("Frames: 3", "Frames: 2");
        assert!(matches!(
            err(&text),
            BvhError::MoreFramesThanDeclared {
                line: 21,
                declared: 2,
                ..
            }
        ));
    }

    #[test]
    fn zero_frames_and_bad_frame_time_are_errors() {
        assert!(matches!(
            err(&CHAIN.replace("Frames: 3", "Frames: 0")),
            BvhError::ZeroFrames { line: 17, .. }
        ));
        assert!(matches!(
            err(&CHAIN.replace("Frames: 3", "Frames: -3")),
            BvhError::BadNumber { line: 17, .. }
        ));
        for bad in ["0", "-0.1", "nan", "inf"] {
            let e = err(&CHAIN.replace("Frame Time: 0.5", &format!("Frame Time: {bad}")));
            assert!(
                matches!(e, BvhError::BadFrameTime { line: 18, .. }),
                "{bad}: {e:?}"
            );
        }
        assert!(matches!(
            err(&CHAIN.replace("Frame Time: 0.5", "Frame Time: fast")),
            BvhError::BadNumber { line: 18, .. }
        ));
    }

    #[test]
    fn unexpected_tokens_are_errors() {
        assert!(matches!(
            err("HIERARCHY\nJOINT A\n"),
            BvhError::UnexpectedToken { line: 2, .. }
        ));
        assert!(matches!(
            err("\n\nMOTION\n"),
            BvhError::UnexpectedToken {
                line: 3,
                expected: "HIERARCHY",
                ..
            }
        ));
        let e = err(&CHAIN.replace(
            "Zrotation Xrotation Yrotation\n    End",
            "Zrotation Xrotation Wrotation\n    End",
        ));
        assert!(
            matches!(e, BvhError::UnexpectedToken { line: 9, .. }),
            "{e:?}"
        );
        assert!(matches!(
            err(&CHAIN.replace(
                "OFFSET 1 0 0\n    CHANNELS",
                "OFFSET 1 0 0\n    OFFSET 1 0 0\n    CHANNELS"
            )),
            BvhError::UnexpectedToken { line: 9, .. }
        ));
        assert!(matches!(
            err("HIERARCHY\nROOT A\n{\n OFFSET 0 0"),
            BvhError::UnexpectedEof { line: 4, .. }
        ));
        assert!(matches!(
            err("HIERARCHY\nROOT A\n{\n OFFSET 0 0 0\n}\nMOTION\nFrames: 1\nFrame Time: 1\n"),
            BvhError::NoChannels { line: 6, .. }
        ));
        assert!(matches!(
            err(CHAIN.split("Frames").next().unwrap_or_default()),
            BvhError::UnexpectedEof { .. }
        ));
    }

    #[test]
    fn messages_are_lowercase_and_name_file_and_line() {
        let cases = [
            CHAIN.replace("Frames: 3", "Frames: 5"),
            CHAIN.replace("10 20 30 0 0 0 0 0 90\n", "10 20\n"),
            CHAIN.replace("OFFSET 1 0 0\n    CHANNELS", "OFFSET x 0 0\n    CHANNELS"),
            CHAIN.replace("Frame Time: 0.5", "Frame Time: 0"),
            CHAIN.replace("Frames: 3", "Frames: 0"),
            CHAIN.replace("Frames: 3", "Frames: 2"),
            CHAIN.replace("10 20 30 0 0 0 0 0 90\n", "10 20 nan 0 0 0 0 0 90\n"),
            CHAIN.replace("JOINT Mid\n  {\n", "JOINT Mid\n"),
            "HIERARCHY\nROOT A\n{\n OFFSET 0 0".to_owned(),
            "HIERARCHY\nROOT A\n{\n OFFSET 0 0 0\n}\nMOTION\nFrames: 1\nFrame Time: 1\n".to_owned(),
            String::new(),
        ];
        for text in cases {
            let msg = err(&text).to_string();
            let rest = msg
                .strip_prefix("test.bvh:")
                .unwrap_or_else(|| panic!("{msg}"));
            let (line, text) = rest.split_once(": ").unwrap_or_else(|| panic!("{msg}"));
            assert!(line.parse::<usize>().is_ok(), "{msg}");
            assert!(text.starts_with(|c: char| !c.is_ascii_uppercase()), "{msg}");
        }
    }

    #[test]
    fn read_missing_file_is_io_error() {
        let e = read(Path::new("/nonexistent/dir/x.bvh"));
        assert!(
            matches!(e, Err(BvhError::Io { ref file, .. }) if file == "/nonexistent/dir/x.bvh")
        );
    }

    #[test]
    fn every_truncation_of_a_valid_file_is_handled() {
        for cut in 0..CHAIN.len() {
            let text = CHAIN.get(..cut).unwrap_or_default();
            if let Ok(b) = parse(text, "cut") {
                // Only cuts inside the final line's trailing part can still parse.
                assert!(cut > CHAIN.len() - 4, "cut at {cut} parsed");
                assert_eq!(b.frame_count(), 3);
            }
        }
    }

    fn exercise(text: &str) {
        if let Ok(b) = parse(text, "fuzz") {
            assert!(b.frames.iter().all(|f| f.len() == b.channel_count()));
            let _ = b.world_transforms(0);
            let _ = b.rest_positions();
            let _ = b.guess_metres_per_unit();
            let _ = b.to_pose_sequence(0.01, SourceAxes::YUp);
        }
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
            exercise(&String::from_utf8_lossy(&bytes));
        }

        #[test]
        fn arbitrary_tokens_never_panic(tokens in proptest::collection::vec(
            prop_oneof![
                Just("HIERARCHY"), Just("ROOT"), Just("JOINT"), Just("End"), Just("Site"),
                Just("{"), Just("}"), Just("OFFSET"), Just("CHANNELS"), Just("Xrotation"),
                Just("Yposition"), Just("MOTION"), Just("Frames:"), Just("Frame"), Just("Time:"),
                Just("0"), Just("1"), Just("3"), Just("-2.5"), Just("nan"), Just("\n"), Just("A"),
            ],
            0..80,
        )) {
            exercise(&tokens.join(" "));
        }

        #[test]
        fn mutated_valid_file_never_panics(
            cut in 0..CHAIN.len(),
            edits in proptest::collection::vec((0..CHAIN.len(), any::<u8>()), 0..4),
        ) {
            let mut bytes = CHAIN.as_bytes().to_vec();
            for (at, byte) in edits {
                if let Some(b) = bytes.get_mut(at) {
                    *b = byte;
                }
            }
            bytes.truncate(cut);
            exercise(&String::from_utf8_lossy(&bytes));
        }
    }

    #[test]
    fn finite_but_absurd_values_are_refused_with_line_and_channel() {
        let motion = |values: &str| CHAIN.replace("10 20 30 0 0 0 0 0 90", values);
        let e = err(&motion("10 20 -1e308 0 0 0 0 0 90")).to_string();
        assert_eq!(
            e,
            "test.bvh:20: frame 1, column 2 (Root Zposition): value -1e308 is not physical (Zposition values are at most 1e7 file units)"
        );
        let e = err(&motion("10 20 30 0 0 0 0 0 1e300")).to_string();
        assert_eq!(
            e,
            "test.bvh:20: frame 1, column 8 (Mid Yrotation): value 1e300 is not physical (Yrotation values are at most 1e6 degrees)"
        );
        let e = err(&CHAIN.replace(
            "OFFSET 1 0 0\n    CHANNELS",
            "OFFSET 1 -1e308 0\n    CHANNELS",
        ))
        .to_string();
        assert_eq!(
            e,
            "test.bvh:8: OFFSET of Mid: value -1e308 is not physical (offsets are at most 1e7 file units)"
        );
        let e = err(&CHAIN.replace("OFFSET 1 0 0\n    }", "OFFSET 1e9 0 0\n    }")).to_string();
        assert!(
            e.starts_with("test.bvh:12: OFFSET of the End Site of Mid: value 1e9"),
            "{e}"
        );
        // Large but plausible values pass: 9,000 km in file units, a thousand turns.
        let b = ok(&motion("9e6 20 30 0 0 360000 0 0 90"));
        assert_eq!(b.frame_lines, [19, 20, 21]);
        assert!(b.check_translations(0.001, MAX_TRANSLATION_M).is_ok());
        let e = b
            .check_translations(0.01, MAX_TRANSLATION_M)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "test.bvh:20: frame 1, column 0 (Root Xposition): value 9e6 is not physical (9.000e4 m at 0.01 m per unit; translations are at most 1e4 m)"
        );
    }
}
