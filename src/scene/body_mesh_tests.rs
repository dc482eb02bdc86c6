//! Tests of the body mesh: topology, weights, shape against the skeleton, skinning.

use std::collections::BTreeMap;

use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::scene::cast::Population;
use crate::skeleton::rig::Dof;

/// The triangle count the module docs state for the standard adult.
const STANDARD_TRIANGLES: usize = 3_316;
/// The vertex count the module docs state for the standard adult.
const STANDARD_VERTICES: usize = 1_787;

struct Body {
    label: String,
    character: Character,
    mesh: BodyMesh,
}

fn body(rig: &Rig, label: &str, character: Character, shape: &BodyShape) -> Body {
    Body {
        label: label.to_string(),
        mesh: BodyMesh::build(rig, &character, shape),
        character,
    }
}

fn draws(pop: &Population, seed: u64, n: usize) -> Vec<Look> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n).map(|_| pop.draw(&mut rng).unwrap()).collect()
}

/// A child, the tallest of 300 adults and the heaviest woman of 300 adults (long hair, bust).
fn drawn_looks() -> Vec<(String, Look)> {
    let children = Population {
        age_weights: [1.0, 0.0, 0.0],
        ..Population::default()
    };
    let child = draws(&children, 11, 1).remove(0);
    let adults = Population {
        age_weights: [0.0, 1.0, 0.0],
        ..Population::default()
    };
    let many = draws(&adults, 12, 300);
    let tall = many
        .iter()
        .max_by(|a, b| a.height_m.total_cmp(&b.height_m))
        .unwrap()
        .clone();
    let heavy_woman = many
        .iter()
        .filter(|l| l.sex == Sex::Female)
        .max_by(|a, b| a.bmi_kg_per_m2.total_cmp(&b.bmi_kg_per_m2))
        .unwrap()
        .clone();
    vec![
        (format!("child {:.2} m", child.height_m), child),
        (format!("tall adult {:.2} m", tall.height_m), tall),
        (
            format!("heavy woman BMI {:.1}", heavy_woman.bmi_kg_per_m2),
            heavy_woman,
        ),
    ]
}

fn bodies(rig: &Rig) -> Vec<Body> {
    let mut v = vec![body(
        rig,
        "standard",
        Character::standard(rig),
        &BodyShape::standard(),
    )];
    for (label, look) in drawn_looks() {
        v.push(body(
            rig,
            &label,
            look.character(rig),
            &BodyShape::from_look(&look),
        ));
    }
    v
}

fn v3(p: &[f32; 3]) -> Vector3<f64> {
    Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))
}

fn triangle(mesh: &BodyMesh, positions: &[[f32; 3]], t: usize) -> [Vector3<f64>; 3] {
    [0, 1, 2].map(|k| v3(&positions[mesh.indices[3 * t + k] as usize]))
}

/// Each vertex's representative: the first vertex with a bitwise-equal position.
fn welded(positions: &[[f32; 3]]) -> Vec<usize> {
    let mut first: BTreeMap<[u32; 3], usize> = BTreeMap::new();
    positions
        .iter()
        .enumerate()
        .map(|(i, p)| *first.entry(p.map(f32::to_bits)).or_insert(i))
        .collect()
}

/// Every directed edge of the part's triangles (welded) appears once and its reverse once:
/// a closed, consistently oriented surface.
fn check_closed(mesh: &BodyMesh, part: &BodyPart, weld: &[usize]) -> Result<(), String> {
    let mut edges: BTreeMap<(usize, usize), usize> = BTreeMap::new();
    for t in part.triangles.clone() {
        let v = [0, 1, 2].map(|k| weld[mesh.indices[3 * t + k] as usize]);
        for k in 0..3 {
            *edges.entry((v[k], v[(k + 1) % 3])).or_default() += 1;
        }
    }
    for (&(a, b), &n) in &edges {
        let back = edges.get(&(b, a)).copied().unwrap_or(0);
        if n != 1 || back != 1 {
            return Err(format!(
                "{}: edge {a}→{b} used {n} times, reverse {back} times",
                part.name
            ));
        }
    }
    Ok(())
}

fn signed_volume(mesh: &BodyMesh, positions: &[[f32; 3]], triangles: Range<usize>) -> f64 {
    triangles
        .map(|t| {
            let [a, b, c] = triangle(mesh, positions, t);
            a.dot(&b.cross(&c)) / 6.0
        })
        .sum()
}

fn total_volume(mesh: &BodyMesh, positions: &[[f32; 3]]) -> f64 {
    signed_volume(mesh, positions, 0..mesh.triangle_count())
}

