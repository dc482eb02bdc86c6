//! Cutting stream-copy clips in-process: the source MP4's H.264 samples of whole frames are
//! copied into a new MP4, with no `ffmpeg` or `ffprobe` process per clip.
//!
//! A process per clip cost 0.12–0.14 s of CPU whatever the clip's length (issue 22), which
//! dominated cutting thousands of short clips. autoact's own renders are H.264 in MP4 with no
//! B-frames and an IDR frame at every segment boundary, so a clip starting on a boundary is a
//! run of whole samples: its file is the source's sample description (the `avcC` copied as it
//! is), the samples' bytes in one `mdat`, and sample tables rebuilt for that run, timed from
//! zero. Boxes are read and written with the `mp4-atom` crate (a maintained ISO-BMFF box
//! codec; the higher-level `mp4` crate rebuilds `avcC` from SPS/PPS only, and its last release
//! is from 2023).
//!
//! [`Mp4Source::open`] declines (returns `None`) any file it cannot copy from exactly — not
//! ISO-BMFF, not exactly one track, not `avc1`, frames reordered (`ctts`), an edit list that is
//! not the identity, fragmented — and the caller falls back to `ffmpeg` ([`super::cut`]), which
//! also serves videos from other engines and re-encodes.
//!
//! A clip is written to a hidden `.part` sibling, read back (sample count, first sample a sync
//! sample), synced and renamed; every error removes the `.part` file. The bytes depend only on
//! the source and the frame range, so two machines cutting the same render write the same clip.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use mp4_atom::{
    Atom, Codec, Encode, Ftyp, Header, Mdat, Moov, ReadAtom, ReadFrom, Stco, Stsc, StscEntry, Stss,
    Stsz, StszSamples, Stts, SttsEntry, Trak,
};

use super::encode::remove_part;
use super::{CutClip, CutMethod, VideoError};
use crate::atomic_file::temporary_sibling as part_path;

/// One sample (frame) of the source: where its bytes are, how long it lasts, whether it is a
/// sync sample (IDR frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Sample {
    offset: u64,
    size: u32,
    duration: u32,
    sync: bool,
}

/// An MP4 whose clips can be cut by copying samples: its file type, its one track's boxes and
/// every sample's place, read once and reused for each clip.
#[derive(Debug, Clone)]
pub struct Mp4Source {
    path: PathBuf,
    ftyp: Ftyp,
    moov: Moov,
    samples: Vec<Sample>,
}

/// Why a file is left to `ffmpeg` (logged at debug level).
type Declined = String;

impl Mp4Source {
    /// Reads the boxes of `path` (not the media data). `Ok(None)` when it is not a file this
    /// module copies from exactly (see the module docs); then cut it with `ffmpeg`.
    ///
    /// # Errors
    /// [`VideoError::Io`] if the file cannot be opened or read.
    pub fn open(path: &Path) -> Result<Option<Mp4Source>, VideoError> {
        let io = VideoError::io;
        let file = File::open(path).map_err(io("open", path))?;
        let len = file.metadata().map_err(io("read the size of", path))?.len();
        match read_boxes(BufReader::new(file), len) {
            Ok(Ok((ftyp, moov))) => match sample_table(&moov, len) {
                Ok(samples) => Ok(Some(Mp4Source {
                    path: path.to_path_buf(),
                    ftyp,
                    moov,
                    samples,
                })),
                Err(why) => Ok(decline(path, &why)),
            },
            Ok(Err(why)) => Ok(decline(path, &why)),
            Err(e) => Err(io("read the boxes of", path)(e)),
        }
    }

    /// Whether [`Mp4Source::cut`] writes `output`: an `.mp4` or `.m4v` name (other containers
    /// are `ffmpeg`'s).
    #[must_use]
    pub fn writes(output: &Path) -> bool {
        super::encode::container_for(output) == Ok("mp4")
    }

    /// Frames (samples) in the video.
    #[must_use]
    pub fn frame_count(&self) -> u64 {
        self.samples.len() as u64
    }

    /// Indices of the sync samples (IDR frames): where a copied clip can start.
    #[must_use]
    pub fn keyframes(&self) -> Vec<u64> {
        (0_u64..)
            .zip(&self.samples)
            .filter(|(_, s)| s.sync)
            .map(|(i, _)| i)
            .collect()
    }

