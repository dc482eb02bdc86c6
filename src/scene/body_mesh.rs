//! The character's body as a skinned triangle mesh: generated from the rig and a [`Character`],
//! posed by forward kinematics with linear blend skinning. The embedded renderer and the glTF
//! exporter both draw this body, so it is built here once.
//!
//! # What the body is
//! A low-poly clothed figure made of closed, overlapping surfaces ([`BodyMesh::parts`]):
//! - `torso`: one tube from the crotch over the pelvis and spine to the neck, wider at the hips
//!   and chest than at the waist, ending inside the head;
//! - `head`: an ellipsoid (scaled by the head bone's scale) with a nose, face skin and a hair
//!   cap on the top and back; `l_eye`, `r_eye` (dark) and `l_ear`, `r_ear` (skin): small
//!   ellipsoids on the head where the rays from its centre through the rig's eye and ear
//!   landmarks (COCO's face keypoints) meet it; `l_brow`, `r_brow` (hair) above the eyes and
//!   `mouth` (dark) below the nose, laid on the head from the eye landmarks; the hair in one of
//!   [`HairStyle`]'s cuts (the cap's hairline on the head, and `hair` — a mass down the back
//!   for long hair —, `ponytail` or `bun`);
//! - `l_arm`, `r_arm`: one tube each from inside the chest along clavicle, upper arm, forearm
//!   and hand, flattening into a palm that ends just past the knuckles; `l_thumb`, `r_thumb`
//!   and `l_index` … `r_pinky`: a tube per finger along the rig's three bones of that finger,
//!   so a curled or spread finger is drawn where its bones (and its landmarks) are;
//! - `l_leg`, `r_leg`: one tube each from inside the pelvis along thigh and calf to the ankle;
//! - `l_shoe`, `r_shoe`: flat-soled shoes along the feet.
//!
//! Limb tubes are continuous along their bone chains; the rings near a joint are weighted
//! between the two bones (50/50 at the joint, fading over [`JOINT_BLEND`] of each bone's
//! length), so a bent knee or elbow stays closed. Short sleeves: the upper arm is
//! [`Material::Top`] and the forearm skin; the pelvis and legs are [`Material::Bottom`].
//! Lengths come from the character's rest skeleton; widths scale with its stature (the head
//! with its head bone, hands and feet with theirs) and with [`BodyShape::girth_scale`].
//!
//! The standard adult has 3,316 triangles and 1,787 vertices; long hair adds 80 triangles, a
//! ponytail or a bun 64.
//! Every body stays under [`MAX_TRIANGLES`].
//!
//! # Conventions
//! - Positions are in the autoact frame ([`crate::skeleton::frames`]): metres, +Z up, the rest pose
//!   stands on `z = 0` facing +Y, +X is the body's right.
//! - Triangles wind counter-clockwise seen from outside; every part is closed (each edge is
//!   shared by exactly two triangles once vertices at the same position are welded) and
//!   encloses a positive volume. Parts overlap, so draw with a depth buffer.
//! - A vertex belongs to one material. Where two materials meet (sleeve, waistband, collar,
//!   hairline) the vertex is duplicated with the same position, normal and weights, so the
//!   seam never opens.
//! - Normals are smooth (area-weighted over each part, across material seams), unit, outward.
//! - Skinning: `x' = Σ_b w_b · (R_b · (x − rest_head_b) + head_b)` with `R_b` the bone's world
//!   rotation relative to rest ([`Skinning`]); normals use the same blended rotation.
//! - The output is a pure function of the rig, the character and the shape: two builds are
//!   identical.

use std::ops::Range;

use nalgebra::Vector3;

use crate::scene::cast::{AgeGroup, Look, Sex};
use crate::skeleton::character::Character;
use crate::skeleton::fk::{self, BonePose, WorldPose};
use crate::skeleton::rig::Rig;

/// The most triangles a body can have (the renderer's budget).
pub const MAX_TRIANGLES: usize = 3_400;

/// Blend fraction at the shoulder (clavicle | upper arm), wider than elsewhere so that the
/// shoulder stays round when the arm hangs down.
const SHOULDER_BLEND: f64 = 0.45;

/// How much further (in chain coordinates) the top of the shoulder stays with the clavicle
/// than the armpit.
const SHOULDER_WEIGHT_SHIFT: f64 = 0.2;

/// Fraction of a bone's length, each side of a joint, over which its rings blend between the
/// parent and the child bone (50/50 at the joint).
pub const JOINT_BLEND: f64 = 0.25;

/// Height of the rig's default adult, metres, which the body's widths are given for.
const STANDARD_HEIGHT_M: f64 = Character::STANDARD_HEIGHT_M;

/// Which surface a vertex belongs to (its colour comes from the [`Look`], see [`albedo_srgb`]).
#[repr(u8)]
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Material {
    /// Face, neck, forearms, hands.
    Skin = 0,
    /// Hair cap and long hair.
    Hair = 1,
    /// Shirt: chest, belly, shoulders, upper arms (short sleeves).
    Top = 2,
    /// Trousers: pelvis and legs.
    Bottom = 3,
    /// Shoes.
    Shoes = 4,
    /// Eyes (iris and pupil, dark at this scale).
    Eye = 5,
}

impl Material {
    /// Every material, in `repr` order.
    pub const ALL: [Material; 6] = [
        Material::Skin,
        Material::Hair,
        Material::Top,
        Material::Bottom,
        Material::Shoes,
        Material::Eye,
    ];

    /// Lower-case name: `skin`, `hair`, `top`, `bottom`, `shoes`, `eye`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Material::Skin => "skin",
            Material::Hair => "hair",
            Material::Top => "top",
            Material::Bottom => "bottom",
            Material::Shoes => "shoes",
            Material::Eye => "eye",
        }
    }
}

/// The sRGB colour (gamma-encoded, `[0, 1]`) of a material for a look: the one place that maps a
/// [`Look`] to surface colours.
#[must_use]
pub fn albedo_srgb(look: &Look, material: Material) -> [f32; 3] {
    match material {
        Material::Skin => look.skin_rgb,
        Material::Hair => look.hair_rgb,
        Material::Top => look.clothing.top_rgb,
        Material::Bottom => look.clothing.bottom_rgb,
        Material::Shoes => look.clothing.shoes_rgb,
        Material::Eye => EYE_SRGB,
    }
}

/// sRGB of the eyes: a dark iris and pupil (the white is too small to show at video sizes).
pub const EYE_SRGB: [f32; 3] = [0.09, 0.065, 0.05];

/// Body shape beyond the skeleton: build and sex-based tweaks. Lengths never change here.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyShape {
    /// Width factor on the torso and limbs relative to the rig's lean adult (BMI 22), as
    /// [`Look::girth_scale`]. Clamped to `[0.6, 1.8]` when the mesh is built.
    pub girth_scale: f64,
    /// Extra width factor on the hips and buttocks (1 = the rig's male figure).
    pub hip_scale: f64,
    /// Extra width factor on the waist.
    pub waist_scale: f64,
    /// Extra width factor on the chest and shoulders.
    pub chest_scale: f64,
    /// Extra forward depth of the chest (bust), metres for the standard height.
    pub bust_depth_m: f64,
    /// How far the hair falls below the bottom of the head at the back, metres for the
    /// standard head (0 = short hair: a cap above the ears and nape); only for
    /// [`HairStyle::Long`].
    pub hair_length_m: f64,
    /// The cut.
    pub hair_style: HairStyle,
}

/// A character's haircut.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum HairStyle {
    /// A cap above the ears and the nape.
    Short,
    /// Down the back, [`BodyShape::hair_length_m`] below the head.
    Long,
    /// Pulled back into a tail from the back of the head.
    Ponytail,
    /// Pulled back into a bun at the back of the head.
    Bun,
    /// Bald on top, a fringe of hair round the sides and back.
    Bald,
}

impl HairStyle {
    /// Every style.
    pub const ALL: [HairStyle; 5] = [
        HairStyle::Short,
        HairStyle::Long,
        HairStyle::Ponytail,
        HairStyle::Bun,
        HairStyle::Bald,
    ];

    /// The style of a drawn look: a draw (keyed by the look's own drawn hair colour, age and
    /// height, so the scene's seeded draw decides it and every engine and export agrees) from
    /// weights by sex and age group — women and girls mostly long, ponytails and buns, older
    /// women mostly short or a bun; men mostly short, older men often bald.
    #[must_use]
    pub fn of(look: &Look) -> HairStyle {
        use HairStyle::{Bald, Bun, Long, Ponytail, Short};
        let key = look.hair_rgb.iter().fold(
            crate::hash::hash2(u64::from(look.age_years), look.height_m.to_bits()),
            |h, c| crate::hash::hash2(h, u64::from(c.to_bits())),
        );
        let weights: &[(HairStyle, u32)] = match (look.sex, look.age_group) {
            (Sex::Female, AgeGroup::Older) => &[(Short, 60), (Bun, 30), (Long, 10)],
            (Sex::Female, _) => &[(Long, 40), (Ponytail, 25), (Bun, 15), (Short, 20)],
            (Sex::Male, AgeGroup::Child) => &[(Short, 85), (Long, 15)],
            (Sex::Male, AgeGroup::Adult) => {
                &[(Short, 70), (Bald, 12), (Long, 8), (Ponytail, 5), (Bun, 5)]
            }
            (Sex::Male, AgeGroup::Older) => &[(Short, 55), (Bald, 45)],
        };
        let total: u32 = weights.iter().map(|w| w.1).sum();
        let mut pick = (key % u64::from(total)) as u32;
        for &(style, w) in weights {
            if pick < w {
                return style;
            }
            pick -= w;
        }
        Short
    }
}

