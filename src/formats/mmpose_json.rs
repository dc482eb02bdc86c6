//! Reader for the MMPose-style JSON that 3D pose lifters write (e.g. whole-body lifters with
//! 133 COCO-WholeBody keypoints).
//!
//! # Format
//!
//! A top-level list of frames (or an object whose `"instance_info"` is that list, as MMPose's
//! demo scripts save it):
//!
//! ```json
//! [ {"frame_id": 0,
//!    "instances": [ {"keypoints": [[x, y, z], ...],
//!                    "keypoint_scores": [s, ...],
//!                    "track_id": 3} ]},
//!   ... ]
//! ```
//!
//! * `frame_id`: non-negative integer, strictly increasing through the file. The frame is
//!   stamped `stamp_nanos_at(frame_id, fps)`, so gaps in the ids are gaps in time.
//! * `instances`: a list of people, or a single object (the GTAutoAct reference lifter writes
//!   `"instances": {"keypoints": [...]}`); `null` or `[]` means nobody in that frame.
//! * `keypoints`: exactly as many `[x, y, z]` entries as [`JsonOptions::joint_names`]. An entry
//!   that is `null`, or has a `null`/`NaN`/`Infinity` coordinate, is a joint that was not seen:
//!   NaN position, confidence 0. (Python's `json` writes bare `NaN`/`Infinity`, which is not
//!   JSON; this reader reads those tokens as `null`.)
//! * `keypoint_scores` (optional): one number per keypoint, clamped to [0, 1]; `null` is 0.
//!   Without scores every seen joint has confidence 1.
//! * `track_id` (optional): non-negative integer; instances without one are tracked by their
//!   index in the frame's instance list.
//!
//! # Units and axes
//!
//! The file carries neither, so the caller states them in [`JsonOptions`]: coordinates are
//! multiplied by [`JsonOptions::metres_per_unit`] and converted once from
//! [`JsonOptions::axes`] to the autoact frame through [`SourceAxes::point_to_autoact`].
//!
//! # Output
//!
//! One [`PoseSequence`] per track id, in ascending track id order; a track has frames only where
//! its instance appears (nothing is invented).
//!
//! # Errors
//!
//! [`parse`] and [`read`] never panic; every problem is a [`JsonError`] naming the file and the
//! line and column (JSON syntax), or the frame (index in the list and `frame_id`), instance and
//! field: bad options, a wrong type, a missing field, a keypoint or score count that differs
//! from the joint names, non-increasing `frame_id`s (naming both ids), or the same track twice
//! in one frame.

use std::collections::BTreeMap;
use std::path::Path;

use nalgebra::Point3;
use serde_json::Value;
use thiserror::Error;

use crate::skeleton::frames::SourceAxes;
use crate::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};

/// How to interpret a file: the rate, units, axes and keypoint layout it does not state itself.
#[derive(Debug, Clone, PartialEq)]
pub struct JsonOptions {
    /// Frames per second of `frame_id` (positive).
    pub fps: f64,
    /// Metres per file unit (1.0 for metres, 0.001 for millimetres; positive).
    pub metres_per_unit: f64,
    /// Axis convention of the coordinates.
    pub axes: SourceAxes,
    /// Names of the keypoints, in file order (from the chosen keypoint layout).
    pub joint_names: Vec<String>,
}

/// Everything that can go wrong reading MMPose-style JSON.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum JsonError {
    /// The file could not be read.
    #[error("{file}: cannot read the file: {error}")]
    Io {
        /// The file.
        file: String,
        /// The underlying error.
        #[source]
        error: std::io::Error,
    },
    /// The text is not valid JSON (or not UTF-8).
    #[error("{file}:{line}:{column}: invalid json: {message}")]
    Syntax {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// 1-based column (approximate on a line holding bare `NaN`/`Infinity` tokens).
        column: usize,
        /// The parser's message.
        message: String,
    },
    /// The caller's options cannot be used.
    #[error("{file}: invalid option {field}: {message}")]
    InvalidOptions {
        /// The file.
        file: String,
        /// The option's name.
        field: &'static str,
        /// What is wrong with it.
        message: String,
    },
    /// The top level is neither a list of frames nor an object with `instance_info`.
    #[error("{file}: top level: expected a list of frames, found {found}")]
    NotAList {
        /// The file.
        file: String,
        /// The JSON type found.
        found: &'static str,
    },
    /// A field has the wrong type or an impossible value.
    #[error("{file}: frame {frame}: field {field}: expected {expected}, found {found}")]
    Field {
        /// The file.
        file: String,
        /// 0-based index of the frame in the list.
        frame: usize,
        /// Path of the field inside the frame, e.g. `instances[1].keypoints[4][2]`.
        field: String,
        /// What was expected.
        expected: &'static str,
        /// What was found (type or value).
        found: String,
    },
    /// A required field is missing.
    #[error("{file}: frame {frame}: missing field {field}")]
    MissingField {
        /// The file.
        file: String,
        /// 0-based index of the frame in the list.
        frame: usize,
        /// Path of the missing field inside the frame.
        field: String,
    },
    /// An instance has a different number of keypoints (or scores) than there are joint names.
    #[error(
        "{file}: frame {frame} (frame_id {frame_id}), instance {instance}: {field} has {found} entries, expected {expected}"
    )]
    KeypointCount {
        /// The file.
        file: String,
        /// 0-based index of the frame in the list.
        frame: usize,
        /// The frame's `frame_id`.
        frame_id: u64,
        /// 0-based index of the instance in the frame.
        instance: usize,
        /// `keypoints` or `keypoint_scores`.
        field: &'static str,
        /// Entries expected (the number of joint names).
        expected: usize,
        /// Entries found.
        found: usize,
    },
    /// `frame_id`s do not strictly increase.
    #[error(
        "{file}: frame {frame}: frame_id {frame_id} does not follow frame_id {previous} (ids must strictly increase)"
    )]
    FrameOrder {
        /// The file.
        file: String,
        /// 0-based index of the offending frame in the list.
        frame: usize,
        /// The previous frame's id.
        previous: u64,
        /// This frame's id.
        frame_id: u64,
    },
    /// Two instances of one frame have the same track id.
    #[error(
        "{file}: frame {frame} (frame_id {frame_id}), instance {instance}: track_id {track_id} appears twice"
    )]
    DuplicateTrack {
        /// The file.
        file: String,
        /// 0-based index of the frame in the list.
        frame: usize,
        /// The frame's `frame_id`.
        frame_id: u64,
        /// 0-based index of the second instance with that id.
        instance: usize,
        /// The repeated track id.
        track_id: u64,
    },
}

