//! Joint positions → per-bone local quaternions (the paper's rotation-oriented motion
//! representation, done right).
//!
//! For every bone, in parent-before-child order:
//! 1. its recipe's direction landmarks give the current bone direction; the rest direction comes
//!    from the same landmarks on the rest skeleton;
//! 2. for 3-D bones, a reference vector (a body line, or the normal of a limb's bend plane)
//!    projected perpendicular to the bone gives the twist — over a full turn, never folded;
//! 3. the target world rotation is turned into a local one against the parent's *solved* world
//!    rotation (`local = parent_world⁻¹ · child_world`), so projection errors never accumulate;
//! 4. the local rotation is projected onto the bone's degree-of-freedom class: hinges keep only
//!    their angle, 2-D bones lose their twist, static bones stay at rest, the root keeps only yaw
//!    and takes the pelvis trajectory as its translation;
//! 5. its sign is chosen so that ⟨q_t, q_{t−1}⟩ ≥ 0.
//!
//! Only directions enter the rotations (positions are differenced first), so a translated body
//! gives identical rotations. Degenerate input — a missing or non-finite joint, a joint below the
//! confidence threshold, a zero-length bone, a reference parallel to its bone — never panics and
//! never produces NaN: the bone keeps its previous frame's rotation (or, for an unobservable
//! twist, the smallest rotation from its previous orientation), and every such event is counted in
//! the [`ConversionReport`].

use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};

use crate::skeleton::character::Character;
use crate::skeleton::fk::BonePose;
use crate::skeleton::geom;
use crate::skeleton::layout::{Binding, Coverage, Layout, LayoutError, rest_reference};
use crate::skeleton::pose::{PoseFrame, PoseSequence};
use crate::skeleton::rig::{Dof, DofSet, ROOT, Reference, Rig};

/// How the root follows the pelvis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum RootMotion {
    /// The root follows the pelvis in all three axes: walking moves, sitting lowers.
    #[default]
    Full,
    /// Horizontal motion removed (the body walks in place); height kept.
    InPlace,
    /// No translation at all: the body stays at the origin at its rest height.
    Pinned,
}

/// Conversion settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConvertOptions {
    /// Joints with a lower confidence are treated as missing.
    pub min_confidence: f32,
    /// The angle between a 3-D bone and its twist reference (for a thigh or an upper arm, the
    /// knee's or elbow's bend) at and above which the reference alone sets the twist (radians).
    /// Below it the reference's weight falls smoothly to zero at a straight limb and the rest of
    /// the twist is carried from the parent, so a nearly straight limb never spins.
    pub full_twist_reference_angle_rad: f64,
    /// How the root follows the pelvis.
    pub root_motion: RootMotion,
    /// Which degrees of freedom are solved: all (pelvis tilt and roll, clavicle swing) or the
    /// paper's (pelvis and clavicles at rest).
    pub dof: DofSet,
}

impl Default for ConvertOptions {
    fn default() -> Self {
        ConvertOptions {
            min_confidence: 0.3,
            full_twist_reference_angle_rad: 20f64.to_radians(),
            root_motion: RootMotion::Full,
            dof: DofSet::Full,
        }
    }
}

/// Errors that stop a conversion (degenerate frames do not: they are counted).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConvertError {
    /// The layout cannot be bound or does not match the data.
    #[error("layout problem converting {source_name}")]
    Layout {
        /// The data being converted.
        source_name: String,
        /// The cause.
        #[source]
        source: LayoutError,
    },
    /// A frame's arrays do not have the layout's joint count.
    #[error(
        "{source_name}: frame {frame} has {found} positions and {confidences} confidences, the layout `{layout}` has {expected} joints"
    )]
    WrongJointCount {
        /// The data being converted.
        source_name: String,
        /// Frame index.
        frame: usize,
        /// Positions found.
        found: usize,
        /// Confidences found.
        confidences: usize,
        /// Joints expected.
        expected: usize,
        /// Layout name.
        layout: String,
    },
    /// No frame could be used.
    #[error("{source_name}: no usable frames")]
    Empty {
        /// The data being converted.
        source_name: String,
    },
}

/// Kinds of degenerate input, counted per bone and in total.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Degeneracy {
    /// A joint the bone needs was missing or non-finite.
    MissingJoint,
    /// A joint the bone needs was below the confidence threshold.
    LowConfidence,
    /// The bone's two landmarks coincide.
    ZeroLengthBone,
    /// The twist reference was (nearly) parallel to the bone, e.g. a straight limb.
    ParallelReference,
    /// A hinge bone pointed along its own hinge axis.
    AlongHingeAxis,
}

impl Degeneracy {
    /// All kinds, in report order.
    pub const ALL: [Degeneracy; 5] = [
        Degeneracy::MissingJoint,
        Degeneracy::LowConfidence,
        Degeneracy::ZeroLengthBone,
        Degeneracy::ParallelReference,
        Degeneracy::AlongHingeAxis,
    ];

    /// Short label for reports.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Degeneracy::MissingJoint => "missing joint",
            Degeneracy::LowConfidence => "low confidence",
            Degeneracy::ZeroLengthBone => "zero-length bone",
            Degeneracy::ParallelReference => "reference parallel to bone",
            Degeneracy::AlongHingeAxis => "bone along its hinge axis",
        }
    }

    fn index(self) -> usize {
        self as usize
    }
}

/// What a conversion met on the way.
#[derive(Debug, Clone, PartialEq)]
pub struct ConversionReport {
    /// Frames converted.
    pub frames: usize,
    /// Frames in which at least one bone needed the degenerate-input path.
    pub degenerate_frames: usize,
    /// Per kind ([`Degeneracy::ALL`] order): how many (frame, bone) events.
    pub events: [usize; 5],
    /// Per bone, per kind ([`Degeneracy::ALL`] order): frames in which the bone took the
    /// degenerate-input path for that reason.
    pub bone_events: Vec<[usize; 5]>,
    /// Frames dropped because their stamp was not after the previous one: (frame index, stamp).
    pub dropped_non_monotonic: Vec<(usize, u64)>,
    /// Which bones the layout drives.
    pub coverage: Coverage,
}

