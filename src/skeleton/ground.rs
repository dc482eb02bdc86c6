//! Grounding camera-frame pose estimates: the up direction and the ground plane estimated from a
//! clip's feet, and the rigid transform `world_from_camera` that stands the body on `z = 0`.
//!
//! Pose estimators (ZED, MMPose lifters, Kinect, any `MarkerArray` with `--layout`) give joints
//! in the camera's frame: after the axis conversion of [`crate::skeleton::frames`] +Z is only the
//! camera's up, tilted by however the camera was mounted, and the body floats where the camera
//! saw it (a ZED subject sits 1 m under the ground, 4.5 m away). This module:
//!
//! 1. **Samples** the clip ([`GroundSampler`]): per pushed frame, the foot points of each side
//!    (ankle, heel, toes — whatever the layout binds), the pelvis, the neck and the hips. Any
//!    subset of frames will do (every k-th frame of a stream), in stamp order.
//! 2. **Finds contacts**: per side and sample the foot's points, each lowered by its height
//!    above the sole in the rig's rest pose (so an ankle-only layout still reaches the floor),
//!    kept when the foot is slow (≤ 20 % of the clip's 95th-percentile foot speed, at least
//!    0.3 m/s, at most 1 m/s) and near the current floor estimate; of a foot's points, only
//!    those within [`INLIER_M`] of its lowest (a raised heel is not on the floor).
//! 3. **Fits the plane** robustly: RANSAC over the contact points (3 cm inliers, normals within
//!    35° of the body's vertical), then a least-squares refit of the inliers regularised towards
//!    the body's long-run vertical (the mean feet → neck direction over the frames where the body
//!    is most extended). The refit measures each landmark kind (ankle, heel, toe, …) about its
//!    own mean: a source's ankle or toe joint sits at its own height above the sole, unlike the
//!    rig's, so only distinct placements of one landmark may tilt the floor. The prior weighs
//!    like a contact spread of [`PRIOR_SPREAD_M`]: a straight walk puts its contacts on a line,
//!    which fixes the tilt along the line but hardly about it (feet 20 cm apart, heights noisy
//!    by centimetres), and a standing clip's two planted feet fix only the tilt across them;
//!    there the body decides. Up is the plane normal, towards the head; the floor's height is
//!    the median lowest foot point at contact.
//! 4. **Places the body**: tilt the normal onto +Z, turn about +Z so that the hip line of the
//!    first sampled frames points along +X (the body faces +Y), and translate so that the plane
//!    is `z = 0` and the first frame's pelvis is over the origin.
//!
//! The estimate reports the tilt it removed, the number of contacts and the residual foot height
//! at contact (median and 95th percentile of |z| after grounding): the numbers `import` prints.
//! A clip without feet or without any observed frame is an error ([`GroundError`]); one frame
//! is enough (the plane then goes through its lowest foot, square to the trunk).

use nalgebra::{Isometry3, Matrix3, Point3, Translation3, UnitQuaternion, Vector3};

use crate::skeleton::layout::{Layout, OBSERVED, terms_point};
use crate::skeleton::pose::{PoseFrame, PoseSequence, nanos_to_secs};

/// How much the trunk's direction counts in the plane fit, as a spread of contacts (metres):
/// contacts spread less than this across a line leave the tilt about that line to the trunk.
pub const PRIOR_SPREAD_M: f64 = 0.1;

/// Distance from the plane within which a contact supports it (RANSAC inlier), metres.
pub const INLIER_M: f64 = 0.03;

/// Largest angle between a candidate ground normal and the trunk direction, degrees.
pub const MAX_TILT_FROM_TRUNK_DEG: f64 = 35.0;

/// Contact spread across their line below which the trunk weighs four times the contacts in
/// the tilt about it (the prior weighs like a spread of [`PRIOR_SPREAD_M`]), metres.
pub const TRUNK_DECIDES_SPREAD_M: f64 = PRIOR_SPREAD_M / 2.0;

