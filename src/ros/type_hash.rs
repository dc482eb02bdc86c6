//! REP-2011 type description hashes (`RIHS01_<sha256 hex>`) of `ros2msg` schema texts, as
//! rosbag2 (Iron and later) writes them per topic in `metadata.yaml` (`type_description_hash`).
//!
//! The hash is the SHA-256 of a canonical JSON of the type description:
//! `{"type_description": T, "referenced_type_descriptions": [R, ...]}` where each description is
//! `{"type_name": "pkg/msg/Type", "fields": [{"name": ..., "type": {"type_id": ..., "capacity":
//! ..., "string_capacity": ..., "nested_type_name": ...}}, ...]}`, the referenced types are every
//! type reachable from the root (each once, sorted by name), and the JSON is printed as Python's
//! `json.dumps` does by default (`", "` and `": "` separators), which is what rosidl
//! (`rosidl_generator_type_description`) and rosbags (`Typestore.hash_rihs01`) both hash.
//! Constants, default values and comments are not part of the description; a type without fields
//! gets rosidl's placeholder `uint8 structure_needs_at_least_one_member`.
//!
//! Field type ids are rosidl's (`type_description_interfaces/msg/FieldType`): a primitive's id,
//! `1` for a nested type, plus 48 for a fixed array, 96 for a bounded sequence, 144 for an
//! unbounded one. A `.msg` `char` is `uint8` in rosidl's IDL, so it hashes as `uint8`.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use sha2::{Digest, Sha256};

/// One field of a parsed `.msg` type: its name and its type token (`float64[3]`, `Header`, …).
#[derive(Debug)]
struct FieldDef<'a> {
    name: &'a str,
    ty: &'a str,
}

/// The RIHS01 hash of `type_name` (`pkg/msg/Type`) given its full `ros2msg` definition (its own
/// text, then each dependency after a line of 80 `=` and `MSG: pkg/Type`, as rosbag2 writes
/// schema records). `None` when the text does not parse or names a type it does not define.
#[must_use]
pub fn rihs01(type_name: &str, definition: &str) -> Option<String> {
    let types = parse_definition(&super::full_name(type_name, ""), definition)?;
    let mut described: BTreeMap<String, String> = BTreeMap::new();
    let root = super::full_name(type_name, "");
    describe(&root, &types, &mut described)?;
    let mut json = String::from("{\"type_description\": ");
    json.push_str(described.get(&root)?);
    json.push_str(", \"referenced_type_descriptions\": [");
    let referenced: Vec<&str> = described
        .iter()
        .filter(|(name, _)| **name != root)
        .map(|(_, d)| d.as_str())
        .collect();
    json.push_str(&referenced.join(", "));
    json.push_str("]}");
    let digest = Sha256::digest(json.as_bytes());
    let mut out = String::from("RIHS01_");
    for byte in digest {
        let _ = write!(out, "{byte:02x}");
    }
    Some(out)
}

/// The types of a full definition: root text, then `MSG: pkg/Type` blocks after separators.
fn parse_definition<'a>(
    root: &str,
    definition: &'a str,
) -> Option<BTreeMap<String, Vec<FieldDef<'a>>>> {
    let separator = "=".repeat(80);
    let mut types: BTreeMap<String, Vec<FieldDef<'a>>> = BTreeMap::new();
    let mut current = root.to_string();
    let mut fields: Vec<FieldDef<'a>> = Vec::new();
    let mut lines = definition.lines();
    while let Some(line) = lines.next() {
        if line.trim_end() == separator {
            let name = lines.next()?.strip_prefix("MSG: ")?.trim();
            types.insert(
                std::mem::replace(&mut current, super::full_name(name, "")),
                std::mem::take(&mut fields),
            );
            continue;
        }
        if let Line::Field(field) = parse_line(line)? {
            fields.push(field);
        }
    }
    types.insert(current, fields);
    Some(types)
}

/// The message types the fields of `.msg` text `text` (a type of `package`) use, as full names,
/// in order of first use; `None` when a line does not parse.
pub(super) fn nested_types(text: &str, package: &str) -> Option<Vec<String>> {
    let mut out: Vec<String> = Vec::new();
    for line in text.lines() {
        if let Line::Field(field) = parse_line(line)?
            && let Some(nested) = FieldType::parse(field.ty, package)?.nested
            && !out.contains(&nested)
        {
            out.push(nested);
        }
    }
    Some(out)
}

/// What a line of `.msg` text holds.
#[derive(Debug)]
enum Line<'a> {
    /// A field.
    Field(FieldDef<'a>),
    /// A blank line, a comment, an annotation or a constant: nothing the description holds.
    Other,
}

