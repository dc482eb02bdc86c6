//! The `autoact` binary, run as a user would: outputs, formats, errors and exit codes.

use crate::common::{autoact, stderr, stdout};

#[test]
fn rig_prints_53_bones_with_gta_names() {
    let o = autoact(&["rig"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    let rows = out
        .lines()
        .filter(|l| {
            l.split_whitespace()
                .next()
                .is_some_and(|c| c.parse::<usize>().is_ok())
        })
        .count();
    assert_eq!(rows, 53, "{out}");
    assert!(out.contains("SKEL_L_UpperArm") && out.contains("45509"));
    assert!(
        stderr(&o).is_empty(),
        "diagnostics on a clean run: {}",
        stderr(&o)
    );
}

#[test]
fn rig_json_is_valid_and_complete() {
    let o = autoact(&["rig", "--format", "json"]);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let bones = v["bones"].as_array().unwrap();
    assert_eq!(bones.len(), 53);
    assert_eq!(bones[0]["dof"], "root");
    let calf = bones.iter().find(|b| b["name"] == "l_calf").unwrap();
    assert_eq!(calf["dof"], "1-D");
    assert_eq!(calf["hinge_axis"].as_array().unwrap().len(), 3);
    assert_eq!(calf["rest_orientation_xyzw"].as_array().unwrap().len(), 4);
}

#[test]
fn rig_with_a_layout_says_which_bones_stay_at_rest() {
    let o = autoact(&["rig", "--layout", "h36m-17", "--format", "json"]);
    assert!(o.status.success());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let status = |name: &str| {
        v["bones"]
            .as_array()
            .unwrap()
            .iter()
            .find(|b| b["name"] == name)
            .unwrap()["layout"]
            .clone()
    };
    assert_eq!(status("l_forearm"), "driven");
    assert_eq!(status("l_index1"), "at rest (not in layout)");
    assert_eq!(status("head"), "driven, twist unobserved");
    // Since issue 19 the pelvis turns (3-D, along the hip line) and the clavicles swing.
    assert_eq!(status("pelvis"), "driven");
    assert_eq!(status("l_clavicle"), "driven");
    assert_eq!(status("spine_root"), "static");
}

#[test]
fn user_layout_file_works_and_bad_ones_are_named() {
    let dir = std::env::temp_dir().join(format!("autoact-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("mine.toml");
    std::fs::write(&good, "name = \"mine\"\njoints = [\"hl\", \"hr\", \"kl\"]\n[landmarks]\nl_hip = \"hl\"\nr_hip = \"hr\"\nl_knee = \"kl\"\npelvis = { mean = [\"hl\", \"hr\"] }\n").unwrap();
    let o = autoact(&["layouts", good.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("layout mine"));
    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        "name = \"bad\"\njoints = [\"a\"]\n[landmarks]\nl_hip = \"nope\"\n",
    )
    .unwrap();
    let o = autoact(&["rig", "--layout", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("`nope`") && stderr(&o).contains("bad.toml"),
        "{}",
        stderr(&o)
    );
    assert!(stdout(&o).is_empty());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn unknown_layout_lists_the_built_in_ones() {
    let o = autoact(&["layouts", "openpose"]);
    assert_eq!(o.status.code(), Some(1));
    let err = stderr(&o);
    assert!(
        err.contains("unknown layout `openpose`") && err.contains("coco-wholebody-133"),
        "{err}"
    );
}

#[test]
fn usage_errors_exit_2_and_help_lists_exit_codes() {
    assert_eq!(autoact(&["rig", "--format", "xml"]).status.code(), Some(2));
    assert_eq!(autoact(&["frobnicate"]).status.code(), Some(2));
    let help = stdout(&autoact(&["--help"]));
    assert!(help.contains("Exit codes:") && help.contains("3  finished, but some input was lost"));
    let version = stdout(&autoact(&["--version"]));
    assert!(version.starts_with("autoact "), "{version}");
}

#[test]
fn layouts_list_shows_every_builtin() {
    let o = autoact(&["layouts"]);
    assert!(o.status.success());
    let out = stdout(&o);
    for name in [
        "coco-wholebody-133",
        "coco-17",
        "ntu-25",
        "h36m-17",
        "h36m-32",
        "zed-body-34",
        "mediapipe-pose-33",
        "smpl-24",
        "smplx-55",
        "azure-kinect-32",
        "autoact-landmarks",
    ] {
        assert!(out.contains(name), "{name} missing from:\n{out}");
    }
}

/// A BVH skeleton no built-in mapping knows (joint names of its own), cm, Y up.
const UNKNOWN_SKELETON_BVH: &str = "HIERARCHY
ROOT pelvis_jnt
{
  OFFSET 0 95 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT chest_jnt
  {
    OFFSET 0 50 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT head_jnt
    {
      OFFSET 0 10 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 20 0
      }
    }
    JOINT larm_jnt
    {
      OFFSET 18 0 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT lelbow_jnt
      {
        OFFSET 28 0 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {
          OFFSET 25 0 0
        }
      }
    }
  }
}
MOTION
Frames: 3
Frame Time: 0.04
0 95 0 0 0 0 0 0 0 0 0 0 0 0 0 10 0 0
1 95 0 0 5 0 0 0 0 0 0 0 0 0 0 20 0 0
2 95 0 0 10 0 0 0 0 0 0 0 0 0 0 30 0 0
";

#[test]
fn an_unknown_bvh_skeleton_is_refused_with_how_to_map_it_and_imports_with_bvh_map() {
    use crate::common::arg;
    let dir = tempfile::tempdir().unwrap();
    let bvh = dir.path().join("mine.bvh");
    std::fs::write(&bvh, UNKNOWN_SKELETON_BVH).unwrap();
    let out = dir.path().join("mine.pose.mcap");
    let o = autoact(&["import", arg(&bvh), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let err = stderr(&o);
    for needle in [
        "no built-in BVH mapping fits this skeleton",
        "Its joints are: pelvis_jnt, chest_jnt, head_jnt, larm_jnt, lelbow_jnt.",
        "docs/convert.md",
        "src/skeleton/layouts/bvh/cmu.toml",
        "--bvh-map FILE.toml",
    ] {
        assert!(err.contains(needle), "`{needle}` not in: {err}");
    }
    assert!(!out.exists());
    // `autoact layouts` names the built-in mappings.
    let listing = stdout(&autoact(&["layouts"]));
    assert!(
        listing.contains("Built-in BVH skeleton mappings")
            && listing.contains("bandai-namco  Hips, Chest, UpperArm_L"),
        "{listing}"
    );

    let map = dir.path().join("mine.toml");
    std::fs::write(
        &map,
        "skeleton = \"mine\"\nrequired = [\"pelvis_jnt\", \"head_jnt\"]\nmetres_per_unit = 0.01\n\
         [layouts.autoact-landmarks]\npelvis = \"pelvis_jnt\"\nchest = \"chest_jnt\"\n\
         neck = \"head_jnt\"\nhead_top = \"head_jnt_End\"\nl_shoulder = \"larm_jnt\"\n\
         l_elbow = \"lelbow_jnt\"\nl_wrist = \"lelbow_jnt_End\"\n",
    )
    .unwrap();
    let o = autoact(&["import", arg(&bvh), "--bvh-map", arg(&map), "-o", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("3 skeletons (1 track), layout autoact-landmarks"),
        "{}",
        stdout(&o)
    );
    let anim = dir.path().join("mine.anim.mcap");
    let o = autoact(&["convert", arg(&out), "-o", arg(&anim)]);
    assert!(o.status.success(), "{}", stderr(&o));

    // A mapping naming a joint the file does not have says which, and lists the file's joints.
    std::fs::write(
        &map,
        "skeleton = \"mine\"\nrequired = [\"pelvis_jnt\"]\n[layouts.autoact-landmarks]\npelvis = \"hips\"\n",
    )
    .unwrap();
    let out2 = dir.path().join("mine2.pose.mcap");
    let o = autoact(&[
        "import",
        arg(&bvh),
        "--bvh-map",
        arg(&map),
        "-o",
        arg(&out2),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("uses `hips`, which is neither a joint of the clip nor a virtual point (the clip's joints: pelvis_jnt, "),
        "{}",
        stderr(&o)
    );
    let o = autoact(&[
        "import",
        arg(&bvh),
        "--bvh-map",
        arg(&map),
        "--format",
        "ntu",
        "-o",
        arg(&out2),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("--bvh-map is for BVH input only"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn a_bvh_value_of_minus_1e308_is_refused_with_its_line() {
    use crate::common::arg;
    let dir = tempfile::tempdir().unwrap();
    let bvh = dir.path().join("far.bvh");
    std::fs::write(
        &bvh,
        UNKNOWN_SKELETON_BVH.replace("1 95 0 0 5", "1 95 -1e308 0 5"),
    )
    .unwrap();
    let out = dir.path().join("far.pose.mcap");
    let o = autoact(&["import", arg(&bvh), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains(&format!(
            "{}:39: frame 1, column 2 (pelvis_jnt Zposition): value -1e308 is not physical",
            bvh.display()
        )),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}
