//! Stills: PNG writing and reading (crate `png`) and contact sheets (frames tiled in a grid,
//! each with an optional label in the built-in 5×7 font).
//!
//! Images are `rgb24`: `width × height × 3` bytes, rows top to bottom. A PNG is written to a
//! hidden `.<name>.part` sibling and renamed when complete, so a crash never leaves a truncated
//! file under the real name.

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};

use super::font::{GLYPH_H, draw_text, text_width};
use super::{InvalidSetting, VideoError};

/// Border around and between contact-sheet tiles, in pixels.
const BORDER_PX: u32 = 2;
/// Background and border colour of contact sheets.
const BORDER_RGB: [u8; 3] = [40, 40, 40];
/// Label text colour.
const LABEL_RGB: [u8; 3] = [255, 255, 255];
/// Label backing colour.
const LABEL_BACK_RGB: [u8; 3] = [0, 0, 0];

/// One frame for [`contact_sheet`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tile<'a> {
    /// The pixels, `rgb24`.
    pub rgb24: &'a [u8],
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Text drawn in the tile's top-left corner; empty for none.
    pub label: &'a str,
}

/// What one pixel of a PNG [`write_png_as`] writes is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PngPixels {
    /// `rgb24`: 3 bytes per pixel.
    Rgb8,
    /// One grey byte per pixel (labels: instance masks).
    Grey8,
    /// One grey 16-bit value per pixel, 2 bytes big-endian as PNG stores them (depth).
    Grey16,
}

impl PngPixels {
    fn bytes_per_pixel(self) -> usize {
        match self {
            PngPixels::Rgb8 => 3,
            PngPixels::Grey8 => 1,
            PngPixels::Grey16 => 2,
        }
    }
}

/// Writes an `rgb24` image as an 8-bit RGB PNG.
///
/// # Errors
/// As [`write_png_as`].
pub fn write_png(path: &Path, width: u32, height: u32, rgb24: &[u8]) -> Result<(), VideoError> {
    write_png_as(path, width, height, PngPixels::Rgb8, rgb24)
}

/// Writes `bytes` (row-major from the top-left, `pixels` per pixel) as a PNG, atomically.
///
/// # Errors
/// [`VideoError::FrameSize`] if `bytes` is not `width × height` pixels (or a side is 0),
/// [`VideoError::Io`] / [`VideoError::Png`] if writing fails (nothing is left at `path` then).
pub fn write_png_as(
    path: &Path,
    width: u32,
    height: u32,
    pixels: PngPixels,
    bytes: &[u8],
) -> Result<(), VideoError> {
    let expected = width as usize * height as usize * pixels.bytes_per_pixel();
    if bytes.len() != expected || expected == 0 {
        return Err(VideoError::FrameSize {
            path: path.to_path_buf(),
            frame: 0,
            width,
            height,
            expected,
            got: bytes.len(),
        });
    }
    let part =
        crate::atomic_file::temporary_sibling(path).ok_or_else(|| VideoError::InvalidSettings {
            path: path.to_path_buf(),
            reason: InvalidSetting::NotAFileName,
        })?;
    let result = encode_png(&part, width, height, pixels, bytes).and_then(|()| {
        crate::atomic_file::commit(&part, path)
            .map_err(VideoError::io("sync and rename into place", path))
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&part);
    }
    result
}

fn encode_png(
    part: &Path,
    width: u32,
    height: u32,
    pixels: PngPixels,
    bytes: &[u8],
) -> Result<(), VideoError> {
    let io = |action: &'static str| {
        move |source| VideoError::Io {
            action,
            path: part.to_path_buf(),
            source,
        }
    };
    let png_error = |e: png::EncodingError| match e {
        png::EncodingError::IoError(source) => VideoError::Io {
            action: "write",
            path: part.to_path_buf(),
            source,
        },
        other => VideoError::Png {
            path: part.to_path_buf(),
            detail: other.to_string(),
        },
    };
    let file = File::create(part).map_err(io("create"))?;
    let mut out = BufWriter::new(file);
    let mut encoder = png::Encoder::new(&mut out, width, height);
    let (color, depth) = match pixels {
        PngPixels::Rgb8 => (png::ColorType::Rgb, png::BitDepth::Eight),
        PngPixels::Grey8 => (png::ColorType::Grayscale, png::BitDepth::Eight),
        PngPixels::Grey16 => (png::ColorType::Grayscale, png::BitDepth::Sixteen),
    };
    encoder.set_color(color);
    encoder.set_depth(depth);
    let mut writer = encoder.write_header().map_err(png_error)?;
    writer.write_image_data(bytes).map_err(png_error)?;
    writer.finish().map_err(png_error)?;
    out.into_inner().map_err(|e| VideoError::Io {
        action: "write",
        path: part.to_path_buf(),
        source: e.into_error(),
    })?;
    Ok(())
}

