//! Helpers shared by the integration tests that run the `autoact` binary.

use std::process::{Command, Output};

/// Runs `autoact` with `args`.
pub fn autoact(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_autoact"))
        .args(args)
        .output()
        .expect("run autoact")
}

/// A run's stdout as text.
#[allow(dead_code, reason = "not every test binary reads stdout through this")]
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// A run's stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// ffmpeg, or `None` after saying loudly on stderr that `test` is skipped (CI installs ffmpeg).
#[allow(dead_code, reason = "only the tests that encode video use it")]
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