impl ConversionReport {
    /// The bones that took the degenerate-input path, by name, with their counts per kind
    /// ([`Degeneracy::ALL`] order), the most frequent first.
    #[must_use]
    pub fn degenerate_bones(&self, rig: &Rig) -> Vec<(String, [usize; 5])> {
        let mut bones: Vec<(String, [usize; 5])> = self
            .bone_events
            .iter()
            .zip(&rig.bones)
            .filter(|(events, _)| events.iter().any(|&n| n > 0))
            .map(|(events, bone)| (bone.name.clone(), *events))
            .collect();
        bones.sort_by_key(|(_, events)| std::cmp::Reverse(events.iter().sum::<usize>()));
        bones
    }
}

/// `events` per kind ([`Degeneracy::ALL`] order) in words: `missing joint ×12, low confidence ×3`.
#[must_use]
pub fn describe_events(events: &[usize; 5]) -> String {
    Degeneracy::ALL
        .iter()
        .zip(events)
        .filter(|&(_, &n)| n > 0)
        .map(|(kind, n)| format!("{} ×{n}", kind.label()))
        .collect::<Vec<_>>()
        .join(", ")
}

/// One animation frame.
#[derive(Debug, Clone, PartialEq)]
pub struct AnimationFrame {
    /// Stamp, nanoseconds.
    pub stamp_nanos: u64,
    /// The pose.
    pub pose: BonePose,
}

/// A converted animation: local rotations per bone per frame, and the body they were solved on.
#[derive(Debug, Clone, PartialEq)]
pub struct Animation {
    /// Rig name.
    pub rig_name: String,
    /// Layout the source used.
    pub layout_name: String,
    /// Where the data came from.
    pub source: String,
    /// Proportions fitted to the source subject; the root translation is in its metres.
    pub character: Character,
    /// Frames in stamp order.
    pub frames: Vec<AnimationFrame>,
    /// What the conversion met.
    pub report: ConversionReport,
}

impl Animation {
    /// The factor that scales this animation's root translation onto `character`: the ratio of
    /// hip heights, so strides scale with legs and feet stay on the ground.
    #[must_use]
    pub fn translation_scale_for(&self, rig: &Rig, character: &Character) -> f64 {
        character.hip_height_m(rig) / self.character.hip_height_m(rig)
    }
}

/// Precomputed per-recipe data for the layout in use.
#[derive(Debug, Clone)]
struct BoneSolve {
    dof: Dof,
    /// (from, to) landmark sets of the chosen direction alternative.
    dir: Option<(Vec<usize>, Vec<usize>)>,
    rest_dir: Unit<Vector3<f64>>,
    reference: Option<RefSolve>,
    /// For an aimed recipe ([`crate::skeleton::rig::Recipe::aim`]): the direction's end
    /// landmark, aimed at from the bone's solved head (`rest_dir` is then its offset on the body).
    aim: Option<usize>,
}

#[derive(Debug, Clone)]
enum RefSolve {
    Direction {
        from: Vec<usize>,
        to: Vec<usize>,
        rest_perp: Unit<Vector3<f64>>,
    },
    Normal {
        points: [usize; 3],
        rest_perp: Unit<Vector3<f64>>,
        /// The sine of the bend from which the plane's noise, measured on the clip by
        /// [`Converter::fit_reference_noise`], cannot spin the bone: below it the twist moves
        /// towards the plane's by bounded steps. 0 when not measured (no bound).
        noise_sin: f64,
    },
}

/// Landmark value for one frame: present, or why not.
#[derive(Debug, Clone, Copy)]
enum Lm {
    Unbound,
    Missing,
    LowConfidence,
    At(Point3<f64>),
}

/// How many standard deviations of a bend plane's one-frame change, from the input's noise, must
/// fit within [`geom::TWIST_FOLLOW_RAD`] for the plane to be trusted frame by frame
/// ([`Converter::fit_reference_noise`]).
pub const REFERENCE_NOISE_SIGMAS: f64 = 4.0;

/// The coefficient of variation (standard deviation over mean) of `d`; `None` with fewer than
/// two values or a non-positive mean.
fn variation(d: &[f64]) -> Option<f64> {
    if d.len() < 2 {
        return None;
    }
    #[expect(
        clippy::cast_precision_loss,
        reason = "a sample of a few hundred frames"
    )]
    let n = d.len() as f64;
    let mean = d.iter().sum::<f64>() / n;
    let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
    (mean.is_finite() && mean > 0.0 && var.is_finite()).then(|| var.sqrt() / mean)
}

/// A stateful converter for one tracked person: frames must be fed in time order.
#[derive(Debug, Clone)]
pub struct Converter<'r> {
    rig: &'r Rig,
    binding: Binding,
    options: ConvertOptions,
    /// Root height offset: the pelvis landmark's rest offset from the root, scaled.
    pelvis_offset_m: Vector3<f64>,
    solves: Vec<BoneSolve>,
    /// Recipe index per bone (`usize::MAX` for none).
    solve_of_bone: Vec<usize>,
    landmark_buf: Vec<Lm>,
    /// Landmarks the layout binds (the only ones worth computing per frame).
    bound_landmarks: Vec<usize>,
    /// Bones that are solved per frame; every other one stays at rest relative to its parent.
    solved_bones: Vec<bool>,
    world: Vec<UnitQuaternion<f64>>,
    /// The previous frame's solution (valid when `has_previous`).
    previous: BonePose,
    has_previous: bool,
    previous_world: Vec<UnitQuaternion<f64>>,
    report: ConversionReport,
    frame_flags: bool,
    hip_lms: Option<(usize, usize)>,
    shoulder_lms: Option<(usize, usize)>,
    pelvis_lm: Option<usize>,
    /// Per bone: its head's rest offset from its parent's head on the body solved on.
    head_offset_m: Vec<Vector3<f64>>,
    /// Per bone: its head this frame (the root's from the full translation, whatever the root
    /// motion), for aimed bones.
    heads_m: Vec<Point3<f64>>,
}