impl BodyShape {
    /// The rig's figure: lean, male proportions, short hair.
    #[must_use]
    pub fn standard() -> BodyShape {
        BodyShape {
            girth_scale: 1.0,
            hip_scale: 1.0,
            waist_scale: 1.0,
            chest_scale: 1.0,
            bust_depth_m: 0.0,
            hair_length_m: 0.0,
            hair_style: HairStyle::Short,
        }
    }

    /// The shape for a drawn look: its girth, and (deterministically, from sex and age group)
    /// wider hips, a narrower waist and chest and a bust for women and girls; children's
    /// figures less marked; the haircut [`HairStyle::of`] the look (long hair longer for women
    /// and girls than for men and older women).
    #[must_use]
    pub fn from_look(look: &Look) -> BodyShape {
        let mut shape = BodyShape {
            girth_scale: look.girth_scale(),
            hair_style: HairStyle::of(look),
            ..BodyShape::standard()
        };
        let mut long: f64 = 0.08;
        if look.sex == Sex::Female {
            let (hips, waist, chest, bust, hair) = match look.age_group {
                AgeGroup::Child => (1.02, 0.97, 0.96, 0.0, 0.12),
                AgeGroup::Adult => (1.07, 0.9, 0.92, 0.022, 0.14),
                AgeGroup::Older => (1.06, 0.95, 0.93, 0.02, 0.04),
            };
            shape.hip_scale = hips;
            shape.waist_scale = waist;
            shape.chest_scale = chest;
            shape.bust_depth_m = bust;
            long = hair;
        }
        if shape.hair_style == HairStyle::Long {
            shape.hair_length_m = long.max(0.06);
        }
        shape
    }
}

impl Default for BodyShape {
    fn default() -> BodyShape {
        BodyShape::standard()
    }
}

/// Why a body mesh cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BodyMeshError {
    /// The rig lacks a bone the body is built on.
    #[error("the rig has no bone `{0}`; the body mesh needs the bones of `Rig::standard`")]
    MissingBone(String),
    /// The character was made for another rig.
    #[error("the character has {character} bone scales but the rig has {rig} bones")]
    CharacterMismatch {
        /// Bones in the character.
        character: usize,
        /// Bones in the rig.
        rig: usize,
    },
}

/// One closed surface of the body: a contiguous run of vertices and triangles.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BodyPart {
    /// `torso`, `head`, `l_eye`, `r_eye`, `l_ear`, `r_ear`, `hair` / `ponytail` / `bun`,
    /// `l_arm`, `r_arm`, the fingers (`l_index` … `r_pinky`),
    /// `l_thumb`, `r_thumb`, `l_leg`, `r_leg`, `l_shoe`, `r_shoe`.
    pub name: &'static str,
    /// Its vertices (indices into the per-vertex arrays).
    pub vertices: Range<usize>,
    /// Its triangles (triangle `t` is `indices[3t..3t + 3]`).
    pub triangles: Range<usize>,
}

/// The skinned body of one character at rest.
///
/// # Invariants
/// The per-vertex arrays have one entry per vertex; every triangle's vertices share a
/// material; weights are ≥ 0, sorted by decreasing weight, sum to 1, and unused slots have
/// joint 0 and weight 0.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyMesh {
    /// Rest positions of this character, autoact frame, metres.
    pub rest_positions_m: Vec<[f32; 3]>,
    /// Rest normals: unit, outward.
    pub rest_normals: Vec<[f32; 3]>,
    /// Up to four rig bone indices per vertex.
    pub joints: Vec<[u16; 4]>,
    /// Their weights.
    pub weights: Vec<[f32; 4]>,
    /// Material per vertex.
    pub materials: Vec<Material>,
    /// Triangles, three vertex indices each, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
    /// The closed parts, in the order their vertices and triangles are stored.
    pub parts: Vec<BodyPart>,
}

/// Per-bone transforms of one frame for [`BodyMesh::skin_into`]:
/// `x' = R_b · (x − rest_head_b) + head_b`, stored as `(R_b − I | t_b)` so that the rest pose
/// reproduces the rest mesh exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct Skinning {
    /// Per bone, row-major 3×4: `[R − I | t]` with `t = head − R · rest_head`.
    bones: Vec<[f32; 12]>,
}

impl Skinning {
    /// The transforms that take the body at `rest` to `posed`. `rest` is the character's rest
    /// pose, `fk::forward(rig, character, &BonePose::rest(rig), 1.0)`, for the same character the
    /// mesh was built for; `posed` is any pose of that character.
    #[must_use]
    pub fn new(rest: &WorldPose, posed: &WorldPose) -> Skinning {
        let mut s = Skinning { bones: Vec::new() };
        s.update(rest, posed);
        s
    }

    /// Recomputes the transforms in place (no allocation once sized).
    pub fn update(&mut self, rest: &WorldPose, posed: &WorldPose) {
        self.bones.clear();
        let bones = rest
            .rotations
            .iter()
            .zip(&rest.heads_m)
            .zip(posed.rotations.iter().zip(&posed.heads_m));
        for ((rest_rot, rest_head), (rot, head)) in bones {
            let r = (rot * rest_rot.inverse()).to_rotation_matrix();
            let m = r.matrix();
            let t = head.coords - m * rest_head.coords;
            #[expect(
                clippy::cast_possible_truncation,
                reason = "the renderer skins in f32 on purpose"
            )]
            let f = |x: f64| x as f32;
            self.bones.push([
                f(m[(0, 0)] - 1.0),
                f(m[(0, 1)]),
                f(m[(0, 2)]),
                f(t.x),
                f(m[(1, 0)]),
                f(m[(1, 1)] - 1.0),
                f(m[(1, 2)]),
                f(t.y),
                f(m[(2, 0)]),
                f(m[(2, 1)]),
                f(m[(2, 2)] - 1.0),
                f(t.z),
            ]);
        }
    }

    /// Number of bones.
    #[must_use]
    pub fn bone_count(&self) -> usize {
        self.bones.len()
    }
}

impl BodyMesh {
    /// Builds the body of `character` on `rig`.
    ///
    /// # Panics
    /// When the rig lacks a bone of [`Rig::standard`] or the character belongs to another rig;
    /// [`BodyMesh::try_build`] reports those as errors.
    #[must_use]
    pub fn build(rig: &Rig, character: &Character, shape: &BodyShape) -> BodyMesh {
        match BodyMesh::try_build(rig, character, shape) {
            Ok(mesh) => mesh,
            Err(e) => panic!("cannot build the body mesh: {e}"),
        }
    }

    /// Builds the body of `character` on `rig`.
    ///
    /// # Errors
    /// [`BodyMeshError`] when the rig lacks a bone the body is built on, or the character has
    /// another number of bones than the rig.
    pub fn try_build(
        rig: &Rig,
        character: &Character,
        shape: &BodyShape,
    ) -> Result<BodyMesh, BodyMeshError> {
        if character.bone_scale.len() != rig.bones.len()
            || character.head_offset_m.len() != rig.bones.len()
        {
            return Err(BodyMeshError::CharacterMismatch {
                character: character.bone_scale.len(),
                rig: rig.bones.len(),
            });
        }
        let skeleton = Skeleton::new(rig, character)?;
        let dims = Dims::new(&skeleton, shape)?;
        let mut parts = vec![
            torso(&skeleton, &dims, shape)?,
            head(&skeleton, &dims, shape)?,
        ];
        parts.extend(face_features(&skeleton, &dims)?);
        match shape.hair_style {
            HairStyle::Long if shape.hair_length_m > 0.03 => {
                parts.push(long_hair(&skeleton, &dims, shape)?);
            }
            HairStyle::Ponytail => parts.push(ponytail(&skeleton, &dims)?),
            HairStyle::Bun => parts.push(bun(&skeleton, &dims)?),
            _ => {}
        }
        for side in [Side::Left, Side::Right] {
            parts.push(arm(&skeleton, &dims, side)?);
            parts.push(thumb(&skeleton, side)?);
            for (finger, radius_m) in FINGERS {
                parts.push(finger_part(&skeleton, side, finger, radius_m)?);
            }
        }
        for side in [Side::Left, Side::Right] {
            parts.push(leg(&skeleton, &dims, side)?);
            parts.push(shoe(&skeleton, side)?);
        }
        Ok(assemble(&parts))
    }