/// Reads a PNG as `(width, height, rgb24)`: 16-bit channels are reduced to 8, palettes and grey
/// expanded, alpha dropped.
///
/// # Errors
/// [`VideoError::Io`] if the file cannot be opened, [`VideoError::Png`] if it is not a PNG the
/// `png` crate can decode.
pub fn read_png(path: &Path) -> Result<(u32, u32, Vec<u8>), VideoError> {
    let bad = |detail: String| VideoError::Png {
        path: path.to_path_buf(),
        detail,
    };
    let file = File::open(path).map_err(|source| VideoError::Io {
        action: "open",
        path: path.to_path_buf(),
        source,
    })?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::EXPAND | png::Transformations::STRIP_16);
    let mut reader = decoder.read_info().map_err(|e| bad(e.to_string()))?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| bad("the image is too large".into()))?;
    let mut buf = vec![0; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| bad(e.to_string()))?;
    let data = &buf[..info.buffer_size()];
    let channels = match info.color_type {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Indexed => return Err(bad("palette was not expanded".into())),
    };
    if info.bit_depth != png::BitDepth::Eight {
        return Err(bad(format!(
            "{:?} bits per channel after expansion",
            info.bit_depth
        )));
    }
    let (width, height) = (info.width, info.height);
    let mut rgb = Vec::with_capacity(width as usize * height as usize * 3);
    for row in data.chunks_exact(info.line_size).take(height as usize) {
        for px in row[..width as usize * channels].chunks_exact(channels) {
            if channels < 3 {
                rgb.extend_from_slice(&[px[0], px[0], px[0]]);
            } else {
                rgb.extend_from_slice(&px[..3]);
            }
        }
    }
    Ok((width, height, rgb))
}