/// For an aimed recipe of `bone` whose direction ends at one landmark riding on `bone`: that
/// landmark and its rest direction from the bone's head on `character`.
fn aim_target(
    rig: &Rig,
    character: &Character,
    bone: usize,
    dir: Option<&(Vec<usize>, Vec<usize>)>,
) -> Option<(usize, Unit<Vector3<f64>>)> {
    let aimed = rig.recipes.iter().any(|r| r.bone == bone && r.aim);
    let (_, to) = dir?;
    let &[target] = to.as_slice() else {
        return None;
    };
    if !aimed || rig.landmarks[target].bone != bone {
        return None;
    }
    Some((
        target,
        geom::direction(character.landmark_offset_m[target])?,
    ))
}

fn perp_of(v: &Vector3<f64>, axis: &Unit<Vector3<f64>>) -> Unit<Vector3<f64>> {
    geom::perpendicular_direction(v, axis, 1e-3).unwrap_or_else(|| {
        let helper = if axis.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        Unit::new_normalize(axis.cross(&helper))
    })
}

impl<'r> Converter<'r> {
    /// A converter for data in `layout`'s joint order, solved on `character` (the subject's
    /// proportions, e.g. from [`fit_character`]).
    ///
    /// # Errors
    /// [`LayoutError`] if the layout does not bind to the rig.
    pub fn new(
        rig: &'r Rig,
        layout: &Layout,
        character: &Character,
        options: ConvertOptions,
    ) -> Result<Self, LayoutError> {
        Ok(Converter::with_binding(
            rig,
            layout.bind(rig)?,
            character,
            options,
        ))
    }

    /// A converter for an already bound layout.
    #[must_use]
    pub fn with_binding(
        rig: &'r Rig,
        binding: Binding,
        character: &Character,
        options: ConvertOptions,
    ) -> Self {
        let mut coverage = binding.coverage(rig);
        let held = |name: &String| {
            rig.bone_index(name)
                .is_some_and(|b| options.dof.holds_at_rest(&rig.bones[b]))
        };
        // Bones the DoF set holds are at rest, as the bones a layout cannot see: writers put
        // them in `/tf_static`.
        coverage.driven.retain(|name| !held(name));
        coverage.twist_unobserved.retain(|name| !held(name));
        for b in rig.bones.iter().filter(|b| options.dof.holds_at_rest(b)) {
            if !coverage.at_rest.contains(&b.name) {
                coverage.at_rest.push(b.name.clone());
            }
        }
        let mut solves = Vec::with_capacity(rig.recipes.len());
        let mut solve_of_bone = vec![usize::MAX; rig.bones.len()];
        for src in &binding.bone_sources {
            let bone = &rig.bones[src.bone];
            let dir = src
                .direction
                .as_ref()
                .map(|d| (d.from.clone(), d.to.clone()));
            let rest_dir = dir
                .as_ref()
                .and_then(|(f, t)| geom::direction(rig.rest_point(t) - rig.rest_point(f)))
                .unwrap_or_else(|| bone.rest_direction());
            let reference = src.reference.as_ref().map(|refr| {
                let rest_perp = perp_of(&rest_reference(rig, refr), &rest_dir);
                match refr {
                    Reference::Direction { from, to } => RefSolve::Direction {
                        from: from.clone(),
                        to: to.clone(),
                        rest_perp,
                    },
                    Reference::Normal { points, .. } => RefSolve::Normal {
                        points: *points,
                        rest_perp,
                        noise_sin: 0.0,
                    },
                }
            });
            let (aim, rest_dir) = aim_target(rig, character, src.bone, dir.as_ref())
                .map_or((None, rest_dir), |(l, d)| (Some(l), d));
            solve_of_bone[src.bone] = solves.len();
            solves.push(BoneSolve {
                dof: bone.dof,
                dir,
                rest_dir,
                reference,
                aim,
            });
        }
        let lm = |n: &str| rig.landmark_index(n);
        let pair = |a: &str, b: &str| {
            Some((lm(a)?, lm(b)?)).filter(|(a, b)| {
                binding.landmark_terms[*a].is_some() && binding.landmark_terms[*b].is_some()
            })
        };
        let pelvis_lm = lm("pelvis");
        let bound_landmarks: Vec<usize> = (0..rig.landmarks.len())
            .filter(|&l| binding.landmark_terms[l].is_some())
            .collect();
        let solved_bones: Vec<bool> = (0..rig.bones.len())
            .map(|b| {
                !options.dof.holds_at_rest(&rig.bones[b])
                    && solves
                        .get(solve_of_bone[b])
                        .is_some_and(|s| s.dir.is_some())
            })
            .collect();
        let pelvis_offset_m =
            pelvis_lm.map_or_else(Vector3::zeros, |p| character.landmark_from_root_m(rig, p));
        Converter {
            rig,
            options,
            pelvis_offset_m,
            solves,
            solve_of_bone,
            landmark_buf: vec![Lm::Unbound; rig.landmarks.len()],
            bound_landmarks,
            solved_bones,
            world: vec![UnitQuaternion::identity(); rig.bones.len()],
            previous: BonePose::rest(rig),
            has_previous: false,
            previous_world: vec![UnitQuaternion::identity(); rig.bones.len()],
            report: ConversionReport {
                frames: 0,
                degenerate_frames: 0,
                events: [0; 5],
                bone_events: vec![[0; 5]; rig.bones.len()],
                dropped_non_monotonic: Vec::new(),
                coverage,
            },
            frame_flags: false,
            hip_lms: pair("l_hip", "r_hip"),
            shoulder_lms: pair("l_shoulder", "r_shoulder"),
            pelvis_lm: pelvis_lm.filter(|p| binding.landmark_terms[*p].is_some()),
            binding,
            head_offset_m: character.head_offset_m.clone(),
            heads_m: vec![Point3::origin(); rig.bones.len()],
        }
    }

