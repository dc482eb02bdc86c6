//! The 53-bone whole-body rig: bones, their degree-of-freedom classes, the default adult rest
//! skeleton, the named landmarks that keypoint layouts bind to, and the recipes that say which
//! landmarks drive each bone.
//!
//! # Conventions (defined here once)
//! - Positions are in the autoact frame ([`crate::skeleton::frames`]): metres, +Z up, the character stands
//!   on `z = 0` facing +Y in a T-pose (arms along ±X, palms down). +X is the character's right.
//! - A bone's **local rotation** is its rotation relative to the rest pose, expressed in its
//!   parent's frame: `local = parent_world⁻¹ · child_world`, where `world` is the rotation that
//!   takes the bone from its rest orientation to its posed one. The rest pose is identity for
//!   every bone, so rotations mean "how far from rest", which is what interpolation, angular
//!   distances and random variants need.
//! - Each bone also has an anatomical **rest orientation** (`character_from_bone`): +Y runs along
//!   the bone, +X is the hinge axis for 1-D bones (and a lateral axis otherwise). Exporters use it
//!   to re-express local rotations in an engine's bone frames (e.g. GTA V's +X-along-bone); the
//!   solver uses the bone axis for twist and the hinge axis for 1-D bones.
//! - Bone names are ours (`l_upper_arm`); the GTA V ped names and tags of the paper's rig are kept
//!   as attributes (`SKEL_L_UpperArm`, 45509) for game-engine exporters.

use nalgebra::{Matrix3, Point3, Rotation3, Unit, UnitQuaternion, Vector3};

/// Degree-of-freedom class of a bone.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Dof {
    /// Yaw about the vertical axis plus the body's translation.
    Root,
    /// Free rotation: swing and twist.
    ThreeD,
    /// Swing only: no twist about the bone's own axis.
    TwoD,
    /// A hinge: rotation about one axis (given in the rest/character frame) only.
    Hinge {
        /// Hinge axis, autoact frame at rest; flexion is a positive angle.
        axis: Unit<Vector3<f64>>,
    },
    /// Never rotates relative to its parent.
    Static,
}

impl Dof {
    /// Short label used in tables and reports: `root`, `3-D`, `2-D`, `1-D`, `static`.
    #[must_use]
    pub fn label(&self) -> &'static str {
        match self {
            Dof::Root => "root",
            Dof::ThreeD => "3-D",
            Dof::TwoD => "2-D",
            Dof::Hinge { .. } => "1-D",
            Dof::Static => "static",
        }
    }
}

/// Which degrees of freedom a conversion solves.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    clap::ValueEnum,
    serde::Serialize,
    serde::Deserialize,
)]
#[serde(rename_all = "kebab-case")]
pub enum DofSet {
    /// Every class of the rig: the pelvis turns in 3-D (tilt, roll) under the yaw-only root, the
    /// clavicles swing (shrug, protraction).
    #[default]
    Full,
    /// The paper's rig: the pelvis and clavicles stay at rest ([`PAPER_STATIC_BONES`]), so the
    /// hips and shoulders keep the subject's median place on the root and the chest.
    Paper,
}

/// Bones the paper's rig keeps static and [`DofSet::Full`] moves.
pub const PAPER_STATIC_BONES: [&str; 3] = ["pelvis", "l_clavicle", "r_clavicle"];

impl DofSet {
    /// Whether a conversion with this set holds `bone` at rest whatever its class.
    #[must_use]
    pub fn holds_at_rest(self, bone: &Bone) -> bool {
        self == DofSet::Paper && PAPER_STATIC_BONES.contains(&bone.name.as_str())
    }

    /// Name as the command line and the bag metadata write it: `full` or `paper`.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            DofSet::Full => "full",
            DofSet::Paper => "paper",
        }
    }
}

/// One bone of the rig.
#[derive(Debug, Clone, PartialEq)]
pub struct Bone {
    /// autoact name, e.g. `l_upper_arm`.
    pub name: String,
    /// GTA V ped bone name, e.g. `SKEL_L_UpperArm`.
    pub gta_name: &'static str,
    /// GTA V ped bone tag, e.g. 45509.
    pub gta_tag: u16,
    /// Parent bone index (`None` only for the root). Parents always precede children.
    pub parent: Option<usize>,
    /// Head (joint) position at rest, autoact frame, metres.
    pub head_rest_m: Point3<f64>,
    /// Tail position at rest (where the bone points), autoact frame, metres.
    pub tail_rest_m: Point3<f64>,
    /// Degree-of-freedom class.
    pub dof: Dof,
    /// Anatomical frame at rest, `character_from_bone`: +Y along the bone, +X hinge/lateral.
    pub rest_orientation: UnitQuaternion<f64>,
}

impl Bone {
    /// The rotation of this bone's class nearest to `q` (a local rotation): a 3-D bone keeps it;
    /// a 2-D bone keeps its swing (drops the twist about the bone); a hinge keeps the part about
    /// its axis; the root keeps its yaw; a static bone is at rest. The quaternion's hemisphere
    /// follows `q`'s, so a continuous track stays continuous.
    #[must_use]
    pub fn constrain(&self, q: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
        let about = |axis: &Vector3<f64>| {
            let part = nalgebra::Quaternion::from_parts(q.w, axis * axis.dot(&q.as_ref().vector()));
            let n = part.norm();
            if n > 1e-12 {
                UnitQuaternion::new_unchecked(part / n)
            } else {
                UnitQuaternion::identity()
            }
        };
        match &self.dof {
            Dof::ThreeD => *q,
            Dof::Static => UnitQuaternion::identity(),
            Dof::Root => about(&Vector3::z()),
            Dof::Hinge { axis } => about(axis),
            Dof::TwoD => {
                let axis = self.rest_direction();
                let moved = Unit::new_unchecked(q * axis.into_inner());
                crate::skeleton::geom::align_hemisphere(
                    crate::skeleton::geom::shortest_arc(&axis, &moved),
                    q,
                )
            }
        }
    }