/// Tiles frames left to right, top to bottom, `columns` per row, each scaled to `tile_width`
/// pixels wide (keeping its aspect; shrinking averages pixels, enlarging repeats them), with a
/// 2-pixel border around and between tiles and each tile's label in its top-left corner (5×7
/// font, doubled when tiles are at least 200 pixels wide and every label fits so; a label too
/// long for its tile even at the font's size is cut and ends in `..`). Rows are as tall as the
/// tallest scaled tile. Returns `(width, height, rgb24)`; no tiles give `(0, 0, [])`.
///
/// # Errors
/// [`VideoError::InvalidSettings`] when `tile_width` or `columns` is 0 or a tile's buffer is
/// not `width × height × 3` bytes (or a side is 0).
pub fn contact_sheet(
    tiles: &[Tile<'_>],
    columns: u32,
    tile_width: u32,
) -> Result<(u32, u32, Vec<u8>), VideoError> {
    let invalid = |reason: InvalidSetting| VideoError::InvalidSettings {
        path: PathBuf::from("(contact sheet)"),
        reason,
    };
    if tile_width == 0 || columns == 0 {
        return Err(invalid(InvalidSetting::SheetLayout {
            columns,
            tile_width,
        }));
    }
    if tiles.is_empty() {
        return Ok((0, 0, Vec::new()));
    }
    let mut scaled_heights = Vec::with_capacity(tiles.len());
    for (index, tile) in tiles.iter().enumerate() {
        let expected = tile.width as usize * tile.height as usize * 3;
        if tile.rgb24.len() != expected || expected == 0 {
            return Err(invalid(InvalidSetting::TileSize {
                index,
                got: tile.rgb24.len(),
                width: tile.width,
                height: tile.height,
                expected,
            }));
        }
        let h = (u64::from(tile.height) * u64::from(tile_width) + u64::from(tile.width) / 2)
            / u64::from(tile.width);
        scaled_heights.push(
            u32::try_from(h.max(1))
                .map_err(|_| invalid(InvalidSetting::TileTooTall { index, tile_width }))?,
        );
    }
    let count = u32::try_from(tiles.len()).map_err(|_| invalid(InvalidSetting::TooManyTiles))?;
    let columns = columns.min(count);
    let rows = count.div_ceil(columns);
    let cell_height = scaled_heights.iter().copied().max().unwrap_or(1);
    let sheet_width = u64::from(columns) * u64::from(tile_width + BORDER_PX) + u64::from(BORDER_PX);
    let sheet_height = u64::from(rows) * u64::from(cell_height + BORDER_PX) + u64::from(BORDER_PX);
    if sheet_width * sheet_height > 1 << 30 {
        return Err(invalid(InvalidSetting::SheetTooLarge {
            width: sheet_width,
            height: sheet_height,
        }));
    }
    #[expect(clippy::cast_possible_truncation, reason = "checked above")]
    let (sheet_width, sheet_height) = (sheet_width as u32, sheet_height as u32);
    let mut sheet = BORDER_RGB.repeat(sheet_width as usize * sheet_height as usize);
    // One text size for the whole sheet: doubled on wide tiles when every label fits so.
    let label_scale =
        if tile_width >= 200 && tiles.iter().all(|t| label_fits(t.label, 2, tile_width)) {
            2
        } else {
            1
        };

    for ((index, tile), &height) in (0_u32..).zip(tiles).zip(&scaled_heights) {
        let x0 = BORDER_PX + (index % columns) * (tile_width + BORDER_PX);
        let y0 = BORDER_PX + (index / columns) * (cell_height + BORDER_PX);
        blit_scaled(
            &mut sheet,
            sheet_width,
            (x0, y0),
            tile,
            (tile_width, height),
        );
        if !tile.label.is_empty() {
            draw_label(
                &mut sheet,
                sheet_width,
                (x0, y0),
                (tile_width, height),
                tile.label,
                label_scale,
            );
        }
    }
    Ok((sheet_width, sheet_height, sheet))
}

/// Box-filter resample of `tile` to `dst_w × dst_h`, written at `(x0, y0)` in the sheet.
fn blit_scaled(
    sheet: &mut [u8],
    sheet_width: u32,
    (x0, y0): (u32, u32),
    tile: &Tile<'_>,
    (dst_w, dst_h): (u32, u32),
) {
    let span = |i: u32, src: u32, dst: u32| -> (usize, usize) {
        let a = u64::from(i) * u64::from(src) / u64::from(dst);
        let b = (u64::from(i + 1) * u64::from(src) / u64::from(dst)).max(a + 1);
        #[expect(
            clippy::cast_possible_truncation,
            reason = "bounded by the source side"
        )]
        (a as usize, b.min(u64::from(src)) as usize)
    };
    let x_spans: Vec<(usize, usize)> = (0..dst_w).map(|x| span(x, tile.width, dst_w)).collect();
    let src_w = tile.width as usize;
    for y in 0..dst_h {
        let (sy0, sy1) = span(y, tile.height, dst_h);
        let row_at = ((y0 + y) as usize * sheet_width as usize + x0 as usize) * 3;
        for (x, &(sx0, sx1)) in x_spans.iter().enumerate() {
            let mut sum = [0_u64; 3];
            for sy in sy0..sy1 {
                let src_row = &tile.rgb24[sy * src_w * 3..(sy + 1) * src_w * 3];
                for px in src_row[sx0 * 3..sx1 * 3].chunks_exact(3) {
                    sum[0] += u64::from(px[0]);
                    sum[1] += u64::from(px[1]);
                    sum[2] += u64::from(px[2]);
                }
            }
            let n = ((sy1 - sy0) * (sx1 - sx0)) as u64;
            let at = row_at + x * 3;
            for c in 0..3 {
                #[expect(clippy::cast_possible_truncation, reason = "an average of bytes")]
                let value = ((sum[c] + n / 2) / n) as u8;
                sheet[at + c] = value;
            }
        }
    }
}

fn draw_label(
    sheet: &mut [u8],
    sheet_width: u32,
    (x0, y0): (u32, u32),
    (cell_w, cell_h): (u32, u32),
    label: &str,
    scale: u32,
) {
    let label = if label_fits(label, scale, cell_w) {
        label.to_owned()
    } else {
        shortened(label, |text| label_fits(text, scale, cell_w))
    };
    let label = label.as_str();
    let pad = scale;
    let box_w = (text_width(label, scale) + 2 * pad).min(cell_w);
    let box_h = (GLYPH_H * scale + 2 * pad).min(cell_h);
    for y in y0..y0 + box_h {
        let at = (y as usize * sheet_width as usize + x0 as usize) * 3;
        for px in sheet[at..at + box_w as usize * 3].chunks_exact_mut(3) {
            px.copy_from_slice(&LABEL_BACK_RGB);
        }
    }
    // Draw into a box-sized scratch image so text never spills out of its tile.
    let mut scratch = LABEL_BACK_RGB.repeat(box_w as usize * box_h as usize);
    draw_text(
        &mut scratch,
        box_w,
        box_h,
        (pad, pad),
        label,
        LABEL_RGB,
        scale,
    );
    for (dy, row) in (0_u32..).zip(scratch.chunks_exact(box_w as usize * 3)) {
        let at = ((y0 + dy) as usize * sheet_width as usize + x0 as usize) * 3;
        sheet[at..at + row.len()].copy_from_slice(row);
    }
}