/// Read a JSON file into one sequence per track (the whole file in memory; [`for_each_frame`]
/// reads it frame by frame).
///
/// # Errors
///
/// [`JsonError::Io`] if the file cannot be read, otherwise as [`parse`].
pub fn read(path: impl AsRef<Path>, options: &JsonOptions) -> Result<Vec<PoseSequence>, JsonError> {
    let path = path.as_ref();
    let file = path.display().to_string();
    let mut tracks = Tracks::default();
    for_each_frame(path, options, |people| {
        tracks.add(&file, options, people);
        Ok(())
    })?;
    Ok(tracks.into_sequences())
}

/// Parse JSON text; `source` names it in errors and in the result.
///
/// # Errors
///
/// Any [`JsonError`] but `Io`; see the module docs.
pub fn parse(
    text: &str,
    source: &str,
    options: &JsonOptions,
) -> Result<Vec<PoseSequence>, JsonError> {
    let mut tracks = Tracks::default();
    stream(text.as_bytes(), source, options, &mut |people| {
        tracks.add(source, options, people);
        Ok(())
    })?;
    Ok(tracks.into_sequences())
}

/// Reads the file at `path` frame by frame, in file order, without holding more than one
/// frame: `on_frame` gets each frame's people as (track id, pose) in their order in the frame
/// (an empty list for a frame with nobody). An error `on_frame` returns stops the reading and
/// is returned.
///
/// # Errors
///
/// [`JsonError::Io`] if the file cannot be read, otherwise as [`parse`], or `on_frame`'s.
pub fn for_each_frame<E: From<JsonError>>(
    path: &Path,
    options: &JsonOptions,
    mut on_frame: impl FnMut(Vec<(u64, PoseFrame)>) -> Result<(), E>,
) -> Result<(), E> {
    let file = path.display().to_string();
    let reader = std::fs::File::open(path).map_err(|error| JsonError::Io {
        file: file.clone(),
        error,
    })?;
    stream(
        std::io::BufReader::with_capacity(1 << 16, reader),
        &file,
        options,
        &mut on_frame,
    )
}

/// Sequences per track, in ascending track id order, built frame by frame.
#[derive(Default)]
struct Tracks(BTreeMap<u64, PoseSequence>);

impl Tracks {
    fn add(&mut self, source: &str, options: &JsonOptions, people: Vec<(u64, PoseFrame)>) {
        for (track_id, pose) in people {
            self.0
                .entry(track_id)
                .or_insert_with(|| PoseSequence {
                    source: source.to_owned(),
                    track_id,
                    joint_names: options.joint_names.clone(),
                    frames: Vec::new(),
                })
                .frames
                .push(pose);
        }
    }

    fn into_sequences(self) -> Vec<PoseSequence> {
        self.0.into_values().collect()
    }
}

/// The one reader behind [`parse`], [`read`] and [`for_each_frame`]: the top level is walked
/// by a serde visitor that takes one frame at a time.
fn stream<E: From<JsonError>>(
    reader: impl std::io::Read,
    source: &str,
    options: &JsonOptions,
    on_frame: &mut dyn FnMut(Vec<(u64, PoseFrame)>) -> Result<(), E>,
) -> Result<(), E> {
    check_options(source, options)?;
    let not_utf8 = std::rc::Rc::new(std::cell::Cell::new(None));
    let reader = NonFiniteAsNull::new(reader, std::rc::Rc::clone(&not_utf8));
    let failure = std::cell::RefCell::new(None);
    let mut frames = FrameReader {
        source,
        options,
        on_frame,
        failure: &failure,
        index: 0,
        previous: None,
    };
    // serde_json reads a reader one byte at a time; `BufReader` answers those from its buffer.
    let mut de =
        serde_json::Deserializer::from_reader(std::io::BufReader::with_capacity(1 << 16, reader));
    let result = serde::de::DeserializeSeed::deserialize(
        Top {
            reader: &mut frames,
            nested: false,
        },
        &mut de,
    )
    .and_then(|()| de.end());
    if let Some(e) = failure.into_inner() {
        return Err(e);
    }
    if let Some((line, column)) = not_utf8.get() {
        return Err(E::from(JsonError::Syntax {
            file: source.to_owned(),
            line,
            column,
            message: "not utf-8 text".to_owned(),
        }));
    }
    result.map_err(|e| {
        E::from(match e.classify() {
            serde_json::error::Category::Io => JsonError::Io {
                file: source.to_owned(),
                error: std::io::Error::other(e.to_string()),
            },
            _ => JsonError::Syntax {
                file: source.to_owned(),
                line: e.line(),
                column: e.column(),
                message: e.to_string(),
            },
        })
    })
}