/// Height above the fitted floor over which a slow foot is not a contact, metres.
const CONTACT_BAND_M: f64 = 0.10;

/// When to ground a sequence (`--ground`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum GroundMode {
    /// Camera-frame sources (estimators, Kinect) are grounded; world-frame ones (mocap, CMU
    /// Panoptic) are left as they are.
    #[default]
    Auto,
    /// Never ground: keep the source's frame.
    Off,
    /// Always ground, even a world-frame source.
    On,
}

impl GroundMode {
    /// Whether a source is grounded: `camera_frame` says whether it is in a camera's frame.
    #[must_use]
    pub fn applies(self, camera_frame: bool) -> bool {
        match self {
            GroundMode::Auto => camera_frame,
            GroundMode::Off => false,
            GroundMode::On => true,
        }
    }
}

/// Why no ground could be estimated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GroundError {
    /// The layout binds no foot landmark (ankle, heel, toe) to the data's joints.
    #[error(
        "{source_name}: the layout `{layout}` has no ankle, heel or toe joint to find the ground with"
    )]
    NoFeet {
        /// The sequence's source.
        source_name: String,
        /// The layout.
        layout: String,
    },
    /// No sampled frame observes a foot.
    #[error("{source_name}: no frame observes a foot ({samples} frames sampled)")]
    NoFootObserved {
        /// The sequence's source.
        source_name: String,
        /// How many frames were sampled.
        samples: usize,
    },
}

/// A landmark as weighted joints of the data ([`JointExpr::terms`]).
type Joints = Vec<(usize, f64)>;

/// One foot landmark: its joints and its kind (an index into [`FOOT_LANDMARKS`]).
#[derive(Debug, Clone)]
struct FootJoint {
    joints: Joints,
    kind: usize,
}

/// A foot point and its landmark kind (an index into [`FOOT_LANDMARKS`]).
type FootPoint = (Point3<f64>, usize);

/// Which joints of the data give the points grounding needs.
#[derive(Debug, Clone)]
struct BodyPoints {
    feet: [Vec<FootJoint>; 2],
    pelvis: Option<Joints>,
    neck: Option<Joints>,
    hips: Option<(Joints, Joints)>,
}

/// The points of one sampled frame (positions as given, `None` where unobserved).
#[derive(Debug, Clone)]
struct Sample {
    stamp_nanos: u64,
    /// Per side, every observed foot landmark.
    feet: [Vec<FootPoint>; 2],
    pelvis: Option<Point3<f64>>,
    neck: Option<Point3<f64>>,
    /// (left, right) hip.
    hips: Option<(Point3<f64>, Point3<f64>)>,
}

/// Gathers the points grounding needs from frames fed one at a time (all of a clip, or a
/// sample such as every k-th frame of a stream), then estimates the ground.
#[derive(Debug, Clone)]
pub struct GroundSampler {
    source_name: String,
    points: BodyPoints,
    samples: Vec<Sample>,
}

/// The ground of a clip and the transform that stands it on `z = 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct Grounding {
    /// The rigid transform applied to every point: the input frame → the grounded frame.
    pub world_from_camera: Isometry3<f64>,
    /// The estimated up direction in the input frame (unit).
    pub up_in_camera: Vector3<f64>,
    /// The angle between the estimated up and the input's +Z, degrees: the tilt removed.
    pub tilt_deg: f64,
    /// Foot contacts the plane was fitted to (side × sampled frame).
    pub contacts: usize,
    /// Median |z| of the contacts after grounding, metres.
    pub residual_median_m: f64,
    /// 95th percentile of |z| of the contacts after grounding, metres.
    pub residual_p95_m: f64,
    /// Frames sampled.
    pub samples: usize,
    /// How far the contacts spread across their main line, metres (the second principal
    /// spread of the contact points about each landmark kind's mean; 0 for fewer than three).
    /// Below [`TRUNK_DECIDES_SPREAD_M`] the trunk's direction, not the feet, set the tilt
    /// about that line.
    pub across_spread_m: f64,
}

