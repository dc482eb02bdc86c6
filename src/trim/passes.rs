//! The render's depth and mask passes (`autoact render --depth --masks`: one PNG per video
//! frame in `<video stem>.depth/` and `<video stem>.mask/` beside the capture video, see
//! [`crate::bags::render::depth_dir_beside`]) given to every clip: its frames linked (hard
//! links, copies across file systems) into `depth/<label>/<clip_id>/img_00001.png` … and
//! `masks/<label>/<clip_id>/img_00001.png` …, numbered like `--rawframes` so frame `i` of a
//! clip's video, rawframes, depth and mask are one instant.

use std::path::{Path, PathBuf};

use super::TrimError;

/// Folder of the clips' depth frames inside the dataset folder.
pub const DEPTH_DIR: &str = "depth";
/// Folder of the clips' mask frames inside the dataset folder.
pub const MASKS_DIR: &str = "masks";

/// The pass folders found beside a capture video.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PassSources {
    depth: Option<PathBuf>,
    mask: Option<PathBuf>,
}

/// Where one clip's passes went, relative to the dataset folder.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ClipPasses {
    /// `depth/<label>/<clip_id>`, when the video has a depth pass.
    pub depth: Option<String>,
    /// `masks/<label>/<clip_id>`, when the video has a mask pass.
    pub masks: Option<String>,
}

impl PassSources {
    /// The pass folders beside `video`, each checked to hold one frame per video frame, the
    /// last of them numbered `last_frame` (frames are numbered by the render's timeline: a
    /// render that drew only some frames numbers them with gaps).
    ///
    /// # Errors
    /// [`TrimError::PassFrames`] naming a folder whose frames are not the video's.
    pub fn beside(
        video: &Path,
        video_frames: u64,
        last_frame: Option<u64>,
    ) -> Result<PassSources, TrimError> {
        let found = |dir: PathBuf| -> Result<Option<PathBuf>, TrimError> {
            if !dir.is_dir() {
                return Ok(None);
            }
            let frames = std::fs::read_dir(&dir)
                .map_err(TrimError::io("read", &dir))?
                .filter_map(Result::ok)
                .filter(|e| {
                    let name = e.file_name();
                    let name = name.to_string_lossy();
                    name.starts_with("frame_") && name.ends_with(".png")
                })
                .count() as u64;
            let complete = frames == video_frames
                && last_frame.is_none_or(|k| crate::bags::render::frame_file(&dir, k).is_file());
            if !complete {
                return Err(TrimError::PassFrames {
                    dir,
                    frames,
                    video_frames,
                });
            }
            Ok(Some(dir))
        };
        Ok(PassSources {
            depth: found(crate::bags::render::depth_dir_beside(video))?,
            mask: found(crate::bags::render::mask_dir_beside(video))?,
        })
    }

    /// Whether the video has any pass.
    #[must_use]
    pub fn any(&self) -> bool {
        self.depth.is_some() || self.mask.is_some()
    }

    /// Whether `passes` (a clip's, from the manifest) holds every pass this video has.
    #[must_use]
    pub fn covered_by(&self, passes: &ClipPasses) -> bool {
        (self.depth.is_none() || passes.depth.is_some())
            && (self.mask.is_none() || passes.masks.is_some())
    }

    /// Links video frames `start .. start + count` of every pass into the clip's folders in
    /// `dataset` (replacing what an interrupted run left there).
    ///
    /// # Errors
    /// [`TrimError::Io`] naming the file.
    pub fn link_clip(
        &self,
        dataset: &Path,
        label_dir: &str,
        clip_id: &str,
        start: u64,
        count: u64,
    ) -> Result<ClipPasses, TrimError> {
        let link = |source: &Option<PathBuf>, kind: &str| -> Result<Option<String>, TrimError> {
            let Some(source) = source else {
                return Ok(None);
            };
            let rel = format!("{kind}/{label_dir}/{clip_id}");
            let out = dataset.join(&rel);
            if out.exists() {
                std::fs::remove_dir_all(&out).map_err(TrimError::io("replace", &out))?;
            }
            std::fs::create_dir_all(&out).map_err(TrimError::io("create", &out))?;
            for i in 0..count {
                let from = crate::bags::render::frame_file(source, start + i);
                let to = out.join(format!("img_{:05}.png", i + 1));
                crate::atomic_file::link_or_copy(&from, &to)
                    .map_err(TrimError::io("copy", &from))?;
            }
            Ok(Some(rel))
        };
        Ok(ClipPasses {
            depth: link(&self.depth, DEPTH_DIR)?,
            masks: link(&self.mask, MASKS_DIR)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pass(dir: &Path, name: &str, frames: u64) {
        let d = dir.join(name);
        std::fs::create_dir_all(&d).unwrap();
        for k in 0..frames {
            std::fs::write(
                crate::bags::render::frame_file(&d, k),
                format!("{name} {k}"),
            )
            .unwrap();
        }
    }

    #[test]
    fn a_clip_gets_its_own_frames_of_every_pass_numbered_from_one() {
        let dir = tempfile::tempdir().unwrap();
        let video = dir.path().join("v.mp4");
        pass(dir.path(), "v.depth", 10);
        pass(dir.path(), "v.mask", 10);
        let sources = PassSources::beside(&video, 10, Some(9)).unwrap();
        let ds = dir.path().join("ds");
        let got = sources.link_clip(&ds, "wave", "c1", 4, 3).unwrap();
        assert_eq!(got.depth.as_deref(), Some("depth/wave/c1"));
        assert_eq!(got.masks.as_deref(), Some("masks/wave/c1"));
        let read = |p: &str| std::fs::read_to_string(ds.join(p)).unwrap();
        assert_eq!(read("depth/wave/c1/img_00001.png"), "v.depth 4");
        assert_eq!(read("masks/wave/c1/img_00003.png"), "v.mask 6");
        assert!(!ds.join("depth/wave/c1/img_00004.png").exists());
        // Again (a re-run): the same files, nothing left over.
        sources.link_clip(&ds, "wave", "c1", 4, 2).unwrap();
        assert!(!ds.join("depth/wave/c1/img_00003.png").exists());
    }

    #[test]
    fn a_pass_that_is_not_the_videos_is_refused_by_name_and_no_pass_is_fine() {
        let dir = tempfile::tempdir().unwrap();
        let video = dir.path().join("v.mp4");
        assert!(!PassSources::beside(&video, 10, Some(9)).unwrap().any());
        pass(dir.path(), "v.mask", 9);
        let e = PassSources::beside(&video, 10, Some(9))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("v.mask") && e.contains(" 9 ") && e.contains(" 10"),
            "{e}"
        );
    }
}
