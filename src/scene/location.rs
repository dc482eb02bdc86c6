//! Locations: where an action is shown — a floor of a given size and ground, a backdrop, and
//! props scattered around the character, who performs at the floor's origin.
//!
//! The paper teleports its character among GTA V sites (open field, tennis court, golf course,
//! office; beach, pool, parking lot, gym and more commented out) and shows actions only where
//! they fit ("diving" only in water). Here a [`Location`] is a small description a renderer can
//! build a set from, and an action names what it needs with [`Location::suits`]. Users define
//! their own locations in the dataset spec (TOML) with the same field names as the struct, e.g.
//! as entries of [`super::SceneConfig::locations`]:
//!
//! ```toml
//! [[scene.locations]]
//! name = "rooftop"          # unique, snake_case
//! indoor = false            # default false
//! ground = "concrete"       # grass | asphalt | concrete | sand | wood | tiles | carpet | rubber | dirt | water
//! size_m = [20.0, 15.0]     # usable floor, x (east) × y (north), metres, centred on the character
//! has_water = false         # default false: water the action can use at the spot (pool, sea)
//! backdrop = "city_blocks"  # sky | hills | trees | city_blocks | sea | walls
//! tags = ["urban", "open_space"]
//! props = [ { kind = "vent", count = [1, 3], size_m = [1.0, 1.0, 1.2] } ]
//! ```
//!
//! A prop's `count` is an inclusive range `[min, max]`; its `size_m` is its bounding box
//! `[x, y, z]` (width, depth, height) in metres before its random yaw.
//!
//! Frame: x east, y north, z up, metres; the floor is the rectangle `|x| ≤ size_m[0]/2`,
//! `|y| ≤ size_m[1]/2` at z = 0; yaw is degrees counter-clockwise about +z.

use serde::{Deserialize, Serialize};

use super::SceneError;
use rand::{Rng, RngExt};

/// What the floor is made of (sets the ground material).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Ground {
    /// Lawn or meadow.
    Grass,
    /// Road, car park, hard court.
    Asphalt,
    /// Pavement, plaza, warehouse floor.
    Concrete,
    /// Beach, desert.
    Sand,
    /// Floorboards, deck, pier.
    Wood,
    /// Tiled floor, pool deck.
    Tiles,
    /// Office or home carpet.
    Carpet,
    /// Gym or playground rubber.
    Rubber,
    /// Bare earth, gravel, building site.
    Dirt,
    /// Shallow water the character stands in.
    Water,
}

/// What surrounds the floor, seen behind the character.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Backdrop {
    /// An open horizon.
    Sky,
    /// Hills or mountains.
    Hills,
    /// A tree line or forest.
    Trees,
    /// Buildings.
    CityBlocks,
    /// The sea.
    Sea,
    /// A room's walls (indoors).
    Walls,
}

/// A kind of prop a location may hold, and how many.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PropSpec {
    /// What it is (`"bench"`, `"car"`): the renderer's asset name.
    pub kind: String,
    /// How many, an inclusive range `[min, max]`.
    pub count: [u32; 2],
    /// Bounding box before yaw, `[x, y, z]` metres.
    pub size_m: [f64; 3],
}

/// A place an action can be shown in.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Location {
    /// Unique name, snake_case.
    pub name: String,
    /// Whether it is inside a building.
    #[serde(default)]
    pub indoor: bool,
    /// The floor's material.
    pub ground: Ground,
    /// Usable floor `[x, y]`, metres, centred on the character.
    pub size_m: [f64; 2],
    /// Whether there is water the action can use at the spot (a pool, the sea's edge).
    #[serde(default)]
    pub has_water: bool,
    /// What is seen around the floor.
    pub backdrop: Backdrop,
    /// Props to scatter.
    #[serde(default)]
    pub props: Vec<PropSpec>,
    /// Free tags an action can require (see [`Location::suits`]).
    #[serde(default)]
    pub tags: Vec<String>,
}

/// One placed prop.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlacedProp {
    /// Its kind (from its [`PropSpec`]).
    pub kind: String,
    /// Centre of its footprint on the floor, `[x, y, 0]`, metres.
    pub position_m: [f64; 3],
    /// Rotation about +z, degrees counter-clockwise, in [0, 360).
    pub yaw_deg: f64,
    /// Bounding box before yaw, `[x, y, z]` metres.
    pub size_m: [f64; 3],
}

/// One draw of a location: its description and where its props went.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LocationInstance {
    /// The location's name.
    pub name: String,
    /// Whether it is inside.
    pub indoor: bool,
    /// The floor's material.
    pub ground: Ground,
    /// Usable floor `[x, y]`, metres, centred on the character.
    pub size_m: [f64; 2],
    /// Whether there is usable water.
    pub has_water: bool,
    /// What is seen around the floor.
    pub backdrop: Backdrop,
    /// The placed props.
    pub props: Vec<PlacedProp>,
    /// How many props the draw asked for (the sum of the drawn counts).
    pub props_requested: u32,
    /// How many of those found no free spot and were left out.
    pub props_not_placed: u32,
    /// The radius kept free around the character, metres.
    pub clear_radius_m: f64,
    /// The water's rectangle `[x0, y0, x1, y1]`, metres, once staged
    /// ([`LocationInstance::stage`]): the sea beyond the floor's north edge or a pool, always
    /// clear of the character's path; `None` for a location without water, or one not staged
    /// (a renderer then puts a pool north of the origin, or the sea beyond the floor).
    #[serde(default)]
    pub water_m: Option<[f64; 4]>,
}

