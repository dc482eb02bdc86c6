//! glTF 2.0 writer: one [`Clip`] → a skinned, animated character (and the capture's camera) as a
//! `.gltf` (JSON with the buffer embedded as a base64 data URI) or a `.glb` (binary container).
//! Spec: <https://registry.khronos.org/glTF/specs/2.0/glTF-2.0.html>.
//!
//! **What is in the file.**
//! - The body the embedded renderer draws ([`BodyMesh::build`] on the clip's [`Character`],
//!   shaped by the capture's [`Look`] when there is one): one mesh `body`, one primitive per
//!   [`Material`] present (all sharing the `POSITION`, `NORMAL`, `JOINTS_0`, `WEIGHTS_0`
//!   accessors), each with a material whose `baseColorFactor` is the look's sRGB colour
//!   converted to linear (a neutral palette, [`DEFAULT_ALBEDO_SRGB`], without a look).
//! - The rig as joints: node `1 + b` is bone `b` (rig order, named as `autoact rig` names them),
//!   nested as the rig's parents say, with its rest head offset as translation. The skin's
//!   inverse bind matrices are translations by minus each bone's rest head (every bone's rest
//!   world rotation is the identity in autoact's frame).
//! - One animation `<track>_v<variant>`: a `rotation` channel per bone (the bag's local
//!   rotations, x y z w) and the root's `translation` (its head in the world), keyed at every
//!   frame, time `k / fps` seconds, `LINEAR`. Quaternions keep one hemisphere from frame to frame
//!   (a sign flip where the bag's changes sign), so that interpolation takes the short way.
//! - For a capture bag (`autoact convert --spec`): a perspective camera on node `camera`, its
//!   `yfov` and `aspectRatio` from the first `/camera/camera_info`, animated with the
//!   `/camera/pose` at every frame's stamp (the optical frame — z forward, x right, y down —
//!   turned by 180° about x into glTF's camera frame: −z forward, y up).
//! - `scenes[0].extras.autoact`: bag, track, variant, fps, frames, the label and seed where the
//!   bag has them, its metadata records, and for a capture bag the clip's scene (`scene_id`,
//!   `scene_index`, and `timeline_first_frame`: the capture frame of the file's frame 0), its
//!   clips (`/segments`, with frame numbers in the file) and the scene's `/scene` state, with the
//!   lighting the embedded renderer derives. A capture bag's export is one file per scene, each
//!   on that scene's character (see [`super::read_clips`]).
//!
//! **Axes.** glTF is +Y up. The scene's one root node `autoact_world` is turned by −90° about x
//! ([`Y_UP_FROM_Z_UP`]), which maps autoact's Z-up `(x, y, z)` to glTF's `(x, z, −y)`; every
//! position and rotation below it (joints, camera) stays in autoact's frame and metres, and
//! Blender's importer, turning glTF back to Z-up, shows exactly autoact's world coordinates. The
//! skinned mesh node sits at the scene root without a transform, as glTF asks (skinned vertices
//! follow the joints, which carry the turn).
//!
//! The output is a pure function of its inputs: two exports of one clip are byte-identical.

use std::collections::BTreeMap;
use std::f32::consts::FRAC_1_SQRT_2;
use std::path::Path;

use gltf_json as json;
use json::accessor::{ComponentType, GenericComponentType, Type};
use json::validation::Checked::Valid;
use json::validation::USize64;
use json::{Index, buffer::Target};
use nalgebra::{Isometry3, UnitQuaternion};
use serde_json::{Value, json};

use super::{Clip, ExportError};
use crate::bags::capture::Capture;
use crate::mcap_io::BagReader;
use crate::scene::body_mesh::{BodyMesh, BodyShape, Material, albedo_srgb};
use crate::scene::cast::Look;
use crate::scene::color::linear_from_srgb;
use crate::scene::environment::Environment;
use crate::skeleton::character::Character;
use crate::skeleton::fk::{self, BonePose, WorldPose};
use crate::skeleton::rig::{ROOT, Rig};

/// Rotation of node `autoact_world`, x y z w: −90° about x, autoact's Z-up → glTF's Y-up.
pub const Y_UP_FROM_Z_UP: [f32; 4] = [-FRAC_1_SQRT_2, 0.0, 0.0, FRAC_1_SQRT_2];

