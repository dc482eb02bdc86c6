//! Every bag output appears whole or not at all, and nothing is replaced without `--force`
//! (issue 20, item 4): an existing output is refused before anything is read; a write that fails
//! half-way (a full disk, simulated with a file-size limit) leaves no file under the final name,
//! no `.part`, and an existing output untouched; `-o /dev/null` works.

use std::path::Path;
use std::process::{Command, Output};

use crate::common::{arg, autoact, repo, stderr};

/// Runs `autoact` in a shell whose file-size limit is `limit_kib` (with SIGXFSZ ignored, a write
/// past the limit fails with EFBIG, as a write onto a full disk fails with ENOSPC).
fn autoact_with_full_disk(limit_kib: u32, args: &[&str]) -> Output {
    let quoted: Vec<String> = args.iter().map(|a| format!("'{a}'")).collect();
    Command::new("sh")
        .arg("-c")
        .arg(format!(
            "trap '' XFSZ; ulimit -f {limit_kib}; exec '{}' {}",
            env!("CARGO_BIN_EXE_autoact"),
            quoted.join(" ")
        ))
        .output()
        .expect("run sh")
}

fn names_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .expect("list the folder")
        .map(|e| {
            e.expect("a folder entry")
                .file_name()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    names.sort();
    names
}

#[test]
fn an_existing_output_is_refused_without_force_and_replaced_with_it() {
    let dir = tempfile::tempdir().unwrap();
    let pose = repo("bags/bandai_wave.pose.mcap");
    let out = dir.path().join("wave.anim.mcap");
    for rosbag2 in [false, true] {
        let out = if rosbag2 {
            dir.path().join("wave_anim")
        } else {
            out.clone()
        };
        let mut args = vec!["convert", pose.as_str(), "-o", arg(&out)];
        if rosbag2 {
            args.push("--rosbag2");
        }
        let o = autoact(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let o = autoact(&args);
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("exists; pass --force"),
            "{}",
            stderr(&o)
        );
        args.push("--force");
        let o = autoact(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    // import and plan -o follow the same rule, before reading their input (which here is not
    // even a BVH file).
    let bvh = dir.path().join("clip.bvh");
    std::fs::write(&bvh, b"not read").unwrap();
    let pose_out = dir.path().join("clip.pose.mcap");
    std::fs::write(&pose_out, b"keep me").unwrap();
    let o = autoact(&["import", arg(&bvh), "-o", arg(&pose_out)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(std::fs::read(&pose_out).unwrap(), b"keep me");
    let plan_out = dir.path().join("plan.csv");
    std::fs::write(&plan_out, b"keep me").unwrap();
    let spec = repo("examples/dataset.toml");
    let o = autoact(&["plan", &spec, "--format", "csv", "-o", arg(&plan_out)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(std::fs::read(&plan_out).unwrap(), b"keep me");
    let o = autoact(&[
        "plan",
        &spec,
        "--format",
        "csv",
        "-o",
        arg(&plan_out),
        "--force",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_ne!(std::fs::read(&plan_out).unwrap(), b"keep me");
}

#[test]
fn a_full_disk_leaves_no_truncated_file_and_the_old_output_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let pose = repo("bags/bandai_walk.pose.mcap");
    let out = dir.path().join("walk.anim.mcap");
    let o = autoact(&["convert", pose.as_str(), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let good = std::fs::read(&out).unwrap();
    assert!(good.len() > 40 * 1024, "the bag must outgrow the limit");
    // A new output on a full disk: nothing appears.
    let fresh = dir.path().join("fresh.anim.mcap");
    let o = autoact_with_full_disk(16, &["convert", pose.as_str(), "-o", arg(&fresh)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("fresh.anim.mcap"), "{}", stderr(&o));
    // Replacing an output on a full disk: the old one stays as it was.
    let o = autoact_with_full_disk(16, &["convert", pose.as_str(), "-o", arg(&out), "--force"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(&out).unwrap(),
        good,
        "the old output was touched"
    );
    // The same for a rosbag2 directory.
    let folder = dir.path().join("walk_anim");
    let o = autoact_with_full_disk(
        16,
        &["convert", pose.as_str(), "-o", arg(&folder), "--rosbag2"],
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    // With DSI, the clip's keys wait in a temporary file in the output's folder: a full disk
    // stops them there, with an error that says so, and leaves nothing behind.
    let o = autoact_with_full_disk(16, &["convert", pose.as_str(), "-o", arg(&fresh), "--dsi"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("temporary file for the clip's key frames"),
        "{}",
        stderr(&o)
    );
    assert_eq!(names_in(dir.path()), ["walk.anim.mcap"], "leftovers");
}

#[test]
fn a_device_output_is_written_in_place_and_never_replaced() {
    let pose = repo("bags/bandai_wave.pose.mcap");
    for command in [
        vec!["convert", pose.as_str(), "-o", "/dev/null"],
        vec!["convert", pose.as_str(), "-o", "/dev/null", "--force"],
        // DSI's keys go to the system's temporary folder, not next to the device.
        vec!["convert", pose.as_str(), "-o", "/dev/null", "--dsi"],
    ] {
        let o = autoact(&command);
        assert_eq!(o.status.code(), Some(0), "{command:?}: {}", stderr(&o));
    }
    let meta = std::fs::metadata("/dev/null").unwrap();
    assert!(!meta.is_file(), "/dev/null was replaced by a file");
    let o = autoact(&["convert", pose.as_str(), "-o", "/dev/null", "--rosbag2"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    // A full device fails cleanly, with the output named.
    let o = autoact(&["convert", pose.as_str(), "-o", "/dev/full"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("/dev/full"), "{}", stderr(&o));
}

#[test]
fn convert_spec_refuses_a_folder_holding_its_dataset_before_converting() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("captures");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("plan.json"), b"keep me").unwrap();
    let spec = repo("examples/dataset.toml");
    let o = autoact(&["convert", "--spec", &spec, "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("plan.json exists"), "{}", stderr(&o));
    assert!(
        !stderr(&o).contains("converting"),
        "refused after converting"
    );
    assert_eq!(std::fs::read(out.join("plan.json")).unwrap(), b"keep me");
}