    /// Writes frames `start_frame .. start_frame + frame_count` to `output` (an `.mp4`),
    /// through a hidden `.part` sibling renamed once read back and found complete.
    ///
    /// # Errors
    /// [`VideoError::FrameCountMismatch`] if the source holds fewer frames,
    /// [`VideoError::Probe`] if the first frame is not a keyframe or the written file does not
    /// read back as the clip, [`VideoError::InvalidSettings`] for an empty clip or an output
    /// without a file name, [`VideoError::Io`]. No `.part` file is left on any error.
    pub fn cut(
        &self,
        output: &Path,
        start_frame: u64,
        frame_count: u64,
    ) -> Result<CutClip, VideoError> {
        let invalid = |reason| VideoError::InvalidSettings {
            path: output.to_path_buf(),
            reason,
        };
        if frame_count == 0 {
            return Err(invalid(super::InvalidSetting::EmptyClip));
        }
        let part = part_path(output).ok_or_else(|| invalid(super::InvalidSetting::NoFileName))?;
        let end = start_frame.saturating_add(frame_count);
        let Some(run) = usize::try_from(start_frame)
            .ok()
            .zip(usize::try_from(end).ok())
            .and_then(|(a, b)| self.samples.get(a..b))
        else {
            return Err(VideoError::FrameCountMismatch {
                path: output.to_path_buf(),
                written: frame_count,
                found: self.frame_count().saturating_sub(start_frame),
            });
        };
        if !run[0].sync {
            return Err(VideoError::Probe {
                path: output.to_path_buf(),
                detail: format!(
                    "frame {start_frame} of `{}` is not a keyframe: the clip cannot start there by copy",
                    self.path.display()
                ),
            });
        }
        let result = self.write_clip(&part, output, run);
        if result.is_err() {
            remove_part(&part);
        }
        let bytes = result?;
        Ok(CutClip {
            path: output.to_path_buf(),
            frame_count,
            method: CutMethod::StreamCopy,
            bytes,
        })
    }

    /// Writes `run` into `part`, checks it, renames it to `output`; returns its size.
    fn write_clip(&self, part: &Path, output: &Path, run: &[Sample]) -> Result<u64, VideoError> {
        let io = VideoError::io;
        let media = self.read_samples(run)?;
        let mut ftyp = Vec::new();
        encode(&self.ftyp, &mut ftyp, output)?;
        let mut mdat_header = Vec::new();
        encode(
            &Header {
                kind: Mdat::KIND,
                size: Some(media.len()),
            },
            &mut mdat_header,
            output,
        )?;
        let data_offset = (ftyp.len() + mdat_header.len()) as u64;
        let moov = clip_moov(&self.moov, run, data_offset, output)?;
        let mut tail = Vec::new();
        encode(&moov, &mut tail, output)?;
        let mut file = File::create(part).map_err(io("create", part))?;
        for bytes in [&ftyp, &mdat_header, &media, &tail] {
            file.write_all(bytes).map_err(io("write", part))?;
        }
        drop(file);
        check_clip(part, output, run)?;
        crate::atomic_file::commit(part, output)
            .map_err(io("sync and rename into place", output))?;
        Ok((ftyp.len() + mdat_header.len() + media.len() + tail.len()) as u64)
    }

    /// The bytes of `run`'s samples, in order (contiguous ones in one read).
    fn read_samples(&self, run: &[Sample]) -> Result<Vec<u8>, VideoError> {
        let io = VideoError::io;
        let path = &self.path;
        let mut file = File::open(path).map_err(io("open", path))?;
        let total: usize = run.iter().map(|s| s.size as usize).sum();
        let mut media = vec![0_u8; total];
        let mut at = 0;
        let mut i = 0;
        while i < run.len() {
            // Samples stored back to back are read at once.
            let mut j = i + 1;
            while j < run.len() && run[j].offset == run[j - 1].offset + u64::from(run[j - 1].size) {
                j += 1;
            }
            let len: usize = run[i..j].iter().map(|s| s.size as usize).sum();
            file.seek(SeekFrom::Start(run[i].offset))
                .and_then(|_| file.read_exact(&mut media[at..at + len]))
                .map_err(io("read the frames of", path))?;
            at += len;
            i = j;
        }
        Ok(media)
    }
}

