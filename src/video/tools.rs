//! The `ffmpeg` / `ffprobe` installation: finding it, downloading it on request, and running it
//! to capture its output.
//!
//! Search order ([`Ffmpeg::locate`]):
//! 1. `AUTOACT_FFMPEG`: a path to an `ffmpeg` binary (or a bare name looked up on `PATH`).
//!    `ffprobe` is then `AUTOACT_FFPROBE` if set, else the `ffprobe` beside that binary, else
//!    `ffprobe` on `PATH`.
//! 2. `ffmpeg` on `PATH` (with `ffprobe` beside it, else on `PATH`).
//! 3. The download cache ([`download_cache_dir`]), filled by an earlier [`Ffmpeg::download`].

use std::ffi::{OsStr, OsString};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use super::VideoError;
use super::stderr_tail::tail_of_text;

/// How to install ffmpeg; part of every [`VideoError::NotFound`] message.
pub const INSTALL_HINT: &str = "Install ffmpeg (it includes ffprobe): `sudo apt-get install ffmpeg` \
(Debian, Ubuntu), `sudo dnf install ffmpeg` (Fedora, with RPM Fusion enabled) or `brew install ffmpeg` \
(macOS). Or set `AUTOACT_FFMPEG` to the path of an ffmpeg binary. Or pass `--download-ffmpeg` to \
fetch a static ffmpeg build into the user cache (needs autoact built with the `download-ffmpeg` \
feature).";

/// The environment variable naming the `ffmpeg` binary to use.
pub const FFMPEG_ENV: &str = "AUTOACT_FFMPEG";
/// The environment variable naming the `ffprobe` binary to use.
pub const FFPROBE_ENV: &str = "AUTOACT_FFPROBE";

/// An `ffmpeg` and an `ffprobe` binary to run.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ffmpeg {
    ffmpeg: PathBuf,
    ffprobe: PathBuf,
}

impl Ffmpeg {
    /// Finds `ffmpeg` and `ffprobe`: `AUTOACT_FFMPEG` (and `AUTOACT_FFPROBE`), else `PATH`, else
    /// the download cache. Nothing is run; see [`Ffmpeg::version`] for a check that it works.
    ///
    /// # Errors
    /// [`VideoError::NotFound`], whose message says where we looked and gives the install
    /// commands (`sudo apt-get install ffmpeg`, dnf, brew) and the download option.
    pub fn locate() -> Result<Ffmpeg, VideoError> {
        Ffmpeg::locate_with(|name| std::env::var_os(name))
    }

    /// [`Ffmpeg::locate`] reading environment variables (`AUTOACT_FFMPEG`, `AUTOACT_FFPROBE`,
    /// `PATH`, `XDG_CACHE_HOME`, `HOME`) through `env` instead of the process environment.
    ///
    /// # Errors
    /// As [`Ffmpeg::locate`].
    pub fn locate_with(env: impl Fn(&str) -> Option<OsString>) -> Result<Ffmpeg, VideoError> {
        let path_var = env("PATH").unwrap_or_default();
        let ffmpeg_name = exe_name("ffmpeg");
        let ffprobe_name = exe_name("ffprobe");

        let ffmpeg = if let Some(chosen) = env(FFMPEG_ENV).filter(|v| !v.is_empty()) {
            resolve(&chosen, &path_var).ok_or_else(|| VideoError::NotFound {
                program: "ffmpeg",
                detail: format!(
                    "`{FFMPEG_ENV}` is `{}`, which is not an executable file",
                    Path::new(&chosen).display()
                ),
            })?
        } else if let Some(found) = search_path(&ffmpeg_name, &path_var) {
            found
        } else if let Some(found) = download_cache_dir_with(&env)
            .map(|dir| dir.join(&ffmpeg_name))
            .filter(|p| is_executable(p))
        {
            found
        } else {
            let cache = download_cache_dir_with(&env).map_or_else(
                || String::from("(no cache directory: neither `XDG_CACHE_HOME` nor `HOME` is set)"),
                |d| format!("`{}`", d.display()),
            );
            return Err(VideoError::NotFound {
                program: "ffmpeg",
                detail: format!(
                    "`{FFMPEG_ENV}` is not set, no `ffmpeg` on `PATH`, none in the download cache {cache}"
                ),
            });
        };

        let ffprobe = if let Some(chosen) = env(FFPROBE_ENV).filter(|v| !v.is_empty()) {
            resolve(&chosen, &path_var).ok_or_else(|| VideoError::NotFound {
                program: "ffprobe",
                detail: format!(
                    "`{FFPROBE_ENV}` is `{}`, which is not an executable file",
                    Path::new(&chosen).display()
                ),
            })?
        } else if let Some(beside) = ffmpeg
            .parent()
            .map(|dir| dir.join(&ffprobe_name))
            .filter(|p| is_executable(p))
        {
            beside
        } else if let Some(found) = search_path(&ffprobe_name, &path_var) {
            found
        } else {
            return Err(VideoError::NotFound {
                program: "ffprobe",
                detail: format!(
                    "found `{}`, but no `ffprobe` beside it or on `PATH` (set `{FFPROBE_ENV}`)",
                    ffmpeg.display()
                ),
            });
        };
        Ok(Ffmpeg { ffmpeg, ffprobe })
    }

