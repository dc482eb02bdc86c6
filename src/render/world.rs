//! The static world of a scene: the ground's materials as tiled, mip-mapped textures, the props
//! the location placed, and the backdrop around the floor (hills, a tree line, city blocks, the
//! sea, or a room's walls and ceiling). Built once per scene from its
//! [`LocationInstance`] and [`Environment`]; the layout of the backdrop comes from the scene's
//! seed, so two scenes at one location differ.
//!
//! Props are drawn from their kind's name (the built-in pool's `tree`, `car`, `bench`, …),
//! parsed once into a [`PropKind`] whose shape is data, inside their placed bounding box; a kind
//! the renderer does not know is drawn as a box of that size (never skipped), and
//! [`World::unknown_prop_kinds`] lists them so the caller can say so.

use crate::hash::{hash2, unit2};
use crate::scene::color::{Rgb, linear_from_srgb, mix, scale};
use crate::scene::environment::Environment;
use crate::scene::fast_float::{floor_small, pow2};
use crate::scene::location::{Backdrop, Ground, LocationInstance, PlacedProp};

/// What a pixel shows, for masks and annotations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
#[repr(u8)]
pub enum Surface {
    /// Sky or nothing.
    Sky = 0,
    /// The ground plane.
    Ground = 1,
    /// The animated character.
    Character = 2,
    /// A prop.
    Prop = 3,
    /// The backdrop (hills, buildings, walls).
    Backdrop = 4,
}

/// A triangle mesh in world coordinates with per-vertex normals and albedo.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions, metres, world frame.
    pub positions: Vec<[f32; 3]>,
    /// Unit normals.
    pub normals: Vec<[f32; 3]>,
    /// Linear albedo per vertex.
    pub albedo: Vec<Rgb>,
    /// Triangles, counter-clockwise seen from outside.
    pub indices: Vec<u32>,
}

impl Mesh {
    fn vertex(&mut self, p: [f32; 3], n: [f32; 3], c: Rgb) -> u32 {
        let i = self.positions.len() as u32;
        self.positions.push(p);
        self.normals.push(n);
        self.albedo.push(c);
        i
    }

    /// Number of triangles.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }
}

/// Places local shapes: a yaw about +z and a translation.
#[derive(Debug, Clone, Copy)]
struct Place {
    origin: [f32; 3],
    cos: f32,
    sin: f32,
}

impl Place {
    fn new(origin: [f32; 3], yaw_rad: f32) -> Place {
        Place {
            origin,
            cos: yaw_rad.cos(),
            sin: yaw_rad.sin(),
        }
    }
    fn point(&self, p: [f32; 3]) -> [f32; 3] {
        [
            self.origin[0] + self.cos * p[0] - self.sin * p[1],
            self.origin[1] + self.sin * p[0] + self.cos * p[1],
            self.origin[2] + p[2],
        ]
    }
    fn dir(&self, n: [f32; 3]) -> [f32; 3] {
        [
            self.cos * n[0] - self.sin * n[1],
            self.sin * n[0] + self.cos * n[1],
            n[2],
        ]
    }
}

/// An axis-aligned box (in the placed frame) from `lo` to `hi`, flat-shaded, outward.
fn add_box(m: &mut Mesh, at: Place, lo: [f32; 3], hi: [f32; 3], c: Rgb) {
    // Each face: normal, and its four corners counter-clockwise seen from outside.
    let faces: [([f32; 3], [[f32; 3]; 4]); 6] = [
        (
            [1.0, 0.0, 0.0],
            [
                [hi[0], lo[1], lo[2]],
                [hi[0], hi[1], lo[2]],
                [hi[0], hi[1], hi[2]],
                [hi[0], lo[1], hi[2]],
            ],
        ),
        (
            [-1.0, 0.0, 0.0],
            [
                [lo[0], hi[1], lo[2]],
                [lo[0], lo[1], lo[2]],
                [lo[0], lo[1], hi[2]],
                [lo[0], hi[1], hi[2]],
            ],
        ),
        (
            [0.0, 1.0, 0.0],
            [
                [hi[0], hi[1], lo[2]],
                [lo[0], hi[1], lo[2]],
                [lo[0], hi[1], hi[2]],
                [hi[0], hi[1], hi[2]],
            ],
        ),
        (
            [0.0, -1.0, 0.0],
            [
                [lo[0], lo[1], lo[2]],
                [hi[0], lo[1], lo[2]],
                [hi[0], lo[1], hi[2]],
                [lo[0], lo[1], hi[2]],
            ],
        ),
        (
            [0.0, 0.0, 1.0],
            [
                [lo[0], lo[1], hi[2]],
                [hi[0], lo[1], hi[2]],
                [hi[0], hi[1], hi[2]],
                [lo[0], hi[1], hi[2]],
            ],
        ),
        (
            [0.0, 0.0, -1.0],
            [
                [lo[0], hi[1], lo[2]],
                [hi[0], hi[1], lo[2]],
                [hi[0], lo[1], lo[2]],
                [lo[0], lo[1], lo[2]],
            ],
        ),
    ];
    for (n, corners) in faces {
        let n = at.dir(n);
        let k: Vec<u32> = corners
            .iter()
            .map(|&p| m.vertex(at.point(p), n, c))
            .collect();
        m.indices
            .extend_from_slice(&[k[0], k[1], k[2], k[0], k[2], k[3]]);
    }
}

/// A box standing on z = `z0` centred at (x, y) of the placed frame.
fn add_block(m: &mut Mesh, at: Place, centre: [f32; 2], size: [f32; 3], z0: f32, c: Rgb) {
    let lo = [centre[0] - size[0] / 2.0, centre[1] - size[1] / 2.0, z0];
    let hi = [
        centre[0] + size[0] / 2.0,
        centre[1] + size[1] / 2.0,
        z0 + size[2],
    ];
    add_box(m, at, lo, hi, c);
}

