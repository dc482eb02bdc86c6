//! Where DSI keeps a clip's key frames between its passes ([`super::stream`]): in memory, or
//! spilled to an unnamed temporary file, so that a long clip costs disk space instead of memory
//! (a key of the 53-bone rig is 1,728 bytes: 1.7 GB for a million).

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::ops::Range;
use std::os::unix::fs::FileExt;
use std::path::{Path, PathBuf};

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::DsiError;
use crate::skeleton::fk::BonePose;

/// A clip's key frames, appended in order and read back by index range.
#[derive(Debug)]
pub enum KeyStore {
    /// Held in memory.
    Memory(Vec<BonePose>),
    /// In a temporary file.
    Spill(Spill),
}

impl KeyStore {
    /// An empty store in memory.
    #[must_use]
    pub fn memory() -> KeyStore {
        KeyStore::Memory(Vec::new())
    }

    /// An empty store in an unnamed temporary file in `dir` (removed when the store drops, or
    /// the process dies), for keys of `bones` bones.
    ///
    /// # Errors
    /// The file cannot be created in `dir`.
    pub fn spill(dir: &Path, bones: usize) -> io::Result<KeyStore> {
        let file = tempfile::tempfile_in(dir)?;
        Ok(KeyStore::Spill(Spill {
            reader: file.try_clone()?,
            writer: BufWriter::with_capacity(1 << 20, file),
            dir: dir.to_path_buf(),
            bones,
            len: 0,
        }))
    }

    /// Number of keys stored.
    #[must_use]
    pub fn len(&self) -> usize {
        match self {
            KeyStore::Memory(v) => v.len(),
            KeyStore::Spill(s) => s.len,
        }
    }

    /// Whether no key is stored.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The folder of the temporary file (`None` in memory), for messages.
    #[must_use]
    pub fn dir(&self) -> Option<&Path> {
        match self {
            KeyStore::Memory(_) => None,
            KeyStore::Spill(s) => Some(&s.dir),
        }
    }

    /// Appends a key.
    ///
    /// # Errors
    /// Writing the temporary file failed (a full disk).
    pub fn push(&mut self, pose: BonePose) -> io::Result<()> {
        match self {
            KeyStore::Memory(v) => v.push(pose),
            KeyStore::Spill(s) => s.push(&pose)?,
        }
        Ok(())
    }

    /// The keys `range` (clipped to the stored ones).
    ///
    /// # Errors
    /// Reading the temporary file failed.
    pub fn read(&mut self, range: Range<usize>) -> io::Result<Vec<BonePose>> {
        let range = range.start.min(self.len())..range.end.min(self.len());
        match self {
            KeyStore::Memory(v) => Ok(v[range].to_vec()),
            KeyStore::Spill(s) => s.read(range),
        }
    }
}

/// One clip's part of a store that several clips share (the stretches of one person, so that a
/// recording cut by many gaps does not open a file per stretch): keys `start..` of the store.
/// Clips sharing a store are written one after the other: a part is appended to only while it
/// ends the store.
#[derive(Debug, Clone)]
pub struct Shelf {
    store: std::rc::Rc<std::cell::RefCell<KeyStore>>,
    start: usize,
}

impl Shelf {
    /// The whole of `store`, which starts empty.
    #[must_use]
    pub fn new(store: KeyStore) -> Shelf {
        Shelf {
            start: store.len(),
            store: std::rc::Rc::new(std::cell::RefCell::new(store)),
        }
    }

    /// The whole of a new store in a temporary file in `dir` ([`KeyStore::spill`]).
    ///
    /// # Errors
    /// [`DsiError::Spill`] when the file cannot be created.
    pub fn spill(dir: &Path, bones: usize) -> Result<Shelf, DsiError> {
        KeyStore::spill(dir, bones)
            .map(Shelf::new)
            .map_err(|source| DsiError::Spill {
                dir: Some(dir.to_path_buf()),
                source,
            })
    }

    /// A new part of the same store, from its current end.
    #[must_use]
    pub fn next(&self) -> Shelf {
        Shelf {
            store: std::rc::Rc::clone(&self.store),
            start: self.store.borrow().len(),
        }
    }