/// Near clipping plane of the exported camera, metres.
pub const CAMERA_ZNEAR_M: f32 = 0.05;

/// sRGB colours per [`Material`] (in [`Material::ALL`] order) when the bag has no [`Look`]:
/// light skin, dark brown hair, a grey-blue shirt, dark trousers, near-black shoes, dark eyes.
pub const DEFAULT_ALBEDO_SRGB: [[f32; 3]; 6] = [
    [0.86, 0.69, 0.58],
    [0.23, 0.16, 0.11],
    [0.38, 0.47, 0.60],
    [0.20, 0.22, 0.26],
    [0.08, 0.08, 0.08],
    crate::scene::body_mesh::EYE_SRGB,
];

/// Index of the joint node of bone `b`.
#[must_use]
pub fn joint_node(bone: usize) -> usize {
    1 + bone
}

/// `.gltf` (JSON, buffer as a data URI) or `.glb` (binary).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Container {
    /// JSON text with the buffer embedded as base64.
    Gltf,
    /// The binary container: header, JSON chunk, BIN chunk.
    Glb,
}

/// The capture's camera, one pose per clip frame.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraPath {
    /// Vertical field of view, radians.
    pub yfov_rad: f64,
    /// Width over height of the field of view.
    pub aspect_ratio: f64,
    /// The optical frame (z forward, x right, y down) in the world, per frame.
    pub world_from_optical: Vec<Isometry3<f64>>,
}

/// What the file carries besides the clip: the camera, the look and the extras.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SceneContext {
    /// The capture's camera (none for a plain animation bag).
    pub camera: Option<CameraPath>,
    /// The character's look (colours, build), from the scene of the clip's first frame (a
    /// capture bag's clip holds one scene).
    pub look: Option<Look>,
    /// `scenes[0].extras.autoact`.
    pub extras: BTreeMap<String, Value>,
}

impl SceneContext {
    /// Reads what the bag at `path` says around `clip`: for a capture bag (one with an
    /// `autoact.dataset` metadata record) the camera, scenes and clips; for every bag the
    /// metadata, the label and the seed where stated.
    ///
    /// # Errors
    /// [`ExportError::Capture`] when a capture bag cannot be read as one,
    /// [`ExportError::NoCameraPose`] when it has no camera pose at one of the clip's frames.
    pub fn read(
        rig: &Rig,
        path: &Path,
        readers: &[BagReader],
        clip: &Clip,
    ) -> Result<SceneContext, ExportError> {
        let mut extras = base_extras(path, clip);
        let mut metadata = BTreeMap::new();
        for r in readers {
            for (name, record) in r.metadata() {
                if name.starts_with(crate::bags::pose::METADATA_NAME) {
                    metadata.insert(name, record);
                }
            }
        }
        let find = |key: &str| metadata.values().find_map(|r| r.get(key).cloned());
        if let Some(label) = find("action").or_else(|| find("label")) {
            extras.insert("label".into(), json!(label));
        }
        if let Some(seed) = find("seed") {
            extras.insert(
                "seed".into(),
                seed.parse::<u64>()
                    .map_or_else(|_| json!(seed), |s| json!(s)),
            );
        }
        let is_capture = metadata.contains_key(crate::bags::capture::METADATA_NAME);
        extras.insert("metadata".into(), json!(metadata));
        if !is_capture {
            return Ok(SceneContext {
                camera: None,
                look: None,
                extras,
            });
        }
        let capture = Capture::read(rig, path).map_err(|source| ExportError::Capture {
            path: path.to_path_buf(),
            key: clip.key,
            source: Box::new(source),
        })?;
        let mut world_from_optical = Vec::with_capacity(clip.stamps_nanos.len());
        let mut at = Vec::with_capacity(clip.stamps_nanos.len());
        for &stamp in &clip.stamps_nanos {
            at.push(
                capture
                    .stamps
                    .position(stamp)
                    .ok_or_else(|| ExportError::NoCameraPose {
                        path: path.to_path_buf(),
                        key: clip.key,
                        stamp_nanos: stamp,
                    })?,
            );
        }
        // The clip's stretch of the capture, read for its cameras alone.
        let frames = capture
            .frames_at(rig, &at)
            .map_err(|source| ExportError::Capture {
                path: path.to_path_buf(),
                key: clip.key,
                source: Box::new(source),
            })?;
        world_from_optical.extend(frames.iter().map(|f| f.world_from_optical));
        let i = &capture.intrinsics;
        let camera = CameraPath {
            yfov_rad: 2.0 * (f64::from(i.height_px) / (2.0 * i.fy_px)).atan(),
            aspect_ratio: (f64::from(i.width_px) / i.fx_px) / (f64::from(i.height_px) / i.fy_px),
            world_from_optical,
        };
        capture_extras(&capture, clip, &mut extras);
        let first = clip.stamps_nanos.first().copied().unwrap_or(0);
        let look = capture
            .stamps
            .get(capture.stamps.count_before(first))
            .map(|t| capture.scenes[capture.scene_at(t)].scene.look.clone());
        Ok(SceneContext {
            camera: Some(camera),
            look,
            extras,
        })
    }
}