/// Turns each frame's JSON into its people, checking the order of the frame ids.
struct FrameReader<'a, E> {
    source: &'a str,
    options: &'a JsonOptions,
    on_frame: &'a mut dyn FnMut(Vec<(u64, PoseFrame)>) -> Result<(), E>,
    /// The error that stopped the reading, if it was not the parser's.
    failure: &'a std::cell::RefCell<Option<E>>,
    index: usize,
    previous: Option<u64>,
}

impl<E: From<JsonError>> FrameReader<'_, E> {
    /// Records `e` as the reason the reading stops; the parser gets a placeholder.
    fn fail<D: serde::de::Error>(&self, e: E) -> D {
        *self.failure.borrow_mut() = Some(e);
        D::custom("stopped")
    }

    fn frame(&mut self, frame: &Value) -> Result<(), E> {
        let index = self.index;
        self.index += 1;
        let people = self.people(frame, index).map_err(E::from)?;
        (self.on_frame)(people)
    }

    /// The people of frame `index`, checked.
    fn people(&mut self, frame: &Value, index: usize) -> Result<Vec<(u64, PoseFrame)>, JsonError> {
        let (source, options) = (self.source, self.options);
        let ctx = FrameCtx {
            file: source,
            frame: index,
            frame_id: 0,
        };
        let object = frame
            .as_object()
            .ok_or_else(|| ctx.field("", "an object", frame))?;
        let id_value = object
            .get("frame_id")
            .ok_or_else(|| ctx.missing("frame_id"))?;
        let frame_id = id_value
            .as_u64()
            .ok_or_else(|| ctx.field("frame_id", "a non-negative integer", id_value))?;
        if let Some(previous) = self.previous
            && frame_id <= previous
        {
            return Err(JsonError::FrameOrder {
                file: source.to_owned(),
                frame: index,
                previous,
                frame_id,
            });
        }
        self.previous = Some(frame_id);
        let ctx = FrameCtx { frame_id, ..ctx };
        let stamp = stamp_nanos_at(usize::try_from(frame_id).unwrap_or(usize::MAX), options.fps);

        let instances: Vec<&Value> = match object.get("instances") {
            None => return Err(ctx.missing("instances")),
            Some(Value::Null) => Vec::new(),
            Some(Value::Array(list)) => list.iter().collect(),
            Some(single @ Value::Object(_)) => vec![single],
            Some(other) => {
                return Err(ctx.field("instances", "a list of instances or one instance", other));
            }
        };
        let mut people: Vec<(u64, PoseFrame)> = Vec::with_capacity(instances.len());
        for (instance, value) in instances.into_iter().enumerate() {
            let (track_id, pose) = parse_instance(&ctx, instance, value, stamp, options)?;
            if people.iter().any(|(t, _)| *t == track_id) {
                return Err(JsonError::DuplicateTrack {
                    file: source.to_owned(),
                    frame: index,
                    frame_id,
                    instance,
                    track_id,
                });
            }
            people.push((track_id, pose));
        }
        Ok(people)
    }
}

/// The top level: a list of frames, or an object whose `instance_info` is one (`nested`: this
/// is that `instance_info`, where anything but a list is reported as the object around it).
struct Top<'r, 'a, E> {
    reader: &'r mut FrameReader<'a, E>,
    nested: bool,
}

impl<'de, E: From<JsonError>> serde::de::DeserializeSeed<'de> for Top<'_, '_, E> {
    type Value = ();

    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_any(self)
    }
}

impl<E: From<JsonError>> Top<'_, '_, E> {
    fn not_a_list<D: serde::de::Error>(self, found: &'static str) -> Result<(), D> {
        let e = JsonError::NotAList {
            file: self.reader.source.to_owned(),
            found: if self.nested { "an object" } else { found },
        };
        Err(self.reader.fail(E::from(e)))
    }
}

impl<'de, E: From<JsonError>> serde::de::Visitor<'de> for Top<'_, '_, E> {
    type Value = ();

    fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("a list of frames")
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        while let Some(frame) = seq.next_element::<Value>()? {
            if let Err(e) = self.reader.frame(&frame) {
                return Err(self.reader.fail(e));
            }
        }
        Ok(())
    }

    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        if self.nested {
            return self.not_a_list("an object");
        }
        let mut found = false;
        while let Some(key) = map.next_key::<String>()? {
            if key == "instance_info" && !found {
                found = true;
                map.next_value_seed(Top {
                    reader: &mut *self.reader,
                    nested: true,
                })?;
            } else {
                map.next_value::<serde::de::IgnoredAny>()?;
            }
        }
        if found {
            Ok(())
        } else {
            self.not_a_list("an object")
        }
    }

    fn visit_unit<D: serde::de::Error>(self) -> Result<(), D> {
        self.not_a_list("null")
    }

    fn visit_bool<D: serde::de::Error>(self, _: bool) -> Result<(), D> {
        self.not_a_list("a boolean")
    }

    fn visit_i64<D: serde::de::Error>(self, _: i64) -> Result<(), D> {
        self.not_a_list("a number")
    }

    fn visit_u64<D: serde::de::Error>(self, _: u64) -> Result<(), D> {
        self.not_a_list("a number")
    }

    fn visit_f64<D: serde::de::Error>(self, _: f64) -> Result<(), D> {
        self.not_a_list("a number")
    }

    fn visit_str<D: serde::de::Error>(self, _: &str) -> Result<(), D> {
        self.not_a_list("a string")
    }
}