    /// Measures, on `sample` (frames in the layout's joint order, evenly spread over the clip),
    /// how noisy each bend-plane twist reference is. The plane through hip, knee and ankle turns
    /// by about `cv / sin(bend)` radians when its joints move by `cv` bone lengths across it,
    /// and the coefficient of variation of the plane's two segment lengths over the clip (RMS of
    /// the two) measures `cv` on the clip itself: a rigid limb's segments keep their length, so
    /// what varies is the input's noise. From the bend where [`REFERENCE_NOISE_SIGMAS`] standard
    /// deviations of the plane's one-frame change fit within [`geom::TWIST_FOLLOW_RAD`] the
    /// plane is followed frame by frame as before; below, with a trust falling smoothly to 0 at
    /// a straight limb, the twist moves towards it from the previous frame's by bounded steps
    /// (see `three_d_world`), so noise flipping the plane of a nearly straight knee cannot spin
    /// the thigh. Clean motion capture (`cv` ≈ 0) is unaffected, and where the limb is well bent
    /// the twist is the plane's, so the knee or elbow hinge below still reaches the ankle or
    /// wrist. Without a call (a live stream with no sample), every plane is followed frame by
    /// frame.
    pub fn fit_reference_noise(&mut self, sample: &[PoseFrame]) {
        let min_c = self.options.min_confidence;
        for s in &mut self.solves {
            let Some(RefSolve::Normal {
                points: [a, b, c],
                noise_sin,
                ..
            }) = &mut s.reference
            else {
                continue;
            };
            let mut segments = [Vec::new(), Vec::new()];
            for f in sample {
                let p = |l: usize| self.binding.set_point(&[l], f, min_c);
                if let (Some(pa), Some(pb), Some(pc)) = (p(*a), p(*b), p(*c)) {
                    segments[0].push((pb - pa).norm());
                    segments[1].push((pc - pb).norm());
                }
            }
            let cv2: Vec<f64> = segments.iter().filter_map(|d| variation(d)).collect();
            if cv2.len() == 2 {
                let cv = (0.5 * (cv2[0] * cv2[0] + cv2[1] * cv2[1])).sqrt();
                // Three noisy joints move the plane's defining offset by about √(3/2)·cv bone
                // lengths, and its one-frame change by √2 times that.
                *noise_sin = REFERENCE_NOISE_SIGMAS * 3f64.sqrt() * cv / geom::TWIST_FOLLOW_RAD;
            }
        }
    }

    /// The report so far.
    #[must_use]
    pub fn report(&self) -> &ConversionReport {
        &self.report
    }

    /// Ends the conversion, returning the report.
    #[must_use]
    pub fn into_report(self) -> ConversionReport {
        self.report
    }

    fn count(&mut self, bone: usize, kind: Degeneracy) {
        self.report.events[kind.index()] += 1;
        self.report.bone_events[bone][kind.index()] += 1;
        self.frame_flags = true;
    }