/// A staged character's body radius on the ground, metres: the water keeps this far from every
/// point of its path.
pub const BODY_RADIUS_M: f64 = 0.6;
/// Half width of the corridor from a camera to the character that props keep out of, metres.
pub const SIGHT_RADIUS_M: f64 = 0.6;
/// Props no higher than this (towels, mats) neither block a view nor a walk, metres.
pub const FLAT_PROP_M: f64 = 0.05;
/// A staged pool's size `[x, y]`, metres.
pub const POOL_SIZE_M: [f64; 2] = [8.0, 5.0];

/// Distance from `p` to the segment `a`–`b` (2-D).
#[must_use]
pub fn distance_to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let e = [b[0] - a[0], b[1] - a[1]];
    let len2 = e[0] * e[0] + e[1] * e[1];
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * e[0] + (p[1] - a[1]) * e[1]) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * e[0]).hypot(p[1] - a[1] - t * e[1])
}

/// Distance from `p` to the rectangle `[x0, y0, x1, y1]` (0 inside).
#[must_use]
pub fn distance_to_rect(p: [f64; 2], r: [f64; 4]) -> f64 {
    let dx = (r[0] - p[0]).max(p[0] - r[2]).max(0.0);
    let dy = (r[1] - p[1]).max(p[1] - r[3]).max(0.0);
    dx.hypot(dy)
}

/// What a staged scene must keep clear: the character's ground path and the lines from the
/// cameras to it, metres, world frame.
#[derive(Debug, Clone, Copy)]
pub struct Staging<'a> {
    /// The character's ground point, frame by frame.
    pub path_xy_m: &'a [[f64; 2]],
    /// Per camera frame: the camera's ground point and the character's at that frame.
    pub sight_lines_m: &'a [[[f64; 2]; 2]],
}

impl Staging<'_> {
    /// Whether a prop's footprint circle (centre `c`, radius `r`) stays `clear` from the path
    /// and [`SIGHT_RADIUS_M`] from every line of sight.
    #[must_use]
    pub fn prop_is_clear(&self, c: [f64; 2], r: f64, clear: f64) -> bool {
        self.path_xy_m
            .iter()
            .all(|p| (p[0] - c[0]).hypot(p[1] - c[1]) >= r + clear)
            && self
                .sight_lines_m
                .iter()
                .all(|[a, b]| distance_to_segment(c, *a, *b) >= r + SIGHT_RADIUS_M)
    }

    /// Whether the rectangle `rect` stays [`BODY_RADIUS_M`] from every point of the path.
    #[must_use]
    pub fn water_is_clear(&self, rect: [f64; 4]) -> bool {
        self.path_xy_m
            .iter()
            .all(|&p| distance_to_rect(p, rect) >= BODY_RADIUS_M)
    }
}

impl LocationInstance {
    /// Stages the drawn location around what the character and the cameras do: the floor grows
    /// to hold the path and every camera (so walls and backdrops stay behind them), the water
    /// (the sea's shore or a [`POOL_SIZE_M`] pool) is placed clear of the path, and every prop
    /// whose footprint circle comes within the clear radius of the path, within
    /// [`SIGHT_RADIUS_M`] of a line from a camera to the character, or over the water is moved
    /// to a spot clear of all of them (or left out and counted in `props_not_placed` after
    /// [`PLACEMENT_ATTEMPTS`] tries). Flat props (≤ [`FLAT_PROP_M`]) stay where they are unless
    /// over the water. `rng` draws the new spots.
    pub fn stage(&mut self, staging: &Staging<'_>, rng: &mut (impl Rng + ?Sized)) {
        if !self.size_m.iter().all(|s| s.is_finite() && *s > 0.0) {
            return;
        }
        let mut half = [self.size_m[0] / 2.0, self.size_m[1] / 2.0];
        let cameras = staging.sight_lines_m.iter().map(|l| (l[0], 1.0));
        let path = staging.path_xy_m.iter().map(|&p| (p, BODY_RADIUS_M + 1.0));
        for (p, margin) in path.chain(cameras) {
            if p.iter().all(|v| v.is_finite()) {
                half[0] = half[0].max(p[0].abs() + margin);
                half[1] = half[1].max(p[1].abs() + margin);
            }
        }
        self.size_m = [2.0 * half[0], 2.0 * half[1]];
        self.water_m = match (self.backdrop, self.has_water) {
            (Backdrop::Sea, _) => Some([-1e4, half[1], 1e4, 1e4]),
            (_, true) => Some(place_pool(staging, half, rng)),
            _ => None,
        };
        let clear = self.clear_radius_m;
        let water = self.water_m;
        let dry = |c: [f64; 2], r: f64| water.is_none_or(|w| distance_to_rect(c, w) >= r);
        let ok = |p: &PlacedProp, c: [f64; 2]| {
            let r = 0.5 * p.size_m[0].hypot(p.size_m[1]);
            dry(c, r) && (p.size_m[2] <= FLAT_PROP_M || staging.prop_is_clear(c, r, clear))
        };
        let mut kept: Vec<(PlacedProp, f64)> = Vec::new();
        for prop in std::mem::take(&mut self.props) {
            let r = 0.5 * prop.size_m[0].hypot(prop.size_m[1]);
            let here = [prop.position_m[0], prop.position_m[1]];
            let free = |c: [f64; 2], kept: &[(PlacedProp, f64)]| {
                kept.iter()
                    .all(|(q, rq)| (q.position_m[0] - c[0]).hypot(q.position_m[1] - c[1]) >= r + rq)
            };
            if ok(&prop, here) && free(here, &kept) {
                kept.push((prop, r));
                continue;
            }
            let spot = (0..PLACEMENT_ATTEMPTS).find_map(|_| {
                try_spot(rng, prop.size_m, half, r, clear, &kept)
                    .filter(|(c, _)| ok(&prop, [c[0], c[1]]))
            });
            match spot {
                Some((position_m, yaw_deg)) => kept.push((
                    PlacedProp {
                        position_m,
                        yaw_deg,
                        ..prop
                    },
                    r,
                )),
                None => self.props_not_placed = self.props_not_placed.saturating_add(1),
            }
        }
        self.props = kept.into_iter().map(|(p, _)| p).collect();
    }
}