    /// Unit direction head → tail at rest.
    #[must_use]
    pub fn rest_direction(&self) -> Unit<Vector3<f64>> {
        self.rest_orientation * Vector3::y_axis()
    }

    /// Rest length head → tail, metres.
    #[must_use]
    pub fn rest_length_m(&self) -> f64 {
        (self.tail_rest_m - self.head_rest_m).norm()
    }
}

/// A named point on the body that layouts bind keypoints to.
#[derive(Debug, Clone, PartialEq)]
pub struct Landmark {
    /// Name, e.g. `l_elbow`.
    pub name: String,
    /// The bone it moves with.
    pub bone: usize,
    /// Rest position, autoact frame, metres.
    pub rest_m: Point3<f64>,
}

/// A point built from landmarks: their mean.
pub type LandmarkSet = Vec<usize>;

/// How a bone's twist is observed.
#[derive(Debug, Clone, PartialEq)]
pub enum Reference {
    /// The direction `from → to` (rest direction taken from the landmarks' rest positions).
    Direction {
        /// Start landmarks (mean).
        from: LandmarkSet,
        /// End landmarks (mean).
        to: LandmarkSet,
    },
    /// The normal `(b − a) × (c − b)` of the plane through three landmarks, which at rest is
    /// `rest` (the hinge axis of the child: a straight limb has no plane).
    Normal {
        /// Landmarks a, b, c.
        points: [usize; 3],
        /// The normal's rest direction, autoact frame.
        rest: Unit<Vector3<f64>>,
    },
}

/// One way of observing a bone's direction.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionSource {
    /// Start landmarks (mean).
    pub from: LandmarkSet,
    /// End landmarks (mean).
    pub to: LandmarkSet,
}

/// Which landmarks drive a bone: direction alternatives (the first one whose landmarks a layout
/// has is used) and twist-reference alternatives (likewise).
#[derive(Debug, Clone, PartialEq)]
pub struct Recipe {
    /// Bone index.
    pub bone: usize,
    /// Direction alternatives, in order of preference.
    pub directions: Vec<DirectionSource>,
    /// Twist-reference alternatives, in order of preference (empty for 2-D and 1-D bones).
    pub references: Vec<Reference>,
    /// Aim the bone from its solved head at the direction's end point instead of along the
    /// observed `from → to` line: for a bone whose `from` point is not its head (the clavicle,
    /// seen from the chest), so the end point lands where it is seen.
    pub aim: bool,
}

/// A pair of landmarks whose distance measures a body segment, used to fit a [`crate::skeleton::character::Character`].
#[derive(Debug, Clone, PartialEq)]
pub struct Measure {
    /// Start landmarks (mean).
    pub from: LandmarkSet,
    /// End landmarks (mean).
    pub to: LandmarkSet,
    /// Bones whose length scale this distance sets.
    pub bones: Vec<usize>,
}

/// The rig: bones in parent-before-child order, landmarks, recipes and measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    /// Rig name, stored in animation files.
    pub name: &'static str,
    /// Bones; `bones[0]` is the root.
    pub bones: Vec<Bone>,
    /// Landmarks.
    pub landmarks: Vec<Landmark>,
    /// Driving recipes for every bone that is not static or root.
    pub recipes: Vec<Recipe>,
    /// Widths of the shoulders on the chest and the hips on the pelvis, measured to fit body
    /// proportions along with the segments a layout drives.
    pub width_measures: Vec<Measure>,
}

/// Index of the root bone.
pub const ROOT: usize = 0;

/// Number of bones in the autoact rig.
pub const BONE_COUNT: usize = 53;

impl Rig {
    /// Index of a bone by autoact name or GTA name.
    #[must_use]
    pub fn bone_index(&self, name: &str) -> Option<usize> {
        self.bones
            .iter()
            .position(|b| b.name == name || b.gta_name == name)
    }

    /// Index of a landmark by name.
    #[must_use]
    pub fn landmark_index(&self, name: &str) -> Option<usize> {
        self.landmarks.iter().position(|l| l.name == name)
    }

    /// Rest position of the mean of a landmark set.
    #[must_use]
    pub fn rest_point(&self, set: &[usize]) -> Point3<f64> {
        mean_point(set.iter().map(|&i| self.landmarks[i].rest_m))
    }

    /// Whether `ancestor` is `bone` or one of its ancestors.
    #[must_use]
    pub fn is_ancestor(&self, ancestor: usize, mut bone: usize) -> bool {
        loop {
            if bone == ancestor {
                return true;
            }
            match self.bones[bone].parent {
                Some(p) => bone = p,
                None => return false,
            }
        }
    }

    /// The default rig: the 53 bones of the GTA V ped skeleton used by the paper, with an adult
    /// (1.75 m) T-pose rest skeleton.
    #[must_use]
    ///
    /// # Panics
    /// Never for a released build: the built-in tables name only bones and landmarks the rig
    /// has, which the test `built_in_tables_resolve` proves. A misspelt name in them is a bug
    /// and stops here, naming the bone and the landmark, rather than building a wrong rig.
    pub fn standard() -> Rig {
        match build_standard() {
            Ok(rig) => rig,
            Err(e) => panic!("the built-in rig tables are inconsistent: {e}"),
        }
    }
}

fn mean_point(points: impl Iterator<Item = Point3<f64>>) -> Point3<f64> {
    let mut sum = Vector3::zeros();
    let mut n = 0.0;
    for p in points {
        sum += p.coords;
        n += 1.0;
    }
    Point3::from(sum / n)
}

// ---------------------------------------------------------------------------------------------
// The table.
// ---------------------------------------------------------------------------------------------

