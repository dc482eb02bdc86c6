//! The static world of a scene: the ground's materials as tiled, mip-mapped textures, the props
//! the location placed, and the backdrop around the floor (hills, a tree line, city blocks, the
//! sea, or a room's walls and ceiling). Built once per scene from its
//! [`LocationInstance`] and [`Environment`]; the layout of the backdrop comes from the scene's
//! seed, so two scenes at one location differ.
//!
//! Props are drawn from their kind's name (the built-in pool's `tree`, `car`, `bench`, …) inside
//! their placed bounding box; a kind the renderer does not know is drawn as a box of that size
//! (never skipped), and [`World::unknown_prop_kinds`] lists them so the caller can say so.

use crate::hash::{hash2, unit2};
use crate::scene::color::{Rgb, linear_from_srgb, mix, scale};
use crate::scene::environment::Environment;
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

/// Kinds [`add_prop`] draws with a shape of their own.
pub const KNOWN_PROP_KINDS: [&str; 25] = [
    "ball_basket",
    "beach_towel",
    "bench",
    "cabinet",
    "car",
    "cooler",
    "crate",
    "desk",
    "dumbbell_rack",
    "exercise_mat",
    "flagstick",
    "forklift",
    "golf_cart",
    "lamp_post",
    "office_chair",
    "pallet",
    "parasol",
    "plant",
    "rock",
    "sun_lounger",
    "trash_bin",
    "tree",
    "treadmill",
    "umpire_chair",
    "weight_bench",
];