/// The foot landmarks the rig knows, with their height above the sole at rest (metres, the
/// rig's rest pose: `l_ankle` 0.08, `l_heel` 0.01, …). A source's joints sit elsewhere in the
/// foot (a BVH ankle about 10 cm up, a toe joint 4 cm up), so these heights only bring each
/// landmark near the floor; the plane's tilt is fitted to each kind's own spread
/// ([`refit`]), never to the differences between kinds.
const FOOT_LANDMARKS: [(&str, f64); 5] = [
    ("ankle", 0.08),
    ("heel", 0.01),
    ("toe", 0.02),
    ("big_toe", 0.01),
    ("small_toe", 0.01),
];

impl BodyPoints {
    fn new(layout: &Layout, joint_names: &[String]) -> Self {
        let find = |name: &str| layout.landmarks.get(name)?.terms(joint_names);
        let foot = |side: &str| -> Vec<FootJoint> {
            FOOT_LANDMARKS
                .iter()
                .enumerate()
                .filter_map(|(kind, (n, _))| {
                    find(&format!("{side}_{n}")).map(|joints| FootJoint { joints, kind })
                })
                .collect()
        };
        let pelvis = find("pelvis");
        let neck = find("neck")
            .or_else(|| find("chest"))
            .or_else(|| find("head_center"));
        let hips = find("l_hip").zip(find("r_hip"));
        BodyPoints {
            feet: [foot("l"), foot("r")],
            pelvis,
            neck,
            hips,
        }
    }
}

/// Landmark `joints` in `frame`, if all are observed (confidence above 0).
fn point(frame: &PoseFrame, joints: &[(usize, f64)]) -> Option<Point3<f64>> {
    terms_point(joints, frame, OBSERVED)
}

impl GroundSampler {
    /// A sampler for data whose joints are `joint_names`, in `layout` (its landmarks say which
    /// joints are feet, pelvis, neck and hips). `source_name` names the data in errors.
    ///
    /// # Errors
    /// [`GroundError::NoFeet`] when the layout binds no foot landmark to these joints.
    pub fn new(
        layout: &Layout,
        joint_names: &[String],
        source_name: &str,
    ) -> Result<Self, GroundError> {
        let points = BodyPoints::new(layout, joint_names);
        if points.feet.iter().all(Vec::is_empty) {
            return Err(GroundError::NoFeet {
                source_name: source_name.to_string(),
                layout: layout.name.clone(),
            });
        }
        Ok(GroundSampler {
            source_name: source_name.to_string(),
            points,
            samples: Vec::new(),
        })
    }

    /// Adds one frame (frames must come in stamp order; any subset of a clip will do).
    pub fn push(&mut self, frame: &PoseFrame) {
        let b = &self.points;
        let side = |feet: &[FootJoint]| -> Vec<FootPoint> {
            feet.iter()
                .filter_map(|f| point(frame, &f.joints).map(|p| (p, f.kind)))
                .collect()
        };
        let get = |j: &Option<Joints>| j.as_deref().and_then(|j| point(frame, j));
        let hips = b
            .hips
            .as_ref()
            .and_then(|(l, r)| point(frame, l).zip(point(frame, r)));
        self.samples.push(Sample {
            stamp_nanos: frame.stamp_nanos,
            feet: [side(&b.feet[0]), side(&b.feet[1])],
            pelvis: get(&b.pelvis).or_else(|| hips.map(|(l, r)| nalgebra::center(&l, &r))),
            neck: get(&b.neck),
            hips,
        });
    }