/// Left-side and centre bones; right-side bones are their mirror images (x → −x).
/// (name, GTA name, GTA tag, parent, head, tail, dof) — for sided bones the GTA fields are given
/// for the left side and the right side's come from [`RIGHT_GTA`].
struct BoneDef {
    name: &'static str,
    gta: (&'static str, u16),
    parent: &'static str,
    head: [f64; 3],
    tail: [f64; 3],
    dof: DofDef,
}

#[derive(Clone, Copy)]
enum DofDef {
    Root,
    D3,
    D2,
    /// Hinge about an axis given for the left side (mirrored as an axial vector for the right).
    Hinge([f64; 3]),
    /// Finger hinge: axis = bone direction × palm normal (−Z), i.e. flexion towards the palm.
    FingerHinge,
    Static,
}

const HIP_Z: f64 = 0.90;
const SHOULDER_Z: f64 = 1.44;

#[rustfmt::skip]
/// Finger joints of the left hand at rest: (finger, [base, second, third, tip] positions).
const LEFT_FINGERS: [(&str, [[f64; 3]; 4]); 5] = [
    ("thumb", [[-0.735, 0.025, 1.435], [-0.765, 0.050, 1.430], [-0.790, 0.070, 1.430], [-0.810, 0.085, 1.430]]),
    ("index", [[-0.800, 0.025, SHOULDER_Z], [-0.845, 0.025, SHOULDER_Z], [-0.870, 0.025, SHOULDER_Z], [-0.892, 0.025, SHOULDER_Z]]),
    ("middle", [[-0.805, 0.000, SHOULDER_Z], [-0.855, 0.000, SHOULDER_Z], [-0.885, 0.000, SHOULDER_Z], [-0.909, 0.000, SHOULDER_Z]]),
    ("ring", [[-0.800, -0.020, SHOULDER_Z], [-0.845, -0.020, SHOULDER_Z], [-0.873, -0.020, SHOULDER_Z], [-0.895, -0.020, SHOULDER_Z]]),
    ("pinky", [[-0.790, -0.040, SHOULDER_Z], [-0.825, -0.040, SHOULDER_Z], [-0.845, -0.040, SHOULDER_Z], [-0.865, -0.040, SHOULDER_Z]]),
];

#[rustfmt::skip]
/// GTA names and tags of the finger bones, left then right, per finger (thumb..pinky) × 3.
const LEFT_FINGER_GTA: [[(&str, u16); 3]; 5] = [
    [("SKEL_L_Finger00", 26610), ("SKEL_L_Finger01", 4089), ("SKEL_L_Finger02", 4090)],
    [("SKEL_L_Finger10", 26611), ("SKEL_L_Finger11", 4169), ("SKEL_L_Finger12", 4170)],
    [("SKEL_L_Finger20", 26612), ("SKEL_L_Finger21", 4185), ("SKEL_L_Finger22", 4186)],
    [("SKEL_L_Finger30", 26613), ("SKEL_L_Finger31", 4137), ("SKEL_L_Finger32", 4138)],
    [("SKEL_L_Finger40", 26614), ("SKEL_L_Finger41", 4153), ("SKEL_L_Finger42", 4154)],
];
#[rustfmt::skip]
const RIGHT_FINGER_GTA: [[(&str, u16); 3]; 5] = [
    [("SKEL_R_Finger00", 58866), ("SKEL_R_Finger01", 64016), ("SKEL_R_Finger02", 64017)],
    [("SKEL_R_Finger10", 58867), ("SKEL_R_Finger11", 64096), ("SKEL_R_Finger12", 64097)],
    [("SKEL_R_Finger20", 58868), ("SKEL_R_Finger21", 64112), ("SKEL_R_Finger22", 64113)],
    [("SKEL_R_Finger30", 58869), ("SKEL_R_Finger31", 64064), ("SKEL_R_Finger32", 64065)],
    [("SKEL_R_Finger40", 58870), ("SKEL_R_Finger41", 64080), ("SKEL_R_Finger42", 64081)],
];

#[rustfmt::skip]
/// GTA names/tags of the right-side body bones, keyed by the left bone's autoact name.
const RIGHT_GTA: [(&str, (&str, u16)); 7] = [
    ("l_thigh", ("SKEL_R_Thigh", 51826)),
    ("l_calf", ("SKEL_R_Calf", 36864)),
    ("l_foot", ("SKEL_R_Foot", 52301)),
    ("l_clavicle", ("SKEL_R_Clavicle", 10706)),
    ("l_upper_arm", ("SKEL_R_UpperArm", 40269)),
    ("l_forearm", ("SKEL_R_Forearm", 28252)),
    ("l_hand", ("SKEL_R_Hand", 57005)),
];

#[rustfmt::skip]
fn leg_defs() -> Vec<BoneDef> {
    vec![
        BoneDef { name: "l_thigh", gta: ("SKEL_L_Thigh", 58271), parent: "pelvis", head: [-0.09, 0.0, HIP_Z], tail: [-0.09, 0.0, 0.49], dof: DofDef::D3 },
        BoneDef { name: "l_calf", gta: ("SKEL_L_Calf", 63931), parent: "l_thigh", head: [-0.09, 0.0, 0.49], tail: [-0.09, 0.0, 0.08], dof: DofDef::Hinge([-1.0, 0.0, 0.0]) },
        // The foot's axis runs from the ankle to the midpoint of the big and small toe tips.
        BoneDef { name: "l_foot", gta: ("SKEL_L_Foot", 14201), parent: "l_calf", head: [-0.09, 0.0, 0.08], tail: [-0.095, 0.1775, 0.01], dof: DofDef::D2 },
    ]
}

#[rustfmt::skip]
fn arm_defs() -> Vec<BoneDef> {
    let mut v = vec![
        BoneDef { name: "l_clavicle", gta: ("SKEL_L_Clavicle", 64729), parent: "spine3", head: [-0.02, 0.0, 1.42], tail: [-0.18, 0.0, SHOULDER_Z], dof: DofDef::D2 },
        BoneDef { name: "l_upper_arm", gta: ("SKEL_L_UpperArm", 45509), parent: "l_clavicle", head: [-0.18, 0.0, SHOULDER_Z], tail: [-0.46, 0.0, SHOULDER_Z], dof: DofDef::D3 },
        BoneDef { name: "l_forearm", gta: ("SKEL_L_Forearm", 61163), parent: "l_upper_arm", head: [-0.46, 0.0, SHOULDER_Z], tail: [-0.71, 0.0, SHOULDER_Z], dof: DofDef::Hinge([0.0, 0.0, -1.0]) },
        BoneDef { name: "l_hand", gta: ("SKEL_L_Hand", 18905), parent: "l_forearm", head: [-0.71, 0.0, SHOULDER_Z], tail: LEFT_FINGERS[2].1[0], dof: DofDef::D3 },
    ];
    for (f, (finger, joints)) in LEFT_FINGERS.iter().enumerate() {
        for k in 0..3 {
            v.push(BoneDef {
                name: FINGER_BONE_NAMES[f][k],
                gta: LEFT_FINGER_GTA[f][k],
                parent: if k == 0 {
                    "l_hand"
                } else {
                    FINGER_BONE_NAMES[f][k - 1]
                },
                head: joints[k],
                tail: joints[k + 1],
                dof: if k == 0 {
                    DofDef::D2
                } else {
                    DofDef::FingerHinge
                },
            });
            let _ = finger;
        }
    }
    v
}

const FINGER_BONE_NAMES: [[&str; 3]; 5] = [
    ["l_thumb0", "l_thumb1", "l_thumb2"],
    ["l_index0", "l_index1", "l_index2"],
    ["l_middle0", "l_middle1", "l_middle2"],
    ["l_ring0", "l_ring1", "l_ring2"],
    ["l_pinky0", "l_pinky1", "l_pinky2"],
];

#[rustfmt::skip]
fn centre_defs_before_legs() -> Vec<BoneDef> {
    vec![
        BoneDef { name: "root", gta: ("SKEL_ROOT", 0), parent: "", head: [0.0, 0.0, 0.0], tail: [0.0, 0.15, 0.0], dof: DofDef::Root },
        BoneDef { name: "pelvis", gta: ("SKEL_Pelvis", 11816), parent: "root", head: [0.0, 0.0, HIP_Z], tail: [0.0, 0.0, 0.80], dof: DofDef::D3 },
    ]
}

#[rustfmt::skip]
fn spine_defs() -> Vec<BoneDef> {
    vec![
        BoneDef { name: "spine_root", gta: ("SKEL_Spine_Root", 57597), parent: "root", head: [0.0, 0.0, HIP_Z], tail: [0.0, 0.0, 1.0], dof: DofDef::Static },
        BoneDef { name: "spine0", gta: ("SKEL_Spine0", 23553), parent: "spine_root", head: [0.0, 0.0, HIP_Z], tail: [0.0, 0.0, 1.02], dof: DofDef::D3 },
        BoneDef { name: "spine1", gta: ("SKEL_Spine1", 24816), parent: "spine0", head: [0.0, 0.0, 1.02], tail: [0.0, 0.0, 1.13], dof: DofDef::D3 },
        BoneDef { name: "spine2", gta: ("SKEL_Spine2", 24817), parent: "spine1", head: [0.0, 0.0, 1.13], tail: [0.0, 0.0, 1.27], dof: DofDef::D3 },
        BoneDef { name: "spine3", gta: ("SKEL_Spine3", 24818), parent: "spine2", head: [0.0, 0.0, 1.27], tail: [0.0, 0.0, SHOULDER_Z], dof: DofDef::D3 },
        BoneDef { name: "neck", gta: ("SKEL_Neck_1", 39317), parent: "spine3", head: [0.0, 0.0, SHOULDER_Z], tail: [0.0, 0.0, 1.54], dof: DofDef::D3 },
        BoneDef { name: "head", gta: ("SKEL_Head", 31086), parent: "neck", head: [0.0, 0.0, 1.54], tail: [0.0, 0.0, 1.75], dof: DofDef::D3 },
    ]
}

#[rustfmt::skip]
/// Landmarks: (name, bone, rest position) for the centre and the left side; the right side is
/// mirrored (`l_` → `r_`, x → −x).
fn landmark_defs() -> Vec<(&'static str, &'static str, [f64; 3])> {
    let mut v = vec![
        ("pelvis", "spine_root", [0.0, 0.0, HIP_Z]),
        ("spine_mid", "spine1", [0.0, 0.0, 1.13]),
        ("chest", "spine3", [0.0, 0.0, SHOULDER_Z]),
        ("neck", "neck", [0.0, 0.0, 1.54]),
        ("head_center", "head", [0.0, 0.0, 1.63]),
        ("head_top", "head", [0.0, 0.0, 1.75]),
        ("nose", "head", [0.0, 0.105, 1.62]),
        ("l_eye", "head", [-0.032, 0.085, 1.66]),
        ("l_ear", "head", [-0.075, 0.0, 1.63]),
        ("l_hip", "pelvis", [-0.09, 0.0, HIP_Z]),
        ("l_knee", "l_thigh", [-0.09, 0.0, 0.49]),
        ("l_ankle", "l_calf", [-0.09, 0.0, 0.08]),
        ("l_toe", "l_foot", [-0.092, 0.125, 0.02]),
        ("l_heel", "l_foot", [-0.09, -0.05, 0.01]),
        ("l_big_toe", "l_foot", [-0.065, 0.19, 0.01]),
        ("l_small_toe", "l_foot", [-0.125, 0.165, 0.01]),
        ("l_clavicle", "spine3", [-0.02, 0.0, 1.42]),
        ("l_shoulder", "l_clavicle", [-0.18, 0.0, SHOULDER_Z]),
        ("l_elbow", "l_upper_arm", [-0.46, 0.0, SHOULDER_Z]),
        ("l_wrist", "l_forearm", [-0.71, 0.0, SHOULDER_Z]),
    ];
    for (f, (_, joints)) in LEFT_FINGERS.iter().enumerate() {
        for (k, p) in joints.iter().enumerate() {
            let bone = if k == 0 {
                "l_hand"
            } else {
                FINGER_BONE_NAMES[f][k - 1]
            };
            v.push((finger_landmark_name(f, k), bone, *p));
        }
    }
    v
}

/// `l_thumb1` .. `l_pinky4` for finger `f` of [`LEFT_FINGERS`] and joint `k`: the numbering
/// follows COCO-WholeBody (1 = base joint, 4 = tip).
fn finger_landmark_name(f: usize, k: usize) -> &'static str {
    const NAMES: [[&str; 4]; 5] = [
        ["l_thumb1", "l_thumb2", "l_thumb3", "l_thumb4"],
        ["l_index1", "l_index2", "l_index3", "l_index4"],
        ["l_middle1", "l_middle2", "l_middle3", "l_middle4"],
        ["l_ring1", "l_ring2", "l_ring3", "l_ring4"],
        ["l_pinky1", "l_pinky2", "l_pinky3", "l_pinky4"],
    ];
    NAMES[f][k]
}