    #[inline]
    fn point(&self, set: &[usize]) -> Result<Point3<f64>, Degeneracy> {
        if let [l] = set {
            return match self.landmark_buf[*l] {
                Lm::At(p) => Ok(p),
                Lm::LowConfidence => Err(Degeneracy::LowConfidence),
                Lm::Missing | Lm::Unbound => Err(Degeneracy::MissingJoint),
            };
        }
        let mut sum = Vector3::zeros();
        for &l in set {
            match self.landmark_buf[l] {
                Lm::At(p) => sum += p.coords,
                Lm::LowConfidence => return Err(Degeneracy::LowConfidence),
                Lm::Missing | Lm::Unbound => return Err(Degeneracy::MissingJoint),
            }
        }
        #[expect(
            clippy::cast_precision_loss,
            reason = "landmark sets hold a handful of points"
        )]
        let n = set.len().max(1) as f64;
        Ok(Point3::from(sum / n))
    }

    #[inline]
    /// The vector `from → to`, checked to be finite and not (nearly) zero.
    fn vector_between(&self, from: &[usize], to: &[usize]) -> Result<Vector3<f64>, Degeneracy> {
        let v = self.point(to)? - self.point(from)?;
        let n2 = v.norm_squared();
        if n2.is_finite() && n2 > geom::EPS_NORM * geom::EPS_NORM {
            Ok(v)
        } else {
            Err(Degeneracy::ZeroLengthBone)
        }
    }

    /// The current twist reference of `r`, perpendicular to the bone, its weight in [0, 1]: how
    /// well it is defined, from the sine of its angle to the bone (for a bend plane, the sine of
    /// the bend), full at and above `full_twist_reference_angle_rad`; and how far its noise is
    /// trusted in one frame, in [0, 1] (1 unless measured by [`Converter::fit_reference_noise`]).
    #[inline]
    fn current_reference(
        &self,
        r: &RefSolve,
        cur_dir: &Unit<Vector3<f64>>,
    ) -> Result<(Unit<Vector3<f64>>, f64, f64), Degeneracy> {
        let (v, scale, noise_sin) = match r {
            RefSolve::Direction { from, to, .. } => {
                let v = self.point(to)? - self.point(from)?;
                (v, v.norm(), 0.0)
            }
            RefSolve::Normal {
                points: [a, b, c],
                noise_sin,
                ..
            } => {
                let (a, b, c) = (self.point(&[*a])?, self.point(&[*b])?, self.point(&[*c])?);
                let (u, w) = (b - a, c - b);
                // Scale-free: the normal's length over the product of the segment lengths is
                // the sine of the bend.
                (u.cross(&w), u.norm() * w.norm(), *noise_sin)
            }
        };
        if !(scale.is_finite() && scale > geom::EPS_NORM * geom::EPS_NORM) {
            return Err(Degeneracy::ParallelReference);
        }
        let perp = v - cur_dir.into_inner() * cur_dir.dot(&v);
        let sin = perp.norm() / scale;
        let weight = geom::reference_weight(sin, self.options.full_twist_reference_angle_rad.sin());
        let trust = if noise_sin > 0.0 {
            geom::reference_weight(sin, noise_sin)
        } else {
            1.0
        };
        match geom::direction(perp) {
            Some(p) if weight > 0.0 => Ok((p, weight, trust)),
            _ => Err(Degeneracy::ParallelReference),
        }
    }

    /// Converts one frame (positions in the layout's joint order) into `out`.
    ///
    /// # Errors
    /// [`ConvertError::WrongJointCount`] if the arrays do not match the layout.
    pub fn convert_frame(
        &mut self,
        frame: &PoseFrame,
        out: &mut BonePose,
    ) -> Result<(), ConvertError> {
        let expected = self.binding.joint_count;
        if frame.positions_m.len() != expected || frame.confidence.len() != expected {
            return Err(ConvertError::WrongJointCount {
                source_name: String::new(),
                frame: self.report.frames,
                found: frame.positions_m.len(),
                confidences: frame.confidence.len(),
                expected,
                layout: self.binding.layout_name.clone(),
            });
        }
        self.frame_flags = false;
        self.fill_landmarks(frame);
        self.solve_root(out);
        for b in 1..self.rig.bones.len() {
            let Some(parent) = self.rig.bones[b].parent else {
                continue;
            };
            let parent_world = self.world[parent];
            self.heads_m[b] = self.heads_m[parent] + parent_world * self.head_offset_m[b];
            if !self.solved_bones[b] {
                // Static, or not driven by this layout: at rest relative to its parent.
                out.local_rotations[b] = UnitQuaternion::identity();
                self.world[b] = parent_world;
                continue;
            }
            let prev_local = self.has_previous.then(|| self.previous.local_rotations[b]);
            let local = self.solve_bone(b, &parent_world, prev_local);
            let local = match prev_local {
                Some(p) => geom::align_hemisphere(local, &p),
                None => local,
            };
            out.local_rotations[b] = local;
            self.world[b] = parent_world * local;
        }
        // Renormalise once per frame: every written quaternion is unit to rounding (≤ 1e-15),
        // whatever products and arcs made it.
        for q in &mut out.local_rotations {
            q.renormalize();
        }
        self.previous_world.copy_from_slice(&self.world);
        self.previous
            .local_rotations
            .copy_from_slice(&out.local_rotations);
        self.previous.root_translation_m = out.root_translation_m;
        self.has_previous = true;
        self.report.frames += 1;
        if self.frame_flags {
            self.report.degenerate_frames += 1;
        }
        Ok(())
    }

    fn fill_landmarks(&mut self, frame: &PoseFrame) {
        let min_c = self.options.min_confidence;
        for &l in &self.bound_landmarks {
            self.landmark_buf[l] = match &self.binding.landmark_terms[l] {
                None => Lm::Unbound,
                Some(terms) => {
                    let mut state = Lm::At(Point3::origin());
                    let mut sum = Vector3::zeros();
                    if let [(j, _)] = terms[..] {
                        // One joint: a copy, no weighting.
                        let p = frame.positions_m[j];
                        let c = frame.confidence[j];
                        self.landmark_buf[l] = if !p.coords.iter().all(|v| v.is_finite()) {
                            Lm::Missing
                        } else if c.is_nan() || c < min_c {
                            Lm::LowConfidence
                        } else {
                            Lm::At(p)
                        };
                        continue;
                    }
                    for &(j, w) in terms {
                        let p = frame.positions_m[j];
                        if !p.coords.iter().all(|v| v.is_finite()) {
                            state = Lm::Missing;
                            break;
                        }
                        if frame.confidence[j].is_nan() || frame.confidence[j] < min_c {
                            state = Lm::LowConfidence;
                        }
                        sum += p.coords * w;
                    }
                    match state {
                        Lm::At(_) => Lm::At(Point3::from(sum)),
                        other => other,
                    }
                }
            };
        }
    }

    fn solve_root(&mut self, out: &mut BonePose) {
        let prev_pose = self.has_previous.then(|| {
            (
                self.previous.local_rotations[ROOT],
                self.previous.root_translation_m,
            )
        });
        let horizontal = |pair: Option<(usize, usize)>, this: &Self| -> Option<Vector3<f64>> {
            let (a, b) = pair?;
            let v = this.point(&[b]).ok()? - this.point(&[a]).ok()?;
            let h = Vector3::new(v.x, v.y, 0.0);
            (h.norm() > 1e-6).then_some(h)
        };
        let yaw = horizontal(self.hip_lms, self)
            .or_else(|| horizontal(self.shoulder_lms, self))
            .map(|h| h.y.atan2(h.x));
        let root_rot = match (yaw, prev_pose) {
            (Some(y), _) => geom::yaw_rotation(y),
            (None, Some((rot, _))) => {
                self.count(ROOT, Degeneracy::MissingJoint);
                rot
            }
            (None, None) => {
                if self.hip_lms.is_some() || self.shoulder_lms.is_some() {
                    self.count(ROOT, Degeneracy::MissingJoint);
                }
                UnitQuaternion::identity()
            }
        };
        let root_rot =
            prev_pose.map_or(root_rot, |(rot, _)| geom::align_hemisphere(root_rot, &rot));
        let pelvis = self.pelvis_lm.and_then(|p| self.point(&[p]).ok());
        let translation = match (pelvis, prev_pose) {
            (Some(p), _) => p.coords - root_rot * self.pelvis_offset_m,
            (None, Some((_, t))) => {
                if self.pelvis_lm.is_some() {
                    self.count(ROOT, Degeneracy::MissingJoint);
                }
                t
            }
            (None, None) => Vector3::zeros(),
        };
        out.root_translation_m = match self.options.root_motion {
            RootMotion::Full => translation,
            RootMotion::InPlace => Vector3::new(0.0, 0.0, translation.z),
            RootMotion::Pinned => Vector3::zeros(),
        };
        self.heads_m[ROOT] = self.rig.bones[ROOT].head_rest_m + translation;
        out.local_rotations[ROOT] = root_rot;
        self.world[ROOT] = root_rot;
    }

    /// The vector a bone's solved direction must follow: its recipe's `from → to`, or for an
    /// aimed bone, from its solved head to the `to` point.
    #[inline]
    fn direction_vector(
        &self,
        b: usize,
        s: &BoneSolve,
        from: &[usize],
        to: &[usize],
    ) -> Result<Vector3<f64>, Degeneracy> {
        match s.aim {
            Some(target) => {
                let v = self.point(&[target])? - self.heads_m[b];
                let n2 = v.norm_squared();
                if n2.is_finite() && n2 > geom::EPS_NORM * geom::EPS_NORM {
                    Ok(v)
                } else {
                    Err(Degeneracy::ZeroLengthBone)
                }
            }
            None => self.vector_between(from, to),
        }
    }

    #[inline]
    fn solve_bone(
        &mut self,
        b: usize,
        parent_world: &UnitQuaternion<f64>,
        prev_local: Option<UnitQuaternion<f64>>,
    ) -> UnitQuaternion<f64> {
        let (local, degeneracy) = self.bone_rotation(b, parent_world, prev_local);
        if let Some(kind) = degeneracy {
            self.count(b, kind);
        }
        local
    }

    /// The local rotation of bone `b`, and the degenerate-input path it took, if any.
    #[inline]
    fn bone_rotation(
        &self,
        b: usize,
        parent_world: &UnitQuaternion<f64>,
        prev_local: Option<UnitQuaternion<f64>>,
    ) -> (UnitQuaternion<f64>, Option<Degeneracy>) {
        let si = self.solve_of_bone[b];
        let Some(s) = self.solves.get(si) else {
            return (UnitQuaternion::identity(), None); // static
        };
        let Some((from, to)) = &s.dir else {
            return (UnitQuaternion::identity(), None); // the layout cannot drive it: rest
        };
        let hold = prev_local.unwrap_or_else(UnitQuaternion::identity);
        let v = match self.direction_vector(b, s, from, to) {
            Ok(v) => v,
            Err(kind) => return (hold, Some(kind)),
        };
        let rest_dir = s.rest_dir;
        // Rotations preserve length: the parent-frame vector needs no normalising for 2-D and
        // hinge bones, whose geometry functions take unnormalised directions.
        let v_in_parent = parent_world.inverse() * v;
        match s.dof {
            Dof::Static | Dof::Root => (UnitQuaternion::identity(), None),
            Dof::TwoD => match geom::shortest_arc_to(&rest_dir, &v_in_parent) {
                Some(q) => (q, None),
                None => (hold, Some(Degeneracy::ZeroLengthBone)),
            },
            Dof::Hinge { axis } => match geom::hinge_rotation(&rest_dir, &v_in_parent, &axis) {
                Some(q) => (q, None),
                None => (hold, Some(Degeneracy::AlongHingeAxis)),
            },
            Dof::ThreeD => {
                let cur_dir = Unit::new_normalize(v);
                let (target_world, degeneracy) =
                    self.three_d_world(b, s, parent_world, prev_local.is_some(), &cur_dir);
                (parent_world.inverse() * target_world, degeneracy)
            }
        }
    }

    /// The world rotation of 3-D bone `b` (recipe `s`) pointing along `cur_dir`, and the
    /// degenerate-input path it took. The direction is always exact; the twist is a blend, about
    /// the bone, of its reference (weighted by how well the reference is defined: for a limb, by
    /// the sine of the elbow's or knee's bend, full from
    /// [`ConvertOptions::full_twist_reference_angle_rad`]) and of the twist carried from the
    /// parent (the parent's frame moved onto the bone by the smallest arc). As the limb
    /// straightens the reference's weight falls smoothly to zero, so the twist never jumps, and
    /// a bend plane's twist depends on the current frame only. A leaf bone's direction reference
    /// (a hand's thumb tip) moves the twist from the previous frame's by [`geom::twist_step`] of
    /// what it asks.
    fn three_d_world(
        &self,
        b: usize,
        s: &BoneSolve,
        parent_world: &UnitQuaternion<f64>,
        has_previous: bool,
        cur_dir: &Unit<Vector3<f64>>,
    ) -> (UnitQuaternion<f64>, Option<Degeneracy>) {
        let rest_dir = s.rest_dir;
        let carried = |base: &UnitQuaternion<f64>| {
            let was = Unit::new_unchecked(base * rest_dir.into_inner());
            geom::shortest_arc(&was, cur_dir) * base
        };
        let from_parent = carried(parent_world);
        let Some(r) = s.reference.as_ref() else {
            // Twist never observed: carried from the parent frame.
            return (from_parent, None);
        };
        let (RefSolve::Direction { rest_perp, .. } | RefSolve::Normal { rest_perp, .. }) = r;
        let parent_perp = from_parent * rest_perp.into_inner();
        // How far this frame's twist is trusted against the previous frame's (below 1 only for
        // a bend plane whose measured noise can flip it at this bend).
        let noise_measured = matches!(r, RefSolve::Normal { noise_sin, .. } if *noise_sin > 0.0);
        let (perp, degeneracy, trust) = match self.current_reference(r, cur_dir) {
            Ok((cur_perp, weight, trust)) => {
                let blended = cur_perp.into_inner() * weight + parent_perp * (1.0 - weight);
                let perp = geom::perpendicular_direction(&blended, cur_dir, 1e-9)
                    .unwrap_or_else(|| Unit::new_normalize(parent_perp));
                (perp, None, trust)
            }
            Err(Degeneracy::ParallelReference) => (
                Unit::new_normalize(parent_perp),
                Some(Degeneracy::ParallelReference),
                if noise_measured { 0.0 } else { 1.0 },
            ),
            Err(kind) => {
                // The reference's joints are missing: keep the previous orientation's twist,
                // i.e. the smallest rotation from where the bone was (or from the parent frame).
                let base = if has_previous {
                    self.previous_world[b]
                } else {
                    *parent_world
                };
                return (carried(&base), Some(kind));
            }
        };
        // A direction reference (a thumb tip) of a bone that passes its twist to no solved child
        // (a hand whose fingers the layout does not see) sets the twist from the previous
        // frame's, carried along the bone, by at most a plausible one-frame turn
        // (`geom::twist_step`), so a noisy reference flipping sides, or falling back to the
        // parent's twist, never spins the bone. A bone with solved children (the trunk) keeps
        // the current frame's twist: a 2-D or hinge child below cannot undo a lagging one. A
        // noisy bend plane (trust < 1) moves the twist by `trust` of the step it asks plus the
        // rest of `geom::twist_step`'s: exact where the bend is well above the noise (the hinge
        // below reaches its end point), bounded where the noise can flip the plane.
        let leaf = || {
            !self
                .rig
                .bones
                .iter()
                .zip(&self.solved_bones)
                .any(|(child, solved)| *solved && child.parent == Some(b))
        };
        let perp = match r {
            RefSolve::Direction { .. } if has_previous && leaf() => {
                let was = carried(&self.previous_world[b]) * rest_perp.into_inner();
                let delta = cur_dir.dot(&was.cross(&perp)).atan2(was.dot(&perp));
                let turn = UnitQuaternion::from_axis_angle(cur_dir, geom::twist_step(delta));
                geom::perpendicular_direction(&(turn * was), cur_dir, 1e-9).unwrap_or(perp)
            }
            RefSolve::Normal { .. } if has_previous && trust < 1.0 => {
                let was = carried(&self.previous_world[b]) * rest_perp.into_inner();
                let delta = cur_dir.dot(&was.cross(&perp)).atan2(was.dot(&perp));
                if delta.abs() <= geom::TWIST_FOLLOW_RAD {
                    // `twist_step` follows it exactly: this frame's twist, bit for bit.
                    perp
                } else {
                    let step = trust * delta + (1.0 - trust) * geom::twist_step(delta);
                    let turn = UnitQuaternion::from_axis_angle(cur_dir, step);
                    geom::perpendicular_direction(&(turn * was), cur_dir, 1e-9).unwrap_or(perp)
                }
            }
            _ => perp,
        };
        (
            geom::frame_rotation(&rest_dir, rest_perp, cur_dir, &perp),
            degeneracy,
        )
    }
}