/// The extras a capture bag adds around `clip`: its scene (id, index, first capture frame), the
/// clips (`/segments`) it overlaps with frame numbers in the file (and the label when they share
/// one), and the scene's state with the lighting the embedded renderer derives.
fn capture_extras(capture: &Capture, clip: &Clip, extras: &mut BTreeMap<String, Value>) {
    let frame_of = |stamp: u64| clip.stamps_nanos.partition_point(|&s| s < stamp);
    let segments: Vec<Value> = capture
        .segments
        .iter()
        .filter_map(|s| {
            let (start, end) = (s.start.to_nanos()?, s.end.to_nanos()?);
            let (first, last) = (*clip.stamps_nanos.first()?, *clip.stamps_nanos.last()?);
            (start <= last && end > first).then(|| {
                json!({
                    "id": s.id, "action": s.action, "label_id": s.label_id,
                    "category": s.category, "animation": s.animation, "variant": s.variant,
                    "scene_id": s.scene_id, "viewpoint": s.viewpoint,
                    "start_frame": frame_of(start), "end_frame": frame_of(end),
                })
            })
        })
        .collect();
    let mut actions: Vec<&str> = segments
        .iter()
        .filter_map(|s| s["action"].as_str())
        .collect();
    actions.sort_unstable();
    actions.dedup();
    if let [only] = actions[..] {
        extras.insert("label".into(), json!(only));
    }
    // A clip holds the frames of one scene: its extras describe that scene.
    let scenes: Vec<Value> = capture
        .scenes
        .iter()
        .filter(|s| clip.scene.as_ref().is_none_or(|c| c.scene_id == s.scene_id))
        .map(|s| {
            let env = Environment::from_scene(&s.scene, s.stream);
            json!({
                "scene_id": s.scene_id,
                "stream": s.stream,
                "start_frame": frame_of(s.start_nanos),
                "lighting": {
                    "key_dir_world": env.key_dir, "key_rgb_linear": env.key_rgb,
                    "zenith_rgb_linear": env.zenith_rgb, "horizon_rgb_linear": env.horizon_rgb,
                    "sky_ambient_rgb_linear": env.sky_ambient_rgb, "fog_per_m": env.fog_per_m,
                    "indoor": env.indoor,
                },
                "scene": s.scene,
            })
        })
        .collect();
    if let Some(scene) = &clip.scene {
        extras.insert("scene_id".into(), json!(scene.scene_id));
        extras.insert("scene_index".into(), json!(scene.index));
        extras.insert(
            "timeline_first_frame".into(),
            json!(scene.first_timeline_frame),
        );
    }
    extras.insert("session".into(), json!(capture.session));
    extras.insert("segments".into(), Value::Array(segments));
    extras.insert("scenes".into(), Value::Array(scenes));
}

/// The extras every export has: bag, track, variant, fps, frames, first stamp.
fn base_extras(path: &Path, clip: &Clip) -> BTreeMap<String, Value> {
    let bag = crate::file_name(path);
    let mut extras = BTreeMap::new();
    extras.insert("bag".into(), json!(bag));
    extras.insert("track".into(), json!(clip.key.track_id));
    extras.insert("variant".into(), json!(clip.key.variant));
    extras.insert("fps".into(), json!(clip.fps_hz));
    extras.insert("frames".into(), json!(clip.poses.len()));
    extras.insert(
        "first_stamp_ns".into(),
        json!(clip.stamps_nanos.first().copied().unwrap_or(0)),
    );
    extras.insert(
        "axes".into(),
        json!("autoact frame (metres, +Z up) under node autoact_world, turned -90 deg about x to glTF's +Y up"),
    );
    extras
}