/// A pool's rectangle on a floor of half size `half`, clear of the path: a random spot on the
/// floor where it fits, or else just north of the path's farthest point north.
fn place_pool(staging: &Staging<'_>, half: [f64; 2], rng: &mut (impl Rng + ?Sized)) -> [f64; 4] {
    let [w, h] = POOL_SIZE_M;
    let room = [half[0] - w / 2.0, half[1] - h / 2.0];
    if room[0] >= 0.0 && room[1] >= 0.0 {
        for _ in 0..PLACEMENT_ATTEMPTS {
            let x = rng.random_range(-room[0]..=room[0]);
            let y = rng.random_range(-room[1]..=room[1]);
            let rect = [x - w / 2.0, y - h / 2.0, x + w / 2.0, y + h / 2.0];
            if staging.water_is_clear(rect) {
                return rect;
            }
        }
    }
    let north = staging
        .path_xy_m
        .iter()
        .map(|p| p[1])
        .filter(|y| y.is_finite())
        .fold(0.0, f64::max);
    let y0 = north + BODY_RADIUS_M + 0.5;
    [-w / 2.0, y0, w / 2.0, y0 + h]
}

/// Tries per prop before it is left out (rejection sampling never loops forever).
pub const PLACEMENT_ATTEMPTS: u32 = 64;
/// Most props of one kind a location may ask for.
pub const MAX_PROPS_PER_KIND: u32 = 1000;

impl Location {
    /// Whether this location meets every requirement. Vocabulary (case-insensitive):
    /// `water` — it has usable water; `indoor` / `outdoor` — it is / is not inside; any other
    /// word must be one of its `tags` (the builtins use `open_space`, `sport`, `nature`,
    /// `urban`, `work`, `beach`, `pool`, `court`, `golf`, `fitness`, `vehicle`, `furniture`,
    /// `industrial`).
    #[must_use]
    pub fn suits(&self, requirements: &[String]) -> bool {
        requirements.iter().all(|r| {
            let r = r.trim();
            if r.eq_ignore_ascii_case("water") {
                self.has_water
            } else if r.eq_ignore_ascii_case("indoor") {
                self.indoor
            } else if r.eq_ignore_ascii_case("outdoor") {
                !self.indoor
            } else {
                self.tags.iter().any(|t| t.trim().eq_ignore_ascii_case(r))
            }
        })
    }

    /// Checks that the description makes sense: a name, a finite positive floor, prop ranges
    /// with min ≤ max ≤ [`MAX_PROPS_PER_KIND`] and finite positive sizes.
    ///
    /// # Errors
    /// [`SceneError::BadLocation`] naming the location and the problem.
    pub fn validate(&self) -> Result<(), SceneError> {
        let bad = |problem: String| {
            Err(SceneError::BadLocation {
                name: self.name.clone(),
                problem,
            })
        };
        if self.name.trim().is_empty() {
            return bad("the name is empty".into());
        }
        if !self.size_m.iter().all(|s| s.is_finite() && *s > 0.0) {
            return bad(format!(
                "size_m {:?} must be finite and positive",
                self.size_m
            ));
        }
        for p in &self.props {
            if p.kind.trim().is_empty() {
                return bad("a prop has an empty kind".into());
            }
            if p.count[0] > p.count[1] || p.count[1] > MAX_PROPS_PER_KIND {
                return bad(format!(
                    "prop `{}`: count {:?} must be [min, max] with min ≤ max ≤ {MAX_PROPS_PER_KIND}",
                    p.kind, p.count
                ));
            }
            if !p.size_m.iter().all(|s| s.is_finite() && *s > 0.0) {
                return bad(format!(
                    "prop `{}`: size_m {:?} must be finite and positive",
                    p.kind, p.size_m
                ));
            }
        }
        Ok(())
    }