/// One line of `.msg` text; `None` when it does not parse.
fn parse_line(line: &str) -> Option<Line<'_>> {
    let line = line.trim_start();
    if line.is_empty() || line.starts_with('#') || line.starts_with('@') {
        return Some(Line::Other);
    }
    let (ty, rest) = line.split_once([' ', '\t'])?;
    let rest = rest.trim_start();
    let end = rest
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(rest.len());
    let (name, after) = rest.split_at(end);
    if name.is_empty()
        || !ty
            .chars()
            .all(|c| c.is_ascii_graphic() && c != '"' && c != '\\')
    {
        return None;
    }
    // A constant (`int32 ARROW=0`, `uint8 RED = 1`); a field's default value has no `=`.
    if after.trim_start().starts_with('=') {
        return Some(Line::Other);
    }
    Some(Line::Field(FieldDef { name, ty }))
}

/// Describes `name` and (first) every type it references into `described` (name → JSON).
fn describe(
    name: &str,
    types: &BTreeMap<String, Vec<FieldDef<'_>>>,
    described: &mut BTreeMap<String, String>,
) -> Option<()> {
    if described.contains_key(name) {
        return Some(());
    }
    // Marks it as in progress, so a type reached again (a cycle) is not described twice.
    described.insert(name.to_string(), String::new());
    let fields = types.get(name)?;
    let package = name.split('/').next().unwrap_or("");
    let mut parts = Vec::new();
    if fields.is_empty() {
        parts.push(field_json(
            "structure_needs_at_least_one_member",
            3,
            0,
            0,
            "",
        ));
    }
    for field in fields {
        let ty = FieldType::parse(field.ty, package)?;
        if let Some(nested) = &ty.nested {
            describe(nested, types, described)?;
        }
        parts.push(field_json(
            field.name,
            ty.type_id,
            ty.capacity,
            ty.string_capacity,
            ty.nested.as_deref().unwrap_or(""),
        ));
    }
    described.insert(
        name.to_string(),
        format!(
            "{{\"type_name\": \"{name}\", \"fields\": [{}]}}",
            parts.join(", ")
        ),
    );
    Some(())
}

fn field_json(
    name: &str,
    type_id: u32,
    capacity: u64,
    string_capacity: u64,
    nested: &str,
) -> String {
    format!(
        "{{\"name\": \"{name}\", \"type\": {{\"type_id\": {type_id}, \"capacity\": {capacity}, \"string_capacity\": {string_capacity}, \"nested_type_name\": \"{nested}\"}}}}"
    )
}

/// A field's type as the type description gives it.
#[derive(Debug, PartialEq, Eq)]
struct FieldType {
    type_id: u32,
    capacity: u64,
    string_capacity: u64,
    nested: Option<String>,
}

impl FieldType {
    /// Parses a `.msg` type token (`string<=8[<=4]`, `geometry_msgs/Point[]`, `Header`, …) of a
    /// field of a type in `package`.
    fn parse(token: &str, package: &str) -> Option<FieldType> {
        let (base, increment, capacity) = match token.split_once('[') {
            None => (token, 0, 0),
            Some((base, bound)) => {
                let bound = bound.strip_suffix(']')?;
                if bound.is_empty() {
                    (base, 144, 0)
                } else if let Some(n) = bound.strip_prefix("<=") {
                    (base, 96, n.parse().ok()?)
                } else {
                    (base, 48, bound.parse().ok()?)
                }
            }
        };
        let (type_id, string_capacity, nested) = if let Some(n) = base.strip_prefix("string<=") {
            (21, n.parse().ok()?, None)
        } else if let Some(n) = base.strip_prefix("wstring<=") {
            (22, n.parse().ok()?, None)
        } else if let Some(id) = primitive_id(base) {
            (id, 0, None)
        } else {
            (1, 0, Some(nested_name(base, package)?))
        };
        Some(FieldType {
            type_id: type_id + increment,
            capacity,
            string_capacity,
            nested,
        })
    }
}

/// rosidl's id of a primitive `.msg` type.
fn primitive_id(name: &str) -> Option<u32> {
    Some(match name {
        "int8" => 2,
        "uint8" | "char" => 3,
        "int16" => 4,
        "uint16" => 5,
        "int32" => 6,
        "uint32" => 7,
        "int64" => 8,
        "uint64" => 9,
        "float32" => 10,
        "float64" => 11,
        "bool" => 15,
        "byte" => 16,
        "string" => 17,
        "wstring" => 18,
        _ => return None,
    })
}

