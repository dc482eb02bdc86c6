//! The Blender engine: the capture's frames rendered by Blender Cycles through the PyPI `bpy`
//! module (a venv that `tools/setup-blender.sh` makes), behind the same `autoact render`.
//!
//! autoact hands Blender exactly the embedded renderer's scene — the body mesh skinned for each
//! frame, the props' and backdrop's meshes, the ground's textures, the environment's light,
//! sky, fog and precipitation, and the capture's camera per frame — as a manifest (JSON) and
//! one binary file of arrays; `tools/blender_engine.py` (embedded here, written beside the
//! manifest) builds it in Blender and writes each frame's PNG and, when asked, its depth (Z
//! pass) and person mask (object index pass). autoact then encodes the frames exactly as it
//! encodes its own (keyframes on every boundary) and writes the render bag.
//!
//! **Labels.** The annotations do not come from Blender: they are computed by the same code as
//! for the embedded engine ([`super::annotate`]) from the capture's skeleton and camera and the
//! embedded renderer's depth and surface buffers of the same frame, so the render bags of the
//! two engines carry identical `/render/annotations`. Visibility therefore uses the embedded
//! renderer's depth, not Blender's; both draw the same meshes from the same camera, so they
//! differ only by sampling at silhouette edges (the CI check measures that ≥ 95 % of visible
//! joints fall on Blender's person mask). The depth and mask *passes* written beside the video
//! are Blender's.

use std::io::{BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};

use serde_json::{Value, json};

use super::passes::{FramePasses, PERSON_ID, Wanted};
use super::world::{GroundTexture, Mesh, Surface};
use super::{Camera, Image, Stage};
use crate::scene::weather::Precipitation;

/// The bpy script, written beside the manifest at run time.
pub const SCRIPT: &str = include_str!("../../tools/blender_engine.py");

/// What makes the venv with `bpy`.
pub const SETUP_SCRIPT: &str = "tools/setup-blender.sh";

/// Exit status of the script when its Python has no `bpy`.
const NO_BPY_STATUS: i32 = 3;

/// Lines of Blender's output quoted when it fails.
const TAIL_LINES: usize = 25;

/// Which engine draws the frames.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Engine {
    /// The embedded CPU renderer ([`super::cpu::CpuRenderer`]).
    #[default]
    Embedded,
    /// Blender Cycles.
    Blender(BlenderSettings),
}

/// How Blender renders.
#[derive(Debug, Clone, PartialEq)]
pub struct BlenderSettings {
    /// The Python that has `bpy`; default [`default_python`].
    pub python: Option<PathBuf>,
    /// Cycles samples per pixel.
    pub samples: u32,
    /// Denoise (OpenImageDenoise) after sampling.
    pub denoise: bool,
    /// Render threads (default: all cores).
    pub threads: Option<usize>,
}

/// Cycles samples per pixel by default.
pub const DEFAULT_SAMPLES: u32 = 16;

impl Default for BlenderSettings {
    fn default() -> Self {
        BlenderSettings {
            python: None,
            samples: DEFAULT_SAMPLES,
            denoise: true,
            threads: None,
        }
    }
}

/// Why the Blender engine failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BlenderError {
    /// No Python with `bpy`.
    #[error(
        "the Blender engine needs a Python with `bpy`: {reason} (`{}`); run {SETUP_SCRIPT} \
         (it makes {}) or pass --blender-python PATH",
        python.display(),
        default_venv().display()
    )]
    NoBpy {
        /// The Python tried.
        python: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// Blender (the script) exited with an error.
    #[error("Blender failed ({status}); the last lines it printed:\n{tail}")]
    Failed {
        /// Its exit status.
        status: String,
        /// The end of its output.
        tail: String,
    },
    /// A file system error.
    #[error("cannot {action} `{}`: {source}", path.display())]
    Io {
        /// What was being done.
        action: &'static str,
        /// The path.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A frame Blender wrote is missing or not what was asked.
    #[error("`{}`: {reason}", path.display())]
    BadFrame {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// Stopped by a signal.
    #[error("interrupted")]
    Interrupted,
}

fn io<'a>(
    action: &'static str,
    path: &'a Path,
) -> impl FnOnce(std::io::Error) -> BlenderError + 'a {
    move |source| BlenderError::Io {
        action,
        path: path.to_path_buf(),
        source,
    }
}