/// The glTF of `clip` with `context`, as `container`.
///
/// # Panics
/// Only on an internal bug: the JSON of a glTF document always serialises.
#[must_use]
pub fn write(rig: &Rig, clip: &Clip, context: &SceneContext, container: Container) -> Vec<u8> {
    let mut b = Builder::default();
    // The body the renderer draws: the scene's look on the rig when the bag has one (a capture),
    // else the body the bag's rest offsets describe.
    let looked = context.look.as_ref().map(|look| look.character(rig));
    let character = looked.as_ref().unwrap_or(&clip.character);
    let rest = fk::forward(rig, character, &BonePose::rest(rig), 1.0);
    let shape = context
        .look
        .as_ref()
        .map_or_else(BodyShape::standard, BodyShape::from_look);
    let body = BodyMesh::build(rig, character, &shape);

    // Node 0: the Z-up → Y-up turn; nodes 1..=n: the joints.
    let camera_node = context
        .camera
        .as_ref()
        .map(|_| joint_node(rig.bones.len()) + 1);
    joint_nodes(&mut b, rig, character, &rest, camera_node);
    let skin = skin(&mut b, rig, &rest);

    // The mesh: shared attributes, one primitive per material.
    let mesh = mesh(&mut b, &body, context.look.as_ref());
    let mesh_node = b.root.push(json::Node {
        name: Some("body".into()),
        mesh: Some(mesh),
        skin: Some(skin),
        ..Default::default()
    });

    if let Some(path) = &context.camera {
        let node = camera(&mut b, path);
        debug_assert_eq!(Some(node.value()), camera_node);
    }

    animation(
        &mut b,
        rig,
        clip,
        &rest,
        context.camera.as_ref(),
        camera_node,
    );

    let scene = b.root.push(json::Scene {
        extensions: None,
        extras: Some(raw(&json!({ "autoact": context.extras }))),
        name: Some("autoact".into()),
        nodes: vec![Index::new(0), mesh_node],
    });
    b.root.scene = Some(scene);
    b.root.asset = json::Asset {
        generator: Some(format!("autoact {}", env!("CARGO_PKG_VERSION"))),
        ..Default::default()
    };
    b.finish(container)
}

/// Node 0, `autoact_world` (the Z-up → Y-up turn, parent of the root joint and of the camera
/// node when there is one), then one node per joint at its rest translation from its parent.
fn joint_nodes(
    b: &mut Builder,
    rig: &Rig,
    character: &Character,
    rest: &WorldPose,
    camera_node: Option<usize>,
) {
    let n = rig.bones.len();
    let mut world_children = vec![Index::new(to_u32(joint_node(ROOT)))];
    world_children.extend(camera_node.map(|c| Index::new(to_u32(c))));
    b.root.nodes.push(json::Node {
        name: Some("autoact_world".into()),
        rotation: Some(json::scene::UnitQuaternion(Y_UP_FROM_Z_UP)),
        children: Some(world_children),
        ..Default::default()
    });
    for (i, bone) in rig.bones.iter().enumerate() {
        let children: Vec<Index<json::Node>> = (0..n)
            .filter(|&c| rig.bones[c].parent == Some(i))
            .map(|c| Index::new(to_u32(joint_node(c))))
            .collect();
        let translation = match bone.parent {
            None => rest.heads_m[i].coords,
            Some(_) => character.head_offset_m[i],
        };
        b.root.nodes.push(json::Node {
            name: Some(bone.name.clone()),
            translation: Some(f32x3(&translation)),
            children: (!children.is_empty()).then_some(children),
            ..Default::default()
        });
    }
}

/// The skin over the joint nodes: inverse bind matrices from the rest pose's bone heads.
fn skin(b: &mut Builder, rig: &Rig, rest: &WorldPose) -> Index<json::Skin> {
    let ibm: Vec<f32> = rest
        .heads_m
        .iter()
        .flat_map(|h| {
            let mut m = [0.0_f32; 16];
            m[0] = 1.0;
            m[5] = 1.0;
            m[10] = 1.0;
            m[15] = 1.0;
            let t = f32x3(&h.coords);
            m[12] = -t[0];
            m[13] = -t[1];
            m[14] = -t[2];
            m
        })
        .collect();
    let ibm = b.accessor_f32(&ibm, Type::Mat4, None, false);
    b.root.push(json::Skin {
        extensions: None,
        extras: None,
        inverse_bind_matrices: Some(ibm),
        joints: (0..rig.bones.len())
            .map(|j| Index::new(to_u32(joint_node(j))))
            .collect(),
        name: Some("rig".into()),
        skeleton: Some(Index::new(to_u32(joint_node(ROOT)))),
    })
}