fn check_options(file: &str, options: &JsonOptions) -> Result<(), JsonError> {
    let invalid = |field, message: String| JsonError::InvalidOptions {
        file: file.to_owned(),
        field,
        message,
    };
    if !(options.fps.is_finite() && options.fps > 0.0) {
        return Err(invalid(
            "fps",
            format!("must be positive and finite, is {}", options.fps),
        ));
    }
    if !(options.metres_per_unit.is_finite() && options.metres_per_unit > 0.0) {
        return Err(invalid(
            "metres_per_unit",
            format!(
                "must be positive and finite, is {}",
                options.metres_per_unit
            ),
        ));
    }
    if options.joint_names.is_empty() {
        return Err(invalid("joint_names", "must not be empty".to_owned()));
    }
    Ok(())
}

/// One instance → (track id, pose frame).
fn parse_instance(
    ctx: &FrameCtx<'_>,
    instance: usize,
    value: &Value,
    stamp: u64,
    options: &JsonOptions,
) -> Result<(u64, PoseFrame), JsonError> {
    let path = |field: &str| format!("instances[{instance}]{field}");
    let object = value
        .as_object()
        .ok_or_else(|| ctx.field(&path(""), "an object", value))?;

    let track_id = match object.get("track_id") {
        None | Some(Value::Null) => u64::try_from(instance).unwrap_or(u64::MAX),
        Some(v) => v
            .as_u64()
            .ok_or_else(|| ctx.field(&path(".track_id"), "a non-negative integer", v))?,
    };

    let expected = options.joint_names.len();
    let keypoints = match object.get("keypoints") {
        None => return Err(ctx.missing(&path(".keypoints"))),
        Some(Value::Array(list)) => list,
        Some(other) => {
            return Err(ctx.field(&path(".keypoints"), "a list of [x, y, z]", other));
        }
    };
    if keypoints.len() != expected {
        return Err(ctx.count(instance, "keypoints", expected, keypoints.len()));
    }

    let scores = match object.get("keypoint_scores") {
        None | Some(Value::Null) => None,
        Some(Value::Array(list)) => {
            if list.len() != expected {
                return Err(ctx.count(instance, "keypoint_scores", expected, list.len()));
            }
            Some(list)
        }
        Some(other) => {
            return Err(ctx.field(&path(".keypoint_scores"), "a list of numbers", other));
        }
    };

    let mut frame = PoseFrame::missing(stamp, expected);
    for (k, ((keypoint, position), confidence)) in keypoints
        .iter()
        .zip(&mut frame.positions_m)
        .zip(&mut frame.confidence)
        .enumerate()
    {
        let at = || path(&format!(".keypoints[{k}]"));
        let Some(point) = parse_point(ctx, at, keypoint)? else {
            continue;
        };
        let score = match scores.and_then(|s| s.get(k)) {
            None => 1.0,
            Some(Value::Null) => 0.0,
            Some(v) => v.as_f64().ok_or_else(|| {
                ctx.field(
                    &path(&format!(".keypoint_scores[{k}]")),
                    "a number or null",
                    v,
                )
            })?,
        };
        *position = options
            .axes
            .point_to_autoact(point * options.metres_per_unit);
        *confidence = score.clamp(0.0, 1.0) as f32;
    }
    Ok((track_id, frame))
}

/// `[x, y, z]` → `Some(point)`; `null` or any null coordinate → `None` (not seen). `path`
/// names the value in an error (made only then: this runs for every keypoint).
fn parse_point(
    ctx: &FrameCtx<'_>,
    path: impl Fn() -> String,
    value: &Value,
) -> Result<Option<Point3<f64>>, JsonError> {
    let list = match value {
        Value::Null => return Ok(None),
        Value::Array(list) if list.len() == 3 => list,
        other => return Err(ctx.field(&path(), "[x, y, z] or null", other)),
    };
    let mut xyz = [0.0; 3];
    for (c, (slot, v)) in xyz.iter_mut().zip(list).enumerate() {
        match v {
            Value::Null => return Ok(None),
            Value::Number(n) => *slot = n.as_f64().unwrap_or(f64::NAN),
            other => {
                let path = format!("{}[{c}]", path());
                return Err(ctx.field(&path, "a number or null", other));
            }
        }
    }
    if xyz.iter().all(|c| c.is_finite()) {
        Ok(Some(Point3::from(xyz)))
    } else {
        Ok(None)
    }
}

/// Where in the file we are, for errors.
#[derive(Clone, Copy)]
struct FrameCtx<'a> {
    file: &'a str,
    frame: usize,
    frame_id: u64,
}

impl FrameCtx<'_> {
    fn field(&self, field: &str, expected: &'static str, found: &Value) -> JsonError {
        let found = match found {
            Value::Number(n) => format!("the number {n}"),
            Value::String(s) if s.len() <= 40 => format!("the string {s:?}"),
            other => type_name(other).to_owned(),
        };
        JsonError::Field {
            file: self.file.to_owned(),
            frame: self.frame,
            field: if field.is_empty() {
                "(the frame itself)".to_owned()
            } else {
                field.to_owned()
            },
            expected,
            found,
        }
    }

    fn missing(&self, field: &str) -> JsonError {
        JsonError::MissingField {
            file: self.file.to_owned(),
            frame: self.frame,
            field: field.to_owned(),
        }
    }

    fn count(
        &self,
        instance: usize,
        field: &'static str,
        expected: usize,
        found: usize,
    ) -> JsonError {
        JsonError::KeypointCount {
            file: self.file.to_owned(),
            frame: self.frame,
            frame_id: self.frame_id,
            instance,
            field,
            expected,
            found,
        }
    }
}