fn mirror_name(name: &str) -> String {
    name.strip_prefix("l_")
        .map_or_else(|| name.to_string(), |rest| format!("r_{rest}"))
}

fn mirror_point(p: [f64; 3]) -> [f64; 3] {
    [-p[0], p[1], p[2]]
}

/// Mirror of an axial vector (a rotation axis) under x → −x: `det(M)·M·v = (v.x, −v.y, −v.z)`.
fn mirror_axis(a: [f64; 3]) -> [f64; 3] {
    [a[0], -a[1], -a[2]]
}

/// The anatomical rest frame: +Y along `dir`, +X as close as possible to `x_hint`.
fn anatomical_frame(dir: &Unit<Vector3<f64>>, x_hint: &Vector3<f64>) -> UnitQuaternion<f64> {
    let y = dir.into_inner();
    let candidates = [*x_hint, Vector3::x(), Vector3::y(), Vector3::z()];
    let x = candidates
        .iter()
        .find_map(|c| crate::skeleton::geom::perpendicular_direction(c, dir, 0.2))
        .map_or_else(Vector3::x, Unit::into_inner);
    let z = x.cross(&y);
    let m = Matrix3::from_columns(&[x, y, z]);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m))
}

struct Builder {
    bones: Vec<Bone>,
}

impl Builder {
    fn index(&self, name: &str) -> Option<usize> {
        self.bones.iter().position(|b| b.name == name)
    }