/// The venv `tools/setup-blender.sh` makes: `$AUTOACT_BLENDER_VENV`, else
/// `~/.cache/autoact-ci/blender-venv`.
#[must_use]
pub fn default_venv() -> PathBuf {
    if let Some(v) = std::env::var_os("AUTOACT_BLENDER_VENV") {
        return PathBuf::from(v);
    }
    let home = std::env::var_os("HOME").map_or_else(|| PathBuf::from("/root"), PathBuf::from);
    home.join(".cache/autoact-ci/blender-venv")
}

/// The Python to run: `explicit`, else `$AUTOACT_BLENDER_PYTHON`, else the default venv's.
#[must_use]
pub fn default_python(explicit: Option<&Path>) -> PathBuf {
    if let Some(p) = explicit {
        return p.to_path_buf();
    }
    if let Some(p) = std::env::var_os("AUTOACT_BLENDER_PYTHON") {
        return PathBuf::from(p);
    }
    default_venv().join("bin/python")
}

/// One frame for Blender: which scene, when, the camera and the skinned body.
#[derive(Debug, Clone)]
pub struct BlenderFrame {
    /// Index of the stage.
    pub scene: usize,
    /// Seconds since the scene started.
    pub time_s: f64,
    /// The camera at the output resolution.
    pub camera: Camera,
    /// The body's vertices for this frame (the stage's mesh, skinned), world frame, metres.
    pub body_m: Vec<[f32; 3]>,
}

/// What a run needs besides the frames.
#[derive(Debug, Clone, Copy)]
pub struct BlenderJob<'a> {
    /// How to render.
    pub settings: &'a BlenderSettings,
    /// Every scene (frames refer to them by index).
    pub stages: &'a [Stage],
    /// Output width, pixels.
    pub width: u32,
    /// Output height, pixels.
    pub height: u32,
    /// The passes to read back.
    pub wanted: Wanted,
}

/// Frames Blender rendered, in a temporary folder, to be read back in order.
#[derive(Debug)]
pub struct BlenderFrames {
    dir: tempfile::TempDir,
    width: u32,
    height: u32,
    wanted: Wanted,
    /// What Blender said it runs on (`Blender 5.2.3 LTS, Cycles on CPU`).
    pub description: String,
}

/// Appends arrays to the binary file and names them by offset and count.
struct Blob {
    file: BufWriter<std::fs::File>,
    path: PathBuf,
    offset: u64,
}

impl Blob {
    fn create(path: &Path) -> Result<Blob, BlenderError> {
        let file = std::fs::File::create(path).map_err(io("create", path))?;
        Ok(Blob {
            file: BufWriter::new(file),
            path: path.to_path_buf(),
            offset: 0,
        })
    }

    fn put<const N: usize>(
        &mut self,
        count: usize,
        bytes: impl Iterator<Item = [u8; N]>,
    ) -> Result<Value, BlenderError> {
        let at = self.offset;
        for b in bytes {
            self.file.write_all(&b).map_err(io("write", &self.path))?;
            self.offset += N as u64;
        }
        Ok(json!({"offset": at, "count": count}))
    }

    fn f32s(&mut self, values: &[[f32; 3]]) -> Result<Value, BlenderError> {
        self.put(
            3 * values.len(),
            values.iter().flatten().map(|v| v.to_le_bytes()),
        )
    }

    fn u32s(&mut self, values: &[u32]) -> Result<Value, BlenderError> {
        self.put(values.len(), values.iter().map(|v| v.to_le_bytes()))
    }

    fn finish(mut self) -> Result<(), BlenderError> {
        self.file.flush().map_err(io("write", &self.path))
    }
}