/// Whether `label` fits, with its box's padding, in a tile `cell_w` pixels wide at `scale`.
fn label_fits(label: &str, scale: u32, cell_w: u32) -> bool {
    text_width(label, scale) + 2 * scale <= cell_w
}

/// The longest start of `label` that, with `..` after it, `fits`: the whole label when it
/// fits, `..` alone when no start does.
fn shortened(label: &str, fits: impl Fn(&str) -> bool) -> String {
    let mut out = label.to_owned();
    while !out.is_empty() && !fits(&format!("{out}..")) {
        out.pop();
    }
    out.push_str("..");
    out
}

#[cfg(test)]
mod tests {
    use super::{BORDER_PX, BORDER_RGB, Tile, contact_sheet, read_png, shortened, write_png};

    fn pattern(w: u32, h: u32, seed: u8) -> Vec<u8> {
        (0..w * h * 3)
            .map(|i| u8::try_from((i * 7 + u32::from(seed) * 13) % 251).unwrap())
            .collect()
    }

    #[test]
    fn png_round_trips_exactly_and_leaves_no_part_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("still.png");
        let img = pattern(37, 21, 3);
        write_png(&path, 37, 21, &img).unwrap();
        let (w, h, back) = read_png(&path).unwrap();
        assert_eq!((w, h), (37, 21));
        assert_eq!(back, img);
        let names: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("still.png")]);
    }

    #[test]
    fn png_rejects_wrong_buffer_and_missing_dir() {
        let dir = tempfile::tempdir().unwrap();
        let err = write_png(&dir.path().join("a.png"), 4, 4, &[0; 10]).unwrap_err();
        assert!(err.to_string().contains("needs 48"), "{err}");
        let err = write_png(&dir.path().join("no/such/a.png"), 1, 1, &[0; 3]).unwrap_err();
        assert!(err.to_string().contains("no/such"), "{err}");
    }

    #[test]
    fn contact_sheet_places_tiles_in_a_grid() {
        // Three flat tiles, 40x20 each, two columns, shrunk to 20 wide (10 tall).
        let colours = [[200_u8, 0, 0], [0, 200, 0], [0, 0, 200]];
        let images: Vec<Vec<u8>> = colours.iter().map(|c| c.repeat(40 * 20)).collect();
        let tiles: Vec<Tile<'_>> = images
            .iter()
            .map(|img| Tile {
                rgb24: img,
                width: 40,
                height: 20,
                label: "",
            })
            .collect();
        let (w, h, sheet) = contact_sheet(&tiles, 2, 20).unwrap();
        assert_eq!(w, 2 * 20 + 3 * BORDER_PX);
        assert_eq!(h, 2 * 10 + 3 * BORDER_PX);
        let at = |x: u32, y: u32| -> [u8; 3] {
            let i = ((y * w + x) * 3) as usize;
            [sheet[i], sheet[i + 1], sheet[i + 2]]
        };
        assert_eq!(at(0, 0), BORDER_RGB);
        assert_eq!(at(BORDER_PX, BORDER_PX), colours[0]);
        assert_eq!(at(BORDER_PX + 19, BORDER_PX + 9), colours[0]);
        assert_eq!(at(BORDER_PX + 20, BORDER_PX), BORDER_RGB);
        assert_eq!(at(2 * BORDER_PX + 20, BORDER_PX), colours[1]);
        assert_eq!(at(BORDER_PX, 2 * BORDER_PX + 10), colours[2]);
        // The empty fourth cell is background.
        assert_eq!(at(2 * BORDER_PX + 25, 2 * BORDER_PX + 15), BORDER_RGB);
    }

    #[test]
    fn contact_sheet_averages_when_shrinking_and_draws_labels() {
        // A 1-pixel checkerboard shrunk 2x becomes mid-grey.
        let img: Vec<u8> = (0..8 * 8)
            .flat_map(|i| {
                if (i % 8 + i / 8) % 2 == 0 {
                    [255; 3]
                } else {
                    [1; 3]
                }
            })
            .collect();
        let tile = Tile {
            rgb24: &img,
            width: 8,
            height: 8,
            label: "",
        };
        let (w, _, sheet) = contact_sheet(&[tile], 1, 4).unwrap();
        let i = ((BORDER_PX * w + BORDER_PX) * 3) as usize;
        assert_eq!(sheet[i], 128);

        let grey = [128_u8; 3].repeat(64 * 32);
        let labelled = Tile {
            rgb24: &grey,
            width: 64,
            height: 32,
            label: "A7",
        };
        let (w, _, sheet) = contact_sheet(&[labelled], 1, 64).unwrap();
        let white = sheet
            .chunks_exact(3)
            .enumerate()
            .filter(|(_, px)| *px == [255, 255, 255])
            .map(|(i, _)| (i as u32 % w, i as u32 / w))
            .collect::<Vec<_>>();
        assert!(!white.is_empty());
        // All text pixels lie inside the label box at the tile's top-left.
        assert!(
            white
                .iter()
                .all(|&(x, y)| x < BORDER_PX + 14 && y < BORDER_PX + 9)
        );
    }

    /// The columns of `sheet` (`w` wide) that hold label text (white pixels).
    fn text_columns(sheet: &[u8], w: u32) -> Vec<u32> {
        let mut xs: Vec<u32> = sheet
            .chunks_exact(3)
            .enumerate()
            .filter(|(_, px)| *px == [255, 255, 255])
            .map(|(i, _)| i as u32 % w)
            .collect();
        xs.sort_unstable();
        xs.dedup();
        xs
    }

    #[test]
    fn long_labels_shrink_then_shorten_instead_of_running_off_the_tile() {
        let grey = [128_u8; 3].repeat(320 * 240);
        let sheet_of = |label: &str, tile_width: u32| {
            let tile = Tile {
                rgb24: &grey,
                width: 320,
                height: 240,
                label,
            };
            contact_sheet(&[tile], 1, tile_width).unwrap()
        };
        // 17 characters: 202 px at the doubled size, too wide for a 200 px tile; 101 px at
        // the font's own size, which fits, so the whole label is drawn small.
        let label = "MIDNIGHT OLDER 84";
        let (w, _, sheet) = sheet_of(label, 200);
        let xs = text_columns(&sheet, w);
        let width = xs.last().unwrap() - xs.first().unwrap() + 1;
        assert!(width <= 101, "{width} px");
        // A short label keeps the doubled size.
        let (w, _, sheet) = sheet_of("DAWN", 200);
        let xs = text_columns(&sheet, w);
        assert!(xs.last().unwrap() - xs.first().unwrap() + 1 > 23 + 1);
        // In one sheet with the long label, the short one is drawn small too.
        let tiles: Vec<Tile<'_>> = ["DAWN", label]
            .into_iter()
            .map(|label| Tile {
                rgb24: &grey,
                width: 320,
                height: 240,
                label,
            })
            .collect();
        let (w, _, sheet) = contact_sheet(&tiles, 2, 200).unwrap();
        let xs = text_columns(&sheet, w);
        let first_tile: Vec<u32> = xs.into_iter().filter(|&x| x < BORDER_PX + 200).collect();
        assert_eq!(
            first_tile.last().unwrap() - first_tile.first().unwrap() + 1,
            23
        );
        // Too long even small: cut, with `..`, inside the tile.
        let long = "A".repeat(40);
        let (w, _, sheet) = sheet_of(&long, 100);
        let xs = text_columns(&sheet, w);
        assert!(*xs.last().unwrap() < BORDER_PX + 100 - 1, "{xs:?}");
        assert_eq!(
            shortened(&long, |t| t.len() <= 10),
            format!("{}..", "A".repeat(8))
        );
        assert_eq!(shortened("ABC", |t| t.len() <= 1), "..");
    }

    #[test]
    fn contact_sheet_rejects_bad_tiles() {
        let tile = Tile {
            rgb24: &[0; 5],
            width: 2,
            height: 2,
            label: "",
        };
        assert!(contact_sheet(&[tile], 1, 10).is_err());
        assert!(contact_sheet(&[], 0, 10).is_err());
        assert_eq!(contact_sheet(&[], 3, 10).unwrap(), (0, 0, Vec::new()));
    }
}