/// A surface of revolution about the placed frame's z axis through `(x, y)`: `profile` lists
/// (radius, z) from bottom to top; smooth-shaded sides, closed by the first and last rings
/// when their radius is zero or by flat caps otherwise.
fn add_lathe(m: &mut Mesh, at: Place, xy: [f32; 2], profile: &[(f32, f32)], segments: u32, c: Rgb) {
    let n = segments as usize;
    let ring = |k: usize| {
        let a = std::f32::consts::TAU * k as f32 / n as f32;
        (a.cos(), a.sin())
    };
    let mut rings = Vec::with_capacity(profile.len());
    for (j, &(r, z)) in profile.iter().enumerate() {
        // Normal of the profile at this ring from its neighbours.
        let (pr, pz) = profile[j.saturating_sub(1)];
        let (nr, nz) = profile[(j + 1).min(profile.len() - 1)];
        let (dr, dz) = (nr - pr, nz - pz);
        let len = (dr * dr + dz * dz).sqrt().max(1e-6);
        let (radial, up) = (dz / len, -dr / len);
        let first = m.positions.len() as u32;
        for k in 0..n {
            let (cs, sn) = ring(k);
            let p = [xy[0] + r * cs, xy[1] + r * sn, z];
            let nn = [radial * cs, radial * sn, up];
            m.vertex(at.point(p), at.dir(nn), c);
        }
        rings.push(first);
    }
    for j in 0..rings.len() - 1 {
        for k in 0..n {
            let (a, b) = (rings[j] + k as u32, rings[j] + ((k + 1) % n) as u32);
            let (d, e) = (rings[j + 1] + k as u32, rings[j + 1] + ((k + 1) % n) as u32);
            // A ring of radius zero is an apex: its quads are triangles.
            if profile[j + 1].0 > 1e-4 || profile[j].0 <= 1e-4 {
                m.indices.extend_from_slice(&[a, e, d]);
            }
            if profile[j].0 > 1e-4 {
                m.indices.extend_from_slice(&[a, b, e]);
            }
        }
    }
    for (end, normal_z) in [(0usize, -1.0f32), (profile.len() - 1, 1.0)] {
        let (r, z) = profile[end];
        if r <= 1e-4 {
            continue;
        }
        let centre = m.vertex(at.point([xy[0], xy[1], z]), at.dir([0.0, 0.0, normal_z]), c);
        let first = m.positions.len() as u32;
        for k in 0..n {
            let (cs, sn) = ring(k);
            m.vertex(
                at.point([xy[0] + r * cs, xy[1] + r * sn, z]),
                at.dir([0.0, 0.0, normal_z]),
                c,
            );
        }
        for k in 0..n as u32 {
            let (a, b) = (first + k, first + (k + 1) % n as u32);
            if normal_z > 0.0 {
                m.indices.extend_from_slice(&[centre, a, b]);
            } else {
                m.indices.extend_from_slice(&[centre, b, a]);
            }
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn cylinder(m: &mut Mesh, at: Place, xy: [f32; 2], r: f32, z0: f32, z1: f32, seg: u32, c: Rgb) {
    add_lathe(m, at, xy, &[(r, z0), (r, z1)], seg, c);
}

fn srgb(c: [f32; 3]) -> Rgb {
    linear_from_srgb(c)
}

/// sRGB of bare metal (legs, posts, frames).
const METAL: [f32; 3] = [0.55, 0.57, 0.6];
/// sRGB of black plastic and rubber (wheels, weight benches, treadmill belts).
const DARK: [f32; 3] = [0.08, 0.08, 0.09];
/// sRGB of varnished wood (benches, desks).
const WOOD: [f32; 3] = [0.5, 0.34, 0.2];
/// sRGB of a kind the renderer has no shape for (drawn as a box).
const UNKNOWN_GREY: [f32; 3] = [0.6, 0.6, 0.6];

// Palettes a prop's colour is drawn from (by its variety hash), sRGB.
/// Tree crowns.
const LEAVES: [[f32; 3]; 3] = [[0.2, 0.42, 0.15], [0.16, 0.36, 0.14], [0.26, 0.45, 0.18]];
/// Rocks.
const STONE: [[f32; 3]; 2] = [[0.45, 0.44, 0.42], [0.38, 0.36, 0.33]];
/// Cars and golf carts.
const CAR_PAINT: [[f32; 3]; 6] = [
    [0.7, 0.08, 0.07],
    [0.9, 0.9, 0.92],
    [0.1, 0.12, 0.2],
    [0.5, 0.52, 0.55],
    [0.1, 0.1, 0.1],
    [0.15, 0.3, 0.6],
];
/// Parasol canopies.
const CANOPY: [[f32; 3]; 4] = [
    [0.9, 0.3, 0.2],
    [0.95, 0.85, 0.3],
    [0.2, 0.5, 0.8],
    [0.95, 0.95, 0.95],
];
/// Coolers.
const COOLER: [[f32; 3]; 2] = [[0.2, 0.4, 0.8], [0.85, 0.2, 0.2]];
/// Chair seats and backs.
const UPHOLSTERY: [[f32; 3]; 3] = [[0.12, 0.12, 0.14], [0.2, 0.25, 0.4], [0.35, 0.2, 0.15]];
/// Cabinets.
const CABINET: [[f32; 3]; 2] = [[0.6, 0.6, 0.62], [0.35, 0.3, 0.25]];
/// Beach towels and exercise mats.
const FABRIC: [[f32; 3]; 4] = [
    [0.2, 0.6, 0.8],
    [0.9, 0.4, 0.5],
    [0.3, 0.7, 0.3],
    [0.6, 0.3, 0.7],
];

/// A prop kind the renderer draws with a shape of its own, parsed once from the location's prop
/// name (the built-in pool's `tree`, `car`, `bench`, …). Adding a prop is adding a variant, its
/// name and its [`Shape`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum PropKind {
    /// `ball_basket`.
    BallBasket,
    /// `beach_towel`.
    BeachTowel,
    /// `bench`.
    Bench,
    /// `cabinet`.
    Cabinet,
    /// `car`.
    Car,
    /// `cooler`.
    Cooler,
    /// `crate`.
    Crate,
    /// `desk`.
    Desk,
    /// `dumbbell_rack`.
    DumbbellRack,
    /// `exercise_mat`.
    ExerciseMat,
    /// `flagstick`.
    Flagstick,
    /// `forklift`.
    Forklift,
    /// `golf_cart`.
    GolfCart,
    /// `lamp_post`.
    LampPost,
    /// `office_chair`.
    OfficeChair,
    /// `pallet`.
    Pallet,
    /// `parasol`.
    Parasol,
    /// `plant`.
    Plant,
    /// `rock`.
    Rock,
    /// `sun_lounger`.
    SunLounger,
    /// `trash_bin`.
    TrashBin,
    /// `treadmill`.
    Treadmill,
    /// `tree`.
    Tree,
    /// `umpire_chair`.
    UmpireChair,
    /// `weight_bench`.
    WeightBench,
}

impl PropKind {
    /// Every kind, in the order of their names.
    pub const ALL: [PropKind; 25] = [
        PropKind::BallBasket,
        PropKind::BeachTowel,
        PropKind::Bench,
        PropKind::Cabinet,
        PropKind::Car,
        PropKind::Cooler,
        PropKind::Crate,
        PropKind::Desk,
        PropKind::DumbbellRack,
        PropKind::ExerciseMat,
        PropKind::Flagstick,
        PropKind::Forklift,
        PropKind::GolfCart,
        PropKind::LampPost,
        PropKind::OfficeChair,
        PropKind::Pallet,
        PropKind::Parasol,
        PropKind::Plant,
        PropKind::Rock,
        PropKind::SunLounger,
        PropKind::TrashBin,
        PropKind::Treadmill,
        PropKind::Tree,
        PropKind::UmpireChair,
        PropKind::WeightBench,
    ];

    /// The kind named `name` in a location's props, if the renderer has a shape for it.
    #[must_use]
    pub fn from_name(name: &str) -> Option<PropKind> {
        PropKind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The name locations use for this kind.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            PropKind::BallBasket => "ball_basket",
            PropKind::BeachTowel => "beach_towel",
            PropKind::Bench => "bench",
            PropKind::Cabinet => "cabinet",
            PropKind::Car => "car",
            PropKind::Cooler => "cooler",
            PropKind::Crate => "crate",
            PropKind::Desk => "desk",
            PropKind::DumbbellRack => "dumbbell_rack",
            PropKind::ExerciseMat => "exercise_mat",
            PropKind::Flagstick => "flagstick",
            PropKind::Forklift => "forklift",
            PropKind::GolfCart => "golf_cart",
            PropKind::LampPost => "lamp_post",
            PropKind::OfficeChair => "office_chair",
            PropKind::Pallet => "pallet",
            PropKind::Parasol => "parasol",
            PropKind::Plant => "plant",
            PropKind::Rock => "rock",
            PropKind::SunLounger => "sun_lounger",
            PropKind::TrashBin => "trash_bin",
            PropKind::Treadmill => "treadmill",
            PropKind::Tree => "tree",
            PropKind::UmpireChair => "umpire_chair",
            PropKind::WeightBench => "weight_bench",
        }
    }

    /// How this kind is built inside its box.
    fn shape(self) -> Shape {
        use Paint::{Fixed, Pick};
        match self {
            PropKind::Tree => Shape::Tree {
                leaves: Pick(&LEAVES),
            },
            PropKind::Rock => Shape::Rock {
                stone: Pick(&STONE),
            },
            PropKind::Bench => Shape::Bench {
                seat: Fixed(WOOD),
                backrest: true,
            },
            PropKind::WeightBench => Shape::Bench {
                seat: Fixed(DARK),
                backrest: false,
            },
            PropKind::Car => Shape::Vehicle {
                body: Pick(&CAR_PAINT),
                cabin_of_length: 0.5,
            },
            PropKind::GolfCart => Shape::Vehicle {
                body: Pick(&CAR_PAINT),
                cabin_of_length: 0.6,
            },
            PropKind::LampPost => Shape::Pole {
                top: TopBlock {
                    centre_m: [0.0, 0.0],
                    size_m: [0.5, 0.25, 0.15],
                    below_top_m: 0.15,
                    srgb: [0.95, 0.92, 0.8],
                },
            },
            PropKind::Flagstick => Shape::Pole {
                top: TopBlock {
                    centre_m: [0.25, 0.0],
                    size_m: [0.5, 0.02, 0.35],
                    below_top_m: 0.4,
                    srgb: [0.9, 0.1, 0.1],
                },
            },
            PropKind::Parasol => Shape::Parasol {
                canopy: Pick(&CANOPY),
            },
            PropKind::Plant => Shape::Plant,
            PropKind::TrashBin => Shape::Drum {
                paint: Fixed([0.2, 0.35, 0.25]),
            },
            PropKind::BallBasket => Shape::Drum {
                paint: Fixed([0.8, 0.85, 0.2]),
            },
            PropKind::Cooler => Shape::Block {
                paint: Pick(&COOLER),
            },
            PropKind::Cabinet => Shape::Block {
                paint: Pick(&CABINET),
            },
            PropKind::Crate => Shape::Block {
                paint: Fixed([0.62, 0.45, 0.25]),
            },
            PropKind::DumbbellRack => Shape::Block { paint: Fixed(DARK) },
            PropKind::Desk => Shape::Desk,
            PropKind::OfficeChair => Shape::Chair {
                seat_of_height: 0.42,
            },
            PropKind::UmpireChair => Shape::Chair {
                seat_of_height: 0.7,
            },
            PropKind::Forklift => Shape::Forklift {
                body: Fixed([0.95, 0.7, 0.1]),
            },
            PropKind::Treadmill => Shape::Treadmill,
            PropKind::Pallet => Shape::Slab {
                paint: Fixed([0.6, 0.48, 0.3]),
            },
            PropKind::SunLounger => Shape::Slab {
                paint: Fixed([0.92, 0.92, 0.9]),
            },
            PropKind::BeachTowel | PropKind::ExerciseMat => Shape::Slab {
                paint: Pick(&FABRIC),
            },
        }
    }
}

/// A prop's colour: one sRGB colour, or one of a palette chosen by the prop's variety hash.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Paint {
    Fixed([f32; 3]),
    Pick(&'static [[f32; 3]]),
}

impl Paint {
    /// The linear colour of the prop with `variety`.
    fn rgb(self, variety: u64) -> Rgb {
        match self {
            Paint::Fixed(c) => srgb(c),
            Paint::Pick(palette) => srgb(palette[(variety % palette.len() as u64) as usize]),
        }
    }
}

/// The block at the top of a pole.
#[derive(Debug, Clone, Copy, PartialEq)]
struct TopBlock {
    /// Centre `[x, y]` in the prop's frame, metres.
    centre_m: [f32; 2],
    /// Size `[x, y, z]`, metres.
    size_m: [f32; 3],
    /// Its bottom, below the prop's height, metres.
    below_top_m: f32,
    /// Its sRGB colour.
    srgb: [f32; 3],
}

/// How a kind is built inside its placed box, from boxes, cylinders and lathed profiles.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Shape {
    /// A trunk under a crown of leaves.
    Tree { leaves: Paint },
    /// A lathed boulder.
    Rock { stone: Paint },
    /// A seat on two legs, with a backrest or not.
    Bench { seat: Paint, backrest: bool },
    /// A body on four wheels under a glass cabin that long (a fraction of the box's length).
    Vehicle { body: Paint, cabin_of_length: f32 },
    /// A thin metal pole with a block at its top.
    Pole { top: TopBlock },
    /// A thin pole under a canopy.
    Parasol { canopy: Paint },
    /// A pot and its foliage.
    Plant,
    /// An upright cylinder filling the box.
    Drum { paint: Paint },
    /// A block filling the box.
    Block { paint: Paint },
    /// A block filling the box, at least 1 cm high.
    Slab { paint: Paint },
    /// A wooden top on four metal legs.
    Desk,
    /// A seat at that fraction of the height on a post, with a backrest.
    Chair { seat_of_height: f32 },
    /// A body and a mast at its front.
    Forklift { body: Paint },
    /// A low belt and an upright console at its front.
    Treadmill,
}