/// The perspective camera of `path` and its node, placed at the path's first pose; returns the
/// node.
fn camera(b: &mut Builder, path: &CameraPath) -> Index<json::Node> {
    let camera = b.root.push(json::Camera {
        name: Some("camera".into()),
        orthographic: None,
        perspective: Some(json::camera::Perspective {
            aspect_ratio: Some(to_f32(path.aspect_ratio)),
            yfov: to_f32(path.yfov_rad),
            zfar: None,
            znear: CAMERA_ZNEAR_M,
            extensions: None,
            extras: None,
        }),
        type_: Valid(json::camera::Type::Perspective),
        extensions: None,
        extras: None,
    });
    let first = path.world_from_optical.first().copied().unwrap_or_default();
    b.root.push(json::Node {
        name: Some("camera".into()),
        camera: Some(camera),
        translation: Some(f32x3(&first.translation.vector)),
        rotation: Some(json::scene::UnitQuaternion(quat(&gltf_camera_rotation(
            &first.rotation,
        )))),
        ..Default::default()
    })
}

/// The glTF camera node's rotation for an optical frame: glTF cameras look down −z with +y up,
/// the optical frame down +z with +y down, so the camera frame is the optical one turned by 180°
/// about its x axis.
#[must_use]
pub fn gltf_camera_rotation(world_from_optical: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    world_from_optical
        * UnitQuaternion::from_axis_angle(&nalgebra::Vector3::x_axis(), std::f64::consts::PI)
}

fn mesh(b: &mut Builder, body: &BodyMesh, look: Option<&Look>) -> Index<json::Mesh> {
    let positions: Vec<f32> = body.rest_positions_m.iter().flatten().copied().collect();
    let normals: Vec<f32> = body.rest_normals.iter().flatten().copied().collect();
    let weights: Vec<f32> = body.weights.iter().flatten().copied().collect();
    let joints: Vec<u8> = body
        .joints
        .iter()
        .flatten()
        .flat_map(|j| j.to_le_bytes())
        .collect();
    let position = b.accessor_f32(&positions, Type::Vec3, Some(Target::ArrayBuffer), true);
    let normal = b.accessor_f32(&normals, Type::Vec3, Some(Target::ArrayBuffer), false);
    let joints_view = b.view(&joints, Some(Target::ArrayBuffer));
    let joints = b.accessor(
        joints_view,
        body.joints.len(),
        ComponentType::U16,
        Type::Vec4,
        None,
    );
    let weight = b.accessor_f32(&weights, Type::Vec4, Some(Target::ArrayBuffer), false);
    let mut primitives = Vec::new();
    for (slot, material) in Material::ALL.into_iter().enumerate() {
        let indices: Vec<u8> = body
            .indices
            .chunks_exact(3)
            .filter(|t| body.materials[t[0] as usize] == material)
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        if indices.is_empty() {
            continue;
        }
        let srgb = look.map_or(DEFAULT_ALBEDO_SRGB[slot], |l| albedo_srgb(l, material));
        let [r, g, bl] = linear_from_srgb(srgb);
        let material_index = b.root.push(json::Material {
            name: Some(material.name().into()),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor([r, g, bl, 1.0]),
                metallic_factor: json::material::StrengthFactor(0.0),
                roughness_factor: json::material::StrengthFactor(0.8),
                ..Default::default()
            },
            ..Default::default()
        });
        let count = indices.len() / 4;
        let view = b.view(&indices, Some(Target::ElementArrayBuffer));
        let indices = b.accessor(view, count, ComponentType::U32, Type::Scalar, None);
        let mut attributes = BTreeMap::new();
        attributes.insert(Valid(json::mesh::Semantic::Positions), position);
        attributes.insert(Valid(json::mesh::Semantic::Normals), normal);
        attributes.insert(Valid(json::mesh::Semantic::Joints(0)), joints);
        attributes.insert(Valid(json::mesh::Semantic::Weights(0)), weight);
        primitives.push(json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: None,
            indices: Some(indices),
            material: Some(material_index),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        });
    }
    b.root.push(json::Mesh {
        extensions: None,
        extras: None,
        name: Some("body".into()),
        primitives,
        weights: None,
    })
}