/// Generalised winding number of `p` with respect to the given triangles (Van Oosterom and
/// Strackee's solid angle): 1 inside one closed surface, k inside k overlapping ones, 0 outside.
fn winding_number(
    mesh: &BodyMesh,
    positions: &[[f32; 3]],
    triangles: Range<usize>,
    p: &Vector3<f64>,
) -> f64 {
    let mut sum = 0.0;
    for t in triangles {
        let [a, b, c] = triangle(mesh, positions, t).map(|x| x - p);
        let (la, lb, lc) = (a.norm(), b.norm(), c.norm());
        let num = a.dot(&b.cross(&c));
        let den = la * lb * lc + a.dot(&b) * lc + b.dot(&c) * la + c.dot(&a) * lb;
        sum += 2.0 * num.atan2(den);
    }
    sum / (4.0 * std::f64::consts::PI)
}

fn part<'a>(mesh: &'a BodyMesh, name: &str) -> &'a BodyPart {
    mesh.parts.iter().find(|p| p.name == name).unwrap()
}

fn rest_pose(rig: &Rig, character: &Character) -> WorldPose {
    fk::forward(rig, character, &BonePose::rest(rig), 1.0)
}

fn skinned(
    rig: &Rig,
    character: &Character,
    mesh: &BodyMesh,
    pose: &BonePose,
) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
    let rest = rest_pose(rig, character);
    let posed = fk::forward(rig, character, pose, 1.0);
    let skinning = Skinning::new(&rest, &posed);
    let (mut p, mut n) = (Vec::new(), Vec::new());
    mesh.skin_into(&skinning, &mut p, &mut n);
    (p, n)
}

/// Knees and elbows bent 90° about their hinge axes.
fn bent_knees_and_elbows(rig: &Rig) -> BonePose {
    let mut pose = BonePose::rest(rig);
    for name in ["l_calf", "r_calf", "l_forearm", "r_forearm"] {
        let b = rig.bone_index(name).unwrap();
        let Dof::Hinge { axis } = rig.bones[b].dof else {
            panic!("{name} is a hinge");
        };
        pose.local_rotations[b] = UnitQuaternion::from_axis_angle(&axis, FRAC_PI_2);
    }
    pose
}

use std::f64::consts::FRAC_PI_2;

#[test]
fn weights_joints_materials_and_triangles_are_well_formed() {
    let rig = Rig::standard();
    for b in bodies(&rig) {
        let m = &b.mesh;
        let n = m.vertex_count();
        assert_eq!(m.rest_normals.len(), n);
        assert_eq!(m.joints.len(), n);
        assert_eq!(m.weights.len(), n);
        assert_eq!(m.materials.len(), n);
        assert_eq!(m.indices.len() % 3, 0);
        for (i, (j, w)) in m.joints.iter().zip(&m.weights).enumerate() {
            let sum: f32 = w.iter().sum();
            assert!(
                (sum - 1.0).abs() < 1e-5,
                "{}: vertex {i} weights {w:?}",
                b.label
            );
            assert!(w.iter().all(|&x| x >= 0.0), "{}: {w:?}", b.label);
            assert!(
                w.windows(2).all(|p| p[0] >= p[1]),
                "{}: unsorted {w:?}",
                b.label
            );
            for (&jj, &ww) in j.iter().zip(w) {
                assert!(usize::from(jj) < rig.bones.len(), "{}: joint {jj}", b.label);
                if ww == 0.0 {
                    assert_eq!(jj, 0, "{}: unused slot names a bone", b.label);
                }
            }
        }
        for t in 0..m.triangle_count() {
            let v = [0, 1, 2].map(|k| m.indices[3 * t + k] as usize);
            assert!(v.iter().all(|&i| i < n), "{}: triangle {t} {v:?}", b.label);
            assert!(
                m.materials[v[0]] == m.materials[v[1]] && m.materials[v[1]] == m.materials[v[2]],
                "{}: triangle {t} mixes materials",
                b.label
            );
            let [a, bb, c] = triangle(m, &m.rest_positions_m, t);
            let area = 0.5 * (bb - a).cross(&(c - a)).norm();
            assert!(
                area > 1e-8,
                "{}: triangle {t} is degenerate ({area} m²)",
                b.label
            );
        }
        for nrm in &m.rest_normals {
            assert!(
                (v3(nrm).norm() - 1.0).abs() < 1e-5,
                "{}: normal {nrm:?}",
                b.label
            );
        }
        // Every material is used, and the parts tile the arrays.
        for mat in Material::ALL {
            assert!(m.materials.contains(&mat), "{}: no {}", b.label, mat.name());
        }
        let mut next = (0, 0);
        for p in &m.parts {
            assert_eq!((p.vertices.start, p.triangles.start), next, "{}", p.name);
            next = (p.vertices.end, p.triangles.end);
        }
        assert_eq!(next, (n, m.triangle_count()));
    }
}