/// Fits a [`Character`] to a subject: first the length of every segment the layout drives (median
/// over frames), then where each observed point sits on the bone it rides on, measured in that
/// bone's solved frame (median over frames). The second pass gives the subject its own geometry
/// where the rig is rigid — where its hip joints sit on its pelvis, its shoulders on its
/// clavicles, its heels, ears and thumb tips on their bones — so that no joint below a rigid part
/// is off by a difference of build, and the points a layout reports land where it reported them.
/// The pelvis is the exception: it places the root.
#[must_use]
pub fn fit_character(
    rig: &Rig,
    binding: &Binding,
    frames: &[PoseFrame],
    options: ConvertOptions,
) -> Character {
    // A few hundred evenly spread frames are plenty for a median.
    let step = (frames.len() / 256).max(1);
    let sample: Vec<&PoseFrame> = frames.iter().step_by(step).collect();
    let point = |f: &PoseFrame, set: &[usize]| binding.set_point(set, f, options.min_confidence);
    // The segments this layout drives bones along, and the static widths.
    let measures = binding.measures(rig);
    let observed: Vec<(&crate::skeleton::rig::Measure, f64)> = measures
        .iter()
        .filter_map(|m| {
            let mut d: Vec<f64> = sample
                .iter()
                .filter_map(|f| Some((point(f, &m.to)? - point(f, &m.from)?).norm()))
                .filter(|d| d.is_finite() && *d > 1e-6)
                .collect();
            Some((m, crate::skeleton::character::median(&mut d)?))
        })
        .collect();
    let mut character = Character::fitted(rig, &observed);

    // Pass 2: where each observed point rides. The pelvis landmark places the root, so it stays.
    let movable: Vec<usize> = rig
        .landmarks
        .iter()
        .enumerate()
        .filter(|(l, lm)| lm.name != "pelvis" && binding.landmark_terms[*l].is_some())
        .map(|(l, _)| l)
        .collect();
    if movable.is_empty() {
        return character;
    }
    // Solve the sample once: rotations do not depend on where points ride (the pelvis, which
    // places the root, is not refitted).
    let mut converter = Converter::with_binding(rig, binding.clone(), &character, options);
    let mut solved: Vec<(&PoseFrame, BonePose)> = Vec::with_capacity(sample.len());
    let mut pose = BonePose::rest(rig);
    for f in &sample {
        if converter.convert_frame(f, &mut pose).is_ok() {
            solved.push((f, pose.clone()));
        }
    }
    // Bone by bone, parents first, so each offset is measured from a head already in place.
    let mut world = crate::skeleton::fk::WorldPose::new(rig);
    for b in 0..rig.bones.len() {
        let riders: Vec<usize> = movable
            .iter()
            .copied()
            .filter(|&l| rig.landmarks[l].bone == b)
            .collect();
        if riders.is_empty() {
            continue;
        }
        let mut samples: Vec<[Vec<f64>; 3]> =
            vec![[Vec::new(), Vec::new(), Vec::new()]; riders.len()];
        for (f, pose) in &solved {
            crate::skeleton::fk::forward_into(rig, &character, pose, 1.0, &mut world);
            for (k, &l) in riders.iter().enumerate() {
                let Some(p) = point(f, &[l]) else { continue };
                let offset = world.rotations[b].inverse() * (p - world.heads_m[b]);
                for (axis, v) in offset.iter().enumerate() {
                    samples[k][axis].push(*v);
                }
            }
        }
        for (k, &l) in riders.iter().enumerate() {
            let [x, y, z] = &mut samples[k];
            if let (Some(x), Some(y), Some(z)) = (
                crate::skeleton::character::median(x),
                crate::skeleton::character::median(y),
                crate::skeleton::character::median(z),
            ) {
                character.set_landmark_offset(rig, l, Vector3::new(x, y, z));
            }
        }
    }
    character
}