/// A placed prop's frame and box: the size `[sx, sy, sz]` and half footprint `[hx, hy]`, metres.
#[derive(Debug, Clone, Copy)]
struct PropFrame {
    at: Place,
    sx: f32,
    sy: f32,
    sz: f32,
    hx: f32,
    hy: f32,
}

impl Shape {
    /// Draws the shape into `m` inside `f`; `variety` picks palette colours.
    fn draw(self, m: &mut Mesh, f: PropFrame, variety: u64) {
        let PropFrame {
            at,
            sx,
            sy,
            sz,
            hx,
            hy,
        } = f;
        match self {
            Shape::Tree { leaves } => draw_tree(m, f, leaves.rgb(variety)),
            Shape::Rock { stone } => add_lathe(
                m,
                at,
                [0.0, 0.0],
                &[
                    (hx * 0.8, 0.0),
                    (hx, sz * 0.35),
                    (hx * 0.6, sz * 0.85),
                    (0.0, sz),
                ],
                7,
                stone.rgb(variety),
            ),
            Shape::Bench { seat, backrest } => draw_bench(m, f, seat.rgb(variety), backrest),
            Shape::Vehicle {
                body,
                cabin_of_length,
            } => draw_vehicle(m, f, body.rgb(variety), cabin_of_length),
            Shape::Pole { top } => {
                cylinder(m, at, [0.0, 0.0], hx.min(0.08), 0.0, sz, 6, srgb(METAL));
                let z0 = sz - top.below_top_m;
                add_block(m, at, top.centre_m, top.size_m, z0, srgb(top.srgb));
            }
            Shape::Parasol { canopy } => {
                cylinder(m, at, [0.0, 0.0], 0.03, 0.0, sz, 6, srgb([0.9, 0.9, 0.88]));
                let profile = [(hx, sz * 0.8), (hx * 0.5, sz * 0.92), (0.0, sz)];
                add_lathe(m, at, [0.0, 0.0], &profile, 8, canopy.rgb(variety));
            }
            Shape::Plant => draw_plant(m, f),
            Shape::Drum { paint } => {
                cylinder(
                    m,
                    at,
                    [0.0, 0.0],
                    hx.min(hy),
                    0.0,
                    sz,
                    10,
                    paint.rgb(variety),
                );
            }
            Shape::Block { paint } => {
                add_block(m, at, [0.0, 0.0], [sx, sy, sz], 0.0, paint.rgb(variety));
            }
            Shape::Slab { paint } => {
                let size = [sx, sy, sz.max(0.01)];
                add_block(m, at, [0.0, 0.0], size, 0.0, paint.rgb(variety));
            }
            Shape::Desk => draw_desk(m, f),
            Shape::Chair { seat_of_height } => {
                draw_chair(m, f, Paint::Pick(&UPHOLSTERY).rgb(variety), seat_of_height);
            }
            Shape::Forklift { body } => {
                let c = body.rgb(variety);
                add_block(m, at, [-sx * 0.1, 0.0], [sx * 0.7, sy, sz * 0.5], 0.1, c);
                add_block(
                    m,
                    at,
                    [hx * 0.75, 0.0],
                    [0.1, sy * 0.8, sz],
                    0.0,
                    srgb(DARK),
                );
            }
            Shape::Treadmill => {
                add_block(m, at, [0.0, 0.0], [sx, sy, 0.2], 0.0, srgb(DARK));
                add_block(m, at, [hx * 0.85, 0.0], [0.08, sy, sz], 0.0, srgb(METAL));
            }
        }
    }
}