/// Draws one placed prop into `m`; returns whether its kind is known (else a plain box).
fn add_prop(m: &mut Mesh, prop: &PlacedProp, variety: u64) -> bool {
    let [sx, sy, sz] = prop.size_m.map(|v| v as f32);
    let at = Place::new(
        [prop.position_m[0] as f32, prop.position_m[1] as f32, 0.0],
        (prop.yaw_deg as f32).to_radians(),
    );
    let pick = |palette: &[[f32; 3]]| srgb(palette[(variety % palette.len() as u64) as usize]);
    let (hx, hy) = (sx / 2.0, sy / 2.0);
    let metal = srgb([0.55, 0.57, 0.6]);
    let dark = srgb([0.08, 0.08, 0.09]);
    let wood = srgb([0.5, 0.34, 0.2]);
    match prop.kind.as_str() {
        "tree" => {
            let trunk_h = sz * 0.35;
            cylinder(
                m,
                at,
                [0.0, 0.0],
                sx * 0.07,
                0.0,
                trunk_h + 0.3,
                6,
                srgb([0.33, 0.22, 0.13]),
            );
            let leaf = pick(&[[0.2, 0.42, 0.15], [0.16, 0.36, 0.14], [0.26, 0.45, 0.18]]);
            add_lathe(
                m,
                at,
                [0.0, 0.0],
                &[
                    (0.0, trunk_h * 0.9),
                    (hx * 0.95, trunk_h + 0.2 * sz),
                    (hx * 0.75, trunk_h + 0.45 * sz),
                    (0.0, sz),
                ],
                8,
                leaf,
            );
        }
        "rock" => add_lathe(
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
            pick(&[[0.45, 0.44, 0.42], [0.38, 0.36, 0.33]]),
        ),
        "bench" | "weight_bench" => {
            let seat = if prop.kind == "bench" { wood } else { dark };
            add_block(m, at, [0.0, 0.0], [sx, sy * 0.9, 0.06], sz * 0.48, seat);
            if prop.kind == "bench" {
                add_block(
                    m,
                    at,
                    [0.0, hy * 0.8],
                    [sx, 0.05, sz * 0.45],
                    sz * 0.55,
                    seat,
                );
            }
            for x in [-hx * 0.8, hx * 0.8] {
                add_block(m, at, [x, 0.0], [0.06, sy * 0.8, sz * 0.48], 0.0, metal);
            }
        }
        "car" | "golf_cart" => {
            let body = pick(&[
                [0.7, 0.08, 0.07],
                [0.9, 0.9, 0.92],
                [0.1, 0.12, 0.2],
                [0.5, 0.52, 0.55],
                [0.1, 0.1, 0.1],
                [0.15, 0.3, 0.6],
            ]);
            let wheel_r = sz * 0.22;
            add_block(m, at, [0.0, 0.0], [sx, sy, sz * 0.42], wheel_r * 0.8, body);
            let glass = srgb([0.12, 0.16, 0.2]);
            let cabin_len = if prop.kind == "car" {
                sx * 0.5
            } else {
                sx * 0.6
            };
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
                let wheel = Place::new(
                    at.point([x, y, wheel_r]),
                    (prop.yaw_deg as f32).to_radians(),
                );
                // A wheel: a short cylinder about the local y axis, drawn as an 8-sided block.
                add_block(
                    m,
                    wheel,
                    [0.0, 0.0],
                    [wheel_r * 1.8, 0.2, wheel_r * 1.8],
                    -wheel_r * 0.9,
                    dark,
                );
            }
        }
        "lamp_post" | "flagstick" => {
            cylinder(m, at, [0.0, 0.0], hx.min(0.08), 0.0, sz, 6, metal);
            if prop.kind == "lamp_post" {
                add_block(
                    m,
                    at,
                    [0.0, 0.0],
                    [0.5, 0.25, 0.15],
                    sz - 0.15,
                    srgb([0.95, 0.92, 0.8]),
                );
            } else {
                add_block(
                    m,
                    at,
                    [0.25, 0.0],
                    [0.5, 0.02, 0.35],
                    sz - 0.4,
                    srgb([0.9, 0.1, 0.1]),
                );
            }
        }
        "parasol" => {
            cylinder(m, at, [0.0, 0.0], 0.03, 0.0, sz, 6, srgb([0.9, 0.9, 0.88]));
            let canopy = pick(&[
                [0.9, 0.3, 0.2],
                [0.95, 0.85, 0.3],
                [0.2, 0.5, 0.8],
                [0.95, 0.95, 0.95],
            ]);
            add_lathe(
                m,
                at,
                [0.0, 0.0],
                &[(hx, sz * 0.8), (hx * 0.5, sz * 0.92), (0.0, sz)],
                8,
                canopy,
            );
        }
        "plant" => {
            cylinder(
                m,
                at,
                [0.0, 0.0],
                hx * 0.6,
                0.0,
                sz * 0.3,
                8,
                srgb([0.6, 0.35, 0.25]),
            );
            add_lathe(
                m,
                at,
                [0.0, 0.0],
                &[
                    (0.0, sz * 0.3),
                    (hx, sz * 0.6),
                    (hx * 0.6, sz * 0.9),
                    (0.0, sz),
                ],
                7,
                srgb([0.18, 0.45, 0.16]),
            );
        }
        "trash_bin" | "ball_basket" | "cooler" => {
            let c = match prop.kind.as_str() {
                "trash_bin" => srgb([0.2, 0.35, 0.25]),
                "cooler" => pick(&[[0.2, 0.4, 0.8], [0.85, 0.2, 0.2]]),
                _ => srgb([0.8, 0.85, 0.2]),
            };
            if prop.kind == "cooler" {
                add_block(m, at, [0.0, 0.0], [sx, sy, sz], 0.0, c);
            } else {
                cylinder(m, at, [0.0, 0.0], hx.min(hy), 0.0, sz, 10, c);
            }
        }
        "desk" => {
            add_block(m, at, [0.0, 0.0], [sx, sy, 0.04], sz - 0.04, wood);
            for (x, y) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
                add_block(
                    m,
                    at,
                    [x * (hx - 0.05), y * (hy - 0.05)],
                    [0.05, 0.05, sz - 0.04],
                    0.0,
                    metal,
                );
            }
        }
        "office_chair" | "umpire_chair" => {
            let seat_z = sz
                * if prop.kind == "umpire_chair" {
                    0.7
                } else {
                    0.42
                };
            let c = pick(&[[0.12, 0.12, 0.14], [0.2, 0.25, 0.4], [0.35, 0.2, 0.15]]);
            cylinder(m, at, [0.0, 0.0], 0.04, 0.0, seat_z, 6, metal);
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
        "cabinet" | "crate" | "dumbbell_rack" | "treadmill" | "forklift" => {
            let c = match prop.kind.as_str() {
                "cabinet" => pick(&[[0.6, 0.6, 0.62], [0.35, 0.3, 0.25]]),
                "crate" => srgb([0.62, 0.45, 0.25]),
                "forklift" => srgb([0.95, 0.7, 0.1]),
                _ => dark,
            };
            if prop.kind == "forklift" {
                add_block(m, at, [-sx * 0.1, 0.0], [sx * 0.7, sy, sz * 0.5], 0.1, c);
                add_block(m, at, [hx * 0.75, 0.0], [0.1, sy * 0.8, sz], 0.0, dark);
            } else if prop.kind == "treadmill" {
                add_block(m, at, [0.0, 0.0], [sx, sy, 0.2], 0.0, dark);
                add_block(m, at, [hx * 0.85, 0.0], [0.08, sy, sz], 0.0, metal);
            } else {
                add_block(m, at, [0.0, 0.0], [sx, sy, sz], 0.0, c);
            }
        }
        "pallet" | "beach_towel" | "exercise_mat" | "sun_lounger" => {
            let c = match prop.kind.as_str() {
                "pallet" => srgb([0.6, 0.48, 0.3]),
                "sun_lounger" => srgb([0.92, 0.92, 0.9]),
                _ => pick(&[
                    [0.2, 0.6, 0.8],
                    [0.9, 0.4, 0.5],
                    [0.3, 0.7, 0.3],
                    [0.6, 0.3, 0.7],
                ]),
            };
            add_block(m, at, [0.0, 0.0], [sx, sy, sz.max(0.01)], 0.0, c);
        }
        _ => {
            add_block(m, at, [0.0, 0.0], [sx, sy, sz], 0.0, srgb([0.6, 0.6, 0.6]));
            return false;
        }
    }
    true
}