    /// Number of triangles.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Number of vertices.
    #[must_use]
    pub fn vertex_count(&self) -> usize {
        self.rest_positions_m.len()
    }

    /// Linear blend skinning into caller-owned buffers (resized to one entry per vertex and
    /// overwritten; no allocation after the first call). Normals are renormalised when
    /// blending changed their length.
    ///
    /// # Panics
    /// When `skinning` has fewer bones than the mesh's joints refer to (another rig).
    pub fn skin_into(
        &self,
        skinning: &Skinning,
        positions_m: &mut Vec<[f32; 3]>,
        normals: &mut Vec<[f32; 3]>,
    ) {
        let n = self.rest_positions_m.len();
        // Sized once; every entry is overwritten below.
        positions_m.resize(n, [0.0; 3]);
        normals.resize(n, [0.0; 3]);
        let sources = self
            .rest_positions_m
            .iter()
            .zip(&self.rest_normals)
            .zip(self.joints.iter().zip(&self.weights));
        let targets = positions_m.iter_mut().zip(normals.iter_mut());
        for (((p, n), (joints, weights)), (out_p, out_n)) in sources.zip(targets) {
            let mut m = [0.0f32; 12];
            for (&j, &w) in joints.iter().zip(weights) {
                if w <= 0.0 {
                    break;
                }
                let b = &skinning.bones[usize::from(j)];
                for (acc, x) in m.iter_mut().zip(b) {
                    *acc += w * x;
                }
            }
            *out_p = [
                p[0] + m[0] * p[0] + m[1] * p[1] + m[2] * p[2] + m[3],
                p[1] + m[4] * p[0] + m[5] * p[1] + m[6] * p[2] + m[7],
                p[2] + m[8] * p[0] + m[9] * p[1] + m[10] * p[2] + m[11],
            ];
            let mut q = [
                n[0] + m[0] * n[0] + m[1] * n[1] + m[2] * n[2],
                n[1] + m[4] * n[0] + m[5] * n[1] + m[6] * n[2],
                n[2] + m[8] * n[0] + m[9] * n[1] + m[10] * n[2],
            ];
            let len2 = q[0] * q[0] + q[1] * q[1] + q[2] * q[2];
            if (len2 - 1.0).abs() > 1e-6 && len2 > 0.0 {
                let inv = len2.sqrt().recip();
                q = q.map(|c| c * inv);
            }
            *out_n = q;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The character's rest skeleton and the widths derived from it.
// ---------------------------------------------------------------------------------------------

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Side {
    Left,
    Right,
}

impl Side {
    fn name(self, bone: &str) -> String {
        match self {
            Side::Left => format!("l_{bone}"),
            Side::Right => format!("r_{bone}"),
        }
    }

    fn part(self, left: &'static str, right: &'static str) -> &'static str {
        match self {
            Side::Left => left,
            Side::Right => right,
        }
    }
}

/// The character at rest: bone heads and tails, scales, landmarks used for sizing.
struct Skeleton<'a> {
    rig: &'a Rig,
    character: &'a Character,
    rest: WorldPose,
    /// Height of the top of the head, metres.
    stature_m: f64,
    /// Top of the head.
    head_top: Vector3<f64>,
}

impl<'a> Skeleton<'a> {
    fn new(rig: &'a Rig, character: &'a Character) -> Result<Skeleton<'a>, BodyMeshError> {
        let rest = fk::forward(rig, character, &BonePose::rest(rig), 1.0);
        let head = bone(rig, "head")?;
        let head_top = match rig.landmark_index("head_top") {
            Some(l) if l < character.landmark_offset_m.len() => {
                fk::landmark_position(rig, character, &rest, l).coords
            }
            _ => tail_of(rig, character, &rest, head),
        };
        Ok(Skeleton {
            rig,
            character,
            rest,
            stature_m: head_top.z,
            head_top,
        })
    }

    fn index(&self, name: &str) -> Result<usize, BodyMeshError> {
        bone(self.rig, name)
    }

    fn head(&self, b: usize) -> Vector3<f64> {
        self.rest.heads_m[b].coords
    }

    fn tail(&self, b: usize) -> Vector3<f64> {
        tail_of(self.rig, self.character, &self.rest, b)
    }

    fn scale(&self, b: usize) -> f64 {
        self.character.bone_scale[b]
    }
}

fn bone(rig: &Rig, name: &str) -> Result<usize, BodyMeshError> {
    rig.bone_index(name)
        .ok_or_else(|| BodyMeshError::MissingBone(name.to_string()))
}

/// Rest tail of a bone in the character: its head plus its scaled rig offset.
fn tail_of(rig: &Rig, character: &Character, rest: &WorldPose, b: usize) -> Vector3<f64> {
    let bone = &rig.bones[b];
    rest.heads_m[b].coords + (bone.tail_rest_m - bone.head_rest_m) * character.bone_scale[b]
}

/// Width factors (multiply the standard adult's metres).
struct Dims {
    /// Stature relative to the standard adult.
    size: f64,
    /// Girth relative to the rig's lean adult.
    girth: f64,
    /// The head bone's scale.
    head: f64,
}

impl Dims {
    fn new(skeleton: &Skeleton<'_>, shape: &BodyShape) -> Result<Dims, BodyMeshError> {
        let size = (skeleton.stature_m / STANDARD_HEIGHT_M).max(0.1);
        let girth = if shape.girth_scale.is_finite() {
            shape.girth_scale.clamp(0.6, 1.8)
        } else {
            1.0
        };
        let head = skeleton.scale(skeleton.index("head")?).abs();
        Ok(Dims { size, girth, head })
    }

    /// Size times girth to the power `exponent`: how much a region widens with build (the
    /// belly most, forearms and calves least).
    fn width(&self, exponent: f64) -> f64 {
        self.size * self.girth.powf(exponent)
    }
}

/// Linear interpolation of `a → b` as `x` runs `x0 → x1`, clamped.
fn ramp(x: f64, x0: f64, x1: f64, a: f64, b: f64) -> f64 {
    a + (b - a) * ((x - x0) / (x1 - x0)).clamp(0.0, 1.0)
}

// ---------------------------------------------------------------------------------------------
// Geometry building blocks: influences, chains, tubes.
// ---------------------------------------------------------------------------------------------

/// Up to four `(bone, weight)` pairs.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Influences {
    entries: [(u16, f64); 4],
    len: usize,
}

impl Influences {
    fn single(bone: usize) -> Influences {
        let mut s = Influences {
            entries: [(0, 0.0); 4],
            len: 0,
        };
        s.add(bone, 1.0);
        s
    }

    /// Equal shares of several bones.
    fn shared(bones: &[usize]) -> Influences {
        let mut s = Influences {
            entries: [(0, 0.0); 4],
            len: 0,
        };
        #[expect(clippy::cast_precision_loss, reason = "at most four bones")]
        let w = 1.0 / bones.len().max(1) as f64;
        for &b in bones {
            s.add(b, w);
        }
        s
    }

    fn add(&mut self, bone: usize, w: f64) {
        if w <= 1e-12 {
            return;
        }
        let bone = u16::try_from(bone).unwrap_or(u16::MAX);
        if let Some(e) = self.entries[..self.len].iter_mut().find(|e| e.0 == bone) {
            e.1 += w;
        } else if self.len < 4 {
            self.entries[self.len] = (bone, w);
            self.len += 1;
        } else if let Some(min) = self.entries.iter_mut().min_by(|a, b| a.1.total_cmp(&b.1))
            && min.1 < w
        {
            // A fifth bone (the chains here never blend more than four): keep the heaviest.
            *min = (bone, w);
        }
    }

    /// `(1 − t) · a + t · b`.
    fn mix(a: &Influences, b: &Influences, t: f64) -> Influences {
        let mut s = Influences {
            entries: [(0, 0.0); 4],
            len: 0,
        };
        for &(bone, w) in &a.entries[..a.len] {
            s.add(usize::from(bone), w * (1.0 - t));
        }
        for &(bone, w) in &b.entries[..b.len] {
            s.add(usize::from(bone), w * t);
        }
        s
    }

    /// Joints and weights sorted by decreasing weight, normalised, unused slots `(0, 0)`.
    fn packed(&self) -> ([u16; 4], [f32; 4]) {
        let mut e = self.entries;
        e[..self.len].sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        let total: f64 = e[..self.len].iter().map(|x| x.1).sum();
        let mut joints = [0u16; 4];
        let mut weights = [0.0f32; 4];
        for (k, &(bone, w)) in e[..self.len].iter().enumerate() {
            joints[k] = bone;
            #[expect(clippy::cast_possible_truncation, reason = "weights are stored as f32")]
            let w = (w / total) as f32;
            weights[k] = w;
        }
        (joints, weights)
    }
}

/// `3x² − 2x³` on `[0, 1]`, clamped outside.
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