/// A trunk and a crown of `leaf` colour.
fn draw_tree(m: &mut Mesh, f: PropFrame, leaf: Rgb) {
    let PropFrame { at, sx, sz, hx, .. } = f;
    let trunk_h = sz * 0.35;
    let bark = srgb([0.33, 0.22, 0.13]);
    cylinder(m, at, [0.0, 0.0], sx * 0.07, 0.0, trunk_h + 0.3, 6, bark);
    let crown = [
        (0.0, trunk_h * 0.9),
        (hx * 0.95, trunk_h + 0.2 * sz),
        (hx * 0.75, trunk_h + 0.45 * sz),
        (0.0, sz),
    ];
    add_lathe(m, at, [0.0, 0.0], &crown, 8, leaf);
}

/// A seat of `seat` colour on two metal legs, with a backrest if `backrest`.
fn draw_bench(m: &mut Mesh, f: PropFrame, seat: Rgb, backrest: bool) {
    let PropFrame {
        at,
        sx,
        sy,
        sz,
        hx,
        hy,
    } = f;
    add_block(m, at, [0.0, 0.0], [sx, sy * 0.9, 0.06], sz * 0.48, seat);
    if backrest {
        let size = [sx, 0.05, sz * 0.45];
        add_block(m, at, [0.0, hy * 0.8], size, sz * 0.55, seat);
    }
    for x in [-hx * 0.8, hx * 0.8] {
        add_block(
            m,
            at,
            [x, 0.0],
            [0.06, sy * 0.8, sz * 0.48],
            0.0,
            srgb(METAL),
        );
    }
}

/// A `body`-coloured body, a glass cabin `cabin_of_length` of its length and four wheels.
fn draw_vehicle(m: &mut Mesh, f: PropFrame, body: Rgb, cabin_of_length: f32) {
    let PropFrame {
        at,
        sx,
        sy,
        sz,
        hx,
        hy,
    } = f;
    let wheel_r = sz * 0.22;
    add_block(m, at, [0.0, 0.0], [sx, sy, sz * 0.42], wheel_r * 0.8, body);
    let glass = srgb([0.12, 0.16, 0.2]);
    let cabin_len = sx * cabin_of_length;
    add_block(
        m,
        at,
        [-sx * 0.05, 0.0],
        [cabin_len, sy * 0.86, sz * 0.36],
        wheel_r * 0.8 + sz * 0.42,
        glass,
    );
    for (x, y) in [
        (-hx * 0.65, -hy),
        (hx * 0.65, -hy),
        (-hx * 0.65, hy),
        (hx * 0.65, hy),
    ] {
        let wheel = Place {
            origin: at.point([x, y, wheel_r]),
            ..at
        };
        // A wheel: a short cylinder about the local y axis, drawn as a block.
        let size = [wheel_r * 1.8, 0.2, wheel_r * 1.8];
        add_block(m, wheel, [0.0, 0.0], size, -wheel_r * 0.9, srgb(DARK));
    }
}

/// A clay pot and a lathed bush.
fn draw_plant(m: &mut Mesh, f: PropFrame) {
    let PropFrame { at, sz, hx, .. } = f;
    let pot = srgb([0.6, 0.35, 0.25]);
    cylinder(m, at, [0.0, 0.0], hx * 0.6, 0.0, sz * 0.3, 8, pot);
    let bush = [
        (0.0, sz * 0.3),
        (hx, sz * 0.6),
        (hx * 0.6, sz * 0.9),
        (0.0, sz),
    ];
    add_lathe(m, at, [0.0, 0.0], &bush, 7, srgb([0.18, 0.45, 0.16]));
}

/// A wooden top on four metal legs at its corners.
fn draw_desk(m: &mut Mesh, f: PropFrame) {
    let PropFrame {
        at,
        sx,
        sy,
        sz,
        hx,
        hy,
    } = f;
    add_block(m, at, [0.0, 0.0], [sx, sy, 0.04], sz - 0.04, srgb(WOOD));
    for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
        let leg = [x * (hx - 0.05), y * (hy - 0.05)];
        add_block(m, at, leg, [0.05, 0.05, sz - 0.04], 0.0, srgb(METAL));
    }
}

/// A `c`-coloured seat at `seat_of_height` of the height on a metal post, with a backrest.
fn draw_chair(m: &mut Mesh, f: PropFrame, c: Rgb, seat_of_height: f32) {
    let PropFrame {
        at, sx, sy, sz, hy, ..
    } = f;
    let seat_z = sz * seat_of_height;
    cylinder(m, at, [0.0, 0.0], 0.04, 0.0, seat_z, 6, srgb(METAL));
    add_block(m, at, [0.0, 0.0], [sx * 0.8, sy * 0.8, 0.08], seat_z, c);
    add_block(
        m,
        at,
        [0.0, hy * 0.75],
        [sx * 0.8, 0.06, sz - seat_z - 0.08],
        seat_z + 0.08,
        c,
    );
}

/// Draws one placed prop of `kind` (`None`: a kind without a shape, drawn as a plain grey box)
/// into `m`; `variety` picks its colours.
fn add_prop(m: &mut Mesh, prop: &PlacedProp, kind: Option<PropKind>, variety: u64) {
    let [sx, sy, sz] = prop.size_m.map(|v| v as f32);
    let frame = PropFrame {
        at: Place::new(
            [prop.position_m[0] as f32, prop.position_m[1] as f32, 0.0],
            (prop.yaw_deg as f32).to_radians(),
        ),
        sx,
        sy,
        sz,
        hx: sx / 2.0,
        hy: sy / 2.0,
    };
    match kind {
        Some(kind) => kind.shape().draw(m, frame, variety),
        None => add_block(
            m,
            frame.at,
            [0.0, 0.0],
            [sx, sy, sz],
            0.0,
            srgb(UNKNOWN_GREY),
        ),
    }
}

/// Smooth value noise over the ground tile, in [0, 1]: `cells` × `cells` random values at the
/// lattice points, wrapping at the tile's edges (so tiles join seamlessly), blended with
/// smoothstep weights — continuous, with no blocks.
fn tile_noise(seed: u64, cells: usize, u: f32, v: f32) -> f32 {
    let (x, y) = (u * cells as f32, v * cells as f32);
    let (x0, y0) = (x.floor(), y.floor());
    let smooth = |t: f32| t * t * (3.0 - 2.0 * t);
    let (sx, sy) = (smooth(x - x0), smooth(y - y0));
    let (i0, j0) = (x0 as usize % cells, y0 as usize % cells);
    let (i1, j1) = ((i0 + 1) % cells, (j0 + 1) % cells);
    let at = |i: usize, j: usize| unit2(seed, (j * cells + i) as u64);
    let top = at(i0, j0) + (at(i1, j0) - at(i0, j0)) * sx;
    let bottom = at(i0, j1) + (at(i1, j1) - at(i0, j1)) * sx;
    top + (bottom - top) * sy
}

/// A ground texel of colour `c` at tile coordinates `(u, v)` under `env`'s weather: snow lies in
/// soft-edged drifts (two octaves of [`tile_noise`]) covering about `snow_cover` of the ground,
/// and wet ground darkens unevenly (damp patches and darker puddles), both continuous. `grain`
/// is the texel's own random value (the snow's sparkle).
fn weathered(c: Rgb, seed: u64, env: &Environment, u: f32, v: f32, grain: f32) -> Rgb {
    let mut c = c;
    if env.snow_cover > 0.0 {
        let drift =
            0.75 * tile_noise(seed ^ 0xa11, 3, u, v) + 0.25 * tile_noise(seed ^ 0xa12, 12, u, v);
        // The level below which the noise is snow: none at cover 0, all of it at cover 1, with a
        // soft edge (thin snow at the drifts' rims) 0.5 wide.
        let level = -0.25 + 1.5 * env.snow_cover;
        let t = ((level - drift) / 0.5 + 0.5).clamp(0.0, 1.0);
        let amount = t * t * (3.0 - 2.0 * t);
        let snow = scale(srgb([0.92, 0.93, 0.96]), 0.96 + 0.04 * grain);
        c = mix(c, snow, 0.95 * amount);
    }
    if env.wetness > 0.0 {
        let puddle = tile_noise(seed ^ 0x3e7, 8, u, v);
        c = scale(c, 1.0 - env.wetness * (0.3 + 0.3 * puddle));
    }
    c
}