    /// Frames pushed so far.
    #[must_use]
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Whether no frame was pushed.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Estimates the ground from the frames pushed.
    ///
    /// # Errors
    /// [`GroundError::NoFootObserved`] when no pushed frame observes a foot.
    pub fn estimate(&self) -> Result<Grounding, GroundError> {
        if self
            .samples
            .iter()
            .all(|s| s.feet.iter().all(Vec::is_empty))
        {
            return Err(GroundError::NoFootObserved {
                source_name: self.source_name.clone(),
                samples: self.samples.len(),
            });
        }
        let prior = body_vertical(&self.samples);
        let speeds = foot_speeds(&self.samples);
        let speed_limit = speed_limit(&speeds);
        let mut up = prior;
        let mut offset = f64::NAN;
        let mut lows = Vec::new();
        let mut across_spread_m = 0.0;
        for _ in 0..3 {
            let mut contacts = contact_points(&self.samples, &speeds, speed_limit, up, offset);
            if contacts.is_empty() {
                // No slow foot near the floor: every foot is a candidate.
                contacts = contact_points(&self.samples, &speeds, f64::INFINITY, up, offset);
            }
            if contacts.is_empty() {
                contacts = contact_points(&self.samples, &speeds, f64::INFINITY, up, f64::NAN);
            }
            let (n, fitted, across) = fit_plane(&contacts.concat(), prior);
            across_spread_m = across;
            // The floor's height: the median lowest point of the feet at contact.
            lows = contacts
                .iter()
                .filter_map(|foot| foot.iter().map(|(p, _)| n.dot(&p.coords)).reduce(f64::min))
                .filter(|h| (h - fitted).abs() <= CONTACT_BAND_M)
                .collect();
            lows.sort_by(f64::total_cmp);
            up = n;
            offset = percentile(&lows, 0.5).unwrap_or(fitted);
        }
        Ok(self.placed(up, offset, &lows, across_spread_m))
    }

    /// The grounding for a floor `{p : up·p = offset}`, with its residuals at the feet's lowest
    /// points at contact (`lows`: their heights along `up`) and the contacts' spread across
    /// their line.
    fn placed(
        &self,
        up: Vector3<f64>,
        offset: f64,
        lows: &[f64],
        across_spread_m: f64,
    ) -> Grounding {
        let tilt = UnitQuaternion::rotation_between(&up, &Vector3::z()).unwrap_or_else(|| {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
        // The hip line (left → right) of the first sampled frames becomes +X.
        let right: Vector3<f64> = self
            .samples
            .iter()
            .filter_map(|s| s.hips)
            .take(10)
            .map(|(l, r)| tilt * (r - l))
            .sum();
        let yaw = if right.x.hypot(right.y) > 1e-9 {
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), -right.y.atan2(right.x))
        } else {
            UnitQuaternion::identity()
        };
        let rotation = yaw * tilt;
        let start = self
            .samples
            .iter()
            .find_map(|s| s.pelvis)
            .map_or_else(Vector3::zeros, |p| rotation * p.coords);
        let translation = Translation3::new(-start.x, -start.y, -offset);
        let world_from_camera = Isometry3::from_parts(translation, rotation);
        let mut residuals: Vec<f64> = lows.iter().map(|h| (h - offset).abs()).collect();
        residuals.sort_by(f64::total_cmp);
        let pick = |q: f64| percentile(&residuals, q).unwrap_or(0.0);
        Grounding {
            world_from_camera,
            up_in_camera: up,
            tilt_deg: angle_deg(&up, &Vector3::z()),
            contacts: lows.len(),
            residual_median_m: pick(0.5),
            residual_p95_m: pick(0.95),
            samples: self.samples.len(),
            across_spread_m,
        }
    }
}

/// The angle between two vectors, degrees.
#[must_use]
pub fn angle_deg(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.cross(b).norm().atan2(a.dot(b)).to_degrees()
}