/// A path along joints with the bones between them: `nodes[k] → nodes[k + 1]` is segment `k`,
/// moved by `segments[k]`. A chain coordinate `c` runs 0 at `nodes[0]`, 1 at `nodes[1]`, … and
/// extrapolates beyond the ends along the end segments.
struct Chain {
    nodes: Vec<Vector3<f64>>,
    segments: Vec<Influences>,
    /// Bone before the first node (blends in over `c < 0`).
    before: Option<Influences>,
    /// Bone after the last node (blends in over `c > n`).
    after: Option<Influences>,
    /// Per joint (`c = 0, 1, …, n`): the fraction of each adjacent segment over which the
    /// joint blends. Adjacent joints' fractions on a segment sum to at most 1.
    blend: Vec<f64>,
}

impl Chain {
    /// A chain blending every joint over [`JOINT_BLEND`].
    fn new(
        nodes: Vec<Vector3<f64>>,
        segments: Vec<Influences>,
        before: Option<Influences>,
        after: Option<Influences>,
    ) -> Chain {
        debug_assert_eq!(nodes.len(), segments.len() + 1, "internal bug: chain shape");
        let blend = vec![JOINT_BLEND; nodes.len()];
        Chain {
            nodes,
            segments,
            before,
            after,
            blend,
        }
    }

    /// Sets the blend fraction of joint `j`.
    fn with_blend(mut self, j: usize, fraction: f64) -> Chain {
        self.blend[j] = fraction;
        self
    }

    fn segment_of(&self, c: f64) -> (usize, f64) {
        let n = self.segments.len();
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "clamped to the segment range"
        )]
        let k = (c.floor().max(0.0) as usize).min(n - 1);
        #[expect(clippy::cast_precision_loss, reason = "a handful of segments")]
        let f = c - k as f64;
        (k, f)
    }

    fn point(&self, c: f64) -> Vector3<f64> {
        let (k, f) = self.segment_of(c);
        self.nodes[k] + (self.nodes[k + 1] - self.nodes[k]) * f
    }

    fn tangent(&self, c: f64) -> Vector3<f64> {
        let d = self.point(c + 0.02) - self.point(c - 0.02);
        d.try_normalize(1e-12).unwrap_or_else(Vector3::z)
    }

    /// Weights at `c`: one segment's bone, blended 50/50 at each joint and fading over the
    /// joint's blend fraction of the segment each side.
    fn influences(&self, c: f64) -> Influences {
        let n = self.segments.len();
        #[expect(clippy::cast_precision_loss, reason = "a handful of segments")]
        let last = n as f64;
        let odd = |x: f64| x.signum() * smoothstep(x.abs());
        if let Some(before) = &self.before {
            let b = self.blend[0];
            if c < b {
                return Influences::mix(before, &self.segments[0], 0.5 + 0.5 * odd(c / b));
            }
        }
        if let Some(after) = &self.after {
            let b = self.blend[n];
            if c > last - b {
                return Influences::mix(
                    &self.segments[n - 1],
                    after,
                    0.5 + 0.5 * odd((c - last) / b),
                );
            }
        }
        let (k, f) = self.segment_of(c);
        let (lo, hi) = (self.blend[k], self.blend[k + 1]);
        if k > 0 && f < lo {
            return Influences::mix(
                &self.segments[k - 1],
                &self.segments[k],
                0.5 + 0.5 * smoothstep(f / lo),
            );
        }
        if k + 1 < n && f > 1.0 - hi {
            return Influences::mix(
                &self.segments[k],
                &self.segments[k + 1],
                0.5 - 0.5 * smoothstep((1.0 - f) / hi),
            );
        }
        self.segments[k]
    }
}

/// One ring of a tube.
#[derive(Debug, Clone, Copy)]
struct Station {
    /// Chain coordinate.
    c: f64,
    /// Half-width along the ring's `u` axis, metres.
    half_width_m: f64,
    /// Half-depth towards `+v`, metres.
    front_m: f64,
    /// Half-depth towards `−v`, metres.
    back_m: f64,
    /// Offset of the ring's centre from the chain, metres.
    offset_m: Vector3<f64>,
    /// Weights of a ring vertex are taken at `c − weight_shift · v` (`v` its profile
    /// coefficient, +1 at the `+v` side): the `+v` side follows the parent bone longer.
    weight_shift: f64,
}

impl Station {
    fn oval(c: f64, half_width_m: f64, half_depth_m: f64) -> Station {
        Station {
            c,
            half_width_m,
            front_m: half_depth_m,
            back_m: half_depth_m,
            offset_m: Vector3::zeros(),
            weight_shift: 0.0,
        }
    }

    fn scaled(mut self, k: f64) -> Station {
        self.half_width_m *= k;
        self.front_m *= k;
        self.back_m *= k;
        self
    }
}

/// A tube's closing point: chain coordinate and offset.
#[derive(Debug, Clone, Copy)]
struct Pole {
    c: f64,
    offset_m: Vector3<f64>,
}

impl Pole {
    fn at(c: f64) -> Pole {
        Pole {
            c,
            offset_m: Vector3::zeros(),
        }
    }
}

/// Unit ring points, counter-clockwise about the tube's direction: `(u, v)` coefficients.
fn ellipse(n: usize) -> Vec<[f64; 2]> {
    superellipse(n, 2.0)
}

/// Points of `|u|^p + |v|^p = 1`, at evenly spaced parameter angles starting on `+u`.
fn superellipse(n: usize, p: f64) -> Vec<[f64; 2]> {
    (0..n)
        .map(|i| {
            #[expect(clippy::cast_precision_loss, reason = "small counts")]
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            let (s, c) = a.sin_cos();
            let e = 2.0 / p;
            [c.signum() * c.abs().powf(e), s.signum() * s.abs().powf(e)]
        })
        .collect()
}

/// A closed surface under construction (f64, one vertex per position).
struct PartBuilder {
    name: &'static str,
    positions: Vec<Vector3<f64>>,
    influences: Vec<Influences>,
    faces: Vec<([u32; 3], Material)>,
}

impl PartBuilder {
    fn new(name: &'static str) -> PartBuilder {
        PartBuilder {
            name,
            positions: Vec::new(),
            influences: Vec::new(),
            faces: Vec::new(),
        }
    }

    fn vertex(&mut self, p: Vector3<f64>, w: Influences) -> u32 {
        self.positions.push(p);
        self.influences.push(w);
        u32::try_from(self.positions.len() - 1).unwrap_or(u32::MAX)
    }

    fn face(
        &mut self,
        v: [u32; 3],
        material: &impl Fn(usize, &Vector3<f64>) -> Material,
        band: usize,
    ) {
        let c = v
            .iter()
            .map(|&i| self.positions[i as usize])
            .sum::<Vector3<f64>>()
            / 3.0;
        self.faces.push((v, material(band, &c)));
    }

    /// Adds a closed tube: rings at `stations` (increasing `c`) around `chain`, closed by fans
    /// to the two poles. `hint` orients the rings (`v` = `hint` made perpendicular to the
    /// chain, `u = v × t`). `material(band, centroid)` colours the faces of band 0 (start
    /// fan), `k` (between rings `k − 1` and `k`) and `stations.len()` (end fan).
    fn tube(
        &mut self,
        chain: &Chain,
        hint: &Vector3<f64>,
        profile: &[[f64; 2]],
        stations: &[Station],
        poles: [Pole; 2],
        material: &impl Fn(usize, &Vector3<f64>) -> Material,
    ) {
        let n = profile.len();
        let mut rings: Vec<u32> = Vec::with_capacity(stations.len() * n);
        for s in stations {
            let t = chain.tangent(s.c);
            let v = (hint - t * hint.dot(&t))
                .try_normalize(1e-9)
                .unwrap_or_else(|| t.cross(&Vector3::x()).normalize());
            let u = v.cross(&t);
            let centre = chain.point(s.c) + s.offset_m;
            let ring_weights = chain.influences(s.c);
            for &[pu, pv] in profile {
                let depth = if pv >= 0.0 { s.front_m } else { s.back_m };
                let p = centre + u * (pu * s.half_width_m) + v * (pv * depth);
                let w = if s.weight_shift == 0.0 {
                    ring_weights
                } else {
                    chain.influences(s.c - s.weight_shift * pv)
                };
                rings.push(self.vertex(p, w));
            }
        }
        let pole = |b: &mut PartBuilder, p: &Pole| {
            b.vertex(chain.point(p.c) + p.offset_m, chain.influences(p.c))
        };
        let start = pole(self, &poles[0]);
        let end = pole(self, &poles[1]);
        let last = stations.len() - 1;
        for i in 0..n {
            let j = (i + 1) % n;
            self.face([rings[j], rings[i], start], material, 0);
        }
        for k in 0..last {
            for i in 0..n {
                let j = (i + 1) % n;
                let (a, b) = (rings[k * n + i], rings[k * n + j]);
                let (c, d) = (rings[(k + 1) * n + j], rings[(k + 1) * n + i]);
                self.face([a, b, c], material, k + 1);
                self.face([a, c, d], material, k + 1);
            }
        }
        for i in 0..n {
            let j = (i + 1) % n;
            self.face(
                [rings[last * n + i], rings[last * n + j], end],
                material,
                last + 1,
            );
        }
    }
}