fn animation(
    b: &mut Builder,
    rig: &Rig,
    clip: &Clip,
    rest: &fk::WorldPose,
    camera: Option<&CameraPath>,
    camera_node: Option<usize>,
) {
    #[expect(clippy::cast_precision_loss, reason = "frame counts far below 2^24")]
    let times: Vec<f32> = (0..clip.poses.len())
        .map(|k| to_f32(k as f64 / clip.fps_hz))
        .collect();
    let input = b.accessor_f32(&times, Type::Scalar, None, true);
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    let mut channel =
        |b: &mut Builder, node: usize, path: json::animation::Property, data: &[f32], ty: Type| {
            let output = b.accessor_f32(data, ty, None, false);
            samplers.push(json::animation::Sampler {
                extensions: None,
                extras: None,
                input,
                interpolation: Valid(json::animation::Interpolation::Linear),
                output,
            });
            channels.push(json::animation::Channel {
                sampler: Index::new(to_u32(samplers.len() - 1)),
                target: json::animation::Target {
                    extensions: None,
                    extras: None,
                    node: Index::new(to_u32(node)),
                    path: Valid(path),
                },
                extensions: None,
                extras: None,
            });
        };
    for bone in 0..rig.bones.len() {
        let rotations = continuous(clip.poses.iter().map(|p| p.local_rotations[bone]));
        let data: Vec<f32> = rotations.iter().flat_map(quat).collect();
        channel(
            b,
            joint_node(bone),
            json::animation::Property::Rotation,
            &data,
            Type::Vec4,
        );
    }
    let root_rest = rest.heads_m[ROOT].coords;
    let data: Vec<f32> = clip
        .poses
        .iter()
        .flat_map(|p| f32x3(&(root_rest + p.root_translation_m)))
        .collect();
    channel(
        b,
        joint_node(ROOT),
        json::animation::Property::Translation,
        &data,
        Type::Vec3,
    );
    if let (Some(path), Some(node)) = (camera, camera_node) {
        let translations: Vec<f32> = path
            .world_from_optical
            .iter()
            .flat_map(|p| f32x3(&p.translation.vector))
            .collect();
        let rotations = continuous(
            path.world_from_optical
                .iter()
                .map(|p| gltf_camera_rotation(&p.rotation)),
        );
        let rotations: Vec<f32> = rotations.iter().flat_map(quat).collect();
        channel(
            b,
            node,
            json::animation::Property::Translation,
            &translations,
            Type::Vec3,
        );
        channel(
            b,
            node,
            json::animation::Property::Rotation,
            &rotations,
            Type::Vec4,
        );
    }
    b.root.push(json::Animation {
        extensions: None,
        extras: None,
        channels,
        name: Some(format!("track{}_v{}", clip.key.track_id, clip.key.variant)),
        samplers,
    });
}

/// `rotations` with each sign chosen to be in the previous one's hemisphere (`q` and `−q` are
/// the same rotation; LINEAR interpolation between opposite signs would take the long way).
fn continuous(rotations: impl Iterator<Item = UnitQuaternion<f64>>) -> Vec<UnitQuaternion<f64>> {
    let mut out: Vec<UnitQuaternion<f64>> = Vec::new();
    for q in rotations {
        let q = out.last().map_or(q, |previous| {
            crate::skeleton::geom::align_hemisphere(q, previous)
        });
        out.push(q);
    }
    out
}

/// x y z w.
fn quat(q: &UnitQuaternion<f64>) -> [f32; 4] {
    let c = q.coords;
    [to_f32(c.x), to_f32(c.y), to_f32(c.z), to_f32(c.w)]
}

fn f32x3(v: &nalgebra::Vector3<f64>) -> [f32; 3] {
    [to_f32(v.x), to_f32(v.y), to_f32(v.z)]
}

#[expect(
    clippy::cast_possible_truncation,
    reason = "glTF stores f32; metres and radians of a body"
)]
fn to_f32(v: f64) -> f32 {
    v as f32
}