/// The mean of a side's foot points, if it has any.
fn foot_centre(foot: &[FootPoint]) -> Option<Point3<f64>> {
    #[expect(clippy::cast_precision_loss, reason = "a handful of points")]
    let n = foot.len() as f64;
    (!foot.is_empty())
        .then(|| Point3::from(foot.iter().map(|(p, _)| p.coords).sum::<Vector3<f64>>() / n))
}

/// The body's long-run vertical: the mean direction from the feet to the neck over the frames
/// where the body is most extended (within 3 % of its 95th-percentile feet → neck distance:
/// standing, not squatting or bowing); else the mean pelvis → neck direction; else +Z.
fn body_vertical(samples: &[Sample]) -> Vector3<f64> {
    let spans: Vec<Vector3<f64>> = samples
        .iter()
        .filter_map(|s| {
            let feet: Vec<FootPoint> = s.feet.concat();
            Some(s.neck? - foot_centre(&feet)?)
        })
        .collect();
    let mut lengths: Vec<f64> = spans.iter().map(Vector3::norm).collect();
    lengths.sort_by(f64::total_cmp);
    if let Some(p95) = percentile(&lengths, 0.95) {
        let sum: Vector3<f64> = spans
            .iter()
            .filter(|d| d.norm() >= 0.97 * p95)
            .filter_map(|d| d.try_normalize(1e-9))
            .sum();
        if let Some(v) = sum.try_normalize(1e-9) {
            return v;
        }
    }
    let sum: Vector3<f64> = samples
        .iter()
        .filter_map(|s| Some(s.neck? - s.pelvis?))
        .filter_map(|d| d.try_normalize(1e-9))
        .sum();
    sum.try_normalize(1e-9).unwrap_or_else(Vector3::z)
}

/// The `q` quantile (nearest rank) of sorted `values`.
fn percentile(sorted: &[f64], q: f64) -> Option<f64> {
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_precision_loss,
        reason = "an index within the list"
    )]
    let i = (sorted.len().checked_sub(1)? as f64 * q).round() as usize;
    sorted.get(i).copied()
}

/// Per sample and side, the speed of the foot's centre (metres per second): the smaller of the
/// speeds to the previous and the next sample seeing that foot; `None` with no neighbour.
fn foot_speeds(samples: &[Sample]) -> Vec<[Option<f64>; 2]> {
    let mut out = vec![[None, None]; samples.len()];
    for side in [0, 1] {
        let seen: Vec<(usize, Point3<f64>)> = samples
            .iter()
            .enumerate()
            .filter_map(|(i, s)| foot_centre(&s.feet[side]).map(|p| (i, p)))
            .collect();
        for w in seen.windows(2) {
            let ((i, a), (j, b)) = (w[0], w[1]);
            let dt = nanos_to_secs(
                samples[j]
                    .stamp_nanos
                    .saturating_sub(samples[i].stamp_nanos),
            );
            if dt <= 0.0 {
                continue;
            }
            let v = (b - a).norm() / dt;
            for k in [i, j] {
                let s = &mut out[k][side];
                *s = Some(s.map_or(v, |old: f64| old.min(v)));
            }
        }
    }
    out
}

/// The speed under which a foot counts as planted: 20 % of the clip's 95th-percentile foot
/// speed, within 0.3–1 m/s.
fn speed_limit(speeds: &[[Option<f64>; 2]]) -> f64 {
    let mut all: Vec<f64> = speeds.iter().flatten().flatten().copied().collect();
    if all.is_empty() {
        return f64::INFINITY;
    }
    all.sort_by(f64::total_cmp);
    percentile(&all, 0.95).map_or(f64::INFINITY, |p95| (0.2 * p95).clamp(0.3, 1.0))
}