    /// Scatters the props: for each [`PropSpec`] in order, a count uniform in its range, then
    /// each prop gets a yaw uniform in [0, 360) and a position uniform over the spots where its
    /// rotated box lies inside the floor. A spot is rejected if the prop's footprint circle
    /// (radius half its footprint diagonal, so any yaw fits in it) comes within
    /// `clear_radius_m` of the origin, where the character performs, or overlaps an
    /// earlier prop's circle. After [`PLACEMENT_ATTEMPTS`] rejections the prop and the rest of
    /// its kind are left out and counted in `props_not_placed`.
    ///
    /// Meant for a [validated](Location::validate) location; otherwise a reversed count range
    /// is read in order, counts are capped at [`MAX_PROPS_PER_KIND`], and props with bad sizes
    /// (or all props, if the floor's size is bad) are left out. A negative or NaN radius counts
    /// as 0.
    #[must_use]
    pub fn draw(&self, rng: &mut (impl Rng + ?Sized), clear_radius_m: f64) -> LocationInstance {
        let clear = if clear_radius_m > 0.0 {
            clear_radius_m
        } else {
            0.0
        };
        let half = [self.size_m[0] / 2.0, self.size_m[1] / 2.0];
        let floor_ok = self.size_m.iter().all(|s| s.is_finite() && *s > 0.0);
        let mut placed: Vec<(PlacedProp, f64)> = Vec::new();
        let mut requested = 0_u32;
        let mut not_placed = 0_u32;
        for spec in &self.props {
            let [a, b] = spec.count.map(|c| c.min(MAX_PROPS_PER_KIND));
            let n = rng.random_range(a.min(b)..=a.max(b));
            requested = requested.saturating_add(n);
            let sized = floor_ok && spec.size_m.iter().all(|s| s.is_finite() && *s > 0.0);
            let radius = 0.5 * spec.size_m[0].hypot(spec.size_m[1]);
            for i in 0..n {
                let spot = if sized {
                    (0..PLACEMENT_ATTEMPTS)
                        .find_map(|_| try_spot(rng, spec.size_m, half, radius, clear, &placed))
                } else {
                    None
                };
                if let Some((position_m, yaw_deg)) = spot {
                    placed.push((
                        PlacedProp {
                            kind: spec.kind.clone(),
                            position_m,
                            yaw_deg,
                            size_m: spec.size_m,
                        },
                        radius,
                    ));
                } else {
                    not_placed = not_placed.saturating_add(n - i);
                    break;
                }
            }
        }
        LocationInstance {
            name: self.name.clone(),
            indoor: self.indoor,
            ground: self.ground,
            size_m: self.size_m,
            has_water: self.has_water,
            backdrop: self.backdrop,
            props: placed.into_iter().map(|(p, _)| p).collect(),
            props_requested: requested,
            props_not_placed: not_placed,
            clear_radius_m: clear,
            water_m: None,
        }
    }

    /// The built-in locations, after the paper's list of GTA V sites.
    #[must_use]
    pub fn builtin_pool() -> Vec<Location> {
        BUILTIN
            .iter()
            .map(|b| Location {
                name: b.name.to_owned(),
                indoor: b.indoor,
                ground: b.ground,
                size_m: b.size_m,
                has_water: b.has_water,
                backdrop: b.backdrop,
                props: b
                    .props
                    .iter()
                    .map(|&(kind, count, size_m)| PropSpec {
                        kind: kind.to_owned(),
                        count,
                        size_m,
                    })
                    .collect(),
                tags: b.tags.iter().map(|&t| t.to_owned()).collect(),
            })
            .collect()
    }
}

/// One try at a spot: yaw, then a position where the rotated box fits the floor; `None` if the
/// box cannot fit at this yaw or the spot is too near the character or another prop.
fn try_spot(
    rng: &mut (impl Rng + ?Sized),
    size_m: [f64; 3],
    half: [f64; 2],
    radius: f64,
    clear: f64,
    placed: &[(PlacedProp, f64)],
) -> Option<([f64; 3], f64)> {
    let yaw_deg = rng.random_range(0.0..360.0);
    let (s, c) = f64::to_radians(yaw_deg).sin_cos();
    let extent = [
        0.5 * (c.abs() * size_m[0] + s.abs() * size_m[1]),
        0.5 * (s.abs() * size_m[0] + c.abs() * size_m[1]),
    ];
    let room = [half[0] - extent[0], half[1] - extent[1]];
    if room[0] < 0.0 || room[1] < 0.0 {
        return None;
    }
    let mut coord = |r: f64| {
        if r > 0.0 {
            rng.random_range(-r..=r)
        } else {
            0.0
        }
    };
    let (x, y) = (coord(room[0]), coord(room[1]));
    let far_from_character = x.hypot(y) >= clear + radius;
    let free = placed
        .iter()
        .all(|(p, r)| (p.position_m[0] - x).hypot(p.position_m[1] - y) >= r + radius);
    (far_from_character && free).then_some(([x, y, 0.0], yaw_deg))
}