    fn push(&mut self, def: &BoneDef, mirrored: bool) {
        let map_p = |p: [f64; 3]| if mirrored { mirror_point(p) } else { p };
        let name = if mirrored {
            mirror_name(def.name)
        } else {
            def.name.to_string()
        };
        let parent_name = if mirrored {
            mirror_name(def.parent)
        } else {
            def.parent.to_string()
        };
        let parent = self.index(&parent_name);
        let head = Point3::from(map_p(def.head));
        let tail = Point3::from(map_p(def.tail));
        let dir = crate::skeleton::geom::direction(tail - head).unwrap_or_else(Vector3::y_axis);
        let dof = match def.dof {
            DofDef::Root => Dof::Root,
            DofDef::D3 => Dof::ThreeD,
            DofDef::D2 => Dof::TwoD,
            DofDef::Static => Dof::Static,
            DofDef::Hinge(a) => {
                let a = if mirrored { mirror_axis(a) } else { a };
                Dof::Hinge {
                    axis: Unit::new_normalize(Vector3::from(a)),
                }
            }
            DofDef::FingerHinge => {
                let axis = dir.cross(&-Vector3::z());
                Dof::Hinge {
                    axis: Unit::new_normalize(axis),
                }
            }
        };
        let x_hint = match dof {
            Dof::Hinge { axis } => axis.into_inner(),
            _ => Vector3::x(),
        };
        let (gta_name, gta_tag) = if mirrored {
            right_gta(def.name)
        } else {
            def.gta
        };
        self.bones.push(Bone {
            name,
            gta_name,
            gta_tag,
            parent,
            head_rest_m: head,
            tail_rest_m: tail,
            dof,
            rest_orientation: anatomical_frame(&dir, &x_hint),
        });
    }
}

fn right_gta(left_name: &str) -> (&'static str, u16) {
    if let Some((_, g)) = RIGHT_GTA.iter().find(|(l, _)| *l == left_name) {
        return *g;
    }
    for (f, names) in FINGER_BONE_NAMES.iter().enumerate() {
        if let Some(k) = names.iter().position(|n| *n == left_name) {
            return RIGHT_FINGER_GTA[f][k];
        }
    }
    ("", 0)
}

/// A name in the built-in rig tables that the rig does not have.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RigTableError {
    /// A recipe for a bone the rig does not have.
    #[error("recipe for bone `{bone}`: the rig has no such bone")]
    UnknownBone {
        /// The bone the recipe names.
        bone: String,
    },
    /// A recipe naming a landmark the rig does not have.
    #[error("recipe for bone `{bone}`: the rig has no landmark `{landmark}`")]
    UnknownLandmark {
        /// The bone the recipe drives.
        bone: String,
        /// The landmark name it gives.
        landmark: String,
    },
    /// A landmark on a bone the rig does not have.
    #[error("landmark `{landmark}`: the rig has no bone `{bone}`")]
    LandmarkBone {
        /// The landmark.
        landmark: String,
        /// The bone it is said to ride on.
        bone: String,
    },
    /// A width measure naming a landmark the rig does not have.
    #[error("width measure `{from}` → `{to}`: the rig has no landmark `{landmark}`")]
    MeasureLandmark {
        /// Start landmark of the measure.
        from: String,
        /// End landmark of the measure.
        to: String,
        /// The name not found.
        landmark: String,
    },
}

fn build_standard() -> Result<Rig, RigTableError> {
    let bones = build_bones();
    let landmarks = build_landmarks(&bones)?;
    let mut rig = Rig {
        name: "autoact53",
        bones,
        landmarks,
        recipes: Vec::new(),
        width_measures: Vec::new(),
    };
    rig.recipes = build_recipes(&rig)?;
    rig.width_measures = build_width_measures(&rig)?;
    Ok(rig)
}