/// The contact candidates, one list per sample and side: the foot's points (lowered by their
/// sole offsets) when the foot is slower than `speed_limit` (or its speed is unknown) and, once
/// a floor `up·p = offset` is known, within [`CONTACT_BAND_M`] of it. Of a foot's points only
/// those within [`INLIER_M`] of its lowest one count: a foot on its ball (the back foot of a
/// fighting stance, a heel raised) touches the floor at the toes, not at the heel or ankle.
fn contact_points(
    samples: &[Sample],
    speeds: &[[Option<f64>; 2]],
    speed_limit: f64,
    up: Vector3<f64>,
    offset: f64,
) -> Vec<Vec<FootPoint>> {
    let mut out = Vec::new();
    for (s, v) in samples.iter().zip(speeds) {
        for side in [0, 1] {
            if v[side].is_some_and(|v| v > speed_limit) {
                continue;
            }
            let lowered: Vec<(FootPoint, f64)> = s.feet[side]
                .iter()
                .map(|&(p, kind)| {
                    let q = p - up * FOOT_LANDMARKS[kind].1;
                    ((q, kind), up.dot(&q.coords))
                })
                .collect();
            let lowest = lowered
                .iter()
                .map(|(_, h)| *h)
                .fold(f64::INFINITY, f64::min);
            if offset.is_finite() && lowest - offset > CONTACT_BAND_M {
                continue;
            }
            let foot: Vec<FootPoint> = lowered
                .into_iter()
                .filter(|(_, h)| h - lowest <= INLIER_M)
                .map(|(p, _)| p)
                .collect();
            if !foot.is_empty() {
                out.push(foot);
            }
        }
    }
    out
}

/// A tiny deterministic generator for RANSAC (xorshift64*).
struct Xorshift(u64);

impl Xorshift {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        let r = self.0.wrapping_mul(0x2545_F491_4F6C_DD1D);
        #[expect(clippy::cast_possible_truncation, reason = "n fits usize; r % n < n")]
        let i = (r % n as u64) as usize;
        i
    }
}

/// The floor through `contacts`: (unit normal towards `prior`, offset) with `normal·p =
/// offset`. RANSAC picks the inliers, a least-squares fit regularised towards `prior` places
/// the plane.
fn fit_plane(contacts: &[FootPoint], prior: Vector3<f64>) -> (Vector3<f64>, f64, f64) {
    let points: Vec<Point3<f64>> = contacts.iter().map(|(p, _)| *p).collect();
    let max_cos = MAX_TILT_FROM_TRUNK_DEG.to_radians().cos();
    let inliers_of = |n: &Vector3<f64>, c: f64| -> Vec<usize> {
        (0..points.len())
            .filter(|&i| (n.dot(&points[i].coords) - c).abs() <= INLIER_M)
            .collect()
    };
    // Hypotheses: planes square to the trunk through each point, and through random triples.
    // Of equals, the lowest plane (a lower envelope), its height measured along the trunk from
    // the points' centroid: a camera's rotation or position then changes no choice.
    #[expect(clippy::cast_precision_loss, reason = "point counts are small")]
    let centroid = points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / points.len() as f64;
    let height = |n: &Vector3<f64>, c: f64| (c - n.dot(&centroid)) / n.dot(&prior);
    let mut best: (Vec<usize>, f64) = (Vec::new(), f64::INFINITY);
    let mut consider = |n: Vector3<f64>, c: f64| {
        let inl = inliers_of(&n, c);
        let h = height(&n, c);
        if inl.len() > best.0.len() || (inl.len() == best.0.len() && h < best.1) {
            best = (inl, h);
        }
    };
    for p in points.iter().step_by(points.len().div_ceil(200).max(1)) {
        consider(prior, prior.dot(&p.coords));
    }
    let mut rng = Xorshift(0x9E37_79B9_7F4A_7C15);
    if points.len() >= 3 {
        for _ in 0..300 {
            let (a, b, c) = (
                points[rng.below(points.len())],
                points[rng.below(points.len())],
                points[rng.below(points.len())],
            );
            let Some(mut n) = (b - a).cross(&(c - a)).try_normalize(1e-9) else {
                continue;
            };
            if n.dot(&prior) < 0.0 {
                n = -n;
            }
            if n.dot(&prior) < max_cos {
                continue;
            }
            consider(n, n.dot(&a.coords));
        }
    }
    let chosen: Vec<FootPoint> = best.0.iter().map(|&i| contacts[i]).collect();
    refit(&chosen, prior)
}