/// Side of the ground texture tile, texels.
const TEXTURE_SIZE: usize = 128;

/// A square ground texture tiled over the plane, with its mip chain (each level half the
/// previous, down to 1×1: the pattern's average, which distant ground fades to).
#[derive(Debug, Clone, PartialEq)]
pub struct GroundTexture {
    /// Metres covered by one tile.
    pub tile_m: f32,
    /// Levels, largest first; level `k` is `(TEXTURE_SIZE >> k)²` texels, row-major.
    levels: Vec<Vec<Rgb>>,
}

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
                let mut c = scale(base, f);
                // Snow lies in patches that grow with the cover; wet ground is darker.
                let patch = unit2(seed ^ 0xa11, ((y / 16) * n + x / 16) as u64) * 0.6 + 0.4 * r;
                if patch < env.snow_cover {
                    c = mix(c, srgb([0.92, 0.93, 0.96]), 0.9);
                }
                c = scale(c, 1.0 - 0.45 * env.wetness);
                texels[y * n + x] = c;
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
        GroundTexture { tile_m, levels }
    }

    /// The colour at ground point `(x, y)` seen with a pixel footprint of `footprint_m` metres:
    /// the mip level whose texels are about that size (nearest texel), so distant ground does
    /// not shimmer.
    #[inline]
    #[must_use]
    pub fn sample(&self, x: f32, y: f32, footprint_m: f32) -> Rgb {
        let texel_m = self.tile_m / TEXTURE_SIZE as f32;
        let ratio = footprint_m / texel_m;
        let level = if ratio <= 1.0 {
            0
        } else {
            // ⌊log2(ratio)⌋ from the float's exponent.
            (((ratio.to_bits() >> 23) & 0xff) as i32 - 127).clamp(0, 7) as usize
        };
        let level = level.min(self.levels.len() - 1);
        let size = TEXTURE_SIZE >> level;
        let scale_px = size as f32 / self.tile_m;
        // `size` is a power of two: masking the floored texel index wraps negatives too.
        let mask = size as i32 - 1;
        let u = (fast_floor(x * scale_px) & mask) as usize;
        let v = (fast_floor(y * scale_px) & mask) as usize;
        self.levels[level][v * size + u]
    }
}