/// Material of each band of a tube from seam coordinates: bands below `seams[0].0` take
/// `first`, then each seam's material up to the next.
fn banded(stations: &[Station], first: Material, seams: &[(f64, Material)]) -> Vec<Material> {
    let at = |c: f64| {
        seams
            .iter()
            .rev()
            .find(|(s, _)| c >= *s)
            .map_or(first, |(_, m)| *m)
    };
    let mut bands = Vec::with_capacity(stations.len() + 1);
    bands.push(at(stations[0].c - 1e-6));
    for w in stations.windows(2) {
        bands.push(at(0.5 * (w[0].c + w[1].c)));
    }
    bands.push(at(stations[stations.len() - 1].c + 1e-6));
    bands
}

// ---------------------------------------------------------------------------------------------
// The parts. Numbers are the standard adult's (1.75 m, BMI 22), metres, scaled by `Dims`.
// ---------------------------------------------------------------------------------------------

/// Ring resolutions (vertices around).
const TORSO_AROUND: usize = 16;
const HEAD_AROUND: usize = 20;
const HEAD_RINGS: usize = 11;
const ARM_AROUND: usize = 10;
const THUMB_AROUND: usize = 6;
const LEG_AROUND: usize = 12;
const HAIR_AROUND: usize = 8;

/// The torso from the crotch to inside the head; its chain runs pelvis tail (0) → hips (1) →
/// spine1 (2) → spine2 (3) → spine3 (4) → neck (5) → head (6) → top of the head (7).
fn torso(sk: &Skeleton<'_>, dims: &Dims, shape: &BodyShape) -> Result<PartBuilder, BodyMeshError> {
    let bones = [
        "pelvis", "spine0", "spine1", "spine2", "spine3", "neck", "head",
    ];
    let idx = bones
        .iter()
        .map(|b| sk.index(b))
        .collect::<Result<Vec<usize>, BodyMeshError>>()?;
    let mut nodes = vec![sk.tail(idx[0])];
    nodes.extend(idx[1..].iter().map(|&b| sk.head(b)));
    nodes.push(sk.head_top);
    let chain = Chain::new(
        nodes,
        idx.iter().map(|&b| Influences::single(b)).collect(),
        None,
        None,
    );
    let bust = shape.bust_depth_m.clamp(0.0, 0.1) * dims.size;
    // (c, half-width, front, back).
    #[rustfmt::skip]
    let table: [(f64, f64, f64, f64); 15] = [
        (0.05, 0.125, 0.080, 0.090), // crotch
        (0.50, 0.163, 0.095, 0.112), // buttocks
        (1.00, 0.172, 0.100, 0.105), // hips
        (1.60, 0.158, 0.100, 0.092),
        (1.75, 0.155, 0.100, 0.090), // waistband
        (2.50, 0.143, 0.098, 0.088), // waist
        (3.50, 0.150, 0.112, 0.095), // lower chest
        (4.20, 0.156, 0.118, 0.100), // chest
        (4.55, 0.158, 0.108, 0.098), // armpits
        (4.85, 0.150, 0.085, 0.085), // shoulder line
        (5.15, 0.105, 0.060, 0.065), // trapezius
        (5.35, 0.058, 0.052, 0.055), // neck base, collar
        (5.80, 0.052, 0.050, 0.050),
        (6.20, 0.050, 0.045, 0.050), // inside the head
        (6.35, 0.0, 0.0, 0.0),       // top pole
    ];
    let stations: Vec<Station> = table[..14]
        .iter()
        .map(|&(c, w, f, b)| {
            // (width factor, front factor, back factor) by region.
            let (kw, kf, kb) = if c >= 5.3 {
                let k = dims.width(0.5);
                (k, k, k)
            } else if c <= 1.75 {
                let k = dims.width(1.0);
                (dims.width(0.75) * shape.hip_scale, k, k)
            } else if c < 3.2 {
                let k = dims.width(1.0);
                (k * shape.waist_scale, dims.width(1.4), k)
            } else {
                let k = dims.width(0.9);
                (k * shape.chest_scale, dims.width(1.0), k)
            };
            let bust_here = if (3.4..=4.6).contains(&c) {
                bust * (1.0 - ((c - 4.1) / 0.6).abs()).max(0.0)
            } else {
                0.0
            };
            Station {
                c,
                half_width_m: w * kw,
                front_m: f * kf + bust_here,
                back_m: b * kb,
                offset_m: Vector3::zeros(),
                weight_shift: 0.0,
            }
        })
        .collect();
    let bands = banded(
        &stations,
        Material::Bottom,
        &[(1.75, Material::Top), (5.35, Material::Skin)],
    );
    let mut part = PartBuilder::new("torso");
    part.tube(
        &chain,
        &Vector3::y(),
        &superellipse(TORSO_AROUND, 2.5),
        &stations,
        [Pole::at(-0.3), Pole::at(table[14].0)],
        &|band, _| bands[band],
    );
    Ok(part)
}

/// Head ellipsoid semi-axes for the standard head: x, front, back, z.
const HEAD_SEMI_M: [f64; 4] = [0.078, 0.100, 0.095, 0.115];
/// Forward offset of the head's centre from the neck axis, standard head.
const HEAD_FORWARD_M: f64 = 0.012;

fn head_centre(sk: &Skeleton<'_>, dims: &Dims) -> Vector3<f64> {
    sk.head_top - Vector3::new(0.0, -HEAD_FORWARD_M, HEAD_SEMI_M[3]) * dims.head
}

/// The head: an ellipsoid hanging from the top of the head, jaw a little narrower, a nose,
/// hair on the top and back.
fn head(sk: &Skeleton<'_>, dims: &Dims, shape: &BodyShape) -> Result<PartBuilder, BodyMeshError> {
    let hs = dims.head;
    let [ax, af, ab, az] = HEAD_SEMI_M.map(|s| s * hs);
    let centre = head_centre(sk, dims);
    let head_bone = sk.index("head")?;
    let chain = Chain::new(
        vec![centre - Vector3::z() * az, centre + Vector3::z() * az],
        vec![Influences::single(head_bone)],
        None,
        None,
    );
    let stations: Vec<Station> = (1..HEAD_RINGS)
        .map(|k| {
            #[expect(clippy::cast_precision_loss, reason = "small counts")]
            let phi = std::f64::consts::PI * k as f64 / HEAD_RINGS as f64;
            let (s, c) = phi.sin_cos();
            // c > 0: lower half. The jaw narrows, the skull base recedes into the neck.
            let jaw = 1.0 - 0.12 * c.max(0.0).powi(2);
            let nape = 1.0 - 0.15 * c.max(0.0);
            Station {
                c: 0.5 * (1.0 - c),
                half_width_m: ax * s * jaw,
                front_m: af * s,
                back_m: ab * s * nape,
                offset_m: Vector3::zeros(),
                weight_shift: 0.0,
            }
        })
        .collect();
    let hair = hairline(match shape.hair_style {
        HairStyle::Long => shape.hair_length_m / HEAD_SEMI_M[3],
        // Pulled back: the hair covers the nape a little lower than a short cut.
        HairStyle::Ponytail | HairStyle::Bun => 0.1,
        HairStyle::Short | HairStyle::Bald => 0.0,
    });
    // Bald: no hair above this height on the unit head (the crown), only the fringe below it.
    let crown = if shape.hair_style == HairStyle::Bald {
        0.4
    } else {
        f64::INFINITY
    };
    let last_band = stations.len();
    let mut part = PartBuilder::new("head");
    part.tube(
        &chain,
        &Vector3::y(),
        &ellipse(HEAD_AROUND),
        &stations,
        [Pole::at(0.0), Pole::at(1.0)],
        &|band, p: &Vector3<f64>| {
            if band == 0 {
                return Material::Skin;
            }
            if band == last_band {
                return if crown.is_finite() {
                    Material::Skin
                } else {
                    Material::Hair
                };
            }
            let d = p - centre;
            let q = Vector3::new(d.x / ax, d.y / if d.y >= 0.0 { af } else { ab }, d.z / az);
            let q = q.try_normalize(1e-12).unwrap_or_else(Vector3::z);
            if q.z > hair(q.y) && (q.z < crown && q.y < 0.2 || crown.is_infinite()) {
                Material::Hair
            } else {
                Material::Skin
            }
        },
    );
    // The nose: push the front vertices near eye–mouth height forward.
    for p in &mut part.positions {
        let d = *p - centre;
        let q = Vector3::new(d.x / ax, d.y / af, d.z / az);
        let Some(q) = q.try_normalize(1e-12) else {
            continue;
        };
        p.y += nose_push_m(&q, hs);
    }
    Ok(part)
}

/// How far the nose pushes the head's surface forward (+y) in the direction `q` from the head's
/// centre (a unit direction on the unit head), for a head scaled by `hs`.
fn nose_push_m(q: &Vector3<f64>, hs: f64) -> f64 {
    let nose_dir = Vector3::new(0.0, 1.0, -0.12).normalize();
    let cos_reach = 25f64.to_radians().cos();
    0.018 * hs * smoothstep((q.dot(&nose_dir) - cos_reach) / (1.0 - cos_reach))
}