/// Side of the ground texture tile, texels.
const TEXTURE_SIZE: usize = 128;

/// A square ground texture tiled over the plane, with its mip chain (each level half the
/// previous, down to 1×1: the pattern's average, which distant ground fades to).
#[derive(Debug, Clone, PartialEq)]
pub struct GroundTexture {
    /// Metres covered by one tile.
    tile_m: f32,
    /// Every level's texels, one after another, largest first; level `k` is
    /// `(TEXTURE_SIZE >> k)²` texels, row-major.
    texels: Vec<Rgb>,
    /// Texels per metre of the full-size level (`TEXTURE_SIZE / tile_m`), divided once here
    /// instead of per pixel.
    texels_per_m: f32,
}

/// Levels of a ground texture's mip chain: `TEXTURE_SIZE` down to 1×1.
const MIP_LEVELS: usize = TEXTURE_SIZE.trailing_zeros() as usize + 1;

impl GroundTexture {
    fn generate(ground: Ground, seed: u64, env: &Environment) -> GroundTexture {
        let n = TEXTURE_SIZE;
        let (tile_m, base): (f32, [f32; 3]) = match ground {
            Ground::Grass => (2.0, [0.24, 0.42, 0.14]),
            Ground::Asphalt => (2.0, [0.2, 0.2, 0.21]),
            Ground::Concrete => (2.0, [0.58, 0.57, 0.54]),
            Ground::Sand => (2.0, [0.8, 0.7, 0.52]),
            Ground::Wood => (1.6, [0.55, 0.38, 0.22]),
            Ground::Tiles => (2.0, [0.82, 0.85, 0.86]),
            Ground::Carpet => (1.0, [0.32, 0.35, 0.42]),
            Ground::Rubber => (2.0, [0.16, 0.16, 0.17]),
            Ground::Dirt => (2.0, [0.42, 0.32, 0.22]),
            Ground::Water => (4.0, [0.1, 0.22, 0.3]),
        };
        let base = srgb(base);
        let mut texels = vec![[0.0f32; 3]; n * n];
        for y in 0..n {
            for x in 0..n {
                let r = unit2(seed, (y * n + x) as u64);
                let coarse = unit2(seed ^ 0x5a5a, ((y / 8) * n + x / 8) as u64);
                let (u, v) = (x as f32 / n as f32, y as f32 / n as f32);
                let f = match ground {
                    Ground::Grass => 0.75 + 0.35 * r + 0.2 * coarse,
                    Ground::Asphalt | Ground::Rubber => {
                        if r > 0.97 {
                            1.8
                        } else {
                            0.85 + 0.3 * r
                        }
                    }
                    Ground::Concrete => {
                        let joint = u < 0.01 || v < 0.01;
                        if joint {
                            0.6
                        } else {
                            0.9 + 0.15 * r + 0.1 * coarse
                        }
                    }
                    Ground::Sand => 0.9 + 0.1 * r + 0.08 * (v * 40.0 + coarse * 3.0).sin(),
                    Ground::Wood => {
                        let plank = (v * 8.0).floor();
                        let seam = (v * 8.0).fract() < 0.04;
                        let tone = unit2(seed, plank as u64 + 1000);
                        if seam {
                            0.5
                        } else {
                            0.8 + 0.3 * tone + 0.08 * (u * 60.0 + tone * 9.0).sin()
                        }
                    }
                    Ground::Tiles => {
                        let grout = (u * 4.0).fract() < 0.03 || (v * 4.0).fract() < 0.03;
                        if grout { 0.55 } else { 0.97 + 0.05 * r }
                    }
                    Ground::Carpet => 0.85 + 0.3 * r,
                    Ground::Dirt => 0.7 + 0.45 * r * coarse + 0.2 * coarse,
                    Ground::Water => 0.9 + 0.2 * coarse,
                };
                let c = scale(base, f);
                texels[y * n + x] = weathered(c, seed, env, u, v, r);
            }
        }
        let mut levels = vec![texels];
        let mut size = n;
        while size > 1 {
            let prev = levels.last().map_or(&[][..], |l| l.as_slice());
            let half = size / 2;
            let mut next = vec![[0.0f32; 3]; half * half];
            for y in 0..half {
                for x in 0..half {
                    let mut acc = [0.0; 3];
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let t = prev[(2 * y + dy) * size + 2 * x + dx];
                        for k in 0..3 {
                            acc[k] += 0.25 * t[k];
                        }
                    }
                    next[y * half + x] = acc;
                }
            }
            levels.push(next);
            size = half;
        }
        GroundTexture {
            tile_m,
            texels: levels.concat(),
            texels_per_m: TEXTURE_SIZE as f32 / tile_m,
        }
    }

    /// Metres covered by one tile.
    #[must_use]
    pub fn tile_m(&self) -> f32 {
        self.tile_m
    }

    /// Changes every texel of every level by `f` (linear in the colour, so the mip levels stay
    /// the averages of the tile).
    pub fn map_texels(&mut self, f: impl Fn(Rgb) -> Rgb) {
        for t in &mut self.texels {
            *t = f(*t);
        }
    }

    /// The full-size tile: its side in texels and its texels (linear RGB), row-major, row `v`
    /// covering `y ∈ [v, v + 1) · tile_m / side` (for engines that sample it themselves).
    #[must_use]
    pub fn texels(&self) -> (usize, &[Rgb]) {
        (TEXTURE_SIZE, &self.texels[..TEXTURE_SIZE * TEXTURE_SIZE])
    }

    /// The colour at ground point `(x, y)` seen with a pixel footprint of `footprint_m` metres:
    /// the mip level whose texels are about that size (nearest texel), so distant ground does
    /// not shimmer.
    #[inline]
    #[must_use]
    pub fn sample(&self, x: f32, y: f32, footprint_m: f32) -> Rgb {
        self.texels[texel_index(self.texels_per_m, x, y, footprint_m)]
    }
}

/// The top mip level (1×1); level `k`'s side is `2^(TOP_LEVEL − k)`.
const TOP_LEVEL: i32 = MIP_LEVELS as i32 - 1;

/// Where [`GroundTexture::sample`] reads, in a texture whose full-size level has
/// `texels_per_m`: an index into its texels. Float and integer arithmetic only, without a
/// float-to-integer cast or a table, so that the ground pass's loop over pixels vectorises.
///
/// Texel coordinates are floored with [`floor_small`], exact below 2²² in magnitude. The top
/// level's one texel is read whatever the point; below it, a level is chosen only for a
/// footprint under `2^(level + 1)` of its texels, and the ground pass's footprint is at least
/// the distance over f_x (more at a slant), so a coordinate is at most 2·f_x of the level's
/// texels from the camera's. Wherever the coordinate lands, the mask keeps the index inside
/// the texture.
#[inline]
fn texel_index(texels_per_m: f32, x: f32, y: f32, footprint_m: f32) -> usize {
    // Footprint in full-size texels (a product: a division here is on the pixel's critical
    // path); its level ⌊log2⌋ from the float's exponent.
    let ratio = footprint_m * texels_per_m;
    let exponent = ((ratio.to_bits() >> 23) & 0xff) as i32 - 127;
    let level = if ratio <= 1.0 {
        0
    } else {
        exponent.clamp(0, TOP_LEVEL)
    };
    // The level's side and texels per metre are the full level's times a power of two
    // (exactly: scaling by 2^k commutes with rounding).
    let side = pow2(TOP_LEVEL - level);
    let scale_px = texels_per_m * pow2(-level);
    // The side is a power of two: masking the floored texel index wraps negatives too.
    let mask = floor_small(side).1 - 1;
    let u = floor_small(x * scale_px).1 & mask;
    let v = floor_small(y * scale_px).1 & mask;
    // Levels 0..level hold Σ 4^(TOP − k) = (4^(TOP + 1) − 4^(TOP + 1 − level)) / 3 texels,
    // an integer below 2²⁴, which the float division gives exactly.
    let start = (pow2(2 * (TOP_LEVEL + 1)) - pow2(2 * (TOP_LEVEL + 1 - level))) / 3.0;
    floor_small(start + (v as f32 * side + u as f32)).1 as usize
}