fn to_u32(i: usize) -> u32 {
    u32::try_from(i).unwrap_or(u32::MAX)
}

fn raw(v: &Value) -> Box<serde_json::value::RawValue> {
    serde_json::value::to_raw_value(v).unwrap_or_default()
}

/// The document and its one binary buffer, growing together.
#[derive(Default)]
struct Builder {
    root: json::Root,
    bin: Vec<u8>,
}

impl Builder {
    /// A buffer view of `bytes`, starting 4-byte aligned.
    fn view(&mut self, bytes: &[u8], target: Option<Target>) -> Index<json::buffer::View> {
        pad(&mut self.bin, 0);
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.root.push(json::buffer::View {
            buffer: Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: target.map(Valid),
            extensions: None,
            extras: None,
        })
    }

    fn accessor(
        &mut self,
        view: Index<json::buffer::View>,
        count: usize,
        component: ComponentType,
        ty: Type,
        min_max: Option<(Value, Value)>,
    ) -> Index<json::Accessor> {
        let (min, max) = min_max.unzip();
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(GenericComponentType(component)),
            extensions: None,
            extras: None,
            type_: Valid(ty),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    /// An f32 accessor of `data` (`ty`'s components per element), with per-component min and
    /// max when `bounds`.
    fn accessor_f32(
        &mut self,
        data: &[f32],
        ty: Type,
        target: Option<Target>,
        bounds: bool,
    ) -> Index<json::Accessor> {
        let width = ty.multiplicity();
        let min_max = bounds.then(|| {
            let mut min = vec![f32::INFINITY; width];
            let mut max = vec![f32::NEG_INFINITY; width];
            for element in data.chunks_exact(width) {
                for (c, &v) in element.iter().enumerate() {
                    min[c] = min[c].min(v);
                    max[c] = max[c].max(v);
                }
            }
            (json!(min), json!(max))
        });
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, target);
        self.accessor(view, data.len() / width, ComponentType::F32, ty, min_max)
    }

    fn finish(mut self, container: Container) -> Vec<u8> {
        pad(&mut self.bin, 0);
        let uri = match container {
            Container::Gltf => Some(format!(
                "data:application/octet-stream;base64,{}",
                base64(&self.bin)
            )),
            Container::Glb => None,
        };
        self.root.push(json::Buffer {
            byte_length: USize64::from(self.bin.len()),
            name: None,
            uri,
            extensions: None,
            extras: None,
        });
        #[expect(
            clippy::expect_used,
            reason = "serialising a glTF document to JSON cannot fail"
        )]
        let mut text = match container {
            Container::Gltf => self.root.to_vec_pretty(),
            Container::Glb => self.root.to_vec(),
        }
        .expect("internal bug: the glTF JSON does not serialise");
        match container {
            Container::Gltf => {
                text.push(b'\n');
                text
            }
            Container::Glb => glb(text, self.bin),
        }
    }
}

/// Pads `bytes` with `fill` to a multiple of 4.
fn pad(bytes: &mut Vec<u8>, fill: u8) {
    while !bytes.len().is_multiple_of(4) {
        bytes.push(fill);
    }
}

/// The GLB container: 12-byte header (`glTF`, version 2, total length), the JSON chunk padded
/// with spaces, the BIN chunk padded with zeros, every chunk 4-byte aligned.
fn glb(mut json_text: Vec<u8>, mut bin: Vec<u8>) -> Vec<u8> {
    pad(&mut json_text, b' ');
    pad(&mut bin, 0);
    let total = 12 + 8 + json_text.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2_u32.to_le_bytes());
    out.extend_from_slice(&to_u32(total).to_le_bytes());
    out.extend_from_slice(&to_u32(json_text.len()).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_text);
    out.extend_from_slice(&to_u32(bin.len()).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// Standard base64 with padding (RFC 4648 §4).
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = u32::from(b[0]) << 16 | u32::from(b[1]) << 8 | u32::from(b[2]);
        for (i, shift) in [18, 12, 6, 0].into_iter().enumerate() {
            if i <= chunk.len() {
                out.push(char::from(ALPHABET[(n >> shift) as usize & 63]));
            } else {
                out.push('=');
            }
        }
    }
    out
}

#[cfg(test)]
#[path = "gltf_tests.rs"]
mod tests;