    /// Uses these two binaries as they are (not checked until run).
    #[must_use]
    pub fn from_paths(ffmpeg: impl Into<PathBuf>, ffprobe: impl Into<PathBuf>) -> Ffmpeg {
        Ffmpeg {
            ffmpeg: ffmpeg.into(),
            ffprobe: ffprobe.into(),
        }
    }

    /// Downloads a static ffmpeg build into [`download_cache_dir`] (reusing one already there)
    /// and returns it. Only call this when the user asked for it (`--download-ffmpeg`).
    ///
    /// What it fetches: the archive named by `ffmpeg_sidecar::download::ffmpeg_download_url()`
    /// of `ffmpeg-sidecar` 2.7 — on Linux (x86-64 and arm64) the "latest" GPL static build of
    /// BtbN's FFmpeg-Builds GitHub releases (ffmpeg 9.0, `.tar.xz`, about 100 MB unpacked); on
    /// Windows the gyan.dev "release essentials" zip; on macOS a static build from
    /// martin-riedl.de (Intel) or osxexperts.net (Apple silicon). It is fetched over HTTPS with no
    /// further checksum or signature check, unpacked, and only `ffmpeg`, `ffprobe` and `ffplay`
    /// are kept. The package manager's ffmpeg is the better choice wherever there is one.
    ///
    /// # Errors
    /// [`VideoError::Download`] when this build lacks the `download-ffmpeg` cargo feature, when
    /// there is no cache directory, or when the download or unpacking fails.
    pub fn download() -> Result<Ffmpeg, VideoError> {
        let env = |name: &str| std::env::var_os(name);
        let Some(dir) = download_cache_dir_with(&env) else {
            return Err(VideoError::Download {
                dir: PathBuf::new(),
                detail: "neither `XDG_CACHE_HOME` nor `HOME` is set".into(),
            });
        };
        if let Some(found) = Ffmpeg::in_dir(&dir) {
            return Ok(found);
        }
        download_into(&dir)?;
        Ffmpeg::in_dir(&dir).ok_or_else(|| VideoError::Download {
            dir: dir.clone(),
            detail: "the archive did not contain both `ffmpeg` and `ffprobe`".into(),
        })
    }

    /// [`Ffmpeg::locate`]; if that finds none and `download` allows it (`--download-ffmpeg`),
    /// [`Ffmpeg::download`].
    ///
    /// # Errors
    /// [`VideoError::NotFound`] (with the install command) or the download failing.
    pub fn locate_or_download(download: bool) -> Result<Ffmpeg, VideoError> {
        match Ffmpeg::locate() {
            Ok(found) => Ok(found),
            Err(e) if download => {
                tracing::warn!("{e}; downloading ffmpeg as --download-ffmpeg allows");
                Ffmpeg::download()
            }
            Err(e) => Err(e),
        }
    }

    fn in_dir(dir: &Path) -> Option<Ffmpeg> {
        let ffmpeg = dir.join(exe_name("ffmpeg"));
        let ffprobe = dir.join(exe_name("ffprobe"));
        (is_executable(&ffmpeg) && is_executable(&ffprobe)).then_some(Ffmpeg { ffmpeg, ffprobe })
    }

    /// The `ffmpeg` binary.
    #[must_use]
    pub fn ffmpeg_path(&self) -> &Path {
        &self.ffmpeg
    }

    /// The `ffprobe` binary.
    #[must_use]
    pub fn ffprobe_path(&self) -> &Path {
        &self.ffprobe
    }

    /// The version `ffmpeg -version` reports, e.g. `5.1.9-0+deb12u1`.
    ///
    /// # Errors
    /// [`VideoError::Spawn`] or [`VideoError::Exited`] if `ffmpeg` does not run,
    /// [`VideoError::Probe`] if its first line is not `ffmpeg version …`.
    pub fn version(&self) -> Result<String, VideoError> {
        let stdout = self.run_ffmpeg(["-hide_banner", "-version"], &self.ffmpeg)?;
        let text = String::from_utf8_lossy(&stdout);
        text.lines()
            .next()
            .and_then(|line| line.strip_prefix("ffmpeg version "))
            .and_then(|rest| rest.split_whitespace().next())
            .map(str::to_owned)
            .ok_or_else(|| VideoError::Probe {
                path: self.ffmpeg.clone(),
                detail: format!(
                    "`-version` printed `{}`, not `ffmpeg version …`",
                    text.lines().next().unwrap_or("")
                ),
            })
    }