/// What the ground shows at a point: a texel of the floor's texture, of the surround's, or
/// water. [`GroundModel::texel`] finds it without a branch; [`GroundModel::albedo_of`] reads it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GroundTexel(u32);

impl GroundTexel {
    const WATER: GroundTexel = GroundTexel(u32::MAX);
    /// Marks the surround's texels.
    const SURROUND: u32 = 1 << 30;
}

/// The ground: the location's floor inside its rectangle, another material around it, and
/// water where the location has a sea or a pool.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundModel {
    /// Floor material.
    pub floor: GroundTexture,
    /// Material around the floor.
    pub surround: GroundTexture,
    /// Half size of the floor rectangle `[x, y]`, metres.
    pub floor_half_m: [f32; 2],
    /// Water rectangle `[x0, y0, x1, y1]` (sea beyond the floor's north edge, or a pool).
    pub water: Option<[f32; 4]>,
    /// Water colour (linear).
    pub water_rgb: Rgb,
}

impl GroundModel {
    /// Albedo at `(x, y)`, and whether it is water (which also mirrors the sky).
    #[inline]
    #[must_use]
    pub fn albedo(&self, x: f32, y: f32, footprint_m: f32) -> (Rgb, bool) {
        self.albedo_of(self.texel(x, y, footprint_m))
    }

    /// What [`GroundModel::albedo`] reads at `(x, y)`: the water where the point is in the
    /// water's rectangle, else the floor's texture inside the floor's, else the surround's.
    /// Without a branch (both tests are made and one texture's numbers selected), so that a
    /// loop over pixels calling it vectorises.
    #[inline]
    #[must_use]
    pub fn texel(&self, x: f32, y: f32, footprint_m: f32) -> GroundTexel {
        // No water: a rectangle nothing is in.
        let [x0, y0, x1, y1] = self.water.unwrap_or([
            f32::INFINITY,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NEG_INFINITY,
        ]);
        let water = x >= x0 && x <= x1 && y >= y0 && y <= y1;
        let floor = x.abs() <= self.floor_half_m[0] && y.abs() <= self.floor_half_m[1];
        // Both textures have the same size, so only their texels per metre differ.
        let texels_per_m = if floor {
            self.floor.texels_per_m
        } else {
            self.surround.texels_per_m
        };
        let index = texel_index(texels_per_m, x, y, footprint_m) as u32;
        let texel = if floor {
            index
        } else {
            index | GroundTexel::SURROUND
        };
        if water {
            GroundTexel::WATER
        } else {
            GroundTexel(texel)
        }
    }

    /// The albedo of `texel`, and whether it is water.
    #[inline]
    #[must_use]
    pub fn albedo_of(&self, texel: GroundTexel) -> (Rgb, bool) {
        if texel == GroundTexel::WATER {
            return (self.water_rgb, true);
        }
        let (texture, index) = if texel.0 & GroundTexel::SURROUND == 0 {
            (&self.floor, texel.0)
        } else {
            (&self.surround, texel.0 & !GroundTexel::SURROUND)
        };
        (texture.texels[index as usize], false)
    }
}

/// A scene's static world.
#[derive(Debug, Clone, PartialEq)]
pub struct World {
    /// The ground.
    pub ground: GroundModel,
    /// Props (cast shadows).
    pub props: Mesh,
    /// Backdrop (far, no shadows), or the room.
    pub backdrop: Mesh,
    /// Prop kinds drawn as plain boxes because the renderer has no shape for them.
    pub unknown_prop_kinds: Vec<String>,
}

impl World {
    /// Builds the world of `location` under `env`, its backdrop laid out by `seed`.
    #[must_use]
    pub fn build(location: &LocationInstance, env: &Environment, seed: u64) -> World {
        let (props, unknown_prop_kinds) = build_props(&location.props, seed);
        let half = [
            (location.size_m[0] / 2.0) as f32,
            (location.size_m[1] / 2.0) as f32,
        ];
        World {
            ground: GroundModel {
                floor: GroundTexture::generate(location.ground, seed, env),
                surround: GroundTexture::generate(surround_ground(location), seed ^ 1, env),
                floor_half_m: half,
                water: water_rect(location, half),
                water_rgb: srgb([0.05, 0.16, 0.24]),
            },
            props,
            backdrop: build_backdrop(location, half, seed),
            unknown_prop_kinds,
        }
    }
}

/// The props' mesh, and the sorted names of the kinds drawn as plain boxes.
fn build_props(props: &[PlacedProp], seed: u64) -> (Mesh, Vec<String>) {
    let mut mesh = Mesh::default();
    let mut unknown = Vec::new();
    for (i, p) in props.iter().enumerate() {
        let kind = PropKind::from_name(&p.kind);
        add_prop(&mut mesh, p, kind, hash2(seed, i as u64));
        if kind.is_none() && !unknown.contains(&p.kind) {
            unknown.push(p.kind.clone());
        }
    }
    unknown.sort();
    (mesh, unknown)
}

/// The material around the floor: the backdrop's (grass under hills and trees, sand by the
/// sea, concrete among buildings), the floor's own in a room.
fn surround_ground(location: &LocationInstance) -> Ground {
    match (location.ground, location.backdrop) {
        (_, Backdrop::Walls) => location.ground,
        (Ground::Grass, _) | (_, Backdrop::Hills | Backdrop::Trees) => Ground::Grass,
        (Ground::Sand, _) | (_, Backdrop::Sea) => Ground::Sand,
        (Ground::Tiles, _) | (_, Backdrop::CityBlocks) => Ground::Concrete,
        (g, Backdrop::Sky) => g,
    }
}

/// The water rectangle `[x0, y0, x1, y1]`: where staging put it ([`LocationInstance::stage`],
/// clear of the character's path), or for a location never staged the sea beyond the floor's
/// north edge (`half` is the floor's half size) or a pool north of the origin.
fn water_rect(location: &LocationInstance, half: [f32; 2]) -> Option<[f32; 4]> {
    if let Some(rect) = location.water_m {
        return Some(rect.map(|v| v as f32));
    }
    match (location.backdrop, location.has_water) {
        (Backdrop::Sea, _) => Some([-1e4, half[1], 1e4, 1e4]),
        (_, true) => Some([-4.0, 3.0, 4.0, half[1].max(8.0)]),
        _ => None,
    }
}

/// The backdrop's random draws: one stream per scene seed, in the order the backdrop asks.
struct BackdropDraws {
    seed: u64,
    drawn: u64,
}

impl BackdropDraws {
    /// The next draw in `[0, 1)`.
    fn next(&mut self) -> f32 {
        self.drawn += 1;
        unit2(self.seed ^ 0xbac, self.drawn)
    }
}