fn type_name(value: &Value) -> &'static str {
    match value {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "a list",
        Value::Object(_) => "an object",
    }
}

/// Python's `json` module writes `NaN`, `Infinity` and `-Infinity`, which are not JSON: outside
/// strings, this reader passes those tokens on as `null`. It also checks that the text is UTF-8,
/// and where it is not, records the place (1-based line and byte column) in `not_utf8` and ends
/// the text there.
struct NonFiniteAsNull<R> {
    inner: R,
    /// Bytes read, not yet passed on.
    input: Vec<u8>,
    /// Bytes ready to be passed on, from `out_at`.
    out: Vec<u8>,
    out_at: usize,
    eof: bool,
    in_string: bool,
    escaped: bool,
    line: usize,
    column: usize,
    not_utf8: std::rc::Rc<std::cell::Cell<Option<(usize, usize)>>>,
}

const NON_FINITE: [&[u8]; 3] = [b"NaN", b"Infinity", b"-Infinity"];

impl<R: std::io::Read> NonFiniteAsNull<R> {
    fn new(inner: R, not_utf8: std::rc::Rc<std::cell::Cell<Option<(usize, usize)>>>) -> Self {
        NonFiniteAsNull {
            inner,
            input: Vec::new(),
            out: Vec::new(),
            out_at: 0,
            eof: false,
            in_string: false,
            escaped: false,
            line: 1,
            column: 1,
            not_utf8,
        }
    }

    /// Reads more and passes on what can be decided (a possible token cut at the end of what
    /// was read waits for the rest).
    fn refill(&mut self) -> std::io::Result<()> {
        let have = self.input.len();
        self.input.resize(have + (1 << 15), 0);
        let n = self.inner.read(&mut self.input[have..])?;
        self.input.truncate(have + n);
        self.eof = n == 0;
        // Only whole UTF-8 characters; stop for good at the first invalid byte.
        let valid = match std::str::from_utf8(&self.input) {
            Ok(_) => self.input.len(),
            Err(e) if e.error_len().is_none() && !self.eof => e.valid_up_to(),
            Err(e) => {
                let valid = e.valid_up_to();
                let (line, column) = self.advance(valid);
                self.not_utf8.set(Some((line, column)));
                self.input.truncate(valid);
                self.eof = true;
                valid
            }
        };
        let mut i = 0;
        while i < valid {
            // The bytes up to the next one that can matter pass on as they are (after a
            // backslash in a string, the next byte matters whatever it is).
            let rest = &self.input[i..valid];
            let run = if self.escaped {
                Some(0)
            } else if self.in_string {
                rest.iter().position(|&b| matches!(b, b'"' | b'\\'))
            } else {
                rest.iter()
                    .position(|&b| matches!(b, b'"' | b'N' | b'I' | b'-'))
            };
            let run = run.unwrap_or(rest.len());
            self.out.extend_from_slice(&rest[..run]);
            i += run;
            if i == valid {
                break;
            }
            let b = self.input[i];
            if self.in_string {
                if self.escaped {
                    self.escaped = false;
                } else if b == b'\\' {
                    self.escaped = true;
                } else if b == b'"' {
                    self.in_string = false;
                }
            } else if matches!(b, b'N' | b'I' | b'-') {
                let rest = &self.input[i..valid];
                if let Some(token) = NON_FINITE.iter().find(|t| rest.starts_with(t)) {
                    self.out.extend_from_slice(b"null");
                    i += token.len();
                    continue;
                }
                if !self.eof && NON_FINITE.iter().any(|t| t.starts_with(rest)) {
                    break;
                }
            } else if b == b'"' {
                self.in_string = true;
            }
            self.out.push(b);
            i += 1;
        }
        if self.not_utf8.get().is_none() {
            self.advance(i);
        }
        self.input.drain(..i);
        Ok(())
    }

    /// The line and column after the first `n` bytes of `input`, counted from where the
    /// passed-on text ends (updated when `n` bytes are passed on).
    fn advance(&mut self, n: usize) -> (usize, usize) {
        let passed = &self.input[..n];
        match passed.iter().rposition(|&b| b == b'\n') {
            Some(last) => {
                self.line += passed.iter().filter(|&&b| b == b'\n').count();
                // 1, and one for each byte after the last line break.
                self.column = n - last;
            }
            None => self.column += n,
        }
        (self.line, self.column)
    }
}