/// Joins `parts` (videos of one stream's consecutive pieces, each encoded on its own with the
/// same settings) into `output` by copying their samples in order: one MP4 with the first part's
/// sample description, timed as the parts back to back. Written to a hidden `.part` sibling, read
/// back (sample count, sizes, keyframes), synced and renamed; returns its size. The bytes depend
/// only on the parts, so a render joined from pieces some of which an earlier (killed) run made
/// is the same file as one whose pieces were all made in one go.
///
/// # Errors
/// [`VideoError::Probe`] when the parts' sample descriptions (SPS, PPS, size) or time scales
/// differ, or the result does not read back; [`VideoError::InvalidSettings`] for no parts;
/// [`VideoError::Io`]. No `.part` file is left on any error.
pub fn concat(parts: &[Mp4Source], output: &Path) -> Result<u64, VideoError> {
    let invalid = |reason| VideoError::InvalidSettings {
        path: output.to_path_buf(),
        reason,
    };
    let Some(first) = parts.first() else {
        return Err(invalid(super::InvalidSetting::EmptyClip));
    };
    // The sample descriptions but for their `btrt` (each encode states its own bit rates).
    let track = |s: &Mp4Source| {
        let t = &s.moov.trak[0];
        (
            t.mdia.mdhd.timescale,
            without_bit_rates(&t.mdia.minf.stbl.stsd),
        )
    };
    if let Some(other) = parts.iter().find(|p| track(p) != track(first)) {
        return Err(VideoError::Probe {
            path: output.to_path_buf(),
            detail: format!(
                "`{}` and `{}` differ in their sample description or time scale: not pieces of one stream",
                first.path.display(),
                other.path.display()
            ),
        });
    }
    let part = part_path(output).ok_or_else(|| invalid(super::InvalidSetting::NoFileName))?;
    let result = write_joined(parts, &part, output);
    if result.is_err() {
        remove_part(&part);
    }
    result
}

/// Writes every sample of `parts` into `part` (ftyp, one mdat, moov), checks it and renames it to
/// `output`; returns its size.
fn write_joined(parts: &[Mp4Source], part: &Path, output: &Path) -> Result<u64, VideoError> {
    let io = VideoError::io;
    let first = &parts[0];
    let run: Vec<Sample> = parts
        .iter()
        .flat_map(|p| p.samples.iter().copied())
        .collect();
    let media_len: u64 = run.iter().map(|s| u64::from(s.size)).sum();
    let mut ftyp = Vec::new();
    encode(&first.ftyp, &mut ftyp, output)?;
    let mut mdat_header = Vec::new();
    encode(
        &Header {
            kind: Mdat::KIND,
            size: Some(usize::try_from(media_len).unwrap_or(usize::MAX)),
        },
        &mut mdat_header,
        output,
    )?;
    let data_offset = (ftyp.len() + mdat_header.len()) as u64;
    let mut moov = clip_moov(&first.moov, &run, data_offset, output)?;
    let stsd = &mut moov.trak[0].mdia.minf.stbl.stsd;
    *stsd = without_bit_rates(stsd);
    let mut tail = Vec::new();
    encode(&moov, &mut tail, output)?;
    let mut file = std::io::BufWriter::new(File::create(part).map_err(io("create", part))?);
    for bytes in [&ftyp, &mdat_header] {
        file.write_all(bytes).map_err(io("write", part))?;
    }
    for p in parts {
        // One part's media at a time: memory stays at one piece, not the whole render.
        let media = p.read_samples(&p.samples)?;
        file.write_all(&media).map_err(io("write", part))?;
    }
    file.write_all(&tail).map_err(io("write", part))?;
    file.into_inner()
        .map_err(|e| io("write", part)(e.into_error()))?;
    check_joined(part, output, &run)?;
    crate::atomic_file::commit(part, output).map_err(io("sync and rename into place", output))?;
    Ok(data_offset + media_len + tail.len() as u64)
}

/// `stsd` with no `btrt` box (bit rates of one encode, not of a join of several).
fn without_bit_rates(stsd: &mp4_atom::Stsd) -> mp4_atom::Stsd {
    let mut stsd = stsd.clone();
    for codec in &mut stsd.codecs {
        if let Codec::Avc1(avc1) = codec {
            avc1.btrt = None;
        }
    }
    stsd
}

fn decline(path: &Path, why: &str) -> Option<Mp4Source> {
    tracing::debug!(path = %path.display(), why, "not cut in-process; ffmpeg cuts it");
    None
}

fn encode(atom: &impl Encode, buf: &mut Vec<u8>, path: &Path) -> Result<(), VideoError> {
    atom.encode(buf).map_err(|e| VideoError::Probe {
        path: path.to_path_buf(),
        detail: format!("cannot encode an MP4 box: {e}"),
    })
}