/// Converts a person's frames one at a time, as they come: the subject's proportions are fitted
/// on construction from a sample of the frames (the whole sequence, or a bounded sample read
/// ahead), then each frame pushed is solved at once, so a caller can stream a bag of any length
/// through it without holding it.
///
/// Frames whose stamp is not after the previous kept frame are dropped and listed in the report
/// (`lost_input()` is then true). Joints absent from every frame are treated as not in the layout,
/// so the bones they would drive are reported at rest.
#[derive(Debug)]
pub struct SequenceConverter<'a> {
    converter: Converter<'a>,
    /// Data joint of each layout joint (`None`: the data is in the layout's order already).
    order: Option<Vec<Option<usize>>>,
    /// Frames pushed so far.
    pushed: usize,
    last_stamp: Option<u64>,
    dropped: Vec<(usize, u64)>,
    pose: BonePose,
    character: Character,
    layout_name: String,
    source: String,
}

impl<'a> SequenceConverter<'a> {
    /// Prepares the conversion of `seq` (joints named as in `layout`), fitted on all its frames.
    ///
    /// # Errors
    /// [`ConvertError::Layout`] when the data's joints are not the layout's.
    pub fn new(
        rig: &'a Rig,
        layout: &Layout,
        seq: &PoseSequence,
        options: ConvertOptions,
    ) -> Result<Self, ConvertError> {
        let observed = crate::skeleton::pose::observed_joints(&seq.frames, seq.joint_names.len());
        Self::from_sample(
            rig,
            layout,
            &seq.source,
            &seq.joint_names,
            &seq.frames,
            &observed,
            options,
        )
    }