impl<R: std::io::Read> std::io::Read for NonFiniteAsNull<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.out_at >= self.out.len() {
            self.out.clear();
            self.out_at = 0;
            if self.eof && self.input.is_empty() {
                return Ok(0);
            }
            self.refill()?;
        }
        let n = buf.len().min(self.out.len() - self.out_at);
        buf[..n].copy_from_slice(&self.out[self.out_at..self.out_at + n]);
        self.out_at += n;
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn options(n: usize) -> JsonOptions {
        JsonOptions {
            fps: 30.0,
            metres_per_unit: 1.0,
            axes: SourceAxes::ZUp,
            joint_names: (0..n).map(|i| format!("j{i}")).collect(),
        }
    }

    fn ok(text: &str, opts: &JsonOptions) -> Vec<PoseSequence> {
        match parse(text, "t.json", opts) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        }
    }

    fn err(text: &str, opts: &JsonOptions) -> JsonError {
        match parse(text, "t.json", opts) {
            Ok(s) => panic!("expected an error, got {} tracks", s.len()),
            Err(e) => e,
        }
    }

    const TWO_TRACKS: &str = r#"[
        {"frame_id": 0, "instances": [
            {"keypoints": [[1, 2, 3], [4, 5, 6]], "keypoint_scores": [0.9, 1.5], "track_id": 4},
            {"keypoints": [[7, 8, 9], null], "track_id": 2}]},
        {"frame_id": 2, "instances": [
            {"keypoints": [[1, 2, null], [4, 5, 6]], "keypoint_scores": [-1, null], "track_id": 4}]}
    ]"#;

    #[test]
    fn groups_by_track_and_stamps_by_frame_id() {
        let seqs = ok(TWO_TRACKS, &options(2));
        assert_eq!(seqs.len(), 2);
        assert_eq!((seqs[0].track_id, seqs[1].track_id), (2, 4));
        assert_eq!(seqs[0].frames.len(), 1);
        let t4 = &seqs[1];
        assert_eq!(t4.joint_names, vec!["j0", "j1"]);
        assert_eq!(
            t4.frames.iter().map(|f| f.stamp_nanos).collect::<Vec<_>>(),
            vec![0, 66_666_667]
        );
        assert_eq!(t4.frames[0].positions_m[1], Point3::new(4.0, 5.0, 6.0));
        assert_eq!(t4.frames[0].confidence, vec![0.9, 1.0]);
        // null coordinate → NaN + 0; scores clamp; null score → 0
        assert!(t4.frames[1].positions_m[0].x.is_nan());
        assert_eq!(t4.frames[1].confidence, vec![0.0, 0.0]);
        // no scores → 1 for seen joints, null keypoint → NaN + 0
        assert_eq!(seqs[0].frames[0].confidence, vec![1.0, 0.0]);
        assert!(seqs[0].frames[0].positions_m[1].z.is_nan());
    }

    #[test]
    fn single_object_instances_with_133_keypoints() {
        let n = 133;
        let kps: Vec<String> = (0..n)
            .map(|k| format!("[{}, {}, {}]", k, 2 * k, 1000 + k))
            .collect();
        let text = format!(
            r#"[{{"frame_id": 0, "instances": {{"keypoints": [{kps}]}}}},
                {{"frame_id": 1, "instances": {{"keypoints": [{kps}]}}}}]"#,
            kps = kps.join(", ")
        );
        let opts = JsonOptions {
            fps: 25.0,
            metres_per_unit: 0.001,
            axes: SourceAxes::YDown,
            joint_names: (0..n).map(|i| format!("k{i}")).collect(),
        };
        let seqs = ok(&text, &opts);
        assert_eq!(seqs.len(), 1);
        assert_eq!(seqs[0].track_id, 0);
        assert_eq!(seqs[0].frames.len(), 2);
        assert_eq!(seqs[0].frames[1].stamp_nanos, 40_000_000);
        // mm → m, Y down → (x, z, −y)
        let p = seqs[0].frames[0].positions_m[10];
        assert!((p.x - 0.010).abs() < 1e-12);
        assert!((p.y - 1.010).abs() < 1e-12);
        assert!((p.z + 0.020).abs() < 1e-12);
        assert!(seqs[0].frames[0].confidence.iter().all(|c| *c == 1.0));
    }

    #[test]
    fn instance_index_is_the_track_without_track_id_and_instance_info_wrapper() {
        let text = r#"{"meta_info": {}, "instance_info": [
            {"frame_id": 1, "instances": [{"keypoints": [[0, 0, 0]]}, {"keypoints": [[1, 1, 1]]}]},
            {"frame_id": 2, "instances": []},
            {"frame_id": 3, "instances": null}]}"#;
        let seqs = ok(text, &options(1));
        assert_eq!(
            seqs.iter().map(|s| s.track_id).collect::<Vec<_>>(),
            vec![0, 1]
        );
        assert_eq!(seqs[1].frames[0].positions_m[0], Point3::new(1.0, 1.0, 1.0));
        assert_eq!(seqs[1].frames[0].stamp_nanos, 33_333_333);
        assert!(ok("[]", &options(1)).is_empty());
    }

    #[test]
    fn python_nan_and_infinity_tokens_are_missing() {
        let text = r#"[{"frame_id": 0, "instances": [{"keypoints": [[NaN, 1, 2], [1, -Infinity, 2], [1, 2, 3]],
            "keypoint_scores": [0.5, 0.5, NaN], "note": "NaN in a \" string Infinity"}]}]"#;
        let seqs = ok(text, &options(3));
        let f = &seqs[0].frames[0];
        assert!(f.positions_m[0].x.is_nan() && f.positions_m[1].x.is_nan());
        assert_eq!(f.confidence, vec![0.0, 0.0, 0.0]);
        assert_eq!(f.positions_m[2], Point3::new(1.0, 2.0, 3.0));
        // Tokens cut anywhere between reads, escapes, and tokens in strings.
        let text = r#"["NaN", NaN, -Infinity,Infinity, "a\" NaN", Nx, -1.5, "é"]"#;
        let want = r#"["NaN", null, null,null, "a\" NaN", Nx, -1.5, "é"]"#;
        assert_eq!(filtered(text), want);
    }

    /// `text` through [`NonFiniteAsNull`] from a reader that gives one byte at a time.
    fn filtered(text: &str) -> String {
        struct OneByte<'a>(&'a [u8]);
        impl std::io::Read for OneByte<'_> {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                let Some((first, rest)) = self.0.split_first() else {
                    return Ok(0);
                };
                buf[0] = *first;
                self.0 = rest;
                Ok(1)
            }
        }
        let flag = std::rc::Rc::new(std::cell::Cell::new(None));
        let mut out = String::new();
        std::io::Read::read_to_string(
            &mut NonFiniteAsNull::new(OneByte(text.as_bytes()), flag),
            &mut out,
        )
        .unwrap();
        out
    }

    #[test]
    fn keypoint_count_mismatch_names_frame_and_instance() {
        let text = r#"[{"frame_id": 0, "instances": [{"keypoints": [[0,0,0]]}]},
                       {"frame_id": 5, "instances": [{"keypoints": [[0,0,0]]}, {"keypoints": [[0,0,0],[1,1,1]]}]}]"#;
        match err(text, &options(1)) {
            e @ JsonError::KeypointCount {
                frame: 1,
                frame_id: 5,
                instance: 1,
                field: "keypoints",
                expected: 1,
                found: 2,
                ..
            } => {
                assert_eq!(
                    e.to_string(),
                    "t.json: frame 1 (frame_id 5), instance 1: keypoints has 2 entries, expected 1"
                );
            }
            e => panic!("{e}"),
        }
        let text =
            r#"[{"frame_id": 0, "instances": [{"keypoints": [[0,0,0]], "keypoint_scores": []}]}]"#;
        assert!(matches!(
            err(text, &options(1)),
            JsonError::KeypointCount {
                field: "keypoint_scores",
                ..
            }
        ));
    }

    #[test]
    fn frame_ids_must_strictly_increase() {
        for (a, b) in [(3, 3), (3, 1)] {
            let text = format!(
                r#"[{{"frame_id": {a}, "instances": []}}, {{"frame_id": {b}, "instances": []}}]"#
            );
            match err(&text, &options(1)) {
                JsonError::FrameOrder {
                    frame: 1,
                    previous,
                    frame_id,
                    ..
                } => {
                    assert_eq!((previous, frame_id), (a, b));
                }
                e => panic!("{e}"),
            }
        }
    }

    #[test]
    fn duplicate_track_in_one_frame() {
        let text = r#"[{"frame_id": 0, "instances": [{"keypoints": [[0,0,0]], "track_id": 1},
                                                     {"keypoints": [[0,0,0]], "track_id": 1}]}]"#;
        assert!(matches!(
            err(text, &options(1)),
            JsonError::DuplicateTrack {
                frame: 0,
                instance: 1,
                track_id: 1,
                ..
            }
        ));
    }

    #[test]
    fn wrong_types_and_missing_fields() {
        let o = options(1);
        let field = |text: &str| match err(text, &o) {
            JsonError::Field { field, .. } => field,
            e => panic!("{e}"),
        };
        assert_eq!(field(r#"[{"frame_id": -1, "instances": []}]"#), "frame_id");
        assert_eq!(field(r#"[{"frame_id": 1.5, "instances": []}]"#), "frame_id");
        assert_eq!(field(r#"[{"frame_id": 0, "instances": 3}]"#), "instances");
        assert_eq!(
            field(r#"[{"frame_id": 0, "instances": [{"keypoints": [[0, 0]]}]}]"#),
            "instances[0].keypoints[0]"
        );
        assert_eq!(
            field(r#"[{"frame_id": 0, "instances": [{"keypoints": [[0, "a", 0]]}]}]"#),
            "instances[0].keypoints[0][1]"
        );
        assert_eq!(
            field(r#"[{"frame_id": 0, "instances": [{"keypoints": {}}]}]"#),
            "instances[0].keypoints"
        );
        assert_eq!(
            field(
                r#"[{"frame_id": 0, "instances": [{"keypoints": [[0,0,0]], "keypoint_scores": ["x"]}]}]"#
            ),
            "instances[0].keypoint_scores[0]"
        );
        assert_eq!(
            field(r#"[{"frame_id": 0, "instances": [{"keypoints": [[0,0,0]], "track_id": "a"}]}]"#),
            "instances[0].track_id"
        );
        assert_eq!(
            field(r#"[{"frame_id": 0, "instances": [7]}]"#),
            "instances[0]"
        );
        assert_eq!(field("[1]"), "(the frame itself)");
        let missing = |text: &str| match err(text, &o) {
            JsonError::MissingField { frame, field, .. } => (frame, field),
            e => panic!("{e}"),
        };
        assert_eq!(
            missing(r#"[{"instances": []}]"#),
            (0, "frame_id".to_owned())
        );
        assert_eq!(missing(r#"[{"frame_id": 0}]"#), (0, "instances".to_owned()));
        assert_eq!(
            missing(r#"[{"frame_id": 0, "instances": [{}]}]"#),
            (0, "instances[0].keypoints".to_owned())
        );
        assert!(matches!(
            err(r#"{"a": 1}"#, &o),
            JsonError::NotAList {
                found: "an object",
                ..
            }
        ));
        assert!(matches!(
            err("3", &o),
            JsonError::NotAList {
                found: "a number",
                ..
            }
        ));
    }

    #[test]
    fn syntax_errors_and_options() {
        match err("[\n{\"frame_id\": 0,,}]", &options(1)) {
            JsonError::Syntax {
                line: 2, column, ..
            } => assert!(column > 1),
            e => panic!("{e}"),
        }
        let mut o = options(1);
        o.fps = 0.0;
        assert!(matches!(
            err("[]", &o),
            JsonError::InvalidOptions { field: "fps", .. }
        ));
        let mut o = options(1);
        o.metres_per_unit = f64::NAN;
        assert!(matches!(
            err("[]", &o),
            JsonError::InvalidOptions {
                field: "metres_per_unit",
                ..
            }
        ));
        assert!(matches!(
            err("[]", &options(0)),
            JsonError::InvalidOptions {
                field: "joint_names",
                ..
            }
        ));
    }

    #[test]
    fn read_reports_io_and_encoding() {
        let o = options(2);
        assert!(matches!(
            read("/nonexistent/x.json", &o),
            Err(JsonError::Io { .. })
        ));
        let dir = std::env::temp_dir().join(format!("autoact-json-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("a.json");
        std::fs::write(&path, b"[\n  \xff]").expect("write");
        assert!(matches!(
            read(&path, &o),
            Err(JsonError::Syntax {
                line: 2,
                column: 3,
                ..
            })
        ));
        std::fs::write(&path, TWO_TRACKS).expect("write");
        assert_eq!(read(&path, &o).expect("valid").len(), 2);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn every_truncation_is_an_error() {
        let end = TWO_TRACKS.trim_end().len();
        for k in 0..end {
            assert!(
                parse(&TWO_TRACKS[..k], "t", &options(2)).is_err(),
                "cut at {k} parsed"
            );
        }
    }

    /// What the filter gives, from the whole text at once, one byte at a time: the text up to its
    /// first invalid UTF-8 byte, the non-finite tokens outside strings as `null`, and the
    /// invalid byte's line and column.
    fn reference_filter(bytes: &[u8]) -> (Vec<u8>, Option<(usize, usize)>) {
        let valid = std::str::from_utf8(bytes).map_or_else(|e| e.valid_up_to(), str::len);
        let text = &bytes[..valid];
        let place = (valid < bytes.len()).then(|| {
            let line = 1 + text.iter().filter(|&&b| b == b'\n').count();
            let line_start = text.iter().rposition(|&b| b == b'\n').map_or(0, |k| k + 1);
            (line, 1 + valid - line_start)
        });
        let (mut out, mut i, mut in_string, mut escaped) = (Vec::new(), 0, false, false);
        while i < text.len() {
            let b = text[i];
            if in_string {
                if escaped {
                    escaped = false;
                } else if b == b'\\' {
                    escaped = true;
                } else if b == b'"' {
                    in_string = false;
                }
            } else if b == b'"' {
                in_string = true;
            } else if let Some(t) = NON_FINITE.iter().find(|t| text[i..].starts_with(t)) {
                out.extend_from_slice(b"null");
                i += t.len();
                continue;
            }
            out.push(b);
            i += 1;
        }
        (out, place)
    }

    /// A reader that gives its bytes in reads of the given sizes, in turn.
    struct Pieces<'a>(&'a [u8], &'a [usize], usize);
    impl std::io::Read for Pieces<'_> {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let n = self.1[self.2 % self.1.len()]
                .min(buf.len())
                .min(self.0.len());
            self.2 += 1;
            buf[..n].copy_from_slice(&self.0[..n]);
            self.0 = &self.0[n..];
            Ok(n)
        }
    }

    proptest! {
        /// The filter gives the reference's text and place, however the reads cut the text.
        #[test]
        fn the_filter_gives_the_reference_whatever_the_reads(
            pieces in proptest::collection::vec(proptest::sample::select(vec![
                "NaN", "Infinity", "-Infinity", "-1.5", "Na", "-Inf", "\"", "\\", "\\\"", "N", "I",
                "-", "\n", "a", "é", " ", "12", "[", ",",
            ]), 0..80),
            invalid_at in proptest::option::of(0usize..80),
            read_sizes in proptest::collection::vec(1usize..40, 1..8),
        ) {
            let mut bytes = Vec::new();
            for (k, piece) in pieces.iter().enumerate() {
                if invalid_at == Some(k) {
                    bytes.push(0xff);
                }
                bytes.extend_from_slice(piece.as_bytes());
            }
            let place = std::rc::Rc::new(std::cell::Cell::new(None));
            let mut filter =
                NonFiniteAsNull::new(Pieces(&bytes, &read_sizes, 0), std::rc::Rc::clone(&place));
            let mut out = Vec::new();
            std::io::Read::read_to_end(&mut filter, &mut out).unwrap();
            let (want, want_place) = reference_filter(&bytes);
            prop_assert_eq!(String::from_utf8_lossy(&out), String::from_utf8_lossy(&want));
            prop_assert_eq!(place.get(), want_place);
        }

        #[test]
        fn arbitrary_text_never_panics(text in "\\PC{0,300}") {
            let _ = parse(&text, "p", &options(2));
        }

        #[test]
        fn json_like_noise_never_panics(text in r#"[\[\]{}":,0-9a-z_\- .NaIfinty]{0,300}"#) {
            let _ = parse(&text, "p", &options(2));
        }

        #[test]
        fn mutated_files_never_panic(pos in 0usize..1000, byte in 0x20u8..0x7f) {
            let mut bytes = TWO_TRACKS.as_bytes().to_vec();
            let len = bytes.len();
            if let Some(b) = bytes.get_mut(pos % len) {
                *b = byte;
            }
            if let Ok(text) = String::from_utf8(bytes) {
                let _ = parse(&text, "p", &options(2));
            }
        }
    }
}