/// The least-squares plane through `contacts`, its normal pulled towards `prior` as if the
/// points spread [`PRIOR_SPREAD_M`] in every direction square to it: (unit normal, offset,
/// the points' own spread across their main line in metres).
///
/// Each landmark kind gets a height of its own above the floor: the scatter is taken about each
/// kind's own mean, so only distinct placements of one landmark (the left and the right heel,
/// the heel of one step and of the next) tilt the plane, never the difference between an ankle
/// and a toe, whose heights above the sole vary from source to source. Where the placements do
/// not span the floor (both feet planted, a straight walk), the prior decides what they leave.
fn refit(contacts: &[FootPoint], prior: Vector3<f64>) -> (Vector3<f64>, f64, f64) {
    if contacts.is_empty() {
        return (prior, 0.0, 0.0);
    }
    let mut sums = [(Vector3::zeros(), 0.0_f64); FOOT_LANDMARKS.len()];
    for (p, kind) in contacts {
        sums[*kind].0 += p.coords;
        sums[*kind].1 += 1.0;
    }
    let mut scatter = Matrix3::zeros();
    for (p, kind) in contacts {
        let d = p.coords - sums[*kind].0 / sums[*kind].1;
        scatter += d * d.transpose();
    }
    #[expect(
        clippy::cast_precision_loss,
        reason = "point counts are far below 2^52"
    )]
    let count = contacts.len() as f64;
    scatter /= count;
    let mut spreads: Vec<f64> = scatter.symmetric_eigenvalues().iter().copied().collect();
    spreads.sort_by(|a, b| b.total_cmp(a));
    let across_spread_m = spreads[1].max(0.0).sqrt();
    let penalty = (Matrix3::identity() - prior * prior.transpose()) * PRIOR_SPREAD_M.powi(2);
    let eigen = (scatter + penalty).symmetric_eigen();
    let mut n = eigen
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .map_or(prior, |(i, _)| eigen.eigenvectors.column(i).into_owned());
    if n.dot(&prior) < 0.0 {
        n = -n;
    }
    let n = n.try_normalize(1e-12).unwrap_or(prior);
    let mut offsets: Vec<f64> = contacts.iter().map(|(p, _)| n.dot(&p.coords)).collect();
    offsets.sort_by(f64::total_cmp);
    (n, offsets[offsets.len() / 2], across_spread_m)
}

impl Grounding {
    /// Moves every point of `seq` by [`Grounding::world_from_camera`] (NaN stays NaN).
    pub fn apply(&self, seq: &mut PoseSequence) {
        for f in &mut seq.frames {
            for p in &mut f.positions_m {
                *p = self.world_from_camera * *p;
            }
        }
    }

    /// One line for people: the tilt removed, the contacts and the residual at contact.
    #[must_use]
    pub fn summary(&self) -> String {
        let u = self.up_in_camera;
        format!(
            "up ({:.3}, {:.3}, {:.3}) in the source frame, {:.1}° from its +Z; {} foot contacts in {} frames, |z| at contact median {:.1} mm, p95 {:.1} mm",
            u.x,
            u.y,
            u.z,
            self.tilt_deg,
            self.contacts,
            self.samples,
            self.residual_median_m * 1000.0,
            self.residual_p95_m * 1000.0,
        ) + &self.trunk_note()
    }

    /// A warning when the feet at contact sit more than [`INLIER_M`] off the plane (median):
    /// the clip may not stand on one floor.
    #[must_use]
    pub fn loose_fit_warning(&self) -> Option<String> {
        (self.residual_median_m > INLIER_M).then(|| {
            format!(
                "the feet do not settle on one plane ({}); check the result, or give --ground off",
                self.summary()
            )
        })
    }