/// The eyes and ears, small closed ellipsoids on the head's surface moving with the head bone,
/// each where the ray from the head's centre through the rig's landmark (`l_eye`, `r_eye`,
/// `l_ear`, `r_ear`, the points COCO's face keypoints are read from) meets the head: eyes
/// [`Material::Eye`], ears skin; then the brows and the mouth ([`brows_and_mouth`]). A rig
/// without those landmarks gets none.
fn face_features(sk: &Skeleton<'_>, dims: &Dims) -> Result<Vec<PartBuilder>, BodyMeshError> {
    let hs = dims.head;
    let [ax, af, ab, az] = HEAD_SEMI_M.map(|s| s * hs);
    let centre = head_centre(sk, dims);
    let head_bone = sk.index("head")?;
    let features: [(&'static str, &str, [f64; 3], f64, Material); 4] = [
        ("l_eye", "l_eye", [0.013, 0.008, 0.009], 0.4, Material::Eye),
        ("r_eye", "r_eye", [0.013, 0.008, 0.009], 0.4, Material::Eye),
        ("l_ear", "l_ear", [0.012, 0.022, 0.032], 0.2, Material::Skin),
        ("r_ear", "r_ear", [0.012, 0.022, 0.032], 0.2, Material::Skin),
    ];
    let mut parts = Vec::new();
    for (name, landmark, semi, out, material) in features {
        let Some(l) = sk.rig.landmark_index(landmark) else {
            continue;
        };
        if l >= sk.character.landmark_offset_m.len() {
            continue;
        }
        let at = fk::landmark_position(sk.rig, sk.character, &sk.rest, l).coords;
        let d = at - centre;
        let front = if d.y >= 0.0 { af } else { ab };
        let q = Vector3::new(d.x / ax, d.y / front, d.z / az);
        let Some(q) = q.try_normalize(1e-12) else {
            continue;
        };
        let surface = centre + Vector3::new(q.x * ax, q.y * front, q.z * az);
        // Outward along the surface normal, so the feature sits partly out of the head.
        let normal = Vector3::new(q.x / ax, q.y / front, q.z / az).normalize();
        let semi = semi.map(|v| v * hs);
        let mid = surface + normal * (out * semi[0]);
        parts.push(blob(name, mid, semi, head_bone, material, BLOB));
    }
    parts.extend(brows_and_mouth(sk, dims)?);
    Ok(parts)
}

/// Below the eyes' midpoint, the mouth's height on an adult head of scale 1, metres (the eyes to
/// the lips' parting is about 6.5 cm on an adult).
const EYES_TO_MOUTH_M: f64 = 0.064;
/// Above each eye, its brow's height on an adult head of scale 1, metres.
const EYE_TO_BROW_M: f64 = 0.019;

/// The brows (`l_brow`, `r_brow`: thin [`Material::Hair`] bars above the eyes, the hair's
/// colour) and the mouth (`mouth`: a flat [`Material::Eye`] bar, the shadowed parting of the
/// lips, which reads as a dark line at video sizes), laid on the head's surface (the mouth over
/// the nose's push) from the eye landmarks. Small, coarse ellipsoids (36 triangles each): no
/// texture or per-pixel pass. A rig without eye landmarks gets none.
fn brows_and_mouth(sk: &Skeleton<'_>, dims: &Dims) -> Result<Vec<PartBuilder>, BodyMeshError> {
    let hs = dims.head;
    let [ax, af, ab, az] = HEAD_SEMI_M.map(|s| s * hs);
    let centre = head_centre(sk, dims);
    let head_bone = sk.index("head")?;
    let eye = |name: &str| {
        let l = sk.rig.landmark_index(name)?;
        (l < sk.character.landmark_offset_m.len())
            .then(|| fk::landmark_position(sk.rig, sk.character, &sk.rest, l).coords)
    };
    let (Some(l_eye), Some(r_eye)) = (eye("l_eye"), eye("r_eye")) else {
        return Ok(Vec::new());
    };
    // Where the ray from the centre through `at` meets the head (with the nose's push), and the
    // surface's normal there.
    let on_surface = |at: Vector3<f64>| {
        let d = at - centre;
        let front = if d.y >= 0.0 { af } else { ab };
        let q = Vector3::new(d.x / ax, d.y / front, d.z / az).try_normalize(1e-12)?;
        let mut surface = centre + Vector3::new(q.x * ax, q.y * front, q.z * az);
        surface.y += nose_push_m(&q, hs);
        let normal = Vector3::new(q.x / ax, q.y / front, q.z / az).normalize();
        Some((surface, normal))
    };
    let features: [(&'static str, Vector3<f64>, [f64; 3], Material); 3] = [
        (
            "l_brow",
            l_eye + Vector3::z() * (EYE_TO_BROW_M * hs),
            [0.017, 0.006, 0.005],
            Material::Hair,
        ),
        (
            "r_brow",
            r_eye + Vector3::z() * (EYE_TO_BROW_M * hs),
            [0.017, 0.006, 0.005],
            Material::Hair,
        ),
        (
            "mouth",
            0.5 * (l_eye + r_eye) - Vector3::z() * (EYES_TO_MOUTH_M * hs),
            [0.021, 0.006, 0.005],
            Material::Eye,
        ),
    ];
    let mut parts = Vec::new();
    for (name, at, semi, material) in features {
        let Some((surface, normal)) = on_surface(at) else {
            continue;
        };
        let semi = semi.map(|v| v * hs);
        // Half out of the skin, so it shows from the front and the side.
        let mid = surface + normal * (0.3 * semi[1]);
        parts.push(blob(name, mid, semi, head_bone, material, FLAT_BLOB));
    }
    Ok(parts)
}

/// [`blob`]'s rings between its poles, plus one, and vertices around: a small ellipsoid (8
/// around, 4 rings), for the eyes, ears and hair buns.
const BLOB: (usize, usize) = (5, 8);

/// A coarse [`blob`] (6 around, 3 rings: 36 triangles), for the brows and the mouth.
const FLAT_BLOB: (usize, usize) = (4, 6);

/// A small closed ellipsoid named `name` centred at `centre` with semi-axes `semi` (x, y, z),
/// all on `bone`, of one `material`: `rings - 1` rings of `sides` vertices between its two poles
/// ([`BLOB`], [`FLAT_BLOB`]).
fn blob(
    name: &'static str,
    centre: Vector3<f64>,
    semi: [f64; 3],
    bone: usize,
    material: Material,
    (rings, sides): (usize, usize),
) -> PartBuilder {
    let chain = Chain::new(
        vec![
            centre - Vector3::z() * semi[2],
            centre + Vector3::z() * semi[2],
        ],
        vec![Influences::single(bone)],
        None,
        None,
    );
    let stations: Vec<Station> = (1..rings)
        .map(|k| {
            #[expect(clippy::cast_precision_loss, reason = "small counts")]
            let phi = std::f64::consts::PI * k as f64 / rings as f64;
            let (s, c) = phi.sin_cos();
            Station {
                c: 0.5 * (1.0 - c),
                half_width_m: semi[0] * s,
                front_m: semi[1] * s,
                back_m: semi[1] * s,
                offset_m: Vector3::zeros(),
                weight_shift: 0.0,
            }
        })
        .collect();
    let mut part = PartBuilder::new(name);
    part.tube(
        &chain,
        &Vector3::y(),
        &ellipse(sides),
        &stations,
        [Pole::at(0.0), Pole::at(1.0)],
        &|_, _| material,
    );
    part
}

/// The hairline on the unit head: hair where `z > hairline(y)` (y forward, z up, unit sphere
/// directions). `extra` lowers the back and sides (long hair), in units of the head's height.
fn hairline(extra: f64) -> impl Fn(f64) -> f64 {
    let extra = extra.clamp(0.0, 2.0);
    let front = 0.72;
    let side = 0.25 - 1.2 * extra.min(0.5);
    let back = -0.5 - 0.5 * extra.min(1.0);
    move |y: f64| {
        if y >= 0.0 {
            side + (front - side) * y
        } else {
            side + (side - back) * y
        }
    }
}

/// Long hair: a flattened mass down the back of the head and neck, moving with the head.
fn long_hair(
    sk: &Skeleton<'_>,
    dims: &Dims,
    shape: &BodyShape,
) -> Result<PartBuilder, BodyMeshError> {
    let hs = dims.head;
    let centre = head_centre(sk, dims);
    let head_bone = sk.index("head")?;
    let top = centre + Vector3::new(0.0, -0.03, 0.02) * hs;
    let bottom = centre
        + Vector3::new(
            0.0,
            -0.07,
            -HEAD_SEMI_M[3] - shape.hair_length_m.clamp(0.0, 0.4),
        ) * hs;
    let chain = Chain::new(
        vec![bottom, top],
        vec![Influences::single(head_bone)],
        None,
        None,
    );
    let rings = [0.12, 0.35, 0.6, 0.8, 0.95];
    let stations: Vec<Station> = rings
        .iter()
        .map(|&c| {
            let s = (c * std::f64::consts::PI).sin().max(0.3);
            Station::oval(c, 0.072 * hs * s.sqrt(), 0.032 * hs * s)
        })
        .collect();
    let mut part = PartBuilder::new("hair");
    part.tube(
        &chain,
        &Vector3::y(),
        &ellipse(HAIR_AROUND),
        &stations,
        [Pole::at(0.0), Pole::at(1.0)],
        &|_, _| Material::Hair,
    );
    Ok(part)
}

/// A ponytail: a tube from the back of the head down behind the neck, moving with the head.
fn ponytail(sk: &Skeleton<'_>, dims: &Dims) -> Result<PartBuilder, BodyMeshError> {
    let hs = dims.head;
    let centre = head_centre(sk, dims);
    let head_bone = sk.index("head")?;
    let root = centre + Vector3::new(0.0, -HEAD_SEMI_M[2] * 0.85, 0.02) * hs;
    let end = centre + Vector3::new(0.0, -HEAD_SEMI_M[2] - 0.05, -0.2) * hs;
    let chain = Chain::new(
        vec![end, root],
        vec![Influences::single(head_bone)],
        None,
        None,
    );
    let stations: Vec<Station> = [(0.08, 0.012), (0.35, 0.024), (0.65, 0.028), (0.9, 0.02)]
        .iter()
        .map(|&(c, r)| Station::oval(c, r * hs, r * hs))
        .collect();
    let mut part = PartBuilder::new("ponytail");
    part.tube(
        &chain,
        &Vector3::y(),
        &ellipse(HAIR_AROUND),
        &stations,
        [Pole::at(0.0), Pole::at(1.05)],
        &|_, _| Material::Hair,
    );
    Ok(part)
}

/// A bun: a ball of hair at the back of the head, moving with it.
fn bun(sk: &Skeleton<'_>, dims: &Dims) -> Result<PartBuilder, BodyMeshError> {
    let hs = dims.head;
    let centre = head_centre(sk, dims) + Vector3::new(0.0, -HEAD_SEMI_M[2] * 0.92, 0.035) * hs;
    let semi = [0.038, 0.034, 0.034].map(|v| v * hs);
    Ok(blob(
        "bun",
        centre,
        semi,
        sk.index("head")?,
        Material::Hair,
        BLOB,
    ))
}

/// The fingers besides the thumb, and each one's radius at its base for the standard hand,
/// metres.
const FINGERS: [(&str, f64); 4] = [
    ("index", 0.0095),
    ("middle", 0.0100),
    ("ring", 0.0093),
    ("pinky", 0.0080),
];

/// Ring resolution of a finger.
const FINGER_AROUND: usize = 6;

/// A finger (`index`, `middle`, `ring` or `pinky`): from inside the palm along its three bones
/// to its tip, each ring on its own bone (blended at the joints), so it bends as its bones do.
fn finger_part(
    sk: &Skeleton<'_>,
    side: Side,
    finger: &str,
    radius_m: f64,
) -> Result<PartBuilder, BodyMeshError> {
    let b = |name: &str| sk.index(&side.name(name));
    let hand = b("hand")?;
    let f = [
        b(&format!("{finger}0"))?,
        b(&format!("{finger}1"))?,
        b(&format!("{finger}2"))?,
    ];
    let chain = Chain::new(
        vec![sk.head(f[0]), sk.head(f[1]), sk.head(f[2]), sk.tail(f[2])],
        f.iter().map(|&bone| Influences::single(bone)).collect(),
        Some(Influences::single(hand)),
        None,
    );
    let k = sk.scale(hand).abs() * radius_m;
    let stations: Vec<Station> = [(-0.3, 1.0), (0.6, 0.97), (1.6, 0.9), (2.55, 0.8)]
        .iter()
        .map(|&(c, r)| Station::oval(c, r * k, r * k * 0.85))
        .collect();
    let name = match (finger, side) {
        ("index", Side::Left) => "l_index",
        ("index", Side::Right) => "r_index",
        ("middle", Side::Left) => "l_middle",
        ("middle", Side::Right) => "r_middle",
        ("ring", Side::Left) => "l_ring",
        ("ring", Side::Right) => "r_ring",
        (_, Side::Left) => "l_pinky",
        (_, Side::Right) => "r_pinky",
    };
    let mut part = PartBuilder::new(name);
    part.tube(
        &chain,
        &Vector3::z(),
        &ellipse(FINGER_AROUND),
        &stations,
        [Pole::at(-0.5), Pole::at(2.95)],
        &|_, _| Material::Skin,
    );
    Ok(part)
}

/// An arm: clavicle (0) → shoulder (1) → elbow (2) → wrist (3) → knuckles (4) → middle
/// fingertip (5). The tube ends in a palm just past the knuckles; the fingers are parts of
/// their own ([`finger_part`]).
fn arm(sk: &Skeleton<'_>, dims: &Dims, side: Side) -> Result<PartBuilder, BodyMeshError> {
    let b = |name: &str| sk.index(&side.name(name));
    let (clavicle, upper, fore, hand) =
        (b("clavicle")?, b("upper_arm")?, b("forearm")?, b("hand")?);
    let (index0, middle0, middle2, ring0, pinky0) = (
        b("index0")?,
        b("middle0")?,
        b("middle2")?,
        b("ring0")?,
        b("pinky0")?,
    );
    let chain = Chain::new(
        vec![
            sk.head(clavicle),
            sk.head(upper),
            sk.head(fore),
            sk.head(hand),
            sk.head(middle0),
            sk.tail(middle2),
        ],
        vec![
            Influences::single(clavicle),
            Influences::single(upper),
            Influences::single(fore),
            Influences::single(hand),
            Influences::shared(&[index0, middle0, ring0]),
        ],
        None,
        None,
    )
    // A wide shoulder blend rounds the shoulder when the arm hangs down.
    .with_blend(1, SHOULDER_BLEND);
    let hand_scale = sk.scale(hand).abs();
    // The palm's centre line lies between the index and pinky knuckles.
    let palm_offset = Vector3::new(
        0.0,
        0.5 * (sk.head(index0).y + sk.head(pinky0).y) - sk.head(hand).y,
        0.0,
    );
    // (c, half-width (horizontal), half-height (vertical), drop of the centre below the chain).
    // Towards the chest the tube sinks a little so that the shoulder slopes to the neck.
    #[rustfmt::skip]
    let arm_table: [(f64, f64, f64, f64); 13] = [
        (0.35, 0.038, 0.032, 0.010), (0.70, 0.045, 0.040, 0.006), (1.00, 0.050, 0.045, 0.0),
        (1.20, 0.049, 0.046, 0.0),
        (1.45, 0.046, 0.044, 0.0), // sleeve hem
        (1.70, 0.041, 0.040, 0.0), (1.90, 0.038, 0.037, 0.0), (2.00, 0.037, 0.036, 0.0),
        (2.15, 0.039, 0.037, 0.0), (2.45, 0.034, 0.031, 0.0), (2.75, 0.029, 0.025, 0.0),
        (3.00, 0.027, 0.020, 0.0), (3.35, 0.040, 0.017, 0.0),
    ];
    // The palm, to just past the knuckles: (c, half-width, half-thickness).
    let hand_table: [(f64, f64, f64); 3] = [
        (3.75, 0.045, 0.016),
        (4.00, 0.044, 0.014),
        (4.12, 0.039, 0.012),
    ];
    let mut stations: Vec<Station> = arm_table
        .iter()
        .map(|&(c, w, h, drop)| {
            // From the wrist on, sizes follow the hand; the upper arm widens with build more
            // than the forearm.
            let limb = dims.width(ramp(c, 1.0, 2.5, 0.9, 0.7));
            let k = if c >= 3.2 { hand_scale } else { limb };
            let mut s = Station::oval(c, w, h).scaled(k);
            s.offset_m = Vector3::z() * (-drop * limb);
            // Over the shoulder the top of the arm stays with the clavicle longer than the
            // armpit, so a lowered arm leaves a rounded shoulder rather than a corner.
            s.weight_shift = SHOULDER_WEIGHT_SHIFT * (1.0 - ((c - 1.0) / 0.45).abs()).max(0.0);
            s
        })
        .collect();
    stations.extend(
        hand_table
            .iter()
            .map(|&(c, w, h)| Station::oval(c, w, h).scaled(hand_scale)),
    );
    for s in &mut stations {
        s.offset_m += palm_offset * smoothstep((s.c - 3.0) / 0.5);
    }
    let bands = banded(&stations, Material::Top, &[(1.45, Material::Skin)]);
    let mut part = PartBuilder::new(side.part("l_arm", "r_arm"));
    part.tube(
        &chain,
        &Vector3::z(),
        &ellipse(ARM_AROUND),
        &stations,
        [
            Pole::at(0.2),
            Pole {
                c: 4.2,
                offset_m: palm_offset,
            },
        ],
        &|band, _| bands[band],
    );
    Ok(part)
}

/// A thumb: from inside the palm along the three thumb bones.
fn thumb(sk: &Skeleton<'_>, side: Side) -> Result<PartBuilder, BodyMeshError> {
    let b = |name: &str| sk.index(&side.name(name));
    let (hand, t0, t1, t2) = (b("hand")?, b("thumb0")?, b("thumb1")?, b("thumb2")?);
    let chain = Chain::new(
        vec![sk.head(t0), sk.head(t1), sk.head(t2), sk.tail(t2)],
        vec![
            Influences::single(t0),
            Influences::single(t1),
            Influences::single(t2),
        ],
        Some(Influences::single(hand)),
        None,
    );
    let k = sk.scale(hand).abs();
    let stations: Vec<Station> = [
        (-0.4, 0.012),
        (0.3, 0.0135),
        (1.0, 0.012),
        (2.0, 0.0105),
        (2.7, 0.0095),
    ]
    .iter()
    .map(|&(c, r)| Station::oval(c, r, r * 0.85).scaled(k))
    .collect();
    let mut part = PartBuilder::new(side.part("l_thumb", "r_thumb"));
    part.tube(
        &chain,
        &Vector3::z(),
        &ellipse(THUMB_AROUND),
        &stations,
        [Pole::at(-0.6), Pole::at(3.0)],
        &|_, _| Material::Skin,
    );
    Ok(part)
}

/// A leg: hip (0) → knee (1) → ankle (2); starts inside the pelvis, ends inside the shoe.
fn leg(sk: &Skeleton<'_>, dims: &Dims, side: Side) -> Result<PartBuilder, BodyMeshError> {
    let b = |name: &str| sk.index(&side.name(name));
    let (thigh, calf, foot) = (b("thigh")?, b("calf")?, b("foot")?);
    let pelvis = sk.index("pelvis")?;
    let chain = Chain::new(
        vec![sk.head(thigh), sk.head(calf), sk.head(foot)],
        vec![Influences::single(thigh), Influences::single(calf)],
        Some(Influences::single(pelvis)),
        Some(Influences::single(foot)),
    );
    // (c, half-width (lateral), front, back).
    #[rustfmt::skip]
    let table: [(f64, f64, f64, f64); 11] = [
        (-0.18, 0.060, 0.075, 0.075),
        (0.00, 0.082, 0.085, 0.085), // hip joint
        (0.25, 0.080, 0.082, 0.082),
        (0.50, 0.071, 0.073, 0.073),
        (0.80, 0.060, 0.062, 0.062),
        (1.00, 0.054, 0.056, 0.056), // knee
        (1.20, 0.053, 0.050, 0.062), // calf
        (1.40, 0.050, 0.045, 0.058),
        (1.65, 0.043, 0.042, 0.045),
        (1.90, 0.040, 0.040, 0.040), // trouser hem
        (2.00, 0.040, 0.042, 0.042), // ankle
    ];
    let stations: Vec<Station> = table
        .iter()
        .map(|&(c, w, f, bk)| {
            // Thighs widen with build as the hips do, calves less.
            let k = dims.width(ramp(c, 0.25, 1.4, 1.0, 0.7));
            Station {
                c,
                half_width_m: w * k,
                front_m: f * k,
                back_m: bk * k,
                offset_m: Vector3::zeros(),
                weight_shift: 0.0,
            }
        })
        .collect();
    let mut part = PartBuilder::new(side.part("l_leg", "r_leg"));
    part.tube(
        &chain,
        &Vector3::y(),
        &ellipse(LEG_AROUND),
        &stations,
        [Pole::at(-0.26), Pole::at(2.08)],
        &|_, _| Material::Bottom,
    );
    Ok(part)
}

/// Flat-bottomed shoe profile, counter-clockwise from the sole's middle: `(u, v)` with `v = −1`
/// the sole.
const SHOE_PROFILE: [[f64; 2]; 12] = [
    [0.0, -1.0],
    [0.6, -1.0],
    [0.95, -0.85],
    [1.0, -0.3],
    [0.95, 0.35],
    [0.6, 0.85],
    [0.0, 1.0],
    [-0.6, 0.85],
    [-0.95, 0.35],
    [-1.0, -0.3],
    [-0.95, -0.85],
    [-0.6, -1.0],
];

/// A shoe along the foot, its sole on the ground under the ankle.
fn shoe(sk: &Skeleton<'_>, side: Side) -> Result<PartBuilder, BodyMeshError> {
    let foot = sk.index(&side.name("foot"))?;
    let root = sk.index("root")?;
    let k = sk.scale(foot).abs();
    let ankle = sk.head(foot);
    let rig_ankle_height_m = sk.rig.bones[foot].head_rest_m.z - sk.rig.bones[root].head_rest_m.z;
    let sole_z = ankle.z - rig_ankle_height_m * k;
    let along = sk.tail(foot) - ankle;
    let forward = Vector3::new(along.x, along.y, 0.0)
        .try_normalize(1e-9)
        .unwrap_or_else(Vector3::y);
    let base = Vector3::new(ankle.x, ankle.y, sole_z);
    let (heel_m, toe_m) = (-0.072 * k, 0.213 * k);
    let chain = Chain::new(
        vec![base + forward * heel_m, base + forward * toe_m],
        vec![Influences::single(foot)],
        None,
        None,
    );
    let c_of = |y_m: f64| (y_m * k - heel_m) / (toe_m - heel_m);
    // (distance ahead of the ankle, half-width, height), standard foot.
    #[rustfmt::skip]
    let table: [(f64, f64, f64); 9] = [
        (-0.066, 0.026, 0.060), (-0.045, 0.037, 0.088), (-0.020, 0.042, 0.105),
        (0.030, 0.045, 0.100), (0.080, 0.048, 0.075), (0.130, 0.050, 0.055),
        (0.170, 0.047, 0.046), (0.195, 0.039, 0.038), (0.208, 0.026, 0.028),
    ];
    let stations: Vec<Station> = table
        .iter()
        .map(|&(y, w, h)| Station {
            c: c_of(y),
            half_width_m: w * k,
            front_m: 0.5 * h * k,
            back_m: 0.5 * h * k,
            offset_m: Vector3::z() * (0.5 * h * k),
            weight_shift: 0.0,
        })
        .collect();
    let mut part = PartBuilder::new(side.part("l_shoe", "r_shoe"));
    part.tube(
        &chain,
        &Vector3::z(),
        &SHOE_PROFILE,
        &stations,
        [
            Pole {
                c: 0.0,
                offset_m: Vector3::z() * (0.035 * k),
            },
            Pole {
                c: 1.0,
                offset_m: Vector3::z() * (0.014 * k),
            },
        ],
        &|_, _| Material::Shoes,
    );
    Ok(part)
}

// ---------------------------------------------------------------------------------------------
// Assembly: normals, material seams, f32.
// ---------------------------------------------------------------------------------------------

fn assemble(parts: &[PartBuilder]) -> BodyMesh {
    let mut mesh = BodyMesh {
        rest_positions_m: Vec::new(),
        rest_normals: Vec::new(),
        joints: Vec::new(),
        weights: Vec::new(),
        materials: Vec::new(),
        indices: Vec::new(),
        parts: Vec::new(),
    };
    for part in parts {
        let first_vertex = mesh.rest_positions_m.len();
        let first_triangle = mesh.indices.len() / 3;
        // Area-weighted vertex normals over the whole part, seams included.
        let mut normals = vec![Vector3::zeros(); part.positions.len()];
        for (f, _) in &part.faces {
            let [a, b, c] = f.map(|i| part.positions[i as usize]);
            let n = (b - a).cross(&(c - a));
            for &i in f {
                normals[i as usize] += n;
            }
        }
        // One output vertex per (position, material).
        let mut out: Vec<[u32; Material::ALL.len()]> =
            vec![[u32::MAX; Material::ALL.len()]; part.positions.len()];
        for (f, material) in &part.faces {
            for &i in f {
                let slot = &mut out[i as usize][*material as usize];
                if *slot == u32::MAX {
                    *slot = u32::try_from(mesh.rest_positions_m.len()).unwrap_or(u32::MAX);
                    let i = i as usize;
                    let p = part.positions[i];
                    let n = normals[i].try_normalize(1e-18).unwrap_or_else(Vector3::z);
                    let (joints, weights) = part.influences[i].packed();
                    mesh.rest_positions_m.push(to_f32(&p));
                    mesh.rest_normals.push(to_f32(&n));
                    mesh.joints.push(joints);
                    mesh.weights.push(weights);
                    mesh.materials.push(*material);
                }
                mesh.indices.push(*slot);
            }
        }
        mesh.parts.push(BodyPart {
            name: part.name,
            vertices: first_vertex..mesh.rest_positions_m.len(),
            triangles: first_triangle..mesh.indices.len() / 3,
        });
    }
    mesh
}

#[expect(clippy::cast_possible_truncation, reason = "the mesh is stored in f32")]
fn to_f32(v: &Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

#[cfg(test)]
#[path = "body_mesh_tests.rs"]
mod tests;