/// The bones: centre, legs (left then mirrored), spine, arms (left then mirrored).
fn build_bones() -> Vec<Bone> {
    let mut b = Builder {
        bones: Vec::with_capacity(BONE_COUNT),
    };
    for d in centre_defs_before_legs() {
        b.push(&d, false);
    }
    for mirrored in [false, true] {
        for d in leg_defs() {
            b.push(&d, mirrored);
        }
    }
    for d in spine_defs() {
        b.push(&d, false);
    }
    for mirrored in [false, true] {
        for d in arm_defs() {
            b.push(&d, mirrored);
        }
    }
    b.bones
}

/// The landmarks of [`landmark_defs`], each sided one followed by its mirror image.
fn build_landmarks(bones: &[Bone]) -> Result<Vec<Landmark>, RigTableError> {
    let bone_of = |landmark: &str, bone: &str| {
        bones
            .iter()
            .position(|x| x.name == bone)
            .ok_or_else(|| RigTableError::LandmarkBone {
                landmark: landmark.to_string(),
                bone: bone.to_string(),
            })
    };
    let mut landmarks = Vec::new();
    for (name, bone, p) in landmark_defs() {
        landmarks.push(Landmark {
            name: name.to_string(),
            bone: bone_of(name, bone)?,
            rest_m: Point3::from(p),
        });
        if name.starts_with("l_") {
            let rname = mirror_name(name);
            let rbone = mirror_name(bone);
            landmarks.push(Landmark {
                bone: bone_of(&rname, &rbone)?,
                name: rname,
                rest_m: Point3::from(mirror_point(p)),
            });
        }
    }
    Ok(landmarks)
}

/// Landmark names, as the recipe table writes them.
type Names = Vec<String>;

/// A recipe as the built-in table writes it, by names; [`resolve_recipe`] makes it a [`Recipe`].
#[derive(Debug, Clone, PartialEq)]
struct RecipeDef {
    bone: String,
    /// `(from, to)` landmark names per direction alternative.
    directions: Vec<(Names, Names)>,
    references: Vec<ReferenceDef>,
    aim: bool,
}

/// A [`Reference`] by landmark names.
#[derive(Debug, Clone, PartialEq)]
enum ReferenceDef {
    Direction(Names, Names),
    Normal([String; 3], Unit<Vector3<f64>>),
}

fn names(list: &[&str]) -> Names {
    list.iter().map(|n| (*n).to_string()).collect()
}

/// A direction alternative `from → to` by names.
fn dir(from: &[&str], to: &[&str]) -> (Names, Names) {
    (names(from), names(to))
}

fn recipe(bone: &str, directions: Vec<(Names, Names)>, references: Vec<ReferenceDef>) -> RecipeDef {
    RecipeDef {
        bone: bone.to_string(),
        directions,
        references,
        aim: false,
    }
}

/// The pelvis, spine, neck and head: directions along the trunk, twist from the hips, the
/// shoulders, the ears or the eyes. The pelvis is aimed along the hip line (its roll and yaw) and
/// turned about it by the lower trunk (its tilt: hips and pelvis point are collinear in most
/// layouts, so the tilt follows the trunk, as it mostly does when the body bends at the hips).
fn trunk_recipes() -> Vec<RecipeDef> {
    let hips = ReferenceDef::Direction(names(&["l_hip"]), names(&["r_hip"]));
    let shoulders = ReferenceDef::Direction(names(&["l_shoulder"]), names(&["r_shoulder"]));
    let mut out = vec![recipe(
        "pelvis",
        vec![dir(&["l_hip"], &["r_hip"])],
        vec![
            ReferenceDef::Direction(names(&["pelvis"]), names(&["spine_mid"])),
            ReferenceDef::Direction(names(&["pelvis"]), names(&["chest"])),
        ],
    )];
    for s in ["spine0", "spine1"] {
        out.push(recipe(
            s,
            vec![
                dir(&["pelvis"], &["spine_mid"]),
                dir(&["pelvis"], &["chest"]),
            ],
            vec![hips.clone()],
        ));
    }
    for s in ["spine2", "spine3"] {
        out.push(recipe(
            s,
            vec![
                dir(&["spine_mid"], &["chest"]),
                dir(&["pelvis"], &["chest"]),
            ],
            vec![shoulders.clone()],
        ));
    }
    out.push(recipe(
        "neck",
        vec![
            dir(&["chest"], &["neck"]),
            dir(&["chest"], &["head_center"]),
        ],
        vec![shoulders],
    ));
    out.push(recipe(
        "head",
        vec![
            dir(&["neck"], &["head_top"]),
            dir(&["neck"], &["head_center"]),
            dir(&["head_center"], &["nose"]),
        ],
        vec![
            ReferenceDef::Direction(names(&["l_ear"]), names(&["r_ear"])),
            ReferenceDef::Direction(names(&["l_eye"]), names(&["r_eye"])),
        ],
    ));
    out
}