    /// When the contacts lie on a line (both feet planted, a straight walk, a short clip), what
    /// that means for the up: empty otherwise.
    #[must_use]
    pub fn trunk_note(&self) -> String {
        if self.across_spread_m >= TRUNK_DECIDES_SPREAD_M {
            return String::new();
        }
        format!(
            "; the contacts spread {:.1} cm across their line, so the trunk set the tilt about it (a seated or leaning body reads as tilted)",
            self.across_spread_m * 100.0
        )
    }
}

/// Estimates the ground of a whole sequence from every `stride`-th frame (1 = all).
///
/// # Errors
/// [`GroundError`] when the layout has no feet or no sampled frame sees one.
pub fn estimate(
    seq: &PoseSequence,
    layout: &Layout,
    stride: usize,
) -> Result<Grounding, GroundError> {
    estimate_frames(
        layout,
        &seq.joint_names,
        &seq.source,
        seq.frames.iter().step_by(stride.max(1)),
    )
}

/// Estimates the ground from `frames` (in stamp order; any sample of a clip) whose joints are
/// `joint_names` in `layout`; `source_name` names the data in errors.
///
/// # Errors
/// [`GroundError`] when the layout has no feet or no frame sees one.
pub fn estimate_frames<'f>(
    layout: &Layout,
    joint_names: &[String],
    source_name: &str,
    frames: impl IntoIterator<Item = &'f PoseFrame>,
) -> Result<Grounding, GroundError> {
    let mut sampler = GroundSampler::new(layout, joint_names, source_name)?;
    for f in frames {
        sampler.push(f);
    }
    sampler.estimate()
}

/// A grounding shared by the tracks one camera saw, and the track it was estimated on.
#[derive(Debug, Clone)]
pub struct SharedGrounding {
    /// The track whose feet gave the estimate.
    pub track_id: u64,
    /// The grounding, applied to every track: one camera, one floor, so the people keep their
    /// places relative to each other.
    pub grounding: Grounding,
}

impl SharedGrounding {
    /// What the grounding did to track `track_id`, for people: the estimate on its own track,
    /// the track it came from on the others.
    #[must_use]
    pub fn note(&self, track_id: u64) -> String {
        if track_id == self.track_id {
            format!("grounded: {}", self.grounding.summary())
        } else {
            format!(
                "grounded with track {} (one camera: one floor, places kept)",
                self.track_id
            )
        }
    }
}

/// One grounding for tracks seen by one camera (`(track id, frame count)` of each by `key`):
/// estimated on the track with the most frames (ties: the first), or else the next whose
/// estimate succeeds. `None` for no tracks; the first track's error when none can be grounded.
pub fn shared<T, N: Ord>(
    tracks: &[T],
    key: impl Fn(&T) -> (u64, N),
    estimate: impl Fn(&T) -> Result<Grounding, GroundError>,
) -> Option<Result<SharedGrounding, GroundError>> {
    let mut order: Vec<&T> = tracks.iter().collect();
    order.sort_by_key(|t| std::cmp::Reverse(key(t).1));
    let mut first_error = None;
    for t in order {
        match estimate(t) {
            Ok(grounding) => {
                return Some(Ok(SharedGrounding {
                    track_id: key(t).0,
                    grounding,
                }));
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    first_error.map(Err)
}

/// Grounds `seq` in place (see the module documentation) and returns what was done.
///
/// # Errors
/// [`GroundError`] when the layout has no feet or no frame sees one; `seq` is then unchanged.
pub fn ground(seq: &mut PoseSequence, layout: &Layout) -> Result<Grounding, GroundError> {
    let grounding = estimate(seq, layout, 1)?;
    grounding.apply(seq);
    Ok(grounding)
}

#[cfg(test)]
#[path = "ground_tests.rs"]
mod tests;