/// The `ftyp` and `moov` boxes of a file of `len` bytes (the outer error is I/O; the inner one
/// says why the file is declined).
fn read_boxes(
    mut reader: BufReader<File>,
    len: u64,
) -> std::io::Result<Result<(Ftyp, Moov), Declined>> {
    let mut ftyp = None;
    let mut moov = None;
    let mut at = 0_u64;
    while at < len {
        let header = match Header::read_from(&mut reader) {
            Ok(h) => h,
            Err(e) => return Ok(Err(format!("box header at byte {at}: {e}"))),
        };
        let header_len = reader.stream_position()? - at;
        let Some(body) = header.size.map(|s| s as u64) else {
            // A box running to the end of the file (an mdat): nothing after it.
            break;
        };
        match header.kind {
            k if k == Ftyp::KIND => match Ftyp::read_atom(&header, &mut reader) {
                Ok(f) => ftyp = Some(f),
                Err(e) => return Ok(Err(format!("ftyp: {e}"))),
            },
            k if k == Moov::KIND => match Moov::read_atom(&header, &mut reader) {
                Ok(m) => moov = Some(m),
                Err(e) => return Ok(Err(format!("moov: {e}"))),
            },
            k if k == mp4_atom::Moof::KIND => return Ok(Err("fragmented MP4".into())),
            _ => {
                reader.seek_relative(i64::try_from(body).unwrap_or(i64::MAX))?;
            }
        }
        at += header_len + body;
        if reader.stream_position()? != at {
            return Ok(Err(format!("a box ending at byte {at} was not read whole")));
        }
    }
    Ok(match (ftyp, moov) {
        (Some(f), Some(m)) => Ok((f, m)),
        _ => Err("no ftyp or no moov box".into()),
    })
}

/// The one video track of `moov`, if it is one this module copies from.
fn only_track(moov: &Moov) -> Result<&Trak, Declined> {
    let [trak] = moov.trak.as_slice() else {
        return Err(format!("{} tracks, not one", moov.trak.len()));
    };
    let stbl = &trak.mdia.minf.stbl;
    if !matches!(stbl.stsd.codecs.as_slice(), [Codec::Avc1(_)]) {
        return Err("not one avc1 (H.264) sample description".into());
    }
    if stbl
        .ctts
        .as_ref()
        .is_some_and(|c| c.entries.iter().any(|e| e.sample_offset != 0))
    {
        return Err("frames are reordered (ctts)".into());
    }
    if let Some(edts) = &trak.edts
        && let Some(elst) = &edts.elst
        && !(elst.entries.len() == 1
            && elst.entries[0].media_time == Some(0)
            && elst.entries[0].media_rate.integer() == 1)
    {
        return Err("an edit list that is not the identity".into());
    }
    if moov.mvex.is_some() {
        return Err("fragmented MP4".into());
    }
    Ok(trak)
}

/// Every sample's place, duration and sync flag, from the track's sample tables, checked to lie
/// inside a file of `len` bytes.
fn sample_table(moov: &Moov, len: u64) -> Result<Vec<Sample>, Declined> {
    let stbl = &only_track(moov)?.mdia.minf.stbl;
    let sizes: Vec<u32> = match &stbl.stsz.samples {
        // A sample takes at least one byte of the file: a larger count is not believed.
        StszSamples::Identical { count, .. } if u64::from(*count) > len => {
            return Err("more samples than bytes in the file".into());
        }
        StszSamples::Identical { count, size } => vec![*size; *count as usize],
        StszSamples::Different { sizes } => sizes.clone(),
    };
    let chunks: Vec<u64> = match (&stbl.stco, &stbl.co64) {
        (Some(stco), None) => stco.entries.iter().map(|&o| u64::from(o)).collect(),
        (None, Some(co64)) => co64.entries.clone(),
        _ => return Err("not exactly one of stco and co64".into()),
    };
    let mut samples = Vec::with_capacity(sizes.len());
    let mut durations = stbl
        .stts
        .entries
        .iter()
        .flat_map(|e| std::iter::repeat_n(e.sample_delta, e.sample_count as usize));
    let stsc = &stbl.stsc.entries;
    for (k, entry) in stsc.iter().enumerate() {
        let first = entry.first_chunk as usize;
        let last = stsc
            .get(k + 1)
            .map_or(chunks.len() + 1, |n| n.first_chunk as usize);
        if first == 0 || last < first || last > chunks.len() + 1 {
            return Err("a sample-to-chunk entry outside the chunk table".into());
        }
        for &chunk in &chunks[first - 1..last - 1] {
            let mut offset = chunk;
            for _ in 0..entry.samples_per_chunk {
                let Some(&size) = sizes.get(samples.len()) else {
                    return Err("more samples in chunks than sizes".into());
                };
                let Some(duration) = durations.next() else {
                    return Err("more samples than durations (stts)".into());
                };
                if offset + u64::from(size) > len {
                    return Err(format!("sample {} lies past the end", samples.len() + 1));
                }
                samples.push(Sample {
                    offset,
                    size,
                    duration,
                    sync: stbl.stss.is_none(),
                });
                offset += u64::from(size);
            }
        }
    }
    if samples.len() != sizes.len() || durations.next().is_some() {
        return Err("the sample tables disagree on the sample count".into());
    }
    for &n in stbl.stss.iter().flat_map(|s| &s.entries) {
        match (n as usize).checked_sub(1).and_then(|i| samples.get_mut(i)) {
            Some(s) => s.sync = true,
            None => return Err(format!("sync sample {n} does not exist")),
        }
    }
    Ok(samples)
}

