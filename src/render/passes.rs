//! Per-pixel label passes of rendered frames, written beside the video as one PNG per frame
//! (`frame_000000.png`, …, frame `k` of the video):
//!
//! - **depth** (`<video stem>.depth/`): 16-bit grey, millimetres along the camera's optical axis
//!   (z-depth, as the renderer's depth buffer holds it, not the distance along the ray), rounded;
//!   0 where no surface is seen (the sky), 65535 for surfaces at or beyond 65.535 m;
//! - **mask** (`<video stem>.mask/`): 8-bit grey instance ids, 0 for everything that is not a
//!   person, [`PERSON_ID`] for the capture's one character (the pixels the annotations' box and
//!   visibility are measured on).
//!
//! The folders are filled under a temporary sibling (`.<name>.part`) and renamed into place when
//! the render completes, so an interrupted render leaves no folder that looks complete.
//! `autoact trim` links each clip's frames into the dataset.

use std::path::{Path, PathBuf};

use super::Image;
use super::world::Surface;
use crate::video::{PngPixels, VideoError, write_png_as};

/// The instance id of the capture's character in the mask pass.
pub const PERSON_ID: u8 = 1;

/// The depth pass of `image`: per pixel, millimetres as a big-endian `u16` (PNG's byte order).
#[must_use]
pub fn depth_mm_be(image: &Image) -> Vec<u8> {
    image
        .depth
        .iter()
        .flat_map(|&inv_z| depth_mm(inv_z).to_be_bytes())
        .collect()
}

/// Millimetres of a depth-buffer value (`1 / z`, metres⁻¹; 0 for no surface).
fn depth_mm(inv_z: f32) -> u16 {
    if inv_z <= 0.0 || !inv_z.is_finite() {
        return 0;
    }
    let mm = (1000.0 / f64::from(inv_z)).round();
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "clamped to 1..=65535 first"
    )]
    let mm = mm.clamp(1.0, f64::from(u16::MAX)) as u16;
    mm
}

/// The mask pass of `image`: [`PERSON_ID`] where the character is seen, 0 elsewhere.
#[must_use]
pub fn person_mask(image: &Image) -> Vec<u8> {
    image
        .surface
        .iter()
        .map(|&s| {
            if s == Surface::Character as u8 {
                PERSON_ID
            } else {
                0
            }
        })
        .collect()
}

/// The passes of one frame, as their PNGs' pixel bytes.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FramePasses {
    /// [`depth_mm_be`], when asked for.
    pub depth: Option<Vec<u8>>,
    /// [`person_mask`], when asked for.
    pub mask: Option<Vec<u8>>,
}

/// Which passes a render writes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Wanted {
    /// The depth pass.
    pub depth: bool,
    /// The mask pass.
    pub mask: bool,
}

impl FramePasses {
    /// The passes `wanted` of `image`.
    #[must_use]
    pub fn of(image: &Image, wanted: Wanted) -> FramePasses {
        FramePasses {
            depth: wanted.depth.then(|| depth_mm_be(image)),
            mask: wanted.mask.then(|| person_mask(image)),
        }
    }
}

/// The pass folders of one render, being filled.
#[derive(Debug, Default)]
pub struct PassDirs {
    depth: Option<PartDir>,
    mask: Option<PartDir>,
}

/// A folder filled under its temporary sibling and renamed into place by [`PartDir::commit`];
/// removed when dropped uncommitted.
#[derive(Debug)]
struct PartDir {
    part: PathBuf,
    path: PathBuf,
    committed: bool,
}

impl PartDir {
    fn create(path: &Path) -> Result<PartDir, VideoError> {
        let part = crate::atomic_file::temporary_sibling(path).ok_or_else(|| {
            VideoError::InvalidSettings {
                path: path.to_path_buf(),
                reason: crate::video::InvalidSetting::NotAFileName,
            }
        })?;
        if part.exists() {
            std::fs::remove_dir_all(&part).map_err(VideoError::io("remove the old", &part))?;
        }
        std::fs::create_dir_all(&part).map_err(VideoError::io("create", &part))?;
        Ok(PartDir {
            part,
            path: path.to_path_buf(),
            committed: false,
        })
    }