/// The full name of a field's message type: a bare `Type` is in the field's own package (but a
/// bare `Header` is `std_msgs`'s, as the parsers of rosbag2 definitions read it).
fn nested_name(base: &str, package: &str) -> Option<String> {
    if !base
        .chars()
        .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '/')
    {
        return None;
    }
    Some(match base {
        "Header" => "std_msgs/msg/Header".to_string(),
        _ if base.contains('/') => super::full_name(base, ""),
        _ => format!("{package}/msg/{base}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published hashes of ROS 2 Jazzy types, as rosbags 0.11.9's Jazzy type store computes them
    /// (`get_typestore(Stores.ROS2_JAZZY).hash_rihs01(name)`, read from the interop venv); the
    /// `std_msgs/msg/Header` value is also the one a Jazzy install reports.
    const JAZZY: [(&str, &str); 8] = [
        (
            "std_msgs/msg/Header",
            "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
        ),
        (
            "builtin_interfaces/msg/Time",
            "RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197",
        ),
        (
            "geometry_msgs/msg/Pose",
            "RIHS01_d501954e9476cea2996984e812054b68026ae0bfae789d9a10b23daf35cc90fa",
        ),
        (
            "geometry_msgs/msg/Point",
            "RIHS01_6963084842a9b04494d6b2941d11444708d892da2f4b09843b9c43f42a7f6881",
        ),
        (
            "tf2_msgs/msg/TFMessage",
            "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087",
        ),
        (
            "visualization_msgs/msg/MarkerArray",
            "RIHS01_86cb8800b6fb05b5eff1abd7a56f62a5641d3ae9a1c29e78e67e704f1d067dcf",
        ),
        (
            "sensor_msgs/msg/CameraInfo",
            "RIHS01_b3dfd68ff46c9d56c80fd3bd4ed22c7a4ddce8c8348f2f59c299e73118e7e275",
        ),
        (
            "sensor_msgs/msg/CompressedImage",
            "RIHS01_15640771531571185e2efc8a100baf923961a4d15d5569652e6cb6691e8e371a",
        ),
    ];

    #[test]
    fn vendored_standard_types_hash_as_jazzy_publishes() {
        for (name, expected) in JAZZY {
            let definition = crate::ros::definition(name).unwrap();
            assert_eq!(
                rihs01(name, &definition).as_deref(),
                Some(expected),
                "{name}"
            );
        }
    }

    #[test]
    fn a_type_without_fields_hashes_with_rosidls_placeholder() {
        // std_msgs/msg/Empty in Jazzy (rosbags' Jazzy store gives the same value).
        assert_eq!(
            rihs01("std_msgs/msg/Empty", "").as_deref(),
            Some("RIHS01_20b625256f32d5dbc0d04fee44f43c41e51c70d3502f84b4a08e7a9c26a96312")
        );
    }

    #[test]
    fn constants_comments_and_defaults_do_not_change_the_hash() {
        let plain = "float64 x\nstring name\n";
        let decorated =
            "# a point\nint32 KIND=3\nuint8 RED = 1\nfloat64 x 1.5 # x\n  string name \"a#b\"\n";
        assert_eq!(rihs01("p/msg/T", plain), rihs01("p/msg/T", decorated));
        assert_ne!(rihs01("p/msg/T", plain), rihs01("p/msg/U", plain));
        assert_ne!(
            rihs01("p/msg/T", plain),
            rihs01("p/msg/T", "float32 x\nstring name\n")
        );
    }

    #[test]
    fn field_types_get_rosidls_ids_and_bounds() {
        let t = |s| FieldType::parse(s, "pkg").unwrap();
        assert_eq!((t("float64").type_id, t("float64[3]").type_id), (11, 59));
        assert_eq!((t("uint8[<=4]").type_id, t("uint8[<=4]").capacity), (99, 4));
        assert_eq!(t("string[]").type_id, 161);
        let bounded = t("string<=8[2]");
        assert_eq!(
            (bounded.type_id, bounded.string_capacity, bounded.capacity),
            (69, 8, 2)
        );
        assert_eq!(t("Other").nested.as_deref(), Some("pkg/msg/Other"));
        assert_eq!(t("Header").nested.as_deref(), Some("std_msgs/msg/Header"));
        assert_eq!(t("geometry_msgs/Point[]").type_id, 145);
        assert!(FieldType::parse("float64[x]", "pkg").is_none());
    }

    #[test]
    fn an_unresolved_or_broken_definition_has_no_hash() {
        assert_eq!(rihs01("p/msg/T", "q/Missing m\n"), None);
        assert_eq!(rihs01("p/msg/T", "float64\n"), None);
        let cut = format!("p/Q q\n{}\nnot a header\n", "=".repeat(80));
        assert_eq!(rihs01("p/msg/T", &cut), None);
    }
}