    /// Prepares the conversion of a person whose frames will be pushed later: `joint_names` name
    /// their joints (as in `layout`), `sample` is a sample of them to fit the body on (any
    /// number, evenly spread; [`fit_character`] uses at most a few hundred), `observed` says per
    /// data joint whether any frame observes it.
    ///
    /// # Errors
    /// [`ConvertError::Layout`] when the data's joints are not the layout's.
    pub fn from_sample(
        rig: &'a Rig,
        layout: &Layout,
        source: &str,
        joint_names: &[String],
        sample: &[PoseFrame],
        observed: &[bool],
        options: ConvertOptions,
    ) -> Result<Self, ConvertError> {
        let layout_err = |e| ConvertError::Layout {
            source_name: source.to_string(),
            source: e,
        };
        let order = layout.joint_order(joint_names).map_err(layout_err)?;
        let identity_order = joint_names.len() == layout.joints.len()
            && order.iter().enumerate().all(|(k, i)| *i == Some(k));
        let sample: std::borrow::Cow<'_, [PoseFrame]> = if identity_order {
            std::borrow::Cow::Borrowed(sample)
        } else {
            std::borrow::Cow::Owned(sample.iter().map(|f| Layout::reorder(&order, f)).collect())
        };
        // Joints the source never provides (face points from mocap, hands from a body-only
        // tracker) are not in this data: their bones are reported at rest, not missing in every
        // frame.
        let present: Vec<bool> = order
            .iter()
            .map(|i| i.is_some_and(|i| observed.get(i).copied().unwrap_or(false)))
            .collect();
        let restricted;
        let layout = if present.iter().all(|&p| p) {
            layout
        } else {
            restricted = layout.restricted(&present);
            &restricted
        };
        let binding = layout.bind(rig).map_err(layout_err)?;
        let character = fit_character(rig, &binding, &sample, options);
        let mut converter = Converter::with_binding(rig, binding, &character, options);
        converter.fit_reference_noise(&sample);
        Ok(SequenceConverter {
            converter,
            order: (!identity_order).then_some(order),
            pushed: 0,
            last_stamp: None,
            dropped: Vec::new(),
            pose: BonePose::rest(rig),
            character,
            layout_name: layout.name.clone(),
            source: source.to_string(),
        })
    }

    /// The body fitted to the subject; root translations are in its metres.
    #[must_use]
    pub fn character(&self) -> &Character {
        &self.character
    }

    /// Name of the layout the data is in.
    #[must_use]
    pub fn layout_name(&self) -> &str {
        &self.layout_name
    }

    /// Which bones the data drives (the report's coverage, known before any frame is solved).
    #[must_use]
    pub fn coverage(&self) -> &Coverage {
        &self.converter.report().coverage
    }

    /// Solves the next frame (joints in the data's order): its stamp and pose (valid until the
    /// next call), or `None` when it is dropped for a stamp not after the previous frame's.
    ///
    /// # Errors
    /// [`ConvertError::WrongJointCount`] for a frame whose arrays do not match the layout.
    pub fn push(&mut self, frame: &PoseFrame) -> Result<Option<(u64, &BonePose)>, ConvertError> {
        let i = self.pushed;
        self.pushed += 1;
        let stamp = frame.stamp_nanos;
        if self.last_stamp.is_some_and(|s| stamp <= s) {
            self.dropped.push((i, stamp));
            return Ok(None);
        }
        let solved = match &self.order {
            None => self.converter.convert_frame(frame, &mut self.pose),
            Some(order) => self
                .converter
                .convert_frame(&Layout::reorder(order, frame), &mut self.pose),
        };
        if let Err(e) = solved {
            return Err(match e {
                ConvertError::WrongJointCount {
                    found,
                    confidences,
                    expected,
                    layout,
                    ..
                } => ConvertError::WrongJointCount {
                    source_name: self.source.clone(),
                    frame: i,
                    found,
                    confidences,
                    expected,
                    layout,
                },
                other => other,
            });
        }
        self.last_stamp = Some(stamp);
        Ok(Some((stamp, &self.pose)))
    }

    /// Ends the conversion: the fitted body and the report.
    #[must_use]
    pub fn finish(self) -> (Character, ConversionReport) {
        let mut report = self.converter.into_report();
        report.dropped_non_monotonic = self.dropped;
        (self.character, report)
    }
}

/// Converts a whole sequence into memory (see [`SequenceConverter`] to stream instead).
///
/// # Errors
/// [`ConvertError`] when the layout does not match the data or no frame is usable.
pub fn convert_sequence(
    rig: &Rig,
    layout: &Layout,
    seq: &PoseSequence,
    options: ConvertOptions,
) -> Result<Animation, ConvertError> {
    let mut sc = SequenceConverter::new(rig, layout, seq, options)?;
    let layout_name = sc.layout_name().to_string();
    let mut out_frames = Vec::with_capacity(seq.frames.len());
    for frame in &seq.frames {
        if let Some((stamp_nanos, pose)) = sc.push(frame)? {
            out_frames.push(AnimationFrame {
                stamp_nanos,
                pose: pose.clone(),
            });
        }
    }
    if out_frames.is_empty() {
        return Err(ConvertError::Empty {
            source_name: seq.source.clone(),
        });
    }
    let (character, report) = sc.finish();
    Ok(Animation {
        rig_name: rig.name.to_string(),
        layout_name,
        source: seq.source.clone(),
        character,
        frames: out_frames,
        report,
    })
}

impl crate::outcome::LostInput for ConversionReport {
    /// Whether any input was lost (frames dropped).
    fn lost_input(&self) -> bool {
        !self.dropped_non_monotonic.is_empty()
    }
}

#[cfg(test)]
#[path = "convert_tests.rs"]
mod tests;