fn mesh_json(blob: &mut Blob, mesh: &Mesh) -> Result<Value, BlenderError> {
    Ok(json!({
        "positions": blob.f32s(&mesh.positions)?,
        "normals": blob.f32s(&mesh.normals)?,
        "albedo": blob.f32s(&mesh.albedo)?,
        "indices": blob.u32s(&mesh.indices)?,
    }))
}

fn texture_json(blob: &mut Blob, texture: &GroundTexture) -> Result<Value, BlenderError> {
    let (size, texels) = texture.texels();
    Ok(json!({"tile_m": texture.tile_m(), "size": size, "texels": blob.f32s(texels)?}))
}

/// The scene as the script builds it.
fn stage_json(blob: &mut Blob, stage: &Stage) -> Result<Value, BlenderError> {
    let env = &stage.environment;
    let (kind, rate) = env.precipitation;
    let kind = match kind {
        Precipitation::None => "none",
        Precipitation::Rain => "rain",
        Precipitation::Snow => "snow",
    };
    let ground = &stage.world.ground;
    Ok(json!({
        "seed": stage.seed,
        "environment": {
            "key_dir": env.key_dir,
            "key_rgb": env.key_rgb,
            "key_shadows": env.key_shadows,
            "sky_ambient_rgb": env.sky_ambient_rgb,
            "ground_ambient_rgb": env.ground_ambient_rgb,
            "zenith_rgb": env.zenith_rgb,
            "horizon_rgb": env.horizon_rgb,
            "fog_per_m": env.fog_per_m,
            "precipitation": [kind, rate],
            "wind_m_per_s": env.wind_m_per_s,
            "wetness": env.wetness,
            "indoor": env.indoor,
        },
        "body": {
            "vertices": stage.body.rest_positions_m.len(),
            "indices": blob.u32s(&stage.body.indices)?,
            "albedo": blob.f32s(&stage.body_vertex_albedo)?,
        },
        "props": mesh_json(blob, &stage.world.props)?,
        "backdrop": mesh_json(blob, &stage.world.backdrop)?,
        "ground": {
            "floor": texture_json(blob, &ground.floor)?,
            "surround": texture_json(blob, &ground.surround)?,
            "floor_half_m": ground.floor_half_m,
            "water": ground.water,
            "water_rgb": ground.water_rgb,
        },
    }))
}

fn frame_json(blob: &mut Blob, frame: &BlenderFrame) -> Result<Value, BlenderError> {
    let m = frame.camera.world_from_optical.to_homogeneous();
    let rows: Vec<f64> = (0..4)
        .flat_map(|r| (0..4).map(move |c| m[(r, c)]))
        .collect();
    let k = &frame.camera.intrinsics;
    Ok(json!({
        "scene": frame.scene,
        "time_s": frame.time_s,
        "world_from_optical": rows,
        "fx": k.fx_px, "fy": k.fy_px, "cx": k.cx_px, "cy": k.cy_px,
        "body": blob.f32s(&frame.body_m)?,
    }))
}

/// Renders `count` frames with Blender; `frame(k)` gives frame `k`. `progress` is called with
/// the frames done; setting `stop` kills Blender.
///
/// # Errors
/// [`BlenderError`]: no `bpy`, Blender failing (with the end of its output), I/O.
pub fn render(
    job: &BlenderJob<'_>,
    count: usize,
    frame: &dyn Fn(usize) -> BlenderFrame,
    progress: &(dyn Fn(u64) + Sync),
    stop: &AtomicBool,
) -> Result<BlenderFrames, BlenderError> {
    let dir = tempfile::Builder::new()
        .prefix("autoact-blender-")
        .tempdir()
        .map_err(io("create a temporary folder in", &std::env::temp_dir()))?;
    let data = dir.path().join("data.bin");
    let mut blob = Blob::create(&data)?;
    let scenes = job
        .stages
        .iter()
        .map(|s| stage_json(&mut blob, s))
        .collect::<Result<Vec<_>, _>>()?;
    let frames = (0..count)
        .map(|k| frame_json(&mut blob, &frame(k)))
        .collect::<Result<Vec<_>, _>>()?;
    blob.finish()?;
    let manifest = json!({
        "data": data,
        "out_dir": dir.path(),
        "width": job.width,
        "height": job.height,
        "samples": job.settings.samples,
        "denoise": job.settings.denoise,
        "threads": job.settings.threads,
        "depth": job.wanted.depth,
        "mask": job.wanted.mask,
        "scenes": scenes,
        "frames": frames,
    });
    let manifest_path = dir.path().join("manifest.json");
    std::fs::write(&manifest_path, manifest.to_string()).map_err(io("write", &manifest_path))?;
    let script = dir.path().join("blender_engine.py");
    std::fs::write(&script, SCRIPT).map_err(io("write", &script))?;
    let python = default_python(job.settings.python.as_deref());
    let description = run_script(&python, &script, &manifest_path, progress, stop)?;
    Ok(BlenderFrames {
        dir,
        width: job.width,
        height: job.height,
        wanted: job.wanted,
        description,
    })
}