/// One side's (`l` or `r`) leg, clavicle, arm and hand: twist of the thigh and upper arm from the plane of
/// the limb (at rest, the knee's and elbow's hinge axes), of the hand from its knuckles.
fn limb_recipes(rig: &Rig, side: &str) -> Result<Vec<RecipeDef>, RigTableError> {
    let n = |s: &str| format!("{side}_{s}");
    let sdir = |from: &str, to: &str| (vec![n(from)], vec![n(to)]);
    let mirrored = |a: [f64; 3]| {
        Unit::new_normalize(Vector3::from(if side == "l" { a } else { mirror_axis(a) }))
    };
    let hinge_axis = |bone: &str, otherwise: [f64; 3]| {
        let b = rig
            .bone_index(&n(bone))
            .ok_or_else(|| RigTableError::UnknownBone { bone: n(bone) })?;
        Ok(match rig.bones[b].dof {
            Dof::Hinge { axis } => axis,
            _ => mirrored(otherwise),
        })
    };
    let knee_axis = hinge_axis("calf", [-1.0, 0.0, 0.0])?;
    let elbow_axis = hinge_axis("forearm", [0.0, 0.0, -1.0])?;
    let direction = |from: &str, to: &str| ReferenceDef::Direction(vec![n(from)], vec![n(to)]);
    Ok(vec![
        recipe(
            &n("thigh"),
            vec![sdir("hip", "knee")],
            vec![ReferenceDef::Normal(
                [n("hip"), n("knee"), n("ankle")],
                knee_axis,
            )],
        ),
        recipe(&n("calf"), vec![sdir("knee", "ankle")], vec![]),
        recipe(
            &n("foot"),
            vec![
                (vec![n("ankle")], vec![n("big_toe"), n("small_toe")]),
                sdir("ankle", "toe"),
            ],
            vec![],
        ),
        // The clavicle swings (shrug, protraction) to put the shoulder where it is seen: from
        // the sternoclavicular joint when the layout has it, else from the chest.
        RecipeDef {
            aim: true,
            ..recipe(
                &n("clavicle"),
                vec![
                    sdir("clavicle", "shoulder"),
                    (names(&["chest"]), vec![n("shoulder")]),
                ],
                vec![],
            )
        },
        recipe(
            &n("upper_arm"),
            vec![sdir("shoulder", "elbow")],
            vec![ReferenceDef::Normal(
                [n("shoulder"), n("elbow"), n("wrist")],
                elbow_axis,
            )],
        ),
        recipe(&n("forearm"), vec![sdir("elbow", "wrist")], vec![]),
        recipe(
            &n("hand"),
            vec![sdir("wrist", "middle1")],
            vec![
                direction("index1", "pinky1"),
                direction("index1", "ring1"),
                direction("wrist", "thumb4"),
            ],
        ),
    ])
}

/// One side's (`l` or `r`) phalanges: each points from its joint to the next.
fn finger_recipes(side: &str) -> Vec<RecipeDef> {
    let mut out = Vec::new();
    for (f, (finger, _)) in LEFT_FINGERS.iter().enumerate() {
        for (k, left_bone) in FINGER_BONE_NAMES[f].iter().enumerate() {
            let bone = if side == "l" {
                (*left_bone).to_string()
            } else {
                mirror_name(left_bone)
            };
            out.push(recipe(
                &bone,
                vec![(
                    vec![format!("{side}_{finger}{}", k + 1)],
                    vec![format!("{side}_{finger}{}", k + 2)],
                )],
                vec![],
            ));
        }
    }
    out
}

/// The recipe table by names, in the rig's recipe order: trunk, then each side's limbs and
/// fingers.
fn recipe_table(rig: &Rig) -> Result<Vec<RecipeDef>, RigTableError> {
    let mut table = trunk_recipes();
    for side in ["l", "r"] {
        table.extend(limb_recipes(rig, side)?);
        table.extend(finger_recipes(side));
    }
    Ok(table)
}

/// A recipe's names as indices of `rig`: an unknown bone or landmark is an error naming both.
fn resolve_recipe(rig: &Rig, def: &RecipeDef) -> Result<Recipe, RigTableError> {
    let bone = rig
        .bone_index(&def.bone)
        .ok_or_else(|| RigTableError::UnknownBone {
            bone: def.bone.clone(),
        })?;
    let landmark = |name: &String| {
        rig.landmark_index(name)
            .ok_or_else(|| RigTableError::UnknownLandmark {
                bone: def.bone.clone(),
                landmark: name.clone(),
            })
    };
    let set = |list: &Names| {
        list.iter()
            .map(landmark)
            .collect::<Result<LandmarkSet, _>>()
    };
    let directions = def
        .directions
        .iter()
        .map(|(from, to)| {
            Ok(DirectionSource {
                from: set(from)?,
                to: set(to)?,
            })
        })
        .collect::<Result<_, RigTableError>>()?;
    let references = def
        .references
        .iter()
        .map(|r| {
            Ok(match r {
                ReferenceDef::Direction(from, to) => Reference::Direction {
                    from: set(from)?,
                    to: set(to)?,
                },
                ReferenceDef::Normal([a, b, c], rest) => Reference::Normal {
                    points: [landmark(a)?, landmark(b)?, landmark(c)?],
                    rest: *rest,
                },
            })
        })
        .collect::<Result<_, RigTableError>>()?;
    Ok(Recipe {
        bone,
        directions,
        references,
        aim: def.aim,
    })
}

fn build_recipes(rig: &Rig) -> Result<Vec<Recipe>, RigTableError> {
    recipe_table(rig)?
        .iter()
        .map(|def| resolve_recipe(rig, def))
        .collect()
}

impl Rig {
    /// The measure of the segment `from → to` (landmark sets): the bones on the path from the
    /// bone `to` rides on up to (not including) the lowest common ancestor with the bone `from`
    /// rides on; both on one bone → that bone. `None` for an empty set or an empty path.
    #[must_use]
    pub fn measure(&self, from: &[usize], to: &[usize]) -> Option<Measure> {
        let a = self.landmarks[*from.first()?].bone;
        let b = self.landmarks[*to.first()?].bone;
        let mut bones = Vec::new();
        if a == b {
            bones.push(a);
        } else {
            let mut cur = b;
            while !self.is_ancestor(cur, a) {
                bones.push(cur);
                match self.bones[cur].parent {
                    Some(p) => cur = p,
                    None => break,
                }
            }
        }
        (!bones.is_empty()).then(|| Measure {
            from: from.to_vec(),
            to: to.to_vec(),
            bones,
        })
    }
}