/// The backdrop around a floor of half size `half`, laid out by `seed`: which of its kind's
/// palettes (a season for hills and trees, a facade material for buildings, a wall paint for a
/// room) and how many hills, trees or buildings are drawn per scene, so that two scenes of one
/// location do not look alike.
fn build_backdrop(location: &LocationInstance, half: [f32; 2], seed: u64) -> Mesh {
    let mut backdrop = Mesh::default();
    let mut draws = BackdropDraws { seed, drawn: 0 };
    let palette = |draws: &mut BackdropDraws, n: usize| {
        let k = (draws.next() * n as f32) as usize;
        k.min(n - 1)
    };
    match location.backdrop {
        Backdrop::Hills => {
            let season = SEASONS[palette(&mut draws, SEASONS.len())];
            add_hills(&mut backdrop, &mut draws, season);
        }
        Backdrop::Trees => {
            let season = SEASONS[palette(&mut draws, SEASONS.len())];
            add_tree_line(&mut backdrop, &mut draws, half, season);
        }
        Backdrop::CityBlocks => {
            let facade = FACADES[palette(&mut draws, FACADES.len())];
            add_city_blocks(&mut backdrop, &mut draws, half, facade);
        }
        Backdrop::Walls => {
            let paint = WALL_PAINTS[palette(&mut draws, WALL_PAINTS.len())];
            add_room(&mut backdrop, &mut draws, location, half, paint);
        }
        Backdrop::Sea | Backdrop::Sky => {}
    }
    backdrop
}

/// A season's vegetation, sRGB: two ends of the hills' colours and of the tree crowns'.
#[derive(Debug, Clone, Copy)]
struct Season {
    hills: [[f32; 3]; 2],
    crowns: [[f32; 3]; 2],
}

/// Spring, summer, a dry summer and autumn.
const SEASONS: [Season; 4] = [
    Season {
        hills: [[0.3, 0.48, 0.2], [0.42, 0.52, 0.28]],
        crowns: [[0.2, 0.42, 0.14], [0.32, 0.5, 0.2]],
    },
    Season {
        hills: [[0.25, 0.38, 0.18], [0.45, 0.42, 0.3]],
        crowns: [[0.12, 0.3, 0.1], [0.22, 0.4, 0.15]],
    },
    Season {
        hills: [[0.55, 0.5, 0.32], [0.66, 0.58, 0.38]],
        crowns: [[0.3, 0.36, 0.16], [0.42, 0.42, 0.2]],
    },
    Season {
        hills: [[0.45, 0.36, 0.2], [0.55, 0.42, 0.24]],
        crowns: [[0.6, 0.3, 0.08], [0.75, 0.55, 0.15]],
    },
];

/// Buildings' facades, sRGB ends: concrete, brick, sandstone, blue glass.
const FACADES: [[[f32; 3]; 2]; 4] = [
    [[0.55, 0.53, 0.5], [0.7, 0.68, 0.64]],
    [[0.45, 0.24, 0.17], [0.6, 0.33, 0.24]],
    [[0.72, 0.62, 0.46], [0.82, 0.72, 0.55]],
    [[0.3, 0.4, 0.5], [0.42, 0.52, 0.6]],
];

/// A room's wall paints, sRGB ends: white, beige, pale blue, pale green, grey.
const WALL_PAINTS: [[[f32; 3]; 2]; 5] = [
    [[0.85, 0.84, 0.8], [0.9, 0.88, 0.85]],
    [[0.8, 0.72, 0.6], [0.85, 0.78, 0.66]],
    [[0.65, 0.74, 0.82], [0.72, 0.8, 0.86]],
    [[0.68, 0.78, 0.66], [0.74, 0.82, 0.72]],
    [[0.55, 0.56, 0.58], [0.62, 0.63, 0.64]],
];

/// Ten to eighteen hills in a ring 180–340 m out, in the season's colours.
fn add_hills(m: &mut Mesh, draws: &mut BackdropDraws, season: Season) {
    let tau = std::f32::consts::TAU;
    let at0 = Place::new([0.0, 0.0, 0.0], 0.0);
    let count = 10 + (draws.next() * 9.0) as usize;
    for k in 0..count {
        let a = tau * (k as f32 + draws.next()) / count as f32;
        let r = 180.0 + 160.0 * draws.next();
        let (w, h) = (70.0 + 80.0 * draws.next(), 25.0 + 45.0 * draws.next());
        let c = srgb(mix(season.hills[0], season.hills[1], draws.next()));
        let xy = [r * a.cos(), r * a.sin()];
        add_lathe(
            m,
            at0,
            xy,
            &[(w, -2.0), (w * 0.6, h * 0.6), (w * 0.2, h * 0.95), (0.0, h)],
            10,
            c,
        );
    }
}

/// A ring of 32 to 60 trees just beyond the floor (of half size `half`), in the season's
/// colours.
fn add_tree_line(m: &mut Mesh, draws: &mut BackdropDraws, half: [f32; 2], season: Season) {
    let tau = std::f32::consts::TAU;
    let at0 = Place::new([0.0, 0.0, 0.0], 0.0);
    let count = 32 + (draws.next() * 29.0) as usize;
    for k in 0..count {
        let a = tau * (k as f32 + 0.8 * draws.next()) / count as f32;
        let r = half[0].max(half[1]) + 8.0 + 20.0 * draws.next();
        let h = 6.0 + 8.0 * draws.next();
        let xy = [r * a.cos(), r * a.sin()];
        let bark = srgb([0.3, 0.2, 0.12]);
        cylinder(m, at0, xy, 0.25, 0.0, h * 0.4, 5, bark);
        let c = srgb(mix(season.crowns[0], season.crowns[1], draws.next()));
        let crown = [(h * 0.3, h * 0.3), (h * 0.22, h * 0.65), (0.0, h)];
        add_lathe(m, at0, xy, &crown, 7, c);
    }
}

/// A ring of 20 to 34 buildings with bands of windows beyond the floor (of half size `half`),
/// of the facade's colours.
fn add_city_blocks(m: &mut Mesh, draws: &mut BackdropDraws, half: [f32; 2], facade: [[f32; 3]; 2]) {
    let tau = std::f32::consts::TAU;
    let count = 20 + (draws.next() * 15.0) as usize;
    for k in 0..count {
        let a = tau * (k as f32 + 0.5 * draws.next()) / count as f32;
        let r = half[0].max(half[1]) + 25.0 + 40.0 * draws.next();
        let (w, d, h) = (
            14.0 + 14.0 * draws.next(),
            12.0 + 10.0 * draws.next(),
            10.0 + 50.0 * draws.next(),
        );
        let c = srgb(mix(facade[0], facade[1], draws.next()));
        let block = Place::new([r * a.cos(), r * a.sin(), 0.0], a);
        add_block(m, block, [0.0, 0.0], [d, w, h], 0.0, c);
        // A darker band of windows on every other floor group.
        let glass = scale(c, 0.45);
        let mut z = 3.0;
        while z + 2.0 < h {
            let band = [0.1, w * 0.85, 1.4];
            add_block(m, block, [-d * 0.5 - 0.05, 0.0], band, z, glass);
            z += 4.0;
        }
    }
}