    /// Runs `ffmpeg` with `args` (stdin closed), returning its stdout. `file` names the file the
    /// command works on, for error messages.
    pub(crate) fn run_ffmpeg<I, S>(&self, args: I, file: &Path) -> Result<Vec<u8>, VideoError>
    where
        I: IntoIterator<Item = S>,
        S: AsRef<OsStr>,
    {
        run_capture("ffmpeg", &self.ffmpeg, args, file)
    }

    /// Runs `ffprobe` with `args` (stdin closed), returning its stdout.
    pub(crate) fn run_ffprobe<I, S>(&self, args: I, file: &Path) -> Result<Vec<u8>, VideoError>
    where
        I: IntoIterator<Item = S>,
        S: AsRef<OsStr>,
    {
        run_capture("ffprobe", &self.ffprobe, args, file)
    }
}

/// Where [`Ffmpeg::download`] puts ffmpeg: `$XDG_CACHE_HOME/autoact/ffmpeg`, else
/// `$HOME/.cache/autoact/ffmpeg`; `None` if neither variable is set.
#[must_use]
pub fn download_cache_dir() -> Option<PathBuf> {
    download_cache_dir_with(&|name: &str| std::env::var_os(name))
}

fn download_cache_dir_with(env: &impl Fn(&str) -> Option<OsString>) -> Option<PathBuf> {
    let base = env("XDG_CACHE_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| {
            env("HOME")
                .filter(|v| !v.is_empty())
                .map(|home| PathBuf::from(home).join(".cache"))
        })?;
    Some(base.join("autoact").join("ffmpeg"))
}

#[cfg(feature = "download-ffmpeg")]
fn download_into(dir: &Path) -> Result<(), VideoError> {
    use ffmpeg_sidecar::download::{download_ffmpeg_package, ffmpeg_download_url, unpack_ffmpeg};
    let failed = |e: anyhow::Error| VideoError::Download {
        dir: dir.to_path_buf(),
        detail: format!("{e:#}"),
    };
    std::fs::create_dir_all(dir).map_err(|source| VideoError::Io {
        action: "create",
        path: dir.to_path_buf(),
        source,
    })?;
    let url = ffmpeg_download_url().map_err(failed)?;
    tracing::info!(url, dir = %dir.display(), "downloading ffmpeg");
    let archive = download_ffmpeg_package(url, dir).map_err(failed)?;
    unpack_ffmpeg(&archive, dir).map_err(failed)
}

#[cfg(not(feature = "download-ffmpeg"))]
fn download_into(dir: &Path) -> Result<(), VideoError> {
    Err(VideoError::Download {
        dir: dir.to_path_buf(),
        detail:
            "this autoact was built without the `download-ffmpeg` feature. Install ffmpeg with \
                 `sudo apt-get install ffmpeg` (or dnf, brew), or rebuild autoact with \
                 `--features download-ffmpeg`"
                .into(),
    })
}

fn run_capture<I, S>(
    program: &'static str,
    binary: &Path,
    args: I,
    file: &Path,
) -> Result<Vec<u8>, VideoError>
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let mut command = Command::new(binary);
    command.args(args);
    run(program, &mut command, file).map(|output| output.stdout)
}

/// Runs `command` (the program `program`, working on `file`) to the end with stdin closed, and
/// returns its output; a program that cannot start or exits unsuccessfully is an error with the
/// tail of what it wrote to stderr.
pub(crate) fn run(
    program: &'static str,
    command: &mut Command,
    file: &Path,
) -> Result<std::process::Output, VideoError> {
    // `output()` reads stdout and stderr concurrently, so neither pipe can fill up and block.
    let output = command
        .stdin(Stdio::null())
        .output()
        .map_err(|source| spawn_error(program, Path::new(command.get_program()), source))?;
    if output.status.success() {
        Ok(output)
    } else {
        Err(VideoError::Exited {
            program,
            status: output.status,
            path: file.to_path_buf(),
            stderr_tail: tail_of_text(&output.stderr),
        })
    }
}

/// The error for a program that could not be started: [`VideoError::NotFound`] when it does not
/// exist, [`VideoError::Spawn`] otherwise.
pub(crate) fn spawn_error(
    program: &'static str,
    binary: &Path,
    source: std::io::Error,
) -> VideoError {
    if source.kind() == std::io::ErrorKind::NotFound {
        VideoError::NotFound {
            program,
            detail: format!("`{}` does not exist", binary.display()),
        }
    } else {
        VideoError::Spawn {
            program: binary.to_path_buf(),
            source,
        }
    }
}