    fn commit(mut self) -> Result<(), VideoError> {
        if self.path.exists() {
            std::fs::remove_dir_all(&self.path)
                .map_err(VideoError::io("replace the folder", &self.path))?;
        }
        std::fs::rename(&self.part, &self.path)
            .map_err(VideoError::io("rename into place", &self.path))?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for PartDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.part);
        }
    }
}

impl PassDirs {
    /// Starts the folders asked for (under temporary names).
    ///
    /// # Errors
    /// [`VideoError::Io`] naming the folder.
    pub fn open(depth: Option<&Path>, mask: Option<&Path>) -> Result<PassDirs, VideoError> {
        Ok(PassDirs {
            depth: depth.map(PartDir::create).transpose()?,
            mask: mask.map(PartDir::create).transpose()?,
        })
    }

    /// The passes these folders are for.
    #[must_use]
    pub fn wanted(&self) -> Wanted {
        Wanted {
            depth: self.depth.is_some(),
            mask: self.mask.is_some(),
        }
    }

    /// Writes frame `k`'s passes.
    ///
    /// # Errors
    /// [`VideoError`] naming the file.
    pub fn write(
        &self,
        k: usize,
        width: u32,
        height: u32,
        passes: &FramePasses,
    ) -> Result<(), VideoError> {
        let name = format!("frame_{k:06}.png");
        if let (Some(dir), Some(bytes)) = (&self.depth, &passes.depth) {
            write_png_as(
                &dir.part.join(&name),
                width,
                height,
                PngPixels::Grey16,
                bytes,
            )?;
        }
        if let (Some(dir), Some(bytes)) = (&self.mask, &passes.mask) {
            write_png_as(
                &dir.part.join(&name),
                width,
                height,
                PngPixels::Grey8,
                bytes,
            )?;
        }
        Ok(())
    }

    /// Renames the folders into place.
    ///
    /// # Errors
    /// [`VideoError::Io`] naming the folder.
    pub fn commit(self) -> Result<(), VideoError> {
        for dir in [self.depth, self.mask].into_iter().flatten() {
            dir.commit()?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_is_millimetres_along_the_axis_with_zero_for_the_sky_and_a_ceiling() {
        assert_eq!(depth_mm(0.0), 0);
        assert_eq!(depth_mm(f32::NAN), 0);
        assert_eq!(depth_mm(1.0 / 2.5), 2500);
        assert_eq!(
            depth_mm(1.0 / 0.0004),
            1,
            "a surface nearer than 1 mm is not the sky"
        );
        assert_eq!(depth_mm(1.0 / 100.0), u16::MAX);
        let mut image = Image::new(2, 1);
        image.depth = vec![0.25, 0.0];
        image.surface = vec![Surface::Character as u8, Surface::Sky as u8];
        assert_eq!(depth_mm_be(&image), vec![0x0F, 0xA0, 0, 0]);
        assert_eq!(person_mask(&image), vec![PERSON_ID, 0]);
    }

    #[test]
    fn pass_folders_appear_only_when_committed() {
        let dir = tempfile::tempdir().unwrap();
        let depth = dir.path().join("v.depth");
        let image = Image::new(4, 2);
        let dirs = PassDirs::open(Some(&depth), None).unwrap();
        dirs.write(0, 4, 2, &FramePasses::of(&image, dirs.wanted()))
            .unwrap();
        assert!(!depth.exists());
        drop(dirs);
        assert!(!depth.exists() && std::fs::read_dir(dir.path()).unwrap().count() == 0);
        let dirs = PassDirs::open(Some(&depth), None).unwrap();
        dirs.write(0, 4, 2, &FramePasses::of(&image, dirs.wanted()))
            .unwrap();
        dirs.commit().unwrap();
        assert!(depth.join("frame_000000.png").is_file());
    }
}