fn build_width_measures(rig: &Rig) -> Result<Vec<Measure>, RigTableError> {
    let mut measures = Vec::new();
    for (from, to) in [
        ("chest", "l_shoulder"),
        ("chest", "r_shoulder"),
        ("pelvis", "l_hip"),
        ("pelvis", "r_hip"),
    ] {
        let landmark = |name: &str| {
            rig.landmark_index(name)
                .ok_or_else(|| RigTableError::MeasureLandmark {
                    from: from.to_string(),
                    to: to.to_string(),
                    landmark: name.to_string(),
                })
        };
        measures.extend(rig.measure(&[landmark(from)?], &[landmark(to)?]));
    }
    Ok(measures)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rig_has_53_bones_with_the_papers_class_counts() {
        let rig = Rig::standard();
        assert_eq!(rig.bones.len(), BONE_COUNT);
        let count = |label: &str| rig.bones.iter().filter(|b| b.dof.label() == label).count();
        assert_eq!(count("root"), 1);
        // The paper's rig had 4 static bones (pelvis, spine root, clavicles), 12 3-D and 12 2-D;
        // the pelvis is now 3-D and the clavicles 2-D (issue 19), `DofSet::Paper` holds those
        // three at rest again.
        assert_eq!(count("static"), 1, "spine root");
        assert_eq!(
            count("3-D"),
            13,
            "pelvis, spine0-3, neck, head, upper arms, thighs, hands"
        );
        assert_eq!(
            count("2-D"),
            14,
            "ten finger bases, two feet, two clavicles"
        );
        assert_eq!(count("1-D"), 24, "forearms, calves and twenty phalanges");
        let held: Vec<&str> = rig
            .bones
            .iter()
            .filter(|b| DofSet::Paper.holds_at_rest(b))
            .map(|b| b.name.as_str())
            .collect();
        assert_eq!(held, ["pelvis", "l_clavicle", "r_clavicle"]);
        assert!(!rig.bones.iter().any(|b| DofSet::Full.holds_at_rest(b)));
    }

    #[test]
    fn parents_precede_children_and_names_are_unique() {
        let rig = Rig::standard();
        for (i, b) in rig.bones.iter().enumerate() {
            if i == ROOT {
                assert!(b.parent.is_none());
            } else {
                assert!(
                    b.parent.is_some_and(|p| p < i),
                    "{} has parent {:?}",
                    b.name,
                    b.parent
                );
            }
            assert_eq!(rig.bones.iter().filter(|o| o.name == b.name).count(), 1);
            assert_eq!(
                rig.bones.iter().filter(|o| o.gta_tag == b.gta_tag).count(),
                1,
                "{}",
                b.gta_name
            );
            assert!(b.gta_name.starts_with("SKEL_"), "{}", b.name);
        }
    }

    #[test]
    fn hinge_axes_are_perpendicular_to_their_bones() {
        let rig = Rig::standard();
        for b in &rig.bones {
            if let Dof::Hinge { axis } = b.dof {
                assert!(axis.dot(&b.rest_direction()).abs() < 1e-9, "{}", b.name);
                assert!(
                    (b.rest_orientation * Vector3::x() - axis.into_inner()).norm() < 1e-9,
                    "{}",
                    b.name
                );
            }
        }
    }

    #[test]
    fn every_moving_bone_has_a_recipe_and_every_landmark_a_bone() {
        let rig = Rig::standard();
        for (i, b) in rig.bones.iter().enumerate() {
            let moving = !matches!(b.dof, Dof::Static | Dof::Root);
            assert_eq!(
                rig.recipes.iter().any(|r| r.bone == i),
                moving,
                "{}",
                b.name
            );
        }
        for r in &rig.recipes {
            for d in &r.directions {
                assert!(!d.from.is_empty() && !d.to.is_empty());
                let v = rig.rest_point(&d.to) - rig.rest_point(&d.from);
                assert!(
                    v.norm() > 0.005,
                    "{}: zero-length rest direction",
                    rig.bones[r.bone].name
                );
            }
        }
        assert!(rig.landmarks.iter().all(|l| l.bone < rig.bones.len()));
        let names: std::collections::BTreeSet<_> =
            rig.landmarks.iter().map(|l| l.name.as_str()).collect();
        assert_eq!(names.len(), rig.landmarks.len());
    }

    #[test]
    fn built_in_tables_resolve() {
        let rig = build_standard().unwrap();
        assert_eq!(rig, Rig::standard());
        // Every entry of the recipe table resolves on its own, so none is dropped on the way.
        let table = recipe_table(&rig).unwrap();
        assert_eq!(table.len(), rig.recipes.len());
        for def in &table {
            resolve_recipe(&rig, def).unwrap();
        }
        assert_eq!(rig.width_measures.len(), 4);
    }

    #[test]
    fn a_misspelt_recipe_name_is_refused_naming_bone_and_landmark() {
        let rig = Rig::standard();
        let mut table = recipe_table(&rig).unwrap();
        let thigh = table.iter_mut().find(|d| d.bone == "l_thigh").unwrap();
        thigh.directions[0].1 = vec!["l_kne".to_string()];
        let e = resolve_recipe(&rig, thigh).unwrap_err();
        assert_eq!(
            e,
            RigTableError::UnknownLandmark {
                bone: "l_thigh".into(),
                landmark: "l_kne".into()
            }
        );
        assert_eq!(
            e.to_string(),
            "recipe for bone `l_thigh`: the rig has no landmark `l_kne`"
        );
        let mut normal = table
            .iter()
            .find(|d| d.bone == "r_upper_arm")
            .unwrap()
            .clone();
        let ReferenceDef::Normal(points, _) = &mut normal.references[0] else {
            panic!("the upper arm's twist comes from the arm's plane")
        };
        points[2] = "r_wirst".into();
        assert!(matches!(
            resolve_recipe(&rig, &normal),
            Err(RigTableError::UnknownLandmark { bone, landmark }) if bone == "r_upper_arm" && landmark == "r_wirst"
        ));
        let unknown_bone = recipe("l_tail", vec![dir(&["pelvis"], &["chest"])], vec![]);
        assert_eq!(
            resolve_recipe(&rig, &unknown_bone).unwrap_err(),
            RigTableError::UnknownBone {
                bone: "l_tail".into()
            }
        );
    }

    #[test]
    fn left_and_right_are_mirror_images() {
        let rig = Rig::standard();
        for b in rig.bones.iter().filter(|b| b.name.starts_with("l_")) {
            let r = &rig.bones[rig.bone_index(&mirror_name(&b.name)).unwrap()];
            assert!((r.head_rest_m.x + b.head_rest_m.x).abs() < 1e-12);
            assert!(r.gta_name.contains("_R_"), "{}", r.gta_name);
        }
    }
}