/// `path` as an ffmpeg/ffprobe argument: a relative path starting with `-` gets a `./` so it is
/// not read as an option.
pub(crate) fn ffmpeg_path_arg(path: &Path) -> OsString {
    if path.as_os_str().as_encoded_bytes().first() == Some(&b'-') {
        Path::new(".").join(path).into_os_string()
    } else {
        path.as_os_str().to_owned()
    }
}

fn exe_name(stem: &str) -> String {
    format!("{stem}{}", std::env::consts::EXE_SUFFIX)
}

/// A path (used as is when it has a directory part) or a bare name looked up on `PATH`.
fn resolve(chosen: &OsStr, path_var: &OsStr) -> Option<PathBuf> {
    let path = Path::new(chosen);
    if path.components().count() > 1 || path.is_absolute() {
        is_executable(path).then(|| path.to_path_buf())
    } else {
        search_path(chosen, path_var)
    }
}

fn search_path(name: impl AsRef<OsStr>, path_var: &OsStr) -> Option<PathBuf> {
    std::env::split_paths(path_var)
        .filter(|dir| !dir.as_os_str().is_empty())
        .map(|dir| dir.join(name.as_ref()))
        .find(|candidate| is_executable(candidate))
}

fn is_executable(path: &Path) -> bool {
    let Ok(meta) = std::fs::metadata(path) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        meta.is_file() && meta.permissions().mode() & 0o111 != 0
    }
    #[cfg(not(unix))]
    {
        meta.is_file()
    }
}

#[cfg(test)]
mod tests {
    use std::ffi::OsString;

    use super::{Ffmpeg, VideoError};

    fn env_of(pairs: &[(&str, &str)]) -> impl Fn(&str) -> Option<OsString> {
        let pairs: Vec<(String, OsString)> = pairs
            .iter()
            .map(|(k, v)| ((*k).to_owned(), OsString::from(v)))
            .collect();
        move |name| {
            pairs
                .iter()
                .find(|(k, _)| k == name)
                .map(|(_, v)| v.clone())
        }
    }

    #[test]
    fn missing_override_is_not_found_with_install_hint() {
        let err = Ffmpeg::locate_with(env_of(&[
            ("AUTOACT_FFMPEG", "/nonexistent"),
            ("PATH", "/usr/bin:/bin"),
        ]))
        .unwrap_err();
        assert!(matches!(
            err,
            VideoError::NotFound {
                program: "ffmpeg",
                ..
            }
        ));
        let text = err.to_string();
        assert!(text.contains("/nonexistent"), "{text}");
        assert!(text.contains("sudo apt-get install ffmpeg"), "{text}");
        assert!(text.contains("brew install ffmpeg"), "{text}");
        assert!(text.contains("dnf install ffmpeg"), "{text}");
        assert!(text.contains("--download-ffmpeg"), "{text}");
    }

    #[test]
    fn empty_path_and_no_cache_is_not_found() {
        let dir = tempfile::tempdir().unwrap();
        let err = Ffmpeg::locate_with(env_of(&[
            ("PATH", dir.path().to_str().unwrap()),
            ("HOME", dir.path().to_str().unwrap()),
        ]))
        .unwrap_err();
        let text = err.to_string();
        assert!(text.contains("no `ffmpeg` on `PATH`"), "{text}");
        assert!(text.contains("sudo apt-get install ffmpeg"), "{text}");
    }

    #[cfg(unix)]
    #[test]
    fn finds_ffmpeg_and_ffprobe_side_by_side_on_path() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        for name in ["ffmpeg", "ffprobe"] {
            let p = dir.path().join(name);
            std::fs::write(&p, "#!/bin/sh\n").unwrap();
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o755)).unwrap();
        }
        let path = format!("/nonexistent-dir:{}", dir.path().display());
        let found = Ffmpeg::locate_with(env_of(&[("PATH", &path)])).unwrap();
        assert_eq!(found.ffmpeg_path(), dir.path().join("ffmpeg"));
        assert_eq!(found.ffprobe_path(), dir.path().join("ffprobe"));

        // Not executable: skipped.
        std::fs::set_permissions(
            dir.path().join("ffmpeg"),
            std::fs::Permissions::from_mode(0o644),
        )
        .unwrap();
        assert!(Ffmpeg::locate_with(env_of(&[("PATH", &path), ("HOME", "/nonexistent")])).is_err());
    }

    #[test]
    fn download_cache_dir_prefers_xdg() {
        let env = env_of(&[("XDG_CACHE_HOME", "/x"), ("HOME", "/h")]);
        assert_eq!(
            super::download_cache_dir_with(&env).unwrap(),
            std::path::Path::new("/x/autoact/ffmpeg")
        );
        let env = env_of(&[("HOME", "/h")]);
        assert_eq!(
            super::download_cache_dir_with(&env).unwrap(),
            std::path::Path::new("/h/.cache/autoact/ffmpeg")
        );
    }
}