/// A room's four walls (in the paint's colours), ceiling and ceiling lights around the floor
/// (of half size `half`).
fn add_room(
    m: &mut Mesh,
    draws: &mut BackdropDraws,
    location: &LocationInstance,
    half: [f32; 2],
    paint: [[f32; 3]; 2],
) {
    let at0 = Place::new([0.0, 0.0, 0.0], 0.0);
    let height = (location.size_m[0].min(location.size_m[1]) as f32 * 0.35).clamp(3.0, 9.0);
    let wall = srgb(mix(paint[0], paint[1], draws.next()));
    let (hx, hy, t) = (half[0] + 0.2, half[1] + 0.2, 0.2);
    // Four walls and a ceiling as boxes seen from inside: draw inverted boxes.
    for (lo, hi) in [
        ([-hx - t, -hy - t, 0.0], [hx + t, -hy, height]),
        ([-hx - t, hy, 0.0], [hx + t, hy + t, height]),
        ([-hx - t, -hy, 0.0], [-hx, hy, height]),
        ([hx, -hy, 0.0], [hx + t, hy, height]),
    ] {
        add_box(m, at0, lo, hi, wall);
    }
    let ceiling = ([-hx - t, -hy - t, height], [hx + t, hy + t, height + t]);
    add_box(m, at0, ceiling.0, ceiling.1, scale(wall, 0.9));
    // Ceiling lights.
    let mut x = -hx + 2.0;
    while x < hx - 1.0 {
        let (lo, hi) = ([x - 0.6, -0.15, height - 0.05], [x + 0.6, 0.15, height]);
        add_box(m, at0, lo, hi, [3.0, 3.0, 2.9]);
        x += 4.0;
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// The texel [`GroundTexture::sample`] reads, by the definition: the mip level whose
    /// texels match the footprint (⌊log2⌋ of it in full-size texels, clamped to the chain),
    /// the point's texel on that level, wrapped.
    fn texel_by_definition(texels_per_m: f32, x: f32, y: f32, footprint_m: f32) -> usize {
        let ratio = footprint_m * texels_per_m;
        let level = if ratio <= 1.0 {
            0
        } else {
            (ratio.log2().floor() as usize).min(MIP_LEVELS - 1)
        };
        let side = TEXTURE_SIZE >> level;
        let scale = texels_per_m / (1 << level) as f32;
        let wrap = |c: f32| (c * scale).floor().rem_euclid(side as f32) as usize;
        let start: usize = (0..level).map(|k| (TEXTURE_SIZE >> k).pow(2)).sum();
        start + wrap(y) * side + wrap(x)
    }

    proptest! {
        /// Over points within 10 km and footprints from 0.1 mm to 1 km, every tile size the
        /// grounds use.
        #[test]
        fn the_texel_index_is_the_definitions(
            tile in prop::sample::select(vec![1.0f32, 1.6, 2.0, 4.0]),
            x in -1.0e4f32..1.0e4,
            y in -1.0e4f32..1.0e4,
            log_footprint in -4.0f32..3.0,
        ) {
            let texels_per_m = TEXTURE_SIZE as f32 / tile;
            let footprint_m = 10f32.powf(log_footprint);
            prop_assert_eq!(
                texel_index(texels_per_m, x, y, footprint_m),
                texel_by_definition(texels_per_m, x, y, footprint_m)
            );
        }
    }

    fn closed_and_outward(m: &Mesh) {
        use std::collections::BTreeMap;
        let mut edges: BTreeMap<(u32, u32), i32> = BTreeMap::new();
        let key = |p: [f32; 3]| p.map(|v| (v * 1000.0).round() as i64);
        // Weld by position (boxes duplicate vertices per face).
        let mut ids: BTreeMap<[i64; 3], u32> = BTreeMap::new();
        let welded: Vec<u32> = m
            .positions
            .iter()
            .map(|&p| {
                let n = ids.len() as u32;
                *ids.entry(key(p)).or_insert(n)
            })
            .collect();
        let mut volume = 0.0f64;
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| welded[i as usize]);
            for (p, q) in [(a, b), (b, c), (c, a)] {
                *edges.entry((p.min(q), p.max(q))).or_default() += if p < q { 1 } else { -1 };
            }
            let [pa, pb, pc] = [t[0], t[1], t[2]].map(|i| m.positions[i as usize].map(f64::from));
            volume += pa[0] * (pb[1] * pc[2] - pb[2] * pc[1])
                - pa[1] * (pb[0] * pc[2] - pb[2] * pc[0])
                + pa[2] * (pb[0] * pc[1] - pb[1] * pc[0]);
        }
        assert!(
            edges.values().all(|&v| v == 0),
            "every edge is used once each way"
        );
        assert!(
            volume > 0.0,
            "outward winding gives a positive volume: {volume}"
        );
    }

    #[test]
    fn boxes_and_lathes_are_closed_and_wound_outward() {
        let mut m = Mesh::default();
        add_box(
            &mut m,
            Place::new([1.0, 2.0, 0.0], 0.7),
            [-0.5, -0.2, 0.0],
            [0.5, 0.2, 1.0],
            [0.5; 3],
        );
        closed_and_outward(&m);
        let mut m = Mesh::default();
        cylinder(
            &mut m,
            Place::new([0.0, 0.0, 0.0], 0.0),
            [0.0, 0.0],
            0.5,
            0.0,
            2.0,
            8,
            [0.5; 3],
        );
        closed_and_outward(&m);
        let mut m = Mesh::default();
        add_lathe(
            &mut m,
            Place::new([0.0, 0.0, 0.0], 0.0),
            [0.0, 0.0],
            &[(0.0, 0.0), (1.0, 1.0), (0.0, 2.0)],
            8,
            [0.5; 3],
        );
        closed_and_outward(&m);
    }

    #[test]
    fn every_builtin_prop_kind_has_a_shape_inside_its_box() {
        for kind in PropKind::ALL {
            let prop = PlacedProp {
                kind: kind.name().into(),
                position_m: [3.0, -2.0, 0.0],
                yaw_deg: 30.0,
                size_m: [1.2, 0.8, 1.5],
            };
            let mut m = Mesh::default();
            assert_eq!(PropKind::from_name(&prop.kind), Some(kind));
            add_prop(&mut m, &prop, Some(kind), 5);
            assert!(m.triangle_count() > 0);
            // Within the yawed box's circumscribed circle and height (small slack for wheels).
            let r = 0.5 * (1.2f32.hypot(0.8)) + 0.15;
            for p in &m.positions {
                assert!((p[0] - 3.0).hypot(p[1] + 2.0) <= r, "{kind:?}: {p:?}");
                assert!(p[2] >= -0.01 && p[2] <= 1.5 + 0.01, "{kind:?}: {p:?}");
            }
        }
        let mut m = Mesh::default();
        let odd = PlacedProp {
            kind: "spaceship".into(),
            position_m: [0.0; 3],
            yaw_deg: 0.0,
            size_m: [1.0; 3],
        };
        assert_eq!(PropKind::from_name(&odd.kind), None);
        add_prop(&mut m, &odd, None, 0);
        assert_eq!(m.triangle_count(), 12);
    }

    #[test]
    fn prop_kind_names_are_sorted_unique_and_parse_back() {
        let names: Vec<&str> = PropKind::ALL.iter().map(|k| k.name()).collect();
        assert!(names.windows(2).all(|w| w[0] < w[1]), "{names:?}");
        for kind in PropKind::ALL {
            assert_eq!(PropKind::from_name(kind.name()), Some(kind));
        }
        assert_eq!(PropKind::from_name("Tree"), None);
    }

    #[test]
    fn unknown_prop_kinds_are_drawn_as_boxes_and_listed_once_sorted() {
        let prop = |kind: &str| PlacedProp {
            kind: kind.into(),
            position_m: [0.0; 3],
            yaw_deg: 0.0,
            size_m: [1.0; 3],
        };
        let props = [
            prop("zeppelin"),
            prop("tree"),
            prop("anvil"),
            prop("zeppelin"),
        ];
        let (mesh, unknown) = build_props(&props, 9);
        assert_eq!(unknown, ["anvil", "zeppelin"]);
        let mut tree = Mesh::default();
        add_prop(&mut tree, &props[1], Some(PropKind::Tree), 0);
        assert_eq!(
            mesh.triangle_count(),
            3 * 12 + tree.triangle_count(),
            "three boxes and a tree"
        );
    }

    #[test]
    fn distant_ground_fades_to_the_texture_average() {
        let env = Environment::from_scene(
            &crate::scene::tests::test_scene(
                crate::scene::weather::Weather::Clear,
                crate::scene::sky::ClockTime::NOON,
            ),
            3,
        );
        let t = GroundTexture::generate(Ground::Tiles, 3, &env);
        let avg = *t.texels.last().expect("1×1 level");
        let far = t.sample(0.37, 1.91, 100.0);
        assert_eq!(far, avg);
        // Near: texels differ (grout vs tile).
        let near: Vec<Rgb> = (0..64)
            .map(|i| t.sample(i as f32 * 0.013, 0.2, 0.001))
            .collect();
        assert!(near.iter().any(|c| (c[0] - near[0][0]).abs() > 0.05));
    }
}