/// `⌊v⌋` as an integer, without a libm call (values beyond ±2³¹ saturate).
#[inline]
fn fast_floor(v: f32) -> i32 {
    let i = v as i32;
    if v < i as f32 { i - 1 } else { i }
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
        if let Some([x0, y0, x1, y1]) = self.water
            && x >= x0
            && x <= x1
            && y >= y0
            && y <= y1
        {
            return (self.water_rgb, true);
        }
        if x.abs() <= self.floor_half_m[0] && y.abs() <= self.floor_half_m[1] {
            (self.floor.sample(x, y, footprint_m), false)
        } else {
            (self.surround.sample(x, y, footprint_m), false)
        }
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
        let mut props = Mesh::default();
        let mut unknown = Vec::new();
        for (i, p) in location.props.iter().enumerate() {
            if !add_prop(&mut props, p, hash2(seed, i as u64)) && !unknown.contains(&p.kind) {
                unknown.push(p.kind.clone());
            }
        }
        unknown.sort();
        let half = [
            (location.size_m[0] / 2.0) as f32,
            (location.size_m[1] / 2.0) as f32,
        ];
        let surround_ground = match (location.ground, location.backdrop) {
            (_, Backdrop::Walls) => location.ground,
            (Ground::Grass, _) | (_, Backdrop::Hills | Backdrop::Trees) => Ground::Grass,
            (Ground::Sand, _) | (_, Backdrop::Sea) => Ground::Sand,
            (Ground::Tiles, _) => Ground::Concrete,
            (_, Backdrop::CityBlocks) => Ground::Concrete,
            (g, Backdrop::Sky) => g,
        };
        let water = match (location.backdrop, location.has_water) {
            (Backdrop::Sea, _) => Some([-1e4, half[1], 1e4, 1e4]),
            (_, true) => Some([-4.0, 3.0, 4.0, half[1].max(8.0)]),
            _ => None,
        };
        let mut backdrop = Mesh::default();
        let mut rng_i = 0u64;
        let mut next = || {
            rng_i += 1;
            unit2(seed ^ 0xbac, rng_i)
        };
        let tau = std::f32::consts::TAU;
        let at0 = Place::new([0.0, 0.0, 0.0], 0.0);
        match location.backdrop {
            Backdrop::Hills => {
                for k in 0..14 {
                    let a = tau * (k as f32 + next()) / 14.0;
                    let r = 180.0 + 160.0 * next();
                    let (w, h) = (70.0 + 80.0 * next(), 25.0 + 45.0 * next());
                    let c = srgb(mix([0.25, 0.38, 0.18], [0.45, 0.42, 0.3], next()));
                    let xy = [r * a.cos(), r * a.sin()];
                    add_lathe(
                        &mut backdrop,
                        at0,
                        xy,
                        &[(w, -2.0), (w * 0.6, h * 0.6), (w * 0.2, h * 0.95), (0.0, h)],
                        10,
                        c,
                    );
                }
            }
            Backdrop::Trees => {
                for k in 0..48 {
                    let a = tau * (k as f32 + 0.8 * next()) / 48.0;
                    let r = half[0].max(half[1]) + 8.0 + 20.0 * next();
                    let h = 6.0 + 8.0 * next();
                    let xy = [r * a.cos(), r * a.sin()];
                    cylinder(
                        &mut backdrop,
                        at0,
                        xy,
                        0.25,
                        0.0,
                        h * 0.4,
                        5,
                        srgb([0.3, 0.2, 0.12]),
                    );
                    let c = srgb(mix([0.12, 0.3, 0.1], [0.22, 0.4, 0.15], next()));
                    add_lathe(
                        &mut backdrop,
                        at0,
                        xy,
                        &[(h * 0.3, h * 0.3), (h * 0.22, h * 0.65), (0.0, h)],
                        7,
                        c,
                    );
                }
            }
            Backdrop::CityBlocks => {
                for k in 0..28 {
                    let a = tau * (k as f32 + 0.5 * next()) / 28.0;
                    let r = half[0].max(half[1]) + 25.0 + 40.0 * next();
                    let (w, d, h) = (
                        14.0 + 14.0 * next(),
                        12.0 + 10.0 * next(),
                        10.0 + 50.0 * next(),
                    );
                    let c = srgb(mix([0.55, 0.53, 0.5], [0.7, 0.62, 0.52], next()));
                    let block = Place::new([r * a.cos(), r * a.sin(), 0.0], a);
                    add_block(&mut backdrop, block, [0.0, 0.0], [d, w, h], 0.0, c);
                    // A darker band of windows on every other floor group.
                    let glass = scale(c, 0.45);
                    let mut z = 3.0;
                    while z + 2.0 < h {
                        add_block(
                            &mut backdrop,
                            block,
                            [-d * 0.5 - 0.05, 0.0],
                            [0.1, w * 0.85, 1.4],
                            z,
                            glass,
                        );
                        z += 4.0;
                    }
                }
            }
            Backdrop::Walls => {
                let height =
                    (location.size_m[0].min(location.size_m[1]) as f32 * 0.35).clamp(3.0, 9.0);
                let wall = srgb(mix([0.82, 0.8, 0.76], [0.7, 0.74, 0.78], next()));
                let (hx, hy, t) = (half[0] + 0.2, half[1] + 0.2, 0.2);
                // Four walls and a ceiling as boxes seen from inside: draw inverted boxes.
                for (lo, hi) in [
                    ([-hx - t, -hy - t, 0.0], [hx + t, -hy, height]),
                    ([-hx - t, hy, 0.0], [hx + t, hy + t, height]),
                    ([-hx - t, -hy, 0.0], [-hx, hy, height]),
                    ([hx, -hy, 0.0], [hx + t, hy, height]),
                ] {
                    add_box(&mut backdrop, at0, lo, hi, wall);
                }
                add_box(
                    &mut backdrop,
                    at0,
                    [-hx - t, -hy - t, height],
                    [hx + t, hy + t, height + t],
                    scale(wall, 0.9),
                );
                // Ceiling lights.
                let mut x = -hx + 2.0;
                while x < hx - 1.0 {
                    add_box(
                        &mut backdrop,
                        at0,
                        [x - 0.6, -0.15, height - 0.05],
                        [x + 0.6, 0.15, height],
                        [3.0, 3.0, 2.9],
                    );
                    x += 4.0;
                }
            }
            Backdrop::Sea | Backdrop::Sky => {}
        }
        World {
            ground: GroundModel {
                floor: GroundTexture::generate(location.ground, seed, env),
                surround: GroundTexture::generate(surround_ground, seed ^ 1, env),
                floor_half_m: half,
                water,
                water_rgb: srgb([0.05, 0.16, 0.24]),
            },
            props,
            backdrop,
            unknown_prop_kinds: unknown,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        for kind in KNOWN_PROP_KINDS {
            let prop = PlacedProp {
                kind: kind.into(),
                position_m: [3.0, -2.0, 0.0],
                yaw_deg: 30.0,
                size_m: [1.2, 0.8, 1.5],
            };
            let mut m = Mesh::default();
            assert!(add_prop(&mut m, &prop, 5), "{kind}");
            assert!(m.triangle_count() > 0);
            // Within the yawed box's circumscribed circle and height (small slack for wheels).
            let r = 0.5 * (1.2f32.hypot(0.8)) + 0.15;
            for p in &m.positions {
                assert!((p[0] - 3.0).hypot(p[1] + 2.0) <= r, "{kind}: {p:?}");
                assert!(p[2] >= -0.01 && p[2] <= 1.5 + 0.01, "{kind}: {p:?}");
            }
        }
        let mut m = Mesh::default();
        let odd = PlacedProp {
            kind: "spaceship".into(),
            position_m: [0.0; 3],
            yaw_deg: 0.0,
            size_m: [1.0; 3],
        };
        assert!(!add_prop(&mut m, &odd, 0));
        assert_eq!(m.triangle_count(), 12);
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
        let avg = *t.levels.last().and_then(|l| l.first()).expect("1×1 level");
        let far = t.sample(0.37, 1.91, 100.0);
        assert_eq!(far, avg);
        // Near: texels differ (grout vs tile).
        let near: Vec<Rgb> = (0..64)
            .map(|i| t.sample(i as f32 * 0.013, 0.2, 0.001))
            .collect();
        assert!(near.iter().any(|c| (c[0] - near[0][0]).abs() > 0.05));
    }
}