/// A built-in location as static data (see [`BUILTIN`]).
struct Builtin {
    name: &'static str,
    indoor: bool,
    ground: Ground,
    size_m: [f64; 2],
    has_water: bool,
    backdrop: Backdrop,
    /// (kind, count range, bounding box `[x, y, z]` m).
    props: &'static [(&'static str, [u32; 2], [f64; 3])],
    tags: &'static [&'static str],
}

/// The built-in pool: the paper's four active GTA V sites (open field, tennis court, golf
/// course, office) and six of its commented-out ones (beach, swimming pool, parking lot, gym,
/// street, warehouse). Floor sizes are the usable area around the spot: a tennis court is
/// 23.77 × 10.97 m plus run-off; indoor rooms are typical office/gym floors. Prop sizes are
/// common real dimensions (a car 4.6 × 1.9 × 1.5 m, a bench 1.8 × 0.5 × 0.9 m, a desk
/// 1.6 × 0.8 × 0.75 m).
#[rustfmt::skip]
const BUILTIN: [Builtin; 10] = [
    Builtin {
        name: "open_field", indoor: false, ground: Ground::Grass, size_m: [60.0, 60.0],
        has_water: false, backdrop: Backdrop::Hills,
        props: &[("tree", [2, 6], [3.0, 3.0, 6.0]), ("rock", [0, 4], [1.0, 0.8, 0.6])],
        tags: &["open_space", "nature"],
    },
    Builtin {
        name: "tennis_court", indoor: false, ground: Ground::Asphalt, size_m: [36.0, 18.0],
        has_water: false, backdrop: Backdrop::CityBlocks,
        props: &[
            ("bench", [1, 2], [1.8, 0.5, 0.9]),
            ("ball_basket", [0, 2], [0.5, 0.5, 0.9]),
            ("umpire_chair", [0, 1], [1.0, 1.0, 2.0]),
        ],
        tags: &["open_space", "sport", "court"],
    },
    Builtin {
        name: "golf_course", indoor: false, ground: Ground::Grass, size_m: [80.0, 80.0],
        has_water: false, backdrop: Backdrop::Hills,
        props: &[
            ("golf_cart", [0, 2], [2.4, 1.2, 1.8]),
            ("flagstick", [0, 1], [0.1, 0.1, 2.1]),
            ("tree", [1, 5], [3.0, 3.0, 6.0]),
        ],
        tags: &["open_space", "sport", "golf", "nature"],
    },
    Builtin {
        name: "office", indoor: true, ground: Ground::Carpet, size_m: [12.0, 10.0],
        has_water: false, backdrop: Backdrop::Walls,
        props: &[
            ("desk", [2, 5], [1.6, 0.8, 0.75]),
            ("office_chair", [2, 5], [0.6, 0.6, 1.1]),
            ("cabinet", [1, 3], [0.9, 0.5, 1.9]),
            ("plant", [0, 3], [0.5, 0.5, 1.2]),
        ],
        tags: &["work", "furniture"],
    },
    Builtin {
        name: "beach", indoor: false, ground: Ground::Sand, size_m: [40.0, 30.0],
        has_water: true, backdrop: Backdrop::Sea,
        props: &[
            ("parasol", [0, 4], [2.0, 2.0, 2.4]),
            ("beach_towel", [0, 4], [1.8, 0.9, 0.01]),
            ("cooler", [0, 2], [0.6, 0.4, 0.4]),
        ],
        tags: &["open_space", "beach", "nature"],
    },
    Builtin {
        name: "swimming_pool", indoor: false, ground: Ground::Tiles, size_m: [25.0, 15.0],
        has_water: true, backdrop: Backdrop::Trees,
        props: &[
            ("sun_lounger", [2, 6], [2.0, 0.7, 0.4]),
            ("parasol", [0, 3], [2.0, 2.0, 2.4]),
        ],
        tags: &["sport", "pool"],
    },
    Builtin {
        name: "parking_lot", indoor: false, ground: Ground::Asphalt, size_m: [50.0, 40.0],
        has_water: false, backdrop: Backdrop::CityBlocks,
        props: &[
            ("car", [3, 12], [4.6, 1.9, 1.5]),
            ("lamp_post", [0, 4], [0.3, 0.3, 6.0]),
            ("trash_bin", [0, 3], [0.6, 0.6, 1.0]),
        ],
        tags: &["open_space", "urban", "vehicle"],
    },
    Builtin {
        name: "gym", indoor: true, ground: Ground::Rubber, size_m: [20.0, 15.0],
        has_water: false, backdrop: Backdrop::Walls,
        props: &[
            ("treadmill", [1, 4], [2.0, 0.9, 1.5]),
            ("weight_bench", [1, 4], [1.4, 0.6, 0.5]),
            ("dumbbell_rack", [0, 2], [1.5, 0.6, 0.9]),
            ("exercise_mat", [0, 4], [1.8, 0.6, 0.01]),
        ],
        tags: &["sport", "fitness"],
    },
    Builtin {
        name: "street", indoor: false, ground: Ground::Concrete, size_m: [30.0, 12.0],
        has_water: false, backdrop: Backdrop::CityBlocks,
        props: &[
            ("bench", [0, 2], [1.8, 0.5, 0.9]),
            ("trash_bin", [0, 2], [0.6, 0.6, 1.0]),
            ("lamp_post", [1, 3], [0.3, 0.3, 6.0]),
            ("car", [0, 3], [4.6, 1.9, 1.5]),
        ],
        tags: &["urban"],
    },
    Builtin {
        name: "warehouse", indoor: true, ground: Ground::Concrete, size_m: [30.0, 20.0],
        has_water: false, backdrop: Backdrop::Walls,
        props: &[
            ("crate", [2, 8], [1.2, 1.2, 1.2]),
            ("pallet", [1, 6], [1.2, 0.8, 0.15]),
            ("forklift", [0, 1], [2.3, 1.2, 2.1]),
        ],
        tags: &["open_space", "industrial", "work"],
    },
];

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn reqs(words: &[&str]) -> Vec<String> {
        words.iter().map(|&w| w.to_owned()).collect()
    }

    /// The corners of a placed prop's rotated footprint.
    fn corners(p: &PlacedProp) -> [[f64; 2]; 4] {
        let (s, c) = p.yaw_deg.to_radians().sin_cos();
        let (hx, hy) = (p.size_m[0] / 2.0, p.size_m[1] / 2.0);
        [[-hx, -hy], [hx, -hy], [hx, hy], [-hx, hy]].map(|[x, y]| {
            [
                p.position_m[0] + c * x - s * y,
                p.position_m[1] + s * x + c * y,
            ]
        })
    }

    /// Whether two rotated rectangles overlap (separating axis theorem).
    fn overlap(a: &[[f64; 2]; 4], b: &[[f64; 2]; 4]) -> bool {
        let axes = [a, b].into_iter().flat_map(|r| {
            (0..2).map(move |i| {
                let e = [r[i + 1][0] - r[i][0], r[i + 1][1] - r[i][1]];
                [-e[1], e[0]]
            })
        });
        for axis in axes {
            let proj = |r: &[[f64; 2]; 4]| {
                let d: Vec<f64> = r.iter().map(|p| p[0] * axis[0] + p[1] * axis[1]).collect();
                let lo = d.iter().copied().fold(f64::INFINITY, f64::min);
                let hi = d.iter().copied().fold(f64::NEG_INFINITY, f64::max);
                (lo, hi)
            };
            let ((a0, a1), (b0, b1)) = (proj(a), proj(b));
            if a1 < b0 || b1 < a0 {
                return false;
            }
        }
        true
    }

    /// Distance from the origin to the nearest point of a convex polygon (0 if inside).
    fn distance_to_origin(r: &[[f64; 2]; 4]) -> f64 {
        let mut best = f64::INFINITY;
        let mut inside = true;
        for i in 0..4 {
            let (p, q) = (r[i], r[(i + 1) % 4]);
            let e = [q[0] - p[0], q[1] - p[1]];
            let t = (-(p[0] * e[0] + p[1] * e[1]) / (e[0] * e[0] + e[1] * e[1])).clamp(0.0, 1.0);
            best = best.min((p[0] + t * e[0]).hypot(p[1] + t * e[1]));
            // The origin is inside iff it lies on the same side of every edge.
            inside &= e[0] * (-p[1]) - e[1] * (-p[0]) >= 0.0;
        }
        if inside { 0.0 } else { best }
    }

    fn check_instance(loc: &Location, inst: &LocationInstance, clear: f64) {
        let rects: Vec<_> = inst.props.iter().map(corners).collect();
        for (i, (p, r)) in inst.props.iter().zip(&rects).enumerate() {
            for c in r {
                assert!(
                    c[0].abs() <= loc.size_m[0] / 2.0 + 1e-9,
                    "{}: {p:?}",
                    loc.name
                );
                assert!(
                    c[1].abs() <= loc.size_m[1] / 2.0 + 1e-9,
                    "{}: {p:?}",
                    loc.name
                );
            }
            assert!(distance_to_origin(r) >= clear - 1e-9, "{}: {p:?}", loc.name);
            assert!((0.0..360.0).contains(&p.yaw_deg));
            assert_eq!(p.position_m[2], 0.0);
            for other in &rects[..i] {
                assert!(!overlap(r, other), "{}: {p:?} overlaps", loc.name);
            }
        }
        assert_eq!(
            inst.props.len() as u32 + inst.props_not_placed,
            inst.props_requested
        );
    }

    #[test]
    fn the_overlap_checker_itself_works() {
        let prop = |x: f64, yaw: f64| PlacedProp {
            kind: "box".into(),
            position_m: [x, 0.0, 0.0],
            yaw_deg: yaw,
            size_m: [2.0, 1.0, 1.0],
        };
        assert!(overlap(
            &corners(&prop(0.0, 0.0)),
            &corners(&prop(1.9, 0.0))
        ));
        assert!(!overlap(
            &corners(&prop(0.0, 0.0)),
            &corners(&prop(2.1, 0.0))
        ));
        assert!(!overlap(
            &corners(&prop(0.0, 90.0)),
            &corners(&prop(1.6, 90.0))
        ));
        assert_eq!(distance_to_origin(&corners(&prop(0.0, 30.0))), 0.0);
        assert!((distance_to_origin(&corners(&prop(3.0, 0.0))) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn props_keep_clear_of_the_character_each_other_and_the_walls() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for loc in Location::builtin_pool() {
            for clear in [0.0, 1.5, 2.5, 4.0] {
                for _ in 0..50 {
                    let inst = loc.draw(&mut rng, clear);
                    check_instance(&loc, &inst, clear);
                    assert_eq!(inst.name, loc.name);
                }
            }
        }
    }

    /// A random path (a straight walk, a circle or standing still) from the origin, and for
    /// every point a camera 2–9 m away at a drifting azimuth, as sight lines.
    fn random_staging(rng: &mut ChaCha8Rng) -> (Vec<[f64; 2]>, Vec<[[f64; 2]; 2]>) {
        let n = 120;
        let kind = rng.random_range(0..3);
        let heading: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let length: f64 = rng.random_range(0.0..14.0);
        let path: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let t = f64::from(i) / f64::from(n - 1);
                match kind {
                    0 => [length * t * heading.cos(), length * t * heading.sin()],
                    1 => {
                        let r = 0.2 * length;
                        let a = heading + std::f64::consts::TAU * t;
                        [r * (a.cos() - heading.cos()), r * (a.sin() - heading.sin())]
                    }
                    _ => [0.0, 0.0],
                }
            })
            .collect();
        let distance = rng.random_range(2.0..9.0);
        let (a0, turn) = (
            rng.random_range(0.0..std::f64::consts::TAU),
            rng.random_range(-1.5..1.5),
        );
        let sight = path
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let a = a0 + turn * f64::from(i as u32) / f64::from(n);
                [[p[0] + distance * a.cos(), p[1] + distance * a.sin()], *p]
            })
            .collect();
        (path, sight)
    }

    #[test]
    fn staging_keeps_water_and_props_off_the_path_and_out_of_every_line_of_sight() {
        let mut rng = ChaCha8Rng::seed_from_u64(21);
        let (mut moved, mut pools) = (0, 0);
        for loc in Location::builtin_pool() {
            for _ in 0..40 {
                let drawn = loc.draw(&mut rng, 2.5);
                let (path, sight) = random_staging(&mut rng);
                let staging = Staging {
                    path_xy_m: &path,
                    sight_lines_m: &sight,
                };
                let mut inst = drawn.clone();
                inst.stage(&staging, &mut rng);
                let name = &loc.name;
                // Every point of the path and every camera on the (grown) floor.
                let half = [inst.size_m[0] / 2.0, inst.size_m[1] / 2.0];
                for p in path.iter().chain(sight.iter().map(|l| &l[0])) {
                    assert!(
                        p[0].abs() <= half[0] && p[1].abs() <= half[1],
                        "{name}: {p:?}"
                    );
                }
                assert_eq!(inst.water_m.is_some(), loc.has_water, "{name}");
                if let Some(w) = inst.water_m {
                    pools += usize::from(loc.backdrop != Backdrop::Sea);
                    for p in &path {
                        assert!(
                            distance_to_rect(*p, w) >= BODY_RADIUS_M,
                            "{name}: {p:?} {w:?}"
                        );
                    }
                }
                for p in &inst.props {
                    let c = [p.position_m[0], p.position_m[1]];
                    let r = 0.5 * p.size_m[0].hypot(p.size_m[1]);
                    if let Some(w) = inst.water_m {
                        assert!(distance_to_rect(c, w) >= r, "{name}: {p:?} in the water");
                    }
                    if p.size_m[2] <= FLAT_PROP_M {
                        continue;
                    }
                    for q in &path {
                        let d = (q[0] - c[0]).hypot(q[1] - c[1]);
                        assert!(
                            d >= r + inst.clear_radius_m - 1e-9,
                            "{name}: {p:?} on the path"
                        );
                    }
                    for [a, b] in &sight {
                        let d = distance_to_segment(c, *a, *b);
                        assert!(d >= r + SIGHT_RADIUS_M - 1e-9, "{name}: {p:?} blocks {a:?}");
                    }
                }
                check_instance(
                    &Location {
                        size_m: inst.size_m,
                        ..loc.clone()
                    },
                    &inst,
                    inst.clear_radius_m,
                );
                moved += usize::from(inst.props != drawn.props);
            }
        }
        // The property is not vacuous: staging had to move props and place pools.
        assert!(
            moved > 50 && pools > 20,
            "{moved} scenes with props moved, {pools} pools"
        );
    }

    #[test]
    fn segment_and_rectangle_distances() {
        assert!((distance_to_segment([0.0, 1.0], [-1.0, 0.0], [1.0, 0.0]) - 1.0).abs() < 1e-12);
        assert!((distance_to_segment([3.0, 4.0], [0.0, 0.0], [0.0, 0.0]) - 5.0).abs() < 1e-12);
        assert!((distance_to_segment([2.0, 0.0], [-1.0, 0.0], [1.0, 0.0]) - 1.0).abs() < 1e-12);
        let r = [0.0, 0.0, 2.0, 1.0];
        assert_eq!(distance_to_rect([1.0, 0.5], r), 0.0);
        assert!((distance_to_rect([5.0, 5.0], r) - 5.0).abs() < 1e-12);
        assert!((distance_to_rect([1.0, -2.0], r) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn a_crowded_floor_places_fewer_and_says_so() {
        let loc = Location {
            name: "closet".into(),
            indoor: true,
            ground: Ground::Wood,
            size_m: [6.0, 6.0],
            has_water: false,
            backdrop: Backdrop::Walls,
            props: vec![
                PropSpec {
                    kind: "crate".into(),
                    count: [50, 50],
                    size_m: [1.0, 1.0, 1.0],
                },
                PropSpec {
                    kind: "piano".into(),
                    count: [1, 1],
                    size_m: [8.0, 8.0, 1.0],
                },
            ],
            tags: vec![],
        };
        loc.validate().unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let inst = loc.draw(&mut rng, 2.0);
        check_instance(&loc, &inst, 2.0);
        assert_eq!(inst.props_requested, 51);
        assert!(inst.props_not_placed > 40, "{}", inst.props_not_placed);
        assert!(inst.props.iter().all(|p| p.kind == "crate"));
        assert!(!inst.props.is_empty());
        // A clear radius larger than the floor leaves no room at all.
        let inst = loc.draw(&mut rng, 100.0);
        assert!(inst.props.is_empty() && inst.props_not_placed == 51);
        // Bad input never panics.
        let inst = loc.draw(&mut rng, f64::NAN);
        assert_eq!(inst.clear_radius_m, 0.0);
        for size_m in [[f64::INFINITY, 6.0], [f64::NAN, 6.0], [-6.0, 6.0]] {
            let bad = Location {
                size_m,
                ..loc.clone()
            };
            assert!(bad.validate().is_err());
            let inst = bad.draw(&mut rng, 1.0);
            assert!(inst.props.is_empty() && inst.props_not_placed == 51);
        }
    }

    #[test]
    fn same_seed_same_props_other_seed_other_props() {
        let pool = Location::builtin_pool();
        let draw = |seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            pool.iter()
                .map(|l| l.draw(&mut rng, 2.5))
                .collect::<Vec<_>>()
        };
        assert_eq!(draw(11), draw(11));
        assert_ne!(draw(11), draw(12));
    }

    #[test]
    fn suits_reads_water_indoor_outdoor_and_tags() {
        let pool = Location::builtin_pool();
        let names = |words: &[&str]| {
            pool.iter()
                .filter(|l| l.suits(&reqs(words)))
                .map(|l| l.name.as_str())
                .collect::<Vec<_>>()
        };
        assert_eq!(names(&["water"]), ["beach", "swimming_pool"]);
        assert_eq!(names(&["indoor"]), ["office", "gym", "warehouse"]);
        assert_eq!(
            names(&["outdoor", "sport"]),
            ["tennis_court", "golf_course", "swimming_pool"]
        );
        assert_eq!(names(&["Open_Space", "indoor"]), ["warehouse"]);
        assert_eq!(names(&[]).len(), pool.len());
        assert!(names(&["indoor", "outdoor"]).is_empty());
        assert!(names(&["volcano"]).is_empty());
    }

    #[test]
    fn builtins_are_valid_unique_and_round_trip_through_toml() {
        #[derive(Serialize, Deserialize, PartialEq, Debug)]
        struct Spec {
            location: Vec<Location>,
        }
        let pool = Location::builtin_pool();
        assert!(pool.len() >= 8);
        for l in &pool {
            l.validate().unwrap();
        }
        let mut names: Vec<_> = pool.iter().map(|l| l.name.clone()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), pool.len());
        let spec = Spec { location: pool };
        let text = toml::to_string(&spec).unwrap();
        assert_eq!(toml::from_str::<Spec>(&text).unwrap(), spec);
    }

    #[test]
    fn the_documented_toml_parses_and_bad_locations_are_named() {
        #[derive(Deserialize)]
        struct Spec {
            location: Vec<Location>,
        }
        let text = r#"
            [[location]]
            name = "rooftop"
            ground = "concrete"
            size_m = [20.0, 15.0]
            backdrop = "city_blocks"
            tags = ["urban", "open_space"]
            props = [ { kind = "vent", count = [1, 3], size_m = [1.0, 1.0, 1.2] } ]
        "#;
        let spec: Spec = toml::from_str(text).unwrap();
        let roof = &spec.location[0];
        roof.validate().unwrap();
        assert!(!roof.indoor && !roof.has_water);
        assert!(roof.suits(&reqs(&["outdoor", "urban"])));

        let bad = Location {
            size_m: [0.0, 5.0],
            ..roof.clone()
        };
        let msg = bad.validate().unwrap_err().to_string();
        assert!(msg.contains("rooftop") && msg.contains("size_m"), "{msg}");
        let mut bad = roof.clone();
        bad.props[0].count = [3, 1];
        let msg = bad.validate().unwrap_err().to_string();
        assert!(msg.contains("vent") && msg.contains("[3, 1]"), "{msg}");
        // Typos in field names are errors, not silently ignored.
        let typo = text.replace("has_water", "haswater").replace("tags", "tag");
        assert!(toml::from_str::<Spec>(&typo).is_err());
    }
}