/// The source's `moov` made to describe `run` alone: its samples stored back to back in one
/// chunk at `data_offset`, timed from zero, durations in every header set to the clip's, no
/// edit list.
fn clip_moov(
    source: &Moov,
    run: &[Sample],
    data_offset: u64,
    output: &Path,
) -> Result<Moov, VideoError> {
    let too_big = |what: &str| VideoError::Probe {
        path: output.to_path_buf(),
        detail: format!("{what}: too large for this MP4 writer (32-bit tables)"),
    };
    let mut moov = source.clone();
    let trak = &mut moov.trak[0];
    let media_units: u64 = run.iter().map(|s| u64::from(s.duration)).sum();
    let media_scale = u64::from(trak.mdia.mdhd.timescale.max(1));
    let movie_scale = u64::from(moov.mvhd.timescale.max(1));
    let movie_units = media_units * movie_scale / media_scale;
    moov.mvhd.duration = movie_units;
    trak.tkhd.duration = movie_units;
    trak.edts = None;
    trak.mdia.mdhd.duration = media_units;
    let stbl = &mut trak.mdia.minf.stbl;
    let mut stts: Vec<SttsEntry> = Vec::new();
    for s in run {
        match stts.last_mut() {
            Some(e) if e.sample_delta == s.duration => e.sample_count += 1,
            _ => stts.push(SttsEntry {
                sample_count: 1,
                sample_delta: s.duration,
            }),
        }
    }
    let count = u32::try_from(run.len()).map_err(|_| too_big("the frame count"))?;
    stbl.stts = Stts { entries: stts };
    stbl.ctts = None;
    stbl.stss = Some(Stss {
        entries: (1..=count)
            .zip(run)
            .filter(|(_, s)| s.sync)
            .map(|(n, _)| n)
            .collect(),
    });
    stbl.stsc = Stsc {
        entries: vec![StscEntry {
            first_chunk: 1,
            samples_per_chunk: count,
            sample_description_index: 1,
        }],
    };
    stbl.stsz = Stsz {
        samples: StszSamples::Different {
            sizes: run.iter().map(|s| s.size).collect(),
        },
    };
    let offset = u32::try_from(data_offset).map_err(|_| too_big("the media offset"))?;
    stbl.stco = Some(Stco {
        entries: vec![offset],
    });
    stbl.co64 = None;
    stbl.sbgp.clear();
    stbl.sgpd.clear();
    stbl.subs.clear();
    stbl.saiz.clear();
    stbl.saio.clear();
    stbl.cslg = None;
    Ok(moov)
}

/// Reads `part` back and checks it holds `run`: its sample count and sizes, a sync first sample.
fn check_clip(part: &Path, output: &Path, run: &[Sample]) -> Result<(), VideoError> {
    check_joined(part, output, run)
}

/// Reads `part` back and checks it holds `run`: its sample count, sizes, durations and sync
/// flags, a sync first sample.
fn check_joined(part: &Path, output: &Path, run: &[Sample]) -> Result<(), VideoError> {
    let bad = |detail: String| VideoError::Probe {
        path: output.to_path_buf(),
        detail: format!("the copied clip does not read back: {detail}"),
    };
    let Some(clip) = Mp4Source::open(part)? else {
        return Err(bad("not a readable single-track H.264 MP4".into()));
    };
    if clip.samples.len() != run.len() {
        return Err(VideoError::FrameCountMismatch {
            path: output.to_path_buf(),
            written: run.len() as u64,
            found: clip.frame_count(),
        });
    }
    let same = clip
        .samples
        .iter()
        .zip(run)
        .all(|(a, b)| a.size == b.size && a.duration == b.duration && a.sync == b.sync);
    if !same || !clip.samples[0].sync {
        return Err(bad(
            "sizes, durations or keyframes differ from the source's".into(),
        ));
    }
    Ok(())
}