/// Runs the script, following its `autoact-frame K SECONDS` lines; returns its first
/// `autoact-blender:` line (what renders).
fn run_script(
    python: &Path,
    script: &Path,
    manifest: &Path,
    progress: &(dyn Fn(u64) + Sync),
    stop: &AtomicBool,
) -> Result<String, BlenderError> {
    let log_path = manifest.with_file_name("blender.log");
    let log = std::fs::File::create(&log_path).map_err(io("create", &log_path))?;
    let mut child = Command::new(python)
        .arg(script)
        .arg(manifest)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(log)
        .spawn()
        .map_err(|e| BlenderError::NoBpy {
            python: python.to_path_buf(),
            reason: format!("cannot run it: {e}"),
        })?;
    let mut description = String::new();
    let mut tail: std::collections::VecDeque<String> = std::collections::VecDeque::new();
    if let Some(out) = child.stdout.take() {
        for line in BufReader::new(out).lines() {
            if stop.load(Ordering::Relaxed) {
                let _ = child.kill();
                let _ = child.wait();
                return Err(BlenderError::Interrupted);
            }
            let Ok(line) = line else { break };
            if let Some(k) = line.strip_prefix("autoact-frame ") {
                // `autoact-frame K SECONDS`
                if let Some(Ok(k)) = k.split_whitespace().next().map(str::parse::<u64>) {
                    progress(k + 1);
                }
            } else if let Some(d) = line.strip_prefix("autoact-blender: ") {
                // The first line says what renders; the last how long it took.
                if description.is_empty() {
                    d.clone_into(&mut description);
                }
                tracing::info!("{d}");
            } else {
                tail.push_back(line);
                if tail.len() > TAIL_LINES {
                    tail.pop_front();
                }
            }
        }
    }
    let status = child.wait().map_err(io("wait for", python))?;
    if stop.load(Ordering::Relaxed) {
        // Ctrl-C reaches Blender too (one process group): it stopped for the same reason.
        return Err(BlenderError::Interrupted);
    }
    if status.success() {
        return Ok(description);
    }
    let stderr = std::fs::read_to_string(&log_path).unwrap_or_default();
    let stderr_tail: Vec<&str> = stderr.lines().rev().take(TAIL_LINES).collect();
    if status.code() == Some(NO_BPY_STATUS) {
        return Err(BlenderError::NoBpy {
            python: python.to_path_buf(),
            reason: stderr_tail.first().map_or_else(
                || "`import bpy` failed".to_owned(),
                |l| l.trim_start_matches("autoact-blender: ").to_owned(),
            ),
        });
    }
    let mut lines: Vec<String> = tail.into_iter().collect();
    lines.extend(stderr_tail.into_iter().rev().map(str::to_owned));
    let keep = lines.len().saturating_sub(TAIL_LINES);
    Err(BlenderError::Failed {
        status: status.to_string(),
        tail: lines[keep..].join("\n"),
    })
}