    /// Appends a key to the store (this part's next key while it ends the store).
    ///
    /// # Errors
    /// [`DsiError::Spill`] when the temporary file cannot be written (a full disk).
    pub fn push(&self, pose: BonePose) -> Result<(), DsiError> {
        let result = self.store.borrow_mut().push(pose);
        result.map_err(|source| self.error(source))
    }

    /// This part's keys `range`.
    ///
    /// # Errors
    /// [`DsiError::Spill`] when the temporary file cannot be read.
    pub fn read(&self, range: Range<usize>) -> Result<Vec<BonePose>, DsiError> {
        let shifted = self.start + range.start..self.start + range.end;
        let result = self.store.borrow_mut().read(shifted);
        result.map_err(|source| self.error(source))
    }

    /// The one place a store's I/O error becomes a [`DsiError`], naming the file's folder.
    fn error(&self, source: io::Error) -> DsiError {
        DsiError::Spill {
            dir: self.store.borrow().dir().map(Path::to_path_buf),
            source,
        }
    }
}

/// Keys in a temporary file: fixed-size little-endian records (root translation, every bone's
/// quaternion `i, j, k, w`), so key `f` is at `f` times the record size.
#[derive(Debug)]
pub struct Spill {
    writer: BufWriter<File>,
    reader: File,
    dir: PathBuf,
    bones: usize,
    len: usize,
}

impl Spill {
    fn record_bytes(&self) -> usize {
        8 * (3 + 4 * self.bones)
    }

    fn push(&mut self, pose: &BonePose) -> io::Result<()> {
        if pose.local_rotations.len() != self.bones {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "a key of {} bones in a clip of {}",
                    pose.local_rotations.len(),
                    self.bones
                ),
            ));
        }
        let w = &mut self.writer;
        for v in pose.root_translation_m.iter() {
            w.write_all(&v.to_le_bytes())?;
        }
        for q in &pose.local_rotations {
            for v in q.as_ref().coords.iter() {
                w.write_all(&v.to_le_bytes())?;
            }
        }
        self.len += 1;
        Ok(())
    }

    fn read(&mut self, range: Range<usize>) -> io::Result<Vec<BonePose>> {
        self.writer.flush()?;
        let size = self.record_bytes();
        let mut bytes = vec![0u8; range.len() * size];
        // Positional reads: the writer shares the file's offset.
        self.reader
            .read_exact_at(&mut bytes, (range.start * size) as u64)?;
        Ok(bytes.chunks_exact(size).map(|r| self.decode(r)).collect())
    }

    fn decode(&self, record: &[u8]) -> BonePose {
        let mut floats = record
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])));
        let mut float = || floats.next().unwrap_or(0.0);
        let root_translation_m = Vector3::new(float(), float(), float());
        let local_rotations = (0..self.bones)
            .map(|_| {
                let (i, j, k, w) = (float(), float(), float(), float());
                UnitQuaternion::new_unchecked(Quaternion::new(w, i, j, k))
            })
            .collect();
        BonePose {
            root_translation_m,
            local_rotations,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(k: u32, bones: usize) -> BonePose {
        let a = f64::from(k) * 0.1;
        BonePose {
            root_translation_m: Vector3::new(a, -a, 1.0 / (a + 1.0)),
            local_rotations: (0..bones)
                .map(|b| {
                    UnitQuaternion::from_euler_angles(
                        a,
                        0.3 * f64::from(u32::try_from(b).unwrap()),
                        -a,
                    )
                })
                .collect(),
        }
    }

    #[test]
    fn a_spill_gives_back_every_bit_of_what_it_was_given() {
        let dir = tempfile::tempdir().unwrap();
        let mut memory = KeyStore::memory();
        let mut spill = KeyStore::spill(dir.path(), 5).unwrap();
        for k in 0..100 {
            memory.push(frame(k, 5)).unwrap();
            spill.push(frame(k, 5)).unwrap();
        }
        assert_eq!(spill.len(), 100);
        for range in [0..100, 17..18, 90..140, 100..120, 3..3] {
            assert_eq!(
                spill.read(range.clone()).unwrap(),
                memory.read(range).unwrap()
            );
        }
        // Writing after reading appends.
        spill.push(frame(100, 5)).unwrap();
        assert_eq!(spill.read(99..101).unwrap()[1], frame(100, 5));
        assert!(spill.push(frame(101, 4)).is_err());
        // The file is unnamed: nothing is left in the folder.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}