#[test]
fn triangle_budget_holds_and_the_documented_counts_are_right() {
    let rig = Rig::standard();
    let standard = BodyMesh::build(&rig, &Character::standard(&rig), &BodyShape::standard());
    assert_eq!(standard.triangle_count(), STANDARD_TRIANGLES);
    assert_eq!(standard.vertex_count(), STANDARD_VERTICES);
    for (style, extra) in [
        (HairStyle::Long, 80),
        (HairStyle::Ponytail, 64),
        (HairStyle::Bun, 64),
        (HairStyle::Bald, 0),
    ] {
        let shape = BodyShape {
            hair_length_m: 0.14,
            hair_style: style,
            ..BodyShape::standard()
        };
        let with_hair = BodyMesh::build(&rig, &Character::standard(&rig), &shape);
        assert_eq!(
            with_hair.triangle_count(),
            STANDARD_TRIANGLES + extra,
            "{style:?}"
        );
        assert!(with_hair.triangle_count() <= MAX_TRIANGLES);
    }
    for b in bodies(&rig) {
        assert!(
            b.mesh.triangle_count() <= MAX_TRIANGLES,
            "{}: {} triangles",
            b.label,
            b.mesh.triangle_count()
        );
    }
}

#[test]
fn every_part_is_closed_and_wound_outward() {
    let rig = Rig::standard();
    for b in bodies(&rig) {
        let m = &b.mesh;
        let weld = welded(&m.rest_positions_m);
        // Welding never joins two parts: each closed part is its own surface.
        for p in &m.parts {
            for v in p.vertices.clone() {
                assert!(
                    p.vertices.contains(&weld[v]),
                    "{}: {} shares a vertex",
                    b.label,
                    p.name
                );
            }
            check_closed(m, p, &weld).unwrap();
            let vol = signed_volume(m, &m.rest_positions_m, p.triangles.clone());
            assert!(vol > 0.0, "{}: {} volume {vol}", b.label, p.name);
        }
        // Normals point out of their own part: a step along the normal leaves it, a step
        // against it enters it (every other vertex, to keep the test quick).
        for p in &m.parts {
            for v in p.vertices.clone().step_by(2) {
                let x = v3(&m.rest_positions_m[v]);
                let n = v3(&m.rest_normals[v]);
                let tris = p.triangles.clone();
                let out = winding_number(m, &m.rest_positions_m, tris.clone(), &(x + n * 1e-3));
                let inside = winding_number(m, &m.rest_positions_m, tris, &(x - n * 1e-3));
                assert!(
                    out < 0.5 && inside > 0.5,
                    "{}: {} vertex {v} normal {n:?} points in (winding {out} out, {inside} in)",
                    b.label,
                    p.name
                );
            }
        }
    }
}

#[test]
fn the_standard_adult_has_a_plausible_volume() {
    let rig = Rig::standard();
    let m = BodyMesh::build(&rig, &Character::standard(&rig), &BodyShape::standard());
    let vol = total_volume(&m, &m.rest_positions_m);
    assert!((0.05..0.09).contains(&vol), "{vol} m³");
}

#[test]
fn the_rest_mesh_encloses_the_joints_of_limbs_spine_neck_and_head() {
    let rig = Rig::standard();
    let mut names: Vec<String> = [
        "pelvis", "spine0", "spine1", "spine2", "spine3", "neck", "head",
    ]
    .iter()
    .map(ToString::to_string)
    .collect();
    for side in ["l", "r"] {
        for bone in [
            "clavicle",
            "upper_arm",
            "forearm",
            "hand",
            "middle0",
            "thigh",
            "calf",
            "foot",
        ] {
            names.push(format!("{side}_{bone}"));
        }
    }
    for b in bodies(&rig) {
        let m = &b.mesh;
        let rest = rest_pose(&rig, &b.character);
        let all = 0..m.triangle_count();
        for name in &names {
            let i = rig.bone_index(name).unwrap();
            let p = rest.heads_m[i].coords;
            let w = winding_number(m, &m.rest_positions_m, all.clone(), &p);
            assert!(
                w > 0.5,
                "{}: {name} head {p:?} is outside (winding {w})",
                b.label
            );
        }
        // And the test can tell: points beside the body are outside.
        for p in [
            Vector3::new(0.0, 0.4, 1.0),
            Vector3::new(0.0, 0.0, 0.4),
            Vector3::new(0.0, 0.0, 2.5),
        ] {
            let w = winding_number(m, &m.rest_positions_m, all.clone(), &p);
            assert!(w.abs() < 1e-6, "{}: {p:?} winding {w}", b.label);
        }
    }
}