impl BlenderFrames {
    /// Frame `k`: its sRGB pixels and the passes asked for (from Blender's depth and mask).
    ///
    /// # Errors
    /// [`BlenderError::BadFrame`] when a file is missing or of the wrong size.
    pub fn frame(&self, k: usize) -> Result<(Vec<u8>, FramePasses), BlenderError> {
        let stem = self.dir.path().join(format!("frame_{k:06}"));
        let png = stem.with_extension("png");
        let bad = |path: &Path, reason: String| BlenderError::BadFrame {
            path: path.to_path_buf(),
            reason,
        };
        let (w, h, rgb) = crate::video::read_png(&png).map_err(|e| bad(&png, e.to_string()))?;
        if (w, h) != (self.width, self.height) {
            return Err(bad(
                &png,
                format!("{w}x{h}, expected {}x{}", self.width, self.height),
            ));
        }
        let n = w as usize * h as usize;
        let mut image = Image::new(w, h);
        image.rgb = rgb;
        if self.wanted.depth {
            let path = stem.with_extension("depth");
            let bytes = std::fs::read(&path).map_err(|e| bad(&path, e.to_string()))?;
            if bytes.len() != 4 * n {
                return Err(bad(
                    &path,
                    format!("{} bytes, expected {}", bytes.len(), 4 * n),
                ));
            }
            for (d, b) in image.depth.iter_mut().zip(bytes.chunks_exact(4)) {
                let z = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                *d = if z > 0.0 { 1.0 / z } else { 0.0 };
            }
        }
        if self.wanted.mask {
            let path = stem.with_extension("mask");
            let bytes = std::fs::read(&path).map_err(|e| bad(&path, e.to_string()))?;
            if bytes.len() != n {
                return Err(bad(&path, format!("{} bytes, expected {n}", bytes.len())));
            }
            for (s, &b) in image.surface.iter_mut().zip(&bytes) {
                if b == PERSON_ID {
                    *s = Surface::Character as u8;
                }
            }
        }
        let passes = FramePasses::of(&image, self.wanted);
        Ok((image.rgb, passes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_python_names_the_setup_script() {
        let err = run_script(
            Path::new("/nonexistent/autoact/python"),
            Path::new("x.py"),
            &std::env::temp_dir().join("autoact-missing-manifest.json"),
            &|_| {},
            &AtomicBool::new(false),
        )
        .unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, BlenderError::NoBpy { .. }), "{text}");
        assert!(text.contains(SETUP_SCRIPT), "{text}");
        assert!(text.contains("/nonexistent/autoact/python"), "{text}");
    }

    #[test]
    fn a_python_without_bpy_names_the_setup_script() {
        // The script's own import check, with a Python that has no bpy.
        let python = PathBuf::from("python3");
        let dir = tempfile::tempdir().unwrap();
        let script = dir.path().join("blender_engine.py");
        std::fs::write(&script, "import sys\ntry:\n    import bpy_not_here\nexcept ImportError as e:\n    print(f'autoact-blender: {e}', file=sys.stderr)\n    sys.exit(3)\n").unwrap();
        let err = run_script(
            &python,
            &script,
            &dir.path().join("manifest.json"),
            &|_| {},
            &AtomicBool::new(false),
        )
        .unwrap_err();
        let text = err.to_string();
        assert!(text.contains("No module named 'bpy_not_here'"), "{text}");
        assert!(text.contains(SETUP_SCRIPT), "{text}");
    }

    #[test]
    fn a_failing_blender_quotes_its_output() {
        let python = PathBuf::from("python3");
        let dir = tempfile::tempdir().unwrap();
        let script = dir.path().join("fail.py");
        std::fs::write(
            &script,
            "import sys\nprint('rendering')\nraise RuntimeError('Cycles fell over')\n",
        )
        .unwrap();
        let err = run_script(
            &python,
            &script,
            &dir.path().join("manifest.json"),
            &|_| {},
            &AtomicBool::new(false),
        )
        .unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, BlenderError::Failed { .. }), "{text}");
        assert!(text.contains("RuntimeError: Cycles fell over"), "{text}");
        assert!(text.contains("rendering"), "{text}");
    }
}
