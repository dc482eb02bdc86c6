//! Helpers shared by the integration-test modules: running the `autoact` binary, paths of the
//! repository, ffmpeg or a loud skip.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `autoact` with `args`.
pub fn autoact(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_autoact"))
        .args(args)
        .output()
        .expect("run autoact")
}

/// A run's stdout as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A run's stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// ffmpeg, or `None` after saying loudly on stderr that `test` is skipped (CI installs ffmpeg).
#[allow(clippy::print_stderr, reason = "a loud skip")]
pub fn ffmpeg_or_skip(test: &str) -> Option<autoact::video::Ffmpeg> {
    match autoact::video::Ffmpeg::locate() {
        Ok(found) => Some(found),
        Err(e) => {
            eprintln!("SKIPPED {test}: no ffmpeg on this machine ({e})");
            None
        }
    }
}

/// `p` as a command-line argument (the tests' temporary paths are UTF-8).
pub fn arg(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}

/// A file of the repository, as an absolute path (for specs that name the sample bags).
pub fn repo(path: &str) -> String {
    format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))
}

/// Writes `spec` (a dataset spec of one session) into `dir`, runs `autoact convert --spec` on it
/// into `dir/capture`, and returns the one capture bag it made.
pub fn capture_bag_from_spec(dir: &Path, spec: &str) -> PathBuf {
    let bags = capture_bags_from_spec(dir, spec);
    assert_eq!(bags.len(), 1, "{bags:?}");
    bags.into_iter().next().expect("one bag")
}

/// Writes `spec` into `dir`, runs `autoact convert --spec` on it into `dir/capture` (bags and
/// `plan.json`), and returns every capture bag it made, sorted.
pub fn capture_bags_from_spec(dir: &Path, spec: &str) -> Vec<PathBuf> {
    let spec_path = dir.join("spec.toml");
    std::fs::write(&spec_path, spec).expect("write the spec");
    let out = dir.join("capture");
    let o = autoact(&[
        "-q",
        "convert",
        "--spec",
        spec_path.to_str().expect("UTF-8 path"),
        "-o",
        out.to_str().expect("UTF-8 path"),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut bags: Vec<PathBuf> = std::fs::read_dir(&out)
        .expect("the capture folder")
        .map(|e| e.expect("a folder entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    bags.sort();
    bags
}