#[test]
fn rest_extents_match_the_skeleton_and_the_body_is_symmetric() {
    let rig = Rig::standard();
    let top = rig.landmark_index("head_top").unwrap();
    for b in bodies(&rig) {
        let m = &b.mesh;
        let rest = rest_pose(&rig, &b.character);
        let stature = fk::landmark_position(&rig, &b.character, &rest, top).z;
        let zs = m.rest_positions_m.iter().map(|p| f64::from(p[2]));
        let min_z = zs.clone().fold(f64::INFINITY, f64::min);
        let max_z = zs.fold(f64::NEG_INFINITY, f64::max);
        assert!(min_z.abs() < 0.01, "{}: soles at {min_z}", b.label);
        assert!(
            (max_z - stature).abs() < 0.03,
            "{}: top {max_z} vs {stature}",
            b.label
        );
        // Shoes: flat soles, and every sole vertex on the ground.
        for side in ["l_shoe", "r_shoe"] {
            let p = part(m, side);
            let lowest = p
                .vertices
                .clone()
                .filter(|&v| f64::from(m.rest_positions_m[v][2]) < 0.005)
                .count();
            assert!(
                lowest >= 8 * 3,
                "{}: {side} has {lowest} sole vertices",
                b.label
            );
        }
        // The arm's palm reaches past the knuckles, and the middle finger to its fingertip.
        for (side, arm, sign) in [("l", "l_arm", -1.0), ("r", "r_arm", 1.0)] {
            let hand = rig.bone_index(&format!("{side}_hand")).unwrap();
            let middle2 = rig.bone_index(&format!("{side}_middle2")).unwrap();
            let hand_tail = rest.heads_m[rig.bone_index(&format!("{side}_middle0")).unwrap()];
            let tip = rest.heads_m[middle2].coords
                + (rig.bones[middle2].tail_rest_m - rig.bones[middle2].head_rest_m)
                    * b.character.bone_scale[middle2];
            let reach_of = |name: &str| {
                part(m, name)
                    .vertices
                    .clone()
                    .map(|v| sign * f64::from(m.rest_positions_m[v][0]))
                    .fold(f64::NEG_INFINITY, f64::max)
            };
            let palm = reach_of(arm);
            assert!(palm > sign * hand_tail.x, "{}: {arm} reach {palm}", b.label);
            let reach = reach_of(&format!("{side}_middle"));
            assert!(
                (reach - sign * tip.x).abs() < 0.01,
                "{}: {arm} reaches {reach}, fingertip at {}",
                b.label,
                sign * tip.x
            );
            let _ = hand;
        }
        // Mirror symmetry: every vertex has a twin at (−x, y, z).
        let pts: Vec<Vector3<f64>> = m.rest_positions_m.iter().map(v3).collect();
        for p in &pts {
            let mirror = Vector3::new(-p.x, p.y, p.z);
            let nearest = pts
                .iter()
                .map(|q| (q - mirror).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(
                nearest < 1e-5,
                "{}: {p:?} has no mirror twin ({nearest})",
                b.label
            );
        }
    }
}

#[test]
fn identity_skinning_reproduces_the_rest_mesh_exactly() {
    let rig = Rig::standard();
    for b in bodies(&rig) {
        let (p, n) = skinned(&rig, &b.character, &b.mesh, &BonePose::rest(&rig));
        assert_eq!(p, b.mesh.rest_positions_m, "{}", b.label);
        assert_eq!(n, b.mesh.rest_normals, "{}", b.label);
    }
}

#[test]
fn bent_knees_and_elbows_keep_the_mesh_closed() {
    let rig = Rig::standard();
    let pose = bent_knees_and_elbows(&rig);
    for b in bodies(&rig) {
        let m = &b.mesh;
        let (p, _) = skinned(&rig, &b.character, m, &pose);
        // The bend happened: the left wrist moved forward, the left ankle backward.
        let rest = rest_pose(&rig, &b.character);
        let posed = fk::forward(&rig, &b.character, &pose, 1.0);
        let hand = rig.bone_index("l_hand").unwrap();
        let foot = rig.bone_index("l_foot").unwrap();
        assert!(posed.heads_m[hand].y > rest.heads_m[hand].y + 0.15);
        assert!(posed.heads_m[foot].y < rest.heads_m[foot].y - 0.15);
        // Seams stay shut: welded duplicates move together.
        let weld = welded(&m.rest_positions_m);
        for (v, &w) in weld.iter().enumerate() {
            assert_eq!(p[v], p[w], "{}: seam vertex {v} left {w}", b.label);
        }
        // No edge stretches more than 3×.
        for t in 0..m.triangle_count() {
            let r = triangle(m, &m.rest_positions_m, t);
            let s = triangle(m, &p, t);
            for k in 0..3 {
                let rest_len = (r[(k + 1) % 3] - r[k]).norm();
                let len = (s[(k + 1) % 3] - s[k]).norm();
                assert!(
                    len < 3.0 * rest_len,
                    "{}: triangle {t} edge {k} {rest_len} → {len}",
                    b.label
                );
            }
        }
        // Volume kept, body and each bent limb.
        let ratio = total_volume(m, &p) / total_volume(m, &m.rest_positions_m);
        assert!(
            (0.85..1.15).contains(&ratio),
            "{}: volume ratio {ratio}",
            b.label
        );
        for name in ["l_arm", "r_arm", "l_leg", "r_leg"] {
            let tris = part(m, name).triangles.clone();
            let ratio =
                signed_volume(m, &p, tris.clone()) / signed_volume(m, &m.rest_positions_m, tris);
            assert!(
                (0.85..1.15).contains(&ratio),
                "{}: {name} volume ratio {ratio}",
                b.label
            );
        }
    }
}

#[test]
fn a_whole_body_rotation_and_translation_moves_every_vertex_rigidly() {
    let rig = Rig::standard();
    let mut pose = BonePose::rest(&rig);
    let axis = Unit::new_normalize(Vector3::new(0.3, -0.5, 1.0));
    let rotation = UnitQuaternion::from_axis_angle(&axis, 2.2);
    pose.local_rotations[crate::skeleton::rig::ROOT] = rotation;
    pose.root_translation_m = Vector3::new(3.0, -1.5, 0.4);
    for b in bodies(&rig) {
        let m = &b.mesh;
        let (p, n) = skinned(&rig, &b.character, m, &pose);
        let root_rest = rig.bones[crate::skeleton::rig::ROOT].head_rest_m;
        for (i, (q, nq)) in p.iter().zip(&n).enumerate() {
            let x = Point3::from(v3(&m.rest_positions_m[i]));
            let want = rotation * (x - root_rest) + root_rest.coords + pose.root_translation_m;
            assert!((v3(q) - want).norm() < 1e-5, "{}: vertex {i}", b.label);
            let want_n = rotation * v3(&m.rest_normals[i]);
            assert!((v3(nq) - want_n).norm() < 1e-5, "{}: normal {i}", b.label);
        }
    }
}

#[test]
fn two_builds_are_identical() {
    let rig = Rig::standard();
    let (_, look) = drawn_looks().remove(2);
    let character = look.character(&rig);
    let shape = BodyShape::from_look(&look);
    assert_eq!(
        BodyMesh::build(&rig, &character, &shape),
        BodyMesh::build(&rig, &character, &shape)
    );
}

#[test]
fn shapes_follow_the_look_and_colours_come_from_it() {
    let rig = Rig::standard();
    let looks = draws(&Population::default(), 3, 200);
    let woman = looks
        .iter()
        .find(|l| l.sex == Sex::Female && l.age_group == AgeGroup::Adult)
        .unwrap();
    let man = looks
        .iter()
        .find(|l| l.sex == Sex::Male && l.age_group == AgeGroup::Adult)
        .unwrap();
    let (ws, ms) = (BodyShape::from_look(woman), BodyShape::from_look(man));
    assert!(ws.hip_scale > ms.hip_scale && ws.bust_depth_m > 0.0);
    assert_eq!(ms.girth_scale, man.girth_scale());
    let long = looks
        .iter()
        .find(|l| BodyShape::from_look(l).hair_style == HairStyle::Long)
        .unwrap();
    let long_shape = BodyShape::from_look(long);
    assert!(long_shape.hair_length_m > 0.03);
    let with_hair = BodyMesh::build(&rig, &long.character(&rig), &long_shape);
    assert!(with_hair.parts.iter().any(|p| p.name == "hair"));
    let short = looks
        .iter()
        .find(|l| BodyShape::from_look(l).hair_style == HairStyle::Short)
        .unwrap();
    let short_shape = BodyShape::from_look(short);
    assert_eq!(short_shape.hair_length_m, 0.0);
    let short = BodyMesh::build(&rig, &short.character(&rig), &short_shape);
    assert!(short.parts.iter().all(|p| p.name != "hair"));
    // A heavier build is wider, not taller.
    let heavy = BodyShape {
        girth_scale: 1.3,
        ..BodyShape::standard()
    };
    let c = Character::standard(&rig);
    let lean = BodyMesh::build(&rig, &c, &BodyShape::standard());
    let wide = BodyMesh::build(&rig, &c, &heavy);
    let v_lean = total_volume(&lean, &lean.rest_positions_m);
    let v_wide = total_volume(&wide, &wide.rest_positions_m);
    assert!(v_wide > 1.3 * v_lean, "{v_wide} vs {v_lean}");
    let top = |m: &BodyMesh| m.rest_positions_m.iter().map(|p| p[2]).fold(0.0, f32::max);
    assert_eq!(top(&lean), top(&wide));

    for (mat, want) in [
        (Material::Skin, woman.skin_rgb),
        (Material::Hair, woman.hair_rgb),
        (Material::Top, woman.clothing.top_rgb),
        (Material::Bottom, woman.clothing.bottom_rgb),
        (Material::Shoes, woman.clothing.shoes_rgb),
    ] {
        assert_eq!(albedo_srgb(woman, mat), want, "{}", mat.name());
    }
    let names: Vec<&str> = Material::ALL.iter().map(|m| m.name()).collect();
    assert_eq!(names, ["skin", "hair", "top", "bottom", "shoes", "eye"]);
}

#[test]
fn materials_sit_where_the_clothes_are() {
    let rig = Rig::standard();
    let m = BodyMesh::build(&rig, &Character::standard(&rig), &BodyShape::standard());
    let material_near = |p: Vector3<f64>| {
        let (i, _) = m
            .rest_positions_m
            .iter()
            .enumerate()
            .map(|(i, q)| (i, (v3(q) - p).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        m.materials[i]
    };
    assert_eq!(material_near(Vector3::new(0.0, 0.0, 1.80)), Material::Hair);
    assert_eq!(
        material_near(Vector3::new(0.0, -0.12, 1.62)),
        Material::Hair
    );
    assert_eq!(material_near(Vector3::new(0.0, 0.2, 1.62)), Material::Skin);
    assert_eq!(material_near(Vector3::new(0.0, 0.2, 1.25)), Material::Top);
    assert_eq!(material_near(Vector3::new(0.3, 0.0, 1.50)), Material::Top);
    assert_eq!(material_near(Vector3::new(0.6, 0.0, 1.48)), Material::Skin);
    assert_eq!(material_near(Vector3::new(0.8, 0.0, 1.46)), Material::Skin);
    assert_eq!(
        material_near(Vector3::new(0.0, 0.2, 0.85)),
        Material::Bottom
    );
    assert_eq!(
        material_near(Vector3::new(0.09, 0.1, 0.5)),
        Material::Bottom
    );
    assert_eq!(
        material_near(Vector3::new(0.09, 0.25, 0.02)),
        Material::Shoes
    );
}

#[test]
fn a_rig_without_the_bones_is_an_error() {
    let mut rig = Rig::standard();
    let c = Character::standard(&rig);
    let b = rig.bone_index("l_thumb1").unwrap();
    rig.bones[b].name = "l_thumb_x".to_string();
    rig.bones[b].gta_name = "";
    let err = BodyMesh::try_build(&rig, &c, &BodyShape::standard()).unwrap_err();
    assert!(err.to_string().contains("`l_thumb1`"), "{err}");
    let short = Character {
        bone_scale: vec![1.0; 10],
        ..Character::standard(&Rig::standard())
    };
    assert!(matches!(
        BodyMesh::try_build(&Rig::standard(), &short, &BodyShape::standard()),
        Err(BodyMeshError::CharacterMismatch { .. })
    ));
}

#[test]
#[expect(
    clippy::print_stderr,
    reason = "a rough timing for the report, not an assertion"
)]
fn skinning_time_is_reported() {
    let rig = Rig::standard();
    let c = Character::standard(&rig);
    let m = BodyMesh::build(&rig, &c, &BodyShape::standard());
    let rest = rest_pose(&rig, &c);
    let posed = fk::forward(&rig, &c, &bent_knees_and_elbows(&rig), 1.0);
    let mut skinning = Skinning::new(&rest, &rest);
    let (mut p, mut n) = (Vec::new(), Vec::new());
    m.skin_into(&skinning, &mut p, &mut n);
    let (cap_p, cap_n) = (p.capacity(), n.capacity());
    let runs = 200;
    let start = std::time::Instant::now();
    for _ in 0..runs {
        skinning.update(&rest, &posed);
        m.skin_into(&skinning, &mut p, &mut n);
    }
    let per = start.elapsed() / runs;
    assert_eq!(
        (p.capacity(), n.capacity()),
        (cap_p, cap_n),
        "no reallocation"
    );
    eprintln!(
        "skinning {} vertices ({} triangles): {per:?} per frame (this build profile)",
        m.vertex_count(),
        m.triangle_count()
    );
}

#[test]
fn limb_joints_blend_half_and_half_fading_over_a_quarter_bone() {
    let rig = Rig::standard();
    let c = Character::standard(&rig);
    let m = BodyMesh::build(&rig, &c, &BodyShape::standard());
    let rest = rest_pose(&rig, &c);
    let weight = |v: usize, bone: usize| -> f32 {
        m.joints[v]
            .iter()
            .zip(&m.weights[v])
            .filter(|(j, _)| usize::from(**j) == bone)
            .map(|(_, w)| *w)
            .sum()
    };
    for (limb, parent, child) in [
        ("l_leg", "l_thigh", "l_calf"),
        ("r_leg", "r_thigh", "r_calf"),
        ("l_arm", "l_upper_arm", "l_forearm"),
        ("r_arm", "r_upper_arm", "r_forearm"),
    ] {
        let (p, ch) = (
            rig.bone_index(parent).unwrap(),
            rig.bone_index(child).unwrap(),
        );
        let joint = rest.heads_m[ch].coords;
        let axis = rig.bones[ch].rest_direction().into_inner();
        let (lp, lc) = (
            rig.bones[p].rest_length_m() * c.bone_scale[p],
            rig.bones[ch].rest_length_m() * c.bone_scale[ch],
        );
        // (distance along the child's axis, child weight), over the blend region and beyond.
        let mut samples: Vec<(f64, f32)> = part(&m, limb)
            .vertices
            .clone()
            .filter_map(|v| {
                let s = (v3(&m.rest_positions_m[v]) - joint).dot(&axis);
                (-0.45 * lp..0.45 * lc).contains(&s).then(|| {
                    let (wp, wc) = (weight(v, p), weight(v, ch));
                    assert!((wp + wc - 1.0).abs() < 1e-5, "{limb}: other bones at {s}");
                    (s, wc)
                })
            })
            .collect();
        samples.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert!(samples.len() > 40, "{limb}: {} samples", samples.len());
        for w in samples.windows(2) {
            assert!(
                w[1].1 >= w[0].1 - 1e-6,
                "{limb}: child weight falls at {w:?}"
            );
        }
        for &(s, wc) in &samples {
            if s.abs() < 1e-4 {
                assert!((wc - 0.5).abs() < 1e-4, "{limb}: joint ring weight {wc}");
            } else if s > 0.0 && s < 0.2 * lc {
                assert!(wc > 0.5 && wc < 1.0, "{limb}: {wc} at {s} m past the joint");
            } else if s < 0.0 && s > -0.2 * lp {
                assert!(
                    wc > 0.0 && wc < 0.5,
                    "{limb}: {wc} at {s} m before the joint"
                );
            } else if s >= 0.25 * lc {
                assert!(
                    (wc - 1.0).abs() < 1e-6,
                    "{limb}: {wc} at {s} m past the joint"
                );
            } else if s <= -0.25 * lp {
                assert!(wc.abs() < 1e-6, "{limb}: {wc} at {s} m before the joint");
            }
        }
        assert!(
            samples.iter().any(|&(s, _)| s.abs() < 1e-4),
            "{limb}: no joint ring"
        );
    }
}

#[test]
fn eyes_and_ears_sit_on_the_head_at_cocos_face_points() {
    let rig = Rig::standard();
    for b in bodies(&rig) {
        let rest = crate::skeleton::fk::forward(&rig, &b.character, &BonePose::rest(&rig), 1.0);
        let head = rig.bone_index("head").unwrap();
        for (name, material) in [
            ("l_eye", Material::Eye),
            ("r_eye", Material::Eye),
            ("l_ear", Material::Skin),
            ("r_ear", Material::Skin),
        ] {
            let part = b.mesh.parts.iter().find(|p| p.name == name).unwrap();
            let n = part.vertices.len() as f64;
            let centroid = part
                .vertices
                .clone()
                .map(|i| v3(&b.mesh.rest_positions_m[i]))
                .sum::<Vector3<f64>>()
                / n;
            let l = rig.landmark_index(name).unwrap();
            let want = crate::skeleton::fk::landmark_position(&rig, &b.character, &rest, l).coords;
            let off = (centroid - want).norm();
            assert!(
                off < 0.03,
                "{}: {name} {off:.3} m from its landmark",
                b.label
            );
            for i in part.vertices.clone() {
                assert_eq!(b.mesh.materials[i], material, "{}: {name}", b.label);
                assert_eq!(b.mesh.joints[i][0] as usize, head, "{}: {name}", b.label);
                assert_eq!(b.mesh.weights[i][0], 1.0, "{}: {name}", b.label);
            }
        }
        // Left is −x (the body's right is +x), and the eyes are in front of the ears.
        let x = |name: &str| {
            let p = b.mesh.parts.iter().find(|p| p.name == name).unwrap();
            f64::from(b.mesh.rest_positions_m[p.vertices.start][0])
        };
        assert!(x("l_eye") < 0.0 && x("r_eye") > 0.0 && x("l_ear") < x("l_eye"));
    }
}

/// Where the hair is on a body: how many hair vertices, the lowest one's height and the
/// furthest one's distance behind the head bone's head, metres.
fn hair_extent(mesh: &BodyMesh, head_m: &Vector3<f64>) -> (usize, f64, f64) {
    let mut n = 0;
    let (mut lowest, mut behind) = (f64::INFINITY, 0.0f64);
    for (p, &m) in mesh.rest_positions_m.iter().zip(&mesh.materials) {
        if m == Material::Hair {
            n += 1;
            lowest = lowest.min(f64::from(p[2]));
            behind = behind.max(head_m.y - f64::from(p[1]));
        }
    }
    (n, lowest, behind)
}

#[test]
fn hair_styles_are_drawn_per_character_and_shaped_apart() {
    let rig = Rig::standard();
    // Every style comes out of drawn looks, in proportions that depend on sex and age.
    let looks = draws(&Population::default(), 9, 600);
    let mut seen = BTreeMap::new();
    for l in &looks {
        *seen.entry(HairStyle::of(l)).or_insert(0usize) += 1;
    }
    for style in HairStyle::ALL {
        assert!(seen.get(&style).copied().unwrap_or(0) >= 10, "{seen:?}");
    }
    // The same look always gets the same style.
    assert!(
        looks
            .iter()
            .all(|l| HairStyle::of(l) == HairStyle::of(&l.clone()))
    );
    let c = Character::standard(&rig);
    let head = rest_pose(&rig, &c).heads_m[rig.bone_index("head").unwrap()].coords;
    let extent = |style| {
        let shape = BodyShape {
            hair_length_m: 0.14,
            hair_style: style,
            ..BodyShape::standard()
        };
        hair_extent(&BodyMesh::build(&rig, &c, &shape), &head)
    };
    let short = extent(HairStyle::Short);
    let long = extent(HairStyle::Long);
    let pony = extent(HairStyle::Ponytail);
    let bun = extent(HairStyle::Bun);
    let bald = extent(HairStyle::Bald);
    // Long hair and a ponytail fall below a short cut; a bun stands out behind the head; a
    // bald head has less hair than a short cut.
    assert!(long.1 < short.1 - 0.08, "{long:?} {short:?}");
    assert!(pony.1 < short.1 - 0.05, "{pony:?} {short:?}");
    assert!(bun.2 > short.2 + 0.02, "{bun:?} {short:?}");
    assert!(bald.0 < short.0 * 3 / 4, "{bald:?} {short:?}");
}

#[test]
fn curled_fingers_are_drawn_where_their_bones_put_the_fingertips() {
    let rig = Rig::standard();
    let c = Character::standard(&rig);
    let mesh = BodyMesh::build(&rig, &c, &BodyShape::standard());
    let mut pose = BonePose::rest(&rig);
    let fingers = ["index", "middle", "ring", "pinky"];
    for side in ["l", "r"] {
        for finger in fingers {
            for k in 0..3 {
                let b = rig.bone_index(&format!("{side}_{finger}{k}")).unwrap();
                let axis = match rig.bones[b].dof {
                    Dof::Hinge { axis } => axis,
                    _ => Vector3::y_axis(),
                };
                let angle = if k == 0 { 0.3 } else { 0.9 };
                pose.local_rotations[b] = UnitQuaternion::from_axis_angle(&axis, angle);
            }
        }
    }
    let (p, _) = skinned(&rig, &c, &mesh, &pose);
    let rest = rest_pose(&rig, &c);
    let posed = fk::forward(&rig, &c, &pose, 1.0);
    for side in ["l", "r"] {
        for finger in fingers {
            let l = rig.landmark_index(&format!("{side}_{finger}4")).unwrap();
            let tip = fk::landmark_position(&rig, &c, &posed, l).coords;
            let tip_at_rest = fk::landmark_position(&rig, &c, &rest, l).coords;
            // The curl moves the tip (so the check below is not vacuous)...
            assert!((tip - tip_at_rest).norm() > 0.03, "{side}_{finger}");
            // ...and the body's surface is there (a mitten following only the fingers' first
            // bones is not: the curl of the second and third bones carries the tips off it).
            let nearest = p
                .iter()
                .map(|q| (v3(q) - tip).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < 0.012, "{side}_{finger}: {nearest:.4} m");
            // The finger is a part of its own.
            assert!(
                mesh.parts
                    .iter()
                    .any(|q| q.name == format!("{side}_{finger}"))
            );
        }
    }
}
